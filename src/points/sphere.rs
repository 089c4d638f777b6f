//! Ray against one point's sphere, as Cycles intersects a point cloud's points
//! (`kernel/geom/point_intersect.h`): only where a ray *enters* the sphere counts (Cycles
//! culls the back face of points), so a ray starting inside one never meets it.
//!
//! Precision: the ray's origin is first moved along the ray to its closest approach to the
//! centre, so the distance from the axis and the half chord are of the size of the sphere,
//! not of its distance from the origin (Haines et al., Ray Tracing Gems ch. 7); the distance
//! moved is added back at the end.
//!
//! Leaving a sphere: Cycles skips the primitive a ray leaves. Here a ray whose origin lies in
//! the sphere, or outside it by less than the offset the integrators give a ray leaving a
//! surface (`math::offset_ray_origin`: at most 256 ulps of the point's coordinates per axis,
//! or 2^-16 near the world's origin), never meets it. A ray leaving a sphere's surface, offset
//! outward (a reflection) or inward (a refraction into a glass point; on a sphere narrower than
//! the offset, through it and out of its far side) or not offset at all, so never re-hits the
//! sphere it leaves, whatever its angle; one refracted into a glass point crosses it and
//! leaves through its back unrefracted, as in Cycles. Rays from every other origin find the
//! entry of the mathematical sphere: surfaces closer together than that offset are not told
//! apart, as everywhere in the renderer.

use glam::{Vec3, Vec4, Vec4Swizzles};

/// How far outside a sphere an origin may lie and still count as on it, per unit of the
/// largest coordinate of the origin and the centre: the largest offset `offset_ray_origin`
/// gives (256 ulps of a coordinate per axis, an ulp being at most 2^-23 of it, over three
/// axes), doubled for rounding.
const LEAVING_SLACK: f32 = 2.0 * 256.0 * 2.0 * f32::EPSILON * 1.7320508;
/// The same near the world's origin, where `offset_ray_origin` moves a point by 2^-16 per axis.
const LEAVING_SLACK_ABS: f32 = 2.0 * 1.7320508 / 65536.0;

/// The entry of the ray `o + t d` (`d` unit) into the sphere `s` (xyz centre, w radius) for
/// `0 < t < tmax`: its distance along the ray.
#[inline(always)]
pub fn intersect(o: Vec3, d: Vec3, s: Vec4, tmax: f32) -> Option<f32> {
    let c = s.xyz();
    let r = s.w;
    let oc = c - o;
    // Closest approach of the ray to the centre, and the origin moved there.
    let t0 = oc.dot(d);
    let perp = oc - d * t0;
    let l2 = perp.length_squared();
    let r2 = r * r;
    if !(l2 <= r2) {
        return None;
    }
    // An origin in the sphere or on its surface (up to a leaving ray's offset): the sphere
    // the ray leaves, or one it starts inside (culled).
    let slack = (LEAVING_SLACK * o.abs().max(c.abs()).max_element()).max(LEAVING_SLACK_ABS);
    let reach = r + slack;
    if oc.length_squared() <= reach * reach {
        return None;
    }
    let t = t0 - (r2 - l2).sqrt();
    (t > 0.0 && t < tmax).then_some(t)
}

/// The point where the ray `o + t d` (`d` unit) enters the sphere `s`, and the outward unit
/// normal there (Cycles' `normalize(P - center)`), computed from the moved origin; the point
/// lies on the sphere up to rounding. For a ray that misses (a hit found by a neighbouring
/// query, rounding apart) the nearest point of the sphere to the ray's line.
#[inline]
pub fn entry_point(o: Vec3, d: Vec3, s: Vec4) -> (Vec3, Vec3) {
    let c = s.xyz();
    let r = s.w;
    let oc = c - o;
    let t0 = oc.dot(d);
    // From the centre: the closest approach (−perp), then back along the ray by the half chord.
    let from_centre = -(oc - d * t0);
    let half = (r * r - from_centre.length_squared()).max(0.0).sqrt();
    let n = (from_centre - d * half).normalize_or(-d);
    (c + n * r, n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::offset_ray_origin;

    /// The entry in f64: the nearer root of |o + t d − c|² = r², when the origin is outside.
    fn reference(o: Vec3, d: Vec3, s: Vec4) -> Option<f64> {
        let v = |p: Vec3| [p.x as f64, p.y as f64, p.z as f64];
        let (o, d, c, r) = (v(o), v(d), v(s.xyz()), s.w as f64);
        let dn = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let d = [d[0] / dn, d[1] / dn, d[2] / dn];
        let f = [o[0] - c[0], o[1] - c[1], o[2] - c[2]];
        let b = f[0] * d[0] + f[1] * d[1] + f[2] * d[2];
        let cc = f[0] * f[0] + f[1] * f[1] + f[2] * f[2] - r * r;
        if cc <= 0.0 {
            return None;
        }
        let disc = b * b - cc;
        if disc < 0.0 {
            return None;
        }
        let t = -b - disc.sqrt();
        (t > 0.0).then_some(t)
    }

    fn rng(seed: u64) -> impl FnMut() -> f32 {
        let mut state = seed;
        move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32 + 0.5) / (1u64 << 24) as f32
        }
    }

    /// Random rays against random spheres: hits and misses as in f64, distances within a
    /// relative 1e-5 of the f64 root (away from grazing rays, where the root is ill-posed).
    #[test]
    fn agrees_with_f64() {
        let mut rnd = rng(3);
        let (mut hits, mut checked) = (0, 0);
        for _ in 0..200_000 {
            let s = Vec4::new(rnd() * 4.0 - 2.0, rnd() * 4.0 - 2.0, rnd() * 4.0 - 2.0, 0.05 + rnd());
            let o = Vec3::new(rnd() * 20.0 - 10.0, rnd() * 20.0 - 10.0, rnd() * 20.0 - 10.0);
            let target = s.xyz() + Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 3.0 * s.w;
            let d = (target - o).normalize();
            let got = intersect(o, d, s, f32::INFINITY);
            let want = reference(o, d, s);
            // How far from grazing: the ray's distance from the centre against the radius.
            let oc = s.xyz() - o;
            let l = (oc - d * oc.dot(d)).length();
            if (l - s.w).abs() < 1e-4 * s.w || (oc.length() - s.w).abs() < 1e-4 {
                continue;
            }
            checked += 1;
            match (got, want) {
                (Some(t), Some(w)) => {
                    hits += 1;
                    assert!((t as f64 - w).abs() <= 1e-5 * w.max(1.0), "t {t} against {w}");
                    let (p, n) = entry_point(o, d, s);
                    assert!((p - (o + d * t)).length() < 1e-4 * t.max(1.0));
                    assert!((n.length() - 1.0).abs() < 1e-5 && n.dot(d) < 0.0);
                }
                (None, None) => {}
                _ => panic!("hit {got:?}, f64 {want:?} (o {o}, d {d}, sphere {s})"),
            }
        }
        assert!(hits > 10_000 && checked > 150_000, "{hits} hits of {checked}");
    }

    /// A far, small sphere: the moved origin keeps the entry exact where the textbook
    /// quadratic (|o − c|² − r², of size 10¹⁰ against r² = 10⁻⁴) loses it entirely.
    #[test]
    fn far_small_sphere_is_exact() {
        let s = Vec4::new(1.0e5, 3.0, -2.0, 0.01);
        for k in 0..100 {
            let y = 3.0 + 0.0099 * (k as f32 / 50.0 - 1.0);
            let o = Vec3::new(0.0, y, -2.0);
            let d = Vec3::X;
            let t = intersect(o, d, s, f32::INFINITY).expect("hits");
            let chord = (0.01f64 * 0.01 - ((y - 3.0) as f64).powi(2)).sqrt();
            let want = 1.0e5 - chord;
            assert!((t as f64 - want).abs() < 0.02, "t {t}, want {want}");
            let (p, n) = entry_point(o, d, s);
            assert!((n.y as f64 - (y - 3.0) as f64 / 0.01).abs() < 1e-2, "normal {n}");
            // On the sphere up to the coordinates' rounding (an ulp of 1e5 is 2^-7).
            assert!(((p - s.xyz()).length() - 0.01).abs() < 1e5 * f32::EPSILON);
        }
    }

    /// Rays leaving a sphere's surface never meet it again: reflected (offset outward, or not
    /// offset), refracted into it (offset inward, or not), at every angle down to grazing, on
    /// spheres from tiny to large and near to far from the world's origin; a ray that enters
    /// a neighbour sphere still meets it.
    #[test]
    fn rays_leaving_a_sphere_do_not_meet_it() {
        let mut rnd = rng(11);
        for _ in 0..100_000 {
            let scale = 10f32.powf(rnd() * 6.0 - 3.0);
            let far = 10f32.powf(rnd() * 5.0 - 2.0);
            let c = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * far;
            let s = c.extend(scale * (0.1 + rnd()));
            // A camera ray hitting it.
            let o = c + Vec3::new(rnd() - 0.5, rnd() - 0.5, 1.0).normalize() * (s.w * 3.0 + far);
            let aim = c + Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * s.w;
            let d = (aim - o).normalize();
            let Some(t) = intersect(o, d, s, f32::INFINITY) else { continue };
            let (p, n) = entry_point(o, d, s);
            let _ = t;
            // Outgoing directions over the whole sphere of directions, grazing ones included.
            let frame = crate::math::Frame::from_normal(n);
            let z = (rnd() * 2.0 - 1.0) * if rnd() < 0.3 { 1e-4 } else { 1.0 };
            let phi = rnd() * std::f32::consts::TAU;
            let rxy = (1.0 - z * z).max(0.0).sqrt();
            let w = frame.to_world(Vec3::new(rxy * phi.cos(), rxy * phi.sin(), z)).normalize();
            let side = if w.dot(n) >= 0.0 { n } else { -n };
            for org in [p, offset_ray_origin(p, side)] {
                assert_eq!(intersect(org, w, s, f32::INFINITY), None, "re-hit: sphere {s}, p {p}, n {n}, w {w}");
            }
        }
        // Touching neighbours: a ray leaving one into the other meets it.
        let a = Vec4::new(0.0, 0.0, 0.0, 1.0);
        let b = Vec4::new(2.5, 0.0, 0.0, 1.0);
        let (p, n) = entry_point(Vec3::new(5.0, 0.0, 0.0), -Vec3::X, a);
        assert!((p - Vec3::X).length() < 1e-6 && (n - Vec3::X).length() < 1e-6);
        let t = intersect(offset_ray_origin(p, n), Vec3::X, b, f32::INFINITY).expect("meets the neighbour");
        assert!((t - 0.5).abs() < 1e-4);
    }

    /// A ray inside a sphere never meets it (Cycles' back-face culling); tmax bounds the hit.
    #[test]
    fn inside_and_tmax() {
        let s = Vec4::new(0.0, 0.0, 0.0, 1.0);
        assert_eq!(intersect(Vec3::new(0.2, 0.1, 0.0), Vec3::X, s, f32::INFINITY), None);
        assert_eq!(intersect(Vec3::new(-3.0, 0.0, 0.0), Vec3::X, s, 1.5), None);
        assert_eq!(intersect(Vec3::new(-3.0, 0.0, 0.0), Vec3::X, s, 2.5), Some(2.0));
        assert_eq!(intersect(Vec3::new(-3.0, 0.0, 0.0), -Vec3::X, s, f32::INFINITY), None);
        assert_eq!(intersect(Vec3::new(-3.0, 1.0001, 0.0), Vec3::X, s, f32::INFINITY), None);
    }
}
