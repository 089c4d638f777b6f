//! Next-event estimation, once for every walker: at a surface (BSDF times light, MIS
//! against BSDF sampling), at a scattering event in a medium (phase function), and at
//! the Lambertian exit of a subsurface walk; and the shadow ray's transmittance through
//! media and volume boundaries.

use super::{SceneContext, media, power_heuristic};
use crate::bsdf::BsdfAt;
use crate::light::LightSample;
use crate::math::Rgb;
use crate::medium::{MediumStack, Phase};
use crate::render::job::RayStats;
use crate::scene::light_path::LightPath;
use crate::scene::linking::NO_OBJECT;
use crate::scene::shading::{ShadingPoint, SurfaceHit};
use glam::{Vec2, Vec3};

/// Light reaching surface `s` from one light sample, times the BSDF (`at`: the shading
/// point's BSDF seen from the outgoing direction) and the throughput
/// `beta`, MIS-weighted against BSDF sampling whose density is scaled by `bsdf_pdf_scale`
/// (the probability of the BSDF part of the material). `n_select` is the receiver normal
/// given to light selection (zero when the BSDF transmits: lights below count too).
/// Shading and geometric normals must agree on reflection versus transmission, or light
/// would leak through the surface.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn surface_nee(
    ctx: &SceneContext,
    s: &SurfaceHit,
    sp: &ShadingPoint,
    at: &BsdfAt,
    n_select: Vec3,
    bsdf_pdf_scale: f32,
    beta: Rgb,
    media: MediumStack,
    u_light: f32,
    u_light_pt: Vec2,
    stats: &mut RayStats,
) -> Rgb {
    surface_nee_at(ctx, s, sp, at, n_select, bsdf_pdf_scale, beta, media, u_light, u_light_pt, stats).0
}

/// [`surface_nee`], with the light direction in the shading frame (zero when no light
/// was sampled): the light passes split the estimate by the BSDF's classes there; and
/// the light's index ([`NO_LIGHT`] when none was sampled), which the light groups file it by.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn surface_nee_at(
    ctx: &SceneContext,
    s: &SurfaceHit,
    sp: &ShadingPoint,
    at: &BsdfAt,
    n_select: Vec3,
    bsdf_pdf_scale: f32,
    beta: Rgb,
    media: MediumStack,
    u_light: f32,
    u_light_pt: Vec2,
    stats: &mut RayStats,
) -> (Rgb, Vec3, usize) {
    let Some((index, pmf)) = ctx.lights.sample(s.p, n_select, u_light) else {
        return (Rgb::ZERO, Vec3::ZERO, NO_LIGHT);
    };
    // Light linking: a light chosen for a surface it does not light gives nothing (the
    // choice keeps its density, so the estimate of the linked lights is unchanged).
    // So does a light past its Max Bounces (Cycles skips the estimate, keeping the choice).
    if !ctx.links(index, s.tri) || !ctx.nee_within_bounces(index, s.light_path.depth) {
        return (Rgb::ZERO, Vec3::ZERO, index);
    }
    let Some(ls) = ctx.sample_light_at(index, s.p, n_select, u_light_pt, s.light_path) else {
        return (Rgb::ZERO, Vec3::ZERO, index);
    };
    let wi_local = sp.frame.to_local(ls.wi);
    // A light hidden from some kinds of ray lights only the other classes' closures.
    let excluded = ctx.light_excludes(index);
    let mut f =
        if excluded.none() { at.eval(wi_local) } else { at.eval_visible(wi_local, excluded) } * wi_local.z.abs();
    // Shadow Terminator Shading Offset: the cosine to a light on the normal's side remapped
    // (`scene::terminator::shift_cos_in`), as Cycles' `bsdf_eval`.
    if wi_local.z >= 0.0 {
        f *= ctx.scene.ray_visibility.shading_offset_factor(s.tri, wi_local.z);
    }
    // A light above the shading normal's horizon but below the triangle's plane: Cycles
    // traces it from the smooth patch where the object has a Shadow Terminator offset (the
    // triangle itself may then block it), which lights a coarse smooth mesh up to its
    // shading terminator; without one such a light is behind the surface.
    // A coat on its own normal reflects light from below the frame's horizon too (`BsdfAt::above`).
    let above = at.above(wi_local);
    let consistent = above == (ls.wi.dot(s.ng) > 0.0) || (above && terminator_cutoff(ctx, s) > 0.0);
    if f == Rgb::ZERO || ls.li == Rgb::ZERO || !consistent {
        return (Rgb::ZERO, wi_local, index);
    }
    let tr = if ctx.casts_shadow(index) {
        stats.shadow += 1;
        shadow_transmittance(ctx, s, &ls, media, index)
    } else {
        Rgb::ONE
    };
    if tr == Rgb::ZERO {
        return (Rgb::ZERO, wi_local, index);
    }
    let bsdf_pdf = at.pdf(wi_local) * bsdf_pdf_scale;
    // A shadow-linked light is found by next-event estimation alone.
    let w = if ls.delta || ctx.shadow_linked(index) { 1.0 } else { power_heuristic(ls.pdf * pmf, bsdf_pdf) };
    (beta * f * tr * ls.li * (w / (ls.pdf * pmf)), wi_local, index)
}

/// The light index next-event estimation reports when it sampled no light.
pub const NO_LIGHT: usize = usize::MAX;

/// Transmittance of a shadow ray from surface `s` to a sample of light `light`: through
/// media and volume boundaries (and tinted Transparent BSDFs) when the scene has any that
/// act on shadow rays (`SceneContext::shadow_media`), else plain visibility; with shadow linking only the light's blockers stop it.
#[inline]
pub fn shadow_transmittance(
    ctx: &SceneContext,
    s: &SurfaceHit,
    ls: &LightSample,
    media: MediumStack,
    light: usize,
) -> Rgb {
    let (p, own) = terminator_origin(ctx, s, ls.wi);
    if own && crate::scene::terminator::meets_own_triangle(&ctx.scene.mesh, s.tri, p, ls.wi) {
        return Rgb::ZERO;
    }
    if ctx.shadow_media || ctx.tinted_shadows {
        media::light_transmittance_of(
            ctx,
            p,
            Some(s.ng),
            ls,
            ctx.medium_after(s, ls.wi, media),
            Some(light),
            s.light_path.shadow(),
        )
    } else {
        Rgb::splat(ctx.visibility_of(p, s.ng, ls, Some(light), s.light_path.shadow()))
    }
}

/// Where a shadow ray toward `wi` leaves surface `s`: moved onto the smooth patch of its
/// triangle by its object's Shadow Terminator Geometry Offset, as Cycles' next-event
/// estimation does (`scene::terminator`); and whether its own triangle may then block it.
#[inline]
fn terminator_origin(ctx: &SceneContext, s: &SurfaceHit, wi: Vec3) -> (Vec3, bool) {
    let cutoff = terminator_cutoff(ctx, s);
    if !(cutoff > 0.0) {
        return (s.p, false);
    }
    crate::scene::terminator::shadow_ray_origin(&ctx.scene.mesh, s.tri, s.bary, s.p, s.ns, s.ng, wi, cutoff)
}

/// The Shadow Terminator Geometry Offset of the triangle `s` lies on (0 for none, and for
/// strands, points and moving triangles, which keep their origin).
#[inline]
fn terminator_cutoff(ctx: &SceneContext, s: &SurfaceHit) -> f32 {
    let scene = ctx.scene;
    let cutoff = scene.ray_visibility.terminator_offset(s.tri);
    if !(cutoff > 0.0) || crate::curves::is_curve(s.tri) || crate::points::is_point(s.tri) {
        return 0.0;
    }
    if scene.motion.as_ref().is_some_and(|mo| mo.blurs() && mo.moving(s.tri).is_some()) {
        return 0.0;
    }
    cutoff
}

/// Light arriving at medium point `p` by NEE, times the phase function (MIS against
/// phase sampling), for a path travelling along `dir` that reached `p` as `path` says (an
/// emitter's Light Path node reads its counters, as Cycles' volume light sampling does),
/// and the light it sampled ([`NO_LIGHT`]: none gave light).
#[allow(clippy::too_many_arguments)]
pub fn medium_nee_light(
    ctx: &SceneContext,
    p: Vec3,
    dir: Vec3,
    phase: Phase,
    media: MediumStack,
    path: LightPath,
    u_light: f32,
    u_light_pt: Vec2,
    stats: &mut RayStats,
) -> (Rgb, usize) {
    if let Some((index, pmf)) = ctx.lights.sample(p, Vec3::ZERO, u_light)
        && ctx.links(index, NO_OBJECT)
        && ctx.nee_within_bounces(index, path.depth)
        && ctx.light_seen_in_volume(index)
        && let Some(ls) = ctx.sample_light_from(index, p, u_light_pt, path)
    {
        let f = phase.eval(dir, ls.wi);
        if f > 0.0 && ls.li != Rgb::ZERO {
            let tr = if ctx.casts_shadow(index) {
                stats.shadow += 1;
                media::light_transmittance_of(ctx, p, None, &ls, media, Some(index), LightPath::SHADOW_RAY)
            } else {
                Rgb::ONE
            };
            if tr != Rgb::ZERO {
                let w = if ls.delta || ctx.shadow_linked(index) { 1.0 } else { power_heuristic(ls.pdf * pmf, f) };
                return (tr * ls.li * (f * w / (ls.pdf * pmf)), index);
            }
        }
    }
    (Rgb::ZERO, NO_LIGHT)
}

/// NEE at a subsurface exit point: a Lambertian of albedo 1 about `n_s` on the outside
/// (`n_g` the outward geometric normal), MIS against cosine sampling.
#[allow(clippy::too_many_arguments)]
pub fn exit_nee(
    ctx: &SceneContext,
    se: &SurfaceHit,
    n_g: Vec3,
    n_s: Vec3,
    media: MediumStack,
    u_light: f32,
    u_pt: Vec2,
    stats: &mut RayStats,
) -> Rgb {
    exit_nee_light(ctx, se, n_g, n_s, media, u_light, u_pt, stats).0
}

/// [`exit_nee`] and the light it sampled ([`NO_LIGHT`]: none gave light).
#[allow(clippy::too_many_arguments)]
pub fn exit_nee_light(
    ctx: &SceneContext,
    se: &SurfaceHit,
    n_g: Vec3,
    n_s: Vec3,
    media: MediumStack,
    u_light: f32,
    u_pt: Vec2,
    stats: &mut RayStats,
) -> (Rgb, usize) {
    if let Some((index, pmf)) = ctx.lights.sample(se.p, n_g, u_light)
        && ctx.links(index, se.tri)
        && ctx.nee_within_bounces(index, se.light_path.depth)
        // The exit is a diffuse closure (Cycles' BSSRDF exit).
        && !ctx.light_excludes(index).diffuse
        && let Some(ls) = ctx.sample_light_at(index, se.p, n_g, u_pt, se.light_path)
    {
        let cos = ls.wi.dot(n_s);
        if cos > 0.0 && ls.wi.dot(n_g) > 0.0 && ls.li != Rgb::ZERO {
            let tr = if !ctx.casts_shadow(index) {
                Rgb::ONE
            } else if ctx.shadow_media || ctx.tinted_shadows {
                stats.shadow += 1;
                media::light_transmittance_of(ctx, se.p, Some(n_g), &ls, media, Some(index), se.light_path.shadow())
            } else {
                stats.shadow += 1;
                Rgb::splat(ctx.visibility_of(se.p, n_g, &ls, Some(index), se.light_path.shadow()))
            };
            if tr != Rgb::ZERO {
                let f = cos * std::f32::consts::FRAC_1_PI;
                let w = if ls.delta || ctx.shadow_linked(index) { 1.0 } else { power_heuristic(ls.pdf * pmf, f) };
                return (tr * ls.li * (f * w / (ls.pdf * pmf)), index);
            }
        }
    }
    (Rgb::ZERO, NO_LIGHT)
}
