//! Next-event estimation's side of every light: sampling a point of the light as seen
//! from a shading point (`sample_li`) and the density of that choice (`pdf_li`), which
//! MIS needs when a BSDF-sampled ray finds the light instead.

use super::{
    DELTA_SUN_COS, EmitterTriangle, INSIDE_SPHERE_PDF, Light, LightSample, area_to_solid_angle, intersect_sphere,
    intersect_sphere_light, sample_triangle, sphere_cos_max, sphere_mask, spot_attenuation, spot_cos, spot_inside_pdf,
    sun_radiance,
};
use crate::math::Frame;
use crate::sampling::warp::{concentric_disk, cosine_hemisphere, uniform_cone, uniform_cone_pdf, uniform_sphere};
use crate::scene::Scene;
use crate::scene::light_path::LightPath;
use glam::{Vec2, Vec3};

// Here rather than beside the type in `light/mod.rs`: the light types sit below the
// scene (which holds them), and only the sampling side may look into the scene.
impl EmitterTriangle {
    /// Emissive triangle `tri` of the scene: its corners.
    #[inline]
    pub fn of(scene: &Scene, tri: u32) -> Self {
        let m = &scene.mesh;
        EmitterTriangle { p: m.triangles[tri as usize].map(|i| m.positions[i as usize]) }
    }
}

/// A world light sample from `p` toward `wi`.
#[inline]
fn world_sample(p: Vec3, wi: Vec3, li: crate::math::Rgb, pdf: f32) -> LightSample {
    LightSample { wi, dist: f32::INFINITY, li, pdf, delta: false, point: p + wi, normal: Vec3::ZERO }
}

/// Next-event estimation from `p` inside a sphere light's ball, which Cycles lights from
/// every direction (its emission is seen from inside): a uniform direction up to the
/// sphere's far side. Cycles draws a cosine hemisphere around the shading normal (a uniform
/// sphere for transmitting BSDFs); the uniform sphere serves every BSDF with the same
/// expectation, at some more noise on opaque surfaces, without the normal reaching here. A
/// spot's cone does not mask receivers inside the ball (`SpotCone::mask`).
fn sphere_from_inside(center: Vec3, radius: f32, radiance: crate::math::Rgb, p: Vec3, u: Vec2) -> Option<LightSample> {
    let wi = uniform_sphere(u);
    let t = intersect_sphere_light(p, wi, center, radius, f32::INFINITY)?;
    let q = p + wi * t;
    Some(LightSample {
        wi,
        dist: t,
        li: radiance,
        pdf: INSIDE_SPHERE_PDF,
        delta: false,
        point: q,
        normal: (q - center).normalize_or(wi),
    })
}

/// Next-event estimation from `p` (normal `n`) inside a spot's sphere, as Cycles samples it
/// (`spot_light_sample`): a cosine hemisphere around `n`, up to the sphere's far side, the cone
/// not masking. Its density must be the one the emitter hit weighs against
/// (`spot_inside_pdf`), as Cycles' one-sided `spot_light_intersect` drops some of those hits.
fn spot_from_inside(
    center: Vec3,
    radius: f32,
    radiance: crate::math::Rgb,
    p: Vec3,
    n: Vec3,
    u: Vec2,
) -> Option<LightSample> {
    let n = n.try_normalize()?;
    let wi = Frame::from_normal(n).to_world(cosine_hemisphere(u));
    let pdf = spot_inside_pdf(n, wi);
    if !(pdf > 0.0) {
        return None;
    }
    let t = intersect_sphere_light(p, wi, center, radius, f32::INFINITY)?;
    let q = p + wi * t;
    Some(LightSample { wi, dist: t, li: radiance, pdf, delta: false, point: q, normal: (q - center).normalize_or(wi) })
}

impl Light {
    /// [`sample_li_from`](Self::sample_li_from) with the world sampled by its map alone,
    /// its portals left out: BDPT and VCM weigh a world connection against light subpaths
    /// that leave the world by the map, whose density must be the connection's too.
    #[inline]
    pub fn sample_li_unguided(&self, scene: &Scene, p: Vec3, u: Vec2, path: LightPath) -> Option<LightSample> {
        match self {
            Light::World => {
                let (wi, li, pdf) = scene.world.as_ref()?.sample(u)?;
                Some(world_sample(p, wi, li, pdf))
            }
            _ => self.sample_li_from(scene, p, u, path),
        }
    }

    /// Samples a point of this light as seen from `p` for next-event estimation: the
    /// direction, distance, incident radiance and its solid-angle density. An emissive
    /// node graph is evaluated as for light sampling without a path behind it.
    #[inline]
    pub fn sample_li(&self, scene: &Scene, p: Vec3, u: Vec2) -> Option<LightSample> {
        self.sample_li_from(scene, p, u, LightPath::LIGHT_EMISSION)
    }

    /// [`sample_li`](Self::sample_li) from a shading point reached by `path`: an emissive
    /// node graph reads the path's counters and the distance (`LightPath::emission`).
    #[inline]
    pub fn sample_li_from(&self, scene: &Scene, p: Vec3, u: Vec2, path: LightPath) -> Option<LightSample> {
        self.sample_li_at(scene, p, Vec3::ZERO, u, path)
    }

    /// [`sample_li_from`](Self::sample_li_from) at a receiver of normal `n` (the one light
    /// selection was given; zero for a transmitting BSDF or a medium point): from inside a
    /// spot's sphere the directions follow Cycles' density, a cosine hemisphere around `n`
    /// (`spot_inside_pdf`), which its one-sided ray hits are weighed against.
    #[inline]
    pub fn sample_li_at(&self, scene: &Scene, p: Vec3, n: Vec3, u: Vec2, path: LightPath) -> Option<LightSample> {
        match self {
            Light::Point { position, intensity } => {
                let d = *position - p;
                let dist2 = d.length_squared();
                let dist = dist2.sqrt();
                (dist > 0.0).then(|| LightSample {
                    wi: d / dist,
                    dist,
                    li: *intensity / dist2,
                    pdf: 1.0,
                    delta: true,
                    point: *position,
                    normal: Vec3::ZERO,
                })
            }
            Light::Spot { position, direction, intensity, cos_inner, cos_outer, smooth, axes } => {
                let d = *position - p;
                let dist2 = d.length_squared();
                let dist = dist2.sqrt();
                if dist <= 0.0 {
                    return None;
                }
                let wi = d / dist;
                let falloff = spot_attenuation(spot_cos(*direction, axes, -wi), *cos_inner, *cos_outer, *smooth);
                (falloff > 0.0).then(|| LightSample {
                    wi,
                    dist,
                    li: *intensity * (falloff / dist2),
                    pdf: 1.0,
                    delta: true,
                    point: *position,
                    normal: Vec3::ZERO,
                })
            }
            Light::Directional { direction, irradiance, cos_half } => {
                if *cos_half >= DELTA_SUN_COS {
                    return Some(LightSample {
                        wi: -*direction,
                        dist: f32::INFINITY,
                        li: *irradiance,
                        pdf: 1.0,
                        delta: true,
                        point: p - *direction,
                        normal: Vec3::ZERO,
                    });
                }
                let wi = Frame::from_normal(-*direction).to_world(uniform_cone(u, *cos_half));
                Some(LightSample {
                    wi,
                    dist: f32::INFINITY,
                    li: sun_radiance(*irradiance, *cos_half),
                    pdf: uniform_cone_pdf(*cos_half),
                    delta: false,
                    point: p + wi,
                    normal: Vec3::ZERO,
                })
            }
            Light::Sphere { center, radius, radiance, soft: true, spot, .. } => {
                // A disk of the sphere's radius facing the shading point (masked by a
                // spot's cone along the sampled ray).
                let n = (p - *center).normalize_or(Vec3::Y);
                let d2 = concentric_disk(u) * *radius;
                let f = Frame::from_normal(n);
                let q = *center + f.s * d2.x + f.t * d2.y;
                let d = q - p;
                let dist = d.length();
                if dist <= 0.0 {
                    return None;
                }
                let wi = d / dist;
                let mask = sphere_mask(spot, *center, *radius, p, -wi);
                if !(mask > 0.0) {
                    return None;
                }
                let pdf = area_to_solid_angle(1.0 / (std::f32::consts::PI * radius * radius), dist, (-wi).dot(n));
                (pdf > 0.0).then_some(LightSample {
                    wi,
                    dist,
                    li: *radiance * mask,
                    pdf,
                    delta: false,
                    point: q,
                    normal: n,
                })
            }
            Light::Sphere { center, radius, radiance, soft: false, spot, .. } => {
                let to_c = *center - p;
                let dist = to_c.length();
                let Some(cos_max) = sphere_cos_max(dist, *radius) else {
                    if spot.is_some() && n != Vec3::ZERO {
                        return spot_from_inside(*center, *radius, *radiance, p, n, u);
                    }
                    return sphere_from_inside(*center, *radius, *radiance, p, u);
                };
                let wi = Frame::from_normal(to_c / dist).to_world(uniform_cone(u, cos_max));
                let mask = sphere_mask(spot, *center, *radius, p, -wi);
                if !(mask > 0.0) {
                    return None;
                }
                // Rounding can make a ray at the cone's edge miss: use the tangent point.
                let t = intersect_sphere(p, wi, *center, *radius, f32::INFINITY).unwrap_or(dist * cos_max);
                let q = p + wi * t;
                Some(LightSample {
                    wi,
                    dist: t,
                    li: *radiance * mask,
                    pdf: uniform_cone_pdf(cos_max),
                    delta: false,
                    point: q,
                    normal: (q - *center).normalize_or(-wi),
                })
            }
            Light::Area(a) => {
                let (q, pdf_area) = a.sample_from(p, u)?;
                let d = q - p;
                let dist = d.length();
                if dist <= 0.0 {
                    return None;
                }
                let wi = d / dist;
                let cos_l = (-wi).dot(a.normal);
                let pdf = area_to_solid_angle(pdf_area, dist, cos_l);
                (pdf > 0.0).then_some(LightSample {
                    wi,
                    dist,
                    li: a.radiance * a.spread_attenuation(cos_l),
                    pdf,
                    delta: false,
                    point: q,
                    normal: a.normal,
                })
            }
            Light::World => {
                let env = scene.world.as_ref()?;
                let (wi, li, pdf) = env.sample_from(p, u)?;
                Some(world_sample(p, wi, li, pdf))
            }
            Light::Triangle { tri } => {
                let et = EmitterTriangle::of(scene, *tri);
                let (q, n, b, area) = sample_triangle(&et, u);
                let d = q - p;
                let dist = d.length();
                if dist <= 0.0 {
                    return None;
                }
                let wi = d / dist;
                // Either face emits: the side `p` sees.
                let cos_signed = (-wi).dot(n);
                let pdf = area_to_solid_angle(1.0 / area, dist, cos_signed.abs());
                if !(pdf > 0.0) {
                    return None;
                }
                let normal = if cos_signed >= 0.0 { n } else { -n };
                // A partly transparent emitter emits in proportion to its coverage, as
                // a path that hits it counts its emission only when it does not pass.
                let coverage = scene.emission_coverage(*tri, b.x, b.y);
                Some(LightSample {
                    wi,
                    dist,
                    li: scene.emission_for(*tri, b.x, b.y, path.emission(dist), Some(-wi)) * coverage,
                    pdf,
                    delta: false,
                    point: q,
                    normal,
                })
            }
        }
    }

    /// Solid-angle density with which `sample_li` from `p` picks the point `q` with
    /// normal `n_light` (None for lights that ray hits cannot find by area: their MIS
    /// weight is handled where they are crossed).
    #[inline]
    pub fn pdf_li(&self, scene: &Scene, p: Vec3, q: Vec3, n_light: Vec3) -> Option<f32> {
        let pdf_area = match self {
            Light::Area(a) => a.pdf_area_from(p, q),
            Light::Triangle { tri } => {
                let m = &scene.mesh;
                let [a, b, c] = m.triangles[*tri as usize].map(|i| m.positions[i as usize]);
                1.0 / (0.5 * (b - a).cross(c - a).length())
            }
            _ => return None,
        };
        let d = q - p;
        let dist = d.length();
        let cos_l = n_light.dot(-d / dist).abs();
        Some(area_to_solid_angle(pdf_area, dist, cos_l))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::SpotCone;
    use crate::math::Rgb;

    /// A spot with a radius 2 m above the floor (y = 0) pointing down: outer cone 30°,
    /// Blender's blend 0.2, radius 0.5, radiance 1.
    fn spot_sphere(soft: bool) -> Light {
        let cos_outer = 30f32.to_radians().cos();
        Light::Sphere {
            center: Vec3::new(0.0, 2.0, 0.0),
            radius: 0.5,
            radiance: Rgb::ONE,
            soft,
            camera_visible: false,
            spot: Some(SpotCone {
                direction: -Vec3::Y,
                cos_inner: cos_outer,
                cos_outer,
                smooth: Some(1.0 / ((1.0 - cos_outer) * 0.2)),
                axes: None,
            }),
        }
    }

    /// Blender's smoothstep in f64, for the quadrature.
    fn attenuation(cos: f64) -> f64 {
        let cos_outer = 30f64.to_radians().cos();
        let t = ((cos - cos_outer) / ((1.0 - cos_outer) * 0.2)).clamp(0.0, 1.0);
        if cos <= cos_outer { 0.0 } else { t * t * (3.0 - 2.0 * t) }
    }

    /// Irradiance at floor point `x` (normal +y) by midpoint quadrature over the light as
    /// Cycles defines it: the sphere's visible cap (hard) or the disk facing `x` (soft),
    /// radiance 1 masked by the attenuation of each ray's direction from the light to `x`.
    fn irradiance(x: [f64; 3], soft: bool) -> f64 {
        let (c, r, n) = ([0.0, 2.0, 0.0], 0.5f64, 2000);
        let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
        let len = |a: [f64; 3]| (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        let to_c = sub(c, x);
        let d = len(to_c);
        let a = to_c.map(|v| v / d);
        // A frame around the axis a (x → light centre).
        let s = {
            let t = [a[1], -a[0], 0.0];
            let l = len(t);
            t.map(|v| v / l)
        };
        let t = [a[1] * s[2] - a[2] * s[1], a[2] * s[0] - a[0] * s[2], a[0] * s[1] - a[1] * s[0]];
        let dir = |u: f64, v: f64, w: f64| [0, 1, 2].map(|k| s[k] * u + t[k] * v + a[k] * w);
        let mut e = 0.0;
        for i in 0..n {
            for j in 0..n {
                let phi = (j as f64 + 0.5) / n as f64 * std::f64::consts::TAU;
                let (w, dw) = if soft {
                    // A disk point at radius rho (area element rho drho dphi), seen from x.
                    let rho = (i as f64 + 0.5) / n as f64 * r;
                    let q = dir(rho * phi.cos(), rho * phi.sin(), 0.0).map(|v| v);
                    let q = [c[0] + q[0], c[1] + q[1], c[2] + q[2]];
                    let xq = sub(q, x);
                    let dist = len(xq);
                    let cos_l = d / dist;
                    let area = rho * (r / n as f64) * (std::f64::consts::TAU / n as f64);
                    (xq.map(|v| v / dist), area * cos_l / (dist * dist))
                } else {
                    let cos_max = (1.0 - (r / d).powi(2)).sqrt();
                    let cos = 1.0 - (i as f64 + 0.5) / n as f64 * (1.0 - cos_max);
                    let sin = (1.0 - cos * cos).sqrt();
                    let area = (1.0 - cos_max) / n as f64 * (std::f64::consts::TAU / n as f64);
                    (dir(sin * phi.cos(), sin * phi.sin(), cos), area)
                };
                // w points from x to the light; the light sends along -w, whose cosine to
                // the spot's axis (-y) is w.y.
                e += attenuation(w[1]) * w[1].max(0.0) * dw;
            }
        }
        e
    }

    /// Next-event estimation's irradiance from a spot with a radius (its sampling, value
    /// and density) against the quadrature, inside the cone (where it is the point's
    /// I cos θ / d² with I = π r² L), at its edge (the mask along each ray blurs the
    /// blend) and outside (zero), for the sphere and the soft-falloff disk. The bound is
    /// 5 standard errors of the mean of 2^18 stratified samples plus 1e-4 for the quadrature.
    #[test]
    fn spot_with_a_radius_irradiance_matches_quadrature() {
        let scene = Scene::default();
        for soft in [false, true] {
            let light = spot_sphere(soft);
            for x in [0.3f32, 0.9, 1.155, 1.5, 2.5] {
                let p = Vec3::new(x, 0.0, 0.1);
                let side = 512u32;
                let (mut sum, mut sum2) = (0.0f64, 0.0f64);
                for k in 0..side * side {
                    let u =
                        Vec2::new(((k % side) as f32 + 0.5) / side as f32, ((k / side) as f32 + 0.37) / side as f32);
                    let v = light.sample_li(&scene, p, u).map_or(0.0, |s| (s.li.x * s.wi.y.max(0.0) / s.pdf) as f64);
                    sum += v;
                    sum2 += v * v;
                }
                let n = (side * side) as f64;
                let mean = sum / n;
                let se = ((sum2 / n - mean * mean).max(0.0) / n).sqrt();
                let want = irradiance([x as f64, 0.0, 0.1], soft);
                assert!(
                    (mean - want).abs() <= 5.0 * se + 1e-4 * want.max(1e-3),
                    "soft {soft}, x {x}: NEE {mean} vs quadrature {want} (se {se})"
                );
                if x == 0.3 && !soft {
                    // Inside the blend's full part: the sphere's I cos θ / d².
                    let (d2, cos) = (4.0 + 0.09 + 0.01f64, 2.0 / (4.1f64).sqrt());
                    let point = std::f64::consts::PI * 0.25 * cos / d2;
                    assert!((want - point).abs() < 1e-3 * point, "{want} vs {point}");
                }
                if x == 2.5 {
                    assert_eq!(want, 0.0, "outside the cone");
                }
            }
        }
    }

    /// Inside a spot's sphere (Soft Falloff off) Cycles' estimate of a white Lambertian's
    /// irradiance: next-event estimation by a cosine hemisphere around n, unmasked by the cone
    /// (`sample_li_at`), and BSDF-sampled cosine rays that find the sphere only moving toward
    /// its centre's side (`spot_sphere_faces`), both weighed by the power heuristic with
    /// `spot_inside_pdf`. Both densities are cos/π, so each weight is ½ and the expectation is
    /// L (π − ½ ∫ cos over the missed directions): with the offset from the centre along n every
    /// upward ray misses (π L / 2), against n none does (π L), across n half the hemisphere
    /// does (3π L / 4). Bound: 5 standard errors of 2^16 stratified samples.
    #[test]
    fn inside_a_spot_sphere_is_weighed_as_cycles() {
        use crate::light::{SpotCone, spot_inside_pdf, spot_sphere_faces};
        use crate::sampling::warp::{cosine_hemisphere, cosine_hemisphere_pdf};
        let scene = Scene::default();
        let (center, radius) = (Vec3::new(0.2, 1.0, -0.3), 1.0f32);
        let spot = SpotCone { direction: -Vec3::Z, cos_inner: 0.9, cos_outer: 0.8, smooth: Some(5.0), axes: None };
        let light = Light::Sphere {
            center,
            radius,
            radiance: Rgb::splat(2.0),
            soft: false,
            camera_visible: false,
            spot: Some(spot),
        };
        let n = Vec3::new(0.3, 0.9, -0.2).normalize();
        let t = Frame::from_normal(n).s;
        let pi = std::f64::consts::PI;
        for (offset, want) in [(n * 0.5, pi), (-n * 0.5, 2.0 * pi), (t * 0.5, 1.5 * pi)] {
            let p = center + offset;
            let frame = Frame::from_normal(n);
            let side = 256u32;
            let (mut sum, mut sum2) = (0.0f64, 0.0f64);
            for k in 0..side * side {
                let u = Vec2::new(((k % side) as f32 + 0.5) / side as f32, ((k / side) as f32 + 0.37) / side as f32);
                let mut m = 0.0f64;
                if let Some(s) = light.sample_li_at(&scene, p, n, u, LightPath::LIGHT_EMISSION) {
                    assert_eq!(s.li, Rgb::splat(2.0), "the cone does not mask inside");
                    let cos = s.wi.dot(n);
                    let pdf_b = cosine_hemisphere_pdf(cos);
                    let w = s.pdf * s.pdf / (s.pdf * s.pdf + pdf_b * pdf_b);
                    m += (s.li.x * cos / s.pdf * w) as f64;
                }
                let wo = frame.to_world(cosine_hemisphere(u));
                let pdf_b = cosine_hemisphere_pdf(wo.dot(n));
                if pdf_b > 0.0 && spot_sphere_faces(p, wo, center) {
                    let pdf_l = spot_inside_pdf(n, wo);
                    let w = pdf_b * pdf_b / (pdf_b * pdf_b + pdf_l * pdf_l);
                    m += (2.0 * wo.dot(n) / pdf_b * w) as f64;
                }
                sum += m;
                sum2 += m * m;
            }
            let count = (side * side) as f64;
            let mean = sum / count;
            let se = ((sum2 / count - mean * mean).max(0.0) / count).sqrt();
            assert!((mean - want).abs() <= 5.0 * se + 1e-4, "offset {offset}: {mean} vs {want} (se {se})");
        }
    }

    /// A point inside a sphere light of radiance L (Soft Falloff off) sees it all around:
    /// the irradiance on any surface there is π L. Next-event estimation alone, BSDF
    /// sampling alone (cosine directions finding the far side from inside, as Cycles'
    /// intersection does) and their power-heuristic MIS with `sphere_light_pdf` (the density
    /// the path tracer weighs a crossed sphere by) each give it; the sampled point lies on the
    /// sphere where the ray from inside meets it. Bound: 5 standard errors of 2^16
    /// stratified samples (BSDF sampling alone is exact: every direction finds the light).
    #[test]
    fn inside_a_sphere_light_nee_and_bsdf_sampling_agree() {
        use crate::light::{intersect_sphere_light, sphere_light_pdf};
        use crate::sampling::warp::{cosine_hemisphere, cosine_hemisphere_pdf};
        let scene = Scene::default();
        let (center, radius) = (Vec3::new(0.2, 1.0, -0.3), 1.3f32);
        let light =
            Light::Sphere { center, radius, radiance: Rgb::splat(2.0), soft: false, camera_visible: false, spot: None };
        let want = std::f64::consts::PI * 2.0;
        for (p, n) in [
            (center, Vec3::Y),
            (center + Vec3::new(0.9, -0.5, 0.2), Vec3::new(0.3, 0.9, -0.2).normalize()),
            (center + Vec3::new(0.0, -1.25, 0.0), -Vec3::Y),
        ] {
            let frame = Frame::from_normal(n);
            let side = 256u32;
            let (mut nee, mut nee2, mut bsdf, mut mis, mut mis2) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
            for k in 0..side * side {
                let u = Vec2::new(((k % side) as f32 + 0.5) / side as f32, ((k / side) as f32 + 0.37) / side as f32);
                let s = light.sample_li(&scene, p, u).expect("inside, every direction finds the sphere");
                assert!(((s.point - center).length() - radius).abs() < 1e-4 * radius, "{:?} off the sphere", s.point);
                let t = intersect_sphere_light(p, s.wi, center, radius, f32::INFINITY).unwrap();
                assert!((t - s.dist).abs() < 1e-4, "sample at {} but the ray meets the sphere at {t}", s.dist);
                let cos = s.wi.dot(n).max(0.0);
                let v = (s.li.x * cos / s.pdf) as f64;
                let pdf_b = cosine_hemisphere_pdf(cos);
                let w_l = (s.pdf * s.pdf / (s.pdf * s.pdf + pdf_b * pdf_b)) as f64;
                nee += v;
                nee2 += v * v;
                // BSDF sampling: a cosine direction, the light found from inside.
                let wo = frame.to_world(cosine_hemisphere(u));
                assert!(intersect_sphere_light(p, wo, center, radius, f32::INFINITY).is_some());
                let pdf_b = cosine_hemisphere_pdf(wo.dot(n));
                let pdf_l = sphere_light_pdf((center - p).length(), radius);
                let b = (2.0 * wo.dot(n) / pdf_b) as f64;
                bsdf += b;
                let m = w_l * v + (pdf_b * pdf_b / (pdf_b * pdf_b + pdf_l * pdf_l)) as f64 * b;
                mis += m;
                mis2 += m * m;
            }
            let n_s = (side * side) as f64;
            let se = |sum: f64, sum2: f64| ((sum2 / n_s - (sum / n_s).powi(2)).max(0.0) / n_s).sqrt();
            assert!((nee / n_s - want).abs() <= 5.0 * se(nee, nee2) + 1e-9, "NEE {} vs {want}", nee / n_s);
            assert!((bsdf / n_s - want).abs() <= 1e-4 * want, "BSDF {} vs {want}", bsdf / n_s);
            assert!((mis / n_s - want).abs() <= 5.0 * se(mis, mis2) + 1e-9, "MIS {} vs {want}", mis / n_s);
        }
    }

    /// Outside the ball the sphere light's intersection is the plain sphere's near side.
    #[test]
    fn sphere_light_intersection_outside_is_the_near_side() {
        use crate::light::intersect_sphere_light;
        let (c, r) = (Vec3::new(0.0, 0.0, 5.0), 1.0);
        assert_eq!(intersect_sphere_light(Vec3::ZERO, Vec3::Z, c, r, 100.0), Some(4.0));
        assert_eq!(intersect_sphere_light(Vec3::ZERO, -Vec3::Z, c, r, 100.0), None);
        assert_eq!(intersect_sphere_light(c, Vec3::Z, c, r, 100.0), Some(1.0));
        assert_eq!(intersect_sphere_light(c, Vec3::Z, c, r, 0.5), None);
    }
}
