//! `CAUSTIC_points` (root extension): point clouds as a sphere per point, world-space centres
//! and radii read from accessors (docs/contract.md), checked point by point, and their BVH
//! built.

use super::Loader;
use crate::error::Result;
use crate::math::Rgb;
use crate::medium::HomogeneousMedium;
use crate::points::{PointObject, Points};
use crate::scene::{AlphaMode, Material};
use crate::shader::geom::ObjectData;
use glam::{Mat4, Vec4};
use serde::Deserialize;

/// One point cloud object of the extension.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PointsObjectExt {
    /// Name, for messages.
    name: String,
    /// The Blender object the points belong to (a Point Cloud object, or the mesh whose
    /// Geometry Nodes made them), which light linking's collections name; `name` when absent.
    #[serde(default)]
    object: Option<String>,
    /// glTF material index; the default material when absent.
    material: Option<u32>,
    /// VEC3 float accessor: the points' centres, world space, glTF axes.
    positions: usize,
    /// SCALAR float accessor: each point's radius (world), > 0.
    radii: usize,
    /// SCALAR unsigned-int accessor: each point's index in its Blender point cloud, when
    /// points were left out (Point Info's Random hashes it); the position's index without.
    #[serde(default)]
    indices: Option<usize>,
    /// The object's matrix, object to world in glTF axes, column-major (Texture Coordinate's
    /// Object and Generated, Object Info's Location); the identity when absent.
    #[serde(default)]
    matrix: Option<[f32; 16]>,
    /// The instance's random id in Blender's depsgraph (Object Info Random); the name's hash
    /// when absent.
    #[serde(default, rename = "randomId")]
    random_id: Option<u32>,
    /// The object's Ray Visibility and Holdout, as `CAUSTIC_object_visibility` on a mesh.
    #[serde(default)]
    visibility: Option<super::extensions::ObjectVisibilityExt>,
}

/// The extension's root.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PointsExt {
    objects: Vec<PointsObjectExt>,
}

/// Bytes per point as loaded, for the memory budget: its sphere, its index and its share of
/// the BVH's nodes (about 10 bytes, `points::bvh`'s test), with room.
const BYTES_PER_POINT: u64 = 16 + 4 + 16;

impl Loader<'_> {
    /// Reads `CAUSTIC_points`, if present, and builds the points' BVH. Points whose material
    /// has transparency, a volume that attenuates or glows, or subsurface scattering get an
    /// opaque copy of it (with a warning naming both): points are opaque surfaces here, which
    /// a glass refracts into once (as Cycles, which culls their back faces). With `objects` (the scene has
    /// shader graphs) each point cloud object gets its instance data there.
    pub(super) fn points(
        &mut self,
        value: &serde_json::Value,
        doc: &gltf::Document,
        buffers: &[Vec<u8>],
        materials: &mut Vec<Material>,
        default_material: u32,
        mut objects: Option<&mut Vec<ObjectData>>,
    ) -> Result<Points> {
        let mut points = Points::default();
        let Some(ext) = value.pointer("/extensions/CAUSTIC_points") else {
            return Ok(points);
        };
        let ext: PointsExt =
            serde_json::from_value(ext.clone()).map_err(|e| self.err(format!("CAUSTIC_points is malformed: {e}")))?;
        let mut opaque_copies: std::collections::HashMap<u32, u32> = Default::default();
        let mut warnings = Vec::new();
        for obj in &ext.objects {
            let what = format!("point cloud '{}'", obj.name);
            let accessor = |index: usize, field: &str| {
                doc.accessors().nth(index).ok_or_else(|| {
                    self.err(format!(
                        "{what}: {field} accessor {index} does not exist (the file has {})",
                        doc.accessors().len()
                    ))
                })
            };
            let (positions_acc, radii_acc) = (accessor(obj.positions, "positions")?, accessor(obj.radii, "radii")?);
            use gltf::accessor::{DataType as T, Dimensions as D};
            let check = |acc: &gltf::Accessor, field: &str, t: T, d: D| {
                if acc.data_type() == t && acc.dimensions() == d && !acc.normalized() {
                    Ok(())
                } else {
                    Err(self.err(format!(
                        "{what}: {field} accessor {} is {:?} {:?}; it must be {t:?} {d:?}",
                        acc.index(),
                        acc.data_type(),
                        acc.dimensions()
                    )))
                }
            };
            check(&positions_acc, "positions", T::F32, D::Vec3)?;
            check(&radii_acc, "radii", T::F32, D::Scalar)?;
            let n = positions_acc.count();
            if radii_acc.count() != n {
                return Err(self.err(format!("{what}: {} radii for {n} positions", radii_acc.count())));
            }
            let indices_acc = match obj.indices {
                Some(i) => {
                    let acc = accessor(i, "indices")?;
                    check(&acc, "indices", T::U32, D::Scalar)?;
                    if acc.count() != n {
                        return Err(self.err(format!("{what}: {} indices for {n} positions", acc.count())));
                    }
                    Some(acc)
                }
                None => None,
            };
            if points.spheres.len() + n > crate::points::MAX_POINTS {
                return Err(self.err(format!("{what}: more than 2^30 points in the scene")));
            }
            self.budget.charge(format!("{what} ({n} points)"), (n as u64).saturating_mul(BYTES_PER_POINT))?;
            let get = |b: gltf::Buffer| buffers.get(b.index()).map(|v| v.as_slice());
            let unreadable = |field: &str| self.err(format!("{what}: the {field} accessor has no data"));
            let centres =
                gltf::accessor::Iter::<[f32; 3]>::new(positions_acc, get).ok_or_else(|| unreadable("positions"))?;
            let radii = gltf::accessor::Iter::<f32>::new(radii_acc, get).ok_or_else(|| unreadable("radii"))?;
            let first = points.spheres.len() as u32;
            points.spheres.reserve(n);
            for (i, (p, r)) in centres.zip(radii).enumerate() {
                if !p.iter().all(|c| c.is_finite() && c.abs() <= super::MAX_COORDINATE) {
                    return Err(self.err(format!("{what}: point {i}'s position is not finite ({p:?})")));
                }
                if !(r.is_finite() && r > 0.0 && r <= super::MAX_COORDINATE) {
                    return Err(self.err(format!("{what}: point {i} has radius {r}; radii must be finite and > 0")));
                }
                points.spheres.push(Vec4::new(p[0], p[1], p[2], r));
            }
            if points.spheres.len() != first as usize + n {
                return Err(unreadable("positions"));
            }
            let indices = match indices_acc {
                Some(acc) => {
                    let v: Vec<u32> =
                        gltf::accessor::Iter::<u32>::new(acc, get).ok_or_else(|| unreadable("indices"))?.collect();
                    if v.len() != n {
                        return Err(unreadable("indices"));
                    }
                    Some(v)
                }
                None => None,
            };
            let material = match obj.material {
                Some(m) if m as usize >= materials.len() => {
                    return Err(
                        self.err(format!("{what}: material {m} does not exist (the file has {})", materials.len()))
                    );
                }
                Some(m) => m,
                None => default_material,
            };
            let material = match opaque_copies.get(&material) {
                Some(&copy) => copy,
                None => {
                    let m = &materials[material as usize];
                    // A solid glass keeps a medium that neither attenuates nor glows: the
                    // BSDF refracts at the entry, and the walker enters no medium at a point
                    // (`SceneContext::medium_after`).
                    let inside = m.medium.is_some_and(|h| h.attenuates() || h.emission != Rgb::ZERO)
                        || m.grid.is_some()
                        || m.volume_program.is_some();
                    let copy =
                        if m.alpha_mode != AlphaMode::Opaque || inside || m.null_surface || m.subsurface.is_some() {
                            let mut opaque = m.clone();
                            warnings.push(format!(
                                "{what}: material '{}' has transparency, a volume or subsurface scattering, which \
                             points do not render; they are shaded as an opaque surface (a glass still refracts)",
                                m.name
                            ));
                            opaque.alpha_mode = AlphaMode::Opaque;
                            opaque.medium = m.medium.map(|_| HomogeneousMedium::absorbing(Rgb::ZERO));
                            opaque.grid = None;
                            opaque.volume_program = None;
                            opaque.null_surface = false;
                            opaque.subsurface = None;
                            materials.push(opaque);
                            materials.len() as u32 - 1
                        } else {
                            material
                        };
                    opaque_copies.insert(material, copy);
                    copy
                }
            };
            let m = &materials[material as usize];
            if m.is_emissive() || m.nodes.as_ref().is_some_and(|p| p.emits) {
                warnings.push(format!(
                    "{what}: material '{}' emits: points are not sampled as lights (nor in Cycles), so their \
                     light reaches other surfaces only by rays that hit them, and photons (Jensen, SPPM) do \
                     not carry it",
                    m.name
                ));
            }
            if m.nodes.as_ref().is_some_and(|p| p.hair) {
                // Cycles gives a point no fibre (dPdu = dPdv = 0, `point_shader_setup`): the Hair
                // BSDF's tangent is normalize(0) and the Huang model's frame is empty, so both
                // shade a point black; the Chiang model evaluates one direction-independent value
                // from its empty frame and samples a zero direction (measured: points of a
                // Principled Hair BSDF flat and bright, of a Hair BSDF black). Caustic renders the
                // hair closures black there.
                warnings.push(format!(
                    "{what}: material '{}' has hair BSDFs, which have no fibre direction on a point: they render \
                     black there (as Cycles renders the Hair BSDF and the Principled Hair BSDF's Huang model; its \
                     Chiang model shows a flat, direction-independent value in Cycles)",
                    m.name
                ));
            }
            let world = match obj.matrix {
                Some(m) => {
                    let m = Mat4::from_cols_array(&m);
                    if !m.is_finite() || m.determinant() == 0.0 || !m.determinant().is_finite() {
                        return Err(self.err(format!("{what}: its matrix is not an invertible finite transform")));
                    }
                    m
                }
                None => Mat4::IDENTITY,
            };
            let mut object = PointObject::new(&obj.name, first, n as u32, material);
            object.indices = indices;
            if let Some(v) = &obj.visibility {
                object.rays = v.mask();
                object.holdout = v.holdout;
                if v.shadow_catcher {
                    warnings.push(format!(
                        "{what}: Shadow Catcher is not rendered on points: they are shaded as an ordinary surface"
                    ));
                }
            }
            if let Some(objects) = objects.as_deref_mut() {
                let random_id = obj.random_id.map(serde_json::Value::from);
                objects.push(super::shader_graph::object_data(
                    &world,
                    obj.object.as_deref().unwrap_or(&obj.name),
                    None,
                    None,
                    random_id.as_ref(),
                    None,
                ));
                object.object = Some(objects.len() as u32 - 1);
            }
            if n > 0 {
                points.objects.push(object);
            }
        }
        for w in warnings {
            self.warn(w);
        }
        points.build();
        Ok(points)
    }
}

/// Each `CAUSTIC_points` object with points, its Blender object (its `object`, else its
/// `name`) and that object's id for light linking: the first node of that name (the mesh
/// whose Geometry Nodes made the points), else one past the nodes and `curves` objects by the
/// point cloud's index among them (a Point Cloud object has no node).
pub(super) fn object_ids(value: &serde_json::Value, doc: &gltf::Document, curves: usize) -> Vec<(String, u32)> {
    let objects = value.pointer("/extensions/CAUSTIC_points/objects").and_then(|o| o.as_array());
    let nodes = doc.nodes().count() as u32;
    let count = |o: &serde_json::Value| {
        let positions = o.get("positions").and_then(|p| p.as_u64())?;
        doc.accessors().nth(positions as usize).map(|a| a.count())
    };
    objects
        .into_iter()
        .flatten()
        .filter(|o| count(o).is_some_and(|n| n > 0))
        .enumerate()
        .map(|(k, o)| {
            let name = o.get("object").or_else(|| o.get("name")).and_then(|n| n.as_str()).unwrap_or("").to_string();
            let id = doc
                .nodes()
                .find(|n| n.name() == Some(name.as_str()))
                .map_or(nodes + (curves + k) as u32, |n| n.index() as u32);
            (name, id)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::tests::load_triangle_after;
    use crate::points::{POINT_BITS, is_point};
    use serde_json::json;

    /// Three points after the unit triangle: centres (bytes 36..72), radii (72..84), indices
    /// (84..96); `object` is the extension's object, its accessors 1, 2 and 3.
    fn load(object: serde_json::Value, radii: [f32; 3]) -> crate::error::Result<crate::scene::Scene> {
        load_with(object, radii, json!({}))
    }

    /// `load` with more root properties (materials) merged in.
    fn load_with(
        object: serde_json::Value,
        radii: [f32; 3],
        more: serde_json::Value,
    ) -> crate::error::Result<crate::scene::Scene> {
        let mut extra: Vec<u8> = Vec::new();
        for c in [[0.0f32, 0.0, 2.0], [1.0, 0.0, 2.0], [2.0, 0.0, 2.0]] {
            extra.extend(c.iter().flat_map(|f| f.to_le_bytes()));
        }
        extra.extend(radii.iter().flat_map(|f| f.to_le_bytes()));
        extra.extend([0u32, 5, 9].iter().flat_map(|i| i.to_le_bytes()));
        load_triangle_after(
            &extra,
            json!({
                "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 36},
                    {"buffer": 0, "byteOffset": 72, "byteLength": 12}, {"buffer": 0, "byteOffset": 84, "byteLength": 12}],
                "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                        "min": [0, 0, 0], "max": [1, 1, 0]},
                    {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
                    {"bufferView": 2, "componentType": 5126, "count": 3, "type": "SCALAR"},
                    {"bufferView": 3, "componentType": 5125, "count": 3, "type": "SCALAR"}],
                "extensionsUsed": ["CAUSTIC_points", "CAUSTIC_materials_nodes"],
                "extensions": {"CAUSTIC_points": {"objects": [object]}},
                "materials": more.get("materials").cloned().unwrap_or(json!([]))
            }),
        )
    }

    /// Hair BSDFs on points are named (object and material), since they render black there
    /// (as the Hair BSDF and the Huang model do in Cycles: a point has no fibre direction); a
    /// Diffuse material on the same points is not.
    #[test]
    fn hair_bsdfs_on_points_are_named() {
        let graph = |name: &str, node: serde_json::Value| {
            json!({"name": name, "extensions": {"CAUSTIC_materials_nodes":
                {"version": 1, "nodes": [node], "output": {"surface": [0, "BSDF"]}}}})
        };
        let hair = json!({"name": "H", "type": "ShaderNodeBsdfHairPrincipled", "props": {"parametrization": "COLOR"},
            "inputs": {"Color": {"value": [0.6, 0.3, 0.15, 1.0]}}});
        let lobes = json!({"name": "H", "type": "ShaderNodeBsdfHair", "props": {"component": "Reflection"}});
        let diffuse = json!({"name": "D", "type": "ShaderNodeBsdfDiffuse"});
        let materials = json!({"materials": [graph("Fur", hair), graph("Lobes", lobes), graph("Matte", diffuse)]});
        for (m, name, warned) in [(0, "Fur", true), (1, "Lobes", true), (2, "Matte", false)] {
            let obj = json!({"name": "dots", "positions": 1, "radii": 2, "material": m});
            let scene = load_with(obj, [0.1; 3], materials.clone()).unwrap();
            let named = scene.warnings.iter().any(|w| {
                w.contains("point cloud 'dots'") && w.contains(&format!("material '{name}'")) && w.contains("hair")
            });
            assert_eq!(named, warned, "{name}: {:?}", scene.warnings);
        }
    }

    /// Point Info at each point: its centre, radius and Cycles' Random of its index in its
    /// Blender point cloud (`indices` when given, else its position), read through a hit.
    #[test]
    fn point_info_reads_each_point_and_its_blender_index() {
        let hash =
            |i: u32| crate::shader::texture::hash::uint_to_float_incl(crate::shader::texture::hash::hash_uint2(i, 0));
        for (indices, want) in [(None, [0, 1, 2]), (Some(3), [0, 5, 9])] {
            let mut obj = json!({"name": "dots", "positions": 1, "radii": 2});
            if let Some(a) = indices {
                obj["indices"] = json!(a);
            }
            let scene = load(obj, [0.1, 0.2, 0.3]).unwrap();
            assert_eq!(scene.report.points, 3);
            for (k, x) in [0.0f32, 1.0, 2.0].into_iter().enumerate() {
                let org = glam::Vec3::new(x, 0.0, 5.0);
                let bvh = scene.points.bvh.as_ref().unwrap();
                let hit = bvh.intersect(&scene.points.spheres, org, -glam::Vec3::Z, f32::INFINITY, |_| true).unwrap();
                assert!(is_point(hit.tri) && hit.tri & POINT_BITS == POINT_BITS);
                let info = scene.points.info(hit.tri);
                assert_eq!(info.centre, glam::Vec3::new(x, 0.0, 2.0));
                assert_eq!(info.radius, [0.1, 0.2, 0.3][k]);
                assert_eq!(info.random, hash(want[k]), "point {k}");
                let s = scene.surface(&hit, org, -glam::Vec3::Z);
                assert!((s.p.z - (2.0 + info.radius)).abs() < 1e-6 && s.ng == glam::Vec3::Z && s.front);
            }
        }
    }

    /// Bad points are refused with the object's name: radii ≤ 0 or NaN, mismatched counts,
    /// an indices accessor of the wrong type or count, a bad matrix, a missing accessor.
    #[test]
    fn bad_points_are_refused_by_name() {
        let obj = json!({"name": "dots", "positions": 1, "radii": 2});
        let with = |k: &str, v: serde_json::Value| {
            let mut o = obj.clone();
            o[k] = v;
            o
        };
        let singular = json!([1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]);
        for (object, radii, what) in [
            (obj.clone(), [0.1, 0.0, 0.3], "point 1 has radius 0"),
            (obj.clone(), [0.1, 0.2, -1.0], "point 2 has radius -1"),
            (obj.clone(), [f32::NAN, 0.2, 0.3], "point 0 has radius NaN"),
            (obj.clone(), [0.1, f32::INFINITY, 0.3], "point 1 has radius inf"),
            (with("radii", json!(0)), [0.1; 3], "radii accessor 0 is F32 Vec3"),
            (with("indices", json!(2)), [0.1; 3], "indices accessor 2 is F32 Scalar; it must be U32 Scalar"),
            (with("positions", json!(7)), [0.1; 3], "positions accessor 7 does not exist"),
            (with("matrix", singular), [0.1; 3], "its matrix is not an invertible finite transform"),
            (with("material", json!(3)), [0.1; 3], "material 3 does not exist"),
            (with("colour", json!(1)), [0.1; 3], "CAUSTIC_points is malformed"),
        ] {
            let err = load(object, radii).err().map(|e| e.to_string()).unwrap_or_default();
            assert!(err.contains(what), "{what}: {err}");
            if what != "CAUSTIC_points is malformed" {
                assert!(err.contains("point cloud 'dots'"), "{err}");
            }
        }
        // Counts that differ: the first two positions, three radii.
        let mut extra: Vec<u8> = Vec::new();
        for f in [0.0f32, 0.0, 2.0, 1.0, 0.0, 2.0, 0.1, 0.2, 0.3] {
            extra.extend(f.to_le_bytes());
        }
        let err = load_triangle_after(
            &extra,
            json!({
                "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 24},
                    {"buffer": 0, "byteOffset": 60, "byteLength": 12}],
                "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                        "min": [0, 0, 0], "max": [1, 1, 0]},
                    {"bufferView": 1, "componentType": 5126, "count": 2, "type": "VEC3"},
                    {"bufferView": 2, "componentType": 5126, "count": 3, "type": "SCALAR"}],
                "extensions": {"CAUSTIC_points": {"objects": [obj]}}
            }),
        )
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
        assert!(err.contains("point cloud 'dots': 3 radii for 2 positions"), "{err}");
    }
}
