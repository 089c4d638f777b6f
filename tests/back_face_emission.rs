//! Emission leaves both faces of an emissive triangle whatever glTF's `doubleSided` says, as
//! Cycles renders Blender's import of such a file (Cycles culls no back face and its Emission
//! closure emits on both sides), in every integrator: what a camera or BSDF-sampled ray sees,
//! light sampling and its density, the light tree's and the photons' power, light subpaths.
//!
//! The scene: an open square quad of side 2a = 0.5 at height h = 2 over a white Lambertian
//! floor (albedo ρ = 0.8, no specular layer), single-sided (no `doubleSided`), its front facing
//! up, away from the floor; it emits L = 16 and reflects nothing (black, no specular layer), so
//! the floor is lit once, by the quad's back face alone, and nothing else is lit. An
//! orthographic camera between the two (y = 1) looks down at the floor (±0.25 square) or up at
//! the quad's back (±0.2, inside the quad). Before, the floor and the back face were black.
//!
//! The floor's radiance in closed form: a Lambertian floor of albedo ρ under a Lambertian
//! emitter of radiance L has radiance ρ L F, F the view factor from the floor point to the
//! rectangle (E = π L F). For a rectangle parallel to the floor at height h with one corner
//! straight above the point and sides X h, Y h, F = g(X, Y) / 2π with
//! g(X, Y) = X/√(1+X²) · atan(Y/√(1+X²)) + Y/√(1+Y²) · atan(X/√(1+Y²)) (Siegel & Howell's
//! parallel-rectangle case); g is odd in X and in Y, so the quad's F from any point is the
//! signed sum over its four corners. It is evaluated at each pixel's centre: the film's
//! filter averages F over a pixel's neighbourhood instead, which moves it by about
//! (filter width)² · F''/F / 2 ≈ (0.03)² · 1.5 / 2 ≈ 7·10⁻⁴ relative at most (pixels 0.031
//! wide, F''/F ≈ −6/h² at the centre), two orders under the noise bound below.
//!
//! Bounds (`common::agreement`): K = 6 seeds per estimate; each region's mean against the
//! closed form by a one-sample Student-t test, and against the path tracer by Welch's test,
//! at a false-alarm rate of 10⁻³ split over every comparison (Šidák). The photon
//! integrators' gather radius 0.02 averages F over a disk: a relative bias of about
//! r² · |F''/F| / 8 ≈ 3·10⁻⁴, far under the bound.
//!
//! The tests fail without each part of the rule: before it, every integrator rendered the floor,
//! the wall and the back face black; with light subpaths leaving the front alone, BDPT and VCM
//! miss the floor's closed form and the path tracer in every region; with photons carrying the
//! power of one face, Jensen and SPPM miss the path tracer on the wall.

mod common;

use common::agreement::{Seeded, disagreeing, mean_var, regions, sidak};
use common::pass_checks::channels;
use common::{GltfBuilder, look_rotation, render_image, temp_dir};
use serde_json::json;
use statrs::distribution::{ContinuousCDF, StudentsT};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);
const RES: usize = 16;
/// The quad's half side, height and radiance; the floor's albedo.
const A: f64 = 0.25;
const H: f64 = 2.0;
const L: f64 = 16.0;
const RHO: f64 = 0.8;
/// The floor camera's half extent.
const VIEW: f64 = 0.25;

/// Where the camera looks (see the module doc).
#[derive(Clone, Copy, PartialEq)]
enum View {
    /// Down at the floor under the quad.
    Floor,
    /// Up at the quad's back face.
    Back,
    /// At a wall beside the quad, which a white wall at x = 0.6 adds.
    Wall,
}

/// How the quad emits.
#[derive(Clone, Copy, PartialEq)]
enum Glow {
    /// The glTF material of the module doc: L from either face.
    Material,
    /// A node graph whose Emission strength is L × Backfacing: L from the back face alone.
    BackOnly,
    /// A node graph whose Emission strength is L × (1 − Backfacing): the front face alone, as
    /// Blender users make a one-sided emitter.
    FrontOnly,
}

/// The Emission node graph of `glow` (not `Glow::Material`): strength L × Backfacing, or
/// L − L × Backfacing.
fn graph_glow(glow: Glow) -> serde_json::Value {
    let (scale, offset) = if glow == Glow::BackOnly { (L, 0.0) } else { (-L, L) };
    json!({"name": "Glow", "extensions": {"CAUSTIC_materials_nodes": {"version": 1, "nodes": [
        {"name": "Geometry", "type": "ShaderNodeNewGeometry"},
        {"name": "Side", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY_ADD"},
         "inputs": {"Value": {"link": [0, "Backfacing"]}, "Value_001": {"value": scale}, "Value_002": {"value": offset}}},
        {"name": "Emission", "type": "ShaderNodeEmission",
         "inputs": {"Color": {"value": [1, 1, 1, 1]}, "Strength": {"link": [1, "Value"]}}}
    ], "output": {"surface": [2, "Emission"]}}}})
}

/// The scene of the module doc seen from `view`.
fn scene(dir: &Path, view: View) -> PathBuf {
    scene_glowing(dir, view, Glow::Material)
}

/// The scene of the module doc seen from `view`, its quad emitting as `glow` says.
fn scene_glowing(dir: &Path, view: View, glow_kind: Glow) -> PathBuf {
    let mut g = GltfBuilder::new();
    g.use_ext("KHR_materials_specular");
    g.use_ext("KHR_materials_emissive_strength");
    let white = g.material(json!({"name": "White", "pbrMetallicRoughness": {
        "baseColorFactor": [RHO, RHO, RHO, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}}));
    // No `doubleSided`: glTF's default, false.
    let glow = g.material(json!({"name": "Glow", "pbrMetallicRoughness": {
        "baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0},
        "emissiveFactor": [1.0, 1.0, 1.0],
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0},
            "KHR_materials_emissive_strength": {"emissiveStrength": L}}}));
    let glow = if glow_kind == Glow::Material {
        glow
    } else {
        g.use_ext("CAUSTIC_materials_nodes");
        g.material(graph_glow(glow_kind))
    };
    // Both counter-clockwise seen from +Y: the floor faces up, the quad's front faces up too.
    g.mesh(&[[-4.0, 0.0, -4.0], [-4.0, 0.0, 4.0], [4.0, 0.0, 4.0], [4.0, 0.0, -4.0]], &[0, 1, 2, 0, 2, 3], white);
    let (a, h) = (A as f32, H as f32);
    g.mesh(&[[-a, h, -a], [-a, h, a], [a, h, a], [a, h, -a]], &[0, 1, 2, 0, 2, 3], glow);
    match view {
        // A pinhole 1 above the floor whose frame spans ±VIEW there, as the closed form's
        // pixel centres assume; it lets BDPT and VCM trace light to the camera too.
        View::Floor => {
            g.camera([0.0, 1.0, 0.0], look_rotation([0.0, -1.0, 0.0]), 2.0 * (VIEW as f32).atan());
        }
        View::Back => {
            g.orthographic([0.0, 1.0, 0.0], look_rotation([0.0, 1.0, 0.0]), 0.2, 0.2);
        }
        View::Wall => {
            // Facing -X, lit by the quad's back face and by the floor it lights; the camera
            // sees the wall from y 0.49 to 1.11, not the quad.
            g.mesh(&[[0.6, 0.0, -4.0], [0.6, 0.0, 4.0], [0.6, 3.0, 4.0], [0.6, 3.0, -4.0]], &[0, 1, 2, 0, 2, 3], white);
            g.camera([-0.4, 0.8, 0.0], look_rotation([1.0, 0.0, 0.0]), 0.6);
        }
    }
    g.write(
        dir,
        &format!(
            "{}{}.gltf",
            ["floor", "back", "wall"][view as usize],
            ["", "_back_only", "_front_only"][glow_kind as usize]
        ),
    )
}

/// g(X, Y) of the module doc: 2π × the view factor to a rectangle with a corner overhead.
fn corner(x: f64, y: f64) -> f64 {
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    x / sx * (y / sx).atan() + y / sy * (x / sy).atan()
}

/// The floor's radiance at (x, z): ρ L F, F summed over the quad's corners.
fn floor_radiance(x: f64, z: f64) -> f64 {
    let mut g = 0.0;
    for (cx, sx) in [(A, 1.0), (-A, -1.0)] {
        for (cz, sz) in [(A, 1.0), (-A, -1.0)] {
            g += sx * sz * corner((cx - x) / H, (cz - z) / H);
        }
    }
    RHO * L * g / (2.0 * std::f64::consts::PI)
}

/// The closed form's mean over each region's pixel centres. The image's axes need not be
/// known: the floor's radiance is symmetric under x ↔ z and either's sign.
fn expected(regs: &[(String, Vec<usize>)]) -> Vec<f64> {
    let at = |i: usize| ((i as f64 + 0.5) / RES as f64 * 2.0 - 1.0) * VIEW;
    regs.iter()
        .map(|(_, idx)| idx.iter().map(|&i| floor_radiance(at(i % RES), at(i / RES))).sum::<f64>() / idx.len() as f64)
        .collect()
}

/// One-sample Student-t test of the per-seed means `a` against the exact `want`.
fn matches_closed_form(name: &str, a: &[f64], want: f64, alpha: f64) -> bool {
    let (m, v) = mean_var(a);
    let se = (v / a.len() as f64).sqrt();
    let t = StudentsT::new(0.0, 1.0, a.len() as f64 - 1.0).unwrap().inverse_cdf(1.0 - alpha / 2.0);
    eprintln!("{name}: {m:.5} vs closed form {want:.5} (ratio {:.4}), bound {:.2e}", m / want, t * se);
    (m - want).abs() <= t * se
}

/// Every integrator lights the floor from the quad's back face as the closed form says, and
/// agrees with the path tracer region by region.
#[test]
fn the_back_face_of_a_single_sided_emitter_lights_the_floor_in_every_integrator() {
    floor_in_every_integrator(Glow::Material);
}

/// A node graph that emits from the back face alone (strength L × Backfacing) lights the floor
/// under it as the closed form says in every integrator: light sampling, light subpaths and
/// photons read the graph from the side they leave (before, from the front: 0, so the floor
/// got its light from BSDF-sampled rays alone, MIS-weighted, and none in BDPT's and the photon
/// integrators' light strategies).
#[test]
fn a_graph_emitting_by_backfacing_lights_the_side_it_emits_on() {
    floor_in_every_integrator(Glow::BackOnly);
}

/// A node graph that emits from the front face alone (L × (1 − Backfacing), Blender users'
/// one-sided emitter) leaves the floor under its back face black in every integrator: exactly
/// 0 in every pixel (before, light sampling read the front's L from below, so the path tracer's
/// floor was lit by its light samples' MIS-weighted share and the photons lit it fully).
#[test]
fn a_graph_emitting_from_its_front_alone_leaves_the_floor_behind_it_black() {
    let dir = temp_dir();
    let path = scene_glowing(dir.path(), View::Floor, Glow::FrontOnly);
    for (name, flags) in integrator_runs() {
        let out = dir.path().join(format!("{name}.exr"));
        let mut args = vec!["--resolution", "16x16", "--seed", "1"];
        args.extend_from_slice(flags);
        let px = render_image(&path, &out, &args, LIMIT);
        let lit = px.iter().filter(|p| p[..3].iter().any(|&c| c != 0.0)).count();
        assert_eq!(lit, 0, "{name}: {lit} of {} floor pixels lit from behind a front-only emitter", px.len());
    }
}

/// The five integrators' flags for the floor view, at the sample counts the bounds assume.
fn integrator_runs() -> [(&'static str, &'static [&'static str]); 5] {
    [
        ("path", &["--integrator", "path", "--spp", "32"]),
        ("bdpt", &["--integrator", "bdpt", "--spp", "16"]),
        ("vcm", &["--integrator", "vcm", "--spp", "16", "--vcm-radius", "0.02"]),
        ("photon", &["--integrator", "photon", "--spp", "16", "--photons", "100000", "--max-radius", "0.02"]),
        ("sppm", &["--integrator", "sppm", "--sppm-iterations", "16", "--sppm-radius", "0.02"]),
    ]
}

/// The floor under the quad emitting as `glow` (from its back face) against the closed form
/// and the path tracer, in every integrator.
fn floor_in_every_integrator(glow: Glow) {
    let dir = temp_dir();
    let path = scene_glowing(dir.path(), View::Floor, glow);
    let regs = regions(RES, RES);
    let want = expected(&regs);
    let r = format!("{RES}x{RES}");
    let seeded = Seeded::six(dir.path(), &r, "4", &regs, LIMIT);
    let runs = integrator_runs();
    // Five against the closed form and four against the path tracer, each over every region.
    let alpha = sidak(regs.len() * 9);
    let mut failed = Vec::new();
    let mut reference = Vec::new();
    for (name, flags) in runs {
        let m = seeded.means(&path, flags);
        for (k, (rn, _)) in regs.iter().enumerate() {
            if !matches_closed_form(&format!("{name} {rn}"), &m[k], want[k], alpha) {
                failed.push(format!("{name} {rn} (closed form)"));
            }
        }
        if name == "path" {
            reference = m;
        } else {
            failed.extend(disagreeing(name, &regs, &m, &reference, alpha).into_iter().map(|r| format!("{name} {r}")));
        }
    }
    assert!(failed.is_empty(), "disagree: {failed:?}");
}

/// A camera looking at the quad's back face sees its radiance L, in Combined and in the
/// Emission pass, in every integrator.
#[test]
fn a_camera_sees_the_back_face_of_a_single_sided_emitter() {
    let dir = temp_dir();
    let path = scene(dir.path(), View::Back);
    for integrator in ["path", "bdpt", "vcm", "photon", "sppm"] {
        let out = dir.path().join(format!("{integrator}.exr"));
        let args = ["--resolution", "8x8", "--spp", "4", "--integrator", integrator, "--passes", "emit"];
        let px = render_image(&path, &out, &args, LIMIT);
        let emit = channels(&out);
        for (i, p) in px.iter().enumerate() {
            for c in 0..3 {
                // Camera rays meet the emitter first and it reflects nothing: every sample is L
                // (f32 rounding of the film's average of equal samples: 1e-5 relative).
                let e = emit[&format!("Emission.{}", ["R", "G", "B"][c])][i];
                for (what, v) in [("Combined", p[c]), ("Emission", e)] {
                    assert!(
                        (v as f64 - L).abs() <= 1e-5 * L,
                        "{integrator}: {what} pixel {i} channel {c} = {v}, want {L}"
                    );
                }
            }
        }
    }
}

/// Light subpaths and photons leave the back face too: a wall lit by it directly and through
/// the floor it lights (photon maps hold that second part) renders in BDPT, VCM, Jensen and
/// SPPM as in the path tracer, region by region.
#[test]
fn light_subpaths_and_photons_leave_the_back_face_of_a_single_sided_emitter() {
    let dir = temp_dir();
    let path = scene(dir.path(), View::Wall);
    let regs = regions(RES, RES);
    let r = format!("{RES}x{RES}");
    let seeded = Seeded::six(dir.path(), &r, "4", &regs, LIMIT);
    let reference = seeded.means(&path, &["--integrator", "path", "--spp", "32"]);
    // Lit at all: the back face's direct light alone gives ρ L A cos θe cos θr / (π d²) ≈ 0.23
    // at the view's centre (the wall point (0.6, 0.8, 0), d² = 1.8 from the quad's centre,
    // cosines 0.89 and 0.45); before, the wall was black in every integrator.
    let (whole, _) = mean_var(&reference[0]);
    assert!(whole > 0.1, "the wall is dark: {whole}");
    let others: [(&str, &[&str]); 4] = [
        ("bdpt", &["--integrator", "bdpt", "--spp", "16"]),
        ("vcm", &["--integrator", "vcm", "--spp", "16", "--vcm-radius", "0.02"]),
        ("photon", &["--integrator", "photon", "--spp", "16", "--photons", "100000", "--max-radius", "0.02"]),
        // A photon per pixel and iteration (the default) leaves SPPM's estimate of the wall,
        // lit by photons alone, 30-60 % noisy: 100000 photons an iteration bring its bound to 1-4 %.
        (
            "sppm",
            &["--integrator", "sppm", "--sppm-iterations", "16", "--sppm-radius", "0.02", "--sppm-photons", "100000"],
        ),
    ];
    let failed = seeded.disagreeing_others(&path, &reference, &others, sidak(regs.len() * others.len()));
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}
