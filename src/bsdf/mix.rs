//! A weighted mixture of closures: what a Blender shader graph's Surface output becomes
//! (Mix Shader and Add Shader over Diffuse, Glossy, Glass, Translucent, Sheen and Principled
//! BSDFs). To every integrator it is one BSDF:
//!
//! * `eval` is the weighted sum Σ wₖ fₖ(wo, wi) of the lobes (weights are RGB: a closure's
//!   colour times the mix factors above it, as Cycles weights its closures);
//! * `sample` picks lobe k with probability pₖ ∝ lum(wₖ) × Aₖ(wo) (Aₖ an estimate of the
//!   lobe's albedo at wo, the same choice Cycles makes by "sample weight"), samples it and,
//!   for a non-delta direction, returns the value and the density of the whole mixture,
//!   Σ pₖ pdfₖ(wo, wi); a delta direction returns that lobe's value times its weight and
//!   pₖ times its probability;
//! * `pdf` is Σ pₖ pdfₖ, so sampling and density agree exactly (chi-square tested below).
//!
//! Each closure has its own frame, as each Cycles closure has its own normal (a Bump or
//! Normal Map on one of two mixed shaders): wo and wi go into the closure's frame, its value
//! is scaled by its cosine over the mixture's (the integrators multiply by the mixture's),
//! and densities, being per solid angle, add as they are. Diffuse-class lobes on a normal
//! other than the interpolated one carry Cycles' bump terminator term (`bump`); which normal
//! each closure gets (bent or not) is the shader's choice (`shader::shade`).
//!
//! Capacity: [`MAX_LOBES`] small lobes plus [`MAX_PBR`] Principled BSDFs ([`PbrBsdf`], itself
//! layered), each evaluated in full. Past them the last slot of each kind holds one of the
//! closures offered to it, chosen by weight at each point, with the weight of them all
//! (`shader::closure`: a weighted reservoir, so a pixel averages the whole mixture). The
//! Principled parts are the bulk of the enum's size (`Bsdf` is copied into BDPT vertices and
//! SPPM's visible points; see [`Bsdf`](super::Bsdf)).
//!
//! Lobes are two-sided like [`PbrBsdf`]: wo below the mixture's shading plane mirrors both
//! directions. Translucent sends light to the side opposite wo.

use super::ashikhmin_shirley::AshikhminShirley;
use super::dielectric::{DielectricBsdf, SMOOTH_ROUGHNESS};
use super::hair::BumpCut;
use super::microfacet::{Ggx, conductor_fresnel, f82_b_through, f82_tint, f82_tint_b, reflect, schlick_weight};
use super::microfiber::Microfiber;
use super::oren_nayar::OrenNayar;
use super::pbr::bump_shadowing;
use super::thin_film::{conductor_film_reflectance, f82_conductor_index};
use super::velvet::Velvet;
use super::{BsdfSample, LobeKind, PbrBsdf, albedo::specular_albedo};
use crate::math::{Frame, Rgb, luminance};
use crate::sampling::warp::{cosine_hemisphere, cosine_hemisphere_pdf, uniform_cone, uniform_cone_pdf};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Small lobes a mixture holds besides its Principled part.
pub const MAX_LOBES: usize = 4;

/// Fresnel of a GGX reflection lobe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GlossyFresnel {
    /// Constant (Cycles' Glossy BSDF: the colour, which the lobe's weight carries).
    Constant,
    /// Schlick's with this F0 (the Metallic BSDF's base colour; its weight is grey).
    Schlick(Rgb),
    /// Cycles' F82-tint (Kutz et al., "Novel aspects of the Adobe Standard Material"):
    /// Schlick's minus b cos θ (1 − cos θ)⁶, saturated, with b chosen so that at cos θ = 1/7
    /// (about 82°) it is Schlick's times the tint (the Metallic BSDF's Edge Tint).
    F82Tint {
        /// Normal-incidence reflectance (the base colour).
        f0: Rgb,
        /// The (1 − cos)⁶ term's factor from the tint.
        b: Rgb,
    },
    /// Cycles' physical conductor: the exact Fresnel of the complex index n + ik per channel.
    Conductor {
        /// Real part (the Metallic BSDF's IOR).
        n: Rgb,
        /// Imaginary part (its Extinction).
        k: Rgb,
    },
    /// A thin film (thickness nm, film IOR) on the F82-tint conductor (`thin_film.rs`).
    F82Film {
        /// Normal-incidence reflectance (the base colour).
        f0: Rgb,
        /// The F82-tint factor (zero: Schlick's).
        b: Rgb,
        /// (thickness nm, film IOR).
        film: (f32, f32),
    },
    /// A thin film (thickness nm, film IOR) on the physical conductor n + ik.
    ConductorFilm {
        /// Real part of the index.
        n: Rgb,
        /// Imaginary part.
        k: Rgb,
        /// (thickness nm, film IOR).
        film: (f32, f32),
    },
}

impl GlossyFresnel {
    /// The Metallic BSDF's F82-tint Fresnel of colour `f0` and edge tint `tint` (both in
    /// [0, 1]): Schlick's when the tint is white, as Cycles (`fresnel_f82tint_B`).
    pub fn f82_tint(f0: Rgb, tint: Rgb) -> Self {
        if tint == Rgb::ONE {
            return GlossyFresnel::Schlick(f0);
        }
        GlossyFresnel::F82Tint { f0, b: f82_tint_b(f0, tint) }
    }

    /// This conductor's Fresnel under a film of `thickness` nm and index `ior`, as Cycles' Metallic
    /// BSDF puts one above Cycles' cutoff of 0.1 nm (a constant Fresnel takes none).
    pub fn with_film(self, thickness: f32, ior: f32) -> Self {
        if !(thickness > 0.1) || !thickness.is_finite() || !ior.is_finite() {
            return self;
        }
        let film = (thickness, ior.max(1e-5));
        match self {
            GlossyFresnel::Constant => self,
            GlossyFresnel::Schlick(f0) => GlossyFresnel::F82Film { f0, b: Rgb::ZERO, film },
            GlossyFresnel::F82Tint { f0, b } => GlossyFresnel::F82Film { f0, b, film },
            GlossyFresnel::Conductor { n, k } => GlossyFresnel::ConductorFilm { n, k, film },
            GlossyFresnel::F82Film { f0, b, .. } => GlossyFresnel::F82Film { f0, b, film },
            GlossyFresnel::ConductorFilm { n, k, .. } => GlossyFresnel::ConductorFilm { n, k, film },
        }
    }

    /// The reflectance at cos θ to the microfacet normal.
    #[inline]
    fn at(&self, cos: f32) -> Rgb {
        match self {
            GlossyFresnel::F82Film { f0, b, film: (d, ior) } => {
                let (n, k, g) = f82_conductor_index(*f0, *b);
                conductor_film_reflectance(cos, *ior, *d, n, k, Some(g))
            }
            GlossyFresnel::ConductorFilm { n, k, film: (d, ior) } => {
                conductor_film_reflectance(cos, *ior, *d, *n, *k, None)
            }
            GlossyFresnel::Constant => Rgb::ONE,
            GlossyFresnel::Schlick(f0) => *f0 + (Rgb::ONE - *f0) * schlick_weight(cos),
            GlossyFresnel::F82Tint { f0, b } => f82_tint(*f0, *b, cos),
            GlossyFresnel::Conductor { n, k } => conductor_fresnel(cos, *n, *k),
        }
    }
}

/// One closure of a mixture, with unit weight (the mixture holds the weights).
#[derive(Clone, Copy, Debug)]
pub enum Lobe {
    /// Lambertian reflection.
    Diffuse,
    /// Rough diffuse reflection: Fujii's improved Oren-Nayar with OpenPBR's energy-preserving
    /// multiple-scattering term, as Cycles' Diffuse BSDF with a roughness (`oren_nayar.rs`).
    OrenNayar(OrenNayar),
    /// Lambertian transmission to the other side (Translucent BSDF).
    Translucent,
    /// GGX reflection with multiple-scattering compensation (Glossy, Metallic).
    Glossy {
        /// Distribution.
        ggx: Ggx,
        /// Perceptual roughness (the albedo table's axis).
        roughness: f32,
        /// Fresnel.
        fresnel: GlossyFresnel,
        /// Kulla & Conty's F_ms per channel (zero: smooth, no compensation).
        fms: Rgb,
    },
    /// A dielectric interface (Glass, Refraction) with white tint.
    Dielectric(DielectricBsdf),
    /// The Sheen BSDF, white: Cycles' microfiber sheen (`microfiber.rs`).
    Sheen {
        /// Roughness.
        roughness: f32,
    },
    /// The Toon BSDF as Cycles' `bsdf_toon.h`: f cos θ constant inside a cone of half-angle
    /// Size × π/2 around the normal (Diffuse) or wo's mirror direction (Glossy), falling
    /// linearly to 0 over a further Smooth × π/2, sampled uniformly over the cone that holds it.
    Toon(Toon),
    /// The Glossy BSDF's Ashikhmin-Shirley distribution, white (`ashikhmin_shirley.rs`).
    AshikhminShirley(AshikhminShirley),
    /// The Sheen BSDF's Ashikhmin distribution (Velvet), white (`velvet.rs`).
    Velvet(Velvet),
}

/// Cycles' toon lobe (see [`Lobe::Toon`]).
#[derive(Clone, Copy, Debug)]
pub struct Toon {
    /// Half-angle of the full-intensity cone (radians).
    size: f32,
    /// Width of the linear fall-off beyond it (radians).
    smooth: f32,
    /// Around wo's mirror direction (Glossy) instead of the normal (Diffuse).
    glossy: bool,
}

impl Toon {
    /// The Glossy Toon (around wo's mirror direction), not the Diffuse one.
    pub fn is_glossy(&self) -> bool {
        self.glossy
    }

    /// Cycles' setup: Size clamped to [10⁻⁵, 1] and Smooth to [0, 1], both × π/2.
    pub fn new(size: f32, smooth: f32, glossy: bool) -> Self {
        let half_pi = std::f32::consts::FRAC_PI_2;
        let size = if size.is_finite() { size.clamp(1e-5, 1.0) } else { 1.0 };
        let smooth = if smooth.is_finite() { smooth.clamp(0.0, 1.0) } else { 0.0 };
        Toon { size: size * half_pi, smooth: smooth * half_pi, glossy }
    }

    /// The cosine of the sampled cone's half-angle, min(size + smooth, π/2).
    #[inline]
    fn cos_cone(&self) -> f32 {
        (self.size + self.smooth).min(std::f32::consts::FRAC_PI_2).cos()
    }

    /// The cone's axis for wo.
    #[inline]
    fn axis(&self, wo: Vec3) -> Vec3 {
        if self.glossy { Vec3::new(-wo.x, -wo.y, wo.z) } else { Vec3::Z }
    }

    /// f cos θ / the cone's density at angle `angle` from the axis: 1 inside, then linear.
    #[inline]
    fn intensity(&self, angle: f32) -> f32 {
        if angle < self.size {
            1.0
        } else if self.smooth != 0.0 && angle < self.size + self.smooth {
            1.0 - (angle - self.size) / self.smooth
        } else {
            0.0
        }
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let cos = self.axis(wo).dot(wi);
        if wi.z <= 0.0 || cos < self.cos_cone() {
            return 0.0;
        }
        uniform_cone_pdf(self.cos_cone())
    }

    fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wi.z <= 0.0 {
            return 0.0;
        }
        let cos = self.axis(wo).dot(wi).clamp(-1.0, 1.0);
        if cos < self.cos_cone() {
            return 0.0;
        }
        // Cycles' value is f cos θ; Caustic's lobes return f.
        uniform_cone_pdf(self.cos_cone()) * self.intensity(cos.max(0.0).acos()) / wi.z
    }

    fn sample(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let local = uniform_cone(u, self.cos_cone());
        let axis = self.axis(wo);
        if axis.z >= 1.0 - 1e-7 {
            return local;
        }
        let f = crate::math::Frame::from_normal(axis);
        f.to_world(local)
    }
}

impl Lobe {
    /// A GGX reflection lobe of `roughness` whose multiple scattering is compensated for
    /// the single-scattering Fresnel average `f_avg` (the colour for a constant Fresnel).
    pub fn glossy(roughness: f32, fresnel: GlossyFresnel) -> Self {
        let roughness = roughness.clamp(0.0, 1.0);
        Self::glossy_of(Ggx::from_roughness(roughness), roughness, fresnel)
    }

    /// A reflection lobe of widths (αx along the frame's X, αy), each clamped to [0, 1] as
    /// Cycles' setup does, GGX compensated as [`Lobe::glossy`] at Cycles' table roughness
    /// (αx αy)^¼, or Beckmann's distribution, which Cycles leaves uncompensated.
    pub fn glossy_widths(alpha_x: f32, alpha_y: f32, beckmann: bool, fresnel: GlossyFresnel) -> Self {
        let (ax, ay) = (alpha_x.clamp(0.0, 1.0), alpha_y.clamp(0.0, 1.0));
        let roughness = (ax * ay).sqrt().sqrt();
        let ggx = Ggx::anisotropic(ax, ay);
        if beckmann {
            return Lobe::Glossy { ggx: ggx.with_beckmann(), roughness, fresnel, fms: Rgb::ZERO };
        }
        Self::glossy_of(ggx, roughness, fresnel)
    }

    fn glossy_of(ggx: Ggx, roughness: f32, fresnel: GlossyFresnel) -> Self {
        let f_avg = match fresnel {
            GlossyFresnel::Constant => Rgb::ONE,
            GlossyFresnel::Schlick(f0) => f0 + (Rgb::ONE - f0) / 21.0,
            // Cycles' fresnel_f82_Fss: the cosine-weighted average of the F82-tint curve.
            // A film leaves Cycles' average the bare metal's (`microfacet_ggx_preserve_energy`
            // is given `fresnel_f82_Fss` / `fresnel_conductor_Fss` whatever the film).
            GlossyFresnel::F82Tint { f0, b } | GlossyFresnel::F82Film { f0, b, .. } => {
                (f0 + (Rgb::ONE - f0) / 21.0 - b / 126.0).clamp(Rgb::ZERO, Rgb::ONE)
            }
            // Cycles' fresnel_conductor_Fss: the F82 curve through the exact values at 0 and
            // cos θ = 1/7, averaged as above.
            GlossyFresnel::Conductor { n, k } | GlossyFresnel::ConductorFilm { n, k, .. } => {
                let f0 = conductor_fresnel(1.0, n, k);
                let b = f82_b_through(f0, conductor_fresnel(1.0 / 7.0, n, k));
                (f0 + (Rgb::ONE - f0) / 21.0 - b / 126.0).clamp(Rgb::ZERO, Rgb::ONE)
            }
        };
        let fms = if roughness < SMOOTH_ROUGHNESS {
            Rgb::ZERO
        } else {
            let e_avg = specular_albedo().e_avg_white(roughness);
            f_avg * e_avg / (Rgb::ONE - f_avg * (1.0 - e_avg)).max(Rgb::splat(1e-6))
        };
        Lobe::Glossy { ggx, roughness, fresnel, fms }
    }

    fn smooth(&self) -> bool {
        match self {
            Lobe::Glossy { roughness, .. } => *roughness < SMOOTH_ROUGHNESS,
            Lobe::Dielectric(d) => d.smooth,
            Lobe::AshikhminShirley(a) => a.smooth,
            _ => false,
        }
    }

    /// The GGX lobe's multiple-scattering factor at μo.
    fn glossy_ms(fms: Rgb, roughness: f32, mu_o: f32) -> Rgb {
        if fms == Rgb::ZERO {
            return Rgb::ONE;
        }
        let e = specular_albedo().e_white(mu_o, roughness).max(0.05);
        Rgb::ONE + fms * (1.0 / e - 1.0)
    }

    /// A rough diffuse lobe of Oren-Nayar σ `sigma` for the colour `albedo` (in [0, 1]),
    /// whose multiple scattering depends on it.
    pub fn oren_nayar(sigma: f32, albedo: Rgb) -> Self {
        Lobe::OrenNayar(OrenNayar::new(sigma, albedo))
    }

    /// Albedo estimate at wo (wo.z > 0) for choosing the lobe.
    fn albedo(&self, wo: Vec3) -> f32 {
        match self {
            Lobe::Diffuse | Lobe::Translucent | Lobe::OrenNayar(_) => 1.0,
            Lobe::Glossy { fresnel, .. } => match fresnel {
                GlossyFresnel::Constant => 1.0,
                GlossyFresnel::Schlick(f0) => luminance(*f0 + (Rgb::ONE - *f0) * schlick_weight(wo.z)),
                GlossyFresnel::F82Tint { .. }
                | GlossyFresnel::Conductor { .. }
                | GlossyFresnel::F82Film { .. }
                | GlossyFresnel::ConductorFilm { .. } => luminance(fresnel.at(wo.z)).max(1e-3),
            },
            Lobe::Dielectric(_) => 1.0,
            Lobe::Sheen { roughness } => Microfiber::at(wo, *roughness).albedo().max(1e-3),
            Lobe::Toon(_) | Lobe::AshikhminShirley(_) | Lobe::Velvet(_) => 1.0,
        }
    }

    /// f(wo, wi) with wo.z > 0.
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        match self {
            Lobe::Diffuse => Rgb::splat(if wi.z > 0.0 { FRAC_1_PI } else { 0.0 }),
            Lobe::OrenNayar(o) => o.eval(wo, wi),
            Lobe::Translucent => Rgb::splat(if wi.z < 0.0 { FRAC_1_PI } else { 0.0 }),
            Lobe::Glossy { ggx, roughness, fresnel, fms } => {
                if wi.z <= 0.0 || *roughness < SMOOTH_ROUGHNESS {
                    return Rgb::ZERO;
                }
                let h = (wo + wi).normalize();
                let spec = ggx.d(h) * ggx.g2(wo, wi) / (4.0 * wo.z * wi.z);
                let f = fresnel.at(wo.dot(h).max(0.0));
                f * Self::glossy_ms(*fms, *roughness, wo.z) * spec
            }
            Lobe::Dielectric(d) => d.eval(wo, wi),
            Lobe::Sheen { roughness } => Rgb::splat(Microfiber::at(wo, *roughness).f(wi)),
            Lobe::Toon(t) => Rgb::splat(t.eval(wo, wi)),
            Lobe::AshikhminShirley(a) => Rgb::splat(a.eval(wo, wi)),
            Lobe::Velvet(v) => Rgb::splat(v.eval(wo, wi)),
        }
    }

    /// Density of `sample` (non-delta part), wo.z > 0.
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Lobe::Sheen { roughness } => Microfiber::at(wo, *roughness).density(wi),
            Lobe::Diffuse | Lobe::OrenNayar(_) => {
                if wi.z > 0.0 {
                    cosine_hemisphere_pdf(wi.z)
                } else {
                    0.0
                }
            }
            Lobe::Translucent => {
                if wi.z < 0.0 {
                    cosine_hemisphere_pdf(-wi.z)
                } else {
                    0.0
                }
            }
            Lobe::Glossy { ggx, roughness, .. } => {
                if wi.z <= 0.0 || *roughness < SMOOTH_ROUGHNESS {
                    return 0.0;
                }
                let h = (wo + wi).normalize();
                ggx.pdf_visible_normal(wo, h) / (4.0 * wo.dot(h).max(1e-8))
            }
            Lobe::Dielectric(d) => d.pdf(wo, wi),
            Lobe::Toon(t) => t.pdf(wo, wi),
            Lobe::AshikhminShirley(a) => a.pdf(wo, wi),
            Lobe::Velvet(v) => v.pdf(wi),
        }
    }

    /// Samples wi (wo.z > 0); the value is f (delta lobes: the delta's weight / cos).
    fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        let wi = match self {
            Lobe::Diffuse | Lobe::OrenNayar(_) => cosine_hemisphere(u),
            Lobe::Sheen { roughness } => Microfiber::at(wo, *roughness).sample(u)?,
            Lobe::Translucent => {
                let w = cosine_hemisphere(u);
                Vec3::new(w.x, w.y, -w.z)
            }
            Lobe::Glossy { ggx, roughness, fresnel, fms } => {
                if *roughness < SMOOTH_ROUGHNESS {
                    let wi = Vec3::new(-wo.x, -wo.y, wo.z);
                    let f = fresnel.at(wo.z);
                    return Some(BsdfSample {
                        wi,
                        f: f * Self::glossy_ms(*fms, *roughness, wo.z) / wi.z,
                        pdf: 1.0,
                        delta: true,
                        kind: LobeKind::Glossy,
                    });
                }
                reflect(wo, ggx.sample_visible_normal(wo, u))
            }
            Lobe::Dielectric(d) => return d.sample(wo, uc, u),
            Lobe::Toon(t) => t.sample(wo, u),
            Lobe::Velvet(v) => v.sample(u),
            Lobe::AshikhminShirley(a) => {
                let wi = a.sample(wo, u);
                if a.smooth {
                    // Cycles' singular case: a mirror of weight 1.
                    let delta =
                        BsdfSample { wi, f: Rgb::splat(1.0 / wi.z), pdf: 1.0, delta: true, kind: LobeKind::Glossy };
                    return Some(delta);
                }
                wi
            }
        };
        if wi.z == 0.0 {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        let kind = match self {
            Lobe::Glossy { .. }
            | Lobe::AshikhminShirley(_)
            | Lobe::Dielectric(_)
            | Lobe::Toon(Toon { glossy: true, .. }) => LobeKind::Glossy,
            Lobe::Diffuse
            | Lobe::OrenNayar(_)
            | Lobe::Sheen { .. }
            | Lobe::Velvet(_)
            | Lobe::Translucent
            | Lobe::Toon(Toon { glossy: false, .. }) => LobeKind::Diffuse,
        };
        (pdf > 0.0).then(|| BsdfSample { wi, f: self.eval(wo, wi), pdf, delta: false, kind })
    }
}

/// A mixture's small lobes as a shader graph gathers them (weights and lobes; the frames
/// come when the mixture is built): small enough that a graph whose closures are one
/// Principled BSDF does not copy a whole [`MixBsdf`] a shading point.
#[derive(Clone, Copy, Debug)]
pub struct Lobes {
    /// Number in use.
    pub n: u8,
    /// Their weights.
    pub weights: [Rgb; MAX_LOBES],
    /// The lobes.
    pub lobes: [Lobe; MAX_LOBES],
}

impl Lobes {
    /// None.
    pub const EMPTY: Lobes = Lobes { n: 0, weights: [Rgb::ZERO; MAX_LOBES], lobes: [Lobe::Diffuse; MAX_LOBES] };

    /// Adds a lobe; false when full (the lobe is dropped). A black or non-finite weight adds
    /// nothing.
    pub fn push(&mut self, weight: Rgb, lobe: Lobe) -> bool {
        push_lobe(&mut self.n, &mut self.weights, &mut self.lobes, weight, lobe)
    }
}

/// Appends (`weight`, `lobe`) to the first `n` of `weights` and `lobes`: false when they are
/// full (the lobe is dropped); a black or non-finite weight adds nothing.
#[inline]
fn push_lobe(
    n: &mut u8,
    weights: &mut [Rgb; MAX_LOBES],
    lobes: &mut [Lobe; MAX_LOBES],
    weight: Rgb,
    lobe: Lobe,
) -> bool {
    if weight.max_element() <= 0.0 || !weight.is_finite() {
        return true;
    }
    let k = *n as usize;
    if k >= MAX_LOBES {
        return false;
    }
    weights[k] = weight;
    lobes[k] = lobe;
    *n += 1;
    true
}

/// Principled BSDFs a mixture holds in full, each with its own frame.
pub const MAX_PBR: usize = 2;

/// Mixture of weighted lobes and Principled BSDFs, each closure in its own frame.
///
/// Every frame is given within the mixture's shading frame (the one the integrators use):
/// `None` where the closure's normal is the mixture's. A closure with its own frame sees wo
/// and wi in it, and its value is scaled by its cosine over the mixture's, |wiₖ·z| / |wi·z|
/// (the integrators multiply by the latter; Cycles' closures by their own).
#[derive(Clone, Copy, Debug)]
pub struct MixBsdf {
    /// The Principled parts (meaningful where their weight is above 0).
    pub pbr: [PbrBsdf; MAX_PBR],
    /// Their weights (the mix factors above each).
    pub pbr_weights: [f32; MAX_PBR],
    /// Their frames within the mixture's.
    pub pbr_frames: [Option<Frame>; MAX_PBR],
    /// Number of small lobes in use.
    pub n: u8,
    /// Weights of the small lobes.
    pub weights: [Rgb; MAX_LOBES],
    /// The small lobes.
    pub lobes: [Lobe; MAX_LOBES],
    /// The small lobes' frames within the mixture's.
    pub frames: [Option<Frame>; MAX_LOBES],
    /// Per small lobe, the bump terminator's GGX α² (0: none; diffuse-class lobes whose
    /// normal is not the interpolated one, as Cycles shadows them).
    pub bump: [f32; MAX_LOBES],
    /// Per small lobe, Cycles' cut of its evaluation (`hair::BumpCut`): a lobe outside the
    /// diffuse class whose normal is not the interpolated one gives nothing toward light on
    /// the other side of it than the interpolated normal puts that light, in evaluation and
    /// its density, never in its own sampling (Cycles' `bump_shadowing_term`, `is_eval`).
    pub cut: [bool; MAX_LOBES],
    /// The interpolated normal in the mixture's frame (the bump terminator's reference).
    pub ns: Vec3,
}

/// Mirrors (wo, wi) so that wo is in the upper hemisphere; returns whether it did.
#[inline]
fn upper(wo: Vec3, wi: Vec3) -> (Vec3, Vec3, bool) {
    if wo.z < 0.0 { (Vec3::new(wo.x, wo.y, -wo.z), Vec3::new(wi.x, wi.y, -wi.z), true) } else { (wo, wi, false) }
}

/// `v` in `frame` (itself when the frame is the mixture's).
#[inline]
fn into_frame(frame: &Option<Frame>, v: Vec3) -> Vec3 {
    match frame {
        Some(f) => f.to_local(v),
        None => v,
    }
}

/// True when a Principled part reflects light from `wi` to `wo` (its frame): on wo's side of
/// its horizon, or across it by its coat's own normal (`PbrBsdf::reflects_across`).
#[inline]
fn part_reflects(pbr: &PbrBsdf, wo: Vec3, wi: Vec3) -> bool {
    wi.z * wo.z > 0.0 || pbr.reflects_across(wo, wi)
}

/// The closure's cosine over the mixture's: |wiₖ·z| / |wi·z| (1 in the mixture's frame).
#[inline]
fn cos_ratio(frame: &Option<Frame>, wi_k: Vec3, wi: Vec3) -> f32 {
    match frame {
        Some(_) if wi.z != 0.0 => wi_k.z.abs() / wi.z.abs(),
        Some(_) => 0.0,
        None => 1.0,
    }
}

impl Lobe {
    /// Cycles' diffuse-class closures (diffuse, Oren-Nayar, translucent, sheen, diffuse toon),
    /// `CLOSURE_IS_BSDF_DIFFUSE`: the light passes' and the light visibility's diffuse class.
    /// Not the Ashikhmin Velvet, which Cycles' closure order puts among the glossy ones (its
    /// light in the Glossy passes), though its sampled bounces are labelled diffuse.
    #[inline]
    pub fn is_diffuse_class(&self) -> bool {
        self.bump_shadowed()
    }

    /// The lobe's value does not depend on wo (it may be evaluated with wo below its own
    /// horizon, as Cycles evaluates a diffuse closure whatever the view).
    #[inline]
    fn view_free(&self) -> bool {
        matches!(self, Lobe::Diffuse | Lobe::OrenNayar(_) | Lobe::Translucent | Lobe::Toon(Toon { glossy: false, .. }))
    }

    /// Cycles' `CLOSURE_IS_BSDF_DIFFUSE` (Diffuse, Oren-Nayar, Sheen, Toon Diffuse, Translucent;
    /// not the Ashikhmin Velvet, which Cycles' closure order puts among the glossy ones), the
    /// closures its `bump_shadowing_term` cuts in sampling too and softens by their normal's
    /// tilt; it cuts every other closure's evaluation alone.
    #[inline]
    pub fn bump_shadowed(&self) -> bool {
        matches!(
            self,
            Lobe::Diffuse
                | Lobe::OrenNayar(_)
                | Lobe::Translucent
                | Lobe::Sheen { .. }
                | Lobe::Toon(Toon { glossy: false, .. })
        )
    }
}

impl MixBsdf {
    /// An empty mixture (black).
    pub fn new() -> Self {
        let black = PbrBsdf::new(Rgb::ZERO, 0.0, 1.0);
        MixBsdf {
            pbr: [black; MAX_PBR],
            pbr_weights: [0.0; MAX_PBR],
            pbr_frames: [None; MAX_PBR],
            n: 0,
            weights: [Rgb::ZERO; MAX_LOBES],
            lobes: [Lobe::Diffuse; MAX_LOBES],
            frames: [None; MAX_LOBES],
            bump: [0.0; MAX_LOBES],
            cut: [false; MAX_LOBES],
            ns: Vec3::Z,
        }
    }

    /// Adds a lobe in the mixture's frame; false when the mixture is full (the lobe is dropped).
    pub fn push(&mut self, weight: Rgb, lobe: Lobe) -> bool {
        let k = self.n as usize;
        let kept = push_lobe(&mut self.n, &mut self.weights, &mut self.lobes, weight, lobe);
        if self.n as usize > k {
            self.frames[k] = None;
            self.bump[k] = 0.0;
            self.cut[k] = false;
        }
        kept
    }

    /// Takes the small lobes `l`, in the mixture's frame (its own are replaced).
    pub fn set_lobes(&mut self, l: &Lobes) {
        (self.n, self.weights, self.lobes) = (l.n, l.weights, l.lobes);
        self.frames = [None; MAX_LOBES];
        self.bump = [0.0; MAX_LOBES];
        self.cut = [false; MAX_LOBES];
    }

    /// Scales every weight (a Transparent part's complement is divided out by the caller).
    pub fn scale(&mut self, s: f32) {
        for w in &mut self.pbr_weights {
            *w *= s;
        }
        for w in &mut self.weights[..self.n as usize] {
            *w *= s;
        }
    }

    /// True when nothing scatters.
    pub fn is_empty(&self) -> bool {
        self.n == 0 && self.pbr_weights.iter().all(|&w| w <= 0.0)
    }

    /// The Principled parts in use: index, part, weight, frame.
    #[inline]
    fn parts(&self) -> impl Iterator<Item = (usize, &PbrBsdf, f32, &Option<Frame>)> {
        (0..MAX_PBR)
            .filter(|&j| self.pbr_weights[j] > 0.0)
            .map(|j| (j, &self.pbr[j], self.pbr_weights[j], &self.pbr_frames[j]))
    }

    /// Lobe selection probabilities at wo (the mixture's frame): the Principled parts first,
    /// then the small lobes; all zero when the mixture is black.
    #[inline]
    fn choice(&self, wo: Vec3) -> ([f32; MAX_PBR + MAX_LOBES], f32) {
        let mut p = [0.0; MAX_PBR + MAX_LOBES];
        for (j, pbr, w, _) in self.parts() {
            p[j] = w * luminance(pbr.albedo()).max(1e-3);
        }
        let (wo_u, _, _) = upper(wo, Vec3::Z);
        for k in 0..self.n as usize {
            let wo_k = into_frame(&self.frames[k], wo_u);
            let l = &self.lobes[k];
            let albedo = if wo_k.z > 0.0 {
                l.albedo(wo_k)
            } else if l.view_free() {
                1.0
            } else {
                0.0
            };
            p[MAX_PBR + k] = luminance(self.weights[k]).max(1e-6) * albedo;
        }
        let total: f32 = p.iter().sum();
        if total > 0.0 {
            for x in &mut p {
                *x /= total;
            }
        }
        (p, total)
    }

    /// True when small lobe k's evaluation toward `wi` (the mixture's frame) is cut (`cut`).
    #[inline]
    fn cuts(&self, k: usize, wi: Vec3) -> bool {
        self.cut[k] && BumpCut { ns: self.ns, n: self.frames[k].map_or(Vec3::Z, |f| f.n) }.cuts(wi)
    }

    /// Small lobe k's evaluated f(wo, wi) (both in the mixture's frame, wo in its upper
    /// hemisphere) times its weight, cosine ratio and bump shadowing; 0 where cut.
    #[inline]
    fn lobe_f(&self, k: usize, wo: Vec3, wi: Vec3) -> Rgb {
        if self.cuts(k, wi) {
            return Rgb::ZERO;
        }
        self.lobe_value(k, wo, wi)
    }

    /// Small lobe k's f(wo, wi) as [`lobe_f`](Self::lobe_f), without the cut (its own sample).
    #[inline]
    fn lobe_value(&self, k: usize, wo: Vec3, wi: Vec3) -> Rgb {
        self.lobe_value_with(k, wo, wi, true)
    }

    /// [`lobe_value`](Self::lobe_value), with its bump shadowing when `bumped`.
    #[inline]
    fn lobe_value_with(&self, k: usize, wo: Vec3, wi: Vec3, bumped: bool) -> Rgb {
        let frame = &self.frames[k];
        let (wo_k, wi_k) = (into_frame(frame, wo), into_frame(frame, wi));
        let l = &self.lobes[k];
        if wo_k.z <= 0.0 && !l.view_free() {
            return Rgb::ZERO;
        }
        let mut s = cos_ratio(frame, wi_k, wi);
        if bumped && self.bump[k] > 0.0 {
            let n = frame.map_or(Vec3::Z, |f| f.n);
            s *= bump_shadowing(self.ns, n, wi, self.bump[k]);
        }
        if s == 0.0 {
            return Rgb::ZERO;
        }
        self.weights[k] * l.eval(wo_k, wi_k) * s
    }

    /// Σ of the parts' values: `part` for the Principled parts (in their frames), the small
    /// lobes that `keep` accepts.
    #[inline]
    fn eval_by(
        &self,
        wo: Vec3,
        wi: Vec3,
        part: impl Fn(&PbrBsdf, Vec3, Vec3) -> Rgb,
        keep: impl Fn(&Lobe) -> bool,
    ) -> Rgb {
        let mut f = Rgb::ZERO;
        for (_, pbr, w, frame) in self.parts() {
            let (wo_j, wi_j) = (into_frame(frame, wo), into_frame(frame, wi));
            let s = cos_ratio(frame, wi_j, wi);
            if s > 0.0 {
                f += part(pbr, wo_j, wi_j) * (w * s);
            }
        }
        let (wo, wi, _) = upper(wo, wi);
        if wo.z <= 0.0 {
            return f;
        }
        for k in 0..self.n as usize {
            if keep(&self.lobes[k]) {
                f += self.lobe_f(k, wo, wi);
            }
        }
        f
    }

    /// f(wo, wi): the weighted sum.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        self.eval_by(wo, wi, |p, wo, wi| p.eval(wo, wi), |_| true)
    }

    /// Density of `sample`.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo_u, wi_u, _) = upper(wo, wi);
        if wo_u.z <= 0.0 {
            return 0.0;
        }
        let (p, total) = self.choice(wo);
        if total <= 0.0 {
            return 0.0;
        }
        // A part samples only directions on the side of the mixture's plane that its own
        // normal gives them (`sample`).
        let side = wi.z * wo.z > 0.0;
        let mut pdf = 0.0;
        for (j, pbr, _, frame) in self.parts() {
            let (wo_j, wi_j) = (into_frame(frame, wo), into_frame(frame, wi));
            // A part's side is its own reflection, its coat's across its frame's horizon too.
            if p[j] > 0.0 && part_reflects(pbr, wo_j, wi_j) == side {
                pdf += p[j] * pbr.pdf(wo_j, wi_j);
            }
        }
        for k in 0..self.n as usize {
            let q = p[MAX_PBR + k];
            if q <= 0.0 || self.cuts(k, wi_u) {
                continue;
            }
            let frame = &self.frames[k];
            let (wo_k, wi_k) = (into_frame(frame, wo_u), into_frame(frame, wi_u));
            if (wi_k.z > 0.0) != side {
                continue;
            }
            let l = &self.lobes[k];
            if wo_k.z > 0.0 {
                pdf += q * l.pdf(wo_k, wi_k);
            } else if l.view_free() {
                // Its sampling never looks at wo: the density at wo's mirror image is the same.
                pdf += q * l.pdf(Vec3::new(wo_k.x, wo_k.y, -wo_k.z), wi_k);
            }
        }
        pdf
    }

    /// Samples a part by `uc`, then a direction.
    #[inline]
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        let (wo_u, _, flip) = upper(wo, Vec3::Z);
        if wo_u.z <= 0.0 {
            return None;
        }
        let (p, total) = self.choice(wo);
        if total <= 0.0 {
            return None;
        }
        // Which part, and uc rescaled within it (the glass lobes reuse it).
        let last = MAX_PBR + self.n as usize - 1;
        let mut k = 0;
        let mut acc = 0.0;
        while k < last && uc >= acc + p[k] {
            acc += p[k];
            k += 1;
        }
        if p[k] <= 0.0 {
            return None;
        }
        let uc_in = ((uc - acc) / p[k]).clamp(0.0, 0.999_999);
        // The sample in the part's own frame, its direction moved to the mixture's.
        // The part's own side of wo, which its sample's reflection keeps (a small lobe sees wo
        // in its upper hemisphere).
        let mut wo_side = 1.0;
        let mut across = false;
        let (s, frame, w) = if k < MAX_PBR {
            let frame = &self.pbr_frames[k];
            let wo_j = into_frame(frame, wo);
            wo_side = wo_j.z;
            let s = self.pbr[k].sample(wo_j, uc_in, u)?;
            across = self.pbr[k].reflects_across(wo_j, s.wi);
            (s, frame, Rgb::splat(self.pbr_weights[k]))
        } else {
            let i = k - MAX_PBR;
            let frame = &self.frames[i];
            let mut wo_k = into_frame(frame, wo_u);
            let l = &self.lobes[i];
            if wo_k.z <= 0.0 {
                if !l.view_free() {
                    return None;
                }
                // Sampled without looking at wo: its mirror image serves.
                wo_k.z = -wo_k.z;
            }
            (l.sample(wo_k, uc_in, u)?, frame, self.weights[i])
        };
        let mut wi = frame.map_or(s.wi, |f| f.to_world(s.wi));
        if k >= MAX_PBR && flip {
            wi.z = -wi.z;
        }
        // A reflection by the part's own normal that leaves on the other side of the mixture's
        // (the integrators take that side, checked against the geometry, as reflection or
        // transmission), or a transmission that stays on wo's side, is no sample: Cycles
        // rejects a sampled direction whose side of the surface disagrees with its label.
        if (s.wi.z * wo_side > 0.0 || across) != (wi.z * wo.z > 0.0) {
            return None;
        }
        if s.delta {
            // The delta's value over the part's cosine, moved to the mixture's cosine.
            let r = cos_ratio(frame, s.wi, wi);
            return (r > 0.0).then(|| BsdfSample { wi, f: s.f * w * r, pdf: s.pdf * p[k], delta: true, kind: s.kind });
        }
        let (mut f, mut pdf) = (self.eval(wo, wi), self.pdf(wo, wi));
        // The sampled lobe's own value and density are not cut (Cycles cuts only what the
        // other closures evaluate toward the sampled direction).
        if let Some(i) = k.checked_sub(MAX_PBR) {
            let (wo_u, wi_u, _) = upper(wo, wi);
            if self.cuts(i, wi_u) {
                f += self.lobe_value(i, wo_u, wi_u);
                pdf += p[k] * self.lobes[i].pdf(into_frame(frame, wo_u), into_frame(frame, wi_u));
            }
            // Cycles' sampled transmission skips the bump terminator term (`bsdf_sample` applies
            // it to reflections alone): a Translucent's own sample carries its whole value.
            if matches!(self.lobes[i], Lobe::Translucent) && self.bump[i] > 0.0 {
                f += self.lobe_value_with(i, wo_u, wi_u, false) - self.lobe_value(i, wo_u, wi_u);
            }
        }
        (pdf > 0.0).then_some(BsdfSample { wi, f, pdf, delta: false, kind: s.kind })
    }

    /// Filter Glossy's blur (`Bsdf::blur`): the Principled parts and every glossy and
    /// dielectric lobe at least `alpha` wide (Cycles' `bsdf_blur` touches microfacet
    /// closures only); compensations stay the original roughness's, as in Cycles.
    pub fn blur(&mut self, alpha: f32) {
        for (pbr, &w) in self.pbr.iter_mut().zip(&self.pbr_weights) {
            if w > 0.0 {
                pbr.blur(alpha);
            }
        }
        for lobe in &mut self.lobes[..self.n as usize] {
            match lobe {
                Lobe::Glossy { ggx, roughness, fms, .. } => {
                    *ggx = ggx.blurred(alpha);
                    // `roughness` decides smoothness at evaluation and is the axis of the
                    // multiple-scattering factor, which Cycles computes at setup from the
                    // unblurred width: a lobe with that factor (rough already) keeps it, a
                    // smooth one (no factor) turns rough. Read at the blurred width, the
                    // factor added up to 20 % to a blurred Multiscatter GGX mirror (a glossy
                    // floor lighting a diffuse ball: 1.011 of Cycles' mean).
                    if *fms == Rgb::ZERO {
                        let (x, y) = ggx.alphas();
                        *roughness = roughness.max(x.max(y).sqrt());
                    }
                }
                Lobe::AshikhminShirley(a) => *a = a.blurred(alpha),
                Lobe::Dielectric(d) => d.blur(alpha),
                _ => {}
            }
        }
    }

    /// Drops the caustic closures (`Bsdf::drop_caustics`): with `reflective`, the Glossy,
    /// Metallic, Ashikhmin-Shirley and glossy Toon lobes and the glass's reflection; with
    /// `refractive`, the Refraction lobes and the glass's refraction; a glass losing both is
    /// gone. The Principled parts drop theirs layer by layer.
    pub fn drop_caustics(&mut self, reflective: bool, refractive: bool) {
        for (pbr, &w) in self.pbr.iter_mut().zip(&self.pbr_weights) {
            if w > 0.0 {
                pbr.drop_caustics(reflective, refractive);
            }
        }
        for (lobe, weight) in self.lobes[..self.n as usize].iter_mut().zip(&mut self.weights) {
            let gone = match lobe {
                Lobe::Glossy { .. } | Lobe::AshikhminShirley(_) => reflective,
                Lobe::Toon(t) => t.glossy && reflective,
                Lobe::Dielectric(d) if d.refracts_only() => refractive,
                Lobe::Dielectric(d) => {
                    d.drop_caustics(reflective, refractive);
                    reflective && refractive
                }
                _ => false,
            };
            if gone {
                *weight = Rgb::ZERO;
            }
        }
    }

    /// True when every lobe in use is a delta lobe.
    pub fn is_delta(&self) -> bool {
        self.parts().all(|(_, p, _, _)| p.is_delta()) && self.lobes[..self.n as usize].iter().all(Lobe::smooth)
    }

    /// True when some lobe is a Translucent BSDF (a diffuse-class closure that sends light to
    /// the other side).
    pub fn has_translucent(&self) -> bool {
        self.lobes[..self.n as usize].iter().any(|l| matches!(l, Lobe::Translucent))
    }

    /// True when some lobe transmits.
    pub fn transmits(&self) -> bool {
        self.parts().any(|(_, p, _, _)| p.transmits())
            || self.lobes[..self.n as usize].iter().any(|l| matches!(l, Lobe::Translucent | Lobe::Dielectric(_)))
    }

    /// [`Bsdf::glass_alpha2`]: the roughest refracting lobe's αx·αy (the sampled one is not
    /// known after a mixture's sample), infinite when none refracts.
    pub fn glass_alpha2(&self) -> f32 {
        let pbr = self.parts().filter(|(_, p, _, _)| p.transmits()).map(|(_, p, _, _)| p.glass.alpha2());
        let lobes = self.lobes[..self.n as usize].iter().filter_map(|l| match l {
            Lobe::Dielectric(d) => Some(d.alpha2()),
            _ => None,
        });
        lobes.chain(pbr).reduce(f32::max).unwrap_or(f32::INFINITY)
    }

    /// The first refracting Principled part.
    fn refracting_part(&self) -> Option<(&PbrBsdf, &Option<Frame>)> {
        self.parts().find(|(_, p, _, _)| p.transmits()).map(|(_, p, _, f)| (p, f))
    }

    /// 1/η² of the refracting part: the first refracting Principled part's glass, else the
    /// first dielectric lobe (a mixture of two glasses of different IOR is warned at load;
    /// the first one's η applies to the adjoint correction).
    pub fn refraction_adjoint_scale(&self) -> f32 {
        if let Some((p, _)) = self.refracting_part() {
            return if p.glass.thin { 1.0 } else { 1.0 / (p.glass.eta * p.glass.eta) };
        }
        for l in &self.lobes[..self.n as usize] {
            if let Lobe::Dielectric(d) = l {
                return if d.thin { 1.0 } else { 1.0 / (d.eta * d.eta) };
            }
        }
        1.0
    }

    /// The adjoint ratio of rough glass's compensation (of the refracting part named by
    /// [`refraction_adjoint_scale`](Self::refraction_adjoint_scale)).
    pub fn refraction_adjoint_ratio(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if let Some((p, frame)) = self.refracting_part() {
            return p.refraction_adjoint_ratio(into_frame(frame, wo), into_frame(frame, wi));
        }
        for k in 0..self.n as usize {
            if let Lobe::Dielectric(d) = &self.lobes[k] {
                let (wo, wi, _) = upper(wo, wi);
                let frame = &self.frames[k];
                return d.adjoint_ratio(into_frame(frame, wo), into_frame(frame, wi));
            }
        }
        Rgb::ONE
    }

    /// The Principled parts' subsurface probability, each times its share of the mixture.
    pub fn subsurface_weight(&self, wo: Vec3) -> f32 {
        let s: f32 = self.parts().map(|(_, p, w, frame)| w * p.subsurface_weight(into_frame(frame, wo))).sum();
        s.min(1.0)
    }

    /// The Principled part whose subsurface weighs most (its base is the walk's).
    pub fn subsurface_part(&self) -> &PbrBsdf {
        let j = if self.pbr_weights[1] * self.pbr[1].subsurface > self.pbr_weights[0] * self.pbr[0].subsurface {
            1
        } else {
            0
        };
        &self.pbr[j]
    }

    /// Denoising albedo: the weighted sum of the lobes' colours.
    pub fn albedo(&self) -> Rgb {
        let mut a = Rgb::ZERO;
        for (_, p, w, _) in self.parts() {
            a += p.albedo() * w;
        }
        for k in 0..self.n as usize {
            let c = match self.lobes[k] {
                Lobe::Glossy { fresnel: GlossyFresnel::Schlick(f0), .. } => f0,
                _ => Rgb::ONE,
            };
            a += self.weights[k] * c;
        }
        a
    }
}

impl Default for MixBsdf {
    fn default() -> Self {
        Self::new()
    }
}

mod passes;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{ChiSquareTest, Pcg32, assert_chi2};

    fn mixtures() -> Vec<(&'static str, MixBsdf)> {
        let mut a = MixBsdf::new();
        a.push(Rgb::new(0.5, 0.4, 0.3), Lobe::Diffuse);
        a.push(Rgb::splat(0.3), Lobe::glossy(0.3, GlossyFresnel::Constant));
        a.push(Rgb::splat(0.2), Lobe::Translucent);
        a.push(Rgb::new(0.3, 0.2, 0.1), Lobe::oren_nayar(0.8, Rgb::new(0.7, 0.5, 0.3)));
        let mut b = MixBsdf::new();
        b.push(Rgb::splat(0.5), Lobe::Dielectric(DielectricBsdf::new(1.5, 0.4, false, Rgb::ONE).with_multiscatter()));
        b.push(Rgb::splat(0.3), Lobe::Sheen { roughness: 0.5 });
        b.pbr[0] = PbrBsdf::new(Rgb::new(0.8, 0.5, 0.2), 0.5, 0.6);
        b.pbr_weights[0] = 0.4;
        let mut c = MixBsdf::new();
        c.push(Rgb::splat(0.6), Lobe::glossy(0.7, GlossyFresnel::Schlick(Rgb::new(0.9, 0.6, 0.3))));
        c.push(Rgb::splat(0.4), Lobe::Dielectric(DielectricBsdf::new(1.0 / 1.33, 0.5, false, Rgb::ONE)));
        let mut d = MixBsdf::new();
        d.push(
            Rgb::splat(0.5),
            Lobe::glossy(0.4, GlossyFresnel::f82_tint(Rgb::new(0.9, 0.6, 0.3), Rgb::new(0.5, 0.8, 1.0))),
        );
        d.push(
            Rgb::splat(0.5),
            Lobe::Dielectric(DielectricBsdf::new(1.0 / 1.5, 0.4, false, Rgb::ONE).refraction_only()),
        );
        let mut e = MixBsdf::new();
        e.push(Rgb::splat(0.4), Lobe::glossy_widths(0.3, 0.05, true, GlossyFresnel::Constant));
        e.push(Rgb::splat(0.3), Lobe::glossy_widths(0.08, 0.5, false, GlossyFresnel::Constant));
        e.push(
            Rgb::splat(0.3),
            Lobe::Dielectric(DielectricBsdf::new(1.5, 0.5, false, Rgb::ONE).with_beckmann().refraction_only()),
        );
        let mut f = MixBsdf::new();
        f.push(
            Rgb::splat(0.5),
            Lobe::Dielectric(DielectricBsdf::new(1.0 / 1.45, 0.4, false, Rgb::ONE).with_beckmann()),
        );
        f.push(Rgb::splat(0.5), Lobe::glossy_widths(0.36, 0.36, true, GlossyFresnel::Constant));
        let mut g = MixBsdf::new();
        g.push(Rgb::splat(0.5), Lobe::Toon(Toon::new(0.5, 0.2, false)));
        g.push(Rgb::splat(0.3), Lobe::Toon(Toon::new(0.2, 0.1, true)));
        g.push(Rgb::splat(0.2), Lobe::Toon(Toon::new(0.9, 0.5, true)));
        // Every closure in a frame of its own (tilted normals, a turned tangent), two
        // Principled parts, a bump-shadowed diffuse lobe: Cycles' per-closure normals.
        let tilted = |x: f32, y: f32| Some(Frame::from_normal(Vec3::new(x, y, 1.0).normalize()));
        let mut h = MixBsdf::new();
        h.pbr[0] = PbrBsdf::new(Rgb::new(0.9, 0.6, 0.3), 1.0, 0.15);
        h.pbr_weights[0] = 0.3;
        h.pbr_frames[0] = tilted(0.4, -0.2);
        h.pbr[1] = PbrBsdf::new(Rgb::new(0.2, 0.5, 0.8), 0.0, 0.8);
        h.pbr_weights[1] = 0.3;
        h.push(Rgb::splat(0.2), Lobe::Diffuse);
        h.frames[0] = tilted(-0.5, 0.3);
        h.bump[0] = 0.2;
        h.push(Rgb::splat(0.2), Lobe::glossy_widths(0.3, 0.08, false, GlossyFresnel::Constant));
        h.frames[1] = Some(Frame::from_normal_tangent(Vec3::new(0.2, 0.3, 1.0).normalize(), Vec3::new(1.0, 1.0, 0.0)));
        let mut i = MixBsdf::new();
        i.push(Rgb::splat(0.4), Lobe::Translucent);
        i.frames[0] = tilted(0.6, 0.0);
        i.push(Rgb::splat(0.3), Lobe::Dielectric(DielectricBsdf::new(1.5, 0.4, false, Rgb::ONE).with_multiscatter()));
        i.frames[1] = tilted(-0.2, 0.5);
        i.push(Rgb::splat(0.3), Lobe::Sheen { roughness: 0.5 });
        i.frames[2] = tilted(0.1, 0.1);
        // A coated Principled part on a mapped normal leaning 40° from the mixture's (sd->N),
        // its coat on sd->N: the coat reflects below the part's horizon (`part_reflects`).
        let part = Frame::from_normal(Vec3::new(0.64, 0.0, 0.77).normalize());
        let ns = part.to_local(Vec3::Z);
        let mut j = MixBsdf::new();
        j.pbr[0] = PbrBsdf::from_params(&crate::bsdf::pbr::PbrParams {
            specular: 0.0,
            coat: 1.0,
            coat_roughness: 0.3,
            coat_normal: Some(ns),
            cut_normal: Some(ns),
            smooth_normal: Some(ns),
            coat_dielectric_fresnel: true,
            ..crate::bsdf::pbr::PbrParams::opaque(Rgb::new(0.3, 0.5, 0.2), 0.0, 0.5)
        });
        j.pbr_weights[0] = 0.7;
        j.pbr_frames[0] = Some(part);
        j.push(Rgb::splat(0.3), Lobe::Diffuse);
        vec![
            ("coated principled on a leaning normal, coat on the mixture's", j),
            ("two principled+bumped diffuse+anisotropic glossy, own frames", h),
            ("translucent+glass+sheen, own frames", i),
            ("diffuse+glossy+translucent+oren-nayar", a),
            ("toon diffuse+toon glossy", g),
            ("anisotropic beckmann+anisotropic ggx+beckmann refraction", e),
            ("leaving beckmann glass+beckmann glossy", f),
            ("glass+sheen+principled", b),
            ("metal+leaving glass", c),
            ("f82 metal+leaving refraction", d),
        ]
    }

    /// The mixture's sampling matches its pdf (the pdf of the whole mixture).
    #[test]
    fn chi2_mixtures() {
        for (name, m) in mixtures() {
            for &theta in &[0.3f32, 1.2] {
                for &side in &[1.0f32, -1.0] {
                    let wo = Vec3::new(theta.sin(), 0.0, side * theta.cos());
                    let mut rng = Pcg32::new(7);
                    let t = ChiSquareTest::new(&format!("mix {name} θ={theta} side={side}"));
                    assert_chi2(
                        t.run_with_pdf(|u| m.sample(wo, rng.next_f32(), u).map(|s| (s.wi, s.pdf)), |wi| m.pdf(wo, wi)),
                    );
                }
            }
        }
    }

    /// A sampled direction's value is the mixture's eval there (the weighted sum).
    #[test]
    fn sampled_values_are_the_weighted_sum() {
        for (name, m) in mixtures() {
            let wo = Vec3::new(0.6, 0.0, 0.8);
            let mut rng = Pcg32::new(3);
            for _ in 0..200 {
                let Some(s) = m.sample(wo, rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32())) else { continue };
                if s.delta {
                    continue;
                }
                let f = m.eval(wo, s.wi);
                assert!((s.f - f).abs().max_element() <= 1e-5 * f.max_element().max(1.0), "{name}: {} vs {f}", s.f);
            }
        }
    }

    /// White furnace: weights summing to one over lobes that each conserve energy
    /// (white Lambert, constant-Fresnel glossy with multiple scattering, clear glass,
    /// translucent) reflect and transmit all the light, E[f cos / pdf] = 1. The tolerance
    /// 1 % is the multiscatter tables' own accuracy (README: white furnace within 1 %)
    /// plus 4σ of 200k samples of a weight bounded near 1.
    #[test]
    fn white_lobes_conserve_energy() {
        let mut m = MixBsdf::new();
        m.push(Rgb::splat(0.25), Lobe::Diffuse);
        m.push(Rgb::splat(0.25), Lobe::glossy(0.5, GlossyFresnel::Constant));
        m.push(Rgb::splat(0.25), Lobe::Translucent);
        // A thin sheet: no η² radiance scaling across it, so the sum is the energy balance.
        m.push(Rgb::splat(0.25), Lobe::Dielectric(DielectricBsdf::new(1.5, 0.5, true, Rgb::ONE).with_multiscatter()));
        for &theta in &[0.2f32, 0.8, 1.3] {
            let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
            let mut rng = Pcg32::new(5);
            let n = 200_000;
            let mut sum = 0.0f64;
            for _ in 0..n {
                if let Some(s) = m.sample(wo, rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32())) {
                    sum += (s.f.x * s.wi.z.abs() / s.pdf) as f64;
                }
            }
            let mean = sum / n as f64;
            assert!((mean - 1.0).abs() < 0.02, "θ={theta}: albedo {mean}");
        }
    }
}

#[cfg(test)]
mod blur_tests {
    use super::*;

    /// Filter Glossy widens a compensated GGX lobe and nothing else: its multiple-scattering
    /// factor stays the unblurred roughness's (Cycles scales the closure's weight at setup,
    /// before `bsdf_blur`), so blurred f / the blurred single-scattering f is that factor.
    #[test]
    fn blur_keeps_the_multiscatter_factor_of_the_unblurred_lobe() {
        let lobe = Lobe::glossy(0.3, GlossyFresnel::Constant);
        let Lobe::Glossy { fms, .. } = lobe else { unreachable!() };
        assert!(fms != Rgb::ZERO);
        let mut m = MixBsdf::new();
        m.push(Rgb::ONE, lobe);
        m.blur(0.42);
        let Lobe::Glossy { ggx, roughness, .. } = m.lobes[0] else { unreachable!() };
        assert!(ggx.alphas().0 > 0.4, "the width is blurred");
        let single = Lobe::Glossy { ggx, roughness, fresnel: GlossyFresnel::Constant, fms: Rgb::ZERO };
        let wo = Vec3::new(0.5, 0.0, 0.6).normalize();
        for wi in [Vec3::new(-0.3, 0.1, 0.9), Vec3::new(-0.7, -0.2, 0.4), Vec3::new(0.1, 0.5, 0.8)] {
            let wi = wi.normalize();
            let factor = m.lobes[0].eval(wo, wi) / single.eval(wo, wi);
            let want = Lobe::glossy_ms(fms, 0.3, wo.z);
            assert!((factor - want).abs().max_element() < 1e-5, "{factor:?} against {want:?}");
        }
    }
}

#[cfg(test)]
mod frame_tests {
    use super::*;
    use crate::sampling::chi2::{ChiSquareTest, Pcg32, assert_chi2};

    /// A Glossy lobe on a normal tilted 53 degrees from the interpolated one (+Z) reflects
    /// only to wo's side of the mixture's plane: Cycles rejects a reflection sampled into the
    /// surface, which the integrators took for a transmission (a glossy cube with a world-space
    /// normal map 1.0070 of Cycles, 6.9 sigma). Its density is that of its samples (chi-square),
    /// and a sample's value is the evaluation. With Cycles' cut (`cut`) its evaluation and
    /// density are 0 toward light on the other side of it than +Z puts that light (which only
    /// directions below the plane are, where it does not sample), and as before elsewhere.
    #[test]
    fn a_tilted_glossy_reflects_to_wo_side_and_is_cut_beyond_it() {
        let n = Vec3::new(0.8, 0.0, 0.6);
        let mut m = MixBsdf::new();
        m.push(Rgb::splat(0.7), Lobe::glossy(0.5, GlossyFresnel::Constant));
        m.frames[0] = Some(Frame::from_normal(n));
        let wo = Vec3::new(-0.2, 0.1, 0.97).normalize();
        let mut rng = Pcg32::new(5);
        let t = ChiSquareTest::new("tilted glossy");
        assert_chi2(t.run_with_pdf(|u| m.sample(wo, rng.next_f32(), u).map(|s| (s.wi, s.pdf)), |wi| m.pdf(wo, wi)));
        let mut cut = m;
        cut.cut[0] = true;
        let (mut samples, mut below) = (0, 0);
        for _ in 0..20_000 {
            let u = Vec2::new(rng.next_f32(), rng.next_f32());
            let Some(s) = cut.sample(wo, 0.5, u) else { continue };
            samples += 1;
            below += (s.wi.z <= 0.0) as usize;
            assert_eq!((s.f, s.pdf), (cut.eval(wo, s.wi), cut.pdf(wo, s.wi)));
        }
        assert!(samples > 1000 && below == 0, "{below} of {samples} reflections sampled below the plane");
        let (mut in_cut, mut lit) = (0, 0);
        for i in 0..64 {
            for j in 0..64 {
                let (c, phi) = (-1.0 + (i as f32 + 0.5) / 32.0, std::f32::consts::TAU * j as f32 / 64.0);
                let s = (1.0 - c * c).sqrt();
                let wi = Vec3::new(s * phi.cos(), s * phi.sin(), c);
                if (BumpCut { ns: Vec3::Z, n }).cuts(wi) {
                    assert_eq!((cut.eval(wo, wi), cut.pdf(wo, wi)), (Rgb::ZERO, 0.0), "{wi}");
                    in_cut += (m.eval(wo, wi) != Rgb::ZERO) as usize;
                } else {
                    assert_eq!((cut.eval(wo, wi), cut.pdf(wo, wi)), (m.eval(wo, wi), m.pdf(wo, wi)));
                    lit += (m.eval(wo, wi) != Rgb::ZERO) as usize;
                }
            }
        }
        assert!(in_cut > 50 && lit > 50, "{in_cut} lit directions cut, {lit} kept");
    }

    /// A Translucent lobe on a normal tilted from the interpolated one (+Z) takes Cycles' bump
    /// terminator term in its evaluation (light sampling: less than without it, 0 beyond its
    /// cut), never in its own samples: Cycles' `bsdf_sample` applies the term to reflections
    /// alone, so a sampled transmission carries the lobe's whole value.
    #[test]
    fn a_bumped_translucent_is_shadowed_in_evaluation_not_in_its_samples() {
        let n = Vec3::new(0.5, 0.0, 0.866).normalize();
        let mut plain = MixBsdf::new();
        plain.push(Rgb::splat(0.8), Lobe::Translucent);
        plain.frames[0] = Some(Frame::from_normal(n));
        let mut bumped = plain;
        bumped.bump[0] = crate::bsdf::pbr::bump_alpha2(Vec3::Z, n).unwrap();
        let wo = Vec3::new(-0.3, 0.2, 0.93).normalize();
        let mut rng = Pcg32::new(9);
        let (mut samples, mut darker) = (0, 0);
        for _ in 0..5000 {
            let u = Vec2::new(rng.next_f32(), rng.next_f32());
            let Some(s) = bumped.sample(wo, 0.5, u) else { continue };
            samples += 1;
            assert!(s.wi.z < 0.0);
            // Equal up to the rounding of adding the unshadowed value back.
            let f = plain.eval(wo, s.wi);
            assert!((s.f - f).abs().max_element() <= 1e-6 * f.max_element() && s.pdf == plain.pdf(wo, s.wi));
            let e = bumped.eval(wo, s.wi);
            assert!(e.cmple(f).all());
            darker += (e.x < s.f.x) as usize;
        }
        assert!(samples > 1000 && darker > samples / 2, "{darker} of {samples} evaluations shadowed");
    }

    /// A Diffuse lobe on a tilted normal reflects by its own cosine: the integrators' weight
    /// f |cos θ| / pdf, with θ to the mixture's normal, is exactly 1 for every sample (the
    /// cosine ratio undoes the mixture's cosine), where it keeps wo's side of the mixture's
    /// plane (elsewhere it gives no sample). With its bump terminator (α² of its tilt
    /// from the interpolated normal, +Z) each weight lies in [0, 1] and their mean is the
    /// albedo ∫ f |cos θ| dω by quadrature (within 4σ + the grid's 0.5 %), below 1.
    #[test]
    fn a_tilted_lobe_reflects_by_its_own_cosine() {
        let n = Vec3::new(0.5, -0.2, 1.0).normalize();
        let mut m = MixBsdf::new();
        m.push(Rgb::ONE, Lobe::Diffuse);
        m.frames[0] = Some(Frame::from_normal(n));
        let mut bumped = m;
        bumped.bump[0] = super::super::pbr::bump_alpha2(Vec3::Z, n).unwrap();
        let wo = Vec3::new(0.3, 0.1, 0.95).normalize();
        let mut rng = Pcg32::new(11);
        let (mut count, mut sum, mut sum2) = (0, 0.0f64, 0.0f64);
        for _ in 0..20_000 {
            // A direction the lobe reflects below the mixture's plane is no sample (weight 0;
            // the bump terminator gives nothing there either).
            count += 1;
            let Some(s) = m.sample(wo, rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32())) else { continue };
            let weight = s.f.x * s.wi.z.abs() / s.pdf;
            assert!((weight - 1.0).abs() < 1e-4, "{s:?}: {weight}");
            let b = bumped.eval(wo, s.wi).x * s.wi.z.abs() / s.pdf;
            assert!((0.0..=1.0 + 1e-4).contains(&b), "{b}");
            sum += b as f64;
            sum2 += (b * b) as f64;
        }
        let mean = sum / count as f64;
        let se = ((sum2 / count as f64 - mean * mean).max(0.0) / count as f64).sqrt();
        // ∫ over the sphere in (cos θ, φ) cells: dω = dcos dφ.
        let cells = 800;
        let mut quad = 0.0f64;
        for i in 0..cells {
            let c = -1.0 + 2.0 * (i as f64 + 0.5) / cells as f64;
            let sin = (1.0 - c * c).sqrt();
            for j in 0..cells {
                let phi = std::f64::consts::TAU * (j as f64 + 0.5) / cells as f64;
                let wi = Vec3::new((sin * phi.cos()) as f32, (sin * phi.sin()) as f32, c as f32);
                quad += (bumped.eval(wo, wi).x * wi.z.abs()) as f64;
            }
        }
        quad *= 2.0 * std::f64::consts::TAU / (cells * cells) as f64;
        assert!((mean - quad).abs() < 4.0 * se + 5e-3 * quad, "{mean} ± {se} vs {quad}");
        assert!(mean < 1.0 - 4.0 * se, "{mean}");
    }
}

#[cfg(test)]
mod beckmann_tests {
    use super::*;
    use crate::sampling::chi2::Pcg32;

    /// ∫ f cos dwi over the hemisphere by a midpoint rule in (cos²θ, φ), 400 × 400 cells (cos θ
    /// = √s puts the cells' density where a peaked lobe is).
    fn quadrature_albedo(lobe: &Lobe, wo: Vec3) -> f64 {
        let n = 400;
        let mut sum = 0.0f64;
        for i in 0..n {
            let s = (i as f64 + 0.5) / n as f64;
            let (cos, sin) = (s.sqrt(), (1.0 - s).sqrt());
            for j in 0..n {
                let phi = std::f64::consts::TAU * (j as f64 + 0.5) / n as f64;
                let wi = Vec3::new((sin * phi.cos()) as f32, (sin * phi.sin()) as f32, cos as f32);
                // dω = dcosθ dφ = ds dφ / (2 cos θ); times cos θ: ds dφ / 2.
                sum += lobe.eval(wo, wi).x as f64 * 0.5 * std::f64::consts::TAU / (n * n) as f64;
            }
        }
        sum
    }

    /// Beckmann and anisotropic reflection lobes (white, constant Fresnel): the sampled
    /// estimate E[f cos / pdf] is the quadrature of f cos (sampling weights agree with `eval`,
    /// within 4σ + the quadrature's 0.5 %), and at most 1 (Beckmann: + the 0.4 % of Cycles' Λ
    /// fit, `beckmann::tests::lambda_fit_is_close`). The compensated anisotropic GGX lobe is
    /// compensated as Cycles does, by the isotropic table at (αx αy)^¼, which restores only
    /// part of what it loses (0.88 at α = (0.5, 0.1), 11° from the normal): at most 1 too.
    #[test]
    fn beckmann_and_anisotropic_lobes_conserve_energy() {
        let lobes = [
            ("beckmann α=0.3", Lobe::glossy_widths(0.3, 0.3, true, GlossyFresnel::Constant), true),
            ("beckmann α=(0.8, 0.1)", Lobe::glossy_widths(0.8, 0.1, true, GlossyFresnel::Constant), true),
            ("beckmann α=1", Lobe::glossy_widths(1.0, 1.0, true, GlossyFresnel::Constant), true),
            ("ms ggx α=(0.5, 0.1)", Lobe::glossy_widths(0.5, 0.1, false, GlossyFresnel::Constant), false),
        ];
        for (name, lobe, beckmann) in lobes {
            for &theta in &[0.2f32, 0.8, 1.3] {
                let wo = Vec3::new(theta.sin() * 0.6, theta.sin() * 0.8, theta.cos());
                let mut rng = Pcg32::new(9);
                let n = 100_000;
                let (mut sum, mut sum2) = (0.0f64, 0.0f64);
                for _ in 0..n {
                    if let Some(s) = lobe.sample(wo, rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32())) {
                        let v = (s.f.x * s.wi.z.abs() / s.pdf) as f64;
                        sum += v;
                        sum2 += v * v;
                    }
                }
                let mean = sum / n as f64;
                let se = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
                let quad = quadrature_albedo(&lobe, wo);
                assert!((mean - quad).abs() < 4.0 * se + 5e-3 * quad, "{name} θ={theta}: {mean} ± {se} vs {quad}");
                let fit = if beckmann { 4e-3 } else { 0.0 };
                assert!(mean <= 1.0 + 4.0 * se + fit, "{name} θ={theta}: {mean} ± {se}");
            }
        }
    }
}

#[cfg(test)]
mod toon_tests {
    use super::*;
    use crate::sampling::chi2::Pcg32;

    /// A Toon lobe without Smooth whose cone stays above the horizon is a white furnace: every
    /// sample's weight f cos / pdf is 1 (Cycles' value is the cone's density); with Smooth the
    /// mean is the cone-averaged linear fall-off, below 1.
    #[test]
    fn toon_weights_are_its_intensity() {
        let wo = Vec3::new(0.0, 0.0, 1.0);
        for lobe in [Toon::new(0.5, 0.0, false), Toon::new(0.3, 0.0, true)] {
            let mut rng = Pcg32::new(4);
            for _ in 0..1000 {
                let wi = lobe.sample(wo, Vec2::new(rng.next_f32(), rng.next_f32()));
                let weight = lobe.eval(wo, wi) * wi.z / lobe.pdf(wo, wi);
                assert!((weight - 1.0).abs() < 1e-4, "{lobe:?}: {weight}");
            }
        }
        let smooth = Toon::new(0.3, 0.4, false);
        let mut rng = Pcg32::new(4);
        let n = 20_000;
        let mean: f32 = (0..n)
            .map(|_| {
                let wi = smooth.sample(wo, Vec2::new(rng.next_f32(), rng.next_f32()));
                smooth.eval(wo, wi) * wi.z / smooth.pdf(wo, wi)
            })
            .sum::<f32>()
            / n as f32;
        assert!(mean < 1.0 && mean > 0.3, "{mean}");
    }
}

#[cfg(test)]
mod f82_tests {
    use super::*;

    /// F82-tint: F0 at normal incidence, 1 at grazing, Schlick's times the tint at cos = 1/7
    /// (Cycles' construction); a white tint is Schlick's.
    #[test]
    fn f82_tint_is_schlick_times_tint_at_82_degrees() {
        let (f0, tint) = (Rgb::new(0.9, 0.6, 0.3), Rgb::new(0.5, 0.8, 1.0));
        let f = GlossyFresnel::f82_tint(f0, tint);
        assert!((f.at(1.0) - f0).abs().max_element() < 1e-6);
        assert!((f.at(0.0) - Rgb::ONE).abs().max_element() < 1e-6);
        let schlick = GlossyFresnel::Schlick(f0).at(1.0 / 7.0);
        assert!((f.at(1.0 / 7.0) - schlick * tint).abs().max_element() < 1e-5, "{:?}", f.at(1.0 / 7.0));
        assert_eq!(GlossyFresnel::f82_tint(f0, Rgb::ONE), GlossyFresnel::Schlick(f0));
    }
}
