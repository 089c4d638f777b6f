//! A piecewise-constant 1D distribution for picking one of many items
//! (lights by power, filter table entries) in proportion to a weight.

/// Discrete distribution over `n` items, sampled by binary search on the CDF.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    weights: Vec<f32>,
    cdf: Vec<f32>,
    total: f32,
}

impl Distribution1D {
    /// Builds the distribution; negative or non-finite weights count as zero.
    /// When every weight is zero the distribution is uniform.
    pub fn new(weights: &[f32]) -> Self {
        let weights: Vec<f32> = weights.iter().map(|&w| if w.is_finite() && w > 0.0 { w } else { 0.0 }).collect();
        let mut total = weights.iter().map(|&w| w as f64).sum::<f64>();
        let uniform = total <= 0.0;
        if uniform {
            total = weights.len() as f64;
        }
        let mut cdf = Vec::with_capacity(weights.len() + 1);
        let mut acc = 0.0f64;
        cdf.push(0.0);
        for &w in &weights {
            acc += if uniform { 1.0 } else { w as f64 };
            cdf.push((acc / total) as f32);
        }
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        let weights = if uniform { vec![1.0; weights.len()] } else { weights };
        Distribution1D { weights, cdf, total: total as f32 }
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.weights.len()
    }

    /// True when there is nothing to pick.
    pub fn is_empty(&self) -> bool {
        self.weights.is_empty()
    }

    /// Sum of the weights.
    pub fn total(&self) -> f32 {
        self.total
    }

    /// Picks an item; returns its index, its probability, and `u` rescaled to [0,1)
    /// within the item so it can be reused.
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32, f32) {
        let n = self.weights.len();
        // partition_point finds the first cdf entry > u; the item is the one before.
        let i = self.cdf.partition_point(|&c| c <= u).clamp(1, n) - 1;
        // Skip zero-weight items that a rounding u could land on.
        let i = if self.weights[i] > 0.0 { i } else { self.next_nonzero(i) };
        let lo = self.cdf[i];
        let width = self.cdf[i + 1] - lo;
        let u_remapped = if width > 0.0 { ((u - lo) / width).clamp(0.0, 0.999_999_94) } else { 0.5 };
        (i, self.pmf(i), u_remapped)
    }

    fn next_nonzero(&self, i: usize) -> usize {
        (i..self.weights.len()).chain((0..i).rev()).find(|&j| self.weights[j] > 0.0).unwrap_or(i)
    }

    /// Probability of picking item `i`.
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.weights[i] / self.total
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pmf_matches_weights_and_sampling() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0, 4.0]);
        assert!((d.pmf(0) - 0.125).abs() < 1e-6);
        assert_eq!(d.pmf(1), 0.0);
        let mut counts = [0usize; 4];
        let n = 80_000;
        for k in 0..n {
            let u = (k as f32 + 0.5) / n as f32;
            let (i, p, _) = d.sample(u);
            assert_eq!(p, d.pmf(i));
            counts[i] += 1;
        }
        assert_eq!(counts[1], 0);
        assert!((counts[3] as f32 / n as f32 - 0.5).abs() < 1e-3);
    }

    #[test]
    fn all_zero_is_uniform() {
        let d = Distribution1D::new(&[0.0, 0.0]);
        assert_eq!(d.pmf(1), 0.5);
        assert_eq!(d.sample(0.75).0, 1);
    }
}
