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
//! Not handled here: transmission, clearcoat, sheen, specular tint (the materials
//! issue), and the energy lost by single-scattering GGX at high roughness (Cycles
//! compensates with multiscatter GGX: rough metals are slightly darker in Caustic).

use super::BsdfSample;
use super::dielectric::{DielectricBsdf, SMOOTH_ROUGHNESS};
use super::microfacet::{Ggx, reflect, schlick_weight};
use crate::math::{Rgb, luminance};
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
    /// Cosine-weighted mean albedo of the dielectric layer (specular weight included).
    layer_avg: f32,

    /// The coat is a perfect mirror.
    pub smooth_coat: bool,
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
        PbrBsdf {
            base,
            metallic: p.metallic.clamp(0.0, 1.0),
            roughness,
            specular: p.specular.clamp(0.0, 1.0),
            f0: f0_from_ior(if p.ior.is_finite() && p.ior >= 1.0 { p.ior } else { 1.5 }).min(1.0),
            transmission: p.transmission.clamp(0.0, 1.0),
            glass: DielectricBsdf::new(p.eta, roughness, p.thin, base),
            ggx: Ggx::from_roughness(roughness),
            coat: p.coat.clamp(0.0, 1.0),
            coat_roughness: p.coat_roughness.clamp(0.0, 1.0),
            coat_ggx: Ggx::from_roughness(p.coat_roughness.clamp(0.0, 1.0)),
            smooth: roughness < SMOOTH_ROUGHNESS,
            smooth_coat: p.coat_roughness < SMOOTH_ROUGHNESS,
            layer_avg: 0.0,
            subsurface: p.subsurface.clamp(0.0, 1.0),
        }
        .with_layer_avg()
    }

    fn with_layer_avg(mut self) -> Self {
        self.layer_avg = self.specular * specular_albedo().e_avg(self.roughness, self.f0);
        self
    }

    /// Directional albedo of the coat at μ (weight included).
    #[inline]
    fn coat_albedo(&self, mu: f32) -> f32 {
        if self.coat > 0.0 { self.coat * specular_albedo().e(mu, self.coat_roughness, F0_DIELECTRIC) } else { 0.0 }
    }

    /// Directional albedo of the opaque dielectric's specular layer at μ.
    #[inline]
    fn layer_albedo(&self, mu: f32) -> f32 {
        // Blender's Specular IOR Level 0 (a pure Lambertian) needs no table lookup.
        if self.specular == 0.0 { 0.0 } else { self.specular * specular_albedo().e(mu, self.roughness, self.f0) }
    }

    #[inline]
    fn lobes(&self, wo: Vec3) -> LobeChoice {
        let e = self.layer_albedo(wo.z);
        let ec = self.coat_albedo(wo.z);
        let under = 1.0 - ec;
        let dielectric = 1.0 - self.metallic;
        let opaque = dielectric * (1.0 - self.transmission);
        let metal = under * self.metallic * luminance(self.base + (Vec3::ONE - self.base) * schlick_weight(wo.z));
        let spec = under * opaque * e;
        let diffuse = under * opaque * (1.0 - e) * luminance(self.base) * (1.0 - self.subsurface);
        let glass = if self.transmission > 0.0 {
            let r = self.glass.reflect_probability(wo);
            under * dielectric * self.transmission * (r + (1.0 - r) * luminance(self.base)).max(1e-3)
        } else {
            0.0
        };
        let coat = ec;
        let total = metal + spec + diffuse + glass + coat;
        if total > 0.0 {
            LobeChoice {
                metal: metal / total,
                spec: spec / total,
                diffuse: diffuse / total,
                glass: glass / total,
                coat: coat / total,
            }
        } else {
            LobeChoice { metal: 0.0, spec: 1.0, diffuse: 0.0, glass: 0.0, coat: 0.0 }
        }
    }

    /// True when every lobe is a delta lobe (smooth clear glass): no light sampling helps.
    pub fn is_delta(&self) -> bool {
        let dielectric = 1.0 - self.metallic;
        let opaque = dielectric * (1.0 - self.transmission);
        let rough = (opaque > 0.0 && luminance(self.base) > 0.0 && self.subsurface < 1.0)
            || (!self.smooth && (self.metallic > 0.0 || (opaque > 0.0 && self.specular > 0.0)))
            || (self.transmission > 0.0 && dielectric > 0.0 && !self.glass.smooth)
            || (self.coat > 0.0 && !self.smooth_coat);
        !rough
    }

    /// f(wo, wi) of the non-delta lobes; directions in the local frame. Reflection is
    /// two-sided; transmission goes to the other side of wo.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        let (wo, wi) = flip_to_upper(wo, wi);
        if wo.z <= 0.0 || wi.z == 0.0 {
            return Vec3::ZERO;
        }
        let dielectric = 1.0 - self.metallic;
        // The coat reflects E_c(μo) of the light and leaves the rest to the layers below
        // (albedo scaling by the outgoing direction, as Cycles layers its coat).
        let under = 1.0 - self.coat_albedo(wo.z);
        let mut f = Rgb::ZERO;
        if self.transmission > 0.0 {
            f += self.glass.eval(wo, wi) * (dielectric * self.transmission);
        }
        if wi.z < 0.0 {
            return f * under;
        }
        let h = (wo + wi).normalize();
        let fw = schlick_weight(wo.dot(h).max(0.0));
        // Smooth reflection is a delta lobe: sampled only, never evaluated.
        let spec = if self.smooth { 0.0 } else { self.ggx.d(h) * self.ggx.g2(wo, wi) / (4.0 * wo.z * wi.z) };
        let opaque = dielectric * (1.0 - self.transmission);
        if opaque > 0.0 {
            // The specular weight scales the whole layer (F0 and F90), so its albedo is
            // weight × E and the albedo scaling stays exact.
            let f_layer = self.specular * (self.f0 + (1.0 - self.f0) * fw);
            let (eo, ei) = (self.layer_albedo(wo.z), self.layer_albedo(wi.z));
            let diffuse_weight = (1.0 - eo) * (1.0 - ei) / (1.0 - self.layer_avg) * (1.0 - self.subsurface);
            f += (self.base * (FRAC_1_PI * diffuse_weight) + Vec3::splat(f_layer * spec)) * opaque;
        }
        if self.metallic > 0.0 {
            f += (self.base + (Vec3::ONE - self.base) * fw) * (spec * self.metallic);
        }
        f *= under;
        if self.coat > 0.0 && !self.smooth_coat {
            let f_coat = F0_DIELECTRIC + (1.0 - F0_DIELECTRIC) * fw;
            let coat_spec = self.coat_ggx.d(h) * self.coat_ggx.g2(wo, wi) / (4.0 * wo.z * wi.z);
            f += Rgb::splat(self.coat * f_coat * coat_spec);
        }
        f
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
            pdf += c.diffuse * cosine_hemisphere_pdf(wi.z);
            if c.coat > 0.0 && !self.smooth_coat {
                pdf += c.coat * self.coat_ggx.pdf_visible_normal(wo, h) / (4.0 * wo.dot(h).max(1e-8));
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
                let weight = (1.0 - self.metallic) * self.transmission * (1.0 - self.coat_albedo(wo_up.z));
                return Some(BsdfSample { wi: mirror(s.wi), f: s.f * weight, pdf: s.pdf * c.glass, delta: true });
            }
            s.wi
        } else if uc < c.glass + c.metal + c.spec {
            if self.smooth {
                // Perfect mirror: the metal's and the dielectric layer's reflectance.
                let mu = wo_up.z;
                let under = 1.0 - self.coat_albedo(mu);
                let opaque = (1.0 - self.metallic) * (1.0 - self.transmission);
                let metal = (self.base + (Vec3::ONE - self.base) * schlick_weight(mu)) * self.metallic;
                let refl = (metal + Vec3::splat(opaque * self.layer_albedo(mu))) * under;
                let wi = Vec3::new(-wo_up.x, -wo_up.y, wo_up.z);
                return Some(BsdfSample { wi: mirror(wi), f: refl / mu, pdf: c.metal + c.spec, delta: true });
            }
            reflect(wo_up, self.ggx.sample_visible_normal(wo_up, u))
        } else if uc < c.glass + c.metal + c.spec + c.diffuse {
            cosine_hemisphere(u)
        } else {
            if self.smooth_coat {
                let mu = wo_up.z;
                let wi = Vec3::new(-wo_up.x, -wo_up.y, wo_up.z);
                return Some(BsdfSample {
                    wi: mirror(wi),
                    f: Rgb::splat(self.coat_albedo(mu) / mu),
                    pdf: c.coat,
                    delta: true,
                });
            }
            reflect(wo_up, self.coat_ggx.sample_visible_normal(wo_up, u))
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
        let mu = wo.z.abs();
        let opaque = (1.0 - self.metallic) * (1.0 - self.transmission);
        (1.0 - self.coat_albedo(mu)) * opaque * (1.0 - self.layer_albedo(mu)) * self.subsurface
    }

    /// Albedo for the denoiser: the colour a white light would reflect, roughly.
    pub fn albedo(&self) -> Rgb {
        let f0 = self.f0 * self.specular;
        let dielectric = self.base * (1.0 - f0) + Vec3::splat(f0);
        let below = dielectric * (1.0 - self.metallic) + self.base * self.metallic;
        below * (1.0 - self.coat * F0_DIELECTRIC) + Vec3::splat(self.coat * F0_DIELECTRIC)
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
        let x = mu.clamp(0.0, 1.0).sqrt() * (TABLE_N - 1) as f32;
        let y = roughness.clamp(0.0, 1.0) * (TABLE_N - 1) as f32;
        let (x0, y0) = ((x as usize).min(TABLE_N - 2), (y as usize).min(TABLE_N - 2));
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let (i00, i01) = (y0 * TABLE_N + x0, (y0 + 1) * TABLE_N + x0);
        let w = [(1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy];
        let at = |t: &[f32]| w[0] * t[i00] + w[1] * t[i00 + 1] + w[2] * t[i01] + w[3] * t[i01 + 1];
        f0 * at(&self.a) + at(&self.b)
    }

    /// Cosine-weighted average of E over the hemisphere.
    #[inline]
    pub fn e_avg(&self, roughness: f32, f0: f32) -> f32 {
        let y = roughness.clamp(0.0, 1.0) * (TABLE_N - 1) as f32;
        let y0 = (y as usize).min(TABLE_N - 2);
        let fy = y - y0 as f32;
        let lerp = |t: &[f32]| t[y0] * (1.0 - fy) + t[y0 + 1] * fy;
        f0 * lerp(&self.avg_a) + lerp(&self.avg_b)
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
                let (mut sum, mut sum2) = (0f64, 0f64);
                for _ in 0..n {
                    let u = Vec2::new(rng.next_f32(), rng.next_f32());
                    let v = b
                        .sample(wo, rng.next_f32(), u)
                        .map(|s| {
                            // Undo the 1/η² radiance scaling of refracted samples.
                            let scale = if s.wi.z < 0.0 && !b.glass.thin { b.glass.eta * b.glass.eta } else { 1.0 };
                            (s.f.max_element() * s.wi.z.abs() / s.pdf * scale) as f64
                        })
                        .unwrap_or(0.0);
                    sum += v;
                    sum2 += v * v;
                }
                let mean = sum / n as f64;
                let se = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
                assert!(mean <= 1.0 + 5.0 * se + TABLE_ERROR, "{name} θ={theta}: albedo {mean} ± {se}");
            }
        }
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
