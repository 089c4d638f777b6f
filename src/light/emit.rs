//! Photon emission: picks a light in proportion to its exact emitted power (RGB
//! luminance), then a point and a direction on it, and gives the photon the power that
//! makes the sum over all photons equal the lights' power:
//!
//! | light | position | direction | power of one photon |
//! |---|---|---|---|
//! | point | the light | uniform sphere | 4π I / (p_l N) |
//! | spot | the light | exactly ∝ glTF's falloff inside the outer cone | Φ_spot / (p_l N) |
//! | sphere (point with a radius) | its surface, or its centre with soft falloff | cosine-weighted, or uniform sphere | 4π² r² L / (p_l N) |
//! | spot with a radius | as the sphere, or with soft falloff its centre | as the sphere, or uniform in the outer cone | × the cone's attenuation of the direction |
//! | directional | uniform on a disk of the scene's bounding-sphere radius, outside it, facing the photon's direction | the light's (uniform in its cone for a sun with a size) | π R² E · 2/(1 + cos θ) / (p_l N) |
//! | world | the same disk, facing the direction | from the world's importance map, density p(ω) | π R² L(ω) / (p(ω) p_l N) |
//! | area (CAUSTIC) | uniform | cosine-weighted, one-sided | π A L / (p_l N) |
//! | emissive triangle | uniform | cosine-weighted, either face (both emit) | 2π A L(x) / (p_l N) |
//!
//! with p_l the light's selection probability (luminance of its power over the total; a
//! negative emitter is picked by |Φ|, as Cycles' light tree takes |emission|: a negative
//! light's photons carry the sign of its power, an emissive triangle's that of its local
//! emission's factor)
//! and N the photons emitted. With every photon carrying Φ_l / (p_l N) and p_l ∝ Φ_l
//! exactly, each photon carries the same luminance, Φ_total / N, so the sum over N
//! photons is the total power up to rounding, for every light type. The only
//! exception: textured or partly transparent emitters, whose photons carry the local
//! emission (unbiased, not exact).
//!
//! A spot's power is 2π I [(1 - c₁) + (c₁ - c_o)³ / (3 w²)] with c_o the outer cone's
//! cosine, w = max(c_i - c_o, 10⁻³) and c₁ = min(c_o + w, 1) (glTF's smooth ramp as
//! `light::spot_falloff` computes it); directions are drawn with exactly that density.
//! The disk faces each photon's own direction, so that every direction covers the whole
//! bounding sphere (a disk facing the sun's axis leaves part of the scene unlit by the
//! cone's slanted directions). Through such a disk a sun of radiance L over a cone of
//! half-angle θ sends π R² L Ω = π R² E · 2/(1 + cos θ), since E = L π sin²θ and
//! Ω = 2π (1 − cos θ); the world sends π R² ∫ L dω = 4π² R² L̄ (L̄ its mean over the
//! sphere).

use crate::light::{Light, sample_triangle};
use crate::math::{Frame, Rgb};
use crate::sampling::Distribution1D;
use crate::sampling::warp::{concentric_disk, cosine_hemisphere, uniform_cone, uniform_cone_pdf, uniform_sphere};
use crate::scene::Scene;
use crate::scene::light_path::LightPath;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// A photon leaving a light.
#[derive(Clone, Copy, Debug)]
pub struct EmittedPhoton {
    /// Index of the light that emitted it (`Scene::lights`): light linking reads it.
    pub light: usize,
    /// Origin (already offset off an emitting surface).
    pub org: Vec3,
    /// Unit direction of travel.
    pub dir: Vec3,
    /// Power (W).
    pub power: Rgb,
}

/// The lights as photon sources.
#[derive(Clone, Debug)]
pub struct Emitters {
    /// Exact emitted power of each scene light (RGB, W): signed for a negative light; an
    /// emissive triangle's from its |emission| (its photons take the local emission's sign).
    pub power: Vec<Rgb>,
    dist: Distribution1D,
    total_lum: f32,
    center: Vec3,
    radius: f32,
    /// Emitting media, when the photon integrators asked for them (`with_media`).
    pub media: crate::light::media_emit::MediaEmitters,
}

/// Exact RGB power of a spot: 2π I ∫ falloff(c) dc over c in [cos_outer, 1].
pub fn spot_power_factor(cos_inner: f32, cos_outer: f32) -> (f32, f32, f32, f32) {
    let w = (cos_inner - cos_outer).max(1e-3);
    let c1 = (cos_outer + w).min(1.0);
    let a_ramp = (c1 - cos_outer).powi(3) / (3.0 * w * w);
    let a_flat = 1.0 - c1;
    (a_ramp, a_flat, c1, w)
}

/// A direction around +Z with density ∝ glTF's spot falloff (exactly): cos θ is drawn
/// from the ramp's cubic inverse CDF or uniformly on the flat part, by their masses.
#[inline]
pub fn spot_direction(u: Vec2, cos_inner: f32, cos_outer: f32) -> Vec3 {
    let (a_ramp, a_flat, c1, _) = spot_power_factor(cos_inner, cos_outer);
    let p_ramp = a_ramp / (a_ramp + a_flat);
    let c = if u.x < p_ramp {
        cos_outer + (c1 - cos_outer) * (u.x / p_ramp).cbrt()
    } else {
        c1 + (1.0 - c1) * ((u.x - p_ramp) / (1.0 - p_ramp))
    };
    let c = c.clamp(-1.0, 1.0);
    let s = (1.0 - c * c).max(0.0).sqrt();
    let ph = 2.0 * PI * u.y;
    Vec3::new(s * ph.cos(), s * ph.sin(), c)
}

/// Power of a sun through a disk facing each photon's direction over its power through a
/// disk facing its axis (π R² E): Ω L / E = 2 / (1 + cos θ) for a cone of half-angle θ, 1
/// for a delta sun.
#[inline]
pub fn sun_disk_factor(cos_half: f32) -> f32 {
    if cos_half < 1.0 { 2.0 / (1.0 + cos_half) } else { 1.0 }
}

impl Emitters {
    /// Computes each light's exact power and the selection distribution.
    pub fn new(scene: &Scene) -> Self {
        let (center, radius) = scene.bounding_sphere();
        let power: Vec<Rgb> = scene
            .lights
            .iter()
            .map(|l| match l {
                Light::Point { intensity, .. } => *intensity * (4.0 * PI),
                Light::Spot { intensity, cos_outer, smooth: Some(k), .. } => {
                    // ∫ smoothstep over the ramp is half its width: Ω (1 - blend / 2).
                    let ramp = (1.0 / (k * (1.0 - cos_outer))).min(1.0);
                    *intensity * (2.0 * PI * (1.0 - cos_outer) * (1.0 - 0.5 * ramp))
                }
                Light::Spot { intensity, cos_inner, cos_outer, .. } => {
                    let (a, b, _, _) = spot_power_factor(*cos_inner, *cos_outer);
                    *intensity * (2.0 * PI * (a + b))
                }
                Light::Sphere { radius, radiance, spot, .. } => {
                    *radiance * (4.0 * PI * PI * radius * radius * spot.map_or(1.0, |c| c.power_share()))
                }
                // π R² through the disk times ∫ L dω = 4π L̄ over the sphere.
                Light::World => match &scene.world {
                    Some(w) => Rgb::splat(w.mean_luminance() * 4.0 * PI * PI * radius * radius),
                    None => Rgb::ZERO,
                },
                Light::Directional { irradiance, cos_half, .. } => {
                    *irradiance * (PI * radius * radius * sun_disk_factor(*cos_half))
                }
                Light::Area(a) => a.radiance * (PI * a.area),
                Light::Triangle { tri } => {
                    let m = &scene.mesh;
                    let mat = &scene.materials[m.tri_material[*tri as usize] as usize];
                    let p = m.triangles[*tri as usize].map(|i| m.positions[i as usize]);
                    let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
                    let tex =
                        mat.emissive_tex.map(|t| scene.textures[t.texture as usize].mean_rgb()).unwrap_or(Vec3::ONE);
                    // π A L from each face.
                    mat.emissive * tex * (2.0 * PI * area)
                }
            })
            .collect();
        let lum: Vec<f32> = power.iter().map(|p| crate::light::selection_weight(*p)).collect();
        let total_lum = lum.iter().map(|&x| x as f64).sum::<f64>() as f32;
        Emitters { power, dist: Distribution1D::new(&lum), total_lum, center, radius, media: Default::default() }
    }

    /// These lights and the scene's emitting media as photon sources (`media_emit`).
    pub fn with_media(mut self, scene: &Scene) -> Self {
        self.media = crate::light::media_emit::MediaEmitters::new(scene);
        self
    }

    /// Sum of the lights' power (luminance, W), by which they share photons with media.
    pub fn total_luminance(&self) -> f32 {
        self.total_lum
    }

    /// Sum of the lights' power (RGB).
    pub fn total_power(&self) -> Rgb {
        self.power.iter().fold(Rgb::ZERO, |a, b| a + *b)
    }

    /// True when nothing emits.
    pub fn is_empty(&self) -> bool {
        !(self.total_lum > 0.0)
    }

    /// Probability of picking light `i`.
    pub fn pmf(&self, i: usize) -> f32 {
        self.dist.pmf(i)
    }

    /// Emits one of `n` photons: `u_light` picks the light, `u_side` the face of an
    /// emissive triangle (both emit), `u_pos` the point and `u_dir` the direction.
    #[inline]
    pub fn emit(
        &self,
        scene: &Scene,
        u_light: f32,
        u_side: f32,
        u_pos: Vec2,
        u_dir: Vec2,
        n: u64,
    ) -> Option<EmittedPhoton> {
        if self.is_empty() {
            return None;
        }
        let (index, pmf, _) = self.dist.sample(u_light);
        if !(pmf > 0.0) {
            return None;
        }
        let scale = 1.0 / (pmf * n as f32);
        let phi = self.power[index] * scale;
        match &scene.lights[index] {
            Light::Point { position, .. } => {
                Some(EmittedPhoton { light: index, org: *position, dir: uniform_sphere(u_dir), power: phi })
            }
            Light::Spot { position, direction, intensity, cos_inner, cos_outer, smooth: Some(k), axes } => {
                // Blender's smoothstep: uniform in the round cone holding the outer cone,
                // weighted by the falloff.
                let bound = crate::light::spot_cos_bound(*cos_outer, axes);
                let local = crate::sampling::warp::uniform_cone(u_dir, bound);
                let dir = Frame::from_normal(*direction).to_world(local);
                let cos = if axes.is_some() { crate::light::spot_cos(*direction, axes, dir) } else { local.z };
                let atten = crate::light::spot_attenuation(cos, *cos_inner, *cos_outer, Some(*k));
                let omega = 2.0 * PI * (1.0 - bound);
                Some(EmittedPhoton {
                    light: index,
                    org: *position,
                    dir,
                    power: *intensity * (atten * omega / (pmf * n as f32)),
                })
            }
            Light::Sphere { center, radius, radiance, soft: false, spot: Some(cone), .. } => {
                // The sphere's photons, each weighted by the cone's attenuation of its
                // direction (whose mean over the photons is the power's share).
                let nrm = uniform_sphere(u_pos);
                let dir = Frame::from_normal(nrm).to_world(cosine_hemisphere(u_dir));
                let unmasked = *radiance * (4.0 * PI * PI * radius * radius / (pmf * n as f32));
                Some(EmittedPhoton {
                    light: index,
                    org: *center + nrm * (*radius * 1.0001),
                    dir,
                    power: unmasked * cone.attenuation(dir),
                })
            }
            Light::Sphere { center, radius, radiance, soft: true, spot: Some(cone), .. } => {
                // A soft spot with a radius: as a soft point light, far away a point spot of
                // the disk's intensity π r² L, its photons uniform in the outer cone weighted
                // by the attenuation.
                let bound = cone.cos_bound();
                let local = crate::sampling::warp::uniform_cone(u_dir, bound);
                let dir = Frame::from_normal(cone.direction).to_world(local);
                let cos =
                    if cone.axes.is_some() { crate::light::spot_cos(cone.direction, &cone.axes, dir) } else { local.z };
                let atten = crate::light::spot_attenuation(cos, cone.cos_inner, cone.cos_outer, cone.smooth);
                let omega = 2.0 * PI * (1.0 - bound);
                Some(EmittedPhoton {
                    light: index,
                    org: *center,
                    dir,
                    power: *radiance * (PI * radius * radius * atten * omega / (pmf * n as f32)),
                })
            }
            Light::Sphere { center, radius, soft, .. } => {
                if *soft {
                    // Blender's soft falloff has no fixed shape; far away it is a point.
                    return Some(EmittedPhoton { light: index, org: *center, dir: uniform_sphere(u_dir), power: phi });
                }
                let nrm = uniform_sphere(u_pos);
                let dir = Frame::from_normal(nrm).to_world(cosine_hemisphere(u_dir));
                Some(EmittedPhoton { light: index, org: *center + nrm * (*radius * 1.0001), dir, power: phi })
            }
            Light::World => {
                let r = infinite_ray(scene, &scene.lights[index], (self.center, self.radius), u_pos, u_dir)?;
                Some(EmittedPhoton {
                    light: index,
                    org: r.org,
                    dir: r.dir,
                    power: r.le * (PI * self.radius * self.radius / (r.pdf_dir * pmf * n as f32)),
                })
            }
            Light::Spot { position, direction, cos_inner, cos_outer, .. } => {
                let local = spot_direction(u_dir, *cos_inner, *cos_outer);
                Some(EmittedPhoton {
                    light: index,
                    org: *position,
                    dir: Frame::from_normal(*direction).to_world(local),
                    power: phi,
                })
            }
            Light::Directional { .. } => {
                let r = infinite_ray(scene, &scene.lights[index], (self.center, self.radius), u_pos, u_dir)?;
                Some(EmittedPhoton { light: index, org: r.org, dir: r.dir, power: phi })
            }
            Light::Area(a) => {
                let q = a.sample_point(u_pos);
                let local = cosine_hemisphere(u_dir);
                let dir = Frame::from_normal(a.normal).to_world(local);
                // Blender's spread reshapes the emission but keeps its power: the falloff
                // averages 1 over cosine-distributed directions, so it weights the photon.
                Some(EmittedPhoton { light: index, org: q, dir, power: phi * a.spread_attenuation(local.z) })
            }
            Light::Triangle { tri } => {
                let m = &scene.mesh;
                let mat = &scene.materials[m.tri_material[*tri as usize] as usize];
                let et = crate::light::EmitterTriangle::of(scene, *tri);
                let (q, mut n, b, _) = sample_triangle(&et, u_pos);
                if u_side >= 0.5 {
                    n = -n;
                }
                let dir = Frame::from_normal(n).to_world(cosine_hemisphere(u_dir));
                // Local emission relative to the mean the power was computed with.
                let (uv, color) = scene.attributes(*tri, b.x, b.y);
                let mut factor = Rgb::ONE;
                if let Some(t) = mat.emissive_tex {
                    let mean = scene.textures[t.texture as usize].mean_rgb();
                    let local = mat.emission(&scene.textures, uv, color) / mat.emissive;
                    factor = Rgb::new(ratio(local.x, mean.x), ratio(local.y, mean.y), ratio(local.z, mean.z));
                } else if mat.nodes.is_some() {
                    // A node graph's emission toward the photon's direction (a graph may
                    // emit by Backfacing or Fresnel) relative to the material's estimate the
                    // power was computed with (exact when the emission is constant).
                    // Signed: a negative emitter's photons carry negative power (the power
                    // it was picked by is |emission|), so they subtract its light.
                    let local = scene.emission_for(*tri, b.x, b.y, LightPath::LIGHT_EMISSION, Some(dir));
                    let e = mat.emissive;
                    factor = Rgb::new(ratio(local.x, e.x), ratio(local.y, e.y), ratio(local.z, e.z));
                } else if mat.unlit {
                    // An unlit surface's vertex colour, which the power left out.
                    factor = color.truncate();
                }
                let coverage = scene.emission_coverage(*tri, b.x, b.y);
                Some(EmittedPhoton {
                    light: index,
                    org: crate::math::offset_ray_origin(q, n),
                    dir,
                    power: phi * factor * coverage,
                })
            }
        }
    }
}

/// A ray of a light at infinity (the world or a sun) toward the scene.
#[derive(Clone, Copy, Debug)]
pub struct InfiniteRay {
    /// Origin on the disk beyond the scene's bounding sphere.
    pub org: Vec3,
    /// Unit direction of travel (toward the scene).
    pub dir: Vec3,
    /// Radiance arriving from `-dir` (a delta sun: its irradiance).
    pub le: Rgb,
    /// Solid-angle density of `dir` (1 for a delta sun, whose direction is fixed).
    pub pdf_dir: f32,
    /// The light has this one direction only (a sun without a size).
    pub delta: bool,
}

/// Area density of a point on the disk of [`infinite_ray`] for a bounding radius `radius`.
#[inline]
pub fn disk_pdf(radius: f32) -> f32 {
    1.0 / (PI * radius * radius)
}

/// A ray from light `light` (the world or a sun; None for other lights) toward the scene
/// bounded by the sphere (`center`, `radius`): a direction from the light's own
/// distribution (the world's importance map, uniform in a sun's cone) drawn with `u_dir`,
/// and a point drawn with `u_pos` uniformly on a disk of radius `radius` beyond the
/// sphere, perpendicular to that direction, so that every direction covers the whole
/// sphere (area density [`disk_pdf`]). Photon emission and BDPT's light subpaths share it.
#[inline]
pub fn infinite_ray(
    scene: &Scene,
    light: &Light,
    (center, radius): (Vec3, f32),
    u_pos: Vec2,
    u_dir: Vec2,
) -> Option<InfiniteRay> {
    let d = concentric_disk(u_pos) * radius;
    match light {
        Light::World => {
            let env = scene.world.as_ref()?;
            let (to_world, le, pdf_dir) = env.sample(u_dir)?;
            let f = Frame::from_normal(to_world);
            Some(InfiniteRay {
                org: center + to_world * (radius * 1.01) + f.s * d.x + f.t * d.y,
                dir: -to_world,
                le,
                pdf_dir,
                delta: false,
            })
        }
        Light::Directional { direction, irradiance, cos_half } => {
            // A sun with a size sends each ray from a direction within its cone (uniform:
            // its radiance is constant there).
            let delta = *cos_half >= crate::light::DELTA_SUN_COS;
            let dir = if delta {
                *direction
            } else {
                Frame::from_normal(*direction).to_world(uniform_cone(u_dir, *cos_half)).normalize()
            };
            let f = Frame::from_normal(dir);
            let (le, pdf_dir) = if delta {
                (*irradiance, 1.0)
            } else {
                (crate::light::sun_radiance(*irradiance, *cos_half), uniform_cone_pdf(*cos_half))
            };
            Some(InfiniteRay { org: center - dir * (radius * 1.01) + f.s * d.x + f.t * d.y, dir, le, pdf_dir, delta })
        }
        _ => None,
    }
}

#[inline]
fn ratio(a: f32, b: f32) -> f32 {
    if b > 0.0 && a.is_finite() { a / b } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Spot photon directions follow falloff(cos θ) / (2π (a_ramp + a_flat)) (χ² test).
    #[test]
    fn chi2_spot_directions() {
        use crate::sampling::chi2::{ChiSquareTest, assert_chi2};
        for (ci, co) in [(0.9f32, 0.5f32), (0.99, 0.9), (0.3, 0.0)] {
            let (a, b, _, _) = spot_power_factor(ci, co);
            let t = ChiSquareTest::new(&format!("spot photons {ci} {co}"));
            assert_chi2(t.run(
                |u| Some(spot_direction(u, ci, co)),
                |w| crate::light::spot_falloff(w.z, ci, co) / (2.0 * PI * (a + b)),
            ));
        }
    }

    /// The spot's falloff integrated numerically equals the closed form.
    #[test]
    fn spot_power_closed_form() {
        for (ci, co) in [(0.95f32, 0.8f32), (0.9, 0.9), (0.5, 0.0), (0.99, 0.2)] {
            let (a, b, _, _) = spot_power_factor(ci, co);
            let n = 200_000;
            let mut s = 0.0f64;
            for i in 0..n {
                let c = co + (1.0 - co) * (i as f32 + 0.5) / n as f32;
                s += crate::light::spot_falloff(c, ci, co) as f64;
            }
            let num = s * (1.0 - co) as f64 / n as f64;
            assert!((num - (a + b) as f64).abs() < 1e-4 * (a + b) as f64 + 1e-7, "{ci} {co}: {num} vs {}", a + b);
        }
    }
}
