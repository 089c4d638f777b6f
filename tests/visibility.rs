//! Per-object ray visibility (`CAUSTIC_object_visibility`, Blender's Ray Visibility) in
//! scenes whose answer is known without rendering: an object hidden from a kind of ray
//! is passed by rays of that kind and only by them.
//!
//! The camera sits at the origin looking down -Z at a white diffuse floor at z = -4 (or a
//! mirror); a black quad at z = -2 covers the middle of the view. Images are 32 × 32 with
//! a one-pixel box filter, so each pixel's value is a mean over its own footprint only.

mod common;

use common::{GltfBuilder, render_image, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);
const W: usize = 32;

fn quad(g: &mut GltfBuilder, z: f32, h: f32, facing_up: bool, material: usize) -> usize {
    let p = [[-h, -h, z], [h, -h, z], [h, h, z], [-h, h, z]];
    let idx: &[u32] = if facing_up { &[0, 1, 2, 0, 2, 3] } else { &[0, 2, 1, 0, 3, 2] };
    g.mesh(&p, idx, material)
}

fn render(scene: &Path, out: &Path, spp: &str, depth: &str) -> Vec<[f32; 4]> {
    let args = ["--resolution", "32x32", "--spp", spp, "--filter", "box", "--filter-width", "1", "--max-depth", depth];
    render_image(scene, out, &args, LIMIT)
}

/// Mean red value over the pixels whose centre lies within `r` of the image centre
/// (Chebyshev distance in pixels), or beyond `r` when `inside` is false.
fn mean_red(px: &[[f32; 4]], r: f32, inside: bool) -> f64 {
    let c = W as f32 / 2.0;
    let sel: Vec<f64> = (0..px.len())
        .filter(|i| {
            let (x, y) = ((i % W) as f32 + 0.5 - c, (i / W) as f32 + 0.5 - c);
            (x.abs().max(y.abs()) < r) == inside
        })
        .map(|i| px[i][0] as f64)
        .collect();
    sel.iter().sum::<f64>() / sel.len() as f64
}

/// Floor under a sun shining straight down, with the black occluder of visibility `vis`.
/// The image's half-height is tan(0.25) = 0.2553 per unit of depth over 16 px: the occluder
/// (half-width 0.3 at depth 2) images to ±9.4 px about the centre and its shadow on the
/// floor (half-width 0.3 at depth 4) to ±4.7 px; the floor is lit outside both.
fn sun_scene(dir: &Path, name: &str, vis: Value) -> PathBuf {
    let mut g = GltfBuilder::new();
    let white =
        g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0}}));
    let black = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0}}));
    quad(&mut g, -4.0, 10.0, true, white);
    let occluder = quad(&mut g, -2.0, 0.3, true, black);
    g.node_ext(occluder, "CAUSTIC_object_visibility", vis);
    g.punctual(json!({"type": "directional", "intensity": 683.0}), [0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0]);
    g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.5);
    g.write(dir, name)
}

/// Hidden from the camera, the occluder still casts its shadow: the middle of the image
/// shows the floor in shadow (0: direct light only, a black occluder reflects nothing)
/// where a visible occluder shows itself (also 0) — and hidden from both the camera and
/// shadow rays, the floor is lit everywhere. The sun is a delta light seen by NEE only, so
/// a lit pixel is the same in two renders up to rounding (1e-4 relative); across the image
/// the floor's value varies a little with the view direction (its dielectric layer's albedo
/// seen from the viewer: 8e-5 of it here), so the bare floor is held to 1e-3 of its mean,
/// where a shadow would be 100 % off.
#[test]
fn hidden_from_camera_still_casts_its_shadow() {
    let dir = temp_dir();
    let d = dir.path();
    let px = render(&sun_scene(d, "a.gltf", json!({"camera": false})), &d.join("a.exr"), "4", "1");
    let bare = render(&sun_scene(d, "b.gltf", json!({"camera": false, "shadow": false})), &d.join("b.exr"), "4", "1");
    let lit = mean_red(&px, 10.0, false);
    assert!(lit > 0.1, "the floor is lit around the occluder: {lit}");
    assert_eq!(mean_red(&px, 2.0, true), 0.0, "the floor under an unseen occluder is in its shadow");
    // Pixels wholly between the shadow (±4.7 px) and the occluder's image (±9.4 px): floor, lit
    // as the bare floor is there.
    let ring: Vec<usize> = (0..px.len())
        .filter(|i| {
            let (x, y) = ((i % W) as f32 - 15.5, (i / W) as f32 - 15.5);
            (5.5..=8.5).contains(&x.abs().max(y.abs()))
        })
        .collect();
    let off: Vec<(f32, f32)> = ring
        .iter()
        .filter(|&&i| (px[i][0] - bare[i][0]).abs() > 1e-4 * bare[i][0])
        .map(|&i| (px[i][0], bare[i][0]))
        .collect();
    assert!(off.is_empty(), "the floor does not show where the occluder hides: {off:?}");
    assert!(bare.iter().all(|p| (p[0] as f64 - lit).abs() <= 1e-3 * lit), "nothing hides the floor or its light");

    // Seen by the camera but not by shadow rays: the occluder shows (black: only its 4 %
    // dielectric specular reflects the sun) and casts no shadow beside its image.
    let px = render(&sun_scene(d, "c.gltf", json!({"shadow": false})), &d.join("c.exr"), "4", "1");
    assert!(mean_red(&px, 9.0, true) < 0.05 * lit, "the occluder is seen");
    assert!((mean_red(&px, 10.0, false) - lit).abs() <= 1e-4 * lit);
}

/// A mirror floor (metal, roughness 0, white: reflectance 1) shows an emitter of radiance 1
/// behind the camera through a glossy bounce; hidden from glossy rays it shows the black
/// world instead. A delta bounce has no NEE, so the emitter's value is exact: 1 within the
/// f32 rounding of the mirror's Fresnel (1e-4).
#[test]
fn hidden_from_glossy_rays_leaves_the_mirror_empty() {
    let dir = temp_dir();
    let d = dir.path();
    let scene = |name: &str, vis: Value| {
        let mut g = GltfBuilder::new();
        let mirror = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 1.0, "roughnessFactor": 0.0}}));
        let glow =
            g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}, "emissiveFactor": [1, 1, 1]}));
        quad(&mut g, -4.0, 10.0, true, mirror);
        let emitter = quad(&mut g, 1.0, 10.0, false, glow);
        g.node_ext(emitter, "CAUSTIC_object_visibility", vis);
        g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.5);
        g.write(d, name)
    };
    let seen = render(&scene("a.gltf", json!({"diffuse": false, "transmission": false})), &d.join("a.exr"), "4", "3");
    assert!(
        (mean_red(&seen, 16.0, true) - 1.0).abs() < 1e-4,
        "mirror shows the emitter: {}",
        mean_red(&seen, 16.0, true)
    );
    let hidden = render(&scene("b.gltf", json!({"glossy": false})), &d.join("b.exr"), "4", "3");
    assert_eq!(mean_red(&hidden, 16.0, true), 0.0, "a glossy ray passes the emitter");
}

/// Behind clear glass of index 1.01 (Fresnel reflectance at normal incidence
/// (0.01/2.01)² = 2.5e-5 per face, so the view through it is 1 within 1e-4), an emitter of
/// radiance 1 is seen by transmitted rays; hidden from transmission it is not, though
/// camera rays that miss the glass still see it.
#[test]
fn hidden_from_transmission_is_not_seen_through_glass() {
    let dir = temp_dir();
    let d = dir.path();
    let scene = |name: &str, vis: Value| {
        let mut g = GltfBuilder::new();
        g.use_ext("KHR_materials_transmission");
        g.use_ext("KHR_materials_ior");
        let glass = g.material(json!({
            "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
            "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.01}}
        }));
        let glow =
            g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}, "emissiveFactor": [1, 1, 1]}));
        g.cube([-0.3, -0.3, -2.2], [0.3, 0.3, -1.8], glass);
        let emitter = quad(&mut g, -4.0, 10.0, true, glow);
        g.node_ext(emitter, "CAUSTIC_object_visibility", vis);
        g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.5);
        g.write(d, name)
    };
    let seen = render(&scene("a.gltf", json!({"diffuse": false, "glossy": false})), &d.join("a.exr"), "4", "4");
    assert!((mean_red(&seen, 2.0, true) - 1.0).abs() < 1e-4, "through glass: {}", mean_red(&seen, 2.0, true));
    let hidden = render(&scene("b.gltf", json!({"transmission": false})), &d.join("b.exr"), "4", "4");
    assert!(mean_red(&hidden, 2.0, true) < 1e-4, "hidden from transmitted rays: {}", mean_red(&hidden, 2.0, true));
    // The glass's front face (half-width 0.3 at depth 1.8) images to ±10.4 px.
    assert!((mean_red(&hidden, 12.0, false) - 1.0).abs() < 1e-6, "camera rays beside the glass see it");
}

/// A diffuse floor of albedo 0.5 under a white world of radiance 1, below a black roof
/// hidden from diffuse and shadow rays: every light path reaches the world, so the floor
/// shows ρ·L = 0.5 (direct light only). The image mean averages 1024 px × 64 spp = 65 536
/// samples of an estimator bounded by 0.5·2 (MIS weights ≤ 1 of two strategies): its standard
/// error is under 1/√65536 = 0.004, so a 3 % bound (0.015) is over 3.7 of them. Seen by
/// diffuse rays but not by shadow rays, the roof blocks the BSDF-sampled part of MIS only:
/// darker than 0.5 by far more than that (checked at 10 %).
#[test]
fn hidden_from_diffuse_and_shadow_rays_lets_the_world_in() {
    let dir = temp_dir();
    let d = dir.path();
    let scene = |name: &str, vis: Value| {
        let mut g = GltfBuilder::new();
        let grey = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
        let black =
            g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0}}));
        quad(&mut g, -4.0, 10.0, true, grey);
        let roof = quad(&mut g, -3.0, 50.0, false, black);
        g.node_ext(roof, "CAUSTIC_object_visibility", vis);
        g.world(json!({"color": [1, 1, 1], "strength": 1.0}));
        g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.5);
        g.write(d, name)
    };
    let open = render(
        &scene("a.gltf", json!({"camera": false, "diffuse": false, "shadow": false})),
        &d.join("a.exr"),
        "64",
        "1",
    );
    let mean = |px: &[[f32; 4]]| px.iter().map(|p| p[0] as f64).sum::<f64>() / px.len() as f64;
    assert!((mean(&open) - 0.5).abs() < 0.5 * 0.03, "floor under a hidden roof: {}", mean(&open));
    let half = render(&scene("b.gltf", json!({"camera": false, "shadow": false})), &d.join("b.exr"), "64", "1");
    assert!(mean(&half) < 0.5 * 0.9, "a roof seen by diffuse rays hides the BSDF-sampled world: {}", mean(&half));
}

/// A holdout quad (half-width 0.3 at depth 2: ±9.4 px) in front of an emitter of radiance 1
/// filling the view: camera rays that reach it see nothing, colour and alpha 0, in the path,
/// Jensen, SPPM, BDPT and VCM integrators (whose light tracing shows no light the holdout
/// reflects); the emitter around it shows 1 with alpha 1. Pixels wholly inside or outside the
/// quad's image are exact (a box filter of one pixel).
#[test]
fn a_holdout_shows_nothing_with_alpha_zero() {
    let dir = temp_dir();
    let d = dir.path();
    let mut g = GltfBuilder::new();
    let grey =
        g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0.0}}));
    let glow =
        g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}, "emissiveFactor": [1, 1, 1]}));
    quad(&mut g, -4.0, 10.0, true, glow);
    let held = quad(&mut g, -2.0, 0.3, true, grey);
    g.node_ext(held, "CAUSTIC_object_visibility", json!({"holdout": true}));
    g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.5);
    let scene = g.write(d, "held.gltf");
    for integrator in ["path", "photon", "sppm", "bdpt", "vcm"] {
        let args = [
            "--resolution",
            "32x32",
            "--spp",
            "4",
            "--filter",
            "box",
            "--filter-width",
            "1",
            "--max-depth",
            "3",
            "--integrator",
            integrator,
            "--photons",
            "1000",
        ];
        let px = render_image(&scene, &d.join(format!("{integrator}.exr")), &args, LIMIT);
        let centre = |p: &[f32; 4]| p.iter().all(|v| *v == 0.0);
        let inside: Vec<&[f32; 4]> = (0..px.len())
            .filter(|i| ((i % W) as f32 - 15.5).abs().max(((i / W) as f32 - 15.5).abs()) < 9.0)
            .map(|i| &px[i])
            .collect();
        assert!(inside.iter().all(|p| centre(p)), "{integrator}: the holdout shows colour or alpha: {:?}", inside[0]);
        let outside: Vec<&[f32; 4]> = (0..px.len())
            .filter(|i| ((i % W) as f32 - 15.5).abs().max(((i / W) as f32 - 15.5).abs()) > 10.0)
            .map(|i| &px[i])
            .collect();
        if matches!(integrator, "bdpt" | "vcm") {
            // The emitter seen directly is weighed between s = 0 and light tracing, whose
            // sum is 1 only on average: its mean within 5 standard errors of the pixels'
            // spread (each light path splats the emitter into one pixel: nearly independent).
            let v: Vec<f64> = outside.iter().map(|p| p[0] as f64).collect();
            let (m, se) = common::mean_se(&v);
            assert!(outside.iter().all(|p| p[3] == 1.0), "{integrator}: alpha around the holdout");
            assert!((m - 1.0).abs() <= 5.0 * se + 1e-6, "{integrator}: the emitter around the holdout: {m} ± {se}");
            continue;
        }
        assert!(
            outside.iter().all(|p| p[3] == 1.0 && (p[0] - 1.0).abs() < 1e-3),
            "{integrator}: the emitter around the holdout: {:?}",
            outside[0]
        );
    }
}

/// Under an opaque film (Film → Transparent off) Cycles counts the world as seen but keeps a
/// holdout's share out of alpha: a holdout quad (±9.4 px) with nothing behind it and no world
/// has alpha exactly 0 where it covers the pixel and 1 around it, where camera rays miss
/// everything, in every integrator. (The film used to set alpha 1 wherever it had sampled.)
#[test]
fn a_holdout_keeps_alpha_zero_under_an_opaque_film() {
    let dir = temp_dir();
    let d = dir.path();
    let mut g = GltfBuilder::new();
    let grey =
        g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0.0}}));
    let held = quad(&mut g, -2.0, 0.3, true, grey);
    g.node_ext(held, "CAUSTIC_object_visibility", json!({"holdout": true}));
    g.punctual(json!({"type": "point", "intensity": 683.0}), [0.0, 0.0, -1.0], [0.0, 0.0, 0.0, 1.0]);
    g.settings(json!({"transparent": false}));
    g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.5);
    let scene = g.write(d, "held.gltf");
    for integrator in ["path", "photon", "sppm", "bdpt", "vcm"] {
        let args = [
            "--resolution",
            "32x32",
            "--spp",
            "4",
            "--filter",
            "box",
            "--filter-width",
            "1",
            "--integrator",
            integrator,
            "--photons",
            "1000",
        ];
        let px = render_image(&scene, &d.join(format!("{integrator}.exr")), &args, LIMIT);
        let ring = |i: usize| ((i % W) as f32 - 15.5).abs().max(((i / W) as f32 - 15.5).abs());
        for (i, p) in px.iter().enumerate() {
            if ring(i) < 9.0 {
                assert_eq!(p[3], 0.0, "{integrator}: alpha on the holdout at pixel {i}");
            } else if ring(i) > 10.0 {
                assert_eq!(p[3], 1.0, "{integrator}: alpha around the holdout at pixel {i}");
            }
        }
    }
}

/// A holdout quad lit from the front by a point light between it and the camera: BDPT's and
/// VCM's light tracing reaches the camera from the lit quad, and must show none of it where
/// the camera sees the holdout (colour and alpha exactly 0, as camera rays that hit it).
#[test]
fn a_lit_holdout_shows_nothing_in_light_tracing() {
    let dir = temp_dir();
    let d = dir.path();
    let mut g = GltfBuilder::new();
    let grey =
        g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0}}));
    let held = quad(&mut g, -2.0, 0.3, true, grey);
    g.node_ext(held, "CAUSTIC_object_visibility", json!({"holdout": true}));
    g.punctual(json!({"type": "point", "intensity": 50.0, "color": [1, 1, 1]}), [0.0, 0.2, -1.0], [0.0, 0.0, 0.0, 1.0]);
    g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.5);
    let scene = g.write(d, "lit_held.gltf");
    for integrator in ["bdpt", "vcm"] {
        let args = ["--resolution", "32x32", "--spp", "16", "--filter", "box", "--filter-width", "1"];
        let args = [&args[..], &["--integrator", integrator]].concat();
        let px = render_image(&scene, &d.join(format!("{integrator}.exr")), &args, LIMIT);
        let inside: Vec<&[f32; 4]> = (0..px.len())
            .filter(|i| ((i % W) as f32 - 15.5).abs().max(((i / W) as f32 - 15.5).abs()) < 9.0)
            .map(|i| &px[i])
            .collect();
        assert!(
            inside.iter().all(|p| p.iter().all(|v| *v == 0.0)),
            "{integrator}: the lit holdout shows colour or alpha: {:?}",
            inside.iter().find(|p| p.iter().any(|v| *v != 0.0))
        );
    }
}
