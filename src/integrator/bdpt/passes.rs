//! BDPT's and VCM's light passes and light groups: every strategy's contribution filed as
//! the path tracer files the same path (`integrator::light_passes`, Cycles' rule).
//!
//! A path of the strategy (s, t) has its camera vertex, then `cam[1..t]` and `light[..s]`.
//! Its first scattering event is the vertex after the camera: `cam[1]` when t ≥ 2 (its
//! class from the BSDF's diffuse and glossy shares toward the path's next vertex: the
//! sampled bounce's for t ≥ 3, the connection's or the light sample's for t = 2), the light
//! vertex `light[s-1]` for light tracing (t = 1, the BSDF evaluated toward the camera). The
//! contribution is direct when that is the path's only scattering vertex, indirect
//! otherwise; a path with none is Emission (or Environment, the world seen directly).
//! Merges (VCM) are filed by the camera vertex's class at the first scattering.
//!
//! The light group is the emitter's: the light the light subpath started at, the light
//! sampled by s = 1, or the emitter the camera subpath found (s = 0).

use super::*;
use crate::integrator::light_passes::shares_at;
use crate::passes::slot;
use crate::scene::light_groups::NONE;

/// The class of a path's first scattering event.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum First {
    /// At a surface: the BSDF's diffuse and glossy shares toward the next vertex
    /// (transmission: the rest).
    Surface(Rgb, Rgb),
    /// In a medium.
    Volume,
}

impl First {
    /// The path tracer's tally for a continuation of a camera path whose first event is of
    /// this class.
    pub(crate) fn tally(self) -> crate::integrator::light_passes::Tally {
        let shares = match self {
            First::Surface(d, g) => Some((d, g)),
            First::Volume => None,
        };
        crate::integrator::light_passes::Tally::continued(shares)
    }
}

impl Default for First {
    fn default() -> Self {
        First::Surface(Rgb::ONE, Rgb::ZERO)
    }
}

/// What the film keeps of BDPT's contributions besides Combined.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Ledger {
    /// The light passes (Diffuse/Glossy/Transmission/Volume Direct and Indirect, the
    /// Colour passes, Emission, Environment).
    pub light_passes: bool,
    /// One pass per light group.
    pub light_groups: bool,
}

/// Up to three `(slot, value)` parts of one contribution.
pub(crate) type Parts = ([(usize, Rgb); 3], usize);

/// The diffuse and glossy shares of the BSDF seen from wo toward local `wi`.
#[inline]
pub(crate) fn shares_seen(at: &crate::bsdf::BsdfAt, wi: Vec3) -> First {
    let (d, g) = shares_at(at, wi);
    First::Surface(d, g)
}

/// The class of a bounce sampled from a delta lobe: glossy when reflected, transmission
/// when refracted (as the path tracer files it).
#[inline]
pub(crate) fn delta_bounce(transmitted: bool) -> First {
    First::Surface(Rgb::ZERO, Rgb::splat(!transmitted as u8 as f32))
}

/// The light-pass parts of contribution `c` of a path with `events` scattering vertices
/// whose first is of class `first`; `world`: emitted by the world or a sun.
#[inline]
pub(crate) fn parts(events: usize, first: First, world: bool, c: Rgb) -> Parts {
    let none = (0, Rgb::ZERO);
    if events == 0 {
        return ([(if world { slot::ENV } else { slot::EMIT }, c), none, none], 1);
    }
    let direct = events == 1;
    match first {
        First::Surface(d, g) => {
            let (sd, sg, st) = match direct {
                true => (slot::DIFF_DIR, slot::GLOSS_DIR, slot::TRANS_DIR),
                false => (slot::DIFF_IND, slot::GLOSS_IND, slot::TRANS_IND),
            };
            ([(sd, d * c), (sg, g * c), (st, (Rgb::ONE - d - g) * c)], 3)
        }
        First::Volume => ([(if direct { slot::VOL_DIR } else { slot::VOL_IND }, c), none, none], 1),
    }
}

impl Ledger {
    /// True when anything besides Combined is kept.
    #[inline]
    pub(crate) fn any(self) -> bool {
        self.light_passes || self.light_groups
    }

    /// Files camera-side contribution `c` (see [`parts`]) from an emitter of light group
    /// `group` into the camera sample's passes.
    #[inline]
    pub(crate) fn file(self, out: &mut CameraSample, events: usize, first: First, world: bool, group: u8, c: Rgb) {
        if self.light_passes {
            let (p, n) = parts(events, first, world, c);
            for &(k, v) in &p[..n] {
                out.aov.add3(k, v);
            }
        }
        if self.light_groups && group != NONE {
            out.groups.add(group, c);
        }
    }

    /// The group of light `index` when groups are kept, else [`NONE`].
    #[inline]
    pub(crate) fn group_of_light(self, ctx: &SceneContext, index: usize) -> u8 {
        if self.light_groups { ctx.scene.light_groups.of_light(index) } else { NONE }
    }

    /// The group of the light a light subpath started at.
    #[inline]
    pub(crate) fn group_of_subpath(self, ctx: &SceneContext, light: &[Vertex]) -> u8 {
        match light.first().and_then(|v| v.light) {
            Some(lp) => self.group_of_light(ctx, lp.light as usize),
            None => NONE,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_split_by_class_and_count_of_events() {
        let c = Rgb::new(1.0, 2.0, 4.0);
        let (p, n) = parts(0, First::Volume, true, c);
        assert_eq!((n, p[0]), (1, (slot::ENV, c)));
        let (p, n) = parts(0, First::Volume, false, c);
        assert_eq!((n, p[0]), (1, (slot::EMIT, c)));
        let first = First::Surface(Rgb::splat(0.25), Rgb::splat(0.5));
        let (p, n) = parts(1, first, false, c);
        assert_eq!(n, 3);
        assert_eq!(p, [(slot::DIFF_DIR, c * 0.25), (slot::GLOSS_DIR, c * 0.5), (slot::TRANS_DIR, c * 0.25)]);
        let (p, _) = parts(3, first, false, c);
        assert_eq!([p[0].0, p[1].0, p[2].0], [slot::DIFF_IND, slot::GLOSS_IND, slot::TRANS_IND]);
        assert_eq!(parts(2, First::Volume, false, c).0[0], (slot::VOL_IND, c));
        // The parts always sum to the contribution (Combined).
        let s = p[..3].iter().fold(Rgb::ZERO, |a, (_, v)| a + *v);
        assert_eq!(s, c);
    }
}
