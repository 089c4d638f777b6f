//! Film → Transparent Glass (`transparent_glass` in the scene settings) in a scene whose
//! answer is known without rendering: a smooth glass pane of IOR 1.5 (glTF transmission
//! without a volume: a thin sheet) filling the view of a camera at the origin looking down
//! -Z, in a constant grey world.
//!
//! A camera path is reflected by the sheet with probability R = 2F / (1 + F) (Fresnel's F
//! summed over the sheet's inner reflections: 0.0769 at normal incidence, at most 0.0774 at
//! the frame's corners, 19.9° off axis) and passes straight through otherwise, meeting the
//! world: under the rule that share stays transparent and adds no world to Combined, while the
//! reflection sees the world by a reflection, which is opaque. So alpha's mean is R and
//! Combined's the world times R, where without the setting alpha is 1 and Combined the world.

mod common;

use common::{GltfBuilder, quick_render_warnings, render_image, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);
const WORLD: f32 = 0.5;
/// The sheet's reflectance at normal incidence, and its largest value in the frame.
const R0: f64 = 0.076923;
const R_CORNER: f64 = 0.077400;

fn scene(dir: &Path, name: &str, settings: Value) -> PathBuf {
    let mut g = GltfBuilder::new();
    let glass = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5}}
    }));
    let h = 5.0;
    let p = [[-h, -h, -2.0], [h, -h, -2.0], [h, h, -2.0], [-h, h, -2.0]];
    g.mesh(&p, &[0, 1, 2, 0, 2, 3], glass);
    g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.5);
    g.world(json!({"color": [WORLD, WORLD, WORLD]}));
    g.settings(settings);
    g.write(dir, name)
}

/// Means of (Combined's red, alpha) over the image.
fn means(px: &[[f32; 4]]) -> (f64, f64) {
    let n = px.len() as f64;
    (px.iter().map(|p| p[0] as f64).sum::<f64>() / n, px.iter().map(|p| p[3] as f64).sum::<f64>() / n)
}

const ARGS: [&str; 10] =
    ["--resolution", "32x32", "--spp", "64", "--filter", "box", "--filter-width", "1", "--max-depth", "4"];

/// The share that passes the glass is transparent: alpha's mean is R. Each sample's alpha is
/// 0 or 1 (the reflection is chosen with probability R): over 65536 samples its standard
/// error is at most sqrt(R (1 - R) / 65536) = 1.04e-3; the bound is 5 of them plus R's spread
/// over the frame. Combined is the reflection alone, the world times R, bounded likewise.
/// The same in every integrator (before BDPT, VCM and the photon integrators followed the rule:
/// alpha 1, Combined the world).
#[test]
fn glass_leaves_the_background_transparent() {
    let dir = temp_dir();
    let d = dir.path();
    let s = scene(d, "g.gltf", json!({"transparent": true, "transparent_glass": 0.1}));
    for integrator in ["path", "bdpt", "vcm", "photon", "sppm"] {
        let extra = ["--integrator", integrator, "--sppm-iterations", "64", "--photons", "1000"];
        let args: Vec<&str> = ARGS.iter().copied().chain(extra).collect();
        let (red, alpha) = means(&render_image(&s, &d.join("g.exr"), &args, LIMIT));
        let se = (R_CORNER * (1.0 - R_CORNER) / 65536.0).sqrt();
        let bound = 5.0 * se + (R_CORNER - R0);
        assert!((alpha - R0).abs() < bound, "{integrator}: alpha {alpha} against R {R0} (bound {bound})");
        let world = WORLD as f64;
        assert!(
            (red - world * R0).abs() < world * bound,
            "{integrator}: Combined {red} against {} (bound {})",
            world * R0,
            world * bound
        );
    }
}

/// Without the setting (or with an opaque film, where the add-on does not write it) the
/// glass is opaque: alpha 1 everywhere and Combined the whole world behind and around it.
#[test]
fn without_the_setting_glass_is_opaque() {
    let dir = temp_dir();
    let d = dir.path();
    for (name, settings) in
        [("o.gltf", json!({"transparent": true})), ("f.gltf", json!({"transparent": false, "transparent_glass": 0.1}))]
    {
        let px = render_image(&scene(d, name, settings), &d.join("o.exr"), &ARGS, LIMIT);
        assert!(px.iter().all(|p| (p[3] - 1.0).abs() < 1e-5), "{name}: alpha not 1");
        let (red, _) = means(&px);
        assert!((red - WORLD as f64).abs() < 1e-3, "{name}: Combined {red} against the world {WORLD}");
    }
}

/// Every integrator follows the rule and says nothing of it; a threshold outside [0, 1] is
/// refused.
#[test]
fn no_integrator_warns_and_bad_thresholds_are_refused() {
    let dir = temp_dir();
    let d = dir.path();
    let s = scene(d, "w.gltf", json!({"transparent": true, "transparent_glass": 0.1}));
    for integrator in ["path", "bdpt", "vcm", "photon", "sppm"] {
        let flags = ["--integrator", integrator, "--sppm-iterations", "1", "--photons", "1000"];
        let said: Vec<String> = quick_render_warnings(&s, &d.join("w.exr"), &flags, LIMIT)
            .into_iter()
            .filter(|w| w.contains("Transparent Glass"))
            .collect();
        assert!(said.is_empty(), "{integrator}: {said:?}");
    }
    let bad = scene(d, "b.gltf", json!({"transparent": true, "transparent_glass": 1.5}));
    let out = d.join("b.exr");
    let r = common::run(&["render", bad.to_str().unwrap(), "-o", out.to_str().unwrap()], LIMIT);
    assert_eq!(r.code, Some(2), "{}", r.stderr);
    assert!(r.stderr.contains("transparent_glass"), "{}", r.stderr);
}
