//! `EXT_meshopt_compression`: a sphere written twice, plain and as gltfpack lays it out
//! (compressed views in buffer 0, their fallback a buffer without data): positions with the
//! EXPONENTIAL filter, normals as OCTAHEDRAL bytes (KHR_mesh_quantization), indices with
//! the TRIANGLES codec, all encoded by meshoptimizer (the `meshopt` crate). The compressed
//! file loads to the same triangles, within the filters' precision, and renders the same
//! image; bad views are refused naming the mesh and the extension, never a crash.

mod common;

use base64::Engine;
use caustic::memory::MemoryBudget;
use common::*;
use serde_json::{Value, json};
use std::path::Path;
use std::time::Duration;

const EXT: &str = "EXT_meshopt_compression";

/// A UV sphere of radius 1: positions (= normals) and triangle indices.
fn sphere(rings: u32, segments: u32) -> (Vec<[f32; 3]>, Vec<u32>) {
    let mut p = Vec::new();
    for r in 0..=rings {
        let theta = r as f32 / rings as f32 * std::f32::consts::PI;
        for k in 0..=segments {
            let phi = k as f32 / segments as f32 * std::f32::consts::TAU;
            p.push([theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()]);
        }
    }
    let row = segments + 1;
    let mut idx = Vec::new();
    for r in 0..rings {
        for k in 0..segments {
            let (a, b, c, d) = (r * row + k, r * row + k + 1, (r + 1) * row + k, (r + 1) * row + k + 1);
            idx.extend([a, b, c, b, d, c]);
        }
    }
    (p, idx)
}

fn data_uri(bytes: &[u8]) -> String {
    format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(bytes))
}

/// The scene around the mesh: camera at +Z, a sun, a white material.
fn document(buffers: Value, views: Value, accessors: Value, used: &[&str]) -> Value {
    let mut used_list = vec![json!("KHR_lights_punctual")];
    used_list.extend(used.iter().map(|u| json!(u)));
    json!({
        "asset": { "version": "2.0" },
        "extensionsUsed": used_list,
        "extensionsRequired": used,
        "extensions": { "KHR_lights_punctual": { "lights": [{ "type": "directional", "intensity": 2000.0 }] } },
        "scene": 0,
        "scenes": [{ "nodes": [0, 1, 2] }],
        "nodes": [
            { "mesh": 0 },
            { "camera": 0, "translation": [0.0, 0.0, 3.5] },
            { "rotation": look_rotation([0.5, -0.6, -1.0]), "extensions": { "KHR_lights_punctual": { "light": 0 } } },
        ],
        "cameras": [{ "type": "perspective", "perspective": { "yfov": 0.7, "aspectRatio": 1.0, "znear": 0.05 } }],
        "materials": [{ "pbrMetallicRoughness": { "baseColorFactor": [0.9, 0.9, 0.9, 1.0], "roughnessFactor": 0.6 } }],
        "meshes": [{ "name": "ball", "primitives": [{ "attributes": { "POSITION": 0, "NORMAL": 1 }, "indices": 2, "material": 0 }] }],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": buffers,
    })
}

fn plain(p: &[[f32; 3]], idx: &[u32]) -> Value {
    let mut buf: Vec<u8> = p.as_flattened().iter().flat_map(|x| x.to_le_bytes()).collect();
    let n = buf.len();
    buf.extend(p.as_flattened().iter().flat_map(|x| x.to_le_bytes()));
    buf.extend(idx.iter().flat_map(|i| i.to_le_bytes()));
    let views = json!([
        { "buffer": 0, "byteOffset": 0, "byteLength": n },
        { "buffer": 0, "byteOffset": n, "byteLength": n },
        { "buffer": 0, "byteOffset": 2 * n, "byteLength": idx.len() * 4 },
    ]);
    let accessors = json!([
        { "bufferView": 0, "componentType": 5126, "count": p.len(), "type": "VEC3", "min": [-1.0, -1.0, -1.0], "max": [1.0, 1.0, 1.0] },
        { "bufferView": 1, "componentType": 5126, "count": p.len(), "type": "VEC3" },
        { "bufferView": 2, "componentType": 5125, "count": idx.len(), "type": "SCALAR" },
    ]);
    document(json!([{ "byteLength": buf.len(), "uri": data_uri(&buf) }]), views, accessors, &[])
}

/// The compressed file: buffer 0 the meshopt streams, buffer 1 the data-less fallback.
fn compressed(p: &[[f32; 3]], idx: &[u32]) -> Value {
    let positions = meshopt::encode_filter_exp::<3>(p, 24, meshopt::EncodeExpMode::Separate);
    let normals4: Vec<[f32; 4]> = p.iter().map(|n| [n[0], n[1], n[2], 0.0]).collect();
    let normals = meshopt::encode_filter_oct::<i8>(&normals4, 8);
    let streams = [
        (meshopt::encode_vertex_buffer(&positions).unwrap(), 12, "ATTRIBUTES", "EXPONENTIAL", p.len()),
        (meshopt::encode_vertex_buffer(&normals).unwrap(), 4, "ATTRIBUTES", "OCTAHEDRAL", p.len()),
        (meshopt::encode_index_buffer(idx, p.len()).unwrap(), 4, "TRIANGLES", "NONE", idx.len()),
    ];
    let (mut buf, mut views, mut fallback) = (Vec::new(), Vec::new(), 0usize);
    for (bytes, stride, mode, filter, count) in &streams {
        let mut ext = json!({ "buffer": 0, "byteOffset": buf.len(), "byteLength": bytes.len(),
                              "byteStride": stride, "count": count, "mode": mode });
        if *filter != "NONE" {
            ext["filter"] = json!(filter);
        }
        let mut view = json!({ "buffer": 1, "byteOffset": fallback, "byteLength": stride * count,
                               "extensions": { EXT: ext } });
        if *mode == "ATTRIBUTES" {
            view["byteStride"] = json!(stride);
        }
        views.push(view);
        fallback += stride * count;
        buf.extend(bytes);
        buf.resize(buf.len().next_multiple_of(4), 0);
    }
    let accessors = json!([
        { "bufferView": 0, "componentType": 5126, "count": p.len(), "type": "VEC3", "min": [-1.0, -1.0, -1.0], "max": [1.0, 1.0, 1.0] },
        { "bufferView": 1, "componentType": 5120, "normalized": true, "count": p.len(), "type": "VEC3" },
        { "bufferView": 2, "componentType": 5125, "count": idx.len(), "type": "SCALAR" },
    ]);
    let buffers = json!([
        { "byteLength": buf.len(), "uri": data_uri(&buf) },
        { "byteLength": fallback, "extensions": { EXT: { "fallback": true } } },
    ]);
    document(buffers, json!(views), accessors, &[EXT, "KHR_mesh_quantization"])
}

fn load(doc: &Value) -> Result<caustic::scene::Scene, String> {
    let bytes = serde_json::to_vec(doc).unwrap();
    caustic::scene::gltf::load_bytes(&bytes, Path::new("."), "test.gltf", &MemoryBudget::unlimited())
        .map_err(|e| e.to_string())
}

#[test]
fn compressed_views_load_the_same_triangles_and_render_the_same_image() {
    let (p, idx) = sphere(16, 32);
    let a = load(&plain(&p, &idx)).expect("plain");
    let b = load(&compressed(&p, &idx)).expect("compressed");
    // The index codec keeps the triangles and their order, each turned at most (the same
    // winding); the vertex codec is lossless.
    let canonical = |t: &[u32; 3]| {
        let r = (0..3).min_by_key(|&k| t[k]).unwrap();
        [t[r], t[(r + 1) % 3], t[(r + 2) % 3]]
    };
    let same = a.mesh.triangles.iter().map(canonical).eq(b.mesh.triangles.iter().map(canonical));
    assert!(same && a.mesh.triangles.len() == idx.len() / 3 - 32, "the decoded triangles are not the original ones");
    for (i, (x, y)) in a.mesh.positions.iter().zip(&b.mesh.positions).enumerate() {
        assert!((*x - *y).abs().max_element() < 1e-6, "vertex {i}: {x} against {y} (EXPONENTIAL, 24 bits)");
    }
    for (i, (x, y)) in a.mesh.normals.iter().zip(&b.mesh.normals).enumerate() {
        assert!(x.dot(*y) > 0.999, "vertex {i}: normal {y} against {x} (OCTAHEDRAL, 8 bits)");
    }
    let dir = temp_dir();
    let pa = dir.path().join("plain.gltf");
    let pb = dir.path().join("meshopt.gltf");
    std::fs::write(&pa, serde_json::to_vec(&plain(&p, &idx)).unwrap()).unwrap();
    std::fs::write(&pb, serde_json::to_vec(&compressed(&p, &idx)).unwrap()).unwrap();
    let flags = ["--resolution", "48x48", "--spp", "64"];
    let limit = Duration::from_secs(120);
    let ia = render_image(&pa, &dir.path().join("plain.exr"), &flags, limit);
    let ib = render_image(&pb, &dir.path().join("meshopt.exr"), &flags, limit);
    let lum = |p: &[f32; 4]| (p[0] + p[1] + p[2]) as f64 / 3.0;
    let (ma, mb) = (ia.iter().map(lum).sum::<f64>(), ib.iter().map(lum).sum::<f64>());
    eprintln!("image sums: plain {ma}, meshopt {mb}, ratio {}", mb / ma);
    assert!(ma > 0.0 && (mb / ma - 1.0).abs() < 0.005, "image means differ: {mb} / {ma}");
}

#[test]
fn bad_views_are_refused_naming_the_mesh_and_damaged_streams_never_crash() {
    let (p, idx) = sphere(6, 12);
    let good = compressed(&p, &idx);
    // (what, view, key of its extension, new value, what the message says)
    let cases = [
        ("stride 6", 0, "byteStride", json!(6), "byteStride 6"),
        ("quaternion on 4 bytes", 1, "filter", json!("QUATERNION"), "QUATERNION"),
        ("unknown mode", 0, "mode", json!("STRIPS"), "STRIPS"),
        ("outside the buffer", 0, "byteOffset", json!(1 << 30), "outside"),
        ("triangles of 7", 2, "count", json!(7), "multiple of 3"),
    ];
    for (what, view, key, value, needle) in cases {
        let mut doc = good.clone();
        doc["bufferViews"][view]["extensions"][EXT][key] = value;
        let msg = load(&doc).expect_err(what);
        assert!(msg.contains("mesh 0 ('ball')") && msg.contains(EXT) && msg.contains(needle), "{what}: {msg}");
    }
    // Damaged streams: meshoptimizer's decoders are safe on untrusted input.
    let uri = good["buffers"][0]["uri"].as_str().unwrap().to_string();
    let bytes = base64::engine::general_purpose::STANDARD.decode(uri.split_once(";base64,").unwrap().1).unwrap();
    for k in 0..60 {
        let mut b = bytes.clone();
        let at = (k * 7919) % b.len();
        b[at] ^= 1 << (k % 8);
        let mut doc = good.clone();
        doc["buffers"][0]["uri"] = json!(data_uri(&b));
        if let Err(e) = load(&doc) {
            assert!(!e.contains("parser failed"), "damage {k}: a panic: {e}");
        }
    }
}
