//! Times the per-triangle touching flags (`accel::touching`) against the BVH build on a
//! generated scene: a UV sphere of about `N` triangles (default 1M) resting on a
//! two-triangle floor (its poles are fans of 2 sqrt(N) thin triangles, the grid's worst
//! case), or with `grid` a height field of about `N` triangles (no fans).
//! `cargo run --release --example touching_profile [N] [grid]`.

use caustic::accel::{Accel, touching::touching};
use glam::Vec3;
use std::time::Instant;

fn main() {
    let n: usize = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(1_000_000);
    // rings * segments * 2 ~ n, segments = 2 rings.
    let rings = ((n as f64 / 4.0).sqrt() as u32).max(2);
    let segs = 2 * rings;
    let at = |i: u32, j: u32| {
        let (phi, theta) =
            (i as f32 * std::f32::consts::TAU / segs as f32, j as f32 * std::f32::consts::PI / rings as f32);
        Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), 1.0 + theta.cos())
    };
    let mut tris = Vec::new();
    if std::env::args().nth(2).as_deref() == Some("grid") {
        let k = ((n as f64 / 2.0).sqrt() as u32).max(1);
        let h = |i: u32, j: u32| {
            let (x, y) = (i as f32 * 10.0 / k as f32, j as f32 * 10.0 / k as f32);
            Vec3::new(x, y, 0.3 * x.sin() * y.cos())
        };
        for i in 0..k {
            for j in 0..k {
                let (a, b, c, d) = (h(i, j), h(i + 1, j), h(i + 1, j + 1), h(i, j + 1));
                tris.extend([[a, b, c], [a, c, d]]);
            }
        }
    }
    for i in 0..segs * u32::from(tris.is_empty()) {
        for j in 0..rings {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            if j > 0 {
                tris.push([a, c, b]);
            }
            if j + 1 < rings {
                tris.push([a, d, c]);
            }
        }
    }
    let (a, b, c, d) = (Vec3::new(-5., -5., 0.), Vec3::new(5., -5., 0.), Vec3::new(5., 5., 0.), Vec3::new(-5., 5., 0.));
    if std::env::args().nth(2).is_none() {
        tris.extend([[a, b, c], [a, c, d]]);
    }
    let start = Instant::now();
    let flags = touching(&tris);
    let flag_s = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let accel = Accel::build(&tris);
    let build_s = start.elapsed().as_secs_f64();
    println!(
        "{{\"triangles\": {}, \"flagged\": {}, \"touching_seconds\": {flag_s:.3}, \"accel_build_seconds_with_flags\": {build_s:.3}, \"bvh_core_seconds\": {:.3}}}",
        tris.len(),
        flags.slot.iter().filter(|&&k| k != caustic::accel::touching::NEVER).count(),
        accel.build_time.as_secs_f64()
    );
}
