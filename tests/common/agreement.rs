//! Statistical agreement of two integrators' images, region by region.
//!
//! How the bounds are derived: light tracing splats one light path onto many pixels (and
//! merging shares each light vertex among many pixels), so pixels of one render are
//! correlated and a per-pixel standard error would understate the noise. Each estimate is
//! therefore rendered with K independent seeds; the standard error of a region's mean comes
//! from the spread of its K means, and two estimates agree when their difference is within
//! a Student-t quantile (Welch's degrees of freedom) at a false-alarm rate of 10⁻³ per
//! test, split over the comparisons of the test (Šidák).

use super::render_image;
use statrs::distribution::{ContinuousCDF, StudentsT};
use std::path::Path;
use std::time::Duration;

/// Mean of the channel means of each region, for K seeds.
pub fn region_means(
    scene: &Path,
    dir: &Path,
    extra: &[&str],
    seeds: u32,
    regions: &[(String, Vec<usize>)],
    limit: Duration,
) -> Vec<Vec<f64>> {
    let mut out = vec![Vec::new(); regions.len()];
    for seed in 0..seeds {
        let mut args: Vec<&str> = extra.to_vec();
        let s = (seed * 7919 + 13).to_string();
        args.extend_from_slice(&["--seed", &s]);
        let px = render_image(scene, &dir.join("r.exr"), &args, limit);
        for (k, (_, idx)) in regions.iter().enumerate() {
            let m = idx.iter().map(|&i| (px[i][0] + px[i][1] + px[i][2]) as f64 / 3.0).sum::<f64>() / idx.len() as f64;
            out[k].push(m);
        }
    }
    out
}

/// Sample mean and variance.
pub fn mean_var(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    (m, v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0))
}

/// Welch's test: |mean(a) - mean(b)| within the t quantile at two-sided level `alpha`.
pub fn agree(name: &str, a: &[f64], b: &[f64], alpha: f64) -> bool {
    let (ma, va) = mean_var(a);
    let (mb, vb) = mean_var(b);
    let (sa, sb) = (va / a.len() as f64, vb / b.len() as f64);
    let se = (sa + sb).sqrt();
    let dof = (sa + sb).powi(2) / (sa * sa / (a.len() as f64 - 1.0) + sb * sb / (b.len() as f64 - 1.0));
    let t = StudentsT::new(0.0, 1.0, dof.max(1.0)).unwrap().inverse_cdf(1.0 - alpha / 2.0);
    let ok = (ma - mb).abs() <= t * se;
    eprintln!(
        "{name}: {ma:.5} vs {mb:.5} (ratio {:.4}), diff {:.2e}, bound {:.2e} (t {t:.2}, dof {dof:.1})",
        ma / mb,
        (ma - mb).abs(),
        t * se
    );
    ok
}

/// The regions (of `regions`) where the per-seed means `a` and `b` disagree at level `alpha`.
pub fn disagreeing(
    name: &str,
    regions: &[(String, Vec<usize>)],
    a: &[Vec<f64>],
    b: &[Vec<f64>],
    alpha: f64,
) -> Vec<String> {
    regions
        .iter()
        .enumerate()
        .filter(|(k, (rn, _))| !agree(&format!("{name} {rn}"), &a[*k], &b[*k], alpha))
        .map(|(_, (rn, _))| rn.clone())
        .collect()
}

/// Per-comparison level for a test making `n` comparisons at overall level 10⁻³.
pub fn sidak(n: usize) -> f64 {
    1.0 - (1.0 - 1e-3f64).powf(1.0 / n as f64)
}

/// Whole image and quadrants of a w×h image.
pub fn regions(w: usize, h: usize) -> Vec<(String, Vec<usize>)> {
    let mut out = vec![("whole".to_string(), (0..w * h).collect::<Vec<_>>())];
    for (qy, qx) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
        let idx = (0..w * h).filter(|i| (i / w) * 2 / h == qy && (i % w) * 2 / w == qx).collect();
        out.push((format!("quadrant {qy}{qx}"), idx));
    }
    out
}

/// Renders of one size and depth compared region by region: `common` flags first, then
/// each call's own; K = `seeds` independent seeds per estimate.
pub struct Seeded<'a> {
    /// Where the renders are written.
    pub dir: &'a Path,
    /// Flags every render takes (resolution, depth).
    pub common: Vec<&'a str>,
    /// Seeds per estimate.
    pub seeds: u32,
    /// The regions compared.
    pub regions: &'a [(String, Vec<usize>)],
    /// Time limit of one render.
    pub limit: Duration,
}

impl<'a> Seeded<'a> {
    /// Six seeds per estimate of `resolution` ("WxH") images at `max_depth` over `regions`.
    pub fn six(
        dir: &'a Path,
        resolution: &'a str,
        max_depth: &'a str,
        regions: &'a [(String, Vec<usize>)],
        limit: Duration,
    ) -> Self {
        Seeded { dir, common: vec!["--resolution", resolution, "--max-depth", max_depth], seeds: 6, regions, limit }
    }

    /// Asserts that `reference` is what the rule under test makes: `without` (the scene
    /// without the rule) disagrees with it in some region (`what` names the change).
    pub fn assert_rule_matters(&self, what: &str, without: &[Vec<f64>], reference: &[Vec<f64>], alpha: f64) {
        assert!(!disagreeing(what, self.regions, without, reference, alpha).is_empty(), "{what}: it changes nothing");
    }

    /// The regions where BDPT or VCM (`spp` samples; VCM with `--vcm-radius vcm_radius`)
    /// rendering `scene` disagree with `reference` at level `alpha`.
    pub fn bidirectional_disagreeing(
        &self,
        scene: &Path,
        reference: &[Vec<f64>],
        spp: &str,
        vcm_radius: &str,
        alpha: f64,
    ) -> Vec<String> {
        let bdpt = ["--integrator", "bdpt", "--spp", spp];
        let vcm = ["--integrator", "vcm", "--spp", spp, "--vcm-radius", vcm_radius];
        self.disagreeing_others(scene, reference, &[("bdpt", &bdpt), ("vcm", &vcm)], alpha)
    }

    /// Per-seed means of each region of `scene` rendered with `extra`.
    pub fn means(&self, scene: &Path, extra: &[&str]) -> Vec<Vec<f64>> {
        let mut a = self.common.clone();
        a.extend_from_slice(extra);
        region_means(scene, self.dir, &a, self.seeds, self.regions, self.limit)
    }

    /// "name region" for each region where an integrator of `others` (name, flags)
    /// rendering `scene` disagrees with `reference` at level `alpha`.
    pub fn disagreeing_others(
        &self,
        scene: &Path,
        reference: &[Vec<f64>],
        others: &[(&str, &[&str])],
        alpha: f64,
    ) -> Vec<String> {
        let mut failed = Vec::new();
        for (name, flags) in others {
            let m = self.means(scene, flags);
            failed.extend(
                disagreeing(name, self.regions, &m, reference, alpha).into_iter().map(|r| format!("{name} {r}")),
            );
        }
        failed
    }
}
