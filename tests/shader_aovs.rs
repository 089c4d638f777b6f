//! Shader AOVs (AOV Output nodes, `--passes shader_aovs`): the values a graph computes at
//! the camera ray's hit, with Blender's channels; Cycles' rule for transparent surfaces
//! (written up to the first surface at least as opaque as the Alpha Threshold); every
//! per-sample integrator writes them; chunks merge bit for bit; bad lists are refused.

mod common;

use common::{GltfBuilder, run, temp_dir};
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);

fn channels(path: &Path) -> BTreeMap<String, Vec<f32>> {
    let image = exr::prelude::read_all_flat_layers_from_file(path).expect("read EXR");
    let layer = &image.layer_data[0];
    layer.channel_data.list.iter().map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect())).collect()
}

fn render(scene: &Path, out: &Path, extra: &[&str]) -> BTreeMap<String, Vec<f32>> {
    let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"];
    args.extend_from_slice(extra);
    let r = run(&args, LIMIT);
    assert_eq!(r.code, Some(0), "render failed: {}", r.stderr);
    channels(out)
}

fn node_material(name: &str, nodes: Value, surface: Value) -> Value {
    json!({"name": name, "extensions": {"CAUSTIC_materials_nodes":
        {"version": 1, "nodes": nodes, "output": {"surface": surface}}}})
}

/// The quad z = `z`, [-1, 1]² (glTF axes), with material `m`.
fn quad(g: &mut GltfBuilder, z: f32, m: usize) {
    g.mesh(&[[-1., -1., z], [1., -1., z], [1., 1., z], [-1., 1., z]], &[0, 1, 2, 0, 2, 3], m);
}

/// The view layer's AOVs: a colour "pos" and a value "val" (and `extra`).
fn aov_settings(extra: Value, threshold: f32) -> Value {
    let mut aovs = vec![json!({"name": "pos", "type": "COLOR"}), json!({"name": "val", "type": "VALUE"})];
    if let Value::Array(more) = extra {
        aovs.extend(more);
    }
    json!({"filter": "box", "filter_width": 0.001, "transparent": false,
           "shader_aovs": {"aovs": aovs, "alpha_threshold": threshold}})
}

/// One quad filling an orthographic frame, seen from +Z; its graph writes the Geometry
/// Position to "pos" and 2 × (the Position's average) to "val" through a Math node that
/// only the AOV reads; an AOV Output naming an AOV the view layer lacks is warned.
fn position_scene(dir: &Path) -> PathBuf {
    let mut g = GltfBuilder::new();
    let m = g.material(node_material("plane", position_nodes(), json!([1, "Emission"])));
    quad(&mut g, 0.0, m);
    g.orthographic([0.0, 0.0, 5.0], [0.0, 0.0, 0.0, 1.0], 1.0, 1.0);
    g.use_ext("CAUSTIC_materials_nodes");
    g.settings(aov_settings(json!([{"name": "unwritten", "type": "COLOR"}]), 0.5));
    g.write(dir, "pos.gltf")
}

/// The nodes of `position_scene`'s material.
fn position_nodes() -> Value {
    json!([
        {"name": "Geometry", "type": "ShaderNodeNewGeometry"},
        {"name": "Emission", "type": "ShaderNodeEmission",
         "inputs": {"Color": {"value": [0.5, 0.5, 0.5, 1]}, "Strength": {"value": 1.0}}},
        {"name": "Twice", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
         "inputs": {"Value": {"link": [0, "Position"]}, "Value_001": {"value": 2.0}}},
        {"name": "AOV pos", "type": "ShaderNodeOutputAOV", "props": {"aov_name": "pos"},
         "inputs": {"Color": {"link": [0, "Position"]}, "Value": {"value": 0.0}}},
        {"name": "AOV val", "type": "ShaderNodeOutputAOV", "props": {"aov_name": "val"},
         "inputs": {"Value": {"link": [2, "Value"]}}},
        {"name": "AOV ghost", "type": "ShaderNodeOutputAOV", "props": {"aov_name": "ghost"},
         "inputs": {"Value": {"value": 1.0}}}
    ])
}

/// At each pixel centre the AOVs hold the graph's values: "pos" = the position in
/// Blender's axes (x, −z, y) with alpha 1, "val" = 2 × its average; an AOV that no node
/// writes is 0; Combined is unchanged by asking for AOVs; a node naming an AOV the view
/// layer lacks is named in a warning. Every integrator gives the same values (SPPM from its
/// iterations' camera rays, `sppm_extras.rs`).
#[test]
fn aovs_hold_the_graph_values() {
    let dir = temp_dir();
    let scene = position_scene(dir.path());
    let out = dir.path().join("o.exr");
    let res = 8usize;
    let plain = render(&scene, &out, &["--resolution", "8x8", "--spp", "2", "--passes", "none"]);
    assert!(!plain.keys().any(|k| k.starts_with("pos.") || k.starts_with("val.")));
    for integrator in ["path", "bdpt", "photon", "vcm", "sppm"] {
        let args = [
            "--resolution",
            "8x8",
            "--spp",
            "2",
            "--sppm-iterations",
            "2",
            "--passes",
            "shader_aovs",
            "--integrator",
            integrator,
        ];
        let r =
            run(&[&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap()][..], &args[..]].concat(), LIMIT);
        assert_eq!(r.code, Some(0), "{integrator}: {}", r.stderr);
        assert!(r.stderr.contains("'AOV ghost'") && r.stderr.contains("'ghost'"), "{}", r.stderr);
        let ch = channels(&out);
        for name in ["pos.R", "pos.G", "pos.B", "pos.A", "val.X", "unwritten.R", "unwritten.A"] {
            assert!(ch.contains_key(name), "{integrator}: no {name} in {:?}", ch.keys().collect::<Vec<_>>());
        }
        if integrator == "path" {
            assert_eq!(ch["Combined.R"], plain["Combined.R"], "asking for AOVs changed Combined");
        }
        for py in 0..res {
            for px in 0..res {
                let i = py * res + px;
                // Pixel centres: x = −1 + (px + ½)·2/8, y = 1 − (py + ½)·2/8 (top row first).
                let x = -1.0 + (px as f32 + 0.5) * 2.0 / res as f32;
                let y = 1.0 - (py as f32 + 0.5) * 2.0 / res as f32;
                // The samples lie within 0.0005 px (the box filter) = 1.25e-4 in x and y of
                // the centre; the hit point's f32 rounding is far below that.
                let tol = 2e-4;
                let want = [x, 0.0, y];
                for (k, c) in ["pos.R", "pos.G", "pos.B"].iter().enumerate() {
                    assert!(
                        (ch[*c][i] - want[k]).abs() < tol,
                        "{integrator} ({px}, {py}) {c}: {} vs {}",
                        ch[*c][i],
                        want[k]
                    );
                }
                assert_eq!(ch["pos.A"][i], 1.0);
                // 2 × the average of (x, 0, y): the Math node converts the vector by its mean.
                let v = 2.0 * (x + y) / 3.0;
                assert!((ch["val.X"][i] - v).abs() < tol, "{integrator} val ({px}, {py}): {} vs {v}", ch["val.X"][i]);
                assert_eq!((ch["unwritten.R"][i], ch["unwritten.A"][i]), (0.0, 0.0));
            }
        }
    }
}

/// A front quad whose Transparent weight is `1 − alpha` over a back quad; the front writes
/// "val" = 1 and "pos" = black, the back "val" = 2 and "pos" = (0, 1, 0).
fn layered_scene(dir: &Path, alpha: f32, threshold: f32) -> PathBuf {
    let layer = |value: f32, colour: [f32; 4], alpha: f32| {
        json!([
            {"name": "Emission", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"value": [1, 1, 1, 1]}, "Strength": {"value": 1.0}}},
            {"name": "Transparent", "type": "ShaderNodeBsdfTransparent", "inputs": {"Color": {"value": [1, 1, 1, 1]}}},
            {"name": "Mix", "type": "ShaderNodeMixShader",
             "inputs": {"Fac": {"value": 1.0 - alpha}, "Shader": {"link": [0, "Emission"]}, "Shader_001": {"link": [1, "BSDF"]}}},
            {"name": "AOV val", "type": "ShaderNodeOutputAOV", "props": {"aov_name": "val"},
             "inputs": {"Value": {"value": value}}},
            {"name": "AOV pos", "type": "ShaderNodeOutputAOV", "props": {"aov_name": "pos"},
             "inputs": {"Color": {"value": colour}}}
        ])
    };
    let mut g = GltfBuilder::new();
    let front = g.material(node_material("front", layer(1.0, [0.0; 4], alpha), json!([2, "Shader"])));
    let back = g.material(node_material("back", layer(2.0, [0.0, 1.0, 0.0, 1.0], 1.0), json!([2, "Shader"])));
    quad(&mut g, 0.0, front);
    quad(&mut g, -1.0, back);
    g.orthographic([0.0, 0.0, 5.0], [0.0, 0.0, 0.0, 1.0], 1.0, 1.0);
    g.use_ext("CAUSTIC_materials_nodes");
    g.settings(aov_settings(json!([]), threshold));
    g.write(dir, &format!("layers{alpha}_{threshold}.gltf"))
}

/// Cycles' rule behind transparent surfaces: a front surface less opaque than the threshold
/// lets the camera ray write the surface behind it whenever the path passes it (probability
/// 1 − alpha); one at least as opaque ends the writing.
#[test]
fn transparent_surfaces_follow_the_alpha_threshold() {
    let dir = temp_dir();
    let out = dir.path().join("o.exr");
    let spp = 64;
    let args = ["--resolution", "8x8", "--spp", "64", "--passes", "shader_aovs"];
    // alpha 0.3 < 0.5: val = 1 + 2 (1 − alpha); pos.A = 1 + (1 − alpha) (both write pos, the
    // front black), pos.G = 1 − alpha. Sums, not blends, as Cycles' film adds each write.
    let ch = render(&layered_scene(dir.path(), 0.3, 0.5), &out, &args);
    let n = (ch["val.X"].len() * spp) as f64;
    let mean = |c: &str| ch[c].iter().map(|&v| v as f64).sum::<f64>() / ch[c].len() as f64;
    // Each sample passes or not (Bernoulli 0.7): the mean of n draws has σ = sqrt(0.21 / n);
    // "val" carries it times 2. 5σ.
    let sigma = (0.21 / n).sqrt();
    assert!((mean("val.X") - 2.4).abs() < 5.0 * 2.0 * sigma, "val {}", mean("val.X"));
    assert!((mean("pos.A") - 1.7).abs() < 5.0 * sigma, "pos.A {}", mean("pos.A"));
    assert!((mean("pos.G") - 0.7).abs() < 5.0 * sigma, "pos.G {}", mean("pos.G"));
    // alpha 0.7 ≥ 0.5: the front alone writes, exactly.
    let ch = render(&layered_scene(dir.path(), 0.7, 0.5), &out, &args);
    assert!(ch["val.X"].iter().all(|&v| v == 1.0) && ch["pos.A"].iter().all(|&v| v == 1.0));
    // Threshold 0: the first surface writes alone whatever its alpha.
    let ch = render(&layered_scene(dir.path(), 0.3, 0.0), &out, &args);
    assert!(ch["val.X"].iter().all(|&v| v == 1.0));
}

/// Chunks carry the AOV sums: two chunks merge into the single render bit for bit, SPPM's
/// too (its AOVs depend on the iterations' camera rays alone, `sppm_extras.rs`, whatever
/// each chunk's photons gave); a list with a name twice is a bad scene (exit 3).
#[test]
fn aovs_merge_from_chunks_and_bad_lists_are_refused() {
    let dir = temp_dir();
    let scene = layered_scene(dir.path(), 0.3, 0.5);
    let p = |n: &str| dir.path().join(n);
    for (integrator, count) in [("path", "--spp"), ("sppm", "--sppm-iterations")] {
        let base = ["--resolution", "8x8", "--passes", "shader_aovs", "--integrator", integrator];
        let single = render(&scene, &p("single.exr"), &[&base[..], &[count, "4"]].concat());
        render(&scene, &p("a.exr"), &[&base[..], &[count, "1", "--chunk"]].concat());
        render(&scene, &p("b.exr"), &[&base[..], &[count, "3", "--sample-offset", "1", "--chunk"]].concat());
        let (a, b, m) = (p("a.exr"), p("b.exr"), p("merged.exr"));
        let r = run(&["merge", a.to_str().unwrap(), b.to_str().unwrap(), "-o", m.to_str().unwrap()], LIMIT);
        assert_eq!(r.code, Some(0), "{integrator}: {}", r.stderr);
        let merged = channels(&m);
        assert!(single.contains_key("val.X") && single.contains_key("pos.A"));
        // SPPM's chunks are independent runs: its Combined is their weighted mean (tests/merge.rs).
        let compared =
            |name: &str| integrator == "path" || ["val.", "pos.", "unwritten."].iter().any(|a| name.starts_with(a));
        for (name, v) in single.iter().filter(|(n, _)| compared(n)) {
            let w = &merged[name];
            assert!(
                v.iter().zip(w).all(|(x, y)| x.to_bits() == y.to_bits()),
                "{integrator}: {name} differs after the merge"
            );
        }
    }
    let mut doc: Value = serde_json::from_slice(&std::fs::read(&scene).unwrap()).unwrap();
    doc["scenes"][0]["extras"]["caustic"]["shader_aovs"]["aovs"][1]["name"] = json!("pos");
    std::fs::write(&scene, serde_json::to_vec(&doc).unwrap()).unwrap();
    let r = run(&["render", scene.to_str().unwrap(), "-o", p("bad.exr").to_str().unwrap()], LIMIT);
    assert_eq!(r.code, Some(3), "{}", r.stderr);
    assert!(r.stderr.contains("'pos' is listed twice"), "{}", r.stderr);
}

/// `position_scene`'s quad over the left half of the frame only ([-1, 0] × [-1, 1]), under a
/// world graph (a grey Background) whose AOV Output nodes write its Generated coordinate (the
/// direction, in Blender's axes) to "pos" and 3 × its average to "val"; `world` adds fields
/// to `CAUSTIC_world` (visibility), `settings` to the render settings.
fn world_scene(dir: &Path, world: Value, settings: Value) -> PathBuf {
    let mut g = GltfBuilder::new();
    let m = g.material(node_material("plane", position_nodes(), json!([1, "Emission"])));
    g.mesh(&[[-1., -1., 0.], [0., -1., 0.], [0., 1., 0.], [-1., 1., 0.]], &[0, 1, 2, 0, 2, 3], m);
    g.orthographic([0.0, 0.0, 5.0], [0.0, 0.0, 0.0, 1.0], 1.0, 1.0);
    g.use_ext("CAUSTIC_materials_nodes");
    let mut st = aov_settings(json!([]), 0.5);
    if let (Value::Object(s), Value::Object(more)) = (&mut st, settings) {
        s.extend(more);
    }
    g.settings(st);
    let nodes = json!([
        {"name": "Coords", "type": "ShaderNodeTexCoord"},
        {"name": "Background", "type": "ShaderNodeBackground",
         "inputs": {"Color": {"value": [0.2, 0.2, 0.2, 1]}, "Strength": {"value": 1.0}}},
        {"name": "Thrice", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
         "inputs": {"Value": {"link": [0, "Generated"]}, "Value_001": {"value": 3.0}}},
        {"name": "World pos", "type": "ShaderNodeOutputAOV", "props": {"aov_name": "pos"},
         "inputs": {"Color": {"link": [0, "Generated"]}}},
        {"name": "World val", "type": "ShaderNodeOutputAOV", "props": {"aov_name": "val"},
         "inputs": {"Value": {"link": [2, "Value"]}}}
    ]);
    let mut w = json!({"nodes": {"version": 1, "nodes": nodes, "output": {"surface": [1, "Background"]}}});
    if let (Value::Object(w), Value::Object(more)) = (&mut w, world) {
        w.extend(more);
    }
    g.world(w);
    g.write(dir, "world_aovs.gltf")
}

/// The world's AOV Output nodes write where the camera sees the world, in every integrator
/// (Cycles' background shader): the orthographic camera looks along glTF −Z, Blender's +Y, so
/// "pos" is (0, 1, 0) with alpha 1 and "val" 3 × 1/3 there, while the quad's half keeps its own
/// values. Not with the world hidden from the camera, nor with Film → Transparent unless the
/// Environment pass is on (Cycles skips the background shader then; warned).
#[test]
fn world_aovs_where_the_camera_sees_the_world() {
    let dir = temp_dir();
    let out = dir.path().join("w.exr");
    let res = 8usize;
    let render_with = |scene: &Path, integrator: &str, passes: &str| -> (BTreeMap<String, Vec<f32>>, String) {
        let args = [
            "--resolution",
            "8x8",
            "--spp",
            "2",
            "--sppm-iterations",
            "2",
            "--passes",
            passes,
            "--integrator",
            integrator,
        ];
        let r =
            run(&[&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap()][..], &args[..]].concat(), LIMIT);
        assert_eq!(r.code, Some(0), "{integrator}: {}", r.stderr);
        (channels(&out), r.stderr)
    };
    // Pixel columns 0..4 see the quad (x < 0), 4..8 the world.
    let world_px = |f: &dyn Fn(usize) -> bool| (0..res * res).filter(|i| i % res >= res / 2).all(f);
    let scene = world_scene(dir.path(), json!({}), json!({}));
    for integrator in ["path", "bdpt", "photon", "vcm", "sppm"] {
        let (ch, _) = render_with(&scene, integrator, "shader_aovs");
        // 3 × (0 + 1 + 0) / 3 in f32: within an ulp of 1.
        let ok = |i: usize| {
            [ch["pos.R"][i], ch["pos.G"][i], ch["pos.B"][i], ch["pos.A"][i]] == [0.0, 1.0, 0.0, 1.0]
                && (ch["val.X"][i] - 1.0).abs() <= f32::EPSILON
        };
        assert!(world_px(&ok), "{integrator}: the world's AOVs {:?} {:?}", ch["pos.G"], ch["val.X"]);
        // The quad's pixels keep the quad's: "pos" its position (z = 0 → Blender's y = 0).
        let quad = (0..res * res).filter(|i| i % res < res / 2);
        assert!(quad.clone().all(|i| ch["pos.G"][i] == 0.0 && ch["pos.R"][i] < 0.0), "{integrator}: {:?}", ch["pos.R"]);
    }
    let hidden = world_scene(dir.path(), json!({"visibility": {"camera": false}}), json!({}));
    let (ch, _) = render_with(&hidden, "path", "shader_aovs");
    assert!(world_px(&|i| ch["pos.A"][i] == 0.0 && ch["val.X"][i] == 0.0), "a world hidden from the camera wrote");
    let transparent = world_scene(dir.path(), json!({}), json!({"transparent": true}));
    let (ch, stderr) = render_with(&transparent, "path", "shader_aovs");
    assert!(world_px(&|i| ch["pos.A"][i] == 0.0), "a transparent film's world wrote");
    assert!(stderr.contains("Film → Transparent unless the Environment pass is on"), "{stderr}");
    let (ch, stderr) = render_with(&transparent, "path", "shader_aovs,environment");
    assert!(world_px(&|i| ch["pos.A"][i] == 1.0), "the Environment pass did not bring the world's AOVs");
    assert!(!stderr.contains("Film → Transparent"), "{stderr}");
}
