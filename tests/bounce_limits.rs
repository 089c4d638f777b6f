//! Light Paths' per-kind bounce limits in BDPT and VCM (`src/integrator/bdpt/bounces.rs`):
//! they converge to the path tracer's image region by region where the limits bind, and
//! the limits matter there (the path tracer's image without them disagrees).
//!
//! The scene: a closed room (max depth 6) lit by a point light inside, its walls a pure
//! diffuse grey (specular 0: every reflection there is diffuse, whatever strategy made it),
//! the floor a rough metal (glossy only), and a block standing on it of the default
//! dielectric Principled material, which reflects both diffusely and glossily (a mixed
//! vertex: its class is the sampled lobe's, and paths whose verdict depends on it are left
//! to the camera side). Two settings: Diffuse 1 / Glossy 1 and Diffuse 2 / Glossy 0.
//!
//! Bounds (`common::agreement`): K seeds per estimate, Welch's test per region, Šidák's
//! split over every comparison of the test (per setting: the rule check and two
//! integrators, five regions each).

mod common;

use common::agreement::{Seeded, disagreeing, regions, sidak};
use common::{GltfBuilder, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);
const RES: (usize, usize) = (24, 24);

/// The room of the module doc with the scene settings `settings`.
fn room(dir: &Path, name: &str, settings: Value) -> PathBuf {
    let mut g = GltfBuilder::new();
    g.use_ext("KHR_materials_specular");
    let grey = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}, "doubleSided": true
    }));
    let metal = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.8, 0.6, 1], "metallicFactor": 1.0, "roughnessFactor": 0.35},
        "doubleSided": true
    }));
    let mixed = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0.3, 0.5, 0.8, 1], "metallicFactor": 0.0, "roughnessFactor": 0.3},
        "doubleSided": true
    }));
    g.cube([-2.0, -2.0, -6.0], [2.0, 2.0, 1.0], grey);
    g.mesh(
        &[[-1.99, -1.99, -5.99], [1.99, -1.99, -5.99], [1.99, -1.99, 0.99], [-1.99, -1.99, 0.99]],
        &[0, 2, 1, 0, 3, 2],
        metal,
    );
    g.cube([-0.3, -1.99, -4.5], [0.9, -0.8, -3.3], mixed);
    g.punctual(json!({"type": "point", "intensity": 20000.0}), [-0.6, 1.2, -3.0], [0.0, 0.0, 0.0, 1.0]);
    g.camera([0.0, 0.3, 0.0], common::look_rotation([0.0, -0.3, -1.0]), 1.1);
    g.settings(settings);
    g.write(dir, name)
}

/// BDPT and VCM agree with the path tracer under each setting, which matters.
#[test]
fn bidirectional_integrators_follow_the_bounce_limits() {
    let dir = temp_dir();
    let regs = regions(RES.0, RES.1);
    let r = format!("{}x{}", RES.0, RES.1);
    let seeded = Seeded::six(dir.path(), &r, "6", &regs, LIMIT);
    let unlimited = room(dir.path(), "unlimited.gltf", json!({}));
    let path_tracer = ["--integrator", "path", "--spp", "64"];
    let free = seeded.means(&unlimited, &path_tracer);
    let settings = [
        ("diffuse 1, glossy 1", json!({"diffuse_max_bounces": 1, "glossy_max_bounces": 1})),
        ("diffuse 2, glossy 0", json!({"diffuse_max_bounces": 2, "glossy_max_bounces": 0})),
    ];
    let alpha = sidak(settings.len() * regs.len() * 3);
    let mut failed = Vec::new();
    for (k, (label, s)) in settings.into_iter().enumerate() {
        let scene = room(dir.path(), &format!("limited_{k}.gltf"), s);
        let reference = seeded.means(&scene, &path_tracer);
        assert!(
            !disagreeing(&format!("{label}: unlimited"), &regs, &free, &reference, alpha).is_empty(),
            "{label}: the limits change nothing"
        );
        for r in seeded.bidirectional_disagreeing(&scene, &reference, "16", "0.02", alpha) {
            failed.push(format!("{label}: {r}"));
        }
    }
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}
