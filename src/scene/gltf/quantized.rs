//! Vertex attributes as floats whatever their component type: glTF's own float and
//! normalized-integer attributes and `KHR_mesh_quantization`'s integer ones (positions,
//! normals, tangents and texture coordinates as bytes or shorts, normalized or not).

use gltf::accessor::{DataType, Item, Iter};

/// Which component types an attribute may use: glTF 2.0 alone, or with
/// `KHR_mesh_quantization` declared in `extensionsUsed`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Quantization {
    /// Core glTF: float positions, normals and tangents.
    Core,
    /// The extension is declared: integer positions, normals, tangents, texture coordinates.
    Allowed,
}

/// Whether `semantic` may be stored as `data_type` (normalized or not) with `dims`
/// components: the tables of glTF 2.0 §3.7.2.1 and of `KHR_mesh_quantization`.
pub(super) fn attribute_type_allowed(
    semantic: &gltf::Semantic,
    data_type: DataType,
    normalized: bool,
    dims: gltf::accessor::Dimensions,
    q: Quantization,
) -> bool {
    use DataType as T;
    use gltf::Semantic as S;
    use gltf::accessor::Dimensions as D;
    let ext = q == Quantization::Allowed;
    match semantic {
        S::Positions => dims == D::Vec3 && (data_type == T::F32 || (ext && data_type != T::U32)),
        S::Normals => {
            dims == D::Vec3 && (data_type == T::F32 || (ext && normalized && matches!(data_type, T::I8 | T::I16)))
        }
        S::Tangents => {
            dims == D::Vec4 && (data_type == T::F32 || (ext && normalized && matches!(data_type, T::I8 | T::I16)))
        }
        // Core glTF wants unsigned texture coordinates normalized; files that forget the
        // flag are read as normalized, as before (see `read_f32`).
        S::TexCoords(_) => {
            dims == D::Vec2 && (matches!(data_type, T::F32 | T::U8 | T::U16) || (ext && data_type != T::U32))
        }
        S::Colors(_) => matches!(dims, D::Vec3 | D::Vec4) && matches!(data_type, T::F32 | T::U8 | T::U16),
        S::Joints(_) => dims == D::Vec4 && matches!(data_type, T::U8 | T::U16),
        S::Weights(_) => dims == D::Vec4 && matches!(data_type, T::F32 | T::U8 | T::U16),
        #[allow(unreachable_patterns)]
        _ => true,
    }
}

/// Reads an accessor of N components as floats (sparse substitution and strides by the
/// crate): normalized integers by glTF's rule (unsigned c / MAX, signed max(c / MAX, -1)),
/// others by their value; `normalize` reads integers as normalized whatever the flag (core
/// glTF's unsigned texture coordinates). None when the accessor's data cannot be read.
pub(super) fn read_f32<const N: usize>(
    acc: &gltf::Accessor,
    buffers: &[Vec<u8>],
    normalize: bool,
) -> Option<Vec<[f32; N]>>
where
    [f32; N]: Item,
    [i8; N]: Item,
    [u8; N]: Item,
    [i16; N]: Item,
    [u16; N]: Item,
    [u32; N]: Item,
{
    let normalized = acc.normalized() || normalize;
    let data = |b: gltf::Buffer| buffers.get(b.index()).map(|v| v.as_slice());
    fn map<T: Copy, const N: usize>(it: Iter<[T; N]>, f: impl Fn(T) -> f32) -> Vec<[f32; N]>
    where
        [T; N]: Item,
    {
        it.map(|v| v.map(&f)).collect()
    }
    Some(match acc.data_type() {
        DataType::F32 => Iter::<[f32; N]>::new(acc.clone(), data)?.collect(),
        DataType::I8 if normalized => map(Iter::<[i8; N]>::new(acc.clone(), data)?, |c| (c as f32 / 127.0).max(-1.0)),
        DataType::U8 if normalized => map(Iter::<[u8; N]>::new(acc.clone(), data)?, |c| c as f32 / 255.0),
        DataType::I16 if normalized => {
            map(Iter::<[i16; N]>::new(acc.clone(), data)?, |c| (c as f32 / 32767.0).max(-1.0))
        }
        DataType::U16 if normalized => map(Iter::<[u16; N]>::new(acc.clone(), data)?, |c| c as f32 / 65535.0),
        DataType::I8 => map(Iter::<[i8; N]>::new(acc.clone(), data)?, |c| c as f32),
        DataType::U8 => map(Iter::<[u8; N]>::new(acc.clone(), data)?, |c| c as f32),
        DataType::I16 => map(Iter::<[i16; N]>::new(acc.clone(), data)?, |c| c as f32),
        DataType::U16 => map(Iter::<[u16; N]>::new(acc.clone(), data)?, |c| c as f32),
        DataType::U32 => map(Iter::<[u32; N]>::new(acc.clone(), data)?, |c| c as f32),
    })
}

#[cfg(test)]
mod tests {
    use base64::Engine;
    use glam::{Vec2, Vec3};
    use serde_json::json;

    /// A quad stored as KHR_mesh_quantization allows (positions as normalized shorts scaled
    /// by the node, normals as normalized bytes, texture coordinates as unnormalized unsigned
    /// shorts undone by KHR_texture_transform's scale is the usual pairing, but here read
    /// raw), or refused when the file does not declare the extension.
    fn quad(declare: bool) -> crate::error::Result<crate::scene::Scene> {
        // VEC3 of shorts padded to 8 bytes per element (the extension's 4-byte alignment).
        let pos: [[i16; 4]; 4] =
            [[-32767, -32767, 0, 0], [32767, -32767, 0, 0], [32767, 32767, 0, 0], [-32767, 32767, 0, 0]];
        let nrm: [[i8; 4]; 4] = [[0, 0, 127, 0]; 4]; // VEC3 padded to 4 bytes per element
        let uv: [[u16; 2]; 4] = [[0, 0], [3, 0], [3, 5], [0, 5]];
        let mut data: Vec<u8> = pos.iter().flatten().flat_map(|c| c.to_le_bytes()).collect(); // 32 bytes
        data.extend(nrm.iter().flatten().map(|&c| c as u8)); // 16 bytes
        data.extend(uv.iter().flatten().flat_map(|c| c.to_le_bytes())); // 16 bytes
        data.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|c| c.to_le_bytes())); // 12 bytes
        let used: Vec<&str> = if declare { vec!["KHR_mesh_quantization"] } else { vec![] };
        let doc = json!({
            "asset": {"version": "2.0"},
            "extensionsUsed": used,
            "buffers": [{"uri": format!("data:application/octet-stream;base64,{}",
                base64::engine::general_purpose::STANDARD.encode(&data)), "byteLength": data.len()}],
            "bufferViews": [
                {"buffer": 0, "byteOffset": 0, "byteLength": 32, "byteStride": 8},
                {"buffer": 0, "byteOffset": 32, "byteLength": 16, "byteStride": 4},
                {"buffer": 0, "byteOffset": 48, "byteLength": 16},
                {"buffer": 0, "byteOffset": 64, "byteLength": 12}
            ],
            "accessors": [
                {"bufferView": 0, "componentType": 5122, "normalized": true, "count": 4, "type": "VEC3",
                 "min": [-32767, -32767, 0], "max": [32767, 32767, 0]},
                {"bufferView": 1, "componentType": 5120, "normalized": true, "count": 4, "type": "VEC3"},
                {"bufferView": 2, "componentType": 5123, "count": 4, "type": "VEC2"},
                {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}
            ],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3}]}],
            "nodes": [{"mesh": 0, "scale": [2.0, 2.0, 2.0], "translation": [0.0, 0.0, 1.0]}],
            "scenes": [{"nodes": [0]}]
        });
        let bytes = serde_json::to_vec(&doc).unwrap();
        let budget = crate::memory::MemoryBudget::unlimited();
        crate::scene::gltf::load_bytes(&bytes, std::path::Path::new("."), "quantized.gltf", &budget)
    }

    #[test]
    fn quantized_attributes_are_dequantized_by_the_specs_rules() {
        let scene = quad(true).expect("a quantized file loads");
        let m = &scene.mesh;
        // Normalized shorts: ±32767 → ±1, then the node's scale 2 and translation.
        let mut corners: Vec<Vec3> = m.positions.clone();
        corners.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
        let expect = [Vec3::new(-2., -2., 1.), Vec3::new(-2., 2., 1.), Vec3::new(2., -2., 1.), Vec3::new(2., 2., 1.)];
        for (c, e) in corners.iter().zip(expect) {
            assert!((*c - e).length() < 1e-6, "{c} vs {e}");
        }
        // Normalized bytes: 127 → 1.
        assert!(m.normals.iter().all(|n| (*n - Vec3::Z).length() < 1e-6), "{:?}", m.normals);
        // Unnormalized unsigned shorts under the extension: their values.
        for want in [Vec2::new(0., 0.), Vec2::new(3., 0.), Vec2::new(3., 5.), Vec2::new(0., 5.)] {
            assert!(m.uv0.iter().any(|u| (*u - want).length() < 1e-6), "{want} not in {:?}", m.uv0);
        }
    }

    #[test]
    fn integer_positions_without_the_extension_are_refused_by_name() {
        let err = quad(false).expect_err("core glTF has float positions only").to_string();
        assert!(err.contains("POSITION") && err.contains("KHR_mesh_quantization"), "{err}");
    }
}
