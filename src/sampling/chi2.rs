//! Chi-square goodness-of-fit test of a direction sampler against its density, after
//! Mitsuba's `chi2.py`: histogram the samples on a (θ, φ) grid,
//! integrate the pdf over every cell, pool sparse cells, and reject at a significance
//! level corrected for the number of tests in the suite.

use glam::{Vec2, Vec3};
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::f64::consts::PI;

/// Independent uniform numbers for the test (a PCG32); the renderer's Sobol points are
/// deliberately *not* used because the test assumes independent samples.
pub struct Pcg32(u64);

impl Pcg32 {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        let mut r = Pcg32(seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407));
        r.next_u32();
        r
    }
    /// Next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.0;
        self.0 = old.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }
    /// Uniform in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }
}

/// Settings of one chi-square test.
pub struct ChiSquareTest {
    name: String,
    cos_bins: usize,
    phi_bins: usize,
    samples: usize,
    /// Significance level of the whole suite, divided among its tests (Šidák).
    significance: f64,
    tests_in_suite: usize,
}

/// What a test found.
pub struct ChiSquareResult {
    /// Test name.
    pub name: String,
    /// p-value of the pooled statistic.
    pub p_value: f64,
    /// Threshold the p-value is compared with.
    pub threshold: f64,
    /// Integral of the pdf over the sphere (≤ 1; < 1 when samples can fail).
    pub pdf_integral: f64,
    /// Fraction of sample calls that failed.
    pub failed_fraction: f64,
    /// Samples that landed where the pdf is zero, or whose direction was not unit length.
    pub out_of_support: usize,
    /// Largest relative gap between a sample's returned pdf and `pdf(dir)`, when the
    /// sampler returns its own pdf.
    pub max_pdf_mismatch: f64,
}

impl ChiSquareTest {
    /// A test with the default resolution (32 × 64 cells, 400k samples).
    pub fn new(name: &str) -> Self {
        ChiSquareTest {
            name: name.to_string(),
            cos_bins: 32,
            phi_bins: 64,
            samples: 400_000,
            significance: 0.01,
            tests_in_suite: 100,
        }
    }

    /// Runs the test on a sampler (None = failed sample) and the matching pdf.
    pub fn run(&self, mut sample: impl FnMut(Vec2) -> Option<Vec3>, pdf: impl Fn(Vec3) -> f32) -> ChiSquareResult {
        self.run_with_pdf(|u| sample(u).map(|w| (w, f32::NAN)), pdf)
    }

    /// Like [`run`](Self::run) for samplers that also return the pdf of the direction
    /// they chose, which is then checked against `pdf(dir)`.
    pub fn run_with_pdf(
        &self,
        mut sample: impl FnMut(Vec2) -> Option<(Vec3, f32)>,
        pdf: impl Fn(Vec3) -> f32,
    ) -> ChiSquareResult {
        let (nc, np) = (self.cos_bins, self.phi_bins);
        let mut observed = vec![0f64; nc * np];
        let mut rng = Pcg32::new(0x5eed ^ self.name.len() as u64);
        let mut failed = 0usize;
        let mut out_of_support = 0usize;
        let mut max_pdf_mismatch = 0f64;
        for _ in 0..self.samples {
            let u = Vec2::new(rng.next_f32(), rng.next_f32());
            match sample(u) {
                None => failed += 1,
                Some((w, p)) => {
                    if !w.is_finite() || (w.length() - 1.0).abs() > 1e-3 {
                        out_of_support += 1;
                        continue;
                    }
                    let expect = pdf(w);
                    if expect <= 0.0 {
                        out_of_support += 1;
                    }
                    if p.is_finite() && expect > 0.0 {
                        let rel = ((p - expect) / expect).abs() as f64;
                        max_pdf_mismatch = max_pdf_mismatch.max(rel);
                    }
                    observed[self.cell(w)] += 1.0;
                }
            }
        }
        // Integrate the pdf over each cell (θ, φ) with nested adaptive Simpson rules,
        // which follow narrow lobes and the edges of cones and triangles.
        let mut expected = vec![0f64; nc * np];
        let mut pdf_integral = 0f64;
        for ic in 0..nc {
            for ip in 0..np {
                let (t0, t1) = (PI * ic as f64 / nc as f64, PI * (ic + 1) as f64 / nc as f64);
                let (p0, p1) = (2.0 * PI * ip as f64 / np as f64, 2.0 * PI * (ip + 1) as f64 / np as f64);
                let f_theta = |theta: f64| {
                    let (st, ct) = theta.sin_cos();
                    let f_phi = |phi: f64| {
                        let w = Vec3::new((st * phi.cos()) as f32, (st * phi.sin()) as f32, ct as f32);
                        pdf(w) as f64
                    };
                    adaptive_simpson(&f_phi, p0, p1, 1e-7, 7) * st
                };
                let integral = adaptive_simpson(&f_theta, t0, t1, 1e-7, 7);
                pdf_integral += integral;
                expected[ic * np + ip] = integral * self.samples as f64;
            }
        }
        // The failed samples are one more category: the test then also checks that the
        // pdf's mass matches the success rate.
        observed.push(failed as f64);
        expected.push(((1.0 - pdf_integral) * self.samples as f64).max(0.0));

        // Pool cells whose expected count is below 5.
        let mut order: Vec<usize> = (0..expected.len()).collect();
        order.sort_by(|&a, &b| expected[a].partial_cmp(&expected[b]).unwrap());
        let (mut pool_obs, mut pool_exp) = (0f64, 0f64);
        let mut chi2 = 0f64;
        let mut dof = 0usize;
        for &i in &order {
            if pool_exp < 5.0 && expected[i] < 5.0 {
                pool_obs += observed[i];
                pool_exp += expected[i];
                continue;
            }
            chi2 += (observed[i] - expected[i]).powi(2) / expected[i];
            dof += 1;
        }
        if pool_exp > 0.0 {
            chi2 += (pool_obs - pool_exp).powi(2) / pool_exp;
            dof += 1;
        } else if pool_obs > 0.0 {
            // Samples where the pdf has no mass at all.
            chi2 = f64::INFINITY;
        }
        let dof = dof.saturating_sub(1).max(1);
        let p_value = if chi2.is_finite() { 1.0 - ChiSquared::new(dof as f64).unwrap().cdf(chi2) } else { 0.0 };
        let threshold = 1.0 - (1.0 - self.significance).powf(1.0 / self.tests_in_suite as f64);
        ChiSquareResult {
            name: self.name.clone(),
            p_value,
            threshold,
            pdf_integral,
            failed_fraction: failed as f64 / self.samples as f64,
            out_of_support,
            max_pdf_mismatch,
        }
    }

    fn cell(&self, w: Vec3) -> usize {
        let c = ((w.z.clamp(-1.0, 1.0) as f64).acos() / PI * self.cos_bins as f64) as usize;
        let mut phi = (w.y as f64).atan2(w.x as f64);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let p = (phi / (2.0 * PI) * self.phi_bins as f64) as usize;
        c.min(self.cos_bins - 1) * self.phi_bins + p.min(self.phi_bins - 1)
    }
}

/// Fails the calling test with the statistics when the sampler does not match its pdf.
pub fn assert_chi2(r: ChiSquareResult) {
    eprintln!(
        "{}: p = {:.4} (threshold {:.2e}), ∫pdf = {:.4}, failed = {:.4}, out of support = {}, pdf mismatch = {:.2e}",
        r.name, r.p_value, r.threshold, r.pdf_integral, r.failed_fraction, r.out_of_support, r.max_pdf_mismatch
    );
    assert!(r.out_of_support == 0, "{}: {} samples where pdf = 0", r.name, r.out_of_support);
    assert!(r.max_pdf_mismatch < 1e-2, "{}: sampled pdf differs from pdf() by {:.3}", r.name, r.max_pdf_mismatch);
    assert!(r.pdf_integral <= 1.0 + 2e-3, "{}: pdf integrates to {}", r.name, r.pdf_integral);
    assert!(r.p_value > r.threshold, "{}: chi-square rejects the sampler (p = {:.3e})", r.name, r.p_value);
}

/// Adaptive Simpson quadrature of `f` over [a, b] to absolute tolerance `eps`.
fn adaptive_simpson(f: &dyn Fn(f64) -> f64, a: f64, b: f64, eps: f64, depth: u32) -> f64 {
    // Start from 4 panels so that features narrower than the interval are seen.
    let n = 4;
    let h = (b - a) / n as f64;
    (0..n)
        .map(|i| {
            let (x0, x1) = (a + h * i as f64, a + h * (i + 1) as f64);
            let (f0, f1, fm) = (f(x0), f(x1), f(0.5 * (x0 + x1)));
            let whole = (x1 - x0) / 6.0 * (f0 + 4.0 * fm + f1);
            simpson_rec(f, x0, x1, f0, fm, f1, whole, eps / n as f64, depth)
        })
        .sum()
}

#[allow(clippy::too_many_arguments)]
fn simpson_rec(
    f: &dyn Fn(f64) -> f64,
    a: f64,
    b: f64,
    fa: f64,
    fm: f64,
    fb: f64,
    whole: f64,
    eps: f64,
    depth: u32,
) -> f64 {
    let m = 0.5 * (a + b);
    let (lm, rm) = (0.5 * (a + m), 0.5 * (m + b));
    let (flm, frm) = (f(lm), f(rm));
    let left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
    let right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
    let delta = left + right - whole;
    if depth == 0 || delta.abs() <= 15.0 * eps {
        return left + right + delta / 15.0;
    }
    simpson_rec(f, a, m, fa, flm, fm, left, eps / 2.0, depth - 1)
        + simpson_rec(f, m, b, fm, frm, fb, right, eps / 2.0, depth - 1)
}
