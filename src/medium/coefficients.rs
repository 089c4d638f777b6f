//! What a volume shader gives at a point: the Principled Volume's parameters and the
//! coefficients they make. Shared by the grid media (`grid.rs`) and the node-graph volumes
//! (`procedural_source.rs`), below both.

use crate::math::Rgb;

/// The Principled Volume's parameters (after the add-on's conversion of the other volume
/// nodes; docs/contract.md).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeShader {
    /// Density multiplier.
    pub density: f32,
    /// Scattering colour.
    pub color: Rgb,
    /// Absorption Color as Blender has it (the σa factor is max(1 − √c, 0)).
    pub absorption_color: Rgb,
    /// Henyey-Greenstein anisotropy.
    pub anisotropy: f32,
    /// Emission Strength × Emission Color (per unit length).
    pub emission: Rgb,
    /// Blackbody Intensity.
    pub blackbody_intensity: f32,
    /// Blackbody Tint.
    pub blackbody_tint: Rgb,
    /// Temperature (kelvin), times the temperature grid where there is one.
    pub temperature: f32,
}

/// Coefficients at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointCoefficients {
    /// Absorption σa.
    pub sigma_a: Rgb,
    /// Scattering σs.
    pub sigma_s: Rgb,
    /// Emitted radiance per unit length.
    pub emission: Rgb,
}
