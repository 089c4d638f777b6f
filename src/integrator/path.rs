//! Unidirectional path tracing with next-event estimation, multiple importance
//! sampling (power heuristic) between light and BSDF sampling, and Russian roulette.
//!
//! Parameters: `max_depth` (scattering events; 1 = direct light only; default 13,
//! i.e. Blender's default 12 bounces), Russian roulette from `rr_depth` (default 3),
//! with survival probability min(0.95, max(throughput)).
//!
//! Each bounce draws a fixed block of sample dimensions (light choice, light point,
//! lobe, direction, roulette, transparency) so that Sobol dimensions line up across
//! paths. Area lights do not block rays (as in Cycles): they add their emission where a
//! ray crosses them and the path goes on.
//!
//! Media (scenes with `SceneContext::has_media`, which draw one more block of four
//! dimensions per bounce; skipped, its place kept, when every medium is vacuum,
//! `SceneContext::media_act`): inside a medium the path samples a free flight
//! (`HomogeneousMedium::sample_free_flight`); at a scattering event it does NEE with
//! the phase function (MIS against phase sampling) and shadow rays that cross volume
//! boundaries and attenuate through media (`media::light_transmittance`), then samples
//! the phase function. Medium emission along a segment is added analytically. Volume
//! boundaries without a surface only change the medium stack. Area lights crossed
//! inside a scattering medium are weighted by the pass weight at the segment's end,
//! which is exact for grey media and approximate for chromatic ones.
//!
//! Subsurface (Principled "Random Walk"): at a subsurface material the path chooses the
//! subsurface part with probability equal to its weight, enters (refraction through
//! the rough interface, or half diffuse for the skin method, as Cycles), walks inside
//! (`medium::walk::random_walk`) with the base colour's throughput divided out as Cycles does,
//! and leaves through a Lambertian exit (NEE at the exit point, cosine sampling out).

use super::SceneContext;
use super::catcher::{self, Split};
use super::filing::Filing;
use super::light_passes::{Tally, shares_at};
use super::nee::{exit_nee_light, medium_nee_light, surface_nee_at};
use super::walk::{PathState, Step};
use crate::bsdf::LobeKind;
use crate::bsdf::dielectric::refract;
use crate::bsdf::microfacet::Ggx;
use crate::film::CameraSample;
use crate::math::{Frame, Rgb, offset_ray_origin};
use crate::medium::{MediumStack, Phase, WalkMedium, WalkRng, skin_mean_free_path};
use crate::render::job::RayStats;
use crate::sampling::PixelSampler;
use crate::sampling::warp::{cosine_hemisphere, cosine_hemisphere_pdf};
use crate::scene::camera::CameraRay;
use crate::scene::light_path::LightPath;
use crate::scene::linking::NO_OBJECT;
use crate::scene::material::{Subsurface, SubsurfaceMethod};
use crate::scene::shading::{ShadingPoint, SurfaceHit};
use crate::scene::visibility::RayMask;
use glam::{Vec2, Vec3};

/// The path tracer's parameters.
#[derive(Clone, Debug)]
pub struct PathIntegrator {
    /// Maximum number of scattering events.
    pub max_depth: u32,
    /// Depth from which Russian roulette may end paths.
    pub rr_depth: u32,
    /// Camera rays that miss show nothing (alpha 0) instead of the world, as Blender's
    /// Film → Transparent; the world still lights the scene.
    pub transparent_background: bool,
    /// Film → Transparent Glass's roughness threshold: a camera path that only refracted
    /// through glass whose αx·αy is at most its fourth power (a perceptual roughness, squared
    /// to α and once more for the product, as Cycles' `background.cpp`) and then escapes
    /// leaves its throughput's share of the pixel transparent, the world unseen.
    pub glass_threshold: Option<f32>,
    /// Classify contributions into the light passes (`light_passes.rs`; only when asked).
    pub light_passes: bool,
    /// File contributions by the light group of the emitter that gave them
    /// (`scene::light_groups`; only when asked).
    pub light_groups: bool,
    /// Emission found after delta bounces alone from where the path starts is left out
    /// for lights whose light subpaths VCM merges in media (`vcm::volume_merge`): VCM
    /// continues its camera paths from a medium vertex with this set.
    pub merged_delta_light: bool,
    /// Light Paths > Fast GI Approximation (`fast_gi`; the path tracer's own paths only).
    pub fast_gi: Option<super::fast_gi::FastGi>,
    /// The film reads the first hit's albedo (`film::needs_guides`, a denoiser); without it
    /// the BSDF's albedo is not computed (1 % of the glass bench scene's instructions).
    pub guides: bool,
}

impl Default for PathIntegrator {
    fn default() -> Self {
        PathIntegrator {
            max_depth: 13,
            rr_depth: 3,
            transparent_background: true,
            glass_threshold: None,
            light_passes: false,
            light_groups: false,
            merged_delta_light: false,
            fast_gi: None,
            guides: true,
        }
    }
}

impl PathIntegrator {
    /// A path tracer of at most `max_depth` scattering events (Russian roulette at its default depth).
    pub fn new(max_depth: u32, transparent_background: bool) -> Self {
        PathIntegrator { max_depth, transparent_background, ..Default::default() }
    }

    /// Parameters, for logs and the summary.
    pub fn describe(&self) -> String {
        format!("path (max depth {}, russian roulette from depth {})", self.max_depth, self.rr_depth)
    }

    /// Radiance arriving at the camera along a ray, written over `out` (the caller's sample,
    /// reset here: filled in place, the ~1 KiB record is not copied out per sample).
    pub fn li(
        &self,
        ctx: &SceneContext,
        ray: &CameraRay,
        sampler: &mut PixelSampler,
        depth_of: impl Fn(Vec3) -> f32,
        stats: &mut RayStats,
        out: &mut CameraSample,
    ) {
        *out = CameraSample { depth: f32::INFINITY, ..Default::default() };
        stats.camera += 1;
        // Camera rays start in vacuum, with no MIS for what they hit first.
        let st = PathState::camera(ray, ctx.camera_media);
        let mut split = Split::new(ctx.catcher.is_some());
        out.radiance = self.trace(ctx, st, sampler, depth_of, stats, out, &mut split, None);
        if let (Some(pass_ctx), Some((pre, _))) = (ctx.catcher.as_deref(), split.at) {
            // The catcher pass: the same camera segment again, in the scene of catchers
            // only; its own first-hit values are not the pixel's.
            let mut scratch = CameraSample::default();
            let mut replay = split.stream.unwrap_or(*sampler);
            let pass =
                self.trace(pass_ctx, pre, &mut replay, |_| 0.0, stats, &mut scratch, &mut Split::new(false), None);
            let behind = match self.transparent_background {
                true => Rgb::ZERO,
                false => pre.escaped_radiance(ctx).map_or(Rgb::ZERO, |le| pre.beta * le),
            };
            catcher::record(&mut out.aov, &split, out.radiance, pass, behind);
        } else if split.allowed {
            catcher::record(&mut out.aov, &split, out.radiance, Rgb::ZERO, Rgb::ZERO);
        }
        if !self.transparent_background {
            out.make_opaque();
        }
    }

    /// The shadow catcher's pass (`catcher`) from `pre`, the state that walked a camera
    /// segment ending on a catcher, in the catcher pass's context `pass_ctx`: how BDPT and
    /// VCM, which split their camera subpaths too, estimate it.
    pub(crate) fn catcher_pass(
        &self,
        pass_ctx: &SceneContext,
        pre: PathState,
        sampler: &mut PixelSampler,
        stats: &mut RayStats,
    ) -> Rgb {
        let mut scratch = CameraSample::default();
        self.trace(pass_ctx, pre, sampler, |_| 0.0, stats, &mut scratch, &mut Split::new(false), None)
    }

    /// Radiance brought back by a path continued from `st` (depth ≥ 1), times its
    /// throughput: how the photon integrators path-trace what they do not map (media).
    pub fn continue_path(
        &self,
        ctx: &SceneContext,
        st: PathState,
        sampler: &mut PixelSampler,
        stats: &mut RayStats,
    ) -> Rgb {
        let mut out = CameraSample::default();
        self.trace(ctx, st, sampler, |_| 0.0, stats, &mut out, &mut Split::new(false), None)
    }

    /// [`continue_path`](Self::continue_path), filing its contributions as `filing` says
    /// (the caller's light passes and groups).
    pub fn continue_path_filed(
        &self,
        ctx: &SceneContext,
        st: PathState,
        sampler: &mut PixelSampler,
        stats: &mut RayStats,
        filing: Option<Filing<'_>>,
    ) -> Rgb {
        match filing {
            Some(f) => {
                let filed = Some((f.tally, f.groups));
                self.trace(ctx, st, sampler, |_| 0.0, stats, f.out, &mut Split::new(false), filed)
            }
            None => self.continue_path(ctx, st, sampler, stats),
        }
    }

    /// Radiance scattered at a point `p` in a medium of phase function `phase` toward a
    /// path arriving along `dir` with throughput `beta` after `depth` events (the caller
    /// checks `depth` < Max Bounces): NEE there, then the path continued by phase sampling.
    #[allow(clippy::too_many_arguments)]
    pub fn scatter_in_medium(
        &self,
        ctx: &SceneContext,
        p: Vec3,
        dir: Vec3,
        phase: Phase,
        media: MediumStack,
        beta: Rgb,
        depth: u32,
        sampler: &mut PixelSampler,
        stats: &mut RayStats,
    ) -> Rgb {
        self.scatter_in_medium_filed(ctx, p, dir, phase, media, beta, depth, sampler, stats, None)
    }

    /// [`scatter_in_medium`](Self::scatter_in_medium), filing its contributions as
    /// `filing` says (the caller's light passes and groups).
    #[allow(clippy::too_many_arguments)]
    pub fn scatter_in_medium_filed(
        &self,
        ctx: &SceneContext,
        p: Vec3,
        dir: Vec3,
        phase: Phase,
        media: MediumStack,
        beta: Rgb,
        depth: u32,
        sampler: &mut PixelSampler,
        stats: &mut RayStats,
        mut filing: Option<Filing<'_>>,
    ) -> Rgb {
        let [u_light, u_lx, u_ly, _] = sampler.next_4d();
        let [u_dx, u_dy, u_rr, _] = sampler.next_4d();
        // The path behind the medium point is not known here: only its depth.
        let path = LightPath { depth: depth as u16, ..LightPath::FROM_LIGHT };
        let (le, light) = medium_nee_light(ctx, p, dir, phase, media, path, u_light, Vec2::new(u_lx, u_ly), stats);
        let mut radiance = beta * le;
        if let Some(f) = filing.as_mut() {
            if f.groups {
                f.out.groups.add(ctx.scene.light_groups.of_light(light), radiance);
            }
            if let Some(t) = f.tally.as_mut() {
                t.estimated(f.out, depth, radiance, None);
                t.volume();
            }
        }
        let (wi, pdf) = phase.sample(dir, Vec2::new(u_dx, u_dy));
        let mut st = PathState {
            org: p,
            dir: wi,
            beta,
            depth: depth + 1,
            prev_pdf: pdf,
            prev_p: p,
            prev_n: Vec3::ZERO,
            media,
            transparent_hits: 0,
            tmax: f32::INFINITY,
            ray: RayMask::AFTER_VOLUME,
            prev_tri: NO_OBJECT,
            light_path: path.scattered_in_volume(),
        };
        // The phase-sampled ray is traced even past Max Bounces (as `trace` does after its
        // last event): the emission it finds, crossed lights, media and the surface it hits,
        // is the other half of the MIS estimate whose light-sampled half NEE gave above; the
        // continued path ends at its next event.
        if st.survives(self.rr_depth, u_rr) {
            stats.bounce += 1;
            radiance += self.continue_path_filed(ctx, st, sampler, stats, filing);
        }
        radiance
    }

    /// The path loop from state `st`; AOVs of the first hit go to `out`; a camera path
    /// that finds a shadow catcher first notes where in `split` (when it is allowed).
    #[allow(clippy::too_many_arguments)]
    fn trace(
        &self,
        ctx: &SceneContext,
        mut st: PathState,
        sampler: &mut PixelSampler,
        depth_of: impl Fn(Vec3) -> f32,
        stats: &mut RayStats,
        out: &mut CameraSample,
        split: &mut Split,
        filed: Option<(Option<Tally>, bool)>,
    ) -> Rgb {
        let mut radiance = Rgb::ZERO;
        // Light passes: only camera paths (`li`) keep a tally, or a path continued for
        // another integrator's camera path (`filed`: its tally so far).
        // Light groups: camera paths file by emitter, until they split at a shadow catcher
        // (Cycles files nothing of a path that hit a catcher).
        let (passes, mut tally, mut grouping) = match filed {
            Some((t, g)) => (t.is_some(), t.unwrap_or_default(), g),
            None => (self.light_passes && st.depth == 0, Tally::default(), self.light_groups && st.depth == 0),
        };
        let groups = &ctx.scene.light_groups;
        // Delta bounces since the start while every bounce was one (`merged_delta_light`).
        let mut delta_chain = self.merged_delta_light.then_some(0u32);
        // Cycles' PATH_RAY_TRANSPARENT_BACKGROUND past the first hit: a camera path that has
        // only refracted through glass under the Transparent Glass threshold (see below).
        let glass_limit = self.glass_threshold.filter(|_| self.transparent_background && st.depth == 0);
        let mut see_through = glass_limit.is_some();
        // Filter Glossy's least density of the path's non-singular bounces (Cycles'
        // `min_ray_pdf`; a continued path starts without one).
        let mut min_pdf = f32::MAX;
        let merged = |chain: Option<u32>, light: Option<usize>| {
            chain.is_some_and(|k| k > 0) && light.is_some_and(|l| crate::integrator::linking::merged_in_media(ctx, l))
        };
        loop {
            // Where a camera segment that may split at a catcher starts in the stream.
            let stream = (split.allowed && st.depth == 0).then_some(*sampler);
            // Bounce dimensions, drawn up front so that their positions are fixed.
            let [u_light, u_lx, u_ly, u_lobe] = sampler.next_4d();
            let [u_dx, u_dy, u_rr, u_alpha] = sampler.next_4d();
            // (Media that are all vacuum keep their place in the layout but are not drawn.)
            let [u_channel, u_dist, u_sss, u_walk] = match (ctx.has_media, ctx.media_act) {
                (true, true) => sampler.next_4d(),
                (true, false) => {
                    sampler.skip_4d();
                    [0.0; 4]
                }
                (false, _) => [0.0; 4],
            };
            let (u_light_pt, u_dir) = (Vec2::new(u_lx, u_ly), Vec2::new(u_dx, u_dy));

            // Fast GI (Replace): past its bounces the ray is an occlusion test that sees at
            // most the AO distance (`fast_gi`).
            let occlusion = self.fast_gi.filter(|g| g.occlusion_ray(&st.light_path));
            if let Some(g) = occlusion {
                st.tmax = st.tmax.min(g.distance);
            }
            let world_factor = occlusion.map_or(1.0, |g| g.world_factor());

            // Along the ray: medium, crossed lights, pass-through surfaces.
            let pre = if split.allowed && st.depth == 0 { Some(st) } else { None };
            let before = radiance;
            let depth_before = st.depth;
            let mut left_out = Rgb::ZERO;
            // What the segment finds (crossed lights, medium emission), clamped as one
            // contribution (Cycles clamps each; they differ only for a ray that crosses two
            // emitters past the clamp).
            let mut found = Rgb::ZERO;
            let (step, crossed) = st.advance_each(
                ctx,
                [u_channel, u_dist],
                || u_alpha,
                true,
                &mut found,
                stats,
                |light, c| {
                    if merged(delta_chain, Some(light)) {
                        left_out += c;
                    } else if grouping {
                        out.groups.add(groups.of_light(light), c);
                    }
                },
            );
            radiance += ctx.light_paths.found(found - left_out, depth_before);
            if passes && radiance != before {
                // Crossed lights and medium emission (the difference keeps Combined's sum as it was).
                tally.found(out, depth_before, radiance - before, false);
            }
            if crossed && st.depth == 0 {
                out.alpha = 1.0;
            }
            let (hit, s) = match step {
                Step::End => break,
                Step::Passed => continue,
                Step::Medium { p, phase, .. } => {
                    // An occlusion test ends at a volume event (Cycles lights the event first).
                    if !st.beta.is_finite() || st.beta == Rgb::ZERO || occlusion.is_some() {
                        break;
                    }
                    if st.depth == 0 {
                        out.alpha = 1.0;
                        out.depth = depth_of(p);
                    }
                    // Max Bounces, or a kind's bounces spent (Cycles' segment is then
                    // attenuation only: a free flight ending here leaves the same mean).
                    if st.depth >= self.max_depth || ctx.light_paths.spent(st.light_path) {
                        break;
                    }
                    let (le, light) =
                        medium_nee_light(ctx, p, st.dir, phase, st.media, st.light_path, u_light, u_light_pt, stats);
                    let c = ctx.light_paths.estimated(st.beta * le, st.depth);
                    radiance += c;
                    if grouping {
                        out.groups.add(groups.of_light(light), c);
                    }
                    if passes {
                        tally.estimated(out, st.depth, c, None);
                        tally.volume();
                    }
                    // The phase function is its own density: the throughput is unchanged.
                    let (wi, pdf) = phase.sample(st.dir, u_dir);
                    min_pdf = min_pdf.min(pdf);
                    see_through = false;
                    st.prev_pdf = pdf;
                    st.prev_p = p;
                    st.prev_n = Vec3::ZERO;
                    st.depth += 1;
                    if !st.survives(self.rr_depth, u_rr) {
                        break;
                    }
                    delta_chain = None;
                    st.light_path = st.light_path.moved(p.distance(st.org)).scattered_in_volume();
                    st.org = p;
                    st.dir = wi;
                    st.ray = RayMask::AFTER_VOLUME;
                    st.prev_tri = NO_OBJECT;
                    stats.bounce += 1;
                    continue;
                }
                Step::Escaped if delta_chain.is_some_and(|k| k > 0) => {
                    // Past the first event: only what VCM does not merge (`merged_delta_light`).
                    let world = ctx.scene.lights.iter().position(|l| matches!(l, crate::light::Light::World));
                    let mut le = Rgb::ZERO;
                    st.escaped_radiance_each(ctx, |light, c| {
                        if !merged(delta_chain, light.or(world)) {
                            le += c;
                            if grouping {
                                out.groups.add(light.map_or(groups.world, |i| groups.of_light(i)), st.beta * c);
                            }
                        }
                    });
                    let c = ctx.light_paths.found(st.beta * le, st.depth);
                    radiance += c;
                    if passes {
                        tally.found(out, st.depth, c, true);
                    }
                    break;
                }
                Step::Escaped => {
                    // The world, weighted against light sampling. (Leaving from inside a
                    // medium means its mesh is open: the segment's weight is then zero in
                    // every channel the medium attenuates.)
                    let seen_directly = st.depth == 0;
                    if see_through && !seen_directly {
                        // The world behind transparent glass: what the throughput carries
                        // is transparent (Cycles' `transparent += average(throughput)`).
                        out.alpha = (out.alpha - st.beta.element_sum() / 3.0).max(0.0);
                    }
                    // Seen directly or through transparent glass: behind the film.
                    let behind_film = seen_directly || see_through;
                    if split.allowed && st.depth == 0 {
                        split.background = st.escaped_radiance(ctx).map_or(Rgb::ZERO, |le| st.beta * le);
                    }
                    // The world's and the suns' groups (Cycles files the world seen through a
                    // transparent film in its group too, as in the Environment pass).
                    // Fast GI's occlusion test sees the world (not the suns) times its factor.
                    let beta = st.beta;
                    let file = |light: Option<usize>, c: Rgb, out: &mut CameraSample| {
                        let g = light.map_or(groups.world, |i| groups.of_light(i));
                        out.groups.add(g, beta * c * if light.is_none() { world_factor } else { 1.0 });
                    };
                    if grouping {
                        st.escaped_radiance_each(ctx, |light, c| file(light, c, out));
                    }
                    if !(behind_film && self.transparent_background)
                        && let Some(le) = escaped_scaled(&st, ctx, world_factor)
                    {
                        let c = ctx.light_paths.found(st.beta * le, st.depth);
                        radiance += c;
                        if seen_directly {
                            out.alpha = 1.0;
                        }
                        if passes {
                            tally.found(out, st.depth, c, true);
                        }
                    } else if passes
                        && behind_film
                        && let Some(le) = st.escaped_radiance(ctx)
                    {
                        // Cycles' Environment pass shows the world behind a transparent film too.
                        tally.found(out, 0, st.beta * le, true);
                    }
                    break;
                }
                Step::Surface { hit, s } => (hit, s),
            };
            // A holdout seen by a camera ray (through pass-throughs only): nothing, alpha 0,
            // as Cycles' holdout (indirect rays see the object as it is).
            if st.depth == 0 && ctx.is_holdout(hit.tri) {
                out.alpha = 0.0;
                out.held = 1.0;
                break;
            }
            // A shadow catcher seen by a camera ray: the path splits here (the catcher
            // pass follows in `li`); what it gathered so far is the matte's.
            if let Some(pre) = pre
                && ctx.is_catcher(hit.tri)
            {
                split.at = Some((pre, radiance));
                split.stream = stream;
                grouping = false;
            }
            let wo = -st.dir;
            let mat = &ctx.scene.materials[s.material as usize];
            let mut sp = ctx.shade(&s, wo);
            let (no_reflective, no_refractive) = ctx.light_paths.drops_caustics(st.light_path);
            sp.bsdf.drop_caustics(no_reflective, no_refractive);
            if ctx.light_paths.filter_glossy > 0.0 {
                sp.bsdf.blur(ctx.light_paths.filter_glossy, min_pdf);
            }
            if st.depth == 0 {
                let (alpha, held) = SceneContext::holdout_alpha(&sp, st.beta);
                out.alpha = alpha;
                out.held = 1.0 - alpha;
                if held {
                    break;
                }
                out.depth = depth_of(s.p);
                out.normal = sp.frame.n;
                if self.guides {
                    out.albedo = sp.bsdf.albedo();
                }
            }

            // Emission found by the path, weighted against light sampling.
            if sp.emitted != Rgb::ZERO && !merged(delta_chain, ctx.lights.light_of_triangle(hit.tri)) {
                let c = ctx.light_paths.found(st.surface_emission(ctx, &hit, &s, &sp), st.depth);
                radiance += c;
                if grouping {
                    out.groups.add(groups.of_tri(hit.tri), c);
                }
                if passes {
                    tally.found(out, st.depth, c, false);
                }
            }

            // Past Transparent Max Bounces, Max Bounces or a kind's bounces (Light Paths) a
            // path ends here, after the emission (Cycles), as does Fast GI's occlusion test.
            if st.depth >= self.max_depth
                || ctx.ends_at_surface(st.light_path)
                || ctx.light_paths.spent(st.light_path)
                || occlusion.is_some()
            {
                break;
            }

            let wo_local = sp.frame.to_local(wo);
            let at = sp.bsdf.at(wo_local);
            if passes && st.depth == 0 {
                Tally::colours(out, &at, st.beta);
            }
            // Probability of the subsurface part (its weight: what the layers above leave
            // to the diffuse base, times Subsurface Weight); the BSDF has the rest.
            let q_sss = if mat.subsurface.is_some() { sp.bsdf.subsurface_weight(wo_local) } else { 0.0 };

            // Next-event estimation: one light (useless for pure delta BSDFs such as
            // clear glass). Without transmission no light below the surface can count,
            // which the light tree uses.
            let n_select = if sp.bsdf.transmits() { Vec3::ZERO } else { s.ng };
            if !sp.bsdf.is_delta() {
                let (c, wi_light, light) = surface_nee_at(
                    ctx,
                    &s,
                    &sp,
                    &at,
                    n_select,
                    1.0 - q_sss,
                    st.beta,
                    st.media,
                    u_light,
                    u_light_pt,
                    stats,
                );
                let c = ctx.light_paths.estimated(c, st.depth);
                radiance += c;
                if grouping {
                    out.groups.add(groups.of_light(light), c);
                }
                if passes && c != Rgb::ZERO {
                    tally.estimated(out, st.depth, c, Some(shares_at(&at, wi_light)));
                }
            }
            // Fast GI (Add): ambient occlusion at every surface, in Combined only.
            if let Some(g) = self.fast_gi
                && let Some(factor) = g.additive()
            {
                let c = additive_ao(ctx, &s, &sp, &at, wo, factor, g.distance, u_dir, st.light_path, stats);
                radiance += ctx.light_paths.estimated(st.beta * c, st.depth);
            }

            if u_sss < q_sss
                && let Some(ss) = mat.subsurface
            {
                // Subsurface: enter, walk, leave through a Lambertian exit.
                delta_chain = None;
                see_through = false;
                let Some(exit) = self.subsurface(ctx, &s, &sp, wo, &ss, st.beta, [u_dx, u_dy, u_lobe, u_walk]) else {
                    break;
                };
                // Chosen with probability q = its weight: the weight over q is 1, and the
                // base colour is the walk's to give (Cycles divides it out the same way).
                // The walk is no event: Cycles' `subsurface_bounce` moves no counter, and its
                // exit is never terminated, so the exit lights at the entry's depth and only
                // its diffuse bounce counts (Max Bounces, Diffuse Bounces, the clamps).
                st.beta *= exit.weight;
                let (se, n_g, n_s) = (exit.se, exit.n_g, exit.n_s);
                if !st.beta.is_finite() || st.beta == Rgb::ZERO {
                    break;
                }
                let [v_light, v_lx, v_ly, _] = sampler.next_4d();
                let [v_dx, v_dy, _, _] = sampler.next_4d();
                if passes {
                    tally.subsurface();
                }
                let (le, light) = exit_nee_light(ctx, &se, n_g, n_s, st.media, v_light, Vec2::new(v_lx, v_ly), stats);
                let c = ctx.light_paths.estimated(st.beta * le, st.depth);
                radiance += c;
                if grouping {
                    out.groups.add(groups.of_light(light), c);
                }
                if passes {
                    tally.estimated(out, st.depth, c, Some((Rgb::ONE, Rgb::ZERO)));
                }
                let local = cosine_hemisphere(Vec2::new(v_dx, v_dy));
                let wi = Frame::from_normal(n_s).to_world(local);
                if wi.dot(n_g) <= 0.0 {
                    break;
                }
                st.prev_pdf = cosine_hemisphere_pdf(local.z);
                min_pdf = min_pdf.min(st.prev_pdf);
                st.prev_p = se.p;
                st.prev_n = n_g;
                st.depth += 1;
                if !st.survives(self.rr_depth, u_rr) {
                    break;
                }
                st.org = offset_ray_origin(se.p, n_g);
                st.dir = wi;
                st.ray = RayMask::DIFFUSE;
                // Cycles continues from a subsurface exit as from a diffuse reflection.
                // The footprint of the entry point carries to the exit (Cycles' subsurface
                // ray keeps `sd->dP`).
                st.light_path = st.light_path.moved(s.light_path.ray_length).bounced(LobeKind::Diffuse, false, false);
                st.prev_tri = se.tri;
                stats.bounce += 1;
                continue;
            }

            // Sample the BSDF for the next direction.
            let Some(bs) = at.sample(u_lobe, u_dir) else {
                break;
            };
            let wi = sp.frame.to_world(bs.wi);
            // A coat on its own normal reflects below the frame's horizon too (`BsdfAt::above`).
            let transmitted = !at.above(bs.wi);
            if transmitted != (wi.dot(s.ng) < 0.0) {
                // The shading normal disagrees with the geometry about the side.
                break;
            }
            let pdf = bs.pdf * (1.0 - q_sss);
            if passes && st.depth == 0 {
                let (d, g) =
                    if bs.delta { (Rgb::ZERO, Rgb::splat(!transmitted as u8 as f32)) } else { shares_at(&at, bs.wi) };
                tally.surface_bounce(d, g);
            }
            st.beta *= bs.f * (bs.wi.z.abs() / pdf);
            // Shading Offset on a reflected sample, as Cycles' `bsdf_sample` (not on transmission).
            if !transmitted {
                st.beta *= ctx.scene.ray_visibility.shading_offset_factor(s.tri, bs.wi.z.abs());
            }
            if !st.beta.is_finite() || st.beta == Rgb::ZERO {
                break;
            }
            delta_chain = delta_chain.filter(|_| bs.delta).map(|k| k + 1);
            // After a delta lobe, emission found next is not MIS-weighted (0 = "specular").
            st.prev_pdf = if bs.delta { 0.0 } else { pdf };
            // A singular bounce leaves Filter Glossy's density alone (Cycles' is 10⁶ times the lobe's).
            if !bs.delta {
                min_pdf = min_pdf.min(pdf);
            }
            st.prev_p = s.p;
            st.prev_n = n_select;
            st.depth += 1;

            // Crossing an interface of a solid changes the medium.
            st.media = ctx.medium_after(&s, wi, st.media);

            if !st.survives(self.rr_depth, u_rr) {
                break;
            }

            st.org = offset_ray_origin(s.p, if transmitted { -s.ng } else { s.ng });
            st.dir = wi;
            st.ray = RayMask::after_bounce(bs.kind, transmitted);
            st.light_path = st.light_path.moved(s.light_path.ray_length).bounced(bs.kind, transmitted, bs.delta);
            st.prev_tri = hit.tri;
            // Transparent Glass: only a glossy refraction through glass at most the threshold
            // rough keeps the background transparent (Cycles' LABEL_TRANSMIT_TRANSPARENT).
            see_through &= glass_limit.is_some_and(|t| {
                transmitted && bs.kind == LobeKind::Glossy && sp.bsdf.glass_alpha2() <= (t * t) * (t * t)
            });
            stats.bounce += 1;
        }
        radiance
    }

    /// Radiance of the subsurface part of the material at `s` seen along `wo`, per unit
    /// of its weight (`PbrBsdf::subsurface_weight`): enter, walk, leave through the
    /// Lambertian exit and path trace on. For integrators that handle the rest of the
    /// material otherwise (the photon integrators); `depth` counts the events before `s`,
    /// and the walk adds none (the exit's diffuse bounce does).
    #[allow(clippy::too_many_arguments)]
    pub fn subsurface_from(
        &self,
        ctx: &SceneContext,
        s: &SurfaceHit,
        sp: &ShadingPoint,
        wo: Vec3,
        media: MediumStack,
        beta: Rgb,
        depth: u32,
        sampler: &mut PixelSampler,
        stats: &mut RayStats,
    ) -> Rgb {
        self.subsurface_from_filed(ctx, s, sp, wo, media, beta, depth, sampler, stats, None)
    }

    /// [`subsurface_from`](Self::subsurface_from), filing its contributions as `filing`
    /// says (the caller's light passes and groups).
    #[allow(clippy::too_many_arguments)]
    pub fn subsurface_from_filed(
        &self,
        ctx: &SceneContext,
        s: &SurfaceHit,
        sp: &ShadingPoint,
        wo: Vec3,
        media: MediumStack,
        beta: Rgb,
        depth: u32,
        sampler: &mut PixelSampler,
        stats: &mut RayStats,
        mut filing: Option<Filing<'_>>,
    ) -> Rgb {
        let mat = &ctx.scene.materials[s.material as usize];
        let Some(ss) = mat.subsurface else {
            return Rgb::ZERO;
        };
        let u = sampler.next_4d();
        let Some(exit) = self.subsurface(ctx, s, sp, wo, &ss, beta, u) else {
            return Rgb::ZERO;
        };
        // The walk is no event (as the path tracer's, Cycles'): the exit lights at `depth`.
        let beta = beta * exit.weight;
        if !beta.is_finite() || beta == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let (se, n_g, n_s) = (exit.se, exit.n_g, exit.n_s);
        let [v_light, v_lx, v_ly, v_rr] = sampler.next_4d();
        let [v_dx, v_dy, _, _] = sampler.next_4d();
        let (le, light) = exit_nee_light(ctx, &se, n_g, n_s, media, v_light, Vec2::new(v_lx, v_ly), stats);
        let radiance = beta * le;
        if let Some(f) = filing.as_mut() {
            if f.groups {
                f.out.groups.add(ctx.scene.light_groups.of_light(light), radiance);
            }
            if let Some(t) = f.tally.as_mut() {
                // As the path tracer: the walk is the first event's diffuse class, its
                // exit's estimate direct when the walk started at the first hit.
                t.subsurface();
                t.estimated(f.out, depth, radiance, Some((Rgb::ONE, Rgb::ZERO)));
            }
        }
        let local = cosine_hemisphere(Vec2::new(v_dx, v_dy));
        let wi = Frame::from_normal(n_s).to_world(local);
        let mut st = PathState {
            org: offset_ray_origin(se.p, n_g),
            dir: wi,
            beta,
            depth: depth + 1,
            prev_pdf: cosine_hemisphere_pdf(local.z),
            prev_p: se.p,
            prev_n: n_g,
            media,
            transparent_hits: 0,
            tmax: f32::INFINITY,
            // The exit scatters as a diffuse reflection, as Cycles labels it.
            ray: RayMask::DIFFUSE,
            prev_tri: se.tri,
            light_path: LightPath { depth: (depth + 1) as u16, ..LightPath::FROM_LIGHT }.bounced(
                LobeKind::Diffuse,
                false,
                false,
            ),
        };
        if wi.dot(n_g) <= 0.0 || !st.survives(self.rr_depth, v_rr) {
            return radiance;
        }
        stats.bounce += 1;
        radiance + self.continue_path_filed(ctx, st, sampler, stats, filing)
    }

    /// Enters a subsurface material at `s` (seen along `wo`) and walks inside; None when
    /// the entry fails (Cycles then ends the path too) or the walk is abandoned.
    #[allow(clippy::too_many_arguments)]
    pub fn subsurface(
        &self,
        ctx: &SceneContext,
        s: &SurfaceHit,
        sp: &ShadingPoint,
        wo: Vec3,
        ss: &Subsurface,
        beta: Rgb,
        u: [f32; 4],
    ) -> Option<SubsurfaceExit> {
        let n = sp.frame.n;
        let (albedo, base_roughness, layer_eta) = sp.bsdf.subsurface_base();
        // Channels whose radius is too small to walk reflect diffusely at the entry, as
        // Cycles' bssrdf_setup turns them into a diffuse BSDF (BSSRDF_MIN_RADIUS): one of
        // the two is chosen by the share of channels that walk, and each weighs only its own.
        let walks = Rgb::new(
            (ss.radius.x >= MIN_WALK_RADIUS) as u8 as f32,
            (ss.radius.y >= MIN_WALK_RADIUS) as u8 as f32,
            (ss.radius.z >= MIN_WALK_RADIUS) as u8 as f32,
        );
        let p_walk = walks.element_sum() / 3.0;
        let mut u = u;
        if p_walk < 1.0 {
            if u[2] >= p_walk {
                let thin = (Rgb::ONE - walks) * albedo.clamp(Rgb::ZERO, Rgb::ONE) / (1.0 - p_walk);
                return Some(SubsurfaceExit { se: *s, n_g: s.ng, n_s: n, weight: thin });
            }
            u[2] /= p_walk;
        }
        let (mfp, diffuse_entry, roughness, ior) = match ss.method {
            // The entry refracts at the specular layer's IOR, as Cycles' (`eta`, after the
            // Specular IOR Level's adjustment): a Principled BSDF with level 0 enters almost
            // straight (1.01), not at its IOR (1.5 bent walks deeper: 2-8 % darker on a
            // subsurface Suzanne against Cycles).
            SubsurfaceMethod::RandomWalk => {
                let eta = if ss.enter_at_ior { ss.ior } else { layer_eta };
                (ss.radius * (0.25 * std::f32::consts::FRAC_1_PI), false, base_roughness, eta.clamp(1.01, 3.8))
            }
            SubsurfaceMethod::RandomWalkSkin => {
                let r = Rgb::new(
                    skin_mean_free_path(ss.radius.x, albedo.x, ss.ior),
                    skin_mean_free_path(ss.radius.y, albedo.y, ss.ior),
                    skin_mean_free_path(ss.radius.z, albedo.z, ss.ior),
                );
                (r, u[2] < 0.5, 1.0, ss.ior)
            }
        };
        let entry = if diffuse_entry {
            Frame::from_normal(-n).to_world(cosine_hemisphere(Vec2::new(u[0], u[1])))
        } else {
            // Refraction about a visible microfacet normal; like Cycles, only the
            // direction is taken from the interface (no Fresnel or masking weight).
            let frame = Frame::from_normal(n);
            let wo_local = frame.to_local(wo);
            if wo_local.z <= 0.0 {
                return None;
            }
            let m = Ggx::from_roughness(roughness).sample_visible_normal(wo_local, Vec2::new(u[0], u[1]));
            frame.to_world(refract(wo_local, m, ior)?)
        };
        if entry.dot(s.ng) >= 0.0 {
            return None;
        }
        // `mfp` is a function of the material and the albedo (Skin's), so the albedo keys it.
        let memo = &ctx.scene.materials[s.material as usize].walk_memo;
        let walk = match memo.get() {
            Some((a, walk)) if *a == albedo => *walk,
            _ => {
                let walk = WalkMedium::new(albedo, mfp, ss.anisotropy);
                let _ = memo.set((albedo, walk));
                walk
            }
        };
        let mut rng = WalkRng::new(u[3], s.tri);
        let mut near = crate::accel::NO_TRIANGLE;
        // The channels that do not walk have no throughput in it (their free flights are
        // never drawn, as Cycles' zero-weight channels).
        let exit = crate::medium::walk::random_walk(
            |o, d, t| ctx.intersect(o, d, t),
            |p, cap| ctx.clearance(p, cap, &mut near),
            s.p,
            n,
            offset_ray_origin(s.p, -s.ng),
            entry,
            &walk,
            beta * walks,
            &mut rng,
        )?;
        let se = ctx.scene.surface(&exit.hit, exit.org, exit.dir);
        // The walk came from the inside: the exit's normals on the outside.
        Some(SubsurfaceExit { se, n_g: -se.ng, n_s: -se.ns, weight: exit.weight * walks / p_walk })
    }
}

/// Below this radius (scene units) a channel does not walk but reflects diffusely at the
/// entry (Cycles' BSSRDF_MIN_RADIUS).
const MIN_WALK_RADIUS: f32 = 1e-8;

/// Where the subsurface part of a material leaves the surface.
pub struct SubsurfaceExit {
    /// The exit point: the walk's, or the entry itself for the channels too thin to walk.
    pub se: SurfaceHit,
    /// Its geometric normal on the outside.
    pub n_g: Vec3,
    /// Its shading normal on the outside (the Lambertian exit's).
    pub n_s: Vec3,
    /// The part's throughput factor (per unit of its selection weight).
    pub weight: Rgb,
}

/// What a ray that escapes finds, with the world's part (not the suns') times `world_factor`
/// (Fast GI's occlusion test).
#[inline]
fn escaped_scaled(st: &PathState, ctx: &SceneContext, world_factor: f32) -> Option<Rgb> {
    if world_factor == 1.0 {
        return st.escaped_radiance(ctx);
    }
    let mut world = Rgb::ZERO;
    let total = st.escaped_radiance_each(ctx, |light, c| {
        if light.is_none() {
            world = c;
        }
    })?;
    Some(total - world * (1.0 - world_factor))
}

/// Fast GI's additive ambient occlusion at `s` per unit throughput (Cycles'
/// `integrate_surface_ao`): the diffuse closures' weight times `factor` when one cosine ray
/// about the shading normal, drawn with the BSDF's numbers `u`, leaves within `distance`
/// unblocked (transparent surfaces let part of it through).
#[allow(clippy::too_many_arguments)]
fn additive_ao(
    ctx: &SceneContext,
    s: &SurfaceHit,
    sp: &ShadingPoint,
    at: &crate::bsdf::BsdfAt,
    wo: Vec3,
    factor: f32,
    distance: f32,
    u: Vec2,
    path: LightPath,
    stats: &mut RayStats,
) -> Rgb {
    let weight = at.class_albedo()[0] * factor;
    if weight == Rgb::ZERO {
        return Rgb::ZERO;
    }
    let n = if sp.frame.n.dot(wo) < 0.0 { -sp.frame.n } else { sp.frame.n };
    let ng = if s.ng.dot(n) < 0.0 { -s.ng } else { s.ng };
    let wi = Frame::from_normal(n).to_world(cosine_hemisphere(u));
    if wi.dot(ng) <= 0.0 {
        return Rgb::ZERO;
    }
    stats.shadow += 1;
    weight * ctx.transmittance(offset_ray_origin(s.p, ng), wi, distance, path.shadow())
}
