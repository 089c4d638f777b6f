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

/// What a shader graph reads of an instance: its inverse world matrix and location, a
/// per-object random number, and the mesh's texture space (`CAUSTIC_texspace` extras).
///
/// Object Info's Random: Cycles hashes the object's name with Blender's own string hash;
/// Caustic hashes the node's name (the Blender object's name) with its own integer hash,
/// so the value is stable per object and uniform in [0, 1) but not Cycles' number.
pub(super) fn object_data(
    world: &glam::Mat4,
    node_name: &str,
    texspace: Option<&serde_json::Value>,
) -> crate::shader::program::ObjectData {
    let mut h = 0x9e37_79b9u32;
    for b in node_name.bytes() {
        h = crate::math::hash_u32(h ^ b as u32);
    }
    let vec3 = |v: Option<&serde_json::Value>| -> Option<glam::Vec3> {
        let a = v?.as_array()?;
        if a.len() != 3 {
            return None;
        }
        Some(glam::Vec3::new(a[0].as_f64()? as f32, a[1].as_f64()? as f32, a[2].as_f64()? as f32))
    };
    let texspace = texspace.and_then(|t| Some((vec3(t.get("location"))?, vec3(t.get("size"))?)));
    crate::shader::program::ObjectData {
        world_to_object: world.inverse(),
        location: world.w_axis.truncate(),
        random: (h >> 8) as f32 / 16_777_216.0,
        texspace,
    }
}
