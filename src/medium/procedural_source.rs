//! The node-graph volume's shader at a point (`procedural.rs` builds the medium around it):
//! the compiled [`VolumeProgram`] run in the thread's register file, read as a Principled
//! Volume, and Cycles' coefficients from it.

use super::blackbody::{CLOSURE_WEIGHT_CUTOFF, blackbody_emission};
use super::coefficients::PointCoefficients;
use super::{HomogeneousMedium, Phase};
use crate::math::Rgb;
use crate::scene::light_path::LightPath;
use crate::scene::mesh::AttributeValue;
use crate::shader::closure::Closures;
use crate::shader::compile::volume::{VolumeKind, VolumeProgram, VolumeRegs};
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
    /// A volume object's grids, which its Attribute nodes read by name (`volume_grids.rs`);
    /// None for a mesh's or the world's volume.
    pub grids: Option<super::volume_grids::VolumeGrids>,
}

impl ProceduralSource {
    /// The shading point the program sees at world point `p` (glTF axes), reading `grid_values`
    /// for its attributes when given (a volume object's voxel).
    #[inline]
    fn geom<'a>(&'a self, p: Vec3, grid_values: Option<&'a [Option<AttributeValue>]>) -> Geom<'a> {
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
            curve: None,
            grid_values,
        }
    }

    /// The phase function's anisotropy at world point `p` (a scattering point): the graph's
    /// value there when a linked Anisotropy varies, else the shader's own.
    #[inline]
    pub fn anisotropy_at(&self, p: Vec3) -> f32 {
        let Some(reg) = self.volume.anisotropy_reg else {
            return self.volume.anisotropy;
        };
        let run = |values: Option<&[Option<AttributeValue>]>| {
            let g = self.geom(p, values);
            with_registers(|regs| {
                self.volume.program.run(&g, regs, &mut Closures::default());
                regs[reg as usize]
            })
        };
        // A volume object's: the nearest voxel's (Cycles' stochastic lookup picks one voxel).
        match &self.grids {
            Some(grids) => grids.nearest(p, |v| run(Some(v))),
            None => run(None),
        }
    }

    /// The coefficients at world point `p` (emission only when `with_emission`): each
    /// volume shader's as Cycles' SVM builds them (`svm_node_principled_volume`,
    /// `svm_node_closure_volume`, `svm_node_volume_coefficients`, the volume's Emission)
    /// for its inputs' values there, summed by the shaders' weights.
    /// A volume object's are the blend of those at the voxels around `p` by their trilinear
    /// weights (`volume_grids.rs`).
    #[inline]
    pub fn coefficients(&self, p: Vec3, with_emission: bool) -> PointCoefficients {
        let Some(grids) = &self.grids else {
            return self.coefficients_with(p, None, with_emission);
        };
        let mut total = PointCoefficients { sigma_a: Rgb::ZERO, sigma_s: Rgb::ZERO, emission: Rgb::ZERO };
        grids.each_corner(p, |w, values| {
            let c = self.coefficients_with(p, Some(values), with_emission);
            total.sigma_a += c.sigma_a * w;
            total.sigma_s += c.sigma_s * w;
            total.emission += c.emission * w;
        });
        total
    }

    /// The coefficients at world point `p` with the attributes `grid_values` (a voxel's), or
    /// the mesh's where None.
    #[inline]
    pub fn coefficients_with(
        &self,
        p: Vec3,
        grid_values: Option<&[Option<AttributeValue>]>,
        with_emission: bool,
    ) -> PointCoefficients {
        let g = self.geom(p, grid_values);
        let prog = &self.volume.program;
        with_registers(|regs| {
            let mut sink = Closures::default();
            prog.run(&g, regs, &mut sink);
            let mut total = PointCoefficients { sigma_a: Rgb::ZERO, sigma_s: Rgb::ZERO, emission: Rgb::ZERO };
            for cl in &self.volume.closures {
                let w = cl.weight.map_or(1.0, |w| regs[w as usize]);
                if w == 0.0 {
                    continue;
                }
                closure_coefficients(cl.kind, &cl.regs, w, regs, with_emission, &prog.space, &mut total);
            }
            total
        })
    }
}

impl ProceduralSource {
    /// The phase function at world point `p` where the tree pairs two Henyey-Greenstein
    /// lobes (`VolumeProgram::phase_pair`): each weighted by its scattering there (the mean
    /// over the colour channels; Cycles weighs them per channel); else the medium's.
    #[inline]
    pub fn phase_at(&self, p: Vec3) -> Phase {
        let Some((a, b)) = self.volume.phase_pair else {
            return self.volume.phase;
        };
        let run = |values: Option<&[Option<AttributeValue>]>| {
            let g = self.geom(p, values);
            with_registers(|regs| {
                self.volume.program.run(&g, regs, &mut Closures::default());
                pair_weight(&self.volume, regs, a, b)
            })
        };
        // A volume object's: the nearest voxel's, as `anisotropy_at`.
        let w2 = match &self.grids {
            Some(grids) => grids.nearest(p, |v| run(Some(v))),
            None => run(None),
        };
        self.volume.phase.with_pair_weight(w2)
    }
}

/// The second lobe's share of the scattering of closures `a` and `b` (`regs` after the
/// program ran); an even split where neither scatters.
fn pair_weight(volume: &VolumeProgram, regs: &[f32], a: usize, b: usize) -> f32 {
    let scattering = |k: usize| {
        let cl = &volume.closures[k];
        let w = cl.weight.map_or(1.0, |w| regs[w as usize]);
        let mut c = PointCoefficients { sigma_a: Rgb::ZERO, sigma_s: Rgb::ZERO, emission: Rgb::ZERO };
        closure_coefficients(cl.kind, &cl.regs, w, regs, false, &volume.program.space, &mut c);
        c.sigma_s.element_sum()
    };
    let (sa, sb) = (scattering(a), scattering(b));
    if sa + sb > 0.0 { sb / (sa + sb) } else { 0.5 }
}

/// Adds one volume shader's coefficients, weighted by `w`, to `total` (`regs` after the
/// program ran; a blackbody's colour in `space`).
#[inline]
fn closure_coefficients(
    kind: VolumeKind,
    r: &VolumeRegs,
    w: f32,
    regs: &[f32],
    with_emission: bool,
    space: &crate::scene::working_space::WorkingSpace,
    total: &mut PointCoefficients,
) {
    let f = |i: u32| regs[i as usize];
    let v = |i: u32| Vec3::new(regs[i as usize], regs[i as usize + 1], regs[i as usize + 2]);
    match kind {
        VolumeKind::Principled | VolumeKind::Scatter | VolumeKind::Absorption => {
            let d = w * f(r.density).max(0.0);
            if d > CLOSURE_WEIGHT_CUTOFF {
                let col = v(r.color).max(Rgb::ZERO);
                match kind {
                    VolumeKind::Principled => {
                        let absorption =
                            (Rgb::ONE - v(r.absorption_color).max(Rgb::ZERO).map(f32::sqrt)).max(Rgb::ZERO);
                        total.sigma_s += col * d;
                        total.sigma_a += (Rgb::ONE - col).max(Rgb::ZERO) * absorption * d;
                    }
                    VolumeKind::Scatter => total.sigma_s += col * d,
                    _ => total.sigma_a += (Rgb::ONE - col).max(Rgb::ZERO) * d,
                }
            }
        }
        VolumeKind::Coefficients => {
            // Cycles reads the coefficients as given; negative ones would make the
            // extinction negative, which no tracker samples: they count as 0.
            total.sigma_s += v(r.color).max(Rgb::ZERO) * w;
            total.sigma_a += v(r.absorption_color).max(Rgb::ZERO) * w;
        }
        VolumeKind::Emission => {}
    }
    if !with_emission {
        return;
    }
    let e = v(r.emission_color).max(Rgb::ZERO) * f(r.emission_strength).max(0.0);
    if e.max_element() > CLOSURE_WEIGHT_CUTOFF {
        total.emission += e * w;
    }
    if kind == VolumeKind::Principled {
        let t = f(r.temperature).max(0.0);
        let bb = blackbody_emission(t, f(r.blackbody_intensity).max(0.0), v(r.blackbody_tint).max(Rgb::ZERO), space);
        total.emission += bb * w;
    }
}
/// The homogeneous medium of a volume program whose coefficients are the same everywhere
/// (`VolumeProgram::constant`: a tree of constant shaders and Mix factors), so that it is
/// tracked in closed form rather than against a sampled majorant; else the program back.
pub fn constant_medium(volume: Box<VolumeProgram>) -> Result<HomogeneousMedium, Box<VolumeProgram>> {
    if !volume.constant {
        return Err(volume);
    }
    let source = ProceduralSource { volume: *volume, object: crate::shader::geom::NO_OBJECT, grids: None };
    let c = source.coefficients(Vec3::ZERO, true);
    Ok(HomogeneousMedium {
        sigma_a: c.sigma_a,
        sigma_s: c.sigma_s,
        phase: source.phase_at(Vec3::ZERO),
        emission: c.emission,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader::compile::volume::compile_volume;
    use crate::shader::graph::NodesExt;
    use serde_json::json;

    /// Cycles' coefficients of a Mix Shader (factor 0.25) of a Volume Scatter + Volume
    /// Absorption pair and a Principled Volume that emits, worked by hand from
    /// `svm_node_closure_volume` / `svm_node_principled_volume`: a constant tree is one
    /// homogeneous medium with their weighted sum, and a Volume Coefficients node gives its
    /// coefficients as they are.
    #[test]
    fn a_constant_tree_sums_its_shaders() {
        let ext: NodesExt = serde_json::from_value(json!({"version": 1, "nodes": [
            {"name": "S", "type": "ShaderNodeVolumeScatter",
             "inputs": {"Density": {"value": 2.0}, "Color": {"value": [0.5, 0.25, 1.0, 1.0]}, "Anisotropy": {"value": 0.3}}},
            {"name": "A", "type": "ShaderNodeVolumeAbsorption",
             "inputs": {"Density": {"value": 3.0}, "Color": {"value": [0.8, 0.6, 0.0, 1.0]}}},
            {"name": "Add", "type": "ShaderNodeAddShader",
             "inputs": {"Shader": {"link": [0, "Volume"]}, "Shader_001": {"link": [1, "Volume"]}}},
            {"name": "P", "type": "ShaderNodeVolumePrincipled",
             "inputs": {"Density": {"value": 4.0}, "Color": {"value": [0.5, 0.5, 0.5, 1.0]},
                        "Absorption Color": {"value": [0.25, 0.25, 0.25, 1.0]}, "Anisotropy": {"value": 0.3},
                        "Emission Strength": {"value": 2.0}, "Emission Color": {"value": [1.0, 0.5, 0.0, 1.0]}}},
            {"name": "Mix", "type": "ShaderNodeMixShader",
             "inputs": {"Fac": {"value": 0.25}, "Shader": {"link": [2, "Shader"]}, "Shader_001": {"link": [3, "Volume"]}}}],
            "output": {}}))
        .unwrap();
        let v = compile_volume("m", &ext, 4, &[], Default::default()).unwrap();
        assert!(v.warnings.is_empty(), "{:?}", v.warnings);
        let h = constant_medium(Box::new(v)).expect("a constant tree");
        // Weights 0.75 (the pair) and 0.25 (Principled).
        let sigma_s = Vec3::new(0.5, 0.25, 1.0) * 2.0 * 0.75 + Vec3::splat(0.5) * 4.0 * 0.25;
        let sigma_a = (Vec3::ONE - Vec3::new(0.8, 0.6, 0.0)) * 3.0 * 0.75 + Vec3::splat(0.5 * 0.5) * 4.0 * 0.25;
        let emission = Vec3::new(1.0, 0.5, 0.0) * 2.0 * 0.25;
        assert!((h.sigma_s - sigma_s).abs().max_element() < 1e-6, "{} vs {sigma_s}", h.sigma_s);
        assert!((h.sigma_a - sigma_a).abs().max_element() < 1e-6, "{} vs {sigma_a}", h.sigma_a);
        assert!((h.emission - emission).abs().max_element() < 1e-6, "{} vs {emission}", h.emission);
        assert_eq!(h.phase, crate::medium::Phase::hg(0.3));

        let coeffs: NodesExt = serde_json::from_value(json!({"version": 1, "nodes": [
            {"name": "C", "type": "ShaderNodeVolumeCoefficients", "props": {"phase": "RAYLEIGH"},
             "inputs": {"Absorption Coefficients": {"value": [0.1, 0.2, 0.3]},
                        "Scatter Coefficients": {"value": [1.0, 2.0, 3.0]},
                        "Emission Coefficients": {"value": [0.0, 0.5, 0.0]}}}],
            "output": {}}))
        .unwrap();
        let h = constant_medium(Box::new(compile_volume("c", &coeffs, 0, &[], Default::default()).unwrap()))
            .expect("constant");
        assert_eq!(
            (h.sigma_a, h.sigma_s, h.emission),
            (Vec3::new(0.1, 0.2, 0.3), Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.0, 0.5, 0.0))
        );
        assert_eq!(h.phase, crate::medium::Phase::Rayleigh);

        // Two Henyey-Greenstein scatterers (a dual-lobe cloud): the lobes weighted by their
        // scattering, σs 2·0.5 = 1 (mean) against 1·(0.2 + 0.4 + 0.6)/3 = 0.4.
        let pair: NodesExt = serde_json::from_value(json!({"version": 1, "nodes": [
            {"name": "F", "type": "ShaderNodeVolumeScatter",
             "inputs": {"Density": {"value": 2.0}, "Color": {"value": [0.5, 0.5, 0.5, 1.0]}, "Anisotropy": {"value": 0.7}}},
            {"name": "B", "type": "ShaderNodeVolumeScatter",
             "inputs": {"Density": {"value": 1.0}, "Color": {"value": [0.2, 0.4, 0.6, 1.0]}, "Anisotropy": {"value": -0.3}}},
            {"name": "Add", "type": "ShaderNodeAddShader",
             "inputs": {"Shader": {"link": [0, "Volume"]}, "Shader_001": {"link": [1, "Volume"]}}}],
            "output": {}}))
        .unwrap();
        let h = constant_medium(Box::new(compile_volume("p", &pair, 2, &[], Default::default()).unwrap()))
            .expect("constant");
        let Phase::HgPair { g1, g2, w2 } = h.phase else { panic!("{:?}", h.phase) };
        assert!((g1 - 0.7).abs() < 1e-6 && (g2 + 0.3).abs() < 1e-6 && (w2 - 0.4 / 1.4).abs() < 1e-6, "{:?}", h.phase);
    }
}
