//! What the index and Cryptomatte passes say about a hit: the object's and material's pass
//! indices (Blender's `pass_index`) and the Cryptomatte ids of the object, its material and
//! its asset (the topmost parent), as Cycles names them (`intern/cycles/blender/object.cpp`:
//! the object's name, the top parent's name; the material's name).

use crate::cryptomatte::{Kind, id_of};

/// Per-instance and per-material ids, looked up by triangle.
#[derive(Clone, Debug, Default)]
pub struct PassIds {
    /// Per instance (as `Scene::instances`), the end of its triangle range: instances
    /// cover the mesh's triangles in order, so a triangle's instance is a binary search.
    tri_end: Vec<u32>,
    /// Per instance: object pass index.
    object_index: Vec<f32>,
    /// Per instance: Cryptomatte ids of the object and of its asset.
    object_ids: Vec<[u32; 2]>,
    /// Per material: pass index.
    material_index: Vec<f32>,
    /// Per material: Cryptomatte id.
    material_ids: Vec<u32>,
    /// Distinct names per Cryptomatte layer (`Kind::index`), for the manifests.
    names: [Vec<String>; 3],
}

/// One instance's part of [`PassIds`].
#[derive(Clone, Debug)]
pub struct InstanceIds {
    /// End of its triangle range in the mesh.
    pub tri_end: u32,
    /// Object name (Blender's object name).
    pub name: String,
    /// Asset name (the topmost parent's name; the object's own without a parent).
    pub asset: String,
    /// Blender's object pass index.
    pub pass_index: u32,
}

impl PassIds {
    /// Ids of instances (in triangle order) and materials (name, pass index).
    pub fn new(instances: &[InstanceIds], materials: &[(String, u32)]) -> Self {
        let mut names: [Vec<String>; 3] = Default::default();
        let mut note = |k: Kind, n: &str| {
            let list = &mut names[k.index()];
            if !list.iter().any(|x| x == n) {
                list.push(n.to_string());
            }
        };
        for i in instances {
            note(Kind::Object, &i.name);
            note(Kind::Asset, &i.asset);
        }
        for (m, _) in materials {
            note(Kind::Material, m);
        }
        PassIds {
            tri_end: instances.iter().map(|i| i.tri_end).collect(),
            object_index: instances.iter().map(|i| i.pass_index as f32).collect(),
            object_ids: instances.iter().map(|i| [id_of(&i.name), id_of(&i.asset)]).collect(),
            material_index: materials.iter().map(|m| m.1 as f32).collect(),
            material_ids: materials.iter().map(|m| id_of(&m.0)).collect(),
            names,
        }
    }

    /// Appends the ids of a second scene whose triangles follow this one's from
    /// `tri_offset` and whose materials follow from `material_offset` (the viewport's merge
    /// of added objects: `server::merge`).
    pub fn append(&mut self, other: &PassIds, tri_offset: u32, material_offset: u32) {
        // Material ids are indexed by material: pad for materials this scene has no ids of.
        self.material_index.resize(material_offset as usize, 0.0);
        self.material_ids.resize(material_offset as usize, 0);
        self.tri_end.extend(other.tri_end.iter().map(|e| e + tri_offset));
        self.object_index.extend(&other.object_index);
        self.object_ids.extend(&other.object_ids);
        self.material_index.extend(&other.material_index);
        self.material_ids.extend(&other.material_ids);
        for (mine, theirs) in self.names.iter_mut().zip(&other.names) {
            for n in theirs {
                if !mine.contains(n) {
                    mine.push(n.clone());
                }
            }
        }
    }

    /// The instance holding triangle `tri`.
    #[inline]
    fn instance(&self, tri: u32) -> Option<usize> {
        let i = self.tri_end.partition_point(|&end| end <= tri);
        (i < self.tri_end.len()).then_some(i)
    }

    /// Object and material pass indices at triangle `tri` of material `material`.
    #[inline]
    pub fn indices(&self, tri: u32, material: u32) -> [f32; 2] {
        let ob = self.instance(tri).map_or(0.0, |i| self.object_index[i]);
        [ob, self.material_index.get(material as usize).copied().unwrap_or(0.0)]
    }

    /// The pass index of material `material` (0 for one without ids).
    #[inline]
    pub fn material_index(&self, material: u32) -> f32 {
        self.material_index.get(material as usize).copied().unwrap_or(0.0)
    }

    /// Cryptomatte ids (object, material, asset; `Kind::index` order) at triangle `tri`.
    #[inline]
    pub fn crypto(&self, tri: u32, material: u32) -> [u32; 3] {
        let [ob, asset] = self.instance(tri).map_or([0, 0], |i| self.object_ids[i]);
        [ob, self.material_ids.get(material as usize).copied().unwrap_or(0), asset]
    }

    /// The distinct names of layer `k`, for its manifest.
    pub fn names(&self, k: Kind) -> &[String] {
        &self.names[k.index()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangles_find_their_instance() {
        let inst = |end, name: &str, asset: &str, pass_index| InstanceIds {
            tri_end: end,
            name: name.into(),
            asset: asset.into(),
            pass_index,
        };
        // An instance without triangles (end 2 twice) is skipped by the search.
        let ids = PassIds::new(
            &[inst(2, "A", "A", 3), inst(2, "Empty", "Empty", 9), inst(5, "B", "A", 4)],
            &[("M".into(), 7)],
        );
        assert_eq!(ids.indices(0, 0), [3.0, 7.0]);
        assert_eq!(ids.indices(2, 0), [4.0, 7.0]);
        assert_eq!(ids.indices(9, 1), [0.0, 0.0]);
        assert_eq!(ids.crypto(4, 0), [id_of("B"), id_of("M"), id_of("A")]);
        assert_eq!(ids.names(Kind::Asset), ["A", "Empty"]);
    }
}
