//! A bounded run of the loader fuzzer (`src/fuzz.rs`) with a fixed seed: 400 mutants of
//! the good corpus files must each render finite pixels or be refused with an error —
//! no panic (not even one the loader's guard catches), no NaN. Long runs: `cargo run --release --example fuzz_loader -- 600`.

use caustic::fuzz::{Outcome, Rng, mutate, run_one};

#[test]
fn mutants_never_panic() {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let manifest: Vec<serde_json::Value> =
        serde_json::from_slice(&std::fs::read(data.join("manifest.json")).unwrap()).unwrap();
    let seeds: Vec<(Vec<u8>, std::path::PathBuf)> = manifest
        .iter()
        .filter(|e| e["expect"] == "ok")
        .map(|e| {
            let p = data.join(e["file"].as_str().unwrap());
            (std::fs::read(&p).unwrap(), p.parent().unwrap().to_path_buf())
        })
        .collect();
    let mut rng = Rng::new(2026);
    let (mut rendered, mut refused) = (0, 0);
    let mut findings = Vec::new();
    for i in 0..400 {
        let (input, base) = &seeds[rng.below(seeds.len())];
        let m = mutate(input, &mut rng);
        match run_one(&m, base) {
            Outcome::Rendered => rendered += 1,
            Outcome::Refused => refused += 1,
            // A parser panic the loader's guard turned into an error is safe for users
            // (exit 3), but the loader now checks what the glTF crate panics on first
            // (3 fuzz runs, README "Fuzzing"): one coming back is a regression.
            Outcome::CaughtPanic(what) => findings.push(format!("mutant {i}: guarded parser panic: {what}")),
            Outcome::Finding(what) => findings.push(format!("mutant {i}: {what}")),
        }
    }
    eprintln!("{rendered} rendered, {refused} refused, {} findings", findings.len());
    assert!(findings.is_empty(), "{}", findings.join("\n"));
    assert!(rendered > 20 && refused > 20, "the mutations should both pass and break files");
}
