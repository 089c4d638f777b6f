//! Colour nodes as Cycles computes them (`kernel/svm/color_util.h`, `util/color.h`):
//! the Mix node's blend modes, HSV and HSL conversions, Hue/Saturation/Value, Gamma and
//! Bright/Contrast.

use glam::Vec3;

/// Colour blend modes of the Mix node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(missing_docs)]
pub enum Blend {
    Mix,
    Add,
    Multiply,
    Subtract,
    Screen,
    Divide,
    Difference,
    Exclusion,
    Darken,
    Lighten,
    Overlay,
    Dodge,
    Burn,
    Hue,
    Saturation,
    Value,
    Color,
    SoftLight,
    LinearLight,
}

impl Blend {
    /// From Blender's `blend_type` identifier.
    pub fn parse(s: &str) -> Option<Self> {
        use Blend::*;
        Some(match s {
            "MIX" => Mix,
            "ADD" => Add,
            "MULTIPLY" => Multiply,
            "SUBTRACT" => Subtract,
            "SCREEN" => Screen,
            "DIVIDE" => Divide,
            "DIFFERENCE" => Difference,
            "EXCLUSION" => Exclusion,
            "DARKEN" => Darken,
            "LIGHTEN" => Lighten,
            "OVERLAY" => Overlay,
            "DODGE" => Dodge,
            "BURN" => Burn,
            "HUE" => Hue,
            "SATURATION" => Saturation,
            "VALUE" => Value,
            "COLOR" => Color,
            "SOFT_LIGHT" => SoftLight,
            "LINEAR_LIGHT" => LinearLight,
            _ => return None,
        })
    }
}

#[inline]
fn lerp3(a: Vec3, b: Vec3, t: f32) -> Vec3 {
    a * (1.0 - t) + b * t
}

/// Cycles' `svm_mix` of two colours with factor t (not clamped here).
pub fn blend(mode: Blend, t: f32, c1: Vec3, c2: Vec3) -> Vec3 {
    let tm = 1.0 - t;
    let ch = |f: &dyn Fn(f32, f32) -> f32| Vec3::new(f(c1.x, c2.x), f(c1.y, c2.y), f(c1.z, c2.z));
    match mode {
        Blend::Mix => lerp3(c1, c2, t),
        Blend::Add => lerp3(c1, c1 + c2, t),
        Blend::Multiply => lerp3(c1, c1 * c2, t),
        Blend::Subtract => lerp3(c1, c1 - c2, t),
        Blend::Screen => Vec3::ONE - (Vec3::splat(tm) + t * (Vec3::ONE - c2)) * (Vec3::ONE - c1),
        Blend::Divide => ch(&|a, b| if b != 0.0 { tm * a + t * a / b } else { a }),
        Blend::Difference => lerp3(c1, (c1 - c2).abs(), t),
        Blend::Exclusion => lerp3(c1, c1 + c2 - 2.0 * c1 * c2, t).max(Vec3::ZERO),
        Blend::Darken => lerp3(c1, c1.min(c2), t),
        Blend::Lighten => lerp3(c1, c1.max(c2), t),
        Blend::Overlay => ch(&|a, b| {
            if a < 0.5 { a * (tm + 2.0 * t * b) } else { 1.0 - (tm + 2.0 * t * (1.0 - b)) * (1.0 - a) }
        }),
        Blend::Dodge => ch(&|a, b| {
            if a == 0.0 {
                return a;
            }
            let tmp = 1.0 - t * b;
            if tmp <= 0.0 { 1.0 } else { (a / tmp).min(1.0) }
        }),
        Blend::Burn => ch(&|a, b| {
            let tmp = tm + t * b;
            if tmp <= 0.0 { 0.0 } else { (1.0 - (1.0 - a) / tmp).clamp(0.0, 1.0) }
        }),
        Blend::Hue => {
            let hsv2 = rgb_to_hsv(c2);
            if hsv2.y != 0.0 {
                let mut hsv = rgb_to_hsv(c1);
                hsv.x = hsv2.x;
                lerp3(c1, hsv_to_rgb(hsv), t)
            } else {
                c1
            }
        }
        Blend::Saturation => {
            let mut hsv = rgb_to_hsv(c1);
            if hsv.y != 0.0 {
                let hsv2 = rgb_to_hsv(c2);
                hsv.y = tm * hsv.y + t * hsv2.y;
                hsv_to_rgb(hsv)
            } else {
                c1
            }
        }
        Blend::Value => {
            let mut hsv = rgb_to_hsv(c1);
            let hsv2 = rgb_to_hsv(c2);
            hsv.z = tm * hsv.z + t * hsv2.z;
            hsv_to_rgb(hsv)
        }
        Blend::Color => {
            let hsv2 = rgb_to_hsv(c2);
            if hsv2.y != 0.0 {
                let mut hsv = rgb_to_hsv(c1);
                hsv.x = hsv2.x;
                hsv.y = hsv2.y;
                lerp3(c1, hsv_to_rgb(hsv), t)
            } else {
                c1
            }
        }
        Blend::SoftLight => {
            let scr = Vec3::ONE - (Vec3::ONE - c2) * (Vec3::ONE - c1);
            tm * c1 + t * ((Vec3::ONE - c1) * c2 * c1 + c1 * scr)
        }
        Blend::LinearLight => c1 + t * (2.0 * c2 - Vec3::ONE),
    }
}

/// Blender's RGB → HSV.
pub fn rgb_to_hsv(rgb: Vec3) -> Vec3 {
    let cmax = rgb.max_element();
    let cmin = rgb.min_element();
    let cdelta = cmax - cmin;
    let v = cmax;
    let (mut h, s);
    if cmax != 0.0 {
        s = cdelta / cmax;
    } else {
        s = 0.0;
    }
    if s != 0.0 {
        let c = (Vec3::splat(cmax) - rgb) / cdelta;
        h = if rgb.x == cmax {
            c.z - c.y
        } else if rgb.y == cmax {
            2.0 + c.x - c.z
        } else {
            4.0 + c.y - c.x
        };
        h /= 6.0;
        if h < 0.0 {
            h += 1.0;
        }
    } else {
        h = 0.0;
    }
    Vec3::new(h, s, v)
}

/// Blender's HSV → RGB.
pub fn hsv_to_rgb(hsv: Vec3) -> Vec3 {
    let (mut h, s, v) = (hsv.x, hsv.y, hsv.z);
    if s == 0.0 {
        return Vec3::splat(v);
    }
    if h == 1.0 {
        h = 0.0;
    }
    h *= 6.0;
    let i = h.floor();
    let f = h - i;
    let p = v * (1.0 - s);
    let q = v * (1.0 - s * f);
    let t = v * (1.0 - s * (1.0 - f));
    match i as i32 {
        0 => Vec3::new(v, t, p),
        1 => Vec3::new(q, v, p),
        2 => Vec3::new(p, v, t),
        3 => Vec3::new(p, q, v),
        4 => Vec3::new(t, p, v),
        _ => Vec3::new(v, p, q),
    }
}

/// Blender's RGB → HSL.
pub fn rgb_to_hsl(rgb: Vec3) -> Vec3 {
    let cmax = rgb.max_element();
    let cmin = rgb.min_element();
    let l = (cmax + cmin) / 2.0;
    if cmax == cmin {
        return Vec3::new(0.0, 0.0, l);
    }
    let d = cmax - cmin;
    let s = if l > 0.5 { d / (2.0 - cmax - cmin) } else { d / (cmax + cmin) };
    let h = if cmax == rgb.x {
        (rgb.y - rgb.z) / d + if rgb.y < rgb.z { 6.0 } else { 0.0 }
    } else if cmax == rgb.y {
        (rgb.z - rgb.x) / d + 2.0
    } else {
        (rgb.x - rgb.y) / d + 4.0
    };
    Vec3::new(h / 6.0, s, l)
}

/// Blender's HSL → RGB.
pub fn hsl_to_rgb(hsl: Vec3) -> Vec3 {
    let (h, s, l) = (hsl.x, hsl.y, hsl.z);
    let nr = (h * 6.0 - 3.0).abs() - 1.0;
    let ng = 2.0 - (h * 6.0 - 2.0).abs();
    let nb = 2.0 - (h * 6.0 - 4.0).abs();
    let n = Vec3::new(nr, ng, nb).clamp(Vec3::ZERO, Vec3::ONE);
    let chroma = (1.0 - (2.0 * l - 1.0).abs()) * s;
    (n - 0.5) * chroma + Vec3::splat(l)
}

/// The Hue/Saturation/Value node.
pub fn hue_sat_val(color: Vec3, hue: f32, sat: f32, val: f32, fac: f32) -> Vec3 {
    let mut hsv = rgb_to_hsv(color);
    let h = hsv.x + hue + 0.5;
    hsv.x = h - h.floor();
    hsv.y = (hsv.y * sat).clamp(0.0, 1.0);
    hsv.z *= val;
    let c = hsv_to_rgb(hsv);
    (c * fac + color * (1.0 - fac)).max(Vec3::ZERO)
}

/// Gamma as Cycles: channels above 0 raised to the power; gamma 0 gives white.
pub fn gamma(c: Vec3, g: f32) -> Vec3 {
    if g == 0.0 {
        return Vec3::ONE;
    }
    let f = |x: f32| if x > 0.0 { x.powf(g) } else { x };
    Vec3::new(f(c.x), f(c.y), f(c.z))
}

/// Bright/Contrast as Cycles.
pub fn bright_contrast(c: Vec3, bright: f32, contrast: f32) -> Vec3 {
    let a = 1.0 + contrast;
    let b = bright - contrast * 0.5;
    (a * c + Vec3::splat(b)).max(Vec3::ZERO)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blends_against_hand_values() {
        let c1 = Vec3::new(0.2, 0.6, 1.0);
        let c2 = Vec3::new(0.5, 0.5, 0.0);
        let near = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 1e-6;
        assert!(near(blend(Blend::Mix, 0.5, c1, c2), Vec3::new(0.35, 0.55, 0.5)));
        assert!(near(blend(Blend::Add, 0.5, c1, c2), Vec3::new(0.45, 0.85, 1.0)));
        assert!(near(blend(Blend::Multiply, 1.0, c1, c2), Vec3::new(0.1, 0.3, 0.0)));
        // Screen at t = 1: 1 - (1 - c2)(1 - c1).
        assert!(near(blend(Blend::Screen, 1.0, c1, c2), Vec3::new(0.6, 0.8, 1.0)));
        // Overlay at t = 1: 2 c1 c2 below 0.5, else 1 - 2 (1 - c2)(1 - c1).
        assert!(near(blend(Blend::Overlay, 1.0, c1, c2), Vec3::new(0.2, 0.6, 1.0)));
        assert!(near(blend(Blend::Divide, 1.0, c1, c2), Vec3::new(0.4, 1.2, 1.0)));
        assert!(near(blend(Blend::LinearLight, 1.0, c1, c2), Vec3::new(0.2, 0.6, 0.0)));
        // Dodge: c1 / (1 - t c2), capped at 1.
        assert!(near(blend(Blend::Dodge, 1.0, c1, c2), Vec3::new(0.4, 1.0, 1.0)));
        // Burn: 1 - (1 - c1) / (tm + t c2), in [0, 1].
        assert!(near(blend(Blend::Burn, 1.0, c1, c2), Vec3::new(0.0, 0.2, 0.0)));
        // Value: V of c2 replaces that of c1 (both have V 0.5 and 1): c1 × 0.5.
        assert!(near(blend(Blend::Value, 1.0, c1, c2), c1 * 0.5));
    }

    #[test]
    fn colour_spaces_round_trip() {
        for c in [Vec3::new(0.2, 0.6, 1.0), Vec3::new(0.9, 0.1, 0.3), Vec3::new(0.5, 0.5, 0.2)] {
            assert!((hsv_to_rgb(rgb_to_hsv(c)) - c).abs().max_element() < 1e-5);
            assert!((hsl_to_rgb(rgb_to_hsl(c)) - c).abs().max_element() < 1e-5);
        }
        // Pure red: hue 0, saturation 1.
        assert_eq!(rgb_to_hsv(Vec3::X), Vec3::new(0.0, 1.0, 1.0));
        // Hue shift by half a turn turns red into cyan.
        let c = hue_sat_val(Vec3::X, 1.0, 1.0, 1.0, 1.0);
        assert!((c - Vec3::new(0.0, 1.0, 1.0)).abs().max_element() < 1e-6, "{c}");
    }
}
