//! What a ray hit, as the integrators see it: the surface's interpolated geometry and
//! attributes (`Scene::surface`), its alpha, and the material evaluated there — textures,
//! normal mapping and the BSDF (`Scene::shade`).

use super::bent_normal::valid_reflection_normal;
// The hit types live in the leaf `hit.rs` so that the node evaluator can take them
// without importing this dispatch; re-exported for the integrators.
pub use super::hit::{ShadingPoint, SurfaceHit};
use super::light_path::LightPath;
use super::{AlphaMode, Scene};
use crate::accel::Hit;
use crate::bsdf::pbr::PbrParams;
use crate::bsdf::{Bsdf, PbrBsdf};
use crate::math::{Frame, Rgb};
use glam::{Vec2, Vec3, Vec4};

impl Scene {
    /// Texture coordinates and vertex attributes interpolated at barycentrics.
    #[inline]
    pub fn attributes(&self, tri: u32, b1: f32, b2: f32) -> ([Vec2; 2], glam::Vec4) {
        let m = &self.mesh;
        let [i0, i1, i2] = m.triangles[tri as usize].map(|i| i as usize);
        let b0 = 1.0 - b1 - b2;
        let uv0 = m.uv0[i0] * b0 + m.uv0[i1] * b1 + m.uv0[i2] * b2;
        let uv1 = m.uv1[i0] * b0 + m.uv1[i1] * b1 + m.uv1[i2] * b2;
        // Offsets from the first corner, so that equal corners (the default white of a mesh
        // without COLOR_0) give that colour exactly: the three-term sum came to 0.99999994 at
        // some points, which cut holes in a MASK material whose alpha equals its cutoff.
        let c = m.colors[i0] + (m.colors[i1] - m.colors[i0]) * b1 + (m.colors[i2] - m.colors[i0]) * b2;
        ([uv0, uv1], c)
    }

    /// Alpha (coverage) of a triangle's material at barycentrics (a node graph's as light
    /// sampling sees it; rays use `pass_through` and `shadow_alpha`).
    #[inline]
    pub fn alpha(&self, tri: u32, b1: f32, b2: f32) -> f32 {
        let mat = &self.materials[self.mesh.tri_material[tri as usize] as usize];
        if let Some(prog) = &mat.nodes {
            return crate::shader::shade::node_alpha(self, prog, tri, b1, b2, LightPath::LIGHT_EMISSION, None, None);
        }
        let (uv, color) = self.attributes(tri, b1, b2);
        let mut a = mat.base_color.w * color.w;
        if let Some(t) = mat.base_color_tex {
            a *= self.textures[t.texture as usize].lookup(t.uv(uv[t.tex_coord as usize])).w;
        }
        a
    }

    /// Coverage of a triangle at barycentrics, as a path that hits it counts it: 1 when
    /// opaque, alpha for BLEND (stochastic pass-through), 0 or 1 for MASK. A partly
    /// transparent emitter emits in proportion to it, in every light-sampling routine.
    #[inline]
    pub fn coverage(&self, tri: u32, b1: f32, b2: f32) -> f32 {
        match self.materials[self.mesh.tri_material[tri as usize] as usize].alpha_mode {
            AlphaMode::Opaque => 1.0,
            AlphaMode::Blend => self.alpha(tri, b1, b2).clamp(0.0, 1.0),
            AlphaMode::Mask(cutoff) => (self.alpha(tri, b1, b2) >= cutoff) as u8 as f32,
        }
    }

    /// The factor a light-sampling routine gives a triangle's `emission_for` so that it
    /// emits what a path hitting it finds: its coverage, except on a BLEND node material,
    /// whose emission already carries its Transparent share (Cycles' closure weights: a
    /// Mix of Transparent and Emission at 0.5 emits 0.5 E), which a hit renormalises
    /// (`shade_nodes`) and passes through with the rest. Multiplying again by the coverage
    /// lit a floor by such a panel at 0.5 of Cycles.
    #[inline]
    pub fn emission_coverage(&self, tri: u32, b1: f32, b2: f32) -> f32 {
        let mat = &self.materials[self.mesh.tri_material[tri as usize] as usize];
        if mat.nodes.is_some() && mat.alpha_mode == AlphaMode::Blend {
            return 1.0;
        }
        self.coverage(tri, b1, b2)
    }

    /// Triangle `tri`'s corner positions and normals, a moving triangle's where it is at the
    /// ray's time (motion blur).
    #[inline]
    pub fn corners(&self, tri: u32) -> ([Vec3; 3], [Vec3; 3]) {
        let m = &self.mesh;
        let [i0, i1, i2] = m.triangles[tri as usize].map(|i| i as usize);
        let moved = self
            .motion
            .as_ref()
            .filter(|mo| mo.blurs())
            .and_then(|mo| mo.moving(tri).map(|k| mo.triangle_at(k, crate::motion::ray_time())));
        moved.unwrap_or((
            [m.positions[i0], m.positions[i1], m.positions[i2]],
            [m.normals[i0], m.normals[i1], m.normals[i2]],
        ))
    }

    /// Geometry of a hit as seen from direction `wo` (pointing back along the ray).
    #[inline]
    pub fn surface(&self, hit: &Hit, org: Vec3, dir: Vec3) -> SurfaceHit {
        if crate::curves::is_curve(hit.tri) {
            let mut s = self.curves.surface(hit, org, dir);
            let m = &self.materials[s.material as usize];
            if m.hair.is_some() || m.nodes.as_ref().is_some_and(|p| p.hair) {
                crate::curves::shade::as_fibre(&mut s, self.curves.axis_point(hit), -dir);
            }
            return s;
        }
        if crate::points::is_point(hit.tri) {
            return self.points.surface(hit, org, dir);
        }
        let m = &self.mesh;
        let [i0, i1, i2] = m.triangles[hit.tri as usize].map(|i| i as usize);
        let (b1, b2) = (hit.b1, hit.b2);
        let b0 = 1.0 - b1 - b2;
        let ([p0, p1, p2], [n0, n1, n2]) = self.corners(hit.tri);
        let mut p = p0 * b0 + p1 * b1 + p2 * b2;
        if !p.is_finite() {
            p = org + dir * hit.t;
        }
        let ng_front = (p1 - p0).cross(p2 - p0).normalize();
        let front = ng_front.dot(dir) < 0.0;
        let side = if front { 1.0 } else { -1.0 };
        let ng = ng_front * side;
        let n_interp = n0 * b0 + n1 * b1 + n2 * b2;
        // Vertex normals that point against the winding (an authoring slip some exporters
        // make) are kept as given, as Cycles and the glTF spec shade them: the shading
        // hemisphere then lies below the surface seen, where no path continues and no light
        // is taken (a plane of downward custom normals under a light is black in Cycles with
        // every BSDF; turned round, as pbrt does, it was 1.2-1.6 of Cycles' image).
        let ns = match n_interp.try_normalize() {
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
            bary: Vec2::new(b1, b2),
            front,
            t: hit.t,
            light_path: LightPath::CAMERA_RAY.at(hit.t),
        }
    }

    /// Evaluates the material at a hit: BSDF, shading frame and emission (a node graph's
    /// Ambient Occlusion and Bevel nodes untraced: `SceneContext::shade` traces them).
    #[inline]
    pub fn shade(&self, s: &SurfaceHit, wo: Vec3) -> ShadingPoint {
        self.shade_with(s, wo, None, None)
    }

    /// `shade`, taking the BSDF from `constant` (the material's `constant_bsdf`) when the
    /// hit's parameters are the ones it was built from but for the base colour: the same
    /// BSDF bit for bit, without rebuilding what does not change from hit to hit. `rays`:
    /// the scene's rays for a node graph's Ambient Occlusion and Bevel nodes.
    #[inline]
    pub fn shade_with(
        &self,
        s: &SurfaceHit,
        wo: Vec3,
        constant: Option<&ConstantBsdf>,
        rays: Option<&dyn crate::shader::geom::SceneRays>,
    ) -> ShadingPoint {
        let mat = &self.materials[s.material as usize];
        // A graph with hair closures wins over the compact parameters.
        if let Some(hair) = &mat.hair
            && crate::curves::is_curve(s.tri)
            && !mat.nodes.as_ref().is_some_and(|p| p.hair)
        {
            return self.shade_hair(hair, s, wo);
        }
        if let Some(prog) = &mat.nodes {
            return crate::shader::shade::shade_nodes(self, prog, s, wo, rays);
        }
        // Emission leaves both faces whatever glTF's `doubleSided` says, as Cycles renders the
        // Emission Blender's importer makes of it (it culls no back face); an unlit surface too.
        let emitted = if mat.is_emissive() { mat.emission(&self.textures, s.uv, s.color) } else { Rgb::ZERO };
        let side = s.front as usize;
        // The common case without building the parameters: a plain constant material
        // whose normal the viewer does not bend. `pbr_params` would then give the
        // template's parameters but for the base colour (no texture, no anisotropy, no
        // bent or mapped normal, so no diffuse or smooth normal and the frame of `s.ns`),
        // which `same_but_base` accepts: the same BSDF and frame, bit for bit. Skipping
        // the parameters and their comparison was ~40 % of `shade`'s instructions (callgrind).
        if let Some(c) = constant
            && c.plain
        {
            let n = valid_reflection_normal(s.ng, wo, s.ns);
            if n == s.ns {
                let base = if mat.unlit { Rgb::ZERO } else { mat.base_color.truncate() * s.color.truncate() };
                let bsdf = c.bsdf[side].with_base(base);
                return ShadingPoint { bsdf: Bsdf::Pbr(bsdf), frame: Frame::from_normal(n), emitted, holdout: 0.0 };
            }
        }
        let (params, frame) = self.pbr_params(s, wo);
        let bsdf = match constant {
            Some(c) if params.same_but_base(&c.params[side]) => c.bsdf[side].with_base(params.base),
            _ => PbrBsdf::from_params(&params),
        };
        ShadingPoint { bsdf: Bsdf::Pbr(bsdf), frame, emitted, holdout: 0.0 }
    }

    /// The BSDF of material `m` built once per side, when the material reads no texture
    /// (`Material::textures`, the one list of them) and has no shader graph; None otherwise.
    pub fn constant_bsdf(&self, m: u32) -> Option<ConstantBsdf> {
        let mat = self.materials.get(m as usize)?;
        if mat.nodes.is_some() || mat.textures().iter().any(Option::is_some) {
            return None;
        }
        let side = |front: bool| {
            // A hit seen head-on whose interpolated normal is the geometric one: no
            // normal is bent and there is no tangent, so nothing per-hit enters but the
            // base colour (which `with_base` supplies).
            let s = SurfaceHit {
                p: Vec3::ZERO,
                ng: Vec3::Z,
                ns: Vec3::Z,
                tangent: Vec4::ZERO,
                uv: [Vec2::ZERO; 2],
                color: Vec4::ONE,
                material: m,
                tri: 0,
                bary: Vec2::ZERO,
                front,
                t: 1.0,
                light_path: LightPath::CAMERA_RAY,
            };
            self.pbr_params(&s, Vec3::Z).0
        };
        let params = [side(false), side(true)];
        // Anisotropy enters per hit (through the tangent); parameters that are not equal
        // to themselves (a NaN factor) never pass `same_but_base`, so they keep that route.
        let plain = !(mat.anisotropy_strength > 0.0) && params.iter().all(|p| p.same_but_base(p));
        Some(ConstantBsdf { params, bsdf: params.map(|p| PbrBsdf::without_base(&p)), plain })
    }

    /// The glTF parameters of a material without a shader graph at a hit (textures read,
    /// normal mapped and bent) and the shading frame. Always inlined: returned from a
    /// call, the parameters were copied once more (callgrind).
    #[inline(always)]
    fn pbr_params(&self, s: &SurfaceHit, wo: Vec3) -> (PbrParams, Frame) {
        let mat = &self.materials[s.material as usize];
        let tex = &self.textures;
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
            let z = 2.0 * v.z - 1.0;
            // glTF scales x and y alone; Blender's Strength (Cycles' svm_node_normal_map) also
            // moves z from 1 towards the map's, so a weak map flattens rather than tilts.
            let z = if mat.normal_strength_blender { 1.0 + (z - 1.0) * scale.clamp(0.0, 1.0) } else { z };
            let local = Vec3::new((2.0 * v.x - 1.0) * scale, (2.0 * v.y - 1.0) * scale, z);
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
        // A shading normal whose mirror image of the viewer points below the surface (or
        // that faces away from the viewer) is turned towards the geometric normal just
        // enough for the specular reflection to stay valid, as Cycles does; the diffuse
        // base keeps the unbent normal, as Cycles' diffuse closure does.
        let unbent = n;
        n = valid_reflection_normal(s.ng, wo, n);
        let mut frame = match tangent_hint {
            Some(t) => Frame::from_normal_tangent(n, t),
            None => Frame::from_normal(n),
        };
        // KHR_materials_anisotropy: the direction in tangent space is (cos r, sin r), or the
        // texture's RG rotated by r; the texture's B scales the strength. The frame's X axis
        // is the direction; widths αx = mix(α, 1, strength²) along it and αy = α across.
        let mut anisotropy = None;
        let tan = s.tangent.truncate();
        if (mat.anisotropy_strength > 0.0 || mat.anisotropy_tex.is_some()) && tan.length_squared() > 0.0 {
            let (sin_r, cos_r) = mat.anisotropy_rotation.sin_cos();
            let (mut dir, mut strength) = (glam::Vec2::new(cos_r, sin_r), mat.anisotropy_strength);
            if let Some(t) = &mat.anisotropy_tex {
                let v = lookup(t);
                let d = glam::Vec2::new(2.0 * v.x - 1.0, 2.0 * v.y - 1.0);
                dir = glam::Vec2::new(cos_r * d.x - sin_r * d.y, sin_r * d.x + cos_r * d.y);
                strength *= v.z;
            }
            let side = if s.front { 1.0 } else { -1.0 };
            let nf = s.ns * side;
            let tf = (tan - nf * nf.dot(tan)).normalize_or_zero();
            let bf = nf.cross(tf) * if s.tangent.w < 0.0 { -1.0 } else { 1.0 };
            let d = tf * dir.x + bf * dir.y;
            let strength = strength.clamp(0.0, 1.0);
            if strength > 0.0 && (d - n * n.dot(d)).length_squared() > 1e-12 {
                frame = Frame::from_normal_tangent(n, d);
                let a = roughness.clamp(0.0, 1.0).powi(2);
                anisotropy = Some(if mat.anisotropy_blender {
                    // Cycles' Principled BSDF; widths above 1 are clamped to 1 by the BSDF.
                    let aspect = (1.0 - 0.9 * strength).sqrt();
                    (a / aspect, a * aspect)
                } else {
                    (a + (1.0 - a) * strength * strength, a)
                });
            }
        }
        let mut transmission = mat.transmission;
        if let Some(t) = &mat.transmission_tex {
            transmission *= lookup(t).x;
        }
        let mut diffuse_transmission = mat.diffuse_transmission;
        if let Some(t) = &mat.diffuse_transmission_tex {
            diffuse_transmission *= lookup(t).w;
        }
        let mut diffuse_transmission_color = mat.diffuse_transmission_color;
        if let Some(t) = &mat.diffuse_transmission_color_tex {
            diffuse_transmission_color *= lookup(t).truncate();
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
            Some(t) if coat > 0.0 => {
                map_normal(t, mat.coat_normal_scale).map(|(m, _)| frame.to_local(valid_reflection_normal(s.ng, wo, m)))
            }
            // Without its own map the coat keeps the interpolated normal, not the base's map
            // (KHR_materials_clearcoat; Cycles' unlinked Coat Normal is sd->N).
            None if coat > 0.0 && mat.normal_tex.is_some() => {
                Some(frame.to_local(valid_reflection_normal(s.ng, wo, s.ns)))
            }
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
            coat_dielectric_fresnel: mat.coat_dielectric_fresnel,
            specular_color,
            sheen_color,
            sheen_roughness,
            microfiber_sheen: mat.sheen_microfiber,
            dispersion: mat.dispersion,
            subsurface: mat.subsurface.map_or(0.0, |s| s.weight),
            diffuse_normal: (n != unbent).then(|| frame.to_local(unbent)),
            smooth_normal: (unbent != s.ns).then(|| frame.to_local(s.ns)),
            cut_normal: (n != s.ns).then(|| frame.to_local(s.ns)),
            anisotropy,
            diffuse_roughness: 0.0,
            cycles_principled: false,
            thin_film: mat.iridescence.map(|i| {
                let factor = i.factor * i.factor_tex.map_or(1.0, |t| lookup(&t).x);
                let g = i.thickness_tex.map_or(1.0, |t| lookup(&t).y);
                (i.thickness_min + (i.thickness_max - i.thickness_min) * g, i.ior, factor)
            }),
            thin_film_metal: mat.iridescence.is_some_and(|i| i.on_metal),
            // glTF's materials are compensated, as Cycles' default Multiscatter GGX.
            single_scatter: false,
            diffuse_transmission,
            diffuse_transmission_color,
        };
        // An unlit surface only shows its colour (the emission above): it reflects nothing.
        let params =
            if mat.unlit { PbrParams { specular: 0.0, ..PbrParams::opaque(Rgb::ZERO, 0.0, 1.0) } } else { params };
        (params, frame)
    }
}

/// A texture-free material's BSDF on each side (indexed by `SurfaceHit::front`) without
/// its base colour, and the parameters it was built from (`Scene::constant_bsdf`).
#[derive(Clone, Debug)]
pub struct ConstantBsdf {
    params: [PbrParams; 2],
    bsdf: [PbrBsdf; 2],
    /// Nothing but the base colour and the bent normal varies per hit (no anisotropy,
    /// parameters equal to themselves): `shade_with` may skip building the parameters.
    plain: bool,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Material;

    /// For texture-free materials of every kind the glTF path builds, the BSDF, frame and
    /// emission taken from `constant_bsdf` are the ones `shade` builds, bit for bit
    /// (compared through `Debug`, which prints each f32 exactly), at hits with vertex
    /// colours, tilted shading normals (some bent) and tangents; and the fast path is
    /// taken at most of them.
    #[test]
    fn constant_bsdf_is_the_shaded_one() {
        let materials = vec![
            Material::default(),
            Material {
                base_color: glam::Vec4::new(0.8, 0.3, 0.2, 1.0),
                metallic: 0.0,
                roughness: 0.5,
                ..Default::default()
            },
            Material { metallic: 0.6, roughness: 0.3, ..Default::default() },
            Material { metallic: 0.0, roughness: 0.2, transmission: 0.9, ior: 1.45, ..Default::default() },
            Material {
                metallic: 0.0,
                coat: 0.7,
                coat_roughness: 0.1,
                sheen_color: Vec3::splat(0.5),
                ..Default::default()
            },
            Material { metallic: 0.0, anisotropy_strength: 0.6, ..Default::default() },
            Material { unlit: true, ..Default::default() },
            Material { emissive: Vec3::new(2.0, 1.0, 0.5), ..Default::default() },
        ];
        let scene = Scene { materials, ..Default::default() };
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut rnd = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32 + 0.5) / (1u64 << 24) as f32
        };
        let (mut fast, mut plain, mut total) = (0, 0, 0);
        for m in 0..scene.materials.len() as u32 {
            let constant = scene.constant_bsdf(m).expect("texture-free material");
            for i in 0..400 {
                let tilt = if i % 2 == 0 { 0.0 } else { 0.4 };
                let ns = Vec3::new(tilt * (rnd() - 0.5), tilt * (rnd() - 0.5), 1.0).normalize();
                let wo = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd()).normalize();
                let s = SurfaceHit {
                    p: Vec3::ZERO,
                    ng: Vec3::Z,
                    ns,
                    tangent: if i % 3 == 0 { Vec4::ZERO } else { Vec4::new(1.0, 0.0, 0.0, 1.0) },
                    uv: [Vec2::ZERO; 2],
                    color: Vec4::new(rnd(), rnd(), rnd(), 1.0) * 0.5 + Vec4::splat(0.5),
                    material: m,
                    tri: 0,
                    bary: Vec2::ZERO,
                    front: i % 4 < 2,
                    t: 1.0,
                    light_path: LightPath::CAMERA_RAY,
                };
                let (want, got) = (scene.shade(&s, wo), scene.shade_with(&s, wo, Some(&constant), None));
                let want = format!("{:?} {:?} {:?}", want.bsdf, want.frame, want.emitted);
                let got = format!("{:?} {:?} {:?}", got.bsdf, got.frame, got.emitted);
                assert_eq!(got, want, "material {m}, hit {i}");
                total += 1;
                fast += scene.pbr_params(&s, wo).0.same_but_base(&constant.params[s.front as usize]) as u32;
                plain += (constant.plain && valid_reflection_normal(s.ng, wo, s.ns) == s.ns) as u32;
            }
        }
        assert!(fast * 2 > total, "fast path taken at {fast} of {total} hits");
        // Every material but the anisotropic one is plain; unbent hits take the shortest route.
        assert!(plain * 2 > total, "parameters skipped at {plain} of {total} hits");
    }
}
