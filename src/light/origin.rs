//! Lights as the origins of light subpaths: a point and a direction from each light
//! with their densities, and the same densities evaluated for a given point and
//! direction (needed by the MIS weights of every strategy).
//!
//! Every light but Blender's soft-falloff point light (a disk that turns to face each
//! receiver: no fixed surface to start from) and spot with a radius (its mask leaves
//! receivers inside the sphere unmasked, which a light subpath cannot know; the soft one
//! has no fixed surface either) starts light subpaths. Lights with a fixed
//! emitting surface or point ("finite": point, spot, area, emissive triangle, a point
//! light with a radius and without soft falloff) start them there; the world and suns
//! (lights at infinity) start them on a disk beyond the scene's bounding sphere, facing a
//! direction drawn from the light's own distribution, as photons are emitted
//! (`emit::infinite_ray`). Such a light vertex lies at infinity: its density from the
//! light side is the light's choice times the direction's solid-angle density, the next
//! vertex's is the disk's area density times the cosine there, and a camera path reaches
//! it with the BSDF's solid-angle density (no distance). Soft point lights and spots with a
//! radius are reached
//! only from the camera side: by a camera path that crosses them (s = 0) and by light
//! sampling at a camera vertex (s = 1), weighted between those two strategies exactly as
//! the path tracer weights them.

use super::emit::Emitters;
use crate::light::{Light, spot_attenuation};
use crate::math::{Frame, Rgb};
use crate::sampling::Distribution1D;
use crate::sampling::warp::{cosine_hemisphere, uniform_cone, uniform_cone_pdf, uniform_sphere};
use crate::scene::Scene;
use crate::scene::light_path::LightPath;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// A point on a light that a light subpath starts from (or that a camera vertex connects to).
#[derive(Clone, Copy, Debug)]
pub struct LightPoint {
    /// Light index.
    pub light: u32,
    /// Position.
    pub p: Vec3,
    /// Unit surface normal on the emitting side (zero for point and spot lights).
    pub n: Vec3,
    /// Radiance (surfaces) or intensity (point, spot) before direction-dependent factors.
    pub le: Rgb,
    /// Area density of `p` among the light's points (1 for a point).
    pub pdf_pos: f32,
    /// Emits from both faces (emissive triangles).
    pub two_sided: bool,
    /// Barycentrics of `p` on an emissive triangle (its graph's emission is read toward each
    /// direction, `emitted`); zero for other lights.
    pub bary: Vec2,
}

/// The light-side view of the scene's lights for bidirectional path tracing.
#[derive(Clone, Debug)]
pub struct BdptLights {
    /// Light choice for light sampling at a camera vertex (s = 1): every light but those
    /// reading the Light Path node, by power.
    all: Distribution1D,
    /// Light choice for light subpaths: the lights that start them (not restricted ones), by power.
    origin: Distribution1D,
    /// Per light: starts light subpaths.
    starts: Vec<bool>,
    /// Per light: an emitter whose graph reads the Light Path node (`path_emitters`):
    /// taken by the camera side alone, out of both choices above.
    reads_path: Vec<bool>,
    /// Some light reads it (asked at every camera vertex).
    any_reads_path: bool,
    /// The scene's bounding sphere (centre, radius): lights at infinity start light
    /// subpaths on a disk of this radius.
    bounds: (Vec3, f32),
}

/// True for lights with a fixed emitting point or surface.
pub fn is_finite(l: &Light) -> bool {
    match l {
        Light::Point { .. } | Light::Spot { .. } | Light::Area(_) | Light::Triangle { .. } => true,
        Light::Sphere { soft, spot, .. } => !soft && spot.is_none(),
        Light::Directional { .. } | Light::World => false,
    }
}

/// True for lights that start light subpaths: all but soft-falloff point lights and spots
/// with a radius, whose emission toward a receiver depends on where the receiver lies (the
/// disk turns to face it; the cone leaves receivers inside the sphere unmasked), not on the
/// emitted ray alone.
pub fn starts_subpaths(l: &Light) -> bool {
    !matches!(l, Light::Sphere { soft: true, .. } | Light::Sphere { spot: Some(_), .. })
}

impl BdptLights {
    /// Selection distributions from the lights' exact emitted power. `restricted(i)`: light
    /// `i`'s paths are made by the camera side alone (`integrator::bdpt::visibility`), so it
    /// starts no light subpath and the origin choice leaves it out (a subpath started there
    /// would end at once); the strategies that weigh its paths never ask its origin density.
    pub fn new(scene: &Scene, restricted: impl Fn(usize) -> bool) -> Self {
        let emitters = Emitters::new(scene);
        let lum: Vec<f32> = emitters.power.iter().map(|p| crate::light::selection_weight(*p)).collect();
        let reads_path = super::path_emitters::reading_light_path(scene);
        let starts: Vec<bool> = scene
            .lights
            .iter()
            .zip(&reads_path)
            .enumerate()
            .map(|(i, (l, &r))| starts_subpaths(l) && !r && !restricted(i))
            .collect();
        let origin: Vec<f32> = lum.iter().zip(&starts).map(|(&l, &f)| if f { l } else { 0.0 }).collect();
        // Emitters reading the Light Path node are sampled at camera vertices as the path
        // tracer samples them (its own light choice), not by this one.
        let all: Vec<f32> = lum.iter().zip(&reads_path).map(|(&l, &r)| if r { 0.0 } else { l }).collect();
        BdptLights {
            all: Distribution1D::new(&all),
            origin: Distribution1D::new(&origin),
            starts,
            any_reads_path: reads_path.iter().any(|&r| r),
            reads_path,
            bounds: scene.bounding_sphere(),
        }
    }

    /// True when some light can start a light subpath.
    pub fn has_origins(&self) -> bool {
        !self.origin.is_empty() && self.origin.total() > 0.0
    }

    /// Whether light `i` starts light subpaths.
    #[inline]
    pub fn starts(&self, i: usize) -> bool {
        self.starts[i]
    }

    /// Whether light `i` is an emitter whose graph reads the Light Path node.
    #[inline]
    pub fn reads_path(&self, i: usize) -> bool {
        self.reads_path[i]
    }

    /// True when some emitter's graph reads the Light Path node.
    #[inline]
    pub fn any_reads_path(&self) -> bool {
        self.any_reads_path
    }

    /// The scene's bounding sphere (centre, radius), which the disk of lights at infinity covers.
    #[inline]
    pub fn bounds(&self) -> (Vec3, f32) {
        self.bounds
    }

    /// Area density of a light subpath's start on the disk of a light at infinity.
    #[inline]
    pub fn disk_pdf(&self) -> f32 {
        super::emit::disk_pdf(self.bounds.1)
    }

    /// Picks a light for light sampling at a camera vertex: (index, probability).
    #[inline]
    pub fn pick_any(&self, u: f32) -> Option<(usize, f32)> {
        if self.all.is_empty() || !(self.all.total() > 0.0) {
            return None;
        }
        let (i, p, _) = self.all.sample(u);
        (p > 0.0).then_some((i, p))
    }

    /// Probability that `pick_any` returns light `i`.
    #[inline]
    pub fn pmf_any(&self, i: usize) -> f32 {
        if self.all.is_empty() || !(self.all.total() > 0.0) { 0.0 } else { self.all.pmf(i) }
    }

    /// Picks a light to start a light subpath: (index, probability).
    #[inline]
    pub fn pick_origin(&self, u: f32) -> Option<(usize, f32)> {
        if !self.has_origins() {
            return None;
        }
        let (i, p, _) = self.origin.sample(u);
        (p > 0.0 && self.starts[i]).then_some((i, p))
    }

    /// Probability that `pick_origin` returns light `i` (the light-origin density of the
    /// MIS weights, times the position or direction density).
    #[inline]
    pub fn pmf_origin(&self, i: usize) -> f32 {
        if !self.has_origins() { 0.0 } else { self.origin.pmf(i) }
    }
}

/// Samples a point on finite light `index` uniformly by area (or its position).
#[inline]
pub fn sample_point(scene: &Scene, index: usize, u: Vec2) -> Option<LightPoint> {
    let light = index as u32;
    match &scene.lights[index] {
        Light::Point { position, intensity } | Light::Spot { position, intensity, .. } => Some(LightPoint {
            light,
            p: *position,
            n: Vec3::ZERO,
            le: *intensity,
            pdf_pos: 1.0,
            two_sided: false,
            bary: Vec2::ZERO,
        }),
        Light::Area(a) => Some(LightPoint {
            light,
            p: a.sample_point(u),
            n: a.normal,
            le: a.radiance,
            pdf_pos: 1.0 / a.area,
            two_sided: false,
            bary: Vec2::ZERO,
        }),
        Light::Sphere { center, radius, radiance, soft: false, spot: None, .. } => {
            let n = uniform_sphere(u);
            Some(LightPoint {
                light,
                p: *center + n * *radius,
                n,
                le: *radiance,
                pdf_pos: 1.0 / (4.0 * PI * radius * radius),
                two_sided: false,
                bary: Vec2::ZERO,
            })
        }
        Light::Triangle { tri } => {
            let et = crate::light::EmitterTriangle::of(scene, *tri);
            let (q, n, b, area) = crate::light::sample_triangle(&et, u);
            if !(area > 0.0) {
                return None;
            }
            // A partly transparent emitter emits in proportion to its coverage, as the
            // path tracer's light sampling does.
            let coverage = scene.emission_coverage(*tri, b.x, b.y);
            Some(LightPoint {
                light,
                p: q,
                n,
                // Signed: a negative emitter's subpaths carry negative light, which the
                // camera side's strategies find signed too (its power is |emission|).
                le: scene.emission_at(*tri, b.x, b.y) * coverage,
                pdf_pos: 1.0 / area,
                two_sided: true,
                bary: b,
            })
        }
        Light::Sphere { .. } | Light::Directional { .. } | Light::World => None,
    }
}

/// Area density with which `sample_point` picks `p` on finite light `index`.
#[inline]
pub fn pdf_point(scene: &Scene, index: usize) -> f32 {
    match &scene.lights[index] {
        Light::Point { .. } | Light::Spot { .. } => 1.0,
        Light::Area(a) => 1.0 / a.area,
        Light::Sphere { radius, soft: false, spot: None, .. } => 1.0 / (4.0 * PI * radius * radius),
        Light::Triangle { tri } => {
            let m = &scene.mesh;
            let [a, b, c] = m.triangles[*tri as usize].map(|i| m.positions[i as usize]);
            let area = 0.5 * (b - a).cross(c - a).length();
            if area > 0.0 { 1.0 / area } else { 0.0 }
        }
        _ => 0.0,
    }
}

/// True for lights emitting from both faces: emissive triangles (`Material::emissive`).
#[inline]
pub fn two_sided(scene: &Scene, index: usize) -> bool {
    matches!(scene.lights[index], Light::Triangle { .. })
}

/// True for lights that no path can hit: at a single point (point and spot lights) or
/// from a single direction (a sun without a size).
#[inline]
pub fn is_delta(scene: &Scene, index: usize) -> bool {
    match scene.lights[index] {
        Light::Point { .. } | Light::Spot { .. } => true,
        Light::Directional { cos_half, .. } => cos_half >= crate::light::DELTA_SUN_COS,
        _ => false,
    }
}

/// Emitted radiance (or intensity) of a light point in direction `w`.
#[inline]
pub fn emitted(scene: &Scene, lp: &LightPoint, w: Vec3) -> Rgb {
    match &scene.lights[lp.light as usize] {
        Light::Point { .. } => lp.le,
        Light::Spot { direction, cos_inner, cos_outer, smooth, axes, .. } => {
            lp.le * spot_attenuation(crate::light::spot_cos(*direction, axes, w), *cos_inner, *cos_outer, *smooth)
        }
        // Blender's Spread narrows an area light's emission (1 without spread, 0 behind);
        // light subpaths leave cosine-distributed, so the falloff weighs what they carry.
        Light::Area(a) => lp.le * a.spread_attenuation(w.dot(lp.n)),
        // A node graph may emit by the side or the angle it is seen from (Backfacing,
        // Fresnel, Layer Weight): read toward `w`, as light sampling and rays read it.
        Light::Triangle { tri } if scene.emission_is_graph(*tri) => {
            if w.dot(lp.n) == 0.0 {
                return Rgb::ZERO;
            }
            let b = lp.bary;
            scene.emission_for(*tri, b.x, b.y, LightPath::LIGHT_EMISSION, Some(w))
                * scene.emission_coverage(*tri, b.x, b.y)
        }
        _ => {
            let c = w.dot(lp.n);
            if c > 0.0 || (lp.two_sided && c < 0.0) { lp.le } else { Rgb::ZERO }
        }
    }
}

/// Solid-angle density of the first direction `w` of a light subpath from `lp`.
#[inline]
pub fn pdf_direction(scene: &Scene, lp: &LightPoint, w: Vec3) -> f32 {
    match &scene.lights[lp.light as usize] {
        Light::Point { .. } => 1.0 / (4.0 * PI),
        Light::Spot { direction, cos_outer, axes, .. } => {
            // Uniform in the round cone that holds the (stretched) outer cone.
            let bound = crate::light::spot_cos_bound(*cos_outer, axes);
            if w.dot(*direction) > bound { uniform_cone_pdf(bound) } else { 0.0 }
        }
        _ => {
            let c = w.dot(lp.n);
            if lp.two_sided {
                c.abs() / (2.0 * PI)
            } else if c > 0.0 {
                c / PI
            } else {
                0.0
            }
        }
    }
}

/// Samples the first direction of a light subpath: cosine-weighted for surfaces (either
/// face of a two-sided one, chosen by `u_side`), uniform for points, uniform in the
/// outer cone for spots.
#[inline]
pub fn sample_direction(scene: &Scene, lp: &LightPoint, u_side: f32, u: Vec2) -> Vec3 {
    match &scene.lights[lp.light as usize] {
        Light::Point { .. } => uniform_sphere(u),
        Light::Spot { direction, cos_outer, axes, .. } => {
            Frame::from_normal(*direction).to_world(uniform_cone(u, crate::light::spot_cos_bound(*cos_outer, axes)))
        }
        _ => {
            let n = if lp.two_sided && u_side >= 0.5 { -lp.n } else { lp.n };
            Frame::from_normal(n).to_world(cosine_hemisphere(u))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{ChiSquareTest, assert_chi2};

    /// Directions drawn by `sample_direction` have the density `pdf_direction` says, for
    /// a one-sided and a double-sided surface point and a spot (χ² test).
    #[test]
    fn chi2_light_directions() {
        let mut scene = Scene::default();
        scene.lights.push(Light::Spot {
            position: Vec3::ZERO,
            direction: Vec3::new(0.3, 0.1, 0.9).normalize(),
            intensity: Rgb::ONE,
            cos_inner: 0.9,
            cos_outer: 0.6,
            smooth: None,
            axes: None,
        });
        scene.lights.push(Light::Point { position: Vec3::ZERO, intensity: Rgb::ONE });
        // A Blender spot stretched by its object's scale: sampled in the cone that holds it.
        let stretched_dir = Vec3::new(0.3, 0.1, 0.9).normalize();
        let f = Frame::from_normal(stretched_dir);
        scene.lights.push(Light::Spot {
            position: Vec3::ZERO,
            direction: stretched_dir,
            intensity: Rgb::ONE,
            cos_inner: 0.6,
            cos_outer: 0.6,
            smooth: Some(5.0),
            axes: crate::light::SpotAxes::from_object_axes(f.s * 2.0, f.t * 0.5, -stretched_dir * 1.5, stretched_dir)
                .unwrap(),
        });
        let n = Vec3::new(0.2, -0.5, 0.8).normalize();
        let cases = [
            (0u32, Vec3::ZERO, false, "spot"),
            (2, Vec3::ZERO, false, "stretched spot"),
            (1, Vec3::ZERO, false, "point"),
            (1, n, false, "one-sided surface"),
            (1, n, true, "two-sided surface"),
        ];
        for (light, normal, two_sided, name) in cases {
            let mut lp =
                LightPoint { light, p: Vec3::ZERO, n: normal, le: Rgb::ONE, pdf_pos: 1.0, two_sided, bary: Vec2::ZERO };
            if normal != Vec3::ZERO {
                // Surfaces: evaluate through the generic arm with a non-point light.
                scene.lights[1] = Light::Area(
                    crate::light::AreaLight::new(
                        crate::light::AreaShape::Rectangle,
                        Vec3::ZERO,
                        Frame::from_normal(normal).s,
                        Frame::from_normal(normal).t,
                        normal,
                        Rgb::ONE,
                    )
                    .unwrap(),
                );
                lp.light = 1;
            }
            let t = ChiSquareTest::new(&format!("bdpt light direction: {name}"));
            let mut k = 0u32;
            assert_chi2(t.run(
                |u| {
                    k = k.wrapping_add(0x9e37_79b9);
                    let side = (k >> 8) as f32 / (1u32 << 24) as f32;
                    Some(sample_direction(&scene, &lp, side, u))
                },
                |w| pdf_direction(&scene, &lp, w),
            ));
        }
    }
}
