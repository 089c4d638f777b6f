//! Blender's Noise Texture node (`svm/noisetex.h`): fractal Perlin noise in 1 to 4
//! dimensions with optional domain distortion, and a colour made of two more noise
//! evaluations at seeded offsets.
//!
//! Inputs as the node receives them: `detail` is clamped to [0, 15] and `roughness` to >= 0
//! here, as Cycles does; `normalize` only affects fBM (as in Blender). 1-D noise reads only
//! `w`, 2-D only `p.xy`, 3-D only `p`, 4-D `(p, w)`.

use glam::{Vec2, Vec3, Vec4};

use super::fractal::{fbm, hetero_terrain, hybrid_multi_fractal, multi_fractal, ridged_multi_fractal};
use super::hash::{hash_float_to_float, hash_vector2_to_float};
use super::perlin::NoiseCoord;

/// The node's "Type" setting.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoiseKind {
    Multifractal,
    RidgedMultifractal,
    HybridMultifractal,
    Fbm,
    HeteroTerrain,
}

/// The Noise node's settings and non-vector inputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseParams {
    /// 1..=4 (anything else is treated as 3, Blender's default).
    pub dims: u8,
    /// The fractal: the node's "Type".
    pub kind: NoiseKind,
    /// Map fBM to about [0, 1] (the node's "Normalize"; other kinds ignore it).
    pub normalize: bool,
    /// Multiplies the vector and W before anything else.
    pub scale: f32,
    /// Octaves after the first, [0, 15]; a fraction blends in one more.
    pub detail: f32,
    /// Amplitude ratio between octaves (>= 0).
    pub roughness: f32,
    /// Frequency ratio between octaves.
    pub lacunarity: f32,
    /// Musgrave's offset (hybrid, ridged, hetero terrain).
    pub offset: f32,
    /// Musgrave's gain (hybrid, ridged).
    pub gain: f32,
    /// Strength of the noise-driven domain distortion (0: none).
    pub distortion: f32,
}

/// Cycles' `random_floatN_offset(seed)` component `k`: an offset in [100, 200] that seeds the
/// distortion and colour channels.
#[inline(always)]
fn offset_component(seed: f32, k: f32) -> f32 {
    100.0 + hash_vector2_to_float(Vec2::new(seed, k)) * 100.0
}

/// A noise coordinate that can also build Cycles' seeded offsets and distortion.
trait Seeded: NoiseCoord {
    /// The number of components; also the first colour seed (the distortion takes 0..DIMS).
    const DIMS: f32;
    /// Cycles' `random_floatN_offset(seed)`.
    fn random_offset(seed: f32) -> Self;
    /// The distortion vector: one snoise per component, each at its own seeded offset.
    fn distortion(self, amount: f32) -> Self;
}

impl Seeded for f32 {
    const DIMS: f32 = 1.0;
    #[inline(always)]
    fn random_offset(seed: f32) -> Self {
        100.0 + hash_float_to_float(seed) * 100.0
    }
    #[inline(always)]
    fn distortion(self, amount: f32) -> Self {
        (self + Self::random_offset(0.0)).snoise() * amount
    }
}

impl Seeded for Vec2 {
    const DIMS: f32 = 2.0;
    #[inline(always)]
    fn random_offset(seed: f32) -> Self {
        Vec2::new(offset_component(seed, 0.0), offset_component(seed, 1.0))
    }
    #[inline(always)]
    fn distortion(self, amount: f32) -> Self {
        Vec2::new(
            (self + Self::random_offset(0.0)).snoise() * amount,
            (self + Self::random_offset(1.0)).snoise() * amount,
        )
    }
}

impl Seeded for Vec3 {
    const DIMS: f32 = 3.0;
    #[inline(always)]
    fn random_offset(seed: f32) -> Self {
        Vec3::new(offset_component(seed, 0.0), offset_component(seed, 1.0), offset_component(seed, 2.0))
    }
    #[inline(always)]
    fn distortion(self, amount: f32) -> Self {
        Vec3::new(
            (self + Self::random_offset(0.0)).snoise() * amount,
            (self + Self::random_offset(1.0)).snoise() * amount,
            (self + Self::random_offset(2.0)).snoise() * amount,
        )
    }
}

impl Seeded for Vec4 {
    const DIMS: f32 = 4.0;
    #[inline(always)]
    fn random_offset(seed: f32) -> Self {
        Vec4::new(
            offset_component(seed, 0.0),
            offset_component(seed, 1.0),
            offset_component(seed, 2.0),
            offset_component(seed, 3.0),
        )
    }
    #[inline(always)]
    fn distortion(self, amount: f32) -> Self {
        Vec4::new(
            (self + Self::random_offset(0.0)).snoise() * amount,
            (self + Self::random_offset(1.0)).snoise() * amount,
            (self + Self::random_offset(2.0)).snoise() * amount,
            (self + Self::random_offset(3.0)).snoise() * amount,
        )
    }
}

/// Cycles' `noise_select`: the fractal of the node's type.
#[inline]
fn select<T: NoiseCoord>(p: T, prm: &NoiseParams, detail: f32, roughness: f32) -> f32 {
    match prm.kind {
        NoiseKind::Multifractal => multi_fractal(p, detail, roughness, prm.lacunarity),
        NoiseKind::Fbm => fbm(p, detail, roughness, prm.lacunarity, prm.normalize),
        NoiseKind::HybridMultifractal => {
            hybrid_multi_fractal(p, detail, roughness, prm.lacunarity, prm.offset, prm.gain)
        }
        NoiseKind::RidgedMultifractal => {
            ridged_multi_fractal(p, detail, roughness, prm.lacunarity, prm.offset, prm.gain)
        }
        NoiseKind::HeteroTerrain => hetero_terrain(p, detail, roughness, prm.lacunarity, prm.offset),
    }
}

/// Cycles' `noise_texture_Nd`. The colour seeds follow the distortion seeds: 1-D distorts with
/// seed 0 and colours with 1, 2; N-D distorts with seeds 0..N and colours with N, N + 1
/// (so the first colour seed is always the dimension). Without `COLOR` the two colour
/// fractals (two thirds of the node's cost without distortion) are skipped and the colour is 0.
#[inline]
fn texture<T: Seeded, const COLOR: bool>(co: T, prm: &NoiseParams, detail: f32, roughness: f32) -> (f32, Vec3) {
    let mut p = co;
    if prm.distortion != 0.0 {
        p = p + p.distortion(prm.distortion);
    }
    let first = T::DIMS;
    let value = select(p, prm, detail, roughness);
    if !COLOR {
        return (value, Vec3::ZERO);
    }
    let g = select(p + T::random_offset(first), prm, detail, roughness);
    let b = select(p + T::random_offset(first + 1.0), prm, detail, roughness);
    (value, Vec3::new(value, g, b))
}

/// The node at `p` (and `w` for 1-D and 4-D), with or without its colour.
#[inline]
fn node<const COLOR: bool>(p: Vec3, w: f32, prm: &NoiseParams) -> (f32, Vec3) {
    let detail = prm.detail.clamp(0.0, 15.0);
    let roughness = prm.roughness.max(0.0);
    let p = p * prm.scale;
    let w = w * prm.scale;
    match prm.dims {
        1 => texture::<f32, COLOR>(w, prm, detail, roughness),
        2 => texture::<Vec2, COLOR>(Vec2::new(p.x, p.y), prm, detail, roughness),
        4 => texture::<Vec4, COLOR>(p.extend(w), prm, detail, roughness),
        _ => texture::<Vec3, COLOR>(p, prm, detail, roughness),
    }
}

/// The 3-D Noise's random offset for seed `seed` (its distortion and colour channels).
#[inline(always)]
pub(super) fn offset_3d(seed: f32) -> Vec3 {
    <Vec3 as Seeded>::random_offset(seed)
}

/// (Fac, Color) of the Noise Texture node at `p` (and `w` for 1-D and 4-D).
pub fn noise_texture(p: Vec3, w: f32, prm: &NoiseParams) -> (f32, Vec3) {
    node::<true>(p, w, prm)
}

/// Fac alone of the Noise Texture node (the same number as `noise_texture`'s), for a node
/// whose Color output is not linked.
pub fn noise_fac(p: Vec3, w: f32, prm: &NoiseParams) -> f32 {
    node::<false>(p, w, prm).0
}
