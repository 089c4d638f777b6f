//! The pure functions of Blender's converter nodes, as Cycles computes them
//! (`kernel/svm/math_util.h`, `color_util.h`, `map_range.h`, `util/color.h`): Math and
//! Vector Math (every operation, with Cycles' "safe" variants), the colour blend modes,
//! Map Range, colour-space conversions (HSV, HSL), Hue/Saturation/Value, Wavelength.

//!
//! One file per family; the names are re-exported here so callers write `ops::math`,
//! `ops::blend`, `ops::MathOp`.

mod colour;
mod map_range;
mod math;
mod vector;
mod wavelength;

pub use colour::{Blend, blend, bright_contrast, gamma, hsl_to_rgb, hsv_to_rgb, hue_sat_val, rgb_to_hsl, rgb_to_hsv};
pub use map_range::{RangeInterp, map_range};
pub use math::{
    MathOp, compatible_signf, math, math_lanes, pingpongf, safe_divide, safe_floored_modulo, safe_logf, safe_modulo,
    safe_powf, smoothminf, wrapf,
};
pub use vector::{VecOp, rotate_around_axis, safe_normalize, vector_math};
pub use wavelength::wavelength_to_rgb;
