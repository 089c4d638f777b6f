//! Which part of a BSDF the photon maps stand for (Jensen's rule: maps are read at
//! diffuse-like surfaces only; glossy and specular scattering is followed by sampling).
//!
//! A BSDF f splits into a **diffuse-like** part f_D, which photon density estimates
//! represent well (their blur is hidden by a wide lobe), and a **glossy** part
//! f_G = f − f_D, which a camera or gather path continues by sampling (a narrow lobe
//! times a few photons is noise, not an estimate). The rule:
//!
//! - Cycles' diffuse-class closures (diffuse base, translucent, sheen) are diffuse-like
//!   (`BsdfAt::eval_diffuse`);
//! - a glTF material whose every reflection lobe is rough, GGX α = roughness² ≥
//!   [`ROUGH_ALPHA`] for the base and for the coat when it has one, and which does not
//!   transmit, is diffuse-like as a whole: its specular layer is as wide as a cosine lobe
//!   and gains nothing from being continued (the Cornell box's walls, roughness 1);
//! - every other lobe is glossy: metal, specular and coat below the threshold, glass,
//!   hair. A rough transmitting material stays glossy because photons are gathered on
//!   the viewer's side only (the normal test in `estimate.rs`), so a map read there
//!   would miss the light from behind. For the same reason a Translucent BSDF's light,
//!   which comes from the other side, is glossy here too (its value toward the viewer's side
//!   is 0): it is followed by sampling, as glTF's diffuse transmission is. Before, a leaf
//!   lit from behind and the floor it lights were 0.25–0.9 of the path tracer's in Jensen
//!   and SPPM.
//!
//! The same split classifies photon paths (`trace.rs`): a photon's scattering counts
//! as glossy for the fraction f_G / f of its weight, so the caustic map (paths whose
//! every scattering was glossy or specular, L {G|S}+ D) holds exactly what a camera
//! vertex's f_D does not get from the global map through a gather ray.

use crate::bsdf::{Bsdf, BsdfAt};
use crate::math::Rgb;
use glam::Vec3;

/// GGX α at and above which a glTF material's reflection lobes are diffuse-like.
/// α = 0.5 (perceptual roughness 0.71): the GGX lobe's half-width is then about 45°,
/// comparable to a cosine lobe's 60°, so a density estimate over it blurs no more
/// than the diffuse base's does; below, highlights narrow quickly (α = 0.1: ~10°).
pub const ROUGH_ALPHA: f32 = 0.5;

/// How a BSDF splits into its diffuse-like and glossy parts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Split {
    /// The whole (non-delta) BSDF is diffuse-like.
    AllDiffuse,
    /// The diffuse-class closures are diffuse-like, the rest glossy.
    ByClass,
}

impl Split {
    /// The split of `bsdf`.
    #[inline]
    pub fn of(bsdf: &Bsdf) -> Split {
        match bsdf {
            Bsdf::Pbr(b) => {
                let rough = |r: f32| r * r >= ROUGH_ALPHA;
                if rough(b.roughness) && (b.coat <= 0.0 || rough(b.coat_roughness)) && !b.transmits() {
                    Split::AllDiffuse
                } else {
                    Split::ByClass
                }
            }
            Bsdf::Mix(_) | Bsdf::Hair(_) | Bsdf::HairLobes(_) => Split::ByClass,
        }
    }

    /// f_D(wo, wi) for a non-delta direction (the glossy part is `at.eval(wi)` minus it).
    #[inline]
    pub fn diffuse(self, at: &BsdfAt, wi: Vec3) -> Rgb {
        match self {
            Split::AllDiffuse => at.eval(wi),
            Split::ByClass if reflects(at, wi) => at.eval_diffuse(wi),
            Split::ByClass => Rgb::ZERO,
        }
    }

    /// The diffuse-like part of a sampled value `f` at `wi` (zero for a delta sample,
    /// whose lobe is specular), clamped to `f` so that the glossy rest is never negative.
    #[inline]
    pub fn diffuse_of_sample(self, at: &BsdfAt, wi: Vec3, f: Rgb, delta: bool) -> Rgb {
        if delta {
            return Rgb::ZERO;
        }
        match self {
            Split::AllDiffuse => f,
            Split::ByClass if reflects(at, wi) => at.eval_diffuse(wi).min(f).max(Rgb::ZERO),
            Split::ByClass => Rgb::ZERO,
        }
    }

    /// True when the BSDF seen from `at` has a diffuse-like part at all.
    #[inline]
    pub fn has_diffuse(self, at: &BsdfAt) -> bool {
        self.parts(at).0
    }

    /// Whether the BSDF seen from `at` has (a diffuse-like part, a glossy part), from
    /// its albedo per closure class.
    #[inline]
    pub fn parts(self, at: &BsdfAt) -> (bool, bool) {
        match self {
            Split::AllDiffuse => (true, false),
            Split::ByClass => {
                let [d, g, t] = at.class_albedo();
                let translucent = match at {
                    BsdfAt::Mix(m, _) => m.has_translucent(),
                    BsdfAt::Pbr(b) => b.transmits_diffusely(),
                    _ => false,
                };
                (d.max_element() > 0.0, (g + t).max_element() > 0.0 || translucent)
            }
        }
    }
}

/// Whether `wi` is on the viewer's side of the BSDF's frame (always for hair, whose
/// diffuse-class part is empty): the photon maps stand for light from that side, so a
/// diffuse-class lobe that transmits (Translucent, glTF's diffuse transmission) is followed.
#[inline]
fn reflects(at: &BsdfAt, wi: Vec3) -> bool {
    match at {
        BsdfAt::Mix(_, wo) => wo.z * wi.z > 0.0,
        BsdfAt::Pbr(b) => b.wo_local().z * wi.z > 0.0 || b.reflects_across(wi),
        _ => true,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::pbr::PbrBsdf;
    use glam::Vec2;

    fn pbr(metallic: f32, roughness: f32) -> Bsdf {
        Bsdf::Pbr(PbrBsdf::new(Rgb::new(0.6, 0.4, 0.2), metallic, roughness))
    }

    /// The split follows the stated rule: rough dielectrics whole, metals and smooth
    /// dielectrics by class; f_D ≤ f and a metal has no diffuse-like part.
    #[test]
    fn split_rule() {
        assert_eq!(Split::of(&pbr(0.0, 1.0)), Split::AllDiffuse);
        assert_eq!(Split::of(&pbr(0.0, 0.71)), Split::AllDiffuse);
        assert_eq!(Split::of(&pbr(0.0, 0.7)), Split::ByClass);
        assert_eq!(Split::of(&pbr(0.0, 0.15)), Split::ByClass);
        assert_eq!(Split::of(&pbr(1.0, 0.25)), Split::ByClass);
        let wo = Vec3::new(0.3, 0.1, 0.9).normalize();
        for (m, r) in [(0.0, 0.15), (1.0, 0.25), (0.0, 1.0)] {
            let b = pbr(m, r);
            let at = b.at(wo);
            let split = Split::of(&b);
            assert_eq!(split.parts(&at), (m < 1.0, r < 0.71), "metallic {m} roughness {r}");
            for i in 0..64 {
                let u = Vec2::new((i % 8) as f32 / 8.0 + 0.06, (i / 8) as f32 / 8.0 + 0.06);
                let wi = crate::sampling::warp::cosine_hemisphere(u);
                let f = at.eval(wi);
                let fd = split.diffuse_of_sample(&at, wi, f, false);
                assert!(fd.cmple(f + Rgb::splat(1e-6)).all() && fd.cmpge(Rgb::ZERO).all(), "{fd} {f}");
                if m == 1.0 {
                    assert_eq!(fd, Rgb::ZERO);
                }
            }
        }
    }

    /// glTF's diffuse transmission is diffuse-class (the light passes file it as Cycles'
    /// Translucent), but its light comes from behind, where the maps hold nothing: it must
    /// stay a followed lobe, read from the maps on the viewer's side only.
    #[test]
    fn diffuse_transmission_is_followed() {
        use crate::bsdf::pbr::PbrParams;
        let b = Bsdf::Pbr(PbrBsdf::from_params(&PbrParams {
            diffuse_transmission: 0.8,
            ..PbrParams::opaque(Rgb::new(0.6, 0.4, 0.2), 0.0, 1.0)
        }));
        let wo = Vec3::new(0.3, 0.1, 0.9).normalize();
        let at = b.at(wo);
        let split = Split::of(&b);
        assert_eq!(split, Split::ByClass);
        assert_eq!(split.parts(&at), (true, true));
        let through = Vec3::new(-0.2, 0.3, -0.93).normalize();
        let f = at.eval(through);
        assert!(at.eval_diffuse(through).min_element() > 0.0);
        assert_eq!(split.diffuse(&at, through), Rgb::ZERO);
        assert_eq!(split.diffuse_of_sample(&at, through, f, false), Rgb::ZERO);
        let above = Vec3::new(-0.2, 0.3, 0.93).normalize();
        assert!(split.diffuse(&at, above).min_element() > 0.0);
    }
}
