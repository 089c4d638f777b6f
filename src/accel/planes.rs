//! The scene BVH's node test on child boxes stored as floats: each CWBVH node's eight
//! quantised child boxes are widened once, at build time, into world-space planes
//! (`NodePlanes`, 192 bytes beside obvhs' 80-byte node), so that a node visit loads its
//! planes instead of widening 48 bytes, scaling them by the node's exponent and
//! bounding that arithmetic's error per ray (callgrind on the subsurface bench scene:
//! ~330 instructions per node visit, 5 visits per random-walk step, the walk's steps
//! 62 % of the render's time).
//!
//! The test is conservative, so a traversal visits every node the quantised test keeps
//! (and a few ulps more) and finds the same closest hit: the visiting order is fixed by
//! the tree and the ray's octant, not by the test.

use super::traverse::{NodeRay, place_hits, walk};
use glam::Vec3A;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::node::CwBvhNode;

/// A node's child boxes as floats: `planes[2k]` the eight children's minima along axis
/// k, `planes[2k + 1]` their maxima; empty slots hold a point (their child bits are 0).
#[derive(Clone, Copy)]
#[repr(C, align(32))]
pub(crate) struct NodePlanes {
    pub(super) planes: [[f32; 8]; 6],
}

/// The largest f32 not above `x`.
fn down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x { f.next_down() } else { f }
}

/// The smallest f32 not below `x`.
fn up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x { f.next_up() } else { f }
}

impl NodePlanes {
    /// The world-space child boxes of `node`, rounded outwards. obvhs quantises in f32
    /// (`floor((min - p) / e)`, and the exponent e from an f32 log2), so its box may cut
    /// the true child box by about one rounding of |min - p| ≤ 255 e, or of the extent
    /// where the log2 rounds down; each plane is moved out by 8 ε (|p| + 255 e), the
    /// margin the quantised test allowed for the same error (`traverse::node_hits`).
    pub(crate) fn new(node: &CwBvhNode) -> Self {
        let ext = node.compute_extent();
        let p = [node.p.x, node.p.y, node.p.z];
        let e = [ext.x, ext.y, ext.z];
        let q = [
            &node.child_min_x,
            &node.child_max_x,
            &node.child_min_y,
            &node.child_max_y,
            &node.child_min_z,
            &node.child_max_z,
        ];
        let mut planes = [[0.0f32; 8]; 6];
        for (k, (&p, &e)) in p.iter().zip(&e).enumerate() {
            let (p, e) = (f64::from(p), f64::from(e));
            let pad = 8.0 * f64::from(f32::EPSILON) * (p.abs() + 255.0 * e);
            for j in 0..8 {
                // p + q e is exact in f64 (e a power of two, q < 256, p an f32).
                planes[2 * k][j] = down(p + f64::from(q[2 * k][j]) * e - pad);
                planes[2 * k + 1][j] = up(p + f64::from(q[2 * k + 1][j]) * e + pad);
            }
        }
        NodePlanes { planes }
    }

    /// The planes of every node of `bvh`, in node order.
    pub(crate) fn of(bvh: &CwBvh) -> Vec<NodePlanes> {
        bvh.nodes.iter().map(NodePlanes::new).collect()
    }
}

/// Relative bound on the error of a slab distance (b - o) · (1/d): three f32 roundings
/// (the subtraction, the reciprocal, the product), each at most u = ε/2, so the computed
/// distance lies within a factor (1 ± u)³ of the true one and has its sign. A box is hit
/// when max(0, nears) ≤ min(tmax, fars); the computed nears are at most (1 + u)³ and the
/// fars at least (1 - u)³ times the true ones, so scaling the computed far by
/// (1 + u)³ / (1 - u)³ ≈ 1 + 6u, plus one rounding of that product, keeps every box
/// the true segment touches. 1 + 8ε = 1 + 16u covers it with room.
const FAR_SCALE: f32 = 1.0 + 8.0 * f32::EPSILON;

/// Per-ray constants of the float-plane test.
pub(crate) struct PlaneRay {
    org: [f32; 3],
    inv: [f32; 3],
    /// Index in `NodePlanes::planes` of each axis's entry and exit planes.
    near: [usize; 3],
    far: [usize; 3],
}

impl PlaneRay {
    /// The test's constants from the quantised test's (the same reciprocal, so the same
    /// treatment of directions parallel to an axis).
    #[inline]
    pub(crate) fn new(ray: &NodeRay) -> Self {
        let org: Vec3A = ray.org;
        let inv: Vec3A = ray.inv;
        let n = |k: usize| 2 * k + ray.neg[k] as usize;
        let f = |k: usize| 2 * k + 1 - ray.neg[k] as usize;
        PlaneRay { org: org.to_array(), inv: inv.to_array(), near: [n(0), n(1), n(2)], far: [f(0), f(1), f(2)] }
    }

    /// One bit per child slot whose box the segment (0, tmax) touches.
    #[inline(always)]
    fn slots(&self, node: &NodePlanes, tmax: f32) -> u32 {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            let mut slots = 0u32;
            // SAFETY: SSE2 is part of x86_64; the loads read 4 of a plane's 8 floats
            // (i < 2) at a 16-byte multiple of the 32-byte aligned struct; near/far < 6.
            unsafe {
                let scale = _mm_set1_ps(FAR_SCALE);
                for i in 0..2 {
                    let mut near = _mm_setzero_ps();
                    let mut far = _mm_set1_ps(tmax);
                    for k in 0..3 {
                        let o = _mm_set1_ps(self.org[k]);
                        let inv = _mm_set1_ps(self.inv[k]);
                        let n = _mm_load_ps(node.planes.get_unchecked(self.near[k]).as_ptr().add(4 * i));
                        let f = _mm_load_ps(node.planes.get_unchecked(self.far[k]).as_ptr().add(4 * i));
                        near = _mm_max_ps(near, _mm_mul_ps(_mm_sub_ps(n, o), inv));
                        far = _mm_min_ps(far, _mm_mul_ps(_mm_sub_ps(f, o), inv));
                    }
                    far = _mm_mul_ps(far, scale);
                    slots |= (_mm_movemask_ps(_mm_cmple_ps(near, far)) as u32) << (4 * i);
                }
            }
            slots
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let mut slots = 0u32;
            for j in 0..8 {
                let (mut near, mut far) = (0.0f32, tmax);
                for k in 0..3 {
                    near = near.max((node.planes[self.near[k]][j] - self.org[k]) * self.inv[k]);
                    far = far.min((node.planes[self.far[k]][j] - self.org[k]) * self.inv[k]);
                }
                slots |= ((near <= far * FAR_SCALE) as u32) << j;
            }
            slots
        }
    }
}

/// [`traverse`](super::traverse) with the float-plane node test: `planes` are
/// [`NodePlanes::of`] the same `bvh`.
#[inline(always)]
pub(crate) fn traverse_planes(
    bvh: &CwBvh,
    planes: &[NodePlanes],
    ray: &PlaneRay,
    oct_inv4: u32,
    tmax: f32,
    leaf: impl FnMut(usize, f32) -> Option<f32>,
) {
    walk(
        bvh,
        oct_inv4,
        tmax,
        |index, node, tmax| {
            let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
            place_hits(child_bits8, bit_index8, ray.slots(&planes[index], tmax))
        },
        leaf,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::traverse::obvhs_direction;
    use glam::Vec3;

    /// Deterministic uniform numbers for the test's rays (a 64-bit LCG's high bits).
    fn lcg(state: &mut u64) -> f32 {
        *state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (*state >> 40) as f32 / (1u64 << 24) as f32
    }

    /// The slab test of one child box in f64 on the exact quantised box (p + q e):
    /// whether the segment (0, tmax) touches it, to ~1e-16 of the distances.
    fn touches_f64(node: &CwBvhNode, slot: usize, org: Vec3, inv: Vec3A, tmax: f32) -> bool {
        let e = node.compute_extent();
        let q = [
            (node.child_min_x[slot], node.child_max_x[slot]),
            (node.child_min_y[slot], node.child_max_y[slot]),
            (node.child_min_z[slot], node.child_max_z[slot]),
        ];
        let (mut near, mut far) = (0.0f64, f64::from(tmax));
        for k in 0..3 {
            let (p, e, o, inv) = (f64::from(node.p[k]), f64::from(e[k]), f64::from(org[k]), f64::from(inv[k]));
            let (a, b) = ((p + f64::from(q[k].0) * e - o) * inv, (p + f64::from(q[k].1) * e - o) * inv);
            near = near.max(a.min(b));
            far = far.min(a.max(b));
        }
        near <= far
    }

    /// The float test keeps every child box the segment touches (so traversals find the
    /// same hits), and few more: its margins are a few ulps.
    #[test]
    fn keeps_every_child_box_the_segment_touches() {
        let mut s = 7u64;
        let mut tris = Vec::new();
        for _ in 0..3000 {
            let c = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 10.0 - 5.0;
            let d = |s: &mut u64| Vec3::new(lcg(s), lcg(s), lcg(s)) * 0.4 - 0.2;
            tris.push([c + d(&mut s), c + d(&mut s), c + d(&mut s)]);
        }
        let accel = crate::accel::Accel::build(&tris);
        let planes = NodePlanes::of(&accel.bvh);
        let (mut touched, mut extra) = (0u32, 0u32);
        for _ in 0..400 {
            let org = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 12.0 - 6.0;
            let dir = (Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 2.0 - 1.0).normalize_or(Vec3::X);
            let ray = NodeRay::new(org, obvhs_direction(dir));
            let pr = PlaneRay::new(&ray);
            for tmax in [1e-5, 1e-3, 0.1, 2.0, f32::INFINITY] {
                for (node, pl) in accel.bvh.nodes.iter().zip(&planes) {
                    let float = pr.slots(pl, tmax);
                    for slot in 0..8 {
                        if node.child_meta[slot] == 0 {
                            continue;
                        }
                        let kept = float & (1 << slot) != 0;
                        if touches_f64(node, slot, org, ray.inv, tmax) {
                            assert!(kept, "a touched child box was dropped");
                            touched += 1;
                        } else if kept {
                            extra += 1;
                        }
                    }
                }
            }
        }
        assert!(touched > 1000, "the rays must touch boxes for the test to say anything ({touched})");
        assert!(extra * 100 < touched, "{extra} boxes kept beyond {touched} touched");
    }

    /// The memory charged per triangle (`memory::BVH_PLANES_BYTES_PER_TRIANGLE`) covers the
    /// planes of a soup of small triangles and of a grid (a mesh's shape).
    #[test]
    fn planes_fit_their_memory_charge() {
        let mut s = 3u64;
        let soup: Vec<[Vec3; 3]> = (0..20000)
            .map(|_| {
                let c = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 10.0;
                [c, c + Vec3::X * 0.01, c + Vec3::Y * 0.01]
            })
            .collect();
        let n = 100;
        let grid: Vec<[Vec3; 3]> = (0..n * n)
            .flat_map(|i| {
                let p = Vec3::new((i % n) as f32, (i / n) as f32, 0.0);
                [[p, p + Vec3::X, p + Vec3::Y], [p + Vec3::X, p + Vec3::ONE - Vec3::Z, p + Vec3::Y]]
            })
            .collect();
        for tris in [&soup, &grid] {
            let accel = crate::accel::Accel::build(tris);
            let bytes = (accel.planes.len() * std::mem::size_of::<NodePlanes>()) as f64 / tris.len() as f64;
            println!("{} triangles: {} nodes, {bytes:.1} plane bytes per triangle", tris.len(), accel.planes.len());
            assert!(bytes <= crate::memory::BVH_PLANES_BYTES_PER_TRIANGLE as f64, "{bytes} B per triangle");
        }
    }

    /// Rays that start on a triangle and stop short of it (a random walk's steps) and
    /// long rays find the same hit with either node test.
    #[test]
    fn same_hits_as_the_quantised_test() {
        let mut s = 11u64;
        let mut tris = Vec::new();
        for _ in 0..2000 {
            let c = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 4.0 - 2.0;
            let d = |s: &mut u64| Vec3::new(lcg(s), lcg(s), lcg(s)) * 0.6 - 0.3;
            tris.push([c + d(&mut s), c + d(&mut s), c + d(&mut s)]);
        }
        let accel = crate::accel::Accel::build(&tris);
        let unmasked = vec![false; tris.len()];
        let (mut hits, mut rays) = (0u32, 0u32);
        for i in 0..4000 {
            let t = &tris[i % tris.len()];
            let (b1, b2) = (lcg(&mut s) * 0.5, lcg(&mut s) * 0.5);
            let org = t[0] + (t[1] - t[0]) * b1 + (t[2] - t[0]) * b2;
            let dir = (Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 2.0 - 1.0).normalize_or(Vec3::Y);
            for tmax in [1e-6, 1e-3, 0.05, f32::INFINITY] {
                let a = accel.intersect(org, dir, tmax, &unmasked, |_, _, _| true);
                let b = accel.intersect_quantised_for_tests(org, dir, tmax);
                assert_eq!(a.map(|h| (h.tri, h.t.to_bits())), b.map(|h| (h.tri, h.t.to_bits())));
                hits += a.is_some() as u32;
                rays += 1;
            }
        }
        assert!(hits > rays / 10 && hits < rays, "{hits} hits of {rays} rays");
    }
}
