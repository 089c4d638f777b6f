//! Deformation motion in `CAUSTIC_motion` (docs/contract.md): a node's `reference` accessor
//! holds its object's vertex positions at the frame and `positions` one accessor per step,
//! object space (the node's local frame), in the source's vertex order (Blender's), which is
//! not the mesh's: the exporter splits and reorders vertices. Each mesh vertex finds its
//! source vertex by position at the frame: the add-on writes `reference` from the same
//! evaluated mesh the exporter wrote, so the floats are equal bit for bit, and so are their
//! images under the node's world matrix (the same `transform_point3` the mesh loader
//! applies). Between steps a vertex moves linearly in object space, as Cycles interpolates
//! its vertex motion steps.

use super::Loader;
use crate::error::Result;
use glam::{Mat4, Quat, Vec3};
use std::collections::HashMap;

/// One node's vertex positions at the frame and at each step (object space).
pub(super) struct Deformation {
    /// At the frame.
    reference: Vec<Vec3>,
    /// Per step (as the scene's step times), each as long as `reference`.
    steps: Vec<Vec<Vec3>>,
}

impl Deformation {
    /// The source vertex of each mesh vertex in `positions` (world space, placed by
    /// `world`), or None when some vertex has no source at its position (the exporter's
    /// mesh is not the one the positions were taken from).
    pub(super) fn vertex_map(&self, world: &Mat4, positions: &[Vec3]) -> Option<Vec<u32>> {
        let key = |p: Vec3| p.to_array().map(f32::to_bits);
        let by_position: HashMap<[u32; 3], u32> =
            self.reference.iter().enumerate().map(|(k, p)| (key(world.transform_point3(*p)), k as u32)).collect();
        positions.iter().map(|p| by_position.get(&key(*p)).copied()).collect()
    }

    /// Source vertex `k` in object space at fraction `f` of step segment `i`.
    #[inline]
    pub(super) fn at(&self, k: u32, i: usize, f: f32) -> Vec3 {
        let (a, b) = (self.steps[i][k as usize], self.steps[i + 1][k as usize]);
        a + (b - a) * f
    }
}

/// The rotation that turns a triangle's face normal at the frame into its face normal
/// deformed (`frame`, `moved`: its corners): vertex normals turn with their face, which
/// keeps smooth shading on a mesh that bends without recomputing normals over its topology.
pub(super) fn normal_turn(frame: [Vec3; 3], moved: [Vec3; 3]) -> Quat {
    let n0 = (frame[1] - frame[0]).cross(frame[2] - frame[0]).normalize_or_zero();
    let n1 = (moved[1] - moved[0]).cross(moved[2] - moved[0]).normalize_or_zero();
    if n0 == Vec3::ZERO || n1 == Vec3::ZERO {
        return Quat::IDENTITY;
    }
    Quat::from_rotation_arc(n0, n1)
}

impl Loader<'_> {
    /// Reads node `n`'s deformation accessors (`reference`, `positions`), checked against
    /// `steps` step times.
    pub(super) fn deformation(
        &mut self,
        n: usize,
        doc: &gltf::Document,
        buffers: &[Vec<u8>],
        reference: usize,
        positions: &[usize],
        steps: usize,
    ) -> Result<Deformation> {
        let what = format!("node {n}: CAUSTIC_motion");
        if positions.len() != steps {
            return Err(self.err(format!("{what} has {} positions accessors for {steps} step times", positions.len())));
        }
        let read = |index: usize, field: &str| -> Result<Vec<Vec3>> {
            use gltf::accessor::{DataType as T, Dimensions as D};
            let acc = doc.accessors().nth(index).ok_or_else(|| {
                self.err(format!(
                    "{what}: {field} accessor {index} does not exist (the file has {})",
                    doc.accessors().len()
                ))
            })?;
            if acc.data_type() != T::F32 || acc.dimensions() != D::Vec3 || acc.normalized() {
                return Err(self.err(format!("{what}: {field} accessor {index} must be F32 Vec3")));
            }
            let get = |b: gltf::Buffer| buffers.get(b.index()).map(|v| v.as_slice());
            let iter = gltf::accessor::Iter::<[f32; 3]>::new(acc, get)
                .ok_or_else(|| self.err(format!("{what}: the {field} accessor has no data")))?;
            let v: Vec<Vec3> = iter.map(Vec3::from).collect();
            if !v.iter().all(|p| p.is_finite() && p.abs().max_element() <= super::MAX_COORDINATE) {
                return Err(self.err(format!("{what}: {field} has a position that is not finite or too large")));
            }
            Ok(v)
        };
        let reference = read(reference, "reference")?;
        let mut all = Vec::with_capacity(steps);
        for (s, &index) in positions.iter().enumerate() {
            let p = read(index, &format!("positions[{s}]"))?;
            if p.len() != reference.len() {
                return Err(self.err(format!(
                    "{what}: positions[{s}] has {} vertices, the reference {}",
                    p.len(),
                    reference.len()
                )));
            }
            all.push(p);
        }
        Ok(Deformation { reference, steps: all })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mesh_vertices_find_their_source_by_position_and_move_linearly() {
        let d = Deformation {
            reference: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            steps: vec![vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![Vec3::Z, Vec3::X * 3.0, Vec3::Y]],
        };
        let world = Mat4::from_translation(Vec3::new(0.5, 0.0, 2.0));
        // The mesh split vertex 1 in two and reordered them.
        let mesh = [Vec3::Y, Vec3::X, Vec3::ZERO, Vec3::X].map(|p| world.transform_point3(p));
        assert_eq!(d.vertex_map(&world, &mesh), Some(vec![2, 1, 0, 1]));
        assert_eq!(d.vertex_map(&world, &[Vec3::splat(9.0)]), None);
        assert_eq!(d.at(1, 0, 0.25), Vec3::X * 1.5);
        assert_eq!(d.at(0, 0, 0.5), Vec3::Z * 0.5);
        // A triangle tipped onto its side turns its normals with it.
        let q = normal_turn([Vec3::ZERO, Vec3::X, Vec3::Y], [Vec3::ZERO, Vec3::X, Vec3::Z]);
        assert!((q * Vec3::Z - Vec3::NEG_Y).length() < 1e-6);
    }
}
