//! The pure functions of Blender's converter nodes, as Cycles computes them
//! (`kernel/svm/math_util.h`, `color_util.h`, `map_range.h`, `util/color.h`): Math and
//! Vector Math (every operation, with Cycles' "safe" variants), the colour blend modes,
//! Map Range, colour-space conversions (HSV, HSL), Hue/Saturation/Value.

use glam::Vec3;

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
    if a < 0.0 && b != b.trunc() { 0.0 } else { a.powf(b) }
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

/// Vector Math node operations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(missing_docs)]
pub enum VecOp {
    Add,
    Subtract,
    Multiply,
    Divide,
    MultiplyAdd,
    Cross,
    Project,
    Reflect,
    Refract,
    Faceforward,
    Dot,
    Distance,
    Length,
    Scale,
    Normalize,
    Absolute,
    Power,
    Sign,
    Minimum,
    Maximum,
    Floor,
    Ceil,
    Fraction,
    Modulo,
    Wrap,
    Snap,
    Sine,
    Cosine,
    Tangent,
}

impl VecOp {
    /// From Blender's `operation` identifier.
    pub fn parse(s: &str) -> Option<Self> {
        use VecOp::*;
        Some(match s {
            "ADD" => Add,
            "SUBTRACT" => Subtract,
            "MULTIPLY" => Multiply,
            "DIVIDE" => Divide,
            "MULTIPLY_ADD" => MultiplyAdd,
            "CROSS_PRODUCT" => Cross,
            "PROJECT" => Project,
            "REFLECT" => Reflect,
            "REFRACT" => Refract,
            "FACEFORWARD" => Faceforward,
            "DOT_PRODUCT" => Dot,
            "DISTANCE" => Distance,
            "LENGTH" => Length,
            "SCALE" => Scale,
            "NORMALIZE" => Normalize,
            "ABSOLUTE" => Absolute,
            "POWER" => Power,
            "SIGN" => Sign,
            "MINIMUM" => Minimum,
            "MAXIMUM" => Maximum,
            "FLOOR" => Floor,
            "CEIL" => Ceil,
            "FRACTION" => Fraction,
            "MODULO" => Modulo,
            "WRAP" => Wrap,
            "SNAP" => Snap,
            "SINE" => Sine,
            "COSINE" => Cosine,
            "TANGENT" => Tangent,
            _ => return None,
        })
    }

    /// True when the result is the Value output (else the Vector output).
    pub fn gives_value(self) -> bool {
        matches!(self, VecOp::Dot | VecOp::Distance | VecOp::Length)
    }
}

/// a / |a|, zero for the zero vector.
#[inline]
pub fn safe_normalize(a: Vec3) -> Vec3 {
    let l = a.length();
    if l > 0.0 { a / l } else { Vec3::ZERO }
}

fn per(a: Vec3, b: Vec3, f: impl Fn(f32, f32) -> f32) -> Vec3 {
    Vec3::new(f(a.x, b.x), f(a.y, b.y), f(a.z, b.z))
}

/// The Vector Math node: (vector, value).
pub fn vector_math(op: VecOp, a: Vec3, b: Vec3, c: Vec3, scale: f32) -> (Vec3, f32) {
    use VecOp::*;
    let v = match op {
        Add => a + b,
        Subtract => a - b,
        Multiply => a * b,
        Divide => per(a, b, safe_divide),
        MultiplyAdd => a * b + c,
        Cross => a.cross(b),
        Project => {
            let l2 = b.length_squared();
            if l2 != 0.0 { b * (a.dot(b) / l2) } else { Vec3::ZERO }
        }
        Reflect => {
            let n = safe_normalize(b);
            a - 2.0 * n * a.dot(n)
        }
        Refract => {
            let n = safe_normalize(b);
            let d = n.dot(a);
            let k = 1.0 - scale * scale * (1.0 - d * d);
            if k < 0.0 { Vec3::ZERO } else { scale * a - (scale * d + k.sqrt()) * n }
        }
        Faceforward => {
            if c.dot(b) < 0.0 {
                a
            } else {
                -a
            }
        }
        Dot => return (Vec3::ZERO, a.dot(b)),
        Distance => return (Vec3::ZERO, a.distance(b)),
        Length => return (Vec3::ZERO, a.length()),
        Scale => a * scale,
        Normalize => safe_normalize(a),
        Absolute => a.abs(),
        Power => per(a, b, safe_powf),
        Sign => Vec3::new(compatible_signf(a.x), compatible_signf(a.y), compatible_signf(a.z)),
        Minimum => a.min(b),
        Maximum => a.max(b),
        Floor => a.floor(),
        Ceil => a.ceil(),
        Fraction => a - a.floor(),
        Modulo => per(a, b, safe_modulo),
        Wrap => Vec3::new(wrapf(a.x, b.x, c.x), wrapf(a.y, b.y, c.y), wrapf(a.z, b.z, c.z)),
        Snap => per(a, b, safe_divide).floor() * b,
        Sine => Vec3::new(a.x.sin(), a.y.sin(), a.z.sin()),
        Cosine => Vec3::new(a.x.cos(), a.y.cos(), a.z.cos()),
        Tangent => Vec3::new(a.x.tan(), a.y.tan(), a.z.tan()),
    };
    (v, 0.0)
}

/// Colour blend modes of the Mix node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(missing_docs)]
pub enum Blend {
    Mix,
    Add,
    Multiply,
    Subtract,
    Screen,
    Divide,
    Difference,
    Exclusion,
    Darken,
    Lighten,
    Overlay,
    Dodge,
    Burn,
    Hue,
    Saturation,
    Value,
    Color,
    SoftLight,
    LinearLight,
}

impl Blend {
    /// From Blender's `blend_type` identifier.
    pub fn parse(s: &str) -> Option<Self> {
        use Blend::*;
        Some(match s {
            "MIX" => Mix,
            "ADD" => Add,
            "MULTIPLY" => Multiply,
            "SUBTRACT" => Subtract,
            "SCREEN" => Screen,
            "DIVIDE" => Divide,
            "DIFFERENCE" => Difference,
            "EXCLUSION" => Exclusion,
            "DARKEN" => Darken,
            "LIGHTEN" => Lighten,
            "OVERLAY" => Overlay,
            "DODGE" => Dodge,
            "BURN" => Burn,
            "HUE" => Hue,
            "SATURATION" => Saturation,
            "VALUE" => Value,
            "COLOR" => Color,
            "SOFT_LIGHT" => SoftLight,
            "LINEAR_LIGHT" => LinearLight,
            _ => return None,
        })
    }
}

#[inline]
fn lerp3(a: Vec3, b: Vec3, t: f32) -> Vec3 {
    a * (1.0 - t) + b * t
}

/// Cycles' `svm_mix` of two colours with factor t (not clamped here).
pub fn blend(mode: Blend, t: f32, c1: Vec3, c2: Vec3) -> Vec3 {
    let tm = 1.0 - t;
    let ch = |f: &dyn Fn(f32, f32) -> f32| Vec3::new(f(c1.x, c2.x), f(c1.y, c2.y), f(c1.z, c2.z));
    match mode {
        Blend::Mix => lerp3(c1, c2, t),
        Blend::Add => lerp3(c1, c1 + c2, t),
        Blend::Multiply => lerp3(c1, c1 * c2, t),
        Blend::Subtract => lerp3(c1, c1 - c2, t),
        Blend::Screen => Vec3::ONE - (Vec3::splat(tm) + t * (Vec3::ONE - c2)) * (Vec3::ONE - c1),
        Blend::Divide => ch(&|a, b| if b != 0.0 { tm * a + t * a / b } else { a }),
        Blend::Difference => lerp3(c1, (c1 - c2).abs(), t),
        Blend::Exclusion => lerp3(c1, c1 + c2 - 2.0 * c1 * c2, t).max(Vec3::ZERO),
        Blend::Darken => lerp3(c1, c1.min(c2), t),
        Blend::Lighten => lerp3(c1, c1.max(c2), t),
        Blend::Overlay => ch(&|a, b| {
            if a < 0.5 { a * (tm + 2.0 * t * b) } else { 1.0 - (tm + 2.0 * t * (1.0 - b)) * (1.0 - a) }
        }),
        Blend::Dodge => ch(&|a, b| {
            if a == 0.0 {
                return a;
            }
            let tmp = 1.0 - t * b;
            if tmp <= 0.0 { 1.0 } else { (a / tmp).min(1.0) }
        }),
        Blend::Burn => ch(&|a, b| {
            let tmp = tm + t * b;
            if tmp <= 0.0 { 0.0 } else { (1.0 - (1.0 - a) / tmp).clamp(0.0, 1.0) }
        }),
        Blend::Hue => {
            let hsv2 = rgb_to_hsv(c2);
            if hsv2.y != 0.0 {
                let mut hsv = rgb_to_hsv(c1);
                hsv.x = hsv2.x;
                lerp3(c1, hsv_to_rgb(hsv), t)
            } else {
                c1
            }
        }
        Blend::Saturation => {
            let mut hsv = rgb_to_hsv(c1);
            if hsv.y != 0.0 {
                let hsv2 = rgb_to_hsv(c2);
                hsv.y = tm * hsv.y + t * hsv2.y;
                hsv_to_rgb(hsv)
            } else {
                c1
            }
        }
        Blend::Value => {
            let mut hsv = rgb_to_hsv(c1);
            let hsv2 = rgb_to_hsv(c2);
            hsv.z = tm * hsv.z + t * hsv2.z;
            hsv_to_rgb(hsv)
        }
        Blend::Color => {
            let hsv2 = rgb_to_hsv(c2);
            if hsv2.y != 0.0 {
                let mut hsv = rgb_to_hsv(c1);
                hsv.x = hsv2.x;
                hsv.y = hsv2.y;
                lerp3(c1, hsv_to_rgb(hsv), t)
            } else {
                c1
            }
        }
        Blend::SoftLight => {
            let scr = Vec3::ONE - (Vec3::ONE - c2) * (Vec3::ONE - c1);
            tm * c1 + t * ((Vec3::ONE - c1) * c2 * c1 + c1 * scr)
        }
        Blend::LinearLight => c1 + t * (2.0 * c2 - Vec3::ONE),
    }
}

/// Blender's RGB → HSV.
pub fn rgb_to_hsv(rgb: Vec3) -> Vec3 {
    let cmax = rgb.max_element();
    let cmin = rgb.min_element();
    let cdelta = cmax - cmin;
    let v = cmax;
    let (mut h, s);
    if cmax != 0.0 {
        s = cdelta / cmax;
    } else {
        s = 0.0;
    }
    if s != 0.0 {
        let c = (Vec3::splat(cmax) - rgb) / cdelta;
        h = if rgb.x == cmax {
            c.z - c.y
        } else if rgb.y == cmax {
            2.0 + c.x - c.z
        } else {
            4.0 + c.y - c.x
        };
        h /= 6.0;
        if h < 0.0 {
            h += 1.0;
        }
    } else {
        h = 0.0;
    }
    Vec3::new(h, s, v)
}

/// Blender's HSV → RGB.
pub fn hsv_to_rgb(hsv: Vec3) -> Vec3 {
    let (mut h, s, v) = (hsv.x, hsv.y, hsv.z);
    if s == 0.0 {
        return Vec3::splat(v);
    }
    if h == 1.0 {
        h = 0.0;
    }
    h *= 6.0;
    let i = h.floor();
    let f = h - i;
    let p = v * (1.0 - s);
    let q = v * (1.0 - s * f);
    let t = v * (1.0 - s * (1.0 - f));
    match i as i32 {
        0 => Vec3::new(v, t, p),
        1 => Vec3::new(q, v, p),
        2 => Vec3::new(p, v, t),
        3 => Vec3::new(p, q, v),
        4 => Vec3::new(t, p, v),
        _ => Vec3::new(v, p, q),
    }
}

/// Blender's RGB → HSL.
pub fn rgb_to_hsl(rgb: Vec3) -> Vec3 {
    let cmax = rgb.max_element();
    let cmin = rgb.min_element();
    let l = (cmax + cmin) / 2.0;
    if cmax == cmin {
        return Vec3::new(0.0, 0.0, l);
    }
    let d = cmax - cmin;
    let s = if l > 0.5 { d / (2.0 - cmax - cmin) } else { d / (cmax + cmin) };
    let h = if cmax == rgb.x {
        (rgb.y - rgb.z) / d + if rgb.y < rgb.z { 6.0 } else { 0.0 }
    } else if cmax == rgb.y {
        (rgb.z - rgb.x) / d + 2.0
    } else {
        (rgb.x - rgb.y) / d + 4.0
    };
    Vec3::new(h / 6.0, s, l)
}

/// Blender's HSL → RGB.
pub fn hsl_to_rgb(hsl: Vec3) -> Vec3 {
    let (h, s, l) = (hsl.x, hsl.y, hsl.z);
    let nr = (h * 6.0 - 3.0).abs() - 1.0;
    let ng = 2.0 - (h * 6.0 - 2.0).abs();
    let nb = 2.0 - (h * 6.0 - 4.0).abs();
    let n = Vec3::new(nr, ng, nb).clamp(Vec3::ZERO, Vec3::ONE);
    let chroma = (1.0 - (2.0 * l - 1.0).abs()) * s;
    (n - 0.5) * chroma + Vec3::splat(l)
}

/// The Hue/Saturation/Value node.
pub fn hue_sat_val(color: Vec3, hue: f32, sat: f32, val: f32, fac: f32) -> Vec3 {
    let mut hsv = rgb_to_hsv(color);
    let h = hsv.x + hue + 0.5;
    hsv.x = h - h.floor();
    hsv.y = (hsv.y * sat).clamp(0.0, 1.0);
    hsv.z *= val;
    let c = hsv_to_rgb(hsv);
    (c * fac + color * (1.0 - fac)).max(Vec3::ZERO)
}

/// Map Range interpolations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(missing_docs)]
pub enum RangeInterp {
    Linear,
    Stepped,
    SmoothStep,
    SmootherStep,
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    if x <= e0 {
        0.0
    } else if x >= e1 {
        1.0
    } else {
        let t = (x - e0) / (e1 - e0);
        (3.0 - 2.0 * t) * t * t
    }
}

fn smootherstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = safe_divide(x - e0, e1 - e0).clamp(0.0, 1.0);
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// The float Map Range node (Cycles' `svm_node_map_range`).
#[allow(clippy::too_many_arguments)]
pub fn map_range(
    interp: RangeInterp,
    value: f32,
    from_min: f32,
    from_max: f32,
    to_min: f32,
    to_max: f32,
    steps: f32,
    clamp: bool,
) -> f32 {
    let factor = match interp {
        RangeInterp::Linear => safe_divide(value - from_min, from_max - from_min),
        RangeInterp::Stepped => {
            let f = safe_divide(value - from_min, from_max - from_min);
            if steps > 0.0 { (f * (steps + 1.0)).floor() / steps } else { 0.0 }
        }
        RangeInterp::SmoothStep => {
            if from_min > from_max {
                1.0 - smoothstep(from_max, from_min, value)
            } else {
                smoothstep(from_min, from_max, value)
            }
        }
        RangeInterp::SmootherStep => {
            if from_min > from_max {
                1.0 - smootherstep(from_max, from_min, value)
            } else {
                smootherstep(from_min, from_max, value)
            }
        }
    };
    let mut r = to_min + factor * (to_max - to_min);
    if clamp && matches!(interp, RangeInterp::Linear | RangeInterp::Stepped) {
        r = if to_min > to_max { r.clamp(to_max, to_min) } else { r.clamp(to_min, to_max) };
    }
    r
}

/// Gamma as Cycles: channels above 0 raised to the power; gamma 0 gives white.
pub fn gamma(c: Vec3, g: f32) -> Vec3 {
    if g == 0.0 {
        return Vec3::ONE;
    }
    let f = |x: f32| if x > 0.0 { x.powf(g) } else { x };
    Vec3::new(f(c.x), f(c.y), f(c.z))
}

/// Bright/Contrast as Cycles.
pub fn bright_contrast(c: Vec3, bright: f32, contrast: f32) -> Vec3 {
    let a = 1.0 + contrast;
    let b = bright - contrast * 0.5;
    (a * c + Vec3::splat(b)).max(Vec3::ZERO)
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

    #[test]
    fn vector_math_against_hand_values() {
        let a = Vec3::new(1.0, -2.0, 3.0);
        let b = Vec3::new(0.0, 0.0, 2.0);
        assert_eq!(vector_math(VecOp::Divide, a, b, Vec3::ZERO, 0.0).0, Vec3::new(0.0, 0.0, 1.5));
        assert_eq!(vector_math(VecOp::Project, a, b, Vec3::ZERO, 0.0).0, Vec3::new(0.0, 0.0, 3.0));
        assert_eq!(vector_math(VecOp::Reflect, a, b, Vec3::ZERO, 0.0).0, Vec3::new(1.0, -2.0, -3.0));
        assert_eq!(vector_math(VecOp::Dot, a, b, Vec3::ZERO, 0.0).1, 6.0);
        assert_eq!(vector_math(VecOp::Snap, a, Vec3::splat(2.0), Vec3::ZERO, 0.0).0, Vec3::new(0.0, -2.0, 2.0));
        // Refraction straight through at η = 1 keeps the direction.
        let d = Vec3::new(0.0, 0.0, -1.0);
        let r = vector_math(VecOp::Refract, d, Vec3::Z, Vec3::ZERO, 1.0).0;
        assert!((r - d).length() < 1e-6, "{r}");
        assert_eq!(vector_math(VecOp::Faceforward, a, Vec3::Z, -Vec3::Z, 0.0).0, a);
        assert_eq!(vector_math(VecOp::Wrap, Vec3::splat(5.5), Vec3::splat(2.0), Vec3::ONE, 0.0).0, Vec3::splat(1.5));
    }

    #[test]
    fn blends_against_hand_values() {
        let c1 = Vec3::new(0.2, 0.6, 1.0);
        let c2 = Vec3::new(0.5, 0.5, 0.0);
        let near = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 1e-6;
        assert!(near(blend(Blend::Mix, 0.5, c1, c2), Vec3::new(0.35, 0.55, 0.5)));
        assert!(near(blend(Blend::Add, 0.5, c1, c2), Vec3::new(0.45, 0.85, 1.0)));
        assert!(near(blend(Blend::Multiply, 1.0, c1, c2), Vec3::new(0.1, 0.3, 0.0)));
        // Screen at t = 1: 1 - (1 - c2)(1 - c1).
        assert!(near(blend(Blend::Screen, 1.0, c1, c2), Vec3::new(0.6, 0.8, 1.0)));
        // Overlay at t = 1: 2 c1 c2 below 0.5, else 1 - 2 (1 - c2)(1 - c1).
        assert!(near(blend(Blend::Overlay, 1.0, c1, c2), Vec3::new(0.2, 0.6, 1.0)));
        assert!(near(blend(Blend::Divide, 1.0, c1, c2), Vec3::new(0.4, 1.2, 1.0)));
        assert!(near(blend(Blend::LinearLight, 1.0, c1, c2), Vec3::new(0.2, 0.6, 0.0)));
        // Dodge: c1 / (1 - t c2), capped at 1.
        assert!(near(blend(Blend::Dodge, 1.0, c1, c2), Vec3::new(0.4, 1.0, 1.0)));
        // Burn: 1 - (1 - c1) / (tm + t c2), in [0, 1].
        assert!(near(blend(Blend::Burn, 1.0, c1, c2), Vec3::new(0.0, 0.2, 0.0)));
        // Value: V of c2 replaces that of c1 (both have V 0.5 and 1): c1 × 0.5.
        assert!(near(blend(Blend::Value, 1.0, c1, c2), c1 * 0.5));
    }

    #[test]
    fn colour_spaces_round_trip() {
        for c in [Vec3::new(0.2, 0.6, 1.0), Vec3::new(0.9, 0.1, 0.3), Vec3::new(0.5, 0.5, 0.2)] {
            assert!((hsv_to_rgb(rgb_to_hsv(c)) - c).abs().max_element() < 1e-5);
            assert!((hsl_to_rgb(rgb_to_hsl(c)) - c).abs().max_element() < 1e-5);
        }
        // Pure red: hue 0, saturation 1.
        assert_eq!(rgb_to_hsv(Vec3::X), Vec3::new(0.0, 1.0, 1.0));
        // Hue shift by half a turn turns red into cyan.
        let c = hue_sat_val(Vec3::X, 1.0, 1.0, 1.0, 1.0);
        assert!((c - Vec3::new(0.0, 1.0, 1.0)).abs().max_element() < 1e-6, "{c}");
    }

    #[test]
    fn map_range_against_hand_values() {
        use RangeInterp::*;
        assert_eq!(map_range(Linear, 0.25, 0.0, 1.0, 10.0, 20.0, 4.0, true), 12.5);
        assert_eq!(map_range(Linear, 2.0, 0.0, 1.0, 10.0, 20.0, 4.0, true), 20.0);
        assert_eq!(map_range(Linear, 2.0, 0.0, 1.0, 10.0, 20.0, 4.0, false), 30.0);
        // Stepped with 4 steps: floor(0.3 × 5) / 4 = 0.25.
        assert_eq!(map_range(Stepped, 0.3, 0.0, 1.0, 0.0, 1.0, 4.0, false), 0.25);
        // Smoothstep at 0.25: 3t² - 2t³ = 0.15625.
        assert!((map_range(SmoothStep, 0.25, 0.0, 1.0, 0.0, 1.0, 0.0, false) - 0.15625).abs() < 1e-6);
        // Smootherstep at 0.25: 6t⁵ - 15t⁴ + 10t³ = 0.103515625.
        assert!((map_range(SmootherStep, 0.25, 0.0, 1.0, 0.0, 1.0, 0.0, false) - 0.103_515_63).abs() < 1e-6);
    }
}
