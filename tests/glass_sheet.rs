//! A single refracting surface, as Cycles renders it: one glass quad with
//! `KHR_materials_volume` (what Blender's exporter writes for a window modelled as a plane)
//! in a uniform white world of radiance L. Cycles refracts at the plane (entering by the
//! geometric normal's side) and its refraction keeps 1 - F of the path's throughput whatever
//! η (its BTDF is η² times the radiance one): reflection sees L above, refraction L below,
//! so every pixel is L. With the radiance convention (a refracted value divided by η²) the
//! sheet came out R + T/η², about 0.47 L at normal incidence for η = 1.5.
//!
//! Every integrator renders the same BSDF: BDPT's light subpaths and the photon tracers use
//! its adjoint (1/η² of a refraction's value), so they must give L too.

mod common;

use common::{GltfBuilder, look_rotation, mean_se, render_image, temp_dir};
use serde_json::json;
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);

/// Radiance of the world.
const L: f64 = 0.7;

/// The sheet of `roughness` facing +Z (its front towards the camera) filling a view that
/// meets it at 0° to about 60° of incidence; written to `dir/name`.
fn sheet_scene(dir: &std::path::Path, name: &str, roughness: f32) -> std::path::PathBuf {
    let mut g = GltfBuilder::new();
    g.use_ext("KHR_materials_transmission");
    g.use_ext("KHR_materials_volume");
    let glass = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": roughness},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                       "KHR_materials_volume": {"thicknessFactor": 1.0}}
    }));
    let s = 40.0;
    g.mesh(&[[-s, -s, 0.0], [s, -s, 0.0], [s, s, 0.0], [-s, s, 0.0]], &[0, 1, 2, 0, 2, 3], glass);
    g.camera([0.0, 0.0, 1.0], look_rotation([0.0, 0.55, -1.0]), 1.0);
    g.world(json!({"color": [L, L, L]}));
    g.settings(json!({"transparent": false}));
    g.write(dir, name)
}

/// The smooth sheet: each camera sample reflects (weight 1) or refracts (weight 1, Cycles'
/// convention) into the world, so every pixel is L up to float rounding, in every integrator.
#[test]
fn a_smooth_single_sheet_in_a_white_world_is_invisible() {
    let dir = temp_dir();
    let scene = sheet_scene(dir.path(), "sheet.gltf", 0.0);
    for integrator in ["path", "bdpt", "photon", "sppm"] {
        let out = dir.path().join(format!("{integrator}.exr"));
        let px = render_image(
            &scene,
            &out,
            &["--integrator", integrator, "--resolution", "16x12", "--spp", "8", "--max-depth", "8"],
            LIMIT,
        );
        let worst = px.iter().flat_map(|p| p[..3].iter()).map(|&c| (c as f64 - L).abs()).fold(0.0, f64::max);
        eprintln!("smooth sheet, {integrator}: worst |pixel - L| = {worst:.2e}");
        // Float rounding of a few products and the film's fixed-point sums: 1e-5 relative.
        assert!(worst <= 1e-5 * L, "{integrator}: a pixel is off L by {worst} (R + T/η² would be ~0.5 L)");
    }
}

/// The rough sheet (roughness 0.5, multiple scattering restored): one interface's albedo is
/// 1 within the glass table's error, entered from the front.
#[test]
fn a_rough_single_sheet_in_a_white_world_keeps_its_light() {
    let dir = temp_dir();
    let scene = sheet_scene(dir.path(), "rough.gltf", 0.5);
    for integrator in ["path", "bdpt"] {
        let out = dir.path().join(format!("{integrator}.exr"));
        let px = render_image(
            &scene,
            &out,
            &["--integrator", integrator, "--resolution", "16x12", "--spp", "64", "--max-depth", "8"],
            LIMIT,
        );
        let v: Vec<f64> = px.iter().map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0).collect();
        let (mean, se) = mean_se(&v);
        // Reflection and refraction both end in the world: the pixel is L times the
        // interface's compensated albedo, whose 1/E is off by at most the glass table's
        // error (`bsdf::glass_albedo::GLASS_TABLE_ERROR`, 1 %), once per path.
        let bound = 5.0 * se + L * caustic::bsdf::glass_albedo::GLASS_TABLE_ERROR as f64;
        eprintln!("rough sheet, {integrator}: mean {mean:.5} ± {se:.5}, expected {L}, bound {bound:.5}");
        assert!((mean - L).abs() <= bound, "{integrator}: {mean} vs {L}");
    }
}
