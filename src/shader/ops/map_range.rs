//! The Map Range node as Cycles computes it (`kernel/svm/map_range.h`).

use super::math::safe_divide;

/// Map Range interpolations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(missing_docs)]
pub enum RangeInterp {
    Linear,
    Stepped,
    SmoothStep,
    SmootherStep,
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    if x <= e0 {
        0.0
    } else if x >= e1 {
        1.0
    } else {
        let t = (x - e0) / (e1 - e0);
        (3.0 - 2.0 * t) * t * t
    }
}

fn smootherstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = safe_divide(x - e0, e1 - e0).clamp(0.0, 1.0);
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// The float Map Range node (Cycles' `svm_node_map_range`).
#[allow(clippy::too_many_arguments)]
pub fn map_range(
    interp: RangeInterp,
    value: f32,
    from_min: f32,
    from_max: f32,
    to_min: f32,
    to_max: f32,
    steps: f32,
    clamp: bool,
) -> f32 {
    let factor = match interp {
        RangeInterp::Linear => safe_divide(value - from_min, from_max - from_min),
        RangeInterp::Stepped => {
            let f = safe_divide(value - from_min, from_max - from_min);
            if steps > 0.0 { (f * (steps + 1.0)).floor() / steps } else { 0.0 }
        }
        RangeInterp::SmoothStep => {
            if from_min > from_max {
                1.0 - smoothstep(from_max, from_min, value)
            } else {
                smoothstep(from_min, from_max, value)
            }
        }
        RangeInterp::SmootherStep => {
            if from_min > from_max {
                1.0 - smootherstep(from_max, from_min, value)
            } else {
                smootherstep(from_min, from_max, value)
            }
        }
    };
    let mut r = to_min + factor * (to_max - to_min);
    if clamp && matches!(interp, RangeInterp::Linear | RangeInterp::Stepped) {
        r = if to_min > to_max { r.clamp(to_max, to_min) } else { r.clamp(to_min, to_max) };
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_range_against_hand_values() {
        use RangeInterp::*;
        assert_eq!(map_range(Linear, 0.25, 0.0, 1.0, 10.0, 20.0, 4.0, true), 12.5);
        assert_eq!(map_range(Linear, 2.0, 0.0, 1.0, 10.0, 20.0, 4.0, true), 20.0);
        assert_eq!(map_range(Linear, 2.0, 0.0, 1.0, 10.0, 20.0, 4.0, false), 30.0);
        // Stepped with 4 steps: floor(0.3 × 5) / 4 = 0.25.
        assert_eq!(map_range(Stepped, 0.3, 0.0, 1.0, 0.0, 1.0, 4.0, false), 0.25);
        // Smoothstep at 0.25: 3t² - 2t³ = 0.15625.
        assert!((map_range(SmoothStep, 0.25, 0.0, 1.0, 0.0, 1.0, 0.0, false) - 0.15625).abs() < 1e-6);
        // Smootherstep at 0.25: 6t⁵ - 15t⁴ + 10t³ = 0.103515625.
        assert!((map_range(SmootherStep, 0.25, 0.0, 1.0, 0.0, 1.0, 0.0, false) - 0.103_515_63).abs() < 1e-6);
    }
}
