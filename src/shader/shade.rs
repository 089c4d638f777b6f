//! The shading point of a material with a node graph: the program evaluated at the hit,
//! its closures turned into one BSDF, the shading frame and the emission; and the
//! graph's transparency for `Scene::alpha`, and its colour for the pass-through and shadow
//! rays (`Scene::pass_through`, `Scene::transmission`).

use super::closure::{Closures, empty_mix};
use super::geom::{Geom, NO_OBJECT, ObjectData, Rays, SceneRays, ViewData, geom_at};
use super::instructions::Program;
use super::mesh_hair;
use super::program::with_registers;
use crate::bsdf::mix::{Lobe, MAX_PBR, MixBsdf};
use crate::bsdf::pbr::bump_alpha2;
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
        curve: None,
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
    if prog.reads_curves_info && crate::curves::is_curve(s.tri) {
        g.curve = Some(scene.curves.info(s, wo));
    }
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
        if let Some(n) = prog.displacement_normal {
            let n = n as usize;
            let n = Vec3::new(regs[n], regs[n + 1], regs[n + 2]);
            out.default_normal = Some(n);
            out.normal = out.normal.or(Some(n));
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
    rays: Option<&dyn SceneRays>,
) -> ShadingPoint {
    let c = evaluate(scene, prog, s, wo, rays);
    // The Transparent part is taken by coverage (Scene::alpha) before the surface is
    // shaded: what is shaded here is the rest, renormalised.
    let t = pass_fraction(c.transparent);
    let mut keep = if t > 0.0 && t < 1.0 { 1.0 / (1.0 - t) } else { 1.0 };
    // Both faces emit, as Cycles' Emission closure (see `Material::emissive`).
    let emitted = c.emission * keep;
    let holdout = c.holdout * keep;
    if c.has_hair() {
        if crate::curves::is_curve(s.tri) {
            return crate::curves::shade::hair_closures(&c, s, wo, keep, emitted);
        }
        if !crate::points::is_point(s.tri) {
            // A triangle shades its hair closures as Cycles does; mixed with others, either
            // these or those at each point, by weight (`mesh_hair::hair_share`).
            let share = mesh_hair::hair_share(&c);
            if share >= 1.0 || mesh_hair::choice_u(s) < share {
                return mesh_hair::hair_on_triangle(scene, &c, s, wo, keep / share, emitted, holdout);
            }
            keep /= 1.0 - share;
        }
    }
    // Shading normal: the closures' first linked normal, else the interpolated one, on the
    // viewer's side and bent toward the viewer as the glTF path does. In a mixture it is only
    // the frame the integrators see: each closure has its own normal within it.
    let facing = |m: Vec3| viewer_side(s, m);
    let principled_only = c.pbr_w[0] > 0.0 && c.pbr_w[1] <= 0.0 && c.mix.n == 0;
    // A mixture's frame is the normal of closures without a Normal input (the interpolated
    // one, or the Material Output's bump): the integrators decide reflection against
    // transmission by it and the geometric normal, which a bumped closure's normal would
    // get wrong for the others (a smooth Diffuse mixed with a bumped Glossy lost the light
    // its own normal sees above the surface but the bumped one puts below: 6.5 % in red).
    let mut n = if principled_only { c.normal_world() } else { c.default_normal_world() }.map_or(s.ns, facing);
    // Cycles keeps a Principled BSDF's reflection valid by bending its specular normal
    // towards the geometric one (`maybe_ensure_valid_specular_reflection`), while its diffuse
    // closure keeps the unbent normal and is shadowed by the bump terminator term against the
    // interpolated normal. Without the bend, a steeply bumped normal sends the specular lobe
    // below the surface, where it is lost (a valley 3-5 % darker than Cycles). A lone
    // Principled BSDF is the glTF material, in the bent frame; a mixture's closures each
    // get Cycles' rule in their own frames (`mixture`).
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
    let bsdf;
    let frame;
    if principled_only {
        // An anisotropic Principled BSDF's widths lie along its tangent: the frame's X axis.
        frame = match c.tangents[0] {
            Some(t) => Frame::from_normal_tangent(n, t),
            None => Frame::from_normal(n),
        };
        let mut params = c.principled_params(0, !s.front);
        // The terminator's reference as in `mixture`: Cycles' sd->N.
        let reference = c.default_normal_world().map_or(s.ns, facing);
        params.coat_normal = coat_normal(&c, 0, s, wo, reference, &frame);
        params.diffuse_normal = (n != unbent).then(|| frame.to_local(unbent));
        params.smooth_normal = (unbent != reference).then(|| frame.to_local(reference));
        params.cut_normal = (n != reference).then(|| frame.to_local(reference));
        let pbr = PbrBsdf::from_params(&params);
        let w = c.pbr_w[0] * keep;
        bsdf = if (w - 1.0).abs() < 1e-6 {
            // A lone Principled BSDF is the glTF material: the same code path.
            Bsdf::Pbr(pbr)
        } else {
            let mut mix = empty_mix();
            mix.pbr[0] = pbr;
            mix.pbr_weights[0] = w;
            Bsdf::Mix(mix)
        };
    } else {
        frame = Frame::from_normal(n);
        bsdf = Bsdf::Mix(mixture(&c, s, wo, &frame, keep));
    }
    ShadingPoint { bsdf, frame, emitted, holdout }
}

/// A closure's Normal input `m` as Cycles uses it at hit `s`: on a front face as it is, even
/// below the surface (a normal map bent past the horizon: its diffuse closure then sees only
/// the light the bump terminator term lets through, its glossy ones are bent back by
/// `valid_reflection_normal`); on a back face turned to the viewer's side when it points away,
/// as Cycles' Normal Map and Bump nodes negate what they give there. Turning it on front faces
/// too lit a world-space normal map's below-horizon texels (a cube 1.04-1.08 of Cycles).
#[inline]
fn viewer_side(s: &SurfaceHit, m: Vec3) -> Vec3 {
    if !s.front && m.dot(s.ng) < 0.0 { -m } else { m }
}

/// Principled BSDF j's coat normal in `frame` as Cycles sets its coat closure up: the Coat Normal
/// input, else the geometry's Normal (`LINK_NORMAL`: sd->N, `reference`, not the Normal input's
/// map), bent to keep the mirror reflection above the surface
/// (`maybe_ensure_valid_specular_reflection`); None where that is the frame's own normal. An
/// unlinked Coat Normal on the Normal input's map made the coat over a moderate bump 0.9931 of
/// Cycles (4 blocks beyond 5 sigma), 0.9989 (none) on sd->N; over steep ridges the coat then needs
/// its own hemisphere below the frame's horizon (`PbrBsdf::coat_across`).
#[inline]
fn coat_normal(c: &Closures, j: usize, s: &SurfaceHit, wo: Vec3, reference: Vec3, frame: &Frame) -> Option<Vec3> {
    let m = c.coat_normal_world(j).map_or(reference, |m| viewer_side(s, m));
    let bent = valid_reflection_normal(s.ng, wo, m);
    (bent != frame.n).then(|| frame.to_local(bent))
}

/// `inner` (world axes) within `outer`: None where they are the same frame.
#[inline]
fn within(outer: &Frame, inner: Frame) -> Option<Frame> {
    if inner.n == outer.n && inner.s == outer.s {
        return None;
    }
    Some(Frame { s: outer.to_local(inner.s), t: outer.to_local(inner.t), n: outer.to_local(inner.n) })
}

/// The mixture of closures `c` at hit `s` seen from `wo`, each closure in its own frame
/// within `frame`, weights times `keep`, as Cycles sets each closure up: its Normal input
/// (else the interpolated normal, or the Material Output's bump) on the viewer's side;
/// microfacet closures (Glossy, Metallic, Glass, Refraction, each Principled BSDF's specular
/// lobes) and the Translucent BSDF on that normal bent to keep the mirror reflection above the
/// surface; the other closures on the unbent normal. Cycles' diffuse class (Diffuse, Sheen,
/// Toon Diffuse, Translucent, each Principled BSDF's diffuse base) is shadowed by the bump
/// terminator term where its normal is not the interpolated one, every other closure cut by it
/// (`MixBsdf::cut`, `PbrParams::cut_normal`).
fn mixture(c: &Closures, s: &SurfaceHit, wo: Vec3, frame: &Frame, keep: f32) -> MixBsdf {
    let facing = |m: Vec3| viewer_side(s, m);
    let default_n = c.default_normal_world().map_or(s.ns, facing);
    // The bump terminator's reference is Cycles' sd->N: the interpolated normal, or the
    // Material Output's bump, which Cycles writes into sd->N before the surface runs (a
    // displaced "Displacement and Bump" surface is not shadowed by its own bump: with the
    // interpolated normal as reference it came out 0.9635 of Cycles, 15 blocks off).
    let reference = default_n;
    let mut mix = empty_mix();
    mix.set_lobes(&c.mix);
    mix.scale(keep);
    mix.ns = frame.to_local(reference);
    for j in 0..MAX_PBR {
        if c.pbr_w[j] <= 0.0 {
            continue;
        }
        let m = c.pbr_normal_world(j).map_or(default_n, facing);
        let bent = valid_reflection_normal(s.ng, wo, m);
        let own = match c.tangents[j] {
            Some(t) => Frame::from_normal_tangent(bent, t),
            None => Frame::from_normal(bent),
        };
        let mut params = c.principled_params(j, !s.front);
        params.coat_normal = coat_normal(c, j, s, wo, reference, &own);
        params.diffuse_normal = (bent != m).then(|| own.to_local(m));
        params.smooth_normal = (m != reference).then(|| own.to_local(reference));
        params.cut_normal = (bent != reference).then(|| own.to_local(reference));
        mix.pbr[j] = PbrBsdf::from_params(&params);
        mix.pbr_weights[j] = c.pbr_w[j] * keep;
        mix.pbr_frames[j] = within(frame, own);
    }
    for k in 0..mix.n as usize {
        let m = c.lobe_normal_world(k).map_or(default_n, facing);
        let lobe = &mix.lobes[k];
        // Cycles bends the microfacet closures' normals and the Translucent BSDF's
        // (`maybe_ensure_valid_specular_reflection` in svm_node_closure_bsdf); a bumped
        // Translucent lit from behind on its unbent normal was 0.898 of Cycles.
        let bends =
            matches!(lobe, Lobe::Glossy { .. } | Lobe::AshikhminShirley(_) | Lobe::Dielectric(_) | Lobe::Translucent);
        let nk = if bends { valid_reflection_normal(s.ng, wo, m) } else { m };
        mix.frames[k] = match c.lobe_tangents[k] {
            Some(t) => within(frame, Frame::from_normal_tangent(nk, t)),
            None if nk != frame.n => within(frame, Frame::from_normal(nk)),
            None => None,
        };
        // The term reads the closure's own normal (sc->N), bent where Cycles bends it.
        if lobe.bump_shadowed() && nk != reference {
            mix.bump[k] = bump_alpha2(reference, nk).unwrap_or(0.0);
        }
        // Cycles cuts every closure's evaluation by its normal against sd->N, not only the
        // diffuse ones' (whose bump shadowing above holds the cut): a Glossy BSDF on a normal
        // past the horizon was 1.0070 of Cycles.
        mix.cut[k] = !lobe.bump_shadowed() && nk != reference;
    }
    mix
}

/// The probability that a path passes a surface whose Transparent weight is `t`: the mean of
/// its channels, each in [0, 1] (for grey weights the same number as clamping the mean).
#[inline]
fn pass_fraction(t: Rgb) -> f32 {
    let t = t.clamp(Rgb::ZERO, Rgb::ONE);
    (t.x + t.y + t.z) / 3.0
}

/// The graph's Transparent weight at barycentrics, for a ray of state `path` (its length
/// measured from `org` when given) travelling along `dir` when known: the graph then sees
/// the surface from the ray's side, as Cycles' shadow and transparent-bounce evaluation
/// does (Fresnel, Layer Weight, Incoming and Backfacing read it); unknown (light sampling's
/// coverage), along the normal.
#[allow(clippy::too_many_arguments)]
fn node_transparent(
    scene: &Scene,
    prog: &Program,
    tri: u32,
    b1: f32,
    b2: f32,
    path: LightPath,
    org: Option<Vec3>,
    dir: Option<Vec3>,
) -> Rgb {
    let mut g = geom_at(&scene.mesh, &scene.objects, &scene.textures, tri, b1, b2);
    g.view = &scene.view;
    g.path = org.map_or(path, |o| path.at((g.p - o).length()));
    if let Some(d) = dir {
        // As `geom_of` for a shaded hit: normals on the side the ray came from.
        g.wo = -d.normalize_or(-g.n);
        if g.ng.dot(g.wo) < 0.0 {
            g.backfacing = true;
            g.ng = -g.ng;
            g.n = -g.n;
        }
    }
    let mut out = Closures::default();
    with_registers(|regs| prog.run(&g, regs, &mut out));
    out.transparent
}

/// The graph's opacity at barycentrics (1 − the mean of its Transparent weight) for a ray
/// of state `path` (from `org`, when its length is not in `path`) along `dir` when known.
#[allow(clippy::too_many_arguments)]
pub fn node_alpha(
    scene: &Scene,
    prog: &Program,
    tri: u32,
    b1: f32,
    b2: f32,
    path: LightPath,
    org: Option<Vec3>,
    dir: Option<Vec3>,
) -> f32 {
    1.0 - pass_fraction(node_transparent(scene, prog, tri, b1, b2, path, org, dir))
}

/// The emission of a node material at barycentrics toward `wo` (unit, from the surface; None:
/// along the normal, for estimates of its power), for the render camera `view` and a Light
/// Path node reading `path`. Seen from behind, the program reads the back face as a ray that
/// hits it does (Backfacing 1, normals flipped), so a graph that emits by Backfacing, Fresnel
/// or Layer Weight gives light sampling, light subpaths and photons what rays find there,
/// as Cycles' `shader_setup_from_sample` does.
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
    wo: Option<Vec3>,
) -> Rgb {
    if let Some(e) = prog.constant_emission {
        return e;
    }
    let mut g = geom_at(mesh, objects, textures, tri, b1, b2);
    g.view = view;
    g.path = path;
    if let Some(w) = wo {
        g.wo = w;
        if g.ng.dot(w) < 0.0 {
            g.backfacing = true;
            g.ng = -g.ng;
            g.n = -g.n;
        }
    }
    let mut out = Closures::default();
    with_registers(|regs| prog.run(&g, regs, &mut out));
    // Negative too, as Cycles evaluates it for light sampling: what a ray finds and what
    // next-event estimation finds must agree under MIS. Powers and paths started at lights,
    // which cannot carry negative light, clamp it themselves.
    out.emission
}

impl Scene {
    /// A BLEND surface's stochastic pass-through at barycentrics: its alpha (a path passes
    /// with probability 1 − alpha) and the throughput weight of passing, transmission /
    /// (1 − alpha): 1 unless a node graph's Transparent colour is tinted, whose expected
    /// weight is then that colour (Cycles' transparent bounce carries the closure's colour).
    /// `path`: the ray that reached the surface (the Light Path node), along `dir`.
    #[inline]
    pub fn pass_through(&self, tri: u32, b1: f32, b2: f32, path: LightPath, dir: Vec3) -> (f32, Rgb) {
        let mat = &self.materials[self.mesh.tri_material[tri as usize] as usize];
        match &mat.nodes {
            Some(prog) if prog.tinted_transparency => {
                let t = node_transparent(self, prog, tri, b1, b2, path, None, Some(dir));
                let p = pass_fraction(t);
                let tint = if p > 0.0 { t.clamp(Rgb::ZERO, Rgb::ONE) / p } else { Rgb::ONE };
                (1.0 - p, tint)
            }
            Some(prog) => (node_alpha(self, prog, tri, b1, b2, path, None, Some(dir)), Rgb::ONE),
            None => (self.alpha(tri, b1, b2), Rgb::ONE),
        }
    }

    /// What a BLEND surface lets through at barycentrics per channel, for shadow rays:
    /// 1 − alpha, or a tinted node graph's Transparent colour (each channel in [0, 1]).
    /// `path`: the shadow ray's state with its length to the surface, along `dir`.
    #[inline]
    pub fn transmission(&self, tri: u32, b1: f32, b2: f32, path: LightPath, dir: Vec3) -> Rgb {
        let mat = &self.materials[self.mesh.tri_material[tri as usize] as usize];
        match &mat.nodes {
            Some(prog) if prog.tinted_transparency => {
                node_transparent(self, prog, tri, b1, b2, path, None, Some(dir)).clamp(Rgb::ZERO, Rgb::ONE)
            }
            Some(prog) => {
                Rgb::splat((1.0 - node_alpha(self, prog, tri, b1, b2, path, None, Some(dir))).clamp(0.0, 1.0))
            }
            None => Rgb::splat((1.0 - self.alpha(tri, b1, b2)).clamp(0.0, 1.0)),
        }
    }

    /// Alpha of a triangle's material at barycentrics as a shadow ray of state `path` from
    /// `org` along `dir` sees it (a node graph may read the Light Path node and the ray's
    /// direction; other materials do not).
    #[inline]
    pub fn shadow_alpha(&self, tri: u32, b1: f32, b2: f32, path: LightPath, org: Vec3, dir: Vec3) -> f32 {
        let mat = &self.materials[self.mesh.tri_material[tri as usize] as usize];
        match &mat.nodes {
            Some(prog) => node_alpha(self, prog, tri, b1, b2, path, Some(org), Some(dir)),
            None => self.alpha(tri, b1, b2),
        }
    }

    /// Emitted radiance of triangle `tri` at barycentrics along its normal: the node graph's
    /// emission, or the glTF material's. For estimates of an emitter's power.
    #[inline]
    pub fn emission_at(&self, tri: u32, b1: f32, b2: f32) -> Rgb {
        self.emission_for(tri, b1, b2, LightPath::LIGHT_EMISSION, None)
    }

    /// Whether triangle `tri`'s emission is a node graph's that is not constant (so it may
    /// depend on the direction it is seen from).
    #[inline]
    pub fn emission_is_graph(&self, tri: u32) -> bool {
        let mat = &self.materials[self.mesh.tri_material[tri as usize] as usize];
        mat.nodes.as_ref().is_some_and(|p| p.constant_emission.is_none())
    }

    /// [`emission_at`](Self::emission_at) toward `wo` (unit, leaving the surface, on either
    /// side; None: along the normal) with the Light Path node reading `path`.
    #[inline]
    pub fn emission_for(&self, tri: u32, b1: f32, b2: f32, path: LightPath, wo: Option<Vec3>) -> Rgb {
        let mat = &self.materials[self.mesh.tri_material[tri as usize] as usize];
        match &mat.nodes {
            Some(prog) => {
                node_emission(&self.mesh, &self.objects, &self.textures, &self.view, prog, tri, b1, b2, path, wo)
            }
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
