//! A mixture split by Cycles' closure classes for the light passes: Diffuse,
//! Translucent and Sheen closures are diffuse (Cycles' `CLOSURE_IS_BSDF_DIFFUSE`), Glossy
//! and Metallic glossy, Glass reflection glossy and its refraction transmission; the
//! Principled part splits as [`PbrAt`](crate::bsdf::PbrAt) does.

use super::{Lobe, MixBsdf, Toon, upper};
use crate::bsdf::microfacet::fresnel_dielectric;
use crate::math::Rgb;
use glam::Vec3;

impl MixBsdf {
    /// The diffuse-class part of [`eval`](Self::eval).
    pub fn eval_diffuse(&self, wo: Vec3, wi: Vec3) -> Rgb {
        let mut f = if self.pbr_weight > 0.0 { self.pbr.at(wo).eval_diffuse(wi) * self.pbr_weight } else { Rgb::ZERO };
        let (wo, wi, _) = upper(wo, wi);
        if wo.z <= 0.0 {
            return f;
        }
        for k in 0..self.n as usize {
            if matches!(
                self.lobes[k],
                Lobe::Diffuse
                    | Lobe::OrenNayar(_)
                    | Lobe::Translucent
                    | Lobe::Sheen { .. }
                    | Lobe::Velvet(_)
                    | Lobe::Toon(Toon { glossy: false, .. })
            ) {
                f += self.weights[k] * self.lobes[k].eval(wo, wi);
            }
        }
        f
    }

    /// The glass part of [`eval`](Self::eval): the Principled part's and the Glass and
    /// Refraction lobes'.
    pub fn eval_glass(&self, wo: Vec3, wi: Vec3) -> Rgb {
        let mut f = if self.pbr_weight > 0.0 { self.pbr.at(wo).eval_glass(wi) * self.pbr_weight } else { Rgb::ZERO };
        let (wo, wi, _) = upper(wo, wi);
        if wo.z <= 0.0 {
            return f;
        }
        for k in 0..self.n as usize {
            if matches!(self.lobes[k], Lobe::Dielectric(_)) {
                f += self.weights[k] * self.lobes[k].eval(wo, wi);
            }
        }
        f
    }

    /// Albedo seen from wo per class (diffuse, glossy, transmission), for the Colour passes.
    pub fn class_albedo(&self, wo: Vec3) -> [Rgb; 3] {
        let mut c = if self.pbr_weight > 0.0 {
            self.pbr.at(wo).class_albedo().map(|v| v * self.pbr_weight)
        } else {
            [Rgb::ZERO; 3]
        };
        let (wo, _, _) = upper(wo, Vec3::Z);
        if wo.z <= 0.0 {
            return c;
        }
        for k in 0..self.n as usize {
            let w = self.weights[k];
            match &self.lobes[k] {
                Lobe::Diffuse
                | Lobe::OrenNayar(_)
                | Lobe::Translucent
                | Lobe::Sheen { .. }
                | Lobe::Velvet(_)
                | Lobe::Toon(Toon { glossy: false, .. }) => c[0] += w * self.lobes[k].albedo(wo),
                Lobe::Glossy { .. } | Lobe::AshikhminShirley(_) | Lobe::Toon(Toon { glossy: true, .. }) => {
                    c[1] += w * self.lobes[k].albedo(wo)
                }
                Lobe::Dielectric(d) => {
                    let f = fresnel_dielectric(wo.z, d.eta);
                    if d.refracts_only() {
                        // Cycles' Refraction BSDF: all of it refracts, unless it reflects totally.
                        c[2] += w * d.tint * if f >= 1.0 { 0.0 } else { 1.0 };
                    } else {
                        c[1] += w * f;
                        c[2] += w * d.tint * (1.0 - f);
                    }
                }
            }
        }
        c
    }
}
