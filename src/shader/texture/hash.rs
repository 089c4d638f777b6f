//! Cycles' hashes (`intern/cycles/util/hash.h`): Bob Jenkins' lookup3 on 32-bit words and
//! the float wrappers the procedural textures seed themselves with.
//!
//! Voronoi cells in 2 to 4 dimensions are hashed from their integer coordinates with PCG
//! (Blender 4.3 on); everything else hashes float bit patterns with lookup3.
//!
//! Every function is bit-exact with Cycles: floats are hashed by their bit pattern, and the
//! `[0, 1]` mapping multiplies by `1 / 2^32` (Cycles divides by `(float)0xFFFFFFFF`, which
//! rounds to `2^32`), so a hash of `0xFFFFFFFF` gives exactly 1.

use glam::{Vec2, Vec3, Vec4};

/// The lookup3 `final` mix of three words.
#[inline(always)]
fn finalize(mut a: u32, mut b: u32, mut c: u32) -> u32 {
    c ^= b;
    c = c.wrapping_sub(b.rotate_left(14));
    a ^= c;
    a = a.wrapping_sub(c.rotate_left(11));
    b ^= a;
    b = b.wrapping_sub(a.rotate_left(25));
    c ^= b;
    c = c.wrapping_sub(b.rotate_left(16));
    a ^= c;
    a = a.wrapping_sub(c.rotate_left(4));
    b ^= a;
    b = b.wrapping_sub(a.rotate_left(14));
    c ^= b;
    c.wrapping_sub(b.rotate_left(24))
}

/// The lookup3 `mix` of three words (used by the four-word hash).
#[inline(always)]
fn mix(a: &mut u32, b: &mut u32, c: &mut u32) {
    *a = a.wrapping_sub(*c);
    *a ^= c.rotate_left(4);
    *c = c.wrapping_add(*b);
    *b = b.wrapping_sub(*a);
    *b ^= a.rotate_left(6);
    *a = a.wrapping_add(*c);
    *c = c.wrapping_sub(*b);
    *c ^= b.rotate_left(8);
    *b = b.wrapping_add(*a);
    *a = a.wrapping_sub(*c);
    *a ^= c.rotate_left(16);
    *c = c.wrapping_add(*b);
    *b = b.wrapping_sub(*a);
    *b ^= a.rotate_left(19);
    *a = a.wrapping_add(*c);
    *c = c.wrapping_sub(*b);
    *c ^= b.rotate_left(4);
    *b = b.wrapping_add(*a);
}

/// lookup3's initial value for a key of `words` 32-bit words.
#[inline(always)]
const fn seed(words: u32) -> u32 {
    0xdeadbeef_u32.wrapping_add(words << 2).wrapping_add(13)
}

/// Cycles' `hash_uint`.
#[inline(always)]
pub fn hash_uint(kx: u32) -> u32 {
    let s = seed(1);
    finalize(s.wrapping_add(kx), s, s)
}

/// Cycles' `hash_uint2`.
#[inline(always)]
pub fn hash_uint2(kx: u32, ky: u32) -> u32 {
    let s = seed(2);
    finalize(s.wrapping_add(kx), s.wrapping_add(ky), s)
}

/// Cycles' `hash_uint3`.
#[inline(always)]
pub fn hash_uint3(kx: u32, ky: u32, kz: u32) -> u32 {
    let s = seed(3);
    finalize(s.wrapping_add(kx), s.wrapping_add(ky), s.wrapping_add(kz))
}

/// Cycles' `hash_uint4`.
#[inline(always)]
pub fn hash_uint4(kx: u32, ky: u32, kz: u32, kw: u32) -> u32 {
    let s = seed(4);
    let (mut a, mut b, mut c) = (s.wrapping_add(kx), s.wrapping_add(ky), s.wrapping_add(kz));
    mix(&mut a, &mut b, &mut c);
    finalize(a.wrapping_add(kw), b, c)
}

/// Cycles' `uint_to_float_incl`: `[0, 2^32 - 1]` to `[0, 1]`.
#[inline(always)]
pub fn uint_to_float_incl(n: u32) -> f32 {
    n as f32 * (1.0 / 4294967296.0)
}

/// Cycles' `hash_float_to_float`.
#[inline]
pub fn hash_float_to_float(k: f32) -> f32 {
    uint_to_float_incl(hash_uint(k.to_bits()))
}

/// Cycles' `hash_float2_to_float`.
#[inline]
pub fn hash_vector2_to_float(k: Vec2) -> f32 {
    uint_to_float_incl(hash_uint2(k.x.to_bits(), k.y.to_bits()))
}

/// Cycles' `hash_float3_to_float`.
#[inline]
pub fn hash_vector3_to_float(k: Vec3) -> f32 {
    uint_to_float_incl(hash_uint3(k.x.to_bits(), k.y.to_bits(), k.z.to_bits()))
}

/// Cycles' `hash_float4_to_float`.
#[inline]
pub fn hash_vector4_to_float(k: Vec4) -> f32 {
    uint_to_float_incl(hash_uint4(k.x.to_bits(), k.y.to_bits(), k.z.to_bits(), k.w.to_bits()))
}

/// Cycles' `hash_float2_to_float2`.
#[inline]
pub fn hash_vector2_to_float2(k: Vec2) -> Vec2 {
    Vec2::new(hash_vector2_to_float(k), hash_vector3_to_float(Vec3::new(k.x, k.y, 1.0)))
}

/// Cycles' `hash_float3_to_float3`.
#[inline]
pub fn hash_vector3_to_float3(k: Vec3) -> Vec3 {
    Vec3::new(hash_vector3_to_float(k), hash_vector4_to_float(k.extend(1.0)), hash_vector4_to_float(k.extend(2.0)))
}

/// Cycles' `hash_float4_to_float4`.
#[inline]
pub fn hash_vector4_to_float4(k: Vec4) -> Vec4 {
    Vec4::new(
        hash_vector4_to_float(k),
        hash_vector4_to_float(Vec4::new(k.w, k.x, k.y, k.z)),
        hash_vector4_to_float(Vec4::new(k.z, k.w, k.x, k.y)),
        hash_vector4_to_float(Vec4::new(k.y, k.z, k.w, k.x)),
    )
}

/// Cycles' `hash_float_to_float3`.
#[inline]
pub fn hash_float_to_float3(k: f32) -> Vec3 {
    Vec3::new(
        hash_float_to_float(k),
        hash_vector2_to_float(Vec2::new(k, 1.0)),
        hash_vector2_to_float(Vec2::new(k, 2.0)),
    )
}

/// Cycles' `hash_float2_to_float3`.
#[inline]
pub fn hash_vector2_to_float3(k: Vec2) -> Vec3 {
    Vec3::new(
        hash_vector2_to_float(k),
        hash_vector3_to_float(Vec3::new(k.x, k.y, 1.0)),
        hash_vector3_to_float(Vec3::new(k.x, k.y, 2.0)),
    )
}

/// Cycles' `hash_float4_to_float3`.
#[inline]
pub fn hash_vector4_to_float3(k: Vec4) -> Vec3 {
    Vec3::new(
        hash_vector4_to_float(k),
        hash_vector4_to_float(Vec4::new(k.z, k.x, k.w, k.y)),
        hash_vector4_to_float(Vec4::new(k.w, k.z, k.y, k.x)),
    )
}

/// PCG's multiplier and increment (Numerical Recipes' LCG), as Cycles uses them.
const PCG_MUL: i32 = 1664525;
const PCG_INC: i32 = 1013904223;

/// Cycles' `hash_pcg2d_i`: Jarzynski and Olano's PCG2D on signed integers (so that OSL can run
/// it: wrapping arithmetic, arithmetic shift), masked to 31 bits.
#[inline(always)]
pub fn hash_pcg2d_i(k: [i32; 2]) -> [i32; 2] {
    let [mut x, mut y] = k.map(|v| v.wrapping_mul(PCG_MUL).wrapping_add(PCG_INC));
    x = x.wrapping_add(y.wrapping_mul(PCG_MUL));
    y = y.wrapping_add(x.wrapping_mul(PCG_MUL));
    x ^= x >> 16;
    y ^= y >> 16;
    x = x.wrapping_add(y.wrapping_mul(PCG_MUL));
    y = y.wrapping_add(x.wrapping_mul(PCG_MUL));
    [x & 0x7FFF_FFFF, y & 0x7FFF_FFFF]
}

/// Cycles' `hash_pcg3d_i` (see [`hash_pcg2d_i`]).
#[inline(always)]
pub fn hash_pcg3d_i(k: [i32; 3]) -> [i32; 3] {
    let [mut x, mut y, mut z] = k.map(|v| v.wrapping_mul(PCG_MUL).wrapping_add(PCG_INC));
    x = x.wrapping_add(y.wrapping_mul(z));
    y = y.wrapping_add(z.wrapping_mul(x));
    z = z.wrapping_add(x.wrapping_mul(y));
    x ^= x >> 16;
    y ^= y >> 16;
    z ^= z >> 16;
    x = x.wrapping_add(y.wrapping_mul(z));
    y = y.wrapping_add(z.wrapping_mul(x));
    z = z.wrapping_add(x.wrapping_mul(y));
    [x & 0x7FFF_FFFF, y & 0x7FFF_FFFF, z & 0x7FFF_FFFF]
}

/// Cycles' `hash_pcg4d_i` (see [`hash_pcg2d_i`]).
#[inline(always)]
pub fn hash_pcg4d_i(k: [i32; 4]) -> [i32; 4] {
    let [mut x, mut y, mut z, mut w] = k.map(|v| v.wrapping_mul(PCG_MUL).wrapping_add(PCG_INC));
    x = x.wrapping_add(y.wrapping_mul(w));
    y = y.wrapping_add(z.wrapping_mul(x));
    z = z.wrapping_add(x.wrapping_mul(y));
    w = w.wrapping_add(y.wrapping_mul(z));
    x ^= x >> 16;
    y ^= y >> 16;
    z ^= z >> 16;
    w ^= w >> 16;
    x = x.wrapping_add(y.wrapping_mul(w));
    y = y.wrapping_add(z.wrapping_mul(x));
    z = z.wrapping_add(x.wrapping_mul(y));
    w = w.wrapping_add(y.wrapping_mul(z));
    [x & 0x7FFF_FFFF, y & 0x7FFF_FFFF, z & 0x7FFF_FFFF, w & 0x7FFF_FFFF]
}

/// A 31-bit hash to [0, 1]: Cycles multiplies by `1 / (float)0x7FFFFFFF`, and that float is 2^31.
#[inline(always)]
fn int31_to_float(h: i32) -> f32 {
    h as f32 * (1.0 / 2147483648.0)
}

/// Cycles' `hash_int2_to_float2`: the feature point of a 2-D Voronoi cell.
#[inline]
pub fn hash_int2_to_float2(k: [i32; 2]) -> Vec2 {
    let [x, y] = hash_pcg2d_i(k);
    Vec2::new(int31_to_float(x), int31_to_float(y))
}

/// Cycles' `hash_int3_to_float3`.
#[inline]
pub fn hash_int3_to_float3(k: [i32; 3]) -> Vec3 {
    let [x, y, z] = hash_pcg3d_i(k);
    Vec3::new(int31_to_float(x), int31_to_float(y), int31_to_float(z))
}

/// Cycles' `hash_int4_to_float4`.
#[inline]
pub fn hash_int4_to_float4(k: [i32; 4]) -> Vec4 {
    let [x, y, z, w] = hash_pcg4d_i(k);
    Vec4::new(int31_to_float(x), int31_to_float(y), int31_to_float(z), int31_to_float(w))
}

/// Cycles' `hash_int2_to_float3`: the 3-D hash of `(k, 0)`.
#[inline]
pub fn hash_int2_to_float3(k: [i32; 2]) -> Vec3 {
    hash_int3_to_float3([k[0], k[1], 0])
}

/// Cycles' `hash_int4_to_float3`: the first three components of the 4-D hash.
#[inline]
pub fn hash_int4_to_float3(k: [i32; 4]) -> Vec3 {
    hash_int4_to_float4(k).truncate()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// lookup3's published check: `hashword` of no words with initval 0 is 0xdeadbeef; with one
    /// word the values below are what Bob Jenkins' reference `hashword(&k, 1, 0)` returns, which
    /// is exactly `hash_uint(k)` (same seed `0xdeadbeef + (1 << 2) + 0`, here + 13).
    /// We check the structure instead against values computed by hand from the C macros.
    #[test]
    fn hash_uint_matches_the_c_macros() {
        // Reference evaluation of the C `final` macro in u64 arithmetic masked to 32 bits,
        // written independently of `finalize` above.
        fn rot(x: u64, k: u32) -> u64 {
            ((x << k) | (x >> (32 - k))) & 0xffff_ffff
        }
        fn reference(kx: u32) -> u32 {
            let m = 0xffff_ffffu64;
            let init = (0xdeadbeefu64 + 4 + 13) & m;
            let (mut a, mut b, mut c) = ((init + kx as u64) & m, init, init);
            c ^= b;
            c = (c + (1 << 32) - rot(b, 14)) & m;
            a ^= c;
            a = (a + (1 << 32) - rot(c, 11)) & m;
            b ^= a;
            b = (b + (1 << 32) - rot(a, 25)) & m;
            c ^= b;
            c = (c + (1 << 32) - rot(b, 16)) & m;
            a ^= c;
            a = (a + (1 << 32) - rot(c, 4)) & m;
            b ^= a;
            b = (b + (1 << 32) - rot(a, 14)) & m;
            c ^= b;
            c = (c + (1 << 32) - rot(b, 24)) & m;
            let _ = (a, b);
            c as u32
        }
        for k in [0u32, 1, 2, 0x3f80_0000, 0xdead_beef, u32::MAX] {
            assert_eq!(hash_uint(k), reference(k), "k = {k:#x}");
        }
    }

    #[test]
    fn float_mapping_is_inclusive() {
        assert_eq!(uint_to_float_incl(0), 0.0);
        assert_eq!(uint_to_float_incl(u32::MAX), 1.0);
    }
}
