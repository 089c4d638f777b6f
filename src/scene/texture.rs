//! Decoded textures and their lookup: wrap modes, bilinear or nearest filtering,
//! sRGB decoding, `KHR_texture_transform`.
//!
//! An sRGB image, 8-bit or float (a 16-bit PNG, an OpenEXR tagged sRGB), is filtered as stored
//! and decoded after, as Cycles does (it keeps every sRGB image encoded, `compress_as_srgb`,
//! and converts the interpolated value in `svm_image_texture`): between a dark and a light
//! texel the blend is darker than a blend of decoded texels.
//!
//! A colour image in a scene whose working space is not Rec.709 (`to_working`) is decoded and
//! converted texel by texel before filtering, as Cycles converts such an image to float scene
//! linear on load (its sRGB is no longer the built-in space it keeps encoded).

use glam::{Mat3, Vec2, Vec3, Vec4};

/// glTF sampler wrap mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    /// REPEAT.
    Repeat,
    /// MIRRORED_REPEAT.
    Mirror,
    /// CLAMP_TO_EDGE.
    Clamp,
}

/// An RGBA image with its sampler state: 8 bits per channel for glTF's textures, which
/// keeps large scenes in memory (a 4k texture is 64 MiB; 16-bit PNGs are reduced to 8 bits
/// on load), or linear f32 (`hdr`) for a shader graph's float images (EXR, 16-bit), whose
/// values may pass 1 or need finer steps than 1/255.
#[derive(Clone, Debug)]
pub struct Texture {
    /// Name for messages.
    pub name: String,
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Row-major RGBA texels, top row first (glTF's UV origin is the top-left); empty when
    /// the image is held in `hdr`.
    pub texels: Vec<[u8; 4]>,
    /// Row-major linear RGBA texels as floats, top row first, already decoded from sRGB
    /// where the image was; empty for an 8-bit image.
    pub hdr: Vec<Vec4>,
    /// RGB are sRGB-encoded (base colour, emissive); alpha is always linear.
    pub srgb: bool,
    /// Horizontal wrap.
    pub wrap_s: Wrap,
    /// Vertical wrap.
    pub wrap_t: Wrap,
    /// Nearest-texel lookup (glTF magFilter NEAREST) instead of bilinear.
    pub nearest: bool,
    /// Linear Rec.709 → the scene's working space, for a colour image in a scene whose
    /// working space is not Rec.709 (`scene::working_space`); `None` for data images.
    pub to_working: Option<Mat3>,
    /// RGB are associated with alpha (multiplied by it), as Cycles holds a graph's colour
    /// image (`ImageOp::alpha_read` divides them back): 8-bit texels, which Blender holds
    /// straight, premultiplied on load ([`premultiply`]); float ones as Blender holds them
    /// (associated already).
    pub associated: bool,
    /// Mean linear RGB over the image, computed once by [`Texture::with_mean`] (emitters
    /// ask for it per triangle and per photon).
    pub mean: Vec3,
}

/// Whether a shader graph's image is held with associated alpha, as Cycles holds it: a colour
/// image (not data) whose Blender alpha mode is Straight or Premultiplied (Channel Packed and
/// None keep their RGB as stored; `ImageManager` associates only colour images,
/// `ImageTextureNode::compile` unassociates the same ones). Not a `float` image in Straight
/// mode (a 16-bit PNG): Cycles associates it after converting it to linear, which its
/// sRGB-encoded file cannot reproduce, so it stays straight (measured closer to Cycles).
pub fn associates_alpha(data: bool, alpha_mode: Option<&str>, float: bool) -> bool {
    !data
        && match alpha_mode {
            Some("STRAIGHT") => !float,
            Some("PREMUL") => true,
            _ => false,
        }
}

/// Cycles' association of an 8-bit image (straight in Blender) on load (`load_byte_pixels`): each stored
/// (still sRGB-encoded) byte times alpha / 255, truncated.
pub fn premultiply(texels: &mut [[u8; 4]]) {
    for t in texels {
        let a = t[3] as u32;
        for c in &mut t[..3] {
            *c = (*c as u32 * a / 255) as u8;
        }
    }
}

/// sRGB → linear table for 8-bit values.
fn srgb_table() -> &'static [f32; 256] {
    static TABLE: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = [0.0; 256];
        for (i, v) in t.iter_mut().enumerate() {
            let c = i as f32 / 255.0;
            *v = if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) };
        }
        t
    })
}

/// sRGB → linear for one encoded value (the table's formula, for filtered values): as
/// Cycles' `color_srgb_to_linear`, negative values (a float image's) give 0 and values past 1
/// continue the power curve.
#[inline]
fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 { c.max(0.0) / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// Texel index `i` of a row or column of `n` texels under wrap `mode`.
#[inline]
pub fn wrap(i: i64, n: u32, mode: Wrap) -> u32 {
    let n = n as i64;
    let j = match mode {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::Clamp => i.clamp(0, n - 1),
        Wrap::Mirror => {
            let period = 2 * n;
            let k = i.rem_euclid(period);
            if k < n { k } else { period - 1 - k }
        }
    };
    j as u32
}

impl Texture {
    /// Linear RGBA of texel (x, y), wrapped by the sampler's modes.
    #[inline]
    pub fn texel(&self, x: i64, y: i64) -> Vec4 {
        let x = wrap(x, self.width, self.wrap_s);
        let y = wrap(y, self.height, self.wrap_t);
        let i = (y * self.width + x) as usize;
        let linear = if !self.hdr.is_empty() {
            self.decode_srgb(self.hdr[i])
        } else {
            let t = self.texels[i];
            if self.srgb {
                let table = srgb_table();
                Vec4::new(table[t[0] as usize], table[t[1] as usize], table[t[2] as usize], t[3] as f32 / 255.0)
            } else {
                Vec4::new(t[0] as f32, t[1] as f32, t[2] as f32, t[3] as f32) / 255.0
            }
        };
        match self.to_working {
            Some(m) => (m * linear.truncate()).extend(linear.w),
            None => linear,
        }
    }

    /// RGBA of texel (x, y) as filtered, wrapped by the sampler's modes: an sRGB image's RGB
    /// still encoded (filter these, then [`decode`](Self::decode)); with `to_working` the
    /// texel in the working space already.
    #[inline]
    pub fn stored_texel(&self, x: i64, y: i64) -> Vec4 {
        if self.to_working.is_some() {
            return self.texel(x, y);
        }
        let x = wrap(x, self.width, self.wrap_s);
        let y = wrap(y, self.height, self.wrap_t);
        let i = (y * self.width + x) as usize;
        if !self.hdr.is_empty() {
            return self.hdr[i];
        }
        let t = self.texels[i];
        Vec4::new(t[0] as f32, t[1] as f32, t[2] as f32, t[3] as f32) / 255.0
    }

    /// Linear RGBA of a value filtered from [`stored_texel`](Self::stored_texel)s.
    #[inline]
    pub fn decode(&self, v: Vec4) -> Vec4 {
        if self.to_working.is_some() { v } else { self.decode_srgb(v) }
    }

    /// sRGB → linear of an encoded value; others as they are.
    #[inline]
    fn decode_srgb(&self, v: Vec4) -> Vec4 {
        if self.srgb { Vec4::new(srgb_to_linear(v.x), srgb_to_linear(v.y), srgb_to_linear(v.z), v.w) } else { v }
    }

    /// Filtered linear RGBA at texture coordinate `uv`.
    #[inline]
    pub fn lookup(&self, uv: Vec2) -> Vec4 {
        if !uv.is_finite() {
            return self.texel(0, 0);
        }
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        if self.nearest {
            return self.texel(x.round() as i64, y.round() as i64);
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let a = self.stored_texel(x0, y0).lerp(self.stored_texel(x0 + 1, y0), fx);
        let b = self.stored_texel(x0, y0 + 1).lerp(self.stored_texel(x0 + 1, y0 + 1), fx);
        self.decode(a.lerp(b, fy))
    }

    /// Mean linear RGB over the image (for light power estimates).
    #[inline]
    pub fn mean_rgb(&self) -> Vec3 {
        self.mean
    }

    /// Sets [`Texture::mean`] from the texels: one pass, summed in f64 (so that a constant
    /// image's mean is its texel value exactly).
    pub fn with_mean(mut self) -> Self {
        let mut sum = glam::DVec3::ZERO;
        for y in 0..self.height as i64 {
            for x in 0..self.width as i64 {
                sum += self.texel(x, y).truncate().as_dvec3();
            }
        }
        self.mean = (sum / (self.width as f64 * self.height as f64).max(1.0)).as_vec3();
        self
    }
}

/// A material's reference to a texture.
#[derive(Clone, Copy, Debug)]
pub struct TexRef {
    /// Index into `Scene::textures`.
    pub texture: u32,
    /// Which UV set (0 or 1).
    pub tex_coord: u32,
    /// `KHR_texture_transform` as a 2D affine matrix (identity when absent).
    pub transform: Mat3,
}

impl TexRef {
    /// Applies the texture transform.
    #[inline]
    pub fn uv(&self, uv: Vec2) -> Vec2 {
        self.transform.transform_point2(uv)
    }
}

/// Builds the `KHR_texture_transform` matrix: T * R * S, as the extension specifies.
pub fn texture_transform(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> Mat3 {
    let t = Mat3::from_cols(Vec3::X, Vec3::Y, Vec3::new(offset[0], offset[1], 1.0));
    let (s, c) = rotation.sin_cos();
    let r = Mat3::from_cols(Vec3::new(c, -s, 0.0), Vec3::new(s, c, 0.0), Vec3::Z);
    let sc = Mat3::from_diagonal(Vec3::new(scale[0], scale[1], 1.0));
    t * r * sc
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tex(wrap_mode: Wrap) -> Texture {
        Texture {
            name: "t".into(),
            width: 2,
            height: 1,
            texels: vec![[0, 0, 0, 255], [255, 255, 255, 255]],
            hdr: Vec::new(),
            srgb: false,
            wrap_s: wrap_mode,
            wrap_t: Wrap::Clamp,
            nearest: true,
            to_working: None,
            associated: false,
            mean: Vec3::ZERO,
        }
        .with_mean()
    }

    #[test]
    fn working_space_images_are_decoded_converted_then_filtered() {
        // Under a working space other than Rec.709 Cycles converts an sRGB image to float scene
        // linear on load: the blend of black and white decodes to 0.5, then the matrix applies.
        let m = Mat3::from_cols(Vec3::new(0.6, 0.07, 0.02), Vec3::new(0.34, 0.92, 0.11), Vec3::new(0.05, 0.01, 0.87));
        let t = Texture { srgb: true, nearest: false, to_working: Some(m), ..tex(Wrap::Clamp) };
        let mid = t.lookup(Vec2::new(0.5, 0.5));
        assert!((mid.truncate() - m * Vec3::splat(0.5)).abs().max_element() < 1e-6, "{mid}");
        assert_eq!(t.texel(1, 0).truncate(), m * Vec3::ONE);
        assert_eq!(t.texel(1, 0).w, 1.0);
    }

    #[test]
    fn premultiply_truncates_as_cycles_byte_loader() {
        let mut t = vec![[255, 128, 1, 128], [200, 100, 50, 255], [9, 9, 9, 0]];
        premultiply(&mut t);
        // 255·128/255 = 128, 128·128/255 = 64.25 → 64, 1·128/255 → 0; opaque and clear texels.
        assert_eq!(t, vec![[128, 64, 0, 128], [200, 100, 50, 255], [0, 0, 0, 0]]);
        assert!(associates_alpha(false, Some("STRAIGHT"), false) && associates_alpha(false, Some("PREMUL"), false));
        assert!(associates_alpha(false, Some("PREMUL"), true) && !associates_alpha(false, Some("STRAIGHT"), true));
        assert!(!associates_alpha(true, Some("STRAIGHT"), false));
        assert!(
            !associates_alpha(false, Some("CHANNEL_PACKED"), false) && !associates_alpha(false, Some("NONE"), false)
        );
        assert!(!associates_alpha(false, None, false));
    }

    #[test]
    fn wrap_modes() {
        assert_eq!(tex(Wrap::Repeat).lookup(Vec2::new(1.25, 0.5)).x, 0.0);
        assert_eq!(tex(Wrap::Clamp).lookup(Vec2::new(1.25, 0.5)).x, 1.0);
        assert_eq!(tex(Wrap::Mirror).lookup(Vec2::new(1.25, 0.5)).x, 1.0);
        assert_eq!(tex(Wrap::Mirror).lookup(Vec2::new(1.75, 0.5)).x, 0.0);
    }

    #[test]
    fn srgb_images_are_filtered_encoded_and_decoded_after() {
        // Half way between black and white: Cycles blends the encoded 0 and 1 and decodes
        // 0.5 (0.214), where blending the decoded texels would give 0.5.
        let t = Texture { srgb: true, nearest: false, wrap_s: Wrap::Clamp, ..tex(Wrap::Clamp) };
        let mid = t.lookup(Vec2::new(0.5, 0.5));
        let want = ((0.5f32 + 0.055) / 1.055).powf(2.4);
        assert!((mid.x - want).abs() < 1e-6, "{} vs {want}", mid.x);
        assert_eq!(mid.w, 1.0, "alpha is linear");
        // A texel centre is the table's value exactly.
        assert_eq!(t.lookup(Vec2::new(0.75, 0.5)), t.texel(1, 0));
    }

    #[test]
    fn float_srgb_images_are_filtered_encoded_and_decoded_after() {
        // A 16-bit PNG or an OpenEXR tagged sRGB keeps its encoded floats, as Cycles'
        // `compress_as_srgb` does for every sRGB image: the blend of 0 and 1 decodes 0.5.
        let hdr = vec![Vec4::new(0.0, 0.0, 0.0, 1.0), Vec4::new(1.0, 1.0, 1.0, 1.0)];
        let t =
            Texture { srgb: true, nearest: false, wrap_s: Wrap::Clamp, texels: Vec::new(), hdr, ..tex(Wrap::Clamp) };
        let mid = t.lookup(Vec2::new(0.5, 0.5));
        let want = ((0.5f32 + 0.055) / 1.055).powf(2.4);
        assert!((mid.x - want).abs() < 1e-6, "{} vs {want}", mid.x);
        // Texels are decoded too (`texel`: Closest, the mean), and negative values give 0.
        assert_eq!(t.texel(1, 0), Vec4::ONE);
        let negative = Texture { hdr: vec![Vec4::new(-0.5, 0.02, 2.0, 1.0)], width: 1, ..t.clone() };
        let v = negative.texel(0, 0);
        assert!(
            v.x == 0.0 && (v.y - 0.02 / 12.92).abs() < 1e-7 && (v.z - (2.055f32 / 1.055).powf(2.4)).abs() < 1e-4,
            "{v}"
        );
    }

    #[test]
    fn transform_rotates_then_offsets() {
        // The extension's example: rotation by 90° maps (1, 0) to (0, -1) (its matrix
        // is [c s; -s c] in column order), then offset.
        let m = texture_transform([0.5, 0.0], std::f32::consts::FRAC_PI_2, [1.0, 1.0]);
        let p = m.transform_point2(Vec2::new(1.0, 0.0));
        assert!((p - Vec2::new(0.5, -1.0)).length() < 1e-5, "{p}");
    }
}
