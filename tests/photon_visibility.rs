//! Cast Shadow off and Ray Visibility in Jensen's photon mapping and SPPM
//! (`src/integrator/photon/visibility.rs`, `src/integrator/linking.rs`): both converge to
//! the path tracer's image, region by region, and neither warns that it ignores the rule.
//!
//! The scene: a grey floor, a back wall and a grey quad hanging over the floor
//! ("Blocker"), seen from the front, lit by a point light above the blocker, with indirect
//! light (max depth 4). Each case changes one rule: the light's Cast Shadow off (the floor
//! under the blocker is lit directly, and so is the blocker's top: photons pass the blocker
//! and scatter at both), the blocker hidden from diffuse rays (it still casts its direct
//! shadow, but the floor's and the wall's diffuse rays pass it, and its own bounce light
//! reaches them only through their glossy layer), the blocker seen by shadow rays alone, or
//! the light hidden from diffuse rays (it lights only the materials' glossy layer). A point light is a
//! delta light, which the path tracer takes by next-event estimation alone with weight 1,
//! so its image is the reference without MIS shares in the way. Each case checks that its
//! rule matters: the path tracer's image without it leaves the case's bounds.
//!
//! Bounds (`common::agreement`): K seeds per estimate, Welch's test per region, Šidák's
//! split over every comparison of the test. The photon integrators are consistent, not
//! unbiased: their kernel blurs the indirect light by at most the gather radius, which the
//! test sets to 0.02 on a scene 4 units across, as `tests/linking_integrators.rs` derives:
//! the blur's loss at the edges is a tenth of the regions' noise bound.

mod common;

use common::agreement::{Seeded, disagreeing, regions, sidak};
use common::{GltfBuilder, quick_render_warnings, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);
const RES: (usize, usize) = (32, 32);

/// One case of the scene: the light's punctual extension and the blocker's visibility.
struct Case {
    name: &'static str,
    light: Value,
    blocker: Value,
}

/// The scene (module doc) with the light's punctual extension `light` and the blocker's
/// visibility `blocker_vis` (empty objects: none).
fn scene(dir: &Path, file: &str, light: &Value, blocker_vis: &Value) -> PathBuf {
    let mut g = GltfBuilder::new();
    let grey = g
        .material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1], "metallicFactor": 0.0},
            "doubleSided": true}));
    let quad = |g: &mut GltfBuilder, p: [[f32; 3]; 4]| g.mesh(&p, &[0, 1, 2, 0, 2, 3], grey);
    let floor = quad(&mut g, [[-2.0, -1.0, -2.0], [2.0, -1.0, -2.0], [2.0, -1.0, -6.0], [-2.0, -1.0, -6.0]]);
    let wall = quad(&mut g, [[-2.0, -1.0, -6.0], [2.0, -1.0, -6.0], [2.0, 2.0, -6.0], [-2.0, 2.0, -6.0]]);
    let blocker = quad(&mut g, [[-1.2, 0.3, -3.5], [0.2, 0.3, -3.5], [0.2, 0.3, -4.5], [-1.2, 0.3, -4.5]]);
    g.node_name(floor, "Floor");
    g.node_name(wall, "Wall");
    g.node_name(blocker, "Blocker");
    if blocker_vis.as_object().is_some_and(|o| !o.is_empty()) {
        g.node_ext(blocker, "CAUSTIC_object_visibility", blocker_vis.clone());
    }
    let point = json!({"type": "point", "intensity": 4000.0});
    let at = ([-0.5, 1.5, -4.0], [0.0, 0.0, 0.0, 1.0]);
    if light.as_object().is_some_and(|o| !o.is_empty()) {
        g.use_ext("CAUSTIC_lights_punctual");
        g.punctual_with(point, at.0, at.1, json!({"CAUSTIC_lights_punctual": light}));
    } else {
        g.punctual(point, at.0, at.1);
    }
    g.camera([0.0, 0.3, 0.0], [0.0, 0.0, 0.0, 1.0], 0.9);
    g.write(dir, file)
}

/// The cases, each with the rule it sets.
fn cases() -> Vec<Case> {
    vec![
        Case { name: "cast shadow off", light: json!({"cast_shadow": false}), blocker: json!({}) },
        Case { name: "blocker hidden from diffuse rays", light: json!({}), blocker: json!({"diffuse": false}) },
        Case {
            name: "blocker seen by shadow rays only",
            light: json!({}),
            blocker: json!({"camera": false, "diffuse": false, "glossy": false, "transmission": false}),
        },
        Case { name: "light hidden from diffuse rays", light: json!({"diffuse_visible": false}), blocker: json!({}) },
    ]
}

/// Jensen and SPPM each agree with the path tracer on every case, and each case's rule
/// matters.
#[test]
fn photon_integrators_match_the_path_tracer() {
    let dir = temp_dir();
    let regs = regions(RES.0, RES.1);
    let r = format!("{}x{}", RES.0, RES.1);
    let seeded = Seeded {
        dir: dir.path(),
        common: vec!["--resolution", &r, "--max-depth", "4"],
        seeds: 6,
        regions: &regs,
        limit: LIMIT,
    };
    let means = |path: &Path, extra: &[&str]| seeded.means(path, extra);
    let cases = cases();
    let alpha = sidak(regs.len() * 3 * cases.len());
    let path_tracer = ["--integrator", "path", "--spp", "64"];
    let plain = means(&scene(dir.path(), "plain.gltf", &json!({}), &json!({})), &path_tracer);
    let mut failed = Vec::new();
    for (k, case) in cases.iter().enumerate() {
        let ruled = scene(dir.path(), &format!("case{k}.gltf"), &case.light, &case.blocker);
        let reference = means(&ruled, &path_tracer);
        let label = format!("{}: without the rule", case.name);
        assert!(!disagreeing(&label, &regs, &plain, &reference, alpha).is_empty(), "{label}: it changes nothing");
        let others: [(&str, &[&str]); 2] = [
            ("photon", &["--integrator", "photon", "--spp", "32", "--photons", "400000", "--max-radius", "0.02"]),
            ("sppm", &["--integrator", "sppm", "--sppm-iterations", "256", "--sppm-radius", "0.02"]),
        ];
        let case_failed = seeded.disagreeing_others(&ruled, &reference, &others, alpha);
        failed.extend(case_failed.into_iter().map(|r| format!("{}: {r}", case.name)));
    }
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}

/// Neither photon integrator warns that it ignores a case's rule.
#[test]
fn no_photon_integrator_warns_about_the_rules() {
    let dir = temp_dir();
    for (k, case) in cases().iter().enumerate() {
        let path = scene(dir.path(), &format!("w{k}.gltf"), &case.light, &case.blocker);
        for integrator in ["photon", "sppm"] {
            let out = dir.path().join(format!("{integrator}.exr"));
            let flags = ["--integrator", integrator, "--sppm-iterations", "1", "--photons", "1000"];
            let warned: Vec<String> = quick_render_warnings(&path, &out, &flags, LIMIT)
                .into_iter()
                .filter(|m| m.contains("Cast Shadow") || m.contains("ray visibility") || m.contains("shadow catcher"))
                .collect();
            assert!(warned.is_empty(), "{} / {integrator}: {warned:?}", case.name);
        }
    }
}
