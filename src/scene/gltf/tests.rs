//! Tests of glTF loading: required extensions, default materials, texture sources.

use super::{SUPPORTED_REQUIRED, load_bytes};
use crate::memory::MemoryBudget;
use base64::Engine;
use serde_json::json;

/// One triangle whose file lists `required` in extensionsRequired (and extensionsUsed).
fn load_requiring(required: &[&str]) -> crate::error::Result<crate::scene::Scene> {
    load_triangle(required, json!({}))
}

/// One triangle without a material, `required` in extensionsRequired, `root`'s keys
/// set on the document's root.
fn load_triangle(required: &[&str], root: serde_json::Value) -> crate::error::Result<crate::scene::Scene> {
    let data: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|f| f.to_le_bytes()).collect();
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&data));
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": required,
        "extensionsRequired": required,
        "buffers": [{"uri": uri, "byteLength": 36}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
            "min": [0, 0, 0], "max": [1, 1, 0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}]
    });
    let mut doc = doc;
    for (k, v) in root.as_object().unwrap() {
        doc[k] = v.clone();
    }
    load_bytes(&serde_json::to_vec(&doc).unwrap(), std::path::Path::new("."), "req.gltf", &MemoryBudget::unlimited())
}

/// The unit triangle (0,0,0) (1,0,0) (0,1,0) as accessor 0, with `extra` bytes after its
/// positions in the one buffer (for further accessors) and `root`'s keys set on the document;
/// the loader tests of other files (pose, gpu instancing, specular-glossiness) build on it.
pub(super) fn load_triangle_after(extra: &[u8], root: serde_json::Value) -> crate::error::Result<crate::scene::Scene> {
    let mut data: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|f| f.to_le_bytes()).collect();
    data.extend_from_slice(extra);
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&data));
    let mut doc = json!({
        "asset": {"version": "2.0"},
        "buffers": [{"uri": uri, "byteLength": data.len()}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
            "min": [0, 0, 0], "max": [1, 1, 0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}]
    });
    for (k, v) in root.as_object().unwrap() {
        doc[k] = v.clone();
    }
    load_bytes(&serde_json::to_vec(&doc).unwrap(), std::path::Path::new("."), "test.gltf", &MemoryBudget::unlimited())
}

/// A 2×2 image of one colour, encoded as PNG or lossless WebP, as a data URI.
fn image_uri(rgb: [u8; 3], webp: bool) -> String {
    let img = image::RgbaImage::from_pixel(2, 2, image::Rgba([rgb[0], rgb[1], rgb[2], 255]));
    let mut bytes = Vec::new();
    let (format, mime) =
        if webp { (image::ImageFormat::WebP, "image/webp") } else { (image::ImageFormat::Png, "image/png") };
    img.write_to(&mut std::io::Cursor::new(&mut bytes), format).unwrap();
    format!("data:{mime};base64,{}", base64::engine::general_purpose::STANDARD.encode(&bytes))
}

#[test]
fn ext_texture_webp_reads_the_webp_image_over_the_fallback() {
    // Texture 0 has a PNG fallback (red) and a WebP source (green); texture 1 only WebP.
    for (texture, required) in [
        (json!({"source": 0, "extensions": {"EXT_texture_webp": {"source": 1}}}), &[][..]),
        (json!({"extensions": {"EXT_texture_webp": {"source": 1}}}), &["EXT_texture_webp"][..]),
    ] {
        let root = json!({
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
            "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
            "textures": [texture],
            "images": [{"uri": image_uri([255, 0, 0], false)}, {"uri": image_uri([0, 255, 0], true)}]
        });
        let scene = load_triangle(required, root).expect("loads");
        assert_eq!(scene.textures.len(), 1);
        assert!(scene.textures[0].texels.iter().all(|t| t[..3] == [0, 255, 0]), "{:?}", scene.textures[0].texels);
    }
}

#[test]
fn every_extension_caustic_renders_may_be_required() {
    for name in [
        "KHR_materials_clearcoat",
        "KHR_materials_transmission",
        "KHR_materials_diffuse_transmission",
        "KHR_node_visibility",
        "KHR_materials_volume",
        "KHR_materials_ior",
        "KHR_materials_specular",
        "KHR_materials_sheen",
        "KHR_materials_dispersion",
        "KHR_draco_mesh_compression",
        "EXT_meshopt_compression",
        "KHR_materials_emissive_strength",
        "KHR_materials_unlit",
        "KHR_materials_anisotropy",
        "KHR_materials_pbrSpecularGlossiness",
        "KHR_texture_transform",
        "KHR_lights_punctual",
        "CAUSTIC_lights_area",
        "CAUSTIC_lights_punctual",
        "CAUSTIC_camera",
        "CAUSTIC_world",
        "CAUSTIC_materials_medium",
        "CAUSTIC_materials_subsurface",
        "CAUSTIC_materials_coat",
        "CAUSTIC_materials_anisotropy",
    ] {
        assert!(SUPPORTED_REQUIRED.contains(&name), "{name} is not in SUPPORTED_REQUIRED");
        if let Err(e) = load_requiring(&[name]) {
            panic!("a file requiring {name} was refused: {e}");
        }
    }
    assert!(load_requiring(SUPPORTED_REQUIRED).is_ok(), "all of them at once");
}

#[test]
fn unknown_required_extensions_are_refused_by_name() {
    for unknown in [
        &["KHR_texture_video"][..],
        &["KHR_materials_clearcoat", "EXT_meshopt_compression", "KHR_materials_volume_scatter"],
    ] {
        let msg = load_requiring(unknown).expect_err("refused").to_string();
        for name in unknown.iter().filter(|n| !SUPPORTED_REQUIRED.contains(n)) {
            assert!(msg.contains(name), "{msg}");
        }
        assert!(msg.contains("requires unsupported extension"), "{msg}");
    }
}

#[test]
fn a_primitive_without_material_gets_gltfs_default_in_a_plain_file() {
    let scene = load_triangle(&[], json!({})).unwrap();
    let m = &scene.materials[scene.mesh.tri_material[0] as usize];
    // glTF 2.0, materials: the default is base colour 1, metallic 1, roughness 1.
    assert_eq!((m.base_color, m.metallic, m.roughness), (glam::Vec4::ONE, 1.0, 1.0));
}

#[test]
fn caustic_default_material_names_the_material_for_primitives_without_one() {
    // Blender's default surface (Principled: base 0.8, metallic 0, roughness 0.5, IOR
    // 1.5), written by the add-on as a material of the file.
    let blender = json!({"name": "Blender default",
        "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.5}});
    let root = json!({"materials": [blender], "extensionsUsed": ["CAUSTIC_default_material"],
        "extensions": {"CAUSTIC_default_material": {"material": 0}}});
    let scene = load_triangle(&[], root).unwrap();
    let m = &scene.materials[scene.mesh.tri_material[0] as usize];
    assert_eq!(m.name, "Blender default");
    assert_eq!((m.base_color, m.metallic, m.roughness, m.ior), (glam::Vec4::new(0.8, 0.8, 0.8, 1.0), 0.0, 0.5, 1.5));
    let root = json!({"materials": [{}], "extensions": {"CAUSTIC_default_material": {"material": 0}}});
    assert!(load_triangle(&["CAUSTIC_default_material"], root).is_ok(), "may be required");
    for (bad, want) in [
        (json!({"material": 3}), "material 3 does not exist (the file has 1)"),
        (json!({"material": "grey"}), "CAUSTIC_default_material is malformed"),
        (json!({"materia": 0}), "CAUSTIC_default_material is malformed"),
    ] {
        let root = json!({"materials": [{}], "extensions": {"CAUSTIC_default_material": bad}});
        let msg = load_triangle(&[], root).expect_err("refused").to_string();
        assert!(msg.contains(want), "{msg}");
    }
}

/// A KTX2 image's bytes (the file identifier and nothing more: Caustic must never decode it).
fn ktx2_uri() -> String {
    let magic = [0xABu8, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A];
    format!("data:image/ktx2;base64,{}", base64::engine::general_purpose::STANDARD.encode(magic))
}

#[test]
fn khr_texture_basisu_renders_the_fallback_or_drops_the_texture_by_name() {
    // With a PNG fallback (green) as the core source: that image is the texture, quietly.
    let root = json!({
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
        "materials": [{"name": "leafy", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        "textures": [{"source": 0, "extensions": {"KHR_texture_basisu": {"source": 1}}}],
        "images": [{"uri": image_uri([0, 255, 0], false)}, {"uri": ktx2_uri()}]
    });
    let scene = load_triangle(&[], root).expect("loads");
    assert_eq!(scene.textures.len(), 1);
    assert!(scene.textures[0].texels.iter().all(|t| t[..3] == [0, 255, 0]));
    assert!(scene.materials[0].base_color_tex.is_some());
    assert!(scene.warnings.iter().all(|w| !w.contains("KTX2")), "{:?}", scene.warnings);
    // Without a fallback (the extension required): no texture, a warning naming texture and
    // material, the factor alone.
    let root = json!({
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
        "materials": [{"name": "leafy", "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.6, 0.1, 1],
            "baseColorTexture": {"index": 0}}, "normalTexture": {"index": 0},
            "extensions": {"KHR_materials_sheen": {"sheenColorFactor": [1, 1, 1], "sheenColorTexture": {"index": 0}}}}],
        "textures": [{"name": "bark", "extensions": {"KHR_texture_basisu": {"source": 0}}}],
        "images": [{"uri": ktx2_uri()}]
    });
    let scene = load_triangle(&["KHR_texture_basisu"], root).expect("a file requiring it loads");
    let m = &scene.materials[0];
    assert!(m.base_color_tex.is_none() && m.normal_tex.is_none() && m.sheen_color_tex.is_none());
    assert!(scene.textures.is_empty(), "the KTX2 image is never decoded");
    assert_eq!(m.base_color, glam::Vec4::new(0.2, 0.6, 0.1, 1.0));
    let w: Vec<&String> = scene.warnings.iter().filter(|w| w.contains("KTX2")).collect();
    assert_eq!(w.len(), 1, "one warning for the three uses: {:?}", scene.warnings);
    assert!(w[0].contains("material 'leafy'") && w[0].contains("texture 0 ('bark')"), "{}", w[0]);
}

#[test]
fn khr_materials_variants_renders_the_default_material_quietly() {
    let root = json!({
        "extensionsUsed": ["KHR_materials_variants"],
        "extensions": {"KHR_materials_variants": {"variants": [{"name": "red"}, {"name": "blue"}]}},
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0,
            "extensions": {"KHR_materials_variants": {"mappings": [{"material": 1, "variants": [0]},
                {"material": 2, "variants": [1]}]}}}]}],
        "materials": [{"name": "default"}, {"name": "red"}, {"name": "blue"}]
    });
    for required in [&[][..], &["KHR_materials_variants"][..]] {
        // Blender's exporter lists it as required (glTF-Blender-IO's 18_variants.gltf), which
        // refused the file before.
        let scene = load_triangle(required, root.clone()).expect("loads");
        assert_eq!(scene.materials[scene.mesh.tri_material[0] as usize].name, "default");
        assert!(scene.warnings.iter().all(|w| !w.contains("variants")), "{:?}", scene.warnings);
    }
}

/// glTF leaves a scene's `nodes` and an animation channel's `target.node` optional (an empty
/// scene; a `KHR_animation_pointer` channel); the crate's types require them, and such files
/// were refused ("invalid glTF: missing field"). They load now, the animation still named as
/// not played.
#[test]
fn optional_scene_nodes_and_channel_targets_load() {
    let scene = load_triangle(&[], json!({"scenes": [{"nodes": [0]}, {}]})).expect("an empty scene loads");
    assert_eq!(scene.mesh.triangles.len(), 1);
    let root = json!({
        "animations": [{"name": "Pointer", "samplers": [{"input": 0, "output": 0}],
            "channels": [{"sampler": 0, "target": {"path": "pointer",
                "extensions": {"KHR_animation_pointer": {"pointer": "/nodes/0/translation"}}}}]}]
    });
    let scene = load_triangle(&[], root).expect("a channel without a node loads");
    assert!(scene.warnings.iter().any(|w| w.contains("'Pointer'") && w.contains("not played")), "{:?}", scene.warnings);
}

#[test]
fn khr_node_visibility_hides_a_subtree_but_not_its_camera() {
    // Node 0 (hidden) holds a mesh, a child with a mesh marked visible (hidden by its parent)
    // and a child camera; node 3 is a visible mesh; node 4 a hidden light.
    let root = json!({
        "extensionsUsed": ["KHR_node_visibility", "KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 100.0}]}},
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}],
        "nodes": [
            {"name": "hidden", "mesh": 0, "children": [1, 2], "extensions": {"KHR_node_visibility": {"visible": false}}},
            {"name": "child", "mesh": 0, "translation": [0, 0, 1], "extensions": {"KHR_node_visibility": {"visible": true}}},
            {"name": "cam", "camera": 0, "translation": [0, 0, 5]},
            {"name": "shown", "mesh": 0, "translation": [0, 0, 2]},
            {"name": "lamp", "extensions": {"KHR_lights_punctual": {"light": 0}, "KHR_node_visibility": {"visible": false}}}
        ],
        "scenes": [{"nodes": [0, 3, 4]}]
    });
    let scene = load_triangle(&[], root).expect("loads");
    assert_eq!(scene.mesh.triangles.len(), 1, "only 'shown' is drawn");
    assert!(scene.mesh.positions.iter().all(|p| p.z == 2.0), "{:?}", scene.mesh.positions);
    assert_eq!(scene.cameras.len(), 1, "the hidden node's camera stays usable");
    assert!(scene.lights.is_empty(), "the hidden light lights nothing");
    let note = scene.warnings.iter().find(|w| w.contains("KHR_node_visibility")).expect("a note");
    assert!(note.contains("'hidden'") && note.contains("'child'") && note.contains("'lamp'"), "{note}");
    let bad = json!({"nodes": [{"mesh": 0, "extensions": {"KHR_node_visibility": {"visible": "no"}}}]});
    let msg = load_triangle(&[], bad).expect_err("refused").to_string();
    assert!(msg.contains("visible is not a boolean"), "{msg}");
}

#[test]
fn a_child_listed_as_a_scene_root_renders_once_under_its_parents() {
    // UniGLTF's files (Kenney's assets): the scene lists node 1, a child of a "tmpParent" left
    // out of the scene. Blender's importer renders it; Caustic refused the file. Here the
    // parent moves it by z = 3 (applied), and a grandchild listed beside its ancestor is drawn
    // once, not twice.
    let root = json!({
        "nodes": [
            {"name": "tmpParent", "translation": [0, 0, 3], "children": [1]},
            {"name": "model", "mesh": 0, "children": [2]},
            {"name": "part", "mesh": 0, "translation": [0, 0, 1]}
        ],
        "scenes": [{"nodes": [1, 2]}]
    });
    let scene = load_triangle(&[], root).expect("loads");
    let mut zs: Vec<f32> = scene.mesh.positions.iter().map(|p| p.z).collect();
    zs.sort_by(f32::total_cmp);
    zs.dedup();
    assert_eq!(scene.mesh.triangles.len(), 2, "model and part once each");
    assert_eq!(zs, vec![3.0, 4.0], "under tmpParent's translation");
    assert!(
        scene.warnings.iter().any(|w| w.contains("node 1") && w.contains("child of node 0")),
        "{:?}",
        scene.warnings
    );
    assert!(scene.warnings.iter().any(|w| w.contains("node 2") && w.contains("rendered once")), "{:?}", scene.warnings);
}

#[test]
fn mask_alpha_exactly_at_the_cutoff_is_opaque_everywhere() {
    // glTF: MASK renders opaque where alpha >= alphaCutoff. glTF-Blender-IO's
    // 11_factors_and_textures has base alpha 0.5 against cutoff 0.5; the triangle's (default
    // white) vertex colours summed by barycentrics came to 0.99999994 at some points, which
    // cut 2-3 % of the surface away (Caustic/Cycles R 0.967, G 0.985 -> 1.000, 1.002).
    let root = json!({
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
        "materials": [{"alphaMode": "MASK", "alphaCutoff": 0.5,
            "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 0.5]}}]
    });
    let scene = load_triangle(&[], root).expect("loads");
    let n = 97;
    for i in 0..n {
        for j in 0..n - i {
            let (b1, b2) = (i as f32 / n as f32 + 0.001, j as f32 / n as f32 + 0.0007);
            assert_eq!(scene.coverage(0, b1, b2), 1.0, "cut away at barycentrics ({b1}, {b2})");
        }
    }
}
