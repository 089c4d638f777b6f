//! Light and shadow linking for the integrators that build paths from the lights too
//! (BDPT and VCM, photon tracing for Jensen and SPPM). The path tracer's rules are the
//! reference (`nee.rs`, `walk.rs`); in path space they read:
//!
//! - **Light linking** concerns only the segment that touches the light: a path whose light
//!   vertex x₀ is followed by x₁ counts only when the light lights x₁'s object (x₁ in a
//!   medium: `NO_OBJECT`). That is a property of the path, not of the strategy that made
//!   it, so every strategy drops the same paths and the MIS weights of the others still
//!   sum to one.
//! - **Shadow linking**: the segment x₀x₁ of a light with a blocker rule is stopped only by
//!   its blockers, unlike every other segment. Only a strategy that joins x₀ and x₁ by a
//!   shadow ray can test that, so the path tracer takes such a light by next-event
//!   estimation alone with weight 1, and by the ray that finds it only where next-event
//!   estimation cannot go (from the camera, after a delta lobe). BDPT and VCM do the same:
//!   s = 1 takes these paths whole, s = 0 takes the ones s = 1 cannot make, and light
//!   subpaths of such a light stop at their light vertex (no s ≥ 2, no t = 1, no merging).
//! - **Cast Shadow off** is shadow linking with an empty blocker set: nothing stops the
//!   segment x₀x₁ (nor do media dim it), so the same strategies take it ([`own_shadows`]).
//!   The path tracer (Cycles) skips the shadow ray of next-event estimation but weighs it
//!   by MIS as usual against the BSDF-sampled ray, which occluders still stop: where x₀x₁ is
//!   blocked it keeps only next-event estimation's share. BDPT and VCM take the whole
//!   unshadowed light there (s = 1 with weight 1), so they agree with the path tracer
//!   exactly for delta lights (points, spots, suns: next-event estimation's weight is 1)
//!   and where the segment is open, and are brighter than it in the shadow of an area light
//!   by the BSDF-sampled share the path tracer loses.
//! - **Photons** stand for x₀x₁x₂…: a photon whose first event is not on a receiver of its
//!   light is dropped there. A shadow-linked light's photon passes the surfaces that do not
//!   block it: it scatters at each one it lights and also goes on through it, as far as the
//!   first blocker, so that every surface on that segment gets the light's direct photons
//!   (light linking adds light; it need not conserve the light's power). A light with
//!   Cast Shadow off is again a shadow-linked light without blockers: its photons scatter
//!   at every surface on their first segment and go on through each.

use super::SceneContext;
use crate::scene::linking::NO_OBJECT;

/// How one strategy weighs a path that ends at a light, under linking.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Gate {
    /// The path gives nothing here (not linked, or another strategy takes it whole).
    Drop,
    /// This strategy takes the path with weight 1.
    Whole,
    /// Linking says nothing: the strategies' usual MIS weight.
    Mis,
}

impl Gate {
    /// The weight of the contribution given the usual MIS weight `mis`.
    #[inline]
    pub fn weight(self, mis: f32) -> f32 {
        match self {
            Gate::Drop => 0.0,
            Gate::Whole => 1.0,
            Gate::Mis => mis,
        }
    }
}

/// A camera-side path finds light `light` (s = 0) on a ray that left `from`: `None` for a
/// camera ray (which sees every emitter, as in Cycles), else the receiver it left (a
/// triangle or curve id, `NO_OBJECT` in a medium) and whether it left through a delta lobe.
#[inline]
pub fn found(ctx: &SceneContext, light: usize, from: Option<(u32, bool)>) -> Gate {
    match from {
        None if own_shadows(ctx, light) => Gate::Whole,
        None => Gate::Mis,
        Some((receiver, _)) if !ctx.links(light, receiver) => Gate::Drop,
        Some((_, delta)) if own_shadows(ctx, light) => {
            if delta {
                Gate::Whole
            } else {
                Gate::Drop
            }
        }
        Some(_) => Gate::Mis,
    }
}

/// Light `light` sampled from a non-delta vertex on `receiver` (s = 1).
#[inline]
pub fn sampled(ctx: &SceneContext, light: usize, receiver: u32) -> Gate {
    if !ctx.links(light, receiver) {
        Gate::Drop
    } else if own_shadows(ctx, light) {
        Gate::Whole
    } else {
        Gate::Mis
    }
}

/// True when light subpaths from light `light` go on past their light vertex (false for a
/// shadow-linked light or one with Cast Shadow off, whose paths s = 0 and s = 1 take whole).
#[inline]
pub fn light_subpaths_leave(ctx: &SceneContext, light: usize) -> bool {
    !own_shadows(ctx, light)
}

/// True when light subpaths start on light `light` and go on past it, so that VCM's volume
/// merging makes the paths that reach it from a medium vertex through delta bounces alone
/// (`vcm::volume_merge`) and the path tracer continued there leaves them out: not a soft
/// point light, an emitter reading the Light Path node (`bdpt::path_emitters`), a
/// shadow-linked light or one with Cast Shadow off.
#[inline]
pub fn merged_in_media(ctx: &SceneContext, light: usize) -> bool {
    ctx.scene.lights.get(light).is_some_and(|l| {
        crate::light::origin::starts_subpaths(l) && !crate::light::path_emitters::reads_light_path(ctx.scene, light)
    }) && light_subpaths_leave(ctx, light)
}

/// True when the segment from light `light` to the first vertex is stopped by a rule of
/// the light's own rather than by whatever lies between: shadow linking's blockers, or
/// none at all (Cast Shadow off). Only a shadow ray from that vertex can test it.
#[inline]
pub fn own_shadows(ctx: &SceneContext, light: usize) -> bool {
    ctx.shadow_linked(light) || !ctx.casts_shadow(light)
}

/// What a photon of light `light` does at its first event, on `receiver` (a triangle or
/// curve id; `NO_OBJECT`: in a medium).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FirstEvent {
    /// The light lights it: the photon is stored and scatters there.
    pub scatters: bool,
    /// It does not block the light (shadow linking, or the light's Cast Shadow is off):
    /// the photon also goes on through it.
    pub passes: bool,
}

/// The first event of a photon of light `light` on `receiver`.
#[inline]
pub fn photon_first_event(ctx: &SceneContext, light: usize, receiver: u32) -> FirstEvent {
    FirstEvent {
        scatters: ctx.links(light, receiver),
        passes: receiver != NO_OBJECT
            && (!ctx.casts_shadow(light) || (ctx.shadow_linked(light) && !ctx.blocks(light, receiver))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gate_weights() {
        assert_eq!(Gate::Drop.weight(0.3), 0.0);
        assert_eq!(Gate::Whole.weight(0.3), 1.0);
        assert_eq!(Gate::Mis.weight(0.3), 0.3);
    }
}
