//! Cycles' fractal sums of Perlin noise (`svm/fractal_noise.h`): fBM, multifractal, hybrid
//! multifractal, ridged multifractal and heterogeneous terrain, generic over the dimension.
//!
//! `detail` is the number of octaves after the first (Cycles clamps it to [0, 15] before);
//! a fractional part adds a last octave weighted by it. Operation order follows Cycles.

use super::perlin::{NoiseCoord, mix};

/// Cycles' `float_to_int`: truncation (detail is never negative here).
#[inline(always)]
fn octaves(detail: f32) -> i32 {
    detail as i32
}

/// Fractal Brownian motion; with `normalize` the sum is mapped to about [0, 1].
#[inline]
pub fn fbm<T: NoiseCoord>(p: T, detail: f32, roughness: f32, lacunarity: f32, normalize: bool) -> f32 {
    let mut fscale = 1.0f32;
    let mut amp = 1.0f32;
    let mut maxamp = 0.0f32;
    let mut sum = 0.0f32;
    for _ in 0..=octaves(detail) {
        let t = (p * fscale).snoise();
        sum += t * amp;
        maxamp += amp;
        amp *= roughness;
        fscale *= lacunarity;
    }
    let rmd = detail - detail.floor();
    if rmd != 0.0 {
        let t = (p * fscale).snoise();
        let sum2 = sum + t * amp;
        if normalize {
            mix(0.5 * sum / maxamp + 0.5, 0.5 * sum2 / (maxamp + amp) + 0.5, rmd)
        } else {
            mix(sum, sum2, rmd)
        }
    } else if normalize {
        0.5 * sum / maxamp + 0.5
    } else {
        sum
    }
}

/// Musgrave's multifractal: a product of octaves.
#[inline]
pub fn multi_fractal<T: NoiseCoord>(mut p: T, detail: f32, roughness: f32, lacunarity: f32) -> f32 {
    let mut value = 1.0f32;
    let mut pwr = 1.0f32;
    for _ in 0..=octaves(detail) {
        value *= pwr * p.snoise() + 1.0;
        pwr *= roughness;
        p = p * lacunarity;
    }
    let rmd = detail - detail.floor();
    if rmd != 0.0 {
        value *= rmd * pwr * p.snoise() + 1.0;
    }
    value
}

/// Musgrave's heterogeneous terrain: octaves scaled by the value so far.
#[inline]
pub fn hetero_terrain<T: NoiseCoord>(mut p: T, detail: f32, roughness: f32, lacunarity: f32, offset: f32) -> f32 {
    let mut pwr = roughness;
    // The first octave is unscaled; later octaves are scaled by the value so far.
    let mut value = offset + p.snoise();
    p = p * lacunarity;
    for _ in 1..=octaves(detail) {
        let increment = (p.snoise() + offset) * pwr * value;
        value += increment;
        pwr *= roughness;
        p = p * lacunarity;
    }
    let rmd = detail - detail.floor();
    if rmd != 0.0 {
        let increment = (p.snoise() + offset) * pwr * value;
        value += rmd * increment;
    }
    value
}

/// Musgrave's hybrid additive/multiplicative multifractal.
#[inline]
pub fn hybrid_multi_fractal<T: NoiseCoord>(
    mut p: T,
    detail: f32,
    roughness: f32,
    lacunarity: f32,
    offset: f32,
    gain: f32,
) -> f32 {
    let mut pwr = 1.0f32;
    let mut value = 0.0f32;
    let mut weight = 1.0f32;
    let mut i = 0;
    while weight > 0.001 && i <= octaves(detail) {
        if weight > 1.0 {
            weight = 1.0;
        }
        let signal = (p.snoise() + offset) * pwr;
        pwr *= roughness;
        value += weight * signal;
        weight *= gain * signal;
        p = p * lacunarity;
        i += 1;
    }
    let rmd = detail - detail.floor();
    if rmd != 0.0 && weight > 0.001 {
        if weight > 1.0 {
            weight = 1.0;
        }
        let signal = (p.snoise() + offset) * pwr;
        value += rmd * weight * signal;
    }
    value
}

/// Musgrave's ridged multifractal (Cycles ignores the fractional part of `detail` here).
#[inline]
pub fn ridged_multi_fractal<T: NoiseCoord>(
    mut p: T,
    detail: f32,
    roughness: f32,
    lacunarity: f32,
    offset: f32,
    gain: f32,
) -> f32 {
    let mut pwr = roughness;
    let mut signal = offset - p.snoise().abs();
    signal *= signal;
    let mut value = signal;
    for _ in 1..=octaves(detail) {
        p = p * lacunarity;
        let weight = (signal * gain).clamp(0.0, 1.0);
        signal = offset - p.snoise().abs();
        signal *= signal;
        signal *= weight;
        value += signal * pwr;
        pwr *= roughness;
    }
    value
}
