//! Transforms between motion steps as Cycles interpolates them
//! (`transform_motion_decompose`): translation and scale linearly, rotation by slerp of
//! the unit quaternions, so that a spinning object keeps its size between steps.

use glam::{Mat4, Quat, Vec3};

/// A transform split into scale, rotation and translation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Decomposed {
    /// Per-axis scale.
    pub scale: Vec3,
    /// Unit rotation.
    pub rotation: Quat,
    /// Translation.
    pub translation: Vec3,
}

impl Decomposed {
    /// Splits `m` (an affine matrix without shear; shear is lost, as in Cycles' decomposition
    /// of non-orthogonal matrices).
    pub fn new(m: &Mat4) -> Self {
        let (scale, rotation, translation) = m.to_scale_rotation_translation();
        Decomposed { scale, rotation: rotation.normalize(), translation }
    }

    /// The transform a fraction `f` of the way from `self` to `b`, along the shorter arc.
    pub fn lerp(&self, b: &Decomposed, f: f32) -> Decomposed {
        // glam's slerp takes the shorter arc (it flips the sign when the dot is negative).
        Decomposed {
            scale: self.scale.lerp(b.scale, f),
            rotation: self.rotation.slerp(b.rotation, f).normalize(),
            translation: self.translation.lerp(b.translation, f),
        }
    }

    /// The matrix.
    pub fn matrix(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }

    /// Angle in radians of the rotation from `self` to `b` (the shorter way).
    pub fn angle_to(&self, b: &Decomposed) -> f32 {
        self.rotation.angle_between(b.rotation)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halfway_keeps_rotation_on_the_arc() {
        let a = Decomposed::new(&Mat4::IDENTITY);
        let b = Decomposed::new(&Mat4::from_rotation_y(std::f32::consts::FRAC_PI_2));
        let mid = a.lerp(&b, 0.5).matrix();
        let p = mid.transform_point3(Vec3::X);
        // Rotated by 45°, still of unit length (a linear blend of the matrices gives 0.707).
        assert!((p.length() - 1.0).abs() < 1e-6);
        assert!((p - Vec3::new(0.5f32.sqrt(), 0.0, -(0.5f32.sqrt()))).length() < 1e-6);
        assert!((a.angle_to(&b) - std::f32::consts::FRAC_PI_2).abs() < 1e-5);
    }

    #[test]
    fn translation_and_scale_are_linear() {
        let a = Decomposed::new(&Mat4::from_translation(Vec3::new(0.0, 0.0, 0.0)));
        let b =
            Decomposed::new(&(Mat4::from_translation(Vec3::new(2.0, 0.0, 0.0)) * Mat4::from_scale(Vec3::splat(3.0))));
        let m = a.lerp(&b, 0.25);
        assert!((m.translation - Vec3::new(0.5, 0.0, 0.0)).length() < 1e-6);
        assert!((m.scale - Vec3::splat(1.5)).length() < 1e-6);
    }
}
