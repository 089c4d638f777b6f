//! Hair BSDFs on meshes (`shader::mesh_hair`), as Cycles shades them, in every integrator.
//!
//! The analytic case: an open square of the Hair BSDF's Transmission, facing +Z, lit from
//! straight behind by a sun of irradiance E = 1 W/m² and seen from the front by an
//! orthographic camera over a black world, one bounce. On a triangle Cycles' fibre runs along
//! its `dPdv` (in its plane) with no Offset, so both the view and the light are across the
//! fibre (θr = θi = 0) and opposite (φ = π): the lobe's value is its colour times
//! θ_pdf · φ_pdf = c · r1 / (2 r1² (a − b)) · 1 / (c_TT r2), with a = −b = atan(π/4 / r1) and
//! c_TT = 2 atan(π/2 / r2) (`bsdf_hair_transmission_eval`). The light is found by a shadow
//! ray that leaves into the square's back: a ray offset to the wrong side would meet the
//! triangle it leaves and the square would be black (the render before this change was black
//! for another reason: hair closures were not shaded on meshes).
//!
//! The agreement case: a closed box of the Principled Hair BSDF (rays leaving it inward meet
//! its far faces, which shade as hair again), a square of the Hair BSDF's Reflection and
//! Transmission, and a box mixing a Principled Hair BSDF with a Diffuse one (one or the other
//! at each point, by weight) on a grey floor under a sun and a dim world. BDPT, VCM, Jensen
//! and SPPM agree with the path tracer region by region (`common::agreement`); the test first
//! checks that the hair shading matters (the same boxes black, as before, leave the bounds).
//! Cycles cuts a hair closure's evaluation, not its sampling (`bsdf::hair::BumpCut`): the path
//! tracer weighs the two by MIS as Cycles does, the other integrators by their own strategies,
//! so they agree up to that blend (the largest gap measured, Jensen's and SPPM's quadrant 01,
//! 0.95 of the path tracer, within its bound).

mod common;

use common::agreement::{Seeded, regions, sidak};
use common::{GltfBuilder, look_rotation, render_image, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);

/// A node-graph material of `nodes` whose surface is node `out`'s output `socket`.
fn graph(g: &mut GltfBuilder, name: &str, nodes: Value, out: usize, socket: &str) -> usize {
    g.use_ext("CAUSTIC_materials_nodes");
    g.material(json!({"name": name, "doubleSided": true, "extensions": {"CAUSTIC_materials_nodes":
        {"version": 1, "nodes": nodes, "output": {"surface": [out, socket]}}}}))
}

/// Every integrator renders the backlit square of the Hair BSDF's Transmission at the
/// lobe's value (module doc). The sun is a delta light reached by next-event estimation (or a
/// connection) with weight 1, light transmitted to the front leaves into the black world, and
/// the orthographic camera cannot be reached by light paths: every integrator is exact per
/// pixel up to float rounding (1e-4 relative allows the lobe's atan and tan in f32).
#[test]
fn a_backlit_hair_transmission_square_lets_the_lobe_through() {
    let dir = temp_dir();
    let d = dir.path();
    let (c, r1, r2) = ([0.8f32, 0.5, 0.3], 0.3f32, 0.4f32);
    let mut g = GltfBuilder::new();
    let nodes = json!([{"name": "T", "type": "ShaderNodeBsdfHair", "props": {"component": "Transmission"},
        "inputs": {"Color": {"value": [c[0], c[1], c[2], 1.0]}, "RoughnessU": {"value": r1},
                   "RoughnessV": {"value": r2}, "Offset": {"value": 0.2}}}]);
    let m = graph(&mut g, "Transmission", nodes, 0, "BSDF");
    let s = 4.0;
    g.mesh(&[[-s, -s, 0.0], [s, -s, 0.0], [s, s, 0.0], [-s, s, 0.0]], &[0, 1, 2, 0, 2, 3], m);
    // The sun travels along the node's −Z: turned half a turn about X it travels +Z, from behind.
    g.punctual(json!({"type": "directional", "intensity": 683.0}), [0.0, 0.0, -3.0], [1.0, 0.0, 0.0, 0.0]);
    g.orthographic([0.0, 0.0, 3.0], [0.0, 0.0, 0.0, 1.0], 1.0, 1.0);
    let scene = g.write(d, "backlit.gltf");
    let a = (std::f64::consts::FRAC_PI_4 / r1 as f64).atan();
    let theta_pdf = r1 as f64 / (2.0 * (r1 * r1) as f64 * (2.0 * a));
    let c_tt = 2.0 * (std::f64::consts::FRAC_PI_2 / r2 as f64).atan();
    let phi_pdf = 1.0 / (c_tt * r2 as f64);
    let expected = c.map(|c| c as f64 * theta_pdf * phi_pdf);
    eprintln!("expected {expected:.5?}");
    for (integrator, extra) in [
        ("path", vec![]),
        ("bdpt", vec![]),
        ("vcm", vec!["--vcm-radius", "0.02"]),
        ("photon", vec!["--photons", "100000"]),
        ("sppm", vec!["--sppm-iterations", "8", "--sppm-radius", "0.05"]),
    ] {
        let mut args = vec!["--integrator", integrator, "--resolution", "16x16", "--spp", "4", "--max-depth", "1"];
        args.extend(extra);
        let px = render_image(&scene, &d.join(format!("{integrator}.exr")), &args, LIMIT);
        for k in 0..3 {
            let worst = px.iter().map(|p| (p[k] as f64 - expected[k]).abs()).fold(0.0, f64::max);
            eprintln!("{integrator} channel {k}: worst |pixel − expected| {worst:.2e}");
            assert!(worst <= 1e-4 * expected[k], "{integrator}: channel {k} off {} by {worst}", expected[k]);
        }
    }
}

/// The agreement scene of the module doc; `black` replaces the hair materials by black ones.
fn hair_scene(dir: &Path, name: &str, black: bool) -> PathBuf {
    let mut g = GltfBuilder::new();
    let grey = g
        .material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0.0},
        "doubleSided": true}));
    let black_diffuse = json!([{"name": "D", "type": "ShaderNodeBsdfDiffuse",
        "inputs": {"Color": {"value": [0.0, 0.0, 0.0, 1.0]}}}]);
    let principled = if black {
        graph(&mut g, "Fur", black_diffuse.clone(), 0, "BSDF")
    } else {
        let nodes = json!([{"name": "H", "type": "ShaderNodeBsdfHairPrincipled",
            "props": {"parametrization": "MELANIN"},
            "inputs": {"Melanin": {"value": 0.3}, "Roughness": {"value": 0.35}, "Radial Roughness": {"value": 0.4}}}]);
        graph(&mut g, "Fur", nodes, 0, "BSDF")
    };
    let lobes = if black {
        graph(&mut g, "Lobes", black_diffuse.clone(), 0, "BSDF")
    } else {
        let lobe = |component: &str, colour: [f32; 4]| {
            json!({"name": component, "type": "ShaderNodeBsdfHair", "props": {"component": component},
                "inputs": {"Color": {"value": colour}, "RoughnessU": {"value": 0.3}, "RoughnessV": {"value": 0.4}}})
        };
        let nodes = json!([lobe("Reflection", [0.6, 0.5, 0.3, 1.0]), lobe("Transmission", [0.3, 0.5, 0.7, 1.0]),
            {"name": "Add", "type": "ShaderNodeAddShader",
             "inputs": {"Shader": {"link": [0, "BSDF"]}, "Shader_001": {"link": [1, "BSDF"]}}}]);
        graph(&mut g, "Lobes", nodes, 2, "Shader")
    };
    let mixed = if black {
        graph(&mut g, "Mixed", black_diffuse, 0, "BSDF")
    } else {
        let nodes = json!([
            {"name": "H", "type": "ShaderNodeBsdfHairPrincipled", "props": {"parametrization": "COLOR"},
             "inputs": {"Color": {"value": [0.7, 0.3, 0.1, 1.0]}}},
            {"name": "D", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"value": [0.2, 0.4, 0.8, 1.0]}}},
            {"name": "Mix", "type": "ShaderNodeMixShader", "inputs": {"Fac": {"value": 0.4},
                "Shader": {"link": [0, "BSDF"]}, "Shader_001": {"link": [1, "BSDF"]}}}]);
        graph(&mut g, "Mixed", nodes, 2, "Shader")
    };
    let s = 3.0;
    g.mesh(&[[-s, 0.0, -s], [s, 0.0, -s], [s, 0.0, s], [-s, 0.0, s]], &[0, 2, 1, 0, 3, 2], grey);
    g.cube([-1.4, 0.0, -0.6], [-0.4, 1.0, 0.4], principled);
    // The square stands upright, turned a little toward the sun.
    g.mesh(&[[-0.2, 0.0, -0.3], [0.5, 0.0, 0.1], [0.5, 1.2, 0.1], [-0.2, 1.2, -0.3]], &[0, 1, 2, 0, 2, 3], lobes);
    g.cube([0.7, 0.0, -0.5], [1.5, 0.8, 0.3], mixed);
    let q = glam::Quat::from_rotation_x(-1.0) * glam::Quat::from_rotation_y(0.4);
    g.punctual(json!({"type": "directional", "intensity": 2000.0}), [0.0, 3.0, 0.0], [q.x, q.y, q.z, q.w]);
    g.world(json!({"color": [0.05, 0.05, 0.05]}));
    g.camera([0.0, 1.6, 3.6], look_rotation([0.0, -0.35, -1.0]), 0.75);
    g.write(dir, name)
}

#[test]
fn hair_on_meshes_renders_alike_in_every_integrator() {
    let dir = temp_dir();
    let d = dir.path();
    let scene = hair_scene(d, "hair.gltf", false);
    let black = hair_scene(d, "black.gltf", true);
    let res = (24usize, 24usize);
    let regs = regions(res.0, res.1);
    let r = format!("{}x{}", res.0, res.1);
    let seeded = Seeded::six(d, &r, "4", &regs, LIMIT);
    let alpha = sidak(regs.len() * 5);
    let path_tracer = ["--integrator", "path", "--spp", "64"];
    let reference = seeded.means(&scene, &path_tracer);
    let before = seeded.means(&black, &path_tracer);
    seeded.assert_rule_matters("the hair meshes black", &before, &reference, alpha);
    let others: [(&str, &[&str]); 4] = [
        ("bdpt", &["--integrator", "bdpt", "--spp", "16"]),
        ("vcm", &["--integrator", "vcm", "--spp", "16", "--vcm-radius", "0.02"]),
        ("photon", &["--integrator", "photon", "--spp", "32", "--photons", "400000", "--max-radius", "0.02"]),
        ("sppm", &["--integrator", "sppm", "--sppm-iterations", "256", "--sppm-radius", "0.02"]),
    ];
    let failed = seeded.disagreeing_others(&scene, &reference, &others, alpha);
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}
