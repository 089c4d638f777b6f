//! The instruction set of a compiled shader graph: the operations (`Op`) over the
//! register file, their tables (ramps, curves) and the compiled `Program` that holds
//! them. Evaluation is in `program.rs`.

use super::closure::ClosureOp;
use super::geom::Reg;
use super::image_node::ImageOp;
use super::ops::{Blend, MathOp, RangeInterp, VecOp};
use super::texture_nodes::TexOp;
use super::trace::{AoOp, BevelOp};
use crate::scene::light_path::PathOutput;
use crate::scene::mesh::AttributeKey;
use glam::{Mat3, Mat4, Vec3};

/// Which geometric quantity an `Input` op reads (each in Blender axes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputKind {
    /// World position.
    Position,
    /// Shading normal.
    Normal,
    /// Geometric normal.
    TrueNormal,
    /// Toward the viewer.
    Incoming,
    /// Backfacing as 0/1.
    Backfacing,
    /// Tangent node, UV Map: the mesh's tangent (of `Program::tangent_uv`'s set) made
    /// perpendicular to the shading normal; zero without.
    Tangent,
    /// Tangent node, Radial about axis 0 (X), 1 (Y) or 2 (Z) of the Generated coordinates, and
    /// Geometry's Tangent (radial about Z, Cycles' `primitive_tangent`): to the world by the
    /// object's normal transform, made perpendicular to the shading normal.
    Radial(u8),
    /// Texture coordinates of a set, (u, 1 − v, 0) as Blender's.
    Uv(u8),
    /// Generated: object position in the texture space, or the object's bounds-free fallback.
    Generated,
    /// Object-space position.
    Object,
    /// Object-space position under an explicit world→object matrix (index into `matrices`).
    ObjectMatrix(u32),
    /// Object-space normal.
    ObjectNormal,
    /// The incoming direction (toward the viewer) turned into object space as a normal:
    /// Cycles' implicit Vector of the IES Texture (`LINK_TEXTURE_INCOMING`: Geometry's
    /// Incoming through a world-to-object Normal transform), on a light the direction from
    /// the light toward the lit point in the light's frame.
    ObjectIncoming,
    /// Reflection of the view direction about the normal (world).
    Reflection,
    /// Texture Coordinate Camera: the position in the render camera's space.
    Camera,
    /// Texture Coordinate Window: the position on the render frame, 0..1.
    Window,
    /// COLOR_0 rgb.
    VertexColor,
    /// COLOR_0 alpha.
    VertexAlpha,
    /// Object Info Location.
    ObjectLocation,
    /// Object Info Random.
    ObjectRandom,
    /// Object Info Color.
    ObjectColor,
    /// Object Info Alpha.
    ObjectAlpha,
    /// Geometry Parametric: the point's weights of the triangle's first and second corners
    /// (Cycles' `(1 − u − v, u, 0)`).
    Parametric,
    /// Object Info Object Index (the object's Pass Index).
    ObjectIndex,
    /// Object Info Material Index (the material's Pass Index, `Program::material_index`).
    MaterialIndex,
    /// One output of the Light Path node.
    LightPath(PathOutput),
    /// Point Info Position: the point's centre (Blender axes); 0 off a point.
    PointPosition,
    /// Point Info Radius: the point's radius; 0 off a point.
    PointRadius,
    /// Point Info Random: Cycles' per-point random number; 0 off a point.
    PointRandom,
    /// One output of Curves Info: Cycles' values on a strand, 0 elsewhere (`curves::info`).
    Curve(CurveOutput),
    /// One output of an attribute read by name (`Program::attributes[slot]`): the Attribute
    /// node's, the Color Attribute node's, Geometry's Pointiness and Random Per Island.
    Attribute { slot: u32, out: AttributeOutput },
}

/// Which output of Curves Info an `InputKind::Curve` reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CurveOutput {
    /// Is Strand: 1 on a strand.
    IsStrand,
    /// Intercept: 0 at the root, 1 at the tip.
    Intercept,
    /// Length of the strand.
    Length,
    /// Thickness: twice the radius.
    Thickness,
    /// Tangent Normal (a vector).
    TangentNormal,
    /// Random: Cycles' per-strand number.
    Random,
}

/// Which output of an attribute an `InputKind::Attribute` reads (`scene::mesh::AttributeValue`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AttributeOutput {
    /// Color and Vector.
    Vector,
    /// Fac.
    Fac,
    /// Alpha.
    Alpha,
    /// The Color Attribute node's Alpha: 0 where the attribute is not found (Cycles'
    /// `svm_node_vertex_color`), not the Attribute node's 1.
    ColorAlpha,
}

/// Curve tables' kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CurveKind {
    /// RGB Curves (tables C, R, G, B).
    Rgb,
    /// Vector Curves (X, Y, Z).
    Vector,
    /// Float Curve (one table).
    Float,
}

/// A baked curve mapping (docs/contract.md): tables over `range`.
#[derive(Clone, Debug)]
pub struct CurveTable {
    /// x range of the tables.
    pub range: [f32; 2],
    /// Extrapolate linearly beyond the range (else hold).
    pub extrapolate: bool,
    /// One table of 256 values per curve.
    pub tables: Vec<Vec<f32>>,
}

impl CurveTable {
    /// Curve `i` at x (Cycles' `rgb_ramp_lookup` with extrapolation).
    #[inline]
    pub fn eval(&self, i: usize, x: f32) -> f32 {
        let t = &self.tables[i];
        let n = t.len();
        let span = self.range[1] - self.range[0];
        let f = if span != 0.0 { (x - self.range[0]) / span } else { 0.0 };
        if self.extrapolate && !(0.0..=1.0).contains(&f) && n >= 2 {
            let (t0, dy, d) = if f < 0.0 { (t[0], t[0] - t[1], -f) } else { (t[n - 1], t[n - 1] - t[n - 2], f - 1.0) };
            return t0 + dy * d * (n - 1) as f32;
        }
        lookup(t, f, true)
    }
}

/// Linear interpolation in a table over [0, 1], clamped (Cycles' ramp lookup).
#[inline]
fn lookup(t: &[f32], f: f32, interpolate: bool) -> f32 {
    let n = t.len();
    let f = if f.is_nan() { 0.0 } else { f.clamp(0.0, 1.0) * (n - 1) as f32 };
    let i = (f as usize).min(n - 1);
    let frac = f - i as f32;
    if interpolate && frac > 0.0 && i + 1 < n { t[i] * (1.0 - frac) + t[i + 1] * frac } else { t[i] }
}

/// Mapping node kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(missing_docs)]
pub enum MappingKind {
    Point,
    Texture,
    Vector,
    Normal,
}

/// Colour spaces of Separate/Combine Color.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(missing_docs)]
pub enum ColorSpace {
    Hsv,
    Hsl,
}

/// One operation. Register operands name the first of three registers for vectors.
#[derive(Clone, Debug)]
#[allow(missing_docs)]
pub enum Op {
    Math {
        op: MathOp,
        a: Reg,
        b: Reg,
        c: Reg,
        out: Reg,
        clamp: bool,
    },
    VecMath {
        op: VecOp,
        a: Reg,
        b: Reg,
        c: Reg,
        s: Reg,
        vout: Reg,
        fout: Reg,
    },
    MixFloat {
        fac: Reg,
        a: Reg,
        b: Reg,
        out: Reg,
        clamp: bool,
    },
    /// `fac_vec`: the factor is a vector (non-uniform).
    MixVec {
        fac: Reg,
        fac_vec: bool,
        a: Reg,
        b: Reg,
        out: Reg,
        clamp: bool,
    },
    MixColor {
        blend: Blend,
        fac: Reg,
        a: Reg,
        b: Reg,
        out: Reg,
        clamp_fac: bool,
        clamp_res: bool,
    },
    MapRange {
        interp: RangeInterp,
        vector: bool,
        v: Reg,
        fmin: Reg,
        fmax: Reg,
        tmin: Reg,
        tmax: Reg,
        steps: Reg,
        out: Reg,
        clamp: bool,
    },
    Clamp {
        range: bool,
        v: Reg,
        min: Reg,
        max: Reg,
        out: Reg,
    },
    Ramp {
        table: u32,
        interpolate: bool,
        fac: Reg,
        color: Reg,
        alpha: Reg,
    },
    Curve {
        table: u32,
        kind: CurveKind,
        fac: Reg,
        v: Reg,
        out: Reg,
    },
    Invert {
        fac: Reg,
        c: Reg,
        out: Reg,
    },
    Gamma {
        c: Reg,
        g: Reg,
        out: Reg,
    },
    /// IES Texture: Strength × the profile toward `vector` (the light's frame, Blender axes;
    /// Cycles' `svm_node_ies`); without a profile 100 × Strength, as Cycles for a missing file.
    Ies {
        profile: Option<std::sync::Arc<crate::shader::ies::IesProfile>>,
        vector: Reg,
        strength: Reg,
        out: Reg,
    },
    /// Blackbody: the colour of temperature `t` (kelvin), Cycles' fit clamped at 0.
    Blackbody {
        t: Reg,
        out: Reg,
    },
    /// Wavelength: the colour of wavelength `lambda` (nm), `ops::wavelength_to_rgb`.
    Wavelength {
        lambda: Reg,
        out: Reg,
    },
    /// Wireframe: 1 within `size` / 2 of one of the shaded triangle's edges, else 0 (Cycles'
    /// `wireframe`); with `pixel_size` the size is in pixels, times the ray's footprint.
    Wireframe {
        size: Reg,
        out: Reg,
        pixel_size: bool,
    },
    BrightContrast {
        c: Reg,
        bright: Reg,
        contrast: Reg,
        out: Reg,
    },
    HueSat {
        hue: Reg,
        sat: Reg,
        val: Reg,
        fac: Reg,
        c: Reg,
        out: Reg,
    },
    /// Colour to float (luminance).
    Lum {
        c: Reg,
        out: Reg,
    },
    /// Vector to float (average).
    Avg {
        v: Reg,
        out: Reg,
    },
    /// Float to vector/colour.
    Splat {
        f: Reg,
        out: Reg,
    },
    /// Three floats to a vector.
    Pack {
        x: Reg,
        y: Reg,
        z: Reg,
        out: Reg,
    },
    /// Copy a vector.
    Copy3 {
        src: Reg,
        out: Reg,
    },
    /// RGB to (false) or from (true) HSV/HSL.
    ColorSpace {
        space: ColorSpace,
        to_rgb: bool,
        c: Reg,
        out: Reg,
    },
    /// A geometric quantity.
    Input {
        what: InputKind,
        out: Reg,
    },
    Fresnel {
        ior: Reg,
        n: Option<Reg>,
        out: Reg,
    },
    LayerWeight {
        blend: Reg,
        n: Option<Reg>,
        fresnel: Reg,
        facing: Reg,
    },
    /// `rotation`: the rotation matrix built at load (index into `Program::rotations`)
    /// when the Rotation input is constant.
    Mapping {
        kind: MappingKind,
        v: Reg,
        loc: Reg,
        rot: Reg,
        rotation: Option<u32>,
        scale: Reg,
        out: Reg,
    },
    /// Vector Rotate: `v` turned about `center` by `angle` around `axis` (kind 0), the X, Y
    /// or Z axis (kinds 1-3), or by the Euler angles `rot` (kind 4); `invert` turns back.
    VectorRotate {
        kind: u8,
        invert: bool,
        v: Reg,
        center: Reg,
        axis: Reg,
        angle: Reg,
        rot: Reg,
        out: Reg,
    },
    /// Vector Transform of a point (kind 0), vector (1) or normal (2, normalised after, as
    /// Cycles) between world (0), object (1) and camera (2) space.
    VectorTransform {
        kind: u8,
        from: u8,
        to: u8,
        v: Reg,
        out: Reg,
    },
    /// Normal Map: tangent (0), object (1) or world (2) space.
    NormalMap {
        space: u8,
        strength: Reg,
        color: Reg,
        out: Reg,
    },
    /// Closure weights of a Mix Shader: out1 = w (1 − fac), out2 = w fac.
    MixWeight {
        w: Option<Reg>,
        fac: Reg,
        out1: Reg,
        out2: Reg,
    },
    /// A closure (shader/closure.rs).
    Closure(Box<ClosureOp>),
    /// A procedural texture (shader/texture_nodes.rs).
    Texture(Box<TexOp>),
    /// An Image Texture (shader/image_node.rs).
    Image(Box<ImageOp>),
    /// A Bump node (or the Displacement output as bump).
    Bump(Box<BumpOp>),
    /// An Ambient Occlusion node (shader/trace.rs).
    Ao(Box<AoOp>),
    /// A Bevel node (shader/trace.rs).
    Bevel(Box<BevelOp>),
}

/// A Bump node: the height's operations re-run at two offset positions.
#[derive(Clone, Debug)]
pub struct BumpOp {
    /// Strength register.
    pub strength: Reg,
    /// Distance register.
    pub distance: Reg,
    /// Invert the height.
    pub invert: bool,
    /// The Filter Width: the offsets are this many ray footprints (Cycles reads it when
    /// compiling, so it is a constant).
    pub filter_width: f32,
    /// The height at the shading point.
    pub height: Reg,
    /// The Normal input when linked (Blender axes).
    pub normal: Option<Reg>,
    /// Output normal (Blender axes).
    pub out: Reg,
    /// Operation ranges that compute the height (re-run at the offsets).
    pub sub: Vec<(u32, u32)>,
}

/// A compiled material graph.
#[derive(Clone, Debug, Default)]
pub struct Program {
    /// Material name (messages).
    pub name: String,
    /// Initial register file: constants, zeros elsewhere.
    pub init: Vec<f32>,
    /// The operations in order.
    pub ops: Vec<Op>,
    /// ColorRamp tables (256 RGBA each).
    pub ramps: Vec<Vec<[f32; 4]>>,
    /// Curve tables.
    pub curves: Vec<CurveTable>,
    /// Texture Coordinate object matrices (world → object, glTF axes).
    pub matrices: Vec<Mat4>,
    /// Mapping nodes' rotation matrices, built once when their Rotation is constant.
    pub rotations: Vec<Mat3>,
    /// The scene's working colour space: Blackbody and Wavelength are given in it, colour →
    /// float weighs by its luminance.
    pub space: crate::scene::working_space::WorkingSpace,
    /// The graph has a Transparent part (alpha must be evaluated).
    pub transparent: bool,
    /// A Curves Info node is read, or a Principled Hair BSDF's strand random number: a strand's
    /// shading point then computes it (`curves::info`).
    pub reads_curves_info: bool,
    /// The surface has hair closures (Principled Hair, Hair BSDF): strands are then shaded as
    /// fibres (`curves::shade`), with those closures alone.
    pub hair: bool,
    /// A Transparent BSDF's colour may not be grey: pass-throughs and shadow rays carry it
    /// per channel (`Scene::pass_through`, `Scene::transmission`).
    pub tinted_transparency: bool,
    /// A Principled BSDF's Transmission Weight may be nonzero (linked, or a nonzero constant):
    /// without it and without a Glass closure the graph never shows rough glass.
    pub transmits: bool,
    /// The graph can emit.
    pub emits: bool,
    /// The emission does not depend on the shading point (then it is `constant_emission`).
    pub constant_emission: Option<Vec3>,
    /// The Displacement output's bumped normal (Blender axes), the default closure normal.
    pub displacement_normal: Option<Reg>,
    /// True displacement (method "DISPLACEMENT" or "BOTH"): what the loader moves each mesh
    /// vertex by (`scene::gltf::displace`).
    pub true_displacement: Option<std::sync::Arc<TrueDisplacement>>,
    /// Mesh tangents are read (tangent-space Normal Map, Geometry Tangent), from this UV set.
    pub tangent_uv: Option<u32>,
    /// `ops[..surface_end]` shade the surface; the rest compute only what AOV Output nodes
    /// read, run after them for camera-ray hits (`shader::aov`).
    pub surface_end: usize,
    /// The AOV Output nodes, their inputs' registers after the whole program ran.
    pub aovs: Vec<AovOutput>,
    /// The first Bump, run with its three heights as lanes (`shader::bump_lanes`).
    pub lane_bump: Option<LaneBump>,
    /// The Light Path outputs that change the scattering (BSDFs, transparency,
    /// displacement), not only the emission (`compile::light_path_use`).
    pub scattering_light_path: Vec<PathOutput>,
    /// The subsurface walk the graph's closures ask for (the first such closure's).
    pub subsurface: Option<GraphSubsurface>,
    /// The graph has a Holdout closure: camera rays that reach it lose its weight from the
    /// film's alpha (`ShadingPoint::holdout`).
    pub holdout: bool,
    /// Object Info's Material Index: the material's Pass Index (`CAUSTIC_material_pass`),
    /// set by the loader after compiling.
    pub material_index: f32,
    /// The graph has an Ambient Occlusion or Bevel node: its shading points get the scene's
    /// rays and a seed (`shader::trace`).
    pub traces: bool,
    /// The attributes the graph reads by name (`InputKind::Attribute`'s slots), each with the
    /// node that reads it first (messages: a mesh without it).
    pub attributes: Vec<(AttributeKey, String)>,
}

/// A material's true displacement: the Displacement node's (Height − Midlevel) × Scale computed
/// by a program of its own (the graph compiled for the Displacement output alone), run once at
/// each mesh vertex as Cycles' `GeometryManager::displace` runs the displacement shader.
#[derive(Clone, Debug)]
pub struct TrueDisplacement {
    /// The program; it runs no closures.
    pub program: Program,
    /// The register of the displacement amount along the normal.
    pub height: Reg,
    /// The node's space is Object: the amount is along the object-space normal and scaled by
    /// the object's transform (Cycles' `svm_node_displacement`); else along the world normal.
    pub object_space: bool,
    /// "BOTH": the surface is also bumped in shading (the main program's displacement normal).
    pub bump: bool,
}

/// The subsurface walk a graph's Principled BSDF (with a Subsurface Weight) or Subsurface
/// Scattering node asks for: its parameters are constants, as a material has one walk
/// medium (the loader makes the material's `Subsurface` of it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GraphSubsurface {
    /// Radius × Scale per channel (scene units).
    pub radius: [f32; 3],
    /// Henyey-Greenstein anisotropy.
    pub anisotropy: f32,
    /// The Subsurface IOR (Principled) or the node's IOR.
    pub ior: f32,
    /// Random Walk (Skin).
    pub skin: bool,
    /// The walk enters at `ior` (the Subsurface Scattering node, which has no specular layer),
    /// not at the Principled BSDF's specular layer's IOR.
    pub enter_at_ior: bool,
}

impl Program {
    /// The Light Path node's outputs that shading a surface reads (the AOV Output nodes'
    /// tail, run for camera rays alone, is left out), in program order, repeats included.
    pub fn light_path_outputs(&self) -> impl Iterator<Item = PathOutput> + '_ {
        self.ops[..self.surface_end.min(self.ops.len())].iter().filter_map(|op| match op {
            Op::Input { what: InputKind::LightPath(o), .. } => Some(*o),
            _ => None,
        })
    }

    /// True when the graph's emission may change with the ray that finds it: it emits, not
    /// a constant, and the surface reads the Light Path node (conservatively: the node may
    /// feed only the BSDF or the alpha).
    pub fn emission_reads_light_path(&self) -> bool {
        self.emits && self.constant_emission.is_none() && self.light_path_outputs().next().is_some()
    }

    /// True when a Bump (node or Displacement output) or a Wireframe with Pixel Size reads
    /// the ray's footprint, anywhere in the graph (the AOV Output tail included): the readers
    /// of camera footprints.
    pub fn reads_footprint(&self) -> bool {
        self.ops.iter().any(|op| matches!(op, Op::Bump(_) | Op::Wireframe { pixel_size: true, .. }))
    }
}

/// One AOV Output node of a material.
#[derive(Clone, Debug, PartialEq)]
pub struct AovOutput {
    /// The AOV it writes (Blender's `aov_name`).
    pub name: String,
    /// The node's name (messages).
    pub node: String,
    /// Register of its Color input (three).
    pub color: Reg,
    /// Register of its Value input.
    pub value: Reg,
}

/// Where a program's lane-form Bump sits: `ops[start..at]` in runs of height operations
/// (run in lanes) and others (run at the centre only); the Bump itself is `ops[at]`.
#[derive(Clone, Debug, Default)]
pub struct LaneBump {
    /// The first operation of the Bump's height.
    pub(super) start: usize,
    /// The Bump operation's index.
    pub(super) at: usize,
    /// Consecutive operations `(from, to, height)`, covering `start..at` in order.
    pub(super) runs: Vec<(usize, usize, bool)>,
}

impl LaneBump {
    /// The first Bump among the surface's operations `ops[..end]`, when its height's
    /// operations hold no Bump (a nested one keeps `Program::bump`'s passes).
    pub fn find(ops: &[Op], end: usize) -> Option<LaneBump> {
        let at = ops[..end].iter().position(|op| matches!(op, Op::Bump(_)))?;
        let Op::Bump(b) = &ops[at] else { return None };
        let start = b.sub.first()?.0 as usize;
        let mut in_height = vec![false; at.saturating_sub(start)];
        for &(a, z) in &b.sub {
            let (a, z) = (a as usize, z as usize);
            if z > at || a < start {
                return None;
            }
            if ops[a..z].iter().any(|op| matches!(op, Op::Bump(_))) {
                return None;
            }
            in_height[a - start..z - start].fill(true);
        }
        let mut runs: Vec<(usize, usize, bool)> = Vec::new();
        for (k, &h) in in_height.iter().enumerate() {
            match runs.last_mut() {
                Some(last) if last.2 == h => last.1 = start + k + 1,
                _ => runs.push((start + k, start + k + 1, h)),
            }
        }
        Some(LaneBump { start, at, runs })
    }
}
