//! Light Paths' per-kind bounce limits (Diffuse, Glossy, Transmission, Volume Bounces) in
//! BDPT and VCM, exactly as the path tracer (`integrator::light_paths`, Cycles' kernel)
//! keeps or drops each path, whatever strategy made it.
//!
//! The rule: in camera order a path x₀ (camera) … xₙ (on the emitter) has the scattering
//! vertices x₁ … xₙ₋₁. The path tracer counts a bounce at xᵢ by the class of the lobe it
//! sampled there (diffuse, glossy; every crossing of the surface as transmission; medium
//! scattering as volume) and stops at a vertex reached after some count passed its limit:
//! it still finds the emission there but makes no next-event estimate and no bounce. So
//! the path is kept iff the counts over x₁ … xₙ₋₂ are within the limits: xₙ₋₁, the vertex
//! next to the emitter, is never counted (its bounce or light sample reaches the emitter
//! either way). Light subpaths count from their third vertex on for that reason.
//!
//! Which class a bounce at xᵢ has depends on the sampled lobe: given the path's directions
//! it is random, with the path tracer's probability p_c pdf_c(ωᵢ)/Σ p pdf (one lobe sampled,
//! f and the density the mixture's), so the path tracer's expectation is ∫ f(path) ×
//! P[the class draws keep it]. Where the geometry fixes every class — a crossing is
//! transmission; a reflection at a BSDF that reflects in one class only (a Diffuse, a
//! Glossy, a metal, glass) is that class — P is 0 or 1, a property of the path that every
//! strategy computes alike: each contribution is kept or dropped by it, and the MIS
//! weights, which sum to one over the strategies that make the path, stay exact (the
//! camera side stops only where a kept path could not go on, so every strategy still makes
//! every kept path). At a *mixed* vertex (a reflection where the BSDF reflects both
//! diffusely and glossily, a Principled BSDF) the class is the sampled lobe's. A path
//! whose verdict is the same for every assignment of its mixed vertices' classes is
//! still kept or dropped as above; an *ambiguous* one (kept for some assignments, not
//! others) is made by the camera side alone, s = 0 and s = 1 weighed against each other as
//! next-event estimation and BSDF sampling (`visibility`'s restricted paths), each kept by
//! the classes its camera subpath sampled: exactly the path tracer's estimate of it. Every
//! path is in one of the two disjoint sets whatever strategy looks at it, so the sum is
//! exact. Ambiguity needs more counted vertices than the least binding limit, so short
//! paths keep all of BDPT's strategies.
//!
//! A strand (hair BSDF) and a material with subsurface scattering count as mixed.

use crate::bsdf::Bsdf;
use crate::bsdf::mix::Lobe;
use crate::integrator::light_paths::{LightPaths, NO_LIMIT};

/// How a surface vertex's BSDF reflects (crossings are transmission whatever it is).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) enum Reflection {
    /// Diffuse-class lobes only (or none).
    #[default]
    Diffuse,
    /// Glossy-class lobes only (singular ones included).
    Glossy,
    /// Both: the class of a reflection is the sampled lobe's.
    Mixed,
}

impl Reflection {
    /// The reflection classes of `bsdf`, from its weights alone (the same from either side
    /// and every direction, so every strategy reads the same at a vertex).
    pub(crate) fn of(bsdf: &Bsdf) -> Reflection {
        let (diffuse, glossy) = match bsdf {
            Bsdf::Pbr(b) => pbr_classes(b),
            Bsdf::Mix(m) => {
                let mut dg = (false, false);
                for (lobe, w) in m.lobes.iter().zip(&m.weights).take(m.n as usize) {
                    if w.max_element() <= 0.0 {
                        continue;
                    }
                    match lobe {
                        Lobe::Diffuse | Lobe::OrenNayar(_) | Lobe::Sheen { .. } | Lobe::Velvet(_) => dg.0 = true,
                        Lobe::Toon(t) if !t.is_glossy() => dg.0 = true,
                        // Lambertian transmission: a crossing, transmission by the geometry.
                        Lobe::Translucent => {}
                        _ => dg.1 = true,
                    }
                }
                for (b, w) in m.pbr.iter().zip(&m.pbr_weights) {
                    if *w > 0.0 {
                        let (d, g) = pbr_classes(b);
                        dg = (dg.0 || d, dg.1 || g);
                    }
                }
                dg
            }
            // Strands: their class follows the fibre's lobes, which only the camera side samples.
            Bsdf::Hair(_) | Bsdf::HairLobes(_) => (true, true),
        };
        match (diffuse, glossy) {
            (true, true) => Reflection::Mixed,
            (false, true) => Reflection::Glossy,
            _ => Reflection::Diffuse,
        }
    }
}

/// A Principled part's (diffuse, glossy) reflection: diffuse where its opaque dielectric
/// base, sheen or subsurface has weight (subsurface counts as mixed: its walk's classes are
/// the path tracer's), glossy where the metal, the glass, the coat or the opaque base's
/// specular layer (`specular` 0: none) has weight.
fn pbr_classes(b: &crate::bsdf::pbr::PbrBsdf) -> (bool, bool) {
    let opaque = (1.0 - b.metallic) * (1.0 - b.transmission);
    let diffuse = opaque > 0.0 && b.diffuse.max_element() > 0.0;
    let sheen = b.sheen_color.max_element() > 0.0;
    let glossy = b.metallic > 0.0 || b.transmission > 0.0 || b.coat > 0.0 || (opaque > 0.0 && b.specular > 0.0);
    (diffuse || sheen || b.subsurface > 0.0 || !glossy, glossy || b.subsurface > 0.0)
}

/// Bounce counts by class over part of a path; `mixed`: reflections at mixed vertices.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Classes {
    diffuse: u8,
    glossy: u8,
    transmission: u8,
    volume: u8,
    mixed: u8,
}

/// What the limits make of a path (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Verdict {
    /// Within the limits for every class of its mixed vertices.
    Kept,
    /// Past a limit for every class of its mixed vertices.
    Dropped,
    /// Kept for some classes of its mixed vertices: the camera side's alone.
    Ambiguous,
}

impl Classes {
    /// These counts and one bounce at a vertex reflecting as `r` (`transmitted`: crossing).
    #[inline]
    pub(crate) fn with_bounce(mut self, r: Reflection, transmitted: bool) -> Classes {
        let slot = match (transmitted, r) {
            (true, _) => &mut self.transmission,
            (false, Reflection::Diffuse) => &mut self.diffuse,
            (false, Reflection::Glossy) => &mut self.glossy,
            (false, Reflection::Mixed) => &mut self.mixed,
        };
        *slot = slot.saturating_add(1);
        self
    }

    /// The sum of two parts' counts.
    #[inline]
    pub(crate) fn plus(self, o: Classes) -> Classes {
        Classes {
            diffuse: self.diffuse.saturating_add(o.diffuse),
            glossy: self.glossy.saturating_add(o.glossy),
            transmission: self.transmission.saturating_add(o.transmission),
            volume: self.volume.saturating_add(o.volume),
            mixed: self.mixed.saturating_add(o.mixed),
        }
    }

    /// The verdict of `lp` on a path whose counted bounces are these.
    #[inline]
    pub(crate) fn verdict(self, lp: &LightPaths) -> Verdict {
        let limit = |n: u32| if n == NO_LIMIT { i64::MAX / 4 } else { n as i64 };
        let (d, g, m) = (self.diffuse as i64, self.glossy as i64, self.mixed as i64);
        if self.transmission as i64 > limit(lp.transmission) || self.volume as i64 > limit(lp.volume) {
            return Verdict::Dropped;
        }
        // k of the m mixed bounces diffuse: kept iff d + k ≤ D and g + m − k ≤ G.
        let lo = (g + m - limit(lp.glossy)).max(0);
        let hi = m.min(limit(lp.diffuse) - d);
        if lo > hi {
            Verdict::Dropped
        } else if lo == 0 && hi == m {
            Verdict::Kept
        } else {
            Verdict::Ambiguous
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lp(diffuse: u32, glossy: u32) -> LightPaths {
        LightPaths { diffuse, glossy, transmission: 1, ..LightPaths::UNLIMITED }
    }

    #[test]
    fn fixed_classes_keep_or_drop() {
        let two_diffuse =
            Classes::default().with_bounce(Reflection::Diffuse, false).with_bounce(Reflection::Diffuse, false);
        assert_eq!(two_diffuse.verdict(&lp(2, 0)), Verdict::Kept);
        assert_eq!(two_diffuse.verdict(&lp(1, 9)), Verdict::Dropped);
        let crossings = Classes::default().with_bounce(Reflection::Mixed, true).with_bounce(Reflection::Diffuse, true);
        assert_eq!(crossings.verdict(&lp(0, 0)), Verdict::Dropped, "two crossings past Transmission 1");
        assert_eq!(Classes::default().verdict(&lp(0, 0)), Verdict::Kept);
    }

    #[test]
    fn mixed_vertices_are_ambiguous_only_where_their_class_matters() {
        let one = Classes::default().with_bounce(Reflection::Mixed, false);
        assert_eq!(one.verdict(&lp(1, 1)), Verdict::Kept);
        assert_eq!(one.verdict(&lp(1, 0)), Verdict::Ambiguous);
        assert_eq!(one.verdict(&lp(0, 0)), Verdict::Dropped);
        let two = one.with_bounce(Reflection::Mixed, false).with_bounce(Reflection::Glossy, false);
        // g = 1 fixed: at most one more glossy, at most one diffuse: k = 1 only.
        assert_eq!(two.verdict(&lp(1, 2)), Verdict::Ambiguous);
        assert_eq!(two.verdict(&lp(0, 1)), Verdict::Dropped);
        assert_eq!(two.verdict(&lp(4, 4)), Verdict::Kept);
    }
}
