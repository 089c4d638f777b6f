//! The shadow catcher (`CAUSTIC_object_visibility.shadow_catcher`, Blender's Shadow
//! Catcher) in a scene whose answer is known without rendering: a white floor that
//! catches shadows under a sun shining straight down, and a quad above it that the camera
//! does not see but that casts its shadow on the floor.
//!
//! Camera at the origin looking down -Z (half-height tan(0.25) = 0.2553 per unit of depth
//! over 16 px); floor at z = -4; the quad (half-width 0.3) at z = -2 shadows the floor to
//! ±4.7 px about the centre. Direct light only (max depth 1) from a delta sun: the floor's
//! value on the split path and on the catcher pass is the same computation, so the factor
//! is exactly 0 in the shadow and 1 outside it (up to the film's fixed-point rounding,
//! far below the 1e-5 allowed).

mod common;

use common::{GltfBuilder, render_image, temp_dir};
use serde_json::json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);
const W: usize = 32;
const TOL: f32 = 1e-5;

fn quad(g: &mut GltfBuilder, z: f32, h: f32, material: usize) -> usize {
    let p = [[-h, -h, z], [h, -h, z], [h, h, z], [-h, h, z]];
    g.mesh(&p, &[0, 1, 2, 0, 2, 3], material)
}

/// The scene; `world`: a constant world colour (none: no world); `transparent`: the film.
fn scene(dir: &Path, name: &str, world: Option<f32>, transparent: bool) -> PathBuf {
    let mut g = GltfBuilder::new();
    let white =
        g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0}}));
    let floor = quad(&mut g, -4.0, 10.0, white);
    g.node_ext(floor, "CAUSTIC_object_visibility", json!({"shadow_catcher": true}));
    let occluder = quad(&mut g, -2.0, 0.3, white);
    g.node_ext(occluder, "CAUSTIC_object_visibility", json!({"camera": false}));
    g.punctual(json!({"type": "directional", "intensity": 683.0}), [0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0]);
    g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.5);
    if let Some(w) = world {
        g.world(json!({"color": [w, w, w]}));
    }
    g.settings(json!({"transparent": transparent}));
    g.write(dir, name)
}

fn args<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    let mut a =
        vec!["--resolution", "32x32", "--spp", "8", "--filter", "box", "--filter-width", "1", "--max-depth", "1"];
    a.extend_from_slice(extra);
    a
}

/// Pixel indices wholly in the shadow (centre within 3.5 px) or wholly lit (6.5 to 15 px).
fn shadowed(i: usize) -> bool {
    ((i % W) as f32 - 15.5).abs().max(((i / W) as f32 - 15.5).abs()) < 3.5
}
fn lit(i: usize) -> bool {
    (6.5..15.0).contains(&((i % W) as f32 - 15.5).abs().max(((i / W) as f32 - 15.5).abs()))
}

fn channels(path: &Path) -> BTreeMap<String, Vec<f32>> {
    let image = exr::prelude::read_all_flat_layers_from_file(path).expect("read EXR");
    let layer = &image.layer_data[0];
    layer.channel_data.list.iter().map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect())).collect()
}

/// Film → Transparent without the Shadow Catcher pass (Cycles' approximate catcher): the
/// floor itself is gone (colour 0) and its alpha is the shadow: 1 in the shadow, 0 where lit.
#[test]
fn transparent_combined_alpha_holds_the_shadow() {
    let dir = temp_dir();
    let d = dir.path();
    let px = render_image(&scene(d, "a.gltf", None, true), &d.join("a.exr"), &args(&[]), LIMIT);
    for (i, p) in px.iter().enumerate() {
        if shadowed(i) {
            assert!((p[3] - 1.0).abs() < TOL && p[0] == 0.0, "pixel {i} in the shadow: {p:?}");
        }
        if lit(i) {
            assert!(p[3].abs() < TOL && p[0] == 0.0, "pixel {i} lit: {p:?}");
        }
    }
}

/// With the Shadow Catcher pass asked: the pass is the factor (0 in the shadow, 1 lit) and
/// Combined is the matte, empty over the floor.
#[test]
fn shadow_catcher_pass_is_the_factor() {
    catcher_pass_is_the_factor(&[]);
}

/// Jensen's photon mapping splits its camera paths as the path tracer does: at max depth 1
/// its Combined on the floor is the same next-event estimate and its catcher pass is path
/// traced, so the factor is as exact.
#[test]
fn jensen_catcher_pass_is_the_factor() {
    catcher_pass_is_the_factor(&["--integrator", "photon", "--photons", "20000"]);
}

/// SPPM at max depth 1 gathers no photons (their first hits are direct light, which NEE
/// gives): the split path and the catcher pass compute the floor's direct light alike.
#[test]
fn sppm_catcher_pass_is_the_factor() {
    catcher_pass_is_the_factor(&["--integrator", "sppm", "--sppm-iterations", "8"]);
}

/// SPPM's chunks carry the catcher's sums as means times their iterations (as Combined):
/// two chunks merged keep the exact factor of the single render at max depth 1.
#[test]
fn sppm_chunks_merge_the_catcher() {
    let dir = temp_dir();
    let d = dir.path();
    let s = scene(d, "k.gltf", None, true);
    let chunk = |out: &Path, offset: &str, iterations: &str| {
        let mut a = vec!["render", s.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"];
        a.extend_from_slice(&["--integrator", "sppm", "--sppm-iterations", iterations, "--sample-offset", offset]);
        a.extend(args(&["--passes", "shadow_catcher", "--chunk"]));
        let r = common::run(&a, LIMIT);
        assert_eq!(r.code, Some(0), "{}", r.stderr);
    };
    let (a, b, merged) = (d.join("a.exr"), d.join("b.exr"), d.join("merged.exr"));
    chunk(&a, "0", "2");
    chunk(&b, "2", "6");
    let r = common::run(
        &["merge", a.to_str().unwrap(), b.to_str().unwrap(), "-o", merged.to_str().unwrap(), "--progress", "json"],
        LIMIT,
    );
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let ch = channels(&merged);
    let (sc, alpha) = (&ch["Shadow Catcher.G"], &ch["Combined.A"]);
    for i in 0..W * W {
        assert!(alpha[i] == 0.0, "pixel {i}: the matte over the floor is empty");
        if shadowed(i) {
            assert!(sc[i].abs() < TOL, "pixel {i} in the shadow: factor {}", sc[i]);
        }
        if lit(i) {
            assert!((sc[i] - 1.0).abs() < TOL, "pixel {i} lit: factor {}", sc[i]);
        }
    }
}

fn catcher_pass_is_the_factor(integrator: &[&str]) {
    let dir = temp_dir();
    let d = dir.path();
    let out = d.join("b.exr");
    let pass_args = args(&[&["--passes", "shadow_catcher"], integrator].concat());
    render_image(&scene(d, "b.gltf", None, true), &out, &pass_args, LIMIT);
    let ch = channels(&out);
    let (sc, alpha) = (&ch["Shadow Catcher.R"], &ch["Combined.A"]);
    assert!(ch.contains_key("Shadow Catcher.B") && !ch.contains_key("Shadow Catcher.A"));
    for i in 0..W * W {
        assert!(alpha[i] == 0.0 && ch["Combined.G"][i] == 0.0, "pixel {i}: the matte over the floor is empty");
        if shadowed(i) {
            assert!(sc[i].abs() < TOL, "pixel {i} in the shadow: factor {}", sc[i]);
        }
        if lit(i) {
            assert!((sc[i] - 1.0).abs() < TOL, "pixel {i} lit: factor {}", sc[i]);
        }
    }
    // Without catchers the pass is 1 everywhere and Combined is the ordinary image.
    let plain =
        std::fs::read_to_string(d.join("b.gltf")).unwrap().replace("\"shadow_catcher\": true", "\"shadow\": true");
    std::fs::write(d.join("c.gltf"), plain).unwrap();
    let out = d.join("c.exr");
    render_image(&d.join("c.gltf"), &out, &pass_args, LIMIT);
    let ch = channels(&out);
    assert!(ch["Shadow Catcher.G"].iter().all(|v| *v == 1.0));
    assert!((0..W * W).filter(|&i| lit(i)).all(|i| ch["Combined.A"][i] == 1.0 && ch["Combined.R"][i] > 0.1));
}

/// An opaque film composites the matte over the world behind the catcher (Cycles'
/// approximate catcher with its background pass): over the floor the image is the world's
/// colour times the mean Shadow Catcher factor (at most 1), which a render with the pass asked gives
/// for the same samples (the pass changes no sample), so the two agree to rounding. The
/// world also lights the floor, so the factor is no longer exactly 0 or 1.
#[test]
fn opaque_film_shows_the_world_darkened_by_the_shadow() {
    let dir = temp_dir();
    let d = dir.path();
    let s = scene(d, "o.gltf", Some(0.01), false);
    let px = render_image(&s, &d.join("o.exr"), &args(&[]), LIMIT);
    let out = d.join("f.exr");
    render_image(&s, &out, &args(&["--passes", "shadow_catcher"]), LIMIT);
    let ch = channels(&out);
    for (i, p) in px.iter().enumerate().filter(|(i, _)| shadowed(*i) || lit(*i)) {
        let mean = (ch["Shadow Catcher.R"][i] + ch["Shadow Catcher.G"][i] + ch["Shadow Catcher.B"][i]) / 3.0;
        // Cycles clamps the mean factor to [0, 1] in the alpha.
        assert!(p[3] == 1.0 && (p[1] - 0.01 * mean.clamp(0.0, 1.0)).abs() < 1e-6, "pixel {i}: {p:?}, factor {mean}");
        assert!(if shadowed(i) { mean < 0.2 } else { mean > 0.5 }, "pixel {i}: factor {mean}");
    }
}

/// Chunks of a scene with a catcher carry the catcher's sums: two chunks merged give the
/// single render's Combined and Shadow Catcher pass bit for bit; every other integrator takes
/// the Shadow Catcher pass (each splits camera paths; their agreement is tested in this file
/// and `shadow_catcher_integrators.rs`).
#[test]
fn chunks_merge_exactly_and_every_integrator_splits() {
    let dir = temp_dir();
    let d = dir.path();
    let s = scene(d, "w.gltf", None, true);
    let out = d.join("w.exr");
    let render = |out: &Path, extra: &[&str]| {
        let mut a = vec!["render", s.to_str().unwrap(), "-o", out.to_str().unwrap(), "--passes", "shadow_catcher"];
        a.extend_from_slice(&["--resolution", "16x12", "--progress", "json"]);
        a.extend_from_slice(extra);
        let r = common::run(&a, LIMIT);
        assert_eq!(r.code, Some(0), "{extra:?}: {}", r.stderr);
    };
    render(&d.join("single.exr"), &["--spp", "6"]);
    render(&d.join("a.exr"), &["--spp", "2", "--chunk"]);
    render(&d.join("b.exr"), &["--spp", "4", "--sample-offset", "2", "--chunk"]);
    let merged = d.join("merged.exr");
    let (a, b) = (d.join("a.exr"), d.join("b.exr"));
    let r = common::run(
        &["merge", b.to_str().unwrap(), a.to_str().unwrap(), "-o", merged.to_str().unwrap(), "--progress", "json"],
        LIMIT,
    );
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let (single, merged) = (common::exr_channel_bits(&d.join("single.exr")), common::exr_channel_bits(&merged));
    assert_eq!(single.iter().map(|c| &c.0).collect::<Vec<_>>(), merged.iter().map(|c| &c.0).collect::<Vec<_>>());
    assert!(single.iter().any(|c| c.0.starts_with("Shadow Catcher")));
    for ((name, x), (_, y)) in single.iter().zip(&merged) {
        assert_eq!(x, y, "{name} differs between the single render and the merged chunks");
    }
    let others: [&[&str]; 4] = [
        &["--integrator", "bdpt", "--spp", "1"],
        &["--integrator", "vcm", "--spp", "1"],
        &["--integrator", "photon", "--photons", "1000", "--spp", "1"],
        &["--integrator", "sppm", "--sppm-iterations", "1", "--sppm-photons", "1000"],
    ];
    for flags in others {
        let mut a = vec!["render", s.to_str().unwrap(), "-o", out.to_str().unwrap(), "--passes", "shadow_catcher"];
        a.extend_from_slice(&["--resolution", "16x12", "--progress", "json"]);
        a.extend_from_slice(flags);
        let r = common::run(&a, LIMIT);
        assert_eq!(r.code, Some(0), "{flags:?}: {}", r.stderr);
        assert!(common::exr_channel_bits(&out).iter().any(|c| c.0.starts_with("Shadow Catcher")), "{flags:?}");
    }
}

/// With indirect light (max depth 3) Jensen's Shadow Catcher pass converges to the path
/// tracer's: under the occluder it is the light bounced between the floor and the occluder
/// (from the photon maps in Jensen) over the floor lit alone (the catcher pass, path traced),
/// around it about 1. Each estimate is the mean of K seeds per region (the shadow, the lit
/// ring), compared by Welch's test with Šidák's split (`common::agreement`). Jensen's
/// kernel blurs the indirect light by at most its radius, 0.02: its loss at the shadow's
/// edge (0.6 units wide) is about r / 0.6 = 3 % of the indirect light in the outermost
/// pixels, under 1 % of the shadow region's mean, below its noise bound.
#[test]
fn jensen_catcher_pass_converges_to_the_path_tracer() {
    converges_to_the_path_tracer(
        "Jensen",
        &["--integrator", "photon", "--spp", "256", "--photons", "1000000", "--max-radius", "0.02"],
    );
}

/// SPPM's pass as Jensen's (above), its matte keeping the photon flux of the paths that did
/// not split (`sppm_catcher`). The radius is fixed at 0.02 for every pixel (as Jensen's
/// largest) and shrinks from there, so the same blur bound holds.
#[test]
fn sppm_catcher_pass_converges_to_the_path_tracer() {
    converges_to_the_path_tracer(
        "SPPM",
        &["--integrator", "sppm", "--sppm-iterations", "256", "--sppm-photons", "100000", "--sppm-radius", "0.02"],
    );
}

/// SPPM's matte holds the photon flux of the paths that did not split: with the occluder the
/// catcher (seen by the camera) and the floor ordinary, floor pixels beyond the occluder's
/// image (9.4 px from the centre, the box filter reaching 0.5 px more) never split, so with
/// the pass asked their Combined (the matte) is the render without catchers bit for bit (the
/// same photons, sampler streams and sums). At max depth 3 that holds indirect light (the
/// floor lit again by the occluder's underside), which max depth 1 lacks: τ is in play.
#[test]
fn sppm_matte_keeps_the_flux_of_paths_that_did_not_split() {
    let dir = temp_dir();
    let d = dir.path();
    let write = |name: &str, catcher: bool| {
        let mut g = GltfBuilder::new();
        let white =
            g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0}}));
        quad(&mut g, -4.0, 10.0, white);
        let occluder = quad(&mut g, -2.0, 0.3, white);
        if catcher {
            g.node_ext(occluder, "CAUSTIC_object_visibility", json!({"shadow_catcher": true}));
        }
        g.punctual(json!({"type": "directional", "intensity": 683.0}), [0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0]);
        g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.5);
        g.settings(json!({"transparent": true}));
        g.write(d, name)
    };
    let (with, without) = (write("m.gltf", true), write("n.gltf", false));
    fn sppm<'a>(depth: &'a str, passes: &[&'a str]) -> Vec<&'a str> {
        let mut a = vec!["--integrator", "sppm", "--sppm-iterations", "16", "--sppm-photons", "200000"];
        a.extend_from_slice(&["--resolution", "32x32", "--filter", "box", "--filter-width", "1", "--max-depth", depth]);
        a.extend_from_slice(passes);
        a
    }
    let caught = render_image(&with, &d.join("m.exr"), &sppm("3", &["--passes", "shadow_catcher"]), LIMIT);
    let plain = render_image(&without, &d.join("n.exr"), &sppm("3", &[]), LIMIT);
    let direct = render_image(&without, &d.join("o.exr"), &sppm("1", &[]), LIMIT);
    let beyond = |i: usize| ((i % W) as f32 - 15.5).abs().max(((i / W) as f32 - 15.5).abs()) > 10.5;
    let mut indirect = 0.0;
    for i in (0..W * W).filter(|&i| beyond(i)) {
        assert_eq!(caught[i], plain[i], "pixel {i}: the matte of a path that never split");
        indirect += plain[i][1] - direct[i][1];
    }
    assert!(indirect > 0.0, "no indirect light beyond the occluder: {indirect}");
}

/// Runs the comparison of `name`'s Shadow Catcher pass (rendered with `extra`) with the path
/// tracer's (module doc of the tests above).
fn converges_to_the_path_tracer(name: &str, extra: &[&str]) {
    use common::agreement::{agree, sidak};
    let dir = temp_dir();
    let d = dir.path();
    let s = scene(d, "i.gltf", None, true);
    let seeds = 8u32;
    // Per region: the per-seed means of the pass.
    let means = |extra: &[&str]| {
        let mut m = vec![Vec::new(); 2];
        for seed in 0..seeds {
            let out = d.join("i.exr");
            let sd = (seed * 7919 + 13).to_string();
            let a =
                [&["--resolution", "32x32", "--max-depth", "3", "--passes", "shadow_catcher", "--seed", &sd], extra]
                    .concat();
            render_image(&s, &out, &a, LIMIT);
            let ch = channels(&out);
            for (r, region) in [shadowed as fn(usize) -> bool, lit].iter().enumerate() {
                let idx: Vec<usize> = (0..W * W).filter(|&i| region(i)).collect();
                let v = idx.iter().map(|&i| ["R", "G", "B"].map(|c| ch[&format!("Shadow Catcher.{c}")][i] as f64));
                m[r].push(v.map(|c| (c[0] + c[1] + c[2]) / 3.0).sum::<f64>() / idx.len() as f64);
            }
        }
        m
    };
    let reference = means(&["--spp", "1024"]);
    let tested = means(extra);
    let alpha = sidak(2);
    for (k, region) in ["shadow", "lit ring"].iter().enumerate() {
        assert!(agree(region, &tested[k], &reference[k], alpha), "{region}: {name} disagrees with the path tracer");
    }
    // The indirect light matters: the shadow's factor is not 0.
    let (m, _) = common::agreement::mean_var(&reference[0]);
    assert!(m > 0.005, "the shadow's factor {m}");
}
