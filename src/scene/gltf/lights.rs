//! Lights: `KHR_lights_punctual` (with `CAUSTIC_lights_punctual`'s shapes),
//! `CAUSTIC_lights_area`, emissive triangles, and each light's power for light selection.

use super::emission::{MeanPyramid, pyramid_bytes};
use super::extensions::{AreaLightExt, BlenderLight, light_rays};
use super::{LUMENS_PER_WATT, Loader};
use crate::error::Result;
use crate::light::light_graph::LightGraph;
use crate::light::{AreaLight, AreaShape, Light, SpotAxes, SpotCone};
use crate::math::luminance;
use crate::scene::{LightReport, Material, Mesh};
use glam::{Mat4, Vec3};
use std::collections::HashMap;

/// The selection power of emissive triangle `tri` of mean radiance luminance `radiance`:
/// its flux π L A from each of its two faces, which both emit (`Material::emissive`;
/// the loader and the server's graph edit share it).
pub(crate) fn triangle_light_power(mesh: &Mesh, tri: u32, radiance: f32) -> f32 {
    let p = mesh.triangles[tri as usize].map(|i| mesh.positions[i as usize]);
    let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
    radiance * area * std::f32::consts::PI * 2.0
}

/// What a `CAUSTIC_lights_area` node becomes.
pub(super) enum AreaResult {
    /// An emitting area light, its report and its varying node tree.
    Light(Light, LightReport, Option<LightGraph>),
    /// A portal (Cycles' Portal): it steers the world's light sampling and emits nothing.
    Portal(AreaLight),
}

impl Loader<'_> {
    pub(super) fn punctual_light(
        &mut self,
        l: &gltf::khr_lights_punctual::Light,
        node_name: &str,
        world: &Mat4,
        blender: Option<serde_json::Value>,
    ) -> Result<(Light, LightReport, Option<LightGraph>)> {
        let name = l.name().map(str::to_string).unwrap_or_else(|| node_name.to_string());
        let intensity = l.intensity();
        let color = Vec3::from(l.color());
        // glTF's intensity is never negative; Blender's negative power comes as its size with
        // CAUSTIC_lights_punctual's `negative`.
        if !(intensity >= 0.0 && intensity.is_finite() && color.is_finite()) || color.min_element() < 0.0 {
            return Err(self.err(format!(
                "light '{name}': intensity and color must be finite and non-negative (a light that subtracts \
                 light says so with CAUSTIC_lights_punctual's 'negative')"
            )));
        }
        if l.range().is_some() {
            self.warn(format!("light '{name}': 'range' is ignored (Caustic's lights fall off physically, as Cycles')"));
        }
        let position = world.transform_point3(Vec3::ZERO);
        let forward = world.transform_vector3(-Vec3::Z).normalize_or(-Vec3::Z);
        let bl: BlenderLight = match blender {
            None => BlenderLight::default(),
            Some(v) => serde_json::from_value(v)
                .map_err(|e| self.err(format!("light '{name}': CAUSTIC_lights_punctual is malformed: {e}")))?,
        };
        // A negative light subtracts its light, as Cycles renders a negative strength: the
        // emission carries the sign, light selection takes its size (`punctual_power`).
        let sign = if bl.negative { -1.0 } else { 1.0 };
        let radiometric = color * (sign * intensity / LUMENS_PER_WATT);
        if !(bl.radius.is_finite() && bl.radius >= 0.0 && bl.angle.is_finite() && bl.angle >= 0.0)
            || bl.spot_blend.is_some_and(|b| !(b.is_finite() && b >= 0.0))
        {
            return Err(self.err(format!("light '{name}': CAUSTIC_lights_punctual values must be finite and ≥ 0")));
        }
        use gltf::khr_lights_punctual::Kind;
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
                        spot: None,
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
                let (cos_inner, cos_outer) = (inner.cos(), outer.cos());
                let smooth = bl.spot_blend.map(|b| 1.0 / ((1.0 - cos_outer) * b).max(1e-12));
                // Cycles stretches a Blender spot's cone by its object's scale (the node's
                // local frame is the light object's, scale included); glTF's own spots
                // ignore the node's scale, as its spec says.
                let axes = if smooth.is_some() {
                    let axis = |v: Vec3| world.transform_vector3(v);
                    SpotAxes::from_object_axes(axis(Vec3::X), axis(Vec3::Y), axis(Vec3::Z), forward).unwrap_or_else(
                        |_| {
                            self.warn(format!(
                            "light '{name}': its object's axes are sheared (a parent's non-uniform scale): the spot \
                             cone is not stretched by the scale as in Cycles"
                        ));
                            None
                        },
                    )
                } else {
                    None
                };
                let light = if bl.radius > 0.0 {
                    // Cycles' spot with a radius: the point light's sphere (or soft-falloff
                    // disk) of the same intensity, masked by the cone (`SpotCone`).
                    let r = bl.radius;
                    Light::Sphere {
                        center: position,
                        radius: r,
                        radiance: radiometric / (std::f32::consts::PI * r * r),
                        soft: bl.soft_falloff,
                        camera_visible: bl.camera_visible,
                        spot: Some(SpotCone { direction: forward, cos_inner, cos_outer, smooth, axes }),
                    }
                } else {
                    Light::Spot {
                        position,
                        direction: forward,
                        intensity: radiometric,
                        cos_inner,
                        cos_outer,
                        smooth,
                        axes,
                    }
                };
                (light, "spot")
            }
        };
        let (light, graph) = match &bl.nodes {
            Some(nodes) => self.light_with_nodes(light, &name, nodes, world)?,
            None => (light, None),
        };
        Ok((
            light,
            LightReport {
                kind: kind.into(),
                name,
                power: 0.0,
                triangles: 0,
                cast_shadow: bl.cast_shadow,
                lights_catcher: bl.shadow_catcher,
                rays: light_rays(
                    bl.diffuse_visible,
                    bl.glossy_visible,
                    bl.transmission_visible,
                    bl.volume_scatter_visible,
                ),
                max_bounces: crate::scene::light_bounces::from_file(bl.max_bounces),
            },
            graph,
        ))
    }

    /// An area light of `CAUSTIC_lights_area` on node `name`: a light with its report, or
    /// a portal of the world; None (warned) when its area is zero.
    pub(super) fn area_light(
        &mut self,
        ext: &serde_json::Value,
        name: &str,
        world: &Mat4,
    ) -> Result<Option<AreaResult>> {
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
        // A negative power subtracts light, as Cycles renders a negative strength.
        if !(a.power.is_finite() && color.is_finite() && sx.is_finite() && sy.is_finite()) || color.min_element() < 0.0
        {
            return Err(self.err(format!(
                "node '{name}': CAUSTIC_lights_area power, color and size must be finite, color non-negative"
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
        if a.portal {
            // A window for the world's light sampling: its shape and facing only.
            return match AreaLight::new(shape, center, ax, ay, emit, Vec3::ZERO) {
                Some(l) => Ok(Some(AreaResult::Portal(l))),
                None => {
                    self.warn(format!("portal '{name}' has zero area and was skipped"));
                    Ok(None)
                }
            };
        }
        match AreaLight::new(shape, center, ax, ay, emit, color * a.power)
            .map(|l| AreaLight { camera_visible: a.camera_visible, ..l }.with_spread(a.spread))
        {
            Some(l) => {
                let (light, graph) = match &a.nodes {
                    Some(nodes) => self.light_with_nodes(Light::Area(l), name, nodes, world)?,
                    None => (Light::Area(l), None),
                };
                Ok(Some(AreaResult::Light(
                    light,
                    LightReport {
                        kind: "area".into(),
                        name: name.into(),
                        power: 0.0,
                        triangles: 0,
                        cast_shadow: a.cast_shadow,
                        lights_catcher: a.shadow_catcher,
                        rays: light_rays(
                            a.diffuse_visible,
                            a.glossy_visible,
                            a.transmission_visible,
                            a.volume_scatter_visible,
                        ),
                        max_bounces: crate::scene::light_bounces::from_file(a.max_bounces),
                    },
                    graph,
                )))
            }
            None => {
                self.warn(format!("area light '{name}' has zero area and was skipped"));
                Ok(None)
            }
        }
    }

    /// Makes every emissive triangle a light of its own, with its power for light
    /// selection (the emissive texture's mean over the triangle's UVs, from a pyramid
    /// built once per texture), and adds one report entry per emissive material.
    pub(super) fn emissive_lights(
        &mut self,
        mesh: &Mesh,
        materials: &[Material],
        lights: &mut Vec<Light>,
        light_power: &mut Vec<f32>,
        light_reports: &mut Vec<LightReport>,
    ) -> Result<()> {
        let mut pyramids: HashMap<u32, MeanPyramid> = HashMap::new();
        let mut reads = 0u64;
        let mut emissive_by_material: HashMap<u32, (usize, f32)> = HashMap::new();
        for (ti, tri) in mesh.triangles.iter().enumerate() {
            let mi = mesh.tri_material[ti];
            let mat = &materials[mi as usize];
            // An unlit surface shows its colour to the camera alone: no light (`mod.rs`).
            if !mat.is_emissive() || mat.unlit {
                continue;
            }
            // The image's mean bounds what the per-triangle mean may miss (a bright texel
            // whose coarse texel's centre falls outside the triangle): every triangle of
            // a texture that emits anywhere stays a light, with at least a hundredth of
            // that power, because BDPT joins only emitters that are lights.
            let (mean_tex, floor) = match mat.emissive_tex {
                None => (Vec3::ONE, Vec3::ZERO),
                Some(t) => {
                    let tex = &self.textures[t.texture as usize];
                    if let std::collections::hash_map::Entry::Vacant(slot) = pyramids.entry(t.texture) {
                        // Transient: dropped when the powers are known.
                        self.budget.check_peak(
                            format!("the emission pyramid of texture '{}' ({}×{})", tex.name, tex.width, tex.height),
                            pyramid_bytes(tex.width, tex.height),
                        )?;
                        slot.insert(MeanPyramid::new(tex, &mut reads));
                    }
                    let set = if t.tex_coord == 0 { &mesh.uv0 } else { &mesh.uv1 };
                    let uv = tri.map(|i| t.uv(set[i as usize]));
                    (pyramids[&t.texture].triangle_mean(tex, uv, &mut reads), tex.mean_rgb() * MIN_POWER_SHARE)
                }
            };
            let radiance = luminance(mat.emissive * mean_tex).max(luminance(mat.emissive * floor));
            let power = triangle_light_power(mesh, ti as u32, radiance);
            if power <= 0.0 {
                continue;
            }
            lights.push(Light::Triangle { tri: ti as u32 });
            light_power.push(power);
            let e = emissive_by_material.entry(mi).or_default();
            e.0 += 1;
            e.1 += power;
        }
        self.profile.emitter_texel_reads += reads;
        let mut emissive: Vec<_> = emissive_by_material.into_iter().collect();
        emissive.sort_by_key(|(mi, _)| *mi);
        for (mi, (count, power)) in emissive {
            light_reports.push(LightReport {
                kind: "emissive".into(),
                name: materials[mi as usize].name.clone(),
                power,
                triangles: count,
                cast_shadow: true,
                lights_catcher: true,
                rays: crate::scene::visibility::RayMask::ALL,
                // Cycles gives emissive objects no Max Bounces.
                max_bounces: crate::scene::light_bounces::NO_LIMIT,
            });
        }
        Ok(())
    }
}

/// Least power of a textured emissive triangle, as a share of what the image's mean gives.
const MIN_POWER_SHARE: f32 = 0.01;

/// Power used for light selection (luminance, W): its size, so a negative light is picked as
/// often as a positive one of the same size, as Cycles' light tree takes |energy| (the
/// server's light edits share it).
pub(crate) fn punctual_power(l: &Light, scene_radius: f32) -> f32 {
    // The luminance's size, as `light::selection_weight` takes it.
    signed_power(l, scene_radius).abs()
}

/// The light's power (luminance, W) with the sign of its emission, as `info` reports it.
pub(super) fn signed_power(l: &Light, scene_radius: f32) -> f32 {
    use std::f32::consts::PI;
    match l {
        Light::Point { intensity, .. } => 4.0 * PI * luminance(*intensity),
        // A spot's power is bounded by its cone; Blender's spots have a point's
        // intensity, so use the cone's solid angle.
        Light::Spot { intensity, cos_outer, .. } => 2.0 * PI * (1.0 - cos_outer) * luminance(*intensity),
        Light::Sphere { radius, radiance, spot, .. } => {
            4.0 * PI * PI * radius * radius * luminance(*radiance) * spot.map_or(1.0, |c| c.power_share())
        }
        Light::Directional { irradiance, .. } => PI * scene_radius * scene_radius * luminance(*irradiance),
        Light::Area(a) => luminance(a.radiance) * a.area * PI,
        Light::Triangle { .. } | Light::World => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use crate::light::Light;
    use crate::memory::MemoryBudget;
    use base64::Engine;
    use serde_json::json;

    /// An n×n grid of quads (2n² triangles) over the unit square, UVs = positions, with an
    /// emissive material whose emissiveTexture is a `side`² PNG from `texel`.
    fn grid_scene(n: u32, side: u32, texel: impl Fn(u32, u32) -> [u8; 3]) -> crate::scene::Scene {
        let b64 = |b: &[u8]| base64::engine::general_purpose::STANDARD.encode(b);
        let mut pos = Vec::new();
        let mut uv = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (i as f32 / n as f32, j as f32 / n as f32);
                pos.extend([x, y, 0.0]);
                uv.extend([x, y]);
            }
        }
        let v = |i: u32, j: u32| j * (n + 1) + i;
        let idx: Vec<u32> = (0..n)
            .flat_map(|j| {
                (0..n).flat_map(move |i| [v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j), v(i + 1, j + 1), v(i, j + 1)])
            })
            .collect();
        let bytes = |f: &[f32]| f.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
        let (p, t, i) = (bytes(&pos), bytes(&uv), idx.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>());
        let data = [p.clone(), t.clone(), i.clone()].concat();
        let img = image::RgbImage::from_fn(side, side, |x, y| image::Rgb(texel(x, y)));
        let mut png = std::io::Cursor::new(Vec::new());
        img.write_to(&mut png, image::ImageFormat::Png).unwrap();
        let doc = json!({
            "asset": {"version": "2.0"},
            "buffers": [{"uri": format!("data:application/octet-stream;base64,{}", b64(&data)), "byteLength": data.len()}],
            "bufferViews": [
                {"buffer": 0, "byteOffset": 0, "byteLength": p.len()},
                {"buffer": 0, "byteOffset": p.len(), "byteLength": t.len()},
                {"buffer": 0, "byteOffset": p.len() + t.len(), "byteLength": i.len()}
            ],
            "accessors": [
                {"bufferView": 0, "componentType": 5126, "count": pos.len() / 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                {"bufferView": 1, "componentType": 5126, "count": uv.len() / 2, "type": "VEC2"},
                {"bufferView": 2, "componentType": 5125, "count": idx.len(), "type": "SCALAR"}
            ],
            "images": [{"uri": format!("data:image/png;base64,{}", b64(png.get_ref()))}],
            "textures": [{"source": 0}],
            "materials": [{"emissiveFactor": [1.0, 0.5, 0.25], "emissiveTexture": {"index": 0}}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
            "nodes": [{"mesh": 0}],
            "scenes": [{"nodes": [0]}]
        });
        let json = serde_json::to_vec(&doc).unwrap();
        super::super::load_bytes(&json, std::path::Path::new("."), "grid.gltf", &MemoryBudget::unlimited()).unwrap()
    }

    /// The power the loader gave every emissive triangle before the per-triangle means:
    /// the image's mean for each triangle.
    fn image_mean_powers(scene: &crate::scene::Scene) -> Vec<f32> {
        let mat = &scene.materials[0];
        let mean = scene.textures[mat.emissive_tex.unwrap().texture as usize].mean_rgb();
        let m = &scene.mesh;
        scene
            .lights
            .iter()
            .map(|l| {
                let Light::Triangle { tri } = l else { panic!("only emissive triangles") };
                let p = m.triangles[*tri as usize].map(|i| m.positions[i as usize]);
                let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
                // Both faces emit (`triangle_light_power`).
                crate::math::luminance(mat.emissive * mean) * area * std::f32::consts::PI * 2.0
            })
            .collect()
    }

    #[test]
    fn many_emissive_triangles_on_a_large_texture_read_each_texel_a_bounded_number_of_times() {
        let (n, side) = (64u32, 1024u64);
        let scene = grid_scene(n, side as u32, |x, y| [(x ^ y) as u8, x as u8, 255]);
        let triangles = 2 * (n as u64).pow(2);
        assert_eq!(scene.lights.len() as u64, triangles);
        // The pyramid reads each texel once plus a third for its levels; each triangle
        // reads at most (8 + 2)² texels. The whole-image mean per triangle read 8.6e9.
        let bound = side * side * 4 / 3 + 4 * side + triangles * 100;
        let reads = scene.report.profile.emitter_texel_reads;
        assert!(reads <= bound, "{reads} texel reads > {bound}");
        // On a grid covering the image once, the area-weighted sum of the per-triangle
        // means is the image's power but for the texel centres on each quad's diagonal,
        // which both halves count. A quad is 16 texels wide, so its triangles are read at
        // level 1 (8 texels wide after the FOOTPRINT_TEXELS rule): N = 64 texels, k = 8 of
        // them on the diagonal. Halves' means (S1 + D)/c and (S2 + D)/c with c = (N + k)/2
        // average to (T + D)/(N + k) against the true T/N (T = S1 + S2 + D), a difference
        // of k/(N + k) · (D/k - T/N), at most k/(N + k) · (max - min) of the texels'
        // luminance. (Box filtering over whole quads is exact: 16 is even.)
        let mat = &scene.materials[0];
        let tex = &scene.textures[mat.emissive_tex.unwrap().texture as usize];
        let lum = |x: i64, y: i64| crate::math::luminance(mat.emissive * tex.texel(x, y).truncate()) as f64;
        let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
        for y in 0..side as i64 {
            for x in 0..side as i64 {
                (lo, hi) = (lo.min(lum(x, y)), hi.max(lum(x, y)));
            }
        }
        let area_pi = std::f64::consts::PI; // the grid's area (1) × π
        let (new, old): (f64, f64) = (
            scene.light_power.iter().map(|&p| p as f64).sum(),
            image_mean_powers(&scene).iter().map(|&p| p as f64).sum(),
        );
        let bound = 8.0 / (64.0 + 8.0) * (hi - lo) * area_pi;
        assert!((new - old).abs() <= bound, "{new} vs {old}: more than {bound} apart");
    }

    #[test]
    fn every_triangle_of_a_texture_that_emits_somewhere_stays_a_light() {
        // One lit texel corner on black: BDPT sees emission only from lights, so the black
        // triangles stay lights too, with the floor of a hundredth of the image mean's power.
        let scene = grid_scene(8, 64, |x, y| if x < 4 && y < 4 { [255; 3] } else { [0; 3] });
        assert_eq!(scene.lights.len(), 128);
        let old = image_mean_powers(&scene);
        let floor = old[0] * super::MIN_POWER_SHARE;
        let at_floor = scene.light_power.iter().filter(|&&p| (p - floor).abs() <= 1e-6 * floor).count();
        assert!(at_floor >= 120, "{at_floor} of 128 triangles at the floor: {:?}", scene.light_power);
        assert!(scene.light_power.iter().any(|&p| p > old[0]), "the lit corner outweighs the image mean");
    }

    #[test]
    fn a_constant_emissive_texture_gives_exactly_the_old_power() {
        let scene = grid_scene(16, 300, |_, _| [180, 40, 220]);
        assert_eq!(scene.light_power, image_mean_powers(&scene));
    }
}
