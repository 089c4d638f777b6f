//! Denoising (`--denoise`) with Intel Open Image Denoise, loaded from `$CAUSTIC_OIDN` or the
//! copy in the venv's bpy wheel (`scripts/setup_python.sh` installs it; CI has it).

mod common;

use common::*;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(180);

/// The OIDN library to test with, or None (the tests then say why they skip).
fn library() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("CAUSTIC_OIDN").filter(|p| !p.is_empty()) {
        return Some(PathBuf::from(p));
    }
    let venv = root().join(".venv/lib/python3.11/site-packages/bpy/lib/libOpenImageDenoise.so.2");
    venv.exists().then_some(venv)
}

/// A flat-lit scene: a white diffuse plane filling the view under a large square area
/// light close in front of it (hidden from the camera), with a small box casting a soft
/// shadow: smooth everywhere, noisy at few samples.
fn flat_lit(dir: &Path) -> PathBuf {
    let mut g = GltfBuilder::new();
    let white = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1],
        "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
    g.mesh(&[[-3.0, -3.0, -2.0], [3.0, -3.0, -2.0], [3.0, 3.0, -2.0], [-3.0, 3.0, -2.0]], &[0, 1, 2, 0, 2, 3], white);
    g.cube([-0.3, -0.3, -2.0], [0.3, 0.3, -1.7], white);
    g.use_ext("CAUSTIC_lights_area");
    g.node(json!({"translation": [0.0, 0.0, -1.0],
        "extensions": {"CAUSTIC_lights_area": {"shape": "square", "size": [2.0, 2.0], "power": 40.0,
            "color": [1, 1, 1], "camera_visible": false}}}));
    g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 1.2);
    g.settings(json!({"transparent": false, "resolution": [64, 64]}));
    g.write(dir, "flat_lit.gltf")
}

/// One channel of an EXR as floats.
fn channel(path: &Path, name: &str) -> Vec<f32> {
    let image = exr::prelude::read_all_flat_layers_from_file(path).expect("read EXR");
    let c = image.layer_data[0].channel_data.list.iter().find(|c| c.name.to_string() == name);
    c.unwrap_or_else(|| panic!("no channel {name}")).sample_data.values_as_f32().collect()
}

/// Root-mean-square difference over R, G and B.
fn rmse(path: &Path, prefix: &str, reference: &[Vec<f32>]) -> f64 {
    let mut sum = 0.0;
    let mut n = 0.0;
    for (c, r) in ["R", "G", "B"].iter().zip(reference) {
        for (a, b) in channel(path, &format!("{prefix}.{c}")).iter().zip(r) {
            sum += ((a - b) as f64).powi(2);
            n += 1.0;
        }
    }
    (sum / n).sqrt()
}

#[test]
fn denoising_lowers_the_error_and_keeps_the_noisy_image() {
    let Some(lib) = library() else {
        // scripts/test.sh installs bpy before the Rust tests: on CI a missing library is a
        // broken set-up, not a reason to skip.
        assert!(std::env::var_os("CI").is_none(), "CI has no Open Image Denoise: bpy's copy is missing");
        eprintln!("skipped: no Open Image Denoise (set CAUSTIC_OIDN or run scripts/setup_python.sh for bpy's copy)");
        return;
    };
    let dir = temp_dir();
    let scene = flat_lit(dir.path());
    let lib = lib.to_str().unwrap();
    let noisy = dir.path().join("n.exr");
    let denoised = dir.path().join("d.exr");
    let reference = dir.path().join("r.exr");
    render_image(&scene, &noisy, &["--spp", "4"], LIMIT);
    render_image(&scene, &denoised, &["--spp", "4", "--denoise", "--oidn", lib], LIMIT);
    render_image(&scene, &reference, &["--spp", "2048", "--seed", "9"], LIMIT);
    let r: Vec<Vec<f32>> = ["R", "G", "B"].iter().map(|c| channel(&reference, &format!("Combined.{c}"))).collect();
    // The noisy image beside the denoised one is the plain render, bit for bit.
    for c in ["R", "G", "B", "A"] {
        let plain = channel(&noisy, &format!("Combined.{c}"));
        let kept = channel(&denoised, &format!("Noisy Image.{c}"));
        assert!(plain.iter().zip(&kept).all(|(a, b)| a.to_bits() == b.to_bits()), "Noisy Image.{c}");
    }
    assert_eq!(channel(&noisy, "Combined.A"), channel(&denoised, "Combined.A"), "alpha is kept");
    let before = rmse(&noisy, "Combined", &r);
    let after = rmse(&denoised, "Combined", &r);
    eprintln!("RMSE against the reference: {before} noisy, {after} denoised");
    // The reference's own noise: 2048 samples against 4, so its error is √(4/2048) ≈ 4 % of
    // the noisy image's; a denoiser that removes nothing cannot pass a factor of 2.
    assert!(after < 0.5 * before, "RMSE {before} before denoising, {after} after");
}

/// A render that writes Combined alone (the add-on's default `--passes none`) skips the
/// normal and albedo sums, except for the denoiser: it must get the same guides as a render
/// that writes them, so the denoised image is the same bit for bit.
#[test]
fn denoising_keeps_its_guides_without_their_passes() {
    let Some(lib) = library() else {
        assert!(std::env::var_os("CI").is_none(), "CI has no Open Image Denoise: bpy's copy is missing");
        eprintln!("skipped: no Open Image Denoise (set CAUSTIC_OIDN or run scripts/setup_python.sh for bpy's copy)");
        return;
    };
    let dir = temp_dir();
    let scene = flat_lit(dir.path());
    let lib = lib.to_str().unwrap();
    let with_passes = dir.path().join("w.exr");
    let combined_only = dir.path().join("c.exr");
    render_image(&scene, &with_passes, &["--spp", "4", "--denoise", "--oidn", lib], LIMIT);
    render_image(&scene, &combined_only, &["--spp", "4", "--denoise", "--oidn", lib, "--passes", "none"], LIMIT);
    for c in ["R", "G", "B", "A"] {
        let a = channel(&with_passes, &format!("Combined.{c}"));
        let b = channel(&combined_only, &format!("Combined.{c}"));
        assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()), "denoised Combined.{c} differs");
    }
}

#[test]
fn denoising_without_the_library_is_refused_before_rendering() {
    let dir = temp_dir();
    let scene = flat_lit(dir.path());
    let out = dir.path().join("o.exr");
    let missing = dir.path().join("nowhere");
    let (s, o, m) = (scene.to_str().unwrap(), out.to_str().unwrap(), missing.to_str().unwrap());
    let r = run(&["render", s, "-o", o, "--progress", "json", "--spp", "1", "--denoise", "--oidn", m], LIMIT);
    assert_eq!(r.code, Some(2), "{}", r.stderr);
    let msg = r.error_message().unwrap();
    assert!(msg.contains("Open Image Denoise") && msg.contains("nowhere"), "{msg}");
    assert!(!r.stderr.contains("\"rendering\""), "it rendered before failing: {}", r.stderr);
    assert!(!out.exists());
    let r = run(&["render", s, "-o", o, "--progress", "json", "--spp", "1", "--denoise", "--chunk"], LIMIT);
    assert_eq!(r.code, Some(2), "{}", r.stderr);
    assert!(!out.exists());
}
