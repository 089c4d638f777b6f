//! The shadow catcher in BDPT and VCM (`integrator::catcher` defines it as Cycles does).
//!
//! In path space a path "split" when its first vertex seen from the camera (through
//! pass-throughs) lies on a catcher. Combined keeps every path, as the path tracer's does;
//! the matte keeps the paths that did not split. Every strategy with t ≥ 2 shares the
//! camera subpath's first vertex, so the camera sample's sum goes to the matte unless the
//! subpath split; a light-tracing splat (t = 1) goes to the matte unless the light vertex
//! the camera sees is on a catcher. Merges (VCM) are camera-side contributions too.
//!
//! The catcher pass and the matte's transparency are estimated from the camera side alone,
//! by the path tracer's walk from the split state in the catcher pass's context (as the
//! path tracer does; `PathIntegrator::catcher_pass`), which is consistent whatever the
//! strategies that made Combined.

use super::*;
use crate::integrator::catcher;

impl BdptIntegrator {
    /// Files the camera sample `out` (its Combined radiance complete, merges included)
    /// into the shadow catcher's sums, tracing the catcher pass when its camera subpath
    /// split (`scratch.split`); `sampler` is the camera stream, past the camera subpath.
    pub(crate) fn file_catcher(
        &self,
        ctx: &SceneContext,
        sampler: &mut PixelSampler,
        scratch: &BdptScratch,
        out: &mut CameraSample,
        stats: &mut RayStats,
    ) {
        let split = &scratch.split;
        if !split.allowed {
            return;
        }
        let (pass, behind) = match (ctx.catcher.as_deref(), split.at) {
            (Some(pass_ctx), Some((pre, _))) => {
                let pass = self.continuation().catcher_pass(pass_ctx, pre, sampler, stats);
                let behind = match self.transparent_background {
                    true => Rgb::ZERO,
                    false => pre.escaped_radiance(ctx).map_or(Rgb::ZERO, |le| pre.beta * le),
                };
                // The path tracer files nothing of a split path in the light groups.
                out.groups = *scratch.groups_at_split;
                (pass, behind)
            }
            _ => (Rgb::ZERO, Rgb::ZERO),
        };
        catcher::record(&mut out.aov, split, out.radiance, pass, behind);
    }

    /// True when the camera sees light vertex `y` on a shadow catcher, where paths split:
    /// its splat belongs to Combined and not to the matte.
    #[inline]
    pub(super) fn seen_on_catcher(ctx: &SceneContext, y: &Vertex) -> bool {
        match (y.hit, y.light) {
            (Some(h), _) => ctx.is_catcher(h.tri),
            (None, Some(lp)) => match ctx.scene.lights.get(lp.light as usize) {
                Some(Light::Triangle { tri }) => ctx.is_catcher(*tri),
                _ => false,
            },
            _ => false,
        }
    }
}
