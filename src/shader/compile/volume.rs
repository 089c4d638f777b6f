//! A material's Volume output compiled into a [`VolumeProgram`]: the data nodes feeding the
//! volume shader node (Principled Volume, Volume Scatter, Volume Absorption, or Emission)
//! become a program, and the shader's inputs become registers that
//! `medium::procedural` reads at each point of the medium (Cycles evaluates a volume
//! shader per point in the same way, `svm_node_principled_volume`).
//!
//! The graph is `CAUSTIC_materials_medium.graph` (docs/contract.md): the shader node and what
//! feeds it, in the node-graph format, with `shader` naming the shader node's index.

use super::{Compiler, Sock, Ty, check_and_sort};
use crate::medium::Phase;
use crate::scene::mesh::AttributeKey;
use crate::shader::geom::Reg;
use crate::shader::graph::NodesExt;
use crate::shader::instructions::Program;
use glam::Vec3;
use std::collections::HashSet;

/// Which volume shader the program feeds (each maps its inputs to the Principled Volume's
/// coefficients differently, `VolumeProgram::regs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VolumeKind {
    /// Principled Volume.
    Principled,
    /// Volume Scatter: σs = Color × Density, no absorption.
    Scatter,
    /// Volume Absorption: σa = (1 − Color) × Density, no scattering.
    Absorption,
    /// Emission on the Volume output: emission only.
    Emission,
}

/// Registers of the volume shader's inputs after the program ran (vectors take three).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VolumeRegs {
    /// Density (float).
    pub density: Reg,
    /// Color (scatter colour; Absorption's and Emission's Color).
    pub color: Reg,
    /// Absorption Color (Principled only; a constant 0 otherwise).
    pub absorption_color: Reg,
    /// Emission Color.
    pub emission_color: Reg,
    /// Emission Strength (Emission's Strength).
    pub emission_strength: Reg,
    /// Blackbody Intensity.
    pub blackbody_intensity: Reg,
    /// Blackbody Tint.
    pub blackbody_tint: Reg,
    /// Temperature (kelvin).
    pub temperature: Reg,
}

/// A compiled volume shader.
#[derive(Clone, Debug)]
pub struct VolumeProgram {
    /// The data nodes (every operation runs per point: `surface_end` covers them all).
    pub program: Program,
    /// The shader node.
    pub kind: VolumeKind,
    /// Its inputs' registers.
    pub regs: VolumeRegs,
    /// Anisotropy: the shader's own value (the medium's phase function where it does not vary).
    pub anisotropy: f32,
    /// The register of a linked Anisotropy that varies over the medium, read at each
    /// scattering point.
    pub anisotropy_reg: Option<Reg>,
    /// The phase function: a Volume Scatter's Phase with its own inputs' values (Anisotropy
    /// applied at each point where it varies), else Henyey-Greenstein of `anisotropy`.
    pub phase: Phase,
    /// Generated coordinates are read (the mesh's texture space is needed).
    pub uses_generated: bool,
    /// Warnings (without the material's name; the loader adds it).
    pub warnings: Vec<String>,
    /// The graph's images, which its Image Texture nodes index (the loader decodes them
    /// into the medium's own list, as the world graph's).
    pub textures: Vec<crate::scene::texture::Texture>,
}

/// Compiles the volume graph `ext` whose shader node is `shader`, for material `name`;
/// `images[k]` is graph image k's index in the list the caller puts in
/// [`VolumeProgram::textures`]. Errors name the node.
pub fn compile_volume(name: &str, ext: &NodesExt, shader: usize, images: &[u32]) -> Result<VolumeProgram, String> {
    let order = check_and_sort(ext)?;
    let Some(node) = ext.nodes.get(shader) else {
        return Err(format!("the volume shader is node {shader} but the graph has {} nodes", ext.nodes.len()));
    };
    let kind = match node.kind.as_str() {
        "ShaderNodeVolumePrincipled" => VolumeKind::Principled,
        "ShaderNodeVolumeScatter" => VolumeKind::Scatter,
        "ShaderNodeVolumeAbsorption" => VolumeKind::Absorption,
        "ShaderNodeEmission" => VolumeKind::Emission,
        other => return Err(format!("node '{}' ({other}) is not a volume shader Caustic renders", node.name)),
    };
    let mut used = HashSet::new();
    for n in &ext.nodes {
        for i in n.inputs.values() {
            if let Some(l) = &i.link {
                used.insert((l.0, l.1.clone()));
            }
        }
    }
    let mut c = Compiler::new(ext, images, name, used);
    for &i in order.iter().filter(|&&i| i != shader) {
        c.node(i)?;
    }
    let zero = c.konst_f(0.0);
    let zero3 = c.konst_v(Vec3::ZERO);
    let one3 = c.konst_v(Vec3::ONE);
    let s = shader;
    let regs = match kind {
        VolumeKind::Principled => VolumeRegs {
            density: c.float(s, "Density", 1.0)?,
            color: c.vec(s, "Color", Vec3::splat(0.5))?,
            absorption_color: c.vec(s, "Absorption Color", Vec3::ZERO)?,
            emission_color: c.vec(s, "Emission Color", Vec3::ONE)?,
            emission_strength: c.float(s, "Emission Strength", 0.0)?,
            blackbody_intensity: c.float(s, "Blackbody Intensity", 0.0)?,
            blackbody_tint: c.vec(s, "Blackbody Tint", Vec3::ONE)?,
            temperature: c.float(s, "Temperature", 1000.0)?,
        },
        VolumeKind::Scatter | VolumeKind::Absorption => VolumeRegs {
            density: c.float(s, "Density", 1.0)?,
            color: c.vec(s, "Color", Vec3::splat(0.8))?,
            absorption_color: zero3,
            emission_color: zero3,
            emission_strength: zero,
            blackbody_intensity: zero,
            blackbody_tint: one3,
            temperature: zero,
        },
        VolumeKind::Emission => VolumeRegs {
            density: zero,
            color: zero3,
            absorption_color: zero3,
            emission_color: c.vec(s, "Color", Vec3::ONE)?,
            emission_strength: c.float(s, "Strength", 1.0)?,
            blackbody_intensity: zero,
            blackbody_tint: one3,
            temperature: zero,
        },
    };
    let (anisotropy, anisotropy_reg) = match kind {
        VolumeKind::Principled | VolumeKind::Scatter => anisotropy(&mut c, s)?,
        _ => (0.0, None),
    };
    let phase = match kind {
        VolumeKind::Scatter => scatter_phase(&mut c, s, anisotropy),
        _ => Phase::hg(anisotropy),
    };
    // Inside a medium there is no triangle: mesh attributes are not found there, as in
    // Cycles; an object's attributes are, which the medium does not carry.
    for (key, node) in &c.prog.attributes {
        if matches!(key, AttributeKey::Object(_) | AttributeKey::Instancer(_)) {
            c.warnings.push(format!(
                "{node}: {} reads 0 in a volume shader (Cycles reads the object's value there)",
                key.describe()
            ));
        }
    }
    let mut prog = c.prog;
    prog.init = c.init;
    prog.ops = c.ops;
    prog.surface_end = prog.ops.len();
    Ok(VolumeProgram {
        program: prog,
        kind,
        regs,
        anisotropy,
        anisotropy_reg,
        phase,
        uses_generated: c.uses_generated,
        warnings: c.warnings,
        textures: Vec::new(),
    })
}

/// A Volume Scatter node's phase function from its `phase` property and its inputs' own
/// values; a linked Alpha, IOR, Backscatter or Diameter is named in a warning (its own value
/// is used), as is an unknown phase (rendered as Henyey-Greenstein).
fn scatter_phase(c: &mut Compiler, i: usize, anisotropy: f32) -> Phase {
    let kind = c.prop_str(i, "phase", "HENYEY_GREENSTEIN").to_string();
    let mut own = |id: &str, default: f32| {
        if c.source(i, id).ok().flatten().is_some() && kind != "HENYEY_GREENSTEIN" {
            c.warn(i, format!("a link into {id} is not read by the phase function: its own value is used"));
        }
        c.value(i, id).and_then(|v| v.as_f64()).map_or(default, |v| v as f32)
    };
    let (alpha, ior, backscatter, diameter) =
        (own("Alpha", 0.5), own("IOR", 1.33), own("Backscatter", 0.1), own("Diameter", 20.0));
    match Phase::from_blender(&kind, anisotropy, alpha, ior, backscatter, diameter) {
        Some(p) => p,
        None => {
            c.warn(i, format!("phase '{kind}' is unknown: rendered as Henyey-Greenstein"));
            Phase::hg(anisotropy)
        }
    }
}

/// The shader's Anisotropy: its own value, and the register of a linked one that varies
/// over the medium (the phase function is then looked up at each scattering point,
/// `GridMedium::phase_at`). A closure linked into it is named in a warning and its own value
/// used.
fn anisotropy(c: &mut Compiler, i: usize) -> Result<(f32, Option<Reg>), String> {
    let own = c.value(i, "Anisotropy").and_then(|v| v.as_f64()).map_or(0.0, |v| v as f32);
    match c.source(i, "Anisotropy")? {
        Some(Sock { ty: Ty::Closure, .. }) => {
            c.warn(i, "a shader linked into Anisotropy is not a value: its own value is used");
            Ok((own, None))
        }
        Some(Sock { reg, .. }) if !c.is_const(reg, 1) => Ok((own, Some(c.float(i, "Anisotropy", 0.0)?))),
        _ => Ok((own, None)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader::instructions::Op;
    use serde_json::json;

    /// A Noise Texture into a Math node into the Principled Volume's Density compiles; the
    /// shader's own Anisotropy is read; an Image Texture compiles to an image lookup of the
    /// image it names, and one naming an image the graph does not list is refused.
    #[test]
    fn principled_volume_with_a_texture() {
        let ext: NodesExt = serde_json::from_value(json!({"version": 1, "nodes": [
            {"name": "Noise", "type": "ShaderNodeTexNoise", "props": {"noise_dimensions": "3D"},
             "inputs": {"Scale": {"value": 5.0}}},
            {"name": "Math", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
             "inputs": {"Value": {"value": 0.5, "link": [0, "Fac"]}, "Value_001": {"value": 4.0}}},
            {"name": "PV", "type": "ShaderNodeVolumePrincipled",
             "inputs": {"Density": {"value": 1.0, "link": [1, "Value"]}, "Anisotropy": {"value": 0.3}}}],
            "output": {}}))
        .unwrap();
        let v = compile_volume("m", &ext, 2, &[]).unwrap();
        assert_eq!(v.kind, VolumeKind::Principled);
        assert!((v.anisotropy - 0.3).abs() < 1e-6);
        assert!(v.uses_generated, "the Noise Texture's unlinked Vector is Generated");
        assert!(!v.program.ops.is_empty());
        let img: NodesExt = serde_json::from_value(json!({"version": 1, "nodes": [
            {"name": "Img", "type": "ShaderNodeTexImage", "props": {"image": 0}, "inputs": {}},
            {"name": "PV", "type": "ShaderNodeVolumeScatter", "inputs": {"Density": {"link": [0, "Alpha"]}}}],
            "output": {}}))
        .unwrap();
        let v = compile_volume("m", &img, 1, &[0]).unwrap();
        assert!(v.program.ops.iter().any(|op| matches!(op, Op::Image(t) if t.texture == Some(0))));
        assert!(compile_volume("m", &img, 1, &[]).unwrap_err().contains("not in the graph's images"));
        assert!(compile_volume("m", &img, 0, &[0]).unwrap_err().contains("not a volume shader"));
    }
}
