//! Ray Visibility of objects, lights and the world in BDPT and VCM
//! (`src/integrator/bdpt/visibility.rs`: paths that meet a restricted object or light are
//! made by s = 0 and s = 1 alone, as the path tracer makes them): both converge to the
//! path tracer's image region by region on each case, and neither warns.
//!
//! The cases (`common::visibility_cases`, the scene `tests/photon_visibility.rs` renders
//! too): the blocker hidden from diffuse rays (it casts its direct shadow, the floor's and
//! wall's diffuse rays pass it), the blocker seen by shadow rays only (the camera sees
//! through it, its shadow stays), the point light hidden from diffuse rays (it lights the
//! glossy layer alone), and the world hidden from glossy rays over rough metal (the sky
//! is seen, its reflections are not); then under an area light in the point light's place,
//! where BSDF sampling and light sampling share the restricted paths by MIS: the light hidden
//! from diffuse rays, and the blocker hidden from transmission rays (no material transmits,
//! so the rule changes nothing in expectation, but every path that meets the blocker is
//! weighed by s = 0 against s = 1 alone). Each case but the last checks that its rule
//! matters: the path tracer's image without it leaves the case's bounds.
//!
//! Bounds (`common::agreement`): K seeds per estimate, Welch's test per region, Šidák's
//! split over every comparison of the test (per case the rule check and two integrators,
//! five regions each). VCM's merging blurs indirect light by at most its radius, 0.02 on a
//! scene 4 units across (a loss of about r / side at the regions' edges, a tenth of their
//! noise bound, as in `linking_integrators.rs`).

mod common;

use common::agreement::{Seeded, regions, sidak};
use common::visibility_cases::{
    Case, area_light_hidden_from_diffuse, blocker_hidden_from_transmission_under_an_area_light, cases, scene,
    world_hidden_from_glossy,
};
use common::{quick_render_warnings, temp_dir};
use std::path::Path;
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);
const RES: (usize, usize) = (32, 32);

/// The cases of Ray Visibility (Cast Shadow off is `tests/visibility_integrators.rs`'s),
/// each with whether its rule changes the image.
fn visibility_cases() -> Vec<(Case, bool)> {
    let mut v: Vec<(Case, bool)> =
        cases().into_iter().filter(|c| c.light.get("cast_shadow").is_none()).map(|c| (c, true)).collect();
    v.push((world_hidden_from_glossy(), true));
    v.push((area_light_hidden_from_diffuse(), true));
    v.push((blocker_hidden_from_transmission_under_an_area_light(), false));
    v
}

/// BDPT and VCM each agree with the path tracer on every case, and each case's rule matters.
#[test]
fn bdpt_and_vcm_match_the_path_tracer_on_ray_visibility() {
    let dir = temp_dir();
    let regs = regions(RES.0, RES.1);
    let r = format!("{}x{}", RES.0, RES.1);
    let seeded = Seeded::six(dir.path(), &r, "4", &regs, LIMIT);
    let means = |path: &Path, extra: &[&str]| seeded.means(path, extra);
    let cases = visibility_cases();
    let alpha = sidak(regs.len() * 3 * cases.len());
    let path_tracer = ["--integrator", "path", "--spp", "64"];
    let mut failed = Vec::new();
    for (k, (case, matters)) in cases.iter().enumerate() {
        let ruled = scene(dir.path(), &format!("case{k}.gltf"), case);
        let reference = means(&ruled, &path_tracer);
        if *matters {
            let plain = means(&scene(dir.path(), &format!("plain{k}.gltf"), &case.without_rule()), &path_tracer);
            let label = format!("{}: without the rule", case.name);
            seeded.assert_rule_matters(&label, &plain, &reference, alpha);
        }
        let case_failed = seeded.bidirectional_disagreeing(&ruled, &reference, "16", "0.02", alpha);
        failed.extend(case_failed.into_iter().map(|r| format!("{}: {r}", case.name)));
    }
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}

/// Neither BDPT nor VCM warns that it ignores a case's rule.
#[test]
fn bdpt_and_vcm_do_not_warn_about_ray_visibility() {
    let dir = temp_dir();
    for (k, (case, _)) in visibility_cases().iter().enumerate() {
        let path = scene(dir.path(), &format!("w{k}.gltf"), case);
        for integrator in ["bdpt", "vcm"] {
            let out = dir.path().join(format!("{integrator}.exr"));
            let warned: Vec<String> = quick_render_warnings(&path, &out, &["--integrator", integrator], LIMIT)
                .into_iter()
                .filter(|m| m.to_lowercase().contains("visibility"))
                .collect();
            assert!(warned.is_empty(), "{} / {integrator}: {warned:?}", case.name);
        }
    }
}

/// Under motion blur BDPT and VCM judge a moving restricted object where it is at the frame,
/// and say so naming it; a still one, or the path tracer, says nothing.
#[test]
fn bdpt_and_vcm_warn_about_moving_restricted_objects() {
    let dir = temp_dir();
    let d = dir.path();
    let write = |name: &str, moves: bool| {
        let mut g = common::GltfBuilder::new();
        let grey = g.material(serde_json::json!({"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1]}}));
        let floor = g.mesh(
            &[[-2.0, -1.0, -1.0], [2.0, -1.0, -1.0], [2.0, -1.0, -5.0], [-2.0, -1.0, -5.0]],
            &[0, 1, 2, 0, 2, 3],
            grey,
        );
        g.node_name(floor, "Floor");
        let q = g.mesh(
            &[[-0.3, -0.3, -3.0], [0.3, -0.3, -3.0], [0.3, 0.3, -3.0], [-0.3, 0.3, -3.0]],
            &[0, 1, 2, 0, 2, 3],
            grey,
        );
        g.node_name(q, "Ghost");
        g.node_ext(q, "CAUSTIC_object_visibility", serde_json::json!({"diffuse": false}));
        let shift = |x: f32| serde_json::json!([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, x, 0, 0, 1]);
        g.scene_ext(
            "CAUSTIC_motion",
            serde_json::json!({"times": [-0.5, 0.5], "shutter": {"open": -0.5, "close": 0.5}}),
        );
        if moves {
            g.node_ext(
                q,
                "CAUSTIC_motion",
                serde_json::json!({"matrix": shift(0.0), "matrices": [shift(-0.2), shift(0.2)]}),
            );
        }
        g.punctual(serde_json::json!({"type": "point", "intensity": 1000.0}), [0.0, 1.5, -3.0], [0.0, 0.0, 0.0, 1.0]);
        g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.9);
        g.write(d, name)
    };
    for (moves, integrator, warns) in
        [(true, "bdpt", true), (true, "vcm", true), (true, "path", false), (false, "bdpt", false)]
    {
        let scene = write(&format!("m_{moves}.gltf"), moves);
        let out = d.join(format!("{integrator}.exr"));
        let warnings = quick_render_warnings(&scene, &out, &["--integrator", integrator], LIMIT);
        let said = warnings.iter().any(|w| w.contains("ray visibility of moving object(s) 'Ghost'"));
        assert_eq!(said, warns, "{integrator}, moving {moves}: {warnings:?}");
    }
}
