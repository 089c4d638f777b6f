//! The pass indices and Cryptomatte names of the instances and materials
//! (`CAUSTIC_object_pass` on a node, `CAUSTIC_material_pass` on a material, docs/contract.md).

use super::Loader;
use crate::error::Result;
use crate::scene::ids::{InstanceIds, PassIds};
use crate::scene::material::Material;
use serde::Deserialize;

/// `CAUSTIC_object_pass` on a mesh's node: Blender's Object → Pass Index and the name of
/// the object's topmost parent (its Cryptomatte asset).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ObjectPassExt {
    #[serde(default)]
    pass_index: u32,
    asset: Option<String>,
}

/// `CAUSTIC_material_pass` on a material: Blender's Material → Pass Index.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialPassExt {
    #[serde(default)]
    pass_index: u32,
}

impl Loader<'_> {
    /// The ids of `instances` ((node index, node name, end of its triangles), in triangle
    /// order) and of `materials` (the scene's; a material the loader added or split keeps
    /// its name and takes the file's material of that name).
    pub(super) fn pass_ids(
        &self,
        doc: &gltf::Document,
        instances: &[(usize, String, u32)],
        materials: &[Material],
    ) -> Result<PassIds> {
        let mut parent = vec![None; doc.nodes().count()];
        for n in doc.nodes() {
            for c in n.children() {
                parent[c.index()] = Some(n.index());
            }
        }
        let name = |i: usize| {
            doc.nodes().nth(i).and_then(|n| n.name().map(str::to_string)).unwrap_or_else(|| format!("node {i}"))
        };
        let mut out = Vec::with_capacity(instances.len());
        for (node_index, node_name, tri_end) in instances {
            let node = doc.nodes().nth(*node_index).expect("validated index");
            let ext: Option<ObjectPassExt> = node
                .extension_value("CAUSTIC_object_pass")
                .map(|v| serde_json::from_value(v.clone()))
                .transpose()
                .map_err(|e| self.err(format!("node {node_index} ('{node_name}'): bad CAUSTIC_object_pass: {e}")))?;
            // Without the extension the asset is the node's root in the file's hierarchy,
            // which is Blender's topmost parent when the exporter kept the parenting.
            let asset = ext.as_ref().and_then(|e| e.asset.clone()).unwrap_or_else(|| {
                let mut root = *node_index;
                while let Some(p) = parent[root] {
                    root = p;
                }
                name(root)
            });
            out.push(InstanceIds {
                tri_end: *tri_end,
                name: node_name.clone(),
                asset,
                pass_index: ext.map_or(0, |e| e.pass_index),
            });
        }
        let mut file_materials = Vec::new();
        for m in doc.materials() {
            let index = match m.extension_value("CAUSTIC_material_pass") {
                Some(v) => {
                    serde_json::from_value::<MaterialPassExt>(v.clone())
                        .map_err(|e| {
                            self.err(format!(
                                "material {} ('{}'): bad CAUSTIC_material_pass: {e}",
                                m.index().unwrap_or(0),
                                m.name().unwrap_or("")
                            ))
                        })?
                        .pass_index
                }
                None => 0,
            };
            file_materials.push((m.name().unwrap_or("").to_string(), index));
        }
        let mats: Vec<(String, u32)> = materials
            .iter()
            .map(|m| {
                let index = file_materials.iter().find(|(n, _)| *n == m.name).map_or(0, |f| f.1);
                (m.name.clone(), index)
            })
            .collect();
        Ok(PassIds::new(&out, &mats))
    }
}
