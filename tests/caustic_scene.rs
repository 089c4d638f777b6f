//! The glass caustic scene (`scenes/glass_caustic.gltf`): path tracing and SPPM agree in
//! the caustic region (the floor under the clear sphere) and over the whole image.
//!
//! Bound: |SPPM(N) - PT| ≤ 5σ + b(N), σ from two seeds of each renderer (block variance of
//! the seed differences, as the Blender agreement tests do), and b(N) SPPM's remaining
//! bias. With α = 2/3 the radius shrinks as r² ∝ N^(-1/3), and the density-estimation bias
//! is ∝ r², so b(N) = Δ / (4^(1/3) - 1) where Δ = SPPM(N/4) - SPPM(N) is measured.

mod common;

use common::{root, run, temp_dir};
use std::time::Duration;

const W: usize = 64;
const H: usize = 48;

fn render(integrator: &str, seed: u32, extra: &[&str]) -> Vec<f64> {
    let dir = temp_dir();
    let out = dir.path().join("o.exr");
    let scene = root().join("scenes/glass_caustic.gltf");
    let seed = seed.to_string();
    let res = format!("{W}x{H}");
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--resolution",
        &res,
        "--integrator",
        integrator,
        "--seed",
        &seed,
        "--progress",
        "none",
    ];
    args.extend_from_slice(extra);
    let r = run(&args, Duration::from_secs(300));
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    caustic::output::read_combined(&out).unwrap().2.iter().map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0).collect()
}

/// Mean over a region and the variance of that mean from two seeds (8×8-block sums of
/// the seed difference: var(mean of one) = Σ D_k² / (2 P²), the two-seed mean halves it).
fn mean_var(a: &[f64], b: &[f64], x0: usize, y0: usize, x1: usize, y1: usize) -> (f64, f64) {
    let p = ((x1 - x0) * (y1 - y0)) as f64;
    let mut sum = 0.0;
    let mut var = 0.0;
    for by in (y0..y1).step_by(8) {
        for bx in (x0..x1).step_by(8) {
            let mut d = 0.0;
            for y in by..(by + 8).min(y1) {
                for x in bx..(bx + 8).min(x1) {
                    d += a[y * W + x] - b[y * W + x];
                    sum += a[y * W + x] + b[y * W + x];
                }
            }
            var += d * d;
        }
    }
    (sum / (2.0 * p), var / (2.0 * p * p) / 2.0)
}

#[test]
fn sppm_agrees_with_path_tracing_on_caustics() {
    let pt = [render("path", 1, &["--spp", "512"]), render("path", 2, &["--spp", "512"])];
    let n = 256;
    let sppm = [
        render("sppm", 1, &["--sppm-iterations", &n.to_string()]),
        render("sppm", 2, &["--sppm-iterations", &n.to_string()]),
    ];
    let coarse = [
        render("sppm", 3, &["--sppm-iterations", &(n / 4).to_string()]),
        render("sppm", 4, &["--sppm-iterations", &(n / 4).to_string()]),
    ];
    // The caustic of the clear sphere falls on the floor in the lower left of the frame.
    for (name, (x0, y0, x1, y1)) in [("whole image", (0, 0, W, H)), ("caustic region", (8, 24, 32, 48))] {
        let (m_pt, v_pt) = mean_var(&pt[0], &pt[1], x0, y0, x1, y1);
        let (m_s, v_s) = mean_var(&sppm[0], &sppm[1], x0, y0, x1, y1);
        let (m_c, v_c) = mean_var(&coarse[0], &coarse[1], x0, y0, x1, y1);
        let delta = (m_c - m_s).abs() + 5.0 * (v_c + v_s).sqrt();
        let bias = delta / (4f64.powf(1.0 / 3.0) - 1.0);
        let sigma = (v_pt + v_s).sqrt();
        let bound = 5.0 * sigma + bias;
        eprintln!(
            "{name}: PT {m_pt:.5} SPPM({n}) {m_s:.5} SPPM({}) {m_c:.5} sigma {sigma:.2e} bias bound {bias:.2e}",
            n / 4
        );
        assert!(m_pt > 0.01, "{name} must be lit");
        assert!((m_s - m_pt).abs() <= bound, "{name}: SPPM {m_s} vs PT {m_pt} (bound {bound})");
    }
}
