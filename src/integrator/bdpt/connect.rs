//! Joining the subpaths: every strategy (s, t), light tracing to the camera (t = 1), a
//! fresh light sample (s = 1) and shadow rays between vertices.

use super::contact::{self, LightEnd};
use super::vertex::*;
use super::*;
use crate::bsdf::BsdfAt;
use crate::integrator::linking::{self, Gate};
use crate::scene::light_path::LightPath;
use crate::scene::visibility::RayMask;

impl BdptIntegrator {
    /// Every strategy with s ≥ 1; returns the camera-side sum, splats t = 1. `sampler` is
    /// the pixel sample's `connection_sampler` (light samples at camera vertices).
    pub(crate) fn connect_all(
        &self,
        ctx: &SceneContext,
        sampler: &mut PixelSampler,
        film: &mut FilmTarget,
        scratch: &mut BdptScratch,
        out: &mut CameraSample,
        stats: &mut RayStats,
    ) -> Rgb {
        let mut sum = Rgb::ZERO;
        let n_cam = scratch.cam.len();
        let n_light = scratch.light.len();
        // t = 1: light vertices seen by the camera.
        for s in 1..=n_light {
            if s - 1 > self.max_depth as usize || !self.allowed(s, 1) {
                continue;
            }
            self.connect_to_camera(ctx, s, film, scratch, stats);
        }
        for t in 2..=n_cam {
            // s = 1: a fresh light point sampled for this camera vertex.
            let [u_pick, u_x, u_y, _] = sampler.next_4d();
            // Past Light Paths' bounce limits (`bounces`): no path goes on from here.
            if scratch.cam[t - 1].spent {
                break;
            }
            if t - 1 <= self.max_depth as usize && self.allowed(1, t) {
                let rays = stats.total();
                sum += self.connect_light_sample(ctx, t, [u_pick, u_x, u_y], film.camera, scratch, out, stats);
                scratch.tally.s1_rays += stats.total() - rays;
            }
            // s = 1 toward emitters that read the Light Path node (`path_emitters`).
            if self.lights.any_reads_path() {
                let [u_pick, u_x, u_y, _] = sampler.next_4d();
                if t - 1 <= self.max_depth as usize && self.allowed(1, t) {
                    sum += self.connect_path_emitter(ctx, t, [u_pick, u_x, u_y], scratch, out, stats);
                }
            }
            for s in 2..=n_light {
                if s + t - 2 > self.max_depth as usize || !self.allowed(s, t) {
                    continue;
                }
                let c = self.connect_vertices(ctx, s, t, film.camera, scratch, out, stats);
                scratch.tally.light += c;
                sum += c;
            }
        }
        sum
    }

    /// Light vertex `light[s-1]` connected to the camera and splatted.
    pub(super) fn connect_to_camera(
        &self,
        ctx: &SceneContext,
        s: usize,
        film: &mut FilmTarget,
        scratch: &mut BdptScratch,
        stats: &mut RayStats,
    ) {
        let camera = film.camera;
        // Borrowed, not copied (see `connect_vertices`).
        let BdptScratch { cam, light, dens, tally, .. } = scratch;
        let y = &light[s - 1];
        // A light at infinity sends one direction through the camera's point: no pixel
        // sees it by this strategy (s = 0 alone makes such paths).
        if y.kind == Kind::Infinite {
            return;
        }
        // Border pixels' filters reach outside the frame, where their camera samples go too.
        // The camera subpath's aperture point is a uniform lens sample independent of this
        // light subpath: connecting to it is the t = 1 strategy through a thin lens.
        let cam_p = cam[0].p;
        // Through the camera where it is at the sample's time (under motion blur the light
        // subpath shares the camera sample's time, `crate::motion`).
        let t = crate::motion::ray_time();
        let Some(proj) = camera.project_at(y.p, cam_p, 0.5 * film.filter.width, t) else {
            return;
        };
        let (pos, dist) = (proj.pos, proj.dist);
        // Only what lies between the clipping planes is seen, as by camera rays.
        let (near, far) = camera.clip();
        let depth = dist * proj.depth_per_dist;
        if depth < near || depth > far {
            return;
        }
        let w = (cam_p - y.p) / dist;
        // Light Paths' bounce limits (`bounces`): light[2..s] counted, light[1] never.
        if s >= 3 && !self.kept(y.classes_toward(w)) {
            return;
        }
        let mut first = First::default();
        // The light vertex's BSDF seen from the camera: its value and reverse density.
        let mut back = None;
        // What the light vertex sends toward the camera (times the cosine at it).
        let f = match (y.kind, y.light) {
            (Kind::Light, Some(lp)) => {
                // A light seen directly: hidden lights stay hidden.
                let visible = match &ctx.scene.lights[lp.light as usize] {
                    Light::Area(a) => a.camera_visible,
                    Light::Sphere { camera_visible, .. } => *camera_visible,
                    // An emissive holdout seen by the camera shows nothing either, nor an
                    // emissive object hidden from camera rays.
                    Light::Triangle { tri } => !ctx.is_holdout(*tri) && ctx.sees(RayMask::CAMERA, *tri),
                    _ => true,
                };
                // A shadow-linked or shadowless light seen by the camera is s = 0's alone
                // (`linking`); a point or spot light is seen by no camera ray (Cycles shows
                // none, and the path tracer's camera rays cannot hit a point).
                let point = lights::is_delta(ctx.scene, lp.light as usize);
                if !visible || point || linking::own_shadows(ctx, lp.light as usize) {
                    return;
                }
                lights::emitted(ctx.scene, &lp, w) * y.abs_cos_geo(w)
            }
            _ => {
                let (Some(bsdf), Some(hit)) = (y.bsdf.as_ref(), y.hit.as_ref()) else { return };
                // The camera sees this vertex directly (the segment is tested below): on a
                // holdout it shows nothing, as camera rays that hit it do.
                // Nor does it see a vertex on an object hidden from camera rays (the
                // camera subpath passes such objects, so no strategy makes these paths).
                if ctx.is_holdout(hit.tri) || !ctx.sees(RayMask::CAMERA, hit.tri) {
                    return;
                }
                let (wo_l, wi_l) = (y.frame.to_local(y.wo), y.frame.to_local(w));
                let own = bsdf.bind(&y.view);
                if own.above(wi_l) != (w.dot(hit.ng) > 0.0) {
                    return;
                }
                let from_camera = back.insert(bsdf.at_value(wi_l));
                if self.ledger.light_passes {
                    // Seen from the camera: leaving toward it, arriving from the light side.
                    first = passes::shares_seen(&from_camera.lobed(), wo_l);
                }
                bsdf.eval_adjoint_at(&own, from_camera, wo_l, wi_l)
                    * wi_l.z.abs()
                    * shading_correction(hit, &y.frame, y.wo, w)
            }
        };
        if f == Rgb::ZERO {
            return;
        }
        let mut c = y.beta * f * (proj.importance / (dist * dist));
        if s == 2
            && y.contact
            && let Some(end) = LightEnd::of(&light[0])
        {
            // The path tracer's share of the light at a contact (`contact`).
            c *= contact::trap_weight(ctx, y, w, end);
        }
        if c == Rgb::ZERO {
            return;
        }
        stats.shadow += 1;
        // The segment ends where the camera ray would start: on the near clipping plane.
        let cam_end = if near > 0.0 { cam_p - w * (near / proj.depth_per_dist) } else { cam_p };
        // A segment that meets a restricted object: the camera side's path (`visibility`).
        if self.restriction.between(y.p, cam_end) {
            return;
        }
        // In camera order the segment is a camera ray: objects hidden from the camera do not block it.
        let tr = segment_transmittance_to(ctx, y, cam_end, cam[0].ng, media_leaving(ctx, y, w), None, RayMask::CAMERA);
        if tr == Rgb::ZERO {
            return;
        }
        c *= tr;
        // MIS: the path light[..s] + camera.
        self.fill_path(ctx, &cam[..1], light, s, camera, dens);
        let k = s; // index of the camera vertex
        dens.connectible[s - 1] = true;
        // b[s-1]: the camera generating y.
        dens.b[s - 1] = y.area_density(proj.pdf_dir, cam_p);
        if s >= 2
            && let Some(from_camera) = &back
        {
            let prev = &light[s - 2];
            let pdf = from_camera.lobed().pdf(y.frame.to_local(prev.dir_from(y.p)));
            dens.b[s - 2] = prev.area_density(pdf, y.p);
        }
        dens.a[k] = 0.0; // unused (t = 0 is not a strategy)
        let wgt = self.mis(dens.weight(s));
        tally.splat += crate::math::luminance(c * wgt) as f64;
        if !self.ledger.any() && ctx.catcher.is_none() {
            film.splats.add(film.filter, pos, c * wgt);
            // A panorama all the way round: the border pixels across the seam see it too.
            if let Some(q) = proj.wrapped {
                film.splats.add(film.filter, q, c * wgt);
            }
            return;
        }
        // The camera side's first scattering event is this light vertex (none for s = 1).
        let (light_parts, n) = passes::parts(s - 1, first, false, c * wgt);
        let mut n = if self.ledger.light_passes { n } else { 0 };
        // The light passes' parts, then room for the matte's.
        let mut parts = [(0, Rgb::ZERO); 4];
        parts[..3].copy_from_slice(&light_parts);
        let mut group = self.ledger.group_of_subpath(ctx, light);
        if ctx.catcher.is_some() {
            // Shadow catcher (`catcher`): a path the camera sees on a catcher split there;
            // it is Combined's and files no light group, any other goes to the matte too.
            if Self::seen_on_catcher(ctx, y) {
                group = crate::scene::light_groups::NONE;
            } else {
                parts[n] = (crate::passes::slot::CATCHER_MATTE, c * wgt);
                n += 1;
            }
        }
        film.splats.add_filed(film.filter, pos, c * wgt, &parts[..n], group);
        if let Some(q) = proj.wrapped {
            film.splats.add_filed(film.filter, q, c * wgt, &parts[..n], group);
        }
    }

    /// s = 1: light sampling at camera vertex `cam[t-1]`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn connect_light_sample(
        &self,
        ctx: &SceneContext,
        t: usize,
        u: [f32; 3],
        camera: &CameraRays,
        scratch: &mut BdptScratch,
        out: &mut CameraSample,
        stats: &mut RayStats,
    ) -> Rgb {
        let c = self.light_sample_at(ctx, t, u, camera, scratch, stats);
        if c.0 != Rgb::ZERO && self.ledger.any() {
            let first = if t == 2 { c.1 } else { scratch.first };
            self.ledger.file(out, t - 1, first, false, self.ledger.group_of_light(ctx, c.2), c.0);
        }
        c.0
    }

    /// [`connect_light_sample`](Self::connect_light_sample)'s contribution, with the class
    /// of the camera vertex's BSDF toward the light (when light passes are kept) and the light.
    fn light_sample_at(
        &self,
        ctx: &SceneContext,
        t: usize,
        u: [f32; 3],
        camera: &CameraRays,
        scratch: &mut BdptScratch,
        stats: &mut RayStats,
    ) -> (Rgb, First, usize) {
        let none = (Rgb::ZERO, First::default(), 0);
        // Borrowed, not copied (see `connect_vertices`).
        let BdptScratch { cam, dens, .. } = scratch;
        let x = &cam[t - 1];
        let (Some(bsdf), Some(hit)) = (x.bsdf.as_ref(), x.hit.as_ref()) else {
            return none;
        };
        if x.specular {
            return none;
        }
        let own = bsdf.bind(&x.view);
        let Some((index, pmf)) = self.lights.pick_any(u[0]) else {
            return none;
        };
        // `connect_path_emitter`'s (chosen here only by the uniform choice of a scene
        // whose other lights have no power).
        if self.lights.reads_path(index) {
            return none;
        }
        let gate = linking::sampled(ctx, index, hit.tri);
        // A light past its Max Bounces at this vertex: chosen, nothing (`scene::light_bounces`;
        // such a light is restricted, so s = 0 weighs its hits as the path tracer does).
        if gate == Gate::Drop || !ctx.nee_within_bounces(index, hit.light_path.depth) {
            return none;
        }
        if !lights::is_finite(&ctx.scene.lights[index]) {
            // The world, a sun or a soft point light: light sampling as the path tracer
            // does; weighted over every strategy for lights that start light subpaths,
            // else against BSDF sampling only.
            let Some(ls) = ctx.sample_light_unguided(index, x.p, Vec2::new(u[1], u[2]), LightPath::LIGHT_EMISSION)
            else {
                return none;
            };
            let wi_l = x.frame.to_local(ls.wi);
            let consistent = own.above(wi_l) == (ls.wi.dot(hit.ng) > 0.0);
            let f = Self::eval_lit(ctx, &own, index, wi_l) * wi_l.z.abs();
            if f == Rgb::ZERO || ls.li == Rgb::ZERO || !consistent {
                return none;
            }
            let tr = shadow_transmittance(ctx, x, hit.ng, &ls, index, LightPath::SHADOW_RAY, stats);
            if tr == Rgb::ZERO {
                return none;
            }
            let p_light = pmf * ls.pdf;
            let restricted =
                x.restricted || self.restriction.light(index) || self.restriction.crosses(x.p, ls.wi, ls.dist);
            let trap = contact::trap_weight(ctx, x, x.wo, LightEnd::Direction { light: index, d: ls.wi });
            let w = trap
                * if gate != Gate::Mis {
                    1.0
                } else if restricted {
                    // Made by s = 0 and s = 1 alone (`visibility`), as next-event estimation weighs it.
                    if ls.delta { 1.0 } else { power_heuristic(p_light, own.pdf(wi_l)) }
                } else if self.lights.starts(index) {
                    self.weight_s1_infinite(ctx, t, index, &ls, camera, cam, dens)
                } else if ls.delta {
                    1.0
                } else {
                    power_heuristic(p_light, own.pdf(wi_l))
                };
            let c = x.beta * f * tr * ls.li * (self.mis(gate.weight(w)) / p_light);
            return (c, self.first_seen(&own, wi_l), index);
        }
        let Some(lp) = lights::sample_point(ctx.scene, index, Vec2::new(u[1], u[2])) else {
            return none;
        };
        let d = lp.p - x.p;
        let dist2 = d.length_squared();
        if !(dist2 > 0.0) {
            return none;
        }
        let dist = dist2.sqrt();
        let wi = d / dist;
        let le = lights::emitted(ctx.scene, &lp, -wi);
        if le == Rgb::ZERO {
            return none;
        }
        let wi_l = x.frame.to_local(wi);
        if own.above(wi_l) != (wi.dot(hit.ng) > 0.0) {
            return none;
        }
        let f = Self::eval_lit(ctx, &own, index, wi_l) * wi_l.z.abs();
        if f == Rgb::ZERO {
            return none;
        }
        let mut y = Vertex::new(Kind::Light, lp.p);
        y.ng = lp.n;
        y.light = Some(lp);
        let cos_y = y.abs_cos_geo(wi);
        let g = cos_y / dist2;
        let contribution = x.beta * f * le * (g / (pmf * lp.pdf_pos));
        if contribution == Rgb::ZERO {
            return none;
        }
        stats.shadow += 1;
        let tr = segment_transmittance_of(ctx, x, &y, media_leaving(ctx, x, wi), Some(index));
        if tr == Rgb::ZERO {
            return none;
        }
        let trap = contact::trap_weight(ctx, x, x.wo, LightEnd::Point { light: index, q: lp.p, n: lp.n });
        if gate == Gate::Whole {
            return (contribution * tr * (trap * self.mis(1.0)), self.first_seen(&own, wi_l), index);
        }
        if x.restricted || self.restriction.light(index) || self.restriction.between(x.p, lp.p) {
            // Made by s = 0 and s = 1 alone (`visibility`): BSDF sampling against this
            // light sample, as next-event estimation weighs it.
            let w = if lights::is_delta(ctx.scene, index) {
                1.0
            } else {
                power_heuristic(pmf * lp.pdf_pos * dist2 / cos_y, own.pdf(wi_l))
            };
            return (contribution * tr * self.mis(w), self.first_seen(&own, wi_l), index);
        }
        // MIS with the light-origin density of light subpaths.
        y.pdf_fwd = self.lights.pmf_origin(index) * lp.pdf_pos;
        self.fill_path(ctx, &cam[..t], std::slice::from_ref(&y), 1, camera, dens);
        dens.connectible[0] = true;
        dens.connectible[1] = true;
        // b[0]: the camera vertex's BSDF generating the light point.
        dens.b[0] = y.area_density(own.pdf(wi_l), x.p);
        // a[1]: the light's emission generating x.
        dens.a[1] = x.area_density(lights::pdf_direction(ctx.scene, &lp, -wi), lp.p);
        if t >= 2 {
            let prev = &cam[t - 2];
            let pdf = if prev.kind == Kind::Camera {
                0.0 // a[k] is never used
            } else {
                bsdf.pdf(wi_l, x.frame.to_local((prev.p - x.p).normalize_or_zero()))
            };
            dens.a[2] = prev.area_density(pdf, x.p);
        }
        let w = self.mis(dens.weight(1)) * trap;
        (contribution * tr * w, self.first_seen(&own, wi_l), index)
    }

    /// The BSDF at a camera vertex (seen from its wo) toward light `index`, without the closure classes the
    /// light's Ray Visibility hides it from (as next-event estimation's, `nee`).
    #[inline]
    fn eval_lit(ctx: &SceneContext, at: &BsdfAt, index: usize, wi: Vec3) -> Rgb {
        let ex = ctx.light_excludes(index);
        if ex.none() { at.eval(wi) } else { at.eval_visible(wi, ex) }
    }

    /// The class of the BSDF seen from wo toward local `wi`, when light passes are kept.
    #[inline]
    fn first_seen(&self, at: &BsdfAt, wi: Vec3) -> First {
        if self.ledger.light_passes { passes::shares_seen(at, wi) } else { First::default() }
    }

    /// MIS weight of light sampling (s = 1) at camera vertex `cam[t-1]` toward light `index`
    /// at infinity (the world or a sun, sampled as `ls`), over every strategy: the light
    /// vertex's density from the light side is the light's choice times the direction's
    /// density (that of `ls`: light subpaths draw directions from the same distribution).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn weight_s1_infinite(
        &self,
        ctx: &SceneContext,
        t: usize,
        index: usize,
        ls: &LightSample,
        camera: &CameraRays,
        cam: &[Vertex],
        dens: &mut PathDensities,
    ) -> f32 {
        let x = &cam[t - 1];
        let Some((bsdf, own)) = x.seen() else { return 0.0 };
        let mut y = Vertex::new(Kind::Infinite, ls.wi);
        y.pdf_fwd = self.lights.pmf_origin(index) * ls.pdf;
        y.light = Some(LightPoint {
            light: index as u32,
            p: ls.wi,
            n: Vec3::ZERO,
            le: ls.li,
            pdf_pos: self.lights.disk_pdf(),
            two_sided: false,
            bary: Vec2::ZERO,
        });
        let wi_l = x.frame.to_local(ls.wi);
        self.fill_path(ctx, &cam[..t], std::slice::from_ref(&y), 1, camera, dens);
        dens.connectible[0] = true;
        dens.connectible[1] = true;
        // b[0]: the camera vertex's BSDF generating the direction (a solid-angle density).
        dens.b[0] = if ls.delta { 0.0 } else { own.pdf(wi_l) };
        // a[1]: the light's disk generating x.
        dens.a[1] = x.density_from_infinity(ls.wi, self.lights.disk_pdf());
        let prev = &cam[t - 2];
        dens.a[2] = if prev.kind == Kind::Camera {
            0.0 // a[k] is never used
        } else {
            prev.area_density(bsdf.pdf(wi_l, x.frame.to_local(prev.dir_from(x.p))), x.p)
        };
        dens.weight(1)
    }

    /// s, t ≥ 2: light vertex `light[s-1]` joined to camera vertex `cam[t-1]`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn connect_vertices(
        &self,
        ctx: &SceneContext,
        s: usize,
        t: usize,
        camera: &CameraRays,
        scratch: &mut BdptScratch,
        out: &mut CameraSample,
        stats: &mut RayStats,
    ) -> Rgb {
        // Borrowed, not copied: a vertex holds a whole BSDF, and copying the two was 9 % of
        // BDPT's instructions on the Cornell box (callgrind: `memcpy` from here).
        let BdptScratch { cam, light, dens, first, .. } = scratch;
        let (x, y) = (&cam[t - 1], &light[s - 1]);
        // A restricted path: the camera side's (`visibility`).
        if x.restricted {
            return Rgb::ZERO;
        }
        let (Some(bx), Some(hx), Some(by), Some(hy)) =
            (x.bsdf.as_ref(), x.hit.as_ref(), y.bsdf.as_ref(), y.hit.as_ref())
        else {
            return Rgb::ZERO;
        };
        // No connection leaves a camera vertex at a contact, nor joins a light vertex that
        // reached one after a scattering (`contact`; light subpaths do not store those).
        if x.specular || y.specular || x.contact || (y.contact && s > 2) {
            return Rgb::ZERO;
        }
        let d = y.p - x.p;
        let dist2 = d.length_squared();
        if !(dist2 > 0.0) {
            return Rgb::ZERO;
        }
        let dist = dist2.sqrt();
        let w = d / dist; // from x toward y
        // Light Paths' bounce limits (`bounces`): both ends counted, light[1] never.
        let light_side = if s >= 3 { y.classes_toward(-w) } else { bounces::Classes::default() };
        if !self.kept(x.classes_toward(w).plus(light_side)) {
            return Rgb::ZERO;
        }
        let wi_x = x.frame.to_local(w);
        let (wo_y, wi_y) = (y.frame.to_local(y.wo), y.frame.to_local(-w));
        // Each side seen from its own wo (kept with the vertex) and from the other vertex.
        let (ax, ay) = (bx.bind(&x.view), by.bind(&y.view));
        if ax.above(wi_x) != (w.dot(hx.ng) > 0.0) || ay.above(wi_y) != ((-w).dot(hy.ng) > 0.0) {
            return Rgb::ZERO;
        }
        let fx = ax.eval(wi_x) * wi_x.z.abs();
        let ry = by.at_value(wi_y);
        let fy = by.eval_adjoint_at(&ay, &ry, wo_y, wi_y) * wi_y.z.abs() * shading_correction(hy, &y.frame, y.wo, -w);
        let mut c = x.beta * fx * fy * y.beta / dist2;
        if s == 2
            && y.contact
            && let Some(end) = LightEnd::of(&light[0])
        {
            // The path tracer's share of the light at a contact (`contact`).
            c *= contact::trap_weight(ctx, y, -w, end);
        }
        if c == Rgb::ZERO {
            return Rgb::ZERO;
        }
        if self.restriction.between(x.p, y.p) {
            return Rgb::ZERO;
        }
        stats.shadow += 1;
        let tr = segment_transmittance(ctx, x, y, media_leaving(ctx, x, w));
        if tr == Rgb::ZERO {
            return Rgb::ZERO;
        }
        self.fill_path(ctx, &cam[..t], light, s, camera, dens);
        dens.connectible[s - 1] = true;
        dens.connectible[s] = true;
        // b[s-1]: x generating y; a[s]: y generating x.
        dens.b[s - 1] = y.area_density(ax.pdf(wi_x), x.p);
        dens.a[s] = x.area_density(ay.pdf(wi_y), y.p);
        // b[s-2]: y generating its predecessor given x; a[s+1]: x generating its predecessor given y.
        let yp = &light[s - 2];
        dens.b[s - 2] = yp.area_density(ry.lobed().pdf(y.frame.to_local(yp.dir_from(y.p))), y.p);
        let xp = &cam[t - 2];
        dens.a[s + 1] = if xp.kind == Kind::Camera {
            0.0
        } else {
            xp.area_density(bx.pdf(wi_x, x.frame.to_local((xp.p - x.p).normalize_or_zero())), x.p)
        };
        let wgt = self.mis(dens.weight(s));
        if self.ledger.any() {
            let first = if t == 2 { self.first_seen(&ax, wi_x) } else { *first };
            let group = self.ledger.group_of_subpath(ctx, light);
            self.ledger.file(out, (t - 1) + (s - 1), first, false, group, c * tr * wgt);
        }
        c * tr * wgt
    }
}

/// Transmittance of next-event estimation's shadow ray from camera vertex `x` (geometric
/// normal `ng`) to light `index`'s sample `ls`, the ray read by the Light Path node as
/// `path`; 1 without a ray for a light with Cast Shadow off, as the path tracer's.
pub(super) fn shadow_transmittance(
    ctx: &SceneContext,
    x: &Vertex,
    ng: Vec3,
    ls: &crate::light::LightSample,
    index: usize,
    path: LightPath,
    stats: &mut RayStats,
) -> Rgb {
    if !ctx.casts_shadow(index) {
        return Rgb::ONE;
    }
    stats.shadow += 1;
    crate::integrator::media::light_transmittance_of(
        ctx,
        x.p,
        Some(ng),
        ls,
        media_leaving(ctx, x, ls.wi),
        Some(index),
        path,
    )
}
