//! `KHR_draco_mesh_compression`: each compressed primitive's Draco bitstream decoded
//! (`draco-core`, a pure Rust decoder) into a buffer of the loader's own, and the
//! primitive's accessors rewritten to read it, in the component types and normalization
//! they declare. Every later step (validation, morph, skin, mesh) then reads ordinary
//! accessors. Runs on the raw JSON before the typed document is rebuilt from it; every
//! offset, length, count and id in the file and the bitstream is untrusted.

use super::Loader;
use crate::error::Result;
use draco_core::{DataType, DecodeLimits, DecoderBuffer, MeshDecoder};
use serde_json::{Value, json};
use std::collections::HashSet;

pub(super) const EXTENSION: &str = "KHR_draco_mesh_compression";

/// Whether any primitive of the file carries the extension.
pub(super) fn present(value: &Value) -> bool {
    value.get("meshes").and_then(Value::as_array).into_iter().flatten().any(|m| {
        m.get("primitives")
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
            .any(|p| p.pointer(&format!("/extensions/{EXTENSION}")).is_some())
    })
}

/// glTF component types: (size in bytes, integer range) of `componentType`.
fn component(component_type: u64) -> Option<(usize, Option<(f64, f64)>)> {
    match component_type {
        5120 => Some((1, Some((i8::MIN as f64, i8::MAX as f64)))),
        5121 => Some((1, Some((0.0, u8::MAX as f64)))),
        5122 => Some((2, Some((i16::MIN as f64, i16::MAX as f64)))),
        5123 => Some((2, Some((0.0, u16::MAX as f64)))),
        5125 => Some((4, Some((0.0, u32::MAX as f64)))),
        5126 => Some((4, None)),
        _ => None,
    }
}

fn components(ty: &str) -> Option<usize> {
    match ty {
        "SCALAR" => Some(1),
        "VEC2" => Some(2),
        "VEC3" => Some(3),
        "VEC4" => Some(4),
        _ => None,
    }
}

/// The largest value of an integer Draco type, for normalized attributes.
fn draco_max(t: DataType) -> Option<f64> {
    match t {
        DataType::Int8 => Some(i8::MAX as f64),
        DataType::Uint8 => Some(u8::MAX as f64),
        DataType::Int16 => Some(i16::MAX as f64),
        DataType::Uint16 => Some(u16::MAX as f64),
        DataType::Int32 => Some(i32::MAX as f64),
        DataType::Uint32 => Some(u32::MAX as f64),
        _ => None,
    }
}

/// Appends `value` as one component of `size` bytes (`range`: the integer type's range).
fn push_component(out: &mut Vec<u8>, value: f64, size: usize, range: Option<(f64, f64)>, signed: bool) {
    match (range, size, signed) {
        (None, _, _) => out.extend_from_slice(&(value as f32).to_le_bytes()),
        (Some(_), 1, false) => out.push(value as u8),
        (Some(_), 1, true) => out.push(value as i8 as u8),
        (Some(_), 2, false) => out.extend_from_slice(&(value as u16).to_le_bytes()),
        (Some(_), 2, true) => out.extend_from_slice(&(value as i16).to_le_bytes()),
        (Some(_), _, _) => out.extend_from_slice(&(value as u32).to_le_bytes()),
    }
}

impl Loader<'_> {
    /// Decodes every `KHR_draco_mesh_compression` primitive of `value` into a new buffer
    /// appended to `buffers` (and to the JSON's buffers), and points the primitive's
    /// indices and compressed attributes at new accessors over it; the extension is then
    /// removed from the primitive.
    pub(super) fn decode_draco(&self, value: &mut Value, buffers: &mut Vec<Vec<u8>>) -> Result<()> {
        let list = |value: &Value, key: &str| -> Vec<Value> {
            value.get(key).and_then(Value::as_array).cloned().unwrap_or_default()
        };
        let mut out = Decoded {
            bytes: Vec::new(),
            buffer: buffers.len(),
            views: list(value, "bufferViews"),
            accessors: list(value, "accessors"),
            replaced: HashSet::new(),
        };
        let mut meshes = list(value, "meshes");
        let mut decoded = false;
        for (mi, mesh) in meshes.iter_mut().enumerate() {
            let mesh_name = match mesh.get("name").and_then(Value::as_str) {
                Some(n) => format!("mesh {mi} ('{n}')"),
                None => format!("mesh {mi}"),
            };
            let Some(prims) = mesh.get_mut("primitives").and_then(Value::as_array_mut) else { continue };
            for (pi, prim) in prims.iter_mut().enumerate() {
                let Some(ext) = prim.pointer(&format!("/extensions/{EXTENSION}")).cloned() else { continue };
                let what = format!("{mesh_name} primitive {pi} ({EXTENSION})");
                *prim = self.decode_primitive(value, buffers, prim, &ext, &what, &mut out)?;
                decoded = true;
            }
        }
        if !decoded {
            return Ok(());
        }
        let mut bufs = list(value, "buffers");
        // No uri: the bytes are already in `buffers`, which is never reloaded.
        bufs.push(json!({ "byteLength": out.bytes.len(), "name": "decoded KHR_draco_mesh_compression" }));
        let root = value.as_object_mut().expect("checked to be an object");
        root.insert("meshes".into(), Value::Array(meshes));
        root.insert("bufferViews".into(), Value::Array(out.views));
        root.insert("accessors".into(), Value::Array(out.accessors));
        root.insert("buffers".into(), Value::Array(bufs));
        buffers.push(out.bytes);
        Ok(())
    }

    /// One primitive: the bitstream decoded, its indices and attributes written to
    /// `out` as new views and accessors; returns the rewritten primitive.
    fn decode_primitive(
        &self,
        value: &Value,
        buffers: &[Vec<u8>],
        prim: &Value,
        ext: &Value,
        what: &str,
        file: &mut Decoded,
    ) -> Result<Value> {
        let mode = prim.get("mode").and_then(Value::as_u64).unwrap_or(4);
        if mode != 4 {
            return Err(self.err(format!("{what}: mode {mode} (Draco compresses triangle lists, mode 4, only)")));
        }
        if prim.get("targets").is_some() {
            return Err(self.err(format!("{what}: morph targets on a Draco-compressed primitive are not supported")));
        }
        // The compressed bytes: the extension's bufferView, checked against its buffer.
        let view_index = ext.get("bufferView").and_then(Value::as_u64);
        let view = view_index.and_then(|v| value.pointer(&format!("/bufferViews/{v}")));
        let Some(view) = view else {
            let named = ext.get("bufferView").map_or_else(|| "(missing)".to_string(), Value::to_string);
            return Err(self.err(format!("{what}: bufferView {named} is not a valid index")));
        };
        let view_index = view_index.unwrap_or_default();
        let buffer = view.get("buffer").and_then(Value::as_u64).and_then(|b| buffers.get(b as usize));
        let offset = view.get("byteOffset").and_then(Value::as_u64).unwrap_or(0);
        let length = view.get("byteLength").and_then(Value::as_u64).unwrap_or(0);
        let bytes = buffer.and_then(|b| {
            let start = usize::try_from(offset).ok()?;
            let end = start.checked_add(usize::try_from(length).ok()?)?;
            b.get(start..end)
        });
        let Some(bytes) = bytes else {
            return Err(self.err(format!(
                "{what}: bufferView {view_index} (offset {offset}, length {length}) lies outside its buffer"
            )));
        };
        let attributes = ext.get("attributes").and_then(Value::as_object).cloned().unwrap_or_default();
        let accessor = |index: Option<&Value>, name: &str| -> Result<(usize, Value)> {
            index
                .and_then(Value::as_u64)
                .and_then(|i| Some((i as usize, value.pointer(&format!("/accessors/{i}"))?.clone())))
                .ok_or_else(|| self.err(format!("{what}: {name} has no valid accessor")))
        };
        let count = |acc: &Value| acc.get("count").and_then(Value::as_u64).unwrap_or(0);
        let (_, position) = accessor(prim.pointer("/attributes/POSITION"), "POSITION")?;
        let indices = prim.get("indices").map(|i| accessor(Some(i), "indices")).transpose()?;
        let buffer_index = file.buffer;
        let points = count(&position);
        let corners = indices.as_ref().map_or(points, |(_, a)| count(a));

        // The decode, bounded by what the accessors declare (a header can claim anything).
        let declared_bytes = |acc: &Value| {
            let n = acc.get("type").and_then(Value::as_str).and_then(components).unwrap_or(4) as u64;
            count(acc).saturating_mul(n * 8)
        };
        let mut limit_bytes = 1u64 << 20;
        for (name, _) in &attributes {
            if let Ok((_, acc)) = accessor(prim.pointer(&format!("/attributes/{name}")), name) {
                limit_bytes = limit_bytes.saturating_add(declared_bytes(&acc));
            }
        }
        // What this primitive's decoded accessors will take (at most 16 bytes a vertex
        // per attribute, 4 an index), charged before the decoder allocates.
        let estimate = (attributes.len() as u64 * 16).saturating_mul(points).saturating_add(corners.saturating_mul(4));
        self.budget.charge(format!("{what}: the decoded geometry"), estimate)?;
        let limits = DecodeLimits::default()
            .with_max_points(points.max(1))
            .with_max_faces((corners / 3).max(1))
            .with_max_decoded_bytes(limit_bytes);
        let decoded = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let mut buffer = DecoderBuffer::new(bytes).with_limits(limits);
            let mut mesh = draco_core::Mesh::new();
            MeshDecoder::new().decode(&mut buffer, &mut mesh).map(|()| mesh)
        }));
        let mesh = match decoded {
            Ok(Ok(mesh)) => mesh,
            Ok(Err(e)) => {
                return Err(self.err(format!(
                    "{what}: the Draco data cannot be decoded: {e} (the accessors declare {points} vertices and \
                     {corners} indices)"
                )));
            }
            Err(_) => return Err(self.err(format!("{what}: the Draco data cannot be decoded (decoder failure)"))),
        };
        // Encoders drop vertices no triangle uses: fewer than declared is fine (the
        // rewritten accessors take the decoded counts), more is refused.
        let n = mesh.num_points();
        if n as u64 > points {
            return Err(self.err(format!(
                "{what}: the Draco data holds {n} vertices, but the POSITION accessor declares only {points}"
            )));
        }
        let mut new_prim = prim.clone();

        // Indices: every face's corners, in the accessor's type (a 32-bit list when the
        // primitive declares none), each below the vertex count.
        let faces = mesh.faces();
        if (faces.len() as u64).saturating_mul(3) > corners {
            return Err(self.err(format!(
                "{what}: the Draco data holds {} triangles, but the indices accessor declares only {corners} indices",
                faces.len()
            )));
        }
        let (index_accessor, mut acc) = match &indices {
            Some((i, acc)) => (Some(*i), acc.clone()),
            None => (None, json!({ "componentType": 5125, "type": "SCALAR" })),
        };
        acc["count"] = json!(faces.len() * 3);
        let ty = acc.get("componentType").and_then(Value::as_u64).unwrap_or(0);
        let size = match ty {
            5121 => 1,
            5123 => 2,
            5125 => 4,
            _ => return Err(self.err(format!("{what}: indices componentType {ty} is not an unsigned integer"))),
        };
        let max = if size == 4 { u32::MAX as u64 } else { (1u64 << (8 * size)) - 1 };
        align(&mut file.bytes);
        let start = file.bytes.len();
        for face in faces {
            for p in face {
                let i = p.0 as u64;
                if i >= n as u64 || i > max {
                    return Err(self.err(format!("{what}: decoded index {i} is out of range")));
                }
                push_component(&mut file.bytes, i as f64, size, Some((0.0, max as f64)), false);
            }
        }
        let view = json!({ "buffer": buffer_index, "byteOffset": start, "byteLength": file.bytes.len() - start });
        new_prim["indices"] = json!(file.add_accessor(index_accessor, &acc, view));

        // Attributes: each named Draco attribute in its accessor's declared type.
        for (name, id) in &attributes {
            let (acc_index, acc) = accessor(prim.pointer(&format!("/attributes/{name}")), name)
                .map_err(|_| self.err(format!("{what}: names attribute {name}, which the primitive does not have")))?;
            let attribute =
                id.as_u64().and_then(|id| u32::try_from(id).ok()).and_then(|id| mesh.attribute_by_unique_id(id));
            let Some(attribute) = attribute else {
                return Err(self.err(format!("{what}: {name}'s Draco attribute id {id} is not in the Draco data")));
            };
            if count(&acc) < n as u64 {
                return Err(self.err(format!(
                    "{what}: {name}'s accessor declares {} elements for {n} decoded vertices",
                    count(&acc)
                )));
            }
            let mut acc = acc;
            acc["count"] = json!(n);
            let ty = acc.get("componentType").and_then(Value::as_u64).unwrap_or(0);
            let comps = acc.get("type").and_then(Value::as_str).and_then(components);
            let (Some((size, range)), Some(comps)) = (component(ty), comps) else {
                return Err(self.err(format!("{what}: {name}'s accessor has an unsupported componentType or type")));
            };
            let draco_comps = attribute.num_components() as usize;
            if draco_comps != comps {
                return Err(self.err(format!(
                    "{what}: {name} has {draco_comps} components in the Draco data, its accessor {comps}"
                )));
            }
            let normalized = acc.get("normalized").and_then(Value::as_bool).unwrap_or(false);
            let draco_type = attribute.data_type();
            let signed = matches!(ty, 5120 | 5122);
            // Widened to f32 by the decoder (exact for every type glTF vertex attributes use).
            let raw = attribute.read_f32s(n, comps);
            // Draco's normalized integers to their value in [0, 1] or [-1, 1] ...
            let draco_scale = if attribute.normalized() { draco_max(draco_type) } else { None };
            let elem = size * comps;
            let stride = elem.next_multiple_of(4);
            align(&mut file.bytes);
            let start = file.bytes.len();
            for v in raw.chunks_exact(comps) {
                for &c in v {
                    let mut x = c as f64;
                    if let Some(m) = draco_scale {
                        x = (x / m).max(-1.0);
                    }
                    // ... and to the accessor's: float, normalized integer or plain integer.
                    let x = match range {
                        None => x,
                        Some((lo, hi)) => {
                            let q = match (normalized, draco_scale.is_some() || !draco_type.is_integral()) {
                                (true, true) => (x * hi).round(),
                                (true, false) | (false, _) => x,
                            };
                            if !(q >= lo && q <= hi) || q.fract() != 0.0 {
                                return Err(self.err(format!(
                                    "{what}: {name} decodes to {c}, which its accessor's componentType {ty} cannot hold"
                                )));
                            }
                            q
                        }
                    };
                    push_component(&mut file.bytes, x, size, range, signed);
                }
                file.bytes.resize(file.bytes.len() + (stride - elem), 0);
            }
            let mut view =
                json!({ "buffer": buffer_index, "byteOffset": start, "byteLength": file.bytes.len() - start });
            if stride != elem {
                view["byteStride"] = json!(stride);
            }
            new_prim["attributes"][name] = json!(file.add_accessor(Some(acc_index), &acc, view));
        }
        if let Some(exts) = new_prim.get_mut("extensions").and_then(Value::as_object_mut) {
            exts.remove(EXTENSION);
            if exts.is_empty() {
                new_prim.as_object_mut().expect("a primitive is an object").remove("extensions");
            }
        }
        Ok(new_prim)
    }
}

/// What the decode adds to the file: the new buffer's bytes and index, and the
/// document's views and accessors with the decoded ones among them.
struct Decoded {
    bytes: Vec<u8>,
    buffer: usize,
    views: Vec<Value>,
    accessors: Vec<Value>,
    /// Accessors of the file already pointed at decoded data.
    replaced: HashSet<usize>,
}

impl Decoded {
    /// `declared` reading `view` (a new view): the file's accessor `index` itself the
    /// first time (the crate refuses an accessor without a view, even unused), a copy
    /// after that (an accessor shared by two compressed primitives); returns its index.
    fn add_accessor(&mut self, index: Option<usize>, declared: &Value, view: Value) -> usize {
        let mut acc = declared.clone();
        if let Some(a) = acc.as_object_mut() {
            a.remove("sparse");
            a.remove("byteOffset");
            a.insert("bufferView".into(), json!(self.views.len()));
        }
        self.views.push(view);
        match index {
            Some(i) if self.replaced.insert(i) => {
                self.accessors[i] = acc;
                i
            }
            _ => {
                self.accessors.push(acc);
                self.accessors.len() - 1
            }
        }
    }
}

/// Pads `out` to a multiple of 4 bytes (glTF's alignment for every component type).
fn align(out: &mut Vec<u8>) {
    out.resize(out.len().next_multiple_of(4), 0);
}
