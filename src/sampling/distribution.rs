//! A piecewise-constant 1D distribution for picking one of many items
//! (lights by power, filter table entries) in proportion to a weight.

/// Discrete distribution over `n` items, sampled by search on the CDF narrowed by a
/// guide table.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    weights: Vec<f32>,
    cdf: Vec<f32>,
    total: f32,
    /// `guide[b]` = the number of CDF entries ≤ b / G for b = 0..=G (G = `guide.len() - 1`,
    /// a power of two, so b / G and u·G are exact in f32): the search for u in
    /// [b/G, (b+1)/G) is confined to `cdf[guide[b]..guide[b + 1]]`. A plain binary search
    /// over the pixel filter's and the world map's 257-entry CDFs was 4-12 % of a path
    /// traced sample (perf, the benchmark's scenes); the guided one finds the same item.
    guide: Vec<u32>,
}

/// Most guide buckets per distribution: beyond this the search within a bucket (a few
/// entries of a large world map's row) is cheaper than the memory the guide would take.
const MAX_GUIDE: usize = 1024;

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
        let g = weights.len().next_power_of_two().min(MAX_GUIDE);
        let guide = (0..=g).map(|b| cdf.partition_point(|&c| c <= b as f32 / g as f32) as u32).collect();
        Distribution1D { weights, cdf, total: total as f32, guide }
    }

    /// The number of CDF entries ≤ `u`: a binary search within `u`'s guide bucket (entries
    /// before it are ≤ b/G ≤ u, entries after it > (b+1)/G > u), the whole CDF for `u`
    /// outside [0, 1) or NaN.
    #[inline]
    fn entries_at_most(&self, u: f32) -> usize {
        let g = self.guide.len() - 1;
        if !(0.0..1.0).contains(&u) || g == 0 {
            return self.cdf.partition_point(|&c| c <= u);
        }
        // u·G is exact (G a power of two), so b = ⌊u·G⌋ and b/G ≤ u < (b+1)/G exactly.
        let b = ((u * g as f32) as usize).min(g - 1);
        let (lo, hi) = (self.guide[b] as usize, self.guide[b + 1] as usize);
        lo + self.cdf[lo..hi].partition_point(|&c| c <= u)
    }

    /// The CDF: `len() + 1` entries from 0 to 1, item i between entries i and i + 1.
    pub fn cdf(&self) -> &[f32] {
        &self.cdf
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
        let i = self.entries_at_most(u).clamp(1, n) - 1;
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

    /// The guided search finds what a binary search over the whole CDF finds, for every
    /// u near each CDF entry (the boundaries are where a wrong bucket would show), on
    /// distributions with and without empty buckets, and past the guide's size limit.
    #[test]
    fn guided_search_is_the_plain_search() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut rnd = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32 + 0.5) / (1u64 << 24) as f32
        };
        let peaked: Vec<f32> = (0..300).map(|i| if i % 37 == 0 { 1e4 } else { 1e-3 }).collect();
        let random: Vec<f32> = (0..5000).map(|_| rnd().powi(6)).collect();
        for weights in [vec![1.0], vec![0.0, 2.0, 0.0], peaked, random, vec![1.0; 256]] {
            let d = Distribution1D::new(&weights);
            let mut us = vec![0.0, 1.0, -0.5, 1.5, f32::NAN, 0.999_999_94];
            for &c in &d.cdf {
                us.extend([c, f32::from_bits(c.to_bits().saturating_sub(1)), f32::from_bits(c.to_bits() + 1)]);
            }
            us.extend((0..10_000).map(|_| rnd()));
            for u in us {
                let plain = d.cdf.partition_point(|&c| c <= u);
                assert_eq!(d.entries_at_most(u), plain, "u = {u:e} ({} items)", weights.len());
            }
        }
    }

    #[test]
    fn all_zero_is_uniform() {
        let d = Distribution1D::new(&[0.0, 0.0]);
        assert_eq!(d.pmf(1), 0.5);
        assert_eq!(d.sample(0.75).0, 1);
    }
}
