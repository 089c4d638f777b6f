//! Blender's White Noise Texture node (`svm/white_noise.h`): the hash of the input itself.
//!
//! `dims` picks the input: 1 hashes `w`, 2 hashes `p.xy`, 3 hashes `p`, 4 hashes `(p, w)`.
//! The node applies no scale, so equal inputs give equal outputs bit for bit.

use glam::{Vec2, Vec3};

use super::hash::{
    hash_float_to_float, hash_float_to_float3, hash_vector2_to_float, hash_vector2_to_float3, hash_vector3_to_float,
    hash_vector3_to_float3, hash_vector4_to_float, hash_vector4_to_float3,
};

/// (Value, Color) of the White Noise node with `dims` in 1..=4 (anything else is treated as 3,
/// Blender's default, since the node has no other settings).
#[inline]
pub fn white_noise_texture(dims: u8, p: Vec3, w: f32) -> (f32, Vec3) {
    match dims {
        1 => (hash_float_to_float(w), hash_float_to_float3(w)),
        2 => {
            let q = Vec2::new(p.x, p.y);
            (hash_vector2_to_float(q), hash_vector2_to_float3(q))
        }
        4 => {
            let q = p.extend(w);
            (hash_vector4_to_float(q), hash_vector4_to_float3(q))
        }
        _ => (hash_vector3_to_float(p), hash_vector3_to_float3(p)),
    }
}
