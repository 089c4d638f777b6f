//! Blender's procedural texture nodes as Cycles computes them (`intern/cycles/kernel/svm/`),
//! as pure functions of the node's inputs after its Vector input is resolved (Blender's axes).
//!
//! The results match Cycles to rounding: `tests/texture_reference.rs` compares every texture
//! with values Blender itself computed (`tests/data/make_texture_reference.py`).

pub mod fractal;
pub mod hash;
pub mod noise;
pub mod perlin;
pub mod voronoi;
pub mod white_noise;

pub use noise::{NoiseKind, NoiseParams, noise_texture};
pub use voronoi::{VoronoiFeature, VoronoiMetric, VoronoiOut, VoronoiParams, voronoi_texture};
pub use white_noise::white_noise_texture;
