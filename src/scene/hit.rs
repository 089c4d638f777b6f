//! What a ray hit (`SurfaceHit`) and what the material gives there (`ShadingPoint`): the
//! leaf types that the shading dispatch (`shading.rs`) and the node evaluator
//! (`shader::shade`) share.

use crate::bsdf::Bsdf;
use crate::math::{Frame, Rgb};
use glam::{Vec2, Vec3};

/// A surface point found by a ray.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    /// Position.
    pub p: Vec3,
    /// Unit geometric normal on the side the ray came from.
    pub ng: Vec3,
    /// Unit interpolated shading normal (before normal mapping), on the same side as `ng`.
    pub ns: Vec3,
    /// Interpolated tangent (xyz) and bitangent sign (w), zero when absent.
    pub tangent: glam::Vec4,
    /// Texture coordinates (sets 0 and 1).
    pub uv: [Vec2; 2],
    /// Vertex colour.
    pub color: glam::Vec4,
    /// Material index.
    pub material: u32,
    /// Triangle index.
    pub tri: u32,
    /// Barycentrics (b1, b2) of the hit: the weights of the triangle's second and third
    /// vertices (named attributes are interpolated by them).
    pub bary: Vec2,
    /// True when the ray hit the front (counter-clockwise) face.
    pub front: bool,
    /// Hit distance.
    pub t: f32,
    /// The ray that found the hit, as the Light Path node sees it (the walkers set it).
    pub light_path: crate::scene::light_path::LightPath,
}

/// What the material gives at a hit.
pub struct ShadingPoint {
    /// Scattering function.
    pub bsdf: Bsdf,
    /// Shading frame (normal-mapped), normal on the side of `ng`.
    pub frame: Frame,
    /// Emitted radiance toward the ray's origin.
    pub emitted: Rgb,
    /// A node graph's Holdout weight: what a camera ray (through pass-throughs only) takes
    /// from the film's alpha here, times its throughput; 1 ends the path (Cycles'
    /// `integrate_surface_holdout`). 0 for every other material.
    pub holdout: f32,
}
