//! Blender's procedural texture nodes as Cycles computes them (`intern/cycles/kernel/svm/`),
//! as pure functions of the node's inputs after its Vector input is resolved (Blender's axes).
//!
//! The results match Cycles to rounding: `tests/texture_reference.rs` compares every texture
//! with values Blender itself computed (`tests/data/make_texture_reference.py`).

pub mod brick;
pub mod checker;
pub mod fractal;
pub mod gradient;
pub mod hash;
pub mod magic;
pub mod noise;
pub mod perlin;
pub mod voronoi;
pub mod wave;
pub mod white_noise;

pub use brick::{BrickParams, brick_texture};
pub use checker::checker_texture;
pub use gradient::{GradientKind, gradient_texture};
pub use magic::magic_texture;
pub use noise::{NoiseKind, NoiseParams, noise_texture};
pub use voronoi::{VoronoiFeature, VoronoiMetric, VoronoiOut, VoronoiParams, voronoi_texture};
pub use wave::{WaveDirection, WaveKind, WaveParams, WaveProfile, wave_texture};
pub use white_noise::white_noise_texture;
