//! Adaptive sampling (`--noise-threshold`): a scene whose left half is flat (an unlit
//! surface: every sample of a pixel is the same) and whose right half is noisy (a diffuse
//! surface under a large area light, sampled by next-event estimation).

mod common;

use common::*;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Duration;

const W: u32 = 48;
const H: u32 = 32;
const LIMIT: Duration = Duration::from_secs(120);

/// The half-flat, half-noisy scene: a plane at z = -2 filling the view, its left half
/// unlit grey, its right half diffuse white under a 1.5 m square area light hidden from the
/// camera, 0.6 m in front of the plane (so that the light's solid angle, and with it each
/// sample's value, varies a lot).
fn half_flat(dir: &Path) -> PathBuf {
    let mut g = GltfBuilder::new();
    g.use_ext("KHR_materials_unlit");
    let flat = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.4, 0.4, 0.4, 1]},
        "extensions": {"KHR_materials_unlit": {}}}));
    let diffuse = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1],
        "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
    g.mesh(&[[-3.0, -3.0, -2.0], [0.0, -3.0, -2.0], [0.0, 3.0, -2.0], [-3.0, 3.0, -2.0]], &[0, 1, 2, 0, 2, 3], flat);
    g.mesh(&[[0.0, -3.0, -2.0], [3.0, -3.0, -2.0], [3.0, 3.0, -2.0], [0.0, 3.0, -2.0]], &[0, 1, 2, 0, 2, 3], diffuse);
    g.use_ext("CAUSTIC_lights_area");
    g.node(json!({"translation": [0.9, 0.0, -1.4],
        "extensions": {"CAUSTIC_lights_area": {"shape": "square", "size": [1.5, 1.5], "power": 30.0,
            "color": [1, 1, 1], "camera_visible": false}}}));
    // The camera's 90° view at distance 2 spans x in [-2, 2]: the seam is the middle column.
    g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], std::f32::consts::FRAC_PI_2);
    g.settings(json!({"transparent": false, "resolution": [W, H]}));
    g.write(dir, "half_flat.gltf")
}

/// One channel as floats.
fn channel(path: &Path, name: &str) -> Vec<f32> {
    let c = exr_channel_bits(path).into_iter().find(|c| c.0 == name).unwrap_or_else(|| panic!("no channel {name}"));
    c.1.into_iter().map(f32::from_bits).collect()
}

/// Renders `scene` with `extra` flags into `dir/name`, asserting success; returns the path.
fn render(scene: &Path, dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let out = dir.join(name);
    render_image(scene, &out, extra, LIMIT);
    out
}

/// Pixels (x, y) whose 3 px filter window and the 3×3 dilation around it stay on one side
/// of the seam: the flat ones left of it, the noisy ones right of it.
fn is_flat(x: u32) -> bool {
    x + 4 < W / 2
}
fn is_noisy(x: u32) -> bool {
    x >= W / 2 + 4
}

#[test]
fn sample_count_pass_shows_the_flat_half_stopping_at_the_first_test() {
    let dir = temp_dir();
    let scene = half_flat(dir.path());
    // Min samples 16: the first test is after 32 samples (Cycles tests after the 0-based
    // index N - 1 when it exceeds the minimum and N is a multiple of the step of 16).
    let out =
        render(&scene, dir.path(), "a.exr", &["--spp", "512", "--noise-threshold", "0.01", "--min-samples", "16"]);
    let counts = channel(&out, "Debug Sample Count.X");
    let (mut flat, mut noisy) = (Vec::new(), Vec::new());
    for y in 0..H {
        for x in 0..W {
            let n = counts[(y * W + x) as usize];
            if is_flat(x) {
                flat.push(n);
            } else if is_noisy(x) {
                noisy.push(n);
            }
        }
    }
    // Flat pixels: every sample equal, so both halves agree exactly and the error is 0.
    assert!(flat.iter().all(|&n| n == 32.0), "flat pixels took {:?}", flat);
    // Noisy pixels keep sampling well past the first test.
    let mean_noisy = noisy.iter().sum::<f32>() / noisy.len() as f32;
    assert!(mean_noisy > 4.0 * 32.0, "noisy pixels took {mean_noisy} samples on average");
    assert!(noisy.iter().all(|&n| n > 32.0), "a noisy pixel stopped at the first test: {noisy:?}");
}

#[test]
fn adaptive_image_is_unbiased() {
    let dir = temp_dir();
    let scene = half_flat(dir.path());
    let adaptive =
        render(&scene, dir.path(), "a.exr", &["--spp", "256", "--noise-threshold", "0.02", "--min-samples", "16"]);
    // The reference: another seed, every pixel 1024 samples.
    let reference = render(&scene, dir.path(), "r.exr", &["--spp", "1024", "--seed", "7"]);
    let counts = channel(&adaptive, "Debug Sample Count.X");
    let (a, r) = (channel(&adaptive, "Combined.R"), channel(&reference, "Combined.R"));
    let mut d = Vec::new();
    for y in 0..H {
        for x in 0..W {
            if is_noisy(x) {
                let i = (y * W + x) as usize;
                d.push(a[i] as f64 - r[i] as f64);
            }
        }
    }
    assert!(counts.iter().any(|&n| n < 256.0), "adaptive sampling stopped no pixel early: the test says nothing");
    // Pixels are independent estimates (each has its own scrambled sequence, and the
    // filter sends every sample to one pixel): the mean difference has standard error
    // sd(d)/√n. 4 standard errors: a correct renderer fails with probability 6e-5.
    let (mean, se) = mean_se(&d);
    assert!(mean.abs() < 4.0 * se, "adaptive - reference = {mean} ± {se} over {} pixels", d.len());
    // And it is not a vacuous bound: the noise is small against the signal.
    let level = r.iter().map(|&v| v as f64).sum::<f64>() / r.len() as f64;
    assert!(se < 0.01 * level, "standard error {se} against a mean of {level}");
}

#[test]
fn threshold_zero_is_the_non_adaptive_image_bit_for_bit() {
    let dir = temp_dir();
    let scene = half_flat(dir.path());
    let plain = render(&scene, dir.path(), "p.exr", &["--spp", "40"]);
    let zero = render(&scene, dir.path(), "z.exr", &["--spp", "40", "--noise-threshold", "0", "--min-samples", "8"]);
    assert_eq!(exr_channel_bits(&plain), exr_channel_bits(&zero));
}

#[test]
fn adaptive_image_does_not_depend_on_the_thread_count() {
    let dir = temp_dir();
    let scene = half_flat(dir.path());
    let args = |t: &'static str| ["--spp", "128", "--noise-threshold", "0.02", "--min-samples", "16", "--threads", t];
    let one = render(&scene, dir.path(), "1.exr", &args("1"));
    let two = render(&scene, dir.path(), "2.exr", &args("3"));
    assert_eq!(exr_channel_bits(&one), exr_channel_bits(&two));
    for integrator in ["bdpt", "photon"] {
        let flags = |t: &'static str| {
            [
                "--spp",
                "48",
                "--noise-threshold",
                "0.01",
                "--min-samples",
                "8",
                "--integrator",
                integrator,
                "--threads",
                t,
            ]
        };
        let a = render(&scene, dir.path(), &format!("{integrator}1.exr"), &flags("1"));
        let b = render(&scene, dir.path(), &format!("{integrator}3.exr"), &flags("3"));
        assert_eq!(exr_channel_bits(&a), exr_channel_bits(&b), "{integrator}");
        let counts = channel(&a, "Debug Sample Count.X");
        // First test after 16 samples (index 15 > 8): the flat half stops there, the noisy half goes on.
        assert!(counts.contains(&16.0) && counts.contains(&48.0), "{integrator}: {counts:?}");
    }
}

#[test]
fn chunks_are_refused_and_sppm_warns() {
    let dir = temp_dir();
    let scene = half_flat(dir.path());
    let out = dir.path().join("c.exr");
    let s = scene.to_str().unwrap();
    let o = out.to_str().unwrap();
    for extra in [&["--chunk"][..], &["--sample-offset", "16"][..]] {
        let mut args = vec!["render", s, "-o", o, "--progress", "json", "--spp", "8", "--noise-threshold", "0.01"];
        args.extend_from_slice(extra);
        let r = run(&args, LIMIT);
        assert_eq!(r.code, Some(2), "{}", r.stderr);
        assert!(r.error_message().unwrap().contains("cannot be split into chunks"), "{}", r.stderr);
        assert!(!out.exists());
    }
    let r = run(&["render", s, "-o", o, "--progress", "json", "--noise-threshold", "2"], LIMIT);
    assert_eq!(r.code, Some(2), "{}", r.stderr);
    let r = run(
        &[
            "render",
            s,
            "-o",
            o,
            "--progress",
            "json",
            "--integrator",
            "sppm",
            "--sppm-iterations",
            "2",
            "--noise-threshold",
            "0.01",
        ],
        LIMIT,
    );
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let warnings = r.summary().unwrap()["warnings"].to_string();
    assert!(warnings.contains("ignored by SPPM"), "{warnings}");
}
