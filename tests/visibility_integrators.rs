//! Cast Shadow off in BDPT and VCM (`src/integrator/linking.rs`: a light whose blocker set
//! is empty), and objects hidden from camera rays alone (exact in every strategy,
//! `src/integrator/bdpt/visibility.rs`): they converge to the path tracer's image region by
//! region, and do not warn (other kinds: `tests/bidirectional_visibility.rs`).
//!
//! The scene: a floor, a back wall and a small quad hanging over the floor ("Blocker"),
//! seen from the front, with indirect light (max depth 4). A point light above the blocker
//! and a low sun from behind the camera have Cast Shadow off, so the floor under the
//! blocker and the wall behind it are lit by them as if the blocker were not there; an
//! area light overhead casts its shadows as usual. Both shadowless lights are delta lights,
//! for which the path tracer's next-event estimate has weight 1 and so carries their whole
//! unshadowed light (for an area light it keeps only its MIS share in the shadow, where
//! BDPT and VCM keep all of it: `linking`'s module doc). The test first checks that the flag
//! matters: the path tracer's image with shadows on leaves the shadowless one's bounds.
//!
//! Bounds (`common::agreement`): K seeds per estimate, Welch's test per region, Šidák's
//! split over every comparison of the test (the flag check and two integrators, five
//! regions each). VCM's merging blurs indirect light by at most its radius, 0.02 on a scene
//! 4 units across (a loss of about r / side at the regions' edges, a tenth of their noise
//! bound, as in `linking_integrators.rs`).

mod common;

use common::agreement::{Seeded, regions, sidak};
use common::{GltfBuilder, quick_render_warnings, temp_dir};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);
const RES: (usize, usize) = (32, 32);

/// The scene of the module doc; `shadows`: the point light and the sun cast shadows.
fn scene(dir: &Path, shadows: bool) -> PathBuf {
    scene_with(dir, shadows, None)
}

/// [`scene`], with a standing panel (right of the middle, in front of the wall, lit by the
/// point light and shadowing the floor behind it) of Ray Visibility `vis`
/// (`CAUSTIC_object_visibility`).
fn scene_with(dir: &Path, shadows: bool, vis: Option<serde_json::Value>) -> PathBuf {
    let mut g = GltfBuilder::new();
    let grey = g
        .material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1], "metallicFactor": 0.0},
            "doubleSided": true}));
    let quad = |g: &mut GltfBuilder, p: [[f32; 3]; 4]| g.mesh(&p, &[0, 1, 2, 0, 2, 3], grey);
    quad(&mut g, [[-2.0, -1.0, -2.0], [2.0, -1.0, -2.0], [2.0, -1.0, -6.0], [-2.0, -1.0, -6.0]]);
    quad(&mut g, [[-2.0, -1.0, -6.0], [2.0, -1.0, -6.0], [2.0, 2.0, -6.0], [-2.0, 2.0, -6.0]]);
    let blocker = quad(&mut g, [[-1.2, 0.3, -3.5], [0.2, 0.3, -3.5], [0.2, 0.3, -4.5], [-1.2, 0.3, -4.5]]);
    g.node_name(blocker, "Blocker");
    if let Some(v) = &vis {
        let panel = quad(&mut g, [[0.2, -1.0, -3.2], [1.2, -1.0, -3.2], [1.2, 0.2, -3.2], [0.2, 0.2, -3.2]]);
        g.node_ext(panel, "CAUSTIC_object_visibility", v.clone());
    }
    g.use_ext("CAUSTIC_lights_area");
    // Facing down: -Z turned by -90° about X.
    let h = std::f32::consts::FRAC_1_SQRT_2;
    g.node(json!({"translation": [0.8, 1.8, -4.0], "rotation": [-h, 0.0, 0.0, h],
        "extensions": {"CAUSTIC_lights_area": {"shape": "square", "size": [0.6, 0.6], "power": 30.0}}}));
    let flags = json!({"CAUSTIC_lights_punctual": {"cast_shadow": shadows}});
    g.punctual_with(
        json!({"type": "point", "intensity": 4000.0}),
        [-0.3, 1.5, -3.0],
        [0.0, 0.0, 0.0, 1.0],
        flags.clone(),
    );
    // From behind the camera's right shoulder, low: the blocker's shadow falls on the wall.
    let (sx, sy) = (0.2f32, -0.25f32);
    let c = (1.0 - sx * sx - sy * sy).sqrt();
    g.punctual_with(
        json!({"type": "directional", "intensity": 683.0}),
        [0.0, 0.0, 0.0],
        common::look_rotation([sx, sy, -c]),
        flags,
    );
    g.camera([0.0, 0.3, 0.0], [0.0, 0.0, 0.0, 1.0], 0.9);
    g.write(
        dir,
        &format!(
            "shadows_{shadows}_{}.gltf",
            vis.map_or(String::new(), |v| v.to_string().replace(['"', ':', '{', '}', ','], "_"))
        ),
    )
}

/// BDPT and VCM agree with the path tracer on lights with Cast Shadow off.
#[test]
fn bdpt_and_vcm_match_the_path_tracer_without_cast_shadow() {
    let dir = temp_dir();
    let shadowless = scene(dir.path(), false);
    let regs = regions(RES.0, RES.1);
    let r = format!("{}x{}", RES.0, RES.1);
    let seeded = Seeded::six(dir.path(), &r, "4", &regs, LIMIT);
    let means = |path: &Path, extra: &[&str]| seeded.means(path, extra);
    let path_tracer = ["--integrator", "path", "--spp", "64"];
    let reference = means(&shadowless, &path_tracer);
    let alpha = sidak(regs.len() * 3);
    let shadowed = means(&scene(dir.path(), true), &path_tracer);
    seeded.assert_rule_matters("with shadows", &shadowed, &reference, alpha);
    let failed = seeded.bidirectional_disagreeing(&shadowless, &reference, "16", "0.02", alpha);
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}

/// BDPT and VCM no longer warn about lights with Cast Shadow off.
#[test]
fn bdpt_and_vcm_do_not_warn_about_cast_shadow() {
    let dir = temp_dir();
    let path = scene(dir.path(), false);
    for integrator in ["path", "bdpt", "vcm"] {
        let out = dir.path().join(format!("{integrator}.exr"));
        let warnings = quick_render_warnings(&path, &out, &["--integrator", integrator], LIMIT);
        let w: Vec<String> = warnings.into_iter().filter(|m| m.contains("Cast Shadow")).collect();
        assert!(w.is_empty(), "{integrator}: {w:?}");
    }
}

/// A panel hidden from camera rays (the lights cast shadows): the camera sees the floor and
/// wall through it, its shadows and the light it reflects stay. BDPT and VCM agree with the path tracer; without the flag the
/// path tracer's image leaves those bounds (the blocker is seen). Bounds as above, Šidák's
/// split over the flag check and two integrators, five regions each.
#[test]
fn bdpt_and_vcm_match_the_path_tracer_with_an_object_hidden_from_the_camera() {
    let dir = temp_dir();
    let hidden = scene_with(dir.path(), true, Some(json!({"camera": false})));
    let regs = regions(RES.0, RES.1);
    let r = format!("{}x{}", RES.0, RES.1);
    let seeded = Seeded::six(dir.path(), &r, "4", &regs, LIMIT);
    let means = |path: &Path, extra: &[&str]| seeded.means(path, extra);
    let path_tracer = ["--integrator", "path", "--spp", "64"];
    let reference = means(&hidden, &path_tracer);
    let alpha = sidak(regs.len() * 3);
    let seen = means(&scene_with(dir.path(), true, Some(json!({}))), &path_tracer);
    seeded.assert_rule_matters("seen by the camera", &seen, &reference, alpha);
    let failed = seeded.bidirectional_disagreeing(&hidden, &reference, "16", "0.02", alpha);
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}
