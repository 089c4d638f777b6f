//! The Beckmann microfacet distribution as Cycles renders it (`bsdf_microfacet.h`, Blender's
//! "Beckmann" on the Glossy, Anisotropic, Glass and Refraction BSDFs): D, Smith's Λ and the
//! sampling of the visible normals (Heitz & d'Eon 2014, the slope x by Jakob's inversion),
//! isotropic or anisotropic, in the stretched configuration of widths (αx, αy).
//!
//! Λ comes twice: Cycles' masking-shadowing uses Walter et al.'s rational approximation
//! ([`lambda_cycles`], the value of f, so that a surface looks as in Cycles), while the density
//! of the sampled visible normals uses the exact Λ ([`lambda_exact`], with the erf of
//! [`erf`]): the sampler draws the exact distribution, so its density must be the exact one
//! for the estimator to be unbiased (the approximation differs from it by under 0.4 %).

use glam::{Vec2, Vec3};
use std::f64::consts::PI as PI64;

/// 1/√π.
const FRAC_1_SQRT_PI: f64 = 0.564_189_583_547_756_3;

/// erfc(x) for x ≥ 0 with a fractional error below 1.2 × 10⁻⁷ everywhere (the Chebyshev fit
/// of Press et al., Numerical Recipes §6.2): relative precision in the tail, where
/// 1 − erf loses it.
fn erfc_pos(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.5 * x);
    let poly = -1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98 + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    t * (-x * x + poly).exp()
}

/// The error function (the tests' check of `erfc_pos`).
#[cfg(test)]
fn erf(x: f64) -> f64 {
    if x >= 0.0 { 1.0 - erfc_pos(x) } else { erfc_pos(-x) - 1.0 }
}

/// 1 + erf(x), precise for x far below 0 (where it is erfc(−x)).
fn one_plus_erf(x: f64) -> f64 {
    if x >= 0.0 { 2.0 - erfc_pos(x) } else { erfc_pos(-x) }
}

/// The inverse error function on (−1, 1): Winitzki's closed form as the start (relative error
/// ~10⁻³), then Newton steps on erfc for the tails' precision.
fn erf_inv(y: f64) -> f64 {
    let y = y.clamp(-1.0 + 1e-15, 1.0 - 1e-15);
    let a = 0.147;
    let ln = (1.0 - y * y).ln();
    let t = 2.0 / (PI64 * a) + 0.5 * ln;
    let mut x = ((t * t - ln / a).sqrt() - t).sqrt().copysign(y);
    // Solve erfc(|x|) = 1 − |y| (the tail keeps its digits in erfc).
    let (s, target) = (y.signum(), 1.0 - y.abs());
    let mut ax = x.abs();
    for _ in 0..4 {
        let err = erfc_pos(ax) - target;
        let slope = -2.0 * FRAC_1_SQRT_PI * (-ax * ax).exp();
        ax = (ax - err / slope).max(0.0);
    }
    x = s * ax;
    x
}

/// Beckmann's D(m) for widths (αx, αy), m in the local frame.
#[inline]
pub fn d(ax: f32, ay: f32, m: Vec3) -> f32 {
    if m.z <= 0.0 {
        return 0.0;
    }
    let cos2 = m.z * m.z;
    let (x, y) = (m.x / ax, m.y / ay);
    let e = (x * x + y * y) / cos2;
    // Past e^-80 the value is 0 in f32, and cos⁴ may underflow to 0 with it (0/0).
    if !(e < 80.0) {
        return 0.0;
    }
    (-e).exp() / (std::f32::consts::PI * ax * ay * cos2 * cos2)
}

/// α² tan²θ of direction `w` seen through widths (αx, αy).
#[inline]
fn alpha2_tan2(ax: f32, ay: f32, w: Vec3) -> f32 {
    ((ax * w.x) * (ax * w.x) + (ay * w.y) * (ay * w.y)) / (w.z * w.z).max(1e-12)
}

/// Cycles' Λ(w): Walter et al.'s rational fit in a = 1/(α tan θ), 0 from a = 1.6 up.
#[inline]
pub fn lambda_cycles(ax: f32, ay: f32, w: Vec3) -> f32 {
    let s = alpha2_tan2(ax, ay, w);
    if s < 0.39 {
        return 0.0;
    }
    let a = 1.0 / s.sqrt();
    ((0.396 * a - 1.259) * a + 1.0) / ((2.181 * a + 3.535) * a)
}

/// The exact Λ(w) = (erf(a) − 1)/2 + e^(−a²)/(2a√π), a = 1/(α tan θ).
#[inline]
pub fn lambda_exact(ax: f32, ay: f32, w: Vec3) -> f32 {
    let s = alpha2_tan2(ax, ay, w) as f64;
    if s <= 0.0 {
        return 0.0;
    }
    let a = 1.0 / s.sqrt();
    // erf(a) − 1 = −erfc(a), a > 0.
    (-0.5 * erfc_pos(a) + (-a * a).exp() * 0.5 * FRAC_1_SQRT_PI / a) as f32
}

/// Samples a visible normal for `wo` (wo.z > 0) of widths (αx, αy): the view stretched to
/// unit widths, a slope drawn from its visible-slope distribution (x by inverting its CDF,
/// y a Gaussian independent of it), rotated to the view's azimuth and unstretched.
pub fn sample_visible_normal(ax: f32, ay: f32, wo: Vec3, u: Vec2) -> Vec3 {
    let v = Vec3::new(ax * wo.x, ay * wo.y, wo.z).normalize();
    let sin = (v.x * v.x + v.y * v.y).sqrt();
    let (cos_phi, sin_phi) = if sin > 1e-7 { (v.x / sin, v.y / sin) } else { (1.0, 0.0) };
    let sx = slope_x(v.z as f64, sin as f64, u.x as f64);
    let sy = erf_inv(2.0 * u.y as f64 - 1.0);
    let (sx, sy) = (sx as f32, sy as f32);
    let (rx, ry) = (cos_phi * sx - sin_phi * sy, sin_phi * sx + cos_phi * sy);
    Vec3::new(-ax * rx, -ay * ry, 1.0).normalize()
}

/// The slope x of unit-width Beckmann's visible slopes for a view at (cos θ, sin θ) in the
/// xz plane: density ∝ (cot θ − x) e^(−x²) on x < cot θ, whose CDF is proportional to
/// G(x) = 1 + erf(x) + tan θ/√π e^(−x²). Solved by Newton's method kept inside a bracket
/// (bisection when a step leaves it), in f64.
fn slope_x(cos: f64, sin: f64, u: f64) -> f64 {
    if sin < 1e-7 {
        // Normal view: the visible slopes are the slopes, x ~ N(0, ½).
        return erf_inv(2.0 * u - 1.0);
    }
    let tan = sin / cos;
    let k = tan * FRAC_1_SQRT_PI;
    let cot = cos / sin;
    let g = |x: f64| one_plus_erf(x) + k * (-x * x).exp();
    // Beyond ±6 the tails hold under 10⁻¹⁵ of the mass, below f32's smallest u.
    let (mut lo, mut hi) = (-6.0f64, cot.min(6.0));
    let target = u * g(hi);
    let mut x = erf_inv((2.0 * u - 1.0).clamp(-0.999_999, 0.999_999)).clamp(lo, hi);
    for _ in 0..40 {
        let r = g(x) - target;
        if r.abs() <= 1e-12 * target.max(1e-300) {
            break;
        }
        if r > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let slope = 2.0 * FRAC_1_SQRT_PI * (-x * x).exp() * (1.0 - x * tan);
        let next = if slope > 0.0 { x - r / slope } else { f64::NAN };
        x = if next > lo && next < hi { next } else { 0.5 * (lo + hi) };
        if hi - lo < 1e-12 {
            break;
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// erf and its inverse against known values and each other.
    #[test]
    fn erf_and_inverse() {
        for (x, e) in [(0.5f64, 0.520_499_877_813_046_5), (1.0, 0.842_700_792_949_714_9), (2.5, 0.999_593_047_982_555)]
        {
            assert!((erf(x) - e).abs() < 2e-7, "erf({x}) = {}", erf(x));
            assert!((erf(-x) + e).abs() < 2e-7);
        }
        for y in [-0.999_999f64, -0.9, -0.3, 0.0, 0.1, 0.7, 0.999_99] {
            let x = erf_inv(y);
            assert!((erf(x) - y).abs() < 1e-9 + 1e-6 * (1.0 - y.abs()), "erf_inv({y}) = {x}");
        }
    }

    /// Cycles' rational Λ agrees with the exact one within its stated fit (under 0.4 % of
    /// 1 + Λ over the range where it is not 0).
    #[test]
    fn lambda_fit_is_close() {
        for alpha in [0.1f32, 0.5, 1.0] {
            for i in 1..60 {
                let theta = i as f32 / 60.0 * 1.55;
                let w = Vec3::new(theta.sin(), 0.0, theta.cos());
                let (a, b) = (lambda_cycles(alpha, alpha, w), lambda_exact(alpha, alpha, w));
                assert!(((1.0 + a) / (1.0 + b) - 1.0).abs() < 4e-3, "α={alpha} θ={theta}: {a} vs {b}");
            }
        }
    }
}
