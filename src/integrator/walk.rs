//! The steps every unidirectional path walker shares: the path's state between two
//! bounces, one `advance` along the ray (medium segment, crossed emitters, surfaces that
//! only bound a medium or are transparent), emission found by the path with its MIS
//! weight, and Russian roulette. The path tracer, SPPM's camera paths, Jensen's
//! camera and gather paths and photon tracing walk with these; each keeps its own sample-dimension layout
//! (the random numbers come in as arguments) and its own policy of what to do at the
//! event `advance` returns.

use super::SceneContext;
use super::media::medium_segment;
use crate::accel::Hit;
use crate::math::{Rgb, offset_ray_origin};
use crate::medium::{MediumStack, Phase};
use crate::render::job::RayStats;
use crate::scene::AlphaMode;
use crate::scene::camera::CameraRay;
use crate::scene::light_path::LightPath;
use crate::scene::linking::NO_OBJECT;
use crate::scene::shading::{ShadingPoint, SurfaceHit};
use crate::scene::visibility::RayMask;
use glam::{Vec2, Vec3};

use super::power_heuristic;

/// Limit on pass-throughs of transparent surfaces and volume boundaries per path, so
/// that a stack of thousands of transparent layers cannot loop forever. One rule for
/// every walker (SPPM used to shade the 129th boundary as a surface).
pub const MAX_TRANSPARENT_HITS: u32 = 128;

/// Where a path stands between two bounces.
#[derive(Clone, Copy, Debug)]
pub struct PathState {
    /// Origin of the next ray.
    pub org: Vec3,
    /// Direction of the next ray.
    pub dir: Vec3,
    /// Throughput.
    pub beta: Rgb,
    /// Scattering events so far.
    pub depth: u32,
    /// Density of the sample that chose `dir`, for MIS (0: none, e.g. after a delta lobe).
    pub prev_pdf: f32,
    /// The vertex that chose `dir`.
    pub prev_p: Vec3,
    /// The receiver normal light selection was given at `prev_p` (zero in a medium).
    pub prev_n: Vec3,
    /// The media the path is in.
    pub media: MediumStack,
    /// Transparent surfaces and volume boundaries passed so far.
    pub transparent_hits: u32,
    /// How far the next ray sees: the far clipping plane for a camera ray (passed surfaces
    /// use up some of it), infinite after the first event.
    pub tmax: f32,
    /// The kind of the next ray (camera until the first event, then the kind of the
    /// last bounce): objects hidden from it are passed (`SceneContext::with_ray_visibility`).
    pub ray: RayMask,
    /// The triangle the ray left (`NO_OBJECT` for camera rays and after a medium event):
    /// light linking's receiver for what the ray finds.
    pub prev_tri: u32,
    /// The ray as the Light Path node sees it (flags of the last bounce, bounce counts).
    pub light_path: LightPath,
}

/// What `PathState::advance` found along the ray.
pub enum Step {
    /// The path ends: too many pass-throughs, or a throughput that is zero or not finite
    /// on arrival at a surface.
    End,
    /// The ray left the scene (the state's `dir` is the escape direction).
    Escaped,
    /// A scattering event in a medium at `p` (the throughput already carries the
    /// segment's weight; it may be zero).
    Medium {
        /// Position of the event.
        p: Vec3,
        /// The medium's phase function.
        phase: Phase,
        /// The free flight's weight (already in the throughput): photon tracing's
        /// Russian roulette is taken on it.
        weight: Rgb,
    },
    /// A volume boundary without a surface or a transparent surface was passed: the
    /// state now starts beyond it; the walker goes on with fresh sample dimensions.
    Passed,
    /// A surface to shade.
    Surface {
        /// The hit.
        hit: Hit,
        /// Its geometry as seen along the ray.
        s: SurfaceHit,
    },
}

impl PathState {
    /// A path leaving a light carrying `power` (photons, BDPT's light subpaths), in vacuum.
    pub fn photon(org: Vec3, dir: Vec3, power: Rgb) -> Self {
        PathState {
            beta: power,
            ray: RayMask::ALL,
            light_path: LightPath::FROM_LIGHT,
            ..Self::camera(&CameraRay::unclipped(org, dir), MediumStack::default())
        }
    }

    /// A camera ray, starting at its near clipping plane and seeing as far as its far one,
    /// in the media around the camera (`SceneContext::camera_media`; none: vacuum or the
    /// world's medium), no MIS for what it hits first.
    pub fn camera(ray: &CameraRay, media: MediumStack) -> Self {
        let org = if ray.near > 0.0 { ray.org + ray.dir * ray.near } else { ray.org };
        let dir = ray.dir;
        PathState {
            tmax: ray.far - ray.near,
            org,
            dir,
            beta: Rgb::ONE,
            depth: 0,
            prev_pdf: 0.0,
            prev_p: org,
            prev_n: Vec3::ZERO,
            media,
            transparent_hits: 0,
            ray: RayMask::CAMERA,
            prev_tri: NO_OBJECT,
            // The ray starts at the near plane: its footprint has grown to there.
            light_path: LightPath::camera(ray.footprint.moved(ray.near.max(0.0))),
        }
    }

    /// Follows the ray to its next event: the medium segment's emission is added to
    /// `radiance` and its weight to the throughput, area and sphere lights crossed before
    /// the event add their emission when `count_crossed` (MIS-weighted against light
    /// sampling from `prev_p`; they do not block, as in Cycles), and surfaces that only
    /// bound a medium or that a BLEND alpha lets through (`u_alpha()` ≥ alpha; drawn only
    /// there) are passed. Returns the event and whether any light was crossed.
    #[inline]
    pub fn advance(
        &mut self,
        ctx: &SceneContext,
        u_medium: [f32; 2],
        u_alpha: impl FnOnce() -> f32,
        count_crossed: bool,
        radiance: &mut Rgb,
        stats: &mut RayStats,
    ) -> (Step, bool) {
        self.advance_each(ctx, u_medium, u_alpha, count_crossed, radiance, stats, |_, _| {})
    }

    /// [`advance`](Self::advance), also handing each crossed light's index and its
    /// contribution (throughput included) to `each` (the light groups file them).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn advance_each(
        &mut self,
        ctx: &SceneContext,
        u_medium: [f32; 2],
        u_alpha: impl FnOnce() -> f32,
        count_crossed: bool,
        radiance: &mut Rgb,
        stats: &mut RayStats,
        mut each: impl FnMut(usize, Rgb),
    ) -> (Step, bool) {
        let mut any = false;
        let crossed = |st: &PathState, t_event: f32, w: Rgb| {
            if !count_crossed {
                return Rgb::ZERO;
            }
            let (le, a) = ctx.crossed_emission_each(
                st.org,
                st.dir,
                t_event,
                st.prev_p,
                st.prev_n,
                st.prev_pdf,
                st.depth == 0,
                st.prev_tri,
                &st.light_path,
                |i, c| each(i, w * c),
            );
            any = a;
            if a { w * le } else { Rgb::ZERO }
        };
        let (step, crossed) = self.advance_with(ctx, Some(u_medium), u_alpha, crossed, radiance, stats);
        if any {
            *radiance += crossed;
        }
        (step, any)
    }

    /// [`advance`](Self::advance) with the walker's own rule for lights crossed on the
    /// way: `crossed(state, t_event, beta × pass weight to the event)` gives their
    /// contribution (BDPT weighs them over all its strategies), which is returned
    /// beside the event rather than added. Without `u_medium` the media only attenuate
    /// (no scattering events, no emission): BDPT's light subpaths carry the paths
    /// without medium vertices.
    #[inline]
    pub fn advance_with(
        &mut self,
        ctx: &SceneContext,
        u_medium: Option<[f32; 2]>,
        u_alpha: impl FnOnce() -> f32,
        crossed: impl FnOnce(&PathState, f32, Rgb) -> Rgb,
        radiance: &mut Rgb,
        stats: &mut RayStats,
    ) -> (Step, Rgb) {
        let hit = match self.coincident_hit(ctx) {
            Some(h) => Some(h),
            None => ctx.intersect_as(self.org, self.dir, self.tmax, self.ray),
        };
        // Past the far clipping plane the ray sees the world, through the medium up to it.
        let t_surface = hit.map_or(self.tmax, |h| h.t);
        let tmax = std::mem::replace(&mut self.tmax, f32::INFINITY);

        // The medium along this segment: emission, then where the next event is.
        let (scatter, crossed_w, segment_weight) = match u_medium {
            Some(u) if ctx.media_act => {
                medium_segment(ctx, &self.media, (self.org, self.dir), t_surface, self.beta, u, radiance)
            }
            Some(_) => (None, Rgb::ONE, Rgb::ONE),
            None => match (ctx.medium(&self.media), hit) {
                (Some(m), Some(h)) if ctx.media_act => (None, Rgb::ONE, m.transmittance_along(self.org, self.dir, h.t)),
                _ => (None, Rgb::ONE, Rgb::ONE),
            },
        };
        let t_event = scatter.map_or(t_surface, |(t, _)| t);
        let lights = crossed(self, t_event, self.beta * crossed_w);
        self.beta *= segment_weight;

        if let Some((t, phase)) = scatter {
            return (Step::Medium { p: self.org + self.dir * t, phase, weight: segment_weight }, lights);
        }
        let Some(hit) = hit else {
            return (Step::Escaped, lights);
        };
        if !self.beta.is_finite() || self.beta == Rgb::ZERO {
            return (Step::End, lights);
        }
        let s = ctx.scene.surface(&hit, self.org, self.dir);
        let mat = &ctx.scene.materials[s.material as usize];
        // A volume boundary without a surface: only the medium changes.
        if mat.null_surface {
            if self.transparent_hits >= MAX_TRANSPARENT_HITS {
                return (Step::End, lights);
            }
            self.transparent_hits += 1;
            self.media = ctx.medium_after(&s, self.dir, self.media);
            self.org = offset_ray_origin(s.p, -s.ng);
            self.tmax = tmax - hit.t;
            self.light_path = self.light_path.moved(hit.t);
            stats.bounce += 1;
            return (Step::Passed, lights);
        }
        // Stochastic transparency: pass straight through with probability 1 - alpha, the
        // throughput tinted by a coloured Transparent BSDF (weight colour / (1 - alpha)).
        if mat.alpha_mode == AlphaMode::Blend && self.transparent_hits < MAX_TRANSPARENT_HITS {
            let (alpha, tint) = ctx.scene.pass_through(hit.tri, hit.b1, hit.b2, self.light_path.at(hit.t), self.dir);
            if u_alpha() >= alpha {
                // Past Transparent Max Bounces the path ends at this surface (Cycles): what
                // it would pass to is not seen.
                if ctx.ends_at_surface(self.light_path) {
                    return (Step::End, lights);
                }
                self.transparent_hits += 1;
                self.light_path = self.light_path.moved(hit.t).passed_transparent();
                self.beta *= tint;
                // Crossing enters or leaves the material's medium, as Cycles' transparent
                // bounce does (a Transparent surface around glowing fog showed nothing).
                self.media = ctx.medium_after(&s, self.dir, self.media);
                self.org = offset_ray_origin(s.p, -s.ng);
                self.tmax = tmax - hit.t;
                stats.bounce += 1;
                return (Step::Passed, lights);
            }
        }
        let s = SurfaceHit { light_path: self.light_path.at(hit.t), ..s };
        (Step::Surface { hit, s }, lights)
    }

    /// A surface coincident with the one the ray has just left (a glass resting on a floor,
    /// a liquid filling its glass): the ray's origin is offset across the surface it leaves
    /// (`offset_ray_origin`), which also carries it past a second surface in the same
    /// plane — a ray leaving the glass's bottom face started below the floor, one leaving
    /// the floor started inside the glass without entering it — so it is looked for behind
    /// the origin, as Cycles finds it by starting on the surface and skipping only the
    /// triangle it left. The look back runs from the mirror image of the origin (the same
    /// offset to the other side) across the surface to the origin's offset, skipping the
    /// triangle left, among the still triangles; when it finds one facing the other way,
    /// the ray starts there.
    /// Moving triangles and strands are not looked for; walkers that do not record the
    /// triangle left (`prev_tri`: BDPT's light subpaths, photon tracing) do not look
    /// (`bdpt::contact`, `photon::contact` say what they do at a contact instead).
    #[inline]
    fn coincident_hit(&mut self, ctx: &SceneContext) -> Option<Hit> {
        // No triangle left: a camera ray, a medium event, a strand (`CURVE_BIT` ids).
        if self.prev_tri == NO_OBJECT || self.prev_tri as usize >= ctx.scene.mesh.triangles.len() {
            return None;
        }
        // No triangle facing the other way within reach of the point left: the look back
        // would find none.
        if !ctx.accel.touches_at(self.prev_tri, self.prev_p) {
            return None;
        }
        let offset = self.org - self.prev_p;
        // The offset is at most 256 ulps or 1/65536 per axis (`offset_ray_origin`, with a
        // normal of length 1 up to rounding: twice that here); a larger gap means the origin
        // moved on since the bounce (a pass-through): nothing to look back across.
        let bound = 2.0 * (self.prev_p.abs().max_element() * (256.0 * f32::EPSILON)).max(1.0 / 65536.0);
        if offset == Vec3::ZERO || offset.abs().max_element() > bound {
            return None;
        }
        let back = self.prev_p - offset;
        let span = 2.0 * offset.length();
        // Along the direction the slab between the two offsets is span / cos thick; below
        // cos = 1/20 the look back is capped at 20 spans (a grazing ray crossing the slab
        // further away would meet its own mesh's neighbours of the triangle left).
        let cos = (self.dir.dot(offset) / offset.length()).abs().max(1.0 / 20.0);
        let mut hit = ctx.intersect_still_except(back, self.dir, span / cos, self.ray, self.prev_tri)?;
        // Two surfaces in contact face each other (the floor up, the glass's bottom down);
        // a triangle facing the same way as the one left is its own mesh's neighbour, which
        // the look back crosses when it leaves near an edge: not a second surface, but one may
        // lie behind it (a ray leaving exactly on the edge the two share, as a pixel's centre
        // sample can: the glass-on-floor test's diagonal pixels leaked the world below).
        let mesh = &ctx.scene.mesh;
        let winding = |tri: u32| {
            let [a, b, c] = mesh.triangles[tri as usize].map(|i| mesh.positions[i as usize]);
            (b - a).cross(c - a)
        };
        let left = winding(self.prev_tri);
        if winding(hit.tri).dot(left) >= 0.0 {
            let (prev_tri, accept) = (self.prev_tri, ctx.accepts(self.ray));
            let mut facing: Option<Hit> = None;
            ctx.accel.visit_hits(back, self.dir, span / cos, &mut |h| {
                if h.tri != prev_tri
                    && winding(h.tri).dot(left) < 0.0
                    && accept(h.tri, h.b1, h.b2)
                    && facing.is_none_or(|f| h.t < f.t)
                {
                    facing = Some(h);
                }
                true
            });
            hit = facing?;
        }
        self.org = back;
        Some(hit)
    }

    /// Radiance of the world and sun disks along the escape direction, MIS-weighted
    /// against light sampling (not yet times the throughput); None when there is none.
    #[inline]
    pub fn escaped_radiance(&self, ctx: &SceneContext) -> Option<Rgb> {
        self.escaped_radiance_each(ctx, |_, _| {})
    }

    /// [`escaped_radiance`](Self::escaped_radiance), also handing each part to `each`:
    /// the world's (None) and each sun's (its light index), not yet times the throughput.
    #[inline]
    pub fn escaped_radiance_each(&self, ctx: &SceneContext, mut each: impl FnMut(Option<usize>, Rgb)) -> Option<Rgb> {
        // No world and no sun: nothing to find (half the glass bench scene's rays escape).
        if ctx.scene.world.is_none() && ctx.suns.is_empty() {
            return None;
        }
        // The world's own Ray Visibility (Cycles' World > Ray Visibility).
        let le = if ctx.world_seen_by(self.depth == 0, &self.light_path) {
            ctx.world_radiance_for(self.dir, &self.light_path)
        } else {
            Rgb::ZERO
        };
        let sun =
            ctx.sun_emission_each(self.dir, self.prev_pdf, self.depth == 0, self.prev_tri, &self.light_path, |i, c| {
                each(Some(i), c)
            });
        if le == Rgb::ZERO && sun == Rgb::ZERO {
            return None;
        }
        let w = if self.prev_pdf == 0.0 {
            1.0
        } else {
            power_heuristic(self.prev_pdf, ctx.world_pdf(self.prev_p, self.dir))
        };
        each(None, le * w);
        Some(le * w + sun)
    }

    /// Emission of the shaded surface `s` toward the path, MIS-weighted against light
    /// sampling from the previous vertex, times the throughput.
    #[inline]
    pub fn surface_emission(&self, ctx: &SceneContext, hit: &Hit, s: &SurfaceHit, sp: &ShadingPoint) -> Rgb {
        if sp.emitted == Rgb::ZERO {
            return Rgb::ZERO;
        }
        // Light linking: an emitter that does not light the surface the ray left gives it
        // nothing (camera rays see every emitter, as in Cycles).
        if self.depth > 0
            && let Some(index) = ctx.lights.light_of_triangle(hit.tri)
            && !ctx.links(index, self.prev_tri)
        {
            return Rgb::ZERO;
        }
        // A shadow-linked emitter is found by next-event estimation alone (after a delta
        // lobe, which NEE cannot follow, the path still finds it).
        if self.prev_pdf > 0.0
            && let Some(index) = ctx.lights.light_of_triangle(hit.tri)
            && ctx.shadow_linked(index)
        {
            return Rgb::ZERO;
        }
        let w = match (self.prev_pdf > 0.0, ctx.lights.light_of_triangle(hit.tri)) {
            (true, Some(index)) => {
                power_heuristic(self.prev_pdf, ctx.light_pdf(index, self.prev_p, self.prev_n, s.p, s.ng))
            }
            _ => 1.0,
        };
        self.beta * sp.emitted * w
    }

    /// Russian roulette from `rr_depth` on: false when the path ends; survivors are
    /// reweighted. The survival probability is the throughput's largest channel, at most
    /// 0.95 (a refraction does not scale the throughput: `bsdf::dielectric`); by magnitude,
    /// since a procedural medium's tracking can make it negative (`medium::tracking`).
    #[inline]
    pub fn survives(&mut self, rr_depth: u32, u_rr: f32) -> bool {
        if self.depth < rr_depth {
            return true;
        }
        let survive = self.beta.abs().max_element().min(0.95);
        if u_rr >= survive {
            return false;
        }
        self.beta /= survive;
        true
    }

    /// Follows the delta lobe of a specular surface (camera paths of the photon
    /// integrators, which read their maps at the first non-specular hit): samples the
    /// BSDF, updates throughput, depth and media and spawns the next ray. False when the
    /// path ends.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn follow_specular(
        &mut self,
        ctx: &SceneContext,
        s: &SurfaceHit,
        sp: &ShadingPoint,
        wo_local: Vec3,
        u_lobe: f32,
        u_dir: Vec2,
        stats: &mut RayStats,
    ) -> bool {
        let Some(bs) = sp.bsdf.sample(wo_local, u_lobe, u_dir) else {
            return false;
        };
        let wi = sp.frame.to_world(bs.wi);
        self.beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
        if !self.beta.is_finite() || self.beta == Rgb::ZERO {
            return false;
        }
        self.depth += 1;
        // What the next ray finds was reached through a delta lobe (no MIS) from this
        // surface, light linking's receiver.
        self.prev_pdf = 0.0;
        self.prev_p = s.p;
        self.prev_tri = s.tri;
        self.media = ctx.medium_after(s, wi, self.media);
        self.ray = RayMask::after_bounce(bs.kind, wi.dot(s.ng) <= 0.0);
        self.light_path =
            self.light_path.moved(s.light_path.ray_length).bounced(bs.kind, wi.dot(s.ng) <= 0.0, bs.delta);
        self.org = offset_ray_origin(s.p, if wi.dot(s.ng) > 0.0 { s.ng } else { -s.ng });
        self.dir = wi;
        stats.bounce += 1;
        true
    }
}
