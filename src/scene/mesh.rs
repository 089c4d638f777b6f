//! The scene's triangles: world-space geometry and per-vertex attributes, a leaf type
//! that the shader evaluator and the loader both read.

use glam::{Vec2, Vec3, Vec4};

/// All triangles of the scene, instanced and transformed to world space, with
/// per-vertex attributes (absent attributes are filled with defaults).
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// World-space positions.
    pub positions: Vec<Vec3>,
    /// World-space unit shading normals.
    pub normals: Vec<Vec3>,
    /// World-space tangents with the bitangent sign in w (zero when not needed).
    pub tangents: Vec<Vec4>,
    /// TEXCOORD_0.
    pub uv0: Vec<Vec2>,
    /// TEXCOORD_1.
    pub uv1: Vec<Vec2>,
    /// COLOR_0 (white when absent).
    pub colors: Vec<Vec4>,
    /// Vertex indices, counter-clockwise seen from the front.
    pub triangles: Vec<[u32; 3]>,
    /// Material of each triangle.
    pub tri_material: Vec<u32>,
    /// Instance (index into `Scene::objects`) of each triangle; empty when no material
    /// reads instance data (shader graphs' Object coordinates, Object Info).
    pub tri_object: Vec<u32>,
    /// World-space positions before true displacement (`scene::gltf::displace`), which the
    /// Generated coordinate reads as Cycles reads the undisplaced orco; empty when no
    /// material moved the mesh.
    pub undisplaced: Vec<Vec3>,
    /// The attributes shader graphs read by name (the Attribute and Color Attribute nodes,
    /// Geometry's Pointiness and Random Per Island), one value per vertex; only those some
    /// graph reads are kept.
    pub attributes: Vec<VertexAttribute>,
}

/// No triangles: the mesh a shader graph is evaluated against where there is no surface
/// (constant folding at load, the world's graphs).
pub static EMPTY_MESH: Mesh = Mesh {
    positions: Vec::new(),
    normals: Vec::new(),
    tangents: Vec::new(),
    uv0: Vec::new(),
    uv1: Vec::new(),
    colors: Vec::new(),
    triangles: Vec::new(),
    tri_material: Vec::new(),
    tri_object: Vec::new(),
    undisplaced: Vec::new(),
    attributes: Vec::new(),
};

/// What a shader graph reads by name, as Cycles names its attribute requests (docs/contract.md,
/// "Attributes"): a mesh attribute, or a value of the object the triangle belongs to.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum AttributeKey {
    /// A named attribute of the mesh (the Attribute node's Geometry type, a Color Attribute
    /// node's layer): `_CAUSTIC_ATTR_<hex of the name>` on the primitive.
    Named(String),
    /// The mesh's render colour attribute (a Color Attribute node without a name):
    /// `_CAUSTIC_RENDER_COLOR`.
    RenderColor,
    /// Geometry Pointiness (Cycles' `attr_create_pointiness`): `_CAUSTIC_POINTINESS`.
    Pointiness,
    /// Geometry Random Per Island (Cycles' `attr_create_random_per_island`):
    /// `_CAUSTIC_RANDOM_PER_ISLAND`.
    RandomPerIsland,
    /// The Attribute node's Object type: a property of the object or its data, per instance
    /// (`CAUSTIC_object_attributes.object` in the node's extras).
    Object(String),
    /// The Attribute node's Instancer type: the instancer's (its particle settings, the
    /// instancing object), else the object's (`CAUSTIC_object_attributes.instancer`).
    Instancer(String),
}

/// The prefix of a named attribute's glTF semantic; the name follows in upper-case hex of its
/// UTF-8 bytes, so that any Blender name (spaces, dots, case) makes a valid semantic.
pub const NAMED_SEMANTIC_PREFIX: &str = "_CAUSTIC_ATTR_";

impl AttributeKey {
    /// The glTF attribute semantic that carries the key on a primitive; None for the keys
    /// carried per instance.
    pub fn semantic(&self) -> Option<String> {
        Some(match self {
            AttributeKey::Named(name) => {
                let hex: String = name.bytes().map(|b| format!("{b:02X}")).collect();
                format!("{NAMED_SEMANTIC_PREFIX}{hex}")
            }
            AttributeKey::RenderColor => "_CAUSTIC_RENDER_COLOR".into(),
            AttributeKey::Pointiness => "_CAUSTIC_POINTINESS".into(),
            AttributeKey::RandomPerIsland => "_CAUSTIC_RANDOM_PER_ISLAND".into(),
            AttributeKey::Object(_) | AttributeKey::Instancer(_) => return None,
        })
    }

    /// The key a primitive's attribute semantic carries (glTF's full name, leading underscore
    /// included); None for any other semantic, and for a `_CAUSTIC_ATTR_` whose hex is not
    /// a UTF-8 name (`Err` with the reason).
    pub fn from_semantic(semantic: &str) -> Option<Result<AttributeKey, String>> {
        Some(Ok(match semantic {
            "_CAUSTIC_RENDER_COLOR" => AttributeKey::RenderColor,
            "_CAUSTIC_POINTINESS" => AttributeKey::Pointiness,
            "_CAUSTIC_RANDOM_PER_ISLAND" => AttributeKey::RandomPerIsland,
            s => {
                let hex = s.strip_prefix(NAMED_SEMANTIC_PREFIX)?;
                return Some(decode_hex_name(hex).map(AttributeKey::Named));
            }
        }))
    }

    /// How messages name it.
    pub fn describe(&self) -> String {
        match self {
            AttributeKey::Named(n) => format!("attribute '{n}'"),
            AttributeKey::RenderColor => "the render colour attribute".into(),
            AttributeKey::Pointiness => "Pointiness".into(),
            AttributeKey::RandomPerIsland => "Random Per Island".into(),
            AttributeKey::Object(n) => format!("object attribute '{n}'"),
            AttributeKey::Instancer(n) => format!("instancer attribute '{n}'"),
        }
    }
}

/// The name a `_CAUSTIC_ATTR_` semantic's hex spells.
fn decode_hex_name(hex: &str) -> Result<String, String> {
    if !hex.len().is_multiple_of(2) || !hex.bytes().all(|b| b.is_ascii_digit() || (b'A'..=b'F').contains(&b)) {
        return Err(format!("'{NAMED_SEMANTIC_PREFIX}{hex}' does not end in upper-case hex byte pairs"));
    }
    let bytes: Vec<u8> = (0..hex.len() / 2)
        .map(|i| u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).expect("checked hex digits"))
        .collect();
    String::from_utf8(bytes).map_err(|_| format!("'{NAMED_SEMANTIC_PREFIX}{hex}' is not a UTF-8 name"))
}

/// The Attribute node's outputs at a point, as Cycles' `svm_node_attr` gives them for the
/// attribute's type: Color and Vector, Fac, Alpha.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AttributeValue {
    /// Color and Vector.
    pub vector: Vec3,
    /// Fac.
    pub fac: f32,
    /// Alpha.
    pub alpha: f32,
}

/// An attribute the mesh (or object) does not have: Cycles' `attribute_not_found`, read as
/// 0, with Alpha 1 (its descriptor then takes the Alpha output's type, a float3 one).
pub const NOT_FOUND: AttributeValue = AttributeValue { vector: Vec3::ZERO, fac: 0.0, alpha: 1.0 };

/// One row of a full-width attribute: Vector xyz, Alpha, Fac.
pub type AttributeRow = [f32; FULL];

/// Floats a vertex takes in a full-width attribute.
pub const FULL: usize = 5;

/// The row of a vertex without the attribute: NaN, which no stored value is (the loader
/// refuses non-finite values), so that a lookup can tell a value from its absence.
const NOT_FOUND_ROW: AttributeRow = [f32::NAN; FULL];

/// Cycles' `average` of a float3.
#[inline]
fn average(x: f32, y: f32, z: f32) -> f32 {
    (x + y + z) * (1.0 / 3.0)
}

impl AttributeValue {
    /// The outputs of one attribute value of `n` components (1 to 4), by Cycles' rules
    /// (`svm_node_attr`): a float f gives Vector (f, f, f), Fac f, Alpha 1; a float2 (x, y)
    /// Vector (x, y, 0), Fac x, Alpha 1; a float3 Fac the average, Alpha 1; a float4 or RGBA
    /// Vector its first three, Fac their average, Alpha the fourth.
    pub fn row(v: &[f32]) -> AttributeRow {
        match *v {
            [f] => [f, f, f, 1.0, f],
            [x, y] => [x, y, 0.0, 1.0, x],
            [x, y, z] => [x, y, z, 1.0, average(x, y, z)],
            [x, y, z, w, ..] => [x, y, z, w, average(x, y, z)],
            [] => [0.0, 0.0, 0.0, 1.0, 0.0],
        }
    }
}

/// One attribute of every vertex of the mesh (`Mesh::attributes`). Vertices without it (a
/// primitive without it, and those past the stored rows: a mesh appended after the
/// attribute's last primitive) read as not found.
#[derive(Clone, Debug, PartialEq)]
pub struct VertexAttribute {
    /// What it is.
    pub key: AttributeKey,
    /// Floats per vertex: 1 (a float s: Vector (s, s, s), Fac s, Alpha 1) while every value so
    /// far was a float, else `FULL` (Vector xyz, Alpha, Fac).
    pub width: usize,
    /// `width` floats per vertex; NaN where a vertex does not have the attribute.
    pub values: Vec<f32>,
}

impl VertexAttribute {
    /// An attribute without rows.
    pub fn new(key: AttributeKey) -> VertexAttribute {
        VertexAttribute { key, width: 1, values: Vec::new() }
    }

    /// Vertices stored (the rest read as not found).
    pub fn len(&self) -> usize {
        self.values.len() / self.width
    }

    /// No vertex stored.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// Vertex `v`'s full row (NaN where the vertex does not have the attribute).
    #[inline]
    fn row(&self, v: usize) -> AttributeRow {
        match self.width {
            1 => match self.values.get(v) {
                Some(&s) => scalar_row(s),
                None => NOT_FOUND_ROW,
            },
            _ => match self.values.get(v * FULL..v * FULL + FULL) {
                Some(r) => r.try_into().expect("FULL floats"),
                None => NOT_FOUND_ROW,
            },
        }
    }

    /// The outputs at barycentrics (b1, b2) of the triangle of vertices `t`; None where the
    /// triangle's vertices do not have the attribute. A value equal at the three corners is
    /// returned as it is, so that a face attribute (written equal at a face's corners) reads
    /// exactly its value, as Cycles' face attributes do (Random Per Island is hashed further
    /// by many graphs).
    #[inline]
    pub fn at(&self, t: [u32; 3], b1: f32, b2: f32) -> Option<AttributeValue> {
        let [r0, r1, r2] = t.map(|i| self.row(i as usize));
        if r0[0].is_nan() || r1[0].is_nan() || r2[0].is_nan() {
            return None;
        }
        let b0 = 1.0 - b1 - b2;
        let mut out = [0.0; FULL];
        for k in 0..FULL {
            out[k] = if r0[k] == r1[k] && r1[k] == r2[k] { r0[k] } else { r0[k] * b0 + r1[k] * b1 + r2[k] * b2 };
        }
        Some(AttributeValue { vector: Vec3::new(out[0], out[1], out[2]), alpha: out[3], fac: out[4] })
    }

    /// Makes every row full width.
    fn widen(&mut self) {
        if self.width == FULL {
            return;
        }
        self.values = self.values.iter().flat_map(|&s| scalar_row(s)).collect();
        self.width = FULL;
    }

    /// Sets the rows of vertices `first..` to `rows` (each 1 to 4 components, all of one
    /// count), not-found rows filling any gap before `first`.
    pub fn set(&mut self, first: usize, components: usize, rows: impl ExactSizeIterator<Item = Vec4>) {
        if components != 1 {
            self.widen();
        }
        let fill: &[f32] = if self.width == 1 { &[f32::NAN] } else { &NOT_FOUND_ROW };
        while self.len() < first {
            self.values.extend_from_slice(fill);
        }
        self.values.truncate(first * self.width);
        self.values.reserve(rows.len() * self.width);
        for r in rows {
            if self.width == 1 {
                self.values.push(r.x);
            } else {
                self.values.extend_from_slice(&AttributeValue::row(&r.to_array()[..components]));
            }
        }
    }

    /// Pads the rows to `n` vertices with not-found rows.
    pub fn pad(&mut self, n: usize) {
        let fill: &[f32] = if self.width == 1 { &[f32::NAN] } else { &NOT_FOUND_ROW };
        while self.len() < n {
            self.values.extend_from_slice(fill);
        }
    }
}

/// A float's full row (a NaN, not found, to a row of NaN).
#[inline]
fn scalar_row(s: f32) -> AttributeRow {
    if s.is_nan() { NOT_FOUND_ROW } else { [s, s, s, 1.0, s] }
}

impl Mesh {
    /// The attribute `key`, if some vertex has it.
    #[inline]
    pub fn attribute(&self, key: &AttributeKey) -> Option<&VertexAttribute> {
        self.attributes.iter().find(|a| &a.key == key)
    }

    /// Attribute `key` at barycentrics (b1, b2) of triangle `tri`: None (not found) off the
    /// mesh (a curve, the world) and where the triangle's mesh does not have it.
    #[inline]
    pub fn attribute_at(&self, key: &AttributeKey, tri: u32, b1: f32, b2: f32) -> Option<AttributeValue> {
        match (self.attribute(key), self.triangles.get(tri as usize)) {
            (Some(a), Some(&t)) => a.at(t, b1, b2),
            _ => None,
        }
    }

    /// The attribute `key`, made if absent.
    pub fn attribute_mut(&mut self, key: &AttributeKey) -> &mut VertexAttribute {
        match self.attributes.iter().position(|a| &a.key == key) {
            Some(i) => &mut self.attributes[i],
            None => {
                self.attributes.push(VertexAttribute::new(key.clone()));
                self.attributes.last_mut().expect("just pushed")
            }
        }
    }

    /// Appends `other`'s attributes to vertices `v0..` (this mesh's vertices before
    /// `other`'s were appended): merged by key, not-found rows where one side lacks one.
    pub fn append_attributes(&mut self, other: &mut Mesh, v0: usize) {
        for a in std::mem::take(&mut other.attributes) {
            let mine = self.attribute_mut(&a.key);
            if a.width == FULL {
                mine.widen();
            }
            mine.pad(v0);
            mine.values.truncate(v0 * mine.width);
            if mine.width == a.width {
                mine.values.extend_from_slice(&a.values);
            } else {
                mine.values.extend(a.values.iter().flat_map(|&s| scalar_row(s)));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn semantics_name_every_key_and_back() {
        for key in [
            AttributeKey::Named("Wet paint.001 é".into()),
            AttributeKey::Named(String::new()),
            AttributeKey::RenderColor,
            AttributeKey::Pointiness,
            AttributeKey::RandomPerIsland,
        ] {
            let s = key.semantic().expect("a mesh attribute");
            assert!(
                s.starts_with("_CAUSTIC_")
                    && s.bytes().all(|b| b == b'_' || b.is_ascii_uppercase() || b.is_ascii_digit()),
                "{s}"
            );
            assert_eq!(AttributeKey::from_semantic(&s), Some(Ok(key)));
        }
        assert_eq!(AttributeKey::Named("foo".into()).semantic().unwrap(), "_CAUSTIC_ATTR_666F6F");
        assert_eq!(AttributeKey::from_semantic("_FOO"), None);
        assert!(AttributeKey::from_semantic("_CAUSTIC_ATTR_6G").unwrap().is_err());
        assert!(AttributeKey::from_semantic("_CAUSTIC_ATTR_FF").unwrap().is_err(), "not UTF-8");
        assert!(AttributeKey::Object("foo".into()).semantic().is_none());
    }

    /// Cycles' conversions of each type to the node's outputs.
    #[test]
    fn rows_follow_cycles_output_rules() {
        assert_eq!(AttributeValue::row(&[0.3]), [0.3, 0.3, 0.3, 1.0, 0.3]);
        assert_eq!(AttributeValue::row(&[0.3, 0.6]), [0.3, 0.6, 0.0, 1.0, 0.3]);
        assert_eq!(AttributeValue::row(&[0.3, 0.6, 0.9]), [0.3, 0.6, 0.9, 1.0, (0.3 + 0.6 + 0.9) * (1.0 / 3.0)]);
        assert_eq!(AttributeValue::row(&[0.3, 0.6, 0.9, 0.5])[3], 0.5);
    }

    #[test]
    fn scalar_and_full_rows_mix_and_missing_vertices_read_not_found() {
        let mut a = VertexAttribute::new(AttributeKey::Named("a".into()));
        a.set(2, 1, [Vec4::splat(0.5), Vec4::splat(0.25)].into_iter());
        assert_eq!(a.width, 1);
        assert_eq!(a.len(), 4);
        assert_eq!(a.at([0, 1, 0], 0.5, 0.25), None);
        let v = a.at([2, 2, 2], 0.3, 0.3).unwrap();
        assert_eq!((v.vector, v.fac, v.alpha), (Vec3::splat(0.5), 0.5, 1.0));
        // A colour after: every row goes full width, earlier ones keep their values.
        a.set(4, 4, [Vec4::new(1.0, 0.0, 0.0, 0.5)].into_iter());
        assert_eq!(a.width, FULL);
        assert_eq!(a.at([3, 3, 3], 0.2, 0.2).unwrap().fac, 0.25);
        assert_eq!(a.at([0, 0, 0], 0.2, 0.2), None, "the gap stays not found");
        let c = a.at([4, 4, 4], 0.2, 0.2).unwrap();
        assert_eq!((c.vector, c.alpha), (Vec3::X, 0.5));
        // Past the stored rows: not found.
        assert_eq!(a.at([9, 9, 9], 0.2, 0.2), None);
        // Interpolated where the corners differ.
        let mid = a.at([2, 3, 2], 0.5, 0.0).unwrap();
        assert!((mid.fac - 0.375).abs() < 1e-6, "{mid:?}");
    }

    /// A value equal at the three corners reads bit for bit, whatever the barycentrics (a
    /// plain blend can round it by an ulp, which a hash of it would magnify).
    #[test]
    fn equal_corners_read_exactly() {
        let x = 0.123_456_79_f32;
        let mut a = VertexAttribute::new(AttributeKey::RandomPerIsland);
        a.set(0, 1, [Vec4::splat(x); 3].into_iter());
        for (b1, b2) in [(0.1, 0.7), (0.333, 0.333), (0.9, 0.05)] {
            assert_eq!(a.at([0, 1, 2], b1, b2).unwrap().fac.to_bits(), x.to_bits());
        }
    }

    #[test]
    fn appending_meshes_merges_attributes_by_key() {
        let key = AttributeKey::Named("w".into());
        let mut m = Mesh { positions: vec![Vec3::ZERO; 3], ..Default::default() };
        m.attribute_mut(&key).set(0, 1, [Vec4::splat(1.0); 3].into_iter());
        let mut other = Mesh { positions: vec![Vec3::ZERO; 2], ..Default::default() };
        other.attribute_mut(&AttributeKey::Pointiness).set(0, 1, [Vec4::splat(0.5); 2].into_iter());
        other.attribute_mut(&key).set(0, 3, [Vec4::new(0.0, 1.0, 0.0, 0.0); 2].into_iter());
        m.append_attributes(&mut other, 3);
        let w = m.attribute(&key).unwrap();
        assert_eq!((w.width, w.len()), (FULL, 5));
        assert_eq!(w.at([0, 0, 0], 0.1, 0.1).unwrap().fac, 1.0);
        assert_eq!(w.at([4, 4, 4], 0.1, 0.1).unwrap().vector, Vec3::Y);
        let p = m.attribute(&AttributeKey::Pointiness).unwrap();
        assert_eq!(p.at([0, 1, 2], 0.2, 0.2), None);
        assert_eq!(p.at([3, 4, 3], 0.2, 0.2).unwrap().fac, 0.5);
    }
}
