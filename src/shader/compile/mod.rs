//! Compiles a checked graph ([`NodesExt`]) into a [`Program`]: nodes in topological
//! order become operations over registers, unlinked inputs become constants, a node whose
//! inputs are all constant is evaluated here and replaced by its results, socket types
//! are converted as Blender converts them (colour → float by luminance, vector → float by
//! the average, float → grey), and the Surface output's closure tree is flattened into
//! weight computations and closure operations (Mix Shader: w (1 − fac) and w fac; Add
//! Shader: w for both), as Cycles' SVM compiler does.
//!
//! Nodes that only AOV Output nodes read are compiled after the surface's closures
//! (`Program::surface_end`), so that shading a surface never computes them.
//!
//! Node types the renderer does not know are named in a warning; their outputs are 0.

mod aov;
mod closures;
mod converters;
mod light_path_use;
mod sources;
pub mod volume;

use crate::scene::working_space::WorkingSpace;
use crate::shader::closure::{AnisoMapping, AnisoRegs, ClosureKind, ClosureOp, Closures, PrincipledRegs};
use crate::shader::geom::{Geom, ObjectData, Reg};
use crate::shader::graph::{NodeDesc, NodesExt, check_and_sort};
use crate::shader::image_node::{Extension, ImageOp, Interp, Projection};
use crate::shader::instructions::{BumpOp, ColorSpace, CurveKind, CurveTable, InputKind, MappingKind, Op, Program};
use crate::shader::ops::{Blend, MathOp, RangeInterp, VecOp};
use crate::shader::texture::{GaborKind, RadialTilingUse};
use crate::shader::texture_nodes::{
    TexOp, dims as noise_dims, gradient_kind, noise_kind, voronoi_feature, voronoi_metric, wave_settings,
};
use glam::{Mat4, Vec2, Vec3, Vec4};
use serde_json::Value;
use std::collections::HashSet;

/// Blender 5.0's Bump node Filter Width default (Cycles' `BumpNode` socket default).
pub(crate) const BUMP_FILTER_WIDTH: f32 = 0.1;

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
    /// Compiled for the Displacement output alone: the amount's register and whether it is
    /// in object space.
    displacement_height: Option<(Reg, bool)>,
}

/// The material's Displacement method (`NodesExt::displacement_method`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Method {
    Bump,
    Displacement,
    Both,
}

impl Method {
    fn parse(s: Option<&str>) -> Result<Self, String> {
        match s {
            None | Some("BUMP") => Ok(Method::Bump),
            Some("DISPLACEMENT") => Ok(Method::Displacement),
            Some("BOTH") => Ok(Method::Both),
            Some(other) => Err(format!("displacement_method '{other}' is not one of BUMP, DISPLACEMENT, BOTH")),
        }
    }
}

/// Compiles `ext` for material `name`, whose `images` are scene textures `images[i]`;
/// errors name the node.
pub fn compile(name: &str, ext: &NodesExt, images: &[u32]) -> Result<Compiled, String> {
    compile_in(name, ext, images, WorkingSpace::default())
}

/// [`compile`] for a scene whose working colour space is `space` (what the graph computes as
/// RGB itself is given in it, colour → float weighs by its luminance).
pub fn compile_in(name: &str, ext: &NodesExt, images: &[u32], space: WorkingSpace) -> Result<Compiled, String> {
    let method = Method::parse(ext.displacement_method.as_deref())?;
    let mut compiled = compile_with(name, ext, images, method, false, space)?;
    if method != Method::Bump && ext.output.displacement.is_some() {
        // The displacement's own program: the graph with the Displacement output alone, so that
        // moving a vertex runs no closure and shading runs no more than before.
        let mut alone = ext.clone();
        alone.output.surface = None;
        let h = compile_with(name, &alone, images, method, true, space)?;
        if let Some((height, object_space)) = h.displacement_height {
            compiled.program.true_displacement =
                Some(std::sync::Arc::new(crate::shader::instructions::TrueDisplacement {
                    program: h.program,
                    height,
                    object_space,
                    bump: method == Method::Both,
                }));
        }
    }
    Ok(compiled)
}

/// [`compile`] for one displacement `method`; `height_only` compiles the Displacement output
/// alone into `Compiled::displacement_height` (no bump).
fn compile_with(
    name: &str,
    ext: &NodesExt,
    images: &[u32],
    method: Method,
    height_only: bool,
    space: WorkingSpace,
) -> Result<Compiled, String> {
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
    let mut c = Compiler::new(ext, images, name, used);
    c.prog.space = space;
    (c.method, c.height_only) = (method, height_only);
    let surface = reachable_from_outputs(ext);
    for &i in order.iter().filter(|&&i| surface[i]) {
        c.node(i)?;
    }
    if let Some((n, out)) = &ext.output.surface {
        c.closure(*n, out, None)?;
    }
    if let Some((n, out)) = &ext.output.displacement {
        c.displacement(*n, out)?;
    }
    let surface_end = c.ops.len();
    for &i in order.iter().filter(|&&i| !surface[i]) {
        c.node(i)?;
    }
    if c.hair_principled > 1 {
        c.warnings.push(format!(
            "{} Principled Hair BSDFs are mixed: strands render them as one, with their parameters averaged by weight",
            c.hair_principled
        ));
    }
    if c.hair_principled > 0 && c.hair_lobes > 0 {
        c.warnings.push(
            "Principled Hair and Hair BSDFs are mixed: strands render the Principled Hair BSDFs alone".to_string(),
        );
    }
    if c.prog.hair && (c.small_lobes > 0 || c.principled > 0) {
        c.warnings.push(
            "hair BSDFs are mixed with other BSDFs: strands render the hair BSDFs alone (meshes mix them)".to_string(),
        );
    }
    let mut prog = c.prog;
    prog.init = c.init;
    prog.ops = c.ops;
    prog.surface_end = surface_end;
    prog.lane_bump = crate::shader::instructions::LaneBump::find(&prog.ops, surface_end);
    prog.constant_emission = constant_emission(&prog);
    prog.scattering_light_path = light_path_use::scattering_outputs(ext);
    Ok(Compiled {
        program: prog,
        warnings: c.warnings,
        uses_generated: c.uses_generated,
        displacement_height: c.displacement_height,
    })
}

/// Which nodes the Surface and Displacement outputs read (the rest feed AOV Output nodes).
fn reachable_from_outputs(ext: &NodesExt) -> Vec<bool> {
    let mut seen = vec![false; ext.nodes.len()];
    let mut stack: Vec<usize> = ext.output.surface.iter().chain(&ext.output.displacement).map(|l| l.0).collect();
    while let Some(i) = stack.pop() {
        if std::mem::replace(&mut seen[i], true) {
            continue;
        }
        stack.extend(ext.nodes[i].inputs.values().filter_map(|d| d.link.as_ref().map(|l| l.0)));
    }
    seen
}

/// The emission when no surface operation depends on the shading point: the program run once.
fn constant_emission(prog: &Program) -> Option<Vec3> {
    let varying = prog.ops[..prog.surface_end].iter().any(|op| {
        matches!(
            op,
            Op::Input { .. }
                | Op::Fresnel { .. }
                | Op::LayerWeight { .. }
                | Op::NormalMap { .. }
                | Op::Bump(_)
                | Op::Image(_)
                | Op::Ao(_)
                | Op::Bevel(_)
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
        mesh: &crate::scene::mesh::EMPTY_MESH,
        tri: 0,
        bary: Vec2::ZERO,
        path: crate::scene::light_path::LightPath::LIGHT_EMISSION,
        view: &crate::shader::geom::NO_VIEW,
        rays: crate::shader::geom::Rays::default(),
        point: None,
        curve: None,
        grid_values: None,
    }
}

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
    small_lobes: usize,
    principled: usize,
    /// Principled Hair BSDFs in the surface.
    hair_principled: usize,
    /// Hair BSDFs in the surface.
    hair_lobes: usize,
    uses_generated: bool,
    /// The material's displacement method.
    method: Method,
    /// Compiling the Displacement output alone for true displacement.
    height_only: bool,
    /// Set by `displacement` when `height_only`.
    displacement_height: Option<(Reg, bool)>,
    /// Compiling a volume graph (Volume Info reads grids there, which it does not render).
    volume: bool,
}

impl<'a> Compiler<'a> {
    /// An empty compiler for graph `ext` (images `images`) of material `name`, whose used
    /// sockets are `used`.
    fn new(ext: &'a NodesExt, images: &'a [u32], name: &str, used: HashSet<(usize, String)>) -> Self {
        Compiler {
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
            small_lobes: 0,
            principled: 0,
            hair_principled: 0,
            hair_lobes: 0,
            uses_generated: false,
            method: Method::Bump,
            height_only: false,
            displacement_height: None,
            volume: false,
        }
    }
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
            | "ShaderNodeBsdfToon"
            | "ShaderNodeBsdfTransparent"
            | "ShaderNodeBsdfRayPortal"
            | "ShaderNodeBsdfSheen"
            | "ShaderNodeEmission"
            | "ShaderNodeBackground"
            | "ShaderNodeMixShader"
            | "ShaderNodeAddShader"
            | "ShaderNodeHoldout"
            | "ShaderNodeSubsurfaceScattering"
            | "ShaderNodeBsdfHairPrincipled"
            | "ShaderNodeBsdfHair"
    )
}

/// The display name of an EEVEE-only shader node, which Cycles' sync leaves out of its graph
/// (the inputs it feeds read nothing: a black shader, a zero value); None for any other type.
/// Shader to RGB is handled by the add-on (the input it feeds keeps its own value).
fn eevee_only(kind: &str) -> Option<&'static str> {
    match kind {
        "ShaderNodeEeveeSpecular" => Some("Specular BSDF"),
        "ShaderNodeShaderToRGB" => Some("Shader to RGB"),
        _ => None,
    }
}

fn closure_output(kind: &str) -> &'static str {
    match kind {
        "ShaderNodeEmission" => "Emission",
        "ShaderNodeBackground" => "Background",
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

    /// A Bump node's Filter Width. Cycles compiles it into the offset evaluations as a
    /// constant: a link whose value folds to a constant (a Value node, math on constants)
    /// gives that constant, as Cycles' constant folding does; a link that varies over the
    /// surface is not followed (warned) and the socket's own value is taken, as Cycles
    /// takes it (both measured in Blender 5.0). Blender's default where the file has none
    /// (older add-ons).
    fn filter_width(&mut self, i: usize) -> Result<f32, String> {
        let own = match self.value(i, "Filter Width") {
            None => BUMP_FILTER_WIDTH,
            Some(Value::Number(n)) => n.as_f64().unwrap_or(0.0) as f32,
            Some(other) => return Err(self.err(i, format!("input 'Filter Width' expects a number, not {other}"))),
        };
        let v = match self.source(i, "Filter Width")? {
            None => own,
            Some(s) => match self.folded_float(s) {
                Some(v) => v,
                None => {
                    self.warn(
                        i,
                        format!(
                            "a Filter Width linked to a value that varies over the surface is read as the \
                             socket's own value {own}, as Cycles reads it"
                        ),
                    );
                    own
                }
            },
        };
        if !v.is_finite() {
            return Err(self.err(i, "input 'Filter Width' is not a finite number".to_string()));
        }
        Ok(v)
    }

    /// The value of a constant socket as a float input reads it (Cycles' colour and vector
    /// to float conversions); None when it varies or is a shader.
    fn folded_float(&self, s: Sock) -> Option<f32> {
        let r = s.reg as usize;
        match s.ty {
            Ty::Float if self.is_const(s.reg, 1) => Some(self.init[r]),
            Ty::Color if self.is_const(s.reg, 3) => {
                Some(self.prog.space.luminance(Vec3::new(self.init[r], self.init[r + 1], self.init[r + 2])))
            }
            Ty::Vector if self.is_const(s.reg, 3) => Some((self.init[r] + self.init[r + 1] + self.init[r + 2]) / 3.0),
            _ => None,
        }
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

    /// A 2-D vector input (Blender 5's two-dimensional sockets, whose value is 2 numbers; a
    /// constant through a group socket may arrive as 3): linked (converted, z kept for the
    /// node to ignore), else its value with z 0, else the origin.
    fn vec_xy(&mut self, i: usize, id: &str) -> Result<Reg, String> {
        if let Some(s) = self.source(i, id)? {
            return self.convert_vec(i, id, s);
        }
        let v = match self.value(i, id) {
            None => Vec3::ZERO,
            Some(Value::Array(a)) if a.len() == 2 || a.len() == 3 => {
                let mut v = Vec3::ZERO;
                for (k, x) in a.iter().enumerate() {
                    v[k] =
                        x.as_f64().map(|x| x as f32).filter(|x| x.is_finite()).ok_or_else(|| {
                            self.err(i, format!("input '{id}' expects 2 or 3 finite numbers, not {x}"))
                        })?;
                }
                v
            }
            Some(other) => return Err(self.err(i, format!("input '{id}' expects 2 or 3 numbers, not {other}"))),
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
        if kind == aov::AOV_OUTPUT {
            return self.aov_output(i);
        }
        let mark = self.ops.len();
        self.all_const = true;
        let known = self.data_node(i, kind)?;
        self.ranges[i] = (mark as u32, self.ops.len() as u32);
        if !known {
            self.unknown[i] = true;
            let msg = match eevee_only(kind) {
                Some(what) => format!("{what} is EEVEE-only: Cycles renders nothing of it either (its output is 0)"),
                None => "this node type is not supported: its outputs are 0".to_string(),
            };
            self.warn(i, msg);
            return Ok(());
        }
        // Fold a node whose inputs are all constant and that reads nothing of the point.
        let pure = self.ops[mark..].iter().all(|op| {
            !matches!(
                op,
                Op::Input { .. }
                    | Op::Fresnel { .. }
                    | Op::LayerWeight { .. }
                    | Op::NormalMap { .. }
                    | Op::Bump(_)
                    | Op::Ao(_)
                    | Op::Bevel(_)
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

    /// The microfacet options compile to Cycles' closures without a warning (Beckmann and
    /// single-scattering GGX on Glossy, Glass and Refraction — the last's default Beckmann —,
    /// the Glossy BSDF's Anisotropy along the radial tangent, which reads Generated, its
    /// Ashikhmin-Shirley lobe); what is still not rendered is named: a thin film; two
    /// anisotropic closures each keep their own tangent.
    #[test]
    fn microfacet_options_compile_as_cycles() {
        let kinds = |c: &Compiled| -> Vec<ClosureKind> {
            c.program
                .ops
                .iter()
                .filter_map(|op| if let Op::Closure(c) = op { Some(c.kind.clone()) } else { None })
                .collect()
        };
        let node = |kind: &str, dist: Option<&str>, inputs: Value| {
            let props = dist.map_or(json!({}), |d| json!({"distribution": d}));
            json!({"name": "N", "type": kind, "props": props, "inputs": inputs})
        };
        let glossy =
            compiled(json!([node("ShaderNodeBsdfAnisotropic", Some("BECKMANN"), json!({}))]), json!([0, "BSDF"]));
        assert!(glossy.warnings.is_empty(), "{:?}", glossy.warnings);
        assert!(matches!(
            kinds(&glossy)[0],
            ClosureKind::Glossy { beckmann: true, multiscatter: false, aniso: None, .. }
        ));
        let refraction = compiled(json!([node("ShaderNodeBsdfRefraction", None, json!({}))]), json!([0, "BSDF"]));
        assert!(refraction.warnings.is_empty(), "{:?}", refraction.warnings);
        assert!(matches!(kinds(&refraction)[0], ClosureKind::Refraction { beckmann: true }));
        let glass = compiled(json!([node("ShaderNodeBsdfGlass", Some("GGX"), json!({}))]), json!([0, "BSDF"]));
        assert!(matches!(kinds(&glass)[0], ClosureKind::Glass { beckmann: false, multiscatter: false }));
        let aniso = compiled(
            json!([node("ShaderNodeBsdfAnisotropic", Some("MULTI_GGX"), json!({"Anisotropy": {"value": 0.5}}))]),
            json!([0, "BSDF"]),
        );
        assert!(aniso.warnings.is_empty() && aniso.uses_generated, "{:?}", aniso.warnings);
        assert!(matches!(kinds(&aniso)[0], ClosureKind::Glossy { aniso: Some(_), multiscatter: true, .. }));
        let ashikhmin = compiled(
            json!([node("ShaderNodeBsdfAnisotropic", Some("ASHIKHMIN_SHIRLEY"), json!({}))]),
            json!([0, "BSDF"]),
        );
        assert!(ashikhmin.warnings.is_empty(), "{:?}", ashikhmin.warnings);
        assert!(matches!(kinds(&ashikhmin)[0], ClosureKind::Glossy { ashikhmin: true, beckmann: false, .. }));
        let film = compiled(
            json!([node("ShaderNodeBsdfGlass", None, json!({"Thin Film Thickness": {"value": 300.0}}))]),
            json!([0, "BSDF"]),
        );
        assert!(film.warnings.iter().any(|w| w.contains("thin film")), "{:?}", film.warnings);
        let two = compiled(
            json!([
                node("ShaderNodeBsdfAnisotropic", None, json!({"Anisotropy": {"value": 0.5}})),
                node("ShaderNodeBsdfMetallic", None, json!({"Anisotropy": {"value": 0.5}})),
                {"name": "Add", "type": "ShaderNodeAddShader",
                 "inputs": {"Shader": {"link": [0, "BSDF"]}, "Shader_001": {"link": [1, "BSDF"]}}}
            ]),
            json!([2, "Shader"]),
        );
        // Each closure lies along its own tangent (its own frame in the mixture): no warning.
        assert!(two.warnings.is_empty(), "{:?}", two.warnings);
        let toon = compiled(
            json!([{"name": "T", "type": "ShaderNodeBsdfToon", "props": {"component": "GLOSSY"}, "inputs": {}}]),
            json!([0, "BSDF"]),
        );
        assert!(toon.warnings.is_empty(), "{:?}", toon.warnings);
        assert!(matches!(kinds(&toon)[0], ClosureKind::Toon { glossy: true }));
    }

    /// The walk a graph asks for: a Principled BSDF's subsurface behind a Mix Shader, a
    /// Subsurface Scattering node's (entering at its IOR, Skin from its falloff), none for a
    /// Principled without Subsurface Weight; two that differ are named in a warning.
    /// Curves Info and Volume Info on a surface give Cycles' 0 without a warning (a mesh has
    /// no curve or volume attributes); Curves Info is read per shading point (a strand's
    /// values, `tests/curves.rs`), so the emission is no longer a constant.
    #[test]
    fn curves_and_volume_info_are_zero_on_surfaces() {
        let c = compiled(
            json!([
                {"name": "H", "type": "ShaderNodeHairInfo"},
                {"name": "V", "type": "ShaderNodeVolumeInfo"},
                {"name": "A", "type": "ShaderNodeMath", "props": {"operation": "ADD"},
                 "inputs": {"Value": {"link": [0, "Intercept"]}, "Value_001": {"link": [1, "Density"]}}},
                {"name": "E", "type": "ShaderNodeEmission",
                 "inputs": {"Color": {"link": [0, "Tangent Normal"]}, "Strength": {"link": [2, "Value"]}}}
            ]),
            json!([3, "Emission"]),
        );
        assert!(c.warnings.is_empty(), "{:?}", c.warnings);
        assert!(c.program.reads_curves_info);
        assert_eq!(c.program.constant_emission, None);
    }

    #[test]
    fn graphs_carry_their_subsurface_walk() {
        let mix = |a: usize, b: usize, ka: &str, kb: &str| {
            json!({"name": "Mix", "type": "ShaderNodeMixShader",
                   "inputs": {"Fac": {"value": 0.3}, "Shader": {"link": [a, ka]}, "Shader_001": {"link": [b, kb]}}})
        };
        let principled = json!({"name": "P", "type": "ShaderNodeBsdfPrincipled", "props": {"subsurface_method": "RANDOM_WALK"},
            "inputs": {"Subsurface Weight": {"value": 1.0}, "Subsurface Radius": {"value": [1.0, 0.5, 0.25]},
                       "Subsurface Scale": {"value": 0.2}, "Subsurface IOR": {"value": 1.3}}});
        let diffuse = json!({"name": "D", "type": "ShaderNodeBsdfDiffuse"});
        let c = compiled(json!([principled, diffuse, mix(0, 1, "BSDF", "BSDF")]), json!([2, "Shader"]));
        let s = c.program.subsurface.expect("the Principled's walk");
        assert_eq!(s.radius, [0.2, 0.1, 0.05]);
        assert_eq!((s.ior, s.skin, s.enter_at_ior), (1.3, false, false));

        let sss = json!({"name": "S", "type": "ShaderNodeSubsurfaceScattering", "props": {"falloff": "RANDOM_WALK_SKIN"},
            "inputs": {"Radius": {"value": [2.0, 1.0, 1.0]}, "Scale": {"value": 0.5}, "IOR": {"value": 1.45}}});
        let c = compiled(json!([sss.clone()]), json!([0, "BSSRDF"]));
        let s = c.program.subsurface.expect("the node's walk");
        assert_eq!(s.radius, [1.0, 0.5, 0.5]);
        assert_eq!((s.ior, s.skin, s.enter_at_ior), (1.45, true, true));
        assert!(c.warnings.is_empty(), "{:?}", c.warnings);

        let c = compiled(json!([{"name": "P", "type": "ShaderNodeBsdfPrincipled"}]), json!([0, "BSDF"]));
        assert_eq!(c.program.subsurface, None);

        let c = compiled(json!([principled, sss, mix(0, 1, "BSDF", "BSSRDF")]), json!([2, "Shader"]));
        assert!(c.warnings.iter().any(|w| w.contains("differ from another subsurface closure")), "{:?}", c.warnings);
    }

    /// Attribute nodes read their attribute by key (`Program::attributes`), one slot per key
    /// whichever nodes read it, each slot naming its first reader; a Color Attribute node
    /// without a name reads the render colour; Geometry's Pointiness and Random Per Island take
    /// a slot only where linked; a View Layer attribute folds to constants (Color its RGB, Fac
    /// their average, Alpha its A); an unknown attribute type is refused naming the node.
    #[test]
    fn attributes_compile_to_slots_and_view_layer_constants() {
        use crate::scene::mesh::AttributeKey as K;
        let attribute = |name: &str, kind: &str| {
            json!({"name": format!("{kind}:{name}"), "type": "ShaderNodeAttribute",
                   "props": {"attribute_name": name, "attribute_type": kind}})
        };
        let c = compiled(
            json!([
                attribute("wet", "GEOMETRY"),
                attribute("wet", "GEOMETRY"),
                attribute("tint", "OBJECT"),
                attribute("tint", "INSTANCER"),
                {"name": "Paint", "type": "ShaderNodeVertexColor", "props": {"layer_name": ""}},
                {"name": "Geometry", "type": "ShaderNodeNewGeometry"},
                {"name": "Sum", "type": "ShaderNodeMath", "props": {"operation": "ADD"},
                 "inputs": {"Value": {"link": [0, "Fac"]}, "Value_001": {"link": [1, "Alpha"]}}},
                {"name": "Mix", "type": "ShaderNodeMix", "props": {"data_type": "RGBA"},
                 "inputs": {"Factor_Float": {"link": [5, "Pointiness"]}, "A_Color": {"link": [2, "Color"]},
                            "B_Color": {"link": [3, "Color"]}}},
                {"name": "E", "type": "ShaderNodeEmission",
                 "inputs": {"Color": {"link": [7, "Result_Color"]}, "Strength": {"link": [6, "Value"]}}},
                {"name": "E2", "type": "ShaderNodeEmission", "inputs": {"Strength": {"link": [4, "Alpha"]}}},
                {"name": "Add", "type": "ShaderNodeAddShader",
                 "inputs": {"Shader": {"link": [8, "Emission"]}, "Shader_001": {"link": [9, "Emission"]}}}
            ]),
            json!([10, "Shader"]),
        );
        let keys: Vec<&K> = c.program.attributes.iter().map(|(k, _)| k).collect();
        let want = [
            K::Named("wet".into()),
            K::Object("tint".into()),
            K::Instancer("tint".into()),
            K::RenderColor,
            K::Pointiness,
        ];
        assert_eq!(keys.len(), want.len(), "{keys:?}");
        for k in &want {
            assert!(keys.contains(&k), "{k:?} not in {keys:?}");
        }
        assert!(!keys.contains(&&K::RandomPerIsland), "Random Per Island is not linked");
        let wet = c.program.attributes.iter().find(|(k, _)| *k == K::Named("wet".into())).unwrap();
        assert_eq!(wet.1, "node 'GEOMETRY:wet' (ShaderNodeAttribute)");
        assert!(c.warnings.is_empty(), "{:?}", c.warnings);

        let c = compiled(
            json!([
                {"name": "Layer", "type": "ShaderNodeAttribute",
                 "props": {"attribute_name": "level", "attribute_type": "VIEW_LAYER", "view_layer_value": [0.3, 0.6, 0.9, 0.5]}},
                {"name": "E", "type": "ShaderNodeEmission",
                 "inputs": {"Color": {"link": [0, "Color"]}, "Strength": {"link": [0, "Alpha"]}}}
            ]),
            json!([1, "Emission"]),
        );
        assert!(c.program.attributes.is_empty());
        assert_eq!(c.program.constant_emission, Some(Vec3::new(0.3, 0.6, 0.9) * 0.5));
        let c = compiled(
            json!([
                {"name": "Layer", "type": "ShaderNodeAttribute", "props": {"attribute_name": "level", "attribute_type": "VIEW_LAYER"}},
                {"name": "E", "type": "ShaderNodeEmission", "inputs": {"Strength": {"link": [0, "Fac"]}}}
            ]),
            json!([1, "Emission"]),
        );
        assert_eq!(c.program.constant_emission, Some(Vec3::ZERO));
        assert!(c.warnings.iter().any(|w| w.contains("'Layer'") && w.contains("not in the file")), "{:?}", c.warnings);

        let ext: NodesExt = serde_json::from_value(json!({"version": 1, "nodes": [
            {"name": "Odd", "type": "ShaderNodeAttribute", "props": {"attribute_name": "x", "attribute_type": "SIDEWAYS"}},
            {"name": "E", "type": "ShaderNodeEmission", "inputs": {"Strength": {"link": [0, "Fac"]}}}
        ], "output": {"surface": [1, "Emission"]}}))
        .unwrap();
        let err = compile("m", &ext, &[]).err().expect("an unknown type is refused");
        assert!(err.contains("'Odd'") && err.contains("SIDEWAYS"), "{err}");
    }

    /// More small lobes (five) or Principled BSDFs (three) than a mixture holds in full are not
    /// warned: past the capacity each kind's last slot holds one of them by weight at each point
    /// (`closure::tests::lobes_past_the_capacity_share_the_last_slot`,
    /// `third_principled_is_chosen_by_weight`); the lobes past four used to be dropped, warned.
    #[test]
    fn no_capacity_warning() {
        let mut nodes = Vec::new();
        for k in 0..5 {
            nodes.push(json!({"name": format!("D{k}"), "type": "ShaderNodeBsdfDiffuse"}));
        }
        nodes.push(json!({"name": "P1", "type": "ShaderNodeBsdfPrincipled"}));
        nodes.push(json!({"name": "P2", "type": "ShaderNodeBsdfPrincipled"}));
        nodes.push(json!({"name": "P3", "type": "ShaderNodeBsdfPrincipled"}));
        // Add shaders chaining all eight.
        let mut last = (0usize, "BSDF".to_string());
        for k in 1..8 {
            nodes.push(json!({"name": format!("Add{k}"), "type": "ShaderNodeAddShader",
                "inputs": {"Shader": {"link": [last.0, last.1]}, "Shader_001": {"link": [k, "BSDF"]}}}));
            last = (nodes.len() - 1, "Shader".into());
        }
        let c = compiled(Value::Array(nodes), json!([last.0, last.1]));
        assert!(c.warnings.is_empty(), "{:?}", c.warnings);
    }

    /// Three Principled BSDFs mixed (weights 0.2, 0.3, 0.5 by two Mix Shaders): the first has
    /// its own slot; the second slot weighs 0.8 and holds the second or the third whole (never
    /// an average), the third at a fraction 0.5 / 0.8 of the points. Over 20,000 points that
    /// fraction is within 4.4 standard deviations (sqrt(p (1 - p) / n) = 0.0034: 0.015).
    #[test]
    fn third_principled_is_chosen_by_weight() {
        let bsdf = |name: &str, base: [f32; 3], rough: f32| {
            json!({"name": name, "type": "ShaderNodeBsdfPrincipled", "inputs": {
                "Base Color": {"value": [base[0], base[1], base[2], 1.0]}, "Roughness": {"value": rough}}})
        };
        let c = compiled(
            json!([
                bsdf("A", [0.8, 0.1, 0.1], 0.9),
                bsdf("B", [0.1, 0.8, 0.1], 0.5),
                bsdf("C", [0.1, 0.1, 0.8], 0.1),
                {"name": "M1", "type": "ShaderNodeMixShader", "inputs": {"Fac": {"value": 0.6},
                 "Shader": {"link": [0, "BSDF"]}, "Shader_001": {"link": [1, "BSDF"]}}},
                {"name": "M2", "type": "ShaderNodeMixShader", "inputs": {"Fac": {"value": 0.5},
                 "Shader": {"link": [3, "Shader"]}, "Shader_001": {"link": [2, "BSDF"]}}}
            ]),
            json!([4, "Shader"]),
        );
        let object = ObjectData::default();
        let (n, mut third) = (20_000, 0);
        let mut regs = Vec::new();
        for k in 0..n {
            let mut g = dummy_geom(&object);
            g.p = Vec3::new(k as f32 * 0.013, (k % 97) as f32 * 0.7, 1.0);
            let mut out = Closures::default();
            c.program.run(&g, &mut regs, &mut out);
            assert!((out.pbr_w[0] - 0.2).abs() < 1e-6 && (out.pbr_w[1] - 0.8).abs() < 1e-6, "{:?}", out.pbr_w);
            let p = out.principled_params(1, false);
            let blue = (p.base - crate::math::Rgb::new(0.1, 0.1, 0.8)).abs().max_element() < 1e-6
                && (p.roughness - 0.1).abs() < 1e-6;
            let green = (p.base - crate::math::Rgb::new(0.1, 0.8, 0.1)).abs().max_element() < 1e-6
                && (p.roughness - 0.5).abs() < 1e-6;
            assert!(blue != green, "point {k}: the slot holds an average: {:?} roughness {}", p.base, p.roughness);
            third += blue as usize;
        }
        let f = third as f64 / n as f64;
        assert!((f - 0.625).abs() < 0.015, "the third was chosen at {f} of the points, want 0.625");
    }

    /// A Bump's Filter Width linked to a constant (a Value node, math on it) is that constant,
    /// as Cycles folds it; linked to a value that varies over the surface, the socket's own
    /// value, named in a warning, as Cycles reads it (both measured in Blender 5.0).
    #[test]
    fn a_linked_filter_width_is_read_as_cycles_reads_it() {
        let with_width = |width: Value| {
            compiled(
                json!([
                    {"name": "tc", "type": "ShaderNodeTexCoord"},
                    {"name": "noise", "type": "ShaderNodeTexNoise", "inputs": {"Vector": {"link": [0, "Object"]}}},
                    {"name": "V", "type": "ShaderNodeValue", "props": {"value": 0.5}, "inputs": {}},
                    {"name": "M", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
                     "inputs": {"Value": {"link": [2, "Value"]}, "Value_001": {"value": 2.0}}},
                    {"name": "bump", "type": "ShaderNodeBump",
                     "inputs": {"Height": {"link": [1, "Fac"]}, "Filter Width": width}},
                    {"name": "D", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Normal": {"link": [4, "Normal"]}}}
                ]),
                json!([5, "BSDF"]),
            )
        };
        let width_of = |c: &Compiled| {
            c.program.ops.iter().find_map(|op| if let Op::Bump(b) = op { Some(b.filter_width) } else { None }).unwrap()
        };
        let folded = with_width(json!({"value": 0.1, "link": [3, "Value"]}));
        assert_eq!(width_of(&folded), 1.0);
        assert!(folded.warnings.is_empty(), "{:?}", folded.warnings);
        let varying = with_width(json!({"value": 0.3, "link": [1, "Fac"]}));
        assert_eq!(width_of(&varying), 0.3);
        assert!(varying.warnings.iter().any(|w| w.contains("varies over the surface")), "{:?}", varying.warnings);
        assert_eq!(width_of(&with_width(json!({"value": 0.7}))), 0.7);
    }

    /// EEVEE-only shader nodes are named as such: Cycles leaves them out of its graph, so it
    /// renders nothing of them either.
    #[test]
    fn eevee_only_nodes_are_named_as_eevee_only() {
        let c = compiled(json!([{"name": "S", "type": "ShaderNodeEeveeSpecular", "inputs": {}}]), json!([0, "BSDF"]));
        assert!(
            c.warnings
                .iter()
                .any(|w| w.contains("Specular BSDF is EEVEE-only") && w.contains("Cycles renders nothing")),
            "{:?}",
            c.warnings
        );
    }
}
