//! Lights of negative power (Blender lets a light's Power or Strength be negative; Cycles
//! subtracts its light and its light tree picks it by |energy|) in every integrator: the
//! emission carries the sign, light selection takes its size (`light::selection_weight`, the
//! machinery negative emitting meshes use: `tests/negative_emission.rs`).
//!
//! * A light alone renders exactly the negated image of the same light with positive power,
//!   seed for seed, in every integrator and for every kind of light (point, spot, sphere, sun,
//!   area): every sampling decision depends on |power| only, so each sample is the positive
//!   one's with its sign flipped (IEEE negation is exact).
//! * A grey floor and back wall (max depth 4) under a positive area light "Key" and four
//!   negative lights that darken parts of it (a point "Hole", a point with a radius "Orb", a
//!   small area light "Shade" and a weak sun "Dusk"): BDPT, VCM, Jensen and SPPM converge to
//!   the path tracer's image region by region, and the path tracer's image with the negative
//!   lights at 0 disagrees with it (so an integrator dropping them would fail).
//!
//! Bounds (`common::agreement`): K seeds per estimate, Welch's test per region, Šidák's split
//! over every comparison of the test (four integrators and the rule check, five regions
//! each). The photon integrators are consistent, not unbiased: their gather radius 0.02 on a
//! scene 4 units across blurs the indirect light at the edges by about r / side of a region's,
//! a tenth of the regions' noise bound (as `tests/negative_emission.rs`).

mod common;

use common::agreement::{Seeded, disagreeing, regions, sidak};
use common::{GltfBuilder, look_rotation, render_image, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);
const RES: (usize, usize) = (24, 24);

/// A light turned by -90° about X: its -Z (where area lights and spots face) points down.
const DOWN: [f32; 4] = [-std::f32::consts::FRAC_1_SQRT_2, 0.0, 0.0, std::f32::consts::FRAC_1_SQRT_2];

/// The floor and back wall seen from the front, as `tests/negative_emission.rs`.
fn room() -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let grey = g
        .material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1], "metallicFactor": 0.0},
            "doubleSided": true}));
    let quad = |g: &mut GltfBuilder, p: [[f32; 3]; 4], m: usize| g.mesh(&p, &[0, 1, 2, 0, 2, 3], m);
    quad(&mut g, [[-2.0, -1.0, -2.0], [2.0, -1.0, -2.0], [2.0, -1.0, -6.0], [-2.0, -1.0, -6.0]], grey);
    quad(&mut g, [[-2.0, -1.0, -6.0], [2.0, -1.0, -6.0], [2.0, 2.0, -6.0], [-2.0, 2.0, -6.0]], grey);
    g.camera([0.0, 1.2, 0.0], look_rotation([0.0, -0.35, -1.0]), 1.0);
    g
}

/// An area light of `power` W (negative: it subtracts light), a `size` square facing down.
fn area(g: &mut GltfBuilder, at: [f32; 3], size: f32, power: f32) {
    g.use_ext("CAUSTIC_lights_area");
    g.node(json!({"translation": at, "rotation": DOWN,
        "extensions": {"CAUSTIC_lights_area": {"shape": "square", "size": [size], "power": power}}}));
}

/// A KHR_lights_punctual light of `intensity` (cd or lux, its size), negative through
/// `CAUSTIC_lights_punctual` as the add-on writes a Blender light of negative power; `shape`
/// holds the extension's other keys.
fn punctual(g: &mut GltfBuilder, light: Value, intensity: f32, at: [f32; 3], rotation: [f32; 4], shape: Value) {
    let mut light = light;
    light["intensity"] = json!(intensity.abs());
    let mut ext = shape;
    if intensity < 0.0 {
        ext["negative"] = json!(true);
    }
    g.use_ext("CAUSTIC_lights_punctual");
    g.punctual_with(light, at, rotation, json!({ "CAUSTIC_lights_punctual": ext }));
}

/// The lights of the module doc, one scene of a single light each, `sign` its power's.
fn single_light(dir: &Path, kind: &str, sign: f32) -> PathBuf {
    let mut g = room();
    let up = [0.0, 0.0, 0.0, 1.0];
    match kind {
        "point" => punctual(&mut g, json!({"type": "point"}), sign * 1700.0, [0.8, 0.6, -3.8], up, json!({})),
        "sphere" => {
            punctual(&mut g, json!({"type": "point"}), sign * 700.0, [-1.0, 0.2, -3.0], up, json!({"radius": 0.15}))
        }
        "spot" => punctual(
            &mut g,
            json!({"type": "spot", "spot": {"innerConeAngle": 0.4, "outerConeAngle": 0.6}}),
            sign * 3000.0,
            [0.0, 1.0, -4.0],
            DOWN,
            json!({"spot_blend": 0.3}),
        ),
        "sun" => {
            punctual(&mut g, json!({"type": "directional"}), sign * 300.0, [0.0, 3.0, 0.0], DOWN, json!({"angle": 0.2}))
        }
        "area" => area(&mut g, [-0.5, 1.8, -4.0], 1.0, sign * 80.0),
        _ => unreachable!("{kind}"),
    }
    g.write(dir, &format!("{kind}_{sign}.gltf"))
}

/// The scene of the module doc; `negative` false sets the four negative lights to 0.
fn mixed(dir: &Path, negative: bool) -> PathBuf {
    let mut g = room();
    let s = if negative { -1.0 } else { 0.0 };
    let up = [0.0, 0.0, 0.0, 1.0];
    area(&mut g, [-0.5, 1.8, -4.0], 1.0, 80.0);
    punctual(&mut g, json!({"type": "point", "name": "Hole"}), s * 1700.0, [0.8, 0.6, -3.8], up, json!({}));
    punctual(
        &mut g,
        json!({"type": "point", "name": "Orb"}),
        s * 700.0,
        [-1.0, 0.2, -3.0],
        up,
        json!({"radius": 0.15}),
    );
    area(&mut g, [1.0, 1.2, -5.0], 0.5, s * 15.0);
    let slant = look_rotation([0.3, -1.0, -0.4]);
    punctual(
        &mut g,
        json!({"type": "directional", "name": "Dusk"}),
        s * 200.0,
        [0.0, 3.0, 0.0],
        slant,
        json!({"angle": 0.2}),
    );
    g.write(dir, &format!("mixed_{negative}.gltf"))
}

const INTEGRATORS: [(&str, &[&str]); 5] = [
    ("path", &["--integrator", "path", "--spp", "4"]),
    ("bdpt", &["--integrator", "bdpt", "--spp", "2"]),
    ("vcm", &["--integrator", "vcm", "--spp", "2", "--vcm-radius", "0.05"]),
    ("photon", &["--integrator", "photon", "--spp", "2", "--photons", "20000", "--max-radius", "0.05"]),
    ("sppm", &["--integrator", "sppm", "--sppm-iterations", "2", "--sppm-radius", "0.05"]),
];

/// Each kind of light alone, negative, renders the negated image of the positive one, exactly,
/// in every integrator (the positive image is checked to be lit, so the check can fail).
#[test]
fn a_negative_light_alone_renders_the_negated_image() {
    let dir = temp_dir();
    let out = dir.path().join("n.exr");
    for kind in ["point", "sphere", "spot", "sun", "area"] {
        let (pos, neg) = (single_light(dir.path(), kind, 1.0), single_light(dir.path(), kind, -1.0));
        for (name, flags) in INTEGRATORS {
            let mut args = vec!["--resolution", "16x16", "--max-depth", "3", "--seed", "7"];
            args.extend_from_slice(flags);
            let p = render_image(&pos, &out, &args, LIMIT);
            let n = render_image(&neg, &out, &args, LIMIT);
            let lit = p.iter().map(|px| px[0] as f64).sum::<f64>();
            assert!(lit > 0.0, "{kind} ({name}): the positive light lights nothing");
            for (i, (a, b)) in p.iter().zip(&n).enumerate() {
                for c in 0..3 {
                    assert_eq!(-a[c], b[c], "{kind} ({name}): pixel {i} channel {c}");
                }
            }
        }
    }
}

/// BDPT, VCM, Jensen and SPPM each agree with the path tracer region by region.
#[test]
fn every_integrator_matches_the_path_tracer_with_negative_lights() {
    let dir = temp_dir();
    let path = mixed(dir.path(), true);
    let regs = regions(RES.0, RES.1);
    let r = format!("{}x{}", RES.0, RES.1);
    let seeded = Seeded::six(dir.path(), &r, "4", &regs, LIMIT);
    // 4× the samples of `tests/negative_emission.rs` (the renders take a fraction of a second):
    // the Welch bound shrinks by 2, so a smaller error in the negative lights' share shows.
    let path_tracer = ["--integrator", "path", "--spp", "256"];
    let reference = seeded.means(&path, &path_tracer);
    let alpha = sidak(regs.len() * 5);
    let without = seeded.means(&mixed(dir.path(), false), &path_tracer);
    assert!(
        !disagreeing("negative lights at 0", &regs, &without, &reference, alpha).is_empty(),
        "the negative lights change nothing"
    );
    let others: [(&str, &[&str]); 4] = [
        ("bdpt", &["--integrator", "bdpt", "--spp", "64"]),
        ("vcm", &["--integrator", "vcm", "--spp", "64", "--vcm-radius", "0.02"]),
        ("photon", &["--integrator", "photon", "--spp", "64", "--photons", "100000", "--max-radius", "0.02"]),
        ("sppm", &["--integrator", "sppm", "--sppm-iterations", "64", "--sppm-radius", "0.02"]),
    ];
    let failed = seeded.disagreeing_others(&path, &reference, &others, alpha);
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}
