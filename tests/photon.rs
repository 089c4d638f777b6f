//! Photon mapping, end to end: emitted power, a point light's irradiance estimate on a
//! plane, Jensen PM and SPPM against the path tracer on the Cornell box, the furnace,
//! photon-map files, determinism across thread counts.
//!
//! How the bounds are derived (no hand-tuned thresholds):
//! - noise: a region's mean is compared with 5 standard errors, each estimated from two
//!   renders with different seeds (E[Σ (a - b)²] / 2 = Σ σ², so the region mean's
//!   variance is Σ (a - b)² / (2 n²));
//! - photon-density bias: a cone-filtered estimate is unbiased where the photon density
//!   is uniform over the disc, so on flat, piecewise-planar scenes its bias comes from the
//!   disc crossing an edge of a face (the normal filter drops photons on the other face).
//!   At distance d < r from an edge the disc loses r² acos(d/r) - d √(r² - d²) of its
//!   area, whose integral over d is 2r³/3; averaged over faces of total area A and total
//!   edge length P (creases and borders, counted per face) the estimate is low by at most
//!   a fraction 2 r P / (3 π A) of the photon-estimated part, r being the largest radius
//!   used. The curvature term (r²/8)·ΔE/E is O(r²/L²) ≈ 10⁻³ here, an order of
//!   magnitude below, and folded into the 5σ.

mod common;

use caustic::accel::Accel;
use caustic::integrator::SceneContext;
use caustic::integrator::photon::PhotonMap;
use caustic::integrator::photon::estimate::estimate;
use caustic::integrator::photon::trace::{MapKind, TraceJob, trace_photons};
use caustic::light::emit::Emitters;
use common::{GltfBuilder, emissive_furnace, look_rotation, render_image, root, run, temp_dir};
use glam::{DVec3, Vec2, Vec3};
use serde_json::json;
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);

fn render(scene: &Path, out: &Path, extra: &[&str]) -> Vec<[f32; 4]> {
    render_image(scene, out, extra, LIMIT)
}

fn lum(p: &[f32; 4]) -> f64 {
    (p[0] + p[1] + p[2]) as f64 / 3.0
}

/// Mean of a region of two independent renders and the standard error of one render's
/// region mean, from their difference.
fn region_stats(a: &[[f32; 4]], b: &[[f32; 4]], idx: &[usize]) -> (f64, f64) {
    let n = idx.len() as f64;
    let mean = idx.iter().map(|&i| lum(&a[i]) + lum(&b[i])).sum::<f64>() / (2.0 * n);
    let d2 = idx.iter().map(|&i| (lum(&a[i]) - lum(&b[i])).powi(2)).sum::<f64>();
    // Var(mean of one render) = Σσ²/n² = E[Σd²]/(2n²); the mean of two halves it.
    let se = (d2 / (2.0 * n * n) / 2.0).sqrt();
    (mean, se)
}

fn load(path: &Path) -> (caustic::scene::Scene, Accel) {
    let scene = caustic::scene::gltf::load(path).unwrap();
    let tris: Vec<[Vec3; 3]> =
        scene.mesh.triangles.iter().map(|t| t.map(|i| scene.mesh.positions[i as usize])).collect();
    let accel = Accel::build(&tris);
    (scene, accel)
}

/// Total crease/border edge length P (per face) and total area A of a mesh: an edge is
/// interior when another triangle shares it in the same plane.
fn edge_length_and_area(scene: &caustic::scene::Scene) -> (f64, f64) {
    let m = &scene.mesh;
    let key = |p: Vec3| (p * 1e4).round().as_ivec3().to_array();
    let mut edges: std::collections::HashMap<([i32; 3], [i32; 3]), Vec<Vec3>> = std::collections::HashMap::new();
    let mut area = 0.0f64;
    for t in &m.triangles {
        let p = t.map(|i| m.positions[i as usize]);
        let c = (p[1] - p[0]).cross(p[2] - p[0]);
        area += 0.5 * c.length() as f64;
        let n = c.normalize();
        for e in 0..3 {
            let (a, b) = (key(p[e]), key(p[(e + 1) % 3]));
            let k = if a < b { (a, b) } else { (b, a) };
            edges.entry(k).or_default().push(n);
        }
    }
    let mut perimeter = 0.0f64;
    for ((a, b), normals) in &edges {
        let len = (Vec3::from_array(a.map(|x| x as f32)) - Vec3::from_array(b.map(|x| x as f32))).length() as f64 / 1e4;
        for (i, n) in normals.iter().enumerate() {
            let coplanar = normals.iter().enumerate().any(|(j, o)| j != i && n.dot(*o).abs() > 0.999);
            if !coplanar {
                perimeter += len;
            }
        }
    }
    (perimeter, area)
}

/// Relative bias bound of a photon estimate of radius ≤ r on a piecewise-planar scene.
fn edge_bias(r: f64, perimeter: f64, area: f64) -> f64 {
    2.0 * r * perimeter / (3.0 * std::f64::consts::PI * area)
}

/// Scenes with one light of each type (and all together): the power of the emitted
/// photons sums to the lights' power. Every photon of a light carries Φ_l / (p_l N);
/// with Sobol points the light-choice dimension puts exactly one point in each of the
/// N strata (N a power of two), so light l gets N p_l ± 2 photons: the sum is exact for
/// one light and within Σ_l 2 Φ_l / (p_l N) per channel for several (and exact in
/// luminance, since Φ_l / p_l is the same for all).
#[test]
fn emitted_power_sums_to_light_power() {
    let dir = temp_dir();
    let q = glam::Quat::from_rotation_x(std::f32::consts::FRAC_PI_2);
    type AddLight = Box<dyn Fn(&mut GltfBuilder)>;
    let lights: Vec<(&str, AddLight)> = vec![
        (
            "point",
            Box::new(|g: &mut GltfBuilder| {
                g.punctual(
                    json!({"type": "point", "intensity": 683.0, "color": [1.0, 0.5, 0.25]}),
                    [0.0, 1.0, 0.0],
                    [0.0, 0.0, 0.0, 1.0],
                );
            }),
        ),
        (
            "spot",
            Box::new(|g: &mut GltfBuilder| {
                g.punctual(json!({"type": "spot", "intensity": 1000.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.7}}), [0.0, 1.0, 0.0], look_rotation([0.0, -1.0, 0.0001]));
            }),
        ),
        (
            "directional",
            Box::new(|g: &mut GltfBuilder| {
                g.punctual(
                    json!({"type": "directional", "intensity": 500.0}),
                    [0.0, 3.0, 0.0],
                    look_rotation([0.3, -1.0, 0.1]),
                );
            }),
        ),
        (
            "area",
            Box::new(move |g: &mut GltfBuilder| {
                g.use_ext("CAUSTIC_lights_area");
                g.node(json!({"translation": [0.0, 1.5, 0.0], "rotation": [q.x, q.y, q.z, q.w],
                    "extensions": {"CAUSTIC_lights_area": {"shape": "rectangle", "size": [0.5, 0.3], "power": 30.0, "color": [1, 0.8, 0.6]}}}));
            }),
        ),
        (
            "emissive, doubleSided false (both faces emit)",
            Box::new(|g: &mut GltfBuilder| {
                let m = g.material(json!({"emissiveFactor": [1.0, 0.2, 0.4]}));
                g.mesh(&[[0.0, 1.0, 0.0], [0.3, 1.0, 0.0], [0.0, 1.0, 0.4]], &[0, 1, 2], m);
            }),
        ),
        (
            "emissive two-sided",
            Box::new(|g: &mut GltfBuilder| {
                let m = g.material(json!({"emissiveFactor": [0.3, 0.9, 0.4], "doubleSided": true}));
                g.mesh(&[[0.0, 1.2, 0.0], [0.5, 1.2, 0.0], [0.0, 1.3, 0.4], [0.6, 1.3, 0.5]], &[0, 1, 2, 1, 3, 2], m);
            }),
        ),
    ];
    let n = 1u64 << 14;
    let check = |name: &str, builders: &[&dyn Fn(&mut GltfBuilder)]| {
        let mut g = GltfBuilder::new();
        let floor = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1]}}));
        g.mesh(&[[-2.0, 0.0, -2.0], [2.0, 0.0, -2.0], [2.0, 0.0, 2.0], [-2.0, 0.0, 2.0]], &[0, 2, 1, 0, 3, 2], floor);
        for b in builders {
            b(&mut g);
        }
        let path = g.write(dir.path(), "lights.gltf");
        let (scene, accel) = load(&path);
        let ctx = SceneContext::new(&scene, &accel);
        let em = Emitters::new(&scene);
        let mut sum = DVec3::ZERO;
        for i in 0..n as u32 {
            let mut s = caustic::sampling::PixelSampler::new(3, 0xF07_0001, 0, i);
            let [ul, us, px, py] = s.next_4d();
            let [dx, dy, _, _] = s.next_4d();
            if let Some(e) = em.emit(ctx.scene, ul, us, Vec2::new(px, py), Vec2::new(dx, dy), n) {
                assert!(e.dir.is_normalized() && e.power.is_finite());
                sum += e.power.as_dvec3();
            }
        }
        let total = em.total_power().as_dvec3();
        let bound: DVec3 = if em.power.len() == 1 {
            // One light: N photons of Φ/N each; only rounding (N additions in f64 of f32 values).
            total * 1e-6
        } else {
            em.power
                .iter()
                .enumerate()
                .map(|(i, p)| p.as_dvec3() * (2.0 / (em.pmf(i) as f64 * n as f64)))
                .fold(DVec3::ZERO, |a, b| a + b)
                + total * 1e-6
        };
        eprintln!("{name}: photons {sum:?}, lights {total:?}, bound {bound:?}");
        assert!(total.max_element() > 0.0);
        for c in 0..3 {
            assert!(
                (sum[c] - total[c]).abs() <= bound[c],
                "{name}, channel {c}: {} vs {} (bound {})",
                sum[c],
                total[c],
                bound[c]
            );
        }
    };
    for (name, b) in &lights {
        check(name, &[b.as_ref()]);
    }
    let all: Vec<&dyn Fn(&mut GltfBuilder)> = lights.iter().map(|(_, b)| b.as_ref()).collect();
    check("all lights", &all);
}

/// A diffuse plane under a point light of intensity I at height h: the photon
/// estimate of irradiance at the light's foot converges to E₀ = I/h² as photons grow.
/// The estimate uses a fixed radius r (fewer than k photons inside), with r² ∝ N^(-1/2)
/// so that r → 0 while the photons inside grow (consistency). Every photon position
/// is marginally uniform (Owen scrambling), so the cone-filtered estimate's expectation
/// is exactly the cone-weighted mean of E over the disc: the relative bias is
/// ∫(1-ρ/r)(1+ρ²/h²)^(-3/2) ρ dρ / ∫(1-ρ/r) ρ dρ - 1 ≈ -0.45 r²/h², computed here by
/// quadrature. At N and 4N (r² halved) the measured bias must match it within 5
/// standard errors (over independent seeds), and must fall.
#[test]
fn point_light_irradiance_converges() {
    let dir = temp_dir();
    let (h, intensity) = (1.0f64, 1.0f64);
    let mut g = GltfBuilder::new();
    let m = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
    g.mesh(&[[-50.0, 0.0, -50.0], [50.0, 0.0, -50.0], [50.0, 0.0, 50.0], [-50.0, 0.0, 50.0]], &[0, 2, 1, 0, 3, 2], m);
    g.punctual(json!({"type": "point", "intensity": 683.0 * intensity}), [0.0, h as f32, 0.0], [0.0, 0.0, 0.0, 1.0]);
    let path = g.write(dir.path(), "plane.gltf");
    let (scene, accel) = load(&path);
    let ctx = SceneContext::new(&scene, &accel);
    let em = Emitters::new(&scene);
    let stop = AtomicBool::new(false);
    let e0 = intensity / (h * h);
    let runs = 400u32;
    let k = caustic::integrator::photon::MAX_K;
    let measure = |n: u64, r2: f32| -> (f64, f64) {
        let mut errs = Vec::with_capacity(runs as usize);
        for seed in 0..runs {
            let job = TraceJob {
                kind: MapKind::Global,
                count: n,
                seed,
                pass: 0,
                max_depth: 1,
                skip_direct: false,
                light_groups: false,
            };
            let (ph, _, _) = trace_photons(&ctx, &em, &job, &stop, &|_| {});
            let map = PhotonMap::build(ph);
            let mut found = 0;
            map.for_each_within(Vec3::ZERO, r2, |_, _, _| found += 1);
            assert!(found < k, "the estimate must use the fixed radius");
            let (e, used) = estimate(&map, Vec3::ZERO, Vec3::Y, k, r2, |_| true, |_| Vec3::ONE);
            assert_eq!(used, r2);
            errs.push(e.x as f64 / e0 - 1.0);
        }
        let mean = errs.iter().sum::<f64>() / runs as f64;
        let var = errs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (runs as f64 - 1.0);
        (mean, (var / runs as f64).sqrt())
    };
    let predicted = |r2: f64| {
        let r = r2.sqrt();
        let steps = 100_000;
        let (mut num, mut den) = (0.0, 0.0);
        for i in 0..steps {
            let rho = r * (i as f64 + 0.5) / steps as f64;
            let w = (1.0 - rho / r) * rho;
            num += w * (1.0 + rho * rho / (h * h)).powf(-1.5);
            den += w;
        }
        num / den - 1.0
    };
    let (n0, r2_0) = (4000u64, 0.1f32);
    let (b1, se1) = measure(n0, r2_0);
    let (b4, se4) = measure(4 * n0, r2_0 / 2.0);
    let (p1, p4) = (predicted(r2_0 as f64), predicted(r2_0 as f64 / 2.0));
    eprintln!("N={n0}, r²={r2_0}: bias {b1:.5} ± {se1:.5} (predicted {p1:.5})");
    eprintln!("N={}, r²={}: bias {b4:.5} ± {se4:.5} (predicted {p4:.5})", 4 * n0, r2_0 / 2.0);
    assert!((b1 - p1).abs() <= 5.0 * se1, "N: {b1} vs {p1}");
    assert!((b4 - p4).abs() <= 5.0 * se4, "4N: {b4} vs {p4}");
    assert!(b4.abs() < b1.abs(), "the bias must fall: {b1} -> {b4}");
}

fn cornell() -> std::path::PathBuf {
    root().join("scenes/cornell_box.gltf")
}

/// Quadrant and whole-image pixel index sets of a w×w image.
fn regions(w: usize) -> Vec<(String, Vec<usize>)> {
    let mut out = vec![("whole".to_string(), (0..w * w).collect::<Vec<_>>())];
    for (qy, qx) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
        let idx = (0..w * w).filter(|i| (i / w) * 2 / w == qy && (i % w) * 2 / w == qx).collect();
        out.push((format!("quadrant {qy}{qx}"), idx));
    }
    out
}

/// Jensen PM (final gather) on the Cornell box agrees with the path tracer region by
/// region within 5σ (both renders' noise, from two seeds each) plus the edge bias
/// bound on the photon-estimated part, which is at most the indirect light (full path
/// tracing minus direct-only path tracing, plus its own 5σ).
#[test]
fn cornell_photon_matches_path_tracing() {
    let dir = temp_dir();
    let w = 32usize;
    let res = format!("{w}x{w}");
    let base = ["--resolution", res.as_str(), "--filter", "box"];
    let r = |name: &str, extra: &[&str]| {
        let mut a = base.to_vec();
        a.extend_from_slice(extra);
        render(&cornell(), &dir.path().join(name), &a)
    };
    let pt_a = r("pt_a.exr", &["--spp", "1024", "--seed", "1"]);
    let pt_b = r("pt_b.exr", &["--spp", "1024", "--seed", "2"]);
    let d_a = r("d_a.exr", &["--spp", "256", "--seed", "1", "--max-depth", "1"]);
    let d_b = r("d_b.exr", &["--spp", "256", "--seed", "2", "--max-depth", "1"]);
    let max_radius = 0.02f64;
    let pm = |name: &str, seed: &str| {
        r(
            name,
            &[
                "--integrator",
                "photon",
                "--spp",
                "64",
                "--gather-rays",
                "4",
                "--photons",
                "200000",
                "--max-radius",
                "0.02",
                "--seed",
                seed,
            ],
        )
    };
    let pm_a = pm("pm_a.exr", "1");
    let pm_b = pm("pm_b.exr", "2");
    let (scene, _) = load(&cornell());
    let (perimeter, area) = edge_length_and_area(&scene);
    let bias = edge_bias(max_radius, perimeter, area);
    eprintln!("edge bias bound {bias:.4} (P {perimeter:.3}, A {area:.3})");
    for (name, idx) in regions(w) {
        let (pt, se_pt) = region_stats(&pt_a, &pt_b, &idx);
        let (direct, se_d) = region_stats(&d_a, &d_b, &idx);
        let (pm, se_pm) = region_stats(&pm_a, &pm_b, &idx);
        let indirect = (pt - direct).abs() + 5.0 * (se_pt * se_pt + se_d * se_d).sqrt();
        let bound = 5.0 * (se_pt * se_pt + se_pm * se_pm).sqrt() + bias * indirect;
        eprintln!(
            "{name}: PT {pt:.5} ± {se_pt:.5}, PM {pm:.5} ± {se_pm:.5}, diff {:.5}, bound {bound:.5} (indirect {indirect:.4})",
            pm - pt
        );
        assert!((pm - pt).abs() <= bound, "{name}: PM {pm} vs PT {pt}, bound {bound}");
    }
}

/// Mean squared error per pixel against a reference, minus the reference's own noise
/// (estimated from two reference seeds: E[(a-b)²]/2 per pixel, halved for their mean).
fn mse(img: &[[f32; 4]], ref_a: &[[f32; 4]], ref_b: &[[f32; 4]]) -> f64 {
    let n = img.len() as f64;
    let mut s = 0.0;
    let mut noise = 0.0;
    for i in 0..img.len() {
        let r = 0.5 * (lum(&ref_a[i]) + lum(&ref_b[i]));
        s += (lum(&img[i]) - r).powi(2);
        noise += (lum(&ref_a[i]) - lum(&ref_b[i])).powi(2) / 4.0;
    }
    (s - noise) / n
}

/// SPPM's error against the path-traced reference falls with iterations: the mean
/// over 3 seeds of the squared error (the reference's noise removed) after 32
/// iterations is below half that after 4. SPPM's error decays like I^(-2/3) (variance
/// and squared bias both, with α = 2/3), so 8× the iterations should divide it by ~4;
/// half leaves room for the seeds' spread.
#[test]
fn cornell_sppm_error_falls_with_iterations() {
    let dir = temp_dir();
    let w = 24usize;
    let res = format!("{w}x{w}");
    let r = |name: &str, extra: &[&str]| {
        let mut a = vec!["--resolution", res.as_str(), "--filter", "box"];
        a.extend_from_slice(extra);
        render(&cornell(), &dir.path().join(name), &a)
    };
    let ref_a = r("ref_a.exr", &["--spp", "2048", "--seed", "11"]);
    let ref_b = r("ref_b.exr", &["--spp", "2048", "--seed", "12"]);
    let mut e4 = 0.0;
    let mut e32 = 0.0;
    for seed in ["1", "2", "3"] {
        let a = r("s4.exr", &["--integrator", "sppm", "--sppm-iterations", "4", "--seed", seed]);
        let b = r("s32.exr", &["--integrator", "sppm", "--sppm-iterations", "32", "--seed", seed]);
        let (ea, eb) = (mse(&a, &ref_a, &ref_b), mse(&b, &ref_a, &ref_b));
        eprintln!("seed {seed}: MSE after 4 iterations {ea:.3e}, after 32 {eb:.3e}");
        e4 += ea;
        e32 += eb;
    }
    assert!(e32 < e4 / 2.0, "SPPM error must fall: {e4} -> {e32}");
}

/// The albedo-1 furnace (see tests/render.rs): L = (D + 1) Le exactly for a path
/// tracer. The photon methods estimate the light of paths with ≥ 2 scattering events,
/// at most (D - 1) Le, from photons, so they may be low by the edge bias bound on that
/// part; the BSDF's albedo table adds k ε Le per bounce (as in tests/render.rs).
#[test]
fn furnace_photon_and_sppm() {
    let dir = temp_dir();
    let le = 0.5f64;
    let depth = 4u32;
    let scene_path = emissive_furnace(dir.path(), "furnace.gltf", le, 1.0);
    let (scene, _) = load(&scene_path);
    let (perimeter, area) = edge_length_and_area(&scene);
    let expect = (depth + 1) as f64 * le;
    let systematic = le * 2e-3 * (depth * (depth + 1) / 2) as f64;
    let d = depth.to_string();
    let radius = 0.05f64;
    for (label, extra) in [
        (
            "photon",
            vec![
                "--integrator",
                "photon",
                "--spp",
                "8",
                "--photons",
                "100000",
                "--gather-rays",
                "4",
                "--max-radius",
                "0.05",
            ],
        ),
        ("sppm", vec!["--integrator", "sppm", "--sppm-iterations", "16", "--sppm-radius", "0.05"]),
    ] {
        let mut means = Vec::new();
        let mut imgs = Vec::new();
        for seed in ["1", "2"] {
            let mut a = vec!["--resolution", "24x24", "--max-depth", d.as_str(), "--seed", seed];
            a.extend_from_slice(&extra);
            let px = render(&scene_path, &dir.path().join(format!("{label}{seed}.exr")), &a);
            means.push(px.iter().map(lum).sum::<f64>() / px.len() as f64);
            imgs.push(px);
        }
        let idx: Vec<usize> = (0..imgs[0].len()).collect();
        let (mean, se) = region_stats(&imgs[0], &imgs[1], &idx);
        let bias = edge_bias(radius, perimeter, area) * (depth - 1) as f64 * le;
        let bound = 5.0 * se + systematic + bias;
        eprintln!("{label}: mean {mean:.5} ± {se:.5}, expected {expect}, bound {bound:.5} (edge bias ≤ {bias:.5})");
        assert!((mean - expect).abs() <= bound, "{label}: {mean} vs {expect} (bound {bound})");
    }
}

/// `caustic photons` writes a map; rendering with it equals rendering with the same
/// photons traced in-process (bit for bit), for any thread count; a map is refused for
/// another scene file.
#[test]
fn photon_map_reuse_and_determinism() {
    let dir = temp_dir();
    let map = dir.path().join("cornell.pm");
    let r = run(
        &[
            "photons",
            cornell().to_str().unwrap(),
            "-o",
            map.to_str().unwrap(),
            "--photons",
            "50000",
            "--caustic-photons",
            "1000",
            "--progress",
            "json",
        ],
        LIMIT,
    );
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(r.json_lines().iter().any(|v| v["type"] == "progress" && v["phase"] == "photons"));
    let common = [
        "--resolution",
        "24x24",
        "--spp",
        "2",
        "--integrator",
        "photon",
        "--photons",
        "50000",
        "--caustic-photons",
        "1000",
    ];
    let with = |name: &str, extra: &[&str]| {
        let mut a = common.to_vec();
        a.extend_from_slice(extra);
        render(&cornell(), &dir.path().join(name), &a)
    };
    let traced1 = with("t1.exr", &["--threads", "1"]);
    let traced2 = with("t2.exr", &["--threads", "2"]);
    assert!(traced1 == traced2, "photon mapping must not depend on the thread count");
    let loaded = with("l.exr", &["--photon-map", map.to_str().unwrap()]);
    assert!(loaded == traced1, "a loaded map must render as the traced one");
    let s1 = render(
        &cornell(),
        &dir.path().join("s1.exr"),
        &["--resolution", "24x24", "--integrator", "sppm", "--sppm-iterations", "3", "--threads", "1"],
    );
    let s2 = render(
        &cornell(),
        &dir.path().join("s2.exr"),
        &["--resolution", "24x24", "--integrator", "sppm", "--sppm-iterations", "3", "--threads", "2"],
    );
    assert!(s1 == s2, "SPPM must not depend on the thread count");
    // Another scene file: a copy with one byte changed (a trailing space).
    let other = dir.path().join("other.gltf");
    std::fs::copy(root().join("scenes/cornell_box.bin"), dir.path().join("cornell_box.bin")).unwrap();
    let mut bytes = std::fs::read(cornell()).unwrap();
    bytes.push(b' ');
    std::fs::write(&other, bytes).unwrap();
    let out = dir.path().join("x.exr");
    let r = run(
        &[
            "render",
            other.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--integrator",
            "photon",
            "--photon-map",
            map.to_str().unwrap(),
            "--progress",
            "json",
        ],
        LIMIT,
    );
    assert_eq!(r.code, Some(2), "{}", r.stderr);
    assert!(r.error_message().unwrap_or_default().contains("different scene"));
    assert!(!out.exists());
}

/// The photon settings are read from `extras.caustic` (flags override them), are
/// validated, and bad values are usage errors (exit 2).
#[test]
fn photon_settings_from_scene_and_flags() {
    let dir = temp_dir();
    let mut g = GltfBuilder::new();
    let m = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0}}));
    g.cube([-1.0, -1.0, -3.0], [1.0, 1.0, -2.0], m);
    g.punctual(json!({"type": "point", "intensity": 683.0}), [0.0, 2.0, 0.0], [0.0, 0.0, 0.0, 1.0]);
    g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.8);
    g.settings(json!({"integrator": "sppm", "sppm_iterations": 3, "sppm_radius": 0.05, "photons": 1000,
        "caustic_photons": 10, "k": 20, "max_radius": 0.1, "gather_rays": 2, "diffuse_bounces": 1, "sppm_photons": 500}));
    let path = g.write(dir.path(), "s.gltf");
    let out = dir.path().join("s.exr");
    let args = |extra: &[&str]| {
        let mut a = vec![
            "render",
            path.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--resolution",
            "8x8",
            "--progress",
            "json",
        ];
        a.extend_from_slice(extra);
        run(&a, LIMIT)
    };
    let r = args(&[]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let s = r.summary().unwrap();
    assert!(s["integrator"].as_str().unwrap().starts_with("sppm (3 iterations, 500 photons"), "{}", s["integrator"]);
    assert_eq!(s["spp"], 3);
    let r = args(&["--integrator", "photon", "--spp", "1"]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let d = r.summary().unwrap()["integrator"].as_str().unwrap().to_string();
    assert!(d.contains("global 1000 photons") && d.contains("k 20 (caustic 10)") && d.contains("2 gather rays"), "{d}");
    for (bad, word) in [
        (vec!["--k", "0"], "k"),
        (vec!["--k", "100000"], "k"),
        (vec!["--caustic-k", "0"], "caustic-k"),
        (vec!["--caustic-k", "257"], "caustic-k"),
        (vec!["--gather-rays", "0"], "gather"),
        (vec!["--max-radius=-1"], "radius"),
        (vec!["--sppm-iterations", "0"], "iterations"),
        (vec!["--integrator", "path", "--photon-map", "x.pm"], "photon-map"),
    ] {
        let r = args(&bad);
        assert_eq!(r.code, Some(2), "{bad:?}: {}", r.stderr);
        assert!(r.error_message().unwrap_or_default().contains(word), "{bad:?}: {:?}", r.error_message());
    }
}

/// Light through a rough transmissive sheet reaches the camera in the photon
/// integrators too: a thin rough glass sheet fills the view, a point light behind it, so
/// every pixel is direct light transmitted by a non-delta lobe. The photon integrators'
/// NEE must sample lights below the surface when the BSDF transmits (their photons are
/// gathered on the camera's side only). Nothing else is in the scene: no indirect light,
/// no photon-map bias (r ≤ 0.05 on a flat sheet with no edge in view). Bound: 5σ of the
/// two estimates, each from two seeds.
#[test]
fn rough_sheet_transmits_direct_light_in_photon_integrators() {
    let dir = temp_dir();
    let mut g = GltfBuilder::new();
    g.use_ext("KHR_materials_transmission");
    let sheet = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.9, 0.9, 1], "metallicFactor": 0.0, "roughnessFactor": 0.4},
        "doubleSided": true,
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}}
    }));
    g.mesh(&[[-4.0, -4.0, 0.0], [4.0, -4.0, 0.0], [4.0, 4.0, 0.0], [-4.0, 4.0, 0.0]], &[0, 1, 2, 0, 2, 3], sheet);
    g.camera([0.0, 0.0, 3.0], [0.0, 0.0, 0.0, 1.0], 0.6);
    g.punctual(json!({"type": "point", "intensity": 1000.0}), [0.3, -0.2, -1.5], [0.0, 0.0, 0.0, 1.0]);
    let path = g.write(dir.path(), "sheet.gltf");
    let all: Vec<usize> = (0..24 * 24).collect();
    let r = |name: &str, extra: &[&str]| {
        let mut a = vec!["--resolution", "24x24"];
        a.extend_from_slice(extra);
        render(&path, &dir.path().join(name), &a)
    };
    let (pt, se_pt) = region_stats(
        &r("a.exr", &["--spp", "128", "--seed", "1"]),
        &r("b.exr", &["--spp", "128", "--seed", "2"]),
        &all,
    );
    let sppm = ["--integrator", "sppm", "--sppm-iterations", "64", "--sppm-radius", "0.05"];
    let jensen = ["--integrator", "photon", "--spp", "32", "--photons", "50000", "--max-radius", "0.05"];
    for (name, args) in [("SPPM", &sppm[..]), ("PM", &jensen[..])] {
        let run_seed = |seed: &str| {
            let mut a = args.to_vec();
            a.extend_from_slice(&["--seed", seed]);
            r(&format!("{name}{seed}.exr"), &a)
        };
        let (m, se) = region_stats(&run_seed("1"), &run_seed("2"), &all);
        let bound = 5.0 * (se_pt * se_pt + se * se).sqrt();
        eprintln!(
            "rough sheet: PT {pt:.5} ± {se_pt:.5}, {name} {m:.5} ± {se:.5}, ratio {:.4}, bound {bound:.5}",
            m / pt
        );
        assert!(pt > 0.1, "the sheet should be lit through: {pt}");
        assert!((m - pt).abs() <= bound, "{name} {m} vs PT {pt} (bound {bound})");
    }
}

/// An icosphere of `levels` subdivisions (20·4^levels flat triangles) of radius `r` at `c`.
fn icosphere(levels: u32, c: [f32; 3], r: f32) -> (Vec<[f32; 3]>, Vec<u32>) {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|p| Vec3::from(*p).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mids = std::collections::HashMap::new();
        let mut mid = |a: u32, b: u32, v: &mut Vec<Vec3>| {
            *mids.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push((v[a as usize] + v[b as usize]).normalize());
                v.len() as u32 - 1
            })
        };
        f = f
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (mid(a, b, &mut v), mid(b, c, &mut v), mid(c, a, &mut v));
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    let pos = v.iter().map(|p| (Vec3::from(c) + *p * r).to_array()).collect();
    (pos, f.into_iter().flatten().collect())
}

/// A glossy sphere (a blue dielectric of roughness 0.15: a diffuse base under a GGX
/// layer of α = 0.0225, below the photon maps' roughness threshold) alone under a
/// constant white world. Light reaches the camera after one scattering event at most (a
/// convex object), so no photon estimate enters the image: Jensen PM and SPPM must then
/// be the path tracer itself at the sphere (NEE and the BSDF-sampled ray combined by MIS
/// through the whole BSDF), photons or not. Checked on the sphere's pixels:
/// - the means agree within 5σ (both renders' noise, from two seeds each);
/// - the noise agrees: Σ (a − b)² over the pixels estimates Σ σ² with
///   m = 3 (Σ v)² / Σ v² effective degrees of freedom (v = (a − b)²/2 is σ² χ²₁, whose
///   fourth moment is 3σ⁴), so the ratio of two such sums of equal estimators has
///   log-variance 2·(2/m) to first order; it must stay within 5 of those standard deviations.
///
/// Before glossy lobes were continued SPPM gathered photons through the glossy lobe and
/// found the world's direct light by NEE alone, which a narrow lobe samples badly: its
/// noise was many times the path tracer's (the bound fails by a wide margin).
#[test]
fn glossy_sphere_under_world_is_path_traced_by_photon_integrators() {
    let dir = temp_dir();
    let mut g = GltfBuilder::new();
    let glossy = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.15, 0.3, 0.8, 1], "metallicFactor": 0.0, "roughnessFactor": 0.15}}));
    let (pos, idx) = icosphere(3, [0.0, 0.0, 0.0], 0.5);
    g.mesh(&pos, &idx, glossy);
    g.camera([0.0, 0.4, 2.2], look_rotation([0.0, -0.4, -2.2]), 0.45);
    g.world(json!({"color": [1.0, 1.0, 1.0]}));
    let path = g.write(dir.path(), "glossy_sphere.gltf");
    let w = 32usize;
    let res = format!("{w}x{w}");
    let r = |name: &str, extra: &[&str]| {
        let mut a = vec!["--resolution", res.as_str(), "--filter", "box", "--max-depth", "4"];
        a.extend_from_slice(extra);
        render(&path, &dir.path().join(name), &a)
    };
    let pt = [r("pt1.exr", &["--spp", "64", "--seed", "1"]), r("pt2.exr", &["--spp", "64", "--seed", "2"])];
    // The sphere's pixels: the world is white (1), the sphere reflects at most ~0.2 of
    // red (its base 0.15 plus the layer's few per cent); edge pixels between count too.
    let sphere: Vec<usize> = (0..w * w).filter(|&i| pt[0][i][0] < 0.7 && pt[1][i][0] < 0.7).collect();
    assert!(sphere.len() > 200, "the sphere covers {} pixels", sphere.len());
    let noise = |a: &[[f32; 4]], b: &[[f32; 4]]| {
        let v: Vec<f64> = sphere.iter().map(|&i| (lum(&a[i]) - lum(&b[i])).powi(2) / 2.0).collect();
        let s: f64 = v.iter().sum();
        (s, 3.0 * s * s / v.iter().map(|x| x * x).sum::<f64>())
    };
    let (v_pt, m_pt) = noise(&pt[0], &pt[1]);
    let (mean_pt, se_pt) = region_stats(&pt[0], &pt[1], &sphere);
    for (label, extra) in [
        ("photon", vec!["--integrator", "photon", "--spp", "64", "--photons", "20000"]),
        ("sppm", vec!["--integrator", "sppm", "--sppm-iterations", "64"]),
    ] {
        let img: Vec<Vec<[f32; 4]>> = ["1", "2"]
            .iter()
            .map(|seed| {
                let mut a = extra.clone();
                a.extend_from_slice(&["--seed", seed]);
                r(&format!("{label}{seed}.exr"), &a)
            })
            .collect();
        let (mean, se) = region_stats(&img[0], &img[1], &sphere);
        let bound = 5.0 * (se * se + se_pt * se_pt).sqrt();
        let (v, m) = noise(&img[0], &img[1]);
        let log_bound = 5.0 * (2.0 / m + 2.0 / m_pt).sqrt();
        eprintln!(
            "{label}: sphere mean {mean:.5} ± {se:.5} vs path {mean_pt:.5} ± {se_pt:.5} (bound {bound:.5}); \
             noise ratio {:.3} (dof {m:.0} / {m_pt:.0}, bound e^±{log_bound:.3})",
            v / v_pt
        );
        assert!((mean - mean_pt).abs() <= bound, "{label}: mean {mean} vs {mean_pt} (bound {bound})");
        assert!((v / v_pt).ln().abs() <= log_bound, "{label}: noise {v} vs the path tracer's {v_pt}");
    }
}
