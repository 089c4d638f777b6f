//! Photon tracing: follows photons from the lights through the scene and stores them
//! at every non-specular hit.
//!
//! At each hit the BSDF is sampled (`Bsdf::sample`, with the photon's arrival
//! direction as `wo`); the scattering weight is w = f* |cos| / pdf, f* the adjoint BSDF
//! f(wi, wo) for a non-delta reflection (the coat's albedo scaling by the eye-side
//! direction is not reciprocal), times the adjoint
//! shading-normal correction |wo·ns| |wi·ng| / (|wo·ng| |wi·ns|) (Veach's thesis, §5.3),
//! and the photon continues with probability q = min(1, max component of w), its power
//! becoming power · w / q. For an energy-conserving BSDF max(w) ≤ 1 on average, so the
//! photon's largest power component never grows: no power blow-up, and every stored
//! photon has at most its light's per-photon power.
//!
//! Two maps, as in Jensen's notes, with "glossy" as `lobes.rs` splits a BSDF (specular
//! lobes and glossy lobes below the roughness threshold; the diffuse-like rest is "D"):
//! - `Global`: every non-specular hit of every photon (paths L {G|D}* D), with its hit
//!   index (1 = direct light) and a flag for L G+ D paths (every scattering glossy);
//! - `Caustic`: only hits reached through glossy scattering alone (L G+ D); the photon
//!   continues with the glossy part of each scattering only and is dropped when none is
//!   left. Not implemented: aiming caustic photons at glossy objects (projection maps);
//!   caustic photons are emitted as the global ones are, only more of them (on the glass
//!   caustic scene 10.7 % are stored, and 10x as many changed PM's error by 6 %:
//!   docs/benchmarks.md).
//!
//! A scattering with both parts keeps the L G+ D flag for its glossy share of the weight
//! only: in the global pass the photon stays flagged with probability P_G = lum(w_G) /
//! lum(w) and then carries w_G / P_G, else w_D / (1 − P_G) (both unbiased), so that the
//! flagged photons estimate exactly the light a camera vertex's diffuse-like part does
//! not get from the global map through a gather ray.
//!
//! Ray Visibility (`visibility.rs`): each photon carries the kinds of camera ray that may
//! read or continue its segment; it may pass objects hidden from some of them, is stored
//! with them, and scatters only through the classes they allow.
//!
//! Random numbers: photon i of pass `pass` draws from the Owen-scrambled Sobol stream
//! (seed, salt, pass, i), so the maps depend on (seed, i) only, never on threads; the
//! photons are traced in fixed chunks in parallel and concatenated in chunk order.
//! Stochastic transparency (BLEND) lets photons pass as camera rays do. At a contact (a
//! glass resting on a floor) a photon that arrives after a scattering, or onto a specular
//! surface, ends unstored: the camera walk brings no other light there (`contact.rs`).

use super::Photon;
use super::contact;
use super::lobes::Split;
use super::visibility::{self, PHOTON_KINDS, SURFACE_KINDS};
use crate::integrator::SceneContext;
use crate::integrator::linking;
use crate::integrator::path::PathIntegrator;
use crate::integrator::walk::{MAX_TRANSPARENT_HITS, PathState, Step};
use crate::light::emit::Emitters;
use crate::math::offset_ray_origin;
use crate::math::{Rgb, luminance};
use crate::render::job::RayStats;
use crate::sampling::PixelSampler;
use crate::sampling::warp::cosine_hemisphere;
use crate::scene::light_groups::NONE;
use crate::scene::linking::NO_OBJECT;
use crate::scene::visibility::RayMask;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Which map a tracing pass fills.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapKind {
    /// Every non-specular hit.
    Global,
    /// Only L S+ D hits.
    Caustic,
}

/// Photons per parallel work item.
pub const CHUNK: u64 = 4096;

/// Counters of a tracing pass.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct TraceStats {
    /// Photons emitted.
    pub emitted: u64,
    /// Photons stored.
    pub stored: u64,
    /// Rays cast.
    pub rays: u64,
}

/// What to trace.
#[derive(Clone, Copy, Debug)]
pub struct TraceJob {
    /// Map kind.
    pub kind: MapKind,
    /// Photons to emit.
    pub count: u64,
    /// Seed.
    pub seed: u32,
    /// Pass number (SPPM iteration; 0 for Jensen's maps).
    pub pass: u32,
    /// Largest hit index stored (the render's maximum depth).
    pub max_depth: u32,
    /// Do not store first hits (direct light), for SPPM, which computes it by NEE.
    pub skip_direct: bool,
    /// Tag each stored photon with its light's group (`scene::light_groups`).
    pub light_groups: bool,
}

/// Salts that keep the global, caustic and SPPM streams apart from the pixels'.
fn salt(kind: MapKind) -> u32 {
    match kind {
        MapKind::Global => 0xF07_0001,
        MapKind::Caustic => 0xF07_0002,
    }
}

/// Traces `job.count` photons in parallel; `progress` receives the number of photons
/// done after each chunk. Returns the stored photons (not yet a tree), their light groups
/// (when `job.light_groups`, one per photon; else empty) and counters.
pub fn trace_photons(
    ctx: &SceneContext,
    emitters: &Emitters,
    job: &TraceJob,
    stop: &AtomicBool,
    progress: &(dyn Fn(u64) + Sync),
) -> (Vec<Photon>, Vec<u8>, TraceStats) {
    let chunks = job.count.div_ceil(CHUNK);
    let groups_of = &ctx.scene.light_groups;
    let done = AtomicU64::new(0);
    let parts: Vec<(Vec<Photon>, Vec<u8>, TraceStats)> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let lo = c * CHUNK;
            let hi = (lo + CHUNK).min(job.count);
            // Room for up to 4 stored hits per photon: the per-photon loop then pushes
            // without reallocating unless the chunk's photons average more than 4 hits.
            let mut out = Vec::with_capacity(((hi - lo) * job.max_depth.clamp(1, 4) as u64) as usize);
            let mut st = TraceStats::default();
            let mut groups = Vec::new();
            if stop.load(Ordering::Relaxed) {
                return (out, groups, st);
            }
            for i in lo..hi {
                let light = trace_one(ctx, emitters, job, i, &mut out, &mut st);
                if job.light_groups {
                    // Every photon this one stored has its light's group.
                    groups.resize(out.len(), light.map_or(NONE, |l| groups_of.of_light(l)));
                }
            }
            progress(done.fetch_add(hi - lo, Ordering::Relaxed) + hi - lo);
            (out, groups, st)
        })
        .collect();
    let total: usize = parts.iter().map(|p| p.0.len()).sum();
    let mut photons = Vec::with_capacity(total);
    let mut groups = Vec::with_capacity(if job.light_groups { total } else { 0 });
    let mut stats = TraceStats::default();
    for (p, g, s) in parts {
        photons.extend_from_slice(&p);
        groups.extend_from_slice(&g);
        stats.emitted += s.emitted;
        stats.stored += s.stored;
        stats.rays += s.rays;
    }
    (photons, groups, stats)
}

/// A photon's time (frames) when the render blurs motion: drawn as a camera sample's, on a
/// scanline drawn uniformly, so that under a rolling shutter the photons cover the times of
/// every row. None for a still scene (no time is drawn, the maps are those of the frame).
#[inline]
fn photon_time(ctx: &SceneContext, u_time: f32, u_row: f32) -> Option<f32> {
    // Rows of a virtual frame fine enough that the scan times are continuous in effect.
    const ROWS: u32 = 1 << 16;
    let shutter = ctx.scene.motion.as_ref().and_then(|m| m.shutter).filter(|_| ctx.blurs_motion)?;
    Some(shutter.time(u_time, ((u_row * ROWS as f32) as u32).min(ROWS - 1), ROWS))
}

/// Traces photon `i` of the job, appending what it stores to `out`; returns the light
/// that emitted it (None: no photon left a light).
#[inline]
pub fn trace_one(
    ctx: &SceneContext,
    emitters: &Emitters,
    job: &TraceJob,
    i: u64,
    out: &mut Vec<Photon>,
    st: &mut TraceStats,
) -> Option<usize> {
    let mut s = PixelSampler::new(job.seed, salt(job.kind), job.pass ^ ((i >> 32) as u32), i as u32);
    let [u_light, u_side, u_px, u_py] = s.next_4d();
    let [u_dx, u_dy, u_time, u_row] = s.next_4d();
    st.emitted += 1;
    // Under motion blur each photon flies at its own time over the shutter, so that the maps
    // hold the light of the whole exposure (`photon_time`).
    let _time = crate::motion::TimeScope::enter(photon_time(ctx, u_time, u_row));
    // Lights and emitting media share the photons by power (`light::media_emit`); without
    // emitting media the lights take every photon and `u_light` as it is.
    let media_lum = emitters.media.total_luminance();
    let (mut u_light, mut light_share) = (u_light, 1.0f32);
    if media_lum > 0.0 {
        let p_media = media_lum / (media_lum + emitters.total_luminance());
        light_share = 1.0 - p_media;
        if u_light >= light_share {
            let u = ((u_light - light_share) / p_media).min(ONE_BELOW);
            let [u_cell, u_x, u_y, u_z] = s.next_4d();
            let scale = 1.0 / (p_media * job.count as f32);
            let m =
                emitters.media.emit(ctx.scene, u, u_cell, Vec3::new(u_x, u_y, u_z), Vec2::new(u_dx, u_dy), scale)?;
            if let Some(material) = m.inside
                && !inside_mesh(ctx, m.org, m.dir, material)
            {
                return None;
            }
            let path = PathState { media: m.media, ..PathState::photon(m.org, m.dir, m.power) };
            follow(ctx, job, &mut s, None, path, PHOTON_KINDS, &mut None, out, st);
            return None;
        }
        u_light = (u_light / light_share).min(ONE_BELOW);
    }
    let mut e = emitters.emit(ctx.scene, u_light, u_side, Vec2::new(u_px, u_py), Vec2::new(u_dx, u_dy), job.count)?;
    if light_share < 1.0 {
        e.power /= light_share;
    }
    // A light of Max Bounces 0 lights no path past its first bounce, and every photon read
    // is such light (`scene::light_bounces`): its photons carry nothing.
    if ctx.scene.light_max_bounces.get(e.light) == Some(&0) {
        return Some(e.light);
    }
    // A light's varying node tree weighs the photon by its value along the photon's
    // direction (the direction is drawn from the light's own emission, so the weighted
    // power stays unbiased); the photon does not know its first segment's length yet, and
    // reads a Ray Length of 1 (warned: `path_emitters::photon_warning`).
    if ctx.scene.light_graphs.get(e.light).is_some_and(Option::is_some) {
        e.power *= crate::light::light_graph::graph_factor(
            ctx.scene,
            e.light,
            e.org,
            Vec3::ZERO,
            e.org + e.dir,
            crate::scene::light_path::LightPath::LIGHT_EMISSION,
        );
    }
    // A shadow-linked light's photon may go on through surfaces that do not block it
    // (`linking`): each such continuation is traced after the path it split from.
    let mut pending = Some((PathState::photon(e.org, e.dir, e.power), visibility::of_light(ctx, e.light)));
    while let Some((path, kinds)) = pending.take() {
        follow(ctx, job, &mut s, Some(e.light), path, kinds, &mut pending, out, st);
    }
    Some(e.light)
}

/// The largest f32 below 1: a rescaled sample stays in [0, 1).
const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

/// True when `p` is inside the mesh of `material`: the first surface along `dir` is that
/// material's, met from its back (a photon of the mesh's medium drawn in its box starts
/// there only then; one outside carries nothing, which keeps the estimate unbiased).
#[inline]
fn inside_mesh(ctx: &SceneContext, p: Vec3, dir: Vec3, material: u32) -> bool {
    ctx.intersect(p, dir, f32::INFINITY).is_some_and(|hit| {
        let s = ctx.scene.surface(&hit, p, dir);
        s.material == material && !s.front
    })
}

/// Follows a photon of light `light` (None: of an emitting medium, which light linking
/// and shadow rays do not concern) from its state `path` (at its light, or passing a
/// surface on its first segment) readable by the camera-ray kinds `kinds`
/// (`visibility.rs`), storing its hits in `out`; a continuation through a surface that
/// does not block the light goes to `pending`.
#[allow(clippy::too_many_arguments)]
#[inline]
fn follow(
    ctx: &SceneContext,
    job: &TraceJob,
    s: &mut PixelSampler,
    light: Option<usize>,
    mut path: PathState,
    mut kinds: RayMask,
    pending: &mut Option<(PathState, RayMask)>,
    out: &mut Vec<Photon>,
    st: &mut TraceStats,
) {
    // Every scattering so far was glossy or specular (the L G+ D flag).
    let mut glossy_only = true;
    // Photons scatter in media (free flights as the path tracer's, with the photon's
    // power as the channel weights) but are stored only on surfaces; they count no
    // emission on the way.
    let mut ignored = Rgb::ZERO;
    let mut ray_stats = RayStats::default();
    loop {
        let [u_lobe, u_x, u_y, mut u_rr] = s.next_4d();
        let [u_channel, u_dist, u_px, u_py] = if ctx.has_media { s.next_4d() } else { [0.0; 4] };
        st.rays += 1;
        let power_before = path.beta;
        let (step, _) = path.advance(ctx, [u_channel, u_dist], || s.next_4d()[0], false, &mut ignored, &mut ray_stats);
        let sh = match step {
            Step::End | Step::Escaped => return,
            Step::Passed => continue,
            Step::Medium { p, phase, weight } => {
                if let Some(light) = light
                    && path.depth == 0
                    && !linking::photon_first_event(ctx, light, NO_OBJECT).scatters
                {
                    return;
                }
                // The camera side leaves a medium event by a volume ray.
                if !kinds.meets(RayMask::AFTER_VOLUME) {
                    return;
                }
                // Russian roulette on the event's weight (the single-scattering albedo
                // for a grey medium), as on surfaces.
                let q = weight.max_element().min(1.0);
                if !(q > 0.0) || u_rr >= q || !weight.is_finite() {
                    return;
                }
                path.beta = power_before * (weight / q);
                path.depth += 1;
                glossy_only = false;
                if path.depth >= job.max_depth || job.kind == MapKind::Caustic {
                    return;
                }
                path.org = p;
                path.dir = phase.sample(path.dir, Vec2::new(u_px, u_py)).0;
                kinds = PHOTON_KINDS;
                continue;
            }
            Step::Surface { s, .. } => s,
        };
        // Ray Visibility: stop here, or go on through an object hidden from some of the
        // kinds (`visibility.rs`: each with probability ½ when both can be); the light's
        // own segment is the camera side's shadow ray, which objects hidden from shadow
        // rays let through.
        let mask = ctx.object_rays(sh.tri);
        // A medium's light reaches surfaces by the camera side's BSDF-sampled rays, never
        // by shadow rays: its first segment is as any later one.
        let through = match path.depth {
            0 if light.is_some() && mask.meets(RayMask::SHADOW) => RayMask(0),
            0 if light.is_some() => kinds,
            _ => RayMask(kinds.0 & !mask.0),
        };
        let stops = kinds.meets(SURFACE_KINDS);
        if through.0 != 0 {
            let pass = !stops || {
                path.beta *= 2.0;
                s.next_4d()[0] < 0.5
            };
            if pass {
                path.transparent_hits += 1;
                if path.transparent_hits > MAX_TRANSPARENT_HITS {
                    return;
                }
                path.org = offset_ray_origin(sh.p, -sh.ng);
                path.media = ctx.medium_after(&sh, path.dir, path.media);
                kinds = through;
                continue;
            }
        } else if !stops {
            return;
        }
        if let Some(light) = light
            && path.depth == 0
        {
            // Light linking reads the first event (module doc of `linking`).
            let first = linking::photon_first_event(ctx, light, sh.tri);
            if first.passes {
                let on = PathState {
                    org: offset_ray_origin(sh.p, -sh.ng),
                    media: ctx.medium_after(&sh, path.dir, path.media),
                    ..path
                };
                *pending = Some((on, kinds));
            }
            if !first.scatters {
                return;
            }
        }
        path.depth += 1;
        let wo = -path.dir;
        let sp = ctx.shade(&sh, wo);
        let delta = sp.bsdf.is_delta();
        // At a contact (a glass resting on a floor) light arrives only straight from its
        // light onto a non-specular surface, as the camera walk's NEE finds it (`contact.rs`).
        if (path.depth > 1 || delta) && contact::at_contact(ctx, &sh, path.ray) {
            return;
        }
        if !delta {
            let caustic = glossy_only && path.depth > 1;
            let store = match job.kind {
                MapKind::Global => !(job.skip_direct && path.depth == 1),
                MapKind::Caustic => caustic,
            };
            if store {
                out.push(Photon::new(sh.p, path.beta, wo, sh.ng, path.depth, caustic).with_kinds(kinds));
                st.stored += 1;
            }
        }
        if path.depth >= job.max_depth {
            return;
        }
        // Scatter.
        let wo_local = sp.frame.to_local(wo);
        // The subsurface part, chosen with probability its weight (as the path tracer):
        // enter, walk, leave through the Lambertian exit. (Photons are not stored in the walk.)
        let mat = &ctx.scene.materials[sh.material as usize];
        let q_sss = if mat.subsurface.is_some() { sp.bsdf.subsurface_weight(wo_local) } else { 0.0 };
        if let Some(ss) = mat.subsurface
            && q_sss > 0.0
        {
            let u = s.next_4d();
            let [v_dx, v_dy, v_rr, _] = s.next_4d();
            if u[0] < q_sss {
                // A subsurface walk is not glossy: the caustic map has no use for it. The
                // camera side leaves it by a diffuse ray (as the path tracer).
                if job.kind == MapKind::Caustic || !kinds.meets(RayMask::DIFFUSE) {
                    return;
                }
                let walker = PathIntegrator::default();
                let entry_u = [u[1], u[2], (u[0] / q_sss).min(0.999_999), u[3]];
                let Some(exit) = walker.subsurface(ctx, &sh, &sp, wo, &ss, path.beta, entry_u) else {
                    return;
                };
                let q = exit.weight.max_element().min(1.0);
                if !(q > 0.0) || v_rr >= q || !exit.weight.is_finite() {
                    return;
                }
                // The walk is no event (the camera side's count, as Cycles'): the exit's
                // diffuse bounce alone leads to the next hit.
                path.beta *= exit.weight / q;
                glossy_only = false;
                let (se, n_g, n_s) = (exit.se, exit.n_g, exit.n_s);
                let wi = crate::math::Frame::from_normal(n_s).to_world(cosine_hemisphere(Vec2::new(v_dx, v_dy)));
                if wi.dot(n_g) <= 0.0 {
                    return;
                }
                path.org = offset_ray_origin(se.p, n_g);
                path.dir = wi;
                kinds = visibility::of_object(ctx, se.tri);
                continue;
            }
        }
        let Some(bs) = sp.bsdf.sample(wo_local, u_lobe, Vec2::new(u_x, u_y)) else {
            return;
        };
        let wi = sp.frame.to_world(bs.wi);
        let (cos_o_g, cos_i_g) = (wo.dot(sh.ng), wi.dot(sh.ng));
        // Reflection in the shading frame must be reflection geometrically (and the
        // same for transmission), or light leaks through the surface.
        // (A coat on its own normal reflects across the frame's horizon: `Bsdf::reflects`.)
        let reflected = sp.bsdf.reflects(wo_local, bs.wi);
        if reflected != (cos_i_g * cos_o_g > 0.0) || cos_i_g == 0.0 {
            return;
        }
        let correction = (wo_local.z * cos_i_g / (cos_o_g * bs.wi.z)).abs();
        // Ray Visibility: only the classes whose camera rays may continue this photon.
        let excluded = if visibility::all_surface(kinds) {
            Default::default()
        } else if bs.delta {
            if !kinds.meets(RayMask::after_bounce(bs.kind, !reflected)) {
                return;
            }
            Default::default()
        } else {
            match visibility::excluded(kinds, reflected) {
                Some(ex) => ex,
                None => return,
            }
        };
        // Photons carry flux, which scatters by the adjoint BSDF f(wi, wo): it differs from
        // f(wo, wi) where a clear coat scales the layers below by its albedo seen from the
        // eye's side (as Cycles), which is not reciprocal, and across a refraction, whose
        // camera-side value follows Cycles' convention (no η², `bsdf::dielectric`): the
        // adjoint is 1/η² of it (and takes rough glass's multiple-scattering compensation
        // from the photon's side).
        let f = if !excluded.none() {
            // A reflection's adjoint is f seen from the photon's outgoing side.
            sp.bsdf.at(bs.wi).eval_visible(wo_local, excluded)
        } else if !bs.delta {
            sp.bsdf.eval_adjoint(wo_local, bs.wi)
        } else if !reflected {
            bs.f * sp.bsdf.refraction_adjoint_scale()
        } else {
            bs.f
        };
        let scale = (bs.wi.z.abs() / (bs.pdf * (1.0 - q_sss))) * correction;
        let mut w = f * scale;
        // The L G+ D flag: split the weight into its diffuse-like and glossy shares (the
        // adjoint's diffuse part for a reflection, as f above).
        if glossy_only {
            let split = Split::of(&sp.bsdf);
            let f_d = if bs.delta || (excluded.diffuse && split == Split::ByClass) {
                Rgb::ZERO
            } else if split == Split::AllDiffuse {
                f
            } else if reflected {
                split.diffuse(&sp.bsdf.at(bs.wi), wo_local).min(f).max(Rgb::ZERO)
            } else {
                split.diffuse_of_sample(&sp.bsdf.at(wo_local), bs.wi, bs.f, false)
                    * sp.bsdf.refraction_adjoint_ratio(wo_local, bs.wi)
            };
            let (w_d, w_g) = (f_d * scale, (f - f_d).max(Rgb::ZERO) * scale);
            let p_g = if w_d == Rgb::ZERO { 1.0 } else { luminance(w_g) / luminance(w_d + w_g) };
            if job.kind == MapKind::Caustic {
                // Only the glossy share goes on in the caustic pass.
                w = w_g;
            } else if p_g >= 1.0 {
                w = w_g;
            } else if u_rr < p_g {
                // The choice spends u_rr's first share; the rest, rescaled, is uniform
                // again for Russian roulette.
                w = w_g / p_g;
                u_rr /= p_g;
            } else {
                w = w_d / (1.0 - p_g);
                u_rr = (u_rr - p_g) / (1.0 - p_g);
                glossy_only = false;
            }
        }
        let q = w.max_element().min(1.0);
        if !(q > 0.0) || u_rr >= q || !w.is_finite() {
            return;
        }
        path.beta *= w / q;
        path.media = ctx.medium_after(&sh, wi, path.media);
        path.org = offset_ray_origin(sh.p, if cos_i_g > 0.0 { sh.ng } else { -sh.ng });
        path.dir = wi;
        kinds = visibility::of_object(ctx, sh.tri);
    }
}
