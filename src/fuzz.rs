//! A mutation fuzzer for the loader that runs on stable Rust (no libFuzzer): it mutates
//! valid glTF/GLB files (byte flips, truncation, splices, JSON numbers replaced by extreme
//! values, duplicated or deleted spans) and runs each mutant through the whole pipeline —
//! load, BVH, a 4×4 one-sample render — on this thread. Whatever fails must fail as an
//! `Error`; a panic (even one the loader's guard turns into an error), a non-finite pixel,
//! or a hang beyond the time limit is a finding. Used by `examples/fuzz_loader.rs` (long
//! runs) and by a bounded test.

use crate::accel::Accel;
use crate::film::Filter;
use crate::integrator::path::PathIntegrator;
use crate::integrator::{Integrator, SceneContext};
use crate::render::{RenderJob, render};
use crate::scene::camera::CameraRays;
use std::path::Path;
use std::sync::atomic::AtomicBool;

/// A small xorshift generator: the fuzzer must be reproducible from its seed.
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1)
    }
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    /// Uniform in 0..n.
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n.max(1) as u64) as usize
    }
}

/// Values that break naive code.
const EXTREMES: &[&str] =
    &["0", "-1", "1e38", "-1e38", "4294967295", "2147483648", "1e-45", "0.0", "99999999999", "3.4e38", "-0"];

/// Memory budget of one mutant's load: far above what the seed files need (< 1 MiB).
const FUZZ_MEMORY_LIMIT: u64 = 1 << 30;

/// One mutant of `input`.
pub fn mutate(input: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut v = input.to_vec();
    let rounds = 1 + rng.below(3);
    for _ in 0..rounds {
        if v.is_empty() {
            v.push(b'{');
        }
        match rng.below(7) {
            0 => {
                let i = rng.below(v.len());
                v[i] ^= 1 << rng.below(8);
            }
            1 => {
                let n = rng.below(v.len());
                v.truncate(n);
            }
            2 => {
                let i = rng.below(v.len());
                let j = (i + rng.below(64)).min(v.len());
                v.drain(i..j);
            }
            3 => {
                let i = rng.below(v.len());
                let j = (i + rng.below(64)).min(v.len());
                let span = v[i..j].to_vec();
                let k = rng.below(v.len());
                v.splice(k..k, span);
            }
            _ => {
                // Replace a JSON number with an extreme value.
                let digits: Vec<usize> = (0..v.len()).filter(|&i| v[i].is_ascii_digit()).collect();
                if digits.is_empty() {
                    continue;
                }
                let mut i = digits[rng.below(digits.len())];
                while i > 0 && (v[i - 1].is_ascii_digit() || v[i - 1] == b'.' || v[i - 1] == b'-') {
                    i -= 1;
                }
                let mut j = i;
                while j < v.len() && (v[j].is_ascii_digit() || v[j] == b'.' || v[j] == b'-' || v[j] == b'e') {
                    j += 1;
                }
                let value = EXTREMES[rng.below(EXTREMES.len())].as_bytes().to_vec();
                v.splice(i..j, value);
            }
        }
    }
    v
}

/// What one mutant did.
#[derive(Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Loaded and rendered finite pixels.
    Rendered,
    /// Refused with an error.
    Refused,
    /// Refused, but through a panic inside the glTF parser that the loader's guard caught
    /// and turned into an error: safe for users, still worth fixing at its source.
    CaughtPanic(String),
    /// A finding: the message says what.
    Finding(String),
}

/// Runs one input through load, BVH and a tiny render.
pub fn run_one(bytes: &[u8], base_dir: &Path) -> Outcome {
    // A mutant may declare a mesh or texture far larger than its bytes (a sparse
    // accessor's count, shared subtrees): the budget must refuse it, as for users.
    let budget = crate::memory::MemoryBudget::bytes(FUZZ_MEMORY_LIMIT);
    let scene = match crate::scene::gltf::load_bytes(bytes, base_dir, "fuzz", &budget) {
        Ok(s) => s,
        Err(e) => {
            let msg = e.to_string();
            return if msg.contains("parser failed") { Outcome::CaughtPanic(msg) } else { Outcome::Refused };
        }
    };
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let tris: Vec<[glam::Vec3; 3]> =
            scene.mesh.triangles.iter().map(|t| t.map(|i| scene.mesh.positions[i as usize])).collect();
        let accel = Accel::build(&tris);
        let ctx = SceneContext::new(&scene, &accel);
        let camera = CameraRays::new(&scene.cameras[0], 4, 4);
        let job = RenderJob {
            width: 4,
            height: 4,
            window: [0, 0, 4, 4],
            spp: Some(1),
            time_limit: None,
            seed: 0,
            sample_offset: 0,
            filter: Filter::box_filter(1.0),
            adaptive: None,
            passes: crate::passes::ALL.into_iter().collect(),
            data: Default::default(),
            guides: true,
        };
        let integrator = Integrator::Path(PathIntegrator { light_passes: true, ..PathIntegrator::new(4, true) });
        let stop = AtomicBool::new(false);
        render(&ctx, &camera, &integrator, &job, &stop, &|_| {}, &mut |_, _| {})
    }));
    match result {
        Err(_) => Outcome::Finding("panic while rendering a loaded scene".into()),
        Ok(r) if r.image.combined.iter().any(|p| p.iter().any(|c| !c.is_finite())) => {
            Outcome::Finding("non-finite pixel".into())
        }
        Ok(_) => Outcome::Rendered,
    }
}
