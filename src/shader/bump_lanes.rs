//! The Bump node's three heights (at the point and at its two offsets) as lanes of one pass.
//!
//! `Program::bump` re-runs the height's operations at the two offset points after the
//! centre run: three passes of the same operations, 10⁻⁴ apart. Here the program's first
//! Bump (when its height holds no other Bump) is run in lane form instead: from the first
//! operation of its height on, each height operation runs for the centre in the register
//! file and for the two offsets in two copies of it, one operation after the other, so an
//! operation with a lane form (`lane_step`: the 3-D fBm Noise texture) does the three
//! points' work together; every other operation runs once per lane, the same call as in
//! `Program::bump`. Each lane computes what the scalar passes compute (bit for bit: the
//! lane forms are tested against the scalar code), so images do not change.
//!
//! What an offset lane starts from: the height's operations read only constants and each
//! other's results (a node's operations, conversions included, lie in its own range, and
//! `upstream_ranges` takes every node above the height), so a copy of the file at the first
//! height operation is what `Program::bump`'s copy at the Bump holds for them.

use super::closure::Closures;
use super::geom::{Geom, v3};
use super::instructions::{LaneBump, Op, Program};
use super::ops;
use super::program::bump_offsets;
use super::texture::noise::{NoiseKind, NoiseParams};
use super::texture::noise_lanes::noise_fbm_3d_lanes;
use super::texture::voronoi_texture_lanes;
use super::texture_nodes::{TexOp, set_voronoi, voronoi_params};
use std::cell::RefCell;

thread_local! {
    /// The two offset lanes' register files, one after the other.
    static LANES: RefCell<Vec<f32>> = const { RefCell::new(Vec::new()) };
}

impl Program {
    /// The surface's operations `ops[..end]` with the lane-form Bump `l`.
    pub(super) fn run_lanes(&self, l: &LaneBump, g: &Geom, r: &mut [f32], out: &mut Closures, end: usize) {
        let Op::Bump(b) = &self.ops[l.at] else {
            return self.steps(&self.ops[..end], g, r, out);
        };
        self.steps(&self.ops[..l.start], g, r, out);
        let Some(off) = bump_offsets(g, b.filter_width) else {
            // A degenerate triangle: the height at the centre only, as `Program::bump`.
            return self.steps(&self.ops[l.start..end], g, r, out);
        };
        let h = LANES.with(|lanes| {
            let Ok(mut lanes) = lanes.try_borrow_mut() else { return None };
            let n = r.len();
            lanes.clear();
            lanes.extend_from_slice(r);
            lanes.extend_from_slice(r);
            let (la, lb) = lanes.split_at_mut(n);
            let gs = [g, &off.geom[0], &off.geom[1]];
            for &(a, z, height) in &l.runs {
                if height {
                    for op in &self.ops[a..z] {
                        self.lane_step(op, gs, [&mut *r, &mut *la, &mut *lb], out);
                    }
                } else {
                    self.steps(&self.ops[a..z], g, r, out);
                }
            }
            Some([la[b.height as usize], lb[b.height as usize]])
        });
        match h {
            Some(h) => self.bump_finish(b, g, r, Some((off.d, h))),
            // The lanes' files are in use (cannot happen: evaluation does not recurse).
            None => {
                self.steps(&self.ops[l.start..l.at], g, r, out);
                self.step(&self.ops[l.at], g, r, out);
            }
        }
        self.steps(&self.ops[l.at + 1..end], g, r, out);
    }

    /// One height operation at the three points `g` in the files `r`: the Math node inline
    /// (as `steps` has it), the lane forms, and one `dispatch` per lane for the rest.
    #[inline]
    fn lane_step(&self, op: &Op, g: [&Geom; 3], r: [&mut [f32]; 3], out: &mut Closures) {
        if let Op::Math { op, a, b, c, out, clamp } = *op {
            let at = |k: u32| [r[0][k as usize], r[1][k as usize], r[2][k as usize]];
            let v = ops::math_lanes(op, at(a), at(b), at(c));
            for (file, v) in r.into_iter().zip(v) {
                file[out as usize] = if clamp { v.clamp(0.0, 1.0) } else { v };
            }
            return;
        }
        if let Op::Texture(t) = op
            && let TexOp::Noise { dims: 3, kind: NoiseKind::Fbm, normalize, inputs: i, fac, color: None } = **t
            && same_settings(&r, &i[2..])
        {
            let f = |k: usize| r[0][i[k] as usize];
            let prm = NoiseParams {
                dims: 3,
                kind: NoiseKind::Fbm,
                normalize,
                scale: f(2),
                detail: f(3),
                roughness: f(4),
                lacunarity: f(5),
                offset: f(6),
                gain: f(7),
                distortion: f(8),
            };
            let p = [v3(r[0], i[0]), v3(r[1], i[0]), v3(r[2], i[0])];
            let v = noise_fbm_3d_lanes(p, &prm);
            for (file, v) in r.into_iter().zip(v) {
                file[fac as usize] = v;
            }
            return;
        }
        if let Op::Texture(t) = op
            && let TexOp::Voronoi { dims: 3, feature, metric, normalize, color, inputs: i, outputs: o } = **t
            && same_settings(&r, &i[2..])
        {
            let prm = voronoi_params(3, feature, metric, normalize, &i, r[0]);
            let p = [v3(r[0], i[0]), v3(r[1], i[0]), v3(r[2], i[0])];
            let w = [r[0][i[1] as usize], r[1][i[1] as usize], r[2][i[1] as usize]];
            let v = voronoi_texture_lanes(p, w, &prm, color);
            for (file, v) in r.into_iter().zip(&v) {
                set_voronoi(file, &o, v);
            }
            return;
        }
        for (file, g) in r.into_iter().zip(g) {
            self.dispatch(op, g, file, out);
        }
    }
}

/// Whether registers `regs` hold the same bits in the three files: a lane form needs the
/// node's settings alike at the three points (they are constants or position-independent
/// links nearly always; otherwise each lane runs alone).
#[inline]
fn same_settings(r: &[&mut [f32]; 3], regs: &[u32]) -> bool {
    regs.iter().all(|&k| {
        let k = k as usize;
        r[0][k].to_bits() == r[1][k].to_bits() && r[0][k].to_bits() == r[2][k].to_bits()
    })
}

#[cfg(test)]
mod tests {
    use super::super::compile::compile;
    use super::super::geom::{ObjectData, geom_at};
    use super::super::graph::NodesExt;
    use crate::scene::mesh::Mesh;
    use glam::{Vec2, Vec3, Vec4};
    use serde_json::{Value, json};

    /// One triangle, tilted and away from the origin (so the Bump's offsets are not along the
    /// axes), with every attribute `geom_at` reads.
    fn triangle() -> Mesh {
        let positions = vec![Vec3::new(-2.0, -1.0, 0.5), Vec3::new(3.0, -1.5, 1.0), Vec3::new(0.5, 2.5, -0.5)];
        let n = (positions[1] - positions[0]).cross(positions[2] - positions[0]).normalize();
        Mesh {
            positions,
            normals: vec![n, (n + Vec3::X * 0.1).normalize(), (n - Vec3::Y * 0.1).normalize()],
            tangents: vec![Vec4::new(1.0, 0.0, 0.0, 1.0); 3],
            uv0: vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)],
            uv1: vec![Vec2::ZERO; 3],
            colors: vec![Vec4::ONE; 3],
            triangles: vec![[0, 1, 2]],
            tri_material: vec![0],
            tri_object: vec![0],
            undisplaced: Vec::new(),
            attributes: Vec::new(),
        }
    }

    /// The graph's register file after a run with its lane-form Bump equals the one after a
    /// run with `Program::bump`'s three passes, bit for bit, at many points; returns how many
    /// points' bumped normals differ from the unbumped one (so that the test sees a bump).
    fn lanes_match_passes(nodes: Value, expect_lanes: bool) -> usize {
        let ext: NodesExt =
            serde_json::from_value(json!({"version": 1, "nodes": nodes, "output": {"surface": [0, "BSDF"]}})).unwrap();
        let lanes = compile("m", &ext, &[]).unwrap().program;
        assert_eq!(lanes.lane_bump.is_some(), expect_lanes);
        // A Bump reads the footprint: the camera must compute it (`CameraRays::with_footprints`).
        assert!(lanes.reads_footprint());
        let mut passes = lanes.clone();
        passes.lane_bump = None;
        let mesh = triangle();
        let objects = [ObjectData::default()];
        let mut tilted = 0;
        for i in 0..400 {
            let (b1, b2) = ((i % 20) as f32 / 21.0 + 0.01, (i / 20) as f32 / 23.0 * 0.95);
            if b1 + b2 >= 1.0 {
                continue;
            }
            let g = geom_at(&mesh, &objects, &[], 0, b1, b2);
            let run = |p: &super::super::instructions::Program| {
                let (mut r, mut out) = (Vec::new(), super::super::closure::Closures::default());
                p.run(&g, &mut r, &mut out);
                (r, out.normal)
            };
            let (a, na) = run(&lanes);
            let (b, nb) = run(&passes);
            assert_eq!(
                a.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                b.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
            );
            assert_eq!(na.map(|n| n.to_array().map(f32::to_bits)), nb.map(|n| n.to_array().map(f32::to_bits)));
            let n = na.expect("the Principled BSDF's Normal is linked");
            // A bumped normal moves by far more than f32 rounding of a unit vector (1e-7).
            tilted += ((n - super::super::geom::to_blender(g.n)).length() > 1e-4) as usize;
        }
        tilted
    }

    /// A graph without a Bump does not read the footprint: its camera rays skip it.
    #[test]
    fn no_bump_no_footprint() {
        let nodes = json!([
            {"name": "bsdf", "type": "ShaderNodeBsdfPrincipled", "inputs": {"Roughness": {"link": [1, "Fac"]}}},
            {"name": "noise", "type": "ShaderNodeTexNoise"}
        ]);
        let ext: NodesExt =
            serde_json::from_value(json!({"version": 1, "nodes": nodes, "output": {"surface": [0, "BSDF"]}})).unwrap();
        assert!(!compile("m", &ext, &[]).unwrap().program.reads_footprint());
    }

    /// The 3-D fBm Noise with distortion (its lane form) and a Voronoi and Math chain (one
    /// dispatch per lane) as the height, as in `bench/node_graph.py`.
    #[test]
    fn noise_voronoi_math_height() {
        let nodes = json!([
            {"name": "bsdf", "type": "ShaderNodeBsdfPrincipled", "inputs": {"Normal": {"link": [5, "Normal"]}}},
            {"name": "tc", "type": "ShaderNodeTexCoord"},
            {"name": "noise", "type": "ShaderNodeTexNoise", "props": {"noise_dimensions": "3D", "noise_type": "FBM"},
             "inputs": {"Vector": {"link": [1, "Object"]}, "Scale": {"value": 5.0}, "Detail": {"value": 3.5},
                        "Distortion": {"value": 0.3}}},
            {"name": "vor", "type": "ShaderNodeTexVoronoi", "inputs": {"Vector": {"link": [1, "Object"]}, "Scale": {"value": 4.0}}},
            {"name": "pow", "type": "ShaderNodeMath", "props": {"operation": "POWER"},
             "inputs": {"Value": {"link": [2, "Fac"]}, "Value_001": {"link": [3, "Distance"]}}},
            {"name": "bump", "type": "ShaderNodeBump", "inputs": {"Strength": {"value": 0.8}, "Distance": {"value": 0.1},
             "Height": {"link": [4, "Value"]}}}
        ]);
        assert!(lanes_match_passes(nodes, true) > 100);
    }

    /// A Noise whose Scale depends on the point (its lanes differ: each lane runs alone) and
    /// a colour height (its conversion to a float belongs to the height).
    #[test]
    fn point_dependent_settings_and_a_colour_height() {
        let nodes = json!([
            {"name": "bsdf", "type": "ShaderNodeBsdfPrincipled", "inputs": {"Normal": {"link": [4, "Normal"]}}},
            {"name": "tc", "type": "ShaderNodeTexCoord"},
            {"name": "sep", "type": "ShaderNodeSeparateXYZ", "inputs": {"Vector": {"link": [1, "Object"]}}},
            {"name": "noise", "type": "ShaderNodeTexNoise", "props": {"noise_dimensions": "3D", "noise_type": "FBM"},
             "inputs": {"Vector": {"link": [1, "Object"]}, "Scale": {"link": [2, "X"]}}},
            {"name": "bump", "type": "ShaderNodeBump", "inputs": {"Distance": {"value": 0.5},
             "Height": {"link": [3, "Color"]}}}
        ]);
        assert!(lanes_match_passes(nodes, true) > 100);
    }

    /// A Bump whose height reads another Bump: the inner one (first in order) takes the
    /// lanes, the outer one the passes, whose re-runs hold the inner one.
    #[test]
    fn nested_bumps() {
        let nodes = json!([
            {"name": "bsdf", "type": "ShaderNodeBsdfPrincipled", "inputs": {"Normal": {"link": [5, "Normal"]}}},
            {"name": "tc", "type": "ShaderNodeTexCoord"},
            {"name": "noise", "type": "ShaderNodeTexNoise", "props": {"noise_dimensions": "3D"},
             "inputs": {"Vector": {"link": [1, "Object"]}, "Scale": {"value": 3.0}}},
            {"name": "inner", "type": "ShaderNodeBump", "inputs": {"Height": {"link": [2, "Fac"]}}},
            {"name": "dot", "type": "ShaderNodeVectorMath", "props": {"operation": "DOT_PRODUCT"},
             "inputs": {"Vector": {"link": [3, "Normal"]}, "Vector_001": {"link": [1, "Object"]}}},
            {"name": "outer", "type": "ShaderNodeBump", "inputs": {"Height": {"link": [4, "Value"]}}}
        ]);
        assert!(lanes_match_passes(nodes, true) > 100);
    }
}
