//! Materials whose Volume output has a node graph (`CAUSTIC_materials_medium.graph`): once
//! the meshes are placed, each becomes a procedural grid medium (`medium::procedural`) over
//! the box of the triangles that wear it, in the space of the object that wears it, and the
//! material points to it (`Material::grid`), as a volume object's box does. The graph's
//! images are decoded for its program alone (`Loader::volume_program`).

use super::Loader;
use crate::medium::GridMedium;
use crate::medium::procedural::procedural_medium;
use crate::medium::procedural_source::ProceduralSource;
use crate::scene::{Material, Mesh};
use crate::shader::compile::volume::{VolumeProgram, compile_volume};
use crate::shader::geom::{NO_OBJECT, ObjectData};
use glam::Vec3;

impl Loader<'_> {
    /// A Volume output's graph (`CAUSTIC_materials_medium.graph`, of a material or the world)
    /// compiled, its images decoded as the surface graphs' are and kept by the program alone
    /// (they leave the scene's list, as the world graph's do). `what` names it in errors.
    pub(super) fn volume_program(
        &mut self,
        name: &str,
        graph: &crate::shader::graph::NodesExt,
        shader: usize,
        what: &str,
    ) -> crate::error::Result<VolumeProgram> {
        let first = self.textures.len();
        let mut images = Vec::with_capacity(graph.images.len());
        for (k, img) in graph.images.iter().enumerate() {
            images.push(self.node_image(name, k, img)? - first as u32);
        }
        let textures = self.textures.split_off(first);
        let mut v =
            compile_volume(name, graph, shader, &images, self.space).map_err(|e| self.err(format!("{what}: {e}")))?;
        v.textures = textures;
        Ok(v)
    }

    /// Turns each material's volume program into a grid medium appended to `grids`.
    pub(super) fn procedural_media(
        &mut self,
        grids: &mut Vec<GridMedium>,
        mesh: &Mesh,
        objects: &[ObjectData],
        materials: &mut [Material],
    ) {
        for (index, mat) in materials.iter_mut().enumerate() {
            let Some(volume) = mat.volume_program.take() else {
                continue;
            };
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            let mut object: Option<u32> = None;
            let mut several = false;
            for (t, tri) in mesh.triangles.iter().enumerate() {
                if mesh.tri_material[t] as usize != index {
                    continue;
                }
                for &v in tri {
                    lo = lo.min(mesh.positions[v as usize]);
                    hi = hi.max(mesh.positions[v as usize]);
                }
                let o = mesh.tri_object.get(t).copied();
                match (object, o) {
                    (None, Some(o)) => object = Some(o),
                    (Some(a), Some(b)) if a != b => several = true,
                    _ => {}
                }
            }
            if !(lo.x <= hi.x) {
                // No triangle wears it: nothing to fill.
                continue;
            }
            if several {
                self.warn(format!(
                    "material '{}': its textured volume is on several objects; Object and Generated \
                     coordinates are those of the first for all of them",
                    mat.name
                ));
            }
            let obj = object.and_then(|o| objects.get(o as usize)).copied().unwrap_or(NO_OBJECT);
            let source = ProceduralSource { volume: *volume, object: obj, grids: None };
            grids.push(procedural_medium(mat.name.clone(), lo, hi, source));
            mat.grid = Some(grids.len() as u32 - 1);
        }
    }
}
