//! Object > Shading > Shadow Terminator > Shading Offset (`CAUSTIC_object_shading`'s
//! `shading_offset`), as Cycles applies it: the cosine between the shading normal and the
//! light becomes cos(k θ), k = 1 / (1 − offset / 2) (`scene::terminator::shift_cos_in`).

mod common;

use common::{GltfBuilder, quick_render_warnings, render_image, run, temp_dir};
use serde_json::json;
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(60);

/// A grey quad facing up (+Y, glTF), a sun 60° from its normal, a camera looking straight
/// down at it; the quad's node carries `shading` as its CAUSTIC_object_shading.
fn quad_under_sun(dir: &std::path::Path, name: &str, shading: serde_json::Value) -> std::path::PathBuf {
    let mut g = GltfBuilder::new();
    let grey = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0],
        "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
    let quad =
        g.mesh(&[[-2.0, 0.0, -2.0], [-2.0, 0.0, 2.0], [2.0, 0.0, 2.0], [2.0, 0.0, -2.0]], &[0, 1, 2, 0, 2, 3], grey);
    g.node_ext(quad, "CAUSTIC_object_shading", shading);
    let h = std::f32::consts::FRAC_1_SQRT_2;
    g.camera([0.0, 3.0, 0.0], [-h, 0.0, 0.0, h], 0.5);
    // The sun's -Z turned 30° up from the horizon (60° from the quad's normal), about X.
    let a = (-60f32).to_radians() / 2.0 - std::f32::consts::FRAC_PI_4;
    g.punctual(json!({"type": "directional", "intensity": 683.0}), [0.0, 5.0, 0.0], [a.sin(), 0.0, 0.0, a.cos()]);
    g.write(dir, name)
}

#[test]
fn shading_offset_turns_the_cosine_to_cos_k_theta() {
    let dir = temp_dir();
    let mean = |shading: serde_json::Value, name: &str| {
        let scene = quad_under_sun(dir.path(), name, shading);
        let px = render_image(
            &scene,
            &dir.path().join(format!("{name}.exr")),
            &["--resolution", "8x8", "--spp", "4"],
            LIMIT,
        );
        px.iter().map(|p| p[1] as f64).sum::<f64>() / px.len() as f64
    };
    let plain = mean(json!({"shadow_terminator_offset": 0.0}), "plain.gltf");
    let half = mean(json!({"shading_offset": 0.5}), "half.gltf");
    let one = mean(json!({"shading_offset": 1.0}), "one.gltf");
    assert!(plain > 0.05, "the quad is lit: {plain}");
    // The sun is a delta light over a lone quad in a black world: its light is next-event
    // estimation's alone, so the ratio is the cosine's exactly (f32: 1e-4).
    let theta = 60f64.to_radians();
    let want = (4.0 / 3.0 * theta).cos() / theta.cos();
    assert!((half / plain - want).abs() < 1e-4, "offset 0.5: {} vs cos(80°)/cos(60°) = {want}", half / plain);
    // Offset 1: k = 2, cos(120°) < 0: the terminator reached 45°, the quad is dark.
    assert!(one.abs() < 1e-6 * plain, "offset 1: {one}");
}

#[test]
fn shading_offset_out_of_range_is_refused_and_other_integrators_say_what_they_apply() {
    let dir = temp_dir();
    let bad = quad_under_sun(dir.path(), "bad.gltf", json!({"shading_offset": 2.5}));
    let r = run(&["render", bad.to_str().unwrap(), "-o", dir.path().join("b.exr").to_str().unwrap()], LIMIT);
    assert_eq!(r.code, Some(3), "{}", r.stderr);
    assert!(r.stderr.contains("shading_offset"), "{}", r.stderr);
    let ok = quad_under_sun(dir.path(), "ok.gltf", json!({"shading_offset": 0.5}));
    let out = dir.path().join("o.exr");
    assert!(
        quick_render_warnings(&ok, &out, &["--integrator", "path"], LIMIT)
            .iter()
            .all(|w| !w.contains("Shading Offset"))
    );
    for integrator in ["bdpt", "vcm", "photon", "sppm"] {
        let w = quick_render_warnings(&ok, &out, &["--integrator", integrator], LIMIT);
        assert!(w.iter().any(|w| w.contains("Shading Offset")), "{integrator}: {w:?}");
    }
}
