//! Blender's procedural texture nodes as Cycles computes them (`intern/cycles/kernel/svm/`),
//! as pure functions of the node's inputs after its Vector input is resolved (Blender's axes).
//!
//! The results match Cycles to rounding: `tests/texture_reference.rs` compares every texture
//! with values Blender itself computed (`tests/data/make_texture_reference.py`).

pub mod brick;
mod cell_offsets;
pub mod checker;
pub mod float_ops;
pub mod fractal;
pub mod gabor;
pub mod gradient;
pub mod hash;
pub mod magic;
pub mod noise;
pub mod noise_lanes;
pub mod perlin;
pub mod radial_tiling;
pub(crate) mod simd;
pub mod voronoi;
mod voronoi_coord;
mod voronoi_settings;
pub mod wave;
pub mod white_noise;

pub use brick::{BrickParams, brick_texture};
pub use checker::checker_texture;
pub use gabor::{GaborKind, GaborParams, gabor_texture};
pub use gradient::{GradientKind, gradient_texture};
pub use magic::magic_texture;
pub use noise::{NoiseKind, NoiseParams, noise_fac, noise_texture};
pub use radial_tiling::{RadialTiling, RadialTilingUse, radial_tiling};
pub use voronoi::{
    VoronoiFeature, VoronoiMetric, VoronoiOut, VoronoiParams, voronoi_texture, voronoi_texture_lanes,
    voronoi_texture_without_color,
};
pub use wave::{WaveDirection, WaveKind, WaveParams, WaveProfile, wave_texture};
pub use white_noise::white_noise_texture;

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Every fractal kind of the Noise node.
    const NOISE_KINDS: [NoiseKind; 5] = [
        NoiseKind::Multifractal,
        NoiseKind::RidgedMultifractal,
        NoiseKind::HybridMultifractal,
        NoiseKind::Fbm,
        NoiseKind::HeteroTerrain,
    ];

    /// Every node with every setting, at `p` and `w`, with the given scalar inputs.
    fn all_outputs(p: Vec3, w: f32, x: f32) -> Vec<f32> {
        let mut out = Vec::new();
        for dims in 1..=4 {
            let (v, c) = white_noise_texture(dims, p, w);
            out.extend([v, c.x, c.y, c.z]);
            for kind in NOISE_KINDS {
                let prm = NoiseParams {
                    dims,
                    kind,
                    normalize: true,
                    scale: x,
                    detail: x,
                    roughness: x,
                    lacunarity: x,
                    offset: x,
                    gain: x,
                    distortion: x,
                };
                let (f, c) = noise_texture(p, w, &prm);
                out.extend([f, c.x, c.y, c.z]);
            }
            for feature in [
                VoronoiFeature::F1,
                VoronoiFeature::F2,
                VoronoiFeature::SmoothF1,
                VoronoiFeature::DistanceToEdge,
                VoronoiFeature::NSphereRadius,
            ] {
                for metric in [
                    VoronoiMetric::Euclidean,
                    VoronoiMetric::Manhattan,
                    VoronoiMetric::Chebychev,
                    VoronoiMetric::Minkowski,
                ] {
                    let prm = VoronoiParams {
                        dims,
                        feature,
                        metric,
                        normalize: true,
                        scale: x,
                        detail: x.min(3.0),
                        roughness: x,
                        lacunarity: x,
                        smoothness: x,
                        exponent: x,
                        randomness: x,
                    };
                    let o = voronoi_texture(p, w, &prm);
                    out.extend([o.distance, o.color.x, o.position.y, o.w, o.radius]);
                }
            }
        }
        out.push(checker_texture(p, Vec3::ONE, Vec3::ZERO, x).1);
        out.push(gradient_texture(p * x, GradientKind::Radial));
        out.push(magic_texture(p, 10, x, x).1);
        out.push(wave_texture(p, &wave(x)).0);
        let brick = BrickParams {
            offset: x,
            offset_frequency: -1,
            squash: x,
            squash_frequency: i32::MIN,
            color1: Vec3::ONE,
            color2: Vec3::ZERO,
            mortar: Vec3::X,
            scale: x,
            mortar_size: x,
            mortar_smooth: x,
            bias: x,
            brick_width: x,
            row_height: x,
        };
        out.push(brick_texture(p, &brick).1);
        out
    }

    fn wave(x: f32) -> WaveParams {
        WaveParams {
            kind: WaveKind::Rings,
            direction: WaveDirection::Spherical,
            profile: WaveProfile::Saw,
            scale: x,
            distortion: x,
            detail: x,
            detail_scale: x,
            detail_roughness: x,
            phase_offset: x,
        }
    }

    /// Ordinary inputs give finite values; zeros (a Minkowski exponent of 0 gives Cycles'
    /// infinite distance too), 15 everywhere (hetero terrain overflows as in Cycles), NaN,
    /// infinite and huge inputs are not rejected by Blender either and must not panic.
    #[test]
    fn extreme_inputs_never_panic_and_stay_finite_when_ordinary() {
        let p = Vec3::new(-2.5, 0.75, 3.0);
        for x in [0.5, 1.0, 2.5] {
            for (i, v) in all_outputs(p, -1.25, x).into_iter().enumerate() {
                assert!(v.is_finite(), "output {i} with inputs {x}: {v}");
            }
        }
        for x in [0.0, 15.0, f32::NAN, f32::INFINITY, -f32::INFINITY, 1e30, -1e30] {
            all_outputs(Vec3::splat(x), x, 2.0);
            all_outputs(p, 0.5, x);
        }
    }

    /// The entry points without a colour (for unlinked Color outputs) give the other outputs
    /// bit for bit, for every dimension, kind, feature and metric.
    #[test]
    fn colourless_entry_points_keep_the_other_outputs() {
        for (p, w, x) in [(Vec3::new(-2.5, 0.75, 3.0), -1.25, 0.6), (Vec3::new(13.1, -7.2, 0.4), 4.5, 2.5)] {
            for dims in 1..=4 {
                for kind in NOISE_KINDS {
                    let prm = NoiseParams {
                        dims,
                        kind,
                        normalize: true,
                        scale: x,
                        detail: 3.5,
                        roughness: 0.5,
                        lacunarity: 2.0,
                        offset: 0.5,
                        gain: 1.0,
                        distortion: x,
                    };
                    assert_eq!(noise_fac(p, w, &prm).to_bits(), noise_texture(p, w, &prm).0.to_bits());
                }
                for feature in [VoronoiFeature::F1, VoronoiFeature::F2, VoronoiFeature::SmoothF1] {
                    for metric in [VoronoiMetric::Euclidean, VoronoiMetric::Manhattan, VoronoiMetric::Minkowski] {
                        let prm = VoronoiParams {
                            dims,
                            feature,
                            metric,
                            normalize: true,
                            scale: x,
                            detail: 1.5,
                            roughness: 0.5,
                            lacunarity: 2.0,
                            smoothness: 0.7,
                            exponent: 1.5,
                            randomness: 0.9,
                        };
                        let (a, b) = (voronoi_texture(p, w, &prm), voronoi_texture_without_color(p, w, &prm));
                        assert_eq!(b.color, Vec3::ZERO);
                        assert_eq!(VoronoiOut { color: Vec3::ZERO, ..a }, b, "{dims}-D {feature:?} {metric:?}");
                    }
                }
            }
        }
    }
}
