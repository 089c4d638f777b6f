//! A moving camera: its rigid frame at each motion step, interpolated as Cycles does
//! (decomposed: position linearly, rotation by slerp). Camera rays are made in the frame
//! the camera has at the shutter's reference (the exported frame) and then carried by the
//! rigid motion from that frame to the frame at the sample's time.

use super::segment;
use super::transform::Decomposed;
use glam::{Mat4, Vec3};

/// The camera's rigid frames at the motion steps.
#[derive(Clone, Debug)]
pub struct CameraMotion {
    /// Step times in frames, ascending.
    pub times: Vec<f32>,
    /// The camera's frame (scale removed) at each step.
    pub frames: Vec<Decomposed>,
    /// Inverse of the frame the camera's rays are made in (the node's frame at time 0).
    pub reference_inv: Mat4,
}

impl CameraMotion {
    /// Motion through world matrices `steps` at `times`, relative to the camera's matrix
    /// `reference` (all in the same axes; scale is dropped as the camera drops it).
    pub fn new(times: Vec<f32>, steps: &[Mat4], reference: &Mat4) -> Self {
        let rigid = |m: &Mat4| Decomposed { scale: Vec3::ONE, ..Decomposed::new(m) };
        CameraMotion {
            times,
            frames: steps.iter().map(rigid).collect(),
            reference_inv: rigid(reference).matrix().inverse(),
        }
    }

    /// The rigid motion from the reference frame to the frame at time `t`: a point fixed to
    /// the camera at `p` (reference) is at `delta(t) · p` at time `t`.
    #[inline]
    pub fn delta(&self, t: f32) -> Mat4 {
        let (i, f) = segment(&self.times, t);
        let frame = if f == 0.0 { self.frames[i] } else { self.frames[i].lerp(&self.frames[i + 1], f) };
        frame.matrix() * self.reference_inv
    }

    /// A ray of the reference camera moved to the camera at time `t`: (origin, direction).
    #[inline]
    pub fn move_ray(&self, org: Vec3, dir: Vec3, t: f32) -> (Vec3, Vec3) {
        let d = self.delta(t);
        (d.transform_point3(org), d.transform_vector3(dir).normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moves_rays_with_the_camera() {
        let reference = Mat4::from_translation(Vec3::new(0.0, 0.0, 5.0));
        let steps =
            [Mat4::from_translation(Vec3::new(-1.0, 0.0, 5.0)), Mat4::from_translation(Vec3::new(1.0, 0.0, 5.0))];
        let m = CameraMotion::new(vec![-0.5, 0.5], &steps, &reference);
        let (o, d) = m.move_ray(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z, 0.25);
        assert!((o - Vec3::new(0.5, 0.0, 5.0)).length() < 1e-6);
        assert!((d + Vec3::Z).length() < 1e-6);
        // A turning camera turns its rays.
        let turn = [reference, reference * Mat4::from_rotation_y(std::f32::consts::FRAC_PI_2)];
        let m = CameraMotion::new(vec![0.0, 1.0], &turn, &reference);
        let (o, d) = m.move_ray(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z, 1.0);
        assert!((o - Vec3::new(0.0, 0.0, 5.0)).length() < 1e-5 && (d + Vec3::X).length() < 1e-5, "{o} {d}");
    }
}
