//! A light's own Ray Visibility (`diffuse_visible`, `glossy_visible`, ... in
//! `CAUSTIC_lights_punctual` and `CAUSTIC_lights_area`; `scene::light_visibility`) in scenes
//! whose answer follows from linearity or from the lobe that finds the light.
//!
//! The camera sits at the origin looking down -Z at a floor at z = -4 facing it. Images
//! are 32 × 32 with a one-pixel box filter.

mod common;

use common::{GltfBuilder, render_image, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);

fn floor(g: &mut GltfBuilder, material: usize) {
    let h = 10.0;
    let p = [[-h, -h, -4.0], [h, -h, -4.0], [h, h, -4.0], [-h, h, -4.0]];
    g.mesh(&p, &[0, 1, 2, 0, 2, 3], material);
}

fn render(scene: &Path, out: &Path, args: &[&str]) -> Vec<[f32; 4]> {
    let mut all = vec!["--resolution", "32x32", "--filter", "box", "--filter-width", "1"];
    all.extend_from_slice(args);
    render_image(scene, out, &all, LIMIT)
}

fn mean(px: &[[f32; 4]], c: usize) -> f64 {
    px.iter().map(|p| p[c] as f64).sum::<f64>() / px.len() as f64
}

/// A rough dielectric floor (diffuse base under a specular layer) under a point light of
/// the given flags.
fn point_scene(dir: &Path, name: &str, flags: Value) -> PathBuf {
    let mut g = GltfBuilder::new();
    let m = g.material(json!({"pbrMetallicRoughness": {
        "baseColorFactor": [0.8, 0.6, 0.4, 1], "metallicFactor": 0.0, "roughnessFactor": 0.3}}));
    floor(&mut g, m);
    g.punctual_with(
        json!({"type": "point", "intensity": 2000.0}),
        [0.7, 0.4, -2.5],
        [0.0, 0.0, 0.0, 1.0],
        json!({"CAUSTIC_lights_punctual": flags}),
    );
    g.use_ext("CAUSTIC_lights_punctual");
    g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.8);
    g.write(dir, name)
}

/// A point light is found by next-event estimation alone, and f splits into its diffuse
/// and glossy classes: the floor under a light hidden from diffuse rays plus the floor
/// under one hidden from glossy rays is the floor under the light seen by all, pixel by
/// pixel (the same samples: equal up to float rounding of a sum of two terms, 1e-5
/// relative); hidden from transmission it is unchanged (nothing transmits), and hidden
/// from both diffuse and glossy the floor is black.
#[test]
fn next_event_estimation_leaves_out_the_hidden_classes() {
    let dir = temp_dir();
    let d = dir.path();
    let args = ["--spp", "4", "--max-depth", "1"];
    let all = render(&point_scene(d, "a.gltf", json!({})), &d.join("a.exr"), &args);
    let no_diffuse = render(&point_scene(d, "b.gltf", json!({"diffuse_visible": false})), &d.join("b.exr"), &args);
    let no_glossy = render(&point_scene(d, "c.gltf", json!({"glossy_visible": false})), &d.join("c.exr"), &args);
    let no_transmission =
        render(&point_scene(d, "t.gltf", json!({"transmission_visible": false})), &d.join("t.exr"), &args);
    let neither = render(
        &point_scene(d, "n.gltf", json!({"diffuse_visible": false, "glossy_visible": false})),
        &d.join("n.exr"),
        &args,
    );
    for c in 0..3 {
        let (a, b, g) = (mean(&all, c), mean(&no_diffuse, c), mean(&no_glossy, c));
        assert!(a > 0.0 && b > 0.0 && g > 0.0, "channel {c}: {a} {b} {g}");
        assert!(g > b, "the diffuse base gives more than the specular layer: {g} vs {b}");
        assert!(((b + g) / a - 1.0).abs() < 1e-5, "channel {c}: {b} + {g} vs {a}");
    }
    for (i, (p, q)) in all.iter().zip(&no_transmission).enumerate() {
        assert_eq!(p[..3], q[..3], "pixel {i}: hiding transmission changed an opaque floor");
    }
    assert!(neither.iter().all(|p| p[..3] == [0.0; 3]), "hidden from both classes the light lights nothing");
}

/// A mirror floor under a large area light above the camera, facing down: camera rays
/// find the light after one glossy (singular) bounce. Hidden from glossy rays the mirror
/// shows black; hidden from diffuse rays it shows the same as a light seen by all (the
/// same samples take the same path: bit for bit).
#[test]
fn bounces_find_the_light_by_their_kind() {
    let dir = temp_dir();
    let d = dir.path();
    let scene = |name: &str, flags: Value| {
        let mut g = GltfBuilder::new();
        let mirror = g.material(json!({"pbrMetallicRoughness": {
            "baseColorFactor": [1, 1, 1, 1], "metallicFactor": 1.0, "roughnessFactor": 0.0}}));
        floor(&mut g, mirror);
        let mut area = json!({"shape": "square", "size": [40.0, 40.0], "power": 1000.0});
        area.as_object_mut().unwrap().extend(flags.as_object().unwrap().clone());
        let n = g.node(json!({"translation": [0.0, 0.0, 1.0]}));
        g.node_ext(n, "CAUSTIC_lights_area", area);
        g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.5);
        g.write(d, name)
    };
    let args = ["--spp", "4", "--max-depth", "3"];
    let all = render(&scene("a.gltf", json!({})), &d.join("a.exr"), &args);
    assert!(mean(&all, 0) > 0.0, "the mirror shows the light");
    let no_diffuse = render(&scene("b.gltf", json!({"diffuse_visible": false})), &d.join("b.exr"), &args);
    assert_eq!(all, no_diffuse, "a mirror bounce is glossy: a light hidden from diffuse rays is still found");
    let no_glossy = render(&scene("c.gltf", json!({"glossy_visible": false})), &d.join("c.exr"), &args);
    assert!(no_glossy.iter().all(|p| p[..3] == [0.0; 3]), "a light hidden from glossy rays is not found by them");
}

/// In a medium lit only by a point light, a light hidden from volume rays gives the
/// scattering events nothing. The light is hidden from diffuse and glossy rays in both
/// renders, so the floor (whose specular layer would reflect it) takes none of its light:
/// with volume rays hidden too the image is black.
#[test]
fn volume_scattering_ignores_a_light_hidden_from_volume_rays() {
    let dir = temp_dir();
    let d = dir.path();
    let scene = |name: &str, flags: Value| {
        let mut g = GltfBuilder::new();
        let black =
            g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0}}));
        floor(&mut g, black);
        g.world(json!({"color": [0.0, 0.0, 0.0], "medium": {"density": 0.2, "scatter_color": [0.8, 0.8, 0.8]}}));
        g.punctual_with(
            json!({"type": "point", "intensity": 500.0}),
            [0.0, 0.0, -2.0],
            [0.0, 0.0, 0.0, 1.0],
            json!({"CAUSTIC_lights_punctual": flags}),
        );
        g.use_ext("CAUSTIC_lights_punctual");
        g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.5);
        g.write(d, name)
    };
    let args = ["--spp", "4", "--max-depth", "2"];
    let surfaces_hidden = json!({"diffuse_visible": false, "glossy_visible": false});
    let seen = render(&scene("a.gltf", surfaces_hidden.clone()), &d.join("a.exr"), &args);
    assert!(mean(&seen, 0) > 0.0, "the fog glows around the light");
    let mut all_hidden = surfaces_hidden;
    all_hidden["volume_scatter_visible"] = json!(false);
    let hidden = render(&scene("b.gltf", all_hidden), &d.join("b.exr"), &args);
    assert!(hidden.iter().all(|p| p[..3] == [0.0; 3]), "a light hidden from volume rays lights no fog");
}

/// The world's own Ray Visibility (`visibility` in `CAUSTIC_world`, Cycles' World > Ray
/// Visibility): a grey world over a floor that fills the left half of the view (a diffuse
/// closure only: no specular layer), direct light only. Hidden from diffuse rays the world
/// lights the floor with exactly nothing and the sky is seen as before (bit for bit); hidden
/// from the camera the sky is black and the floor is lit bit for bit as before (the camera's
/// escaping rays draw no random numbers). A malformed flag is a bad scene (exit 3).
#[test]
fn the_world_is_hidden_from_the_rays_its_flags_name() {
    let dir = temp_dir();
    let d = dir.path();
    let scene = |name: &str, visibility: Option<Value>| {
        let mut g = GltfBuilder::new();
        g.use_ext("KHR_materials_specular");
        let m = g
            .material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0},
            "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}}));
        let h = 10.0;
        g.mesh(&[[-h, -h, -4.0], [0.0, -h, -4.0], [0.0, h, -4.0], [-h, h, -4.0]], &[0, 1, 2, 0, 2, 3], m);
        let mut w = json!({"color": [0.5, 0.5, 0.5], "strength": 1.0});
        if let Some(v) = visibility {
            w["visibility"] = v;
        }
        g.world(w);
        // An opaque film: camera rays that miss show the world.
        g.settings(json!({"transparent": false}));
        g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.5);
        g.write(d, name)
    };
    let args = ["--spp", "16", "--max-depth", "1"];
    let r = |name: &str, v: Option<Value>| {
        render(&scene(&format!("{name}.gltf"), v), &d.join(format!("{name}.exr")), &args)
    };
    let (floor, sky): (Vec<usize>, Vec<usize>) =
        (0..32 * 32).filter(|i| i % 32 != 15 && i % 32 != 16).partition(|i| i % 32 < 16);
    let seen = r("seen", None);
    assert!(
        floor.iter().all(|&i| seen[i][0] > 0.01) && sky.iter().all(|&i| seen[i][0] > 0.4),
        "the world lights and shows"
    );
    let no_diffuse = r("no_diffuse", Some(json!({"diffuse": false})));
    assert!(floor.iter().all(|&i| no_diffuse[i][..3] == [0.0; 3]), "hidden from diffuse rays: the floor is unlit");
    assert!(sky.iter().all(|&i| no_diffuse[i] == seen[i]), "the camera still sees the world");
    let no_camera = r("no_camera", Some(json!({"camera": false})));
    assert!(sky.iter().all(|&i| no_camera[i][..3] == [0.0; 3]), "hidden from the camera: the sky is black");
    assert!(floor.iter().all(|&i| no_camera[i] == seen[i]), "the floor is lit as before");
    let bad = scene("bad.gltf", Some(json!({"camera": 1})));
    let out = d.join("bad.exr");
    let run = common::run(&["render", bad.to_str().unwrap(), "-o", out.to_str().unwrap()], LIMIT);
    assert_eq!(run.code, Some(3), "a malformed flag is a bad scene: {}", run.stderr);
}
