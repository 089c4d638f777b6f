//! A hashed uniform grid for VCM's range queries: every stored light vertex within r of
//! a camera vertex. Built once per iteration (cells of side 2r, so a query ball touches
//! at most the 2 × 2 × 2 cells nearest its centre), its buffers reused across iterations;
//! a query allocates nothing. The caller stores its points in bucket order (`order`), so a
//! bucket is one contiguous run of them: a query reads no index array and touches no
//! scattered records (the profile of the Cornell box had a tenth of VCM's time in the
//! query loop, most of it cache misses on records reached through the index).

use glam::Vec3;

/// Points hashed into cells of side 2r, as index ranges into one array.
#[derive(Debug, Default)]
pub struct HashGrid {
    /// The smallest corner of the points' bounds.
    lo: Vec3,
    /// 1 / cell side.
    inv_cell: f32,
    /// Search radius squared.
    r2: f32,
    /// Bucket b's points are `start[b]..start[b + 1]` in bucket order.
    start: Vec<u32>,
    /// Point indices (of the order `build` saw them in), by bucket.
    order: Vec<u32>,
    /// Each point's bucket (scratch of the build).
    bucket_of: Vec<u32>,
}

/// Cell coordinates to a bucket (the usual three large primes), `mask` + 1 buckets.
#[inline]
fn hash(x: i32, y: i32, z: i32, mask: u32) -> u32 {
    ((x as u32).wrapping_mul(73_856_093) ^ (y as u32).wrapping_mul(19_349_663) ^ (z as u32).wrapping_mul(83_492_791))
        & mask
}

impl HashGrid {
    /// Rebuilds the grid over `points` for queries of radius `r`; the caller then puts its
    /// points in the order `order` gives, which the queries' indices refer to.
    pub fn build(&mut self, points: impl ExactSizeIterator<Item = Vec3> + Clone, r: f32) {
        let n = points.len();
        let buckets = n.max(1).next_power_of_two();
        let mask = (buckets - 1) as u32;
        self.r2 = r * r;
        self.inv_cell = 1.0 / (2.0 * r);
        self.lo = points.clone().fold(Vec3::splat(f32::INFINITY), Vec3::min);
        self.start.clear();
        self.start.resize(buckets + 1, 0);
        self.bucket_of.clear();
        for p in points {
            let c = self.cell(p);
            let b = hash(c[0], c[1], c[2], mask);
            self.bucket_of.push(b);
            self.start[b as usize + 1] += 1;
        }
        for b in 0..buckets {
            self.start[b + 1] += self.start[b];
        }
        self.order.clear();
        self.order.resize(n, 0);
        // Fill each bucket from its start, then shift the starts back (counting sort).
        for (i, &b) in self.bucket_of.iter().enumerate() {
            let at = &mut self.start[b as usize];
            self.order[*at as usize] = i as u32;
            *at += 1;
        }
        for b in (1..=buckets).rev() {
            self.start[b] = self.start[b - 1];
        }
        self.start[0] = 0;
    }

    /// The points' original indices in bucket order: position i of the reordered points
    /// holds original point `order()[i]`.
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// Integer cell coordinates of `p`.
    #[inline]
    fn cell(&self, p: Vec3) -> [i32; 3] {
        let c = ((p - self.lo) * self.inv_cell).floor();
        [c.x as i32, c.y as i32, c.z as i32]
    }

    /// Calls `f(index)` for every point within the radius of `p`, `index` counted in bucket
    /// order (`pos(index)` gives that point's position). Each point is visited at most once.
    #[inline]
    pub fn for_each_within(&self, p: Vec3, pos: impl Fn(u32) -> Vec3, mut f: impl FnMut(u32)) {
        if self.order.is_empty() {
            return;
        }
        let mask = (self.start.len() - 2) as u32;
        let q = (p - self.lo) * self.inv_cell;
        let base = q.floor();
        let frac = q - base;
        let (bx, by, bz) = (base.x as i32, base.y as i32, base.z as i32);
        // The neighbour on each axis is on the side of the cell's centre the point lies.
        let step = |f: f32| if f < 0.5 { -1 } else { 1 };
        let (sx, sy, sz) = (step(frac.x), step(frac.y), step(frac.z));
        let mut seen = [u32::MAX; 8];
        for k in 0..8usize {
            let b = hash(
                bx + if k & 1 != 0 { sx } else { 0 },
                by + if k & 2 != 0 { sy } else { 0 },
                bz + if k & 4 != 0 { sz } else { 0 },
                mask,
            );
            // Two cells may share a bucket: visit it once.
            if seen[..k].contains(&b) {
                continue;
            }
            seen[k] = b;
            for i in self.start[b as usize]..self.start[b as usize + 1] {
                if (pos(i) - p).length_squared() <= self.r2 {
                    f(i);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The grid finds exactly the points a brute-force search finds, each once (its indices
    /// in bucket order mapped back to the points' own).
    #[test]
    fn matches_brute_force() {
        let mut state = 0x2545_f491u64;
        let mut rnd = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32 + 0.5) / (1u64 << 24) as f32
        };
        let mut grid = HashGrid::default();
        for trial in 0..20 {
            let n = 1 + trial * 37;
            let pts: Vec<Vec3> = (0..n).map(|_| Vec3::new(rnd(), rnd() * 0.5, rnd() * 2.0 - 1.0)).collect();
            let r = 0.02 + 0.1 * rnd();
            grid.build(pts.iter().copied(), r);
            let order = grid.order();
            for _ in 0..50 {
                let q = Vec3::new(rnd() * 1.2 - 0.1, rnd() * 0.6 - 0.05, rnd() * 2.2 - 1.1);
                let mut found = Vec::new();
                let pos = |i: u32| pts[order[i as usize] as usize];
                grid.for_each_within(q, pos, |i| found.push(order[i as usize]));
                found.sort_unstable();
                let expect: Vec<u32> =
                    (0..n as u32).filter(|&i| (pts[i as usize] - q).length_squared() <= r * r).collect();
                assert_eq!(found, expect, "trial {trial}");
            }
        }
    }
}
