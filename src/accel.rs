//! Ray queries against all triangles: an obvhs compressed wide BVH (CWBVH, PLOC
//! build) traversed with a watertight ray/triangle test (Woop, Benthin & Wald 2013),
//! so that rays never slip between triangles that share an edge.
//!
//! Triangles are copied into BVH order at build time so that the leaf test reads
//! memory sequentially instead of going through `primitive_indices`.
//!
//! Short rays must not lose surfaces (a subsurface random walk's steps start within
//! 1e-6 of them): the node test is our own, because obvhs' culls every child box that
//! ends within 1e-4 of the origin and its error is not bounded, and the triangle test
//! settles the sign of a distance that its f32 rounding cannot decide in f64.

mod clearance;
pub use clearance::NO_TRIANGLE;
pub(crate) use clearance::point_triangle_squared;
mod planes;
pub mod touching;
mod traverse;

use glam::{Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::cwbvh::CwBvh;
use planes::{NodePlanes, PlaneRay, traverse_planes};
use std::time::{Duration, Instant};
pub(crate) use traverse::{NodeRay, RayTransform, obvhs_direction, octant_inv4, traverse};

/// A ray/triangle hit.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Triangle index in the scene mesh.
    pub tri: u32,
    /// Distance along the (unit) ray direction.
    pub t: f32,
    /// Barycentric weight of vertex 1.
    pub b1: f32,
    /// Barycentric weight of vertex 2.
    pub b2: f32,
}

/// The acceleration structure over the scene's triangles.
pub struct Accel {
    bvh: CwBvh,
    /// The nodes' child boxes as floats (`planes`), in node order.
    planes: Vec<NodePlanes>,
    /// Triangle vertices in BVH order.
    tris: Vec<[Vec3A; 3]>,
    /// Scene triangle index of each BVH-ordered triangle.
    ids: Vec<u32>,
    /// Triangles placed anew since the build (`relocate`), in a BVH of their own; None for
    /// every render but the viewport's after an object moved or was shown again.
    moved: Option<Box<Accel>>,
    /// Per scene triangle: whether and where another surface lies within the look back's
    /// reach (`touching`); ids beyond it (moving triangles, anything after `relocate`)
    /// count as touching everywhere.
    touching: touching::Touching,
    /// Core build time.
    pub build_time: Duration,
}

impl Accel {
    /// Builds the BVH over some of the scene's triangles: `triangles[i]` is scene
    /// triangle `ids[i]` (motion blur keeps the moving ones in `motion::accel`).
    pub fn build_with_ids(triangles: &[[Vec3; 3]], ids: &[u32]) -> Self {
        let mut accel = Self::build(triangles);
        for id in &mut accel.ids {
            *id = ids[*id as usize];
        }
        let mut slot = vec![touching::ALWAYS; ids.iter().max().map_or(0, |&m| m as usize + 1)];
        for (&id, &t) in ids.iter().zip(&accel.touching.slot) {
            slot[id as usize] = t;
        }
        accel.touching.slot = slot;
        accel
    }

    /// Builds the BVH over triangles given by their three vertices.
    pub fn build(triangles: &[[Vec3; 3]]) -> Self {
        let start = Instant::now();
        let prims: Vec<obvhs::triangle::Triangle> = triangles
            .iter()
            .map(|t| obvhs::triangle::Triangle { v0: t[0].into(), v1: t[1].into(), v2: t[2].into() })
            .collect();
        // Spatial pre-splits are off: with them a triangle can sit in several leaves,
        // which would double-count it in transmittance queries.
        let params = BvhBuildParams { pre_split: false, ..BvhBuildParams::medium_build() };
        let mut core = Duration::ZERO;
        let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(&prims, params, &mut core);
        let ids = bvh.primitive_indices.clone();
        let tris = ids.iter().map(|&i| [prims[i as usize].v0, prims[i as usize].v1, prims[i as usize].v2]).collect();
        let touching = touching::touching(triangles);
        let planes = NodePlanes::of(&bvh);
        Accel { bvh, planes, tris, ids, moved: None, touching, build_time: start.elapsed() }
    }

    /// Moves and hides scene triangles without rebuilding this BVH (the viewport's object
    /// moves and hides): the triangles `detached` are collapsed to a point where this BVH
    /// holds them (three equal corners make every edge function exactly 0, so the triangle
    /// test never reports them), and `placed` (ids among them, with their corners now) are
    /// held in a BVH of their own, built over them alone. Collapsing is for good: a later
    /// call must detach every triangle an earlier one did. The cost is a scan of the ids and
    /// a build over the placed triangles, not over the scene.
    pub fn relocate(&mut self, detached: &[u32], placed: &[(u32, [Vec3; 3])]) {
        let start = Instant::now();
        let mut gone = vec![false; self.ids.iter().max().map_or(0, |&m| m as usize + 1)];
        for &id in detached {
            if let Some(f) = gone.get_mut(id as usize) {
                *f = true;
            }
        }
        for (tri, &id) in self.tris.iter_mut().zip(&self.ids) {
            if gone[id as usize] {
                *tri = [tri[0]; 3];
            }
        }
        let corners: Vec<[Vec3; 3]> = placed.iter().map(|(_, c)| *c).collect();
        let ids: Vec<u32> = placed.iter().map(|(id, _)| *id).collect();
        self.moved = (!placed.is_empty()).then(|| Box::new(Accel::build_with_ids(&corners, &ids)));
        // Moved triangles may now rest on others: every triangle looks back again.
        self.touching.slot.clear();
        self.build_time = start.elapsed();
    }

    /// Whether the coincident-surface look back from scene triangle `tri` can find
    /// anything: a triangle facing the other way lies within its reach.
    #[inline]
    pub fn touches(&self, tri: u32) -> bool {
        self.touching.slot.get(tri as usize).is_none_or(|&k| k != touching::NEVER)
    }

    /// [`touches`](Self::touches) at point `p` of scene triangle `tri` (the point a ray
    /// leaves): whether an opposite-facing triangle's box lies within the look back's
    /// reach of it.
    #[inline]
    pub fn touches_at(&self, tri: u32, p: Vec3) -> bool {
        self.touching.slot.get(tri as usize).is_none_or(|&k| self.touching.may_touch_at(k, p))
    }

    /// Closest hit along a unit-direction ray in (0, tmax); `accept(tri, b1, b2)`
    /// filters hits (alpha masks) and is called only for triangles flagged in `maybe_masked`.
    #[inline]
    pub fn intersect(
        &self,
        org: Vec3,
        dir: Vec3,
        tmax: f32,
        maybe_masked: &[bool],
        accept: impl Fn(u32, f32, f32) -> bool,
    ) -> Option<Hit> {
        self.intersect_except(org, dir, tmax, u32::MAX, maybe_masked, accept)
    }

    /// [`intersect`](Self::intersect) passing triangle `skip` (the one a ray leaves, as
    /// Cycles skips its `isect.prim`; `u32::MAX` skips none).
    #[inline]
    pub fn intersect_except(
        &self,
        org: Vec3,
        dir: Vec3,
        tmax: f32,
        skip: u32,
        maybe_masked: &[bool],
        accept: impl Fn(u32, f32, f32) -> bool,
    ) -> Option<Hit> {
        let rt = RayTransform::new(org, dir);
        let dir_a = obvhs_direction(dir);
        let ray = PlaneRay::new(&NodeRay::new(org, dir_a));
        let mut best: Option<Hit> = None;
        traverse_planes(&self.bvh, &self.planes, &ray, octant_inv4(dir_a), tmax, |id, best_t| {
            if let Some((t, b1, b2)) = rt.intersect(&self.tris[id], 0.0, best_t) {
                let tri = self.ids[id];
                if tri != skip && (!maybe_masked[tri as usize] || accept(tri, b1, b2)) {
                    best = Some(Hit { tri, t, b1, b2 });
                    return Some(t);
                }
            }
            Some(best_t)
        });
        match &self.moved {
            Some(m) => m.intersect_except(org, dir, best.map_or(tmax, |h| h.t), skip, maybe_masked, accept).or(best),
            None => best,
        }
    }

    /// Calls `f` with every triangle hit in (0, tmax), in no order, until it returns false
    /// (the shader's local queries, `integrator::shader_rays`); false when `f` stopped it.
    pub fn visit_hits(&self, org: Vec3, dir: Vec3, tmax: f32, f: &mut dyn FnMut(Hit) -> bool) -> bool {
        let rt = RayTransform::new(org, dir);
        let dir_a = obvhs_direction(dir);
        let ray = PlaneRay::new(&NodeRay::new(org, dir_a));
        let mut go = true;
        traverse_planes(&self.bvh, &self.planes, &ray, octant_inv4(dir_a), tmax, |id, _| {
            if let Some((t, b1, b2)) = rt.intersect(&self.tris[id], 0.0, tmax)
                && !f(Hit { tri: self.ids[id], t, b1, b2 })
            {
                go = false;
                return None;
            }
            Some(tmax)
        });
        match &self.moved {
            Some(m) if go => m.visit_hits(org, dir, tmax, f),
            _ => go,
        }
    }

    /// Fraction of light that passes along the segment (0, tmax): 0 at the first
    /// opaque triangle; `transparency(tri, b1, b2)` gives the pass-through fraction of
    /// triangles flagged in `maybe_transparent`, and the fractions multiply.
    #[inline]
    pub fn transmittance(
        &self,
        org: Vec3,
        dir: Vec3,
        tmax: f32,
        maybe_transparent: &[bool],
        transparency: impl Fn(u32, f32, f32) -> f32,
    ) -> f32 {
        let rt = RayTransform::new(org, dir);
        let dir_a = obvhs_direction(dir);
        let ray = PlaneRay::new(&NodeRay::new(org, dir_a));
        let mut tr = 1.0f32;
        traverse_planes(&self.bvh, &self.planes, &ray, octant_inv4(dir_a), tmax, |id, _| {
            if let Some((_, b1, b2)) = rt.intersect(&self.tris[id], 0.0, tmax) {
                let tri = self.ids[id];
                tr = if maybe_transparent[tri as usize] { tr * transparency(tri, b1, b2) } else { 0.0 };
                if !(tr > 0.0) {
                    // The first opaque occluder ends the query.
                    tr = 0.0;
                    return None;
                }
            }
            Some(tmax)
        });
        match &self.moved {
            Some(m) if tr > 0.0 => tr * m.transmittance(org, dir, tmax, maybe_transparent, transparency),
            _ => tr,
        }
    }
}

#[cfg(test)]
impl Accel {
    /// The closest hit found with the quantised node test (`traverse`), no filter: the
    /// float-plane test's reference (`planes::tests`).
    pub(crate) fn intersect_quantised_for_tests(&self, org: Vec3, dir: Vec3, tmax: f32) -> Option<Hit> {
        let rt = RayTransform::new(org, dir);
        let dir_a = obvhs_direction(dir);
        let ray = NodeRay::new(org, dir_a);
        let mut best: Option<Hit> = None;
        traverse(&self.bvh, &ray, octant_inv4(dir_a), tmax, |id, best_t| {
            if let Some((t, b1, b2)) = rt.intersect(&self.tris[id], 0.0, best_t) {
                best = Some(Hit { tri: self.ids[id], t, b1, b2 });
                return Some(t);
            }
            Some(best_t)
        });
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fan of triangles sharing a vertex and edges: rays aimed exactly at the shared
    /// edges and vertex must hit (no leak) — the property the watertight test buys.
    #[test]
    #[allow(clippy::needless_range_loop)]
    fn shared_edges_do_not_leak() {
        let n = 7;
        let c = Vec3::new(0.1, 0.2, 0.0);
        let ring: Vec<Vec3> = (0..n)
            .map(|i| {
                let a = i as f32 / n as f32 * std::f32::consts::TAU;
                c + Vec3::new(a.cos(), a.sin(), 0.0) * 3.0
            })
            .collect();
        let tris: Vec<[Vec3; 3]> = (0..n).map(|i| [c, ring[i], ring[(i + 1) % n]]).collect();
        let accel = Accel::build(&tris);
        let flags = vec![false; n];
        for i in 0..n {
            for f in [0.0f32, 0.25, 0.5, 0.999] {
                let target = c + (ring[i] - c) * f;
                let org = Vec3::new(0.3, -0.7, 5.0);
                let dir = (target - org).normalize();
                let hit = accel.intersect(org, dir, f32::INFINITY, &flags, |_, _, _| true);
                assert!(hit.is_some(), "ray through shared edge {i} at {f} leaked");
            }
        }
    }

    #[test]
    fn barycentrics_and_distance() {
        let tri = [Vec3::new(0.0, 0.0, -2.0), Vec3::new(1.0, 0.0, -2.0), Vec3::new(0.0, 1.0, -2.0)];
        let accel = Accel::build(&[tri]);
        let h = accel.intersect(Vec3::new(0.25, 0.5, 0.0), -Vec3::Z, f32::INFINITY, &[false], |_, _, _| true).unwrap();
        assert!((h.t - 2.0).abs() < 1e-5 && (h.b1 - 0.25).abs() < 1e-5 && (h.b2 - 0.5).abs() < 1e-5);
        assert!(accel.intersect(Vec3::new(0.25, 0.5, 0.0), -Vec3::Z, 1.5, &[false], |_, _, _| true).is_none());
        assert_eq!(accel.transmittance(Vec3::new(0.25, 0.5, 0.0), -Vec3::Z, 3.0, &[false], |_, _, _| 1.0), 0.0);
        assert_eq!(accel.transmittance(Vec3::new(0.25, 0.5, 0.0), -Vec3::Z, 3.0, &[true], |_, _, _| 0.25), 0.25);
        assert_eq!(accel.transmittance(Vec3::new(0.25, 0.5, 0.0), Vec3::Z, 3.0, &[false], |_, _, _| 1.0), 1.0);
    }

    /// A relocated triangle is met where it moved to, with its own id, and no longer where
    /// the BVH was built with it; the others stay; relocating again starts from the build.
    #[test]
    fn relocated_triangles_are_met_where_they_moved() {
        let at = |z: f32, x: f32| [Vec3::new(x, 0.0, z), Vec3::new(x + 1.0, 0.0, z), Vec3::new(x, 1.0, z)];
        let mut accel = Accel::build(&[at(-2.0, 0.0), at(-3.0, 5.0)]);
        let flags = [false, false];
        let down = |a: &Accel, x: f32| {
            a.intersect(Vec3::new(x + 0.25, 0.25, 0.0), -Vec3::Z, f32::INFINITY, &flags, |_, _, _| true)
        };
        let shadow =
            |a: &Accel, x: f32| a.transmittance(Vec3::new(x + 0.25, 0.25, 0.0), -Vec3::Z, 10.0, &flags, |_, _, _| 1.0);
        // Triangle 0 slides from x = 0 to x = 10, one unit further away.
        accel.relocate(&[0], &[(0, at(-3.0, 10.0))]);
        assert!(down(&accel, 0.0).is_none() && shadow(&accel, 0.0) == 1.0, "met where it was");
        let h = down(&accel, 10.0).expect("not met where it moved");
        assert_eq!(h.tri, 0);
        assert!((h.t - 3.0).abs() < 1e-5);
        assert_eq!(shadow(&accel, 10.0), 0.0);
        assert_eq!(down(&accel, 5.0).map(|h| h.tri), Some(1), "an unmoved triangle was lost");
        // Both moved: the second list replaces the first.
        accel.relocate(&[0, 1], &[(0, at(-1.0, 20.0)), (1, at(-1.0, 30.0))]);
        assert!(down(&accel, 10.0).is_none() && down(&accel, 5.0).is_none());
        assert_eq!(down(&accel, 20.0).map(|h| h.tri), Some(0));
        assert_eq!(down(&accel, 30.0).map(|h| h.tri), Some(1));
        // Detached but not placed: hidden everywhere.
        accel.relocate(&[0, 1], &[(1, at(-1.0, 30.0))]);
        assert!(down(&accel, 20.0).is_none() && shadow(&accel, 20.0) == 1.0);
        assert_eq!(down(&accel, 30.0).map(|h| h.tri), Some(1));
        // The nearer of a built and a relocated triangle on one ray wins, either way round.
        let mut accel = Accel::build(&[at(-2.0, 0.0), at(-3.0, 5.0)]);
        accel.relocate(&[1], &[(1, at(-1.0, 0.0))]);
        assert_eq!(down(&accel, 0.0).map(|h| h.tri), Some(1));
        accel.relocate(&[1], &[(1, at(-4.0, 0.0))]);
        assert_eq!(down(&accel, 0.0).map(|h| h.tri), Some(0));
    }

    /// Axis-aligned rays whose other components are -0.0 (e.g. `-Vec3::Z`) must hit.
    #[test]
    fn negative_zero_direction_hits() {
        let tri = [Vec3::new(0.0, 0.0, -2.0), Vec3::new(1.0, 0.0, -2.1), Vec3::new(0.0, 1.0, -2.0)];
        let accel = Accel::build(&[tri]);
        let d = Vec3::new(-0.0, -0.0, -1.0);
        assert!(accel.intersect(Vec3::new(0.25, 0.5, 0.0), d, f32::INFINITY, &[false], |_, _, _| true).is_some());
    }

    /// A closed box (12 triangles) with centre `c`, half-extents `h` and rotation
    /// `rot` (orthonormal columns), built from f32-rounded corners.
    fn box_tris(c: [f64; 3], h: [f64; 3], rot: [[f64; 3]; 3]) -> Vec<[Vec3; 3]> {
        let corner = |i: usize| {
            let l = [0, 1, 2].map(|k| if i >> k & 1 == 1 { h[k] } else { -h[k] });
            let w = [0, 1, 2].map(|r| c[r] + rot[0][r] * l[0] + rot[1][r] * l[1] + rot[2][r] * l[2]);
            Vec3::new(w[0] as f32, w[1] as f32, w[2] as f32)
        };
        // Quads as corner bit patterns, wound outward.
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        quads
            .iter()
            .flat_map(|q| [[corner(q[0]), corner(q[1]), corner(q[2])], [corner(q[0]), corner(q[2]), corner(q[3])]])
            .collect()
    }

    /// Closest hit in f64 (Möller-Trumbore on the same f32 vertices): the reference
    /// distance and the cosine between the ray and the hit triangle's normal.
    fn reference_hit(tris: &[[Vec3; 3]], o: Vec3, d: Vec3) -> Option<(f64, f64)> {
        let v = |p: Vec3| [p.x as f64, p.y as f64, p.z as f64];
        let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
        };
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let (o, d) = (v(o), v(d));
        let mut best: Option<(f64, f64)> = None;
        for t in tris {
            let (p0, e1, e2) = (v(t[0]), sub(v(t[1]), v(t[0])), sub(v(t[2]), v(t[0])));
            let pv = cross(d, e2);
            let det = dot(e1, pv);
            if det == 0.0 {
                continue;
            }
            let s = sub(o, p0);
            let b1 = dot(s, pv) / det;
            let qv = cross(s, e1);
            let b2 = dot(d, qv) / det;
            let tt = dot(e2, qv) / det;
            if b1 < 0.0 || b2 < 0.0 || b1 + b2 > 1.0 || tt <= 0.0 || best.is_some_and(|b| b.0 <= tt) {
                continue;
            }
            let n = cross(e1, e2);
            best = Some((tt, dot(n, d).abs() / dot(n, n).sqrt()));
        }
        best
    }

    /// Rays from points 1e-6..1e-3 inside a closed box of large triangles (20 and 100
    /// units), aimed at the near face as a subsurface random walk's steps are, must hit
    /// the box at the f64 reference distance: a miss loses the walk.
    #[test]
    fn short_rays_inside_a_box_hit_it() {
        let mut state = 0x853c_49e6_748f_ea9bu64;
        let mut rnd = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f64 + 0.5) / (1u64 << 24) as f64
        };
        let (c, s) = (0.6f64.cos(), 0.6f64.sin());
        let tilted = [[c, s * 0.6, s * 0.8], [-s, c * 0.6, c * 0.8], [0.0, -0.8, 0.6]];
        let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let boxes = [
            ("20-unit axis-aligned", [0.0, -1.0, 0.0], [10.0, 1.0, 10.0], identity),
            ("100-unit tilted", [13.0, -11.0, 38.0], [50.0, 50.0, 50.0], tilted),
        ];
        let mut failures = Vec::new();
        for (name, centre, half, rot) in boxes {
            let tris = box_tris(centre, half, rot);
            let accel = Accel::build(&tris);
            let flags = vec![false; tris.len()];
            // Coordinates of magnitude `scale` carry f32 spacing ~ε·scale; the hit
            // point's error along the normal is a few such spacings (pbrt-v4's δt bound
            // is ~10 ε·scale for these shapes), so the distance may be off by 32 ε·scale / cos.
            let scale = tris.iter().flatten().map(|p| p.abs().max_element()).fold(0.0f32, f32::max) as f64;
            let (mut misses, mut wrong, mut unblocked, mut rays) = ([0u32; 3], [0u32; 3], [0u32; 3], [0u32; 3]);
            for _ in 0..30_000 {
                let axis = (rnd() * 3.0) as usize % 3;
                let side = if rnd() < 0.5 { -1.0 } else { 1.0 };
                let decade = (rnd() * 3.0) as usize % 3;
                let dist = 10f64.powf(-6.0 + decade as f64 + rnd());
                let mut local = [0.0; 3];
                for k in 0..3 {
                    local[k] = if k == axis { side * (half[k] - dist) } else { (2.0 * rnd() - 1.0) * 0.99 * half[k] };
                }
                let world = |l: [f64; 3], with_centre: bool| {
                    let w = [0, 1, 2].map(|r| rot[0][r] * l[0] + rot[1][r] * l[1] + rot[2][r] * l[2]);
                    let c = if with_centre { centre } else { [0.0; 3] };
                    Vec3::new((c[0] + w[0]) as f32, (c[1] + w[1]) as f32, (c[2] + w[2]) as f32)
                };
                let org = world(local, true);
                // A uniform direction in the hemisphere toward the face.
                let z = rnd();
                let phi = rnd() * std::f64::consts::TAU;
                let r = (1.0 - z * z).sqrt();
                let mut l = [0.0; 3];
                l[axis] = side * z;
                l[(axis + 1) % 3] = r * phi.cos();
                l[(axis + 2) % 3] = r * phi.sin();
                let dir = world(l, false).normalize();
                // Points that rounded onto the surface have no defined answer.
                let Some((t_ref, cos)) = reference_hit(&tris, org, dir) else { continue };
                if t_ref < 1e-12 {
                    continue;
                }
                rays[decade] += 1;
                match accel.intersect(org, dir, f32::INFINITY, &flags, |_, _, _| true) {
                    None => misses[decade] += 1,
                    Some(h) if (h.t as f64 - t_ref).abs() > 32.0 * f32::EPSILON as f64 * scale / cos => {
                        wrong[decade] += 1
                    }
                    Some(_) => {}
                }
                if accel.transmittance(org, dir, f32::INFINITY, &flags, |_, _, _| 1.0) != 0.0 {
                    unblocked[decade] += 1;
                }
            }
            for k in 0..3 {
                eprintln!(
                    "{name}: distance 1e{}..1e{}: {} of {} rays missed, {} at a wrong distance, {} unblocked",
                    k as i32 - 6,
                    k as i32 - 5,
                    misses[k],
                    rays[k],
                    wrong[k],
                    unblocked[k]
                );
                if misses[k] + wrong[k] + unblocked[k] > 0 {
                    let (m, w, u) = (misses[k], wrong[k], unblocked[k]);
                    failures.push(format!("{name} 1e{}: {m} missed, {w} wrong, {u} unblocked", k as i32 - 6));
                }
            }
        }
        assert!(failures.is_empty(), "{failures:?}");
    }

    /// Subsurface random walks (mean free path 0.008, isotropic) inside the 20-unit box
    /// of tests/media.rs, entering at its top face: no step may leave the box without
    /// the accel reporting the face it crosses (the f64 reference decides).
    #[test]
    fn random_walks_in_a_box_do_not_step_out() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32 + 0.5) / (1u64 << 24) as f32
        };
        let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let tris = box_tris([0.0, -1.0, 0.0], [10.0, 1.0, 10.0], identity);
        let accel = Accel::build(&tris);
        let flags = vec![false; tris.len()];
        let inside = |p: Vec3| p.x.abs() < 10.0 && p.z.abs() < 10.0 && p.y < 0.0 && p.y > -2.0;
        let (mut lost, mut rounded_out, mut exits, mut steps) = (0u32, 0u32, 0u32, 0u64);
        for _ in 0..20_000 {
            let mut org = Vec3::new(rnd() * 16.0 - 8.0, 0.0, rnd() * 16.0 - 8.0);
            let mut dir = Vec3::new(0.3, -1.0, 0.2).normalize();
            for _ in 0..2_000 {
                steps += 1;
                let t = -(1.0 - rnd()).ln() * 0.008;
                if accel.intersect(org, dir, t, &flags, |_, _, _| true).is_some() {
                    exits += 1;
                    break;
                }
                // The reference is taken before moving: did the step truly cross the box?
                let crossed = reference_hit(&tris, org, dir).is_some_and(|(t_ref, _)| t_ref < t as f64);
                org += dir * t;
                if crossed {
                    lost += 1;
                    break;
                }
                if !inside(org) {
                    rounded_out += 1;
                    break;
                }
                let (z, phi) = (2.0 * rnd() - 1.0, rnd() * std::f32::consts::TAU);
                let r = (1.0 - z * z).sqrt();
                dir = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            }
        }
        eprintln!("{exits} walks exited in {steps} steps; {lost} stepped out unseen, {rounded_out} rounded out");
        assert_eq!(lost, 0, "walks that stepped out of the box without a hit");
    }
}
