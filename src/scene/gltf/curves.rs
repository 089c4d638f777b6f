//! `CAUSTIC_curves` (root extension): hair and curves objects as strands of control points
//! with a radius each, read from accessors (docs/contract.md), checked point by point,
//! and their BVH built.

use super::Loader;
use crate::bsdf::hair::HairParams;
use crate::curves::{Curves, Strand};
use crate::error::Result;
use crate::scene::{AlphaMode, Material};
use glam::{Vec2, Vec4};
use serde::Deserialize;

/// One curves object of the extension.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CurvesObjectExt {
    /// Name, for messages.
    name: String,
    /// The Blender object the strands belong to (a hair system's emitter, a Curves object),
    /// which light linking's collections name; `name` when absent.
    #[serde(default)]
    object: Option<String>,
    /// glTF material index; the default material when absent.
    material: Option<u32>,
    /// VEC3 float accessor: control points, world space, glTF axes.
    points: usize,
    /// SCALAR float accessor: radius of each control point.
    radii: usize,
    /// SCALAR unsigned-int accessor: control points per strand, in order.
    counts: usize,
    /// VEC2 float accessor: each strand's root texture coordinates (glTF convention).
    #[serde(rename = "rootUvs")]
    root_uvs: Option<usize>,
    /// How a ray meets the strands: round (the default) or ray-facing ribbons.
    #[serde(default)]
    shape: CurveShape,
    /// Cycles' index of the first strand in its hair geometry (Curves Info Random).
    #[serde(default, rename = "randomBase")]
    random_base: u32,
    /// Object-space length per world-space length (Curves Info Length).
    #[serde(default = "one", rename = "lengthScale")]
    length_scale: f32,
    /// Points per interval between Cycles' keys (Curves Info Intercept and Length).
    #[serde(default = "one_u32", rename = "keyStep")]
    key_step: u32,
}

fn one() -> f32 {
    1.0
}

fn one_u32() -> u32 {
    1
}

/// The strands' shape, as Cycles' Curves Shape.
#[derive(Deserialize, Default, Clone, Copy, PartialEq)]
enum CurveShape {
    /// Round cones between the points (Cycles' Thick and Thick Linear).
    #[default]
    #[serde(rename = "round")]
    Round,
    /// Ray-facing strips through the axis, with Cycles' self-intersection guard.
    #[serde(rename = "ribbon")]
    Ribbon,
}

/// The extension's root.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CurvesExt {
    objects: Vec<CurvesObjectExt>,
}

/// Bytes per control point and per strand as loaded, for the memory budget: a point and its
/// share of the segments' index and BVH nodes (one 80-byte node per ~4 segments).
const BYTES_PER_POINT: u64 = 16 + 4 + 20;
const BYTES_PER_STRAND: u64 = size_of::<Strand>() as u64;

impl Loader<'_> {
    /// Reads `CAUSTIC_curves`, if present, and builds the strands' BVH. A strand whose
    /// material has transparency, a volume or subsurface scattering gets an opaque copy of it
    /// (with a warning naming both): strands are opaque surfaces.
    pub(super) fn curves(
        &mut self,
        value: &serde_json::Value,
        doc: &gltf::Document,
        buffers: &[Vec<u8>],
        materials: &mut Vec<Material>,
        default_material: u32,
    ) -> Result<Curves> {
        let mut curves = Curves::default();
        let Some(ext) = value.pointer("/extensions/CAUSTIC_curves") else {
            return Ok(curves);
        };
        // The Principled Hair BSDF of the materials that have one (strands shade with it).
        for (i, m) in value.get("materials").and_then(|m| m.as_array()).into_iter().flatten().enumerate() {
            if let Some(hair) = m.pointer("/extensions/CAUSTIC_materials_hair") {
                let name = m.get("name").and_then(|n| n.as_str()).unwrap_or("");
                let params: HairParams = serde_json::from_value(hair.clone()).map_err(|e| {
                    self.err(format!("material {i} ('{name}'): CAUSTIC_materials_hair is malformed: {e}"))
                })?;
                if !params.valid() {
                    return Err(self.err(format!(
                        "material {i} ('{name}'): CAUSTIC_materials_hair out of range (absorption >= 0, roughnesses \
                         and coat in [0, 1], IOR > 1): {params:?}"
                    )));
                }
                materials[i].hair = Some(params);
            }
        }
        let ext: CurvesExt =
            serde_json::from_value(ext.clone()).map_err(|e| self.err(format!("CAUSTIC_curves is malformed: {e}")))?;
        let mut opaque_copies: std::collections::HashMap<u32, u32> = Default::default();
        // Given to `warn` after the loop, whose closures borrow the loader.
        let mut warnings = Vec::new();
        for obj in &ext.objects {
            let what = format!("curves object '{}'", obj.name);
            let accessor = |index: usize, field: &str| {
                doc.accessors().nth(index).ok_or_else(|| {
                    self.err(format!(
                        "{what}: {field} accessor {index} does not exist (the file has {})",
                        doc.accessors().len()
                    ))
                })
            };
            let (points_acc, radii_acc, counts_acc) =
                (accessor(obj.points, "points")?, accessor(obj.radii, "radii")?, accessor(obj.counts, "counts")?);
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
            check(&points_acc, "points", T::F32, D::Vec3)?;
            check(&radii_acc, "radii", T::F32, D::Scalar)?;
            check(&counts_acc, "counts", T::U32, D::Scalar)?;
            let uv_acc = match obj.root_uvs {
                Some(i) => {
                    let acc = accessor(i, "rootUvs")?;
                    check(&acc, "rootUvs", T::F32, D::Vec2)?;
                    Some(acc)
                }
                None => None,
            };
            let n_points = points_acc.count();
            if radii_acc.count() != n_points {
                return Err(self.err(format!("{what}: {} radii for {n_points} points", radii_acc.count())));
            }
            let n_strands = counts_acc.count();
            if let Some(acc) = &uv_acc
                && acc.count() != n_strands
            {
                return Err(self.err(format!("{what}: {} root UVs for {n_strands} strands", acc.count())));
            }
            self.budget.charge(
                format!("{what} ({n_strands} strands, {n_points} points)"),
                (n_points as u64).saturating_mul(BYTES_PER_POINT).saturating_add((n_strands as u64) * BYTES_PER_STRAND),
            )?;
            let get = |b: gltf::Buffer| buffers.get(b.index()).map(|v| v.as_slice());
            let unreadable = |field: &str| self.err(format!("{what}: the {field} accessor has no data"));
            let points = gltf::accessor::Iter::<[f32; 3]>::new(points_acc, get).ok_or_else(|| unreadable("points"))?;
            let radii = gltf::accessor::Iter::<f32>::new(radii_acc, get).ok_or_else(|| unreadable("radii"))?;
            let first_point = curves.points.len();
            curves.points.reserve(n_points);
            for (i, (p, r)) in points.zip(radii).enumerate() {
                if !p.iter().all(|c| c.is_finite() && c.abs() <= super::MAX_COORDINATE) {
                    return Err(self.err(format!("{what}: point {i} is not finite ({p:?})")));
                }
                if !(r.is_finite() && r >= 0.0) {
                    return Err(self.err(format!("{what}: point {i} has radius {r}; radii must be finite and >= 0")));
                }
                curves.points.push(Vec4::new(p[0], p[1], p[2], r));
            }
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
                    let copy = if m.alpha_mode != AlphaMode::Opaque
                        || m.medium.is_some()
                        || m.null_surface
                        || m.subsurface.is_some()
                    {
                        let mut opaque = m.clone();
                        warnings.push(format!(
                            "{what}: material '{}' has transparency, a volume or subsurface scattering, which \
                             strands do not render; they are shaded as an opaque surface",
                            m.name
                        ));
                        opaque.alpha_mode = AlphaMode::Opaque;
                        opaque.medium = None;
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
            let mut uvs = match uv_acc {
                Some(acc) => {
                    Some(gltf::accessor::Iter::<[f32; 2]>::new(acc, get).ok_or_else(|| unreadable("rootUvs"))?)
                }
                None => None,
            };
            let counts = gltf::accessor::Iter::<u32>::new(counts_acc, get).ok_or_else(|| unreadable("counts"))?;
            let object = curves.objects.len() as u32;
            let mut next = first_point;
            for (i, count) in counts.enumerate() {
                if count < 2 {
                    return Err(self.err(format!("{what}: strand {i} has {count} point(s); a strand needs at least 2")));
                }
                if next + count as usize > first_point + n_points {
                    return Err(self.err(format!(
                        "{what}: strand {i} runs past the last point (the counts add up to more than {n_points} points)"
                    )));
                }
                let uv = uvs.as_mut().and_then(Iterator::next).map_or(Vec2::ZERO, Vec2::from);
                if !uv.is_finite() {
                    return Err(self.err(format!("{what}: strand {i}'s root UV is not finite")));
                }
                curves.strands.push(Strand { first: next as u32, count, material, uv, object });
                next += count as usize;
            }
            if next != first_point + n_points {
                return Err(self.err(format!(
                    "{what}: the strands' counts add up to {} points, the points accessor has {n_points}",
                    next - first_point
                )));
            }
            if curves.points.len() >= crate::curves::bvh::MAX_POINTS {
                return Err(self.err(format!("{what}: more than 2^29 control points in the scene")));
            }
            curves.objects.push(obj.name.clone());
            curves.object_names.push(obj.object.clone().unwrap_or_else(|| obj.name.clone()));
            curves.ribbons.push(obj.shape == CurveShape::Ribbon);
            if !(obj.length_scale.is_finite() && obj.length_scale > 0.0) || obj.key_step == 0 {
                return Err(self.err(format!(
                    "{what}: lengthScale must be finite and > 0 and keyStep >= 1 (got {} and {})",
                    obj.length_scale, obj.key_step
                )));
            }
            curves.info.push(crate::curves::info::ObjectInfo {
                random_base: obj.random_base,
                length_scale: obj.length_scale,
                key_step: obj.key_step,
            });
        }
        for w in warnings {
            self.warn(w);
        }
        curves.build();
        Ok(curves)
    }
}

/// Each `CAUSTIC_curves` object's Blender object (its `object`, else its `name`) and that
/// object's id for light linking: the first node of that name (a hair system's emitter mesh),
/// else one past the nodes by the curves object's index (a Curves object has no node).
pub(super) fn object_ids(value: &serde_json::Value, doc: &gltf::Document) -> Vec<(String, u32)> {
    let objects = value.pointer("/extensions/CAUSTIC_curves/objects").and_then(|o| o.as_array());
    let nodes = doc.nodes().count() as u32;
    objects
        .into_iter()
        .flatten()
        .enumerate()
        .map(|(k, o)| {
            let name = o.get("object").or_else(|| o.get("name")).and_then(|n| n.as_str()).unwrap_or("").to_string();
            let id =
                doc.nodes().find(|n| n.name() == Some(name.as_str())).map_or(nodes + k as u32, |n| n.index() as u32);
            (name, id)
        })
        .collect()
}
