//! Subpath vertices and the segments between them: kinds, densities, media, and
//! Veach's shading-normal correction.

use super::*;
use crate::bsdf::{BsdfAt, BsdfView};
use crate::scene::visibility::RayMask;

/// What a vertex is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    Camera,
    /// The first vertex of a light subpath (or a light point connected to).
    Light,
    /// The first vertex of a light subpath from a light at infinity (the world, a sun), or
    /// such a light found or sampled from the camera side: `p` is the unit direction
    /// toward the light, densities toward it are solid-angle densities.
    Infinite,
    Surface,
}

/// A vertex of a subpath.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Vertex {
    pub(crate) kind: Kind,
    pub(crate) p: Vec3,
    /// Geometric normal (surfaces: on the side the subpath arrived from; lights: the
    /// emitting side; zero for points and the camera).
    pub(crate) ng: Vec3,
    /// Shading frame and BSDF of surfaces.
    pub(crate) frame: Frame,
    pub(crate) bsdf: Option<Bsdf>,
    /// Surfaces: the BSDF seen from `wo` (`Bsdf::bind`), which its sampled bounce and every
    /// connection from it read.
    pub(crate) view: BsdfView,
    /// Surfaces: every lobe of its BSDF is a delta lobe, so no connection leaves it (asked
    /// once per connection, so kept).
    pub(crate) specular: bool,
    pub(crate) hit: Option<SurfaceHit>,
    /// Unit direction toward the previous vertex of its own subpath.
    pub(crate) wo: Vec3,
    /// Throughput up to this vertex divided by the densities (subpath measure).
    pub(crate) beta: Rgb,
    /// Area density of this vertex from its own subpath's side.
    pub(crate) pdf_fwd: f32,
    /// Area density of this vertex from the other side (set when the next vertex is sampled).
    pub(crate) pdf_rev: f32,
    /// Its outgoing direction was sampled from a delta lobe.
    pub(crate) delta: bool,
    /// The media the arriving segment crossed (absorbing only in this integrator).
    pub(crate) medium: MediumStack,
    /// Light vertices: the light point (index, emission, densities).
    pub(crate) light: Option<LightPoint>,
    /// Emission of a surface toward `wo` (emissive triangles).
    pub(crate) emitted: Rgb,
    /// Camera vertices: the camera subpath up to here (its segments and vertices) meets a
    /// restricted object (`visibility`), so only s = 0 and s = 1 make paths through it.
    pub(crate) restricted: bool,
    /// The surface is at a contact (`contact`: a glass resting on a floor).
    pub(crate) contact: bool,
    /// The bounces its own subpath counted before it (`bounces`: camera vertices from the
    /// first hit on, light vertices from the third, the light's neighbour never).
    pub(crate) classes: super::bounces::Classes,
    /// How its BSDF reflects (surfaces).
    pub(crate) reflection: super::bounces::Reflection,
    /// Camera vertices: the bounce limits drop every path that goes on from here.
    pub(crate) spent: bool,
}

impl Vertex {
    pub(crate) fn new(kind: Kind, p: Vec3) -> Self {
        Vertex {
            kind,
            p,
            ng: Vec3::ZERO,
            frame: Frame::from_normal(Vec3::Z),
            bsdf: None,
            view: BsdfView::Wo(Vec3::ZERO),
            specular: false,
            hit: None,
            wo: Vec3::ZERO,
            beta: Rgb::ONE,
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
            delta: false,
            medium: MediumStack::default(),
            light: None,
            emitted: Rgb::ZERO,
            restricted: false,
            contact: false,
            classes: Default::default(),
            reflection: Default::default(),
            spent: false,
        }
    }

    /// A surface vertex reached from direction `wo` with throughput `beta` through `medium`.
    pub(crate) fn surface(
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
            view: sp.bsdf.at(sp.frame.to_local(wo)).view(),
            specular: sp.bsdf.is_delta(),
            hit: Some(*s),
            wo,
            beta,
            medium,
            reflection: super::bounces::Reflection::of(&sp.bsdf),
            ..Vertex::new(Kind::Surface, s.p)
        }
    }

    /// Its BSDF seen from `wo`, and the BSDF (surfaces).
    #[inline]
    pub(crate) fn seen(&self) -> Option<(&Bsdf, BsdfAt<'_>)> {
        self.bsdf.as_ref().map(|b| (b, b.bind(&self.view)))
    }

    /// The class counts of a path through this surface vertex that goes on toward unit
    /// direction `w` from it: its own subpath's counts and its bounce between `wo` and `w`,
    /// a crossing when they lie on opposite sides of the surface.
    #[inline]
    pub(crate) fn classes_toward(&self, w: Vec3) -> super::bounces::Classes {
        self.classes.with_bounce(self.reflection, self.ng.dot(self.wo) * self.ng.dot(w) < 0.0)
    }

    /// |cos| between the vertex's normal and `w` (1 for points and the camera).
    #[inline]
    pub(crate) fn abs_cos_geo(&self, w: Vec3) -> f32 {
        if self.ng == Vec3::ZERO { 1.0 } else { self.ng.dot(w).abs() }
    }

    /// Converts a solid-angle density at `from` toward this vertex into an area density here
    /// (a vertex at infinity keeps the solid-angle density: its measure is directions).
    #[inline]
    pub(crate) fn area_density(&self, pdf_sa: f32, from: Vec3) -> f32 {
        if self.kind == Kind::Infinite {
            return pdf_sa;
        }
        let d = self.p - from;
        let d2 = d.length_squared();
        if !(d2 > 0.0) {
            return 0.0;
        }
        pdf_sa * self.abs_cos_geo(d / d2.sqrt()) / d2
    }

    /// Unit direction from point `from` toward this vertex.
    #[inline]
    pub(crate) fn dir_from(&self, from: Vec3) -> Vec3 {
        if self.kind == Kind::Infinite { self.p } else { (self.p - from).normalize_or_zero() }
    }

    /// Area density of this vertex as the first hit of a light subpath from a light at
    /// infinity in direction `to_light` (`disk_pdf`: the disk's area density): the disk
    /// projected along the direction, |cos| at this vertex.
    #[inline]
    pub(crate) fn density_from_infinity(&self, to_light: Vec3, disk_pdf: f32) -> f32 {
        disk_pdf * self.abs_cos_geo(to_light)
    }
}

/// Fraction of light carried from vertex `a` to vertex `b` through the media `stack` the
/// segment starts in: volume-only boundaries are crossed (changing the medium), BLEND
/// surfaces pass 1 - alpha, media attenuate by their extinction (light subpaths and
/// connections carry the paths without a medium vertex; those with one are path traced
/// from the camera side), any other surface blocks.
#[inline]
pub(crate) fn segment_transmittance(ctx: &SceneContext, a: &Vertex, b: &Vertex, stack: MediumStack) -> Rgb {
    segment_transmittance_of(ctx, a, b, stack, None)
}

/// [`segment_transmittance`] of a segment to a point of light `light` (shadow linking:
/// only its blockers stop it; Cast Shadow off: nothing does, as next-event estimation's
/// skipped shadow ray).
#[inline]
pub(crate) fn segment_transmittance_of(
    ctx: &SceneContext,
    a: &Vertex,
    b: &Vertex,
    stack: MediumStack,
    light: Option<usize>,
) -> Rgb {
    if light.is_some_and(|l| !ctx.casts_shadow(l)) {
        return Rgb::ONE;
    }
    segment_transmittance_as(ctx, a, b, stack, light, RayMask::SHADOW)
}

/// [`segment_transmittance_of`] along a segment that rays of kind `ray` trace in camera
/// order (objects hidden from that kind are passed): the shadow rays of connections, or the
/// camera ray of light tracing (t = 1).
#[inline]
pub(crate) fn segment_transmittance_as(
    ctx: &SceneContext,
    a: &Vertex,
    b: &Vertex,
    stack: MediumStack,
    light: Option<usize>,
    ray: RayMask,
) -> Rgb {
    segment_transmittance_to(ctx, a, b.p, b.ng, stack, light, ray)
}

/// [`segment_transmittance_as`] toward the point `b` of geometric normal `b_ng` (zero for
/// none): light tracing's segment ends on the near clipping plane, not at a vertex.
#[inline]
pub(crate) fn segment_transmittance_to(
    ctx: &SceneContext,
    a: &Vertex,
    b: Vec3,
    b_ng: Vec3,
    stack: MediumStack,
    light: Option<usize>,
    ray: RayMask,
) -> Rgb {
    let d = b - a.p;
    let dist = d.length();
    if !(dist > 0.0) {
        return Rgb::ZERO;
    }
    let wi = d / dist;
    // The target's normal on the side facing `a` (the shadow ray stops just short of it).
    let normal = if b_ng == Vec3::ZERO {
        Vec3::ZERO
    } else if b_ng.dot(wi) <= 0.0 {
        b_ng
    } else {
        -b_ng
    };
    let target = LightSample { wi, dist, li: Rgb::ZERO, pdf: 0.0, delta: false, point: b, normal };
    let ng = (a.ng != Vec3::ZERO).then_some(a.ng);
    crate::integrator::media::light_transmittance_as(
        ctx,
        a.p,
        ng,
        &target,
        stack,
        light,
        crate::scene::light_path::LightPath::SHADOW_RAY,
        ray,
    )
}

/// The media a segment leaving vertex `v` in direction `w` is in.
#[inline]
pub(crate) fn media_leaving(ctx: &SceneContext, v: &Vertex, w: Vec3) -> MediumStack {
    match v.hit {
        Some(h) => ctx.medium_after(&h, w, v.medium),
        None => v.medium,
    }
}

/// Veach's correction for shading normals on light paths: |wo·ns| |wi·ng| / (|wo·ng| |wi·ns|),
/// with `wo` toward the light side and `wi` the direction importance leaves in.
#[inline]
pub(crate) fn shading_correction(s: &SurfaceHit, frame: &Frame, wo: Vec3, wi: Vec3) -> f32 {
    let num = wo.dot(frame.n).abs() * wi.dot(s.ng).abs();
    let den = wo.dot(s.ng).abs() * wi.dot(frame.n).abs();
    if den > 0.0 && num.is_finite() { (num / den).min(10.0) } else { 0.0 }
}
