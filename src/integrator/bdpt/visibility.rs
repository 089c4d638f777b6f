//! Ray Visibility (objects, lights, the world: `scene::visibility`,
//! `scene::light_visibility`) and BSDFs switched by the Light Path node in BDPT and VCM.
//!
//! In camera order every segment of a path is a ray of one kind, set at its camera-side
//! end: the camera, the lobe the vertex scattered with (diffuse, glossy, transmission), or
//! next-event estimation's shadow ray for the segment to the light. A camera subpath and
//! a light sample from a camera vertex (s = 1) know that kind when they trace, as the path
//! tracer does; a light subpath learns it only at the segment's far end, and a connection
//! has no lobe at all. So the paths where kinds matter are left to the strategies that
//! know them:
//!
//! - **Restricted objects** are those hidden from a kind a surface path traces (diffuse,
//!   glossy, transmission or shadow rays; an object hidden from every kind is passed by
//!   every ray alike, one hidden from the camera alone is the camera segment's business,
//!   exact in every strategy, and volume rays belong to the path-traced medium vertices).
//!   The triangles of a material whose scattering (BSDFs, Mix factors, transparency,
//!   displacement) reads the Light Path node are restricted too (`switched_materials`):
//!   a vertex there is shaded with the path's state (Is Camera Ray, a bounce's kind, Ray
//!   Depth), set in camera order by the camera-side prefix, which a light subpath's vertex
//!   does not have. (Why s = 0 and s = 1 alone rather than every strategy whose light
//!   subpath ends before the first such vertex: it is the tested machinery below, and
//!   little is lost where the switched vertex is diffuse; caustics through a switched
//!   glass keep the path tracer's variance.)
//!   A point cloud object hidden from such a kind is restricted too (its spheres in a BVH
//!   of their own, tested as the triangles are).
//!   A **restricted light** is one whose Ray Visibility hides it from a surface bounce
//!   kind (the world included), one with a Max Bounces (`scene::light_bounces`: light
//!   sampling past it gives nothing, BSDF-sampled hits keep their weight against it, as
//!   Cycles), or an emissive triangle of a restricted object or of one hidden from volume
//!   rays (volume scattering takes no light from it, neither found nor estimated).
//! - A path is **restricted** when a segment of it crosses or ends on a restricted
//!   object (the test is geometric, on the triangles alone: alpha and pass-through are
//!   ignored, so every strategy answers it alike for the same segment), or its light is
//!   restricted. That is a property of the path, not of the strategy that made it.
//! - A restricted path is made by the camera side alone, as the path tracer makes it:
//!   s = 0 (the camera subpath, each ray of its kind, finds the emitter; a light hidden
//!   from the last bounce's kind is not found) and s = 1 (the light sample at a camera
//!   vertex, its shadow ray passing what shadow rays pass, the BSDF without the classes
//!   the light is hidden from), weighed against each other by the power heuristic on the
//!   two densities (BSDF sampling against this integrator's light sampling), as next-event
//!   estimation and BSDF sampling are. Every other strategy (s ≥ 2, t = 1, merging)
//!   gives it nothing: light subpaths stop before a segment that crosses or ends on a
//!   restricted object, restricted lights start none (the light-origin choice leaves them
//!   out, `BdptLights::new`, so no subpath is wasted on them), connections and merges test
//!   the camera prefix (`Vertex::restricted`) and the joining segment.
//! - An unrestricted path meets no restricted object, so every kind of ray sees the same
//!   scene along it and every strategy evaluates the same function of it: the usual
//!   weights over every strategy, unchanged. The two sets are disjoint and each path's
//!   weights sum to one within its set, so the sum is unbiased.
//!
//! Where Cycles' own estimate is not one function of the path (the shadow ray and the
//! BSDF-sampled ray see different objects, e.g. an area light behind an object hidden
//! from diffuse rays only), the result depends on the MIS weights of the two strategies;
//! this integrator's light choice (`BdptLights::pick_any`) may differ from the path
//! tracer's (a light tree), so there they agree only as far as those weights do. For
//! delta lights (next-event estimation alone) and wherever both rays see the same
//! objects, they agree exactly. Under motion blur a moving restricted object is tested
//! where it is at the frame (`moving_restricted`, warned): near its path the split into the
//! two sets is then not exact.

use crate::accel::Accel;
use crate::light::Light;
use crate::scene::Scene;
use crate::scene::light_bounces::NO_LIMIT;
use crate::scene::visibility::RayMask;
use glam::Vec3;

/// The kinds a BDPT surface path traces (camera rays apart): an object or light hidden
/// from one of them is restricted.
const SURFACE_PATH_KINDS: RayMask =
    RayMask(RayMask::DIFFUSE.0 | RayMask::GLOSSY.0 | RayMask::TRANSMISSION.0 | RayMask::SHADOW.0);

/// The bounce kinds a light's Ray Visibility can hide it from on a BDPT surface path.
const LIGHT_BOUNCE_KINDS: RayMask = RayMask(RayMask::DIFFUSE.0 | RayMask::GLOSSY.0 | RayMask::TRANSMISSION.0);

/// True when an object of mask `m` is restricted (module doc).
#[inline]
pub fn restricted_object(m: RayMask) -> bool {
    m.0 != 0 && m.0 & SURFACE_PATH_KINDS.0 != SURFACE_PATH_KINDS.0
}

/// The restricted objects' triangles (their own BVH) and lights of a scene.
pub struct Restriction {
    /// The restricted triangles' BVH (None: the scene has none).
    accel: Option<Accel>,
    /// `Accel::intersect`'s alpha flags for `accel`'s triangles: none is tested.
    unmasked: Vec<bool>,
    /// Per scene triangle: restricted (empty: none is).
    objects: Vec<bool>,
    /// Per light: restricted.
    lights: Vec<bool>,
    /// The restricted point cloud objects' spheres (in `point_bvh`'s order) and their BVH
    /// (None: no point cloud object is restricted).
    point_spheres: Vec<glam::Vec4>,
    point_bvh: Option<crate::points::bvh::PointBvh>,
    /// Per scene sphere slot: its object is restricted (empty: none is).
    point_slots: Vec<bool>,
}

impl std::fmt::Debug for Restriction {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Restriction")
            .field("triangles", &self.unmasked.len())
            .field("lights", &self.lights.iter().filter(|&&r| r).count())
            .finish()
    }
}

impl Restriction {
    /// The restricted objects and lights of `scene`.
    pub fn new(scene: &Scene) -> Self {
        Self::build(scene, false)
    }

    /// The restricted objects and lights of `scene`, with the triangles of every material
    /// that may refract when `glass` (Film → Transparent Glass: whether the world behind is
    /// shown depends on the camera prefix, as with the Light Path node).
    pub fn build(scene: &Scene, glass: bool) -> Self {
        let vis = &scene.ray_visibility.per_triangle;
        let mut switched = switched_materials(scene);
        if glass {
            for (s, m) in switched.iter_mut().zip(&scene.materials) {
                *s |= m.may_refract();
            }
        }
        let objects: Vec<bool> = (0..scene.mesh.triangles.len())
            .map(|t| {
                vis.get(t).is_some_and(|m| restricted_object(*m))
                    || switched.get(scene.mesh.tri_material[t] as usize).copied().unwrap_or(false)
            })
            .collect();
        let ids: Vec<usize> = (0..objects.len()).filter(|&t| objects[t]).collect();
        let accel = (!ids.is_empty()).then(|| {
            let m = &scene.mesh;
            let tris: Vec<[Vec3; 3]> = ids.iter().map(|&t| m.triangles[t].map(|i| m.positions[i as usize])).collect();
            Accel::build(&tris)
        });
        let objects = if ids.is_empty() { Vec::new() } else { objects };
        let lights = scene
            .lights
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let own = scene.light_rays.get(i).is_some_and(|m| m.0 & LIGHT_BOUNCE_KINDS.0 != LIGHT_BOUNCE_KINDS.0);
                // A Max Bounces: light sampling stops past it, BSDF-sampled hits do not.
                let bounded = scene.light_max_bounces.get(i).is_some_and(|&m| m != NO_LIMIT);
                // An emissive triangle of an object hidden from volume rays too: Cycles' volume
                // scattering takes no light from it (`SceneContext::light_excludes`, found
                // nor estimated), which only the camera side's strategies know.
                let object = matches!(l, Light::Triangle { tri } if objects.get(*tri as usize).copied().unwrap_or(false)
                    || vis.get(*tri as usize).is_some_and(|m| !m.meets(RayMask::VOLUME)));
                own || bounded || object
            })
            .collect();
        // Point cloud objects hidden from a surface path's kind: their spheres in a BVH of their own.
        let points = &scene.points;
        let point_slots: Vec<bool> = if points.objects.iter().any(|o| restricted_object(o.rays)) {
            (0..points.spheres.len() as u32)
                .map(|slot| restricted_object(points.rays_of(crate::points::POINT_BITS | slot)))
                .collect()
        } else {
            Vec::new()
        };
        let restricted: Vec<glam::Vec4> =
            point_slots.iter().zip(&points.spheres).filter(|(r, _)| **r).map(|(_, s)| *s).collect();
        let (point_bvh, point_spheres) = if restricted.is_empty() {
            (None, Vec::new())
        } else {
            let (bvh, order) = crate::points::bvh::PointBvh::build(&restricted);
            (Some(bvh), order.iter().map(|&k| restricted[k as usize]).collect())
        };
        Restriction { accel, unmasked: vec![false; ids.len()], objects, lights, point_spheres, point_bvh, point_slots }
    }

    /// True when the scene has no restricted object or light (no test is needed).
    #[inline]
    pub fn none(&self) -> bool {
        self.accel.is_none() && self.point_bvh.is_none() && !self.lights.iter().any(|&r| r)
    }

    /// True when triangle `tri` belongs to a restricted object.
    #[inline]
    pub fn object(&self, tri: u32) -> bool {
        if crate::points::is_point(tri) {
            return self.point_slots.get((tri & !crate::points::POINT_BITS) as usize).copied().unwrap_or(false);
        }
        self.objects.get(tri as usize).copied().unwrap_or(false)
    }

    /// True when light `index` is restricted (its paths are the camera side's).
    #[inline]
    pub fn light(&self, index: usize) -> bool {
        self.lights.get(index).copied().unwrap_or(false)
    }

    /// True when the segment from `org` along unit `dir` to distance `tmax` (infinite:
    /// a ray that escapes) crosses or ends on a restricted triangle.
    #[inline]
    pub fn crosses(&self, org: Vec3, dir: Vec3, tmax: f32) -> bool {
        let points =
            self.point_bvh.as_ref().is_some_and(|b| b.occluded_by(&self.point_spheres, org, dir, tmax, |_| true));
        points
            || match &self.accel {
                None => false,
                Some(a) => a.intersect(org, dir, tmax, &self.unmasked, |_, _, _| true).is_some(),
            }
    }

    /// True when the segment from `a` to `b` crosses or ends on a restricted triangle.
    #[inline]
    pub fn between(&self, a: Vec3, b: Vec3) -> bool {
        if self.accel.is_none() && self.point_bvh.is_none() {
            return false;
        }
        let d = b - a;
        let dist = d.length();
        dist > 0.0 && self.crosses(a, d / dist, dist)
    }
}

/// Per material: its scattering (BSDFs, Mix factors, transparency, displacement) reads
/// the Light Path node (`Program::scattering_light_path`), so its triangles are restricted:
/// a vertex on it (or a segment through it) reads the path's state, which only the camera
/// side knows in camera order.
pub fn switched_materials(scene: &Scene) -> Vec<bool> {
    scene.materials.iter().map(|m| m.nodes.as_ref().is_some_and(|p| !p.scattering_light_path.is_empty())).collect()
}

/// The names of the materials whose scattering reads the Light Path node (restricted,
/// [`switched_materials`]) on triangles that move under `motion`'s blur, tested where they
/// are at the frame as [`moving_restricted`]'s objects are.
pub fn moving_switched<'a>(scene: &'a Scene, motion: &crate::motion::SceneMotion) -> Vec<&'a str> {
    let switched = switched_materials(scene);
    let mut moving = vec![false; switched.len()];
    for (t, &m) in scene.mesh.tri_material.iter().enumerate() {
        if switched.get(m as usize).copied().unwrap_or(false) && motion.moving(t as u32).is_some() {
            moving[m as usize] = true;
        }
    }
    scene.materials.iter().zip(moving).filter(|(_, m)| *m).map(|(m, _)| m.name.as_str()).collect()
}

/// The names of the restricted objects of `scene` that move under `motion`'s blur: their
/// triangles are tested where they are at the frame (`Restriction` keeps no swept shape).
pub fn moving_restricted<'a>(scene: &'a Scene, motion: &crate::motion::SceneMotion) -> Vec<&'a str> {
    scene
        .ray_visibility
        .hidden_objects
        .iter()
        .filter(|o| restricted_object(o.mask) && o.triangles.clone().any(|t| motion.moving(t as u32).is_some()))
        .map(|o| o.name.as_str())
        .collect()
}

impl super::BdptIntegrator {
    /// The solid-angle density with which s = 1 at `from` samples point `q` (normal `n`,
    /// zero for none) of finite light `index`: the light's choice and its area density,
    /// seen from `from`. A restricted path's s = 0 weighs BSDF sampling against it.
    pub(crate) fn light_sample_density(
        &self,
        ctx: &crate::integrator::SceneContext,
        index: usize,
        from: Vec3,
        q: Vec3,
        n: Vec3,
    ) -> f32 {
        let d = q - from;
        let d2 = d.length_squared();
        let cos = if n == Vec3::ZERO { 1.0 } else { n.dot(d).abs() / d2.sqrt() };
        if !(d2 > 0.0) || !(cos > 0.0) {
            return 0.0;
        }
        self.lights.pmf_any(index) * crate::light::origin::pdf_point(ctx.scene, index) * d2 / cos
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn without(kind: RayMask) -> RayMask {
        RayMask(RayMask::ALL.0 & !kind.0)
    }

    #[test]
    fn restricted_objects_are_hidden_from_a_surface_path_kind() {
        assert!(!restricted_object(RayMask::ALL));
        // The camera segment is exact in every strategy; volume rays are path traced.
        assert!(!restricted_object(without(RayMask::CAMERA)));
        assert!(!restricted_object(without(RayMask::VOLUME)));
        // Hidden from every kind: every ray passes it alike.
        assert!(!restricted_object(RayMask(0)));
        for k in [RayMask::DIFFUSE, RayMask::GLOSSY, RayMask::TRANSMISSION, RayMask::SHADOW] {
            assert!(restricted_object(without(k)), "{k:?}");
        }
        assert!(restricted_object(RayMask::SHADOW));
    }

    /// The triangles of a material whose scattering reads the Light Path node are
    /// restricted objects, and an emissive one a restricted light; a plain material's are not.
    #[test]
    fn bsdfs_switched_by_the_light_path_node_are_restricted() {
        use crate::scene::light_path::PathOutput;
        use crate::shader::instructions::Program;
        let mut scene = Scene::default();
        let switched = Program { scattering_light_path: vec![PathOutput::IsCamera], ..Program::default() };
        scene.materials = vec![
            crate::scene::material::Material::default(),
            crate::scene::material::Material { nodes: Some(std::sync::Arc::new(switched)), ..Default::default() },
        ];
        scene.mesh.positions = vec![
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(1.0, -1.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
            Vec3::new(-1.0, -1.0, -1.0),
            Vec3::new(1.0, -1.0, -1.0),
            Vec3::new(0.0, 1.0, -1.0),
        ];
        scene.mesh.triangles = vec![[0, 1, 2], [3, 4, 5]];
        scene.mesh.tri_material = vec![0, 1];
        scene.lights = vec![Light::Triangle { tri: 0 }, Light::Triangle { tri: 1 }];
        assert_eq!(switched_materials(&scene), vec![false, true]);
        let r = Restriction::new(&scene);
        assert!(!r.none());
        assert!(!r.object(0) && r.object(1));
        assert!(!r.light(0) && r.light(1));
        // Only the switched triangle (z = -1) is found by the segment tests.
        assert!(!r.between(Vec3::ZERO, Vec3::new(0.0, 0.0, 2.0)));
        assert!(r.between(Vec3::ZERO, Vec3::new(0.0, 0.0, -2.0)));
    }

    /// A restricted path's set is s = 0 (BSDF sampling, `camera_only_weight`) and s = 1
    /// (light sampling, weighed by the power heuristic against the BSDF's density, as
    /// `connect` does): over random paths' densities the two weights sum to 1, and s = 0
    /// takes it whole where s = 1 cannot make it (a camera ray, a delta bounce).
    #[test]
    fn restricted_paths_weights_sum_to_one() {
        let bdpt = super::super::BdptIntegrator::new(&Scene::default(), 4, false, None);
        let mut state = 0x5eed_1234u64;
        let mut rnd = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32 + 0.5) / (1u64 << 24) as f32
        };
        for trial in 0..4000 {
            let pdf_sa = (rnd() * 20.0 - 10.0).exp();
            let p_light = (rnd() * 20.0 - 10.0).exp();
            let (i, prev_delta) = (1 + trial % 5, trial % 7 == 0);
            let s0 = bdpt.camera_only_weight(i, prev_delta, pdf_sa, p_light) as f64;
            let s1 = if prev_delta { 0.0 } else { crate::integrator::power_heuristic(p_light, pdf_sa) as f64 };
            assert!((s0 + s1 - 1.0).abs() < 1e-5, "trial {trial}: {s0} + {s1}");
            assert_eq!(bdpt.camera_only_weight(0, false, pdf_sa, p_light), 1.0);
        }
    }

    #[test]
    fn segments_find_restricted_triangles_only_between_their_ends() {
        let tris = [[Vec3::new(-1.0, -1.0, 1.0), Vec3::new(1.0, -1.0, 1.0), Vec3::new(0.0, 1.0, 1.0)]];
        let r = Restriction {
            accel: Some(Accel::build(&tris)),
            unmasked: vec![false],
            objects: vec![true],
            lights: vec![false],
            point_spheres: Vec::new(),
            point_bvh: None,
            point_slots: Vec::new(),
        };
        assert!(r.between(Vec3::ZERO, Vec3::new(0.0, 0.0, 2.0)));
        assert!(!r.between(Vec3::ZERO, Vec3::new(0.0, 0.0, 0.5)));
        assert!(!r.between(Vec3::new(3.0, 0.0, 0.0), Vec3::new(3.0, 0.0, 2.0)));
        assert!(r.crosses(Vec3::ZERO, Vec3::Z, f32::INFINITY));
        assert!(!r.crosses(Vec3::ZERO, -Vec3::Z, f32::INFINITY));
        assert!(r.object(0) && !r.object(1) && !r.light(0) && !r.none());
    }

    #[test]
    fn segments_find_restricted_points() {
        let sphere = glam::Vec4::new(0.0, 0.0, 2.0, 0.5);
        let (bvh, _) = crate::points::bvh::PointBvh::build(&[sphere]);
        let r = Restriction {
            accel: None,
            unmasked: Vec::new(),
            objects: Vec::new(),
            lights: Vec::new(),
            point_spheres: vec![sphere],
            point_bvh: Some(bvh),
            point_slots: vec![true],
        };
        assert!(r.between(Vec3::ZERO, Vec3::new(0.0, 0.0, 4.0)));
        assert!(!r.between(Vec3::ZERO, Vec3::new(0.0, 0.0, 1.0)));
        assert!(!r.crosses(Vec3::ZERO, -Vec3::Z, f32::INFINITY));
        assert!(r.object(crate::points::POINT_BITS) && !r.object(crate::points::POINT_BITS | 1) && !r.none());
    }
}
