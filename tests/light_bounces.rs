//! A light's and the world's Max Bounces (`max_bounces` in `CAUSTIC_lights_punctual`,
//! `CAUSTIC_lights_area` and `CAUSTIC_world`; `scene::light_bounces`), as Cycles renders it:
//! next-event estimation stops at a shading point past the limit, BSDF-sampled rays that find
//! the light keep their MIS weight.
//!
//! The scene (`common::visibility_cases`): a grey floor, a back wall and a grey quad hanging
//! over the floor, seen from the front, lit by a point light (or a 0.6-wide square area
//! light facing down) above the quad; it has indirect light (floor to wall to quad).

mod common;

use common::agreement::{Seeded, regions, sidak};
use common::visibility_cases::{Case, scene};
use common::{GltfBuilder, quick_render_warnings, render_image, temp_dir};
use serde_json::json;
use std::path::Path;
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);
const RES: (usize, usize) = (32, 32);

fn case(light: serde_json::Value, area: bool) -> Case {
    Case { name: "max bounces", light, blocker: json!({}), world: None, area }
}

fn render(scene: &Path, out: &Path, args: &[&str]) -> Vec<[f32; 4]> {
    let mut all = vec!["--resolution", "32x32", "--filter", "box", "--filter-width", "1"];
    all.extend_from_slice(args);
    render_image(scene, out, &all, LIMIT)
}

fn mean(px: &[[f32; 4]]) -> f64 {
    px.iter().map(|p| (p[0] + p[1] + p[2]) as f64).sum::<f64>() / (3 * px.len()) as f64
}

/// A point light is found by next-event estimation alone: with Max Bounces B it lights
/// exactly the paths of at most B + 1 scattering events, so the image at depth 8 is the
/// unlimited light's image at depth B + 1, pixel by pixel (the same samples: the estimates
/// past the limit add exact zeros). The unlimited light at depth 8 differs (its indirect
/// light is there), so the limit is what makes them equal.
#[test]
fn a_point_light_lights_paths_up_to_its_max_bounces() {
    let dir = temp_dir();
    let d = dir.path();
    let unlimited = scene(d, "u.gltf", &case(json!({}), false));
    let full = render(&unlimited, &d.join("full.exr"), &["--spp", "8", "--max-depth", "8"]);
    for b in [0u32, 1] {
        let bounded = scene(d, &format!("b{b}.gltf"), &case(json!({"max_bounces": b}), false));
        let limited = render(&bounded, &d.join(format!("b{b}.exr")), &["--spp", "8", "--max-depth", "8"]);
        let depth = (b + 1).to_string();
        let short = render(&unlimited, &d.join(format!("s{b}.exr")), &["--spp", "8", "--max-depth", &depth]);
        for (i, (p, q)) in limited.iter().zip(&short).enumerate() {
            for c in 0..3 {
                let tol = 1e-6 * p[c].abs().max(q[c].abs()).max(1e-6);
                assert!((p[c] - q[c]).abs() <= tol, "B = {b}, pixel {i} channel {c}: {} vs {}", p[c], q[c]);
            }
        }
        // Indirect light is a few per cent of this scene at least (measured 20 %).
        assert!(mean(&full) > 1.02 * mean(&limited), "B = {b}: {} vs {}", mean(&full), mean(&limited));
    }
}

/// An area light that BSDF-sampled rays find keeps, past its Max Bounces, the BSDF
/// strategy's MIS share of its light (Cycles' forward hits never read the limit): with Max
/// Bounces 0 the image lies strictly between the direct light alone (depth 1) and the
/// unlimited light's, each difference many standard errors of the 8-seed means. The light
/// is large (3 × 3) and close over a grey floor and back wall, so that BSDF sampling's share
/// of the wall's light from it is large.
#[test]
fn an_area_light_keeps_its_hits_past_its_max_bounces() {
    let dir = temp_dir();
    let d = dir.path();
    let write = |name: &str, bounces: Option<u32>| {
        let mut g = GltfBuilder::new();
        let grey = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1],
            "metallicFactor": 0.0}, "doubleSided": true}));
        let quad = |g: &mut GltfBuilder, p: [[f32; 3]; 4]| g.mesh(&p, &[0, 1, 2, 0, 2, 3], grey);
        quad(&mut g, [[-2.0, -1.0, -1.0], [2.0, -1.0, -1.0], [2.0, -1.0, -6.0], [-2.0, -1.0, -6.0]]);
        quad(&mut g, [[-2.0, -1.0, -6.0], [2.0, -1.0, -6.0], [2.0, 2.0, -6.0], [-2.0, 2.0, -6.0]]);
        let mut area = json!({"shape": "square", "size": [3.0, 3.0], "power": 300.0, "camera_visible": false});
        if let Some(b) = bounces {
            area["max_bounces"] = json!(b);
        }
        g.use_ext("CAUSTIC_lights_area");
        let h = std::f32::consts::FRAC_1_SQRT_2;
        g.node(json!({"translation": [0.0, 0.2, -4.0], "rotation": [-h, 0.0, 0.0, h],
            "extensions": {"CAUSTIC_lights_area": area}}));
        g.camera([0.0, 0.3, 0.0], [0.0, 0.0, 0.0, 1.0], 0.9);
        g.write(d, name)
    };
    let unlimited = write("u.gltf", None);
    let bounded = write("b.gltf", Some(0));
    let seeds = |path: &Path, depth: &str| -> (f64, f64) {
        let v: Vec<f64> = (0..8)
            .map(|s| {
                let seed = s.to_string();
                mean(&render(path, &d.join("x.exr"), &["--spp", "16", "--max-depth", depth, "--seed", &seed]))
            })
            .collect();
        common::mean_se(&v)
    };
    let (direct, se_d) = seeds(&unlimited, "1");
    let (limited, se_l) = seeds(&bounded, "8");
    let (full, se_f) = seeds(&unlimited, "8");
    eprintln!("direct {direct} ± {se_d}, limited {limited} ± {se_l}, full {full} ± {se_f}");
    // Four joint standard errors each side: a false failure has odds below 1e-4.
    assert!(
        limited - direct > 4.0 * se_d.hypot(se_l),
        "hits past the limit kept: {direct} ± {se_d} vs {limited} ± {se_l}"
    );
    assert!(
        full - limited > 4.0 * se_f.hypot(se_l),
        "estimates past the limit dropped: {limited} ± {se_l} vs {full} ± {se_f}"
    );
}

/// BDPT and VCM make the paths of a light with Max Bounces as the path tracer does (s = 0
/// and s = 1 alone, `bdpt::visibility`): they agree with it region by region under the
/// point light (B = 1) and the area light (B = 0); Jensen's photon mapping and SPPM, whose
/// photons of a light with Max Bounces 0 carry nothing, agree under the point light (B = 0).
/// Bounds as `tests/bidirectional_visibility.rs` (Welch per region, Šidák over every
/// comparison; radius 0.02 on a scene 4 units across).
#[test]
fn other_integrators_match_the_path_tracer() {
    let dir = temp_dir();
    let regs = regions(RES.0, RES.1);
    let r = format!("{}x{}", RES.0, RES.1);
    let seeded = Seeded::six(dir.path(), &r, "4", &regs, LIMIT);
    let path_tracer = ["--integrator", "path", "--spp", "64"];
    let alpha = sidak(regs.len() * 8);
    let mut failed = Vec::new();
    for (k, (light, area)) in
        [(json!({"max_bounces": 1}), false), (json!({"max_bounces": 0}), true)].into_iter().enumerate()
    {
        let ruled = scene(dir.path(), &format!("case{k}.gltf"), &case(light, area));
        let reference = seeded.means(&ruled, &path_tracer);
        let plain = seeded.means(&scene(dir.path(), &format!("plain{k}.gltf"), &case(json!({}), area)), &path_tracer);
        seeded.assert_rule_matters(&format!("case {k}: without the limit"), &plain, &reference, alpha);
        failed.extend(seeded.bidirectional_disagreeing(&ruled, &reference, "16", "0.02", alpha));
    }
    let ruled = scene(dir.path(), "photons.gltf", &case(json!({"max_bounces": 0}), false));
    let reference = seeded.means(&ruled, &path_tracer);
    let photon = ["--integrator", "photon", "--spp", "32", "--photons", "400000", "--max-radius", "0.02"];
    let sppm = ["--integrator", "sppm", "--sppm-iterations", "256", "--sppm-radius", "0.02"];
    failed.extend(seeded.disagreeing_others(&ruled, &reference, &[("photon", &photon), ("sppm", &sppm)], alpha));
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}

/// The photon integrators name a light whose Max Bounces they do not follow (a limit above
/// 0; an area light's hits at 0) and the integrator; a delta light at 0, and the path
/// tracer, BDPT and VCM, say nothing.
#[test]
fn photon_integrators_name_the_limits_they_do_not_follow() {
    let dir = temp_dir();
    let d = dir.path();
    let said = |file: &str, c: Case, integrator: &str| -> Vec<String> {
        let path = scene(d, file, &c);
        let flags = ["--integrator", integrator, "--sppm-iterations", "1", "--photons", "1000"];
        quick_render_warnings(&path, &d.join("w.exr"), &flags, LIMIT)
            .into_iter()
            .filter(|w| w.contains("Max Bounces"))
            .collect()
    };
    for integrator in ["photon", "sppm"] {
        let name = if integrator == "photon" { "photon mapping" } else { "SPPM" };
        let w = said("p2.gltf", case(json!({"max_bounces": 2}), false), integrator);
        assert!(w.len() == 1 && w[0].contains("(Max Bounces 2)") && w[0].contains(name), "{integrator}: {w:?}");
        let w = said("a0.gltf", case(json!({"max_bounces": 0}), true), integrator);
        assert!(w.len() == 1 && w[0].contains("sends no photons"), "{integrator}: {w:?}");
        assert!(said("p0.gltf", case(json!({"max_bounces": 0}), false), integrator).is_empty());
    }
    for integrator in ["path", "bdpt", "vcm"] {
        assert!(said("p2.gltf", case(json!({"max_bounces": 2}), false), integrator).is_empty(), "{integrator}");
    }
}

/// The world's Max Bounces: a white world over a grey floor under a grey roof (the floor
/// sees the sky through the gap between them). Cycles samples a world as a light only where
/// it varies or has portals (`test_enabled_lights`), so a constant world's limit changes
/// nothing (bit for bit). With a portal in the back opening the world is sampled, and with
/// Max Bounces 0 its next-event estimates past the first hit give nothing: darker than the
/// unlimited world, brighter than the direct light alone (its BSDF-sampled hits keep their
/// MIS share).
#[test]
fn the_world_limits_its_light_sampling() {
    let dir = temp_dir();
    let d = dir.path();
    let write = |name: &str, bounces: Option<u32>, portal: bool| {
        let mut g = GltfBuilder::new();
        let grey = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1],
            "metallicFactor": 0.0}, "doubleSided": true}));
        let quad = |g: &mut GltfBuilder, y: f32| {
            g.mesh(&[[-3.0, y, -1.0], [3.0, y, -1.0], [3.0, y, -7.0], [-3.0, y, -7.0]], &[0, 1, 2, 0, 2, 3], grey)
        };
        quad(&mut g, -1.0);
        quad(&mut g, 1.0);
        let mut w = json!({"color": [1.0, 1.0, 1.0], "strength": 1.0});
        if let Some(b) = bounces {
            w["max_bounces"] = json!(b);
        }
        g.world(w);
        if portal {
            // The back opening, facing the scene (+Z: turned half a turn about Y).
            g.use_ext("CAUSTIC_lights_area");
            g.node(json!({"translation": [0.0, 0.0, -7.0], "rotation": [0.0, 1.0, 0.0, 0.0],
                "extensions": {"CAUSTIC_lights_area":
                    {"shape": "rectangle", "size": [6.0, 2.0], "power": 0.0, "portal": true}}}));
        }
        g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.9);
        g.write(d, name)
    };
    let args = ["--spp", "8", "--max-depth", "8"];
    let plain = render(&write("c.gltf", None, false), &d.join("c.exr"), &args);
    let constant = render(&write("cb.gltf", Some(0), false), &d.join("cb.exr"), &args);
    assert_eq!(plain, constant, "a constant world's Max Bounces changed the image");
    let unlimited = write("u.gltf", None, true);
    let bounded = write("b.gltf", Some(0), true);
    let seeds = |path: &Path, depth: &str| -> (f64, f64) {
        let v: Vec<f64> = (0..8)
            .map(|s| {
                let seed = s.to_string();
                mean(&render(path, &d.join("x.exr"), &["--spp", "8", "--max-depth", depth, "--seed", &seed]))
            })
            .collect();
        common::mean_se(&v)
    };
    let (direct, se_d) = seeds(&unlimited, "1");
    let (limited, se_l) = seeds(&bounded, "8");
    let (full, se_f) = seeds(&unlimited, "8");
    eprintln!("world: direct {direct} ± {se_d}, limited {limited} ± {se_l}, full {full} ± {se_f}");
    assert!(limited - direct > 4.0 * se_d.hypot(se_l), "{direct} ± {se_d} vs {limited} ± {se_l}");
    assert!(full - limited > 4.0 * se_f.hypot(se_l), "{limited} ± {se_l} vs {full} ± {se_f}");
}
