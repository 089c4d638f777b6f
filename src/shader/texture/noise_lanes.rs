//! The 3-D fBm Noise texture's Fac at three nearby points at once (the Bump node's centre
//! and offsets, `shader::bump_lanes`), bit for bit `noise::noise_fac` at each point.
//!
//! The three points go through the fractal sum together: the octave bookkeeping (amplitudes,
//! frequencies, the detail's remainder) is done once, and each octave's three Perlin lookups
//! share their lattice cell's corner hashes when the points fall in one cell
//! (`simd::perlin_3d_mixed_shared`), which at the Bump's 10⁻⁴ spacing is nearly always.
//! Every per-point number is computed by the same operations in the same order as
//! `noise.rs`, `fractal::fbm` and `perlin::snoise`.

use glam::Vec3;

use super::float_ops::fmod_pos;
use super::noise::{NoiseParams, offset_3d};
#[cfg(target_arch = "x86_64")]
use super::perlin::LATTICE_KERNEL_LIMIT;
use super::perlin::{REPEAT, mix, perlin_3d};
#[cfg(target_arch = "x86_64")]
use super::simd::{has_avx2, perlin_3d_mixed_shared};

/// Three points, one per lane.
type Lanes = [Vec3; 3];

/// Cycles' `snoise_3d` at each of three points (`<Vec3 as NoiseCoord>::snoise`).
#[inline]
fn snoise3(p: Lanes) -> [f32; 3] {
    let q = p.map(|p| [fmod_pos(p.x, REPEAT), fmod_pos(p.y, REPEAT), fmod_pos(p.z, REPEAT)]);
    #[cfg(target_arch = "x86_64")]
    if has_avx2() && q.iter().flatten().all(|c| c.abs() < LATTICE_KERNEL_LIMIT) {
        // SAFETY: the CPU has AVX2 and every coordinate is below 2^23.
        if let Some(v) = unsafe { perlin_3d_mixed_shared(q) } {
            return v.map(|v| 0.9820 * v);
        }
    }
    q.map(|q| 0.9820 * perlin_3d(q[0], q[1], q[2]))
}

/// `p * s` at each point.
#[inline(always)]
fn scale(p: Lanes, s: f32) -> Lanes {
    p.map(|p| p * s)
}

/// `fractal::fbm` at three points.
#[inline]
fn fbm3(p: Lanes, detail: f32, roughness: f32, lacunarity: f32, normalize: bool) -> [f32; 3] {
    let mut fscale = 1.0f32;
    let mut amp = 1.0f32;
    let mut maxamp = 0.0f32;
    let mut sum = [0.0f32; 3];
    for _ in 0..=(detail as i32) {
        let t = snoise3(scale(p, fscale));
        for k in 0..3 {
            sum[k] += t[k] * amp;
        }
        maxamp += amp;
        amp *= roughness;
        fscale *= lacunarity;
    }
    let rmd = detail - detail.floor();
    if rmd != 0.0 {
        let t = snoise3(scale(p, fscale));
        core::array::from_fn(|k| {
            let sum2 = sum[k] + t[k] * amp;
            if normalize {
                mix(0.5 * sum[k] / maxamp + 0.5, 0.5 * sum2 / (maxamp + amp) + 0.5, rmd)
            } else {
                mix(sum[k], sum2, rmd)
            }
        })
    } else if normalize {
        sum.map(|s| 0.5 * s / maxamp + 0.5)
    } else {
        sum
    }
}

/// The Fac of a 3-D fBm Noise texture (`prm.dims` 3, `prm.kind` fBm, Color not read) at
/// three points: `noise::noise_fac(p[k], _, prm)` for each k.
pub fn noise_fbm_3d_lanes(p: Lanes, prm: &NoiseParams) -> [f32; 3] {
    let detail = prm.detail.clamp(0.0, 15.0);
    let roughness = prm.roughness.max(0.0);
    let mut p = scale(p, prm.scale);
    if prm.distortion != 0.0 {
        // `p + p.distortion(amount)`: one lookup per axis at the seeded offsets.
        let d: [[f32; 3]; 3] =
            core::array::from_fn(|axis| snoise3(p.map(|q| q + offset_3d(axis as f32))).map(|v| v * prm.distortion));
        p = core::array::from_fn(|k| p[k] + Vec3::new(d[0][k], d[1][k], d[2][k]));
    }
    fbm3(p, detail, roughness, prm.lacunarity, prm.normalize)
}

#[cfg(test)]
mod tests {
    use super::super::noise::{NoiseKind, noise_fac};
    use super::*;

    /// Each lane is the scalar node bit for bit: points 10⁻⁴ apart (one cell, the shared
    /// kernel), points across cell faces and far apart (one lookup at a time), signed
    /// zeros, coordinates beyond the `fmod` period, and every setting the lanes read.
    #[test]
    fn lanes_are_the_scalar_noise() {
        let mut state = 0x2545_f491u32;
        let mut next = || {
            state = state.wrapping_mul(1664525).wrapping_add(1013904223);
            (state >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
        };
        let mut shared = 0;
        for k in 0..20_000 {
            let range = [1.0, 30.0, 2000.0, 150_000.0][k % 4];
            let c = Vec3::new(next(), next(), next()) * range;
            let eps = [1e-4, 0.3, 5.0][k % 3] * c.abs().max_element().max(1.0);
            let mut p = [c, c + Vec3::X * eps, c + Vec3::new(0.0, eps, -eps)];
            if k % 13 == 0 {
                p[0] = Vec3::new(-0.0, 0.0, c.z.round());
            }
            let prm = NoiseParams {
                dims: 3,
                kind: NoiseKind::Fbm,
                normalize: k % 2 == 0,
                scale: [5.0, 0.7, 1.0][k % 3],
                detail: [4.0, 0.0, 2.5, 15.0, 16.0][k % 5],
                roughness: [0.5, 0.0, 0.9][k % 3],
                lacunarity: [2.0, 1.7][k % 2],
                offset: 0.0,
                gain: 1.0,
                distortion: [0.2, 0.0, -1.5][k % 3],
            };
            let lanes = noise_fbm_3d_lanes(p, &prm);
            for (l, q) in lanes.iter().zip(p) {
                assert_eq!(l.to_bits(), noise_fac(q, 0.0, &prm).to_bits(), "{q:?} {prm:?}");
            }
            let q = p.map(|p| [p.x, p.y, p.z].map(|c| fmod_pos(c, REPEAT)));
            shared += q.iter().all(|l| l.map(f32::floor) == q[0].map(f32::floor)) as u32;
        }
        // Both paths ran (the shared cell and one lookup at a time).
        assert!(shared > 1000 && shared < 19_000, "{shared}");
    }
}
