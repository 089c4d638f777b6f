//! The file's bytes: buffers from the GLB chunk, relative files or data URIs, and the
//! scene's source hash over every file read (so that chunks of a changed scene are refused).

use super::Loader;
use crate::error::Result;
use base64::Engine;
use std::path::PathBuf;

impl Loader<'_> {
    /// The bytes at `uri` (a data URI or a file relative to the glTF); `what` names it in errors.
    pub(super) fn resolve_uri(&self, uri: &str, what: &str) -> Result<Vec<u8>> {
        if let Some(rest) = uri.strip_prefix("data:") {
            let Some((_, payload)) = rest.split_once(";base64,") else {
                return Err(self.err(format!("{what}: data URI is not base64-encoded")));
            };
            return base64::engine::general_purpose::STANDARD
                .decode(payload.trim())
                .map_err(|e| self.err(format!("{what}: data URI has invalid base64: {e}")));
        }
        if uri.contains("://") {
            return Err(
                self.err(format!("{what}: remote URI '{uri}' is not supported (only relative files and data URIs)"))
            );
        }
        let decoded = percent_encoding::percent_decode_str(uri).decode_utf8_lossy().to_string();
        let path: PathBuf = self.base_dir.join(&decoded);
        let bytes =
            std::fs::read(&path).map_err(|e| self.err(format!("{what}: cannot read '{}': {e}", path.display())))?;
        self.files_read.borrow_mut().push((decoded, crate::math::fnv1a64(&bytes)));
        Ok(bytes)
    }

    /// The scene's source hash: the glTF's bytes, then each external file read (URI and
    /// content hash) in URI order, so the order of reading does not matter.
    pub(super) fn source_hash(&self, gltf: &[u8]) -> u64 {
        let mut files = self.files_read.borrow().clone();
        files.sort();
        files.dedup();
        let mut h = crate::math::fnv1a64(gltf);
        for (uri, file) in &files {
            h = crate::math::fnv1a64_from(h, &[0]);
            h = crate::math::fnv1a64_from(h, uri.as_bytes());
            h = crate::math::fnv1a64_from(h, &file.to_le_bytes());
        }
        h
    }

    /// Every buffer of the document, checked against its byteLength.
    pub(super) fn load_buffers(&self, doc: &gltf::Document, mut bin: Option<Vec<u8>>) -> Result<Vec<Vec<u8>>> {
        let mut out = Vec::new();
        for b in doc.buffers() {
            let what = format!("buffer {}", b.index());
            let data = match b.source() {
                gltf::buffer::Source::Bin => bin
                    .take()
                    .ok_or_else(|| self.err(format!("{what} refers to the GLB binary chunk, which is missing")))?,
                gltf::buffer::Source::Uri(uri) => self.resolve_uri(uri, &what)?,
            };
            if data.len() < b.length() {
                return Err(self.err(format!(
                    "{what} is shorter than its byteLength ({} < {} bytes): truncated file?",
                    data.len(),
                    b.length()
                )));
            }
            out.push(data);
        }
        Ok(out)
    }
}
