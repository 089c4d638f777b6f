//! Stochastic progressive photon mapping (Hachisuka & Jensen 2009), with its own
//! iteration driver. Each iteration:
//!
//! 1. **Visible points**: one camera sample per pixel (Owen-scrambled Sobol, sample index
//!    = iteration) follows glossy and specular bounces (`lobes.rs`: glossy below the
//!    roughness threshold) to the first vertex with a diffuse-like part; emission on the
//!    way and direct light (NEE with MIS at every non-delta vertex, the visible point's
//!    BSDF-sampled ray finding emission even where it carries nothing on) are accumulated. The
//!    photons are gathered through the visible point's diffuse-like part only; its
//!    glossy part is path traced from there (up to the maximum depth), so a glossy
//!    surface shows a path-traced reflection instead of a blurred, noisy photon estimate.
//! 2. **Photon pass**: `photons per iteration` photons are traced (first hits are not
//!    stored: direct light came from NEE) and put in a kd-tree.
//! 3. **Gather**: each pixel sums f(wo, wp) Φp over the photons within its radius r
//!    (normal within 60°, path length within the maximum depth), M photons, and updates
//!    N' = N + αM, r' = r √(N'/(N + M)), τ' = (τ + β Σ f Φ) r'²/r².
//!
//! Pixel value: L = mean(direct) + τ / (I π r²) after I iterations (photon powers are
//! already divided by the photons per iteration). r → 0 and N → ∞ as iterations grow,
//! so the estimate is consistent: error → 0 with iterations.
//!
//! Memory: per-pixel state (~160 bytes) plus one iteration's photons (32 bytes each;
//! two per pixel by default), so it is bounded by the image, never by the total
//! photon count.
//!
//! Parameters (defaults in `PhotonSettings`): iterations 64; photons per iteration = the
//! window's pixel count × `SPPM_PHOTONS_PER_PIXEL` (2); α = 2/3; initial radius per pixel = `SPPM_RADIUS_FOOTPRINTS` (3) pixel footprints at the
//! visible point (the distance between adjacent pixels' camera rays there), widened to
//! reach the k nearest photons (Jensen's k, 20) of the pixel's first photon pass
//! (`photon_radius`), clamped to [10⁻⁴, 5·10⁻²] × the scene's bounding radius, or
//! `--sppm-radius` for every pixel.
//! Media: photons scatter in media (`trace.rs`); a camera path that scatters in a
//! medium is path traced from there (no volume photon map), one that passes through
//! media to a surface carries their transmittance. The subsurface part of a visible
//! point's material is path traced; its BSDF part reads the photons. Not handled: the world light, the pixel filter (one sample at
//! a filter-distributed offset per pixel and iteration, so the filter is applied), AOVs
//! other than those of the first hit.
//!
//! Chunks (`--sample-offset N`): iterations take sample indices and photon passes N, N+1, …,
//! but each chunk is a whole SPPM run of its own (radii start again; the per-pixel state
//! of earlier iterations is not carried over): chunks are independent consistent
//! estimates, and `caustic merge` averages them weighted by their iterations. This
//! reduces the variance, not the bias of the first iterations' larger radii, and is not
//! bit for bit a single run of all the iterations (which the path tracer, BDPT and Jensen
//! photon mapping give).

use super::kdtree::KnnResult;
use super::lobes::Split;
use super::trace::{MapKind, TraceJob, trace_photons};
use super::{PhotonMap, PhotonSettings, default_sppm_photons};
use crate::bsdf::Bsdf;
use crate::film::{DEPTH_BACKGROUND, FilmImage};
use crate::integrator::SceneContext;
use crate::integrator::nee::surface_nee;
use crate::integrator::path::PathIntegrator;
use crate::integrator::walk::{PathState, Step};
use crate::light::emit::Emitters;
use crate::math::{Frame, Rgb, offset_ray_origin};
use crate::render::job::RayStats;
use crate::render::job::{Progress, RenderJob, RenderResult};
use crate::sampling::PixelSampler;
use crate::scene::camera::CameraRay;
use crate::scene::camera::CameraRays;
use crate::scene::visibility::RayMask;
use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

/// The automatic initial radius in pixel footprints at the visible point. A larger
/// radius gathers more photons (less noise) and blurs more (bias, until it shrinks):
/// equal time (bench/integrators.py, 15 s, 160x120, 3 seeds), SPPM/path relMSE for
/// 2 / 3 / 4 / 6 footprints was 1.26 / 0.84 / 0.80 / 0.83 on the Cornell box and
/// 0.071 / 0.087 / 0.132 / 0.289 on the glass caustic scene; 3 keeps both well inside
/// the targets (≤ 1.2 and ≤ 0.2).
const SPPM_RADIUS_FOOTPRINTS: f32 = 3.0;

/// Per-pixel progressive state.
#[derive(Clone, Copy, Debug, Default)]
struct PixelState {
    /// Σ over iterations of emission + direct light.
    ld: DVec3,
    /// Accumulated, radius-scaled photon flux.
    tau: DVec3,
    /// Accumulated photon count N.
    n: f64,
    /// Current radius (0: not yet set).
    r: f32,
    alpha: f64,
    depth: f32,
    normal: Vec3,
    albedo: Vec3,
}

/// What this iteration's camera pass adds to a pixel's state; applied only when the whole
/// iteration (camera pass, photon pass) finished, so an interrupted iteration leaves no trace.
#[derive(Clone, Copy, Debug, Default)]
struct Pending {
    /// Emission and direct light of this camera sample.
    ld: Vec3,
    /// Coverage of this sample (0 or 1, plus crossed emitters as in `PixelState::alpha`).
    alpha: f32,
    /// Camera depth of the first hit (0: none).
    depth: f32,
    normal: Vec3,
    albedo: Vec3,
    /// The initial radius, when this is the pixel's first visible point (0: none).
    r_init: f32,
    /// The sample's radiance was not finite (counted, not added).
    bad: bool,
}

impl Pending {
    /// Adds this sample to the pixel's progressive state.
    fn apply(&self, state: &mut PixelState) {
        if !self.bad {
            state.ld += self.ld.as_dvec3();
        }
        state.alpha += self.alpha as f64;
        if self.depth > 0.0 && (state.depth == 0.0 || self.depth < state.depth) {
            state.depth = self.depth;
        }
        state.normal += self.normal;
        state.albedo += self.albedo;
        if state.r == 0.0 && self.r_init > 0.0 {
            state.r = self.r_init;
        }
    }
}

/// This iteration's visible point.
#[derive(Clone, Copy, Debug)]
struct VisiblePoint {
    p: Vec3,
    ng: Vec3,
    frame: Frame,
    bsdf: Bsdf,
    wo_local: Vec3,
    /// Which part of the BSDF the photons stand for.
    split: Split,
    beta: Rgb,
    /// Scattering event index of the visible point on the camera path.
    d: u32,
}

/// Bytes of SPPM's per-pixel state (progressive sums, this iteration's visible point and
/// its pending camera sample), for the memory budget.
pub fn bytes_per_pixel() -> u64 {
    (std::mem::size_of::<PixelState>() + std::mem::size_of::<Option<VisiblePoint>>() + std::mem::size_of::<Pending>())
        as u64
}

/// Counters of an SPPM render.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct SppmStats {
    /// Iterations completed.
    pub iterations: u32,
    /// Photons emitted in all.
    pub photons: u64,
    /// Seconds spent tracing photons and building trees.
    pub photon_seconds: f64,
}

/// SPPM's parameters.
#[derive(Clone, Debug)]
pub struct SppmIntegrator {
    /// Maximum scattering events per path.
    pub max_depth: u32,
    /// Photon-mapping settings (iterations, photons per iteration, radius, α).
    pub settings: PhotonSettings,
    /// Camera rays that miss show nothing (Film → Transparent), as in the path tracer.
    pub transparent_background: bool,
}

impl SppmIntegrator {
    /// SPPM with the given settings.
    pub fn new(max_depth: u32, settings: PhotonSettings, transparent_background: bool) -> Self {
        SppmIntegrator { max_depth, settings, transparent_background }
    }

    /// Parameters, for logs and the summary.
    pub fn describe(&self) -> String {
        let p = &self.settings;
        format!(
            "sppm ({} iterations, {} photons per iteration, initial radius {}, alpha {:.3}, max depth {})",
            p.sppm_iterations,
            p.sppm_photons.map_or(format!("{} per pixel", super::SPPM_PHOTONS_PER_PIXEL), |n| n.to_string()),
            p.sppm_radius.map_or(format!("3 pixel footprints or {} photons", p.k), |r| r.to_string()),
            p.sppm_alpha,
            self.max_depth
        )
    }

    /// Renders the job's window. `job.spp` is ignored: the iteration count comes from the
    /// settings (one camera sample per pixel per iteration). The result's
    /// `integrator_stats` holds SPPM's counters.
    pub fn render(
        &self,
        ctx: &SceneContext,
        camera: &CameraRays,
        job: &RenderJob,
        stop: &AtomicBool,
        on_progress: &(dyn Fn(&Progress) + Sync),
    ) -> RenderResult {
        let (mut r, st) =
            render(ctx, camera, job, self.max_depth, &self.settings, self.transparent_background, stop, on_progress);
        // The passes of the camera ray alone, over the completed iterations.
        super::sppm_extras::fill(ctx, camera, job, st.iterations, &mut r.image, &mut r.rays);
        r.integrator_stats = Some(serde_json::json!({
            "sppm": st,
            "photons_per_sec": st.photons as f64 / st.photon_seconds.max(1e-9),
        }));
        r
    }
}

/// Renders the job's window with SPPM (see [`SppmIntegrator::render`]).
#[allow(clippy::too_many_arguments)]
fn render(
    ctx: &SceneContext,
    camera: &CameraRays,
    job: &RenderJob,
    max_depth: u32,
    settings: &PhotonSettings,
    transparent_background: bool,
    stop: &AtomicBool,
    on_progress: &(dyn Fn(&Progress) + Sync),
) -> (RenderResult, SppmStats) {
    let [x0, y0, x1, y1] = job.window;
    let (w, h) = (x1 - x0, y1 - y0);
    let npix = (w * h) as usize;
    let start = Instant::now();
    let deadline = job.time_limit.map(|t| start + t);
    let iterations = settings.sppm_iterations.max(1);
    let per_iter = settings.sppm_photons.unwrap_or_else(|| default_sppm_photons(npix as u64)).max(1);
    let (_, scene_r) = ctx.scene.bounding_sphere();
    let emitters = Emitters::new(ctx.scene);
    let mut states = vec![PixelState::default(); npix];
    let mut vps: Vec<Option<VisiblePoint>> = vec![None; npix];
    let mut pending = vec![Pending::default(); npix];
    let mut rays = RayStats::default();
    let mut st = SppmStats::default();
    let rays_done = AtomicU64::new(0);
    let mut nan = 0u64;
    let alpha = settings.sppm_alpha;
    // The automatic radius's upper bound (the footprint rule's clamp).
    let r_max = 5e-2 * scene_r;
    // An iteration stops early on a signal, or when the time limit passes during any but the
    // first iteration (so a time limit always gives an image); it is then discarded whole,
    // so every pixel keeps the same number of complete iterations. Without this a large image
    // overran a time limit or a cancel by a whole iteration (8 s at 1920x1080 on 2 cores for
    // the Cornell box, beyond the add-on's 15 s grace at 4K).
    let abort = AtomicBool::new(false);
    let should_stop = |it: u32| {
        let s = stop.load(Ordering::Relaxed) || (it > 0 && deadline.is_some_and(|d| Instant::now() >= d));
        if s {
            abort.store(true, Ordering::Relaxed);
        }
        s
    };
    for it in 0..iterations {
        if stop.load(Ordering::Relaxed) || deadline.is_some_and(|d| Instant::now() >= d) {
            break;
        }
        // 1. Visible points and direct light.
        let row_stats: Vec<(RayStats, u64)> = states
            .par_chunks(w as usize)
            .zip(vps.par_chunks_mut(w as usize))
            .zip(pending.par_chunks_mut(w as usize))
            .enumerate()
            .map(|(row, ((srow, vrow), prow))| {
                let mut rs = RayStats::default();
                let mut bad = 0u64;
                if should_stop(it) {
                    return (rs, bad);
                }
                let py = y0 + row as u32;
                for (i, ((state, vp), pend)) in srow.iter().zip(vrow.iter_mut()).zip(prow.iter_mut()).enumerate() {
                    let px = x0 + i as u32;
                    let mut sampler = PixelSampler::new(job.seed, px, py, job.sample_offset + it);
                    let off = job.filter.sample(sampler.next_2d());
                    let (fx, fy) = (px as f32 + 0.5 + off.x, py as f32 + 0.5 + off.y);
                    let u_lens = if camera.has_lens() { sampler.next_2d() } else { Vec2::ZERO };
                    let ray = camera.sample_clipped(fx, fy, u_lens);
                    let (org, dir) = (ray.org, ray.dir);
                    *pend = Pending::default();
                    let (ld, point, first_t) =
                        camera_path(ctx, &ray, &mut sampler, max_depth, pend, camera, &mut rs, transparent_background);
                    pend.ld = ld;
                    if !ld.is_finite() {
                        pend.bad = true;
                        bad += 1;
                    }
                    *vp = point;
                    if state.r == 0.0 && first_t.is_finite() {
                        pend.r_init = settings.sppm_radius.unwrap_or_else(|| {
                            let (o2, d2) = camera.sample_ray(fx + 1.0, fy, u_lens);
                            // first_t is counted from the near clipping plane.
                            let t = first_t + ray.near;
                            let fp = ((o2 + d2 * t) - (org + dir * t)).length();
                            (SPPM_RADIUS_FOOTPRINTS * fp).clamp(1e-4 * scene_r, r_max)
                        });
                    }
                }
                (rs, bad)
            })
            .collect();
        let mut nan_here = 0;
        for (r, b) in &row_stats {
            rays.add(r);
            nan_here += b;
        }
        if abort.load(Ordering::Relaxed) {
            break;
        }
        // 2. Photons (the same rule: a signal or the deadline abandons the iteration).
        let t_ph = Instant::now();
        let (photons, _, ts) = trace_photons(
            ctx,
            &emitters,
            &TraceJob {
                kind: MapKind::Global,
                count: per_iter,
                seed: job.seed,
                pass: job.sample_offset + it + 1,
                max_depth,
                skip_direct: true,
                light_groups: false,
            },
            &abort,
            &|_| {
                should_stop(it);
            },
        );
        if should_stop(it) {
            st.photon_seconds += t_ph.elapsed().as_secs_f64();
            break;
        }
        let map = PhotonMap::build(photons);
        st.photon_seconds += t_ph.elapsed().as_secs_f64();
        st.photons += ts.emitted;
        nan += nan_here;
        // 3. Gather and update.
        // Not interruptible: from here on the iteration counts, for every pixel.
        states.par_chunks_mut(w as usize).zip(vps.par_chunks(w as usize)).zip(pending.par_chunks(w as usize)).for_each(
            |((srow, vrow), prow)| {
                for ((state, vp), pend) in srow.iter_mut().zip(vrow).zip(prow) {
                    let first = state.r == 0.0;
                    pend.apply(state);
                    let Some(vp) = vp else { continue };
                    if !(state.r > 0.0) {
                        continue;
                    }
                    let jmax = max_depth + 1 - vp.d;
                    if first && settings.sppm_radius.is_none() {
                        state.r = photon_radius(&map, vp, jmax, state.r, r_max, settings.k);
                    }
                    let r2 = state.r * state.r;
                    let mut phi = Rgb::ZERO;
                    let mut m = 0u32;
                    let at = vp.bsdf.at(vp.wo_local);
                    map.for_each_within(vp.p, r2, |ph, _| {
                        if ph.depth() <= jmax && ph.normal_within_60(vp.ng) {
                            let wi = vp.frame.to_local(ph.wi());
                            phi += vp.split.diffuse(&at, wi) * ph.power();
                            m += 1;
                        }
                    });
                    if m == 0 {
                        continue;
                    }
                    let contrib = vp.beta * phi;
                    if !contrib.is_finite() {
                        continue;
                    }
                    let n_new = state.n + alpha as f64 * m as f64;
                    let ratio = n_new / (state.n + m as f64);
                    let r_new = state.r * (ratio as f32).sqrt();
                    state.tau = (state.tau + contrib.as_dvec3()) * ratio;
                    state.n = n_new;
                    state.r = r_new;
                }
            },
        );
        st.iterations = it + 1;
        rays_done.store(rays.total(), Ordering::Relaxed);
        let elapsed = start.elapsed().as_secs_f64();
        let fraction = (it + 1) as f64 / iterations as f64;
        on_progress(&Progress {
            fraction,
            samples_done: it + 1,
            samples_total: Some(iterations),
            elapsed,
            eta: Some(elapsed * (1.0 - fraction) / fraction),
            rays_per_sec: rays.total() as f64 / elapsed.max(1e-6),
        });
    }
    let image = image(&states, w, h, st.iterations);
    (
        RenderResult {
            image,
            rays,
            nan_samples: nan,
            spp_min: st.iterations,
            spp_max: st.iterations,
            adaptive_active: None,
            interrupted: stop.load(Ordering::Relaxed),
            elapsed: start.elapsed(),
            light_paths: 0,
            splats: 0,
            integrator_stats: None,
            film: None,
        },
        st,
    )
}

/// A pixel's initial radius: its footprint radius `r_fp`, widened to reach the `k`
/// nearest photons of its first photon pass that it could gather (up to `r_max`). Where
/// photons are dense the footprint rule stands; where they are sparse (an environment
/// map's photons spread over a whole floor's bounding disc, of which few bounce onto the
/// object in view) a footprint's disc held about one photon per iteration, and the
/// estimate stayed that noisy while the radius, which shrinks only as photons arrive,
/// hardly moved. k is Jensen's k (the same density estimate's count).
fn photon_radius(map: &PhotonMap, vp: &VisiblePoint, jmax: u32, r_fp: f32, r_max: f32, k: usize) -> f32 {
    if r_fp >= r_max {
        return r_fp;
    }
    let mut near = KnnResult::new(k);
    map.knn(vp.p, r_max * r_max, |ph| ph.depth() <= jmax && ph.normal_within_60(vp.ng), &mut near);
    let r_k = if near.full() { near.max_d2().sqrt() } else { r_max };
    r_fp.max(r_k)
}

/// The image after `iters` iterations.
fn image(states: &[PixelState], w: u32, h: u32, iters: u32) -> FilmImage {
    let n = states.len();
    let mut img = FilmImage {
        width: w,
        height: h,
        combined: vec![[0.0; 4]; n],
        depth: vec![DEPTH_BACKGROUND; n],
        normal: vec![[0.0; 3]; n],
        albedo: vec![[0.0; 3]; n],
        samples: vec![iters; n],
        noisy: Vec::new(),
        passes: crate::passes::PassSet::legacy(),
        ..Default::default()
    };
    if iters == 0 {
        return img;
    }
    let inv = 1.0 / iters as f64;
    for (i, s) in states.iter().enumerate() {
        let mut c = s.ld * inv;
        if s.r > 0.0 {
            c += s.tau * inv / (std::f64::consts::PI * (s.r as f64) * (s.r as f64));
        }
        img.combined[i] = [c.x as f32, c.y as f32, c.z as f32, (s.alpha * inv) as f32];
        if s.depth.is_finite() && s.depth > 0.0 {
            img.depth[i] = s.depth;
        }
        img.normal[i] = (s.normal * inv as f32).to_array();
        img.albedo[i] = (s.albedo * inv as f32).to_array();
    }
    img
}

/// Follows a camera ray through glossy and specular bounces to its visible point, the
/// first vertex with a diffuse-like part (`lobes.rs`), where the photons will be gathered
/// through that part; the glossy part there and everything after it is path traced
/// (NEE with MIS at every non-delta vertex, the BSDF-sampled ray finding emission).
/// Returns the emission and direct light collected, the visible point, and the first hit
/// distance; the sample's coverage and first-hit passes go to `pend`.
#[allow(clippy::too_many_arguments)]
fn camera_path(
    ctx: &SceneContext,
    ray: &CameraRay,
    sampler: &mut PixelSampler,
    max_depth: u32,
    pend: &mut Pending,
    camera: &CameraRays,
    stats: &mut RayStats,
    transparent_background: bool,
) -> (Rgb, Option<VisiblePoint>, f32) {
    let mut l = Rgb::ZERO;
    let mut first_t = f32::INFINITY;
    stats.camera += 1;
    // A scattering event in a medium is path traced from that vertex on (media have no
    // photon map): NEE plus a continued path.
    let mut st = PathState::camera(ray, ctx.camera_media);
    let continuation = PathIntegrator { max_depth, transparent_background, ..Default::default() };
    // `beta` carries the path on; `e` weighs the emission the next ray finds (they differ
    // after the visible point, whose diffuse-like part the photons stand for but whose
    // direct light NEE and the next ray share by MIS through the whole BSDF).
    let mut beta = Rgb::ONE;
    let mut e = Rgb::ONE;
    let mut vp: Option<VisiblePoint> = None;
    // This sample's alpha is undone if the camera ray ends on a holdout.
    let alpha_before = pend.alpha;
    loop {
        let [u_light, u_lx, u_ly, u_lobe] = sampler.next_4d();
        let [u_dx, u_dy, u_rr, u_alpha] = sampler.next_4d();
        let [u_channel, u_dist, _, _] = if ctx.has_media { sampler.next_4d() } else { [0.0; 4] };
        // Along the ray with a unit throughput (the segment's weight then scales both).
        // Lights crossed and the world carry MIS against the NEE where the ray left (none
        // for the camera ray and after delta lobes: the state's pdf is 0).
        let mut medium_l = Rgb::ZERO;
        let mut crossed_any = false;
        st.beta = Rgb::ONE;
        let (step, crossed_l) = st.advance_with(
            ctx,
            Some([u_channel, u_dist]),
            || u_alpha,
            |st, t_event, w| {
                let (le, any) = ctx.crossed_emission(
                    st.org,
                    st.dir,
                    t_event,
                    st.prev_p,
                    st.prev_n,
                    st.prev_pdf,
                    st.depth == 0,
                    st.prev_tri,
                    &st.light_path,
                );
                crossed_any = any;
                if any { e * w * le } else { Rgb::ZERO }
            },
            &mut medium_l,
            stats,
        );
        l += crossed_l + e * medium_l;
        let seg = std::mem::replace(&mut st.beta, Rgb::ONE);
        beta *= seg;
        e *= seg;
        if crossed_any && st.depth == 0 {
            pend.alpha += 1.0;
        }
        let (hit, s) = match step {
            Step::End => break,
            Step::Passed => continue,
            Step::Medium { p, phase, .. } => {
                if st.depth == 0 {
                    pend.alpha += 1.0;
                }
                if st.depth < max_depth && beta.is_finite() && beta != Rgb::ZERO {
                    l +=
                        continuation.scatter_in_medium(ctx, p, st.dir, phase, st.media, beta, st.depth, sampler, stats);
                }
                break;
            }
            Step::Escaped => {
                if !(st.depth == 0 && transparent_background)
                    && let Some(le) = st.escaped_radiance(ctx)
                {
                    l += e * le;
                    if st.depth == 0 {
                        pend.alpha += 1.0;
                    }
                }
                break;
            }
            Step::Surface { hit, s } => (hit, s),
        };
        // A holdout seen by a camera ray: nothing, alpha 0 (as the path tracer).
        if st.depth == 0 && ctx.is_holdout(hit.tri) {
            pend.alpha = alpha_before;
            return (l, None, first_t);
        }
        let wo = -st.dir;
        let sp = ctx.shade(&s, wo);
        if st.depth == 0 {
            first_t = s.t;
            pend.alpha += 1.0;
            let z = camera.depth(s.p);
            pend.depth = z;
            pend.normal = sp.frame.n;
            pend.albedo = sp.bsdf.albedo();
        } else if first_t.is_infinite() {
            first_t = s.t;
        }
        l += PathState { beta: e, ..st }.surface_emission(ctx, &hit, &s, &sp);
        // The ray a diffuse-only visible point sent was for its emission alone (above).
        if st.depth >= max_depth || beta == Rgb::ZERO {
            break;
        }
        let wo_local = sp.frame.to_local(wo);
        // The subsurface part has no photon map: path traced (the BSDF part as below).
        if ctx.scene.materials[s.material as usize].subsurface.is_some() {
            let q = sp.bsdf.subsurface_weight(wo_local);
            if q > 0.0 {
                l += continuation.subsurface_from(ctx, &s, &sp, wo, st.media, beta * q, st.depth, sampler, stats);
            }
        }
        let at = sp.bsdf.at(wo_local);
        let split = Split::of(&sp.bsdf);
        let delta = sp.bsdf.is_delta();
        // The visible point: the first vertex with a diffuse-like part.
        let (diffuse, glossy) = if delta || vp.is_some() { (false, true) } else { split.parts(&at) };
        let is_vp = diffuse;
        if !delta {
            // Direct light (lights below count when the BSDF transmits: photons are
            // gathered on this side only), MIS against the next ray, which a visible point
            // with no glossy part sends too, for the emission it finds only: light
            // sampling alone left the broad sky of an environment map to the few world
            // samples its sun disc left over (floor blocks 3-4x the path tracer's error
            // on bench/run.py's hdri scene).
            let n_select = if sp.bsdf.transmits() { Vec3::ZERO } else { s.ng };
            l += surface_nee(ctx, &s, &sp, &at, n_select, 1.0, beta, st.media, u_light, Vec2::new(u_lx, u_ly), stats);
            if is_vp {
                vp = Some(VisiblePoint {
                    p: s.p,
                    ng: s.ng,
                    frame: sp.frame,
                    bsdf: sp.bsdf,
                    split,
                    wo_local,
                    beta,
                    d: st.depth + 1,
                });
            }
            st.prev_n = n_select;
        }
        // The next ray from the whole BSDF; at the visible point only its glossy share goes on.
        let Some(bs) = at.sample(u_lobe, Vec2::new(u_dx, u_dy)) else {
            break;
        };
        let wi = sp.frame.to_world(bs.wi);
        let (co, ci) = (wo.dot(s.ng), wi.dot(s.ng));
        if (bs.wi.z * wo_local.z > 0.0) != (co * ci > 0.0) || ci == 0.0 {
            break;
        }
        let w = bs.f * (bs.wi.z.abs() / bs.pdf);
        e = beta * w;
        beta = if is_vp && !glossy {
            Rgb::ZERO
        } else if is_vp {
            beta * (w - split.diffuse_of_sample(&at, bs.wi, bs.f, bs.delta) * (bs.wi.z.abs() / bs.pdf)).max(Rgb::ZERO)
        } else {
            e
        };
        if !(beta.is_finite() && e.is_finite()) || (beta == Rgb::ZERO && e == Rgb::ZERO) {
            break;
        }
        st.prev_pdf = if bs.delta { 0.0 } else { bs.pdf };
        st.prev_p = s.p;
        st.prev_tri = s.tri;
        st.depth += 1;
        st.media = ctx.medium_after(&s, wi, st.media);
        st.ray = RayMask::after_bounce(bs.kind, ci < 0.0);
        st.light_path = s.light_path.bounced(bs.kind, ci < 0.0, bs.delta);
        st.org = offset_ray_origin(s.p, if ci > 0.0 { s.ng } else { -s.ng });
        st.dir = wi;
        stats.bounce += 1;
        // Russian roulette after the visible point, as the path tracer's.
        if vp.is_some() && st.depth >= continuation.rr_depth {
            // Refraction keeps 1 − F of the throughput (Cycles' convention): no η scale.
            let q = beta.max_element().max(e.max_element()).min(0.95);
            if !(u_rr < q) {
                break;
            }
            beta /= q;
            e /= q;
        }
    }
    (l, vp, first_t)
}
