//! Which triangles another surface touches: the coincident-surface look back
//! (`walk::PathState::coincident_hit`) can find a surface only within a few origin
//! offsets of the triangle a ray leaves, and only one facing the other way, so it runs
//! only from triangles flagged here, and only from points of them within the reach of an
//! opposite-facing triangle's box (a floor under a resting glass looks back only around
//! the glass's foot: callgrind on the glass caustic bench scene put the floor's look
//! backs at 7 % of the render's instructions). Computed once per BVH build with a uniform
//! grid (cells about twice the median triangle size): O(n log n) for the sort of the cell
//! entries, plus the pairs that share a cell.

use glam::Vec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};

/// A triangle's entry in [`Touching::slot`]: no opposite-facing triangle within reach.
pub const NEVER: u32 = u32::MAX;

/// A triangle's entry in [`Touching::slot`]: look back from every point (nothing could be
/// ruled out: a corner is not finite).
pub const ALWAYS: u32 = u32::MAX - 1;

/// Which triangles another surface touches, and where.
pub struct Touching {
    /// Per triangle: [`NEVER`], [`ALWAYS`], or its box in `regions`.
    pub slot: Vec<u32>,
    /// Boxes (min, max) outside which a point of the triangle has no opposite-facing
    /// triangle within the look back's reach: the bounding box of the partners' boxes
    /// grown by the reach, clipped to the triangle's own grown box.
    pub regions: Vec<[Vec3; 2]>,
}

impl Touching {
    /// Whether the look back from point `p` of the triangle with entry `slot` can find a
    /// surface (a non-finite `p` looks).
    #[inline]
    pub fn may_touch_at(&self, slot: u32, p: Vec3) -> bool {
        match slot {
            NEVER => false,
            ALWAYS => true,
            k => {
                let [lo, hi] = self.regions[k as usize];
                !(p.cmplt(lo).any() || p.cmpgt(hi).any())
            }
        }
    }
}

/// An order-preserving u32 key of a float (for atomic min and max): negative floats
/// reversed below the positive ones.
fn order_key(x: f32) -> u32 {
    let b = x.to_bits();
    if b >> 31 == 1 { !b } else { b | 0x8000_0000 }
}

/// The float of an [`order_key`].
fn from_order_key(k: u32) -> f32 {
    f32::from_bits(if k >> 31 == 1 { k & 0x7fff_ffff } else { !k })
}

/// Triangles spanning more cells than this are tested against every triangle instead
/// of being entered in each cell (a floor of two triangles under a million-triangle
/// model would otherwise fill the grid).
const MAX_CELLS: i64 = 64;

/// Per-axis distance from a point on a triangle whose coordinates are at most `m` in
/// magnitude within which the look back can meet a surface. The look back offsets by at
/// most `b = 2 max(256 ulp(m), 1/65536)` per axis (`walk.rs`) and runs at most 20 spans
/// of 2|offset| <= 2 sqrt(3) b: b + 40 sqrt(3) b < 70.3 b; 72 b leaves room for the
/// rounding of the point inside the triangle's box (m is taken 1e-4 larger).
pub(crate) fn reach(m: f32) -> f32 {
    72.0 * 2.0 * (m * 1.0001 * (256.0 * f32::EPSILON)).max(1.0 / 65536.0)
}

/// For each triangle, whether a triangle facing the other way (the look back's own test,
/// on the same f32 winding) has its box within [`reach`] of the triangle's box, and the
/// region of the triangle where one does. Every triangle is [`ALWAYS`] when any corner is
/// not finite (nothing can be ruled out).
pub fn touching(tris: &[[Vec3; 3]]) -> Touching {
    let n = tris.len();
    if tris.iter().any(|t| !t.iter().all(|v| v.is_finite())) {
        return Touching { slot: vec![ALWAYS; n], regions: Vec::new() };
    }
    if n < 2 {
        return Touching { slot: vec![NEVER; n], regions: Vec::new() };
    }
    // (box min, box max, reach), winding as walk.rs computes it.
    let boxes: Vec<(Vec3, Vec3, f32)> = tris
        .par_iter()
        .map(|t| {
            let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
            (lo, hi, reach(lo.abs().max(hi.abs()).max_element()))
        })
        .collect();
    let winding: Vec<Vec3> = tris.par_iter().map(|[a, b, c]| (*b - *a).cross(*c - *a)).collect();
    let mut sizes: Vec<f32> = boxes.par_iter().map(|(lo, hi, r)| (*hi - *lo).max_element() + 2.0 * r).collect();
    let mid = n / 2;
    let cell = 2.0 * *sizes.select_nth_unstable_by(mid, f32::total_cmp).1;
    drop(sizes);
    let origin = boxes.iter().fold(Vec3::INFINITY, |m, b| m.min(b.0 - b.2));
    let coord = |v: f32, o: f32| ((v - o) / cell).floor() as i64;
    // Cells of each triangle's box grown by its reach: two triangles whose grown boxes
    // overlap share a cell. Keys wrap at 2^21 per axis; a wrapped key only adds pairs.
    let spans: Vec<Option<([i64; 3], [i64; 3])>> = boxes
        .par_iter()
        .map(|(lo, hi, r)| {
            let a = [coord(lo.x - r, origin.x), coord(lo.y - r, origin.y), coord(lo.z - r, origin.z)];
            let b = [coord(hi.x + r, origin.x), coord(hi.y + r, origin.y), coord(hi.z + r, origin.z)];
            let count = (0..3).map(|k| b[k] - a[k] + 1).fold(1i64, |p, c| p.saturating_mul(c));
            (count <= MAX_CELLS).then_some((a, b))
        })
        .collect();
    let key = |x: i64, y: i64, z: i64| {
        (x as u64 & 0x1f_ffff) | ((y as u64 & 0x1f_ffff) << 21) | ((z as u64 & 0x1f_ffff) << 42)
    };
    let mut entries: Vec<(u64, u32)> = spans
        .par_iter()
        .enumerate()
        .flat_map_iter(|(i, s)| {
            s.iter().flat_map(move |(a, b)| {
                (a[0]..=b[0]).flat_map(move |x| {
                    (a[1]..=b[1]).flat_map(move |y| (a[2]..=b[2]).map(move |z| (key(x, y, z), i as u32)))
                })
            })
        })
        .collect();
    entries.par_sort_unstable();
    // Per triangle, its region's min and max as atomic keys (empty: min above max).
    let region: Vec<[AtomicU32; 6]> = (0..n)
        .map(|_| {
            let (lo, hi) = (order_key(f32::INFINITY), order_key(f32::NEG_INFINITY));
            [lo, lo, lo, hi, hi, hi].map(AtomicU32::new)
        })
        .collect();
    // Where i can look back and meet j (both grown boxes), when j faces the other way and
    // their grown boxes meet. The look back goes on only past a hit facing the other way;
    // the same negated test keeps a NaN winding (a degenerate triangle) on the side of looking.
    let meets = |i: usize, j: usize| -> Option<(Vec3, Vec3)> {
        let ((li, hi, ri), (lj, hj, rj)) = (boxes[i], boxes[j]);
        let r = ri.max(rj);
        if winding[i].dot(winding[j]) >= 0.0 || !((li - r).cmple(hj).all() && (lj - r).cmple(hi).all()) {
            return None;
        }
        Some(((li - r).max(lj - r), (hi + r).min(hj + r)))
    };
    // A triangle's partners' region, summed locally, is merged into its atomic keys once.
    let merge = |t: usize, (lo, up): (Vec3, Vec3)| {
        for k in 0..3 {
            region[t][k].fetch_min(order_key(lo[k]), Ordering::Relaxed);
            region[t][3 + k].fetch_max(order_key(up[k]), Ordering::Relaxed);
        }
    };
    let gather = |i: usize, partners: &mut dyn Iterator<Item = usize>| {
        let mut acc: Option<(Vec3, Vec3)> = None;
        for j in partners {
            if let Some((lo, up)) = meets(i, j) {
                acc = Some(acc.map_or((lo, up), |(a, b)| (a.min(lo), b.max(up))));
            }
        }
        if let Some(a) = acc {
            merge(i, a);
        }
    };
    // Runs of equal keys: the triangles of one cell. Their pairs are swept along x (each box
    // grown by its own reach, whose overlap every pair that meets has), so pairs apart along x
    // are never tested: cells can hold hundreds of triangles (24_gpu_instancing: a median of
    // 349, 29 G pairs in all). Each pair met is summed into both triangles' local regions,
    // merged into the atomic keys once per cell.
    let starts: Vec<usize> =
        (0..entries.len()).filter(|&k| k == 0 || entries[k].0 != entries[k - 1].0).chain([entries.len()]).collect();
    starts.par_windows(2).for_each(|w| {
        let cell = &entries[w[0]..w[1]];
        if one_way(cell.iter().map(|&(_, i)| winding[i as usize])) {
            return;
        }
        let mut order: Vec<(f32, f32, usize)> = cell
            .iter()
            .map(|&(_, i)| {
                let (lo, hi, r) = boxes[i as usize];
                (lo.x - r, hi.x + r, i as usize)
            })
            .collect();
        order.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let mut acc: Vec<Option<(Vec3, Vec3)>> = vec![None; order.len()];
        let mut add = |k: usize, (lo, up): (Vec3, Vec3)| {
            acc[k] = Some(acc[k].map_or((lo, up), |(a, b)| (a.min(lo), b.max(up))));
        };
        for a in 0..order.len() {
            let (_, end, i) = order[a];
            for (b, &(start, _, j)) in order.iter().enumerate().skip(a + 1) {
                if start > end {
                    break;
                }
                if let Some(m) = meets(i, j) {
                    add(a, m);
                    add(b, m);
                }
            }
        }
        for (&(_, _, i), a) in order.iter().zip(acc) {
            if let Some(a) = a {
                merge(i, a);
            }
        }
    });
    drop(entries);
    // Triangles too large for the grid, against every other triangle (both ways).
    let big: Vec<usize> = (0..n).filter(|&i| spans[i].is_none()).collect();
    (0..n).into_par_iter().for_each(|j| {
        gather(j, &mut big.iter().copied().filter(|&i| i != j));
    });
    big.par_iter().for_each(|&i| gather(i, &mut (0..n).filter(|&j| j != i)));
    let mut regions = Vec::new();
    let slot = region
        .into_iter()
        .map(|b| {
            let [x0, y0, z0, x1, y1, z1] = b.map(|k| from_order_key(k.into_inner()));
            let (lo, hi) = (Vec3::new(x0, y0, z0), Vec3::new(x1, y1, z1));
            if lo.cmpgt(hi).any() {
                return NEVER;
            }
            regions.push([lo, hi]);
            (regions.len() - 1) as u32
        })
        .collect();
    Touching { slot, regions }
}

/// Whether no two of these windings can face away from each other: every one lies within
/// acos(0.71) = 44.8° of their mean direction, so any two are within 89.6°, and their dot
/// is at least 0.008 |a| |b|, far above its f32 rounding (3 ulps of |a| |b|): the
/// pairwise look-back test would pass them all. Spares the quadratic loop in cells of
/// one smooth surface (a height field, the fan at a sphere's pole). A zero or non-finite
/// winding (degenerate triangle) is not settled here.
fn one_way(windings: impl Iterator<Item = Vec3> + Clone) -> bool {
    let mut mean = Vec3::ZERO;
    for w in windings.clone() {
        let u = w.normalize_or_zero();
        if u == Vec3::ZERO {
            return false;
        }
        mean += u;
    }
    let mean = mean.normalize_or_zero();
    mean != Vec3::ZERO && windings.into_iter().all(|w| w.normalize_or_zero().dot(mean) >= 0.71)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The two triangles of an axis-aligned square at height `z`, facing up or down.
    fn square(lo: f32, hi: f32, z: f32, up: bool) -> [[Vec3; 3]; 2] {
        let (a, b, c, d) = (Vec3::new(lo, lo, z), Vec3::new(hi, lo, z), Vec3::new(hi, hi, z), Vec3::new(lo, hi, z));
        if up { [[a, b, c], [a, c, d]] } else { [[a, c, b], [a, d, c]] }
    }

    #[test]
    fn resting_faces_touch_and_the_rest_do_not() {
        // A floor facing up, a box's bottom facing down on it, the box's top 1 above.
        let mut tris = Vec::new();
        tris.extend(square(-5.0, 5.0, 0.0, true));
        tris.extend(square(-0.5, 0.5, 0.0, false));
        tris.extend(square(-0.5, 0.5, 1.0, true));
        // A box's bottom 0.1 above the floor is beyond the reach (0.013 at coordinates of 3).
        tris.extend(square(2.0, 3.0, 0.1, false));
        let t = touching(&tris);
        let f: Vec<bool> = t.slot.iter().map(|&k| k != NEVER).collect();
        assert_eq!(f, [true, true, true, true, false, false, false, false]);
        // The floor looks back only near the box's foot (within the reach, 0.022 at
        // coordinates of 5), and the foot everywhere on it.
        let r = reach(5.0);
        for (p, near) in [
            (Vec3::new(0.0, 0.0, 0.0), true),
            (Vec3::new(0.5 + 0.9 * r, -0.5 - 0.9 * r, 0.0), true),
            (Vec3::new(0.5 + 1.1 * r, 0.0, 0.0), false),
            (Vec3::new(-4.0, 3.0, 0.0), false),
        ] {
            assert_eq!(t.may_touch_at(t.slot[0], p), near, "floor at {p}");
        }
        assert!(t.may_touch_at(t.slot[2], Vec3::new(0.49, -0.49, 0.0)));
        assert!(t.may_touch_at(t.slot[0], Vec3::NAN));
    }

    #[test]
    fn a_lone_sphere_is_not_flagged() {
        // A UV sphere (16 x 8): only triangles a quarter turn apart face away from each
        // other, and their boxes are far apart.
        let at = |i: u32, j: u32| {
            let (phi, theta) = (i as f32 * std::f32::consts::TAU / 16.0, j as f32 * std::f32::consts::PI / 8.0);
            Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
        };
        let mut tris = Vec::new();
        for i in 0..16 {
            for j in 0..8 {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                if j > 0 {
                    tris.push([a, c, b]);
                }
                if j < 7 {
                    tris.push([a, d, c]);
                }
            }
        }
        assert!(touching(&tris).slot.iter().all(|&t| t == NEVER));
    }

    #[test]
    fn a_large_triangle_is_tested_against_all() {
        // A floor much larger than the grid cells (set by the many small triangles).
        let mut tris: Vec<[Vec3; 3]> = (0..100)
            .map(|k| {
                let x = k as f32 * 0.01 + 100.0;
                [Vec3::new(x, 0.0, 5.0), Vec3::new(x + 0.005, 0.0, 5.0), Vec3::new(x, 0.005, 5.0)]
            })
            .collect();
        tris.extend(square(-1000.0, 1000.0, 0.0, true));
        tris.push([Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.0, 0.01, 0.0), Vec3::new(0.01, 0.0, 0.0)]);
        let f: Vec<bool> = touching(&tris).slot.iter().map(|&k| k != NEVER).collect();
        assert!(f[..100].iter().all(|&t| !t));
        assert!(f[100] && f[102]);
    }
}
