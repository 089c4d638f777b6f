//! Mutation fuzzing of the loader and the render pipeline on stable Rust:
//! `cargo run --release --example fuzz_loader -- [SECONDS] [SEED]` (defaults 600, 1).
//! Seeds are the good files of `tests/data/manifest.json`; every finding (a panic, a
//! non-finite pixel) is written to `tests/data/fuzz_findings/` to become a regression case.

use caustic::fuzz::{Outcome, Rng, mutate, run_one};
use std::time::{Duration, Instant};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seconds: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(600);
    let seed: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let manifest: Vec<serde_json::Value> =
        serde_json::from_slice(&std::fs::read(data.join("manifest.json")).expect("manifest")).expect("json");
    let seeds: Vec<(Vec<u8>, std::path::PathBuf)> = manifest
        .iter()
        .filter(|e| e["expect"] == "ok")
        .filter_map(|e| {
            let p = data.join(e["file"].as_str()?);
            Some((std::fs::read(&p).ok()?, p.parent()?.to_path_buf()))
        })
        .collect();
    std::panic::set_hook(Box::new(|_| {}));
    let mut rng = Rng::new(seed);
    let start = Instant::now();
    let (mut execs, mut rendered, mut refused, mut findings, mut caught) = (0u64, 0u64, 0u64, 0u64, 0u64);
    let out_dir = data.join("fuzz_findings");
    while start.elapsed() < Duration::from_secs(seconds) {
        let (input, base) = &seeds[rng.below(seeds.len())];
        let m = mutate(input, &mut rng);
        execs += 1;
        match run_one(&m, base) {
            Outcome::Rendered => rendered += 1,
            Outcome::Refused => refused += 1,
            Outcome::CaughtPanic(what) => {
                caught += 1;
                if caught <= 20 {
                    std::fs::create_dir_all(&out_dir).ok();
                    let name = format!("caught_{seed}_{execs}.gltf");
                    std::fs::write(out_dir.join(&name), &m).ok();
                    println!(
                        "caught parser panic: {what} -> tests/data/fuzz_findings/{name} (resolve from tests/data)"
                    );
                }
            }
            Outcome::Finding(what) => {
                findings += 1;
                std::fs::create_dir_all(&out_dir).ok();
                let name = format!("finding_{seed}_{execs}.gltf");
                std::fs::write(out_dir.join(&name), &m).ok();
                println!("finding: {what} -> tests/data/fuzz_findings/{name}");
            }
        }
    }
    println!(
        "{execs} executions in {:.0} s ({:.0}/s): {rendered} rendered, {refused} refused, {caught} parser panics caught by the guard, {findings} findings",
        start.elapsed().as_secs_f64(),
        execs as f64 / start.elapsed().as_secs_f64()
    );
}
