//! The GGX / Trowbridge-Reitz microfacet distribution with Smith masking, isotropic or
//! anisotropic (widths αx along the local X axis, αy along Y), and Heitz's (2018) sampling
//! of the distribution of visible normals. The isotropic case keeps its own formulas (the
//! anisotropic ones with αx = αy are the same function, rounded differently). The same
//! type holds Beckmann's distribution (`beckmann.rs`) for Blender's BSDFs that choose it.

use super::beckmann;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Smallest α used: below this, f32 evaluation of D loses precision and the lobe is a
/// mirror for all practical purposes.
pub const MIN_ALPHA: f32 = 1e-3;

/// GGX with roughness α (= perceptual roughness², as glTF and Blender define it), or
/// Beckmann's distribution of the same widths.
#[derive(Clone, Copy, Debug)]
pub struct Ggx {
    /// Width α (along X when anisotropic).
    pub alpha: f32,
    /// Width along Y when it differs from `alpha` (anisotropic).
    pub alpha_y: Option<f32>,
    /// Beckmann's distribution instead of GGX (Cycles' "Beckmann").
    pub beckmann: bool,
}

impl Ggx {
    /// The distribution for a glTF/Blender perceptual roughness in [0, 1].
    pub fn from_roughness(roughness: f32) -> Self {
        Ggx { alpha: (roughness * roughness).max(MIN_ALPHA), alpha_y: None, beckmann: false }
    }

    /// An anisotropic distribution of widths αx (along local X) and αy (along Y).
    pub fn anisotropic(alpha_x: f32, alpha_y: f32) -> Self {
        let (ax, ay) = (alpha_x.max(MIN_ALPHA), alpha_y.max(MIN_ALPHA));
        Ggx { alpha: ax, alpha_y: (ax != ay).then_some(ay), beckmann: false }
    }

    /// The widths raised to at least `alpha` each (Cycles' `bsdf_microfacet_blur`, Filter
    /// Glossy).
    pub fn blurred(self, alpha: f32) -> Self {
        let (x, y) = self.alphas();
        let (x, y) = (x.max(alpha), y.max(alpha));
        Ggx { alpha: x, alpha_y: (x != y).then_some(y), beckmann: self.beckmann }
    }

    /// The same widths with Beckmann's distribution.
    pub fn with_beckmann(self) -> Self {
        Ggx { beckmann: true, ..self }
    }

    /// The widths (αx, αy).
    #[inline]
    pub fn alphas(&self) -> (f32, f32) {
        (self.alpha, self.alpha_y.unwrap_or(self.alpha))
    }

    /// Normal distribution D(m), local frame.
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        if self.beckmann {
            let (ax, ay) = self.alphas();
            return beckmann::d(ax, ay, m);
        }
        if let Some(ay) = self.alpha_y {
            let ax = self.alpha;
            let (x, y) = (m.x / ax, m.y / ay);
            let t = x * x + y * y + m.z * m.z;
            return 1.0 / (PI * ax * ay * t * t);
        }
        let a2 = self.alpha * self.alpha;
        let t = m.z * m.z * (a2 - 1.0) + 1.0;
        a2 / (PI * t * t)
    }

    /// Smith's Λ(w) (Beckmann: Cycles' rational approximation, what its images show).
    #[inline]
    pub fn lambda(&self, w: Vec3) -> f32 {
        let cos2 = w.z * w.z;
        if cos2 >= 1.0 {
            return 0.0;
        }
        if self.beckmann {
            let (ax, ay) = self.alphas();
            return beckmann::lambda_cycles(ax, ay, w);
        }
        if let Some(ay) = self.alpha_y {
            // α projected on w's azimuth: tan²θ α² = ((αx wx)² + (αy wy)²) / wz².
            let ax = self.alpha;
            let a2tan2 = ((ax * w.x) * (ax * w.x) + (ay * w.y) * (ay * w.y)) / cos2.max(1e-12);
            return 0.5 * (-1.0 + (1.0 + a2tan2).sqrt());
        }
        let tan2 = (1.0 - cos2) / cos2.max(1e-12);
        0.5 * (-1.0 + (1.0 + self.alpha * self.alpha * tan2).sqrt())
    }

    /// Masking G1(w).
    #[inline]
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated masking-shadowing G2(wo, wi).
    #[inline]
    pub fn g2(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Density of visible normals D_wo(m) = G1(wo) max(0, wo·m) D(m) / wo.z (Beckmann's with
    /// the exact Λ: the density of what `sample_visible_normal` draws).
    #[inline]
    pub fn pdf_visible_normal(&self, wo: Vec3, m: Vec3) -> f32 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        let g1 = if self.beckmann {
            let (ax, ay) = self.alphas();
            1.0 / (1.0 + beckmann::lambda_exact(ax, ay, wo))
        } else {
            self.g1(wo)
        };
        g1 * wo.dot(m).max(0.0) * self.d(m) / wo.z
    }

    /// Samples a visible normal for `wo` (wo.z > 0).
    #[inline]
    pub fn sample_visible_normal(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let (a, ay) = self.alphas();
        if self.beckmann {
            return beckmann::sample_visible_normal(a, ay, wo, u);
        }
        // Stretch the view so the distribution becomes the hemisphere of radius 1.
        let vh = Vec3::new(a * wo.x, ay * wo.y, wo.z).normalize();
        let len2 = vh.x * vh.x + vh.y * vh.y;
        let t1 = if len2 > 0.0 { Vec3::new(-vh.y, vh.x, 0.0) / len2.sqrt() } else { Vec3::X };
        let t2 = vh.cross(t1);
        // Uniform point on the projected disk, warped toward the visible half.
        let r = u.x.sqrt();
        let phi = 2.0 * PI * u.y;
        let p1 = r * phi.cos();
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
        let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
        // Unstretch.
        Vec3::new(a * nh.x, ay * nh.y, nh.z.max(1e-6)).normalize()
    }
}

/// Mirror `w` about `m`.
#[inline]
pub fn reflect(w: Vec3, m: Vec3) -> Vec3 {
    2.0 * w.dot(m) * m - w
}

/// Schlick's Fresnel weight (1 - cos)^5.
#[inline]
pub fn schlick_weight(cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// Cycles' F82-tint factor b (Kutz et al., "Novel aspects of the Adobe Standard Material"):
/// the (1 − cos)⁶ term's weight that makes [`f82_tint`] at cos θ = 1/7 (about 82°) Schlick's
/// times `tint`; zero for a white tint.
#[inline]
pub fn f82_tint_b(f0: Vec3, tint: Vec3) -> Vec3 {
    let f = 6.0f32 / 7.0;
    let f5 = f * f * f * f * f;
    let schlick = f0 + (Vec3::ONE - f0) * f5;
    schlick * (7.0 / (f5 * f)) * (Vec3::ONE - tint)
}

/// The F82-tint factor b whose curve passes through `f82` at cos θ = 1/7 (Cycles'
/// `fresnel_f82_B`, which fits the model to a physical conductor).
#[inline]
pub fn f82_b_through(f0: Vec3, f82: Vec3) -> Vec3 {
    let f = 6.0f32 / 7.0;
    let f5 = f * f * f * f * f;
    (f0 + (Vec3::ONE - f0) * f5 - f82) * (7.0 / (f5 * f))
}

/// The F82-tint reflectance at cos θ: Schlick's of `f0` minus b cos θ (1 − cos θ)⁶, saturated.
#[inline]
pub fn f82_tint(f0: Vec3, b: Vec3, cos: f32) -> Vec3 {
    let s = (1.0 - cos).clamp(0.0, 1.0);
    let s5 = s * s * s * s * s;
    (f0 + (Vec3::ONE - f0) * s5 - b * (cos * s5 * s)).clamp(Vec3::ZERO, Vec3::ONE)
}

/// Unpolarised Fresnel reflectance of a conductor of complex index n + ik (per channel) for
/// cosine `cos` of the incident direction, exact (the s and p reflectances averaged), as
/// Cycles' physical-conductor Metallic BSDF (`fresnel_conductor`).
#[inline]
pub fn conductor_fresnel(cos: f32, n: Vec3, k: Vec3) -> Vec3 {
    let c2 = cos.clamp(0.0, 1.0).powi(2);
    let s2 = 1.0 - c2;
    let (n2, k2) = (n * n, k * k);
    // a² + b² = |(n + ik)² − sin²θ|, a its real square root's real part.
    let t0 = n2 - k2 - Vec3::splat(s2);
    let ab2 = (t0 * t0 + 4.0 * n2 * k2).powf(0.5);
    let a = (0.5 * (ab2 + t0)).max(Vec3::ZERO).powf(0.5);
    let t1 = ab2 + Vec3::splat(c2);
    let t2 = 2.0 * cos.clamp(0.0, 1.0) * a;
    let rs = (t1 - t2) / (t1 + t2).max(Vec3::splat(1e-20));
    let t3 = c2 * ab2 + Vec3::splat(s2 * s2);
    let t4 = t2 * s2;
    let rp = rs * (t3 - t4) / (t3 + t4).max(Vec3::splat(1e-20));
    (0.5 * (rs + rp)).clamp(Vec3::ZERO, Vec3::ONE)
}

/// Unpolarised Fresnel reflectance of a dielectric interface for cosine `cos_i` of the
/// incident direction and relative index `eta` (transmitted over incident). 1 under
/// total internal reflection.
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parl * r_parl + r_perp * r_perp)
}

/// Refracts `w` (pointing away from the surface, on the side of `n`) through the
/// interface with relative index `eta`; None under total internal reflection.
#[inline]
pub fn refract(w: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = n.dot(w);
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-w / eta + n * (cos_i / eta - cos_t))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{ChiSquareTest, assert_chi2};

    #[test]
    fn conductor_fresnel_limits() {
        // Normal incidence: ((n − 1)² + k²) / ((n + 1)² + k²); k = 0: the dielectric's;
        // grazing: 1 (the limits the exact formula must meet whatever its algebra).
        let (n, k) = (Vec3::new(0.18, 1.3, 2.757), Vec3::new(3.42, 0.0, 3.867));
        let f0 = (n - 1.0) * (n - 1.0) + k * k;
        let f0 = f0 / ((n + 1.0) * (n + 1.0) + k * k);
        assert!((conductor_fresnel(1.0, n, k) - f0).abs().max_element() < 1e-6);
        for cos in [0.05f32, 0.3, 0.7, 1.0] {
            let f = conductor_fresnel(cos, Vec3::splat(1.5), Vec3::ZERO);
            assert!((f.x - fresnel_dielectric(cos, 1.5)).abs() < 1e-5, "{cos}: {f}");
        }
        assert!((conductor_fresnel(0.0, n, k) - Vec3::ONE).abs().max_element() < 1e-6);
        // Gold's (n, k) at 45°, from the complex Fresnel equations evaluated in f64:
        // rs = |cos − w|² / |cos + w|², rp = |m cos − w|² / |m cos + w|², w = sqrt(m − sin²), m = (n + ik)².
        let gold = conductor_fresnel(std::f32::consts::FRAC_1_SQRT_2, Vec3::splat(0.18), Vec3::splat(3.42));
        let reference = complex_fresnel(std::f64::consts::FRAC_1_SQRT_2, 0.18, 3.42);
        assert!((gold.x as f64 - reference).abs() < 1e-5, "{} against {reference}", gold.x);
    }

    /// The unpolarised conductor Fresnel straight from complex arithmetic (f64).
    fn complex_fresnel(cos: f64, n: f64, k: f64) -> f64 {
        let (mr, mi) = (n * n - k * k, 2.0 * n * k);
        let (zr, zi) = (mr - (1.0 - cos * cos), mi);
        let r = (zr * zr + zi * zi).sqrt();
        let (wr, wi) = (((r + zr) / 2.0).sqrt(), ((r - zr) / 2.0).sqrt().copysign(zi));
        let abs2 = |a: f64, b: f64| a * a + b * b;
        let rs = abs2(cos - wr, -wi) / abs2(cos + wr, wi);
        let (pr, pi) = (mr * cos, mi * cos);
        let rp = abs2(pr - wr, pi - wi) / abs2(pr + wr, pi + wi);
        (rs + rp) / 2.0
    }

    #[test]
    fn chi2_visible_normals() {
        for roughness in [0.2f32, 0.5, 1.0] {
            for theta in [0.0f32, 0.8, 1.4] {
                let ggx = Ggx::from_roughness(roughness);
                let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                let t = ChiSquareTest::new(&format!("GGX visible normals r={roughness} θ={theta}"));
                assert_chi2(t.run(|u| Some(ggx.sample_visible_normal(wo, u)), |m| ggx.pdf_visible_normal(wo, m)));
            }
        }
    }

    #[test]
    fn chi2_anisotropic_visible_normals() {
        for (ax, ay) in [(0.05f32, 0.4f32), (0.6, 0.1), (1.0, 0.3)] {
            for (theta, phi) in [(0.0f32, 0.0f32), (0.8, 0.7), (1.4, 2.0)] {
                let ggx = Ggx::anisotropic(ax, ay);
                let wo = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
                let t =
                    ChiSquareTest::new(&format!("anisotropic GGX visible normals α=({ax}, {ay}) θ={theta} φ={phi}"));
                assert_chi2(t.run(|u| Some(ggx.sample_visible_normal(wo, u)), |m| ggx.pdf_visible_normal(wo, m)));
            }
        }
    }

    /// Beckmann's visible normals, isotropic and anisotropic, from normal to grazing views.
    #[test]
    fn chi2_beckmann_visible_normals() {
        for (ax, ay) in [(0.2f32, 0.2f32), (0.5, 0.5), (1.0, 1.0), (0.05, 0.4), (0.6, 0.1)] {
            for (theta, phi) in [(0.0f32, 0.0f32), (0.8, 0.7), (1.4, 2.0)] {
                let b = Ggx::anisotropic(ax, ay).with_beckmann();
                let wo = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
                let t = ChiSquareTest::new(&format!("Beckmann visible normals α=({ax}, {ay}) θ={theta} φ={phi}"));
                assert_chi2(t.run(|u| Some(b.sample_visible_normal(wo, u)), |m| b.pdf_visible_normal(wo, m)));
            }
        }
    }

    /// The anisotropic formulas with αx = αy are the isotropic function, and the visible
    /// normals integrate to 1 for any view (∫ D_wo(m) dm = 1 checks D and Λ together):
    /// a midpoint quadrature over (cos θm, φm) on a 400 × 400 grid.
    #[test]
    fn anisotropic_d_and_lambda_are_consistent() {
        let iso = Ggx { alpha: 0.3, alpha_y: None, beckmann: false };
        let same = Ggx { alpha: 0.3, alpha_y: Some(0.3), beckmann: false };
        for m in [Vec3::new(0.2, 0.1, 0.97).normalize(), Vec3::new(0.7, -0.4, 0.3).normalize()] {
            assert!((iso.d(m) - same.d(m)).abs() <= 1e-5 * iso.d(m));
            assert!((iso.lambda(m) - same.lambda(m)).abs() <= 1e-5 * iso.lambda(m).max(1e-3));
        }
        let n = 400;
        for (ax, ay, beckmann) in [(0.2f32, 0.5f32, false), (0.8, 0.15, false), (0.2, 0.5, true), (0.8, 0.15, true)] {
            let ggx = Ggx { beckmann, ..Ggx::anisotropic(ax, ay) };
            for wo in [Vec3::Z, Vec3::new(0.6, 0.3, 0.74).normalize()] {
                let mut sum = 0.0f64;
                for i in 0..n {
                    // Substitute cos θm = s² so the grid is denser near grazing normals.
                    let sv = (i as f64 + 0.5) / n as f64;
                    let cos = sv * sv;
                    let sin = (1.0 - cos * cos).sqrt();
                    for j in 0..n {
                        let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / n as f64;
                        let m = Vec3::new((sin * phi.cos()) as f32, (sin * phi.sin()) as f32, cos as f32);
                        let w = 2.0 * sv * (1.0 / n as f64) * (2.0 * std::f64::consts::PI / n as f64);
                        sum += ggx.pdf_visible_normal(wo, m) as f64 * w;
                    }
                }
                // Quadrature error of a peaked integrand on this grid: a few 1e-3.
                assert!((sum - 1.0).abs() < 1e-2, "α=({ax}, {ay}) wo={wo}: {sum}");
            }
        }
    }

    /// ∫ D(m) cos θm dm = 1: the projected microfacet area equals the macro surface.
    #[test]
    fn d_is_normalised() {
        for (roughness, beckmann) in
            [(0.3f32, false), (0.6, false), (1.0, false), (0.3, true), (0.6, true), (1.0, true)]
        {
            let ggx = Ggx { beckmann, ..Ggx::from_roughness(roughness) };
            let n = 2000;
            let mut sum = 0.0f64;
            for i in 0..n {
                let cos = (i as f32 + 0.5) / n as f32;
                let m = Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos);
                sum += (ggx.d(m) * cos) as f64 * 2.0 * std::f64::consts::PI / n as f64;
            }
            assert!((sum - 1.0).abs() < 5e-3, "roughness {roughness}: {sum}");
        }
    }
}
