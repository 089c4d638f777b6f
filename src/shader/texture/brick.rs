//! Blender's Brick Texture node (`svm/brick.h`): rows of bricks with offset and squash, a
//! per-brick tint from an integer hash, and mortar with a smooth edge.

use glam::Vec3;

/// The Brick node's settings and non-vector inputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BrickParams {
    /// Shift of every `offset_frequency`-th row, as a fraction of the brick width.
    pub offset: f32,
    /// Which rows are shifted (every n-th).
    pub offset_frequency: i32,
    /// Width factor of every `squash_frequency`-th row.
    pub squash: f32,
    /// Which rows are squashed (every n-th).
    pub squash_frequency: i32,
    /// One end of the bricks' tint range.
    pub color1: Vec3,
    /// The other end of the tint range.
    pub color2: Vec3,
    /// The mortar's colour.
    pub mortar: Vec3,
    /// Multiplies the vector.
    pub scale: f32,
    /// Width of the mortar.
    pub mortar_size: f32,
    /// Softness of the brick edge, as a fraction of the mortar.
    pub mortar_smooth: f32,
    /// Shifts the tint towards `color1` (< 0) or `color2` (> 0).
    pub bias: f32,
    /// Brick width.
    pub brick_width: f32,
    /// Row height.
    pub row_height: f32,
}

/// Cycles' `brick_noise`: a fast integer hash to [0, 1).
#[inline(always)]
fn brick_noise(n: u32) -> f32 {
    let mut n = n.wrapping_add(1013) & 0x7fff_ffff;
    n ^= n >> 13;
    let nn = n.wrapping_mul(n.wrapping_mul(n).wrapping_mul(60493).wrapping_add(19990303)).wrapping_add(1376312589)
        & 0x7fff_ffff;
    0.5 * (nn as f32 / 1073741824.0)
}

/// Cycles' `smoothstepf`: `3f^2 - 2f^3`, clamped to [0, 1] outside [0, 1].
#[inline(always)]
fn smoothstepf(f: f32) -> f32 {
    if f <= 0.0 {
        0.0
    } else if f >= 1.0 {
        1.0
    } else {
        let ff = f * f;
        3.0 * ff - 2.0 * ff * f
    }
}

/// Cycles' `svm_brick`: the brick's tint and the mortar weight at `p` (already scaled).
#[inline]
fn brick(p: Vec3, prm: &BrickParams) -> (f32, f32) {
    let row_height = prm.row_height;
    let mut brick_width = prm.brick_width;
    let mut offset = 0.0;
    let rownum = (p.y / row_height).floor() as i32;
    if prm.offset_frequency != 0 && prm.squash_frequency != 0 {
        if rownum.wrapping_rem(prm.squash_frequency) == 0 {
            brick_width *= prm.squash;
        }
        if rownum.wrapping_rem(prm.offset_frequency) == 0 {
            offset = brick_width * prm.offset;
        }
    }
    let bricknum = ((p.x + offset) / brick_width).floor() as i32;
    let x = (p.x + offset) - brick_width * bricknum as f32;
    let y = p.y - row_height * rownum as f32;
    let key = ((rownum as u32) << 16).wrapping_add((bricknum & 0xFFFF) as u32);
    let tint = (brick_noise(key) + prm.bias).clamp(0.0, 1.0);
    let min_dist = x.min(y).min((brick_width - x).min(row_height - y));
    let mortar = if min_dist >= prm.mortar_size {
        0.0
    } else if prm.mortar_smooth == 0.0 {
        1.0
    } else {
        smoothstepf((1.0 - min_dist / prm.mortar_size) / prm.mortar_smooth)
    };
    (tint, mortar)
}

/// (Color, Fac) of the Brick node: Fac is the mortar weight.
#[inline]
pub fn brick_texture(p: Vec3, prm: &BrickParams) -> (Vec3, f32) {
    let (tint, f) = brick(p * prm.scale, prm);
    let mut color1 = prm.color1;
    if f != 1.0 {
        color1 = (1.0 - tint) * color1 + tint * prm.color2;
    }
    (color1 * (1.0 - f) + prm.mortar * f, f)
}
