//! Blender's shader nodes as the renderer evaluates them.
pub mod texture;

pub mod aov;
pub mod bump_lanes;
pub mod closure;
pub mod compile;
pub mod geom;
pub mod graph;
pub mod ies;
pub mod image_node;
pub mod instructions;
pub mod mesh_hair;
pub mod ops;
pub mod program;
pub mod shade;
pub mod sky;
pub mod texture_nodes;
pub mod trace;
