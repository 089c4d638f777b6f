//! Jensen's two-pass photon mapping, the rendering pass (the photon pass is
//! `trace.rs`, the maps `io.rs`). At the first non-specular hit x₁ of a camera path:
//!
//! ```text
//! L(x₁) = Le + direct (NEE, MIS against the gather rays)
//!       + caustics (caustic map, radiance estimate)
//!       + indirect: diffuse_bounces = 0: global map at x₁ (photons after ≥ 1 bounce,
//!                                         not on L S+ D paths: those are the caustics)
//!                   diffuse_bounces = b ≥ 1: N gather rays (BSDF-sampled); each follows
//!                   specular bounces, path-traces b - 1 non-specular bounces (NEE + MIS),
//!                   then reads the global map (all photons) where it lands.
//! ```
//! Specular (delta) surfaces before x₁ are followed as a path tracer does; glossy lobes
//! at x₁ are integrated by the gather rays, which sample the full BSDF. Emission reached
//! from x₁ through specular bounces only is skipped: it is in the caustic map.
//! Depth: a photon with hit index j read at the camera path's n-th scattering event
//! makes a path of (j - 1) + n events; only those within `max_depth` are counted, so
//! the result converges to the path tracer's at the same maximum depth.
//!
//! Parameters (defaults in `PhotonSettings`): k = 20 neighbours (10 in the caustic map), maximum radius a tenth
//! of the scene radius, 1 gather ray per camera sample, 1 diffuse bounce (final gather), maximum depth
//! as the path tracer's. Media: a camera path or gather ray that scatters in a medium is
//! path traced from there (media have no photon map); crossing media, paths carry
//! their transmittance; the subsurface part of a material is path traced, its BSDF part
//! reads the maps. Not handled: shadow photons (measured not to
//! pay off: shadow rays are ~2 % of the render, less than the lookups that would skip them;
//! docs/benchmarks.md), photon-map irradiance caching, the world light.

use super::estimate::radiance;
use super::io::PhotonMaps;
use crate::film::CameraSample;
use crate::integrator::SceneContext;
use crate::integrator::nee::surface_nee;
use crate::integrator::path::PathIntegrator;
use crate::integrator::walk::{PathState, Step};
use crate::math::{Rgb, offset_ray_origin};
use crate::medium::MediumStack;
use crate::render::job::RayStats;
use crate::sampling::PixelSampler;
use crate::scene::camera::CameraRay;
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
        }
    }

    /// The path tracer that takes over where a path scatters in a medium (media have no
    /// photon map).
    fn continuation(&self) -> PathIntegrator {
        PathIntegrator {
            max_depth: self.max_depth,
            rr_depth: self.rr_depth,
            transparent_background: self.transparent_background,
            light_passes: false,
            light_groups: false,
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
    ) -> Rgb {
        if ctx.scene.materials[s.material as usize].subsurface.is_none() {
            return Rgb::ZERO;
        }
        let q = sp.bsdf.subsurface_weight(wo_local);
        if q > 0.0 {
            self.continuation().subsurface_from(ctx, s, sp, wo, media, beta * q, depth, sampler, stats)
        } else {
            Rgb::ZERO
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
        let mut radiance = Rgb::ZERO;
        // A scattering event in a medium is path traced from that vertex on.
        let mut st = PathState::camera(ray, ctx.camera_media);
        stats.camera += 1;
        loop {
            let [u_light, u_lx, u_ly, u_lobe] = sampler.next_4d();
            let [u_dx, u_dy, u_channel, u_dist] = sampler.next_4d();
            // Area lights crossed: every earlier vertex was specular (no MIS).
            st.prev_p = st.org;
            let (step, crossed) =
                st.advance(ctx, [u_channel, u_dist], || sampler.next_4d()[0], true, &mut radiance, stats);
            if crossed && st.depth == 0 {
                out.alpha = 1.0;
            }
            let (hit, s) = match step {
                Step::End => break,
                Step::Passed => continue,
                Step::Medium { p, phase, .. } => {
                    if st.depth == 0 {
                        out.alpha = 1.0;
                        out.depth = depth_of(p);
                    }
                    if st.depth < self.max_depth && st.beta.is_finite() && st.beta != Rgb::ZERO {
                        radiance += self
                            .continuation()
                            .scatter_in_medium(ctx, p, st.dir, phase, st.media, st.beta, st.depth, sampler, stats);
                    }
                    break;
                }
                Step::Escaped => {
                    // The world and sun disks (every earlier vertex was specular).
                    if !(st.depth == 0 && self.transparent_background)
                        && let Some(le) = st.escaped_radiance(ctx)
                    {
                        radiance += st.beta * le;
                        if st.depth == 0 {
                            out.alpha = 1.0;
                        }
                    }
                    break;
                }
                Step::Surface { hit, s } => (hit, s),
            };
            // A holdout seen by a camera ray: nothing, alpha 0 (as the path tracer).
            if st.depth == 0 && ctx.is_holdout(hit.tri) {
                out.alpha = 0.0;
                break;
            }
            let wo = -st.dir;
            let sp = ctx.shade(&s, wo);
            if st.depth == 0 {
                out.alpha = 1.0;
                out.depth = depth_of(s.p);
                out.normal = sp.frame.n;
                out.albedo = sp.bsdf.albedo();
            }
            radiance += st.surface_emission(ctx, &hit, &s, &sp);
            if st.depth >= self.max_depth {
                break;
            }
            let wo_local = sp.frame.to_local(wo);
            radiance += self.subsurface_part(ctx, &s, &sp, wo, wo_local, st.media, st.beta, st.depth, sampler, stats);
            if !sp.bsdf.is_delta() {
                // x₁: the first non-specular hit, scattering event depth + 1.
                radiance += st.beta
                    * self.shade_first_diffuse(
                        ctx,
                        &s,
                        &sp,
                        wo_local,
                        st.depth + 1,
                        u_light,
                        Vec2::new(u_lx, u_ly),
                        st.media,
                        sampler,
                        stats,
                    );
                break;
            }
            // Specular: continue the path.
            if !st.follow_specular(ctx, &s, &sp, wo_local, u_lobe, Vec2::new(u_dx, u_dy), stats) {
                break;
            }
        }
        out.radiance = radiance;
        out
    }

    /// Reflected radiance at x₁ (scattering event `d`), without its emission.
    #[allow(clippy::too_many_arguments)]
    fn shade_first_diffuse(
        &self,
        ctx: &SceneContext,
        s: &crate::scene::shading::SurfaceHit,
        sp: &crate::scene::shading::ShadingPoint,
        wo_local: Vec3,
        d: u32,
        u_light: f32,
        u_pt: Vec2,
        media: MediumStack,
        sampler: &mut PixelSampler,
        stats: &mut RayStats,
    ) -> Rgb {
        let gather = if self.diffuse_bounces == 0 || d >= self.max_depth { 0 } else { self.gather_rays };
        let max_r2 = self.max_radius * self.max_radius;
        // Direct light, MIS against the gather rays (lights below count when the BSDF
        // transmits: photons are gathered on the camera's side only).
        let n_select = if sp.bsdf.transmits() { Vec3::ZERO } else { s.ng };
        let at = sp.bsdf.at(wo_local);
        let mut l = surface_nee(ctx, s, sp, &at, n_select, gather as f32, Rgb::ONE, media, u_light, u_pt, stats);
        // Caustics: photons with hit index j make paths of j - 1 + d events.
        let jmax = self.max_depth + 1 - d;
        l += radiance(&self.maps.caustic, s.p, s.ng, &sp.frame, &sp.bsdf, wo_local, self.caustic_k, max_r2, |p| {
            p.depth() <= jmax
        });
        if self.diffuse_bounces == 0 {
            l += radiance(&self.maps.global, s.p, s.ng, &sp.frame, &sp.bsdf, wo_local, self.k, max_r2, |p| {
                p.depth() >= 2 && !p.caustic() && p.depth() <= jmax
            });
            return l;
        }
        // Final gather.
        let wo = sp.frame.to_world(wo_local);
        let mut gathered = Rgb::ZERO;
        for _ in 0..gather {
            let [u_lobe, u_x, u_y, _] = sampler.next_4d();
            let Some(bs) = sp.bsdf.sample(wo_local, u_lobe, Vec2::new(u_x, u_y)) else {
                continue;
            };
            let wi = sp.frame.to_world(bs.wi);
            let (co, ci) = (wo.dot(s.ng), wi.dot(s.ng));
            if (bs.wi.z * wo_local.z > 0.0) != (co * ci > 0.0) || ci == 0.0 {
                continue;
            }
            // Russian roulette sees the per-ray weight; the 1/N comes at the end.
            let beta = bs.f * (bs.wi.z.abs() / bs.pdf);
            let mis_pdf = if sp.bsdf.is_delta() { 0.0 } else { bs.pdf * gather as f32 };
            let org = offset_ray_origin(s.p, if ci > 0.0 { s.ng } else { -s.ng });
            let gather_media = ctx.medium_after(s, wi, media);
            let st = PathState {
                org,
                dir: wi,
                beta,
                depth: d,
                prev_pdf: mis_pdf,
                prev_p: s.p,
                prev_n: n_select,
                media: gather_media,
                transparent_hits: 0,
                tmax: f32::INFINITY,
                ray: RayMask::after_bounce(bs.kind, ci < 0.0),
                prev_tri: s.tri,
                light_path: s.light_path.bounced(bs.kind, ci < 0.0, bs.delta),
            };
            gathered += self.gather_path(ctx, st, sampler, stats);
        }
        l + gathered / gather.max(1) as f32
    }

    /// One gather ray from x₁ (scattering event `d`): radiance it brings, times the
    /// state's throughput.
    fn gather_path(
        &self,
        ctx: &SceneContext,
        mut st: PathState,
        sampler: &mut PixelSampler,
        stats: &mut RayStats,
    ) -> Rgb {
        let max_r2 = self.max_radius * self.max_radius;
        let mut l = Rgb::ZERO;
        // Only specular bounces since x₁, and at least one: emission is a caustic.
        let mut delta_only = true;
        let mut bounced = false;
        let mut nondelta = 0u32;
        stats.bounce += 1;
        loop {
            let [u_light, u_lx, u_ly, u_lobe] = sampler.next_4d();
            let [u_dx, u_dy, u_rr, u_channel] = sampler.next_4d();
            let u_dist = if ctx.has_media { sampler.next_4d()[0] } else { 0.0 };
            let caustic = delta_only && bounced;
            let (step, _) = st.advance(ctx, [u_channel, u_dist], || sampler.next_4d()[0], !caustic, &mut l, stats);
            let (hit, s) = match step {
                Step::End => break,
                Step::Passed => continue,
                Step::Medium { p, phase, .. } => {
                    if st.depth < self.max_depth && st.beta.is_finite() && st.beta != Rgb::ZERO {
                        l += self
                            .continuation()
                            .scatter_in_medium(ctx, p, st.dir, phase, st.media, st.beta, st.depth, sampler, stats);
                    }
                    break;
                }
                Step::Escaped => {
                    if !caustic && let Some(le) = st.escaped_radiance(ctx) {
                        l += st.beta * le;
                    }
                    break;
                }
                Step::Surface { hit, s } => (hit, s),
            };
            let wo = -st.dir;
            let sp = ctx.shade(&s, wo);
            if !caustic {
                l += st.surface_emission(ctx, &hit, &s, &sp);
            }
            if st.depth >= self.max_depth {
                break;
            }
            let wo_local = sp.frame.to_local(wo);
            let at = sp.bsdf.at(wo_local);
            l += self.subsurface_part(ctx, &s, &sp, wo, wo_local, st.media, st.beta, st.depth, sampler, stats);
            let delta = sp.bsdf.is_delta();
            let n_select = if sp.bsdf.transmits() { Vec3::ZERO } else { s.ng };
            if !delta {
                nondelta += 1;
                delta_only = false;
                if nondelta >= self.diffuse_bounces {
                    // Read the global map: this is event depth + 1.
                    let jmax = self.max_depth - st.depth;
                    l += st.beta
                        * radiance(&self.maps.global, s.p, s.ng, &sp.frame, &sp.bsdf, wo_local, self.k, max_r2, |p| {
                            p.depth() <= jmax
                        });
                    break;
                }
                l += surface_nee(
                    ctx,
                    &s,
                    &sp,
                    &at,
                    n_select,
                    1.0,
                    st.beta,
                    st.media,
                    u_light,
                    Vec2::new(u_lx, u_ly),
                    stats,
                );
            }
            let Some(bs) = at.sample(u_lobe, Vec2::new(u_dx, u_dy)) else {
                break;
            };
            let wi = sp.frame.to_world(bs.wi);
            let (co, ci) = (wo.dot(s.ng), wi.dot(s.ng));
            if (bs.wi.z * wo_local.z > 0.0) != (co * ci > 0.0) || ci == 0.0 {
                break;
            }
            st.beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
            if !st.beta.is_finite() || st.beta == Rgb::ZERO {
                break;
            }
            st.prev_pdf = if delta { 0.0 } else { bs.pdf };
            st.prev_p = s.p;
            // The receiver normal NEE gave light selection here.
            st.prev_n = n_select;
            bounced = true;
            st.depth += 1;
            if !st.survives(self.rr_depth, u_rr) {
                break;
            }
            st.media = ctx.medium_after(&s, wi, st.media);
            st.org = offset_ray_origin(s.p, if ci > 0.0 { s.ng } else { -s.ng });
            st.dir = wi;
            stats.bounce += 1;
        }
        l
    }
}
