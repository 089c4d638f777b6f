//! SPPM's camera pass: a camera ray followed to its visible point (module doc of `sppm`),
//! filing its light passes and light groups when asked (`sppm_passes`).

use super::{Pending, VisiblePoint};
use crate::film::CameraSample;
use crate::integrator::SceneContext;
use crate::integrator::catcher::Split as CatcherSplit;
use crate::integrator::filing::Filing;
use crate::integrator::light_passes::{Tally, shares_at};
use crate::integrator::nee::surface_nee_at;
use crate::integrator::path::PathIntegrator;
use crate::integrator::photon::lobes::Split;
use crate::integrator::walk::{PathState, Step};
use crate::math::{Rgb, offset_ray_origin};
use crate::render::job::RayStats;
use crate::sampling::PixelSampler;
use crate::scene::camera::{CameraRay, CameraRays};
use crate::scene::visibility::RayMask;
use glam::{Vec2, Vec3};

/// The filing of a path traced on from the camera path (None when nothing is asked).
fn filing_of(tally: Option<Tally>, groups: bool, out: &mut CameraSample) -> Option<Filing<'_>> {
    let f = Filing { tally, groups, out };
    f.any().then_some(f)
}

/// What a camera path shows and files.
#[derive(Clone, Copy, Debug)]
pub(super) struct Flags {
    /// Camera rays that miss show nothing (Film → Transparent).
    pub(super) transparent_background: bool,
    /// File the light passes into the camera sample.
    pub(super) passes: bool,
    /// File the light groups into the camera sample.
    pub(super) grouping: bool,
    /// Film → Transparent Glass's roughness threshold (None: off).
    pub(super) glass: Option<f32>,
}

/// Follows a camera ray through glossy and specular bounces to its visible point, the
/// first vertex with a diffuse-like part (`lobes.rs`), where the photons will be gathered
/// through that part; the glossy part there and everything after it is path traced
/// (NEE with MIS at every non-delta vertex, the BSDF-sampled ray finding emission).
/// Returns the emission and direct light collected, the visible point, and the first hit
/// distance; the sample's coverage and first-hit passes go to `pend`, its light passes and
/// light groups (as `flags` asks) to `out`. Where its camera segment ends on a shadow
/// catcher it notes the split in `caught` (when allowed; `sppm_catcher`), and goes on.
#[allow(clippy::too_many_arguments)]
pub(super) fn camera_path(
    ctx: &SceneContext,
    ray: &CameraRay,
    sampler: &mut PixelSampler,
    max_depth: u32,
    pend: &mut Pending,
    camera: &CameraRays,
    stats: &mut RayStats,
    flags: Flags,
    out: &mut CameraSample,
    caught: &mut CatcherSplit,
) -> (Rgb, Option<VisiblePoint>, f32) {
    if ray.is_blind() {
        // Outside a panoramic camera's lens: no path, black and opaque (`CameraSample::blind`).
        pend.alpha += 1.0;
        return (Rgb::ZERO, None, f32::INFINITY);
    }
    let Flags { transparent_background, passes, grouping, glass } = flags;
    // Film → Transparent Glass: the path has only refracted through glass under the
    // threshold, so the world it meets stays transparent (the path tracer's rule; no
    // visible point lies on such a path, as glass has no diffuse-like part).
    let glass_limit = glass.filter(|_| transparent_background);
    let mut see_through = glass_limit.is_some();
    let groups = &ctx.scene.light_groups;
    let mut tally = Tally::default();
    let mut l = Rgb::ZERO;
    let mut first_t = f32::INFINITY;
    stats.camera += 1;
    // A scattering event in a medium is path traced from that vertex on (media have no
    // photon map): NEE plus a continued path.
    let mut st = PathState::camera(ray, ctx.camera_media);
    let continuation = PathIntegrator { max_depth, transparent_background, ..Default::default() };
    // `beta` carries the path on; `e` weighs the emission the next ray finds (they differ
    // after the visible point, whose diffuse-like part the photons stand for but whose
    // direct light NEE and the next ray share by MIS through the whole BSDF).
    let mut beta = Rgb::ONE;
    let mut e = Rgb::ONE;
    let mut vp: Option<VisiblePoint> = None;
    // This sample's alpha is undone if the camera ray ends on a holdout.
    let alpha_before = pend.alpha;
    loop {
        let [u_light, u_lx, u_ly, u_lobe] = sampler.next_4d();
        let [u_dx, u_dy, u_rr, u_alpha] = sampler.next_4d();
        let [u_channel, u_dist, _, _] = if ctx.has_media { sampler.next_4d() } else { [0.0; 4] };
        // Along the ray with a unit throughput (the segment's weight then scales both).
        // Lights crossed and the world carry MIS against the NEE where the ray left (none
        // for the camera ray and after delta lobes: the state's pdf is 0).
        let mut medium_l = Rgb::ZERO;
        let mut crossed_any = false;
        let depth_before = st.depth;
        // The camera segment as it starts, should it end on a shadow catcher.
        let pre = (caught.allowed && st.depth == 0).then_some(PathState { beta, ..st });
        st.beta = Rgb::ONE;
        let out_groups = &mut out.groups;
        let (step, crossed_l) = st.advance_with(
            ctx,
            Some([u_channel, u_dist]),
            || u_alpha,
            |st, t_event, w| {
                // One call either way: `crossed_emission` is this with a closure that files nothing.
                let (le, any) = ctx.crossed_emission_each(
                    st.org,
                    st.dir,
                    t_event,
                    st.prev_p,
                    st.prev_n,
                    st.prev_pdf,
                    st.depth == 0,
                    st.prev_tri,
                    &st.light_path,
                    |light, c| {
                        if grouping {
                            out_groups.add(groups.of_light(light), e * w * c)
                        }
                    },
                );
                crossed_any = any;
                if any { e * w * le } else { Rgb::ZERO }
            },
            &mut medium_l,
            stats,
        );
        let along = crossed_l + e * medium_l;
        l += along;
        if passes && along != Rgb::ZERO {
            // Crossed lights and media's emission (which goes to no light group).
            tally.found(out, depth_before, along, false);
        }
        let seg = std::mem::replace(&mut st.beta, Rgb::ONE);
        beta *= seg;
        e *= seg;
        if crossed_any && st.depth == 0 {
            pend.alpha += 1.0;
        }
        let (hit, s) = match step {
            Step::End => break,
            Step::Passed => continue,
            Step::Medium { p, phase, .. } => {
                if st.depth == 0 {
                    pend.alpha += 1.0;
                }
                if st.depth < max_depth && beta.is_finite() && beta != Rgb::ZERO {
                    l += continuation.scatter_in_medium_filed(
                        ctx,
                        p,
                        st.dir,
                        phase,
                        st.media,
                        beta,
                        st.depth,
                        sampler,
                        stats,
                        filing_of(passes.then_some(tally), grouping, out),
                    );
                }
                break;
            }
            Step::Escaped => {
                if caught.allowed && st.depth == 0 {
                    caught.background = st.escaped_radiance(ctx).map_or(Rgb::ZERO, |le| e * le);
                }
                let through_glass = see_through && st.depth > 0;
                let shown = !(through_glass || (st.depth == 0 && transparent_background));
                if through_glass {
                    // What the throughput carries is transparent (Cycles' `transparent +=
                    // average(throughput)`).
                    pend.alpha = (pend.alpha - e.element_sum() / 3.0).max(alpha_before);
                }
                if grouping {
                    // As the path tracer: the world seen through a transparent film too.
                    st.escaped_radiance_each(ctx, |light, c| {
                        out.groups.add(light.map_or(groups.world, |i| groups.of_light(i)), e * c);
                    });
                }
                if (shown || passes)
                    && let Some(le) = st.escaped_radiance(ctx)
                {
                    if passes {
                        // The Environment pass shows the world behind a transparent film too.
                        tally.found(out, st.depth, e * le, true);
                    }
                    if shown {
                        l += e * le;
                        if st.depth == 0 {
                            pend.alpha += 1.0;
                        }
                    }
                }
                break;
            }
            Step::Surface { hit, s } => (hit, s),
        };
        // A holdout seen by a camera ray: nothing, alpha 0 (as the path tracer).
        if st.depth == 0 && ctx.is_holdout(hit.tri) {
            pend.alpha = alpha_before;
            pend.held = 1.0;
            return (l, None, first_t);
        }
        // A shadow catcher seen by the camera ray: the path splits here (the catcher pass
        // follows in `sppm_catcher::sample`); what it collected so far is the matte's.
        if let Some(pre) = pre
            && ctx.is_catcher(hit.tri)
        {
            caught.at = Some((pre, l));
        }
        let wo = -st.dir;
        let sp = ctx.shade(&s, wo);
        if st.depth == 0 {
            let (alpha, held) = SceneContext::holdout_alpha(&sp, beta);
            pend.held = 1.0 - alpha;
            if held {
                pend.alpha = alpha_before + alpha;
                return (l, None, first_t);
            }
            first_t = s.t;
            pend.alpha += alpha;
            let z = camera.depth(s.p);
            pend.depth = z;
            pend.normal = sp.frame.n;
            pend.albedo = sp.bsdf.albedo();
        } else if first_t.is_infinite() {
            first_t = s.t;
        }
        let le = PathState { beta: e, ..st }.surface_emission(ctx, &hit, &s, &sp);
        l += le;
        if le != Rgb::ZERO {
            if grouping {
                out.groups.add(groups.of_tri(hit.tri), le);
            }
            if passes {
                tally.found(out, st.depth, le, false);
            }
        }
        // The ray a diffuse-only visible point sent was for its emission alone (above).
        if st.depth >= max_depth || beta == Rgb::ZERO || ctx.ends_at_surface(st.light_path) {
            break;
        }
        let wo_local = sp.frame.to_local(wo);
        let at = sp.bsdf.at(wo_local);
        if passes && st.depth == 0 {
            Tally::colours(out, &at, beta);
        }
        // The subsurface part has no photon map: path traced (the BSDF part as below).
        if ctx.scene.materials[s.material as usize].subsurface.is_some() {
            let q = sp.bsdf.subsurface_weight(wo_local);
            if q > 0.0 {
                l += continuation.subsurface_from_filed(
                    ctx,
                    &s,
                    &sp,
                    wo,
                    st.media,
                    beta * q,
                    st.depth,
                    sampler,
                    stats,
                    filing_of(passes.then_some(tally), grouping, out),
                );
            }
        }
        let split = Split::of(&sp.bsdf);
        let delta = sp.bsdf.is_delta();
        // The visible point: the first vertex with a diffuse-like part.
        let (diffuse, glossy) = if delta || vp.is_some() { (false, true) } else { split.parts(&at) };
        let is_vp = diffuse;
        if !delta {
            // Direct light (lights below count when the BSDF transmits: photons are
            // gathered on this side only), MIS against the next ray, which a visible point
            // with no glossy part sends too, for the emission it finds only: light
            // sampling alone left the broad sky of an environment map to the few world
            // samples its sun disc left over (floor blocks 3-4x the path tracer's error
            // on bench/run.py's hdri scene).
            let n_select = if sp.bsdf.transmits() { Vec3::ZERO } else { s.ng };
            let (ln, wi_light, light) =
                surface_nee_at(ctx, &s, &sp, &at, n_select, 1.0, beta, st.media, u_light, Vec2::new(u_lx, u_ly), stats);
            l += ln;
            if grouping {
                out.groups.add(groups.of_light(light), ln);
            }
            if passes && ln != Rgb::ZERO {
                tally.estimated(out, st.depth, ln, Some(shares_at(&at, wi_light)));
            }
            if is_vp {
                vp = Some(VisiblePoint {
                    p: s.p,
                    ng: s.ng,
                    frame: sp.frame,
                    bsdf: sp.bsdf,
                    split,
                    wo_local,
                    beta,
                    d: st.depth + 1,
                    first: if passes { tally.first_shares() } else { None },
                });
            }
            st.prev_n = n_select;
        }
        // The next ray from the whole BSDF; at the visible point only its glossy share goes on.
        let Some(bs) = at.sample(u_lobe, Vec2::new(u_dx, u_dy)) else {
            break;
        };
        let wi = sp.frame.to_world(bs.wi);
        let (co, ci) = (wo.dot(s.ng), wi.dot(s.ng));
        let reflected = sp.bsdf.reflects(wo_local, bs.wi);
        if reflected != (co * ci > 0.0) || ci == 0.0 {
            break;
        }
        let mut w = bs.f * (bs.wi.z.abs() / bs.pdf);
        // Shading Offset on a reflected sample, as the path tracer (`path.rs`).
        if reflected {
            w *= ctx.scene.ray_visibility.shading_offset_factor(s.tri, bs.wi.z.abs());
        }
        e = beta * w;
        beta = if is_vp && !glossy {
            Rgb::ZERO
        } else if is_vp {
            beta * (w - split.diffuse_of_sample(&at, bs.wi, bs.f, bs.delta) * (bs.wi.z.abs() / bs.pdf)).max(Rgb::ZERO)
        } else {
            e
        };
        if !(beta.is_finite() && e.is_finite()) || (beta == Rgb::ZERO && e == Rgb::ZERO) {
            break;
        }
        if passes && st.depth == 0 {
            tally.surface_bounce_sampled(&at, &bs);
        }
        st.prev_pdf = if bs.delta { 0.0 } else { bs.pdf };
        st.prev_p = s.p;
        st.prev_tri = s.tri;
        st.depth += 1;
        st.media = ctx.medium_after(&s, wi, st.media);
        st.ray = RayMask::after_bounce(bs.kind, ci < 0.0);
        st.light_path = s.light_path.moved(s.light_path.ray_length).bounced(bs.kind, ci < 0.0, bs.delta);
        see_through &= glass_limit.is_some_and(|t| {
            co * ci < 0.0 && bs.kind == crate::bsdf::LobeKind::Glossy && sp.bsdf.glass_alpha2() <= (t * t) * (t * t)
        });
        st.org = offset_ray_origin(s.p, if ci > 0.0 { s.ng } else { -s.ng });
        st.dir = wi;
        stats.bounce += 1;
        // Russian roulette after the visible point, as the path tracer's.
        if vp.is_some() && st.depth >= continuation.rr_depth {
            // Refraction keeps 1 − F of the throughput (Cycles' convention): no η scale.
            let q = beta.max_element().max(e.max_element()).min(0.95);
            if !(u_rr < q) {
                break;
            }
            beta /= q;
            e /= q;
        }
    }
    (l, vp, first_t)
}
