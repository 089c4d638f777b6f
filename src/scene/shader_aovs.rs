//! Shader AOVs (Blender's View Layer → Shader AOV, written by AOV Output nodes): the view
//! layer's list of AOVs in the scene's render settings, each a colour (Blender's channels
//! R, G, B, A) or a value (X), and, per material, which of its AOV Output nodes write which
//! AOV's channels.
//!
//! Cycles writes an AOV at every camera-ray hit up to the first surface that is not
//! transparent (`svm_node_aov_*`, `film_write_aov_pass_*`): the value without any path
//! weight, a colour with alpha 1; the film divides the sums by the samples, so a colour
//! AOV's A channel is the fraction of samples that wrote it (`integrator::shader_aovs`
//! walks the camera ray). A node naming an AOV the view layer does not have writes nothing,
//! as in Cycles (the loader warns, naming the material and node).
//!
//! The world's AOV Output nodes write where the camera ray leaves the scene (Cycles shades
//! the background with the camera ray's path flags, `integrator_eval_background_shader`, and
//! an AOV node keeps the world from its constant-colour shortcut): not when the world is
//! hidden from camera rays, nor with Film → Transparent unless the Environment pass is on
//! (Cycles then skips the background shader, `integrate_background`; `caustic render` warns).

use crate::scene::material::Material;
use serde::{Deserialize, Serialize};

/// Most channels the shader AOVs of a render can take (a colour four, a value one): each is
/// one f32 per camera sample and one fixed-point sum per pixel.
pub const MAX_CHANNELS: usize = 64;

/// An AOV's kind, as Blender's `ViewLayer.aovs[i].type`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum AovKind {
    /// RGBA: the node's Color input, alpha 1 where written.
    #[serde(rename = "COLOR")]
    Color,
    /// X: the node's Value input.
    #[serde(rename = "VALUE")]
    Value,
}

impl AovKind {
    /// Blender's channel names of the pass.
    pub fn channels(self) -> &'static [&'static str] {
        match self {
            AovKind::Color => &["R", "G", "B", "A"],
            AovKind::Value => &["X"],
        }
    }
}

/// One AOV of the view layer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AovSpec {
    /// The pass name (the AOV's name).
    pub name: String,
    /// Colour or value.
    #[serde(rename = "type")]
    pub kind: AovKind,
}

/// `shader_aovs` in the scene's render settings (docs/contract.md).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShaderAovSpec {
    /// The view layer's AOVs in its order (the passes' order).
    pub aovs: Vec<AovSpec>,
    /// Blender's View Layer → Passes → Alpha Threshold: a surface at least this opaque is the
    /// last the camera ray writes AOVs at (Cycles' `pass_alpha_threshold`, default 0.5).
    #[serde(default = "default_threshold")]
    pub alpha_threshold: f32,
}

fn default_threshold() -> f32 {
    0.5
}

/// Where one AOV Output node of a material writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AovTarget {
    /// The node's index in the material program's `aovs`.
    pub output: u16,
    /// First channel of the AOV among the render's shader AOV channels.
    pub offset: u8,
    /// Colour (the Color input and alpha 1) or value (the Value input).
    pub kind: AovKind,
}

/// The shader AOVs of a loaded scene; empty when the view layer has none.
#[derive(Clone, Debug)]
pub struct ShaderAovs {
    /// The AOVs, in pass order.
    pub specs: Vec<AovSpec>,
    /// Channels of all AOVs together.
    pub channels: usize,
    /// See [`ShaderAovSpec::alpha_threshold`].
    pub alpha_threshold: f32,
    /// Per material (indexed as `Scene::materials`), its nodes' targets.
    pub by_material: Vec<Vec<AovTarget>>,
    /// The world graph's nodes' targets (empty: the world writes none).
    pub world: Vec<AovTarget>,
    /// The world graph whose nodes `world` names.
    pub world_graph: Option<crate::light::world_graph::WorldGraph>,
}

impl ShaderAovSpec {
    /// Checks the list: distinct non-empty names, at most [`MAX_CHANNELS`] channels, a
    /// threshold in [0, 1]; the message says what is wrong.
    pub fn check(&self) -> Result<(), String> {
        for (i, a) in self.aovs.iter().enumerate() {
            if a.name.is_empty() {
                return Err(format!("AOV {i} has an empty name"));
            }
            if self.aovs[..i].iter().any(|b| b.name == a.name) {
                return Err(format!("the AOV '{}' is listed twice", a.name));
            }
        }
        let channels: usize = self.aovs.iter().map(|a| a.kind.channels().len()).sum();
        if channels > MAX_CHANNELS {
            return Err(format!(
                "the AOVs take {channels} channels (a colour 4, a value 1); Caustic renders at most {MAX_CHANNELS}"
            ));
        }
        if !(0.0..=1.0).contains(&self.alpha_threshold) {
            return Err(format!("alpha_threshold {} is not in [0, 1]", self.alpha_threshold));
        }
        Ok(())
    }
}

/// One camera sample's shader AOV values ([`MAX_CHANNELS`]; only the render's first
/// `channels` are used).
#[derive(Clone, Copy, Debug)]
pub struct AovSums(pub [f32; MAX_CHANNELS]);

impl Default for AovSums {
    fn default() -> Self {
        AovSums([0.0; MAX_CHANNELS])
    }
}

impl ShaderAovs {
    /// Resolves `spec` (checked) against the materials' AOV Output nodes and those of the
    /// world graph `world` (None: a world without AOV nodes, or hidden from the camera);
    /// `warn` receives a message for each node naming an AOV the view layer does not have.
    /// Without a list (the viewport, a file without AOVs) no AOV is rendered and nothing is
    /// said: asking for the AOVs of such a scene is warned by the render command.
    pub fn resolve(
        spec: Option<&ShaderAovSpec>,
        materials: &[Material],
        world: Option<&crate::light::world_graph::WorldGraph>,
        mut warn: impl FnMut(String),
    ) -> Result<ShaderAovs, String> {
        let Some(spec) = spec.filter(|s| !s.aovs.is_empty()) else {
            return Ok(ShaderAovs::default());
        };
        spec.check()?;
        let mut offsets = Vec::with_capacity(spec.aovs.len());
        let mut channels = 0;
        for a in &spec.aovs {
            offsets.push(channels);
            channels += a.kind.channels().len();
        }
        // The AOV Output nodes of a program that name one of the list's AOVs; `warn` names the others.
        let mut targets_of = |prog: &crate::shader::instructions::Program, owner: &str| {
            let mut targets = Vec::new();
            for (k, out) in prog.aovs.iter().enumerate() {
                match spec.aovs.iter().position(|a| a.name == out.name) {
                    Some(i) => {
                        targets.push(AovTarget { output: k as u16, offset: offsets[i] as u8, kind: spec.aovs[i].kind })
                    }
                    None => warn(unlisted(owner, &out.node, &out.name)),
                }
            }
            targets
        };
        let by_material = materials
            .iter()
            .map(|m| m.nodes.as_ref().map_or_else(Vec::new, |prog| targets_of(prog, &format!("material '{}'", m.name))))
            .collect();
        let world_targets = world.map_or_else(Vec::new, |g| targets_of(g.program(), "the world"));
        Ok(ShaderAovs {
            specs: spec.aovs.clone(),
            channels,
            alpha_threshold: spec.alpha_threshold,
            by_material,
            world_graph: world.filter(|_| !world_targets.is_empty()).cloned(),
            world: world_targets,
        })
    }

    /// The targets of material `m`.
    #[inline]
    pub fn of_material(&self, m: u32) -> &[AovTarget] {
        self.by_material.get(m as usize).map_or(&[], Vec::as_slice)
    }
}

impl Default for ShaderAovs {
    /// No AOVs, and Blender's default Alpha Threshold, which the data passes read too.
    fn default() -> Self {
        ShaderAovs {
            specs: Vec::new(),
            channels: 0,
            alpha_threshold: default_threshold(),
            by_material: Vec::new(),
            world: Vec::new(),
            world_graph: None,
        }
    }
}

fn unlisted(owner: &str, node: &str, aov: &str) -> String {
    format!(
        "{owner}: the AOV Output node '{node}' writes the AOV '{aov}', which the view layer does not list: \
         it writes nothing (as in Cycles)"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(names: &[(&str, AovKind)]) -> ShaderAovSpec {
        ShaderAovSpec {
            aovs: names.iter().map(|(n, k)| AovSpec { name: n.to_string(), kind: *k }).collect(),
            alpha_threshold: 0.5,
        }
    }

    #[test]
    fn specs_are_checked() {
        spec(&[("a", AovKind::Color), ("b", AovKind::Value)]).check().unwrap();
        assert!(spec(&[("a", AovKind::Color), ("a", AovKind::Value)]).check().unwrap_err().contains("twice"));
        assert!(spec(&[("", AovKind::Value)]).check().unwrap_err().contains("empty"));
        let many: Vec<(String, AovKind)> = (0..17).map(|i| (format!("c{i}"), AovKind::Color)).collect();
        let many: Vec<(&str, AovKind)> = many.iter().map(|(n, k)| (n.as_str(), *k)).collect();
        assert!(spec(&many).check().unwrap_err().contains("68 channels"));
        let parsed: ShaderAovSpec =
            serde_json::from_str(r#"{"aovs": [{"name": "m", "type": "VALUE"}, {"name": "c", "type": "COLOR"}]}"#)
                .unwrap();
        assert_eq!(parsed, spec(&[("m", AovKind::Value), ("c", AovKind::Color)]));
    }
}
