//! Picks a light in proportion to its emitted power (the baseline sampler).

use crate::sampling::Distribution1D;

/// Chooses one light per shadow ray, with probability ∝ power.
#[derive(Clone, Debug)]
pub struct LightSampler {
    dist: Distribution1D,
    /// For every mesh triangle, the index of its light, or `u32::MAX`.
    tri_to_light: Vec<u32>,
}

impl LightSampler {
    /// A sampler from each light's power (luminance of W) and the triangle→light map.
    pub fn new(powers: &[f32], tri_to_light: Vec<u32>) -> Self {
        LightSampler { dist: Distribution1D::new(powers), tri_to_light }
    }

    /// True when the scene has no light.
    pub fn is_empty(&self) -> bool {
        self.dist.is_empty()
    }

    /// Picks a light: (index, probability).
    #[inline]
    pub fn sample(&self, u: f32) -> Option<(usize, f32)> {
        if self.dist.is_empty() {
            return None;
        }
        let (i, p, _) = self.dist.sample(u);
        (p > 0.0).then_some((i, p))
    }

    /// Probability of picking light `i`.
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.dist.pmf(i)
    }

    /// The light index of an emissive triangle.
    #[inline]
    pub fn light_of_triangle(&self, tri: u32) -> Option<usize> {
        match self.tri_to_light.get(tri as usize) {
            Some(&l) if l != u32::MAX => Some(l as usize),
            _ => None,
        }
    }
}
