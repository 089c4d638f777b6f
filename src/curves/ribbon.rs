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
//! The strip follows the segment's uniform Catmull-Rom curve through its two control points
//! (the neighbours before and after steer it; at a strand's ends the end point stands in for
//! the missing one, as Cycles' `ka`/`kb`), in [`PIECES`] straight pieces as Cycles cuts it
//! (2^Curve Subdivisions, Blender's default 2), radius interpolated alike
//! ([`intersect_curve`]). Difference kept: each piece is its own ray-facing strip, where
//! Cycles joins the pieces' ends into one bilinear quad strip, so at a bend between pieces
//! two strips overlap on the inside and leave a sliver on the outside, of width under
//! r·(bend angle between pieces)/2.

use glam::{Vec3, Vec4, Vec4Swizzles};

/// Cycles' self-intersection guard: hits nearer than this many radii are not hits.
pub const AVOIDANCE_RADII: f32 = 2.0;

/// Straight pieces per segment: Cycles' 2^subdivisions at Blender's default Curve
/// Subdivisions (2).
pub const PIECES: u32 = 4;

/// Weights of the uniform Catmull-Rom basis at u (Cycles' `catmull_rom_basis_eval`): exactly
/// (0, 1, 0, 0) at u = 0 and (0, 0, 1, 0) at u = 1.
#[inline]
fn catmull_rom_weights(u: f32) -> [f32; 4] {
    let (u2, u3) = (u * u, u * u * u);
    [-0.5 * u3 + u2 - 0.5 * u, 1.5 * u3 - 2.5 * u2 + 1.0, -1.5 * u3 + 2.0 * u2 + 0.5 * u, 0.5 * u3 - 0.5 * u2]
}

/// The Catmull-Rom curve of the segment from `p[1]` to `p[2]` (`p[0]`, `p[3]` its
/// neighbours) at u in [0, 1]: centre (xyz) and radius (w).
#[inline]
pub fn catmull_rom(p: &[Vec4; 4], u: f32) -> Vec4 {
    let w = catmull_rom_weights(u);
    p[0] * w[0] + p[1] * w[1] + p[2] * w[2] + p[3] * w[3]
}

/// The curve's derivative in u (its tangent, not normalised).
#[inline]
pub fn catmull_rom_tangent(p: &[Vec4; 4], u: f32) -> Vec3 {
    let u2 = u * u;
    let w = [-1.5 * u2 + 2.0 * u - 0.5, 4.5 * u2 - 5.0 * u, -4.5 * u2 + 4.0 * u + 0.5, 1.5 * u2 - u];
    (p[0] * w[0] + p[1] * w[1] + p[2] * w[2] + p[3] * w[3]).xyz()
}

/// Bounds of the Catmull-Rom segment's ribbons (min and max corner): the curve lies in the
/// convex hull of its Bézier control points p1, p1 + (p2 − p0)/6, p2 − (p3 − p1)/6, p2, and
/// so do the pieces' chords; the strip reaches out by the radius, whose curve is bounded by
/// the same four coefficients' largest.
pub fn curve_bounds(p: &[Vec4; 4]) -> (Vec3, Vec3) {
    let b = [p[1], p[1] + (p[2] - p[0]) / 6.0, p[2] - (p[3] - p[1]) / 6.0, p[2]];
    let r = b.iter().fold(0.0f32, |m, q| m.max(q.w));
    let lo = b.iter().fold(Vec3::INFINITY, |m, q| m.min(q.xyz()));
    let hi = b.iter().fold(Vec3::NEG_INFINITY, |m, q| m.max(q.xyz()));
    (lo - r, hi + r)
}

/// The closest hit of the ray `o + t d` (`d` unit) on the ribbon along the Catmull-Rom curve of
/// the segment `p[1]`→`p[2]`, in (tmin, tmax) and beyond the guard: each of the [`PIECES`]
/// pieces a ray-facing strip (`intersect`); `s` is the curve parameter u.
#[inline]
pub fn intersect_curve(o: Vec3, d: Vec3, p: &[Vec4; 4], tmin: f32, tmax: f32) -> Option<RibbonHit> {
    // Quick reject: the curve stays within `reach` of the line through p1 and p2 (its Bézier
    // hull's inner points are no farther, and it bulges no wider than the largest radius
    // coefficient), so a ray whose line passes farther from that line misses every piece.
    let axis = (p[2] - p[1]).xyz();
    let (b1, b2) = (p[1] + (p[2] - p[0]) / 6.0, p[2] - (p[3] - p[1]) / 6.0);
    let len2 = axis.length_squared();
    if len2 > 0.0 {
        let off = |q: Vec3| {
            let v = q - p[1].xyz();
            (v - axis * (v.dot(axis) / len2)).length()
        };
        let reach = off(b1.xyz()).max(off(b2.xyz())) + p[1].w.max(p[2].w).max(b1.w).max(b2.w);
        let c = d.cross(axis);
        let c2 = c.length_squared();
        // Lines closer than parallel by 1e-6 (relative) keep the full test.
        if c2 > 1e-12 * len2 && (p[1].xyz() - o).dot(c).abs() > reach * c2.sqrt() * (1.0 + 1e-5) {
            return None;
        }
    }
    let mut best: Option<RibbonHit> = None;
    let mut a = p[1];
    for i in 1..=PIECES {
        let b = if i == PIECES { p[2] } else { catmull_rom(p, i as f32 / PIECES as f32) };
        let limit = best.map_or(tmax, |h| h.t);
        if let Some(h) = intersect(o, d, a, b, tmin, limit) {
            best = Some(RibbonHit { s: ((i - 1) as f32 + h.s) / PIECES as f32, ..h });
        }
        a = b;
    }
    best
}

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
    normal_along(d, b.xyz() - a.xyz(), v)
}

/// [`normal`] for a strip along `tangent` (any length): on a Catmull-Rom ribbon, the curve's.
#[inline]
pub fn normal_along(d: Vec3, tangent: Vec3, v: f32) -> Vec3 {
    let tangent = tangent.normalize_or(Vec3::X);
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

    /// Hits on a Catmull-Rom ribbon lie on the curve: for random bent segments and rays aimed
    /// across them at random curve points, the hit is within the radius of the curve at its
    /// parameter, plus the pieces' interpolation error (a chord of length Δu = 1/PIECES
    /// departs from a curve by at most Δu²/8·max|C''|, for the centre and the radius alike;
    /// C'' is linear in u, so its largest norm is at an end). The curve passes through its two
    /// control points, and a ray at a curve point far from the straight segment still hits.
    #[test]
    fn hits_lie_on_the_catmull_rom_curve() {
        let mut state = 11u64;
        let mut rnd = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32 + 0.5) / (1u64 << 24) as f32
        };
        let (mut hits, mut off_chord) = (0, 0);
        for _ in 0..2000 {
            let mut p = [Vec4::ZERO; 4];
            let mut at = Vec3::ZERO;
            for q in p.iter_mut() {
                *q = at.extend(0.03 + 0.04 * rnd());
                at += Vec3::new(1.0, rnd() * 1.6 - 0.8, rnd() * 1.6 - 0.8);
            }
            assert!((catmull_rom(&p, 0.0) - p[1]).length() < 1e-6 && (catmull_rom(&p, 1.0) - p[2]).length() < 1e-6);
            let second = |u: f32| {
                p[0] * (2.0 - 3.0 * u) + p[1] * (9.0 * u - 5.0) + p[2] * (4.0 - 9.0 * u) + p[3] * (3.0 * u - 1.0)
            };
            let du = 1.0 / PIECES as f32;
            let chord_err = du * du / 8.0 * second(0.0).length().max(second(1.0).length());
            let u0 = rnd();
            let c = catmull_rom(&p, u0);
            let tangent = catmull_rom_tangent(&p, u0).normalize();
            let side = tangent.any_orthonormal_vector();
            let across = tangent.cross(side);
            let target = c.xyz() + across * (rnd() * 1.6 - 0.8) * c.w;
            let o = target + side * 3.0;
            let Some(h) = intersect_curve(o, -side, &p, 0.0, f32::INFINITY) else { continue };
            hits += 1;
            let q = catmull_rom(&p, h.s);
            let hit = o - side * h.t;
            let dist = (hit - q.xyz()).length();
            assert!(
                dist <= q.w + 2.0 * chord_err + 1e-4,
                "hit {dist} from the curve, radius {}, chord error {chord_err}",
                q.w
            );
            // Distance of the hit from the straight segment p1→p2: the old strip's axis.
            let ab = (p[2] - p[1]).xyz();
            let s = ((hit - p[1].xyz()).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
            off_chord += ((hit - (p[1].xyz() + ab * s)).length() > 2.0 * q.w) as u32;
        }
        assert!(hits > 1500, "{hits} of 2000 rays aimed within the radius hit");
        // 70 of the hits lie more than two radii off the straight segment, where a straight
        // strip (the previous model) cannot reach.
        assert!(off_chord > 20, "the curve should bend away from the segment: {off_chord}");
    }
}
