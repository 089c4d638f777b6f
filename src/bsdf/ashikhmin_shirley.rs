//! The Glossy BSDF's Ashikhmin-Shirley distribution as Cycles renders it
//! (`kernel/closure/bsdf_ashikhmin_shirley.h`): Ashikhmin & Shirley's anisotropic Phong lobe
//! ("An Anisotropic Phong BRDF Model", 2000) without its Fresnel factor, exponents
//! n = 2/α² − 2 from Cycles' widths, the paper's "pump" 1 / (h·wo · max(cos θo, cos θi)), and the
//! paper's half-vector sampling (per quadrant when anisotropic). No multiple-scattering
//! compensation, as Cycles. Local frame: z the normal, x the tangent; wo is the view side.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, PI, TAU};

/// Widths at or below this are a mirror (Cycles' singular case).
const SMOOTH_ALPHA: f32 = 1e-4;

/// One Ashikhmin-Shirley lobe: its Phong exponents along x and y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AshikhminShirley {
    /// Exponent along the frame's x axis.
    nx: f32,
    /// Exponent along y.
    ny: f32,
    /// Both widths at or below [`SMOOTH_ALPHA`]: a mirror.
    pub smooth: bool,
}

impl AshikhminShirley {
    /// The lobe of widths (αx along x, αy), clamped to [10⁻⁴, 1] as Cycles' setup does.
    pub fn new(alpha_x: f32, alpha_y: f32) -> Self {
        let clamp = |a: f32| if a.is_finite() { a.clamp(SMOOTH_ALPHA, 1.0) } else { 1.0 };
        let (ax, ay) = (clamp(alpha_x), clamp(alpha_y));
        let exponent = |a: f32| 2.0 / (a * a) - 2.0;
        AshikhminShirley { nx: exponent(ax), ny: exponent(ay), smooth: ax.max(ay) <= SMOOTH_ALPHA }
    }

    /// Filter Glossy's blur (Cycles' `bsdf_ashikhmin_shirley_blur`): both widths at least
    /// `alpha`.
    pub fn blurred(&self, alpha: f32) -> Self {
        // Exponent n = 2 / α² − 2, so α = √(2 / (n + 2)).
        let width = |n: f32| (2.0 / (n + 2.0)).sqrt();
        AshikhminShirley::new(width(self.nx).max(alpha), width(self.ny).max(alpha))
    }

    /// The half-vector density p_h(h) / (2π) normalisation and lobe value at `h` (h.z > 0).
    #[inline]
    fn lobe(&self, h: Vec3) -> f32 {
        let cos = h.z.max(1e-6);
        if self.nx == self.ny {
            return (self.nx + 1.0) / (8.0 * PI) * cos.powf(self.nx);
        }
        let norm = ((self.nx + 1.0) * (self.ny + 1.0)).sqrt() / (8.0 * PI);
        let sin2 = 1.0 - cos * cos;
        if sin2 <= 0.0 {
            return norm;
        }
        norm * cos.powf((self.nx * h.x * h.x + self.ny * h.y * h.y) / sin2)
    }

    /// f(wo, wi), wo.z > 0 (zero below the horizon and for the mirror).
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.smooth || wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        let h_dot_o = h.dot(wo).abs().max(1e-6);
        let pump = 1.0 / (h_dot_o * wo.z.max(1e-6).max(wi.z.max(1e-6))).max(1e-6);
        self.lobe(h) * pump
    }

    /// Density of [`Self::sample`]'s wi: p_h / (4 h·wo).
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.smooth || wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        self.lobe(h) / h.dot(wo).abs().max(1e-6)
    }

    /// A direction by the paper's half-vector sampling (wo.z > 0); the mirror's for a smooth
    /// lobe. May lie below the horizon (then f and pdf are 0 there, as in Cycles).
    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Vec3 {
        if self.smooth {
            return Vec3::new(-wo.x, -wo.y, wo.z);
        }
        let (phi, cos) = if self.nx == self.ny {
            (TAU * u.x, u.y.powf(1.0 / (self.nx + 1.0)))
        } else {
            // The first quadrant's sample mirrored into the quadrant u.x picks.
            let quadrant = ((u.x * 4.0) as u32).min(3);
            let t = u.x * 4.0 - quadrant as f32;
            let t = if quadrant % 2 == 1 { 1.0 - t } else { t };
            let phi = (((self.nx + 1.0) / (self.ny + 1.0)).sqrt() * (FRAC_PI_2 * t).tan()).atan();
            let (s, c) = phi.sin_cos();
            let cos = u.y.powf(1.0 / (self.nx * c * c + self.ny * s * s + 1.0));
            let phi = match quadrant {
                0 => phi,
                1 => PI - phi,
                2 => PI + phi,
                _ => TAU - phi,
            };
            (phi, cos)
        };
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let (sp, cp) = phi.sin_cos();
        let h = Vec3::new(sin * cp, sin * sp, cos);
        2.0 * h.dot(wo) * h - wo
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{ChiSquareTest, assert_chi2};

    #[test]
    fn sampling_matches_density() {
        for (ax, ay) in [(0.3f32, 0.3f32), (0.6, 0.15), (1.0, 1.0)] {
            let lobe = AshikhminShirley::new(ax, ay);
            for theta in [0.2f32, 1.0] {
                let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                let t = ChiSquareTest::new(&format!("Ashikhmin-Shirley α=({ax}, {ay}) θ={theta}"));
                assert_chi2(t.run(
                    |u| {
                        let wi = lobe.sample(wo, u);
                        (wi.z > 0.0).then_some(wi)
                    },
                    |wi| lobe.pdf(wo, wi),
                ));
            }
        }
    }

    #[test]
    fn isotropic_values_follow_cycles_formula() {
        // Cycles' eval at α = 0.5 (n = 6) for a view at 30° and the mirror direction:
        // h = z, f = (n + 1)/(8π) / (cos 30° · cos 30°).
        let lobe = AshikhminShirley::new(0.5, 0.5);
        let (s, c) = 30f32.to_radians().sin_cos();
        let (wo, wi) = (Vec3::new(s, 0.0, c), Vec3::new(-s, 0.0, c));
        let expected = 7.0 / (8.0 * PI) / (c * c);
        assert!((lobe.eval(wo, wi) - expected).abs() < 1e-5 * expected);
        assert!((lobe.pdf(wo, wi) - 7.0 / (8.0 * PI) / c).abs() < 1e-5);
    }
}
