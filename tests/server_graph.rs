//! The `material_graph` request of `caustic serve`: a node-graph material's new graph,
//! applied in place, renders bit for bit as the scene loaded with that graph; a graph the
//! running scene cannot take (malformed, an image it does not hold, emission where it has
//! no lights, an attribute it did not keep) gets an error reply and the scene stays as it was.

mod common;

use common::serve::{Server, f32_pixels, frame, generation};
use common::{GltfBuilder, look_rotation, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// A floor coloured by a Noise Texture of `scale` and a ceiling quad whose emission is a
/// second noise of `scale` times `strength`: a varying emission, so the lights' powers come
/// from the graph's mean (`mean_node_emission`).
fn graphs(scale: f64, strength: f64) -> (Value, Value) {
    let floor = json!({"version": 1, "output": {"surface": [2, "BSDF"]}, "nodes": [
        {"name": "Geometry", "type": "ShaderNodeNewGeometry"},
        {"name": "Noise", "type": "ShaderNodeTexNoise",
         "props": {"noise_dimensions": "3D", "noise_type": "FBM", "normalize": true},
         "inputs": {"Vector": {"link": [0, "Position"]}, "Scale": {"value": scale}, "Detail": {"value": 2.0},
                    "Roughness": {"value": 0.5}, "Lacunarity": {"value": 2.0}, "Distortion": {"value": 0.0}}},
        {"name": "Diffuse", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"link": [1, "Color"]}}}
    ]});
    let lamp = json!({"version": 1, "output": {"surface": [3, "Emission"]}, "nodes": [
        {"name": "Geometry", "type": "ShaderNodeNewGeometry"},
        {"name": "Noise", "type": "ShaderNodeTexNoise",
         "props": {"noise_dimensions": "3D", "noise_type": "FBM", "normalize": true},
         "inputs": {"Vector": {"link": [0, "Position"]}, "Scale": {"value": scale}, "Detail": {"value": 1.0},
                    "Roughness": {"value": 0.5}, "Lacunarity": {"value": 2.0}, "Distortion": {"value": 0.0}}},
        {"name": "Strength", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
         "inputs": {"Value": {"link": [1, "Fac"]}, "Value_001": {"value": strength}}},
        {"name": "Emission", "type": "ShaderNodeEmission",
         "inputs": {"Color": {"value": [1, 0.9, 0.8, 1]}, "Strength": {"link": [2, "Value"]}}}
    ]});
    (floor, lamp)
}

/// The scene with the graphs of `graphs(scale, strength)` and a grey plain material, as `name`.
fn scene(dir: &Path, name: &str, scale: f64, strength: f64) -> PathBuf {
    let (floor, lamp) = graphs(scale, strength);
    let mut g = GltfBuilder::new();
    g.use_ext("CAUSTIC_materials_nodes");
    let node = |n: &str, v: Value| json!({"name": n, "extensions": {"CAUSTIC_materials_nodes": v}});
    let f = g.material(node("floor", floor));
    let l = g.material(node("lamp", lamp));
    let grey = g.material(json!({"name": "grey", "pbrMetallicRoughness": {"metallicFactor": 0.0}}));
    g.mesh(&[[-2.0, 0.0, -2.0], [2.0, 0.0, -2.0], [2.0, 0.0, 2.0], [-2.0, 0.0, 2.0]], &[0, 2, 1, 0, 3, 2], f);
    g.mesh(&[[-1.0, 2.0, -1.0], [1.0, 2.0, -1.0], [1.0, 2.0, 1.0], [-1.0, 2.0, 1.0]], &[0, 1, 2, 0, 2, 3], l);
    g.cube([-0.3, 0.0, -0.3], [0.3, 0.6, 0.3], grey);
    g.camera([0.0, 1.2, 4.0], look_rotation([0.0, -0.3, -1.0]), 0.9);
    g.settings(json!({"resolution": [48, 32]}));
    g.write(dir, name)
}

/// A server rendering `path` at 4 spp, f32 frames, full resolution from the first frame.
fn serving(path: &Path) -> Server {
    let mut s = Server::start();
    s.ok(json!({"type": "settings", "spp": 4, "frame_format": "f32", "reduce": 1}));
    s.ok(json!({"type": "load", "path": path}));
    s.ok(json!({"type": "render_start"}));
    s
}

/// The newest frame after `reply`'s generation has converged.
fn converged(s: &Server, reply: &Value) -> Vec<f32> {
    f32_pixels(&s.frame(generation(reply), true).1)
}

/// Both graphs edited in place (scale 3 → 7, the lamp's strength 2 → 5) render bit for bit
/// as the scene loaded with the edited graphs: the same programs, the same emission
/// estimate and light powers, the same BVH answers.
#[test]
fn a_graph_edit_renders_as_the_scene_loaded_with_it() {
    let dir = temp_dir();
    let before = scene(dir.path(), "before.gltf", 3.0, 2.0);
    let after = scene(dir.path(), "after.gltf", 7.0, 5.0);
    let mut fresh = serving(&after);
    let r = fresh.ok(json!({"type": "render_start"}));
    let reference = converged(&fresh, &r);
    fresh.finish();
    let mut s = serving(&before);
    let r = s.ok(json!({"type": "render_start"}));
    let old = converged(&s, &r);
    assert!(old != reference, "the edit must change the picture for the test to mean anything");
    let (floor, lamp) = graphs(7.0, 5.0);
    s.ok(json!({"type": "material_graph", "name": "floor", "nodes": floor}));
    let r = s.ok(json!({"type": "material_graph", "name": "lamp", "nodes": lamp}));
    assert!(r["warnings"].as_array().unwrap().iter().any(|w| w.as_str().unwrap().contains("'lamp'")), "{r}");
    let served = converged(&s, &r);
    assert!(served == reference, "the edited graphs differ from the scene loaded with them");
    s.finish();
}

/// Malformed graphs, unknown materials, a plain material, an image the scene does not hold,
/// emission on a material without lights and an attribute read by name that the loaded mesh
/// does not keep are refused; the picture stays as loaded.
#[test]
fn refused_graphs_leave_the_scene_unchanged() {
    let dir = temp_dir();
    let path = scene(dir.path(), "box.gltf", 3.0, 2.0);
    let mut s = serving(&path);
    let r = s.ok(json!({"type": "render_start"}));
    let reference = converged(&s, &r);
    let (floor, _) = graphs(5.0, 1.0);
    let edit = |name: &str, nodes: Value| frame(&json!({"type": "material_graph", "name": name, "nodes": nodes}), &[]);
    let mut image = floor.clone();
    image["images"] = json!([{"uri": "caustic_nodes/missing.png", "colorspace": "sRGB"}]);
    let (_, lamp) = graphs(5.0, 1.0);
    let mut cyclic = floor.clone();
    cyclic["nodes"][0]["inputs"] = json!({"Vector": {"link": [1, "Color"]}});
    // The floor's noise scaled by an attribute the loaded graphs did not read (the mesh kept none).
    let mut wet = floor.clone();
    wet["nodes"].as_array_mut().unwrap().push(json!({"name": "Wet", "type": "ShaderNodeAttribute",
        "props": {"attribute_name": "wet", "attribute_type": "GEOMETRY"}}));
    wet["nodes"][1]["inputs"]["Scale"] = json!({"link": [3, "Fac"]});
    let cases = [
        (edit("floor", json!({"version": 1, "nodes": "x"})), "CAUSTIC_materials_nodes is malformed"),
        (edit("floor", json!({"version": 1, "nodes": [], "output": {}, "extra": 1})), "malformed"),
        (edit("floor", cyclic), "material 'floor': CAUSTIC_materials_nodes:"),
        (edit("nowhere", floor.clone()), "no material named 'nowhere'"),
        (edit("grey", floor.clone()), "send load"),
        (edit("floor", image), "not in the loaded scene; send load"),
        (edit("floor", lamp), "no lights; send load"),
        (edit("floor", wet), "reads attribute 'wet', which the loaded mesh was not given; send load"),
    ];
    for (bytes, want) in cases {
        let msg = s.error_for(&bytes);
        assert!(msg.contains(want), "{msg} (want {want})");
    }
    let r = s.ok(json!({"type": "render_start"}));
    let served = converged(&s, &r);
    assert!(served == reference, "a refused graph changed the scene");
    s.finish();
}

/// The only emitter's graph turned black: its triangles stay lights of power 0 (no light index
/// moves), the frame renders black without a panic, and turning it back on restores the
/// picture as loaded, bit for bit.
#[test]
fn an_emitter_turned_off_and_on_again_renders_as_loaded() {
    let dir = temp_dir();
    let path = scene(dir.path(), "box.gltf", 3.0, 2.0);
    let mut s = serving(&path);
    let r = s.ok(json!({"type": "render_start"}));
    let reference = converged(&s, &r);
    let (_, black) = graphs(3.0, 0.0);
    let r = s.ok(json!({"type": "material_graph", "name": "lamp", "nodes": black}));
    let dark = converged(&s, &r);
    assert!(dark.chunks(4).all(|p| p[..3] == [0.0; 3]), "nothing emits, yet the frame is not black");
    let (_, lamp) = graphs(3.0, 2.0);
    let r = s.ok(json!({"type": "material_graph", "name": "lamp", "nodes": lamp}));
    assert!(converged(&s, &r) == reference, "the emitter turned on again differs from the loaded one");
    s.finish();
}
