//! What a ray hit, as the integrators see it: the surface's interpolated geometry and
//! attributes (`Scene::surface`), its alpha, and the material evaluated there — textures,
//! normal mapping and the BSDF (`Scene::shade`).

use super::bent_normal::valid_reflection_normal;
// The hit types live in the leaf `hit.rs` so that the node evaluator can take them
// without importing this dispatch; re-exported for the integrators.
pub use super::hit::{ShadingPoint, SurfaceHit};
use super::{AlphaMode, Scene};
use crate::accel::Hit;
use crate::bsdf::pbr::PbrParams;
use crate::bsdf::{Bsdf, PbrBsdf};
use crate::math::{Frame, Rgb};
use glam::{Vec2, Vec3};

impl Scene {
    /// Texture coordinates and vertex attributes interpolated at barycentrics.
    #[inline]
    pub fn attributes(&self, tri: u32, b1: f32, b2: f32) -> ([Vec2; 2], glam::Vec4) {
        let m = &self.mesh;
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
        let mat = &self.materials[self.mesh.tri_material[tri as usize] as usize];
        if let Some(prog) = &mat.nodes {
            return crate::shader::shade::node_alpha(self, prog, tri, b1, b2);
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

    /// Geometry of a hit as seen from direction `wo` (pointing back along the ray).
    #[inline]
    pub fn surface(&self, hit: &Hit, org: Vec3, dir: Vec3) -> SurfaceHit {
        let m = &self.mesh;
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
        let mat = &self.materials[s.material as usize];
        if let Some(prog) = &mat.nodes {
            return crate::shader::shade::shade_nodes(self, prog, s, wo, mat.double_sided);
        }
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
        let emitted = if mat.is_emissive() && (s.front || mat.double_sided) {
            mat.emission(tex, s.uv, s.color)
        } else {
            Rgb::ZERO
        };
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
            Some(t) if coat > 0.0 => {
                map_normal(t, mat.coat_normal_scale).map(|(m, _)| frame.to_local(valid_reflection_normal(s.ng, wo, m)))
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
            specular_color,
            sheen_color,
            sheen_roughness,
            dispersion: mat.dispersion,
            subsurface: mat.subsurface.map_or(0.0, |s| s.weight),
            diffuse_normal: (n != unbent).then(|| frame.to_local(unbent)),
            smooth_normal: (unbent != s.ns).then(|| frame.to_local(s.ns)),
            anisotropy,
        };
        // An unlit surface only shows its colour (the emission above): it reflects nothing.
        let params =
            if mat.unlit { PbrParams { specular: 0.0, ..PbrParams::opaque(Rgb::ZERO, 0.0, 1.0) } } else { params };
        ShadingPoint { bsdf: Bsdf::Pbr(PbrBsdf::from_params(&params)), frame, emitted }
    }
}
