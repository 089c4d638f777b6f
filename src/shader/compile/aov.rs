//! The AOV Output node (`ShaderNodeOutputAOV`): its Color and Value inputs compiled into
//! registers that `shader::aov::write` reads after the program ran. Which one is written
//! depends on the view layer's AOV of that name (colour or value), resolved at load.

use super::Compiler;
use crate::shader::instructions::AovOutput;
use glam::Vec3;
use serde_json::Value;

/// Blender's type name of the node.
pub(super) const AOV_OUTPUT: &str = "ShaderNodeOutputAOV";

impl Compiler<'_> {
    /// Compiles AOV Output node `i` (Blender's defaults: Color black, Value 0).
    pub(super) fn aov_output(&mut self, i: usize) -> Result<(), String> {
        let name = match self.desc(i).props.get("aov_name") {
            Some(Value::String(s)) if !s.is_empty() => s.clone(),
            _ => return Err(self.err(i, "the AOV Output node needs its 'aov_name' (a non-empty string)")),
        };
        let color = self.vec(i, "Color", Vec3::ZERO)?;
        let value = self.float(i, "Value", 0.0)?;
        let node = self.desc(i).name.clone();
        self.prog.aovs.push(AovOutput { name, node, color, value });
        Ok(())
    }
}
