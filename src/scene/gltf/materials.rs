//! glTF materials to [`Material`]: metallic-roughness factors and textures, normal maps,
//! alpha; the extensions are read in `material_ext.rs`.

use super::{Loader, push_unique};
use crate::error::Result;
use crate::scene::texture::texture_transform;
use crate::scene::{AlphaMode, Material, MaterialReport};
use glam::{Mat3, Vec3, Vec4};

impl Loader<'_> {
    /// Converts glTF material `m`, with the features it uses for the report.
    pub(super) fn material(
        &mut self,
        doc: &gltf::Document,
        m: &gltf::Material,
        buffers: &[Vec<u8>],
    ) -> Result<(Material, MaterialReport)> {
        let index = m.index().unwrap_or(0);
        let name = m.name().map(str::to_string).unwrap_or_else(|| format!("material {index}"));
        let mut features = Vec::new();
        let pbr = m.pbr_metallic_roughness();
        let check = |v: f32, what: &str| -> Result<f32> {
            if v.is_finite() {
                Ok(v)
            } else {
                Err(self.err(format!("material '{name}': {what} is not a finite number")))
            }
        };
        let bc = pbr.base_color_factor();
        let base_color = Vec4::new(
            check(bc[0], "baseColorFactor")?,
            check(bc[1], "baseColorFactor")?,
            check(bc[2], "baseColorFactor")?,
            check(bc[3], "baseColorFactor")?,
        );
        let metallic = check(pbr.metallic_factor(), "metallicFactor")?;
        let roughness = check(pbr.roughness_factor(), "roughnessFactor")?;
        let em = m.emissive_factor();
        let strength = m.emissive_strength().unwrap_or(1.0);
        let emissive = Vec3::new(
            check(em[0], "emissiveFactor")?,
            check(em[1], "emissiveFactor")?,
            check(em[2], "emissiveFactor")?,
        ) * check(strength, "emissive strength")?;
        let clamped = |v: Vec4| v.clamp(Vec4::ZERO, Vec4::ONE);
        if clamped(base_color) != base_color || !(0.0..=1.0).contains(&metallic) || !(0.0..=1.0).contains(&roughness) {
            self.warn(format!("material '{name}': factors outside [0, 1] were clamped"));
        }
        if emissive.min_element() < 0.0 {
            self.warn(format!("material '{name}': negative emission was clamped to 0"));
        }
        if m.emissive_strength().is_some() {
            features.push("KHR_materials_emissive_strength".into());
        }
        let base_color_tex =
            self.info_texture(doc, pbr.base_color_texture(), true, buffers, &mut features, "baseColorTexture", &name)?;
        let metallic_roughness_tex = self.info_texture(
            doc,
            pbr.metallic_roughness_texture(),
            false,
            buffers,
            &mut features,
            "metallicRoughnessTexture",
            &name,
        )?;
        let emissive_tex =
            self.info_texture(doc, m.emissive_texture(), true, buffers, &mut features, "emissiveTexture", &name)?;
        let (normal_tex, normal_scale) = match m.normal_texture() {
            Some(n) if self.undecodable(&n.texture(), &name) => (None, 1.0),
            Some(n) => {
                let mut transform = Mat3::IDENTITY;
                let mut tex_coord = n.tex_coord();
                if let Some(t) = n.extension_value("KHR_texture_transform") {
                    let f = |k: &str, d: f32, i: usize| {
                        t.get(k)
                            .and_then(|v| v.get(i).or(Some(v)))
                            .and_then(|v| v.as_f64())
                            .map(|v| v as f32)
                            .unwrap_or(d)
                    };
                    transform = texture_transform(
                        [f("offset", 0.0, 0), f("offset", 0.0, 1)],
                        f("rotation", 0.0, 0),
                        [f("scale", 1.0, 0), f("scale", 1.0, 1)],
                    );
                    if let Some(tc) = t.get("texCoord").and_then(|v| v.as_u64()) {
                        tex_coord = tc as u32;
                    }
                    push_unique(&mut features, "KHR_texture_transform");
                }
                features.push("normalTexture".into());
                (Some(self.texture(doc, n.texture(), tex_coord, transform, false, buffers)?), n.scale())
            }
            None => (None, 1.0),
        };
        if m.occlusion_texture().is_some() {
            features.push("occlusionTexture (ignored: path tracing computes occlusion)".into());
        }
        let alpha_mode = match m.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => {
                features.push("alphaMode MASK".into());
                AlphaMode::Mask(m.alpha_cutoff().unwrap_or(0.5))
            }
            gltf::material::AlphaMode::Blend => {
                features.push("alphaMode BLEND (stochastic transparency)".into());
                AlphaMode::Blend
            }
        };
        if m.double_sided() {
            features.push("doubleSided".into());
        }
        let mut mat = Material {
            name: name.clone(),
            base_color: clamped(base_color),
            base_color_tex,
            metallic: metallic.clamp(0.0, 1.0),
            roughness: roughness.clamp(0.0, 1.0),
            metallic_roughness_tex,
            normal_tex,
            normal_scale,
            emissive: emissive.max(Vec3::ZERO),
            emissive_tex,
            alpha_mode,
            ..Material::default()
        };
        self.material_extensions(doc, m, buffers, &mut mat, &mut features)?;
        if let Some(ext) = m.extension_value("KHR_materials_pbrSpecularGlossiness") {
            features.push("KHR_materials_pbrSpecularGlossiness".into());
            self.specular_glossiness(doc, ext, buffers, &mut mat)?;
        }
        if m.extension_value("KHR_materials_unlit").is_some() {
            // The spec: the base colour (factor × texture × vertex colour) is the surface's
            // colour, every other lighting property is ignored; alpha and doubleSided apply.
            // Rendered as emission of that colour over a surface that reflects nothing, seen
            // by camera rays alone and no light, as Blender's importer builds it (Emission for
            // camera rays, Transparent for the others: "so it won't glow"): the sample model
            // UnlitTest's README allows shadows, lit panels on the object itself it does not.
            features.push("KHR_materials_unlit".into());
            mat.unlit = true;
            mat.emissive = mat.base_color.truncate();
            mat.emissive_tex = mat.base_color_tex;
        }
        self.material_nodes(m, &mut mat, &mut features)?;
        Ok((mat, MaterialReport { name, features }))
    }
}

#[cfg(test)]
mod tests {
    //! Material parsing from small glTF documents built in memory: one triangle whose
    //! primitive uses the material under test, textures as PNG data URIs.

    use crate::memory::MemoryBudget;
    use crate::scene::{AlphaMode, Material, Scene};
    use base64::Engine;
    use glam::{Vec2, Vec3, Vec4};
    use serde_json::{Value, json};

    /// A 2×2 RGBA PNG as a data URI.
    fn png_uri(rgba: [u8; 4]) -> String {
        let img = image::RgbaImage::from_pixel(2, 2, image::Rgba(rgba));
        let mut bytes = std::io::Cursor::new(Vec::new());
        img.write_to(&mut bytes, image::ImageFormat::Png).unwrap();
        format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(bytes.get_ref()))
    }

    /// Loads a one-triangle scene whose triangle uses `material`; the file has
    /// `textures` textures, each on its own 2×2 image (texture i's texels are all i+1).
    fn load_with(material: Value, textures: usize) -> crate::error::Result<Scene> {
        let positions: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|f| f.to_le_bytes()).collect();
        let uvs: Vec<u8> = [0f32, 0., 1., 0., 0., 1.].iter().flat_map(|f| f.to_le_bytes()).collect();
        let normals: Vec<u8> = [0f32, 0., 1., 0., 0., 1., 0., 0., 1.].iter().flat_map(|f| f.to_le_bytes()).collect();
        let data = [positions, uvs, normals].concat();
        let uri =
            format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&data));
        let mut used: Vec<String> = Vec::new();
        if let Some(exts) = material.get("extensions").and_then(Value::as_object) {
            used.extend(exts.keys().cloned());
        }
        let doc = json!({
            "asset": {"version": "2.0"},
            "extensionsUsed": used,
            "buffers": [{"uri": uri, "byteLength": data.len()}],
            "bufferViews": [
                {"buffer": 0, "byteOffset": 0, "byteLength": 36},
                {"buffer": 0, "byteOffset": 36, "byteLength": 24},
                {"buffer": 0, "byteOffset": 60, "byteLength": 36}
            ],
            "accessors": [
                {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                 "min": [0, 0, 0], "max": [1, 1, 0]},
                {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"},
                {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC3"}
            ],
            "images": (0..textures).map(|i| json!({"uri": png_uri([i as u8 + 1; 4])})).collect::<Vec<_>>(),
            "textures": (0..textures).map(|i| json!({"source": i})).collect::<Vec<_>>(),
            "materials": [material],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1, "NORMAL": 2}, "material": 0}]}],
            "nodes": [{"mesh": 0}],
            "scenes": [{"nodes": [0]}],
            "scene": 0
        });
        let bytes = serde_json::to_vec(&doc).unwrap();
        super::super::load_bytes(&bytes, std::path::Path::new("."), "test.gltf", &MemoryBudget::unlimited())
    }

    fn material(m: Value, textures: usize) -> (Material, Scene) {
        let scene = load_with(m, textures).unwrap_or_else(|e| panic!("load failed: {e}"));
        (scene.materials[0].clone(), scene)
    }

    /// The texture a reference points to, identified by its texel value (texture i is i+1).
    fn texel_id(scene: &Scene, t: Option<crate::scene::TexRef>) -> u8 {
        let t = t.expect("a texture");
        scene.textures[t.texture as usize].texels[0][0] - 1
    }

    fn error(m: Value, textures: usize) -> String {
        match load_with(m, textures) {
            Ok(_) => panic!("expected an error"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn an_empty_material_is_the_gltf_default() {
        let (m, _) = material(json!({"name": "m"}), 0);
        assert_eq!(m.base_color, Vec4::ONE);
        assert_eq!((m.metallic, m.roughness, m.ior, m.specular, m.transmission), (1.0, 1.0, 1.5, 1.0, 0.0));
        assert_eq!(m.alpha_mode, AlphaMode::Opaque);
        assert!(m.medium.is_none() && m.emissive == Vec3::ZERO);
    }

    #[test]
    fn unlit_shows_the_base_colour_and_ignores_emission() {
        let (m, scene) = material(
            json!({"name": "flat",
                "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.25, 0.125, 0.75], "baseColorTexture": {"index": 0}},
                "emissiveFactor": [1.0, 1.0, 1.0], "emissiveTexture": {"index": 1},
                "extensions": {"KHR_materials_unlit": {}}}),
            2,
        );
        assert!(m.unlit);
        assert_eq!(m.emissive, Vec3::new(0.5, 0.25, 0.125));
        assert_eq!(texel_id(&scene, m.emissive_tex), 0, "the emission is the base colour texture");
        assert_eq!(m.base_color.w, 0.75, "alpha still applies");
    }

    #[test]
    fn anisotropy_strength_rotation_and_texture() {
        let (m, scene) = material(
            json!({"name": "brushed",
                "extensions": {"KHR_materials_anisotropy": {"anisotropyStrength": 0.6, "anisotropyRotation": 0.75,
                    "anisotropyTexture": {"index": 0}}}}),
            1,
        );
        assert_eq!((m.anisotropy_strength, m.anisotropy_rotation), (0.6, 0.75));
        assert_eq!(texel_id(&scene, m.anisotropy_tex), 0);
        assert!(!m.anisotropy_blender, "glTF's mapping unless the file says otherwise");
        let blender = json!({"name": "b", "extensions": {
            "KHR_materials_anisotropy": {"anisotropyStrength": 0.6},
            "CAUSTIC_materials_anisotropy": {"mapping": "blender"}}});
        assert!(material(blender, 0).0.anisotropy_blender);
        let bad = json!({"name": "b", "extensions": {"CAUSTIC_materials_anisotropy": {"mapping": "cycles"}}});
        assert!(error(bad, 0).contains("mapping 'cycles'"));
    }

    #[test]
    fn normal_map_strength_mapping() {
        let plain = json!({"name": "n", "normalTexture": {"index": 0, "scale": 0.5}});
        let (m, _) = material(plain, 1);
        assert_eq!((m.normal_scale, m.normal_strength_blender), (0.5, false), "glTF's mapping by default");
        let blender = json!({"name": "n", "normalTexture": {"index": 0, "scale": 0.5},
            "extensions": {"CAUSTIC_materials_normal_map": {"mapping": "blender"}}});
        assert!(material(blender, 1).0.normal_strength_blender);
        let bad = json!({"name": "b", "extensions": {"CAUSTIC_materials_normal_map": {"mapping": "cycles"}}});
        assert!(error(bad, 0).contains("mapping 'cycles'"));
    }

    #[test]
    fn coat_fresnel_schlick_unless_the_file_says_dielectric() {
        let coat = json!({"clearcoatFactor": 1.0});
        let plain = json!({"name": "c", "extensions": {"KHR_materials_clearcoat": coat}});
        assert!(!material(plain, 0).0.coat_dielectric_fresnel, "glTF's Schlick by default");
        let blender = json!({"name": "c", "extensions": {"KHR_materials_clearcoat": coat,
            "CAUSTIC_materials_coat": {"fresnel": "dielectric"}}});
        let (m, _) = material(blender, 0);
        assert!(m.coat_dielectric_fresnel);
        assert_eq!(m.coat_ior, 1.5, "the IOR keeps its default");
        let bad = json!({"name": "b", "extensions": {"KHR_materials_clearcoat": coat,
            "CAUSTIC_materials_coat": {"fresnel": "exact"}}});
        assert!(error(bad, 0).contains("fresnel 'exact'"));
    }

    #[test]
    fn sheen_model_charlie_unless_the_file_says_microfiber() {
        let sheen = json!({"sheenColorFactor": [0.5, 0.4, 0.3], "sheenRoughnessFactor": 0.25});
        let (m, _) = material(json!({"name": "velvet", "extensions": {"KHR_materials_sheen": sheen}}), 0);
        assert_eq!((m.sheen_color, m.sheen_roughness, m.sheen_microfiber), (Vec3::new(0.5, 0.4, 0.3), 0.25, false));
        let blender = json!({"name": "b", "extensions": {"KHR_materials_sheen": sheen,
            "CAUSTIC_materials_sheen": {"model": "microfiber"}}});
        assert!(material(blender, 0).0.sheen_microfiber);
        let bad = json!({"name": "b", "extensions": {"CAUSTIC_materials_sheen": {"model": "velvet"}}});
        assert!(error(bad, 0).contains("model 'velvet'"));
    }

    /// A film on a metal is left off it (warned) unless the add-on's marker puts it on Cycles'
    /// conductor; the marker without a film, or with another value, is named.
    #[test]
    fn iridescence_on_the_metal_only_when_marked() {
        let film = json!({"iridescenceFactor": 1.0, "iridescenceIor": 1.8, "iridescenceThicknessMaximum": 300.0});
        let (m, scene) = material(json!({"name": "g", "extensions": {"KHR_materials_iridescence": film}}), 0);
        assert!(!m.iridescence.expect("a film").on_metal);
        assert!(
            scene.warnings.iter().any(|w| w.contains("'g'") && w.contains("not on the metal")),
            "{:?}",
            scene.warnings
        );
        let marked = json!({"name": "b", "extensions": {"KHR_materials_iridescence": film,
            "CAUSTIC_materials_iridescence": {"metal": "conductor"}}});
        let (m, scene) = material(marked, 0);
        assert!(m.iridescence.expect("a film").on_metal);
        assert!(scene.warnings.iter().all(|w| !w.contains("not on the metal")), "{:?}", scene.warnings);
        let alone = json!({"name": "a", "extensions": {"CAUSTIC_materials_iridescence": {"metal": "conductor"}}});
        let (_, scene) = material(alone, 0);
        assert!(scene.warnings.iter().any(|w| w.contains("'a'") && w.contains("does nothing")), "{:?}", scene.warnings);
        let bad = json!({"name": "b", "extensions": {"KHR_materials_iridescence": film,
            "CAUSTIC_materials_iridescence": {"metal": "gold"}}});
        assert!(error(bad, 0).contains("metal 'gold'"));
    }

    #[test]
    fn shadows_transparent_unless_the_file_says_not() {
        let (m, _) = material(json!({"name": "leaf", "alphaMode": "BLEND"}), 0);
        assert!(m.transparent_shadow);
        let opaque = json!({"name": "b", "alphaMode": "BLEND",
            "extensions": {"CAUSTIC_materials_shadow": {"transparent": false}}});
        assert!(!material(opaque, 0).0.transparent_shadow);
        let bad = json!({"name": "b", "extensions": {"CAUSTIC_materials_shadow": {"transparent": "no"}}});
        assert!(error(bad, 0).contains("transparent must be true or false"));
    }

    #[test]
    fn diffuse_transmission_factor_colour_and_textures() {
        let (m, scene) = material(
            json!({"name": "leaf", "extensions": {"KHR_materials_diffuse_transmission": {
                "diffuseTransmissionFactor": 0.6, "diffuseTransmissionColorFactor": [0.3, 0.8, 0.1],
                "diffuseTransmissionTexture": {"index": 0}, "diffuseTransmissionColorTexture": {"index": 1}}}}),
            2,
        );
        assert_eq!((m.diffuse_transmission, m.diffuse_transmission_color), (0.6, Vec3::new(0.3, 0.8, 0.1)));
        assert_eq!(texel_id(&scene, m.diffuse_transmission_tex), 0);
        assert!(!scene.textures[m.diffuse_transmission_tex.unwrap().texture as usize].srgb, "the factor is data (A)");
        assert_eq!(texel_id(&scene, m.diffuse_transmission_color_tex), 1);
        assert!(scene.textures[m.diffuse_transmission_color_tex.unwrap().texture as usize].srgb, "the colour is sRGB");
        assert!(scene.warnings.iter().all(|w| !w.contains("diffuse_transmission")), "{:?}", scene.warnings);
        let (m, scene) = material(
            json!({"name": "l", "extensions": {"KHR_materials_diffuse_transmission": {
                "diffuseTransmissionFactor": 1.5, "diffuseTransmissionColorFactor": [2.0, 0.5, 0.5]}}}),
            0,
        );
        assert_eq!((m.diffuse_transmission, m.diffuse_transmission_color), (1.0, Vec3::new(1.0, 0.5, 0.5)));
        assert_eq!(scene.warnings.iter().filter(|w| w.contains("clamped")).count(), 2, "{:?}", scene.warnings);
        let bad = json!({"name": "l", "extensions": {"KHR_materials_diffuse_transmission": {
            "diffuseTransmissionColorFactor": [1.0, 0.5]}}});
        assert!(error(bad, 0).contains("diffuseTransmissionColorFactor must be 3 finite numbers"));
    }

    #[test]
    fn core_factors_and_textures() {
        let (m, scene) = material(
            json!({"name": "m",
                "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.25, 0.125, 0.75], "metallicFactor": 0.3,
                    "roughnessFactor": 0.6, "baseColorTexture": {"index": 0},
                    "metallicRoughnessTexture": {"index": 1, "texCoord": 1}},
                "normalTexture": {"index": 2, "scale": 0.5},
                "emissiveTexture": {"index": 3,
                    "extensions": {"KHR_texture_transform": {"offset": [0.5, 0.0], "scale": [2.0, 2.0]}}},
                "emissiveFactor": [1.0, 0.5, 0.0],
                "alphaMode": "MASK", "alphaCutoff": 0.25, "doubleSided": true}),
            4,
        );
        assert_eq!(m.base_color, Vec4::new(0.5, 0.25, 0.125, 0.75));
        assert_eq!((m.metallic, m.roughness), (0.3, 0.6));
        assert_eq!(m.emissive, Vec3::new(1.0, 0.5, 0.0));
        assert_eq!(m.alpha_mode, AlphaMode::Mask(0.25));
        assert_eq!(texel_id(&scene, m.base_color_tex), 0);
        assert!(scene.textures[m.base_color_tex.unwrap().texture as usize].srgb, "base colour is sRGB");
        assert_eq!(texel_id(&scene, m.metallic_roughness_tex), 1);
        assert_eq!(m.metallic_roughness_tex.unwrap().tex_coord, 1);
        assert!(!scene.textures[m.metallic_roughness_tex.unwrap().texture as usize].srgb, "data is linear");
        assert_eq!(texel_id(&scene, m.normal_tex), 2);
        assert_eq!(m.normal_scale, 0.5);
        assert_eq!(texel_id(&scene, m.emissive_tex), 3);
        // KHR_texture_transform: uv × scale + offset.
        let uv = m.emissive_tex.unwrap().uv(Vec2::new(0.25, 0.5));
        assert!((uv - Vec2::new(1.0, 1.0)).length() < 1e-6, "{uv}");
    }

    #[test]
    fn emissive_strength_multiplies_the_factor() {
        let (m, _) = material(
            json!({"emissiveFactor": [1.0, 0.5, 0.25],
                "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}}),
            0,
        );
        assert_eq!(m.emissive, Vec3::new(4.0, 2.0, 1.0));
    }

    #[test]
    fn transmission_ior_and_volume() {
        let (m, scene) = material(
            json!({"extensions": {
                "KHR_materials_transmission": {"transmissionFactor": 0.9, "transmissionTexture": {"index": 0}},
                "KHR_materials_ior": {"ior": 1.33},
                "KHR_materials_volume": {"thicknessFactor": 0.5, "attenuationColor": [0.5, 0.25, 1.0],
                    "attenuationDistance": 2.0}}}),
            1,
        );
        assert_eq!((m.transmission, m.ior), (0.9, 1.33));
        assert_eq!(texel_id(&scene, m.transmission_tex), 0);
        // Beer-Lambert: exp(-σa d) = attenuationColor at d = attenuationDistance.
        let sigma_a = m.medium.expect("a volume with thickness bounds a medium").sigma_a;
        let want = Vec3::new(0.5f32.ln(), 0.25f32.ln(), 0.0) / -2.0;
        assert!((sigma_a - want).abs().max_element() < 1e-6, "{sigma_a} vs {want}");
    }

    #[test]
    fn out_of_range_factors_are_clamped_with_a_warning_naming_the_material() {
        let scene = load_with(
            json!({"name": "glassy", "extensions": {"KHR_materials_transmission": {"transmissionFactor": 2.0},
                "KHR_materials_ior": {"ior": 0.5}}}),
            0,
        )
        .unwrap();
        // An IOR below 1 is kept (Cycles renders Blender's import of it), named as outside
        // glTF's range; 0 becomes Cycles' 1e-5.
        assert_eq!((scene.materials[0].transmission, scene.materials[0].ior), (1.0, 0.5));
        assert!(scene.warnings.iter().any(|w| w.contains("'glassy'") && w.contains("transmissionFactor")));
        assert!(scene.warnings.iter().any(|w| w.contains("'glassy'") && w.contains("ior 0.5")), "{:?}", scene.warnings);
        let scene = load_with(json!({"name": "mirror", "extensions": {"KHR_materials_ior": {"ior": 0.0}}}), 0).unwrap();
        assert_eq!(scene.materials[0].ior, crate::bsdf::pbr::MIN_IOR);
    }

    #[test]
    fn clearcoat_and_caustic_coat() {
        let (m, scene) = material(
            json!({"extensions": {
                "KHR_materials_clearcoat": {"clearcoatFactor": 0.8, "clearcoatRoughnessFactor": 0.2,
                    "clearcoatTexture": {"index": 0}, "clearcoatRoughnessTexture": {"index": 1},
                    "clearcoatNormalTexture": {"index": 2, "scale": 0.7}},
                "CAUSTIC_materials_coat": {"ior": 1.6, "tint": [1.0, 0.5, 0.25]}}}),
            3,
        );
        assert_eq!((m.coat, m.coat_roughness, m.coat_normal_scale, m.coat_ior), (0.8, 0.2, 0.7, 1.6));
        assert_eq!(m.coat_tint, Vec3::new(1.0, 0.5, 0.25));
        assert_eq!(
            [texel_id(&scene, m.coat_tex), texel_id(&scene, m.coat_roughness_tex), texel_id(&scene, m.coat_normal_tex)],
            [0, 1, 2]
        );
    }

    #[test]
    fn specular_sheen_and_dispersion() {
        let (m, scene) = material(
            json!({"extensions": {
                "KHR_materials_specular": {"specularFactor": 0.4, "specularColorFactor": [1.0, 0.8, 0.6],
                    "specularTexture": {"index": 0}, "specularColorTexture": {"index": 1}},
                "KHR_materials_sheen": {"sheenColorFactor": [0.2, 0.3, 0.4], "sheenRoughnessFactor": 0.5,
                    "sheenColorTexture": {"index": 2}, "sheenRoughnessTexture": {"index": 3}},
                "KHR_materials_dispersion": {"dispersion": 0.5}}}),
            4,
        );
        assert_eq!((m.specular, m.specular_color), (0.4, Vec3::new(1.0, 0.8, 0.6)));
        assert_eq!((m.sheen_color, m.sheen_roughness, m.dispersion), (Vec3::new(0.2, 0.3, 0.4), 0.5, 0.5));
        let ids = [m.specular_tex, m.specular_color_tex, m.sheen_color_tex, m.sheen_roughness_tex];
        assert_eq!(ids.map(|t| texel_id(&scene, t)), [0, 1, 2, 3]);
        // Colour textures are sRGB, the others linear.
        let srgb = ids.map(|t| scene.textures[t.unwrap().texture as usize].srgb);
        assert_eq!(srgb, [false, true, true, false]);
    }

    #[test]
    fn a_medium_without_surface_emits_nothing_from_its_boundary() {
        // Blender's glTF exporter writes a Volume output's Emission node as emissiveFactor;
        // with no surface the boundary must not become an emitter (its triangles lights).
        let (m, _) = material(
            json!({"emissiveFactor": [0.8, 0.32, 0.08], "extensions": {
                "CAUSTIC_materials_medium": {"density": 0.0, "emission": [0.8, 0.32, 0.08], "surface": false}}}),
            0,
        );
        assert!(m.null_surface && !m.is_emissive() && m.emissive_tex.is_none());
        assert_eq!(m.medium.expect("medium").emission, Vec3::new(0.8, 0.32, 0.08));
        let (m, _) = material(
            json!({"emissiveFactor": [0.8, 0.32, 0.08], "extensions": {
                "CAUSTIC_materials_medium": {"density": 0.0, "emission": [0.8, 0.32, 0.08], "surface": true}}}),
            0,
        );
        assert!(m.is_emissive(), "a surface keeps its own emission");
    }

    #[test]
    fn caustic_medium_and_subsurface() {
        let (m, _) = material(
            json!({"extensions": {
                "CAUSTIC_materials_medium": {"density": 2.0, "scatter_color": [0.5, 0.5, 1.0],
                    "absorption_color": [0.1, 0.0, 0.0], "anisotropy": 0.3, "emission": [0.0, 1.0, 0.0],
                    "surface": false},
                "CAUSTIC_materials_subsurface": {"weight": 0.5, "radius": [1.0, 0.2, 0.1], "anisotropy": 0.1,
                    "ior": 1.3, "method": "random_walk_skin"}}}),
            0,
        );
        let med = m.medium.expect("medium");
        assert_eq!(
            (med.sigma_s, med.sigma_a, med.emission),
            (Vec3::new(1.0, 1.0, 2.0), Vec3::new(0.2, 0.0, 0.0), Vec3::Y)
        );
        assert!(m.null_surface);
        let s = m.subsurface.expect("subsurface");
        assert_eq!((s.weight, s.radius, s.anisotropy, s.ior), (0.5, Vec3::new(1.0, 0.2, 0.1), 0.1, 1.3));
        assert_eq!(s.method, crate::scene::material::SubsurfaceMethod::RandomWalkSkin);
    }

    #[test]
    fn invalid_values_name_the_material_and_the_problem() {
        let cases = [
            (
                json!({"KHR_materials_transmission": {"transmissionFactor": "x"}}),
                "transmissionFactor is not a finite number",
            ),
            (json!({"KHR_materials_specular": {"specularFactor": "a"}}), "specularFactor is not a finite number"),
            (json!({"KHR_materials_volume": {"attenuationColor": [1.0, "a", 1.0]}}), "3 finite attenuationColor"),
            (
                json!({"KHR_materials_volume": {"thicknessFactor": 1.0, "attenuationDistance": 0.0}}),
                "attenuationDistance > 0",
            ),
            (
                json!({"KHR_materials_sheen": {"sheenColorFactor": [1.0, 1.0]}}),
                "sheenColorFactor must be 3 finite numbers",
            ),
            (json!({"CAUSTIC_materials_coat": {"tint": "red"}}), "tint must be 3 finite numbers"),
            (json!({"CAUSTIC_materials_medium": {"anisotropy": 2.0}}), "anisotropy 2 is outside [-1, 1]"),
            (json!({"CAUSTIC_materials_medium": {"densty": 2.0}}), "CAUSTIC_materials_medium is malformed"),
            (json!({"CAUSTIC_materials_medium": {"density": -1.0}}), "finite, non-negative density"),
            (
                json!({"CAUSTIC_materials_subsurface": {"radius": [1.0, 1.0, 1.0], "method": "dipole"}}),
                "method 'dipole' is unknown",
            ),
            (json!({"CAUSTIC_materials_subsurface": {"radius": [1.0, 1.0, 1.0], "ior": 0.5}}), "ior >= 1"),
        ];
        for (ext, want) in cases {
            let msg = error(json!({"name": "bad", "extensions": ext}), 0);
            assert!(msg.contains(want), "{ext}: {msg}");
            assert!(msg.contains("material 'bad'"), "{ext}: {msg}");
        }
    }
}
