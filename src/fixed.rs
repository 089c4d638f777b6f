//! Exact, order-free sums of film samples: fixed-point integers instead of floats.
//!
//! Floating-point addition is not associative, so a sum taken in one order (one machine,
//! one thread) and the same values summed in pieces (chunks rendered on several machines,
//! splat buffers of several threads) differ in their last bits. Integer addition is
//! associative and commutative, so the film holds every sum as an `i128` counting units of
//! 2^-64:
//!
//! * **Conversion** ([`to_fixed`]): an f32 sample times 2^64 is exact in f64 (a power-of-two
//!   scale only moves the exponent; the f32's 24-bit mantissa fits f64's 53), and f64 → i128
//!   truncates towards zero. The truncation drops the part of the sample below 2^-64
//!   (≈ 5.4e-20), the same way for the same sample in every run and every order, so it
//!   never breaks the equality of a chunked and a single render.
//! * **Range**: a sample is accepted when |v| < 2^31 ([`MAX_SAMPLE`], ≈ 2.1e9, far above
//!   any radiance a camera sample carries: a sun disk of 1000 W/m² is ≈ 1.7e7); a pixel holds
//!   at most 2^32 samples (its counter is a u32), so |Σ| < 2^63 = i128::MAX · 2^-64: the sum
//!   never overflows. Samples beyond the range are dropped and counted with the non-finite
//!   ones (which stay rejected as before).
//! * **Additions** wrap (`wrapping_add`): with the bound above they never do, and a
//!   wrapping sum stays associative even if a light-tracing pixel collected more than the
//!   bound (then its value, not the agreement between runs, is wrong).
//! * **Back to floats** ([`from_fixed`]): i128 → f64 rounds to nearest, then × 2^-64 is
//!   exact; the mean is taken in f64 and rounded to f32 once, as before.

/// Units per 1.0 in a fixed-point sum: 2^64.
pub const SCALE: f64 = 18_446_744_073_709_551_616.0;

/// Largest magnitude (exclusive) of one sample that the sums accept: 2^31.
pub const MAX_SAMPLE: f32 = 2_147_483_648.0;

/// One sample in fixed point (truncated towards zero below 2^-64): the same value as
/// `(v as f64 * SCALE) as i128`, computed from the float's bits with integer shifts
/// (the float-to-i128 cast is a library call: with it the Cornell box at 96x72, 8 spp
/// took 7.0 % more instructions in BDPT than the f64 film, with this form 4.6 %; the path
/// tracer 2.5 % and 1.8 %). Callers check [`in_range`] first; magnitudes of 2^63 and
/// above saturate and NaN gives 0, deterministically.
#[inline]
pub fn to_fixed(v: f32) -> i128 {
    let bits = v.to_bits();
    let exp = ((bits >> 23) & 0xff) as i32;
    if exp == 0 {
        return 0; // zero or subnormal: below 2^-126, far under 2^-64
    }
    if exp == 0xff && bits & 0x7f_ffff != 0 {
        return 0; // NaN
    }
    // |v| = mant · 2^(exp − 150), so |v| · 2^64 = mant · 2^(exp − 86).
    let mant = ((bits & 0x7f_ffff) | 0x80_0000) as i128;
    let shift = exp - 86;
    let mag = if shift >= 104 {
        i128::MAX // mant < 2^24: from here on the product reaches 2^127
    } else if shift >= 0 {
        mant << shift
    } else if shift > -24 {
        mant >> -shift
    } else {
        0
    };
    if bits >> 31 != 0 { -mag } else { mag }
}

/// A fixed-point sum as f64 (rounded to nearest).
#[inline]
pub fn from_fixed(s: i128) -> f64 {
    s as f64 / SCALE
}

/// True when every component is finite and below [`MAX_SAMPLE`] in magnitude.
#[inline]
pub fn in_range(v: [f32; 3]) -> bool {
    v.iter().all(|x| x.abs() < MAX_SAMPLE) // false for NaN and ±inf
}

/// Adds a sample's three components to a fixed-point triple.
#[inline]
pub fn add3(acc: &mut [i128; 3], v: [f32; 3]) {
    for (a, x) in acc.iter_mut().zip(v) {
        *a = a.wrapping_add(to_fixed(x));
    }
}

/// Adds two fixed-point triples.
#[inline]
pub fn sum3(acc: &mut [i128; 3], o: &[i128; 3]) {
    for (a, x) in acc.iter_mut().zip(o) {
        *a = a.wrapping_add(*x);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sums in any grouping and order agree bit for bit; a float sum of the same values does not.
    #[test]
    fn sums_are_order_free() {
        let mut rng = crate::fuzz::Rng::new(3);
        let mut u = || (rng.next_u64() >> 40) as f32 / (1u32 << 24) as f32;
        // Values over twelve decades, where float sums lose the small ones differently per order.
        let vals: Vec<f32> = (0..10_000).map(|_| u() * 10f32.powi((u() * 12.0) as i32 - 6)).collect();
        let forward = vals.iter().fold(0i128, |s, &v| s.wrapping_add(to_fixed(v)));
        let backward = vals.iter().rev().fold(0i128, |s, &v| s.wrapping_add(to_fixed(v)));
        let (a, b) = vals.split_at(3_333);
        let chunks = b
            .iter()
            .fold(0i128, |s, &v| s.wrapping_add(to_fixed(v)))
            .wrapping_add(a.iter().fold(0i128, |s, &v| s.wrapping_add(to_fixed(v))));
        assert_eq!(forward, backward);
        assert_eq!(forward, chunks);
        // The exact sum is the f64 sum to within f64 rounding of 10^4 additions.
        let f: f64 = vals.iter().map(|&v| v as f64).sum();
        assert!((from_fixed(forward) - f).abs() <= f.abs() * 1e-12);
    }

    /// Conversion is exact for samples representable above 2^-64, truncates below.
    #[test]
    fn conversion_exact_and_truncating() {
        for v in [1.0f32, -1.0, 0.1, 3.5e-7, 1.0e9, -2.0e9] {
            assert_eq!(from_fixed(to_fixed(v)), v as f64);
        }
        assert_eq!(to_fixed(2f32.powi(-65)), 0);
        assert_eq!(to_fixed(-(2f32.powi(-65))), 0);
        assert_eq!(to_fixed(2f32.powi(-64)), 1);
        // The integer form equals the float cast it replaces, bit for bit, over the range.
        let mut rng = crate::fuzz::Rng::new(11);
        for _ in 0..200_000 {
            let v = f32::from_bits(rng.next_u64() as u32);
            if v.abs() < 2f32.powi(62) {
                assert_eq!(to_fixed(v), (v as f64 * SCALE) as i128, "{v:e}");
            }
        }
        assert_eq!(to_fixed(f32::NAN), 0);
        assert_eq!(to_fixed(f32::INFINITY), i128::MAX);
        assert_eq!(to_fixed(f32::NEG_INFINITY), -i128::MAX);
        assert!(!in_range([f32::NAN, 0.0, 0.0]));
        assert!(!in_range([0.0, f32::INFINITY, 0.0]));
        assert!(!in_range([0.0, 0.0, -MAX_SAMPLE]));
        assert!(in_range([0.0, 0.0, 2.0e9]));
    }
}
