//! Emitting media as photon sources (`light::media_emit`): a glowing medium lights a
//! diffuse floor and wall, and Jensen's photon mapping and SPPM agree with the path
//! tracer region by region. Three media: a scattering homogeneous medium with emission in
//! a mesh, a volume object whose temperature grid burns (blackbody fire), an emitting,
//! scattering World Volume inside a closed room, and an emitting, absorbing one in the open
//! (its light from beyond the photons' box enters through the box's faces). Photons that start only at lights miss
//! the medium's light after a bounce or a scattering (the floor's indirect light from the
//! wall, the fog's own glow scattered): before `media_emit`, Jensen's and SPPM's images
//! fell short of the path tracer's here.
//!
//! Bounds as in `common/agreement.rs`: each estimate from K independent seeds, Welch's t
//! on the regions' per-seed means at a false-alarm rate of 10⁻³ for the whole test
//! (Šidák over its comparisons). The photon estimates' bias (the kernel's blur of the
//! light across the radius 0.05 at the floor–wall edge, the SPPM radius shrinking) is
//! below these standard errors at these settings: checked by their agreement, not assumed.

mod common;

use caustic::medium::grid_file::{GridFile, NamedGrid};
use common::agreement::{Seeded, disagreeing, regions, sidak};
use common::{GltfBuilder, look_rotation, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(300);

/// Seeds per estimate: with 30-40 comparisons at 10⁻³ in all, 6 seeds' t quantile (about 12
/// at 5 degrees of freedom) left a 7 % shortfall unseen; 12 seeds bring it to about 6.
const SEEDS: u32 = 12;

/// A white floor (y = 0) and back wall (z = −2) of 4 × 4 and 4 × 3, seen from the front
/// and above, with no light: what the medium `add` puts in is all the light there is.
fn room(dir: &Path, name: &str, add: impl FnOnce(&mut GltfBuilder)) -> PathBuf {
    let mut g = GltfBuilder::new();
    let white = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
    g.mesh(&[[-2.0, 0.0, -2.0], [2.0, 0.0, -2.0], [2.0, 0.0, 2.0], [-2.0, 0.0, 2.0]], &[0, 2, 1, 0, 3, 2], white);
    g.mesh(&[[-2.0, 0.0, -2.0], [2.0, 0.0, -2.0], [2.0, 3.0, -2.0], [-2.0, 3.0, -2.0]], &[0, 1, 2, 0, 2, 3], white);
    g.camera([0.0, 2.0, 2.5], look_rotation([0.0, -1.6, -3.5]), 0.9);
    add(&mut g);
    g.write(dir, name)
}

/// A glowing, scattering homogeneous medium in a cube above the floor (no surface).
fn glowing_cube(g: &mut GltfBuilder) {
    g.use_ext("CAUSTIC_materials_medium");
    let m = g.material(json!({"extensions": {"CAUSTIC_materials_medium": {
        "density": 1.0, "scatter_color": [2.0, 1.6, 1.2], "absorption_color": [0.3, 0.3, 0.3],
        "emission": [1.5, 1.0, 0.5], "surface": false}}}));
    g.cube([-0.6, 0.5, -1.4], [0.6, 1.3, -0.4], m);
}

/// A volume object of 6 × 4 × 6 voxels (voxel 0.2, the domain x, z ∈ [−0.7, 0.7] around
/// z = −0.9, y ∈ [0.3, 1.3]) whose temperature grid rises from 0 at the bottom to 1.5 at the
/// top: blackbody fire at up to 1500 K (Temperature 1000), in a thin scattering smoke.
fn fire(dir: &Path, path: &Path) {
    let dims = [6u32, 4, 6];
    let values: Vec<f32> = (0..dims[0] * dims[1] * dims[2]).map(|i| 0.5 * (i / dims[0] % dims[1]) as f32).collect();
    let file = GridFile {
        dims,
        index_to_object: [0.2, 0.0, 0.0, -0.5, 0.0, 0.2, 0.0, 0.5, 0.0, 0.0, 0.2, -1.4],
        grids: vec![NamedGrid { name: "temperature".into(), components: 1, values }],
    };
    std::fs::write(dir.join("fire.cvol"), file.to_bytes()).unwrap();
    let volume = json!({"name": "Fire", "uri": "fire.cvol", "matrix": glam::Mat4::IDENTITY.to_cols_array(),
        "density_grid": null, "temperature_grid": "temperature",
        "shader": {"density": 0.5, "color": [0.8, 0.8, 0.8], "absorption_color": [0.0, 0.0, 0.0], "anisotropy": 0.0,
                   "emission": [0.0, 0.0, 0.0], "blackbody_intensity": 1.0, "blackbody_tint": [1.0, 1.0, 1.0],
                   "temperature": 1000.0}});
    let mut doc: Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    doc["extensionsUsed"].as_array_mut().unwrap().push(json!("CAUSTIC_volume"));
    doc["extensions"]["CAUSTIC_volume"] = json!({"volumes": [volume]});
    std::fs::write(path, serde_json::to_vec(&doc).unwrap()).unwrap();
}

/// An emitting, scattering World Volume, closed in by a ceiling, side walls and a front
/// wall behind the camera (every point it lights is within its photons' box).
fn glowing_world(g: &mut GltfBuilder) {
    let grey = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
    let (x0, x1, y1, z0, z1) = (-2.0, 2.0, 3.0, -2.0, 3.0);
    g.mesh(&[[x0, y1, z0], [x1, y1, z0], [x1, y1, z1], [x0, y1, z1]], &[0, 1, 2, 0, 2, 3], grey);
    g.mesh(&[[x0, 0.0, z0], [x0, y1, z0], [x0, y1, z1], [x0, 0.0, z1]], &[0, 1, 2, 0, 2, 3], grey);
    g.mesh(&[[x1, 0.0, z0], [x1, y1, z0], [x1, y1, z1], [x1, 0.0, z1]], &[0, 2, 1, 0, 3, 2], grey);
    g.mesh(&[[x0, 0.0, z1], [x1, 0.0, z1], [x1, y1, z1], [x0, y1, z1]], &[0, 2, 1, 0, 3, 2], grey);
    g.mesh(&[[x0, 0.0, 2.0], [x1, 0.0, 2.0], [x1, 0.0, z1], [x0, 0.0, z1]], &[0, 2, 1, 0, 3, 2], grey);
    g.world(json!({"color": [0.0, 0.0, 0.0], "medium": {"density": 1.0, "scatter_color": [0.3, 0.3, 0.3],
        "absorption_color": [0.2, 0.2, 0.2], "emission": [0.2, 0.15, 0.1]}}));
}

/// An emitting World Volume that only absorbs, open all round: the fog beyond the photons'
/// box lights the floor and wall through the box's faces (E/σt, exact without scattering).
fn glowing_open_world(g: &mut GltfBuilder) {
    g.world(json!({"color": [0.0, 0.0, 0.0], "medium": {"density": 1.0, "scatter_color": [0.0, 0.0, 0.0],
        "absorption_color": [0.3, 0.25, 0.2], "emission": [0.2, 0.15, 0.1]}}));
}

/// Jensen's photon mapping and SPPM against the path tracer on each glowing medium, per
/// region (whole image and quadrants), [`SEEDS`] seeds each.
#[test]
fn photon_integrators_gather_emitting_media() {
    let dir = temp_dir();
    let d = dir.path();
    let scenes = [
        ("cube", room(d, "cube.gltf", glowing_cube)),
        ("fire", {
            let p = room(d, "fire.gltf", |_| {});
            fire(d, &p);
            p
        }),
        ("world", room(d, "world.gltf", glowing_world)),
        ("open world", room(d, "open.gltf", glowing_open_world)),
    ];
    let regions = regions(24, 24);
    let common = vec!["--resolution", "24x24", "--max-depth", "6"];
    let seeded = Seeded { dir: d, common, seeds: SEEDS, regions: &regions, limit: LIMIT };
    let jensen = ["--integrator", "photon", "--spp", "32", "--photons", "100000", "--max-radius", "0.05"];
    let sppm = ["--integrator", "sppm", "--sppm-iterations", "128", "--sppm-radius", "0.05"];
    let alpha = sidak(scenes.len() * 2 * regions.len());
    let mut failed = Vec::new();
    for (label, scene) in &scenes {
        let reference = seeded.means(scene, &["--spp", "256"]);
        assert!(reference[0].iter().all(|&m| m > 1e-3), "{label}: the scene is black");
        for (name, flags) in [("PM", &jensen[..]), ("SPPM", &sppm[..])] {
            let m = seeded.means(scene, flags);
            let tag = format!("{label} {name}");
            failed.extend(disagreeing(&tag, &regions, &m, &reference, alpha).into_iter().map(|r| format!("{tag} {r}")));
        }
    }
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}

/// The glowing cube under a small emitting quad facing it (a light that MIS weighs), at Max
/// Bounces 0 and 1: where the photon integrators' camera paths scatter in the medium at their
/// last event, the path tracer's `scatter_in_medium` traces the phase-sampled ray as `trace`
/// does, for the medium's glow and the quad's MIS-weighted light it finds. Before, it stopped
/// there: next-event estimation's half of the MIS estimate alone, and no glow.
fn lit_glowing_cube(g: &mut GltfBuilder) {
    glowing_cube(g);
    g.use_ext("KHR_materials_emissive_strength");
    let lamp = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0},
        "emissiveFactor": [1.0, 1.0, 1.0],
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}
    }));
    // Facing down (−y) over the cube.
    g.mesh(&[[-0.5, 2.0, -1.4], [0.5, 2.0, -1.4], [0.5, 2.0, -0.4], [-0.5, 2.0, -0.4]], &[0, 1, 2, 0, 2, 3], lamp);
}

#[test]
fn the_last_event_in_a_medium_keeps_its_phase_ray() {
    const FEW: u32 = 6;
    let dir = temp_dir();
    let d = dir.path();
    let scene = room(d, "lit.gltf", lit_glowing_cube);
    let regions = regions(16, 16);
    let jensen = ["--integrator", "photon", "--spp", "16", "--photons", "20000", "--max-radius", "0.05"];
    let sppm = ["--integrator", "sppm", "--sppm-iterations", "32", "--sppm-radius", "0.05"];
    let depths = ["1", "2"];
    let alpha = sidak(depths.len() * 2 * regions.len());
    let mut failed = Vec::new();
    for depth in depths {
        let common = vec!["--resolution", "16x16", "--max-depth", depth];
        let seeded = Seeded { dir: d, common, seeds: FEW, regions: &regions, limit: LIMIT };
        let reference = seeded.means(&scene, &["--spp", "128"]);
        assert!(reference[0].iter().all(|&m| m > 1e-3), "the scene is black");
        for (name, flags) in [("PM", &jensen[..]), ("SPPM", &sppm[..])] {
            let m = seeded.means(&scene, flags);
            let tag = format!("max depth {depth} {name}");
            failed.extend(disagreeing(&tag, &regions, &m, &reference, alpha).into_iter().map(|r| format!("{tag} {r}")));
        }
    }
    assert!(failed.is_empty(), "disagree with the path tracer: {failed:?}");
}
