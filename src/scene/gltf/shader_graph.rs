//! `CAUSTIC_materials_nodes`: Blender's shader graph on a material, compiled into the
//! material's program (`shader::compile`). The glTF parameters of that material are then
//! not rendered (docs/contract.md); its `CAUSTIC_materials_medium` and
//! `CAUSTIC_materials_subsurface` still apply.

use super::Loader;
use crate::error::Result;
use crate::scene::{AlphaMode, Material};
use crate::shader::compile::compile;
use crate::shader::graph::NodesExt;
use std::sync::Arc;

impl Loader<'_> {
    /// Compiles the material's graph, if it has one, into `mat.nodes`.
    pub(super) fn material_nodes(
        &mut self,
        m: &gltf::Material,
        mat: &mut Material,
        features: &mut Vec<String>,
    ) -> Result<()> {
        let Some(v) = m.extension_value("CAUSTIC_materials_nodes") else {
            return Ok(());
        };
        let name = mat.name.clone();
        features.push("CAUSTIC_materials_nodes".into());
        let ext: NodesExt = serde_json::from_value(v.clone())
            .map_err(|e| self.err(format!("material '{name}': CAUSTIC_materials_nodes is malformed: {e}")))?;
        let compiled =
            compile(&name, &ext).map_err(|e| self.err(format!("material '{name}': CAUSTIC_materials_nodes: {e}")))?;
        for w in compiled.warnings {
            self.warn(format!("material '{name}': {w}"));
        }
        let prog = compiled.program;
        // The graph replaces the glTF description: no glTF textures, emission or alpha.
        let keep = Material {
            name: mat.name.clone(),
            double_sided: true,
            medium: if features.iter().any(|f| f == "CAUSTIC_materials_medium") { mat.medium } else { None },
            null_surface: mat.null_surface,
            subsurface: mat.subsurface,
            ..Material::default()
        };
        *mat = keep;
        mat.metallic = 0.0;
        mat.alpha_mode = if prog.transparent { AlphaMode::Blend } else { AlphaMode::Opaque };
        mat.emissive = if prog.emits {
            match prog.constant_emission {
                Some(e) => e.max(glam::Vec3::ZERO),
                // Estimated per material once the mesh is known (`node_emitters`).
                None => glam::Vec3::splat(1.0),
            }
        } else {
            glam::Vec3::ZERO
        };
        mat.nodes = Some(Arc::new(prog));
        Ok(())
    }
}

/// Triangles sampled per material for the estimate of a varying emission.
const EMISSION_SAMPLES: usize = 4096;

impl Loader<'_> {
    /// Node materials whose emission varies over the surface get an estimate of their
    /// mean radiance in `emissive` (the light list's powers and photon emission use it;
    /// the radiance itself is always evaluated exactly, `Scene::emission_at`): the mean of
    /// the graph's emission at the centroids of up to 4096 of the material's triangles
    /// (evenly strided). A material whose samples are all black keeps a tiny positive
    /// estimate, so that its triangles stay sampleable lights wherever they do emit.
    pub(super) fn node_emitters(
        &mut self,
        mesh: &crate::scene::Mesh,
        objects: &[crate::shader::program::ObjectData],
        materials: &mut [Material],
    ) {
        for (mi, mat) in materials.iter_mut().enumerate() {
            let Some(prog) = &mat.nodes else { continue };
            if !prog.emits || prog.constant_emission.is_some() {
                continue;
            }
            let tris: Vec<u32> =
                (0..mesh.triangles.len() as u32).filter(|&t| mesh.tri_material[t as usize] == mi as u32).collect();
            if tris.is_empty() {
                continue;
            }
            let stride = tris.len().div_ceil(EMISSION_SAMPLES);
            let mut sum = glam::Vec3::ZERO;
            let mut n = 0;
            for &t in tris.iter().step_by(stride) {
                sum += crate::shader::shade::node_emission(mesh, objects, prog, t, 1.0 / 3.0, 1.0 / 3.0);
                n += 1;
            }
            let mean = sum / n as f32;
            mat.emissive = mean.max(glam::Vec3::splat(1e-6));
            let name = mat.name.clone();
            self.warn(format!(
                "material '{name}': its emission varies over the surface; lights are weighted by its mean over {n} triangle centres"
            ));
        }
    }
}
