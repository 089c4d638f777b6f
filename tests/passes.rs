//! Render passes (`--passes`): the light passes recombine to Combined as Cycles'
//! compositing formula says, only the passes asked for are written, and the data passes
//! give known answers on a tiny scene.

mod common;

use common::pass_checks::{channels, opaque_copy, with_light_groups};
use common::{GltfBuilder, look_rotation, root, run, temp_dir};
use serde_json::json;
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);

fn render(scene: &Path, out: &Path, extra: &[&str]) {
    let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"];
    args.extend_from_slice(extra);
    let r = run(&args, LIMIT);
    assert_eq!(r.code, Some(0), "render failed: {}", r.stderr);
}

const LIGHT: &str = "diffuse_direct,diffuse_indirect,diffuse_color,glossy_direct,glossy_indirect,glossy_color,\
transmission_direct,transmission_indirect,transmission_color,volume_direct,volume_indirect,emit,environment";

/// Asserts that the light passes of `ch` sum to its Combined, pixel by pixel (see below).
fn assert_recombines(ch: &BTreeMap<String, Vec<f32>>, name: &str) {
    let rgb = |pass: &str, c: usize| &ch[&format!("{pass}.{}", ["R", "G", "B"][c])];
    let mut worst = 0.0f64;
    let mut total = 0.0f64;
    for c in 0..3 {
        for i in 0..ch["Combined.R"].len() {
            let mut sum = 0.0f64;
            // Each term's size, for the rounding bound.
            let mut scale = 0.0f64;
            for class in ["Diffuse", "Glossy", "Transmission"] {
                let col = rgb(&format!("{class} Color"), c)[i] as f64;
                for kind in ["Direct", "Indirect"] {
                    let t = rgb(&format!("{class} {kind}"), c)[i] as f64 * col;
                    sum += t;
                    scale += t.abs();
                }
            }
            for pass in ["Volume Direct", "Volume Indirect", "Emission", "Environment"] {
                sum += rgb(pass, c)[i] as f64;
                scale += (rgb(pass, c)[i] as f64).abs();
            }
            let combined = rgb("Combined", c)[i] as f64;
            // Float rounding: every pass is a sum of the same contributions in f32
            // (about 2^-24 relative per addition and 8 samples × a few terms per
            // path), then a quotient and a product in f32 (2 × 2^-24): 1e-5 of the
            // terms' magnitude bounds it with room, far below any misfiled light.
            let tol = 1e-5 * scale.max(combined.abs()) + 1e-9;
            worst = worst.max((combined - sum).abs() / tol);
            total += combined;
        }
    }
    assert!(total > 0.0, "{name}: black image");
    assert!(worst <= 1.0, "{name}: passes differ from Combined by {worst} × the rounding bound");
}

/// (Diffuse Direct + Indirect) × Color + the same for Glossy and Transmission + Volume
/// Direct + Indirect + Emission + Environment = Combined, pixel by pixel.
#[test]
fn light_passes_recombine_to_combined() {
    let dir = temp_dir();
    // Diffuse, glossy and glass with a caustic; an emitter seen directly; subsurface; a world.
    for name in ["glass_caustic", "cornell_box", "subsurface", "hdri_sky"] {
        let scene = opaque_copy(name, dir.path());
        let out = dir.path().join(format!("{name}.exr"));
        render(&scene, &out, &["--spp", "8", "--resolution", "40x30", "--passes", LIGHT]);
        assert_recombines(&channels(&out), name);
    }
}

/// The light passes are filed by class: the glass scene has glossy and transmitted
/// light, the Cornell box an emitter seen directly, the sky scene the world.
#[test]
fn light_passes_are_filed_by_class() {
    let dir = temp_dir();
    let mean = |ch: &BTreeMap<String, Vec<f32>>, pass: &str| -> f64 {
        ["R", "G", "B"].iter().map(|c| ch[&format!("{pass}.{c}")].iter().map(|&v| v as f64).sum::<f64>()).sum()
    };
    let scene = opaque_copy("glass_caustic", dir.path());
    let out = dir.path().join("g.exr");
    render(&scene, &out, &["--spp", "8", "--resolution", "40x30", "--passes", LIGHT]);
    let ch = channels(&out);
    for pass in ["Diffuse Direct", "Glossy Color", "Transmission Color", "Transmission Indirect"] {
        assert!(mean(&ch, pass) > 0.0, "glass scene: {pass} is empty");
    }
    assert_eq!(mean(&ch, "Volume Direct"), 0.0, "no medium, yet Volume Direct has light");
    let scene = opaque_copy("cornell_box", dir.path());
    render(&scene, &out, &["--spp", "4", "--resolution", "40x30", "--passes", LIGHT]);
    let ch = channels(&out);
    assert!(mean(&ch, "Emission") > 0.0 && mean(&ch, "Diffuse Indirect") > 0.0);
    // The subsurface scene's glass-bounded medium scatters light seen through its surface
    // (surface first: transmission) and nothing scatters first in a medium at the camera.
    let scene = opaque_copy("subsurface", dir.path());
    render(&scene, &out, &["--spp", "4", "--resolution", "40x30", "--passes", LIGHT]);
    let ch = channels(&out);
    assert!(mean(&ch, "Transmission Indirect") > 0.0 && mean(&ch, "Volume Direct") == 0.0);
}

/// A camera in world fog over a grey floor lit by a point light: light scattered first in
/// the fog is volume light (direct from the light, indirect via the floor), the fog's own
/// emission seen directly is Emission, and everything still sums to Combined.
#[test]
fn volume_passes_in_fog() {
    let dir = temp_dir();
    let mut g = GltfBuilder::new();
    let grey =
        g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0.0}}));
    g.mesh(&[[-5.0, 0.0, -5.0], [5.0, 0.0, -5.0], [5.0, 0.0, 5.0], [-5.0, 0.0, 5.0]], &[0, 2, 1, 0, 3, 2], grey);
    g.camera([0.0, 1.0, 4.0], look_rotation([0.0, -0.3, -1.0]), 0.8);
    g.punctual(
        json!({"type": "point", "intensity": 2000.0, "color": [1, 1, 1]}),
        [0.0, 2.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    );
    g.world(json!({"color": [0, 0, 0], "medium": {
        "density": 0.2, "scatter_color": [1, 1, 1], "absorption_color": [0.2, 0.2, 0.2], "emission": [0.01, 0.01, 0.01]
    }}));
    g.settings(json!({"transparent": false}));
    let path = g.write(dir.path(), "fog.gltf");
    let out = dir.path().join("fog.exr");
    render(&path, &out, &["--spp", "8", "--resolution", "32x24", "--passes", LIGHT]);
    let ch = channels(&out);
    let mean = |pass: &str| -> f64 {
        ["R", "G", "B"].iter().map(|c| ch[&format!("{pass}.{c}")].iter().map(|&v| v as f64).sum::<f64>()).sum()
    };
    for pass in ["Volume Direct", "Volume Indirect", "Emission", "Diffuse Direct"] {
        assert!(mean(pass) > 0.0, "fog: {pass} is empty");
    }
    assert_recombines(&ch, "fog");
}

/// Only Combined and the passes asked for are written: nothing else (memory, and
/// Blender's compositor sees exactly the view layer's passes).
#[test]
fn only_selected_passes_are_written() {
    let dir = temp_dir();
    let scene = root().join("scenes/cornell_box.gltf");
    let out = dir.path().join("a.exr");
    let names = |p: &Path| channels(p).into_keys().collect::<Vec<_>>();
    render(&scene, &out, &["--spp", "1", "--resolution", "16x12", "--passes", "none"]);
    assert_eq!(names(&out), ["Combined.A", "Combined.B", "Combined.G", "Combined.R"]);
    render(&scene, &out, &["--spp", "1", "--resolution", "16x12", "--passes", "Diffuse Direct,z"]);
    let want = ["Combined.A", "Combined.B", "Combined.G", "Combined.R", "Depth.Z"].into_iter().chain([
        "Diffuse Direct.B",
        "Diffuse Direct.G",
        "Diffuse Direct.R",
    ]);
    let mut want: Vec<String> = want.map(String::from).collect();
    want.sort();
    assert_eq!(names(&out), want, "the colour pass is kept for the division, not written");
    // Without --passes: the passes Caustic always wrote.
    render(&scene, &out, &["--spp", "1", "--resolution", "16x12"]);
    assert!(names(&out).contains(&"Denoising Albedo.R".to_string()));
    // Unknown names are refused.
    let bad = run(&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--passes", "difuse"], LIMIT);
    assert_eq!(bad.code, Some(2), "{}", bad.stderr);
    // SPPM writes the light passes too (`sppm_passes.rs`), in chunks as well (their sums
    // as SPPM's Combined: means times iterations, `sppm_passes::into_film`).
    let (s, o) = (scene.to_str().unwrap(), out.to_str().unwrap());
    let sppm = ["render", s, "-o", o, "--passes", "emit", "--integrator", "sppm", "--sppm-iterations", "2"];
    let r = run(&[&sppm[..], &["--resolution", "16x12"]].concat(), LIMIT);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(names(&out).contains(&"Emission.R".to_string()), "{:?}", names(&out));
    let r = run(&[&sppm[..], &["--chunk", "--resolution", "16x12"]].concat(), LIMIT);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let chunk = names(&out);
    assert!(chunk.iter().any(|n| n.starts_with("CausticSum.S33.")), "no Emission sums in the chunk: {chunk:?}");
}

/// A 2 × 2 quad in the plane z = 0 seen straight on by an orthographic camera 10 units
/// away: every ray hits at distance 10, so Mist with start 5 and depth 10, linear, is
/// 0.5 everywhere; Position's z is 0 and its x, y lie on the quad (the nearest hit's, not
/// a mean); UV's A is the
/// coverage 1; nothing occludes the AO rays, so AO is 1.
#[test]
fn data_passes_on_a_known_scene() {
    let dir = temp_dir();
    let mut g = GltfBuilder::new();
    let m = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0.0}}));
    g.mesh(&[[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]], &[0, 1, 2, 0, 2, 3], m);
    let cam = g.camera([0.0, 0.0, 10.0], look_rotation([0.0, 0.0, -1.0]), 0.5);
    let _ = cam;
    g.settings(json!({"mist": [5.0, 10.0, 1.0], "ao_distance": 5.0}));
    let path = g.write(dir.path(), "quad.gltf");
    // Make the camera orthographic, 1.6 × 1.6 units: all of it on the quad.
    let mut doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    doc["cameras"][0] =
        json!({"type": "orthographic", "orthographic": {"xmag": 0.8, "ymag": 0.8, "znear": 0.01, "zfar": 100.0}});
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let out = dir.path().join("d.exr");
    render(&path, &out, &["--spp", "4", "--resolution", "8x8", "--passes", "mist,position,uv,ambient_occlusion"]);
    let ch = channels(&out);
    for v in &ch["Mist.Z"] {
        // (10 − 5) / 10, computed in f32 from a distance rounded at 2^-24 relative.
        assert!((v - 0.5).abs() < 1e-5, "mist {v}");
    }
    for (x, (y, z)) in ch["Position.X"].iter().zip(ch["Position.Y"].iter().zip(&ch["Position.Z"])) {
        // The pixel filter reaches 1.5 px (0.3 units) beyond the frame: still on the quad.
        assert!(z.abs() < 1e-6 && x.abs() <= 1.0 && y.abs() <= 1.0, "position {x} {y} {z}");
    }
    assert!(ch["UV.A"].iter().all(|&a| a == 1.0));
    assert!(ch["Ambient Occlusion.R"].iter().all(|&a| a == 1.0), "{:?}", ch["Ambient Occlusion.R"]);
    assert!(!ch.contains_key("Depth.Z"), "Depth was not asked for");
}

/// Σ over the channels R, G, B and pixels of pass `pass`.
fn pass_total(ch: &BTreeMap<String, Vec<f32>>, pass: &str) -> f64 {
    ["R", "G", "B"].iter().map(|c| ch[&format!("{pass}.{c}")].iter().map(|&v| v as f64).sum::<f64>()).sum()
}

/// Light groups whose emitters are every emitter of the scene sum to Combined, pixel by
/// pixel, and each holds light: an area light and the world (with subsurface exits and a
/// medium), a street of emissive objects split into two groups, an emissive ceiling.
#[test]
fn light_groups_sum_to_combined() {
    let dir = temp_dir();
    let bulbs = |range: std::ops::Range<u32>| range.map(|i| (format!("bulbs{i}"), json!("near")));
    let cases = [
        ("subsurface", json!({"names": ["key", "sky"], "world": "sky", "objects": {"area_light": "key"}})),
        (
            "many_lights",
            json!({"names": ["near", "far"], "objects": bulbs(0..4)
                .chain(bulbs(4..8).map(|(k, _)| (k, json!("far"))))
                .chain([("windows".to_string(), json!("far"))])
                .collect::<serde_json::Map<_, _>>()}),
        ),
        ("cornell_box", json!({"names": ["ceiling"], "objects": {"light": "ceiling"}})),
    ];
    for (name, spec) in cases {
        let scene = opaque_copy(name, dir.path());
        let names: Vec<String> = spec["names"].as_array().unwrap().iter().map(|n| n.as_str().unwrap().into()).collect();
        with_light_groups(&scene, spec);
        let out = dir.path().join(format!("{name}.exr"));
        render(&scene, &out, &["--spp", "8", "--resolution", "40x30", "--passes", "light_groups"]);
        let ch = channels(&out);
        for g in &names {
            assert!(pass_total(&ch, &format!("Combined_{g}")) > 0.0, "{name}: group {g} is empty");
        }
        let mut worst = 0.0f64;
        for c in ["R", "G", "B"] {
            for (i, combined) in ch[&format!("Combined.{c}")].iter().enumerate() {
                let sum: f64 = names.iter().map(|g| ch[&format!("Combined_{g}.{c}")][i] as f64).sum();
                // Each group and Combined add the same f32 contributions (a few dozen per
                // path, 8 paths) in different orders: 2^-24 relative per addition, so
                // 1e-5 of the magnitude bounds the difference with room.
                let tol = 1e-5 * (*combined as f64).abs().max(sum) + 1e-9;
                worst = worst.max((*combined as f64 - sum).abs() / tol);
            }
        }
        assert!(worst <= 1.0, "{name}: the light groups differ from Combined by {worst} × the rounding bound");
    }
}

/// An emitter in no group is in no group pass: with half of the street's bulbs grouped,
/// the group holds part of Combined; light groups are asked of the path tracer only, merge
/// exactly from chunks, and a group the view layer does not have is a bad scene.
#[test]
fn light_groups_leave_out_ungrouped_emitters_merge_from_chunks_and_refuse_bad_requests() {
    let dir = temp_dir();
    let scene = opaque_copy("many_lights", dir.path());
    with_light_groups(&scene, json!({"names": ["some"], "objects": {"bulbs0": "some", "bulbs1": "some"}}));
    let out = dir.path().join("lg.exr");
    render(&scene, &out, &["--spp", "4", "--resolution", "32x24", "--passes", "light_groups"]);
    let ch = channels(&out);
    let (group, combined) = (pass_total(&ch, "Combined_some"), pass_total(&ch, "Combined"));
    assert!(group > 0.0 && group < 0.9 * combined, "group {group}, combined {combined}");
    // Without the token the groups are not written.
    render(&scene, &out, &["--spp", "1", "--resolution", "16x12", "--passes", "none"]);
    assert!(!channels(&out).keys().any(|k| k.starts_with("Combined_")));
    let s = scene.to_str().unwrap();
    let o = out.to_str().unwrap();
    // SPPM writes them too (`sppm_passes.rs`).
    let sppm = ["--passes", "light_groups", "--integrator", "sppm", "--sppm-iterations", "2", "--resolution", "16x12"];
    let r = run(&[&["render", s, "-o", o][..], &sppm[..]].concat(), LIMIT);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let ch = channels(&out);
    let (group, combined) = (pass_total(&ch, "Combined_some"), pass_total(&ch, "Combined"));
    assert!(group > 0.0 && group < 0.9 * combined, "sppm: group {group}, combined {combined}");
    // Chunks carry the groups' sums: two chunks merge into the single render bit for bit.
    let p = |n: &str| dir.path().join(n);
    let lg = ["--resolution", "16x12", "--passes", "light_groups"];
    render(&scene, &p("single.exr"), &[&lg[..], &["--spp", "4"]].concat());
    render(&scene, &p("a.exr"), &[&lg[..], &["--spp", "1", "--chunk"]].concat());
    render(&scene, &p("b.exr"), &[&lg[..], &["--spp", "3", "--sample-offset", "1", "--chunk"]].concat());
    let (a, b, m) = (p("a.exr"), p("b.exr"), p("merged.exr"));
    let r = run(&["merge", a.to_str().unwrap(), b.to_str().unwrap(), "-o", m.to_str().unwrap()], LIMIT);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let (single, merged) = (channels(&p("single.exr")), channels(&m));
    assert!(single.contains_key("Combined_some.R"));
    for (name, v) in &single {
        let w = &merged[name];
        assert!(v.iter().zip(w).all(|(x, y)| x.to_bits() == y.to_bits()), "{name} differs after the merge");
    }
    with_light_groups(&scene, json!({"names": ["some"], "objects": {"bulbs0": "other"}}));
    let bad = run(&["render", s, "-o", o, "--passes", "light_groups"], LIMIT);
    assert_eq!(bad.code, Some(3), "{}", bad.stderr);
    assert!(bad.stderr.contains("'other'"), "{}", bad.stderr);
}
