//! Surfaces in contact: a smooth glass cube resting on a black floor, its bottom face in the
//! floor's plane, in a uniform white world of radiance L, seen straight down through its top.
//!
//! Light that enters the top can only leave through the bottom onto the floor, which absorbs
//! it, or back through the top after reflecting off the bottom face. So a pixel is at most
//! F0 L (the top's reflection) plus (1 - F0)² F0 L Σ (F0²)^k (the bottom's reflections going
//! back out) < 2 F0 L. A ray leaving through the bottom used to start its next segment offset
//! below the floor (`math::offset_ray_origin`) and see the world under it: a pixel of about
//! L. Cycles lands on the floor (it skips only the primitive the ray left); Caustic's walk
//! looks back across the surface it leaves (`PathState::coincident_hit`).

mod common;

use common::{GltfBuilder, look_rotation, render_image, temp_dir};
use serde_json::json;
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);

/// Radiance of the world.
const L: f64 = 0.8;

/// The cube [-0.5, 0.5]² × [0, 1] on the floor z = 0, faces wound outwards; the camera at
/// z = 3 looking down with a field of view inside the top face.
fn contact_scene(dir: &std::path::Path) -> std::path::PathBuf {
    let mut g = GltfBuilder::new();
    g.use_ext("KHR_materials_transmission");
    g.use_ext("KHR_materials_volume");
    g.use_ext("KHR_materials_specular");
    let glass = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                       "KHR_materials_volume": {"thicknessFactor": 1.0}}
    }));
    // Black and without a specular layer: the floor returns nothing.
    let black = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}
    }));
    let s = 20.0;
    g.mesh(&[[-s, -s, 0.0], [s, -s, 0.0], [s, s, 0.0], [-s, s, 0.0]], &[0, 1, 2, 0, 2, 3], black);
    let c: Vec<[f32; 3]> = (0..8)
        .map(|i| [if i & 1 == 0 { -0.5 } else { 0.5 }, if i & 2 == 0 { -0.5 } else { 0.5 }, (i >> 2) as f32])
        .collect();
    // Each face's corners counter-clockwise seen from outside.
    let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let idx: Vec<u32> = quads.iter().flat_map(|q| [q[0], q[1], q[2], q[0], q[2], q[3]]).collect();
    g.mesh(&c, &idx, glass);
    g.camera([0.0, 0.0, 3.0], look_rotation([0.0, 0.0, -1.0]), 0.2);
    g.world(json!({"color": [L, L, L]}));
    g.settings(json!({"transparent": false}));
    g.write(dir, "contact.gltf")
}

/// The path tracer walks `PathState::advance`,
/// recording the triangle left, and looks back (SPPM and Jensen record it after their own
/// bounces, not after `follow_specular`; BDPT does not yet; photon tracing follows the trap
/// this makes, mirrored: `photon/contact.rs`, tests/photon_contact.rs).
#[test]
fn light_leaving_a_glass_through_a_face_on_the_floor_lands_on_the_floor() {
    let dir = temp_dir();
    let scene = contact_scene(dir.path());
    // F0 of IOR 1.5; within 8° of normal incidence (the view's half-diagonal, 0.1 √2 rad)
    // Fresnel stays within 1e-4 of it.
    let f0 = ((1.5f64 - 1.0) / (1.5 + 1.0)).powi(2);
    let bound = (f0 + 1e-4) * L + f0 * L / (1.0 - f0 * f0);
    let out = dir.path().join("path.exr");
    let px = render_image(
        &scene,
        &out,
        &["--integrator", "path", "--resolution", "8x8", "--spp", "16", "--max-depth", "8"],
        LIMIT,
    );
    let worst = px.iter().flat_map(|p| p[..3].iter()).map(|&c| c as f64).fold(0.0, f64::max);
    eprintln!("brightest pixel {worst:.4} (bound {bound:.4}, a leak below the floor ~{L})");
    assert!(worst <= bound, "a pixel of {worst} > {bound}: light left the glass below the floor");
}
