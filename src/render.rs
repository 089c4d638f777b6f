//! The render driver: progressive passes over tiles with rayon, stopping on the
//! sample count, the time limit or a signal; progress reports; interim images.
//!
//! Pass sizes grow (1, 1, 2, 4, 8, 16, 16, ...) so that a first full image appears at
//! once and later passes amortise the scheduling. Within a pass every tile renders the
//! same sample indices, so the result never depends on which thread took which tile.

use crate::film::{Film, FilmImage, Filter, SplatPool};
use crate::integrator::bdpt::{BdptScratch, FilmTarget};
use crate::integrator::{Integrator, RayStats, SceneContext};
use crate::sampling::PixelSampler;
use crate::scene::camera::CameraRays;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Tile side in pixels.
pub const TILE_SIZE: u32 = 32;

/// Largest pass, in samples per pixel.
const MAX_PASS: u32 = 16;

/// What to render.
#[derive(Clone, Debug)]
pub struct RenderJob {
    /// Full frame width.
    pub width: u32,
    /// Full frame height.
    pub height: u32,
    /// Pixel window (x0, y0, x1, y1) of the full frame to render.
    pub window: [u32; 4],
    /// Samples per pixel (None: until the time limit).
    pub spp: Option<u32>,
    /// Wall-clock limit for the rendering phase.
    pub time_limit: Option<Duration>,
    /// Seed.
    pub seed: u32,
    /// Pixel filter.
    pub filter: Filter,
    /// Algorithm.
    pub integrator: Integrator,
    /// Camera rays that miss show nothing (alpha 0) rather than the world.
    pub transparent_background: bool,
}

/// What came out.
pub struct RenderResult {
    /// The normalised image.
    pub image: FilmImage,
    /// Ray counts.
    pub rays: RayStats,
    /// Samples that were NaN or infinite and were dropped.
    pub nan_samples: u64,
    /// Fewest samples any pixel got.
    pub spp_min: u32,
    /// Most samples any pixel got.
    pub spp_max: u32,
    /// Stopped by a signal.
    pub interrupted: bool,
    /// Rendering time.
    pub elapsed: Duration,
    /// Light subpaths traced (bidirectional: one per camera sample; 0 otherwise).
    pub light_paths: u64,
    /// Light-tracing splats added to the film (each spread over the pixel filter).
    pub splats: u64,
}

/// Progress callback data.
pub struct Progress {
    /// Fraction done in [0, 1].
    pub fraction: f64,
    /// Complete passes' samples per pixel.
    pub samples_done: u32,
    /// Target samples per pixel.
    pub samples_total: Option<u32>,
    /// Seconds since rendering started.
    pub elapsed: f64,
    /// Estimated seconds left.
    pub eta: Option<f64>,
    /// Rays per second so far.
    pub rays_per_sec: f64,
}

/// Per-tile counters, summed after each pass.
#[derive(Default, Clone, Copy)]
struct TileStats {
    rays: RayStats,
    nan: u64,
    /// Light subpaths traced (bidirectional integrators: one per camera sample).
    light_paths: u64,
}

/// Renders `job` with the context; `stop` is polled per pixel. `on_progress` is
/// called from a reporter thread about twice a second; `on_pass` after each pass
/// with the film (for interim images).
pub fn render(
    ctx: &SceneContext,
    camera: &CameraRays,
    job: &RenderJob,
    stop: &AtomicBool,
    on_progress: &(dyn Fn(&Progress) + Sync),
    on_pass: &mut dyn FnMut(&Film, u32),
) -> RenderResult {
    let [x0, y0, x1, y1] = job.window;
    let mut film = Film::new(x1 - x0, y1 - y0, TILE_SIZE);
    let pixels = ((x1 - x0) as u64) * ((y1 - y0) as u64);
    let start = Instant::now();
    let deadline = job.time_limit.map(|t| start + t);
    let samples_done_px = AtomicU64::new(0);
    let rays_done = AtomicU64::new(0);
    let timed_out = AtomicBool::new(false);
    let finished = AtomicBool::new(false);
    let mut stats = TileStats::default();
    let mut spp_done = 0u32;
    let target = job.spp.unwrap_or(u32::MAX);
    let splats = SplatPool::new(job.window);
    let mut splat_count = 0u64;

    std::thread::scope(|scope| {
        // Reporter thread: reads the counters, never touches the film.
        scope.spawn(|| {
            while !finished.load(Ordering::Relaxed) {
                let elapsed = start.elapsed().as_secs_f64();
                let done = samples_done_px.load(Ordering::Relaxed) as f64;
                let by_samples = job.spp.map(|s| done / (s as f64 * pixels as f64));
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
                    std::thread::sleep(Duration::from_millis(50));
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
                .map(|tile| {
                    let mut ts = TileStats::default();
                    // Bidirectional: a splat buffer and vertex scratch for this tile.
                    let mut bd = match &job.integrator {
                        Integrator::Bdpt(b) => Some((splats.take(), BdptScratch::new(b.max_depth))),
                        _ => None,
                    };
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
                            let (px, py) = (x0 + tile.x0 + tx, y0 + tile.y0 + ty);
                            let acc = &mut tile.pixels[(ty * tile.w + tx) as usize];
                            let rays_before = ts.rays.total();
                            for i in first..first + n {
                                let mut sampler = PixelSampler::new(job.seed, px, py, i);
                                let off = job.filter.sample(sampler.next_2d());
                                let u_lens = if camera.has_lens() { sampler.next_2d() } else { glam::Vec2::ZERO };
                                let (org, dir) =
                                    camera.sample_ray(px as f32 + 0.5 + off.x, py as f32 + 0.5 + off.y, u_lens);
                                let s = match &job.integrator {
                                    Integrator::Path(p) => {
                                        p.li(ctx, org, dir, &mut sampler, |q| camera.depth(q), &mut ts.rays)
                                    }
                                    Integrator::Photon(p) => {
                                        p.li(ctx, org, dir, &mut sampler, |q| camera.depth(q), &mut ts.rays)
                                    }
                                    Integrator::Bdpt(b) => {
                                        let Some((buf, scratch)) = bd.as_mut() else { unreachable!() };
                                        let mut target = FilmTarget { camera, filter: &job.filter, splats: buf };
                                        ts.light_paths += 1;
                                        b.li(
                                            ctx,
                                            org,
                                            dir,
                                            &mut sampler,
                                            (job.seed, px, py, i),
                                            &mut target,
                                            scratch,
                                            &mut ts.rays,
                                        )
                                    }
                                };
                                if s.radiance.is_finite() {
                                    acc.add(&s);
                                } else {
                                    ts.nan += 1;
                                }
                            }
                            samples_done_px.fetch_add(n as u64, Ordering::Relaxed);
                            rays_done.fetch_add(ts.rays.total() - rays_before, Ordering::Relaxed);
                        }
                    }
                    if let Some((buf, _)) = bd {
                        splats.give(buf);
                    }
                    ts
                })
                .collect();
            for t in &tile_stats {
                stats.rays.add(&t.rays);
                stats.nan += t.nan;
                film.light_paths += t.light_paths;
            }
            splat_count += splats.drain_into(&mut film);
            if stop.load(Ordering::Relaxed) || timed_out.load(Ordering::Relaxed) {
                break;
            }
            spp_done += n;
            on_pass(&film, spp_done);
            pass = (pass * 2).min(MAX_PASS);
            if spp_done == n {
                pass = 1; // the second pass is 1 spp too: a quick refinement
            }
        }
        finished.store(true, Ordering::Relaxed);
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
        interrupted: stop.load(Ordering::Relaxed),
        light_paths: film.light_paths,
        splats: splat_count,
        elapsed: start.elapsed(),
    }
}
