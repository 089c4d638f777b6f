//! A dielectric interface (glass, water): Fresnel-weighted reflection and refraction,
//! smooth (delta) or rough (GGX microfacets, Walter et al. 2007, sampled through the
//! visible normals), optionally thin-walled.
//!
//! Conventions: local frame with `wo.z > 0` (the caller orients the frame toward the
//! viewer); `eta` is the relative index of refraction n(other side) / n(wo's side),
//! decided by the caller from the geometric normal (entering or leaving). Transmission is
//! tinted by `tint` (glTF: the base colour).
//!
//! Refraction follows Cycles' convention, not the radiance one: a refracted ray's value is
//! not divided by η² (Cycles' BTDF is η² times Walter's radiance BTDF, the adjoint of it:
//! its sampled weight is 1 - F whatever η; `bsdf_microfacet_eval`'s `sqr(ior)` term). Over
//! a closed object the two agree (entering and leaving cancel), but a single refracting
//! surface (a window modelled as one plane, an open mesh) does not: with the radiance
//! convention the floor seen through a glass sheet came out 1/η² of Cycles' where its light
//! does not cross the sheet. Light paths use the adjoint, 1/η² of `eval` for a refraction
//! (`Bsdf::eval_adjoint`).
//!
//! Thin-walled (glTF's default without `KHR_materials_volume`): light passes straight
//! through (smooth) or through the mirror image of the reflection lobe (rough), with
//! the interreflections of the two faces summed: R' = 2R / (1 + R), T' = 1 - R'.
//!
//! Multiple scattering between microfacets ([`DielectricBsdf::with_multiscatter`]), as
//! Cycles' Multiscatter GGX: single-scattering GGX keeps only E(μo) of the light (E from
//! `glass_albedo`, reflection plus refraction; thin sheets keep the reflection lobe's E),
//! and both lobes are scaled by 1 + F_ms (1/E(μo) - 1), with Kulla & Conty's
//! F_ms = F_ss E_avg / (1 - F_ss (1 - E_avg)) and F_ss the tint, as Cycles takes it for
//! its glass. Clear glass (F_ss = 1) then keeps exactly all of the light; the sampling is
//! unchanged (the factor depends on wo alone). The factor depends on the viewer's side,
//! so the BTDF is no longer reciprocal: [`DielectricBsdf::adjoint_ratio`] corrects the
//! generalised reciprocity that light paths rely on.
//!
//! Refraction only ([`DielectricBsdf::refraction_only`]), Cycles' Refraction BSDF: no reflection
//! lobe and no Fresnel weighting (a refracted sample keeps its whole weight, as Cycles'
//! `MicrofacetFresnel::NONE`), except where the microfacet reflects totally (no refraction
//! there: the light is lost). Every sample refracts; its density is the visible normal's
//! through the refraction Jacobian, and microfacets that reflect totally give no sample.
//!
//! Not handled: dispersion of rough glass (one IOR for all wavelengths), absorption
//! inside (the integrator applies `KHR_materials_volume` along the path).

use super::albedo::specular_albedo;
use super::glass_albedo::glass_albedo;
use super::microfacet::{Ggx, reflect};
pub use super::microfacet::{fresnel_dielectric, refract};
use super::{BsdfSample, LobeKind};
use crate::math::Rgb;
use glam::{Vec2, Vec3};

/// Roughness below which the interface is treated as perfectly smooth (delta).
pub const SMOOTH_ROUGHNESS: f32 = 0.02;

/// |η - 1| below which the interface is invisible, as Cycles treats IOR ≈ 1: light passes
/// straight through (a smooth interface; it reflects ((η-1)/(η+1))² < 10⁻⁷). A rough one
/// would be degenerate there (the half vector of a refraction with η = 1 is the zero
/// vector, and near it f32 cancellation in wo + η wi leaves the half vector's direction
/// wrong by ~10⁻⁷/|η - 1| rad); a microfacet tilted by θm bends a ray by about
/// |η - 1| tan θm, under 10⁻³ rad here for all but the most grazing facets: invisible.
pub const INVISIBLE_ETA: f32 = 1e-3;

/// The dielectric interface.
#[derive(Clone, Copy, Debug)]
pub struct DielectricBsdf {
    /// Relative index of refraction (other side over wo's side).
    pub eta: f32,
    /// Microfacets (ignored when smooth).
    pub ggx: Ggx,
    /// Perfectly smooth: reflection and refraction are delta lobes.
    pub smooth: bool,
    /// Thin-walled sheet (no refraction bending).
    pub thin: bool,
    /// Colour of transmitted light.
    pub tint: Rgb,
    /// Relative index per RGB channel when the glass disperses (`KHR_materials_dispersion`).
    pub eta_rgb: Option<Vec3>,
    /// Perceptual roughness (the albedo tables' axis).
    roughness: f32,
    /// Kulla & Conty's F_ms per channel of the multiple-scattering compensation; zero
    /// when it is off (smooth, or not asked for).
    ms_fms: Rgb,
    /// Cycles' Refraction BSDF: refraction alone, unweighted by Fresnel (module doc).
    refract_only: bool,
    /// Scale of the reflection (Cycles' `reflection_tint`): 0 once Reflective Caustics
    /// dropped it, sampling unchanged (the dropped half then carries no weight).
    reflect_scale: f32,
}

/// Wavelengths (nm) that stand for the R, G and B channels in dispersion: the peaks of
/// the Rec.709 primaries' spectra, roughly.
pub const RGB_WAVELENGTHS: [f32; 3] = [630.0, 532.0, 465.0];

/// Index of refraction at wavelength `lambda` (nm) of a glass with index `ior` at the d line
/// and `dispersion` = 20 / Abbe number, as `KHR_materials_dispersion` defines it (a Cauchy
/// fit through the F, d and C lines), never below 1.
#[inline]
pub fn dispersed_ior(ior: f32, dispersion: f32, lambda: f32) -> f32 {
    let abbe = 20.0 / dispersion;
    (ior + (ior - 1.0) / abbe * (523_655.0 / (lambda * lambda) - 1.5168)).max(1.0)
}

impl DielectricBsdf {
    /// αx·αy of its microfacets, 0 when smooth (Cycles' specular roughness squared).
    pub fn alpha2(&self) -> f32 {
        if self.smooth {
            return 0.0;
        }
        let (x, y) = self.ggx.alphas();
        x * y
    }

    /// Filter Glossy's blur (`Bsdf::blur`): microfacets at least `alpha` wide; a smooth
    /// interface becomes rough past the smooth threshold. The multiple-scattering compensation
    /// stays the original roughness's, as Cycles does not recompute it.
    pub fn blur(&mut self, alpha: f32) {
        if (self.eta - 1.0).abs() < INVISIBLE_ETA {
            return;
        }
        self.ggx = self.ggx.blurred(alpha);
        let (x, y) = self.ggx.alphas();
        if x.max(y).sqrt() >= SMOOTH_ROUGHNESS {
            self.smooth = false;
        }
    }

    /// An interface from glTF parameters.
    pub fn new(eta: f32, roughness: f32, thin: bool, tint: Rgb) -> Self {
        DielectricBsdf {
            eta: if eta.is_finite() && eta > 0.0 { eta } else { 1.0 },
            ggx: Ggx::from_roughness(roughness),
            smooth: roughness < SMOOTH_ROUGHNESS || !((eta - 1.0).abs() >= INVISIBLE_ETA),
            thin,
            tint,
            eta_rgb: None,
            roughness,
            ms_fms: Rgb::ZERO,
            refract_only: false,
            reflect_scale: 1.0,
        }
    }

    /// The same interface refracting only, as Cycles' Refraction BSDF (module doc): a solid's
    /// interface (not thin), without multiple-scattering compensation (Cycles has none for it).
    pub fn refraction_only(mut self) -> Self {
        self.refract_only = true;
        self.thin = false;
        self.ms_fms = Rgb::ZERO;
        self
    }

    /// The same interface on Beckmann's microfacets (Cycles' "Beckmann" Glass and Refraction
    /// BSDFs), which Cycles does not compensate for multiple scattering.
    pub fn with_beckmann(mut self) -> Self {
        self.ggx = self.ggx.with_beckmann();
        self.ms_fms = Rgb::ZERO;
        self
    }

    /// Drops the reflection (`reflective`) and the refraction (`refractive`) as Cycles'
    /// caustics switches zero the glass's `reflection_tint` and `transmission_tint`.
    pub fn drop_caustics(&mut self, reflective: bool, refractive: bool) {
        if reflective {
            self.reflect_scale = 0.0;
        }
        if refractive {
            self.tint = Rgb::ZERO;
        }
    }

    /// Refracts only (Cycles' Refraction BSDF).
    pub fn refracts_only(&self) -> bool {
        self.refract_only
    }

    /// What a refraction through a microfacet at cos θ to wo keeps, before the tint: 1 − F,
    /// or, refracting only, 1 unless the microfacet reflects totally.
    #[inline]
    fn transmittance(&self, cos: f32) -> f32 {
        let f = fresnel_dielectric(cos, self.eta);
        if !self.refract_only {
            1.0 - f
        } else if f >= 1.0 {
            0.0
        } else {
            1.0
        }
    }

    /// The same interface with the energy that single-scattering GGX loses restored
    /// (module doc); a smooth interface loses none.
    pub fn with_multiscatter(mut self) -> Self {
        if !self.smooth && !self.ggx.beckmann {
            self.ms_fms = self.fms(self.eta);
        }
        self
    }

    /// F_ms for the tint on the side where the relative IOR is `eta`.
    fn fms(&self, eta: f32) -> Rgb {
        let e_avg = if self.thin {
            specular_albedo().e_avg_white(self.roughness)
        } else {
            glass_albedo().e_avg(self.roughness, eta)
        };
        let fss = self.tint.clamp(Vec3::ZERO, Vec3::ONE);
        fss * e_avg / (Vec3::ONE - fss * (1.0 - e_avg)).max(Vec3::splat(1e-6))
    }

    /// The compensation factor 1 + F_ms (1/E(μo) - 1) seen from μo on the side of `eta`.
    #[inline]
    fn ms_factor(&self, fms: Rgb, mu_o: f32, eta: f32) -> Rgb {
        let e = if self.thin {
            specular_albedo().e_white(mu_o, self.roughness)
        } else {
            glass_albedo().e(mu_o, self.roughness, eta)
        };
        // E is never below ~0.3 on the tables' domain; the floor only guards the division.
        Rgb::ONE + fms * (1.0 / e.max(0.05) - 1.0)
    }

    /// The multiple-scattering factor of both lobes seen from `wo` (1 when off).
    #[inline]
    pub fn multiscatter(&self, wo: Vec3) -> Rgb {
        if self.ms_fms == Rgb::ZERO { Rgb::ONE } else { self.ms_factor(self.ms_fms, wo.z.abs(), self.eta) }
    }

    /// For a refracted pair (wo, wi), η² f(wi, wo) / f(wo, wi): 1 for single scattering
    /// (Cycles' BTDF is η² times a reciprocal one), else the compensation seen from wi (on
    /// the other side, η → 1/η; the same η for a thin sheet) over that seen from wo.
    #[inline]
    pub fn adjoint_ratio(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if self.ms_fms == Rgb::ZERO {
            return Rgb::ONE;
        }
        let eta_i = if self.thin { self.eta } else { 1.0 / self.eta };
        let fms_i = if self.thin { self.ms_fms } else { self.fms(eta_i) };
        self.ms_factor(fms_i, wi.z.abs(), eta_i) / self.multiscatter(wo)
    }

    /// The same interface with an index per channel from `dispersion` (only smooth solid
    /// glass disperses; the loader warns about rough dispersive glass).
    pub fn with_dispersion(mut self, ior: f32, dispersion: f32) -> Self {
        if !self.smooth || self.thin || !(dispersion > 0.0) || !(ior > 1.0) {
            return self;
        }
        let n = RGB_WAVELENGTHS.map(|l| dispersed_ior(ior, dispersion, l));
        // `eta` is ior entering and 1/ior leaving: keep the direction for each channel.
        let entering = self.eta >= 1.0;
        self.eta_rgb = Some(Vec3::from(n.map(|n| if entering { n } else { 1.0 / n })));
        self
    }

    /// Reflectance at normal incidence... and at `cos`, with the thin-wall sum.
    #[inline]
    fn reflectance(&self, cos: f32) -> f32 {
        let r = fresnel_dielectric(cos, self.eta);
        if self.thin { 2.0 * r / (1.0 + r) } else { r }
    }

    /// Fraction reflected at `wo` for sampling decisions (exact when smooth; 0 refracting only).
    pub fn reflect_probability(&self, wo: Vec3) -> f32 {
        if self.refract_only { 0.0 } else { self.reflectance(wo.z) }
    }

    /// f(wo, wi) of the non-delta part (zero when smooth).
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if self.smooth || wo.z <= 0.0 || wi.z == 0.0 || (self.refract_only && wi.z > 0.0) {
            return Rgb::ZERO;
        }
        if wi.z > 0.0 || self.thin {
            // Reflection, or thin transmission through the mirrored reflection lobe.
            let wr = Vec3::new(wi.x, wi.y, wi.z.abs());
            let m = (wo + wr).normalize();
            let f = self.reflectance(wo.dot(m));
            let spec = self.ggx.d(m) * self.ggx.g2(wo, wr) / (4.0 * wo.z * wr.z);
            let value =
                if wi.z > 0.0 { Rgb::splat(f * spec * self.reflect_scale) } else { self.tint * ((1.0 - f) * spec) };
            return value * self.multiscatter(wo);
        }
        let Some(m) = self.half_vector_transmission(wo, wi) else {
            return Rgb::ZERO;
        };
        let (dot_o, dot_i) = (wo.dot(m), wi.dot(m));
        let t = self.transmittance(dot_o);
        let denom = dot_i + dot_o / self.eta;
        let value = self.ggx.d(m) * t * self.ggx.g2(wo, Vec3::new(wi.x, wi.y, -wi.z)) * (dot_i * dot_o).abs()
            / (denom * denom * wi.z.abs() * wo.z);
        // Cycles' convention (module doc): Walter's radiance BTDF times η².
        self.tint * self.multiscatter(wo) * value
    }

    /// Generalised half vector of a refraction pair, oriented to +Z; None for pairs that
    /// no microfacet can produce.
    #[inline]
    fn half_vector_transmission(&self, wo: Vec3, wi: Vec3) -> Option<Vec3> {
        let m = wi * self.eta + wo;
        if m.length_squared() == 0.0 {
            return None;
        }
        let mut m = m.normalize();
        if m.z < 0.0 {
            m = -m;
        }
        // The microfacet must face wo and face away from wi.
        if wo.dot(m) <= 0.0 || wi.dot(m) >= 0.0 {
            return None;
        }
        Some(m)
    }

    /// Density of `sample` for the non-delta part.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.smooth || wo.z <= 0.0 || wi.z == 0.0 || (self.refract_only && wi.z > 0.0) {
            return 0.0;
        }
        if wi.z > 0.0 || self.thin {
            let wr = Vec3::new(wi.x, wi.y, wi.z.abs());
            let m = (wo + wr).normalize();
            let r = self.reflectance(wo.dot(m));
            let p = if wi.z > 0.0 { r } else { 1.0 - r };
            return p * self.ggx.pdf_visible_normal(wo, m) / (4.0 * wo.dot(m).max(1e-8));
        }
        let Some(m) = self.half_vector_transmission(wo, wi) else {
            return 0.0;
        };
        let (dot_o, dot_i) = (wo.dot(m), wi.dot(m));
        // Refracting only, every sample refracts (but not through totally reflecting facets).
        let t = self.transmittance(dot_o);
        let denom = dot_i + dot_o / self.eta;
        t * self.ggx.pdf_visible_normal(wo, m) * dot_i.abs() / (denom * denom)
    }

    /// Samples reflection or transmission; `uc` chooses, `u` picks the microfacet.
    #[inline]
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        if self.smooth && self.refract_only {
            // All of it refracts, unless it reflects totally (then nothing: Cycles' closure).
            let wi = refract(wo, Vec3::Z, self.eta)?;
            return Some(BsdfSample { wi, f: self.tint / wi.z.abs(), pdf: 1.0, delta: true, kind: LobeKind::Glossy });
        }
        if self.smooth {
            let r = self.reflectance(wo.z);
            if uc < r {
                let wi = Vec3::new(-wo.x, -wo.y, wo.z);
                let f = Rgb::splat(r * self.reflect_scale / wi.z);
                return Some(BsdfSample { wi, f, pdf: r, delta: true, kind: LobeKind::Glossy });
            }
            let t = 1.0 - r;
            if self.thin {
                let wi = -wo;
                return Some(BsdfSample {
                    wi,
                    f: self.tint * (t / wi.z.abs()),
                    pdf: t,
                    delta: true,
                    kind: LobeKind::Glossy,
                });
            }
            if let Some(etas) = self.eta_rgb {
                // Dispersion: one channel's wavelength refracts, chosen uniformly (the rest of
                // the path carries that channel alone, ×3); its own Fresnel applies.
                let v = ((uc - r) / t).clamp(0.0, 0.999_999);
                let c = (v * 3.0) as usize;
                let eta = etas[c];
                let wi = refract(wo, Vec3::Z, eta)?;
                let tc = 1.0 - fresnel_dielectric(wo.z, eta);
                let mut mask = Vec3::ZERO;
                mask[c] = 3.0;
                let f = self.tint * mask * (tc / wi.z.abs());
                return Some(BsdfSample { wi, f, pdf: t, delta: true, kind: LobeKind::Glossy });
            }
            let wi = refract(wo, Vec3::Z, self.eta)?;
            let f = self.tint * (t / wi.z.abs());
            return Some(BsdfSample { wi, f, pdf: t, delta: true, kind: LobeKind::Glossy });
        }
        let m = self.ggx.sample_visible_normal(wo, u);
        let r = if self.refract_only { 0.0 } else { self.reflectance(wo.dot(m)) };
        let wi = if uc < r {
            reflect(wo, m)
        } else if self.thin {
            let w = reflect(wo, m);
            Vec3::new(w.x, w.y, -w.z)
        } else {
            refract(wo, m, self.eta)?
        };
        // A reflection must stay above, a refraction go below.
        if (uc < r) != (wi.z > 0.0) {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample { wi, f: self.eval(wo, wi), pdf, delta: false, kind: LobeKind::Glossy })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Dispersive glass: each channel refracts by Snell's law with its own index (blue
    /// bends most), and per channel the sampled transmission weight averages to 1 - F(η_c)
    /// (Cycles' convention: no η²), so no channel gains or loses energy.
    #[test]
    fn dispersion_follows_snell_per_channel() {
        let (ior, dispersion) = (1.5f32, 20.0 / 30.0); // Abbe number 30 (dense flint-like)
        let n = RGB_WAVELENGTHS.map(|l| dispersed_ior(ior, dispersion, l));
        assert!(n[0] < n[1] && n[1] < n[2], "normal dispersion: {n:?}");
        assert!((dispersed_ior(ior, dispersion, 587.56) - ior).abs() < 2e-3, "d line keeps the index");
        for entering in [true, false] {
            let eta = if entering { ior } else { 1.0 / ior };
            let b = DielectricBsdf::new(eta, 0.0, false, Rgb::ONE).with_dispersion(ior, dispersion);
            let theta = if entering { 0.9f32 } else { 0.5 };
            let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
            let m = 30_000;
            let mut sum = Vec3::ZERO;
            for i in 0..m {
                let uc = (i as f32 + 0.5) / m as f32;
                let Some(s) = b.sample(wo, uc, Vec2::splat(0.5)) else { continue };
                if s.wi.z > 0.0 {
                    continue;
                }
                let c = (0..3).find(|&c| s.f[c] > 0.0).unwrap();
                let eta_c = if entering { n[c] } else { 1.0 / n[c] };
                let sin_t = (s.wi.x * s.wi.x + s.wi.y * s.wi.y).sqrt();
                assert!((theta.sin() - eta_c * sin_t).abs() < 1e-5, "Snell for channel {c}");
                sum += s.f * s.wi.z.abs() / s.pdf;
            }
            let mean = sum / m as f32;
            for c in 0..3 {
                let eta_c = if entering { n[c] } else { 1.0 / n[c] };
                let expect = 1.0 - fresnel_dielectric(wo.z, eta_c);
                // Stratified over uc in thirds: the estimate is exact up to the strata's rounding.
                assert!((mean[c] - expect).abs() < 5e-3, "channel {c}: {} vs {expect}", mean[c]);
            }
        }
    }
    use crate::sampling::chi2::{ChiSquareTest, Pcg32, assert_chi2};

    #[test]
    fn chi2_rough_dielectric() {
        for &eta in &[1.33f32, 1.5, 2.4, 1.0 / 1.5] {
            for &roughness in &[0.3f32, 0.6, 1.0] {
                for &thin in &[false, true] {
                    for &theta in &[0.2f32, 0.9, 1.3] {
                        let b = DielectricBsdf::new(eta, roughness, thin, Rgb::ONE);
                        let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                        let mut rng = Pcg32::new(11);
                        let t = ChiSquareTest::new(&format!("dielectric η={eta} r={roughness} thin={thin} θ={theta}"));
                        assert_chi2(t.run_with_pdf(
                            |u| b.sample(wo, rng.next_f32(), u).map(|s| (s.wi, s.pdf)),
                            |wi| b.pdf(wo, wi),
                        ));
                    }
                }
            }
        }
    }

    /// Beckmann's interface (Cycles' "Beckmann" Glass and Refraction BSDFs): sampling matches
    /// the density, entering and leaving, glass and refracting only.
    #[test]
    fn chi2_beckmann_dielectric() {
        for &eta in &[1.5f32, 1.0 / 1.5] {
            for &roughness in &[0.3f32, 0.8] {
                for &refract_only in &[false, true] {
                    for &theta in &[0.2f32, 1.2] {
                        let b = DielectricBsdf::new(eta, roughness, false, Rgb::ONE).with_beckmann();
                        let b = if refract_only { b.refraction_only() } else { b };
                        let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                        let mut rng = Pcg32::new(17);
                        let t = ChiSquareTest::new(&format!(
                            "Beckmann dielectric η={eta} r={roughness} refract_only={refract_only} θ={theta}"
                        ));
                        assert_chi2(t.run_with_pdf(
                            |u| b.sample(wo, rng.next_f32(), u).map(|s| (s.wi, s.pdf)),
                            |wi| b.pdf(wo, wi),
                        ));
                    }
                }
            }
        }
    }

    /// Refracting only (Cycles' Refraction BSDF): sampling matches the density, rough, entering
    /// and leaving (where facets reflect totally and give no sample).
    #[test]
    fn chi2_refraction_only() {
        for &eta in &[1.5f32, 1.0 / 1.5, 1.33] {
            for &roughness in &[0.3f32, 0.8] {
                for &theta in &[0.2f32, 0.9, 1.3] {
                    let b = DielectricBsdf::new(eta, roughness, false, Rgb::ONE).refraction_only();
                    let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                    let mut rng = Pcg32::new(13);
                    let t = ChiSquareTest::new(&format!("refraction only η={eta} r={roughness} θ={theta}"));
                    assert_chi2(
                        t.run_with_pdf(|u| b.sample(wo, rng.next_f32(), u).map(|s| (s.wi, s.pdf)), |wi| b.pdf(wo, wi)),
                    );
                }
            }
        }
    }

    /// Refracting only: nothing is reflected; a smooth interface passes all of the light (the
    /// weight is the tint, no 1 − F), and none beyond the critical angle; a sampled rough
    /// refraction's value is `eval` and its weight is the tint (Fresnel-free).
    #[test]
    fn refraction_only_keeps_the_whole_weight() {
        let tint = Rgb::new(0.9, 0.5, 0.2);
        let smooth = DielectricBsdf::new(1.5, 0.0, false, tint).refraction_only();
        let wo = Vec3::new(0.8f32.sin(), 0.0, 0.8f32.cos());
        let s = smooth.sample(wo, 0.01, Vec2::ZERO).unwrap();
        assert!(s.wi.z < 0.0 && s.delta);
        assert!((s.f * s.wi.z.abs() / s.pdf - tint).abs().max_element() < 1e-6);
        let inside = DielectricBsdf::new(1.0 / 1.5, 0.0, false, tint).refraction_only();
        let beyond = 45f32.to_radians();
        assert!(inside.sample(Vec3::new(beyond.sin(), 0.0, beyond.cos()), 0.5, Vec2::ZERO).is_none());
        let rough = DielectricBsdf::new(1.5, 0.4, false, tint).refraction_only();
        assert_eq!(rough.reflect_probability(wo), 0.0);
        assert_eq!(rough.eval(wo, Vec3::new(-0.3, 0.1, 0.95).normalize()), Rgb::ZERO);
        let mut rng = Pcg32::new(2);
        for _ in 0..100 {
            let Some(s) = rough.sample(wo, rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32())) else { continue };
            assert!(s.wi.z < 0.0);
            assert!((s.f - rough.eval(wo, s.wi)).abs().max_element() < 1e-5);
        }
    }

    /// A smooth interface: R + T = 1 for every angle (the sampled weights sum to one),
    /// the refracted direction obeys Snell's law, and beyond the critical angle all
    /// light is reflected.
    #[test]
    fn smooth_energy_snell_and_tir() {
        for &eta in &[1.33f32, 1.5, 2.4] {
            let b = DielectricBsdf::new(eta, 0.0, false, Rgb::ONE);
            for i in 1..20 {
                let theta = i as f32 / 20.0 * 1.5;
                let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                let r = b.sample(wo, 0.0, Vec2::ZERO).unwrap();
                let t = b.sample(wo, 0.999_999, Vec2::ZERO).unwrap();
                // Weight of each choice = f |cos| / pdf · P(choice) (Cycles' convention: no η²).
                let r_part = r.f.x * r.wi.z.abs();
                let t_part = t.f.x * t.wi.z.abs();
                assert!((r_part + t_part - 1.0).abs() < 1e-5, "η={eta} θ={theta}: R+T = {}", r_part + t_part);
                // Snell: sin θo = η sin θt.
                let sin_t = (t.wi.x * t.wi.x + t.wi.y * t.wi.y).sqrt();
                assert!((theta.sin() - eta * sin_t).abs() < 1e-5);
                assert!(t.wi.z < 0.0 && t.wi.x < 0.0, "refracted ray continues forward");
            }
        }
        // From inside glass (η = 1/1.5) the critical angle is asin(1/1.5) ≈ 41.8°.
        let inside = DielectricBsdf::new(1.0 / 1.5, 0.0, false, Rgb::ONE);
        let beyond = 45f32.to_radians();
        let wo = Vec3::new(beyond.sin(), 0.0, beyond.cos());
        assert_eq!(inside.reflect_probability(wo), 1.0);
        let s = inside.sample(wo, 0.999, Vec2::ZERO).unwrap();
        assert!(s.wi.z > 0.0, "total internal reflection");
        let before = 40f32.to_radians();
        assert!(inside.reflect_probability(Vec3::new(before.sin(), 0.0, before.cos())) < 1.0);
    }

    /// Normal-incidence Fresnel is ((η-1)/(η+1))² and symmetric in η ↔ 1/η.
    #[test]
    fn fresnel_normal_incidence() {
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        assert!((fresnel_dielectric(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-6);
        assert_eq!(fresnel_dielectric(1.0, 1.0), 0.0);
    }

    /// The rough interface's albedo (reflection + transmission; Cycles' convention has no
    /// η² in a refraction's weight) is at most 1, within 5 standard errors (Beckmann's: and
    /// its Λ fit).
    #[test]
    fn rough_albedo_at_most_one() {
        let n = 100_000;
        for &eta in &[1.5f32, 1.0 / 1.5] {
            for &roughness in &[0.3f32, 1.0] {
                for (theta, beckmann) in [(0.1f32, false), (1.0, false), (1.45, false), (0.1, true), (1.45, true)] {
                    let b = DielectricBsdf::new(eta, roughness, false, Rgb::ONE);
                    let b = if beckmann { b.with_beckmann() } else { b };
                    let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                    let mut rng = Pcg32::new(5);
                    let (mut sum, mut sum2) = (0f64, 0f64);
                    for _ in 0..n {
                        let u = Vec2::new(rng.next_f32(), rng.next_f32());
                        let v = b
                            .sample(wo, rng.next_f32(), u)
                            .map(|s| (s.f.x * s.wi.z.abs() / s.pdf) as f64)
                            .unwrap_or(0.0);
                        sum += v;
                        sum2 += v * v;
                    }
                    let mean = sum / n as f64;
                    let se = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
                    // Cycles' rational Λ for Beckmann's G2 lies up to 0.4 % below the exact Λ of the
                    // sampled density (`beckmann::tests::lambda_fit_is_close`): up to that much gain.
                    let fit = if beckmann { 4e-3 } else { 0.0 };
                    assert!(mean <= 1.0 + 5.0 * se + fit, "η={eta} r={roughness} θ={theta} {beckmann}: {mean} ± {se}");
                }
            }
        }
    }
}
