//! What a render is asked to do and what it gives back: the job, the result, progress
//! reports and ray counters. Shared by the driver and the integrators that drive
//! themselves (SPPM), so that neither imports the other's internals.

use crate::film::{Film, FilmImage, Filter};
use std::time::Duration;

/// Tile side in pixels: small enough that a 128x128 image has 64 tiles, so that at the end
/// of each progressive pass a worker waits for at most a small tile (with 32 px, 16 tiles,
/// one costly tile of an object's centre could hold a pass back); the film's fixed-point sums
/// make the image independent of the tiling.
pub const TILE_SIZE: u32 = 16;

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
    /// Index of the first sample (`--sample-offset`): the render takes samples
    /// offset..offset+spp of the seed's sequence (SPPM: its iterations' samples and photon passes).
    pub sample_offset: u32,
    /// Pixel filter.
    pub filter: Filter,
    /// Adaptive sampling (`--noise-threshold`); None: every pixel takes every sample.
    pub adaptive: Option<super::adaptive::Adaptive>,
    /// The passes to render besides Combined.
    pub passes: crate::passes::PassSet,
    /// Mist and AO settings of the data passes.
    pub data: crate::passes::DataSettings,
    /// The film sums the first hit's normal and albedo (`film::needs_guides`, or a denoiser).
    pub guides: bool,
}

/// What came out.
pub struct RenderResult {
    /// The normalised image.
    pub image: FilmImage,
    /// Ray counts.
    pub rays: RayStats,
    /// Samples (and light-tracing splats) that were NaN, infinite or beyond ±2^31 and were dropped.
    pub nan_samples: u64,
    /// Fewest samples any pixel got.
    pub spp_min: u32,
    /// Most samples any pixel got.
    pub spp_max: u32,
    /// Pixels still taking samples when adaptive sampling stopped (None when it is off).
    pub adaptive_active: Option<u64>,
    /// Stopped by a signal.
    pub interrupted: bool,
    /// Rendering time.
    pub elapsed: Duration,
    /// Light subpaths traced (bidirectional: one per camera sample; 0 otherwise).
    pub light_paths: u64,
    /// Light-tracing splats added to the film (each spread over the pixel filter).
    pub splats: u64,
    /// The integrator's own counters for the summary (SPPM's iterations and photons), if any.
    pub integrator_stats: Option<serde_json::Value>,
    /// The film's sums (the progressive loop; SPPM keeps none), for chunk files.
    pub film: Option<Film>,
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

/// Ray counts by kind, kept per tile and summed (no shared counters in the hot loop).
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct RayStats {
    /// Primary rays from the camera.
    pub camera: u64,
    /// Rays continuing a path after scattering or passing through a transparent surface.
    pub bounce: u64,
    /// Shadow rays for next-event estimation.
    pub shadow: u64,
}

impl RayStats {
    /// Adds another tile's counts.
    pub fn add(&mut self, o: &RayStats) {
        self.camera += o.camera;
        self.bounce += o.bounce;
        self.shadow += o.shadow;
    }

    /// All rays.
    pub fn total(&self) -> u64 {
        self.camera + self.bounce + self.shadow
    }
}
