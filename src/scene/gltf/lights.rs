//! Lights: `KHR_lights_punctual` (with `CAUSTIC_lights_punctual`'s shapes),
//! `CAUSTIC_lights_area`, emissive triangles, and each light's power for light selection.

use super::extensions::{AreaLightExt, BlenderLight};
use super::{LUMENS_PER_WATT, Loader};
use crate::error::Result;
use crate::light::{AreaLight, AreaShape, Light};
use crate::math::luminance;
use crate::scene::{LightReport, Material, Mesh};
use glam::{Mat4, Vec3};
use std::collections::HashMap;

impl Loader<'_> {
    pub(super) fn punctual_light(
        &mut self,
        l: &gltf::khr_lights_punctual::Light,
        node_name: &str,
        world: &Mat4,
        blender: Option<serde_json::Value>,
    ) -> Result<(Light, LightReport)> {
        let name = l.name().map(str::to_string).unwrap_or_else(|| node_name.to_string());
        let intensity = l.intensity();
        let color = Vec3::from(l.color());
        if !(intensity >= 0.0 && intensity.is_finite() && color.is_finite()) || color.min_element() < 0.0 {
            return Err(self.err(format!("light '{name}': intensity and color must be finite and non-negative")));
        }
        if l.range().is_some() {
            self.warn(format!("light '{name}': 'range' is ignored (Caustic's lights fall off physically, as Cycles')"));
        }
        let position = world.transform_point3(Vec3::ZERO);
        let forward = world.transform_vector3(-Vec3::Z).normalize_or(-Vec3::Z);
        let radiometric = color * (intensity / LUMENS_PER_WATT);
        let bl: BlenderLight = match blender {
            None => BlenderLight::default(),
            Some(v) => serde_json::from_value(v)
                .map_err(|e| self.err(format!("light '{name}': CAUSTIC_lights_punctual is malformed: {e}")))?,
        };
        if !(bl.radius.is_finite() && bl.radius >= 0.0 && bl.angle.is_finite() && bl.angle >= 0.0)
            || bl.spot_blend.is_some_and(|b| !(b.is_finite() && b >= 0.0))
        {
            return Err(self.err(format!("light '{name}': CAUSTIC_lights_punctual values must be finite and ≥ 0")));
        }
        use gltf::khr_lights_punctual::Kind;
        if bl.radius > 0.0 && matches!(l.kind(), Kind::Spot { .. }) {
            self.warn(format!("light '{name}': a spot's radius is not supported; rendered as a point spot"));
        }
        let (light, kind) = match l.kind() {
            Kind::Point if bl.radius > 0.0 => {
                // The sphere radiates the point's power: L = P / (4π² r²), P = 4π I.
                let r = bl.radius;
                let radiance = radiometric / (std::f32::consts::PI * r * r);
                (
                    Light::Sphere {
                        center: position,
                        radius: r,
                        radiance,
                        soft: bl.soft_falloff,
                        camera_visible: bl.camera_visible,
                    },
                    "point",
                )
            }
            Kind::Point => (Light::Point { position, intensity: radiometric }, "point"),
            Kind::Directional => {
                let half = (0.5 * bl.angle).min(std::f32::consts::FRAC_PI_2);
                (
                    Light::Directional { direction: forward, irradiance: radiometric, cos_half: half.cos() },
                    "directional",
                )
            }
            Kind::Spot { inner_cone_angle, outer_cone_angle } => {
                let outer = outer_cone_angle.clamp(1e-4, std::f32::consts::FRAC_PI_2);
                let inner = inner_cone_angle.clamp(0.0, outer);
                if outer != outer_cone_angle || inner != inner_cone_angle {
                    self.warn(format!("light '{name}': spot cone angles were clamped to 0 ≤ inner ≤ outer ≤ π/2"));
                }
                (
                    Light::Spot {
                        position,
                        direction: forward,
                        intensity: radiometric,
                        cos_inner: inner.cos(),
                        cos_outer: outer.cos(),
                        smooth: bl.spot_blend.map(|b| 1.0 / ((1.0 - outer.cos()) * b).max(1e-12)),
                    },
                    "spot",
                )
            }
        };
        Ok((light, LightReport { kind: kind.into(), name, power: 0.0, triangles: 0 }))
    }

    pub(super) fn area_light(
        &mut self,
        ext: &serde_json::Value,
        name: &str,
        world: &Mat4,
    ) -> Result<Option<(Light, LightReport)>> {
        let a: AreaLightExt = serde_json::from_value(ext.clone())
            .map_err(|e| self.err(format!("node '{name}': CAUSTIC_lights_area is malformed: {e}")))?;
        let shape = match a.shape.as_str() {
            "rectangle" | "square" => AreaShape::Rectangle,
            "disk" | "ellipse" => AreaShape::Ellipse,
            other => {
                return Err(self.err(format!(
                    "node '{name}': CAUSTIC_lights_area shape '{other}' is unknown (rectangle, square, disk, ellipse)"
                )));
            }
        };
        let sx = *a.size.first().ok_or_else(|| self.err(format!("node '{name}': CAUSTIC_lights_area has no size")))?;
        let sy = if matches!(a.shape.as_str(), "square" | "disk") { sx } else { a.size.get(1).copied().unwrap_or(sx) };
        let color = Vec3::from(a.color);
        if !(a.power >= 0.0 && a.power.is_finite() && color.is_finite() && sx.is_finite() && sy.is_finite())
            || color.min_element() < 0.0
        {
            return Err(self.err(format!(
                "node '{name}': CAUSTIC_lights_area power, color and size must be finite and non-negative"
            )));
        }
        if !(a.spread > 0.0 && a.spread <= std::f32::consts::PI + 1e-4) {
            return Err(
                self.err(format!("node '{name}': CAUSTIC_lights_area spread {} must be in (0, π] radians", a.spread))
            );
        }
        if a.spread < crate::light::MIN_SPREAD {
            self.warn(format!(
                "area light '{name}': spread {:.2e} rad is rendered as {:.0e} rad (a collimated beam is not supported)",
                a.spread,
                crate::light::MIN_SPREAD
            ));
        }
        let center = world.transform_point3(Vec3::ZERO);
        let ax = world.transform_vector3(Vec3::X * (0.5 * sx));
        let ay = world.transform_vector3(Vec3::Y * (0.5 * sy));
        let emit = world.transform_vector3(-Vec3::Z);
        match AreaLight::new(shape, center, ax, ay, emit, color * a.power)
            .map(|l| AreaLight { camera_visible: a.camera_visible, ..l }.with_spread(a.spread))
        {
            Some(l) => Ok(Some((
                Light::Area(l),
                LightReport { kind: "area".into(), name: name.into(), power: 0.0, triangles: 0 },
            ))),
            None => {
                self.warn(format!("area light '{name}' has zero area and was skipped"));
                Ok(None)
            }
        }
    }

    /// Makes every emissive triangle a light of its own, with its power for light
    /// selection, and adds one report entry per emissive material.
    pub(super) fn emissive_lights(
        &self,
        mesh: &Mesh,
        materials: &[Material],
        lights: &mut Vec<Light>,
        light_power: &mut Vec<f32>,
        light_reports: &mut Vec<LightReport>,
    ) {
        let mut emissive_by_material: HashMap<u32, (usize, f32)> = HashMap::new();
        for (ti, tri) in mesh.triangles.iter().enumerate() {
            let mi = mesh.tri_material[ti];
            let mat = &materials[mi as usize];
            if !mat.is_emissive() {
                continue;
            }
            let mean_tex = mat.emissive_tex.map(|t| self.textures[t.texture as usize].mean_rgb()).unwrap_or(Vec3::ONE);
            let p = tri.map(|i| mesh.positions[i as usize]);
            let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
            let sides = if mat.double_sided { 2.0 } else { 1.0 };
            let power = luminance(mat.emissive * mean_tex) * area * std::f32::consts::PI * sides;
            if power <= 0.0 {
                continue;
            }
            lights.push(Light::Triangle { tri: ti as u32 });
            light_power.push(power);
            let e = emissive_by_material.entry(mi).or_default();
            e.0 += 1;
            e.1 += power;
        }
        let mut emissive: Vec<_> = emissive_by_material.into_iter().collect();
        emissive.sort_by_key(|(mi, _)| *mi);
        for (mi, (count, power)) in emissive {
            light_reports.push(LightReport {
                kind: "emissive".into(),
                name: materials[mi as usize].name.clone(),
                power,
                triangles: count,
            });
        }
    }
}

/// Power used for light selection and reported by `info` (luminance, W).
pub(super) fn punctual_power(l: &Light, scene_radius: f32) -> f32 {
    use std::f32::consts::PI;
    match l {
        Light::Point { intensity, .. } => 4.0 * PI * luminance(*intensity),
        // A spot's power is bounded by its cone; Blender's spots have a point's
        // intensity, so use the cone's solid angle.
        Light::Spot { intensity, cos_outer, .. } => 2.0 * PI * (1.0 - cos_outer) * luminance(*intensity),
        Light::Sphere { radius, radiance, .. } => 4.0 * PI * PI * radius * radius * luminance(*radiance),
        Light::Directional { irradiance, .. } => PI * scene_radius * scene_radius * luminance(*irradiance),
        Light::Area(a) => luminance(a.radiance) * a.area * PI,
        Light::Triangle { .. } | Light::World => 0.0,
    }
}
