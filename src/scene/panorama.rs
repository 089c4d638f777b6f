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
