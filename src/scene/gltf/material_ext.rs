//! The material extensions: `KHR_materials_transmission`, `_ior`, `_volume`,
//! `_clearcoat`, `_sheen`, `_dispersion`, `_specular`, and `CAUSTIC_materials_medium`, `_shadow`,
//! `_subsurface` and `_coat`. Every value is checked (a non-finite number is an error
//! naming the material and key); values outside their range are clamped with a warning.

use super::Loader;
use super::extensions::{MediumExt, SubsurfaceExt};
use crate::error::{Error, Result};
use crate::medium::{HomogeneousMedium, Phase};
use crate::scene::Material;
use crate::scene::material::{Subsurface, SubsurfaceMethod};
use glam::Vec3;

/// Material extensions that Caustic reads.
pub(super) const HANDLED_MATERIAL_EXTENSIONS: &[&str] = &[
    "KHR_materials_emissive_strength",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_diffuse_transmission",
    "KHR_materials_ior",
    "KHR_materials_volume",
    "KHR_materials_clearcoat",
    "CAUSTIC_materials_medium",
    "CAUSTIC_materials_subsurface",
    "KHR_materials_sheen",
    "CAUSTIC_materials_sheen",
    "CAUSTIC_materials_shadow",
    "KHR_materials_dispersion",
    "CAUSTIC_materials_coat",
    "CAUSTIC_materials_nodes",
    // Read by `pass_ids.rs` (the Material Index pass).
    "CAUSTIC_material_pass",
    // Read in `materials.rs`:
    "KHR_materials_unlit",
    "KHR_materials_anisotropy",
    "CAUSTIC_materials_anisotropy",
    "CAUSTIC_materials_normal_map",
    // Read in `spec_gloss.rs`:
    "KHR_materials_pbrSpecularGlossiness",
    // Read in `iridescence.rs`:
    "KHR_materials_iridescence",
    "CAUSTIC_materials_iridescence",
    // Read in `curves.rs` (strands with this material shade with it).
    "CAUSTIC_materials_hair",
];

impl Loader<'_> {
    /// A medium's phase function from its `phase` name and [anisotropy, alpha, ior,
    /// backscatter, diameter]: a clear error for an unknown name or a number that is not finite.
    pub(super) fn phase(&self, what: &str, kind: &str, values: [f32; 5]) -> Result<Phase> {
        if values.iter().any(|v| !v.is_finite()) {
            return Err(self.err(format!("{what}: the phase function's parameters must be finite")));
        }
        let [g, alpha, ior, backscatter, diameter] = values;
        Phase::from_blender(kind, g, alpha, ior, backscatter, diameter).ok_or_else(|| {
            self.err(format!(
                "{what}: phase '{kind}' is unknown (HENYEY_GREENSTEIN, RAYLEIGH, DRAINE, FOURNIER_FORAND, MIE)"
            ))
        })
    }

    /// The homogeneous medium a `CAUSTIC_materials_medium` value describes (also the world's
    /// volume), checked: finite, non-negative density and colours, anisotropy in [-1, 1].
    /// A two-valued string field `key` of extension `ext`: false for `values[0]` or absent,
    /// true for `values[1]`, an error naming the material for anything else.
    fn either(&self, value: &serde_json::Value, ext: &str, key: &str, values: [&str; 2], name: &str) -> Result<bool> {
        match value.get(key).and_then(|v| v.as_str()) {
            None => Ok(false),
            Some(v) if v == values[0] => Ok(false),
            Some(v) if v == values[1] => Ok(true),
            Some(other) => Err(self.err(format!(
                "material '{name}': {ext} {key} '{other}' is not \"{}\" or \"{}\"",
                values[0], values[1]
            ))),
        }
    }

    pub(super) fn homogeneous_medium(&self, what: &str, ext: &MediumExt) -> Result<HomogeneousMedium> {
        let colours = [ext.scatter_color, ext.absorption_color, ext.emission, ext.blackbody_tint];
        let finite = ext.density.is_finite()
            && ext.anisotropy.is_finite()
            && ext.blackbody_intensity.is_finite()
            && ext.temperature.is_finite()
            && colours.iter().all(|c| c.iter().all(|x| x.is_finite()));
        if !finite || ext.density < 0.0 || colours.iter().any(|c| c.iter().any(|&x| x < 0.0)) {
            return Err(self.err(format!("{what} needs finite, non-negative density and colours")));
        }
        if !(-1.0..=1.0).contains(&ext.anisotropy) {
            return Err(self.err(format!("{what}: anisotropy {} is outside [-1, 1]", ext.anisotropy)));
        }
        let phase = self.phase(
            what,
            &ext.phase,
            [ext.anisotropy, ext.phase_alpha, ext.phase_ior, ext.phase_backscatter, ext.phase_diameter],
        )?;
        Ok(HomogeneousMedium {
            sigma_a: Vec3::from(ext.absorption_color) * ext.density,
            sigma_s: Vec3::from(ext.scatter_color) * ext.density,
            phase,
            // A mesh or the world has no temperature grid: the Temperature alone, as Cycles.
            emission: Vec3::from(ext.emission)
                + crate::medium::blackbody::blackbody_emission(
                    ext.temperature,
                    ext.blackbody_intensity,
                    Vec3::from(ext.blackbody_tint),
                    &self.space,
                ),
        })
    }

    /// Reads the material extensions of `m` into `mat` (whose core glTF fields are set),
    /// naming each one read in `features`.
    pub(super) fn material_extensions(
        &mut self,
        doc: &gltf::Document,
        m: &gltf::Material,
        buffers: &[Vec<u8>],
        mat: &mut Material,
        features: &mut Vec<String>,
    ) -> Result<()> {
        let name = mat.name.clone();
        let roughness = mat.roughness;
        let file = self.file.to_string();
        let num = |v: &serde_json::Value, key: &str, default: f32| -> Result<f32> {
            match v.get(key) {
                None => Ok(default),
                Some(x) => x.as_f64().map(|f| f as f32).filter(|f| f.is_finite()).ok_or_else(|| Error::Scene {
                    file: file.clone(),
                    message: format!("material '{name}': {key} is not a finite number"),
                }),
            }
        };
        let mut transmission = 0.0;
        let mut transmission_tex = None;
        if let Some(t) = m.extension_value("KHR_materials_transmission").cloned() {
            features.push("KHR_materials_transmission".into());
            let factor = num(&t, "transmissionFactor", 0.0)?;
            transmission = factor.clamp(0.0, 1.0);
            if transmission != factor {
                self.warn(format!("material '{name}': transmissionFactor {factor} was clamped to [0, 1]"));
            }
            if let Some(tex) = t.get("transmissionTexture") {
                transmission_tex = self.raw_texture(doc, tex, false, buffers, &name)?;
            }
        }
        let mut ior = 1.5;
        if let Some(i) = m.extension_value("KHR_materials_ior").cloned() {
            features.push("KHR_materials_ior".into());
            let v = num(&i, "ior", 1.5)?;
            // Below 1 too, as Blender imports it and Cycles renders it (down to 1e-5, where a
            // Principled BSDF's layer is a near mirror): `PbrBsdf` takes the Fresnel of η < 1.
            ior = v.clamp(crate::bsdf::pbr::MIN_IOR, 10.0);
            // glTF's IOR is at least 1: say what is made of one below (a node graph, which
            // carries Blender's own IOR, renders in place of these factors and is not named).
            if v < 1.0 && m.extension_value("CAUSTIC_materials_nodes").is_none() {
                self.warn(format!(
                    "material '{name}': ior {v} is below glTF's minimum of 1; rendered as Blender imports it and \
                     Cycles renders it (η {ior}: total internal reflection inside the layer, 0 a near mirror)"
                ));
            }
        }
        let mut medium = None;
        if let Some(v) = m.extension_value("KHR_materials_volume").cloned() {
            features.push("KHR_materials_volume".into());
            let thickness = num(&v, "thicknessFactor", 0.0)?;
            let distance = num(&v, "attenuationDistance", f32::INFINITY)?;
            let color = v
                .get("attenuationColor")
                .and_then(|c| c.as_array())
                // A value that is not a number becomes NaN, refused below (not silently 1).
                .map(|c| c.iter().map(|x| x.as_f64().unwrap_or(f64::NAN) as f32).collect::<Vec<f32>>())
                .unwrap_or_else(|| vec![1.0; 3]);
            if color.len() != 3 || color.iter().any(|c| !c.is_finite()) || !(distance > 0.0) {
                return Err(self.err(format!(
                    "material '{name}': KHR_materials_volume needs 3 finite attenuationColor values and attenuationDistance > 0"
                )));
            }
            // Beer-Lambert: after attenuationDistance, light keeps attenuationColor.
            let sigma = Vec3::new(color[0], color[1], color[2]).clamp(Vec3::splat(1e-6), Vec3::ONE);
            let sigma_a = if distance.is_finite() {
                -Vec3::new(sigma.x.ln(), sigma.y.ln(), sigma.z.ln()) / distance
            } else {
                Vec3::ZERO
            };
            if thickness > 0.0 {
                medium = Some(HomogeneousMedium::absorbing(sigma_a));
            }
            if v.get("thicknessTexture").is_some() {
                features.push("thicknessTexture (ignored: Caustic traces the real geometry)".into());
            }
        }
        let mut null_surface = false;
        if let Some(v) = m.extension_value("CAUSTIC_materials_medium").cloned() {
            features.push("CAUSTIC_materials_medium".into());
            let ext: MediumExt = serde_json::from_value(v)
                .map_err(|e| self.err(format!("material '{name}': CAUSTIC_materials_medium is malformed: {e}")))?;
            let parsed = self.homogeneous_medium(&format!("material '{name}': CAUSTIC_materials_medium"), &ext)?;
            if medium.is_some() {
                self.warn(format!(
                    "material '{name}': CAUSTIC_materials_medium replaces the KHR_materials_volume attenuation"
                ));
            }
            medium = Some(parsed);
            null_surface = !ext.surface;
            if let Some(graph) = &ext.graph {
                let what = format!("material '{name}': CAUSTIC_materials_medium.graph");
                let Some(shader) = ext.graph_shader else {
                    return Err(self.err(format!("{what} needs graph_shader (the volume shader node)")));
                };
                let v = self.volume_program(&name, graph, shader, &what)?;
                for w in &v.warnings {
                    self.warn(format!("{what}: {w}"));
                }
                // A tree of constant shaders (Mix and Add Shader of volume shaders, Volume
                // Coefficients) is one homogeneous medium.
                match crate::medium::procedural_source::constant_medium(Box::new(v)) {
                    Ok(h) => medium = Some(h),
                    Err(v) => mat.volume_program = Some(v),
                }
            }
        }
        let mut subsurface = None;
        if let Some(v) = m.extension_value("CAUSTIC_materials_subsurface").cloned() {
            features.push("CAUSTIC_materials_subsurface".into());
            let ext: SubsurfaceExt = serde_json::from_value(v)
                .map_err(|e| self.err(format!("material '{name}': CAUSTIC_materials_subsurface is malformed: {e}")))?;
            let finite = [ext.weight, ext.anisotropy, ext.ior].iter().chain(ext.radius.iter()).all(|x| x.is_finite());
            if !finite || ext.weight < 0.0 || ext.radius.iter().any(|&r| r < 0.0) || ext.ior < 1.0 {
                return Err(self.err(format!(
                    "material '{name}': CAUSTIC_materials_subsurface needs finite values, weight and radius >= 0, ior >= 1"
                )));
            }
            let method = match ext.method.as_str() {
                "random_walk" => SubsurfaceMethod::RandomWalk,
                "random_walk_skin" => SubsurfaceMethod::RandomWalkSkin,
                other => {
                    return Err(self.err(format!(
                        "material '{name}': CAUSTIC_materials_subsurface method '{other}' is unknown (random_walk, random_walk_skin)"
                    )));
                }
            };
            if ext.weight > 1.0 || !(0.0..=0.9).contains(&ext.anisotropy) {
                self.warn(format!(
                    "material '{name}': subsurface weight was clamped to [0, 1] and anisotropy to [0, 0.9] (as Cycles)"
                ));
            }
            // Zero radii stay: those channels reflect diffusely (the walk's rule), as Cycles'.
            if ext.weight > 0.0 {
                subsurface = Some(Subsurface {
                    weight: ext.weight.min(1.0),
                    radius: Vec3::from(ext.radius),
                    anisotropy: ext.anisotropy.clamp(0.0, 0.9),
                    ior: ext.ior.clamp(1.01, 3.8),
                    method,
                    enter_at_ior: false,
                });
            }
        }
        let (mut coat, mut coat_tex, mut coat_roughness, mut coat_roughness_tex) = (0.0, None, 0.0, None);
        let (mut coat_normal_tex, mut coat_normal_scale) = (None, 1.0);
        if let Some(c) = m.extension_value("KHR_materials_clearcoat").cloned() {
            features.push("KHR_materials_clearcoat".into());
            coat = num(&c, "clearcoatFactor", 0.0)?.clamp(0.0, 1.0);
            coat_roughness = num(&c, "clearcoatRoughnessFactor", 0.0)?.clamp(0.0, 1.0);
            if let Some(t) = c.get("clearcoatTexture") {
                coat_tex = self.raw_texture(doc, t, false, buffers, &name)?;
            }
            if let Some(t) = c.get("clearcoatRoughnessTexture") {
                coat_roughness_tex = self.raw_texture(doc, t, false, buffers, &name)?;
            }
            if let Some(t) = c.get("clearcoatNormalTexture") {
                coat_normal_tex = self.raw_texture(doc, t, false, buffers, &name)?;
                coat_normal_scale = num(t, "scale", 1.0)?;
            }
        }
        // A colour factor: 3 finite numbers, clamped to be non-negative.
        let color3 = |v: &serde_json::Value, key: &str, default: Vec3| -> Result<Vec3> {
            match v.get(key) {
                None => Ok(default),
                Some(c) => c
                    .as_array()
                    .filter(|a| a.len() == 3)
                    .and_then(|a| {
                        let f: Vec<f32> = a.iter().filter_map(|x| x.as_f64().map(|f| f as f32)).collect();
                        (f.len() == 3 && f.iter().all(|x| x.is_finite())).then(|| Vec3::new(f[0], f[1], f[2]))
                    })
                    .map(|c| c.max(Vec3::ZERO))
                    .ok_or_else(|| Error::Scene {
                        file: self.file.to_string(),
                        message: format!("material '{name}': {key} must be 3 finite numbers"),
                    }),
            }
        };
        let (mut coat_ior, mut coat_tint, mut coat_dielectric_fresnel) = (1.5, Vec3::ONE, false);
        if let Some(c) = m.extension_value("CAUSTIC_materials_coat").cloned() {
            features.push("CAUSTIC_materials_coat".into());
            let v = num(&c, "ior", 1.5)?;
            if !(1.0..=10.0).contains(&v) {
                self.warn(format!("material '{name}': coat ior {v} was clamped to [1, 10]"));
            }
            coat_ior = v.clamp(1.0, 10.0);
            coat_tint = color3(&c, "tint", Vec3::ONE)?;
            coat_dielectric_fresnel =
                self.either(&c, "CAUSTIC_materials_coat", "fresnel", ["schlick", "dielectric"], &name)?;
            if coat_tint.max_element() > 1.0 {
                self.warn(format!("material '{name}': coat tint {coat_tint} was clamped to [0, 1]"));
                coat_tint = coat_tint.min(Vec3::ONE);
            }
            if coat == 0.0 {
                self.warn(format!(
                    "material '{name}': CAUSTIC_materials_coat without a coat (KHR_materials_clearcoat) does nothing"
                ));
            }
        }
        let (mut sheen_color, mut sheen_color_tex, mut sheen_roughness, mut sheen_roughness_tex) =
            (Vec3::ZERO, None, 0.0, None);
        if let Some(sh) = m.extension_value("KHR_materials_sheen").cloned() {
            features.push("KHR_materials_sheen".into());
            sheen_color = color3(&sh, "sheenColorFactor", Vec3::ZERO)?;
            if sheen_color.max_element() > 1.0 {
                self.warn(format!("material '{name}': sheenColorFactor {sheen_color} was clamped to [0, 1]"));
                sheen_color = sheen_color.min(Vec3::ONE);
            }
            sheen_roughness = num(&sh, "sheenRoughnessFactor", 0.0)?.clamp(0.0, 1.0);
            if let Some(t) = sh.get("sheenColorTexture") {
                sheen_color_tex = self.raw_texture(doc, t, true, buffers, &name)?;
            }
            if let Some(t) = sh.get("sheenRoughnessTexture") {
                sheen_roughness_tex = self.raw_texture(doc, t, false, buffers, &name)?;
            }
        }
        let mut sheen_microfiber = false;
        if let Some(sh) = m.extension_value("CAUSTIC_materials_sheen").cloned() {
            features.push("CAUSTIC_materials_sheen".into());
            sheen_microfiber =
                self.either(&sh, "CAUSTIC_materials_sheen", "model", ["charlie", "microfiber"], &name)?;
        }
        let mut transparent_shadow = true;
        if let Some(sh) = m.extension_value("CAUSTIC_materials_shadow").cloned() {
            features.push("CAUSTIC_materials_shadow".into());
            transparent_shadow = match sh.get("transparent") {
                None => true,
                Some(v) => v.as_bool().ok_or_else(|| {
                    self.err(format!("material '{name}': CAUSTIC_materials_shadow transparent must be true or false"))
                })?,
            };
        }
        let mut dispersion = 0.0;
        if let Some(d) = m.extension_value("KHR_materials_dispersion").cloned() {
            features.push("KHR_materials_dispersion".into());
            let v = num(&d, "dispersion", 0.0)?;
            if v < 0.0 {
                self.warn(format!("material '{name}': dispersion {v} is negative and was set to 0"));
            }
            dispersion = v.clamp(0.0, 20.0);
            if dispersion > 0.0 && roughness >= crate::bsdf::dielectric::SMOOTH_ROUGHNESS {
                self.warn(format!(
                    "material '{name}': dispersion is rendered on smooth glass only; this rough glass uses its mean index"
                ));
            }
        }
        let mut iridescence = None;
        if let Some(ext) = m.extension_value("KHR_materials_iridescence").cloned() {
            features.push("KHR_materials_iridescence".into());
            let metallic = mat.metallic > 0.0;
            let on_metal = match m.extension_value("CAUSTIC_materials_iridescence") {
                Some(c) => {
                    features.push("CAUSTIC_materials_iridescence".into());
                    self.either(c, "CAUSTIC_materials_iridescence", "metal", ["none", "conductor"], &name)?
                }
                None => false,
            };
            iridescence = self.iridescence(doc, &ext, buffers, &name, metallic, on_metal)?;
        } else if m.extension_value("CAUSTIC_materials_iridescence").is_some() {
            features.push("CAUSTIC_materials_iridescence".into());
            self.warn(format!(
                "material '{name}': CAUSTIC_materials_iridescence without a film (KHR_materials_iridescence) does nothing"
            ));
        }
        let (mut anisotropy_strength, mut anisotropy_rotation, mut anisotropy_tex) = (0.0, 0.0, None);
        if let Some(a) = m.extension_value("KHR_materials_anisotropy").cloned() {
            features.push("KHR_materials_anisotropy".into());
            let strength = num(&a, "anisotropyStrength", 0.0)?;
            anisotropy_strength = strength.clamp(0.0, 1.0);
            if anisotropy_strength != strength {
                self.warn(format!("material '{name}': anisotropyStrength {strength} was clamped to [0, 1]"));
            }
            anisotropy_rotation = num(&a, "anisotropyRotation", 0.0)?;
            if let Some(t) = a.get("anisotropyTexture") {
                anisotropy_tex = self.raw_texture(doc, t, false, buffers, &name)?;
            }
        }
        let mut anisotropy_blender = false;
        if let Some(a) = m.extension_value("CAUSTIC_materials_anisotropy").cloned() {
            features.push("CAUSTIC_materials_anisotropy".into());
            anisotropy_blender =
                self.either(&a, "CAUSTIC_materials_anisotropy", "mapping", ["gltf", "blender"], &name)?;
        }
        let mut specular = 1.0;
        let (mut specular_color, mut specular_tex, mut specular_color_tex) = (Vec3::ONE, None, None);
        if let Some(spec) = m.extension_value("KHR_materials_specular").cloned() {
            features.push("KHR_materials_specular".into());
            let factor = num(&spec, "specularFactor", 1.0)?;
            specular = factor.clamp(0.0, 1.0);
            if specular != factor {
                self.warn(format!("material '{name}': specularFactor {factor} was clamped to [0, 1]"));
            }
            specular_color = color3(&spec, "specularColorFactor", Vec3::ONE)?;
            if let Some(t) = spec.get("specularTexture") {
                specular_tex = self.raw_texture(doc, t, false, buffers, &name)?;
            }
            if let Some(t) = spec.get("specularColorTexture") {
                specular_color_tex = self.raw_texture(doc, t, true, buffers, &name)?;
            }
        }
        let (mut diffuse_transmission, mut diffuse_transmission_tex) = (0.0, None);
        let (mut diffuse_transmission_color, mut diffuse_transmission_color_tex) = (Vec3::ONE, None);
        if let Some(d) = m.extension_value("KHR_materials_diffuse_transmission").cloned() {
            features.push("KHR_materials_diffuse_transmission".into());
            let factor = num(&d, "diffuseTransmissionFactor", 0.0)?;
            diffuse_transmission = factor.clamp(0.0, 1.0);
            if diffuse_transmission != factor {
                self.warn(format!("material '{name}': diffuseTransmissionFactor {factor} was clamped to [0, 1]"));
            }
            diffuse_transmission_color = color3(&d, "diffuseTransmissionColorFactor", Vec3::ONE)?;
            if diffuse_transmission_color.max_element() > 1.0 {
                self.warn(format!(
                    "material '{name}': diffuseTransmissionColorFactor {diffuse_transmission_color} was clamped to [0, 1]"
                ));
                diffuse_transmission_color = diffuse_transmission_color.min(Vec3::ONE);
            }
            // The factor is the texture's A channel, the colour its sRGB RGB (the spec).
            if let Some(t) = d.get("diffuseTransmissionTexture") {
                diffuse_transmission_tex = self.raw_texture(doc, t, false, buffers, &name)?;
            }
            if let Some(t) = d.get("diffuseTransmissionColorTexture") {
                diffuse_transmission_color_tex = self.raw_texture(doc, t, true, buffers, &name)?;
            }
        }
        if let Some(exts) = m.extensions() {
            for key in exts.keys() {
                if HANDLED_MATERIAL_EXTENSIONS.contains(&key.as_str()) {
                    continue;
                }
                features.push(format!("{key} (ignored)"));
                self.warn(format!("material '{name}': {key} is not rendered yet and was ignored"));
            }
        }
        mat.specular = specular;
        mat.specular_tex = specular_tex;
        mat.specular_color = specular_color;
        mat.specular_color_tex = specular_color_tex;
        mat.ior = ior;
        mat.transmission = transmission;
        mat.transmission_tex = transmission_tex;
        mat.diffuse_transmission = diffuse_transmission;
        mat.diffuse_transmission_tex = diffuse_transmission_tex;
        mat.diffuse_transmission_color = diffuse_transmission_color;
        mat.diffuse_transmission_color_tex = diffuse_transmission_color_tex;
        mat.medium = medium;
        mat.null_surface = null_surface;
        if null_surface {
            // No surface, no surface emission (Cycles renders nothing of an unlinked Surface
            // output). Blender's glTF exporter writes a volume's Emission node as
            // emissiveFactor, which made the boundary's triangles lights that NEE sampled
            // though camera rays crossed them unseen: 1.37x Cycles in a cube glowing alone.
            mat.emissive = glam::Vec3::ZERO;
            mat.emissive_tex = None;
        }
        mat.subsurface = subsurface;
        mat.coat = coat;
        mat.coat_tex = coat_tex;
        mat.coat_roughness = coat_roughness;
        mat.coat_roughness_tex = coat_roughness_tex;
        mat.coat_ior = coat_ior;
        mat.coat_dielectric_fresnel = coat_dielectric_fresnel;
        mat.coat_tint = coat_tint;
        mat.coat_normal_tex = coat_normal_tex;
        mat.coat_normal_scale = coat_normal_scale;
        mat.sheen_color = sheen_color;
        mat.sheen_color_tex = sheen_color_tex;
        mat.sheen_roughness = sheen_roughness;
        mat.sheen_roughness_tex = sheen_roughness_tex;
        mat.sheen_microfiber = sheen_microfiber;
        mat.transparent_shadow = transparent_shadow;
        mat.dispersion = dispersion;
        mat.iridescence = iridescence;
        mat.anisotropy_strength = anisotropy_strength;
        mat.anisotropy_rotation = anisotropy_rotation;
        mat.anisotropy_tex = anisotropy_tex;
        mat.anisotropy_blender = anisotropy_blender;
        if let Some(n) = m.extension_value("CAUSTIC_materials_normal_map").cloned() {
            features.push("CAUSTIC_materials_normal_map".into());
            mat.normal_strength_blender =
                self.either(&n, "CAUSTIC_materials_normal_map", "mapping", ["gltf", "blender"], &name)?;
        }
        Ok(())
    }
}
