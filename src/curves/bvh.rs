//! The curves' own BVH: an obvhs CWBVH over the segments' boxes, traversed with the
//! triangle BVH's node test (`accel::traverse::node_hits`, which keeps boxes next to the origin
//! and widens slabs by their rounding error) and at the leaves the round-cone test, or the
//! ray-facing ribbon's for the segments of objects drawn as ribbons (`ribbon.rs`). It sits
//! beside the triangles' BVH; `SceneContext` asks both, the nearer hit winning, and a scene
//! without curves has no curve BVH and asks nothing.

use super::{CURVE_BIT, Strand, ribbon, round_cone};
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
    /// the next one), with [`RIBBON_BIT`] set when its object is drawn as ribbons and, for a
    /// ribbon, [`ROOT_BIT`] / [`TIP_BIT`] when it is its strand's first / last segment (its
    /// Catmull-Rom curve then has no neighbour on that side): 4 bytes per segment.
    first: Vec<u32>,
}

/// Set in a segment's `first` entry when it is a ribbon (control points stay below
/// [`MAX_POINTS`]).
const RIBBON_BIT: u32 = 1 << 31;
/// Set on a ribbon segment that starts its strand.
const ROOT_BIT: u32 = 1 << 30;
/// Set on a ribbon segment that ends its strand.
const TIP_BIT: u32 = 1 << 29;
/// The flags of a `first` entry.
const FLAGS: u32 = RIBBON_BIT | ROOT_BIT | TIP_BIT;
/// Control points a scene may hold: the point index shares its word with three flags.
pub const MAX_POINTS: usize = 1 << 29;

/// The four control points of the Catmull-Rom curve of the segment whose `first` entry is
/// `e`: the segment's two and their neighbours, an end point standing in for a missing one.
#[inline(always)]
fn curve_points(points: &[Vec4], e: u32) -> [Vec4; 4] {
    let k = (e & !FLAGS) as usize;
    let (a, b) = (points[k], points[k + 1]);
    [if e & ROOT_BIT != 0 { a } else { points[k - 1] }, a, b, if e & TIP_BIT != 0 { b } else { points[k + 2] }]
}

impl CurveBvh {
    /// Builds the BVH over the segments of `strands`; `ribbons[o]` says whether curves object
    /// `o` is drawn as ribbons (objects beyond the slice are round).
    pub fn build(points: &[Vec4], strands: &[Strand], ribbons: &[bool]) -> Self {
        let mut first = Vec::with_capacity(strands.iter().map(|s| s.count as usize - 1).sum());
        for s in strands {
            let ribbon = ribbons.get(s.object as usize).copied().unwrap_or(false);
            let last = s.first + s.count - 2;
            first.extend((s.first..=last).map(|k| match ribbon {
                true => k | RIBBON_BIT | if k == s.first { ROOT_BIT } else { 0 } | if k == last { TIP_BIT } else { 0 },
                false => k,
            }));
        }
        let boxes: Vec<Aabb> = first
            .iter()
            .map(|&e| {
                if e & RIBBON_BIT != 0 {
                    let (lo, hi) = ribbon::curve_bounds(&curve_points(points, e));
                    return Aabb::new(lo.into(), hi.into());
                }
                let (a, b) = (points[e as usize], points[e as usize + 1]);
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
        self.first[id as usize] & !FLAGS
    }

    /// The Catmull-Rom control points of ribbon segment `id` (BVH order).
    #[inline]
    pub fn ribbon_points(&self, points: &[Vec4], id: u32) -> [Vec4; 4] {
        curve_points(points, self.first[id as usize])
    }

    /// True when segment `id` (BVH order) is a ribbon.
    #[inline]
    pub fn is_ribbon(&self, id: u32) -> bool {
        self.first[id as usize] & RIBBON_BIT != 0
    }

    /// Closest entry into a segment along a unit-direction ray in (0, tmax): a `Hit` with
    /// `CURVE_BIT | segment`, the axial parameter in `b1` and, for a ribbon, the offset
    /// across it in `b2` (0 for a round cone).
    #[inline]
    pub fn intersect(&self, points: &[Vec4], org: Vec3, dir: Vec3, tmax: f32) -> Option<Hit> {
        let dir_a = obvhs_direction(dir);
        let ray = NodeRay::new(org, dir_a);
        let mut best: Option<Hit> = None;
        traverse(&self.bvh, &ray, octant_inv4(dir_a), tmax, |id, best_t| {
            match self.segment_hit(points, id, org, dir, best_t) {
                Some(h) => {
                    best = Some(Hit { tri: CURVE_BIT | id as u32, ..h });
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
            blocked = blocks(id as u32) && self.segment_hit(points, id, org, dir, tmax).is_some();
            (!blocked).then_some(tmax)
        });
        blocked
    }
}

impl CurveBvh {
    /// The ray's hit on segment `id` in (0, tmax), as a `Hit` without its id: the round
    /// cone's entry, or the ribbon's hit with its offset in `b2`.
    #[inline(always)]
    fn segment_hit(&self, points: &[Vec4], id: usize, org: Vec3, dir: Vec3, tmax: f32) -> Option<Hit> {
        let e = self.first[id];
        if e & RIBBON_BIT != 0 {
            let p = curve_points(points, e);
            ribbon::intersect_curve(org, dir, &p, 0.0, tmax).map(|h| Hit { tri: 0, t: h.t, b1: h.s, b2: h.v })
        } else {
            let k = e as usize;
            let (a, b) = (points[k], points[k + 1]);
            round_cone::intersect(org, dir, a, b, 0.0, tmax).map(|h| Hit { tri: 0, t: h.t, b1: h.s, b2: 0.0 })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::curves::Curves;
    use glam::Vec2;

    /// A field of random strands, every other one a ribbon: the BVH's closest hit and
    /// occlusion agree with testing every segment with its own shape's test.
    #[test]
    fn bvh_agrees_with_testing_every_segment() {
        let mut state = 7u64;
        let mut rnd = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32 + 0.5) / (1u64 << 24) as f32
        };
        let mut curves = Curves { ribbons: vec![false, true], ..Curves::default() };
        for n in 0..300 {
            let first = curves.points.len() as u32;
            let mut p = Vec3::new(rnd(), 0.0, rnd()) * 4.0 - Vec3::new(2.0, 0.0, 2.0);
            let count = 2 + (rnd() * 6.0) as u32;
            for i in 0..count {
                curves.points.push(p.extend(0.02 * (1.0 - i as f32 / count as f32) + 0.002));
                p += Vec3::new(rnd() - 0.5, 1.0, rnd() - 0.5) * 0.2;
            }
            curves.strands.push(Strand { first, count, material: 0, uv: Vec2::ZERO, object: n % 2 });
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
            for strand in &curves.strands {
                for k in strand.first as usize..(strand.first + strand.count - 1) as usize {
                    let (a, b) = (curves.points[k], curves.points[k + 1]);
                    let t = if strand.object == 1 {
                        let last = (strand.first + strand.count - 1) as usize;
                        let p0 = if k == strand.first as usize { a } else { curves.points[k - 1] };
                        let p3 = if k + 1 == last { b } else { curves.points[k + 2] };
                        ribbon::intersect_curve(o, d, &[p0, a, b, p3], 0.0, tmax).map(|h| h.t)
                    } else {
                        round_cone::intersect(o, d, a, b, 0.0, tmax).map(|h| h.t)
                    };
                    if let Some(t) = t
                        && brute.is_none_or(|b| t < b)
                    {
                        brute = Some(t);
                    }
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
