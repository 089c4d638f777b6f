//! The texture nodes' side of the program: each procedural texture node's settings and
//! input registers, evaluated by the pure functions of `texture/`.

use super::program::Reg;
use super::texture::{NoiseKind, NoiseParams, noise_texture, white_noise_texture};
use glam::Vec3;

/// A texture node compiled (boxed in `Op::Texture` to keep the op list compact).
#[derive(Clone, Debug)]
pub enum TexOp {
    /// Noise Texture: settings, then registers of Vector, W, Scale, Detail, Roughness,
    /// Lacunarity, Offset, Gain, Distortion; outputs Fac and Color.
    Noise { dims: u8, kind: NoiseKind, normalize: bool, inputs: [Reg; 9], fac: Reg, color: Reg },
    /// White Noise Texture: Vector, W; outputs Value and Color.
    WhiteNoise { dims: u8, vector: Reg, w: Reg, value: Reg, color: Reg },
}

#[inline]
fn v3(r: &[f32], i: Reg) -> Vec3 {
    let i = i as usize;
    Vec3::new(r[i], r[i + 1], r[i + 2])
}

#[inline]
fn set3(r: &mut [f32], i: Reg, v: Vec3) {
    let i = i as usize;
    r[i] = v.x;
    r[i + 1] = v.y;
    r[i + 2] = v.z;
}

impl TexOp {
    /// Evaluates the texture into its output registers.
    #[inline]
    pub fn run(&self, r: &mut [f32]) {
        match *self {
            TexOp::Noise { dims, kind, normalize, inputs: i, fac, color } => {
                let f = |k: usize| r[i[k] as usize];
                let prm = NoiseParams {
                    dims,
                    kind,
                    normalize,
                    scale: f(2),
                    detail: f(3),
                    roughness: f(4),
                    lacunarity: f(5),
                    offset: f(6),
                    gain: f(7),
                    distortion: f(8),
                };
                let (v, c) = noise_texture(v3(r, i[0]), f(1), &prm);
                r[fac as usize] = v;
                set3(r, color, c);
            }
            TexOp::WhiteNoise { dims, vector, w, value, color } => {
                let (v, c) = white_noise_texture(dims, v3(r, vector), r[w as usize]);
                r[value as usize] = v;
                set3(r, color, c);
            }
        }
    }
}

/// Blender's `noise_dimensions` identifier as a count (None: unknown).
pub fn dims(s: &str) -> Option<u8> {
    match s {
        "1D" => Some(1),
        "2D" => Some(2),
        "3D" => Some(3),
        "4D" => Some(4),
        _ => None,
    }
}

/// Blender's `noise_type` identifier.
pub fn noise_kind(s: &str) -> Option<NoiseKind> {
    Some(match s {
        "MULTIFRACTAL" => NoiseKind::Multifractal,
        "RIDGED_MULTIFRACTAL" => NoiseKind::RidgedMultifractal,
        "HYBRID_MULTIFRACTAL" => NoiseKind::HybridMultifractal,
        "FBM" => NoiseKind::Fbm,
        "HETERO_TERRAIN" => NoiseKind::HeteroTerrain,
        _ => return None,
    })
}
