//! A mixture split by Cycles' closure classes for the light passes: Diffuse,
//! Translucent and Microfiber Sheen closures are diffuse (Cycles' `CLOSURE_IS_BSDF_DIFFUSE`),
//! Glossy, Metallic and the Ashikhmin Velvet glossy (`CLOSURE_IS_BSDF_GLOSSY`), Glass reflection glossy and its refraction transmission; each
//! Principled part splits as [`PbrAt`](crate::bsdf::PbrAt) does. Every part is seen in its
//! own frame, as in [`MixBsdf::eval`].

use super::{Lobe, MAX_PBR, MixBsdf, Toon, into_frame, upper};
use crate::bsdf::microfacet::fresnel_dielectric;
use crate::math::Rgb;
use glam::Vec3;

impl MixBsdf {
    /// The diffuse-class part of [`eval`](Self::eval).
    pub fn eval_diffuse(&self, wo: Vec3, wi: Vec3) -> Rgb {
        self.eval_by(wo, wi, |p, wo, wi| p.at(wo).eval_diffuse(wi), Lobe::is_diffuse_class)
    }

    /// The glass part of [`eval`](Self::eval): the Principled parts' and the Glass and
    /// Refraction lobes'.
    pub fn eval_glass(&self, wo: Vec3, wi: Vec3) -> Rgb {
        self.eval_by(wo, wi, |p, wo, wi| p.at(wo).eval_glass(wi), |l| matches!(l, Lobe::Dielectric(_)))
    }

    /// Albedo seen from wo per class (diffuse, glossy, transmission), for the Colour passes.
    pub fn class_albedo(&self, wo: Vec3) -> [Rgb; 3] {
        let mut c = [Rgb::ZERO; 3];
        for j in 0..MAX_PBR {
            let w = self.pbr_weights[j];
            if w > 0.0 {
                let a = self.pbr[j].at(into_frame(&self.pbr_frames[j], wo)).class_albedo();
                for (c, a) in c.iter_mut().zip(a) {
                    *c += a * w;
                }
            }
        }
        let (wo, _, _) = upper(wo, Vec3::Z);
        if wo.z <= 0.0 {
            return c;
        }
        for k in 0..self.n as usize {
            let w = self.weights[k];
            let wo = into_frame(&self.frames[k], wo);
            let l = &self.lobes[k];
            if wo.z <= 0.0 {
                if l.view_free() {
                    c[0] += w;
                }
                continue;
            }
            match l {
                Lobe::Diffuse
                | Lobe::OrenNayar(_)
                | Lobe::Translucent
                | Lobe::Sheen { .. }
                | Lobe::Toon(Toon { glossy: false, .. }) => c[0] += w * l.albedo(wo),
                // The Ashikhmin Velvet is in Cycles' glossy range (`CLOSURE_IS_BSDF_GLOSSY`).
                Lobe::Glossy { .. }
                | Lobe::AshikhminShirley(_)
                | Lobe::Velvet(_)
                | Lobe::Toon(Toon { glossy: true, .. }) => c[1] += w * l.albedo(wo),
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
