//! Curves Info on strands (`curves::info`), through the binary, in every integrator.
//!
//! Two straight round strands of radius 0.25 along x, from x = −1 to 1 (the frame's width),
//! at y = −0.5 and 0.5, lit by a sun straight above and seen straight down by an orthographic
//! camera over a black world, one bounce. Their material is a Diffuse BSDF whose colour is
//! (Intercept, Random, Length / 2): a pixel's light is its colour times a shading factor that
//! varies across the strand (its round normal) but not along it, so over a covered pixel
//! red / blue is the intercept at its centre, (x + 1) / 2 (the strand is straight, so the
//! fraction of its length is the fraction of x, whatever the uneven spacing of its points; a
//! pixel's box average of a ramp is its centre's value), green / blue Cycles' hash of the
//! strand's index (`hash_uint2_to_float(i, 0)`), and blue / (the same strand with a white
//! colour) is the length 2 over 2. Every integrator shades the strands through the graph.

mod common;

use common::{GltfBuilder, render_image, temp_dir};
use serde_json::json;
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(180);
const RES: usize = 64;

#[test]
fn curves_info_reads_each_strand_in_every_integrator() {
    let dir = temp_dir();
    let d = dir.path();
    let mut g = GltfBuilder::new();
    let nodes = json!([
        {"name": "Info", "type": "ShaderNodeHairInfo"},
        {"name": "Half", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
         "inputs": {"Value": {"link": [0, "Length"]}, "Value_001": {"value": 0.5}}},
        {"name": "Combine", "type": "ShaderNodeCombineXYZ",
         "inputs": {"X": {"link": [0, "Intercept"]}, "Y": {"link": [0, "Random"]}, "Z": {"link": [1, "Value"]}}},
        {"name": "Diffuse", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"link": [2, "Vector"]}}}
    ]);
    let material = g.material(json!({"name": "Info", "extensions": {"CAUSTIC_materials_nodes":
        {"version": 1, "nodes": nodes, "output": {"surface": [3, "BSDF"]}}}}));
    g.use_ext("CAUSTIC_materials_nodes");
    let (mut points, mut radii, mut counts) = (Vec::new(), Vec::new(), Vec::new());
    for y in [-0.5f32, 0.5] {
        for x in [-1.0f32, -0.6, 0.2, 1.0] {
            points.push([x, y, 0.0]);
            radii.push(0.25);
        }
        counts.push(4);
    }
    g.curves("strands", material, &points, &radii, &counts);
    // The sun shines along the node's −Z: straight down.
    g.punctual(json!({"type": "directional", "intensity": 683.0}), [0.0, 0.0, 3.0], [0.0, 0.0, 0.0, 1.0]);
    g.orthographic([0.0, 0.0, 3.0], [0.0, 0.0, 0.0, 1.0], 1.0, 1.0);
    let scene = g.write(d, "info.gltf");
    use caustic::shader::texture::hash::{hash_uint2, uint_to_float_incl};
    let random = [0, 1].map(|i| uint_to_float_incl(hash_uint2(i, 0)));
    assert!((random[0] - random[1]).abs() > 0.05, "the two strands' numbers differ: {random:?}");
    // The path tracer, BDPT and VCM light the strands exactly (a delta sun, one bounce): their
    // ratios are off only by the pixel's jitter, 2e-3 (see the loop). The photon integrators
    // estimate the light from photons gathered over a radius 0.02 along the ramp (0.01 of its
    // value) with their noise: 2e-2.
    for (integrator, tol, extra) in [
        ("path", 6e-3, vec![]),
        ("bdpt", 6e-3, vec![]),
        ("vcm", 6e-3, vec!["--vcm-radius", "0.02"]),
        ("photon", 2e-2, vec![]),
        ("sppm", 2e-2, vec!["--sppm-iterations", "16", "--sppm-radius", "0.02"]),
    ] {
        let mut args =
            vec!["--resolution", "64x64", "--spp", "16", "--filter", "box", "--filter-width", "1", "--max-depth", "1"];
        args.extend(["--integrator", integrator]);
        args.extend(extra);
        let px = render_image(&scene, &d.join(format!("{integrator}.exr")), &args, LIMIT);
        let mut checked = 0;
        let mut blues = Vec::new();
        for (i, p) in px.iter().enumerate() {
            let (col, row) = (i % RES, i / RES);
            let x = -1.0 + (col as f32 + 0.5) * 2.0 / RES as f32;
            let y = 1.0 - (row as f32 + 0.5) * 2.0 / RES as f32;
            // Pixels wholly on a strand (its width ± a pixel) away from its ends.
            if x.abs() > 0.9 {
                continue;
            }
            let strand = if (y - 0.5).abs() < 0.2 {
                0
            } else if (y + 0.5).abs() < 0.2 {
                1
            } else {
                continue;
            };
            // glTF's y up is the image's up; the first strand written is at y = −0.5.
            let strand = 1 - strand;
            // 16 jittered samples over a pixel (1/64 of the ramp's range) leave an error near
            // 1/64 / √(12 · 16) = 1e-3 in red / blue; 6e-3 allows the shading factor's own
            // variation over the samples too.
            let blue = p[2];
            assert!(blue > 0.01, "{integrator}: pixel ({col}, {row}) is lit ({blue})");
            let got = [p[0] / blue, p[1] / blue];
            let expect = [(x + 1.0) / 2.0, random[strand]];
            for k in 0..2 {
                assert!(
                    (got[k] - expect[k]).abs() < tol,
                    "{integrator}: pixel ({col}, {row}) ratio {k}: {} against {}",
                    got[k],
                    expect[k]
                );
            }
            blues.push(blue);
            checked += 1;
        }
        assert!(checked > 2 * RES * 8, "{integrator}: {checked} pixels checked");
        // Length: blue is the colour 1 times the shading factor, which over a sun straight
        // above is at most the Lambertian 1 × E / π (the strand's top).
        let top = blues.iter().copied().fold(0.0, f32::max) as f64;
        eprintln!("{integrator}: brightest blue {top:.4}, Lambertian top {:.4}", 1.0 / std::f64::consts::PI);
        assert!((top * std::f64::consts::PI - 1.0).abs() < 0.05, "{integrator}: Length gives blue {top}");
    }
}
