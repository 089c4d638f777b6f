//! The glTF material split by Cycles' closure classes for the light passes: the diffuse
//! part of f (the diffuse base, its Lambertian transmission and the sheen, which Cycles
//! counts as diffuse: Blender's importer makes the transmission a Translucent BSDF) and the
//! albedo of each class seen from wo (the Colour passes). Everything else the material
//! reflects is glossy (metal, specular layer, coat, glass reflection), and what its glass
//! transmits is transmission.

use super::PbrAt;
use crate::bsdf::microfacet::{fresnel_dielectric, schlick_weight};
use crate::math::Rgb;
use glam::Vec3;
use std::f32::consts::FRAC_1_PI;

impl PbrAt<'_> {
    /// The diffuse-class part of [`eval`](Self::eval): the diffuse base, its Lambertian
    /// transmission and the sheen, with the same layer, sheen and coat scaling.
    #[inline]
    pub fn eval_diffuse(&self, wi: Vec3) -> Rgb {
        let b = self.b;
        let wo = self.wo;
        if self.reflects_across(wi) {
            return Rgb::ZERO;
        }
        let wi = if self.flip { Vec3::new(wi.x, wi.y, -wi.z) } else { wi };
        if wi.z < 0.0 {
            return self.diffuse_transmission_up(wi);
        }
        if wo.z <= 0.0 || wi.z == 0.0 {
            return Rgb::ZERO;
        }
        let scaling = b.sheen_scaling_from(self.sheen_o, wi.z);
        let opaque = (1.0 - b.metallic) * (1.0 - b.transmission);
        let mut f = Rgb::ZERO;
        if opaque > 0.0 {
            let diffuse_weight =
                super::PbrBsdf::base_weight(self.eo) * (1.0 - b.subsurface) * (1.0 - b.diffuse_transmission);
            f = match b.oren {
                // Lambert's product in the order it always had (bit-exact golden images).
                None => b.diffuse * (diffuse_weight * FRAC_1_PI * b.diffuse_cos_ratio(wi) * opaque),
                Some(_) => b.diffuse_f(wo, wi, diffuse_weight * opaque),
            };
        }
        (f * scaling + b.sheen_eval(&self.fiber, wo, wi)) * self.under
    }

    /// The glass part of [`eval`](Self::eval) (the transmission lobe's reflection and
    /// refraction, a glass closure to Cycles), with the same sheen and coat scaling.
    #[inline]
    pub fn eval_glass(&self, wi: Vec3) -> Rgb {
        let b = self.b;
        let cut = b.cuts(wi).spec;
        let wi = if self.flip { Vec3::new(wi.x, wi.y, -wi.z) } else { wi };
        if b.transmission <= 0.0 || self.wo.z <= 0.0 || wi.z == 0.0 || cut {
            return Rgb::ZERO;
        }
        let scaling = b.sheen_scaling_from(self.sheen_o, wi.z.abs());
        b.glass.eval(self.wo, wi) * ((1.0 - b.metallic) * b.transmission) * scaling * self.under
    }

    /// wo as given to [`PbrBsdf::at`] (not flipped).
    #[inline]
    pub fn wo_local(&self) -> Vec3 {
        if self.flip { Vec3::new(self.wo.x, self.wo.y, -self.wo.z) } else { self.wo }
    }

    /// Albedo seen from wo per class (diffuse, glossy, transmission), as Cycles' Colour
    /// passes sum its closures' albedo estimates: the diffuse base (subsurface included,
    /// which Cycles counts as diffuse) under the specular layer, the sheen; the specular
    /// layer, the metal at Schlick's Fresnel, the coat and glass reflection; glass
    /// transmission (its tint times 1 − Fresnel).
    pub fn class_albedo(&self) -> [Rgb; 3] {
        let b = self.b;
        let wo = self.wo;
        if wo.z <= 0.0 {
            return [Rgb::ZERO; 3];
        }
        let below = self.under * self.sheen_o;
        let dielectric = 1.0 - b.metallic;
        let opaque = dielectric * (1.0 - b.transmission);
        let base = super::PbrBsdf::base_weight(self.eo) * opaque;
        let dt = b.diffuse_transmission;
        // The diffuse base's Lambertian transmission is diffuse, as Cycles files the
        // Translucent closure Blender's importer makes of it (the photon integrators follow
        // it by sampling all the same: `photon::lobes`).
        let diffuse_transmission = b.diffuse_transmission_color * (base * dt * (1.0 - b.subsurface)) * below;
        let diffuse = b.diffuse * (base * (1.0 - dt)) * below
            + b.sheen_color * (self.es / b.sheen_max.max(1e-6)) * self.under
            + diffuse_transmission;
        // The multiple-scattering compensation makes the metal's albedo its Fresnel colour.
        let metal = b.base + (Vec3::ONE - b.base) * schlick_weight(wo.z);
        let f_glass = fresnel_dielectric(wo.z, b.glass.eta);
        let glass = dielectric * b.transmission;
        let glossy =
            (self.eo * opaque + metal * b.metallic + Rgb::splat(f_glass * glass)) * below + Rgb::splat(self.ec);
        let transmission = b.glass.tint * ((1.0 - f_glass) * glass) * below;
        [diffuse, glossy, transmission]
    }

    /// True when the material transmits diffusely (`KHR_materials_diffuse_transmission`).
    #[inline]
    pub fn transmits_diffusely(&self) -> bool {
        self.b.transmits_diffusely()
    }
}
