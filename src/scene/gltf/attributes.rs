//! Attributes read by name (docs/contract.md, "Attributes"): the mesh attributes a primitive
//! carries as `_CAUSTIC_*` vertex attributes (named ones, the render colour, Pointiness,
//! Random Per Island) and the object attributes a mesh node carries in its extras
//! (`CAUSTIC_object_attributes`), kept per vertex on the world mesh for the keys some
//! material's graph reads; a material whose meshes lack one is named in a warning (it
//! reads 0 there, as in Cycles).

use super::Loader;
use super::quantized::read_f32;
use crate::error::Result;
use crate::scene::Material;
use crate::scene::mesh::{AttributeKey, Mesh};
use glam::Vec4;
use std::collections::HashSet;

/// The node extras that carry an instance's object attributes.
pub(super) const OBJECT_EXTRA: &str = "CAUSTIC_object_attributes";

/// An instance's object and instancer attributes (RGBA, as Cycles looks them up).
pub(super) type ObjectAttributes = Vec<(AttributeKey, Vec4)>;

/// Every attribute the materials' surface graphs read by name.
pub(super) fn keys_read(materials: &[Material]) -> HashSet<AttributeKey> {
    materials
        .iter()
        .filter_map(|m| m.nodes.as_ref())
        .flat_map(|p| p.attributes.iter().map(|(k, _)| k.clone()))
        .collect()
}

impl Loader<'_> {
    /// The object attributes of node `node_index` that some graph reads, from its extras.
    pub(super) fn object_attributes(
        &self,
        value: &serde_json::Value,
        node_index: usize,
        node_name: &str,
    ) -> Result<ObjectAttributes> {
        let mut out = Vec::new();
        let Some(ext) = value.pointer(&format!("/nodes/{node_index}/extras/{OBJECT_EXTRA}")) else {
            return Ok(out);
        };
        let what = format!("node {node_index} ('{node_name}'): extras.{OBJECT_EXTRA}");
        let table = ext.as_object().ok_or_else(|| self.err(format!("{what} must be an object")))?;
        for (kind, entries) in table {
            let make: fn(String) -> AttributeKey = match kind.as_str() {
                "object" => AttributeKey::Object,
                "instancer" => AttributeKey::Instancer,
                other => return Err(self.err(format!("{what}: unknown kind '{other}' (object or instancer)"))),
            };
            let entries = entries.as_object().ok_or_else(|| self.err(format!("{what}.{kind} must be an object")))?;
            for (name, v) in entries {
                let nums: Option<Vec<f32>> =
                    v.as_array().map(|a| a.iter().filter_map(|x| x.as_f64()).map(|x| x as f32).collect());
                let rgba = match nums {
                    Some(n) if n.len() == 4 && v.as_array().is_some_and(|a| a.len() == 4) => Vec4::from_slice(&n),
                    _ => return Err(self.err(format!("{what}.{kind}['{name}'] must be four numbers (RGBA)"))),
                };
                if !rgba.is_finite() {
                    return Err(self.err(format!("{what}.{kind}['{name}'] is not finite: {rgba}")));
                }
                let key = make(name.clone());
                if self.attribute_keys.contains(&key) {
                    out.push((key, rgba));
                }
            }
        }
        Ok(out)
    }

    /// Stores the attributes of a primitive whose `nv` vertices were appended to `out` from
    /// vertex `base` on: its `_CAUSTIC_*` vertex attributes and its instance's object
    /// attributes, for the keys some graph reads; notes the keys its material reads that it
    /// lacks. `what` names the primitive in errors, `mesh_name` the mesh in warnings.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn primitive_attributes(
        &mut self,
        prim: &gltf::Primitive,
        buffers: &[Vec<u8>],
        what: &str,
        mesh_name: &str,
        material: (u32, &Material),
        per_object: &ObjectAttributes,
        base: usize,
        nv: usize,
        out: &mut Mesh,
    ) -> Result<()> {
        if self.attribute_keys.is_empty() {
            return Ok(());
        }
        let mut present: HashSet<AttributeKey> = HashSet::new();
        for (semantic, acc) in prim.attributes() {
            let name = semantic.to_string();
            let key = match AttributeKey::from_semantic(&name) {
                None => continue,
                Some(Ok(key)) => key,
                Some(Err(why)) => return Err(self.err(format!("{what}: attribute {name}: {why}"))),
            };
            if !self.attribute_keys.contains(&key) {
                continue;
            }
            let label = format!("{what}: {} ({name})", key.describe());
            use gltf::accessor::Dimensions as D;
            if acc.data_type() != gltf::accessor::DataType::F32 {
                return Err(self.err(format!(
                    "{label}: accessor {} is of {:?} components; FLOAT expected",
                    acc.index(),
                    acc.data_type()
                )));
            }
            let data = |b: gltf::Buffer| buffers.get(b.index()).map(|v| v.as_slice());
            let rows: Vec<Vec4> = match acc.dimensions() {
                D::Scalar => {
                    gltf::accessor::Iter::<f32>::new(acc.clone(), data).map(|it| it.map(Vec4::splat).collect())
                }
                D::Vec2 => read_f32::<2>(&acc, buffers, false)
                    .map(|v| v.into_iter().map(|[x, y]| Vec4::new(x, y, 0.0, 0.0)).collect()),
                D::Vec3 => read_f32::<3>(&acc, buffers, false)
                    .map(|v| v.into_iter().map(|[x, y, z]| Vec4::new(x, y, z, 0.0)).collect()),
                D::Vec4 => read_f32::<4>(&acc, buffers, false).map(|v| v.into_iter().map(Vec4::from).collect()),
                other => {
                    return Err(
                        self.err(format!("{label}: accessor {} is {other:?}; SCALAR or VEC2-4 expected", acc.index()))
                    );
                }
            }
            .ok_or_else(|| self.err(format!("{label}: cannot read accessor {}", acc.index())))?;
            if rows.len() != nv {
                return Err(self.err(format!("{label} has {} entries for {nv} vertices", rows.len())));
            }
            if let Some(bad) = rows.iter().position(|r| !r.is_finite()) {
                return Err(self.err(format!("{label}: vertex {bad} has a NaN or infinite value ({})", rows[bad])));
            }
            let components = acc.dimensions().multiplicity();
            out.attribute_mut(&key).set(base, components, rows.into_iter());
            present.insert(key);
        }
        for (key, rgba) in per_object {
            out.attribute_mut(key).set(base, 4, std::iter::repeat_n(*rgba, nv));
            present.insert(key.clone());
        }
        let (index, mat) = material;
        for (key, _) in mat.nodes.iter().flat_map(|p| p.attributes.iter()) {
            if !present.contains(key) {
                let meshes = self.attribute_gaps.entry((index, key.clone())).or_default();
                if !meshes.iter().any(|m| m == mesh_name) {
                    meshes.push(mesh_name.to_string());
                }
            }
        }
        Ok(())
    }

    /// Pads every attribute to the whole mesh and names, per material and attribute, the
    /// meshes that lack one it reads.
    pub(super) fn finish_attributes(&mut self, mesh: &mut Mesh, materials: &[Material]) {
        let n = mesh.positions.len();
        for a in &mut mesh.attributes {
            a.pad(n);
        }
        let mut gaps: Vec<_> = std::mem::take(&mut self.attribute_gaps).into_iter().collect();
        gaps.sort_by(|a, b| (a.0.0, format!("{:?}", a.0.1)).cmp(&(b.0.0, format!("{:?}", b.0.1))));
        for ((index, key), meshes) in gaps {
            let Some(mat) = materials.get(index as usize) else { continue };
            let Some(node) =
                mat.nodes.iter().flat_map(|p| p.attributes.iter()).find(|(k, _)| *k == key).map(|(_, n)| n)
            else {
                continue;
            };
            let shown: Vec<String> = meshes.iter().take(5).map(|m| format!("'{m}'")).collect();
            let more = if meshes.len() > 5 { format!(" and {} more", meshes.len() - 5) } else { String::new() };
            self.warn(format!(
                "material '{}': {node}: {} is not on mesh {}{more}: it reads 0 there (Alpha 1), as Cycles reads an \
                 attribute a mesh does not have",
                mat.name,
                key.describe(),
                shown.join(", ")
            ));
        }
    }
}
