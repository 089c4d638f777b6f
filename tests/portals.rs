//! Light portals (Blender's area lights marked Portal, `"portal": true` in
//! `CAUSTIC_lights_area`): they emit nothing and only steer the world's light sampling,
//! so a room lit by the sky through a window renders the same with and without a portal
//! in the window, in every integrator, and with less noise where light sampling aims
//! through it.
//!
//! The room is 2 m wide, 2 m high and 2 m deep, grey walls, with a 0.6 × 0.8 m window in
//! its +X wall; the world is a constant colour, so every bit of light enters through the
//! window. Regions are compared with Welch's test over six seeds (`common::agreement`).

mod common;

use common::agreement::{Seeded, disagreeing, regions, sidak};
use common::{GltfBuilder, look_rotation, render_image, temp_dir};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);

fn quad(g: &mut GltfBuilder, p: [[f32; 3]; 4], m: usize) {
    g.mesh(&p, &[0, 1, 2, 0, 2, 3], m);
}

/// The room, optionally with a portal filling its window.
fn room(dir: &Path, name: &str, portal: bool) -> PathBuf {
    let mut g = GltfBuilder::new();
    let wall = g.material(json!({"doubleSided": true, "pbrMetallicRoughness": {
        "baseColorFactor": [0.7, 0.7, 0.7, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
    let floor = g.material(json!({"doubleSided": true, "pbrMetallicRoughness": {
        "baseColorFactor": [0.6, 0.5, 0.4, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
    let (lo, hi) = (-1.0f32, 1.0f32);
    quad(&mut g, [[lo, 0.0, lo], [hi, 0.0, lo], [hi, 0.0, hi], [lo, 0.0, hi]], floor);
    quad(&mut g, [[lo, 2.0, lo], [hi, 2.0, lo], [hi, 2.0, hi], [lo, 2.0, hi]], wall);
    quad(&mut g, [[lo, 0.0, lo], [lo, 2.0, lo], [lo, 2.0, hi], [lo, 0.0, hi]], wall);
    quad(&mut g, [[lo, 0.0, lo], [hi, 0.0, lo], [hi, 2.0, lo], [lo, 2.0, lo]], wall);
    quad(&mut g, [[lo, 0.0, hi], [hi, 0.0, hi], [hi, 2.0, hi], [lo, 2.0, hi]], wall);
    // The +X wall around the window (y in [0.8, 1.6], z in [-0.3, 0.3]).
    let x = hi;
    quad(&mut g, [[x, 0.0, lo], [x, 0.8, lo], [x, 0.8, hi], [x, 0.0, hi]], wall);
    quad(&mut g, [[x, 1.6, lo], [x, 2.0, lo], [x, 2.0, hi], [x, 1.6, hi]], wall);
    quad(&mut g, [[x, 0.8, lo], [x, 1.6, lo], [x, 1.6, -0.3], [x, 0.8, -0.3]], wall);
    quad(&mut g, [[x, 0.8, 0.3], [x, 1.6, 0.3], [x, 1.6, hi], [x, 0.8, hi]], wall);
    g.world(json!({"color": [3.0, 3.2, 3.6]}));
    if portal {
        // Local -Z (where an area light sends its light) turned to -X, into the room;
        // local X along world -Z, local Y along world Y.
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let node = g.node(json!({"translation": [x - 1e-3, 1.2, 0.0], "rotation": [0.0, h, 0.0, h]}));
        g.node_ext(
            node,
            "CAUSTIC_lights_area",
            json!({"shape": "rectangle", "size": [0.6, 0.8], "power": 100.0, "portal": true}),
        );
    }
    g.camera([-0.9, 1.7, 0.9], look_rotation([0.8, -0.7, -0.9]), 1.2);
    g.write(dir, name)
}

fn per_pixel_variance(a: &[[f32; 4]], b: &[[f32; 4]]) -> f64 {
    // Two independent renders: E[(a - b)²] = 2 σ² per pixel.
    a.iter().zip(b).map(|(p, q)| (0..3).map(|c| ((p[c] - q[c]) as f64).powi(2)).sum::<f64>() / 6.0).sum::<f64>()
        / a.len() as f64
}

/// The portal changes the path tracer's noise, not its mean: the regions agree with the
/// render without it, and the per-pixel variance falls. The window subtends about 2 % of
/// the sphere seen from the room's middle, so map sampling sends about one shadow ray in
/// fifty toward it while the portal method sends half of its samples through it: direct
/// light from the window, most of the image, has its variance cut several times over. The
/// test asks for less than half (a portal that did nothing would give 1, up to the ~10 %
/// spread of a variance estimated over 24² pixels).
#[test]
fn portal_changes_the_noise_not_the_mean() {
    let dir = temp_dir();
    let d = dir.path();
    let (with, without) = (room(d, "portal.gltf", true), room(d, "plain.gltf", false));
    let regions = regions(24, 24);
    let s = Seeded { seeds: 16, ..Seeded::six(d, "24x24", "6", &regions, LIMIT) };
    let flags = ["--spp", "16"];
    let a = s.means(&with, &flags);
    let b = s.means(&without, &flags);
    let bad = disagreeing("path, portal vs none", &regions, &a, &b, sidak(regions.len()));
    assert!(bad.is_empty(), "the portal changed the mean in {bad:?}");

    let args = ["--resolution", "24x24", "--max-depth", "6", "--spp", "16"];
    let render = |scene: &Path, seed: &str, out: &str| {
        let mut all = args.to_vec();
        all.extend_from_slice(&["--seed", seed]);
        render_image(scene, &d.join(out), &all, LIMIT)
    };
    let v_with = per_pixel_variance(&render(&with, "1", "a.exr"), &render(&with, "2", "b.exr"));
    let v_without = per_pixel_variance(&render(&without, "1", "c.exr"), &render(&without, "2", "d.exr"));
    eprintln!("per-pixel variance with the portal {v_with:.3e}, without {v_without:.3e}");
    assert!(v_with < 0.5 * v_without, "the portal did not steer sampling: {v_with:.3e} vs {v_without:.3e}");
}

/// BDPT, VCM, Jensen's photon mapping and SPPM with the portal agree with the path tracer
/// with it (light sampling through the portal at their camera vertices; their light
/// subpaths and photons leave the world as before).
#[test]
fn every_integrator_renders_the_portal_room_alike() {
    let dir = temp_dir();
    let d = dir.path();
    let scene = room(d, "portal.gltf", true);
    let regions = regions(24, 24);
    // Sixteen seeds: Welch's quantile at the Šidák level of 20 comparisons is then about
    // 4.5 standard errors instead of 12 with six (which let a 29 % bias of BDPT through
    // all but one region while its connections still aimed through the portal).
    let s = Seeded { seeds: 16, ..Seeded::six(d, "24x24", "6", &regions, LIMIT) };
    let reference = s.means(&scene, &["--spp", "64"]);
    let alpha = sidak(regions.len() * 4);
    let mut bad = s.bidirectional_disagreeing(&scene, &reference, "32", "0.03", alpha);
    bad.extend(s.disagreeing_others(
        &scene,
        &reference,
        &[
            ("photon", &["--integrator", "photon", "--spp", "32", "--photons", "200000", "--max-radius", "0.05"]),
            ("sppm", &["--integrator", "sppm", "--sppm-iterations", "32", "--sppm-radius", "0.05"]),
        ],
        alpha,
    ));
    assert!(bad.is_empty(), "disagreeing with the path tracer: {bad:?}");
}
