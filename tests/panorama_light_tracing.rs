//! BDPT's and VCM's light tracing (t = 1) through panoramic cameras
//! (`scene::panorama::Panorama::inverse` and `density`, `CameraRays::project`).
//!
//! A grey room lit by an emissive panel on its ceiling, seen from its middle by an
//! equirectangular camera (the whole sphere: every wall, the seam at the back) and by an
//! equidistant fisheye looking at a corner. Every diffuse vertex a light subpath reaches is
//! splatted onto the film through the inverse mapping with the importance W·H·density, and
//! weighed by MIS against the camera strategies with the same density; an error in either
//! (a wrong Jacobian, a splat at the wrong pixel, a missing seam copy) moves the image away
//! from the path tracer's, which never projects. Light tracing carries a large share of
//! these paths (the panel lights the room's diffuse walls directly), so a density off by a
//! few per cent shows in every region.
//!
//! The fisheye's circle leaves the frame's corners blind: those camera samples still trace
//! and splat their light subpaths (`BdptIntegrator::li_blind`), since splats are normalised
//! by every camera sample; without that BDPT and VCM gave 0.84 of the path tracer here
//! (light tracing alone π/4 of next-event estimation's image).
//!
//! Bounds (`common::agreement`): six seeds per estimate, Welch's test per region, Šidák's
//! split over both integrators, both cameras and every region. VCM's merging blurs indirect
//! light by its radius (0.02 in a room 4 units across), far below a region's noise bound.

mod common;

use common::GltfBuilder;
use common::agreement::{Seeded, regions, sidak};
use common::temp_dir;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);

/// The room of the module doc, seen by the panoramic camera `panorama` from `pos` with
/// node rotation `rotation`.
fn room(dir: &Path, name: &str, panorama: Value, pos: [f32; 3], rotation: [f32; 4]) -> PathBuf {
    let mut g = GltfBuilder::new();
    g.use_ext("KHR_materials_emissive_strength");
    let grey = g.material(
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1], "metallicFactor": 0.0}, "doubleSided": true}),
    );
    let red = g.material(
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.2, 0.1, 1], "metallicFactor": 0.0}, "doubleSided": true}),
    );
    let panel = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0},
        "emissiveFactor": [1, 0.9, 0.8], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 8.0}}
    }));
    let (s, h) = (2.0f32, 3.0f32);
    // Floor, ceiling and four walls (double-sided), one wall red so that regions differ.
    g.mesh(&[[-s, 0.0, -s], [s, 0.0, -s], [s, 0.0, s], [-s, 0.0, s]], &[0, 2, 1, 0, 3, 2], grey);
    g.mesh(&[[-s, h, -s], [s, h, -s], [s, h, s], [-s, h, s]], &[0, 1, 2, 0, 2, 3], grey);
    g.mesh(&[[-s, 0.0, -s], [s, 0.0, -s], [s, h, -s], [-s, h, -s]], &[0, 1, 2, 0, 2, 3], red);
    g.mesh(&[[-s, 0.0, s], [s, 0.0, s], [s, h, s], [-s, h, s]], &[0, 2, 1, 0, 3, 2], grey);
    g.mesh(&[[-s, 0.0, -s], [-s, 0.0, s], [-s, h, s], [-s, h, -s]], &[0, 2, 1, 0, 3, 2], grey);
    g.mesh(&[[s, 0.0, -s], [s, 0.0, s], [s, h, s], [s, h, -s]], &[0, 1, 2, 0, 2, 3], grey);
    // The panel just under the ceiling, facing down, off centre.
    let (y, x0, x1, z0, z1) = (h - 0.01, -0.9, 0.1, -0.6, 0.4);
    g.mesh(&[[x0, y, z0], [x1, y, z0], [x1, y, z1], [x0, y, z1]], &[0, 1, 2, 0, 2, 3], panel);
    let cam = g.node(json!({"translation": pos, "rotation": rotation}));
    g.camera_ext(cam, json!({"panorama": panorama}));
    g.write(dir, name)
}

/// BDPT and VCM, whose light tracing projects through the panorama, agree with the path
/// tracer under an equirectangular and an equidistant fisheye camera.
#[test]
fn bidirectional_light_tracing_through_panoramas_matches_the_path_tracer() {
    use std::f32::consts::{FRAC_PI_2, PI};
    let dir = temp_dir();
    let equirect = room(
        dir.path(),
        "equirect.gltf",
        json!({"type": "equirectangular", "latitude": [-FRAC_PI_2, FRAC_PI_2], "longitude": [-PI, PI]}),
        [0.3, 1.4, 0.2],
        [0.0, 0.0, 0.0, 1.0],
    );
    // Turned 30° about y and tilted down 20°: the fisheye's circle holds the corner, the
    // panel and part of the floor; outside it the film is black in every integrator.
    let (a, b) = (15f32.to_radians(), -10f32.to_radians());
    let q = glam::Quat::from_xyzw(0.0, a.sin(), 0.0, a.cos()) * glam::Quat::from_xyzw(b.sin(), 0.0, 0.0, b.cos());
    let fisheye = room(
        dir.path(),
        "fisheye.gltf",
        json!({"type": "fisheye_equidistant", "fov": 3.0}),
        [0.8, 1.2, 1.2],
        q.to_array(),
    );
    let cases = [(&equirect, "32x16", 32, 16), (&fisheye, "24x24", 24, 24)];
    let alpha = sidak(cases.iter().map(|c| regions(c.2, c.3).len()).sum::<usize>() * 2);
    let mut failed = Vec::new();
    for (scene, res, w, h) in cases {
        let regs = regions(w, h);
        let seeded = Seeded::six(dir.path(), res, "4", &regs, LIMIT);
        let reference = seeded.means(scene, &["--integrator", "path", "--spp", "64"]);
        for f in seeded.bidirectional_disagreeing(scene, &reference, "32", "0.02", alpha) {
            failed.push(format!("{}: {f}", scene.display()));
        }
    }
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}
