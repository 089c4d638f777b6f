//! The lights a camera subpath finds along its rays without hitting a surface (s = 0):
//! the world and sun disks it escapes to (`escaped_radiance`, weighed by
//! `weight_escaped`), and the area and sphere lights a segment crosses
//! (`crossed_lights`); and the weight of s = 0 or s = 1 for the paths only the camera
//! side makes (`camera_only_weight`).

use super::vertex::*;
use super::*;
use crate::integrator::linking::{self, Gate};
use crate::light::light_graph::graph_factor;

impl BdptIntegrator {
    /// What a camera subpath escaping along `dir` from its last vertex sees: the world and
    /// sun disks, each weighed over every strategy that can make the path (s = 0 here).
    /// Each emitter's weighted radiance goes to `each` (`None`: the world), for the passes.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn escaped_radiance(
        &self,
        ctx: &SceneContext,
        dir: Vec3,
        cam: &mut Vec<Vertex>,
        dens: &mut PathDensities,
        (prev_delta, pdf_sa): (bool, f32),
        (restricted, path): (bool, &crate::scene::light_path::LightPath),
        camera: &CameraRays,
        each: &mut dyn FnMut(Option<usize>, Rgb),
    ) {
        let from = found_from(cam);
        let i = cam.len() - 1;
        // The world's Ray Visibility (the camera's flag included): rays of a hidden kind miss it.
        // A camera ray sees the world with its own state, which s = 0 alone makes (no other
        // strategy reaches the camera from a light at infinity); later escapes read the world
        // as light sampling does, as the other strategies do (warned).
        let le = match (ctx.world_seen_by(i == 0, path), i) {
            (false, _) => Rgb::ZERO,
            (true, 0) => ctx.world_radiance_for(dir, path),
            (true, _) => ctx.world_radiance(dir),
        };
        if le != Rgb::ZERO {
            let world = ctx.scene.lights.iter().position(|l| matches!(l, Light::World));
            let pdf_dir = ctx.scene.world.as_ref().map_or(0.0, |e| e.pdf(dir));
            let gate = world.map_or(Gate::Mis, |w| linking::found(ctx, w, from));
            let w = match world {
                // Made by s = 0 and s = 1 alone (`visibility`).
                Some(w) if gate == Gate::Mis && (restricted || self.restriction.light(w)) => {
                    self.camera_only_weight(i, prev_delta, pdf_sa, self.lights.pmf_any(w) * pdf_dir)
                }
                Some(w) if gate == Gate::Mis => {
                    self.weight_escaped(ctx, cam, dens, w, dir, pdf_dir, (prev_delta, pdf_sa), camera)
                }
                _ => 1.0,
            };
            each(None, le * self.mis(gate.weight(w)));
        }
        for (index, l) in ctx.scene.lights.iter().enumerate() {
            if let Light::Directional { direction, irradiance, cos_half } = l
                && *cos_half < crate::light::DELTA_SUN_COS
                && dir.dot(-*direction) >= *cos_half
            {
                let gate = linking::found(ctx, index, from);
                let pdf_dir = uniform_cone_pdf(*cos_half);
                let own = restricted || self.restriction.light(index);
                if own && !ctx.light_seen_by(index, path) {
                    continue;
                }
                let w = if gate == Gate::Mis && own {
                    self.camera_only_weight(i, prev_delta, pdf_sa, self.lights.pmf_any(index) * pdf_dir)
                } else if gate == Gate::Mis {
                    self.weight_escaped(ctx, cam, dens, index, dir, pdf_dir, (prev_delta, pdf_sa), camera)
                } else {
                    1.0
                };
                each(Some(index), crate::light::sun_radiance(*irradiance, *cos_half) * self.mis(gate.weight(w)));
            }
        }
    }

    /// MIS weight of the s = 0 strategy for the camera subpath `cam` escaping along `dir` to
    /// light `index` at infinity, whose light subpaths draw `dir` with density `pdf_dir`;
    /// the last camera direction had density `pdf_sa` (or was a delta lobe's).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn weight_escaped(
        &self,
        ctx: &SceneContext,
        cam: &mut Vec<Vertex>,
        dens: &mut PathDensities,
        index: usize,
        dir: Vec3,
        pdf_dir: f32,
        (prev_delta, pdf_sa): (bool, f32),
        camera: &CameraRays,
    ) -> f32 {
        // Seen directly from the camera: no other strategy makes the path.
        if cam.len() < 2 {
            return 1.0;
        }
        let mut z0 = Vertex::new(Kind::Infinite, dir);
        z0.pdf_fwd = if prev_delta { self.delta_solid_angle() } else { pdf_sa };
        cam.push(z0);
        let t = cam.len();
        self.fill_path(ctx, cam, &[], 0, camera, dens);
        dens.a[0] = self.lights.pmf_origin(index) * pdf_dir;
        dens.a[1] = cam[t - 2].density_from_infinity(dir, self.lights.disk_pdf());
        dens.connectible[0] = true;
        dens.light_hittable = true;
        let w = dens.weight(0);
        cam.pop();
        w
    }

    /// The weight of an s = 0 or s = 1 contribution from a light that only the camera
    /// side reaches: BSDF sampling (density `pdf_sa`) against light sampling (`p_light`).
    #[inline]
    pub(super) fn camera_only_weight(&self, i: usize, prev_delta: bool, pdf_sa: f32, p_light: f32) -> f32 {
        if i == 0 || prev_delta { self.mis(1.0) } else { self.mis(power_heuristic(pdf_sa, p_light)) }
    }

    /// The probability with which the camera side's light sampling at vertex `v` picks light
    /// `index`: BDPT's light choice, or for a light taken by the camera side alone because its
    /// emission depends on the receiver (`light::path_emitters`: a varying node tree) the path
    /// tracer's, which its s = 1 uses (`connect_path_emitter`).
    #[inline]
    fn camera_side_pmf(&self, ctx: &SceneContext, index: usize, v: &Vertex) -> f32 {
        if self.lights.reads_path(index) {
            ctx.lights.pmf(v.p, super::path_emitters::selection_normal(v), index)
        } else {
            self.lights.pmf_any(index)
        }
    }

    /// s = 0 contributions of area and sphere lights crossed by the segment from the last
    /// camera vertex (they do not block: the path goes on, as in Cycles).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn crossed_lights(
        &self,
        ctx: &SceneContext,
        cam: &mut Vec<Vertex>,
        dens: &mut PathDensities,
        (org, dir, tmax): (Vec3, Vec3, f32),
        beta: Rgb,
        (pdf_sa, prev_delta, restricted): (f32, bool, bool),
        camera: &CameraRays,
        (out, first): (&mut CameraSample, First),
        path: &crate::scene::light_path::LightPath,
    ) -> Rgb {
        let i = cam.len() - 1;
        let from = found_from(cam);
        let mut sum = Rgb::ZERO;
        for (index, l) in ctx.scene.lights.iter().enumerate() {
            let gate = match l {
                Light::Area(_) | Light::Sphere { .. } => linking::found(ctx, index, from),
                _ => continue,
            };
            if gate == Gate::Drop {
                continue;
            }
            let (t, n, le) = match l {
                Light::Area(a) => {
                    if i == 0 && !a.camera_visible {
                        continue;
                    }
                    match a.intersect(org, dir, tmax) {
                        // Spread's falloff toward the camera vertex, as the path tracer's `emission`.
                        Some(t) if (-dir).dot(a.normal) > 0.0 => {
                            (t, a.normal, a.radiance * a.spread_attenuation((-dir).dot(a.normal)))
                        }
                        _ => continue,
                    }
                }
                Light::Sphere { center, radius, radiance, soft: false, camera_visible, spot: None } => {
                    if i == 0 && !camera_visible {
                        continue;
                    }
                    match intersect_sphere(org, dir, *center, *radius, tmax) {
                        Some(t) => (t, ((org + dir * t) - *center).normalize_or(-dir), *radiance),
                        None => continue,
                    }
                }
                Light::Sphere { center, radius, radiance, soft, camera_visible, spot } => {
                    // Camera-side only (`lights::starts_subpaths`): a soft point light's disk
                    // facing the previous vertex, or a spot's sphere masked along the ray.
                    if i == 0 && !camera_visible {
                        continue;
                    }
                    let prev_p = cam[i].p;
                    let mask = crate::light::sphere_mask(spot, *center, *radius, prev_p, -dir);
                    if !(mask > 0.0) {
                        continue;
                    }
                    let (density, q) = if *soft {
                        let n = (prev_p - *center).normalize_or(Vec3::Y);
                        let denom = n.dot(dir);
                        if denom >= 0.0 {
                            continue;
                        }
                        let t = n.dot(*center - org) / denom;
                        let q = org + dir * t;
                        if !(t > 0.0 && t < tmax) || (q - *center).length_squared() > radius * radius {
                            continue;
                        }
                        let dist = (q - prev_p).length();
                        (area_to_solid_angle(1.0 / (std::f32::consts::PI * radius * radius), dist, -denom), q)
                    } else {
                        let Some(t) = intersect_sphere(org, dir, *center, *radius, tmax) else {
                            continue;
                        };
                        let density = crate::light::sphere_cos_max((*center - prev_p).length(), *radius)
                            .map_or(0.0, crate::sampling::warp::uniform_cone_pdf);
                        (density, org + dir * t)
                    };
                    // Camera-side only already; a light hidden from the last bounce's kind is not found.
                    if !ctx.light_seen_by(index, path) {
                        continue;
                    }
                    let p_light = self.camera_side_pmf(ctx, index, &cam[i]) * density;
                    let w = gate.weight(self.camera_only_weight(i, prev_delta, pdf_sa, p_light));
                    let n_q = if *soft { Vec3::ZERO } else { (q - *center) / *radius };
                    let f = graph_factor(ctx.scene, index, q, n_q, prev_p, *path);
                    let c = beta * *radiance * f * (mask * w);
                    sum += c;
                    if self.ledger.any() {
                        self.ledger.file(out, i, first, false, self.ledger.group_of_light(ctx, index), c);
                    }
                    continue;
                }
                _ => continue,
            };
            let q = org + dir * t;
            let le = le * graph_factor(ctx.scene, index, q, n, cam[i].p, *path);
            // Made by s = 0 and s = 1 alone (`visibility`): a light hidden from the last
            // bounce's kind is not found, else BSDF sampling is weighed against light sampling.
            let varying = self.lights.reads_path(index);
            if varying || restricted || self.restriction.light(index) || self.restriction.crosses(org, dir, t) {
                if !ctx.light_seen_by(index, path) {
                    continue;
                }
                let p_light = if varying {
                    // A light whose node tree varies: its s = 1 is the path tracer's own
                    // next-event estimation (`path_emitters`), with the path tracer's density.
                    match l {
                        Light::Sphere { center, radius, .. } => {
                            crate::light::sphere_cos_max((*center - cam[i].p).length(), *radius)
                                .map_or(0.0, |c| self.camera_side_pmf(ctx, index, &cam[i]) * uniform_cone_pdf(c))
                        }
                        _ => ctx.light_pdf(index, cam[i].p, super::path_emitters::selection_normal(&cam[i]), q, n),
                    }
                } else {
                    self.light_sample_density(ctx, index, cam[i].p, q, n)
                };
                let c = beta * le * self.mis(gate.weight(self.camera_only_weight(i, prev_delta, pdf_sa, p_light)));
                sum += c;
                if self.ledger.any() {
                    self.ledger.file(out, i, first, false, self.ledger.group_of_light(ctx, index), c);
                }
                continue;
            }
            let mut v = Vertex::new(Kind::Light, q);
            v.ng = n;
            v.wo = -dir;
            v.pdf_fwd = if prev_delta { self.delta_area(&v, cam[i].p) } else { v.area_density(pdf_sa, cam[i].p) };
            v.light = Some(LightPoint {
                light: index as u32,
                p: q,
                n,
                le,
                pdf_pos: lights::pdf_point(ctx.scene, index),
                two_sided: false,
                bary: Vec2::ZERO,
            });
            let w = if gate == Gate::Mis {
                cam.push(v);
                let w = self.weight_s0(ctx, cam, dens, index, camera);
                cam.pop();
                w
            } else {
                1.0
            };
            let c = beta * le * self.mis(gate.weight(w));
            sum += c;
            if self.ledger.any() {
                self.ledger.file(out, i, first, false, self.ledger.group_of_light(ctx, index), c);
            }
        }
        sum
    }
}

/// Where the ray that leaves the last vertex of `cam` starts, for `linking::found`: `None`
/// from the camera, else that vertex's receiver and whether it scattered through a delta lobe.
#[inline]
pub(super) fn found_from(cam: &[Vertex]) -> Option<(u32, bool)> {
    let v = cam.last()?;
    match v.kind {
        Kind::Camera => None,
        _ => Some((v.hit.map_or(crate::scene::linking::NO_OBJECT, |h| h.tri), v.delta)),
    }
}
