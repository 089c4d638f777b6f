//! Primitives to world-space triangles: attributes read and checked, strips and fans
//! unrolled, degenerate triangles dropped, mirrored instances rewound, and MikkTSpace
//! tangents generated for normal maps when the file has none.

use super::pose::{NodePose, VertexTransforms};
use super::quantized::{Quantization, read_f32};
use super::{Loader, MAX_COORDINATE};
use crate::error::Result;
use crate::math::Rgb;
use crate::memory;
use crate::scene::{Material, Mesh};
use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
use std::collections::HashMap;

impl Loader<'_> {
    /// Charges the world-space mesh that flattening `instances` will build (each
    /// instance copies its mesh's vertices and triangles), before any of it is read:
    /// accessor counts are known from the JSON alone, and a sparse accessor or a shared
    /// subtree can declare far more than the file holds.
    pub(super) fn charge_mesh(&self, doc: &gltf::Document, instances: &[(usize, Mat4, bool)]) -> Result<()> {
        use gltf::mesh::Mode;
        let mut per_mesh: HashMap<usize, (u64, u64)> = HashMap::new();
        let (mut vertices, mut triangles) = (0u64, 0u64);
        // Hidden nodes (`KHR_node_visibility`) add no triangles.
        for (node_index, _, _) in instances.iter().filter(|i| i.2) {
            let Some(node) = doc.nodes().nth(*node_index) else { continue };
            let Some(m) = node.mesh() else { continue };
            let copies = super::gpu_instancing::copies(&node, doc);
            let (v, t) = *per_mesh.entry(m.index()).or_insert_with(|| {
                let (mut v, mut t) = (0u64, 0u64);
                for prim in m.primitives() {
                    let n = prim.get(&gltf::Semantic::Positions).map_or(0, |a| a.count() as u64);
                    let idx = prim.indices().map_or(n, |a| a.count() as u64);
                    v += n;
                    t += match prim.mode() {
                        Mode::Triangles => idx / 3,
                        Mode::TriangleStrip | Mode::TriangleFan => idx.saturating_sub(2),
                        _ => 0,
                    };
                }
                (v, t)
            });
            vertices = vertices.saturating_add(v.saturating_mul(copies));
            triangles = triangles.saturating_add(t.saturating_mul(copies));
        }
        // Attributes read by name take up to five floats a vertex each (`Mesh::attributes`).
        let per_vertex = memory::MESH_BYTES_PER_VERTEX + self.attribute_keys.len() as u64 * 20;
        let bytes = vertices
            .saturating_mul(per_vertex)
            .saturating_add(triangles.saturating_mul(memory::MESH_BYTES_PER_TRIANGLE));
        self.budget.charge(format!("the mesh ({triangles} triangles and {vertices} vertices after instancing)"), bytes)
    }

    /// Appends every triangle primitive of `m` under `world` in its `pose` (morph
    /// weights, skin); returns the number of degenerate triangles dropped.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn append_mesh(
        &mut self,
        m: &gltf::Mesh,
        world: &Mat4,
        pose: &NodePose,
        buffers: &[Vec<u8>],
        materials: &[Material],
        default_material: u32,
        per_object: &super::attributes::ObjectAttributes,
        out: &mut Mesh,
    ) -> Result<usize> {
        let mesh_name =
            m.name().map(|n| format!("mesh {} ('{n}')", m.index())).unwrap_or_else(|| format!("mesh {}", m.index()));
        let normal_matrix = Mat3::from_mat4(*world).inverse().transpose();
        let det = Mat3::from_mat4(*world).determinant();
        if !det.is_finite() {
            return Err(self.err(format!("{mesh_name}: an instance's transform is not finite (scale too large?)")));
        }
        // A skinned mesh ignores its node's transform (glTF 2.0 §3.7.3): only the joints place it.
        if det == 0.0 && pose.joints.is_none() {
            self.warn(format!("{mesh_name}: an instance has a singular transform (zero scale) and was skipped"));
            return Ok(0);
        }
        let flip = det < 0.0;
        let mut degenerate = 0;
        for prim in m.primitives() {
            let what = format!("{mesh_name} primitive {}", prim.index());
            use gltf::mesh::Mode;
            let mode = prim.mode();
            if matches!(mode, Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip) {
                self.warn(format!("{what}: {mode:?} primitives (points/lines) are not rendered and were skipped"));
                continue;
            }
            let reader = prim.reader(|b| buffers.get(b.index()).map(|v| v.as_slice()));
            let pos_acc = prim
                .get(&gltf::Semantic::Positions)
                .ok_or_else(|| self.err(format!("{what}: no POSITION attribute")))?;
            // Any component type the file may use (validate.rs checked it against glTF
            // and KHR_mesh_quantization): integers are dequantized here, their scale and
            // offset are in the node's transform.
            let mut positions: Vec<Vec3> = read_f32::<3>(&pos_acc, buffers, false)
                .ok_or_else(|| self.err(format!("{what}: cannot read POSITION")))?
                .into_iter()
                .map(Vec3::from)
                .collect();
            if positions.len() != pos_acc.count() {
                return Err(self.err(format!("{what}: POSITION data is shorter than its accessor count")));
            }
            if let Some(bad) = positions.iter().position(|p| !p.is_finite()) {
                return Err(self.err(format!("{what}: vertex {bad} has a NaN or infinite position")));
            }
            let nv = positions.len();
            let read_exact = |v: Option<Vec<Vec3>>, name: &str| -> Result<Option<Vec<Vec3>>> {
                match v {
                    Some(v) if v.len() != nv => {
                        Err(self.err(format!("{what}: {name} has {} entries for {nv} vertices", v.len())))
                    }
                    other => Ok(other),
                }
            };
            let attribute = |semantic: gltf::Semantic| prim.get(&semantic).map(|acc| (acc, semantic.to_string()));
            let unreadable = |name: &str| self.err(format!("{what}: cannot read {name}"));
            let normals = match attribute(gltf::Semantic::Normals) {
                Some((acc, name)) => read_f32::<3>(&acc, buffers, false)
                    .map(|v| v.into_iter().map(Vec3::from).collect())
                    .ok_or_else(|| unreadable(&name))
                    .map(Some)?,
                None => None,
            };
            let mut normals = read_exact(normals, "NORMAL")?;
            let mut tangents: Option<Vec<Vec4>> = match attribute(gltf::Semantic::Tangents) {
                Some((acc, name)) => Some(
                    read_f32::<4>(&acc, buffers, false)
                        .ok_or_else(|| unreadable(&name))?
                        .into_iter()
                        .map(Vec4::from)
                        .collect(),
                ),
                None => None,
            };
            // Without KHR_mesh_quantization, integer coordinates are normalized (core glTF).
            let quantized = self.quantization == Quantization::Allowed;
            let uv = |set: u32| -> Result<Option<Vec<Vec2>>> {
                match attribute(gltf::Semantic::TexCoords(set)) {
                    Some((acc, name)) => Ok(Some(
                        read_f32::<2>(&acc, buffers, !quantized)
                            .ok_or_else(|| unreadable(&name))?
                            .into_iter()
                            .map(Vec2::from)
                            .collect(),
                    )),
                    None => Ok(None),
                }
            };
            let (uv0, uv1) = (uv(0)?, uv(1)?);
            let colors: Option<Vec<Vec4>> = reader.read_colors(0).map(|c| c.into_rgba_f32().map(Vec4::from).collect());
            for (len, name) in [
                (tangents.as_ref().map(Vec::len), "TANGENT"),
                (uv0.as_ref().map(Vec::len), "TEXCOORD_0"),
                (uv1.as_ref().map(Vec::len), "TEXCOORD_1"),
                (colors.as_ref().map(Vec::len), "COLOR_0"),
            ] {
                if let Some(l) = len
                    && l != nv
                {
                    return Err(self.err(format!("{what}: {name} has {l} entries for {nv} vertices")));
                }
            }
            self.apply_morph(
                &prim,
                &pose.weights,
                buffers,
                &what,
                (&mut positions, normals.as_mut(), tangents.as_mut()),
            )?;
            let transforms = match &pose.joints {
                Some(joints) => self.skin_vertices(&prim, joints, nv, buffers, &what)?,
                None => VertexTransforms::Uniform,
            };
            let raw_indices: Vec<u32> = match reader.read_indices() {
                Some(ix) => ix.into_u32().collect(),
                None => (0..nv as u32).collect(),
            };
            if let Some(&bad) = raw_indices.iter().find(|&&i| i as usize >= nv) {
                return Err(self.err(format!("{what}: index {bad} is out of range (the primitive has {nv} vertices)")));
            }
            let tris: Vec<[u32; 3]> = match mode {
                Mode::Triangles => raw_indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
                Mode::TriangleStrip => (0..raw_indices.len().saturating_sub(2))
                    .map(|i| {
                        let (a, b, c) = (raw_indices[i], raw_indices[i + 1], raw_indices[i + 2]);
                        if i % 2 == 0 { [a, b, c] } else { [b, a, c] }
                    })
                    .collect(),
                Mode::TriangleFan => (1..raw_indices.len().saturating_sub(1))
                    .map(|i| [raw_indices[0], raw_indices[i], raw_indices[i + 1]])
                    .collect(),
                _ => unreachable!("points and lines skipped above"),
            };
            let material_index = prim.material().index().map(|i| i as u32).unwrap_or(default_material);
            let material = &materials[material_index as usize];

            // Tangents for normal maps and anisotropy: given, or generated with MikkTSpace
            // (on the normal map's UVs, else the coat normal map's, else the anisotropy
            // texture's, else set 0). A shader graph's tangent-space Normal Map (or Tangent
            // input) needs them too.
            let tangent_uvs = material
                .normal_tex
                .or(material.coat_normal_tex)
                .or(material.anisotropy_tex)
                .map(|t| t.tex_coord)
                .or((material.anisotropy_strength > 0.0).then_some(0))
                .or(material.nodes.as_ref().and_then(|p| p.tangent_uv));
            if let Some(tex_coord) = tangent_uvs
                && tangents.is_none()
            {
                let uv = if tex_coord == 0 { &uv0 } else { &uv1 };
                match (uv, &normals) {
                    (Some(uv), Some(n)) => {
                        let t0 = std::time::Instant::now();
                        tangents = Some(mikktspace_tangents(&positions, n, uv, &tris));
                        self.profile.tangents += t0.elapsed().as_secs_f64();
                    }
                    _ => self.warn(format!(
                        "{what}: a normal map or anisotropy without UVs or normals (no tangents) cannot be applied; ignored"
                    )),
                }
            }

            // Append transformed vertices.
            let base = out.positions.len() as u32;
            // Skinned vertices each have their own matrix; the winding of a triangle
            // follows its first vertex's (a mirrored joint turns it inside out).
            let mut vertex_flip = Vec::new();
            for i in 0..nv {
                let (world, normal_matrix, flip) = match &transforms {
                    VertexTransforms::Uniform => (*world, normal_matrix, flip),
                    VertexTransforms::Skinned(m) => {
                        let m3 = Mat3::from_mat4(m[i]);
                        let vflip = m3.determinant() < 0.0;
                        vertex_flip.push(vflip);
                        (m[i], m3.inverse().transpose(), vflip)
                    }
                };
                let p = world.transform_point3(positions[i]);
                if !p.is_finite() {
                    return Err(self.err(format!(
                        "{what}: vertex {i} is not finite after its node transform (position or scale too large)"
                    )));
                }
                // Beyond this, bounding-box arithmetic in the BVH build overflows f32.
                if p.abs().max_element() > MAX_COORDINATE {
                    return Err(self.err(format!(
                        "{what}: vertex {i} lies at {p}, beyond ±{MAX_COORDINATE:e} scene units (not supported)"
                    )));
                }
                out.positions.push(p);
                // A zero normal marks "use the geometric normal" (glTF: flat shading
                // when normals are absent).
                let n = normals.as_ref().map(|n| (normal_matrix * n[i]).normalize_or_zero()).unwrap_or(Vec3::ZERO);
                out.normals.push(n);
                let t = tangents
                    .as_ref()
                    .map(|t| {
                        let v = world.transform_vector3(t[i].truncate()).normalize_or_zero();
                        v.extend(if flip { -t[i].w } else { t[i].w })
                    })
                    .unwrap_or(Vec4::ZERO);
                out.tangents.push(t);
                out.uv0.push(uv0.as_ref().map(|u| u[i]).unwrap_or(Vec2::ZERO));
                out.uv1.push(uv1.as_ref().map(|u| u[i]).unwrap_or(Vec2::ZERO));
                out.colors.push(colors.as_ref().map(|c| c[i]).unwrap_or(Vec4::ONE));
            }
            let plain_name = m.name().map(str::to_string).unwrap_or_else(|| format!("mesh {}", m.index()));
            let material_of = (material_index, &materials[material_index as usize]);
            self.primitive_attributes(
                &prim,
                buffers,
                &what,
                &plain_name,
                material_of,
                per_object,
                base as usize,
                nv,
                out,
            )?;
            let first_tri = out.triangles.len();
            let mut against = 0usize;
            for t in tris {
                let p = t.map(|i| out.positions[(base + i) as usize]);
                let area2 = (p[1] - p[0]).cross(p[2] - p[0]).length();
                if !(area2 > 0.0) || !area2.is_finite() {
                    degenerate += 1;
                    continue;
                }
                let flip = vertex_flip.get(t[0] as usize).copied().unwrap_or(flip);
                let t = if flip { [t[0], t[2], t[1]] } else { t };
                let t = t.map(|i| base + i);
                let ng = (out.positions[t[1] as usize] - out.positions[t[0] as usize])
                    .cross(out.positions[t[2] as usize] - out.positions[t[0] as usize]);
                against += t.iter().all(|&i| out.normals[i as usize].dot(ng) < 0.0) as usize;
                out.triangles.push(t);
                out.tri_material.push(material_index);
            }
            if against > 0 {
                // Cycles shades with the normals as given (`triangle_smooth_normal`), and so
                // does Caustic (`Scene::surface`), as the glTF specification reads them: a face
                // whose normals point against its winding reflects nothing toward lights on its
                // front (a Diffuse plane with its custom normals turned down renders 0 in bpy
                // 5.0.1, 0.63 with them up). Named, since it is most likely an authoring slip.
                self.warn(format!(
                    "{what}: {against} triangle(s) have vertex normals pointing against their winding; they \
                     are shaded with the normals as given, as Cycles does, and render black under light \
                     from their front"
                ));
            }
            let material = &materials[material_index as usize];
            // A volume on an open primitive (Blender's exporter and the add-on put
            // KHR_materials_volume on every transmissive material, a window modelled as one
            // quad included) is entered and left by the side of the geometric normal, as
            // Cycles refracts at every glass surface whatever the topology. Only a medium
            // that absorbs, scatters or emits, or subsurface scattering, loses light through
            // the holes.
            let lossy = material.subsurface.is_some()
                || material
                    .medium
                    .as_ref()
                    .is_some_and(|m| m.sigma_a != Rgb::ZERO || m.sigma_s != Rgb::ZERO || m.emission != Rgb::ZERO);
            if lossy {
                let open = open_edges(&out.positions, &out.triangles[first_tri..]);
                if open > 0 {
                    self.warn(format!(
                        "{what}: material '{}' has a volume or subsurface scattering but the primitive is not closed \
                         ({open} open edges): paths that leave through a hole lose the light the medium would have \
                         scattered (a path escaping to the sky from inside is black)",
                        material.name
                    ));
                }
            }
        }
        Ok(degenerate)
    }
}

/// Edges used by an odd number of the triangles: 0 for a closed surface. Vertices are
/// joined by position rounded to 10⁻⁶ of the primitive's size, so that vertices split
/// for UV seams or hard edges, or computed twice with rounding (a sphere's seam and
/// poles), still join.
pub(super) fn open_edges(positions: &[Vec3], tris: &[[u32; 3]]) -> usize {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for t in tris {
        for &i in t {
            lo = lo.min(positions[i as usize]);
            hi = hi.max(positions[i as usize]);
        }
    }
    let scale = 1e6 / (hi - lo).max_element().max(1e-30);
    let key = |i: u32| (positions[i as usize] * scale).round().to_array().map(|c| c as i64);
    let mut count: HashMap<([i64; 3], [i64; 3]), u32> = HashMap::new();
    for t in tris {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            let (ka, kb) = (key(a), key(b));
            if ka != kb {
                *count.entry(if ka < kb { (ka, kb) } else { (kb, ka) }).or_default() += 1;
            }
        }
    }
    count.values().filter(|&&c| c % 2 == 1).count()
}

/// MikkTSpace tangents for an indexed triangle list, per vertex, in glTF's convention
/// (bitangent = cross(normal, xyz) · w points up the image, as Blender exports them).
pub(super) fn mikktspace_tangents(positions: &[Vec3], normals: &[Vec3], uvs: &[Vec2], tris: &[[u32; 3]]) -> Vec<Vec4> {
    struct Geo<'a> {
        p: &'a [Vec3],
        n: &'a [Vec3],
        uv: &'a [Vec2],
        tris: &'a [[u32; 3]],
        out: Vec<Vec4>,
    }
    impl mikktspace::Geometry for Geo<'_> {
        fn num_faces(&self) -> usize {
            self.tris.len()
        }
        fn num_vertices_of_face(&self, _face: usize) -> usize {
            3
        }
        fn position(&self, face: usize, vert: usize) -> [f32; 3] {
            self.p[self.tris[face][vert] as usize].to_array()
        }
        fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
            self.n[self.tris[face][vert] as usize].to_array()
        }
        fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
            // MikkTSpace (as Blender, which computes the tangents its exporter writes)
            // takes V up from a bottom-left origin; glTF's UV origin is the top-left with
            // V down. Unflipped, every generated bitangent points down the image and the
            // normal map's green axis is inverted.
            let uv = self.uv[self.tris[face][vert] as usize];
            [uv.x, 1.0 - uv.y]
        }
        fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
            self.out[self.tris[face][vert] as usize] = Vec4::from(tangent);
        }
    }
    let mut g = Geo { p: positions, n: normals, uv: uvs, tris, out: vec![Vec4::ZERO; positions.len()] };
    mikktspace::generate_tangents(&mut g);
    g.out
}

#[cfg(test)]
mod tests {
    use super::mikktspace_tangents;
    use glam::{Vec2, Vec3, Vec4};

    /// A unit quad in the XY plane facing +Z, with UVs as Blender's exporter writes them:
    /// Blender's (x, y) become glTF's (x, 1 - y), so the image's top row (v = 0) lies at
    /// y = 1. `mirror_u` mirrors the texture horizontally (u = 1 - x), as the mirrored
    /// half of Khronos' NormalTangentMirrorTest does.
    fn quad(mirror_u: bool) -> (Vec<Vec3>, Vec<Vec3>, Vec<Vec2>, Vec<[u32; 3]>) {
        let p = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let uv = p.iter().map(|q| Vec2::new(if mirror_u { 1.0 - q.x } else { q.x }, 1.0 - q.y)).collect();
        (p, vec![Vec3::Z; 4], uv, vec![[0, 1, 2], [0, 2, 3]])
    }

    /// The TANGENT a file carries for this geometry, by the glTF 2.0 spec: xyz = dP/du (the
    /// normal texture's +X), and w such that bitangent = cross(normal, xyz) · w points to
    /// the normal texture's +Y, which is "up" in the image: towards its top row, v = 0,
    /// i.e. along -dP/dv in glTF's top-left UV origin (Blender's +V).
    fn spec_tangent(p: &[Vec3], uv: &[Vec2], n: Vec3) -> Vec4 {
        let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
        let (d1, d2) = (uv[1] - uv[0], uv[2] - uv[0]);
        let det = d1.x * d2.y - d2.x * d1.y;
        let dp_du = (e1 * d2.y - e2 * d1.y) / det;
        let dp_dv = (e2 * d1.x - e1 * d2.x) / det;
        let up = -dp_dv;
        let w = if n.cross(dp_du).dot(up) > 0.0 { 1.0 } else { -1.0 };
        dp_du.normalize().extend(w)
    }

    /// Vertex normals against the winding are named (they render black, as in Cycles): the unit
    /// triangle (winding +Z) with normals −Z warns, with +Z does not.
    #[test]
    fn normals_against_the_winding_are_named() {
        use serde_json::json;
        for (z, warned) in [(-1.0f32, true), (1.0, false)] {
            let normals: Vec<u8> = [0.0f32, 0.0, z].repeat(3).iter().flat_map(|f| f.to_le_bytes()).collect();
            let scene = super::super::tests::load_triangle_after(
                &normals,
                json!({
                    "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 36}],
                    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                            "min": [0, 0, 0], "max": [1, 1, 0]},
                        {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"}],
                    "meshes": [{"name": "tri", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}}]}]
                }),
            )
            .unwrap();
            let named = scene.warnings.iter().any(|w| w.contains("'tri'") && w.contains("against their winding"));
            assert_eq!(named, warned, "{:?}", scene.warnings);
        }
    }

    /// A node mirroring its mesh (scale (-1, 1, 1)) reverses the winding, which the loader
    /// turns back: both copies of `tests/data/negative_scale.gltf`'s quad (no normals, so the
    /// winding alone says which face is the front) face +Z, as the unmirrored one does. The
    /// corpus's render of that file cannot show it since emission leaves both faces.
    #[test]
    fn a_mirroring_node_keeps_the_front_face_where_it_was() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/negative_scale.gltf");
        let scene = crate::scene::gltf::load(&path).unwrap();
        let m = &scene.mesh;
        assert_eq!(m.triangles.len(), 4);
        let mut mirrored = 0;
        for t in &m.triangles {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            let n = (b - a).cross(c - a);
            assert!(n.z > 0.0 && n.x == 0.0 && n.y == 0.0, "a triangle faces {n}");
            mirrored += (a.x + b.x + c.x < 0.0) as u32;
        }
        assert_eq!(mirrored, 2, "the mirrored copy is on x < 0");
    }

    #[test]
    fn generated_tangents_are_the_ones_a_file_would_carry() {
        for mirror in [false, true] {
            let (p, n, uv, tris) = quad(mirror);
            let want = spec_tangent(&p, &uv, Vec3::Z);
            // By hand: +X (or -X mirrored) with the bitangent +Y, the image's up.
            assert_eq!(want, if mirror { Vec4::new(-1.0, 0.0, 0.0, -1.0) } else { Vec4::new(1.0, 0.0, 0.0, 1.0) });
            for (i, t) in mikktspace_tangents(&p, &n, &uv, &tris).iter().enumerate() {
                // MikkTSpace normalises in f32: a few ulps.
                assert!((*t - want).abs().max_element() < 1e-6, "mirror {mirror}, vertex {i}: {t} vs {want}");
            }
        }
    }

    /// A quad (an open sheet, 2 triangles) and a cube (12 triangles, closed) or an open box
    /// (the cube without its top face), all of one glass material with KHR_materials_volume
    /// thickness 1, as Blender's exports are; `absorbing` gives the volume an attenuation.
    fn sheet_and_box(closed: bool, absorbing: bool) -> crate::scene::Scene {
        use base64::Engine;
        let quad = [[-1f32, -1., 0.], [1., -1., 0.], [1., 1., 0.], [-1., 1., 0.]];
        let cube: Vec<[f32; 3]> =
            (0..8).map(|i| [(i & 1) as f32 + 3.0, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32]).collect();
        let faces: [[u32; 4]; 6] = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let faces = if closed { &faces[..] } else { &faces[..5] };
        let cube_idx: Vec<u32> = faces.iter().flat_map(|f| [f[0], f[1], f[2], f[0], f[2], f[3]]).collect();
        let f = |v: &[[f32; 3]]| v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
        let u = |v: &[u32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
        let parts = [f(&quad), u(&[0, 1, 2, 0, 2, 3]), f(&cube), u(&cube_idx)];
        let mut views = Vec::new();
        let mut offset = 0;
        for p in &parts {
            views.push(serde_json::json!({"buffer": 0, "byteOffset": offset, "byteLength": p.len()}));
            offset += p.len();
        }
        let data = parts.concat();
        let doc = serde_json::json!({
            "asset": {"version": "2.0"},
            "buffers": [{"uri": format!("data:application/octet-stream;base64,{}",
                base64::engine::general_purpose::STANDARD.encode(&data)), "byteLength": data.len()}],
            "bufferViews": views,
            "accessors": [
                {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]},
                {"bufferView": 1, "componentType": 5125, "count": 6, "type": "SCALAR"},
                {"bufferView": 2, "componentType": 5126, "count": 8, "type": "VEC3", "min": [3, 0, 0], "max": [4, 1, 1]},
                {"bufferView": 3, "componentType": 5125, "count": cube_idx.len(), "type": "SCALAR"}
            ],
            "materials": [{"name": "glass", "extensions": {
                "KHR_materials_transmission": {"transmissionFactor": 1.0},
                "KHR_materials_volume": if absorbing {
                    serde_json::json!({"thicknessFactor": 1.0, "attenuationColor": [0.5, 0.5, 0.5], "attenuationDistance": 1.0})
                } else {
                    serde_json::json!({"thicknessFactor": 1.0})
                }}}],
            "meshes": [
                {"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]},
                {"primitives": [{"attributes": {"POSITION": 2}, "indices": 3, "material": 0}]}
            ],
            "nodes": [{"mesh": 0}, {"mesh": 1}],
            "scenes": [{"nodes": [0, 1]}]
        });
        let bytes = serde_json::to_vec(&doc).unwrap();
        let budget = crate::memory::MemoryBudget::unlimited();
        crate::scene::gltf::load_bytes(&bytes, std::path::Path::new("."), "sheet.gltf", &budget).unwrap()
    }

    /// Cycles refracts at every glass surface, entering by the geometric normal's side,
    /// whatever the topology: a volume on a single sheet or an open box is kept (the sheet
    /// is no thin wall), as on the closed cube.
    #[test]
    fn a_volume_on_an_open_sheet_or_box_stays_a_volume() {
        for closed in [true, false] {
            let scene = sheet_and_box(closed, false);
            let m = &scene.mesh;
            assert_eq!(m.triangles.len(), if closed { 14 } else { 12 });
            for (t, &mat) in m.tri_material.iter().enumerate() {
                let mat = &scene.materials[mat as usize];
                assert!(mat.medium.is_some(), "closed {closed}: triangle {t} bounds a volume");
                assert_eq!((mat.name.as_str(), mat.transmission), ("glass", 1.0));
            }
        }
    }

    /// Holes lose light only where the medium does something: a clear volume on open
    /// primitives loads without a warning, an absorbing one warns for each open primitive
    /// (the sheet, the open box) and not for the closed cube.
    #[test]
    fn open_primitives_warn_only_when_their_medium_absorbs() {
        let clear = sheet_and_box(false, false);
        assert!(!clear.warnings.iter().any(|w| w.contains("not closed")), "{:?}", clear.warnings);
        for closed in [true, false] {
            let scene = sheet_and_box(closed, true);
            let open: Vec<_> = scene.warnings.iter().filter(|w| w.contains("not closed")).collect();
            assert_eq!(open.len(), if closed { 1 } else { 2 }, "closed {closed}: {open:?}");
            assert!(open[0].contains("4 open edges"), "the sheet: {open:?}");
        }
    }
}
