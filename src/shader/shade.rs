//! The shading point of a material with a node graph: the program evaluated at the hit,
//! its closures turned into one BSDF, the shading frame and the emission; and the
//! graph's transparency for `Scene::alpha`, and its colour for the pass-through and shadow
//! rays (`Scene::pass_through`, `Scene::transmission`).

use super::closure::Closures;
use super::geom::{Geom, NO_OBJECT, ObjectData, Rays, SceneRays, ViewData, geom_at};
use super::instructions::Program;
use super::program::with_registers;
use crate::bsdf::{Bsdf, PbrBsdf};
use crate::math::{Frame, Rgb};
use crate::scene::Scene;
use crate::scene::bent_normal::valid_reflection_normal;
use crate::scene::hit::{ShadingPoint, SurfaceHit};
use crate::scene::light_path::LightPath;
use crate::scene::mesh::Mesh;
use crate::scene::texture::Texture;
use glam::Vec3;

impl Scene {
    /// The instance data of a triangle, or of a point's point cloud.
    #[inline]
    pub fn object_of(&self, tri: u32) -> &ObjectData {
        if crate::points::is_point(tri) && !self.points.objects.is_empty() {
            let (o, _) = self.points.object_of_prim(tri);
            return match self.points.objects[o].object {
                Some(k) => self.objects.get(k as usize).unwrap_or(&NO_OBJECT),
                None => &NO_OBJECT,
            };
        }
        match self.mesh.tri_object.get(tri as usize) {
            Some(&o) => self.objects.get(o as usize).unwrap_or(&NO_OBJECT),
            None => &NO_OBJECT,
        }
    }
}

/// The shading point of hit `s` seen from `wo`, as a program reads it.
pub(super) fn geom_of<'a>(scene: &'a Scene, s: &SurfaceHit, wo: Vec3) -> Geom<'a> {
    Geom {
        p: s.p,
        n: s.ns,
        ng: s.ng,
        wo,
        uv: s.uv,
        color: s.color,
        tangent: s.tangent,
        backfacing: !s.front,
        object: scene.object_of(s.tri),
        textures: &scene.textures,
        mesh: &scene.mesh,
        tri: s.tri,
        bary: s.bary,
        path: s.light_path,
        view: &scene.view,
        rays: Rays::default(),
        point: crate::points::is_point(s.tri).then(|| scene.points.info(s.tri)),
        grid_values: None,
    }
}

/// [`geom_of`] with the scene's rays `rays` for a program that traces (`Program::traces`).
pub(super) fn traced_geom_of<'a>(
    scene: &'a Scene,
    prog: &Program,
    s: &SurfaceHit,
    wo: Vec3,
    rays: Option<&'a dyn SceneRays>,
) -> Geom<'a> {
    let mut g = geom_of(scene, s, wo);
    if prog.traces {
        g.rays = Rays { query: rays, seed: super::trace::seed_of(s.p, wo, s.light_path.depth) };
    }
    g
}

/// Runs `prog` at the hit `s` seen from `wo`, tracing its AO and Bevel nodes with `rays`.
fn evaluate(scene: &Scene, prog: &Program, s: &SurfaceHit, wo: Vec3, rays: Option<&dyn SceneRays>) -> Closures {
    let g = traced_geom_of(scene, prog, s, wo, rays);
    let mut out = Closures::default();
    with_registers(|regs| {
        prog.run(&g, regs, &mut out);
        if out.normal.is_none()
            && let Some(n) = prog.displacement_normal
        {
            let n = n as usize;
            out.normal = Some(Vec3::new(regs[n], regs[n + 1], regs[n + 2]));
        }
    });
    out
}

/// The shading point of a node material (`Scene::shade` calls this when the material
/// has a program); `rays`: the scene's rays for its AO and Bevel nodes.
pub fn shade_nodes(
    scene: &Scene,
    prog: &Program,
    s: &SurfaceHit,
    wo: Vec3,
    double_sided: bool,
    rays: Option<&dyn SceneRays>,
) -> ShadingPoint {
    let c = evaluate(scene, prog, s, wo, rays);
    // The Transparent part is taken by coverage (Scene::alpha) before the surface is
    // shaded: what is shaded here is the rest, renormalised.
    let t = pass_fraction(c.transparent);
    let keep = if t > 0.0 && t < 1.0 { 1.0 / (1.0 - t) } else { 1.0 };
    // Shading normal: the closures' linked normal, else the interpolated one, on the
    // viewer's side and bent toward the viewer as the glTF path does.
    let mut n = match c.normal_world() {
        Some(m) => {
            if m.dot(s.ng) < 0.0 {
                -m
            } else {
                m
            }
        }
        None => s.ns,
    };
    // Cycles keeps a Principled BSDF's reflection valid by bending its specular normal
    // towards the geometric one (`maybe_ensure_valid_specular_reflection`), while its diffuse
    // closure keeps the unbent normal and is shadowed by the bump terminator term against the
    // interpolated normal. Without the bend, a steeply bumped normal sends the specular lobe
    // below the surface, where it is lost (a valley 3-5 % darker than Cycles). Only a graph
    // whose closures are all Principled gets this: the other closures share the frame and
    // would turn with it (their Diffuse BSDFs must not).
    let principled_only = c.pbr_w > 0.0 && c.mix.n == 0;
    let unbent = n;
    if principled_only {
        n = valid_reflection_normal(s.ng, wo, n);
    } else {
        let cos_o = n.dot(wo);
        if cos_o < 1e-3 {
            n = (n + wo * (1e-3 - cos_o)).normalize_or(s.ng);
            if n.dot(wo) <= 0.0 {
                n = s.ng;
            }
        }
    }
    // An anisotropic Principled BSDF's widths lie along its tangent: the frame's X axis.
    let frame = match c.tangent_world() {
        Some(t) => Frame::from_normal_tangent(n, t),
        None => Frame::from_normal(n),
    };
    // The mixture is copied out of the closures only where it becomes the BSDF (callgrind:
    // a copy of ~80 instructions a shading point that a lone Principled BSDF threw away).
    let scaled = |c: &Closures| {
        let mut mix = c.mix;
        mix.scale(keep);
        mix
    };
    let bsdf = if c.pbr_w > 0.0 {
        let mut params = c.principled_params(!s.front);
        params.coat_normal = c.coat_normal_world().map(|m| frame.to_local(if m.dot(s.ng) < 0.0 { -m } else { m }));
        if principled_only {
            params.diffuse_normal = (n != unbent).then(|| frame.to_local(unbent));
            params.smooth_normal = (unbent != s.ns).then(|| frame.to_local(s.ns));
        }
        let pbr = PbrBsdf::from_params(&params);
        let w = c.pbr_w * keep;
        if c.mix.n == 0 && (w - 1.0).abs() < 1e-6 {
            // A lone Principled BSDF is the glTF material: the same code path.
            Bsdf::Pbr(pbr)
        } else {
            let mut mix = scaled(&c);
            mix.pbr = pbr;
            mix.pbr_weight = w;
            Bsdf::Mix(mix)
        }
    } else {
        Bsdf::Mix(scaled(&c))
    };
    let emitted = if s.front || double_sided { c.emission * keep } else { Rgb::ZERO };
    ShadingPoint { bsdf, frame, emitted, holdout: c.holdout * keep }
}

/// The probability that a path passes a surface whose Transparent weight is `t`: the mean of
/// its channels, each in [0, 1] (for grey weights the same number as clamping the mean).
#[inline]
fn pass_fraction(t: Rgb) -> f32 {
    let t = t.clamp(Rgb::ZERO, Rgb::ONE);
    (t.x + t.y + t.z) / 3.0
}

/// The graph's Transparent weight at barycentrics, for a ray of state `path` (its length
/// measured from `org` when given).
fn node_transparent(
    scene: &Scene,
    prog: &Program,
    tri: u32,
    b1: f32,
    b2: f32,
    path: LightPath,
    org: Option<Vec3>,
) -> Rgb {
    let mut g = geom_at(&scene.mesh, &scene.objects, &scene.textures, tri, b1, b2);
    g.view = &scene.view;
    g.path = org.map_or(path, |o| path.at((g.p - o).length()));
    let mut out = Closures::default();
    with_registers(|regs| prog.run(&g, regs, &mut out));
    out.transparent
}

/// The graph's opacity at barycentrics (1 − the mean of its Transparent weight) for a ray
/// of state `path` (from `org`, when its length is not in `path`).
pub fn node_alpha(
    scene: &Scene,
    prog: &Program,
    tri: u32,
    b1: f32,
    b2: f32,
    path: LightPath,
    org: Option<Vec3>,
) -> f32 {
    1.0 - pass_fraction(node_transparent(scene, prog, tri, b1, b2, path, org))
}

/// The emission of a node material at barycentrics, seen along the normal, for the render
/// camera `view` and a Light Path node reading `path`.
#[allow(clippy::too_many_arguments)]
pub fn node_emission(
    mesh: &Mesh,
    objects: &[ObjectData],
    textures: &[Texture],
    view: &ViewData,
    prog: &Program,
    tri: u32,
    b1: f32,
    b2: f32,
    path: LightPath,
) -> Rgb {
    if let Some(e) = prog.constant_emission {
        return e;
    }
    let mut g = geom_at(mesh, objects, textures, tri, b1, b2);
    g.view = view;
    g.path = path;
    let mut out = Closures::default();
    with_registers(|regs| prog.run(&g, regs, &mut out));
    out.emission.max(Vec3::ZERO)
}

impl Scene {
    /// A BLEND surface's stochastic pass-through at barycentrics: its alpha (a path passes
    /// with probability 1 − alpha) and the throughput weight of passing, transmission /
    /// (1 − alpha): 1 unless a node graph's Transparent colour is tinted, whose expected
    /// weight is then that colour (Cycles' transparent bounce carries the closure's colour).
    /// `path`: the ray that reached the surface (the Light Path node).
    #[inline]
    pub fn pass_through(&self, tri: u32, b1: f32, b2: f32, path: LightPath) -> (f32, Rgb) {
        let mat = &self.materials[self.mesh.tri_material[tri as usize] as usize];
        match &mat.nodes {
            Some(prog) if prog.tinted_transparency => {
                let t = node_transparent(self, prog, tri, b1, b2, path, None);
                let p = pass_fraction(t);
                let tint = if p > 0.0 { t.clamp(Rgb::ZERO, Rgb::ONE) / p } else { Rgb::ONE };
                (1.0 - p, tint)
            }
            Some(prog) => (node_alpha(self, prog, tri, b1, b2, path, None), Rgb::ONE),
            None => (self.alpha(tri, b1, b2), Rgb::ONE),
        }
    }

    /// What a BLEND surface lets through at barycentrics per channel, for shadow rays:
    /// 1 − alpha, or a tinted node graph's Transparent colour (each channel in [0, 1]).
    /// `path`: the shadow ray's state with its length to the surface.
    #[inline]
    pub fn transmission(&self, tri: u32, b1: f32, b2: f32, path: LightPath) -> Rgb {
        let mat = &self.materials[self.mesh.tri_material[tri as usize] as usize];
        match &mat.nodes {
            Some(prog) if prog.tinted_transparency => {
                node_transparent(self, prog, tri, b1, b2, path, None).clamp(Rgb::ZERO, Rgb::ONE)
            }
            Some(prog) => Rgb::splat((1.0 - node_alpha(self, prog, tri, b1, b2, path, None)).clamp(0.0, 1.0)),
            None => Rgb::splat((1.0 - self.alpha(tri, b1, b2)).clamp(0.0, 1.0)),
        }
    }

    /// Alpha of a triangle's material at barycentrics as a shadow ray of state `path` from
    /// `org` sees it (a node graph may read the Light Path node; other materials do not).
    #[inline]
    pub fn shadow_alpha(&self, tri: u32, b1: f32, b2: f32, path: LightPath, org: Vec3) -> f32 {
        let mat = &self.materials[self.mesh.tri_material[tri as usize] as usize];
        match &mat.nodes {
            Some(prog) => node_alpha(self, prog, tri, b1, b2, path, Some(org)),
            None => self.alpha(tri, b1, b2),
        }
    }

    /// Emitted radiance of triangle `tri` at barycentrics (toward its front): the node
    /// graph's emission, or the glTF material's. For the light routines.
    #[inline]
    pub fn emission_at(&self, tri: u32, b1: f32, b2: f32) -> Rgb {
        self.emission_for(tri, b1, b2, LightPath::LIGHT_EMISSION)
    }

    /// [`emission_at`](Self::emission_at) with the Light Path node reading `path`.
    #[inline]
    pub fn emission_for(&self, tri: u32, b1: f32, b2: f32, path: LightPath) -> Rgb {
        let mat = &self.materials[self.mesh.tri_material[tri as usize] as usize];
        match &mat.nodes {
            Some(prog) => node_emission(&self.mesh, &self.objects, &self.textures, &self.view, prog, tri, b1, b2, path),
            // Neither a texture nor the vertex colour (unlit) enters: the factor itself,
            // without interpolating the attributes (every light sample asks, callgrind).
            None if mat.emissive_tex.is_none() && !mat.unlit => mat.emissive,
            None => {
                let (uv, color) = self.attributes(tri, b1, b2);
                mat.emission(&self.textures, uv, color)
            }
        }
    }
}
