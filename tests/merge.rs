//! Chunks and `caustic merge` (issue 23): renders of disjoint sample ranges
//! (`--sample-offset`, `--chunk`) merge into exactly the single render of all the samples,
//! in any order and grouping, for every integrator whose samples are independent (path
//! tracer, BDPT with its light-tracing splats, Jensen photon mapping with its shared map);
//! bad merges fail with a clear error and write nothing.

mod common;

use common::{exr_channel_bits, root, run, temp_dir};
use std::path::Path;
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);

/// Asserts two EXRs hold the same channels bit for bit.
fn assert_same(a: &Path, b: &Path) {
    let (ca, cb) = (exr_channel_bits(a), exr_channel_bits(b));
    assert_eq!(ca.iter().map(|c| &c.0).collect::<Vec<_>>(), cb.iter().map(|c| &c.0).collect::<Vec<_>>());
    for ((name, x), (_, y)) in ca.iter().zip(&cb) {
        let differ = x.iter().zip(y).filter(|(p, q)| p != q).count();
        assert_eq!(
            differ,
            0,
            "{name}: {differ} of {} values differ between {} and {}",
            x.len(),
            a.display(),
            b.display()
        );
    }
}

/// Renders the Cornell box with `extra` flags to `out`; asserts success.
fn render(out: &Path, extra: &[&str]) {
    let scene = root().join("scenes/cornell_box.gltf");
    let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--resolution", "24x18"];
    args.extend_from_slice(extra);
    let r = run(&args, LIMIT);
    assert_eq!(r.code, Some(0), "render {extra:?} failed: {}", r.stderr);
}

/// Merges `inputs` into `out` with `extra` flags; returns the run.
fn merge(inputs: &[&Path], out: &Path, extra: &[&str]) -> common::Run {
    let mut args = vec!["merge"];
    args.extend(inputs.iter().map(|p| p.to_str().unwrap()));
    args.extend_from_slice(&["-o", out.to_str().unwrap(), "--progress", "json"]);
    args.extend_from_slice(extra);
    run(&args, LIMIT)
}

/// Single render of spp 8 against chunks 0..3 + 3..8 and against three chunks merged in a
/// shuffled order, with different thread counts per chunk (the sums are order-free).
fn chunks_equal_single(settings: &[&'static str]) {
    let dir = temp_dir();
    let p = |n: &str| dir.path().join(n);
    let with = |more: &[&'static str]| -> Vec<&'static str> { [settings, more].concat() };
    render(&p("single.exr"), &with(&["--spp", "8", "--threads", "2"]));
    render(&p("a.exr"), &with(&["--spp", "3", "--threads", "1", "--chunk"]));
    render(&p("b.exr"), &with(&["--spp", "5", "--sample-offset", "3", "--threads", "2", "--chunk"]));
    let r = merge(&[&p("b.exr"), &p("a.exr")], &p("two.exr"), &[]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert_same(&p("single.exr"), &p("two.exr"));
    let s = r.summary().expect("summary");
    assert_eq!(s["spp"], 8);
    assert_eq!(s["samples"], serde_json::json!([[0, 3], [3, 8]]));

    render(&p("c0.exr"), &with(&["--spp", "2", "--chunk"]));
    render(&p("c1.exr"), &with(&["--spp", "3", "--sample-offset", "2", "--threads", "1", "--chunk"]));
    render(&p("c2.exr"), &with(&["--spp", "3", "--sample-offset", "5", "--chunk"]));
    let r = merge(&[&p("c2.exr"), &p("c0.exr"), &p("c1.exr")], &p("three.exr"), &[]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert_same(&p("single.exr"), &p("three.exr"));

    // A merged chunk merges again: (c0 + c2) + c1.
    let r = merge(&[&p("c0.exr"), &p("c2.exr")], &p("partial.exr"), &["--chunk"]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let r = merge(&[&p("c1.exr"), &p("partial.exr")], &p("again.exr"), &[]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert_same(&p("single.exr"), &p("again.exr"));
}

#[test]
fn path_tracer_chunks_merge_exactly() {
    chunks_equal_single(&["--integrator", "path"]);
}

/// The light and data passes travel in chunks as sums (the first-sample ones, Position and
/// the indices, from the chunk holding sample 0), so that merged passes are the single
/// render's bit for bit.
#[test]
fn passes_merge_exactly() {
    chunks_equal_single(&[
        "--passes",
        "diffuse_direct,diffuse_indirect,glossy_color,transmission_direct,emit,environment,volume_direct,\
         mist,position,uv,ambient_occlusion,object_index,material_index,vector,z,normal,denoising_albedo",
    ]);
}

#[test]
fn bdpt_chunks_merge_exactly() {
    // A crop window too: chunks keep the window and merge within it.
    chunks_equal_single(&["--integrator", "bdpt", "--max-depth", "4", "--crop", "4,2,20,14"]);
}

/// VCM's radius follows the global iteration (the sample index), so chunks take exactly
/// the merges a single render takes at those samples.
#[test]
fn vcm_chunks_merge_exactly() {
    chunks_equal_single(&["--integrator", "vcm", "--max-depth", "4"]);
}

#[test]
fn photon_mapping_chunks_share_the_map_and_merge_exactly() {
    // Every chunk traces the same maps from the seed: the frame's map is shared.
    chunks_equal_single(&["--integrator", "photon", "--photons", "3000", "--caustic-photons", "1000"]);
}

/// SPPM chunks are independent runs (docs/contract.md): the merge is their mean weighted
/// by iterations, with the iterations of both.
#[test]
fn sppm_chunks_merge_as_weighted_mean() {
    let dir = temp_dir();
    let p = |n: &str| dir.path().join(n);
    let sppm = ["--integrator", "sppm", "--sppm-photons", "2000", "--chunk"];
    render(&p("a.exr"), &[&sppm[..], &["--sppm-iterations", "2"]].concat());
    render(&p("b.exr"), &[&sppm[..], &["--sppm-iterations", "6", "--sample-offset", "2"]].concat());
    let r = merge(&[&p("a.exr"), &p("b.exr")], &p("m.exr"), &[]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let read = |n: &str| caustic::output::read_combined(&p(n)).unwrap().2;
    let (a, b, m) = (read("a.exr"), read("b.exr"), read("m.exr"));
    for i in 0..m.len() {
        for c in 0..4 {
            let want = (2.0 * a[i][c] as f64 + 6.0 * b[i][c] as f64) / 8.0;
            // The sums are exact (mean × n in f64, then fixed point); the only rounding is
            // the final f32 of the mean: half an ulp, 2^-24 relative.
            assert!((m[i][c] as f64 - want).abs() <= want.abs() * 2f64.powi(-23) + 1e-30, "pixel {i} channel {c}");
        }
    }
    let spp = caustic_sample_counts(&p("m.exr"));
    assert!(spp.iter().all(|&n| n == 8.0), "iterations of both chunks");
}

/// The Debug Sample Count channel.
fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

fn caustic_sample_counts(path: &Path) -> Vec<f32> {
    exr_channel_bits(path)
        .into_iter()
        .find(|c| c.0 == "Debug Sample Count.X")
        .expect("sample count")
        .1
        .into_iter()
        .map(f32::from_bits)
        .collect()
}

#[test]
fn bad_merges_fail_clearly_and_write_nothing() {
    let dir = temp_dir();
    let p = |n: &str| dir.path().join(n);
    render(&p("a.exr"), &["--spp", "2", "--chunk"]);
    render(&p("b.exr"), &["--spp", "2", "--sample-offset", "2", "--chunk", "--seed", "9"]);
    render(&p("small.exr"), &["--spp", "2", "--sample-offset", "2", "--chunk", "--crop", "0,0,20,18"]);
    render(&p("overlap.exr"), &["--spp", "2", "--sample-offset", "1", "--chunk"]);
    render(&p("plain.exr"), &["--spp", "2", "--sample-offset", "2"]);
    render(&p("bdpt.exr"), &["--spp", "2", "--sample-offset", "2", "--chunk", "--integrator", "bdpt"]);
    let bytes = std::fs::read(p("a.exr")).unwrap();
    std::fs::write(p("cut.exr"), &bytes[..bytes.len() / 2]).unwrap();
    std::fs::write(p("text.exr"), b"not an image").unwrap();
    // A chunk of an older layout (a build before the shader AOV and Cryptomatte sums): the
    // same file with its causticChunk JSON saying version 2.
    let info_at = find(&bytes, b"\"version\":").expect("causticChunk holds a version");
    let mut old = bytes.clone();
    let digits = info_at + b"\"version\":".len();
    assert_eq!(old[digits], b'0' + caustic::chunk::CHUNK_VERSION as u8);
    old[digits] = b'2';
    std::fs::write(p("old.exr"), &old).unwrap();
    let cases: [(&str, i32, &str); 8] = [
        ("old.exr", 2, "layout version 2"),
        ("b.exr", 2, "seeds differ"),
        ("small.exr", 2, "sizes differ"),
        ("overlap.exr", 2, "overlap"),
        ("plain.exr", 2, "not a Caustic chunk"),
        ("bdpt.exr", 2, "render settings differ"),
        ("cut.exr", 4, "not a readable OpenEXR"),
        ("text.exr", 4, "not a readable OpenEXR"),
    ];
    for (other, code, says) in cases {
        let out = p("out.exr");
        let r = merge(&[&p("a.exr"), &p(other)], &out, &[]);
        assert_eq!(r.code, Some(code), "{other}: {}", r.stderr);
        let msg = r.error_message().unwrap_or_default();
        assert!(msg.contains(says), "{other}: {msg}");
        assert!(!out.exists(), "{other}: nothing may be written");
    }
    let scene = root().join("scenes/cornell_box.gltf");
    let out = p("y.exr");
    let r =
        run(&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--sample-offset", "4294967295"], LIMIT);
    assert_eq!(r.code, Some(2), "{}", r.stderr);
}

/// `--photon-seed` chooses the map's seed alone: equal to the seed it is the default map,
/// another seed gives another map (an independent chunk); without Jensen it is refused.
#[test]
fn photon_seed_picks_the_map_only() {
    let dir = temp_dir();
    let p = |n: &str| dir.path().join(n);
    let jensen =
        ["--integrator", "photon", "--photons", "3000", "--caustic-photons", "1000", "--spp", "2", "--seed", "4"];
    render(&p("default.exr"), &jensen);
    render(&p("same.exr"), &[&jensen[..], &["--photon-seed", "4"]].concat());
    render(&p("other.exr"), &[&jensen[..], &["--photon-seed", "5"]].concat());
    assert_same(&p("default.exr"), &p("same.exr"));
    assert_ne!(exr_channel_bits(&p("default.exr")), exr_channel_bits(&p("other.exr")));
    let scene = root().join("scenes/cornell_box.gltf");
    let out = p("x.exr");
    let r = run(&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--photon-seed", "1"], LIMIT);
    assert_eq!(r.code, Some(2), "{}", r.stderr);
}

/// A chunk's identity covers the files the glTF reads, not only the glTF: chunks rendered
/// before and after its `.bin` changed (one vertex moved) are refused, while two chunks of the
/// unchanged files merge.
#[test]
fn chunks_of_a_changed_buffer_are_refused() {
    let dir = temp_dir();
    for f in ["cornell_box.gltf", "cornell_box.bin"] {
        std::fs::copy(root().join("scenes").join(f), dir.path().join(f)).unwrap();
    }
    let scene = dir.path().join("cornell_box.gltf");
    let chunk = |name: &str, offset: &str| {
        let out = dir.path().join(name);
        let r = run(
            &[
                "render",
                scene.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
                "--resolution",
                "12x9",
                "--spp",
                "2",
                "--chunk",
                "--sample-offset",
                offset,
            ],
            LIMIT,
        );
        assert_eq!(r.code, Some(0), "{}", r.stderr);
        out
    };
    let a = chunk("a.exr", "0");
    let b = chunk("b.exr", "2");
    let ok = merge(&[&a, &b], &dir.path().join("ab.exr"), &[]);
    assert_eq!(ok.code, Some(0), "{}", ok.stderr);
    // Nudge the first float of the buffer (a position) by one ulp.
    let bin = dir.path().join("cornell_box.bin");
    let mut bytes = std::fs::read(&bin).unwrap();
    let x = f32::from_le_bytes(bytes[0..4].try_into().unwrap());
    bytes[0..4].copy_from_slice(&f32::from_bits(x.to_bits() + 1).to_le_bytes());
    std::fs::write(&bin, bytes).unwrap();
    let c = chunk("c.exr", "4");
    let out = dir.path().join("ac.exr");
    let bad = merge(&[&a, &c], &out, &[]);
    assert_eq!(bad.code, Some(2), "{}", bad.stderr);
    assert!(bad.stderr.contains("scenes"), "the error names the scenes: {}", bad.stderr);
    assert!(!out.exists(), "nothing written");
}
