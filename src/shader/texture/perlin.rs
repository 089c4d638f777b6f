//! Cycles' Perlin noise (`svm/noise.h`): improved gradient noise in 1 to 4 dimensions, its
//! `snoise` scaling to about [-1, 1], and the `fmod(p, 100000)` precision fix.
//!
//! Written from the scalar (non-SSE) branch of noise.h; the SSE/AVX branches compute the same
//! interpolation with the same per-lane operations.

use glam::{Vec2, Vec3, Vec4};

use super::float_ops::{floor, fmod_pos};
use super::hash::{hash_uint, hash_uint2, hash_uint3, hash_uint4};

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

/// Unscaled 3-D Perlin noise.
#[inline]
pub fn perlin_3d(x: f32, y: f32, z: f32) -> f32 {
    let (ix, fx) = floorfrac(x);
    let (iy, fy) = floorfrac(y);
    let (iz, fz) = floorfrac(z);
    let mut v = [0.0; 8];
    for (i, vi) in v.iter_mut().enumerate() {
        let (dx, dy, dz) = (bit(i, 0), bit(i, 1), bit(i, 2));
        *vi = grad3(
            hash_uint3(ix.wrapping_add(dx) as u32, iy.wrapping_add(dy) as u32, iz.wrapping_add(dz) as u32),
            fx - dx as f32,
            fy - dy as f32,
            fz - dz as f32,
        );
    }
    tri_mix(v, fade(fx), fade(fy), fade(fz))
}

/// Unscaled 4-D Perlin noise.
#[inline]
pub fn perlin_4d(x: f32, y: f32, z: f32, w: f32) -> f32 {
    let (ix, fx) = floorfrac(x);
    let (iy, fy) = floorfrac(y);
    let (iz, fz) = floorfrac(z);
    let (iw, fw) = floorfrac(w);
    let mut v = [0.0; 16];
    for (i, vi) in v.iter_mut().enumerate() {
        let (dx, dy, dz, dw) = (bit(i, 0), bit(i, 1), bit(i, 2), bit(i, 3));
        *vi = grad4(
            hash_uint4(
                ix.wrapping_add(dx) as u32,
                iy.wrapping_add(dy) as u32,
                iz.wrapping_add(dz) as u32,
                iw.wrapping_add(dw) as u32,
            ),
            fx - dx as f32,
            fy - dy as f32,
            fz - dz as f32,
            fw - dw as f32,
        );
    }
    let (u, t, s, r) = (fade(fx), fade(fy), fade(fz), fade(fw));
    let lo = tri_mix([v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]], u, t, s);
    let hi = tri_mix([v[8], v[9], v[10], v[11], v[12], v[13], v[14], v[15]], u, t, s);
    mix(lo, hi, r)
}

/// Period of Cycles' precision fix: coordinates are taken `fmod 100000` on each axis before
/// the lattice lookup, so large coordinates keep their fractional precision (at the price of a
/// seam every 100000 units, as in Blender).
const REPEAT: f32 = 100000.0;

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
}
