//! A photon-map read at a camera-path vertex, split for the light passes and light groups
//! (issue 21): the same neighbours and cone weights as `estimate::estimate`, each photon's
//! share also summed by the BSDF class of its arrival direction (at the camera path's first
//! vertex, where the read decides the pass) and by its light's group.
//!
//! Class of a photon arriving from `wi` at the first vertex: the path tracer files light
//! from `wi` by the whole BSDF's shares there (`light_passes::shares`: diffuse f_dc / f,
//! glossy the reflected rest, transmission the transmitted rest). The map stands for the
//! diffuse-like part f_D and the camera path's sampled continuation for the glossy part f_G
//! with the same shares at its direction, so filing f_D's light by those shares too makes
//! each pass's expectation ∫ share · (f_D + f_G) L = the path tracer's ∫ share · f L.

use super::estimate::{estimate, estimate_each};
use super::{Photon, PhotonMap};
use crate::bsdf::BsdfAt;
use crate::integrator::light_passes::shares_at;
use crate::math::{Frame, Rgb};
use crate::scene::light_groups::GroupSums;
use glam::Vec3;

/// What a split read files besides its total.
#[derive(Clone, Copy)]
pub struct Want<'a> {
    /// Split by class with the BSDF seen from here, in the shading `frame` (the first vertex).
    pub classes: Option<(&'a BsdfAt<'a>, &'a Frame)>,
    /// Split by light group.
    pub groups: bool,
}

/// A map read: the total radiance and, when asked, its split.
pub struct MapRead {
    /// Σ f_D Φ w over the disc, as `estimate`.
    pub total: Rgb,
    /// The total by class: diffuse, glossy, transmission (only when asked).
    pub classes: [Rgb; 3],
    /// The total by light group (only when asked).
    pub groups: GroupSums,
}

/// Reads `map` at `q` (normal `n`) with k neighbours within `max_r2`, weighting photons by
/// `weight` (f_D at their direction) and splitting as `want` says.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn read(
    map: &PhotonMap,
    q: Vec3,
    n: Vec3,
    k: usize,
    max_r2: f32,
    filter: impl Fn(&Photon) -> bool,
    weight: impl Fn(&Photon) -> Rgb,
    want: Want<'_>,
) -> MapRead {
    let mut r = MapRead { total: Rgb::ZERO, classes: [Rgb::ZERO; 3], groups: GroupSums::default() };
    if want.classes.is_none() && !want.groups {
        // The plain read: the same sums as the renders without passes, bit for bit.
        r.total = estimate(map, q, n, k, max_r2, filter, weight).0;
        return r;
    }
    let mut sum = Rgb::ZERO;
    let (norm, _) = estimate_each(map, q, n, k, max_r2, filter, |i, p, w| {
        let c = weight(p) * p.power() * w;
        sum += c;
        if let Some((at, frame)) = want.classes {
            let (d, g) = shares_at(at, frame.to_local(p.wi()));
            r.classes[0] += d * c;
            r.classes[1] += g * c;
            r.classes[2] += (Rgb::ONE - d - g) * c;
        }
        if want.groups {
            r.groups.add(map.group(i), c);
        }
    });
    r.total = sum * norm;
    for c in &mut r.classes {
        *c *= norm;
    }
    for g in &mut r.groups.0 {
        for x in g.iter_mut() {
            *x *= norm;
        }
    }
    r
}
