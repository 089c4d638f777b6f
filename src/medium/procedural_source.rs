//! The node-graph volume's shader at a point (`procedural.rs` builds the medium around it):
//! the compiled [`VolumeProgram`] run in the thread's register file, read as a Principled
//! Volume, and Cycles' coefficients from it.

use super::blackbody::{CLOSURE_WEIGHT_CUTOFF, blackbody_emission};
use super::coefficients::{PointCoefficients, VolumeShader};
use crate::math::Rgb;
use crate::scene::light_path::LightPath;
use crate::shader::closure::Closures;
use crate::shader::compile::volume::{VolumeKind, VolumeProgram};
use crate::shader::geom::{Geom, NO_VIEW, ObjectData};
use crate::shader::program::with_registers;
use glam::{Vec2, Vec3, Vec4};

/// The program and what its input nodes read.
#[derive(Clone, Debug)]
pub struct ProceduralSource {
    /// The compiled volume shader.
    pub volume: VolumeProgram,
    /// The object whose space Object and Generated coordinates are in.
    pub object: ObjectData,
}

impl ProceduralSource {
    /// The shading point the program sees at world point `p` (glTF axes).
    #[inline]
    fn geom(&self, p: Vec3) -> Geom<'_> {
        Geom {
            p,
            n: Vec3::Y,
            ng: Vec3::Y,
            wo: Vec3::Y,
            uv: [Vec2::ZERO; 2],
            // A mesh's colour attributes are not defined inside its volume: 0, as Cycles reads
            // an attribute it does not find.
            color: Vec4::ZERO,
            tangent: Vec4::ZERO,
            backfacing: false,
            object: &self.object,
            textures: &self.volume.textures,
            mesh: &crate::scene::mesh::EMPTY_MESH,
            tri: 0,
            bary: Vec2::ZERO,
            // The Light Path node in a volume is not modelled: read as a camera ray's.
            path: LightPath::CAMERA_RAY,
            view: &NO_VIEW,
            rays: crate::shader::geom::Rays::default(),
            point: None,
        }
    }

    /// The shader's inputs at world point `p` (glTF axes), as a Principled Volume with
    /// constant fields.
    #[inline]
    pub fn shader_at(&self, p: Vec3) -> VolumeShader {
        let g = self.geom(p);
        let prog = &self.volume.program;
        let r = &self.volume.regs;
        with_registers(|regs| {
            let mut sink = Closures::default();
            prog.run(&g, regs, &mut sink);
            let f = |i: u32| regs[i as usize];
            let v = |i: u32| Vec3::new(regs[i as usize], regs[i as usize + 1], regs[i as usize + 2]);
            let (density, color, absorption_color) = match self.volume.kind {
                VolumeKind::Principled => (f(r.density), v(r.color), v(r.absorption_color)),
                // σa = max(1 − c, 0)·max(1 − √a, 0)·d: a = 1 removes absorption.
                VolumeKind::Scatter => (f(r.density), v(r.color), Vec3::ONE),
                // c = 0 scatters nothing; a = Color² makes 1 − √a = 1 − Color.
                VolumeKind::Absorption => {
                    let c = v(r.color).max(Vec3::ZERO);
                    (f(r.density), Vec3::ZERO, c * c)
                }
                VolumeKind::Emission => (0.0, Vec3::ZERO, Vec3::ZERO),
            };
            VolumeShader {
                density,
                color,
                absorption_color,
                anisotropy: self.volume.anisotropy,
                emission: v(r.emission_color).max(Vec3::ZERO) * f(r.emission_strength).max(0.0),
                blackbody_intensity: f(r.blackbody_intensity).max(0.0),
                blackbody_tint: v(r.blackbody_tint).max(Vec3::ZERO),
                temperature: f(r.temperature),
            }
        })
    }

    /// The phase function's anisotropy at world point `p` (a scattering point): the graph's
    /// value there when a linked Anisotropy varies, else the shader's own.
    #[inline]
    pub fn anisotropy_at(&self, p: Vec3) -> f32 {
        let Some(reg) = self.volume.anisotropy_reg else {
            return self.volume.anisotropy;
        };
        let g = self.geom(p);
        with_registers(|regs| {
            self.volume.program.run(&g, regs, &mut Closures::default());
            regs[reg as usize]
        })
    }

    /// The coefficients at world point `p` (emission only when `with_emission`): Cycles'
    /// Principled Volume (`svm_node_principled_volume`) for the shader's values there.
    #[inline]
    pub fn coefficients(&self, p: Vec3, with_emission: bool) -> PointCoefficients {
        let sh = self.shader_at(p);
        let d = sh.density.max(0.0);
        let (mut sigma_a, mut sigma_s) = (Rgb::ZERO, Rgb::ZERO);
        if d > CLOSURE_WEIGHT_CUTOFF {
            let col = sh.color.max(Rgb::ZERO);
            let absorption = (Rgb::ONE - sh.absorption_color.max(Rgb::ZERO).map(f32::sqrt)).max(Rgb::ZERO);
            sigma_s = col * d;
            sigma_a = (Rgb::ONE - col).max(Rgb::ZERO) * absorption * d;
        }
        if !with_emission {
            return PointCoefficients { sigma_a, sigma_s, emission: Rgb::ZERO };
        }
        let mut emission = if sh.emission.max_element() > CLOSURE_WEIGHT_CUTOFF { sh.emission } else { Rgb::ZERO };
        emission += blackbody_emission(sh.temperature.max(0.0), sh.blackbody_intensity, sh.blackbody_tint);
        PointCoefficients { sigma_a, sigma_s, emission }
    }
}
