//! Resource limits: settings or scenes whose estimated memory exceeds the budget
//! (`--memory-limit`, by default 90 % of the available memory) are refused before the
//! big buffers are allocated — exit 7, an error message naming the item, no output
//! file and no temporary file left — and a budget that fits lets the same render run.

mod common;

use base64::Engine;
use common::{GltfBuilder, Run, root, run, temp_dir};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Hang guard: a refused render must not start rendering (these settings would take
/// hours or be killed by the kernel); the bound only catches that, it measures nothing.
const LIMIT: Duration = Duration::from_secs(30);

const MEMORY: i32 = caustic::error::exit_code::MEMORY;

fn cornell() -> String {
    root().join("scenes/cornell_box.gltf").to_str().unwrap().to_string()
}

/// Renders with `extra` flags into a fresh directory; returns the run and the directory.
fn render(scene: &str, extra: &[&str]) -> (Run, tempfile::TempDir) {
    let dir = temp_dir();
    let out = dir.path().join("out.exr");
    let mut args = vec!["render", scene, "-o", out.to_str().unwrap(), "--progress", "json"];
    args.extend_from_slice(extra);
    (run(&args, LIMIT), dir)
}

/// The run was refused for memory, naming `what`, and left nothing behind.
fn assert_refused(r: &Run, dir: &Path, what: &[&str]) {
    assert_eq!(r.code, Some(MEMORY), "stderr:\n{}", r.stderr);
    assert!(!r.stderr.contains("panicked"), "{}", r.stderr);
    let msg = r.error_message().expect("a JSON error object").to_lowercase();
    assert!(msg.contains("memory limit"), "{msg}");
    for w in what {
        assert!(msg.contains(&w.to_lowercase()), "message lacks '{w}': {msg}");
    }
    let left: Vec<_> = std::fs::read_dir(dir).unwrap().flatten().map(|e| e.file_name()).collect();
    assert!(left.is_empty(), "files left after a refused render: {left:?}");
}

#[test]
fn huge_resolution_is_refused_by_the_default_budget() {
    // 32768 × 8192 passes the resolution check (≤ 2^28 pixels) but its film needs
    // 268 M pixels × 168 B = 42 GiB: beyond the default budget on any machine that
    // runs these tests (the budget is at most 90 % of its memory).
    let (r, dir) = render(&cornell(), &["--resolution", "32768x8192", "--spp", "1"]);
    assert_refused(&r, dir.path(), &["film", "32768x8192"]);
}

#[test]
fn absurd_photon_counts_are_refused() {
    // 4·10^9 photons × 4 stored × 32 B × 2 ≈ 950 GiB.
    let (r, dir) = render(&cornell(), &["--integrator", "photon", "--photons", "4000000000", "--spp", "1"]);
    assert_refused(&r, dir.path(), &["photon maps", "4000000000"]);
    // 10^10 is beyond the settings' range altogether: a usage error (exit 2).
    let (r, dir) = render(&cornell(), &["--integrator", "photon", "--photons", "10000000000", "--spp", "1"]);
    assert_eq!(r.code, Some(caustic::error::exit_code::USAGE), "{}", r.stderr);
    assert!(r.error_message().unwrap().contains("photon counts"));
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    // The same through `caustic photons`.
    let dir = temp_dir();
    let map = dir.path().join("m.pm");
    let r = run(
        &["photons", &cornell(), "-o", map.to_str().unwrap(), "--photons", "4000000000", "--progress", "json"],
        LIMIT,
    );
    assert_refused(&r, dir.path(), &["photon maps"]);
}

#[test]
fn sppm_state_counts_against_the_budget() {
    // 1024² pixels: film 168 MiB + SPPM state + two photons per pixel per iteration;
    // a 64 MiB budget refuses it, naming the film (the first item over).
    let (r, dir) = render(&cornell(), &["--integrator", "sppm", "--resolution", "1024x1024", "--memory-limit", "64M"]);
    assert_refused(&r, dir.path(), &["film", "set by --memory-limit"]);
    // With the film allowed, SPPM's own state is what goes over: 100 MiB covers
    // the 168 B/pixel film of 512² (42 MiB) but not the per-pixel state on top.
    let per_pixel = caustic::integrator::photon::sppm::bytes_per_pixel(false, false);
    let pixels = 512u64 * 512;
    let film = pixels * caustic::memory::film_bytes_per_pixel();
    let limit = film + 64 * 1024 + pixels * per_pixel / 2;
    let limit_s = limit.to_string();
    let (r, dir) = render(&cornell(), &["--integrator", "sppm", "--resolution", "512x512", "--memory-limit", &limit_s]);
    assert_refused(&r, dir.path(), &["sppm's per-pixel state"]);
}

#[test]
fn a_budget_that_fits_renders() {
    let (r, dir) = render(&cornell(), &["--resolution", "16x16", "--spp", "1", "--memory-limit", "64M"]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(dir.path().join("out.exr").exists());
}

#[test]
fn bad_limits_are_usage_errors() {
    for bad in ["lots", "0", "-1G", "150%", "0%"] {
        let flag = format!("--memory-limit={bad}");
        let (r, _dir) = render(&cornell(), &[&flag]);
        assert_eq!(r.code, Some(caustic::error::exit_code::USAGE), "{bad}: {}", r.stderr);
        assert!(r.error_message().unwrap().contains("--memory-limit"), "{bad}");
    }
}

/// CRC-32 (PNG's), to write a PNG header by hand.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xFFFF_FFFFu32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
        }
    }
    !c
}

/// A PNG whose header declares `w`×`h` RGBA8 texels and that holds no texels.
fn png_header_only(w: u32, h: u32) -> Vec<u8> {
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut chunk = |kind: &[u8], data: &[u8]| {
        png.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let mut body = kind.to_vec();
        body.extend_from_slice(data);
        png.extend_from_slice(&body);
        png.extend_from_slice(&crc32(&body).to_be_bytes());
    };
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&w.to_be_bytes());
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[8, 6, 0, 0, 0]); // 8-bit RGBA
    chunk(b"IHDR", &ihdr);
    chunk(b"IDAT", &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01]); // zlib of nothing
    chunk(b"IEND", &[]);
    png
}

/// A small scene whose floor has a base-colour texture from `png`.
fn textured_scene(dir: &Path, png: &[u8]) -> PathBuf {
    let mut b = GltfBuilder::new();
    let m = b.material(json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}));
    b.cube([-1.0, -1.0, -1.0], [1.0, 0.0, 1.0], m);
    b.camera([0.0, 1.0, 4.0], [0.0, 0.0, 0.0, 1.0], 0.8);
    b.punctual(json!({"type": "point", "intensity": 100.0}), [0.0, 3.0, 0.0], [0.0, 0.0, 0.0, 1.0]);
    let path = b.write(dir, "textured.gltf");
    let mut doc: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let uri = format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(png));
    doc["images"] = json!([{ "uri": uri }]);
    doc["textures"] = json!([{ "source": 0 }]);
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

#[test]
fn a_png_header_declaring_a_huge_image_is_refused_before_decoding() {
    let scene_dir = temp_dir();
    // 16000² is within the per-side cap (16384): only the budget stands in the way.
    let scene = textured_scene(scene_dir.path(), &png_header_only(16_000, 16_000));
    let s = scene.to_str().unwrap();
    let (r, dir) = render(s, &["--resolution", "8x8", "--spp", "1", "--memory-limit", "512M"]);
    assert_refused(&r, dir.path(), &["texture image 0", "16000×16000"]);
    // `info` loads textures too and honours the same flag.
    let i = run(&["info", s, "--memory-limit", "512M"], LIMIT);
    assert_eq!(i.code, Some(MEMORY), "{}", i.stderr);
    // Within a budget that fits, the file is what it is: a PNG without data (exit 3).
    let (r, dir) = render(s, &["--resolution", "8x8", "--spp", "1", "--memory-limit", "8G"]);
    assert_eq!(r.code, Some(caustic::error::exit_code::BAD_SCENE), "{}", r.stderr);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    // And a real 4×4 texture under a small budget renders.
    let mut small = Vec::new();
    image::RgbaImage::from_pixel(4, 4, image::Rgba([200, 100, 50, 255]))
        .write_to(&mut std::io::Cursor::new(&mut small), image::ImageFormat::Png)
        .unwrap();
    let ok = textured_scene(scene_dir.path(), &small);
    let (r, _dir) = render(ok.to_str().unwrap(), &["--resolution", "8x8", "--spp", "1", "--memory-limit", "64M"]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
}

#[test]
fn a_tiny_file_declaring_billions_of_vertices_is_refused() {
    // A sparse POSITION accessor needs no buffer for its base values: 38 bytes of JSON
    // declare 2·10^9 vertices (144 GB once flattened).
    let dir = temp_dir();
    let mut b = GltfBuilder::new();
    b.cube([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], 0);
    b.material(json!({}));
    b.camera([0.0, 0.0, 4.0], [0.0, 0.0, 0.0, 1.0], 0.8);
    let path = b.write(dir.path(), "sparse.gltf");
    let mut doc: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let n = 2_000_000_000u64;
    doc["accessors"][0] = json!({
        "componentType": 5126, "count": n, "type": "VEC3", "min": [-1, -1, -1], "max": [1, 1, 1],
        "sparse": {"count": 1, "indices": {"bufferView": 1, "componentType": 5125},
                   "values": {"bufferView": 0}}
    });
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let (r, out_dir) = render(path.to_str().unwrap(), &["--resolution", "8x8", "--spp", "1", "--memory-limit", "8G"]);
    assert_refused(&r, out_dir.path(), &["the mesh", "2000000000 vertices"]);
}
