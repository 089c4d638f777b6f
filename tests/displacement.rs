//! True displacement (a node material's Displacement method "DISPLACEMENT" or "BOTH") through
//! the binary: a grid plane whose displacement has a closed form, seen from above by an
//! orthographic camera with a box filter a thousandth of a pixel wide, so that each pixel is the
//! surface at its centre. The Depth pass gives the moved geometry, a sun straight above the
//! recomputed normals.

mod common;

use base64::Engine;
use common::*;
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);
/// Pixels across the grid (the orthographic view's whole frame).
const RES: usize = 8;
/// Quads across the grid: pixel centres fall on every other vertex column, (x + 1) · M / 2 =
/// 2i + 1, so a pixel sees a vertex's position and normal exactly.
const M: usize = 16;
/// The camera's height above the undisplaced plane.
const CAMERA_Z: f32 = 5.0;

/// A grid of M × M quads over [-h, h]² (h = 1 / `scale`) at z = 0, normal +Z, on a node scaled
/// by `scale`, with `material`; the mesh's extras say normals domain `domain`. A sun straight
/// down lights it; an orthographic camera at z = 5 frames exactly [-1, 1]².
fn grid_scene(dir: &Path, material: Value, scale: f32, domain: &str) -> PathBuf {
    let h = 1.0 / scale;
    let n = M + 1;
    let mut pos = Vec::new();
    let mut nrm = Vec::new();
    let mut uv = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let (u, v) = (i as f32 / M as f32, j as f32 / M as f32);
            pos.extend([-h + 2.0 * h * u, -h + 2.0 * h * v, 0.0]);
            nrm.extend([0.0f32, 0.0, 1.0]);
            uv.extend([u, 1.0 - v]);
        }
    }
    let mut idx: Vec<u32> = Vec::new();
    for j in 0..M {
        for i in 0..M {
            let a = (j * n + i) as u32;
            let (b, c, d) = (a + 1, a + 1 + n as u32, a + n as u32);
            idx.extend([a, b, c, a, c, d]);
        }
    }
    let mut data: Vec<u8> = Vec::new();
    for f in pos.iter().chain(&nrm).chain(&uv) {
        data.extend_from_slice(&f.to_le_bytes());
    }
    for i in &idx {
        data.extend_from_slice(&i.to_le_bytes());
    }
    let (nv, p_len, uv_len) = (n * n, n * n * 12, n * n * 8);
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&data));
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["CAUSTIC_materials_nodes", "KHR_lights_punctual"],
        "buffers": [{"uri": uri, "byteLength": data.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": p_len},
            {"buffer": 0, "byteOffset": p_len, "byteLength": p_len},
            {"buffer": 0, "byteOffset": 2 * p_len, "byteLength": uv_len},
            {"buffer": 0, "byteOffset": 2 * p_len + uv_len, "byteLength": idx.len() * 4}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": nv, "type": "VEC3", "min": [-h, -h, 0], "max": [h, h, 0]},
            {"bufferView": 1, "componentType": 5126, "count": nv, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": nv, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5125, "count": idx.len(), "type": "SCALAR"}
        ],
        "materials": [material],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3,
                                    "material": 0}],
                    "extras": {"CAUSTIC_normals_domain": domain}}],
        "cameras": [{"type": "orthographic", "orthographic": {"xmag": 1.0, "ymag": 1.0, "znear": 0.1, "zfar": 100.0}}],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 683.0}]}},
        "nodes": [{"mesh": 0, "scale": [scale, scale, scale]}, {"camera": 0, "translation": [0, 0, CAMERA_Z]},
                  {"extensions": {"KHR_lights_punctual": {"light": 0}}}],
        "scenes": [{"nodes": [0, 1, 2], "extras": {"caustic": {"filter": "box", "filter_width": 0.001}}}],
        "scene": 0
    });
    let path = dir.join("grid.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

/// A white Diffuse BSDF displaced by `height` nodes (the last of which gives `height_out`),
/// through a Displacement node of midlevel 0, scale `scale`, space `space`, by `method`.
fn material(height: Value, height_out: &str, scale: f32, space: &str, method: &str) -> Value {
    let mut nodes: Vec<Value> = height.as_array().cloned().unwrap_or_default();
    let last = nodes.len();
    let height_input = if last == 0 { json!({"value": 0.0}) } else { json!({"link": [last - 1, height_out]}) };
    nodes.push(json!({"name": "Displacement", "type": "ShaderNodeDisplacement", "props": {"space": space},
        "inputs": {"Height": height_input, "Midlevel": {"value": 0.0}, "Scale": {"value": scale},
                   "Normal": {"value": [0, 0, 0]}}}));
    nodes.push(json!({"name": "Diffuse", "type": "ShaderNodeBsdfDiffuse",
        "inputs": {"Color": {"value": [1, 1, 1, 1]}, "Roughness": {"value": 0.0}}}));
    json!({"name": "displaced", "doubleSided": true, "extensions": {"CAUSTIC_materials_nodes": {
        "version": 1, "nodes": nodes, "displacement_method": method,
        "output": {"surface": [last + 1, "BSDF"], "displacement": [last, "Displacement"]}}}})
}

/// Height sin(2X) of the Geometry node's Position (Blender's X is glTF's x).
fn sine_height() -> Value {
    json!([
        {"name": "Geometry", "type": "ShaderNodeNewGeometry"},
        {"name": "Separate", "type": "ShaderNodeSeparateXYZ", "inputs": {"Vector": {"link": [0, "Position"]}}},
        {"name": "Twice", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
         "inputs": {"Value": {"link": [1, "X"]}, "Value_001": {"value": 2.0}}},
        {"name": "Sine", "type": "ShaderNodeMath", "props": {"operation": "SINE"},
         "inputs": {"Value": {"link": [2, "Value"]}}}
    ])
}

/// Every channel of an EXR by name.
fn channels(path: &Path) -> BTreeMap<String, Vec<f32>> {
    let image = exr::prelude::read_all_flat_layers_from_file(path).expect("read EXR");
    let layer = &image.layer_data[0];
    layer.channel_data.list.iter().map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect())).collect()
}

/// Renders `scene` with `extra` flags (direct light only) and returns its channels.
fn render(scene: &Path, extra: &[&str]) -> BTreeMap<String, Vec<f32>> {
    let out = scene.with_file_name(format!("o{}.exr", extra.join("_").replace(['-', ' '], "")));
    let res = format!("{RES}x{RES}");
    let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--resolution", &res];
    args.extend_from_slice(&["--spp", "4", "--max-depth", "1", "--passes", "z", "--progress", "json"]);
    args.extend_from_slice(extra);
    let r = run(&args, LIMIT);
    assert_eq!(r.code, Some(0), "render failed: {}", r.stderr);
    channels(&out)
}

/// Pixel (col, row)'s centre x (the grid's columns are along x).
fn pixel_x(i: usize) -> f32 {
    -1.0 + (i as f32 + 0.5) * 2.0 / RES as f32
}

/// The Depth pass is the camera's height less the closed-form displacement 0.1 sin(2x) at
/// each pixel centre (a vertex), under the path tracer and BDPT; the same graph as bump leaves
/// the plane where it was.
#[test]
fn depth_pass_sees_the_displaced_surface() {
    let dir = temp_dir();
    for integrator in ["path", "bdpt"] {
        let scene =
            grid_scene(dir.path(), material(sine_height(), "Value", 0.1, "OBJECT", "DISPLACEMENT"), 1.0, "POINT");
        let depth = &render(&scene, &["--integrator", integrator])["Depth.Z"];
        for (k, d) in depth.iter().enumerate() {
            let x = pixel_x(k % RES);
            let want = CAMERA_Z - 0.1 * (2.0 * x).sin();
            // Samples lie within 0.0005 pixel (1.25e-4 units) of the centre, where the surface
            // slopes at most 0.2: 2.5e-5, plus a few ulps of 5.
            assert!((d - want).abs() < 3e-5, "{integrator} pixel {k} (x {x}): depth {d} vs {want}");
        }
    }
    let scene = grid_scene(dir.path(), material(sine_height(), "Value", 0.1, "OBJECT", "BUMP"), 1.0, "POINT");
    let depth = &render(&scene, &[])["Depth.Z"];
    assert!(depth.iter().all(|d| (d - CAMERA_Z).abs() < 2e-5), "bump does not move the surface: {depth:?}");
}

/// A constant displacement (Height unlinked: 0, Scale 0.2, so −0.2 along the normal) moves the
/// whole plane; in object space the node's scale 2 doubles it (Cycles' object_dir_transform),
/// in world space it does not.
#[test]
fn object_space_displacement_scales_with_the_object() {
    let dir = temp_dir();
    for (space, want) in [("OBJECT", -0.4), ("WORLD", -0.2)] {
        let m = json!({"name": "constant", "extensions": {"CAUSTIC_materials_nodes": {"version": 1,
            "displacement_method": "DISPLACEMENT",
            "nodes": [
                {"name": "Displacement", "type": "ShaderNodeDisplacement", "props": {"space": space},
                 "inputs": {"Height": {"value": 0.0}, "Midlevel": {"value": 0.5}, "Scale": {"value": 0.4}}},
                {"name": "Diffuse", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"value": [1, 1, 1, 1]}}}],
            "output": {"surface": [1, "BSDF"], "displacement": [0, "Displacement"]}}}});
        let scene = grid_scene(dir.path(), m, 2.0, "POINT");
        let depth = &render(&scene, &[])["Depth.Z"];
        for (k, d) in depth.iter().enumerate() {
            assert!((d - (CAMERA_Z - want)).abs() < 2e-5, "{space} pixel {k}: depth {d} vs {}", CAMERA_Z - want);
        }
    }
}

/// Recomputed normals: under a sun straight down, a white diffuse surface's radiance is in
/// proportion to its normal's z. With "DISPLACEMENT" on a smooth mesh (POINT) each vertex's
/// normal is the normalised sum of its faces' normals (as Cycles): on this grid, whose facets
/// depend on x alone, the sum of the unit normals of the facets left and right of the vertex.
/// The flat plane (the same graph as bump of an unlinked height: no bump) is the reference.
#[test]
fn sun_sees_the_recomputed_normals() {
    let dir = temp_dir();
    let flat = material(json!([]), "", 0.0, "OBJECT", "BUMP");
    let flat = render(&grid_scene(dir.path(), flat, 1.0, "POINT"), &[]);
    let scene = grid_scene(dir.path(), material(sine_height(), "Value", 0.1, "OBJECT", "DISPLACEMENT"), 1.0, "POINT");
    let lit = render(&scene, &[]);
    let z = |x: f32| 0.1 * (2.0 * x).sin();
    let step = 2.0 / M as f32;
    for (k, (a, b)) in lit["Combined.R"].iter().zip(&flat["Combined.R"]).enumerate() {
        let x = pixel_x(k % RES);
        let facet = |x0: f32| glam::Vec3::new(-(z(x0 + step) - z(x0)) / step, 0.0, 1.0).normalize();
        let want = (facet(x - step) + facet(x)).normalize().z;
        // Deterministic direct light from a delta light at a point: f32 rounding.
        assert!((a / b - want).abs() < 1e-4, "pixel {k} (x {x}): cos {} vs {want}", a / b);
        assert!(want < 0.9999 || (2.0 * x).cos().abs() < 0.1, "the case tilts the normal at x {x}");
    }
}

/// A displacement that is not finite (Height 10³⁰ × Scale 10³⁰) leaves the vertices in place,
/// as Cycles does, with a warning naming the material.
#[test]
fn a_non_finite_displacement_is_named_and_not_applied() {
    let dir = temp_dir();
    let m = json!({"name": "overflow", "extensions": {"CAUSTIC_materials_nodes": {"version": 1,
        "displacement_method": "BOTH",
        "nodes": [
            {"name": "Displacement", "type": "ShaderNodeDisplacement", "props": {"space": "OBJECT"},
             "inputs": {"Height": {"value": 1e30}, "Midlevel": {"value": 0.0}, "Scale": {"value": 1e30}}},
            {"name": "Diffuse", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"value": [1, 1, 1, 1]}}}],
        "output": {"surface": [1, "BSDF"], "displacement": [0, "Displacement"]}}}});
    let scene = grid_scene(dir.path(), m, 1.0, "POINT");
    let out = dir.path().join("o.exr");
    let w = quick_render_warnings(&scene, &out, &[], LIMIT);
    assert!(
        w.iter().any(|w| w.contains("material 'overflow'") && w.contains("NaN or infinite at 289 vertices")),
        "{w:?}"
    );
}
