//! Which Light Path outputs change a material's scattering (its BSDFs' weights and inputs,
//! transparency, holdout, displacement) rather than only its emission. The integrators
//! that shade surfaces from the light side (light subpaths, photons) have no camera path
//! there, so they name such materials in a warning (`light::path_emitters`).

use crate::scene::light_path::PathOutput;
use crate::shader::graph::NodesExt;

/// The Light Path outputs, in `PathOutput::ALL`'s order, that the scattering part of the
/// checked (acyclic) graph `ext` reads, directly or through any chain of nodes.
pub(super) fn scattering_outputs(ext: &NodesExt) -> Vec<PathOutput> {
    let mut memo = vec![None; ext.nodes.len()];
    let mut shaders = vec![None; ext.nodes.len()];
    let mut mask = 0u32;
    if let Some((n, _)) = &ext.output.displacement {
        mask |= upstream(ext, *n, &mut memo);
    }
    if let Some((n, _)) = &ext.output.surface {
        mask |= shader(ext, *n, &mut memo, &mut shaders).1;
    }
    PathOutput::ALL.iter().enumerate().filter(|(k, _)| mask & (1 << k) != 0).map(|(_, (_, o))| *o).collect()
}

/// The bit of a Light Path output socket (its name as the add-on writes links).
fn bit(socket: &str) -> u32 {
    PathOutput::ALL.iter().position(|(name, _)| *name == socket).map_or(0, |k| 1 << k)
}

/// The Light Path outputs node `i`'s inputs read (through any chain of links).
fn upstream(ext: &NodesExt, i: usize, memo: &mut [Option<u32>]) -> u32 {
    if let Some(m) = memo[i] {
        return m;
    }
    let mut m = 0;
    for link in ext.nodes[i].inputs.values().filter_map(|d| d.link.as_ref()) {
        m |= if ext.nodes[link.0].kind == "ShaderNodeLightPath" { bit(&link.1) } else { upstream(ext, link.0, memo) };
    }
    memo[i] = Some(m);
    m
}

/// Shader node `i`: whether it holds a closure other than emission, and the Light Path
/// outputs that change those closures (a Mix Shader's factor counts where either side
/// scatters: it scales that side's weight).
fn shader(ext: &NodesExt, i: usize, memo: &mut [Option<u32>], done: &mut [Option<(bool, u32)>]) -> (bool, u32) {
    if let Some(r) = done[i] {
        return r;
    }
    let node = &ext.nodes[i];
    let linked = |id: &str| node.inputs.get(id).and_then(|d| d.link.as_ref()).map(|l| l.0);
    let r = match node.kind.as_str() {
        "ShaderNodeEmission" | "ShaderNodeBackground" => (false, 0),
        "ShaderNodeMixShader" | "ShaderNodeAddShader" => {
            let (mut scatters, mut m) = (false, 0);
            for n in ["Shader", "Shader_001"].into_iter().filter_map(linked) {
                let (s, mn) = shader(ext, n, memo, done);
                scatters |= s;
                m |= mn;
            }
            if scatters && node.kind == "ShaderNodeMixShader" {
                m |= match node.inputs.get("Fac").and_then(|d| d.link.as_ref()) {
                    Some(l) if ext.nodes[l.0].kind == "ShaderNodeLightPath" => bit(&l.1),
                    Some(l) => upstream(ext, l.0, memo),
                    None => 0,
                };
            }
            (scatters, m)
        }
        // A BSDF, Transparent, Holdout or anything else: every input may change it.
        _ => (true, upstream(ext, i, memo)),
    };
    done[i] = Some(r);
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn ext(nodes: serde_json::Value, surface: serde_json::Value) -> NodesExt {
        serde_json::from_value(json!({"version": 1, "nodes": nodes, "output": {"surface": surface}})).unwrap()
    }

    /// An emission strength read from Ray Depth leaves the scattering alone; a Mix Shader
    /// of a BSDF and an emission by Is Camera Ray changes the BSDF's weight; a BSDF colour
    /// from Is Diffuse Ray through a Math node changes it too.
    #[test]
    fn emission_only_reads_are_told_from_scattering_ones() {
        let emission_only = ext(
            json!([
                {"name": "LP", "type": "ShaderNodeLightPath"},
                {"name": "E", "type": "ShaderNodeEmission", "inputs": {"Strength": {"link": [0, "Ray Depth"]}}},
                {"name": "D", "type": "ShaderNodeBsdfDiffuse"},
                {"name": "A", "type": "ShaderNodeAddShader",
                 "inputs": {"Shader": {"link": [1, "Emission"]}, "Shader_001": {"link": [2, "BSDF"]}}}
            ]),
            json!([3, "Shader"]),
        );
        assert_eq!(scattering_outputs(&emission_only), []);
        let mixed = ext(
            json!([
                {"name": "LP", "type": "ShaderNodeLightPath"},
                {"name": "E", "type": "ShaderNodeEmission"},
                {"name": "D", "type": "ShaderNodeBsdfDiffuse"},
                {"name": "M", "type": "ShaderNodeMixShader",
                 "inputs": {"Fac": {"link": [0, "Is Camera Ray"]}, "Shader": {"link": [2, "BSDF"]},
                            "Shader_001": {"link": [1, "Emission"]}}}
            ]),
            json!([3, "Shader"]),
        );
        assert_eq!(scattering_outputs(&mixed), [PathOutput::IsCamera]);
        let coloured = ext(
            json!([
                {"name": "LP", "type": "ShaderNodeLightPath"},
                {"name": "Math", "type": "ShaderNodeMath", "inputs": {"Value": {"link": [0, "Is Diffuse Ray"]}}},
                {"name": "D", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Roughness": {"link": [1, "Value"]}}}
            ]),
            json!([2, "BSDF"]),
        );
        assert_eq!(scattering_outputs(&coloured), [PathOutput::IsDiffuse]);
    }
}
