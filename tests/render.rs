//! End-to-end rendering tests of the `caustic` binary: furnaces, analytic scenes,
//! determinism, crops, settings errors, interruption, time limits and interim images.
//!
//! Statistical bounds: a test compares the mean of N pixel values against the exact
//! answer with a bound of 5 standard errors, where the standard error is the sample
//! standard deviation of the N pixel values over √N (pixels use independent scrambles,
//! so they are independent estimates); a systematic allowance is added only where a
//! known, separately tested approximation (the BSDF's albedo table) enters, and it is
//! derived from that approximation's tested error bound.

mod common;

use caustic::bsdf::PbrBsdf;
use caustic::math::Frame;
use caustic::scene::camera::CameraRays;
use common::{GltfBuilder, emissive_furnace, look_rotation, mean_se, render_image, root, run, temp_dir};
use glam::Vec3;
use serde_json::json;
use std::path::Path;
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);

fn render(scene: &Path, out: &Path, extra: &[&str]) -> Vec<[f32; 4]> {
    render_image(scene, out, extra, LIMIT)
}

/// Error bound of the albedo table, as asserted by `bsdf::albedo::tests::albedo_table_accuracy`.
const ALBEDO_TABLE_ERROR: f64 = 2e-3;

/// A closed box of albedo 1 emitting Le everywhere: a path of at most D scattering
/// events collects Le at each of its D + 1 vertices, so L = (D + 1) Le exactly.
#[test]
fn furnace_albedo_one() {
    let dir = temp_dir();
    let le = 0.5f32;
    let depth = 4u32;
    for roughness in [1.0f32, 0.3] {
        let scene = emissive_furnace(dir.path(), "furnace.gltf", le as f64, roughness);
        let px = render(
            &scene,
            &dir.path().join("f.exr"),
            &["--resolution", "24x24", "--spp", "32", "--max-depth", &depth.to_string()],
        );
        let v: Vec<f64> = px.iter().map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0).collect();
        let (mean, se) = mean_se(&v);
        let expect = (depth + 1) as f64 * le as f64;
        // Each bounce's albedo may be off by the table error: Σ k ε Le over k ≤ D.
        let systematic = le as f64 * ALBEDO_TABLE_ERROR * (depth * (depth + 1) / 2) as f64;
        let bound = 5.0 * se + systematic;
        eprintln!("furnace r={roughness}: mean {mean:.5} ± {se:.5}, expected {expect}, bound {bound:.5}");
        assert!((mean - expect).abs() <= bound, "furnace r={roughness}: {mean} vs {expect} (bound {bound})");
        assert!(px.iter().all(|p| p[3] == 1.0), "inside a closed box every pixel is covered");
    }
}

/// A closed box of albedo 1 whose walls have coverage a (BLEND): a path survives each
/// wall with probability a, so the walls act as albedo a and emit a·Le; with at most D
/// scattering events L = a Le (1 - a^(D+1)) / (1 - a), → a Le / (1 - a).
#[test]
fn furnace_partial_coverage() {
    let dir = temp_dir();
    let (a, le, depth) = (0.5f64, 1.0f64, 13u32);
    let mut g = GltfBuilder::new();
    let m = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, a], "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "emissiveFactor": [le, le, le], "alphaMode": "BLEND", "doubleSided": true
    }));
    g.cube([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], m);
    g.camera([0.0, 0.0, 0.0], look_rotation([0.2, 0.1, -1.0]), 1.2);
    let scene = g.write(dir.path(), "furnace_alpha.gltf");
    let px = render(&scene, &dir.path().join("f.exr"), &["--resolution", "24x24", "--spp", "64"]);
    let v: Vec<f64> = px.iter().map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0).collect();
    let (mean, se) = mean_se(&v);
    let expect = a * le * (1.0 - a.powi(depth as i32 + 1)) / (1.0 - a);
    let systematic = le * ALBEDO_TABLE_ERROR * (1..=depth).map(|k| k as f64 * a.powi(k as i32 + 1)).sum::<f64>();
    let bound = 5.0 * se + systematic;
    eprintln!("coverage furnace: mean {mean:.5} ± {se:.5}, expected {expect:.5}, bound {bound:.5}");
    assert!((mean - expect).abs() <= bound, "{mean} vs {expect}");
}

/// Renders a white rough plane under a light, one sample per pixel at the pixel centre
/// (a 0.00001 px box filter), depth 1: the light is a delta light, so each pixel is
/// exactly f(wo, wi) E(p), computed here from the camera and the BRDF.
fn plane_under_light(
    light: serde_json::Value,
    light_pos: [f32; 3],
    light_rot: [f32; 4],
    irradiance: impl Fn(&caustic::scene::Scene, Vec3) -> (Vec3, f32),
) {
    let dir = temp_dir();
    let mut g = GltfBuilder::new();
    let base = 0.8f32;
    let m = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [base, base, base, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
    g.mesh(&[[-20.0, 0.0, -20.0], [20.0, 0.0, -20.0], [20.0, 0.0, 20.0], [-20.0, 0.0, 20.0]], &[0, 2, 1, 0, 3, 2], m);
    g.camera([0.0, 3.0, 3.0], look_rotation([0.0, -1.0, -1.0]), 1.0);
    g.punctual(light, light_pos, light_rot);
    let path = g.write(dir.path(), "plane.gltf");
    let (w, h) = (24u32, 24u32);
    let px = render(
        &path,
        &dir.path().join("p.exr"),
        &[
            "--resolution",
            &format!("{w}x{h}"),
            "--spp",
            "1",
            "--max-depth",
            "1",
            "--filter",
            "box",
            "--filter-width",
            "0.00001",
        ],
    );
    let scene = caustic::scene::gltf::load(&path).unwrap();
    let cam = CameraRays::new(&scene.cameras[0], w, h);
    let bsdf = PbrBsdf::new(Vec3::splat(base), 0.0, 1.0);
    let frame = Frame::from_normal(Vec3::Y);
    let mut checked = 0;
    for y in 0..h {
        for x in 0..w {
            let (o, d) = cam.ray(x as f32 + 0.5, y as f32 + 0.5);
            let got = Vec3::new(px[(y * w + x) as usize][0], px[(y * w + x) as usize][1], px[(y * w + x) as usize][2]);
            if d.y >= 0.0 {
                continue;
            }
            let p = o + d * (-o.y / d.y);
            if p.x.abs() > 19.0 || p.z.abs() > 19.0 {
                continue;
            }
            let (wi, e) = irradiance(&scene, p);
            let f = bsdf.eval(frame.to_local(-d), frame.to_local(wi));
            let expect = f * e;
            let err = (got - expect).abs().max_element();
            assert!(err <= 2e-3 * expect.max_element() + 1e-7, "pixel ({x},{y}): {got} vs {expect}");
            checked += 1;
        }
    }
    assert!(checked > 100);
}

/// Point light of 683 cd = 1 W/sr (Blender's exporter writes W/(4π)·683) at height 1:
/// E = I cos θ / r².
#[test]
fn point_light_over_plane() {
    let lp = Vec3::new(0.3, 1.0, -0.2);
    plane_under_light(json!({"type": "point", "intensity": 683.0}), lp.to_array(), [0.0, 0.0, 0.0, 1.0], |_, p| {
        let d = lp - p;
        let r2 = d.length_squared();
        let wi = d.normalize();
        (wi, wi.y / r2)
    });
}

/// Directional light of 683 lux = 1 W/m² arriving at 45°: E = cos 45°.
#[test]
fn directional_light_over_plane() {
    let travel = Vec3::new(0.0, -1.0, -1.0).normalize();
    plane_under_light(
        json!({"type": "directional", "intensity": 683.0}),
        [0.0, 5.0, 0.0],
        look_rotation(travel.to_array()),
        |_, _| (-travel, -travel.y),
    );
}

/// Spot light: intensity times glTF's smooth cone falloff.
#[test]
fn spot_light_over_plane() {
    let lp = Vec3::new(0.0, 2.0, 0.0);
    let (inner, outer) = (0.3f32, 0.6f32);
    plane_under_light(
        json!({"type": "spot", "intensity": 683.0, "spot": {"innerConeAngle": inner, "outerConeAngle": outer}}),
        lp.to_array(),
        look_rotation([0.0, -1.0, 0.0001]),
        |scene, p| {
            let d = lp - p;
            let wi = d.normalize();
            // The axis as the loader computed it from the node's rotation: the falloff is
            // steep, so rounding in a separately computed axis would show.
            let caustic::light::Light::Spot { direction: axis, .. } = scene.lights[0] else { panic!("not a spot") };
            let falloff = caustic::light::spot_falloff((-wi).dot(axis), inner.cos(), outer.cos());
            (wi, falloff * wi.y / d.length_squared())
        },
    );
}

/// An emissive quad seen directly has exactly its emitted radiance.
#[test]
fn emissive_quad_seen_directly() {
    let dir = temp_dir();
    let mut g = GltfBuilder::new();
    g.use_ext("KHR_materials_emissive_strength");
    let m = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]},
        "emissiveFactor": [1.0, 0.5, 0.25], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 3.0}}
    }));
    g.mesh(&[[-5.0, -5.0, -2.0], [5.0, -5.0, -2.0], [5.0, 5.0, -2.0], [-5.0, 5.0, -2.0]], &[0, 1, 2, 0, 2, 3], m);
    g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.8);
    let path = g.write(dir.path(), "quad.gltf");
    let px = render(&path, &dir.path().join("q.exr"), &["--resolution", "16x16", "--spp", "4"]);
    for p in &px {
        assert!((p[0] - 3.0).abs() < 1e-5 && (p[1] - 1.5).abs() < 1e-5 && (p[2] - 0.75).abs() < 1e-5, "{p:?}");
        assert_eq!(p[3], 1.0);
    }
}

/// A disk area light (CAUSTIC_lights_area) of power P and radius R at height h over a
/// rough plane: each pixel is ∫ f(wo, wi) L cos θ dω with L = P / (π² R²), integrated
/// here by a fine polar quadrature; the render (NEE + MIS, many samples) must agree
/// within 5 standard errors of the per-pixel residuals.
#[test]
fn disk_area_light_over_plane() {
    let dir = temp_dir();
    let (power, radius, h) = (40.0f32, 0.5f32, 1.0f32);
    let mut g = GltfBuilder::new();
    let base = 0.8f32;
    let m = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [base, base, base, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
    g.mesh(&[[-20.0, 0.0, -20.0], [20.0, 0.0, -20.0], [20.0, 0.0, 20.0], [-20.0, 0.0, 20.0]], &[0, 2, 1, 0, 3, 2], m);
    g.camera([0.0, 3.0, 3.0], look_rotation([0.0, -1.0, -1.0]), 1.0);
    g.use_ext("CAUSTIC_lights_area");
    // Local -Z must point down: a rotation of -90° about X maps (0, 0, -1) to (0, -1, 0).
    let q = glam::Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    assert!((q * Vec3::NEG_Z - Vec3::NEG_Y).length() < 1e-6);
    g.node(json!({"translation": [0.0, h, 0.0], "rotation": [q.x, q.y, q.z, q.w],
        "extensions": {"CAUSTIC_lights_area": {"shape": "disk", "size": [2.0 * radius, 2.0 * radius], "power": power, "color": [1, 1, 1]}}}));
    let path = g.write(dir.path(), "disk.gltf");
    let (w, hh) = (24u32, 24u32);
    let crop = [8u32, 8, 16, 16];
    let px = render(
        &path,
        &dir.path().join("d.exr"),
        &[
            "--resolution",
            &format!("{w}x{hh}"),
            "--spp",
            "256",
            "--max-depth",
            "1",
            "--filter",
            "box",
            "--filter-width",
            "0.00001",
            "--crop",
            &format!("{},{},{},{}", crop[0], crop[1], crop[2], crop[3]),
        ],
    );
    let scene = caustic::scene::gltf::load(&path).unwrap();
    let cam = CameraRays::new(&scene.cameras[0], w, hh);
    let bsdf = PbrBsdf::new(Vec3::splat(base), 0.0, 1.0);
    let frame = Frame::from_normal(Vec3::Y);
    let radiance = power / (std::f32::consts::PI * std::f32::consts::PI * radius * radius);
    let mut residuals = Vec::new();
    let mut expected_sum = 0.0;
    for y in crop[1]..crop[3] {
        for x in crop[0]..crop[2] {
            let (o, d) = cam.ray(x as f32 + 0.5, y as f32 + 0.5);
            let p = o + d * (-o.y / d.y);
            let wo = frame.to_local(-d);
            // Polar quadrature over the disk (area measure → solid angle).
            let (nr, nphi) = (200, 200);
            let mut e = 0.0f64;
            for i in 0..nr {
                let r = radius * (i as f32 + 0.5) / nr as f32;
                for j in 0..nphi {
                    let phi = std::f32::consts::TAU * (j as f32 + 0.5) / nphi as f32;
                    let q = Vec3::new(r * phi.cos(), h, r * phi.sin());
                    let dq = q - p;
                    let dist2 = dq.length_squared();
                    let wi = dq / dist2.sqrt();
                    let cos_l = wi.y; // the light faces down: cos at the light = wi·(0,1,0)
                    let da = r * (radius / nr as f32) * (std::f32::consts::TAU / nphi as f32);
                    let f = bsdf.eval(wo, frame.to_local(wi)).x;
                    e += (f * radiance * wi.y * cos_l / dist2 * da) as f64;
                }
            }
            let i = ((y - crop[1]) * (crop[2] - crop[0]) + (x - crop[0])) as usize;
            residuals.push(px[i][0] as f64 - e);
            expected_sum += e;
        }
    }
    let (mean, se) = mean_se(&residuals);
    let expected_mean = expected_sum / residuals.len() as f64;
    eprintln!("disk light: mean residual {mean:.2e} ± {se:.2e} (expected mean pixel {expected_mean:.4})");
    assert!(expected_mean > 0.01, "the test scene must be lit");
    assert!(se < 0.01 * expected_mean, "too noisy to test anything: SE {se} for a mean of {expected_mean}");
    assert!(mean.abs() <= 5.0 * se + 1e-4 * expected_mean, "residual {mean} ± {se}");
}

fn cornell() -> std::path::PathBuf {
    root().join("scenes/cornell_box.gltf")
}

#[test]
fn identical_for_any_thread_count() {
    let dir = temp_dir();
    let a = render(&cornell(), &dir.path().join("a.exr"), &["--resolution", "40x40", "--spp", "8", "--threads", "1"]);
    let b = render(&cornell(), &dir.path().join("b.exr"), &["--resolution", "40x40", "--spp", "8", "--threads", "2"]);
    let c = render(&cornell(), &dir.path().join("c.exr"), &["--resolution", "40x40", "--spp", "8", "--threads", "3"]);
    assert!(a == b && b == c, "images differ between thread counts");
    let d = render(&cornell(), &dir.path().join("d.exr"), &["--resolution", "40x40", "--spp", "8", "--seed", "7"]);
    assert!(a != d, "the seed must change the noise");
}

#[test]
fn crop_equals_window_of_full_frame() {
    let dir = temp_dir();
    let full = render(&cornell(), &dir.path().join("full.exr"), &["--resolution", "48x40", "--spp", "4"]);
    let crop = [7u32, 5, 31, 29];
    let part = render(
        &cornell(),
        &dir.path().join("part.exr"),
        &["--resolution", "48x40", "--spp", "4", "--crop", "7,5,31,29"],
    );
    let (cw, ch) = (crop[2] - crop[0], crop[3] - crop[1]);
    assert_eq!(part.len(), (cw * ch) as usize);
    for y in 0..ch {
        for x in 0..cw {
            assert_eq!(
                part[(y * cw + x) as usize],
                full[((y + crop[1]) * 48 + x + crop[0]) as usize],
                "pixel ({x},{y})"
            );
        }
    }
}

/// `--view left` names every channel for Blender's view (`<Pass>.left.<Channel>`, which a
/// multi-view render result reads) and changes nothing else: the same pixels as without it.
#[test]
fn view_names_the_channels_and_keeps_the_pixels() {
    let dir = temp_dir();
    let args = ["--resolution", "16x12", "--spp", "4", "--passes", "z,normal"];
    let plain = dir.path().join("plain.exr");
    let left = dir.path().join("left.exr");
    render(&cornell(), &plain, &args);
    let r = run(
        &[
            &[
                "render",
                cornell().to_str().unwrap(),
                "-o",
                left.to_str().unwrap(),
                "--view",
                "left",
                "--progress",
                "none",
            ][..],
            &args[..],
        ]
        .concat(),
        LIMIT,
    );
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let channels = |path: &Path| {
        let image = exr::prelude::read_all_flat_layers_from_file(path).unwrap();
        let layer = &image.layer_data[0];
        layer.channel_data.list.iter().map(|c| (c.name.to_string(), c.sample_data.clone())).collect::<Vec<_>>()
    };
    let (a, b) = (channels(&plain), channels(&left));
    let names: Vec<&str> = b.iter().map(|(n, _)| n.as_str()).collect();
    for want in ["Combined.left.R", "Combined.left.A", "Depth.left.Z", "Normal.left.X"] {
        assert!(names.contains(&want), "{want} missing from {names:?}");
    }
    assert_eq!(a.len(), b.len());
    for (n, data) in &a {
        let (pass, channel) = n.rsplit_once('.').unwrap();
        let named = format!("{pass}.left.{channel}");
        let other = &b.iter().find(|(m, _)| *m == named).unwrap_or_else(|| panic!("{named} missing")).1;
        assert!(format!("{data:?}") == format!("{other:?}"), "{n}: pixels differ");
    }
    let bad = run(&["render", cornell().to_str().unwrap(), "-o", left.to_str().unwrap(), "--view", "a.b"], LIMIT);
    assert_eq!(bad.code, Some(2), "a view name with a dot is a usage error: {}", bad.stderr);
}

#[test]
fn settings_errors_are_usage_errors() {
    let dir = temp_dir();
    let out = dir.path().join("x.exr");
    let scene = cornell();
    let cases: &[(&[&str], i32, &str)] = &[
        (&["--spp", "0"], 2, "spp"),
        (&["--resolution", "0x10"], 2, "resolution"),
        (&["--resolution", "100000x100000"], 2, "resolution"),
        (&["--camera", "nope"], 2, "camera"),
        (&["--crop", "0,0,999,10"], 2, "crop"),
        (&["--threads", "0"], 2, "threads"),
        (&["--time-limit=-1"], 2, "time"),
        (&["--max-depth", "99999"], 2, "depth"),
        (&["--resolution", "banana"], 2, "banana"),
    ];
    for (extra, code, word) in cases {
        let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"];
        args.extend_from_slice(extra);
        let r = run(&args, LIMIT);
        assert_eq!(r.code, Some(*code), "{extra:?}: {}", r.stderr);
        let msg = r.error_message().unwrap_or_default();
        assert!(msg.to_lowercase().contains(word), "{extra:?}: message '{msg}' should name '{word}'");
        assert!(!out.exists(), "{extra:?} left an output file");
    }
    let r = run(&["render", scene.to_str().unwrap(), "-o", "/nonexistent-dir/x.exr", "--progress", "json"], LIMIT);
    assert_eq!(r.code, Some(4), "unwritable output: {}", r.stderr);
    assert!(r.error_message().unwrap_or_default().contains("nonexistent-dir"));
}

/// SPPM takes one sample per pixel an iteration, so `--spp` sets its iteration count (it was
/// ignored: 64 iterations whatever it said); flags of another integrator are named, not
/// dropped silently.
#[test]
fn sppm_counts_spp_and_foreign_flags_are_warned() {
    let dir = temp_dir();
    let out = dir.path().join("s.exr");
    let scene = cornell();
    let render = |extra: &[&str]| {
        let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"];
        args.extend_from_slice(&["--resolution", "8x8"]);
        args.extend_from_slice(extra);
        let r = run(&args, LIMIT);
        assert_eq!(r.code, Some(0), "{extra:?}: {}", r.stderr);
        r.summary().unwrap()
    };
    let s = render(&["--integrator", "sppm", "--spp", "3", "--sppm-photons", "500"]);
    assert_eq!(s["spp"], 3, "{s}");
    assert!(!s["warnings"].to_string().contains("ignores"), "{s}");
    let s = render(&["--integrator", "sppm", "--sppm-iterations", "2", "--sppm-photons", "500", "--spp", "5"]);
    assert_eq!(s["spp"], 2, "{s}");
    assert!(s["warnings"].to_string().contains("--spp 5 is ignored"), "{s}");
    let s = render(&["--spp", "1", "--photons", "1000", "--sppm-radius", "0.1"]);
    let w = s["warnings"].to_string();
    assert!(w.contains("--photons is read by photon only; the path integrator ignores it"), "{w}");
    assert!(w.contains("--sppm-radius is read by sppm only"), "{w}");
    let s = render(&["--integrator", "sppm", "--spp", "1", "--sppm-photons", "500", "--k", "5", "--gather-rays", "2"]);
    let w = s["warnings"].to_string();
    assert!(w.contains("--gather-rays") && !w.contains("--k "), "{w}");
}

#[test]
fn sigterm_writes_partial_image() {
    use std::io::BufRead;
    let dir = temp_dir();
    let out = dir.path().join("partial.exr");
    let mut child = std::process::Command::new(common::bin())
        .args([
            "render",
            cornell().to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--resolution",
            "64x64",
            "--spp",
            "100000",
            "--progress",
            "json",
        ])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = child.stderr.take().unwrap();
    let mut lines = std::io::BufReader::new(stderr).lines();
    let mut all = Vec::new();
    for line in lines.by_ref() {
        let line = line.unwrap();
        let is_progress =
            line.contains("\"progress\"") && line.contains("\"samples_done\"") && !line.contains("\"samples_done\":0,");
        all.push(line);
        if is_progress {
            break;
        }
    }
    let kill = std::process::Command::new("kill").args(["-TERM", &child.id().to_string()]).status().unwrap();
    assert!(kill.success());
    let start = std::time::Instant::now();
    all.extend(lines.map_while(Result::ok));
    let status = child.wait().unwrap();
    assert!(start.elapsed() < Duration::from_secs(10), "took too long to stop");
    assert_eq!(status.code(), Some(5), "exit code after SIGTERM; stderr:\n{}", all.join("\n"));
    let summary: serde_json::Value = all
        .iter()
        .filter_map(|l| serde_json::from_str(l).ok())
        .find(|v: &serde_json::Value| v["type"] == "summary")
        .expect("summary");
    assert_eq!(summary["interrupted"], true);
    let (_, _, px) = caustic::output::read_combined(&out).unwrap();
    assert!(px.iter().all(|p| p.iter().all(|c| c.is_finite())));
    let mean: f32 = px.iter().map(|p| p[0]).sum::<f32>() / px.len() as f32;
    assert!(mean > 0.01, "the partial image must hold the samples rendered so far");
}

#[test]
fn time_limit_and_interim_images() {
    let dir = temp_dir();
    let out = dir.path().join("t.exr");
    let r = run(
        &[
            "render",
            cornell().to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--resolution",
            "64x64",
            // More samples than 1.5 s can take: the time limit, not the scene's 64 spp (which a
            // quiet machine finishes before the first 0.3 s interim), must end this render.
            "--spp",
            "1000000",
            "--time-limit",
            "1.5",
            "--interim",
            "0.3",
            "--progress",
            "json",
        ],
        LIMIT,
    );
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let lines = r.json_lines();
    assert!(lines.iter().any(|v| v["type"] == "image" && v["final"] == false), "no interim image line");
    assert!(lines.iter().any(|v| v["type"] == "image" && v["final"] == true));
    assert!(lines.iter().any(|v| v["type"] == "progress"));
    let s = r.summary().unwrap();
    let spp = s["spp"].as_u64().unwrap();
    assert!((1..1_000_000).contains(&spp), "the time limit must end the render: {spp} spp");
    // Generous: the limit bounds the rendering phase; loading and writing come on top.
    assert!(r.elapsed < Duration::from_secs(20));
}

/// Simplify's Texture Limit must be a size: 0 is refused by name, not read as "no limit".
#[test]
fn texture_limit_zero_is_refused() {
    let dir = temp_dir();
    let mut g = GltfBuilder::new();
    let m = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1]}}));
    g.cube([-1.0, -1.0, -3.0], [1.0, 1.0, -2.0], m);
    g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.8);
    g.settings(json!({"texture_limit": 0}));
    let path = g.write(dir.path(), "limit.gltf");
    let out = dir.path().join("l.exr");
    let r = run(&["render", path.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"], LIMIT);
    assert_ne!(r.code, Some(0));
    assert!(r.error_message().unwrap_or_default().contains("texture_limit"), "{}", r.stderr);
    assert!(!out.exists());
}

#[test]
fn unlit_scene_warns_about_black_image() {
    let dir = temp_dir();
    let mut g = GltfBuilder::new();
    let m = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1]}}));
    g.cube([-1.0, -1.0, -3.0], [1.0, 1.0, -2.0], m);
    g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.8);
    let path = g.write(dir.path(), "unlit.gltf");
    let out = dir.path().join("u.exr");
    let r = run(
        &[
            "render",
            path.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--resolution",
            "8x8",
            "--spp",
            "1",
            "--progress",
            "json",
        ],
        LIMIT,
    );
    assert_eq!(r.code, Some(0));
    let s = r.summary().unwrap();
    assert_eq!(s["black"], true);
    let warnings = s["warnings"].to_string();
    assert!(warnings.contains("no lights") && warnings.contains("black"), "{warnings}");
}

/// An emitter of radiance Le seen at normal incidence through a smooth glass slab of
/// index n: the slab's faces reflect F = ((n-1)/(n+1))² each, and the light bouncing
/// between them sums to T = (1-F)² τ / (1 - F² τ²), with τ = exp(-σa d) the internal
/// transmittance (Beer-Lambert through `KHR_materials_volume`; τ = 1 without absorption).
#[test]
fn glass_slab_transmittance() {
    let ior = 1.5f64;
    let f = ((ior - 1.0) / (ior + 1.0)).powi(2);
    let thickness = 0.2f64;
    for (attenuation_color, attenuation_distance) in [(None, 0.0), (Some([0.5f64, 0.8, 0.25]), 0.4)] {
        let dir = temp_dir();
        let mut g = GltfBuilder::new();
        g.use_ext("KHR_materials_transmission");
        g.use_ext("KHR_materials_volume");
        let mut volume = json!({"thicknessFactor": thickness});
        if let Some(c) = attenuation_color {
            volume["attenuationColor"] = json!(c);
            volume["attenuationDistance"] = json!(attenuation_distance);
        }
        let glass = g.material(json!({
            "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
            "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_volume": volume}
        }));
        let h = (thickness / 2.0) as f32;
        g.cube([-3.0, -3.0, -h], [3.0, 3.0, h], glass);
        let le = 2.0f64;
        let light = g
            .material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}, "emissiveFactor": [1, 1, 1],
            "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": le}}}));
        g.use_ext("KHR_materials_emissive_strength");
        g.mesh(
            &[[-9.0, -9.0, -1.0], [9.0, -9.0, -1.0], [9.0, 9.0, -1.0], [-9.0, 9.0, -1.0]],
            &[0, 1, 2, 0, 2, 3],
            light,
        );
        // A narrow view along -Z: incidence within 0.03 rad of normal (F changes < 1e-5).
        g.camera([0.0, 0.0, 2.0], [0.0, 0.0, 0.0, 1.0], 0.05);
        let path = g.write(dir.path(), "slab.gltf");
        let px =
            render(&path, &dir.path().join("s.exr"), &["--resolution", "16x16", "--spp", "64", "--max-depth", "64"]);
        for c in 0..3 {
            let tau = match attenuation_color {
                None => 1.0,
                Some(col) => (col[c].ln() / attenuation_distance * thickness).exp(),
            };
            let expect = le * (1.0 - f).powi(2) * tau / (1.0 - f * f * tau * tau);
            let v: Vec<f64> = px.iter().map(|p| p[c] as f64).collect();
            let (mean, se) = mean_se(&v);
            eprintln!("slab channel {c}: {mean:.5} ± {se:.5}, expected {expect:.5}");
            assert!((mean - expect).abs() <= 5.0 * se + 1e-6 * expect, "channel {c}: {mean} vs {expect}");
        }
    }
}

/// White furnace: an object of albedo 1 in a uniform world of radiance L reflects
/// exactly L in every direction, at any depth; with an opaque background every pixel,
/// object or sky, is L. Run with a constant colour and with a constant image (which
/// goes through the image's importance sampling and lookup).
#[test]
fn white_furnace_in_uniform_world() {
    let l = 0.7f64;
    let dir = temp_dir();
    // A constant 8x4 float image.
    let img_path = dir.path().join("const.exr");
    exr::prelude::write_rgb_file(&img_path, 8, 4, |_, _| (1.0f32, 1.0f32, 1.0f32)).unwrap();
    for world in
        [json!({"color": [l, l, l]}), json!({"color": [1, 1, 1], "strength": l, "image": "const.exr", "rotation": 0.4})]
    {
        let mut g = GltfBuilder::new();
        let white = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.5}, "doubleSided": true}));
        g.cube([-0.5, -0.5, -2.5], [0.5, 0.5, -1.5], white);
        g.cube([-2.0, -1.5, -4.0], [2.0, -1.0, -1.0], white);
        g.camera([0.0, 0.5, 1.0], look_rotation([0.0, -0.3, -1.0]), 1.0);
        g.world(world.clone());
        g.settings(json!({"transparent": false}));
        let path = g.write(dir.path(), "furnace_world.gltf");
        let depth = 64u32;
        let out = dir.path().join("w.exr");
        let r = run(
            &[
                "render",
                path.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
                "--progress",
                "json",
                "--resolution",
                "24x24",
                "--spp",
                "32",
                "--max-depth",
                &depth.to_string(),
            ],
            LIMIT,
        );
        assert_eq!(r.code, Some(0), "{}", r.stderr);
        let px = caustic::output::read_combined(&out).unwrap().2;
        let v: Vec<f64> = px.iter().map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0).collect();
        let (mean, se) = mean_se(&v);
        // Each bounce's albedo may be off by the table error ε, so the expected value is
        // off by at most L ε E[k], E[k] the mean number of bounces per path, which the
        // summary gives as bounce rays per camera ray.
        let rays = &r.summary().unwrap()["stats"]["rays"];
        let mean_bounces = rays["bounce"].as_f64().unwrap() / rays["camera"].as_f64().unwrap();
        let systematic = l * ALBEDO_TABLE_ERROR * mean_bounces;
        eprintln!("world furnace {world}: mean {mean:.5} ± {se:.5}, expected {l}");
        assert!((mean - l).abs() <= 5.0 * se + systematic, "{world}: {mean} vs {l}");
        assert!(px.iter().all(|p| p[3] == 1.0), "opaque background: alpha 1 everywhere");
    }
}

/// Renders a rough plane lit by a light seen as a cone of uniform radiance L from each
/// shading point (a sphere light: half angle asin(r/d); a sun with an angular diameter),
/// point-sampled pixels in a crop, and compares each pixel with ∫cone f(wo, wi) L cos θi dω
/// by a fine polar quadrature; the mean residual must be within 5 standard errors.
fn cone_light_over_plane(
    light: serde_json::Value,
    pos: [f32; 3],
    rot: [f32; 4],
    exts: serde_json::Value,
    cone: impl Fn(Vec3) -> (Vec3, f32, f32),
) {
    let dir = temp_dir();
    let mut g = GltfBuilder::new();
    let base = 0.8f32;
    let m = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [base, base, base, 1], "metallicFactor": 0.0, "roughnessFactor": 0.7}}));
    g.mesh(&[[-20.0, 0.0, -20.0], [20.0, 0.0, -20.0], [20.0, 0.0, 20.0], [-20.0, 0.0, 20.0]], &[0, 2, 1, 0, 3, 2], m);
    g.camera([0.0, 3.0, 3.0], look_rotation([0.0, -1.0, -1.0]), 1.0);
    g.punctual_with(light, pos, rot, exts);
    let path = g.write(dir.path(), "cone.gltf");
    let (w, h) = (24u32, 24u32);
    let crop = [6u32, 6, 18, 18];
    let px = render(
        &path,
        &dir.path().join("c.exr"),
        &[
            "--resolution",
            &format!("{w}x{h}"),
            "--spp",
            "256",
            "--max-depth",
            "1",
            "--filter",
            "box",
            "--filter-width",
            "0.00001",
            "--crop",
            &format!("{},{},{},{}", crop[0], crop[1], crop[2], crop[3]),
        ],
    );
    let scene = caustic::scene::gltf::load(&path).unwrap();
    let cam = CameraRays::new(&scene.cameras[0], w, h);
    let bsdf = PbrBsdf::new(Vec3::splat(base), 0.0, 0.7);
    let frame = Frame::from_normal(Vec3::Y);
    let mut residuals = Vec::new();
    let mut expected_sum = 0.0;
    for y in crop[1]..crop[3] {
        for x in crop[0]..crop[2] {
            let (o, d) = cam.ray(x as f32 + 0.5, y as f32 + 0.5);
            let p = o + d * (-o.y / d.y);
            let wo = frame.to_local(-d);
            let (axis, cos_max, radiance) = cone(p);
            let cone_frame = Frame::from_normal(axis);
            let (nt, np) = (200, 200);
            let mut e = 0.0f64;
            for i in 0..nt {
                // Uniform in cos θ over [cos_max, 1]: dω = d(cos θ) dφ.
                let c = 1.0 - (1.0 - cos_max) * (i as f32 + 0.5) / nt as f32;
                let sn = (1.0 - c * c).max(0.0).sqrt();
                for j in 0..np {
                    let phi = std::f32::consts::TAU * (j as f32 + 0.5) / np as f32;
                    let wi = cone_frame.to_world(Vec3::new(sn * phi.cos(), sn * phi.sin(), c));
                    if wi.y <= 0.0 {
                        continue;
                    }
                    let dw = (1.0 - cos_max) / nt as f32 * std::f32::consts::TAU / np as f32;
                    e += (bsdf.eval(wo, frame.to_local(wi)).x * radiance * wi.y * dw) as f64;
                }
            }
            let i = ((y - crop[1]) * (crop[2] - crop[0]) + (x - crop[0])) as usize;
            residuals.push(px[i][0] as f64 - e);
            expected_sum += e;
        }
    }
    let (mean, se) = mean_se(&residuals);
    let expected_mean = expected_sum / residuals.len() as f64;
    eprintln!("cone light: mean residual {mean:.2e} ± {se:.2e} (expected mean pixel {expected_mean:.4})");
    assert!(expected_mean > 0.01, "the test scene must be lit");
    assert!(se < 0.01 * expected_mean, "too noisy to test anything: SE {se} for a mean of {expected_mean}");
    assert!(mean.abs() <= 5.0 * se + 1e-4 * expected_mean, "residual {mean} ± {se}");
}

/// Blender's point light with a radius is a sphere of radiance I / (π r²) (I = P / 4π).
#[test]
fn sphere_light_over_plane() {
    // Beside the crop's view (24° off the axis; the crop spans ±14°): pixels see the floor only.
    let (c, r) = (Vec3::new(1.2, 1.0, 1.2), 0.35f32);
    let intensity = 3.0f32; // W/sr
    cone_light_over_plane(
        json!({"type": "point", "intensity": intensity * 683.0}),
        c.to_array(),
        [0.0, 0.0, 0.0, 1.0],
        json!({"CAUSTIC_lights_punctual": {"radius": r}}),
        |p| {
            let d = c - p;
            let dist = d.length();
            ((d / dist), (1.0 - (r / dist).powi(2)).sqrt(), intensity / (std::f32::consts::PI * r * r))
        },
    );
}

/// A sun of angular diameter 2α and irradiance E: a cone of radiance E / (π sin²α).
#[test]
fn sun_with_angle_over_plane() {
    let travel = Vec3::new(0.3, -1.0, -0.6).normalize();
    let half = 8f32.to_radians();
    let e = 2.0f32;
    cone_light_over_plane(
        json!({"type": "directional", "intensity": e * 683.0}),
        [0.0, 5.0, 0.0],
        look_rotation(travel.to_array()),
        json!({"CAUSTIC_lights_punctual": {"angle": 2.0 * half}}),
        |_| (-travel, half.cos(), e / (std::f32::consts::PI * half.sin().powi(2))),
    );
}
