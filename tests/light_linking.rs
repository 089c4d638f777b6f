//! Light linking (`CAUSTIC_light_linking`, Blender's receiver collections) in scenes whose
//! answer is known: an emitter lights its receivers exactly as without the rule and the
//! other objects not at all, by next-event estimation and by BSDF-sampled rays alike.
//!
//! The camera at the origin looks down -Z at two grey quads side by side at z = -4, "Left"
//! (x < 0) and "Right" (x > 0). Direct light only (max depth 1): a surface an emitter does
//! not light shows exactly 0, and since the rule changes no random number, the lit quad's
//! pixels equal those of the render without the rule bit for bit.

mod common;

use common::{GltfBuilder, render_image, run, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);
const W: usize = 32;

/// The two quads and the camera; `emitter` adds the light and returns its node.
fn scene(dir: &Path, name: &str, rule: Option<Value>, emitter: impl Fn(&mut GltfBuilder) -> usize) -> PathBuf {
    let mut g = GltfBuilder::new();
    let grey =
        g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0.0}}));
    let (z, h) = (-4.0, 3.0);
    let left = g.mesh(&[[-h, -h, z], [0.0, -h, z], [0.0, h, z], [-h, h, z]], &[0, 1, 2, 0, 2, 3], grey);
    let right = g.mesh(&[[0.0, -h, z], [h, -h, z], [h, h, z], [0.0, h, z]], &[0, 1, 2, 0, 2, 3], grey);
    g.node_name(left, "Left");
    g.node_name(right, "Right");
    let e = emitter(&mut g);
    if let Some(r) = rule {
        g.node_ext(e, "CAUSTIC_light_linking", r);
    }
    g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.5);
    g.write(dir, name)
}

fn render(path: &Path, out: &Path) -> Vec<[f32; 4]> {
    let args = ["--resolution", "32x32", "--spp", "16", "--filter", "box", "--filter-width", "1", "--max-depth", "1"];
    render_image(path, out, &args, LIMIT)
}

/// Pixels wholly on the left quad, and wholly on the right one (the seam is the middle column).
fn halves(px: &[[f32; 4]]) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    let left = (0..px.len()).filter(|i| i % W < W / 2 - 1).map(|i| px[i]).collect();
    let right = (0..px.len()).filter(|i| i % W > W / 2).map(|i| px[i]).collect();
    (left, right)
}

fn check(dir: &Path, label: &str, rule: Value, lit_left: bool, emitter: impl Fn(&mut GltfBuilder) -> usize + Copy) {
    let free = render(&scene(dir, &format!("{label}0.gltf"), None, emitter), &dir.join(format!("{label}0.exr")));
    let linked =
        render(&scene(dir, &format!("{label}1.gltf"), Some(rule), emitter), &dir.join(format!("{label}1.exr")));
    let ((fl, fr), (ll, lr)) = (halves(&free), halves(&linked));
    let (lit_free, lit, dark) = if lit_left { (fl, ll, lr) } else { (fr, lr, ll) };
    assert!(lit_free.iter().all(|p| p[0] > 0.01), "{label}: the scene is lit without the rule");
    assert_eq!(lit, lit_free, "{label}: the receiver is lit as without the rule");
    assert!(dark.iter().all(|p| p[0] == 0.0 && p[3] == 1.0), "{label}: the other quad gets no light");
}

/// A sun (delta: NEE only) that includes only "Left".
#[test]
fn a_sun_lights_only_its_receivers() {
    let dir = temp_dir();
    check(dir.path(), "sun", json!({"receivers": ["Left"], "include": true}), true, |g| {
        g.punctual(json!({"type": "directional", "intensity": 683.0}), [0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0])
    });
}

/// An emissive quad behind the camera facing the floor (found by NEE and by BSDF-sampled
/// rays, weighted by MIS) that excludes "Left".
#[test]
fn an_emissive_object_excludes_a_receiver() {
    let dir = temp_dir();
    check(dir.path(), "mesh", json!({"receivers": ["Left"], "include": false}), false, |g| {
        let glow =
            g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}, "emissiveFactor": [1, 1, 1]}));
        let h = 4.0;
        g.mesh(&[[-h, -h, 1.0], [-h, h, 1.0], [h, h, 1.0], [h, -h, 1.0]], &[0, 1, 2, 0, 2, 3], glow)
    });
}

/// An area light (crossed by BSDF-sampled rays, not blocking them) that includes "Right".
#[test]
fn an_area_light_lights_only_its_receivers() {
    let dir = temp_dir();
    check(dir.path(), "area", json!({"receivers": ["Right"], "include": true}), false, |g| {
        g.use_ext("CAUSTIC_lights_area");
        g.node(json!({"translation": [0.0, 0.0, -1.0],
            "extensions": {"CAUSTIC_lights_area": {"shape": "square", "size": [2.0, 2.0], "power": 100.0}}}))
    });
}

/// Every integrator honours an object's ray visibility (BDPT by its camera side,
/// `bdpt::visibility`; Jensen by its photons' kinds), holdouts and light linking
/// (`tests/linking_integrators.rs`) without a word.
#[test]
fn other_integrators_honour_visibility_and_linking_without_a_word() {
    let dir = temp_dir();
    let d = dir.path();
    let path = scene(d, "warn.gltf", Some(json!({"receivers": ["Left"], "include": true})), |g| {
        g.punctual(json!({"type": "directional", "intensity": 683.0}), [0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0])
    });
    // Left hidden from glossy rays, Right a holdout (nodes 0 and 1).
    let mut doc: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    doc["nodes"][0]["extensions"] = json!({"CAUSTIC_object_visibility": {"glossy": false}});
    doc["nodes"][1]["extensions"] = json!({"CAUSTIC_object_visibility": {"holdout": true}});
    doc["extensionsUsed"].as_array_mut().unwrap().push(json!("CAUSTIC_object_visibility"));
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    // Every integrator renders holdouts now (BDPT and VCM drop light vertices on them): no
    // warning names one.
    for integrator in ["bdpt", "photon"] {
        let out = d.join(format!("{integrator}.exr"));
        let args = [
            "render",
            path.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--progress",
            "json",
            "--resolution",
            "4x4",
            "--spp",
            "1",
            "--integrator",
            integrator,
            "--photons",
            "1000",
        ];
        let r = run(&args, LIMIT);
        assert_eq!(r.code, Some(0), "{}", r.stderr);
        let warnings = r.warnings();
        let said = |words: &[&str]| warnings.iter().any(|w| words.iter().all(|x| w.contains(x)));
        assert!(!said(&["light linking"]), "{integrator}: {warnings:?}");
        assert!(!said(&["ray visibility", "'Left'"]), "{integrator}: {warnings:?}");
        assert!(!said(&["holdout", "'Right'"]), "{integrator}: {warnings:?}");
    }
}

/// Shadow linking (`blockers` in `CAUSTIC_light_linking`, Blender's Blocker Collection): a
/// quad that the camera does not see hangs over the left quad under a sun shining straight
/// down. Only the sun's blockers cast its shadow: with a rule that leaves the quad out the
/// floor is lit bit for bit as with the quad hidden from shadow rays; with a rule that lists
/// it, shadowed bit for bit as without any rule (the sun is a delta light: its estimate
/// takes no MIS weight, so the rule changes no number but the shadow test).
#[test]
fn a_sun_is_shadowed_only_by_its_blockers() {
    let dir = temp_dir();
    let d = dir.path();
    let variant = |name: &str, occluder: Value, rule: Option<Value>| {
        let mut g = GltfBuilder::new();
        let grey =
            g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0.0}}));
        let (z, h) = (-4.0, 3.0);
        let left = g.mesh(&[[-h, -h, z], [0.0, -h, z], [0.0, h, z], [-h, h, z]], &[0, 1, 2, 0, 2, 3], grey);
        let right = g.mesh(&[[0.0, -h, z], [h, -h, z], [h, h, z], [0.0, h, z]], &[0, 1, 2, 0, 2, 3], grey);
        let blocker = g.mesh(
            &[[-2.5, -1.0, -2.0], [-0.5, -1.0, -2.0], [-0.5, 1.0, -2.0], [-2.5, 1.0, -2.0]],
            &[0, 1, 2, 0, 2, 3],
            grey,
        );
        g.node_name(left, "Left");
        g.node_name(right, "Right");
        g.node_name(blocker, "Blocker");
        g.node_ext(blocker, "CAUSTIC_object_visibility", occluder);
        let sun = g.punctual(json!({"type": "directional", "intensity": 683.0}), [0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0]);
        if let Some(r) = rule {
            g.node_ext(sun, "CAUSTIC_light_linking", r);
        }
        g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.5);
        render(&g.write(d, &format!("{name}.gltf")), &d.join(format!("{name}.exr")))
    };
    let unseen = json!({"camera": false});
    let unlit = variant("shadowed", unseen.clone(), None);
    let lit = variant("lit", json!({"camera": false, "shadow": false}), None);
    let (shadow_left, _) = halves(&unlit);
    assert!(shadow_left.iter().any(|p| p[0] == 0.0), "the blocker shadows the left quad without a rule");
    assert_ne!(unlit, lit);
    let only_right =
        variant("only_right", unseen.clone(), Some(json!({"blockers": ["Right"], "blockers_include": true})));
    assert_eq!(only_right, lit, "a blocker rule without the quad: no shadow");
    let but_quad =
        variant("but_quad", unseen.clone(), Some(json!({"blockers": ["Blocker"], "blockers_include": false})));
    assert_eq!(but_quad, lit, "a rule excluding the quad: no shadow");
    let only_quad = variant("only_quad", unseen, Some(json!({"blockers": ["Blocker"], "blockers_include": true})));
    assert_eq!(only_quad, unlit, "a rule listing the quad: its shadow");
}

/// Strands and points are lit as their object (`object` in `CAUSTIC_curves`, `CAUSTIC_points`):
/// white strands (or spheres) over a black floor, under a sun whose receivers are their object
/// ("Hair", "Dots", which have no node) or exclude it. Direct light only: including them changes
/// no pixel from the unlinked render (bit for bit), excluding them leaves the image black (the
/// floor reflects nothing).
#[test]
fn strands_and_points_are_lit_as_their_object() {
    let dir = temp_dir();
    let d = dir.path();
    for (object, add) in OBJECTS {
        let scene = |name: &str, rule: Option<Value>| {
            let mut g = GltfBuilder::new();
            let black = g
                .material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0},
                "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}}));
            let white = g.material(
                json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0}}),
            );
            g.use_ext("KHR_materials_specular");
            let (z, h) = (-4.0, 3.0);
            g.mesh(&[[-h, -h, z], [h, -h, z], [h, h, z], [-h, h, z]], &[0, 1, 2, 0, 2, 3], black);
            add(&mut g, white);
            let sun =
                g.punctual(json!({"type": "directional", "intensity": 683.0}), [0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]);
            if let Some(r) = rule {
                g.node_ext(sun, "CAUSTIC_light_linking", r);
            }
            g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.5);
            g.write(d, &format!("{object}_{name}"))
        };
        let plain = render(&scene("plain.gltf", None), &d.join("plain.exr"));
        assert!(plain.iter().any(|p| p[0] > 0.1), "{object}: lit");
        let included =
            render(&scene("in.gltf", Some(json!({"receivers": [object], "include": true}))), &d.join("in.exr"));
        assert_eq!(plain, included, "{object}: the sun lights what it includes as without a rule");
        let excluded =
            render(&scene("out.gltf", Some(json!({"receivers": [object], "include": false}))), &d.join("out.exr"));
        assert!(excluded.iter().all(|p| p[..3] == [0.0; 3]), "{object}: the sun does not light what it excludes");
    }
}

/// Strands and points block a shadow-linked light as their object: white strands (or spheres)
/// over a white floor under a sun shining straight down (direct light only). Without a rule they
/// shadow the floor (some pixels see only shadowed floor: exactly 0); a blocker rule that lists
/// their object changes no pixel (bit for bit: the sun is a delta light, the rule changes no
/// number but the shadow test); a rule that excludes it removes their shadows: no pixel is
/// black, and none is darker than without the rule (the same samples, only shadow tests turned
/// to lit).
#[test]
fn strands_and_points_block_as_their_object() {
    let dir = temp_dir();
    let d = dir.path();
    for (object, add) in OBJECTS {
        let scene = |name: &str, rule: Option<Value>| {
            let mut g = GltfBuilder::new();
            let white = g.material(
                json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0}}),
            );
            let (z, h) = (-4.0, 3.0);
            let floor = g.mesh(&[[-h, -h, z], [h, -h, z], [h, h, z], [-h, h, z]], &[0, 1, 2, 0, 2, 3], white);
            g.node_name(floor, "Floor");
            add(&mut g, white);
            let sun =
                g.punctual(json!({"type": "directional", "intensity": 683.0}), [0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]);
            if let Some(r) = rule {
                g.node_ext(sun, "CAUSTIC_light_linking", r);
            }
            g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.5);
            g.write(d, &format!("{object}_{name}"))
        };
        let plain = render(&scene("plain.gltf", None), &d.join("plain.exr"));
        assert!(plain.iter().any(|p| p[..3] == [0.0; 3]), "{object}: shadows the floor without a rule");
        let listed = render(
            &scene("listed.gltf", Some(json!({"blockers": [object], "blockers_include": true}))),
            &d.join("listed.exr"),
        );
        assert_eq!(plain, listed, "{object}: a blocker shadows as without a rule");
        let left_out = render(
            &scene("left_out.gltf", Some(json!({"blockers": [object], "blockers_include": false}))),
            &d.join("left_out.exr"),
        );
        assert!(left_out.iter().all(|p| p[0] > 0.0), "{object}: no blocker, no shadow");
        assert!(
            left_out.iter().zip(&plain).all(|(a, b)| a[0] >= b[0] && a[1] >= b[1] && a[2] >= b[2]),
            "{object}: leaving it out of the blockers only lights shadowed samples"
        );
    }
}

/// Adds an object of strands or points with a material to a scene.
type AddObject = fn(&mut GltfBuilder, usize);

/// The objects the linking tests above put in front of their floor, by name.
const OBJECTS: [(&str, AddObject); 2] = [("Hair", hair_rows), ("Dots", dot_rows)];

/// Eight rows of eight spheres of radius 0.1 at z = -3, one unit in front of the floors the
/// tests above put at z = -4, as the object "Dots".
fn dot_rows(g: &mut GltfBuilder, material: usize) {
    let (mut centres, mut radii) = (Vec::new(), Vec::new());
    for k in 0..8 {
        for j in 0..8 {
            centres.push([-1.4 + 0.4 * j as f32, -1.4 + 0.4 * k as f32, -3.0]);
            radii.push(0.1);
        }
    }
    g.points("Dots", material, &centres, &radii);
}

/// Eight straight strands of radius 0.05 in a row at z = -3, one unit in front of the floors
/// the strand tests put at z = -4, as the object "Hair".
fn hair_rows(g: &mut GltfBuilder, material: usize) {
    let (mut points, mut radii, mut counts) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..8 {
        let y = -1.4 + 0.4 * k as f32;
        points.extend([[-2.0, y, -3.0], [2.0, y, -3.0]]);
        radii.extend([0.05, 0.05]);
        counts.push(2);
    }
    g.curves("Hair", material, &points, &radii, &counts);
}
