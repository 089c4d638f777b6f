//! Blender's Checker Texture node (`svm/checker.h`): alternating unit cubes.

use glam::Vec3;

/// (Color, Fac) of the Checker node: Fac is 1 on the cubes of `color1`, 0 on those of `color2`.
#[inline]
pub fn checker_texture(p: Vec3, color1: Vec3, color2: Vec3, scale: f32) -> (Vec3, f32) {
    let p = p * scale;
    // Cycles nudges coordinates so that faces lying exactly on integers (a unit plane at
    // z = 0, say) fall consistently into one cube instead of flickering with rounding.
    let cube = |c: f32| (((c + 0.000001) * 0.999999).floor() as i32).wrapping_abs() % 2;
    let (xi, yi, zi) = (cube(p.x), cube(p.y), cube(p.z));
    let fac = if ((xi == yi) as i32) == zi { 1.0 } else { 0.0 };
    (if fac == 1.0 { color1 } else { color2 }, fac)
}
