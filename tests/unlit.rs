//! `KHR_materials_unlit` end to end: a quad whose material is unlit shows its base colour ×
//! vertex colour exactly, however it is lit, and lights nothing else by reflection.

mod common;

use base64::Engine;
use common::{render_image, run, temp_dir};
use serde_json::json;
use std::time::Duration;

fn f32_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|f| f.to_le_bytes()).collect()
}

/// A 2×2 quad facing +Z, one vertex colour for all four vertices, an unlit material of base
/// colour `base`, a strong sun straight down onto it, and a camera looking down at it.
fn scene(dir: &std::path::Path, base: [f32; 3], vertex: [f32; 4]) -> std::path::PathBuf {
    let positions = f32_bytes(&[-1., -1., 0., 1., -1., 0., 1., 1., 0., -1., 1., 0.]);
    let normals = f32_bytes(&[0., 0., 1., 0., 0., 1., 0., 0., 1., 0., 0., 1.]);
    let colors = f32_bytes(&[vertex, vertex, vertex, vertex].concat());
    let indices: Vec<u8> = [0u32, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()).collect();
    let data = [positions, normals, colors, indices].concat();
    let views: Vec<_> = [(0, 48), (48, 48), (96, 64), (160, 24)]
        .iter()
        .map(|(o, l)| json!({"buffer": 0, "byteOffset": o, "byteLength": l}))
        .collect();
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&data));
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_unlit"],
        "extensionsRequired": ["KHR_materials_unlit"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 683.0 * 10.0}]}},
        "buffers": [{"uri": uri, "byteLength": data.len()}],
        "bufferViews": views,
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC4"},
            {"bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR"}
        ],
        "materials": [{"name": "flat", "pbrMetallicRoughness": {"baseColorFactor": [base[0], base[1], base[2], 1.0]},
            "extensions": {"KHR_materials_unlit": {}}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "COLOR_0": 2}, "indices": 3, "material": 0}]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.3, "znear": 0.01, "aspectRatio": 1.0}}],
        "nodes": [
            {"mesh": 0},
            {"camera": 0, "translation": [0.0, 0.0, 3.0]},
            // Lights shine along their node's -Z: straight down onto the quad.
            {"extensions": {"KHR_lights_punctual": {"light": 0}}}
        ],
        "scenes": [{"nodes": [0, 1, 2]}],
        "scene": 0
    });
    let path = dir.join("unlit.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

#[test]
fn an_unlit_quad_shows_base_colour_times_vertex_colour_under_any_light() {
    let dir = temp_dir();
    let (base, vertex) = ([0.8f32, 0.5, 0.25], [0.5f32, 1.0, 0.4, 1.0]);
    let path = scene(dir.path(), base, vertex);
    let out = dir.path().join("out.exr");
    let r = run(
        &[
            "render",
            path.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--resolution",
            "8x8",
            "--spp",
            "4",
            "--progress",
            "none",
        ],
        Duration::from_secs(60),
    );
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(!r.stderr.contains("KHR_materials_unlit"), "no warning about the extension: {}", r.stderr);
    let (_, _, px) = caustic::output::read_combined(&out).unwrap();
    for (i, p) in px.iter().enumerate() {
        for c in 0..3 {
            let want = base[c] * vertex[c];
            // The emission is the only term (the sun's 10 W/m² would add up to 10/π × colour
            // if the surface reflected it); f32 rounding of one product and the film's
            // average of 4 equal samples: 1e-5 relative bounds it.
            assert!((p[c] - want).abs() <= 1e-5 * want, "pixel {i} channel {c} = {}, want {want}", p[c]);
        }
    }
}

/// A grey floor lit by a sun at 45° from -x, and above it an unlit quad (base colour `base`)
/// whose shadow, if it cast one, would fall on the visible floor right of it; camera looking
/// straight down (16×16, 0.6 rad field: the floor spans ±0.93 at z = 0).
fn floor_under_unlit_quad(dir: &std::path::Path, base: [f32; 3], with_quad: bool) -> std::path::PathBuf {
    let mut g = common::GltfBuilder::new();
    let grey = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0],
        "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
    let flat = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [base[0], base[1], base[2], 1.0]},
        "extensions": {"KHR_materials_unlit": {}}}));
    g.use_ext("KHR_materials_unlit");
    // glTF is Y up: the floor is y = 0 (facing +Y), the quad at y = 1 spans x in [-0.9, -0.1].
    g.mesh(&[[-2.0, 0.0, -2.0], [-2.0, 0.0, 2.0], [2.0, 0.0, 2.0], [2.0, 0.0, -2.0]], &[0, 1, 2, 0, 2, 3], grey);
    if with_quad {
        g.mesh(
            &[[-0.9, 1.0, -0.25], [-0.9, 1.0, 0.25], [-0.1, 1.0, 0.25], [-0.1, 1.0, -0.25]],
            &[0, 1, 2, 0, 2, 3],
            flat,
        );
    }
    // Looking down -Y: a rotation of -90° about X.
    let h = std::f32::consts::FRAC_1_SQRT_2;
    g.camera([0.0, 3.0, 0.0], [-h, 0.0, 0.0, h], 0.6);
    // The sun shines along its node's -Z, turned to travel along (1, -1, 0)/√2 (90° about the
    // axis (-1, -1, 0)/√2): its shadow of the quad, if any, lies at x in [0.1, 0.9].
    let q = [-0.5, -0.5, 0.0, h];
    g.punctual(json!({"type": "directional", "intensity": 683.0 * 2.0}), [0.0, 5.0, 0.0], q);
    g.write(dir, if with_quad { "floor_unlit.gltf" } else { "floor.gltf" })
}

#[test]
fn an_unlit_surface_casts_no_shadow_and_lights_nothing_in_every_integrator() {
    // Blender's glTF importer renders KHR_materials_unlit as Emission to camera rays and
    // Transparent to every other ray (materials.rs): Cycles shows the colour, the floor gets the
    // whole sun and no glow. Before, the quad was an emitter that cast a shadow: the region
    // checked below was lit by the quad's emission alone (a few percent of the sun's).
    let dir = temp_dir();
    let base = [0.9f32, 0.45, 0.1];
    let render = |path: &std::path::Path, integrator: &str| {
        let out = dir.path().join(format!("{integrator}.exr"));
        let args = ["--resolution", "16x16", "--spp", "64", "--integrator", integrator];
        (16usize, render_image(path, &out, &args, Duration::from_secs(120)))
    };
    // The floor alone, path traced: what the floor must look like with the quad there too.
    let (w, bare) = render(&floor_under_unlit_quad(dir.path(), base, false), "path");
    let path = floor_under_unlit_quad(dir.path(), base, true);
    for integrator in ["path", "bdpt", "vcm", "photon", "sppm"] {
        let (_, px) = render(&path, integrator);
        let at = |x: usize, y: usize| px[y * w + x];
        // The quad fills columns 0..=4 of rows 6..=9 with its colour alone, whatever the
        // integrator: camera rays are the only ones that see it and it reflects nothing
        // (f32 rounding of the film's average: 1e-4 relative).
        for y in 6..=9 {
            for x in 0..=4 {
                let p = at(x, y);
                for c in 0..3 {
                    assert!((p[c] - base[c]).abs() <= 1e-4 * base[c], "{integrator}: quad pixel ({x}, {y}) = {p:?}");
                }
            }
        }
        // Where its shadow would fall (columns 10..=13, rows 6..=9, two filter radii inside)
        // the floor is as without the quad. The path tracer draws the same samples there, so
        // it is the same up to f32 (1e-4); the others estimate it (light tracing, photons):
        // their mean must be within 10 % — the shadow the quad cast took nearly all of it.
        let (mut sum, mut want) = (0.0, 0.0);
        for y in 6..=9 {
            for x in 10..=13 {
                let (got, bare) = (at(x, y)[1], bare[y * w + x][1]);
                sum += got;
                want += bare;
                if integrator == "path" {
                    assert!(
                        (got - bare).abs() <= 1e-4 * bare,
                        "path: floor ({x}, {y}) = {got}, without the quad {bare}"
                    );
                }
            }
        }
        assert!((sum - want).abs() <= 0.1 * want, "{integrator}: the floor where the shadow was: {sum}, want {want}");
    }
}
