//! `KHR_materials_diffuse_transmission` in every integrator (`bsdf/pbr/diffuse_transmission.rs`).
//!
//! The analytic case: a white sheet of factor 1 (colour white, roughness 1, IOR 1.5) facing
//! +Z, lit from straight behind by a sun of irradiance E = 1 W/m² (683 lux), seen from the
//! front by an orthographic camera looking down -Z in a black world. The only light reaching
//! the front is the Lambertian transmission: L = f_t(+Z, −Z)·E = (1 − E_layer(1))·E/π, the
//! share the dielectric layer leaves seen from the viewer, over π. E_layer(1) is the BSDF's
//! own layer albedo, itself checked against a quadrature of the layer alone in the BSDF's
//! test (0.9861 there); at normal view the expected pixel is 0.9862/π = 0.3139.
//!
//! The agreement case: a green leaf (factor 0.6, the sample asset's kind of plant) held over a
//! grey floor under a sun, seen from below the leaf's height: the floor under the leaf is lit
//! only through it (photons and BDPT's light subpaths cross it by the lobe), the leaf's
//! underside glows by its transmission. BDPT, VCM, Jensen and SPPM agree with the path tracer
//! region by region (`common::agreement`: K seeds per estimate, Welch's test, Šidák's split);
//! the photon integrators' kernel blurs by at most their radius, 0.02 on a scene 6 units
//! across, a tenth of the regions' noise bound as `tests/linking_integrators.rs` derives. The
//! test first checks that the transmission matters: the same leaf without the extension
//! (opaque) leaves the bounds.

mod common;

use common::agreement::{Seeded, regions, sidak};
use common::{GltfBuilder, look_rotation, render_image, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);

/// The backlit sheet of the module doc.
fn backlit_sheet(dir: &Path) -> PathBuf {
    let mut g = GltfBuilder::new();
    g.use_ext("KHR_materials_diffuse_transmission");
    let sheet = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "doubleSided": true,
        "extensions": {"KHR_materials_diffuse_transmission": {"diffuseTransmissionFactor": 1.0}}
    }));
    let s = 4.0;
    g.mesh(&[[-s, -s, 0.0], [s, -s, 0.0], [s, s, 0.0], [-s, s, 0.0]], &[0, 1, 2, 0, 2, 3], sheet);
    // The sun travels along the node's -Z: turned half a turn about X it travels +Z, from behind.
    g.punctual(json!({"type": "directional", "intensity": 683.0}), [0.0, 0.0, -3.0], [1.0, 0.0, 0.0, 0.0]);
    g.orthographic([0.0, 0.0, 3.0], [0.0, 0.0, 0.0, 1.0], 1.0, 1.0);
    g.write(dir, "backlit.gltf")
}

/// Every integrator renders the backlit sheet at (1 − E_layer(1))/π. The sun is a delta
/// light found by next-event estimation (or BDPT's and VCM's connection to it) with weight 1,
/// light transmitted to the front leaves into the black world, and the orthographic camera
/// cannot be reached by light paths, so every integrator is exact per pixel up to float
/// rounding (1e-5 relative): 0.31390 measured in all five.
#[test]
fn a_backlit_sheet_transmits_the_layers_share_over_pi() {
    use caustic::bsdf::pbr::{PbrBsdf, PbrParams};
    let dir = temp_dir();
    let scene = backlit_sheet(dir.path());
    let b = PbrBsdf::from_params(&PbrParams {
        diffuse_transmission: 1.0,
        diffuse_transmission_color: glam::Vec3::ONE,
        ..PbrParams::opaque(glam::Vec3::ONE, 0.0, 1.0)
    });
    let expected = b.eval(glam::Vec3::Z, -glam::Vec3::Z).x as f64;
    eprintln!("expected {expected:.5} = (1 − E_layer) / π, 1 − E_layer = {:.5}", expected * std::f64::consts::PI);
    assert!((expected * std::f64::consts::PI - 0.9861).abs() < 5e-3, "the layer's share: {expected}");
    for (integrator, extra) in [
        ("path", vec![]),
        ("bdpt", vec![]),
        ("vcm", vec!["--vcm-radius", "0.02"]),
        ("photon", vec!["--photons", "100000"]),
        ("sppm", vec!["--sppm-iterations", "32", "--sppm-radius", "0.05"]),
    ] {
        let mut args = vec!["--integrator", integrator, "--resolution", "16x16", "--spp", "4", "--max-depth", "4"];
        args.extend(extra);
        let px = render_image(&scene, &dir.path().join(format!("{integrator}.exr")), &args, LIMIT);
        let v: Vec<f64> = px.iter().map(|p| p[0] as f64).collect();
        let (mean, se) = common::mean_se(&v);
        let worst = v.iter().map(|x| (x - expected).abs()).fold(0.0, f64::max);
        eprintln!("{integrator}: mean {mean:.5} ± {se:.5}, worst |pixel − expected| {worst:.2e}");
        assert!(worst <= 1e-5 * expected, "{integrator}: a pixel is off {expected} by {worst}");
    }
}

/// The leaf over the floor; `leaf_ext` is the leaf's extensions (the transmission, or none).
fn leaf_scene(dir: &Path, name: &str, leaf_ext: Value) -> PathBuf {
    let mut g = GltfBuilder::new();
    g.use_ext("KHR_materials_diffuse_transmission");
    let leaf = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.5, 0.1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.6},
        "doubleSided": true,
        "extensions": leaf_ext
    }));
    let grey = g
        .material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0.0},
        "doubleSided": true}));
    let s = 3.0;
    g.mesh(&[[-s, 0.0, -s], [s, 0.0, -s], [s, 0.0, s], [-s, 0.0, s]], &[0, 2, 1, 0, 3, 2], grey);
    // The leaf, 1.6 × 1.6, tilted a little, 0.8 above the floor (glTF's y up).
    g.mesh(&[[-0.8, 0.7, -0.8], [0.8, 0.9, -0.8], [0.8, 0.9, 0.8], [-0.8, 0.7, 0.8]], &[0, 2, 1, 0, 3, 2], leaf);
    // A sun from above, a little to the side; a dim grey world lights the rest.
    let q = glam::Quat::from_rotation_x(-1.3);
    g.punctual(json!({"type": "directional", "intensity": 2000.0}), [0.0, 3.0, 0.0], [q.x, q.y, q.z, q.w]);
    g.world(json!({"color": [0.05, 0.05, 0.05]}));
    // From the side, just below the leaf: its underside and the floor under it.
    g.camera([0.0, 0.5, 2.6], look_rotation([0.0, -0.1, -1.0]), 0.9);
    g.write(dir, name)
}

/// The leaf scene `leaf` rendered by BDPT, VCM, Jensen and SPPM agrees with the path tracer
/// region by region; with `opaque` (the leaf without its transmission) the test first checks
/// that the transmission changes the image by more than the test can miss.
fn assert_every_integrator_agrees(dir: &Path, leaf: &Path, opaque: Option<&Path>) {
    let res = (24usize, 24usize);
    let regs = regions(res.0, res.1);
    let r = format!("{}x{}", res.0, res.1);
    let seeded = Seeded::six(dir, &r, "4", &regs, LIMIT);
    let alpha = sidak(regs.len() * 5);
    let path_tracer = ["--integrator", "path", "--spp", "64"];
    let reference = seeded.means(leaf, &path_tracer);
    if let Some(opaque) = opaque {
        let opaque = seeded.means(opaque, &path_tracer);
        seeded.assert_rule_matters("the leaf opaque", &opaque, &reference, alpha);
    }
    let others: [(&str, &[&str]); 4] = [
        ("bdpt", &["--integrator", "bdpt", "--spp", "16"]),
        ("vcm", &["--integrator", "vcm", "--spp", "16", "--vcm-radius", "0.02"]),
        ("photon", &["--integrator", "photon", "--spp", "32", "--photons", "400000", "--max-radius", "0.02"]),
        ("sppm", &["--integrator", "sppm", "--sppm-iterations", "256", "--sppm-radius", "0.02"]),
    ];
    let failed = seeded.disagreeing_others(leaf, &reference, &others, alpha);
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}

#[test]
fn a_leaf_over_a_floor_renders_alike_in_every_integrator() {
    let dir = temp_dir();
    let leaf = leaf_scene(
        dir.path(),
        "leaf.gltf",
        json!({"KHR_materials_diffuse_transmission":
            {"diffuseTransmissionFactor": 0.6, "diffuseTransmissionColorFactor": [0.3, 0.8, 0.1]}}),
    );
    let opaque = leaf_scene(dir.path(), "opaque.gltf", json!({}));
    assert_every_integrator_agrees(dir.path(), &leaf, Some(&opaque));
}

/// The same leaf made in Blender's nodes: Diffuse and Translucent BSDFs mixed by 0.6 (the add-on's
/// `CAUSTIC_materials_nodes`). A Translucent closure is diffuse-class, and the photon maps hold
/// light from the viewer's side only: read there, the light it sends through from behind was
/// lost, and Jensen's and SPPM's leaf and the floor it lights were 0.25–0.9 of the path
/// tracer's (`integrator::photon::lobes`). Every integrator now agrees with the path tracer.
#[test]
fn a_translucent_leaf_renders_alike_in_every_integrator() {
    let dir = temp_dir();
    let leaf = leaf_scene(dir.path(), "translucent.gltf", json!({}));
    // The leaf's material replaced by the node graph (material 0 in `leaf_scene`).
    let mut doc: Value = serde_json::from_slice(&std::fs::read(&leaf).unwrap()).unwrap();
    doc["materials"][0] = json!({"name": "Leaf", "doubleSided": true, "extensions": {"CAUSTIC_materials_nodes": {
        "version": 1,
        "nodes": [
            {"name": "D", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"value": [0.2, 0.5, 0.1, 1]}}},
            {"name": "T", "type": "ShaderNodeBsdfTranslucent", "inputs": {"Color": {"value": [0.3, 0.8, 0.1, 1]}}},
            {"name": "Mix", "type": "ShaderNodeMixShader", "inputs": {"Fac": {"value": 0.6},
                "Shader": {"link": [0, "BSDF"]}, "Shader_001": {"link": [1, "BSDF"]}}}
        ],
        "output": {"surface": [2, "Shader"]}}}});
    doc["extensionsUsed"].as_array_mut().unwrap().push(json!("CAUSTIC_materials_nodes"));
    std::fs::write(&leaf, serde_json::to_vec(&doc).unwrap()).unwrap();
    assert_every_integrator_agrees(dir.path(), &leaf, None);
}

/// With `KHR_materials_volume` the transmitted light enters the volume: a wide slab (a closed
/// box 200 × 200 × T) of factor 1, colour white and no specular layer (specularFactor 0) that
/// absorbs with σa = ln 2 / T inside (attenuationColor 0.5 at attenuationDistance T), lit from
/// straight below by a sun of irradiance E = 1 and seen from above. The bottom face sends
/// E/π into the slab in every direction; light crossing it at cosine μ keeps e^(−τ/μ)
/// (τ = σa T = ln 2), and the top face, which transmits all it gets (factor 1), shows
/// L = (1/π)·2E∫₀¹ e^(−τ/μ) μ dμ = 2E·E₃(τ)/π, E₃ the exponential integral (by quadrature
/// here); the thin slab (no volume) shows E/π. Light reaching the sides travels 100 units:
/// e^(−346), nothing. The path tracer's pixels are independent: its mean is within 5
/// standard errors of L, and far from the thin slab's value (the volume matters).
#[test]
fn light_through_a_volumes_surface_enters_the_volume() {
    let dir = temp_dir();
    let t = 0.2f32;
    let slab = |volume: bool| {
        let mut g = GltfBuilder::new();
        g.use_ext("KHR_materials_diffuse_transmission");
        g.use_ext("KHR_materials_specular");
        let mut ext = json!({"KHR_materials_diffuse_transmission": {"diffuseTransmissionFactor": 1.0},
                             "KHR_materials_specular": {"specularFactor": 0.0}});
        if volume {
            g.use_ext("KHR_materials_volume");
            ext["KHR_materials_volume"] =
                json!({"thicknessFactor": t, "attenuationColor": [0.5, 0.5, 0.5], "attenuationDistance": t});
        }
        let m = g.material(json!({
            "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0},
            "extensions": ext
        }));
        g.cube([-100.0, -100.0, 0.0], [100.0, 100.0, t], m);
        g.punctual(json!({"type": "directional", "intensity": 683.0}), [0.0, 0.0, -3.0], [1.0, 0.0, 0.0, 0.0]);
        g.orthographic([0.0, 0.0, 3.0], [0.0, 0.0, 0.0, 1.0], 1.0, 1.0);
        g.write(dir.path(), if volume { "thick.gltf" } else { "thin.gltf" })
    };
    let tau = std::f64::consts::LN_2;
    // E₃(τ) = ∫₀¹ e^(−τ/μ) μ dμ by the midpoint rule on 10⁵ cells (error ~1e-10).
    let n = 100_000;
    let e3: f64 = (0..n).map(|i| (i as f64 + 0.5) / n as f64).map(|mu| (-tau / mu).exp() * mu).sum::<f64>() / n as f64;
    let expected = 2.0 * e3 / std::f64::consts::PI;
    for (volume, want) in [(false, 1.0 / std::f64::consts::PI), (true, expected)] {
        let scene = slab(volume);
        let args = ["--integrator", "path", "--resolution", "32x32", "--spp", "64", "--max-depth", "8"];
        let px = render_image(&scene, &dir.path().join("slab.exr"), &args, LIMIT);
        let v: Vec<f64> = px.iter().map(|p| p[0] as f64).collect();
        let (mean, se) = common::mean_se(&v);
        eprintln!("slab, volume {volume}: mean {mean:.5} ± {se:.5}, expected {want:.5}");
        assert!((mean - want).abs() <= 5.0 * se + 1e-5 * want, "volume {volume}: {mean} vs {want}");
    }
    assert!(expected < 0.6 / std::f64::consts::PI, "the volume absorbs: {expected}");
}
