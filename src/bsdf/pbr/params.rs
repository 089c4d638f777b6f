//! The glTF material's factors at one shading point, the input of `PbrBsdf::from_params`.

use crate::math::Rgb;
use glam::Vec3;

/// The glTF material's factors at a shading point (textures already applied).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PbrParams {
    /// Base colour. Only the diffuse base reads it above 1 (as Cycles' Principled BSDF);
    /// the metal's F0, the glass tint and the subsurface albedo take it clamped to [0, 1].
    pub base: Rgb,
    /// Metalness.
    pub metallic: f32,
    /// Perceptual roughness.
    pub roughness: f32,
    /// `KHR_materials_specular` specularFactor (weight of the dielectric reflection).
    pub specular: f32,
    /// `KHR_materials_ior` (1.5 by default).
    pub ior: f32,
    /// `KHR_materials_transmission` transmissionFactor.
    pub transmission: f32,
    /// Thin-walled (no `KHR_materials_volume`, or thickness 0).
    pub thin: bool,
    /// Relative IOR across the surface for the transmission lobe: `ior` when entering,
    /// `1 / ior` when leaving (decided by the caller from the geometric normal).
    pub eta: f32,
    /// `KHR_materials_clearcoat` clearcoatFactor (weight of the coat layer).
    pub coat: f32,
    /// clearcoatRoughness.
    pub coat_roughness: f32,
    /// The coat's own normal in the shading frame (clearcoatNormalTexture), if it differs.
    pub coat_normal: Option<Vec3>,
    /// Index of refraction of the coat (Blender's Coat IOR; glTF's is 1.5).
    pub coat_ior: f32,
    /// Colour of the coat's absorption at normal incidence (Blender's Coat Tint).
    pub coat_tint: Rgb,
    /// The coat reflects with the exact dielectric Fresnel of `coat_ior`, as Cycles' coat
    /// closure does (Blender's materials), instead of glTF's Schlick approximation.
    pub coat_dielectric_fresnel: bool,
    /// `KHR_materials_specular` specularColorFactor (tints the dielectric layer's F0).
    pub specular_color: Rgb,
    /// `KHR_materials_sheen` sheenColorFactor (black: no sheen).
    pub sheen_color: Rgb,
    /// sheenRoughnessFactor.
    pub sheen_roughness: f32,
    /// The sheen is Blender's microfiber sheen (`CAUSTIC_materials_sheen`), not glTF's Charlie.
    pub microfiber_sheen: bool,
    /// `KHR_materials_dispersion` (20 / Abbe number; 0: none).
    pub dispersion: f32,
    /// Subsurface weight: the part of the diffuse base that scatters below the
    /// surface instead (sampled by the integrator's random walk, not by this BSDF).
    pub subsurface: f32,
    /// The diffuse base's own normal in the shading frame, when the frame's normal was
    /// bent for the specular lobes and this one was not.
    pub diffuse_normal: Option<Vec3>,
    /// The interpolated normal before normal mapping, in the shading frame, when a normal
    /// map changed it (the diffuse base's bump shadowing).
    pub smooth_normal: Option<Vec3>,
    /// Cycles' `sd->N` (the interpolated normal, or the Material Output's bump) in the shading
    /// frame, when the frame's normal (the specular lobes', bent or mapped) is not it: Cycles'
    /// `bump_shadowing_term` cuts those lobes' evaluation there (`PbrBsdf::cut_ref`).
    pub cut_normal: Option<Vec3>,
    /// Anisotropic widths (αx, αy) of the metal's and the specular layer's GGX along the
    /// shading frame's X and Y axes, replacing roughness² there.
    pub anisotropy: Option<(f32, f32)>,
    /// Blender's Diffuse Roughness σ of the diffuse base: Cycles' Oren-Nayar (`oren_nayar.rs`)
    /// above 1e-5, Lambert's below.
    pub diffuse_roughness: f32,
    /// Blender's Principled BSDF as Cycles' closure builds it (the shader-graph path): the glass
    /// transmits √(base colour) at each crossing (two crossings of a solid give the colour;
    /// glTF's transmits the colour), and anisotropic lobes take their albedo (layering and
    /// multiple-scattering compensation) from the isotropic table at the widths' geometric
    /// mean, Cycles' proxy, instead of the anisotropic table.
    pub cycles_principled: bool,
    /// A thin film on the dielectric layer: (thickness in nm, film IOR, weight) — Blender's
    /// Thin Film (weight 1), glTF's `KHR_materials_iridescence` (iridescenceFactor).
    pub thin_film: Option<(f32, f32, f32)>,
    /// The film covers the metal too, on Cycles' F82-tint conductor (Blender's Principled BSDF,
    /// `thin_film::conductor_film_reflectance`); else the dielectric layer alone.
    pub thin_film_metal: bool,
    /// Blender's Principled BSDF with distribution "GGX": single scattering, without Cycles'
    /// multiple-scattering compensation of the metal, the dielectric layer and the glass
    /// (which "Multiscatter GGX", Blender's default, and glTF's materials have).
    pub single_scatter: bool,
    /// `KHR_materials_diffuse_transmission` diffuseTransmissionFactor (0: none): the share of
    /// the diffuse base that transmits to the other side, Lambertian.
    pub diffuse_transmission: f32,
    /// diffuseTransmissionColorFactor (times its texture): that transmission's colour.
    pub diffuse_transmission_color: Rgb,
}

impl PbrParams {
    /// Equal in every factor but the base colour: the BSDF built from `self` is then
    /// `PbrBsdf::without_base(other)` `.with_base(self.base)`.
    #[inline]
    pub fn same_but_base(&self, other: &PbrParams) -> bool {
        PbrParams { base: other.base, ..*self } == *other
    }

    /// An opaque dielectric/metal without the extensions.
    pub fn opaque(base: Rgb, metallic: f32, roughness: f32) -> Self {
        PbrParams {
            base,
            metallic,
            roughness,
            specular: 1.0,
            ior: 1.5,
            transmission: 0.0,
            thin: true,
            eta: 1.5,
            coat: 0.0,
            coat_roughness: 0.0,
            coat_normal: None,
            coat_ior: 1.5,
            coat_tint: Rgb::ONE,
            coat_dielectric_fresnel: false,
            specular_color: Rgb::ONE,
            sheen_color: Rgb::ZERO,
            sheen_roughness: 0.0,
            microfiber_sheen: false,
            dispersion: 0.0,
            subsurface: 0.0,
            diffuse_normal: None,
            smooth_normal: None,
            cut_normal: None,
            anisotropy: None,
            diffuse_roughness: 0.0,
            cycles_principled: false,
            thin_film: None,
            thin_film_metal: false,
            single_scatter: false,
            diffuse_transmission: 0.0,
            diffuse_transmission_color: Rgb::ONE,
        }
    }
}
