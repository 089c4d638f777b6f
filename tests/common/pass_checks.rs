//! Reading render passes back for the tests of integrators other than the path tracer
//! (`tests/photon_passes.rs`): every channel by name, the light passes' contributions
//! (Direct and Indirect times their Color, as they were filed) and their sum against
//! Combined.

use super::{render_image, root};
use serde_json::json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Every `--passes` token of a light pass.
pub const LIGHT: &str = "diffuse_direct,diffuse_indirect,diffuse_color,glossy_direct,glossy_indirect,glossy_color,\
transmission_direct,transmission_indirect,transmission_color,volume_direct,volume_indirect,emit,environment";

/// The light passes' contributions by name: Direct/Indirect (times Color), Volume, Emission, Environment.
pub const CONTRIBUTIONS: [&str; 10] = [
    "Diffuse Direct",
    "Diffuse Indirect",
    "Glossy Direct",
    "Glossy Indirect",
    "Transmission Direct",
    "Transmission Indirect",
    "Volume Direct",
    "Volume Indirect",
    "Emission",
    "Environment",
];

/// Every channel of an EXR by name.
pub fn channels(path: &Path) -> BTreeMap<String, Vec<f32>> {
    let image = exr::prelude::read_all_flat_layers_from_file(path).expect("read EXR");
    let layer = &image.layer_data[0];
    layer.channel_data.list.iter().map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect())).collect()
}

/// A bundled scene copied beside its files with Film → Transparent off, so that the world
/// seen directly is in Combined (and in Environment).
pub fn opaque_copy(name: &str, dir: &Path) -> PathBuf {
    let src = root().join("scenes").join(format!("{name}.gltf"));
    let mut doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&src).unwrap()).unwrap();
    for b in doc["buffers"].as_array().unwrap() {
        let uri = b["uri"].as_str().unwrap();
        std::fs::copy(root().join("scenes").join(uri), dir.join(uri)).unwrap();
    }
    for img in doc["images"].as_array().cloned().unwrap_or_default() {
        if let Some(uri) = img["uri"].as_str() {
            std::fs::copy(root().join("scenes").join(uri), dir.join(uri)).unwrap();
        }
    }
    if let Some(w) = doc["scenes"][0]["extensions"]["CAUSTIC_world"]["image"].as_str() {
        std::fs::copy(root().join("scenes").join(w), dir.join(w)).unwrap();
    }
    doc["scenes"][0]["extras"]["caustic"]["transparent"] = json!(false);
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

/// `scene` with the render settings' `light_groups` set to `spec`.
pub fn with_light_groups(scene: &Path, spec: serde_json::Value) {
    let mut doc: serde_json::Value = serde_json::from_slice(&std::fs::read(scene).unwrap()).unwrap();
    doc["scenes"][0]["extras"]["caustic"]["light_groups"] = spec;
    std::fs::write(scene, serde_json::to_vec(&doc).unwrap()).unwrap();
}

/// Channel `c` (0..3) of contribution `pass` at every pixel: Direct and Indirect passes
/// times their Color pass (the binary writes them divided by it, as Blender holds them).
pub fn contribution(ch: &BTreeMap<String, Vec<f32>>, pass: &str, c: usize) -> Vec<f64> {
    let rgb = |p: &str| &ch[&format!("{p}.{}", ["R", "G", "B"][c])];
    let v = rgb(pass);
    match pass.split_once(' ') {
        Some((class @ ("Diffuse" | "Glossy" | "Transmission"), _)) => {
            let col = rgb(&format!("{class} Color"));
            v.iter().zip(col).map(|(a, b)| *a as f64 * *b as f64).collect()
        }
        _ => v.iter().map(|a| *a as f64).collect(),
    }
}

/// The largest difference between Combined and the sum of `parts` (each a list of
/// per-pixel values for channel c, per channel), in units of the rounding bound: every
/// part is a sum of the same f32 contributions as Combined in another order (2^-24
/// relative per addition, a few dozen per path and a few paths per pixel), then a quotient
/// and a product in f32, so 1e-5 of the terms' magnitude bounds it with room, far below
/// any misfiled light.
pub fn worst_recombination(ch: &BTreeMap<String, Vec<f32>>, parts: &[[Vec<f64>; 3]]) -> f64 {
    let mut worst = 0.0f64;
    for c in 0..3 {
        for (i, combined) in ch[&format!("Combined.{}", ["R", "G", "B"][c])].iter().enumerate() {
            let sum: f64 = parts.iter().map(|p| p[c][i]).sum();
            let scale: f64 = parts.iter().map(|p| p[c][i].abs()).sum();
            let tol = 1e-5 * scale.max((*combined as f64).abs()) + 1e-9;
            worst = worst.max((*combined as f64 - sum).abs() / tol);
        }
    }
    worst
}

/// Region means (mean over the region's pixels and the three channels) of each of
/// `passes` (contributions, or `Combined_<group>`), one per seed, rendered with `extra`:
/// `[pass][region][seed]`.
pub fn pass_region_means(
    scene: &Path,
    dir: &Path,
    extra: &[&str],
    seeds: u32,
    regions: &[(String, Vec<usize>)],
    passes: &[String],
    limit: Duration,
) -> Vec<Vec<Vec<f64>>> {
    let mut out = vec![vec![Vec::new(); regions.len()]; passes.len()];
    let exr = dir.join("passes.exr");
    for seed in 0..seeds {
        let mut args: Vec<&str> = extra.to_vec();
        let s = (seed * 7919 + 13).to_string();
        args.extend_from_slice(&["--seed", &s]);
        render_image(scene, &exr, &args, limit);
        let ch = channels(&exr);
        for (p, pass) in passes.iter().enumerate() {
            let rgb: Vec<Vec<f64>> = (0..3).map(|c| contribution(&ch, pass, c)).collect();
            for (k, (_, idx)) in regions.iter().enumerate() {
                let m =
                    idx.iter().map(|&i| rgb.iter().map(|v| v[i]).sum::<f64>() / 3.0).sum::<f64>() / idx.len() as f64;
                out[p][k].push(m);
            }
        }
    }
    out
}
