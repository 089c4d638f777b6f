//! A strand shaded with the Principled Hair BSDF: the fibre's frame and its offset h, as
//! Cycles' `bsdf_hair_chiang_setup` builds them.

use crate::bsdf::Bsdf;
use crate::bsdf::hair::HairParams;
use crate::math::{Frame, Rgb};
use crate::scene::Scene;
use crate::scene::hit::{ShadingPoint, SurfaceHit};
use crate::shader::closure::Closures;
use glam::Vec3;

/// The hair frame for a fibre along unit `x` seen from `wo`: x along the fibre, z in the
/// plane across it toward the viewer, y = z × x. Cycles' (X, Y, Z) turned by π about the
/// fibre (its Z points away from the viewer), so that wo is on the frame's +z side as the
/// integrators expect; azimuths differ by π for every direction alike.
#[inline]
pub fn hair_frame(x: Vec3, wo: Vec3) -> Frame {
    let y = x.cross(wo).normalize_or(x.any_orthonormal_vector());
    let z = x.cross(y);
    Frame { s: x, t: -y, n: -z }
}

/// Turns a strand's surface hit into a hair fibre's, seen from `wo`: a fibre has no sides, so
/// its shading frame faces the viewer and the side tests (NEE, sampled bounces, ray offsets)
/// follow that frame's z (`ng` = `ns` = z); the point moves to the fibre's axis, inside the
/// strand, so that rays leaving it (reflected or transmitted) never meet the strand they leave,
/// as Cycles skips the primitive a ray leaves (the hair BSDF accounts for the whole fibre);
/// the offset h across the fibre, which only the hit's surface point gives, goes in `uv[1].x`
/// (the hair BSDF reads no texture coordinates).
pub fn as_fibre(s: &mut SurfaceHit, axis: Vec3, wo: Vec3) {
    let x = s.tangent.truncate();
    let z = hair_frame(x, wo).n;
    // h: the sine of the angle between the round normal and Cycles' Z (−z), seen along the
    // fibre: −1 and 1 at the two edges, 0 head-on.
    let h = s.ng.cross(x).dot(-z);
    s.uv[1] = glam::Vec2::new(h.clamp(-1.0, 1.0), 0.0);
    s.p = axis;
    s.ng = z;
    s.ns = z;
}

/// The shading point of strand hit `s` (a fibre, `as_fibre`) from a graph's hair closures `c`,
/// weights times `keep`: the Principled Hair BSDFs (their parameters averaged by weight), else
/// the Hair BSDF's lobes (a graph with both renders the Principled Hair BSDFs, warned at load).
pub fn hair_closures(c: &Closures, s: &SurfaceHit, wo: Vec3, keep: f32, emitted: Rgb) -> ShadingPoint {
    let frame = hair_frame(s.tangent.truncate(), wo);
    let bsdf = match c.hair_params() {
        Some(params) => Bsdf::Hair(params.at(s.uv[1].x).weighted(Rgb::splat(c.hair_w * keep))),
        None => {
            let mut lobes = c.hair_lobes.at(s.uv[1].x);
            for l in &mut lobes.lobes {
                l.weight *= keep;
            }
            Bsdf::HairLobes(lobes)
        }
    };
    ShadingPoint { bsdf, frame, emitted, holdout: c.holdout * keep }
}

impl Scene {
    /// The shading point of strand hit `s` (made a fibre by `as_fibre` in `Scene::surface`)
    /// with the hair parameters of its material.
    pub fn shade_hair(&self, params: &HairParams, s: &SurfaceHit, wo: Vec3) -> ShadingPoint {
        let frame = hair_frame(s.tangent.truncate(), wo);
        ShadingPoint { bsdf: Bsdf::Hair(params.at(s.uv[1].x)), frame, emitted: Rgb::ZERO, holdout: 0.0 }
    }
}
