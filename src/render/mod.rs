//! The render driver: progressive passes over tiles with rayon, stopping on the
//! sample count, the time limit or a signal; progress reports; interim images.
//!
//! Pass sizes grow (1, 1, 2, 4, 8, 16, 16, ...) so that a first full image appears at
//! once and later passes amortise the scheduling. Within a pass every tile renders the
//! same sample indices, so the result never depends on which thread took which tile.
//! Sample i of pixel (x, y) depends only on (seed, x, y, i), never on the pass, so a
//! render of samples offset..offset+spp (`job.sample_offset`) takes exactly the samples a
//! single render takes at those indices, and the film's fixed-point sums add exactly.

pub mod adaptive;
pub mod job;

pub use job::{Progress, RayStats, RenderJob, RenderResult, TILE_SIZE};

use crate::film::{CameraSample, Film, SplatPool};
use crate::integrator::{Integrator, SceneContext, data_passes};
use crate::sampling::PixelSampler;
use crate::scene::camera::CameraRays;
use adaptive::AdaptiveFilm;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Largest pass, in samples per pixel.
const MAX_PASS: u32 = 16;

// Adaptive sampling tests convergence after multiples of its step: the passes (1, 1, 2, 4,
// 8, then MAX_PASS each) end on every multiple of MAX_PASS, so the step must be one of them.
const _: () = assert!(adaptive::ADAPTIVE_STEP.is_multiple_of(MAX_PASS));

/// Per-tile counters, summed after each pass.
#[derive(Default, Clone, Copy)]
struct TileStats {
    rays: RayStats,
    nan: u64,
    /// Light subpaths traced (bidirectional integrators: one per camera sample).
    light_paths: u64,
}

/// Renders `job` with `integrator`: SPPM drives its own iterations, every other
/// integrator computes camera samples in the progressive tile loop. `stop` is polled per
/// pixel. `on_progress` is called about twice a second; `on_pass` after each pass with
/// the film (for interim images; not called by SPPM).
pub fn render(
    ctx: &SceneContext,
    camera: &CameraRays,
    integrator: &Integrator,
    job: &RenderJob,
    stop: &AtomicBool,
    on_progress: &(dyn Fn(&Progress) + Sync),
    on_pass: &mut dyn FnMut(&Film, u32),
) -> RenderResult {
    match integrator {
        Integrator::Sppm(s) => {
            // SPPM renders by iterations over the whole image, not by tiles: it fills every
            // pass itself (light passes `sppm_passes`, camera-ray passes `sppm_extras`,
            // catcher `sppm_catcher`).
            let mut r = s.render(ctx, camera, job, stop, on_progress);
            r.image.passes = job.passes;
            r
        }
        Integrator::Vcm(v) => v.render(ctx, camera, job, stop, on_progress, on_pass),
        _ => progressive(ctx, camera, integrator, job, stop, on_progress, on_pass),
    }
}

/// The progressive tile loop: passes of camera samples until the sample count, the
/// time limit or a signal.
fn progressive(
    ctx: &SceneContext,
    camera: &CameraRays,
    integrator: &Integrator,
    job: &RenderJob,
    stop: &AtomicBool,
    on_progress: &(dyn Fn(&Progress) + Sync),
    on_pass: &mut dyn FnMut(&Film, u32),
) -> RenderResult {
    let [x0, y0, x1, y1] = job.window;
    let mut film = Film::with_passes(x1 - x0, y1 - y0, TILE_SIZE, job.passes);
    film.keep_guides(job.guides);
    // Adaptive sampling: the class-A half sums and converged flags, one tile per film tile.
    let mut adaptive = AdaptiveFilm::new(&film, job.adaptive);
    let pixels = ((x1 - x0) as u64) * ((y1 - y0) as u64);
    let start = Instant::now();
    let deadline = job.time_limit.map(|t| start + t);
    let samples_done_px = AtomicU64::new(0);
    // Samples the render will take in all (pixels × spp, lowered as pixels converge).
    let samples_expected_px = AtomicU64::new(job.spp.map_or(0, |s| s as u64 * pixels));
    let rays_done = AtomicU64::new(0);
    let timed_out = AtomicBool::new(false);
    let finished = AtomicBool::new(false);
    let mut stats = TileStats::default();
    let mut spp_done = 0u32;
    // Without --spp the render runs until the time limit, as far as the index allows.
    let target = job.spp.unwrap_or(u32::MAX - job.sample_offset);
    let splats = SplatPool::with_passes(job.window, job.passes);
    // Data passes trace the camera ray's first hit apart from the integrator.
    let want_data = job.passes.any_data();
    let want_aovs = job.passes.shader_aov_channels() > 0;
    // Motion blur: each camera sample draws its time over the shutter (static scenes draw none).
    let shutter = ctx.scene.motion.as_ref().and_then(|m| m.shutter).filter(|_| ctx.blurs_motion);
    let mut splat_count = 0u64;

    std::thread::scope(|scope| {
        // Reporter thread: reads the counters, never touches the film. It is woken when
        // the render ends, so that a short render (the viewport's) does not wait out its nap.
        let reporter = scope.spawn(|| {
            while !finished.load(Ordering::Relaxed) {
                let elapsed = start.elapsed().as_secs_f64();
                let done = samples_done_px.load(Ordering::Relaxed) as f64;
                let expected = samples_expected_px.load(Ordering::Relaxed) as f64;
                let by_samples = job.spp.map(|_| done / expected.max(1.0));
                let by_time = job.time_limit.map(|t| elapsed / t.as_secs_f64());
                let fraction = match (by_samples, by_time) {
                    (Some(a), Some(b)) => a.max(b),
                    (Some(a), None) => a,
                    (None, Some(b)) => b,
                    (None, None) => 0.0,
                }
                .clamp(0.0, 1.0);
                let eta = (fraction > 0.0).then(|| elapsed * (1.0 - fraction) / fraction);
                on_progress(&Progress {
                    fraction,
                    samples_done: (done / pixels as f64) as u32,
                    samples_total: job.spp,
                    elapsed,
                    eta,
                    rays_per_sec: rays_done.load(Ordering::Relaxed) as f64 / elapsed.max(1e-6),
                });
                for _ in 0..10 {
                    if finished.load(Ordering::Relaxed) {
                        break;
                    }
                    std::thread::park_timeout(Duration::from_millis(50));
                }
            }
        });

        let mut pass = 1u32;
        while spp_done < target && !stop.load(Ordering::Relaxed) && !timed_out.load(Ordering::Relaxed) {
            let n = pass.min(target - spp_done);
            let first = spp_done;
            let tile_stats: Vec<TileStats> = film
                .tiles
                .par_iter_mut()
                .zip(adaptive.tiles.par_iter_mut())
                .map(|(tile, adaptive_tile)| {
                    let mut ts = TileStats::default();
                    // Per-tile working memory (bidirectional: splat buffer, subpath vertices).
                    let mut scratch = integrator.tile_scratch(&splats);
                    // One sample record for the tile, which each sample overwrites.
                    let mut s = CameraSample::default();
                    for ty in 0..tile.h {
                        for tx in 0..tile.w {
                            if stop.load(Ordering::Relaxed) || timed_out.load(Ordering::Relaxed) {
                                break;
                            }
                            if let Some(d) = deadline
                                && Instant::now() >= d
                            {
                                timed_out.store(true, Ordering::Relaxed);
                                break;
                            }
                            let k = (ty * tile.w + tx) as usize;
                            if !adaptive_tile.active(k) {
                                continue; // converged: adaptive sampling stopped this pixel
                            }
                            let (px, py) = (x0 + tile.x0 + tx, y0 + tile.y0 + ty);
                            let rays_before = ts.rays.total();
                            // Sample numbers continue after the offset: a chunk takes the samples a
                            // single render would take at those numbers, camera and light streams alike.
                            for i in job.sample_offset + first..job.sample_offset + first + n {
                                let mut sampler = PixelSampler::new(job.seed, px, py, i);
                                let off = job.filter.camera_offset(i, sampler.next_2d());
                                let u_lens = if camera.has_lens() { sampler.next_2d() } else { glam::Vec2::ZERO };
                                let time = shutter.map(|s| s.time(sampler.next_2d().x, py, job.height));
                                let (fx, fy) = (px as f32 + 0.5 + off.x, py as f32 + 0.5 + off.y);
                                let ray = camera.sample_clipped_at(fx, fy, u_lens, time);
                                // Every ray of this sample (bounces, shadow rays, BDPT's light subpath) at its time.
                                let _time = crate::motion::TimeScope::enter(time);
                                integrator.sample(
                                    ctx,
                                    camera,
                                    &job.filter,
                                    &mut scratch,
                                    &ray,
                                    &mut sampler,
                                    (job.seed, px, py, i),
                                    &mut ts.rays,
                                    &mut s,
                                );
                                if want_data {
                                    let pixel_sample = (job.seed, px, py, i);
                                    data_passes::fill(
                                        ctx,
                                        camera,
                                        &ray,
                                        &mut s,
                                        job.passes,
                                        &job.data,
                                        pixel_sample,
                                        &mut ts.rays,
                                    );
                                }
                                if want_aovs {
                                    crate::integrator::shader_aovs::fill(
                                        ctx,
                                        &ray,
                                        &mut s,
                                        (job.seed, px, py, i),
                                        &mut ts.rays,
                                    );
                                }
                                ts.light_paths += integrator.light_paths_per_sample();
                                if tile.add(k, &s) {
                                    adaptive_tile.add(k, i, &s);
                                } else {
                                    ts.nan += 1;
                                }
                            }
                            samples_done_px.fetch_add(n as u64, Ordering::Relaxed);
                            rays_done.fetch_add(ts.rays.total() - rays_before, Ordering::Relaxed);
                        }
                    }
                    scratch.release(&splats);
                    ts
                })
                .collect();
            for t in &tile_stats {
                stats.rays.add(&t.rays);
                stats.nan += t.nan;
                film.light_paths += t.light_paths;
            }
            let (added, dropped) = splats.drain_into(&mut film);
            splat_count += added;
            stats.nan += dropped;
            if stop.load(Ordering::Relaxed) || timed_out.load(Ordering::Relaxed) {
                break;
            }
            spp_done += n;
            let active_before = adaptive.active;
            let active = adaptive.update(&film, spp_done);
            if active != active_before {
                // Converged pixels take no more samples: the progress counts only what is left.
                let done = samples_done_px.load(Ordering::Relaxed);
                samples_expected_px.store(done + active * (target - spp_done) as u64, Ordering::Relaxed);
            }
            on_pass(&film, spp_done);
            if active == 0 {
                break; // every pixel converged
            }
            pass = (pass * 2).min(MAX_PASS);
            if spp_done == n {
                pass = 1; // the second pass is 1 spp too: a quick refinement
            }
        }
        finished.store(true, Ordering::Relaxed);
        reporter.thread().unpark();
    });

    let image = film.image();
    let spp_min = image.samples.iter().copied().min().unwrap_or(0);
    let spp_max = image.samples.iter().copied().max().unwrap_or(0);
    RenderResult {
        image,
        rays: stats.rays,
        nan_samples: stats.nan,
        spp_min,
        spp_max,
        adaptive_active: job.adaptive.map(|_| adaptive.active),
        interrupted: stop.load(Ordering::Relaxed),
        light_paths: film.light_paths,
        splats: splat_count,
        elapsed: start.elapsed(),
        integrator_stats: None,
        film: Some(film),
    }
}
