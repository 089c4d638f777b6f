//! Contacts: two surfaces in one plane facing apart, a glass resting on a floor (its
//! bottom face down, the floor up), and what the photon integrators do there so that
//! they carry the light the camera walk carries.
//!
//! The camera walk (`walk.rs`, `PathState::coincident_hit`) looks back across the surface
//! a ray leaves, as Cycles skips only the primitive it left: a ray leaving the glass's
//! bottom lands on the floor; one leaving the floor lands on the bottom face and, entering
//! the glass, on the floor's underside; one leaving the bottom face upwards (refracted in
//! or reflected) lands on the floor's underside again. A path that reaches a contact
//! never leaves it: it gathers direct light there (next-event estimation) and nothing
//! else. Cycles agrees (the floor under the glass is dark in both, tests/blender/
//! test_passes.py), so the photon integrators follow the same transport, mirrored:
//! - photon tracing (`trace.rs`): light reaches a contact only straight from its light, as
//!   NEE sees it: a photon arriving at one after a scattering, or at a specular surface
//!   there (no NEE), ends without being stored; a first hit on a non-specular surface is
//!   stored and goes on (a camera path may arrive at the contact from where it goes);
//! - map reads (`jensen.rs`): a read at a contact counts direct photons only (hit index
//!   1), so that no estimate reaches for light outside the contact that a path there
//!   could not get (the k nearest neighbours of an empty region lie around it).
//!
//! The test reaches as far as the look back: the ray offset's length on either side of
//! the surface (`math::offset_ray_origin`), among the still triangles.

use crate::integrator::SceneContext;
use crate::math::offset_ray_origin;
use crate::scene::shading::SurfaceHit;
use crate::scene::visibility::RayMask;

/// True when the surface hit `s` lies on a contact: a still triangle facing the other
/// way crosses its normal within the look back's reach of the hit point, seen by rays of
/// kind `ray`.
#[inline]
pub fn at_contact(ctx: &SceneContext, s: &SurfaceHit, ray: RayMask) -> bool {
    let mesh = &ctx.scene.mesh;
    // Strands (`CURVE_BIT` ids), and points with no opposite-facing triangle's box within
    // the look back's reach (which spans this ray): a floor under resting boxes casts it
    // only around their feet (it was 2.3 % of VCM's instructions on the Cornell box).
    if s.tri as usize >= mesh.triangles.len() || !ctx.accel.touches_at(s.tri, s.p) {
        return false;
    }
    let reach = (offset_ray_origin(s.p, s.ng) - s.p).length();
    if !(reach > 0.0) {
        return false;
    }
    let Some(hit) = ctx.intersect_still_except(s.p - s.ng * reach, s.ng, 2.0 * reach, ray, s.tri) else {
        return false;
    };
    // Facing apart, as the look back asks: a neighbour of the same mesh across an edge
    // faces the same way or sideways.
    let winding = |tri: u32| {
        let [a, b, c] = mesh.triangles[tri as usize].map(|i| mesh.positions[i as usize]);
        (b - a).cross(c - a)
    };
    winding(hit.tri).dot(winding(s.tri)) < 0.0
}
