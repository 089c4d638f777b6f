//! Light and shadow linking in every integrator (`src/integrator/linking.rs`): BDPT, VCM,
//! Jensen's photon mapping and SPPM converge to the path tracer's image of a linked scene,
//! region by region, and none of them warns that it ignores the rules.
//!
//! The scene: a floor, a back wall and a small quad hanging over the floor ("Blocker"),
//! seen from the front, with indirect light (max depth 4). An area light overhead lights
//! only the floor and the blocker (light linking: the wall gets its light only after a
//! bounce), a point light above the blocker is shadowed by everything but the blocker (shadow
//! linking: the floor under the blocker is lit by it), an emissive quad low on the left
//! lights all but the wall and only the wall shadows it (both rules on an emissive mesh,
//! whose light BDPT's paths also find by hitting it), and a sun lights only the wall (an
//! infinite light: BDPT reaches it from the camera side alone). The test checks that each
//! emitter's rules matter: the path tracer's image without them disagrees with the linked one
//! in some region, so an integrator ignoring them would fail.
//!
//! Bounds (`common::agreement`): K seeds per estimate, Welch's test per region, Šidák's
//! split over every comparison of the test (four integrators and four rule checks, five
//! regions each). The photon integrators are consistent, not
//! unbiased: their kernel blurs the indirect light by at most the gather radius, which the
//! test sets to 0.02 on a scene 4 units across, so that the blur's loss at the wall's and
//! floor's edges (a fraction of about r / side of the indirect light in a region) is a
//! tenth of the regions' noise bound (about 2 %).

mod common;

use common::agreement::{Seeded, disagreeing, regions, sidak};
use common::{GltfBuilder, quick_render_warnings, temp_dir};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);
const RES: (usize, usize) = (32, 32);

/// Emitters whose rules `scene` can leave out.
const EMITTERS: [&str; 4] = ["area light", "point light", "emissive quad", "sun"];

/// The linked scene (module doc), without the rules of emitter `free` (an index into
/// `EMITTERS`) when given.
fn scene(dir: &Path, free: Option<usize>) -> PathBuf {
    let ruled = |k: usize| free != Some(k);
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
    g.use_ext("CAUSTIC_lights_area");
    // Facing down: -Z turned by -90° about X.
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let area = g.node(json!({"translation": [0.0, 1.8, -4.0], "rotation": [-h, 0.0, 0.0, h],
        "extensions": {"CAUSTIC_lights_area": {"shape": "square", "size": [1.0, 1.0], "power": 60.0}}}));
    if ruled(0) {
        g.node_ext(area, "CAUSTIC_light_linking", json!({"receivers": ["Floor", "Blocker"], "include": true}));
    }
    let point = g.punctual(json!({"type": "point", "intensity": 4000.0}), [-0.3, 1.5, -3.0], [0.0, 0.0, 0.0, 1.0]);
    if ruled(1) {
        g.node_ext(point, "CAUSTIC_light_linking", json!({"blockers": ["Blocker"], "blockers_include": false}));
    }
    // Facing +X; its back face emits too (emission leaves both faces).
    g.use_ext("KHR_materials_emissive_strength");
    let glow = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]},
        "emissiveFactor": [1.0, 0.9, 0.8], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 6.0}}}));
    let (x, z0, z1) = (-1.9, -4.8, -3.6);
    let quad = g.mesh(&[[x, -0.9, z0], [x, -0.9, z1], [x, 0.1, z1], [x, 0.1, z0]], &[0, 2, 1, 0, 3, 2], glow);
    g.node_name(quad, "Glow");
    if ruled(2) {
        g.node_ext(
            quad,
            "CAUSTIC_light_linking",
            json!({"receivers": ["Wall"], "include": false, "blockers": ["Wall"], "blockers_include": true}),
        );
    }
    // From behind the camera's right shoulder, low: it reaches the wall over the blocker.
    let (sx, sy) = (0.2f32, -0.25f32);
    let c = (1.0 - sx * sx - sy * sy).sqrt();
    let sun = g.punctual(
        json!({"type": "directional", "intensity": 683.0}),
        [0.0, 0.0, 0.0],
        common::look_rotation([sx, sy, -c]),
    );
    if ruled(3) {
        g.node_ext(sun, "CAUSTIC_light_linking", json!({"receivers": ["Wall"], "include": true}));
    }
    g.camera([0.0, 0.3, 0.0], [0.0, 0.0, 0.0, 1.0], 0.9);
    g.write(dir, &format!("linked_{free:?}.gltf"))
}

/// BDPT, VCM, Jensen and SPPM each agree with the path tracer region by region.
#[test]
fn every_integrator_matches_the_path_tracer_on_a_linked_scene() {
    let dir = temp_dir();
    let linked = scene(dir.path(), None);
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
    let path_tracer = ["--integrator", "path", "--spp", "64"];
    let reference = means(&linked, &path_tracer);
    // Each emitter's rules matter: without them the path tracer's image leaves the linked
    // one's bounds.
    let alpha = sidak(regs.len() * (4 + EMITTERS.len()));
    for (k, name) in EMITTERS.iter().enumerate() {
        let free = means(&scene(dir.path(), Some(k)), &path_tracer);
        let label = format!("no rules on the {name}");
        assert!(!disagreeing(&label, &regs, &free, &reference, alpha).is_empty(), "{label}: they change nothing");
    }
    let others: [(&str, &[&str]); 4] = [
        ("bdpt", &["--integrator", "bdpt", "--spp", "16"]),
        ("vcm", &["--integrator", "vcm", "--spp", "16", "--vcm-radius", "0.02"]),
        ("photon", &["--integrator", "photon", "--spp", "16", "--photons", "100000", "--max-radius", "0.02"]),
        ("sppm", &["--integrator", "sppm", "--sppm-iterations", "16", "--sppm-radius", "0.02"]),
    ];
    let failed = seeded.disagreeing_others(&linked, &reference, &others, alpha);
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}

/// No integrator warns that it ignores light or shadow linking any more.
#[test]
fn no_integrator_warns_about_linking() {
    let dir = temp_dir();
    let path = scene(dir.path(), None);
    for integrator in ["path", "bdpt", "vcm", "photon", "sppm"] {
        let out = dir.path().join(format!("{integrator}.exr"));
        let flags = ["--integrator", integrator, "--sppm-iterations", "1", "--photons", "1000"];
        let linking: Vec<String> =
            quick_render_warnings(&path, &out, &flags, LIMIT).into_iter().filter(|m| m.contains("linking")).collect();
        assert!(linking.is_empty(), "{integrator}: {linking:?}");
    }
}
