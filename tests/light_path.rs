//! The Light Path node through the binary, in scenes whose answer is exact: an emitter
//! seen only by camera rays, and an occluder that shadow rays pass (a Mix Shader by Is
//! Shadow Ray), for the integrators that shade with the ray's state (BDPT and VCM take
//! emitters that read it from the camera side).

mod common;

use common::*;
use serde_json::{Value, json};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);

fn node_material(name: &str, nodes: Value, surface: Value) -> Value {
    json!({"name": name, "doubleSided": true, "extensions": {"CAUSTIC_materials_nodes":
        {"version": 1, "nodes": nodes, "output": {"surface": surface}}}})
}

/// A closed white furnace whose walls are Add(Emission × Is Camera Ray, Diffuse white):
/// the camera sees each wall's emission Le, and nothing else emits toward a bounced ray,
/// so every pixel is exactly Le (every wall would add Le per bounce if the flag were
/// ignored: (D + 1) Le with D = 3 scattering events). BDPT and VCM take such emitters by
/// the camera path alone (`bdpt::path_emitters`): s = 0 at the first hit, with weight 1.
#[test]
fn emission_seen_only_by_camera_rays() {
    let le = 0.75;
    for integrator in ["path", "sppm", "photon", "bdpt", "vcm"] {
        let dir = temp_dir();
        let mut g = GltfBuilder::new();
        g.use_ext("CAUSTIC_materials_nodes");
        let walls = g.material(node_material(
            "camera only",
            json!([
                {"name": "Light Path", "type": "ShaderNodeLightPath"},
                {"name": "Emission", "type": "ShaderNodeEmission",
                 "inputs": {"Color": {"value": [1, 1, 1, 1]}, "Strength": {"link": [0, "Is Camera Ray"]}}},
                {"name": "Diffuse", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"value": [1, 1, 1, 1]}}},
                {"name": "Scale", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
                 "inputs": {"Value": {"link": [0, "Is Camera Ray"]}, "Value_001": {"value": le}}},
                {"name": "Emission2", "type": "ShaderNodeEmission",
                 "inputs": {"Color": {"value": [1, 1, 1, 1]}, "Strength": {"link": [3, "Value"]}}},
                {"name": "Add", "type": "ShaderNodeAddShader",
                 "inputs": {"Shader": {"link": [4, "Emission"]}, "Shader_001": {"link": [2, "BSDF"]}}}
            ]),
            json!([5, "Shader"]),
        ));
        g.cube([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], walls);
        g.camera([0.1, 0.2, 0.3], look_rotation([0.3, -0.2, -1.0]), 1.2);
        let scene = g.write(dir.path(), "furnace.gltf");
        let px = render_image(
            &scene,
            &dir.path().join("o.exr"),
            &["--resolution", "8x8", "--spp", "16", "--max-depth", "3", "--integrator", integrator],
            LIMIT,
        );
        for p in &px {
            // Only the camera ray's own hit emits: no noise, f32 rounding of one sum.
            assert!((p[0] as f64 - le).abs() < 1e-5, "{integrator}: pixel {} (want {le})", p[0]);
        }
    }
}

/// A floor under a sun, and above part of it an occluder Mix(Diffuse black, Transparent,
/// Is Shadow Ray): shadow rays pass it, so the floor under it is lit exactly as without
/// it (the sun is a delta light: each pixel is the same deterministic sum, and bounced
/// rays meet only the black side of the occluder), while the camera above sees it black
/// and opaque.
#[test]
fn shadow_rays_pass_an_occluder_mixed_by_is_shadow_ray() {
    let render = |with_occluder: bool, camera_y: f32| {
        let dir = temp_dir();
        let mut g = GltfBuilder::new();
        g.use_ext("CAUSTIC_materials_nodes");
        let white = g.material(node_material(
            "floor",
            json!([{"name": "Diffuse", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"value": [1, 1, 1, 1]}}}]),
            json!([0, "BSDF"]),
        ));
        let ghost = g.material(node_material(
            "ghost",
            json!([
                {"name": "Light Path", "type": "ShaderNodeLightPath"},
                {"name": "Diffuse", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"value": [0, 0, 0, 1]}}},
                {"name": "Transparent", "type": "ShaderNodeBsdfTransparent", "inputs": {"Color": {"value": [1, 1, 1, 1]}}},
                {"name": "Mix", "type": "ShaderNodeMixShader",
                 "inputs": {"Fac": {"link": [0, "Is Shadow Ray"]}, "Shader": {"link": [1, "BSDF"]},
                            "Shader_001": {"link": [2, "BSDF"]}}}
            ]),
            json!([3, "Shader"]),
        ));
        g.mesh(&[[-4.0, 0.0, -4.0], [4.0, 0.0, -4.0], [4.0, 0.0, 4.0], [-4.0, 0.0, 4.0]], &[0, 2, 1, 0, 3, 2], white);
        if with_occluder {
            g.mesh(
                &[[-1.0, 2.0, -1.0], [1.0, 2.0, -1.0], [1.0, 2.0, 1.0], [-1.0, 2.0, 1.0]],
                &[0, 2, 1, 0, 3, 2],
                ghost,
            );
        }
        g.punctual(
            json!({"type": "directional", "intensity": 683.0}),
            [0.0, 5.0, 0.0],
            look_rotation([0.0, -1.0, 0.001]),
        );
        // Looking down from between the occluder and the floor (y = 1) or from above it (y = 3):
        // a narrow view that sees only the square under the occluder.
        g.camera([0.0, camera_y, 0.0], look_rotation([0.0, -1.0, 0.001]), 0.3);
        g.settings(json!({"filter": "box"}));
        let scene = g.write(dir.path(), "ghost.gltf");
        render_image(
            &scene,
            &dir.path().join("o.exr"),
            &["--resolution", "4x4", "--spp", "8", "--max-depth", "2"],
            LIMIT,
        )
    };
    let lit = render(false, 1.0);
    let under = render(true, 1.0);
    assert!(lit[0][0] > 0.1, "the floor is lit: {}", lit[0][0]);
    for (a, b) in lit.iter().zip(&under) {
        // The same sums but for paths bounced off the floor into the black occluder, which add 0.
        assert!((a[0] - b[0]).abs() <= 1e-5 * a[0], "under the occluder {} vs without it {}", b[0], a[0]);
    }
    let above = render(true, 3.0);
    for p in &above {
        // Camera rays see the black diffuse side: opaque and unlit.
        assert!(p[0] == 0.0 && (p[3] - 1.0).abs() < 1e-6, "the occluder seen from above: {p:?}");
    }
}

/// A world of strength 1 + 3 × Is Camera Ray (Cycles' trick of a backdrop that does not
/// light the scene): the camera sees 4 where it sees the world, while a white-diffuse
/// (albedo 0.8) quad facing the camera, alone under the world, is lit by strength 1 over its
/// hemisphere: radiance 0.8 (4 × 0.8 if the lighting read the camera's flag, and the
/// camera's view 1 if it read light sampling's, as before). Every integrator: camera rays
/// read their own state in all of them.
#[test]
fn world_seen_by_the_camera_reads_is_camera_ray() {
    for integrator in ["path", "bdpt", "vcm", "photon", "sppm"] {
        let dir = temp_dir();
        let mut g = GltfBuilder::new();
        g.use_ext("CAUSTIC_materials_nodes");
        let white = g.material(node_material(
            "white",
            json!([{"name": "Diffuse", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"value": [0.8, 0.8, 0.8, 1]}}}]),
            json!([0, "BSDF"]),
        ));
        g.mesh(&[[-3., -3., 0.], [0., -3., 0.], [0., 3., 0.], [-3., 3., 0.]], &[0, 1, 2, 0, 2, 3], white);
        g.camera([0.0, 0.0, 5.0], [0.0, 0.0, 0.0, 1.0], 0.5);
        let nodes = json!([
            {"name": "Light Path", "type": "ShaderNodeLightPath"},
            {"name": "Strength", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY_ADD"},
             "inputs": {"Value": {"link": [0, "Is Camera Ray"]}, "Value_001": {"value": 3.0}, "Value_002": {"value": 1.0}}},
            {"name": "Background", "type": "ShaderNodeBackground",
             "inputs": {"Color": {"value": [1, 1, 1, 1]}, "Strength": {"link": [1, "Value"]}}}
        ]);
        g.world(json!({"nodes": {"version": 1, "nodes": nodes, "output": {"surface": [2, "Background"]}}}));
        // An opaque film: the camera sees the world (a transparent one shows none of it).
        g.settings(json!({"transparent": false}));
        let scene = g.write(dir.path(), "world.gltf");
        let px = render_image(
            &scene,
            &dir.path().join("o.exr"),
            &[
                "--resolution",
                "8x8",
                "--spp",
                "64",
                "--max-depth",
                "1",
                "--filter",
                "box",
                "--filter-width",
                "1",
                "--integrator",
                integrator,
            ],
            LIMIT,
        );
        let (mut quad, mut sky) = (Vec::new(), Vec::new());
        for (i, p) in px.iter().enumerate() {
            if i % 8 < 4 { quad.push(p[0] as f64) } else { sky.push(p[0] as f64) }
        }
        for s in &sky {
            // The camera ray's own evaluation: f32 rounding only.
            assert!((s - 4.0).abs() < 1e-4, "{integrator}: the camera sees the world at {s}, want 4");
        }
        // The quad: a mean over 32 pixels × 64 samples; 5 standard errors from the pixels' spread.
        let (m, se) = mean_se(&quad);
        eprintln!("{integrator}: quad {m:.4} ± {se:.4}");
        assert!((m - 0.8).abs() <= 5.0 * se + 2e-3, "{integrator}: the quad is {m}, want 0.8 (± {se})");
    }
}
