//! Volume objects (`CAUSTIC_volume` grid media) end to end: a grid of constant density
//! renders as the same homogeneous medium in a box, in the path tracer, BDPT and both
//! photon integrators (photons scatter in grids); bad grid files are refused with the
//! scene's exit code, absurd ones with the memory error.

mod common;

use caustic::medium::grid_file::{GridFile, NamedGrid};
use common::{GltfBuilder, look_rotation, render_image, run, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);

/// The fog's Principled Volume: σs = d·colour = (1.2, 0.9, 0.6), σa = d·(1 − colour)·(1 −
/// √0.25) = (0.15, 0.3, 0.45) per unit length, forward scattering.
fn shader() -> Value {
    json!({"density": 1.5, "color": [0.8, 0.6, 0.4], "absorption_color": [0.25, 0.25, 0.25], "anisotropy": 0.3,
           "emission": [0.0, 0.0, 0.0], "blackbody_intensity": 0.0, "blackbody_tint": [1.0, 1.0, 1.0],
           "temperature": 1000.0})
}

/// A white floor at y = 0 lit by a point light at y = 3, a camera at `eye` looking along
/// `look`, and fog in the box x, z ∈ [−2, 2], y ∈ [1, 1.6]: either a homogeneous medium
/// with the coefficients of [`shader`], or a volume object whose grid (7×2×7 voxels, scale
/// (0.5, 0.2, 0.5)) spans exactly that box with its domain [−1, n] and reads no density grid
/// (constant density); `grid` then writes it and names it.
fn fog_scene(dir: &Path, name: &str, eye: [f32; 3], look: [f32; 3], grid: bool) -> PathBuf {
    let mut g = GltfBuilder::new();
    let white = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
    g.mesh(
        &[[-20.0, 0.0, -20.0], [20.0, 0.0, -20.0], [20.0, 0.0, 20.0], [-20.0, 0.0, 20.0]],
        &[0, 2, 1, 0, 3, 2],
        white,
    );
    g.punctual(json!({"type": "point", "intensity": 2732.0}), [0.3, 3.0, -0.2], [0.0, 0.0, 0.0, 1.0]);
    g.camera(eye, look_rotation(look), 0.6);
    if !grid {
        g.use_ext("CAUSTIC_materials_medium");
        let fog = g.material(json!({"extensions": {"CAUSTIC_materials_medium": {
            "density": 1.5, "scatter_color": [1.2 / 1.5, 0.9 / 1.5, 0.6 / 1.5],
            "absorption_color": [0.1, 0.2, 0.3], "anisotropy": 0.3, "surface": false}}}));
        g.cube([-2.0, 1.0, -2.0], [2.0, 1.6, 2.0], fog);
        return g.write(dir, name);
    }
    let file = GridFile {
        dims: [7, 2, 7],
        // Index −1 ↦ −2 and 7 ↦ 2 in x and z; −1 ↦ 1 and 2 ↦ 1.6 in y.
        index_to_object: [0.5, 0.0, 0.0, -1.5, 0.0, 0.2, 0.0, 1.2, 0.0, 0.0, 0.5, -1.5],
        grids: vec![NamedGrid { name: "density".into(), components: 1, values: vec![0.0; 98] }],
    };
    std::fs::write(dir.join("fog.cvol"), file.to_bytes()).unwrap();
    let path = g.write(dir, name);
    add_volume(
        &path,
        json!({"name": "Fog", "uri": "fog.cvol", "matrix": identity(), "density_grid": null,
                             "shader": shader()}),
    );
    path
}

fn identity() -> [f32; 16] {
    glam::Mat4::IDENTITY.to_cols_array()
}

/// Adds `volume` to the root `CAUSTIC_volume` of the glTF at `path`.
fn add_volume(path: &Path, volume: Value) {
    let mut doc: Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    doc["extensionsUsed"].as_array_mut().unwrap().push(json!("CAUSTIC_volume"));
    doc["extensions"]["CAUSTIC_volume"] = json!({"volumes": [volume]});
    std::fs::write(path, serde_json::to_vec(&doc).unwrap()).unwrap();
}

/// Mean luminance of two renders and the standard error of that mean, from their
/// difference (pixels are independent: no filter wider than a pixel's own samples matters
/// for the mean of a difference of independent seeds).
fn two_seed_stats(a: &[[f32; 4]], b: &[[f32; 4]]) -> (f64, f64) {
    let lum = |p: &[f32; 4]| (p[0] + p[1] + p[2]) as f64 / 3.0;
    let n = a.len() as f64;
    let mean = a.iter().zip(b).map(|(x, y)| lum(x) + lum(y)).sum::<f64>() / (2.0 * n);
    let d2 = a.iter().zip(b).map(|(x, y)| (lum(x) - lum(y)).powi(2)).sum::<f64>();
    (mean, (d2 / (2.0 * n * n) / 2.0).sqrt())
}

/// Renders `scene` with two seeds and `args`; the two-seed mean and its standard error.
fn estimate(scene: &Path, dir: &Path, tag: &str, args: &[&str]) -> (f64, f64) {
    let images: Vec<_> = ["1", "2"]
        .iter()
        .map(|seed| {
            let mut a = vec!["--resolution", "24x24", "--seed", seed];
            a.extend_from_slice(args);
            render_image(scene, &dir.join(format!("{tag}{seed}.exr")), &a, LIMIT)
        })
        .collect();
    two_seed_stats(&images[0], &images[1])
}

/// A grid of constant density is the homogeneous medium: seen from below the fog (the
/// floor lit through it: NEE by ratio tracking) and from above (camera paths scattering in
/// it by delta tracking), the path tracer's mean agrees with the homogeneous box's within
/// 5σ of the two estimates; so do BDPT's, SPPM's and Jensen's photon mapping's over the
/// grid (photons scatter in grids), within 5σ as in tests/media.rs (no face edge is in
/// view, so the photon estimate's edge bias is zero, its curvature term < 10⁻³ of the mean).
#[test]
fn constant_grid_renders_as_the_homogeneous_medium() {
    let dir = temp_dir();
    let d = dir.path();
    for (label, eye, look) in
        [("below", [0.0f32, 0.6, 1.5], [0.0f32, -0.6, -1.5]), ("above", [0.0, 2.5, 2.0], [0.0, -2.5, -2.0])]
    {
        let homogeneous = fog_scene(d, &format!("h_{label}.gltf"), eye, look, false);
        let grid = fog_scene(d, &format!("g_{label}.gltf"), eye, look, true);
        let (h, se_h) = estimate(&homogeneous, d, &format!("h_{label}"), &["--spp", "256"]);
        let sppm = ["--integrator", "sppm", "--sppm-iterations", "256", "--sppm-radius", "0.05"];
        let jensen = ["--integrator", "photon", "--spp", "64", "--photons", "100000", "--max-radius", "0.05"];
        let cases: [(&str, &[&str]); 4] = [
            ("path", &["--spp", "256"]),
            ("BDPT", &["--integrator", "bdpt", "--spp", "128"]),
            ("SPPM", &sppm),
            ("PM", &jensen),
        ];
        for (name, args) in cases {
            let (m, se) = estimate(&grid, d, &format!("g_{label}_{name}"), args);
            let bound = 5.0 * (se_h * se_h + se * se).sqrt();
            eprintln!("fog {label}: homogeneous {h:.5} ± {se_h:.5}, grid {name} {m:.5} ± {se:.5}, ratio {:.4}", m / h);
            assert!(h > 1e-3, "{label}: the scene is black");
            assert!((m - h).abs() <= bound, "{label}: grid {name} {m} vs homogeneous {h} (bound {bound})");
        }
    }
}

/// The scene with a one-grid volume whose file holds `bytes`, rendered; the run.
fn render_with_file(bytes: &[u8], volume: Value) -> common::Run {
    let dir = temp_dir();
    std::fs::write(dir.path().join("v.cvol"), bytes).unwrap();
    let path = fog_scene(dir.path(), "v.gltf", [0.0, 2.5, 2.0], [0.0, -2.5, -2.0], false);
    add_volume(&path, volume);
    let out = dir.path().join("o.exr");
    run(
        &[
            "render",
            path.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--progress",
            "json",
            "--spp",
            "1",
            "--resolution",
            "8x8",
            "--memory-limit",
            "1G",
        ],
        LIMIT,
    )
}

fn density_file(dims: [u32; 3], values: Vec<f32>) -> GridFile {
    GridFile {
        dims,
        index_to_object: [0.1, 0.0, 0.0, 0.0, 0.0, 0.1, 0.0, 1.0, 0.0, 0.0, 0.1, 0.0],
        grids: vec![NamedGrid { name: "density".into(), components: 1, values }],
    }
}

/// Bad volumes are refused naming the file or the volume: a truncated file, a NaN density,
/// a grid the extension names but the file lacks, a non-finite or out-of-range shader value,
/// a malformed extension (exit 3); dimensions beyond the memory budget (exit 7).
#[test]
fn bad_volumes_are_refused() {
    let good = density_file([2, 2, 2], vec![1.0; 8]).to_bytes();
    let volume = |grid: &str, shader: Value| json!({"name": "Smoke", "uri": "v.cvol", "matrix": identity(), "density_grid": grid, "shader": shader});
    let mut nan = density_file([2, 2, 2], vec![1.0; 8]);
    nan.grids[0].values[3] = f32::NAN;
    let mut anisotropic = shader();
    anisotropic["anisotropy"] = json!(1.5);
    let cases: [(&str, Vec<u8>, Value, &str); 5] = [
        ("truncated", good[..good.len() - 4].to_vec(), volume("density", shader()), "truncated"),
        ("NaN", nan.to_bytes(), volume("density", shader()), "voxel (1, 1, 0)"),
        ("missing grid", good.clone(), volume("heat", shader()), "'heat'"),
        ("anisotropy", good.clone(), volume("density", anisotropic), "anisotropy"),
        ("malformed", good.clone(), json!({"name": "Smoke", "uri": "v.cvol"}), "CAUSTIC_volume"),
    ];
    for (what, bytes, v, needle) in cases {
        let r = render_with_file(&bytes, v);
        assert_eq!(r.code, Some(3), "{what}: {}", r.stderr);
        let msg = r.error_message().unwrap_or_default();
        assert!(msg.contains(needle), "{what}: {msg}");
    }
    // 2^15 × 2^15 × 64 voxels of f32: 256 GiB, far over the 1 GiB budget.
    let huge = density_file([1 << 15, 1 << 15, 64], Vec::new());
    let header = huge.to_bytes();
    let r = render_with_file(&header, volume("density", shader()));
    assert_eq!(r.code, Some(7), "absurd dimensions: {}", r.stderr);
    assert!(r.error_message().unwrap_or_default().contains("volume grids"), "{}", r.stderr);
}

/// Blackbody emission of a homogeneous medium (`CAUSTIC_materials_medium`'s blackbody keys,
/// here the world's volume): an absorbing, glowing world seen along camera rays that meet
/// nothing gives the unbounded segment's E/σa exactly (no sampling is involved), with E
/// Cycles' blackbody at the Temperature; to 1e-5 relative (f32 evaluation of the same formula).
#[test]
fn homogeneous_blackbody_emission_reaches_equilibrium() {
    let dir = temp_dir();
    let mut g = GltfBuilder::new();
    let grey = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1]}}));
    // Something to render, behind the camera.
    g.mesh(&[[-1.0, -1.0, 5.0], [1.0, -1.0, 5.0], [0.0, 1.0, 5.0]], &[0, 1, 2], grey);
    g.camera([0.0, 0.0, 0.0], look_rotation([0.0, 0.0, -1.0]), 0.5);
    let (sigma_a, t, tint) = (0.5f32, 2500.0f32, [1.0f32, 0.8, 0.6]);
    g.world(json!({"color": [0.0, 0.0, 0.0], "medium": {"density": 1.0, "scatter_color": [0.0, 0.0, 0.0],
        "absorption_color": [sigma_a, sigma_a, sigma_a], "blackbody_intensity": 1.0, "blackbody_tint": tint, "temperature": t}}));
    let path = g.write(dir.path(), "glow.gltf");
    let image = render_image(&path, &dir.path().join("glow.exr"), &["--resolution", "4x4", "--spp", "4"], LIMIT);
    let e = caustic::medium::blackbody::blackbody_emission(t, 1.0, glam::Vec3::from(tint), &Default::default());
    for p in &image {
        for c in 0..3 {
            let want = e[c] / sigma_a;
            assert!(want > 0.01 && (p[c] - want).abs() <= 1e-5 * want, "channel {c}: {} vs {want}", p[c]);
        }
    }
}

/// An Attribute node reading grid `name` into a Volume Scatter's Density through Math
/// Power `power`: the graph of a volume object (`CAUSTIC_volume.graph`).
fn attribute_nodes(names: &[String], power: f32) -> Value {
    let mut nodes: Vec<Value> = names
        .iter()
        .map(|n| json!({"name": n, "type": "ShaderNodeAttribute", "props": {"attribute_name": n, "attribute_type": "GEOMETRY"}, "inputs": {}}))
        .collect();
    // The attributes summed, raised to `power`.
    let mut last = (0usize, "Fac");
    for i in 1..names.len() {
        nodes.push(json!({"name": format!("Add{i}"), "type": "ShaderNodeMath", "props": {"operation": "ADD"},
            "inputs": {"Value": {"value": 0.0, "link": [last.0, last.1]}, "Value_001": {"value": 0.0, "link": [i, "Fac"]}}}));
        last = (nodes.len() - 1, "Value");
    }
    nodes.push(json!({"name": "Pow", "type": "ShaderNodeMath", "props": {"operation": "POWER"},
        "inputs": {"Value": {"value": 0.0, "link": [last.0, last.1]}, "Value_001": {"value": power}}}));
    let pow = nodes.len() - 1;
    nodes.push(json!({"name": "S", "type": "ShaderNodeVolumeScatter",
        "inputs": {"Density": {"value": 1.0, "link": [pow, "Value"]}, "Color": {"value": [0.8, 0.8, 0.8, 1.0]}}}));
    let root = nodes.len() - 1;
    json!({"name": "Smoke", "uri": "v.cvol", "matrix": identity(), "density_grid": null, "shader": shader(),
           "graph": {"version": 1, "output": {}, "nodes": nodes}, "graph_shader": root})
}

/// A file of `count` 2×2×2 grids named g0, g1, … of value `value`.
fn grids_file(count: usize, value: f32) -> GridFile {
    let mut f = density_file([2, 2, 2], vec![value; 8]);
    f.grids = (0..count).map(|i| NamedGrid { name: format!("g{i}"), components: 1, values: vec![value; 8] }).collect();
    f
}

/// A volume object's graph on bad input: a NaN voxel and a file of more grids than the format
/// holds are refused naming the object and the grid (exit 3); a graph reading more attributes
/// than a voxel holds, and one whose extinction overflows to infinity at a voxel, are refused
/// naming the object; a graph naming a grid the file lacks renders it as 0 with a warning
/// naming the object and the grid; a file of 16 grids (the most a graph reads) renders.
#[test]
fn bad_graph_volumes_are_refused_or_named() {
    let names = |n: usize| (0..n).map(|i| format!("g{i}")).collect::<Vec<_>>();
    let mut nan = grids_file(2, 1.0);
    nan.grids[1].values[5] = f32::INFINITY;
    let cases: [(&str, GridFile, Value, &str); 4] = [
        (
            "infinite voxel",
            nan,
            attribute_nodes(&names(2), 1.0),
            "'Smoke': volume grid file 'v.cvol': grid 'g1': voxel (1, 0, 1) is inf",
        ),
        (
            "17 grids",
            grids_file(17, 1.0),
            attribute_nodes(&names(2), 1.0),
            "'Smoke': volume grid file 'v.cvol': 17 grids (1..=16",
        ),
        (
            "17 attributes",
            grids_file(16, 1.0),
            attribute_nodes(&names(17), 1.0),
            "'Smoke': its graph reads 17 attributes",
        ),
        (
            "overflow",
            grids_file(1, 1e20),
            attribute_nodes(&names(1), 3.0),
            "'Smoke': its graph gives a non-finite extinction inf at voxel",
        ),
    ];
    for (what, file, v, needle) in cases {
        let r = render_with_file(&file.to_bytes(), v);
        assert_eq!(r.code, Some(3), "{what}: {}", r.stderr);
        let msg = r.error_message().unwrap_or_default();
        assert!(msg.contains(needle), "{what}: {msg}");
    }
    let mut wanted = names(16);
    wanted[15] = "heat".into();
    let r = render_with_file(&grids_file(16, 0.5).to_bytes(), attribute_nodes(&wanted, 1.0));
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(r.stderr.contains("'Smoke': its graph reads the grid 'heat', which is not in 'v.cvol'"), "{}", r.stderr);
    assert!(!r.stderr.contains("'g14'"), "{}", r.stderr);
}
