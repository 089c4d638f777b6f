//! Simplify > Texture Limit, as Cycles applies it when it loads an image
//! (`ImageManager::file_load_image`): an image whose longer side passes the limit is scaled by
//! the power of two that brings it within, each texel of the result the box average of the
//! k × k stored texels it covers (k = 1 / scale, `util_image_downscale_pixels`), the sizes
//! truncated (at least 1). Cycles holds an image bottom row first, so where a side is not a
//! multiple of k the rows it leaves out are the top ones; texels here are top row first.

use glam::Vec4;

/// The box width k (a power of two) and the new width and height of a `width` × `height`
/// image under `limit`, or None when the image fits.
pub fn factor(width: u32, height: u32, limit: u32) -> Option<(u32, u32, u32)> {
    let longest = width.max(height);
    if limit == 0 || longest <= limit {
        return None;
    }
    // Cycles' loop, in its float arithmetic: halve the scale until the longer side fits.
    let mut scale = 1.0f32;
    while longest as f32 * scale > limit as f32 {
        scale *= 0.5;
    }
    let k = (1.0 / scale + 0.5) as u32;
    let side = |n: u32| ((n as f32 * scale) as u32).max(1);
    Some((k, side(width), side(height)))
}

/// An 8-bit image shrunk to `limit` (None when it fits): averages of v / 255, rounded back
/// as Cycles' `util_image_cast_from_float<uchar>`.
pub fn shrink_u8(texels: &[[u8; 4]], width: u32, height: u32, limit: u32) -> Option<(u32, u32, Vec<[u8; 4]>)> {
    if texels.len() != width as usize * height as usize {
        return None; // not this image's storage (a float image holds no bytes)
    }
    let (k, w, h) = factor(width, height, limit)?;
    let to_byte = |v: f32| {
        if v < 0.0 {
            0
        } else if v > 1.0 - 0.5 / 255.0 {
            255
        } else {
            (255.0 * v + 0.5) as u8
        }
    };
    let out = shrink(width, height, k, w, h, |i| {
        let t = texels[i];
        Vec4::new(t[0] as f32, t[1] as f32, t[2] as f32, t[3] as f32) / 255.0
    })
    .into_iter()
    .map(|v| [to_byte(v.x), to_byte(v.y), to_byte(v.z), to_byte(v.w)])
    .collect();
    Some((w, h, out))
}

/// A float image shrunk to `limit` (None when it fits).
pub fn shrink_f32(hdr: &[Vec4], width: u32, height: u32, limit: u32) -> Option<(u32, u32, Vec<Vec4>)> {
    if hdr.len() != width as usize * height as usize {
        return None; // not this image's storage (an 8-bit image holds no floats)
    }
    let (k, w, h) = factor(width, height, limit)?;
    Some((w, h, shrink(width, height, k, w, h, |i| hdr[i])))
}

/// Box averages of `k` × `k` texels (read by top-first index through `texel`), rows counted
/// from the bottom as Cycles stores them; result top row first.
fn shrink(width: u32, height: u32, k: u32, w: u32, h: u32, texel: impl Fn(usize) -> Vec4) -> Vec<Vec4> {
    let mut out = vec![Vec4::ZERO; (w * h) as usize];
    for by in 0..h {
        for x in 0..w {
            let mut sum = Vec4::ZERO;
            let mut count = 0u32;
            for dy in 0..k {
                let from_bottom = by * k + dy;
                if from_bottom >= height {
                    continue;
                }
                let row = height - 1 - from_bottom;
                for dx in 0..k {
                    let col = x * k + dx;
                    if col < width {
                        sum += texel((row * width + col) as usize);
                        count += 1;
                    }
                }
            }
            let top_row = h - 1 - by;
            out[(top_row * w + x) as usize] = if count > 0 { sum / count as f32 } else { Vec4::ZERO };
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halves_until_the_longer_side_fits() {
        assert_eq!(factor(512, 512, 512), None);
        assert_eq!(factor(513, 100, 512), Some((2, 256, 50)));
        assert_eq!(factor(2048, 1024, 256), Some((8, 256, 128)));
        // Sizes truncate (Cycles' size_t of w × scale) and stay at least 1.
        assert_eq!(factor(1001, 3, 128), Some((8, 125, 1)));
        assert_eq!(factor(1001, 1, 500), Some((4, 250, 1)));
    }

    /// A 3 × 3 image under limit 2 becomes 1 × 1 (k = 2): the bottom-left 2 × 2 block as
    /// Cycles holds it (bottom row first) is averaged, the top row and right column left out.
    #[test]
    fn averages_blocks_from_the_bottom_row() {
        #[rustfmt::skip]
        let v = [
            0.0, 0.0, 0.0, // top row: dropped
            0.2, 0.4, 9.0,
            0.6, 0.8, 9.0, // bottom row
        ];
        let hdr: Vec<Vec4> = v.iter().map(|&x| Vec4::splat(x)).collect();
        let (w, h, out) = shrink_f32(&hdr, 3, 3, 2).unwrap();
        assert_eq!((w, h), (1, 1));
        assert!((out[0].x - 0.5).abs() < 1e-6, "{}", out[0]);
        // Bytes average as v / 255 and cast back as Cycles does.
        let texels = [[10, 0, 200, 255], [12, 2, 102, 255]];
        let (_, _, b) = shrink_u8(&texels, 2, 1, 1).unwrap();
        assert_eq!(b, vec![[11, 1, 151, 255]]);
        // The storage an image does not use is empty: asked of it, nothing (it once indexed it).
        assert!(shrink_u8(&[], 300, 130, 128).is_none() && shrink_f32(&[], 300, 130, 128).is_none());
    }
}
