//! Validation the `gltf` crate leaves to us: every index points into its array, buffer
//! views lie inside their buffers, accessors inside their views, and attribute types are
//! the ones glTF allows. The crate indexes and unwraps on these unchecked (found by the
//! fuzzer), so they run before it sees the document.

use super::Loader;
use super::quantized::{Quantization, attribute_type_allowed};
use crate::error::Result;

impl Loader<'_> {
    /// Checks every primitive's attribute and index accessors and image sources against
    /// the types glTF allows: the crate's readers and `Image::source`
    /// reach `unreachable!()` or unwrap `None` on anything else (found by the fuzzer).
    pub(super) fn check_accessor_types(&self, doc: &gltf::Document) -> Result<()> {
        use gltf::accessor::{DataType as T, Dimensions as D};
        let quantization = self.quantization;
        for m in doc.meshes() {
            for prim in m.primitives() {
                let what = format!("mesh {} primitive {}", m.index(), prim.index());
                if let Some(idx) = prim.indices()
                    && !(idx.dimensions() == D::Scalar && matches!(idx.data_type(), T::U8 | T::U16 | T::U32))
                {
                    return Err(self.err(format!(
                        "{what}: indices accessor {} is {:?} {:?}; indices must be unsigned-integer SCALAR",
                        idx.index(),
                        idx.data_type(),
                        idx.dimensions()
                    )));
                }
                for (semantic, acc) in prim.attributes() {
                    let (t, d) = (acc.data_type(), acc.dimensions());
                    let ok = attribute_type_allowed(&semantic, t, acc.normalized(), d, quantization);
                    if !ok {
                        return Err(self.err(format!(
                            "{what}: attribute {} uses accessor {} of type {t:?} {d:?}{}, which glTF does not allow for it{}",
                            semantic.to_string(),
                            acc.index(),
                            if acc.normalized() { " normalized" } else { "" },
                            if quantization == Quantization::Core && t != gltf::accessor::DataType::F32 {
                                " (integer vertex attributes need KHR_mesh_quantization in extensionsUsed)"
                            } else {
                                ""
                            }
                        )));
                    }
                }
            }
        }
        for image in doc.images() {
            let json = image.index();
            let raw = &doc.as_json().images[json];
            match (&raw.buffer_view, &raw.uri, &raw.mime_type) {
                (Some(_), _, None) => {
                    return Err(self.err(format!("image {json}: a bufferView image needs a mimeType")));
                }
                (None, None, _) => return Err(self.err(format!("image {json}: has neither a uri nor a bufferView"))),
                _ => {}
            }
        }
        Ok(())
    }

    /// Bounds checks the crate leaves to us: views inside buffers, accessors inside views.
    pub(super) fn check_views_and_accessors(&self, doc: &gltf::Document, buffers: &[Vec<u8>]) -> Result<()> {
        for v in doc.views() {
            let end = v.offset().checked_add(v.length());
            let buf_len = v.buffer().length();
            if end.is_none_or(|e| e > buf_len) {
                return Err(self.err(format!(
                    "bufferView {} (offset {} + length {}) lies outside buffer {} ({} bytes)",
                    v.index(),
                    v.offset(),
                    v.length(),
                    v.buffer().index(),
                    buf_len
                )));
            }
            debug_assert!(buffers[v.buffer().index()].len() >= buf_len);
        }
        for a in doc.accessors() {
            let elem = a.size();
            if let Some(v) = a.view() {
                let stride = v.stride().unwrap_or(elem);
                if stride < elem {
                    return Err(self.err(format!(
                        "accessor {}: byteStride {} is smaller than its element size {}",
                        a.index(),
                        stride,
                        elem
                    )));
                }
                let need = if a.count() == 0 {
                    Some(0)
                } else {
                    stride
                        .checked_mul(a.count() - 1)
                        .and_then(|x| x.checked_add(elem))
                        .and_then(|x| x.checked_add(a.offset()))
                };
                if need.is_none_or(|n| n > v.length()) {
                    return Err(self.err(format!(
                        "accessor {} ({} elements of {} bytes at offset {}) runs past the end of bufferView {} ({} bytes)",
                        a.index(),
                        a.count(),
                        elem,
                        a.offset(),
                        v.index(),
                        v.length()
                    )));
                }
            }
            if let Some(sparse) = a.sparse() {
                let idx_view = sparse.indices().view();
                let val_view = sparse.values().view();
                let idx_need = sparse.indices().offset() + sparse.count() * sparse.indices().index_type().size();
                let val_need = sparse.values().offset() + sparse.count() * elem;
                if idx_need > idx_view.length() || val_need > val_view.length() {
                    return Err(self.err(format!("accessor {}: sparse data runs past its bufferView", a.index())));
                }
            }
        }
        Ok(())
    }
}

/// Checks that every index in the document points into its array, with a message naming
/// the JSON path of the first one that does not.
pub(super) fn check_references(v: &serde_json::Value) -> std::result::Result<(), String> {
    use serde_json::Value;
    let len = |key: &str| v.get(key).and_then(Value::as_array).map_or(0, Vec::len);
    let check = |value: Option<&Value>, target: &str, path: &str| -> std::result::Result<(), String> {
        let Some(value) = value else { return Ok(()) };
        let n = len(target);
        match value.as_u64() {
            Some(i) if (i as usize) < n => Ok(()),
            _ => Err(format!("{path} = {value} is not a valid index into {target} (the file has {n})")),
        }
    };
    let items = |key: &str| v.get(key).and_then(Value::as_array).cloned().unwrap_or_default();
    check(v.get("scene"), "scenes", "scene")?;
    for (i, sc) in items("scenes").iter().enumerate() {
        for (j, n) in sc.get("nodes").and_then(Value::as_array).into_iter().flatten().enumerate() {
            check(Some(n), "nodes", &format!("scenes[{i}].nodes[{j}]"))?;
        }
    }
    let light_count = v.pointer("/extensions/KHR_lights_punctual/lights").and_then(Value::as_array).map_or(0, Vec::len);
    for (i, node) in items("nodes").iter().enumerate() {
        for (j, c) in node.get("children").and_then(Value::as_array).into_iter().flatten().enumerate() {
            check(Some(c), "nodes", &format!("nodes[{i}].children[{j}]"))?;
        }
        check(node.get("mesh"), "meshes", &format!("nodes[{i}].mesh"))?;
        check(node.get("camera"), "cameras", &format!("nodes[{i}].camera"))?;
        check(node.get("skin"), "skins", &format!("nodes[{i}].skin"))?;
        if let Some(l) = node.pointer("/extensions/KHR_lights_punctual/light")
            && l.as_u64().is_none_or(|l| l as usize >= light_count)
        {
            return Err(format!("nodes[{i}] refers to light {l}, but the file has {light_count} lights"));
        }
    }
    for (i, mesh) in items("meshes").iter().enumerate() {
        for (j, prim) in mesh.get("primitives").and_then(Value::as_array).into_iter().flatten().enumerate() {
            let path = format!("meshes[{i}].primitives[{j}]");
            for (name, a) in prim.get("attributes").and_then(Value::as_object).into_iter().flatten() {
                check(Some(a), "accessors", &format!("{path}.attributes.{name}"))?;
            }
            check(prim.get("indices"), "accessors", &format!("{path}.indices"))?;
            check(prim.get("material"), "materials", &format!("{path}.material"))?;
            for (k, t) in prim.get("targets").and_then(Value::as_array).into_iter().flatten().enumerate() {
                for (name, a) in t.as_object().into_iter().flatten() {
                    check(Some(a), "accessors", &format!("{path}.targets[{k}].{name}"))?;
                }
            }
        }
    }
    for (i, a) in items("accessors").iter().enumerate() {
        check(a.get("bufferView"), "bufferViews", &format!("accessors[{i}].bufferView"))?;
        check(a.pointer("/sparse/indices/bufferView"), "bufferViews", &format!("accessors[{i}].sparse.indices"))?;
        check(a.pointer("/sparse/values/bufferView"), "bufferViews", &format!("accessors[{i}].sparse.values"))?;
    }
    for (i, bv) in items("bufferViews").iter().enumerate() {
        check(bv.get("buffer").or(Some(&Value::Null)), "buffers", &format!("bufferViews[{i}].buffer"))?;
    }
    for (i, t) in items("textures").iter().enumerate() {
        check(t.get("source"), "images", &format!("textures[{i}].source"))?;
        check(t.get("sampler"), "samplers", &format!("textures[{i}].sampler"))?;
    }
    for (i, im) in items("images").iter().enumerate() {
        check(im.get("bufferView"), "bufferViews", &format!("images[{i}].bufferView"))?;
    }
    // Texture references anywhere in a material (core slots and extensions): "index" keys.
    fn texture_indices(v: &Value, path: String, out: &mut Vec<(String, Value)>) {
        match v {
            Value::Object(m) => {
                for (k, x) in m {
                    if k == "index" {
                        out.push((format!("{path}.index"), x.clone()));
                    } else {
                        texture_indices(x, format!("{path}.{k}"), out);
                    }
                }
            }
            Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    texture_indices(x, format!("{path}[{i}]"), out);
                }
            }
            _ => {}
        }
    }
    for (i, m) in items("materials").iter().enumerate() {
        let mut refs = Vec::new();
        texture_indices(m, format!("materials[{i}]"), &mut refs);
        for (path, r) in refs {
            check(Some(&r), "textures", &path)?;
        }
    }
    for (i, skin) in items("skins").iter().enumerate() {
        check(skin.get("inverseBindMatrices"), "accessors", &format!("skins[{i}].inverseBindMatrices"))?;
        check(skin.get("skeleton"), "nodes", &format!("skins[{i}].skeleton"))?;
        for (j, n) in skin.get("joints").and_then(Value::as_array).into_iter().flatten().enumerate() {
            check(Some(n), "nodes", &format!("skins[{i}].joints[{j}]"))?;
        }
    }
    for (i, anim) in items("animations").iter().enumerate() {
        let samplers = anim.get("samplers").and_then(Value::as_array).cloned().unwrap_or_default();
        for (j, s) in samplers.iter().enumerate() {
            check(s.get("input"), "accessors", &format!("animations[{i}].samplers[{j}].input"))?;
            check(s.get("output"), "accessors", &format!("animations[{i}].samplers[{j}].output"))?;
        }
        for (j, c) in anim.get("channels").and_then(Value::as_array).into_iter().flatten().enumerate() {
            check(c.pointer("/target/node"), "nodes", &format!("animations[{i}].channels[{j}].target.node"))?;
            match c.get("sampler").and_then(Value::as_u64) {
                Some(s) if (s as usize) < samplers.len() => {}
                other => {
                    return Err(format!(
                        "animations[{i}].channels[{j}].sampler = {other:?} is not a valid sampler index"
                    ));
                }
            }
        }
    }
    Ok(())
}
