//! Materials as the renderer sees them: glTF metallic-roughness factors and textures.

use super::texture::{TexRef, Texture};
use crate::math::Rgb;
use crate::medium::HomogeneousMedium;
use glam::{Vec2, Vec4};

/// How a material's alpha is used.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    /// Alpha ignored.
    Opaque,
    /// Surface present where alpha ≥ cutoff.
    Mask(f32),
    /// Alpha is coverage: rays pass with probability 1 - alpha (stochastic transparency).
    Blend,
}

/// A glTF material.
#[derive(Clone, Debug)]
pub struct Material {
    /// Name for messages.
    pub name: String,
    /// Base colour factor (linear RGBA).
    pub base_color: Vec4,
    /// Base colour texture (sRGB).
    pub base_color_tex: Option<TexRef>,
    /// Metallic factor.
    pub metallic: f32,
    /// Roughness factor.
    pub roughness: f32,
    /// Metallic (B) and roughness (G) texture.
    pub metallic_roughness_tex: Option<TexRef>,
    /// Tangent-space normal map.
    pub normal_tex: Option<TexRef>,
    /// Normal map scale.
    pub normal_scale: f32,
    /// `CAUSTIC_materials_normal_map` mapping "blender": the normal and coat normal maps'
    /// scale s is Blender's Normal Map Strength, which Cycles applies as (s·x, s·y,
    /// mix(1, z, clamp(s, 0, 1))) in tangent space where glTF scales x and y alone.
    pub normal_strength_blender: bool,
    /// Emitted radiance factor (emissiveFactor × emissive strength), from both faces whatever
    /// glTF's `doubleSided` says, as Cycles renders Blender's import of it (Cycles culls no
    /// back face and its Emission leaves both sides). Shading is two-sided too.
    pub emissive: Rgb,
    /// Emissive texture (sRGB).
    pub emissive_tex: Option<TexRef>,
    /// `KHR_materials_anisotropy` anisotropyStrength (0: isotropic).
    pub anisotropy_strength: f32,
    /// anisotropyRotation: radians from the tangent towards the bitangent.
    pub anisotropy_rotation: f32,
    /// anisotropyTexture: direction in tangent space (RG, [-1, 1]) and strength (B).
    pub anisotropy_tex: Option<TexRef>,
    /// `CAUSTIC_materials_anisotropy` mapping "blender": the strength is Blender's Anisotropic,
    /// widths α/√(1 − 0.9 s) along the direction and α·√(1 − 0.9 s) across (Cycles').
    pub anisotropy_blender: bool,
    /// `KHR_materials_unlit`: the surface shows its base colour (factor × texture × vertex
    /// colour, held in `emissive` and `emissive_tex`) and reflects no light.
    pub unlit: bool,
    /// `KHR_materials_specular` specularFactor: weight of the dielectric specular layer.
    pub specular: f32,
    /// specularTexture (A): multiplies `specular`.
    pub specular_tex: Option<TexRef>,
    /// specularColorFactor: tints the dielectric layer's F0.
    pub specular_color: Rgb,
    /// specularColorTexture (sRGB).
    pub specular_color_tex: Option<TexRef>,
    /// `KHR_materials_ior` (1.5 when absent, as glTF and Blender's exporter assume).
    pub ior: f32,
    /// `KHR_materials_transmission` transmissionFactor.
    pub transmission: f32,
    /// Transmission texture (R channel).
    pub transmission_tex: Option<TexRef>,
    /// `KHR_materials_diffuse_transmission` diffuseTransmissionFactor: the share of the
    /// diffuse base that transmits, Lambertian, to the other side.
    pub diffuse_transmission: f32,
    /// diffuseTransmissionTexture (A channel): multiplies the factor.
    pub diffuse_transmission_tex: Option<TexRef>,
    /// diffuseTransmissionColorFactor: the transmitted light's colour.
    pub diffuse_transmission_color: Rgb,
    /// diffuseTransmissionColorTexture (sRGB, RGB): multiplies the colour.
    pub diffuse_transmission_color_tex: Option<TexRef>,
    /// `KHR_materials_clearcoat` clearcoatFactor.
    pub coat: f32,
    /// clearcoatTexture (R).
    pub coat_tex: Option<TexRef>,
    /// clearcoatRoughnessFactor.
    pub coat_roughness: f32,
    /// clearcoatRoughnessTexture (G).
    pub coat_roughness_tex: Option<TexRef>,
    /// Coat IOR (`CAUSTIC_materials_coat`; glTF's coat is 1.5).
    pub coat_ior: f32,
    /// Coat tint (`CAUSTIC_materials_coat`).
    pub coat_tint: Rgb,
    /// The coat's Fresnel is the exact dielectric one (`CAUSTIC_materials_coat` fresnel
    /// "dielectric", Cycles' coat) instead of glTF's Schlick approximation.
    pub coat_dielectric_fresnel: bool,
    /// clearcoatNormalTexture: the coat's own normal map.
    pub coat_normal_tex: Option<TexRef>,
    /// Its scale.
    pub coat_normal_scale: f32,
    /// `KHR_materials_sheen` sheenColorFactor (black: no sheen).
    pub sheen_color: Rgb,
    /// sheenColorTexture (sRGB).
    pub sheen_color_tex: Option<TexRef>,
    /// sheenRoughnessFactor.
    pub sheen_roughness: f32,
    /// sheenRoughnessTexture (A).
    pub sheen_roughness_tex: Option<TexRef>,
    /// `CAUSTIC_materials_sheen` model "microfiber": Blender's (Cycles') sheen, not glTF's Charlie.
    pub sheen_microfiber: bool,
    /// `KHR_materials_dispersion` (20 / Abbe number).
    pub dispersion: f32,
    /// `KHR_materials_iridescence` (Blender's Thin Film): a thin film on the dielectric layer.
    pub iridescence: Option<Iridescence>,
    /// The medium inside the mesh: `CAUSTIC_materials_medium`, or the absorption of
    /// `KHR_materials_volume` (σa only); None when the surface is thin-walled.
    pub medium: Option<HomogeneousMedium>,
    /// The boundary has no surface (a volume-only material, as Blender's with nothing
    /// on the Surface output): rays cross it unchanged and only the medium changes.
    pub null_surface: bool,
    /// The volume object's grid medium (`Scene::grids`) that replaces `medium` inside a
    /// volume object's bounding box (`CAUSTIC_volume`).
    pub grid: Option<u32>,
    /// The Volume output's node graph (`CAUSTIC_materials_medium.graph`), until the loader
    /// has made it a procedural grid medium and set `grid`.
    pub volume_program: Option<Box<crate::shader::compile::volume::VolumeProgram>>,
    /// `CAUSTIC_materials_subsurface`: Principled BSDF random-walk subsurface scattering.
    pub subsurface: Option<Subsurface>,
    /// The walk's medium for the first albedo a walk of this material met, with that albedo:
    /// an untextured material's walks all reuse it (callgrind on the subsurface bench scene:
    /// building it, with its albedo fit's `powf`s, was 2.3 % of the render). Set once by
    /// whichever walk comes first; equal inputs give the same medium, so images do not depend
    /// on which.
    pub walk_memo: std::sync::OnceLock<(Rgb, crate::medium::WalkMedium)>,
    /// Alpha mode.
    pub alpha_mode: AlphaMode,
    /// Shadow rays pass the surface as its alpha says (Cycles' Transparent Shadows, on unless
    /// `CAUSTIC_materials_shadow` says `"transparent": false`: then the surface stops them).
    pub transparent_shadow: bool,
    /// Blender's shader graph (`CAUSTIC_materials_nodes`), compiled: when present it
    /// replaces the glTF parameters above in shading, alpha and emission.
    pub nodes: Option<std::sync::Arc<crate::shader::instructions::Program>>,
    /// The Principled Hair BSDF (`CAUSTIC_materials_hair`): strands with this material are
    /// shaded by it; triangles keep the glTF parameters.
    pub hair: Option<crate::bsdf::hair::HairParams>,
}

/// A thin film on the dielectric layer (`KHR_materials_iridescence`, Blender's Thin Film), and
/// on the metal for Blender's (`CAUSTIC_materials_iridescence`).
#[derive(Clone, Copy, Debug)]
pub struct Iridescence {
    /// iridescenceFactor: the weight of the film's Fresnel.
    pub factor: f32,
    /// iridescenceTexture (R scales the factor).
    pub factor_tex: Option<TexRef>,
    /// iridescenceIor: the film's index.
    pub ior: f32,
    /// iridescenceThicknessMinimum, nm.
    pub thickness_min: f32,
    /// iridescenceThicknessMaximum, nm (the thickness without a texture).
    pub thickness_max: f32,
    /// iridescenceThicknessTexture (G mixes minimum to maximum).
    pub thickness_tex: Option<TexRef>,
    /// `CAUSTIC_materials_iridescence` metal "conductor": the film covers the metal as Cycles'
    /// Principled BSDF puts it there, on its F82-tint conductor; else the dielectric layer alone.
    pub on_metal: bool,
}

impl Default for Material {
    /// glTF's default material: white, fully rough dielectric... except that the
    /// spec's default metallic is 1; we keep the spec.
    fn default() -> Self {
        Material {
            name: "default".into(),
            base_color: Vec4::ONE,
            base_color_tex: None,
            metallic: 1.0,
            roughness: 1.0,
            metallic_roughness_tex: None,
            normal_tex: None,
            normal_scale: 1.0,
            normal_strength_blender: false,
            emissive: Rgb::ZERO,
            emissive_tex: None,
            unlit: false,
            anisotropy_strength: 0.0,
            anisotropy_rotation: 0.0,
            anisotropy_tex: None,
            anisotropy_blender: false,
            specular: 1.0,
            specular_tex: None,
            specular_color: Rgb::ONE,
            specular_color_tex: None,
            ior: 1.5,
            transmission: 0.0,
            transmission_tex: None,
            diffuse_transmission: 0.0,
            diffuse_transmission_tex: None,
            diffuse_transmission_color: Rgb::ONE,
            diffuse_transmission_color_tex: None,
            medium: None,
            null_surface: false,
            grid: None,
            volume_program: None,
            subsurface: None,
            walk_memo: std::sync::OnceLock::new(),
            coat: 0.0,
            coat_tex: None,
            coat_roughness: 0.0,
            coat_roughness_tex: None,
            coat_ior: 1.5,
            coat_tint: Rgb::ONE,
            coat_dielectric_fresnel: false,
            coat_normal_tex: None,
            coat_normal_scale: 1.0,
            sheen_color: Rgb::ZERO,
            sheen_color_tex: None,
            sheen_roughness: 0.0,
            sheen_roughness_tex: None,
            sheen_microfiber: false,
            dispersion: 0.0,
            iridescence: None,
            alpha_mode: AlphaMode::Opaque,
            transparent_shadow: true,
            nodes: None,
            hair: None,
        }
    }
}

/// Blender's subsurface methods that Caustic renders.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SubsurfaceMethod {
    /// "Random Walk": mean free path = radius / 4π, entry refracted through the
    /// material's rough interface (its roughness and IOR).
    RandomWalk,
    /// "Random Walk (Skin)": mean free path from the radius and colour (dipole fit),
    /// entry half diffuse, half refracted through a fully rough interface of the
    /// subsurface IOR.
    RandomWalkSkin,
}

/// Principled BSDF subsurface parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Subsurface {
    /// Subsurface Weight: the fraction of the diffuse base that scatters below the surface.
    pub weight: f32,
    /// Radius × Scale per channel (scene units).
    pub radius: Rgb,
    /// Subsurface Anisotropy (Henyey-Greenstein g).
    pub anisotropy: f32,
    /// Subsurface IOR (used by the skin method, and by `enter_at_ior`).
    pub ior: f32,
    /// Method.
    pub method: SubsurfaceMethod,
    /// The walk enters at `ior` (a Subsurface Scattering node: no specular layer above),
    /// not at the Principled BSDF's specular layer's IOR.
    pub enter_at_ior: bool,
}

/// The texture fields of a material (`&Material` or `&mut Material`): the fifteen
/// `Option<TexRef>` fields and the iridescence, whose two textures sit inside it. The fields
/// are destructured without `..`, so a field added to `Material` does not compile until it is
/// named here as a texture or not (and so can never be missed by what relies on the list,
/// such as the shading's texture-free fast path or the viewport's merge, which shifts them).
macro_rules! texture_fields {
    ($m:expr) => {{
        let Material {
            name: _,
            base_color: _,
            base_color_tex,
            metallic: _,
            roughness: _,
            metallic_roughness_tex,
            normal_tex,
            normal_scale: _,
            normal_strength_blender: _,
            emissive: _,
            emissive_tex,
            anisotropy_strength: _,
            anisotropy_rotation: _,
            anisotropy_tex,
            anisotropy_blender: _,
            unlit: _,
            specular: _,
            specular_tex,
            specular_color: _,
            specular_color_tex,
            ior: _,
            transmission: _,
            transmission_tex,
            diffuse_transmission: _,
            diffuse_transmission_tex,
            diffuse_transmission_color: _,
            diffuse_transmission_color_tex,
            coat: _,
            coat_tex,
            coat_roughness: _,
            coat_roughness_tex,
            coat_ior: _,
            coat_tint: _,
            coat_dielectric_fresnel: _,
            coat_normal_tex,
            coat_normal_scale: _,
            sheen_color: _,
            sheen_color_tex,
            sheen_roughness: _,
            sheen_roughness_tex,
            sheen_microfiber: _,
            dispersion: _,
            iridescence,
            medium: _,
            null_surface: _,
            grid: _,
            volume_program: _,
            subsurface: _,
            walk_memo: _,
            alpha_mode: _,
            transparent_shadow: _,
            hair: _,
            // Not a texture: a shader graph replaces every parameter above.
            nodes: _,
        } = $m;
        (
            [
                base_color_tex,
                metallic_roughness_tex,
                normal_tex,
                emissive_tex,
                anisotropy_tex,
                specular_tex,
                specular_color_tex,
                transmission_tex,
                coat_tex,
                coat_roughness_tex,
                coat_normal_tex,
                sheen_color_tex,
                sheen_roughness_tex,
                diffuse_transmission_tex,
                diffuse_transmission_color_tex,
            ],
            iridescence,
        )
    }};
}

impl Material {
    /// Every texture the material's glTF parameters read, in one place (`texture_fields`).
    pub fn textures(&self) -> [Option<TexRef>; 17] {
        let (fields, iridescence) = texture_fields!(self);
        let mut all = [None; 17];
        for (a, f) in all.iter_mut().zip(fields) {
            *a = *f;
        }
        all[15] = iridescence.as_ref().and_then(|i| i.factor_tex);
        all[16] = iridescence.as_ref().and_then(|i| i.thickness_tex);
        all
    }

    /// The same textures as [`Material::textures`], to change in place (the viewport's
    /// merge of a second scene shifts their indices).
    pub fn textures_mut(&mut self) -> impl Iterator<Item = &mut TexRef> {
        let (fields, iridescence) = texture_fields!(self);
        let film = iridescence.iter_mut().flat_map(|i| [&mut i.factor_tex, &mut i.thickness_tex]);
        fields.into_iter().chain(film).flatten()
    }

    /// True when the material emits light (from both faces: see `emissive`).
    pub fn is_emissive(&self) -> bool {
        self.emissive.max_element() > 0.0
    }
}

impl Material {
    /// True when the material may refract (a Glass or Refraction closure, a Principled BSDF
    /// whose Transmission Weight may be nonzero, glTF transmission): a hint from its
    /// parameters alone, never false for a material that refracts somewhere.
    pub fn may_refract(&self) -> bool {
        use crate::shader::closure::ClosureKind;
        use crate::shader::instructions::Op;
        match &self.nodes {
            Some(p) => {
                p.transmits
                    || p.ops.iter().any(|op| {
                        matches!(op, Op::Closure(c) if matches!(c.kind, ClosureKind::Glass { .. } | ClosureKind::Refraction { .. }))
                    })
            }
            None => self.transmission > 0.0 || self.transmission_tex.is_some(),
        }
    }
}

impl Material {
    /// Emitted radiance at a point with texture coordinates `uv` (sets 0 and 1) and vertex
    /// colour `color` (which only an unlit material's emission, its base colour, uses).
    #[inline]
    pub fn emission(&self, textures: &[Texture], uv: [Vec2; 2], color: Vec4) -> Rgb {
        let mut e = self.emissive;
        if let Some(t) = self.emissive_tex {
            e *= textures[t.texture as usize].lookup(t.uv(uv[t.tex_coord as usize])).truncate();
        }
        if self.unlit { e * color.truncate() } else { e }
    }
}
