//! Hosek & Wilkie's configuration for a sun elevation, turbidity and ground albedo, from their
//! published CIE XYZ coefficients (`hosek_xyz.txt`, BSD licence, read once).
//!
//! The dataset holds, per channel, albedo (0 and 1) and integer turbidity (1..10), six
//! control points of a quintic Bézier curve over (elevation / (π/2))^(1/3), for the nine
//! parameters and for the radiance scale. A configuration is the curve at the sun's
//! elevation, blended linearly between the two albedos and the two nearest turbidities.
//! In f64, as Cycles cooks it, then stored as f32 as Cycles hands it to its kernel.

use std::sync::OnceLock;

/// The dataset's text: every number after the licence header, in the layout it describes.
const DATA: &str = include_str!("hosek_xyz.txt");
/// Numbers per channel: 2 albedos × 10 turbidities × (6 control points × 9 parameters), then
/// 2 × 10 × 6 for the radiance.
const CONFIG_LEN: usize = 2 * 10 * 6 * 9;
const RADIANCE_LEN: usize = 2 * 10 * 6;
const CHANNEL_LEN: usize = CONFIG_LEN + RADIANCE_LEN;

/// The dataset as numbers (3 channels of `CHANNEL_LEN`).
fn dataset() -> &'static [f64] {
    static DATA_SET: OnceLock<Vec<f64>> = OnceLock::new();
    DATA_SET.get_or_init(|| {
        let numbers: Vec<f64> = DATA
            .lines()
            .filter(|l| !l.starts_with('#'))
            .flat_map(str::split_whitespace)
            .map(|s| s.parse().expect("hosek_xyz.txt holds numbers only (checked by its test)"))
            .collect();
        assert_eq!(numbers.len(), 3 * CHANNEL_LEN, "hosek_xyz.txt's size (checked by its test)");
        numbers
    })
}

/// The quintic Bézier curve through six control points `stride` apart, at `t`.
fn bezier5(points: &[f64], stride: usize, t: f64) -> f64 {
    let s = 1.0 - t;
    const BINOMIAL: [f64; 6] = [1.0, 5.0, 10.0, 10.0, 5.0, 1.0];
    (0..6).map(|k| BINOMIAL[k] * s.powi(5 - k as i32) * t.powi(k as i32) * points[k * stride]).sum()
}

/// A block's value (parameter `param` of `width` per control point) blended over albedo and
/// turbidity: `block(albedo_index, turbidity_index)` is the start of that block.
fn blend(table: &[f64], width: usize, param: usize, turbidity: f64, albedo: f64, t: f64) -> f64 {
    let block = |a: usize, turb: usize| &table[(a * 10 + turb) * 6 * width + param..];
    let low = (turbidity as usize).clamp(1, 10);
    let rem = turbidity - low as f64;
    let at = |turb: usize| {
        (1.0 - albedo) * bezier5(block(0, turb - 1), width, t) + albedo * bezier5(block(1, turb - 1), width, t)
    };
    let mut v = (1.0 - rem) * at(low);
    // At turbidity 10 there is no higher row (and the remainder is 0).
    if low < 10 {
        v += rem * at(low + 1);
    }
    v
}

/// The per-channel radiance scale and nine parameters for a sun `elevation` (radians, ≥ 0),
/// `turbidity` in [1, 10] and `albedo` in [0, 1].
pub fn configuration(turbidity: f32, albedo: f32, elevation: f32) -> ([f32; 3], [[f32; 9]; 3]) {
    let data = dataset();
    let (turbidity, albedo) = (f64::from(turbidity), f64::from(albedo));
    let t = (f64::from(elevation) / std::f64::consts::FRAC_PI_2).powf(1.0 / 3.0);
    let channel = |c: usize| &data[c * CHANNEL_LEN..(c + 1) * CHANNEL_LEN];
    let scale = std::array::from_fn(|c| blend(&channel(c)[CONFIG_LEN..], 1, 0, turbidity, albedo, t) as f32);
    let config = std::array::from_fn(|c| {
        std::array::from_fn(|p| blend(&channel(c)[..CONFIG_LEN], 9, p, turbidity, albedo, t) as f32)
    });
    (scale, config)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_dataset_parses_whole_with_its_published_ends() {
        let d = dataset();
        assert_eq!(d.len(), 3600);
        // First and last numbers of X's configuration and of Z's radiance, as published.
        assert_eq!(d[0], -1.117001);
        assert_eq!(d[CONFIG_LEN - 1], 0.6232887);
        assert_eq!(d[2 * CHANNEL_LEN + CONFIG_LEN], 1.168084);
        assert_eq!(d[3 * CHANNEL_LEN - 1], 31.10255);
    }

    #[test]
    fn at_a_control_point_the_configuration_is_that_point() {
        // Elevation 0 is t = 0: the curve's first control point; albedo 0, turbidity 1.
        let (scale, config) = configuration(1.0, 0.0, 0.0);
        assert_eq!(config[0][0], -1.117001f64 as f32);
        assert_eq!(scale[0], 1.560219f64 as f32);
        // The zenith sun (t = 1 but for π/2's rounding to f32, 3e-8) with albedo 1,
        // turbidity 10: the last points of each block.
        let (scale, config) = configuration(10.0, 1.0, std::f32::consts::FRAC_PI_2);
        assert!((config[2][8] - 0.6791814).abs() < 1e-6, "{}", config[2][8]);
        assert!((scale[2] - 31.10255).abs() < 1e-5, "{}", scale[2]);
    }
}
