//! Ray Visibility (objects, lights, the world: `scene::visibility`,
//! `scene::light_visibility`) for photons, which travel the camera paths' segments backwards.
//!
//! A camera path's ray from a vertex x has a kind (camera, or the kind of the lobe that
//! chose it: diffuse, glossy, transmission, volume) and passes every object hidden from
//! that kind. A photon segment y_j → y_{j+1} is, in camera order, a ray from y_{j+1} toward
//! y_j whose kind is set at y_{j+1} (by the lobe the photon scatters with there, or the
//! lobe a map read takes it with), which the photon does not know when it leaves y_j. So
//! a photon carries the set K of kinds that may still read or continue its segment:
//!
//! - **Leaving** y_j, K is the kinds that see y_j: a light's Ray Visibility (the world's
//!   for world photons; an emissive triangle's photons, like its next-event estimate, light
//!   every kind), the object's mask after a surface bounce, every kind after a scattering
//!   event in a medium (the camera side reaches it on its own terms).
//! - **Meeting** an object of mask M on the way, the photon may stop there (y_{j+1} is on
//!   that object: K is unchanged, the object's own mask only says which rays see it from
//!   elsewhere) or go on through it (the object lies between y_{j+1} and y_j, which only
//!   rays of a kind it hides from pass: K becomes K \ M). When both are possible the
//!   choice is random, each with probability ½ and the power doubled: unbiased, and the
//!   photon stays one path (no stack of branches); when only one is possible it is taken.
//!   Objects hidden from every kind are passed by the photon's traversal itself. The
//!   light's own segment y_0 → y_1 is different: the camera side takes it with next-event
//!   estimation's shadow ray (the only way to a delta light), so there an object lets the
//!   photon through, K unchanged, exactly when it is hidden from shadow rays. For a light
//!   that BSDF-sampled rays also find, the path tracer weighs the two ways by MIS, each
//!   with its own blockers; photons take the shadow ray's.
//! - **Stopping** there, the photon is stored with K's surface kinds (three bits of its
//!   record, `Photon::kinds`), and a map read counts it only through the BSDF classes whose
//!   rays have a kind in K ([`map_weight`]: reflected light through the diffuse class for
//!   the diffuse kind and the glossy classes for the glossy kind, light from the other side
//!   through every class for the transmission kind, as `RayMask::after_bounce` files rays).
//! - **Scattering** there, the photon's weight keeps only the classes whose kind is in K
//!   (the same rule on the sampled direction; a delta lobe by its kind), a subsurface walk
//!   leaves by a diffuse ray (as the path tracer's), and a medium event by a volume ray
//!   (`RayMask::AFTER_VOLUME`); then K starts again from the object's mask.
//!
//! Approximations, as the path tracer's own next-event estimate makes them: translucency
//! is a diffuse closure to the light passes' class split but a transmission ray to the
//! kinds, and a read splits a restricted photon's light into passes by the whole BSDF's
//! shares.

use super::lobes::Split;
use crate::bsdf::BsdfAt;
use crate::integrator::SceneContext;
use crate::math::Rgb;
use crate::scene::light_visibility::Excluded;
use crate::scene::visibility::RayMask;
use glam::Vec3;

/// The kinds a photon tracks: diffuse, glossy, transmission and volume rays (camera and
/// shadow rays never read a photon).
pub const PHOTON_KINDS: RayMask =
    RayMask(RayMask::DIFFUSE.0 | RayMask::GLOSSY.0 | RayMask::TRANSMISSION.0 | RayMask::VOLUME.0);

/// The kinds a read or a bounce at a surface can have.
pub const SURFACE_KINDS: RayMask = RayMask(RayMask::DIFFUSE.0 | RayMask::GLOSSY.0 | RayMask::TRANSMISSION.0);

/// The kinds that see light `light` (its Ray Visibility; every kind unless the context
/// honours it).
#[inline]
pub fn of_light(ctx: &SceneContext, light: usize) -> RayMask {
    let ex = ctx.light_excludes(light);
    let bit = |hidden: bool, k: RayMask| if hidden { 0 } else { k.0 };
    RayMask(
        bit(ex.diffuse, RayMask::DIFFUSE)
            | bit(ex.glossy, RayMask::GLOSSY)
            | bit(ex.transmission, RayMask::TRANSMISSION)
            | bit(!ctx.light_seen_in_volume(light), RayMask::VOLUME),
    )
}

/// The kinds that see the object of triangle `tri`, of those a photon tracks.
#[inline]
pub fn of_object(ctx: &SceneContext, tri: u32) -> RayMask {
    RayMask(ctx.object_rays(tri).0 & PHOTON_KINDS.0)
}

/// The classes a surface bounce on the side `reflected` leaves out for a photon readable
/// by `kinds` (None: no class; `Excluded::none()`: every class).
#[inline]
pub fn excluded(kinds: RayMask, reflected: bool) -> Option<Excluded> {
    if reflected {
        let (d, g) = (kinds.meets(RayMask::DIFFUSE), kinds.meets(RayMask::GLOSSY));
        // A glass closure reflects glossily: left out with the glossy kind.
        (d || g).then_some(Excluded { diffuse: !d, glossy: !g, transmission: !g })
    } else {
        kinds.meets(RayMask::TRANSMISSION).then_some(Excluded::default())
    }
}

/// True when every surface kind may read a photon of `kinds` (the usual case: no test).
#[inline]
pub fn all_surface(kinds: RayMask) -> bool {
    kinds.0 & SURFACE_KINDS.0 == SURFACE_KINDS.0
}

/// The diffuse-like part f_D (`lobes::Split`) through which a read at a vertex seen from
/// `at` (its outgoing direction's z `wo_z`, shading frame) takes a photon of `kinds`
/// arriving from `wi` (shading frame).
#[inline]
pub fn map_weight(split: Split, at: &BsdfAt, wo_z: f32, wi: Vec3, kinds: RayMask) -> Rgb {
    if all_surface(kinds) {
        return split.diffuse(at, wi);
    }
    match excluded(kinds, wi.z * wo_z > 0.0) {
        None => Rgb::ZERO,
        Some(ex) if ex.none() => split.diffuse(at, wi),
        Some(ex) => match split {
            Split::AllDiffuse => at.eval_visible(wi, ex),
            Split::ByClass if ex.diffuse => Rgb::ZERO,
            Split::ByClass => at.eval_diffuse(wi),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classes_follow_the_kinds_of_the_side() {
        let all = PHOTON_KINDS;
        assert!(excluded(all, true).is_some_and(Excluded::none));
        assert!(excluded(all, false).is_some_and(Excluded::none));
        let diffuse = RayMask::DIFFUSE;
        assert_eq!(excluded(diffuse, true), Some(Excluded { diffuse: false, glossy: true, transmission: true }));
        // Light from the other side comes through a transmission ray, whatever the lobe.
        assert_eq!(excluded(diffuse, false), None);
        assert!(excluded(RayMask::TRANSMISSION, false).is_some_and(Excluded::none));
        assert_eq!(excluded(RayMask::TRANSMISSION, true), None);
        let glossy = RayMask::GLOSSY;
        assert_eq!(excluded(glossy, true), Some(Excluded { diffuse: true, glossy: false, transmission: false }));
        assert!(all_surface(all) && !all_surface(RayMask(all.0 & !RayMask::GLOSSY.0)));
    }
}
