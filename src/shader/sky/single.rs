//! Blender's Single Scattering (`sky_single_scattering.cpp`).

use super::*;

const RAYLEIGH_SCALE: f32 = 8e3;
const MIE_SCALE: f32 = 1.2e3;
const MIE_COEFF: f32 = 2e-5;
const MIE_G: f32 = 0.76;
const EARTH_RADIUS: f32 = 6360e3;
const ATMOSPHERE_RADIUS: f32 = 6420e3;
const STEPS: usize = 32;
const NUM_WAVELENGTHS: usize = 21;
/// (780 − 380) / 20 nm.
const STEP_LAMBDA: f32 = 20.0;
/// Sun irradiance on top of the atmosphere (W m⁻² nm⁻¹).
const IRRADIANCE: [f32; NUM_WAVELENGTHS] = [
    1.457_568_3,
    1.565_963_1,
    1.651_484_5,
    1.714_962_4,
    1.757_979_8,
    1.782_564,
    1.790_951_1,
    1.785_415_5,
    1.768_155_5,
    1.741_220_7,
    1.706_471_3,
    1.665_560_9,
    1.619_934_4,
    1.570_836,
    1.519_323_4,
    1.466_284_9,
    1.412_458_5,
    1.358_449_6,
    1.304_749_1,
    1.251_749_6,
    1.199_76,
];
/// Rayleigh scattering coefficient (m⁻¹).
const RAYLEIGH_COEFF: [f32; NUM_WAVELENGTHS] = [
    5.424_82e-5,
    4.418_55e-5,
    3.635_152e-5,
    3.017_929e-5,
    2.526_320_2e-5,
    2.130_859_3e-5,
    1.809_838e-5,
    1.547_057e-5,
    1.330_285e-5,
    1.150_184_8e-5,
    9.995_574e-6,
    8.728e-6,
    7.655_137e-6,
    6.742_172e-6,
    5.961_341_3e-6,
    5.290_346e-6,
    4.711_157e-6,
    4.209_105e-6,
    3.772_183_8e-6,
    3.390_512_6e-6,
    3.055_915_4e-6,
];
/// Ozone absorption coefficient (m⁻¹).
const OZONE_COEFF: [f32; NUM_WAVELENGTHS] = [
    3.251_268_5e-9,
    5.853_953_6e-9,
    1.977_191_2e-8,
    7.309_569e-8,
    2.008_456_2e-7,
    4.038_396e-7,
    6.355_134e-7,
    9.670_704e-7,
    1.547_974e-6,
    2.090_386_5e-6,
    2.461_280_6e-6,
    2.735_513e-6,
    2.151_258_6e-6,
    1.590_518_4e-6,
    1.123_562e-6,
    7.352_755e-7,
    4.645_013e-7,
    3.309_608e-7,
    2.251_261_3e-7,
    1.487_913e-7,
    1.682_862_3e-7,
];
/// CIE 1931 colour matching functions at the 21 wavelengths.
const CMF_XYZ: [[f32; 3]; NUM_WAVELENGTHS] = [
    [0.001_368, 0.000_039, 0.006_450_001],
    [0.014_31, 0.000_396, 0.067_850_01],
    [0.134_38, 0.004, 0.645_6],
    [0.348_28, 0.023, 1.747_06],
    [0.290_8, 0.06, 1.669_2],
    [0.095_64, 0.139_02, 0.812_950_1],
    [0.004_9, 0.323, 0.272],
    [0.063_27, 0.71, 0.078_249_99],
    [0.290_4, 0.954, 0.020_3],
    [0.594_5, 0.995, 0.003_9],
    [0.916_3, 0.87, 0.001_650_001],
    [1.062_2, 0.631, 0.000_8],
    [0.854_449_9, 0.381, 0.000_19],
    [0.447_9, 0.175, 0.000_02],
    [0.164_9, 0.061, 0.0],
    [0.046_77, 0.017, 0.0],
    [0.011_359_16, 0.004_102, 0.0],
    [0.002_899_327, 0.001_047, 0.0],
    [0.000_690_078_6, 0.000_249_2, 0.0],
    [0.000_166_150_5, 0.000_06, 0.0],
    [0.000_041_509_94, 0.000_014_99, 0.0],
];
/// Gauss–Laguerre nodes (n = 8, scaled so the last stays inside the atmosphere) and
/// weights with the exp(x) factor folded in.
const QUADRATURE_NODES: [f32; 8] =
    [0.006_811_185, 0.036_148_07, 0.090_043_46, 0.170_668, 0.281_836_2, 0.430_340_64, 0.629_627_1, 0.914_525_3];
const QUADRATURE_WEIGHTS: [f32; 8] =
    [0.017_508_936, 0.041_354_774, 0.066_788_39, 0.095_076_99, 0.128_341_64, 0.170_743_02, 0.232_723_34, 0.356_249_05];

fn geographical_to_direction(lat: f32, lon: f32) -> Vec3 {
    Vec3::new(lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin())
}

fn spec_to_xyz(s: &[f32; NUM_WAVELENGTHS]) -> Vec3 {
    let mut xyz = Vec3::ZERO;
    for (c, v) in CMF_XYZ.iter().zip(s) {
        xyz += Vec3::from(*c) * *v;
    }
    xyz * STEP_LAMBDA
}

/// Rayleigh, Mie and ozone densities at a height (m).
fn densities(h: f32) -> Vec3 {
    let ozone = (1.0 - ((h as f64 - 25000.0).abs() / 15000.0)).max(0.0) as f32;
    Vec3::new((-h / RAYLEIGH_SCALE).exp(), (-h / MIE_SCALE).exp(), ozone)
}

fn phase_rayleigh(mu: f32) -> f32 {
    (0.1875 / PI) * (1.0 + mu * mu)
}

fn phase_mie(mu: f32) -> f32 {
    let g2 = MIE_G * MIE_G;
    (3.0 * (1.0 - g2) * (1.0 + mu * mu)) / (8.0 * PI * (2.0 + g2) * (1.0 + g2 - 2.0 * MIE_G * mu).powf(1.5))
}

fn surface_intersection(pos: Vec3, dir: Vec3) -> bool {
    if dir.z >= 0.0 {
        return false;
    }
    let b = -2.0 * dir.dot(-pos);
    let c = pos.length_squared() - EARTH_RADIUS * EARTH_RADIUS;
    b * b - 4.0 * c >= 0.0
}

fn atmosphere_intersection(pos: Vec3, dir: Vec3) -> Vec3 {
    let b = -2.0 * dir.dot(-pos);
    let c = pos.length_squared() - ATMOSPHERE_RADIUS * ATMOSPHERE_RADIUS;
    let t = (-b + (b * b - 4.0 * c).sqrt()) / 2.0;
    pos + dir * t
}

/// Optical depth factors (Rayleigh, Mie, ozone) from `origin` out of the atmosphere.
fn ray_optical_depth(origin: Vec3, dir: Vec3) -> Vec3 {
    let end = atmosphere_intersection(origin, dir);
    let length = origin.distance(end);
    let segment = dir * length;
    let mut depth = Vec3::ZERO;
    for (n, w) in QUADRATURE_NODES.iter().zip(QUADRATURE_WEIGHTS) {
        let p = origin + segment * *n;
        depth += densities(p.length() - EARTH_RADIUS) * w;
    }
    depth * length
}

/// In-scattered spectrum along `dir` from `origin`.
fn scattering(dir: Vec3, sun: Vec3, origin: Vec3, scale: Vec3, out: &mut [f32; NUM_WAVELENGTHS]) {
    let end = atmosphere_intersection(origin, dir);
    let seg_len = origin.distance(end) / STEPS as f32;
    let segment = dir * seg_len;
    let mut depth = Vec3::ZERO;
    *out = [0.0; NUM_WAVELENGTHS];
    let mu = dir.dot(sun);
    let phase = Vec3::new(phase_rayleigh(mu), phase_mie(mu), 0.0);
    let mut p = origin + segment * 0.5;
    for _ in 0..STEPS {
        let density = scale * densities(p.length() - EARTH_RADIUS);
        depth += density * seg_len;
        if !surface_intersection(p, sun) {
            let total = depth + scale * ray_optical_depth(p, sun);
            for wl in 0..NUM_WAVELENGTHS {
                let ext = total * Vec3::new(RAYLEIGH_COEFF[wl], 1.11 * MIE_COEFF, OZONE_COEFF[wl]);
                let attenuation = (-(ext.x + ext.y + ext.z)).exp();
                let scatter = density * Vec3::new(RAYLEIGH_COEFF[wl], MIE_COEFF, 0.0);
                let s = phase * scatter;
                out[wl] += attenuation * (s.x + s.y + s.z) * IRRADIANCE[wl] * seg_len;
            }
        }
        p += segment;
    }
}

/// The XYZ table: upper half only (rows at latitude π/2 (y / (h/2) − 1)²).
pub fn table(elevation: f32, altitude: f32, air: f32, aerosol: f32, ozone: f32) -> Vec<Vec3> {
    use rayon::prelude::*;
    let altitude = altitude.clamp(1.0, 59999.0);
    let (w, h) = (TABLE_WIDTH, TABLE_HEIGHT);
    let (half_w, half_h) = (w / 2, h / 2);
    let cam = Vec3::new(0.0, 0.0, EARTH_RADIUS + altitude);
    let sun = geographical_to_direction(elevation, 0.0);
    let step = 2.0 * PI / w as f32;
    let scale = Vec3::new(air, aerosol, ozone);
    let mut table = vec![Vec3::ZERO; w * h];
    table.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        if y <= half_h {
            return;
        }
        let t = y as f32 / half_h as f32 - 1.0;
        let latitude = FRAC_PI_2 * t * t;
        let mut spectrum = [0.0f32; NUM_WAVELENGTHS];
        for x in 0..half_w {
            let dir = geographical_to_direction(latitude, step * x as f32 - PI);
            scattering(dir, sun, cam, scale, &mut spectrum);
            mirror_row(row, x, spec_to_xyz(&spectrum));
        }
    });
    table
}

/// The disc's XYZ at its lowest and highest point (black below the horizon).
pub fn sun(elevation: f32, diameter: f32, altitude: f32, air: f32, aerosol: f32) -> (Vec3, Vec3) {
    let altitude = altitude.clamp(1.0, 59999.0);
    let half = diameter / 2.0;
    let solid_angle = 2.0 * PI * (1.0 - half.cos());
    let (bottom, top) = ((elevation - half).max(0.0), (elevation + half).max(0.0));
    if top <= 0.0 {
        return (Vec3::ZERO, Vec3::ZERO);
    }
    let radiation = |e: f32| {
        let cam = Vec3::new(0.0, 0.0, EARTH_RADIUS + altitude);
        let depth = ray_optical_depth(cam, geographical_to_direction(e, 0.0));
        let mut s = [0.0f32; NUM_WAVELENGTHS];
        for (i, v) in s.iter_mut().enumerate() {
            let t = RAYLEIGH_COEFF[i] * depth.x * air + 1.11 * MIE_COEFF * depth.y * aerosol;
            *v = IRRADIANCE[i] * (-t).exp() / solid_angle;
        }
        spec_to_xyz(&s)
    };
    (radiation(bottom), radiation(top))
}
