//! The pixel filter: where a camera sample lands around its pixel's centre, and the same
//! density for light-tracing splats. Box, or Blackman-Harris or Gaussian tabulated as Cycles does.

use crate::sampling::Distribution1D;
use glam::Vec2;

/// Pixel filter.
#[derive(Clone, Debug)]
pub struct Filter {
    /// Width in pixels (support [-width/2, width/2] on each axis).
    pub width: f32,
    table: Option<Distribution1D>,
    /// The table's inverse for `sample` (None: some entry has no weight, the general search).
    warp: Option<Warp>,
}

/// Entries of the tabulated filter.
const FILTER_TABLE: usize = 256;

/// Guide buckets of [`Warp`]: 16 a table entry, so that a bucket holds at most one CDF entry
/// where the filter is not near zero (the table's tails, rarely sampled, may hold more).
const WARP_GUIDE: usize = 4096;

/// The filter table's sampling as `Distribution1D::sample` gives it (the same item and
/// offset, bit for bit), for a table whose every entry has weight: a guide of
/// [`WARP_GUIDE`] buckets and a linear scan within the bucket instead of the general
/// search (its 256-bucket guide, binary search, zero-weight skip and density). The two
/// searches per camera sample were 2.4 % of the glass bench's instructions (callgrind).
#[derive(Clone, Debug)]
struct Warp {
    /// The table's CDF, `FILTER_TABLE + 1` entries.
    cdf: Vec<f32>,
    /// `guide[b]`: the number of CDF entries ≤ b / `WARP_GUIDE`, for b in 0..=`WARP_GUIDE`.
    guide: Vec<u16>,
}

impl Warp {
    /// The inverse of `table`; None when an entry has no weight (the general search skips
    /// those items, this one does not).
    fn new(table: &Distribution1D) -> Option<Self> {
        if table.len() != FILTER_TABLE || (0..table.len()).any(|i| !(table.pmf(i) > 0.0)) {
            return None;
        }
        let cdf = table.cdf().to_vec();
        let guide =
            (0..=WARP_GUIDE).map(|b| cdf.partition_point(|&c| c <= b as f32 / WARP_GUIDE as f32) as u16).collect();
        Some(Warp { cdf, guide })
    }

    /// The offset in [-0.5, 0.5) for `u` in [0, 1) (None outside: the general search).
    #[inline]
    fn offset(&self, u: f32) -> Option<f32> {
        if !(0.0..1.0).contains(&u) {
            return None;
        }
        // u·G is exact (G a power of two): b/G ≤ u < (b+1)/G, so the entries ≤ u are the
        // guide's count plus those of the bucket's that are ≤ u (the CDF is sorted).
        let b = ((u * WARP_GUIDE as f32) as usize).min(WARP_GUIDE - 1);
        let (mut i, hi) = (self.guide[b] as usize, self.guide[b + 1] as usize);
        while i < hi && self.cdf[i] <= u {
            i += 1;
        }
        // As `Distribution1D::sample`: the item before the first entry above u, and u
        // rescaled within it.
        let i = i.clamp(1, FILTER_TABLE) - 1;
        let lo = self.cdf[i];
        let width = self.cdf[i + 1] - lo;
        let r = if width > 0.0 { ((u - lo) / width).clamp(0.0, 0.999_999_94) } else { 0.5 };
        Some((i as f32 + r) / FILTER_TABLE as f32 - 0.5)
    }
}

impl Filter {
    /// Box filter of the given width.
    pub fn box_filter(width: f32) -> Self {
        Filter { width, table: None, warp: None }
    }

    /// Blackman-Harris over a window of the given width (Cycles uses twice Blender's filter size: 3 px by default),
    /// separable, as Cycles tabulates it.
    pub fn blackman_harris(width: f32) -> Self {
        Self::tabulated(width, |x| {
            let v = std::f32::consts::TAU * x;
            0.35875 - 0.48829 * v.cos() + 0.14128 * (2.0 * v).cos() - 0.01168 * (3.0 * v).cos()
        })
    }

    /// Cycles' Gaussian over a window of the given width (three times Blender's filter width,
    /// film.cpp), separable: exp(-2 (6 v / width)²) for v from the centre, i.e. a standard
    /// deviation of width / 12, cut at six of them.
    pub fn gaussian(width: f32) -> Self {
        Self::tabulated(width, |x| {
            let v = 6.0 * (x - 0.5);
            (-2.0 * v * v).exp()
        })
    }

    /// A separable filter tabulated over its support from `weight` at x in (0, 1).
    fn tabulated(width: f32, weight: impl Fn(f32) -> f32) -> Self {
        let weights: Vec<f32> =
            (0..FILTER_TABLE).map(|i| weight((i as f32 + 0.5) / FILTER_TABLE as f32).max(0.0)).collect();
        let table = Distribution1D::new(&weights);
        Filter { width, warp: Warp::new(&table), table: Some(table) }
    }

    /// Density of `sample`'s offsets per unit pixel area (separable; zero outside the
    /// support), used to spread light-tracing splats with the same filter.
    #[inline]
    pub fn eval(&self, off: Vec2) -> f32 {
        self.axis(off.x) * self.axis(off.y)
    }

    /// The separable filter's factor along one axis at offset `x` ([`eval`](Self::eval)
    /// is the product of two).
    #[inline]
    pub fn axis(&self, x: f32) -> f32 {
        let v = x / self.width + 0.5;
        if !(0.0..1.0).contains(&v) {
            return 0.0;
        }
        match &self.table {
            None => 1.0 / self.width,
            Some(t) => {
                t.pmf(((v * FILTER_TABLE as f32) as usize).min(FILTER_TABLE - 1)) * FILTER_TABLE as f32 / self.width
            }
        }
    }

    /// Offset from the pixel centre of a camera sample numbered `index` for uniform numbers
    /// `u`: sample 0 takes the pixel's centre, as Cycles' (`integrate_camera_sample`), so the
    /// passes read from the first sample alone (Depth, Position, the indices) are the centre's.
    #[inline]
    pub fn camera_offset(&self, index: u32, u: Vec2) -> Vec2 {
        if index == 0 { Vec2::ZERO } else { self.sample(u) }
    }

    /// Offset from the pixel centre for uniform numbers `u`.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Vec2 {
        let warp = |u: f32| -> f32 {
            if let Some(x) = self.warp.as_ref().and_then(|w| w.offset(u)) {
                return x;
            }
            match &self.table {
                None => u - 0.5,
                Some(t) => {
                    let (i, _, r) = t.sample(u);
                    (i as f32 + r) / FILTER_TABLE as f32 - 0.5
                }
            }
        };
        Vec2::new(warp(u.x), warp(u.y)) * self.width
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The inverse gives `Distribution1D::sample`'s offset bit for bit: on a fine grid of u,
    /// at every CDF entry and the floats either side of it, for both tabulated filters.
    #[test]
    fn warp_matches_the_general_search_bit_for_bit() {
        for f in [Filter::blackman_harris(3.0), Filter::gaussian(4.5), Filter::blackman_harris(1.0)] {
            let (t, w) = (f.table.as_ref().unwrap(), f.warp.as_ref().expect("every entry has weight"));
            let general = |u: f32| {
                let (i, _, r) = t.sample(u);
                (i as f32 + r) / FILTER_TABLE as f32 - 0.5
            };
            let grid = (0..1u32 << 20).map(|k| k as f32 / (1u32 << 20) as f32);
            let edges = t.cdf().iter().flat_map(|&c| [c.next_down(), c, c.next_up()]);
            let mut n = 0;
            for u in grid.chain(edges).chain([0.0, 0.999_999_94, 1.0, -0.0, f32::NAN]) {
                let want = general(u);
                match w.offset(u) {
                    Some(x) => assert_eq!(x.to_bits(), want.to_bits(), "u {u}"),
                    None => assert!(!(0.0..1.0).contains(&u), "u {u} left to the general search"),
                }
                n += 1;
            }
            assert!(n > 1 << 20);
        }
        // A table with an empty entry keeps the general search.
        let mut weights = vec![1.0; FILTER_TABLE];
        weights[7] = 0.0;
        assert!(Warp::new(&Distribution1D::new(&weights)).is_none());
    }

    /// The Gaussian's sampled offsets have the standard deviation Cycles' table gives
    /// (width / 12 per axis, slightly less for the cut tails) and its density integrates to 1.
    #[test]
    fn gaussian_spread_and_density() {
        let f = Filter::gaussian(4.5);
        let n = 4096;
        let var: f64 =
            (0..n).map(|i| f.sample(Vec2::splat((i as f32 + 0.5) / n as f32)).x as f64).map(|x| x * x).sum::<f64>()
                / n as f64;
        let sigma = 4.5 / 12.0;
        assert!((var.sqrt() - sigma).abs() < 0.01 * sigma, "sigma {} vs {sigma}", var.sqrt());
        // eval is a(x) a(y): the integral of eval(x, 0) over x is a(0) times the integral of a.
        let step = 4.5 / 512.0;
        let along_x: f32 = (0..512).map(|i| f.eval(Vec2::new(-2.25 + (i as f32 + 0.5) * step, 0.0)) * step).sum();
        let integral = along_x / f.eval(Vec2::ZERO).sqrt();
        assert!((integral - 1.0).abs() < 0.01, "density integrates to {integral}");
    }
}
