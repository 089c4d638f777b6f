//! Hair and curves (`CAUSTIC_curves`) in scenes whose answer is known without rendering.
//!
//! Horizontal strands of radius r float at height h = 0.5 over a white diffuse floor, seen
//! straight down by an orthographic camera whose frame (y in [-1, 1]) holds exactly eight
//! periods P = 0.25 of them (one more strand beyond each edge keeps the pattern periodic
//! there); a sun tilted by θ (tan θ = 1/4) throws each strand's shadow h tan θ = P/2 aside,
//! midway between strands, so that the frame's edges cut two half shadows. The strands are black with no
//! specular, so a pixel shows either the lit floor (one value, exact: a delta light and one
//! bounce) or 0: the image's mean over the lit value is the lit fraction of the frame,
//! 1 − 2r/P (strands seen) − 2r/(P cos θ) (their shadows, widened by the slant).

mod common;

use common::{GltfBuilder, render_image, run, temp_dir};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(180);
const PERIOD: f32 = 0.25;
const RADIUS: f32 = 0.025;
const HEIGHT: f32 = 0.5;

/// The scene; each strand is four control points along x (three segments, joints included).
fn strands_scene(dir: &Path, name: &str) -> PathBuf {
    let mut g = GltfBuilder::new();
    let white = g
        .material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0},
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}}));
    let black = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0},
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}}));
    g.use_ext("KHR_materials_specular");
    g.mesh(&[[-5.0, -5.0, 0.0], [5.0, -5.0, 0.0], [5.0, 5.0, 0.0], [-5.0, 5.0, 0.0]], &[0, 1, 2, 0, 2, 3], white);
    let (mut points, mut radii, mut counts) = (Vec::new(), Vec::new(), Vec::new());
    for k in -1..9 {
        let y = -1.0 + PERIOD * (k as f32 + 0.5);
        for x in [-2.0f32, -0.7, 0.4, 2.0] {
            points.push([x, y, HEIGHT]);
            radii.push(RADIUS);
        }
        counts.push(4);
    }
    g.curves("strands", black, &points, &radii, &counts);
    // The sun travels along the node's -Z turned by θ about x: (0, -sin θ, -cos θ).
    let theta = 0.25f32.atan();
    let q = glam::Quat::from_rotation_x(theta);
    g.punctual(json!({"type": "directional", "intensity": 683.0}), [0.0, 0.0, 3.0], [q.x, q.y, q.z, q.w]);
    g.orthographic([0.0, 0.0, 3.0], [0.0, 0.0, 0.0, 1.0], 1.0, 1.0);
    g.write(dir, name)
}

/// The lit fraction of the frame (see the module's comment) with each integrator. The floor's
/// lit value is the brightest pixel's (a wholly lit pixel is exact). Partly covered pixels
/// are estimated from 64 stratified samples: at most 4 × 8 × 64 edge pixels each off by at
/// most ~1/64 of their value with independent signs, so the mean over 64² pixels is off by
/// about sqrt(2048) / 64 / 4096 = 1.7e-4; 2e-3 is over ten times that. SPPM's direct light
/// is a density estimate blurred over its gather radius at the 32 shadow edges, which moves
/// light symmetrically across each edge: its bound is the photon noise of its estimate,
/// taken as 2 %.
#[test]
fn strands_and_their_shadows_cover_their_width_in_every_integrator() {
    let dir = temp_dir();
    let d = dir.path();
    let scene = strands_scene(d, "strands.gltf");
    let cos = 1.0 / (1.0f64 + 1.0 / 16.0).sqrt();
    let c = 2.0 * RADIUS as f64 / PERIOD as f64;
    let expected = 1.0 - c - c / cos;
    for (integrator, tol, extra) in [
        ("path", 2e-3, vec![]),
        ("bdpt", 2e-3, vec![]),
        ("photon", 2e-3, vec![]),
        ("sppm", 2e-2, vec!["--sppm-iterations", "64", "--sppm-radius", "0.02"]),
    ] {
        let mut args = vec![
            "--resolution",
            "64x64",
            "--spp",
            "64",
            "--filter",
            "box",
            "--filter-width",
            "1",
            "--max-depth",
            "1",
            "--integrator",
            integrator,
        ];
        args.extend(extra);
        let px = render_image(&scene, &d.join(format!("{integrator}.exr")), &args, LIMIT);
        let lit = px.iter().map(|p| p[0] as f64).fold(0.0, f64::max);
        let mean = px.iter().map(|p| p[0] as f64).sum::<f64>() / px.len() as f64;
        let fraction = mean / lit;
        eprintln!("{integrator}: lit fraction {fraction:.5}, expected {expected:.5}");
        assert!(lit > 0.1, "{integrator}: the floor is lit ({lit})");
        assert!((fraction - expected).abs() < tol, "{integrator}: lit fraction {fraction}, expected {expected}");
        // Every pixel is covered: alpha 1 (the floor or a strand).
        assert!(px.iter().all(|p| p[3] == 1.0));
    }
}

/// A scene of strands only (no triangle at all) renders: the black strands of the scene
/// above, without the floor and the sun, against a white world of radiance 1 seen straight
/// down on an opaque film. Each pixel shows the world (1) or a strand (0: black, no specular),
/// so the image's mean is the uncovered fraction 1 − 2r/P, within the 2e-3 bound of
/// the edge pixels derived above; the same drawn as ribbons (`"shape": "ribbon"`), which
/// face the ray as wide as the strand.
#[test]
fn a_scene_of_strands_only_renders() {
    let dir = temp_dir();
    let d = dir.path();
    let mut g = GltfBuilder::new();
    let black = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0},
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}}));
    g.use_ext("KHR_materials_specular");
    let (mut points, mut radii, mut counts) = (Vec::new(), Vec::new(), Vec::new());
    for k in -1..9 {
        let y = -1.0 + PERIOD * (k as f32 + 0.5);
        for x in [-2.0f32, -0.7, 0.4, 2.0] {
            points.push([x, y, HEIGHT]);
            radii.push(RADIUS);
        }
        counts.push(4);
    }
    g.curves("strands", black, &points, &radii, &counts);
    g.world(json!({"color": [1.0, 1.0, 1.0]}));
    // An opaque film: the world seen directly keeps its colour.
    g.settings(json!({"transparent": false}));
    g.orthographic([0.0, 0.0, 3.0], [0.0, 0.0, 0.0, 1.0], 1.0, 1.0);
    let scene = g.write(d, "strands_only.gltf");
    let mut doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&scene).unwrap()).unwrap();
    doc["extensions"]["CAUSTIC_curves"]["objects"][0]["shape"] = json!("ribbon");
    let ribbons = d.join("ribbons_only.gltf");
    std::fs::write(&ribbons, serde_json::to_vec(&doc).unwrap()).unwrap();
    let args = ["--resolution", "64x64", "--spp", "64", "--filter", "box", "--filter-width", "1", "--max-depth", "2"];
    for (scene, shape) in [(scene, "round"), (ribbons, "ribbon")] {
        let px = render_image(&scene, &d.join(format!("{shape}.exr")), &args, LIMIT);
        let mean = px.iter().map(|p| p[0] as f64).sum::<f64>() / px.len() as f64;
        let expected = 1.0 - 2.0 * RADIUS as f64 / PERIOD as f64;
        assert!((mean - expected).abs() < 2e-3, "{shape}: uncovered fraction {mean}, expected {expected}");
    }
}

/// Bad strands are refused with exit 3 and a message naming the object and the fault.
#[test]
fn bad_strands_are_refused_by_name() {
    let dir = temp_dir();
    let d = dir.path();
    let scene = strands_scene(d, "good.gltf");
    let doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&scene).unwrap()).unwrap();
    let render = |doc: &serde_json::Value, name: &str| {
        let path = d.join(name);
        std::fs::write(&path, serde_json::to_vec(doc).unwrap()).unwrap();
        let out = d.join("bad.exr");
        run(
            &["render", path.to_str().unwrap(), "-o", out.to_str().unwrap(), "--spp", "1", "--resolution", "8x8"],
            LIMIT,
        )
    };
    let ok = render(&doc, "ok.gltf");
    assert_eq!(ok.code, Some(0), "{}", ok.stderr);
    // The object's accessors: points, radii, counts.
    let obj = &doc["extensions"]["CAUSTIC_curves"]["objects"][0];
    let (points, radii, counts) =
        (obj["points"].as_u64().unwrap(), obj["radii"].as_u64().unwrap(), obj["counts"].as_u64().unwrap());
    let accessor_view = |a: u64| doc["accessors"][a as usize]["bufferView"].as_u64().unwrap() as usize;
    // Bytes of the data-URI buffer, patched and written back.
    let patch = |view: usize, at: usize, bytes: [u8; 4], name: &str| {
        use base64::Engine;
        let mut doc = doc.clone();
        let uri = doc["buffers"][0]["uri"].as_str().unwrap().to_string();
        let (head, b64) = uri.split_once(',').unwrap();
        let mut buf = base64::engine::general_purpose::STANDARD.decode(b64).unwrap();
        let offset = doc["bufferViews"][view]["byteOffset"].as_u64().unwrap() as usize + at;
        buf[offset..offset + 4].copy_from_slice(&bytes);
        doc["buffers"][0]["uri"] = json!(format!("{head},{}", base64::engine::general_purpose::STANDARD.encode(&buf)));
        render(&doc, name)
    };
    let cases = [
        (patch(accessor_view(points), 4, f32::NAN.to_le_bytes(), "nan.gltf"), "point 0 is not finite"),
        (patch(accessor_view(radii), 8, (-0.1f32).to_le_bytes(), "negative.gltf"), "point 2 has radius -0.1"),
        (patch(accessor_view(counts), 0, 9u32.to_le_bytes(), "counts.gltf"), "points"),
        (patch(accessor_view(counts), 4, 1u32.to_le_bytes(), "short.gltf"), "strand 1 has 1 point"),
    ];
    for (r, what) in cases {
        assert_eq!(r.code, Some(3), "{}", r.stderr);
        assert!(r.stderr.contains("curves object 'strands'") && r.stderr.contains(what), "{what}: {}", r.stderr);
    }
    let mut bad = doc.clone();
    bad["extensions"]["CAUSTIC_curves"]["objects"][0]["material"] = json!(99);
    let r = render(&bad, "material.gltf");
    assert_eq!(r.code, Some(3));
    assert!(r.stderr.contains("curves object 'strands': material 99 does not exist"), "{}", r.stderr);
}
