//! Owen-scrambled Sobol points exactly as `sobol_burley::sample_4d` gives them, with the
//! Sobol matrix product read from tables instead of a loop over the index's bits.
//!
//! The crate multiplies the (shuffled, bit-reversed) sample index by each dimension's
//! generator matrix over GF(2): one XOR of a direction vector per set bit of the index's
//! top 16 bits. With the per-pixel shuffle those bits are random, so the loop ran about
//! eight times with a data-dependent exit (callgrind, Cornell box: the loop was 3 % of the
//! render's instructions and 8.5 % of its branch mispredictions). The product is linear
//! in the index, so it is the XOR of the products of the index's four nibbles, each a
//! lookup in a 16-entry table per nibble position: four loads instead of a loop. Every
//! other step (index shuffle, Owen scramble, bit reversal, conversion to floats) is the
//! crate's own function, so the points are the crate's bit for bit (tested below).

use sobol_burley::NUM_DIMENSION_SETS_4D;
use sobol_burley::parts::{Int4, hash, hash_int4, owen_scramble_int4_rev, owen_scramble_rev, sobol_rev};
use std::sync::OnceLock;

/// One dimension set's products: `[nibble position][nibble value]` → the four
/// dimensions' reversed Sobol integers for that nibble alone.
type SetTable = [[[u32; 4]; 16]; 4];

/// The nibble tables of every dimension set (256 KiB, built once on first use).
pub struct SobolTables {
    sets: Vec<SetTable>,
    /// The CPU has SSE4.1 and SSSE3 (checked once here rather than at every point).
    sse41: bool,
}

impl std::fmt::Debug for SobolTables {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "SobolTables({} dimension sets)", self.sets.len())
    }
}

/// The shared tables.
#[inline]
pub fn sobol_tables() -> &'static SobolTables {
    static TABLES: OnceLock<SobolTables> = OnceLock::new();
    TABLES.get_or_init(SobolTables::build)
}

impl SobolTables {
    fn build() -> Self {
        let sets = (0..NUM_DIMENSION_SETS_4D)
            .map(|set| {
                let mut t: SetTable = [[[0; 4]; 16]; 4];
                for (k, position) in t.iter_mut().enumerate() {
                    for (v, entry) in position.iter_mut().enumerate() {
                        // The reversed index with only this nibble of its top 16 bits set.
                        let index_rev = (v as u32) << (28 - 4 * k);
                        *entry = [0, 1, 2, 3].map(|sub| sobol_rev(index_rev, set * 4 + sub));
                    }
                }
                t
            })
            .collect();
        #[cfg(target_arch = "x86_64")]
        let sse41 = is_x86_feature_detected!("sse4.1") && is_x86_feature_detected!("ssse3");
        #[cfg(not(target_arch = "x86_64"))]
        let sse41 = false;
        SobolTables { sets, sse41 }
    }

    /// The crate's shuffled (Owen-scrambled, bit-reversed) sample index under `seed`: the
    /// same for every dimension set, so a sample's stream computes it once
    /// (`PixelSampler`; the scalar bit reversal and hash were 3 % of the glass scene's
    /// instructions when every point redid them).
    #[inline]
    pub fn shuffled_index(sample_index: u32, seed: u32) -> u32 {
        owen_scramble_rev(sample_index.reverse_bits(), hash(seed ^ 0x79c68e4a))
    }

    /// `sobol_burley::sample_4d(sample_index, dimension_set, seed)`, bit for bit
    /// (`sample_index` < 2^16, `dimension_set` < `NUM_DIMENSION_SETS_4D`).
    #[inline]
    pub fn sample_4d(&self, sample_index: u32, dimension_set: u32, seed: u32) -> [f32; 4] {
        self.sample_4d_shuffled(Self::shuffled_index(sample_index, seed), dimension_set, seed)
    }

    /// [`sample_4d`](Self::sample_4d) from the index as [`shuffled_index`](Self::shuffled_index)
    /// gives it for `seed`.
    #[inline]
    pub fn sample_4d_shuffled(&self, rev: u32, dimension_set: u32, seed: u32) -> [f32; 4] {
        #[cfg(target_arch = "x86_64")]
        if self.sse41 {
            // SAFETY: the CPU has the features the function is compiled for.
            return unsafe { self.sample_4d_sse41(rev, dimension_set, seed) };
        }
        self.sample_4d_portable(rev, dimension_set, seed)
    }

    /// `sample_4d_shuffled` with the crate's own four-lane steps.
    #[inline]
    fn sample_4d_portable(&self, rev: u32, dimension_set: u32, seed: u32) -> [f32; 4] {
        let t = &self.sets[dimension_set as usize];
        let part = |k: usize| Int4::from(t[k][((rev >> (28 - 4 * k)) & 15) as usize]);
        let sobol = part(0) ^ part(1) ^ part(2) ^ part(3);
        // The crate's scramble values: the multiply keeps structured seeds from cancelling
        // against the dimension set.
        let scramble = Int4::from([seed.wrapping_mul(0x9c8f2d3b); 4])
            ^ Int4::from([dimension_set; 4])
            ^ Int4::from([0x912f69ba, 0x174f18ab, 0x691e72ca, 0xb40cc1b8]);
        owen_scramble_int4_rev(sobol, hash_int4(scramble)).reverse_bits().to_f32_norm()
    }

    /// `sample_4d_shuffled` on CPUs with SSE4.1 (checked at run time): the crate, built for plain
    /// x86_64, emulates its six four-lane multiplications with two 64-bit products, three
    /// shuffles and two masks each, and reverses bits in five shift-and-mask rounds
    /// (callgrind/perf: `next_4d` was 10.5 % of the glass scene's render). Here each
    /// product is one `pmulld` (the same wrapping product) and the bit reversal two nibble
    /// lookups and a byte shuffle: the same integers, so the same points bit for bit.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "sse4.1,ssse3")]
    fn sample_4d_sse41(&self, rev: u32, dimension_set: u32, seed: u32) -> [f32; 4] {
        use std::arch::x86_64::*;
        let t = &self.sets[dimension_set as usize];
        let part = |k: usize| {
            let entry = &t[k][((rev >> (28 - 4 * k)) & 15) as usize];
            // SAFETY: an unaligned 16-byte load of a [u32; 4].
            unsafe { _mm_loadu_si128(entry.as_ptr().cast()) }
        };
        let sobol = _mm_xor_si128(_mm_xor_si128(part(0), part(1)), _mm_xor_si128(part(2), part(3)));
        let c = |v: u32| _mm_set1_epi32(v as i32);
        let mul = |a: __m128i, v: u32| _mm_mullo_epi32(a, c(v));
        // hash_int4 of the crate's scramble values (see `sample_4d_portable`).
        let mut h = _mm_xor_si128(
            _mm_xor_si128(c(seed.wrapping_mul(0x9c8f2d3b)), c(dimension_set)),
            _mm_setr_epi32(0x912f69ba_u32 as i32, 0x174f18ab, 0x691e72ca, 0xb40cc1b8_u32 as i32),
        );
        h = _mm_xor_si128(h, c(0xe6fe3beb));
        h = _mm_xor_si128(h, _mm_srli_epi32::<16>(h));
        h = mul(h, 0x7feb352d);
        h = _mm_xor_si128(h, _mm_srli_epi32::<15>(h));
        h = mul(h, 0x846ca68b);
        h = _mm_xor_si128(h, _mm_srli_epi32::<16>(h));
        // owen_scramble_int4_rev(sobol, h).
        let mut n = _mm_xor_si128(sobol, mul(sobol, 0x3d20adea));
        n = _mm_add_epi32(n, h);
        n = _mm_mullo_epi32(n, _mm_or_si128(_mm_srli_epi32::<16>(h), c(1)));
        n = _mm_xor_si128(n, mul(n, 0x05526c56));
        n = _mm_xor_si128(n, mul(n, 0x53a22864));
        // Bit reversal per lane: bytes in reverse order, then each byte's nibbles swapped
        // and reversed through two 16-entry tables.
        let n = _mm_shuffle_epi8(n, _mm_setr_epi8(3, 2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12));
        let rev4 = _mm_setr_epi8(0, 8, 4, 12, 2, 10, 6, 14, 1, 9, 5, 13, 3, 11, 7, 15);
        let rev4_hi = _mm_slli_epi16::<4>(rev4);
        let low = _mm_and_si128(n, _mm_set1_epi8(15));
        let high = _mm_and_si128(_mm_srli_epi16::<4>(n), _mm_set1_epi8(15));
        let n = _mm_or_si128(_mm_shuffle_epi8(rev4_hi, low), _mm_shuffle_epi8(rev4, high));
        // to_f32_norm: the top 23 bits as a mantissa in [1, 2), minus 1.
        let f = _mm_sub_ps(_mm_castsi128_ps(_mm_or_si128(_mm_srli_epi32::<9>(n), c(0x3f800000))), _mm_set1_ps(1.0));
        let mut out = [0.0f32; 4];
        // SAFETY: an unaligned 16-byte store into a [f32; 4].
        unsafe { _mm_storeu_ps(out.as_mut_ptr(), f) };
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table form gives the crate's points bit for bit over every dimension set,
    /// many indices and seeds, on this CPU's path and on the portable one.
    #[test]
    fn equals_the_crate() {
        let tables = sobol_tables();
        let mut rng = crate::fuzz::Rng::new(5);
        for set in 0..NUM_DIMENSION_SETS_4D {
            for i in 0..64u32 {
                let index = if i < 32 { i } else { (rng.next_u64() as u32) & 0xffff };
                let seed = rng.next_u64() as u32;
                let want = sobol_burley::sample_4d(index, set, seed).map(f32::to_bits);
                assert_eq!(tables.sample_4d(index, set, seed).map(f32::to_bits), want, "set {set} index {index}");
                assert_eq!(
                    tables.sample_4d_portable(SobolTables::shuffled_index(index, seed), set, seed).map(f32::to_bits),
                    want,
                    "set {set} index {index}"
                );
            }
        }
    }
}
