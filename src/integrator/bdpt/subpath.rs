//! The two subpaths: the camera subpath (with the s = 0 strategy at the surfaces it hits;
//! the lights it escapes to or crosses are `found_lights`') and the light subpath.

use super::found_lights::found_from;
use super::vertex::*;
use super::volume_records::{LightSegment, MediumVertex};
use super::*;
use crate::integrator::filing::Filing;
use crate::integrator::linking::{self, Gate};
use crate::integrator::walk::{PathState, Step};
use crate::light::emit::infinite_ray;

impl BdptIntegrator {
    /// Starts the camera subpath in `scratch` with its camera vertex alone: the aperture
    /// point the camera ray leaves from (the ray itself starts at the near clipping plane).
    pub(crate) fn camera_vertex_alone(&self, ctx: &SceneContext, ray: &CameraRay, scratch: &mut BdptScratch) {
        scratch.cam.clear();
        *scratch.medium_vertex = None;
        let mut v0 = Vertex::new(Kind::Camera, ray.org);
        v0.pdf_fwd = 1.0;
        v0.medium = ctx.camera_media;
        scratch.cam.push(v0);
        *scratch.split = crate::integrator::catcher::Split::new(ctx.catcher.is_some());
    }

    /// Traces the camera subpath into `scratch.cam`, adding every s = 0 contribution
    /// (emitters found by the path) to `radiance`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn camera_subpath(
        &self,
        ctx: &SceneContext,
        ray: &CameraRay,
        sampler: &mut PixelSampler,
        camera: &CameraRays,
        scratch: &mut BdptScratch,
        out: &mut CameraSample,
        radiance: &mut Rgb,
        stats: &mut RayStats,
    ) {
        self.camera_vertex_alone(ctx, ray, scratch);
        let cam = &mut scratch.cam;
        let dir = ray.dir;
        let mut path = PathState::camera(ray, ctx.camera_media);
        // Solid-angle density of the direction just sampled (0 after a delta lobe).
        let mut pdf_sa = if !camera.light_tracing_reaches() { 1.0 } else { camera.pdf_dir_of(dir) };
        let mut prev_delta = false;
        stats.camera += 1;
        // The path so far meets a restricted object (`visibility`).
        let mut restricted = false;
        // Film → Transparent Glass: the path has only refracted through glass under the
        // threshold (the path tracer's rule; such glass is restricted, so these paths are
        // the camera side's and weighed as the path tracer weighs them).
        let glass_limit = self.glass_threshold.filter(|_| self.transparent_background);
        let mut see_through = glass_limit.is_some();
        loop {
            let [u_lobe, u_dx, u_dy, u_rr] = sampler.next_4d();
            let [u_alpha, u_channel, u_dist, _] = sampler.next_4d();
            let i = cam.len() - 1; // the vertex the ray leaves from
            // The camera segment's state, where a shadow catcher at its end splits the path.
            let pre = (i == 0 && scratch.split.allowed).then_some(path);
            let org0 = path.org;

            // The shared step: the medium segment (its emission counts only when every
            // strategy does), emitters crossed on the way (area and sphere lights do not
            // block; weighed over BDPT's strategies), pass-through surfaces.
            let mut emitted = Rgb::ZERO;
            let first = scratch.first;
            let crossed = |st: &PathState, t_event: f32, w: Rgb| {
                if !self.allowed(0, i + 2) {
                    return Rgb::ZERO;
                }
                self.crossed_lights(
                    ctx,
                    cam,
                    &mut scratch.dens,
                    (st.org, st.dir, t_event),
                    w,
                    (pdf_sa, prev_delta, restricted),
                    camera,
                    (&mut *out, first),
                    &st.light_path,
                )
            };
            let (step, crossed) =
                path.advance_with(ctx, Some([u_channel, u_dist]), || u_alpha, crossed, &mut emitted, stats);
            if self.strategy.is_none() {
                *radiance += emitted;
                if emitted != Rgb::ZERO && self.ledger.any() {
                    // Media emit in no light group (`scene::light_groups`).
                    self.ledger.file(out, i, first, false, crate::scene::light_groups::NONE, emitted);
                }
            }
            if crossed != Rgb::ZERO {
                *radiance += crossed;
                if i == 0 {
                    out.alpha = 1.0;
                }
            }
            let (dir, beta, medium) = (path.dir, path.beta, path.media);
            // The segment just traced, from its start (after the last pass-through).
            restricted |= match &step {
                Step::Surface { hit, s } => self.restriction.object(hit.tri) || self.restriction.between(org0, s.p),
                Step::Passed => self.restriction.between(org0, path.org),
                Step::Escaped => self.restriction.crosses(org0, dir, f32::INFINITY),
                Step::End | Step::Medium { .. } => false,
            };
            let (hit, s) = match step {
                Step::End => break,
                Step::Passed => continue,
                Step::Medium { p, phase, .. } => {
                    // A vertex in a medium: the rest of the path is traced by the path
                    // tracer (BDPT's strategies carry the paths without medium vertices).
                    if i == 0 {
                        out.alpha = 1.0;
                        out.depth = camera.depth(p);
                    }
                    if self.strategy.is_none() && (i as u32) < self.max_depth && beta.is_finite() && beta != Rgb::ZERO {
                        // The first event is this medium vertex, or the surface before.
                        let first = if i == 0 { First::Volume } else { first };
                        let tally = self.ledger.light_passes.then(|| first.tally());
                        let filing = Filing { tally, groups: self.ledger.light_groups, out: &mut *out };
                        let mut continuation = self.continuation();
                        // VCM merges here what reached this point through delta bounces
                        // alone (`vcm::volume_merge`): the path tracer leaves it out. Not in
                        // a scene with restricted objects or lights (`visibility`): their
                        // light subpaths stop before such a segment or never start, so the
                        // path tracer keeps every path there (exact; what it cannot find,
                        // point lights through mirrors, stays missing as in BDPT and Cycles).
                        if self.volume_merging && self.restriction.none() {
                            continuation.merged_delta_light = true;
                            *scratch.medium_vertex =
                                Some(MediumVertex { p, dir, phase, beta, events_before: i as u32, first });
                        }
                        *radiance += continuation.scatter_in_medium_filed(
                            ctx,
                            p,
                            dir,
                            phase,
                            medium,
                            beta,
                            i as u32,
                            sampler,
                            stats,
                            Some(filing),
                        );
                    }
                    break;
                }
                Step::Escaped => {
                    if pre.is_some() {
                        // The world behind the film, for the approximate catcher's composite.
                        scratch.split.background = path.escaped_radiance(ctx).map_or(Rgb::ZERO, |le| path.beta * le);
                    }
                    // The world seen directly (or through transparent glass) with a
                    // transparent film is not in Combined, but Environment and its light
                    // group show it (as the path tracer's).
                    let through_glass = see_through && i > 0;
                    let hidden = (i == 0 && self.transparent_background) || through_glass;
                    if through_glass {
                        // What the throughput carries is transparent (Cycles' `transparent
                        // += average(throughput)`).
                        out.alpha = (out.alpha - beta.element_sum() / 3.0).max(0.0);
                    }
                    if self.allowed(0, i + 2) && (!hidden || self.ledger.any()) {
                        let (ledger, groups) = (self.ledger, &ctx.scene.light_groups);
                        let mut sum = Rgb::ZERO;
                        let mut each = |light: Option<usize>, c: Rgb| {
                            sum += c;
                            if ledger.any() {
                                let g = match (ledger.light_groups, light) {
                                    (false, _) => crate::scene::light_groups::NONE,
                                    (true, None) => groups.world,
                                    (true, Some(l)) => groups.of_light(l),
                                };
                                ledger.file(out, i, first, true, g, beta * c);
                            }
                        };
                        self.escaped_radiance(
                            ctx,
                            dir,
                            cam,
                            &mut scratch.dens,
                            (prev_delta, pdf_sa),
                            (restricted, &path.light_path),
                            camera,
                            &mut each,
                        );
                        if sum != Rgb::ZERO && !hidden {
                            *radiance += beta * sum;
                            if i == 0 {
                                out.alpha = 1.0;
                            }
                        }
                    }
                    break;
                }
                Step::Surface { hit, s } => (hit, s),
            };
            // A holdout seen by the camera ray (through pass-throughs only): nothing, alpha
            // 0, as the path tracer's (Cycles'); later vertices see the object as it is.
            if i == 0 && ctx.is_holdout(hit.tri) {
                out.alpha = 0.0;
                out.held = 1.0;
                break;
            }
            // A shadow catcher seen by the camera ray: the path splits here (`catcher`);
            // what it gathered so far is the matte's.
            if let Some(pre) = pre
                && ctx.is_catcher(hit.tri)
            {
                scratch.split.at = Some((pre, *radiance));
                *scratch.groups_at_split = out.groups;
            }
            let wo = -dir;
            let mat = &ctx.scene.materials[s.material as usize];
            let sp = ctx.shade(&s, wo);
            // A Holdout closure seen by the camera ray (the path tracer's rule).
            let (alpha, held) = SceneContext::holdout_alpha(&sp, beta);
            if i == 0 && held {
                out.alpha = alpha;
                out.held = 1.0 - alpha;
                break;
            }
            // Subsurface scattering is path traced from here (the BSDF holds the rest of
            // the material: its diffuse base is already reduced by the subsurface weight).
            if mat.subsurface.is_some() && self.strategy.is_none() && (i as u32) < self.max_depth {
                let q = sp.bsdf.subsurface_weight(sp.frame.to_local(wo));
                if q > 0.0 {
                    // From the first hit the walk is the first event (diffuse) and its exit's
                    // estimate the direct one; later, all of it is indirect.
                    let tally = self.ledger.light_passes.then(|| match i {
                        0 => First::Surface(Rgb::ONE, Rgb::ZERO).tally(),
                        _ => first.tally(),
                    });
                    let filing = Filing { tally, groups: self.ledger.light_groups, out: &mut *out };
                    *radiance += self.continuation().subsurface_from_filed(
                        ctx,
                        &s,
                        &sp,
                        wo,
                        medium,
                        beta * q,
                        i as u32,
                        sampler,
                        stats,
                        Some(filing),
                    );
                }
            }
            if i == 0 {
                out.alpha = alpha;
                out.held = 1.0 - alpha;
                out.depth = camera.depth(s.p);
                out.normal = sp.frame.n;
                out.albedo = sp.bsdf.albedo();
            }
            let mut v = Vertex::surface(&s, &sp, wo, beta, medium);
            v.emitted = sp.emitted;
            v.restricted = restricted;
            if i >= 1 {
                v.classes = cam[i].classes_toward(dir);
            }
            v.contact = super::contact::on_contact(ctx, &s);
            v.pdf_fwd = if prev_delta { self.delta_area(&v, cam[i].p) } else { v.area_density(pdf_sa, cam[i].p) };
            cam.push(v);
            let t = cam.len();

            // s = 0: this surface emits (to the vertex before as linking allows).
            if sp.emitted != Rgb::ZERO
                && self.allowed(0, t)
                && let Some(index) = ctx.lights.light_of_triangle(hit.tri)
            {
                let gate = linking::found(ctx, index, found_from(&cam[..t - 1]));
                if gate != Gate::Drop {
                    let w = if gate == Gate::Mis && self.lights.reads_path(index) {
                        // Light subpaths never start on it: s = 1 is the path tracer's own
                        // next-event estimation (`path_emitters`).
                        self.weight_s0_path_emitter(ctx, cam, index, prev_delta, pdf_sa)
                    } else if gate == Gate::Mis && (restricted || self.restriction.light(index)) {
                        // Made by s = 0 and s = 1 alone (`visibility`).
                        let p_light = self.light_sample_density(ctx, index, cam[t - 2].p, s.p, s.ng);
                        self.camera_only_weight(t - 2, prev_delta, pdf_sa, p_light)
                    } else if gate == Gate::Mis {
                        self.weight_s0(ctx, cam, &mut scratch.dens, index, camera)
                    } else {
                        1.0
                    };
                    let c = beta * sp.emitted * self.mis(gate.weight(w));
                    *radiance += c;
                    if self.ledger.any() {
                        let g = if self.ledger.light_groups { ctx.scene.light_groups.of_tri(hit.tri) } else { 0 };
                        self.ledger.file(out, t - 2, first, false, g, c);
                    }
                }
            }
            // s = 0 on an emitter that is no light (an unlit surface, seen by camera rays
            // alone): no other strategy reaches it, so it counts in full.
            if sp.emitted != Rgb::ZERO && self.allowed(0, t) && ctx.lights.light_of_triangle(hit.tri).is_none() {
                let c = beta * sp.emitted * self.mis(1.0);
                *radiance += c;
                if self.ledger.any() {
                    let g = if self.ledger.light_groups { ctx.scene.light_groups.of_tri(hit.tri) } else { 0 };
                    self.ledger.file(out, t - 2, first, false, g, c);
                }
            }
            // Light Paths' bounce limits (`bounces`), after this vertex's emission: the path
            // tracer stops here, or the paths through it are the camera side's.
            match self.ends_after(&cam[t - 1]) {
                None => {
                    cam[t - 1].spent = true;
                    break;
                }
                Some(true) => {
                    restricted = true;
                    cam[t - 1].restricted = true;
                }
                Some(false) => {}
            }
            // Scattering events so far: t - 2; a vertex at the depth limit only emits.
            if t - 1 > self.max_depth as usize || t >= mis::MAX_PATH_VERTICES / 2 {
                break;
            }
            let wo_local = sp.frame.to_local(wo);
            let at = sp.bsdf.bind(&cam[t - 1].view);
            if t == 2 && self.ledger.light_passes {
                crate::integrator::light_passes::Tally::colours(out, &at, beta);
            }
            let Some(bs) = at.sample(u_lobe, Vec2::new(u_dx, u_dy)) else {
                break;
            };
            let wi = sp.frame.to_world(bs.wi);
            let transmitted = !at.above(bs.wi);
            if transmitted != (wi.dot(s.ng) < 0.0) {
                break;
            }
            if t == 2 && self.ledger.light_passes {
                // The class of the first bounce, which every longer camera prefix shares.
                scratch.first = match bs.delta {
                    true => passes::delta_bounce(transmitted),
                    false => passes::shares_seen(&at, bs.wi),
                };
            }
            let last = cam.len() - 1;
            // The density of the previous vertex from this one (the reverse direction).
            let pdf_rev_sa = if bs.delta { self.delta_solid_angle() } else { sp.bsdf.pdf(bs.wi, wo_local) };
            if last >= 2 {
                let prev_p = cam[last].p;
                cam[last - 1].pdf_rev = cam[last - 1].area_density(pdf_rev_sa, prev_p);
            }
            cam[last].delta = bs.delta;
            path.beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
            if !path.beta.is_finite() || path.beta == Rgb::ZERO {
                break;
            }
            pdf_sa = if bs.delta { 0.0 } else { bs.pdf };
            prev_delta = bs.delta;
            path.light_path = path.light_path.moved(s.light_path.ray_length).bounced(bs.kind, transmitted, bs.delta);
            see_through &= glass_limit.is_some_and(|t| {
                transmitted && bs.kind == crate::bsdf::LobeKind::Glossy && sp.bsdf.glass_alpha2() <= (t * t) * (t * t)
            });
            // The next segment's kind (camera rays pass objects hidden from the camera alone).
            path.ray = crate::scene::visibility::RayMask::after_bounce(bs.kind, transmitted);
            path.media = ctx.medium_after(&s, wi, medium);
            if (t - 1) as u32 >= self.rr_depth {
                let survive = path.beta.abs().max_element().min(0.95);
                if u_rr >= survive {
                    break;
                }
                path.beta /= survive;
            }
            path.org = offset_ray_origin(s.p, if transmitted { -s.ng } else { s.ng });
            path.dir = wi;
            // The walk looks back across the surface left, as the path tracer's (`contact`).
            path.prev_p = s.p;
            path.prev_tri = hit.tri;
            stats.bounce += 1;
        }
    }

    /// MIS weight of the s = 0 strategy for the camera subpath `cam` whose last vertex
    /// lies on light `index`.
    pub(super) fn weight_s0(
        &self,
        ctx: &SceneContext,
        cam: &[Vertex],
        dens: &mut PathDensities,
        index: usize,
        camera: &CameraRays,
    ) -> f32 {
        let t = cam.len();
        if !self.lights.starts(index) {
            return 1.0;
        }
        let z0 = &cam[t - 1];
        let lp = LightPoint {
            light: index as u32,
            p: z0.p,
            n: z0.ng,
            le: Rgb::ONE,
            pdf_pos: lights::pdf_point(ctx.scene, index),
            two_sided: lights::two_sided(ctx.scene, index),
            bary: Vec2::ZERO,
        };
        self.fill_path(ctx, cam, &[], 0, camera, dens);
        // Light-side densities of the light point and of the next vertex.
        dens.a[0] = self.lights.pmf_origin(index) * lp.pdf_pos;
        if t >= 2 {
            let z1 = &cam[t - 2];
            let w = (z1.p - z0.p).normalize_or_zero();
            // The sidedness of emission: measured on the side the path came from.
            let lp_dir = LightPoint { n: if z0.ng.dot(w) >= 0.0 { z0.ng } else { -z0.ng }, ..lp };
            dens.a[1] = z1.area_density(lights::pdf_direction(ctx.scene, &lp_dir, w), z0.p);
        }
        dens.connectible[0] = true;
        dens.light_hittable = true;
        dens.weight(0)
    }

    /// Fills `dens` with the path made of `light[..s]` and `cam[..t]` (t = cam.len()),
    /// before the connection's own densities are set.
    pub(super) fn fill_path(
        &self,
        ctx: &SceneContext,
        cam: &[Vertex],
        light: &[Vertex],
        s: usize,
        camera: &CameraRays,
        dens: &mut PathDensities,
    ) {
        let t = cam.len();
        dens.n = s + t;
        for (j, v) in light[..s].iter().enumerate() {
            dens.a[j] = v.pdf_fwd;
            dens.b[j] = v.pdf_rev;
            dens.connectible[j] = !v.delta;
        }
        for m in 0..t {
            let v = &cam[t - 1 - m];
            let j = s + m;
            dens.a[j] = v.pdf_rev;
            dens.b[j] = v.pdf_fwd;
            dens.connectible[j] = if v.kind == Kind::Camera { camera.light_tracing_reaches() } else { !v.delta };
        }
        dens.light_hittable = match light.first() {
            Some(v) => v.light.is_some_and(|lp| !lights::is_delta(ctx.scene, lp.light as usize)),
            None => true,
        };
        dens.contacts =
            super::contact::light_end_contacts(s + t, |j| if j < s { &light[j] } else { &cam[t - 1 - (j - s)] });
    }

    /// Traces the light subpath into `scratch.light`.
    pub(crate) fn light_subpath(
        &self,
        ctx: &SceneContext,
        ls: &mut PixelSampler,
        scratch: &mut BdptScratch,
        stats: &mut RayStats,
    ) {
        let light = &mut scratch.light;
        light.clear();
        let segments = &mut scratch.volume_segments;
        segments.clear();
        let [u_pick, u_side, u_px, u_py] = ls.next_4d();
        let [u_dx, u_dy, _, _] = ls.next_4d();
        let Some((index, pmf)) = self.lights.pick_origin(u_pick) else {
            return;
        };
        // A restricted light's paths are the camera side's (`visibility`): never picked.
        debug_assert!(!self.restriction.light(index));
        let Some((v0, org, dir, beta, pdf_dir)) = self.light_start(ctx, index, pmf, u_side, [u_px, u_py, u_dx, u_dy])
        else {
            return;
        };
        light.push(v0);
        if !linking::light_subpaths_leave(ctx, index) {
            return;
        }
        let infinite = v0.kind == Kind::Infinite;
        // By size: a negative emitter's subpaths carry negative light.
        let beta_ref = beta.abs().max_element();
        let mut pdf_sa = pdf_dir;
        let mut prev_delta = false;
        let mut path = PathState::photon(org, dir, beta);
        let mut ignored = Rgb::ZERO;
        loop {
            let [u_lobe, u_x, u_y, u_rr] = ls.next_4d();
            let [u_alpha, _, _, _] = ls.next_4d();
            // The shared step, with media that only attenuate: light subpaths carry the
            // paths without medium vertices. VCM's volume merging records the segments
            // crossed in a medium after delta bounces alone (`vcm::volume_merge`).
            let bounces = light.len() as u32 - 1;
            let record =
                self.volume_merging && self.restriction.none() && bounces >= 1 && light[1..].iter().all(|v| v.delta);
            let no_lights = |st: &PathState, t_event: f32, _: Rgb| {
                if record && ctx.medium(&st.media).is_some() {
                    segments.push(LightSegment {
                        org: st.org,
                        dir: st.dir,
                        t_end: t_event,
                        media: st.media,
                        beta: st.beta,
                        bounces,
                        light: index as u32,
                    });
                }
                Rgb::ZERO
            };
            let org0 = path.org;
            let (step, _) = path.advance_with(ctx, None, || u_alpha, no_lights, &mut ignored, stats);
            // A segment that meets a restricted object makes restricted paths only, which
            // the camera side takes (`visibility`): the subpath stops before it.
            let s = match step {
                Step::Surface { hit, s } => {
                    if self.restriction.object(hit.tri) || self.restriction.between(org0, s.p) {
                        break;
                    }
                    s
                }
                Step::Passed if self.restriction.between(org0, path.org) => break,
                Step::Passed => continue,
                Step::End | Step::Escaped | Step::Medium { .. } => break,
            };
            let i = light.len() - 1;
            // Light linking: the light's first segment must end on one of its receivers.
            if i == 0 && !ctx.links(index, s.tri) {
                break;
            }
            // A contact is reached only straight from the light (`contact`): arriving after
            // a scattering, the light subpath ends there unstored.
            let contact = super::contact::on_contact(ctx, &s);
            if contact && i > 0 {
                break;
            }
            let (dir, beta, medium) = (path.dir, path.beta, path.media);
            let wo = -dir;
            let sp = ctx.shade(&s, wo);
            let mut v = Vertex::surface(&s, &sp, wo, beta, medium);
            v.contact = contact;
            // The light's neighbour light[1] is never counted (`bounces`).
            if i >= 2 {
                v.classes = light[i].classes_toward(dir);
            }
            v.pdf_fwd = if i == 0 && infinite {
                v.density_from_infinity(light[0].p, self.lights.disk_pdf())
            } else if prev_delta {
                self.delta_area(&v, light[i].p)
            } else {
                v.area_density(pdf_sa, light[i].p)
            };
            light.push(v);
            // s light vertices give paths of s - 1 + (t - 1) scattering events, t ≥ 1.
            if light.len() > self.max_depth as usize || light.len() >= mis::MAX_PATH_VERTICES / 2 {
                break;
            }
            let wo_local = sp.frame.to_local(wo);
            let at = sp.bsdf.bind(&light[light.len() - 1].view);
            let Some(bs) = at.sample(u_lobe, Vec2::new(u_x, u_y)) else {
                break;
            };
            let wi = sp.frame.to_world(bs.wi);
            let transmitted = !at.above(bs.wi);
            if transmitted != (wi.dot(s.ng) < 0.0) {
                break;
            }
            // From a contact only through a lobe a shadow ray sees (`contact`), carrying
            // the path tracer's share of the light there.
            if contact {
                if bs.delta {
                    break;
                }
                if let Some(end) = super::contact::LightEnd::of(&light[0]) {
                    path.beta *= super::contact::trap_weight(ctx, &light[light.len() - 1], wi, end);
                }
            }
            // The BSDF seen from the sampled direction: the adjoint's value and the
            // reverse density both read it.
            let (f, pdf_rev_sa) = if bs.delta {
                let f = if transmitted { bs.f * sp.bsdf.refraction_adjoint_scale() } else { bs.f };
                (f, self.delta_solid_angle())
            } else {
                let back = sp.bsdf.at_value(bs.wi);
                (sp.bsdf.eval_adjoint_at(&at, &back, wo_local, bs.wi), back.lobed().pdf(wo_local))
            };
            let last = light.len() - 1;
            let prev_p = light[last].p;
            light[last - 1].pdf_rev = light[last - 1].area_density(pdf_rev_sa, prev_p);
            light[last].delta = bs.delta;
            path.beta *= f * (bs.wi.z.abs() / bs.pdf) * shading_correction(&s, &sp.frame, wo, wi);
            if !path.beta.is_finite() || path.beta == Rgb::ZERO {
                break;
            }
            pdf_sa = if bs.delta { 0.0 } else { bs.pdf };
            prev_delta = bs.delta;
            path.media = ctx.medium_after(&s, wi, medium);
            if (light.len() - 1) as u32 >= self.rr_depth {
                // Light throughput carries the light's power: survive in proportion to
                // what is left of the first segment's.
                let survive = (path.beta.abs().max_element() / beta_ref).min(0.95);
                if !(survive > 0.0) || u_rr >= survive {
                    break;
                }
                path.beta /= survive;
            }
            path.org = offset_ray_origin(s.p, if transmitted { -s.ng } else { s.ng });
            path.dir = wi;
            stats.bounce += 1;
        }
    }

    /// The first vertex of a light subpath from light `index` (chosen with probability
    /// `pmf`), the first ray (origin, direction), the throughput after it and the
    /// direction's solid-angle density: a point and a cosine-weighted or the light's own
    /// direction for finite lights; a direction and a point on the bounding disk for lights
    /// at infinity (`emit::infinite_ray`), whose throughput is L(ω) / (pmf p(ω) p_disk).
    #[allow(clippy::type_complexity)]
    fn light_start(
        &self,
        ctx: &SceneContext,
        index: usize,
        pmf: f32,
        u_side: f32,
        [u_px, u_py, u_dx, u_dy]: [f32; 4],
    ) -> Option<(Vertex, Vec3, Vec3, Rgb, f32)> {
        let l = &ctx.scene.lights[index];
        if !lights::is_finite(l) {
            let disk = self.lights.disk_pdf();
            let r = infinite_ray(ctx.scene, l, self.lights.bounds(), Vec2::new(u_px, u_py), Vec2::new(u_dx, u_dy))?;
            let pdf_origin = pmf * r.pdf_dir;
            if !(pdf_origin > 0.0) || r.le == Rgb::ZERO {
                return None;
            }
            let mut v0 = Vertex::new(Kind::Infinite, -r.dir);
            v0.beta = Rgb::splat(1.0 / pdf_origin);
            v0.pdf_fwd = pdf_origin;
            v0.light = Some(LightPoint {
                light: index as u32,
                p: -r.dir,
                n: Vec3::ZERO,
                le: r.le,
                pdf_pos: disk,
                two_sided: false,
                bary: Vec2::ZERO,
            });
            return Some((v0, r.org, r.dir, r.le * (1.0 / (pdf_origin * disk)), r.pdf_dir));
        }
        let lp = lights::sample_point(ctx.scene, index, Vec2::new(u_px, u_py))?;
        let dir = lights::sample_direction(ctx.scene, &lp, u_side, Vec2::new(u_dx, u_dy));
        let pdf_dir = lights::pdf_direction(ctx.scene, &lp, dir);
        let le = lights::emitted(ctx.scene, &lp, dir);
        let pdf_origin = pmf * lp.pdf_pos;
        if !(pdf_dir > 0.0) || !(pdf_origin > 0.0) || le == Rgb::ZERO {
            return None;
        }
        let mut v0 = Vertex::new(Kind::Light, lp.p);
        v0.ng = lp.n;
        v0.beta = Rgb::splat(1.0 / pdf_origin);
        v0.pdf_fwd = pdf_origin;
        v0.light = Some(lp);
        let cos0 = if lp.n == Vec3::ZERO { 1.0 } else { lp.n.dot(dir).abs() };
        let beta = le * (cos0 / (pdf_origin * pdf_dir));
        let org = if matches!(l, Light::Triangle { .. }) {
            offset_ray_origin(lp.p, if lp.n.dot(dir) >= 0.0 { lp.n } else { -lp.n })
        } else {
            lp.p
        };
        Some((v0, org, dir, beta, pdf_dir))
    }
}
