//! The moving triangles' BVH, beside the static one (`crate::accel::Accel`): an obvhs
//! CWBVH over each triangle's swept box (the union of its boxes at every step, which holds
//! it at every time because a corner between two steps is a convex blend of its step
//! positions); a leaf tests the triangle with its corners interpolated at the ray's time,
//! with the static BVH's node and watertight triangle tests.

use super::{SceneMotion, segment};
use crate::accel::{Hit, NodeRay, RayTransform, obvhs_direction, octant_inv4, traverse};
use glam::{Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
use std::time::{Duration, Instant};

/// Ray queries against the moving triangles at a time.
pub struct MotionAccel {
    bvh: CwBvh,
    /// Step times (frames).
    times: Vec<f32>,
    /// Corners of BVH-ordered triangle i at step s: `corners[i * steps + s]`.
    corners: Vec<[Vec3A; 3]>,
    /// Scene triangle index of each BVH-ordered triangle.
    ids: Vec<u32>,
    /// Build time.
    pub build_time: Duration,
}

impl MotionAccel {
    /// Builds the BVH over the moving triangles of `motion` (None when nothing moves).
    pub fn build(motion: &SceneMotion) -> Option<Self> {
        if motion.triangles.is_empty() {
            return None;
        }
        let start = Instant::now();
        let steps = motion.steps();
        let boxes: Vec<Aabb> = (0..motion.triangles.len())
            .map(|k| {
                let mut b = Aabb::empty();
                for c in &motion.corners[k * steps..(k + 1) * steps] {
                    for p in c {
                        b.extend((*p).into());
                    }
                }
                b
            })
            .collect();
        let params = BvhBuildParams { pre_split: false, ..BvhBuildParams::medium_build() };
        let mut core = Duration::ZERO;
        let bvh = obvhs::cwbvh::builder::build_cwbvh(&boxes, params, &mut core);
        let order = bvh.primitive_indices.clone();
        let mut corners = Vec::with_capacity(order.len() * steps);
        for &k in &order {
            let k = k as usize;
            corners.extend(motion.corners[k * steps..(k + 1) * steps].iter().map(|c| c.map(Vec3A::from)));
        }
        let ids = order.iter().map(|&k| motion.triangles[k as usize]).collect();
        Some(MotionAccel { bvh, times: motion.times.clone(), corners, ids, build_time: start.elapsed() })
    }

    /// The corners of BVH-ordered triangle `i` at segment `seg` (from `segment`).
    #[inline(always)]
    fn corners_at(&self, i: usize, (s, f): (usize, f32)) -> [Vec3A; 3] {
        let base = i * self.times.len() + s;
        let a = &self.corners[base];
        if f == 0.0 {
            return *a;
        }
        let b = &self.corners[base + 1];
        [a[0].lerp(b[0], f), a[1].lerp(b[1], f), a[2].lerp(b[2], f)]
    }

    /// Closest hit in (0, tmax) at time `t` of a unit-direction ray; `accept` filters the
    /// triangles flagged in `maybe_masked`, as `Accel::intersect`.
    #[inline]
    pub fn intersect(
        &self,
        org: Vec3,
        dir: Vec3,
        tmax: f32,
        t: f32,
        maybe_masked: &[bool],
        accept: impl Fn(u32, f32, f32) -> bool,
    ) -> Option<Hit> {
        let seg = segment(&self.times, t);
        let rt = RayTransform::new(org, dir);
        let dir_a = obvhs_direction(dir);
        let ray = NodeRay::new(org, dir_a);
        let mut best: Option<Hit> = None;
        traverse(&self.bvh, &ray, octant_inv4(dir_a), tmax, |id, best_t| {
            if let Some((d, b1, b2)) = rt.intersect(&self.corners_at(id, seg), 0.0, best_t) {
                let tri = self.ids[id];
                if !maybe_masked[tri as usize] || accept(tri, b1, b2) {
                    best = Some(Hit { tri, t: d, b1, b2 });
                    return Some(d);
                }
            }
            Some(best_t)
        });
        best
    }

    /// Fraction of light passing along (0, tmax) at time `t`, as `Accel::transmittance`.
    #[inline]
    pub fn transmittance(
        &self,
        org: Vec3,
        dir: Vec3,
        tmax: f32,
        t: f32,
        maybe_transparent: &[bool],
        transparency: impl Fn(u32, f32, f32) -> f32,
    ) -> f32 {
        let seg = segment(&self.times, t);
        let rt = RayTransform::new(org, dir);
        let dir_a = obvhs_direction(dir);
        let ray = NodeRay::new(org, dir_a);
        let mut tr = 1.0f32;
        traverse(&self.bvh, &ray, octant_inv4(dir_a), tmax, |id, _| {
            if let Some((_, b1, b2)) = rt.intersect(&self.corners_at(id, seg), 0.0, tmax) {
                let tri = self.ids[id];
                tr = if maybe_transparent[tri as usize] { tr * transparency(tri, b1, b2) } else { 0.0 };
                if !(tr > 0.0) {
                    tr = 0.0;
                    return None;
                }
            }
            Some(tmax)
        });
        tr
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::STATIC;

    /// Unit squares (two triangles each) in the plane z = −2, sliding along x from
    /// x0 − 1 at time −1 to x0 + 1 at time 1.
    fn sliding(x0s: &[f32]) -> SceneMotion {
        let mut m = SceneMotion { times: vec![-1.0, 1.0], ..Default::default() };
        for (q, &x0) in x0s.iter().enumerate() {
            let quad = |dx: f32| {
                let p = |x: f32, y: f32| Vec3::new(x0 + dx + x, y, -2.0);
                [[p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)], [p(0.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)]]
            };
            let (a, b) = (quad(-1.0), quad(1.0));
            for j in 0..2 {
                m.triangles.push((q * 2 + j) as u32);
                m.slot.push((q * 2 + j) as u32);
                m.corners.extend([a[j], b[j]]);
                m.normals.extend([[Vec3::Z; 3]; 2]);
            }
        }
        m.slot.push(STATIC);
        m
    }

    #[test]
    fn hits_the_triangle_where_it_is_at_the_time() {
        let m = sliding(&[0.0, 10.0]);
        let accel = MotionAccel::build(&m).unwrap();
        let flags = vec![false; 5];
        let org = Vec3::new(0.25, 0.5, 0.0);
        // At time 0 the square spans x in [0, 1]; at −1 it spans [−1, 0]; at 0.9 [0.9, 1.9].
        let h = accel.intersect(org, -Vec3::Z, f32::INFINITY, 0.0, &flags, |_, _, _| true).unwrap();
        assert!((h.t - 2.0).abs() < 1e-6 && h.tri < 2);
        assert!(accel.intersect(org, -Vec3::Z, f32::INFINITY, -1.0, &flags, |_, _, _| true).is_none());
        assert!(accel.intersect(org, -Vec3::Z, f32::INFINITY, 0.9, &flags, |_, _, _| true).is_none());
        assert!(accel.intersect(org, -Vec3::Z, f32::INFINITY, -0.5, &flags, |_, _, _| true).is_some());
        assert_eq!(accel.transmittance(org, -Vec3::Z, 3.0, 0.0, &flags, |_, _, _| 1.0), 0.0);
        assert_eq!(accel.transmittance(org, -Vec3::Z, 3.0, 0.9, &flags, |_, _, _| 1.0), 1.0);
        assert_eq!(accel.transmittance(org, -Vec3::Z, 1.5, 0.0, &flags, |_, _, _| 1.0), 1.0);
        // The second square, far away, is found at its own place.
        let h = accel.intersect(Vec3::new(10.25, 0.5, 0.0), -Vec3::Z, f32::INFINITY, 0.0, &flags, |_, _, _| true);
        assert!(h.is_some_and(|h| h.tri >= 2));
    }

    #[test]
    fn nothing_moving_builds_nothing() {
        assert!(MotionAccel::build(&SceneMotion::default()).is_none());
    }
}
