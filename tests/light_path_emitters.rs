//! Emitters whose node graph reads the Light Path node, in the integrators that also build
//! paths from the lights (`src/integrator/bdpt/path_emitters.rs`): BDPT and VCM converge to
//! the path tracer's image region by region, and the photon integrators, whose photons
//! leave such an emitter without a camera path, name the emitter in a warning unless the
//! outputs it reads are the same for every photon as for every ray that finds it.
//!
//! The scene: a grey floor and back wall seen from the front (max depth 4), two emissive
//! quads hanging over the floor, both in view. "Ramp" emits 6 × (Ray Depth < 1.5): the
//! camera and next-event estimation from the first hit see it, deeper rays do not (so
//! it gives direct light only, and light subpaths leaving it would add indirect light).
//! "Hidden" emits 2 × (1 − Is Camera Ray) + 3 × Is Diffuse Ray: black to the camera (light
//! tracing would show it), 2 to next-event estimation and 5 to a ray bounced off a diffuse
//! surface, so its light is the sum of the two strategies' MIS-weighted shares (as in
//! Cycles): only an integrator weighing them as the path tracer does agrees. A plain
//! emissive patch low on the back wall starts light subpaths (so VCM merges, and light
//! tracing and connections run beside the camera-side strategies of the other two).
//!
//! Bounds (`common::agreement`): K seeds per estimate, Welch's test per region, Šidák's
//! split over every comparison of the test (two integrators, five regions each).

mod common;

use common::agreement::{Seeded, regions, sidak};
use common::{GltfBuilder, look_rotation, quick_render_warnings, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);
const RES: (usize, usize) = (24, 24);

fn node_material(name: &str, nodes: Value, surface: Value) -> Value {
    json!({"name": name, "doubleSided": true, "extensions": {"CAUSTIC_materials_nodes":
        {"version": 1, "nodes": nodes, "output": {"surface": surface}}}})
}

/// 6 × (Ray Depth < 1.5).
fn ramp() -> Value {
    node_material(
        "Ramp",
        json!([
            {"name": "Light Path", "type": "ShaderNodeLightPath"},
            {"name": "Less", "type": "ShaderNodeMath", "props": {"operation": "LESS_THAN"},
             "inputs": {"Value": {"link": [0, "Ray Depth"]}, "Value_001": {"value": 1.5}}},
            {"name": "Scale", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
             "inputs": {"Value": {"link": [1, "Value"]}, "Value_001": {"value": 6.0}}},
            {"name": "Emission", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"value": [1, 0.9, 0.8, 1]}, "Strength": {"link": [2, "Value"]}}}
        ]),
        json!([3, "Emission"]),
    )
}

/// 2 × (1 − Is Camera Ray) + 3 × Is Diffuse Ray.
fn hidden() -> Value {
    node_material(
        "Hidden",
        json!([
            {"name": "Light Path", "type": "ShaderNodeLightPath"},
            {"name": "Not camera", "type": "ShaderNodeMath", "props": {"operation": "SUBTRACT"},
             "inputs": {"Value": {"value": 1.0}, "Value_001": {"link": [0, "Is Camera Ray"]}}},
            {"name": "Diffuse part", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
             "inputs": {"Value": {"link": [0, "Is Diffuse Ray"]}, "Value_001": {"value": 3.0}}},
            {"name": "Sum", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY_ADD"},
             "inputs": {"Value": {"link": [1, "Value"]}, "Value_001": {"value": 2.0},
                        "Value_002": {"link": [2, "Value"]}}},
            {"name": "Emission", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"value": [0.8, 0.9, 1, 1]}, "Strength": {"link": [3, "Value"]}}}
        ]),
        json!([4, "Emission"]),
    )
}

/// The scene of the module doc with the given emitter materials.
fn scene(dir: &Path, left: Value, right: Value) -> PathBuf {
    let mut g = GltfBuilder::new();
    g.use_ext("CAUSTIC_materials_nodes");
    g.use_ext("KHR_materials_emissive_strength");
    let grey = g
        .material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1], "metallicFactor": 0.0},
            "doubleSided": true}));
    let quad = |g: &mut GltfBuilder, p: [[f32; 3]; 4], m: usize| g.mesh(&p, &[0, 1, 2, 0, 2, 3], m);
    quad(&mut g, [[-2.0, -1.0, -2.0], [2.0, -1.0, -2.0], [2.0, -1.0, -6.0], [-2.0, -1.0, -6.0]], grey);
    quad(&mut g, [[-2.0, -1.0, -6.0], [2.0, -1.0, -6.0], [2.0, 2.0, -6.0], [-2.0, 2.0, -6.0]], grey);
    let left = g.material(left);
    let right = g.material(right);
    quad(&mut g, [[-1.5, 0.6, -3.5], [-0.3, 0.6, -3.5], [-0.3, 0.6, -4.7], [-1.5, 0.6, -4.7]], left);
    quad(&mut g, [[0.3, 0.6, -3.5], [1.5, 0.6, -3.5], [1.5, 0.6, -4.7], [0.3, 0.6, -4.7]], right);
    let patch = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0},
        "emissiveFactor": [1, 1, 1], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}}));
    quad(&mut g, [[-0.4, -0.8, -5.9], [0.4, -0.8, -5.9], [0.4, -0.4, -5.9], [-0.4, -0.4, -5.9]], patch);
    g.camera([0.0, 1.2, 0.0], look_rotation([0.0, -0.35, -1.0]), 1.0);
    g.write(dir, "light_path_emitters.gltf")
}

#[test]
fn bidirectional_integrators_match_the_path_tracer() {
    let dir = temp_dir();
    let path = scene(dir.path(), ramp(), hidden());
    let regs = regions(RES.0, RES.1);
    let r = format!("{}x{}", RES.0, RES.1);
    let seeded = Seeded::six(dir.path(), &r, "4", &regs, LIMIT);
    let reference = seeded.means(&path, &["--integrator", "path", "--spp", "64"]);
    let alpha = sidak(regs.len() * 2);
    let failed = seeded.bidirectional_disagreeing(&path, &reference, "32", "0.02", alpha);
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}

/// Jensen's photon mapping and SPPM name an emitter that reads Ray Depth or a bounce's kind
/// (their photons cannot), and not one that reads only Is Camera Ray (exact for photons:
/// no ray but the camera's sees it lit, photons included).
#[test]
fn photon_integrators_name_emitters_their_photons_approximate() {
    let dir = temp_dir();
    let camera_only = node_material(
        "CameraOnly",
        json!([
            {"name": "Light Path", "type": "ShaderNodeLightPath"},
            {"name": "Emission", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"value": [1, 1, 1, 1]}, "Strength": {"link": [0, "Is Camera Ray"]}}}
        ]),
        json!([1, "Emission"]),
    );
    let path = scene(dir.path(), ramp(), camera_only);
    let out = dir.path().join("w.exr");
    for integrator in ["photon", "sppm"] {
        let w = quick_render_warnings(&path, &out, &["--integrator", integrator], LIMIT);
        let named: Vec<_> = w.iter().filter(|w| w.contains("Light Path")).collect();
        assert_eq!(named.len(), 1, "{integrator}: {w:?}");
        assert!(named[0].contains("'Ramp'") && !named[0].contains("CameraOnly"), "{integrator}: {}", named[0]);
        assert!(named[0].contains("Ray Depth"), "{integrator}: names the output: {}", named[0]);
    }
    for integrator in ["path", "bdpt", "vcm"] {
        let w = quick_render_warnings(&path, &out, &["--integrator", integrator], LIMIT);
        assert!(!w.iter().any(|w| w.contains("Light Path")), "{integrator}: {w:?}");
    }
}

/// A floor whose BSDF is switched by a Light Path output: the photon integrators, which
/// scatter on it from the light side, name it when their photons read that output otherwise
/// than the path tracer's rays (Is Diffuse Ray; Is Camera Ray is 0 on both); BDPT and VCM,
/// which leave the paths through it to the camera side (`tests/light_path_bsdfs.rs`), and
/// the path tracer never do.
#[test]
fn light_side_integrators_name_bsdfs_switched_by_the_light_path_node() {
    let dir = temp_dir();
    let switched = |name: &str, output: &str| {
        node_material(
            name,
            json!([
                {"name": "Light Path", "type": "ShaderNodeLightPath"},
                {"name": "Grey", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"value": [0.5, 0.5, 0.5, 1]}}},
                {"name": "Green", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"value": [0.1, 0.8, 0.1, 1]}}},
                {"name": "Mix", "type": "ShaderNodeMixShader",
                 "inputs": {"Fac": {"link": [0, output]}, "Shader": {"link": [1, "BSDF"]},
                            "Shader_001": {"link": [2, "BSDF"]}}}
            ]),
            json!([3, "Shader"]),
        )
    };
    let path = scene(dir.path(), switched("ByCamera", "Is Camera Ray"), switched("ByDiffuse", "Is Diffuse Ray"));
    let out = dir.path().join("w.exr");
    for (integrator, names) in [("bdpt", &[][..]), ("vcm", &[]), ("photon", &["ByDiffuse"]), ("sppm", &["ByDiffuse"])] {
        let w = quick_render_warnings(&path, &out, &["--integrator", integrator], LIMIT);
        let named: Vec<_> = w.iter().filter(|w| w.contains("BSDF or transparency")).collect();
        if names.is_empty() {
            assert!(named.is_empty(), "{integrator}: {w:?}");
            continue;
        }
        assert_eq!(named.len(), 1, "{integrator}: {w:?}");
        for m in ["ByCamera", "ByDiffuse"] {
            assert_eq!(named[0].contains(&format!("'{m}'")), names.contains(&m), "{integrator} {m}: {}", named[0]);
        }
    }
    let w = quick_render_warnings(&path, &out, &["--integrator", "path"], LIMIT);
    assert!(!w.iter().any(|w| w.contains("Light Path")), "path: {w:?}");
}
