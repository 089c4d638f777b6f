//! The camera's lens shift and thin lens (`CAUSTIC_camera`), end to end.
//!
//! Depth of field is checked against geometric optics: a point at depth z seen through an
//! aperture of radius a focused at depth f images to a uniformly lit copy of the aperture, of
//! radius a |1/f - 1/z| on the image plane at distance 1 (similar triangles), and the lens
//! moves light around without creating or losing any (every aperture point sees the same
//! source). The shift moves the frame on the image plane: a shifted frame shows
//! what the unshifted frame shows next to it. The clipping planes (glTF znear/zfar,
//! Blender's Clip Start/End) hide what lies nearer or farther, in every integrator.

mod common;

use common::{GltfBuilder, render_image, run, temp_dir};
use serde_json::{Value, json};
use std::path::Path;
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);
const W: usize = 96;
const YFOV: f32 = 0.5;

fn render(scene: &Path, out: &Path, extra: &[&str]) -> Vec<[f32; 4]> {
    render_image(scene, out, extra, LIMIT)
}

/// A small emissive square (side `side`, radiance 1) at depth `z` on the axis of a camera
/// at the origin looking down -Z, with `ext` as its CAUSTIC_camera (None: pinhole).
fn point_source(dir: &Path, name: &str, z: f32, side: f32, ext: Option<Value>) -> std::path::PathBuf {
    let mut g = GltfBuilder::new();
    let m = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}, "emissiveFactor": [1, 1, 1]}));
    let h = 0.5 * side;
    g.mesh(&[[-h, -h, -z], [h, -h, -z], [h, h, -z], [-h, h, -z]], &[0, 1, 2, 0, 2, 3], m);
    let cam = g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], YFOV);
    if let Some(e) = ext {
        g.camera_ext(cam, e);
    }
    g.write(dir, name)
}

/// Image-plane units (distance 1) per pixel.
fn plane_per_pixel() -> f32 {
    2.0 * (0.5 * YFOV).tan() / W as f32
}

/// Sum of the image (red channel) and its second central moments (Mxx, Myy) in pixels².
fn flux_and_moments(px: &[[f32; 4]]) -> (f64, f64, f64) {
    let at = |i: usize| ((i % W) as f64 + 0.5, (i / W) as f64 + 0.5, px[i][0] as f64);
    let sum: f64 = (0..px.len()).map(|i| at(i).2).sum();
    let (mx, my) = (0..px.len()).fold((0.0, 0.0), |(a, b), i| {
        let (x, y, v) = at(i);
        (a + x * v / sum, b + y * v / sum)
    });
    let (vxx, vyy) = (0..px.len()).fold((0.0, 0.0), |(a, b), i| {
        let (x, y, v) = at(i);
        (a + (x - mx).powi(2) * v / sum, b + (y - my).powi(2) * v / sum)
    });
    (sum, vxx, vyy)
}

/// Depth of field blurs a small source by the aperture's shape at the predicted size, and
/// the lens moves light without creating or losing any; for a round aperture, a hexagonal
/// one and an anamorphic one. The blurred image is the sharp image convolved with the
/// aperture's image (radius c on the film), so second moments add: per axis, Mxx(blurred) =
/// Mxx(sharp) + c² E[x²] over the unit aperture (1/4 for a disk; (2 + cos 2π/n)/12 for a
/// regular n-gon of circumradius 1, from its n triangles; x divided by the anamorphic ratio).
/// Bounds: the moments within 4 % (their measured error is under 1 %); the flux within 1.5 %,
/// about 4.5 standard deviations: a blurred pixel's sample sees the source with probability
/// p ≈ 0.2, so over N ≈ 256 spp × 1400 lit pixels the sum's relative deviation is
/// √((1 - p) / (p N)) ≈ 0.33 % (the pinhole image's sum is nearly exact).
#[test]
fn depth_of_field_blurs_by_the_aperture() {
    let dir = temp_dir();
    let (z, focus, aperture) = (4.0f32, 2.0f32, 0.25f32);
    let side = 0.2;
    let c = (aperture * (1.0 / focus - 1.0 / z) / plane_per_pixel()) as f64; // aperture image radius, px
    assert!(c > 8.0 && c < 30.0, "test geometry: blur radius {c} px");
    let args = ["--resolution", "96x96", "--spp", "256", "--filter", "box", "--filter-width", "1", "--max-depth", "1"];
    let pin = render(&point_source(dir.path(), "pin.gltf", z, side, None), &dir.path().join("pin.exr"), &args);
    let (flux_pin, xx_pin, yy_pin) = flux_and_moments(&pin);
    let hex = (2.0 + (std::f64::consts::PI / 3.0).cos()) / 12.0;
    for (label, ext, ex2, ey2) in [
        ("round", json!({"aperture_radius": aperture, "focus_distance": focus}), 0.25, 0.25),
        (
            "hexagon",
            json!({"aperture_radius": aperture, "focus_distance": focus, "blades": 6, "blade_rotation": 0.3}),
            hex,
            hex,
        ),
        (
            "anamorphic 2",
            json!({"aperture_radius": aperture, "focus_distance": focus, "aperture_ratio": 2.0}),
            0.25 / 4.0,
            0.25,
        ),
    ] {
        let scene = point_source(dir.path(), "dof.gltf", z, side, Some(ext));
        let px = render(&scene, &dir.path().join("dof.exr"), &args);
        let (flux, xx, yy) = flux_and_moments(&px);
        let (pxx, pyy) = (xx_pin + c * c * ex2, yy_pin + c * c * ey2);
        eprintln!("{label}: Mxx {xx:.2} (predicted {pxx:.2}), Myy {yy:.2} ({pyy:.2}), flux {flux:.3} vs {flux_pin:.3}");
        assert!((xx / pxx - 1.0).abs() < 0.04 && (yy / pyy - 1.0).abs() < 0.04, "{label}: blur has the wrong size");
        assert!((flux / flux_pin - 1.0).abs() < 0.015, "{label}: the lens changed the flux");
    }
    // Bidirectional: light tracing alone (strategy s = 1, t = 1: a point on the source
    // connected to the camera subpath's aperture point, splatted where that ray crosses the
    // plane in focus) and all strategies together blur by the same aperture.
    let scene = point_source(
        dir.path(),
        "dof.gltf",
        z,
        side,
        Some(json!({"aperture_radius": aperture, "focus_distance": focus})),
    );
    for strategy in [&["--bdpt-strategy", "1,1,unweighted"][..], &[]] {
        let mut a = args.to_vec();
        a[3] = "64";
        a.extend_from_slice(&["--integrator", "bdpt"]);
        a.extend_from_slice(strategy);
        let (flux, xx, yy) = flux_and_moments(&render(&scene, &dir.path().join("bdpt.exr"), &a));
        let p = xx_pin + c * c * 0.25;
        eprintln!("bdpt {strategy:?}: Mxx {xx:.2} Myy {yy:.2} (predicted {p:.2}), flux {flux:.3} vs {flux_pin:.3}");
        assert!((xx / p - 1.0).abs() < 0.04 && (yy / p - 1.0).abs() < 0.04, "bdpt {strategy:?}: wrong blur");
        assert!((flux / flux_pin - 1.0).abs() < 0.015, "bdpt {strategy:?}: the lens changed the flux");
    }
    // SPPM makes its own camera rays.
    let mut a = args.to_vec();
    a.extend_from_slice(&["--integrator", "sppm", "--sppm-iterations", "256"]);
    let (flux, xx, yy) = flux_and_moments(&render(&scene, &dir.path().join("sppm.exr"), &a));
    let p = xx_pin + c * c * 0.25;
    eprintln!("sppm: Mxx {xx:.2} Myy {yy:.2} (predicted {p:.2}), flux {flux:.3} vs {flux_pin:.3}");
    assert!((xx / p - 1.0).abs() < 0.04 && (yy / p - 1.0).abs() < 0.04, "sppm: wrong blur");
    assert!((flux / flux_pin - 1.0).abs() < 0.015, "sppm: the lens changed the flux");
    // In focus, the source stays as sharp as through a pinhole.
    let sharp = point_source(
        dir.path(),
        "sharp.gltf",
        z,
        side,
        Some(json!({"aperture_radius": aperture, "focus_distance": z})),
    );
    let (_, xx, yy) = flux_and_moments(&render(&sharp, &dir.path().join("sharp.exr"), &args));
    eprintln!("in focus: Mxx {xx:.2} Myy {yy:.2} vs pinhole {xx_pin:.2} {yy_pin:.2}");
    assert!((xx / xx_pin - 1.0).abs() < 0.04 && (yy / yy_pin - 1.0).abs() < 0.04, "in focus but blurred");
}

/// A frame shifted by half its width shows the right half of the unshifted frame on its
/// left half. The scene is emission only with a box filter, so the images are exact up to
/// anti-aliasing at edges.
#[test]
fn shift_moves_the_frame() {
    let dir = temp_dir();
    let build = |ext: Option<Value>, name: &str| {
        let mut g = GltfBuilder::new();
        for (i, x) in [-1.2f32, -0.4, 0.3, 0.9, 1.6].iter().enumerate() {
            let c = 0.2 + 0.2 * i as f32;
            let m = g.material(
                json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}, "emissiveFactor": [c, 1.0 - c, 0.5]}),
            );
            g.cube([x - 0.15, -0.3 + 0.1 * i as f32, -5.0], [x + 0.15, 0.2 + 0.1 * i as f32, -4.7], m);
        }
        let cam = g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], YFOV);
        if let Some(e) = ext {
            g.camera_ext(cam, e);
        }
        g.write(dir.path(), name)
    };
    let args = ["--resolution", "96x96", "--spp", "64", "--filter", "box", "--filter-width", "1"];
    let base = render(&build(None, "a.gltf"), &dir.path().join("a.exr"), &args);
    for (sx, sy) in [(0.5f32, 0.0f32), (0.0, -0.25)] {
        let shifted = render(&build(Some(json!({"shift": [sx, sy]})), "b.gltf"), &dir.path().join("b.exr"), &args);
        let (dx, dy) = ((sx * W as f32) as i64, (-sy * W as f32) as i64);
        let (mut diff, mut n, mut lit) = (0f64, 0usize, 0f64);
        for y in 0..W as i64 {
            for x in 0..W as i64 {
                let (bx, by) = (x + dx, y + dy);
                if !(0..W as i64).contains(&bx) || !(0..W as i64).contains(&by) {
                    continue;
                }
                let a = shifted[(y * W as i64 + x) as usize];
                let b = base[(by * W as i64 + bx) as usize];
                diff += (0..3).map(|c| (a[c] - b[c]).abs() as f64).sum::<f64>();
                lit += (0..3).map(|c| b[c] as f64).sum::<f64>();
                n += 1;
            }
        }
        eprintln!("shift ({sx}, {sy}): mean |diff| {:.5}, mean value {:.5}", diff / n as f64, lit / n as f64);
        assert!(lit > 0.0, "nothing visible in the overlap");
        // Anti-aliased edge pixels differ by sampling noise only: well under 2 % of the light.
        assert!(diff < 0.02 * lit, "shift ({sx}, {sy}): the shifted frame is not the moved frame");
    }
}

/// Bad CAUSTIC_camera values are refused with a message naming the camera.
#[test]
fn camera_extension_errors() {
    let dir = temp_dir();
    for (ext, word) in [
        (json!({"aperture_radius": -1.0}), "aperture_radius"),
        (json!({"aperture_radius": 0.1, "focus_distance": 0.0}), "focus_distance"),
        (json!({"aperture_radius": 0.1, "blades": 2}), "blades"),
        (json!({"aperture_radius": 0.1, "aperture_ratio": 0.0}), "aperture_ratio"),
        (json!({"focus_distance": 3.0}), "aperture_radius"),
        (json!({"shift": [1e9, 0.0]}), "shift"),
        (json!({"zoom": 2.0}), "malformed"),
    ] {
        let scene = point_source(dir.path(), "bad.gltf", 3.0, 0.1, Some(ext.clone()));
        let out = dir.path().join("bad.exr");
        let r = run(
            &["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--spp", "1", "--progress", "json"],
            LIMIT,
        );
        assert_eq!(r.code, Some(3), "{ext}: {}", r.stderr);
        let msg = r.error_message().unwrap_or_default();
        assert!(msg.contains(word) && msg.contains("camera"), "{ext}: {msg}");
        assert!(!out.exists(), "{ext}: an output was written");
    }
}

/// `caustic info` says what the camera extension set.
#[test]
fn info_reports_shift_and_depth_of_field() {
    let dir = temp_dir();
    let ext = json!({"shift": [0.25, 0.0], "aperture_radius": 0.02, "focus_distance": 3.5, "blades": 6});
    let scene = point_source(dir.path(), "info.gltf", 3.0, 0.1, Some(ext));
    let r = run(&["info", scene.to_str().unwrap()], LIMIT);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let text = format!("{}{}", r.stdout, r.stderr);
    assert!(
        text.contains("shift 0.25 x 0 frames") && text.contains("aperture radius 0.02, focus 3.5, 6 blades"),
        "{text}"
    );
}

/// An emissive plane (radiance 1) at depth 2 behind a black occluder at depth 0.05, under a
/// world of radiance 0.25: with znear 0.1 the occluder is clipped away and every pixel sees
/// the plane (exactly 1: no light reaches the black occluder's side the camera sees); with
/// zfar 1.5 as well, the plane is clipped too and every pixel sees the world (0.25). In
/// every integrator — BDPT's light-tracing strategy connects to the camera through the
/// same planes.
#[test]
fn clipping_planes_hide_what_lies_outside_them() {
    let dir = temp_dir();
    for (znear, zfar, expected) in [(0.1f32, None, 1.0f32), (0.1, Some(1.5f32), 0.25)] {
        let mut g = GltfBuilder::new();
        let light =
            g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}, "emissiveFactor": [1, 1, 1]}));
        let black =
            g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0}}));
        let quad = |z: f32, h: f32| [[-h, -h, -z], [h, -h, -z], [h, h, -z], [-h, h, -z]];
        g.mesh(&quad(2.0, 10.0), &[0, 1, 2, 0, 2, 3], light);
        g.mesh(&quad(0.05, 1.0), &[0, 1, 2, 0, 2, 3], black);
        g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], YFOV);
        g.world(json!({"color": [0.25, 0.25, 0.25]}));
        let mut path = g.write(dir.path(), "clip.gltf");
        // Set the clipping planes in the written file.
        let mut doc: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        doc["cameras"][0]["perspective"]["znear"] = json!(znear);
        if let Some(f) = zfar {
            doc["cameras"][0]["perspective"]["zfar"] = json!(f);
        }
        // The camera sees the world (Film → Transparent off).
        doc["scenes"][0]["extras"] = json!({"caustic": {"transparent": false}});
        path = dir.path().join("clip_planes.gltf");
        std::fs::write(&path, doc.to_string()).unwrap();
        for integrator in ["path", "bdpt", "photon", "sppm"] {
            let img = render(
                &path,
                &dir.path().join(format!("{integrator}.exr")),
                &["--resolution", "8x8", "--spp", "4", "--integrator", integrator, "--max-depth", "4"],
            );
            // BDPT adds light-tracing splats (random) to the camera paths' exact value, so
            // its pixels are estimates: the image mean is checked to 5 standard errors of
            // the pixel mean (plus f32 rounding, 1e-4); the others are exact and then have
            // a standard error of 0. A clipping error is off by 0.75 or more.
            let v: Vec<f64> = img.iter().map(|p| p[0] as f64).collect();
            let (mean, se) = common::mean_se(&v);
            assert!(
                (mean - expected as f64).abs() <= 5.0 * se + 1e-4,
                "{integrator}, znear {znear}, zfar {zfar:?}: the image is {mean} ± {se} where {expected} is expected"
            );
        }
    }
}

/// Clipping planes that cannot be (negative znear, zfar not beyond znear) are refused.
#[test]
fn bad_clipping_planes_are_refused() {
    let dir = temp_dir();
    for (znear, zfar) in [(0.5f32, 0.5f32), (2.0, 1.0)] {
        let path = point_source(dir.path(), "bad_clip.gltf", 2.0, 1.0, None);
        let mut doc: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        doc["cameras"][0]["perspective"]["znear"] = json!(znear);
        doc["cameras"][0]["perspective"]["zfar"] = json!(zfar);
        std::fs::write(&path, doc.to_string()).unwrap();
        let out = dir.path().join("o.exr");
        let r = run(&["render", path.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"], LIMIT);
        assert_eq!(r.code, Some(3), "znear {znear}, zfar {zfar}: {}", r.stderr);
        assert!(r.error_message().unwrap().contains("znear"), "{}", r.stderr);
    }
}
