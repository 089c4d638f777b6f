//! `EXT_mesh_gpu_instancing`: a node's mesh drawn once per row of its TRANSLATION, ROTATION
//! and SCALE accessors (each instance's transform applied under the node's), as Blender's
//! importer reads it; forests and crowds in public assets use it.

use super::Loader;
use super::quantized::read_f32;
use crate::error::Result;
use glam::{Mat4, Quat, Vec3, Vec4};

const EXT: &str = "EXT_mesh_gpu_instancing";

/// How many times the node's mesh is drawn, from the JSON alone (for the memory budget).
pub(super) fn copies(node: &gltf::Node, doc: &gltf::Document) -> u64 {
    let Some(attributes) = node.extension_value(EXT).and_then(|e| e.get("attributes")) else { return 1 };
    ["TRANSLATION", "ROTATION", "SCALE"]
        .iter()
        .filter_map(|k| attributes.get(*k).and_then(|v| v.as_u64()))
        .filter_map(|i| doc.accessors().nth(i as usize))
        .map(|a| a.count() as u64)
        .max()
        .unwrap_or(1)
}

impl Loader<'_> {
    /// The world matrix of every copy of `node`'s mesh: `[world]` without the extension.
    pub(super) fn mesh_copies(
        &mut self,
        doc: &gltf::Document,
        node: &gltf::Node,
        node_name: &str,
        world: &Mat4,
        buffers: &[Vec<u8>],
    ) -> Result<Vec<Mat4>> {
        let Some(ext) = node.extension_value(EXT) else { return Ok(vec![*world]) };
        let what = format!("node {} ('{node_name}'): {EXT}", node.index());
        let attributes = ext
            .get("attributes")
            .and_then(|a| a.as_object())
            .ok_or_else(|| self.err(format!("{what} has no attributes object")))?;
        let column = |key: &str, dims: usize| -> Result<Option<Vec<[f32; 4]>>> {
            let Some(index) = attributes.get(key) else { return Ok(None) };
            let acc = index
                .as_u64()
                .and_then(|i| doc.accessors().nth(i as usize))
                .ok_or_else(|| self.err(format!("{what}: {key} names no accessor of the file")))?;
            let rows: Option<Vec<[f32; 4]>> = if dims == 3 {
                read_f32::<3>(&acc, buffers, false).map(|v| v.into_iter().map(|[x, y, z]| [x, y, z, 0.0]).collect())
            } else {
                read_f32::<4>(&acc, buffers, false)
            };
            let rows = rows.ok_or_else(|| self.err(format!("{what}: cannot read {key} (wrong type or size)")))?;
            if rows.iter().flatten().any(|x| !x.is_finite()) {
                return Err(self.err(format!("{what}: {key} holds a NaN or infinite value")));
            }
            Ok(Some(rows))
        };
        let (t, r, s) = (column("TRANSLATION", 3)?, column("ROTATION", 4)?, column("SCALE", 3)?);
        let counts: Vec<usize> = [&t, &r, &s].iter().filter_map(|c| c.as_ref().map(Vec::len)).collect();
        let Some(&n) = counts.first() else {
            self.warn(format!("{what} gives no TRANSLATION, ROTATION or SCALE; the mesh is drawn once"));
            return Ok(vec![*world]);
        };
        if counts.iter().any(|&c| c != n) {
            return Err(self.err(format!("{what}: its attributes have different counts ({counts:?})")));
        }
        let mut copies = Vec::with_capacity(n);
        for i in 0..n {
            let tr = t.as_ref().map_or(Vec3::ZERO, |t| Vec3::from_slice(&t[i][..3]));
            let rot = match &r {
                None => Quat::IDENTITY,
                Some(r) => {
                    let q = Vec4::from(r[i]);
                    if !(q.length() > 1e-6) {
                        return Err(self.err(format!("{what}: ROTATION {i} is not a rotation (zero quaternion)")));
                    }
                    Quat::from_vec4(q.normalize())
                }
            };
            let sc = s.as_ref().map_or(Vec3::ONE, |s| Vec3::from_slice(&s[i][..3]));
            copies.push(*world * Mat4::from_scale_rotation_translation(sc, rot, tr));
        }
        Ok(copies)
    }
}

#[cfg(test)]
mod tests {
    use crate::memory::MemoryBudget;
    use base64::Engine;
    use serde_json::json;

    /// The unit triangle drawn by a node at x + 10 with `attributes` (accessors 1.. over
    /// `extra`, appended after the positions).
    fn load(
        extra: &[f32],
        accessors: serde_json::Value,
        attributes: serde_json::Value,
        budget: &MemoryBudget,
    ) -> crate::error::Result<crate::scene::Scene> {
        let mut data: Vec<f32> = vec![0., 0., 0., 1., 0., 0., 0., 1., 0.];
        data.extend_from_slice(extra);
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&bytes)
        );
        let mut all = vec![json!({"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
            "min": [0, 0, 0], "max": [1, 1, 0]})];
        all.extend(accessors.as_array().unwrap().iter().cloned());
        let doc = json!({
            "asset": {"version": "2.0"},
            "extensionsUsed": ["EXT_mesh_gpu_instancing"],
            "extensionsRequired": ["EXT_mesh_gpu_instancing"],
            "buffers": [{"uri": uri, "byteLength": bytes.len()}],
            "bufferViews": [{"buffer": 0, "byteLength": 36},
                            {"buffer": 0, "byteOffset": 36, "byteLength": bytes.len() - 36}],
            "accessors": all,
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
            "nodes": [{"mesh": 0, "translation": [10, 0, 0],
                       "extensions": {"EXT_mesh_gpu_instancing": {"attributes": attributes}}}],
            "scenes": [{"nodes": [0]}]
        });
        crate::scene::gltf::load_bytes(
            &serde_json::to_vec(&doc).unwrap(),
            std::path::Path::new("."),
            "inst.gltf",
            budget,
        )
    }

    #[test]
    fn each_row_draws_the_mesh_under_the_node() {
        // Three instances: translated by y = 0, 2, 4; the last also scaled by 2 and turned
        // a quarter about z (quaternion (0, 0, sin 45°, cos 45°)).
        let t = [0., 0., 0., 0., 2., 0., 0., 4., 0.];
        let s = [1., 1., 1., 1., 1., 1., 2., 2., 2.];
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let r = [0., 0., 0., 1., 0., 0., 0., 1., 0., 0., h, h];
        let extra: Vec<f32> = t.iter().chain(&s).chain(&r).copied().collect();
        let scene = load(
            &extra,
            json!([{"bufferView": 1, "byteOffset": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
                   {"bufferView": 1, "byteOffset": 36, "componentType": 5126, "count": 3, "type": "VEC3"},
                   {"bufferView": 1, "byteOffset": 72, "componentType": 5126, "count": 3, "type": "VEC4"}]),
            json!({"TRANSLATION": 1, "SCALE": 2, "ROTATION": 3}),
            &MemoryBudget::unlimited(),
        )
        .expect("loads");
        assert_eq!(scene.mesh.triangles.len(), 3);
        let p = &scene.mesh.positions;
        let near = |a: glam::Vec3, b: [f32; 3]| (a - glam::Vec3::from(b)).length() < 1e-5;
        assert!(near(p[1], [11., 0., 0.]) && near(p[4], [11., 2., 0.]), "{p:?}");
        // Vertex (1, 0, 0) scaled by 2 and turned to (0, 2, 0), then moved to y = 4.
        assert!(near(p[7], [10., 6., 0.]) && near(p[8], [8., 4., 0.]), "{p:?}");
    }

    #[test]
    fn attributes_of_different_counts_are_an_error_naming_the_node() {
        let extra = [0.0f32; 9];
        let msg = load(
            &extra,
            json!([{"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
                   {"bufferView": 1, "componentType": 5126, "count": 2, "type": "VEC3"}]),
            json!({"TRANSLATION": 1, "SCALE": 2}),
            &MemoryBudget::unlimited(),
        )
        .expect_err("refused")
        .to_string();
        assert!(msg.contains("EXT_mesh_gpu_instancing") && msg.contains("node 0"), "{msg}");
    }

    #[test]
    fn the_copies_are_charged_to_the_memory_budget_before_they_are_built() {
        let extra = [0.0f32; 9];
        let accessors = json!([{"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"}]);
        let attributes = json!({"TRANSLATION": 1});
        assert!(load(&extra, accessors.clone(), attributes.clone(), &MemoryBudget::bytes(1 << 20)).is_ok());
        // The same file under a budget smaller than three copies of the triangle.
        let one = crate::memory::MESH_BYTES_PER_VERTEX * 3 + crate::memory::MESH_BYTES_PER_TRIANGLE;
        let msg = load(&extra, accessors, attributes, &MemoryBudget::bytes(2 * one)).expect_err("over").to_string();
        assert!(msg.contains("3 triangles"), "{msg}");
    }
}
