//! The pixel filter: where a camera sample lands around its pixel's centre, and the same
//! density for light-tracing splats. Box, or Blackman-Harris tabulated as Cycles does.

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
        let weights: Vec<f32> = (0..FILTER_TABLE)
            .map(|i| {
                let x = (i as f32 + 0.5) / FILTER_TABLE as f32; // in (0, 1) over the support
                let v = std::f32::consts::TAU * x;
                (0.35875 - 0.48829 * v.cos() + 0.14128 * (2.0 * v).cos() - 0.01168 * (3.0 * v).cos()).max(0.0)
            })
            .collect();
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
