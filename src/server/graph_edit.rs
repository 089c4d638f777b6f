//! The `material_graph` edit: a node-graph material's `CAUSTIC_materials_nodes` value, as the
//! exporter writes it, compiled by the loader's own steps (`shader::compile`, then
//! `scene::gltf::graph_material` and `mean_node_emission`) into a new program for every
//! material of the name, in place: the BVH stays, and the emissive triangles' selection
//! powers follow the new emission.
//!
//! What the running scene cannot take without loading again is refused with an error ending
//! in "send load", before anything changes: an image the scene does not hold (or holds in
//! another colour space), tangents, texture space or an attribute read by name the loaded mesh
//! was not given for this graph, true displacement (the mesh was moved at load) in the new
//! graph or the old, and emission on a material whose triangles are not lights. A malformed graph is an
//! error too; the scene is then unchanged.

use super::edits::Invalidates;
use crate::light::Light;
use crate::math::luminance;
use crate::scene::Scene;
use crate::scene::gltf::{
    colorspace_converts, colorspace_is_srgb, graph_material, mean_node_emission, triangle_light_power,
};
use crate::scene::texture::associates_alpha;
use crate::shader::graph::NodesExt;

/// A checked, compiled graph edit, ready to apply (`prepare` reads the scene while it
/// renders, so that a refusal leaves the render running).
pub struct GraphEdit {
    name: String,
    /// The materials of the name.
    indices: Vec<u32>,
    program: crate::shader::instructions::Program,
    warnings: Vec<String>,
}

/// Compiles `nodes` for the materials named `name` and checks that the running scene can
/// take it (module doc); nothing changes.
pub fn prepare(scene: &Scene, name: &str, nodes: &serde_json::Value) -> Result<GraphEdit, String> {
    let indices: Vec<u32> =
        (0..scene.materials.len() as u32).filter(|&i| scene.materials[i as usize].name == name).collect();
    if indices.is_empty() {
        return Err(format!("no material named '{name}'"));
    }
    if indices.iter().any(|&i| scene.materials[i as usize].nodes.is_none()) {
        // Its glTF factors were rendered; which of them the graph keeps is the loader's call.
        return Err(format!("material '{name}' was loaded without a node graph; send load"));
    }
    let ext: NodesExt = serde_json::from_value(nodes.clone())
        .map_err(|e| format!("material '{name}': CAUSTIC_materials_nodes is malformed: {e}"))?;
    let images = held_images(scene, name, &ext)?;
    let space = crate::scene::working_space::WorkingSpace::of(scene.settings.working_space.as_ref())?;
    let compiled = crate::shader::compile::compile_in(name, &ext, &images, space)
        .map_err(|e| format!("material '{name}': CAUSTIC_materials_nodes: {e}"))?;
    let prog = &compiled.program;
    let uses = |t: usize| indices.contains(&scene.mesh.tri_material[t]);
    let used_tris = || (0..scene.mesh.triangles.len()).filter(|&t| uses(t));
    let old = scene.materials[indices[0] as usize].nodes.as_ref().expect("checked");
    // True displacement moved the mesh at load (`scene::gltf::displace`): a graph that has it,
    // or had it, changes the geometry, which only loading again rebuilds.
    if prog.true_displacement.is_some() || old.true_displacement.is_some() {
        return Err(format!(
            "material '{name}': its true displacement (method DISPLACEMENT or BOTH) moves the mesh at load; send load"
        ));
    }
    if prog.tangent_uv.is_some() && prog.tangent_uv != old.tangent_uv {
        return Err(format!(
            "material '{name}': the graph now reads tangents the loaded mesh was not given; send load"
        ));
    }
    if compiled.uses_generated
        && used_tris().any(|t| {
            let object = scene.mesh.tri_object.get(t).and_then(|&o| scene.objects.get(o as usize));
            object.is_none_or(|o| o.texspace.is_none())
        })
    {
        return Err(format!(
            "material '{name}': the graph now reads Generated coordinates, whose texture space the loaded mesh lacks; send load"
        ));
    }
    // The loaded mesh keeps the attributes the loaded graphs read (`Mesh::attributes`): one
    // this material did not read, and that no other graph kept, was not exported or kept.
    if let Some((key, _)) = prog
        .attributes
        .iter()
        .find(|(k, _)| scene.mesh.attribute(k).is_none() && !old.attributes.iter().any(|(o, _)| o == k))
    {
        return Err(format!(
            "material '{name}': the graph now reads {}, which the loaded mesh was not given; send load",
            key.describe()
        ));
    }
    let lit: std::collections::HashSet<u32> = scene
        .lights
        .iter()
        .filter_map(|l| match l {
            Light::Triangle { tri } if uses(*tri as usize) => Some(*tri),
            _ => None,
        })
        .collect();
    if prog.emits && used_tris().any(|t| !lit.contains(&(t as u32))) {
        return Err(format!("material '{name}': the graph now emits where the loaded scene has no lights; send load"));
    }

    let warnings = compiled.warnings.iter().map(|w| format!("material '{name}': {w}")).collect();
    Ok(GraphEdit { name: name.to_string(), indices, program: compiled.program, warnings })
}

impl GraphEdit {
    /// Gives every material of the name the new program and its emission estimate, and the
    /// emissive triangles their powers; returns what it invalidates and the warnings.
    pub fn apply(self, scene: &mut Scene) -> (Invalidates, Vec<String>) {
        let GraphEdit { name, indices, program, mut warnings } = self;
        for &i in &indices {
            let m = &scene.materials[i as usize];
            // The loaded material kept its medium already (`graph_material` at load).
            let mut program = program.clone();
            // Object Info's Material Index stays the loaded material's Pass Index.
            program.material_index = scene.pass_ids.material_index(i);
            let mut new = graph_material(m, program, true);
            if let Some((mean, n)) = mean_node_emission(&scene.mesh, &scene.objects, &scene.textures, &new, i) {
                new.emissive = mean;
                warnings.push(format!(
                    "material '{name}': its emission varies over the surface; lights are weighted by its mean over {n} triangle centres"
                ));
            }
            scene.materials[i as usize] = new;
        }
        // The loader's power per emissive triangle (`emissive_lights`; node materials have no
        // emission texture): a graph that no longer emits leaves its triangles lights of
        // power 0, which selection never picks, so that no light index moves.
        let (mesh, materials) = (&scene.mesh, &scene.materials);
        for (l, p) in scene.lights.iter().zip(scene.light_power.iter_mut()) {
            if let Light::Triangle { tri } = *l
                && indices.contains(&mesh.tri_material[tri as usize])
            {
                let m = &materials[mesh.tri_material[tri as usize] as usize];
                *p = triangle_light_power(mesh, tri, luminance(m.emissive));
            }
        }
        // Photon maps and the integrator's per-material BSDFs were built from the old program.
        (Invalidates::Shading, warnings)
    }
}

/// The scene textures of the graph's images, found by the URI the loader named them by (the
/// first of that name: the loaded scene's, before any merged in) and checked to be decoded
/// as the graph's colour space asks.
fn held_images(scene: &Scene, name: &str, ext: &NodesExt) -> Result<Vec<u32>, String> {
    let mut out = Vec::with_capacity(ext.images.len());
    for (k, img) in ext.images.iter().enumerate() {
        let what = format!("material '{name}': CAUSTIC_materials_nodes image {k} '{}'", img.uri);
        let Some(t) = scene.textures.iter().position(|t| t.name == img.uri) else {
            return Err(format!("{what} is not in the loaded scene; send load"));
        };
        let tex = &scene.textures[t];
        // Texels keep their encoding flag (8-bit and float sRGB images are decoded after filtering).
        let working = scene.settings.working_space.as_ref().map(|w| w.name.as_str());
        let srgb = working != Some(img.colorspace.as_str()) && colorspace_is_srgb(&img.colorspace).unwrap_or(false);
        let converts = colorspace_converts(&img.colorspace, working);
        if tex.srgb != srgb || tex.to_working.is_some() != converts {
            return Err(format!("{what} was loaded in another colour space; send load"));
        }
        let associated = associates_alpha(img.colorspace == "Non-Color", img.alpha.as_deref(), !tex.hdr.is_empty());
        if tex.associated != associated {
            return Err(format!("{what} was loaded with another alpha mode; send load"));
        }
        out.push(t as u32);
    }
    Ok(out)
}
