//! Clearance: a lower bound on the distance from a point to every triangle of the BVH,
//! so that a subsurface random walk can take the steps that stay inside a ball free of
//! surfaces without asking the BVH about each (`medium::walk`). Callgrind on the
//! subsurface bench scene: the walk's closest-hit queries were 40 % of the render's
//! instructions, ~1200 each, for steps of a few mean free paths that mostly end far from
//! any surface.
//!
//! A nearest-first search over the float child boxes (`planes`), pruned by the nearest
//! triangle found so far, with the point-triangle distance in f64. The result is shrunk
//! by a margin (see [`Accel::clearance`]) that covers every rounding of the search and of
//! the caller's ball test, so a segment inside the ball is one the ray query would find
//! no hit on: the walk's images stay bit for bit.

use super::Accel;
use super::planes::NodePlanes;
use glam::{DVec3, Vec3, Vec3A};

/// Entries of the search's stack: at most 8 children pushed per level of a tree at most
/// `traverse::STACK_DEPTH` (32) deep.
const STACK: usize = 8 * 32;

/// No triangle: a search without a hint (`Accel::clearance_near`).
pub const NO_TRIANGLE: u32 = u32::MAX;

impl Accel {
    /// A radius r ≤ `cap` such that no triangle of this BVH (nor of its relocated side
    /// BVH) comes within r of `p` (0 when one touches it). Beyond `cap` the search does
    /// not look: the caller has no use for a larger ball, and the search's cost grows
    /// with the radius.
    ///
    /// The nearest distance d is found exactly up to rounding: box distances carry a
    /// relative error of a few ε (one subtraction and a sum of three squares in f32, so
    /// a pruned box's true distance is at least (1 - 4ε) times the one computed), the
    /// triangle distance is computed in f64 from the f32 corners (relative error ~1e-15).
    /// r = min(d, cap) (1 - 1e-4) - 1e-5 max(1, |p|∞): the relative part covers the
    /// search's ε-level errors with room, the absolute part the f32 rounding (≤ a few ε
    /// |p|∞ = 4e-7 |p|∞) of the caller's squared distances and of the walk's end points.
    pub fn clearance(&self, p: Vec3, cap: f32) -> f32 {
        let mut near = NO_TRIANGLE;
        self.clearance_near(p, cap, &mut near)
    }

    /// [`clearance`](Self::clearance), starting from the triangle `near` (the last
    /// search's nearest, `NO_TRIANGLE` for none), which becomes this search's nearest.
    /// A walk's next search is a few mean free paths from its last: that triangle's
    /// distance bounds the search from its start, so it prunes boxes a nearest-first
    /// search would otherwise open before reaching it. The minimum is the same (the
    /// hint is one of the candidates), so the radius is the same bit for bit.
    pub fn clearance_near(&self, p: Vec3, cap: f32, near: &mut u32) -> f32 {
        let mut d2 = self.nearest_squared(p, f64::from(cap).powi(2), near);
        if let Some(moved) = &self.moved {
            let mut none = NO_TRIANGLE;
            d2 = d2.min(moved.nearest_squared(p, d2, &mut none));
        }
        let r = (d2.sqrt() as f32) * (1.0 - 1e-4) - 1e-5 * p.abs().max_element().max(1.0);
        if r > 0.0 { r } else { 0.0 }
    }

    /// The squared distance from `p` to the nearest triangle, or `cap2` when none is
    /// nearer than √cap2; `near` is a triangle to start from and becomes the nearest
    /// found (unchanged when none is nearer than √cap2).
    fn nearest_squared(&self, p: Vec3, cap2: f64, near: &mut u32) -> f64 {
        let mut best = cap2;
        if self.bvh.nodes.is_empty() {
            return best;
        }
        let pd = p.as_dvec3();
        if let Some(tri) = self.tris.get(*near as usize) {
            let d2 = point_triangle_squared(pd, tri);
            if d2 < best {
                best = d2;
            }
        }
        let pa = Vec3A::from(p);
        // Uninitialised: zeroing it cost ~3 % of a search.
        let mut stack = [std::mem::MaybeUninit::<(u32, f32)>::uninit(); STACK];
        stack[0].write((0, 0.0));
        let mut depth = 1usize;
        while depth > 0 {
            depth -= 1;
            // SAFETY: entries below `depth` were written (the root above, then the pushes).
            let (index, d2) = unsafe { stack[depth].assume_init() };
            if f64::from(d2) >= best {
                continue;
            }
            let node = &self.bvh.nodes[index as usize];
            let boxes = box_distances(&self.planes[index as usize], pa);
            // Leaves first (they lower `best`, which prunes the inner children), then the
            // inner children pushed farthest first so that the nearest is searched next.
            let mut inner = [(0u32, 0.0f32); 8];
            let (mut n_inner, mut inner_before) = (0usize, 0u32);
            for (slot, &b2) in boxes.iter().enumerate() {
                let meta = node.child_meta[slot];
                let is_inner = node.imask & (1 << slot) != 0;
                if meta != 0 && f64::from(b2) < best {
                    if is_inner {
                        // Inner children are stored in slot order (obvhs' child_node_index).
                        inner[n_inner] = (node.child_base_idx + inner_before, b2);
                        n_inner += 1;
                    } else {
                        // The count is unary in the top three bits (0b001, 0b011, 0b111).
                        let start = node.primitive_base_idx + u32::from(meta & 0b1_1111);
                        let count = 8 - (meta >> 5).leading_zeros();
                        for id in start..start + count {
                            let d2 = point_triangle_squared(pd, &self.tris[id as usize]);
                            if d2 < best {
                                (best, *near) = (d2, id);
                            }
                        }
                    }
                }
                inner_before += u32::from(is_inner);
            }
            // Farthest first onto the stack (an insertion sort of at most 8), so that the
            // nearest is searched next.
            let inner = &mut inner[..n_inner];
            for i in 1..inner.len() {
                let mut j = i;
                while j > 0 && inner[j - 1].1 < inner[j].1 {
                    inner.swap(j - 1, j);
                    j -= 1;
                }
            }
            for &entry in inner.iter() {
                if f64::from(entry.1) < best && depth < STACK {
                    stack[depth].write(entry);
                    depth += 1;
                }
            }
        }
        best
    }
}

/// Squared distance from `p` to each of a node's eight child boxes (0 inside one).
#[inline]
fn box_distances(planes: &NodePlanes, p: Vec3A) -> [f32; 8] {
    let mut d2 = [0.0f32; 8];
    for (k, &pk) in p.to_array().iter().enumerate() {
        let (lo, hi) = (&planes.planes[2 * k], &planes.planes[2 * k + 1]);
        for j in 0..8 {
            let d = (lo[j] - pk).max(pk - hi[j]).max(0.0);
            d2[j] += d * d;
        }
    }
    d2
}

/// Squared distance from `p` to the triangle `v` (the closest point by the triangle's
/// Voronoi regions, Ericson's Real-Time Collision Detection 5.1.5), in f64.
pub(crate) fn point_triangle_squared(p: DVec3, v: &[Vec3A; 3]) -> f64 {
    let [a, b, c] = v.map(|x| Vec3::from(x).as_dvec3());
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.length_squared();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.length_squared();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let t = d1 / (d1 - d3);
        return (ap - ab * t).length_squared();
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.length_squared();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let t = d2 / (d2 - d6);
        return (ap - ac * t).length_squared();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (bp - (c - b) * t).length_squared();
    }
    let denom = va + vb + vc;
    if !(denom != 0.0) {
        // A degenerate triangle (a segment or a point): its corners and edges' nearest.
        return [ap, bp, cp].iter().map(|q| q.length_squared()).fold(f64::INFINITY, f64::min);
    }
    let (v, w) = (vb / denom, vc / denom);
    (ap - ab * v - ac * w).length_squared()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic uniform numbers (a 64-bit LCG's high bits).
    fn lcg(state: &mut u64) -> f32 {
        *state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (*state >> 40) as f32 / (1u64 << 24) as f32
    }

    /// The clearance is the brute-force nearest distance less the stated margin (so a
    /// lower bound of it), also far from the triangles and for an empty BVH.
    #[test]
    fn clearance_is_the_margined_nearest_distance() {
        let mut s = 5u64;
        let mut tris = Vec::new();
        for _ in 0..3000 {
            let c = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 6.0 - 3.0;
            let d = |s: &mut u64| Vec3::new(lcg(s), lcg(s), lcg(s)) * 0.2 - 0.1;
            tris.push([c + d(&mut s), c + d(&mut s), c + d(&mut s)]);
        }
        let accel = Accel::build(&tris);
        for _ in 0..500 {
            let p = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 16.0 - 8.0;
            let exact = tris
                .iter()
                .map(|t| point_triangle_squared(p.as_dvec3(), &t.map(Vec3A::from)))
                .fold(f64::INFINITY, f64::min)
                .sqrt() as f32;
            let want = (exact * (1.0 - 1e-4) - 1e-5 * p.abs().max_element().max(1.0)).max(0.0);
            assert_eq!(accel.clearance(p, f32::INFINITY), want, "at {p}: exact distance {exact}");
        }
        // A cap below the distance is the radius, less the margin.
        let p = Vec3::new(20.0, 0.0, 0.0);
        assert_eq!(accel.clearance(p, 1.0), 1.0 * (1.0 - 1e-4) - 1e-5 * 20.0);
    }

    /// A search started from a hint (the last search's nearest, as a walk asks along its
    /// way) gives the same radius as one without, under a cap too, and leaves the hint at
    /// a triangle that far; a hint beyond the cap or out of range changes nothing.
    #[test]
    fn a_hint_changes_no_radius() {
        let mut s = 9u64;
        let mut tris = Vec::new();
        for _ in 0..2000 {
            let c = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 6.0 - 3.0;
            let d = |s: &mut u64| Vec3::new(lcg(s), lcg(s), lcg(s)) * 0.2 - 0.1;
            tris.push([c + d(&mut s), c + d(&mut s), c + d(&mut s)]);
        }
        let accel = Accel::build(&tris);
        let mut near = NO_TRIANGLE;
        let mut p = Vec3::ZERO;
        for _ in 0..500 {
            p += (Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) - 0.5) * 0.3;
            let cap = if lcg(&mut s) < 0.5 { f32::INFINITY } else { 0.2 };
            let before = near;
            let r = accel.clearance_near(p, cap, &mut near);
            assert_eq!(r, accel.clearance(p, cap), "at {p}, cap {cap}, hint {before}");
            // A new nearest was found: it lies within the cap, at the radius (less the margin).
            if near != before && near != NO_TRIANGLE {
                let d = point_triangle_squared(p.as_dvec3(), &accel.tris[near as usize]).sqrt() as f32;
                assert!(d <= cap && d * (1.0 - 1e-4) - 1e-5 * p.abs().max_element().max(1.0) <= r + 1e-6);
            }
        }
        let mut out_of_range = u32::MAX - 1;
        assert_eq!(accel.clearance_near(p, 1.0, &mut out_of_range), accel.clearance(p, 1.0));
    }

    /// The point-triangle distance in each Voronoi region of a right triangle.
    #[test]
    fn point_triangle_regions() {
        let t = [Vec3A::ZERO, Vec3A::X, Vec3A::Y];
        let d = |x: f64, y: f64, z: f64| point_triangle_squared(DVec3::new(x, y, z), &t).sqrt();
        assert!((d(0.25, 0.25, 2.0) - 2.0).abs() < 1e-12); // face
        assert!((d(-3.0, -4.0, 0.0) - 5.0).abs() < 1e-12); // corner a
        assert!((d(4.0, -4.0, 0.0) - 5.0).abs() < 1e-12); // corner b
        assert!((d(0.5, -2.0, 0.0) - 2.0).abs() < 1e-12); // edge ab
        assert!((d(-2.0, 0.5, 0.0) - 2.0).abs() < 1e-12); // edge ac
        assert!((d(1.0, 1.0, 0.0) - 0.5f64.sqrt()).abs() < 1e-12); // edge bc
    }
}
