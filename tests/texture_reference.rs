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
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(v.as_str().expect("base64 string"))
        .expect("valid base64");
    bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect()
}

fn load() -> Reference {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/texture_reference.json");
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(path).expect("reference file"))
        .expect("reference JSON");
    let position: Vec<Vec3> = floats(&doc["position"])
        .chunks_exact(3)
        .map(Vec3::from_slice)
        .collect();
    let w = floats(&doc["w"]);
    assert_eq!(position.len(), w.len());
    let cases = doc["cases"]
        .as_array()
        .expect("cases")
        .iter()
        .map(|c| Case {
            texture: c["texture"].as_str().expect("texture").to_owned(),
            properties: c["properties"].as_object().expect("properties").clone(),
            inputs: c["inputs"].as_object().expect("inputs").clone(),
            outputs: c["outputs"]
                .as_object()
                .expect("outputs")
                .iter()
                .map(|(k, v)| (k.clone(), floats(v)))
                .collect(),
        })
        .collect();
    Reference { position, w, cases }
}

impl Case {
    fn prop(&self, key: &str) -> &Value {
        self.properties
            .get(key)
            .unwrap_or_else(|| panic!("{} case without property {key}", self.texture))
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
        self.inputs
            .get(key)
            .map_or(default, |v| v.as_f64().expect("number input") as f32)
    }
    fn color(&self, key: &str) -> Vec3 {
        let c = self.inputs[key].as_array().expect("colour input");
        Vec3::new(
            c[0].as_f64().unwrap() as f32,
            c[1].as_f64().unwrap() as f32,
            c[2].as_f64().unwrap() as f32,
        )
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
            "{} {:?} {:?}",
            self.texture,
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
/// value at point `i`; `tolerance(name, blender)` the allowed absolute difference;
/// `excluded(case, i)` says (by a rule, documented where it is defined) that a point lies
/// within rounding of a discontinuity of that case, where either side is right.
fn compare(
    reference: &Reference,
    texture: &str,
    mut eval: impl FnMut(&Case, Vec3, f32) -> Vec<(&'static str, Out)>,
    tolerance: impl Fn(&Case, &str, f32) -> f32,
    excluded: impl Fn(&Case, Vec3, f32) -> bool,
) -> Tally {
    let mut tally = Tally::default();
    let mut failures = Vec::new();
    let cases: Vec<&Case> = reference
        .cases
        .iter()
        .filter(|c| c.texture == texture)
        .collect();
    assert!(!cases.is_empty(), "no reference cases for {texture}");
    for case in cases {
        for (i, (&p, &w)) in reference.position.iter().zip(&reference.w).enumerate() {
            if excluded(case, p, w) {
                tally.excluded += 1;
                continue;
            }
            for (name, ours) in eval(case, p, w) {
                let theirs = case
                    .outputs
                    .get(name)
                    .unwrap_or_else(|| panic!("{} has no output {name}", case.describe()));
                let pairs: Vec<(f32, f32)> = match ours {
                    Out::Scalar(v) => vec![(v, theirs[i])],
                    Out::Color(c) => (0..3).map(|k| (c[k], theirs[3 * i + k])).collect(),
                };
                for (a, b) in pairs {
                    tally.compared += 1;
                    let err = (a - b).abs();
                    let ok = err <= tolerance(case, name, b) || (a.is_nan() && b.is_nan());
                    if !(err <= tally.max_abs) && err.is_finite() {
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
        |_, _, _| 0.0,
        |_, _, _| false,
    );
}
