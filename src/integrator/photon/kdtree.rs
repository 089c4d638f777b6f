//! A balanced kd-tree over photons. The photons are reordered so that every node's
//! range [lo, hi) is contiguous: its median m = (lo + hi) / 2 splits it into [lo, m)
//! (coordinates ≤ the median's) and [m, hi) (≥ it), the split axis being that of the
//! largest extent of the range's bounds. Ranges of at most `LEAF` (16) photons are
//! leaves. All photons live in leaves; the internal
//! nodes are a separate array of split planes (8 bytes each) in heap order (children of
//! node i: 2i + 1, 2i + 2), so a traversal reads only that small array (~0.5 byte per
//! photon) until it reaches a leaf.
//!
//! Why the planes apart: a profile of Jensen PM on the Cornell box (perf, 1 thread)
//! showed the k-NN query as ~60 % of the render, a third of it on one line, the load of
//! the median photon at each internal node of Jensen's layout (photons at internal
//! nodes, 32 bytes each, spread over the 12 MB map: a cache miss per level). The
//! planes' array fits in the L2 cache; see `docs/benchmarks.md` for the figures.
//!
//! Queries: k nearest neighbours within a maximum radius, with a filter (e.g. normal
//! and depth), into a fixed-size max-heap on the stack; and "every photon within r".
//! Both walk the tree with a fixed-size explicit stack: no allocation, no locks.
//!
//! Build: median selection per level (`select_nth_unstable_by`), O(n log n), the two
//! halves built in parallel with `rayon::join` above 16 384 photons; the result depends
//! only on the input order, so it is the same for any thread count. The planes are read
//! back from the ordered photons (O(nodes)), which is also how a map file's tree order
//! is turned back into a tree.
//!
//! Why not the `kiddo` crate: its trees store points and items apart (more bytes per
//! photon) and it is not in the project's dependency set; this tree is ~200 lines and
//! measured by `caustic bench --integrator photon`.

use super::{MAX_K, Photon};
use glam::Vec3;

/// Depth of the explicit traversal stack: a balanced tree of 2^40 photons.
const STACK: usize = 64;

/// Ranges of at most this many photons are leaves, scanned linearly: they are
/// contiguous in memory, which saves the cache misses of the last levels. k-NN
/// queries per second (k = 20, Cornell box, `caustic bench`, 1 thread) with leaves of
/// 8 / 16 / 32 / 64: 0.200 / 0.288 / 0.281 / 0.290 M.
pub(crate) const LEAF: usize = 16;

/// Photons in kd-tree order, and the internal nodes' split planes.
#[derive(Clone, Debug, Default)]
pub struct PhotonMap {
    photons: Vec<Photon>,
    /// Each photon's light group (`scene::light_groups`), in the photons' order; empty
    /// when the render asks for no light groups (every photon then in none).
    groups: Vec<u8>,
    /// Split plane of internal node i (heap order); unused slots (children of leaves)
    /// are never read.
    planes: Vec<Plane>,
}

/// An internal node's split plane.
#[derive(Clone, Copy, Debug, Default)]
struct Plane {
    value: f32,
    axis: u32,
}

/// The k nearest photons found by [`PhotonMap::knn`]: (squared distance, index) in
/// max-heap order (the farthest first).
pub struct KnnResult {
    items: [(f32, u32); MAX_K],
    len: usize,
    k: usize,
}

impl KnnResult {
    /// An empty result for `k` neighbours (k clamped to 1..=MAX_K).
    #[inline]
    pub fn new(k: usize) -> Self {
        KnnResult { items: [(0.0, 0); MAX_K], len: 0, k: k.clamp(1, MAX_K) }
    }

    /// Found photons: (squared distance, photon index), in heap order.
    #[inline]
    pub fn items(&self) -> &[(f32, u32)] {
        &self.items[..self.len]
    }

    /// True when k photons were found.
    #[inline]
    pub fn full(&self) -> bool {
        self.len == self.k
    }

    /// Squared distance of the farthest photon kept.
    #[inline]
    pub fn max_d2(&self) -> f32 {
        if self.len == 0 { 0.0 } else { self.items[0].0 }
    }

    #[inline]
    fn push(&mut self, d2: f32, i: u32) {
        if self.len < self.k {
            // Sift up.
            let mut c = self.len;
            self.len += 1;
            while c > 0 {
                let parent = (c - 1) / 2;
                if self.items[parent].0 >= d2 {
                    break;
                }
                self.items[c] = self.items[parent];
                c = parent;
            }
            self.items[c] = (d2, i);
        } else if d2 < self.items[0].0 {
            // Replace the root and sift down.
            let n = self.len;
            let mut c = 0;
            loop {
                let l = 2 * c + 1;
                if l >= n {
                    break;
                }
                let r = l + 1;
                let big = if r < n && self.items[r].0 > self.items[l].0 { r } else { l };
                if self.items[big].0 <= d2 {
                    break;
                }
                self.items[c] = self.items[big];
                c = big;
            }
            self.items[c] = (d2, i);
        }
    }
}

impl PhotonMap {
    /// Builds the tree, reordering the photons.
    pub fn build(mut photons: Vec<Photon>) -> Self {
        build_range(&mut photons);
        Self::from_tree_order(photons)
    }

    /// Builds the tree with each photon's light group (`groups[i]` is photon i's), which
    /// moves with its photon: the photons end in the order [`build`](Self::build) gives
    /// (the same comparisons on the same positions).
    pub fn build_grouped(photons: Vec<Photon>, groups: Vec<u8>) -> Self {
        if groups.len() != photons.len() {
            // Untagged photons (no light groups asked): the plain tree.
            return Self::build(photons);
        }
        let mut tagged: Vec<(Photon, u8)> = photons.into_iter().zip(groups).collect();
        build_range(&mut tagged);
        let (photons, groups) = tagged.into_iter().unzip();
        PhotonMap { groups, ..Self::from_tree_order(photons) }
    }

    /// Wraps photons that are already in tree order (from a map file): reads the
    /// split planes back from them.
    pub(crate) fn from_tree_order(photons: Vec<Photon>) -> Self {
        // Heap slots for the deepest level: the largest range halves (rounding up)
        // until it is a leaf.
        let (mut size, mut levels) = (photons.len(), 0u32);
        while size > LEAF {
            size = size.div_ceil(2);
            levels += 1;
        }
        let mut planes = vec![Plane::default(); (1usize << levels) - 1];
        fill_planes(&photons, &mut planes, 0, 0, photons.len());
        PhotonMap { photons, groups: Vec::new(), planes }
    }

    /// The light group of photon `i` (tree order), or `light_groups::NONE`.
    #[inline]
    pub fn group(&self, i: u32) -> u8 {
        self.groups.get(i as usize).copied().unwrap_or(crate::scene::light_groups::NONE)
    }

    /// The photons in tree order.
    pub fn photons(&self) -> &[Photon] {
        &self.photons
    }

    /// Number of photons.
    pub fn len(&self) -> usize {
        self.photons.len()
    }

    /// True when the map holds no photon.
    pub fn is_empty(&self) -> bool {
        self.photons.is_empty()
    }

    /// Bytes used by the photons and the split planes.
    pub fn bytes(&self) -> usize {
        self.photons.len() * std::mem::size_of::<Photon>() + self.planes.len() * std::mem::size_of::<Plane>()
    }

    /// The (at most) `out.k` photons nearest to `q` within squared radius `max_d2`
    /// that pass `accept`.
    #[inline]
    pub fn knn(&self, q: Vec3, max_d2: f32, accept: impl Fn(&Photon) -> bool, out: &mut KnnResult) {
        out.len = 0;
        if self.photons.is_empty() {
            return;
        }
        let q = q.to_array();
        // (node, lo, hi, squared distance of q to the range's splitting plane)
        let mut stack = [(0u32, 0u32, 0u32, 0f32); STACK];
        let mut sp = 0;
        stack[sp] = (0, 0, self.photons.len() as u32, 0.0);
        sp += 1;
        while sp > 0 {
            sp -= 1;
            let (node, lo, hi, plane_d2) = stack[sp];
            let bound = if out.full() { out.max_d2() } else { max_d2 };
            if plane_d2 >= bound {
                continue;
            }
            let (lo, hi) = (lo as usize, hi as usize);
            if hi - lo <= LEAF {
                for (i, ph) in self.photons[lo..hi].iter().enumerate() {
                    let d2 = dist2(ph.p, q);
                    let bound = if out.full() { out.max_d2() } else { max_d2 };
                    if d2 < bound && accept(ph) {
                        out.push(d2, (lo + i) as u32);
                    }
                }
                continue;
            }
            let m = (lo + hi) / 2;
            let plane = self.planes[node as usize];
            let diff = q[plane.axis as usize] - plane.value;
            let (l, r) = (2 * node + 1, 2 * node + 2);
            let (near, far) = if diff < 0.0 { ((l, lo, m), (r, m, hi)) } else { ((r, m, hi), (l, lo, m)) };
            // Far first on the stack, so the near side is searched first.
            if sp + 2 <= STACK {
                stack[sp] = (far.0, far.1 as u32, far.2 as u32, diff * diff);
                stack[sp + 1] = (near.0, near.1 as u32, near.2 as u32, plane_d2.min(0.0));
                sp += 2;
            }
        }
    }

    /// Calls `f` with every photon within squared radius `r2` of `q`, its index (tree order,
    /// as [`group`](Self::group) takes) and its squared distance.
    #[inline]
    pub fn for_each_within(&self, q: Vec3, r2: f32, mut f: impl FnMut(&Photon, u32, f32)) {
        if self.photons.is_empty() {
            return;
        }
        let q = q.to_array();
        let mut stack = [(0u32, 0u32, 0u32); STACK];
        let mut sp = 0;
        stack[sp] = (0, 0, self.photons.len() as u32);
        sp += 1;
        while sp > 0 {
            sp -= 1;
            let (node, lo, hi) = stack[sp];
            let (lo, hi) = (lo as usize, hi as usize);
            if hi - lo <= LEAF {
                for (k, ph) in self.photons[lo..hi].iter().enumerate() {
                    let d2 = dist2(ph.p, q);
                    if d2 < r2 {
                        f(ph, (lo + k) as u32, d2);
                    }
                }
                continue;
            }
            let m = (lo + hi) / 2;
            let plane = self.planes[node as usize];
            let diff = q[plane.axis as usize] - plane.value;
            // Left subtree holds coordinates <= the plane's, right >= it.
            if (diff <= 0.0 || diff * diff < r2) && sp < STACK {
                stack[sp] = (2 * node + 1, lo as u32, m as u32);
                sp += 1;
            }
            if (diff >= 0.0 || diff * diff < r2) && sp < STACK {
                stack[sp] = (2 * node + 2, m as u32, hi as u32);
                sp += 1;
            }
        }
    }
}

#[inline]
fn dist2(p: [f32; 3], q: [f32; 3]) -> f32 {
    let (dx, dy, dz) = (p[0] - q[0], p[1] - q[1], p[2] - q[2]);
    dx * dx + dy * dy + dz * dz
}

/// Parallel build above this many photons.
const PARALLEL_BUILD: usize = 16_384;

/// What the tree build orders: a photon, or a photon with a tag that moves with it.
trait Placed: Send {
    /// The photon's position.
    fn at(&self) -> Vec3;
}

impl Placed for Photon {
    #[inline]
    fn at(&self) -> Vec3 {
        self.pos()
    }
}

impl Placed for (Photon, u8) {
    #[inline]
    fn at(&self) -> Vec3 {
        self.0.pos()
    }
}

fn build_range<T: Placed>(ph: &mut [T]) {
    if ph.len() <= LEAF {
        return;
    }
    let axis = split_axis(ph);
    let m = ph.len() / 2;
    ph.select_nth_unstable_by(m, |a, b| a.at()[axis].total_cmp(&b.at()[axis]));
    let (left, right) = ph.split_at_mut(m);
    if left.len() + right.len() > PARALLEL_BUILD {
        rayon::join(|| build_range(left), || build_range(right));
    } else {
        build_range(left);
        build_range(right);
    }
}

/// Reads node `node`'s plane (range [lo, hi)) and its descendants' from photons in tree
/// order: the axis is the build's (largest extent of the range's bounds, a property of the
/// set, not of its order), the value the largest coordinate of the left half, which
/// separates it from the right half as the build's median did.
fn fill_planes(ph: &[Photon], planes: &mut [Plane], node: usize, lo: usize, hi: usize) {
    if hi - lo <= LEAF {
        return;
    }
    let axis = split_axis(&ph[lo..hi]);
    let m = (lo + hi) / 2;
    let value = ph[lo..m].iter().fold(f32::NEG_INFINITY, |v, p| v.max(p.p[axis]));
    planes[node] = Plane { value, axis: axis as u32 };
    fill_planes(ph, planes, 2 * node + 1, lo, m);
    fill_planes(ph, planes, 2 * node + 2, m, hi);
}

/// The axis of the largest extent of the photons' bounds.
fn split_axis<T: Placed>(ph: &[T]) -> usize {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in ph {
        lo = lo.min(p.at());
        hi = hi.max(p.at());
    }
    let ext = hi - lo;
    if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::hash_combine;

    fn rnd(seed: u32, i: u32) -> f32 {
        hash_combine(&[seed, i]) as f32 / u32::MAX as f32
    }

    /// Random point sets (with duplicates and clusters), random queries, every k
    /// including k > n: the tree's neighbour distances equal a brute-force scan's.
    #[test]
    fn knn_equals_brute_force() {
        for seed in 0..60u32 {
            let n = (rnd(seed, 9999) * 3000.0) as usize + 1;
            let mut pts = Vec::with_capacity(n);
            for i in 0..n as u32 {
                let p = if i % 7 == 3 && !pts.is_empty() {
                    // A duplicate of an earlier point.
                    let j = (rnd(seed, i + 50_000) * pts.len() as f32) as usize;
                    let prev: &Photon = &pts[j.min(pts.len() - 1)];
                    prev.pos()
                } else if seed % 3 == 0 {
                    // Points on a plane: one axis of zero extent.
                    Vec3::new(rnd(seed, 3 * i), 0.5, rnd(seed, 3 * i + 1))
                } else {
                    Vec3::new(rnd(seed, 3 * i), rnd(seed, 3 * i + 1), rnd(seed, 3 * i + 2))
                };
                pts.push(Photon::new(p, Vec3::splat(i as f32), Vec3::Z, Vec3::Z, 1 + i % 3, false));
            }
            let map = PhotonMap::build(pts.clone());
            assert_eq!(map.len(), n);
            for qi in 0..40u32 {
                let q = Vec3::new(
                    rnd(seed ^ 77, 3 * qi) * 1.2 - 0.1,
                    rnd(seed ^ 77, 3 * qi + 1) * 1.2 - 0.1,
                    rnd(seed ^ 77, 3 * qi + 2) * 1.2 - 0.1,
                );
                let k = [1usize, 5, 50, n, n + 10][(qi % 5) as usize].min(MAX_K);
                let max_d2 = if qi % 2 == 0 { f32::INFINITY } else { 0.05 };
                let filter_depth = qi % 3 == 0;
                let accept = |p: &Photon| !filter_depth || p.depth() != 2;
                let mut res = KnnResult::new(k);
                map.knn(q, max_d2, accept, &mut res);
                let mut got: Vec<f32> = res.items().iter().map(|x| x.0).collect();
                got.sort_by(f32::total_cmp);
                let mut want: Vec<f32> = pts
                    .iter()
                    .filter(|p| accept(p))
                    .map(|p| (p.pos() - q).length_squared())
                    .filter(|&d| d < max_d2)
                    .collect();
                want.sort_by(f32::total_cmp);
                want.truncate(k);
                assert_eq!(got.len(), want.len(), "seed {seed} query {qi} k {k}");
                for (a, b) in got.iter().zip(&want) {
                    assert!((a - b).abs() <= 1e-6 * b.max(1e-6), "seed {seed}: {a} vs {b}");
                }
                // The reported indices point at photons at those distances.
                for &(d2, i) in res.items() {
                    let p = &map.photons()[i as usize];
                    assert!(accept(p));
                    assert!(((p.pos() - q).length_squared() - d2).abs() <= 1e-6);
                }
                // Range query: the same set as a brute-force scan.
                let r2 = 0.02;
                let mut count = 0usize;
                let mut sum = 0.0f64;
                map.for_each_within(q, r2, |p, _, _| {
                    count += 1;
                    sum += p.power[0] as f64;
                });
                let (bc, bs) = pts
                    .iter()
                    .filter(|p| dist2(p.p, q.to_array()) < r2)
                    .fold((0usize, 0.0f64), |(c, s), p| (c + 1, s + p.power[0] as f64));
                assert_eq!((count, sum), (bc, bs), "range query, seed {seed}");
            }
        }
    }

    #[test]
    fn groups_move_with_their_photons() {
        // Power i marks photon i; its group is i % 5. Duplicated positions test the order of ties.
        let pts: Vec<Photon> = (0..2000u32)
            .map(|i| {
                let p = Vec3::new(rnd(7, 3 * (i / 2)), rnd(7, 3 * (i / 2) + 1), rnd(7, 3 * (i / 2) + 2));
                Photon::new(p, Vec3::splat(i as f32), Vec3::Z, Vec3::Z, 1, false)
            })
            .collect();
        let groups: Vec<u8> = (0..2000u32).map(|i| (i % 5) as u8).collect();
        let plain = PhotonMap::build(pts.clone());
        let grouped = PhotonMap::build_grouped(pts, groups);
        assert_eq!(plain.photons(), grouped.photons(), "the same tree order");
        for (i, p) in grouped.photons().iter().enumerate() {
            assert_eq!(grouped.group(i as u32), (p.power[0] as u32 % 5) as u8);
        }
        assert_eq!(plain.group(0), crate::scene::light_groups::NONE);
    }

    #[test]
    fn empty_map_finds_nothing() {
        let map = PhotonMap::build(Vec::new());
        let mut res = KnnResult::new(5);
        map.knn(Vec3::ZERO, 1.0, |_| true, &mut res);
        assert!(res.items().is_empty());
    }
}
