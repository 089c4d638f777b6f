//! `caustic serve` driven over pipes as the add-on drives it: every request kind, bad
//! messages answered with an error while the server goes on serving, edits that change
//! the picture, and a converged served frame against `caustic render` of the scene.

mod common;

use common::GltfBuilder;
use common::serve::{
    LIMIT, Server, assert_same_image, cornell, cornell_without, f32_pixels, frame, generation, mean_rgb,
};
use serde_json::{Value, json};
use std::time::Instant;

/// Every request kind gets its reply, and edits restart the render with frames of the
/// new generation (the first one at reduced resolution).
#[test]
fn every_request_kind_is_served() {
    let mut s = Server::start();
    s.send(json!({"type": "hello", "version": 3}));
    let h = s.reply();
    assert_eq!((h["type"].as_str(), h["version"].as_u64()), (Some("hello"), Some(3)));
    s.ok(json!({"type": "settings", "spp": 4, "frame_format": "f32", "max_depth": 4}));
    let loaded = s.ok(json!({"type": "load", "path": cornell()}));
    assert_eq!(loaded["triangles"], 32);
    assert!(loaded["objects"].as_array().unwrap().iter().any(|o| o == "tall_block"));
    let g = generation(&s.ok(json!({"type": "render_start"})));
    let (first, _) = s.frame(g, false);
    assert_eq!((first["reduced"].as_bool(), first["width"].as_u64()), (Some(true), Some(64)), "{first}");
    let (full, px) = s.frame(g, true);
    assert_eq!((full["width"].as_u64(), full["samples"].as_u64()), (Some(256), Some(4)));
    let before = mean_rgb(&f32_pixels(&px));

    // A camera of 320x180 with a border: the frame covers the border's pixels.
    let cam = json!({"type": "camera", "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,1,3.9,1],
        "projection": "perspective", "yfov": 0.69, "resolution": [320, 180], "border": [0.25, 0.0, 0.75, 0.5]});
    let g = generation(&s.ok(cam));
    let (f, p) = s.frame(g, true);
    assert_eq!(f["window"], json!([80, 0, 240, 90]));
    assert_eq!(p.len(), 160 * 90 * 4 * 4);

    // Scene edits, each against the scene camera's view of a fresh server.
    let mut s2 = Server::start();
    s2.ok(json!({"type": "settings", "spp": 4, "frame_format": "f32", "max_depth": 4, "reduce": 1}));
    s2.ok(json!({"type": "load", "path": cornell()}));
    s2.ok(json!({"type": "render_start"}));
    let g = generation(&s2.ok(json!({"type": "material", "name": "white", "base_color": [0.2, 0.2, 0.2, 1.0]})));
    let darker = mean_rgb(&f32_pixels(&s2.frame(g, true).1));
    assert!(darker[1] < 0.8 * before[1], "a darker white did not darken the box: {darker:?} vs {before:?}");
    let g = generation(&s2.ok(json!({"type": "transform", "name": "tall_block",
        "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,-10,0,1]})));
    let (f, _) = s2.frame(g, true);
    assert_eq!(f["samples"], 4);
    let g = generation(&s2.ok(json!({"type": "world", "color": [0.5, 0.5, 0.5]})));
    let lit = mean_rgb(&f32_pixels(&s2.frame(g, true).1));
    assert!(lit[2] > darker[2], "a grey world did not brighten the box: {lit:?} vs {darker:?}");
    s2.ok(json!({"type": "render_stop"}));
    s2.send(json!({"type": "quit"}));
    assert_eq!(s2.reply()["request"], "quit");
    s2.finish();

    // Settings and loads of a scene given as the payload.
    let bytes = std::fs::read(common::root().join("scenes/cornell_box.gltf")).unwrap();
    let hdr = json!({"type": "load", "bytes": bytes.len(), "base_dir": common::root().join("scenes")});
    s.raw(&frame(&hdr, &bytes));
    let r = s.reply();
    assert_eq!(r["type"], "ok", "{r}");
    s.ok(json!({"type": "settings", "integrator": "photon", "spp": 2}));
    s.finish();
}

/// Light edits: a point light's emission scales the picture linearly (the only light; the
/// same samples are taken, so the ratio is 2 up to the f32 rounding of each sample, far
/// below the 1e-4 allowed), moving it away darkens it, and a black world changes nothing; a
/// negative emission (Blender's power turned negative) negates the picture, as Cycles
/// renders a negative light, and a non-finite one is refused.
#[test]
fn light_edits_change_the_picture() {
    let dir = common::temp_dir();
    let mut g = GltfBuilder::new();
    let m = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0}}));
    g.mesh(&[[-2.0, 0.0, -2.0], [2.0, 0.0, -2.0], [2.0, 0.0, 2.0], [-2.0, 0.0, 2.0]], &[0, 2, 1, 0, 3, 2], m);
    g.camera([0.0, 1.0, 4.0], common::look_rotation([0.0, -0.3, -1.0]), 0.8);
    let light = g.punctual(json!({"type": "point", "intensity": 50.0}), [0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]);
    g.settings(json!({"resolution": [64, 48], "spp": 2}));
    let path = g.write(dir.path(), "lit.gltf");
    let mut s = Server::start();
    s.ok(json!({"type": "settings", "frame_format": "f32", "reduce": 1}));
    let loaded = s.ok(json!({"type": "load", "path": path}));
    let name = format!("node {light}");
    assert_eq!(loaded["lights"][0]["name"], name.as_str(), "{loaded}");
    s.ok(json!({"type": "render_start"}));
    let mean_after = |s: &mut Server, req: Value| {
        let g = generation(&s.ok(req));
        mean_rgb(&f32_pixels(&s.frame(g, true).1))
    };
    let a = mean_after(&mut s, json!({"type": "light", "name": name, "emission": [1.0, 1.0, 1.0]}));
    let b = mean_after(&mut s, json!({"type": "light", "name": name, "emission": [2.0, 2.0, 2.0]}));
    let c = mean_after(&mut s, json!({"type": "world", "color": [0.0, 0.0, 0.0]}));
    let far = mean_after(
        &mut s,
        json!({"type": "light", "name": name,
        "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,3,0,1]}),
    );
    let negative = mean_after(&mut s, json!({"type": "light", "name": name, "emission": [-2.0, -2.0, -2.0]}));
    // 1e39 is past f32: the edit reads it as infinite (JSON has no NaN or infinity).
    s.send(json!({"type": "light", "name": name, "emission": [1e39, 1.0, 1.0]}));
    let r = s.reply();
    assert!(r["type"] == "error" && r["message"].as_str().unwrap().contains("finite"), "{r}");
    for ch in 0..3 {
        assert!(a[ch] > 0.0);
        assert!((b[ch] / a[ch] - 2.0).abs() < 1e-4, "emission ×2 gave ×{}", b[ch] / a[ch]);
        assert_eq!(b[ch], c[ch], "a black world changed the picture");
        assert!(far[ch] < b[ch], "a light moved from 1 to 3 above the floor did not darken it");
        assert!((negative[ch] / far[ch] + 1.0).abs() < 1e-4, "emission ×−1 gave ×{}", negative[ch] / far[ch]);
    }
    s.finish();
}

/// Malformed header, unknown type, truncated payload, bad JSON, wrong fields, edits
/// before a load: each gets an error reply and the server keeps serving.
#[test]
fn bad_messages_get_error_replies_and_the_server_goes_on() {
    let mut s = Server::start();
    let cases: Vec<(Vec<u8>, &str)> = vec![
        (frame(&json!({"type": "frobnicate"}), &[]), "unknown variant"),
        (frame(&json!({"no_type": 1}), &[]), "missing field `type`"),
        (frame(&json!([1, 2]), &[]), "bad request"),
        (
            {
                let mut m = 5u32.to_le_bytes().to_vec();
                m.extend_from_slice(&0u32.to_le_bytes());
                m.extend_from_slice(b"{bad}");
                m
            },
            "not JSON",
        ),
        (frame(&json!({"type": "load", "bytes": 100}), b"only twenty bytes...."), "truncated payload"),
        (frame(&json!({"type": "hello", "version": 99}), &[]), "protocol version 99"),
        (frame(&json!({"type": "render_start"}), &[]), "no scene loaded"),
        (frame(&json!({"type": "material", "name": "white", "metallic": 0.5}), &[]), "no scene loaded"),
        (frame(&json!({"type": "quit"}), b"xx"), "unexpected payload"),
        (frame(&json!({"type": "camera", "matrix": [1], "projection": "perspective"}), &[]), "bad request"),
        (frame(&json!({"type": "settings", "integrator": "sppm"}), &[]), "SPPM"),
        (frame(&json!({"type": "settings", "spp": 0}), &[]), "spp"),
        (frame(&json!({"type": "load", "path": "/nonexistent/scene.gltf"}), &[]), "nonexistent"),
    ];
    for (bytes, want) in &cases {
        let msg = s.error_for(bytes);
        assert!(msg.contains(want), "error '{msg}' does not say '{want}'");
    }
    // Still serving: a load, then edits that are refused for a reason.
    s.ok(json!({"type": "settings", "spp": 1}));
    s.ok(json!({"type": "load", "path": cornell()}));
    for (req, want) in [
        (json!({"type": "settings", "integrator": "sppm"}), "SPPM"),
        (json!({"type": "material", "name": "nope", "roughness": 0.5}), "no material named 'nope'"),
        (json!({"type": "material", "name": "white", "roughness": 2.0}), "roughness 2 must be in [0, 1]"),
        (
            json!({"type": "transform", "name": "nope", "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}),
            "no mesh object",
        ),
        (json!({"type": "transform", "name": "floor", "matrix": [-1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}), "mirrors"),
        (json!({"type": "light", "name": "nope", "emission": [1, 1, 1]}), "no light named"),
        (json!({"type": "world", "color": [-1, 0, 0]}), "non-negative"),
        (
            json!({"type": "camera", "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], "projection": "fisheye",
            "resolution": [8, 8]}),
            "unknown projection",
        ),
        (
            json!({"type": "camera", "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], "projection": "perspective",
            "yfov": 0.5, "resolution": [0, 8]}),
            "resolution 0x8",
        ),
    ] {
        s.send(req.clone());
        let r = s.reply();
        assert_eq!(r["type"], "error", "{req} was accepted");
        assert!(r["message"].as_str().unwrap().contains(want), "error {r} does not say '{want}'");
    }
    let g = generation(&s.ok(json!({"type": "render_start"})));
    s.frame(g, true);
    // A payload cut short by the end of the input: an error reply, then a clean exit.
    let mut cut = frame(&json!({"type": "load", "bytes": 1000}), &[0u8; 1000]);
    cut.truncate(cut.len() - 10);
    s.raw(&cut);
    s.close_input();
    let r = s.reply();
    assert!(r["message"].as_str().unwrap().contains("truncated"), "{r}");
    s.finish();
}

/// A length prefix beyond the limit cannot be skipped: an error reply, then the server
/// ends cleanly instead of waiting for a gigabyte that never comes.
#[test]
fn an_absurd_length_prefix_closes_the_stream_with_an_error() {
    let mut s = Server::start();
    s.raw(&[0xff, 0xff, 0xff, 0x7f, 0, 0, 0, 0]);
    let r = s.reply();
    assert!(r["message"].as_str().unwrap().contains("exceeds the limit"), "{r}");
    s.finish();
}

/// The converged served frame of the scene's own view is `caustic render`'s image: the
/// server renders through the same driver with the same seed, so pixel (x, y) takes the
/// same samples (seed, x, y, i), and the film's fixed-point sums do not depend on the
/// order of passes. The means then agree exactly; the bound below allows f32 rounding of
/// a mean of 256² values (≈ 1e-7 relative per addition, summed in f64: far below 1e-6).
#[test]
fn a_converged_frame_matches_caustic_render() {
    let dir = common::temp_dir();
    let out = dir.path().join("cornell.exr");
    let scene = common::root().join("scenes/cornell_box.gltf");
    let reference = common::render_image(&scene, &out, &["--spp", "8", "--threads", "2"], LIMIT);
    let mut s = Server::start();
    s.ok(json!({"type": "settings", "spp": 8, "frame_format": "f32"}));
    s.ok(json!({"type": "load", "path": scene}));
    let g = generation(&s.ok(json!({"type": "render_start"})));
    let (h, p) = s.frame(g, true);
    assert_eq!((h["width"].as_u64(), h["height"].as_u64(), h["samples"].as_u64()), (Some(256), Some(256), Some(8)));
    let served = f32_pixels(&p);
    let flat: Vec<f32> = reference.iter().flatten().copied().collect();
    let (a, b) = (mean_rgb(&served), mean_rgb(&flat));
    for c in 0..3 {
        assert!((a[c] - b[c]).abs() <= 1e-6 * b[c], "channel {c}: served {} vs render {}", a[c], b[c]);
    }
    let differing = served.iter().zip(&flat).filter(|(x, y)| x != y).count();
    assert_eq!(differing, 0, "the served frame differs from the render in {differing} values");
    s.finish();
}

/// Objects moved by transform edits render as the same scene loaded with them there: the
/// served frame against `caustic render` of a copy of the Cornell box whose blocks sit at
/// the moved places. The vertices reach their places by different float roundings (the
/// load applies the node's matrix once; the edit carries loaded vertices by new · old⁻¹),
/// so every path meeting a block continues from a point a few ulps away (`assert_same_image`).
#[test]
fn moved_objects_render_as_loaded_there() {
    let dir = common::temp_dir();
    let src = common::root().join("scenes/cornell_box.gltf");
    let mut doc: Value = serde_json::from_str(&std::fs::read_to_string(&src).unwrap()).unwrap();
    let (tall, short) = ([0.06, 0.0, -0.03], [-0.05, 0.02, 0.04]);
    for node in doc["nodes"].as_array_mut().unwrap() {
        match node["name"].as_str() {
            Some("tall_block") => node["translation"] = json!(tall),
            Some("short_block") => node["translation"] = json!(short),
            _ => {}
        }
    }
    let moved = dir.path().join("moved.gltf");
    std::fs::write(&moved, doc.to_string()).unwrap();
    std::fs::copy(common::root().join("scenes/cornell_box.bin"), dir.path().join("cornell_box.bin")).unwrap();
    let reference =
        common::render_image(&moved, &dir.path().join("moved.exr"), &["--spp", "4", "--threads", "2"], LIMIT);
    let mut s = Server::start();
    s.ok(json!({"type": "settings", "spp": 4, "frame_format": "f32"}));
    s.ok(json!({"type": "load", "path": src}));
    s.ok(json!({"type": "render_start"}));
    let translate = |t: [f64; 3]| json!([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, t[0], t[1], t[2], 1]);
    // The tall block twice (the second edit starts from the first), then the short one.
    s.ok(json!({"type": "transform", "name": "tall_block", "matrix": translate([0.2, 0.0, 0.0])}));
    s.ok(json!({"type": "transform", "name": "tall_block", "matrix": translate(tall)}));
    let g = generation(&s.ok(json!({"type": "transform", "name": "short_block", "matrix": translate(short)})));
    let served = f32_pixels(&s.frame(g, true).1);
    let flat: Vec<f32> = reference.iter().flatten().copied().collect();
    assert_same_image(&served, &flat, "moved blocks");
    s.finish();
}

/// Hiding an object renders the scene without it (its emission too: hiding the box's only
/// light leaves it black), and showing it again renders it as loaded.
#[test]
fn hidden_objects_render_as_left_out() {
    let dir = common::temp_dir();
    let without_block = cornell_without(dir.path(), &["tall_block"]);
    let without_light = cornell_without(dir.path(), &["light"]);
    let full = cornell_without(dir.path(), &[]);
    let mut s = Server::start();
    s.ok(json!({"type": "settings", "spp": 4, "frame_format": "f32"}));
    s.ok(json!({"type": "load", "path": common::root().join("scenes/cornell_box.gltf")}));
    s.ok(json!({"type": "render_start"}));
    let g = generation(&s.ok(json!({"type": "visibility", "name": "tall_block", "visible": false})));
    assert_same_image(&f32_pixels(&s.frame(g, true).1), &without_block, "tall block hidden");
    let g = generation(&s.ok(json!({"type": "visibility", "name": "tall_block", "visible": true})));
    assert_same_image(&f32_pixels(&s.frame(g, true).1), &full, "tall block shown again");
    let g = generation(&s.ok(json!({"type": "visibility", "name": "light", "visible": false})));
    let dark = f32_pixels(&s.frame(g, true).1);
    assert!(mean_rgb(&without_light).iter().all(|&c| c == 0.0), "the box has another light");
    assert!(mean_rgb(&dark).iter().all(|&c| c == 0.0), "a hidden emitter still lights: {:?}", mean_rgb(&dark));
    let g = generation(&s.ok(json!({"type": "visibility", "name": "light", "visible": true})));
    assert_same_image(&f32_pixels(&s.frame(g, true).1), &full, "light shown again");
    assert!(
        s.error_for(&frame(&json!({"type": "visibility", "name": "nope", "visible": false}), &[])).contains("nope")
    );
    s.finish();
}

/// The photon map is traced once and kept across camera moves: the first frame after a
/// camera edit arrives far sooner than the first frame after the load, which traced it.
#[test]
fn photon_maps_survive_camera_moves() {
    let mut s = Server::start();
    s.ok(json!({"type": "settings", "integrator": "photon", "spp": 1, "reduce": 1}));
    s.ok(json!({"type": "load", "path": cornell()}));
    let t = Instant::now();
    let g = generation(&s.ok(json!({"type": "render_start"})));
    s.frame(g, true);
    let with_trace = t.elapsed();
    let cam = json!({"type": "camera", "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,1,3.9,1],
        "projection": "perspective", "yfov": 0.69, "resolution": [256, 256]});
    let t = Instant::now();
    let g = generation(&s.ok(cam));
    s.frame(g, true);
    let without = t.elapsed();
    s.finish();
    // The default map (photons from PhotonSettings) costs far more than a 1-spp pass of
    // 256² pixels; if it were retraced, the second render would take as long as the first.
    assert!(without < with_trace, "camera move {without:?} vs first render {with_trace:?}");
}
