//! Blackbody emission as Cycles computes it for the Principled Volume: the colour of a
//! temperature from Cycles' piecewise fit (`svm_math_blackbody_color_rec709`, the table
//! in `kernel/tables.h`), converted from Rec.709 into the scene's working space as Cycles'
//! `rec709_to_rgb` does, and the Stefan-Boltzmann intensity the node scales it by.

use crate::math::Rgb;
use crate::scene::working_space::WorkingSpace;

/// Below this a closure's weight is dropped, as Cycles' `CLOSURE_WEIGHT_CUTOFF`.
pub const CLOSURE_WEIGHT_CUTOFF: f32 = 1e-5;

/// Cycles' fit of R = a/T + b·T + c per temperature band (the table's data).
#[allow(clippy::excessive_precision)]
const TABLE_R: [[f32; 3]; 7] = [
    [1.61919106e+03, -2.05010916e-03, 5.02995757e+00],
    [2.48845471e+03, -1.11330907e-03, 3.22621544e+00],
    [3.34143193e+03, -4.86551192e-04, 1.76486769e+00],
    [4.09461742e+03, -1.27446582e-04, 7.25731635e-01],
    [4.67028036e+03, 2.91258199e-05, 1.26703442e-01],
    [4.59509185e+03, 2.87495649e-05, 1.50345020e-01],
    [3.78717450e+03, 9.35907826e-06, 3.99075871e-01],
];

/// G = a/T + b·T + c per band.
#[allow(clippy::excessive_precision)]
const TABLE_G: [[f32; 3]; 7] = [
    [-4.88999748e+02, 6.04330754e-04, -7.55807526e-02],
    [-7.55994277e+02, 3.16730098e-04, 4.78306139e-01],
    [-1.02363977e+03, 1.20223470e-04, 9.36662319e-01],
    [-1.26571316e+03, 4.87340896e-06, 1.27054498e+00],
    [-1.42529332e+03, -4.01150431e-05, 1.43972784e+00],
    [-1.17554822e+03, -2.16378048e-05, 1.30408023e+00],
    [-5.00799571e+02, -4.59832026e-06, 1.09098763e+00],
];

/// B = ((a·T + b)·T + c)·T + d per band.
#[allow(clippy::excessive_precision)]
const TABLE_B: [[f32; 4]; 7] = [
    [5.96945309e-11, -4.85742887e-08, -9.70622247e-05, -4.07936148e-03],
    [2.40430366e-11, 5.55021075e-08, -1.98503712e-04, 2.89312858e-02],
    [-1.40949732e-11, 1.89878968e-07, -3.56632824e-04, 9.10767778e-02],
    [-3.61460868e-11, 2.84822009e-07, -4.93211319e-04, 1.56723440e-01],
    [-1.97075738e-11, 1.75359352e-07, -2.50542825e-04, -2.22783266e-02],
    [-1.61997957e-13, -1.64216008e-08, 3.86216271e-04, -7.38077418e-01],
    [6.72650283e-13, -2.73078809e-08, 4.24098264e-04, -7.52335691e-01],
];

/// Lower band edges (kelvin) of the table's rows 1..6.
const BANDS: [f32; 6] = [965.0, 1167.0, 1449.0, 1902.0, 3315.0, 6365.0];

/// Rec.709 colour of a blackbody at `t` kelvin, unclamped (it may be negative outside the
/// gamut), constant below 800 K and above 12000 K, as Cycles' fit.
#[allow(clippy::excessive_precision)]
pub fn blackbody_rgb(t: f32) -> Rgb {
    if t >= 12000.0 {
        return Rgb::new(0.826_295_5, 0.994_508_05, 1.566_307_7);
    }
    if !(t >= 800.0) {
        return Rgb::new(5.413_294_5, -0.203_193_9, -0.082_253_52);
    }
    let i = BANDS.iter().take_while(|&&edge| t >= edge).count();
    let (r, g, b) = (TABLE_R[i], TABLE_G[i], TABLE_B[i]);
    let inv = 1.0 / t;
    Rgb::new(r[0] * inv + r[1] * t + r[2], g[0] * inv + g[1] * t + g[2], ((b[0] * t + b[1]) * t + b[2]) * t + b[3])
}

/// Emitted radiance per unit length of the Principled Volume's blackbody term at
/// temperature `t` (kelvin): σ/π · lerp(1, T⁴, intensity) × colour × tint, with Cycles'
/// σ = 5.670373e-8 · 1e-6 (its unit scale); zero when the intensity is under
/// [`CLOSURE_WEIGHT_CUTOFF`] or `blackbody_intensity` is. The colour is in `space` (not
/// clamped: Cycles keeps the negative channels there too).
pub fn blackbody_emission(t: f32, blackbody_intensity: f32, tint: Rgb, space: &WorkingSpace) -> Rgb {
    if !(blackbody_intensity > CLOSURE_WEIGHT_CUTOFF) {
        return Rgb::ZERO;
    }
    let intensity = blackbody_scale(t.max(0.0), blackbody_intensity);
    if !(intensity > CLOSURE_WEIGHT_CUTOFF) {
        return Rgb::ZERO;
    }
    tint * intensity * space.from_rec709(blackbody_rgb(t.max(0.0)))
}

/// σ/π · lerp(1, T⁴, intensity): increasing in `t` for a positive intensity, so a
/// temperature bound gives an intensity bound (the majorant grid reads it so).
#[inline]
pub fn blackbody_scale(t: f32, blackbody_intensity: f32) -> f32 {
    let sigma = 5.670373e-8 * 1e-6 / std::f32::consts::PI;
    let t4 = (t * t) * (t * t);
    sigma * (1.0 + (t4 - 1.0) * blackbody_intensity)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fit is continuous across its bands to within its own fitting error (a few
    /// thousandths: the bands were fitted separately) and white-ish at 6500 K.
    #[test]
    fn fit_is_continuous_and_daylight_is_neutral() {
        for &edge in &BANDS {
            let (a, b) = (blackbody_rgb(edge - 0.01), blackbody_rgb(edge));
            assert!((a - b).abs().max_element() < 0.02, "jump at {edge} K: {a} vs {b}");
        }
        let d65 = blackbody_rgb(6500.0);
        assert!((d65.x - d65.z).abs() < 0.1 && (d65.y - 1.0).abs() < 0.1, "6500 K is {d65}");
        let ember = blackbody_rgb(1500.0);
        assert!(ember.x > ember.y && ember.y > ember.z, "1500 K is red-orange: {ember}");
    }

    /// Cold voxels emit nothing (the cutoff), hot ones by T⁴.
    #[test]
    fn intensity_follows_stefan_boltzmann() {
        assert_eq!(blackbody_emission(0.0, 1.0, Rgb::ONE, &WorkingSpace::default()), Rgb::ZERO);
        let (a, b) = (blackbody_scale(1000.0, 1.0), blackbody_scale(2000.0, 1.0));
        assert!((b / a - 16.0).abs() < 1e-3);
        assert!(blackbody_emission(1500.0, 1.0, Rgb::ONE, &WorkingSpace::default()).x > 0.0);
    }
}
