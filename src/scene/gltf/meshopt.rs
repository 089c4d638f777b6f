//! `EXT_meshopt_compression` is not decoded. A file that requires it is refused by name
//! (`SUPPORTED_REQUIRED`); a file that only uses it carries an uncompressed fallback,
//! which the loader reads, unless the fallback buffer holds no data (`fallback: true`
//! without a uri), whose views would read as garbage: that is refused here, naming the
//! extension and the meshes that read it.

use super::Loader;
use crate::error::Result;
use serde_json::Value;

pub(super) const EXTENSION: &str = "EXT_meshopt_compression";

impl Loader<'_> {
    /// Refuses a file whose meshes read a data-less `EXT_meshopt_compression` fallback buffer.
    pub(super) fn check_meshopt_fallback(&self, value: &Value) -> Result<()> {
        let items = |key: &str| value.get(key).and_then(Value::as_array).cloned().unwrap_or_default();
        let buffers = items("buffers");
        let empty = |b: usize| {
            buffers.get(b).is_some_and(|b| {
                b.get("uri").is_none()
                    && b.pointer(&format!("/extensions/{EXTENSION}/fallback")).and_then(Value::as_bool) == Some(true)
            })
        };
        if !(0..buffers.len()).any(empty) {
            return Ok(());
        }
        let views = items("bufferViews");
        let accessors = items("accessors");
        let reads_empty = |accessor: &Value| {
            let view = accessor.as_u64().and_then(|a| accessors.get(a as usize)).and_then(|a| a.get("bufferView"));
            let buffer = view.and_then(Value::as_u64).and_then(|v| views.get(v as usize)).and_then(|v| v.get("buffer"));
            buffer.and_then(Value::as_u64).is_some_and(|b| empty(b as usize))
        };
        for (mi, mesh) in items("meshes").iter().enumerate() {
            for prim in mesh.get("primitives").and_then(Value::as_array).into_iter().flatten() {
                let attributes =
                    prim.get("attributes").and_then(Value::as_object).into_iter().flatten().map(|(_, a)| a);
                if attributes.chain(prim.get("indices")).any(reads_empty) {
                    let name =
                        mesh.get("name").and_then(Value::as_str).map(|n| format!(" ('{n}')")).unwrap_or_default();
                    return Err(self.err(format!(
                        "mesh {mi}{name}: its geometry is compressed with {EXTENSION}, which Caustic does not decode, \
                         and the file's fallback buffer holds no data"
                    )));
                }
            }
        }
        Ok(())
    }
}
