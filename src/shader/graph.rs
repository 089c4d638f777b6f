//! `CAUSTIC_materials_nodes` as written by the add-on (docs/contract.md): the serde shapes
//! (unknown keys refused) and the checks every graph passes before it is compiled — links
//! to existing nodes, no cycle — with the topological order the compiler follows.

use serde::Deserialize;
use serde_json::{Map, Value};
use std::collections::BTreeMap;

/// The extension on a material.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodesExt {
    /// Format version (1).
    pub version: u32,
    /// Every node reachable from the outputs (absent when there is none: a Material Output
    /// with nothing linked, whose empty list the glTF exporter drops).
    #[serde(default)]
    pub nodes: Vec<NodeDesc>,
    /// The Material Output's sockets (absent in a volume's graph, whose output is its shader
    /// node: the glTF exporter drops an empty object).
    #[serde(default)]
    pub output: OutputDesc,
    /// Images the add-on wrote beside the glTF.
    #[serde(default)]
    pub images: Vec<ImageDesc>,
    /// The material's Settings > Displacement method: "BUMP" (the default), "DISPLACEMENT"
    /// (the mesh is moved, no bump) or "BOTH" (moved, and bumped in shading).
    #[serde(default)]
    pub displacement_method: Option<String>,
}

/// One node.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeDesc {
    /// Blender's node name (group nodes inlined as `Group/Inner`).
    pub name: String,
    /// `bl_idname`.
    #[serde(rename = "type")]
    pub kind: String,
    /// The node's own settings.
    #[serde(default)]
    pub props: Map<String, Value>,
    /// Enabled input sockets by identifier.
    #[serde(default)]
    pub inputs: BTreeMap<String, InputDesc>,
}

/// An input socket: its value (when it has one) and its link.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputDesc {
    /// Number, or 3/4 numbers (also given when linked, as the default).
    #[serde(default)]
    pub value: Option<Value>,
    /// `[node index, output identifier]`.
    #[serde(default)]
    pub link: Option<(usize, String)>,
}

/// The Material Output's linked sockets.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputDesc {
    /// Surface: `[node, output]`.
    #[serde(default)]
    pub surface: Option<(usize, String)>,
    /// Displacement (bump, true displacement or both: `NodesExt::displacement_method`).
    #[serde(default)]
    pub displacement: Option<(usize, String)>,
}

/// An image file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImageDesc {
    /// Path relative to the glTF.
    pub uri: String,
    /// "sRGB", "Non-Color", "Linear Rec.709".
    #[serde(default = "srgb")]
    pub colorspace: String,
    /// Blender's alpha mode.
    #[serde(default)]
    pub alpha: Option<String>,
}

fn srgb() -> String {
    "sRGB".into()
}

/// Checks links and returns the nodes in an order where every node comes after the
/// nodes it reads. Errors name the node (the caller adds the material).
pub fn check_and_sort(ext: &NodesExt) -> Result<Vec<usize>, String> {
    let n = ext.nodes.len();
    if ext.version != 1 {
        return Err(format!("version {} is not supported (1)", ext.version));
    }
    let check_link = |from: &str, l: &(usize, String)| -> Result<(), String> {
        if l.0 >= n { Err(format!("{from} links to node {} but the graph has {n} nodes", l.0)) } else { Ok(()) }
    };
    for node in &ext.nodes {
        for (id, input) in &node.inputs {
            if let Some(l) = &input.link {
                check_link(&format!("node '{}' input '{id}'", node.name), l)?;
            }
        }
    }
    for l in ext.output.surface.iter().chain(&ext.output.displacement) {
        check_link("the material output", l)?;
    }
    // Depth-first post-order with three colours; a grey node met again closes a cycle.
    let mut colour = vec![0u8; n];
    let mut order = Vec::with_capacity(n);
    for start in 0..n {
        if colour[start] != 0 {
            continue;
        }
        let mut stack: Vec<(usize, Vec<usize>)> = vec![(start, deps(&ext.nodes[start]))];
        colour[start] = 1;
        while let Some((node, pending)) = stack.last_mut() {
            let node = *node;
            match pending.pop() {
                Some(d) => match colour[d] {
                    0 => {
                        colour[d] = 1;
                        let next = deps(&ext.nodes[d]);
                        stack.push((d, next));
                    }
                    1 => {
                        return Err(format!(
                            "node '{}' is part of a cycle (through '{}')",
                            ext.nodes[d].name, ext.nodes[node].name
                        ));
                    }
                    _ => {}
                },
                None => {
                    colour[node] = 2;
                    order.push(node);
                    stack.pop();
                }
            }
        }
    }
    Ok(order)
}

fn deps(node: &NodeDesc) -> Vec<usize> {
    node.inputs.values().filter_map(|i| i.link.as_ref().map(|l| l.0)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn ext(v: Value) -> NodesExt {
        serde_json::from_value(v).unwrap()
    }

    #[test]
    fn order_puts_sources_first_and_cycles_are_named() {
        let e = ext(json!({"version": 1, "nodes": [
            {"name": "a", "type": "ShaderNodeMath", "inputs": {"Value": {"link": [1, "Value"]}}},
            {"name": "b", "type": "ShaderNodeMath", "inputs": {"Value": {"value": 1.0}}}],
            "output": {"surface": null}}));
        assert_eq!(check_and_sort(&e).unwrap(), vec![1, 0]);
        let c = ext(json!({"version": 1, "nodes": [
            {"name": "a", "type": "ShaderNodeMath", "inputs": {"Value": {"link": [1, "Value"]}}},
            {"name": "b", "type": "ShaderNodeMath", "inputs": {"Value": {"link": [0, "Value"]}}}],
            "output": {}}));
        let e = check_and_sort(&c).unwrap_err();
        assert!(e.contains("cycle") && (e.contains("'a'") || e.contains("'b'")), "{e}");
        let m = ext(json!({"version": 1, "nodes": [
            {"name": "a", "type": "ShaderNodeMath", "inputs": {"Value": {"link": [5, "Value"]}}}], "output": {}}));
        assert!(check_and_sort(&m).unwrap_err().contains("node 'a' input 'Value' links to node 5"));
    }

    #[test]
    fn a_graph_without_nodes_is_one_with_nothing_on_its_outputs() {
        // What the add-on's graph of a Material Output with an unlinked Surface becomes after
        // the glTF exporter dropped its empty `nodes` and `output`.
        let e = ext(json!({"version": 1}));
        assert!(e.nodes.is_empty() && e.output.surface.is_none() && e.output.displacement.is_none());
    }

    #[test]
    fn unknown_keys_are_refused() {
        let r: Result<NodesExt, _> =
            serde_json::from_value(json!({"version": 1, "nodes": [], "output": {}, "extra": 1}));
        assert!(r.is_err());
        let r: Result<NodesExt, _> = serde_json::from_value(
            json!({"version": 1, "nodes": [{"name": "a", "type": "X", "input": {}}], "output": {}}),
        );
        assert!(r.is_err());
    }
}
