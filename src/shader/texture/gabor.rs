//! Blender's Gabor Texture node (`svm/gabor.h`): sparse Gabor convolution noise (Lagae et al.
//! 2009) with eight impulses a cell of Bernoulli weights (Tavernier et al. 2019), read as a
//! phasor (Tricard et al. 2019) for its Phase and Intensity outputs.
//!
//! Each cell's impulses come from lookup3 hashes of the cell's float coordinates and the
//! impulse's index, as Cycles seeds them, so the pattern is Blender's to rounding of `sin`,
//! `cos` and `exp` (Rust's libm against the CUDA/CPU intrinsics Cycles calls).

use std::f32::consts::{PI, SQRT_2};

use glam::{Vec2, Vec3, Vec4};

use super::hash::{hash_vector3_to_float, hash_vector4_to_float};

/// Impulses a cell, Cycles' `IMPULSES_COUNT` (a constant count: stratified Poisson sampling).
const IMPULSES: i32 = 8;

/// The node's dimensions (`gabor_type`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GaborKind {
    /// 2D: the Vector's x and y, the Orientation angle.
    TwoD,
    /// 3D: the whole Vector, the Orientation direction.
    ThreeD,
}

/// The node's settings at a point.
#[derive(Clone, Copy, Debug)]
pub struct GaborParams {
    /// 2D or 3D.
    pub kind: GaborKind,
    /// Scale of the coordinates.
    pub scale: f32,
    /// Frequency of the kernels' waves (at least 0.001).
    pub frequency: f32,
    /// Anisotropy: 1 keeps every kernel at the orientation, 0 turns them at random.
    pub anisotropy: f32,
    /// Orientation angle of the 2D kind (radians).
    pub orientation_2d: f32,
    /// Orientation direction of the 3D kind (normalised here).
    pub orientation_3d: Vec3,
}

/// (Value, Phase, Intensity) of the Gabor node at `p`.
pub fn gabor_texture(p: Vec3, prm: &GaborParams) -> (f32, f32, f32) {
    let q = p * prm.scale;
    let isotropy = 1.0 - prm.anisotropy.clamp(0.0, 1.0);
    let frequency = prm.frequency.max(0.001);
    let (phasor, deviation) = match prm.kind {
        GaborKind::TwoD => (noise_2d(Vec2::new(q.x, q.y), frequency, isotropy, prm.orientation_2d), deviation_2d()),
        GaborKind::ThreeD => (noise_3d(q, frequency, isotropy, normalize(prm.orientation_3d)), deviation_3d()),
    };
    // Six standard deviations map to the unit range (Cycles' empirical normalisation).
    let norm = 6.0 * deviation;
    let value = (phasor.y / norm) * 0.5 + 0.5;
    let phase = (phasor.y.atan2(phasor.x) + PI) / (2.0 * PI);
    let intensity = phasor.length() / norm;
    (value, phase, intensity)
}

/// Cycles' `normalize`: a zero vector stays zero (no NaN).
fn normalize(v: Vec3) -> Vec3 {
    let l = v.length();
    if l != 0.0 { v / l } else { v }
}

/// The noise's standard deviation in 2D: √(impulses × ½ × ¼), the kernel's squared integral
/// at high frequency (¼) times a fair Bernoulli weight's second moment (½).
fn deviation_2d() -> f32 {
    (IMPULSES as f32 * 0.5 * 0.25).sqrt()
}

/// The same in 3D, whose squared integral tends to 1/(4√2).
fn deviation_3d() -> f32 {
    (IMPULSES as f32 * 0.5 * (1.0 / (4.0 * SQRT_2))).sqrt()
}

/// A Gaussian kernel windowed by Hann (C¹ at the unit radius), times the phasor of its wave
/// at `angle`: (real, imaginary).
#[inline]
fn kernel(distance_squared: f32, angle: f32) -> Vec2 {
    let hann = 0.5 + 0.5 * (PI * distance_squared).cos();
    let gaussian = (-PI * distance_squared).exp();
    gaussian * hann * Vec2::new(angle.cos(), angle.sin())
}

/// The sum over the 3×3 cells around `p` of their impulses' kernels.
fn noise_2d(p: Vec2, frequency: f32, isotropy: f32, base: f32) -> Vec2 {
    let cell = p.floor();
    let local = p - cell;
    let mut sum = Vec2::ZERO;
    for j in -1..=1 {
        for i in -1..=1 {
            let offset = Vec2::new(i as f32, j as f32);
            sum += cell_2d(cell + offset, local - offset, frequency, isotropy, base);
        }
    }
    sum
}

/// One cell's eight impulses at `position` (relative to the cell's corner).
fn cell_2d(cell: Vec2, position: Vec2, frequency: f32, isotropy: f32, base: f32) -> Vec2 {
    let mut noise = Vec2::ZERO;
    for i in 0..IMPULSES {
        let seed = |k: i32| Vec3::new(cell.x, cell.y, (i * 3 + k) as f32);
        // The random turn spans π: the kernel is symmetric under a half turn.
        let orientation = base + (hash_vector3_to_float(seed(0)) - 0.5) * PI * isotropy;
        let s = seed(1);
        let centre = Vec2::new(hash_vector3_to_float(s), hash_vector3_to_float(Vec3::new(s.z, s.x, s.y)));
        let d = position - centre;
        let d2 = d.dot(d);
        if d2 >= 1.0 {
            continue;
        }
        let weight = if hash_vector3_to_float(seed(2)) < 0.5 { -1.0 } else { 1.0 };
        let wave = frequency * Vec2::new(orientation.cos(), orientation.sin());
        noise += weight * kernel(d2, 2.0 * PI * d.dot(wave));
    }
    noise
}

/// The sum over the 3×3×3 cells around `p` of their impulses' kernels.
fn noise_3d(p: Vec3, frequency: f32, isotropy: f32, base: Vec3) -> Vec2 {
    let cell = p.floor();
    let local = p - cell;
    let mut sum = Vec2::ZERO;
    for k in -1..=1 {
        for j in -1..=1 {
            for i in -1..=1 {
                let offset = Vec3::new(i as f32, j as f32, k as f32);
                sum += cell_3d(cell + offset, local - offset, frequency, isotropy, base);
            }
        }
    }
    sum
}

/// The base direction turned at random by up to π in inclination and azimuth, times
/// the isotropy (Cycles' `compute_3d_orientation`).
fn orientation_3d(base: Vec3, isotropy: f32, seed: Vec4) -> Vec3 {
    if isotropy == 0.0 {
        return base;
    }
    let mut inclination = base.z.clamp(-1.0, 1.0).acos();
    let sign = if base.y < 0.0 { -1.0 } else { 1.0 };
    // Along ±Z the azimuth is undefined (Cycles divides 0 by 0 there and renders NaN): 0.
    let xy = Vec2::new(base.x, base.y).length();
    let mut azimuth = if xy > 0.0 { sign * (base.x / xy).clamp(-1.0, 1.0).acos() } else { 0.0 };
    let random =
        Vec2::new(hash_vector4_to_float(seed), hash_vector4_to_float(Vec4::new(seed.z, seed.x, seed.w, seed.y)));
    inclination += random.x * PI * isotropy;
    azimuth += random.y * PI * isotropy;
    let s = inclination.sin();
    Vec3::new(s * azimuth.cos(), s * azimuth.sin(), inclination.cos())
}

/// One 3D cell's eight impulses at `position` (relative to the cell's corner).
fn cell_3d(cell: Vec3, position: Vec3, frequency: f32, isotropy: f32, base: Vec3) -> Vec2 {
    let mut noise = Vec2::ZERO;
    for i in 0..IMPULSES {
        let seed = |k: i32| cell.extend((i * 3 + k) as f32);
        let orientation = orientation_3d(base, isotropy, seed(0));
        let s = seed(1);
        let centre = Vec3::new(
            hash_vector4_to_float(s),
            hash_vector4_to_float(Vec4::new(s.z, s.x, s.w, s.y)),
            hash_vector4_to_float(Vec4::new(s.w, s.z, s.y, s.x)),
        );
        let d = position - centre;
        let d2 = d.dot(d);
        if d2 >= 1.0 {
            continue;
        }
        let weight = if hash_vector4_to_float(seed(2)) < 0.5 { -1.0 } else { 1.0 };
        noise += weight * kernel(d2, 2.0 * PI * d.dot(frequency * orientation));
    }
    noise
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(kind: GaborKind, anisotropy: f32) -> GaborParams {
        GaborParams {
            kind,
            scale: 5.0,
            frequency: 2.0,
            anisotropy,
            orientation_2d: PI / 4.0,
            orientation_3d: Vec3::new(SQRT_2, SQRT_2, 0.0),
        }
    }

    /// Value, Phase and Intensity stay in their ranges and are finite over many points, for
    /// both kinds and every anisotropy, and the noise has (near) zero mean: Value's mean ½.
    #[test]
    fn outputs_are_finite_bounded_and_centred() {
        for kind in [GaborKind::TwoD, GaborKind::ThreeD] {
            for anisotropy in [0.0, 0.5, 1.0] {
                let prm = params(kind, anisotropy);
                let (mut sum, n) = (0.0f64, 4000);
                for k in 0..n {
                    let t = k as f32;
                    let p = Vec3::new(
                        (t * 0.6180339).fract() * 7.0,
                        (t * 0.7548776).fract() * 7.0,
                        (t * 0.5698403).fract() * 7.0,
                    );
                    let (v, ph, i) = gabor_texture(p, &prm);
                    assert!(v.is_finite() && ph.is_finite() && i.is_finite(), "{kind:?} {anisotropy}: {v} {ph} {i}");
                    assert!((0.0..=1.0).contains(&ph), "phase {ph}");
                    assert!(i >= 0.0, "intensity {i}");
                    sum += v as f64;
                }
                let mean = sum / n as f64;
                // Value is ½ + noise/(12σ): its standard deviation is 1/12, so the mean of 4000
                // correlated-but-spread points stays well within ±0.02 of ½.
                assert!((mean - 0.5).abs() < 0.02, "{kind:?} {anisotropy}: mean {mean}");
            }
        }
    }

    /// A zero orientation vector gives no NaN (Cycles' `normalize` keeps it zero).
    #[test]
    fn zero_orientation_is_finite() {
        let mut prm = params(GaborKind::ThreeD, 1.0);
        prm.orientation_3d = Vec3::ZERO;
        let (v, ph, i) = gabor_texture(Vec3::new(0.3, 0.2, 0.1), &prm);
        assert!(v.is_finite() && ph.is_finite() && i.is_finite());
    }
}
