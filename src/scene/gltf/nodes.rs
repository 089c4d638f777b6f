//! The node graph: cycles and shared subtrees refused, every node reached from the
//! scene's roots with its world matrix.

use super::{Loader, MAX_INSTANCES};
use crate::error::Result;
use glam::Mat4;

impl Loader<'_> {
    /// Walks the scene's node trees; returns (node, world matrix, visible) for every node
    /// reached, refusing cycles. `KHR_node_visibility`: a node is visible when its own
    /// `visible` (default true) and every ancestor's are; a hidden node's meshes and lights
    /// are not rendered, its camera stays usable (the extension's rule).
    pub(super) fn instances(
        &mut self,
        doc: &gltf::Document,
        value: &serde_json::Value,
    ) -> Result<Vec<(usize, Mat4, bool)>> {
        let n = doc.nodes().count();
        // Cycle check over the children graph (iterative three-colour DFS).
        let children: Vec<Vec<usize>> = doc.nodes().map(|nd| nd.children().map(|c| c.index()).collect()).collect();
        let mut colour = vec![0u8; n];
        for start in 0..n {
            if colour[start] != 0 {
                continue;
            }
            let mut stack = vec![(start, 0usize)];
            colour[start] = 1;
            while let Some(&mut (node, ref mut next)) = stack.last_mut() {
                if *next < children[node].len() {
                    let c = children[node][*next];
                    *next += 1;
                    match colour[c] {
                        0 => {
                            colour[c] = 1;
                            stack.push((c, 0));
                        }
                        1 => {
                            return Err(self.err(format!("the node hierarchy has a cycle through node {c}")));
                        }
                        _ => {}
                    }
                } else {
                    colour[node] = 2;
                    stack.pop();
                }
            }
        }
        // glTF's nodes form strict trees: one parent at most, and a root is no one's
        // child and listed once. Shared subtrees could multiply instances exponentially.
        let mut parent = vec![None; n];
        for (p, cs) in children.iter().enumerate() {
            for &c in cs {
                if let Some(q) = parent[c] {
                    return Err(
                        self.err(format!("node {c} has two parents (nodes {q} and {p}); glTF nodes form trees"))
                    );
                }
                parent[c] = Some(p);
            }
        }
        let roots: Vec<usize> = if let Some(scene) = doc.default_scene().or_else(|| doc.scenes().next()) {
            if value.get("scene").is_none() && doc.scenes().count() > 1 {
                self.warn("the file has several scenes and no default: rendering scene 0");
            }
            scene.nodes().map(|n| n.index()).collect()
        } else {
            let mut is_child = vec![false; n];
            for c in children.iter().flatten() {
                is_child[*c] = true;
            }
            if n > 0 {
                self.warn("the file has no scene: rendering every root node");
            }
            (0..n).filter(|&i| !is_child[i]).collect()
        };
        let mut seen_root = vec![false; n];
        for &r in &roots {
            if seen_root[r] {
                return Err(self.err(format!("node {r} is listed twice as a root of the scene")));
            }
            seen_root[r] = true;
        }
        // glTF asks a scene's nodes to be root nodes, but some exporters list a child (UniGLTF
        // writes a "tmpParent" above the scene's one node, left out of the scene: Kenney's
        // assets, Bevy's examples). Blender's importer renders such a node; so does Caustic:
        // under its parents' transforms, or not again where an ancestor is in the scene too.
        let local =
            |i: usize| Mat4::from_cols_array_2d(&doc.nodes().nth(i).expect("validated index").transform().matrix());
        let mut starts = Vec::with_capacity(roots.len());
        for &r in &roots {
            let Some(p) = parent[r] else {
                starts.push((r, Mat4::IDENTITY));
                continue;
            };
            let mut above = Mat4::IDENTITY;
            let mut ancestor = Some(p);
            let mut listed = None;
            while let Some(a) = ancestor {
                if seen_root[a] {
                    listed = Some(a);
                    break;
                }
                above = local(a) * above;
                ancestor = parent[a];
            }
            match listed {
                Some(a) => self.warn(format!(
                    "node {r} is listed as a root of the scene but is a descendant of node {a}, also listed: \
                     rendered once, under node {a}"
                )),
                None => {
                    self.warn(format!(
                        "node {r} is listed as a root of the scene but is a child of node {p}: rendered under its \
                         parents' transforms (glTF asks a scene's nodes to be root nodes)"
                    ));
                    starts.push((r, above));
                }
            }
        }
        let mut out = Vec::new();
        let mut stack: Vec<(usize, Mat4, bool)> = starts.into_iter().rev().map(|(r, m)| (r, m, true)).collect();
        while let Some((node, parent, parent_visible)) = stack.pop() {
            let nd = doc.nodes().nth(node).expect("validated index");
            let local = Mat4::from_cols_array_2d(&nd.transform().matrix());
            let world = parent * local;
            let own = match nd.extension_value("KHR_node_visibility").and_then(|v| v.get("visible")) {
                None => true,
                Some(v) => v.as_bool().ok_or_else(|| {
                    self.err(format!("node {node}: KHR_node_visibility's visible is not a boolean ({v})"))
                })?,
            };
            let visible = parent_visible && own;
            out.push((node, world, visible));
            if out.len() > MAX_INSTANCES {
                return Err(self.err(format!("more than {MAX_INSTANCES} node instances: shared subtrees explode")));
            }
            for c in children[node].iter().rev() {
                stack.push((*c, world, visible));
            }
        }
        Ok(out)
    }
}
