//! Per-pixel sample streams: Owen-scrambled Sobol points (Burley 2020, via the
//! `sobol_burley` crate) with an independent scramble per pixel.
//!
//! A pixel's samples depend only on (seed, pixel, sample index), never on the thread
//! that renders them: that makes images bit-identical for any thread count.

use super::sobol::{SobolTables, sobol_tables};
use crate::math::hash_combine;
use glam::Vec2;

/// The Sobol stream of one pixel sample; dimensions are drawn four at a time
/// (`sobol_burley::sample_4d`'s points, computed from `sobol.rs`' tables).
#[derive(Clone, Debug)]
pub struct PixelSampler {
    pixel_seed: u32,
    index: u32,
    set: u32,
    tables: &'static SobolTables,
}

impl PixelSampler {
    /// The stream for sample `index` of pixel (`x`, `y`) under the render seed.
    #[inline]
    pub fn new(seed: u32, x: u32, y: u32, index: u32) -> Self {
        PixelSampler { pixel_seed: hash_combine(&[seed, x, y]), index, set: 0, tables: sobol_tables() }
    }

    /// Next four dimensions in [0, 1).
    #[inline]
    pub fn next_4d(&mut self) -> [f32; 4] {
        let d = self.set;
        self.set += 1;
        // sobol_burley has 64 sets of 4 dimensions and 2^16 samples; beyond either, a
        // fresh scramble seed keeps the points well distributed (they lose the
        // stratification across blocks, nothing else).
        let block = (d / sobol_burley::NUM_DIMENSION_SETS_4D) ^ ((self.index >> 16) << 8);
        let seed = if block == 0 { self.pixel_seed } else { hash_combine(&[self.pixel_seed, block]) };
        self.tables.sample_4d(self.index & 0xffff, d % sobol_burley::NUM_DIMENSION_SETS_4D, seed)
    }

    /// Two dimensions (a set of four, of which two are left unused).
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let v = self.next_4d();
        Vec2::new(v[0], v[1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deterministic_and_in_range() {
        let mut a = PixelSampler::new(7, 3, 4, 11);
        let mut b = PixelSampler::new(7, 3, 4, 11);
        for _ in 0..150 {
            let x = a.next_4d();
            assert_eq!(x, b.next_4d());
            assert!(x.iter().all(|v| (0.0..1.0).contains(v)));
        }
    }

    #[test]
    fn first_dimension_is_stratified() {
        // 64 samples of an Owen-scrambled Sobol sequence fall one per 1/64 stratum.
        let mut hits = [false; 64];
        for i in 0..64 {
            let u = PixelSampler::new(1, 5, 9, i).next_4d()[0];
            hits[(u * 64.0) as usize] = true;
        }
        assert!(hits.iter().all(|&h| h));
    }
}
