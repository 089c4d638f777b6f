//! Object and Material Index and Cryptomatte on a known scene: two quads meeting in the
//! middle of a pixel column, seen straight on by an orthographic camera through a box
//! filter one pixel wide, so that every sample lands in its own pixel.

mod common;

use caustic::cryptomatte::{id_of, murmur3_32};
use common::{GltfBuilder, look_rotation, run, temp_dir};
use serde_json::json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);
const SIZE: usize = 8;
const SPP: u32 = 64;

/// Every channel of an EXR by name, and its header's text attributes.
fn read(path: &Path) -> (BTreeMap<String, Vec<f32>>, BTreeMap<String, String>) {
    let image = exr::prelude::read_all_flat_layers_from_file(path).expect("read EXR");
    let layer = &image.layer_data[0];
    let channels =
        layer.channel_data.list.iter().map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect())).collect();
    let attributes = layer
        .attributes
        .other
        .iter()
        .filter_map(|(k, v)| match v {
            exr::meta::attribute::AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
            _ => None,
        })
        .collect();
    (channels, attributes)
}

/// Left quad x in [-1, 0.1] ("Left", material "Red", pass indices 3 and 5, asset "Rig"
/// named by the extension); right quad x in [0.1, 1] ("Right", material "Blue" without
/// a pass index, pass index 4, child of node "Parent": its asset). The camera sees
/// x in [-0.8, 0.8] over 8 pixels, so x = 0.1 is the middle of column 4.
fn two_quads(dir: &Path) -> PathBuf {
    let mut g = GltfBuilder::new();
    let red = g.material(json!({"name": "Red", "extensions": {"CAUSTIC_material_pass": {"pass_index": 5}}}));
    let blue = g.material(json!({"name": "Blue"}));
    let quad = |x0: f32, x1: f32| [[x0, -1.0, 0.0], [x1, -1.0, 0.0], [x1, 1.0, 0.0], [x0, 1.0, 0.0]];
    let left = g.mesh(&quad(-1.0, 0.1), &[0, 1, 2, 0, 2, 3], red);
    g.node_name(left, "Left");
    g.node_ext(left, "CAUSTIC_object_pass", json!({"pass_index": 3, "asset": "Rig"}));
    let right = g.mesh(&quad(0.1, 1.0), &[0, 1, 2, 0, 2, 3], blue);
    g.node_name(right, "Right");
    g.node_ext(right, "CAUSTIC_object_pass", json!({"pass_index": 4}));
    let parent = g.node(json!({"name": "Parent", "children": [right]}));
    g.camera([0.0, 0.0, 10.0], look_rotation([0.0, 0.0, -1.0]), 0.5);
    g.settings(json!({"filter": "box", "filter_width": 1.0}));
    g.use_ext("CAUSTIC_material_pass");
    let path = g.write(dir, "quads.gltf");
    let mut doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    doc["cameras"][0] =
        json!({"type": "orthographic", "orthographic": {"xmag": 0.8, "ymag": 0.8, "znear": 0.01, "zfar": 100.0}});
    // "Right" is Parent's child, not a root of the scene.
    doc["scenes"][0]["nodes"].as_array_mut().unwrap().retain(|n| n.as_u64() != Some(right as u64));
    assert!(doc["scenes"][0]["nodes"].as_array().unwrap().iter().any(|n| n.as_u64() == Some(parent as u64)));
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

fn render(scene: &Path, out: &Path, extra: &[&str]) -> common::Run {
    let res = format!("{SIZE}x{SIZE}");
    let spp = SPP.to_string();
    let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"];
    args.extend_from_slice(&["--resolution", &res, "--spp", &spp]);
    args.extend_from_slice(extra);
    run(&args, LIMIT)
}

#[test]
fn index_passes_and_cryptomatte_on_two_quads() {
    let dir = temp_dir();
    let scene = two_quads(dir.path());
    let out = dir.path().join("ids.exr");
    let passes = "object_index,material_index,cryptomatte_object,cryptomatte_material,cryptomatte_asset";
    let r = render(&scene, &out, &["--passes", passes, "--cryptomatte-levels", "2"]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(!r.stderr.contains("_pass"), "the pass extensions are read: {}", r.stderr);
    let (ch, attrs) = read(&out);
    let at = |name: &str, x: usize, y: usize| ch[name][y * SIZE + x];
    let bits = |name: &str, x: usize, y: usize| at(name, x, y).to_bits();
    for y in 0..SIZE {
        for x in (0..4).chain(5..SIZE) {
            let left = x < 4;
            // Indices: the pixel's first sample's object and material, exact.
            assert_eq!(at("Object Index.X", x, y), if left { 3.0 } else { 4.0 }, "({x}, {y})");
            assert_eq!(at("Material Index.X", x, y), if left { 5.0 } else { 0.0 }, "({x}, {y})");
            // Cryptomatte: one id covering the whole pixel, the second rank empty.
            let (ob, ma, asset) = if left { ("Left", "Red", "Rig") } else { ("Right", "Blue", "Parent") };
            for (layer, name) in [("CryptoObject00", ob), ("CryptoMaterial00", ma), ("CryptoAsset00", asset)] {
                assert_eq!(bits(&format!("{layer}.r"), x, y), id_of(name), "{layer} ({x}, {y})");
                assert_eq!(at(&format!("{layer}.g"), x, y), 1.0);
                assert_eq!((at(&format!("{layer}.b"), x, y), at(&format!("{layer}.a"), x, y)), (0.0, 0.0));
            }
        }
        // Column 4 is half covered by each quad.
        let [r, g, b, a] = ["r", "g", "b", "a"].map(|c| format!("CryptoObject00.{c}"));
        let ids = [bits(&r, 4, y), bits(&b, 4, y)];
        assert!(ids == [id_of("Left"), id_of("Right")] || ids == [id_of("Right"), id_of("Left")], "{ids:?}");
        let (cov_first, cov_second) = (at(&g, 4, y), at(&a, 4, y));
        assert!(cov_first >= cov_second, "ranked by coverage");
        // Every sample hit one of the two: the coverages are k/64 and (64 − k)/64, each
        // rounded once to f32 (exact for these fractions).
        assert_eq!(cov_first + cov_second, 1.0);
        // The box filter's x is the sampler's first dimension, stratified over the 64
        // samples (Owen-scrambled Sobol: one sample per 1/64 of the pixel), so 32 lie on
        // each side of the edge; the one or two within rounding of it may fall either way.
        assert!((cov_first - 0.5).abs() <= 2.0 / SPP as f32, "coverage {cov_first} at row {y}");
        assert!([3.0, 4.0].contains(&at("Object Index.X", 4, y)));
    }
    // Levels 2: one pass (two ranks) per layer.
    assert!(!ch.contains_key("CryptoObject01.r"));
    // The manifests, under the specification's keys.
    for (layer, names) in [
        ("CryptoObject", &["Left", "Right"][..]),
        ("CryptoMaterial", &["Red", "Blue"]),
        ("CryptoAsset", &["Rig", "Parent"]),
    ] {
        let key = format!("cryptomatte/{}", &format!("{:08x}", murmur3_32(layer.as_bytes()))[..7]);
        assert_eq!(attrs[&format!("{key}/name")], layer);
        assert_eq!(attrs[&format!("{key}/hash")], "MurmurHash3_32");
        assert_eq!(attrs[&format!("{key}/conversion")], "uint32_to_float32");
        let manifest: serde_json::Value = serde_json::from_str(&attrs[&format!("{key}/manifest")]).unwrap();
        for n in names {
            assert_eq!(manifest[n], format!("{:08x}", murmur3_32(n.as_bytes())), "{layer} {n}");
        }
    }
}

#[test]
fn cryptomatte_levels_are_checked() {
    let dir = temp_dir();
    let scene = two_quads(dir.path());
    let out = dir.path().join("bad.exr");
    let r = render(&scene, &out, &["--passes", "cryptomatte_object", "--cryptomatte-levels", "17"]);
    assert_eq!(r.code, Some(2), "{}", r.stderr);
    assert!(r.stderr.contains("cryptomatte levels 17"), "{}", r.stderr);
    // Default levels (Blender's 6): three passes of two ranks.
    let r = render(&scene, &out, &["--passes", "cryptomatte_material"]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let (ch, _) = read(&out);
    assert!(ch.contains_key("CryptoMaterial02.a") && !ch.contains_key("CryptoMaterial03.r"));
    assert!(!ch.contains_key("CryptoObject00.r"), "only the layer asked for");
}

/// Eight stripes (objects "s0".."s7", materials "m0".."m7") across an orthographic view of
/// 2 × 2 pixels with a box filter two pixels wide: each pixel sees six ids, more than levels
/// 2 keep, so the single render counts later ids in its last slot.
fn stripes(dir: &Path) -> PathBuf {
    let mut g = GltfBuilder::new();
    for k in 0..8 {
        let m = g.material(json!({"name": format!("m{k}")}));
        let (x0, x1) = (-1.0 + k as f32 / 4.0, -1.0 + (k + 1) as f32 / 4.0);
        let quad = [[x0, -1.0, 0.0], [x1, -1.0, 0.0], [x1, 1.0, 0.0], [x0, 1.0, 0.0]];
        let n = g.mesh(&quad, &[0, 1, 2, 0, 2, 3], m);
        g.node_name(n, &format!("s{k}"));
    }
    g.orthographic([0.0, 0.0, 10.0], look_rotation([0.0, 0.0, -1.0]), 1.0, 1.0);
    g.settings(json!({"filter": "box", "filter_width": 2.0}));
    g.write(dir, "stripes.gltf")
}

/// Chunks carry each pixel's first-seen ids with exact counts: three chunks, given to the
/// merge out of order, give the single render's Cryptomatte bit for bit, capped slots
/// (levels 2 over six ids) included.
#[test]
fn cryptomatte_chunks_merge_bit_for_bit() {
    let dir = temp_dir();
    let scene = stripes(dir.path());
    let p = |n: &str| dir.path().join(n);
    let base =
        ["--resolution", "2x2", "--passes", "cryptomatte_object,cryptomatte_material", "--cryptomatte-levels", "2"];
    let go = |out: &str, extra: &[&str]| {
        let mut args = vec!["render", scene.to_str().unwrap(), "-o"];
        let out = p(out);
        args.push(out.to_str().unwrap());
        args.extend_from_slice(&base);
        args.extend_from_slice(extra);
        let r = run(&args, LIMIT);
        assert_eq!(r.code, Some(0), "{}", r.stderr);
    };
    go("single.exr", &["--spp", "64"]);
    go("a.exr", &["--spp", "16", "--chunk"]);
    go("b.exr", &["--spp", "24", "--sample-offset", "16", "--chunk"]);
    go("c.exr", &["--spp", "24", "--sample-offset", "40", "--chunk"]);
    let (a, b, c, m) = (p("a.exr"), p("b.exr"), p("c.exr"), p("merged.exr"));
    let r = run(
        &["merge", c.to_str().unwrap(), a.to_str().unwrap(), b.to_str().unwrap(), "-o", m.to_str().unwrap()],
        LIMIT,
    );
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(!r.stderr.contains("counted under another id"), "{}", r.stderr);
    let ((single, single_attrs), (merged, merged_attrs)) = (read(&p("single.exr")), read(&m));
    // The manifests travel through the chunks into the merged frame.
    let manifests = |a: &BTreeMap<String, String>| {
        a.iter().filter(|(k, _)| k.starts_with("cryptomatte/")).map(|(k, v)| (k.clone(), v.clone())).collect::<Vec<_>>()
    };
    assert!(!manifests(&single_attrs).is_empty());
    assert_eq!(manifests(&merged_attrs), manifests(&single_attrs));
    // Six ids in each pixel, two ranks kept: the last slot holds the ids seen after the first.
    let ids: std::collections::BTreeSet<u32> = single["CryptoObject00.b"].iter().map(|v| v.to_bits()).collect();
    assert!(ids.iter().all(|&i| (0..8).any(|k| id_of(&format!("s{k}")) == i)), "{ids:?}");
    for (name, v) in single.iter().filter(|(n, _)| n.starts_with("Crypto")) {
        let w = &merged[name];
        assert!(v.iter().zip(w).all(|(x, y)| x.to_bits() == y.to_bits()), "{name}: {v:?} vs {w:?}");
    }
    assert!(single.keys().any(|k| k == "CryptoMaterial00.a") && !single.contains_key("CryptoObject01.r"));
}
