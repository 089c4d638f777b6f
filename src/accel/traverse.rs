//! The traversal kernel: the watertight ray/triangle test, the CWBVH node test and the
//! walk over the tree in obvhs' visiting order. Shared by the scene's BVH (`Accel`), the
//! moving triangles' (`motion::accel`) and the curves' (`curves::bvh`).

use glam::{Vec3, Vec3A};
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::node::{CwBvhNode, extract_byte64};

/// Per-ray constants of the watertight test.
#[derive(Clone, Copy)]
pub(crate) struct RayTransform {
    org: Vec3A,
    /// The axes (x, y, z) of the ray's frame, each < 3.
    k: [usize; 3],
    s: [f32; 3],
}

/// The lanes of `v` as an array, so that the test can pick an axis chosen per ray
/// with one load: glam's `Vec3[i]` is a `match` with a panic arm, and those matches
/// were ~10 % of a Cornell box render's instructions (callgrind).
#[inline(always)]
fn lanes(v: Vec3A) -> [f32; 4] {
    v.extend(0.0).to_array()
}

impl RayTransform {
    #[inline]
    pub(crate) fn new(org: Vec3, dir: Vec3) -> Self {
        let a = dir.abs();
        let kz = if a.x > a.y {
            if a.x > a.z { 0 } else { 2 }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        RayTransform { org: org.into(), k: [kx, ky, kz], s: [dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]] }
    }

    /// Watertight intersection; returns (t, b1, b2) for tmin < t < tmax.
    #[inline(always)]
    pub(crate) fn intersect(&self, v: &[Vec3A; 3], tmin: f32, tmax: f32) -> Option<(f32, f32, f32)> {
        // `& 3` proves the index in range to the compiler (k < 3 by construction).
        let [kx, ky, kz] = self.k.map(|k| k & 3);
        let [sx, sy, sz] = self.s;
        // Lane-wise differences, the same f32 subtractions as per component.
        let a = lanes(v[0] - self.org);
        let b = lanes(v[1] - self.org);
        let c = lanes(v[2] - self.org);
        let (ax, ay) = (a[kx] - sx * a[kz], a[ky] - sy * a[kz]);
        let (bx, by) = (b[kx] - sx * b[kz], b[ky] - sy * b[kz]);
        let (cx, cy) = (c[kx] - sx * c[kz], c[ky] - sy * c[kz]);
        let mut u = cx * by - cy * bx;
        let mut vv = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        // On an edge, redo the edge functions in double precision so that the two
        // triangles sharing it agree on which one is hit.
        if u == 0.0 || vv == 0.0 || w == 0.0 {
            let (ax, ay, bx, by, cx, cy) = (ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64);
            u = (cx * by - cy * bx) as f32;
            vv = (ax * cy - ay * cx) as f32;
            w = (bx * ay - by * ax) as f32;
        }
        if (u < 0.0 || vv < 0.0 || w < 0.0) && (u > 0.0 || vv > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + vv + w;
        if det == 0.0 {
            return None;
        }
        let (az, bz, cz) = (sz * a[kz], sz * b[kz], sz * c[kz]);
        let t_scaled = u * az + vv * bz + w * cz;
        let inv = 1.0 / det;
        let t = t_scaled * inv;
        // The error bound of t (pbrt-v4, Triangle::Intersect): near the origin it is
        // ~ε × the triangle's size, far above the distance of a ray that starts next to
        // a large triangle, so t's sign (and its order against tmax) is then settled in f64.
        let max_z = az.abs().max(bz.abs()).max(cz.abs());
        let max_x = ax.abs().max(bx.abs()).max(cx.abs());
        let max_y = ay.abs().max(by.abs()).max(cy.abs());
        let delta_x = gamma(5) * (max_x + max_z);
        let delta_y = gamma(5) * (max_y + max_z);
        let delta_e = 2.0 * (gamma(2) * max_x * max_y + delta_y * max_x + delta_x * max_y);
        // pbrt's max|e|·|1/det| is at most 1 here: u, v, w share a sign, so |det| is their sum.
        let delta_t = 3.0 * (2.0 * gamma(3) * max_z + delta_e * max_z * inv.abs());
        let t = if t - delta_t > tmin && t + delta_t < tmax {
            t
        } else if t + delta_t <= tmin || t - delta_t >= tmax {
            return None;
        } else {
            self.distance_f64(v)
        };
        if !(t > tmin && t < tmax) {
            return None;
        }
        Some((t, vv * inv, w * inv))
    }

    /// The distance to the plane of `v` computed in f64 from the f32 inputs (whose
    /// differences are exact there), so its sign is right to ~1e-16 of the triangle's
    /// size. The f32 edge functions' signs still decide whether the triangle is hit,
    /// as its neighbours' do: this keeps the test watertight.
    #[cold]
    #[inline(never)]
    fn distance_f64(&self, v: &[Vec3A; 3]) -> f32 {
        let [kx, ky, kz] = self.k;
        let [sx, sy, sz] = self.s.map(f64::from);
        let org = lanes(self.org);
        let rel = |p: Vec3A| {
            let p = lanes(p);
            [0, 1, 2].map(|i| p[i] as f64 - org[i] as f64)
        };
        let (a, b, c) = (rel(v[0]), rel(v[1]), rel(v[2]));
        let shear = |p: [f64; 3]| (p[kx] - sx * p[kz], p[ky] - sy * p[kz]);
        let ((ax, ay), (bx, by), (cx, cy)) = (shear(a), shear(b), shear(c));
        let (eu, ev, ew) = (cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax);
        let det = eu + ev + ew;
        if det == 0.0 {
            return f32::NAN;
        }
        ((eu * a[kz] + ev * b[kz] + ew * c[kz]) * sz / det) as f32
    }
}

/// Bound on the relative rounding error of n f32 operations (pbrt's γ).
#[inline(always)]
fn gamma(n: i32) -> f32 {
    let e = f32::EPSILON * 0.5 * n as f32;
    e / (1.0 - e)
}

/// Per-ray constants of the node test (shared with the curves' BVH, `curves::bvh`).
pub(crate) struct NodeRay {
    pub(super) org: Vec3A,
    pub(super) inv: Vec3A,
    pub(super) neg: [bool; 3],
}

impl NodeRay {
    #[inline]
    pub(crate) fn new(org: Vec3, dir: Vec3A) -> Self {
        // Not obvhs' safe_inverse, which clamps 1/d to 1/ε = 8.4e6 and so shortens the
        // box exits of rays nearly parallel to an axis.
        let inv = |d: f32| if d.abs() >= 1e-20 { 1.0 / d } else { 1e20f32.copysign(d) };
        NodeRay {
            org: org.into(),
            inv: Vec3A::new(inv(dir.x), inv(dir.y), inv(dir.z)),
            neg: [dir.x < 0.0, dir.y < 0.0, dir.z < 0.0],
        }
    }
}

/// Which children of `node` the ray's segment (0, tmax) touches, as the hitmask of
/// obvhs' `traverse!`. Unlike obvhs' test it keeps boxes that end within 1e-4 of the
/// origin and widens each slab by its rounding error: the child plane is p + q·e (e a
/// power of two, q < 256), and t = q·(e/d) + (p - o)/d is off by at most ~4ε of
/// (|p - o| + 255 e)/|d| (the subtraction, two products, two sums, and the builder's
/// f32 quantisation); 8ε is used.
#[inline(always)]
fn node_hits(node: &CwBvhNode, ray: &NodeRay, tmax: f32, oct_inv4: u32) -> u32 {
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    place_hits(child_bits8, bit_index8, slab_mask(node, ray, tmax))
}

/// The traversal's hit mask from the slab test's one bit per child slot: each hit child's
/// bits (one for an inner node, the unary triangle count for a leaf) moved to its place.
/// The per-child branch is kept on purpose: predicted, it lets the processor start on the
/// next node before the slab test ends (a branch-free version measured slower, see
/// docs/benchmarks.md, fourth round).
#[inline(always)]
pub(super) fn place_hits(child_bits8: u64, bit_index8: u64, slots: u32) -> u32 {
    let mut hits = 0u32;
    for j in 0..8 {
        if slots & (1 << j) != 0 {
            hits |= extract_byte64(child_bits8, j) << extract_byte64(bit_index8, j);
        }
    }
    hits
}

/// One bit per child slot of `node` whose box the segment touches (see `node_hits`).
#[inline(always)]
fn slab_mask(node: &CwBvhNode, ray: &NodeRay, tmax: f32) -> u32 {
    let ext = node.compute_extent();
    let rel = Vec3A::from(node.p) - ray.org;
    let scale = ext * ray.inv;
    let offset = rel * ray.inv;
    let err = (rel.abs() + ext * 255.0) * ray.inv.abs() * (8.0 * f32::EPSILON);
    // Entries are moved earlier and exits later by the bound.
    let (offset_near, offset_far) = (offset - err, offset + err);
    let mut slots = 0u32;
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // Four quantised planes as floats: the bytes widened in registers (zero-extended
        // to 32 bits, then converted exactly), not converted one by one from memory.
        let q = |v: &[u8; 8], i: usize| -> __m128 {
            let bytes = u32::from_le_bytes([v[i * 4], v[i * 4 + 1], v[i * 4 + 2], v[i * 4 + 3]]);
            // SAFETY: SSE2 is part of x86_64; no memory is touched.
            unsafe {
                let zero = _mm_setzero_si128();
                let words = _mm_unpacklo_epi8(_mm_cvtsi32_si128(bytes as i32), zero);
                _mm_cvtepi32_ps(_mm_unpacklo_epi16(words, zero))
            }
        };
        // SAFETY: SSE2 intrinsics, always available on x86_64.
        unsafe {
            let axes = [
                (&node.child_min_x, &node.child_max_x),
                (&node.child_min_y, &node.child_max_y),
                (&node.child_min_z, &node.child_max_z),
            ];
            for i in 0..2 {
                let mut near = _mm_setzero_ps();
                let mut far = _mm_set1_ps(tmax);
                for (k, (lo, hi)) in axes.iter().enumerate() {
                    let (n, f) = if ray.neg[k] { (q(hi, i), q(lo, i)) } else { (q(lo, i), q(hi, i)) };
                    let s = _mm_set1_ps(scale[k]);
                    near = _mm_max_ps(near, _mm_add_ps(_mm_mul_ps(n, s), _mm_set1_ps(offset_near[k])));
                    far = _mm_min_ps(far, _mm_add_ps(_mm_mul_ps(f, s), _mm_set1_ps(offset_far[k])));
                }
                slots |= (_mm_movemask_ps(_mm_cmple_ps(near, far)) as u32) << (i * 4);
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let axes = [
            (&node.child_min_x, &node.child_max_x),
            (&node.child_min_y, &node.child_max_y),
            (&node.child_min_z, &node.child_max_z),
        ];
        for i in 0..2 {
            let mut mask = 0u32;
            for j in 0..4 {
                let (mut near, mut far) = (0.0f32, tmax);
                for (k, (lo, hi)) in axes.iter().enumerate() {
                    let (n, f) =
                        if ray.neg[k] { (hi[i * 4 + j], lo[i * 4 + j]) } else { (lo[i * 4 + j], hi[i * 4 + j]) };
                    near = near.max(n as f32 * scale[k] + offset_near[k]);
                    far = far.min(f as f32 * scale[k] + offset_far[k]);
                }
                mask |= ((near <= far) as u32) << j;
            }
            slots |= mask << (i * 4);
        }
    }
    slots
}

/// obvhs picks a node's near plane from the direction's comparison with zero but
/// inverts it with the sign bit, so a -0.0 component misses boxes; -0.0 + 0.0 = +0.0.
#[inline]
pub(crate) fn obvhs_direction(dir: Vec3) -> Vec3A {
    Vec3A::from(dir + Vec3::ZERO)
}

/// Set bits of each byte value. Plain x86_64 has no popcnt instruction, so `count_ones`
/// is a dozen dependent shifts and masks in the walk's chain from one node to the next;
/// a byte suffices because the bits counted are the node's 8-bit inner-child mask.
static BYTE_POPCOUNT: [u8; 256] = {
    let mut t = [0u8; 256];
    let mut i = 0;
    while i < 256 {
        t[i] = (i as u32).count_ones() as u8;
        i += 1;
    }
    t
};

/// Deepest CWBVH the traversal's stack holds (obvhs' own traversal has the same bound).
const STACK_DEPTH: usize = 32;

/// The ray-octant code of obvhs' node layout: the child slots are stored in the order a
/// ray of octant 0 meets them, and XOR with this visits them nearest-first for `dir`.
#[inline]
pub(crate) fn octant_inv4(dir: Vec3A) -> u32 {
    (if dir.x < 0.0 { 0 } else { 0x0404_0404 })
        | (if dir.y < 0.0 { 0 } else { 0x0202_0202 })
        | (if dir.z < 0.0 { 0 } else { 0x0101_0101 })
}

/// Walks the CWBVH in obvhs' order (Ylitie et al. 2017: a group of child nodes and a
/// group of primitives per step, highest bit first), so hits are met in the same order as
/// with `obvhs::traverse!` and results stay bit for bit (the moving triangles' and the
/// curves' BVHs walk with it too). `leaf(primitive, tmax)` tests one
/// BVH-ordered triangle and returns the segment's new end, or None to stop. Its own loop
/// because obvhs' traversal state zero-fills a 256-byte stack per ray and pushes through
/// a bounds check (callgrind: 45 instructions per ray before the first node).
#[inline(always)]
pub(crate) fn traverse(
    bvh: &CwBvh,
    ray: &NodeRay,
    oct_inv4: u32,
    tmax: f32,
    leaf: impl FnMut(usize, f32) -> Option<f32>,
) {
    walk(bvh, oct_inv4, tmax, |_, node, tmax| node_hits(node, ray, tmax, oct_inv4), leaf)
}

/// The walk of [`traverse`] with the node test given: `hits(index, node, tmax)` returns the
/// node's hit mask (hit inner children in bits 24..32, hit triangles below).
#[inline(always)]
pub(super) fn walk(
    bvh: &CwBvh,
    oct_inv4: u32,
    mut tmax: f32,
    hits: impl Fn(usize, &CwBvhNode, f32) -> u32,
    mut leaf: impl FnMut(usize, f32) -> Option<f32>,
) {
    if bvh.nodes.is_empty() {
        return;
    }
    let mut stack = [std::mem::MaybeUninit::<(u32, u32)>::uninit(); STACK_DEPTH];
    let mut depth = 0usize;
    // (base index, bits): node groups keep their hit children in bits 24..32 and the
    // children's inner-node mask in bits 0..8; primitive groups one bit per triangle.
    let mut nodes = (0u32, 0x8000_0000u32);
    let mut prims = (0u32, 0u32);
    loop {
        while prims.1 != 0 {
            let bit = 31 - prims.1.leading_zeros();
            prims.1 &= !(1u32 << bit);
            match leaf((prims.0 + bit) as usize, tmax) {
                Some(t) => tmax = t,
                None => return,
            }
        }
        if nodes.1 & 0xff00_0000 != 0 {
            let hits_imask = nodes.1;
            let child = 31 - hits_imask.leading_zeros();
            nodes.1 &= !(1u32 << child);
            if nodes.1 & 0xff00_0000 != 0 {
                // At most one group per level is pending: the depth bounds the stack.
                stack[depth].write(nodes);
                depth += 1;
            }
            let slot = (child - 24) ^ (oct_inv4 & 0xff);
            // The inner children stored before `slot`: imask bits below it (slot < 8).
            let relative = u32::from(BYTE_POPCOUNT[(hits_imask & !(0xffff_ffffu32 << slot)) as u8 as usize]);
            let index = (nodes.0 + relative) as usize;
            let node = &bvh.nodes[index];
            let hitmask = hits(index, node, tmax);
            nodes = (node.child_base_idx, (hitmask & 0xff00_0000) | node.imask as u32);
            prims = (node.primitive_base_idx, hitmask & 0x00ff_ffff);
        } else {
            nodes = (0, 0);
        }
        if prims.1 == 0 && nodes.1 & 0xff00_0000 == 0 {
            if depth == 0 {
                return;
            }
            depth -= 1;
            // SAFETY: entries below `depth` were written by the pushes above.
            nodes = unsafe { stack[depth].assume_init() };
        }
    }
}
