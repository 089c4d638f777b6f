//! VCM's iteration driver: per iteration a light pass (subpaths, merge records, grid) and
//! a camera pass over the film's tiles (one sample per pixel), then the splats are added.
//! Stops on the sample count (iterations), the time limit or a signal, like the
//! progressive driver; an iteration's light pass is not interrupted once its camera pass
//! may need it, and the first iteration always completes so a time limit gives an image.

use super::light_store::RowSubpaths;
use super::merge::{MergeMap, MergeRecord, merge_camera_path, push_records};
use super::volume_merge::{self, VolumeMap, VolumeRecord};
use super::{VCM_ALPHA, VCM_RADIUS_FOOTPRINTS, VcmIntegrator, VcmMode};
use crate::film::{CameraSample, Film, SplatPool};
use crate::integrator::bdpt::{BdptScratch, FilmTarget, connection_sampler, light_sampler};
use crate::integrator::{SceneContext, data_passes};
use crate::math::Rgb;
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
    ) -> CameraSample {
        let mut out = CameraSample { depth: f32::INFINITY, ..Default::default() };
        let mut radiance = Rgb::ZERO;
        self.bdpt.camera_subpath(ctx, ray, sampler, film.camera, scratch, &mut out, &mut radiance, stats);
        row.restore(ctx, i, &mut scratch.light);
        let (seed, px, py, index) = pixel_sample;
        let mut cs = connection_sampler(seed, px, py, index);
        radiance += self.bdpt.connect_all(ctx, &mut cs, film, scratch, &mut out, stats);
        out.radiance = radiance;
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
        let want_data = job.passes.any_data();
        let want_aovs = job.passes.shader_aov_channels() > 0;
        let shutter = ctx.scene.motion.as_ref().and_then(|m| m.shutter).filter(|_| ctx.blurs_motion);
        let max_depth = self.bdpt.max_depth;
        let camera_connectible = !camera.is_orthographic();
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
        let mut st = VcmStats { radius_initial: r0, ..Default::default() };
        let timed_out = AtomicBool::new(false);
        let over = |it: u32| {
            stop.load(Ordering::Relaxed)
                || timed_out.load(Ordering::Relaxed)
                || (it > 0 && deadline.is_some_and(|d| Instant::now() >= d))
        };
        for it in 0..target {
            if over(it) {
                break;
            }
            let index = job.sample_offset + it;
            // 1. Light pass: the subpaths the camera pass will connect to, stored for merging.
            if merging {
                let radius = r0 * ((index + 1) as f32).powf(0.5 * (VCM_ALPHA - 1.0));
                let eta = npix as f32 * std::f32::consts::PI * radius * radius;
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
                            push_records(ctx.scene, &lr.scratch.light, eta, &mut lr.records);
                            let salt = volume_merge::salt(job.seed, px, py, index);
                            volume_merge::deposit(ctx, &lr.scratch.volume_segments, salt, &mut lr.volume);
                            lr.subpaths.push(&lr.scratch.light);
                        }
                        rs
                    })
                    .collect();
                for r in &light_rays {
                    rays.add(r);
                }
                map.records.clear();
                for lr in &rows {
                    map.records.extend_from_slice(&lr.records);
                }
                map.build(radius, npix);
                st.merge_records += map.records.len() as u64;
                volume_map.records.clear();
                for lr in &rows {
                    volume_map.records.extend_from_slice(&lr.volume);
                }
                volume_map.build(radius, npix);
                st.volume_records += volume_map.records.len() as u64;
                st.radius_final = radius;
                if over(it) {
                    break;
                }
            }
            // 2. Camera pass: BDPT's sample with merge-aware weights, then the merges.
            let eta = if merging { map.eta } else { 0.0 };
            let map_ref = &map;
            let volume_ref = &volume_map;
            let rows_ref = &rows;
            let tile_stats: Vec<(RayStats, u64, u64)> = film
                .tiles
                .par_iter_mut()
                .map(|tile| {
                    let mut rs = RayStats::default();
                    let (mut bad, mut done) = (0u64, 0u64);
                    let mut scratch = BdptScratch::new(max_depth);
                    scratch.dens.eta_vm = eta;
                    let mut buf = splats.take();
                    'pixels: for ty in 0..tile.h {
                        for tx in 0..tile.w {
                            if over(it) {
                                timed_out.store(true, Ordering::Relaxed);
                                break 'pixels;
                            }
                            let k = (ty * tile.w + tx) as usize;
                            let (px, py) = (x0 + tile.x0 + tx, y0 + tile.y0 + ty);
                            let mut sampler = PixelSampler::new(job.seed, px, py, index);
                            let off = job.filter.sample(sampler.next_2d());
                            let u_lens = if camera.has_lens() { sampler.next_2d() } else { Vec2::ZERO };
                            let time = shutter.map(|s| s.time(sampler.next_2d().x, py, job.height));
                            let (fx, fy) = (px as f32 + 0.5 + off.x, py as f32 + 0.5 + off.y);
                            let ray = camera.sample_clipped_at(fx, fy, u_lens, time);
                            let _time = crate::motion::TimeScope::enter(time);
                            let mut target = FilmTarget { camera, filter: &job.filter, splats: &mut buf };
                            let pixel_sample = (job.seed, px, py, index);
                            let mut s = if merging {
                                // The pixel's light subpath from the light pass, not traced again.
                                let row = &rows_ref[(py - y0) as usize].subpaths;
                                let light = (row, (px - x0) as usize);
                                let mut s = self.sample_stored(
                                    ctx,
                                    &ray,
                                    &mut sampler,
                                    pixel_sample,
                                    light,
                                    &mut target,
                                    &mut scratch,
                                    &mut rs,
                                );
                                let ledger = self.bdpt.ledger;
                                let passes = ledger.any().then_some((ctx, ledger, scratch.first, &mut s));
                                let merged =
                                    merge_camera_path(&scratch.cam, map_ref, camera_connectible, max_depth, passes);
                                s.radiance += merged;
                                if let Some(x) = *scratch.medium_vertex {
                                    let passes = ledger.any().then_some((ctx, ledger, &mut s));
                                    let merged = volume_ref.merge(&x, max_depth, passes);
                                    s.radiance += merged;
                                }
                                // Merges are camera-side: a split sample's are Combined's only.
                                self.bdpt.file_catcher(ctx, &mut sampler, &scratch, &mut s, &mut rs);
                                s
                            } else {
                                self.bdpt.li(ctx, &ray, &mut sampler, pixel_sample, &mut target, &mut scratch, &mut rs)
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
                                    &mut rs,
                                );
                            }
                            if want_aovs {
                                crate::integrator::shader_aovs::fill(ctx, &ray, &mut s, pixel_sample, &mut rs);
                            }
                            done += 1;
                            if !tile.add(k, &s) {
                                bad += 1;
                            }
                        }
                    }
                    splats.give(buf);
                    (rs, bad, done)
                })
                .collect();
            for (r, b, d) in &tile_stats {
                rays.add(r);
                nan += b;
                // Each camera sample traced one light subpath for its connections.
                film.light_paths += d;
            }
            let (added, dropped) = splats.drain_into(&mut film);
            splat_count += added;
            nan += dropped;
            if timed_out.load(Ordering::Relaxed) || stop.load(Ordering::Relaxed) {
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
