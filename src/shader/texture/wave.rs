//! Blender's Wave Texture node (`svm/wave.h`): bands or rings with a sine, saw or triangle
//! profile, optionally distorted by fBM noise.

use core::f32::consts::{FRAC_PI_2, TAU};

use glam::Vec3;

use super::fractal::fbm;

/// The node's "Wave Type" setting.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WaveKind {
    Bands,
    Rings,
}

/// The node's direction: bands use X, Y, Z or Diagonal; rings use X, Y, Z or Spherical (a
/// direction the kind does not have is read as Diagonal for bands and Spherical for rings, the
/// branch Cycles falls through to).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WaveDirection {
    X,
    Y,
    Z,
    Diagonal,
    Spherical,
}

/// The node's "Wave Profile" setting.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WaveProfile {
    Sine,
    Saw,
    Tri,
}

/// The Wave node's settings and non-vector inputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WaveParams {
    /// Bands or rings.
    pub kind: WaveKind,
    /// The bands' or rings' axis.
    pub direction: WaveDirection,
    /// The shape of one period.
    pub profile: WaveProfile,
    /// Multiplies the vector.
    pub scale: f32,
    /// Strength of the fBM added to the phase (0: none).
    pub distortion: f32,
    /// fBM octaves after the first.
    pub detail: f32,
    /// fBM frequency relative to the scaled vector.
    pub detail_scale: f32,
    /// fBM amplitude ratio between octaves.
    pub detail_roughness: f32,
    /// Added to the phase, in radians.
    pub phase_offset: f32,
}

/// (Fac, Color) of the Wave node; Color is `(Fac, Fac, Fac)`.
#[inline]
pub fn wave_texture(p: Vec3, prm: &WaveParams) -> (f32, Vec3) {
    // Cycles nudges the coordinates off unit values to avoid precision issues there.
    let p = (p * prm.scale + Vec3::splat(0.000001)) * 0.999999;
    let mut n = match prm.kind {
        WaveKind::Bands => match prm.direction {
            WaveDirection::X => p.x * 20.0,
            WaveDirection::Y => p.y * 20.0,
            WaveDirection::Z => p.z * 20.0,
            WaveDirection::Diagonal | WaveDirection::Spherical => (p.x + p.y + p.z) * 10.0,
        },
        WaveKind::Rings => {
            let rp = match prm.direction {
                WaveDirection::X => p * Vec3::new(0.0, 1.0, 1.0),
                WaveDirection::Y => p * Vec3::new(1.0, 0.0, 1.0),
                WaveDirection::Z => p * Vec3::new(1.0, 1.0, 0.0),
                WaveDirection::Diagonal | WaveDirection::Spherical => p,
            };
            (rp.x * rp.x + rp.y * rp.y + rp.z * rp.z).sqrt() * 20.0
        }
    };
    n += prm.phase_offset;
    if prm.distortion != 0.0 {
        // Cycles passes detail unclamped: a detail of 1e9 would loop 1e9 octaves. Clamping to
        // the socket's range [0, 15] (as the Noise node does) changes nothing inside it.
        let detail = prm.detail.clamp(0.0, 15.0);
        let noise = fbm(p * prm.detail_scale, detail, prm.detail_roughness, 2.0, true);
        n += prm.distortion * (noise * 2.0 - 1.0);
    }
    let fac = match prm.profile {
        WaveProfile::Sine => 0.5 + 0.5 * (n - FRAC_PI_2).sin(),
        WaveProfile::Saw => {
            let n = n / TAU;
            n - n.floor()
        }
        WaveProfile::Tri => {
            let n = n / TAU;
            (n - (n + 0.5).floor()).abs() * 2.0
        }
    };
    (fac, Vec3::splat(fac))
}
