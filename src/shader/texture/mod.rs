//! Blender's procedural texture nodes as Cycles computes them (`intern/cycles/kernel/svm/`),
//! as pure functions of the node's inputs after its Vector input is resolved (Blender's axes).
//!
//! The results match Cycles to rounding: `tests/texture_reference.rs` compares every texture
//! with values Blender itself computed (`tests/data/make_texture_reference.py`).

pub mod hash;
pub mod white_noise;

pub use white_noise::white_noise_texture;
