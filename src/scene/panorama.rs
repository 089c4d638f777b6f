//! Panoramic cameras as Cycles renders them (`intern/cycles/kernel/camera/projection.h` and
//! `camera.h`): equirectangular, equiangular cube map face, mirror ball, fisheye
//! (equidistant, equisolid, lens polynomial) and central cylindrical.
//!
//! A film position maps to viewplane coordinates (u, v) in [0, 1]² over the frame (v up),
//! offset by Blender's lens shift unscaled (Cycles' panoramic viewplane is the unit square
//! moved by the shift). Each projection turns (u, v) into a direction in Cycles' panorama
//! space, where +X looks forward, +Y left and +Z up (a mirror ball: −Y forward); positions
//! outside a fisheye's circle or a mirror ball have no direction (Cycles gives such a ray
//! no light: black and opaque). Depth of field turns the aperture in the plane
//! perpendicular to the direction. `to_local` then carries panorama space into the Blender
//! camera's frame (right, up, back), as Cycles' `blender_camera_matrix` does.
//! Stereo (interocular offset, pole merge) is not modelled: the add-on exports one view.

use glam::{Vec2, Vec3};

/// One of Blender's panoramic projections with the values Cycles' kernel reads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Panorama {
    /// Longitude and latitude spans: φ = range[0] u + range[1], θ = range[2] v + range[3]
    /// (Cycles' `equirectangular_range` from Blender's minimum and maximum angles).
    Equirectangular {
        /// (φ per u, φ at u = 0, θ per v, θ at v = 0), radians; θ from +Z.
        range: [f32; 4],
    },
    /// One face of an equiangular cube map (90° each way, angles linear in u and v).
    EquiangularCubemapFace,
    /// The reflection in a mirror ball seen from far away along −Y.
    Mirrorball,
    /// Angle from the axis proportional to the distance from the frame's centre; the
    /// ellipse inscribed in the frame spans `fov`.
    FisheyeEquidistant {
        /// Field of view across the inscribed ellipse (radians).
        fov: f32,
    },
    /// r = 2 f sin(θ / 2) on the sensor, cut at θ = fov / 2.
    FisheyeEquisolid {
        /// Focal length (mm).
        lens: f32,
        /// Field of view (radians).
        fov: f32,
        /// Sensor width and height (mm), fitted to the frame as Cycles fits them.
        sensor: Vec2,
    },
    /// θ = −(k0 + k1 r + k2 r² + k3 r³ + k4 r⁴) with r in mm on the sensor, cut at fov / 2.
    FisheyeLensPolynomial {
        /// k0..k4.
        k: [f32; 5],
        /// Field of view (radians).
        fov: f32,
        /// Sensor width and height (mm), fitted to the frame.
        sensor: Vec2,
    },
    /// A cylinder around the up axis: angle linear in u, height linear in v.
    CentralCylindrical {
        /// (angle at u = 0, angle at u = 1, height at v = 0, height at v = 1): Cycles'
        /// `central_cylindrical_range` (angles negated, heights over the radius).
        range: [f32; 4],
    },
}

/// The direction at angle θ from the view axis whose azimuth is that of the point (u, v) at
/// distance r from the fisheye's centre (Cycles' `fisheye_to_direction`).
#[inline]
fn fisheye(theta: f32, u: f32, v: f32, r: f32) -> Vec3 {
    let cos_phi = if r != 0.0 { (u / r).clamp(-1.0, 1.0) } else { 0.0 };
    let sin_phi = (1.0 - cos_phi * cos_phi).max(0.0).sqrt() * if v < 0.0 { -1.0 } else { 1.0 };
    let (s, c) = theta.sin_cos();
    Vec3::new(c, -cos_phi * s, sin_phi * s)
}

/// The sensor radius (mm) at which a lens polynomial reaches the angle `theta` from the axis,
/// θ = −(k0 + k1 r + … + k4 r⁴), by Newton's method from the linear term's root (as Cycles
/// solves it); the last iterate where it does not converge.
fn lens_polynomial_newton(k: &[f32; 5], theta: f32) -> f32 {
    let target = -theta;
    let f = |r: f32| k[0] + r * (k[1] + r * (k[2] + r * (k[3] + r * k[4]))) - target;
    let df = |r: f32| k[1] + r * (2.0 * k[2] + r * (3.0 * k[3] + r * 4.0 * k[4]));
    let mut r = if k[1] != 0.0 { (target - k[0]) / k[1] } else { 0.0 };
    for _ in 0..30 {
        let s = df(r);
        if s == 0.0 {
            break;
        }
        let step = f(r) / s;
        r -= step;
        if step.abs() <= 1e-7 * r.abs().max(1e-3) {
            break;
        }
    }
    r
}

/// [`lens_polynomial_newton`] where it converged to a radius that reaches `theta`.
fn lens_polynomial_radius(k: &[f32; 5], theta: f32) -> Option<f32> {
    let r = lens_polynomial_newton(k, theta);
    let residual = k[0] + r * (k[1] + r * (k[2] + r * (k[3] + r * k[4]))) + theta;
    // A bias k0 puts θ = 0 a hair off the centre (at r < 0): kept, at the centre.
    (r.is_finite() && r >= -1e-3 && residual.abs() <= 1e-4 * theta.abs().max(1e-2)).then_some(r.max(0.0))
}

impl Panorama {
    /// The direction (not normalised) in panorama space for viewplane coordinates (u, v),
    /// or None where the lens sees nothing.
    pub fn direction(&self, u: f32, v: f32) -> Option<Vec3> {
        match *self {
            Panorama::Equirectangular { range } => {
                let phi = range[0] * u + range[1];
                let theta = range[2] * v + range[3];
                let (st, ct) = theta.sin_cos();
                let (sp, cp) = phi.sin_cos();
                Some(Vec3::new(st * cp, st * sp, ct))
            }
            Panorama::EquiangularCubemapFace => {
                let a = ((0.5 - u) * std::f32::consts::FRAC_PI_2).tan();
                let b = ((v - 0.5) * std::f32::consts::FRAC_PI_2).tan();
                Some(Vec3::new(1.0, a, b))
            }
            Panorama::Mirrorball => {
                let (x, z) = (2.0 * u - 1.0, 2.0 * v - 1.0);
                if x * x + z * z > 1.0 {
                    return None;
                }
                let n = Vec3::new(x, -(1.0 - x * x - z * z).max(0.0).sqrt(), z);
                // The view direction I = −Y reflected about the sphere's normal.
                let i = Vec3::new(0.0, -1.0, 0.0);
                Some(2.0 * n.dot(i) * n - i)
            }
            Panorama::FisheyeEquidistant { fov } => {
                let (x, y) = ((u - 0.5) * 2.0, (v - 0.5) * 2.0);
                let r = (x * x + y * y).sqrt();
                (r <= 1.0).then(|| fisheye(r * fov * 0.5, x, y, r))
            }
            Panorama::FisheyeEquisolid { lens, fov, sensor } => {
                let (x, y) = ((u - 0.5) * sensor.x, (v - 0.5) * sensor.y);
                let r = (x * x + y * y).sqrt();
                let rmax = 2.0 * lens * (fov * 0.25).sin();
                (r <= rmax).then(|| fisheye(2.0 * (r / (2.0 * lens)).clamp(-1.0, 1.0).asin(), x, y, r))
            }
            Panorama::FisheyeLensPolynomial { k, fov, sensor } => {
                let (x, y) = ((u - 0.5) * sensor.x, (v - 0.5) * sensor.y);
                let r = (x * x + y * y).sqrt();
                let theta = -(k[0] + r * (k[1] + r * (k[2] + r * (k[3] + r * k[4]))));
                (theta.abs() <= 0.5 * fov).then(|| fisheye(theta, x, y, r))
            }
            Panorama::CentralCylindrical { range } => {
                let angle = range[0] + (range[1] - range[0]) * u;
                let z = range[2] + (range[3] - range[2]) * v;
                let (s, c) = angle.sin_cos();
                Some(Vec3::new(c, s, z))
            }
        }
    }

    /// The inverse of [`direction`](Self::direction): the viewplane coordinates (u, v) that
    /// see the direction `d` of panorama space, or None where no position of the projection
    /// does (behind a cube face, beyond a fisheye's field of view, a cylinder's poles). The
    /// (u, v) may lie outside the frame.
    pub fn inverse(&self, d: Vec3) -> Option<Vec2> {
        let d = d.try_normalize()?;
        let seen = match *self {
            Panorama::Equirectangular { .. } | Panorama::Mirrorball => true,
            Panorama::EquiangularCubemapFace => d.x > 0.0,
            Panorama::FisheyeEquidistant { fov }
            | Panorama::FisheyeEquisolid { fov, .. }
            | Panorama::FisheyeLensPolynomial { fov, .. } => d.x.clamp(-1.0, 1.0).acos() <= 0.5 * fov,
            Panorama::CentralCylindrical { .. } => d.x.hypot(d.y) > 0.0,
        };
        if let Panorama::FisheyeLensPolynomial { k, .. } = *self {
            lens_polynomial_radius(&k, d.x.clamp(-1.0, 1.0).acos())?;
        }
        seen.then(|| self.uv(d))
    }

    /// Cycles' `direction_to_panorama`: viewplane coordinates for the unit direction `d`
    /// of panorama space, also where the projection does not see it (what the Texture
    /// Coordinate node's Window output gives there).
    pub fn uv(&self, d: Vec3) -> Vec2 {
        match *self {
            Panorama::Equirectangular { range } => {
                let phi = d.y.atan2(d.x);
                let theta = d.z.clamp(-1.0, 1.0).acos();
                Vec2::new((phi - range[1]) / range[0], (theta - range[3]) / range[2])
            }
            Panorama::EquiangularCubemapFace => {
                // Angles linear in u and v.
                let k = 2.0 / std::f32::consts::PI;
                Vec2::new(0.5 - d.y.atan2(d.x) * k, 0.5 + d.z.atan2(d.x) * k)
            }
            Panorama::Mirrorball => {
                // The reflection d = 2 (n·I) n − I puts the normal along d + I (I = −Y).
                let n = (d - Vec3::Y).try_normalize().unwrap_or(Vec3::ZERO);
                Vec2::new(0.5 * (n.x + 1.0), 0.5 * (n.z + 1.0))
            }
            Panorama::FisheyeEquidistant { fov } => {
                let theta = d.x.clamp(-1.0, 1.0).acos();
                Self::fisheye_uv(d, theta / fov, Vec2::ONE)
            }
            Panorama::FisheyeEquisolid { lens, sensor, .. } => {
                let theta = d.x.clamp(-1.0, 1.0).acos();
                Self::fisheye_uv(d, 2.0 * lens * (0.5 * theta).sin(), sensor)
            }
            Panorama::FisheyeLensPolynomial { k, sensor, .. } => {
                let theta = d.x.clamp(-1.0, 1.0).acos();
                let r = lens_polynomial_newton(&k, theta);
                Self::fisheye_uv(d, r, sensor)
            }
            Panorama::CentralCylindrical { range } => {
                let angle = d.y.atan2(d.x);
                let h = d.z / d.x.hypot(d.y);
                Vec2::new((angle - range[0]) / (range[1] - range[0]), (h - range[2]) / (range[3] - range[2]))
            }
        }
    }

    /// A fisheye's (u, v) for the unit direction `d` at distance `r` (in units of `size`)
    /// from the frame's centre, along d's azimuth around the view axis.
    #[inline]
    fn fisheye_uv(d: Vec3, r: f32, size: Vec2) -> Vec2 {
        let s = d.y.hypot(d.z);
        let (c, sn) = if s > 0.0 { (-d.y / s, d.z / s) } else { (1.0, 0.0) };
        Vec2::new(r * c / size.x + 0.5, r * sn / size.y + 0.5)
    }

    /// The film density at the unit direction `d` of panorama space: |d(u, v) / dω|, the
    /// area of viewplane (the frame is 1 × 1) per steradian, which is the solid-angle
    /// density of a camera ray's direction when film positions are uniform over the frame
    /// (light tracing's importance). Zero where [`inverse`](Self::inverse) is None.
    pub fn density(&self, d: Vec3) -> f32 {
        let Some(d) = d.try_normalize() else { return 0.0 };
        match *self {
            Panorama::Equirectangular { range } => {
                // dω = sin θ dθ dφ, dφ = range[0] du, dθ = range[2] dv.
                let sin_theta = d.x.hypot(d.y);
                1.0 / ((range[0] * range[2]).abs() * sin_theta)
            }
            Panorama::EquiangularCubemapFace => {
                if !(d.x > 0.0) {
                    return 0.0;
                }
                // The plane x = 1: dω = da db / (1 + a² + b²)^(3/2), u and v linear in atan a, atan b.
                let (a, b) = (d.y / d.x, d.z / d.x);
                let k = 2.0 / std::f32::consts::PI;
                (1.0 + a * a + b * b).powf(1.5) * k * k / ((1.0 + a * a) * (1.0 + b * b))
            }
            // The disk's area element (ρ dρ dφ, ρ = sin α) over the reflected directions'
            // (sin 2α · 2 dα dφ), a quarter for u, v = (x + 1) / 2: a constant.
            Panorama::Mirrorball => 1.0 / 16.0,
            Panorama::FisheyeEquidistant { fov } => {
                let theta = d.x.clamp(-1.0, 1.0).acos();
                if theta > 0.5 * fov {
                    return 0.0;
                }
                // r = θ / fov: r dr dφ over sin θ dθ dφ.
                let ratio = if theta > 1e-4 { theta / theta.sin() } else { 1.0 };
                ratio / (fov * fov)
            }
            Panorama::FisheyeEquisolid { lens, fov, sensor } => {
                let theta = d.x.clamp(-1.0, 1.0).acos();
                if theta > 0.5 * fov {
                    return 0.0;
                }
                // r = 2 f sin(θ / 2): r dr = f² sin θ dθ, an equal-area projection.
                lens * lens / (sensor.x * sensor.y)
            }
            Panorama::FisheyeLensPolynomial { k, fov, sensor } => {
                let theta = d.x.clamp(-1.0, 1.0).acos();
                if theta > 0.5 * fov {
                    return 0.0;
                }
                let Some(r) = lens_polynomial_radius(&k, theta) else { return 0.0 };
                let slope = (k[1] + r * (2.0 * k[2] + r * (3.0 * k[3] + r * 4.0 * k[4]))).abs();
                // r dr dφ over sin θ |dθ/dr| dr dφ; r / sin θ → 1 / |θ'(0)| on the axis.
                let r_over_sin = if theta > 1e-4 { r / theta.sin() } else { 1.0 / k[1].abs() };
                r_over_sin / (slope * sensor.x * sensor.y)
            }
            Panorama::CentralCylindrical { range } => {
                let rho = d.x.hypot(d.y);
                if !(rho > 0.0) {
                    return 0.0;
                }
                // The cylinder of radius 1: dω = d(angle) dh / (1 + h²)^(3/2).
                let h = d.z / rho;
                (1.0 + h * h).powf(1.5) / ((range[1] - range[0]) * (range[3] - range[2])).abs()
            }
        }
    }

    /// How far along u the projection repeats itself (it goes round the up axis), in
    /// frames: a direction seen at u is seen again at u ± the period; None for the others.
    pub fn u_period(&self) -> Option<f32> {
        let per_u = match *self {
            Panorama::Equirectangular { range } => range[0],
            Panorama::CentralCylindrical { range } => range[1] - range[0],
            _ => return None,
        };
        (per_u != 0.0).then(|| std::f32::consts::TAU / per_u.abs())
    }

    /// Panorama space of a vector in the Blender camera's frame: the inverse of
    /// [`to_local`](Self::to_local).
    #[inline]
    pub fn from_local(&self, l: Vec3) -> Vec3 {
        match self {
            Panorama::Mirrorball => Vec3::new(l.x, l.z, l.y),
            _ => Vec3::new(-l.z, -l.x, l.y),
        }
    }

    /// A vector of panorama space in the Blender camera's frame (right, up, back): Cycles
    /// points +X (a mirror ball −Y) along the camera's view, −Z of its object.
    #[inline]
    pub fn to_local(&self, d: Vec3) -> Vec3 {
        match self {
            Panorama::Mirrorball => Vec3::new(d.x, d.z, d.y),
            _ => Vec3::new(-d.y, d.z, -d.x),
        }
    }

    /// The ray (origin offset, unit direction) in panorama space through (u, v) from the
    /// aperture point `a` (camera units; zero for a pinhole), focused at `focus_distance`
    /// along the pinhole direction (Cycles' `camera_sample_panorama`); None outside the lens.
    pub fn ray(&self, u: f32, v: f32, a: Vec2, focus_distance: f32) -> Option<(Vec3, Vec3)> {
        let d = self.direction(u, v)?.try_normalize()?;
        if a == Vec2::ZERO {
            return Some((Vec3::ZERO, d));
        }
        // The aperture lies in the plane perpendicular to d, its first axis towards +X.
        let ax = (Vec3::X - d.x * d).try_normalize().unwrap_or(Vec3::Y);
        let ay = d.cross(ax).normalize();
        let p = ax * a.x + ay * a.y;
        Some((p, (d * focus_distance - p).normalize()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    const FULL: Panorama = Panorama::Equirectangular { range: [-2.0 * PI, PI, -PI, PI] };

    fn local(p: &Panorama, u: f32, v: f32) -> Vec3 {
        p.to_local(p.direction(u, v).unwrap()).normalize()
    }

    #[test]
    fn every_projection_looks_forward_at_the_frame_centre() {
        let sensor = Vec2::new(36.0, 24.0);
        for p in [
            FULL,
            Panorama::EquiangularCubemapFace,
            Panorama::Mirrorball,
            Panorama::FisheyeEquidistant { fov: PI },
            Panorama::FisheyeEquisolid { lens: 10.5, fov: PI, sensor },
            Panorama::FisheyeLensPolynomial { k: [0.0, -0.02, 0.0, 0.0, 0.0], fov: PI, sensor },
            Panorama::CentralCylindrical { range: [PI, -PI, -1.0, 1.0] },
        ] {
            let d = local(&p, 0.5, 0.5);
            assert!((d - Vec3::NEG_Z).length() < 1e-5, "{p:?}: {d}");
        }
    }

    #[test]
    fn equirectangular_left_is_left_and_top_is_up() {
        // u = 1/4 is 90° to the left; v = 1 straight up; u = 0 behind.
        assert!((local(&FULL, 0.25, 0.5) - Vec3::NEG_X).length() < 1e-5);
        assert!((local(&FULL, 0.5, 1.0) - Vec3::Y).length() < 1e-5);
        assert!((local(&FULL, 0.0, 0.5) - Vec3::Z).length() < 1e-5);
    }

    #[test]
    fn fisheyes_see_nothing_outside_their_circle_and_reach_half_their_fov_on_it() {
        let fe = Panorama::FisheyeEquidistant { fov: PI };
        assert!(fe.direction(0.02, 0.02).is_none());
        // The right edge's middle is 90° off axis: straight right.
        assert!((local(&fe, 1.0, 0.5) - Vec3::X).length() < 1e-5);
        let lens = 10.0;
        let sensor = Vec2::new(40.0, 40.0);
        let es = Panorama::FisheyeEquisolid { lens, fov: PI, sensor };
        // On the circle r = 2 f sin(45°) the angle is 90°.
        let u = 0.5 + 2.0 * lens * (PI / 4.0).sin() / sensor.x;
        assert!((local(&es, u - 1e-6, 0.5) - Vec3::X).length() < 1e-3);
        assert!(es.direction(u + 1e-3, 0.5).is_none());
    }

    #[test]
    fn mirror_ball_rim_looks_backwards() {
        let d = local(&Panorama::Mirrorball, 0.5, 1.0 - 1e-7);
        assert!((d - Vec3::Z).length() < 1e-2, "{d}");
        assert!(Panorama::Mirrorball.direction(0.0, 0.0).is_none());
    }

    /// Every projection with the values of Blender's defaults or near them, partial ranges
    /// and a shifted polynomial included.
    fn all() -> Vec<Panorama> {
        let sensor = Vec2::new(36.0, 24.0);
        vec![
            FULL,
            Panorama::Equirectangular { range: [-1.5, 0.6, -1.2, 2.2] },
            Panorama::EquiangularCubemapFace,
            Panorama::Mirrorball,
            Panorama::FisheyeEquidistant { fov: PI },
            Panorama::FisheyeEquidistant { fov: 1.2 * PI },
            Panorama::FisheyeEquisolid { lens: 10.5, fov: PI, sensor },
            Panorama::FisheyeLensPolynomial { k: [-1.2e-5, -0.0196, -1.0e-5, 3.0e-6, -6.0e-9], fov: PI, sensor },
            Panorama::CentralCylindrical { range: [PI, -PI, -1.0, 1.0] },
            Panorama::CentralCylindrical { range: [1.0, -0.5, -2.0, 0.5] },
        ]
    }

    /// `inverse` returns the (u, v) that `direction` was made from, at many points of each
    /// projection's frame (1e-3 of the frame: f32 angles near the poles and a fisheye's rim
    /// lose about that much; a wrong axis or sign is off by a large part of the frame).
    #[test]
    fn inverse_round_trips_direction() {
        let mut rng = crate::sampling::chi2::Pcg32::new(5);
        for p in all() {
            let mut seen = 0;
            for _ in 0..2000 {
                let (u, v) = (0.002 + 0.996 * rng.next_f32(), 0.002 + 0.996 * rng.next_f32());
                let Some(d) = p.direction(u, v) else { continue };
                // The mirror ball's rim and a fisheye's circle are ill-conditioned: stay inside.
                if matches!(p, Panorama::Mirrorball) && (2.0 * u - 1.0).hypot(2.0 * v - 1.0) > 0.98 {
                    continue;
                }
                let back = p.inverse(d).unwrap_or_else(|| panic!("{p:?}: no inverse at ({u}, {v}) for {d}"));
                assert!((back - Vec2::new(u, v)).length() < 1e-3, "{p:?}: ({u}, {v}) -> {d} -> {back}");
                // Through the camera's frame and back.
                assert!((p.from_local(p.to_local(d)) - d).length() < 1e-6);
                seen += 1;
            }
            assert!(seen > 1000, "{p:?}: {seen}");
        }
    }

    /// `density` is |d(u, v) / dω|: the inverse of the solid angle that a small square of the
    /// viewplane sees, by central differences of `direction` (relative 2e-3: the differences'
    /// truncation at step 1e-3 and f32 rounding; a missing sin θ or a wrong constant is off
    /// by far more away from the frame's centre).
    #[test]
    fn density_is_the_jacobian_of_the_inverse() {
        let mut rng = crate::sampling::chi2::Pcg32::new(9);
        let h = 1e-3;
        for p in all() {
            let mut checked = 0;
            for _ in 0..500 {
                let (u, v) = (0.05 + 0.9 * rng.next_f32(), 0.05 + 0.9 * rng.next_f32());
                let dir = |u: f32, v: f32| p.direction(u, v).map(|d| d.normalize().as_dvec3());
                let (Some(d), Some(du0), Some(du1), Some(dv0), Some(dv1)) =
                    (dir(u, v), dir(u - h, v), dir(u + h, v), dir(u, v - h), dir(u, v + h))
                else {
                    continue;
                };
                // Near the poles of an equirectangular frame the density has no bound; near
                // the mirror ball's rim the differences straddle a square root's kink.
                if d.z.abs() > 0.98 && matches!(p, Panorama::Equirectangular { .. })
                    || matches!(p, Panorama::Mirrorball) && (2.0 * u - 1.0).hypot(2.0 * v - 1.0) > 0.95
                    // A fisheye's azimuth comes from acos(x / r) (as in Cycles), whose f32
                    // rounding near ±1 (the horizontal axis) swamps differences of 1e-3.
                    || matches!(p, Panorama::FisheyeEquidistant { .. } | Panorama::FisheyeEquisolid { .. } | Panorama::FisheyeLensPolynomial { .. })
                        && d.z.abs() < 0.05 * d.y.hypot(d.z)
                {
                    continue;
                }
                let area = ((du1 - du0) / (2.0 * h as f64)).cross((dv1 - dv0) / (2.0 * h as f64)).length();
                let want = 1.0 / area;
                let got = p.density(d.as_vec3()) as f64;
                assert!((got / want - 1.0).abs() < 2e-3, "{p:?} at ({u}, {v}): {got} vs {want}");
                checked += 1;
            }
            assert!(checked > 200, "{p:?}: {checked}");
        }
    }

    /// Directions no position sees have no inverse and no density.
    #[test]
    fn unseen_directions_have_no_inverse() {
        let fe = Panorama::FisheyeEquidistant { fov: PI };
        let behind = Vec3::new(-0.5, 0.3, 0.2);
        assert!(fe.inverse(behind).is_none() && fe.density(behind) == 0.0);
        let cube = Panorama::EquiangularCubemapFace;
        assert!(cube.inverse(behind).is_none() && cube.density(behind) == 0.0);
        let cyl = Panorama::CentralCylindrical { range: [PI, -PI, -1.0, 1.0] };
        assert!(cyl.inverse(Vec3::Z).is_none() && cyl.density(Vec3::Z) == 0.0);
    }

    #[test]
    fn depth_of_field_rays_meet_at_the_focus_distance() {
        let p = Panorama::FisheyeEquidistant { fov: PI };
        let (_, pin) = p.ray(0.7, 0.4, Vec2::ZERO, 3.0).unwrap();
        for a in [Vec2::new(0.1, 0.0), Vec2::new(-0.05, 0.08)] {
            let (o, d) = p.ray(0.7, 0.4, a, 3.0).unwrap();
            assert!(o.dot(pin).abs() < 1e-6, "the aperture is perpendicular to the view");
            let t = (pin * 3.0 - o).length();
            assert!((o + d * t - pin * 3.0).length() < 1e-5);
        }
    }
}
