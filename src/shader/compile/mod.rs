//! Compiles a checked graph ([`NodesExt`]) into a [`Program`]: nodes in topological
//! order become operations over registers, unlinked inputs become constants, a node whose
//! inputs are all constant is evaluated here and replaced by its results, socket types
//! are converted as Blender converts them (colour → float by luminance, vector → float by
//! the average, float → grey), and the Surface output's closure tree is flattened into
//! weight computations and closure operations (Mix Shader: w (1 − fac) and w fac; Add
//! Shader: w for both), as Cycles' SVM compiler does.
//!
//! Node types the renderer does not know are named in a warning; their outputs are 0.

mod closures;
mod sources;

use crate::shader::closure::{CAPACITY, ClosureKind, ClosureOp, Closures, PrincipledRegs};
use crate::shader::graph::{NodeDesc, NodesExt, check_and_sort};
use crate::shader::image_node::{Extension, ImageOp, Interp, Projection};
use crate::shader::ops::{Blend, MathOp, RangeInterp, VecOp};
use crate::shader::program::{
    BumpOp, ColorSpace, CurveKind, CurveTable, Geom, InputKind, MappingKind, ObjectData, Op, Program, Reg,
};
use crate::shader::texture_nodes::{
    TexOp, dims as noise_dims, gradient_kind, noise_kind, voronoi_feature, voronoi_metric, wave_settings,
};
use glam::{Mat4, Vec2, Vec3, Vec4};
use serde_json::Value;
use std::collections::HashSet;

/// Socket types.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ty {
    Float,
    Color,
    Vector,
    Closure,
}

#[derive(Clone, Copy, Debug)]
struct Sock {
    reg: Reg,
    ty: Ty,
}

/// Closure trees deeper than this are cut (a Mix Shader chain of that depth is not a
/// real material; the bound keeps the flattening linear in the graph).
const MAX_CLOSURE_OPS: usize = 64;

/// A compiled material graph and what the loader should say about it.
pub struct Compiled {
    /// The program.
    pub program: Program,
    /// Warnings (without the material's name; the loader adds it).
    pub warnings: Vec<String>,
    /// Texture Coordinate Generated is read (the mesh's texture space is needed).
    pub uses_generated: bool,
}

/// Compiles `ext` for material `name`, whose `images` are scene textures `images[i]`;
/// errors name the node.
pub fn compile(name: &str, ext: &NodesExt, images: &[u32]) -> Result<Compiled, String> {
    let order = check_and_sort(ext)?;
    let mut used = HashSet::new();
    for n in &ext.nodes {
        for i in n.inputs.values() {
            if let Some(l) = &i.link {
                used.insert((l.0, l.1.clone()));
            }
        }
    }
    for l in ext.output.surface.iter().chain(&ext.output.displacement) {
        used.insert((l.0, l.1.clone()));
    }
    let mut c = Compiler {
        ext,
        images,
        init: Vec::new(),
        konst: Vec::new(),
        ops: Vec::new(),
        prog: Program { name: name.to_string(), ..Program::default() },
        outs: vec![Vec::new(); ext.nodes.len()],
        ranges: vec![(0, 0); ext.nodes.len()],
        unknown: vec![false; ext.nodes.len()],
        warnings: Vec::new(),
        all_const: true,
        used,
        closure_ops: 0,
        normals: Vec::new(),
        small_lobes: 0,
        principled: 0,
        uses_generated: false,
    };
    for &i in &order {
        c.node(i)?;
    }
    if let Some((n, out)) = &ext.output.surface {
        c.closure(*n, out, None)?;
    }
    if let Some((n, out)) = &ext.output.displacement {
        c.displacement(*n, out)?;
    }
    if c.small_lobes > CAPACITY {
        c.warnings.push(format!(
            "the surface can mix {} BSDF lobes; Caustic holds {CAPACITY} (and one Principled BSDF) per shading point: \
             the lobes past that are dropped where all are present",
            c.small_lobes
        ));
    }
    if c.normals.len() > 1 {
        c.warnings.push(
            "the BSDFs have different Normal inputs: the mixture shades all of them with the first linked one".into(),
        );
    }
    if c.principled > 1 {
        c.warnings.push(format!(
            "{} Principled BSDFs are mixed: rendered as one Principled BSDF with their parameters averaged by weight",
            c.principled
        ));
    }
    let mut prog = c.prog;
    prog.init = c.init;
    prog.ops = c.ops;
    prog.constant_emission = constant_emission(&prog);
    Ok(Compiled { program: prog, warnings: c.warnings, uses_generated: c.uses_generated })
}

/// The emission when no operation depends on the shading point: the program run once.
fn constant_emission(prog: &Program) -> Option<Vec3> {
    let varying = prog.ops.iter().any(|op| {
        matches!(
            op,
            Op::Input { .. }
                | Op::Fresnel { .. }
                | Op::LayerWeight { .. }
                | Op::NormalMap { .. }
                | Op::Bump(_)
                | Op::Image(_)
        )
    });
    if varying {
        return None;
    }
    let mut out = Closures::default();
    let mut regs = Vec::new();
    prog.run(&dummy_geom(&ObjectData::default()), &mut regs, &mut out);
    Some(out.emission)
}

fn dummy_geom(o: &ObjectData) -> Geom<'_> {
    Geom {
        p: Vec3::ZERO,
        n: Vec3::Y,
        ng: Vec3::Y,
        wo: Vec3::Y,
        uv: [Vec2::ZERO; 2],
        color: Vec4::ONE,
        tangent: Vec4::ZERO,
        backfacing: false,
        object: o,
        textures: &[],
        mesh: &EMPTY_MESH,
        tri: 0,
    }
}

/// No triangles: what constant folding evaluates against.
static EMPTY_MESH: crate::scene::Mesh = crate::scene::Mesh {
    positions: Vec::new(),
    normals: Vec::new(),
    tangents: Vec::new(),
    uv0: Vec::new(),
    uv1: Vec::new(),
    colors: Vec::new(),
    triangles: Vec::new(),
    tri_material: Vec::new(),
    tri_object: Vec::new(),
};

struct Compiler<'a> {
    ext: &'a NodesExt,
    images: &'a [u32],
    init: Vec<f32>,
    konst: Vec<bool>,
    ops: Vec<Op>,
    prog: Program,
    outs: Vec<Vec<(String, Sock)>>,
    /// Each data node's operations in `ops` (start, end).
    ranges: Vec<(u32, u32)>,
    unknown: Vec<bool>,
    warnings: Vec<String>,
    /// Every input of the node being compiled was constant so far.
    all_const: bool,
    used: HashSet<(usize, String)>,
    closure_ops: usize,
    /// The distinct Normal inputs of the BSDF closures (None: the shading normal).
    normals: Vec<Option<Reg>>,
    small_lobes: usize,
    principled: usize,
    uses_generated: bool,
}

fn is_closure_node(kind: &str) -> bool {
    matches!(
        kind,
        "ShaderNodeBsdfPrincipled"
            | "ShaderNodeBsdfDiffuse"
            | "ShaderNodeBsdfGlossy"
            | "ShaderNodeBsdfAnisotropic"
            | "ShaderNodeBsdfMetallic"
            | "ShaderNodeBsdfGlass"
            | "ShaderNodeBsdfRefraction"
            | "ShaderNodeBsdfTranslucent"
            | "ShaderNodeBsdfTransparent"
            | "ShaderNodeBsdfSheen"
            | "ShaderNodeEmission"
            | "ShaderNodeMixShader"
            | "ShaderNodeAddShader"
            | "ShaderNodeHoldout"
            | "ShaderNodeSubsurfaceScattering"
    )
}

fn closure_output(kind: &str) -> &'static str {
    match kind {
        "ShaderNodeEmission" => "Emission",
        "ShaderNodeMixShader" | "ShaderNodeAddShader" => "Shader",
        "ShaderNodeHoldout" => "Holdout",
        "ShaderNodeSubsurfaceScattering" => "BSSRDF",
        _ => "BSDF",
    }
}

impl<'a> Compiler<'a> {
    fn desc(&self, i: usize) -> &'a NodeDesc {
        &self.ext.nodes[i]
    }

    fn alloc(&mut self, n: usize) -> Reg {
        let r = self.init.len() as Reg;
        self.init.extend(std::iter::repeat_n(0.0, n));
        self.konst.extend(std::iter::repeat_n(false, n));
        r
    }

    fn konst_f(&mut self, v: f32) -> Reg {
        let r = self.alloc(1);
        self.init[r as usize] = v;
        self.konst[r as usize] = true;
        r
    }

    fn konst_v(&mut self, v: Vec3) -> Reg {
        let r = self.alloc(3);
        for k in 0..3 {
            self.init[r as usize + k] = v[k];
            self.konst[r as usize + k] = true;
        }
        r
    }

    fn is_const(&self, r: Reg, n: usize) -> bool {
        (0..n).all(|k| self.konst[r as usize + k])
    }

    fn prop_str(&self, i: usize, key: &str, default: &'a str) -> &'a str {
        self.desc(i).props.get(key).and_then(Value::as_str).unwrap_or(default)
    }

    fn prop_bool(&self, i: usize, key: &str, default: bool) -> bool {
        self.desc(i).props.get(key).and_then(Value::as_bool).unwrap_or(default)
    }

    fn err(&self, i: usize, msg: impl std::fmt::Display) -> String {
        format!("node '{}' ({}): {msg}", self.desc(i).name, self.desc(i).kind)
    }

    fn warn(&mut self, i: usize, msg: impl std::fmt::Display) {
        let m = format!("node '{}' ({}): {msg}", self.desc(i).name, self.desc(i).kind);
        if !self.warnings.contains(&m) {
            self.warnings.push(m);
        }
    }

    /// The socket feeding input `id` of node `i`, if linked.
    fn source(&mut self, i: usize, id: &str) -> Result<Option<Sock>, String> {
        let Some(link) = self.desc(i).inputs.get(id).and_then(|d| d.link.as_ref()) else {
            return Ok(None);
        };
        let (src, out) = (link.0, link.1.as_str());
        if let Some((_, s)) = self.outs[src].iter().find(|(n, _)| n == out) {
            let s = *s;
            if s.ty != Ty::Closure && !self.is_const(s.reg, if s.ty == Ty::Float { 1 } else { 3 }) {
                self.all_const = false;
            }
            return Ok(Some(s));
        }
        if self.unknown[src] {
            // Already named in a warning; its outputs are 0.
            return Ok(Some(Sock { reg: self.konst_f(0.0), ty: Ty::Float }));
        }
        Err(self.err(
            i,
            format!("input '{id}' links to output '{out}', which node '{}' does not have", self.desc(src).name),
        ))
    }

    fn value(&self, i: usize, id: &str) -> Option<&'a Value> {
        self.desc(i).inputs.get(id).and_then(|d| d.value.as_ref())
    }

    /// A float input: linked (converted), else its value, else `default`.
    fn float(&mut self, i: usize, id: &str, default: f32) -> Result<Reg, String> {
        if let Some(s) = self.source(i, id)? {
            return self.convert_float(i, id, s);
        }
        let v = match self.value(i, id) {
            None => default,
            Some(Value::Number(n)) => n.as_f64().unwrap_or(0.0) as f32,
            Some(Value::Bool(b)) => *b as u8 as f32,
            Some(other) => return Err(self.err(i, format!("input '{id}' expects a number, not {other}"))),
        };
        if !v.is_finite() {
            return Err(self.err(i, format!("input '{id}' is not a finite number")));
        }
        Ok(self.konst_f(v))
    }

    /// A vector or colour input: linked (converted), else its value (3 or 4 numbers;
    /// a colour's alpha is dropped), else `default`.
    fn vec(&mut self, i: usize, id: &str, default: Vec3) -> Result<Reg, String> {
        if let Some(s) = self.source(i, id)? {
            return self.convert_vec(i, id, s);
        }
        let v = match self.value(i, id) {
            None => default,
            Some(Value::Array(a)) if a.len() == 3 || a.len() == 4 => {
                let mut v = Vec3::ZERO;
                for k in 0..3 {
                    v[k] = a[k].as_f64().map(|x| x as f32).filter(|x| x.is_finite()).ok_or_else(|| {
                        self.err(i, format!("input '{id}' expects 3 or 4 finite numbers, not {}", a[k]))
                    })?;
                }
                v
            }
            Some(other) => return Err(self.err(i, format!("input '{id}' expects 3 or 4 numbers, not {other}"))),
        };
        Ok(self.konst_v(v))
    }

    /// A vector input that Blender fills with an implicit coordinate when unlinked.
    fn vec_implicit(&mut self, i: usize, id: &str, implicit: InputKind) -> Result<Reg, String> {
        if let Some(s) = self.source(i, id)? {
            return self.convert_vec(i, id, s);
        }
        if implicit == InputKind::Generated {
            self.uses_generated = true;
        }
        self.all_const = false;
        let out = self.alloc(3);
        self.ops.push(Op::Input { what: implicit, out });
        Ok(out)
    }

    /// A Normal input: only when linked (unlinked is the shading normal).
    fn normal(&mut self, i: usize, id: &str) -> Result<Option<Reg>, String> {
        match self.source(i, id)? {
            Some(s) => Ok(Some(self.convert_vec(i, id, s)?)),
            None => Ok(None),
        }
    }

    fn convert_float(&mut self, i: usize, id: &str, s: Sock) -> Result<Reg, String> {
        Ok(match s.ty {
            Ty::Float => s.reg,
            Ty::Color => {
                let out = self.alloc(1);
                self.ops.push(Op::Lum { c: s.reg, out });
                out
            }
            Ty::Vector => {
                let out = self.alloc(1);
                self.ops.push(Op::Avg { v: s.reg, out });
                out
            }
            Ty::Closure => return Err(self.err(i, format!("input '{id}' is linked to a shader output"))),
        })
    }

    fn convert_vec(&mut self, i: usize, id: &str, s: Sock) -> Result<Reg, String> {
        Ok(match s.ty {
            Ty::Float => {
                let out = self.alloc(3);
                self.ops.push(Op::Splat { f: s.reg, out });
                out
            }
            Ty::Color | Ty::Vector => s.reg,
            Ty::Closure => return Err(self.err(i, format!("input '{id}' is linked to a shader output"))),
        })
    }

    fn out(&mut self, i: usize, id: &str, ty: Ty) -> Reg {
        let reg = self.alloc(if ty == Ty::Float { 1 } else { 3 });
        self.outs[i].push((id.to_string(), Sock { reg, ty }));
        reg
    }

    fn alias(&mut self, i: usize, id: &str, reg: Reg, ty: Ty) {
        self.outs[i].push((id.to_string(), Sock { reg, ty }));
    }

    fn is_used(&self, i: usize, id: &str) -> bool {
        self.used.contains(&(i, id.to_string()))
    }

    /// Compiles a data node; closure nodes only declare their output (their inputs are
    /// read when the closure tree is flattened).
    fn node(&mut self, i: usize) -> Result<(), String> {
        let kind = self.desc(i).kind.as_str();
        if is_closure_node(kind) {
            self.alias(i, closure_output(kind), 0, Ty::Closure);
            return Ok(());
        }
        let mark = self.ops.len();
        self.all_const = true;
        let known = self.data_node(i, kind)?;
        self.ranges[i] = (mark as u32, self.ops.len() as u32);
        if !known {
            self.unknown[i] = true;
            let why = match kind {
                // The shading point does not know the ray's type (camera, shadow, ...).
                "ShaderNodeLightPath" => "Light Path is not supported (the ray type is not known where it is shaded)",
                _ => "this node type is not supported",
            };
            self.warn(i, format!("{why}: its outputs are 0"));
            return Ok(());
        }
        // Fold a node whose inputs are all constant and that reads nothing of the point.
        let pure = self.ops[mark..].iter().all(|op| {
            !matches!(
                op,
                Op::Input { .. } | Op::Fresnel { .. } | Op::LayerWeight { .. } | Op::NormalMap { .. } | Op::Bump(_)
            )
        });
        if self.all_const && pure && self.ops.len() > mark {
            self.ranges[i] = (mark as u32, mark as u32);
            let ops: Vec<Op> = self.ops.drain(mark..).collect();
            let obj = ObjectData::default();
            let g = dummy_geom(&obj);
            let mut sink = Closures::default();
            for op in &ops {
                self.prog.step(op, &g, &mut self.init, &mut sink);
            }
            for (_, s) in self.outs[i].clone() {
                let n = if s.ty == Ty::Float { 1 } else { 3 };
                for k in 0..n {
                    self.konst[s.reg as usize + k] = true;
                }
            }
        }
        Ok(())
    }

    /// Emits a data node's operations; false for an unknown type.
    fn data_node(&mut self, i: usize, kind: &str) -> Result<bool, String> {
        match kind {
            "ShaderNodeMath" => {
                let name = self.prop_str(i, "operation", "ADD");
                let op = MathOp::parse(name).ok_or_else(|| self.err(i, format!("unknown operation '{name}'")))?;
                let a = self.float(i, "Value", 0.5)?;
                let b = self.float(i, "Value_001", 0.5)?;
                let c = self.float(i, "Value_002", 0.0)?;
                let clamp = self.prop_bool(i, "use_clamp", false);
                let out = self.out(i, "Value", Ty::Float);
                self.ops.push(Op::Math { op, a, b, c, out, clamp });
            }
            "ShaderNodeVectorMath" => {
                let name = self.prop_str(i, "operation", "ADD");
                let op = VecOp::parse(name).ok_or_else(|| self.err(i, format!("unknown operation '{name}'")))?;
                let a = self.vec(i, "Vector", Vec3::ZERO)?;
                let b = self.vec(i, "Vector_001", Vec3::ZERO)?;
                let c = self.vec(i, "Vector_002", Vec3::ZERO)?;
                let s = self.float(i, "Scale", 1.0)?;
                let vout = self.out(i, "Vector", Ty::Vector);
                let fout = self.out(i, "Value", Ty::Float);
                self.ops.push(Op::VecMath { op, a, b, c, s, vout, fout });
            }
            "ShaderNodeMix" => {
                let clamp = self.prop_bool(i, "clamp_factor", true);
                match self.prop_str(i, "data_type", "FLOAT") {
                    "FLOAT" => {
                        let fac = self.float(i, "Factor_Float", 0.5)?;
                        let a = self.float(i, "A_Float", 0.0)?;
                        let b = self.float(i, "B_Float", 0.0)?;
                        let out = self.out(i, "Result_Float", Ty::Float);
                        self.ops.push(Op::MixFloat { fac, a, b, out, clamp });
                    }
                    "VECTOR" => {
                        let fac_vec = self.prop_str(i, "factor_mode", "UNIFORM") == "NON_UNIFORM";
                        let fac = if fac_vec {
                            self.vec(i, "Factor_Vector", Vec3::splat(0.5))?
                        } else {
                            self.float(i, "Factor_Float", 0.5)?
                        };
                        let a = self.vec(i, "A_Vector", Vec3::ZERO)?;
                        let b = self.vec(i, "B_Vector", Vec3::ZERO)?;
                        let out = self.out(i, "Result_Vector", Ty::Vector);
                        self.ops.push(Op::MixVec { fac, fac_vec, a, b, out, clamp });
                    }
                    "RGBA" => {
                        let name = self.prop_str(i, "blend_type", "MIX");
                        let blend =
                            Blend::parse(name).ok_or_else(|| self.err(i, format!("unknown blend type '{name}'")))?;
                        let fac = self.float(i, "Factor_Float", 0.5)?;
                        let a = self.vec(i, "A_Color", Vec3::splat(0.5))?;
                        let b = self.vec(i, "B_Color", Vec3::splat(0.5))?;
                        let clamp_res = self.prop_bool(i, "clamp_result", false);
                        let out = self.out(i, "Result_Color", Ty::Color);
                        self.ops.push(Op::MixColor { blend, fac, a, b, out, clamp_fac: clamp, clamp_res });
                    }
                    other => return Err(self.err(i, format!("data type '{other}' is not supported"))),
                }
            }
            "ShaderNodeMixRGB" => {
                let name = self.prop_str(i, "blend_type", "MIX");
                let blend = Blend::parse(name).ok_or_else(|| self.err(i, format!("unknown blend type '{name}'")))?;
                let fac = self.float(i, "Fac", 0.5)?;
                let a = self.vec(i, "Color1", Vec3::splat(0.5))?;
                let b = self.vec(i, "Color2", Vec3::splat(0.5))?;
                let clamp_res = self.prop_bool(i, "use_clamp", false);
                let out = self.out(i, "Color", Ty::Color);
                self.ops.push(Op::MixColor { blend, fac, a, b, out, clamp_fac: true, clamp_res });
            }
            "ShaderNodeMapRange" => {
                let interp = match self.prop_str(i, "interpolation_type", "LINEAR") {
                    "LINEAR" => RangeInterp::Linear,
                    "STEPPED" => RangeInterp::Stepped,
                    "SMOOTHSTEP" => RangeInterp::SmoothStep,
                    "SMOOTHERSTEP" => RangeInterp::SmootherStep,
                    other => return Err(self.err(i, format!("unknown interpolation '{other}'"))),
                };
                let clamp = self.prop_bool(i, "clamp", true);
                let vector = self.prop_str(i, "data_type", "FLOAT") == "FLOAT_VECTOR";
                let op = if vector {
                    let v = self.vec(i, "Vector", Vec3::ZERO)?;
                    let fmin = self.vec(i, "From_Min_FLOAT3", Vec3::ZERO)?;
                    let fmax = self.vec(i, "From_Max_FLOAT3", Vec3::ONE)?;
                    let tmin = self.vec(i, "To_Min_FLOAT3", Vec3::ZERO)?;
                    let tmax = self.vec(i, "To_Max_FLOAT3", Vec3::ONE)?;
                    let steps = self.vec(i, "Steps_FLOAT3", Vec3::splat(4.0))?;
                    let out = self.out(i, "Vector", Ty::Vector);
                    Op::MapRange { interp, vector, v, fmin, fmax, tmin, tmax, steps, out, clamp }
                } else {
                    let v = self.float(i, "Value", 1.0)?;
                    let fmin = self.float_either(i, "From Min", "From_Min", 0.0)?;
                    let fmax = self.float_either(i, "From Max", "From_Max", 1.0)?;
                    let tmin = self.float_either(i, "To Min", "To_Min", 0.0)?;
                    let tmax = self.float_either(i, "To Max", "To_Max", 1.0)?;
                    let steps = self.float_either(i, "Steps", "Steps", 4.0)?;
                    let out = self.out(i, "Result", Ty::Float);
                    Op::MapRange { interp, vector, v, fmin, fmax, tmin, tmax, steps, out, clamp }
                };
                self.ops.push(op);
            }
            "ShaderNodeClamp" => {
                let range = self.prop_str(i, "clamp_type", "MINMAX") == "RANGE";
                let v = self.float(i, "Value", 1.0)?;
                let min = self.float(i, "Min", 0.0)?;
                let max = self.float(i, "Max", 1.0)?;
                let out = self.out(i, "Result", Ty::Float);
                self.ops.push(Op::Clamp { range, v, min, max, out });
            }
            "ShaderNodeValToRGB" => {
                let (table, interpolate) = self.ramp(i)?;
                let fac = self.float(i, "Fac", 0.5)?;
                let color = self.out(i, "Color", Ty::Color);
                let alpha = self.out(i, "Alpha", Ty::Float);
                self.ops.push(Op::Ramp { table, interpolate, fac, color, alpha });
            }
            "ShaderNodeRGBCurve" | "ShaderNodeVectorCurve" | "ShaderNodeFloatCurve" => {
                let (ckind, n, fac_id, in_id, out_id, ty) = match kind {
                    "ShaderNodeRGBCurve" => (CurveKind::Rgb, 4, "Fac", "Color", "Color", Ty::Color),
                    "ShaderNodeVectorCurve" => (CurveKind::Vector, 3, "Fac", "Vector", "Vector", Ty::Vector),
                    _ => (CurveKind::Float, 1, "Factor", "Value", "Value", Ty::Float),
                };
                let table = self.curve(i, n)?;
                let fac = self.float(i, fac_id, 1.0)?;
                let v = if ty == Ty::Float { self.float(i, in_id, 1.0)? } else { self.vec(i, in_id, Vec3::ZERO)? };
                let out = self.out(i, out_id, ty);
                self.ops.push(Op::Curve { table, kind: ckind, fac, v, out });
            }
            "ShaderNodeInvert" => {
                let fac = self.float(i, "Fac", 1.0)?;
                let c = self.vec(i, "Color", Vec3::ZERO)?;
                let out = self.out(i, "Color", Ty::Color);
                self.ops.push(Op::Invert { fac, c, out });
            }
            "ShaderNodeGamma" => {
                let c = self.vec(i, "Color", Vec3::ONE)?;
                let g = self.float(i, "Gamma", 1.0)?;
                let out = self.out(i, "Color", Ty::Color);
                self.ops.push(Op::Gamma { c, g, out });
            }
            "ShaderNodeBrightContrast" => {
                let c = self.vec(i, "Color", Vec3::ONE)?;
                let bright = self.float(i, "Bright", 0.0)?;
                let contrast = self.float(i, "Contrast", 0.0)?;
                let out = self.out(i, "Color", Ty::Color);
                self.ops.push(Op::BrightContrast { c, bright, contrast, out });
            }
            "ShaderNodeHueSaturation" => {
                let hue = self.float(i, "Hue", 0.5)?;
                let sat = self.float(i, "Saturation", 1.0)?;
                let val = self.float(i, "Value", 1.0)?;
                let fac = self.float(i, "Fac", 1.0)?;
                let c = self.vec(i, "Color", Vec3::splat(0.8))?;
                let out = self.out(i, "Color", Ty::Color);
                self.ops.push(Op::HueSat { hue, sat, val, fac, c, out });
            }
            "ShaderNodeRGBToBW" => {
                let c = self.vec(i, "Color", Vec3::splat(0.5))?;
                let out = self.out(i, "Val", Ty::Float);
                self.ops.push(Op::Lum { c, out });
            }
            "ShaderNodeSeparateXYZ" => {
                let v = self.vec(i, "Vector", Vec3::ZERO)?;
                self.split(i, v, ["X", "Y", "Z"]);
            }
            "ShaderNodeCombineXYZ" => {
                let (x, y, z) = (self.float(i, "X", 0.0)?, self.float(i, "Y", 0.0)?, self.float(i, "Z", 0.0)?);
                let out = self.out(i, "Vector", Ty::Vector);
                self.ops.push(Op::Pack { x, y, z, out });
            }
            "ShaderNodeSeparateColor" | "ShaderNodeSeparateRGB" | "ShaderNodeSeparateHSV" => {
                let (space, in_id, names) = match kind {
                    "ShaderNodeSeparateRGB" => (None, "Image", ["R", "G", "B"]),
                    "ShaderNodeSeparateHSV" => (Some(ColorSpace::Hsv), "Color", ["H", "S", "V"]),
                    _ => (self.color_mode(i)?, "Color", ["Red", "Green", "Blue"]),
                };
                let c = self.vec(i, in_id, Vec3::splat(0.8))?;
                let c = match space {
                    Some(space) => {
                        let out = self.alloc(3);
                        self.ops.push(Op::ColorSpace { space, to_rgb: false, c, out });
                        out
                    }
                    None => c,
                };
                self.split(i, c, names);
            }
            "ShaderNodeCombineColor" | "ShaderNodeCombineRGB" | "ShaderNodeCombineHSV" => {
                let (space, ids, out_id) = match kind {
                    "ShaderNodeCombineRGB" => (None, ["R", "G", "B"], "Image"),
                    "ShaderNodeCombineHSV" => (Some(ColorSpace::Hsv), ["H", "S", "V"], "Color"),
                    _ => (self.color_mode(i)?, ["Red", "Green", "Blue"], "Color"),
                };
                let (x, y, z) = (self.float(i, ids[0], 0.0)?, self.float(i, ids[1], 0.0)?, self.float(i, ids[2], 0.0)?);
                let out = self.out(i, out_id, Ty::Color);
                match space {
                    None => self.ops.push(Op::Pack { x, y, z, out }),
                    Some(space) => {
                        let packed = self.alloc(3);
                        self.ops.push(Op::Pack { x, y, z, out: packed });
                        self.ops.push(Op::ColorSpace { space, to_rgb: true, c: packed, out });
                    }
                }
            }
            "ShaderNodeValue" => {
                let v = self.desc(i).props.get("value").and_then(Value::as_f64).map(|v| v as f32);
                let Some(v) = v.filter(|v| v.is_finite()) else {
                    self.warn(i, "props.value (the node's number) is missing: it gives 0");
                    let r = self.konst_f(0.0);
                    self.alias(i, "Value", r, Ty::Float);
                    return Ok(true);
                };
                let r = self.konst_f(v);
                self.alias(i, "Value", r, Ty::Float);
            }
            "ShaderNodeRGB" => {
                let c = self
                    .desc(i)
                    .props
                    .get("color")
                    .and_then(Value::as_array)
                    .and_then(|a| (a.len() >= 3).then(|| Vec3::new(num(&a[0]), num(&a[1]), num(&a[2]))));
                let Some(c) = c.filter(|c| c.is_finite()) else {
                    self.warn(i, "props.color (the node's colour) is missing: it gives black");
                    let r = self.konst_v(Vec3::ZERO);
                    self.alias(i, "Color", r, Ty::Color);
                    return Ok(true);
                };
                let r = self.konst_v(c);
                self.alias(i, "Color", r, Ty::Color);
            }
            _ => return self.source_node(i, kind),
        }
        Ok(true)
    }

    /// The float Map Range's sockets are "From Min"... in older files and "From_Min" in
    /// newer ones: whichever the node has.
    fn float_either(&mut self, i: usize, a: &str, b: &str, default: f32) -> Result<Reg, String> {
        let has = |id: &str| self.desc(i).inputs.contains_key(id);
        if has(a) { self.float(i, a, default) } else { self.float(i, b, default) }
    }

    fn split(&mut self, i: usize, v: Reg, names: [&str; 3]) {
        for (k, id) in names.iter().enumerate() {
            self.alias(i, id, v + k as Reg, Ty::Float);
        }
    }

    fn color_mode(&self, i: usize) -> Result<Option<ColorSpace>, String> {
        match self.prop_str(i, "mode", "RGB") {
            "RGB" => Ok(None),
            "HSV" => Ok(Some(ColorSpace::Hsv)),
            "HSL" => Ok(Some(ColorSpace::Hsl)),
            other => Err(self.err(i, format!("unknown mode '{other}'"))),
        }
    }

    fn tex_coord(&self, i: usize) -> u8 {
        self.desc(i).props.get("tex_coord").and_then(Value::as_u64).unwrap_or(0).min(1) as u8
    }

    fn matrix(&mut self, i: usize) -> Result<Option<u32>, String> {
        let Some(m) = self.desc(i).props.get("object_matrix") else {
            return Ok(None);
        };
        let a: Vec<f32> = m
            .as_array()
            .filter(|a| a.len() == 16)
            .map(|a| a.iter().map(num).collect())
            .filter(|v: &Vec<f32>| v.iter().all(|x| x.is_finite()))
            .ok_or_else(|| self.err(i, "object_matrix must be 16 finite numbers"))?;
        let mut cols = [0.0; 16];
        cols.copy_from_slice(&a);
        self.prog.matrices.push(Mat4::from_cols_array(&cols));
        Ok(Some(self.prog.matrices.len() as u32 - 1))
    }

    fn ramp(&mut self, i: usize) -> Result<(u32, bool), String> {
        let r = self.desc(i).props.get("color_ramp").ok_or_else(|| self.err(i, "color_ramp is missing"))?;
        let interp = r.get("interpolation").and_then(Value::as_str).unwrap_or("LINEAR");
        let table = r
            .get("table")
            .and_then(Value::as_array)
            .filter(|t| t.len() >= 2)
            .ok_or_else(|| self.err(i, "color_ramp.table must list [r, g, b, a] entries"))?;
        let mut rows = Vec::with_capacity(table.len());
        for e in table {
            let row = e
                .as_array()
                .filter(|a| a.len() == 4)
                .map(|a| [num(&a[0]), num(&a[1]), num(&a[2]), num(&a[3])])
                .filter(|a| a.iter().all(|x| x.is_finite()))
                .ok_or_else(|| self.err(i, "color_ramp.table entries must be 4 finite numbers"))?;
            rows.push(row);
        }
        self.prog.ramps.push(rows);
        Ok((self.prog.ramps.len() as u32 - 1, interp != "CONSTANT"))
    }

    fn curve(&mut self, i: usize, n: usize) -> Result<u32, String> {
        let m = self.desc(i).props.get("mapping").ok_or_else(|| self.err(i, "mapping is missing"))?;
        let bad = || self.err(i, format!("mapping must have a range [min, max] and {n} tables of numbers"));
        let range = m
            .get("range")
            .and_then(Value::as_array)
            .filter(|a| a.len() == 2)
            .map(|a| [num(&a[0]), num(&a[1])])
            .filter(|a| a.iter().all(|x| x.is_finite()))
            .ok_or_else(bad)?;
        let tables: Vec<Vec<f32>> = m
            .get("tables")
            .and_then(Value::as_array)
            .filter(|t| t.len() == n)
            .ok_or_else(bad)?
            .iter()
            .map(|t| t.as_array().map(|a| a.iter().map(num).collect::<Vec<f32>>()))
            .collect::<Option<Vec<_>>>()
            .filter(|ts| ts.iter().all(|t| t.len() >= 2 && t.iter().all(|x| x.is_finite())))
            .ok_or_else(bad)?;
        let extrapolate = m.get("extrapolate").and_then(Value::as_bool).unwrap_or(false);
        self.prog.curves.push(CurveTable { range, extrapolate, tables });
        Ok(self.prog.curves.len() as u32 - 1)
    }
}

fn num(v: &Value) -> f32 {
    v.as_f64().map_or(f32::NAN, |x| x as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn compiled(nodes: Value, surface: Value) -> Compiled {
        let ext: NodesExt =
            serde_json::from_value(json!({"version": 1, "nodes": nodes, "output": {"surface": surface}})).unwrap();
        compile("m", &ext, &[]).unwrap()
    }

    /// A chain of constant nodes folds away: the program keeps only the closure, and its
    /// constant emission is known at load.
    #[test]
    fn constant_nodes_fold_at_load() {
        let c = compiled(
            json!([
                {"name": "A", "type": "ShaderNodeMath", "props": {"operation": "POWER"},
                 "inputs": {"Value": {"value": 2.0}, "Value_001": {"value": 3.0}}},
                {"name": "B", "type": "ShaderNodeCombineXYZ",
                 "inputs": {"X": {"link": [0, "Value"]}, "Y": {"value": 1.0}, "Z": {"value": 0.5}}},
                {"name": "E", "type": "ShaderNodeEmission",
                 "inputs": {"Color": {"link": [1, "Vector"]}, "Strength": {"value": 0.5}}}
            ]),
            json!([2, "Emission"]),
        );
        assert_eq!(c.program.ops.len(), 1, "{:?}", c.program.ops);
        assert!(matches!(c.program.ops[0], Op::Closure(_)));
        assert_eq!(c.program.constant_emission, Some(Vec3::new(4.0, 0.5, 0.25)));
    }

    /// More small lobes than a mixture holds is named at load; two Principled BSDFs too.
    #[test]
    fn capacity_and_merged_principled_are_warned() {
        let mut nodes = Vec::new();
        for k in 0..5 {
            nodes.push(json!({"name": format!("D{k}"), "type": "ShaderNodeBsdfDiffuse"}));
        }
        nodes.push(json!({"name": "P1", "type": "ShaderNodeBsdfPrincipled"}));
        nodes.push(json!({"name": "P2", "type": "ShaderNodeBsdfPrincipled"}));
        // Add shaders chaining all seven.
        let mut last = (0usize, "BSDF".to_string());
        for k in 1..7 {
            nodes.push(json!({"name": format!("Add{k}"), "type": "ShaderNodeAddShader",
                "inputs": {"Shader": {"link": [last.0, last.1]}, "Shader_001": {"link": [k, "BSDF"]}}}));
            last = (nodes.len() - 1, "Shader".into());
        }
        let c = compiled(Value::Array(nodes), json!([last.0, last.1]));
        assert!(c.warnings.iter().any(|w| w.contains("5 BSDF lobes")), "{:?}", c.warnings);
        assert!(c.warnings.iter().any(|w| w.contains("2 Principled BSDFs")), "{:?}", c.warnings);
    }
}
