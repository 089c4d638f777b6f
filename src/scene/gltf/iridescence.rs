//! `KHR_materials_iridescence`: a thin film on the material's dielectric layer, the model of
//! Blender's Principled Thin Film (`bsdf/thin_film.rs`): iridescenceFactor (× texture R) mixes
//! the film's Fresnel in, iridescenceIor is the film's index, and the thickness is
//! mix(thicknessMinimum, thicknessMaximum, texture G) nm (thicknessMaximum without a texture).
//! `CAUSTIC_materials_iridescence` {"metal": "conductor"} (the add-on's, for Blender's
//! Principled BSDF) puts the film on the metal part too, on Cycles' F82-tint conductor
//! (`thin_film::conductor_film_reflectance`); without it the film on a metal part is not
//! rendered (a warning names the material: glTF's own model there is another).

use super::Loader;
use crate::error::Result;
use crate::scene::material::Iridescence;

impl Loader<'_> {
    /// The material's iridescence from the extension's JSON `ext`; `metallic` > 0 (or a
    /// metallic texture) is warned about unless `on_metal` puts the film there too.
    pub(super) fn iridescence(
        &mut self,
        doc: &gltf::Document,
        ext: &serde_json::Value,
        buffers: &[Vec<u8>],
        name: &str,
        metallic: bool,
        on_metal: bool,
    ) -> Result<Option<Iridescence>> {
        let num = |key: &str, default: f32| -> Option<f32> {
            match ext.get(key) {
                None => Some(default),
                Some(x) => x.as_f64().map(|f| f as f32).filter(|f| f.is_finite()),
            }
        };
        let (Some(factor), Some(ior), Some(t_min), Some(t_max)) = (
            num("iridescenceFactor", 0.0),
            num("iridescenceIor", 1.3),
            num("iridescenceThicknessMinimum", 100.0),
            num("iridescenceThicknessMaximum", 400.0),
        ) else {
            return Err(self.err(format!("material '{name}': KHR_materials_iridescence needs finite numbers")));
        };
        if !(0.0..=1.0).contains(&factor) || ior < 1.0 || t_min < 0.0 || t_max < 0.0 {
            return Err(self.err(format!(
                "material '{name}': KHR_materials_iridescence needs iridescenceFactor in [0, 1], \
                 iridescenceIor >= 1 and thicknesses >= 0"
            )));
        }
        let factor_tex = match ext.get("iridescenceTexture") {
            Some(t) => self.raw_texture(doc, t, false, buffers, name)?,
            None => None,
        };
        let thickness_tex = match ext.get("iridescenceThicknessTexture") {
            Some(t) => self.raw_texture(doc, t, false, buffers, name)?,
            None => None,
        };
        if factor == 0.0 {
            return Ok(None);
        }
        if metallic && !on_metal {
            self.warn(format!(
                "material '{name}': iridescence is rendered on the dielectric part only, not on the metal"
            ));
        }
        Ok(Some(Iridescence {
            factor,
            factor_tex,
            ior,
            thickness_min: t_min,
            thickness_max: t_max,
            thickness_tex,
            on_metal,
        }))
    }
}
