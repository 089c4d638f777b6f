//! Lights' node trees (`nodes` of `CAUSTIC_lights_punctual` / `CAUSTIC_lights_area`): a
//! constant tree folds into the light bit for bit, a varying one (Light Falloff) renders the
//! same in every integrator, a malformed IES profile is refused naming the light and node.

mod common;

use common::{GltfBuilder, look_rotation, render_image, run, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);

/// A grey floor and box under a point light named "Bulb" at height 2 with CAUSTIC_lights_punctual
/// `ext`, light colour `color`, seen from above; written to `dir/name`.
fn scene(dir: &Path, name: &str, color: [f32; 3], ext: Value) -> PathBuf {
    let mut g = GltfBuilder::new();
    let m = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0.0,
                                                      "roughnessFactor": 1.0}}));
    g.mesh(&[[-3.0, 0.0, -3.0], [3.0, 0.0, -3.0], [3.0, 0.0, 3.0], [-3.0, 0.0, 3.0]], &[0, 2, 1, 0, 3, 2], m);
    // A box for light that bounces (the integrators' paths then differ beyond direct light).
    g.cube([-0.8, 0.0, -0.6], [0.2, 0.9, 0.4], m);
    g.camera([0.0, 4.0, 0.01], look_rotation([0.0, -1.0, -0.0025]), 1.0);
    let light = g.punctual_with(
        json!({"type": "point", "color": color, "intensity": 683.0 * 40.0}),
        [0.3, 2.0, 0.2],
        [0.0, 0.0, 0.0, 1.0],
        json!({"CAUSTIC_lights_punctual": ext}),
    );
    g.use_ext("CAUSTIC_lights_punctual");
    g.node_name(light, "Bulb");
    g.settings(json!({"max_depth": 3}));
    g.write(dir, name)
}

/// The `nodes` value of a graph whose Emission (node `emission`) is the output.
fn graph(nodes: Value, emission: usize) -> Value {
    json!({"version": 1, "nodes": nodes, "output": {"surface": [emission, "Emission"]}})
}

/// Blackbody at 3000 K into the Emission's Color: constant, so the light renders bit for bit
/// as the same light whose colour is the Blackbody's (the fold multiplies once at load).
#[test]
fn a_constant_blackbody_folds_into_the_lights_colour() {
    let dir = temp_dir();
    let nodes = graph(
        json!([
            {"name": "Blackbody", "type": "ShaderNodeBlackbody", "inputs": {"Temperature": {"value": 3000.0}}},
            {"name": "Emission", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"link": [0, "Color"]}, "Strength": {"value": 1.0}}}
        ]),
        1,
    );
    let with_nodes = scene(dir.path(), "nodes.gltf", [1.0, 1.0, 1.0], json!({"nodes": nodes}));
    let bb = caustic::medium::blackbody::blackbody_rgb(3000.0);
    let plain = scene(dir.path(), "plain.gltf", bb.to_array(), json!({}));
    let flags = ["--resolution", "16x16", "--spp", "4", "--seed", "3"];
    let a = render_image(&with_nodes, &dir.path().join("a.exr"), &flags, LIMIT);
    let b = render_image(&plain, &dir.path().join("b.exr"), &flags, LIMIT);
    assert!(a.iter().any(|p| p[0] > 0.0), "the light renders nothing");
    for (i, (p, q)) in a.iter().zip(&b).enumerate() {
        for c in 0..3 {
            // Folding multiplies the light's colour (1 × bb) once; the plain light is bb.
            assert_eq!(p[c].to_bits(), q[c].to_bits(), "pixel {i} channel {c}: {p:?} vs {q:?}");
        }
    }
}

/// The image mean and its standard error over `seeds` renders.
fn mean_over_seeds(path: &Path, dir: &Path, flags: &[&str], seeds: u32) -> (f64, f64) {
    let means: Vec<f64> = (0..seeds)
        .map(|s| {
            let seed = (s + 1).to_string();
            let mut args = flags.to_vec();
            args.extend_from_slice(&["--seed", &seed]);
            let px = render_image(path, &dir.join(format!("m{s}.exr")), &args, LIMIT);
            px.iter().map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0).sum::<f64>() / px.len() as f64
        })
        .collect();
    common::mean_se(&means)
}

/// Light Falloff's Linear output into the Strength of a sphere light (it falls off as 1/d):
/// BDPT and VCM (which take such a light by their camera-side strategies) agree with the path tracer within 5 standard errors of the
/// difference of their means over independent seeds (a false alarm about 6e-7 per pair), and
/// the path tracer's image differs from the light without the tree by far more than that.
#[test]
fn a_varying_tree_renders_the_same_in_every_integrator() {
    let dir = temp_dir();
    let nodes = graph(
        json!([
            {"name": "Falloff", "type": "ShaderNodeLightFalloff",
             "inputs": {"Strength": {"value": 0.25}, "Smooth": {"value": 0.0}}},
            {"name": "Emission", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"value": [1.0, 1.0, 1.0, 1.0]}, "Strength": {"link": [0, "Linear"]}}}
        ]),
        1,
    );
    // A radius (a sphere light): BSDF-sampled rays cross it, weighed by MIS against NEE.
    let path = scene(
        dir.path(),
        "falloff.gltf",
        [1.0, 1.0, 1.0],
        json!({"nodes": nodes, "radius": 0.3, "camera_visible": false}),
    );
    let plain = scene(dir.path(), "plain.gltf", [1.0, 1.0, 1.0], json!({"radius": 0.3, "camera_visible": false}));
    let base = ["--resolution", "16x16", "--spp", "16"];
    let reference = mean_over_seeds(&path, dir.path(), &[&base[..], &["--integrator", "path"]].concat(), 8);
    let without = mean_over_seeds(&plain, dir.path(), &[&base[..], &["--integrator", "path"]].concat(), 8);
    let sigma = (reference.1.powi(2) + without.1.powi(2)).sqrt();
    assert!((reference.0 - without.0).abs() > 20.0 * sigma, "the tree changes nothing: {reference:?} vs {without:?}");
    for integrator in ["bdpt", "vcm"] {
        let m = mean_over_seeds(&path, dir.path(), &[&base[..], &["--integrator", integrator]].concat(), 8);
        let sigma = (reference.1.powi(2) + m.1.powi(2)).sqrt();
        eprintln!("{integrator}: {m:?} vs path {reference:?}");
        assert!((m.0 - reference.0).abs() <= 5.0 * sigma, "{integrator}: {m:?} vs path {reference:?}");
    }
}

/// A malformed IES profile is refused with an error naming the light and the node.
#[test]
fn a_malformed_ies_profile_is_refused_by_name() {
    let dir = temp_dir();
    std::fs::write(dir.path().join("bad.ies"), "IESNA:LM-63-2002\nTILT=NONE\n1 1000 1 4 1 7 2 0 0 0\n").unwrap();
    let nodes = graph(
        json!([
            {"name": "Profile", "type": "ShaderNodeTexIES", "props": {"ies_file": "bad.ies"},
             "inputs": {"Vector": {"value": [0.0, 0.0, 0.0]}, "Strength": {"value": 1.0}}},
            {"name": "Emission", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"value": [1.0, 1.0, 1.0, 1.0]}, "Strength": {"link": [0, "Fac"]}}}
        ]),
        1,
    );
    let path = scene(dir.path(), "bad.gltf", [1.0, 1.0, 1.0], json!({"nodes": nodes}));
    let out = dir.path().join("bad.exr");
    let r = run(&["render", path.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"], LIMIT);
    assert_ne!(r.code, Some(0), "a malformed IES rendered");
    let msg = r.error_message().unwrap_or_else(|| r.stderr.clone());
    for part in ["Bulb", "Profile", "IES", "photometric type"] {
        assert!(msg.contains(part), "the error does not name {part}: {msg}");
    }
    assert!(!r.stderr.contains("panicked"), "{}", r.stderr);
    // A file that is missing is refused too, naming the light and node.
    std::fs::remove_file(dir.path().join("bad.ies")).unwrap();
    let r = run(&["render", path.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"], LIMIT);
    let msg = r.error_message().unwrap_or_else(|| r.stderr.clone());
    assert!(r.code != Some(0) && msg.contains("Bulb") && msg.contains("Profile"), "{msg}");
}
