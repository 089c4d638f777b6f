//! The Math node as Cycles computes it (`kernel/svm/math_util.h`): every operation with
//! Cycles' "safe" variants, which the vector and range operations reuse.

/// Math node operations (Blender's identifiers).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(missing_docs)]
pub enum MathOp {
    Add,
    Subtract,
    Multiply,
    Divide,
    MultiplyAdd,
    Power,
    Logarithm,
    Sqrt,
    InverseSqrt,
    Absolute,
    Exponent,
    Minimum,
    Maximum,
    LessThan,
    GreaterThan,
    Sign,
    Compare,
    SmoothMin,
    SmoothMax,
    Round,
    Floor,
    Ceil,
    Trunc,
    Fract,
    Modulo,
    FlooredModulo,
    Wrap,
    Snap,
    PingPong,
    Sine,
    Cosine,
    Tangent,
    Arcsine,
    Arccosine,
    Arctangent,
    Arctan2,
    Sinh,
    Cosh,
    Tanh,
    Radians,
    Degrees,
}

impl MathOp {
    /// From Blender's `operation` identifier.
    pub fn parse(s: &str) -> Option<Self> {
        use MathOp::*;
        Some(match s {
            "ADD" => Add,
            "SUBTRACT" => Subtract,
            "MULTIPLY" => Multiply,
            "DIVIDE" => Divide,
            "MULTIPLY_ADD" => MultiplyAdd,
            "POWER" => Power,
            "LOGARITHM" => Logarithm,
            "SQRT" => Sqrt,
            "INVERSE_SQRT" => InverseSqrt,
            "ABSOLUTE" => Absolute,
            "EXPONENT" => Exponent,
            "MINIMUM" => Minimum,
            "MAXIMUM" => Maximum,
            "LESS_THAN" => LessThan,
            "GREATER_THAN" => GreaterThan,
            "SIGN" => Sign,
            "COMPARE" => Compare,
            "SMOOTH_MIN" => SmoothMin,
            "SMOOTH_MAX" => SmoothMax,
            "ROUND" => Round,
            "FLOOR" => Floor,
            "CEIL" => Ceil,
            "TRUNC" => Trunc,
            "FRACT" => Fract,
            "MODULO" => Modulo,
            "FLOORED_MODULO" => FlooredModulo,
            "WRAP" => Wrap,
            "SNAP" => Snap,
            "PINGPONG" => PingPong,
            "SINE" => Sine,
            "COSINE" => Cosine,
            "TANGENT" => Tangent,
            "ARCSINE" => Arcsine,
            "ARCCOSINE" => Arccosine,
            "ARCTANGENT" => Arctangent,
            "ARCTAN2" => Arctan2,
            "SINH" => Sinh,
            "COSH" => Cosh,
            "TANH" => Tanh,
            "RADIANS" => Radians,
            "DEGREES" => Degrees,
            _ => return None,
        })
    }
}

/// a / b, 0 when b = 0.
#[inline]
pub fn safe_divide(a: f32, b: f32) -> f32 {
    if b != 0.0 { a / b } else { 0.0 }
}

/// fmod, 0 when b = 0.
#[inline]
pub fn safe_modulo(a: f32, b: f32) -> f32 {
    if b != 0.0 { a % b } else { 0.0 }
}

/// a - floor(a / b) b, 0 when b = 0.
#[inline]
pub fn safe_floored_modulo(a: f32, b: f32) -> f32 {
    if b != 0.0 { a - (a / b).floor() * b } else { 0.0 }
}

/// powf, 0 for a negative base with a non-integer exponent.
#[inline]
pub fn safe_powf(a: f32, b: f32) -> f32 {
    if a < 0.0 && !is_integer(b) { 0.0 } else { a.powf(b) }
}

/// `b == b.trunc()` without the call `trunc` is on baseline x86-64 (no SSE4.1 `roundss`; the
/// compiler evaluates it even for a positive base: 19 instructions a Power, callgrind). Below
/// 2²³ the cast truncates exactly; from 2²³ on every float is an integer, and so is ±∞; NaN
/// is not (NaN ≠ trunc(NaN)).
#[inline(always)]
fn is_integer(b: f32) -> bool {
    if b.abs() < 8_388_608.0 { (b as i32) as f32 == b } else { !b.is_nan() }
}

/// log_b(a), 0 outside the domain.
#[inline]
pub fn safe_logf(a: f32, b: f32) -> f32 {
    if a <= 0.0 || b <= 0.0 { 0.0 } else { safe_divide(a.ln(), b.ln()) }
}

/// Cycles' wrapf: value wrapped into [min, max).
#[inline]
pub fn wrapf(value: f32, max: f32, min: f32) -> f32 {
    let range = max - min;
    if range != 0.0 { value - range * ((value - min) / range).floor() } else { min }
}

/// Cycles' pingpongf.
#[inline]
pub fn pingpongf(a: f32, b: f32) -> f32 {
    if b != 0.0 {
        let x = (a - b) / (b * 2.0);
        ((x - x.floor()) * b * 2.0 - b).abs()
    } else {
        0.0
    }
}

/// Polynomial smooth minimum of radius c.
#[inline]
pub fn smoothminf(a: f32, b: f32, c: f32) -> f32 {
    if c != 0.0 {
        let h = (c - (a - b).abs()).max(0.0) / c;
        a.min(b) - h * h * h * c * (1.0 / 6.0)
    } else {
        a.min(b)
    }
}

/// Sign, 0 at 0.
#[inline]
pub fn compatible_signf(a: f32) -> f32 {
    if a == 0.0 {
        0.0
    } else if a > 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// The Math node.
pub fn math(op: MathOp, a: f32, b: f32, c: f32) -> f32 {
    math_inline(op, a, b, c)
}

/// The Math node at three points at once (the lanes of `bump_lanes`): one choice of the
/// operation, then the operation per lane, the same code as [`math`] (so the same bits).
/// Callgrind (`bench/node_graph.py`): `math` once per lane chose the operation three times.
#[inline]
pub fn math_lanes(op: MathOp, a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> [f32; 3] {
    use MathOp::*;
    // `math_inline` with the operation a constant: the `match` folds away in each arm.
    macro_rules! lanes {
        ($($name:ident),*) => {
            match op {
                $($name => core::array::from_fn(|k| math_inline($name, a[k], b[k], c[k])),)*
                _ => core::array::from_fn(|k| math_inline(op, a[k], b[k], c[k])),
            }
        };
    }
    lanes!(Add, Subtract, Multiply, Divide, MultiplyAdd, Power, Absolute, Minimum, Maximum, Sine, Cosine)
}

/// [`math`]'s body, inlined into [`math_lanes`] with a constant operation.
#[inline(always)]
fn math_inline(op: MathOp, a: f32, b: f32, c: f32) -> f32 {
    use MathOp::*;
    match op {
        Add => a + b,
        Subtract => a - b,
        Multiply => a * b,
        Divide => safe_divide(a, b),
        MultiplyAdd => a * b + c,
        Power => safe_powf(a, b),
        Logarithm => safe_logf(a, b),
        Sqrt => {
            if a > 0.0 {
                a.sqrt()
            } else {
                0.0
            }
        }
        InverseSqrt => {
            if a > 0.0 {
                1.0 / a.sqrt()
            } else {
                0.0
            }
        }
        Absolute => a.abs(),
        Exponent => a.exp(),
        Minimum => a.min(b),
        Maximum => a.max(b),
        LessThan => (a < b) as u8 as f32,
        GreaterThan => (a > b) as u8 as f32,
        Sign => compatible_signf(a),
        Compare => (a == b || (a - b).abs() <= c.max(f32::EPSILON)) as u8 as f32,
        SmoothMin => smoothminf(a, b, c),
        SmoothMax => -smoothminf(-a, -b, c),
        Round => (a + 0.5).floor(),
        Floor => a.floor(),
        Ceil => a.ceil(),
        Trunc => a.trunc(),
        Fract => a - a.floor(),
        Modulo => safe_modulo(a, b),
        FlooredModulo => safe_floored_modulo(a, b),
        Wrap => wrapf(a, b, c),
        Snap => safe_divide(a, b).floor() * b,
        PingPong => pingpongf(a, b),
        Sine => a.sin(),
        Cosine => a.cos(),
        Tangent => a.tan(),
        Arcsine => a.clamp(-1.0, 1.0).asin(),
        Arccosine => a.clamp(-1.0, 1.0).acos(),
        Arctangent => a.atan(),
        Arctan2 => a.atan2(b),
        Sinh => a.sinh(),
        Cosh => a.cosh(),
        Tanh => a.tanh(),
        Radians => a * (std::f32::consts::PI / 180.0),
        Degrees => a * (180.0 / std::f32::consts::PI),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values of Cycles' formulas computed by hand.
    #[test]
    fn math_against_hand_values() {
        use MathOp::*;
        let cases = [
            (Divide, 1.0, 0.0, 0.0, 0.0),
            (Power, -8.0, 1.0 / 3.0, 0.0, 0.0),
            (Power, -2.0, 3.0, 0.0, -8.0),
            (Logarithm, 8.0, 2.0, 0.0, 3.0),
            (Sqrt, -4.0, 0.0, 0.0, 0.0),
            (Modulo, -7.0, 3.0, 0.0, -1.0),
            (FlooredModulo, -7.0, 3.0, 0.0, 2.0),
            (Wrap, 5.5, 2.0, 1.0, 1.5),
            (PingPong, 3.0, 2.0, 0.0, 1.0),
            (Snap, 7.3, 2.0, 0.0, 6.0),
            (Round, -2.5, 0.0, 0.0, -2.0),
            (Trunc, -2.7, 0.0, 0.0, -2.0),
            (Compare, 1.0, 1.05, 0.1, 1.0),
            (Compare, 1.0, 1.2, 0.1, 0.0),
            // smooth min of 1 and 1.5 with radius 1: h = 0.5, 1 - 0.125/6.
            (SmoothMin, 1.0, 1.5, 1.0, 1.0 - 0.125 / 6.0),
            (SmoothMax, 1.0, 1.5, 1.0, 1.5 + 0.125 / 6.0),
            (Sign, -3.0, 0.0, 0.0, -1.0),
            (Arcsine, 2.0, 0.0, 0.0, std::f32::consts::FRAC_PI_2),
            (MultiplyAdd, 2.0, 3.0, 4.0, 10.0),
        ];
        for (op, a, b, c, want) in cases {
            let got = math(op, a, b, c);
            assert!((got - want).abs() < 1e-6, "{op:?}({a}, {b}, {c}) = {got}, want {want}");
        }
        assert!(MathOp::parse("FLOORED_MODULO").is_some() && MathOp::parse("NOPE").is_none());
    }

    /// `is_integer` is `b == b.trunc()` for every float class: around zero, halves, the
    /// 2²³ boundary, the largest floats, infinities and NaN.
    #[test]
    fn is_integer_is_trunc_equality() {
        let mut v = vec![0.0f32, -0.0, 0.5, -0.5, 1.0, -1.0, 2.5, 1e-40, -3.0e38, f32::MAX, f32::MIN, f32::INFINITY];
        v.extend([f32::NEG_INFINITY, f32::NAN, 8_388_607.5, 8_388_608.0, -8_388_607.5, 16_777_218.0, 2.0e9, 3.0e9]);
        v.extend((0..4000).map(|k| (k as f32 - 2000.0) * 0.37));
        for b in v {
            assert_eq!(is_integer(b), b == b.trunc(), "{b}");
        }
    }

    /// Every operation's Blender identifier.
    const ALL_OPS: [&str; 41] = [
        "ADD",
        "SUBTRACT",
        "MULTIPLY",
        "DIVIDE",
        "MULTIPLY_ADD",
        "POWER",
        "LOGARITHM",
        "SQRT",
        "INVERSE_SQRT",
        "ABSOLUTE",
        "EXPONENT",
        "MINIMUM",
        "MAXIMUM",
        "LESS_THAN",
        "GREATER_THAN",
        "SIGN",
        "COMPARE",
        "SMOOTH_MIN",
        "SMOOTH_MAX",
        "ROUND",
        "FLOOR",
        "CEIL",
        "TRUNC",
        "FRACT",
        "MODULO",
        "FLOORED_MODULO",
        "WRAP",
        "SNAP",
        "PINGPONG",
        "SINE",
        "COSINE",
        "TANGENT",
        "ARCSINE",
        "ARCCOSINE",
        "ARCTANGENT",
        "ARCTAN2",
        "SINH",
        "COSH",
        "TANH",
        "RADIANS",
        "DEGREES",
    ];

    /// `math_lanes` gives each lane `math`'s bits, for every operation (those with a lane
    /// arm and the rest), over values that reach each operation's special cases (zero,
    /// negative, fractional powers, large arguments, NaN-producing inputs).
    #[test]
    fn lanes_are_math_per_lane() {
        let values = [0.0f32, -0.0, 1.0, -2.5, 0.3, 7.75, -1.0e4, 3.0e8, 1.0e-30, f32::INFINITY, f32::NAN];
        let mut k = 0usize;
        let mut pick = || {
            k = (k * 7 + 3) % values.len();
            values[k]
        };
        for name in ALL_OPS {
            let op = MathOp::parse(name).expect("every listed name parses");
            for _ in 0..200 {
                let (a, b, c) = ([pick(), pick(), pick()], [pick(), pick(), pick()], [pick(), pick(), pick()]);
                let got = math_lanes(op, a, b, c).map(f32::to_bits);
                let want: [u32; 3] = core::array::from_fn(|l| math(op, a[l], b[l], c[l]).to_bits());
                assert_eq!(got, want, "{op:?}({a:?}, {b:?}, {c:?})");
            }
        }
    }
}
