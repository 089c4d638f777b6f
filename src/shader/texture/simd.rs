//! AVX2 kernels for the lattice work of Perlin noise and Voronoi, chosen at run time.
//!
//! The scalar code evaluates Perlin's 8 (3-D) or 16 (4-D) cell corners and Voronoi's 27 (3-D)
//! cells one after the other; each corner or cell is an independent integer hash plus a few
//! float operations, so here eight of them run in one 256-bit vector. The build targets
//! baseline x86-64 (SSE2, which has no 32-bit vector multiply for PCG), so these functions
//! enable AVX2 themselves and callers take them only when `has_avx2()` says the CPU has it.
//!
//! Every lane computes exactly what the scalar code computes, in the same order: integer
//! hashes are exact whatever the width, each float lane is the same IEEE-754 operation (`+`,
//! `-`, `*`, `sqrt`, `max` of finite numbers; no FMA), and a sign flip is an XOR of the sign
//! bit, as Rust's negation is. Tests compare the kernels with the scalar code bit for bit.

#[cfg(target_arch = "x86_64")]
use core::arch::x86_64::*;

/// Whether this CPU runs the AVX2 kernels: the CPUID answer cached in one byte (a load and a
/// compare). std's own cache costs 14 instructions a test (callgrind, `bench/node_graph.py`:
/// 6.5 M for the 460,800 Perlin lookups, which each test it once).
#[inline(always)]
pub(crate) fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        use std::sync::atomic::{AtomicU8, Ordering};
        /// 0: not asked yet; 1: no AVX2; 2: AVX2.
        static AVX2: AtomicU8 = AtomicU8::new(0);
        #[cold]
        #[inline(never)]
        fn detect() -> bool {
            let yes = std::arch::is_x86_feature_detected!("avx2");
            AVX2.store(if yes { 2 } else { 1 }, Ordering::Relaxed);
            yes
        }
        match AVX2.load(Ordering::Relaxed) {
            2 => true,
            1 => false,
            _ => detect(),
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// `x.rotate_left(K)` on each lane.
#[cfg(target_arch = "x86_64")]
macro_rules! rotl {
    ($x:expr, $k:literal) => {
        _mm256_or_si256(_mm256_slli_epi32::<$k>($x), _mm256_srli_epi32::<{ 32 - $k }>($x))
    };
}

/// One lookup3 step `x ^= y; x -= rot(y, K)` on each lane.
#[cfg(target_arch = "x86_64")]
macro_rules! xor_sub_rot {
    ($x:ident, $y:ident, $k:literal) => {
        $x = _mm256_xor_si256($x, $y);
        $x = _mm256_sub_epi32($x, rotl!($y, $k));
    };
}

/// lookup3's `final` mix of three words on each lane (`hash::finalize`).
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn finalize8(mut a: __m256i, mut b: __m256i, mut c: __m256i) -> __m256i {
    xor_sub_rot!(c, b, 14);
    xor_sub_rot!(a, c, 11);
    xor_sub_rot!(b, a, 25);
    xor_sub_rot!(c, b, 16);
    xor_sub_rot!(a, c, 4);
    xor_sub_rot!(b, a, 14);
    xor_sub_rot!(c, b, 24);
    c
}

/// lookup3's `mix` of three words on each lane (`hash::mix`).
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn mix8(a: &mut __m256i, b: &mut __m256i, c: &mut __m256i) {
    // x -= z; x ^= rot(z, K); z += y, for (a, c, b), (b, a, c), (c, b, a) twice.
    macro_rules! step {
        ($x:ident, $z:ident, $y:ident, $k:literal) => {
            *$x = _mm256_sub_epi32(*$x, *$z);
            *$x = _mm256_xor_si256(*$x, rotl!(*$z, $k));
            *$z = _mm256_add_epi32(*$z, *$y);
        };
    }
    step!(a, c, b, 4);
    step!(b, a, c, 6);
    step!(c, b, a, 8);
    step!(a, c, b, 16);
    step!(b, a, c, 19);
    step!(c, b, a, 4);
}

/// lookup3's initial value for a key of `words` words (`hash::seed`).
const fn seed(words: u32) -> i32 {
    0xdeadbeef_u32.wrapping_add(words << 2).wrapping_add(13) as i32
}

/// Bit `k` of each lane index 0..8 (+ `base`), as integers and as floats: a corner's offset.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn corner_bits(k: u32, base: u32) -> (__m256i, __m256) {
    let bit = |i: u32| (((i + base) >> k) & 1) as i32;
    let v = _mm256_setr_epi32(bit(0), bit(1), bit(2), bit(3), bit(4), bit(5), bit(6), bit(7));
    (v, _mm256_cvtepi32_ps(v))
}

/// `v` with its sign flipped where `mask` (one bit of the hash, at bit `SHIFT`) is set:
/// `perlin::negate_if` on each lane.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn negate_if8<const SHIFT: i32>(v: __m256, bit: __m256i) -> __m256 {
    _mm256_xor_ps(v, _mm256_castsi256_ps(_mm256_slli_epi32::<SHIFT>(bit)))
}

/// `if c { a } else { b }` on each lane, `c` a lane mask of all ones or zeros.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn select(c: __m256i, a: __m256, b: __m256) -> __m256 {
    _mm256_blendv_ps(b, a, _mm256_castsi256_ps(c))
}

/// Perlin's 3-D lattice work at `p` (each |p_k| < 2^23, as after the `fmod` precision fix):
/// the cell `floor(p)`, the eight corner gradients `grad3(hash_uint3(cell + corner),
/// p - cell - corner)` (corner j has bit k of j on axis k) and the three fades of `p - cell`,
/// as `perlin::perlin_3d` computes them. The floor is SSE4.1's, which is IEEE `floor` like
/// `float_ops::floor` (signed zeros included); below 2^23 the truncation to i32 is exact.
///
/// The renderer takes `perlin_3d_mixed`; this form is what the tests compare with the scalar
/// lattice.
///
/// # Safety
/// The CPU must support AVX2 (`has_avx2`).
#[cfg(all(test, target_arch = "x86_64"))]
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn perlin_lattice_3d(p: [f32; 3]) -> ([f32; 8], [f32; 3]) {
    let (g, fade) = lattice_3d(p);
    let mut corners = [0.0f32; 8];
    let mut fades = [0.0f32; 4];
    // SAFETY: `corners` holds eight f32 and `fades` four; the stores are unaligned.
    unsafe {
        _mm256_storeu_ps(corners.as_mut_ptr(), g);
        _mm_storeu_ps(fades.as_mut_ptr(), fade);
    }
    (corners, [fades[0], fades[1], fades[2]])
}

/// Unscaled 3-D Perlin noise at `p` (each |p_k| < 2^23): `perlin_lattice_3d` and then
/// `perlin::tri_mix` in vectors, bit for bit. Each weighted sum of `tri_mix` is a product of
/// the same two numbers and a sum of the same two products (IEEE `+` and `*` commute
/// exactly), pairs summed by `hadd`. Callgrind: 28 scalar instructions of `tri_mix` plus the
/// stores and loads of eleven floats a lookup became 15 vector ones.
///
/// # Safety
/// The CPU must support AVX2 (`has_avx2`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn perlin_3d_mixed(p: [f32; 3]) -> f32 {
    let (g, fade) = lattice_3d(p);
    let rest = _mm_sub_ps(_mm_set1_ps(1.0), fade);
    // [1 - x, x, 1 - y, y] and [1 - z, z, ..].
    let xy = _mm_unpacklo_ps(rest, fade);
    let z = _mm_unpackhi_ps(rest, fade);
    let wx = _mm_movelh_ps(xy, xy);
    // Lanes 2k and 2k + 1: v[2k] (1 - x) and v[2k + 1] x; summed in pairs (a0..a3).
    let prod = _mm256_mul_ps(g, _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(wx), wx));
    let pairs = _mm256_hadd_ps(prod, prod);
    let a = _mm_shuffle_ps::<0b01_00_01_00>(_mm256_castps256_ps128(pairs), _mm256_extractf128_ps::<1>(pairs));
    // (1 - y) a0 + y a1 and (1 - y) a2 + y a3; then (1 - z) b0 + z b1.
    let b = _mm_hadd_ps(_mm_mul_ps(a, _mm_movehl_ps(xy, xy)), _mm_setzero_ps());
    _mm_cvtss_f32(_mm_hadd_ps(_mm_mul_ps(b, z), _mm_setzero_ps()))
}

/// Unscaled 3-D Perlin noise at three points `p` (each |p_k| < 2^23) that lie in one lattice
/// cell, as three `perlin_3d_mixed` calls compute it, bit for bit; None when their cells
/// differ (the caller then takes one point at a time). The Bump node's three points, 10⁻⁴
/// apart, share their cell nearly always: the eight corner hashes and the gradients'
/// selection masks are computed once for the three, the rest (offsets, gradients, fades and
/// the mix) per point with the same operations as `lattice_3d` and `perlin_3d_mixed`.
///
/// # Safety
/// The CPU must support AVX2 (`has_avx2`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn perlin_3d_mixed_shared(p: [[f32; 3]; 3]) -> Option<[f32; 3]> {
    let v = p.map(|p| _mm_setr_ps(p[0], p[1], p[2], 0.0));
    let cell = v.map(|v| _mm_floor_ps(v));
    let i = _mm_cvttps_epi32(cell[0]);
    let same = _mm_and_si128(
        _mm_castps_si128(_mm_cmpeq_ps(cell[0], cell[1])),
        _mm_castps_si128(_mm_cmpeq_ps(cell[0], cell[2])),
    );
    // Equal floors as floats are equal cells (signed zeros compare equal and truncate to 0).
    if _mm_movemask_ps(_mm_castsi128_ps(same)) & 0b111 != 0b111 {
        return None;
    }
    let h = corner_hashes_3d(i);
    let m = Grad3Masks::new(h);
    let ((_, fdx), (_, fdy), (_, fdz)) = (corner_bits(0, 0), corner_bits(1, 0), corner_bits(2, 0));
    let mut out = [0.0f32; 3];
    for k in 0..3 {
        let f = _mm_sub_ps(v[k], cell[k]);
        let fw = _mm256_castps128_ps256(f);
        let at = |k: i32| _mm256_permutevar8x32_ps(fw, _mm256_set1_epi32(k));
        let g = m.grad(_mm256_sub_ps(at(0), fdx), _mm256_sub_ps(at(1), fdy), _mm256_sub_ps(at(2), fdz));
        out[k] = tri_mix8(g, fade4(f));
    }
    Some(out)
}

/// The eight corner hashes `hash_uint3(i + corner)` of 3-D cell `i` (lanes x, y, z of `i`).
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn corner_hashes_3d(i: __m128i) -> __m256i {
    let ((dx, _), (dy, _), (dz, _)) = (corner_bits(0, 0), corner_bits(1, 0), corner_bits(2, 0));
    let s = _mm256_set1_epi32(seed(3));
    // Lane k of a 128-bit vector broadcast to all eight lanes.
    let wide = _mm256_castsi128_si256(i);
    let key = |lanes: __m256i, d: __m256i| _mm256_add_epi32(s, _mm256_add_epi32(lanes, d));
    finalize8(
        key(_mm256_permutevar8x32_epi32(wide, _mm256_set1_epi32(0)), dx),
        key(_mm256_permutevar8x32_epi32(wide, _mm256_set1_epi32(1)), dy),
        key(_mm256_permutevar8x32_epi32(wide, _mm256_set1_epi32(2)), dz),
    )
}

/// Perlin's fade `t t t (t (6 t - 15) + 10)` on each lane, in `perlin::fade`'s order.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn fade4(f: __m128) -> __m128 {
    let t3 = _mm_mul_ps(_mm_mul_ps(f, f), f);
    let inner =
        _mm_add_ps(_mm_mul_ps(f, _mm_sub_ps(_mm_mul_ps(f, _mm_set1_ps(6.0)), _mm_set1_ps(15.0))), _mm_set1_ps(10.0));
    _mm_mul_ps(t3, inner)
}

/// `perlin::tri_mix` of the eight corners `g` with the fades (lanes x, y, z of `fade`), as
/// `perlin_3d_mixed` computes it.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn tri_mix8(g: __m256, fade: __m128) -> f32 {
    let rest = _mm_sub_ps(_mm_set1_ps(1.0), fade);
    // [1 - x, x, 1 - y, y] and [1 - z, z, ..].
    let xy = _mm_unpacklo_ps(rest, fade);
    let z = _mm_unpackhi_ps(rest, fade);
    let wx = _mm_movelh_ps(xy, xy);
    // Lanes 2k and 2k + 1: v[2k] (1 - x) and v[2k + 1] x; summed in pairs (a0..a3).
    let prod = _mm256_mul_ps(g, _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(wx), wx));
    let pairs = _mm256_hadd_ps(prod, prod);
    let a = _mm_shuffle_ps::<0b01_00_01_00>(_mm256_castps256_ps128(pairs), _mm256_extractf128_ps::<1>(pairs));
    // (1 - y) a0 + y a1 and (1 - y) a2 + y a3; then (1 - z) b0 + z b1.
    let b = _mm_hadd_ps(_mm_mul_ps(a, _mm_movehl_ps(xy, xy)), _mm_setzero_ps());
    _mm_cvtss_f32(_mm_hadd_ps(_mm_mul_ps(b, z), _mm_setzero_ps()))
}

/// `perlin::grad3`'s choices for eight hashes, made once and applied to several offsets.
#[cfg(target_arch = "x86_64")]
struct Grad3Masks {
    /// h < 8: u = x (else y).
    lt8: __m256i,
    /// h is 12 or 14: the second term's fallback is x (else z).
    x_not_z: __m256i,
    /// h < 4: v = y (else that fallback).
    lt4: __m256i,
    /// Bits 0 and 1 of h: negate u, v.
    b0: __m256i,
    b1: __m256i,
}

#[cfg(target_arch = "x86_64")]
impl Grad3Masks {
    #[inline]
    #[target_feature(enable = "avx2")]
    fn new(hash: __m256i) -> Self {
        let h = _mm256_and_si256(hash, _mm256_set1_epi32(15));
        let lt = |n: i32| _mm256_cmpgt_epi32(_mm256_set1_epi32(n), h);
        let eq = |n: i32| _mm256_cmpeq_epi32(h, _mm256_set1_epi32(n));
        let one = _mm256_set1_epi32(1);
        Grad3Masks {
            lt8: lt(8),
            x_not_z: _mm256_or_si256(eq(12), eq(14)),
            lt4: lt(4),
            b0: _mm256_and_si256(h, one),
            b1: _mm256_and_si256(_mm256_srli_epi32::<1>(h), one),
        }
    }

    /// `grad3` of each lane's hash at offset (x, y, z), as `grad3_8`.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn grad(&self, x: __m256, y: __m256, z: __m256) -> __m256 {
        let u = select(self.lt8, x, y);
        let vt = select(self.x_not_z, x, z);
        let v = select(self.lt4, y, vt);
        _mm256_add_ps(negate_if8::<31>(u, self.b0), negate_if8::<31>(v, self.b1))
    }
}

/// The corner gradients and the fades of `perlin_lattice_3d`, in vectors.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn lattice_3d(p: [f32; 3]) -> (__m256, __m128) {
    let v = _mm_setr_ps(p[0], p[1], p[2], 0.0);
    let cell = _mm_floor_ps(v);
    let i = _mm_cvttps_epi32(cell);
    let f = _mm_sub_ps(v, cell);
    // fade(t) = t t t (t (6 t - 15) + 10), in `perlin::fade`'s order.
    let t3 = _mm_mul_ps(_mm_mul_ps(f, f), f);
    let inner =
        _mm_add_ps(_mm_mul_ps(f, _mm_sub_ps(_mm_mul_ps(f, _mm_set1_ps(6.0)), _mm_set1_ps(15.0))), _mm_set1_ps(10.0));
    let fade = _mm_mul_ps(t3, inner);
    let ((dx, fdx), (dy, fdy), (dz, fdz)) = (corner_bits(0, 0), corner_bits(1, 0), corner_bits(2, 0));
    let s = _mm256_set1_epi32(seed(3));
    // Lane k of a 128-bit vector broadcast to all eight lanes.
    let wide = _mm256_castsi128_si256(i);
    let key = |lanes: __m256i, d: __m256i| _mm256_add_epi32(s, _mm256_add_epi32(lanes, d));
    let h = finalize8(
        key(_mm256_permutevar8x32_epi32(wide, _mm256_set1_epi32(0)), dx),
        key(_mm256_permutevar8x32_epi32(wide, _mm256_set1_epi32(1)), dy),
        key(_mm256_permutevar8x32_epi32(wide, _mm256_set1_epi32(2)), dz),
    );
    let fw = _mm256_castps128_ps256(f);
    let at = |k: i32| _mm256_permutevar8x32_ps(fw, _mm256_set1_epi32(k));
    (grad3_8(h, _mm256_sub_ps(at(0), fdx), _mm256_sub_ps(at(1), fdy), _mm256_sub_ps(at(2), fdz)), fade)
}

/// `perlin::grad3` on each lane.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn grad3_8(hash: __m256i, x: __m256, y: __m256, z: __m256) -> __m256 {
    let h = _mm256_and_si256(hash, _mm256_set1_epi32(15));
    let lt = |n: i32| _mm256_cmpgt_epi32(_mm256_set1_epi32(n), h);
    let eq = |n: i32| _mm256_cmpeq_epi32(h, _mm256_set1_epi32(n));
    let u = select(lt(8), x, y);
    let vt = select(_mm256_or_si256(eq(12), eq(14)), x, z);
    let v = select(lt(4), y, vt);
    let one = _mm256_set1_epi32(1);
    let b0 = _mm256_and_si256(h, one);
    let b1 = _mm256_and_si256(_mm256_srli_epi32::<1>(h), one);
    _mm256_add_ps(negate_if8::<31>(u, b0), negate_if8::<31>(v, b1))
}

/// `perlin::grad4` on each lane.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn grad4_8(hash: __m256i, x: __m256, y: __m256, z: __m256, w: __m256) -> __m256 {
    let h = _mm256_and_si256(hash, _mm256_set1_epi32(31));
    let lt = |n: i32| _mm256_cmpgt_epi32(_mm256_set1_epi32(n), h);
    let u = select(lt(24), x, y);
    let v = select(lt(16), y, z);
    let s = select(lt(8), z, w);
    let one = _mm256_set1_epi32(1);
    let b0 = _mm256_and_si256(h, one);
    let b1 = _mm256_and_si256(_mm256_srli_epi32::<1>(h), one);
    let b2 = _mm256_and_si256(_mm256_srli_epi32::<2>(h), one);
    _mm256_add_ps(_mm256_add_ps(negate_if8::<31>(u, b0), negate_if8::<31>(v, b1)), negate_if8::<31>(s, b2))
}

/// Perlin's 4-D corner gradients `grad4(hash_uint4(i + corner), f - corner)` for the sixteen
/// corners of cell `i`, as `perlin::perlin_4d` takes them (two vectors of eight).
///
/// # Safety
/// The CPU must support AVX2 (`has_avx2`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn perlin_corners_4d(i: [i32; 4], f: [f32; 4]) -> [f32; 16] {
    let s = _mm256_set1_epi32(seed(4));
    let mut out = [0.0f32; 16];
    for (half, chunk) in out.chunks_exact_mut(8).enumerate() {
        let base = 8 * half as u32;
        let d: [(__m256i, __m256); 4] = core::array::from_fn(|k| corner_bits(k as u32, base));
        let key = |k: usize| _mm256_add_epi32(s, _mm256_add_epi32(_mm256_set1_epi32(i[k]), d[k].0));
        let (mut a, mut b, mut c) = (key(0), key(1), key(2));
        mix8(&mut a, &mut b, &mut c);
        let kw = _mm256_add_epi32(_mm256_set1_epi32(i[3]), d[3].0);
        let h = finalize8(_mm256_add_epi32(a, kw), b, c);
        let x: [__m256; 4] = core::array::from_fn(|k| _mm256_sub_ps(_mm256_set1_ps(f[k]), d[k].1));
        let g = grad4_8(h, x[0], x[1], x[2], x[3]);
        // SAFETY: `chunk` holds eight f32; the store is unaligned.
        unsafe { _mm256_storeu_ps(chunk.as_mut_ptr(), g) };
    }
    out
}

/// The distance a Voronoi lane kernel measures from each feature point to the shading point.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum LaneMetric {
    /// Euclidean without the root (`distance_bound`, what F1 compares).
    EuclideanSquared,
    Euclidean,
    Manhattan,
    Chebychev,
}

/// The 27 cells of a 3-D Voronoi neighbourhood of radius 1 in scan order (x fastest), padded
/// to 32 lanes (lanes 27 to 31 are cells of the next layer: computed, never read).
pub(crate) struct Cells27 {
    /// The feature point relative to the centre cell: offset + hash × randomness.
    pub(crate) x: [f32; 32],
    pub(crate) y: [f32; 32],
    pub(crate) z: [f32; 32],
    /// Its distance to the shading point in the chosen metric.
    pub(crate) d: [f32; 32],
}

/// Cell offset `lane` of the radius-1 neighbourhood on axis `k` (x fastest), for lanes 0..32.
const fn cell_offset(lane: usize, k: usize) -> i32 {
    let step = [1, 3, 9][k];
    ((lane / step) % 3) as i32 - 1 + if k == 2 && lane >= 27 { 3 } else { 0 }
}

/// The offset table of [`cell_offset`], one row per axis.
const CELL_OFFSETS: [[i32; 32]; 3] = {
    let mut t = [[0; 32]; 3];
    let mut i = 0;
    while i < 32 {
        t[0][i] = cell_offset(i, 0);
        t[1][i] = cell_offset(i, 1);
        t[2][i] = cell_offset(i, 2);
        i += 1;
    }
    t
};

/// The feature points of the 27 cells around `cell` (integer cell coordinates, as
/// `voronoi_coord::cell_index` makes them) and their distances to `local`, the shading point
/// relative to the cell: Cycles' `hash_int3_to_float3` (PCG3D) and `voronoi_distance` (or
/// `voronoi_distance_bound`) for eight cells at a time. `local` and `randomness` must be
/// finite (Chebychev's `max` differs from Rust's `f32::max` on NaN).
///
/// # Safety
/// The CPU must support AVX2 (`has_avx2`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn voronoi_cells_3d(
    cell: [i32; 3],
    local: [f32; 3],
    randomness: f32,
    metric: LaneMetric,
    out: &mut Cells27,
) {
    for g in 0..4 {
        let p = cell_points(cell, g, randomness);
        let d = cell_distances(&p, local, metric);
        store_group(out, g, &p, d);
    }
}

/// [`voronoi_cells_3d`] for three shading points in the same cell (the Bump node's three
/// heights): the feature points once, into `out` with the first point's distances; the
/// second's and third's distances into `more`. Same requirements as [`voronoi_cells_3d`]
/// for every `local`.
///
/// # Safety
/// The CPU must support AVX2 (`has_avx2`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn voronoi_cells_3d_lanes(
    cell: [i32; 3],
    local: [[f32; 3]; 3],
    randomness: f32,
    metric: LaneMetric,
    out: &mut Cells27,
    more: &mut [[f32; 32]; 2],
) {
    for g in 0..4 {
        let p = cell_points(cell, g, randomness);
        store_group(out, g, &p, cell_distances(&p, local[0], metric));
        for (d, local) in more.iter_mut().zip(&local[1..]) {
            // SAFETY: each row has 32 f32, lanes 8g..8g+8 are within it.
            unsafe { _mm256_storeu_ps(d[8 * g..].as_mut_ptr(), cell_distances(&p, *local, metric)) };
        }
    }
}

/// The feature points of cells `8g..8g + 8` (scan order) around `cell`, per axis, relative
/// to `cell`: offset + PCG3D hash × randomness.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn cell_points(cell: [i32; 3], g: usize, randomness: f32) -> [__m256; 3] {
    let (mul, inc) = (_mm256_set1_epi32(1664525), _mm256_set1_epi32(1013904223));
    let mask = _mm256_set1_epi32(0x7FFF_FFFF);
    let to_unit = _mm256_set1_ps(1.0 / 2147483648.0);
    let r = _mm256_set1_ps(randomness);
    let lanes = 8 * g..8 * g + 8;
    // SAFETY (loads): each row of CELL_OFFSETS has 32 i32, lanes is within it.
    let off: [__m256i; 3] =
        core::array::from_fn(|k| unsafe { _mm256_loadu_si256(CELL_OFFSETS[k][lanes.clone()].as_ptr().cast()) });
    // hash_pcg3d_i on cell + offset (wrapping, as cell_index adds).
    let [mut x, mut y, mut z] = core::array::from_fn(|k| {
        let key = _mm256_add_epi32(_mm256_set1_epi32(cell[k]), off[k]);
        _mm256_add_epi32(_mm256_mullo_epi32(key, mul), inc)
    });
    x = _mm256_add_epi32(x, _mm256_mullo_epi32(y, z));
    y = _mm256_add_epi32(y, _mm256_mullo_epi32(z, x));
    z = _mm256_add_epi32(z, _mm256_mullo_epi32(x, y));
    x = _mm256_xor_si256(x, _mm256_srai_epi32::<16>(x));
    y = _mm256_xor_si256(y, _mm256_srai_epi32::<16>(y));
    z = _mm256_xor_si256(z, _mm256_srai_epi32::<16>(z));
    x = _mm256_add_epi32(x, _mm256_mullo_epi32(y, z));
    y = _mm256_add_epi32(y, _mm256_mullo_epi32(z, x));
    z = _mm256_add_epi32(z, _mm256_mullo_epi32(x, y));
    let h = [x, y, z];
    // point = offset + hash × randomness.
    core::array::from_fn(|k| {
        let unit = _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_and_si256(h[k], mask)), to_unit);
        _mm256_add_ps(_mm256_cvtepi32_ps(off[k]), _mm256_mul_ps(unit, r))
    })
}

/// The distances of eight feature points `p` to `local` in `metric` (diff = point − local
/// per axis, as `Vec3` subtracts).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn cell_distances(p: &[__m256; 3], local: [f32; 3], metric: LaneMetric) -> __m256 {
    let sign = _mm256_set1_ps(-0.0);
    let e: [__m256; 3] = core::array::from_fn(|k| _mm256_sub_ps(p[k], _mm256_set1_ps(local[k])));
    match metric {
        LaneMetric::EuclideanSquared | LaneMetric::Euclidean => {
            let sq = |v: __m256| _mm256_mul_ps(v, v);
            let s = _mm256_add_ps(_mm256_add_ps(sq(e[0]), sq(e[1])), sq(e[2]));
            if metric == LaneMetric::Euclidean { _mm256_sqrt_ps(s) } else { s }
        }
        LaneMetric::Manhattan => {
            let a: [__m256; 3] = core::array::from_fn(|k| _mm256_andnot_ps(sign, e[k]));
            _mm256_add_ps(_mm256_add_ps(a[0], a[1]), a[2])
        }
        LaneMetric::Chebychev => {
            let a: [__m256; 3] = core::array::from_fn(|k| _mm256_andnot_ps(sign, e[k]));
            _mm256_max_ps(_mm256_max_ps(a[0], a[1]), a[2])
        }
    }
}

/// Stores group `g`'s points and distances into lanes `8g..8g + 8` of `out`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn store_group(out: &mut Cells27, g: usize, p: &[__m256; 3], d: __m256) {
    // SAFETY (stores): each output row has 32 f32, lanes 8g..8g+8 are within it.
    unsafe {
        _mm256_storeu_ps(out.x[8 * g..].as_mut_ptr(), p[0]);
        _mm256_storeu_ps(out.y[8 * g..].as_mut_ptr(), p[1]);
        _mm256_storeu_ps(out.z[8 * g..].as_mut_ptr(), p[2]);
        _mm256_storeu_ps(out.d[8 * g..].as_mut_ptr(), d);
    }
}

/// The first of the 27 cells (scan order) at the smallest distance `d[..27]`, as F1's scan
/// with strict `<` from `f32::MAX` picks it: the minimum by a tree of `min`s, then the lowest
/// lane equal to it. `None` when no distance is below `f32::MAX` (the scan keeps its zeros).
/// The distances must not be NaN (the kernel's are not: its inputs are finite), so `min` is
/// the exact minimum whatever its order and `==` finds the scan's cell.
///
/// # Safety
/// The CPU must support AVX2 (`has_avx2`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn first_min_27(d: &[f32; 32]) -> Option<usize> {
    // SAFETY (loads): d has 32 f32, four vectors of eight.
    let v: [__m256; 4] = core::array::from_fn(|g| unsafe { _mm256_loadu_ps(d[8 * g..].as_ptr()) });
    // Lanes 27 to 31 (the last vector's 3 to 7) are not cells of the neighbourhood.
    let pad = _mm256_castsi256_ps(_mm256_setr_epi32(0, 0, 0, -1, -1, -1, -1, -1));
    let last = _mm256_blendv_ps(v[3], _mm256_set1_ps(f32::INFINITY), pad);
    let m = _mm256_min_ps(_mm256_min_ps(v[0], v[1]), _mm256_min_ps(v[2], last));
    let m = _mm256_min_ps(m, _mm256_permute2f128_ps::<1>(m, m));
    let m = _mm256_min_ps(m, _mm256_shuffle_ps::<0b01_00_11_10>(m, m));
    let m = _mm256_min_ps(m, _mm256_shuffle_ps::<0b10_11_00_01>(m, m));
    if _mm256_cvtss_f32(m) >= f32::MAX {
        return None;
    }
    let eq = |x: __m256| _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(x, m)) as u32;
    let bits = eq(v[0]) | eq(v[1]) << 8 | eq(v[2]) << 16 | eq(last) << 24;
    Some(bits.trailing_zeros() as usize)
}
