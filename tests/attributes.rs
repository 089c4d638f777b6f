//! Attributes read by name (docs/contract.md, "Attributes") through the binary: a primitive's
//! `_CAUSTIC_*` vertex attributes and a node's `CAUSTIC_object_attributes`, read by the
//! Attribute, Color Attribute and Geometry nodes as Cycles reads them (interpolated, face
//! values exact, each type's outputs, not found: 0 with Alpha 1, a Color Attribute's Alpha 0),
//! the View Layer type's constant, a missing attribute named in a warning, and bad accessors
//! and extras refused naming the mesh and the attribute.
//!
//! The scene is tests/nodes.rs's: one quad z = 0, [-1, 1]², seen from +Z by an orthographic
//! camera framing it, a box filter a thousandth of a pixel wide, so that each pixel is the
//! emission graph's value at its centre.

mod common;

use base64::Engine;
use common::*;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);
const RES: usize = 8;
/// The quad's corners (glTF x, y; z = 0), in the order of its vertices.
const CORNERS: [[f32; 2]; 4] = [[-1., -1.], [1., -1.], [1., 1.], [-1., 1.]];

/// An extra vertex attribute of the quad: semantic, accessor type, component type, values.
struct Extra {
    semantic: String,
    kind: &'static str,
    component: u32,
    values: Vec<f32>,
}

fn float(semantic: &str, kind: &'static str, values: Vec<f32>) -> Extra {
    Extra { semantic: semantic.into(), kind, component: 5126, values }
}

/// The semantic of a named attribute: `_CAUSTIC_ATTR_` and the name's UTF-8 in hex.
fn named(name: &str) -> String {
    format!("_CAUSTIC_ATTR_{}", name.bytes().map(|b| format!("{b:02X}")).collect::<String>())
}

/// The quad with `extras` on its primitive and `node_extras` on its node.
fn quad_scene(dir: &Path, material: Value, extras: &[Extra], node_extras: Option<Value>) -> PathBuf {
    let pos: Vec<f32> = CORNERS.iter().flat_map(|c| [c[0], c[1], 0.0]).collect();
    let nrm: Vec<f32> = [0., 0., 1.].repeat(4);
    let idx: [u32; 6] = [0, 1, 2, 0, 2, 3];
    let mut data: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut push = |bytes: Vec<u8>, data: &mut Vec<u8>| {
        while !data.len().is_multiple_of(4) {
            data.push(0);
        }
        views.push(json!({"buffer": 0, "byteOffset": data.len(), "byteLength": bytes.len()}));
        data.extend(bytes);
        views.len() - 1
    };
    let floats = |v: &[f32]| v.iter().flat_map(|f| f.to_le_bytes()).collect::<Vec<u8>>();
    push(floats(&pos), &mut data);
    push(floats(&nrm), &mut data);
    push(idx.iter().flat_map(|i| i.to_le_bytes()).collect(), &mut data);
    let mut accessors = vec![
        json!({"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]}),
        json!({"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"}),
        json!({"bufferView": 2, "componentType": 5125, "count": 6, "type": "SCALAR"}),
    ];
    let mut attributes = json!({"POSITION": 0, "NORMAL": 1});
    for e in extras {
        let width = match e.kind {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            "MAT2" => 4,
            other => panic!("{other}"),
        };
        let bytes = match e.component {
            5126 => floats(&e.values),
            _ => e.values.iter().map(|&v| v as u8).collect(),
        };
        let view = push(bytes, &mut data);
        let count = e.values.len() / width;
        accessors.push(json!({"bufferView": view, "componentType": e.component, "count": count, "type": e.kind}));
        attributes[&e.semantic] = json!(accessors.len() - 1);
    }
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&data));
    let mut node = json!({"mesh": 0, "name": "Quad"});
    if let Some(x) = node_extras {
        node["extras"] = json!({"CAUSTIC_object_attributes": x});
    }
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["CAUSTIC_materials_nodes"],
        "buffers": [{"uri": uri, "byteLength": data.len()}],
        "bufferViews": views,
        "accessors": accessors,
        "materials": [material],
        "meshes": [{"name": "Sheet", "primitives": [{"attributes": attributes, "indices": 2, "material": 0}]}],
        "cameras": [{"type": "orthographic", "orthographic": {"xmag": 1.0, "ymag": 1.0, "znear": 0.1, "zfar": 100.0}}],
        "nodes": [node, {"camera": 0, "translation": [0, 0, 5]}],
        "scenes": [{"nodes": [0, 1], "extras": {"caustic": {"filter": "box", "filter_width": 0.001}}}],
        "scene": 0
    });
    let path = dir.join("quad.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

/// An emission of colour (r, g, b) from three float sockets: `sources` are nodes (their
/// outputs linked in `channels`, (node, output) per channel).
fn emission_of(mut nodes: Vec<Value>, channels: [(usize, &str); 3]) -> Value {
    let combine = nodes.len();
    nodes.push(json!({"name": "Combine", "type": "ShaderNodeCombineXYZ", "inputs": {
        "X": {"link": [channels[0].0, channels[0].1]},
        "Y": {"link": [channels[1].0, channels[1].1]},
        "Z": {"link": [channels[2].0, channels[2].1]}}}));
    nodes.push(json!({"name": "Emission", "type": "ShaderNodeEmission",
        "inputs": {"Color": {"link": [combine, "Vector"]}, "Strength": {"value": 1.0}}}));
    json!({"name": "M", "extensions": {"CAUSTIC_materials_nodes":
        {"version": 1, "nodes": nodes, "output": {"surface": [combine + 1, "Emission"]}}}})
}

fn attribute(name: &str, kind: &str) -> Value {
    json!({"name": format!("{kind} {name}"), "type": "ShaderNodeAttribute",
           "props": {"attribute_name": name, "attribute_type": kind}})
}

/// A pixel's RGB and its centre (x, y).
type Pixel = ([f32; 3], f32, f32);

/// A case: the graph's nodes, the outputs that make the emission's R, G, B, and the expected
/// colour at (x, y).
type Case = (Value, [(usize, &'static str); 3], Box<dyn Fn(f32, f32) -> [f32; 3]>);

/// Renders the quad; its pixels, and the warnings.
fn render(dir: &Path, scene: &Path) -> (Vec<Pixel>, Vec<String>) {
    let out = dir.join("o.exr");
    let res = format!("{RES}x{RES}");
    let args = ["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"];
    let r = run(&[&args[..], &["--resolution", &res, "--spp", "4"]].concat(), LIMIT);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let px = caustic::output::read_combined(&out).unwrap().2;
    let pixels = px
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (col, row) = (i % RES, i / RES);
            let x = -1.0 + (col as f32 + 0.5) * 2.0 / RES as f32;
            let y = 1.0 - (row as f32 + 0.5) * 2.0 / RES as f32;
            ([p[0], p[1], p[2]], x, y)
        })
        .collect();
    (pixels, r.warnings())
}

/// The value at (x, y) of a function linear in x and y given at the corners (the
/// barycentric interpolation of either triangle reproduces it exactly).
fn linear(f: impl Fn(f32, f32) -> f32) -> Vec<f32> {
    CORNERS.iter().map(|c| f(c[0], c[1])).collect()
}

/// A warning about attributes read by name (the loader's other notes, e.g. a varying
/// emission's light weights, are not this test's).
fn about_attributes(w: &str) -> bool {
    ["attribute", "Pointiness", "Random Per Island", "View Layer"].iter().any(|k| w.contains(k))
}

fn close(got: [f32; 3], want: [f32; 3], what: &str) {
    for k in 0..3 {
        // Samples within 0.0005 pixel of the centre (slopes below 1 per unit: 1.3e-4), f32 rounding.
        assert!((got[k] - want[k]).abs() < 2e-4, "{what}: channel {k} is {}, not {}", got[k], want[k]);
    }
}

/// A float, a float2 and an RGBA attribute on the points, each read through every output by
/// Cycles' rules: a float f is Vector (f, f, f), Fac f, Alpha 1; a float2 (x, y) Vector
/// (x, y, 0), Fac x; an RGBA Vector its RGB, Fac their average, Alpha its A.
#[test]
fn attributes_are_interpolated_and_converted_as_cycles_reads_them() {
    let f = |x: f32, y: f32| 0.5 + 0.25 * x + 0.125 * y;
    let (u, v) = (|x: f32, _: f32| 0.3 + 0.2 * x, |_: f32, y: f32| 0.6 - 0.3 * y);
    let rgba: Vec<f32> =
        CORNERS.iter().flat_map(|c| [0.2 + 0.1 * c[0], 0.4, 0.7 - 0.2 * c[1], 0.5 + 0.25 * c[0]]).collect();
    let extras = [
        float(&named("wet"), "SCALAR", linear(f)),
        float(&named("flow map"), "VEC2", CORNERS.iter().flat_map(|c| [u(c[0], c[1]), v(c[0], c[1])]).collect()),
        float(&named("Paint"), "VEC4", rgba),
    ];
    let dir = temp_dir();
    let cases: [Case; 3] = [
        // Float: Color's red, Fac, Alpha.
        (
            json!([attribute("wet", "GEOMETRY"), {"name": "Split", "type": "ShaderNodeSeparateXYZ",
                   "inputs": {"Vector": {"link": [0, "Color"]}}}]),
            [(1, "X"), (0, "Fac"), (0, "Alpha")],
            Box::new(move |x, y| [f(x, y), f(x, y), 1.0]),
        ),
        // Float2: Vector's x and y (z is 0, read as Fac's stand-in: x).
        (
            json!([attribute("flow map", "GEOMETRY"), {"name": "Split", "type": "ShaderNodeSeparateXYZ",
                   "inputs": {"Vector": {"link": [0, "Vector"]}}}]),
            [(1, "X"), (1, "Y"), (0, "Fac")],
            Box::new(move |x, y| [u(x, y), v(x, y), u(x, y)]),
        ),
        // RGBA: Color's blue, Fac (the average), Alpha.
        (
            json!([attribute("Paint", "GEOMETRY"), {"name": "Split", "type": "ShaderNodeSeparateXYZ",
                   "inputs": {"Vector": {"link": [0, "Color"]}}}]),
            [(1, "Z"), (0, "Fac"), (0, "Alpha")],
            Box::new(|x, y| [0.7 - 0.2 * y, ((0.2 + 0.1 * x) + 0.4 + (0.7 - 0.2 * y)) / 3.0, 0.5 + 0.25 * x]),
        ),
    ];
    for (k, (nodes, channels, want)) in cases.into_iter().enumerate() {
        let material = emission_of(nodes.as_array().unwrap().clone(), channels);
        let scene = quad_scene(dir.path(), material, &extras, None);
        let (px, warnings) = render(dir.path(), &scene);
        assert!(!warnings.iter().any(|w| about_attributes(w)), "case {k}: {warnings:?}");
        for (c, x, y) in px {
            close(c, want(x, y), &format!("case {k} at ({x}, {y})"));
        }
    }
}

/// A value equal at a face's corners (a face attribute; Random Per Island) reads bit for bit;
/// Pointiness and the render colour attribute (a Color Attribute node without a name) read
/// theirs; an Object attribute and a View Layer constant give their RGBA by the same rules.
#[test]
fn face_values_geometry_outputs_object_and_view_layer_attributes() {
    let island = 0.123_456_79_f32;
    let extras = [
        float("_CAUSTIC_RANDOM_PER_ISLAND", "SCALAR", vec![island; 4]),
        float("_CAUSTIC_POINTINESS", "SCALAR", linear(|x, _| 0.5 + 0.1 * x)),
        float("_CAUSTIC_RENDER_COLOR", "VEC4", [0.25, 0.5, 0.75, 0.4].repeat(4)),
    ];
    let dir = temp_dir();
    let geometry = json!({"name": "Geometry", "type": "ShaderNodeNewGeometry"});
    let colour = json!({"name": "Color Attribute", "type": "ShaderNodeVertexColor", "props": {"layer_name": ""}});
    let material = emission_of(vec![geometry, colour], [(0, "Random Per Island"), (0, "Pointiness"), (1, "Alpha")]);
    let scene = quad_scene(dir.path(), material, &extras, None);
    let (px, warnings) = render(dir.path(), &scene);
    assert!(!warnings.iter().any(|w| about_attributes(w)), "{warnings:?}");
    for (c, x, _) in px {
        assert_eq!(c[0].to_bits(), island.to_bits(), "Random Per Island at x {x}");
        close(c, [island, 0.5 + 0.1 * x, 0.4], &format!("x {x}"));
    }

    let object = json!({"object": {"tint": [0.2, 0.4, 0.9, 0.5]}, "instancer": {"tint": [0.6, 0.6, 0.6, 1.0]}});
    let nodes = vec![
        attribute("tint", "OBJECT"),
        attribute("tint", "INSTANCER"),
        json!({"name": "Layer", "type": "ShaderNodeAttribute",
               "props": {"attribute_name": "level", "attribute_type": "VIEW_LAYER", "view_layer_value": [0.3, 0.6, 0.9, 0.25]}}),
    ];
    let material = emission_of(nodes, [(0, "Alpha"), (1, "Fac"), (2, "Fac")]);
    let scene = quad_scene(dir.path(), material, &[], Some(object));
    let (px, warnings) = render(dir.path(), &scene);
    assert!(!warnings.iter().any(|w| about_attributes(w)), "{warnings:?}");
    for (c, x, y) in px {
        close(c, [0.5, 0.6, 0.6], &format!("({x}, {y})"));
    }
}

/// An attribute the mesh does not have reads 0, Alpha 1 (a Color Attribute node's Alpha 0),
/// as Cycles; the material, the node, the attribute and the mesh are named in a warning.
#[test]
fn a_missing_attribute_reads_zero_and_is_named() {
    let dir = temp_dir();
    let colour = json!({"name": "Paint", "type": "ShaderNodeVertexColor", "props": {"layer_name": "paint"}});
    let material = emission_of(vec![attribute("wet", "GEOMETRY"), colour], [(0, "Fac"), (0, "Alpha"), (1, "Alpha")]);
    let scene = quad_scene(dir.path(), material, &[float(&named("other"), "SCALAR", vec![0.5; 4])], None);
    let (px, warnings) = render(dir.path(), &scene);
    for (c, x, y) in px {
        close(c, [0.0, 1.0, 0.0], &format!("({x}, {y})"));
    }
    for (node, what) in [("GEOMETRY wet", "attribute 'wet'"), ("Paint", "attribute 'paint'")] {
        let named = warnings.iter().any(|w| {
            w.contains("material 'M'")
                && w.contains(&format!("node '{node}'"))
                && w.contains(what)
                && w.contains("'Sheet'")
        });
        assert!(named, "{node}: {warnings:?}");
    }
}

/// Bad attribute data is a bad scene (exit 3) naming the mesh and the attribute, never a
/// panic: a count that is not the vertices', a NaN, integer components, a matrix type, a name
/// that is not hex, and object attributes that are not four numbers.
#[test]
fn bad_attributes_are_refused_naming_mesh_and_attribute() {
    let wet = named("wet");
    let cases: Vec<(Vec<Extra>, Option<Value>, Vec<&str>)> = vec![
        (
            vec![float(&wet, "SCALAR", vec![0.5; 3])],
            None,
            vec!["'Sheet'", "attribute 'wet'", "3 entries for 4 vertices"],
        ),
        (vec![float(&wet, "SCALAR", vec![0.5, f32::NAN, 0.5, 0.5])], None, vec!["'Sheet'", "attribute 'wet'", "NaN"]),
        (
            vec![Extra { semantic: wet.clone(), kind: "SCALAR", component: 5121, values: vec![1.0; 4] }],
            None,
            vec!["'Sheet'", "attribute 'wet'", "FLOAT expected"],
        ),
        (vec![float(&wet, "MAT2", vec![0.5; 16])], None, vec!["'Sheet'", "attribute 'wet'", "SCALAR or VEC2-4"]),
        (vec![float("_CAUSTIC_ATTR_7", "SCALAR", vec![0.5; 4])], None, vec!["'Sheet'", "_CAUSTIC_ATTR_7", "hex"]),
        (vec![], Some(json!({"object": {"wet": [1, 2, 3]}})), vec!["'Quad'", "CAUSTIC_object_attributes", "'wet'"]),
        (vec![], Some(json!({"sideways": {}})), vec!["'Quad'", "CAUSTIC_object_attributes", "sideways"]),
    ];
    for (k, (extras, object, wants)) in cases.into_iter().enumerate() {
        let dir = temp_dir();
        let material = emission_of(
            vec![attribute("wet", if object.is_some() { "OBJECT" } else { "GEOMETRY" })],
            [(0, "Fac"), (0, "Fac"), (0, "Fac")],
        );
        let scene = quad_scene(dir.path(), material, &extras, object);
        let out = dir.path().join("o.exr");
        let r = run(&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"], LIMIT);
        assert_eq!(r.code, Some(3), "case {k}: {}", r.stderr);
        let msg = r.error_message().unwrap_or_default();
        for want in wants {
            assert!(msg.contains(want), "case {k}: '{want}' not in: {msg}");
        }
    }
}
