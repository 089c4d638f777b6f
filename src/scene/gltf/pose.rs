//! A mesh instance's static pose, as glTF defines the scene without animation: morph
//! targets blended by the node's (else the mesh's) default weights, and skinned meshes
//! deformed by their joints at the joint nodes' world transforms (the skinned node's own
//! transform is then ignored, glTF 2.0 §3.7.3). Blender's importer shows the same pose
//! when no animation is played.

use super::Loader;
use super::quantized::read_f32;
use crate::error::Result;
use glam::{Mat4, Vec3, Vec4};

/// What deforms one mesh instance's vertices.
#[derive(Default)]
pub(super) struct NodePose {
    /// Morph target weights (empty: no morphing).
    pub weights: Vec<f32>,
    /// Per joint of the node's skin, the joint's world matrix times its inverse bind
    /// matrix; `None` for a mesh without a skin.
    pub joints: Option<Vec<Mat4>>,
}

/// A primitive's vertices under its pose: world matrix per vertex where skinned.
pub(super) enum VertexTransforms {
    /// Every vertex by the node's world matrix.
    Uniform,
    /// Each vertex by its blend of joint matrices (already in world space).
    Skinned(Vec<Mat4>),
}

/// Every node's world matrix through its parent chain, so that joints outside the
/// rendered scene's trees still have one (the hierarchy was checked acyclic).
pub(super) fn node_worlds(doc: &gltf::Document) -> Vec<Mat4> {
    let n = doc.nodes().count();
    let mut parent = vec![None; n];
    for node in doc.nodes() {
        for c in node.children() {
            parent[c.index()] = Some(node.index());
        }
    }
    let locals: Vec<Mat4> = doc.nodes().map(|nd| Mat4::from_cols_array_2d(&nd.transform().matrix())).collect();
    let mut world: Vec<Option<Mat4>> = vec![None; n];
    for start in 0..n {
        let mut chain = vec![start];
        while let Some(p) = parent[*chain.last().expect("non-empty")] {
            if world[p].is_some() {
                break;
            }
            chain.push(p);
        }
        for &i in chain.iter().rev() {
            if world[i].is_none() {
                let up = parent[i].and_then(|p| world[p]).unwrap_or(Mat4::IDENTITY);
                world[i] = Some(up * locals[i]);
            }
        }
    }
    world.into_iter().map(|w| w.expect("every node reached")).collect()
}

impl Loader<'_> {
    /// The pose of the mesh instance at `node`: its weights and its skin's joint matrices.
    pub(super) fn node_pose(
        &self,
        node: &gltf::Node,
        mesh: &gltf::Mesh,
        worlds: &[Mat4],
        buffers: &[Vec<u8>],
    ) -> Result<NodePose> {
        let what =
            node.name().map(|n| format!("node {} ('{n}')", node.index())).unwrap_or(format!("node {}", node.index()));
        let weights: Vec<f32> = node.weights().or(mesh.weights()).map(<[f32]>::to_vec).unwrap_or_default();
        if let Some(bad) = weights.iter().find(|w| !w.is_finite()) {
            return Err(self.err(format!("{what}: morph target weight {bad} is not finite")));
        }
        let joints = match node.skin() {
            None => None,
            Some(skin) => {
                let nodes: Vec<usize> = skin.joints().map(|j| j.index()).collect();
                let inverse_bind: Vec<Mat4> = match skin.inverse_bind_matrices() {
                    // glTF: without the accessor, every inverse bind matrix is the identity.
                    None => vec![Mat4::IDENTITY; nodes.len()],
                    Some(_) => {
                        let reader = skin.reader(|b| buffers.get(b.index()).map(|v| v.as_slice()));
                        let m: Vec<Mat4> = reader
                            .read_inverse_bind_matrices()
                            .ok_or_else(|| self.err(format!("{what}: cannot read the skin's inverse bind matrices")))?
                            .map(|c| Mat4::from_cols_array_2d(&c))
                            .collect();
                        if m.len() < nodes.len() {
                            return Err(self.err(format!(
                                "{what}: the skin has {} joints but {} inverse bind matrices",
                                nodes.len(),
                                m.len()
                            )));
                        }
                        m
                    }
                };
                let matrices: Vec<Mat4> = nodes.iter().zip(&inverse_bind).map(|(&j, ib)| worlds[j] * *ib).collect();
                if matrices.iter().any(|m| !m.is_finite()) {
                    return Err(self.err(format!("{what}: a joint matrix of the skin is not finite")));
                }
                Some(matrices)
            }
        };
        Ok(NodePose { weights, joints })
    }

    /// Adds the weighted morph target deltas of `prim` to its positions, normals and tangents.
    pub(super) fn apply_morph(
        &self,
        prim: &gltf::Primitive,
        weights: &[f32],
        buffers: &[Vec<u8>],
        what: &str,
        (positions, normals, tangents): (&mut [Vec3], Option<&mut Vec<Vec3>>, Option<&mut Vec<Vec4>>),
    ) -> Result<()> {
        let targets: Vec<gltf::mesh::MorphTarget> = prim.morph_targets().collect();
        if targets.is_empty() || weights.iter().all(|&w| w == 0.0) {
            return Ok(());
        }
        let nv = positions.len();
        let delta = |acc: Option<gltf::Accessor>, name: &str, t: usize| -> Result<Option<Vec<[f32; 3]>>> {
            let Some(acc) = acc else { return Ok(None) };
            let d = read_f32::<3>(&acc, buffers, false)
                .ok_or_else(|| self.err(format!("{what}: cannot read morph target {t}'s {name}")))?;
            if d.len() != nv {
                return Err(
                    self.err(format!("{what}: morph target {t}'s {name} has {} entries for {nv} vertices", d.len()))
                );
            }
            if d.iter().flatten().any(|x| !x.is_finite()) {
                return Err(self.err(format!("{what}: morph target {t}'s {name} holds a NaN or infinite value")));
            }
            Ok(Some(d))
        };
        let (mut normals, mut tangents) = (normals, tangents);
        for (t, target) in targets.iter().enumerate() {
            let w = weights.get(t).copied().unwrap_or(0.0);
            if w == 0.0 {
                continue;
            }
            if let Some(d) = delta(target.positions(), "POSITION", t)? {
                for (p, d) in positions.iter_mut().zip(d) {
                    *p += w * Vec3::from(d);
                }
            }
            if let Some(n) = normals.as_deref_mut()
                && let Some(d) = delta(target.normals(), "NORMAL", t)?
            {
                for (n, d) in n.iter_mut().zip(d) {
                    *n += w * Vec3::from(d);
                }
            }
            // Tangent deltas move the direction only; the handedness (w) stays.
            if let Some(tg) = tangents.as_deref_mut()
                && let Some(d) = delta(target.tangents(), "TANGENT", t)?
            {
                for (tg, d) in tg.iter_mut().zip(d) {
                    *tg += (w * Vec3::from(d)).extend(0.0);
                }
            }
        }
        Ok(())
    }

    /// The world matrix of each vertex of a skinned primitive: the blend of its joints'
    /// matrices by JOINTS_n / WEIGHTS_n (every set the primitive has).
    pub(super) fn skin_vertices(
        &self,
        prim: &gltf::Primitive,
        joints: &[Mat4],
        nv: usize,
        buffers: &[Vec<u8>],
        what: &str,
    ) -> Result<VertexTransforms> {
        let mut blend = vec![Mat4::ZERO; nv];
        let mut total = vec![0.0f32; nv];
        let mut sets = 0;
        for set in 0.. {
            let (Some(ja), Some(wa)) =
                (prim.get(&gltf::Semantic::Joints(set)), prim.get(&gltf::Semantic::Weights(set)))
            else {
                break;
            };
            sets += 1;
            let ids = read_f32::<4>(&ja, buffers, false)
                .ok_or_else(|| self.err(format!("{what}: cannot read JOINTS_{set}")))?;
            let ws = read_f32::<4>(&wa, buffers, false)
                .ok_or_else(|| self.err(format!("{what}: cannot read WEIGHTS_{set}")))?;
            if ids.len() != nv || ws.len() != nv {
                return Err(self.err(format!("{what}: JOINTS_{set}/WEIGHTS_{set} do not have one entry per vertex")));
            }
            for (v, (id, w)) in ids.iter().zip(&ws).enumerate() {
                for k in 0..4 {
                    if w[k] == 0.0 {
                        continue;
                    }
                    if !w[k].is_finite() {
                        return Err(self.err(format!("{what}: vertex {v}'s WEIGHTS_{set} is not finite")));
                    }
                    let j = id[k] as usize;
                    let m = joints.get(j).ok_or_else(|| {
                        self.err(format!(
                            "{what}: vertex {v} names joint {j}, but the skin has {} joints",
                            joints.len()
                        ))
                    })?;
                    blend[v] += *m * w[k];
                    total[v] += w[k];
                }
            }
        }
        if sets == 0 {
            return Ok(VertexTransforms::Uniform);
        }
        // glTF asks for weights that sum to 1; renormalise what rounding (or an exporter)
        // left off, as viewers do. A vertex with no weight at all keeps the skin's first
        // joint, so that it does not collapse to the origin.
        for (m, t) in blend.iter_mut().zip(&total) {
            *m = if *t > 0.0 { *m * (1.0 / t) } else { joints.first().copied().unwrap_or(Mat4::IDENTITY) };
        }
        Ok(VertexTransforms::Skinned(blend))
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use serde_json::json;

    use crate::scene::gltf::tests::load_triangle_after as load;

    fn floats(v: &[f32]) -> Vec<u8> {
        v.iter().flat_map(|f| f.to_le_bytes()).collect()
    }

    fn sorted(scene: &crate::scene::Scene) -> Vec<[f32; 3]> {
        let mut p: Vec<[f32; 3]> = scene.mesh.positions.iter().map(|v| v.to_array()).collect();
        p.sort_by(|a, b| a.partial_cmp(b).unwrap());
        p
    }

    /// A morph target that lifts every vertex by z = 1, with `weights` on the mesh and
    /// `node_weights` (if any) on the node.
    fn morphed(mesh_weights: serde_json::Value, node_weights: Option<serde_json::Value>) -> crate::scene::Scene {
        let delta = floats(&[0., 0., 1., 0., 0., 1., 0., 0., 1.]);
        let mut node = json!({"mesh": 0});
        if let Some(w) = node_weights {
            node["weights"] = w;
        }
        load(
            &delta,
            json!({
                "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 36}],
                "accessors": [
                    {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                    {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 1], "max": [0, 0, 1]}
                ],
                "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "targets": [{"POSITION": 1}]}],
                            "weights": mesh_weights}],
                "nodes": [node]
            }),
        )
        .expect("loads")
    }

    #[test]
    fn morph_targets_blend_by_the_default_weights_the_node_overriding_the_mesh() {
        assert!(morphed(json!([0.5]), None).mesh.positions.iter().all(|p| p.z == 0.5));
        assert!(morphed(json!([0.5]), Some(json!([0.25]))).mesh.positions.iter().all(|p| p.z == 0.25));
        assert!(morphed(json!([0.0]), None).mesh.positions.iter().all(|p| p.z == 0.0));
    }

    /// The triangle skinned to two joints: vertex 0 and 1 wholly to joint 0, vertex 2
    /// half to each; joint 0 at x + 1, joint 1 at y + 2 (as a child of a node at y + 1),
    /// identity inverse binds; the skinned node itself sits at z + 100, which glTF ignores.
    fn skinned(joint_of_vertex_2: u8) -> crate::error::Result<crate::scene::Scene> {
        let mut extra = vec![0u8, 0, 0, 0, 0, 0, 0, 0, 0, joint_of_vertex_2, 0, 0];
        extra.extend(floats(&[1., 0., 0., 0., 1., 0., 0., 0., 0.5, 0.5, 0., 0.]));
        load(
            &extra,
            json!({
                "bufferViews": [{"buffer": 0, "byteLength": 36},
                                {"buffer": 0, "byteOffset": 36, "byteLength": 12},
                                {"buffer": 0, "byteOffset": 48, "byteLength": 48}],
                "accessors": [
                    {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                    {"bufferView": 1, "componentType": 5121, "count": 3, "type": "VEC4"},
                    {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC4"}
                ],
                "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "JOINTS_0": 1, "WEIGHTS_0": 2}}]}],
                "skins": [{"joints": [1, 3]}],
                "nodes": [
                    {"mesh": 0, "skin": 0, "translation": [0, 0, 100]},
                    {"translation": [1, 0, 0]},
                    {"translation": [0, 1, 0], "children": [3]},
                    {"translation": [0, 1, 0]}
                ],
                "scenes": [{"nodes": [0, 1, 2]}]
            }),
        )
    }

    #[test]
    fn skinned_vertices_follow_their_joints_and_not_the_skinned_node() {
        let scene = skinned(1).expect("loads");
        // Vertex 2 (0,1,0): half of (1,1,0) and half of (0,3,0) = (0.5, 2, 0).
        let want = [[1., 0., 0.], [2., 0., 0.], [0.5, 2., 0.]];
        let got = sorted(&scene);
        let mut want = want.to_vec();
        want.sort_by(|a, b| a.partial_cmp(b).unwrap());
        for (g, w) in got.iter().zip(&want) {
            assert!((Vec3::from(*g) - Vec3::from(*w)).length() < 1e-6, "{got:?} vs {want:?}");
        }
    }

    #[test]
    fn a_vertex_naming_a_joint_the_skin_lacks_is_an_error_naming_it() {
        let msg = skinned(7).expect_err("refused").to_string();
        assert!(msg.contains("joint 7") && msg.contains("2 joints"), "{msg}");
    }

    #[test]
    fn animations_are_named_in_a_warning_that_they_are_not_played() {
        let times = floats(&[0.0, 1.0]);
        let mut extra = times;
        extra.extend(floats(&[0., 0., 0., 5., 0., 0.]));
        let scene = load(
            &extra,
            json!({
                "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 8},
                                {"buffer": 0, "byteOffset": 44, "byteLength": 24}],
                "accessors": [
                    {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                    {"bufferView": 1, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0], "max": [1]},
                    {"bufferView": 2, "componentType": 5126, "count": 2, "type": "VEC3"}
                ],
                "animations": [{"name": "Slide", "samplers": [{"input": 1, "output": 2}],
                                "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}]}]
            }),
        )
        .expect("loads");
        assert!(
            scene.warnings.iter().any(|w| w.contains("'Slide'") && w.contains("not played")),
            "{:?}",
            scene.warnings
        );
        assert!(sorted(&scene).iter().all(|p| p[0] <= 1.0), "rest pose kept");
    }
}
