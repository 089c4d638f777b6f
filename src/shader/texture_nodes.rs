//! The texture nodes' side of the program: each procedural texture node's settings and
//! input registers, evaluated by the pure functions of `texture/`.

use super::geom::{Reg, set3, v3};
use super::texture::{
    BrickParams, GaborKind, GaborParams, GradientKind, NoiseKind, NoiseParams, RadialTilingUse, VoronoiFeature,
    VoronoiMetric, VoronoiOut, VoronoiParams, WaveDirection, WaveKind, WaveParams, WaveProfile, brick_texture,
    checker_texture, gabor_texture, gradient_texture, magic_texture, noise_fac, noise_texture, radial_tiling,
    voronoi_texture, voronoi_texture_without_color, wave_texture, white_noise_texture,
};
use glam::{Vec2, Vec3};

/// The Voronoi node's settings from its input registers `i` (Vector and W aside).
pub(super) fn voronoi_params(
    dims: u8,
    feature: VoronoiFeature,
    metric: VoronoiMetric,
    normalize: bool,
    i: &[Reg; 9],
    r: &[f32],
) -> VoronoiParams {
    let f = |k: usize| r[i[k] as usize];
    VoronoiParams {
        dims,
        feature,
        metric,
        normalize,
        scale: f(2),
        detail: f(3),
        roughness: f(4),
        lacunarity: f(5),
        smoothness: f(6),
        exponent: f(7),
        randomness: f(8),
    }
}

/// Writes the Voronoi node's outputs to their registers `o`.
pub(super) fn set_voronoi(r: &mut [f32], o: &[Reg; 5], out: &VoronoiOut) {
    r[o[0] as usize] = out.distance;
    set3(r, o[1], out.color);
    set3(r, o[2], out.position);
    r[o[3] as usize] = out.w;
    r[o[4] as usize] = out.radius;
}

/// A texture node compiled (boxed in `Op::Texture` to keep the op list compact).
#[derive(Clone, Debug)]
pub enum TexOp {
    /// Noise Texture: settings, then registers of Vector, W, Scale, Detail, Roughness,
    /// Lacunarity, Offset, Gain, Distortion; outputs Fac and Color (None: not linked, not
    /// computed).
    Noise { dims: u8, kind: NoiseKind, normalize: bool, inputs: [Reg; 9], fac: Reg, color: Option<Reg> },
    /// White Noise Texture: Vector, W; outputs Value and Color.
    WhiteNoise { dims: u8, vector: Reg, w: Reg, value: Reg, color: Reg },
    /// Voronoi Texture: Vector, W, Scale, Detail, Roughness, Lacunarity, Smoothness,
    /// Exponent, Randomness; outputs Distance, Color, Position, W, Radius (`color`: the
    /// Color output is linked and computed).
    Voronoi {
        dims: u8,
        feature: VoronoiFeature,
        metric: VoronoiMetric,
        normalize: bool,
        color: bool,
        inputs: [Reg; 9],
        outputs: [Reg; 5],
    },
    /// Wave Texture: Vector, Scale, Distortion, Detail, Detail Scale, Detail Roughness,
    /// Phase Offset; outputs Fac and Color.
    Wave { kind: WaveKind, direction: WaveDirection, profile: WaveProfile, inputs: [Reg; 7], fac: Reg, color: Reg },
    /// Checker Texture: Vector, Color1, Color2, Scale; outputs Color and Fac.
    Checker { inputs: [Reg; 4], color: Reg, fac: Reg },
    /// Gradient Texture: Vector; outputs Fac and Color.
    Gradient { kind: GradientKind, vector: Reg, fac: Reg, color: Reg },
    /// Magic Texture: Vector, Scale, Distortion; outputs Color and Fac.
    Magic { depth: i32, inputs: [Reg; 3], color: Reg, fac: Reg },
    /// Brick Texture: Vector, Color1, Color2, Mortar, Scale, Mortar Size, Mortar Smooth,
    /// Bias, Brick Width, Row Height; outputs Color and Fac.
    Brick {
        offset: f32,
        offset_frequency: i32,
        squash: f32,
        squash_frequency: i32,
        inputs: [Reg; 10],
        color: Reg,
        fac: Reg,
    },
    /// Gabor Texture: Vector, Scale, Frequency, Anisotropy, Orientation 2D, Orientation 3D;
    /// outputs Value, Phase, Intensity.
    Gabor { kind: GaborKind, inputs: [Reg; 6], outputs: [Reg; 3] },
    /// Radial Tiling: Vector (x and y read), Sides, Roundness; outputs Segment Coordinates,
    /// Segment ID, Segment Width, Segment Rotation (`used`: which are linked and computed).
    RadialTiling { normalize: bool, used: RadialTilingUse, inputs: [Reg; 3], outputs: [Reg; 4] },
    /// Sky Texture (any of its four models, precomputed at load): Vector; output Color.
    Sky { sky: std::sync::Arc<super::sky::Sky>, vector: Reg, color: Reg },
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
                match color {
                    Some(color) => {
                        let (v, c) = noise_texture(v3(r, i[0]), f(1), &prm);
                        r[fac as usize] = v;
                        set3(r, color, c);
                    }
                    None => r[fac as usize] = noise_fac(v3(r, i[0]), f(1), &prm),
                }
            }
            TexOp::Gabor { kind, inputs: i, outputs: o } => {
                let f = |k: usize| r[i[k] as usize];
                let prm = GaborParams {
                    kind,
                    scale: f(1),
                    frequency: f(2),
                    anisotropy: f(3),
                    orientation_2d: f(4),
                    orientation_3d: v3(r, i[5]),
                };
                let (value, phase, intensity) = gabor_texture(v3(r, i[0]), &prm);
                r[o[0] as usize] = value;
                r[o[1] as usize] = phase;
                r[o[2] as usize] = intensity;
            }
            TexOp::RadialTiling { normalize, used, inputs: i, outputs: o } => {
                let v = v3(r, i[0]);
                let out = radial_tiling(Vec2::new(v.x, v.y), r[i[1] as usize], r[i[2] as usize], normalize, used);
                set3(r, o[0], out.coordinates);
                r[o[1] as usize] = out.segment_id;
                r[o[2] as usize] = out.width;
                r[o[3] as usize] = out.rotation;
            }
            TexOp::WhiteNoise { dims, vector, w, value, color } => {
                let (v, c) = white_noise_texture(dims, v3(r, vector), r[w as usize]);
                r[value as usize] = v;
                set3(r, color, c);
            }
            TexOp::Voronoi { dims, feature, metric, normalize, color, inputs: i, outputs: o } => {
                let prm = voronoi_params(dims, feature, metric, normalize, &i, r);
                let out = if color {
                    voronoi_texture(v3(r, i[0]), r[i[1] as usize], &prm)
                } else {
                    voronoi_texture_without_color(v3(r, i[0]), r[i[1] as usize], &prm)
                };
                set_voronoi(r, &o, &out);
            }
            TexOp::Wave { kind, direction, profile, inputs: i, fac, color } => {
                let f = |k: usize| r[i[k] as usize];
                let prm = WaveParams {
                    kind,
                    direction,
                    profile,
                    scale: f(1),
                    distortion: f(2),
                    detail: f(3),
                    detail_scale: f(4),
                    detail_roughness: f(5),
                    phase_offset: f(6),
                };
                let (v, c) = wave_texture(v3(r, i[0]), &prm);
                r[fac as usize] = v;
                set3(r, color, c);
            }
            TexOp::Checker { inputs: i, color, fac } => {
                let (c, v) = checker_texture(v3(r, i[0]), v3(r, i[1]), v3(r, i[2]), r[i[3] as usize]);
                set3(r, color, c);
                r[fac as usize] = v;
            }
            TexOp::Gradient { kind, vector, fac, color } => {
                let v = gradient_texture(v3(r, vector), kind);
                r[fac as usize] = v;
                set3(r, color, Vec3::splat(v));
            }
            TexOp::Magic { depth, inputs: i, color, fac } => {
                let (c, v) = magic_texture(v3(r, i[0]), depth, r[i[1] as usize], r[i[2] as usize]);
                set3(r, color, c);
                r[fac as usize] = v;
            }
            TexOp::Brick { offset, offset_frequency, squash, squash_frequency, inputs: i, color, fac } => {
                let f = |k: usize| r[i[k] as usize];
                let prm = BrickParams {
                    offset,
                    offset_frequency,
                    squash,
                    squash_frequency,
                    color1: v3(r, i[1]),
                    color2: v3(r, i[2]),
                    mortar: v3(r, i[3]),
                    scale: f(4),
                    mortar_size: f(5),
                    mortar_smooth: f(6),
                    bias: f(7),
                    brick_width: f(8),
                    row_height: f(9),
                };
                let (c, v) = brick_texture(v3(r, i[0]), &prm);
                set3(r, color, c);
                r[fac as usize] = v;
            }
            TexOp::Sky { ref sky, vector, color } => set3(r, color, sky.radiance(v3(r, vector))),
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

/// Blender's Voronoi `feature` identifier.
pub fn voronoi_feature(s: &str) -> Option<VoronoiFeature> {
    Some(match s {
        "F1" => VoronoiFeature::F1,
        "F2" => VoronoiFeature::F2,
        "SMOOTH_F1" => VoronoiFeature::SmoothF1,
        "DISTANCE_TO_EDGE" => VoronoiFeature::DistanceToEdge,
        "N_SPHERE_RADIUS" => VoronoiFeature::NSphereRadius,
        _ => return None,
    })
}

/// Blender's Voronoi `distance` identifier.
pub fn voronoi_metric(s: &str) -> Option<VoronoiMetric> {
    Some(match s {
        "EUCLIDEAN" => VoronoiMetric::Euclidean,
        "MANHATTAN" => VoronoiMetric::Manhattan,
        "CHEBYCHEV" => VoronoiMetric::Chebychev,
        "MINKOWSKI" => VoronoiMetric::Minkowski,
        _ => return None,
    })
}

/// Blender's Gradient `gradient_type` identifier.
pub fn gradient_kind(s: &str) -> Option<GradientKind> {
    Some(match s {
        "LINEAR" => GradientKind::Linear,
        "QUADRATIC" => GradientKind::Quadratic,
        "EASING" => GradientKind::Easing,
        "DIAGONAL" => GradientKind::Diagonal,
        "RADIAL" => GradientKind::Radial,
        "QUADRATIC_SPHERE" => GradientKind::QuadraticSphere,
        "SPHERICAL" => GradientKind::Spherical,
        _ => return None,
    })
}

/// The Wave node's kind, direction and profile from Blender's identifiers.
pub fn wave_settings(
    kind: &str,
    bands: &str,
    rings: &str,
    profile: &str,
) -> Option<(WaveKind, WaveDirection, WaveProfile)> {
    let kind = match kind {
        "BANDS" => WaveKind::Bands,
        "RINGS" => WaveKind::Rings,
        _ => return None,
    };
    let dir = if kind == WaveKind::Bands { bands } else { rings };
    let direction = match dir {
        "X" => WaveDirection::X,
        "Y" => WaveDirection::Y,
        "Z" => WaveDirection::Z,
        "DIAGONAL" => WaveDirection::Diagonal,
        "SPHERICAL" => WaveDirection::Spherical,
        _ => return None,
    };
    let profile = match profile {
        "SIN" => WaveProfile::Sine,
        "SAW" => WaveProfile::Saw,
        "TRI" => WaveProfile::Tri,
        _ => return None,
    };
    Some((kind, direction, profile))
}
