//! `EXT_meshopt_compression` (gltfpack's compressed buffer views): each compressed view
//! decoded by meshoptimizer's own decoders (the `meshopt` crate, which builds its C++)
//! into a buffer of the loader's own, with the OCTAHEDRAL, QUATERNION and EXPONENTIAL
//! filters, and the view pointed at it. The fallback buffers (often without data) are
//! then never read. Runs on the raw JSON before the typed document is built; every
//! argument the C++ asserts on is checked here first, since its asserts abort.

use super::Loader;
use crate::error::Result;
use serde_json::{Value, json};

pub(super) const EXTENSION: &str = "EXT_meshopt_compression";

/// Whether any buffer view of the file carries the extension.
pub(super) fn present(value: &Value) -> bool {
    value
        .get("bufferViews")
        .and_then(Value::as_array)
        .into_iter()
        .flatten()
        .any(|v| v.pointer(&format!("/extensions/{EXTENSION}")).is_some())
}

/// Fallback buffers without data get an empty data URI so that loading them reads nothing;
/// a view left on one then fails the views' bounds check by name.
pub(super) fn empty_fallbacks(value: &mut Value) {
    let Some(buffers) = value.get_mut("buffers").and_then(Value::as_array_mut) else { return };
    for b in buffers {
        let fallback = b.pointer(&format!("/extensions/{EXTENSION}/fallback")).and_then(Value::as_bool) == Some(true);
        if fallback && b.get("uri").is_none() {
            b["uri"] = json!("data:application/octet-stream;base64,");
            b["byteLength"] = json!(0);
        }
    }
}

/// "mesh 2 ('name'): " for the first mesh whose primitives read view `view`, else "".
fn meshes_reading(value: &Value, view: usize) -> String {
    let accessors = value.get("accessors").and_then(Value::as_array);
    let reads = |a: &Value| {
        let acc = a.as_u64().and_then(|a| accessors.and_then(|acc| acc.get(a as usize)));
        acc.and_then(|a| a.get("bufferView")).and_then(Value::as_u64) == Some(view as u64)
    };
    for (mi, mesh) in value.get("meshes").and_then(Value::as_array).into_iter().flatten().enumerate() {
        for prim in mesh.get("primitives").and_then(Value::as_array).into_iter().flatten() {
            let attributes = prim.get("attributes").and_then(Value::as_object).into_iter().flatten().map(|(_, a)| a);
            if attributes.chain(prim.get("indices")).any(reads) {
                let name = mesh.get("name").and_then(Value::as_str).map(|n| format!(" ('{n}')")).unwrap_or_default();
                return format!("mesh {mi}{name}: ");
            }
        }
    }
    String::new()
}

impl Loader<'_> {
    /// Decodes every compressed view of `value` into a new buffer appended to `buffers`
    /// (and to the JSON's buffers), and points the view at it.
    pub(super) fn decode_meshopt(&self, value: &mut Value, buffers: &mut Vec<Vec<u8>>) -> Result<()> {
        let mut views = value.get("bufferViews").and_then(Value::as_array).cloned().unwrap_or_default();
        let mut out: Vec<u8> = Vec::new();
        let buffer_index = buffers.len();
        for (vi, view) in views.iter_mut().enumerate() {
            let Some(ext) = view.pointer(&format!("/extensions/{EXTENSION}")).cloned() else { continue };
            let what = format!("{}bufferView {vi} ({EXTENSION})", meshes_reading(value, vi));
            let decoded = self.decode_view(&ext, buffers, &what)?;
            out.resize(out.len().next_multiple_of(4), 0);
            let start = out.len();
            out.extend_from_slice(&decoded);
            view["buffer"] = json!(buffer_index);
            view["byteOffset"] = json!(start);
            view["byteLength"] = json!(decoded.len());
            if let Some(exts) = view.get_mut("extensions").and_then(Value::as_object_mut) {
                exts.remove(EXTENSION);
            }
        }
        let root = value.as_object_mut().expect("checked to be an object");
        root.insert("bufferViews".into(), Value::Array(views));
        let mut bufs = root.get("buffers").and_then(Value::as_array).cloned().unwrap_or_default();
        // No uri: the bytes are already in `buffers`, which is never reloaded.
        bufs.push(json!({ "byteLength": out.len(), "name": "decoded EXT_meshopt_compression" }));
        root.insert("buffers".into(), Value::Array(bufs));
        buffers.push(out);
        Ok(())
    }

    /// One view's `count` elements of `byteStride` bytes, decoded and filtered.
    fn decode_view(&self, ext: &Value, buffers: &[Vec<u8>], what: &str) -> Result<Vec<u8>> {
        let num = |key: &str| ext.get(key).and_then(Value::as_u64);
        let text = |key: &str| ext.get(key).and_then(Value::as_str).unwrap_or("");
        let source = num("buffer").and_then(|b| buffers.get(b as usize));
        let (offset, length) = (num("byteOffset").unwrap_or(0), num("byteLength").unwrap_or(0));
        let bytes = source.and_then(|b| {
            let start = usize::try_from(offset).ok()?;
            b.get(start..start.checked_add(usize::try_from(length).ok()?)?)
        });
        let Some(bytes) = bytes else {
            return Err(self.err(format!(
                "{what}: the compressed bytes (buffer {:?}, offset {offset}, length {length}) lie outside the file's buffers",
                num("buffer")
            )));
        };
        let (Some(count), Some(stride)) = (num("count"), num("byteStride")) else {
            return Err(self.err(format!("{what}: count and byteStride are required")));
        };
        let (mode, filter) = (text("mode"), ext.get("filter").and_then(Value::as_str).unwrap_or("NONE"));
        let size = count.checked_mul(stride).filter(|&s| s <= u32::MAX as u64);
        let Some(size) = size else {
            return Err(self.err(format!("{what}: {count} elements of {stride} bytes is too large")));
        };
        self.budget.charge(format!("{what}: the decoded view"), size)?;
        let (count, stride) = (count as usize, stride as usize);
        let mut data = vec![0u8; size as usize];
        let code = match mode {
            "ATTRIBUTES" => {
                if stride == 0 || stride > 256 || !stride.is_multiple_of(4) {
                    return Err(
                        self.err(format!("{what}: ATTRIBUTES byteStride {stride} (must be 4 to 256, a multiple of 4)"))
                    );
                }
                // SAFETY: `data` holds `count * stride` bytes; the stride is one the decoder accepts.
                unsafe {
                    meshopt::ffi::meshopt_decodeVertexBuffer(
                        data.as_mut_ptr().cast(),
                        count,
                        stride,
                        bytes.as_ptr(),
                        bytes.len(),
                    )
                }
            }
            "TRIANGLES" | "INDICES" => {
                if stride != 2 && stride != 4 {
                    return Err(self.err(format!("{what}: {mode} byteStride {stride} (must be 2 or 4)")));
                }
                if mode == "TRIANGLES" && !count.is_multiple_of(3) {
                    return Err(self.err(format!("{what}: TRIANGLES count {count} is not a multiple of 3")));
                }
                // SAFETY: `data` holds `count * stride` bytes; the index size and count are ones
                // the decoder accepts.
                unsafe {
                    let decode = if mode == "TRIANGLES" {
                        meshopt::ffi::meshopt_decodeIndexBuffer
                    } else {
                        meshopt::ffi::meshopt_decodeIndexSequence
                    };
                    decode(data.as_mut_ptr().cast(), count, stride, bytes.as_ptr(), bytes.len())
                }
            }
            other => return Err(self.err(format!("{what}: unknown mode '{other}'"))),
        };
        if code != 0 {
            return Err(self.err(format!("{what}: the compressed data cannot be decoded (meshoptimizer error {code})")));
        }
        let filter_fn = match (filter, mode) {
            ("NONE", _) => None,
            ("OCTAHEDRAL", "ATTRIBUTES") if stride == 4 || stride == 8 => {
                Some(meshopt::ffi::meshopt_decodeFilterOct as _)
            }
            ("QUATERNION", "ATTRIBUTES") if stride == 8 => Some(meshopt::ffi::meshopt_decodeFilterQuat as _),
            ("EXPONENTIAL", "ATTRIBUTES") => Some(meshopt::ffi::meshopt_decodeFilterExp as _),
            _ => {
                return Err(self.err(format!(
                    "{what}: filter {filter} with mode {mode} and byteStride {stride} is not one the extension defines"
                )));
            }
        };
        if let Some(f) = filter_fn {
            let f: unsafe extern "C" fn(*mut std::os::raw::c_void, usize, usize) = f;
            // SAFETY: `data` holds `count * stride` bytes and the stride is the filter's.
            unsafe { f(data.as_mut_ptr().cast(), count, stride) };
        }
        Ok(data)
    }
}
