//! Cycles' Light Paths settings beyond Max Bounces (`integrator::light_paths`): the per-kind
//! limits and clamps given by the scene's keys or by flags, exact identities that pin their
//! semantics without a reference renderer, and the warnings of the integrators that do not
//! follow them (the agreement with Cycles is `tests/blender/test_light_paths_agreement.py`).

mod common;

use common::{GltfBuilder, quick_render_warnings, render_image, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);

/// A closed grey box (Lambertian: specular factor 0, so every bounce is diffuse) with a point
/// light and the camera inside.
fn room(dir: &Path, name: &str, settings: Value) -> PathBuf {
    let mut g = GltfBuilder::new();
    let grey = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}, "doubleSided": true
    }));
    g.use_ext("KHR_materials_specular");
    g.cube([-2.0, -2.0, -6.0], [2.0, 2.0, 1.0], grey);
    g.punctual(json!({"type": "point", "intensity": 20000.0}), [0.3, 1.0, -3.0], [0.0, 0.0, 0.0, 1.0]);
    g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.9);
    g.settings(settings);
    g.write(dir, name)
}

const ARGS: [&str; 6] = ["--resolution", "24x16", "--spp", "8", "--max-depth", "9"];

fn bits(px: &[[f32; 4]]) -> Vec<u32> {
    px.iter().flat_map(|p| p.iter().map(|v| v.to_bits())).collect()
}

/// Where every bounce is diffuse, Diffuse Bounces n ends paths exactly where Max Bounces n
/// does (depth n + 1), with the same samples: the images are equal bit for bit, whether the
/// limit comes from the scene's key or the flag; and a clamp no sample reaches changes nothing.
#[test]
fn a_diffuse_limit_in_a_diffuse_room_is_max_bounces() {
    let dir = temp_dir();
    let d = dir.path();
    let plain = room(d, "p.gltf", json!({}));
    let keyed = room(d, "k.gltf", json!({"diffuse_max_bounces": 2, "glossy_max_bounces": 0}));
    let max2 = bits(&render_image(
        &plain,
        &d.join("m.exr"),
        &["--resolution", "24x16", "--spp", "8", "--max-depth", "3"],
        LIMIT,
    ));
    let by_key = bits(&render_image(&keyed, &d.join("k.exr"), &ARGS, LIMIT));
    let mut flagged = ARGS.to_vec();
    flagged.extend_from_slice(&["--diffuse-max-bounces", "2", "--clamp-indirect", "1e30"]);
    let by_flag = bits(&render_image(&plain, &d.join("f.exr"), &flagged, LIMIT));
    let unlimited = bits(&render_image(&plain, &d.join("u.exr"), &ARGS, LIMIT));
    assert_eq!(by_key, max2, "the scene's diffuse_max_bounces");
    assert_eq!(by_flag, max2, "--diffuse-max-bounces");
    assert_ne!(unlimited, max2, "the limit matters in this room");
}

/// Transparent Max Bounces 0 ends only paths that have passed an alpha surface (Cycles sets
/// its "terminate on the next surface" flag at a transparent bounce): in a room without alpha
/// surfaces the image is the one of the default limit bit for bit, in every integrator that
/// follows the limit; it was black.
#[test]
fn transparent_max_bounces_zero_leaves_opaque_paths_alone() {
    let dir = temp_dir();
    let d = dir.path();
    let plain = room(d, "p.gltf", json!({}));
    for integrator in ["path", "photon", "sppm"] {
        let base = ["--resolution", "24x16", "--spp", "4", "--max-depth", "4", "--integrator", integrator];
        let default = render_image(&plain, &d.join(format!("{integrator}_8.exr")), &base, LIMIT);
        let mut zero = base.to_vec();
        zero.extend_from_slice(&["--transparent-max-bounces", "0"]);
        let at_zero = render_image(&plain, &d.join(format!("{integrator}_0.exr")), &zero, LIMIT);
        assert!(default.iter().any(|p| p[0] > 0.0), "{integrator}: the room is lit");
        assert_eq!(bits(&at_zero), bits(&default), "{integrator}: Transparent Max Bounces 0 without alpha surfaces");
    }
}

/// A flag wins over the scene's key; Clamp Indirect 0.01 darkens the room (its indirect
/// samples are far above it), Clamp Direct alone leaves the indirect light as it was.
#[test]
fn clamps_cut_their_own_contributions() {
    let dir = temp_dir();
    let d = dir.path();
    let s = room(d, "c.gltf", json!({"clamp_indirect": 0.01}));
    let mean = |px: &[[f32; 4]]| px.iter().map(|p| p[0] as f64).sum::<f64>() / px.len() as f64;
    let clamped = mean(&render_image(&s, &d.join("a.exr"), &ARGS, LIMIT));
    let mut off = ARGS.to_vec();
    off.extend_from_slice(&["--clamp-indirect", "0"]);
    let unclamped = mean(&render_image(&s, &d.join("b.exr"), &off, LIMIT));
    let direct_only = ["--resolution", "24x16", "--spp", "8", "--max-depth", "1", "--clamp-indirect", "0"];
    let direct = mean(&render_image(&s, &d.join("c.exr"), &direct_only, LIMIT));
    assert!(clamped < unclamped * 0.99, "clamped {clamped} vs {unclamped}");
    assert!(clamped > direct, "the direct light is not clamped: {clamped} vs {direct}");
}

/// The integrators other than the path tracer name the limits, clamps and caustics switches
/// they do not follow (the path tracer follows them all and names none, BDPT and VCM the
/// per-kind limits); bad clamps are refused.
#[test]
fn what_is_not_followed_is_named_and_bad_values_refused() {
    let dir = temp_dir();
    let d = dir.path();
    let s = room(
        d,
        "w.gltf",
        json!({"diffuse_max_bounces": 1, "clamp_indirect": 10.0, "filter_glossy": 1.0, "caustics_reflective": false}),
    );
    for integrator in ["path", "bdpt", "vcm", "photon", "sppm"] {
        let flags = ["--integrator", integrator, "--sppm-iterations", "1", "--photons", "1000"];
        let said: Vec<String> = quick_render_warnings(&s, &d.join("w.exr"), &flags, LIMIT)
            .into_iter()
            .filter(|w| w.contains("Light Paths"))
            .collect();
        // BDPT and VCM follow the per-kind limits (`tests/bounce_limits.rs`): in this room,
        // without media or subsurface, they do not name them.
        let (expected, limits) = match integrator {
            "path" => (0, false),
            "bdpt" | "vcm" => (2, false),
            _ => (3, true),
        };
        assert_eq!(said.len(), expected, "{integrator}: {said:?}");
        assert_eq!(said.iter().any(|w| w.contains("Diffuse Bounces")), limits, "{integrator}: {said:?}");
        if integrator != "path" {
            assert!(said.iter().any(|w| w.contains("Reflective Caustics off")), "{integrator}: {said:?}");
            assert!(said.iter().any(|w| w.contains("Clamp Indirect") && w.contains("Filter Glossy")), "{said:?}");
        }
    }
    let out = d.join("b.exr");
    for flag in ["--clamp-direct", "--clamp-indirect", "--filter-glossy"] {
        let bad = format!("{flag}=-1");
        let r = common::run(&["render", s.to_str().unwrap(), "-o", out.to_str().unwrap(), &bad], LIMIT);
        assert_eq!(r.code, Some(2), "{flag}: {}", r.stderr);
        assert!(r.stderr.contains(flag), "{flag}: {}", r.stderr);
    }
}
