//! Light selection for next-event estimation: in proportion to power (the baseline), or
//! with a light tree that prefers the lights near and facing the shading point.
//!
//! With the tree, lights at infinity (the world, suns) stand beside it: the tree's set is
//! chosen with probability P_tree / (P_tree + P_infinite) of the scene's powers, and an
//! infinite light within its set by power, so their probability does not depend on the
//! shading point ([`LightSampler::infinite_pmf`]).

use super::tree::{LightBounds, LightTree};
use crate::sampling::Distribution1D;
use glam::Vec3;

/// How lights are chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum LightSamplerKind {
    /// Light tree (Conty & Kulla 2018) for bounded lights, power for infinite ones.
    #[default]
    Tree,
    /// In proportion to power everywhere.
    Power,
}

impl LightSamplerKind {
    /// The name used on the command line and in the scene settings.
    pub fn name(self) -> &'static str {
        match self {
            LightSamplerKind::Tree => "tree",
            LightSamplerKind::Power => "power",
        }
    }

    /// Parses a name of `name`.
    pub fn from_name(s: &str) -> Option<Self> {
        match s {
            "tree" => Some(LightSamplerKind::Tree),
            "power" => Some(LightSamplerKind::Power),
            _ => None,
        }
    }
}

/// The tree with its infinite lights beside it.
#[derive(Clone, Debug)]
struct TreeSampler {
    tree: LightTree,
    /// Scene indices of the infinite lights and their distribution by power.
    infinite: Vec<u32>,
    infinite_dist: Distribution1D,
    /// For every light, its position in `infinite`, or `u32::MAX`.
    infinite_slot: Vec<u32>,
    /// Probability of choosing among the infinite lights.
    p_infinite: f32,
}

/// Chooses one light per shadow ray.
#[derive(Clone, Debug)]
pub struct LightSampler {
    power: Distribution1D,
    tree: Option<TreeSampler>,
    /// For every mesh triangle, the index of its light, or `u32::MAX`.
    tri_to_light: Vec<u32>,
}

impl LightSampler {
    /// A sampler by power (luminance of W), with the triangle→light map.
    pub fn new(powers: &[f32], tri_to_light: Vec<u32>) -> Self {
        LightSampler { power: Distribution1D::new(powers), tree: None, tri_to_light }
    }

    /// A tree sampler: `bounds[i]` are light i's bounds, None for lights at infinity.
    /// The powers are those of [`LightSampler::new`] (also used for infinite lights).
    pub fn with_tree(powers: &[f32], bounds: &[Option<LightBounds>], tri_to_light: Vec<u32>) -> Self {
        let power = Distribution1D::new(powers);
        // As `Distribution1D`, a scene whose lights all have zero power picks uniformly.
        let all_zero = !powers.iter().any(|&p| p > 0.0 && p.is_finite());
        let weight = |i: usize| if all_zero { 1.0 } else { powers[i] };
        let bounds: Vec<Option<LightBounds>> =
            bounds.iter().enumerate().map(|(i, b)| b.map(|b| LightBounds { phi: weight(i), ..b })).collect();
        let tree = LightTree::build(&bounds);
        let infinite: Vec<u32> = (0..bounds.len()).filter(|&i| bounds[i].is_none()).map(|i| i as u32).collect();
        let inf_w: Vec<f32> = infinite.iter().map(|&i| weight(i as usize)).collect();
        let mut infinite_slot = vec![u32::MAX; bounds.len()];
        for (k, &i) in infinite.iter().enumerate() {
            infinite_slot[i as usize] = k as u32;
        }
        let p_inf_power: f32 = inf_w.iter().filter(|w| w.is_finite() && **w > 0.0).sum();
        let total = p_inf_power + tree.power();
        let p_infinite = if total > 0.0 { p_inf_power / total } else { 0.0 };
        LightSampler {
            power,
            tree: Some(TreeSampler {
                tree,
                infinite,
                infinite_dist: Distribution1D::new(&inf_w),
                infinite_slot,
                p_infinite,
            }),
            tri_to_light,
        }
    }

    /// Which sampler this is.
    pub fn kind(&self) -> LightSamplerKind {
        if self.tree.is_some() { LightSamplerKind::Tree } else { LightSamplerKind::Power }
    }

    /// True when the scene has no light.
    pub fn is_empty(&self) -> bool {
        self.power.is_empty()
    }

    /// Picks a light for shading point `p` with normal `n` (zero when the surface
    /// transmits or there is none; only the tree uses them): (index, probability).
    #[inline]
    pub fn sample(&self, p: Vec3, n: Vec3, u: f32) -> Option<(usize, f32)> {
        if self.power.is_empty() {
            return None;
        }
        let Some(t) = &self.tree else {
            let (i, pmf, _) = self.power.sample(u);
            return (pmf > 0.0).then_some((i, pmf));
        };
        if u < t.p_infinite {
            let u = (u / t.p_infinite).min(0.999_999_94);
            let (k, pmf, _) = t.infinite_dist.sample(u);
            let pmf = pmf * t.p_infinite;
            return (pmf > 0.0).then_some((t.infinite[k] as usize, pmf));
        }
        let u = ((u - t.p_infinite) / (1.0 - t.p_infinite)).clamp(0.0, 0.999_999_94);
        let (i, pmf) = t.tree.sample(p, n, u)?;
        let pmf = pmf * (1.0 - t.p_infinite);
        (pmf > 0.0).then_some((i, pmf))
    }

    /// Probability that `sample(p, n, ·)` picks light `i`.
    #[inline]
    pub fn pmf(&self, p: Vec3, n: Vec3, i: usize) -> f32 {
        match &self.tree {
            None => self.power.pmf(i),
            Some(t) => match t.infinite_slot.get(i) {
                Some(&k) if k != u32::MAX => t.p_infinite * t.infinite_dist.pmf(k as usize),
                Some(_) => (1.0 - t.p_infinite) * t.tree.pmf(p, n, i),
                None => 0.0,
            },
        }
    }

    /// Probability of picking light `i` when it is at infinity (world, sun), which
    /// depends on no shading point.
    #[inline]
    pub fn infinite_pmf(&self, i: usize) -> f32 {
        match &self.tree {
            None => self.power.pmf(i),
            Some(t) => match t.infinite_slot.get(i) {
                Some(&k) if k != u32::MAX => t.p_infinite * t.infinite_dist.pmf(k as usize),
                _ => 0.0,
            },
        }
    }

    /// The light index of an emissive triangle.
    #[inline]
    pub fn light_of_triangle(&self, tri: u32) -> Option<usize> {
        match self.tri_to_light.get(tri as usize) {
            Some(&l) if l != u32::MAX => Some(l as usize),
            _ => None,
        }
    }

    /// Probability that `sample(p, n, ·)` returns None (0 for the power sampler with
    /// lights): the pmfs of all lights sum to 1 minus this.
    pub fn failure_probability(&self, p: Vec3, n: Vec3) -> f32 {
        match &self.tree {
            None => self.power.is_empty() as u8 as f32,
            Some(t) => (1.0 - t.p_infinite) * t.tree.failure_probability(p, n),
        }
    }

    /// Depth of the light tree (0 without one).
    pub fn tree_depth(&self) -> usize {
        self.tree.as_ref().map_or(0, |t| t.tree.depth())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::Pcg32;
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    use std::f32::consts::PI;

    fn unit(rng: &mut Pcg32) -> Vec3 {
        let z = 2.0 * rng.next_f32() - 1.0;
        let phi = 2.0 * PI * rng.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    fn in_box(rng: &mut Pcg32, half: f32) -> Vec3 {
        Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * (2.0 * half) - Vec3::splat(half)
    }

    /// A mixed set: one-sided and two-sided triangles (as emissive meshes), points,
    /// spots, spheres, with powers over four decades, plus two lights at infinity.
    /// Returns (powers, bounds, triangles (light, vertices)).
    #[allow(clippy::type_complexity)]
    fn lights(rng: &mut Pcg32, n: usize) -> (Vec<f32>, Vec<Option<LightBounds>>, Vec<(usize, [Vec3; 3], bool)>) {
        let (mut powers, mut bounds, mut tris) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..n {
            let phi = 10f32.powf(4.0 * rng.next_f32() - 2.0);
            let c = in_box(rng, 5.0);
            let b = match i % 5 {
                0 | 1 => {
                    let v = [c, c + in_box(rng, 0.3), c + in_box(rng, 0.3)];
                    let two_sided = i % 5 == 1;
                    tris.push((i, v, two_sided));
                    let nrm = (v[1] - v[0]).cross(v[2] - v[0]);
                    LightBounds::new(
                        v[0].min(v[1]).min(v[2]),
                        v[0].max(v[1]).max(v[2]),
                        nrm,
                        phi,
                        0.0,
                        PI / 2.0,
                        two_sided,
                    )
                }
                2 => LightBounds::new(c, c, Vec3::Z, phi, PI, PI / 2.0, false),
                3 => LightBounds::new(c, c, unit(rng), phi, 0.2 + rng.next_f32(), 0.0, false),
                _ => LightBounds::new(c - Vec3::splat(0.2), c + Vec3::splat(0.2), Vec3::Z, phi, PI, PI / 2.0, false),
            };
            powers.push(phi);
            bounds.push(Some(b));
        }
        // Two lights at infinity (world, sun) among the others.
        for slot in [n / 3, 2 * n / 3] {
            powers.insert(slot, 50.0);
            bounds.insert(slot, None);
            for t in tris.iter_mut() {
                if t.0 >= slot {
                    t.0 += 1;
                }
            }
        }
        (powers, bounds, tris)
    }

    /// The lights' probabilities and that of finding none sum to 1; the latter is
    /// small (it only wastes a shadow ray, it biases nothing).
    #[test]
    fn tree_pmf_sums_to_one() {
        let mut rng = Pcg32::new(11);
        let (powers, bounds, _) = lights(&mut rng, 300);
        let s = LightSampler::with_tree(&powers, &bounds, Vec::new());
        assert!(s.tree_depth() > 5);
        for k in 0..500 {
            let p = in_box(&mut rng, 7.0);
            let n = if k % 3 == 0 { Vec3::ZERO } else { unit(&mut rng) };
            let sum: f64 =
                (0..powers.len()).map(|i| s.pmf(p, n, i) as f64).sum::<f64>() + s.failure_probability(p, n) as f64;
            // The probabilities are products of at most depth + 1 factors, each with a
            // relative rounding error of a few ulps: 1e-4 is far above that and far
            // below any real error (a missed subtree weighs at least ~1e-6 here, but a
            // wrong branch weighs far more).
            assert!((sum - 1.0).abs() < 1e-4, "sum {sum} at {p} {n}");
        }
    }

    /// The frequency with which `sample` returns each light matches `pmf` (chi-square
    /// on light indices, cells with fewer than 5 expected pooled), and the returned
    /// probability equals `pmf`.
    #[test]
    fn tree_sample_frequencies_match_pmf() {
        let mut rng = Pcg32::new(5);
        let (powers, bounds, _) = lights(&mut rng, 200);
        let s = LightSampler::with_tree(&powers, &bounds, Vec::new());
        let points = 6;
        for k in 0..points {
            let p = in_box(&mut rng, 6.0);
            let n = if k == 0 { Vec3::ZERO } else { unit(&mut rng) };
            let samples = 200_000;
            // The last cell counts failed selections.
            let mut observed = vec![0f64; powers.len() + 1];
            for _ in 0..samples {
                let Some((i, pmf)) = s.sample(p, n, rng.next_f32()) else {
                    observed[powers.len()] += 1.0;
                    continue;
                };
                let expect = s.pmf(p, n, i);
                assert!(((pmf - expect) / expect).abs() < 1e-4, "returned pmf {pmf} != pmf() {expect}");
                observed[i] += 1.0;
            }
            let mut expected: Vec<f64> = (0..powers.len()).map(|i| s.pmf(p, n, i) as f64 * samples as f64).collect();
            expected.push(s.failure_probability(p, n) as f64 * samples as f64);
            let mut order: Vec<usize> = (0..expected.len()).collect();
            order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
            let (mut po, mut pe, mut chi2, mut dof) = (0f64, 0f64, 0f64, 0usize);
            for &i in &order {
                if expected[i] == 0.0 {
                    assert_eq!(observed[i], 0.0, "light {i} sampled with pmf 0");
                    continue;
                }
                if pe < 5.0 && expected[i] < 5.0 {
                    po += observed[i];
                    pe += expected[i];
                    continue;
                }
                chi2 += (observed[i] - expected[i]).powi(2) / expected[i];
                dof += 1;
            }
            if pe > 0.0 {
                chi2 += (po - pe).powi(2) / pe;
                dof += 1;
            }
            let p_value = 1.0 - ChiSquared::new((dof - 1) as f64).unwrap().cdf(chi2);
            // Šidák: 1 % for the test as a whole over its points.
            let threshold = 1.0 - 0.99f64.powf(1.0 / points as f64);
            assert!(p_value > threshold, "chi-square rejects light selection at {p}: p = {p_value:.2e} (dof {dof})");
        }
    }

    /// Unbiasedness needs the tree to give every light that can light a point a
    /// nonzero probability: any triangle with a point in front of it (its emitting side)
    /// and above the receiver's plane must have pmf > 0.
    #[test]
    fn tree_never_culls_a_light_that_can_contribute() {
        let mut rng = Pcg32::new(9);
        let (powers, bounds, tris) = lights(&mut rng, 300);
        let s = LightSampler::with_tree(&powers, &bounds, Vec::new());
        for k in 0..300 {
            let p = in_box(&mut rng, 7.0);
            let n = if k % 4 == 0 { Vec3::ZERO } else { unit(&mut rng) };
            for &(i, v, two_sided) in &tris {
                let nl = (v[1] - v[0]).cross(v[2] - v[0]);
                let reaches = (0..64).any(|_| {
                    let b = crate::sampling::warp::uniform_triangle(glam::Vec2::new(rng.next_f32(), rng.next_f32()));
                    let q = v[0] * (1.0 - b.x - b.y) + v[1] * b.x + v[2] * b.y;
                    let front = (p - q).dot(nl) > 0.0 || two_sided;
                    front && (n == Vec3::ZERO || (q - p).dot(n) > 0.0)
                });
                if reaches {
                    assert!(s.pmf(p, n, i) > 0.0, "light {i} can reach {p} (n {n}) but has pmf 0");
                }
            }
        }
    }

    #[test]
    fn power_sampler_ignores_the_point() {
        let s = LightSampler::new(&[1.0, 3.0], Vec::new());
        assert_eq!(s.pmf(Vec3::ONE, Vec3::Z, 1), 0.75);
        assert_eq!(s.sample(Vec3::ZERO, Vec3::ZERO, 0.5), Some((1, 0.75)));
        assert_eq!(s.kind(), LightSamplerKind::Power);
    }
}
