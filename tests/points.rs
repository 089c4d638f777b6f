//! Point clouds (`CAUSTIC_points`): a sphere per point, in scenes whose answer is known
//! without rendering, in every integrator, and bad points refused by name.

mod common;

use common::agreement::{Seeded, regions, sidak};
use common::{GltfBuilder, look_rotation, mean_se, render_image, run, temp_dir};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);

/// A material without a specular layer of grey `grey` (Lambertian).
fn matte(g: &mut GltfBuilder, grey: f32) -> usize {
    g.use_ext("KHR_materials_specular");
    g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [grey, grey, grey, 1], "metallicFactor": 0.0},
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}}))
}

/// Smooth white solid glass of IOR 1.5.
fn glass(g: &mut GltfBuilder) -> usize {
    g.use_ext("KHR_materials_transmission");
    g.use_ext("KHR_materials_volume");
    g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0,
        "roughnessFactor": 0.0},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                       "KHR_materials_volume": {"thicknessFactor": 1.0}}}))
}

/// Grid period and sphere radius of the coverage scene.
const PERIOD: f32 = 0.25;
const RADIUS: f32 = 0.08;

/// Black spheres (no specular) on a grid of period P = 0.25 in the plane z = 0.5, against a
/// white world of radiance 1, seen straight down by an orthographic camera whose frame (x, y
/// in [-1, 1]) holds exactly 8 × 8 of them, on an opaque film.
fn coverage_scene(dir: &Path) -> PathBuf {
    let mut g = GltfBuilder::new();
    let black = matte(&mut g, 0.0);
    let (mut centres, mut radii) = (Vec::new(), Vec::new());
    for i in 0..8 {
        for j in 0..8 {
            centres.push([-1.0 + PERIOD * (i as f32 + 0.5), -1.0 + PERIOD * (j as f32 + 0.5), 0.5]);
            radii.push(RADIUS);
        }
    }
    g.points("grid", black, &centres, &radii);
    g.world(json!({"color": [1.0, 1.0, 1.0]}));
    g.settings(json!({"transparent": false}));
    g.orthographic([0.0, 0.0, 3.0], [0.0, 0.0, 0.0, 1.0], 1.0, 1.0);
    g.write(dir, "coverage.gltf")
}

/// A scene of points only: each pixel shows the world (1) or a black sphere (0), so the
/// image's mean is the uncovered fraction 1 − π r² / P², exactly, in every integrator (what
/// the camera sees directly is exact in each). Partly covered pixels are estimated from 64
/// stratified samples: the 64 circles' edges cross about 64 × 2π r / (2 / 64 px) ≈ 1030
/// pixels, each off by at most ~1/64 with independent signs, so the mean over 64² pixels is
/// off by about sqrt(1030) / 64 / 4096 = 1.2e-4; 2e-3 is over ten times that.
#[test]
fn points_cover_their_projected_area_in_every_integrator() {
    let dir = temp_dir();
    let d = dir.path();
    let scene = coverage_scene(d);
    let expected = 1.0 - std::f64::consts::PI * (RADIUS as f64 / PERIOD as f64).powi(2);
    let base = ["--resolution", "64x64", "--spp", "64", "--filter", "box", "--filter-width", "1", "--max-depth", "1"];
    for (integrator, extra) in [
        ("path", vec![]),
        ("bdpt", vec![]),
        ("vcm", vec!["--vcm-radius", "0.02"]),
        ("photon", vec!["--photons", "10000"]),
        ("sppm", vec!["--sppm-iterations", "64", "--sppm-radius", "0.02"]),
    ] {
        let mut args = base.to_vec();
        args.extend(["--integrator", integrator]);
        args.extend(extra);
        let px = render_image(&scene, &d.join(format!("{integrator}.exr")), &args, LIMIT);
        let mean = px.iter().map(|p| p[0] as f64).sum::<f64>() / px.len() as f64;
        eprintln!("{integrator}: uncovered fraction {mean:.5}, expected {expected:.5}");
        assert!((mean - expected).abs() < 2e-3, "{integrator}: uncovered fraction {mean}, expected {expected}");
        assert!(px.iter().all(|p| p[3] == 1.0));
    }
}

/// One sphere of radius 0.8 at the origin in a white world of radiance 1, seen straight down
/// by an orthographic camera over [-1, 1]², on an opaque film.
fn furnace_scene(dir: &Path, name: &str, material: impl Fn(&mut GltfBuilder) -> usize) -> PathBuf {
    let mut g = GltfBuilder::new();
    let m = material(&mut g);
    g.points("ball", m, &[[0.0, 0.0, 0.0]], &[0.8]);
    g.world(json!({"color": [1.0, 1.0, 1.0]}));
    g.settings(json!({"transparent": false}));
    g.orthographic([0.0, 0.0, 3.0], [0.0, 0.0, 0.0, 1.0], 1.0, 1.0);
    g.write(dir, name)
}

/// The pixels of a 64 × 64 render of [-1, 1]² whose whole footprint lies on the disc of
/// radius 0.8 (inside), and those wholly off it (outside).
fn disc_pixels() -> (Vec<usize>, Vec<usize>) {
    let (mut inside, mut outside) = (Vec::new(), Vec::new());
    let px = 2.0 / 64.0;
    for i in 0..64 * 64 {
        let (x, y) = (-1.0 + px * ((i % 64) as f64 + 0.5), 1.0 - px * ((i / 64) as f64 + 0.5));
        let r = (x * x + y * y).sqrt();
        if r < 0.8 - px {
            inside.push(i);
        } else if r > 0.8 + px {
            outside.push(i);
        }
    }
    (inside, outside)
}

/// White furnaces with one bounce (`--max-depth 1`): a sphere is convex, so a ray leaving it
/// never meets it again, and what it sends the camera after one bounce is all it sends.
/// * Smooth white glass shows exactly 1 everywhere: every path reflects or refracts once
///   (weight 1 either way: Cycles' refraction convention) and escapes; the refracted ray
///   crosses the sphere and leaves through its back unrefracted, as Cycles culls a point's
///   back face. A ray meeting the sphere it leaves (reflected or refracted) would need a
///   second bounce and read 0: the path tracer's pixels are 1 to rounding, each sample alike.
/// * A matte sphere of albedo 0.5 shows 0.5 (its light and its BSDF-sampled rays both
///   escape). K = 4 seeds per integrator; the bound is 6 standard errors of their means plus,
///   for SPPM, 2 % of the value (its density estimate's blur on the curved surface).
#[test]
fn white_furnace_spheres_show_their_albedo_in_every_integrator() {
    let dir = temp_dir();
    let d = dir.path();
    let glass_ball = furnace_scene(d, "glass.gltf", glass);
    let matte_ball = furnace_scene(d, "matte.gltf", |g| matte(g, 0.5));
    let (inside, outside) = disc_pixels();
    let base = ["--resolution", "64x64", "--filter", "box", "--filter-width", "1", "--max-depth", "1"];
    let px = render_image(&glass_ball, &d.join("glass_path.exr"), &[&base[..], &["--spp", "16"]].concat(), LIMIT);
    for &i in inside.iter().chain(&outside) {
        for c in 0..3 {
            assert!((px[i][c] - 1.0).abs() < 1e-4, "glass pixel {i}: {:?}", px[i]);
        }
    }
    for (scene, expected) in [(&glass_ball, 1.0), (&matte_ball, 0.5)] {
        for (integrator, extra, allowance) in [
            ("path", vec!["--spp", "64"], 0.0),
            ("bdpt", vec!["--spp", "32"], 0.0),
            ("sppm", vec!["--sppm-iterations", "32", "--sppm-radius", "0.02"], 0.02),
        ] {
            let means: Vec<f64> = (0..4)
                .map(|seed| {
                    let s = (seed * 7919 + 13).to_string();
                    let mut args = base.to_vec();
                    args.extend(["--integrator", integrator, "--seed", &s]);
                    args.extend(extra.iter().copied());
                    let px = render_image(scene, &d.join("f.exr"), &args, LIMIT);
                    let background = outside.iter().map(|&i| px[i][0] as f64).sum::<f64>() / outside.len() as f64;
                    assert!((background - 1.0).abs() < 1e-4, "{integrator}: the world reads {background}");
                    inside.iter().map(|&i| (px[i][0] + px[i][1] + px[i][2]) as f64 / 3.0).sum::<f64>()
                        / inside.len() as f64
                })
                .collect();
            let (mean, se) = mean_se(&means);
            eprintln!("{integrator} {}: {mean:.5} ± {se:.1e}, expected {expected}", scene.display());
            assert!(
                (mean - expected).abs() <= 6.0 * se + allowance * expected + 1e-4,
                "{integrator} {}: {mean} (se {se}), expected {expected}",
                scene.display()
            );
        }
    }
}

/// A cloud of coloured matte and glossy points of several sizes (and with `glass` four glass
/// points) over a floor, lit by an area light and a uniform sky and seen in perspective, four
/// bounces (the floor 4 units across).
fn cloud_scene(dir: &Path, glass_points: bool) -> PathBuf {
    let mut g = GltfBuilder::new();
    let floor = matte(&mut g, 0.6);
    g.mesh(&[[-2.0, 0.0, -2.0], [2.0, 0.0, -2.0], [2.0, 0.0, 2.0], [-2.0, 0.0, 2.0]], &[0, 2, 1, 0, 3, 2], floor);
    g.use_ext("KHR_materials_specular");
    let mut colours = Vec::new();
    for rgb in [[0.8, 0.3, 0.2], [0.2, 0.7, 0.3], [0.3, 0.4, 0.9]] {
        colours.push(g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [rgb[0], rgb[1], rgb[2], 1],
            "metallicFactor": 0.0, "roughnessFactor": 0.5}})));
    }
    let clear = glass(&mut g);
    let mut state = 17u64;
    let mut rnd = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 40) as f32 + 0.5) / (1u64 << 24) as f32
    };
    let kinds = if glass_points { 4 } else { 3 };
    for (k, &m) in colours.iter().chain([&clear]).take(kinds).enumerate() {
        let (mut centres, mut radii) = (Vec::new(), Vec::new());
        for _ in 0..if k == 3 { 4 } else { 20 } {
            let r = 0.04 + 0.16 * rnd();
            centres.push([rnd() * 2.4 - 1.2, r + rnd() * 1.0, rnd() * 2.4 - 1.2]);
            radii.push(r);
        }
        g.points(&format!("cloud {k}"), m, &centres, &radii);
    }
    // No delta light: the caustics the glass points throw on the floor are then within the
    // path tracer's reach (BSDF sampling finds the area light and the sky through the glass).
    g.world(json!({"color": [0.15, 0.17, 0.2]}));
    g.use_ext("CAUSTIC_lights_area");
    g.node(json!({"translation": [-0.8, 2.5, 0.8], "rotation": look_rotation([0.2, -1.0, 0.0001]),
        "extensions": {"CAUSTIC_lights_area": {"shape": "rectangle", "size": [1.0, 0.6], "power": 40.0, "color": [1, 0.95, 0.9]}}}));
    g.camera([0.0, 1.6, 4.2], look_rotation([0.0, -0.35, -1.0]), 0.75);
    g.settings(json!({"transparent": false}));
    g.write(dir, if glass_points { "glass_cloud.gltf" } else { "cloud.gltf" })
}

/// BDPT, VCM, Jensen's photon mapping and SPPM each agree with the path tracer region by
/// region on the cloud of matte and glossy points (`common::agreement`: K = 6 seeds per
/// estimate, Welch's test per region, Šidák's split over the four integrators' five regions).
/// The photon integrators are consistent, not unbiased: their kernel (radius 0.02 on a scene 4
/// units across) blurs the indirect light by a fraction of about r / size of a region's, a
/// tenth of its noise bound. Glass points are left out: light traced from the lights does not
/// retrace Cycles' refraction at a point's entry backwards (measured: VCM, Jensen and SPPM 2 %
/// darker than the path tracer in the quadrant of the glass points' caustics, BDPT, which
/// weighs such light against the camera side's, within noise), which
/// `glass_points_are_named_for_the_integrators_that_trace_light` checks is said.
#[test]
fn every_integrator_matches_the_path_tracer_on_a_point_cloud() {
    let dir = temp_dir();
    let scene = cloud_scene(dir.path(), false);
    let regs = regions(32, 32);
    let seeded = Seeded::six(dir.path(), "32x32", "4", &regs, LIMIT);
    let reference = seeded.means(&scene, &["--integrator", "path", "--spp", "256"]);
    let alpha = sidak(regs.len() * 4);
    let others: [(&str, &[&str]); 4] = [
        ("bdpt", &["--integrator", "bdpt", "--spp", "64"]),
        ("vcm", &["--integrator", "vcm", "--spp", "64", "--vcm-radius", "0.02"]),
        ("photon", &["--integrator", "photon", "--spp", "64", "--photons", "100000", "--max-radius", "0.02"]),
        ("sppm", &["--integrator", "sppm", "--sppm-iterations", "64", "--sppm-radius", "0.02"]),
    ];
    let failed = seeded.disagreeing_others(&scene, &reference, &others, alpha);
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}

/// The integrators that trace light from the lights name the glass points' material in a
/// warning; the path tracer, whose image is Cycles', does not.
#[test]
fn glass_points_are_named_for_the_integrators_that_trace_light() {
    let dir = temp_dir();
    let d = dir.path();
    let glass = cloud_scene(d, true);
    let matte = cloud_scene(d, false);
    for integrator in ["path", "bdpt", "vcm", "photon", "sppm"] {
        let flags = ["--integrator", integrator, "--sppm-iterations", "1", "--photons", "1000"];
        for (scene, glassy) in [(&glass, true), (&matte, false)] {
            let out = d.join(format!("{integrator}.exr"));
            let warnings = common::quick_render_warnings(scene, &out, &flags, LIMIT);
            let named = warnings.iter().any(|w| w.contains("point clouds of material(s) 'material 4' transmit"));
            assert_eq!(named, glassy && integrator != "path", "{integrator}, glass {glassy}: {warnings:?}");
        }
    }
}

/// Bad points are refused with exit 3 and a message naming the point cloud and the fault.
#[test]
fn bad_points_are_refused_by_name() {
    let dir = temp_dir();
    let d = dir.path();
    let scene = coverage_scene(d);
    let doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&scene).unwrap()).unwrap();
    let render = |doc: &serde_json::Value, name: &str| {
        let path = d.join(name);
        std::fs::write(&path, serde_json::to_vec(doc).unwrap()).unwrap();
        let out = d.join("bad.exr");
        run(
            &["render", path.to_str().unwrap(), "-o", out.to_str().unwrap(), "--spp", "1", "--resolution", "8x8"],
            LIMIT,
        )
    };
    let ok = render(&doc, "ok.gltf");
    assert_eq!(ok.code, Some(0), "{}", ok.stderr);
    let obj = &doc["extensions"]["CAUSTIC_points"]["objects"][0];
    let (positions, radii) = (obj["positions"].as_u64().unwrap(), obj["radii"].as_u64().unwrap());
    let accessor_view = |a: u64| doc["accessors"][a as usize]["bufferView"].as_u64().unwrap() as usize;
    // Bytes of the data-URI buffer, patched and written back.
    let patch = |view: usize, at: usize, bytes: [u8; 4], name: &str| {
        use base64::Engine;
        let mut doc = doc.clone();
        let uri = doc["buffers"][0]["uri"].as_str().unwrap().to_string();
        let (head, b64) = uri.split_once(',').unwrap();
        let mut buf = base64::engine::general_purpose::STANDARD.decode(b64).unwrap();
        let offset = doc["bufferViews"][view]["byteOffset"].as_u64().unwrap() as usize + at;
        buf[offset..offset + 4].copy_from_slice(&bytes);
        doc["buffers"][0]["uri"] = json!(format!("{head},{}", base64::engine::general_purpose::STANDARD.encode(&buf)));
        render(&doc, name)
    };
    let mut cases = vec![
        (patch(accessor_view(positions), 16, f32::NAN.to_le_bytes(), "nan.gltf"), "point 1's position is not finite"),
        (patch(accessor_view(radii), 8, (-0.1f32).to_le_bytes(), "negative.gltf"), "point 2 has radius -0.1"),
        (patch(accessor_view(radii), 12, 0f32.to_le_bytes(), "zero.gltf"), "point 3 has radius 0"),
        (patch(accessor_view(radii), 0, f32::NAN.to_le_bytes(), "nan_radius.gltf"), "point 0 has radius NaN"),
    ];
    let mut bad = doc.clone();
    bad["accessors"][radii as usize]["count"] = json!(63);
    cases.push((render(&bad, "count.gltf"), "63 radii for 64 positions"));
    let mut bad = doc.clone();
    bad["extensions"]["CAUSTIC_points"]["objects"][0]["material"] = json!(99);
    cases.push((render(&bad, "material.gltf"), "material 99 does not exist"));
    let mut bad = doc.clone();
    bad["extensions"]["CAUSTIC_points"]["objects"][0]["radii"] = json!(99);
    cases.push((render(&bad, "accessor.gltf"), "radii accessor 99 does not exist"));
    let mut bad = doc.clone();
    bad["extensions"]["CAUSTIC_points"]["objects"][0]["radii"] = json!(positions);
    cases.push((render(&bad, "type.gltf"), "radii accessor 0 is F32 Vec3; it must be F32 Scalar"));
    for (r, what) in cases {
        assert_eq!(r.code, Some(3), "{what}: {}", r.stderr);
        assert!(r.stderr.contains("point cloud 'grid'") && r.stderr.contains(what), "{what}: {}", r.stderr);
    }
    // A missing buffer file is named.
    let mut bad = doc.clone();
    bad["buffers"][0]["uri"] = json!("scene_points.bin");
    let r = render(&bad, "missing.gltf");
    assert_eq!(r.code, Some(3), "{}", r.stderr);
    assert!(r.stderr.contains("scene_points.bin"), "{}", r.stderr);
    // A malformed extension is named.
    let mut bad = doc.clone();
    bad["extensions"]["CAUSTIC_points"]["objects"][0]["size"] = json!(1);
    let r = render(&bad, "unknown.gltf");
    assert_eq!(r.code, Some(3), "{}", r.stderr);
    assert!(r.stderr.contains("CAUSTIC_points is malformed"), "{}", r.stderr);
}
