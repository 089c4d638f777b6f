//! Warps from the unit square to hemispheres, spheres, cones, disks and triangles,
//! each with its density. All directions are in a local frame with +Z up.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, FRAC_PI_4, PI};

/// Uniform point on the unit disk by Shirley-Chiu's concentric map (keeps
/// stratification better than the polar map).
#[inline]
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) =
        if o.x.abs() > o.y.abs() { (o.x, FRAC_PI_4 * (o.y / o.x)) } else { (o.y, FRAC_PI_2 - FRAC_PI_4 * (o.x / o.y)) };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Cosine-weighted direction on the +Z hemisphere.
#[inline]
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Density of [`cosine_hemisphere`] per unit solid angle.
#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    if cos_theta > 0.0 { cos_theta * FRAC_1_PI } else { 0.0 }
}

/// Uniform direction on the unit sphere.
#[inline]
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Density of [`uniform_sphere`].
pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Uniform direction in the cone around +Z with cosine of the half-angle `cos_max`.
#[inline]
pub fn uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let z = 1.0 - u.x * (1.0 - cos_max);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Density of [`uniform_cone`] per unit solid angle.
#[inline]
pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_max))
}

/// Uniform point in a regular polygon with `blades` corners (at least 3) inscribed in the
/// unit circle, the first corner at angle `rotation`: a camera's polygonal aperture, as
/// Cycles' blade count and rotation. One of the equal triangles (centre, corner i, corner
/// i + 1) is chosen by `u.x`, whose remainder is reused within it.
#[inline]
pub fn regular_polygon(u: Vec2, blades: u32, rotation: f32) -> Vec2 {
    let n = blades.max(3) as f32;
    let scaled = u.x * n;
    let i = scaled.floor().min(n - 1.0);
    let ux = (scaled - i).clamp(0.0, 1.0);
    let step = 2.0 * PI / n;
    let a0 = rotation + i * step;
    let (c0, c1) = (Vec2::new(a0.cos(), a0.sin()), Vec2::new((a0 + step).cos(), (a0 + step).sin()));
    let b = uniform_triangle(Vec2::new(ux, u.y));
    c0 * b.x + c1 * b.y
}

/// Area of [`regular_polygon`]'s polygon.
#[inline]
pub fn regular_polygon_area(blades: u32) -> f32 {
    let n = blades.max(3) as f32;
    0.5 * n * (2.0 * PI / n).sin()
}

/// Uniform barycentric coordinates (b1, b2) on a triangle; the point is
/// `(1-b1-b2) p0 + b1 p1 + b2 p2`. Uses Heitz's low-distortion map (2019), which keeps
/// the stratification of the input.
#[inline]
pub fn uniform_triangle(u: Vec2) -> Vec2 {
    let (mut b0, mut b1);
    if u.x < u.y {
        b0 = u.x / 2.0;
        b1 = u.y - b0;
    } else {
        b1 = u.y / 2.0;
        b0 = u.x - b1;
    }
    // Clamp the rounding error of the subtraction.
    b0 = b0.clamp(0.0, 1.0);
    b1 = b1.clamp(0.0, 1.0 - b0);
    Vec2::new(b1, 1.0 - b0 - b1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{ChiSquareTest, assert_chi2};

    #[test]
    fn chi2_cosine_hemisphere() {
        let t = ChiSquareTest::new("cosine hemisphere");
        assert_chi2(t.run(|u| Some(cosine_hemisphere(u)), |w| cosine_hemisphere_pdf(w.z)));
    }

    #[test]
    fn chi2_uniform_sphere() {
        let t = ChiSquareTest::new("uniform sphere");
        assert_chi2(t.run(|u| Some(uniform_sphere(u)), |_| UNIFORM_SPHERE_PDF));
    }

    #[test]
    fn chi2_uniform_cone() {
        for cos_max in [0.9f32, 0.3, -0.5] {
            let t = ChiSquareTest::new(&format!("uniform cone cos_max={cos_max}"));
            assert_chi2(t.run(
                |u| Some(uniform_cone(u, cos_max)),
                |w| {
                    if w.z >= cos_max { uniform_cone_pdf(cos_max) } else { 0.0 }
                },
            ));
        }
    }

    /// Aperture sampling is tested as a direction: the polygon lies in the unit disk, which
    /// is lifted onto the +Z hemisphere, where the area density 1/A becomes cos θ / A.
    #[test]
    fn chi2_regular_polygon() {
        for (blades, rotation) in [(3u32, 0.0f32), (5, 0.4), (6, -1.0), (9, 2.0)] {
            let area = regular_polygon_area(blades);
            let step = 2.0 * PI / blades as f32;
            let inside = |p: Vec2| {
                let phi = (p.y.atan2(p.x) - rotation).rem_euclid(2.0 * PI);
                let mid = rotation + ((phi / step).floor() + 0.5) * step;
                p.dot(Vec2::new(mid.cos(), mid.sin())) <= (0.5 * step).cos()
            };
            let t = ChiSquareTest::new(&format!("regular polygon {blades} blades"));
            assert_chi2(t.run(
                |u| {
                    let p = regular_polygon(u, blades, rotation);
                    Some(Vec3::new(p.x, p.y, (1.0 - p.length_squared()).max(0.0).sqrt()))
                },
                |w| if w.z > 0.0 && inside(Vec2::new(w.x, w.y)) { w.z / area } else { 0.0 },
            ));
        }
    }

    /// Triangle sampling is tested as a direction: the triangle is seen from a point and
    /// the area density is converted to solid angle, so the same harness applies.
    #[test]
    fn chi2_uniform_triangle() {
        let p = [Vec3::new(-1.0, -0.5, 1.0), Vec3::new(1.5, -0.2, 0.7), Vec3::new(0.2, 1.0, 1.4)];
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let area = 0.5 * n.length();
        let n = n.normalize();
        let t = ChiSquareTest::new("uniform triangle");
        assert_chi2(t.run(
            |u| {
                let b = uniform_triangle(u);
                let q = p[0] * (1.0 - b.x - b.y) + p[1] * b.x + p[2] * b.y;
                Some(q.normalize())
            },
            |w| {
                // Ray from the origin along w against the triangle's plane.
                let denom = n.dot(w);
                if denom.abs() < 1e-8 {
                    return 0.0;
                }
                let t = n.dot(p[0]) / denom;
                if t <= 0.0 {
                    return 0.0;
                }
                let q = w * t;
                let c0 = (p[1] - p[0]).cross(q - p[0]).dot(n);
                let c1 = (p[2] - p[1]).cross(q - p[1]).dot(n);
                let c2 = (p[0] - p[2]).cross(q - p[2]).dot(n);
                if c0 < 0.0 || c1 < 0.0 || c2 < 0.0 {
                    return 0.0;
                }
                t * t / (area * denom.abs())
            },
        ));
    }

    #[test]
    fn concentric_disk_stays_in_disk() {
        for i in 0..64 {
            for j in 0..64 {
                let d = concentric_disk(Vec2::new(i as f32 / 63.0, j as f32 / 63.0));
                assert!(d.length() <= 1.0 + 1e-6);
            }
        }
    }
}
