//! A light tree (light BVH) for next-event estimation, after Conty Estevez & Kulla,
//! "Importance Sampling of Many Lights with Adaptive Tree Splitting" (2018), as Cycles
//! (since 3.5) and pbrt-v4 use it, without the splitting.
//!
//! Every bounded light is a leaf with its [`LightBounds`]: a box, a cone of emission
//! normals (axis `w`, spread θo, and θe beyond it over which emission falls to zero) and
//! its power. Interior nodes hold the union of their children's bounds. A light is
//! chosen by walking down from the root and picking each child in proportion to a
//! conservative estimate of its contribution at the shading point (`importance`): power
//! over squared distance, times the best emitter and receiver cosines any point of the
//! box could have. Because the estimate is never zero where a light can contribute,
//! the choice is unbiased; its probability is recomputed exactly by walking the same
//! path again (`pmf`), which multiple importance sampling needs. The walk needs no
//! stack and allocates nothing.

use super::Light;
use crate::scene::Scene;
use glam::{Quat, Vec3};
use std::f32::consts::PI;

/// Bounds of a set of lights: where they are, where they emit and how much.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounds {
    /// Box corner.
    pub min: Vec3,
    /// Box corner.
    pub max: Vec3,
    /// Axis of the cone of emission normals (unit).
    pub w: Vec3,
    /// Power (luminance, W).
    pub phi: f32,
    /// cos θo: every emission normal is within θo of `w`.
    pub cos_o: f32,
    /// cos θe: emission is zero more than θe away from every normal.
    pub cos_e: f32,
    /// Emits on both sides of its normals.
    pub two_sided: bool,
}

/// Small angle added to unions and tests so that rounding never makes a bound too tight.
const ANGLE_MARGIN: f32 = 1e-4;

#[inline]
fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

/// cos(max(a - b, 0)) from the sines and cosines of a and b.
#[inline]
fn cos_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b { 1.0 } else { cos_a * cos_b + sin_a * sin_b }
}

/// sin(max(a - b, 0)) from the sines and cosines of a and b.
#[inline]
fn sin_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b { 0.0 } else { sin_a * cos_b - cos_a * sin_b }
}

impl LightBounds {
    /// Bounds of a light occupying box `min..max` that emits around the normals of the
    /// cone (`w`, θo) and up to θe beyond them.
    pub fn new(min: Vec3, max: Vec3, w: Vec3, phi: f32, theta_o: f32, theta_e: f32, two_sided: bool) -> Self {
        LightBounds {
            min,
            max,
            w: w.normalize_or(Vec3::Z),
            phi,
            cos_o: theta_o.min(PI).cos(),
            cos_e: theta_e.min(PI).cos(),
            two_sided,
        }
    }

    /// Centre of the box.
    #[inline]
    pub fn centroid(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// The bounds of both sets.
    pub fn union(&self, o: &LightBounds) -> LightBounds {
        if self.phi <= 0.0 {
            return *o;
        }
        if o.phi <= 0.0 {
            return *self;
        }
        let (w, cos_o) = cone_union(self.w, self.cos_o, o.w, o.cos_o);
        LightBounds {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
            w,
            phi: self.phi + o.phi,
            cos_o,
            cos_e: self.cos_e.min(o.cos_e),
            two_sided: self.two_sided || o.two_sided,
        }
    }

    /// An upper-bound-like estimate of the light's contribution at `p`, whose surface
    /// normal `n` (zero: no surface, or one that transmits) limits what it receives.
    /// Zero only where no light of the set can reach `p` (or reach it from above `n`).
    #[inline]
    pub fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        NodeBounds::from(self).importance(p, n)
    }
}

/// [`LightBounds`] as the tree stores them, with what importance needs precomputed.
#[derive(Clone, Copy, Debug)]
struct NodeBounds {
    center: Vec3,
    /// Radius of the box's bounding sphere.
    radius: f32,
    w: Vec3,
    phi: f32,
    cos_o: f32,
    sin_o: f32,
    cos_e: f32,
    /// cos(θe - θo), or 2 when θe < θo (no direction is lit by every normal).
    cos_e_minus_o: f32,
    two_sided: bool,
}

impl From<&LightBounds> for NodeBounds {
    fn from(b: &LightBounds) -> Self {
        NodeBounds {
            center: b.centroid(),
            radius: (b.max - b.min).length() * 0.5,
            w: b.w,
            phi: b.phi,
            cos_o: b.cos_o,
            sin_o: safe_sqrt(1.0 - b.cos_o * b.cos_o),
            cos_e: b.cos_e,
            cos_e_minus_o: if b.cos_e <= b.cos_o {
                b.cos_e * b.cos_o + safe_sqrt(1.0 - b.cos_e * b.cos_e) * safe_sqrt(1.0 - b.cos_o * b.cos_o)
            } else {
                2.0
            },
            two_sided: b.two_sided,
        }
    }
}

impl NodeBounds {
    /// The conservative importance (see `LightBounds::importance`).
    #[inline]
    fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        self.importance_pair(p, n)[0]
    }

    /// [conservative, pessimistic] importance at (p, n). The conservative one takes the
    /// best cosines any point of the box could have, the pessimistic one the worst (zero
    /// unless every normal of the cone lights p), as Cycles does; choosing children by the
    /// mean of the two normalised measures follows the nearby, well-facing lights better
    /// than the conservative measure alone. The pessimistic one is zero wherever the
    /// conservative one is.
    #[inline]
    fn importance_pair(&self, p: Vec3, n: Vec3) -> [f32; 2] {
        let d = p - self.center;
        let len2 = d.length_squared();
        let len = len2.sqrt();
        // Inside or near the box the distance is no guide: clamp to the box's size.
        let d2 = len2.max(0.25 * self.radius * self.radius).max(1e-12);
        let wi = if len > 0.0 { d / len } else { self.w };

        let mut cos_w = self.w.dot(wi);
        if self.two_sided {
            cos_w = cos_w.abs();
        }
        let sin_w = safe_sqrt(1.0 - cos_w * cos_w);
        // Angle the box subtends from p (its bounding sphere): the whole sphere inside.
        let (sin_b, cos_b) = if len > self.radius {
            let sin_b = self.radius / len;
            (sin_b, safe_sqrt(1.0 - sin_b * sin_b))
        } else {
            (1.0, -1.0)
        };
        // θ' = max(θw - θo - θb, 0): the smallest angle between an emission normal and
        // the direction from any point of the box to p.
        let cos_x = cos_sub_clamped(sin_w, cos_w, self.sin_o, self.cos_o);
        let sin_x = sin_sub_clamped(sin_w, cos_w, self.sin_o, self.cos_o);
        let cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
        if cos_p <= self.cos_e - ANGLE_MARGIN {
            return [0.0; 2];
        }
        // Past the test the set may contribute: keep the estimate positive at grazing angles.
        let mut importance = self.phi * cos_p.max(1e-3) / d2;
        // Pessimistic: θw + θb + θo must stay within θe for every normal to light p.
        let cos_wb = cos_w * cos_b - sin_w * sin_b;
        let mut pessimistic = if cos_w < 0.0 || cos_b < 0.0 || cos_wb < self.cos_e_minus_o {
            0.0
        } else {
            let sin_wb = sin_w * cos_b + cos_w * sin_b;
            self.phi * (cos_wb * self.cos_o - sin_wb * self.sin_o).max(0.0) / d2
        };
        if n != Vec3::ZERO {
            // θi' = max(θi - θb, 0) with θi the angle between n and the centre's direction.
            let cos_i = n.dot(-wi);
            let sin_i = safe_sqrt(1.0 - cos_i * cos_i);
            let cos_pi = cos_sub_clamped(sin_i, cos_i, sin_b, cos_b);
            if cos_pi < -ANGLE_MARGIN {
                return [0.0; 2];
            }
            // A light grazing the horizon still contributes a little: keep it positive.
            importance *= cos_pi.max(1e-3);
            pessimistic *= (cos_i * cos_b - sin_i * sin_b).max(0.0);
        }
        if importance.is_finite() && importance > 0.0 {
            [importance, if pessimistic.is_finite() { pessimistic.clamp(0.0, importance) } else { 0.0 }]
        } else {
            [0.0; 2]
        }
    }
}

/// The bounds of every light of the scene (power from `scene.light_power`); None for
/// lights at infinity (world, suns), which the tree does not hold.
pub fn scene_light_bounds(scene: &Scene) -> Vec<Option<LightBounds>> {
    let half_pi = PI / 2.0;
    scene
        .lights
        .iter()
        .zip(&scene.light_power)
        .map(|(l, &phi)| match l {
            Light::Point { position, .. } => {
                Some(LightBounds::new(*position, *position, Vec3::Z, phi, PI, half_pi, false))
            }
            Light::Spot { position, direction, cos_outer, axes, .. } => {
                // Zero beyond the outer cone for glTF's falloff and Blender's smoothstep alike
                // (beyond the round cone that holds it when the object's scale stretches it).
                let theta = crate::light::spot_cos_bound(*cos_outer, axes).clamp(-1.0, 1.0).acos();
                Some(LightBounds::new(*position, *position, *direction, phi, theta, 0.0, false))
            }
            Light::Sphere { center, radius, spot: None, .. } => {
                let r = Vec3::splat(*radius);
                Some(LightBounds::new(*center - r, *center + r, Vec3::Z, phi, PI, half_pi, false))
            }
            Light::Sphere { center, radius, spot: Some(cone), .. } => {
                // The mask is zero where the direction from the centre leaves the outer
                // cone (outside the sphere, whose box the importance treats as all around).
                let r = Vec3::splat(*radius);
                let theta = cone.cos_bound().clamp(-1.0, 1.0).acos();
                Some(LightBounds::new(*center - r, *center + r, cone.direction, phi, theta, 0.0, false))
            }
            Light::Area(a) => {
                let corners = [a.ax + a.ay, a.ax - a.ay, -a.ax + a.ay, -a.ax - a.ay].map(|c| a.center + c);
                let (lo, hi) =
                    corners.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), c| (lo.min(*c), hi.max(*c)));
                // Nothing is emitted beyond half the spread.
                Some(LightBounds::new(lo, hi, a.normal, phi, 0.0, a.half_spread(), false))
            }
            Light::Triangle { tri } => {
                let m = &scene.mesh;
                let p = m.triangles[*tri as usize].map(|i| m.positions[i as usize]);
                // Both faces emit (`Material::emissive`).
                let n = (p[1] - p[0]).cross(p[2] - p[0]);
                Some(LightBounds::new(p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]), n, phi, 0.0, half_pi, true))
            }
            Light::Directional { .. } | Light::World => None,
        })
        .collect()
}

/// The smallest cone (axis, cos half angle) holding two cones, after pbrt-v4's
/// `DirectionCone` union, widened by a margin against rounding.
fn cone_union(wa: Vec3, cos_a: f32, wb: Vec3, cos_b: f32) -> (Vec3, f32) {
    let theta_a = cos_a.clamp(-1.0, 1.0).acos();
    let theta_b = cos_b.clamp(-1.0, 1.0).acos();
    let theta_d = wa.dot(wb).clamp(-1.0, 1.0).acos();
    if (theta_d + theta_b).min(PI) <= theta_a {
        return (wa, cos_a);
    }
    if (theta_d + theta_a).min(PI) <= theta_b {
        return (wb, cos_b);
    }
    let theta_o = (theta_a + theta_d + theta_b) * 0.5 + ANGLE_MARGIN;
    if theta_o >= PI {
        return (wa, -1.0);
    }
    let theta_r = theta_o - theta_a;
    let axis = wa.cross(wb);
    if axis.length_squared() < 1e-12 {
        return (wa, -1.0);
    }
    let w = (Quat::from_axis_angle(axis.normalize(), theta_r) * wa).normalize();
    (w, theta_o.cos())
}

/// One node: interior nodes have their first child right after them and the second at
/// `index`; leaves name their light in `index`.
#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: NodeBounds,
    index: u32,
    leaf: bool,
}

/// The tree over the bounded lights.
#[derive(Clone, Debug, Default)]
pub struct LightTree {
    nodes: Vec<Node>,
    /// For each light: the choices (bit i set = second child at depth i) leading to its
    /// leaf and the depth, or None when it is not in the tree.
    trail: Vec<Option<(u64, u8)>>,
}

/// The trail of choices is a u64: deeper trees are split by count past this depth.
const MAX_DEPTH: usize = 63;
/// Past this depth the builder splits in the middle by count, which bounds the depth.
const BALANCED_FROM: usize = 32;
const BUCKETS: usize = 12;

impl LightTree {
    /// A tree over the lights with bounds (`None`: not in the tree); indices are the
    /// lights' indices in the scene.
    pub fn build(bounds: &[Option<LightBounds>]) -> Self {
        let mut items: Vec<(LightBounds, u32)> = bounds
            .iter()
            .enumerate()
            .filter_map(|(i, b)| b.filter(|b| b.phi > 0.0 && b.phi.is_finite()).map(|b| (b, i as u32)))
            .collect();
        let mut tree = LightTree { nodes: Vec::with_capacity(2 * items.len()), trail: vec![None; bounds.len()] };
        if !items.is_empty() {
            tree.build_node(&mut items, 0, 0);
        }
        tree
    }

    /// True when no light is in the tree.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Total power in the tree.
    pub fn power(&self) -> f32 {
        self.nodes.first().map_or(0.0, |n| n.bounds.phi)
    }

    fn build_node(&mut self, items: &mut [(LightBounds, u32)], depth: usize, trail: u64) -> LightBounds {
        assert!(depth < MAX_DEPTH, "light tree deeper than its trail");
        if items.len() == 1 {
            let (b, light) = items[0];
            self.nodes.push(Node { bounds: (&b).into(), index: light, leaf: true });
            self.trail[light as usize] = Some((trail, depth as u8));
            return b;
        }
        let mid = if depth >= BALANCED_FROM { split_by_count(items) } else { split_by_cost(items) };
        let me = self.nodes.len();
        self.nodes.push(Node { bounds: (&items[0].0).into(), index: 0, leaf: false });
        let (left, right) = items.split_at_mut(mid);
        let lb = self.build_node(left, depth + 1, trail);
        let second = self.nodes.len() as u32;
        let rb = self.build_node(right, depth + 1, trail | (1u64 << depth));
        let b = lb.union(&rb);
        self.nodes[me] = Node { bounds: (&b).into(), index: second, leaf: false };
        b
    }

    /// The two children and the probabilities of choosing each at (p, n) (both 0 when
    /// neither can light the point).
    #[inline]
    fn child_importance(&self, node: usize, p: Vec3, n: Vec3) -> (usize, usize, f32, f32) {
        let (a, b) = (node + 1, self.nodes[node].index as usize);
        let ([ia, ma], [ib, mb]) =
            (self.nodes[a].bounds.importance_pair(p, n), self.nodes[b].bounds.importance_pair(p, n));
        let total = ia + ib;
        if !(total > 0.0) {
            return (a, b, 0.0, 0.0);
        }
        // Mean of the two normalised measures; a child of zero conservative importance
        // has zero pessimistic importance too, so it is never chosen.
        let p_max = ia / total;
        let m = ma + mb;
        let p_min = if m > 0.0 { ma / m } else { p_max };
        let pa = 0.5 * (p_max + p_min);
        (a, b, pa, 1.0 - pa)
    }

    /// Picks a light for the shading point `p` with normal `n` (zero: none): its index
    /// and probability; None when no light of the tree can reach the point.
    #[inline]
    pub fn sample(&self, p: Vec3, n: Vec3, mut u: f32) -> Option<(usize, f32)> {
        let root = self.nodes.first()?;
        if root.leaf {
            return (root.bounds.importance(p, n) > 0.0).then_some((root.index as usize, 1.0));
        }
        let mut node = 0usize;
        let mut pmf = 1.0f32;
        loop {
            let nd = &self.nodes[node];
            if nd.leaf {
                return Some((nd.index as usize, pmf));
            }
            let (a, b, ia, ib) = self.child_importance(node, p, n);
            let total = ia + ib;
            if !(total > 0.0) {
                return None;
            }
            let pa = ia / total;
            if u < pa {
                u = (u / pa).min(ONE_MINUS_EPS);
                pmf *= pa;
                node = a;
            } else {
                u = ((u - pa) / (1.0 - pa)).clamp(0.0, ONE_MINUS_EPS);
                pmf *= 1.0 - pa;
                node = b;
            }
        }
    }

    /// Probability that `sample(p, n, ·)` picks `light`.
    #[inline]
    pub fn pmf(&self, p: Vec3, n: Vec3, light: usize) -> f32 {
        let Some(Some((trail, depth))) = self.trail.get(light) else {
            return 0.0;
        };
        let root = &self.nodes[0];
        if root.leaf {
            return if root.bounds.importance(p, n) > 0.0 { 1.0 } else { 0.0 };
        }
        let mut node = 0usize;
        let mut pmf = 1.0f32;
        for level in 0..*depth as usize {
            let (a, b, ia, ib) = self.child_importance(node, p, n);
            let total = ia + ib;
            if !(total > 0.0) {
                return 0.0;
            }
            let pa = ia / total;
            if trail & (1u64 << level) == 0 {
                pmf *= pa;
                node = a;
            } else {
                pmf *= 1.0 - pa;
                node = b;
            }
        }
        pmf
    }

    /// Probability that `sample(p, n, ·)` finds no light: it reached a node whose
    /// children both have zero importance (the union of their bounds is looser than
    /// either), or no light reaches the point. The lights' pmfs sum to 1 minus this.
    pub fn failure_probability(&self, p: Vec3, n: Vec3) -> f32 {
        fn walk(t: &LightTree, node: usize, p: Vec3, n: Vec3) -> f64 {
            if t.nodes[node].leaf {
                return 0.0;
            }
            let (a, b, ia, ib) = t.child_importance(node, p, n);
            let total = ia + ib;
            if !(total > 0.0) {
                return 1.0;
            }
            let pa = ia / total;
            let fa = if pa > 0.0 { pa as f64 * walk(t, a, p, n) } else { 0.0 };
            let fb = if pa < 1.0 { (1.0 - pa) as f64 * walk(t, b, p, n) } else { 0.0 };
            fa + fb
        }
        match self.nodes.first() {
            None => 1.0,
            Some(r) if r.leaf => (r.bounds.importance(p, n) <= 0.0) as u8 as f32,
            Some(_) => walk(self, 0, p, n) as f32,
        }
    }

    /// Depth of the deepest leaf (for tests and reports).
    pub fn depth(&self) -> usize {
        self.trail.iter().flatten().map(|&(_, d)| d as usize).max().unwrap_or(0)
    }
}

const ONE_MINUS_EPS: f32 = 0.999_999_94;

/// Splits in the middle by count along the widest axis of the centroids.
fn split_by_count(items: &mut [(LightBounds, u32)]) -> usize {
    let (lo, hi) = centroid_bounds(items);
    let axis = (hi - lo).max_position();
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |a, b| a.0.centroid()[axis].total_cmp(&b.0.centroid()[axis]));
    mid
}

fn centroid_bounds(items: &[(LightBounds, u32)]) -> (Vec3, Vec3) {
    items.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), (b, _)| {
        let c = b.centroid();
        (lo.min(c), hi.max(c))
    })
}

/// pbrt-v4's cost of a node: power × the solid angle its normals spread over × area,
/// with a penalty for thin boxes split along their short side.
fn cost(b: &LightBounds, extent: Vec3, axis: usize) -> f32 {
    let theta_o = b.cos_o.clamp(-1.0, 1.0).acos();
    let theta_e = b.cos_e.clamp(-1.0, 1.0).acos();
    let theta_w = (theta_o + theta_e).min(PI);
    let sin_o = safe_sqrt(1.0 - b.cos_o * b.cos_o);
    let m_omega = 2.0 * PI * (1.0 - b.cos_o)
        + PI / 2.0 * (2.0 * theta_w * sin_o - (theta_o - 2.0 * theta_w).cos() - 2.0 * theta_o * sin_o + b.cos_o);
    let kr = extent.max_element() / extent[axis].max(1e-12);
    let d = b.max - b.min;
    let area = 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
    // A point light has no area: count a tiny one so that power still matters.
    b.phi * m_omega * kr * area.max(1e-12 * extent.max_element().powi(2).max(1e-12))
}

/// Splits by the lowest bucketed cost over the three axes; by count when nothing helps.
fn split_by_cost(items: &mut [(LightBounds, u32)]) -> usize {
    let (lo, hi) = centroid_bounds(items);
    let extent = hi - lo;
    let all = items.iter().skip(1).fold(items[0].0, |acc, (b, _)| acc.union(b));
    let node_extent = (all.max - all.min).max(Vec3::splat(1e-12));
    let mut best: Option<(f32, usize, usize)> = None;
    for axis in 0..3 {
        if !(extent[axis] > 0.0) {
            continue;
        }
        let bucket_of = |b: &LightBounds| {
            let t = (b.centroid()[axis] - lo[axis]) / extent[axis];
            ((t * BUCKETS as f32) as usize).min(BUCKETS - 1)
        };
        let mut buckets: [Option<LightBounds>; BUCKETS] = [None; BUCKETS];
        for (b, _) in items.iter() {
            let k = bucket_of(b);
            buckets[k] = Some(buckets[k].map_or(*b, |acc| acc.union(b)));
        }
        for split in 1..BUCKETS {
            let merge = |r: &[Option<LightBounds>]| {
                r.iter().flatten().fold(None, |acc: Option<LightBounds>, b| Some(acc.map_or(*b, |a| a.union(b))))
            };
            let (Some(l), Some(r)) = (merge(&buckets[..split]), merge(&buckets[split..])) else {
                continue;
            };
            let c = cost(&l, node_extent, axis) + cost(&r, node_extent, axis);
            if best.is_none_or(|(bc, _, _)| c < bc) {
                best = Some((c, axis, split));
            }
        }
    }
    let Some((_, axis, split)) = best else {
        return split_by_count(items);
    };
    let t = |b: &LightBounds| {
        let t = (b.centroid()[axis] - lo[axis]) / extent[axis];
        ((t * BUCKETS as f32) as usize).min(BUCKETS - 1) < split
    };
    // Partition in place: lights of the first buckets first.
    let mut mid = 0;
    for i in 0..items.len() {
        if t(&items[i].0) {
            items.swap(i, mid);
            mid += 1;
        }
    }
    if mid == 0 || mid == items.len() { split_by_count(items) } else { mid }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cone_union_contains_both_cones() {
        let mut rng = crate::sampling::chi2::Pcg32::new(3);
        let mut dir = || {
            let z = 2.0 * rng.next_f32() - 1.0;
            let phi = 2.0 * PI * rng.next_f32();
            let r = safe_sqrt(1.0 - z * z);
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        };
        for _ in 0..10_000 {
            let (wa, wb) = (dir(), dir());
            let (ca, cb) = (dir().z, dir().z);
            let (w, c) = cone_union(wa, ca, wb, cb);
            // Each cone's axis plus its half angle must fit inside the union.
            let inside = |wx: Vec3, cx: f32| {
                let theta = w.dot(wx).clamp(-1.0, 1.0).acos() + cx.clamp(-1.0, 1.0).acos();
                theta <= c.clamp(-1.0, 1.0).acos() + 1e-3 || c <= -1.0
            };
            assert!(inside(wa, ca) && inside(wb, cb), "{wa} {ca} {wb} {cb} -> {w} {c}");
        }
    }

    #[test]
    fn balanced_depth_for_many_identical_lights() {
        // Identical centroids defeat cost splits: the count split must keep the depth low.
        let b = LightBounds::new(Vec3::ZERO, Vec3::ONE, Vec3::Z, 1.0, 0.0, PI / 2.0, false);
        let t = LightTree::build(&vec![Some(b); 1000]);
        assert!(t.depth() <= 10, "depth {}", t.depth());
    }
}
