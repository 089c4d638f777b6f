//! The curves' own BVH: an obvhs CWBVH over the segments' boxes, traversed with the
//! triangle BVH's node test (`accel::node_hits`, which keeps boxes next to the origin and
//! widens slabs by their rounding error) and the round-cone test at the leaves. It sits
//! beside the triangles' BVH; `SceneContext` asks both, the nearer hit winning, and a scene
//! without curves has no curve BVH and asks nothing.

use super::{CURVE_BIT, Strand, round_cone};
use crate::accel::{Hit, NodeRay, obvhs_direction, octant_inv4, traverse};
use glam::{Vec3, Vec3A, Vec4, Vec4Swizzles};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;

/// The BVH over curve segments.
#[derive(Clone, Debug)]
pub struct CurveBvh {
    bvh: CwBvh,
    /// For each segment in BVH order, the index of its first control point (the second is
    /// the next one): 4 bytes per segment.
    first: Vec<u32>,
}

impl CurveBvh {
    /// Builds the BVH over the segments of `strands`.
    pub fn build(points: &[Vec4], strands: &[Strand]) -> Self {
        let mut first = Vec::with_capacity(strands.iter().map(|s| s.count as usize - 1).sum());
        for s in strands {
            first.extend(s.first..s.first + s.count - 1);
        }
        let boxes: Vec<Aabb> = first
            .iter()
            .map(|&k| {
                let (a, b) = (points[k as usize], points[k as usize + 1]);
                let r = Vec3A::splat(a.w.max(b.w));
                let (pa, pb) = (Vec3A::from(a.xyz()), Vec3A::from(b.xyz()));
                Aabb::new(pa.min(pb) - r, pa.max(pb) + r)
            })
            .collect();
        let mut core = std::time::Duration::ZERO;
        let mut bvh = obvhs::cwbvh::builder::build_cwbvh(&boxes, BvhBuildParams::medium_build(), &mut core);
        // Segments in BVH order; the index list is then no longer needed.
        let first = bvh.primitive_indices.iter().map(|&i| first[i as usize]).collect();
        bvh.primitive_indices = Vec::new();
        CurveBvh { bvh, first }
    }

    /// Bytes held (nodes and the per-segment point index).
    pub fn bytes(&self) -> usize {
        self.bvh.nodes.len() * size_of::<obvhs::cwbvh::node::CwBvhNode>() + self.first.len() * size_of::<u32>()
    }

    /// The first control point of segment `id` (BVH order).
    #[inline]
    pub fn first_point(&self, id: u32) -> u32 {
        self.first[id as usize]
    }

    /// Closest entry into a segment along a unit-direction ray in (0, tmax): a `Hit` with
    /// `CURVE_BIT | segment` and the axial parameter in `b1`.
    #[inline]
    pub fn intersect(&self, points: &[Vec4], org: Vec3, dir: Vec3, tmax: f32) -> Option<Hit> {
        let dir_a = obvhs_direction(dir);
        let ray = NodeRay::new(org, dir_a);
        let mut best: Option<Hit> = None;
        traverse(&self.bvh, &ray, octant_inv4(dir_a), tmax, |id, best_t| {
            let k = self.first[id] as usize;
            match round_cone::intersect(org, dir, points[k], points[k + 1], 0.0, best_t) {
                Some(h) => {
                    best = Some(Hit { tri: CURVE_BIT | id as u32, t: h.t, b1: h.s, b2: 0.0 });
                    Some(h.t)
                }
                None => Some(best_t),
            }
        });
        best
    }

    /// True when some segment blocks the segment (0, tmax) of the ray (strands are opaque).
    #[inline]
    pub fn occluded(&self, points: &[Vec4], org: Vec3, dir: Vec3, tmax: f32) -> bool {
        self.occluded_by(points, org, dir, tmax, |_| true)
    }

    /// [`occluded`](Self::occluded) by the segments `blocks` accepts (BVH-order ids, as in a
    /// hit's `tri` without `CURVE_BIT`): shadow linking's blockers.
    #[inline]
    pub fn occluded_by(&self, points: &[Vec4], org: Vec3, dir: Vec3, tmax: f32, blocks: impl Fn(u32) -> bool) -> bool {
        let dir_a = obvhs_direction(dir);
        let ray = NodeRay::new(org, dir_a);
        let mut blocked = false;
        traverse(&self.bvh, &ray, octant_inv4(dir_a), tmax, |id, _| {
            let k = self.first[id] as usize;
            blocked =
                blocks(id as u32) && round_cone::intersect(org, dir, points[k], points[k + 1], 0.0, tmax).is_some();
            (!blocked).then_some(tmax)
        });
        blocked
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::curves::Curves;
    use glam::Vec2;

    /// A field of random strands: the BVH's closest hit and occlusion agree with testing
    /// every segment.
    #[test]
    fn bvh_agrees_with_testing_every_segment() {
        let mut state = 7u64;
        let mut rnd = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32 + 0.5) / (1u64 << 24) as f32
        };
        let mut curves = Curves::default();
        for _ in 0..300 {
            let first = curves.points.len() as u32;
            let mut p = Vec3::new(rnd(), 0.0, rnd()) * 4.0 - Vec3::new(2.0, 0.0, 2.0);
            let count = 2 + (rnd() * 6.0) as u32;
            for i in 0..count {
                curves.points.push(p.extend(0.02 * (1.0 - i as f32 / count as f32) + 0.002));
                p += Vec3::new(rnd() - 0.5, 1.0, rnd() - 0.5) * 0.2;
            }
            curves.strands.push(Strand { first, count, material: 0, uv: Vec2::ZERO, object: 0 });
        }
        curves.build();
        let bvh = curves.bvh.as_ref().unwrap();
        let (mut hits, mut blocked) = (0, 0);
        for _ in 0..3000 {
            let o = Vec3::new(rnd() * 6.0 - 3.0, rnd() * 2.0, 5.0);
            let target = Vec3::new(rnd() * 4.0 - 2.0, rnd() * 1.2, rnd() * 4.0 - 2.0);
            let d = (target - o).normalize();
            let tmax = if rnd() < 0.3 { (target - o).length() } else { f32::INFINITY };
            let mut brute: Option<f32> = None;
            for (id, &k) in bvh.first.iter().enumerate() {
                let k = k as usize;
                if let Some(h) = round_cone::intersect(o, d, curves.points[k], curves.points[k + 1], 0.0, tmax)
                    && brute.is_none_or(|b| h.t < b)
                {
                    brute = Some(h.t);
                    let _ = id;
                }
            }
            let got = bvh.intersect(&curves.points, o, d, tmax);
            assert_eq!(got.map(|h| h.t), brute, "closest hit differs");
            assert_eq!(bvh.occluded(&curves.points, o, d, tmax), brute.is_some());
            hits += got.is_some() as u32;
            blocked += brute.is_some() as u32;
            if let Some(h) = got {
                let s = curves.surface(&h, o, d);
                assert!(s.ng.dot(d) < 0.0 && (s.p - (o + d * h.t)).length() < 1e-4);
            }
        }
        assert!(hits > 100 && blocked > 100, "{hits} hits");
    }
}
