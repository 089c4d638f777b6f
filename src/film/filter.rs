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
}

/// Entries of the tabulated filter.
const FILTER_TABLE: usize = 256;

impl Filter {
    /// Box filter of the given width.
    pub fn box_filter(width: f32) -> Self {
        Filter { width, table: None }
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
        Filter { width, table: Some(Distribution1D::new(&weights)) }
    }

    /// Density of `sample`'s offsets per unit pixel area (separable; zero outside the
    /// support), used to spread light-tracing splats with the same filter.
    #[inline]
    pub fn eval(&self, off: Vec2) -> f32 {
        let axis = |x: f32| -> f32 {
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
        };
        axis(off.x) * axis(off.y)
    }

    /// Offset from the pixel centre for uniform numbers `u`.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Vec2 {
        let warp = |u: f32| -> f32 {
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
