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
//! media to a surface carries their transmittance. Emitting media send photons too
//! (`light::media_emit`): their first hits are not stored either, since the visible point's
//! next ray (`e`, the whole BSDF) sees a medium's emission along it. The subsurface part of a visible
//! point's material is path traced; its BSDF part reads the photons. Not handled: the world light, the pixel filter (one sample at
//! a filter-distributed offset per pixel and iteration, so the filter is applied), AOVs
//! other than those of the first hit.
//!
//! Shadow catchers (`sppm_catcher.rs`): the camera pass splits at a catcher as the path
//! tracer's; the catcher pass is path traced from the split, and a second τ keeps the flux
//! that paths which did not split gathered, for the matte.
//!
//! Chunks (`--sample-offset N`): iterations take sample indices and photon passes N, N+1, …,
//! but each chunk is a whole SPPM run of its own (radii start again; the per-pixel state
//! of earlier iterations is not carried over): chunks are independent consistent
//! estimates, and `caustic merge` averages them weighted by their iterations. This
//! reduces the variance, not the bias of the first iterations' larger radii, and is not
//! bit for bit a single run of all the iterations (which the path tracer, BDPT and Jensen
//! photon mapping give). A chunk (`keep_sums`) returns its sums as a film: its image's means
//! times the iterations (the light passes and groups too, `sppm_passes::into_film`) and the
//! side film's exact sums of the camera ray's passes (`sppm_extras.rs`).

use super::kdtree::KnnResult;
use super::lobes::Split;
use super::sppm_catcher::{CatcherSample, CatcherSums};
use super::sppm_passes::{GatherSplit, SplitSums};
use super::trace::{MapKind, TraceJob, trace_photons};
use super::{PhotonMap, PhotonSettings, default_sppm_photons};
use crate::bsdf::Bsdf;
use crate::film::{CameraSample, DEPTH_BACKGROUND, Film, FilmImage};
use crate::integrator::SceneContext;
use crate::integrator::catcher::Split as CatcherSplit;
use crate::integrator::light_passes::shares_at;
use crate::light::emit::Emitters;
use crate::math::{Frame, Rgb};
use crate::render::job::RayStats;
use crate::render::job::{Progress, RenderJob, RenderResult};
use crate::sampling::PixelSampler;
use crate::scene::camera::CameraRays;
use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;

mod camera;
use camera::{Flags, camera_path};
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
    /// Camera depth of the first iteration's hit (0: no iteration yet; -1: it hit nothing).
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
    /// The share of the sample a holdout took (`CameraSample::held`).
    held: f32,
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
        // The first iteration's depth, as Cycles' sample 0 (at the pixel centre); -1 marks a
        // first iteration that hit nothing, 0 a pixel no iteration has reached yet.
        if state.depth == 0.0 {
            state.depth = if self.depth > 0.0 { self.depth } else { -1.0 };
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
    /// The class shares of the camera path's first bounce, which the photon flux gathered
    /// at a later visible point is filed by (None at the first hit, and without passes).
    first: Option<(Rgb, Rgb)>,
}

/// Bytes of SPPM's per-pixel state (progressive sums, this iteration's visible point and
/// its pending camera sample; with light passes or groups, `split`, their camera sample and
/// sums too; with the shadow catcher's sums, `catcher`, its sample and sums), for the memory
/// budget.
pub fn bytes_per_pixel(split: bool, catcher: bool) -> u64 {
    let split = if split { std::mem::size_of::<CameraSample>() + std::mem::size_of::<SplitSums>() } else { 0 };
    let catcher = if catcher { std::mem::size_of::<CatcherSample>() + std::mem::size_of::<CatcherSums>() } else { 0 };
    (std::mem::size_of::<PixelState>()
        + std::mem::size_of::<Option<VisiblePoint>>()
        + std::mem::size_of::<Pending>()
        + split
        + catcher) as u64
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
    /// Return the image's sums as a film (`RenderResult::film`) for a chunk (`--chunk`).
    pub keep_sums: bool,
    /// Film → Transparent Glass's roughness threshold (the path tracer's rule).
    pub glass_threshold: Option<f32>,
}

impl SppmIntegrator {
    /// SPPM with the given settings.
    pub fn new(max_depth: u32, settings: PhotonSettings, transparent_background: bool) -> Self {
        SppmIntegrator { max_depth, settings, transparent_background, keep_sums: false, glass_threshold: None }
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
        let (mut r, st) = render(ctx, camera, job, self, stop, on_progress);
        r.integrator_stats = Some(serde_json::json!({
            "sppm": st,
            "photons_per_sec": st.photons as f64 / st.photon_seconds.max(1e-9),
        }));
        r
    }
}

/// Renders the job's window with SPPM (see [`SppmIntegrator::render`]).
fn render(
    ctx: &SceneContext,
    camera: &CameraRays,
    job: &RenderJob,
    sppm: &SppmIntegrator,
    stop: &AtomicBool,
    on_progress: &(dyn Fn(&Progress) + Sync),
) -> (RenderResult, SppmStats) {
    let (max_depth, settings, transparent_background) = (sppm.max_depth, &sppm.settings, sppm.transparent_background);
    let [x0, y0, x1, y1] = job.window;
    let (w, h) = (x1 - x0, y1 - y0);
    let npix = (w * h) as usize;
    let start = Instant::now();
    let deadline = job.time_limit.map(|t| start + t);
    let iterations = settings.sppm_iterations.max(1);
    let per_iter = settings.sppm_photons.unwrap_or_else(|| default_sppm_photons(npix as u64)).max(1);
    let (_, scene_r) = ctx.scene.bounding_sphere();
    let emitters = Emitters::new(ctx.scene).with_media(ctx.scene);
    let mut states = vec![PixelState::default(); npix];
    let mut vps: Vec<Option<VisiblePoint>> = vec![None; npix];
    let mut pending = vec![Pending::default(); npix];
    // Light passes and groups (`sppm_passes`): per-pixel camera samples and sums when asked;
    // otherwise one scratch sample and no sums per row (chunks of one).
    let passes = job.passes.any_light();
    let grouping = job.passes.light_groups() > 0;
    let split_on = passes || grouping;
    let (row_len, per_row) = if split_on { (npix, w as usize) } else { (h as usize, 1) };
    let mut samples = vec![CameraSample::default(); row_len];
    let mut sums = vec![SplitSums::default(); if split_on { npix } else { h as usize }];
    // The shadow catcher's sums (`sppm_catcher`), kept as the film keeps them: per pixel when
    // kept, one placeholder per row otherwise (so that the rows still zip).
    let catch_on = super::sppm_catcher::wanted(job.passes);
    let (catch_len, catch_row) = if catch_on { (npix, w as usize) } else { (h as usize, 1) };
    let mut catch_samples = vec![CatcherSample::default(); catch_len];
    let mut catch_sums = vec![CatcherSums::default(); catch_len];
    let continuation =
        crate::integrator::path::PathIntegrator { max_depth, transparent_background, ..Default::default() };
    let mut rays = RayStats::default();
    let mut st = SppmStats::default();
    let rays_done = AtomicU64::new(0);
    let mut nan = 0u64;
    let alpha = settings.sppm_alpha;
    let shutter = ctx.scene.motion.as_ref().and_then(|m| m.shutter).filter(|_| ctx.blurs_motion);
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
            .zip(samples.par_chunks_mut(per_row))
            .zip(catch_samples.par_chunks_mut(catch_row))
            .enumerate()
            .map(|(row, ((((srow, vrow), prow), crow), cat_row))| {
                let mut rs = RayStats::default();
                let mut bad = 0u64;
                if should_stop(it) {
                    return (rs, bad);
                }
                let py = y0 + row as u32;
                for (i, ((state, vp), pend)) in srow.iter().zip(vrow.iter_mut()).zip(prow.iter_mut()).enumerate() {
                    let px = x0 + i as u32;
                    let mut sampler = PixelSampler::new(job.seed, px, py, job.sample_offset + it);
                    let off = job.filter.camera_offset(job.sample_offset + it, sampler.next_2d());
                    let (fx, fy) = (px as f32 + 0.5 + off.x, py as f32 + 0.5 + off.y);
                    let u_lens = if camera.has_lens() { sampler.next_2d() } else { Vec2::ZERO };
                    // Motion blur: the visible point at the sample's time, drawn as the path
                    // tracer draws it; the photons fly at times over the shutter (`trace`).
                    let time = shutter.map(|s| s.time(sampler.next_2d().x, py, job.height));
                    let ray = camera.sample_clipped_at(fx, fy, u_lens, time);
                    let _time = crate::motion::TimeScope::enter(time);
                    let (org, dir) = (ray.org, ray.dir);
                    *pend = Pending::default();
                    let out = &mut crow[if split_on { i } else { 0 }];
                    if split_on {
                        *out = CameraSample::default();
                    }
                    let flags = Flags { transparent_background, passes, grouping, glass: sppm.glass_threshold };
                    let mut caught = CatcherSplit::new(catch_on && ctx.catcher.is_some());
                    let (ld, point, first_t) =
                        camera_path(ctx, &ray, &mut sampler, max_depth, pend, camera, &mut rs, flags, out, &mut caught);
                    pend.ld = ld;
                    if !transparent_background {
                        // An opaque film: the world counts as seen (`CameraSample::make_opaque`).
                        pend.alpha = 1.0 - pend.held;
                    }
                    if !ld.is_finite() {
                        pend.bad = true;
                        bad += 1;
                    }
                    if catch_on {
                        cat_row[i] = super::sppm_catcher::sample(
                            ctx,
                            &caught,
                            ld,
                            pend.bad,
                            &continuation,
                            &mut sampler,
                            &mut rs,
                        );
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
        let (photons, groups, ts) = trace_photons(
            ctx,
            &emitters,
            &TraceJob {
                kind: MapKind::Global,
                count: per_iter,
                seed: job.seed,
                pass: job.sample_offset + it + 1,
                max_depth,
                skip_direct: true,
                light_groups: grouping,
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
        let map = if grouping { PhotonMap::build_grouped(photons, groups) } else { PhotonMap::build(photons) };
        st.photon_seconds += t_ph.elapsed().as_secs_f64();
        st.photons += ts.emitted;
        nan += nan_here;
        // 3. Gather and update.
        // Not interruptible: from here on the iteration counts, for every pixel.
        states
            .par_chunks_mut(w as usize)
            .zip(vps.par_chunks(w as usize))
            .zip(pending.par_chunks(w as usize))
            .zip(samples.par_chunks(per_row))
            .zip(sums.par_chunks_mut(per_row))
            .zip(catch_samples.par_chunks(catch_row))
            .zip(catch_sums.par_chunks_mut(catch_row))
            .for_each(|((((((srow, vrow), prow), crow), sumrow), cat_row), cat_sums)| {
                for (i, ((state, vp), pend)) in srow.iter_mut().zip(vrow).zip(prow).enumerate() {
                    let first = state.r == 0.0;
                    pend.apply(state);
                    let mut sum = split_on.then(|| &mut sumrow[i]);
                    if let Some(sum) = sum.as_deref_mut()
                        && !pend.bad
                    {
                        sum.add_sample(&crow[i]);
                    }
                    if catch_on {
                        cat_sums[i].add_sample(&cat_row[i]);
                    }
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
                    // The split (when asked): at the first hit by each photon's direction,
                    // later by the first bounce's shares (every share then the same).
                    let mut gs = GatherSplit::default();
                    let later = vp.first.unwrap_or((Rgb::ZERO, Rgb::ZERO));
                    map.for_each_within(vp.p, r2, |ph, idx, _| {
                        if ph.depth() <= jmax && ph.normal_within_60(vp.ng) {
                            let wi = vp.frame.to_local(ph.wi());
                            // Through the classes the photon's kinds allow (`visibility.rs`).
                            let c = super::visibility::map_weight(vp.split, &at, vp.wo_local.z, wi, ph.kinds())
                                * ph.power();
                            phi += c;
                            m += 1;
                            if split_on {
                                let sh = if passes && vp.d == 1 { shares_at(&at, wi) } else { later };
                                gs.add(c, sh, map.group(idx));
                            }
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
                    if let Some(sum) = sum {
                        sum.add_gather(vp.beta, &gs, ratio);
                    }
                    if catch_on {
                        cat_sums[i].add_gather(&cat_row[i], contrib, ratio);
                    }
                    state.n = n_new;
                    state.r = r_new;
                }
            });
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
    let mut image = image(&states, w, h, st.iterations);
    let area = |i: usize| {
        let r = states[i].r as f64;
        (r > 0.0).then_some(std::f64::consts::PI * r * r)
    };
    if split_on {
        super::sppm_passes::write(&mut image, job.passes, &sums, st.iterations, area);
    }
    // The passes of the camera ray alone, over the completed iterations.
    let side = super::sppm_extras::fill(ctx, camera, job, st.iterations, &mut image, &mut rays);
    if catch_on {
        super::sppm_catcher::write(&mut image, job.passes, &catch_sums, st.iterations, area);
    }
    // A chunk's sums: the side film's exact ones, and the means times the iterations of
    // what SPPM reduces per pixel (Combined, the light passes and groups).
    let film = sppm.keep_sums.then(|| {
        let mut film = side.unwrap_or_else(|| Film::with_passes(w, h, crate::render::job::TILE_SIZE, job.passes));
        crate::chunk::set_means(&mut film, &image);
        if split_on {
            super::sppm_passes::into_film(&mut film, job.passes, &sums, st.iterations, area);
        }
        if catch_on {
            super::sppm_catcher::into_film(&mut film, &catch_sums, st.iterations, area);
        }
        film
    });
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
            film,
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
