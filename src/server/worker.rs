//! The render worker: one thread per render, which builds the integrator (or reuses the
//! one kept from the last render: photon maps survive camera moves), renders a first
//! frame at reduced resolution, then the full frame progressively through the same
//! driver as `caustic render`, sending a frame after every pass. Setting its stop flag
//! ends it within a pixel's work.

use super::edits::View;
use super::protocol::{FrameFormat, encode_pixels, write_message};
use crate::accel::Accel;
use crate::cli::IntegratorKind;
use crate::film::{FilmImage, Filter};
use crate::integrator::bdpt::BdptIntegrator;
use crate::integrator::path::PathIntegrator;
use crate::integrator::photon::PhotonSettings;
use crate::integrator::photon::io::PhotonMaps;
use crate::integrator::photon::jensen::JensenIntegrator;
use crate::integrator::{Integrator, SceneContext};
use crate::light::LightSamplerKind;
use crate::render::{self, RenderJob};
use crate::scene::Scene;
use crate::scene::camera::CameraRays;
use serde_json::json;
use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Instant;

/// The server's output stream, shared by the request loop and the worker; one
/// message is written whole under the lock.
pub struct Output(Mutex<Box<dyn Write + Send>>);

impl Output {
    /// Wraps a writer.
    pub fn new(w: Box<dyn Write + Send>) -> Self {
        Output(Mutex::new(w))
    }

    /// Sends one message. A client that went away is noticed by the request loop (its
    /// input ends), so a failed write is dropped here.
    pub fn send(&self, header: serde_json::Value, payload: &[u8]) {
        let mut w = self.0.lock().unwrap_or_else(|p| p.into_inner());
        let _ = write_message(&mut *w, &header, payload);
    }
}

/// The render settings of the viewport (resolved as `caustic render` resolves them).
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// Algorithm (SPPM is refused: it has no progressive passes to show).
    pub integrator: IntegratorKind,
    /// Samples per pixel to stop at (None: until stopped).
    pub spp: Option<u32>,
    /// Maximum scattering events.
    pub max_depth: u32,
    /// Cycles' per-kind bounce limits and clamps.
    pub light_paths: crate::integrator::light_paths::LightPaths,
    /// The per-kind bounce limits BDPT follows itself (`Resolved::bounce_limits`).
    pub bounce_limits: crate::integrator::light_paths::LightPaths,
    /// Cycles' Transparent Max Bounces.
    pub transparent_max: u32,
    /// Seed.
    pub seed: u32,
    /// Pixel filter.
    pub filter: Filter,
    /// Film → Transparent.
    pub transparent: bool,
    /// Film → Transparent Glass's roughness threshold (the path tracer's).
    pub transparent_glass: Option<f32>,
    /// Light Paths > Fast GI Approximation (the path tracer's).
    pub fast_gi: Option<crate::integrator::fast_gi::FastGi>,
    /// Photon settings.
    pub photon: PhotonSettings,
    /// Light selection.
    pub light_sampler: LightSamplerKind,
    /// Frame pixel format.
    pub format: FrameFormat,
    /// Divisor of the first frame's resolution (1: none).
    pub reduce: u32,
}

/// One render: everything the worker reads, owned by it.
pub struct Job {
    /// The scene.
    pub scene: Arc<Scene>,
    /// Its BVH.
    pub accel: Arc<Accel>,
    /// The view.
    pub view: View,
    /// Settings.
    pub settings: RenderSettings,
    /// The integrator kept from the last render of this scene state, if any.
    pub integrator: Option<Arc<Integrator>>,
    /// Edit generation the frames belong to.
    pub generation: u64,
}

/// A running render.
pub struct Worker {
    stop: Arc<AtomicBool>,
    handle: JoinHandle<Option<Arc<Integrator>>>,
}

impl Worker {
    /// Starts rendering `job` on `pool`.
    pub fn spawn(job: Job, out: Arc<Output>, pool: Arc<rayon::ThreadPool>) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let handle = std::thread::spawn(move || {
            let generation = job.generation;
            // A bug in a render must not end the server silently: the client hears of it
            // and the next edit starts a fresh worker.
            match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| pool.install(|| run(job, &out, &flag)))) {
                Ok(kept) => kept,
                Err(panic) => {
                    let what = panic
                        .downcast_ref::<&str>()
                        .map(|s| s.to_string())
                        .or_else(|| panic.downcast_ref::<String>().cloned())
                        .unwrap_or_else(|| "unknown".into());
                    out.send(
                        json!({"type": "error", "request": null, "generation": generation,
                               "message": format!("the render failed (internal error, please report it): {what}")}),
                        &[],
                    );
                    None
                }
            }
        });
        Worker { stop, handle }
    }

    /// Stops the render (within a pixel's work) and gives back its integrator when it
    /// was built completely (an interrupted photon trace is not kept).
    pub fn finish(self) -> Option<Arc<Integrator>> {
        self.stop.store(true, Ordering::Relaxed);
        self.handle.join().unwrap_or(None)
    }
}

/// The integrator for the settings, tracing photon maps when it needs them; None when
/// stopped while tracing.
fn build_integrator(ctx: &SceneContext, s: &RenderSettings, stop: &AtomicBool) -> Option<Integrator> {
    Some(match s.integrator {
        IntegratorKind::Path => Integrator::Path(PathIntegrator {
            glass_threshold: s.transparent_glass,
            fast_gi: s.fast_gi,
            ..PathIntegrator::new(s.max_depth, s.transparent)
        }),
        IntegratorKind::Bdpt => Integrator::Bdpt(
            BdptIntegrator::new(ctx.scene, s.max_depth, s.transparent, None)
                .with_transparent_glass(ctx.scene, s.transparent_glass)
                .with_bounce_limits(s.bounce_limits),
        ),
        IntegratorKind::Photon => {
            // The map is never written to a file, so it carries no scene hash (0).
            let (maps, _) = PhotonMaps::trace(
                ctx,
                s.photon.photons,
                s.photon.caustic_photons,
                s.seed,
                s.max_depth,
                0,
                stop,
                &|_, _, _| {},
            );
            if stop.load(Ordering::Relaxed) {
                return None;
            }
            let (_, r) = ctx.scene.bounding_sphere();
            Integrator::Photon(JensenIntegrator {
                glass_threshold: s.transparent_glass,
                ..JensenIntegrator::new(maps, &s.photon, r, s.max_depth, s.transparent)
            })
        }
        IntegratorKind::Vcm => Integrator::Vcm(
            crate::integrator::vcm::VcmIntegrator::new(
                ctx.scene,
                s.max_depth,
                s.transparent,
                crate::integrator::vcm::VcmMode::Full,
                None,
            )
            .with_transparent_glass(ctx.scene, s.transparent_glass),
        ),
        IntegratorKind::Sppm => unreachable!("the server refuses SPPM before rendering"),
    })
}

/// The frame message of an image of `view`'s window.
fn send_frame(out: &Output, img: &mut FilmImage, job: &Job, view: &View, spp: u32, t0: Instant) {
    let s = &job.settings;
    let payload = encode_pixels(&img.combined, s.format);
    out.send(
        json!({
            "type": "frame",
            "generation": job.generation,
            "width": img.width,
            "height": img.height,
            "resolution": [view.resolution.0, view.resolution.1],
            "window": view.window,
            "samples": spp,
            "target": s.spp,
            "reduced": view.resolution != job.view.resolution,
            "format": s.format.name(),
            "elapsed": t0.elapsed().as_secs_f64(),
        }),
        &payload,
    );
}

/// The view at 1/`r` of the resolution, covering the same part of the frame.
fn reduced(view: &View, r: u32) -> View {
    let (w, h) = ((view.resolution.0 / r).max(1), (view.resolution.1 / r).max(1));
    let [x0, y0, x1, y1] = view.window;
    let (x0, y0) = ((x0 / r).min(w - 1), (y0 / r).min(h - 1));
    let window = [x0, y0, x1.div_ceil(r).clamp(x0 + 1, w), y1.div_ceil(r).clamp(y0 + 1, h)];
    View { camera: view.camera.clone(), resolution: (w, h), window }
}

fn run(job: Job, out: &Output, stop: &AtomicBool) -> Option<Arc<Integrator>> {
    let t0 = Instant::now();
    let s = &job.settings;
    // As `caustic render` builds it: the media around the camera, Ray Visibility and light
    // linking for all.
    let ctx = SceneContext::with_light_sampler(&job.scene, &job.accel, s.light_sampler)
        .with_light_paths(s.light_paths, s.transparent_max)
        .with_camera_at(job.view.camera.position);
    let ctx = ctx.with_ray_visibility();
    let ctx = ctx.with_light_linking();
    let ctx = match s.integrator == IntegratorKind::Path
        && crate::integrator::fast_gi::cycles_skips_world_sampling(s.fast_gi, &job.scene)
    {
        true => ctx.without_world_sampling(),
        false => ctx,
    };
    let integrator = match &job.integrator {
        Some(i) => i.clone(),
        None => Arc::new(build_integrator(&ctx, s, stop)?),
    };
    let render_view = |view: &View, spp: Option<u32>, on_pass: &mut dyn FnMut(&crate::film::Film, u32)| {
        let camera = CameraRays::new(&view.camera, view.resolution.0, view.resolution.1);
        let rjob = RenderJob {
            width: view.resolution.0,
            height: view.resolution.1,
            window: view.window,
            spp,
            time_limit: None,
            seed: s.seed,
            sample_offset: 0,
            filter: s.filter.clone(),
            // The viewport refines every pixel alike: a frame is shown after every pass.
            adaptive: None,
            // The viewport shows Combined only.
            passes: crate::passes::PassSet::legacy(),
            data: Default::default(),
            guides: false,
        };
        let on_progress = |p: &render::Progress| {
            out.send(
                json!({
                    "type": "progress",
                    "generation": job.generation,
                    "samples": p.samples_done,
                    "target": p.samples_total,
                    "elapsed": p.elapsed,
                    "rays_per_sec": p.rays_per_sec,
                }),
                &[],
            )
        };
        render::render(&ctx, &camera, &integrator, &rjob, stop, &on_progress, on_pass)
    };
    if s.reduce > 1 {
        let small = reduced(&job.view, s.reduce);
        let r = render_view(&small, Some(1), &mut |_, _| {});
        if stop.load(Ordering::Relaxed) {
            return Some(integrator);
        }
        let mut img = r.image;
        send_frame(out, &mut img, &job, &small, 1, t0);
    }
    let result = render_view(&job.view, s.spp, &mut |film, spp| {
        let mut img = film.image();
        send_frame(out, &mut img, &job, &job.view, spp, t0);
    });
    if !stop.load(Ordering::Relaxed) {
        out.send(
            json!({
                "type": "done",
                "generation": job.generation,
                "samples": result.spp_min,
                "nan_samples": result.nan_samples,
                "elapsed": t0.elapsed().as_secs_f64(),
                "rays_per_sec": result.rays.total() as f64 / result.elapsed.as_secs_f64().max(1e-9),
            }),
            &[],
        );
    }
    Some(integrator)
}
