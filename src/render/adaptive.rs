//! Adaptive sampling as Cycles does it (`intern/cycles/scene/integrator.cpp`,
//! `integrator/adaptive_sampling.cpp`, `kernel/film/adaptive_sampling.h`): every pixel
//! keeps, beside its sum of all samples, a second sum of one half of them (class A); at
//! regular sample counts the two means are compared, and a pixel whose relative
//! difference is below the noise threshold stops taking samples.
//!
//! * **Settings** ([`Adaptive::new`]): Cycles' noise threshold T (0 = off here; the add-on
//!   turns Cycles' "automatic" threshold into a number), minimum samples (0 = derived from
//!   T as Cycles does, `max(4, ceil(16 / T^0.3))`: 0.1 → 32, 0.01 → 64, 0.001 → 128), the
//!   adaptive step of 16 samples, and the threshold scaled by Cycles' factor of 5.
//! * **Halves**: sample i is of class A when the number of set odd bits of i is odd
//!   (Cycles' `sample_is_class_A`, from Christensen et al. 2018, §10.2.1): for Sobol
//!   sequences each class is itself well stratified, so both halves estimate the pixel
//!   with comparable error. The film holds Σ all; [`AdaptiveTile`] holds Σ class A, both
//!   in fixed point, so the test is exact and the same for any thread count.
//! * **Test** ([`AdaptiveFilm::update`]): after N samples with N − 1 > min samples and
//!   N a multiple of the step (Cycles' `need_filter` on the 0-based index N − 1), each
//!   pixel not yet converged gets error = Σ_c |I_c − A_c| / (1e-4 + norm), where I is the
//!   mean of all samples, A twice the class-A sum over the count, and norm = √(ΣI) below
//!   ΣI = 1 and ΣI above it; it converges when error < threshold. Then every pixel in the
//!   3×3 neighbourhood of an unconverged one is marked unconverged again (Cycles' box
//!   filter in x, then y), and is tested again at the next step.
//! * **Scope**: the camera samples of the progressive driver (path tracer, BDPT, Jensen's
//!   photon mapping, whose maps are fixed during the pass). BDPT's light-tracing splats
//!   (strategies with one camera vertex) land in the film's splat buffer, not in a pixel's
//!   samples: they keep arriving from the light paths of unconverged pixels and stay
//!   unbiased, but their noise is not part of the test. SPPM has no per-pixel sample
//!   count to stop (its iterations shrink every pixel's radius together); the settings
//!   resolution ignores the threshold for it with a warning.

use crate::film::{CameraSample, Film};
use crate::fixed::{add3, from_fixed};

/// Samples between two convergence tests (Cycles' fixed adaptive step; a power of two).
pub const ADAPTIVE_STEP: u32 = 16;

/// Cycles' factor on the user's threshold ("makes the threshold more similar to what it
/// was before, and gives arguably more intuitive values").
const THRESHOLD_SCALE: f32 = 5.0;

/// Cycles' guard against division by zero in the error's normalisation.
const ERROR_EPSILON: f64 = 1e-4;

/// Adaptive sampling settings, derived as Cycles derives them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptive {
    /// The user's noise threshold (before Cycles' factor of 5).
    pub noise_threshold: f32,
    /// The threshold the error is compared with (× 5).
    pub threshold: f32,
    /// Samples every pixel takes before the first test.
    pub min_samples: u32,
    /// Samples between tests.
    pub step: u32,
}

impl Adaptive {
    /// Settings for a noise threshold (> 0) and a minimum sample count (0: derived from
    /// the threshold as Cycles does).
    pub fn new(noise_threshold: f32, min_samples: u32) -> Self {
        let min_samples = if min_samples == 0 {
            // Cycles: "Threshold 0.1 -> 32, 0.01 -> 64, 0.001 -> 128", from the threshold before ×5.
            ((16.0 / noise_threshold.powf(0.3)).ceil() as u32).max(4)
        } else {
            min_samples.max(4)
        };
        Adaptive { noise_threshold, threshold: noise_threshold * THRESHOLD_SCALE, min_samples, step: ADAPTIVE_STEP }
    }

    /// Whether the convergence test runs after `done` samples (Cycles' `need_filter` of
    /// the 0-based index `done - 1`).
    pub fn test_after(&self, done: u32) -> bool {
        done >= 1 && done - 1 > self.min_samples && done.is_multiple_of(self.step)
    }

    /// Cycles' per-pixel error of the mean `i` of all samples against the mean `a` of the
    /// class-A half (RGB).
    pub fn error(i: [f64; 3], a: [f64; 3]) -> f64 {
        let difference = (i[0] - a[0]).abs() + (i[1] - a[1]).abs() + (i[2] - a[2]).abs();
        let intensity = i[0] + i[1] + i[2];
        // Below R+G+B = 1 the square root favours dark pixels (where display curves need
        // the most samples); above it the error is relative to the intensity.
        let normalise = if intensity < 1.0 { intensity.max(0.0).sqrt() } else { intensity };
        difference / (ERROR_EPSILON + normalise)
    }
}

/// Whether sample index `i` belongs to class A (Cycles' `sample_is_class_A`).
#[inline]
pub fn is_class_a(i: u32) -> bool {
    (i & 0xaaaa_aaaa).count_ones() & 1 == 1
}

/// One film tile's adaptive state: Σ of the class-A samples' radiance and the converged flags.
#[derive(Clone, Debug, Default)]
pub struct AdaptiveTile {
    /// Σ radiance of class-A samples, fixed point, row-major as the film tile.
    pub half: Vec<[i128; 3]>,
    /// The pixel stopped taking samples.
    pub converged: Vec<bool>,
}

impl AdaptiveTile {
    /// Whether pixel `k` of the tile still takes samples (always, when adaptive sampling is off).
    #[inline]
    pub fn active(&self, k: usize) -> bool {
        !self.converged.get(k).copied().unwrap_or(false)
    }

    /// Records sample `i` of pixel `k`, already added to the film (nothing when off).
    #[inline]
    pub fn add(&mut self, k: usize, i: u32, s: &CameraSample) {
        if let Some(h) = self.half.get_mut(k)
            && is_class_a(i)
        {
            add3(h, s.radiance.to_array());
        }
    }
}

/// The adaptive state of a whole film, one [`AdaptiveTile`] per film tile (empty ones when off).
#[derive(Clone, Debug)]
pub struct AdaptiveFilm {
    /// The settings; None when adaptive sampling is off.
    pub settings: Option<Adaptive>,
    /// Per film tile, in the film's order.
    pub tiles: Vec<AdaptiveTile>,
    /// Pixels still taking samples after the last test.
    pub active: u64,
}

impl AdaptiveFilm {
    /// State for `film`'s tiles.
    pub fn new(film: &Film, settings: Option<Adaptive>) -> Self {
        let tiles = film
            .tiles
            .iter()
            .map(|t| match settings {
                None => AdaptiveTile::default(),
                Some(_) => {
                    let n = t.pixels.len();
                    AdaptiveTile { half: vec![[0; 3]; n], converged: vec![false; n] }
                }
            })
            .collect();
        AdaptiveFilm { settings, tiles, active: (film.width as u64) * (film.height as u64) }
    }

    /// Runs the convergence test after `done` samples when Cycles would, then the 3×3
    /// dilation of unconverged pixels; returns the pixels still active. Sequential over
    /// the image: it reads exact sums, so its outcome does not depend on the thread count.
    pub fn update(&mut self, film: &Film, done: u32) -> u64 {
        let Some(s) = self.settings else { return self.active };
        if !s.test_after(done) {
            return self.active;
        }
        let (w, h) = (film.width as usize, film.height as usize);
        // Row-major unconverged mask of the whole image after the test.
        let mut open = vec![false; w * h];
        for (t, at) in film.tiles.iter().zip(&mut self.tiles) {
            for ty in 0..t.h {
                for tx in 0..t.w {
                    let k = (ty * t.w + tx) as usize;
                    let p = &t.pixels[k];
                    if !at.converged[k] && p.n > 0 {
                        let inv = 1.0 / p.n as f64;
                        let i = p.rgb.map(|v| from_fixed(v) * inv);
                        let a = at.half[k].map(|v| 2.0 * from_fixed(v) * inv);
                        at.converged[k] = Adaptive::error(i, a) < s.threshold as f64;
                    }
                    open[(t.y0 + ty) as usize * w + (t.x0 + tx) as usize] = !at.converged[k];
                }
            }
        }
        let open = dilate(&dilate_rows(&open, w, h), w, h);
        let mut active = 0;
        for (t, at) in film.tiles.iter().zip(&mut self.tiles) {
            for ty in 0..t.h {
                for tx in 0..t.w {
                    let k = (ty * t.w + tx) as usize;
                    let o = open[(t.y0 + ty) as usize * w + (t.x0 + tx) as usize];
                    at.converged[k] = !o;
                    active += o as u64;
                }
            }
        }
        self.active = active;
        active
    }
}

/// Marks the left and right neighbours of every marked pixel (Cycles' `filter_x`, which
/// reads each pixel before it writes it, so it widens by exactly one pixel).
fn dilate_rows(m: &[bool], w: usize, h: usize) -> Vec<bool> {
    let mut out = m.to_vec();
    for y in 0..h {
        let row = &m[y * w..(y + 1) * w];
        for x in 0..w {
            if !row[x] && ((x > 0 && row[x - 1]) || (x + 1 < w && row[x + 1])) {
                out[y * w + x] = true;
            }
        }
    }
    out
}

/// Marks the upper and lower neighbours of every marked pixel (Cycles' `filter_y`).
fn dilate(m: &[bool], w: usize, h: usize) -> Vec<bool> {
    let mut out = m.to_vec();
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if !m[i] && ((y > 0 && m[i - w]) || (y + 1 < h && m[i + w])) {
                out[i] = true;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Cycles' comment on its derivation: threshold 0.1 → 32, 0.01 → 64, 0.001 → 128.
    #[test]
    fn min_samples_follow_cycles() {
        assert_eq!(Adaptive::new(0.1, 0).min_samples, 32);
        assert_eq!(Adaptive::new(0.01, 0).min_samples, 64);
        assert_eq!(Adaptive::new(0.001, 0).min_samples, 128);
        assert_eq!(Adaptive::new(0.01, 2).min_samples, 4);
        assert_eq!(Adaptive::new(0.01, 100).min_samples, 100);
        // ×5 in f32, as Cycles: within one rounding (2^-24 relative) of 0.05.
        assert!((Adaptive::new(0.01, 0).threshold - 0.05).abs() <= 0.05 * f32::EPSILON);
    }

    /// The test runs on multiples of the step after the minimum: with min 64, at 80, 96, …
    /// (index 63 is not > 64; index 79 is).
    #[test]
    fn tests_run_on_cycles_schedule() {
        let a = Adaptive::new(0.01, 0);
        let when: Vec<u32> = (1..=128).filter(|&n| a.test_after(n)).collect();
        assert_eq!(when, vec![80, 96, 112, 128]);
    }

    /// Class A is half of every aligned block of 4 samples (the Sobol stratification unit
    /// the split keeps), so each half holds exactly half of any 2^k ≥ 4 prefix.
    #[test]
    fn class_a_is_half_of_each_block() {
        for block in 0..64u32 {
            let a = (block * 4..block * 4 + 4).filter(|&i| is_class_a(i)).count();
            assert_eq!(a, 2, "block {block}");
        }
    }

    /// The error: equal halves converge at once; the normalisation is √I below 1 and I above.
    #[test]
    fn error_matches_formula() {
        assert_eq!(Adaptive::error([0.3; 3], [0.3; 3]), 0.0);
        let e = Adaptive::error([0.1, 0.1, 0.05], [0.12, 0.1, 0.05]);
        assert!((e - 0.02 / (1e-4 + 0.25f64.sqrt())).abs() < 1e-12, "{e}");
        let e = Adaptive::error([2.0, 1.0, 1.0], [2.0, 1.5, 1.0]);
        assert!((e - 0.5 / (1e-4 + 4.0)).abs() < 1e-12, "{e}");
    }

    /// One unconverged pixel reopens exactly its 3×3 neighbourhood.
    #[test]
    fn dilation_is_three_by_three() {
        let (w, h) = (7, 6);
        let mut m = vec![false; w * h];
        m[3 * w + 2] = true;
        m[w - 1] = true; // a corner: the box is clipped by the image
        let d = dilate(&dilate_rows(&m, w, h), w, h);
        let marked: Vec<(usize, usize)> = (0..w * h).filter(|&i| d[i]).map(|i| (i % w, i / w)).collect();
        let mut want = vec![(5, 0), (6, 0), (5, 1), (6, 1)];
        for y in 2..5 {
            for x in 1..4 {
                want.push((x, y));
            }
        }
        want.sort_by_key(|&(x, y)| (y, x));
        assert_eq!(marked, want);
    }
}
