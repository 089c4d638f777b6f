//! The Image Texture node: Blender's projections (Flat, Box with its blend, Sphere, Tube),
//! interpolations (Closest, Linear, Cubic B-spline; Smart as Cubic) and extensions
//! (Repeat, Extend, Clip, Mirror), as Cycles' `svm/image.h` and its CPU image lookup.
//! Texels are the scene's textures; an 8-bit sRGB image is filtered as stored and decoded
//! after (`Texture::decode`), as Cycles' `svm_image_texture` converts the interpolated value.

use super::geom::Reg;
use crate::scene::texture::{Texture, Wrap, wrap};
use glam::{Vec2, Vec3, Vec4};

/// Interpolation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(missing_docs)]
pub enum Interp {
    Closest,
    Linear,
    Cubic,
}

/// Extension beyond [0, 1].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(missing_docs)]
pub enum Extension {
    Repeat,
    Extend,
    Clip,
    Mirror,
}

/// Projection of the Vector input onto the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(missing_docs)]
pub enum Projection {
    Flat,
    Box,
    Sphere,
    Tube,
    /// Environment Texture: equirectangular lookup of the (normalised) vector.
    Equirectangular,
    /// Environment Texture: mirror ball.
    MirrorBall,
}

/// An Image Texture node compiled.
#[derive(Clone, Debug)]
pub struct ImageOp {
    /// Index into `Scene::textures` (None: the node has no image; Cycles' magenta).
    pub texture: Option<u32>,
    /// A UDIM image's tiles: (tile number, index into `Scene::textures`); empty otherwise.
    pub tiles: Vec<(u32, u32)>,
    /// Interpolation.
    pub interp: Interp,
    /// Extension.
    pub extension: Extension,
    /// Projection.
    pub projection: Projection,
    /// Box projection's blend.
    pub blend: f32,
    /// Vector input (Blender axes).
    pub vector: Reg,
    /// Object-space normal (for Box).
    pub normal: Reg,
    /// Colour output.
    pub color: Reg,
    /// Alpha output.
    pub alpha: Reg,
    /// The Alpha output is read: an associated image's colour is divided back by its alpha
    /// (Cycles' `NODE_IMAGE_ALPHA_UNASSOCIATE`); unread, the colour stays associated.
    pub alpha_read: bool,
}

/// Texel (x, y) under the node's extension, as stored (`Texture::stored_texel`: an 8-bit sRGB
/// image's RGB still encoded; `lookup` decodes after filtering, as Cycles).
fn texel(t: &Texture, x: i64, y: i64, ext: Extension) -> Vec4 {
    let (w, h) = (t.width as i64, t.height as i64);
    let (x, y) = match ext {
        Extension::Clip => {
            if x < 0 || y < 0 || x >= w || y >= h {
                return Vec4::ZERO;
            }
            (x, y)
        }
        Extension::Repeat => (wrap(x, t.width, Wrap::Repeat) as i64, wrap(y, t.height, Wrap::Repeat) as i64),
        Extension::Extend => (x.clamp(0, w - 1), y.clamp(0, h - 1)),
        Extension::Mirror => (wrap(x, t.width, Wrap::Mirror) as i64, wrap(y, t.height, Wrap::Mirror) as i64),
    };
    // In range: the texture's own wrap mode leaves the index unchanged.
    t.stored_texel(x, y)
}

/// Cycles' colour of a missing image or UDIM tile (magenta).
const MISSING: Vec4 = Vec4::new(1.0, 0.0, 1.0, 1.0);

/// The UDIM tile under `uv` and `uv` within it, as Cycles' `kernel_image_udim_map`: the tile
/// of the truncated coordinates (1001 + 10 v + u; u in 0..10, v from 0), None where it is not
/// one of `tiles` (Cycles' missing image).
fn udim_tile(tiles: &[(u32, u32)], uv: Vec2) -> Option<(u32, Vec2)> {
    let (tx, ty) = (uv.x as i64, uv.y as i64);
    if tx < 0 || ty < 0 || tx >= 10 {
        return None;
    }
    let number = 1001 + 10 * ty + tx;
    let &(_, texture) = tiles.iter().find(|&&(n, _)| n as i64 == number)?;
    Some((texture, uv - Vec2::new(tx as f32, ty as f32)))
}

/// Cubic B-spline weights for fraction t.
fn bspline(t: f32) -> [f32; 4] {
    let t2 = t * t;
    let t3 = t2 * t;
    [
        (1.0 - 3.0 * t + 3.0 * t2 - t3) / 6.0,
        (4.0 - 6.0 * t2 + 3.0 * t3) / 6.0,
        (1.0 + 3.0 * t + 3.0 * t2 - 3.0 * t3) / 6.0,
        t3 / 6.0,
    ]
}

/// The image at Blender texture coordinate `uv` (v up); with `unassociate` an associated
/// image's filtered colour is divided by its filtered alpha (`ImageOp::alpha_read`).
pub fn lookup(t: &Texture, uv: Vec2, interp: Interp, ext: Extension, unassociate: bool) -> Vec4 {
    if !uv.is_finite() {
        return Vec4::ZERO;
    }
    // Clip has no cut at the image's edge: texels outside are 0 (`texel`), so the linear and
    // cubic filters fade out over half a texel and a texel and a half past it, as Cycles'
    // `interp_linear`/`interp_cubic` (they only skip points whose texels are all outside).
    // Texel rows are stored top first: Blender's v = 1 is row 0.
    let (fx, fy) = (uv.x * t.width as f32, (1.0 - uv.y) * t.height as f32);
    let stored = match interp {
        Interp::Closest => texel(t, fx.floor() as i64, fy.floor() as i64, ext),
        Interp::Linear => {
            let (x, y) = (fx - 0.5, fy - 0.5);
            let (x0, y0) = (x.floor(), y.floor());
            let (tx, ty) = (x - x0, y - y0);
            let (x0, y0) = (x0 as i64, y0 as i64);
            let a = texel(t, x0, y0, ext).lerp(texel(t, x0 + 1, y0, ext), tx);
            let b = texel(t, x0, y0 + 1, ext).lerp(texel(t, x0 + 1, y0 + 1, ext), tx);
            a.lerp(b, ty)
        }
        Interp::Cubic => {
            let (x, y) = (fx - 0.5, fy - 0.5);
            let (x0, y0) = (x.floor(), y.floor());
            let (wx, wy) = (bspline(x - x0), bspline(y - y0));
            let (x0, y0) = (x0 as i64, y0 as i64);
            let mut c = Vec4::ZERO;
            for (j, wyj) in wy.iter().enumerate() {
                for (i, wxi) in wx.iter().enumerate() {
                    c += texel(t, x0 - 1 + i as i64, y0 - 1 + j as i64, ext) * (wxi * wyj);
                }
            }
            c
        }
    };
    // As Cycles' `svm_image_texture`: filtered, unassociated, then decoded from sRGB.
    let stored = if unassociate && t.associated && stored.w != 0.0 && stored.w != 1.0 {
        (stored.truncate() / stored.w).extend(stored.w)
    } else {
        stored
    };
    t.decode(stored)
}

/// Cycles' box-projection weights for the object-space normal `n` and `blend`.
pub fn box_weights(n: Vec3, blend: f32) -> Vec3 {
    let a = n.abs();
    let s = a.x + a.y + a.z;
    if !(s > 0.0) {
        return Vec3::X;
    }
    let n = a / s;
    let limit = 0.5 * (1.0 + blend);
    let mut w = Vec3::ZERO;
    if n.x > limit * (n.x + n.y) && n.x > limit * (n.x + n.z) {
        w.x = 1.0;
    } else if n.y > limit * (n.x + n.y) && n.y > limit * (n.y + n.z) {
        w.y = 1.0;
    } else if n.z > limit * (n.x + n.z) && n.z > limit * (n.y + n.z) {
        w.z = 1.0;
    } else if blend > 0.0 {
        let ramp = |x: f32| ((x - 0.5 * (1.0 - blend)) / blend).clamp(0.0, 1.0);
        if n.z < (1.0 - limit) * (n.y + n.x) {
            w.x = ramp(n.x / (n.x + n.y));
            w.y = 1.0 - w.x;
        } else if n.x < (1.0 - limit) * (n.y + n.z) {
            w.y = ramp(n.y / (n.y + n.z));
            w.z = 1.0 - w.y;
        } else if n.y < (1.0 - limit) * (n.x + n.z) {
            w.x = ramp(n.x / (n.x + n.z));
            w.z = 1.0 - w.x;
        } else {
            let f = |x: f32| ((2.0 - limit) * x + (limit - 1.0)) / (2.0 * limit - 1.0);
            w = Vec3::new(f(n.x), f(n.y), f(n.z));
        }
    } else {
        w.x = 1.0;
    }
    w
}

impl ImageOp {
    /// Evaluates the node.
    pub fn run(&self, r: &mut [f32], textures: &[Texture]) {
        let v = |i: Reg| Vec3::new(r[i as usize], r[i as usize + 1], r[i as usize + 2]);
        let co = v(self.vector);
        let c = match self.texture.and_then(|i| textures.get(i as usize)) {
            None => MISSING,
            Some(t) => {
                let at = |uv: Vec2| lookup(t, uv, self.interp, self.extension, self.alpha_read);
                match self.projection {
                    Projection::Flat if !self.tiles.is_empty() => match udim_tile(&self.tiles, Vec2::new(co.x, co.y)) {
                        Some((k, uv)) => match textures.get(k as usize) {
                            Some(tile) => lookup(tile, uv, self.interp, self.extension, self.alpha_read),
                            None => MISSING,
                        },
                        None => MISSING,
                    },
                    Projection::Flat => at(Vec2::new(co.x, co.y)),
                    Projection::Sphere => {
                        let p = (co - Vec3::splat(0.5)) * 2.0;
                        let len = p.length();
                        let uv = if len > 0.0 {
                            let u = if p.x == 0.0 && p.y == 0.0 {
                                0.0
                            } else {
                                (1.0 - p.x.atan2(p.y) / std::f32::consts::PI) / 2.0
                            };
                            Vec2::new(u, 1.0 - (p.z / len).clamp(-1.0, 1.0).acos() / std::f32::consts::PI)
                        } else {
                            Vec2::ZERO
                        };
                        at(uv)
                    }
                    Projection::Tube => {
                        let p = (co - Vec3::splat(0.5)) * 2.0;
                        let len = (p.x * p.x + p.y * p.y).sqrt();
                        let u = if len > 0.0 {
                            (1.0 - (p.x / len).atan2(p.y / len) / std::f32::consts::PI) / 2.0
                        } else {
                            0.0
                        };
                        at(Vec2::new(u, (p.z + 1.0) / 2.0))
                    }
                    Projection::Equirectangular => {
                        let d = co.normalize_or(Vec3::X);
                        // As the world's image (docs/contract.md, CAUSTIC_world).
                        let u = 0.5 - d.y.atan2(d.x) / (2.0 * std::f32::consts::PI);
                        let v = 0.5 + d.z.clamp(-1.0, 1.0).asin() / std::f32::consts::PI;
                        at(Vec2::new(u, v))
                    }
                    Projection::MirrorBall => {
                        let mut d = co.normalize_or(Vec3::X);
                        d.y -= 1.0;
                        let div = 2.0 * (-0.5 * d.y).max(0.0).sqrt();
                        if div > 0.0 {
                            d /= div;
                        }
                        at(Vec2::new(0.5 * (d.x + 1.0), 0.5 * (d.z + 1.0)))
                    }
                    Projection::Box => {
                        let signed = v(self.normal);
                        let w = box_weights(signed, self.blend);
                        let mut f = Vec4::ZERO;
                        if w.x > 0.0 {
                            f += at(Vec2::new(if signed.x < 0.0 { 1.0 - co.y } else { co.y }, co.z)) * w.x;
                        }
                        if w.y > 0.0 {
                            f += at(Vec2::new(if signed.y > 0.0 { 1.0 - co.x } else { co.x }, co.z)) * w.y;
                        }
                        if w.z > 0.0 {
                            f += at(Vec2::new(if signed.z > 0.0 { 1.0 - co.y } else { co.y }, co.x)) * w.z;
                        }
                        f
                    }
                }
            }
        };
        let o = self.color as usize;
        r[o] = c.x;
        r[o + 1] = c.y;
        r[o + 2] = c.z;
        r[self.alpha as usize] = c.w;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tex() -> Texture {
        // 2×2: top row red, green; bottom row blue, white.
        Texture {
            name: "t".into(),
            width: 2,
            height: 2,
            texels: vec![[255, 0, 0, 255], [0, 255, 0, 255], [0, 0, 255, 255], [255, 255, 255, 255]],
            hdr: Vec::new(),
            srgb: false,
            wrap_s: Wrap::Repeat,
            wrap_t: Wrap::Repeat,
            nearest: false,
            to_working: None,
            associated: false,
            mean: Vec3::ZERO,
        }
    }

    #[test]
    fn blender_v_is_up_and_extensions_behave() {
        let t = tex();
        // Blender's (0.25, 0.75) is the top-left texel.
        assert_eq!(
            lookup(&t, Vec2::new(0.25, 0.75), Interp::Closest, Extension::Repeat, false),
            Vec4::new(1., 0., 0., 1.)
        );
        assert_eq!(
            lookup(&t, Vec2::new(0.25, 0.25), Interp::Closest, Extension::Repeat, false),
            Vec4::new(0., 0., 1., 1.)
        );
        // Repeat wraps, Clip is transparent black outside, Extend holds the edge.
        assert_eq!(
            lookup(&t, Vec2::new(1.25, 0.75), Interp::Closest, Extension::Repeat, false),
            Vec4::new(1., 0., 0., 1.)
        );
        assert_eq!(lookup(&t, Vec2::new(1.25, 0.75), Interp::Closest, Extension::Clip, false), Vec4::ZERO);
        assert_eq!(
            lookup(&t, Vec2::new(1.25, 0.75), Interp::Closest, Extension::Extend, false),
            Vec4::new(0., 1., 0., 1.)
        );
        // Linear at the centre averages the four texels.
        let c = lookup(&t, Vec2::new(0.5, 0.5), Interp::Linear, Extension::Repeat, false);
        assert!((c - Vec4::new(0.5, 0.5, 0.5, 1.0)).abs().max_element() < 1e-6, "{c}");
        // The cubic B-spline keeps a constant image constant (its weights sum to 1).
        let w: f32 = bspline(0.3).iter().sum();
        assert!((w - 1.0).abs() < 1e-6);
    }

    #[test]
    fn an_associated_image_is_filtered_associated_and_divided_back_only_for_a_read_alpha() {
        // Straight texels: opaque red beside a transparent white, premultiplied on load.
        let mut texels = vec![[255, 0, 0, 255], [255, 255, 255, 0]];
        crate::scene::texture::premultiply(&mut texels);
        assert_eq!(texels, vec![[255, 0, 0, 255], [0, 0, 0, 0]]);
        let t = Texture { width: 2, height: 1, texels, associated: true, ..tex() };
        // Halfway between the texels: the filtered (associated) value is (0.5, 0, 0, 0.5).
        let uv = Vec2::new(0.5, 0.5);
        let unread = lookup(&t, uv, Interp::Linear, Extension::Extend, false);
        assert!((unread - Vec4::new(0.5, 0.0, 0.0, 0.5)).abs().max_element() < 1e-6, "{unread}");
        // Divided back: pure red, with no white bled in from the transparent texel.
        let read = lookup(&t, uv, Interp::Linear, Extension::Extend, true);
        assert!((read - Vec4::new(1.0, 0.0, 0.0, 0.5)).abs().max_element() < 1e-6, "{read}");
        // Alpha 0 is left as it is (Cycles divides only for 0 < alpha < 1).
        let clear = lookup(&t, Vec2::new(0.75, 0.5), Interp::Closest, Extension::Extend, true);
        assert_eq!(clear, Vec4::ZERO);
        // An image that is not associated (data, Channel Packed) is never divided.
        let plain = Texture { associated: false, ..t };
        assert_eq!(lookup(&plain, uv, Interp::Linear, Extension::Extend, true), unread);
    }

    #[test]
    fn clip_fades_out_past_the_edge_as_cycles() {
        let t = tex();
        // A quarter texel past the right edge, on the top row's centre: the linear filter
        // weighs the edge texel (green) 1/4 against the transparent black outside, as Cycles'
        // `interp_linear`; an edge cut at u = 1 gave 0 (2.5 % of the probe image's mean).
        let fringe = lookup(&t, Vec2::new(1.0 + 0.125, 0.75), Interp::Linear, Extension::Clip, false);
        assert!((fringe - Vec4::new(0.0, 0.25, 0.0, 0.25)).abs().max_element() < 1e-6, "{fringe}");
        // Past half a texel every texel the filter reads is outside.
        assert_eq!(lookup(&t, Vec2::new(1.3, 0.75), Interp::Linear, Extension::Clip, false), Vec4::ZERO);
        // The cubic B-spline reaches a texel and a half out.
        let cubic = lookup(&t, Vec2::new(1.5, 0.75), Interp::Cubic, Extension::Clip, false);
        assert!(cubic.y > 0.0 && cubic.y < 0.1, "{cubic}");
        assert_eq!(lookup(&t, Vec2::new(1.0, 0.75), Interp::Closest, Extension::Clip, false), Vec4::ZERO);
    }

    #[test]
    fn udim_tiles_are_found_by_the_truncated_coordinates() {
        let tiles = [(1001, 7), (1002, 8), (1011, 9)];
        assert_eq!(udim_tile(&tiles, Vec2::new(1.25, 0.5)), Some((8, Vec2::new(0.25, 0.5))));
        assert_eq!(udim_tile(&tiles, Vec2::new(0.5, 1.75)), Some((9, Vec2::new(0.5, 0.75))));
        // Truncation, as Cycles' (int) cast: just below 0 is still tile 1001.
        assert_eq!(udim_tile(&tiles, Vec2::new(-0.25, 0.5)), Some((7, Vec2::new(-0.25, 0.5))));
        assert_eq!(udim_tile(&tiles, Vec2::new(2.5, 0.5)), None, "tile 1003 is absent");
        assert_eq!(udim_tile(&tiles, Vec2::new(10.5, 0.5)), None, "u past the tenth column");
        assert_eq!(udim_tile(&tiles, Vec2::new(-1.5, 0.5)), None);
    }

    #[test]
    fn box_weights_pick_the_dominant_axis_and_blend_sums_to_one() {
        assert_eq!(box_weights(Vec3::new(0.1, 0.2, 0.9), 0.0), Vec3::Z);
        let w = box_weights(Vec3::new(1.0, 1.0, 0.0), 0.5);
        assert!((w.x + w.y + w.z - 1.0).abs() < 1e-6 && (w.x - 0.5).abs() < 1e-6, "{w}");
    }
}
