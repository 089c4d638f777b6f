//! The power of emissive triangles: the mean of the emissive texture over each triangle's
//! UV footprint, read from a box-filtered pyramid of the texture built once, at the level
//! where the footprint spans at most [`FOOTPRINT_TEXELS`] texels, so that each triangle
//! costs a bounded number of texel reads whatever the texture's size (it used to cost a
//! pass over the whole texture, which made loading quadratic).
//!
//! The mean is the average of the level's texels whose centres lie in the triangle (the
//! texel under the centroid when none does). Box filtering and averaging are summed in
//! f64, so a constant texture gives its texel value exactly, as the whole-image mean did.

use crate::scene::texture::{Texture, wrap};
use glam::{DVec3, Vec2, Vec3};

/// Largest extent, in texels of the chosen level, of a triangle's UV bounding box: at most
/// (FOOTPRINT_TEXELS + 2)² texels are read per triangle.
pub(super) const FOOTPRINT_TEXELS: f32 = 8.0;

/// A texture's box-filtered levels above the image itself (which is read in place).
pub(super) struct MeanPyramid {
    /// Level 1, 2, ...: (width, height, linear RGB texels row-major); the last is 1×1.
    levels: Vec<(u32, u32, Vec<Vec3>)>,
}

/// Bytes the pyramid of a `width`×`height` texture needs (its levels sum to at most a
/// third of the image's texel count, plus one row and column per level for odd sizes).
pub(super) fn pyramid_bytes(width: u32, height: u32) -> u64 {
    let (w, h) = (width as u64, height as u64);
    (w * h / 3 + 2 * (w + h) + 64) * std::mem::size_of::<Vec3>() as u64
}

impl MeanPyramid {
    /// Builds the levels of `tex`; counts the texels read in `reads`.
    pub(super) fn new(tex: &Texture, reads: &mut u64) -> Self {
        let mut levels: Vec<(u32, u32, Vec<Vec3>)> = Vec::new();
        let (mut w, mut h) = (tex.width, tex.height);
        while w > 1 || h > 1 {
            let (nw, nh) = (w.div_ceil(2), h.div_ceil(2));
            let mut next = Vec::with_capacity((nw * nh) as usize);
            for y in 0..nh {
                for x in 0..nw {
                    // The 2×2 block below, clipped at an odd edge.
                    let mut sum = DVec3::ZERO;
                    let mut n = 0u32;
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let (sx, sy) = (2 * x + dx, 2 * y + dy);
                        if sx < w && sy < h {
                            sum += match levels.last() {
                                None => tex.texel(sx as i64, sy as i64).truncate().as_dvec3(),
                                Some((lw, _, t)) => t[(sy * lw + sx) as usize].as_dvec3(),
                            };
                            n += 1;
                        }
                    }
                    *reads += n as u64;
                    next.push((sum / n as f64).as_vec3());
                }
            }
            levels.push((nw, nh, next));
            (w, h) = (nw, nh);
        }
        MeanPyramid { levels }
    }

    /// Mean linear RGB of `tex` over the triangle with texture coordinates `uv` (after the
    /// texture transform); counts the texels read in `reads`.
    pub(super) fn triangle_mean(&self, tex: &Texture, uv: [Vec2; 3], reads: &mut u64) -> Vec3 {
        if uv.iter().any(|p| !p.is_finite()) {
            // Renders as texel (0, 0) (Texture::lookup); the image's mean is a fair power.
            return tex.mean_rgb();
        }
        let size = Vec2::new(tex.width as f32, tex.height as f32);
        let (lo, hi) = (uv[0].min(uv[1]).min(uv[2]), uv[0].max(uv[1]).max(uv[2]));
        let extent = ((hi - lo) * size).max_element();
        // Smallest level whose texels make the footprint at most FOOTPRINT_TEXELS wide.
        let wanted = (extent / FOOTPRINT_TEXELS).max(1.0).log2().ceil() as usize;
        let level = wanted.min(self.levels.len());
        let (w, h) =
            if level == 0 { (tex.width, tex.height) } else { (self.levels[level - 1].0, self.levels[level - 1].1) };
        if w == 1 && h == 1 {
            // The top of the pyramid: the footprint covers the whole image, or more.
            *reads += 1;
            return if level == 0 { tex.texel(0, 0).truncate() } else { self.levels[level - 1].2[0] };
        }
        let fetch = |x: i64, y: i64| -> DVec3 {
            let (x, y) = (wrap(x, w, tex.wrap_s), wrap(y, h, tex.wrap_t));
            if level == 0 {
                tex.texel(x as i64, y as i64).truncate().as_dvec3()
            } else {
                self.levels[level - 1].2[(y * w + x) as usize].as_dvec3()
            }
        };
        // Texel space of the level: texel (i, j) has its centre at (i + ½, j + ½).
        let s = Vec2::new(w as f32, h as f32);
        let p = uv.map(|q| (q * s).as_dvec2());
        let area2 = (p[1] - p[0]).perp_dot(p[2] - p[0]);
        let (lo, hi) = (lo * s, hi * s);
        let mut sum = DVec3::ZERO;
        let mut count = 0u64;
        if area2 != 0.0 {
            for j in (lo.y - 0.5).floor() as i64..=(hi.y - 0.5).ceil() as i64 {
                for i in (lo.x - 0.5).floor() as i64..=(hi.x - 0.5).ceil() as i64 {
                    let c = glam::DVec2::new(i as f64 + 0.5, j as f64 + 0.5);
                    // Inside (edges included) when every edge function has the area's sign.
                    let inside = (0..3).all(|k| (p[(k + 1) % 3] - p[k]).perp_dot(c - p[k]) * area2.signum() >= 0.0);
                    if inside {
                        sum += fetch(i, j);
                        count += 1;
                    }
                }
            }
        }
        if count == 0 {
            // Smaller than a texel of the level (or degenerate in UV): the texel under it.
            let c = (p[0] + p[1] + p[2]) / 3.0;
            sum = fetch(c.x.floor() as i64, c.y.floor() as i64);
            count = 1;
        }
        *reads += count;
        (sum / count as f64).as_vec3()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::texture::Wrap;

    fn texture(w: u32, h: u32, texel: impl Fn(u32, u32) -> [u8; 4], srgb: bool) -> Texture {
        let texels = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| texel(x, y)).collect();
        Texture {
            name: "t".into(),
            width: w,
            height: h,
            texels,
            hdr: Vec::new(),
            srgb,
            wrap_s: Wrap::Repeat,
            wrap_t: Wrap::Repeat,
            nearest: false,
            to_working: None,
            associated: false,
            mean: Vec3::ZERO,
        }
        .with_mean()
    }

    /// A small deterministic generator (no dependency): xorshift.
    fn rng(state: &mut u64) -> f32 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 40) as f32 / (1u64 << 24) as f32
    }

    #[test]
    fn a_constant_texture_gives_exactly_the_image_mean() {
        // The old power used the image's mean for every triangle; for a constant image the
        // new mean must be that value bit for bit, whatever the triangle (tiny, huge,
        // outside [0, 1] under REPEAT, degenerate), at odd and even sizes.
        for (w, h) in [(37, 19), (64, 64), (1, 1)] {
            let tex = texture(w, h, |_, _| [200, 90, 17, 255], true);
            let pyramid = MeanPyramid::new(&tex, &mut 0);
            let mut state = 0x9e37_79b9_7f4a_7c15;
            for scale in [1e-4, 0.01, 0.3, 1.0, 7.0] {
                for _ in 0..200 {
                    let mut q = || Vec2::new(rng(&mut state) * 4.0 - 2.0, rng(&mut state) * 4.0 - 2.0);
                    let o = q();
                    let uv = [o, o + q() * scale, o + q() * scale];
                    assert_eq!(pyramid.triangle_mean(&tex, uv, &mut 0), tex.mean_rgb(), "{w}x{h} {uv:?}");
                }
            }
        }
    }

    #[test]
    fn blocks_under_their_triangles_give_their_own_value() {
        // A 64×64 texture of square blocks of distinct values; each block is covered by two
        // triangles exactly. Every texel centre in a triangle, at every level up to the
        // block's size, lies in its block, so the mean is the block's value exactly, and
        // the area-weighted sum over all triangles is the image's mean to f32 rounding.
        for block in [4u32, 8, 16, 32] {
            let n = 64 / block;
            let tex = texture(64, 64, |x, y| [(7 * (x / block) + 29 * (y / block)) as u8 * 3, 0, 255, 255], false);
            let pyramid = MeanPyramid::new(&tex, &mut 0);
            let mut total = 0.0f64;
            for by in 0..n {
                for bx in 0..n {
                    let want = tex.texel((bx * block) as i64, (by * block) as i64).x;
                    let c = |dx: u32, dy: u32| Vec2::new((bx + dx) as f32, (by + dy) as f32) / n as f32;
                    for tri in [[c(0, 0), c(1, 0), c(1, 1)], [c(0, 0), c(1, 1), c(0, 1)]] {
                        let m = pyramid.triangle_mean(&tex, tri, &mut 0).x;
                        assert_eq!(m, want, "block {block} at ({bx}, {by})");
                        total += m as f64 * 0.5 / (n * n) as f64;
                    }
                }
            }
            // f32 rounding of each block value (2^-24 relative) is all that separates them.
            let whole = tex.mean_rgb().x as f64;
            assert!((total - whole).abs() <= 1e-6 * whole, "block {block}: {total} vs {whole}");
        }
    }

    #[test]
    fn texel_reads_are_bounded_per_triangle() {
        // 2048² texture, 20000 triangles of every size: the pyramid reads each texel once
        // (plus a third for its upper levels) and each triangle at most (8 + 2)² texels;
        // the old per-triangle image mean would have read 20000 × 2048² = 8.4e10.
        let tex = texture(2048, 2048, |x, y| [(x ^ y) as u8, x as u8, y as u8, 255], true);
        let mut reads = 0;
        let pyramid = MeanPyramid::new(&tex, &mut reads);
        let texels = 2048u64 * 2048;
        assert!(reads <= texels + texels / 3 + 2048 * 4, "pyramid: {reads}");
        let mut state = 12345;
        let triangles = 20_000u64;
        let mut tri_reads = 0;
        for t in 0..triangles {
            let scale = [1e-4, 3e-3, 0.05, 1.0][t as usize % 4];
            let mut q = || Vec2::new(rng(&mut state), rng(&mut state));
            let o = q();
            pyramid.triangle_mean(&tex, [o, o + q() * scale, o + q() * scale], &mut tri_reads);
        }
        let bound = (FOOTPRINT_TEXELS as u64 + 2).pow(2);
        assert!(tri_reads <= triangles * bound, "{tri_reads} reads for {triangles} triangles");
    }
}
