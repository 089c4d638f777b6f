//! Caustic: a physically based offline renderer for glTF 2.0 scenes.
//!
//! Data flows one way: `scene` (glTF loader) → `accel` (BVH) → `integrator` →
//! `film` → `output` (EXR). `cli` wires them into the `caustic` commands.

// `!(x > 0.0)` is used on purpose throughout: it is true for NaN, which `x <= 0.0` is not.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod bsdf;
pub mod chunk;
pub mod cli;
pub mod cryptomatte;
pub mod curves;
pub mod denoise;
pub mod error;
pub mod exr_header;
pub mod film;
pub mod fixed;
pub mod fuzz;
pub mod integrator;
pub mod light;
pub mod math;
pub mod medium;
pub mod memory;
pub mod motion;
pub mod output;
pub mod passes;
pub mod points;
pub mod progress;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod server;
pub mod shader;
pub mod shadow_catcher;
