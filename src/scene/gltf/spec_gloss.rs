//! `KHR_materials_pbrSpecularGlossiness` (archived, but common in older assets), read as
//! Blender's importer converts it, so that a file renders as Cycles renders its import: a
//! dielectric with the diffuse colour as base colour, an F0 of the specular colour (IOR
//! 1000 makes the dielectric F0 ≈ 1, tinted by the specular colour, Fresnel rising to 1 at
//! grazing angles) and roughness 1 − glossiness. Without the extension read, such a
//! material fell back to glTF's default (white, metallic 1, roughness 1).

use super::Loader;
use crate::error::Result;
use crate::scene::Material;
use crate::scene::texture::TexRef;
use glam::{Vec3, Vec4};

/// The IOR Blender's importer gives a specular-glossiness material: F0 = 0.996 × tint.
const SPEC_GLOSS_IOR: f32 = 1000.0;

impl Loader<'_> {
    /// Replaces `mat`'s metallic-roughness values by those of its specular-glossiness
    /// extension `ext`.
    pub(super) fn specular_glossiness(
        &mut self,
        doc: &gltf::Document,
        ext: &serde_json::Value,
        buffers: &[Vec<u8>],
        mat: &mut Material,
    ) -> Result<()> {
        let name = mat.name.clone();
        let floats = |key: &str, default: &[f32]| -> Result<Vec<f32>> {
            let Some(v) = ext.get(key) else { return Ok(default.to_vec()) };
            let parsed: Option<Vec<f32>> = match v.as_array() {
                Some(a) => a.iter().map(|x| x.as_f64().map(|f| f as f32)).collect(),
                None => v.as_f64().map(|f| vec![f as f32]),
            };
            match parsed {
                Some(p) if p.len() == default.len() && p.iter().all(|x| x.is_finite()) => Ok(p),
                _ => Err(self.err(format!(
                    "material '{name}': KHR_materials_pbrSpecularGlossiness {key} must be {} finite number(s)",
                    default.len()
                ))),
            }
        };
        let diffuse = floats("diffuseFactor", &[1.0; 4])?;
        let specular = floats("specularFactor", &[1.0; 3])?;
        let glossiness = floats("glossinessFactor", &[1.0])?[0];
        let diffuse = Vec4::from_slice(&diffuse);
        let specular = Vec3::from_slice(&specular);
        if diffuse.clamp(Vec4::ZERO, Vec4::ONE) != diffuse
            || specular.clamp(Vec3::ZERO, Vec3::ONE) != specular
            || !(0.0..=1.0).contains(&glossiness)
        {
            self.warn(format!("material '{name}': specular-glossiness factors outside [0, 1] were clamped"));
        }
        let glossiness = glossiness.clamp(0.0, 1.0);
        mat.base_color = diffuse.clamp(Vec4::ZERO, Vec4::ONE);
        mat.base_color_tex = match ext.get("diffuseTexture") {
            Some(t) => self.raw_texture(doc, t, true, buffers, &name)?,
            None => None,
        };
        mat.metallic = 0.0;
        mat.ior = SPEC_GLOSS_IOR;
        mat.specular = 1.0;
        mat.specular_tex = None;
        mat.specular_color = specular.clamp(Vec3::ZERO, Vec3::ONE);
        mat.roughness = 1.0 - glossiness;
        mat.metallic_roughness_tex = None;
        mat.specular_color_tex = None;
        if let Some(t) = ext.get("specularGlossinessTexture") {
            // RGB: the specular colour (sRGB); A: glossiness (linear), as a roughness
            // texture (G = 1 − factor × A, B = metallic 0) under a roughness factor of 1.
            mat.specular_color_tex = self.raw_texture(doc, t, true, buffers, &name)?;
            if let Some(linear) = self.raw_texture(doc, t, false, buffers, &name)? {
                mat.metallic_roughness_tex = Some(self.roughness_from_glossiness(linear, glossiness));
                mat.roughness = 1.0;
            }
        }
        Ok(())
    }

    /// A new texture beside `gloss`'s whose green channel is 1 − `factor` × its alpha.
    fn roughness_from_glossiness(&mut self, gloss: TexRef, factor: f32) -> TexRef {
        let mut tex = self.textures[gloss.texture as usize].clone();
        tex.name = format!("{} (roughness from glossiness)", tex.name);
        for t in &mut tex.texels {
            let rough = 1.0 - factor * (t[3] as f32 / 255.0);
            *t = [0, (rough * 255.0).round().clamp(0.0, 255.0) as u8, 0, 255];
        }
        self.textures.push(tex.with_mean());
        TexRef { texture: (self.textures.len() - 1) as u32, ..gloss }
    }
}

#[cfg(test)]
mod tests {
    use base64::Engine;
    use serde_json::json;

    /// A triangle with one material whose only description is `ext`, and `images`.
    fn load(ext: serde_json::Value, images: serde_json::Value) -> crate::scene::Scene {
        let textures: Vec<serde_json::Value> =
            (0..images.as_array().map_or(0, Vec::len)).map(|i| json!({"source": i})).collect();
        crate::scene::gltf::tests::load_triangle_after(
            &[],
            json!({
                "extensionsUsed": ["KHR_materials_pbrSpecularGlossiness"],
                "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
                "materials": [{"name": "SG", "extensions": {"KHR_materials_pbrSpecularGlossiness": ext}}],
                "textures": textures,
                "images": images
            }),
        )
        .expect("loads")
    }

    #[test]
    fn factors_become_a_dielectric_with_the_specular_colour_as_f0() {
        let scene = load(
            json!({"diffuseFactor": [0.5, 0.25, 0.125, 1.0], "specularFactor": [0.2, 0.3, 0.4], "glossinessFactor": 0.75}),
            json!([]),
        );
        let m = &scene.materials[0];
        assert_eq!((m.metallic, m.roughness), (0.0, 0.25));
        assert_eq!(m.base_color.to_array(), [0.5, 0.25, 0.125, 1.0]);
        assert_eq!(m.specular_color.to_array(), [0.2, 0.3, 0.4]);
        // Blender's importer: IOR 1000, so that F0 = 0.996 × specular colour.
        let f0 = crate::bsdf::pbr::f0_from_ior(m.ior);
        assert!((f0 - 0.996).abs() < 1e-3, "{f0}");
        assert!(!scene.warnings.iter().any(|w| w.contains("pbrSpecularGlossiness")), "{:?}", scene.warnings);
    }

    #[test]
    fn the_glossiness_texture_alpha_becomes_roughness() {
        // One texel: specular colour (255, 128, 0), glossiness alpha 0.8 (204).
        let img = image::RgbaImage::from_pixel(1, 1, image::Rgba([255, 128, 0, 204]));
        let mut bytes = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).unwrap();
        let png = format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(&bytes));
        let scene =
            load(json!({"glossinessFactor": 0.5, "specularGlossinessTexture": {"index": 0}}), json!([{"uri": png}]));
        let m = &scene.materials[0];
        let rough = &scene.textures[m.metallic_roughness_tex.expect("roughness texture").texture as usize];
        // 1 − 0.5 × 0.8 = 0.6 → 153 in G; metallic (B) 0.
        assert_eq!(rough.texels[0], [0, 153, 0, 255]);
        assert!(!rough.srgb);
        let spec = &scene.textures[m.specular_color_tex.expect("specular colour texture").texture as usize];
        assert!(spec.srgb && spec.texels[0][..3] == [255, 128, 0]);
        assert_eq!(m.roughness, 1.0);
    }
}
