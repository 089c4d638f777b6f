//! The points' own BVH: an obvhs CWBVH over the spheres' boxes, traversed with the triangle
//! BVH's node test (`accel::traverse`, as the curves' BVH) and the sphere test at the leaves.
//! The spheres are kept in BVH order, so a leaf reads them one after another.

use super::{POINT_BITS, sphere};
use crate::accel::{Hit, NodeRay, obvhs_direction, octant_inv4, traverse};
use glam::{Vec3, Vec3A, Vec4, Vec4Swizzles};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;

/// The BVH over the points' spheres.
#[derive(Clone, Debug)]
pub struct PointBvh {
    bvh: CwBvh,
}

impl PointBvh {
    /// Builds the BVH over `spheres` (xyz centre, w radius); returns it and the permutation
    /// that puts the spheres in BVH order (`order[k]` is the sphere at BVH slot `k`).
    pub fn build(spheres: &[Vec4]) -> (Self, Vec<u32>) {
        let boxes: Vec<Aabb> = spheres
            .iter()
            .map(|s| {
                let (c, r) = (Vec3A::from(s.xyz()), Vec3A::splat(s.w));
                Aabb::new(c - r, c + r)
            })
            .collect();
        let mut core = std::time::Duration::ZERO;
        let mut bvh = obvhs::cwbvh::builder::build_cwbvh(&boxes, BvhBuildParams::medium_build(), &mut core);
        let order = std::mem::take(&mut bvh.primitive_indices);
        (PointBvh { bvh }, order)
    }

    /// Bytes held by the nodes.
    pub fn bytes(&self) -> usize {
        self.bvh.nodes.len() * size_of::<obvhs::cwbvh::node::CwBvhNode>()
    }

    /// Closest entry into a sphere (`spheres` in BVH order) along a unit-direction ray in
    /// (0, tmax), among the slots `accepts` takes: a `Hit` with `POINT_BITS | slot`.
    #[inline]
    pub fn intersect(
        &self,
        spheres: &[Vec4],
        org: Vec3,
        dir: Vec3,
        tmax: f32,
        accepts: impl Fn(u32) -> bool,
    ) -> Option<Hit> {
        let dir_a = obvhs_direction(dir);
        let ray = NodeRay::new(org, dir_a);
        let mut best: Option<Hit> = None;
        traverse(&self.bvh, &ray, octant_inv4(dir_a), tmax, |id, best_t| {
            match sphere::intersect(org, dir, spheres[id], best_t) {
                Some(t) if accepts(id as u32) => {
                    best = Some(Hit { tri: POINT_BITS | id as u32, t, b1: 0.0, b2: 0.0 });
                    Some(t)
                }
                _ => Some(best_t),
            }
        });
        best
    }

    /// True when a sphere that `blocks` takes (BVH slots) blocks the segment (0, tmax) of the
    /// ray (points are opaque).
    #[inline]
    pub fn occluded_by(&self, spheres: &[Vec4], org: Vec3, dir: Vec3, tmax: f32, blocks: impl Fn(u32) -> bool) -> bool {
        let dir_a = obvhs_direction(dir);
        let ray = NodeRay::new(org, dir_a);
        let mut blocked = false;
        traverse(&self.bvh, &ray, octant_inv4(dir_a), tmax, |id, _| {
            blocked = sphere::intersect(org, dir, spheres[id], tmax).is_some() && blocks(id as u32);
            (!blocked).then_some(tmax)
        });
        blocked
    }
}

#[cfg(test)]
mod tests {
    use super::super::{PointObject, Points};
    use super::*;

    /// A cloud of random spheres: the BVH's closest hit and occlusion agree with testing
    /// every sphere, and the surface lies where the ray meets it.
    #[test]
    fn bvh_agrees_with_testing_every_sphere() {
        let mut state = 5u64;
        let mut rnd = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32 + 0.5) / (1u64 << 24) as f32
        };
        let mut points = Points::default();
        for _ in 0..2000 {
            let c = Vec3::new(rnd(), rnd(), rnd()) * 4.0 - 2.0;
            points.spheres.push(c.extend(0.005 + 0.05 * rnd()));
        }
        points.objects.push(PointObject::new("cloud", 0, 2000, 0));
        let loaded = points.spheres.clone();
        points.build();
        let bvh = points.bvh.as_ref().unwrap();
        let (mut hits, mut blocked) = (0, 0);
        for _ in 0..3000 {
            let o = Vec3::new(rnd() * 6.0 - 3.0, rnd() * 6.0 - 3.0, 5.0);
            let target = Vec3::new(rnd() * 4.0 - 2.0, rnd() * 4.0 - 2.0, rnd() * 4.0 - 2.0);
            let d = (target - o).normalize();
            let tmax = if rnd() < 0.3 { (target - o).length() } else { f32::INFINITY };
            let brute = loaded.iter().filter_map(|&s| sphere::intersect(o, d, s, tmax)).min_by(f32::total_cmp);
            let got = bvh.intersect(&points.spheres, o, d, tmax, |_| true);
            assert_eq!(got.map(|h| h.t), brute, "closest hit differs");
            assert_eq!(bvh.occluded_by(&points.spheres, o, d, tmax, |_| true), brute.is_some());
            hits += got.is_some() as u32;
            blocked += brute.is_some() as u32;
            if let Some(h) = got {
                assert!(super::super::is_point(h.tri) && !crate::curves::is_curve(h.tri));
                let s = points.surface(&h, o, d);
                assert!(s.ng.dot(d) < 0.0 && (s.p - (o + d * h.t)).length() < 1e-4);
                // The slot's load-order index names its sphere.
                let k = points.index[(h.tri & !POINT_BITS) as usize] as usize;
                assert_eq!(loaded[k], points.spheres[(h.tri & !POINT_BITS) as usize]);
            }
        }
        assert!(hits > 300 && blocked > 300, "{hits} hits");
        // 16 bytes a sphere, 4 for its index, and the nodes' share.
        let per_point = points.bytes() as f64 / 2000.0;
        let nodes = points.bvh.as_ref().unwrap().bytes() as f64 / 2000.0;
        eprintln!("{per_point:.1} bytes a point, {nodes:.1} of them the BVH's nodes");
        assert!(per_point < 16.0 + 4.0 + 16.0, "{per_point} bytes a point");
    }
}
