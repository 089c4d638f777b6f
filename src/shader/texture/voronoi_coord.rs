//! The Voronoi node's coordinate types, 1-D to 4-D, behind one trait: the cell scan, the
//! feature point hashes and the metrics as Cycles computes them per dimension.

use core::ops::{Add, Mul, Sub};

use glam::{Vec2, Vec3, Vec4};

use super::cell_offsets::{OFFSETS_2D, OFFSETS_3D, OFFSETS_4D};
use super::float_ops::floor;
use super::hash::{
    hash_float_to_float, hash_float_to_float3, hash_int2_to_float2, hash_int2_to_float3, hash_int3_to_float3,
    hash_int4_to_float3, hash_int4_to_float4,
};
use super::simd::Cells27;
#[cfg(target_arch = "x86_64")]
use super::simd::{LaneMetric, first_min_27, has_avx2, voronoi_cells_3d, voronoi_cells_3d_lanes};
use super::voronoi_settings::{Params, VoronoiMetric};

/// A Voronoi coordinate of 1 to 4 dimensions.
pub(super) trait Coord: Copy + Add<Output = Self> + Sub<Output = Self> + Mul<f32, Output = Self> {
    const DIMS: u32;
    fn floor(self) -> Self;
    /// The cell offset with index `i` of the `(2r + 1)^DIMS` neighbourhood, x fastest.
    fn offset(i: u32, r: i32) -> Self;
    fn splat(v: f32) -> Self;
    /// The feature point inside cell `cell + offset` (`cell` is a floor, so integral): 1-D
    /// hashes the float's bits, 2-D to 4-D the integer coordinates (Cycles' `hash_intN_to_floatN`,
    /// added in int arithmetic as Cycles does, which stays exact beyond 2^24).
    fn hash_point(cell: Self, offset: Self) -> Self;
    /// The colour of cell `cell + offset`.
    fn hash_color(cell: Self, offset: Self) -> Vec3;
    fn dot(self, b: Self) -> f32;
    /// Sum of the components (Cycles' `reduce_add`).
    fn sum(self) -> f32;
    fn max_element(self) -> f32;
    fn abs(self) -> Self;
    fn powf(self, e: f32) -> Self;
    /// Cycles' `voronoi_position`: where the coordinate lands in the 4-D output.
    fn position(self) -> Vec4;

    /// Cycles' `voronoi_distance` for the node's metric (1-D overrides: always |a - b|).
    #[inline(always)]
    fn distance(a: Self, b: Self, prm: &Params) -> f32 {
        let d = (a - b).abs();
        match prm.metric {
            VoronoiMetric::Euclidean => euclidean(a, b),
            VoronoiMetric::Manhattan => d.sum(),
            VoronoiMetric::Chebychev => d.max_element(),
            VoronoiMetric::Minkowski => d.powf(prm.exponent).sum().powf(1.0 / prm.exponent),
        }
    }

    /// Cycles' `voronoi_distance_bound`: a monotonic stand-in for the distance (no root) that
    /// F1 compares with (1-D overrides: |a - b|).
    #[inline(always)]
    fn distance_bound(a: Self, b: Self, prm: &Params) -> f32 {
        let d = (a - b).abs();
        match prm.metric {
            VoronoiMetric::Euclidean => (a - b).dot(a - b),
            VoronoiMetric::Manhattan => d.sum(),
            VoronoiMetric::Chebychev => d.max_element(),
            VoronoiMetric::Minkowski => d.powf(prm.exponent).sum(),
        }
    }

    /// The scan of Cycles' `voronoi_f1`: the offset and feature point of the closest cell
    /// (by the distance bound; strict `<`, so ties go to the first cell, zeros if none).
    #[inline(always)]
    fn f1_scan(prm: &Params, cell: Self, local: Self) -> (Self, Self) {
        scan_f1(prm, cell, local)
    }

    /// The scan of Cycles' `voronoi_f2`: (distance, offset, feature point) of the closest and
    /// of the second closest cell.
    #[inline(always)]
    fn f2_scan(prm: &Params, cell: Self, local: Self) -> [(f32, Self, Self); 2] {
        scan_f2(prm, cell, local)
    }

    /// Cycles' `voronoi_distance_to_edge` (1-D overrides with its closed form).
    #[inline]
    fn distance_to_edge(prm: &Params, coord: Self) -> f32 {
        let cell = coord.floor();
        let local = coord - cell;
        let n = 3u32.pow(Self::DIMS);
        let to_point = |i: u32| {
            let offset = Self::offset(i, 1);
            offset + Self::hash_point(cell, offset) * prm.randomness - local
        };
        let mut to_closest = Self::splat(0.0);
        let mut min_distance = f32::MAX;
        for i in 0..n {
            let v = to_point(i);
            let d = v.dot(v);
            if d < min_distance {
                min_distance = d;
                to_closest = v;
            }
        }
        min_distance = f32::MAX;
        for i in 0..n {
            let v = to_point(i);
            let perpendicular = v - to_closest;
            let len2 = perpendicular.dot(perpendicular);
            // Cycles skips the closest point itself (and points within 0.01 of it).
            if len2 > 0.0001 {
                let unit = perpendicular * (1.0 / len2.sqrt());
                let d = ((to_closest + v) * 0.5).dot(unit);
                min_distance = min_distance.min(d);
            }
        }
        min_distance
    }
}

/// Cycles' `make_intN(floor) + offset`: integer cell coordinates.
#[inline(always)]
fn cell_index<const N: usize>(cell: [f32; N], offset: [f32; N]) -> [i32; N] {
    core::array::from_fn(|k| (cell[k] as i32).wrapping_add(offset[k] as i32))
}

/// Cycles' `distance`: the Euclidean length of `a - b`.
#[inline(always)]
pub(super) fn euclidean<T: Coord>(a: T, b: T) -> f32 {
    let d = a - b;
    d.dot(d).sqrt()
}

impl Coord for f32 {
    const DIMS: u32 = 1;
    #[inline(always)]
    fn floor(self) -> Self {
        floor(self)
    }
    #[inline(always)]
    fn offset(i: u32, r: i32) -> Self {
        (i as i32 - r) as f32
    }
    #[inline(always)]
    fn splat(v: f32) -> Self {
        v
    }
    #[inline(always)]
    fn hash_point(cell: Self, offset: Self) -> Self {
        hash_float_to_float(cell + offset)
    }
    #[inline(always)]
    fn hash_color(cell: Self, offset: Self) -> Vec3 {
        hash_float_to_float3(cell + offset)
    }
    #[inline(always)]
    fn dot(self, b: Self) -> f32 {
        self * b
    }
    #[inline(always)]
    fn sum(self) -> f32 {
        self
    }
    #[inline(always)]
    fn max_element(self) -> f32 {
        self
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32::abs(self)
    }
    #[inline(always)]
    fn powf(self, e: f32) -> Self {
        f32::powf(self, e)
    }
    #[inline(always)]
    fn position(self) -> Vec4 {
        Vec4::new(0.0, 0.0, 0.0, self)
    }
    #[inline(always)]
    fn distance(a: Self, b: Self, _: &Params) -> f32 {
        (b - a).abs()
    }
    #[inline(always)]
    fn distance_bound(a: Self, b: Self, _: &Params) -> f32 {
        (b - a).abs()
    }
    #[inline]
    fn distance_to_edge(prm: &Params, coord: Self) -> f32 {
        let cell = coord.floor();
        let local = coord - cell;
        let mid = hash_float_to_float(cell) * prm.randomness;
        let left = -1.0 + hash_float_to_float(cell - 1.0) * prm.randomness;
        let right = 1.0 + hash_float_to_float(cell + 1.0) * prm.randomness;
        let to_mid_left = ((mid + left) / 2.0 - local).abs();
        let to_mid_right = ((mid + right) / 2.0 - local).abs();
        to_mid_left.min(to_mid_right)
    }
}

impl Coord for Vec2 {
    const DIMS: u32 = 2;
    #[inline(always)]
    fn floor(self) -> Self {
        Vec2::new(floor(self.x), floor(self.y))
    }
    #[inline(always)]
    fn offset(i: u32, r: i32) -> Self {
        if r == 1 {
            return OFFSETS_2D[i as usize];
        }
        let n = (2 * r + 1) as u32;
        Vec2::new((i % n) as i32 as f32 - r as f32, (i / n) as i32 as f32 - r as f32)
    }
    #[inline(always)]
    fn splat(v: f32) -> Self {
        Vec2::splat(v)
    }
    #[inline(always)]
    fn hash_point(cell: Self, offset: Self) -> Self {
        hash_int2_to_float2(cell_index(cell.to_array(), offset.to_array()))
    }
    #[inline(always)]
    fn hash_color(cell: Self, offset: Self) -> Vec3 {
        hash_int2_to_float3(cell_index(cell.to_array(), offset.to_array()))
    }
    #[inline(always)]
    fn dot(self, b: Self) -> f32 {
        self.x * b.x + self.y * b.y
    }
    #[inline(always)]
    fn sum(self) -> f32 {
        self.x + self.y
    }
    #[inline(always)]
    fn max_element(self) -> f32 {
        self.x.max(self.y)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Vec2::abs(self)
    }
    #[inline(always)]
    fn powf(self, e: f32) -> Self {
        Vec2::new(self.x.powf(e), self.y.powf(e))
    }
    #[inline(always)]
    fn position(self) -> Vec4 {
        Vec4::new(self.x, self.y, 0.0, 0.0)
    }
}

impl Coord for Vec3 {
    const DIMS: u32 = 3;
    #[inline(always)]
    fn floor(self) -> Self {
        Vec3::new(floor(self.x), floor(self.y), floor(self.z))
    }
    #[inline(always)]
    fn offset(i: u32, r: i32) -> Self {
        if r == 1 {
            return OFFSETS_3D[i as usize];
        }
        let n = (2 * r + 1) as u32;
        Vec3::new((i % n) as f32 - r as f32, (i / n % n) as f32 - r as f32, (i / (n * n)) as f32 - r as f32)
    }
    #[inline(always)]
    fn splat(v: f32) -> Self {
        Vec3::splat(v)
    }
    #[inline(always)]
    fn hash_point(cell: Self, offset: Self) -> Self {
        hash_int3_to_float3(cell_index(cell.to_array(), offset.to_array()))
    }

    #[inline(always)]
    fn hash_color(cell: Self, offset: Self) -> Vec3 {
        hash_int3_to_float3(cell_index(cell.to_array(), offset.to_array()))
    }
    #[inline(always)]
    fn dot(self, b: Self) -> f32 {
        self.x * b.x + self.y * b.y + self.z * b.z
    }
    #[inline(always)]
    fn sum(self) -> f32 {
        self.x + self.y + self.z
    }
    #[inline(always)]
    fn max_element(self) -> f32 {
        self.x.max(self.y).max(self.z)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Vec3::abs(self)
    }
    #[inline(always)]
    fn powf(self, e: f32) -> Self {
        Vec3::new(self.x.powf(e), self.y.powf(e), self.z.powf(e))
    }
    #[inline(always)]
    fn position(self) -> Vec4 {
        self.extend(0.0)
    }
    #[inline(always)]
    fn f1_scan(prm: &Params, cell: Self, local: Self) -> (Self, Self) {
        match cells_3d(prm, cell, local, false) {
            Some(c) => match first_min(&c.d) {
                Some(i) => (OFFSETS_3D[i], Vec3::new(c.x[i], c.y[i], c.z[i])),
                None => (Vec3::ZERO, Vec3::ZERO),
            },
            None => scan_f1(prm, cell, local),
        }
    }
    #[inline(always)]
    fn f2_scan(prm: &Params, cell: Self, local: Self) -> [(f32, Self, Self); 2] {
        match cells_3d(prm, cell, local, true) {
            Some(c) => {
                let mut best = [(f32::MAX, Vec3::ZERO, Vec3::ZERO); 2];
                for (i, &d) in c.d[..27].iter().enumerate() {
                    if d < best[0].0 {
                        best[1] = best[0];
                        best[0] = (d, OFFSETS_3D[i], Vec3::new(c.x[i], c.y[i], c.z[i]));
                    } else if d < best[1].0 {
                        best[1] = (d, OFFSETS_3D[i], Vec3::new(c.x[i], c.y[i], c.z[i]));
                    }
                }
                best
            }
            None => scan_f2(prm, cell, local),
        }
    }
}

/// The cell F1's scan picks among the kernel's 27 (`simd::first_min_27`). Callgrind
/// (`bench/node_graph.py`): the scalar loop over the 27 distances cost ~150 instructions.
#[inline(always)]
fn first_min(d: &[f32; 32]) -> Option<usize> {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: distances come only from the kernels, run only when the CPU has AVX2
        // (`cells_3d`, `f1_scan_lanes`); they are not NaN (finite local and randomness).
        unsafe { first_min_27(d) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut best = None;
        let mut min_distance = f32::MAX;
        for (i, &d) in d[..27].iter().enumerate() {
            if d < min_distance {
                min_distance = d;
                best = Some(i);
            }
        }
        best
    }
}

/// `Coord::f1_scan` at three points of one cell (`local`, each relative to `cell`): the
/// feature points hashed once, three distance passes (`simd::voronoi_cells_3d_lanes`); each
/// pick is the one `f1_scan` makes for that point. None where the kernel does not apply
/// (no AVX2, Minkowski, a point or the randomness not finite): then scan each point alone.
pub(super) fn f1_scan_lanes(prm: &Params, cell: Vec3, local: [Vec3; 3]) -> Option<[(Vec3, Vec3); 3]> {
    #[cfg(target_arch = "x86_64")]
    {
        let metric = match prm.metric {
            VoronoiMetric::Euclidean => LaneMetric::EuclideanSquared,
            VoronoiMetric::Manhattan => LaneMetric::Manhattan,
            VoronoiMetric::Chebychev => LaneMetric::Chebychev,
            VoronoiMetric::Minkowski => return None,
        };
        if !(has_avx2() && local.iter().all(|l| l.is_finite()) && prm.randomness.is_finite()) {
            return None;
        }
        let mut c = Cells27 { x: [0.0; 32], y: [0.0; 32], z: [0.0; 32], d: [0.0; 32] };
        let mut more = [[0.0; 32]; 2];
        let index = cell_index(cell.to_array(), [0.0; 3]);
        let locals = local.map(|l| l.to_array());
        // SAFETY: the CPU has AVX2; every local and the randomness are finite.
        unsafe { voronoi_cells_3d_lanes(index, locals, prm.randomness, metric, &mut c, &mut more) };
        let pick = |d: &[f32; 32]| match first_min(d) {
            Some(i) => (OFFSETS_3D[i], Vec3::new(c.x[i], c.y[i], c.z[i])),
            None => (Vec3::ZERO, Vec3::ZERO),
        };
        Some([pick(&c.d), pick(&more[0]), pick(&more[1])])
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (prm, cell, local);
        None
    }
}

/// F1's scan one cell after the other (`Coord::f1_scan`).
#[inline(always)]
fn scan_f1<T: Coord>(prm: &Params, cell: T, local: T) -> (T, T) {
    let mut min_distance = f32::MAX;
    let mut target = (T::splat(0.0), T::splat(0.0));
    for i in 0..3u32.pow(T::DIMS) {
        let offset = T::offset(i, 1);
        let point = offset + T::hash_point(cell, offset) * prm.randomness;
        let d = T::distance_bound(point, local, prm);
        if d < min_distance {
            min_distance = d;
            target = (offset, point);
        }
    }
    target
}

/// F2's scan one cell after the other (`Coord::f2_scan`).
#[inline(always)]
fn scan_f2<T: Coord>(prm: &Params, cell: T, local: T) -> [(f32, T, T); 2] {
    let mut best = [(f32::MAX, T::splat(0.0), T::splat(0.0)); 2];
    for i in 0..3u32.pow(T::DIMS) {
        let offset = T::offset(i, 1);
        let point = offset + T::hash_point(cell, offset) * prm.randomness;
        let d = T::distance(point, local, prm);
        if d < best[0].0 {
            best[1] = best[0];
            best[0] = (d, offset, point);
        } else if d < best[1].0 {
            best[1] = (d, offset, point);
        }
    }
    best
}

/// The 27 cells of a 3-D neighbourhood from the AVX2 kernel, when the CPU has it and the
/// metric is one the kernel computes (`full`: the distance itself, else F1's bound); `None`
/// sends the caller to the scalar scan.
#[inline(always)]
fn cells_3d(prm: &Params, cell: Vec3, local: Vec3, full: bool) -> Option<Cells27> {
    #[cfg(target_arch = "x86_64")]
    {
        let metric = match prm.metric {
            VoronoiMetric::Euclidean if full => LaneMetric::Euclidean,
            VoronoiMetric::Euclidean => LaneMetric::EuclideanSquared,
            VoronoiMetric::Manhattan => LaneMetric::Manhattan,
            VoronoiMetric::Chebychev => LaneMetric::Chebychev,
            VoronoiMetric::Minkowski => return None,
        };
        if !(has_avx2() && local.is_finite() && prm.randomness.is_finite()) {
            return None;
        }
        let mut c = Cells27 { x: [0.0; 32], y: [0.0; 32], z: [0.0; 32], d: [0.0; 32] };
        let index = cell_index(cell.to_array(), [0.0; 3]);
        // SAFETY: the CPU has AVX2; local and randomness are finite, as the kernel needs.
        unsafe { voronoi_cells_3d(index, local.to_array(), prm.randomness, metric, &mut c) };
        Some(c)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (prm, cell, local, full);
        None
    }
}

impl Coord for Vec4 {
    const DIMS: u32 = 4;
    #[inline(always)]
    fn floor(self) -> Self {
        Vec4::new(floor(self.x), floor(self.y), floor(self.z), floor(self.w))
    }
    #[inline(always)]
    fn offset(i: u32, r: i32) -> Self {
        if r == 1 {
            return OFFSETS_4D[i as usize];
        }
        let n = (2 * r + 1) as u32;
        Vec4::new(
            (i % n) as f32 - r as f32,
            (i / n % n) as f32 - r as f32,
            (i / (n * n) % n) as f32 - r as f32,
            (i / (n * n * n)) as f32 - r as f32,
        )
    }
    #[inline(always)]
    fn splat(v: f32) -> Self {
        Vec4::splat(v)
    }
    #[inline(always)]
    fn hash_point(cell: Self, offset: Self) -> Self {
        hash_int4_to_float4(cell_index(cell.to_array(), offset.to_array()))
    }
    #[inline(always)]
    fn hash_color(cell: Self, offset: Self) -> Vec3 {
        hash_int4_to_float3(cell_index(cell.to_array(), offset.to_array()))
    }
    #[inline(always)]
    fn dot(self, b: Self) -> f32 {
        self.x * b.x + self.y * b.y + self.z * b.z + self.w * b.w
    }
    #[inline(always)]
    fn sum(self) -> f32 {
        self.x + self.y + self.z + self.w
    }
    #[inline(always)]
    fn max_element(self) -> f32 {
        self.x.max(self.y).max(self.z).max(self.w)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Vec4::abs(self)
    }
    #[inline(always)]
    fn powf(self, e: f32) -> Self {
        Vec4::new(self.x.powf(e), self.y.powf(e), self.z.powf(e), self.w.powf(e))
    }
    #[inline(always)]
    fn position(self) -> Vec4 {
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader::texture::voronoi_settings::VoronoiFeature;

    fn params(metric: VoronoiMetric, randomness: f32) -> Params {
        Params {
            feature: VoronoiFeature::F1,
            metric,
            normalize: false,
            scale: 1.0,
            detail: 0.0,
            roughness: 0.5,
            lacunarity: 2.0,
            smoothness: 0.5,
            exponent: 0.5,
            randomness,
            max_distance: 0.0,
            color: false,
        }
    }

    /// The 3-D scans through the AVX2 kernel pick the same cells and give the same points and
    /// distances, bit for bit, as the scalar scans, for every metric the kernel takes, over
    /// small, negative and large coordinates (cells past 2^24, where the cell's float is
    /// coarser than 1, and past i32, where `as i32` saturates) and randomness 0 (ties
    /// everywhere: the first cell must win) to 1.
    #[test]
    fn kernel_scans_are_the_scalar_scans() {
        let mut state = 0x2545_f491u32;
        let mut next = || {
            state = state.wrapping_mul(1664525).wrapping_add(1013904223);
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        let metrics = [VoronoiMetric::Euclidean, VoronoiMetric::Manhattan, VoronoiMetric::Chebychev];
        for k in 0..20_000 {
            let range = [4.0, 300.0, 3.0e7, 5.0e9][k % 4];
            let coord = Vec3::new(next() * 2.0 - 1.0, next() * 2.0 - 1.0, next() * 2.0 - 1.0) * range;
            let prm = params(metrics[k % 3], [0.0, 0.3, 1.0, next()][k % 4]);
            let cell = Coord::floor(coord);
            let local = coord - cell;
            let bits = |v: Vec3| v.to_array().map(f32::to_bits);
            let (a, b) = (<Vec3 as Coord>::f1_scan(&prm, cell, local), scan_f1(&prm, cell, local));
            assert_eq!((bits(a.0), bits(a.1)), (bits(b.0), bits(b.1)), "F1 at {coord:?}");
            let (a, b) = (<Vec3 as Coord>::f2_scan(&prm, cell, local), scan_f2(&prm, cell, local));
            for (x, y) in a.iter().zip(&b) {
                assert_eq!(
                    (x.0.to_bits(), bits(x.1), bits(x.2)),
                    (y.0.to_bits(), bits(y.1), bits(y.2)),
                    "F2 at {coord:?}"
                );
            }
        }
    }
}
