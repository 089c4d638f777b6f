//! BDPT and VCM at a contact (`src/integrator/bdpt/contact.rs`): a smooth glass cube resting
//! on a grey floor, lit by a point light above it, seen from above at an angle so that the
//! floor under the glass shows through its top.
//!
//! The path tracer's look back traps a path that reaches the floor under the glass (it gets
//! direct light there, which the glass blocks, and nothing else, as in Cycles). Before the
//! contact rule BDPT's and VCM's subpaths had no look back: a camera subpath on the floor
//! under the glass went up through the glass to the lit floor around it, and light subpaths
//! landed on that floor after refracting into the glass, so both lit what the path tracer
//! keeps dark (Transmission Indirect 1.50x and 1.36x Cycles' in tests/blender/test_passes.py).
//! Here they converge to the path tracer's image region by region. The test first checks
//! that the contact matters at this noise level: with the cube lifted off the floor by 0.05
//! the path tracer's image leaves the resting cube's bounds (light then reaches the floor
//! under the glass through the gap and from the glass's bottom).
//!
//! Bounds (`common::agreement`): K seeds per estimate, Welch's test per region, Šidák's
//! split over every comparison of the test (the lift check and two integrators, six regions
//! each: the whole image, its quadrants and the glass's middle). VCM's merging blurs
//! indirect light by at most its radius, 0.01 on a scene 8 units across: the loss at edges
//! is about r / side of a region's indirect light, below a tenth of its noise bound.

mod common;

use common::GltfBuilder;
use common::agreement::{Seeded, regions, sidak};
use common::{look_rotation, temp_dir};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);
const RES: (usize, usize) = (32, 32);
/// Half the cube's side: the cube is [-H, H] × [lift, lift + 2H] × [-H, H] (glTF's y up).
const H: f32 = 0.5;

/// The scene of the module doc, the cube raised by `lift` above the floor.
fn scene(dir: &Path, lift: f32) -> PathBuf {
    let mut g = GltfBuilder::new();
    g.use_ext("KHR_materials_transmission");
    g.use_ext("KHR_materials_volume");
    let glass = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                       "KHR_materials_volume": {"thicknessFactor": 1.0}}
    }));
    let grey = g.material(
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0.0}, "doubleSided": true}),
    );
    let s = 4.0;
    g.mesh(&[[-s, 0.0, -s], [s, 0.0, -s], [s, 0.0, s], [-s, 0.0, s]], &[0, 2, 1, 0, 3, 2], grey);
    g.cube([-H, lift, -H], [H, lift + 2.0 * H, H], glass);
    g.punctual(json!({"type": "point", "intensity": 2000.0}), [0.6, 3.0, -0.4], [0.0, 0.0, 0.0, 1.0]);
    // A grey world all round: from below it lights the floor's underside, where paths
    // trapped at the contact take it by next-event estimation alone (`bdpt::contact`).
    g.world(json!({"color": [0.2, 0.2, 0.2]}));
    // From above and in front, looking at the cube's middle: its top shows the floor under it.
    g.camera([0.0, 2.6, 2.2], look_rotation([0.0, -2.2, -2.2]), 0.7);
    g.write(dir, &format!("contact_{lift}.gltf"))
}

/// BDPT and VCM agree with the path tracer on the glass resting on the floor.
#[test]
fn bdpt_and_vcm_match_the_path_tracer_at_a_contact() {
    let dir = temp_dir();
    let resting = scene(dir.path(), 0.0);
    let mut regs = regions(RES.0, RES.1);
    // The glass fills the middle of the image (the floor under it seen through its top).
    let (w, h) = RES;
    let middle = (0..w * h).filter(|i| (i % w).abs_diff(w / 2) < w / 6 && (i / w).abs_diff(h / 2) < h / 6).collect();
    regs.push(("middle".to_string(), middle));
    let r = format!("{}x{}", RES.0, RES.1);
    let seeded = Seeded::six(dir.path(), &r, "4", &regs, LIMIT);
    let path_tracer = ["--integrator", "path", "--spp", "64"];
    let reference = seeded.means(&resting, &path_tracer);
    let alpha = sidak(regs.len() * 3);
    let lifted = seeded.means(&scene(dir.path(), 0.05), &path_tracer);
    seeded.assert_rule_matters("the glass lifted", &lifted, &reference, alpha);
    let failed = seeded.bidirectional_disagreeing(&resting, &reference, "16", "0.01", alpha);
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}
