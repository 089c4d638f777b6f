//! Vertex connection and merging (Georgiev, Křivánek, Davidovič & Slusallek 2012, "Light
//! transport simulation with vertex connection and merging"): BDPT's connections and
//! photon merging combined by multiple importance sampling, with SPPM's shrinking radius.
//! The integrator to pick when unsure: it renders diffuse scenes like BDPT and caustics
//! (seen directly or through glass) like photon mapping.
//!
//! Each iteration takes one sample per pixel (sample index = iteration):
//! 1. **Light pass**: one light subpath per pixel (BDPT's `light_subpath`, the same
//!    stream BDPT takes for that sample), or for a share f of the pixels, chosen per sample
//!    by a stream of its own, where a pilot found that the light subpaths give little for
//!    their cost (`share.rs`: under a sky f ≈ 0.3; the strategies that take the light
//!    subpath count f samples in the weights, `bdpt::mis::PathDensities::light_share`, and
//!    η = f N π r²); its non-delta surface vertices from the second
//!    on (z_m, m ≥ 2: direct light is the connections', `bdpt::mis::MIN_MERGE_VERTEX`) are
//!    stored with the light side of their recursive MIS quantities (`merge::MergeRecord`)
//!    in a hash grid of cell 2r (`grid.rs`, records in its bucket order), and the whole
//!    subpath is kept for its pixel's connections (`light_store.rs`: each light subpath is
//!    traced once).
//! 2. **Camera pass**: per pixel, BDPT's camera sample (camera subpath, emission found by
//!    it (s = 0), light sampling (s = 1), connections to the pixel's own light subpath
//!    (s, t ≥ 2) and light tracing (t = 1), splatted), all weighted over connections *and*
//!    merges (`bdpt::mis` with η); then each non-delta camera vertex merges with the stored
//!    vertices within r (`merge.rs`, weights in recursive form, `mis.rs`), the kernel
//!    normalised by f N π r² (f N light subpaths expected per iteration, N the window's pixels).
//!
//! Radius: r_i = r₀ · i^((α−1)/2), i = 1, 2, … the global iteration (so chunks of samples
//! continue the schedule, and merged chunks equal a single render), α = 0.75; r₀ is
//! `--vcm-radius`, else one pixel footprint (`VCM_RADIUS_FOOTPRINTS`) at the median first hit
//! of a 32 × 32 grid of pixels, clamped to [10⁻⁴, 5·10⁻²] × the scene's bounding radius
//! (SPPM's rule, made one radius for the whole image). The estimate is consistent: merging's bias vanishes as r → 0.
//!
//! What is approximated or left out (as BDPT): light subpaths start at every light but soft
//! point lights and spots with a radius (the world and suns on a disk beyond the scene, as BDPT's;
//! those, and emitters whose node graph reads the Light Path node, are reached by s = 0
//! and s = 1, weighted as the path tracer weights them, and never merged:
//! `bdpt::path_emitters`); paths with a vertex in a medium are path
//! traced from the camera side (light subpaths cross media attenuated, without scattering),
//! except those whose light reached the camera subpath's first medium vertex through delta
//! bounces alone, which are merged there (`volume_merge.rs`); the subsurface part of a
//! camera vertex's material is path traced. Merges are found by distance alone (a thin wall's other side within r leaks,
//! vanishing with r); light and camera subpaths of different pixels are traced at their
//! own shutter times, so merges join paths of different times under motion blur. Only the
//! Combined pass and the data passes are rendered (light passes are refused by settings).

pub mod grid;
pub(crate) mod light_store;
pub mod merge;
pub mod mis;
pub mod render;
pub mod share;
pub mod volume_merge;

use crate::integrator::bdpt::BdptIntegrator;

/// The exponent of the radius schedule (r_i ∝ i^((α−1)/2)), as the task and SPPM's
/// usual choice: closer to 1 shrinks slower (less noise, more bias early).
pub const VCM_ALPHA: f32 = 0.75;

/// The automatic initial radius in pixel footprints at the first hit. SPPM takes 3; VCM
/// merges only where MIS prefers it, so a smaller radius costs it less noise, and its
/// bias (light lost where the disk overhangs an edge) is proportional to r. Measured
/// (bench/integrators.py, 10 s, 128x96, Cornell box, one run): 3 footprints (r = 0.024)
/// left blocks 1-8 % dark, relMSE 2.2x the path tracer's; one footprint (r = 0.0058) blocks
/// within 1 %, 1.75x; on the glass caustic 0.14x and 0.137x (docs/benchmarks.md).
pub const VCM_RADIUS_FOOTPRINTS: f32 = 1.0;

/// Which strategies to combine (debugging and tests).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VcmMode {
    /// Connections and merging.
    Full,
    /// Connections only: BDPT, bit for bit.
    Connect,
}

/// VCM's parameters.
#[derive(Clone, Debug)]
pub struct VcmIntegrator {
    /// The connection strategies (and their subpaths).
    pub bdpt: BdptIntegrator,
    /// Strategies used.
    pub mode: VcmMode,
    /// Initial merging radius (None: automatic, see the module's doc).
    pub radius: Option<f32>,
}

impl VcmIntegrator {
    /// VCM over the scene's lights.
    pub fn new(
        scene: &crate::scene::Scene,
        max_depth: u32,
        transparent_background: bool,
        mode: VcmMode,
        radius: Option<f32>,
    ) -> Self {
        let bdpt = BdptIntegrator {
            delta_geometry: mode == VcmMode::Full,
            volume_merging: mode == VcmMode::Full,
            ..BdptIntegrator::new(scene, max_depth, transparent_background, None)
        };
        VcmIntegrator { bdpt, mode, radius }
    }

    /// Film → Transparent Glass under `threshold`, as BDPT renders it
    /// (`BdptIntegrator::with_transparent_glass`).
    pub fn with_transparent_glass(self, scene: &crate::scene::Scene, threshold: Option<f32>) -> Self {
        VcmIntegrator { bdpt: self.bdpt.with_transparent_glass(scene, threshold), ..self }
    }

    /// Human-readable description.
    pub fn describe(&self) -> String {
        format!(
            "vcm (max depth {}, russian roulette from depth {}, {}, initial radius {}, alpha {})",
            self.bdpt.max_depth,
            self.bdpt.rr_depth,
            match self.mode {
                VcmMode::Full => "connections and merging",
                VcmMode::Connect => "connections only",
            },
            self.radius.map_or(format!("{VCM_RADIUS_FOOTPRINTS} pixel footprints"), |r| r.to_string()),
            VCM_ALPHA
        )
    }
}
