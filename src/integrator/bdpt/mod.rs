//! Bidirectional path tracing (Veach 1997, ch. 10) with multiple importance sampling
//! over all connection strategies, power heuristic.
//!
//! Per camera sample: a camera subpath and a light subpath are traced, then every pair
//! of prefixes (s light vertices, t camera vertices) is connected:
//! - s = 0: the camera subpath finds an emitter (hits an emissive triangle, crosses an
//!   area or sphere light, escapes to the world or a sun); done while tracing it;
//! - s = 1: light sampling at a camera vertex (a fresh light point, not the subpath's);
//! - t = 1: a light subpath vertex is connected to the camera and splatted onto the film
//!   through the pixel filter (light tracing);
//! - s, t ≥ 2: a shadow ray joins the two subpaths.
//!
//! Each contribution is weighted by `mis::PathDensities::weight`. Light subpaths start
//! only at lights with a fixed point or surface (`lights::is_finite`); paths from the
//! world, suns and soft-falloff point lights are made by s = 0 and s = 1 only, weighted as
//! the path tracer weights them.
//!
//! Light subpaths carry importance: refraction does not scale it by 1/η², and shading
//! normals get Veach's correction |wo·ns| |wi·ng| / (|wo·ng| |wi·ns|).
//!
//! Media and subsurface scattering: the strategies above carry the paths without a vertex in
//! a medium, attenuated by extinction along every segment (light subpaths, connections and
//! camera segments alike; volume-only boundaries are crossed). Paths with a medium vertex are
//! made by the camera subpath alone: where free-flight sampling puts a scattering event on
//! it, the path tracer takes over from that vertex (NEE and phase sampling), and the
//! subsurface part of a material at a camera vertex is path traced from it. The two sets of
//! paths are disjoint, so the sum is unbiased; what BDPT does not yet offer is light
//! subpaths scattering in media (a volumetric caustic seen in fog is path traced).

pub mod mis;

use super::{SceneContext, power_heuristic};
use crate::bsdf::Bsdf;
use crate::film::CameraSample;
use crate::film::{Filter, SplatBuffer};
use crate::light::origin::{self as lights, BdptLights, LightPoint};
use crate::light::{Light, LightSample, area_to_solid_angle, intersect_sphere};
use crate::math::{Frame, Rgb, hash_combine, offset_ray_origin};
use crate::medium::{FreeFlight, MediumStack};
use crate::render::job::RayStats;
use crate::sampling::PixelSampler;
use crate::sampling::warp::uniform_cone_pdf;
use crate::scene::AlphaMode;
use crate::scene::camera::CameraRays;
use crate::scene::shading::SurfaceHit;
use glam::{Vec2, Vec3};
use mis::PathDensities;
use std::sync::Arc;

/// Largest `max_depth` the bidirectional integrator accepts (its vertex arrays are fixed).
pub const MAX_BDPT_DEPTH: u32 = 62;

/// Limit on pass-throughs of transparent surfaces per subpath.
const MAX_TRANSPARENT_HITS: u32 = 128;

/// One strategy to render alone (debugging and tests).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Strategy {
    /// Light vertices.
    pub s: u32,
    /// Camera vertices (the camera included).
    pub t: u32,
    /// Apply the MIS weight (else the strategy's own unweighted estimate).
    pub weighted: bool,
}

/// The bidirectional path tracer's parameters.
#[derive(Clone, Debug)]
pub struct BdptIntegrator {
    /// Maximum number of scattering events on a path.
    pub max_depth: u32,
    /// Subpath depth from which Russian roulette may end subpaths.
    pub rr_depth: u32,
    /// Camera rays that miss show nothing (alpha 0), as Blender's Film → Transparent.
    pub transparent_background: bool,
    /// Render only this strategy.
    pub strategy: Option<Strategy>,
    /// The lights as subpath origins.
    pub lights: Arc<BdptLights>,
}

impl BdptIntegrator {
    /// BDPT over the scene's lights (Russian roulette at the path tracer's depth);
    /// `strategy` renders one strategy alone (debugging).
    pub fn new(
        scene: &crate::scene::Scene,
        max_depth: u32,
        transparent_background: bool,
        strategy: Option<Strategy>,
    ) -> Self {
        BdptIntegrator {
            max_depth,
            rr_depth: super::path::PathIntegrator::default().rr_depth,
            transparent_background,
            strategy,
            lights: Arc::new(BdptLights::new(scene)),
        }
    }

    /// Human-readable description.
    pub fn describe(&self) -> String {
        let mut s = format!("bdpt (max depth {}, russian roulette from depth {})", self.max_depth, self.rr_depth);
        if let Some(st) = self.strategy {
            s += &format!(
                ", only strategy s={} t={} {}",
                st.s,
                st.t,
                if st.weighted { "weighted" } else { "unweighted" }
            );
        }
        s
    }

    /// The path tracer that continues camera paths at vertices in media and into
    /// subsurface scattering.
    fn continuation(&self) -> crate::integrator::path::PathIntegrator {
        crate::integrator::path::PathIntegrator {
            max_depth: self.max_depth,
            rr_depth: self.rr_depth,
            transparent_background: self.transparent_background,
        }
    }

    #[inline]
    fn allowed(&self, s: usize, t: usize) -> bool {
        match self.strategy {
            None => true,
            Some(st) => st.s as usize == s && st.t as usize == t,
        }
    }

    #[inline]
    fn mis(&self, w: f32) -> f32 {
        match self.strategy {
            Some(Strategy { weighted: false, .. }) => 1.0,
            _ => w,
        }
    }
}

/// What a vertex is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Camera,
    /// The first vertex of a light subpath (or a light point connected to).
    Light,
    Surface,
}

/// A vertex of a subpath.
#[derive(Clone, Copy, Debug)]
struct Vertex {
    kind: Kind,
    p: Vec3,
    /// Geometric normal (surfaces: on the side the subpath arrived from; lights: the
    /// emitting side; zero for points and the camera).
    ng: Vec3,
    /// Shading frame and BSDF of surfaces.
    frame: Frame,
    bsdf: Option<Bsdf>,
    hit: Option<SurfaceHit>,
    /// Unit direction toward the previous vertex of its own subpath.
    wo: Vec3,
    /// Throughput up to this vertex divided by the densities (subpath measure).
    beta: Rgb,
    /// Area density of this vertex from its own subpath's side.
    pdf_fwd: f32,
    /// Area density of this vertex from the other side (set when the next vertex is sampled).
    pdf_rev: f32,
    /// Its outgoing direction was sampled from a delta lobe.
    delta: bool,
    /// The media the arriving segment crossed (absorbing only in this integrator).
    medium: MediumStack,
    /// Light vertices: the light point (index, emission, densities).
    light: Option<LightPoint>,
    /// Emission of a surface toward `wo` (emissive triangles).
    emitted: Rgb,
}

impl Vertex {
    fn new(kind: Kind, p: Vec3) -> Self {
        Vertex {
            kind,
            p,
            ng: Vec3::ZERO,
            frame: Frame::from_normal(Vec3::Z),
            bsdf: None,
            hit: None,
            wo: Vec3::ZERO,
            beta: Rgb::ONE,
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
            delta: false,
            medium: MediumStack::default(),
            light: None,
            emitted: Rgb::ZERO,
        }
    }

    /// A surface vertex reached from direction `wo` with throughput `beta` through `medium`.
    fn surface(
        s: &SurfaceHit,
        sp: &crate::scene::shading::ShadingPoint,
        wo: Vec3,
        beta: Rgb,
        medium: MediumStack,
    ) -> Self {
        Vertex {
            ng: s.ng,
            frame: sp.frame,
            bsdf: Some(sp.bsdf),
            hit: Some(*s),
            wo,
            beta,
            medium,
            ..Vertex::new(Kind::Surface, s.p)
        }
    }

    /// |cos| between the vertex's normal and `w` (1 for points and the camera).
    #[inline]
    fn abs_cos_geo(&self, w: Vec3) -> f32 {
        if self.ng == Vec3::ZERO { 1.0 } else { self.ng.dot(w).abs() }
    }

    /// Converts a solid-angle density at `from` toward this vertex into an area density here.
    #[inline]
    fn area_density(&self, pdf_sa: f32, from: Vec3) -> f32 {
        let d = self.p - from;
        let d2 = d.length_squared();
        if !(d2 > 0.0) {
            return 0.0;
        }
        pdf_sa * self.abs_cos_geo(d / d2.sqrt()) / d2
    }
}

/// Per-worker scratch memory, reused for every sample (nothing is allocated per sample).
#[derive(Debug, Default)]
pub struct BdptScratch {
    cam: Vec<Vertex>,
    light: Vec<Vertex>,
    dens: Box<PathDensities>,
}

impl BdptScratch {
    /// Scratch for paths of up to `max_depth` scattering events.
    pub fn new(max_depth: u32) -> Self {
        let n = max_depth as usize + 3;
        BdptScratch { cam: Vec::with_capacity(n), light: Vec::with_capacity(n), dens: Box::default() }
    }
}

/// Where the film and camera are, for light tracing (t = 1).
pub struct FilmTarget<'a> {
    /// The camera.
    pub camera: &'a CameraRays,
    /// The pixel filter (splats are spread with it).
    pub filter: &'a Filter,
    /// Splats of this worker.
    pub splats: &'a mut SplatBuffer,
}

/// The light subpath's sample stream: an independent scramble of the pixel's Sobol points.
#[inline]
fn light_sampler(seed: u32, px: u32, py: u32, index: u32) -> PixelSampler {
    PixelSampler::new(hash_combine(&[seed, 0x4c49_4748]), px, py, index)
}

/// Fraction of light carried from vertex `a` to vertex `b` through the media `stack` the
/// segment starts in: volume-only boundaries are crossed (changing the medium), BLEND
/// surfaces pass 1 - alpha, media attenuate by their extinction (light subpaths and
/// connections carry the paths without a medium vertex; those with one are path traced
/// from the camera side), any other surface blocks.
#[inline]
fn segment_transmittance(ctx: &SceneContext, a: &Vertex, b: &Vertex, stack: MediumStack) -> Rgb {
    let d = b.p - a.p;
    let dist = d.length();
    if !(dist > 0.0) {
        return Rgb::ZERO;
    }
    let wi = d / dist;
    // The target's normal on the side facing `a` (the shadow ray stops just short of it).
    let normal = if b.ng == Vec3::ZERO {
        Vec3::ZERO
    } else if b.ng.dot(wi) <= 0.0 {
        b.ng
    } else {
        -b.ng
    };
    let target = LightSample { wi, dist, li: Rgb::ZERO, pdf: 0.0, delta: false, point: b.p, normal };
    let ng = (a.ng != Vec3::ZERO).then_some(a.ng);
    super::media::light_transmittance(ctx, a.p, ng, &target, stack)
}

/// Whether a subpath goes straight on through the surface it hit: a volume-only boundary
/// (which changes the medium) or, with probability 1 - alpha, a BLEND surface.
#[inline]
fn passes_through(
    ctx: &SceneContext,
    s: &SurfaceHit,
    hit: &crate::accel::Hit,
    dir: Vec3,
    u_alpha: f32,
    medium: &mut MediumStack,
) -> bool {
    let mat = &ctx.scene.materials[s.material as usize];
    if mat.null_surface {
        *medium = ctx.medium_after(s, dir, *medium);
        return true;
    }
    mat.alpha_mode == AlphaMode::Blend && u_alpha >= ctx.scene.alpha(hit.tri, hit.b1, hit.b2)
}

/// The media a segment leaving vertex `v` in direction `w` is in.
#[inline]
fn media_leaving(ctx: &SceneContext, v: &Vertex, w: Vec3) -> MediumStack {
    match v.hit {
        Some(h) => ctx.medium_after(&h, w, v.medium),
        None => v.medium,
    }
}

impl BdptIntegrator {
    /// Traces one camera sample: returns the camera-side contributions (s ≥ 0, t ≥ 2) and
    /// splats the light-tracing ones (t = 1) into `film.splats`.
    #[allow(clippy::too_many_arguments)]
    pub fn li(
        &self,
        ctx: &SceneContext,
        org: Vec3,
        dir: Vec3,
        sampler: &mut PixelSampler,
        light_stream: (u32, u32, u32, u32),
        film: &mut FilmTarget,
        scratch: &mut BdptScratch,
        stats: &mut RayStats,
    ) -> CameraSample {
        let mut out = CameraSample { depth: f32::INFINITY, ..Default::default() };
        let mut radiance = Rgb::ZERO;
        self.camera_subpath(ctx, org, dir, sampler, film.camera, scratch, &mut out, &mut radiance, stats);
        let (seed, px, py, index) = light_stream;
        let mut ls = light_sampler(seed, px, py, index);
        self.light_subpath(ctx, &mut ls, scratch, stats);
        radiance += self.connect_all(ctx, sampler, film, scratch, stats);
        out.radiance = radiance;
        out
    }

    /// Traces the camera subpath into `scratch.cam`, adding every s = 0 contribution
    /// (emitters found by the path) to `radiance`.
    #[allow(clippy::too_many_arguments)]
    fn camera_subpath(
        &self,
        ctx: &SceneContext,
        mut org: Vec3,
        mut dir: Vec3,
        sampler: &mut PixelSampler,
        camera: &CameraRays,
        scratch: &mut BdptScratch,
        out: &mut CameraSample,
        radiance: &mut Rgb,
        stats: &mut RayStats,
    ) {
        let cam = &mut scratch.cam;
        cam.clear();
        let mut v0 = Vertex::new(Kind::Camera, org);
        v0.pdf_fwd = 1.0;
        cam.push(v0);
        let mut beta = Rgb::ONE;
        // Solid-angle density of the direction just sampled (0 after a delta lobe).
        let mut pdf_sa = if camera.is_orthographic() { 1.0 } else { camera.pdf_dir((-camera.camera().back).dot(dir)) };
        let mut prev_delta = false;
        let mut medium = MediumStack::default();
        let mut eta_scale = 1.0f32;
        let mut transparent_hits = 0u32;
        stats.camera += 1;
        loop {
            let [u_lobe, u_dx, u_dy, u_rr] = sampler.next_4d();
            let [u_alpha, u_channel, u_dist, _] = sampler.next_4d();
            let i = cam.len() - 1; // the vertex the ray leaves from
            let hit = ctx.intersect(org, dir, f32::INFINITY);
            let t_surface = hit.map_or(f32::INFINITY, |h| h.t);

            // The medium along this segment: its emission, then where the next event is
            // (as the path tracer samples it).
            let in_medium = ctx.medium(&medium).copied();
            let mut scatter_at = None;
            let mut segment_weight = Rgb::ONE;
            if let Some(m) = in_medium {
                if t_surface.is_finite() && self.strategy.is_none() {
                    *radiance += beta * m.emitted(t_surface);
                }
                match m.sample_free_flight(t_surface, beta, u_channel, u_dist) {
                    FreeFlight::Scatter { t, weight } => {
                        scatter_at = Some(t);
                        segment_weight = weight;
                    }
                    FreeFlight::Pass { weight } => segment_weight = weight,
                }
            }
            let t_event = scatter_at.unwrap_or(t_surface);

            // Emitters crossed on the way (area and sphere lights do not block).
            if self.allowed(0, i + 2) {
                let crossed = self.crossed_lights(
                    ctx,
                    cam,
                    &mut scratch.dens,
                    (org, dir, t_event),
                    beta * in_medium.map_or(Rgb::ONE, |m| m.pass_weight(t_event.min(1e30), beta)),
                    (pdf_sa, prev_delta),
                    camera,
                );
                if crossed != Rgb::ZERO {
                    *radiance += crossed;
                    if i == 0 {
                        out.alpha = 1.0;
                    }
                }
            }

            beta *= segment_weight;
            if let Some(t) = scatter_at {
                // A vertex in a medium: the rest of the path is traced by the path tracer
                // (BDPT's strategies carry the paths without medium vertices).
                let p = org + dir * t;
                if i == 0 {
                    out.alpha = 1.0;
                    out.depth = camera.depth(p);
                }
                if self.strategy.is_none() && (i as u32) < self.max_depth && beta.is_finite() && beta != Rgb::ZERO {
                    let phase = in_medium.map(|m| m.phase).unwrap_or_default();
                    *radiance += self
                        .continuation()
                        .scatter_in_medium(ctx, p, dir, phase, medium, beta, i as u32, sampler, stats);
                }
                break;
            }
            let Some(hit) = hit else {
                if self.allowed(0, i + 2) && !(i == 0 && self.transparent_background) {
                    let le = ctx.world_radiance(dir);
                    let mut sum = Rgb::ZERO;
                    if le != Rgb::ZERO {
                        let p_light =
                            ctx.scene.lights.iter().position(|l| matches!(l, Light::World)).map_or(0.0, |w| {
                                self.lights.pmf_any(w) * ctx.scene.world.as_ref().map_or(0.0, |e| e.pdf(dir))
                            });
                        sum += le * self.camera_only_weight(i, prev_delta, pdf_sa, p_light);
                    }
                    for (index, l) in ctx.scene.lights.iter().enumerate() {
                        if let Light::Directional { direction, irradiance, cos_half } = l
                            && *cos_half < 1.0 - 1e-7
                            && dir.dot(-*direction) >= *cos_half
                        {
                            let p_light = self.lights.pmf_any(index) * uniform_cone_pdf(*cos_half);
                            sum += crate::light::sun_radiance(*irradiance, *cos_half)
                                * self.camera_only_weight(i, prev_delta, pdf_sa, p_light);
                        }
                    }
                    if sum != Rgb::ZERO {
                        *radiance += beta * sum;
                        if i == 0 {
                            out.alpha = 1.0;
                        }
                    }
                }
                break;
            };
            let s = ctx.scene.surface(&hit, org, dir);
            let wo = -dir;
            let mat = &ctx.scene.materials[s.material as usize];
            if passes_through(ctx, &s, &hit, dir, u_alpha, &mut medium) && transparent_hits < MAX_TRANSPARENT_HITS {
                transparent_hits += 1;
                org = offset_ray_origin(s.p, -s.ng);
                stats.bounce += 1;
                continue;
            }
            let sp = ctx.scene.shade(&s, wo);
            // Subsurface scattering is path traced from here (the BSDF holds the rest of
            // the material: its diffuse base is already reduced by the subsurface weight).
            if mat.subsurface.is_some() && self.strategy.is_none() && (i as u32) < self.max_depth {
                let q = sp.bsdf.subsurface_weight(sp.frame.to_local(wo));
                if q > 0.0 {
                    *radiance += self.continuation().subsurface_from(
                        ctx,
                        &s,
                        &sp,
                        wo,
                        medium,
                        beta * q,
                        i as u32,
                        sampler,
                        stats,
                    );
                }
            }
            if i == 0 {
                out.alpha = 1.0;
                out.depth = camera.depth(s.p);
                out.normal = sp.frame.n;
                out.albedo = sp.bsdf.albedo();
            }
            let mut v = Vertex::surface(&s, &sp, wo, beta, medium);
            v.emitted = sp.emitted;
            v.pdf_fwd = if prev_delta { 0.0 } else { v.area_density(pdf_sa, cam[i].p) };
            cam.push(v);
            let t = cam.len();

            // s = 0: this surface emits.
            if sp.emitted != Rgb::ZERO
                && self.allowed(0, t)
                && let Some(index) = ctx.lights.light_of_triangle(hit.tri)
            {
                let w = self.weight_s0(ctx, cam, &mut scratch.dens, index, camera);
                *radiance += beta * sp.emitted * self.mis(w);
            }
            // Scattering events so far: t - 2; a vertex at the depth limit only emits.
            if t - 1 > self.max_depth as usize || t >= mis::MAX_PATH_VERTICES / 2 {
                break;
            }
            let wo_local = sp.frame.to_local(wo);
            let Some(bs) = sp.bsdf.sample(wo_local, u_lobe, Vec2::new(u_dx, u_dy)) else {
                break;
            };
            let wi = sp.frame.to_world(bs.wi);
            let transmitted = bs.wi.z < 0.0;
            if transmitted != (wi.dot(s.ng) < 0.0) {
                break;
            }
            let last = cam.len() - 1;
            // The density of the previous vertex from this one (the reverse direction).
            let pdf_rev_sa = if bs.delta { 0.0 } else { sp.bsdf.pdf(bs.wi, wo_local) };
            if last >= 2 {
                let prev_p = cam[last].p;
                cam[last - 1].pdf_rev = cam[last - 1].area_density(pdf_rev_sa, prev_p);
            }
            cam[last].delta = bs.delta;
            beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
            if !beta.is_finite() || beta == Rgb::ZERO {
                break;
            }
            pdf_sa = if bs.delta { 0.0 } else { bs.pdf };
            prev_delta = bs.delta;
            medium = ctx.medium_after(&s, wi, medium);
            if transmitted {
                let mat = &ctx.scene.materials[s.material as usize];
                if mat.medium.is_some() {
                    let eta = if s.front { mat.ior } else { 1.0 / mat.ior };
                    eta_scale *= eta * eta;
                }
            }
            if (t - 1) as u32 >= self.rr_depth {
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
    }

    /// The weight of an s = 0 or s = 1 contribution from a light that only the camera
    /// side reaches: BSDF sampling (density `pdf_sa`) against light sampling (`p_light`).
    #[inline]
    fn camera_only_weight(&self, i: usize, prev_delta: bool, pdf_sa: f32, p_light: f32) -> f32 {
        if i == 0 || prev_delta { self.mis(1.0) } else { self.mis(power_heuristic(pdf_sa, p_light)) }
    }

    /// s = 0 contributions of area and sphere lights crossed by the segment from the last
    /// camera vertex (they do not block: the path goes on, as in Cycles).
    #[allow(clippy::too_many_arguments)]
    fn crossed_lights(
        &self,
        ctx: &SceneContext,
        cam: &mut Vec<Vertex>,
        dens: &mut PathDensities,
        (org, dir, tmax): (Vec3, Vec3, f32),
        beta: Rgb,
        (pdf_sa, prev_delta): (f32, bool),
        camera: &CameraRays,
    ) -> Rgb {
        let i = cam.len() - 1;
        let mut sum = Rgb::ZERO;
        for (index, l) in ctx.scene.lights.iter().enumerate() {
            let (t, n, le) = match l {
                Light::Area(a) => {
                    if i == 0 && !a.camera_visible {
                        continue;
                    }
                    match a.intersect(org, dir, tmax) {
                        Some(t) if (-dir).dot(a.normal) > 0.0 => (t, a.normal, a.radiance),
                        _ => continue,
                    }
                }
                Light::Sphere { center, radius, radiance, soft: false, camera_visible } => {
                    if i == 0 && !camera_visible {
                        continue;
                    }
                    match intersect_sphere(org, dir, *center, *radius, tmax) {
                        Some(t) => (t, ((org + dir * t) - *center).normalize_or(-dir), *radiance),
                        None => continue,
                    }
                }
                Light::Sphere { center, radius, radiance, soft: true, camera_visible } => {
                    // Camera-side only: a disk facing the previous vertex.
                    if i == 0 && !camera_visible {
                        continue;
                    }
                    let prev_p = cam[i].p;
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
                    let p_light = self.lights.pmf_any(index)
                        * area_to_solid_angle(1.0 / (std::f32::consts::PI * radius * radius), dist, -denom);
                    let w = self.camera_only_weight(i, prev_delta, pdf_sa, p_light);
                    sum += beta * *radiance * w;
                    continue;
                }
                _ => continue,
            };
            let q = org + dir * t;
            let mut v = Vertex::new(Kind::Light, q);
            v.ng = n;
            v.wo = -dir;
            v.pdf_fwd = if prev_delta { 0.0 } else { v.area_density(pdf_sa, cam[i].p) };
            v.light = Some(LightPoint {
                light: index as u32,
                p: q,
                n,
                le,
                pdf_pos: lights::pdf_point(ctx.scene, index),
                two_sided: false,
            });
            cam.push(v);
            let w = self.weight_s0(ctx, cam, dens, index, camera);
            cam.pop();
            sum += beta * le * self.mis(w);
        }
        sum
    }

    /// MIS weight of the s = 0 strategy for the camera subpath `cam` whose last vertex
    /// lies on light `index`.
    fn weight_s0(
        &self,
        ctx: &SceneContext,
        cam: &[Vertex],
        dens: &mut PathDensities,
        index: usize,
        camera: &CameraRays,
    ) -> f32 {
        let t = cam.len();
        if !self.lights.finite(index) {
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
        };
        self.fill_path(ctx, cam, &[], 0, camera, dens);
        // Light-side densities of the light point and of the next vertex.
        dens.a[0] = self.lights.pmf_finite(index) * lp.pdf_pos;
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
    fn fill_path(
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
            dens.connectible[j] = if v.kind == Kind::Camera { !camera.is_orthographic() } else { !v.delta };
        }
        dens.light_hittable = match light.first() {
            Some(v) => v.light.is_some_and(|lp| !lights::is_delta_position(ctx.scene, lp.light as usize)),
            None => true,
        };
    }

    /// Traces the light subpath into `scratch.light`.
    fn light_subpath(
        &self,
        ctx: &SceneContext,
        ls: &mut PixelSampler,
        scratch: &mut BdptScratch,
        stats: &mut RayStats,
    ) {
        let light = &mut scratch.light;
        light.clear();
        let [u_pick, u_side, u_px, u_py] = ls.next_4d();
        let [u_dx, u_dy, _, _] = ls.next_4d();
        let Some((index, pmf)) = self.lights.pick_finite(u_pick) else {
            return;
        };
        let Some(lp) = lights::sample_point(ctx.scene, index, Vec2::new(u_px, u_py)) else {
            return;
        };
        let dir = lights::sample_direction(ctx.scene, &lp, u_side, Vec2::new(u_dx, u_dy));
        let pdf_dir = lights::pdf_direction(ctx.scene, &lp, dir);
        let le = lights::emitted(ctx.scene, &lp, dir);
        let pdf_origin = pmf * lp.pdf_pos;
        if !(pdf_dir > 0.0) || !(pdf_origin > 0.0) || le == Rgb::ZERO {
            return;
        }
        let mut v0 = Vertex::new(Kind::Light, lp.p);
        v0.ng = lp.n;
        v0.beta = Rgb::splat(1.0 / pdf_origin);
        v0.pdf_fwd = pdf_origin;
        v0.light = Some(lp);
        light.push(v0);
        let cos0 = if lp.n == Vec3::ZERO { 1.0 } else { lp.n.dot(dir).abs() };
        let mut beta = le * (cos0 / (pdf_origin * pdf_dir));
        let beta_ref = beta.max_element();
        let mut pdf_sa = pdf_dir;
        let mut prev_delta = false;
        let mut org = if matches!(ctx.scene.lights[index], Light::Triangle { .. }) {
            offset_ray_origin(lp.p, if lp.n.dot(dir) >= 0.0 { lp.n } else { -lp.n })
        } else {
            lp.p
        };
        let mut dir = dir;
        let mut medium = MediumStack::default();
        let mut transparent_hits = 0u32;
        loop {
            let [u_lobe, u_x, u_y, u_rr] = ls.next_4d();
            let [u_alpha, _, _, _] = ls.next_4d();
            let Some(hit) = ctx.intersect(org, dir, f32::INFINITY) else {
                break;
            };
            // Light subpaths carry the paths without medium vertices: extinction only.
            if let Some(m) = ctx.medium(&medium) {
                beta *= m.transmittance(hit.t);
            }
            let s = ctx.scene.surface(&hit, org, dir);
            let wo = -dir;
            if passes_through(ctx, &s, &hit, dir, u_alpha, &mut medium) && transparent_hits < MAX_TRANSPARENT_HITS {
                transparent_hits += 1;
                org = offset_ray_origin(s.p, -s.ng);
                stats.bounce += 1;
                continue;
            }
            let sp = ctx.scene.shade(&s, wo);
            let i = light.len() - 1;
            let mut v = Vertex::surface(&s, &sp, wo, beta, medium);
            v.pdf_fwd = if prev_delta { 0.0 } else { v.area_density(pdf_sa, light[i].p) };
            light.push(v);
            // s light vertices give paths of s - 1 + (t - 1) scattering events, t ≥ 1.
            if light.len() > self.max_depth as usize || light.len() >= mis::MAX_PATH_VERTICES / 2 {
                break;
            }
            let wo_local = sp.frame.to_local(wo);
            let Some(bs) = sp.bsdf.sample(wo_local, u_lobe, Vec2::new(u_x, u_y)) else {
                break;
            };
            let wi = sp.frame.to_world(bs.wi);
            let transmitted = bs.wi.z < 0.0;
            if transmitted != (wi.dot(s.ng) < 0.0) {
                break;
            }
            let f = if bs.delta {
                if transmitted { bs.f * sp.bsdf.refraction_eta2() } else { bs.f }
            } else {
                sp.bsdf.eval_adjoint(wo_local, bs.wi)
            };
            let last = light.len() - 1;
            let pdf_rev_sa = if bs.delta { 0.0 } else { sp.bsdf.pdf(bs.wi, wo_local) };
            let prev_p = light[last].p;
            light[last - 1].pdf_rev = light[last - 1].area_density(pdf_rev_sa, prev_p);
            light[last].delta = bs.delta;
            beta *= f * (bs.wi.z.abs() / bs.pdf) * shading_correction(&s, &sp.frame, wo, wi);
            if !beta.is_finite() || beta == Rgb::ZERO {
                break;
            }
            pdf_sa = if bs.delta { 0.0 } else { bs.pdf };
            prev_delta = bs.delta;
            medium = ctx.medium_after(&s, wi, medium);
            if (light.len() - 1) as u32 >= self.rr_depth {
                // Light throughput carries the light's power: survive in proportion to
                // what is left of the first segment's.
                let survive = (beta.max_element() / beta_ref).min(0.95);
                if !(survive > 0.0) || u_rr >= survive {
                    break;
                }
                beta /= survive;
            }
            org = offset_ray_origin(s.p, if transmitted { -s.ng } else { s.ng });
            dir = wi;
            stats.bounce += 1;
        }
    }

    /// Every strategy with s ≥ 1; returns the camera-side sum, splats t = 1.
    fn connect_all(
        &self,
        ctx: &SceneContext,
        sampler: &mut PixelSampler,
        film: &mut FilmTarget,
        scratch: &mut BdptScratch,
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
            if t - 1 <= self.max_depth as usize && self.allowed(1, t) {
                sum += self.connect_light_sample(ctx, t, [u_pick, u_x, u_y], film.camera, scratch, stats);
            }
            for s in 2..=n_light {
                if s + t - 2 > self.max_depth as usize || !self.allowed(s, t) {
                    continue;
                }
                sum += self.connect_vertices(ctx, s, t, film.camera, scratch, stats);
            }
        }
        sum
    }

    /// Light vertex `light[s-1]` connected to the camera and splatted.
    fn connect_to_camera(
        &self,
        ctx: &SceneContext,
        s: usize,
        film: &mut FilmTarget,
        scratch: &mut BdptScratch,
        stats: &mut RayStats,
    ) {
        let camera = film.camera;
        let y = scratch.light[s - 1];
        // Border pixels' filters reach outside the frame, where their camera samples go too.
        // The camera subpath's aperture point is a uniform lens sample independent of this
        // light subpath: connecting to it is the t = 1 strategy through a thin lens.
        let cam_p = scratch.cam[0].p;
        let Some((pos, cos_cam, dist)) = camera.project(y.p, cam_p, 0.5 * film.filter.width) else {
            return;
        };
        let w = (cam_p - y.p) / dist;
        // What the light vertex sends toward the camera (times the cosine at it).
        let f = match (y.kind, y.light) {
            (Kind::Light, Some(lp)) => {
                // A light seen directly: hidden lights stay hidden.
                let visible = match &ctx.scene.lights[lp.light as usize] {
                    Light::Area(a) => a.camera_visible,
                    Light::Sphere { camera_visible, .. } => *camera_visible,
                    _ => true,
                };
                if !visible {
                    return;
                }
                lights::emitted(ctx.scene, &lp, w) * y.abs_cos_geo(w)
            }
            _ => {
                let (Some(bsdf), Some(hit)) = (y.bsdf, y.hit) else { return };
                let (wo_l, wi_l) = (y.frame.to_local(y.wo), y.frame.to_local(w));
                if (wi_l.z > 0.0) != (w.dot(hit.ng) > 0.0) {
                    return;
                }
                bsdf.eval_adjoint(wo_l, wi_l) * wi_l.z.abs() * shading_correction(&hit, &y.frame, y.wo, w)
            }
        };
        if f == Rgb::ZERO {
            return;
        }
        let importance = 1.0 / (camera.pixel_area() * cos_cam * cos_cam * cos_cam);
        let mut c = y.beta * f * (importance / (dist * dist));
        if c == Rgb::ZERO {
            return;
        }
        stats.shadow += 1;
        let cam_vertex = scratch.cam[0];
        let tr = segment_transmittance(ctx, &y, &cam_vertex, media_leaving(ctx, &y, w));
        if tr == Rgb::ZERO {
            return;
        }
        c *= tr;
        // MIS: the path light[..s] + camera.
        let dens = &mut scratch.dens;
        self.fill_path(ctx, &scratch.cam[..1], &scratch.light, s, camera, dens);
        let k = s; // index of the camera vertex
        dens.connectible[s - 1] = true;
        // b[s-1]: the camera generating y.
        dens.b[s - 1] = y.area_density(camera.pdf_dir(cos_cam), cam_p);
        if s >= 2
            && let Some(bsdf) = y.bsdf
        {
            let prev = &scratch.light[s - 2];
            let pdf = bsdf.pdf(y.frame.to_local(w), y.frame.to_local((prev.p - y.p).normalize_or_zero()));
            dens.b[s - 2] = prev.area_density(pdf, y.p);
        }
        dens.a[k] = 0.0; // unused (t = 0 is not a strategy)
        let wgt = self.mis(dens.weight(s));
        film.splats.add(film.filter, pos, c * wgt);
    }

    /// s = 1: light sampling at camera vertex `cam[t-1]`.
    fn connect_light_sample(
        &self,
        ctx: &SceneContext,
        t: usize,
        u: [f32; 3],
        camera: &CameraRays,
        scratch: &mut BdptScratch,
        stats: &mut RayStats,
    ) -> Rgb {
        let x = scratch.cam[t - 1];
        let (Some(bsdf), Some(hit)) = (x.bsdf, x.hit) else {
            return Rgb::ZERO;
        };
        if bsdf.is_delta() {
            return Rgb::ZERO;
        }
        let Some((index, pmf)) = self.lights.pick_any(u[0]) else {
            return Rgb::ZERO;
        };
        let wo_l = x.frame.to_local(x.wo);
        if !self.lights.finite(index) {
            // The world, a sun or a soft point light: light sampling as the path tracer
            // does, weighted against BSDF sampling only.
            let Some(ls) = ctx.sample_light(index, x.p, Vec2::new(u[1], u[2])) else {
                return Rgb::ZERO;
            };
            let wi_l = x.frame.to_local(ls.wi);
            let consistent = (wi_l.z > 0.0) == (ls.wi.dot(hit.ng) > 0.0);
            let f = bsdf.eval(wo_l, wi_l) * wi_l.z.abs();
            if f == Rgb::ZERO || ls.li == Rgb::ZERO || !consistent {
                return Rgb::ZERO;
            }
            stats.shadow += 1;
            let tr = super::media::light_transmittance(ctx, x.p, Some(hit.ng), &ls, media_leaving(ctx, &x, ls.wi));
            if tr == Rgb::ZERO {
                return Rgb::ZERO;
            }
            let p_light = pmf * ls.pdf;
            let w = if ls.delta { 1.0 } else { power_heuristic(p_light, bsdf.pdf(wo_l, wi_l)) };
            return x.beta * f * tr * ls.li * (self.mis(w) / p_light);
        }
        let Some(lp) = lights::sample_point(ctx.scene, index, Vec2::new(u[1], u[2])) else {
            return Rgb::ZERO;
        };
        let d = lp.p - x.p;
        let dist2 = d.length_squared();
        if !(dist2 > 0.0) {
            return Rgb::ZERO;
        }
        let dist = dist2.sqrt();
        let wi = d / dist;
        let le = lights::emitted(ctx.scene, &lp, -wi);
        if le == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let wi_l = x.frame.to_local(wi);
        if (wi_l.z > 0.0) != (wi.dot(hit.ng) > 0.0) {
            return Rgb::ZERO;
        }
        let f = bsdf.eval(wo_l, wi_l) * wi_l.z.abs();
        if f == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let mut y = Vertex::new(Kind::Light, lp.p);
        y.ng = lp.n;
        y.light = Some(lp);
        let cos_y = y.abs_cos_geo(wi);
        let g = cos_y / dist2;
        let contribution = x.beta * f * le * (g / (pmf * lp.pdf_pos));
        if contribution == Rgb::ZERO {
            return Rgb::ZERO;
        }
        stats.shadow += 1;
        let tr = segment_transmittance(ctx, &x, &y, media_leaving(ctx, &x, wi));
        if tr == Rgb::ZERO {
            return Rgb::ZERO;
        }
        // MIS with the light-origin density of light subpaths.
        y.pdf_fwd = self.lights.pmf_finite(index) * lp.pdf_pos;
        let dens = &mut scratch.dens;
        self.fill_path(ctx, &scratch.cam[..t], std::slice::from_ref(&y), 1, camera, dens);
        dens.connectible[0] = true;
        dens.connectible[1] = true;
        // b[0]: the camera vertex's BSDF generating the light point.
        dens.b[0] = y.area_density(bsdf.pdf(wo_l, wi_l), x.p);
        // a[1]: the light's emission generating x.
        dens.a[1] = x.area_density(lights::pdf_direction(ctx.scene, &lp, -wi), lp.p);
        if t >= 2 {
            let prev = &scratch.cam[t - 2];
            let pdf = if prev.kind == Kind::Camera {
                0.0 // a[k] is never used
            } else {
                bsdf.pdf(wi_l, x.frame.to_local((prev.p - x.p).normalize_or_zero()))
            };
            dens.a[2] = prev.area_density(pdf, x.p);
        }
        let w = self.mis(dens.weight(1));
        contribution * tr * w
    }

    /// s, t ≥ 2: light vertex `light[s-1]` joined to camera vertex `cam[t-1]`.
    fn connect_vertices(
        &self,
        ctx: &SceneContext,
        s: usize,
        t: usize,
        camera: &CameraRays,
        scratch: &mut BdptScratch,
        stats: &mut RayStats,
    ) -> Rgb {
        let x = scratch.cam[t - 1];
        let y = scratch.light[s - 1];
        let (Some(bx), Some(hx), Some(by), Some(hy)) = (x.bsdf, x.hit, y.bsdf, y.hit) else {
            return Rgb::ZERO;
        };
        if bx.is_delta() || by.is_delta() {
            return Rgb::ZERO;
        }
        let d = y.p - x.p;
        let dist2 = d.length_squared();
        if !(dist2 > 0.0) {
            return Rgb::ZERO;
        }
        let dist = dist2.sqrt();
        let w = d / dist; // from x toward y
        let (wo_x, wi_x) = (x.frame.to_local(x.wo), x.frame.to_local(w));
        let (wo_y, wi_y) = (y.frame.to_local(y.wo), y.frame.to_local(-w));
        if (wi_x.z > 0.0) != (w.dot(hx.ng) > 0.0) || (wi_y.z > 0.0) != ((-w).dot(hy.ng) > 0.0) {
            return Rgb::ZERO;
        }
        let fx = bx.eval(wo_x, wi_x) * wi_x.z.abs();
        let fy = by.eval_adjoint(wo_y, wi_y) * wi_y.z.abs() * shading_correction(&hy, &y.frame, y.wo, -w);
        let c = x.beta * fx * fy * y.beta / dist2;
        if c == Rgb::ZERO {
            return Rgb::ZERO;
        }
        stats.shadow += 1;
        let tr = segment_transmittance(ctx, &x, &y, media_leaving(ctx, &x, w));
        if tr == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let dens = &mut scratch.dens;
        self.fill_path(ctx, &scratch.cam[..t], &scratch.light, s, camera, dens);
        dens.connectible[s - 1] = true;
        dens.connectible[s] = true;
        // b[s-1]: x generating y; a[s]: y generating x.
        dens.b[s - 1] = y.area_density(bx.pdf(wo_x, wi_x), x.p);
        dens.a[s] = x.area_density(by.pdf(wo_y, wi_y), y.p);
        // b[s-2]: y generating its predecessor given x; a[s+1]: x generating its predecessor given y.
        let yp = &scratch.light[s - 2];
        dens.b[s - 2] = yp.area_density(by.pdf(wi_y, y.frame.to_local((yp.p - y.p).normalize_or_zero())), y.p);
        let xp = &scratch.cam[t - 2];
        dens.a[s + 1] = if xp.kind == Kind::Camera {
            0.0
        } else {
            xp.area_density(bx.pdf(wi_x, x.frame.to_local((xp.p - x.p).normalize_or_zero())), x.p)
        };
        let wgt = self.mis(dens.weight(s));
        c * tr * wgt
    }
}

/// Veach's correction for shading normals on light paths: |wo·ns| |wi·ng| / (|wo·ng| |wi·ns|),
/// with `wo` toward the light side and `wi` the direction importance leaves in.
#[inline]
fn shading_correction(s: &SurfaceHit, frame: &Frame, wo: Vec3, wi: Vec3) -> f32 {
    let num = wo.dot(frame.n).abs() * wi.dot(s.ng).abs();
    let den = wo.dot(s.ng).abs() * wi.dot(frame.n).abs();
    if den > 0.0 && num.is_finite() { (num / den).min(10.0) } else { 0.0 }
}
