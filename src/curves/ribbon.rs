//! Ray against one curve segment drawn as a ribbon, as Cycles draws curves when the scene's
//! Curves Shape is Ribbons (Blender 5.0's default, `scene.cycles_curves.shape`): a flat strip
//! through the segment's axis that turns to face each ray, as wide as the strand (Cycles'
//! `ribbon_intersect` in `kernel/geom/curve_intersect.h`).
//!
//! Facing the ray, the strip lies in the plane that holds the axis and is perpendicular to the
//! ray's component across the axis; the ray meets it where it passes the axis closest, at an
//! offset across the strip of v·r (v in [−1, 1], r the radius there). Cycles then shades it
//! with a normal rounded as a cylinder's at that offset, and gives the hair BSDF h = −v (which
//! is the h the rounded normal gives, so `shade::as_fibre` needs nothing of its own).
//!
//! What makes a ribbon render unlike a round strand is Cycles' guard against meeting the strip
//! a ray leaves: any ribbon hit closer than twice its radius along the ray is ignored, for
//! every ray and every strand (not only the one left). In dense fur, where neighbours are
//! closer than that, shadow rays and bounces pass through them; this module keeps that rule,
//! which is what brings the Principled Hair BSDF on a furry sphere to Cycles' brightness.
//!
//! Differences kept: Caustic's strip follows the straight segment between two exported
//! points (Cycles' follows the Catmull-Rom curve in 2^subdivisions straight pieces), so at a
//! bend the strips of two segments overlap on the inside and leave a sliver on the outside,
//! of width under r·(bend angle)/2.

use glam::{Vec3, Vec4, Vec4Swizzles};

/// Cycles' self-intersection guard: hits nearer than this many radii are not hits.
pub const AVOIDANCE_RADII: f32 = 2.0;

/// Where a ray meets a ribbon: distance along the (unit) ray, axial parameter s in [0, 1],
/// and the offset across the strip v in [−1, 1] (positive toward `axis × −d`).
#[derive(Clone, Copy, Debug)]
pub struct RibbonHit {
    /// Distance along the ray.
    pub t: f32,
    /// Axial parameter (0 at the first control point, 1 at the second).
    pub s: f32,
    /// Offset across the strip, in radii.
    pub v: f32,
}

/// The hit of the ray `o + t d` (`d` unit) on the ray-facing ribbon of the segment from `a` to
/// `b` (xyz centre, w radius), for `tmin < t < tmax` and t beyond the guard
/// (`AVOIDANCE_RADII` radii).
#[inline]
pub fn intersect(o: Vec3, d: Vec3, a: Vec4, b: Vec4, tmin: f32, tmax: f32) -> Option<RibbonHit> {
    let axis = b.xyz() - a.xyz();
    let len2 = axis.length_squared();
    if !(len2 > 0.0) {
        return None;
    }
    // The strip's normal: the ray's direction without its part along the axis.
    let n = d - axis * (d.dot(axis) / len2);
    let dn = n.length_squared();
    // A ray along the axis sees the strip edge-on (Cycles' projected segment is a point).
    if !(dn > 1e-12) {
        return None;
    }
    let q = a.xyz() - o;
    let t = q.dot(n) / dn;
    let p = d * t - q; // the hit relative to a
    let s = p.dot(axis) / len2;
    if !(0.0..=1.0).contains(&s) {
        return None;
    }
    let r = a.w + (b.w - a.w) * s;
    if !(r > 0.0) || !(t > tmin.max(AVOIDANCE_RADII * r)) || !(t < tmax) {
        return None;
    }
    let across = axis.cross(-d).normalize_or_zero();
    let v = p.dot(across) / r;
    (v.abs() <= 1.0).then_some(RibbonHit { t, s, v })
}

/// The rounded normal Cycles gives a ribbon hit (`curve_shader_setup`): a cylinder's at offset
/// `v` across the strip of the segment `a`→`b`, seen along `d` (toward the viewer).
#[inline]
pub fn normal(d: Vec3, a: Vec4, b: Vec4, v: f32) -> Vec3 {
    let tangent = (b.xyz() - a.xyz()).normalize_or(Vec3::X);
    let across = tangent.cross(-d).normalize_or(tangent.any_orthonormal_vector());
    let away = tangent.cross(across);
    let v = v.clamp(-1.0, 1.0);
    (across * v - away * (1.0 - v * v).max(0.0).sqrt()).normalize_or(-d)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A strand along x of radius 0.1 seen from above: the ray at y offsets meets the strip at
    /// the axis's depth with v = offset / r, misses beyond r, and the rounded normal faces the
    /// ray, tilted toward the offset's side like a cylinder's.
    #[test]
    fn a_ray_meets_the_strip_at_the_axis_depth() {
        let (a, b) = (Vec4::new(-1.0, 0.0, 0.0, 0.1), Vec4::new(1.0, 0.0, 0.0, 0.1));
        let d = Vec3::new(0.0, 0.0, -1.0);
        for y in [-0.09f32, -0.03, 0.0, 0.05] {
            let h = intersect(Vec3::new(0.2, y, 3.0), d, a, b, 0.0, f32::INFINITY).expect("a hit");
            assert!((h.t - 3.0).abs() < 1e-6 && (h.s - 0.6).abs() < 1e-6);
            // across = x × (0, 0, 1) = (0, −1, 0): v counts toward −y.
            assert!((h.v + y / 0.1).abs() < 1e-5, "v {} at y {y}", h.v);
            let n = normal(d, a, b, h.v);
            assert!(n.dot(-d) > 0.0 && (n.y - y / 0.1).abs() < 1e-5, "normal {n} at y {y}");
        }
        assert!(intersect(Vec3::new(0.2, 0.11, 3.0), d, a, b, 0.0, f32::INFINITY).is_none());
        assert!(intersect(Vec3::new(1.2, 0.0, 3.0), d, a, b, 0.0, f32::INFINITY).is_none(), "beyond the end");
        assert!(intersect(Vec3::new(0.2, 0.0, 3.0), d, a, b, 0.0, 2.9).is_none(), "beyond tmax");
        assert!(intersect(Vec3::new(-3.0, 0.0, 0.0), Vec3::X, a, b, 0.0, f32::INFINITY).is_none(), "along the axis");
    }

    /// Cycles' guard: a hit nearer than two radii is no hit, a farther one is, whatever the
    /// ray's slant; a tapered strip narrows with its radius.
    #[test]
    fn hits_nearer_than_two_radii_are_ignored() {
        let (a, b) = (Vec4::new(-1.0, 0.0, 0.0, 0.1), Vec4::new(1.0, 0.0, 0.0, 0.1));
        let d = Vec3::new(0.0, 0.6, -0.8);
        // Radius 0.1: the guard is 0.2 along the ray, measured from the origin.
        for (t, hit) in [(0.15f32, false), (0.19, false), (0.21, true), (1.0, true)] {
            let found = intersect(-d * t, d, a, b, 0.0, f32::INFINITY);
            assert_eq!(found.is_some(), hit, "origin {t} along the ray from the axis: {found:?}");
        }
        let tapered = (Vec4::new(-1.0, 0.0, 0.0, 0.2), Vec4::new(1.0, 0.0, 0.0, 0.0));
        let d = Vec3::new(0.0, 0.0, -1.0);
        assert!(intersect(Vec3::new(0.5, 0.04, 3.0), d, tapered.0, tapered.1, 0.0, 9.0).is_some());
        assert!(intersect(Vec3::new(0.5, 0.06, 3.0), d, tapered.0, tapered.1, 0.0, 9.0).is_none());
    }
}
