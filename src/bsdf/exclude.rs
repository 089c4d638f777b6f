//! A BSDF's value without the closure classes a light is hidden from
//! (`scene::light_visibility`): Cycles' `_surface_shader_exclude` on next-event estimation.
//! The value splits as f = diffuse + glass + the rest, the rest being glossy reflection on
//! the side of wo and transmission on the other side.

use super::BsdfAt;
use crate::math::Rgb;
use crate::scene::light_visibility::Excluded;
use glam::Vec3;

impl BsdfAt<'_> {
    /// f(wo, wi) without the classes in `ex`.
    #[inline]
    pub fn eval_visible(&self, wi: Vec3, ex: Excluded) -> Rgb {
        let f = self.eval(wi);
        let diffuse = self.eval_diffuse(wi);
        let glass = self.eval_glass(wi);
        let rest = f - diffuse - glass;
        let reflected = wi.z * self.wo().z > 0.0 || self.reflects_across(wi);
        let mut v = f;
        if ex.diffuse {
            v -= diffuse;
        }
        if (reflected && ex.glossy) || (!reflected && ex.transmission) {
            v -= rest;
        }
        if ex.glass() {
            v -= glass;
        }
        // Rounding in the differences must not leave a negative value.
        v.max(Rgb::ZERO)
    }

    /// The part of [`eval`](Self::eval) from glass closures (reflection and refraction in
    /// one: the Principled BSDF's transmission, Glass and Refraction BSDFs, and hair,
    /// which Cycles counts among them).
    #[inline]
    pub fn eval_glass(&self, wi: Vec3) -> Rgb {
        match self {
            BsdfAt::Pbr(b) => b.eval_glass(wi),
            BsdfAt::Mix(m, wo) => m.eval_glass(*wo, wi),
            BsdfAt::Hair(h, wo) => h.eval(*wo, wi),
            BsdfAt::HairLobes(h, wo) => h.eval(*wo, wi),
        }
    }

    /// The outgoing direction the BSDF is seen from.
    #[inline]
    fn wo(&self) -> Vec3 {
        match self {
            BsdfAt::Pbr(b) => b.wo_local(),
            BsdfAt::Mix(_, wo) | BsdfAt::Hair(_, wo) | BsdfAt::HairLobes(_, wo) => *wo,
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::bsdf::mix::{Lobe, MixBsdf};
    use crate::bsdf::{Bsdf, PbrBsdf};
    use crate::math::Rgb;
    use crate::scene::light_visibility::Excluded;
    use glam::Vec3;

    const NONE: Excluded = Excluded { diffuse: false, glossy: false, transmission: false };

    #[test]
    fn excluding_classes_removes_their_part_of_f() {
        // A dielectric Principled BSDF: diffuse base under a specular layer.
        let b = Bsdf::Pbr(PbrBsdf::new(Rgb::new(0.8, 0.5, 0.2), 0.0, 0.4));
        let wo = Vec3::new(0.3, -0.2, 0.9).normalize();
        let wi = Vec3::new(-0.4, 0.1, 0.8).normalize();
        let at = b.at(wo);
        let (f, fd) = (at.eval(wi), at.eval_diffuse(wi));
        assert!(fd.min_element() > 0.0 && (f - fd).min_element() > 0.0);
        assert_eq!(at.eval_visible(wi, NONE), f);
        let no_diffuse = at.eval_visible(wi, Excluded { diffuse: true, ..NONE });
        assert!((no_diffuse - (f - fd)).abs().max_element() < 1e-6);
        let no_glossy = at.eval_visible(wi, Excluded { glossy: true, ..NONE });
        assert!((no_glossy - fd).abs().max_element() < 1e-6);
        // Nothing transmits here: hiding transmission changes nothing.
        assert_eq!(at.eval_visible(wi, Excluded { transmission: true, ..NONE }), f);
    }

    #[test]
    fn glass_goes_only_with_glossy_and_transmission() {
        let mut m = MixBsdf::new();
        m.push(Rgb::splat(0.5), Lobe::Diffuse);
        m.push(
            Rgb::splat(0.5),
            Lobe::Dielectric(crate::bsdf::dielectric::DielectricBsdf::new(1.5, 0.5, false, Rgb::ONE)),
        );
        let b = Bsdf::Mix(m);
        let wo = Vec3::new(0.2, 0.1, 0.95).normalize();
        let at = b.at(wo);
        for wi in [Vec3::new(-0.3, 0.2, 0.9).normalize(), Vec3::new(-0.1, 0.1, -0.99).normalize()] {
            let (f, glass) = (at.eval(wi), at.eval_glass(wi));
            assert!(glass.max_element() > 0.0);
            assert_eq!(at.eval_visible(wi, Excluded { glossy: true, ..NONE }), f);
            assert_eq!(at.eval_visible(wi, Excluded { transmission: true, ..NONE }), f);
            let both = at.eval_visible(wi, Excluded { glossy: true, transmission: true, ..NONE });
            assert!((both - (f - glass)).abs().max_element() < 1e-6);
        }
    }
}
