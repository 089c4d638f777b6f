//! Negative emission (an Emission shader of negative colour or strength, which Cycles keeps:
//! it subtracts light) in every integrator: BDPT, VCM, Jensen's photon mapping and SPPM
//! converge to the path tracer's image region by region. Lights are picked by |power| (as
//! Cycles' `estimate_emission` takes |emission|), and the sign rides in each light
//! subpath's and photon's weight, so every strategy that makes a path sees the same signed
//! emission.
//!
//! The scene: a grey floor and back wall seen from the front (max depth 4) and two emitters
//! hanging over the floor, both in view: "Glow" emits (1, 0.9, 0.8) × 3 and "Dark" a
//! constant (1, 0.7, 0.4) × −1, which darkens the floor under it; a patch low on the back
//! wall emits 3 × x + 0.6 (its x from −0.6 to 0.6: from −1.2 to 2.4, negative over a third
//! of it, a varying emission whose mean is positive, so main's BDPT and photons took it for
//! a light and dropped its negative part while Dark, of power 0, was no light). The test
//! checks the negative emitters matter: the path tracer's image with both at 0 disagrees
//! with the reference in some region, so an integrator dropping them (main's BDPT, VCM and
//! photons took them at 0) would fail.
//!
//! Bounds (`common::agreement`): K seeds per estimate, Welch's test per region, Šidák's
//! split over every comparison of the test (four integrators and the rule check, five
//! regions each). The photon integrators are consistent, not unbiased: their gather radius
//! 0.02 on a scene 4 units across blurs the indirect light at the edges by about r / side
//! of a region's, a tenth of the regions' noise bound (as `tests/linking_integrators.rs`).

mod common;

use caustic::light::emit::Emitters;
use common::agreement::{Seeded, disagreeing, regions, sidak};
use common::{GltfBuilder, look_rotation, quick_render_warnings, temp_dir};
use glam::{DVec3, Vec2};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);
const RES: (usize, usize) = (24, 24);

fn node_material(name: &str, nodes: Value, surface: Value) -> Value {
    json!({"name": name, "doubleSided": true, "extensions": {"CAUSTIC_materials_nodes":
        {"version": 1, "nodes": nodes, "output": {"surface": surface}}}})
}

/// An Emission of a constant colour and strength.
fn emission(name: &str, color: [f32; 3], strength: f32) -> Value {
    node_material(
        name,
        json!([{"name": "Emission", "type": "ShaderNodeEmission",
                "inputs": {"Color": {"value": [color[0], color[1], color[2], 1]}, "Strength": {"value": strength}}}]),
        json!([0, "Emission"]),
    )
}

/// An Emission of strength `scale` × x + `offset`, x the world x of the shading point.
fn signed_by_x(name: &str, scale: f32, offset: f32) -> Value {
    node_material(
        name,
        json!([
            {"name": "Geometry", "type": "ShaderNodeNewGeometry"},
            {"name": "Split", "type": "ShaderNodeSeparateXYZ", "inputs": {"Vector": {"link": [0, "Position"]}}},
            {"name": "Scale", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY_ADD"},
             "inputs": {"Value": {"link": [1, "X"]}, "Value_001": {"value": scale}, "Value_002": {"value": offset}}},
            {"name": "Emission", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"value": [0.9, 0.9, 1, 1]}, "Strength": {"link": [2, "Value"]}}}
        ]),
        json!([3, "Emission"]),
    )
}

/// The scene of the module doc; `negative` false sets the two negative emitters to 0.
fn scene(dir: &Path, negative: bool) -> PathBuf {
    let mut g = GltfBuilder::new();
    g.use_ext("CAUSTIC_materials_nodes");
    let grey = g
        .material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1], "metallicFactor": 0.0},
            "doubleSided": true}));
    let quad = |g: &mut GltfBuilder, p: [[f32; 3]; 4], m: usize| g.mesh(&p, &[0, 1, 2, 0, 2, 3], m);
    quad(&mut g, [[-2.0, -1.0, -2.0], [2.0, -1.0, -2.0], [2.0, -1.0, -6.0], [-2.0, -1.0, -6.0]], grey);
    quad(&mut g, [[-2.0, -1.0, -6.0], [2.0, -1.0, -6.0], [2.0, 2.0, -6.0], [-2.0, 2.0, -6.0]], grey);
    let glow = g.material(emission("Glow", [1.0, 0.9, 0.8], 3.0));
    let dark = g.material(emission("Dark", [1.0, 0.7, 0.4], if negative { -1.0 } else { 0.0 }));
    quad(&mut g, [[-1.5, 0.6, -3.5], [-0.3, 0.6, -3.5], [-0.3, 0.6, -4.7], [-1.5, 0.6, -4.7]], glow);
    quad(&mut g, [[0.3, 0.6, -3.5], [1.5, 0.6, -3.5], [1.5, 0.6, -4.7], [0.3, 0.6, -4.7]], dark);
    let patch = g.material(if negative { signed_by_x("Patch", 3.0, 0.6) } else { emission("Patch", [0.0; 3], 0.0) });
    quad(&mut g, [[-0.6, -0.8, -5.9], [0.6, -0.8, -5.9], [0.6, -0.2, -5.9], [-0.6, -0.2, -5.9]], patch);
    g.camera([0.0, 1.2, 0.0], look_rotation([0.0, -0.35, -1.0]), 1.0);
    g.write(dir, &format!("negative_{negative}.gltf"))
}

/// BDPT, VCM, Jensen and SPPM each agree with the path tracer region by region.
#[test]
fn every_integrator_matches_the_path_tracer_with_negative_emitters() {
    let dir = temp_dir();
    let path = scene(dir.path(), true);
    let regs = regions(RES.0, RES.1);
    let r = format!("{}x{}", RES.0, RES.1);
    let seeded = Seeded::six(dir.path(), &r, "4", &regs, LIMIT);
    let path_tracer = ["--integrator", "path", "--spp", "64"];
    let reference = seeded.means(&path, &path_tracer);
    let alpha = sidak(regs.len() * 5);
    let without = seeded.means(&scene(dir.path(), false), &path_tracer);
    assert!(
        !disagreeing("negative emitters at 0", &regs, &without, &reference, alpha).is_empty(),
        "the negative emitters change nothing"
    );
    let others: [(&str, &[&str]); 4] = [
        ("bdpt", &["--integrator", "bdpt", "--spp", "16"]),
        ("vcm", &["--integrator", "vcm", "--spp", "16", "--vcm-radius", "0.02"]),
        ("photon", &["--integrator", "photon", "--spp", "16", "--photons", "100000", "--max-radius", "0.02"]),
        ("sppm", &["--integrator", "sppm", "--sppm-iterations", "16", "--sppm-radius", "0.02"]),
    ];
    let failed = seeded.disagreeing_others(&path, &reference, &others, alpha);
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}

/// No integrator warns of the negative emitters: every one renders them.
#[test]
fn no_integrator_warns_of_negative_emission() {
    let dir = temp_dir();
    let path = scene(dir.path(), true);
    let out = dir.path().join("w.exr");
    for integrator in ["path", "bdpt", "vcm", "photon", "sppm"] {
        let flags = ["--integrator", integrator, "--sppm-iterations", "1", "--photons", "1000"];
        let w = quick_render_warnings(&path, &out, &flags, LIMIT);
        assert!(!w.iter().any(|w| w.contains("negative") || w.contains("'Dark'")), "{integrator}: {w:?}");
    }
}

/// The photons of a negative emitter carry its light signed, in closed form: a triangle of
/// area A emitting L = (1, 0.5, 0.25) × −2 from both sides is picked by its power
/// |Φ| = 2 π A |L| and its N photons sum to −|Φ| up to rounding (main's summed to 0).
#[test]
fn photons_of_a_negative_emitter_sum_to_its_signed_power() {
    let dir = temp_dir();
    let mut g = GltfBuilder::new();
    g.use_ext("CAUSTIC_materials_nodes");
    let m = g.material(emission("Dark", [1.0, 0.5, 0.25], -2.0));
    g.mesh(&[[0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.5]], &[0, 1, 2], m);
    let path = g.write(dir.path(), "negative_triangle.gltf");
    let scene = caustic::scene::gltf::load(&path).unwrap();
    let em = Emitters::new(&scene);
    let area = 0.25f64;
    let want = DVec3::new(1.0, 0.5, 0.25) * (2.0 * 2.0 * std::f64::consts::PI * area);
    assert_eq!(em.power.len(), 1, "the negative triangle is a light");
    let power = em.power[0].as_dvec3();
    assert!((power - want).abs().max_element() <= 1e-6 * want.max_element(), "power {power:?} vs {want:?}");
    let n = 1u64 << 14;
    let mut sum = DVec3::ZERO;
    for i in 0..n as u32 {
        let mut s = caustic::sampling::PixelSampler::new(3, 0xF07_0001, 0, i);
        let [ul, us, px, py] = s.next_4d();
        let [dx, dy, _, _] = s.next_4d();
        let e = em.emit(&scene, ul, us, Vec2::new(px, py), Vec2::new(dx, dy), n).expect("a photon");
        sum += e.power.as_dvec3();
    }
    // N additions in f64 of f32 values, each of relative error 2⁻²⁴.
    assert!((sum + want).abs().max_element() <= 1e-6 * want.max_element(), "photons {sum:?} vs {:?}", -want);
}
