//! Light transport. [`SceneContext`] is the narrow view of the scene that every
//! integrator uses: closest hit, transmittance of a shadow segment, the material at a
//! hit, light sampling and the light pdf for MIS. Integrators compute one camera
//! sample at a time; the tile loop, film and progress are shared (`render.rs`).

pub mod bdpt;
pub mod media;
pub mod path;
pub mod photon;

use crate::accel::{Accel, Hit};
use crate::bsdf::pbr::PbrParams;
use crate::bsdf::{Bsdf, PbrBsdf};
use crate::film::{CameraSample, Filter, SplatBuffer, SplatPool};
use crate::light::{
    AreaLight, EmitterTriangle, Light, LightSample, LightSampler, LightSamplerKind, area_to_solid_angle,
    intersect_sphere, sample_triangle, sphere_cos_max, spot_attenuation,
};
use crate::math::{Frame, Rgb, offset_ray_origin};
use crate::medium::{HomogeneousMedium, MediumStack};
use crate::render::job::RayStats;
use crate::sampling::PixelSampler;
use crate::sampling::warp::{concentric_disk, uniform_cone, uniform_cone_pdf};
use crate::scene::camera::CameraRays;
use crate::scene::{AlphaMode, Scene};
use glam::{Vec2, Vec3};

/// A sun whose half angle has a cosine at least this is a delta light.
const DELTA_SUN_COS: f32 = 1.0 - 1e-7;

/// Radiance of a sun disk of half-angle cosine `cos_half` giving irradiance `e` at normal
/// incidence: E = L π sin²α (the projected solid angle of a spherical cap).
#[inline]
pub fn sun_radiance(e: Rgb, cos_half: f32) -> Rgb {
    e / (std::f32::consts::PI * (1.0 - cos_half * cos_half))
}

/// A surface point found by a ray.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    /// Position.
    pub p: Vec3,
    /// Unit geometric normal on the side the ray came from.
    pub ng: Vec3,
    /// Unit interpolated shading normal (before normal mapping), on the same side as `ng`.
    pub ns: Vec3,
    /// Interpolated tangent (xyz) and bitangent sign (w), zero when absent.
    pub tangent: glam::Vec4,
    /// Texture coordinates (sets 0 and 1).
    pub uv: [Vec2; 2],
    /// Vertex colour.
    pub color: glam::Vec4,
    /// Material index.
    pub material: u32,
    /// Triangle index.
    pub tri: u32,
    /// True when the ray hit the front (counter-clockwise) face.
    pub front: bool,
    /// Hit distance.
    pub t: f32,
}

/// What the material gives at a hit.
pub struct ShadingPoint {
    /// Scattering function.
    pub bsdf: Bsdf,
    /// Shading frame (normal-mapped), normal on the side of `ng`.
    pub frame: Frame,
    /// Emitted radiance toward the ray's origin.
    pub emitted: Rgb,
}

/// Everything an integrator may ask of the scene.
pub struct SceneContext<'a> {
    /// The scene description.
    pub scene: &'a Scene,
    /// Triangle BVH.
    pub accel: &'a Accel,
    /// Light selection.
    pub lights: LightSampler,
    /// Triangles whose material has an alpha mask (tested during traversal).
    masked: Vec<bool>,
    /// Triangles that shadow rays may pass through (MASK or BLEND).
    transparent: Vec<bool>,
    /// Area lights with their light index (intersected by camera and BSDF rays).
    area_lights: Vec<(AreaLight, usize)>,
    /// Light index of the world, if it is a light.
    world_light: Option<usize>,
    /// Sphere lights: (centre, radius, radiance, soft, camera-visible, light index).
    spheres: Vec<(Vec3, f32, Rgb, bool, bool, usize)>,
    /// Suns with a size: (unit direction toward the sun, cos half angle, radiance, light index).
    suns: Vec<(Vec3, f32, Rgb, usize)>,
    /// Some material has a medium or subsurface scattering (paths then track media and
    /// shadow rays step through volume boundaries).
    pub has_media: bool,
}

/// Power heuristic (β = 2) of Veach; 0 when the weights are not finite.
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    let w = a / (a + b);
    if w.is_finite() {
        w
    } else if pdf_a > 0.0 && pdf_b == 0.0 {
        1.0
    } else {
        0.0
    }
}

impl<'a> SceneContext<'a> {
    /// Prepares the per-triangle flags and the default light sampler.
    pub fn new(scene: &'a Scene, accel: &'a Accel) -> Self {
        Self::with_light_sampler(scene, accel, LightSamplerKind::default())
    }

    /// Prepares the per-triangle flags and the light sampler of the given kind.
    pub fn with_light_sampler(scene: &'a Scene, accel: &'a Accel, kind: LightSamplerKind) -> Self {
        let mut tri_to_light = vec![u32::MAX; scene.mesh.triangles.len()];
        let mut area_lights = Vec::new();
        let mut world_light = None;
        let (mut spheres, mut suns) = (Vec::new(), Vec::new());
        for (i, l) in scene.lights.iter().enumerate() {
            match l {
                Light::Triangle { tri } => tri_to_light[*tri as usize] = i as u32,
                Light::Area(a) => area_lights.push((*a, i)),
                Light::World => world_light = Some(i),
                Light::Sphere { center, radius, radiance, soft, camera_visible } => {
                    spheres.push((*center, *radius, *radiance, *soft, *camera_visible, i))
                }
                Light::Directional { direction, irradiance, cos_half } if *cos_half < DELTA_SUN_COS => {
                    suns.push((-*direction, *cos_half, sun_radiance(*irradiance, *cos_half), i))
                }
                _ => {}
            }
        }
        let mode = |t: usize| scene.materials[scene.mesh.tri_material[t] as usize].alpha_mode;
        let n = scene.mesh.triangles.len();
        SceneContext {
            scene,
            accel,
            lights: match kind {
                LightSamplerKind::Power => LightSampler::new(&scene.light_power, tri_to_light),
                LightSamplerKind::Tree => LightSampler::with_tree(
                    &scene.light_power,
                    &crate::light::tree::scene_light_bounds(scene),
                    tri_to_light,
                ),
            },
            masked: (0..n).map(|t| matches!(mode(t), AlphaMode::Mask(_))).collect(),
            transparent: (0..n).map(|t| mode(t) != AlphaMode::Opaque).collect(),
            area_lights,
            world_light,
            spheres,
            suns,
            has_media: scene.materials.iter().any(|m| m.medium.is_some() || m.subsurface.is_some()),
        }
    }

    /// Emission of lights that are not scene geometry (area and sphere lights) crossed by
    /// a ray before `tmax`, each weighted by MIS against light sampling from `prev_p`
    /// with the normal `prev_n` that light selection was given there (`prev_pdf` = 0: no
    /// MIS); lights hidden from the camera are skipped for camera rays. Returns the
    /// radiance and whether anything was crossed.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn crossed_emission(
        &self,
        org: Vec3,
        dir: Vec3,
        tmax: f32,
        prev_p: Vec3,
        prev_n: Vec3,
        prev_pdf: f32,
        camera_ray: bool,
    ) -> (Rgb, bool) {
        let mut sum = Rgb::ZERO;
        let mut any = false;
        for (a, index) in &self.area_lights {
            if camera_ray && !a.camera_visible {
                continue;
            }
            if let Some(t) = a.intersect(org, dir, tmax)
                && (-dir).dot(a.normal) > 0.0
            {
                let w = if prev_pdf == 0.0 {
                    1.0
                } else {
                    power_heuristic(prev_pdf, self.light_pdf(*index, prev_p, prev_n, org + dir * t, a.normal))
                };
                sum += a.radiance * (w * a.spread_attenuation((-dir).dot(a.normal)));
                any = true;
            }
        }
        for &(center, radius, radiance, soft, camera_visible, index) in &self.spheres {
            if camera_ray && !camera_visible {
                continue;
            }
            if soft {
                // The disk faces the ray's origin (the previous vertex).
                let n = (prev_p - center).normalize_or(Vec3::Y);
                let denom = n.dot(dir);
                if denom >= 0.0 {
                    continue;
                }
                let t = n.dot(center - org) / denom;
                let q = org + dir * t;
                if !(t > 0.0 && t < tmax) || (q - center).length_squared() > radius * radius {
                    continue;
                }
                let w = if prev_pdf == 0.0 {
                    1.0
                } else {
                    let dist = (q - prev_p).length();
                    let light_pdf = self.lights.pmf(prev_p, prev_n, index)
                        * area_to_solid_angle(1.0 / (std::f32::consts::PI * radius * radius), dist, -denom);
                    power_heuristic(prev_pdf, light_pdf)
                };
                sum += radiance * w;
                any = true;
            } else if intersect_sphere(org, dir, center, radius, tmax).is_some() {
                let w = if prev_pdf == 0.0 {
                    1.0
                } else {
                    let light_pdf = sphere_cos_max((center - prev_p).length(), radius)
                        .map_or(0.0, |c| self.lights.pmf(prev_p, prev_n, index) * uniform_cone_pdf(c));
                    power_heuristic(prev_pdf, light_pdf)
                };
                sum += radiance * w;
                any = true;
            }
        }
        (sum, any)
    }

    /// Radiance of sun disks seen along an escaping ray, MIS-weighted as `crossed_emission`.
    #[inline]
    pub fn sun_emission(&self, dir: Vec3, prev_pdf: f32) -> Rgb {
        let mut sum = Rgb::ZERO;
        for &(to_sun, cos_half, radiance, index) in &self.suns {
            if dir.dot(to_sun) >= cos_half {
                let w = if prev_pdf == 0.0 {
                    1.0
                } else {
                    power_heuristic(prev_pdf, self.lights.infinite_pmf(index) * uniform_cone_pdf(cos_half))
                };
                sum += radiance * w;
            }
        }
        sum
    }

    /// The media a path is in after leaving surface `s` in direction `wi`: crossing the
    /// boundary of a solid with a medium enters or leaves it (the nesting rule is
    /// `MediumStack`'s); reflection and thin surfaces keep the current media.
    #[inline]
    pub fn medium_after(&self, s: &SurfaceHit, wi: Vec3, mut stack: MediumStack) -> MediumStack {
        if wi.dot(s.ng) < 0.0 && self.scene.materials[s.material as usize].medium.is_some() {
            if s.front {
                stack.enter(s.material);
            } else {
                stack.leave(s.material);
            }
        }
        stack
    }

    /// The medium in effect for a stack of media.
    #[inline]
    pub fn medium(&self, stack: &MediumStack) -> Option<&HomogeneousMedium> {
        stack.current().and_then(|m| self.scene.materials[m as usize].medium.as_ref())
    }

    /// Radiance of the world seen along direction `d` (zero without a world).
    #[inline]
    pub fn world_radiance(&self, d: Vec3) -> Rgb {
        self.scene.world.as_ref().map_or(Rgb::ZERO, |w| w.radiance(d))
    }

    /// Density with which light sampling (world choice included) picks direction `d`.
    #[inline]
    pub fn world_pdf(&self, d: Vec3) -> f32 {
        match (self.world_light, &self.scene.world) {
            (Some(i), Some(w)) => self.lights.infinite_pmf(i) * w.pdf(d),
            _ => 0.0,
        }
    }

    /// Texture coordinates and vertex attributes interpolated at barycentrics.
    #[inline]
    fn attributes(&self, tri: u32, b1: f32, b2: f32) -> ([Vec2; 2], glam::Vec4) {
        let m = &self.scene.mesh;
        let [i0, i1, i2] = m.triangles[tri as usize].map(|i| i as usize);
        let b0 = 1.0 - b1 - b2;
        let uv0 = m.uv0[i0] * b0 + m.uv0[i1] * b1 + m.uv0[i2] * b2;
        let uv1 = m.uv1[i0] * b0 + m.uv1[i1] * b1 + m.uv1[i2] * b2;
        let c = m.colors[i0] * b0 + m.colors[i1] * b1 + m.colors[i2] * b2;
        ([uv0, uv1], c)
    }

    /// Alpha (coverage) of a triangle's material at barycentrics.
    #[inline]
    pub fn alpha(&self, tri: u32, b1: f32, b2: f32) -> f32 {
        let mat = &self.scene.materials[self.scene.mesh.tri_material[tri as usize] as usize];
        let (uv, color) = self.attributes(tri, b1, b2);
        let mut a = mat.base_color.w * color.w;
        if let Some(t) = mat.base_color_tex {
            a *= self.scene.textures[t.texture as usize].lookup(t.uv(uv[t.tex_coord as usize])).w;
        }
        a
    }

    /// Closest surface hit (alpha masks applied).
    #[inline]
    pub fn intersect(&self, org: Vec3, dir: Vec3, tmax: f32) -> Option<Hit> {
        self.accel.intersect(org, dir, tmax, &self.masked, |tri, b1, b2| {
            match self.scene.materials[self.scene.mesh.tri_material[tri as usize] as usize].alpha_mode {
                AlphaMode::Mask(cutoff) => self.alpha(tri, b1, b2) >= cutoff,
                _ => true,
            }
        })
    }

    /// Fraction of light passing from `org` along `dir` for distance `tmax`.
    #[inline]
    pub fn transmittance(&self, org: Vec3, dir: Vec3, tmax: f32) -> f32 {
        self.accel.transmittance(org, dir, tmax, &self.transparent, |tri, b1, b2| {
            match self.scene.materials[self.scene.mesh.tri_material[tri as usize] as usize].alpha_mode {
                AlphaMode::Mask(cutoff) => {
                    if self.alpha(tri, b1, b2) >= cutoff {
                        0.0
                    } else {
                        1.0
                    }
                }
                AlphaMode::Blend => (1.0 - self.alpha(tri, b1, b2)).clamp(0.0, 1.0),
                AlphaMode::Opaque => 0.0,
            }
        })
    }

    /// Geometry of a hit as seen from direction `wo` (pointing back along the ray).
    #[inline]
    pub fn surface(&self, hit: &Hit, org: Vec3, dir: Vec3) -> SurfaceHit {
        let m = &self.scene.mesh;
        let [i0, i1, i2] = m.triangles[hit.tri as usize].map(|i| i as usize);
        let (b1, b2) = (hit.b1, hit.b2);
        let b0 = 1.0 - b1 - b2;
        let (p0, p1, p2) = (m.positions[i0], m.positions[i1], m.positions[i2]);
        let mut p = p0 * b0 + p1 * b1 + p2 * b2;
        if !p.is_finite() {
            p = org + dir * hit.t;
        }
        let ng_front = (p1 - p0).cross(p2 - p0).normalize();
        let front = ng_front.dot(dir) < 0.0;
        let side = if front { 1.0 } else { -1.0 };
        let ng = ng_front * side;
        let n_interp = m.normals[i0] * b0 + m.normals[i1] * b1 + m.normals[i2] * b2;
        // Vertex normals that point against the winding (an authoring slip some exporters
        // make) would put the shading hemisphere below the surface and end most paths:
        // they are turned to the geometric normal's side first, as pbrt does.
        let ns = match n_interp.try_normalize() {
            Some(n) if n.dot(ng_front) < 0.0 => -n * side,
            Some(n) => n * side,
            None => ng,
        };
        let tangent = m.tangents[i0] * b0 + m.tangents[i1] * b1 + m.tangents[i2] * b2;
        let (uv, color) = self.attributes(hit.tri, b1, b2);
        SurfaceHit {
            p,
            ng,
            ns,
            tangent,
            uv,
            color,
            material: m.tri_material[hit.tri as usize],
            tri: hit.tri,
            front,
            t: hit.t,
        }
    }

    /// Evaluates the material at a hit: BSDF, shading frame and emission.
    #[inline]
    pub fn shade(&self, s: &SurfaceHit, wo: Vec3) -> ShadingPoint {
        let mat = &self.scene.materials[s.material as usize];
        let tex = &self.scene.textures;
        let lookup = |t: &crate::scene::TexRef| tex[t.texture as usize].lookup(t.uv(s.uv[t.tex_coord as usize]));
        let mut base = mat.base_color.truncate() * s.color.truncate();
        if let Some(t) = &mat.base_color_tex {
            base *= lookup(t).truncate();
        }
        let (mut metallic, mut roughness) = (mat.metallic, mat.roughness);
        if let Some(t) = &mat.metallic_roughness_tex {
            let v = lookup(t);
            roughness *= v.y;
            metallic *= v.z;
        }
        // A tangent-space normal map applied to the interpolated normal: (normal, tangent).
        let map_normal = |t: &crate::scene::TexRef, scale: f32| -> Option<(Vec3, Vec3)> {
            let tan = s.tangent.truncate();
            if tan.length_squared() <= 0.0 {
                return None;
            }
            let v = lookup(t);
            let local = Vec3::new((2.0 * v.x - 1.0) * scale, (2.0 * v.y - 1.0) * scale, 2.0 * v.z - 1.0);
            // The tangent frame belongs to the front face: undo the side flip.
            let side = if s.front { 1.0 } else { -1.0 };
            let nf = s.ns * side;
            let tf = (tan - nf * nf.dot(tan)).normalize_or_zero();
            let bf = nf.cross(tf) * if s.tangent.w < 0.0 { -1.0 } else { 1.0 };
            (tf * local.x + bf * local.y + nf * local.z).try_normalize().map(|m| (m * side, tf))
        };
        let mut n = s.ns;
        let mut tangent_hint = None;
        if let Some(t) = &mat.normal_tex
            && let Some((mapped, tf)) = map_normal(t, mat.normal_scale)
        {
            n = mapped;
            tangent_hint = Some(tf);
        }
        // A shading normal that faces away from the viewer makes the BRDF see the
        // viewer from below: bend it back toward the geometric normal just enough.
        let cos_o = n.dot(wo);
        if cos_o < 1e-3 {
            n = (n + wo * (1e-3 - cos_o)).normalize_or(s.ng);
            if n.dot(wo) <= 0.0 {
                n = s.ng;
            }
        }
        let frame = match tangent_hint {
            Some(t) => Frame::from_normal_tangent(n, t),
            None => Frame::from_normal(n),
        };
        let emitted =
            if mat.is_emissive() && (s.front || mat.double_sided) { mat.emission(tex, s.uv) } else { Rgb::ZERO };
        let mut transmission = mat.transmission;
        if let Some(t) = &mat.transmission_tex {
            transmission *= lookup(t).x;
        }
        let thin = mat.medium.is_none();
        // Entering or leaving is decided by the geometric normal; a thin sheet is the
        // same from both sides.
        let eta = if thin || s.front { mat.ior } else { 1.0 / mat.ior };
        let mut coat = mat.coat;
        if let Some(t) = &mat.coat_tex {
            coat *= lookup(t).x;
        }
        let mut coat_roughness = mat.coat_roughness;
        if let Some(t) = &mat.coat_roughness_tex {
            coat_roughness *= lookup(t).y;
        }
        let mut specular = mat.specular;
        if let Some(t) = &mat.specular_tex {
            specular *= lookup(t).w;
        }
        let mut specular_color = mat.specular_color;
        if let Some(t) = &mat.specular_color_tex {
            specular_color *= lookup(t).truncate();
        }
        let mut sheen_color = mat.sheen_color;
        if let Some(t) = &mat.sheen_color_tex {
            sheen_color *= lookup(t).truncate();
        }
        let mut sheen_roughness = mat.sheen_roughness;
        if let Some(t) = &mat.sheen_roughness_tex {
            sheen_roughness *= lookup(t).w;
        }
        // The coat's own normal map, in the shading frame (the coat lobe uses it).
        let coat_normal = match &mat.coat_normal_tex {
            Some(t) if coat > 0.0 => map_normal(t, mat.coat_normal_scale).map(|(m, _)| frame.to_local(m)),
            _ => None,
        };
        let params = PbrParams {
            base,
            metallic,
            roughness,
            specular,
            ior: mat.ior,
            transmission,
            thin,
            eta,
            coat,
            coat_roughness,
            coat_normal,
            coat_ior: mat.coat_ior,
            coat_tint: mat.coat_tint,
            specular_color,
            sheen_color,
            sheen_roughness,
            dispersion: mat.dispersion,
            subsurface: mat.subsurface.map_or(0.0, |s| s.weight),
        };
        ShadingPoint { bsdf: Bsdf::Pbr(PbrBsdf::from_params(&params)), frame, emitted }
    }

    /// Samples light `index` from point `p`.
    #[inline]
    pub fn sample_light(&self, index: usize, p: Vec3, u: Vec2) -> Option<LightSample> {
        match &self.scene.lights[index] {
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
            Light::Sphere { center, radius, radiance, soft: true, .. } => {
                // A disk of the sphere's radius facing the shading point.
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
                let pdf = area_to_solid_angle(1.0 / (std::f32::consts::PI * radius * radius), dist, (-wi).dot(n));
                (pdf > 0.0).then_some(LightSample { wi, dist, li: *radiance, pdf, delta: false, point: q, normal: n })
            }
            Light::Sphere { center, radius, radiance, soft: false, .. } => {
                let to_c = *center - p;
                let dist = to_c.length();
                let cos_max = sphere_cos_max(dist, *radius)?;
                let wi = Frame::from_normal(to_c / dist).to_world(uniform_cone(u, cos_max));
                // Rounding can make a ray at the cone's edge miss: use the tangent point.
                let t = intersect_sphere(p, wi, *center, *radius, f32::INFINITY).unwrap_or(dist * cos_max);
                let q = p + wi * t;
                Some(LightSample {
                    wi,
                    dist: t,
                    li: *radiance,
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
                let env = self.scene.world.as_ref()?;
                let (wi, li, pdf) = env.sample(u)?;
                Some(LightSample { wi, dist: f32::INFINITY, li, pdf, delta: false, point: p + wi, normal: Vec3::ZERO })
            }
            Light::Triangle { tri } => {
                let m = &self.scene.mesh;
                let idx = m.triangles[*tri as usize];
                let mat = &self.scene.materials[m.tri_material[*tri as usize] as usize];
                let et = EmitterTriangle { p: idx.map(|i| m.positions[i as usize]), two_sided: mat.double_sided };
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
                let (uv, _) = self.attributes(*tri, b.x, b.y);
                let normal = if cos_signed >= 0.0 { n } else { -n };
                // A partly transparent emitter emits in proportion to its coverage, as
                // a path that hits it counts its emission only when it does not pass.
                let coverage = match mat.alpha_mode {
                    AlphaMode::Opaque => 1.0,
                    AlphaMode::Blend => self.alpha(*tri, b.x, b.y).clamp(0.0, 1.0),
                    AlphaMode::Mask(cutoff) => (self.alpha(*tri, b.x, b.y) >= cutoff) as u8 as f32,
                };
                Some(LightSample {
                    wi,
                    dist,
                    li: mat.emission(&self.scene.textures, uv) * coverage,
                    pdf,
                    delta: false,
                    point: q,
                    normal,
                })
            }
        }
    }

    /// Solid-angle density with which `sample_light` (including the light choice, made
    /// with the receiver normal `n`) would pick the point `q` with normal `n_light` of
    /// light `index`, from `p`.
    #[inline]
    pub fn light_pdf(&self, index: usize, p: Vec3, n: Vec3, q: Vec3, n_light: Vec3) -> f32 {
        let pdf_area = match &self.scene.lights[index] {
            Light::Area(a) => a.pdf_area_from(p, q),
            Light::Triangle { tri } => {
                let m = &self.scene.mesh;
                let [a, b, c] = m.triangles[*tri as usize].map(|i| m.positions[i as usize]);
                1.0 / (0.5 * (b - a).cross(c - a).length())
            }
            _ => return 0.0,
        };
        let d = q - p;
        let dist = d.length();
        let cos_l = n_light.dot(-d / dist).abs();
        self.lights.pmf(p, n, index) * area_to_solid_angle(pdf_area, dist, cos_l)
    }

    /// Unoccluded fraction between a surface point (offset along `ng`) and a light sample.
    #[inline]
    pub fn visibility(&self, p: Vec3, ng: Vec3, ls: &LightSample) -> f32 {
        let side = if ls.wi.dot(ng) >= 0.0 { ng } else { -ng };
        let org = offset_ray_origin(p, side);
        if ls.dist.is_infinite() {
            return self.transmittance(org, ls.wi, f32::INFINITY);
        }
        let target = if ls.normal != Vec3::ZERO { offset_ray_origin(ls.point, ls.normal) } else { ls.point };
        let d = target - org;
        let dist = d.length();
        if !(dist > 0.0) {
            return 0.0;
        }
        self.transmittance(org, d / dist, dist * (1.0 - 1e-4))
    }
}

/// The light-transport algorithms; one per file.
#[derive(Clone, Debug)]
pub enum Integrator {
    /// Unidirectional path tracing with NEE and MIS.
    Path(path::PathIntegrator),
    /// Jensen's photon mapping (rendering pass; the maps are built before).
    Photon(photon::jensen::JensenIntegrator),
    /// Bidirectional path tracing with MIS over all strategies.
    Bdpt(bdpt::BdptIntegrator),
    /// Stochastic progressive photon mapping (drives its own iterations).
    Sppm(photon::sppm::SppmIntegrator),
}

/// Per-tile working memory of an integrator, taken before a tile and released after it.
pub enum TileScratch {
    /// Nothing to keep.
    None,
    /// Bidirectional: this tile's light-tracing splats and subpath vertices.
    Bdpt(SplatBuffer, bdpt::BdptScratch),
}

impl TileScratch {
    /// Hands the splat buffer back to the pool it came from.
    pub fn release(self, pool: &SplatPool) {
        if let TileScratch::Bdpt(buf, _) = self {
            pool.give(buf);
        }
    }
}

impl Integrator {
    /// Human-readable description with parameters, for logs and `info`.
    pub fn describe(&self) -> String {
        match self {
            Integrator::Path(p) => p.describe(),
            Integrator::Photon(p) => p.describe(),
            Integrator::Bdpt(b) => b.describe(),
            Integrator::Sppm(s) => s.describe(),
        }
    }

    /// Working memory for one tile of the progressive loop.
    pub fn tile_scratch(&self, splats: &SplatPool) -> TileScratch {
        match self {
            Integrator::Bdpt(b) => TileScratch::Bdpt(splats.take(), bdpt::BdptScratch::new(b.max_depth)),
            _ => TileScratch::None,
        }
    }

    /// Light subpaths traced per camera sample (bidirectional: one), for the summary.
    pub fn light_paths_per_sample(&self) -> u64 {
        matches!(self, Integrator::Bdpt(_)) as u64
    }

    /// One camera sample along `ray` of pixel sample `(seed, px, py, index)`.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn sample(
        &self,
        ctx: &SceneContext,
        camera: &CameraRays,
        filter: &Filter,
        scratch: &mut TileScratch,
        (org, dir): (Vec3, Vec3),
        sampler: &mut PixelSampler,
        pixel_sample: (u32, u32, u32, u32),
        stats: &mut RayStats,
    ) -> CameraSample {
        match (self, scratch) {
            (Integrator::Path(p), _) => p.li(ctx, org, dir, sampler, |q| camera.depth(q), stats),
            (Integrator::Photon(p), _) => p.li(ctx, org, dir, sampler, |q| camera.depth(q), stats),
            (Integrator::Bdpt(b), TileScratch::Bdpt(buf, vertices)) => {
                let mut target = bdpt::FilmTarget { camera, filter, splats: buf };
                b.li(ctx, org, dir, sampler, pixel_sample, &mut target, vertices, stats)
            }
            // SPPM renders whole iterations (`render::render` never asks it for samples);
            // BDPT always has its scratch (`tile_scratch`).
            (Integrator::Sppm(_) | Integrator::Bdpt(_), _) => CameraSample::default(),
        }
    }
}
