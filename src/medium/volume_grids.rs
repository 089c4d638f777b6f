//! A volume object whose material is a node graph (an Attribute "density" through Math or a
//! ColorRamp, a Scatter + Absorption tree, a "flame" grid on the Emission Strength): the
//! object's grids are the attributes the graph reads by name, as Cycles' Attribute node reads
//! a volume object's grids. The graph runs in `procedural_source.rs`; this file holds the
//! grids and the medium's majorant.
//!
//! Cycles looks a grid up stochastically (one voxel, picked with its trilinear weight), so the
//! mean of its coefficients at a point is the trilinear blend of the graph's coefficients at
//! the eight voxels around it, not the graph's at the blended values (a ColorRamp or Math of
//! the density is not linear). The graph is run here once per voxel with a weight, the eight
//! results blended: the same mean, without Cycles' noise.
//!
//! The majorant: where the graph reads nothing but the grids (no texture, no coordinate:
//! [`reads_only_grids`]), the coefficients at a point are a convex blend of the graph at the
//! voxels whose trilinear support reaches it, so the largest σt over those voxels, run once
//! each, bounds every point of a cell exactly ([`voxel_majorant`]); a graph that also reads the
//! position gets the procedural media's sampled majorant (`procedural.rs`), with whose
//! overshoot the trackers stay unbiased.

use super::coefficients::VolumeShader;
use super::grid::{CELL, Field, GridMedium};
use super::procedural_source::ProceduralSource;
use crate::math::Rgb;
use crate::scene::mesh::AttributeValue;
use crate::shader::graph::NodesExt;
use glam::{Affine3A, Vec3};
use rayon::prelude::*;

/// The most attributes a volume object's graph reads (one slot per name; the values of one
/// voxel live on the stack while the graph runs).
pub const MAX_GRID_SLOTS: usize = 16;

/// Relative allowance on the voxel bound for rounding: the eight trilinear weights sum to 1
/// within a few ulps, and the blend's sum rounds within 8 ulps of its largest term.
const ROUNDING: f32 = 1e-5;

/// Node types whose outputs depend only on their inputs (or are constants): a graph of these
/// and Attribute nodes is a function of the voxel values alone.
const GRID_ONLY_NODES: &[&str] = &[
    "ShaderNodeAttribute",
    "ShaderNodeMath",
    "ShaderNodeVectorMath",
    "ShaderNodeValToRGB",
    "ShaderNodeMapRange",
    "ShaderNodeClamp",
    "ShaderNodeMix",
    "ShaderNodeMixRGB",
    "ShaderNodeValue",
    "ShaderNodeRGB",
    "ShaderNodeBlackbody",
    "ShaderNodeWavelength",
    "ShaderNodeCombineXYZ",
    "ShaderNodeSeparateXYZ",
    "ShaderNodeCombineColor",
    "ShaderNodeSeparateColor",
    "ShaderNodeCombineRGB",
    "ShaderNodeSeparateRGB",
    "ShaderNodeInvert",
    "ShaderNodeGamma",
    "ShaderNodeBrightContrast",
    "ShaderNodeHueSaturation",
    "ShaderNodeRGBToBW",
    "ShaderNodeFloatCurve",
    "ShaderNodeRGBCurve",
    "ShaderNodeVolumePrincipled",
    "ShaderNodeVolumeScatter",
    "ShaderNodeVolumeAbsorption",
    "ShaderNodeVolumeCoefficients",
    "ShaderNodeEmission",
    "ShaderNodeAddShader",
    "ShaderNodeMixShader",
];

/// Whether every node of `graph` is a function of its inputs alone ([`GRID_ONLY_NODES`]).
pub fn reads_only_grids(graph: &NodesExt) -> bool {
    graph.nodes.iter().all(|n| GRID_ONLY_NODES.contains(&n.kind.as_str()))
}

/// A volume object's grids as its graph's attribute slots read them.
#[derive(Clone, Debug)]
pub struct VolumeGrids {
    /// Voxels per axis (every grid shares them).
    pub dims: [u32; 3],
    /// World → index space (voxel centres at integers).
    pub index_from_world: Affine3A,
    /// Per attribute slot of the program (`Program::attributes`): its grid, None where the
    /// object has no grid of that name (Cycles' not-found value then).
    pub slots: Vec<Option<Field>>,
}

/// One voxel's attribute values, one per slot.
type Values = [Option<AttributeValue>; MAX_GRID_SLOTS];

impl VolumeGrids {
    /// The attribute values at voxel `v` (zero outside the grid, where the grids' background is).
    #[inline]
    fn values_at(&self, v: [i64; 3], out: &mut Values) {
        for (o, slot) in out.iter_mut().zip(&self.slots) {
            *o = slot.as_ref().map(|f| {
                if f.components == 3 {
                    let c = Vec3::from_array([0, 1, 2].map(|c| f.at(self.dims, v[0], v[1], v[2], c)));
                    // Cycles' Fac of a colour attribute is its average (`svm_node_attr`).
                    AttributeValue { vector: c, fac: (c.x + c.y + c.z) / 3.0, alpha: 1.0 }
                } else {
                    let x = f.at(self.dims, v[0], v[1], v[2], 0);
                    AttributeValue { vector: Vec3::splat(x), fac: x, alpha: 1.0 }
                }
            });
        }
    }

    /// Calls `f(weight, values)` for each voxel around world point `p` with a positive
    /// trilinear weight.
    #[inline]
    pub fn each_corner(&self, p: Vec3, mut f: impl FnMut(f32, &[Option<AttributeValue>])) {
        let q = self.index_from_world.transform_point3(p);
        let fl = q.floor();
        let t = q - fl;
        let base = [fl.x as i64, fl.y as i64, fl.z as i64];
        let mut values: Values = [None; MAX_GRID_SLOTS];
        for corner in 0..8 {
            let d = [corner & 1, corner >> 1 & 1, corner >> 2 & 1];
            let w = (0..3).map(|a| if d[a] == 1 { t[a] } else { 1.0 - t[a] }).product::<f32>();
            if w > 0.0 {
                self.values_at([0, 1, 2].map(|a| base[a] + d[a] as i64), &mut values);
                f(w, &values[..self.slots.len()]);
            }
        }
    }

    /// `f(values)` at the voxel nearest world point `p` (the largest of the trilinear weights).
    #[inline]
    pub fn nearest<R>(&self, p: Vec3, f: impl FnOnce(&[Option<AttributeValue>]) -> R) -> R {
        let q = self.index_from_world.transform_point3(p).round();
        let mut values: Values = [None; MAX_GRID_SLOTS];
        self.values_at([q.x as i64, q.y as i64, q.z as i64], &mut values);
        f(&values[..self.slots.len()])
    }

    /// `f(values)` at voxel `v`.
    #[inline]
    fn at_voxel<R>(&self, v: [i64; 3], f: impl FnOnce(&[Option<AttributeValue>]) -> R) -> R {
        let mut values: Values = [None; MAX_GRID_SLOTS];
        self.values_at(v, &mut values);
        f(&values[..self.slots.len()])
    }
}

/// The grid medium of volume object `name`: `dims` voxels placed by `world_from_index`, its
/// coefficients the graph of `source` (whose `grids` are the object's) at each point; the
/// majorant the voxel bound where `grid_only` (the graph reads nothing else), else sampled.
/// Err names the first voxel where the graph's extinction is not finite.
pub fn graph_grid_medium(
    name: String,
    dims: [u32; 3],
    world_from_index: Affine3A,
    source: ProceduralSource,
    grid_only: bool,
) -> Result<GridMedium, String> {
    let shader = VolumeShader {
        density: 1.0,
        color: Rgb::ONE,
        absorption_color: Rgb::ZERO,
        anisotropy: source.volume.anisotropy,
        emission: Rgb::ZERO,
        blackbody_intensity: 0.0,
        blackbody_tint: Rgb::ONE,
        temperature: 0.0,
    };
    let mut g = GridMedium::new(name, dims, world_from_index, [None, None, None], shader);
    g.phase = source.volume.phase;
    g.procedural = Some(Box::new(source));
    let (majorant, emits) = if grid_only { voxel_majorant(&g)? } else { super::procedural::sampled_majorant(&g) };
    g.majorant = majorant;
    if emits {
        // `may_emit` reads the shader: mark the medium as emitting somewhere.
        g.shader.emission = Rgb::ONE;
    }
    Ok(g)
}

/// Bytes [`voxel_majorant`] holds while it runs over a `dims` grid: one slab of CELL + 1
/// voxel layers (σt and the emission flag per voxel), charged by the loader.
pub fn majorant_scratch_bytes(dims: [u32; 3]) -> u64 {
    (dims[0] as u64 + 2) * (dims[1] as u64 + 2) * (CELL as u64 + 1) * std::mem::size_of::<(f32, bool)>() as u64
}

/// Whether every slot reads the grids' zero background at this voxel.
fn all_zero(values: &[Option<AttributeValue>]) -> bool {
    values.iter().flatten().all(|v| v.vector == Vec3::ZERO)
}

/// Per cell: the largest max-channel σt of the graph over the voxels whose trilinear support
/// reaches the cell (the voxels just outside the grid read its zero background), times
/// 1 + [`ROUNDING`]; raised to one expected collision per cell crossing where one of those
/// voxels emits, so that the tracking visits glowing space that does not attenuate (as
/// `GridMedium::build_majorant`). And whether any voxel emits.
///
/// Cost: the graph is a function of the voxel's values alone, so it runs once for every voxel
/// where all its grids read zero (a smoke's empty space, the ring of background voxels), and
/// once per other voxel, in parallel. The voxels are visited one slab of cell layers at a time
/// (CELL + 1 voxel layers, the top one kept as the next slab's bottom), so the scratch is
/// [`majorant_scratch_bytes`], not a value per voxel of the grid.
pub(super) fn voxel_majorant(g: &GridMedium) -> Result<(Vec<f32>, bool), String> {
    let src = g.procedural.as_deref().expect("a graph medium");
    let grids = src.grids.as_ref().expect("a volume object's grids");
    // Voxels −1 ..= dims along each axis: the domain's and one background voxel around it.
    let ext = g.dims.map(|d| d as usize + 2);
    let run = |v: [i64; 3], values: &[Option<AttributeValue>]| -> Result<(f32, bool), String> {
        let p = g.world_from_index.transform_point3(Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32));
        let c = src.coefficients_with(p, Some(values), true);
        let sigma = (c.sigma_a + c.sigma_s).max_element();
        if !sigma.is_finite() || !c.emission.is_finite() {
            let what =
                if sigma.is_finite() { format!("emission {}", c.emission) } else { format!("extinction {sigma}") };
            return Err(format!(
                "its graph gives a non-finite {what} at voxel {v:?} (grid values {:?}); Caustic cannot bound it",
                values.iter().map(|v| v.map(|v| v.vector)).collect::<Vec<_>>()
            ));
        }
        Ok((sigma.max(0.0), c.emission.abs().max_element() > 0.0))
    };
    let background = grids.at_voxel([-1, -1, -1], |values| run([-1, -1, -1], values))?;
    let layer = ext[0] * ext[1];
    let voxel = (0..3).map(|a| g.world_from_index.matrix3.col(a).length()).fold(f32::INFINITY, f32::min);
    let emission_floor = 1.0 / (CELL as f32 * voxel.max(1e-30));
    let [nx, ny, nz] = g.cells;
    let mut out = Vec::with_capacity((nx * ny * nz) as usize);
    let mut emits_anywhere = false;
    // Slab voxel layers 0..=CELL are index z = cz·CELL − 1 + 0..=CELL (clamped to the ring).
    let mut slab: Vec<(f32, bool)> = vec![(0.0, false); layer * (CELL as usize + 1)];
    for cz in 0..nz as usize {
        let z0 = cz * CELL as usize;
        let first = if cz == 0 { 0 } else { 1 };
        if cz > 0 {
            slab.copy_within(CELL as usize * layer.., 0);
        }
        // The last cell layer may start past the ring (no voxel reaches it: majorant 0).
        let layers = (CELL as usize + 1).min(ext[2].saturating_sub(z0));
        if layers > first {
            slab[first * layer..layers * layer].par_chunks_mut(ext[0]).enumerate().try_for_each(|(row, out)| {
                let (y, z) = (row % ext[1], z0 + first + row / ext[1]);
                for (x, o) in out.iter_mut().enumerate() {
                    let v = [x, y, z].map(|i| i as i64 - 1);
                    *o = grids.at_voxel(v, |values| if all_zero(values) { Ok(background) } else { run(v, values) })?;
                }
                Ok::<(), String>(())
            })?;
        }
        for cy in 0..ny as usize {
            for cx in 0..nx as usize {
                // Cell c spans index [c·CELL − 1, (c + 1)·CELL − 1]: its points blend voxels
                // in that range (a point on the upper face gives the next voxel weight 0).
                let lo = [cx * CELL as usize, cy * CELL as usize];
                let hi = [0, 1].map(|a| (lo[a] + CELL as usize).min(ext[a] - 1));
                let (mut m, mut emits) = (0.0f32, false);
                for z in 0..layers {
                    for y in lo[1]..=hi[1] {
                        for x in lo[0]..=hi[0] {
                            let (s, e) = slab[z * layer + y * ext[0] + x];
                            m = m.max(s);
                            emits |= e;
                        }
                    }
                }
                m *= 1.0 + ROUNDING;
                emits_anywhere |= emits;
                out.push(if emits { m.max(emission_floor) } else { m });
            }
        }
    }
    Ok((out, emits_anywhere))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader::compile::volume::compile_volume;
    use crate::shader::geom::NO_OBJECT;
    use serde_json::{Value, json};

    /// A medium over a `dims` grid of unit voxels at the origin whose graph is `nodes` (the
    /// shader the last node), its attributes read from `grids` by name.
    fn medium(nodes: Value, grids: &[(&str, Field)], dims: [u32; 3]) -> GridMedium {
        let ext: NodesExt = serde_json::from_value(json!({"version": 1, "nodes": nodes, "output": {}})).unwrap();
        let volume = compile_volume("m", &ext, ext.nodes.len() - 1, &[], Default::default()).unwrap();
        assert!(volume.warnings.is_empty(), "{:?}", volume.warnings);
        let slots = volume
            .program
            .attributes
            .iter()
            .map(|(key, _)| match key {
                crate::scene::mesh::AttributeKey::Named(n) => {
                    grids.iter().find(|(name, _)| name == n).map(|(_, f)| f.clone())
                }
                _ => None,
            })
            .collect();
        let world_from_index = Affine3A::IDENTITY;
        let grids = VolumeGrids { dims, index_from_world: world_from_index.inverse(), slots };
        let source = ProceduralSource { volume, object: NO_OBJECT, grids: Some(grids) };
        graph_grid_medium("m".into(), dims, world_from_index, source, reads_only_grids(&ext)).unwrap()
    }

    fn attribute(name: &str) -> Value {
        json!({"name": name, "type": "ShaderNodeAttribute",
               "props": {"attribute_name": name, "attribute_type": "GEOMETRY"}, "inputs": {}})
    }

    /// The Attribute node reads the grid of its name at each voxel: Attribute "density" →
    /// Math Power 2 → × 5 → Volume Scatter's Density gives 5 d² at a voxel centre, and between
    /// voxels the blend of the voxels' 5 d² (Cycles' stochastic lookup in the mean), not 5 ×
    /// the blended d squared; a colour grid read through Attribute's Color colours it, and a
    /// name the object has no grid of reads 0.
    #[test]
    fn the_attribute_node_reads_the_grids_by_name() {
        let density = Field { values: vec![0.0, 1.0, 3.0, 2.0], components: 1 };
        let colour = Field { values: vec![0.5, 0.25, 1.0, 1.0, 0.5, 0.0, 0.2, 0.2, 0.2, 0.0, 1.0, 0.0], components: 3 };
        let nodes = json!([
            attribute("density"),
            {"name": "Sq", "type": "ShaderNodeMath", "props": {"operation": "POWER"},
             "inputs": {"Value": {"value": 0.0, "link": [0, "Fac"]}, "Value_001": {"value": 2.0}}},
            {"name": "Mul", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
             "inputs": {"Value": {"value": 0.0, "link": [1, "Value"]}, "Value_001": {"value": 5.0}}},
            attribute("tint"),
            attribute("nothing"),
            {"name": "Add", "type": "ShaderNodeMath", "props": {"operation": "ADD"},
             "inputs": {"Value": {"value": 0.0, "link": [2, "Value"]}, "Value_001": {"value": 0.0, "link": [4, "Fac"]}}},
            {"name": "S", "type": "ShaderNodeVolumeScatter",
             "inputs": {"Density": {"value": 1.0, "link": [5, "Value"]}, "Color": {"value": [1.0, 1.0, 1.0, 1.0], "link": [3, "Color"]}}},
        ]);
        let g = medium(nodes, &[("density", density.clone()), ("tint", colour.clone())], [4, 1, 1]);
        let rgb = |i: usize| Vec3::new(colour.values[3 * i], colour.values[3 * i + 1], colour.values[3 * i + 2]);
        let d = |i: usize| density.values[i];
        for i in 0..4 {
            let c = g.coefficients(Vec3::new(i as f32, 0.0, 0.0), false);
            let want = rgb(i) * 5.0 * d(i) * d(i);
            assert!((c.sigma_s - want).abs().max_element() < 1e-5, "voxel {i}: {} vs {want}", c.sigma_s);
            assert_eq!(c.sigma_a, Vec3::ZERO);
        }
        // A quarter of the way from voxel 1 to voxel 2.
        let c = g.coefficients(Vec3::new(1.25, 0.0, 0.0), false);
        let want = rgb(1) * 5.0 * d(1) * d(1) * 0.75 + rgb(2) * 5.0 * d(2) * d(2) * 0.25;
        assert!((c.sigma_s - want).abs().max_element() < 1e-5, "{} vs {want}", c.sigma_s);
        // Beyond the grid: the background, 0.
        assert_eq!(g.coefficients(Vec3::new(-1.0, 0.0, 0.0), false).sigma_s, Vec3::ZERO);
    }

    /// xorshift: reproducible numbers in [0, 1).
    fn uniform(state: &mut u64) -> f32 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 40) as f32 / (1u64 << 24) as f32
    }

    /// The voxel majorant bounds σt everywhere: a tree of a Volume Scatter and a Volume
    /// Absorption whose densities are a ColorRamp (non-monotone: high, low, high) and a Math
    /// Power of a random density grid, looked up at 200 000 random points of the domain, at
    /// every voxel centre and just below it and at cell faces, never exceeds its cell's majorant; and the bound is
    /// tight (a voxel reaches it within the rounding allowance).
    #[test]
    fn no_point_exceeds_the_voxel_majorant() {
        let dims = [13u32, 10, 9];
        let n = (dims[0] * dims[1] * dims[2]) as usize;
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        let values: Vec<f32> = (0..n).map(|_| 3.0 * uniform(&mut s) - 0.5).collect();
        let nodes = json!([
            attribute("density"),
            {"name": "Ramp", "type": "ShaderNodeValToRGB",
             "props": {"color_ramp": {"interpolation": "LINEAR",
                                      "table": [[4.0, 1.0, 0.5, 1.0], [0.1, 0.2, 0.0, 1.0], [2.0, 6.0, 1.0, 1.0]]}},
             "inputs": {"Fac": {"value": 0.0, "link": [0, "Fac"]}}},
            {"name": "Pow", "type": "ShaderNodeMath", "props": {"operation": "POWER"},
             "inputs": {"Value": {"value": 0.0, "link": [0, "Fac"]}, "Value_001": {"value": 3.0}}},
            {"name": "S", "type": "ShaderNodeVolumeScatter",
             "inputs": {"Density": {"value": 1.0, "link": [1, "Color"]}, "Color": {"value": [0.9, 0.6, 0.3, 1.0]}}},
            {"name": "A", "type": "ShaderNodeVolumeAbsorption",
             "inputs": {"Density": {"value": 1.0, "link": [2, "Value"]}, "Color": {"value": [0.2, 0.5, 0.9, 1.0]}}},
            {"name": "Add", "type": "ShaderNodeAddShader",
             "inputs": {"Shader": {"link": [3, "Volume"]}, "Shader_001": {"link": [4, "Volume"]}}},
        ]);
        let g = medium(nodes, &[("density", Field { values, components: 1 })], dims);
        assert!(g.procedural.as_ref().unwrap().grids.is_some());
        let (lo, hi) = g.domain();
        let check = |p: Vec3| {
            let c = g.coefficients(p, false);
            let sigma = (c.sigma_a + c.sigma_s).max_element();
            let cell = ((p + 1.0) / CELL as f32).floor().min(Vec3::new(
                g.cells[0] as f32 - 1.0,
                g.cells[1] as f32 - 1.0,
                g.cells[2] as f32 - 1.0,
            ));
            let m = g.cell_majorant([cell.x as u32, cell.y as u32, cell.z as u32]);
            assert!(sigma <= m, "σt {sigma} exceeds the majorant {m} at {p}");
            sigma / m
        };
        let mut tightest = 0.0f32;
        for _ in 0..200_000 {
            let t = Vec3::new(uniform(&mut s), uniform(&mut s), uniform(&mut s));
            tightest = tightest.max(check(lo + t * (hi - lo)));
        }
        for z in -1..=dims[2] as i32 {
            for y in -1..=dims[1] as i32 {
                for x in -1..=dims[0] as i32 {
                    let v = Vec3::new(x as f32, y as f32, z as f32);
                    tightest = tightest.max(check(v));
                    // Just inside the cells below: a voxel on a cell's upper face counts there.
                    check(v - 1e-3);
                }
            }
        }
        // Cell faces (index 7, 15): points on both sides' boundaries.
        for f in [6.999f32, 7.0, 7.001, 15.0] {
            for _ in 0..2000 {
                let t = Vec3::new(uniform(&mut s), uniform(&mut s), uniform(&mut s));
                check(Vec3::new(f.min(hi.x), lo.y + t.y * (hi.y - lo.y), lo.z + t.z * (hi.z - lo.z)));
            }
        }
        assert!(tightest > 0.9999, "the bound is loose: the densest voxel reaches {tightest} of it");
    }

    /// The majorant built slab by slab, with voxels where every grid reads zero given the
    /// graph's background value, equals its definition cell for cell (the largest σt of the
    /// graph run at every voxel whose support reaches the cell, each voxel run alone), on a
    /// sparse grid whose graph is largest where both grids are zero (a falling Map Range of the
    /// first, minus the second, into a Scatter and an Absorption), over dims that leave a last cell layer past the ring of background
    /// voxels.
    #[test]
    fn the_slab_majorant_is_the_per_voxel_definition() {
        let dims = [19u32, 9, 17];
        let n = (dims[0] * dims[1] * dims[2]) as usize;
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let sparse = |s: &mut u64| if uniform(s) < 0.8 { 0.0 } else { 2.5 * uniform(s) + 0.5 };
        let a: Vec<f32> = (0..n).map(|_| sparse(&mut s)).collect();
        let b: Vec<f32> = (0..n).map(|_| sparse(&mut s)).collect();
        let nodes = json!([
            attribute("a"),
            attribute("b"),
            {"name": "Range", "type": "ShaderNodeMapRange",
             "inputs": {"Value": {"value": 0.0, "link": [0, "Fac"]}, "From Min": {"value": 0.0}, "From Max": {"value": 3.0},
                        "To Min": {"value": 2.0}, "To Max": {"value": 0.1}}},
            {"name": "Sub", "type": "ShaderNodeMath", "props": {"operation": "SUBTRACT"},
             "inputs": {"Value": {"value": 0.0, "link": [2, "Result"]}, "Value_001": {"value": 0.0, "link": [1, "Fac"]}}},
            {"name": "S", "type": "ShaderNodeVolumeScatter",
             "inputs": {"Density": {"value": 1.0, "link": [3, "Value"]}, "Color": {"value": [0.9, 0.6, 0.3, 1.0]}}},
            {"name": "A", "type": "ShaderNodeVolumeAbsorption",
             "inputs": {"Density": {"value": 1.0, "link": [3, "Value"]}, "Color": {"value": [0.2, 0.5, 0.9, 1.0]}}},
            {"name": "Add", "type": "ShaderNodeAddShader",
             "inputs": {"Shader": {"link": [4, "Volume"]}, "Shader_001": {"link": [5, "Volume"]}}},
        ]);
        let g = medium(
            nodes,
            &[("a", Field { values: a, components: 1 }), ("b", Field { values: b, components: 1 })],
            dims,
        );
        let src = g.procedural.as_deref().unwrap();
        let grids = src.grids.as_ref().unwrap();
        let sigma = |v: [i64; 3]| {
            let c = grids.at_voxel(v, |values| src.coefficients_with(Vec3::ZERO, Some(values), true));
            (c.sigma_a + c.sigma_s).max_element().max(0.0)
        };
        let background = sigma([-1, -1, -1]);
        assert!(background > 0.1, "the graph is {background} at zero: the test needs it non-zero");
        let [nx, ny, nz] = g.cells;
        for cz in 0..nz {
            for cy in 0..ny {
                for cx in 0..nx {
                    let mut want = 0.0f32;
                    for z in cz as i64 * 8 - 1..=(cz as i64 * 8 + 7).min(dims[2] as i64) {
                        for y in cy as i64 * 8 - 1..=(cy as i64 * 8 + 7).min(dims[1] as i64) {
                            for x in cx as i64 * 8 - 1..=(cx as i64 * 8 + 7).min(dims[0] as i64) {
                                want = want.max(sigma([x, y, z]));
                            }
                        }
                    }
                    let got = g.cell_majorant([cx, cy, cz]);
                    assert_eq!(got, want * (1.0 + ROUNDING), "cell ({cx}, {cy}, {cz})");
                }
            }
        }
    }

    /// A graph whose extinction overflows at a voxel (1e20 cubed) cannot be bounded: an
    /// error naming the voxel, never an infinite majorant.
    #[test]
    fn a_non_finite_extinction_is_refused() {
        let mut values = vec![1.0f32; 8];
        values[6] = 1e20;
        let ext: NodesExt = serde_json::from_value(json!({"version": 1, "output": {}, "nodes": [
            attribute("density"),
            {"name": "Pow", "type": "ShaderNodeMath", "props": {"operation": "POWER"},
             "inputs": {"Value": {"value": 0.0, "link": [0, "Fac"]}, "Value_001": {"value": 3.0}}},
            {"name": "S", "type": "ShaderNodeVolumeScatter",
             "inputs": {"Density": {"value": 1.0, "link": [1, "Value"]}, "Color": {"value": [1.0, 1.0, 1.0, 1.0]}}}]}))
        .unwrap();
        let volume = compile_volume("m", &ext, 2, &[], Default::default()).unwrap();
        let grids = VolumeGrids {
            dims: [2, 2, 2],
            index_from_world: Affine3A::IDENTITY,
            slots: vec![Some(Field { values, components: 1 })],
        };
        let source = ProceduralSource { volume, object: NO_OBJECT, grids: Some(grids) };
        let err = graph_grid_medium("m".into(), [2, 2, 2], Affine3A::IDENTITY, source, true).unwrap_err();
        assert!(err.contains("non-finite extinction inf at voxel [0, 1, 1]"), "{err}");
    }

    /// A graph that reads the position (a Noise texture) is not bounded by its voxels: the
    /// medium takes the sampled majorant instead.
    #[test]
    fn a_graph_reading_the_position_is_not_voxel_bounded() {
        let ext: NodesExt = serde_json::from_value(json!({"version": 1, "nodes": [
            {"name": "N", "type": "ShaderNodeTexNoise", "props": {"noise_dimensions": "3D"}, "inputs": {}},
            attribute("density")], "output": {}}))
        .unwrap();
        assert!(!reads_only_grids(&ext));
        let ext: NodesExt =
            serde_json::from_value(json!({"version": 1, "nodes": [attribute("density")], "output": {}})).unwrap();
        assert!(reads_only_grids(&ext));
    }
}
