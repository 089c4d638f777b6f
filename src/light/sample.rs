//! Next-event estimation's side of every light: sampling a point of the light as seen
//! from a shading point (`sample_li`) and the density of that choice (`pdf_li`), which
//! MIS needs when a BSDF-sampled ray finds the light instead.

use super::{
    DELTA_SUN_COS, EmitterTriangle, Light, LightSample, area_to_solid_angle, intersect_sphere, sample_triangle,
    sphere_cos_max, sphere_mask, spot_attenuation, sun_radiance,
};
use crate::math::Frame;
use crate::sampling::warp::{concentric_disk, uniform_cone, uniform_cone_pdf};
use crate::scene::Scene;
use crate::scene::light_path::LightPath;
use glam::{Vec2, Vec3};

// Here rather than beside the type in `light/mod.rs`: the light types sit below the
// scene (which holds them), and only the sampling side may look into the scene.
impl EmitterTriangle {
    /// Emissive triangle `tri` of the scene: its corners, two-sided when its material is.
    #[inline]
    pub fn of(scene: &Scene, tri: u32) -> Self {
        let m = &scene.mesh;
        EmitterTriangle {
            p: m.triangles[tri as usize].map(|i| m.positions[i as usize]),
            two_sided: scene.materials[m.tri_material[tri as usize] as usize].double_sided,
        }
    }
}

impl Light {
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
            Light::Spot { position, direction, intensity, cos_inner, cos_outer, smooth } => {
                let d = *position - p;
                let dist2 = d.length_squared();
                let dist = dist2.sqrt();
                if dist <= 0.0 {
                    return None;
                }
                let wi = d / dist;
                let falloff = spot_attenuation((-wi).dot(*direction), *cos_inner, *cos_outer, *smooth);
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
                let cos_max = sphere_cos_max(dist, *radius)?;
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
                let (wi, li, pdf) = env.sample(u)?;
                Some(LightSample { wi, dist: f32::INFINITY, li, pdf, delta: false, point: p + wi, normal: Vec3::ZERO })
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
                let cos_signed = (-wi).dot(n);
                let cos_l = if et.two_sided { cos_signed.abs() } else { cos_signed };
                let pdf = area_to_solid_angle(1.0 / area, dist, cos_l);
                if !(pdf > 0.0) {
                    return None;
                }
                let normal = if cos_signed >= 0.0 { n } else { -n };
                // A partly transparent emitter emits in proportion to its coverage, as
                // a path that hits it counts its emission only when it does not pass.
                let coverage = scene.coverage(*tri, b.x, b.y);
                Some(LightSample {
                    wi,
                    dist,
                    li: scene.emission_for(*tri, b.x, b.y, path.emission(dist)) * coverage,
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
