//! Golden images: a fixed set of scenes × integrators rendered small and hashed, so that
//! a restructuring of the renderer is proven to leave every image bit for bit as it was.
//!
//! The checksums live in `tests/golden/checksums.txt`; an image changed on purpose (a
//! fixed bug, a new model) is re-blessed with `CAUSTIC_GOLDEN_BLESS=1 cargo test
//! --release --test golden`, and the commit that does so adds a line to that file's
//! header saying which images moved and why.
//!
//! Every render is single-threaded (the film's fixed-point sums make images equal across
//! thread counts, BDPT's splats included, but one thread keeps the run short). The hash covers
//! every channel of the EXR (decoded, so the file's encoding does not matter), in
//! channel-name order.

mod common;

use common::{GltfBuilder, fog_layer, look_rotation, root, run, temp_dir};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);

/// FNV-1a over 64 bits: stable across Rust versions, unlike `DefaultHasher`.
fn fnv1a(hash: &mut u64, bytes: &[u8]) {
    for &b in bytes {
        *hash ^= b as u64;
        *hash = hash.wrapping_mul(0x0100_0000_01b3);
    }
}

/// Hash of every channel of an EXR, decoded to f32, in channel-name order.
fn exr_hash(path: &Path) -> String {
    let image = exr::prelude::read_all_flat_layers_from_file(path).expect("read EXR");
    let mut channels: Vec<(String, Vec<f32>)> = image
        .layer_data
        .iter()
        .flat_map(|l| l.channel_data.list.iter())
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect();
    channels.sort_by(|a, b| a.0.cmp(&b.0));
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for (name, values) in &channels {
        fnv1a(&mut h, name.as_bytes());
        for v in values {
            fnv1a(&mut h, &v.to_bits().to_le_bytes());
        }
    }
    format!("{h:016x}")
}

/// A fog layer (a medium bounded by a mesh without a surface) over a white floor, lit by
/// a point light: the medium segment, null surfaces and medium NEE in every integrator.
fn fog_scene(dir: &Path) -> PathBuf {
    let mut g = GltfBuilder::new();
    fog_layer(&mut g);
    g.camera([0.0, 2.5, 2.0], look_rotation([0.0, -2.5, -2.0]), 0.6);
    g.write(dir, "fog.gltf")
}

/// The scenes: the bundled ones, loader files with alpha, textures and normal maps, and fog.
fn scenes(dir: &Path) -> Vec<(&'static str, PathBuf)> {
    let r = root();
    vec![
        ("cornell_box", r.join("scenes/cornell_box.gltf")),
        ("door_ajar", r.join("scenes/door_ajar.gltf")),
        ("glass_caustic", r.join("scenes/glass_caustic.gltf")),
        ("hdri_sky", r.join("scenes/hdri_sky.gltf")),
        ("many_lights", r.join("scenes/many_lights.gltf")),
        ("subsurface", r.join("scenes/subsurface.gltf")),
        ("alpha_modes", r.join("tests/data/alpha_modes.gltf")),
        ("pbr_textures", r.join("tests/data/pbr_textures.gltf")),
        ("normal_map_no_tangents", r.join("tests/data/normal_map_no_tangents.gltf")),
        ("lights_punctual", r.join("tests/data/lights_punctual.gltf")),
        ("fog", fog_scene(dir)),
    ]
}

/// Each integrator's flags: a few samples, few photons, one thread.
const INTEGRATORS: [(&str, &[&str]); 4] = [
    ("path", &["--integrator", "path", "--spp", "4"]),
    ("bdpt", &["--integrator", "bdpt", "--spp", "4"]),
    ("photon", &["--integrator", "photon", "--spp", "2", "--photons", "20000", "--caustic-photons", "20000"]),
    ("sppm", &["--integrator", "sppm", "--sppm-iterations", "3"]),
];

fn checksum_file() -> PathBuf {
    root().join("tests/golden/checksums.txt")
}

/// Reads `scene integrator hash` lines (comments and blank lines skipped).
fn read_checksums(path: &Path) -> BTreeMap<(String, String), String> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    text.lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            assert_eq!(f.len(), 3, "bad line in {}: {l}", path.display());
            ((f[0].to_string(), f[1].to_string()), f[2].to_string())
        })
        .collect()
}

/// Writes the new checksums below the existing header comments.
fn bless(path: &Path, sums: &BTreeMap<(String, String), String>) {
    let old = std::fs::read_to_string(path).unwrap_or_default();
    let mut text: String = old.lines().take_while(|l| l.starts_with('#')).map(|l| format!("{l}\n")).collect();
    for ((s, i), h) in sums {
        text.push_str(&format!("{s} {i} {h}\n"));
    }
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, text).unwrap();
}

#[test]
fn images_match_their_checksums() {
    let dir = temp_dir();
    let mut sums = BTreeMap::new();
    for (name, scene) in scenes(dir.path()) {
        for (integrator, flags) in INTEGRATORS {
            let out = dir.path().join(format!("{name}_{integrator}.exr"));
            let mut args = vec![
                "render",
                scene.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
                "--resolution",
                "32x24",
                "--threads",
                "1",
                "--seed",
                "7",
                "--progress",
                "none",
            ];
            args.extend_from_slice(flags);
            let r = run(&args, LIMIT);
            assert_eq!(r.code, Some(0), "{name} {integrator}: {}", r.stderr);
            sums.insert((name.to_string(), integrator.to_string()), exr_hash(&out));
        }
    }
    let path = checksum_file();
    if std::env::var_os("CAUSTIC_GOLDEN_BLESS").is_some() {
        bless(&path, &sums);
        return;
    }
    let expected = read_checksums(&path);
    let mut differ = Vec::new();
    for (key, h) in &sums {
        match expected.get(key) {
            Some(e) if e == h => {}
            Some(e) => differ.push(format!("{} {}: {} (expected {})", key.0, key.1, h, e)),
            None => differ.push(format!("{} {}: {} (no checksum recorded)", key.0, key.1, h)),
        }
    }
    for key in expected.keys().filter(|k| !sums.contains_key(*k)) {
        differ.push(format!("{} {}: recorded but not rendered", key.0, key.1));
    }
    assert!(
        differ.is_empty(),
        "{} of {} golden images changed (re-bless with CAUSTIC_GOLDEN_BLESS=1 only for an intended \
         change, and say why in the file's header):\n{}",
        differ.len(),
        sums.len(),
        differ.join("\n")
    );
}
