//! Blender 5.0's Radial Tiling node (`svm/radial_tiling.h` over `radial_tiling_shared.h`):
//! the plane around the origin cut into `sides` angular segments, each with its own
//! coordinate system whose level lines are a polygon with rounded corners.
//!
//! Names follow Cycles' convention where it helps to compare: an angle is measured from the
//! x axis (counterclockwise, in [0, 2π]) or from a segment's divider (the ray where the
//! segment starts). A segment's *bisector* halves it; with fractional `sides` the last
//! segment is narrower (the *irregular* one) and its bisector is the *last bisector*. The
//! *bevel start* is the angle from the divider where the rounded corner gives way to the
//! straight side. Every branch below is one of Cycles' cases, named as Cycles names it.
//!
//! The operations are Cycles' in Cycles' order on f32 (libm's `atan2`, `tan`, ...), so the
//! values are Blender's to a few ulps away from the segment boundaries, where Segment ID,
//! Rotation and Coordinates jump (`tests/texture_reference.rs`).

use std::f32::consts::{PI, TAU};

use glam::{Vec2, Vec3};

/// The node's four outputs at a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadialTiling {
    /// Segment Coordinates: (parameter across the segment, distance along its bisector, 0).
    pub coordinates: Vec3,
    /// Segment ID: 0 for the segment starting at the x axis, counting counterclockwise.
    pub segment_id: f32,
    /// Segment Width: the largest |parameter| at unit distance, for scaling textures.
    pub width: f32,
    /// Segment Rotation: the angle of the segment's bisector from the x axis.
    pub rotation: f32,
}

/// Which outputs to compute (Cycles skips the unlinked ones; the values do not depend on it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RadialTilingUse {
    /// Segment Coordinates, Width or Rotation (one computation gives all three).
    pub segment: bool,
    /// Segment ID.
    pub segment_id: bool,
}

/// The Radial Tiling node at the 2-D point `coord` (the Vector's x and y) with Sides,
/// Roundness and the `normalize` setting, clamped as Cycles does (at least 2 sides,
/// roundness in [0, 1]). Outputs not asked for by `used` are 0.
pub fn radial_tiling(coord: Vec2, sides: f32, roundness: f32, normalize: bool, used: RadialTilingUse) -> RadialTiling {
    // `max` and `max(0).min(1)` take the number over a NaN, as Cycles' fmaxf and clamp
    // (`f32::clamp` would keep the NaN).
    let sides = sides.max(2.0);
    #[allow(clippy::manual_clamp)]
    let roundness = roundness.max(0.0).min(1.0);
    let mut out = RadialTiling { coordinates: Vec3::ZERO, segment_id: 0.0, width: 0.0, rotation: 0.0 };
    if used.segment {
        let s = segment(normalize, sides, roundness, coord);
        out.coordinates = Vec3::new(s.parameter, s.along_bisector, 0.0);
        out.width = s.width;
        out.rotation = s.rotation;
    }
    if used.segment_id {
        out.segment_id = segment_id(sides, coord);
    }
    out
}

/// Segment ID: the angle from the x axis in [0, 2π) as a count of whole segments (Cycles'
/// `calculate_out_segment_id`; rounded in its own way, not through `Polar`).
pub fn segment_id(sides: f32, coord: Vec2) -> f32 {
    let turn = coord.y.atan2(coord.x) / TAU + below_x_axis(coord);
    (sides * turn).floor()
}

/// 1 below the x axis, else 0: adds a full turn to `atan2` there.
#[inline]
fn below_x_axis(coord: Vec2) -> f32 {
    if coord.y < 0.0 { 1.0 } else { 0.0 }
}

/// What `calculate_out_variables` returns (Cycles' float4 x, y, z, w).
#[derive(Clone, Copy, Debug)]
struct Segment {
    /// The point's distance along the bisector, scaled so that the polygon is at 1 (x).
    along_bisector: f32,
    /// The signed parameter across the segment (y): negative before the bisector.
    parameter: f32,
    /// The parameter's largest magnitude at distance 1 (z).
    width: f32,
    /// The bisector's angle from the x axis (w).
    rotation: f32,
}

/// The point's angle and its place among the segments, which every case starts from.
#[derive(Clone, Copy, Debug)]
struct Polar {
    /// Angle from the x axis, in [0, 2π] (`x_axis_A_coord`).
    angle: f32,
    /// Half a regular segment's angle, π / sides (`segment_divider_A_angle_bisector`).
    half: f32,
    /// A regular segment's angle (`segment_divider_A_next_segment_divider`).
    full: f32,
    /// The segment's index as a float (`segment_id`, rounded as the angle is, unlike the
    /// Segment ID output).
    id: f32,
    /// Angle from the segment's divider (`segment_divider_A_coord`).
    local: f32,
}

impl Polar {
    fn new(sides: f32, coord: Vec2) -> Self {
        let angle = coord.y.atan2(coord.x) + below_x_axis(coord) * TAU;
        let half = PI / sides;
        let full = 2.0 * half;
        let id = (angle / full).floor();
        let local = angle - id * full;
        Polar { angle, half, full, id, local }
    }

    /// The rotation of a segment whose bisector lies `bisector` from its divider.
    fn rotation(&self, bisector: f32) -> f32 {
        self.id * self.full + bisector
    }
}

/// Negated before the bisector, which lies `bisector` from the divider: the parameter runs
/// from negative to positive across the segment.
#[inline]
fn signed(value: f32, local: f32, bisector: f32) -> f32 {
    if local < bisector { -value } else { value }
}

/// Cycles' `mix`: a + t (b − a).
#[inline]
fn mix(a: f32, b: f32, t: f32) -> f32 {
    a + t * (b - a)
}

/// One rounded corner's geometry: the bevel start's angle from its divider (`bevel`), the
/// angle from it to the bisector, the roundness (or the effective one next to the irregular
/// segment) and the spline's start before the bevel start (`spline_start_A_bevel_start`).
#[derive(Clone, Copy, Debug)]
struct Bevel {
    bevel: f32,
    to_bisector: f32,
    roundness: f32,
    spline: f32,
}

impl Bevel {
    /// A regular corner of roundness `roundness` on a segment half `half` wide.
    fn regular(half: f32, roundness: f32) -> Self {
        let bevel = half - ((1.0 - roundness) * half.tan()).atan();
        Bevel { bevel, to_bisector: half - bevel, roundness, spline: (1.0 - roundness) * bevel }
    }

    /// The parameter's normaliser on the straight side, from the distance along the
    /// bisector (`normalize_based_on_l_angle_bisector`).
    fn norm_straight(&self, along: f32) -> f32 {
        along * self.to_bisector.tan() + self.spline * (0.5 * along + 0.5) + self.roundness * self.bevel
    }

    /// The same from the distance to the origin, in the rounded corner
    /// (`normalize_based_on_l_coord`).
    fn norm_rounded(&self, l: f32) -> f32 {
        l * self.to_bisector.sin()
            + self.spline * (0.5 * l * self.to_bisector.cos() + 0.5)
            + self.roundness * self.bevel
    }

    /// Segment Width of a regular segment (`max_unit_parameter`).
    fn width(&self) -> f32 {
        self.to_bisector.tan() + self.spline + self.roundness * self.bevel
    }

    /// The unsigned parameter in the rounded corner, `to_bevel` before the bevel start, as
    /// its two terms (Cycles adds the second to the first, each scaled alike): the bevel
    /// start's, and the way from it (a quadratic spline up to `spline`, then along the arc).
    fn rounded_parameter(&self, l: f32, to_bevel: f32) -> (f32, f32) {
        let cos = self.to_bisector.cos();
        let from_bevel = if to_bevel < self.spline {
            l * cos * to_bevel + 0.5 * (1.0 - l * cos) * (to_bevel * to_bevel) / self.spline
        } else {
            self.spline * (0.5 * l * cos - 0.5) + to_bevel
        };
        (l * self.to_bisector.sin(), from_bevel)
    }
}

/// `calculate_out_variables`: the segment's coordinates, width and rotation, after the
/// parameter is mapped to [0, 1] (normalized) or the distance shifted to 0 at the polygon.
fn segment(normalize: bool, sides: f32, roundness: f32, coord: Vec2) -> Segment {
    let l = (coord.x * coord.x + coord.y * coord.y).sqrt();
    let mut s = if sides - sides.floor() == 0.0 {
        regular(normalize, sides, roundness, coord, l)
    } else if roundness == 0.0 {
        irregular_straight(normalize, sides, coord, l)
    } else {
        irregular_circular(normalize, sides, roundness, coord, l)
    };
    if coord.x == 0.0 && coord.y == 0.0 {
        // The parameter is defined as 0 at the origin (where a normalised one is 0 / 0).
        s.parameter = 0.0;
    }
    if normalize {
        s.parameter = 0.5 * s.parameter + 0.5;
    } else {
        s.along_bisector -= 1.0;
    }
    s
}

/// Whole `sides`: every segment alike.
fn regular(normalize: bool, sides: f32, roundness: f32, coord: Vec2, l: f32) -> Segment {
    let p = Polar::new(sides, coord);
    let rotation = p.rotation(p.half);
    if roundness == 0.0 {
        // Regular straight part (a sharp polygon; two sides make a straight line, whose
        // parameter cannot be normalised).
        let along = l * (p.half - p.local).cos();
        let mut parameter = signed(along * (p.half - p.local).abs().tan(), p.local, p.half);
        if normalize && sides != 2.0 {
            parameter /= along * p.half.tan();
        }
        let width = if sides != 2.0 { p.half.tan() } else { 0.0 };
        Segment { along_bisector: along, parameter, width, rotation }
    } else if roundness == 1.0 {
        // Regular rounded part (circles: the parameter is the angle).
        let mut parameter = signed((p.half - p.local).abs(), p.local, p.half);
        if normalize {
            parameter /= p.half;
        }
        Segment { along_bisector: l, parameter, width: p.half, rotation }
    } else {
        let bevel = Bevel::regular(p.half, roundness);
        if p.local >= p.full - bevel.bevel || p.local < bevel.bevel {
            regular_rounded(normalize, roundness, &p, &bevel, l, rotation)
        } else {
            // Regular straight part.
            let along = l * (p.half - p.local).cos();
            let mut parameter = signed(along * (p.half - p.local).abs().tan(), p.local, p.half);
            if normalize {
                parameter /= bevel.norm_straight(along);
            }
            Segment { along_bisector: along, parameter, width: bevel.width(), rotation }
        }
    }
}

/// Regular rounded part: a point in a regular segment's corner arc, within `bevel.bevel`
/// of its nearest divider.
fn regular_rounded(normalize: bool, roundness: f32, p: &Polar, bevel: &Bevel, l: f32, rotation: f32) -> Segment {
    // Signed angle from the nearest divider (`nearest_segment_divider_SA_coord`).
    let from_divider = p.local - if p.local > p.half { p.full } else { 0.0 };
    // The corner circle's centre lies on the divider at this distance; the point's distance
    // over the arc's at its angle gives the distance along the bisector.
    let centre = (1.0 - roundness) / p.half.cos();
    let c = from_divider.cos() * centre;
    let arc = c + (c * c + roundness * roundness - centre * centre).sqrt();
    let along = l / arc;
    let to_bevel = bevel.bevel - from_divider.abs();
    let (start, from_bevel) = bevel.rounded_parameter(l, to_bevel);
    let mut parameter = signed(start + from_bevel, p.local, p.half);
    if normalize {
        parameter /= mix(bevel.norm_straight(along), bevel.norm_rounded(l), to_bevel / bevel.bevel);
    }
    Segment { along_bisector: along, parameter, width: bevel.width(), rotation }
}

/// The last bisector's angle from the x axis, π − ⌊sides⌋ π / sides
/// (`last_angle_bisector_A_x_axis`): the irregular segment spans twice that before 2π.
#[inline]
fn last_bisector(sides: f32, half: f32) -> f32 {
    PI - sides.floor() * half
}

/// Fractional `sides` and no roundness: sharp polygons, the last one narrower.
fn irregular_straight(normalize: bool, sides: f32, coord: Vec2, l: f32) -> Segment {
    let p = Polar::new(sides, coord);
    let last = last_bisector(sides, p.half);
    if p.angle < TAU - 2.0 * last {
        // Regular straight part.
        let along = l * (p.half - p.local).cos();
        let mut parameter = signed(along * (p.half - p.local).abs().tan(), p.local, p.half);
        if normalize {
            parameter /= along * p.half.tan();
        }
        Segment { along_bisector: along, parameter, width: p.half.tan(), rotation: p.rotation(p.half) }
    } else {
        // Irregular straight part: distances along the last bisector, scaled so that the
        // narrow segment's polygon side continues its neighbours'.
        let ratio = p.half.cos() / last.cos();
        let along_last = l * (last - p.local).cos();
        let mut parameter = signed(ratio * along_last * (last - p.local).abs().tan(), p.local, last);
        if normalize {
            parameter /= ratio * along_last * last.tan();
        }
        Segment { along_bisector: ratio * along_last, parameter, width: last.tan(), rotation: p.rotation(last) }
    }
}

/// The geometry of the irregular segment's corners (fractional `sides`, some roundness):
/// its inner bevel start, its last corner's circle, and the outer bevel start where that
/// circle meets the neighbouring regular segments' side.
#[derive(Clone, Copy, Debug)]
struct LastCorner {
    /// The last bisector's angle from the x axis.
    last: f32,
    /// The irregular segment's inner bevel start, from the x axis
    /// (`inner_last_bevel_start_A_x_axis`).
    inner: f32,
    /// The last corner circle's radius and centre.
    radius: f32,
    centre: Vec2,
    /// The outer bevel start's angle from the x axis (`x_axis_A_outer_last_bevel_start`).
    outer: f32,
}

impl LastCorner {
    fn new(p: &Polar, sides: f32, roundness: f32) -> Self {
        let last = last_bisector(sides, p.half);
        let inner = last - ((1.0 - roundness) * last.tan()).atan();
        let radius = roundness * last.tan() / (0.5 * (p.half + last)).tan();
        let reach = (last - inner).cos();
        let centre = Vec2::new(inner.cos() / reach - radius * last.cos(), radius * last.sin() - inner.sin() / reach);
        let outer_start = centre + radius * Vec2::new(p.half.cos(), p.half.sin());
        let outer = (outer_start.y / outer_start.x).atan();
        LastCorner { last, inner, radius, centre, outer }
    }

    /// The corner next to the irregular segment on a regular segment: its bevel starts at
    /// `outer` (`effective_roundness`, `spline_start_outer_last_bevel_start`).
    fn outer_bevel(&self, half: f32) -> Bevel {
        let roundness = 1.0 - (half - self.outer).tan() / half.tan();
        Bevel { bevel: self.outer, to_bisector: half - self.outer, roundness, spline: (1.0 - roundness) * self.outer }
    }

    /// The irregular segment's own corner, measured on the last bisector.
    fn inner_bevel(&self, roundness: f32) -> Bevel {
        Bevel {
            bevel: self.inner,
            to_bisector: self.last - self.inner,
            roundness,
            spline: (1.0 - roundness) * self.inner,
        }
    }
}

/// `calculate_out_variables_irregular_circular`: fractional `sides` with roundness.
fn irregular_circular(normalize: bool, sides: f32, roundness: f32, coord: Vec2, l: f32) -> Segment {
    let p = Polar::new(sides, coord);
    let corner = LastCorner::new(&p, sides, roundness);
    let last_divider = 2.0 * corner.last;
    let bevel = Bevel::regular(p.half, roundness);

    if p.angle >= corner.outer && p.angle < TAU - last_divider - corner.outer {
        // The regular segments, away from the irregular segment's corner circle.
        let straight = (p.local >= bevel.bevel && p.local < p.full - bevel.bevel)
            || p.angle >= TAU - last_divider - bevel.bevel
            || p.angle < bevel.bevel;
        if !straight {
            return regular_rounded(normalize, roundness, &p, &bevel, l, p.rotation(p.half));
        }
        // Regular straight part.
        let along = l * (p.half - p.local).cos();
        let mut parameter = signed(along * (p.half - p.local).abs().tan(), p.local, p.half);
        if normalize {
            let next_to_irregular = p.angle >= TAU - last_divider - p.half || p.angle < p.half;
            parameter /= if next_to_irregular {
                // Irregular rounded outer part: normalised by the outer corner's bevel.
                corner.outer_bevel(p.half).norm_straight(along)
            } else {
                bevel.norm_straight(along)
            };
        }
        return Segment { along_bisector: along, parameter, width: bevel.width(), rotation: p.rotation(p.half) };
    }

    let ratio = p.half.cos() / corner.last.cos();
    let inner = corner.inner_bevel(roundness);
    // Segment Width of the irregular segment: its inner bevel's, scaled to the regular ones.
    let irregular_width =
        inner.to_bisector.tan() + ratio * (inner.spline * (0.5 / ratio + 0.5) + roundness * inner.bevel);

    if p.angle >= TAU - last_divider + corner.inner && p.angle < TAU - corner.inner {
        // Irregular straight part.
        let along_last = l * (corner.last - p.local).cos();
        let mut parameter = signed(ratio * along_last * (corner.last - p.local).abs().tan(), p.local, corner.last);
        if normalize {
            parameter /= ratio * inner.norm_straight(along_last);
        }
        return Segment {
            along_bisector: ratio * along_last,
            parameter,
            width: irregular_width,
            rotation: p.rotation(corner.last),
        };
    }

    // Irregular rounded part: the angle from the nearest divider, mirrored about the last
    // bisector so that both sides of the irregular segment's corner read alike
    // (`nearest_segment_divider_MSA_coord`): negative inside the irregular segment.
    let mut from_divider = coord.y.atan2(coord.x);
    if p.angle >= TAU - last_divider - corner.outer && p.angle < TAU - corner.last {
        from_divider = -(from_divider + last_divider);
    }
    let (sin, cos) = (from_divider.sin(), from_divider.cos());
    let c = sin * corner.centre.y + cos * corner.centre.x;
    let arc = c
        + (c * c + corner.radius * corner.radius
            - corner.centre.x * corner.centre.x
            - corner.centre.y * corner.centre.y)
            .sqrt();
    let along_last = l / arc;
    let along = ratio * along_last;

    if from_divider < 0.0 {
        // Irregular rounded inner part.
        let to_bevel = inner.bevel - from_divider.abs();
        // Cycles scales the distance before the sine here: (ratio l) sin.
        let (_, from_bevel) = inner.rounded_parameter(l, to_bevel);
        let start = ratio * l * inner.to_bisector.sin();
        let mut parameter = signed(start + ratio * from_bevel, p.local, corner.last);
        if normalize {
            let norm = mix(inner.norm_straight(along_last), inner.norm_rounded(l), to_bevel / inner.bevel);
            parameter /= ratio * norm;
        }
        Segment { along_bisector: along, parameter, width: irregular_width, rotation: p.rotation(corner.last) }
    } else {
        // Irregular rounded outer part.
        let outer = corner.outer_bevel(p.half);
        let to_bevel = outer.bevel - from_divider.abs();
        let (start, from_bevel) = outer.rounded_parameter(l, to_bevel);
        let mut parameter = signed(start + from_bevel, p.local, p.half);
        if normalize {
            parameter /= mix(outer.norm_straight(along), outer.norm_rounded(l), to_bevel / outer.bevel);
        }
        Segment { along_bisector: along, parameter, width: bevel.width(), rotation: p.rotation(p.half) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL: RadialTilingUse = RadialTilingUse { segment: true, segment_id: true };

    /// Every output is finite at the origin (where the angle is 0 / 0) and on the axes, for
    /// every case: whole and fractional sides, each roundness branch, normalised or not. Two
    /// sides with a roundness strictly between 0 and 1 are left out: Blender's corner circle
    /// then has its centre at (1 − roundness) / cos(π/2), and its values are NaN (as ours,
    /// `tests/texture_reference.rs`).
    #[test]
    fn origin_and_axes_are_finite() {
        for sides in [2.0, 3.0, 5.0, 6.5, 2.3, 1.0, -4.0] {
            for roundness in [0.0, 0.3, 1.0, -1.0, 2.0] {
                if sides <= 2.0 && roundness == 0.3 {
                    continue;
                }
                for normalize in [false, true] {
                    let axes = [Vec2::ZERO, Vec2::X, Vec2::new(-1.0, 0.0), Vec2::Y, -Vec2::Y, Vec2::new(0.0, -0.0)];
                    for coord in axes {
                        let o = radial_tiling(coord, sides, roundness, normalize, ALL);
                        let v = [o.coordinates.x, o.coordinates.y, o.coordinates.z, o.segment_id, o.width, o.rotation];
                        assert!(v.iter().all(|x| x.is_finite()), "{sides} {roundness} {normalize} {coord}: {o:?}");
                    }
                }
            }
        }
    }

    /// On the negative x axis with y = −0, `atan2` is −π and no turn is added (−0 is not
    /// below the axis): the segment is counted backwards, as Blender does (its geometry nodes
    /// give Segment ID −4 and Rotation −3.6249 at (−1, −0) with 6.5 sides).
    #[test]
    fn negative_zero_y_counts_backwards_as_blender() {
        let o = radial_tiling(Vec2::new(-1.0, -0.0), 6.5, 1.0, false, ALL);
        assert_eq!(o.segment_id, -4.0);
        assert!((o.rotation + 3.6249144).abs() < 1e-5, "{o:?}");
        assert!((o.coordinates.y - 1.9942653).abs() < 1e-5, "{o:?}");
    }

    /// A NaN Sides or Roundness reads as 2 sides and roundness 0, as Cycles' fmaxf and clamp.
    #[test]
    fn nan_settings_clamp_as_cycles() {
        let c = Vec2::new(0.3, 0.7);
        assert_eq!(radial_tiling(c, f32::NAN, 0.0, true, ALL), radial_tiling(c, 2.0, 0.0, true, ALL));
        assert_eq!(radial_tiling(c, 5.0, f32::NAN, true, ALL), radial_tiling(c, 5.0, 0.0, true, ALL));
    }

    /// At the origin the parameter is 0 (½ normalised) and the distance 0 (−1 unnormalised).
    #[test]
    fn origin_values() {
        let o = radial_tiling(Vec2::ZERO, 5.0, 0.3, false, ALL);
        assert_eq!(o.coordinates, Vec3::new(0.0, -1.0, 0.0));
        let o = radial_tiling(Vec2::ZERO, 6.5, 0.3, true, ALL);
        assert_eq!(o.coordinates.x, 0.5);
    }

    /// The polygon's apothem is 1: a sharp pentagon's side midpoint at distance 1 is on it
    /// (distance 0 unnormalised, parameter 0), and its corner, at 1 / cos(π/5), has the
    /// parameter ±Segment Width (1 normalised, just before the next divider).
    #[test]
    fn sharp_pentagon_geometry() {
        let half = PI / 5.0;
        let mid = Vec2::new(half.cos(), half.sin());
        let o = radial_tiling(mid, 5.0, 0.0, false, ALL);
        assert!(o.coordinates.y.abs() < 1e-6 && o.coordinates.x.abs() < 1e-6, "{o:?}");
        assert!((o.rotation - half).abs() < 1e-6 && o.segment_id == 0.0);
        assert!((o.width - half.tan()).abs() < 1e-6);
        let a = 2.0 * half - 1e-4;
        let corner = Vec2::new(a.cos(), a.sin()) / half.cos();
        let o = radial_tiling(corner, 5.0, 0.0, false, ALL);
        assert!((o.coordinates.x - o.width).abs() < 1e-3 && o.coordinates.y.abs() < 1e-3, "{o:?}");
        let o = radial_tiling(corner, 5.0, 0.0, true, ALL);
        assert!((o.coordinates.x - 1.0).abs() < 1e-3, "{o:?}");
    }

    /// Segment IDs count segments counterclockwise from the x axis; a fractional count's last
    /// segment is ⌊sides⌋.
    #[test]
    fn segment_ids() {
        for (sides, k) in [(5.0f32, 5), (6.5, 7), (2.0, 2)] {
            for i in 0..k {
                let a = (i as f32 + 0.5) * TAU / sides;
                let a = a.min(TAU - 1e-3);
                assert_eq!(segment_id(sides, Vec2::new(a.cos(), a.sin())), i as f32, "{sides} {i}");
            }
        }
    }

    /// With roundness, coordinates are continuous across the case boundaries inside a
    /// segment (bevel starts, the irregular segment's corners): small angle steps make small
    /// changes everywhere except across the segment dividers.
    #[test]
    fn continuous_within_segments() {
        for sides in [5.0f32, 6.5, 3.3] {
            for roundness in [0.3, 0.8, 1.0] {
                for normalize in [false, true] {
                    let n = 20000;
                    let mut prev: Option<(f32, Vec3)> = None;
                    for k in 0..n {
                        let a = (k as f32 + 0.5) * TAU / n as f32;
                        let c = Vec2::new(a.cos(), a.sin()) * 1.3;
                        let id = segment_id(sides, c);
                        let o = radial_tiling(c, sides, roundness, normalize, ALL);
                        if let Some((pid, pc)) = prev
                            && pid == id
                        {
                            let d = (o.coordinates - pc).abs().max_element();
                            assert!(d < 2e-2, "{sides} {roundness} {normalize} at {a}: {pc} -> {}", o.coordinates);
                        }
                        prev = Some((id, o.coordinates));
                    }
                }
            }
        }
    }
}
