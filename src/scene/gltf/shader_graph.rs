//! `CAUSTIC_materials_nodes`: Blender's shader graph on a material, compiled into the
//! material's program (`shader::compile`). The glTF parameters of that material are then
//! not rendered (docs/contract.md); its `CAUSTIC_materials_medium` and
//! `CAUSTIC_materials_subsurface` still apply.

use super::Loader;
use crate::error::Result;
use crate::scene::texture::{associates_alpha, premultiply};
use crate::scene::{AlphaMode, Material};
use crate::shader::compile::compile_in;
use crate::shader::graph::NodesExt;
use std::sync::Arc;

impl Loader<'_> {
    /// Compiles the material's graph, if it has one, into `mat.nodes`.
    pub(super) fn material_nodes(
        &mut self,
        m: &gltf::Material,
        mat: &mut Material,
        features: &mut Vec<String>,
    ) -> Result<()> {
        let Some(v) = m.extension_value("CAUSTIC_materials_nodes") else {
            return Ok(());
        };
        let name = mat.name.clone();
        features.push("CAUSTIC_materials_nodes".into());
        let ext: NodesExt = serde_json::from_value(v.clone())
            .map_err(|e| self.err(format!("material '{name}': CAUSTIC_materials_nodes is malformed: {e}")))?;
        let ext = self.with_ies_profiles(&format!("material '{name}'"), &ext)?;
        let mut images = Vec::with_capacity(ext.images.len());
        for (k, img) in ext.images.iter().enumerate() {
            images.push(self.node_image(&name, k, img)?);
        }
        let compiled = compile_in(&name, &ext, &images, self.space)
            .map_err(|e| self.err(format!("material '{name}': CAUSTIC_materials_nodes: {e}")))?;
        for w in compiled.warnings {
            self.warn(format!("material '{name}': {w}"));
        }
        let keep_medium = features.iter().any(|f| f == "CAUSTIC_materials_medium");
        let mut program = compiled.program;
        // Object Info's Material Index (`pass_ids.rs` checks the extension's shape).
        program.material_index = m
            .extension_value("CAUSTIC_material_pass")
            .and_then(|v| v.get("pass_index")?.as_u64())
            .map_or(0.0, |v| v as f32);
        *mat = graph_material(mat, program, keep_medium);
        Ok(())
    }
}

/// The material a compiled graph makes of `mat`: the graph replaces the glTF description
/// (no glTF textures, emission or alpha); the name, the medium (when `keep_medium`: one of
/// `CAUSTIC_materials_medium`, not glTF's volume), `null_surface`, `transparent_shadow` and
/// subsurface stay. A
/// varying emission gets a placeholder until [`mean_node_emission`] estimates it. The loader
/// and the server's graph edit (`server::graph_edit`) both build node materials here.
pub(crate) fn graph_material(
    mat: &Material,
    prog: crate::shader::instructions::Program,
    keep_medium: bool,
) -> Material {
    let mut out = Material {
        name: mat.name.clone(),
        medium: if keep_medium { mat.medium } else { None },
        null_surface: mat.null_surface,
        transparent_shadow: mat.transparent_shadow,
        // The graph's own closures say what walk they need (a Principled BSDF behind a Mix
        // Shader, a Subsurface Scattering node), which `CAUSTIC_materials_subsurface` (written
        // for a Principled BSDF on the output alone) does not; the graph's wins, so a graph
        // edited in the viewport keeps its walk current.
        subsurface: prog.subsurface.map(graph_subsurface).or(mat.subsurface),
        ..Material::default()
    };
    out.metallic = 0.0;
    out.alpha_mode = if prog.transparent { AlphaMode::Blend } else { AlphaMode::Opaque };
    out.emissive = if prog.emits {
        match prog.constant_emission {
            // A selection weight: |emission|, as Cycles' `estimate_emission` (a negative
            // emitter subtracts light and is sampled like any other).
            Some(e) => e.abs(),
            // Estimated per material once the mesh is known (`mean_node_emission`).
            None => glam::Vec3::splat(1.0),
        }
    } else {
        glam::Vec3::ZERO
    };
    out.nodes = Some(Arc::new(prog));
    out
}

/// The material's walk from the one its graph asks for (zero radii too: those channels
/// reflect diffusely, the walk's rule).
fn graph_subsurface(g: crate::shader::instructions::GraphSubsurface) -> crate::scene::material::Subsurface {
    crate::scene::material::Subsurface {
        weight: 1.0,
        radius: glam::Vec3::from(g.radius),
        anisotropy: g.anisotropy.clamp(0.0, 0.9),
        ior: g.ior.clamp(1.01, 3.8),
        method: if g.skin {
            crate::scene::material::SubsurfaceMethod::RandomWalkSkin
        } else {
            crate::scene::material::SubsurfaceMethod::RandomWalk
        },
        enter_at_ior: g.enter_at_ior,
    }
}

impl Loader<'_> {
    /// Decodes image `k` of a material's graph into a scene texture; returns its index.
    pub(super) fn node_image(
        &mut self,
        material: &str,
        k: usize,
        img: &crate::shader::graph::ImageDesc,
    ) -> Result<u32> {
        let what = format!("material '{material}': CAUSTIC_materials_nodes image {k} '{}'", img.uri);
        let working = self.space_name.clone();
        let working = working.as_deref();
        let srgb = if working == Some(img.colorspace.as_str()) {
            false
        } else {
            colorspace_is_srgb(&img.colorspace).unwrap_or_else(|| {
                self.warn(format!("{what}: colour space '{}' is read as linear (not converted)", img.colorspace));
                false
            })
        };
        let to_working = if colorspace_converts(&img.colorspace, working) { self.space.matrix() } else { None };
        let bytes = self.resolve_uri(&img.uri, &what)?;
        let reader = image::ImageReader::new(std::io::Cursor::new(&bytes))
            .with_guessed_format()
            .map_err(|e| self.err(format!("{what}: {e}")))?;
        let (w, h) = reader.into_dimensions().map_err(|e| self.err(format!("{what}: cannot read the header: {e}")))?;
        if w == 0 || h == 0 || w > super::MAX_TEXTURE_SIDE || h > super::MAX_TEXTURE_SIDE {
            return Err(self.err(format!("{what}: size {w}×{h} is outside 1..={} per side", super::MAX_TEXTURE_SIDE)));
        }
        let texels = w as u64 * h as u64;
        self.budget.check_peak(format!("decoding {what}"), texels * 32)?;
        let start = std::time::Instant::now();
        let decoded = image::ImageReader::new(std::io::Cursor::new(&bytes))
            .with_guessed_format()
            .map_err(|e| self.err(format!("{what}: {e}")))?
            .decode()
            .map_err(|e| self.err(format!("{what}: cannot decode: {e}")))?;
        // 8-bit images stay 8-bit (4 B a texel); anything finer (EXR, HDR, 16-bit PNG) is
        // kept as f32 (16 B), as Cycles keeps a float image; an sRGB one stays encoded, to be
        // decoded after filtering (`Texture::decode`), as Cycles' `compress_as_srgb`.
        let float = !matches!(
            decoded.color(),
            image::ColorType::L8 | image::ColorType::La8 | image::ColorType::Rgb8 | image::ColorType::Rgba8
        );
        self.budget.charge(format!("{what} ({w}×{h})"), texels * if float { 16 } else { 4 })?;
        let associated = associates_alpha(img.colorspace == "Non-Color", img.alpha.as_deref(), float);
        let (texels, hdr) = if float {
            let hdr = decoded
                .to_rgba32f()
                .pixels()
                .map(|p| {
                    let [r, g, b, a] = p.0;
                    // A NaN or infinite texel (a broken EXR) would poison every sum it enters.
                    let clean = |v: f32| if v.is_finite() { v } else { 0.0 };
                    glam::Vec4::new(clean(r), clean(g), clean(b), clean(a))
                })
                .collect();
            (Vec::new(), hdr)
        } else {
            let mut texels: Vec<[u8; 4]> = decoded.to_rgba8().pixels().map(|p| p.0).collect();
            // Blender holds 8-bit images straight whatever their alpha mode, and Cycles
            // associates them on load (`load_byte_pixels`).
            if associated {
                premultiply(&mut texels);
            }
            (texels, Vec::new())
        };
        // Simplify's Texture Limit shrinks what Cycles holds: associated bytes or floats.
        let (mut w, mut h, mut texels, mut hdr) = (w, h, texels, hdr);
        if let Some(limit) = self.texture_limit {
            use crate::scene::texture_limit::{shrink_f32, shrink_u8};
            // An image is held in one of the two: bytes, or floats (`texels` then empty).
            if hdr.is_empty() {
                if let Some((sw, sh, small)) = shrink_u8(&texels, w, h, limit) {
                    (w, h, texels) = (sw, sh, small);
                }
            } else if let Some((sw, sh, small)) = shrink_f32(&hdr, w, h, limit) {
                (w, h, hdr) = (sw, sh, small);
            }
        }
        self.profile.decode_textures += start.elapsed().as_secs_f64();
        let tex = crate::scene::Texture {
            name: img.uri.clone(),
            width: w,
            height: h,
            texels,
            srgb,
            hdr,
            wrap_s: crate::scene::texture::Wrap::Repeat,
            wrap_t: crate::scene::texture::Wrap::Repeat,
            nearest: false,
            to_working,
            associated,
            mean: glam::Vec3::ZERO,
        }
        .with_mean();
        self.textures.push(tex);
        Ok(self.textures.len() as u32 - 1)
    }
}

/// Whether a graph image in colour space `name` is decoded from sRGB (Some(false): read as
/// linear data; None: a space the contract does not name, read as linear with a warning).
pub(crate) fn colorspace_is_srgb(name: &str) -> Option<bool> {
    match name {
        "sRGB" => Some(true),
        "Non-Color" | "Linear Rec.709" | "Linear" => Some(false),
        _ => None,
    }
}

/// Whether a graph image in colour space `name` is colour in linear Rec.709 once decoded, to be
/// taken into a `working` space other than Rec.709 (Cycles converts every image to scene
/// linear but Non-Color ones and those already in it); unknown spaces were warned of.
pub(crate) fn colorspace_converts(name: &str, working: Option<&str>) -> bool {
    working.is_some_and(|w| w != name) && matches!(name, "sRGB" | "Linear Rec.709" | "Linear")
}

/// Triangles sampled per material for the estimate of a varying emission.
const EMISSION_SAMPLES: usize = 4096;

impl Loader<'_> {
    /// Node materials whose emission varies over the surface get an estimate of their
    /// mean |radiance| in `emissive` (the light list's powers and photon emission use it;
    /// the radiance itself is always evaluated exactly, `Scene::emission_at`): the mean of
    /// the graph's emission at the centroids of up to 4096 of the material's triangles
    /// (evenly strided). A material whose samples are all black keeps a tiny positive
    /// estimate, so that its triangles stay sampleable lights wherever they do emit.
    pub(super) fn node_emitters(
        &mut self,
        mesh: &crate::scene::Mesh,
        objects: &[crate::shader::geom::ObjectData],
        materials: &mut [Material],
    ) {
        for (mi, mat) in materials.iter_mut().enumerate() {
            let Some((mean, n)) = mean_node_emission(mesh, objects, &self.textures, mat, mi as u32) else { continue };
            mat.emissive = mean;
            let name = mat.name.clone();
            self.warn(format!(
                "material '{name}': its emission varies over the surface; lights are weighted by its mean over {n} triangle centres"
            ));
        }
    }
}

/// The estimate [`Loader::node_emitters`] gives node material `mat` (material index `mi`) of
/// its mean radiance, with the number of triangle centres it averaged; None when the graph
/// does not emit, emits a constant, or no triangle uses the material.
pub(crate) fn mean_node_emission(
    mesh: &crate::scene::Mesh,
    objects: &[crate::shader::geom::ObjectData],
    textures: &[crate::scene::Texture],
    mat: &Material,
    mi: u32,
) -> Option<(glam::Vec3, usize)> {
    let prog = mat.nodes.as_ref()?;
    if !prog.emits || prog.constant_emission.is_some() {
        return None;
    }
    let tris: Vec<u32> = (0..mesh.triangles.len() as u32).filter(|&t| mesh.tri_material[t as usize] == mi).collect();
    if tris.is_empty() {
        return None;
    }
    let stride = tris.len().div_ceil(EMISSION_SAMPLES);
    let mut sum = glam::Vec3::ZERO;
    let mut n = 0;
    for &t in tris.iter().step_by(stride) {
        // Both faces emit, and a graph may emit differently from each (by Backfacing, say):
        // the mean of the two, seen along either normal.
        let [a, b, c] = mesh.triangles[t as usize].map(|i| mesh.positions[i as usize]);
        let ng = (b - a).cross(c - a).normalize_or_zero();
        let mut both = glam::Vec3::ZERO;
        for wo in [ng, -ng] {
            both += crate::shader::shade::node_emission(
                mesh,
                objects,
                textures,
                &crate::shader::geom::NO_VIEW,
                prog,
                t,
                1.0 / 3.0,
                1.0 / 3.0,
                crate::scene::light_path::LightPath::LIGHT_EMISSION,
                (ng != glam::Vec3::ZERO).then_some(wo),
            )
            // A selection weight: negative emission (which subtracts light) counts by its
            // size, as Cycles' light tree takes |emission|; every path carries the sign itself.
            .abs();
        }
        sum += 0.5 * both;
        n += 1;
    }
    Some(((sum / n as f32).max(glam::Vec3::splat(1e-6)), n))
}

/// What a shader graph reads of an instance: its inverse world matrix and location, a
/// per-object random number (from the node's `CAUSTIC_random_id` extras, an instance's
/// number in Blender's depsgraph, else the hash of its name), the mesh's texture space
/// (`CAUSTIC_texspace` extras) and the object's colour (the node's `CAUSTIC_object_color`
/// extras; white without them, as Blender's default, or when they are not 4 finite numbers)
/// and its Pass Index (`CAUSTIC_object_pass`'s `pass_index`, checked by `pass_ids.rs`; 0
/// without it).
pub(super) fn object_data(
    world: &glam::Mat4,
    node_name: &str,
    texspace: Option<&serde_json::Value>,
    color: Option<&serde_json::Value>,
    random_id: Option<&serde_json::Value>,
    pass_index: Option<&serde_json::Value>,
) -> crate::shader::geom::ObjectData {
    let vec3 = |v: Option<&serde_json::Value>| -> Option<glam::Vec3> {
        let a = v?.as_array()?;
        if a.len() != 3 {
            return None;
        }
        Some(glam::Vec3::new(a[0].as_f64()? as f32, a[1].as_f64()? as f32, a[2].as_f64()? as f32))
    };
    let texspace = texspace.and_then(|t| Some((vec3(t.get("location"))?, vec3(t.get("size"))?)));
    crate::shader::geom::ObjectData {
        world_to_object: world.inverse(),
        location: world.w_axis.truncate(),
        random: match random_id.and_then(|v| v.as_u64()).and_then(|v| u32::try_from(v).ok()) {
            Some(id) => random_from_id(id),
            None => object_random(node_name),
        },
        texspace,
        color: color
            .and_then(|c| c.as_array())
            .filter(|a| a.len() == 4)
            .and_then(|a| {
                let v: Option<Vec<f32>> = a.iter().map(|x| x.as_f64().map(|x| x as f32)).collect();
                v.filter(|v| v.iter().all(|x| x.is_finite())).map(|v| glam::Vec4::new(v[0], v[1], v[2], v[3]))
            })
            .unwrap_or(glam::Vec4::ONE),
        pass_index: pass_index.and_then(|v| v.as_u64()).map_or(0.0, |v| v as f32),
    }
}

/// Object Info's Random as Cycles computes it for an object that is not an instance
/// (`blender/object.cpp`: `hash_uint2(hash_string(name), 0)`, then `scene/object.cpp`:
/// the id times 1 / 0xFFFFFFFF in f32, which is 2⁻³²): `hash_string` is i ← 37 i + byte over
/// the name's UTF-8 bytes, read unsigned (as Blender 5.0's Linux build does: "Würfel.001"
/// renders 0.053860776 in Cycles). The glTF node's name is the Blender object's name.
fn object_random(name: &str) -> f32 {
    let h = name.bytes().fold(0u32, |i, c| i.wrapping_mul(37).wrapping_add(c as u32));
    random_from_id(crate::shader::texture::hash::hash_uint2(h, 0))
}

/// Cycles' Random from an object's random id: the id times 2⁻³² in f32.
fn random_from_id(id: u32) -> f32 {
    id as f32 * (1.0 / 4_294_967_296.0)
}

#[cfg(test)]
mod object_random_tests {
    use super::object_random;

    /// Values Cycles rendered (Blender 5.0.1, an Emission of strength Object Info Random,
    /// one sample, no denoising): bit for bit, a non-ASCII name included.
    #[test]
    fn object_random_is_cycles_number() {
        assert_eq!(object_random("Plane"), 0.135_764_3);
        assert_eq!(object_random("Object Info"), 0.583_441_8);
        assert_eq!(object_random("Würfel.001"), 0.053_860_776);
    }

    /// An instance's Random from its depsgraph id in the node's extras (2³¹ gives ½); an id
    /// that is not a u32 falls back to the name's hash.
    #[test]
    fn instance_random_from_extras() {
        let world = glam::Mat4::IDENTITY;
        let id = serde_json::json!(2_147_483_648u64);
        assert_eq!(super::object_data(&world, "A", None, None, Some(&id), None).random, 0.5);
        let bad = serde_json::json!(-1);
        assert_eq!(super::object_data(&world, "A", None, None, Some(&bad), None).random, object_random("A"));
    }

    /// Object Info Color/Alpha from the node's extras; white without them or when malformed.
    #[test]
    fn object_color_from_extras() {
        let world = glam::Mat4::IDENTITY;
        let c = serde_json::json!([0.2, 0.4, 0.6, 0.5]);
        assert_eq!(
            super::object_data(&world, "A", None, Some(&c), None, None).color,
            glam::Vec4::new(0.2, 0.4, 0.6, 0.5)
        );
        assert_eq!(super::object_data(&world, "A", None, None, None, None).color, glam::Vec4::ONE);
        let bad = serde_json::json!([0.2, "x", 0.6, 1]);
        assert_eq!(super::object_data(&world, "A", None, Some(&bad), None, None).color, glam::Vec4::ONE);
    }
}
