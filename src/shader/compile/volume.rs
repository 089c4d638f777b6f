//! A material's Volume output compiled into a [`VolumeProgram`]: the data nodes feeding the
//! volume shaders (Principled Volume, Volume Scatter, Volume Absorption, Volume Coefficients,
//! Emission, mixed and added by Mix and Add Shader nodes) become a program, and each volume
//! shader's inputs become registers that `medium::procedural_source` reads at each point of
//! the medium, summing the shaders' coefficients by their weights (Cycles evaluates a volume
//! shader per point in the same way, `svm_node_principled_volume`, and sums the closures'
//! extinction, scattering and emission).
//!
//! The graph is `CAUSTIC_materials_medium.graph` (docs/contract.md): the shader tree and what
//! feeds it, in the node-graph format, with `shader` naming the tree's root node.

use super::{Compiler, Sock, Ty, check_and_sort};
use crate::medium::Phase;
use crate::scene::mesh::AttributeKey;
use crate::shader::geom::Reg;
use crate::shader::graph::NodesExt;
use crate::shader::instructions::{Op, Program};
use glam::Vec3;
use std::collections::HashSet;

/// Which volume shader a closure is (each maps its inputs to coefficients differently,
/// `ProceduralSource::coefficients`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VolumeKind {
    /// Principled Volume.
    Principled,
    /// Volume Scatter: σs = Color × Density, no absorption.
    Scatter,
    /// Volume Absorption: σa = (1 − Color) × Density, no scattering.
    Absorption,
    /// Volume Coefficients (Blender 5.0): σa, σs and emission given directly.
    Coefficients,
    /// Emission on the Volume output: emission only.
    Emission,
}

/// Registers of the volume shader's inputs after the program ran (vectors take three).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VolumeRegs {
    /// Density (float; a constant 1 for Volume Coefficients).
    pub density: Reg,
    /// Color (scatter colour; Absorption's and Emission's Color; the Scatter Coefficients).
    pub color: Reg,
    /// Absorption Color (Principled), the Absorption Coefficients; a constant 0 otherwise.
    pub absorption_color: Reg,
    /// Emission Color (the Emission Coefficients).
    pub emission_color: Reg,
    /// Emission Strength (Emission's Strength; 1 for Volume Coefficients).
    pub emission_strength: Reg,
    /// Blackbody Intensity.
    pub blackbody_intensity: Reg,
    /// Blackbody Tint.
    pub blackbody_tint: Reg,
    /// Temperature (kelvin).
    pub temperature: Reg,
}

/// One volume shader of the tree with the weight the Mix Shaders above it give it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VolumeClosure {
    /// The shader node.
    pub kind: VolumeKind,
    /// Its inputs' registers.
    pub regs: VolumeRegs,
    /// Its weight's register (None: 1, no Mix Shader above it).
    pub weight: Option<Reg>,
}

/// A compiled volume shader.
#[derive(Clone, Debug)]
pub struct VolumeProgram {
    /// The data nodes (every operation runs per point: `surface_end` covers them all).
    pub program: Program,
    /// The volume shaders whose coefficients add up at each point.
    pub closures: Vec<VolumeClosure>,
    /// No input of any shader and no weight varies over the medium: the coefficients are
    /// the same everywhere (the loader then makes a homogeneous medium of them).
    pub constant: bool,
    /// Anisotropy: the scattering shader's own value (the medium's phase function where it
    /// does not vary).
    pub anisotropy: f32,
    /// The register of a linked Anisotropy that varies over the medium, read at each
    /// scattering point.
    pub anisotropy_reg: Option<Reg>,
    /// The phase function: a Volume Scatter's or Volume Coefficients' Phase with its own
    /// inputs' values (Anisotropy applied at each point where it varies), else
    /// Henyey-Greenstein of `anisotropy`.
    pub phase: Phase,
    /// Two scattering shaders of different Henyey-Greenstein anisotropy: their indices in
    /// `closures`; the phase function is then the pair of lobes weighted by each one's
    /// scattering at the point (`Phase::HgPair`; `phase` holds the lobes, and their weight
    /// where the tree is constant).
    pub phase_pair: Option<(usize, usize)>,
    /// Generated coordinates are read (the mesh's texture space is needed).
    pub uses_generated: bool,
    /// Warnings (without the material's name; the loader adds it).
    pub warnings: Vec<String>,
    /// The graph's images, which its Image Texture nodes index (the loader decodes them
    /// into the medium's own list, as the world graph's).
    pub textures: Vec<crate::scene::texture::Texture>,
}

/// The volume shader a node type is, or None.
fn volume_kind(kind: &str) -> Option<VolumeKind> {
    Some(match kind {
        "ShaderNodeVolumePrincipled" => VolumeKind::Principled,
        "ShaderNodeVolumeScatter" => VolumeKind::Scatter,
        "ShaderNodeVolumeAbsorption" => VolumeKind::Absorption,
        "ShaderNodeVolumeCoefficients" => VolumeKind::Coefficients,
        "ShaderNodeEmission" => VolumeKind::Emission,
        _ => return None,
    })
}

/// Whether a node type combines shaders (its Shader inputs are closures, not data).
fn is_combiner(kind: &str) -> bool {
    matches!(kind, "ShaderNodeMixShader" | "ShaderNodeAddShader")
}

/// Marks `i` and the shader nodes under it (through Mix and Add Shader's Shader inputs) in `tree`.
fn mark_tree(ext: &NodesExt, i: usize, tree: &mut [bool]) {
    if tree[i] {
        return;
    }
    tree[i] = true;
    if is_combiner(&ext.nodes[i].kind) {
        for id in ["Shader", "Shader_001"] {
            if let Some(l) = ext.nodes[i].inputs.get(id).and_then(|d| d.link.as_ref())
                && l.0 < tree.len()
                && (is_combiner(&ext.nodes[l.0].kind) || volume_kind(&ext.nodes[l.0].kind).is_some())
            {
                mark_tree(ext, l.0, tree);
            }
        }
    }
}

/// Compiles the volume graph `ext` whose shader tree's root is node `shader`, for material
/// `name`; `images[k]` is graph image k's index in the list the caller puts in
/// [`VolumeProgram::textures`]; what the graph computes as RGB (Blackbody, Wavelength, the
/// Principled Volume's blackbody) is in `space`. Errors name the node.
pub fn compile_volume(
    name: &str,
    ext: &NodesExt,
    shader: usize,
    images: &[u32],
    space: crate::scene::working_space::WorkingSpace,
) -> Result<VolumeProgram, String> {
    let order = check_and_sort(ext)?;
    let Some(node) = ext.nodes.get(shader) else {
        return Err(format!("the volume shader is node {shader} but the graph has {} nodes", ext.nodes.len()));
    };
    if volume_kind(&node.kind).is_none() && !is_combiner(&node.kind) {
        return Err(format!("node '{}' ({}) is not a volume shader Caustic renders", node.name, node.kind));
    }
    let mut used = HashSet::new();
    for n in &ext.nodes {
        for i in n.inputs.values() {
            if let Some(l) = &i.link {
                used.insert((l.0, l.1.clone()));
            }
        }
    }
    let mut tree = vec![false; ext.nodes.len()];
    mark_tree(ext, shader, &mut tree);
    let mut c = Compiler::new(ext, images, name, used);
    c.volume = true;
    c.prog.space = space;
    for &i in order.iter().filter(|&&i| !tree[i]) {
        c.node(i)?;
    }
    let mut closures = Vec::new();
    let mut scatterers = Vec::new();
    volume_tree(&mut c, shader, None, &mut closures, &mut scatterers)?;
    let constant = closures.iter().all(|cl| {
        let r = &cl.regs;
        let vectors = [r.color, r.absorption_color, r.emission_color, r.blackbody_tint];
        let floats = [r.density, r.emission_strength, r.blackbody_intensity, r.temperature];
        cl.weight.is_none_or(|w| c.is_const(w, 1))
            && vectors.iter().all(|&v| c.is_const(v, 3))
            && floats.iter().all(|&f| c.is_const(f, 1))
    });
    // The phase function is the first scattering shader's, or two Henyey-Greenstein lobes
    // (Cycles samples among any number of phase closures by weight: more than two different
    // ones, or a pair that is not of Henyey-Greenstein lobes, are rendered by the first).
    let (mut anisotropy, mut anisotropy_reg, mut phase) = (0.0, None, Phase::hg(0.0));
    let mut phase_pair = None;
    if let [(a, ca), (b, cb)] = scatterers[..] {
        let hg = |c: &Compiler, i: usize| {
            c.desc(i).kind == "ShaderNodeVolumePrincipled"
                || c.prop_str(i, "phase", "HENYEY_GREENSTEIN") == "HENYEY_GREENSTEIN"
        };
        if hg(&c, a) && hg(&c, b) {
            let (ga, ra) = self::anisotropy(&mut c, a)?;
            let (gb, rb) = self::anisotropy(&mut c, b)?;
            if ra.is_none() && rb.is_none() && Phase::hg(ga) != Phase::hg(gb) {
                phase_pair = Some((ca, cb));
                anisotropy = ga;
                // The weight is set once the coefficients are known (constant trees) or at
                // each scattering point.
                phase = Phase::hg_pair(ga, gb, 0.5);
            }
        }
    }
    let scatterers: Vec<usize> =
        if phase_pair.is_some() { Vec::new() } else { scatterers.iter().map(|s| s.0).collect() };
    if let Some(&first) = scatterers.first() {
        let kind = volume_kind(&c.desc(first).kind).expect("a scatterer is a volume shader");
        (anisotropy, anisotropy_reg) = self::anisotropy(&mut c, first)?;
        phase = match kind {
            VolumeKind::Principled => Phase::hg(anisotropy),
            _ => scatter_phase(&mut c, first, anisotropy),
        };
        for &other in &scatterers[1..] {
            let kind = volume_kind(&c.desc(other).kind).expect("a scatterer is a volume shader");
            let (g, reg) = self::anisotropy(&mut c, other)?;
            let p = match kind {
                VolumeKind::Principled => Phase::hg(g),
                _ => scatter_phase(&mut c, other, g),
            };
            if p != phase || reg.is_some() || anisotropy_reg.is_some() {
                let first_name = c.desc(first).name.clone();
                c.warn(
                    other,
                    format!(
                        "its phase function differs from that of '{first_name}', which the medium scatters by for both \
                         (a mixture of phase functions is not rendered)"
                    ),
                );
            }
        }
    }
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
        closures,
        constant: constant && anisotropy_reg.is_none(),
        phase_pair,
        anisotropy,
        anisotropy_reg,
        phase,
        uses_generated: c.uses_generated,
        warnings: c.warnings,
        textures: Vec::new(),
    })
}

/// Flattens the shader tree under node `i` with weight `w` (None: 1) into `closures`, and
/// the scattering shaders into `scatterers` (node, closure index) in the order met. Mix Shader weights are
/// Cycles' (`svm_node_mix_closure`: the factor clamped to [0, 1]), folded when constant;
/// Add Shader passes its weight to both inputs. A node under the tree that is not a volume
/// shader is left out with a warning.
fn volume_tree(
    c: &mut Compiler,
    i: usize,
    w: Option<Reg>,
    closures: &mut Vec<VolumeClosure>,
    scatterers: &mut Vec<(usize, usize)>,
) -> Result<(), String> {
    let kind = c.desc(i).kind.clone();
    let link = |c: &Compiler, id: &str| c.desc(i).inputs.get(id).and_then(|d| d.link.clone());
    if is_combiner(&kind) {
        let (w1, w2) = if kind == "ShaderNodeMixShader" {
            let fac = c.float(i, "Fac", 0.5)?;
            if c.is_const(fac, 1) && w.is_none_or(|w| c.is_const(w, 1)) {
                let t = c.init[fac as usize].clamp(0.0, 1.0);
                let wv = w.map_or(1.0, |w| c.init[w as usize]);
                (Some(c.konst_f(wv * (1.0 - t))), Some(c.konst_f(wv * t)))
            } else {
                let (out1, out2) = (c.alloc(1), c.alloc(1));
                c.ops.push(Op::MixWeight { w, fac, out1, out2 });
                (Some(out1), Some(out2))
            }
        } else {
            (w, w)
        };
        for (id, wk) in [("Shader", w1), ("Shader_001", w2)] {
            let Some(l) = link(c, id) else { continue };
            let src = &c.desc(l.0).kind;
            if is_combiner(src) || volume_kind(src).is_some() {
                volume_tree(c, l.0, wk, closures, scatterers)?;
            } else {
                let what = c.desc(l.0).name.clone();
                c.warn(i, format!("'{what}' ({src}) is not a volume shader: it adds nothing to the volume"));
            }
        }
        return Ok(());
    }
    let kind = volume_kind(&kind).expect("the tree holds volume shaders and combiners");
    let zero = c.konst_f(0.0);
    let zero3 = c.konst_v(Vec3::ZERO);
    let one = c.konst_f(1.0);
    let one3 = c.konst_v(Vec3::ONE);
    let regs = match kind {
        VolumeKind::Principled => VolumeRegs {
            density: c.float(i, "Density", 1.0)?,
            color: c.vec(i, "Color", Vec3::splat(0.5))?,
            absorption_color: c.vec(i, "Absorption Color", Vec3::ZERO)?,
            emission_color: c.vec(i, "Emission Color", Vec3::ONE)?,
            emission_strength: c.float(i, "Emission Strength", 0.0)?,
            blackbody_intensity: c.float(i, "Blackbody Intensity", 0.0)?,
            blackbody_tint: c.vec(i, "Blackbody Tint", Vec3::ONE)?,
            temperature: c.float(i, "Temperature", 1000.0)?,
        },
        VolumeKind::Scatter | VolumeKind::Absorption => VolumeRegs {
            density: c.float(i, "Density", 1.0)?,
            color: c.vec(i, "Color", Vec3::splat(0.8))?,
            absorption_color: zero3,
            emission_color: zero3,
            emission_strength: zero,
            blackbody_intensity: zero,
            blackbody_tint: one3,
            temperature: zero,
        },
        VolumeKind::Coefficients => VolumeRegs {
            density: one,
            color: c.vec(i, "Scatter Coefficients", Vec3::ONE)?,
            absorption_color: c.vec(i, "Absorption Coefficients", Vec3::ONE)?,
            emission_color: c.vec(i, "Emission Coefficients", Vec3::ZERO)?,
            emission_strength: one,
            blackbody_intensity: zero,
            blackbody_tint: one3,
            temperature: zero,
        },
        VolumeKind::Emission => VolumeRegs {
            density: zero,
            color: zero3,
            absorption_color: zero3,
            emission_color: c.vec(i, "Color", Vec3::ONE)?,
            emission_strength: c.float(i, "Strength", 1.0)?,
            blackbody_intensity: zero,
            blackbody_tint: one3,
            temperature: zero,
        },
    };
    if matches!(kind, VolumeKind::Principled | VolumeKind::Scatter | VolumeKind::Coefficients) {
        scatterers.push((i, closures.len()));
    }
    closures.push(VolumeClosure { kind, regs, weight: w });
    Ok(())
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
        Some(_) => {
            // A link that folds to a constant gives that constant, not the socket's own value.
            let reg = c.float(i, "Anisotropy", 0.0)?;
            if c.is_const(reg, 1) { Ok((c.init[reg as usize], None)) } else { Ok((own, Some(reg))) }
        }
        None => Ok((own, None)),
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
        let v = compile_volume("m", &ext, 2, &[], Default::default()).unwrap();
        assert_eq!(v.closures.len(), 1);
        assert_eq!(v.closures[0].kind, VolumeKind::Principled);
        assert!(!v.constant, "the Density follows a Noise Texture");
        assert!((v.anisotropy - 0.3).abs() < 1e-6);
        assert!(v.uses_generated, "the Noise Texture's unlinked Vector is Generated");
        assert!(!v.program.ops.is_empty());
        let img: NodesExt = serde_json::from_value(json!({"version": 1, "nodes": [
            {"name": "Img", "type": "ShaderNodeTexImage", "props": {"image": 0}, "inputs": {}},
            {"name": "PV", "type": "ShaderNodeVolumeScatter", "inputs": {"Density": {"link": [0, "Alpha"]}}}],
            "output": {}}))
        .unwrap();
        let v = compile_volume("m", &img, 1, &[0], Default::default()).unwrap();
        assert!(v.program.ops.iter().any(|op| matches!(op, Op::Image(t) if t.texture == Some(0))));
        assert!(
            compile_volume("m", &img, 1, &[], Default::default()).unwrap_err().contains("not in the graph's images")
        );
        assert!(compile_volume("m", &img, 0, &[0], Default::default()).unwrap_err().contains("not a volume shader"));
    }

    /// Volume Scatter and Volume Absorption added, mixed by a constant factor with a Volume
    /// Coefficients node: four closures, constant, the Mix weights folded (Cycles clamps the
    /// factor to [0, 1]); a varying factor keeps a Mix weight operation and the tree is not
    /// constant; a BSDF under the tree is warned and left out; a linked constant Anisotropy
    /// gives its folded value.
    #[test]
    fn a_tree_of_volume_shaders_flattens() {
        let ext: NodesExt = serde_json::from_value(json!({"version": 1, "nodes": [
            {"name": "S", "type": "ShaderNodeVolumeScatter", "inputs": {"Density": {"value": 2.0},
             "Anisotropy": {"value": 0.0, "link": [6, "Value"]}}},
            {"name": "A", "type": "ShaderNodeVolumeAbsorption", "inputs": {"Density": {"value": 3.0}}},
            {"name": "Add", "type": "ShaderNodeAddShader",
             "inputs": {"Shader": {"link": [0, "Volume"]}, "Shader_001": {"link": [1, "Volume"]}}},
            {"name": "C", "type": "ShaderNodeVolumeCoefficients", "props": {"phase": "HENYEY_GREENSTEIN"},
             "inputs": {"Scatter Coefficients": {"value": [0.1, 0.2, 0.3]}, "Anisotropy": {"value": 0.4},
                        "Emission Coefficients": {"value": [1.0, 0.0, 0.0]}}},
            {"name": "Mix", "type": "ShaderNodeMixShader",
             "inputs": {"Fac": {"value": 1.5}, "Shader": {"link": [2, "Shader"]}, "Shader_001": {"link": [3, "Volume"]}}},
            {"name": "D", "type": "ShaderNodeBsdfDiffuse", "inputs": {}},
            {"name": "V", "type": "ShaderNodeValue", "props": {"value": 0.25}, "inputs": {}},
            {"name": "Top", "type": "ShaderNodeAddShader",
             "inputs": {"Shader": {"link": [4, "Shader"]}, "Shader_001": {"link": [5, "BSDF"]}}}],
            "output": {}}))
        .unwrap();
        let v = compile_volume("m", &ext, 7, &[], Default::default()).unwrap();
        let kinds: Vec<_> = v.closures.iter().map(|c| c.kind).collect();
        assert_eq!(kinds, [VolumeKind::Scatter, VolumeKind::Absorption, VolumeKind::Coefficients]);
        assert!(v.constant);
        let weight = |k: usize| v.closures[k].weight.map(|w| v.program.init[w as usize]);
        // Fac 1.5 clamps to 1: the Add Shader's pair weighs 0, the coefficients 1.
        assert_eq!((weight(0), weight(1), weight(2)), (Some(0.0), Some(0.0), Some(1.0)));
        assert!(!v.program.ops.iter().any(|op| matches!(op, Op::MixWeight { .. })));
        assert!((v.anisotropy - 0.25).abs() < 1e-6, "the Value node's 0.25, not the socket's 0: {}", v.anisotropy);
        assert!(v.warnings.iter().any(|w| w.contains("'D'") && w.contains("not a volume shader")), "{:?}", v.warnings);
        // Two Henyey-Greenstein scatterers of different anisotropy: a pair of lobes.
        assert_eq!(v.phase_pair, Some((0, 2)));
        assert!(matches!(v.phase, Phase::HgPair { g1, g2, .. } if (g1 - 0.25).abs() < 1e-6 && (g2 - 0.4).abs() < 1e-6));
        assert_eq!(v.warnings.len(), 1, "{:?}", v.warnings);
        // A third scatterer of another anisotropy: rendered by the first one's, warned.
        let mut three = ext.clone();
        three.nodes[1].kind = "ShaderNodeVolumeScatter".into();
        three.nodes[1].inputs.insert("Anisotropy".into(), serde_json::from_value(json!({"value": -0.5})).unwrap());
        let v = compile_volume("m", &three, 7, &[], Default::default()).unwrap();
        assert_eq!(v.phase_pair, None);
        assert!(v.warnings.iter().any(|w| w.contains("phase function differs")), "{:?}", v.warnings);

        let mut varying = ext.clone();
        varying.nodes.push(
            serde_json::from_value(json!(
            {"name": "N", "type": "ShaderNodeTexNoise", "props": {"noise_dimensions": "3D"}, "inputs": {}}))
            .unwrap(),
        );
        varying.nodes[4].inputs.get_mut("Fac").unwrap().link = Some((8, "Fac".into()));
        let v = compile_volume("m", &varying, 7, &[], Default::default()).unwrap();
        assert!(!v.constant);
        assert!(v.program.ops.iter().any(|op| matches!(op, Op::MixWeight { .. })));
    }
}
