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
#[derive(Clone, Copy, Debug)]
pub struct PixelSampler {
    pixel_seed: u32,
    index: u32,
    set: u32,
    tables: &'static SobolTables,
    /// The shuffled index of the first block (`SobolTables::shuffled_index` of `index`
    /// under `pixel_seed`), which every dimension set of that block shares.
    rev: u32,
}

impl PixelSampler {
    /// The stream for sample `index` of pixel (`x`, `y`) under the render seed.
    #[inline]
    pub fn new(seed: u32, x: u32, y: u32, index: u32) -> Self {
        let pixel_seed = hash_combine(&[seed, x, y]);
        let rev = SobolTables::shuffled_index(index & 0xffff, pixel_seed);
        PixelSampler { pixel_seed, index, set: 0, tables: sobol_tables(), rev }
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
        let set = d % sobol_burley::NUM_DIMENSION_SETS_4D;
        if block == 0 {
            return self.tables.sample_4d_shuffled(self.rev, set, self.pixel_seed);
        }
        self.tables.sample_4d(self.index & 0xffff, set, hash_combine(&[self.pixel_seed, block]))
    }

    /// Passes over the next four dimensions without computing them (a walker's layout
    /// keeps their place where it does not need them): what follows is drawn as before.
    #[inline]
    pub fn skip_4d(&mut self) {
        self.set += 1;
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

    /// The first block's cached shuffled index gives the tables' points for the stream's
    /// seed, as later blocks (past 64 sets, past 2^16 samples) do from their own seeds;
    /// a skipped set leaves the rest of the stream where it was.
    #[test]
    fn stream_is_the_tables_points() {
        let tables = sobol_tables();
        for index in [0, 1, 17, 65_535, 65_536, 200_001] {
            let mut s = PixelSampler::new(9, 4, 2, index);
            let mut skipping = PixelSampler::new(9, 4, 2, index);
            let pixel_seed = hash_combine(&[9, 4, 2]);
            for d in 0..150u32 {
                let block = (d / 64) ^ ((index >> 16) << 8);
                let seed = if block == 0 { pixel_seed } else { hash_combine(&[pixel_seed, block]) };
                let want = tables.sample_4d(index & 0xffff, d % 64, seed);
                assert_eq!(s.next_4d().map(f32::to_bits), want.map(f32::to_bits), "index {index} set {d}");
                if d % 3 == 1 {
                    skipping.skip_4d();
                } else {
                    assert_eq!(skipping.next_4d(), want, "index {index} set {d} after skips");
                }
            }
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
