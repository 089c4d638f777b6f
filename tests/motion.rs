//! Motion blur and the Vector pass (`CAUSTIC_motion`) in scenes with a closed-form answer.
//!
//! The camera sits at the origin looking down −Z (yfov 0.5, 32 × 32, a one-pixel box
//! filter) at a white emitter filling the view at z = −4; a black quad 0.3 wide and
//! taller than the view stands at z = −2. Over the shutter (times −½..½) the quad slides
//! +0.4 along x, or the camera slides −0.4 past a still quad (the same relative motion:
//! the emitter behind is uniform). A camera ray then sees the emitter (1) or the quad (0),
//! so a pixel's value is 1 minus the fraction of its footprint × shutter in which the quad
//! covers the ray — computed here in closed form along x and averaged over the footprint.

mod common;

use common::{GltfBuilder, render_image, run, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);
const W: usize = 32;
const YFOV: f32 = 0.5;
/// The quad's half-width, its speed (units per frame) along x, the shutter's half-length.
const HALF: f64 = 0.15;
const SPEED: f64 = 0.4;
const SHUTTER: f64 = 0.5;

fn translation(x: f32) -> Value {
    json!([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, x, 0, 0, 1])
}

/// The scene; `quad_motion` / `camera_motion` are the node extensions (None: still), and
/// `scene_motion` the scene's.
fn scene(
    dir: &Path,
    name: &str,
    scene_motion: Option<Value>,
    quad_motion: Option<Value>,
    camera_motion: Option<Value>,
) -> PathBuf {
    let mut g = GltfBuilder::new();
    let emitter = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0},
        "emissiveFactor": [1, 1, 1]
    }));
    let black = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0}}));
    let quad = |g: &mut GltfBuilder, hx: f32, hy: f32, z: f32, m: usize| {
        g.mesh(&[[-hx, -hy, z], [hx, -hy, z], [hx, hy, z], [-hx, hy, z]], &[0, 1, 2, 0, 2, 3], m)
    };
    quad(&mut g, 20.0, 20.0, -4.0, emitter);
    let q = quad(&mut g, HALF as f32, 5.0, -2.0, black);
    let cam = g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], YFOV);
    if let Some(m) = scene_motion {
        g.scene_ext("CAUSTIC_motion", m);
    }
    if let Some(m) = quad_motion {
        g.node_ext(q, "CAUSTIC_motion", m);
    }
    if let Some(m) = camera_motion {
        g.node_ext(cam, "CAUSTIC_motion", m);
    }
    g.write(dir, name)
}

fn blur() -> Value {
    json!({"times": [-SHUTTER, SHUTTER], "shutter": {"open": -SHUTTER, "close": SHUTTER}})
}

/// Moves by `dx` units per frame along x, through the frame's position x = 0.
fn sliding(dx: f64) -> Value {
    let s = SHUTTER * dx;
    json!({"matrix": translation(0.0), "matrices": [translation(-s as f32), translation(s as f32)]})
}

/// Where pixel column position `px` (pixels from the left) looks on the plane z = −2.
fn plane_x(px: f64) -> f64 {
    let half = 2.0 * (0.5 * YFOV as f64).tan();
    (2.0 * px / W as f64 - 1.0) * half
}

/// Fraction of the shutter during which the quad (centre SPEED·t) covers x.
fn covered(x: f64) -> f64 {
    // |x − SPEED t| ≤ HALF  ⇔  t ∈ [(x − HALF)/SPEED, (x + HALF)/SPEED], cut to the shutter.
    let (lo, hi) = (((x - HALF) / SPEED).max(-SHUTTER), ((x + HALF) / SPEED).min(SHUTTER));
    ((hi - lo) / (2.0 * SHUTTER)).max(0.0)
}

/// The expected value of column `c`: the emitter's share of its footprint × shutter
/// (midpoint rule on 4096 points; the integrand is piecewise linear, so its error is
/// below 1e-6).
fn expected(c: usize) -> f64 {
    let n = 4096;
    1.0 - (0..n).map(|k| covered(plane_x(c as f64 + (k as f64 + 0.5) / n as f64))).sum::<f64>() / n as f64
}

/// Each column's mean over the 16 middle rows.
fn columns(px: &[[f32; 4]]) -> Vec<f64> {
    (0..W).map(|c| (8..24).map(|r| px[r * W + c][0] as f64).sum::<f64>() / 16.0).collect()
}

/// Compares a render's columns with the closed form. Each camera sample sees 0 or L (a
/// Bernoulli draw of mean p), so a column mean of n = 16 rows × spp samples has a
/// standard deviation of at most √(p(1 − p)/n) with independent samples (Sobol points do
/// better); 5 of them bound it. L is the emitter's radiance, read off a column that the
/// quad never covers.
fn assert_matches(px: &[[f32; 4]], spp: usize, what: &str) {
    let cols = columns(px);
    let open: Vec<usize> = (0..W).filter(|&c| expected(c) == 1.0).collect();
    assert!(!open.is_empty(), "some columns never see the quad");
    let l = open.iter().map(|&c| cols[c]).sum::<f64>() / open.len() as f64;
    assert!(l > 0.0);
    let n = (16 * spp) as f64;
    let mut worst = 0.0f64;
    for (c, col) in cols.iter().enumerate() {
        let (want, got) = (expected(c), col / l);
        let bound = 5.0 * (want * (1.0 - want) / n).sqrt() + 1e-4;
        eprintln!("{what}: column {c}: {got:.4} expected {want:.4} (bound {bound:.4})");
        assert!((got - want).abs() <= bound, "{what}: column {c} is {got}, expected {want} ± {bound}");
        worst = worst.max((got - want).abs());
    }
    // The blur is really there: partial columns between the fully open and fully covered.
    assert!((0..W).filter(|&c| expected(c) > 0.05 && expected(c) < 0.95).count() >= 10);
    eprintln!("{what}: largest column error {worst:.5}");
}

const SPP: usize = 256;

fn render(scene: &Path, out: &Path, extra: &[&str]) -> Vec<[f32; 4]> {
    let spp = SPP.to_string();
    let mut args =
        vec!["--resolution", "32x32", "--spp", &spp, "--filter", "box", "--filter-width", "1", "--max-depth", "1"];
    args.extend_from_slice(extra);
    render_image(scene, out, &args, LIMIT)
}

#[test]
fn a_moving_quad_blurs_by_its_share_of_the_shutter() {
    let dir = temp_dir();
    let d = dir.path();
    let s = scene(d, "quad.gltf", Some(blur()), Some(sliding(SPEED)), None);
    assert_matches(&render(&s, &d.join("path.exr"), &[]), SPP, "path");
    assert_matches(&render(&s, &d.join("bdpt.exr"), &["--integrator", "bdpt"]), SPP, "bdpt");
}

#[test]
fn a_moving_camera_blurs_a_still_quad_alike() {
    let dir = temp_dir();
    let d = dir.path();
    let s = scene(d, "camera.gltf", Some(blur()), None, Some(sliding(-SPEED)));
    assert_matches(&render(&s, &d.join("path.exr"), &[]), SPP, "camera");
}

/// A shutter over nothing that moves (every matrix the frame's) renders the static
/// image bit for bit: no time is drawn, no motion BVH is built.
#[test]
fn still_steps_change_nothing() {
    let dir = temp_dir();
    let d = dir.path();
    let still = json!({"matrix": translation(0.0), "matrices": [translation(0.0), translation(0.0)]});
    let a = scene(d, "a.gltf", None, None, None);
    let b = scene(d, "b.gltf", Some(blur()), Some(still), None);
    let (pa, pb) = (render(&a, &d.join("a.exr"), &[]), render(&b, &d.join("b.exr"), &[]));
    assert!(pa.iter().zip(&pb).all(|(x, y)| x.map(f32::to_bits) == y.map(f32::to_bits)));
}

/// The Vector pass without motion blur (steps at the neighbouring frames): the quad moves
/// SPEED units per frame at depth 2, i.e. SPEED / (2 tan(yfov/2)) × 16 pixels, to the right,
/// which Cycles writes as −that in X (previous − here) and Z (here − next); the still
/// emitter has no motion.
#[test]
fn vector_pass_gives_the_motion_in_pixels() {
    let dir = temp_dir();
    let d = dir.path();
    let steps = json!({"times": [-1.0, 0.0, 1.0]});
    let s = SPEED as f32;
    let quad = json!({"matrix": translation(0.0), "matrices": [translation(-s), translation(0.0), translation(s)]});
    let sc = scene(d, "v.gltf", Some(steps), Some(quad), None);
    let out = d.join("v.exr");
    render(&sc, &out, &["--passes", "vector"]);
    let image = exr::prelude::read_all_flat_layers_from_file(&out).expect("read EXR");
    let layer = &image.layer_data[0];
    let ch = |n: &str| -> Vec<f32> {
        let c = layer.channel_data.list.iter().find(|c| c.name.to_string() == n).unwrap_or_else(|| panic!("no {n}"));
        c.sample_data.values_as_f32().collect()
    };
    let (x, y, z, w) = (ch("Vector.X"), ch("Vector.Y"), ch("Vector.Z"), ch("Vector.W"));
    let px_per_unit = W as f64 / 2.0 / (2.0 * (0.5 * YFOV as f64).tan());
    let want = -SPEED * px_per_unit;
    // Columns wholly on the quad at the frame (|x| < HALF) and wholly off it.
    let inside: Vec<usize> =
        (0..W).filter(|&c| plane_x(c as f64).abs() < HALF && plane_x(c as f64 + 1.0).abs() < HALF).collect();
    let outside: Vec<usize> = (0..W).filter(|&c| plane_x(c as f64).min(plane_x(c as f64 + 1.0)) > HALF).collect();
    assert!(!inside.is_empty() && !outside.is_empty());
    for r in 8..24 {
        for &c in &inside {
            let i = r * W + c;
            // Float rounding of the projection only: 1e-4 of the motion.
            for (v, e) in [(x[i], want), (z[i], want), (y[i], 0.0), (w[i], 0.0)] {
                assert!((v as f64 - e).abs() < 1e-4 * want.abs(), "pixel ({c}, {r}): {v} expected {e}");
            }
        }
        for &c in &outside {
            let i = r * W + c;
            assert_eq!([x[i], y[i], z[i], w[i]], [0.0; 4], "the emitter does not move");
        }
    }
}

/// Bad `CAUSTIC_motion` is refused as a bad scene (exit 3) naming what is wrong.
#[test]
fn bad_motion_is_refused() {
    let dir = temp_dir();
    let d = dir.path();
    let cases = [
        ("descending", json!({"times": [0.5, -0.5]}), sliding(SPEED), "ascending"),
        ("one_step", json!({"times": [0.0]}), sliding(SPEED), "step times"),
        (
            "count",
            blur(),
            json!({"matrix": translation(0.0), "matrices": [translation(0.0)]}),
            "1 matrices for 2 step times",
        ),
        (
            "singular",
            blur(),
            json!({"matrix": translation(0.0), "matrices": [translation(0.0), vec![0.0f32; 16]]}),
            "invertible",
        ),
        (
            "shutter",
            json!({"times": [0.0, 1.0], "shutter": {"open": 1.0, "close": 0.0}}),
            sliding(SPEED),
            "open <= close",
        ),
    ];
    for (name, scene_motion, node_motion, says) in cases {
        let s = scene(d, &format!("{name}.gltf"), Some(scene_motion), Some(node_motion), None);
        let out = d.join(format!("{name}.exr"));
        let r = run(&["render", s.to_str().unwrap(), "-o", out.to_str().unwrap(), "--spp", "1"], LIMIT);
        assert_eq!(r.code, Some(3), "{name}: {}", r.stderr);
        assert!(r.stderr.contains(says), "{name}: {}", r.stderr);
    }
    // Node motion without the scene's step times.
    let s = scene(d, "orphan.gltf", None, Some(sliding(SPEED)), None);
    let r = run(&["render", s.to_str().unwrap(), "-o", d.join("o.exr").to_str().unwrap(), "--spp", "1"], LIMIT);
    assert_eq!(r.code, Some(3), "{}", r.stderr);
}

/// SPPM's visible points take the camera sample's time: the moving quad and the moving
/// camera blur as in the path tracer (max depth 1: what the camera sees, by the closed form).
#[test]
fn sppm_blurs_a_moving_quad_and_a_moving_camera() {
    let dir = temp_dir();
    let d = dir.path();
    let s = scene(d, "quad.gltf", Some(blur()), Some(sliding(SPEED)), None);
    assert_matches(&render(&s, &d.join("sppm.exr"), &["--integrator", "sppm"]), SPP, "sppm quad");
    let s = scene(d, "camera.gltf", Some(blur()), None, Some(sliding(-SPEED)));
    assert_matches(&render(&s, &d.join("sppm_cam.exr"), &["--integrator", "sppm"]), SPP, "sppm camera");
}

/// Photons fly at times over the shutter. A sun shines straight down on a white floor; a
/// white ceiling (x, z in −1..1, y = 2) shades the floor beneath it, and the camera under it
/// looks up at its underside, which only the floor's bounce lights (max depth 2). A black
/// strip at y = 3 shades the floor band x = −1.5..1.5 at the frame, but over the shutter
/// (times ½..1) it has slid to x = 1..6.5. The path tracer sees that (next-event estimation at
/// the sample's time); photon maps traced at the frame give 0.60 of its light (measured when
/// this was written). Jensen's and SPPM's means must agree with the path tracer's (Welch,
/// `common::agreement`).
#[test]
fn photons_see_an_occluder_where_it_is_during_the_shutter() {
    use common::agreement::{Seeded, regions, sidak};
    let dir = temp_dir();
    let d = dir.path();
    let mut g = GltfBuilder::new();
    let white =
        g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0}}));
    let black = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0}}));
    let plane = |g: &mut GltfBuilder, x0: f32, x1: f32, z: f32, y: f32, m: usize| {
        g.mesh(&[[x0, y, -z], [x1, y, -z], [x1, y, z], [x0, y, z]], &[0, 2, 1, 0, 3, 2], m)
    };
    plane(&mut g, -10.0, 10.0, 10.0, 0.0, white);
    plane(&mut g, -1.0, 1.0, 1.0, 2.0, white);
    let strip = plane(&mut g, -1.5, 1.5, 10.0, 3.0, black);
    g.punctual(
        json!({"type": "directional", "intensity": 683.0}),
        [0.0, 5.0, 0.0],
        common::look_rotation([0.0, -1.0, 0.0]),
    );
    g.camera([0.0, 1.0, 0.0], common::look_rotation([0.0, 1.0, 0.001]), 0.5);
    g.scene_ext("CAUSTIC_motion", json!({"times": [0.0, 1.0], "shutter": {"open": 0.5, "close": 1.0}}));
    g.node_ext(
        strip,
        "CAUSTIC_motion",
        json!({"matrix": translation(0.0), "matrices": [translation(0.0), translation(5.0)]}),
    );
    let s = g.write(d, "strip.gltf");
    let regions = regions(8, 8);
    let seeded = Seeded {
        dir: d,
        common: vec!["--resolution", "8x8", "--max-depth", "2"],
        seeds: 6,
        regions: &regions[..1],
        limit: LIMIT,
    };
    let path = seeded.means(&s, &["--spp", "256"]);
    let others: [(&str, &[&str]); 2] = [
        ("photon", &["--integrator", "photon", "--spp", "64", "--photons", "400000"]),
        ("sppm", &["--integrator", "sppm", "--spp", "64", "--sppm-photons", "20000"]),
    ];
    let failed = seeded.disagreeing_others(&s, &path, &others, sidak(2));
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}
