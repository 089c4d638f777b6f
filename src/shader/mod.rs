//! Blender's shader nodes as the renderer evaluates them.
pub mod texture;
