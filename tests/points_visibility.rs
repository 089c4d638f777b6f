//! A point cloud object's Ray Visibility and Holdout (`visibility` on a `CAUSTIC_points`
//! object, the keys of `CAUSTIC_object_visibility`) in scenes whose answer is exact: a grey
//! floor under a white world, a big sphere above it (one point), seen from the front.
//!
//! * Hidden from every kind of ray, the sphere changes nothing: bit for bit the scene without it.
//! * A holdout sphere hidden from every other kind leaves alpha 0 where the camera sees it
//!   (exactly its silhouette: the pixels whose alpha is below 1) and the rest of the image as
//!   the scene without it.
//! * Seen by the camera alone, every pixel outside that silhouette is the scene without it,
//!   bit for bit (the floor's diffuse rays and shadow rays pass the sphere: the same samples
//!   take the same paths), where the sphere seen by every ray shades the floor (the rule
//!   matters).
//! * Jensen's photon mapping, SPPM, BDPT and VCM follow the rule: they agree with the path
//!   tracer region by region on the sphere hidden from diffuse rays under a point light, and
//!   none warns.

mod common;

use common::agreement::{Seeded, regions, sidak};
use common::{GltfBuilder, quick_render_warnings, render_image, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);

/// The scene, the sphere with `visibility` (None: no sphere); `light`: a point light above
/// instead of the white world.
fn scene(dir: &Path, name: &str, visibility: Option<Value>, light: bool) -> PathBuf {
    let mut g = GltfBuilder::new();
    let grey = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1],
        "metallicFactor": 0.0}, "doubleSided": true}));
    g.mesh(&[[-3.0, -1.0, -1.0], [3.0, -1.0, -1.0], [3.0, -1.0, -7.0], [-3.0, -1.0, -7.0]], &[0, 1, 2, 0, 2, 3], grey);
    if visibility.is_some() {
        g.points("Ball", grey, &[[0.0, -0.2, -4.0]], &[0.6]);
    }
    if light {
        g.punctual(json!({"type": "point", "intensity": 3000.0}), [0.3, 1.5, -4.0], [0.0, 0.0, 0.0, 1.0]);
    } else {
        g.world(json!({"color": [1.0, 1.0, 1.0], "strength": 1.0}));
    }
    // An opaque film: alpha is 1 but where a holdout is seen.
    g.settings(json!({"transparent": false}));
    g.camera([0.0, 0.2, 0.0], [0.0, 0.0, 0.0, 1.0], 0.9);
    let path = g.write(dir, name);
    if let Some(v) = visibility.filter(|v| v.as_object().is_some_and(|o| !o.is_empty())) {
        let mut doc: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        doc["extensions"]["CAUSTIC_points"]["objects"][0]["visibility"] = v;
        std::fs::write(&path, serde_json::to_string(&doc).unwrap()).unwrap();
    }
    path
}

fn render(scene: &Path, out: &Path) -> Vec<[f32; 4]> {
    let args = ["--resolution", "32x32", "--filter", "box", "--filter-width", "1", "--spp", "8", "--max-depth", "3"];
    render_image(scene, out, &args, LIMIT)
}

const HIDDEN: [(&str, bool); 6] = [
    ("camera", false),
    ("diffuse", false),
    ("glossy", false),
    ("transmission", false),
    ("volume_scatter", false),
    ("shadow", false),
];

fn hidden_but(keep: &str) -> Value {
    Value::Object(HIDDEN.iter().filter(|(k, _)| *k != keep).map(|(k, v)| (k.to_string(), json!(v))).collect())
}

#[test]
fn points_follow_their_ray_visibility_and_holdout() {
    let dir = temp_dir();
    let d = dir.path();
    let none = render(&scene(d, "none.gltf", None, false), &d.join("none.exr"));
    let invisible = render(&scene(d, "inv.gltf", Some(hidden_but("")), false), &d.join("inv.exr"));
    assert_eq!(invisible, none, "a sphere hidden from every ray changed the image");
    let mut held = hidden_but("camera");
    held["holdout"] = json!(true);
    let held = render(&scene(d, "held.gltf", Some(held), false), &d.join("held.exr"));
    let silhouette: Vec<bool> = held.iter().map(|p| p[3] < 1.0).collect();
    let covered = silhouette.iter().filter(|&&s| s).count();
    assert!(covered > 20 && covered < 512, "the sphere covers {covered} pixels");
    assert!(held.iter().zip(&silhouette).any(|(p, &s)| s && p[3] == 0.0 && p[..3] == [0.0; 3]), "holdout not clear");
    let camera_only = render(&scene(d, "cam.gltf", Some(hidden_but("camera")), false), &d.join("cam.exr"));
    let seen = render(&scene(d, "all.gltf", Some(json!({})), false), &d.join("all.exr"));
    let mut shaded = 0;
    for (i, &s) in silhouette.iter().enumerate() {
        if s {
            continue;
        }
        assert_eq!(held[i], none[i], "pixel {i}: the holdout changed what it does not cover");
        assert_eq!(camera_only[i], none[i], "pixel {i}: a sphere seen by the camera alone shaded the floor");
        shaded += (seen[i] != none[i]) as usize;
    }
    assert!(shaded > 20, "the visible sphere shades only {shaded} floor pixels: the rule does not matter");
}

/// Jensen, SPPM, BDPT and VCM against the path tracer on the sphere hidden from diffuse rays
/// under a point light (photons pass points as triangles, `photon::visibility`; BDPT and VCM
/// leave the paths that meet it to s = 0 and s = 1, `bdpt::visibility`). Bounds as
/// `tests/photon_visibility.rs` and `tests/bidirectional_visibility.rs`: Welch per region,
/// Šidák over the comparisons; radius 0.02 on a scene 6 units across.
#[test]
fn other_integrators_follow_points_ray_visibility() {
    let dir = temp_dir();
    let regs = regions(32, 32);
    let seeded = Seeded::six(dir.path(), "32x32", "4", &regs, LIMIT);
    let ruled = scene(dir.path(), "ruled.gltf", Some(json!({"diffuse": false, "shadow": false})), true);
    let path_tracer = ["--integrator", "path", "--spp", "64"];
    let reference = seeded.means(&ruled, &path_tracer);
    let alpha = sidak(regs.len() * 5);
    let plain = seeded.means(&scene(dir.path(), "plain.gltf", Some(json!({})), true), &path_tracer);
    seeded.assert_rule_matters("points hidden from diffuse and shadow rays", &plain, &reference, alpha);
    let photon = ["--integrator", "photon", "--spp", "32", "--photons", "400000", "--max-radius", "0.02"];
    let sppm = ["--integrator", "sppm", "--sppm-iterations", "256", "--sppm-radius", "0.02"];
    let mut failed = seeded.disagreeing_others(&ruled, &reference, &[("photon", &photon), ("sppm", &sppm)], alpha);
    failed.extend(seeded.bidirectional_disagreeing(&ruled, &reference, "16", "0.02", alpha));
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}

/// No integrator warns that it ignores the points' Ray Visibility.
#[test]
fn no_integrator_warns_about_points_visibility() {
    let dir = temp_dir();
    let d = dir.path();
    let path = scene(d, "d.gltf", Some(json!({"diffuse": false, "camera": false})), true);
    for integrator in ["path", "bdpt", "vcm", "photon", "sppm"] {
        let flags = ["--integrator", integrator, "--sppm-iterations", "1", "--photons", "1000"];
        let warned: Vec<String> = quick_render_warnings(&path, &d.join("w.exr"), &flags, LIMIT)
            .into_iter()
            .filter(|w| w.to_lowercase().contains("visibility") || w.contains("'Ball'"))
            .collect();
        assert!(warned.is_empty(), "{integrator}: {warned:?}");
    }
}
