//! `CAUSTIC_light_linking` on an emitter's node: its receivers and blockers as object ids
//! (glTF node indices, and strands' and points' objects without a node, `curves::object_ids`,
//! `points::object_ids`).

use super::extensions::LightLinkingExt;
use super::{Links, Loader, curves, points};
use crate::error::Result;
use crate::scene::linking::ReceiverRule;

impl Loader<'_> {
    /// `CAUSTIC_light_linking` on emitter node `node_index`: its receivers and its blockers
    /// by node name (every node of that name: an object's instances share it); names not in
    /// the file (objects not rendered) are left out.
    pub(super) fn receiver_rule(
        &self,
        value: &serde_json::Value,
        doc: &gltf::Document,
        node_index: usize,
        node_name: &str,
        ext: &serde_json::Value,
    ) -> Result<Links> {
        let ext: LightLinkingExt = serde_json::from_value(ext.clone())
            .map_err(|e| self.err(format!("node {node_index} ('{node_name}'): bad CAUSTIC_light_linking: {e}")))?;
        let mut strand_objects = curves::object_ids(value, doc);
        // Points of an object that has no node of its own (a Point Cloud object).
        strand_objects.extend(points::object_ids(value, doc, strand_objects.len()));
        let rule = |names: &Option<Vec<String>>, include: bool| {
            names.as_ref().map(|names| {
                let mut objects: Vec<u32> = doc
                    .nodes()
                    .filter(|n| n.name().is_some_and(|name| names.iter().any(|r| r == name)))
                    .map(|n| n.index() as u32)
                    .collect();
                // Strands of an object that has no node of its own (a Curves object).
                objects.extend(strand_objects.iter().filter(|(n, _)| names.contains(n)).map(|(_, id)| *id));
                objects.sort_unstable();
                objects.dedup();
                ReceiverRule { include, objects }
            })
        };
        Ok((rule(&ext.receivers, ext.include), rule(&ext.blockers, ext.blockers_include)))
    }
}
