//! Blender's Voronoi Texture node (`svm/voronoi.h`): Worley noise in 1 to 4 dimensions with
//! the features F1, F2, smooth F1, distance to edge and n-sphere radius, four metrics, and the
//! fractal (multi-octave) Voronoi added in Blender 4.0.
//!
//! Inputs as the node receives them; the node clamps detail to [0, 15], roughness and
//! randomness to [0, 1] and halves smoothness into [0, 0.5], as here. 1-D reads only `w`,
//! 2-D `p.xy`, 3-D `p`, 4-D `(p, w)`. Cycles' float details are kept: cells are scanned in
//! its order (x fastest) with strict `<`, so ties go to the first cell; a vector divided by a
//! scalar is multiplied by the reciprocal; 1-D ignores the metric.

use glam::{Vec2, Vec3, Vec4};

use super::perlin::mix;
use super::voronoi_coord::{Coord, euclidean, f1_scan_lanes};
pub(super) use super::voronoi_settings::Params;
pub use super::voronoi_settings::{VoronoiFeature, VoronoiMetric};

/// The Voronoi node's settings and non-vector inputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VoronoiParams {
    /// 1..=4 (anything else is treated as 3, Blender's default).
    pub dims: u8,
    /// What is measured: the node's "Feature".
    pub feature: VoronoiFeature,
    /// How distance is measured: the node's "Distance".
    pub metric: VoronoiMetric,
    /// Divide distance and colour by their largest possible value.
    pub normalize: bool,
    /// Multiplies the vector and W before anything else.
    pub scale: f32,
    /// Octaves after the first, [0, 15]; a fraction blends in one more.
    pub detail: f32,
    /// Amplitude ratio between octaves, [0, 1].
    pub roughness: f32,
    /// Frequency ratio between octaves.
    pub lacunarity: f32,
    /// Smooth F1's blend width, [0, 1] (halved inside, as Cycles does).
    pub smoothness: f32,
    /// The Minkowski exponent.
    pub exponent: f32,
    /// How far feature points stray from the cell corner, [0, 1].
    pub randomness: f32,
}

/// The node's outputs; those the feature does not produce are zero, as in Cycles.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VoronoiOut {
    /// F1, F2, smooth F1 or edge distance.
    pub distance: f32,
    /// The cell's random colour (blended for smooth F1 and octaves).
    pub color: Vec3,
    /// The feature point, in the input's (unscaled) space.
    pub position: Vec3,
    /// The feature point's W (1-D and 4-D).
    pub w: f32,
    /// The n-sphere radius.
    pub radius: f32,
}

/// One octave's (or the sum's) outputs; position in 4-D as Cycles keeps it.
#[derive(Clone, Copy, Default)]
struct Octave {
    distance: f32,
    color: Vec3,
    position: Vec4,
}

/// Cycles' `voronoi_f1`: the closest feature point (found by the bound, measured after).
#[inline]
fn f1<T: Coord>(prm: &Params, coord: T) -> Octave {
    let cell = coord.floor();
    let local = coord - cell;
    f1_octave(prm, cell, local, T::f1_scan(prm, cell, local))
}

/// F1's outputs from the scan's pick (offset and feature point of the closest cell).
#[inline(always)]
fn f1_octave<T: Coord>(prm: &Params, cell: T, local: T, (target_offset, target_position): (T, T)) -> Octave {
    Octave {
        distance: T::distance(target_position, local, prm),
        color: if prm.color { T::hash_color(cell, target_offset) } else { Vec3::ZERO },
        position: (target_position + cell).position(),
    }
}

/// Cycles' `voronoi_smooth_f1`: a smooth minimum over a 5^N neighbourhood.
#[inline]
fn smooth_f1<T: Coord>(prm: &Params, coord: T) -> Octave {
    let cell = coord.floor();
    let local = coord - cell;
    let mut smooth_distance = 0.0f32;
    let mut smooth_color = Vec3::ZERO;
    let mut smooth_position = T::splat(0.0);
    let mut h = -1.0f32;
    for i in 0..5u32.pow(T::DIMS) {
        let offset = T::offset(i, 2);
        let point = offset + T::hash_point(cell, offset) * prm.randomness;
        let d = T::distance(point, local, prm);
        h = if h == -1.0 { 1.0 } else { smoothstep01(0.5 + 0.5 * (smooth_distance - d) / prm.smoothness) };
        let mut correction = prm.smoothness * h * (1.0 - h);
        smooth_distance = mix(smooth_distance, d, h) - correction;
        correction /= 1.0 + 3.0 * prm.smoothness;
        if prm.color {
            let cell_color = T::hash_color(cell, offset);
            smooth_color = smooth_color + (cell_color - smooth_color) * h - Vec3::splat(correction);
        }
        smooth_position = smooth_position + (point - smooth_position) * h - T::splat(correction);
    }
    Octave { distance: smooth_distance, color: smooth_color, position: (cell + smooth_position).position() }
}

/// Cycles' `smoothstep(0, 1, x)`.
#[inline(always)]
fn smoothstep01(x: f32) -> f32 {
    if x < 0.0 {
        0.0
    } else if x >= 1.0 {
        1.0
    } else {
        (3.0 - 2.0 * x) * (x * x)
    }
}

/// Cycles' `voronoi_f2`: the second closest feature point.
#[inline]
fn f2<T: Coord>(prm: &Params, coord: T) -> Octave {
    let cell = coord.floor();
    let local = coord - cell;
    let [_, (distance_f2, offset_f2, position_f2)] = T::f2_scan(prm, cell, local);
    let color = if prm.color { T::hash_color(cell, offset_f2) } else { Vec3::ZERO };
    Octave { distance: distance_f2, color, position: (position_f2 + cell).position() }
}

/// Cycles' `voronoi_n_sphere_radius`: half the distance from the closest feature point to its
/// own closest neighbour (always Euclidean; compared squared, as Cycles does).
#[inline]
fn n_sphere_radius<T: Coord>(prm: &Params, coord: T) -> f32 {
    let cell = coord.floor();
    let local = coord - cell;
    let mut closest = T::splat(0.0);
    let mut closest_offset = T::splat(0.0);
    let mut min_distance = f32::MAX;
    let n = 3u32.pow(T::DIMS);
    for i in 0..n {
        let offset = T::offset(i, 1);
        let point = offset + T::hash_point(cell, offset) * prm.randomness;
        let d = (point - local).dot(point - local);
        if d < min_distance {
            min_distance = d;
            closest = point;
            closest_offset = offset;
        }
    }
    min_distance = f32::MAX;
    let mut closest_to_closest = T::splat(0.0);
    // Index n / 2 is the zero offset, the closest point's own cell.
    for i in (0..n).filter(|&i| i != n / 2) {
        let offset = T::offset(i, 1) + closest_offset;
        let point = offset + T::hash_point(cell, offset) * prm.randomness;
        let d = (closest - point).dot(closest - point);
        if d < min_distance {
            min_distance = d;
            closest_to_closest = point;
        }
    }
    euclidean(closest_to_closest, closest) / 2.0
}

/// Cycles' `fractal_voronoi_x_fx`: octaves of F1, F2 or smooth F1 summed like fBM, the
/// positions blended by lerps.
#[inline]
fn fractal<T: Coord>(prm: &Params, coord: T) -> Octave {
    let mut amplitude = 1.0f32;
    let mut max_amplitude = 0.0f32;
    let mut scale = 1.0f32;
    let mut out = Octave::default();
    let zero_input = prm.detail == 0.0 || prm.roughness == 0.0;
    let last = prm.detail.ceil() as i32;
    for i in 0..=last {
        let c = coord * scale;
        let octave = match prm.feature {
            VoronoiFeature::F2 => f2(prm, c),
            VoronoiFeature::SmoothF1 if prm.smoothness != 0.0 => smooth_f1(prm, c),
            _ => f1(prm, c),
        };
        if zero_input {
            max_amplitude = 1.0;
            out = octave;
            break;
        }
        let octave_position = octave.position * (1.0 / scale);
        if i as f32 <= prm.detail {
            max_amplitude += amplitude;
            out.distance += octave.distance * amplitude;
            out.color += octave.color * amplitude;
            out.position = mix4(out.position, octave_position, amplitude);
            scale *= prm.lacunarity;
            amplitude *= prm.roughness;
        } else {
            let remainder = prm.detail - prm.detail.floor();
            if remainder != 0.0 {
                max_amplitude = mix(max_amplitude, max_amplitude + amplitude, remainder);
                out.distance = mix(out.distance, out.distance + octave.distance * amplitude, remainder);
                let color = out.color + octave.color * amplitude;
                out.color = out.color + (color - out.color) * remainder;
                let position = mix4(out.position, octave_position, amplitude);
                out.position = mix4(out.position, position, remainder);
            }
        }
    }
    finish(prm, out, max_amplitude)
}

/// The end of [`fractal`]: normalisation and the position back to the input's space.
#[inline(always)]
fn finish(prm: &Params, mut out: Octave, max_amplitude: f32) -> Octave {
    if prm.normalize {
        out.distance /= max_amplitude * prm.max_distance;
        out.color *= 1.0 / max_amplitude;
    }
    // Cycles' `safe_divide(position, scale)`.
    out.position = if prm.scale != 0.0 { out.position * (1.0 / prm.scale) } else { Vec4::ZERO };
    out
}

/// Cycles' vector `mix`: `a + t (b - a)`.
#[inline(always)]
fn mix4(a: Vec4, b: Vec4, t: f32) -> Vec4 {
    a + (b - a) * t
}

/// Cycles' `fractal_voronoi_distance_to_edge`: the smallest edge distance over octaves.
#[inline]
fn fractal_distance_to_edge<T: Coord>(prm: &Params, coord: T) -> f32 {
    let mut amplitude = 1.0f32;
    let mut max_amplitude = prm.max_distance;
    let mut scale = 1.0f32;
    let mut distance = 8.0f32;
    let zero_input = prm.detail == 0.0 || prm.roughness == 0.0;
    for i in 0..=prm.detail.ceil() as i32 {
        let octave_distance = T::distance_to_edge(prm, coord * scale);
        if zero_input {
            distance = octave_distance;
            break;
        }
        if i as f32 <= prm.detail {
            max_amplitude = mix(max_amplitude, prm.max_distance / scale, amplitude);
            distance = mix(distance, distance.min(octave_distance / scale), amplitude);
            scale *= prm.lacunarity;
            amplitude *= prm.roughness;
        } else {
            let remainder = prm.detail - prm.detail.floor();
            if remainder != 0.0 {
                let lerp_amplitude = mix(max_amplitude, prm.max_distance / scale, amplitude);
                max_amplitude = mix(max_amplitude, lerp_amplitude, remainder);
                let lerp_distance = mix(distance, distance.min(octave_distance / scale), amplitude);
                distance = mix(distance, distance.min(lerp_distance), remainder);
            }
        }
    }
    if prm.normalize {
        distance /= max_amplitude;
    }
    distance
}

/// The node for one coordinate type: the feature's outputs.
#[inline]
fn evaluate<T: Coord>(prm: &mut Params, coord: T) -> VoronoiOut {
    match prm.feature {
        VoronoiFeature::DistanceToEdge => {
            prm.max_distance = 0.5 + 0.5 * prm.randomness;
            VoronoiOut { distance: fractal_distance_to_edge(prm, coord), ..VoronoiOut::default() }
        }
        VoronoiFeature::NSphereRadius => VoronoiOut { radius: n_sphere_radius(prm, coord), ..VoronoiOut::default() },
        _ => {
            set_max_distance::<T>(prm);
            output(fractal(prm, coord))
        }
    }
}

/// The largest F1 distance of a jittered grid: the distance to the far corner of the cell's
/// reach (in 1-D plainly 0.5 + 0.5 randomness); twice that for F2.
#[inline(always)]
fn set_max_distance<T: Coord>(prm: &mut Params) {
    let reach = 0.5 + 0.5 * prm.randomness;
    let max_distance = if T::DIMS == 1 { reach } else { T::distance(T::splat(0.0), T::splat(reach), prm) };
    let factor = if prm.feature == VoronoiFeature::F2 { 2.0 } else { 1.0 };
    prm.max_distance = max_distance * factor;
}

/// The node's outputs from F1, F2 or smooth F1's sum.
#[inline(always)]
fn output(out: Octave) -> VoronoiOut {
    VoronoiOut {
        distance: out.distance,
        color: out.color,
        position: out.position.truncate(),
        w: out.position.w,
        radius: 0.0,
    }
}

/// Distance, Color, Position, W and Radius of the Voronoi Texture node at `p` (and `w`).
pub fn voronoi_texture(p: Vec3, w: f32, prm: &VoronoiParams) -> VoronoiOut {
    node(p, w, prm, true)
}

/// [`voronoi_texture`] without its Color output (zero), for a node whose Color is not
/// linked; the other outputs are the same numbers.
pub fn voronoi_texture_without_color(p: Vec3, w: f32, prm: &VoronoiParams) -> VoronoiOut {
    node(p, w, prm, false)
}

/// [`voronoi_texture`] (or, without `color`, [`voronoi_texture_without_color`]) at three
/// points (the Bump node's three heights), each lane the same numbers as one call. 3-D F1 of
/// one octave at three points of one cell (nearly always: they lie 10⁻⁴ apart) hashes the
/// cell's neighbours once (`voronoi_coord::f1_scan_lanes`); anything else is three calls.
pub fn voronoi_texture_lanes(p: [Vec3; 3], w: [f32; 3], prm: &VoronoiParams, color: bool) -> [VoronoiOut; 3] {
    let mut params = params(prm, color);
    let single = params.detail == 0.0 || params.roughness == 0.0;
    if prm.dims == 3 && prm.feature == VoronoiFeature::F1 && single {
        // As `node` then `fractal`'s single octave scale the point (`× 1.0` is exact).
        let coord = p.map(|p| p * prm.scale);
        let cell = coord.map(Coord::floor);
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        if bits(cell[0]) == bits(cell[1]) && bits(cell[0]) == bits(cell[2]) {
            let local = coord.map(|c| c - cell[0]);
            if let Some(picks) = f1_scan_lanes(&params, cell[0], local) {
                set_max_distance::<Vec3>(&mut params);
                return core::array::from_fn(|l| {
                    output(finish(&params, f1_octave(&params, cell[0], local[l], picks[l]), 1.0))
                });
            }
        }
    }
    core::array::from_fn(|l| node(p[l], w[l], prm, color))
}

fn node(p: Vec3, w: f32, prm: &VoronoiParams, color: bool) -> VoronoiOut {
    let mut params = params(prm, color);
    let p = p * prm.scale;
    let w = w * prm.scale;
    match prm.dims {
        1 => evaluate(&mut params, w),
        2 => evaluate(&mut params, Vec2::new(p.x, p.y)),
        4 => evaluate(&mut params, p.extend(w)),
        _ => evaluate(&mut params, p),
    }
}

/// The node's settings as the kernel takes them (clamped, smoothness halved).
#[inline(always)]
fn params(prm: &VoronoiParams, color: bool) -> Params {
    Params {
        feature: prm.feature,
        metric: prm.metric,
        normalize: prm.normalize,
        scale: prm.scale,
        detail: prm.detail.clamp(0.0, 15.0),
        roughness: prm.roughness.clamp(0.0, 1.0),
        lacunarity: prm.lacunarity,
        smoothness: (prm.smoothness / 2.0).clamp(0.0, 0.5),
        exponent: prm.exponent,
        randomness: prm.randomness.clamp(0.0, 1.0),
        max_distance: 0.0,
        color,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bits(o: &VoronoiOut) -> [u32; 9] {
        let [a, b, c] = o.color.to_array().map(f32::to_bits);
        let [x, y, z] = o.position.to_array().map(f32::to_bits);
        [o.distance.to_bits(), a, b, c, x, y, z, o.w.to_bits(), o.radius.to_bits()]
    }

    /// The three-point form gives each point what one call gives, bit for bit: points of one
    /// cell (the shared kernel: offsets 10⁻⁴ apart, as the Bump node's) and of neighbouring
    /// cells (offsets of a cell's size), every metric and feature, one octave and several,
    /// randomness 0 (ties: the first cell wins) to 1, with and without Color, far from the
    /// origin and at a zero scale.
    #[test]
    fn lanes_are_one_call_per_point() {
        let mut state = 0x9e37_79b9u32;
        let mut next = || {
            state = state.wrapping_mul(1664525).wrapping_add(1013904223);
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        let metrics =
            [VoronoiMetric::Euclidean, VoronoiMetric::Manhattan, VoronoiMetric::Chebychev, VoronoiMetric::Minkowski];
        let features = [VoronoiFeature::F1, VoronoiFeature::F1, VoronoiFeature::F2, VoronoiFeature::SmoothF1];
        let mut shared = 0;
        for k in 0..12_000 {
            let range = [2.0, 50.0, 4.0e5][k % 3];
            let p0 = Vec3::new(next() * 2.0 - 1.0, next() * 2.0 - 1.0, next() * 2.0 - 1.0) * range;
            let step = if k % 5 == 0 { 0.4 } else { 1e-4 };
            let d = |s: f32| Vec3::new(s, -0.5 * s, 0.25 * s) * step;
            let p = [p0, p0 + d(1.0), p0 + d(-1.3)];
            let prm = VoronoiParams {
                dims: 3,
                feature: features[k % 4],
                metric: metrics[k / 4 % 4],
                normalize: k % 7 < 3,
                scale: [8.0, 1.5, 0.0, -3.0][k / 16 % 4],
                detail: [0.0, 0.0, 1.5][k % 3],
                roughness: [0.5, 0.0][k / 3 % 2],
                lacunarity: 2.0,
                smoothness: 0.5,
                exponent: 1.5,
                randomness: [1.0, 0.0, 0.3, next()][k / 2 % 4],
            };
            let color = k % 2 == 0;
            let w = [0.0, 0.3, -0.7];
            let got = voronoi_texture_lanes(p, w, &prm, color);
            for l in 0..3 {
                let want = if color {
                    voronoi_texture(p[l], w[l], &prm)
                } else {
                    voronoi_texture_without_color(p[l], w[l], &prm)
                };
                assert_eq!(bits(&got[l]), bits(&want), "lane {l} of {p:?}, {prm:?}, color {color}");
            }
            let cells = p.map(|p| (p * prm.scale).floor());
            shared += usize::from(prm.feature == VoronoiFeature::F1 && cells[0] == cells[1] && cells[0] == cells[2]);
        }
        // The shared-cell path was taken often (not only the per-point fallback).
        assert!(shared > 1000, "{shared} shared-cell cases");
    }
}
