//! The Vector pass: how far the first hit moves on the film between the previous frame,
//! this frame and the next, as Cycles 5.0 writes it, in pixels with y up (Blender's
//! raster): (x, y) = previous − here, (z, w) = here − next, so that an object moving right
//! has negative x and z (measured against Cycles: tests/blender/test_motion_blur.py).
//! Blender offers it only without motion blur; the add-on then exports the steps at
//! frames −1, 0 and +1.

use super::SceneMotion;
use crate::accel::Hit;
use crate::scene::camera::CameraRays;
use glam::Vec3;

/// The Vector pass of a hit at `p` (at time 0) on triangle `hit.tri`, seen by `camera`;
/// zero where a position is behind the camera (no raster position).
pub fn motion_vector(motion: Option<&SceneMotion>, camera: &CameraRays, hit: &Hit, p: Vec3) -> [f32; 4] {
    let at = |t: f32| -> Vec3 {
        match motion.and_then(|m| m.moving(hit.tri).map(|k| (m, k))) {
            Some((m, k)) => {
                let (c, _) = m.triangle_at(k, t);
                c[0] * (1.0 - hit.b1 - hit.b2) + c[1] * hit.b1 + c[2] * hit.b2
            }
            None => p,
        }
    };
    let (Some(pre), Some(here), Some(post)) =
        (camera.raster_at(at(-1.0), -1.0), camera.raster_at(p, 0.0), camera.raster_at(at(1.0), 1.0))
    else {
        return [0.0; 4];
    };
    // Film rows run down, Blender's raster y up.
    [pre.x - here.x, here.y - pre.y, here.x - post.x, post.y - here.y]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Camera, Projection};
    use glam::Mat4;

    #[test]
    fn a_point_moving_right_and_up_has_negative_vectors() {
        let cam = Camera::from_matrix(
            "c".into(),
            &Mat4::from_translation(Vec3::new(0.0, 0.0, 10.0)),
            Projection::Orthographic { xmag: 5.0, ymag: 5.0 },
        );
        let rays = CameraRays::new(&cam, 100, 100);
        // One triangle moving +0.5 in x and +0.25 in y per frame: 5 and 2.5 pixels (10 px per unit).
        let tri = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        let shift = |t: f32| tri.map(|c| c + Vec3::new(0.5, 0.25, 0.0) * t);
        let m = SceneMotion {
            times: vec![-1.0, 0.0, 1.0],
            slot: vec![0],
            triangles: vec![0],
            corners: vec![shift(-1.0), shift(0.0), shift(1.0)],
            normals: vec![[Vec3::Z; 3]; 3],
            ..Default::default()
        };
        let hit = Hit { tri: 0, t: 10.0, b1: 0.25, b2: 0.25 };
        let p = Vec3::new(0.25, 0.25, 0.0);
        let v = motion_vector(Some(&m), &rays, &hit, p);
        for (got, want) in v.iter().zip([-5.0, -2.5, -5.0, -2.5]) {
            assert!((got - want).abs() < 1e-4, "{v:?}");
        }
        // A static scene has no motion.
        assert_eq!(motion_vector(None, &rays, &hit, p), [0.0; 4]);
    }

    /// A still point seen by an equirectangular camera turning left about its up axis by
    /// `a` per frame moves right on the film by W a / 2π pixels per frame (the panorama's
    /// longitude is linear in x): the vectors are −W a / 2π in x and 0 in y.
    #[test]
    fn a_turning_panoramic_camera_moves_points_by_its_angle() {
        use crate::scene::panorama::Panorama;
        use std::f32::consts::PI;
        let a = 0.2f32;
        let reference = Mat4::IDENTITY;
        let steps = [Mat4::from_rotation_y(-a), Mat4::IDENTITY, Mat4::from_rotation_y(a)];
        let mut cam = Camera::from_matrix(
            "c".into(),
            &reference,
            Projection::Panoramic(Panorama::Equirectangular { range: [-2.0 * PI, PI, -PI, PI] }),
        );
        cam.motion = Some(crate::motion::CameraMotion::new(vec![-1.0, 0.0, 1.0], &steps, &reference));
        let rays = CameraRays::new(&cam, 128, 64);
        let hit = Hit { tri: 0, t: 3.0, b1: 0.25, b2: 0.25 };
        let want = -128.0 * a / (2.0 * PI);
        for p in [Vec3::new(0.0, 0.0, -3.0), Vec3::new(-2.0, 0.5, -1.0), Vec3::new(1.0, -0.3, 2.0)] {
            let v = motion_vector(None, &rays, &hit, p);
            for (got, want) in v.iter().zip([want, 0.0, want, 0.0]) {
                assert!((got - want).abs() < 1e-3, "{p}: {v:?} vs {want}");
            }
        }
    }
}
