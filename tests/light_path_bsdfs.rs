//! BSDFs switched by the Light Path node in BDPT and VCM
//! (`src/integrator/bdpt/visibility.rs`: the triangles of a material whose scattering reads
//! the node are restricted, so the paths that meet them are made by s = 0 and s = 1 alone,
//! as the path tracer makes them): both converge to the path tracer's image region by
//! region, and neither warns.
//!
//! The scene: a floor and a back wall with a panel on it, seen from the front (max depth 4),
//! under an emissive quad facing down. Two cases, each with its switch:
//! - **Is Camera Ray**: the floor is grey to the camera, saturated green to every other
//!   ray. The wall takes a green bounce from a floor the camera sees grey; light tracing
//!   (t = 1), shading the floor with the light subpath's state, would show it green.
//! - **Is Diffuse Ray and Ray Depth**: the floor is grey except to diffuse rays (green),
//!   the wall's panel grey at Ray Depth 0 and orange deeper (the rest of the wall is plain,
//!   so every strategy runs beside the restricted paths). A light subpath reaching the floor
//!   straight from the light reads neither a diffuse ray nor the path's depth, so its
//!   connections would shade the floor grey where the camera-order path reaches it by a
//!   diffuse bounce off the wall (green).
//!
//! Each case checks that its switch matters: the path tracer's image with the switched
//! material replaced by its camera-ray branch leaves the case's bounds.
//!
//! Bounds (`common::agreement`): K seeds per estimate, Welch's test per region, Šidák's
//! split over every comparison of the test (per case the switch check and two integrators,
//! five regions each). VCM's merging blurs indirect light by at most its radius, 0.02 on a
//! scene 4 units across, a tenth of the regions' noise bound (as in `linking_integrators.rs`).

mod common;

use common::agreement::{Seeded, regions, sidak};
use common::{GltfBuilder, look_rotation, quick_render_warnings, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);
const RES: (usize, usize) = (24, 24);

/// A diffuse node material of colour `c`.
fn diffuse(name: &str, c: [f32; 3]) -> Value {
    json!({"name": name, "doubleSided": true, "extensions": {"CAUSTIC_materials_nodes": {"version": 1,
        "nodes": [{"name": "D", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"value": [c[0], c[1], c[2], 1]}}}],
        "output": {"surface": [0, "BSDF"]}}}})
}

/// Mix Shader of diffuse `off` (factor 0) and diffuse `on` (factor 1), its factor the Light
/// Path output `output`, or with `above` that output greater than the value.
fn switched(name: &str, output: &str, above: Option<f32>, off: [f32; 3], on: [f32; 3]) -> Value {
    let mut nodes = vec![
        json!({"name": "Light Path", "type": "ShaderNodeLightPath"}),
        json!({"name": "Off", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"value": [off[0], off[1], off[2], 1]}}}),
        json!({"name": "On", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"value": [on[0], on[1], on[2], 1]}}}),
    ];
    let fac = match above {
        None => json!([0, output]),
        Some(v) => {
            nodes.push(json!({"name": "Above", "type": "ShaderNodeMath", "props": {"operation": "GREATER_THAN"},
                "inputs": {"Value": {"link": [0, output]}, "Value_001": {"value": v}}}));
            json!([3, "Value"])
        }
    };
    let mix = nodes.len();
    nodes.push(json!({"name": "Mix", "type": "ShaderNodeMixShader",
        "inputs": {"Fac": {"link": fac}, "Shader": {"link": [1, "BSDF"]}, "Shader_001": {"link": [2, "BSDF"]}}}));
    json!({"name": name, "doubleSided": true, "extensions": {"CAUSTIC_materials_nodes": {"version": 1,
        "nodes": nodes, "output": {"surface": [mix, "Shader"]}}}})
}

const GREY: [f32; 3] = [0.6, 0.6, 0.6];
const GREEN: [f32; 3] = [0.05, 0.85, 0.1];
const ORANGE: [f32; 3] = [0.9, 0.45, 0.1];

/// The scene of the module doc with the floor's and the wall panel's materials.
fn scene(dir: &Path, name: &str, floor: Value, panel: Value) -> PathBuf {
    let mut g = GltfBuilder::new();
    g.use_ext("CAUSTIC_materials_nodes");
    g.use_ext("KHR_materials_emissive_strength");
    let quad = |g: &mut GltfBuilder, p: [[f32; 3]; 4], m: usize| g.mesh(&p, &[0, 1, 2, 0, 2, 3], m);
    let floor = g.material(floor);
    let wall = g.material(diffuse("Wall", GREY));
    let panel = g.material(panel);
    quad(&mut g, [[-2.0, -1.0, -2.0], [2.0, -1.0, -2.0], [2.0, -1.0, -6.0], [-2.0, -1.0, -6.0]], floor);
    quad(&mut g, [[-2.0, -1.0, -6.0], [2.0, -1.0, -6.0], [2.0, 2.0, -6.0], [-2.0, 2.0, -6.0]], wall);
    quad(&mut g, [[-1.8, -0.9, -5.95], [0.0, -0.9, -5.95], [0.0, 0.6, -5.95], [-1.8, 0.6, -5.95]], panel);
    let lamp = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0},
        "emissiveFactor": [1, 1, 1], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 3.0}}}));
    quad(&mut g, [[-0.8, 1.5, -3.4], [-0.8, 1.5, -4.6], [0.8, 1.5, -4.6], [0.8, 1.5, -3.4]], lamp);
    g.camera([0.0, 1.2, 0.0], look_rotation([0.0, -0.35, -1.0]), 1.0);
    g.write(dir, name)
}

/// The cases: name, switched floor and wall panel, and the same with each switched material
/// replaced by its camera-ray branch.
fn cases() -> Vec<(&'static str, [Value; 2], [Value; 2])> {
    vec![
        (
            "is camera ray",
            [switched("ByCamera", "Is Camera Ray", None, GREEN, GREY), diffuse("Panel", GREY)],
            [diffuse("Floor", GREY), diffuse("Panel", GREY)],
        ),
        (
            "is diffuse ray and ray depth",
            [
                switched("ByDiffuse", "Is Diffuse Ray", None, GREY, GREEN),
                switched("ByDepth", "Ray Depth", Some(0.5), GREY, ORANGE),
            ],
            [diffuse("Floor", GREY), diffuse("Panel", GREY)],
        ),
    ]
}

/// BDPT and VCM each agree with the path tracer on every case, each case's switch matters,
/// and neither names the switched materials in a warning.
#[test]
fn bdpt_and_vcm_match_the_path_tracer_with_bsdfs_switched_by_the_light_path_node() {
    let dir = temp_dir();
    let regs = regions(RES.0, RES.1);
    let r = format!("{}x{}", RES.0, RES.1);
    let seeded = Seeded::six(dir.path(), &r, "4", &regs, LIMIT);
    let cases = cases();
    let alpha = sidak(regs.len() * 3 * cases.len());
    let path_tracer = ["--integrator", "path", "--spp", "64"];
    let (mut failed, mut warned) = (Vec::new(), Vec::new());
    for (k, (name, [floor, panel], [plain_floor, plain_panel])) in cases.into_iter().enumerate() {
        let ruled = scene(dir.path(), &format!("case{k}.gltf"), floor, panel);
        let reference = seeded.means(&ruled, &path_tracer);
        let plain = seeded.means(&scene(dir.path(), &format!("plain{k}.gltf"), plain_floor, plain_panel), &path_tracer);
        seeded.assert_rule_matters(&format!("{name}: without the switch"), &plain, &reference, alpha);
        let bad = seeded.bidirectional_disagreeing(&ruled, &reference, "32", "0.02", alpha);
        failed.extend(bad.into_iter().map(|b| format!("{name}: {b}")));
        for integrator in ["bdpt", "vcm"] {
            let out = dir.path().join("w.exr");
            let w = quick_render_warnings(&ruled, &out, &["--integrator", integrator], LIMIT);
            warned.extend(
                w.into_iter().filter(|w| w.contains("Light Path")).map(|w| format!("{name} {integrator}: {w}")),
            );
        }
    }
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
    assert!(warned.is_empty(), "warn: {warned:?}");
}
