//! The `objects` request of `caustic serve`: objects added to the running scene and meshes
//! replaced in it render as the scene loaded whole with them, and a payload that cannot be
//! merged gets an error reply while the server goes on with its scene unchanged.

mod common;

use common::serve::{LIMIT, Server, assert_same_image, f32_pixels, frame, generation};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// The Cornell box with only the nodes named `keep` in its scene (all when None), the nodes
/// of `moves` translated, written as `name` in `dir` beside a copy of its buffer.
fn cornell_with(dir: &Path, name: &str, keep: Option<&[&str]>, moves: &[(&str, [f64; 3])]) -> PathBuf {
    let src = common::root().join("scenes/cornell_box.gltf");
    let mut doc: Value = serde_json::from_str(&std::fs::read_to_string(&src).unwrap()).unwrap();
    let node_name =
        |doc: &Value, n: &Value| doc["nodes"][n.as_u64().unwrap() as usize]["name"].as_str().unwrap().to_string();
    if let Some(keep) = keep {
        let kept: Vec<Value> = doc["scenes"][0]["nodes"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|n| keep.contains(&node_name(&doc, n).as_str()))
            .cloned()
            .collect();
        doc["scenes"][0]["nodes"] = Value::Array(kept);
    }
    for node in doc["nodes"].as_array_mut().unwrap() {
        if let Some((_, t)) = moves.iter().find(|(n, _)| node["name"].as_str() == Some(n)) {
            node["translation"] = json!(t);
        }
    }
    let path = dir.join(name);
    std::fs::write(&path, doc.to_string()).unwrap();
    let _ = std::fs::copy(common::root().join("scenes/cornell_box.bin"), dir.join("cornell_box.bin"));
    path
}

/// `caustic render` of `scene` at 4 spp, the Combined values.
fn render(scene: &Path) -> Vec<f32> {
    let img = common::render_image(scene, &scene.with_extension("exr"), &["--spp", "4", "--threads", "2"], LIMIT);
    img.iter().flatten().copied().collect()
}

/// A server rendering `scene` at 4 spp, f32 frames, full resolution from the first frame.
fn serving(scene: &Path) -> Server {
    let mut s = Server::start();
    s.ok(json!({"type": "settings", "spp": 4, "frame_format": "f32", "reduce": 1}));
    s.ok(json!({"type": "load", "path": scene}));
    s.ok(json!({"type": "render_start"}));
    s
}

/// The box loaded without the tall block and the light, then the block added as a payload and
/// the light from a file, renders bit for bit as the box loaded whole: the nodes come last in
/// the file's order too, so triangles, lights (the light's triangles, in the same order) and
/// the samples drawn are the same, and a triangle's hit does not depend on which BVH holds it.
#[test]
fn added_objects_render_as_the_scene_loaded_whole() {
    let dir = common::temp_dir();
    let d = dir.path();
    let walls = ["floor", "ceiling", "back_wall", "red_wall", "green_wall", "short_block", "camera"];
    let base = cornell_with(d, "base.gltf", Some(&walls), &[]);
    let block = cornell_with(d, "block.gltf", Some(&["tall_block"]), &[]);
    let light = cornell_with(d, "light.gltf", Some(&["light"]), &[]);
    let whole = render(&cornell_with(d, "whole.gltf", None, &[]));

    let mut s = serving(&base);
    let bytes = std::fs::read(&block).unwrap();
    s.raw(&frame(&json!({"type": "objects", "bytes": bytes.len(), "base_dir": d}), &bytes));
    let r = s.reply();
    assert_eq!(
        (r["type"].as_str(), &r["added"], &r["replaced"]),
        (Some("ok"), &json!(["tall_block"]), &json!([])),
        "{r}"
    );
    let r = s.ok(json!({"type": "objects", "path": light}));
    assert_eq!((&r["added"], r["triangles"].as_u64()), (&json!(["light"]), Some(32)), "{r}");
    let served = f32_pixels(&s.frame(generation(&r), true).1);
    let differing = served.iter().zip(&whole).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "the merged scene's frame differs from the whole scene's render in {differing} values");
    s.finish();
}

/// A changed mesh sent again replaces the loaded one: the tall block sent moved renders as the
/// box loaded with it there (bit for bit, as above: the old block's triangles are collapsed
/// where the BVH holds them and its new ones found in the side BVH), and a name keeps finding
/// the newest object (a transform edit after the replacement moves the new block).
#[test]
fn a_replaced_mesh_renders_as_loaded_there() {
    let dir = common::temp_dir();
    let d = dir.path();
    let moved_to = [0.06, 0.0, -0.03];
    let moved = cornell_with(d, "moved.gltf", Some(&["tall_block"]), &[("tall_block", moved_to)]);
    let reference = render(&cornell_with(d, "reference.gltf", None, &[("tall_block", moved_to)]));
    let mut s = serving(&cornell_with(d, "box.gltf", None, &[]));
    let r = s.ok(json!({"type": "objects", "path": moved}));
    assert_eq!((&r["added"], &r["replaced"]), (&json!(["tall_block"]), &json!(["tall_block"])), "{r}");
    // The old block's 10 triangles stay in memory (collapsed), reported as retired.
    assert_eq!((r["triangles"].as_u64(), r["retired_triangles"].as_u64()), (Some(42), Some(10)), "{r}");
    let served = f32_pixels(&s.frame(generation(&r), true).1);
    let differing = served.iter().zip(&reference).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "the replaced block's frame differs from the render in {differing} values");
    // Replaced again: the name once among the replaced, both old blocks retired.
    let r = s.ok(json!({"type": "objects", "path": moved}));
    assert_eq!((&r["replaced"], r["retired_triangles"].as_u64()), (&json!(["tall_block"]), Some(20)), "{r}");
    // Away and back by transform edits: the vertices reach their place by other roundings.
    let translate = |t: [f64; 3]| json!([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, t[0], t[1], t[2], 1]);
    s.ok(json!({"type": "transform", "name": "tall_block", "matrix": translate([0.3, 0.0, 0.0])}));
    let g = generation(&s.ok(json!({"type": "transform", "name": "tall_block", "matrix": translate(moved_to)})));
    assert_same_image(&f32_pixels(&s.frame(g, true).1), &reference, "replaced block moved away and back");
    s.finish();
}

/// The light replaced by itself (an edit that leaves the mesh as it was) lights the box as
/// before: the old light's triangles keep their slots as black lights, so light selection
/// differs and the images differ by noise only. The per-pixel differences of two 4-spp
/// renders are independent across pixels, so their mean is held to 4 standard errors of it.
#[test]
fn a_replaced_emitter_lights_as_before() {
    let dir = common::temp_dir();
    let d = dir.path();
    let box_path = cornell_with(d, "box.gltf", None, &[]);
    let reference = render(&box_path);
    let mut s = serving(&box_path);
    let r = s.ok(json!({"type": "objects", "path": cornell_with(d, "light.gltf", Some(&["light"]), &[])}));
    let served = f32_pixels(&s.frame(generation(&r), true).1);
    for c in 0..3 {
        let diff: Vec<f64> = served.chunks(4).zip(reference.chunks(4)).map(|(a, b)| (a[c] - b[c]) as f64).collect();
        let (mean, se) = common::mean_se(&diff);
        assert!(mean.abs() <= 4.0 * se, "channel {c}: mean difference {mean} vs its standard error {se}");
    }
    s.finish();
}

/// Payloads that cannot be merged get an error reply and leave the scene as it was: no scene
/// yet, not glTF, a declared length the payload does not have, a light (lights come by load).
#[test]
fn bad_objects_get_error_replies_and_the_scene_stays() {
    let dir = common::temp_dir();
    let d = dir.path();
    let box_path = cornell_with(d, "box.gltf", None, &[]);
    let mut s = Server::start();
    assert!(s.error_for(&frame(&json!({"type": "objects", "path": box_path}), &[])).contains("no scene loaded"));
    let reference = render(&box_path);
    s.ok(json!({"type": "settings", "spp": 4, "frame_format": "f32", "reduce": 1}));
    s.ok(json!({"type": "load", "path": box_path}));
    s.ok(json!({"type": "render_start"}));
    let junk = b"not a glTF at all";
    let msg = s.error_for(&frame(&json!({"type": "objects", "bytes": junk.len()}), junk));
    assert!(msg.contains("JSON"), "{msg}");
    let msg = s.error_for(&frame(&json!({"type": "objects", "bytes": 99}), junk));
    assert!(msg.contains("truncated payload"), "{msg}");
    assert!(s.error_for(&frame(&json!({"type": "objects"}), &[])).contains("either path or bytes"));
    let mut g = common::GltfBuilder::new();
    let m = g.material(json!({"name": "grey"}));
    g.cube([-0.1, 0.0, -0.1], [0.1, 0.2, 0.1], m);
    g.punctual(json!({"type": "point", "intensity": 10.0}), [0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]);
    let lit = g.write(d, "lit.gltf");
    let msg = s.error_for(&frame(&json!({"type": "objects", "path": lit}), &[]));
    assert!(msg.contains("send load"), "{msg}");
    let g = generation(&s.ok(json!({"type": "render_start"})));
    let served = f32_pixels(&s.frame(g, true).1);
    assert!(served == reference, "a refused merge changed the scene");
    s.finish();
}
