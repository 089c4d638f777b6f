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
