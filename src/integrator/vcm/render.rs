//! VCM's iteration driver: per iteration a light pass (subpaths, merge records, grid) and
//! a camera pass over the film's tiles (one sample per pixel), then the splats are added.
//! Stops on the sample count (iterations), the time limit or a signal, like the
//! progressive driver; an iteration's light pass is not interrupted once its camera pass
//! may need it, and the first iteration always completes so a time limit gives an image.

use super::light_store::RowSubpaths;
use super::merge::{MergeMap, MergeRecord, merge_camera_path, push_records};
use super::share::PilotSums;
use super::volume_merge::{self, VolumeMap, VolumeRecord};
use super::{VCM_ALPHA, VCM_RADIUS_FOOTPRINTS, VcmIntegrator, VcmMode};
use crate::film::{CameraSample, Film, SplatPool};
use crate::integrator::bdpt::{BdptScratch, FilmTarget, connection_sampler, light_sampler};
use crate::integrator::{SceneContext, data_passes};
use crate::math::{Rgb, hash_combine, luminance};
use crate::render::job::TILE_SIZE;
use crate::render::job::{Progress, RayStats, RenderJob, RenderResult};
use crate::sampling::PixelSampler;
use crate::scene::camera::{CameraRay, CameraRays};
use glam::Vec2;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Counters of a VCM render.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct VcmStats {
    /// Iterations completed (samples per pixel).
    pub iterations: u32,
    /// The initial merging radius.
    pub radius_initial: f32,
    /// The last iteration's radius.
    pub radius_final: f32,
    /// Light subpaths per camera sample (`share`).
    pub light_share: f32,
    /// Light vertices stored for merging, over all iterations.
    pub merge_records: u64,
    /// Light points stored in media for volume merging, over all iterations.
    pub volume_records: u64,
}

/// The automatic initial radius: `VCM_RADIUS_FOOTPRINTS` times the median pixel footprint
/// (the distance between neighbouring pixels' rays) at the first hits of a grid of up to
/// 32 × 32 pixels, clamped to [10⁻⁴, 5·10⁻²] × the scene's bounding radius (SPPM's bounds).
pub fn initial_radius(ctx: &SceneContext, camera: &CameraRays, window: [u32; 4]) -> f32 {
    let [x0, y0, x1, y1] = window;
    let (_, scene_r) = ctx.scene.bounding_sphere();
    let n = 32u32;
    let mut footprints = Vec::with_capacity((n * n) as usize);
    let lens = Vec2::splat(0.5);
    for j in 0..n {
        for i in 0..n {
            let fx = x0 as f32 + (i as f32 + 0.5) / n as f32 * (x1 - x0) as f32;
            let fy = y0 as f32 + (j as f32 + 0.5) / n as f32 * (y1 - y0) as f32;
            let (o, d) = camera.sample_ray(fx, fy, lens);
            let Some(hit) = ctx.intersect(o, d, f32::INFINITY) else { continue };
            let (o2, d2) = camera.sample_ray(fx + 1.0, fy, lens);
            footprints.push(((o2 + d2 * hit.t) - (o + d * hit.t)).length());
        }
    }
    let (lo, hi) = (1e-4 * scene_r, 5e-2 * scene_r);
    if footprints.is_empty() {
        return lo; // nothing in view to merge at
    }
    let mid = footprints.len() / 2;
    let (_, median, _) = footprints.select_nth_unstable_by(mid, f32::total_cmp);
    (VCM_RADIUS_FOOTPRINTS * *median).clamp(lo, hi)
}

/// Whether camera sample `index` of pixel (`px`, `py`) has a light subpath when a share
/// `share` of the camera samples have one: a stream of its own (independent of the light
/// and camera samples), Owen-scrambled Sobol over the sample index, so each pixel's light
/// subpaths are spread evenly over its samples.
#[inline]
fn has_light_subpath(seed: u32, px: u32, py: u32, index: u32, share: f32) -> bool {
    share >= 1.0 || PixelSampler::new(hash_combine(&[seed, 0x5348_4152]), px, py, index).next_4d()[0] < share
}

/// A camera sample's split between the camera side and the light subpath (the pilot's).
#[derive(Clone, Copy, Debug, Default)]
struct Parts {
    /// The connections' (s ≥ 2, t ≥ 2) weighted contribution.
    light: Rgb,
    /// Rays of the camera subpath and its light samples (s = 1).
    camera_rays: u64,
    /// Rays of the connections to the light subpath and of its splats (t = 1).
    light_rays: u64,
}

/// The pilot's sample index, which no image sample takes (a render's samples stop below
/// u32::MAX).
const PILOT_INDEX: u32 = u32::MAX - 1;

/// What every iteration of one render shares.
struct Setup<'a> {
    ctx: &'a SceneContext<'a>,
    camera: &'a CameraRays,
    job: &'a RenderJob,
    /// The shutter, when motion blurs.
    shutter: Option<crate::motion::Shutter>,
    /// Light subpaths can reach the camera (not orthographic).
    camera_connectible: bool,
}

/// One iteration's parameters.
#[derive(Clone, Copy, Debug)]
struct Pass {
    /// The sample index (the light and camera streams').
    index: u32,
    /// The merging radius.
    radius: f32,
    /// Light subpaths per camera sample.
    share: f32,
    /// 1, or 2 for the pilot: every `step`-th pixel of every `step`-th row.
    step: u32,
}

/// What one iteration reports.
#[derive(Debug, Default)]
struct IterationOut {
    rays: RayStats,
    /// Samples not added (not finite).
    bad: u64,
    /// Camera samples taken.
    done: u64,
    /// The time limit or a signal cut it short.
    interrupted: bool,
    /// The pilot's sums.
    pilot: PilotSums,
}

/// Per-row working memory of the light pass, kept across iterations.
struct LightRow {
    records: Vec<MergeRecord>,
    /// Its light points in media (`volume_merge`).
    volume: Vec<VolumeRecord>,
    /// The row's light subpaths, for its pixels' connections in the camera pass.
    subpaths: RowSubpaths,
    scratch: BdptScratch,
}

impl VcmIntegrator {
    /// BDPT's camera sample (`BdptIntegrator::li`) with the light subpath the light pass
    /// traced for this pixel (`light`: the row's subpaths and the pixel's index in it;
    /// `pixel_sample`: (seed, x, y, index), which seeds the connections' light samples).
    #[allow(clippy::too_many_arguments)]
    fn sample_stored(
        &self,
        ctx: &SceneContext,
        ray: &CameraRay,
        sampler: &mut PixelSampler,
        pixel_sample: (u32, u32, u32, u32),
        (row, i): (&RowSubpaths, usize),
        film: &mut FilmTarget,
        scratch: &mut BdptScratch,
        stats: &mut RayStats,
        parts: &mut Parts,
    ) -> CameraSample {
        let mut out = CameraSample { depth: f32::INFINITY, ..Default::default() };
        let mut radiance = Rgb::ZERO;
        let rays = stats.total();
        self.bdpt.camera_subpath(ctx, ray, sampler, film.camera, scratch, &mut out, &mut radiance, stats);
        let camera_rays = stats.total() - rays;
        row.restore(ctx, i, &mut scratch.light);
        let (seed, px, py, index) = pixel_sample;
        let mut cs = connection_sampler(seed, px, py, index);
        let (s1_rays, rays) = (scratch.tally.s1_rays, stats.total());
        scratch.tally.light = Rgb::ZERO;
        radiance += self.bdpt.connect_all(ctx, &mut cs, film, scratch, &mut out, stats);
        let s1_rays = scratch.tally.s1_rays - s1_rays;
        parts.light = scratch.tally.light;
        parts.camera_rays = camera_rays + s1_rays;
        parts.light_rays = stats.total() - rays - s1_rays;
        out.radiance = radiance;
        if !self.bdpt.transparent_background {
            out.make_opaque();
        }
        out
    }

    /// One iteration: the light pass (a light subpath for a share `pass.share` of the
    /// camera samples, merge records, grid), then the camera pass over the tiles, added to
    /// `film` (None: the pilot, whose samples are only summed for the share's rule).
    /// `over(i)`: stop now (the time limit or a signal).
    #[allow(clippy::too_many_arguments)]
    fn iteration(
        &self,
        setup: &Setup,
        pass: Pass,
        rows: &mut [LightRow],
        (map, volume_map): (&mut MergeMap, &mut VolumeMap),
        film: Option<&mut Film>,
        splats: &SplatPool,
        over: &(dyn Fn() -> bool + Sync),
    ) -> IterationOut {
        let Setup { ctx, camera, job, shutter, camera_connectible } = *setup;
        let [x0, y0, x1, y1] = job.window;
        let Pass { index, radius, share, step } = pass;
        let merging = self.mode == VcmMode::Full;
        let pilot = film.is_none();
        let on_lattice = |px: u32, py: u32| (px - x0).is_multiple_of(step) && (py - y0).is_multiple_of(step);
        // Light subpaths expected: the window's camera samples (the lattice's in the pilot).
        let cameras = (x1 - x0).div_ceil(step) as u64 * (y1 - y0).div_ceil(step) as u64;
        let mut out = IterationOut::default();
        // 1. Light pass: the subpaths the camera pass will connect to, stored for merging.
        if merging {
            let eta = share * (cameras as f32 * std::f32::consts::PI * radius * radius);
            let light_rays: Vec<RayStats> = rows
                .par_iter_mut()
                .enumerate()
                .map(|(row, lr)| {
                    let mut rs = RayStats::default();
                    lr.records.clear();
                    lr.volume.clear();
                    lr.subpaths.clear();
                    let py = y0 + row as u32;
                    for px in x0..x1 {
                        if !on_lattice(px, py) || !has_light_subpath(job.seed, px, py, index, share) {
                            lr.subpaths.push(&[]);
                            continue;
                        }
                        // The camera sample's time, drawn as the camera pass draws it.
                        let time = shutter.map(|s| {
                            let mut sampler = PixelSampler::new(job.seed, px, py, index);
                            sampler.next_2d();
                            if camera.has_lens() {
                                sampler.next_2d();
                            }
                            s.time(sampler.next_2d().x, py, job.height)
                        });
                        let _time = crate::motion::TimeScope::enter(time);
                        let mut ls = light_sampler(job.seed, px, py, index);
                        self.bdpt.light_subpath(ctx, &mut ls, &mut lr.scratch, &mut rs);
                        push_records(ctx.scene, &lr.scratch.light, (eta, share), &mut lr.records);
                        let salt = volume_merge::salt(job.seed, px, py, index);
                        volume_merge::deposit(ctx, &lr.scratch.volume_segments, salt, &mut lr.volume);
                        lr.subpaths.push(&lr.scratch.light);
                    }
                    rs
                })
                .collect();
            for r in &light_rays {
                out.rays.add(r);
                out.pilot.light_rays += r.total();
            }
            map.records.clear();
            for lr in rows.iter() {
                map.records.extend_from_slice(&lr.records);
            }
            map.build(radius, cameras, share);
            volume_map.records.clear();
            for lr in rows.iter() {
                volume_map.records.extend_from_slice(&lr.volume);
            }
            volume_map.build(radius, share * cameras as f32);
            if over() {
                out.interrupted = true;
                return out;
            }
        }
        // 2. Camera pass: BDPT's sample with merge-aware weights, then the merges.
        let eta = if merging { map.eta } else { 0.0 };
        let want_data = job.passes.any_data() && !pilot;
        let want_aovs = job.passes.shader_aov_channels() > 0 && !pilot;
        let max_depth = self.bdpt.max_depth;
        let cut = AtomicBool::new(false);
        let (map_ref, rows_ref, cut_ref) = (&*map, &*rows, &cut);
        let volume_ref = &*volume_map;
        // The pilot's tiles: a film's layout without its pixels.
        let mut pilot_tiles;
        let tiles = match film {
            Some(f) => &mut f.tiles,
            None => {
                pilot_tiles = Film::with_passes(x1 - x0, y1 - y0, TILE_SIZE, crate::passes::PassSet::default()).tiles;
                &mut pilot_tiles
            }
        };
        let tile_out: Vec<IterationOut> = tiles
            .par_iter_mut()
            .map(|tile| {
                let mut to = IterationOut::default();
                let mut scratch = BdptScratch::new(max_depth);
                scratch.dens.eta_vm = eta;
                scratch.dens.light_share = share;
                let mut buf = splats.take();
                'pixels: for ty in 0..tile.h {
                    for tx in 0..tile.w {
                        if over() {
                            cut_ref.store(true, Ordering::Relaxed);
                            break 'pixels;
                        }
                        let k = (ty * tile.w + tx) as usize;
                        let (px, py) = (x0 + tile.x0 + tx, y0 + tile.y0 + ty);
                        if !on_lattice(px, py) {
                            continue;
                        }
                        let mut sampler = PixelSampler::new(job.seed, px, py, index);
                        let off = job.filter.camera_offset(index, sampler.next_2d());
                        let u_lens = if camera.has_lens() { sampler.next_2d() } else { Vec2::ZERO };
                        let time = shutter.map(|s| s.time(sampler.next_2d().x, py, job.height));
                        let (fx, fy) = (px as f32 + 0.5 + off.x, py as f32 + 0.5 + off.y);
                        let ray = camera.sample_clipped_at(fx, fy, u_lens, time);
                        let _time = crate::motion::TimeScope::enter(time);
                        let mut target = FilmTarget { camera, filter: &job.filter, splats: &mut buf };
                        let pixel_sample = (job.seed, px, py, index);
                        let mut s = if ray.is_blind() && merging {
                            // Black and opaque, but its light subpath still splats (t = 1).
                            if camera.light_tracing_reaches() {
                                let row = &rows_ref[(py - y0) as usize].subpaths;
                                row.restore(ctx, (px - x0) as usize, &mut scratch.light);
                                self.bdpt.splat_blind(ctx, &ray, pixel_sample, &mut target, &mut scratch, &mut to.rays);
                            }
                            CameraSample::blind()
                        } else if ray.is_blind() {
                            self.bdpt.li_blind(ctx, &ray, pixel_sample, &mut target, &mut scratch, &mut to.rays)
                        } else if merging {
                            // The pixel's light subpath from the light pass, not traced again.
                            let row = &rows_ref[(py - y0) as usize].subpaths;
                            let light = (row, (px - x0) as usize);
                            let mut parts = Parts::default();
                            let mut s = self.sample_stored(
                                ctx,
                                &ray,
                                &mut sampler,
                                pixel_sample,
                                light,
                                &mut target,
                                &mut scratch,
                                &mut to.rays,
                                &mut parts,
                            );
                            let ledger = self.bdpt.ledger;
                            let passes = (ledger.any() && !pilot).then_some((ctx, ledger, scratch.first, &mut s));
                            let mut merged = merge_camera_path(
                                &scratch.cam,
                                map_ref,
                                camera_connectible,
                                max_depth,
                                &self.bdpt.light_paths,
                                passes,
                            );
                            if let Some(x) = *scratch.medium_vertex {
                                let passes = (ledger.any() && !pilot).then_some((ctx, ledger, &mut s));
                                merged += volume_ref.merge(&x, max_depth, passes);
                            }
                            s.radiance += merged;
                            if pilot {
                                let light = luminance(parts.light + merged) as f64;
                                to.pilot.light += light;
                                to.pilot.camera += luminance(s.radiance) as f64 - light;
                                to.pilot.camera_rays += parts.camera_rays;
                                to.pilot.light_rays += parts.light_rays;
                                to.pilot.samples += 1;
                                continue;
                            }
                            // Merges are camera-side: a split sample's are Combined's only.
                            self.bdpt.file_catcher(ctx, &mut sampler, &scratch, &mut s, &mut to.rays);
                            s
                        } else {
                            self.bdpt.li(ctx, &ray, &mut sampler, pixel_sample, &mut target, &mut scratch, &mut to.rays)
                        };
                        if want_data {
                            data_passes::fill(
                                ctx,
                                camera,
                                &ray,
                                &mut s,
                                job.passes,
                                &job.data,
                                pixel_sample,
                                &mut to.rays,
                            );
                        }
                        if want_aovs {
                            crate::integrator::shader_aovs::fill(ctx, &ray, &mut s, pixel_sample, &mut to.rays);
                        }
                        to.done += 1;
                        if !tile.add(k, &s) {
                            to.bad += 1;
                        }
                    }
                }
                to.pilot.splat = scratch.tally.splat;
                splats.give(buf);
                to
            })
            .collect();
        for t in tile_out {
            out.rays.add(&t.rays);
            out.bad += t.bad;
            out.done += t.done;
            out.pilot.add(&t.pilot);
        }
        out.interrupted = cut.load(Ordering::Relaxed);
        out
    }

    /// Renders the job's window (see the module's doc). `on_pass` is called after each
    /// iteration with the film.
    pub fn render(
        &self,
        ctx: &SceneContext,
        camera: &CameraRays,
        job: &RenderJob,
        stop: &AtomicBool,
        on_progress: &(dyn Fn(&Progress) + Sync),
        on_pass: &mut dyn FnMut(&Film, u32),
    ) -> RenderResult {
        let [x0, y0, x1, y1] = job.window;
        let (w, h) = (x1 - x0, y1 - y0);
        let npix = w as u64 * h as u64;
        let mut film = Film::with_passes(w, h, TILE_SIZE, job.passes);
        let start = Instant::now();
        let deadline = job.time_limit.map(|t| start + t);
        let target = job.spp.unwrap_or(u32::MAX - job.sample_offset);
        let merging = self.mode == VcmMode::Full;
        let r0 = self.radius.unwrap_or_else(|| initial_radius(ctx, camera, job.window));
        let splats = SplatPool::with_passes(job.window, job.passes);
        let setup = Setup {
            ctx,
            camera,
            job,
            shutter: ctx.scene.motion.as_ref().and_then(|m| m.shutter).filter(|_| ctx.blurs_motion),
            camera_connectible: camera.light_tracing_reaches(),
        };
        let max_depth = self.bdpt.max_depth;
        let mut map = MergeMap::default();
        let mut volume_map = VolumeMap::default();
        let mut rows: Vec<LightRow> = (0..h)
            .map(|_| LightRow {
                records: Vec::new(),
                volume: Vec::new(),
                subpaths: RowSubpaths::default(),
                scratch: BdptScratch::new(max_depth),
            })
            .collect();
        let mut rays = RayStats::default();
        let mut nan = 0u64;
        let mut splat_count = 0u64;
        let mut st = VcmStats { radius_initial: r0, light_share: 1.0, ..Default::default() };
        let over = |it: u32| stop.load(Ordering::Relaxed) || (it > 0 && deadline.is_some_and(|d| Instant::now() >= d));
        // The share of camera samples with a light subpath, from a pilot thrown away (the
        // module `share`); single strategies unweighted (debugging) carry no sample counts.
        if merging && self.bdpt.strategy.is_none() {
            let pass = Pass { index: PILOT_INDEX, radius: r0, share: 1.0, step: 2 };
            let pool = SplatPool::with_passes(job.window, job.passes);
            let out = self.iteration(&setup, pass, &mut rows, (&mut map, &mut volume_map), None, &pool, &|| false);
            rays.add(&out.rays);
            st.light_share = out.pilot.light_share(npix);
        }
        for it in 0..target {
            if over(it) {
                break;
            }
            let index = job.sample_offset + it;
            let radius = r0 * ((index + 1) as f32).powf(0.5 * (VCM_ALPHA - 1.0));
            let pass = Pass { index, radius, share: st.light_share, step: 1 };
            let out =
                self.iteration(&setup, pass, &mut rows, (&mut map, &mut volume_map), Some(&mut film), &splats, &|| {
                    over(it)
                });
            rays.add(&out.rays);
            nan += out.bad;
            if merging {
                st.merge_records += map.records.len() as u64;
                st.volume_records += volume_map.records.len() as u64;
                st.radius_final = radius;
            }
            // Each camera sample counts as a light path (f of them traced one, weighted 1 / f).
            film.light_paths += out.done;
            let (added, dropped) = splats.drain_into(&mut film);
            splat_count += added;
            nan += dropped;
            if out.interrupted || stop.load(Ordering::Relaxed) {
                break;
            }
            st.iterations = it + 1;
            on_pass(&film, it + 1);
            let elapsed = start.elapsed().as_secs_f64();
            let fraction = match (job.spp, job.time_limit) {
                (Some(n), _) => (it + 1) as f64 / n as f64,
                (None, Some(t)) => (elapsed / t.as_secs_f64()).min(1.0),
                (None, None) => 0.0,
            };
            on_progress(&Progress {
                fraction,
                samples_done: it + 1,
                samples_total: job.spp,
                elapsed,
                eta: (fraction > 0.0).then(|| elapsed * (1.0 - fraction) / fraction),
                rays_per_sec: rays.total() as f64 / elapsed.max(1e-6),
            });
        }
        let image = film.image();
        let spp_min = image.samples.iter().copied().min().unwrap_or(0);
        let spp_max = image.samples.iter().copied().max().unwrap_or(0);
        RenderResult {
            image,
            rays,
            nan_samples: nan,
            spp_min,
            spp_max,
            adaptive_active: None,
            interrupted: stop.load(Ordering::Relaxed),
            elapsed: start.elapsed(),
            light_paths: film.light_paths,
            splats: splat_count,
            integrator_stats: Some(serde_json::json!({ "vcm": st })),
            film: Some(film),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A share f of the camera samples gets a light subpath, spread evenly over each
    /// pixel's samples (Sobol over the sample index): over 64 samples a pixel's count is
    /// within 2 of 64 f (stratified: ±1 from the strata, ±1 from rounding), and the window's
    /// within 1 % of the expectation.
    #[test]
    fn light_subpaths_follow_the_share() {
        for share in [0.1f32, 0.37, 0.5, 0.9] {
            let mut total = 0u32;
            for py in 0..16 {
                for px in 0..16 {
                    let n = (0..64).filter(|&i| has_light_subpath(7, px, py, i, share)).count() as f32;
                    assert!((n - 64.0 * share).abs() <= 2.0, "share {share}: pixel ({px}, {py}) {n}");
                    total += n as u32;
                }
            }
            let expect = 256.0 * 64.0 * share;
            assert!((total as f32 - expect).abs() <= 0.01 * expect, "share {share}: {total} vs {expect}");
        }
        assert!((0..64).all(|i| has_light_subpath(7, 3, 4, i, 1.0)));
    }
}
