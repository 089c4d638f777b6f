//! Bidirectional path tracing (Veach 1997, ch. 10) with multiple importance sampling
//! over all connection strategies, power heuristic.
//!
//! Per camera sample: a camera subpath and a light subpath are traced, then every pair
//! of prefixes (s light vertices, t camera vertices) is connected:
//! - s = 0: the camera subpath finds an emitter (hits an emissive triangle, crosses an
//!   area or sphere light, escapes to the world or a sun); done while tracing it;
//! - s = 1: light sampling at a camera vertex (a fresh light point, not the subpath's);
//! - t = 1: a light subpath vertex is connected to the camera and splatted onto the film
//!   through the pixel filter (light tracing);
//! - s, t ≥ 2: a shadow ray joins the two subpaths.
//!
//! Each contribution is weighted by `mis::PathDensities::weight`. Light subpaths start at
//! every light but soft-falloff point lights and spots with a radius (`lights::starts_subpaths`): the world and
//! suns on a disk beyond the scene's bounding sphere facing a direction from the light's
//! own distribution (a vertex at infinity, `Kind::Infinite`: its light-side density is the
//! direction's, the next vertex's the disk's times the cosine there, and the camera side
//! reaches it with a solid-angle density; t = 1 cannot see it). Paths from soft point
//! lights and spots with a radius are made by s = 0 and s = 1 only, weighted as the path tracer weights them, and
//! so are paths from emitters whose node graph reads the Light Path node (their radiance
//! depends on the camera path: `path_emitters`).
//!
//! Light subpaths carry the adjoint of the camera's BSDF: a refraction, whose camera-side
//! value follows Cycles' convention (no η², `bsdf::dielectric`), scales them by 1/η², and
//! shading normals get Veach's correction |wo·ns| |wi·ng| / (|wo·ng| |wi·ns|).
//!
//! Media and subsurface scattering: the strategies above carry the paths without a vertex in
//! a medium, attenuated by extinction along every segment (light subpaths, connections and
//! camera segments alike; volume-only boundaries are crossed). Paths with a medium vertex are
//! made by the camera subpath alone: where free-flight sampling puts a scattering event on
//! it, the path tracer takes over from that vertex (NEE and phase sampling), and the
//! subsurface part of a material at a camera vertex is path traced from it. The two sets of
//! paths are disjoint, so the sum is unbiased; what BDPT does not yet offer is light
//! subpaths scattering in media (a volumetric caustic seen in fog is path traced).
//!
//! Ray Visibility: paths that meet an object or light hidden from some kind of ray are made
//! by s = 0 and s = 1 alone, as the path tracer makes them (`visibility`).

pub mod mis;

use super::{SceneContext, power_heuristic};
use crate::bsdf::Bsdf;
use crate::film::CameraSample;
use crate::film::{Filter, SplatBuffer};
use crate::light::origin::{self as lights, BdptLights, LightPoint};
use crate::light::{Light, LightSample, area_to_solid_angle, intersect_sphere};
use crate::math::{Frame, Rgb, hash_combine, offset_ray_origin};
use crate::medium::MediumStack;
use crate::render::job::RayStats;
use crate::sampling::PixelSampler;
use crate::sampling::warp::uniform_cone_pdf;
use crate::scene::camera::CameraRay;
use crate::scene::camera::CameraRays;
use crate::scene::shading::SurfaceHit;
use glam::{Vec2, Vec3};
use mis::PathDensities;
use std::sync::Arc;

/// Largest `max_depth` the bidirectional integrator accepts (its vertex arrays are fixed).
pub const MAX_BDPT_DEPTH: u32 = 62;

/// One strategy to render alone (debugging and tests).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Strategy {
    /// Light vertices.
    pub s: u32,
    /// Camera vertices (the camera included).
    pub t: u32,
    /// Apply the MIS weight (else the strategy's own unweighted estimate).
    pub weighted: bool,
}

/// The bidirectional path tracer's parameters.
#[derive(Clone, Debug)]
pub struct BdptIntegrator {
    /// Maximum number of scattering events on a path.
    pub max_depth: u32,
    /// Subpath depth from which Russian roulette may end subpaths.
    pub rr_depth: u32,
    /// Camera rays that miss show nothing (alpha 0), as Blender's Film → Transparent.
    pub transparent_background: bool,
    /// Render only this strategy.
    pub strategy: Option<Strategy>,
    /// The lights as subpath origins.
    pub lights: Arc<BdptLights>,
    /// A vertex reached through a delta lobe keeps its geometric factor |cos| / d² as its
    /// density (the delta's solid-angle density counted as 1, SmallVCM's convention)
    /// instead of 0 (pbrt's, whole density counted as 1). Both give weights that sum to 1;
    /// VCM needs the geometry: merging at a diffuse vertex between two specular ones is
    /// weighed against s = 0 by distances that dropping it would lose (caustics seen
    /// through glass turned to fireflies). False for BDPT, whose images it would change.
    pub delta_geometry: bool,
    /// The light passes and light groups to file contributions into (`passes`).
    pub ledger: Ledger,
    /// The objects and lights whose Ray Visibility leaves their paths to the camera side
    /// (`visibility`).
    pub restriction: Arc<visibility::Restriction>,
    /// VCM's volume merging (`vcm::volume_merge`): light subpaths record the segments they
    /// cross in media after delta bounces alone, the camera subpath its first medium
    /// vertex, and the path tracer continued from there leaves out what merging makes.
    pub volume_merging: bool,
    /// Film → Transparent Glass's roughness threshold (`with_transparent_glass`).
    pub glass_threshold: Option<f32>,
    /// Light Paths' per-kind bounce limits (`bounces`; the clamps and the rest unused).
    pub light_paths: crate::integrator::light_paths::LightPaths,
}

impl BdptIntegrator {
    /// BDPT over the scene's lights (Russian roulette at the path tracer's depth);
    /// `strategy` renders one strategy alone (debugging).
    pub fn new(
        scene: &crate::scene::Scene,
        max_depth: u32,
        transparent_background: bool,
        strategy: Option<Strategy>,
    ) -> Self {
        let restriction = Arc::new(visibility::Restriction::new(scene));
        BdptIntegrator {
            max_depth,
            rr_depth: super::path::PathIntegrator::default().rr_depth,
            transparent_background,
            strategy,
            lights: Arc::new(BdptLights::new(scene, |i| restriction.light(i))),
            delta_geometry: false,
            ledger: Ledger::default(),
            restriction,
            volume_merging: false,
            glass_threshold: None,
            light_paths: crate::integrator::light_paths::LightPaths::UNLIMITED,
        }
    }

    /// Light Paths' per-kind bounce limits `lp` followed (`bounces`). VCM's volume merging
    /// is left off where one can end a path before Max Bounces: the path tracer continued
    /// from the medium vertex then keeps every path there.
    pub fn with_bounce_limits(self, lp: crate::integrator::light_paths::LightPaths) -> Self {
        let binding = !lp.limits_below(self.max_depth).is_empty();
        BdptIntegrator { light_paths: lp, volume_merging: self.volume_merging && !binding, ..self }
    }

    /// What the bounce limits make of paths that end right after camera vertex `x` (s = 0
    /// from its ray, s = 1 at it), and so of every path through it: None when they drop
    /// them; Some(true) when they are the camera side's alone, kept by the classes its
    /// subpath sampled (`bounces`), which keep this one.
    #[inline]
    pub(crate) fn ends_after(&self, x: &Vertex) -> Option<bool> {
        match x.classes.verdict(&self.light_paths) {
            bounces::Verdict::Kept => Some(false),
            bounces::Verdict::Dropped => None,
            bounces::Verdict::Ambiguous => {
                let spent = x.hit.is_some_and(|h| self.light_paths.spent(h.light_path));
                (!spent).then_some(true)
            }
        }
    }

    /// Whether a path whose counted bounces are `c` is made by every strategy (false: the
    /// bounce limits drop it, or leave it to the camera side: `bounces`).
    #[inline]
    pub(crate) fn kept(&self, c: bounces::Classes) -> bool {
        c.verdict(&self.light_paths) == bounces::Verdict::Kept
    }

    /// Film → Transparent Glass under roughness `threshold` (None: off), as the path tracer
    /// renders it: a camera path that has only refracted through such glass leaves the world
    /// behind it transparent. Which paths those are depends on the camera prefix alone, so
    /// the triangles of every material that may refract are restricted (`visibility`): paths
    /// meeting them are made by s = 0 and s = 1 and weighed as the path tracer weighs them.
    /// Nothing changes without a transparent film.
    pub fn with_transparent_glass(self, scene: &crate::scene::Scene, threshold: Option<f32>) -> Self {
        if threshold.is_none() || !self.transparent_background {
            return self;
        }
        let restriction = Arc::new(visibility::Restriction::build(scene, true));
        BdptIntegrator {
            lights: Arc::new(BdptLights::new(scene, |i| restriction.light(i))),
            restriction,
            glass_threshold: threshold,
            ..self
        }
    }

    /// Human-readable description.
    pub fn describe(&self) -> String {
        let mut s = format!("bdpt (max depth {}, russian roulette from depth {})", self.max_depth, self.rr_depth);
        if let Some(st) = self.strategy {
            s += &format!(
                ", only strategy s={} t={} {}",
                st.s,
                st.t,
                if st.weighted { "weighted" } else { "unweighted" }
            );
        }
        s
    }

    /// The path tracer that continues camera paths at vertices in media and into
    /// subsurface scattering.
    fn continuation(&self) -> crate::integrator::path::PathIntegrator {
        crate::integrator::path::PathIntegrator {
            max_depth: self.max_depth,
            rr_depth: self.rr_depth,
            transparent_background: self.transparent_background,
            glass_threshold: None,
            light_passes: false,
            // Passes and groups are filed through `Filing` into the camera sample.
            light_groups: false,
            merged_delta_light: false,
            // Fast GI is the path tracer's own (warned for the others).
            fast_gi: None,
            // Continued paths are past the first hit, where the albedo is taken.
            guides: true,
        }
    }

    /// The solid-angle density a delta lobe's direction is given in the MIS densities.
    #[inline]
    fn delta_solid_angle(&self) -> f32 {
        if self.delta_geometry { 1.0 } else { 0.0 }
    }

    /// The area density of vertex `v` reached from `from` through a delta lobe.
    #[inline]
    fn delta_area(&self, v: &Vertex, from: Vec3) -> f32 {
        v.area_density(self.delta_solid_angle(), from)
    }

    #[inline]
    fn allowed(&self, s: usize, t: usize) -> bool {
        match self.strategy {
            None => true,
            Some(st) => st.s as usize == s && st.t as usize == t,
        }
    }

    #[inline]
    fn mis(&self, w: f32) -> f32 {
        match self.strategy {
            Some(Strategy { weighted: false, .. }) => 1.0,
            _ => w,
        }
    }
}

pub mod bounces;
pub mod catcher;
pub mod connect;
pub mod contact;
pub mod found_lights;
pub mod passes;
pub mod path_emitters;
pub mod subpath;
pub mod vertex;
pub mod visibility;
pub mod volume_records;

use passes::First;
pub use passes::Ledger;
use vertex::*;

/// Per-worker scratch memory, reused for every sample (nothing is allocated per sample).
#[derive(Debug, Default)]
pub struct BdptScratch {
    pub(crate) cam: Vec<Vertex>,
    pub(crate) light: Vec<Vertex>,
    pub(crate) dens: Box<PathDensities>,
    /// The class of the camera subpath's first scattering event (`passes`).
    pub(crate) first: First,
    /// Where the camera subpath split at a shadow catcher (`catcher`; boxed: it holds a
    /// path state, and tiles keep this scratch inline).
    pub(crate) split: Box<crate::integrator::catcher::Split>,
    /// The camera sample's light groups when it split: a split path files nothing in them
    /// from the catcher on, as the path tracer's (`catcher`). Boxed: the sums are large.
    pub(crate) groups_at_split: Box<crate::scene::light_groups::GroupSums>,
    /// What the strategies that take the light subpath gave (VCM's pilot reads it). Boxed:
    /// tiles keep this scratch inline.
    pub(crate) tally: Box<Tally>,
    /// With `volume_merging`: the light subpath's segments in media after delta bounces.
    pub(crate) volume_segments: Vec<volume_records::LightSegment>,
    /// With `volume_merging`: the camera subpath's first medium vertex, if it merges
    /// (boxed, as `split`: tiles keep this scratch inline).
    pub(crate) medium_vertex: Box<Option<volume_records::MediumVertex>>,
}

/// Sums over the camera samples of one scratch: the weighted contributions of the
/// connections s ≥ 2, t ≥ 2, the luminance of the light tracing splats (t = 1), and
/// the rays the s = 1 light samples cast. VCM's pilot splits the image and its cost between
/// the camera side and the light subpath with them (`vcm::share`).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Tally {
    /// Σ weighted contributions of s ≥ 2, t ≥ 2 (for the current camera sample: reset by the reader).
    pub light: Rgb,
    /// Σ luminance of the weighted t = 1 splats.
    pub splat: f64,
    /// Rays cast by s = 1's light samples.
    pub s1_rays: u64,
}

impl BdptScratch {
    /// Scratch for paths of up to `max_depth` scattering events.
    pub fn new(max_depth: u32) -> Self {
        let n = max_depth as usize + 3;
        BdptScratch {
            cam: Vec::with_capacity(n),
            light: Vec::with_capacity(n),
            dens: Box::default(),
            first: First::default(),
            split: Default::default(),
            groups_at_split: Default::default(),
            tally: Box::default(),
            volume_segments: Vec::new(),
            medium_vertex: Box::default(),
        }
    }
}

/// Where the film and camera are, for light tracing (t = 1).
pub struct FilmTarget<'a> {
    /// The camera.
    pub camera: &'a CameraRays,
    /// The pixel filter (splats are spread with it).
    pub filter: &'a Filter,
    /// Splats of this worker.
    pub splats: &'a mut SplatBuffer,
}

/// The light subpath's sample stream: an independent scramble of the pixel's Sobol points.
#[inline]
pub(crate) fn light_sampler(seed: u32, px: u32, py: u32, index: u32) -> PixelSampler {
    PixelSampler::new(hash_combine(&[seed, 0x4c49_4748]), px, py, index)
}

/// The stream of the light samples at camera vertices (s = 1): one set of dimensions per
/// camera vertex, at a fixed place. Drawn from the camera stream after the camera subpath,
/// they would land on dimensions that move with each sample's camera-path length, so a
/// pixel's samples of its first hit's light sample would not be stratified (issue 24).
#[inline]
pub(crate) fn connection_sampler(seed: u32, px: u32, py: u32, index: u32) -> PixelSampler {
    PixelSampler::new(hash_combine(&[seed, 0x434f_4e4e]), px, py, index)
}

impl BdptIntegrator {
    /// Traces one camera sample: returns the camera-side contributions (s ≥ 0, t ≥ 2) and
    /// splats the light-tracing ones (t = 1) into `film.splats`.
    #[allow(clippy::too_many_arguments)]
    pub fn li(
        &self,
        ctx: &SceneContext,
        ray: &CameraRay,
        sampler: &mut PixelSampler,
        light_stream: (u32, u32, u32, u32),
        film: &mut FilmTarget,
        scratch: &mut BdptScratch,
        stats: &mut RayStats,
    ) -> CameraSample {
        let mut out = CameraSample { depth: f32::INFINITY, ..Default::default() };
        let mut radiance = Rgb::ZERO;
        self.camera_subpath(ctx, ray, sampler, film.camera, scratch, &mut out, &mut radiance, stats);
        let (seed, px, py, index) = light_stream;
        let mut ls = light_sampler(seed, px, py, index);
        self.light_subpath(ctx, &mut ls, scratch, stats);
        let mut cs = connection_sampler(seed, px, py, index);
        radiance += self.connect_all(ctx, &mut cs, film, scratch, &mut out, stats);
        out.radiance = radiance;
        self.file_catcher(ctx, sampler, scratch, &mut out, stats);
        if !self.transparent_background {
            out.make_opaque();
        }
        out
    }

    /// A camera sample outside a panoramic camera's lens (`CameraRay::is_blind`): black and
    /// opaque, but its light subpath is still traced and splatted through the camera
    /// (t = 1). Splats are normalised by every camera sample, blind ones included, so
    /// leaving their light subpaths out darkened light tracing by the lens's share of the
    /// frame (π/4 for a fisheye's circle in a square frame).
    #[allow(clippy::too_many_arguments)]
    pub fn li_blind(
        &self,
        ctx: &SceneContext,
        ray: &CameraRay,
        light_stream: (u32, u32, u32, u32),
        film: &mut FilmTarget,
        scratch: &mut BdptScratch,
        stats: &mut RayStats,
    ) -> CameraSample {
        if !film.camera.light_tracing_reaches() {
            return CameraSample::blind();
        }
        let (seed, px, py, index) = light_stream;
        let mut ls = light_sampler(seed, px, py, index);
        self.light_subpath(ctx, &mut ls, scratch, stats);
        self.splat_blind(ctx, ray, light_stream, film, scratch, stats);
        CameraSample::blind()
    }

    /// The t = 1 strategies of the light subpath in `scratch.light` for a blind camera
    /// sample: the camera subpath is its camera vertex alone, so `connect_all` makes only
    /// the splats.
    pub(crate) fn splat_blind(
        &self,
        ctx: &SceneContext,
        ray: &CameraRay,
        (seed, px, py, index): (u32, u32, u32, u32),
        film: &mut FilmTarget,
        scratch: &mut BdptScratch,
        stats: &mut RayStats,
    ) {
        self.camera_vertex_alone(ctx, ray, scratch);
        let mut cs = connection_sampler(seed, px, py, index);
        let mut out = CameraSample::blind();
        self.connect_all(ctx, &mut cs, film, scratch, &mut out, stats);
    }
}
