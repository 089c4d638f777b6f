//! Ray queries against all triangles: an obvhs compressed wide BVH (CWBVH, PLOC
//! build) traversed with a watertight ray/triangle test (Woop, Benthin & Wald 2013),
//! so that rays never slip between triangles that share an edge.
//!
//! Triangles are copied into BVH order at build time so that the leaf test reads
//! memory sequentially instead of going through `primitive_indices`.

use glam::{Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use std::time::{Duration, Instant};

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

/// Per-ray constants of the watertight test.
#[derive(Clone, Copy)]
struct RayTransform {
    org: Vec3,
    k: [usize; 3],
    s: [f32; 3],
}

impl RayTransform {
    #[inline]
    fn new(org: Vec3, dir: Vec3) -> Self {
        let a = dir.abs();
        let kz = if a.x > a.y {
            if a.x > a.z { 0 } else { 2 }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        RayTransform { org, k: [kx, ky, kz], s: [dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]] }
    }

    /// Watertight intersection; returns (t, b1, b2) for tmin < t < tmax.
    #[inline(always)]
    fn intersect(&self, v: &[Vec3A; 3], tmin: f32, tmax: f32) -> Option<(f32, f32, f32)> {
        let [kx, ky, kz] = self.k;
        let [sx, sy, sz] = self.s;
        let a = Vec3::from(v[0]) - self.org;
        let b = Vec3::from(v[1]) - self.org;
        let c = Vec3::from(v[2]) - self.org;
        let (ax, ay) = (a[kx] - sx * a[kz], a[ky] - sy * a[kz]);
        let (bx, by) = (b[kx] - sx * b[kz], b[ky] - sy * b[kz]);
        let (cx, cy) = (c[kx] - sx * c[kz], c[ky] - sy * c[kz]);
        let mut u = cx * by - cy * bx;
        let mut vv = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        // On an edge, redo the edge functions in double precision so that the two
        // triangles sharing it agree on which one is hit.
        if u == 0.0 || vv == 0.0 || w == 0.0 {
            let (ax, ay, bx, by, cx, cy) = (ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64);
            u = (cx * by - cy * bx) as f32;
            vv = (ax * cy - ay * cx) as f32;
            w = (bx * ay - by * ax) as f32;
        }
        if (u < 0.0 || vv < 0.0 || w < 0.0) && (u > 0.0 || vv > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + vv + w;
        if det == 0.0 {
            return None;
        }
        let t_scaled = u * (sz * a[kz]) + vv * (sz * b[kz]) + w * (sz * c[kz]);
        let inv = 1.0 / det;
        let t = t_scaled * inv;
        if !(t > tmin && t < tmax) {
            return None;
        }
        Some((t, vv * inv, w * inv))
    }
}

/// obvhs picks a node's near plane from the direction's comparison with zero but
/// inverts it with the sign bit, so a -0.0 component misses boxes; -0.0 + 0.0 = +0.0.
#[inline]
fn obvhs_direction(dir: Vec3) -> Vec3A {
    Vec3A::from(dir + Vec3::ZERO)
}

/// The acceleration structure over the scene's triangles.
pub struct Accel {
    bvh: CwBvh,
    /// Triangle vertices in BVH order.
    tris: Vec<[Vec3A; 3]>,
    /// Scene triangle index of each BVH-ordered triangle.
    ids: Vec<u32>,
    /// Core build time.
    pub build_time: Duration,
}

impl Accel {
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
        Accel { bvh, tris, ids, build_time: start.elapsed() }
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
        let rt = RayTransform::new(org, dir);
        let ray = Ray::new(org.into(), obvhs_direction(dir), 0.0, tmax);
        let mut hit = RayHit::none();
        let mut best = (0u32, 0f32, 0f32);
        self.bvh.ray_traverse(ray, &mut hit, |r, id| {
            let Some((t, b1, b2)) = rt.intersect(&self.tris[id], 0.0, r.tmax) else {
                return f32::INFINITY;
            };
            let tri = self.ids[id];
            if maybe_masked[tri as usize] && !accept(tri, b1, b2) {
                return f32::INFINITY;
            }
            best = (tri, b1, b2);
            t
        });
        (hit.t < tmax).then_some(Hit { tri: best.0, t: hit.t, b1: best.1, b2: best.2 })
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
        let ray = Ray::new(org.into(), obvhs_direction(dir), 0.0, tmax);
        let mut tr = 1.0f32;
        let miss = self.bvh.ray_traverse_miss(ray, |r, id| {
            let Some((t, b1, b2)) = rt.intersect(&self.tris[id], 0.0, r.tmax) else {
                return f32::INFINITY;
            };
            let tri = self.ids[id];
            if maybe_transparent[tri as usize] {
                tr *= transparency(tri, b1, b2);
                if tr > 0.0 {
                    return f32::INFINITY;
                }
            }
            t
        });
        if miss { tr } else { 0.0 }
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

    /// Axis-aligned rays whose other components are -0.0 (e.g. `-Vec3::Z`) must hit.
    #[test]
    fn negative_zero_direction_hits() {
        let tri = [Vec3::new(0.0, 0.0, -2.0), Vec3::new(1.0, 0.0, -2.1), Vec3::new(0.0, 1.0, -2.0)];
        let accel = Accel::build(&[tri]);
        let d = Vec3::new(-0.0, -0.0, -1.0);
        assert!(accel.intersect(Vec3::new(0.25, 0.5, 0.0), d, f32::INFINITY, &[false], |_, _, _| true).is_some());
    }
}
