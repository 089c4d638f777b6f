//! Jensen's two-pass photon mapping, the rendering pass (the photon pass is
//! `trace.rs`, the maps `io.rs`). The maps are read only for the diffuse-like part f_D
//! of a BSDF; its glossy part f_G (specular lobes and glossy ones below the roughness
//! threshold, `lobes.rs`) is followed by sampling, as Jensen's method intends. At a
//! vertex x reached from the camera through glossy scattering only (E G* x):
//!
//! ```text
//! L(x) = Le + direct (NEE for the whole BSDF, MIS against the BSDF-sampled next ray)
//!      + caustics through f_D (caustic map: photons of L G+ D paths)
//!      + indirect through f_D: diffuse_bounces = 0: global map at x (photons after ≥ 1
//!                                  bounce, not on L G+ D paths: those are the caustics)
//!                              b ≥ 1: gather rays sampled from the BSDF and weighted by
//!                                  f_D; each follows glossy scattering, path-traces b - 1
//!                                  diffuse-like bounces (NEE + MIS), then reads the global
//!                                  map (all photons) through f_D where it lands
//!      + glossy through f_G: the camera path goes on (x's outgoing light again).
//! ```
//!
//! **Roles.** One ray serves all of a vertex's terms: its throughput is split into roles
//! by the diffuse-like bounces taken since the camera, k = 0 (the camera role above),
//! 1..b-1 (path traced: NEE, emission with MIS) and b (gather: reads the global map
//! through f_D, no NEE). A BSDF sample of weight w = f cos / p moves role k's share
//! w_D = f_D cos / p to role k + 1 (the gather role's is spent on its map read) and keeps
//! w_G = w − w_D in role k; emission the ray finds counts with MIS for every role that
//! made NEE at the vertex it left (through the whole w), plainly for the gather role's
//! glossy share when b ≥ 2, and not for it when b = 1 (L G+ D light: the caustic map's).
//! On a purely diffuse-like material this is the classic final gather bit for bit in
//! expectation; on a purely glossy one, a path tracer until a diffuse-like surface.
//! Extra gather rays (`gather_rays` > 1) at a camera-role vertex are chains of their own
//! that count no direct light (NEE and the shared ray did); the shared ray carries 1/N of
//! the gather role.
//!
//! Light passes and light groups (when asked): each chain keeps the path tracer's tally
//! (`light_passes::Tally`) of the camera path's first event, extra gather chains theirs;
//! map reads are indirect, split by class at the first vertex (`map_read.rs`) and by the
//! photons' light groups; media and subsurface parts file through `PathIntegrator::*_filed`.
//!
//! Shadow catchers (`integrator::catcher`): the camera chain splits where its camera
//! segment ends on a catcher, as the path tracer's; the catcher pass is the path tracer's
//! walk from there in the scene of catchers only (no photon map holds that scene's light).
//! Light groups of a split path still file (the path tracer's stop at the split).
//!
//! Depth: a photon with hit index j read at the camera path's n-th scattering event
//! makes a path of (j - 1) + n events; only those within `max_depth` are counted, so
//! the result converges to the path tracer's at the same maximum depth. At a contact (a
//! glass resting on a floor) a read counts direct photons only (`contact.rs`).
//!
//! Parameters (defaults in `PhotonSettings`): k = 20 neighbours (10 in the caustic map),
//! maximum radius a tenth of the scene radius, 1 gather ray per camera sample, 1 diffuse
//! bounce (final gather, at most `MAX_DIFFUSE_BOUNCES`), maximum depth as the path
//! tracer's. Media: a chain that scatters in a medium is path traced from there (media
//! have no photon map); crossing media, chains carry their transmittance; the subsurface
//! part of a material is path traced, its BSDF part as above. Emitting media send photons
//! as lights do (`light::media_emit`), and the chain sees their emission along its rays
//! as a light no NEE samples (weight 1 where a light's would take MIS). Not handled: shadow photons
//! (measured not to pay off: shadow rays are ~2 % of the render, less than the lookups
//! that would skip them; docs/benchmarks.md), photon-map irradiance caching.

use super::contact;
use super::io::PhotonMaps;
use super::lobes::Split;
use super::map_read::{self, Want};
use crate::film::CameraSample;
use crate::integrator::SceneContext;
use crate::integrator::catcher::{self, Split as CatcherSplit};
use crate::integrator::filing::Filing;
use crate::integrator::light_passes::{Tally, shares_at};
use crate::integrator::nee::surface_nee_at;
use crate::integrator::path::PathIntegrator;
use crate::integrator::walk::{PathState, Step};
use crate::math::{Rgb, offset_ray_origin};
use crate::medium::MediumStack;
use crate::passes::slot;
use crate::render::job::RayStats;
use crate::sampling::PixelSampler;
use crate::scene::camera::CameraRay;
use crate::scene::shading::{ShadingPoint, SurfaceHit};
use crate::scene::visibility::RayMask;
use glam::{Vec2, Vec3};
use std::sync::Arc;

/// The rendering pass's parameters and its photon maps.
#[derive(Clone, Debug)]
pub struct JensenIntegrator {
    /// Global and caustic maps.
    pub maps: Arc<PhotonMaps>,
    /// Maximum scattering events per path.
    pub max_depth: u32,
    /// Russian roulette from this depth on gather paths.
    pub rr_depth: u32,
    /// Neighbours per global-map estimate.
    pub k: usize,
    /// Neighbours per caustic-map estimate.
    pub caustic_k: usize,
    /// Maximum search radius.
    pub max_radius: f32,
    /// Gather rays at the first diffuse hit.
    pub gather_rays: u32,
    /// Non-specular bounces before reading the global map (0: at x₁).
    pub diffuse_bounces: u32,
    /// Camera rays that miss show nothing (Film → Transparent), as in the path tracer.
    pub transparent_background: bool,
    /// File contributions into the light passes (`jensen_passes.rs`; only when asked).
    pub light_passes: bool,
    /// File contributions by their emitter's light group (only when asked).
    pub light_groups: bool,
    /// Film → Transparent Glass's roughness threshold (the path tracer's rule).
    pub glass_threshold: Option<f32>,
}

impl JensenIntegrator {
    /// The rendering pass over `maps` with the settings' k, radius and gather; the
    /// maximum radius defaults to a tenth of the scene's radius `scene_radius`.
    pub fn new(
        maps: PhotonMaps,
        settings: &super::PhotonSettings,
        scene_radius: f32,
        max_depth: u32,
        transparent_background: bool,
    ) -> Self {
        JensenIntegrator {
            maps: Arc::new(maps),
            max_depth,
            rr_depth: super::super::path::PathIntegrator::default().rr_depth,
            k: settings.k,
            caustic_k: settings.caustic_k,
            max_radius: settings.max_radius.unwrap_or_else(|| super::default_max_radius(scene_radius)),
            gather_rays: settings.gather_rays,
            diffuse_bounces: settings.diffuse_bounces,
            transparent_background,
            light_passes: false,
            light_groups: false,
            glass_threshold: None,
        }
    }

    /// The path tracer that takes over where a path scatters in a medium (media have no
    /// photon map).
    fn continuation(&self) -> PathIntegrator {
        PathIntegrator {
            max_depth: self.max_depth,
            rr_depth: self.rr_depth,
            transparent_background: self.transparent_background,
            glass_threshold: None,
            light_passes: false,
            light_groups: false,
            merged_delta_light: false,
            // Fast GI is the path tracer's own (warned for the others).
            fast_gi: None,
            // Continued paths are past the first hit, where the albedo is taken.
            guides: true,
        }
    }

    /// The subsurface part of the material at `s` (no photon map: path traced), times `beta`.
    #[allow(clippy::too_many_arguments)]
    fn subsurface_part(
        &self,
        ctx: &SceneContext,
        s: &crate::scene::shading::SurfaceHit,
        sp: &crate::scene::shading::ShadingPoint,
        wo: Vec3,
        wo_local: Vec3,
        media: MediumStack,
        beta: Rgb,
        depth: u32,
        sampler: &mut PixelSampler,
        stats: &mut RayStats,
        filing: Option<Filing<'_>>,
    ) -> Rgb {
        if ctx.scene.materials[s.material as usize].subsurface.is_none() {
            return Rgb::ZERO;
        }
        let q = sp.bsdf.subsurface_weight(wo_local);
        if q > 0.0 {
            self.continuation().subsurface_from_filed(ctx, s, sp, wo, media, beta * q, depth, sampler, stats, filing)
        } else {
            Rgb::ZERO
        }
    }

    /// The light-pass tally and light groups a path continued from a chain files by, when
    /// either is asked.
    fn filing<'a>(&self, tally: Tally, out: &'a mut CameraSample) -> Option<Filing<'a>> {
        let f = Filing { tally: self.light_passes.then_some(tally), groups: self.light_groups, out };
        f.any().then_some(f)
    }

    /// Files a map read `r` taken by a role of throughput `role` (Combined has its total).
    fn file_read(&self, out: &mut CameraSample, tally: &Tally, role: Rgb, r: &map_read::MapRead, want: Want<'_>) {
        if self.light_passes {
            if want.classes.is_some() {
                for (sl, c) in [slot::DIFF_IND, slot::GLOSS_IND, slot::TRANS_IND].into_iter().zip(r.classes) {
                    out.aov.add3(sl, role * c);
                }
            } else {
                tally.indirect(out, role * r.total);
            }
        }
        if want.groups {
            for (g, c) in r.groups.0.iter().enumerate() {
                out.groups.add(g as u8, role * Rgb::from_array(*c));
            }
        }
    }

    /// Parameters, for logs and the summary.
    pub fn describe(&self) -> String {
        format!(
            "photon (global {} photons emitted / {} stored, caustic {} / {}, k {} (caustic {}), max radius {:.4}, {} gather rays, {} diffuse bounce(s), max depth {})",
            self.maps.emitted[0],
            self.maps.global.len(),
            self.maps.emitted[1],
            self.maps.caustic.len(),
            self.k,
            self.caustic_k,
            self.max_radius,
            self.gather_rays,
            self.diffuse_bounces,
            self.max_depth
        )
    }

    /// Radiance arriving at the camera along a ray.
    pub fn li(
        &self,
        ctx: &SceneContext,
        ray: &CameraRay,
        sampler: &mut PixelSampler,
        depth_of: impl Fn(Vec3) -> f32,
        stats: &mut RayStats,
    ) -> CameraSample {
        let mut out = CameraSample { depth: f32::INFINITY, ..Default::default() };
        stats.camera += 1;
        let mut roles = [Rgb::ZERO; MAX_ROLES];
        roles[0] = Rgb::ONE;
        // What the camera ray finds first has no MIS (the state's pdf is 0).
        let chain = Chain {
            st: PathState::camera(ray, ctx.camera_media),
            roles,
            e_mis: Rgb::ONE,
            e_plain: Rgb::ZERO,
            e_medium: Rgb::ONE,
            tally: Tally::default(),
        };
        let mut split = CatcherSplit::new(ctx.catcher.is_some());
        out.radiance = self.walk(ctx, chain, sampler, &depth_of, &mut out, stats, &mut split);
        if let (Some(pass_ctx), Some((pre, _))) = (ctx.catcher.as_deref(), split.at) {
            // The catcher pass (`integrator::catcher`): the same camera segment again in the
            // scene of catchers only, path traced (no photon map holds that scene's light):
            // consistent as the photon estimate of Combined is, unbiased on its own.
            let pass = self.continuation().continue_path(pass_ctx, pre, sampler, stats);
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
        out
    }

    /// The gather role's index b (roles 0..=b are live), capped by `MAX_ROLES`.
    #[inline]
    fn gather_role(&self) -> usize {
        (self.diffuse_bounces as usize).min(MAX_ROLES - 1)
    }

    /// Follows one chain of rays (module doc: the roles), returning the radiance it
    /// brings. The camera's chain fills `out`'s first-hit values and notes in `split` where
    /// it finds a shadow catcher first (when allowed); gather chains that start at depth ≥ 1
    /// leave them alone. Every chain files its light passes (by its tally) and light groups
    /// into `out` when they are asked.
    #[allow(clippy::too_many_arguments)]
    fn walk(
        &self,
        ctx: &SceneContext,
        mut c: Chain,
        sampler: &mut PixelSampler,
        depth_of: &dyn Fn(Vec3) -> f32,
        out: &mut CameraSample,
        stats: &mut RayStats,
        split: &mut CatcherSplit,
    ) -> Rgb {
        let b = self.gather_role();
        let max_r2 = self.max_radius * self.max_radius;
        let mut radiance = Rgb::ZERO;
        let (passes, grouping) = (self.light_passes, self.light_groups);
        let groups = &ctx.scene.light_groups;
        // Film → Transparent Glass: a camera chain that has only refracted through glass
        // under the threshold leaves the world it meets transparent (the path tracer's
        // rule). Glass has no diffuse-like part, so such a chain carries the camera role
        // alone: what it finds is the camera's.
        let glass_limit = self.glass_threshold.filter(|_| self.transparent_background && c.st.depth == 0);
        let mut see_through = glass_limit.is_some();
        loop {
            let [u_light, u_lx, u_ly, u_lobe] = sampler.next_4d();
            let [u_dx, u_dy, u_rr, u_channel] = sampler.next_4d();
            let u_dist = if ctx.has_media { sampler.next_4d()[0] } else { 0.0 };
            // The camera segment as it starts, should it end on a shadow catcher (its
            // throughput is the camera role's).
            let pre = (split.allowed && c.st.depth == 0).then(|| PathState { beta: c.total(), ..c.st });

            // Along the ray, with a unit throughput: the segment's weight then scales every
            // role. Lights crossed count as emission found (MIS and plain weights).
            let (e_mis, e_plain) = (c.e_mis, c.e_plain);
            let mut crossed_any = false;
            let mut medium_l = Rgb::ZERO;
            let depth_before = c.st.depth;
            c.st.beta = Rgb::ONE;
            let out_groups = &mut out.groups;
            let (step, crossed_l) = c.st.advance_with(
                ctx,
                Some([u_channel, u_dist]),
                || sampler.next_4d()[0],
                |st, t_event, w| {
                    let mut l = Rgb::ZERO;
                    for (e, pdf) in [(e_mis, st.prev_pdf), (e_plain, 0.0)] {
                        if e == Rgb::ZERO {
                            continue;
                        }
                        let (le, any) = ctx.crossed_emission_each(
                            st.org,
                            st.dir,
                            t_event,
                            st.prev_p,
                            st.prev_n,
                            pdf,
                            st.depth == 0,
                            st.prev_tri,
                            &st.light_path,
                            |light, c| {
                                if grouping {
                                    out_groups.add(groups.of_light(light), e * w * c);
                                }
                            },
                        );
                        crossed_any |= any;
                        l += e * w * le;
                    }
                    l
                },
                &mut medium_l,
                stats,
            );
            let along = crossed_l + c.e_medium * medium_l;
            radiance += along;
            if passes && along != Rgb::ZERO {
                // Crossed lights and media's emission (which goes to no light group).
                c.tally.found(out, depth_before, along, false);
            }
            let seg = std::mem::replace(&mut c.st.beta, Rgb::ONE);
            c.scale(seg);
            if crossed_any && c.st.depth == 0 {
                out.alpha = 1.0;
            }
            let (hit, s) = match step {
                Step::End => break,
                Step::Passed => continue,
                Step::Medium { p, phase, .. } => {
                    // Media have no photon map: every role is path traced from here.
                    if c.st.depth == 0 {
                        out.alpha = 1.0;
                        out.depth = depth_of(p);
                    }
                    let total = c.total();
                    if c.st.depth < self.max_depth && total.is_finite() && total != Rgb::ZERO {
                        let filing = self.filing(c.tally, out);
                        radiance += self.continuation().scatter_in_medium_filed(
                            ctx, p, c.st.dir, phase, c.st.media, total, c.st.depth, sampler, stats, filing,
                        );
                    }
                    break;
                }
                Step::Escaped => {
                    // The world and sun disks.
                    let seen_directly = c.st.depth == 0;
                    if split.allowed && seen_directly {
                        split.background = c.st.escaped_radiance(ctx).map_or(Rgb::ZERO, |le| c.total() * le);
                    }
                    if grouping {
                        // As the path tracer: the world seen through a transparent film too.
                        c.each_found(|st| {
                            st.escaped_radiance_each(ctx, |light, l| {
                                let g = light.map_or(groups.world, |i| groups.of_light(i));
                                out.groups.add(g, st.beta * l);
                            });
                        });
                    }
                    let through_glass = see_through && !seen_directly;
                    if through_glass {
                        // What the throughput carries is transparent (Cycles' `transparent
                        // += average(throughput)`).
                        out.alpha = (out.alpha - c.total().element_sum() / 3.0).max(0.0);
                    }
                    let hidden = (seen_directly && self.transparent_background) || through_glass;
                    if !hidden || passes {
                        let le = c.found(|st| st.escaped_radiance(ctx).map_or(Rgb::ZERO, |le| st.beta * le));
                        if passes {
                            // The Environment pass shows the world behind a transparent film too.
                            c.tally.found(out, c.st.depth, le, true);
                        }
                        if !hidden {
                            if seen_directly && le != Rgb::ZERO {
                                out.alpha = 1.0;
                            }
                            radiance += le;
                        }
                    }
                    break;
                }
                Step::Surface { hit, s } => (hit, s),
            };
            // A holdout seen by a camera ray: nothing, alpha 0 (as the path tracer).
            if c.st.depth == 0 && ctx.is_holdout(hit.tri) {
                out.alpha = 0.0;
                out.held = 1.0;
                break;
            }
            // A shadow catcher seen by the camera ray: the path splits here (the catcher
            // pass follows in `li`); what it gathered so far is the matte's.
            if let Some(pre) = pre
                && ctx.is_catcher(hit.tri)
            {
                split.at = Some((pre, radiance));
            }
            let wo = -c.st.dir;
            let sp = ctx.shade(&s, wo);
            if c.st.depth == 0 {
                let (alpha, held) = SceneContext::holdout_alpha(&sp, c.total());
                out.alpha = alpha;
                out.held = 1.0 - alpha;
                if held {
                    break;
                }
                out.depth = depth_of(s.p);
                out.normal = sp.frame.n;
                out.albedo = sp.bsdf.albedo();
            }
            if sp.emitted != Rgb::ZERO {
                let le = c.found(|st| st.surface_emission(ctx, &hit, &s, &sp));
                radiance += le;
                if grouping {
                    out.groups.add(groups.of_tri(hit.tri), le);
                }
                if passes {
                    c.tally.found(out, c.st.depth, le, false);
                }
            }
            if c.st.depth >= self.max_depth || ctx.ends_at_surface(c.st.light_path) {
                break;
            }
            let wo_local = sp.frame.to_local(wo);
            let at = sp.bsdf.at(wo_local);
            if passes && c.st.depth == 0 {
                Tally::colours(out, &at, c.total());
            }
            let filing = self.filing(c.tally, out);
            radiance += self.subsurface_part(
                ctx,
                &s,
                &sp,
                wo,
                wo_local,
                c.st.media,
                c.total(),
                c.st.depth,
                sampler,
                stats,
                filing,
            );
            let delta = sp.bsdf.is_delta();
            let split = Split::of(&sp.bsdf);
            let n_select = if sp.bsdf.transmits() { Vec3::ZERO } else { s.ng };
            // This vertex is scattering event d; a photon with hit index j read here makes
            // a path of j - 1 + d events.
            let d = c.st.depth + 1;
            let jmax = self.max_depth + 1 - d;
            let nee_beta = c.nee_roles(b);
            if !delta {
                // Direct light for the roles that path-trace it, MIS against this vertex's
                // BSDF sample (the chain's next ray).
                if nee_beta != Rgb::ZERO {
                    let (l, wi_light, light) = surface_nee_at(
                        ctx,
                        &s,
                        &sp,
                        &at,
                        n_select,
                        1.0,
                        nee_beta,
                        c.st.media,
                        u_light,
                        Vec2::new(u_lx, u_ly),
                        stats,
                    );
                    radiance += l;
                    if grouping {
                        out.groups.add(groups.of_light(light), l);
                    }
                    if passes && l != Rgb::ZERO {
                        c.tally.estimated(out, c.st.depth, l, Some(shares_at(&at, wi_light)));
                    }
                }
                let mapped = (c.roles[0] != Rgb::ZERO || (b > 0 && c.roles[b] != Rgb::ZERO)) && split.has_diffuse(&at);
                if mapped {
                    // At a contact (a glass resting on a floor) paths get direct light only
                    // (`contact.rs`): photons straight from their lights.
                    let jmax = if contact::at_contact(ctx, &s, c.st.ray) { 1 } else { jmax };
                    // Each photon through the classes its kinds allow (`visibility.rs`).
                    let f_d = |p: &super::Photon| {
                        super::visibility::map_weight(split, &at, wo_local.z, sp.frame.to_local(p.wi()), p.kinds())
                    };
                    // Every map read is indirect light (a photon has left its light and
                    // bounced at least once); at the first vertex it is filed by the class
                    // of each photon's direction (`map_read`), later by the first event's.
                    let want =
                        Want { classes: (passes && c.st.depth == 0).then_some((&at, &sp.frame)), groups: grouping };
                    if c.roles[0] != Rgb::ZERO {
                        // The camera role: caustics (L G+ D) from the caustic map, and with
                        // no gather (b = 0) the rest of the indirect light from the global one.
                        let caustic = map_read::read(
                            &self.maps.caustic,
                            s.p,
                            s.ng,
                            self.caustic_k,
                            max_r2,
                            |p| p.depth() <= jmax,
                            f_d,
                            want,
                        );
                        let mut l = caustic.total;
                        self.file_read(out, &c.tally, c.roles[0], &caustic, want);
                        if b == 0 {
                            let global = map_read::read(
                                &self.maps.global,
                                s.p,
                                s.ng,
                                self.k,
                                max_r2,
                                |p| p.depth() >= 2 && !p.caustic() && p.depth() <= jmax,
                                f_d,
                                want,
                            );
                            l += global.total;
                            self.file_read(out, &c.tally, c.roles[0], &global, want);
                        }
                        radiance += c.roles[0] * l;
                    }
                    if b > 0 && c.roles[b] != Rgb::ZERO {
                        // The gather role: everything the global map holds.
                        let global = map_read::read(
                            &self.maps.global,
                            s.p,
                            s.ng,
                            self.k,
                            max_r2,
                            |p| p.depth() <= jmax,
                            f_d,
                            want,
                        );
                        radiance += c.roles[b] * global.total;
                        self.file_read(out, &c.tally, c.roles[b], &global, want);
                    }
                    // More gather rays at a camera-role vertex: each a chain of its own that
                    // counts no direct light (NEE and this chain's sample did).
                    if b > 0 && c.roles[0] != Rgb::ZERO && self.gather_rays > 1 && d < self.max_depth {
                        for _ in 1..self.gather_rays {
                            let [v_lobe, v_x, v_y, _] = sampler.next_4d();
                            let Some(bs) = at.sample(v_lobe, Vec2::new(v_x, v_y)) else { continue };
                            let w_d = split.diffuse_of_sample(&at, bs.wi, bs.f, bs.delta) * (bs.wi.z.abs() / bs.pdf);
                            let mut roles = [Rgb::ZERO; MAX_ROLES];
                            roles[1] = c.roles[0] * w_d / self.gather_rays as f32;
                            let mut tally = c.tally;
                            if passes && c.st.depth == 0 {
                                tally.surface_bounce_sampled(&at, &bs);
                            }
                            let mut g = Chain {
                                st: c.st,
                                roles,
                                e_mis: Rgb::ZERO,
                                e_plain: Rgb::ZERO,
                                e_medium: Rgb::ZERO,
                                tally,
                            };
                            if roles[1] == Rgb::ZERO || !g.bounce(ctx, &s, &sp, wo_local, &bs, n_select, stats) {
                                continue;
                            }
                            // Starting at depth ≥ 1, the chain leaves the first-hit values alone.
                            radiance += self.walk(ctx, g, sampler, depth_of, out, stats, &mut CatcherSplit::new(false));
                        }
                    }
                }
            }

            // The chain's next ray, sampled from the whole BSDF: its diffuse-like share moves
            // each role k < b on to role k + 1 (the camera role's shared with the extra
            // gather rays), its glossy share keeps the role.
            let Some(bs) = at.sample(u_lobe, Vec2::new(u_dx, u_dy)) else {
                break;
            };
            let mut cos_over_pdf = bs.wi.z.abs() / bs.pdf;
            // Shading Offset on a reflected sample, as the path tracer (`path.rs`).
            if sp.bsdf.reflects(wo_local, bs.wi) {
                cos_over_pdf *= ctx.scene.ray_visibility.shading_offset_factor(s.tri, bs.wi.z.abs());
            }
            let w_all = bs.f * cos_over_pdf;
            if !w_all.is_finite() {
                break;
            }
            let w_d = split.diffuse_of_sample(&at, bs.wi, bs.f, bs.delta) * cos_over_pdf;
            let w_g = (w_all - w_d).max(Rgb::ZERO);
            if passes && c.st.depth == 0 {
                c.tally.surface_bounce_sampled(&at, &bs);
            }
            let mut next = [Rgb::ZERO; MAX_ROLES];
            for k in 0..=b {
                if c.roles[k] == Rgb::ZERO {
                    continue;
                }
                next[k] += c.roles[k] * w_g;
                if k < b {
                    let share = if k == 0 { 1.0 / self.gather_rays.max(1) as f32 } else { 1.0 };
                    next[k + 1] += c.roles[k] * w_d * share;
                }
            }
            // Emission the ray finds: the roles that did NEE here see it through the
            // whole BSDF with MIS; the gather role's glossy share sees it plainly when no
            // caustic map stands for it (b ≥ 2: the vertex before is path traced). Media's
            // emission follows the same rule with no MIS (no NEE samples it): their
            // photons are in the maps as the lights' are (`light::media_emit`).
            let gather_glossy = if b > 0 { c.roles[b] * w_g } else { Rgb::ZERO };
            c.e_mis = nee_beta * w_all;
            c.e_plain = if b >= 2 { gather_glossy } else { Rgb::ZERO };
            // Without glowing media that weight multiplies nothing; it keeps its old
            // value there, since roulette reads every weight (the same draws bit for bit).
            c.e_medium = c.e_mis + if ctx.media_emit { c.e_plain } else { gather_glossy };
            c.roles = next;
            if !(c.largest() > 0.0) || !c.bounce(ctx, &s, &sp, wo_local, &bs, n_select, stats) {
                break;
            }
            see_through &= glass_limit.is_some_and(|t| {
                !sp.bsdf.reflects(wo_local, bs.wi)
                    && bs.kind == crate::bsdf::LobeKind::Glossy
                    && sp.bsdf.glass_alpha2() <= (t * t) * (t * t)
            });
            // Russian roulette on the whole chain, by its largest weight.
            if c.st.depth >= self.rr_depth {
                // Refraction keeps 1 − F of the throughput (Cycles' convention): the chain's
                // own weight is what roulette sees, as the path tracer's.
                let q = c.largest().min(0.95);
                if !(u_rr < q) {
                    break;
                }
                c.scale(Rgb::splat(1.0 / q));
            }
        }
        radiance
    }
}

/// Most roles a chain carries: the camera role, up to `MAX_DIFFUSE_BOUNCES` - 1
/// path-traced ones and the gather role.
const MAX_ROLES: usize = super::MAX_DIFFUSE_BOUNCES as usize + 1;

/// One chain of rays from the camera (or from an extra gather ray) with its throughput
/// split into roles by the diffuse-like bounces taken so far (module doc).
#[derive(Clone, Copy)]
struct Chain {
    /// Geometry, media and MIS state of the next ray (its `beta` is kept at one: the
    /// roles carry the throughput).
    st: PathState,
    /// Throughput of role k: k diffuse-like bounces since the camera.
    roles: [Rgb; MAX_ROLES],
    /// Weight of emission the next ray finds, MIS-weighted against NEE where it left.
    e_mis: Rgb,
    /// Weight of emission the next ray finds with no MIS (no NEE was made for it).
    e_plain: Rgb,
    /// Weight of media's emission along the next ray (`e_mis` + `e_plain`, without MIS).
    e_medium: Rgb,
    /// The light passes' filing of what this chain brings (the first event's class).
    tally: Tally,
}

impl Chain {
    /// Scales every weight (a segment's transmittance, Russian roulette).
    #[inline]
    fn scale(&mut self, w: Rgb) {
        for r in &mut self.roles {
            *r *= w;
        }
        self.e_mis *= w;
        self.e_plain *= w;
        self.e_medium *= w;
    }

    /// Sum of the roles' throughputs: what a path traced from here carries.
    #[inline]
    fn total(&self) -> Rgb {
        self.roles.iter().fold(Rgb::ZERO, |a, r| a + *r)
    }

    /// Throughput of the roles that make NEE at a vertex: all but the gather role b
    /// (with b = 0 the camera role reads the whole map and still makes NEE).
    #[inline]
    fn nee_roles(&self, b: usize) -> Rgb {
        let n = if b == 0 { 1 } else { b };
        self.roles[..n].iter().fold(Rgb::ZERO, |a, r| a + *r)
    }

    /// Largest component of any weight (zero: the chain carries nothing).
    #[inline]
    fn largest(&self) -> f32 {
        let m = self.roles.iter().fold(0.0f32, |a, r| a.max(r.max_element()));
        m.max(self.e_mis.max_element()).max(self.e_plain.max_element()).max(self.e_medium.max_element())
    }

    /// Emission found by the ray: `le(state)` (radiance times the state's throughput)
    /// with MIS for `e_mis` and without for `e_plain`, the state's throughput set to each.
    #[inline]
    fn found(&self, le: impl Fn(&PathState) -> Rgb) -> Rgb {
        let mut l = Rgb::ZERO;
        if self.e_mis != Rgb::ZERO {
            l += le(&PathState { beta: self.e_mis, ..self.st });
        }
        if self.e_plain != Rgb::ZERO {
            l += le(&PathState { beta: self.e_plain, prev_pdf: 0.0, ..self.st });
        }
        l
    }

    /// Calls `f` with each state whose found emission counts ([`found`](Self::found)'s two).
    #[inline]
    fn each_found(&self, mut f: impl FnMut(&PathState)) {
        if self.e_mis != Rgb::ZERO {
            f(&PathState { beta: self.e_mis, ..self.st });
        }
        if self.e_plain != Rgb::ZERO {
            f(&PathState { beta: self.e_plain, prev_pdf: 0.0, ..self.st });
        }
    }

    /// Spawns the next ray from the surface `s` along the sampled `bs`; false when the
    /// shading and geometric normals disagree about the side (light would leak).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn bounce(
        &mut self,
        ctx: &SceneContext,
        s: &SurfaceHit,
        sp: &ShadingPoint,
        wo_local: Vec3,
        bs: &crate::bsdf::BsdfSample,
        n_select: Vec3,
        stats: &mut RayStats,
    ) -> bool {
        let wi = sp.frame.to_world(bs.wi);
        let (co, ci) = (sp.frame.to_world(wo_local).dot(s.ng), wi.dot(s.ng));
        if sp.bsdf.reflects(wo_local, bs.wi) != (co * ci > 0.0) || ci == 0.0 {
            return false;
        }
        let st = &mut self.st;
        st.prev_pdf = if bs.delta { 0.0 } else { bs.pdf };
        st.prev_p = s.p;
        // The receiver normal NEE gave light selection here.
        st.prev_n = n_select;
        st.prev_tri = s.tri;
        st.depth += 1;
        st.media = ctx.medium_after(s, wi, st.media);
        st.ray = RayMask::after_bounce(bs.kind, ci < 0.0);
        st.light_path = s.light_path.moved(s.light_path.ray_length).bounced(bs.kind, ci < 0.0, bs.delta);
        st.org = offset_ray_origin(s.p, if ci > 0.0 { s.ng } else { -s.ng });
        st.dir = wi;
        stats.bounce += 1;
        true
    }
}
