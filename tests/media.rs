//! Participating media and subsurface scattering, end to end through the binary:
//! transmittance of a slab (analytic), a scattering furnace (energy conservation), the
//! reflectance of a semi-infinite scattering medium against Chandrasekhar's exact
//! solution, the same for a random-walk subsurface material, and bad input.
//!
//! Statistical bounds as in `render.rs`: 5 standard errors of the pixel mean (pixels
//! are independent estimates), plus the error of the reference where it is numeric.

mod common;

use caustic::scene::camera::CameraRays;
use common::{GltfBuilder, fog_layer, look_rotation, mean_se, render_image, run, temp_dir};
use glam::Vec3;
use serde_json::json;
use std::path::Path;
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);

fn render(scene: &Path, out: &Path, extra: &[&str]) -> Vec<[f32; 4]> {
    render_image(scene, out, extra, LIMIT)
}

/// A material whose mesh bounds a medium and has no surface.
fn medium_material(g: &mut GltfBuilder, sigma_s: [f32; 3], sigma_a: [f32; 3], surface: bool) -> usize {
    g.use_ext("CAUSTIC_materials_medium");
    g.use_ext("KHR_materials_transmission");
    g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
        "extensions": {
            "KHR_materials_transmission": {"transmissionFactor": 1.0},
            "CAUSTIC_materials_medium": {
                "density": 1.0, "scatter_color": sigma_s, "absorption_color": sigma_a, "surface": surface
            }
        }
    }))
}

/// A point light over a white plane seen through nothing, then through a slab of a
/// chromatic scattering medium between light and plane (the camera is below the slab,
/// max depth 1: each pixel is NEE only, deterministic). The ratio of the two images is
/// the shadow ray's transmittance exp(-σt d / cos θ), θ ≤ 0.02 rad here so
/// 1/cos θ - 1 < 2e-4; asserted per pixel to 1e-3 relative.
#[test]
fn slab_transmittance_on_shadow_rays() {
    let dir = temp_dir();
    let (sigma_s, sigma_a) = ([1.0f32, 0.5, 0.2], [0.5f32, 1.0, 2.0]);
    let d = 0.5f32;
    let mut images = Vec::new();
    for with_slab in [false, true] {
        let mut g = GltfBuilder::new();
        let white = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
        g.mesh(
            &[[-20.0, 0.0, -20.0], [20.0, 0.0, -20.0], [20.0, 0.0, 20.0], [-20.0, 0.0, 20.0]],
            &[0, 2, 1, 0, 3, 2],
            white,
        );
        if with_slab {
            let m = medium_material(&mut g, sigma_s, sigma_a, false);
            g.cube([-10.0, 1.0, -10.0], [10.0, 1.0 + d, 10.0], m);
        }
        g.camera([0.0, 0.5, 0.0], look_rotation([0.0, -1.0, 0.001]), 0.1);
        g.punctual(json!({"type": "point", "intensity": 683.0}), [0.0, 3.0, 0.0], [0.0, 0.0, 0.0, 1.0]);
        let path = g.write(dir.path(), "slab.gltf");
        images.push(render(
            &path,
            &dir.path().join("s.exr"),
            &[
                "--resolution",
                "16x16",
                "--spp",
                "1",
                "--max-depth",
                "1",
                "--filter",
                "box",
                "--filter-width",
                "0.00001",
            ],
        ));
    }
    for (a, b) in images[0].iter().zip(&images[1]) {
        for c in 0..3 {
            let expect = (-(sigma_s[c] + sigma_a[c]) * d).exp();
            let got = b[c] / a[c];
            assert!((got - expect).abs() <= 1e-3 * expect, "channel {c}: {got} vs {expect}");
        }
    }
}

/// Furnace: a cube of non-absorbing medium (albedo 1, chromatic σs so that the channels
/// sample differently) in a uniform world of radiance L: every pixel is L, with an
/// invisible boundary and with a smooth glass boundary (which brings the medium in
/// through refraction). Scattering is isotropic and forward; depth 1024 leaves the
/// truncation below 1e-6 (optical size ≤ 8).
#[test]
fn scattering_furnace() {
    let l = 0.7f64;
    for (surface, g_aniso) in [(false, 0.0f32), (true, 0.6)] {
        let dir = temp_dir();
        let mut g = GltfBuilder::new();
        g.use_ext("CAUSTIC_materials_medium");
        g.use_ext("KHR_materials_transmission");
        let m = g.material(json!({
            "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
            "extensions": {
                "KHR_materials_transmission": {"transmissionFactor": 1.0},
                "CAUSTIC_materials_medium": {"density": 2.0, "scatter_color": [0.25, 1.0, 4.0], "anisotropy": g_aniso, "surface": surface}
            }
        }));
        g.cube([-1.0, -1.0, -3.0], [1.0, 1.0, -1.0], m);
        g.camera([0.0, 0.0, 1.0], look_rotation([0.0, 0.0, -1.0]), 0.9);
        g.world(json!({"color": [l, l, l]}));
        g.settings(json!({"transparent": false}));
        let path = g.write(dir.path(), "furnace.gltf");
        let px =
            render(&path, &dir.path().join("f.exr"), &["--resolution", "16x16", "--spp", "64", "--max-depth", "1024"]);
        for c in 0..3 {
            let v: Vec<f64> = px.iter().map(|p| p[c] as f64).collect();
            let (mean, se) = mean_se(&v);
            eprintln!("furnace surface={surface} channel {c}: {mean:.5} ± {se:.5}, expected {l}");
            assert!((mean - l).abs() <= 5.0 * se + 1e-6, "surface={surface} channel {c}: {mean} vs {l}");
        }
    }
}

/// Chandrasekhar's H-function of isotropic scattering with single-scattering albedo
/// `a`, at the nodes of an N-point midpoint rule on [0, 1], by iterating
/// 1/H(μ) = √(1-a) + (a/2) ∫ μ' H(μ') / (μ + μ') dμ' (Chandrasekhar 1960, ch. V).
struct HFunction {
    a: f64,
    mu: Vec<f64>,
    h: Vec<f64>,
}

impl HFunction {
    fn new(a: f64) -> Self {
        let n = 800;
        let mu: Vec<f64> = (0..n).map(|i| (i as f64 + 0.5) / n as f64).collect();
        let mut h = vec![1.0; n];
        for _ in 0..3000 {
            let next: Vec<f64> = mu
                .iter()
                .map(|&m| {
                    let s: f64 = mu.iter().zip(&h).map(|(&mp, &hp)| mp * hp / (m + mp)).sum::<f64>() / n as f64;
                    1.0 / ((1.0 - a).sqrt() + 0.5 * a * s)
                })
                .collect();
            let change = next.iter().zip(&h).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
            h = next;
            if change < 1e-12 {
                break;
            }
        }
        HFunction { a, mu, h }
    }

    fn at(&self, m: f64) -> f64 {
        let n = self.mu.len() as f64;
        let s: f64 = self.mu.iter().zip(&self.h).map(|(&mp, &hp)| mp * hp / (m + mp)).sum::<f64>() / n;
        1.0 / ((1.0 - self.a).sqrt() + 0.5 * self.a * s)
    }

    /// Radiance reflected toward cosine μ by a semi-infinite medium under uniform
    /// illumination of radiance 1, index-matched: 1 - √(1-a) H(μ) (Chandrasekhar 1960;
    /// also the plane albedo for a beam at μ, by reciprocity).
    fn reflected(&self, m: f64) -> f64 {
        1.0 - (1.0 - self.a).sqrt() * self.at(m)
    }

    /// Zeroth moment ∫H dμ, whose exact value is 2(1 - √(1-a))/a: checks the solver.
    fn h0(&self) -> f64 {
        self.h.iter().sum::<f64>() / self.h.len() as f64
    }
}

#[test]
fn h_function_solver_is_accurate() {
    for a in [0.38f64, 0.5, 0.76, 0.8, 0.91, 0.95] {
        let h = HFunction::new(a);
        let exact = 2.0 * (1.0 - (1.0 - a).sqrt()) / a;
        assert!((h.h0() - exact).abs() < 2e-4, "a={a}: h0 {} vs {exact}", h.h0());
        // Without scattering H = 1.
        assert!((HFunction::new(0.0).at(0.3) - 1.0).abs() < 1e-12);
    }
}

/// Renders the top face of a thick box in a uniform world of radiance 1, from a
/// camera at `elevation` (radians above the horizon), and returns the pixels with the
/// cosine of each pixel's view angle to the face.
fn semi_infinite_view(
    g: GltfBuilder,
    elevation: f32,
    spp: &str,
    max_depth: &str,
    extra: &[&str],
) -> Vec<([f32; 4], f64)> {
    let dir = temp_dir();
    let mut g = g;
    let view = Vec3::new(0.0, -elevation.sin(), -elevation.cos());
    let cam_pos = Vec3::new(0.0, 0.0, 0.0) - view * 3.0;
    g.camera(cam_pos.to_array(), look_rotation(view.to_array()), 0.1);
    g.world(json!({"color": [1, 1, 1]}));
    g.settings(json!({"transparent": false}));
    let path = g.write(dir.path(), "semi.gltf");
    let (w, h) = (16u32, 16u32);
    let resolution = format!("{w}x{h}");
    let mut args = vec![
        "--resolution",
        &resolution,
        "--spp",
        spp,
        "--max-depth",
        max_depth,
        "--filter",
        "box",
        "--filter-width",
        "0.00001",
    ];
    args.extend_from_slice(extra);
    let px = render(&path, &dir.path().join("s.exr"), &args);
    let scene = caustic::scene::gltf::load(&path).unwrap();
    let cam = CameraRays::new(&scene.cameras[0], w, h);
    let mut out = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let (_, d) = cam.ray(x as f32 + 0.5, y as f32 + 0.5);
            out.push((px[(y * w + x) as usize], (-d.y) as f64));
        }
    }
    out
}

/// Total diffuse reflectance of a thick slab of isotropically scattering medium with a
/// matched (invisible) boundary, against the exact solution 1 - √(1-a) H(μ) for three
/// albedos at once (chromatic σs, σt = 10 per unit; the box is 40 mean free paths deep
/// and 200 wide, so it is semi-infinite to within e^-20).
#[test]
fn semi_infinite_medium_reflectance() {
    let albedo = [0.5f64, 0.8, 0.95];
    let mut g = GltfBuilder::new();
    let st = 10.0f64;
    let sigma_s = albedo.map(|a| (a * st) as f32);
    let sigma_a = albedo.map(|a| ((1.0 - a) * st) as f32);
    let m = medium_material(&mut g, sigma_s, sigma_a, false);
    g.cube([-10.0, -4.0, -10.0], [10.0, 0.0, 10.0], m);
    let px = semi_infinite_view(g, 0.9, "64", "1024", &[]);
    for (c, &a) in albedo.iter().enumerate() {
        let h = HFunction::new(a);
        let v: Vec<f64> = px.iter().map(|(p, _)| p[c] as f64).collect();
        let expect = px.iter().map(|(_, mu)| h.reflected(*mu)).sum::<f64>() / px.len() as f64;
        let (mean, se) = mean_se(&v);
        eprintln!("semi-infinite medium a={a}: {mean:.5} ± {se:.5}, exact {expect:.5}");
        // The H-function's quadrature error is below 2e-4 (`h_function_solver_is_accurate`).
        assert!((mean - expect).abs() <= 5.0 * se + 2e-4, "a={a}: {mean} vs {expect}");
    }
}

/// A thick box with a random-walk subsurface material (no specular layer, near-smooth
/// interface of index 1.01 so the entry direction is the view direction bent by Snell's
/// law): the walk is a semi-infinite isotropic medium of single-scattering albedo
/// α = `single_scattering_albedo(colour)` entered along μt and left diffusely, which
/// the path then carries to the uniform world, so each pixel is 1 - √(1-α) H(μt)
/// (the plane albedo). The radius sets only the scale: mean free path 1/4π·0.1 = 0.008,
/// 250 of them in the box's depth, so the walk's steps often start within 1e-5 of the
/// box's 20-unit triangles and must still see them (`accel`'s
/// `random_walks_in_a_box_do_not_step_out`: before that was fixed, 1% of walks were lost
/// and this read 1.5% dark).
#[test]
fn subsurface_walk_reflectance() {
    subsurface_walk_reflectance_at("1024", &[]);
}

/// The same walk under Max Bounces 0 and a clamp on indirect light so small that it would
/// blacken anything indirect: the same image. Cycles counts no bounce for the walk
/// (`subsurface_bounce` moves no counter; the exit is never terminated), so the exit's
/// estimate and the world found by its diffuse bounce are bounce 0's, direct. Before, the
/// walk counted as an event: at --max-depth 1 the box was black.
#[test]
fn a_subsurface_walk_is_no_bounce() {
    subsurface_walk_reflectance_at("1", &["--clamp-indirect", "1e-6"]);
}

fn subsurface_walk_reflectance_at(max_depth: &str, extra: &[&str]) {
    let colour = [0.1f32, 0.3, 0.5];
    let mut g = GltfBuilder::new();
    g.use_ext("CAUSTIC_materials_subsurface");
    g.use_ext("KHR_materials_specular");
    g.use_ext("KHR_materials_ior");
    let m = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [colour[0], colour[1], colour[2], 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
        "extensions": {
            "KHR_materials_specular": {"specularFactor": 0.0},
            "KHR_materials_ior": {"ior": 1.01},
            "CAUSTIC_materials_subsurface": {"weight": 1.0, "radius": [0.1, 0.1, 0.1], "method": "random_walk"}
        }
    }));
    g.cube([-10.0, -2.0, -10.0], [10.0, 0.0, 10.0], m);
    let px = semi_infinite_view(g, 0.9, "256", max_depth, extra);
    let eta = 1.01f64;
    for c in 0..3 {
        let alpha = caustic::medium::single_scattering_albedo(colour[c], 0.0) as f64;
        let h = HFunction::new(alpha);
        let mu_t = |mu: f64| (1.0 - (1.0 - mu * mu) / (eta * eta)).sqrt();
        let expect = px.iter().map(|(_, mu)| h.reflected(mu_t(*mu))).sum::<f64>() / px.len() as f64;
        let v: Vec<f64> = px.iter().map(|(p, _)| p[c] as f64).collect();
        let (mean, se) = mean_se(&v);
        eprintln!("subsurface colour {}: α = {alpha:.4}, {mean:.5} ± {se:.5}, exact {expect:.5}", colour[c]);
        assert!((mean - expect).abs() <= 5.0 * se + 2e-4, "channel {c}: {mean} vs {expect}");
        assert!(mean <= 1.0, "energy");
    }
}

/// How closely Cycles' albedo inversion makes the diffuse albedo of the walk (a
/// semi-infinite medium lit uniformly, left diffusely: 1 - 2√(1-α) ∫ H μ dμ) equal
/// the colour. The fit's residual measured here is ≤ 0.007 for colours 0.1-0.7; the
/// bound 0.02 is a regression bound on that (one wrong coefficient moves it by more).
/// Colours near 1 give α within 1e-3 of 1, where the H iteration does not converge.
#[test]
fn albedo_inversion_against_exact_albedo() {
    for a in [0.1f32, 0.3, 0.5, 0.7] {
        let alpha = caustic::medium::single_scattering_albedo(a, 0.0) as f64;
        let h = HFunction::new(alpha);
        let exact_h0 = 2.0 * (1.0 - (1.0 - alpha).sqrt()) / alpha;
        assert!((h.h0() - exact_h0).abs() < 2e-4, "solver at α = {alpha}");
        let n = h.mu.len() as f64;
        let h1: f64 = h.mu.iter().zip(&h.h).map(|(m, x)| m * x).sum::<f64>() / n;
        let albedo = 1.0 - 2.0 * (1.0 - alpha).sqrt() * h1;
        eprintln!("colour {a}: α = {alpha:.4}, diffuse albedo of the walk {albedo:.4}");
        assert!((albedo - a as f64).abs() < 0.02, "colour {a}: {albedo}");
    }
}

/// Bad media are refused by name; negative radii too.
#[test]
fn bad_media_are_refused() {
    for (ext, body) in [
        ("CAUSTIC_materials_medium", json!({"density": -1.0})),
        ("CAUSTIC_materials_medium", json!({"scatter_color": [1.0, -0.5, 1.0]})),
        ("CAUSTIC_materials_medium", json!({"anisotropy": 2.0})),
        ("CAUSTIC_materials_medium", json!({"sigma": 1.0})),
        ("CAUSTIC_materials_medium", json!({"phase": "SCHLICK"})),
        ("CAUSTIC_materials_medium", json!({"phase": "MIE", "phase_diameter": "big"})),
        ("CAUSTIC_materials_subsurface", json!({"radius": [1.0, -1.0, 1.0]})),
        ("CAUSTIC_materials_subsurface", json!({"radius": [1.0, 1.0, 1.0], "method": "burley"})),
    ] {
        let dir = temp_dir();
        let mut g = GltfBuilder::new();
        g.use_ext(ext);
        let m = g.material(json!({"name": "bad", "extensions": {ext: body}}));
        g.cube([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], m);
        let path = g.write(dir.path(), "bad.gltf");
        let out = dir.path().join("o.exr");
        let r = run(&["render", path.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"], LIMIT);
        assert_eq!(r.code, Some(3), "{ext} {body}: {}", r.stderr);
        let msg = r.error_message().unwrap();
        assert!(msg.contains("bad") && msg.contains(ext), "{msg}");
    }
}

/// Mean of two independent renders and the standard error of that mean, from their
/// difference (as in tests/photon.rs).
fn two_seed_stats(a: &[[f32; 4]], b: &[[f32; 4]]) -> (f64, f64) {
    let lum = |p: &[f32; 4]| (p[0] + p[1] + p[2]) as f64 / 3.0;
    let n = a.len() as f64;
    let mean = a.iter().zip(b).map(|(x, y)| lum(x) + lum(y)).sum::<f64>() / (2.0 * n);
    let d2 = a.iter().zip(b).map(|(x, y)| (lum(x) - lum(y)).powi(2)).sum::<f64>();
    (mean, (d2 / (2.0 * n * n) / 2.0).sqrt())
}

/// SPPM and Jensen's photon mapping converge to the path tracer with media: a chromatic,
/// forward-scattering fog slab between a point light and a floor, seen from below the
/// slab (the floor's light came through the fog: NEE through it, photons scattered in
/// it) and from above (camera paths scatter in the fog and are path traced from there);
/// and a thick random-walk subsurface slab under the light (the subsurface part is
/// path traced from the visible point, photons walk through it). Bound: 5σ of the two
/// estimates (two seeds each); no face edge is in view, so the photon estimate's edge
/// bias (tests/photon.rs) is zero and its curvature term, O(r²/h²) < 10⁻³ with r ≤ 0.05
/// and the light 3 above, is folded into the 5σ as there.
#[test]
fn photon_mapping_matches_path_tracing_in_media() {
    let dir = temp_dir();
    for (label, eye, look) in [
        ("fog below", [0.0f32, 0.6, 1.5], [0.0f32, -0.6, -1.5]),
        ("fog above", [0.0, 2.5, 2.0], [0.0, -2.5, -2.0]),
        ("subsurface", [0.0, 1.5, 2.0], [0.0, -1.5, -2.0]),
    ] {
        let mut g = GltfBuilder::new();
        if label == "subsurface" {
            g.use_ext("CAUSTIC_materials_subsurface");
            let m = g.material(json!({
                "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.6, 0.5, 1], "metallicFactor": 0.0, "roughnessFactor": 0.5},
                "extensions": {"CAUSTIC_materials_subsurface": {"radius": [1.0, 0.7, 0.5]}}
            }));
            g.cube([-20.0, -2.0, -20.0], [20.0, 0.0, 20.0], m);
            g.punctual(json!({"type": "point", "intensity": 2732.0}), [0.3, 3.0, -0.2], [0.0, 0.0, 0.0, 1.0]);
        } else {
            fog_layer(&mut g);
        }
        g.camera(eye, look_rotation(look), 0.6);
        let path = g.write(dir.path(), "fog.gltf");
        let r = |name: &str, extra: &[&str]| {
            let mut a = vec!["--resolution", "24x24"];
            a.extend_from_slice(extra);
            render(&path, &dir.path().join(name), &a)
        };
        let pt_a = r("pt_a.exr", &["--spp", "256", "--seed", "1"]);
        let pt_b = r("pt_b.exr", &["--spp", "256", "--seed", "2"]);
        let (pt, se_pt) = two_seed_stats(&pt_a, &pt_b);
        let sppm = ["--integrator", "sppm", "--sppm-iterations", "256", "--sppm-radius", "0.05"];
        let jensen = ["--integrator", "photon", "--spp", "64", "--photons", "100000", "--max-radius", "0.05"];
        for (name, args) in [("SPPM", &sppm[..]), ("PM", &jensen[..])] {
            let run_seed = |seed: &str| {
                let mut a = args.to_vec();
                a.extend_from_slice(&["--seed", seed]);
                r(&format!("{name}{seed}.exr"), &a)
            };
            let (a, b) = (run_seed("1"), run_seed("2"));
            let (m, se) = two_seed_stats(&a, &b);
            let bound = 5.0 * (se_pt * se_pt + se * se).sqrt();
            eprintln!(
                "{label}: PT {pt:.5} ± {se_pt:.5}, {name} {m:.5} ± {se:.5}, ratio {:.4}, bound {bound:.5}",
                m / pt
            );
            assert!((m - pt).abs() <= bound, "{label}: {name} {m} vs PT {pt} (bound {bound})");
        }
    }
}

/// The bundled media scene renders at a tiny size: finite, not black, no dropped samples.
#[test]
fn subsurface_scene_renders() {
    let dir = temp_dir();
    let scene = common::root().join("scenes/subsurface.gltf");
    let out = dir.path().join("s.exr");
    let r = run(
        &[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--progress",
            "json",
            "--resolution",
            "32x24",
            "--spp",
            "4",
        ],
        LIMIT,
    );
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let s = r.summary().unwrap();
    assert_eq!(s["nan_samples"], 0, "{s}");
    let px = caustic::output::read_combined(&out).unwrap().2;
    assert!(px.iter().all(|p| p.iter().all(|c| c.is_finite())));
    let mean = px.iter().map(|p| (p[0] + p[1] + p[2]) as f64).sum::<f64>() / px.len() as f64;
    assert!(mean > 0.01, "black image: {mean}");
}

/// A medium in an open mesh is rendered (a defined behaviour) with a warning naming it.
#[test]
fn open_medium_mesh_warns() {
    let dir = temp_dir();
    let mut g = GltfBuilder::new();
    let m = medium_material(&mut g, [1.0, 1.0, 1.0], [0.0; 3], false);
    g.doc_material_name(m, "leaky");
    // A box without its top: two triangles fewer.
    g.mesh(
        &[
            [-1.0, -1.0, -3.0],
            [1.0, -1.0, -3.0],
            [1.0, 1.0, -3.0],
            [-1.0, 1.0, -3.0],
            [-1.0, -1.0, -1.0],
            [1.0, -1.0, -1.0],
            [1.0, 1.0, -1.0],
            [-1.0, 1.0, -1.0],
        ],
        &[0, 2, 1, 0, 3, 2, 0, 1, 5, 0, 5, 4, 1, 2, 6, 1, 6, 5, 2, 3, 7, 2, 7, 6, 3, 0, 4, 3, 4, 7],
        m,
    );
    let closed = medium_material(&mut g, [1.0, 1.0, 1.0], [0.0; 3], false);
    g.doc_material_name(closed, "tight");
    g.cube([2.0, -1.0, -3.0], [3.0, 1.0, -1.0], closed);
    g.camera([0.0, 0.0, 1.0], look_rotation([0.0, 0.0, -1.0]), 0.9);
    g.world(json!({"color": [1, 1, 1]}));
    let path = g.write(dir.path(), "open.gltf");
    let scene = caustic::scene::gltf::load(&path).unwrap();
    let w = scene.warnings.join("\n");
    assert!(w.contains("leaky") && w.contains("not closed") && w.contains("4 open edges"), "{w}");
    assert!(!w.contains("tight"), "{w}");
}

/// Next-event estimation at a gather vertex inside a medium sees the medium: a V-shaped
/// groove of two diffuse planes inside an absorbing fog, lit by a point light above the
/// fog and seen from above. With two diffuse bounces Jensen's gather rays do NEE at the
/// second plane, inside the fog; a shadow ray started there without the gather ray's
/// media would miss the absorption up to the fog's top (about e¹ too bright there). Bound:
/// 5σ of the two estimates plus the photon estimate's edge bias at the crease, at most
/// half the estimate within r = 0.05 of it: 0.5 × 2r / 2.9 (the planes' width in view)
/// < 1.8 % of the mean, where the map is read.
#[test]
fn gather_nee_inside_a_medium_sees_it() {
    let dir = temp_dir();
    let mut g = GltfBuilder::new();
    let white = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "doubleSided": true
    }));
    g.mesh(&[[-2.0, 1.0, -3.0], [0.0, -0.6, -3.0], [0.0, -0.6, 3.0], [-2.0, 1.0, 3.0]], &[0, 2, 1, 0, 3, 2], white);
    g.mesh(&[[0.0, -0.6, -3.0], [2.0, 1.0, -3.0], [2.0, 1.0, 3.0], [0.0, -0.6, 3.0]], &[0, 2, 1, 0, 3, 2], white);
    g.use_ext("CAUSTIC_materials_medium");
    let fog = g.material(json!({"extensions": {"CAUSTIC_materials_medium": {
        "density": 1.0, "scatter_color": [0.0, 0.0, 0.0], "absorption_color": [1.0, 1.0, 1.0], "surface": false}}}));
    g.cube([-6.0, -1.0, -6.0], [6.0, 1.2, 6.0], fog);
    g.camera([0.0, 3.0, 1.5], look_rotation([0.0, -3.0, -1.5]), 0.5);
    g.punctual(json!({"type": "point", "intensity": 3000.0}), [0.3, 3.0, -0.2], [0.0, 0.0, 0.0, 1.0]);
    let path = g.write(dir.path(), "groove.gltf");
    let r = |name: &str, extra: &[&str]| {
        let mut a = vec!["--resolution", "24x24"];
        a.extend_from_slice(extra);
        render(&path, &dir.path().join(name), &a)
    };
    let (pt, se_pt) =
        two_seed_stats(&r("a.exr", &["--spp", "256", "--seed", "1"]), &r("b.exr", &["--spp", "256", "--seed", "2"]));
    let pm = ["--integrator", "photon", "--spp", "64", "--photons", "200000", "--max-radius", "0.05"];
    let run_seed = |seed: &str| {
        let mut a = pm.to_vec();
        a.extend_from_slice(&["--diffuse-bounces", "2", "--seed", seed]);
        r(&format!("pm{seed}.exr"), &a)
    };
    let (m, se) = two_seed_stats(&run_seed("1"), &run_seed("2"));
    let bound = 5.0 * (se_pt * se_pt + se * se).sqrt() + 0.018 * pt;
    eprintln!("groove in fog: PT {pt:.5} ± {se_pt:.5}, PM {m:.5} ± {se:.5}, ratio {:.4}, bound {bound:.5}", m / pt);
    assert!((m - pt).abs() <= bound, "PM {m} vs PT {pt} (bound {bound})");
}

/// The world's volume (`CAUSTIC_world.medium`, Blender's World Volume) fills the scene and
/// the camera is in it. Absorption only: an emissive plane at distance D seen through it
/// has radiance Le·exp(−σa (D − znear) / cos θ) for the pixel centre's ray at angle θ to the
/// axis (the ray starts at the near clipping plane, as Cycles' Clip Start),
/// exact in every integrator (no sampling at depth 0: the pass weight is the
/// transmittance, and the filter is a box of width 1e-5 px); checked to 1e-4 relative
/// (f32 rounding of the hit distance and of exp).
#[test]
fn world_volume_absorbs_along_camera_rays() {
    let dir = temp_dir();
    let (le, d, sigma_a) = (2.0f32, 1.5f32, [0.5f32, 1.0, 2.0]);
    let mut g = GltfBuilder::new();
    g.use_ext("KHR_materials_emissive_strength");
    let m = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "emissiveFactor": [1, 1, 1],
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": le}}
    }));
    // A plane facing +z at z = -d; the camera at the origin looks down -z.
    g.mesh(&[[-5.0, -5.0, -d], [5.0, -5.0, -d], [5.0, 5.0, -d], [-5.0, 5.0, -d]], &[0, 1, 2, 0, 2, 3], m);
    g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.06);
    g.world(json!({"color": [0, 0, 0], "medium": {
        "density": 1.0, "scatter_color": [0, 0, 0], "absorption_color": sigma_a
    }}));
    let path = g.write(dir.path(), "world_absorb.gltf");
    assert_absorbed_on_camera_rays(dir.path(), &path, le, sigma_a, d);
}

/// Renders `scene` (a camera at the origin looking down −z with a 0.06 rad field of view,
/// an emitter of radiance `le` behind absorption `sigma_a` over the axial depth `depth`) at
/// 8×8, 1 spp, with a 1e-5 px box filter in all four integrators, and checks each pixel
/// against Le·exp(−σa D) along its ray to 1e-4 relative (f32 rounding of the hit distance
/// and of exp). The camera ray starts at the near plane (GltfBuilder's znear 0.01).
fn assert_absorbed_on_camera_rays(dir: &Path, scene: &Path, le: f32, sigma_a: [f32; 3], depth: f32) {
    for integrator in ["path", "bdpt", "photon", "sppm"] {
        let img = render(
            scene,
            &dir.join(format!("{integrator}.exr")),
            &[
                "--resolution",
                "8x8",
                "--spp",
                "1",
                "--integrator",
                integrator,
                "--filter",
                "box",
                "--filter-width",
                "0.00001",
            ],
        );
        let tan_half = (0.03f64).tan();
        for (i, p) in img.iter().enumerate() {
            let x = (2.0 * ((i % 8) as f64 + 0.5) / 8.0 - 1.0) * tan_half;
            let y = (2.0 * ((i / 8) as f64 + 0.5) / 8.0 - 1.0) * tan_half;
            let dist = (depth as f64 - 0.01) * (1.0 + x * x + y * y).sqrt();
            for c in 0..3 {
                let expected = (le as f64 * (-sigma_a[c] as f64 * dist).exp()) as f32;
                assert!(
                    (p[c] - expected).abs() <= 1e-4 * expected,
                    "{integrator}: channel {c} gives {} where Le·exp(−σa D) = {expected}",
                    p[c]
                );
            }
        }
    }
}

/// An unbounded world volume that scatters, absorbs and emits (σs = 1, σa = 0.5, emission
/// E = 1 per unit length, isotropic) and nothing else: the radiance is the same everywhere
/// and in every direction, L = E/σa = 2 (in the transport equation dL/ds = −σt L + σs L + E
/// = 0). Paths are cut at depth 60 (BDPT's limit is 62), which leaves out (σs/σt)^60 · L ≈ 5e-11. Checked per
/// integrator to 5 standard errors of the image mean (pixels are independent estimates).
#[test]
fn world_volume_emission_reaches_equilibrium() {
    let dir = temp_dir();
    let mut g = GltfBuilder::new();
    // The renderer wants a triangle: one 10^4 units away, behind 1.5e4 optical depths.
    let black = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0}}));
    g.mesh(&[[0.0, 0.0, 1e4], [1.0, 0.0, 1e4], [0.0, 1.0, 1e4]], &[0, 1, 2], black);
    g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 1.0);
    g.world(json!({"color": [0, 0, 0], "medium": {
        "density": 1.0, "scatter_color": [1, 1, 1], "absorption_color": [0.5, 0.5, 0.5], "emission": [1, 1, 1]
    }}));
    let path = g.write(dir.path(), "world_emit.gltf");
    for integrator in ["path", "bdpt", "photon", "sppm"] {
        let img = render(
            &path,
            &dir.path().join(format!("{integrator}.exr")),
            &["--resolution", "16x16", "--spp", "16", "--max-depth", "60", "--integrator", integrator],
        );
        let lum: Vec<f64> = img.iter().map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0).collect();
        let (mean, se) = mean_se(&lum);
        eprintln!("{integrator}: L = {mean:.4} ± {se:.4} (expected 2)");
        assert!((mean - 2.0).abs() <= 5.0 * se + 1e-4, "{integrator}: L = {mean} ± {se}, expected E/σa = 2");
    }
    // The photon integrators say that their photons start in the emitting fog only within
    // the scene's box; the others have nothing to say.
    for (integrator, warns) in [("path", false), ("photon", true), ("sppm", true)] {
        let out = dir.path().join(format!("w_{integrator}.exr"));
        let w = common::quick_render_warnings(&path, &out, &["--integrator", integrator], LIMIT);
        assert_eq!(w.iter().any(|w| w.contains("World Volume emits")), warns, "{integrator}: {w:?}");
    }
}

/// A world medium is checked as a mesh medium is, and one with emission in a channel it
/// does not attenuate (infinite radiance) is refused.
#[test]
fn bad_world_media_are_refused() {
    for (medium, words) in [
        (json!({"density": -1.0}), "non-negative"),
        (json!({"scatter_color": [0, 0, 0], "absorption_color": [1, 0, 1], "emission": [1, 1, 1]}), "infinite"),
        (json!({"surface": false}), "surface"),
    ] {
        let dir = temp_dir();
        let mut g = GltfBuilder::new();
        let m = g.material(json!({}));
        g.mesh(&[[0.0, 0.0, -2.0], [1.0, 0.0, -2.0], [0.0, 1.0, -2.0]], &[0, 1, 2], m);
        g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 1.0);
        g.world(json!({"medium": medium}));
        let path = g.write(dir.path(), "bad_world.gltf");
        let out = dir.path().join("o.exr");
        let r = run(&["render", path.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"], LIMIT);
        assert_eq!(r.code, Some(3), "{medium}: {}", r.stderr);
        let msg = r.error_message().unwrap();
        assert!(msg.contains("CAUSTIC_world") && msg.contains(words), "{msg}");
    }
}

/// A camera inside a closed mesh medium starts its paths in it (as Cycles does): inside a
/// cube of absorbing medium (no surface; half-size 2, σa per channel), the camera at the
/// centre looks at an emitter of radiance Le outside the cube, so each pixel is
/// Le·exp(−σa·(D_inside)) where D_inside is the camera ray's length up to the cube's face
/// (the emitter's own distance does not matter: vacuum beyond). Exact in every integrator as
/// in `world_volume_absorbs_along_camera_rays` (pure absorption at depth 0), 1e-4 relative.
/// Before the fix the camera counted itself outside, and the pixels were Le.
#[test]
fn camera_inside_a_mesh_medium_starts_in_it() {
    let dir = temp_dir();
    let (le, half, sigma_a) = (2.0f32, 2.0f32, [0.5f32, 1.0, 0.25]);
    let mut g = GltfBuilder::new();
    g.use_ext("KHR_materials_emissive_strength");
    let glow = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "emissiveFactor": [1, 1, 1],
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": le}}
    }));
    let water = medium_material(&mut g, [0.0; 3], sigma_a, false);
    g.cube([-half; 3], [half; 3], water);
    // The emitter faces +z at z = -5, outside the cube; the camera at the origin looks down -z.
    g.mesh(
        &[[-20.0, -20.0, -5.0], [20.0, -20.0, -5.0], [20.0, 20.0, -5.0], [-20.0, 20.0, -5.0]],
        &[0, 1, 2, 0, 2, 3],
        glow,
    );
    g.camera([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], 0.06);
    let path = g.write(dir.path(), "camera_in_medium.gltf");
    // Absorbed from the near plane to the face z = -half only: vacuum beyond.
    assert_absorbed_on_camera_rays(dir.path(), &path, le, sigma_a, half);
}
