//! Contacts (a glass resting on a floor) in BDPT and VCM: the paths the path tracer's look
//! back leaves in the integrand, and the strategies that can make them.
//!
//! The path tracer's walk (`walk.rs`, `PathState::coincident_hit`; Cycles skips only the
//! primitive a ray leaves) traps a path at a contact: a ray leaving a surface there lands on
//! the other surface at the same point, so from a contact vertex the walk goes on only to
//! its partner across the contact (a segment of length ~0, "the look back"), and the light
//! reaches it only by next-event estimation (`photon::contact` says the same for photons).
//! In path space, camera order z_k (camera) … z₀ (light), with z_i "at a contact" when
//! `photon::contact::at_contact` holds there:
//!
//! **A path is in the integrand only if every segment that leaves a contact vertex (in
//! camera order) goes to its partner by the look back, or to the light by a shadow ray
//! (next-event estimation: the contact vertex scatters through a non-delta lobe).**
//!
//! So the contact vertices of a path form its light end: z₁ … z_c (c ≥ 0 of them), the
//! first reached from anywhere, the others each the partner of the one before. Who makes
//! such a path (light-end-first strategy index j: z₀ … z_{j-1} from the light):
//! - the camera subpath walks with the look back, as the path tracer (it sets the state's
//!   `prev_tri`), so it makes the whole path and its s = 1 light sample at z₁ makes it;
//!   its s = 0 (a ray from z₁ finding the light) cannot: the look back holds the ray;
//! - a light subpath has no look back (in light order a path leaves a contact freely, but
//!   arrives at one only from the light: segment z₁z₀), so it may hold z₁ at a contact,
//!   straight from its light, and ends there if it scatters through a delta lobe (no
//!   shadow ray could have found the light from z₁); a light subpath that reaches a
//!   contact at its second or later vertex ends without storing it;
//! - connections (s, t ≥ 2) never leave a camera vertex at a contact (z_j would have to be
//!   its partner, a segment of length 0); merges (VCM) never take a camera vertex at a
//!   contact (the light vertex would have arrived there after a scattering).
//!
//! The path tracer weighs its next-event estimate at z₁ against BSDF sampling by the power
//! heuristic, as everywhere, though at a contact the BSDF-sampled ray is held by the look
//! back and never finds the light: its image (and Cycles') keeps only that share, p_L² /
//! (p_L² + p_B²), of light from a non-delta emitter at a contact (the world below a floor
//! a glass rests on, seen from the floor's underside). That share is a function of the path
//! (z₂, z₁, z₀: the BSDF's density at z₁ from z₂ toward z₀ and the path tracer's light
//! choice and sampling density there), so every strategy that makes such a path multiplies
//! it in ([`trap_weight`]): s = 1 at a camera vertex, a light subpath leaving z₁ (its
//! throughput from z₂ on), a connection to z₁ (s = 2) and light tracing from it.
//!
//! Hence the MIS weights (`mis::PathDensities::contacts`, c above): c = 0, every strategy
//! as usual; c = 1, all but s = 0 (j = 0); c ≥ 2, only s = 1 at z₁ (the look back's chain
//! is the camera subpath's alone), without merges. VCM's recursive merge weights start
//! their light side without s = 0 when z₁ is at a contact (`vcm::merge::push_records`).
//!
//! Approximations, as `photon::contact`'s: a vertex is at a contact by a test along its
//! normal among every still triangle (RayMask::ALL), while the walk's look back follows the
//! ray's direction and kind (a ray grazing the plane below 1/20 or an object hidden from
//! the ray's kind escapes the trap in the walk but is counted trapped here); an emitter
//! resting on a surface, which the walk's look back finds at its partner (s = 0 at length
//! 0), is given no weight; the path tracer's share at z₁ leaves out the subsurface part
//! of its BSDF density and is 1 for sphere lights (whose density BDPT does not model).

use super::vertex::{Kind, Vertex};
use crate::integrator::photon::contact::at_contact;
use crate::integrator::{SceneContext, power_heuristic};
use crate::light::Light;
use crate::light::origin as lights;
use crate::sampling::warp::uniform_cone_pdf;
use crate::scene::shading::SurfaceHit;
use crate::scene::visibility::RayMask;
use glam::Vec3;

/// Whether the surface hit `s` is at a contact for BDPT's and VCM's strategies (every ray
/// kind: the flag is the vertex's, the same whichever subpath made it).
#[inline]
pub(crate) fn on_contact(ctx: &SceneContext, s: &SurfaceHit) -> bool {
    at_contact(ctx, s, RayMask::ALL)
}

/// The number of contact vertices at the light end of a path, z₁ … z_c, with `vertex(j)`
/// giving z_j (z₀ the light, light end first) for 1 ≤ j < n.
#[inline]
pub(crate) fn light_end_contacts<'a>(n: usize, vertex: impl Fn(usize) -> &'a Vertex) -> usize {
    (1..n).take_while(|&j| vertex(j).contact).count()
}

/// The light end z₀ of a path as z₁ sees it.
#[derive(Clone, Copy, Debug)]
pub(crate) enum LightEnd {
    /// A point `q` with normal `n` on light `light`.
    Point { light: usize, q: Vec3, n: Vec3 },
    /// Light `light` at infinity in unit direction `d`.
    Direction { light: usize, d: Vec3 },
}

impl LightEnd {
    /// The light end of a light subpath: its first vertex (None: not a light vertex).
    #[inline]
    pub(crate) fn of(v0: &Vertex) -> Option<LightEnd> {
        let lp = v0.light?;
        let light = lp.light as usize;
        Some(match v0.kind {
            Kind::Infinite => LightEnd::Direction { light, d: v0.p },
            _ => LightEnd::Point { light, q: lp.p, n: lp.n },
        })
    }
}

/// The path tracer's share of the light z₀ gives the contact vertex z₁ toward `to_z2` (the
/// unit direction to the vertex before it in camera order): its next-event estimate's power
/// heuristic weight against the BSDF-sampled ray that the look back holds (module doc); 1
/// where z₁ is not at a contact, for delta and shadow-linked lights (next-event estimation
/// takes them whole) and for sphere lights.
#[inline]
pub(crate) fn trap_weight(ctx: &SceneContext, z1: &Vertex, to_z2: Vec3, end: LightEnd) -> f32 {
    let (Some(bsdf), Some(hit), true) = (z1.bsdf, z1.hit, z1.contact) else {
        return 1.0;
    };
    let light = match end {
        LightEnd::Point { light, .. } | LightEnd::Direction { light, .. } => light,
    };
    if lights::is_delta(ctx.scene, light) || ctx.shadow_linked(light) {
        return 1.0;
    }
    // The path tracer's light choice takes the normal on the side it arrived from, none
    // where the BSDF transmits (`path.rs`).
    let n_select = match (bsdf.transmits(), hit.ng.dot(to_z2) >= 0.0) {
        (true, _) => Vec3::ZERO,
        (false, true) => hit.ng,
        (false, false) => -hit.ng,
    };
    let (p_light, wi) = match end {
        LightEnd::Point { q, n, .. } => match ctx.scene.lights[light] {
            Light::Area(_) | Light::Triangle { .. } => {
                (ctx.light_pdf(light, hit.p, n_select, q, n), (q - hit.p).normalize_or_zero())
            }
            _ => return 1.0,
        },
        LightEnd::Direction { d, .. } => match ctx.scene.lights[light] {
            Light::World => (ctx.world_map_pdf(d), d),
            Light::Directional { cos_half, .. } => {
                (ctx.lights.pmf(hit.p, n_select, light) * uniform_cone_pdf(cos_half), d)
            }
            _ => return 1.0,
        },
    };
    let p_bsdf = bsdf.pdf(z1.frame.to_local(to_z2), z1.frame.to_local(wi));
    if p_light > 0.0 { power_heuristic(p_light, p_bsdf) } else { 0.0 }
}
