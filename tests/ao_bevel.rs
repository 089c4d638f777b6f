//! The Ambient Occlusion and Bevel nodes (`shader::trace`) through the binary, on scenes
//! with closed-form answers: an emissive surface whose Emission colour is the node's
//! output, seen by an orthographic camera from +Z with a box filter a thousandth of a pixel
//! wide (every pixel is the node's value at its centre, averaged over the samples).

mod common;

use common::*;
use serde_json::{Value, json};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);
/// Pixels across the frame [-1, 1]².
const RES: usize = 8;

/// A material whose emission is the node graph `nodes` output `emit` (Strength 1).
fn emitting(name: &str, mut nodes: Vec<Value>, emit: Value) -> Value {
    let n = nodes.len();
    nodes.push(json!({"name": "Emission", "type": "ShaderNodeEmission",
        "inputs": {"Color": {"link": emit}, "Strength": {"value": 1.0}}}));
    json!({"name": name, "extensions": {"CAUSTIC_materials_nodes":
        {"version": 1, "nodes": nodes, "output": {"surface": [n, "Emission"]}}}})
}

/// An axis-aligned quad: the corners listed counter-clockwise seen from the front.
fn quad(c: [[f32; 3]; 4]) -> (Vec<[f32; 3]>, Vec<u32>) {
    (c.to_vec(), vec![0, 1, 2, 0, 2, 3])
}

/// One mesh of several quads (separate corners: flat normals) on one node.
fn mesh_of(g: &mut GltfBuilder, quads: &[(Vec<[f32; 3]>, Vec<u32>)], material: usize) -> usize {
    let (mut pos, mut idx) = (Vec::new(), Vec::new());
    for (p, i) in quads {
        let base = pos.len() as u32;
        pos.extend_from_slice(p);
        idx.extend(i.iter().map(|k| k + base));
    }
    g.mesh(&pos, &idx, material)
}

/// Each pixel's RGB with its centre (x, y).
type Pixels = Vec<([f32; 3], f32, f32)>;

/// Renders `g` seen from (0, 0, 5) looking down −Z, framing [-1, 1]², and returns each
/// pixel's RGB with its centre (x, y), and the run's warnings.
fn render(mut g: GltfBuilder, spp: u32) -> (Pixels, Vec<String>) {
    g.orthographic([0.0, 0.0, 5.0], [0.0, 0.0, 0.0, 1.0], 1.0, 1.0);
    g.settings(json!({"filter": "box", "filter_width": 0.001}));
    let dir = temp_dir();
    let scene = g.write(dir.path(), "s.gltf");
    let out = dir.path().join("o.exr");
    let res = format!("{RES}x{RES}");
    let spp = spp.to_string();
    let args = ["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"];
    let r = run(&[&args[..], &["--resolution", &res, "--spp", &spp]].concat(), LIMIT);
    assert_eq!(r.code, Some(0), "render failed: {}", r.stderr);
    let px = caustic::output::read_combined(&out).unwrap().2;
    let px = px
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (col, row) = (i % RES, i / RES);
            let x = -1.0 + (col as f32 + 0.5) * 2.0 / RES as f32;
            let y = 1.0 - (row as f32 + 0.5) * 2.0 / RES as f32;
            ([p[0], p[1], p[2]], x, y)
        })
        .collect();
    (px, r.warnings())
}

/// Half-size of the box and the ceiling: every AO ray (horizontal reach below
/// √(d² − h²) < 1 from points within [-1, 1]²) meets their faces, not their edges.
const L: f32 = 4.0;
/// The ceiling's height above the box's top face.
const H_UP: f32 = 0.5;
/// The box's depth below its top face (Inside rays meet its bottom).
const H_DOWN: f32 = 0.7;
/// The AO node's Distance.
const DIST: f32 = 1.0;
/// The AO node's Samples.
const AO_SAMPLES: u32 = 16;
/// Samples a pixel.
const SPP: u32 = 16;

/// The AO scene: a box [-L, L]² × [−H_DOWN, 0] whose faces emit the AO node's Color
/// (Color white), and a separate ceiling quad at z = H_UP that the camera does not see.
fn ao_scene(inside: bool, only_local: bool) -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let ao = json!({"name": "AO", "type": "ShaderNodeAmbientOcclusion",
        "props": {"samples": AO_SAMPLES, "inside": inside, "only_local": only_local},
        "inputs": {"Color": {"value": [1, 1, 1, 1]}, "Distance": {"value": DIST}}});
    let m = g.material(emitting("ao", vec![ao], json!([0, "Color"])));
    g.cube([-L, -L, -H_DOWN], [L, L, 0.0], m);
    let plain = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1]}}));
    let (p, i) = quad([[-L, -L, H_UP], [L, -L, H_UP], [L, L, H_UP], [-L, L, H_UP]]);
    let ceiling = g.mesh(&p, &i, plain);
    g.node_ext(ceiling, "CAUSTIC_object_visibility", json!({"camera": false}));
    g
}

/// The mean of the image's red channel and its bound: the pixels average
/// RES² × SPP × AO_SAMPLES independent rays, each unoccluded with probability `p`, so the
/// mean's standard deviation is √(p (1 − p) / n); 5σ (a false failure 6·10⁻⁷ of the time),
/// and 10⁻⁶ for float rounding where p is 0 or 1.
fn mean_and_bound(px: &[([f32; 3], f32, f32)], p: f64) -> (f64, f64) {
    let mean = px.iter().map(|(c, _, _)| c[0] as f64).sum::<f64>() / px.len() as f64;
    let n = (RES * RES) as f64 * SPP as f64 * AO_SAMPLES as f64;
    (mean, 5.0 * (p * (1.0 - p) / n).sqrt() + 1e-6)
}

/// Cosine-distributed rays about the normal meet a parallel plane at height h within
/// distance d when cos θ > h / d; cos² θ is uniform under the cosine density, so the
/// unoccluded fraction is (h / d)². Up: the ceiling (another object); down (Inside): the
/// box's own bottom. Only Local sees the box alone.
#[test]
fn ao_matches_the_parallel_plane_closed_form() {
    let up = (H_UP / DIST).powi(2) as f64;
    let down = (H_DOWN / DIST).powi(2) as f64;
    for (inside, only_local, want) in [(false, false, up), (false, true, 1.0), (true, false, down), (true, true, down)]
    {
        let (px, warnings) = render(ao_scene(inside, only_local), SPP);
        let (mean, bound) = mean_and_bound(&px, want);
        assert!(
            (mean - want).abs() < bound,
            "inside {inside}, only local {only_local}: AO {mean} vs {want} (bound {bound})"
        );
        assert!(!warnings.iter().any(|w| w.contains("not traced")), "{warnings:?}");
    }
}

/// The AO node as a Bump's height: the offset points draw the centre's random numbers, so
/// over a plane under a parallel ceiling (the same occlusion everywhere) the three heights
/// are equal and the normal is not bent (independent numbers would make the finite
/// difference of two noisy estimates 10⁻⁴ apart, a random tilt of many degrees).
#[test]
fn ao_under_a_bump_draws_the_same_numbers_at_the_offsets() {
    let mut g = GltfBuilder::new();
    let nodes = vec![
        json!({"name": "AO", "type": "ShaderNodeAmbientOcclusion", "props": {"samples": 4},
            "inputs": {"Distance": {"value": DIST}}}),
        json!({"name": "Bump", "type": "ShaderNodeBump",
            "inputs": {"Strength": {"value": 1.0}, "Distance": {"value": 1.0}, "Height": {"link": [0, "AO"]}}}),
        json!({"name": "Shift", "type": "ShaderNodeVectorMath", "props": {"operation": "ADD"},
            "inputs": {"Vector": {"link": [1, "Normal"]}, "Vector_001": {"value": [1, 1, 1]}}}),
    ];
    let m = g.material(emitting("bump", nodes, json!([2, "Vector"])));
    g.cube([-L, -L, -H_DOWN], [L, L, 0.0], m);
    let plain = g.material(json!({}));
    let (p, i) = quad([[-L, -L, H_UP], [L, -L, H_UP], [L, L, H_UP], [-L, L, H_UP]]);
    let ceiling = g.mesh(&p, &i, plain);
    g.node_ext(ceiling, "CAUSTIC_object_visibility", json!({"camera": false}));
    // The top face's normal +Z (glTF) is (0, −1, 0) in Blender's axes: + (1, 1, 1).
    for (c, x, y) in render(g, 4).0 {
        for (k, want) in [1.0, 0.0, 1.0].into_iter().enumerate() {
            assert!((c[k] - want).abs() < 1e-4, "({x}, {y}) channel {k}: {} vs {want}", c[k]);
        }
    }
}

/// A material emitting the Bevel node's normal (Blender axes) plus (1, 1, 1).
fn bevel_material(radius: f32) -> Value {
    let nodes = vec![
        json!({"name": "Bevel", "type": "ShaderNodeBevel", "props": {"samples": 8},
            "inputs": {"Radius": {"value": radius}}}),
        json!({"name": "Shift", "type": "ShaderNodeVectorMath", "props": {"operation": "ADD"},
            "inputs": {"Vector": {"link": [0, "Normal"]}, "Vector_001": {"value": [1, 1, 1]}}}),
    ];
    emitting("bevel", nodes, json!([1, "Vector"]))
}

/// On a flat plane every probe that meets the object meets the plane, whose normal is the
/// point's: the bevelled normal is the plane's, up to rounding, at any radius (also where
/// probes leave the plane's edge).
#[test]
fn bevel_on_a_plane_is_the_plane_normal() {
    for radius in [0.05, 0.5, 3.0] {
        let mut g = GltfBuilder::new();
        let m = g.material(bevel_material(radius));
        let (p, i) = quad([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]]);
        g.mesh(&p, &i, m);
        let (px, warnings) = render(g, 2);
        for (c, x, y) in px {
            for (k, want) in [1.0, 0.0, 1.0].into_iter().enumerate() {
                assert!((c[k] - want).abs() < 1e-5, "radius {radius} ({x}, {y}) channel {k}: {} vs {want}", c[k]);
            }
        }
        assert!(!warnings.iter().any(|w| w.contains("not traced")), "{warnings:?}");
    }
}

/// A box's edge: the top face z = 0 over x < 0 meets the side face x = 0 (normal +X). A
/// probe's hits weigh by the falloff of their distance from the point, zero beyond the
/// radius, so a point s from the edge keeps exactly the face's normal while s ≥ radius;
/// nearer, the side face's hits tilt it toward +X, more as the radius grows (the ratio s /
/// radius falls), and on average never past the 45° bisector, which the point on the edge
/// itself reaches by symmetry.
#[test]
fn bevel_tilts_a_box_edge_toward_the_bisector_as_the_radius_grows() {
    // The mean tilt (the normal's X) of the pixel column at s = 0.125 and of the one at 0.375.
    let tilt = |radius: f32| {
        let mut g = GltfBuilder::new();
        let m = g.material(bevel_material(radius));
        let top = quad([[-L, -L, 0.0], [0.0, -L, 0.0], [0.0, L, 0.0], [-L, L, 0.0]]);
        let side = quad([[0.0, -L, -L], [0.0, L, -L], [0.0, L, 0.0], [0.0, -L, 0.0]]);
        mesh_of(&mut g, &[top, side], m);
        let (px, _) = render(g, 16);
        let column = |x0: f32| {
            let c: Vec<f64> =
                px.iter().filter(|(_, x, _)| (x - x0).abs() < 1e-3).map(|(c, _, _)| c[0] as f64 - 1.0).collect();
            c.iter().sum::<f64>() / c.len() as f64
        };
        (column(-0.125), column(-0.375))
    };
    let t: Vec<(f64, f64)> = [0.1, 0.25, 0.5, 1.0].into_iter().map(tilt).collect();
    // Within the radius only where s < radius; exactly 0 elsewhere (a sum of +Z normals).
    assert!(t[0].0.abs() < 1e-6 && t[0].1.abs() < 1e-6 && t[1].1.abs() < 1e-6, "{t:?}");
    // Growing with the radius: the steps are ~0.1 and more, each column's mean the average
    // of 128 estimates whose spread is at most the range [0, 1] (σ of the mean < 0.045).
    for k in 1..t.len() {
        assert!(t[k].0 > t[k - 1].0 + 0.02, "s = 0.125: {t:?}");
    }
    // Farther from the edge (s / radius 0.75, 0.375) the falloff leaves little, but not none.
    assert!(t[3].1 > t[2].1 + 0.02 && t[2].1 > 0.0, "s = 0.375: {t:?}");
    assert!(t[3].0 < std::f64::consts::FRAC_1_SQRT_2, "past the bisector: {t:?}");
}

/// The traced nodes draw their numbers from a hash of the hit, not from a thread's state:
/// the same file for one thread and two (`tests/determinism.rs` for the rest of a render).
#[test]
fn traced_nodes_render_the_same_file_for_any_thread_count() {
    let mut g = ao_scene(false, false);
    let m = g.material(bevel_material(0.3));
    g.cube([-0.5, -0.5, 0.0], [0.0, 0.0, 0.3], m);
    g.orthographic([0.0, 0.0, 5.0], [0.0, 0.0, 0.0, 1.0], 1.0, 1.0);
    let dir = temp_dir();
    let scene = g.write(dir.path(), "s.gltf");
    let files: Vec<Vec<u8>> = ["1", "2"]
        .iter()
        .map(|threads| {
            let out = dir.path().join(format!("t{threads}.exr"));
            render_image(&scene, &out, &["--resolution", "64x64", "--spp", "4", "--threads", threads], LIMIT);
            std::fs::read(&out).unwrap()
        })
        .collect();
    assert!(files[0] == files[1], "two threads wrote a different file from one");
}
