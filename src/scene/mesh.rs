//! The scene's triangles: world-space geometry and per-vertex attributes, a leaf type
//! that the shader evaluator and the loader both read.

use glam::{Vec2, Vec3, Vec4};

/// All triangles of the scene, instanced and transformed to world space, with
/// per-vertex attributes (absent attributes are filled with defaults).
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// World-space positions.
    pub positions: Vec<Vec3>,
    /// World-space unit shading normals.
    pub normals: Vec<Vec3>,
    /// World-space tangents with the bitangent sign in w (zero when not needed).
    pub tangents: Vec<Vec4>,
    /// TEXCOORD_0.
    pub uv0: Vec<Vec2>,
    /// TEXCOORD_1.
    pub uv1: Vec<Vec2>,
    /// COLOR_0 (white when absent).
    pub colors: Vec<Vec4>,
    /// Vertex indices, counter-clockwise seen from the front.
    pub triangles: Vec<[u32; 3]>,
    /// Material of each triangle.
    pub tri_material: Vec<u32>,
    /// Instance (index into `Scene::objects`) of each triangle; empty when no material
    /// reads instance data (shader graphs' Object coordinates, Object Info).
    pub tri_object: Vec<u32>,
    /// World-space positions before true displacement (`scene::gltf::displace`), which the
    /// Generated coordinate reads as Cycles reads the undisplaced orco; empty when no
    /// material moved the mesh.
    pub undisplaced: Vec<Vec3>,
}

/// No triangles: the mesh a shader graph is evaluated against where there is no surface
/// (constant folding at load, the world's graphs).
pub static EMPTY_MESH: Mesh = Mesh {
    positions: Vec::new(),
    normals: Vec::new(),
    tangents: Vec::new(),
    uv0: Vec::new(),
    uv1: Vec::new(),
    colors: Vec::new(),
    triangles: Vec::new(),
    tri_material: Vec::new(),
    tri_object: Vec::new(),
    undisplaced: Vec::new(),
};
