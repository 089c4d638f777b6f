//! Blender's Multiple Scattering (`sky_multiple_scattering.cpp`, after García Liñán).

use super::*;

const GROUND_ALBEDO: f32 = 0.3;
const PHASE_ISOTROPIC: f32 = 1.0 / (4.0 * PI);
const RAYLEIGH_PHASE_SCALE: f32 = (3.0 / 16.0) / PI;
const G: f32 = 0.8;
/// km.
const EARTH_RADIUS: f32 = 6371.0;
const ATMOSPHERE_THICKNESS: f32 = 100.0;
const ATMOSPHERE_RADIUS: f32 = EARTH_RADIUS + ATMOSPHERE_THICKNESS;
const TRANSMITTANCE_STEPS: usize = 64;
const IN_SCATTERING_STEPS: usize = 64;
const RES_X: usize = 256;
const RES_Y: usize = 64;
const SUN_SPECTRAL_IRRADIANCE: Vec4 = Vec4::new(1.679, 1.828, 1.986, 1.307);
const MOLECULAR_SCATTERING_BASE: Vec4 = Vec4::new(6.605e-3, 1.067e-2, 1.842e-2, 3.156e-2);
const OZONE_ABSORPTION_CROSS_SECTION: Vec4 = Vec4::new(3.472e-25, 3.914e-25, 1.349e-25, 11.03e-27);
const OZONE_MEAN_DOBSON: f32 = 334.5;
const AEROSOL_ABSORPTION_CROSS_SECTION: Vec4 = Vec4::new(2.8722e-24, 4.6168e-24, 7.9706e-24, 1.3578e-23);
const AEROSOL_SCATTERING_CROSS_SECTION: Vec4 = Vec4::new(1.5908e-22, 1.7711e-22, 2.0942e-22, 2.4033e-22);
const AEROSOL_BASE_DENSITY: f32 = 1.3681e20;
const AEROSOL_BACKGROUND_DENSITY: f32 = 2e6;
const AEROSOL_HEIGHT_SCALE: f32 = 0.73;
/// The four wavelengths' contributions to X, Y, Z.
const SPECTRAL_XYZ: [Vec3; 4] = [
    Vec3::new(53.386_917, 22.981_337, 0.0),
    Vec3::new(43.904_846, 71.347_8, 0.102_506_87),
    Vec3::new(1.613_727_8, 18.422_96, 31.742_92),
    Vec3::new(20.762_669, 2.361_421_3, 110.480_095),
];

fn exp4(v: Vec4) -> Vec4 {
    Vec4::new(v.x.exp(), v.y.exp(), v.z.exp(), v.w.exp())
}

fn spectral_to_xyz(l: Vec4) -> Vec3 {
    SPECTRAL_XYZ[0] * l.x + SPECTRAL_XYZ[1] * l.y + SPECTRAL_XYZ[2] * l.z + SPECTRAL_XYZ[3] * l.w
}

fn sun_direction(cos_theta: f32) -> Vec3 {
    Vec3::new(-(1.0 - cos_theta * cos_theta).sqrt(), 0.0, cos_theta)
}

/// Distance to a sphere about the origin (−1: missed or behind), Blender's branches.
fn ray_sphere_intersection(pos: Vec3, dir: Vec3, radius: f32) -> f32 {
    let b = pos.dot(dir);
    let c = pos.dot(pos) - radius * radius;
    if c > 0.0 && b > 0.0 {
        return -1.0;
    }
    let d = b * b - c;
    if d < 0.0 {
        return -1.0;
    }
    if d >= b * b { -b + d.sqrt() } else { -b - d.sqrt() }
}

/// Elevation (radians, positive) of the horizon's dip seen from `altitude` metres.
pub fn earth_intersection_angle(altitude: f32) -> f32 {
    FRAC_PI_2 - (EARTH_RADIUS / (EARTH_RADIUS + altitude / 1000.0)).asin()
}

/// The atmosphere with its density multipliers and transmittance table.
pub struct Atmosphere {
    air: f32,
    aerosol: f32,
    ozone: f32,
    lut: Vec<Vec4>,
}

impl Atmosphere {
    /// The atmosphere and its 256 × 64 transmittance table (cos θ of the sun × altitude).
    pub fn new(air: f32, aerosol: f32, ozone: f32) -> Atmosphere {
        let mut a = Atmosphere { air, aerosol, ozone, lut: Vec::new() };
        let mut lut = vec![Vec4::ZERO; RES_X * RES_Y];
        for y in 0..RES_Y {
            for x in 0..RES_X {
                let (u, v) = (x as f32 / (RES_X - 1) as f32, y as f32 / (RES_Y - 1) as f32);
                lut[y * RES_X + x] = a.transmittance(u * 2.0 - 1.0, v);
            }
        }
        a.lut = lut;
        a
    }

    /// Absorption and scattering of aerosols and molecules at `altitude` km:
    /// (aerosol absorption, aerosol scattering, molecular absorption, molecular scattering).
    fn coefficients(&self, altitude: f32) -> (Vec4, Vec4, Vec4, Vec4) {
        let aerosol = AEROSOL_BASE_DENSITY
            * ((-altitude / AEROSOL_HEIGHT_SCALE).exp() + AEROSOL_BACKGROUND_DENSITY / AEROSOL_BASE_DENSITY)
            * self.aerosol;
        let log_h = altitude.max(1e-4).ln();
        let ozone_density = 3.785_474e20 * (-(log_h - 3.22261) * (log_h - 3.22261) * 5.555_555_5 - log_h).exp();
        let molecular_absorption = OZONE_ABSORPTION_CROSS_SECTION * OZONE_MEAN_DOBSON * ozone_density * self.ozone;
        let molecular_scattering =
            MOLECULAR_SCATTERING_BASE * (-0.077_719_71 * altitude.powf(1.163_642_4)).exp() * self.air;
        (
            AEROSOL_ABSORPTION_CROSS_SECTION * aerosol,
            AEROSOL_SCATTERING_CROSS_SECTION * aerosol,
            molecular_absorption,
            molecular_scattering,
        )
    }

    fn extinction(&self, altitude: f32) -> (Vec4, Vec4, Vec4) {
        let (aa, a_s, ma, ms) = self.coefficients(altitude);
        (aa + a_s + ma + ms, a_s, ms)
    }

    /// Transmittance from a normalised altitude toward a sun at cos θ (marched).
    fn transmittance(&self, cos_theta: f32, normalized_altitude: f32) -> Vec4 {
        let sun = sun_direction(cos_theta);
        let r = EARTH_RADIUS + normalized_altitude * (ATMOSPHERE_RADIUS - EARTH_RADIUS);
        let origin = Vec3::new(0.0, 0.0, r);
        let t_d = ray_sphere_intersection(origin, sun, ATMOSPHERE_RADIUS);
        let step = t_d / TRANSMITTANCE_STEPS as f32;
        let mut depth = Vec4::ZERO;
        for i in 0..TRANSMITTANCE_STEPS {
            let x = origin + sun * ((i as f32 + 0.5) * step);
            let altitude = (x.length() - EARTH_RADIUS).max(0.0);
            depth += self.extinction(altitude).0 * step;
        }
        exp4(-depth)
    }

    fn lut_at(&self, x: usize, y: usize) -> Vec4 {
        self.lut[y * RES_X + x]
    }

    fn lookup(&self, cos_theta: f32, normalized_altitude: f32) -> Vec4 {
        let x = (RES_X - 1) as f32 * (cos_theta * 0.5 + 0.5).clamp(0.0, 1.0);
        let y = (RES_Y - 1) as f32 * normalized_altitude.clamp(0.0, 1.0);
        let (x1, y1) = (x as usize, y as usize);
        let (x2, y2) = ((x1 + 1).min(RES_X - 1), (y1 + 1).min(RES_Y - 1));
        let (fx, fy) = (x - x1 as f32, y - y1 as f32);
        let bottom = self.lut_at(x1, y1).lerp(self.lut_at(x2, y1), fx);
        let top = self.lut_at(x1, y2).lerp(self.lut_at(x2, y2), fx);
        bottom.lerp(top, fy)
    }

    /// Multiple scattering: the ground's second order and the fitted rest.
    fn multiscattering(&self, cos_theta: f32, normalized_height: f32, d: f32) -> Vec4 {
        let ratio = EARTH_RADIUS / d;
        let omega = 2.0 * PI * (1.0 - (1.0 - ratio * ratio).sqrt());
        let to_ground = self.lookup(cos_theta, 0.0);
        let ground_to_sample = self.lookup(1.0, 0.0) / self.lookup(1.0, normalized_height);
        let ground = PHASE_ISOTROPIC * omega * (GROUND_ALBEDO / PI) * to_ground * ground_to_sample * cos_theta;
        let ms = 0.02 * Vec4::new(0.217, 0.347, 0.594, 1.0) * (1.0 / (1.0 + 5.0 * (-17.92 * cos_theta).exp()));
        ms + ground
    }

    /// In-scattered spectral radiance along a ray of length `t_d` km.
    fn inscattering(&self, sun: Vec3, origin: Vec3, dir: Vec3, t_d: f32) -> Vec4 {
        let cos_theta = (-dir).dot(sun);
        let molecular_phase = RAYLEIGH_PHASE_SCALE * (1.0 + cos_theta * cos_theta);
        let den = 1.0 + G * G + 2.0 * G * cos_theta;
        let aerosol_phase = PHASE_ISOTROPIC * (1.0 - G * G) / (den * den.sqrt());
        let dt = t_d / IN_SCATTERING_STEPS as f32;
        let mut l = Vec4::ZERO;
        let mut transmittance = Vec4::ONE;
        for i in 0..IN_SCATTERING_STEPS {
            let x = origin + dir * ((i as f32 + 0.5) * dt);
            let d = x.length();
            let zenith = x / d;
            let altitude = (d - EARTH_RADIUS).max(0.0);
            let na = altitude / ATMOSPHERE_THICKNESS;
            let sample_cos = zenith.dot(sun);
            let (extinction, aerosol_scattering, molecular_scattering) = self.extinction(altitude);
            let to_sun = self.lookup(sample_cos, na);
            let ms = self.multiscattering(sample_cos, na, d);
            let s = SUN_SPECTRAL_IRRADIANCE
                * (molecular_scattering * (molecular_phase * to_sun + ms)
                    + aerosol_scattering * (aerosol_phase * to_sun + ms));
            let step_t = exp4(-dt * extinction);
            // Energy-conserving integration over the step (Hillaire).
            let s_int = (s - s * step_t) / extinction.max(Vec4::splat(1e-7));
            l += transmittance * s_int;
            transmittance *= step_t;
        }
        l
    }

    /// The XYZ table: rows at elevation π/2 · l|l|, l = 2 (y + ½)/h − 1.
    pub fn table(&self, elevation: f32, altitude: f32) -> Vec<Vec3> {
        use rayon::prelude::*;
        let altitude = altitude.clamp(1.0, 99999.0) / 1000.0;
        let (w, h) = (TABLE_WIDTH, TABLE_HEIGHT);
        let sun = sun_direction((FRAC_PI_2 - elevation).cos());
        let origin = Vec3::new(0.0, 0.0, EARTH_RADIUS + altitude);
        let mut table = vec![Vec3::ZERO; w * h];
        table.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for x in 0..w / 2 {
                let (u, v) = ((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
                let azimuth = 2.0 * PI * u;
                let l = v * 2.0 - 1.0;
                let e = (l * l).copysign(l) * FRAC_PI_2;
                let dir = Vec3::new(e.cos() * azimuth.cos(), e.cos() * azimuth.sin(), e.sin());
                let atmosphere = ray_sphere_intersection(origin, dir, ATMOSPHERE_RADIUS);
                let ground = ray_sphere_intersection(origin, dir, EARTH_RADIUS);
                let t_d = if ground < 0.0 { atmosphere } else { ground };
                mirror_row(row, x, spectral_to_xyz(self.inscattering(sun, origin, dir, t_d)));
            }
        });
        table
    }

    /// The disc's XYZ at its lowest and highest point.
    pub fn sun(&self, elevation: f32, diameter: f32, altitude: f32) -> (Vec3, Vec3) {
        let altitude = altitude.clamp(1.0, 99999.0) / 1000.0;
        let half = diameter / 2.0;
        let solid_angle = 2.0 * PI * (1.0 - half.cos());
        let na = altitude / ATMOSPHERE_THICKNESS;
        let xyz = |e: f32| {
            let t = self.transmittance((FRAC_PI_2 - e).cos(), na);
            spectral_to_xyz(SUN_SPECTRAL_IRRADIANCE * t / solid_angle)
        };
        (xyz(elevation - half), xyz(elevation + half))
    }
}
