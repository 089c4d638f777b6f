//! Shader graphs (`CAUSTIC_materials_nodes`) through the binary: loading errors and
//! warnings, one closed-form scene per node family (an emissive plane seen by an
//! orthographic camera with a box filter a thousandth of a pixel wide, whose pixels are
//! the graph's value at their centres),
//! and a white furnace of mixed closures.

mod common;

use base64::Engine;
use common::*;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);
/// Pixels across the plane [-1, 1]² (the orthographic view's whole frame).
const RES: usize = 8;

/// A scene of one quad z = 0, [-1, 1]², normal +Z, UV (u, v) = ((x + 1)/2, (1 − y)/2),
/// with `material`, seen from +Z by an orthographic camera framing exactly the quad, box
/// filter 0.001 pixel wide: every sample lies within 0.0005 pixel of the pixel's centre.
fn plane_scene(dir: &Path, name: &str, material: Value) -> PathBuf {
    plane_scene_scaled(dir, name, material, 1.0)
}

/// The same plane built as a quad of half-size 1/`scale` on a node scaled by `scale`.
fn plane_scene_scaled(dir: &Path, name: &str, material: Value, scale: f32) -> PathBuf {
    let h = 1.0 / scale;
    let pos: [f32; 12] = [-h, -h, 0., h, -h, 0., h, h, 0., -h, h, 0.];
    let nrm: [f32; 12] = [0., 0., 1., 0., 0., 1., 0., 0., 1., 0., 0., 1.];
    let uv: [f32; 8] = [0., 1., 1., 1., 1., 0., 0., 0.];
    let idx: [u32; 6] = [0, 1, 2, 0, 2, 3];
    let mut data: Vec<u8> = Vec::new();
    for f in pos.iter().chain(&nrm).chain(&uv) {
        data.extend_from_slice(&f.to_le_bytes());
    }
    for i in idx {
        data.extend_from_slice(&i.to_le_bytes());
    }
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&data));
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["CAUSTIC_materials_nodes"],
        "buffers": [{"uri": uri, "byteLength": data.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 48},
            {"buffer": 0, "byteOffset": 96, "byteLength": 32},
            {"buffer": 0, "byteOffset": 128, "byteLength": 24}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-h, -h, 0], "max": [h, h, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR"}
        ],
        "materials": [material],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0}]}],
        "cameras": [{"type": "orthographic", "orthographic": {"xmag": 1.0, "ymag": 1.0, "znear": 0.1, "zfar": 100.0}}],
        "nodes": [{"mesh": 0, "scale": [scale, scale, scale]}, {"camera": 0, "translation": [0, 0, 5]}],
        "scenes": [{"nodes": [0, 1], "extras": {"caustic": {"filter": "box", "filter_width": 0.001}}}],
        "scene": 0
    });
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

fn node_material(name: &str, nodes: Value, surface: Value) -> Value {
    json!({"name": name, "extensions": {"CAUSTIC_materials_nodes":
        {"version": 1, "nodes": nodes, "output": {"surface": surface}}}})
}

/// Renders the plane and returns its pixels' RGB with each pixel's centre (x, y).
fn render_plane(material: Value, spp: u32) -> Vec<([f32; 3], f32, f32)> {
    render_plane_scaled(material, spp, 1.0)
}

/// [`render_plane`] of the plane on a node scaled by `scale`.
fn render_plane_scaled(material: Value, spp: u32, scale: f32) -> Vec<([f32; 3], f32, f32)> {
    let dir = temp_dir();
    render_plane_in(dir.path(), material, spp, scale)
}

/// [`render_plane_scaled`] in a given directory (for graphs with image files).
fn render_plane_in(dir: &Path, material: Value, spp: u32, scale: f32) -> Vec<([f32; 3], f32, f32)> {
    let scene = plane_scene_scaled(dir, "plane.gltf", material, scale);
    let res = format!("{RES}x{RES}");
    let spp = spp.to_string();
    let px = render_image(&scene, &dir.join("o.exr"), &["--resolution", &res, "--spp", &spp], LIMIT);
    px.iter()
        .enumerate()
        .map(|(i, p)| {
            let (col, row) = (i % RES, i / RES);
            let x = -1.0 + (col as f32 + 0.5) * 2.0 / RES as f32;
            let y = 1.0 - (row as f32 + 0.5) * 2.0 / RES as f32;
            ([p[0], p[1], p[2]], x, y)
        })
        .collect()
}

/// Geometry → Separate XYZ → Math, Map Range, Mix (float) → Combine XYZ → Emission, with
/// the strength from a constant-folded Math chain: each pixel is the formula at its centre.
#[test]
fn converters_on_an_emissive_plane() {
    let nodes = json!([
        {"name": "Geometry", "type": "ShaderNodeNewGeometry"},
        {"name": "Separate", "type": "ShaderNodeSeparateXYZ", "inputs": {"Vector": {"link": [0, "Position"]}}},
        {"name": "R", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY_ADD"},
         "inputs": {"Value": {"link": [1, "X"]}, "Value_001": {"value": 0.5}, "Value_002": {"value": 1.0}}},
        {"name": "G", "type": "ShaderNodeMapRange", "props": {"data_type": "FLOAT", "interpolation_type": "LINEAR", "clamp": true},
         "inputs": {"Value": {"link": [1, "Z"]}, "From_Min": {"value": -1.0}, "From_Max": {"value": 1.0},
                    "To_Min": {"value": 0.0}, "To_Max": {"value": 2.0}}},
        {"name": "B", "type": "ShaderNodeMix", "props": {"data_type": "FLOAT", "clamp_factor": true},
         "inputs": {"Factor_Float": {"value": 0.25}, "A_Float": {"link": [2, "Value"]}, "B_Float": {"value": 3.0}}},
        {"name": "Combine", "type": "ShaderNodeCombineXYZ",
         "inputs": {"X": {"link": [2, "Value"]}, "Y": {"link": [3, "Result"]}, "Z": {"link": [4, "Result_Float"]}}},
        {"name": "Two", "type": "ShaderNodeMath", "props": {"operation": "SUBTRACT"},
         "inputs": {"Value": {"value": 3.0}, "Value_001": {"value": 1.0}}},
        {"name": "Emission", "type": "ShaderNodeEmission",
         "inputs": {"Color": {"link": [5, "Vector"], "value": [1, 1, 1, 1]}, "Strength": {"link": [6, "Value"]}}}
    ]);
    let px = render_plane(node_material("conv", nodes, json!([7, "Emission"])), 16);
    for (c, x, y) in px {
        // Blender axes: X = x, Z = y (glTF's y up).
        let r = 0.5 * x + 1.0;
        let want = [2.0 * r, 2.0 * (y + 1.0), 2.0 * (0.75 * r + 0.75)];
        for k in 0..3 {
            // Samples within 0.0005 pixel of the centre, steepest channel 0.5 per pixel:
            // 2.5e-4, plus f32 rounding.
            assert!((c[k] - want[k]).abs() < 3e-4, "({x}, {y}) channel {k}: {} vs {}", c[k], want[k]);
        }
    }
}

/// Texture Coordinate UV and Fresnel at normal incidence (0.04 for IOR 1.5).
#[test]
fn uv_and_fresnel_inputs() {
    let nodes = json!([
        {"name": "TexCoord", "type": "ShaderNodeTexCoord"},
        {"name": "Separate", "type": "ShaderNodeSeparateXYZ", "inputs": {"Vector": {"link": [0, "UV"]}}},
        {"name": "Fresnel", "type": "ShaderNodeFresnel", "inputs": {"IOR": {"value": 1.5}}},
        {"name": "Combine", "type": "ShaderNodeCombineColor", "props": {"mode": "RGB"},
         "inputs": {"Red": {"link": [1, "X"]}, "Green": {"link": [1, "Y"]}, "Blue": {"link": [2, "Fac"]}}},
        {"name": "Emission", "type": "ShaderNodeEmission",
         "inputs": {"Color": {"link": [3, "Color"]}, "Strength": {"value": 1.0}}}
    ]);
    let px = render_plane(node_material("uv", nodes, json!([4, "Emission"])), 16);
    for (c, x, y) in px {
        // Blender's UV is (u, 1 − v) of glTF's: ((x + 1)/2, (y + 1)/2).
        let want = [(x + 1.0) / 2.0, (y + 1.0) / 2.0, 0.04];
        for k in 0..3 {
            // As above: gradient 0.25 per pixel, samples within 0.0005 pixel of the centre.
            assert!((c[k] - want[k]).abs() < 2e-4, "({x}, {y}) channel {k}: {} vs {}", c[k], want[k]);
        }
    }
}

/// Object coordinates undo the instance's transform: the plane's node is scaled by 2, so
/// the object position is half the world position (Blender axes: (x, −z, y) of glTF).
#[test]
fn object_coordinates_undo_the_instance_transform() {
    let nodes = json!([
        {"name": "TexCoord", "type": "ShaderNodeTexCoord"},
        {"name": "Shift", "type": "ShaderNodeVectorMath", "props": {"operation": "ADD"},
         "inputs": {"Vector": {"link": [0, "Object"]}, "Vector_001": {"value": [1, 1, 1]}}},
        {"name": "Emission", "type": "ShaderNodeEmission",
         "inputs": {"Color": {"link": [1, "Vector"]}, "Strength": {"value": 1.0}}}
    ]);
    let px = render_plane_scaled(node_material("obj", nodes, json!([2, "Emission"])), 4, 2.0);
    for (c, x, y) in px {
        let want = [x / 2.0 + 1.0, 1.0, y / 2.0 + 1.0];
        for k in 0..3 {
            // Gradient 0.125 per pixel, samples within 0.0005 pixel of the centre.
            assert!((c[k] - want[k]).abs() < 2e-4, "({x}, {y}) channel {k}: {} vs {}", c[k], want[k]);
        }
    }
}

/// The Noise Texture node is wired to its function: Position → Noise (3-D fBM) → Emission
/// gives the function's value at each pixel centre.
#[test]
fn noise_texture_node_gives_the_function_value() {
    use caustic::shader::texture::{NoiseKind, NoiseParams, noise_texture};
    let nodes = json!([
        {"name": "Geometry", "type": "ShaderNodeNewGeometry"},
        {"name": "Noise", "type": "ShaderNodeTexNoise",
         "props": {"noise_dimensions": "3D", "noise_type": "FBM", "normalize": true},
         "inputs": {"Vector": {"link": [0, "Position"]}, "Scale": {"value": 3.0}, "Detail": {"value": 2.0},
                    "Roughness": {"value": 0.5}, "Lacunarity": {"value": 2.0}, "Distortion": {"value": 0.0}}},
        {"name": "Emission", "type": "ShaderNodeEmission",
         "inputs": {"Color": {"link": [1, "Fac"]}, "Strength": {"value": 1.0}}}
    ]);
    let px = render_plane(node_material("noise", nodes, json!([2, "Emission"])), 4);
    let prm = NoiseParams {
        dims: 3,
        kind: NoiseKind::Fbm,
        normalize: true,
        scale: 3.0,
        detail: 2.0,
        roughness: 0.5,
        lacunarity: 2.0,
        offset: 0.0,
        gain: 1.0,
        distortion: 0.0,
    };
    for (c, x, y) in px {
        let want = noise_texture(glam::Vec3::new(x, 0.0, y), 0.0, &prm).0;
        // Noise at scale 3 changes by at most ~3 per unit (gradient of Perlin noise about
        // 1 per lattice unit, fBM sums of halving amplitude), 0.25 units per pixel: samples
        // within 0.0005 pixel move it by < 4e-4.
        assert!((c[0] - want).abs() < 1e-3, "({x}, {y}): {} vs {want}", c[0]);
    }
}

/// The Radial Tiling node is wired to its function: Position's Blender x and z (the plane's
/// axes) → Radial Tiling (6.5 sides, roundness 0.3, normalised) → Emission gives Segment
/// Coordinates at each pixel centre; a second graph gives (Segment ID, Width, Rotation).
#[test]
fn radial_tiling_node_gives_the_function_value() {
    use caustic::shader::texture::{RadialTilingUse, radial_tiling};
    let graph = |emitted: Value| {
        json!([
            {"name": "Geometry", "type": "ShaderNodeNewGeometry"},
            {"name": "Split", "type": "ShaderNodeSeparateXYZ", "inputs": {"Vector": {"link": [0, "Position"]}}},
            {"name": "Plane", "type": "ShaderNodeCombineXYZ",
             "inputs": {"X": {"link": [1, "X"]}, "Y": {"link": [1, "Z"]}, "Z": {"value": 0.0}}},
            {"name": "Tiling", "type": "ShaderNodeRadialTiling", "props": {"normalize": true},
             "inputs": {"Vector": {"link": [2, "Vector"], "value": [0.0, 0.0]}, "Sides": {"value": 6.5},
                        "Roundness": {"value": 0.3}}},
            {"name": "Outputs", "type": "ShaderNodeCombineXYZ",
             "inputs": {"X": {"link": [3, "Segment ID"]}, "Y": {"link": [3, "Segment Width"]},
                        "Z": {"link": [3, "Segment Rotation"]}}},
            {"name": "Emission", "type": "ShaderNodeEmission", "inputs": {"Color": {"link": emitted}, "Strength": {"value": 1.0}}}
        ])
    };
    let coordinates =
        render_plane(node_material("radial", graph(json!([3, "Segment Coordinates"])), json!([5, "Emission"])), 4);
    let others = render_plane(node_material("radial", graph(json!([4, "Vector"])), json!([5, "Emission"])), 4);
    let all = RadialTilingUse { segment: true, segment_id: true };
    let segment = std::f32::consts::TAU / 6.5;
    for ((c, x, y), (o, _, _)) in coordinates.into_iter().zip(others) {
        let angle = y.atan2(x).rem_euclid(std::f32::consts::TAU);
        let from_divider = (angle - (angle / segment).round() * segment).abs().min(std::f32::consts::TAU - angle);
        // The samples lie within 0.0005 pixel (1.25e-4) of the centre: the pixels nearest the
        // origin (0.18 from it) see the parameter move by < 1e-3 there; none is near a divider.
        assert!(from_divider > 1e-2, "pixel ({x}, {y}) is at a divider");
        let want = radial_tiling(glam::Vec2::new(x, y), 6.5, 0.3, true, all);
        assert!(
            (c[0] - want.coordinates.x).abs() < 2e-3 && (c[1] - want.coordinates.y).abs() < 2e-3,
            "({x}, {y}): {c:?} vs {:?}",
            want.coordinates
        );
        assert_eq!(c[2], 0.0);
        assert_eq!(o[0], want.segment_id, "({x}, {y})");
        assert!(
            (o[1] - want.width).abs() < 1e-6 && (o[2] - want.rotation).abs() < 1e-6,
            "({x}, {y}): {o:?} vs {want:?}"
        );
    }
}

/// Image Texture (Closest, Repeat) on UV: each quadrant of the plane shows one texel of a
/// 2×2 sRGB PNG, decoded to linear; a ColorRamp on UV's u gives u back through its table.
#[test]
fn image_texture_and_color_ramp() {
    let dir = temp_dir();
    let texels: [[u8; 4]; 4] = [[255, 0, 0, 255], [0, 128, 0, 255], [0, 0, 64, 255], [255, 255, 255, 255]];
    let mut img = image::RgbaImage::new(2, 2);
    for (k, t) in texels.iter().enumerate() {
        img.put_pixel(k as u32 % 2, k as u32 / 2, image::Rgba(*t));
    }
    img.save(dir.path().join("tex.png")).unwrap();
    let nodes = json!([
        {"name": "Image", "type": "ShaderNodeTexImage",
         "props": {"image": 0, "interpolation": "Closest", "projection": "FLAT", "extension": "REPEAT"}},
        {"name": "Emission", "type": "ShaderNodeEmission",
         "inputs": {"Color": {"link": [0, "Color"]}, "Strength": {"value": 1.0}}}
    ]);
    let mut m = node_material("img", nodes, json!([1, "Emission"]));
    m["extensions"]["CAUSTIC_materials_nodes"]["images"] = json!([{"uri": "tex.png", "colorspace": "sRGB"}]);
    let srgb = |c: u8| {
        let c = c as f32 / 255.0;
        if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
    };
    for (c, x, y) in render_plane_in(dir.path(), m, 4, 1.0) {
        // The image's top row is at the top of the plane (y > 0).
        let k = (x > 0.0) as usize + 2 * (y < 0.0) as usize;
        let want = [srgb(texels[k][0]), srgb(texels[k][1]), srgb(texels[k][2])];
        for ch in 0..3 {
            assert!((c[ch] - want[ch]).abs() < 1e-5, "({x}, {y}) channel {ch}: {} vs {}", c[ch], want[ch]);
        }
    }
    let table: Vec<Value> = (0..256).map(|i| json!([i as f32 / 255.0, 0.5, 0.0, 1.0])).collect();
    let nodes = json!([
        {"name": "TexCoord", "type": "ShaderNodeTexCoord"},
        {"name": "Separate", "type": "ShaderNodeSeparateXYZ", "inputs": {"Vector": {"link": [0, "UV"]}}},
        {"name": "Ramp", "type": "ShaderNodeValToRGB",
         "props": {"color_ramp": {"interpolation": "LINEAR", "table": table}}, "inputs": {"Fac": {"link": [1, "X"]}}},
        {"name": "Emission", "type": "ShaderNodeEmission",
         "inputs": {"Color": {"link": [2, "Color"]}, "Strength": {"value": 1.0}}}
    ]);
    for (c, x, _) in render_plane(node_material("ramp", nodes, json!([3, "Emission"])), 4) {
        // A linear table read linearly is the identity (to f32 rounding).
        let u = (x + 1.0) / 2.0;
        assert!((c[0] - u).abs() < 2e-4 && (c[1] - 0.5).abs() < 1e-6, "({x}): {c:?} vs {u}");
    }
}

/// Float images keep their floats: a 2×2 linear EXR with values above 1 and below 1/255,
/// and a 16-bit PNG (Non-Color) whose values lie between two 8-bit steps, each quadrant
/// showing its texel exactly (8 bits would clamp 2.5 to 1 and round the fine values).
#[test]
fn float_and_16_bit_images_keep_their_values() {
    let dir = temp_dir();
    let hdr: [[f32; 4]; 4] =
        [[2.5, 0.25, 1e-3, 1.0], [7.0, 0.5, 0.125, 1.0], [0.0, 1.5, 3e-4, 1.0], [0.3, 0.3, 0.3, 1.0]];
    let mut img = image::Rgba32FImage::new(2, 2);
    for (k, t) in hdr.iter().enumerate() {
        img.put_pixel(k as u32 % 2, k as u32 / 2, image::Rgba(*t));
    }
    img.save(dir.path().join("tex.exr")).unwrap();
    let fine: [[u16; 4]; 4] =
        [[32769, 100, 65535, 65535], [1, 2, 3, 65535], [40000, 40001, 40002, 65535], [0, 65535, 12345, 65535]];
    let mut img16 = image::ImageBuffer::<image::Rgba<u16>, Vec<u16>>::new(2, 2);
    for (k, t) in fine.iter().enumerate() {
        img16.put_pixel(k as u32 % 2, k as u32 / 2, image::Rgba(*t));
    }
    img16.save(dir.path().join("fine.png")).unwrap();
    for (uri, colorspace, want) in [
        ("tex.exr", "Linear Rec.709", hdr.map(|t| [t[0], t[1], t[2]])),
        ("fine.png", "Non-Color", fine.map(|t| [t[0], t[1], t[2]].map(|v| v as f32 / 65535.0))),
    ] {
        let nodes = json!([
            {"name": "Image", "type": "ShaderNodeTexImage",
             "props": {"image": 0, "interpolation": "Closest", "projection": "FLAT", "extension": "REPEAT"}},
            {"name": "Emission", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"link": [0, "Color"]}, "Strength": {"value": 1.0}}}
        ]);
        let mut m = node_material("img", nodes, json!([1, "Emission"]));
        m["extensions"]["CAUSTIC_materials_nodes"]["images"] = json!([{"uri": uri, "colorspace": colorspace}]);
        for (c, x, y) in render_plane_in(dir.path(), m, 4, 1.0) {
            let k = (x > 0.0) as usize + 2 * (y < 0.0) as usize;
            for ch in 0..3 {
                // The texel itself: only the film's f32 accumulation rounds (relative 1e-6).
                let tol = 1e-6 * want[k][ch].max(1.0);
                assert!(
                    (c[ch] - want[k][ch]).abs() <= tol,
                    "{uri} ({x}, {y}) channel {ch}: {} vs {}",
                    c[ch],
                    want[k][ch]
                );
            }
        }
    }
}

/// Texture Coordinate Camera and Window on the plane under the orthographic camera at
/// z = 5 framing it: Camera is (x, y, 5) (z forward), Window ((x + 1)/2, (y + 1)/2, 0).
#[test]
fn camera_and_window_coordinates() {
    for (output, want) in [
        ("Camera", (|x: f32, y: f32| [x, y, 5.0]) as fn(f32, f32) -> [f32; 3]),
        ("Window", |x: f32, y: f32| [(x + 1.0) / 2.0, (y + 1.0) / 2.0, 0.0]),
    ] {
        let nodes = json!([
            {"name": "TexCoord", "type": "ShaderNodeTexCoord"},
            {"name": "Abs", "type": "ShaderNodeVectorMath", "props": {"operation": "ABSOLUTE"},
             "inputs": {"Vector": {"link": [0, output]}}},
            {"name": "Emission", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"link": [1, "Vector"]}, "Strength": {"value": 1.0}}}
        ]);
        for (c, x, y) in render_plane(node_material("coords", nodes, json!([2, "Emission"])), 4) {
            let w = want(x, y).map(f32::abs);
            for ch in 0..3 {
                // Samples within 0.0005 pixel of the centre (2.5e-4 in x, y), plus f32 rounding.
                assert!((c[ch] - w[ch]).abs() < 3e-4, "{output} ({x}, {y}) channel {ch}: {} vs {}", c[ch], w[ch]);
            }
        }
    }
}

/// Checker Texture on UV: every pixel centre shows exactly one of the two colours, the one
/// the texture function gives there (the cells' edges fall between pixel centres).
#[test]
fn checker_gives_exactly_the_two_colours() {
    use caustic::shader::texture::checker_texture;
    let nodes = json!([
        {"name": "TexCoord", "type": "ShaderNodeTexCoord"},
        {"name": "Checker", "type": "ShaderNodeTexChecker",
         "inputs": {"Vector": {"link": [0, "UV"]}, "Color1": {"value": [0.9, 0.5, 0.1, 1.0]},
                    "Color2": {"value": [0.1, 0.2, 0.7, 1.0]}, "Scale": {"value": 2.0}}},
        {"name": "Emission", "type": "ShaderNodeEmission",
         "inputs": {"Color": {"link": [1, "Color"]}, "Strength": {"value": 1.0}}}
    ]);
    let (c1, c2) = (glam::Vec3::new(0.9, 0.5, 0.1), glam::Vec3::new(0.1, 0.2, 0.7));
    let mut seen = [false; 2];
    for (c, x, y) in render_plane(node_material("checker", nodes, json!([2, "Emission"])), 4) {
        let uv = glam::Vec3::new((x + 1.0) / 2.0, (y + 1.0) / 2.0, 0.0);
        let want = checker_texture(uv, c1, c2, 2.0).0;
        let got = glam::Vec3::from(c);
        assert!((got - want).abs().max_element() < 1e-6, "({x}, {y}): {got} vs {want}");
        seen[(want == c1) as usize] = true;
        assert!(want == c1 || want == c2);
    }
    assert!(seen[0] && seen[1], "both colours appear");
}

/// Bump of a linear height h = 0.5 x (Distance 2): the bumped normal is
/// normalize(N − 2 ∇h) = normalize((−1, 0, 1)) in glTF axes, (−1, −1, 0)/√2 in Blender's;
/// shown through Emission as the normal plus (1, 1, 1).
#[test]
fn bump_of_a_linear_height_tilts_the_normal_by_its_gradient() {
    let nodes = json!([
        {"name": "Geometry", "type": "ShaderNodeNewGeometry"},
        {"name": "Separate", "type": "ShaderNodeSeparateXYZ", "inputs": {"Vector": {"link": [0, "Position"]}}},
        {"name": "Height", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
         "inputs": {"Value": {"link": [1, "X"]}, "Value_001": {"value": 0.5}}},
        {"name": "Bump", "type": "ShaderNodeBump", "props": {"invert": false},
         "inputs": {"Strength": {"value": 1.0}, "Distance": {"value": 2.0}, "Height": {"link": [2, "Value"]}}},
        {"name": "Shift", "type": "ShaderNodeVectorMath", "props": {"operation": "ADD"},
         "inputs": {"Vector": {"link": [3, "Normal"]}, "Vector_001": {"value": [1, 1, 1]}}},
        {"name": "Emission", "type": "ShaderNodeEmission",
         "inputs": {"Color": {"link": [4, "Vector"]}, "Strength": {"value": 1.0}}}
    ]);
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let want = [1.0 - s, 1.0 - s, 1.0];
    for (c, x, y) in render_plane(node_material("bump", nodes, json!([5, "Emission"])), 4) {
        for k in 0..3 {
            // Finite differences of a linear height are exact up to f32 rounding of h
            // (6e-8 over a difference of 5e-5): 1e-3 relative in the gradient.
            assert!((c[k] - want[k]).abs() < 2e-3, "({x}, {y}) channel {k}: {} vs {}", c[k], want[k]);
        }
    }
}

/// Transparent through coverage: Mix(0.25, Emission 1, Transparent white) over the black,
/// transparent background gives radiance 0.75 and alpha 0.75, as Cycles (the emission's
/// weight 0.75, a quarter of the light passes to the background).
#[test]
fn transparent_mix_gives_coverage() {
    let nodes = json!([
        {"name": "Emission", "type": "ShaderNodeEmission", "inputs": {"Color": {"value": [1, 1, 1, 1]}, "Strength": {"value": 1.0}}},
        {"name": "Transparent", "type": "ShaderNodeBsdfTransparent", "inputs": {"Color": {"value": [1, 1, 1, 1]}}},
        {"name": "Mix", "type": "ShaderNodeMixShader",
         "inputs": {"Fac": {"value": 0.25}, "Shader": {"link": [0, "Emission"]}, "Shader_001": {"link": [1, "BSDF"]}}}
    ]);
    let dir = temp_dir();
    let scene = plane_scene(dir.path(), "t.gltf", node_material("glassy", nodes, json!([2, "Shader"])));
    let px = render_image(&scene, &dir.path().join("o.exr"), &["--resolution", "4x4", "--spp", "4096"], LIMIT);
    let n = px.len() as f64;
    let (mean_c, mean_a) = px.iter().fold((0.0, 0.0), |(c, a), p| (c + p[0] as f64 / n, a + p[3] as f64 / n));
    // Stochastic coverage: 65536 Bernoulli(0.75) draws, σ = 0.0017; 5σ.
    assert!((mean_c - 0.75).abs() < 0.009 && (mean_a - 0.75).abs() < 0.009, "radiance {mean_c}, alpha {mean_a}");
}

/// A coloured Transparent BSDF tints what passes, in the walk and in shadow rays: a white
/// Diffuse cube inside a closed box of Transparent (0.5, 0.7, 0.9) walls under a uniform
/// white world. Seen through a wall the world is T; the convex cube (albedo 1, no
/// interreflection) is lit only through the walls, by T per channel (shadow rays carry T,
/// BSDF-sampled paths pass by T's mean and are weighted T / mean). So every pixel is T, for
/// the path tracer and BDPT.
#[test]
fn coloured_transparent_tints_paths_and_shadows() {
    let t = [0.5, 0.7, 0.9];
    for integrator in ["path", "bdpt"] {
        let dir = temp_dir();
        let mut g = GltfBuilder::new();
        g.use_ext("CAUSTIC_materials_nodes");
        let walls = g.material(node_material(
            "tinted",
            json!([{"name": "Transparent", "type": "ShaderNodeBsdfTransparent",
                    "inputs": {"Color": {"value": [t[0], t[1], t[2], 1]}}}]),
            json!([0, "BSDF"]),
        ));
        let white = g.material(node_material(
            "white",
            json!([{"name": "Diffuse", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"value": [1, 1, 1, 1]}}}]),
            json!([0, "BSDF"]),
        ));
        g.cube([-3.0, -3.0, -3.0], [3.0, 3.0, 3.0], walls);
        g.cube([-0.5, -0.5, -0.5], [0.5, 0.5, 0.5], white);
        g.camera([0.3, 0.4, 2.5], look_rotation([-0.1, -0.15, -1.0]), 1.2);
        g.world(json!({"color": [1, 1, 1]}));
        // An opaque film: the world seen through the walls is part of the image.
        g.settings(json!({"filter": "box", "transparent": false}));
        let scene = g.write(dir.path(), "tinted.gltf");
        let px = render_image(
            &scene,
            &dir.path().join("o.exr"),
            &["--resolution", "16x16", "--spp", "256", "--max-depth", "6", "--integrator", integrator],
            LIMIT,
        );
        for k in 0..3 {
            let v: Vec<f64> = px.iter().map(|p| p[k] as f64).collect();
            let (mean, se) = mean_se(&v);
            eprintln!("{integrator} channel {k}: {mean:.4} ± {se:.4} (want {})", t[k]);
            // Box-filtered pixels are independent estimates: 5 standard errors.
            assert!((mean - t[k]).abs() < 5.0 * se, "{integrator} channel {k}: {mean} ± {se}, want {}", t[k]);
        }
    }
}

/// Normal Map (tangent space) on the plane, whose MikkTSpace frame is (+x, +y, +z): the
/// colour of the tangent-space normal t = normalize(0.5, 0, 1) gives t in the world
/// (Blender axes (t.x, −t.z, t.y)), shown through Emission plus (1, 1, 1). The loader makes
/// the tangents because the graph asks for them.
#[test]
fn tangent_space_normal_map_uses_generated_tangents() {
    let t = glam::Vec3::new(0.5, 0.0, 1.0).normalize();
    let c = t * 0.5 + glam::Vec3::splat(0.5);
    let nodes = json!([
        {"name": "Normal Map", "type": "ShaderNodeNormalMap", "props": {"space": "TANGENT"},
         "inputs": {"Strength": {"value": 1.0}, "Color": {"value": [c.x, c.y, c.z, 1.0]}}},
        {"name": "Shift", "type": "ShaderNodeVectorMath", "props": {"operation": "ADD"},
         "inputs": {"Vector": {"link": [0, "Normal"]}, "Vector_001": {"value": [1, 1, 1]}}},
        {"name": "Emission", "type": "ShaderNodeEmission",
         "inputs": {"Color": {"link": [1, "Vector"]}, "Strength": {"value": 1.0}}}
    ]);
    let want = [1.0 + t.x, 1.0 - t.z, 1.0 + t.y];
    for (px, x, y) in render_plane(node_material("nmap", nodes, json!([2, "Emission"])), 4) {
        for k in 0..3 {
            // MikkTSpace on a flat quad is exact up to f32 rounding.
            assert!((px[k] - want[k]).abs() < 1e-4, "({x}, {y}) channel {k}: {} vs {}", px[k], want[k]);
        }
    }
}

/// A white furnace of mixed closures: a closed cube of double-sided walls whose graph is
/// Add(Emission Le, Mix(0.3, Diffuse white, Glossy white)) seen from inside. Every lobe
/// keeps all the light (the glossy one through multiscatter compensation), so with at most
/// D = 3 scattering events each pixel sees (D + 1) Le = 4 Le.
#[test]
fn mixed_closures_white_furnace() {
    let dir = temp_dir();
    let mut g = GltfBuilder::new();
    g.use_ext("CAUSTIC_materials_nodes");
    let nodes = json!([
        {"name": "Diffuse", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"value": [1, 1, 1, 1]}}},
        {"name": "Glossy", "type": "ShaderNodeBsdfGlossy", "props": {"distribution": "MULTI_GGX"},
         "inputs": {"Color": {"value": [1, 1, 1, 1]}, "Roughness": {"value": 0.4}}},
        {"name": "Mix", "type": "ShaderNodeMixShader",
         "inputs": {"Fac": {"value": 0.3}, "Shader": {"link": [0, "BSDF"]}, "Shader_001": {"link": [1, "BSDF"]}}},
        {"name": "Emission", "type": "ShaderNodeEmission", "inputs": {"Color": {"value": [1, 1, 1, 1]}, "Strength": {"value": 0.5}}},
        {"name": "Add", "type": "ShaderNodeAddShader",
         "inputs": {"Shader": {"link": [2, "Shader"]}, "Shader_001": {"link": [3, "Emission"]}}}
    ]);
    let m = g.material(node_material("furnace", nodes, json!([4, "Shader"])));
    g.cube([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], m);
    g.camera([0.1, 0.2, 0.3], look_rotation([0.3, -0.2, -1.0]), 1.2);
    let scene = g.write(dir.path(), "furnace.gltf");
    let px = render_image(
        &scene,
        &dir.path().join("o.exr"),
        &["--resolution", "16x16", "--spp", "64", "--max-depth", "3"],
        LIMIT,
    );
    let mean = px.iter().map(|p| p[0] as f64).sum::<f64>() / px.len() as f64;
    eprintln!("mixed-closure furnace: mean {mean} (want 2)");
    // 4 × 0.5 = 2. The glossy lobe's multiscatter tables hold its albedo within 1 % (README)
    // and it is 70 % of the mixture; 16k paths of bounded weight add < 0.5 % (4σ).
    assert!((mean - 2.0).abs() < 0.03 * 2.0, "furnace mean {mean} (want 2)");
}

/// A cycle is a bad scene (exit 3) naming the material and a node of the cycle.
#[test]
fn a_cycle_is_refused_naming_material_and_node() {
    let nodes = json!([
        {"name": "First", "type": "ShaderNodeMath", "inputs": {"Value": {"link": [1, "Value"]}}},
        {"name": "Second", "type": "ShaderNodeMath", "inputs": {"Value": {"link": [0, "Value"]}}},
        {"name": "Emission", "type": "ShaderNodeEmission", "inputs": {"Strength": {"link": [0, "Value"]}}}
    ]);
    let dir = temp_dir();
    let scene = plane_scene(dir.path(), "cycle.gltf", node_material("Loop", nodes, json!([2, "Emission"])));
    let out = dir.path().join("o.exr");
    let r = run(&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"], LIMIT);
    assert_eq!(r.code, Some(3), "{}", r.stderr);
    let msg = r.error_message().unwrap();
    assert!(msg.contains("material 'Loop'") && msg.contains("cycle"), "{msg}");
    assert!(msg.contains("'First'") || msg.contains("'Second'"), "{msg}");
}

/// Links to missing nodes or outputs and wrong value shapes are bad scenes naming the node.
#[test]
fn bad_links_and_values_are_refused() {
    let cases = [
        (
            json!([{"name": "E", "type": "ShaderNodeEmission", "inputs": {"Strength": {"link": [7, "Value"]}}}]),
            "links to node 7",
        ),
        (
            json!([{"name": "M", "type": "ShaderNodeMath"},
                   {"name": "E", "type": "ShaderNodeEmission", "inputs": {"Strength": {"link": [0, "Nope"]}}}]),
            "output 'Nope'",
        ),
        (
            json!([{"name": "E", "type": "ShaderNodeEmission", "inputs": {"Strength": {"value": [1, 2, 3]}}}]),
            "expects a number",
        ),
        (
            json!([{"name": "R", "type": "ShaderNodeRadialTiling", "props": {"normalize": "yes"}},
                   {"name": "E", "type": "ShaderNodeEmission", "inputs": {"Strength": {"link": [0, "Segment ID"]}}}]),
            "'normalize' must be true or false",
        ),
        (
            json!([{"name": "R", "type": "ShaderNodeRadialTiling", "inputs": {"Vector": {"value": [1.0]}}},
                   {"name": "E", "type": "ShaderNodeEmission", "inputs": {"Strength": {"link": [0, "Segment ID"]}}}]),
            "expects 2 or 3 numbers",
        ),
    ];
    for (nodes, want) in cases {
        let last = nodes.as_array().unwrap().len() - 1;
        let dir = temp_dir();
        let scene = plane_scene(dir.path(), "bad.gltf", node_material("Bad", nodes, json!([last, "Emission"])));
        let out = dir.path().join("o.exr");
        let r = run(&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"], LIMIT);
        assert_eq!(r.code, Some(3), "{want}: {}", r.stderr);
        let msg = r.error_message().unwrap();
        assert!(msg.contains("material 'Bad'") && msg.contains(want), "{msg}");
    }
}

/// An unknown node type is a warning naming material, node and type; its outputs are 0.
#[test]
fn an_unknown_node_type_is_a_warning_and_gives_zero() {
    let nodes = json!([
        {"name": "Mystery", "type": "ShaderNodeFancyThing"},
        {"name": "Add", "type": "ShaderNodeMath", "props": {"operation": "ADD"},
         "inputs": {"Value": {"link": [0, "Fac"]}, "Value_001": {"value": 0.25}}},
        {"name": "Emission", "type": "ShaderNodeEmission", "inputs": {"Strength": {"link": [1, "Value"]}}}
    ]);
    let dir = temp_dir();
    let scene = plane_scene(dir.path(), "unknown.gltf", node_material("Odd", nodes, json!([2, "Emission"])));
    let out = dir.path().join("o.exr");
    let r = run(
        &[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--progress",
            "json",
            "--resolution",
            "4x4",
            "--spp",
            "4",
        ],
        LIMIT,
    );
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let warned = r
        .warnings()
        .iter()
        .any(|m| m.contains("'Odd'") && m.contains("'Mystery'") && m.contains("ShaderNodeFancyThing"));
    assert!(warned, "{}", r.stderr);
    let px = caustic::output::read_combined(&out).unwrap().2;
    // 0 + 0.25 with an unlinked (white) colour.
    assert!(px.iter().all(|p| (p[0] - 0.25).abs() < 1e-5), "{:?}", px[0]);
}

/// A Holdout closure: a camera ray takes its weight from the film's alpha and the rest of the
/// closures shade on (Cycles' `integrate_surface_holdout`), in every integrator. The plane is
/// a Mix Shader of Holdout and a white Emission of strength 1 at factor `fac`: colour and
/// alpha are 1 − `fac` at every pixel (no noise: the camera sees the emission directly);
/// Holdout alone (`fac` 1) ends the path: colour and alpha 0.
#[test]
fn holdout_takes_its_weight_from_alpha_in_every_integrator() {
    for fac in [0.5f32, 1.0] {
        let nodes = json!([
            {"name": "Emission", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"value": [1, 1, 1, 1]}, "Strength": {"value": 1.0}}},
            {"name": "Holdout", "type": "ShaderNodeHoldout"},
            {"name": "Mix", "type": "ShaderNodeMixShader",
             "inputs": {"Fac": {"value": fac}, "Shader": {"link": [0, "Emission"]}, "Shader_001": {"link": [1, "Holdout"]}}}
        ]);
        let dir = temp_dir();
        let scene = plane_scene(dir.path(), "h.gltf", node_material("held", nodes, json!([2, "Shader"])));
        for integrator in ["path", "photon", "sppm", "bdpt", "vcm"] {
            let args = ["--integrator", integrator, "--resolution", "4x4", "--spp", "4"];
            let px = render_image(&scene, &dir.path().join(format!("{integrator}.exr")), &args, LIMIT);
            let want = 1.0 - fac;
            for p in &px {
                for (k, v) in p.iter().enumerate() {
                    assert!((v - want).abs() < 1e-4, "{integrator}, factor {fac}: channel {k} is {v}, not {want}");
                }
            }
        }
    }
}

/// An Attribute node marked as the attribute the add-on exported as COLOR_0 by name
/// (`props.color_0`) reads COLOR_0 without a warning; unmarked it reads the attribute of its
/// name (docs/contract.md, "Attributes"), which this plane does not have: 0, named in a
/// warning (tests/attributes.rs reads ones it has).
#[test]
fn an_attribute_exported_as_colour_0_is_not_warned_about() {
    for marked in [false, true] {
        let mut props = json!({"attribute_name": "Col", "attribute_type": "GEOMETRY"});
        if marked {
            props["color_0"] = json!(true);
        }
        let nodes = json!([
            {"name": "Attribute", "type": "ShaderNodeAttribute", "props": props},
            {"name": "Emission", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"link": [0, "Color"]}, "Strength": {"value": 1.0}}}
        ]);
        let dir = temp_dir();
        let scene = plane_scene(dir.path(), "a.gltf", node_material("painted", nodes, json!([1, "Emission"])));
        let warnings = quick_render_warnings(&scene, &dir.path().join("o.exr"), &[], LIMIT);
        let warned = warnings.iter().any(|w| w.contains("'Col'") && w.contains("not on mesh"));
        assert_eq!(warned, !marked, "marked {marked}: {warnings:?}");
    }
}
