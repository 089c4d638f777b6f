//! A light's node tree (`nodes` of `CAUSTIC_lights_area` / `CAUSTIC_lights_punctual`):
//! compiled with its own images, folded into the light when constant, else kept for
//! evaluation per emission (`light::light_graph`).

use super::Loader;
use crate::error::Result;
use crate::light::Light;
use crate::light::light_graph::LightGraph;
use crate::shader::closure::ClosureKind;
use crate::shader::graph::NodesExt;
use crate::shader::instructions::Op;
use glam::Mat4;

impl Loader<'_> {
    /// `nodes` with each IES Texture node's `ies_file` (a path beside the glTF, contract) read
    /// into its `ies_text`, which the compiler parses; a file that cannot be read is an error
    /// naming the light (or material) and node.
    pub(super) fn with_ies_profiles(&mut self, what: &str, nodes: &NodesExt) -> Result<NodesExt> {
        let mut nodes = nodes.clone();
        for node in nodes.nodes.iter_mut().filter(|n| n.kind == "ShaderNodeTexIES") {
            let Some(file) = node.props.get("ies_file") else { continue };
            let Some(file) = file.as_str().map(str::to_string) else {
                return Err(self.err(format!("{what}: node '{}': ies_file is not a string", node.name)));
            };
            let bytes = self.resolve_uri(&file, &format!("{what}: node '{}': IES file", node.name))?;
            let text = String::from_utf8_lossy(&bytes).into_owned();
            node.props.insert("ies_text".into(), serde_json::Value::String(text));
        }
        Ok(nodes)
    }

    /// Light `light` (named `name`, object matrix `world`) with its node tree `nodes`: a
    /// constant graph's emission multiplied into it, or the light and its varying graph.
    pub(super) fn light_with_nodes(
        &mut self,
        light: Light,
        name: &str,
        nodes: &NodesExt,
        world: &Mat4,
    ) -> Result<(Light, Option<LightGraph>)> {
        let what = format!("light '{name}'");
        let nodes = &self.with_ies_profiles(&what, nodes)?;
        let first = self.textures.len();
        let mut images = Vec::with_capacity(nodes.images.len());
        for (k, img) in nodes.images.iter().enumerate() {
            images.push(self.node_image(&what, k, img)? - first as u32);
        }
        // The graph's images belong to the light alone: they leave the scene's list.
        let textures = self.textures.split_off(first);
        let compiled = crate::shader::compile::compile_in(&what, nodes, &images, self.space)
            .map_err(|e| self.err(format!("{what}: its node tree: {e}")))?;
        for w in &compiled.warnings {
            self.warn(format!("{what}: {w}"));
        }
        let prog = compiled.program;
        // Cycles' light emits its shader's emission only: a BSDF or Transparent there adds
        // nothing, as in Cycles, but is likely a mistake worth naming.
        let lobes = prog.ops.iter().any(|op| matches!(op, Op::Closure(c) if !matches!(c.kind, ClosureKind::Emission)));
        if lobes || prog.transparent {
            self.warn(format!("{what}: a BSDF or Transparent shader in its node tree emits nothing (as in Cycles)"));
        }
        // Cycles' lights have parametric coordinates of their own (`map_to_sphere` of the
        // normal, a spot's cone, an area light's corners), which Caustic does not compute.
        let parametric = prog.ops.iter().any(|op| {
            matches!(
                op,
                Op::Input {
                    what: crate::shader::instructions::InputKind::Parametric
                        | crate::shader::instructions::InputKind::Uv(_),
                    ..
                }
            )
        });
        if parametric {
            self.warn(format!(
                "{what}: its node tree reads Parametric or UV coordinates, which are 0 on a light in Caustic \
                 (Cycles maps the light's normal or surface to them)"
            ));
        }
        let graph = LightGraph::new(name, prog, textures, *world);
        Ok(match graph.constant() {
            Some(factor) => (light.scaled(factor), None),
            None => (light, Some(graph)),
        })
    }
}
