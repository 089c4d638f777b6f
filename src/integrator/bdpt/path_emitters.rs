//! Emitters whose node graph reads the Light Path node (`light::path_emitters`), in BDPT
//! and VCM. Such an emitter's radiance depends on the camera path that reaches it (Is
//! Camera Ray, Ray Depth, the last bounce's kind): the path tracer evaluates it with the
//! state of the ray that hits it, and next-event estimation with the shading point's
//! (Cycles' `light_sample_shader_eval`). A light subpath cannot know that state, so the
//! strategies that start on the light (s ≥ 2, light tracing t = 1, merging) would estimate
//! a different integrand, and their MIS sum with s = 0 and s = 1 would be wrong.
//!
//! These emitters are therefore taken by the camera side alone, as the path tracer takes
//! them: light subpaths never start on them (`BdptLights::starts`), the camera subpath
//! finding one (s = 0) is weighed only against next-event estimation, and s = 1 toward
//! them is the path tracer's next-event estimation at the camera vertex — its light choice
//! (`ctx.lights`), its density and its power-heuristic weight against BSDF sampling, with
//! the vertex's path state — counting only these emitters (BDPT's own light choice
//! leaves them out). The two strategies thus weigh every such path exactly as the path
//! tracer does, which matters where next-event estimation and the ray that hits the
//! emitter read it differently (Is Diffuse Ray: Cycles' answer is the MIS-weighted sum).
//! Light linking's gates (`linking`) apply as to any light.

use super::*;
use crate::integrator::linking::{self, Gate};

impl BdptIntegrator {
    /// MIS weight of s = 0 for the camera subpath `cam` whose last vertex lies on emitter
    /// `index` (which reads the Light Path node), reached from the vertex before through a
    /// delta lobe (`prev_delta`) or with solid-angle density `pdf_sa`: BSDF sampling against
    /// [`connect_path_emitter`](Self::connect_path_emitter)'s light sampling.
    pub(super) fn weight_s0_path_emitter(
        &self,
        ctx: &SceneContext,
        cam: &[Vertex],
        index: usize,
        prev_delta: bool,
        pdf_sa: f32,
    ) -> f32 {
        let t = cam.len();
        let (z0, z1) = (&cam[t - 1], &cam[t - 2]);
        if z1.kind == Kind::Camera || prev_delta {
            return 1.0;
        }
        let p_light = ctx.light_pdf(index, z1.p, selection_normal(z1), z0.p, z0.ng);
        power_heuristic(pdf_sa, p_light)
    }

    /// s = 1 toward the emitters that read the Light Path node, at camera vertex
    /// `cam[t-1]` (see the module's doc); files the contribution into the ledger and
    /// returns it. `u`: the light choice and the point on the light.
    pub(super) fn connect_path_emitter(
        &self,
        ctx: &SceneContext,
        t: usize,
        u: [f32; 3],
        scratch: &BdptScratch,
        out: &mut CameraSample,
        stats: &mut RayStats,
    ) -> Rgb {
        let x = &scratch.cam[t - 1];
        let (Some(bsdf), Some(hit)) = (x.bsdf, x.hit) else {
            return Rgb::ZERO;
        };
        if bsdf.is_delta() {
            return Rgb::ZERO;
        }
        // The path tracer's light choice: a light that does not read the Light Path node
        // is `light_sample_at`'s, so this estimate of the others is left unchanged.
        let Some((index, pmf)) = ctx.lights.sample(x.p, selection_normal(x), u[0]) else {
            return Rgb::ZERO;
        };
        if !self.lights.reads_path(index) {
            return Rgb::ZERO;
        }
        let gate = linking::sampled(ctx, index, hit.tri);
        if gate == Gate::Drop {
            return Rgb::ZERO;
        }
        // The emitter as next-event estimation from this vertex sees it.
        let Some(ls) = ctx.sample_light_unguided(index, x.p, Vec2::new(u[1], u[2]), hit.light_path) else {
            return Rgb::ZERO;
        };
        let wi_l = x.frame.to_local(ls.wi);
        let own = bsdf.bind(&x.view);
        let consistent = own.above(wi_l) == (ls.wi.dot(hit.ng) > 0.0);
        let f = own.eval(wi_l) * wi_l.z.abs();
        if f == Rgb::ZERO || ls.li == Rgb::ZERO || !consistent {
            return Rgb::ZERO;
        }
        let tr = super::connect::shadow_transmittance(ctx, x, hit.ng, &ls, index, hit.light_path.shadow(), stats);
        if tr == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let p_light = pmf * ls.pdf;
        let w = if gate != Gate::Mis || ls.delta { 1.0 } else { power_heuristic(p_light, own.pdf(wi_l)) };
        let c = x.beta * f * tr * ls.li * (self.mis(gate.weight(w)) / p_light);
        if c != Rgb::ZERO && self.ledger.any() {
            let first = match (t, self.ledger.light_passes) {
                (2, true) => passes::shares_seen(&own, wi_l),
                (2, false) => First::default(),
                _ => scratch.first,
            };
            self.ledger.file(out, t - 1, first, false, self.ledger.group_of_light(ctx, index), c);
        }
        c
    }
}

/// The receiver normal the path tracer gives light selection at a surface vertex: zero
/// where the BSDF transmits (lights below count too), else the geometric normal.
#[inline]
pub(super) fn selection_normal(v: &Vertex) -> Vec3 {
    match v.bsdf {
        Some(b) if !b.transmits() => v.ng,
        _ => Vec3::ZERO,
    }
}
