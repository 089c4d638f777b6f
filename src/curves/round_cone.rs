//! Ray against one curve segment: a round cone, the convex hull of the spheres at its two
//! control points (centre, radius). Blender's round curves are swept circles along a smooth
//! curve (Cycles intersects Catmull-Rom/B-spline segments); Caustic joins the exported points
//! with straight round cones instead, which is the same surface in the limit of many points
//! per strand (the add-on exports Blender's render steps, see docs/contract.md).
//!
//! Only where a ray *enters* a segment counts (the surface faces the ray): a strand is
//! a closed tube, so a ray leaving its surface outward never re-enters the convex hull, and
//! one that goes in (a hair BSDF's transmission, a shadow ray from the back) does not stop at
//! the inside of the tube it starts in. The hair BSDF accounts for the whole fibre at once, as
//! Cycles' does.
//!
//! Precision: the ray's origin is first moved along the ray to its closest approach to the
//! segment's centre, so every quantity is of the size of the segment, not of its distance
//! from the camera; the distance moved is added back at the end. The quadratic of the cone's
//! side is solved in the cancellation-free form, which keeps grazing rays (nearly parallel to
//! a generator, leading coefficient near 0) finite.

use glam::{Vec3, Vec4, Vec4Swizzles};

/// Where a ray enters a round cone: distance along the (unit) ray, and the axial parameter
/// s in [0, 1] of the sphere (centre lerp(a, b, s), radius lerp(ra, rb, s)) the point lies on.
#[derive(Clone, Copy, Debug)]
pub struct ConeHit {
    /// Distance along the ray.
    pub t: f32,
    /// Axial parameter (0 at the first control point, 1 at the second).
    pub s: f32,
}

/// The entry of the ray `o + t d` (`d` unit) into the round cone of the spheres `a` and `b`
/// (xyz centre, w radius), for `tmin < t < tmax`.
#[inline]
pub fn intersect(o: Vec3, d: Vec3, a: Vec4, b: Vec4, tmin: f32, tmax: f32) -> Option<ConeHit> {
    let (ra, rb) = (a.w, b.w);
    let centre = (a.xyz() + b.xyz()) * 0.5;
    let t0 = (centre - o).dot(d);
    let o1 = o + d * t0;
    // Sphere centres relative to the moved origin.
    let pa = a.xyz() - o1;
    let pb = b.xyz() - o1;
    let (lo, hi) = (tmin - t0, tmax - t0);
    let axis = pb - pa;
    let len2 = axis.length_squared();
    let dr = ra - rb;
    let mut best: Option<ConeHit> = None;
    let mut best_t = hi;
    // The side exists when neither sphere holds the other; then each sphere shows only its
    // cap beyond the circle where the cone touches it.
    let side = len2 > dr * dr;
    let (len, w, sin) = if side {
        let len = len2.sqrt();
        (len, axis / len, dr / len)
    } else {
        (0.0, Vec3::ZERO, 0.0)
    };
    // Spheres: the nearer root of each, kept when the point is on its exposed cap.
    for (p, r, s) in [(pa, ra, 0.0f32), (pb, rb, 1.0f32)] {
        if side || (s == 0.0) == (ra >= rb) {
            let along = p.dot(d);
            let off = p - d * along;
            let disc = r * r - off.length_squared();
            if disc >= 0.0 {
                let t = along - disc.sqrt();
                if t > lo && t < best_t {
                    let exposed = !side || {
                        // Axial position of the point from A, against the tangent circle's.
                        let z = (d * t - pa).dot(w);
                        if s == 0.0 { z <= ra * sin } else { z >= len + rb * sin }
                    };
                    if exposed {
                        best_t = t;
                        best = Some(ConeHit { t, s });
                    }
                }
            }
        }
    }
    if side {
        // A point x is on the side when ρ cos α + z sin α = ra, with z its axial position
        // from A, ρ its distance from the axis and sin α = (ra − rb)/len: squared, a quadratic
        // A2 t² + 2 A1 t + A0 = 0 in the radial parts (q_r, d_r) of origin and direction.
        let cos2 = 1.0 - sin * sin;
        let q = -pa;
        let z0 = q.dot(w);
        let dz = d.dot(w);
        let qr = q - w * z0;
        let drad = d - w * dz;
        let e0 = ra - sin * z0;
        let a2 = cos2 * drad.length_squared() - sin * sin * dz * dz;
        let a1 = cos2 * qr.dot(drad) + sin * dz * e0;
        let a0 = cos2 * qr.length_squared() - e0 * e0;
        let disc = a1 * a1 - a2 * a0;
        if disc >= 0.0 {
            let root = disc.sqrt();
            let k = -(a1 + root.copysign(a1));
            for t in [k / a2, a0 / k] {
                if !(t > lo && t < best_t) {
                    continue;
                }
                let z = z0 + t * dz;
                // Its own nappe (ρ cos α ≥ 0) and between the tangent circles.
                if e0 - sin * dz * t < 0.0 || z < ra * sin || z > len + rb * sin {
                    continue;
                }
                let radial = (qr + drad * t).normalize_or_zero();
                let n = radial * cos2.sqrt() + w * sin;
                if n.dot(d) >= 0.0 {
                    continue;
                }
                // The touching sphere's centre zc: z = zc + r(zc) sin α, r(zc) = ra − zc sin α.
                let s = ((z - ra * sin) / cos2 / len).clamp(0.0, 1.0);
                best_t = t;
                best = Some(ConeHit { t, s });
            }
        }
    }
    best.map(|h| ConeHit { t: h.t + t0, s: h.s })
}

/// The outward unit normal at a point `p` on the round cone whose hit had axial parameter
/// `s`: the direction from the touching sphere's centre.
#[inline]
pub fn normal(p: Vec3, a: Vec4, b: Vec4, s: f32) -> Vec3 {
    let c = a.xyz().lerp(b.xyz(), s);
    (p - c).normalize_or((b.xyz() - a.xyz()).any_orthonormal_vector())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::offset_ray_origin;

    /// The entry in f64 by brute force: the round cone is the union of the spheres
    /// lerp(A, B, s) of radius lerp(ra, rb, s) (the convex hull of two balls), so its entry
    /// is the least entry into any of them; 20001 of them bound the error by the change of
    /// the entry between neighbours (second order in the spacing for a tangent sphere).
    fn reference(o: Vec3, d: Vec3, a: Vec4, b: Vec4) -> Option<f64> {
        let v = |p: Vec3| [p.x as f64, p.y as f64, p.z as f64];
        let (o, d, pa, pb) = (v(o), v(d), v(a.xyz()), v(b.xyz()));
        let dn = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let d = d.map(|x| x / dn);
        let mut best: Option<f64> = None;
        let n = 20000;
        for i in 0..=n {
            let s = i as f64 / n as f64;
            let c: [f64; 3] = [0, 1, 2].map(|k| pa[k] + (pb[k] - pa[k]) * s);
            let r = a.w as f64 + (b.w as f64 - a.w as f64) * s;
            let oc = [0, 1, 2].map(|k| c[k] - o[k]);
            let along = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
            let off2 = (0..3).map(|k| (oc[k] - d[k] * along).powi(2)).sum::<f64>();
            let disc = r * r - off2;
            if disc >= 0.0 {
                let t = along - disc.sqrt();
                if t > 0.0 && best.is_none_or(|b| t < b) {
                    best = Some(t);
                }
            }
        }
        // An origin inside some sphere of the hull is inside: no entry.
        let inside = (0..=n).any(|i| {
            let s = i as f64 / n as f64;
            let c: [f64; 3] = [0, 1, 2].map(|k| pa[k] + (pb[k] - pa[k]) * s);
            let r = a.w as f64 + (b.w as f64 - a.w as f64) * s;
            (0..3).map(|k| (o[k] - c[k]).powi(2)).sum::<f64>() < r * r
        });
        if inside { None } else { best }
    }

    fn rng(mut state: u64) -> impl FnMut() -> f32 {
        move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32 + 0.5) / (1u64 << 24) as f32
        }
    }

    /// Random segments (cones, cylinders, a sphere inside the other) and rays aimed near them
    /// from far away and close by, grazing ones included: hit or miss and the distance agree
    /// with the brute-force reference. Rays whose reference entry is within the reference's
    /// own error of a tangency (|disc| tiny) may go either way and are not counted.
    #[test]
    fn entries_match_a_brute_force_reference() {
        let mut rnd = rng(0x1234_5678_9abc_def1);
        let (mut checked, mut hits, mut wrong) = (0, 0, Vec::new());
        for case in 0..3000 {
            let a = Vec3::new(rnd(), rnd(), rnd()) * 2.0 - 1.0;
            let b = a + (Vec3::new(rnd(), rnd(), rnd()) * 2.0 - 1.0) * if case % 7 == 0 { 0.05 } else { 1.0 };
            let ra = 0.02 + 0.3 * rnd();
            let rb = if case % 5 == 0 { ra } else { 0.02 + 0.3 * rnd() };
            let (a4, b4) = (a.extend(ra), b.extend(rb));
            // Aim at a point near the segment, from a distance of 0.5 to 50.
            let target = a.lerp(b, rnd() * 1.4 - 0.2) + (Vec3::new(rnd(), rnd(), rnd()) * 2.0 - 1.0) * 0.35;
            let mut dir = (Vec3::new(rnd(), rnd(), rnd()) * 2.0 - 1.0).normalize();
            if case % 3 == 0 {
                // Grazing: nearly along the axis.
                dir = ((b - a).normalize() + dir * 0.02).normalize();
            }
            let dist = 0.5 * 100f32.powf(rnd());
            let o = target - dir * dist;
            let got = intersect(o, dir, a4, b4, 0.0, f32::INFINITY);
            let want = reference(o, dir, a4, b4);
            // The reference's spacing (1/20000 of the axis) moves a tangent entry by about
            // sqrt(2 r Δ) along the ray at worst; the f32 result is off by ~ε × (dist + size).
            let size = (b - a).length() + ra + rb;
            let tol_t = 1e-5 * (dist + size) as f64 + (2.0 * 0.32 * size as f64 / 20000.0).sqrt();
            match (got, want) {
                (Some(g), Some(w)) => {
                    hits += 1;
                    if (g.t as f64 - w).abs() > tol_t {
                        wrong.push(format!("case {case}: t {} against {w}", g.t));
                    }
                    checked += 1;
                }
                (None, None) => checked += 1,
                (g, w) => {
                    // Near-tangent rays: does a slightly fatter or thinner cone decide it?
                    let grow = |k: f32| (a.extend(ra * k), b.extend(rb * k));
                    let (a1, b1) = grow(1.001);
                    let (a2, b2) = grow(0.999);
                    let edge = intersect(o, dir, a1, b1, 0.0, f32::INFINITY).is_some()
                        != intersect(o, dir, a2, b2, 0.0, f32::INFINITY).is_some();
                    if !edge {
                        wrong.push(format!("case {case}: got {g:?}, reference {w:?}"));
                    }
                }
            }
        }
        eprintln!("{checked} rays checked, {hits} hits, {} wrong", wrong.len());
        assert!(hits > 500, "too few hits to test anything: {hits}");
        assert!(wrong.is_empty(), "{wrong:?}");
    }

    /// A ray that leaves the surface outward, or goes in, from the point offset off the
    /// surface as the integrators offset it (`offset_ray_origin`, to the side it leaves
    /// toward), does not hit the segment it starts on: only entries count.
    #[test]
    fn rays_leaving_the_surface_do_not_hit_it() {
        let mut rnd = rng(99);
        let (a, b) = (Vec4::new(0.0, 0.0, 0.0, 0.01), Vec4::new(0.3, 0.1, 0.05, 0.004));
        for _ in 0..2000 {
            let dir = (Vec3::new(rnd(), rnd(), rnd()) * 2.0 - 1.0).normalize();
            let o = Vec3::new(0.15, 0.05, 0.025) - dir * 5.0;
            let Some(h) = intersect(o, dir, a, b, 0.0, f32::INFINITY) else { continue };
            let p = o + dir * h.t;
            let n = normal(p, a, b, h.s);
            assert!(n.dot(dir) < 0.0);
            let out = (n + Vec3::new(rnd(), rnd(), rnd()) * 0.5).normalize();
            if out.dot(n) > 0.0 {
                let o = offset_ray_origin(p, n);
                assert!(intersect(o, out, a, b, 0.0, f32::INFINITY).is_none(), "outward ray re-hit");
            }
            let o = offset_ray_origin(p, -n);
            assert!(intersect(o, dir, a, b, 0.0, f32::INFINITY).is_none(), "inward ray hit the inside");
        }
    }
}
