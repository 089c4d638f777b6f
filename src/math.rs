//! Small geometric helpers shared by every module: frames, ray offsets, colour.

use glam::Vec3;

/// RGB radiance or reflectance in linear Rec.709.
pub type Rgb = Vec3;

/// Luminance of a linear Rec.709 colour (the weights Blender uses).
#[inline]
pub fn luminance(c: Rgb) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// An orthonormal basis whose `n` is the local +Z axis.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// Local X.
    pub s: Vec3,
    /// Local Y.
    pub t: Vec3,
    /// Local Z (the normal).
    pub n: Vec3,
}

impl Frame {
    /// A frame around a unit normal, without branches on the normal's sign
    /// (Duff et al. 2017, "Building an orthonormal basis, revisited").
    #[inline]
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// A frame from a normal and a tangent hint (Gram-Schmidt); falls back to
    /// `from_normal` when the tangent is parallel to the normal.
    #[inline]
    pub fn from_normal_tangent(n: Vec3, tangent: Vec3) -> Self {
        let s = tangent - n * n.dot(tangent);
        let len2 = s.length_squared();
        if !(len2 > 1e-12) {
            return Frame::from_normal(n);
        }
        let s = s / len2.sqrt();
        Frame { s, t: n.cross(s), n }
    }

    /// World to local.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local to world.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// Moves a ray origin off a surface along the geometric normal, by an amount that
/// grows with the magnitude of the coordinates, so that the new ray neither re-hits
/// the surface it leaves nor skips a nearby one (Wächter & Binder, Ray Tracing Gems, ch. 6).
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let of_i = [(INT_SCALE * n.x) as i32, (INT_SCALE * n.y) as i32, (INT_SCALE * n.z) as i32];
    let shift = |v: f32, o: i32| -> f32 {
        let bits = v.to_bits() as i32;
        f32::from_bits((bits + if v < 0.0 { -o } else { o }) as u32)
    };
    let p_i = Vec3::new(shift(p.x, of_i[0]), shift(p.y, of_i[1]), shift(p.z, of_i[2]));
    Vec3::new(
        if p.x.abs() < ORIGIN { p.x + FLOAT_SCALE * n.x } else { p_i.x },
        if p.y.abs() < ORIGIN { p.y + FLOAT_SCALE * n.y } else { p_i.y },
        if p.z.abs() < ORIGIN { p.z + FLOAT_SCALE * n.z } else { p_i.z },
    )
}

/// Hashes integers into a well-mixed 32-bit value (a PCG-style permutation), used to
/// derive independent per-pixel seeds.
#[inline]
pub fn hash_u32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// FNV-1a 64 of a byte string (stable across builds and platforms).
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    fnv1a64_from(0xcbf2_9ce4_8422_2325, bytes)
}

/// FNV-1a 64 continued from state `h`, for a hash over several byte strings.
pub fn fnv1a64_from(mut h: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// Combines several integers into one hash.
#[inline]
pub fn hash_combine(values: &[u32]) -> u32 {
    let mut h = 0x9e37_79b9u32;
    for &v in values {
        h = hash_u32(h ^ v.wrapping_add(0x9e37_79b9).wrapping_add(h << 6).wrapping_add(h >> 2));
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal() {
        for n in [Vec3::Z, -Vec3::Z, Vec3::X, Vec3::new(0.3, -0.5, 0.8).normalize()] {
            let f = Frame::from_normal(n);
            assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(f.n).abs() < 1e-5 && f.t.dot(f.n).abs() < 1e-5);
            assert!((f.s.cross(f.t) - f.n).length() < 1e-5, "right-handed");
            let v = Vec3::new(0.2, 0.4, -0.7);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn offset_moves_along_normal() {
        let p = Vec3::new(100.0, -3.0, 0.0);
        let n = Vec3::Y;
        let q = offset_ray_origin(p, n);
        assert!(q.y > p.y && q.x == p.x);
    }
}
