//! Light passes and light groups in BDPT and VCM (`src/integrator/bdpt/passes.rs`): they
//! sum to Combined pixel by pixel, and each pass agrees with the path tracer's region by
//! region on the Cornell box, a glass scene and a subsurface scene.
//!
//! Bounds (`common::agreement`): K seeds per estimate (light tracing splats one light path
//! onto many pixels, so the noise of a region's mean comes from the spread of its K means),
//! Welch's test per region and pass, Šidák's split over every comparison of the test.

mod common;

use common::agreement::{agree, regions, sidak};
use common::{root, run, temp_dir};
use serde_json::json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);
const RES: (usize, usize) = (32, 24);

const LIGHT: &str = "diffuse_direct,diffuse_indirect,diffuse_color,glossy_direct,glossy_indirect,glossy_color,\
transmission_direct,transmission_indirect,transmission_color,volume_direct,volume_indirect,emit,environment";

/// Every channel of an EXR by name.
fn channels(path: &Path) -> BTreeMap<String, Vec<f32>> {
    let image = exr::prelude::read_all_flat_layers_from_file(path).expect("read EXR");
    let layer = &image.layer_data[0];
    layer.channel_data.list.iter().map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect())).collect()
}

fn render(scene: &Path, out: &Path, extra: &[&str]) {
    let r = format!("{}x{}", RES.0, RES.1);
    let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--resolution", &r];
    args.extend_from_slice(extra);
    let run = run(&args, LIMIT);
    assert_eq!(run.code, Some(0), "render failed: {}", run.stderr);
    assert!(!run.stderr.contains("rendered by the path integrator only"), "{}", run.stderr);
}

/// A bundled scene copied with Film → Transparent off (the world seen directly is in
/// Combined), and the given light groups.
fn copy(name: &str, dir: &Path, groups: Option<serde_json::Value>) -> PathBuf {
    let src = root().join("scenes").join(format!("{name}.gltf"));
    let mut doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&src).unwrap()).unwrap();
    for b in doc["buffers"].as_array().unwrap() {
        let uri = b["uri"].as_str().unwrap();
        std::fs::copy(root().join("scenes").join(uri), dir.join(uri)).unwrap();
    }
    if let Some(w) = doc["scenes"][0]["extensions"]["CAUSTIC_world"]["image"].as_str() {
        std::fs::copy(root().join("scenes").join(w), dir.join(w)).unwrap();
    }
    doc["scenes"][0]["extras"]["caustic"]["transparent"] = json!(false);
    if let Some(g) = groups {
        doc["scenes"][0]["extras"]["caustic"]["light_groups"] = g;
    }
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

/// The light of each pass per pixel and channel (RGB interleaved): Direct and Indirect
/// times their Colour pass (the film divides them by it, as Cycles), the others as they are.
fn light_of_passes(ch: &BTreeMap<String, Vec<f32>>) -> Vec<(String, Vec<f64>)> {
    let rgb = |pass: &str| -> Vec<f64> {
        let [r, g, b] = ["R", "G", "B"].map(|c| &ch[&format!("{pass}.{c}")]);
        (0..r.len()).flat_map(|i| [r[i] as f64, g[i] as f64, b[i] as f64]).collect()
    };
    let mut out = Vec::new();
    for class in ["Diffuse", "Glossy", "Transmission"] {
        let col = rgb(&format!("{class} Color"));
        for kind in ["Direct", "Indirect"] {
            let name = format!("{class} {kind}");
            out.push((name.clone(), rgb(&name).iter().zip(&col).map(|(a, c)| a * c).collect()));
        }
    }
    for pass in ["Volume Direct", "Volume Indirect", "Emission", "Environment"] {
        out.push((pass.to_string(), rgb(pass)));
    }
    out
}

/// Worst |Combined − Σ parts| per pixel and channel, in units of the float-rounding bound:
/// every part is a sum of the same f32 contributions as Combined (a few dozen per path and
/// sample), in another order, then a quotient and a product by the Colour pass in f32
/// (2 × 2^-24): 1e-5 of the terms' magnitude bounds it with room, far below misfiled light.
fn worst_rounding(combined: &[f64], parts: &[&[f64]], skip: &[bool]) -> f64 {
    let mut worst = 0.0f64;
    for (i, c) in combined.iter().enumerate().filter(|(i, _)| !skip[i / 3]) {
        let sum: f64 = parts.iter().map(|p| p[i]).sum();
        let scale: f64 = parts.iter().map(|p| p[i].abs()).sum();
        let tol = 1e-5 * scale.max(c.abs()) + 1e-9;
        worst = worst.max((c - sum).abs() / tol);
    }
    worst
}

/// Pixels where a class's Colour pass is zero in a channel in which a neighbour's is not:
/// pixels at the edge of what the class covers. With a box filter one pixel wide a splat
/// lands in the pixel its point projects into, where the class may cover a part that none
/// of the pixel's camera samples saw (only at such an edge); the film, which writes Direct
/// and Indirect divided by Colour (as Cycles), cannot show that light (Combined has it).
/// Elsewhere the passes recombine exactly.
fn colour_edges(ch: &BTreeMap<String, Vec<f32>>) -> Vec<bool> {
    let (w, h) = RES;
    let mut skip = vec![false; w * h];
    for class in ["Diffuse", "Glossy", "Transmission"] {
        for c in ["R", "G", "B"] {
            let col = &ch[&format!("{class} Color.{c}")];
            for (i, s) in skip.iter_mut().enumerate() {
                let (x, y) = ((i % w) as i64, (i / w) as i64);
                let near = (-1..=1).flat_map(|dy| (-1..=1).map(move |dx| (x + dx, y + dy)));
                let lit = near
                    .filter(|&(u, v)| u >= 0 && v >= 0 && u < w as i64 && v < h as i64)
                    .any(|(u, v)| col[v as usize * w + u as usize] != 0.0);
                *s |= col[i] == 0.0 && lit;
            }
        }
    }
    skip
}

fn combined(ch: &BTreeMap<String, Vec<f32>>, prefix: &str) -> Vec<f64> {
    let [r, g, b] = ["R", "G", "B"].map(|c| &ch[&format!("{prefix}.{c}")]);
    (0..r.len()).flat_map(|i| [r[i] as f64, g[i] as f64, b[i] as f64]).collect()
}

/// Diffuse, glossy and transmission, emitters seen directly, subsurface exits, a world:
/// in BDPT and VCM the light passes sum to Combined pixel by pixel.
#[test]
fn light_passes_sum_to_combined() {
    let dir = temp_dir();
    for name in ["cornell_box", "glass_caustic", "subsurface", "hdri_sky"] {
        let scene = copy(name, dir.path(), None);
        for integrator in ["bdpt", "vcm"] {
            let out = dir.path().join(format!("{name}_{integrator}.exr"));
            let box_filter = ["--filter", "box", "--filter-width", "1"];
            render(
                &scene,
                &out,
                &[&box_filter[..], &["--integrator", integrator, "--spp", "16", "--passes", LIGHT]].concat(),
            );
            let ch = channels(&out);
            let light = light_of_passes(&ch);
            let parts: Vec<&[f64]> = light.iter().map(|(_, v)| v.as_slice()).collect();
            let c = combined(&ch, "Combined");
            assert!(c.iter().sum::<f64>() > 0.0, "{name} {integrator}: black image");
            let skip = colour_edges(&ch);
            let skipped = skip.iter().filter(|s| **s).count();
            eprintln!("{name} {integrator}: {skipped} of {} pixels at a Colour pass's edge", skip.len());
            assert!(skipped * 4 < skip.len(), "{name} {integrator}: {skipped} pixels at edges leave too few to test");
            let worst = worst_rounding(&c, &parts, &skip);
            assert!(worst <= 1.0, "{name} {integrator}: passes differ from Combined by {worst} × the rounding bound");
        }
    }
}

/// The named per-pixel RGB quantities to compare, read from an image's channels.
type Lights = fn(&BTreeMap<String, Vec<f32>>) -> Vec<(String, Vec<f64>)>;

/// Region means (RGB averaged) of each pass's light, for `seeds` seeds.
fn pass_means(
    scene: &Path,
    dir: &Path,
    extra: &[&str],
    seeds: u32,
    regs: &[(String, Vec<usize>)],
    light: Lights,
) -> BTreeMap<String, Vec<Vec<f64>>> {
    let mut out: BTreeMap<String, Vec<Vec<f64>>> = BTreeMap::new();
    for seed in 0..seeds {
        let s = (seed * 7919 + 13).to_string();
        let path = dir.join("r.exr");
        render(scene, &path, &[extra, &["--seed", &s]].concat());
        for (name, v) in light(&channels(&path)) {
            let per = out.entry(name).or_insert_with(|| vec![Vec::new(); regs.len()]);
            for (k, (_, idx)) in regs.iter().enumerate() {
                let m = idx.iter().map(|&i| (v[3 * i] + v[3 * i + 1] + v[3 * i + 2]) / 3.0).sum::<f64>();
                per[k].push(m / idx.len() as f64);
            }
        }
    }
    out
}

/// Each light pass of BDPT and VCM agrees with the path tracer's, region by region, on the
/// Cornell box (diffuse, an emitter seen directly), the glass scene (glossy and
/// transmitted light, caustics) and the subsurface scene (subsurface exits, a world).
#[test]
fn light_passes_agree_with_the_path_tracer() {
    let dir = temp_dir();
    let regs = regions(RES.0, RES.1);
    let seeds = 6;
    let scenes = ["cornell_box", "glass_caustic", "subsurface"];
    let integrators: [(&str, &[&str]); 2] =
        [("bdpt", &["--integrator", "bdpt", "--spp", "16"]), ("vcm", &["--integrator", "vcm", "--spp", "16"])];
    // Ten passes, each region, each scene and integrator.
    let alpha = sidak(10 * regs.len() * scenes.len() * integrators.len());
    let mut failed = Vec::new();
    for name in scenes {
        let scene = copy(name, dir.path(), None);
        let common = ["--max-depth", "6", "--passes", LIGHT];
        let path = ["--integrator", "path", "--spp", "64"];
        let reference = pass_means(&scene, dir.path(), &[&common[..], &path].concat(), seeds, &regs, light_of_passes);
        for (integrator, flags) in integrators {
            let m = pass_means(&scene, dir.path(), &[&common[..], flags].concat(), seeds, &regs, light_of_passes);
            for (pass, per) in &m {
                for (k, (rn, _)) in regs.iter().enumerate() {
                    let label = format!("{name} {integrator} {pass} {rn}");
                    if !agree(&label, &per[k], &reference[pass][k], alpha) {
                        failed.push(label);
                    }
                }
            }
        }
    }
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}

/// Light groups: an area light and the world of the subsurface scene (with subsurface exits
/// path traced from BDPT's camera vertices), the street of emissive objects in two groups.
/// In BDPT and VCM the groups sum to Combined pixel by pixel and each group agrees with the
/// path tracer's region by region.
#[test]
fn light_groups_sum_to_combined_and_agree_with_the_path_tracer() {
    let dir = temp_dir();
    let regs = regions(RES.0, RES.1);
    let bulbs = |range: std::ops::Range<u32>, g: &'static str| range.map(move |i| (format!("bulbs{i}"), json!(g)));
    let cases = [
        ("subsurface", json!({"names": ["key", "sky"], "world": "sky", "objects": {"area_light": "key"}})),
        (
            "many_lights",
            json!({"names": ["near", "far"], "objects": bulbs(0..4, "near")
                .chain(bulbs(4..8, "far"))
                .chain([("windows".to_string(), json!("far"))])
                .collect::<serde_json::Map<_, _>>()}),
        ),
    ];
    let seeds = 6;
    let alpha = sidak(2 * regs.len() * cases.len() * 2);
    let mut failed = Vec::new();
    for (name, spec) in cases {
        let scene = copy(name, dir.path(), Some(spec.clone()));
        let names: Vec<String> = spec["names"].as_array().unwrap().iter().map(|n| n.as_str().unwrap().into()).collect();
        let groups = |ch: &BTreeMap<String, Vec<f32>>| -> Vec<(String, Vec<f64>)> {
            let names = ch.keys().filter_map(|k| k.strip_prefix("Combined_")?.strip_suffix(".R")).map(String::from);
            names.collect::<Vec<_>>().into_iter().map(|g| (g.clone(), combined(ch, &format!("Combined_{g}")))).collect()
        };
        let common = ["--max-depth", "6", "--passes", "light_groups"];
        let reference = pass_means(
            &scene,
            dir.path(),
            &[&common[..], &["--integrator", "path", "--spp", "64"]].concat(),
            seeds,
            &regs,
            groups,
        );
        for integrator in ["bdpt", "vcm"] {
            let out = dir.path().join("g.exr");
            render(&scene, &out, &[&common[..], &["--integrator", integrator, "--spp", "8"]].concat());
            let ch = channels(&out);
            let g: Vec<Vec<f64>> = names.iter().map(|n| combined(&ch, &format!("Combined_{n}"))).collect();
            for (n, v) in names.iter().zip(&g) {
                assert!(v.iter().sum::<f64>() > 0.0, "{name} {integrator}: group {n} is empty");
            }
            let parts: Vec<&[f64]> = g.iter().map(|v| v.as_slice()).collect();
            let worst = worst_rounding(&combined(&ch, "Combined"), &parts, &vec![false; RES.0 * RES.1]);
            assert!(worst <= 1.0, "{name} {integrator}: groups differ from Combined by {worst} × the rounding bound");
            let flags = [&common[..], &["--integrator", integrator, "--spp", "16"]].concat();
            let m = pass_means(&scene, dir.path(), &flags, seeds, &regs, groups);
            for (group, per) in &m {
                for (k, (rn, _)) in regs.iter().enumerate() {
                    let label = format!("{name} {integrator} {group} {rn}");
                    if !agree(&label, &per[k], &reference[group][k], alpha) {
                        failed.push(label);
                    }
                }
            }
        }
    }
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}

/// Chunks of a BDPT render carry the splats' light passes and light groups: two chunks
/// merge into the single render bit for bit.
#[test]
fn bdpt_chunks_with_light_passes_merge_exactly() {
    let dir = temp_dir();
    let scene = copy("cornell_box", dir.path(), Some(json!({"names": ["ceiling"], "objects": {"light": "ceiling"}})));
    let p = |n: &str| dir.path().join(n);
    let passes = format!("{LIGHT},light_groups");
    let flags = ["--integrator", "bdpt", "--passes", passes.as_str()];
    render(&scene, &p("single.exr"), &[&flags[..], &["--spp", "4"]].concat());
    render(&scene, &p("a.exr"), &[&flags[..], &["--spp", "1", "--chunk"]].concat());
    render(&scene, &p("b.exr"), &[&flags[..], &["--spp", "3", "--sample-offset", "1", "--chunk"]].concat());
    let (a, b, m) = (p("a.exr"), p("b.exr"), p("merged.exr"));
    let r = run(&["merge", a.to_str().unwrap(), b.to_str().unwrap(), "-o", m.to_str().unwrap()], LIMIT);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let (single, merged) = (channels(&p("single.exr")), channels(&m));
    assert!(single.contains_key("Combined_ceiling.R") && single.contains_key("Diffuse Indirect.R"));
    for (name, v) in &single {
        let w = &merged[name];
        assert!(v.iter().zip(w).all(|(x, y)| x.to_bits() == y.to_bits()), "{name} differs after the merge");
    }
}
