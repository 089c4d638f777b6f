//! The Vector Math node as Cycles computes it (`kernel/svm/math_util.h`).

use super::math::{compatible_signf, safe_divide, safe_modulo, safe_powf, wrapf};
use glam::Vec3;

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

/// `p` turned by `angle` counter-clockwise around the unit `axis` (Rodrigues' matrix written
/// out as Cycles' `rotate_around_axis`, term by term).
#[inline]
pub fn rotate_around_axis(p: Vec3, axis: Vec3, angle: f32) -> Vec3 {
    let (s, c) = angle.sin_cos();
    let t = 1.0 - c;
    Vec3::new(
        ((c + t * axis.x * axis.x) * p.x)
            + ((t * axis.x * axis.y - axis.z * s) * p.y)
            + ((t * axis.x * axis.z + axis.y * s) * p.z),
        ((t * axis.x * axis.y + axis.z * s) * p.x)
            + ((c + t * axis.y * axis.y) * p.y)
            + ((t * axis.y * axis.z - axis.x * s) * p.z),
        ((t * axis.x * axis.z - axis.y * s) * p.x)
            + ((t * axis.y * axis.z + axis.x * s) * p.y)
            + ((c + t * axis.z * axis.z) * p.z),
    )
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
