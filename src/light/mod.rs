//! Light sources: punctual lights of `KHR_lights_punctual`, Blender's area lights
//! (`CAUSTIC_lights_area`) and emissive triangles. Each can be sampled from a
//! shading point (`sample_li`), and the non-delta ones report the density with which
//! a direction would have been chosen (`pdf_li`) for multiple importance sampling.
//!
//! Units are radiometric, as Cycles': point and spot intensity in W/sr, directional
//! irradiance in W/m², area radiance in W/(m² sr). The loader converts glTF's
//! photometric units (cd, lux) by Blender's exporter convention (683 lm/W).

pub mod emit;
pub mod environment;
pub mod inside;
pub mod light_graph;
pub mod media_emit;
pub mod origin;
pub mod path_emitters;
pub mod sample;
pub mod sampler;
pub mod tree;
pub mod world_graph;

use crate::math::Rgb;
use crate::sampling::warp::{concentric_disk, uniform_triangle};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

pub use environment::Environment;
pub use sampler::{LightSampler, LightSamplerKind};

/// A light's weight in light selection from its power (RGB, W): the size of its luminance,
/// so a negative light, which subtracts light, is picked as often as a positive one of its
/// size, as Cycles' light tree takes |energy|; every path carries the sign in the emission.
#[inline]
pub fn selection_weight(power: Rgb) -> f32 {
    crate::math::luminance(power).abs()
}

/// A sun whose half angle has a cosine at least this is a delta light.
pub const DELTA_SUN_COS: f32 = 1.0 - 1e-7;

/// Radiance of a sun disk of half-angle cosine `cos_half` giving irradiance `e` at normal
/// incidence: E = L π sin²α (the projected solid angle of a spherical cap).
#[inline]
pub fn sun_radiance(e: Rgb, cos_half: f32) -> Rgb {
    e / (std::f32::consts::PI * (1.0 - cos_half * cos_half))
}

/// Shape of an area light.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AreaShape {
    /// Parallelogram spanned by ±ax, ±ay (a rectangle before any shear).
    Rectangle,
    /// Ellipse with semi-axes ax, ay (a disk when they are equal).
    Ellipse,
}

/// A planar one-sided area light (Blender's area lamp), already in world space.
#[derive(Clone, Copy, Debug)]
pub struct AreaLight {
    /// Shape.
    pub shape: AreaShape,
    /// Centre.
    pub center: Vec3,
    /// Half extent (rectangle) or semi-axis (ellipse) along the light's local X.
    pub ax: Vec3,
    /// Same along local Y.
    pub ay: Vec3,
    /// Unit normal on the emitting side.
    pub normal: Vec3,
    /// Dual basis: (p - center)·dx = local x in [-1, 1].
    pub dx: Vec3,
    /// Dual basis for local y.
    pub dy: Vec3,
    /// World-space area.
    pub area: f32,
    /// Emitted radiance.
    pub radiance: Rgb,
    /// Seen by camera rays (Blender's Ray Visibility > Camera; off by default for lights).
    pub camera_visible: bool,
    /// tan of half of Blender's Spread angle (emission is zero beyond it).
    pub tan_half_spread: f32,
    /// Cycles' normalisation of the spread falloff, 1 / (tan h - h); 0 without spread.
    pub normalize_spread: f32,
}

/// Smallest spread accepted (radians); narrower is a collimated beam, which Cycles renders
/// by a separate rule that Caustic does not have.
pub const MIN_SPREAD: f32 = 1e-3;

impl AreaLight {
    /// Builds the light from its world-space frame; None when the area is zero.
    pub fn new(shape: AreaShape, center: Vec3, ax: Vec3, ay: Vec3, emit_dir: Vec3, power: Rgb) -> Option<Self> {
        let cross = ax.cross(ay);
        let scale = match shape {
            AreaShape::Rectangle => 4.0,
            AreaShape::Ellipse => PI,
        };
        let area = cross.length() * scale;
        if !(area > 1e-12) || !area.is_finite() {
            return None;
        }
        let mut normal = cross.normalize();
        if normal.dot(emit_dir) < 0.0 {
            normal = -normal;
        }
        let (g00, g01, g11) = (ax.dot(ax), ax.dot(ay), ay.dot(ay));
        let det = g00 * g11 - g01 * g01;
        let dx = (ax * g11 - ay * g01) / det;
        let dy = (ay * g00 - ax * g01) / det;
        Some(AreaLight {
            shape,
            center,
            ax,
            ay,
            normal,
            dx,
            dy,
            area,
            radiance: power / (PI * area),
            camera_visible: true,
            tan_half_spread: f32::INFINITY,
            normalize_spread: 0.0,
        })
    }

    /// The light with Blender's Spread (full angle, radians, in [MIN_SPREAD, π]): radiance
    /// falls off as Cycles' soft-box grid, max((tan h - tan θ) / (tan h - h), 0) with h half
    /// the spread and θ the angle to the normal, which keeps the emitted power.
    pub fn with_spread(self, spread: f32) -> Self {
        if spread >= PI - 1e-4 {
            return self;
        }
        let h = 0.5 * spread.max(MIN_SPREAD);
        let tan_h = h.tan();
        // tan h - h loses its digits for small h: its series h³/3 (as Cycles).
        let normalize_spread = if h > 0.05 { 1.0 / (tan_h - h) } else { 3.0 / (h * h * h) };
        AreaLight { tan_half_spread: tan_h, normalize_spread, ..self }
    }

    /// Half of the spread angle (π/2 without spread).
    pub fn half_spread(&self) -> f32 {
        if self.normalize_spread > 0.0 { self.tan_half_spread.atan() } else { PI / 2.0 }
    }

    /// Spread falloff for emission at cos θ to the normal (1 without spread, 0 behind).
    #[inline]
    pub fn spread_attenuation(&self, cos_theta: f32) -> f32 {
        if cos_theta <= 0.0 {
            return 0.0;
        }
        if self.normalize_spread == 0.0 {
            return 1.0;
        }
        let tan_a = (1.0 - cos_theta * cos_theta).max(0.0).sqrt() / cos_theta;
        ((self.tan_half_spread - tan_a) * self.normalize_spread).max(0.0)
    }

    /// The window of local coordinates sampled from `p`: the whole light, or with a spread
    /// the part of its bounding rectangle within the circle that can light `p` (radius
    /// t tan h around p's foot on the plane, t its height), as Cycles narrows sampling.
    /// Returns ([x0, x1, y0, y1], whole light); None when no point of it can light `p`.
    #[inline]
    fn window(&self, p: Vec3) -> Option<([f32; 4], bool)> {
        if self.normalize_spread == 0.0 {
            return Some(([-1.0, 1.0, -1.0, 1.0], true));
        }
        let t = self.normal.dot(p - self.center);
        if !(t > 0.0) {
            return None;
        }
        let r = t * self.tan_half_spread;
        let foot = p - self.normal * t - self.center;
        let (xs, ys) = (foot.dot(self.dx), foot.dot(self.dy));
        let (rx, ry) = (r * self.dx.length(), r * self.dy.length());
        let w = [(xs - rx).max(-1.0), (xs + rx).min(1.0), (ys - ry).max(-1.0), (ys + ry).min(1.0)];
        if !(w[0] < w[1] && w[2] < w[3]) {
            return None;
        }
        let whole = w == [-1.0, 1.0, -1.0, 1.0];
        Some((w, whole))
    }

    /// A point on the light for shading point `p` and its density per unit area: uniform
    /// over the light, or with a spread over the window that can light `p`. None when the
    /// sample falls outside the shape or where the light sends nothing toward `p`.
    #[inline]
    pub fn sample_from(&self, p: Vec3, u: Vec2) -> Option<(Vec3, f32)> {
        let (w, whole) = self.window(p)?;
        if whole {
            let q = self.sample_point(u);
            return (self.spread_attenuation(self.normal.dot((p - q).normalize_or_zero())) > 0.0)
                .then_some((q, 1.0 / self.area));
        }
        let (x, y) = (w[0] + (w[1] - w[0]) * u.x, w[2] + (w[3] - w[2]) * u.y);
        if self.shape == AreaShape::Ellipse && x * x + y * y > 1.0 {
            return None;
        }
        let q = self.center + self.ax * x + self.ay * y;
        if !(self.spread_attenuation(self.normal.dot((p - q).normalize_or_zero())) > 0.0) {
            return None;
        }
        Some((q, 1.0 / ((w[1] - w[0]) * (w[3] - w[2]) * self.ax.cross(self.ay).length())))
    }

    /// Density per unit area with which `sample_from(p, ·)` returns the light point `q`.
    #[inline]
    pub fn pdf_area_from(&self, p: Vec3, q: Vec3) -> f32 {
        let Some((w, whole)) = self.window(p) else {
            return 0.0;
        };
        if !(self.spread_attenuation(self.normal.dot((p - q).normalize_or_zero())) > 0.0) {
            return 0.0;
        }
        if whole {
            return 1.0 / self.area;
        }
        let l = q - self.center;
        let (x, y) = (l.dot(self.dx), l.dot(self.dy));
        if x < w[0] || x > w[1] || y < w[2] || y > w[3] {
            return 0.0;
        }
        1.0 / ((w[1] - w[0]) * (w[3] - w[2]) * self.ax.cross(self.ay).length())
    }

    /// Ray hit distance, if the ray hits the emitting region (either side).
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, tmax: f32) -> Option<f32> {
        let denom = self.normal.dot(d);
        if denom.abs() < 1e-12 {
            return None;
        }
        let t = self.normal.dot(self.center - o) / denom;
        if !(t > 0.0 && t < tmax) {
            return None;
        }
        let q = o + d * t - self.center;
        let (x, y) = (q.dot(self.dx), q.dot(self.dy));
        let inside = match self.shape {
            AreaShape::Rectangle => x.abs() <= 1.0 && y.abs() <= 1.0,
            AreaShape::Ellipse => x * x + y * y <= 1.0,
        };
        inside.then_some(t)
    }

    /// Uniform point on the light.
    #[inline]
    pub fn sample_point(&self, u: Vec2) -> Vec3 {
        let l = match self.shape {
            AreaShape::Rectangle => 2.0 * u - Vec2::ONE,
            AreaShape::Ellipse => concentric_disk(u),
        };
        self.center + self.ax * l.x + self.ay * l.y
    }
}

/// One light of the scene.
#[derive(Clone, Copy, Debug)]
pub enum Light {
    /// Isotropic point light.
    Point {
        /// Position.
        position: Vec3,
        /// Radiant intensity (W/sr).
        intensity: Rgb,
    },
    /// Spot light with glTF's smooth cone falloff, or Blender's when `smooth` is set.
    Spot {
        /// Position.
        position: Vec3,
        /// Unit direction the spot points to.
        direction: Vec3,
        /// Radiant intensity on the axis (W/sr).
        intensity: Rgb,
        /// cos of the inner cone angle (full intensity inside).
        cos_inner: f32,
        /// cos of the outer cone angle (zero outside).
        cos_outer: f32,
        /// Blender's spot blend as Cycles applies it: smoothstep((cos θ - cos_outer) × smooth),
        /// smooth = 1 / ((1 - cos_outer) blend); None for glTF's falloff.
        smooth: Option<f32>,
        /// The cone stretched by the light object's non-uniform scale (Blender's); None for a
        /// round cone.
        axes: Option<SpotAxes>,
    },
    /// Sun-like light from one direction, or from a cone of directions (Blender's sun angle).
    Directional {
        /// Unit direction the light travels in (the cone's axis).
        direction: Vec3,
        /// Irradiance on a surface facing the light (W/m²).
        irradiance: Rgb,
        /// cos of the cone's half angle; 1 for a delta light.
        cos_half: f32,
    },
    /// Blender's point light with a radius: a sphere of radiance power / (4π² r²), or with
    /// Blender's "soft falloff" (its default) a disk of the same radius and radiance that
    /// always faces the shading point, as Cycles renders it (irradiance I / (d² + r²)).
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
        /// Emitted radiance.
        radiance: Rgb,
        /// The disk-facing-the-point model of Blender's soft falloff.
        soft: bool,
        /// Seen by camera rays.
        camera_visible: bool,
        /// Blender's spot with a radius: the cone that masks the sphere's emission.
        spot: Option<SpotCone>,
    },
    /// Planar area light.
    Area(AreaLight),
    /// Emissive triangle `tri` of the scene mesh.
    Triangle {
        /// Triangle index.
        tri: u32,
    },
    /// The world (`Scene::world`): light from infinitely far away.
    World,
}

impl Light {
    /// The light with its emission multiplied by `f` (a constant node tree's value; emissive
    /// triangles and the world carry their own graphs and are returned as they are).
    pub fn scaled(self, f: Rgb) -> Light {
        match self {
            Light::Point { position, intensity } => Light::Point { position, intensity: intensity * f },
            Light::Spot { intensity, position, direction, cos_inner, cos_outer, smooth, axes } => {
                Light::Spot { intensity: intensity * f, position, direction, cos_inner, cos_outer, smooth, axes }
            }
            Light::Directional { direction, irradiance, cos_half } => {
                Light::Directional { direction, irradiance: irradiance * f, cos_half }
            }
            Light::Sphere { center, radius, radiance, soft, camera_visible, spot } => {
                Light::Sphere { center, radius, radiance: radiance * f, soft, camera_visible, spot }
            }
            Light::Area(a) => Light::Area(AreaLight { radiance: a.radiance * f, ..a }),
            Light::Triangle { .. } | Light::World => self,
        }
    }

    /// The box of the points a light emits from (a point or spot light's position, a
    /// sphere's ball, an area light's rectangle or disk); None for lights without a place
    /// (suns, the world) and for emissive triangles, which lie among the surfaces.
    pub fn extent(&self) -> Option<(Vec3, Vec3)> {
        match self {
            Light::Point { position, .. } | Light::Spot { position, .. } => Some((*position, *position)),
            Light::Sphere { center, radius, .. } => {
                Some((*center - Vec3::splat(*radius), *center + Vec3::splat(*radius)))
            }
            Light::Area(a) => {
                let corners = [a.ax + a.ay, a.ax - a.ay, -a.ax + a.ay, -a.ax - a.ay].map(|c| a.center + c);
                Some(corners.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), c| (lo.min(*c), hi.max(*c))))
            }
            Light::Directional { .. } | Light::Triangle { .. } | Light::World => None,
        }
    }
}

/// A point sampled on a light, as seen from a shading point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the shading point to the light.
    pub wi: Vec3,
    /// Distance to the light point (infinite for directional lights).
    pub dist: f32,
    /// Incident radiance (area lights) or irradiance-like value for delta lights,
    /// so that `li * f * cos / pdf` is the estimate in both cases.
    pub li: Rgb,
    /// Solid-angle density (1 for delta lights).
    pub pdf: f32,
    /// True for point, spot and directional lights (no MIS with BSDF sampling).
    pub delta: bool,
    /// Point on the light (for shadow rays).
    pub point: Vec3,
    /// Light surface normal at `point` (zero for delta lights).
    pub normal: Vec3,
}

/// Geometry of an emissive triangle, for light sampling; it emits from both faces
/// (`Material::emissive`).
#[derive(Clone, Copy, Debug)]
pub struct EmitterTriangle {
    /// Vertices.
    pub p: [Vec3; 3],
}

/// The cone of Blender's spot with a radius, which Cycles renders as its sphere (or soft
/// falloff disk) light masked by the spot's attenuation of each emitted ray's direction (from
/// the sampled point of the light to the receiver, so the cone's edge blurs by the light's
/// size, as in Cycles); receivers inside the sphere are not masked, as Cycles leaves them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpotCone {
    /// Unit direction the spot points to.
    pub direction: Vec3,
    /// cos of the inner cone angle (glTF's falloff only).
    pub cos_inner: f32,
    /// cos of the outer cone angle (zero beyond).
    pub cos_outer: f32,
    /// Blender's smoothstep factor, as `Light::Spot`'s; None for glTF's falloff.
    pub smooth: Option<f32>,
    /// The cone stretched by the object's scale, as `Light::Spot`'s.
    pub axes: Option<SpotAxes>,
}

impl SpotCone {
    /// The attenuation of light leaving in unit direction `w`.
    #[inline]
    pub fn attenuation(&self, w: Vec3) -> f32 {
        spot_attenuation(spot_cos(self.direction, &self.axes, w), self.cos_inner, self.cos_outer, self.smooth)
    }

    /// cos of the round cone around `direction` that holds every direction lit.
    #[inline]
    pub fn cos_bound(&self) -> f32 {
        spot_cos_bound(self.cos_outer, &self.axes)
    }

    /// The mask of a ray leaving a sphere light (`center`, `radius`) in unit direction `w`
    /// toward receiver `p`.
    #[inline]
    pub fn mask(&self, center: Vec3, radius: f32, p: Vec3, w: Vec3) -> f32 {
        if (p - center).length_squared() <= radius * radius { 1.0 } else { self.attenuation(w) }
    }

    /// The share of the sphere's power the cone lets out (the attenuation's mean over
    /// directions: every direction leaves the sphere through the same projected area), for
    /// light selection: the cone's solid angle over 4π, times the blend ramp's mean
    /// (∫ smoothstep over the ramp is half its width); glTF's ramp is bounded by the cone.
    pub fn power_share(&self) -> f32 {
        let cone = 0.5 * (1.0 - self.cos_outer);
        match self.smooth {
            Some(k) => cone * (1.0 - 0.5 * (1.0 / (k * (1.0 - self.cos_outer))).min(1.0)),
            None => cone,
        }
    }
}

/// A light object's axes that are not orthogonal (a sheared parent).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ShearedAxes;

/// A spot cone stretched by its light object's non-uniform scale, as Cycles measures a
/// direction against it (`spot_light_to_local`): the direction's components along the
/// object's X and Y axes and the spot's direction, each divided by that axis' scale, then
/// normalised; its z is the cosine the attenuation reads. A wider X or Y widens the cone
/// that way; a longer Z narrows it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpotAxes {
    /// The object's unit X axis over its scale.
    pub u: Vec3,
    /// The object's unit Y axis over its scale.
    pub v: Vec3,
    /// The spot's unit direction over the Z scale.
    pub d: Vec3,
    /// max(s_x, s_y) / s_z: how much the tangent of the cone's widest half angle grows.
    pub widening: f32,
}

impl SpotAxes {
    /// The axes of a spot whose object's X, Y and Z axes (with their scale) are `x`, `y`,
    /// `z` and whose unit direction is `direction`; None when the scale is uniform (the round
    /// cone) or the axes are not orthogonal (a sheared parent; the caller warns).
    pub fn from_object_axes(x: Vec3, y: Vec3, z: Vec3, direction: Vec3) -> Result<Option<Self>, ShearedAxes> {
        let (sx, sy, sz) = (x.length(), y.length(), z.length());
        let (lo, hi) = (sx.min(sy).min(sz), sx.max(sy).max(sz));
        if !(lo > 0.0) || hi <= lo * (1.0 + 1e-5) {
            return Ok(None);
        }
        let (xn, yn, zn) = (x / sx, y / sy, z / sz);
        if xn.dot(yn).abs().max(xn.dot(zn).abs()).max(yn.dot(zn).abs()) > 1e-4 {
            return Err(ShearedAxes);
        }
        Ok(Some(SpotAxes { u: xn / sx, v: yn / sy, d: direction / sz, widening: sx.max(sy) / sz }))
    }

    /// The cosine Cycles' attenuation reads for unit direction `w` leaving the spot.
    #[inline]
    pub fn cos(&self, w: Vec3) -> f32 {
        let local = Vec3::new(w.dot(self.u), w.dot(self.v), w.dot(self.d));
        let len = local.length();
        if len > 0.0 { local.z / len } else { 0.0 }
    }
}

/// The cosine a spot's attenuation reads for unit direction `w` leaving it.
#[inline]
pub fn spot_cos(direction: Vec3, axes: &Option<SpotAxes>, w: Vec3) -> f32 {
    match axes {
        None => w.dot(direction),
        Some(a) => a.cos(w),
    }
}

/// cos of the round cone around a spot's direction that holds every direction it lights:
/// the outer cone, or for stretched axes the one whose tangent is the outer cone's times
/// the widening (an axis' component shrinks by at most the largest X/Y scale, the axial one
/// grows by the Z scale).
#[inline]
pub fn spot_cos_bound(cos_outer: f32, axes: &Option<SpotAxes>) -> f32 {
    match axes {
        None => cos_outer,
        Some(a) if cos_outer > 0.0 => {
            let tan = (1.0 - cos_outer * cos_outer).max(0.0).sqrt() / cos_outer * a.widening;
            1.0 / (1.0 + tan * tan).sqrt()
        }
        Some(_) => 0.0,
    }
}

/// Optional spot mask of a sphere light (1 without a cone): see [`SpotCone::mask`].
#[inline]
pub fn sphere_mask(spot: &Option<SpotCone>, center: Vec3, radius: f32, p: Vec3, w: Vec3) -> f32 {
    spot.as_ref().map_or(1.0, |s| s.mask(center, radius, p, w))
}

/// A spot's attenuation: Blender's smoothstep when `smooth` is set, else glTF's.
#[inline]
pub fn spot_attenuation(cos_theta: f32, cos_inner: f32, cos_outer: f32, smooth: Option<f32>) -> f32 {
    match smooth {
        None => spot_falloff(cos_theta, cos_inner, cos_outer),
        Some(k) => {
            if cos_theta <= cos_outer {
                return 0.0;
            }
            let t = ((cos_theta - cos_outer) * k).clamp(0.0, 1.0);
            t * t * (3.0 - 2.0 * t)
        }
    }
}

/// glTF's spot attenuation: a smooth quadratic ramp between the cones.
#[inline]
pub fn spot_falloff(cos_theta: f32, cos_inner: f32, cos_outer: f32) -> f32 {
    let scale = 1.0 / (cos_inner - cos_outer).max(1e-3);
    let t = ((cos_theta - cos_outer) * scale).clamp(0.0, 1.0);
    t * t
}

/// Distance along unit `d` from `o` to a sphere, if the ray hits it from outside.
#[inline]
pub fn intersect_sphere(o: Vec3, d: Vec3, center: Vec3, radius: f32, tmax: f32) -> Option<f32> {
    let oc = o - center;
    let b = oc.dot(d);
    let c = oc.length_squared() - radius * radius;
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    let t = -b - disc.sqrt();
    (t > 0.0 && t < tmax).then_some(t)
}

/// Distance along unit `d` from `o` to a sphere light as Cycles finds it: the near side
/// from outside, the far side from a ray origin inside the ball (lights are not closed
/// surfaces to Cycles: a point inside a sphere light sees its emission all around).
#[inline]
pub fn intersect_sphere_light(o: Vec3, d: Vec3, center: Vec3, radius: f32, tmax: f32) -> Option<f32> {
    let oc = o - center;
    let c = oc.length_squared() - radius * radius;
    if c > 0.0 {
        return intersect_sphere(o, d, center, radius, tmax);
    }
    let b = oc.dot(d);
    // Inside, the discriminant b² - c is never negative: the far root is always there.
    let t = -b + (b * b - c).max(0.0).sqrt();
    (t > 0.0 && t < tmax).then_some(t)
}

/// Solid-angle density of next-event estimation's directions from a point inside a sphere
/// light: uniform over the sphere of directions (1 / 4π).
pub const INSIDE_SPHERE_PDF: f32 = crate::sampling::warp::UNIFORM_SPHERE_PDF;

/// Next-event estimation's solid-angle density of direction `wi` from a point of normal `n`
/// inside a spot's sphere, Cycles' `spot_light_pdf` there: a cosine hemisphere around `n`,
/// uniform over the sphere of directions for a zero `n` (a transmitting BSDF, a medium).
#[inline]
pub fn spot_inside_pdf(n: Vec3, wi: Vec3) -> f32 {
    match n.try_normalize() {
        Some(n) => crate::sampling::warp::cosine_hemisphere_pdf(n.dot(wi).max(0.0)),
        None => INSIDE_SPHERE_PDF,
    }
}

/// Whether a ray from `o` along `d` can find a spot's sphere (`center`): Cycles'
/// `spot_light_intersect` is one-sided, a ray moving away from the centre's side never does
/// (from outside it cannot reach the sphere anyway; from inside it drops the near half).
#[inline]
pub fn spot_sphere_faces(o: Vec3, d: Vec3, center: Vec3) -> bool {
    d.dot(o - center) < 0.0
}

/// Next-event estimation's solid-angle density of a sphere light's directions from a point
/// `dist` from its centre: the cone of its cap from outside, uniform from inside.
#[inline]
pub fn sphere_light_pdf(dist: f32, radius: f32) -> f32 {
    sphere_cos_max(dist, radius).map_or(INSIDE_SPHERE_PDF, crate::sampling::warp::uniform_cone_pdf)
}

/// Cosine of the half angle a sphere subtends from a point at distance `dist` (None inside).
#[inline]
pub fn sphere_cos_max(dist: f32, radius: f32) -> Option<f32> {
    (dist > radius).then(|| (1.0 - (radius / dist).powi(2)).max(0.0).sqrt())
}

/// Converts an area density at a light point into a solid-angle density.
#[inline]
pub fn area_to_solid_angle(pdf_area: f32, dist: f32, cos_light: f32) -> f32 {
    if cos_light <= 0.0 { 0.0 } else { pdf_area * dist * dist / cos_light }
}

/// Samples a point on an emissive triangle uniformly by area.
/// Returns (point, geometric normal, barycentrics (b1, b2), area).
#[inline]
pub fn sample_triangle(t: &EmitterTriangle, u: Vec2) -> (Vec3, Vec3, Vec2, f32) {
    let b = uniform_triangle(u);
    let p = t.p[0] * (1.0 - b.x - b.y) + t.p[1] * b.x + t.p[2] * b.y;
    let c = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]);
    let len = c.length();
    (p, c / len, b, 0.5 * len)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{ChiSquareTest, assert_chi2};

    /// An area light tilted over the origin, in three sizes of spread.
    fn light(shape: AreaShape, spread_deg: f32) -> AreaLight {
        let ax = Vec3::new(1.0, 0.0, 0.2);
        let ay = Vec3::new(0.1, 0.7, 0.0);
        AreaLight::new(shape, Vec3::new(0.3, -0.2, 0.6), ax, ay, -Vec3::Z, Rgb::ONE)
            .unwrap()
            .with_spread(spread_deg.to_radians())
    }

    /// Cycles' falloff keeps the power: ∫ f(θ) cos θ dω over the hemisphere is π.
    #[test]
    fn spread_keeps_the_power() {
        for deg in [2.0f32, 10.0, 45.0, 90.0, 150.0, 180.0] {
            let l = light(AreaShape::Rectangle, deg);
            // Midpoint rule in θ with 200k steps: error far below the 1e-3 asserted.
            let n = 200_000;
            let dt = (PI / 2.0) as f64 / n as f64;
            let integral: f64 = (0..n)
                .map(|i| {
                    let t = (i as f64 + 0.5) * dt;
                    l.spread_attenuation(t.cos() as f32) as f64 * t.cos() * t.sin() * 2.0 * std::f64::consts::PI * dt
                })
                .sum();
            assert!((integral / std::f64::consts::PI - 1.0).abs() < 1e-3, "spread {deg}°: ∫ f cos dω = {integral}");
        }
    }

    /// Sampling a light with spread (the window of the light that can reach the point)
    /// against its pdf, for both shapes and narrow and wide spreads.
    #[test]
    fn chi2_area_light_with_spread() {
        let p = Vec3::ZERO;
        for (shape, deg) in [
            (AreaShape::Rectangle, 120.0),
            (AreaShape::Ellipse, 90.0),
            (AreaShape::Rectangle, 40.0),
            (AreaShape::Ellipse, 180.0),
        ] {
            let l = light(shape, deg);
            let to_solid = |q: Vec3, pdf_area: f32| {
                let d = q - p;
                let cos = (-d.normalize()).dot(l.normal);
                if cos > 0.0 { pdf_area * d.length_squared() / cos } else { 0.0 }
            };
            let t = ChiSquareTest::new(&format!("area light {shape:?} spread {deg}°"));
            let r = t.run_with_pdf(
                |u| {
                    let (q, pa) = l.sample_from(p, u)?;
                    Some(((q - p).normalize(), to_solid(q, pa)))
                },
                |w| match l.intersect(p, w, f32::INFINITY) {
                    Some(t) => to_solid(p + w * t, l.pdf_area_from(p, p + w * t)),
                    None => 0.0,
                },
            );
            assert_chi2(r);
        }
    }

    /// A spot stretched by its object's scale: uniform scale keeps the round cone; X scale 2
    /// lights the X side twice as far in tangent (Cycles' formula), Z scale 2 half as far;
    /// every lit direction lies in the bounding cone, and some lie near its edge.
    #[test]
    fn stretched_spot_cone() {
        let dir = -Vec3::Z;
        assert_eq!(SpotAxes::from_object_axes(Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::Z * 2.0, dir), Ok(None));
        let sheared = SpotAxes::from_object_axes(Vec3::X, Vec3::new(0.3, 1.0, 0.0), Vec3::Z * 2.0, dir);
        assert_eq!(sheared, Err(ShearedAxes));
        let cos_outer = 30f32.to_radians().cos();
        let tan = 30f32.to_radians().tan();
        let wide = SpotAxes::from_object_axes(Vec3::X * 2.0, Vec3::Y, Vec3::Z, dir).unwrap();
        let at = |tan_x: f32, tan_y: f32| Vec3::new(tan_x, tan_y, -1.0).normalize();
        assert!(wide.unwrap().cos(at(1.9 * tan, 0.0)) > cos_outer);
        assert!(wide.unwrap().cos(at(2.1 * tan, 0.0)) < cos_outer);
        assert!(wide.unwrap().cos(at(0.0, 1.1 * tan)) < cos_outer);
        let long = SpotAxes::from_object_axes(Vec3::X, Vec3::Y, Vec3::Z * 2.0, dir).unwrap();
        assert!(long.unwrap().cos(at(0.45 * tan, 0.0)) > cos_outer);
        assert!(long.unwrap().cos(at(0.55 * tan, 0.0)) < cos_outer);
        for axes in [wide, long, SpotAxes::from_object_axes(Vec3::X * 3.0, Vec3::Y * 0.5, Vec3::Z * 0.7, dir).unwrap()]
        {
            let bound = spot_cos_bound(cos_outer, &axes);
            let mut closest = 1.0f32;
            for i in 0..200 {
                for j in 0..200 {
                    let w = at((i as f32 - 100.0) / 20.0, (j as f32 - 100.0) / 20.0);
                    if spot_cos(dir, &axes, w) > cos_outer {
                        assert!(w.dot(dir) > bound - 1e-6, "{w} is lit outside the bound");
                        closest = closest.min(w.dot(dir) - bound);
                    }
                }
            }
            assert!(closest < 0.01, "the bound is loose by {closest}");
        }
    }
}
