//! Images and textures: each image decoded once (charged to the memory budget from its
//! header first), each (image, colour space, sampler) turned into one [`Texture`], and
//! texture references with `KHR_texture_transform`.

use super::{DecodedImage, Loader, MAX_TEXTURE_SIDE, push_unique};
use crate::error::Result;
use crate::scene::TexRef;
use crate::scene::texture::{Texture, Wrap, texture_transform};
use glam::Mat3;

/// `EXT_texture_webp`: a texture whose extension names a WebP image reads that image (the
/// core `source`, when there is one, is the fallback for viewers without WebP). Done on the
/// raw JSON, before references are checked, so that the WebP source is checked like any.
pub(super) fn prefer_webp_sources(root: &mut serde_json::Value) {
    let Some(textures) = root.get_mut("textures").and_then(|t| t.as_array_mut()) else {
        return;
    };
    for t in textures {
        let webp = t.pointer("/extensions/EXT_texture_webp/source").cloned();
        if let (Some(source), Some(obj)) = (webp, t.as_object_mut()) {
            obj.insert("source".into(), source);
        }
    }
}

/// `KHR_texture_basisu`: a texture whose core `source` is a PNG or JPEG has it as the fallback
/// for viewers without Basis Universal, and Caustic reads it (the extension's KTX2 image is
/// never decoded). A texture with the extension's source alone gets that source as its core
/// one, so that the document parses and its references are checked, and is returned here:
/// Caustic cannot decode KTX2, so the materials drop such a texture with a warning naming it
/// (`Loader::undecodable`). Done on the raw JSON, as [`prefer_webp_sources`].
pub(super) fn basisu_only_textures(root: &mut serde_json::Value) -> std::collections::HashSet<usize> {
    let mut out = std::collections::HashSet::new();
    let Some(textures) = root.get_mut("textures").and_then(|t| t.as_array_mut()) else {
        return out;
    };
    for (i, t) in textures.iter_mut().enumerate() {
        let ktx2 = t.pointer("/extensions/KHR_texture_basisu/source").cloned();
        if let (Some(source), Some(obj)) = (ktx2, t.as_object_mut())
            && !obj.contains_key("source")
        {
            obj.insert("source".into(), source);
            out.insert(i);
        }
    }
    out
}

impl Loader<'_> {
    /// True (with a warning naming the texture and `material`) when `texture` is a KTX2 image
    /// without a fallback (`basisu_only_textures`): the material then renders without it.
    pub(super) fn undecodable(&mut self, texture: &gltf::Texture, material: &str) -> bool {
        if !self.basisu_only.contains(&texture.index()) {
            return false;
        }
        let name = texture.name().or_else(|| texture.source().name()).map(|n| format!(" ('{n}')")).unwrap_or_default();
        self.warn(format!(
            "material '{material}': texture {}{name} is a KTX2 image (KHR_texture_basisu) without a PNG or JPEG \
             fallback, which Caustic cannot decode: the material renders without that texture (its factor alone)",
            texture.index()
        ));
        true
    }

    pub(super) fn image(&mut self, doc: &gltf::Document, index: usize, buffers: &[Vec<u8>]) -> Result<DecodedImage> {
        if let Some(img) = self.images.get(&index) {
            return Ok(img.clone());
        }
        let image = doc.images().nth(index).expect("validated index");
        let name = image.name().map(|n| format!("image {index} ('{n}')")).unwrap_or_else(|| format!("image {index}"));
        let (bytes, label) = match image.source() {
            gltf::image::Source::View { view, .. } => {
                let b = &buffers[view.buffer().index()];
                (b[view.offset()..view.offset() + view.length()].to_vec(), name.clone())
            }
            gltf::image::Source::Uri { uri, .. } => {
                let label = if uri.starts_with("data:") { name.clone() } else { format!("{name} '{uri}'") };
                (self.resolve_uri(uri, &format!("texture {label}"))?, label)
            }
        };
        let reader = image::ImageReader::new(std::io::Cursor::new(&bytes))
            .with_guessed_format()
            .map_err(|e| self.err(format!("texture {label}: {e}")))?;
        if reader.format().is_none() {
            return Err(self.err(format!("texture {label}: unknown image format (Caustic reads PNG, JPEG and WebP)")));
        }
        let (w, h) = reader
            .into_dimensions()
            .map_err(|e| self.err(format!("texture {label}: cannot read the image header: {e}")))?;
        if w == 0 || h == 0 || w > MAX_TEXTURE_SIDE || h > MAX_TEXTURE_SIDE {
            return Err(
                self.err(format!("texture {label}: image size {w}×{h} is outside 1..={MAX_TEXTURE_SIDE} per side"))
            );
        }
        // Kept: RGBA8 texels; transient: the decoded image (at most 16-bit RGBA) and
        // its 8-bit conversion.
        let texels = w as u64 * h as u64;
        self.budget.charge(format!("texture {label} ({w}×{h})"), texels * 4)?;
        self.budget.check_peak(format!("decoding texture {label}"), texels * 12)?;
        let decode_start = std::time::Instant::now();
        let decoded = image::ImageReader::new(std::io::Cursor::new(&bytes))
            .with_guessed_format()
            .map_err(|e| self.err(format!("texture {label}: {e}")))?
            .decode()
            .map_err(|e| self.err(format!("texture {label}: cannot decode: {e}")))?
            .to_rgba8();
        let mut texels: Vec<[u8; 4]> = decoded.pixels().map(|p| p.0).collect();
        let (mut w, mut h) = (w, h);
        if let Some((sw, sh, small)) =
            self.texture_limit.and_then(|l| crate::scene::texture_limit::shrink_u8(&texels, w, h, l))
        {
            (w, h, texels) = (sw, sh, small);
        }
        self.profile.decode_textures += decode_start.elapsed().as_secs_f64();
        let entry = (w, h, std::sync::Arc::new(texels));
        self.images.insert(index, entry.clone());
        Ok(entry)
    }

    pub(super) fn texture(
        &mut self,
        doc: &gltf::Document,
        texture: gltf::Texture,
        tex_coord: u32,
        transform: Mat3,
        srgb: bool,
        buffers: &[Vec<u8>],
    ) -> Result<TexRef> {
        let image_index = texture.source().index();
        let sampler = texture.sampler();
        let key = (image_index, srgb, sampler.index());
        let index = if let Some(&i) = self.texture_cache.get(&key) {
            i
        } else {
            let (w, h, texels) = self.image(doc, image_index, buffers)?;
            let wrap = |m: gltf::texture::WrappingMode| match m {
                gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
                gltf::texture::WrappingMode::MirroredRepeat => Wrap::Mirror,
                gltf::texture::WrappingMode::ClampToEdge => Wrap::Clamp,
            };
            let nearest = matches!(sampler.mag_filter(), Some(gltf::texture::MagFilter::Nearest));
            self.textures.push(
                Texture {
                    name: texture.source().name().unwrap_or("").to_string(),
                    width: w,
                    height: h,
                    texels: (*texels).clone(),
                    hdr: Vec::new(),
                    srgb,
                    wrap_s: wrap(sampler.wrap_s()),
                    wrap_t: wrap(sampler.wrap_t()),
                    nearest,
                    // glTF's sRGB textures are its colour ones (base, emissive, specular and
                    // sheen colour); data textures stay as they are.
                    to_working: if srgb { self.space.matrix() } else { None },
                    associated: false,
                    mean: glam::Vec3::ZERO,
                }
                .with_mean(),
            );
            let i = (self.textures.len() - 1) as u32;
            self.texture_cache.insert(key, i);
            i
        };
        if tex_coord > 1 {
            self.warn(format!("a texture uses TEXCOORD_{tex_coord}; Caustic reads TEXCOORD_0 and _1 only (using 0)"));
        }
        Ok(TexRef { texture: index, tex_coord: tex_coord.min(1), transform })
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) fn info_texture(
        &mut self,
        doc: &gltf::Document,
        info: Option<gltf::texture::Info>,
        srgb: bool,
        buffers: &[Vec<u8>],
        features: &mut Vec<String>,
        label: &str,
        material: &str,
    ) -> Result<Option<TexRef>> {
        let Some(info) = info else { return Ok(None) };
        if self.undecodable(&info.texture(), material) {
            return Ok(None);
        }
        let mut tex_coord = info.tex_coord();
        let mut transform = Mat3::IDENTITY;
        if let Some(t) = info.texture_transform() {
            transform = texture_transform(t.offset(), t.rotation(), t.scale());
            if let Some(tc) = t.tex_coord() {
                tex_coord = tc;
            }
            push_unique(features, "KHR_texture_transform");
        }
        push_unique(features, label);
        self.texture(doc, info.texture(), tex_coord, transform, srgb, buffers).map(Some)
    }

    /// A textureInfo given as raw extension JSON (`{"index": i, "texCoord": n, "extensions": ...}`).
    pub(super) fn raw_texture(
        &mut self,
        doc: &gltf::Document,
        info: &serde_json::Value,
        srgb: bool,
        buffers: &[Vec<u8>],
        material: &str,
    ) -> Result<Option<TexRef>> {
        let index = info
            .get("index")
            .and_then(|v| v.as_u64())
            .ok_or_else(|| self.err(format!("material '{material}': a texture reference has no index")))?;
        let texture = doc
            .textures()
            .nth(index as usize)
            .ok_or_else(|| self.err(format!("material '{material}': texture {index} does not exist")))?;
        let mut tex_coord = info.get("texCoord").and_then(|v| v.as_u64()).unwrap_or(0) as u32;
        let mut transform = Mat3::IDENTITY;
        if let Some(t) = info.pointer("/extensions/KHR_texture_transform") {
            let f = |k: &str, d: f32, i: usize| {
                t.get(k).and_then(|v| v.get(i).or(Some(v))).and_then(|v| v.as_f64()).map(|v| v as f32).unwrap_or(d)
            };
            transform = texture_transform(
                [f("offset", 0.0, 0), f("offset", 0.0, 1)],
                f("rotation", 0.0, 0),
                [f("scale", 1.0, 0), f("scale", 1.0, 1)],
            );
            if let Some(tc) = t.get("texCoord").and_then(|v| v.as_u64()) {
                tex_coord = tc as u32;
            }
        }
        if self.undecodable(&texture, material) {
            return Ok(None);
        }
        self.texture(doc, texture, tex_coord, transform, srgb, buffers).map(Some)
    }
}
