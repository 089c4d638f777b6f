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
//! ray crosses them and the path goes on. Not handled: participating media, delta
//! BSDFs (the materials and media issues), the world (the lights/world issue).

use super::{CameraSample, RayStats, SceneContext, power_heuristic};
use crate::math::{Rgb, offset_ray_origin};
use crate::sampling::PixelSampler;
use crate::scene::AlphaMode;
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
}

impl Default for PathIntegrator {
    fn default() -> Self {
        PathIntegrator { max_depth: 13, rr_depth: 3, transparent_background: true }
    }
}

/// Limit on pass-throughs of transparent surfaces per path, so that a stack of
/// thousands of transparent layers cannot loop forever.
const MAX_TRANSPARENT_HITS: u32 = 128;

impl PathIntegrator {
    /// Radiance arriving at the camera along a ray.
    pub fn li(
        &self,
        ctx: &SceneContext,
        mut org: Vec3,
        mut dir: Vec3,
        sampler: &mut PixelSampler,
        depth_of: impl Fn(Vec3) -> f32,
        stats: &mut RayStats,
    ) -> CameraSample {
        let mut out = CameraSample { depth: f32::INFINITY, ..Default::default() };
        let mut radiance = Rgb::ZERO;
        let mut beta = Rgb::ONE;
        let mut depth = 0u32;
        let mut transparent_hits = 0u32;
        // Density of the BSDF sample that produced `dir` (0 for camera rays: no MIS).
        let mut prev_bsdf_pdf = 0.0f32;
        let mut prev_p = org;
        // Receiver normal light selection was given at `prev_p` (zero: none), for MIS.
        let mut prev_n = Vec3::ZERO;
        // Absorption coefficient of the medium the path is in (KHR_materials_volume).
        let mut medium: Option<Rgb> = None;
        // Product of η² over refractions, undone in Russian roulette so that the
        // 1/η² radiance scaling inside glass does not end paths early (pbrt's etaScale).
        let mut eta_scale = 1.0f32;
        stats.camera += 1;
        loop {
            // Bounce dimensions, drawn up front so that their positions are fixed.
            let [u_light, u_lx, u_ly, u_lobe] = sampler.next_4d();
            let [u_dx, u_dy, u_rr, u_alpha] = sampler.next_4d();
            let (u_light_pt, u_dir) = (Vec2::new(u_lx, u_ly), Vec2::new(u_dx, u_dy));

            let hit = ctx.intersect(org, dir, f32::INFINITY);
            let t_surface = hit.map_or(f32::INFINITY, |h| h.t);
            let absorb = |t: f32| match medium {
                Some(sigma) => (-sigma * t).exp(),
                None => Rgb::ONE,
            };

            // Area and sphere lights crossed before the surface add their emission; they
            // do not block (as in Cycles) and the path goes on.
            let (crossed, any) = ctx.crossed_emission(org, dir, t_surface, prev_p, prev_n, prev_bsdf_pdf, depth == 0);
            if any {
                radiance += beta * absorb(t_surface.min(1e30)) * crossed;
                if depth == 0 {
                    out.alpha = 1.0;
                }
            }

            let Some(hit) = hit else {
                // Escaped: the world, weighted against light sampling.
                let seen_directly = depth == 0;
                if !(seen_directly && self.transparent_background) {
                    let le = ctx.world_radiance(dir);
                    let sun = ctx.sun_emission(dir, prev_bsdf_pdf);
                    if le != Rgb::ZERO || sun != Rgb::ZERO {
                        let w =
                            if prev_bsdf_pdf == 0.0 { 1.0 } else { power_heuristic(prev_bsdf_pdf, ctx.world_pdf(dir)) };
                        // Escaping from inside a medium means its mesh is open: the
                        // light would have crossed infinitely much of it.
                        let tr = if medium.is_some_and(|sigma| sigma.max_element() > 0.0) { 0.0 } else { 1.0 };
                        radiance += beta * (le * w + sun) * tr;
                        if seen_directly {
                            out.alpha = 1.0;
                        }
                    }
                }
                break;
            };
            if medium.is_some() {
                beta *= absorb(hit.t);
            }
            let s = ctx.surface(&hit, org, dir);
            let wo = -dir;

            // Stochastic transparency: pass straight through with probability 1 - alpha.
            if ctx.scene.materials[s.material as usize].alpha_mode == AlphaMode::Blend {
                let alpha = ctx.alpha(hit.tri, hit.b1, hit.b2);
                if u_alpha >= alpha && transparent_hits < MAX_TRANSPARENT_HITS {
                    transparent_hits += 1;
                    org = offset_ray_origin(s.p, -s.ng);
                    stats.bounce += 1;
                    continue;
                }
            }

            let sp = ctx.shade(&s, wo);
            if depth == 0 {
                out.alpha = 1.0;
                out.depth = depth_of(s.p);
                out.normal = sp.frame.n;
                out.albedo = sp.bsdf.albedo();
            }

            // Emission found by the path, weighted against light sampling.
            if sp.emitted != Rgb::ZERO {
                let w = match (prev_bsdf_pdf > 0.0, ctx.lights.light_of_triangle(hit.tri)) {
                    (true, Some(index)) => {
                        power_heuristic(prev_bsdf_pdf, ctx.light_pdf(index, prev_p, prev_n, s.p, s.ng))
                    }
                    _ => 1.0,
                };
                radiance += beta * sp.emitted * w;
            }

            if depth >= self.max_depth {
                break;
            }

            let wo_local = sp.frame.to_local(wo);

            // Next-event estimation: one light (useless for pure delta BSDFs such as
            // clear glass). Without transmission no light below the surface can count,
            // which the light tree uses.
            let n_select = if sp.bsdf.transmits() { Vec3::ZERO } else { s.ng };
            let nee = if sp.bsdf.is_delta() { None } else { ctx.lights.sample(s.p, n_select, u_light) };
            if let Some((index, pmf)) = nee
                && let Some(ls) = ctx.sample_light(index, s.p, u_light_pt)
            {
                let wi_local = sp.frame.to_local(ls.wi);
                let f = sp.bsdf.eval(wo_local, wi_local) * wi_local.z.abs();
                // Shading and geometric normals must agree on reflection versus
                // transmission, or light would leak through the surface.
                let consistent = (wi_local.z > 0.0) == (ls.wi.dot(s.ng) > 0.0);
                if f != Rgb::ZERO && ls.li != Rgb::ZERO && consistent {
                    stats.shadow += 1;
                    // An unoccluded shadow segment stays in one medium (boundaries
                    // block shadow rays): the current one, or the one across this
                    // surface when the light is on the other side.
                    let tr = match ctx.medium_after(&s, ls.wi, medium) {
                        Some(sigma) if ls.dist.is_finite() => (-sigma * ls.dist).exp(),
                        _ => Rgb::ONE,
                    };
                    let vis = ctx.visibility(s.p, s.ng, &ls);
                    if vis > 0.0 {
                        let w =
                            if ls.delta { 1.0 } else { power_heuristic(ls.pdf * pmf, sp.bsdf.pdf(wo_local, wi_local)) };
                        radiance += beta * f * tr * ls.li * (vis * w / (ls.pdf * pmf));
                    }
                }
            }

            // Sample the BSDF for the next direction.
            let Some(bs) = sp.bsdf.sample(wo_local, u_lobe, u_dir) else {
                break;
            };
            let wi = sp.frame.to_world(bs.wi);
            let transmitted = bs.wi.z < 0.0;
            if transmitted != (wi.dot(s.ng) < 0.0) {
                // The shading normal disagrees with the geometry about the side.
                break;
            }
            beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
            if !beta.is_finite() || beta == Rgb::ZERO {
                break;
            }
            // After a delta lobe, emission found next is not MIS-weighted (0 = "specular").
            prev_bsdf_pdf = if bs.delta { 0.0 } else { bs.pdf };
            prev_p = s.p;
            prev_n = n_select;
            depth += 1;

            // Crossing an interface of a solid changes the medium and the η scale.
            medium = ctx.medium_after(&s, wi, medium);
            if transmitted {
                let mat = &ctx.scene.materials[s.material as usize];
                if mat.volume.is_some() {
                    let eta = if s.front { mat.ior } else { 1.0 / mat.ior };
                    eta_scale *= eta * eta;
                }
            }

            // Russian roulette.
            if depth >= self.rr_depth {
                let survive = (beta.max_element() * eta_scale).min(0.95);
                if u_rr >= survive {
                    break;
                }
                beta /= survive;
            }

            org = offset_ray_origin(s.p, if transmitted { -s.ng } else { s.ng });
            dir = wi;
            stats.bounce += 1;
        }
        out.radiance = radiance;
        out
    }
}
