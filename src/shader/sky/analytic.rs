//! Blender's legacy Sky Texture models, Preetham and Hosek / Wilkie, as Cycles evaluates them
//! (`SkyTextureNode::compile`'s precomputation, `kernel/svm/sky.h` per direction).
//!
//! Both are fits over the sun's zenith angle θs, the view's zenith angle θ and the angle γ
//! between the view and the sun: at load, nine parameters per channel and a per-channel
//! scale are computed from the sun direction, turbidity and (Hosek) ground albedo; per
//! direction, each channel is the fitted function times its scale. Neither draws a sun disc.
//! Arithmetic per direction is f32 as in Cycles' kernel.

use glam::Vec3;
use std::f32::consts::{FRAC_PI_2, PI};

/// Which of the two analytic models.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AnalyticModel {
    /// Preetham, Shirley, Smits 1999: Perez functions in CIE xyY.
    Preetham,
    /// Hosek & Wilkie 2012: their extended function per CIE XYZ channel.
    HosekWilkie,
}

/// A precomputed analytic sky.
#[derive(Clone, Debug)]
pub struct AnalyticSky {
    model: AnalyticModel,
    /// The space the radiance is given in (`Sky::new_in`).
    pub(super) space: crate::scene::working_space::WorkingSpace,
    /// Sun's zenith angle (Hosek: clamped to the horizon).
    sun_theta: f32,
    /// Sun's azimuth in Cycles' convention, atan2(x, y).
    sun_phi: f32,
    /// Per channel scale: Preetham's zenith Y, x, y over their Perez value at the zenith;
    /// Hosek's X, Y, Z radiance.
    scale: [f32; 3],
    /// Per channel parameters (Preetham uses the first five).
    config: [[f32; 9]; 3],
}

impl AnalyticSky {
    /// Precomputes the model for a sun direction (Blender axes; normalised here, as Blender's
    /// sync does; must not be zero), a turbidity in [1, 10] and a ground albedo in [0, 1]
    /// (Hosek only), the ranges Blender allows.
    pub fn new(model: AnalyticModel, sun_direction: Vec3, turbidity: f32, ground_albedo: f32) -> AnalyticSky {
        let d = sun_direction.normalize();
        let (theta, phi) = (d.z.clamp(-1.0, 1.0).acos(), d.x.atan2(d.y));
        match model {
            AnalyticModel::Preetham => {
                let (scale, config) = preetham(theta, turbidity);
                AnalyticSky { model, space: Default::default(), sun_theta: theta, sun_phi: phi, scale, config }
            }
            AnalyticModel::HosekWilkie => {
                // Cycles clamps the sun to the horizon for this model only.
                let theta = theta.clamp(0.0, FRAC_PI_2);
                let elevation = FRAC_PI_2 - theta;
                let (scale, config) = super::hosek::configuration(turbidity.clamp(1.0, 10.0), ground_albedo, elevation);
                AnalyticSky { model, space: Default::default(), sun_theta: theta, sun_phi: phi, scale, config }
            }
        }
    }

    /// Linear Rec.709 radiance toward `dir` (Blender axes, as the graph's vector: not
    /// normalised, as Cycles reads it).
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let theta = dir.z.clamp(-1.0, 1.0).acos();
        let phi = -dir.y.atan2(dir.x) + FRAC_PI_2;
        let cos_gamma =
            theta.sin() * self.sun_theta.sin() * (self.sun_phi - phi).cos() + theta.cos() * self.sun_theta.cos();
        let gamma = cos_gamma.clamp(-1.0, 1.0).acos();
        // Below the horizon both models repeat the horizon's row (in θ only).
        let theta = theta.min(FRAC_PI_2 - 0.001);
        match self.model {
            AnalyticModel::Preetham => {
                let [sy, sx, sz] = self.scale;
                let x = sx * perez(&self.config[1], theta, gamma);
                let y = sz * perez(&self.config[2], theta, gamma);
                let big_y = sy * perez(&self.config[0], theta, gamma);
                self.space.xyz_to_rgb_clamped(xyy_to_xyz(x, y, big_y))
            }
            AnalyticModel::HosekWilkie => {
                let xyz = Vec3::from_array(std::array::from_fn(|c| {
                    hosek_wilkie(&self.config[c], theta, gamma) * self.scale[c]
                }));
                // The dataset's XYZ is radiometric (W m⁻² sr⁻¹ per the CIE functions): Cycles
                // scales it by 2π/683.
                self.space.xyz_to_rgb_clamped(xyz) * (2.0 * PI / 683.0)
            }
        }
    }
}

/// Perez et al.'s all-weather luminance distribution F(θ, γ), five parameters A..E.
fn perez(lam: &[f32; 9], theta: f32, gamma: f32) -> f32 {
    let cg = gamma.cos();
    (1.0 + lam[0] * (lam[1] / theta.cos()).exp()) * (1.0 + lam[2] * (lam[3] * gamma).exp() + lam[4] * cg * cg)
}

/// Hosek & Wilkie's extended Perez function (their eq. 3 with the Rayleigh, Mie and zenith
/// terms), parameters A..I.
fn hosek_wilkie(c: &[f32; 9], theta: f32, gamma: f32) -> f32 {
    let (ct, cg) = (theta.cos(), gamma.cos());
    let exp_m = (c[4] * gamma).exp();
    let ray_m = cg * cg;
    let mie_m = (1.0 + ray_m) / (1.0 + c[8] * c[8] - 2.0 * c[8] * cg).powf(1.5);
    let zenith = ct.sqrt();
    (1.0 + c[0] * (c[1] / (ct + 0.01)).exp()) * (c[2] + c[3] * exp_m + c[5] * ray_m + c[6] * mie_m + c[7] * zenith)
}

/// CIE xyY to XYZ, zero where y (or Y) is zero (Cycles' `xyY_to_xyz`).
fn xyy_to_xyz(x: f32, y: f32, big_y: f32) -> Vec3 {
    let big_x = if y != 0.0 { x / y * big_y } else { 0.0 };
    let big_z = if y != 0.0 && big_y != 0.0 { (1.0 - x - y) / y * big_y } else { 0.0 };
    Vec3::new(big_x, big_y, big_z)
}

/// Preetham's zenith values and Perez parameters for a sun at zenith angle `theta` and a
/// turbidity (the paper's appendix A.2 fits; zenith luminance in kcd/m² times Cycles' 0.06),
/// each zenith value divided by its Perez function at the zenith, so that the per-direction
/// value is zenith × F(θ, γ) / F(0, θs). Channel order: Y, x, y. In f32, as Cycles.
fn preetham(theta: f32, t: f32) -> ([f32; 3], [[f32; 9]; 3]) {
    let (theta2, t2) = (theta * theta, t * t);
    let theta3 = theta2 * theta;
    let chi = (4.0 / 9.0 - t / 120.0) * (PI - 2.0 * theta);
    let zenith_y = ((4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192) * 0.06;
    let zenith_x = (0.00166 * theta3 - 0.00375 * theta2 + 0.00209 * theta) * t2
        + (-0.02903 * theta3 + 0.06377 * theta2 - 0.03202 * theta + 0.00394) * t
        + (0.11693 * theta3 - 0.21196 * theta2 + 0.06052 * theta + 0.25886);
    let zenith_yc = (0.00275 * theta3 - 0.00610 * theta2 + 0.00317 * theta) * t2
        + (-0.04214 * theta3 + 0.08970 * theta2 - 0.04153 * theta + 0.00516) * t
        + (0.15346 * theta3 - 0.26756 * theta2 + 0.06670 * theta + 0.26688);
    // Perez parameters A..E as linear functions of turbidity (slope, intercept).
    const FITS: [[(f32, f32); 5]; 3] = [
        [(0.1787, -1.4630), (-0.3554, 0.4275), (-0.0227, 5.3251), (0.1206, -2.5771), (-0.0670, 0.3703)],
        [(-0.0193, -0.2592), (-0.0665, 0.0008), (-0.0004, 0.2125), (-0.0641, -0.8989), (-0.0033, 0.0452)],
        [(-0.0167, -0.2608), (-0.0950, 0.0092), (-0.0079, 0.2102), (-0.0441, -1.6537), (-0.0109, 0.0529)],
    ];
    let config: [[f32; 9]; 3] = std::array::from_fn(|c| {
        let mut p = [0.0; 9];
        for (k, (a, b)) in FITS[c].iter().enumerate() {
            p[k] = a * t + b;
        }
        p
    });
    let zenith = [zenith_y, zenith_x, zenith_yc];
    let scale = std::array::from_fn(|c| zenith[c] / perez(&config[c], 0.0, theta));
    (scale, config)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn preetham_at_the_zenith_is_the_fitted_zenith_value() {
        // With the sun at θs, the zenith (θ = 0, γ = θs) gives F(0, θs)/F(0, θs) = 1 times
        // the zenith fit: Y = 0.06 × the paper's kcd/m², and x, y its chromaticity.
        let sun = Vec3::new(0.0, 40f32.to_radians().cos(), 40f32.to_radians().sin());
        let sky = AnalyticSky::new(AnalyticModel::Preetham, sun, 3.0, 0.3);
        let ts = 50f32.to_radians();
        let chi = (4.0 / 9.0 - 3.0 / 120.0) * (PI - 2.0 * ts);
        let y = ((4.0453 * 3.0 - 4.9710) * chi.tan() - 0.2155 * 3.0 + 2.4192) * 0.06;
        let rgb = sky.radiance(Vec3::Z);
        let luminance = 0.212_672_9 * rgb.x + 0.715_152_2 * rgb.y + 0.072_175 * rgb.z;
        assert!((luminance - y).abs() < 1e-3 * y, "{luminance} vs {y}");
        // A clear sky is blue at the zenith.
        assert!(rgb.z > rgb.x, "{rgb}");
    }

    #[test]
    fn the_sky_is_brightest_toward_the_sun_and_symmetric_about_its_vertical_plane() {
        for model in [AnalyticModel::Preetham, AnalyticModel::HosekWilkie] {
            let e = 25f32.to_radians();
            let sun = Vec3::new(0.6 * e.cos(), 0.8 * e.cos(), e.sin());
            let sky = AnalyticSky::new(model, sun, 2.5, 0.3);
            let near = sky.radiance((sun + Vec3::Z * 0.05).normalize());
            let away = sky.radiance(Vec3::new(-sun.x, -sun.y, sun.z).normalize());
            assert!(near.y > 2.0 * away.y, "{model:?}: {near} {away}");
            // Mirror a direction across the plane holding the sun and the zenith.
            let n = Vec3::new(0.8, -0.6, 0.0);
            let d = Vec3::new(0.3, -0.5, 0.4).normalize();
            let m = d - 2.0 * d.dot(n) * n;
            let (a, b) = (sky.radiance(d), sky.radiance(m));
            assert!((a - b).abs().max_element() < 1e-4 * a.max_element(), "{model:?}: {a} {b}");
        }
    }
}
