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
        let bounds: Vec<Option<LightBounds>> = bounds
            .iter()
            .enumerate()
            .map(|(i, b)| b.map(|b| LightBounds { phi: weight(i), ..b }))
            .collect();
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
            tree: Some(TreeSampler { tree, infinite, infinite_dist: Distribution1D::new(&inf_w), infinite_slot, p_infinite }),
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

    /// Depth of the light tree (0 without one).
    pub fn tree_depth(&self) -> usize {
        self.tree.as_ref().map_or(0, |t| t.tree.depth())
    }
}
