//! Blender's Magic Texture node (`svm/magic.h`): nested sines and cosines of the coordinates.

use core::f32::consts::TAU;

use glam::Vec3;

/// (Color, Fac) of the Magic node; `depth` is the node's turbulence depth (0..=10 used), Fac the
/// average of the colour.
#[inline]
pub fn magic_texture(p: Vec3, depth: i32, scale: f32, distortion: f32) -> (Vec3, f32) {
    // Cycles takes the input modulo 2 pi first (the node's Vector is not scaled before): it
    // keeps large coordinates from overflowing `(x + y + z) * 5 scale` and from drowning the
    // small ones in rounding.
    let px = p.x % TAU;
    let py = p.y % TAU;
    let pz = p.z % TAU;
    let n = depth;
    let mut x = ((px + py + pz) * 5.0 * scale).sin();
    let mut y = ((-px + py - pz) * 5.0 * scale).cos();
    let mut z = -((-px - py + pz) * 5.0 * scale).cos();
    // Each level feeds the previous ones back through one more trigonometric function.
    if n > 0 {
        x *= distortion;
        y *= distortion;
        z *= distortion;
        y = -(x - y + z).cos();
        y *= distortion;
        if n > 1 {
            x = (x - y - z).cos();
            x *= distortion;
            if n > 2 {
                z = (-x - y - z).sin();
                z *= distortion;
                if n > 3 {
                    x = -(-x + y - z).cos();
                    x *= distortion;
                    if n > 4 {
                        y = -(-x + y + z).sin();
                        y *= distortion;
                        if n > 5 {
                            y = -(-x + y + z).cos();
                            y *= distortion;
                            if n > 6 {
                                x = (x + y + z).cos();
                                x *= distortion;
                                if n > 7 {
                                    z = (x + y - z).sin();
                                    z *= distortion;
                                    if n > 8 {
                                        x = -(-x - y + z).cos();
                                        x *= distortion;
                                        if n > 9 {
                                            y = -(x - y + z).sin();
                                            y *= distortion;
                                        }
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    if distortion != 0.0 {
        let d = distortion * 2.0;
        x /= d;
        y /= d;
        z /= d;
    }
    let color = Vec3::new(0.5 - x, 0.5 - y, 0.5 - z);
    // Cycles' `average`: the sum times 1/3.
    (color, (color.x + color.y + color.z) * (1.0 / 3.0))
}
