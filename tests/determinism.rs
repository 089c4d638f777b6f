//! The same scene, settings and seed give the same EXR file, byte for byte, run after run
//! and for any thread count (docs/contract.md: the film's fixed-point sums make the pixels
//! independent of the thread count; the file's tile order and header attribute order are
//! fixed by `output` and `exr_header`). Farm chunks and checksums of outputs rely on it.

mod common;

use common::{render_image, root, temp_dir};
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);

#[test]
fn same_render_gives_the_same_file() {
    let dir = temp_dir();
    let scene = root().join("scenes/glass_caustic.gltf");
    // 256×128 is 8 tiles of 64×64, which the EXR encoder compresses in parallel (the
    // unordered write this guards against); Cryptomatte adds several header attributes
    // (the unordered hash map); one sample keeps the run short.
    let common = ["--resolution", "256x128", "--spp", "1", "--passes", "cryptomatte_object,cryptomatte_material"];
    let mut files = Vec::new();
    for (i, threads) in ["1", "1", "1", "2"].iter().enumerate() {
        let out = dir.path().join(format!("run{i}.exr"));
        let mut args = common.to_vec();
        args.extend_from_slice(&["--threads", threads]);
        render_image(&scene, &out, &args, LIMIT);
        files.push(std::fs::read(&out).unwrap());
    }
    for (i, f) in files.iter().enumerate().skip(1) {
        assert!(*f == files[0], "run {i} wrote a different file from run 0");
    }
}
