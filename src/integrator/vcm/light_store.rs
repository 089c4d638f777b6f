//! The light pass's subpaths kept for the camera pass's connections, so that each light
//! subpath is traced once per iteration (for the grid and for its pixel's connections).
//!
//! A BDPT vertex is most of a kilobyte, nearly all of it the BSDF (`size_of::<Bsdf>()`);
//! stored for every pixel that would be gigabytes at full HD. A stored vertex keeps
//! everything but the BSDF and the shading frame, which the camera pass rebuilds by
//! shading the stored hit again from the stored direction: shading is a pure function of
//! the hit, the direction and the sample's time (which the light and camera passes share),
//! so the rebuilt vertex is the traced one bit for bit, at the cost of a shading call
//! instead of a ray and a shading call.

use crate::integrator::SceneContext;
use crate::integrator::bdpt::vertex::{Kind, Vertex};
use crate::light::origin::LightPoint;
use crate::math::Rgb;
use crate::medium::MediumStack;
use crate::scene::shading::SurfaceHit;
use glam::Vec3;

/// A light subpath vertex without its BSDF and shading frame (see the module's doc).
#[derive(Clone, Copy, Debug)]
pub(crate) struct StoredVertex {
    kind: Kind,
    p: Vec3,
    ng: Vec3,
    hit: Option<SurfaceHit>,
    wo: Vec3,
    beta: Rgb,
    pdf_fwd: f32,
    pdf_rev: f32,
    delta: bool,
    /// At a contact (`bdpt::contact`): the connections' trap weight and the MIS read it.
    contact: bool,
    medium: MediumStack,
    light: Option<LightPoint>,
    /// The bounces its light subpath counted before it (`bdpt::bounces`).
    classes: crate::integrator::bdpt::bounces::Classes,
}

/// One light subpath per pixel of a row, in one flat array reused across iterations.
#[derive(Debug, Default)]
pub(crate) struct RowSubpaths {
    /// Every subpath's vertices, pixel after pixel.
    verts: Vec<StoredVertex>,
    /// Pixel i's subpath is `verts[starts[i]..starts[i + 1]]`.
    starts: Vec<u32>,
}

impl RowSubpaths {
    /// Forgets the previous iteration's subpaths (keeping the memory).
    pub(crate) fn clear(&mut self) {
        self.verts.clear();
        self.starts.clear();
        self.starts.push(0);
    }

    /// Appends the next pixel's subpath.
    pub(crate) fn push(&mut self, light: &[Vertex]) {
        self.verts.extend(light.iter().map(|v| {
            // Only surfaces have a BSDF, and every surface vertex has one: the rebuilt
            // vertex takes it from shading `hit`.
            debug_assert_eq!(v.bsdf.is_some(), v.hit.is_some());
            StoredVertex {
                kind: v.kind,
                p: v.p,
                ng: v.ng,
                hit: v.hit,
                wo: v.wo,
                beta: v.beta,
                pdf_fwd: v.pdf_fwd,
                pdf_rev: v.pdf_rev,
                delta: v.delta,
                contact: v.contact,
                medium: v.medium,
                light: v.light,
                classes: v.classes,
            }
        }));
        self.starts.push(self.verts.len() as u32);
    }

    /// Rebuilds pixel `i`'s subpath (i counted from the row's first pixel) into `out`,
    /// as `BdptIntegrator::light_subpath` left it.
    pub(crate) fn restore(&self, ctx: &SceneContext, i: usize, out: &mut Vec<Vertex>) {
        out.clear();
        let (a, b) = (self.starts[i] as usize, self.starts[i + 1] as usize);
        out.extend(self.verts[a..b].iter().map(|s| {
            let mut v = match s.hit {
                Some(hit) => Vertex::surface(&hit, &ctx.shade(&hit, s.wo), s.wo, s.beta, s.medium),
                None => Vertex::new(s.kind, s.p),
            };
            v.kind = s.kind;
            v.p = s.p;
            v.ng = s.ng;
            v.wo = s.wo;
            v.beta = s.beta;
            v.pdf_fwd = s.pdf_fwd;
            v.pdf_rev = s.pdf_rev;
            v.delta = s.delta;
            v.contact = s.contact;
            v.medium = s.medium;
            v.light = s.light;
            v.classes = s.classes;
            v
        }));
    }
}

/// Bytes one stored vertex takes (for the memory budget).
pub const VERTEX_BYTES: u64 = std::mem::size_of::<StoredVertex>() as u64;
