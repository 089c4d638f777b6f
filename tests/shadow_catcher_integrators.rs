//! The shadow catcher in BDPT and VCM (`src/integrator/bdpt/catcher.rs`): with the Shadow
//! Catcher pass asked, Combined (the matte, its alpha less the catcher's share) and the
//! pass converge to the path tracer's, region by region.
//!
//! The scene: a grey floor that is a shadow catcher, a grey box standing on it (no catcher:
//! it stays in the matte, and BDPT's light-tracing splats on it go there too), a low sun
//! and a small area light overhead casting the box's shadows on the floor, a dim world;
//! Film Transparent, indirect light (max depth 3).
//!
//! Bounds (`common::agreement`): K seeds per estimate, Welch's test per region, Šidák's
//! split over every comparison (two integrators, three quantities, five regions). The
//! Shadow Catcher pass is a per-pixel ratio of means, (Combined − matte) / catcher pass;
//! its denominator is the path tracer's walk in every integrator, independent of the
//! numerator, so the ratio's O(1/n) bias is the same for all three and cancels in the
//! comparison to first order. VCM's merging radius is 0.02 on a scene 4 units across (its
//! blur a tenth of the regions' noise bound, as in `linking_integrators.rs`).

mod common;

use common::agreement::{disagreeing, regions, sidak};
use common::{GltfBuilder, run, temp_dir};
use serde_json::json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);
const RES: (usize, usize) = (32, 32);

fn scene(dir: &Path) -> PathBuf {
    let mut g = GltfBuilder::new();
    let grey = g
        .material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1], "metallicFactor": 0.0},
            "doubleSided": true}));
    let floor = g.mesh(
        &[[-2.0, -1.0, -2.0], [2.0, -1.0, -2.0], [2.0, -1.0, -6.0], [-2.0, -1.0, -6.0]],
        &[0, 1, 2, 0, 2, 3],
        grey,
    );
    g.node_ext(floor, "CAUSTIC_object_visibility", json!({"shadow_catcher": true}));
    g.cube([-0.6, -1.0, -4.4], [0.2, -0.2, -3.6], grey);
    g.use_ext("CAUSTIC_lights_area");
    // Facing down: -Z turned by -90° about X.
    let h = std::f32::consts::FRAC_1_SQRT_2;
    g.node(json!({"translation": [0.6, 1.5, -4.0], "rotation": [-h, 0.0, 0.0, h],
        "extensions": {"CAUSTIC_lights_area": {"shape": "square", "size": [0.5, 0.5], "power": 40.0}}}));
    // Low from the left and behind the camera: the box's shadow falls right and back.
    let (sx, sy) = (0.5f32, -0.5f32);
    let c = (1.0 - sx * sx - sy * sy).sqrt();
    g.punctual(
        json!({"type": "directional", "intensity": 300.0}),
        [0.0, 0.0, 0.0],
        common::look_rotation([sx, sy, -c]),
    );
    g.world(json!({"color": [0.1, 0.1, 0.1]}));
    g.settings(json!({"transparent": true}));
    g.camera([0.0, 0.3, 0.0], [0.0, 0.0, 0.0, 1.0], 0.9);
    g.write(dir, "catcher.gltf")
}

fn channels(path: &Path) -> BTreeMap<String, Vec<f32>> {
    let image = exr::prelude::read_all_flat_layers_from_file(path).expect("read EXR");
    let layer = &image.layer_data[0];
    layer.channel_data.list.iter().map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect())).collect()
}

/// Per quantity (Combined's colour, Combined's alpha, the Shadow Catcher pass), per region,
/// the K seeds' region means.
fn means(scene: &Path, dir: &Path, extra: &[&str], regs: &[(String, Vec<usize>)]) -> [Vec<Vec<f64>>; 3] {
    let mut out: [Vec<Vec<f64>>; 3] = std::array::from_fn(|_| vec![Vec::new(); regs.len()]);
    let res = format!("{}x{}", RES.0, RES.1);
    for seed in 0..6u32 {
        let s = (seed * 7919 + 13).to_string();
        let exr = dir.join("r.exr");
        let mut a = vec!["render", scene.to_str().unwrap(), "-o", exr.to_str().unwrap(), "--progress", "json"];
        a.extend_from_slice(&["--resolution", &res, "--max-depth", "3", "--passes", "shadow_catcher", "--seed", &s]);
        a.extend_from_slice(extra);
        let r = run(&a, LIMIT);
        assert_eq!(r.code, Some(0), "{extra:?}: {}", r.stderr);
        assert!(!r.stderr.contains("shadow catcher object(s)"), "{extra:?} warns: {}", r.stderr);
        let ch = channels(&exr);
        let rgb =
            |p: &str, i: usize| ["R", "G", "B"].iter().map(|c| ch[&format!("{p}.{c}")][i] as f64).sum::<f64>() / 3.0;
        for (k, (_, idx)) in regs.iter().enumerate() {
            let mean = |f: &dyn Fn(usize) -> f64| idx.iter().map(|&i| f(i)).sum::<f64>() / idx.len() as f64;
            out[0][k].push(mean(&|i| rgb("Combined", i)));
            out[1][k].push(mean(&|i| ch["Combined.A"][i] as f64));
            out[2][k].push(mean(&|i| rgb("Shadow Catcher", i)));
        }
    }
    out
}

/// BDPT and VCM split at the catcher as the path tracer does.
#[test]
fn bdpt_and_vcm_match_the_path_tracer_on_a_shadow_catcher() {
    let dir = temp_dir();
    let s = scene(dir.path());
    let regs = regions(RES.0, RES.1);
    let reference = means(&s, dir.path(), &["--integrator", "path", "--spp", "64"], &regs);
    let alpha = sidak(2 * 3 * regs.len());
    let others: [(&str, &[&str]); 2] = [
        ("bdpt", &["--integrator", "bdpt", "--spp", "16"]),
        ("vcm", &["--integrator", "vcm", "--spp", "16", "--vcm-radius", "0.02"]),
    ];
    let mut failed = Vec::new();
    for (name, flags) in others {
        let m = means(&s, dir.path(), flags, &regs);
        for (q, label) in ["combined", "alpha", "shadow catcher"].iter().enumerate() {
            let l = format!("{name} {label}");
            failed.extend(disagreeing(&l, &regs, &m[q], &reference[q], alpha).into_iter().map(|r| format!("{l} {r}")));
        }
    }
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}

/// BDPT's and VCM's chunks carry the catcher's sums, the matte's splats among them: two
/// chunks merged give the single render bit for bit.
#[test]
fn bdpt_and_vcm_chunks_with_a_catcher_merge_exactly() {
    let dir = temp_dir();
    let d = dir.path();
    let s = scene(d);
    for integrator in ["bdpt", "vcm"] {
        let render = |out: &Path, extra: &[&str]| {
            let mut a = vec!["render", s.to_str().unwrap(), "-o", out.to_str().unwrap(), "--passes", "shadow_catcher"];
            a.extend_from_slice(&["--resolution", "16x12", "--progress", "json", "--integrator", integrator]);
            a.extend_from_slice(extra);
            let r = run(&a, LIMIT);
            assert_eq!(r.code, Some(0), "{integrator} {extra:?}: {}", r.stderr);
        };
        let (single, a, b, merged) = (d.join("single.exr"), d.join("a.exr"), d.join("b.exr"), d.join("merged.exr"));
        render(&single, &["--spp", "6"]);
        render(&a, &["--spp", "2", "--chunk"]);
        render(&b, &["--spp", "4", "--sample-offset", "2", "--chunk"]);
        let args =
            ["merge", b.to_str().unwrap(), a.to_str().unwrap(), "-o", merged.to_str().unwrap(), "--progress", "json"];
        let r = run(&args, LIMIT);
        assert_eq!(r.code, Some(0), "{integrator}: {}", r.stderr);
        let (x, y) = (common::exr_channel_bits(&single), common::exr_channel_bits(&merged));
        assert!(x.iter().any(|c| c.0.starts_with("Shadow Catcher")));
        assert_eq!(x, y, "{integrator}: the merged chunks differ from the single render");
    }
}
