//! The world as a shader graph (`CAUSTIC_world.nodes`): Blender's World Output Surface
//! compiled by the material compiler (`shader::compile`) and evaluated per escaped ray
//! direction, as Cycles shades the background: Generated, Object and Position coordinates
//! are the direction, the normal and the incoming direction its opposite. Background and
//! Emission closures add their colour × strength; mixtures weigh them as on a surface.
//!
//! Sampling: the graph's radiance is baked at load into an equirectangular table (texel
//! centres, plus each visible Sky Texture sun's centre so that a disc smaller than a texel
//! is still found), and the world is sampled from that table's distribution exactly as an
//! HDRI (`EnvImage`), while the radiance of a direction always comes from the graph itself.
//! This is Cycles' arrangement (its background map serves sampling only), and MIS stays
//! unbiased since the density is the table's wherever the graph is evaluated.

use crate::math::Rgb;
use crate::scene::mesh::Mesh;
use crate::scene::texture::Texture;
use crate::shader::closure::Closures;
use crate::shader::geom::{Geom, NO_OBJECT, from_blender};
use crate::shader::instructions::{InputKind, Op, Program};
use crate::shader::program::with_registers;
use crate::shader::texture_nodes::TexOp;
use glam::{Vec2, Vec3, Vec4};
use std::f32::consts::PI;
use std::sync::Arc;

/// Side of the baked table: 1024 × 512 (Cycles' default background map resolution,
/// 0.35° per texel); a graph reading an image bakes at the image's width (up to 4096) so
/// that the table resolves what the image holds.
pub const DEFAULT_BAKE_WIDTH: usize = 1024;
/// The largest table width.
pub const MAX_BAKE_WIDTH: usize = 4096;

/// No triangles: the world has no surface (a Bump in a world graph finds none and keeps
/// the normal).
static NO_MESH: Mesh = Mesh {
    positions: Vec::new(),
    normals: Vec::new(),
    tangents: Vec::new(),
    uv0: Vec::new(),
    uv1: Vec::new(),
    colors: Vec::new(),
    triangles: Vec::new(),
    tri_material: Vec::new(),
    tri_object: Vec::new(),
};

/// A compiled world graph and the images it reads.
#[derive(Clone, Debug)]
pub struct WorldGraph {
    program: Arc<Program>,
    /// The graph's images (its Image/Environment Texture nodes index these).
    textures: Vec<Texture>,
}

impl WorldGraph {
    /// The graph and its own images.
    pub fn new(program: Program, textures: Vec<Texture>) -> WorldGraph {
        WorldGraph { program: Arc::new(program), textures }
    }

    /// The compiled program.
    pub fn program(&self) -> &Program {
        &self.program
    }

    /// Radiance arriving from glTF direction `d` (unit, pointing away from the scene).
    pub fn radiance(&self, d: Vec3) -> Rgb {
        let g = Geom {
            p: d,
            n: -d,
            ng: -d,
            wo: -d,
            uv: [Vec2::ZERO; 2],
            color: Vec4::ONE,
            tangent: Vec4::ZERO,
            backfacing: false,
            object: &NO_OBJECT,
            textures: &self.textures,
            mesh: &NO_MESH,
            tri: u32::MAX,
        };
        let mut out = Closures::default();
        with_registers(|regs| self.program.run(&g, regs, &mut out));
        let e = out.emission;
        if e.is_finite() { e.max(Vec3::ZERO) } else { Vec3::ZERO }
    }

    /// Directions (glTF) of the visible sun discs of Sky Textures reading the direction
    /// itself (an unlinked Vector, or Generated/Object/Position straight from the input
    /// node); a Sky behind a Mapping is found by the table's texel centres only.
    pub fn sun_directions(&self) -> Vec<Vec3> {
        let ops = &self.program.ops;
        let direct = |reg| {
            ops.iter().any(|op| {
                matches!(op, Op::Input { what: InputKind::Generated | InputKind::Object | InputKind::Position, out }
                    if *out == reg)
            })
        };
        ops.iter()
            .filter_map(|op| match op {
                Op::Texture(t) => match t.as_ref() {
                    TexOp::Sky { sky, vector, .. } if direct(*vector) => sky.sun_direction().map(from_blender),
                    _ => None,
                },
                _ => None,
            })
            .collect()
    }

    /// The table's width: the widest image the graph reads, else 1024; at most 4096.
    pub fn bake_width(&self) -> usize {
        let widest = self.textures.iter().map(|t| t.width as usize).max().unwrap_or(0);
        widest.clamp(DEFAULT_BAKE_WIDTH, MAX_BAKE_WIDTH)
    }

    /// The radiance at the centres of a `width` × `width / 2` equirectangular table (rows
    /// top first, Blender's mapping as `EnvImage`), each texel holding a sun centre raised
    /// to the radiance there. Rows run in parallel.
    pub fn bake(&self, width: usize, dir_of: impl Fn(Vec2) -> Vec3 + Sync) -> Vec<Rgb> {
        use rayon::prelude::*;
        let height = width / 2;
        let mut texels = vec![Rgb::ZERO; width * height];
        texels.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
            for (x, t) in row.iter_mut().enumerate() {
                let uv = Vec2::new((x as f32 + 0.5) / width as f32, 1.0 - (y as f32 + 0.5) / height as f32);
                *t = self.radiance(dir_of(uv));
            }
        });
        for d in self.sun_directions() {
            let b = crate::shader::geom::to_blender(d);
            let u = (0.5 - b.y.atan2(b.x) / (2.0 * PI)).rem_euclid(1.0);
            let v = 0.5 + b.z.clamp(-1.0, 1.0).asin() / PI;
            let x = ((u * width as f32) as usize).min(width - 1);
            let y = (((1.0 - v) * height as f32) as usize).min(height - 1);
            let t = &mut texels[y * width + x];
            *t = t.max(self.radiance(d));
        }
        texels
    }
}
