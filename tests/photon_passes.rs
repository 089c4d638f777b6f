//! Light passes and light groups in Jensen's photon mapping (`src/integrator/photon/`,
//! `map_read.rs`) and SPPM (`sppm_passes.rs`): they sum to Combined pixel by pixel whatever the gather settings, and each
//! pass and group agrees with the path tracer's, region by region.
//!
//! Bounds of the agreement (`common::agreement`): K seeds per estimate, Welch's test per
//! region, Šidák's split over every comparison of the test. Photon mapping is consistent,
//! not unbiased: its kernel blurs the map-read light by at most the search radius, set to
//! 0.02 on a scene 4 units across, as in `tests/linking_integrators.rs`: the blur's loss at
//! the floor's and wall's edges is a fraction of about r / side = 0.5 % of a region's
//! indirect light, a tenth of the regions' noise bound (about 2 %); the k-NN estimate's
//! low bias (up to 1/k where the density is uniform, `estimate.rs`) does not arise since
//! 100 000 photons over the ~30 m² of the scene put about 0.04 photons in a disc of radius
//! 0.02 on average, so the fixed-radius estimate, unbiased for any point set, is used.

mod common;

use common::agreement::{disagreeing, regions, sidak};
use common::pass_checks::{
    CONTRIBUTIONS, LIGHT, channels, contribution, opaque_copy, pass_region_means, with_light_groups,
    worst_recombination,
};
use common::{GltfBuilder, run, temp_dir};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);
const RES: (usize, usize) = (32, 32);

/// The light passes and the groups of every emitter sum to Combined in Jensen's renders,
/// with the map read at the first hit (no gather), one gather bounce with extra gather
/// rays, and two diffuse bounces before the map: glass and caustics, an emitter seen
/// directly, subsurface, a medium, the world.
#[test]
fn jensen_passes_and_groups_sum_to_combined() {
    let dir = temp_dir();
    let groups = [
        ("glass_caustic", None),
        ("cornell_box", Some(json!({"names": ["ceiling"], "objects": {"light": "ceiling"}}))),
        ("subsurface", Some(json!({"names": ["key", "sky"], "world": "sky", "objects": {"area_light": "key"}}))),
        ("hdri_sky", None),
    ];
    let gathers: [&[&str]; 3] =
        [&["--diffuse-bounces", "0"], &["--diffuse-bounces", "1", "--gather-rays", "3"], &["--diffuse-bounces", "2"]];
    for (name, spec) in groups {
        let scene = opaque_copy(name, dir.path());
        let names: Vec<String> = spec
            .as_ref()
            .map(|s| s["names"].as_array().unwrap().iter().map(|n| n.as_str().unwrap().into()).collect())
            .unwrap_or_default();
        let mut tokens = LIGHT.to_string();
        if let Some(s) = spec {
            with_light_groups(&scene, s);
            tokens.push_str(",light_groups");
        }
        for gather in gathers {
            let out = dir.path().join(format!("{name}.exr"));
            let mut args = vec![
                "render",
                scene.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
                "--progress",
                "json",
                "--integrator",
                "photon",
                "--photons",
                "20000",
                "--caustic-photons",
                "20000",
                "--spp",
                "4",
                "--resolution",
                "40x30",
                "--passes",
                &tokens,
            ];
            args.extend_from_slice(gather);
            let r = run(&args, LIMIT);
            assert_eq!(r.code, Some(0), "{name}: {}", r.stderr);
            let ch = channels(&out);
            let label = format!("{name} {gather:?}");
            let parts: Vec<[Vec<f64>; 3]> =
                CONTRIBUTIONS.iter().map(|p| [0, 1, 2].map(|c| contribution(&ch, p, c))).collect();
            let worst = worst_recombination(&ch, &parts);
            assert!(worst <= 1.0, "{label}: the light passes differ from Combined by {worst} × the rounding bound");
            if !names.is_empty() {
                let parts: Vec<[Vec<f64>; 3]> =
                    names.iter().map(|g| [0, 1, 2].map(|c| contribution(&ch, &format!("Combined_{g}"), c))).collect();
                for (g, p) in names.iter().zip(&parts) {
                    assert!(p.iter().flatten().sum::<f64>() > 0.0, "{label}: group {g} is empty");
                }
                let worst = worst_recombination(&ch, &parts);
                assert!(worst <= 1.0, "{label}: the light groups differ from Combined by {worst} × the rounding bound");
            }
        }
    }
}

/// A floor (rough dielectric: its map reads carry glossy light too), a back wall, a rough
/// metal panel (glossy: followed by sampling, casting a caustic), an area light ("key"), an
/// emissive quad seen directly and the world seen above the wall (both "fill").
fn scene(dir: &Path) -> PathBuf {
    let mut g = GltfBuilder::new();
    let floor_mat = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.55, 0.5, 1],
        "metallicFactor": 0.0, "roughnessFactor": 0.8}, "doubleSided": true}));
    let wall_mat = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.6, 0.7, 1],
        "metallicFactor": 0.0, "roughnessFactor": 1.0}, "doubleSided": true}));
    let metal = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.8, 0.6, 1],
        "metallicFactor": 1.0, "roughnessFactor": 0.3}, "doubleSided": true}));
    let quad = |g: &mut GltfBuilder, p: [[f32; 3]; 4], m: usize| g.mesh(&p, &[0, 1, 2, 0, 2, 3], m);
    quad(&mut g, [[-2.0, -1.0, -2.0], [2.0, -1.0, -2.0], [2.0, -1.0, -6.0], [-2.0, -1.0, -6.0]], floor_mat);
    quad(&mut g, [[-2.0, -1.0, -6.0], [2.0, -1.0, -6.0], [2.0, 2.0, -6.0], [-2.0, 2.0, -6.0]], wall_mat);
    // Leaning back on the right, facing the camera and the light.
    quad(&mut g, [[0.4, -1.0, -4.2], [1.6, -1.0, -4.8], [1.6, 0.2, -5.2], [0.4, 0.2, -4.6]], metal);
    g.use_ext("CAUSTIC_lights_area");
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let key = g.node(json!({"translation": [-0.5, 1.8, -3.5], "rotation": [-h, 0.0, 0.0, h],
        "extensions": {"CAUSTIC_lights_area": {"shape": "square", "size": [1.0, 1.0], "power": 80.0}}}));
    g.node_name(key, "Key");
    g.use_ext("KHR_materials_emissive_strength");
    let glow = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]},
        "emissiveFactor": [1.0, 0.9, 0.8], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}}));
    let (x, z0, z1) = (-1.9, -4.8, -3.6);
    let glow = g.mesh(&[[x, -0.9, z0], [x, -0.9, z1], [x, 0.1, z1], [x, 0.1, z0]], &[0, 2, 1, 0, 3, 2], glow);
    g.node_name(glow, "Glow");
    g.world(json!({"color": [0.3, 0.35, 0.45]}));
    g.camera([0.0, 0.3, 0.0], [0.0, 0.0, 0.0, 1.0], 0.9);
    g.settings(json!({"transparent": false, "light_groups": {"names": ["key", "fill"], "world": "fill",
        "objects": {"Key": "key", "Glow": "fill"}}}));
    g.write(dir, "passes.gltf")
}

/// Each light pass and light group of Jensen's photon mapping agrees with the path tracer's.
#[test]
fn jensen_passes_and_groups_match_the_path_tracer() {
    passes_match_the_path_tracer(
        "Jensen",
        &["--integrator", "photon", "--spp", "16", "--photons", "100000", "--max-radius", "0.02"],
    );
}

/// SPPM's light passes and the groups of every emitter sum to Combined: glass and caustics,
/// an emitter seen directly, subsurface, the world (the camera pass's split and τ's, which
/// take the same radius-reduction ratio).
#[test]
fn sppm_passes_and_groups_sum_to_combined() {
    let dir = temp_dir();
    let groups = [
        ("glass_caustic", None),
        ("cornell_box", Some(json!({"names": ["ceiling"], "objects": {"light": "ceiling"}}))),
        ("subsurface", Some(json!({"names": ["key", "sky"], "world": "sky", "objects": {"area_light": "key"}}))),
        ("hdri_sky", None),
    ];
    for (name, spec) in groups {
        let scene = opaque_copy(name, dir.path());
        let names: Vec<String> = spec
            .as_ref()
            .map(|s| s["names"].as_array().unwrap().iter().map(|n| n.as_str().unwrap().into()).collect())
            .unwrap_or_default();
        let mut tokens = LIGHT.to_string();
        if let Some(s) = spec {
            with_light_groups(&scene, s);
            tokens.push_str(",light_groups");
        }
        let out = dir.path().join(format!("{name}.exr"));
        let args = [
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--integrator",
            "sppm",
            "--sppm-iterations",
            "4",
            "--resolution",
            "40x30",
            "--passes",
            &tokens,
        ];
        let r = run(&args, LIMIT);
        assert_eq!(r.code, Some(0), "{name}: {}", r.stderr);
        let ch = channels(&out);
        let parts: Vec<[Vec<f64>; 3]> =
            CONTRIBUTIONS.iter().map(|p| [0, 1, 2].map(|c| contribution(&ch, p, c))).collect();
        let worst = worst_recombination(&ch, &parts);
        assert!(worst <= 1.0, "{name}: the light passes differ from Combined by {worst} × the rounding bound");
        if !names.is_empty() {
            let parts: Vec<[Vec<f64>; 3]> =
                names.iter().map(|g| [0, 1, 2].map(|c| contribution(&ch, &format!("Combined_{g}"), c))).collect();
            for (g, p) in names.iter().zip(&parts) {
                assert!(p.iter().flatten().sum::<f64>() > 0.0, "{name}: group {g} is empty");
            }
            let worst = worst_recombination(&ch, &parts);
            assert!(worst <= 1.0, "{name}: the light groups differ from Combined by {worst} × the rounding bound");
        }
    }
}

/// Each light pass and light group of SPPM agrees with the path tracer's, with the same
/// bounds as Jensen's: the radius starts at 0.02 (`--sppm-radius`) and only shrinks, so the
/// kernel's blur is at most the one bounded in the module doc.
#[test]
fn sppm_passes_and_groups_match_the_path_tracer() {
    passes_match_the_path_tracer(
        "SPPM",
        &["--integrator", "sppm", "--sppm-iterations", "32", "--sppm-photons", "20000", "--sppm-radius", "0.02"],
    );
}

/// SPPM's data passes and Cryptomatte (`sppm_extras.rs`) are the path tracer's bit for bit
/// with the same seed and as many iterations as samples: both take each sample's camera ray
/// from the same sampler dimensions and the passes depend on that ray alone.
#[test]
fn sppm_data_passes_equal_the_path_tracers() {
    let dir = temp_dir();
    let scene = opaque_copy("cornell_box", dir.path());
    let tokens =
        "mist,position,uv,object_index,material_index,ambient_occlusion,cryptomatte_object,cryptomatte_material";
    let render = |integrator: &str, out: &Path| {
        let args = [
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--resolution",
            "24x18",
            "--integrator",
            integrator,
            "--spp",
            "3",
            "--sppm-iterations",
            "3",
            "--seed",
            "5",
            "--passes",
            tokens,
        ];
        let r = run(&args, LIMIT);
        assert_eq!(r.code, Some(0), "{integrator}: {}", r.stderr);
        channels(out)
    };
    let path = render("path", &dir.path().join("path.exr"));
    let sppm = render("sppm", &dir.path().join("sppm.exr"));
    let data: Vec<&String> = path.keys().filter(|k| !k.starts_with("Combined") && !k.starts_with("Depth")).collect();
    let has = |p: &str| data.iter().any(|k| k.starts_with(p));
    assert!(has("CryptoObject") && has("Ambient Occlusion") && has("Mist"), "{data:?}");
    for name in data {
        let (a, b) = (&path[name], &sppm[name]);
        assert!(a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()), "{name} differs");
        // The box has no UV map, pass indices 0 and at most two ids per pixel (ranks 2 and on
        // empty): those are zero in both; the rest hold values.
        let nonzero = ["Ambient Occlusion", "Mist", "Position", "CryptoObject00"].iter().any(|p| name.starts_with(p));
        assert!(!nonzero || a.iter().any(|v| *v != 0.0), "{name} is empty");
    }
}

/// A photon-map file keeps no photon's light group: the light groups with `--photon-map` are
/// refused (exit 2), naming the file; the light passes, which need no group, render from it.
#[test]
fn light_groups_need_traced_maps() {
    let dir = temp_dir();
    let scene = opaque_copy("cornell_box", dir.path());
    with_light_groups(&scene, json!({"names": ["ceiling"], "objects": {"light": "ceiling"}}));
    let map = dir.path().join("box.photons");
    let (s, m) = (scene.to_str().unwrap(), map.to_str().unwrap());
    let r = run(&["photons", s, "-o", m, "--photons", "2000", "--caustic-photons", "2000"], LIMIT);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let out = dir.path().join("o.exr");
    let o = out.to_str().unwrap();
    let base = ["render", s, "-o", o, "--integrator", "photon", "--photon-map", m, "--resolution", "8x6", "--spp", "1"];
    let r = run(&[&base[..], &["--passes", "light_groups"]].concat(), LIMIT);
    assert_eq!(r.code, Some(2), "{}", r.stderr);
    assert!(r.stderr.contains("light group") && r.stderr.contains("box.photons"), "{}", r.stderr);
    let r = run(&[&base[..], &["--passes", LIGHT]].concat(), LIMIT);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
}

/// SPPM's chunks carry its light passes, light groups, data passes and Cryptomatte
/// (`sppm_passes::into_film`, `sppm_extras.rs`). Each chunk is a whole SPPM run, so the
/// merge of chunks of 2 and 3 iterations is not one run of 5: the passes SPPM reduces per
/// pixel (Combined, light passes, groups) are the chunks' mean weighted by iterations, as
/// Combined is, and still sum to the merged Combined; the data passes and Cryptomatte,
/// which depend on the sample indices alone, are a single render's of iterations 0..5 bit
/// for bit. A chunk merged alone gives back its own image.
#[test]
fn sppm_chunks_merge_passes_by_iterations() {
    let dir = temp_dir();
    let scene = opaque_copy("cornell_box", dir.path());
    with_light_groups(&scene, json!({"names": ["ceiling"], "objects": {"light": "ceiling"}}));
    let tokens = format!("{LIGHT},light_groups,mist,position,object_index,cryptomatte_object");
    let p = |n: &str| dir.path().join(n);
    let render = |out: &Path, extra: &[&str]| {
        let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--resolution", "24x18"];
        args.extend_from_slice(&["--integrator", "sppm", "--sppm-photons", "4000", "--seed", "5", "--passes", &tokens]);
        args.extend_from_slice(extra);
        let r = run(&args, LIMIT);
        assert_eq!(r.code, Some(0), "{extra:?}: {}", r.stderr);
        channels(out)
    };
    let merge = |inputs: &[&Path], out: &Path| {
        let mut args = vec!["merge"];
        args.extend(inputs.iter().map(|p| p.to_str().unwrap()));
        args.extend_from_slice(&["-o", out.to_str().unwrap()]);
        let r = run(&args, LIMIT);
        assert_eq!(r.code, Some(0), "{}", r.stderr);
        channels(out)
    };
    let single = render(&p("single.exr"), &["--sppm-iterations", "5"]);
    let a = render(&p("a.exr"), &["--sppm-iterations", "2", "--chunk"]);
    let b = render(&p("b.exr"), &["--sppm-iterations", "3", "--sample-offset", "2", "--chunk"]);
    let m = merge(&[&p("b.exr"), &p("a.exr")], &p("m.exr"));
    let bits_equal = |x: &[f32], y: &[f32]| x.iter().zip(y).all(|(u, v)| u.to_bits() == v.to_bits());
    let divided = |name: &str| {
        name.contains(" Direct.") && !name.starts_with("Volume")
            || name.contains(" Indirect.") && !name.starts_with("Volume")
    };
    let data = ["Mist.", "Position.", "Object Index.", "CryptoObject"];
    let is_data = |name: &str| data.iter().any(|d| name.starts_with(d));
    let mut seen = (0, 0, 0);
    for (name, v) in m.iter().filter(|(n, _)| !n.starts_with("CausticSum") && !n.starts_with("Debug")) {
        if is_data(name) {
            assert!(bits_equal(v, &single[name]), "{name}: not the single render's");
            seen.0 += 1;
        } else if !divided(name) && name != "Depth.Z" {
            // The chunks' sums are their f32 means times their iterations, exact
            // (`chunk::mean_times`); the merged mean (2a + 3b) / 5 is rounded once to f32:
            // half an ulp, 2^-24 relative (2^-23 allowed); a sum's part below 2^-64 is cut
            // (`src/fixed.rs`), 1e-18 absolute covers it.
            for (i, got) in v.iter().enumerate() {
                let want = (2.0 * a[name][i] as f64 + 3.0 * b[name][i] as f64) / 5.0;
                assert!((*got as f64 - want).abs() <= want.abs() * 2f64.powi(-23) + 1e-18, "{name} pixel {i}");
            }
            seen.1 += 1;
        } else if divided(name) {
            seen.2 += 1;
        }
    }
    assert!(seen.0 >= 6 && seen.1 >= 20 && seen.2 >= 18, "channels compared (data, means, divided): {seen:?}");
    assert!(m["Combined_ceiling.R"].iter().any(|v| *v > 0.0) && m["Emission.R"].iter().any(|v| *v > 0.0));
    // Direct and Indirect are divided by the merged Colour from the merged sums: the passes
    // still sum to Combined (tolerance derived in `worst_recombination`).
    let parts: Vec<[Vec<f64>; 3]> = CONTRIBUTIONS.iter().map(|n| [0, 1, 2].map(|c| contribution(&m, n, c))).collect();
    let worst = worst_recombination(&m, &parts);
    assert!(worst <= 1.0, "the merged light passes differ from Combined by {worst} × the rounding bound");
    let parts: Vec<[Vec<f64>; 3]> = [[0, 1, 2].map(|c| contribution(&m, "Combined_ceiling", c))].into();
    let worst = worst_recombination(&m, &parts);
    assert!(worst <= 1.0, "the merged light group differs from Combined by {worst} × the rounding bound");
    // A lone chunk: its sums read back are its image (Direct and Indirect divided again from
    // the sums, f32(d·n) / f32(c·n) against d / c: up to four roundings of 2^-24, 2^-21 allowed).
    let alone = merge(&[&p("a.exr")], &p("alone.exr"));
    for (name, v) in alone.iter().filter(|(n, _)| !n.starts_with("CausticSum")) {
        if divided(name) {
            let close = v.iter().zip(&a[name]).all(|(x, y)| (x - y).abs() as f64 <= y.abs() as f64 * 2f64.powi(-21));
            assert!(close, "{name}: the lone chunk's merge is not its image");
        } else {
            assert!(bits_equal(v, &a[name]), "{name}: the lone chunk's merge is not its image");
        }
    }
}

/// Each light pass and group of `integrator` rendered with `flags` agrees, region by region,
/// with the path tracer's on the passes scene.
fn passes_match_the_path_tracer(integrator: &str, flags: &[&str]) {
    let dir = temp_dir();
    let path = scene(dir.path());
    let regs = regions(RES.0, RES.1);
    let r = format!("{}x{}", RES.0, RES.1);
    let tokens = format!("{LIGHT},light_groups");
    let common = ["--resolution", r.as_str(), "--max-depth", "4", "--passes", tokens.as_str()];
    let passes: Vec<String> = ["Diffuse Direct", "Diffuse Indirect", "Glossy Direct", "Glossy Indirect", "Emission"]
        .into_iter()
        .chain(["Environment", "Combined_key", "Combined_fill"])
        .map(String::from)
        .collect();
    let seeds = 6;
    let means = |extra: &[&str]| {
        let mut a = common.to_vec();
        a.extend_from_slice(extra);
        pass_region_means(&path, dir.path(), &a, seeds, &regs, &passes, LIMIT)
    };
    let reference = means(&["--integrator", "path", "--spp", "64"]);
    let other = means(flags);
    let alpha = sidak(regs.len() * passes.len());
    let mut failed = Vec::new();
    for (p, name) in passes.iter().enumerate() {
        let total: f64 = reference[p][0].iter().sum();
        assert!(total > 0.0, "the scene puts no light in {name}");
        failed.extend(
            disagreeing(name, &regs, &other[p], &reference[p], alpha).into_iter().map(|r| format!("{name} {r}")),
        );
    }
    assert!(failed.is_empty(), "{integrator}'s passes disagree with the path tracer's: {failed:?}");
}
