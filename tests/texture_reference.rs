//! Caustic's procedural textures against the values Blender computed for the same inputs.
//!
//! `tests/data/texture_reference.json` holds, for 256 points and every texture in several
//! settings, the outputs Blender 5.0's geometry nodes gave (same node algorithms as Cycles,
//! on the CPU; `tests/data/make_texture_reference.py` regenerates it with real bpy). Each test
//! maps the case's Blender settings onto our parameters as the node evaluator does, evaluates
//! every point and compares every output component. Run with `--nocapture` to see the largest
//! difference per texture.

use std::collections::BTreeMap;

use base64::Engine;
use caustic::shader::texture::*;
use glam::Vec3;
use serde_json::Value;

/// One texture node in one setting and what Blender computed with it.
struct Case {
    texture: String,
    /// Rendered by Cycles (`cycles_cases`) rather than evaluated by geometry nodes.
    cycles: bool,
    properties: serde_json::Map<String, Value>,
    inputs: serde_json::Map<String, Value>,
    outputs: BTreeMap<String, Vec<f32>>,
}

/// The reference file: sample points and cases.
struct Reference {
    position: Vec<Vec3>,
    w: Vec<f32>,
    cases: Vec<Case>,
}

fn floats(v: &Value) -> Vec<f32> {
    let bytes =
        base64::engine::general_purpose::STANDARD.decode(v.as_str().expect("base64 string")).expect("valid base64");
    bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect()
}

fn load() -> Reference {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/texture_reference.json");
    let doc: Value =
        serde_json::from_str(&std::fs::read_to_string(path).expect("reference file")).expect("reference JSON");
    let position: Vec<Vec3> = floats(&doc["position"]).chunks_exact(3).map(Vec3::from_slice).collect();
    let w = floats(&doc["w"]);
    assert_eq!(position.len(), w.len());
    let geometry_nodes = doc["cases"].as_array().expect("cases").iter().map(|c| (c, false));
    let cycles = doc["cycles_cases"].as_array().expect("cycles cases").iter().map(|c| (c, true));
    let cases = geometry_nodes
        .chain(cycles)
        .map(|(c, cycles)| Case {
            texture: c["texture"].as_str().expect("texture").to_owned(),
            cycles,
            properties: c["properties"].as_object().expect("properties").clone(),
            inputs: c["inputs"].as_object().expect("inputs").clone(),
            outputs: c["outputs"].as_object().expect("outputs").iter().map(|(k, v)| (k.clone(), floats(v))).collect(),
        })
        .collect();
    Reference { position, w, cases }
}

impl Case {
    fn prop(&self, key: &str) -> &Value {
        self.properties.get(key).unwrap_or_else(|| panic!("{} case without property {key}", self.texture))
    }
    fn prop_str(&self, key: &str) -> &str {
        self.prop(key).as_str().expect("string property")
    }
    fn prop_bool(&self, key: &str) -> bool {
        self.prop(key).as_bool().expect("boolean property")
    }
    fn prop_f32(&self, key: &str) -> f32 {
        self.prop(key).as_f64().expect("number property") as f32
    }
    fn prop_i32(&self, key: &str) -> i32 {
        self.prop(key).as_i64().expect("integer property") as i32
    }
    /// A socket's value; `default` is Blender's default for a socket the case leaves alone.
    fn input(&self, key: &str, default: f32) -> f32 {
        self.inputs.get(key).map_or(default, |v| v.as_f64().expect("number input") as f32)
    }
    fn color(&self, key: &str) -> Vec3 {
        let c = self.inputs[key].as_array().expect("colour input");
        Vec3::new(c[0].as_f64().unwrap() as f32, c[1].as_f64().unwrap() as f32, c[2].as_f64().unwrap() as f32)
    }
    fn dims(&self, key: &str) -> u8 {
        match self.prop_str(key) {
            "1D" => 1,
            "2D" => 2,
            "3D" => 3,
            "4D" => 4,
            other => panic!("unknown dimensions {other}"),
        }
    }
    fn describe(&self) -> String {
        format!(
            "{}{} {:?} {:?}",
            self.texture,
            if self.cycles { " (Cycles render)" } else { "" },
            Value::Object(self.properties.clone()),
            Value::Object(self.inputs.clone())
        )
    }
}

/// What one texture output at one point is compared with.
enum Out {
    Scalar(f32),
    Color(Vec3),
}

/// The largest differences seen for one texture, and the comparisons made.
#[derive(Default)]
struct Tally {
    compared: usize,
    excluded: usize,
    max_abs: f32,
    worst: String,
}

/// Compares every output of every case of `texture`. `eval` returns, per output name, our
/// value at point `i`; `tolerance(case, name, p, w, blender)` the allowed absolute difference;
/// `excluded(case, i)` says (by a rule, documented where it is defined) that a point lies
/// within rounding of a discontinuity of that case, where either side is right.
fn compare(
    reference: &Reference,
    texture: &str,
    mut eval: impl FnMut(&Case, Vec3, f32) -> Vec<(&'static str, Out)>,
    tolerance: impl Fn(&Case, &str, Vec3, f32, f32) -> f32,
    excluded: impl Fn(&Case, Vec3, f32) -> bool,
) -> Tally {
    let mut tally = Tally::default();
    let mut failures = Vec::new();
    let cases: Vec<&Case> = reference.cases.iter().filter(|c| c.texture == texture).collect();
    assert!(!cases.is_empty(), "no reference cases for {texture}");
    // TEXTURE_REFERENCE_VERBOSE=1 prints the largest difference of every case.
    let verbose = std::env::var_os("TEXTURE_REFERENCE_VERBOSE").is_some();
    for case in cases {
        let mut case_max = (0.0f32, String::new());
        for (i, (&p, &w)) in reference.position.iter().zip(&reference.w).enumerate() {
            if excluded(case, p, w) {
                tally.excluded += 1;
                continue;
            }
            for (name, ours) in eval(case, p, w) {
                let theirs =
                    case.outputs.get(name).unwrap_or_else(|| panic!("{} has no output {name}", case.describe()));
                let pairs: Vec<(f32, f32)> = match ours {
                    Out::Scalar(v) => vec![(v, theirs[i])],
                    Out::Color(c) => (0..3).map(|k| (c[k], theirs[3 * i + k])).collect(),
                };
                for (a, b) in pairs {
                    tally.compared += 1;
                    let err = (a - b).abs();
                    let ok = err <= tolerance(case, name, p, w, b) || (a.is_nan() && b.is_nan());
                    if err.is_nan() || err > case_max.0 {
                        case_max = (err, format!("{name} point {i}: ours {a}, Blender {b}"));
                    }
                    if err.is_finite() && err > tally.max_abs {
                        tally.max_abs = err;
                        tally.worst = format!("{name} at point {i} {p} w={w}: ours {a}, Blender {b}");
                    }
                    if !ok {
                        failures.push(format!(
                            "{}: {name} at point {i} ({p}, w={w}): ours {a}, Blender {b}",
                            case.describe()
                        ));
                    }
                }
            }
        }
        if verbose {
            println!("  {:e} {} ({})", case_max.0, case.describe(), case_max.1);
        }
    }
    println!(
        "{texture}: {} values compared, {} points excluded, max |difference| {:e} ({})",
        tally.compared, tally.excluded, tally.max_abs, tally.worst
    );
    assert!(
        failures.is_empty(),
        "{} of {} {texture} values differ from Blender, first ones:\n{}",
        failures.len(),
        tally.compared,
        failures[..failures.len().min(12)].join("\n")
    );
    tally
}

/// White noise is a hash of the input bits: it must agree exactly.
#[test]
fn white_noise_matches_blender() {
    let reference = load();
    compare(
        &reference,
        "white_noise",
        |case, p, w| {
            let (value, color) = white_noise_texture(case.dims("noise_dimensions"), p, w);
            vec![("Value", Out::Scalar(value)), ("Color", Out::Color(color))]
        },
        |_, _, _, _, _| 0.0,
        |_, _, _| false,
    );
}

fn noise_params(case: &Case) -> NoiseParams {
    NoiseParams {
        dims: case.dims("noise_dimensions"),
        kind: match case.prop_str("noise_type") {
            "MULTIFRACTAL" => NoiseKind::Multifractal,
            "RIDGED_MULTIFRACTAL" => NoiseKind::RidgedMultifractal,
            "HYBRID_MULTIFRACTAL" => NoiseKind::HybridMultifractal,
            "FBM" => NoiseKind::Fbm,
            "HETERO_TERRAIN" => NoiseKind::HeteroTerrain,
            other => panic!("unknown noise type {other}"),
        },
        normalize: case.prop_bool("normalize"),
        scale: case.input("Scale", 5.0),
        detail: case.input("Detail", 2.0),
        roughness: case.input("Roughness", 0.5),
        lacunarity: case.input("Lacunarity", 2.0),
        offset: case.input("Offset", 0.0),
        gain: case.input("Gain", 1.0),
        distortion: case.input("Distortion", 0.0),
    }
}

#[test]
fn noise_matches_blender() {
    let reference = load();
    compare(
        &reference,
        "noise",
        |case, p, w| {
            let (fac, color) = noise_texture(p, w, &noise_params(case));
            vec![("Fac", Out::Scalar(fac)), ("Color", Out::Color(color))]
        },
        |case, name, p, w, blender| {
            let prm = noise_params(case);
            // Blender's BLI_noise interpolates as `(1 - t) a + t b` where Cycles writes
            // `a + t (b - a)`: a few ulps per lattice mix and octave. 1e-5 relative (~80 ulps)
            // covers the ~10 roundings per octave of a 6-octave sum.
            let arithmetic = 1e-5 * blender.abs().max(1.0);
            if prm.distortion == 0.0 {
                return arithmetic;
            }
            // With distortion the fractal's coordinate is itself a noise result, so the two
            // implementations may round it to neighbouring floats: an uncertainty of one ulp of
            // its magnitude (the point, the distortion, and for the colour the seeded offsets of
            // up to 200). Octave i sees that uncertainty multiplied by lacunarity^i and weighs
            // it by roughness^i; |grad snoise| <= SNOISE_LIPSCHITZ turns it into a value.
            let magnitude = p.abs().max_element().max(w.abs()) * prm.scale
                + prm.distortion
                + if name == "Color" { 200.0 } else { 0.0 };
            let delta = f32::EPSILON * magnitude;
            let octaves = prm.detail.clamp(0.0, 15.0).ceil() as i32;
            let gain: f32 = (0..=octaves).map(|i| (prm.roughness * prm.lacunarity).powi(i)).sum();
            arithmetic + SNOISE_LIPSCHITZ * delta * gain * blender.abs().max(1.0)
        },
        |_, _, _| false,
    );
}

/// An upper bound of the sum over axes of |d snoise / dx_k| in every dimension (so that a
/// rounding of at most delta in each coordinate moves snoise by at most this times delta),
/// checked by `snoise_lipschitz_bound`.
const SNOISE_LIPSCHITZ: f32 = 12.0;

/// Checks SNOISE_LIPSCHITZ on a dense sample: slopes of snoise over steps of 1e-3 along each
/// axis (the fade polynomial and gradients make the noise C2, so finite slopes over such steps
/// approach the gradient to within 1e-3 relative).
#[test]
fn snoise_lipschitz_bound() {
    use caustic::shader::texture::perlin::NoiseCoord;
    use glam::{Vec2, Vec4};
    let h = 1e-3f32;
    let mut max_slope = 0.0f32;
    for i in 0..20000 {
        // A low-discrepancy walk through a few cells.
        let t = i as f32;
        let p = Vec4::new(
            (t * 0.618034).fract() * 4.0 - 2.0,
            (t * 0.754878).fract() * 4.0 - 2.0,
            (t * 0.569840).fract() * 4.0 - 2.0,
            (t * 0.873580).fract() * 4.0 - 2.0,
        );
        let slope = |a: f32, b: f32| (a - b).abs() / h;
        max_slope = max_slope.max(slope((p.x + h).snoise(), p.x.snoise()));
        let p2 = Vec2::new(p.x, p.y);
        for e in [Vec2::X, Vec2::Y] {
            max_slope = max_slope.max(slope((p2 + e * h).snoise(), p2.snoise()));
        }
        let p3 = p.truncate();
        for e in [Vec3::X, Vec3::Y, Vec3::Z] {
            max_slope = max_slope.max(slope((p3 + e * h).snoise(), p3.snoise()));
        }
        for e in [Vec4::X, Vec4::Y, Vec4::Z, Vec4::W] {
            max_slope = max_slope.max(slope((p + e * h).snoise(), p.snoise()));
        }
    }
    println!("largest snoise slope {max_slope}");
    // The sum over at most 4 axes of the largest slope, with 10% for steps that missed a peak.
    assert!(4.0 * 1.1 * max_slope < SNOISE_LIPSCHITZ, "{max_slope}");
}

fn voronoi_params(case: &Case) -> VoronoiParams {
    VoronoiParams {
        dims: case.dims("voronoi_dimensions"),
        feature: match case.prop_str("feature") {
            "F1" => VoronoiFeature::F1,
            "F2" => VoronoiFeature::F2,
            "SMOOTH_F1" => VoronoiFeature::SmoothF1,
            "DISTANCE_TO_EDGE" => VoronoiFeature::DistanceToEdge,
            "N_SPHERE_RADIUS" => VoronoiFeature::NSphereRadius,
            other => panic!("unknown voronoi feature {other}"),
        },
        metric: match case.prop_str("distance") {
            "EUCLIDEAN" => VoronoiMetric::Euclidean,
            "MANHATTAN" => VoronoiMetric::Manhattan,
            "CHEBYCHEV" => VoronoiMetric::Chebychev,
            "MINKOWSKI" => VoronoiMetric::Minkowski,
            other => panic!("unknown voronoi metric {other}"),
        },
        normalize: case.prop_bool("normalize"),
        scale: case.input("Scale", 5.0),
        detail: case.input("Detail", 0.0),
        roughness: case.input("Roughness", 0.5),
        lacunarity: case.input("Lacunarity", 2.0),
        smoothness: case.input("Smoothness", 1.0),
        exponent: case.input("Exponent", 0.5),
        randomness: case.input("Randomness", 1.0),
    }
}

#[test]
fn voronoi_matches_blender() {
    let reference = load();
    compare(
        &reference,
        "voronoi",
        |case, p, w| {
            let out = voronoi_texture(p, w, &voronoi_params(case));
            vec![
                ("Distance", Out::Scalar(out.distance)),
                ("Color", Out::Color(out.color)),
                ("Position", Out::Color(out.position)),
                ("W", Out::Scalar(out.w)),
                ("Radius", Out::Scalar(out.radius)),
            ]
            .into_iter()
            .filter(|(name, _)| case.outputs.contains_key(*name))
            .collect()
        },
        |_, _, _, _, blender| 1e-5 * blender.abs().max(1.0),
        |_, _, _| false,
    );
}

/// Relative-or-absolute closeness for outputs of order 1: 1e-5 (~80 ulps at 1) covers a
/// different operation order in a few dozen f32 operations.
fn order_one(blender: f32) -> f32 {
    1e-5 * blender.abs().max(1.0)
}

#[test]
fn checker_matches_blender() {
    let reference = load();
    compare(
        &reference,
        "checker",
        |case, p, _| {
            let (color, fac) = checker_texture(p, case.color("Color1"), case.color("Color2"), case.input("Scale", 5.0));
            vec![("Color", Out::Color(color)), ("Fac", Out::Scalar(fac))]
        },
        |_, _, _, _, _| 0.0,
        |_, _, _| false,
    );
}

#[test]
fn gradient_matches_blender() {
    let reference = load();
    compare(
        &reference,
        "gradient",
        |case, p, _| {
            let kind = match case.prop_str("gradient_type") {
                "LINEAR" => GradientKind::Linear,
                "QUADRATIC" => GradientKind::Quadratic,
                "EASING" => GradientKind::Easing,
                "DIAGONAL" => GradientKind::Diagonal,
                "RADIAL" => GradientKind::Radial,
                "QUADRATIC_SPHERE" => GradientKind::QuadraticSphere,
                "SPHERICAL" => GradientKind::Spherical,
                other => panic!("unknown gradient type {other}"),
            };
            vec![("Fac", Out::Scalar(gradient_texture(p, kind)))]
        },
        |_, _, _, _, blender| order_one(blender),
        |_, _, _| false,
    );
}

/// Geometry nodes' Magic texture is not Cycles': it omits the `fmod(p, 2 pi)` that Cycles
/// applies to the unscaled vector and scales before summing (node_shader_tex_magic.cc against
/// svm/magic.h), so its reference is a Cycles render of the same points (`cycles_cases`).
#[test]
fn magic_matches_blender() {
    let reference = load();
    compare(
        &reference,
        "magic",
        |case, p, _| {
            let (color, fac) = magic_texture(
                p,
                case.prop_i32("turbulence_depth"),
                case.input("Scale", 5.0),
                case.input("Distortion", 1.0),
            );
            vec![("Color", Out::Color(color)), ("Fac", Out::Scalar(fac))]
        },
        |_, _, _, _, blender| order_one(blender),
        |_, _, _| false,
    );
}

fn wave_params(case: &Case) -> WaveParams {
    let kind = match case.prop_str("wave_type") {
        "BANDS" => WaveKind::Bands,
        "RINGS" => WaveKind::Rings,
        other => panic!("unknown wave type {other}"),
    };
    let direction_key = match kind {
        WaveKind::Bands => "bands_direction",
        WaveKind::Rings => "rings_direction",
    };
    WaveParams {
        kind,
        direction: match case.prop_str(direction_key) {
            "X" => WaveDirection::X,
            "Y" => WaveDirection::Y,
            "Z" => WaveDirection::Z,
            "DIAGONAL" => WaveDirection::Diagonal,
            "SPHERICAL" => WaveDirection::Spherical,
            other => panic!("unknown wave direction {other}"),
        },
        profile: match case.prop_str("wave_profile") {
            "SIN" => WaveProfile::Sine,
            "SAW" => WaveProfile::Saw,
            "TRI" => WaveProfile::Tri,
            other => panic!("unknown wave profile {other}"),
        },
        scale: case.input("Scale", 5.0),
        distortion: case.input("Distortion", 0.0),
        detail: case.input("Detail", 2.0),
        detail_scale: case.input("Detail Scale", 1.0),
        detail_roughness: case.input("Detail Roughness", 0.5),
        phase_offset: case.input("Phase Offset", 0.0),
    }
}

#[test]
fn wave_matches_blender() {
    let reference = load();
    compare(
        &reference,
        "wave",
        |case, p, _| {
            let (fac, _) = wave_texture(p, &wave_params(case));
            vec![("Fac", Out::Scalar(fac))]
        },
        |case, _, p, _, blender| {
            let prm = wave_params(case);
            order_one(blender) + profile_slope(prm.profile) * wave_phase_uncertainty(&prm, p)
        },
        // The saw profile jumps from 1 to 0 where the phase crosses a multiple of 2 pi; within
        // the phase's rounding of that jump either side is right.
        |case, p, _| {
            let prm = wave_params(case);
            let (fac, _) = wave_texture(p, &prm);
            let margin = profile_slope(prm.profile) * wave_phase_uncertainty(&prm, p) + 1e-5;
            prm.profile == WaveProfile::Saw && (fac < margin || fac > 1.0 - margin)
        },
    );
}

/// |d Fac / d phase| of a wave profile: sine 0.5, saw 1 / 2 pi, triangle 2 / 2 pi.
fn profile_slope(profile: WaveProfile) -> f32 {
    match profile {
        WaveProfile::Sine => 0.5,
        WaveProfile::Saw => 1.0 / core::f32::consts::TAU,
        WaveProfile::Tri => 2.0 / core::f32::consts::TAU,
    }
}

/// How far the wave's phase may differ between two f32 evaluations in different operation
/// orders. The phase is ~20 |p| scale (bands along an axis; up to 20 sqrt(3) |p| scale for the
/// diagonal and rings) plus the phase offset, made by about ten roundings (scale, the nudge,
/// the direction sum or length, the factor, the offset), each at most one ulp of the phase.
/// With distortion, it adds distortion (2 fBM - 1): fBM's coordinate p scale dscale may round
/// to a neighbouring float in each octave i (lacunarity 2), which moves the normalised sum by
/// at most 0.5 SNOISE_LIPSCHITZ eps |q| sum(r^i 2^i) / sum(r^i); its own arithmetic adds ~1e-5.
fn wave_phase_uncertainty(prm: &WaveParams, p: Vec3) -> f32 {
    let extent = p.abs().max_element() * prm.scale.abs() + 1.0;
    let phase = 20.0 * 3f32.sqrt() * extent + prm.phase_offset.abs() + prm.distortion.abs();
    let mut delta = 10.0 * f32::EPSILON * phase;
    if prm.distortion != 0.0 {
        let q = extent * prm.detail_scale.abs();
        let octaves = prm.detail.clamp(0.0, 15.0).ceil() as i32;
        let r = prm.detail_roughness;
        let weighted: f32 = (0..=octaves).map(|i| (2.0 * r).powi(i)).sum();
        let total: f32 = (0..=octaves).map(|i| r.powi(i)).sum();
        let fbm = 0.5 * SNOISE_LIPSCHITZ * f32::EPSILON * q * weighted / total + 1e-5;
        delta += 2.0 * prm.distortion.abs() * fbm;
    }
    delta
}

fn brick_params(case: &Case) -> BrickParams {
    BrickParams {
        offset: case.prop_f32("offset"),
        offset_frequency: case.prop_i32("offset_frequency"),
        squash: case.prop_f32("squash"),
        squash_frequency: case.prop_i32("squash_frequency"),
        color1: case.color("Color1"),
        color2: case.color("Color2"),
        mortar: case.color("Mortar"),
        scale: case.input("Scale", 5.0),
        mortar_size: case.input("Mortar Size", 0.02),
        mortar_smooth: case.input("Mortar Smooth", 0.1),
        bias: case.input("Bias", 0.0),
        brick_width: case.input("Brick Width", 0.5),
        row_height: case.input("Row Height", 0.25),
    }
}

#[test]
fn brick_matches_blender() {
    let reference = load();
    compare(
        &reference,
        "brick",
        |case, p, _| {
            let (color, fac) = brick_texture(p, &brick_params(case));
            vec![("Color", Out::Color(color)), ("Fac", Out::Scalar(fac))]
        },
        |_, _, _, _, blender| order_one(blender),
        |_, _, _| false,
    );
}

fn gabor_params(case: &Case) -> GaborParams {
    let orientation = case
        .inputs
        .get("Orientation 3D")
        .and_then(Value::as_array)
        .map_or(Vec3::new(std::f32::consts::SQRT_2, std::f32::consts::SQRT_2, 0.0), |c| {
            Vec3::new(c[0].as_f64().unwrap() as f32, c[1].as_f64().unwrap() as f32, c[2].as_f64().unwrap() as f32)
        });
    GaborParams {
        kind: match case.prop_str("gabor_type") {
            "2D" => GaborKind::TwoD,
            "3D" => GaborKind::ThreeD,
            other => panic!("unknown Gabor type {other}"),
        },
        scale: case.input("Scale", 5.0),
        frequency: case.input("Frequency", 2.0),
        anisotropy: case.input("Anisotropy", 1.0),
        orientation_2d: case.input("Orientation 2D", std::f32::consts::FRAC_PI_4),
        orientation_3d: orientation,
    }
}

/// The largest difference rounding can make in the Gabor phasor's components: each of the
/// cells' 8 impulses within reach (9 cells in 2D, 27 in 3D) adds a kernel of magnitude ≤ 1
/// whose wave angle 2π f (d · o), |d| < 1, |o| = 1, may round differently by a few ulps of
/// 2π f, and whose envelope (exp, cos of π |d|² ≤ π) by a few ulps of 1; 8 ulps each.
fn gabor_phasor_rounding(prm: &GaborParams) -> f32 {
    let kernels = 8.0 * if prm.kind == GaborKind::TwoD { 9.0 } else { 27.0 };
    let angle = 2.0 * std::f32::consts::PI * prm.frequency.max(0.001);
    kernels * 8.0 * f32::EPSILON * (angle + 1.0)
}

/// Gabor (Blender 5.0's sparse convolution noise): Value and Intensity within the phasor's
/// rounding bound over the node's normalisation (6 σ, as `gabor_texture`); Phase within the
/// same error turned into an angle by the phasor's length, and either side of the ±π cut.
#[test]
fn gabor_matches_blender() {
    let reference = load();
    compare(
        &reference,
        "gabor",
        |case, p, _| {
            let (value, phase, intensity) = gabor_texture(p, &gabor_params(case));
            [("Value", value), ("Phase", phase), ("Intensity", intensity)]
                .into_iter()
                .filter(|(name, _)| case.outputs.contains_key(*name))
                .map(|(name, v)| (name, Out::Scalar(v)))
                .collect()
        },
        |case, name, p, _, blender| {
            let prm = gabor_params(case);
            let deviation = match prm.kind {
                GaborKind::TwoD => (8.0f32 * 0.5 * 0.25).sqrt(),
                GaborKind::ThreeD => (8.0f32 * 0.5 / (4.0 * std::f32::consts::SQRT_2)).sqrt(),
            };
            let norm = 6.0 * deviation;
            let rounding = gabor_phasor_rounding(&prm);
            match name {
                // Value = ½ + y / (2 norm): half the component's error over the norm.
                "Value" => 0.5 * rounding / norm + 4.0 * f32::EPSILON,
                "Intensity" => rounding / norm + 4.0 * f32::EPSILON * blender.max(1.0),
                _ => {
                    let length = gabor_texture(p, &prm).2 * norm;
                    let turn = (rounding / length.max(1e-30)) / (2.0 * std::f32::consts::PI) + 4.0 * f32::EPSILON;
                    if blender < turn || blender > 1.0 - turn { 1.0 } else { turn }
                }
            }
        },
        |_, _, _| false,
    );
}

/// Every output of the Radial Tiling node at `p` (x and y read) in `case`'s settings.
fn radial_tiling_at(case: &Case, p: Vec3) -> RadialTiling {
    let used = RadialTilingUse { segment: true, segment_id: true };
    radial_tiling(
        glam::Vec2::new(p.x, p.y),
        case.input("Sides", 5.0),
        case.input("Roundness", 0.0),
        case.prop_bool("normalize"),
        used,
    )
}

/// The rounding of the point's angle from its segment's divider in either implementation:
/// `atan2` (an ulp or two of its value, at most π: one ulp of 2π), the full turn added below
/// the axis (half an ulp of 2π), whole segments taken off (the product and the difference,
/// half an ulp of 2π each), and geometry nodes' π / sides in double where Cycles' is in
/// float (the segment angle's half ulp times the segment count, at most an ulp of 2π):
/// about 4 ulps of 2π.
const RADIAL_ANGLE_ROUNDING: f32 = 4.0 * std::f32::consts::TAU * f32::EPSILON;

/// Whether `p` lies within the angle's rounding of a segment divider (the angles k 2π / sides
/// and the x axis), where Segment ID, Rotation and Coordinates jump and either side is right.
fn near_radial_divider(case: &Case, p: Vec3) -> bool {
    let sides = case.input("Sides", 5.0).max(2.0);
    let angle = p.y.atan2(p.x).rem_euclid(std::f32::consts::TAU);
    let segment = std::f32::consts::TAU / sides;
    let from_divider = angle - (angle / segment).round() * segment;
    let to_turn = std::f32::consts::TAU - angle;
    // Dividers are multiples of the segment angle whose count is near a whole number.
    from_divider.abs() <= 4.0 * RADIAL_ANGLE_ROUNDING
        || angle <= 4.0 * RADIAL_ANGLE_ROUNDING
        || to_turn <= 4.0 * RADIAL_ANGLE_ROUNDING
}

/// Radial Tiling (Blender 5.0): every output of every case within a bound derived from the
/// angle's rounding: how far our own output moves when the point turns by
/// `RADIAL_ANGLE_ROUNDING` either way (steep near the corners, where tangents grow, and far
/// out, where the coordinates are ~1000), plus 32 ulps of the value for the two dozen
/// operations after the angle (tangents, square roots, the normalisers; half an ulp each,
/// libm's within an ulp). Points within four times the angle's rounding of a divider (a
/// jump of Segment ID, Rotation and Coordinates) are excluded. Sides 2 with a roundness
/// between 0 and 1 is NaN in Blender too (cos π/2 in a denominator), and agrees as NaN.
#[test]
fn radial_tiling_matches_blender() {
    let reference = load();
    let outputs = |o: &RadialTiling| {
        [
            ("Segment Coordinates", Out::Color(o.coordinates)),
            ("Segment ID", Out::Scalar(o.segment_id)),
            ("Segment Width", Out::Scalar(o.width)),
            ("Segment Rotation", Out::Scalar(o.rotation)),
        ]
    };
    compare(
        &reference,
        "radial_tiling",
        |case, p, _| {
            outputs(&radial_tiling_at(case, p))
                .into_iter()
                .filter(|(name, _)| case.outputs.contains_key(*name))
                .collect()
        },
        |case, name, p, _, blender| {
            let here = radial_tiling_at(case, p);
            let mut moved = 0.0f32;
            for turn in [-RADIAL_ANGLE_ROUNDING, RADIAL_ANGLE_ROUNDING] {
                let (s, c) = turn.sin_cos();
                let q = Vec3::new(p.x * c - p.y * s, p.x * s + p.y * c, p.z);
                let there = radial_tiling_at(case, q);
                let (a, b) = (outputs(&here), outputs(&there));
                for ((n, x), (_, y)) in a.iter().zip(&b) {
                    if *n != name {
                        continue;
                    }
                    let d = match (x, y) {
                        (Out::Scalar(x), Out::Scalar(y)) => (x - y).abs(),
                        (Out::Color(x), Out::Color(y)) => (*x - *y).abs().max_element(),
                        _ => unreachable!(),
                    };
                    moved = moved.max(d);
                }
            }
            moved + 32.0 * f32::EPSILON * blender.abs().max(1.0)
        },
        |case, p, _| near_radial_divider(case, p),
    );
}
