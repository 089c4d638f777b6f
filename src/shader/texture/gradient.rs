//! Blender's Gradient Texture node (`svm/gradient.h`): ramps along x, around z, or radially.

use glam::Vec3;

/// The node's "Type" setting.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GradientKind {
    Linear,
    Quadratic,
    Easing,
    Diagonal,
    Radial,
    QuadraticSphere,
    Spherical,
}

/// Fac of the Gradient node, clamped to [0, 1] (its Color is `(Fac, Fac, Fac)`).
#[inline]
pub fn gradient_texture(p: Vec3, kind: GradientKind) -> f32 {
    let (x, y, z) = (p.x, p.y, p.z);
    let f = match kind {
        GradientKind::Linear => x,
        GradientKind::Quadratic => {
            let r = x.max(0.0);
            r * r
        }
        GradientKind::Easing => {
            // Cycles' fminf(fmaxf(x, 0), 1), which maps NaN to 0 where clamp would keep it.
            #[allow(clippy::manual_clamp)]
            let r = x.max(0.0).min(1.0);
            let t = r * r;
            3.0 * t - 2.0 * t * r
        }
        GradientKind::Diagonal => (x + y) * 0.5,
        GradientKind::Radial => y.atan2(x) / core::f32::consts::TAU + 0.5,
        GradientKind::QuadraticSphere | GradientKind::Spherical => {
            // Cycles biases the radius so that a unit vector gives exactly zero rather than a
            // rounding residue.
            let r = (0.999999 - (x * x + y * y + z * z).sqrt()).max(0.0);
            if kind == GradientKind::QuadraticSphere { r * r } else { r }
        }
    };
    f.clamp(0.0, 1.0)
}
