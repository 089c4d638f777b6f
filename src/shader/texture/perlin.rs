//! Cycles' Perlin noise (`svm/noise.h`): improved gradient noise in 1 to 4 dimensions, its
//! `snoise` scaling to about [-1, 1], and the `fmod(p, 100000)` precision fix.
//!
//! Written from the scalar (non-SSE) branch of noise.h; the SSE/AVX branches compute the same
//! interpolation with the same per-lane operations.

use glam::{Vec2, Vec3, Vec4};

use super::float_ops::{floor, fmod_pos};
use super::hash::{hash_uint, hash_uint2, hash_uint3, hash_uint4};
#[cfg(all(test, target_arch = "x86_64"))]
use super::simd::perlin_lattice_3d;
#[cfg(target_arch = "x86_64")]
use super::simd::{has_avx2, perlin_3d_mixed, perlin_corners_4d};

/// Perlin's quintic fade `6t^5 - 15t^4 + 10t^3`, in Cycles' operation order.
#[inline(always)]
fn fade(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// Cycles' `floorfrac`: the integer cell and the offset inside it.
#[inline(always)]
fn floorfrac(x: f32) -> (i32, f32) {
    let f = floor(x);
    (f as i32, x - f)
}

#[inline(always)]
fn negate_if(v: f32, condition: u32) -> f32 {
    if condition != 0 { -v } else { v }
}

/// Cycles' `mix`: `a + t (b - a)`.
#[inline(always)]
pub(super) fn mix(a: f32, b: f32, t: f32) -> f32 {
    a + t * (b - a)
}

#[inline(always)]
fn grad1(hash: u32, x: f32) -> f32 {
    let h = hash & 15;
    let g = (1 + (h & 7)) as f32;
    negate_if(g, h & 8) * x
}

#[inline(always)]
fn grad2(hash: u32, x: f32, y: f32) -> f32 {
    let h = hash & 7;
    let u = if h < 4 { x } else { y };
    let v = 2.0 * if h < 4 { y } else { x };
    negate_if(u, h & 1) + negate_if(v, h & 2)
}

#[inline(always)]
fn grad3(hash: u32, x: f32, y: f32, z: f32) -> f32 {
    let h = hash & 15;
    let u = if h < 8 { x } else { y };
    let vt = if h == 12 || h == 14 { x } else { z };
    let v = if h < 4 { y } else { vt };
    negate_if(u, h & 1) + negate_if(v, h & 2)
}

#[inline(always)]
fn grad4(hash: u32, x: f32, y: f32, z: f32, w: f32) -> f32 {
    let h = hash & 31;
    let u = if h < 24 { x } else { y };
    let v = if h < 16 { y } else { z };
    let s = if h < 8 { z } else { w };
    negate_if(u, h & 1) + negate_if(v, h & 2) + negate_if(s, h & 4)
}

#[inline(always)]
fn bi_mix(v0: f32, v1: f32, v2: f32, v3: f32, x: f32, y: f32) -> f32 {
    let x1 = 1.0 - x;
    (1.0 - y) * (v0 * x1 + v1 * x) + y * (v2 * x1 + v3 * x)
}

#[inline(always)]
fn tri_mix(v: [f32; 8], x: f32, y: f32, z: f32) -> f32 {
    let x1 = 1.0 - x;
    let y1 = 1.0 - y;
    let z1 = 1.0 - z;
    z1 * (y1 * (v[0] * x1 + v[1] * x) + y * (v[2] * x1 + v[3] * x))
        + z * (y1 * (v[4] * x1 + v[5] * x) + y * (v[6] * x1 + v[7] * x))
}

/// Lattice corner `i` of a cell as an integer offset (bit k of `i` is axis k).
#[inline(always)]
fn bit(i: usize, k: usize) -> i32 {
    ((i >> k) & 1) as i32
}

/// Unscaled 1-D Perlin noise.
#[inline]
pub fn perlin_1d(x: f32) -> f32 {
    let (ix, fx) = floorfrac(x);
    let u = fade(fx);
    mix(grad1(hash_uint(ix as u32), fx), grad1(hash_uint(ix.wrapping_add(1) as u32), fx - 1.0), u)
}

/// Unscaled 2-D Perlin noise.
#[inline]
pub fn perlin_2d(x: f32, y: f32) -> f32 {
    let (ix, fx) = floorfrac(x);
    let (iy, fy) = floorfrac(y);
    let g = |i: usize| {
        let (dx, dy) = (bit(i, 0), bit(i, 1));
        grad2(hash_uint2(ix.wrapping_add(dx) as u32, iy.wrapping_add(dy) as u32), fx - dx as f32, fy - dy as f32)
    };
    bi_mix(g(0), g(1), g(2), g(3), fade(fx), fade(fy))
}

/// The eight corner gradients of 3-D cell `i` at offset `f`, one corner after the other.
#[inline(always)]
fn corners_3d(i: [i32; 3], f: [f32; 3]) -> [f32; 8] {
    core::array::from_fn(|c| {
        let d: [i32; 3] = core::array::from_fn(|k| bit(c, k));
        let key: [u32; 3] = core::array::from_fn(|k| i[k].wrapping_add(d[k]) as u32);
        grad3(hash_uint3(key[0], key[1], key[2]), f[0] - d[0] as f32, f[1] - d[1] as f32, f[2] - d[2] as f32)
    })
}

/// The sixteen corner gradients of 4-D cell `i` at offset `f`, one corner after the other.
#[inline(always)]
fn corners_4d(i: [i32; 4], f: [f32; 4]) -> [f32; 16] {
    core::array::from_fn(|c| {
        let d: [i32; 4] = core::array::from_fn(|k| bit(c, k));
        let key: [u32; 4] = core::array::from_fn(|k| i[k].wrapping_add(d[k]) as u32);
        let x: [f32; 4] = core::array::from_fn(|k| f[k] - d[k] as f32);
        grad4(hash_uint4(key[0], key[1], key[2], key[3]), x[0], x[1], x[2], x[3])
    })
}

/// Unscaled 3-D Perlin noise.
#[inline]
pub fn perlin_3d(x: f32, y: f32, z: f32) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() && x.abs() < LATTICE_KERNEL_LIMIT && y.abs() < LATTICE_KERNEL_LIMIT && z.abs() < LATTICE_KERNEL_LIMIT
    {
        // SAFETY: the CPU has AVX2 and the coordinates are below 2^23. Floors, fades, the
        // eight corners and their mix in vectors, bit for bit the code below (callgrind: a
        // lookup cost 369 instructions with it, 285 with only the corners in a vector, ~200
        // with the floors and fades too, ~180 with the mix).
        return unsafe { perlin_3d_mixed([x, y, z]) };
    }
    let (ix, fx) = floorfrac(x);
    let (iy, fy) = floorfrac(y);
    let (iz, fz) = floorfrac(z);
    tri_mix(corners_3d([ix, iy, iz], [fx, fy, fz]), fade(fx), fade(fy), fade(fz))
}

/// Below this magnitude (2^23) a coordinate's floor fits an i32 and the vector floor equals
/// `float_ops::floor`; NaN fails the test too. After the `fmod` fix every finite one passes.
#[cfg(target_arch = "x86_64")]
pub(super) const LATTICE_KERNEL_LIMIT: f32 = 8_388_608.0;

/// Unscaled 4-D Perlin noise.
#[inline]
pub fn perlin_4d(x: f32, y: f32, z: f32, w: f32) -> f32 {
    let (ix, fx) = floorfrac(x);
    let (iy, fy) = floorfrac(y);
    let (iz, fz) = floorfrac(z);
    let (iw, fw) = floorfrac(w);
    let (i, f) = ([ix, iy, iz, iw], [fx, fy, fz, fw]);
    #[cfg(target_arch = "x86_64")]
    let v = if has_avx2() {
        // SAFETY: the CPU has AVX2. Sixteen corners in two vectors, bit for bit `corners_4d`.
        unsafe { perlin_corners_4d(i, f) }
    } else {
        corners_4d(i, f)
    };
    #[cfg(not(target_arch = "x86_64"))]
    let v = corners_4d(i, f);
    let (u, t, s, r) = (fade(fx), fade(fy), fade(fz), fade(fw));
    let lo = tri_mix([v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]], u, t, s);
    let hi = tri_mix([v[8], v[9], v[10], v[11], v[12], v[13], v[14], v[15]], u, t, s);
    mix(lo, hi, r)
}

/// Period of Cycles' precision fix: coordinates are taken `fmod 100000` on each axis before
/// the lattice lookup, so large coordinates keep their fractional precision (at the price of a
/// seam every 100000 units, as in Blender).
pub(super) const REPEAT: f32 = 100000.0;

/// A coordinate of 1 to 4 dimensions that signed Perlin noise is defined on; the fractal
/// functions and the Noise texture are generic over it.
pub trait NoiseCoord: Copy + core::ops::Add<Output = Self> + core::ops::Mul<f32, Output = Self> {
    /// Cycles' `snoise_Nd`: Perlin noise scaled to about [-1, 1], after the precision fix.
    fn snoise(self) -> f32;
}

impl NoiseCoord for f32 {
    #[inline]
    fn snoise(self) -> f32 {
        0.2500 * perlin_1d(fmod_pos(self, REPEAT))
    }
}

impl NoiseCoord for Vec2 {
    #[inline]
    fn snoise(self) -> f32 {
        0.6616 * perlin_2d(fmod_pos(self.x, REPEAT), fmod_pos(self.y, REPEAT))
    }
}

impl NoiseCoord for Vec3 {
    #[inline]
    fn snoise(self) -> f32 {
        0.9820 * perlin_3d(fmod_pos(self.x, REPEAT), fmod_pos(self.y, REPEAT), fmod_pos(self.z, REPEAT))
    }
}

impl NoiseCoord for Vec4 {
    #[inline]
    fn snoise(self) -> f32 {
        0.8344
            * perlin_4d(
                fmod_pos(self.x, REPEAT),
                fmod_pos(self.y, REPEAT),
                fmod_pos(self.z, REPEAT),
                fmod_pos(self.w, REPEAT),
            )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Gradient noise vanishes on every lattice point, negative ones included (the `floor` of
    /// an exact negative integer is itself).
    #[test]
    fn noise_vanishes_on_the_lattice() {
        for i in -3..=3 {
            let x = i as f32;
            assert_eq!(perlin_1d(x), 0.0);
            assert_eq!(perlin_2d(x, -x), 0.0);
            assert_eq!(perlin_3d(x, 2.0, -x), 0.0);
            assert_eq!(perlin_4d(x, 1.0, -x, 5.0), 0.0);
        }
    }

    /// The noise is continuous across cell faces: values just either side of x = -1 agree to
    /// the size of the step times the largest gradient (|g| <= 8 in 1-D, a few in N-D).
    #[test]
    fn noise_is_continuous_across_cells() {
        let e = 1e-4;
        for &(y, z, w) in &[(0.3, 0.7, 0.1), (-1.6, 2.2, -0.4)] {
            let a = perlin_4d(-1.0 - e, y, z, w);
            let b = perlin_4d(-1.0 + e, y, z, w);
            assert!((a - b).abs() < 8.0 * 2.0 * e, "{a} {b}");
            let a = perlin_3d(y, -1.0 - e, z);
            let b = perlin_3d(y, -1.0 + e, z);
            assert!((a - b).abs() < 8.0 * 2.0 * e, "{a} {b}");
        }
    }
    /// The AVX2 corner kernels give the scalar corners bit for bit, over cells of both signs,
    /// at the i32 extremes (wrapping keys) and for offsets in and beyond [0, 1).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_corners_are_the_scalar_corners() {
        if !crate::shader::texture::simd::has_avx2() {
            eprintln!("no AVX2 on this CPU: only the scalar corners run here");
            return;
        }
        let mut state = 0x9e37_79b9u32;
        let mut next = || {
            state = state.wrapping_mul(1664525).wrapping_add(1013904223);
            state
        };
        for k in 0..50_000 {
            let i: [i32; 4] = core::array::from_fn(|_| match k % 3 {
                0 => (next() >> 16) as i32 - 32768,
                1 => next() as i32,
                _ => [i32::MIN, i32::MAX, -1, 0][(next() % 4) as usize],
            });
            let f: [f32; 4] = core::array::from_fn(|_| (next() >> 8) as f32 / (1u32 << 24) as f32 * 3.0 - 1.0);
            // SAFETY: AVX2 was found above.
            let a4 = unsafe { perlin_corners_4d(i, f) };
            assert_eq!(a4.map(f32::to_bits), corners_4d(i, f).map(f32::to_bits), "{i:?} {f:?}");
        }
    }
    /// The AVX2 3-D lattice kernel gives the scalar cell, corners and fades bit for bit (and
    /// its mixed form the scalar noise), for
    /// coordinates of both signs up to the precision fix's 100000, lattice points and signed
    /// zeros included.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_lattice_is_the_scalar_lattice() {
        if !crate::shader::texture::simd::has_avx2() {
            eprintln!("no AVX2 on this CPU: only the scalar lattice runs here");
            return;
        }
        let mut state = 0x1234_5678u32;
        let mut next = || {
            state = state.wrapping_mul(1664525).wrapping_add(1013904223);
            (state >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
        };
        for k in 0..50_000 {
            let range = [1.0, 20.0, 99_999.0, 8_000_000.0][k % 4];
            let mut p: [f32; 3] = core::array::from_fn(|_| next() * range);
            if k % 7 == 0 {
                p = p.map(f32::round);
            }
            if k % 11 == 0 {
                p[k % 3] = if k % 2 == 0 { 0.0 } else { -0.0 };
            }
            let (ix, fx) = floorfrac(p[0]);
            let (iy, fy) = floorfrac(p[1]);
            let (iz, fz) = floorfrac(p[2]);
            let scalar = (corners_3d([ix, iy, iz], [fx, fy, fz]), [fade(fx), fade(fy), fade(fz)]);
            // SAFETY: AVX2 was found above; |p| < 2^23.
            let (v, f) = unsafe { perlin_lattice_3d(p) };
            assert_eq!(
                (v.map(f32::to_bits), f.map(f32::to_bits)),
                (scalar.0.map(f32::to_bits), scalar.1.map(f32::to_bits)),
                "{p:?}"
            );
            let [u, t, s] = scalar.1;
            // SAFETY: as above.
            let mixed = unsafe { perlin_3d_mixed(p) };
            assert_eq!(mixed.to_bits(), tri_mix(scalar.0, u, t, s).to_bits(), "{p:?}");
        }
    }
}
