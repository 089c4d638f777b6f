//! `floor` and Cycles' `fmod(x, 100000)` precision fix, bit for bit as the library's, without
//! the library call: built for baseline x86-64 (no SSE4.1 `roundss`), `f32::floor` and `%`
//! are calls into libm that cost about 23 instructions each, and Perlin noise takes three of
//! each per lookup (a third of `perlin_3d` in the profile of `bench/node_graph.py`).

/// Below this magnitude an f32 may have a fraction (2^23: from there on every f32 is an integer).
const INTEGRAL_FROM: f32 = 8_388_608.0;

/// `x.floor()`, identical for every input (signed zeros, NaN and infinities included).
#[inline(always)]
pub fn floor(x: f32) -> f32 {
    if x.abs() < INTEGRAL_FROM {
        // Truncation toward zero is exact here; one step down for negative fractions. The
        // floor of x has x's sign (floor(-0.0) = -0.0, floor(-0.5) = -1), so copysign
        // restores the zero's sign that the integer round trip lost.
        let t = x as i32 as f32;
        let f = if t > x { t - 1.0 } else { t };
        f.copysign(x)
    } else {
        // Integral already, or NaN: floor returns it unchanged.
        x
    }
}

/// `x % m` for m > 0 finite (C's `fmod`), identical for every x: the remainder of |x| < m is x
/// itself (fmod is exact and keeps the sign), which is the common case that skips the call.
#[inline(always)]
pub fn fmod_pos(x: f32, m: f32) -> f32 {
    if x.abs() < m { x } else { fmod_call(x, m) }
}

/// The library `fmod`, out of line. LLVM may execute a `frem` on both sides of a branch (it
/// cannot trap), and did: callgrind showed `fmodf` called for two of the three axes of every
/// Perlin lookup of `bench/node_graph.py` (921,600 calls, 25.8 M instructions, 4 % of the
/// render) although every coordinate there is below 100000. A call to a cold function is
/// not speculated.
#[cold]
#[inline(never)]
fn fmod_call(x: f32, m: f32) -> f32 {
    x % m
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Inputs around every boundary: zeros, fractions, integers, the 2^23 edge, large values,
    /// infinities, NaN, subnormals, plus a sweep of bit patterns.
    fn samples() -> Vec<f32> {
        let mut v = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            0.999_999_94,
            -0.999_999_94,
            1e-45,
            -1e-45,
            8_388_607.5,
            -8_388_607.5,
            8_388_608.0,
            -8_388_608.0,
            16_777_217.0,
            99_999.99,
            100_000.0,
            -100_000.0,
            100_000.01,
            -250_000.3,
            3e38,
            -3e38,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MAX,
            f32::MIN,
        ];
        // Every 9973rd bit pattern (both signs, all exponents).
        v.extend((0..u32::MAX / 9973).map(|k| f32::from_bits(k.wrapping_mul(9973))));
        v
    }

    #[test]
    fn floor_is_the_library_floor_bit_for_bit() {
        for x in samples() {
            let (a, b) = (floor(x), x.floor());
            assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()), "floor({x:e}): {a:e} != {b:e}");
        }
    }

    #[test]
    fn fmod_is_the_library_fmod_bit_for_bit() {
        for x in samples() {
            let (a, b) = (fmod_pos(x, 100_000.0), x % 100_000.0);
            assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()), "fmod({x:e}): {a:e} != {b:e}");
        }
    }
}
