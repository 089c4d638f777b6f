//! The glTF 2.0 metallic-roughness BRDF, as written in Appendix B of the glTF spec:
//!
//! ```text
//! dielectric = fresnel_mix(ior 1.5, base = lambert(base_color), layer = ggx(α))
//! metal      = conductor_fresnel(f0 = base_color, ggx(α))
//! f          = mix(dielectric, metal, metallic)
//! ```
//! with Schlick's Fresnel on the half vector, height-correlated Smith masking, and
//! α = roughness². Sampling picks the GGX lobe (visible normals) or the cosine-weighted
//! diffuse lobe with a probability estimated from the layer albedos at `wo`; `pdf` is
//! the mixture of both, so it matches `sample` exactly.
//!
//! One deliberate departure from Appendix B: the spec weights the diffuse base by
//! (1 - F(v·h)) per direction pair, which reflects more than it receives near 60° for
//! smooth surfaces (albedo ≈ 1.016 at roughness 0.15). Caustic layers by albedo
//! scaling instead, as Cycles' Principled BSDF and the glTF layering extensions do, in
//! Kulla & Conty's reciprocal form: diffuse × (1 - E(μo))(1 - E(μi)) / (1 - E_avg), with
//! E the directional albedo of the specular layer, tabulated once. It conserves energy
//! exactly and stays reciprocal.
//!
//! The glTF extensions layer on top by albedo scaling, as the glTF spec's layering rules
//! say: `KHR_materials_specular` colour tints the dielectric layer's F0 per channel (F90
//! stays the specular weight), `KHR_materials_sheen` is a Charlie-distribution sheen
//! (Estevez & Kulla 2017, Ashikhmin visibility) over everything below it with the
//! reciprocal scaling min(1 - s·E(μo), 1 - s·E(μi)), s = max(sheen colour), and
//! `KHR_materials_clearcoat` is a GGX layer of IOR 1.5 on top, with its own normal.
//!
//! Not handled: the energy lost by single-scattering GGX at high roughness (Cycles
//! compensates with multiscatter GGX: rough metals are slightly darker in Caustic).

use super::BsdfSample;
use super::dielectric::{DielectricBsdf, SMOOTH_ROUGHNESS};
use super::microfacet::{Ggx, reflect, schlick_weight};
use crate::math::{Frame, Rgb, luminance};
use crate::sampling::warp::{cosine_hemisphere, cosine_hemisphere_pdf};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Normal-incidence reflectance of the default dielectric layer (IOR 1.5).
pub const F0_DIELECTRIC: f32 = 0.04;

/// Normal-incidence reflectance of a dielectric of index `ior` in air.
#[inline]
pub fn f0_from_ior(ior: f32) -> f32 {
    let r = (ior - 1.0) / (ior + 1.0);
    r * r
}

/// The glTF material's factors at a shading point (textures already applied).
#[derive(Clone, Copy, Debug)]
pub struct PbrParams {
    /// Base colour.
    pub base: Rgb,
    /// Metalness.
    pub metallic: f32,
    /// Perceptual roughness.
    pub roughness: f32,
    /// `KHR_materials_specular` specularFactor (weight of the dielectric reflection).
    pub specular: f32,
    /// `KHR_materials_ior` (1.5 by default).
    pub ior: f32,
    /// `KHR_materials_transmission` transmissionFactor.
    pub transmission: f32,
    /// Thin-walled (no `KHR_materials_volume`, or thickness 0).
    pub thin: bool,
    /// Relative IOR across the surface for the transmission lobe: `ior` when entering,
    /// `1 / ior` when leaving (decided by the caller from the geometric normal).
    pub eta: f32,
    /// `KHR_materials_clearcoat` clearcoatFactor (weight of the coat layer).
    pub coat: f32,
    /// clearcoatRoughness.
    pub coat_roughness: f32,
    /// The coat's own normal in the shading frame (clearcoatNormalTexture), if it differs.
    pub coat_normal: Option<Vec3>,
    /// Index of refraction of the coat (Blender's Coat IOR; glTF's is 1.5).
    pub coat_ior: f32,
    /// Colour of the coat's absorption at normal incidence (Blender's Coat Tint).
    pub coat_tint: Rgb,
    /// `KHR_materials_specular` specularColorFactor (tints the dielectric layer's F0).
    pub specular_color: Rgb,
    /// `KHR_materials_sheen` sheenColorFactor (black: no sheen).
    pub sheen_color: Rgb,
    /// sheenRoughnessFactor.
    pub sheen_roughness: f32,
    /// `KHR_materials_dispersion` (20 / Abbe number; 0: none).
    pub dispersion: f32,
    /// Subsurface weight: the part of the diffuse base that scatters below the
    /// surface instead (sampled by the integrator's random walk, not by this BSDF).
    pub subsurface: f32,
}

impl PbrParams {
    /// An opaque dielectric/metal without the extensions.
    pub fn opaque(base: Rgb, metallic: f32, roughness: f32) -> Self {
        PbrParams {
            base,
            metallic,
            roughness,
            specular: 1.0,
            ior: 1.5,
            transmission: 0.0,
            thin: true,
            eta: 1.5,
            coat: 0.0,
            coat_roughness: 0.0,
            coat_normal: None,
            coat_ior: 1.5,
            coat_tint: Rgb::ONE,
            specular_color: Rgb::ONE,
            sheen_color: Rgb::ZERO,
            sheen_roughness: 0.0,
            dispersion: 0.0,
            subsurface: 0.0,
        }
    }
}

/// The glTF material BSDF: a metal, an opaque dielectric (specular over diffuse) and a
/// transmissive dielectric (glass), mixed by metallic and transmission as the glTF
/// spec and Blender's Principled BSDF mix them.
#[derive(Clone, Copy, Debug)]
pub struct PbrBsdf {
    /// Base colour (linear).
    pub base: Rgb,
    /// Metalness in [0, 1].
    pub metallic: f32,
    /// Perceptual roughness in [0, 1] (for the albedo table).
    pub roughness: f32,
    /// Weight of the dielectric specular layer (`KHR_materials_specular` specularFactor).
    pub specular: f32,
    /// Normal-incidence reflectance of the opaque dielectric's layer (from the IOR).
    pub f0: f32,
    /// Per-channel F0 of that layer: min(f0 × specular colour, 1).
    pub f0_rgb: Rgb,
    /// Weight of the glass part within the dielectric part.
    pub transmission: f32,
    /// The glass part.
    pub glass: DielectricBsdf,
    /// Microfacet distribution of the reflection lobes.
    pub ggx: Ggx,
    /// Weight of the clear coat (a GGX dielectric layer of IOR 1.5 over everything).
    pub coat: f32,
    /// Roughness of the coat (for its albedo table).
    pub coat_roughness: f32,
    /// Microfacets of the coat.
    pub coat_ggx: Ggx,
    /// The reflection lobes are perfect mirrors (roughness below `SMOOTH_ROUGHNESS`).
    pub smooth: bool,
    /// Cosine-weighted mean albedo of the dielectric layer per channel (specular weight included).
    layer_avg: Rgb,

    /// The coat is a perfect mirror.
    pub smooth_coat: bool,
    /// The coat's frame within the shading frame, when its normal differs.
    pub coat_frame: Option<Frame>,
    /// Normal-incidence reflectance of the coat (from its IOR).
    pub coat_f0: f32,
    /// Coat IOR (for the refracted path length through a tinted coat).
    pub coat_ior: f32,
    /// Coat tint (white: none).
    pub coat_tint: Rgb,
    /// Sheen colour (zero: no sheen).
    pub sheen_color: Rgb,
    /// Sheen roughness.
    pub sheen_roughness: f32,
    /// max(sheen colour): the sheen's albedo is this times the table's E.
    sheen_max: f32,
    /// Fraction of the diffuse base left to subsurface scattering (not in this BSDF).
    pub subsurface: f32,
}

/// Probabilities of the lobes for one `wo`: metal, dielectric specular, diffuse, glass.
#[derive(Clone, Copy)]
struct LobeChoice {
    metal: f32,
    spec: f32,
    diffuse: f32,
    glass: f32,
    coat: f32,
    sheen: f32,
}

impl PbrBsdf {
    /// An opaque BRDF from glTF factors, specular weight 1, IOR 1.5.
    pub fn new(base: Rgb, metallic: f32, roughness: f32) -> Self {
        Self::from_params(&PbrParams::opaque(base, metallic, roughness))
    }

    /// An opaque BRDF with a specular layer weight (`KHR_materials_specular` specularFactor).
    pub fn with_specular(base: Rgb, metallic: f32, roughness: f32, specular: f32) -> Self {
        Self::from_params(&PbrParams { specular, ..PbrParams::opaque(base, metallic, roughness) })
    }

    /// The full material from its parameters (clamped to their valid ranges).
    pub fn from_params(p: &PbrParams) -> Self {
        let base = p.base.clamp(Vec3::ZERO, Vec3::ONE);
        let roughness = p.roughness.clamp(0.0, 1.0);
        let ior = if p.ior.is_finite() && p.ior >= 1.0 { p.ior } else { 1.5 };
        let f0 = f0_from_ior(ior).min(1.0);
        let spec_color = if p.specular_color.is_finite() { p.specular_color.max(Vec3::ZERO) } else { Vec3::ONE };
        let sheen_color =
            if p.sheen_color.is_finite() { p.sheen_color.clamp(Vec3::ZERO, Vec3::ONE) } else { Vec3::ZERO };
        let coat_frame = p.coat_normal.filter(|n| n.is_finite() && n.z > 1e-3).and_then(|n| {
            let n = n.normalize();
            (n.z < 1.0 - 1e-6).then(|| Frame::from_normal(n))
        });
        let mut glass = DielectricBsdf::new(p.eta, roughness, p.thin, base);
        if p.dispersion > 0.0 && p.dispersion.is_finite() && !p.thin {
            glass = glass.with_dispersion(ior, p.dispersion);
        }
        PbrBsdf {
            base,
            metallic: p.metallic.clamp(0.0, 1.0),
            roughness,
            specular: p.specular.clamp(0.0, 1.0),
            f0,
            f0_rgb: (spec_color * f0).min(Vec3::ONE),
            transmission: p.transmission.clamp(0.0, 1.0),
            glass,
            ggx: Ggx::from_roughness(roughness),
            coat: p.coat.clamp(0.0, 1.0),
            coat_roughness: p.coat_roughness.clamp(0.0, 1.0),
            coat_ggx: Ggx::from_roughness(p.coat_roughness.clamp(0.0, 1.0)),
            smooth: roughness < SMOOTH_ROUGHNESS,
            smooth_coat: p.coat_roughness < SMOOTH_ROUGHNESS,
            layer_avg: Rgb::ZERO,
            coat_frame,
            coat_f0: f0_from_ior(if p.coat_ior.is_finite() && p.coat_ior >= 1.0 { p.coat_ior } else { 1.5 }).min(1.0),
            coat_ior: if p.coat_ior.is_finite() && p.coat_ior >= 1.0 { p.coat_ior } else { 1.5 },
            coat_tint: if p.coat_tint.is_finite() { p.coat_tint.clamp(Vec3::ZERO, Vec3::ONE) } else { Vec3::ONE },
            sheen_color,
            sheen_roughness: p.sheen_roughness.clamp(0.0, 1.0),
            sheen_max: sheen_color.max_element(),
            subsurface: p.subsurface.clamp(0.0, 1.0),
        }
        .with_layer_avg()
    }

    fn with_layer_avg(mut self) -> Self {
        let (a, b) = specular_albedo().ab_avg(self.roughness);
        self.layer_avg = (self.f0_rgb * a + Vec3::splat(b)) * self.specular;
        self
    }

    /// cos θ of `w` to the coat's normal.
    #[inline]
    fn coat_mu(&self, w: Vec3) -> f32 {
        match &self.coat_frame {
            Some(f) => w.dot(f.n),
            None => w.z,
        }
    }

    /// Directional albedo of the coat seen from `wo` (weight included).
    #[inline]
    fn coat_albedo(&self, wo: Vec3) -> f32 {
        if self.coat > 0.0 {
            let mu = self.coat_mu(wo);
            if mu <= 0.0 {
                return 0.0;
            }
            self.coat * specular_albedo().e(mu, self.coat_roughness, self.coat_f0)
        } else {
            0.0
        }
    }

    /// What a tinted coat lets through to the layers below, seen from `wo`: Cycles' model,
    /// tint^(1/cos θt) with θt the refracted angle in the coat (Beer's law over a unit-thickness
    /// coat whose tint is its normal-incidence transmittance), mixed in by the coat weight.
    #[inline]
    fn coat_transmittance(&self, wo: Vec3) -> Rgb {
        if self.coat <= 0.0 || self.coat_tint == Rgb::ONE {
            return Rgb::ONE;
        }
        let mu = self.coat_mu(wo).clamp(0.0, 1.0);
        let cos_t = (1.0 - (1.0 - mu * mu) / (self.coat_ior * self.coat_ior)).max(1e-4).sqrt();
        let t = self.coat_tint.powf(1.0 / cos_t);
        Rgb::ONE + (t - Rgb::ONE) * self.coat
    }

    /// Directional albedo of the opaque dielectric's specular layer at μ, per channel.
    #[inline]
    fn layer_albedo(&self, mu: f32) -> Rgb {
        // Blender's Specular IOR Level 0 (a pure Lambertian) needs no table lookup.
        if self.specular == 0.0 {
            return Rgb::ZERO;
        }
        let (a, b) = specular_albedo().ab(mu, self.roughness);
        (self.f0_rgb * a + Vec3::splat(b)) * self.specular
    }

    /// The sheen's directional albedo at μ: max(sheen colour) × E_sheen.
    #[inline]
    fn sheen_albedo(&self, mu: f32) -> f32 {
        if self.sheen_max > 0.0 { self.sheen_max * sheen_albedo_table().e(mu, self.sheen_roughness) } else { 0.0 }
    }

    /// The sheen's reciprocal albedo scaling of everything below it.
    #[inline]
    fn sheen_scaling(&self, mu_o: f32, mu_i: f32) -> f32 {
        if self.sheen_max > 0.0 { (1.0 - self.sheen_albedo(mu_o)).min(1.0 - self.sheen_albedo(mu_i)) } else { 1.0 }
    }

    #[inline]
    fn lobes(&self, wo: Vec3) -> LobeChoice {
        let e = luminance(self.layer_albedo(wo.z));
        let ec = self.coat_albedo(wo);
        let es = self.sheen_albedo(wo.z);
        let under = (1.0 - ec) * luminance(self.coat_transmittance(wo));
        let below = under * (1.0 - es);
        let dielectric = 1.0 - self.metallic;
        let opaque = dielectric * (1.0 - self.transmission);
        let metal = below * self.metallic * luminance(self.base + (Vec3::ONE - self.base) * schlick_weight(wo.z));
        let spec = below * opaque * e;
        let diffuse = below * opaque * (1.0 - e) * luminance(self.base) * (1.0 - self.subsurface);
        let glass = if self.transmission > 0.0 {
            let r = self.glass.reflect_probability(wo);
            below * dielectric * self.transmission * (r + (1.0 - r) * luminance(self.base)).max(1e-3)
        } else {
            0.0
        };
        let coat = ec;
        let sheen = under * es;
        let total = metal + spec + diffuse + glass + coat + sheen;
        if total > 0.0 {
            LobeChoice {
                metal: metal / total,
                spec: spec / total,
                diffuse: diffuse / total,
                glass: glass / total,
                coat: coat / total,
                sheen: sheen / total,
            }
        } else {
            LobeChoice { metal: 0.0, spec: 1.0, diffuse: 0.0, glass: 0.0, coat: 0.0, sheen: 0.0 }
        }
    }

    /// The coat's GGX reflection f(wo, wi) (weight and Fresnel included), in its own frame.
    /// With its own normal, the value is rescaled by cos θi(coat) / cos θi(shading), so that
    /// the integrator's cosine to the shading normal gives the coat's own cosine, as Cycles
    /// takes each closure's cosine to its own normal: the coat then reflects exactly its
    /// albedo E_c(μo) around the coat normal.
    #[inline]
    fn coat_eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        let cos_base = wi.z;
        let (wo, wi) = match &self.coat_frame {
            Some(f) => (f.to_local(wo), f.to_local(wi)),
            None => (wo, wi),
        };
        if wo.z <= 0.0 || wi.z <= 0.0 || cos_base <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        let f_coat = self.coat_f0 + (1.0 - self.coat_f0) * schlick_weight(wo.dot(h).max(0.0));
        let f = self.coat * f_coat * self.coat_ggx.d(h) * self.coat_ggx.g2(wo, wi) / (4.0 * wo.z * wi.z);
        if self.coat_frame.is_some() { f * wi.z / cos_base } else { f }
    }

    /// Density of the coat lobe's samples (visible normals, in its frame).
    #[inline]
    fn coat_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo, wi) = match &self.coat_frame {
            Some(f) => (f.to_local(wo), f.to_local(wi)),
            None => (wo, wi),
        };
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        self.coat_ggx.pdf_visible_normal(wo, h) / (4.0 * wo.dot(h).max(1e-8))
    }

    /// The Charlie sheen lobe's f(wo, wi) (colour included).
    #[inline]
    fn sheen_eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if self.sheen_max <= 0.0 || wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        let h = (wo + wi).normalize();
        self.sheen_color * charlie_brdf(h.z, wo.z, wi.z, self.sheen_roughness)
    }

    /// True when some light may pass through to the other side (a transmission lobe).
    pub fn transmits(&self) -> bool {
        self.transmission > 0.0 && self.metallic < 1.0
    }

    /// True when every lobe is a delta lobe (smooth clear glass): no light sampling helps.
    pub fn is_delta(&self) -> bool {
        let dielectric = 1.0 - self.metallic;
        let opaque = dielectric * (1.0 - self.transmission);
        let rough = (opaque > 0.0 && luminance(self.base) > 0.0 && self.subsurface < 1.0)
            || (!self.smooth && (self.metallic > 0.0 || (opaque > 0.0 && self.specular > 0.0)))
            || (self.transmission > 0.0 && dielectric > 0.0 && !self.glass.smooth)
            || (self.coat > 0.0 && !self.smooth_coat)
            || self.sheen_max > 0.0;
        !rough
    }

    /// f(wo, wi) of the non-delta lobes; directions in the local frame. Reflection is
    /// two-sided; transmission goes to the other side of wo.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        self.at(wo).eval(wi)
    }

    /// The BSDF seen from `wo`, with everything that depends on `wo` alone computed once:
    /// a photon gather evaluates f(wo, ·) for every photon found (the profile of a photon
    /// render had `eval` and its albedo-table lookups at ~20 % of the time).
    #[inline]
    pub fn at(&self, wo: Vec3) -> PbrAt<'_> {
        let flip = wo.z < 0.0;
        let wo = if flip { Vec3::new(wo.x, wo.y, -wo.z) } else { wo };
        if wo.z <= 0.0 {
            return PbrAt { b: self, wo, flip, under: Rgb::ZERO, eo: Rgb::ZERO, sheen_o: 0.0 };
        }
        // The coat reflects E_c(μo) of the light and leaves the rest to the layers below
        // (albedo scaling by the outgoing direction, as Cycles layers its coat).
        let under = self.coat_transmittance(wo) * (1.0 - self.coat_albedo(wo));
        let opaque = (1.0 - self.metallic) * (1.0 - self.transmission);
        let eo = if opaque > 0.0 { self.layer_albedo(wo.z) } else { Rgb::ZERO };
        let sheen_o = if self.sheen_max > 0.0 { 1.0 - self.sheen_albedo(wo.z) } else { 1.0 };
        PbrAt { b: self, wo, flip, under, eo, sheen_o }
    }

    /// Density of [`sample`](Self::sample) for the non-delta lobes.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo, wi) = flip_to_upper(wo, wi);
        if wo.z <= 0.0 || wi.z == 0.0 {
            return 0.0;
        }
        let c = self.lobes(wo);
        let mut pdf = 0.0;
        if c.glass > 0.0 {
            pdf += c.glass * self.glass.pdf(wo, wi);
        }
        if wi.z > 0.0 {
            let h = (wo + wi).normalize();
            if !self.smooth {
                let pdf_spec = self.ggx.pdf_visible_normal(wo, h) / (4.0 * wo.dot(h).max(1e-8));
                pdf += (c.metal + c.spec) * pdf_spec;
            }
            pdf += (c.diffuse + c.sheen) * cosine_hemisphere_pdf(wi.z);
            if c.coat > 0.0 && !self.smooth_coat {
                pdf += c.coat * self.coat_pdf(wo, wi);
            }
        }
        pdf
    }

    /// Samples wi for wo; `uc` picks the lobe (and is reused within the glass lobe).
    #[inline]
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        let flip = wo.z < 0.0;
        let mirror = |w: Vec3| if flip { Vec3::new(w.x, w.y, -w.z) } else { w };
        let wo_up = mirror(wo);
        if wo_up.z <= 0.0 {
            return None;
        }
        let c = self.lobes(wo_up);
        let wi_up = if uc < c.glass {
            let s = self.glass.sample(wo_up, uc / c.glass, u)?;
            if s.delta {
                let weight = self.coat_transmittance(wo_up)
                    * (1.0 - self.metallic)
                    * self.transmission
                    * (1.0 - self.coat_albedo(wo_up))
                    * self.sheen_scaling(wo_up.z, s.wi.z.abs());
                return Some(BsdfSample { wi: mirror(s.wi), f: s.f * weight, pdf: s.pdf * c.glass, delta: true });
            }
            s.wi
        } else if uc < c.glass + c.metal + c.spec {
            if self.smooth {
                // Perfect mirror: the metal's and the dielectric layer's reflectance.
                let mu = wo_up.z;
                let under =
                    self.coat_transmittance(wo_up) * (1.0 - self.coat_albedo(wo_up)) * self.sheen_scaling(mu, mu);
                let opaque = (1.0 - self.metallic) * (1.0 - self.transmission);
                let metal = (self.base + (Vec3::ONE - self.base) * schlick_weight(mu)) * self.metallic;
                let refl = (metal + self.layer_albedo(mu) * opaque) * under;
                let wi = Vec3::new(-wo_up.x, -wo_up.y, wo_up.z);
                return Some(BsdfSample { wi: mirror(wi), f: refl / mu, pdf: c.metal + c.spec, delta: true });
            }
            reflect(wo_up, self.ggx.sample_visible_normal(wo_up, u))
        } else if uc < c.glass + c.metal + c.spec + c.diffuse + c.sheen {
            cosine_hemisphere(u)
        } else {
            let cf = self.coat_frame.unwrap_or(Frame { s: Vec3::X, t: Vec3::Y, n: Vec3::Z });
            let wo_c = cf.to_local(wo_up);
            if wo_c.z <= 0.0 {
                return None;
            }
            if self.smooth_coat {
                let wi = cf.to_world(Vec3::new(-wo_c.x, -wo_c.y, wo_c.z));
                if wi.z <= 0.0 {
                    return None;
                }
                return Some(BsdfSample {
                    wi: mirror(wi),
                    f: Rgb::splat(self.coat_albedo(wo_up) / wi.z),
                    pdf: c.coat,
                    delta: true,
                });
            }
            cf.to_world(reflect(wo_c, self.coat_ggx.sample_visible_normal(wo_c, u)))
        };
        if wi_up.z == 0.0 || (uc >= c.glass && wi_up.z < 0.0) {
            return None;
        }
        let wi = mirror(wi_up);
        let pdf = self.pdf(wo, wi);
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample { wi, f: self.eval(wo, wi), pdf, delta: false })
    }

    /// Weight of the subsurface part seen from `wo` (local, either side), relative to
    /// the base colour: what the layers above (coat, specular) and the metal and glass
    /// mixes leave to the diffuse base, times the subsurface weight. Cycles weights
    /// its subsurface closure the same way (albedo scaling by the outgoing direction).
    pub fn subsurface_weight(&self, wo: Vec3) -> f32 {
        if self.subsurface == 0.0 {
            return 0.0;
        }
        let up = Vec3::new(wo.x, wo.y, wo.z.abs());
        let mu = up.z;
        let opaque = (1.0 - self.metallic) * (1.0 - self.transmission);
        // Coloured layers (a tinted coat or specular layer) are reduced to their luminance:
        // the random walk carries one weight for the whole spectrum of its entry.
        let above = luminance(self.coat_transmittance(up)) * (1.0 - self.coat_albedo(up)) * self.sheen_scaling(mu, mu);
        above * opaque * (1.0 - luminance(self.layer_albedo(mu))) * self.subsurface
    }

    /// Albedo for the denoiser: the colour a white light would reflect, roughly.
    pub fn albedo(&self) -> Rgb {
        let f0 = self.f0 * self.specular;
        let dielectric = self.base * (1.0 - f0) + Vec3::splat(f0);
        let below = dielectric * (1.0 - self.metallic) + self.base * self.metallic;
        let below = below * (1.0 - self.sheen_max * 0.5) + self.sheen_color * 0.5;
        below * self.coat_transmittance(Vec3::Z) * (1.0 - self.coat * self.coat_f0)
            + Vec3::splat(self.coat * self.coat_f0)
    }
}

/// Resolution of the albedo table along cos θ and roughness.
const TABLE_N: usize = 32;

/// Directional albedo of a GGX reflection layer with Schlick's Fresnel, as the split
/// E(μ, roughness, F0) = F0 · A(μ, roughness) + B(μ, roughness) (Schlick's Fresnel is
/// linear in F0), with the cosine-weighted averages of A and B. Computed once by
/// stratified quadrature of the VNDF estimator F · G2 / G1 (deterministic).
pub struct SpecularAlbedo {
    a: Vec<f32>,
    b: Vec<f32>,
    avg_a: Vec<f32>,
    avg_b: Vec<f32>,
}

/// Stratified samples per table entry (per axis).
const TABLE_STRATA: usize = 48;

impl SpecularAlbedo {
    fn compute() -> Self {
        // Entries are independent: build them on all cores (the benchmark found this
        // one-time table at 6-13% of short renders).
        use rayon::prelude::*;
        let entries: Vec<(f32, f32)> = (0..TABLE_N * TABLE_N)
            .into_par_iter()
            .map(|i| {
                let (ri, mi) = (i / TABLE_N, i % TABLE_N);
                directional_albedo_split(Self::mu(mi), ri as f32 / (TABLE_N - 1) as f32, TABLE_STRATA)
            })
            .collect();
        let a: Vec<f32> = entries.iter().map(|e| e.0).collect();
        let b: Vec<f32> = entries.iter().map(|e| e.1).collect();
        // Averages 2 ∫ E(μ) μ dμ by the trapezoid rule on the table's nodes.
        let avg = |t: &[f32]| -> Vec<f32> {
            (0..TABLE_N)
                .map(|ri| {
                    let mut sum = 0.0f32;
                    for mi in 0..TABLE_N - 1 {
                        let (m0, m1) = (Self::mu(mi), Self::mu(mi + 1));
                        sum += 0.5 * (t[ri * TABLE_N + mi] * m0 + t[ri * TABLE_N + mi + 1] * m1) * (m1 - m0);
                    }
                    2.0 * sum
                })
                .collect()
        };
        let (avg_a, avg_b) = (avg(&a), avg(&b));
        SpecularAlbedo { a, b, avg_a, avg_b }
    }

    /// Node i of the μ axis; nodes are spaced in √μ because E changes fastest at grazing angles.
    fn mu(i: usize) -> f32 {
        let x = i as f32 / (TABLE_N - 1) as f32;
        (x * x).max(1e-3)
    }

    /// E(μ, roughness, F0), bilinear in the tables (one set of weights for both).
    #[inline]
    pub fn e(&self, mu: f32, roughness: f32, f0: f32) -> f32 {
        let (a, b) = self.ab(mu, roughness);
        f0 * a + b
    }

    /// (A, B) with E = F0·A + B, bilinear in the tables.
    #[inline]
    pub fn ab(&self, mu: f32, roughness: f32) -> (f32, f32) {
        let x = mu.clamp(0.0, 1.0).sqrt() * (TABLE_N - 1) as f32;
        let y = roughness.clamp(0.0, 1.0) * (TABLE_N - 1) as f32;
        let (x0, y0) = ((x as usize).min(TABLE_N - 2), (y as usize).min(TABLE_N - 2));
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let (i00, i01) = (y0 * TABLE_N + x0, (y0 + 1) * TABLE_N + x0);
        let w = [(1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy];
        let at = |t: &[f32]| w[0] * t[i00] + w[1] * t[i00 + 1] + w[2] * t[i01] + w[3] * t[i01 + 1];
        (at(&self.a), at(&self.b))
    }

    /// Cosine-weighted average of E over the hemisphere.
    #[inline]
    pub fn e_avg(&self, roughness: f32, f0: f32) -> f32 {
        let (a, b) = self.ab_avg(roughness);
        f0 * a + b
    }

    /// (A, B) of the cosine-weighted averages.
    #[inline]
    pub fn ab_avg(&self, roughness: f32) -> (f32, f32) {
        let y = roughness.clamp(0.0, 1.0) * (TABLE_N - 1) as f32;
        let y0 = (y as usize).min(TABLE_N - 2);
        let fy = y - y0 as f32;
        let lerp = |t: &[f32]| t[y0] * (1.0 - fy) + t[y0 + 1] * fy;
        (lerp(&self.avg_a), lerp(&self.avg_b))
    }
}

/// (A, B) of ∫ f_spec cos dωi = F0·A + B for the GGX layer at μ = cos θo, by `n`×`n`
/// stratified VNDF samples.
pub fn directional_albedo_split(mu: f32, roughness: f32, n: usize) -> (f32, f32) {
    let ggx = Ggx::from_roughness(roughness);
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let (mut sa, mut sb) = (0.0f64, 0.0f64);
    for i in 0..n {
        for j in 0..n {
            let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let m = ggx.sample_visible_normal(wo, u);
            let wi = reflect(wo, m);
            if wi.z <= 0.0 {
                continue;
            }
            let w = schlick_weight(wo.dot(m));
            let g = (ggx.g2(wo, wi) / ggx.g1(wo)) as f64;
            sa += (1.0 - w) as f64 * g;
            sb += w as f64 * g;
        }
    }
    let k = (n * n) as f64;
    ((sa / k) as f32, (sb / k) as f32)
}

/// ∫ f_spec cos dωi of the default (F0 = 0.04) layer.
pub fn directional_albedo(mu: f32, roughness: f32, n: usize) -> f32 {
    let (a, b) = directional_albedo_split(mu, roughness, n);
    F0_DIELECTRIC * a + b
}

/// The shared table.
pub fn specular_albedo() -> &'static SpecularAlbedo {
    static TABLE: std::sync::OnceLock<SpecularAlbedo> = std::sync::OnceLock::new();
    TABLE.get_or_init(SpecularAlbedo::compute)
}

/// The Charlie sheen BRDF of Estevez & Kulla 2017 ("Production Friendly Microfacet Sheen
/// BRDF"), one of the two visibilities the glTF sheen extension allows: the normalised
/// distribution D(h) = (2 + 1/α) sin^(1/α)θh / 2π, α = roughness² (kept above 10⁻³ so the
/// exponent stays finite), with the paper's fitted Smith Λ, f = D / ((1 + Λo + Λi) 4 μo μi).
/// A single-scattering microfacet model with a proper masking term reflects at most what
/// it receives, which Ashikhmin's simpler visibility does not (its albedo passes 1 at
/// grazing angles; the energy test caught it).
#[inline]
pub fn charlie_brdf(cos_h: f32, mu_o: f32, mu_i: f32, roughness: f32) -> f32 {
    let alpha = (roughness * roughness).max(1e-3);
    let inv = 1.0 / alpha;
    let sin2 = (1.0 - cos_h * cos_h).max(0.0);
    let d = (2.0 + inv) * sin2.powf(0.5 * inv) / (2.0 * std::f32::consts::PI);
    let denom = (1.0 + charlie_lambda(mu_o, alpha) + charlie_lambda(mu_i, alpha)) * 4.0 * mu_o * mu_i;
    if denom > 0.0 { d / denom } else { 0.0 }
}

/// Estevez & Kulla's fit of the Charlie distribution's Smith Λ: exp(L(μ)) below μ = 1/2 and
/// its mirror exp(2 L(1/2) - L(1 - μ)) above, with L(x) = a / (1 + b x^c) + d x + e and
/// (a..e) interpolated between the paper's two fitted rows by (1 - α)².
#[inline]
fn charlie_lambda(mu: f32, alpha: f32) -> f32 {
    let t = (1.0 - alpha) * (1.0 - alpha);
    let lerp = |x: f32, y: f32| x + (y - x) * t;
    let (a, b, c, d, e) = (
        lerp(21.5473, 25.3245),
        lerp(3.82987, 3.32435),
        lerp(0.19823, 0.16801),
        lerp(-1.97760, -1.27393),
        lerp(-4.32054, -4.85967),
    );
    let l = |x: f32| a / (1.0 + b * x.max(0.0).powf(c)) + d * x + e;
    let mu = mu.abs();
    if mu < 0.5 { l(mu).exp() } else { (2.0 * l(0.5) - l(1.0 - mu)).exp() }
}

/// Stratified samples per axis for the sheen table.
const SHEEN_STRATA: usize = 48;

/// Directional albedo E(μ, roughness) of the Charlie sheen (white), tabulated once by
/// stratified cosine-weighted quadrature.
pub struct SheenAlbedo {
    e: Vec<f32>,
}

impl SheenAlbedo {
    fn compute() -> Self {
        use rayon::prelude::*;
        let e = (0..TABLE_N * TABLE_N)
            .into_par_iter()
            .map(|i| {
                let (ri, mi) = (i / TABLE_N, i % TABLE_N);
                sheen_directional_albedo(SpecularAlbedo::mu(mi), ri as f32 / (TABLE_N - 1) as f32, SHEEN_STRATA)
            })
            .collect();
        SheenAlbedo { e }
    }

    /// E(μ, roughness), bilinear.
    #[inline]
    pub fn e(&self, mu: f32, roughness: f32) -> f32 {
        let x = mu.clamp(0.0, 1.0).sqrt() * (TABLE_N - 1) as f32;
        let y = roughness.clamp(0.0, 1.0) * (TABLE_N - 1) as f32;
        let (x0, y0) = ((x as usize).min(TABLE_N - 2), (y as usize).min(TABLE_N - 2));
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let (i00, i01) = (y0 * TABLE_N + x0, (y0 + 1) * TABLE_N + x0);
        let t = &self.e;
        (1.0 - fx) * (1.0 - fy) * t[i00]
            + fx * (1.0 - fy) * t[i00 + 1]
            + (1.0 - fx) * fy * t[i01]
            + fx * fy * t[i01 + 1]
    }
}

/// ∫ f_sheen cos dωi at μ = cos θo for white sheen, by `n`×`n` stratified samples of the
/// half vector from D(h) cos θh (sin θh = ξ^(α / (2α + 1)) inverts its CDF), for which the
/// estimator f μi / p = |wo·h| / ((1 + Λo + Λi) μo cos θh) is smooth: cosine-weighted
/// strata miss the lobe at grazing angles and low roughness.
pub fn sheen_directional_albedo(mu: f32, roughness: f32, n: usize) -> f32 {
    let alpha = (roughness * roughness).max(1e-3);
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let lo = charlie_lambda(mu, alpha);
    let mut sum = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            let (x1, x2) = ((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let sin_h = x1.powf(alpha / (2.0 * alpha + 1.0));
            let cos_h = (1.0 - sin_h * sin_h).max(0.0).sqrt();
            let phi = std::f32::consts::TAU * x2;
            let h = Vec3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h);
            let wi = reflect(wo, h);
            if wi.z <= 0.0 || cos_h <= 0.0 {
                continue;
            }
            let li = charlie_lambda(wi.z, alpha);
            sum += (wo.dot(h).abs() / ((1.0 + lo + li) * mu * cos_h)) as f64;
        }
    }
    (sum / (n * n) as f64).min(1.0) as f32
}

/// The shared sheen table.
pub fn sheen_albedo_table() -> &'static SheenAlbedo {
    static TABLE: std::sync::OnceLock<SheenAlbedo> = std::sync::OnceLock::new();
    TABLE.get_or_init(SheenAlbedo::compute)
}

/// A [`PbrBsdf`] seen from one outgoing direction ([`PbrBsdf::at`]): evaluates f(wo, wi)
/// for many wi with the wo-only terms (coat transmittance, layer and sheen albedos at wo)
/// computed once. `PbrBsdf::eval` goes through it, so there is one copy of the formula.
#[derive(Clone, Copy, Debug)]
pub struct PbrAt<'a> {
    b: &'a PbrBsdf,
    /// wo, flipped into the upper hemisphere.
    wo: Vec3,
    /// wo was below the surface: wi is flipped with it.
    flip: bool,
    /// What the coat leaves to the layers below, seen from wo.
    under: Rgb,
    /// The opaque dielectric layer's albedo at wo.
    eo: Rgb,
    /// 1 - the sheen's albedo at wo (1 without sheen).
    sheen_o: f32,
}

impl PbrAt<'_> {
    /// f(wo, wi), as [`PbrBsdf::eval`].
    #[inline]
    pub fn eval(&self, wi: Vec3) -> Rgb {
        let b = self.b;
        let wo = self.wo;
        let wi = if self.flip { Vec3::new(wi.x, wi.y, -wi.z) } else { wi };
        if wo.z <= 0.0 || wi.z == 0.0 {
            return Vec3::ZERO;
        }
        let dielectric = 1.0 - b.metallic;
        let under = self.under;
        let scaling = if b.sheen_max > 0.0 { self.sheen_o.min(1.0 - b.sheen_albedo(wi.z.abs())) } else { 1.0 };
        let mut f = Rgb::ZERO;
        if b.transmission > 0.0 {
            f += b.glass.eval(wo, wi) * (dielectric * b.transmission);
        }
        if wi.z < 0.0 {
            return f * (under * scaling);
        }
        let h = (wo + wi).normalize();
        let fw = schlick_weight(wo.dot(h).max(0.0));
        // Smooth reflection is a delta lobe: sampled only, never evaluated.
        let spec = if b.smooth { 0.0 } else { b.ggx.d(h) * b.ggx.g2(wo, wi) / (4.0 * wo.z * wi.z) };
        let opaque = dielectric * (1.0 - b.transmission);
        if opaque > 0.0 {
            // The specular weight scales the whole layer (F0 and F90), so its albedo is
            // weight × E and the albedo scaling stays exact, channel by channel.
            let f_layer = (b.f0_rgb + (Vec3::ONE - b.f0_rgb) * fw) * b.specular;
            let ei = b.layer_albedo(wi.z);
            let diffuse_weight = (Vec3::ONE - self.eo) * (Vec3::ONE - ei)
                / (Vec3::ONE - b.layer_avg).max(Vec3::splat(1e-6))
                * (1.0 - b.subsurface);
            f += (b.base * diffuse_weight * FRAC_1_PI + f_layer * spec) * opaque;
        }
        if b.metallic > 0.0 {
            f += (b.base + (Vec3::ONE - b.base) * fw) * (spec * b.metallic);
        }
        f = (f * scaling + b.sheen_eval(wo, wi)) * under;
        if b.coat > 0.0 && !b.smooth_coat {
            f += Rgb::splat(b.coat_eval(wo, wi));
        }
        f
    }
}

/// Mirrors both directions to the upper hemisphere when `wo` is below it, which makes
/// the BRDF two-sided; `wi` on the other side of the surface than `wo` stays rejected.
#[inline]
fn flip_to_upper(wo: Vec3, wi: Vec3) -> (Vec3, Vec3) {
    if wo.z < 0.0 { (Vec3::new(wo.x, wo.y, -wo.z), Vec3::new(wi.x, wi.y, -wi.z)) } else { (wo, wi) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{ChiSquareTest, Pcg32, assert_chi2};

    fn materials_with(base: Vec3) -> Vec<(String, PbrBsdf)> {
        let mut v = Vec::new();
        for roughness in [0.15f32, 0.5, 1.0] {
            for metallic in [0.0f32, 0.5, 1.0] {
                v.push((format!("r={roughness} m={metallic}"), PbrBsdf::new(base, metallic, roughness)));
            }
            for specular in [0.0f32, 0.5] {
                v.push((
                    format!("r={roughness} specular={specular}"),
                    PbrBsdf::with_specular(base, 0.0, roughness, specular),
                ));
            }
        }
        // Transmissive (rough: the chi-square needs densities), entering and leaving,
        // solid and thin, partly metallic, another IOR.
        for (transmission, eta, thin, metallic, ior) in [
            (1.0f32, 1.5f32, false, 0.0f32, 1.5f32),
            (1.0, 1.0 / 1.5, false, 0.0, 1.5),
            (0.5, 1.5, false, 0.0, 1.5),
            (1.0, 1.5, true, 0.0, 1.5),
            (0.7, 2.4, false, 0.3, 2.4),
        ] {
            for roughness in [0.3f32, 0.8] {
                let p = PbrParams {
                    specular: 1.0,
                    ior,
                    transmission,
                    thin,
                    eta,
                    ..PbrParams::opaque(base, metallic, roughness)
                };
                v.push((
                    format!("r={roughness} transmission={transmission} η={eta} thin={thin} m={metallic}"),
                    PbrBsdf::from_params(&p),
                ));
            }
        }
        // Sheen over a diffuse base, a metal and glass; a tinted specular layer.
        for (sheen, sr, metallic, transmission) in
            [(1.0f32, 0.3f32, 0.0f32, 0.0f32), (0.6, 0.8, 1.0, 0.0), (0.8, 0.5, 0.0, 1.0)]
        {
            let p = PbrParams {
                sheen_color: Vec3::new(sheen, sheen * 0.7, sheen * 0.4),
                sheen_roughness: sr,
                transmission,
                ..PbrParams::opaque(base, metallic, 0.5)
            };
            v.push((format!("sheen={sheen} sr={sr} m={metallic} t={transmission}"), PbrBsdf::from_params(&p)));
        }
        for roughness in [0.2f32, 0.6] {
            let p = PbrParams {
                specular_color: Vec3::new(3.0, 1.0, 0.2),
                ior: 1.8,
                ..PbrParams::opaque(base, 0.0, roughness)
            };
            v.push((format!("specular colour r={roughness}"), PbrBsdf::from_params(&p)));
        }
        // Coated: over a diffuse base, a metal and glass; the coat breaks reciprocity
        // (albedo scaling by wo), so the reciprocity test skips these.
        for (coat, coat_roughness, metallic, transmission) in
            [(1.0f32, 0.1f32, 0.0f32, 0.0f32), (0.5, 0.4, 1.0, 0.0), (1.0, 0.3, 0.0, 1.0)]
        {
            let p = PbrParams { coat, coat_roughness, transmission, ..PbrParams::opaque(base, metallic, 0.6) };
            v.push((
                format!("coat={coat} cr={coat_roughness} m={metallic} t={transmission}"),
                PbrBsdf::from_params(&p),
            ));
        }
        // Blender's coat IOR and tint (CAUSTIC_materials_coat).
        let p = PbrParams {
            coat: 1.0,
            coat_roughness: 0.3,
            coat_ior: 1.8,
            coat_tint: Vec3::new(0.8, 0.5, 0.3),
            ..PbrParams::opaque(base, 0.0, 0.5)
        };
        v.push(("coat ior 1.8 tinted".into(), PbrBsdf::from_params(&p)));
        // A coat with its own normal (clearcoatNormalTexture), rough and smooth.
        for coat_roughness in [0.3f32, 0.1] {
            let p = PbrParams {
                coat: 1.0,
                coat_roughness,
                coat_normal: Some(Vec3::new(0.3, -0.2, 0.93)),
                ..PbrParams::opaque(base, 0.0, 0.5)
            };
            v.push((format!("coat normal cr={coat_roughness}"), PbrBsdf::from_params(&p)));
        }
        v
    }

    fn materials() -> Vec<(String, PbrBsdf)> {
        materials_with(Vec3::new(0.8, 0.4, 0.1))
    }

    #[test]
    fn chi2_pbr_lobes() {
        for (name, b) in materials() {
            for theta in [0.1f32, 0.9, 1.45] {
                let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                let mut rng = Pcg32::new(3);
                let t = ChiSquareTest::new(&format!("glTF PBR {name} θ={theta}"));
                assert_chi2(
                    t.run_with_pdf(|u| b.sample(wo, rng.next_f32(), u).map(|s| (s.wi, s.pdf)), |wi| b.pdf(wo, wi)),
                );
            }
        }
    }

    /// Reciprocity: f(wo, wi) = f(wi, wo) for the whole BRDF (the Fresnel term uses the
    /// half vector, which is symmetric; the diffuse/specular split is too).
    #[test]
    fn reciprocity() {
        let mut rng = Pcg32::new(9);
        for (_, b) in materials().into_iter().filter(|(_, b)| b.coat == 0.0) {
            for _ in 0..200 {
                let a = cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let c = cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let f1 = b.eval(a, c);
                let f2 = b.eval(c, a);
                assert!((f1 - f2).abs().max_element() <= 1e-4 * f1.max_element().max(1.0));
            }
        }
    }

    /// A perfectly smooth metal is a delta mirror whose sampled weight is Schlick's
    /// Fresnel; a smooth dielectric over black is one too, weighted by its layer albedo.
    #[test]
    fn smooth_reflection_is_a_delta_mirror() {
        let metal = PbrBsdf::new(Vec3::new(0.9, 0.6, 0.3), 1.0, 0.0);
        assert!(metal.is_delta());
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let s = metal.sample(wo, 0.5, Vec2::new(0.3, 0.7)).unwrap();
        assert!(s.delta && (s.wi - Vec3::new(-0.6, 0.0, 0.8)).length() < 1e-6);
        let weight = s.f * s.wi.z / s.pdf;
        let expect = metal.base + (Vec3::ONE - metal.base) * schlick_weight(0.8);
        assert!((weight - expect).abs().max_element() < 1e-5, "{weight} vs {expect}");
        assert_eq!(metal.eval(wo, s.wi), Vec3::ZERO);
        // A smooth dielectric with a diffuse base is not a pure delta BSDF.
        assert!(!PbrBsdf::new(Vec3::splat(0.5), 0.0, 0.0).is_delta());
        assert!(PbrBsdf::new(Vec3::ZERO, 0.0, 0.0).is_delta());
    }

    /// The albedo table agrees with a 4× finer quadrature within TABLE_ERROR, which the
    /// energy test below then allows for.
    const TABLE_ERROR: f64 = 2e-3;

    #[test]
    fn albedo_table_accuracy() {
        let t = specular_albedo();
        for &(mu, r) in &[(0.05f32, 0.1f32), (0.3, 0.5), (0.77, 0.23), (1.0, 1.0), (0.5, 0.05)] {
            let fine = directional_albedo(mu, r, 4 * TABLE_STRATA) as f64;
            let err = (t.e(mu, r, F0_DIELECTRIC) as f64 - fine).abs();
            assert!(err < TABLE_ERROR, "E({mu}, {r}): table {} vs {fine}", t.e(mu, r, F0_DIELECTRIC));
        }
    }

    /// Energy: the directional albedo ∫ f cos dwi ≤ 1 at every angle, estimated by
    /// importance sampling with N samples; the bound allows 5 standard errors of the
    /// estimate (its sample standard deviation / √N) plus the albedo table's error.
    #[test]
    fn albedo_at_most_one() {
        let n = 200_000;
        for (name, b) in materials_with(Vec3::ONE) {
            for theta in [0.0f32, 0.5, 1.0, 1.5] {
                let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                let mut rng = Pcg32::new(1);
                // Per channel: a tinted layer has coloured weights, and the mean of the
                // largest channel would overstate every channel's albedo.
                let (mut sum, mut sum2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
                for _ in 0..n {
                    let u = Vec2::new(rng.next_f32(), rng.next_f32());
                    let v = b
                        .sample(wo, rng.next_f32(), u)
                        .map(|s| {
                            // Undo the 1/η² radiance scaling of refracted samples.
                            let scale = if s.wi.z < 0.0 && !b.glass.thin { b.glass.eta * b.glass.eta } else { 1.0 };
                            (s.f * (s.wi.z.abs() / s.pdf * scale)).as_dvec3()
                        })
                        .unwrap_or(glam::DVec3::ZERO);
                    sum += v;
                    sum2 += v * v;
                }
                let mean = sum / n as f64;
                let se = ((sum2 / n as f64 - mean * mean).max(glam::DVec3::ZERO) / n as f64).powf(0.5);
                for c in 0..3 {
                    assert!(
                        mean[c] <= 1.0 + 5.0 * se[c] + TABLE_ERROR,
                        "{name} θ={theta} channel {c}: albedo {} ± {}",
                        mean[c],
                        se[c]
                    );
                }
            }
        }
    }

    /// The sheen table agrees with a 4× finer quadrature (the albedo test allows its error).
    #[test]
    fn sheen_table_accuracy() {
        let t = sheen_albedo_table();
        for &(mu, r) in &[(0.05f32, 0.2f32), (0.3, 0.5), (0.77, 0.9), (1.0, 1.0), (0.5, 0.05)] {
            let fine = sheen_directional_albedo(mu, r, 4 * SHEEN_STRATA) as f64;
            let err = (t.e(mu, r) as f64 - fine).abs();
            assert!(err < TABLE_ERROR, "E_sheen({mu}, {r}): table {} vs {fine}", t.e(mu, r));
        }
    }

    /// A tinted specular layer reflects its tint: at normal incidence over a black base the
    /// sampled weight per channel follows F0 = min(F0(ior) × colour, 1).
    #[test]
    fn specular_colour_tints_f0() {
        let p = PbrParams { specular_color: Vec3::new(2.0, 1.0, 0.0), ..PbrParams::opaque(Vec3::ZERO, 0.0, 0.0) };
        let b = PbrBsdf::from_params(&p);
        let s = b.sample(Vec3::Z, 0.0, Vec2::splat(0.5)).unwrap();
        let w = s.f * s.wi.z / s.pdf;
        let f0 = f0_from_ior(1.5);
        // The delta mirror's weight is the layer albedo, which at μ = 1 is about F0.
        assert!((w.x / w.y - 2.0).abs() < 0.05 && w.z < 0.2 * w.y, "{w} for F0 {f0}");
    }

    /// A white Lambertian (metallic 0, rough) reflects 1 - F: its albedo is close to,
    /// and below, 1 at normal incidence; a black dielectric reflects only the specular.
    #[test]
    fn diffuse_limit() {
        let b = PbrBsdf::new(Vec3::ZERO, 0.0, 1.0);
        let wo = Vec3::Z;
        let wi = Vec3::new(0.6, 0.0, 0.8);
        let f = b.eval(wo, wi);
        assert!(f.x == f.y && f.y == f.z && f.x > 0.0 && f.x < 0.1);
    }
}
