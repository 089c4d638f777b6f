//! The Sheen BSDF's Ashikhmin distribution (the Velvet BSDF of older Blender files) as Cycles
//! renders it (`kernel/closure/bsdf_ashikhmin_velvet.h`): Ashikhmin's velvet distribution
//! D = exp(−cot²θh / σ²) / (π σ² sin⁴θh) with the V-cavity G = min(1, 2 cos θh cos θ / (h·ω))
//! over both directions, f = D G / (4 cos θo cos θi), sampled uniformly over the hemisphere.
//! Local frame: z the normal; wo is the view side.

use crate::sampling::warp::{uniform_cone, uniform_cone_pdf};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// One velvet lobe: 1/σ² of its width σ (Cycles: the Roughness in [0, 1], at least 0.01).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Velvet {
    inv_sigma2: f32,
}

impl Velvet {
    /// The lobe of Cycles' σ = saturate(roughness), at least 0.01.
    pub fn new(roughness: f32) -> Self {
        let sigma = if roughness.is_finite() { roughness.clamp(0.0, 1.0) } else { 0.0 }.max(0.01);
        Velvet { inv_sigma2: 1.0 / (sigma * sigma) }
    }

    /// f(wo, wi), wo.z > 0.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        let (cos_h, h_dot_o) = (h.z, h.dot(wo).abs());
        // Cycles' guards: no value where h is the normal (cot θh infinite) or grazes wo.
        if !(cos_h.abs() < 1.0 - 1e-5 && h_dot_o > 1e-5) {
            return 0.0;
        }
        let ratio = (cos_h / h_dot_o).max(1e-5);
        let g = (2.0 * ratio * wo.z).min(2.0 * ratio * wi.z).min(1.0);
        let sin2 = 1.0 - cos_h * cos_h;
        let cot2 = cos_h * cos_h / sin2;
        let d = (-cot2 * self.inv_sigma2).exp() * self.inv_sigma2 * FRAC_1_PI / (sin2 * sin2);
        0.25 * d * g / (wo.z * wi.z)
    }

    /// Density of [`Self::sample`]: uniform over the upper hemisphere.
    #[inline]
    pub fn pdf(&self, wi: Vec3) -> f32 {
        if wi.z > 0.0 { uniform_cone_pdf(0.0) } else { 0.0 }
    }

    /// A direction uniform over the upper hemisphere.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Vec3 {
        uniform_cone(u, 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    #[test]
    fn value_follows_cycles_formula() {
        // σ = 0.5, view at 80° and light at 40° on the same side: h is 60° from the normal,
        // h·wo = cos 20°, G = min(1, 2 cos 60° cos 80° / cos 20°) (the grazing view's side).
        let v = Velvet::new(0.5);
        let dir = |deg: f32| Vec3::new(deg.to_radians().sin(), 0.0, deg.to_radians().cos());
        let (wo, wi) = (dir(80.0), dir(40.0));
        let (c, s) = (60f32.to_radians().cos(), 60f32.to_radians().sin());
        let d = (-(c * c) / (s * s) * 4.0).exp() * 4.0 / PI / s.powi(4);
        let g = 2.0 * c * wo.z / 20f32.to_radians().cos();
        let expected = 0.25 * d * g / (wo.z * wi.z);
        assert!((v.eval(wo, wi) - expected).abs() < 1e-4 * expected, "{} against {expected}", v.eval(wo, wi));
        // Reciprocal, and black below the horizon.
        assert!((v.eval(wi, wo) - expected).abs() < 1e-4 * expected);
        assert_eq!(v.eval(wo, Vec3::new(0.3, 0.0, -0.9)), 0.0);
    }
}
