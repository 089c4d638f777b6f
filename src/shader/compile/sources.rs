//! Compiling the nodes that read the shading point or the scene: inputs (Texture
//! Coordinate, UV Map, Geometry, Attribute, Fresnel, Layer Weight, Object Info, Point Info),
//! Mapping, Normal Map, Bump, and the texture nodes (procedural and image).

use super::*;
use crate::scene::light_path::PathOutput;
use crate::scene::mesh::AttributeKey;
use crate::shader::instructions::AttributeOutput;
use crate::shader::sky::{Sky, SkyModel, SkyParams};
use crate::shader::trace::{AoOp, BevelOp};

/// The most rays an Ambient Occlusion or Bevel node casts a shading point (Blender's
/// Samples slider stops at 128).
const MAX_TRACE_SAMPLES: u64 = 128;

impl Compiler<'_> {
    /// An Ambient Occlusion or Bevel node's Samples (`default` when absent), at most
    /// `MAX_TRACE_SAMPLES` (more is warned).
    fn samples(&mut self, i: usize, default: u64) -> u32 {
        let n = self.desc(i).props.get("samples").and_then(Value::as_u64).unwrap_or(default);
        if n > MAX_TRACE_SAMPLES {
            self.warn(i, format!("Samples {n} is above Blender's {MAX_TRACE_SAMPLES}: {MAX_TRACE_SAMPLES} are traced"));
        }
        n.min(MAX_TRACE_SAMPLES) as u32
    }

    /// The input that reads output `which` of attribute `key` for node `i` (its slot in
    /// `Program::attributes`, shared by every node reading the key).
    fn attribute_input(&mut self, i: usize, key: AttributeKey, which: AttributeOutput) -> InputKind {
        let slot = match self.prog.attributes.iter().position(|(k, _)| *k == key) {
            Some(s) => s,
            None => {
                let node = format!("node '{}' ({})", self.desc(i).name, self.desc(i).kind);
                self.prog.attributes.push((key, node));
                self.prog.attributes.len() - 1
            }
        };
        InputKind::Attribute { slot: slot as u32, out: which }
    }

    /// An Attribute node of the View Layer type: constants, as Cycles folds them
    /// (`resolve_view_layer_attributes`): the value the add-on looked up on the view layer, the
    /// scene and the world (`view_layer_value`, RGBA; 0 where none has it) gives Color and
    /// Vector its RGB, Fac their average and Alpha its A. Cycles sets a float input linked to
    /// Color to the average too (not the luminance of a colour link): Color is typed a vector
    /// here, whose float conversion is the average.
    fn view_layer_attribute(&mut self, i: usize) -> Result<(), String> {
        let value = match self.desc(i).props.get("view_layer_value") {
            Some(v) => {
                let nums: Option<Vec<f32>> =
                    v.as_array().map(|a| a.iter().filter_map(Value::as_f64).map(|x| x as f32).collect());
                match nums {
                    Some(n) if n.len() == 4 && n.iter().all(|x| x.is_finite()) => Vec4::from_slice(&n),
                    _ => return Err(self.err(i, "view_layer_value must be four finite numbers")),
                }
            }
            None => {
                self.warn(i, "the View Layer attribute's value is not in the file: it gives 0");
                Vec4::ZERO
            }
        };
        let rgb = value.truncate();
        let rgb_reg = self.konst_v(rgb);
        self.alias(i, "Color", rgb_reg, Ty::Vector);
        self.alias(i, "Vector", rgb_reg, Ty::Vector);
        let fac = self.konst_f((rgb.x + rgb.y + rgb.z) / 3.0);
        self.alias(i, "Fac", fac, Ty::Float);
        let alpha = self.konst_f(value.w);
        self.alias(i, "Alpha", alpha, Ty::Float);
        Ok(())
    }

    /// An Image or Environment Texture node's image (None, with a warning: magenta, as
    /// Cycles) and its interpolation.
    fn image_and_interpolation(&mut self, i: usize) -> Result<(Option<u32>, Interp), String> {
        let texture = match self.desc(i).props.get("image").and_then(Value::as_u64) {
            Some(k) => Some(*self.images.get(k as usize).ok_or_else(|| {
                self.err(i, format!("image {k} is not in the graph's images ({})", self.images.len()))
            })?),
            None => {
                self.warn(i, "the node has no image: it gives magenta, as Cycles");
                None
            }
        };
        let interp = match self.prop_str(i, "interpolation", "Linear") {
            "Closest" => Interp::Closest,
            "Linear" => Interp::Linear,
            "Cubic" | "Smart" => Interp::Cubic,
            other => return Err(self.err(i, format!("unknown interpolation '{other}'"))),
        };
        Ok((texture, interp))
    }

    /// An Image Texture node's UDIM tiles (`props.tiles`: [tile number, graph image] pairs) as
    /// (tile number, scene texture) pairs; empty for an image without tiles.
    fn udim_tiles(&self, i: usize) -> Result<Vec<(u32, u32)>, String> {
        let Some(list) = self.desc(i).props.get("tiles") else { return Ok(Vec::new()) };
        let bad = || self.err(i, "tiles must be [tile number 1001..=1100+, image index] pairs".to_string());
        let list = list.as_array().ok_or_else(bad)?;
        list.iter()
            .map(|pair| {
                let pair = pair.as_array().filter(|p| p.len() == 2).ok_or_else(bad)?;
                let number = pair[0].as_u64().filter(|n| (1001..=u32::MAX as u64).contains(n)).ok_or_else(bad)?;
                let k = pair[1].as_u64().ok_or_else(bad)?;
                let texture = *self.images.get(k as usize).ok_or_else(|| {
                    self.err(i, format!("tile image {k} is not in the graph's images ({})", self.images.len()))
                })?;
                Ok((number as u32, texture))
            })
            .collect()
    }

    /// Emits an input, vector or texture node; false for an unknown type.
    pub(super) fn source_node(&mut self, i: usize, kind: &str) -> Result<bool, String> {
        match kind {
            "ShaderNodeTexCoord" => {
                let matrix = self.matrix(i)?;
                for (id, what) in [
                    ("Generated", Some(InputKind::Generated)),
                    ("Normal", Some(InputKind::ObjectNormal)),
                    ("UV", Some(InputKind::Uv(0))),
                    ("Object", Some(matrix.map_or(InputKind::Object, InputKind::ObjectMatrix))),
                    ("Camera", Some(InputKind::Camera)),
                    ("Window", Some(InputKind::Window)),
                    ("Reflection", Some(InputKind::Reflection)),
                ] {
                    if !self.is_used(i, id) {
                        continue;
                    }
                    self.all_const = false;
                    let out = self.out(i, id, Ty::Vector);
                    match what {
                        Some(what) => {
                            if what == InputKind::Generated {
                                self.uses_generated = true;
                            }
                            self.ops.push(Op::Input { what, out });
                        }
                        None => self.warn(i, format!("the {id} output is not supported: it gives 0")),
                    }
                }
            }
            // Curves Info: Cycles' values on a strand (`curves::info`), 0 away from curves (no
            // curve primitive, no curve attributes), as Cycles gives there.
            "ShaderNodeHairInfo" => {
                use crate::shader::instructions::CurveOutput as C;
                for (id, o, ty) in [
                    ("Is Strand", C::IsStrand, Ty::Float),
                    ("Intercept", C::Intercept, Ty::Float),
                    ("Length", C::Length, Ty::Float),
                    ("Thickness", C::Thickness, Ty::Float),
                    ("Tangent Normal", C::TangentNormal, Ty::Vector),
                    ("Random", C::Random, Ty::Float),
                ] {
                    if self.is_used(i, id) {
                        self.all_const = false;
                        let out = self.out(i, id, ty);
                        self.ops.push(Op::Input { what: InputKind::Curve(o), out });
                        self.prog.reads_curves_info = true;
                    }
                }
            }
            // Volume Info away from a volume: 0, as Cycles (volume graphs read it elsewhere).
            "ShaderNodeVolumeInfo" => {
                if self.volume {
                    return Ok(false);
                }
                for (id, ty) in
                    [("Color", Ty::Color), ("Density", Ty::Float), ("Flame", Ty::Float), ("Temperature", Ty::Float)]
                {
                    if self.is_used(i, id) {
                        self.out(i, id, ty);
                    }
                }
            }
            "ShaderNodeLightPath" => {
                self.all_const = false;
                for (id, o) in PathOutput::ALL {
                    if self.is_used(i, id) {
                        let out = self.out(i, id, Ty::Float);
                        self.ops.push(Op::Input { what: InputKind::LightPath(o), out });
                    }
                }
            }
            "ShaderNodeUVMap" => {
                let set = self.tex_coord(i);
                let out = self.out(i, "UV", Ty::Vector);
                self.all_const = false;
                self.ops.push(Op::Input { what: InputKind::Uv(set), out });
            }
            "ShaderNodeNewGeometry" => {
                self.all_const = false;
                for (id, what, ty) in [
                    ("Position", Some(InputKind::Position), Ty::Vector),
                    ("Normal", Some(InputKind::Normal), Ty::Vector),
                    ("Tangent", Some(InputKind::Radial(2)), Ty::Vector),
                    ("True Normal", Some(InputKind::TrueNormal), Ty::Vector),
                    ("Incoming", Some(InputKind::Incoming), Ty::Vector),
                    ("Parametric", Some(InputKind::Parametric), Ty::Vector),
                    ("Backfacing", Some(InputKind::Backfacing), Ty::Float),
                    // Per-vertex and per-face attributes the add-on computes as Cycles' sync does.
                    ("Pointiness", None, Ty::Float),
                    ("Random Per Island", None, Ty::Float),
                ] {
                    if !self.is_used(i, id) {
                        continue;
                    }
                    let out = self.out(i, id, ty);
                    if what == Some(InputKind::Radial(2)) {
                        self.uses_generated = true;
                    }
                    let what = what.unwrap_or_else(|| {
                        let key =
                            if id == "Pointiness" { AttributeKey::Pointiness } else { AttributeKey::RandomPerIsland };
                        self.attribute_input(i, key, AttributeOutput::Fac)
                    });
                    self.ops.push(Op::Input { what, out });
                }
            }
            "ShaderNodeAttribute" | "ShaderNodeVertexColor" => {
                self.all_const = false;
                let name = self.prop_str(i, "attribute_name", self.prop_str(i, "layer_name", "")).to_string();
                let attribute_type = self.prop_str(i, "attribute_type", "GEOMETRY");
                if let Some(set) = self.desc(i).props.get("tex_coord").and_then(Value::as_u64) {
                    // A UV map read as an attribute.
                    for id in ["Vector", "Color"] {
                        if self.is_used(i, id) {
                            let out = self.out(i, id, if id == "Color" { Ty::Color } else { Ty::Vector });
                            self.ops.push(Op::Input { what: InputKind::Uv(set.min(1) as u8), out });
                        }
                    }
                } else if !self.prop_bool(i, "color_0", false) {
                    // Read by name (docs/contract.md, "Attributes"), or a View Layer constant.
                    let key = match (kind, attribute_type) {
                        ("ShaderNodeVertexColor", _) if name.is_empty() => AttributeKey::RenderColor,
                        ("ShaderNodeVertexColor", _) | (_, "GEOMETRY") => AttributeKey::Named(name),
                        (_, "OBJECT") => AttributeKey::Object(name),
                        (_, "INSTANCER") => AttributeKey::Instancer(name),
                        (_, "VIEW_LAYER") => return self.view_layer_attribute(i).map(|()| true),
                        (_, other) => return Err(self.err(i, format!("unknown attribute type '{other}'"))),
                    };
                    let alpha = if kind == "ShaderNodeVertexColor" {
                        AttributeOutput::ColorAlpha
                    } else {
                        AttributeOutput::Alpha
                    };
                    for (id, which, ty) in [
                        ("Color", AttributeOutput::Vector, Ty::Color),
                        ("Vector", AttributeOutput::Vector, Ty::Vector),
                        ("Fac", AttributeOutput::Fac, Ty::Float),
                        ("Alpha", alpha, Ty::Float),
                    ] {
                        if self.is_used(i, id) {
                            let what = self.attribute_input(i, key.clone(), which);
                            let out = self.out(i, id, ty);
                            self.ops.push(Op::Input { what, out });
                        }
                    }
                } else {
                    // `color_0`: the add-on exported this attribute as COLOR_0 by name.
                    for (id, what, ty) in [
                        ("Color", InputKind::VertexColor, Ty::Color),
                        ("Vector", InputKind::VertexColor, Ty::Vector),
                        ("Alpha", InputKind::VertexAlpha, Ty::Float),
                    ] {
                        if self.is_used(i, id) {
                            let out = self.out(i, id, ty);
                            self.ops.push(Op::Input { what, out });
                        }
                    }
                    if self.is_used(i, "Fac") {
                        let c = self.alloc(3);
                        self.ops.push(Op::Input { what: InputKind::VertexColor, out: c });
                        let out = self.out(i, "Fac", Ty::Float);
                        self.ops.push(Op::Avg { v: c, out });
                    }
                }
            }
            "ShaderNodeTangent" => {
                self.all_const = false;
                let what = match self.prop_str(i, "direction_type", "RADIAL") {
                    "UV_MAP" => {
                        let set = self.tex_coord(i) as u32;
                        if *self.prog.tangent_uv.get_or_insert(set) != set {
                            self.warn(i, "a second UV map's tangents: the first one's are read");
                        }
                        InputKind::Tangent
                    }
                    _ => {
                        self.uses_generated = true;
                        InputKind::Radial(match self.prop_str(i, "axis", "Z") {
                            "X" => 0,
                            "Y" => 1,
                            _ => 2,
                        })
                    }
                };
                let out = self.out(i, "Tangent", Ty::Vector);
                self.ops.push(Op::Input { what, out });
            }
            "ShaderNodeWireframe" => {
                self.all_const = false;
                let pixel_size = self.prop_bool(i, "use_pixel_size", false);
                let size = self.float(i, "Size", 0.01)?;
                let out = self.out(i, "Fac", Ty::Float);
                self.ops.push(Op::Wireframe { size, out, pixel_size });
            }
            "ShaderNodeNormal" => {
                // Normal: the node's direction (Blender axes, the add-on's `direction`),
                // normalised; Dot: its dot with the normalised input (Cycles' svm_node_normal).
                let d = self.desc(i).props.get("direction").and_then(Value::as_array).map(|a| {
                    let f = |k: usize| a.get(k).and_then(Value::as_f64).unwrap_or(0.0) as f32;
                    Vec3::new(f(0), f(1), f(2))
                });
                let d = d.unwrap_or(Vec3::Z).normalize_or_zero();
                let dir = self.konst_v(d);
                self.alias(i, "Normal", dir, Ty::Vector);
                if self.is_used(i, "Dot") {
                    let n = self.vec(i, "Normal", Vec3::Z)?;
                    let unit = self.alloc(3);
                    let zero = self.konst_f(0.0);
                    let scratch = self.alloc(1);
                    self.ops.push(Op::VecMath {
                        op: VecOp::Normalize,
                        a: n,
                        b: n,
                        c: n,
                        s: zero,
                        vout: unit,
                        fout: scratch,
                    });
                    let out = self.out(i, "Dot", Ty::Float);
                    let vscratch = self.alloc(3);
                    self.ops.push(Op::VecMath {
                        op: VecOp::Dot,
                        a: dir,
                        b: unit,
                        c: unit,
                        s: zero,
                        vout: vscratch,
                        fout: out,
                    });
                }
            }
            "ShaderNodeFresnel" => {
                let ior = self.float(i, "IOR", 1.5)?;
                let n = self.normal(i, "Normal")?;
                let out = self.out(i, "Fac", Ty::Float);
                self.ops.push(Op::Fresnel { ior, n, out });
            }
            "ShaderNodeLayerWeight" => {
                let blend = self.float(i, "Blend", 0.5)?;
                let n = self.normal(i, "Normal")?;
                let fresnel = self.out(i, "Fresnel", Ty::Float);
                let facing = self.out(i, "Facing", Ty::Float);
                self.ops.push(Op::LayerWeight { blend, n, fresnel, facing });
            }
            "ShaderNodeObjectInfo" => {
                self.all_const = false;
                for (id, ty) in [
                    ("Location", Ty::Vector),
                    ("Random", Ty::Float),
                    ("Color", Ty::Color),
                    ("Alpha", Ty::Float),
                    ("Object Index", Ty::Float),
                    ("Material Index", Ty::Float),
                ] {
                    if !self.is_used(i, id) {
                        continue;
                    }
                    match id {
                        "Location" => {
                            let out = self.out(i, id, ty);
                            self.ops.push(Op::Input { what: InputKind::ObjectLocation, out });
                        }
                        "Random" => {
                            let out = self.out(i, id, ty);
                            self.ops.push(Op::Input { what: InputKind::ObjectRandom, out });
                        }
                        "Color" | "Alpha" => {
                            let out = self.out(i, id, ty);
                            let what = if id == "Color" { InputKind::ObjectColor } else { InputKind::ObjectAlpha };
                            self.ops.push(Op::Input { what, out });
                        }
                        _ => {
                            let out = self.out(i, id, ty);
                            let what =
                                if id == "Object Index" { InputKind::ObjectIndex } else { InputKind::MaterialIndex };
                            self.ops.push(Op::Input { what, out });
                        }
                    }
                }
            }
            "ShaderNodePointInfo" => {
                // Cycles' svm_node_point_info and the ATTR_STD_POINT_RANDOM attribute: the
                // point's centre and radius, its random number; 0 off a point cloud.
                self.all_const = false;
                for (id, what, ty) in [
                    ("Position", InputKind::PointPosition, Ty::Vector),
                    ("Radius", InputKind::PointRadius, Ty::Float),
                    ("Random", InputKind::PointRandom, Ty::Float),
                ] {
                    if self.is_used(i, id) {
                        let out = self.out(i, id, ty);
                        self.ops.push(Op::Input { what, out });
                    }
                }
            }
            "ShaderNodeMapping" => {
                let kind = match self.prop_str(i, "vector_type", "POINT") {
                    "POINT" => MappingKind::Point,
                    "TEXTURE" => MappingKind::Texture,
                    "VECTOR" => MappingKind::Vector,
                    "NORMAL" => MappingKind::Normal,
                    other => return Err(self.err(i, format!("unknown vector type '{other}'"))),
                };
                let v = self.vec(i, "Vector", Vec3::ZERO)?;
                let loc = self.vec(i, "Location", Vec3::ZERO)?;
                let rot = self.vec(i, "Rotation", Vec3::ZERO)?;
                // A constant rotation's matrix (three sin/cos pairs) is built here once.
                let rotation = self.is_const(rot, 3).then(|| {
                    let r = rot as usize;
                    let angles = Vec3::new(self.init[r], self.init[r + 1], self.init[r + 2]);
                    self.prog.rotations.push(crate::shader::program::mapping_rotation(angles));
                    self.prog.rotations.len() as u32 - 1
                });
                let scale = self.vec(i, "Scale", Vec3::ONE)?;
                let out = self.out(i, "Vector", Ty::Vector);
                self.ops.push(Op::Mapping { kind, v, loc, rot, rotation, scale, out });
            }
            "ShaderNodeLightFalloff" => {
                // Cycles' svm_node_light_falloff: Strength times the ray's length to the power
                // 0, 1 and 2, smoothed by length² / (Smooth + length²) when Smooth > 0.
                self.all_const = false;
                let strength = self.float(i, "Strength", 100.0)?;
                let smooth = self.float(i, "Smooth", 0.0)?;
                let len = self.alloc(1);
                self.ops.push(Op::Input { what: InputKind::LightPath(PathOutput::RayLength), out: len });
                let math = |c: &mut Self, op: MathOp, a: Reg, b: Reg| {
                    let out = c.alloc(1);
                    c.ops.push(Op::Math { op, a, b, c: b, out, clamp: false });
                    out
                };
                let squared = math(self, MathOp::Multiply, len, len);
                let smoothless = self.is_const(smooth, 1) && !(self.init[smooth as usize] > 0.0);
                let base = if smoothless {
                    strength
                } else {
                    let wider = math(self, MathOp::Add, smooth, squared);
                    let share = math(self, MathOp::Divide, squared, wider);
                    math(self, MathOp::Multiply, strength, share)
                };
                let linear = math(self, MathOp::Multiply, base, len);
                let constant = math(self, MathOp::Multiply, base, squared);
                self.alias(i, "Quadratic", base, Ty::Float);
                self.alias(i, "Linear", linear, Ty::Float);
                self.alias(i, "Constant", constant, Ty::Float);
            }
            "ShaderNodeCameraData" => {
                // Cycles' svm_node_camera: the point in camera space (Texture Coordinate's
                // Camera, +Z ahead), its direction, its Z and its length.
                self.all_const = false;
                let c = self.alloc(3);
                self.ops.push(Op::Input { what: InputKind::Camera, out: c });
                let z = self.konst_v(Vec3::Z);
                for (id, op, ty) in [
                    ("View Vector", VecOp::Normalize, Ty::Vector),
                    ("View Z Depth", VecOp::Dot, Ty::Float),
                    ("View Distance", VecOp::Length, Ty::Float),
                ] {
                    if !self.is_used(i, id) {
                        continue;
                    }
                    let out = self.out(i, id, ty);
                    let (vout, fout) = if ty == Ty::Vector { (out, self.alloc(1)) } else { (self.alloc(3), out) };
                    self.ops.push(Op::VecMath { op, a: c, b: z, c: z, s: z, vout, fout });
                }
            }
            "ShaderNodeVectorTransform" => {
                let kind = match self.prop_str(i, "vector_type", "VECTOR") {
                    "POINT" => 0,
                    "VECTOR" => 1,
                    "NORMAL" => 2,
                    other => return Err(self.err(i, format!("unknown vector type '{other}'"))),
                };
                let space = |c: &Self, key: &str| match c.prop_str(i, key, "WORLD") {
                    "WORLD" => Ok(0),
                    "OBJECT" => Ok(1),
                    "CAMERA" => Ok(2),
                    other => Err(c.err(i, format!("unknown space '{other}'"))),
                };
                let (from, to) = (space(self, "convert_from")?, space(self, "convert_to")?);
                self.all_const = false;
                let v = self.vec(i, "Vector", Vec3::new(0.5, 0.5, 0.5))?;
                let out = self.out(i, "Vector", Ty::Vector);
                self.ops.push(Op::VectorTransform { kind, from, to, v, out });
            }
            "ShaderNodeVectorRotate" => {
                let kind = match self.prop_str(i, "rotation_type", "AXIS_ANGLE") {
                    "AXIS_ANGLE" => 0,
                    "X_AXIS" => 1,
                    "Y_AXIS" => 2,
                    "Z_AXIS" => 3,
                    "EULER_XYZ" => 4,
                    other => return Err(self.err(i, format!("unknown rotation type '{other}'"))),
                };
                let invert = self.prop_bool(i, "invert", false);
                let v = self.vec(i, "Vector", Vec3::ZERO)?;
                let center = self.vec(i, "Center", Vec3::ZERO)?;
                let axis = self.vec(i, "Axis", Vec3::Z)?;
                let angle = self.float(i, "Angle", 0.0)?;
                let rot = self.vec(i, "Rotation", Vec3::ZERO)?;
                let out = self.out(i, "Vector", Ty::Vector);
                self.ops.push(Op::VectorRotate { kind, invert, v, center, axis, angle, rot, out });
            }
            "ShaderNodeNormalMap" => {
                let space = match self.prop_str(i, "space", "TANGENT") {
                    "TANGENT" => 0,
                    "OBJECT" | "BLENDER_OBJECT" => 1,
                    "WORLD" | "BLENDER_WORLD" => 2,
                    other => return Err(self.err(i, format!("unknown space '{other}'"))),
                };
                if space == 0 {
                    self.prog.tangent_uv = Some(self.tex_coord(i) as u32);
                }
                let strength = self.float(i, "Strength", 1.0)?;
                let color = self.vec(i, "Color", Vec3::new(0.5, 0.5, 1.0))?;
                self.all_const = false;
                let out = self.out(i, "Normal", Ty::Vector);
                self.ops.push(Op::NormalMap { space, strength, color, out });
            }
            "ShaderNodeTexNoise" => {
                let dims = self.noise_dims(i)?;
                let name = self.prop_str(i, "noise_type", "FBM");
                let kind = noise_kind(name).ok_or_else(|| self.err(i, format!("unknown noise type '{name}'")))?;
                let normalize = self.prop_bool(i, "normalize", true);
                let inputs = [
                    self.vec_implicit(i, "Vector", InputKind::Generated)?,
                    self.float(i, "W", 0.0)?,
                    self.float(i, "Scale", 5.0)?,
                    self.float(i, "Detail", 2.0)?,
                    self.float(i, "Roughness", 0.5)?,
                    self.float(i, "Lacunarity", 2.0)?,
                    self.float(i, "Offset", 0.0)?,
                    self.float(i, "Gain", 1.0)?,
                    self.float(i, "Distortion", 0.0)?,
                ];
                let fac = self.out(i, "Fac", Ty::Float);
                // Two of the three fractal sums are the colour's: skipped when unlinked.
                let color = self.out(i, "Color", Ty::Color);
                let color = self.is_used(i, "Color").then_some(color);
                self.ops.push(Op::Texture(Box::new(TexOp::Noise { dims, kind, normalize, inputs, fac, color })));
            }
            "ShaderNodeTexWhiteNoise" => {
                let dims = self.noise_dims(i)?;
                // Unlike the other textures, an unlinked White Noise Vector is not Generated but
                // the socket's value, (0, 0, 0) (Cycles' `SOCKET_IN_POINT(vector, zero)`;
                // measured: Cycles renders the unlinked node one flat colour).
                let vector = self.vec(i, "Vector", Vec3::ZERO)?;
                let w = self.float(i, "W", 0.0)?;
                let value = self.out(i, "Value", Ty::Float);
                let color = self.out(i, "Color", Ty::Color);
                self.ops.push(Op::Texture(Box::new(TexOp::WhiteNoise { dims, vector, w, value, color })));
            }
            "ShaderNodeBump" => {
                let strength = self.float(i, "Strength", 1.0)?;
                let distance = self.float(i, "Distance", 1.0)?;
                let invert = self.prop_bool(i, "invert", false);
                let filter_width = self.filter_width(i)?;
                let normal = self.normal(i, "Normal")?;
                let Some(src) = self.desc(i).inputs.get("Height").and_then(|d| d.link.clone()) else {
                    // An unlinked height is flat: the normal passes through.
                    let out = self.out(i, "Normal", Ty::Vector);
                    let n = match normal {
                        Some(n) => n,
                        None => {
                            let n = self.alloc(3);
                            self.ops.push(Op::Input { what: InputKind::Normal, out: n });
                            n
                        }
                    };
                    self.ops.push(Op::Copy3 { src: n, out });
                    return Ok(true);
                };
                let hmark = self.ops.len();
                let height = self.float(i, "Height", 0.0)?;
                self.all_const = false;
                let out = self.out(i, "Normal", Ty::Vector);
                let mut sub = self.upstream_ranges(src.0);
                // A colour height's conversion to a float lies in this node's range: it is
                // part of the height (without it the offsets would read the centre's value).
                if self.ops.len() > hmark {
                    sub.push((hmark as u32, self.ops.len() as u32));
                }
                self.ops.push(Op::Bump(Box::new(BumpOp {
                    strength,
                    distance,
                    invert,
                    filter_width,
                    height,
                    normal,
                    out,
                    sub,
                })));
            }
            "ShaderNodeAmbientOcclusion" => {
                // Traced at each shading point (`shader::trace`): never folded, as it reads
                // the scene around the point.
                self.all_const = false;
                self.prog.traces = true;
                let samples = self.samples(i, 16);
                let distance_linked = self.desc(i).inputs.get("Distance").is_some_and(|d| d.link.is_some());
                let distance = self.float(i, "Distance", 1.0)?;
                // Cycles' NODE_AO_GLOBAL_RADIUS: an unlinked 0 takes the world's AO distance.
                let global_distance = !distance_linked && self.init[distance as usize] == 0.0;
                let normal = self.normal(i, "Normal")?;
                let color = self.vec(i, "Color", Vec3::ONE)?;
                let color_out = self.out(i, "Color", Ty::Color);
                let ao_out = self.out(i, "AO", Ty::Float);
                self.ops.push(Op::Ao(Box::new(AoOp {
                    samples,
                    inside: self.prop_bool(i, "inside", false),
                    only_local: self.prop_bool(i, "only_local", false),
                    global_distance,
                    distance,
                    normal,
                    color,
                    color_out,
                    ao_out,
                })));
            }
            "ShaderNodeBevel" => {
                // Traced like the AO node (`shader::trace`).
                self.all_const = false;
                self.prog.traces = true;
                let samples = self.samples(i, 8);
                let radius = self.float(i, "Radius", 0.05)?;
                let normal = self.normal(i, "Normal")?;
                let out = self.out(i, "Normal", Ty::Vector);
                self.ops.push(Op::Bevel(Box::new(BevelOp { samples, radius, normal, out })));
            }
            "ShaderNodeDisplacement" => {
                // Linked to the Material Output, it is rendered as bump by `displacement` from
                // its inputs; only another node reading the vector needs it here. Cycles'
                // vector is the normal times (Height − Midlevel) × Scale.
                let read_by_nodes = self.ext.nodes.iter().any(|n| {
                    n.inputs.values().any(|d| d.link.as_ref().is_some_and(|l| l.0 == i && l.1 == "Displacement"))
                });
                if read_by_nodes {
                    let h = self.float(i, "Height", 0.0)?;
                    let mid = self.float(i, "Midlevel", 0.5)?;
                    let scale = self.float(i, "Scale", 1.0)?;
                    let centred = self.alloc(1);
                    self.ops.push(Op::Math { op: MathOp::Subtract, a: h, b: mid, c: mid, out: centred, clamp: false });
                    let amount = self.alloc(1);
                    self.ops.push(Op::Math {
                        op: MathOp::Multiply,
                        a: centred,
                        b: scale,
                        c: scale,
                        out: amount,
                        clamp: false,
                    });
                    let n = self.alloc(3);
                    self.ops.push(Op::Input { what: InputKind::Normal, out: n });
                    let (vout, fout) = (self.out(i, "Displacement", Ty::Vector), self.alloc(1));
                    self.ops.push(Op::VecMath { op: VecOp::Scale, a: n, b: n, c: n, s: amount, vout, fout });
                }
            }
            "ShaderNodeTexVoronoi" => {
                let d = self.prop_str(i, "voronoi_dimensions", "3D");
                let dims = noise_dims(d).ok_or_else(|| self.err(i, format!("unknown dimensions '{d}'")))?;
                let f = self.prop_str(i, "feature", "F1");
                let feature = voronoi_feature(f).ok_or_else(|| self.err(i, format!("unknown feature '{f}'")))?;
                let m = self.prop_str(i, "distance", "EUCLIDEAN");
                let metric = voronoi_metric(m).ok_or_else(|| self.err(i, format!("unknown distance '{m}'")))?;
                let normalize = self.prop_bool(i, "normalize", false);
                let inputs = [
                    self.vec_implicit(i, "Vector", InputKind::Generated)?,
                    self.float(i, "W", 0.0)?,
                    self.float(i, "Scale", 5.0)?,
                    self.float(i, "Detail", 0.0)?,
                    self.float(i, "Roughness", 0.5)?,
                    self.float(i, "Lacunarity", 2.0)?,
                    self.float(i, "Smoothness", 1.0)?,
                    self.float(i, "Exponent", 0.5)?,
                    self.float(i, "Randomness", 1.0)?,
                ];
                let outputs = [
                    self.out(i, "Distance", Ty::Float),
                    self.out(i, "Color", Ty::Color),
                    self.out(i, "Position", Ty::Vector),
                    self.out(i, "W", Ty::Float),
                    self.out(i, "Radius", Ty::Float),
                ];
                // Smooth F1 hashes a colour per cell: skipped when Color is not linked.
                let color = self.is_used(i, "Color");
                let op = TexOp::Voronoi { dims, feature, metric, normalize, color, inputs, outputs };
                self.ops.push(Op::Texture(Box::new(op)));
            }
            "ShaderNodeTexWave" => {
                let (k, b, rg, pr) = (
                    self.prop_str(i, "wave_type", "BANDS"),
                    self.prop_str(i, "bands_direction", "X"),
                    self.prop_str(i, "rings_direction", "X"),
                    self.prop_str(i, "wave_profile", "SIN"),
                );
                let (kind, direction, profile) = wave_settings(k, b, rg, pr)
                    .ok_or_else(|| self.err(i, format!("unknown settings {k}/{b}/{rg}/{pr}")))?;
                let inputs = [
                    self.vec_implicit(i, "Vector", InputKind::Generated)?,
                    self.float(i, "Scale", 5.0)?,
                    self.float(i, "Distortion", 0.0)?,
                    self.float(i, "Detail", 2.0)?,
                    self.float(i, "Detail Scale", 1.0)?,
                    self.float(i, "Detail Roughness", 0.5)?,
                    self.float(i, "Phase Offset", 0.0)?,
                ];
                let fac = self.out(i, "Fac", Ty::Float);
                let color = self.out(i, "Color", Ty::Color);
                self.ops.push(Op::Texture(Box::new(TexOp::Wave { kind, direction, profile, inputs, fac, color })));
            }
            "ShaderNodeTexIES" => {
                // Cycles' IES node reads the Incoming direction in object space by default
                // (`LINK_TEXTURE_INCOMING`): on a light, the direction toward the receiver in
                // the light's frame, also from a sphere light, whose normal differs from it.
                let vector = self.vec_implicit(i, "Vector", InputKind::ObjectIncoming)?;
                let strength = self.float(i, "Strength", 1.0)?;
                let profile = match self.desc(i).props.get("ies_text").and_then(Value::as_str) {
                    Some(text) => Some(std::sync::Arc::new(
                        crate::shader::ies::IesProfile::parse(text)
                            .map_err(|e| self.err(i, format!("its IES profile is malformed: {e}")))?,
                    )),
                    None => {
                        self.warn(i, "it has no IES profile: it gives 100 × Strength, as Cycles for a missing file");
                        None
                    }
                };
                let out = self.out(i, "Fac", Ty::Float);
                self.ops.push(Op::Ies { profile, vector, strength, out });
            }
            "ShaderNodeTexChecker" => {
                let inputs = [
                    self.vec_implicit(i, "Vector", InputKind::Generated)?,
                    self.vec(i, "Color1", Vec3::splat(0.8))?,
                    self.vec(i, "Color2", Vec3::splat(0.2))?,
                    self.float(i, "Scale", 5.0)?,
                ];
                let color = self.out(i, "Color", Ty::Color);
                let fac = self.out(i, "Fac", Ty::Float);
                self.ops.push(Op::Texture(Box::new(TexOp::Checker { inputs, color, fac })));
            }
            "ShaderNodeTexGabor" => {
                let kind = match self.prop_str(i, "gabor_type", "2D") {
                    "2D" => GaborKind::TwoD,
                    "3D" => GaborKind::ThreeD,
                    other => return Err(self.err(i, format!("unknown Gabor type '{other}'"))),
                };
                let inputs = [
                    self.vec_implicit(i, "Vector", InputKind::Generated)?,
                    self.float(i, "Scale", 5.0)?,
                    self.float(i, "Frequency", 2.0)?,
                    self.float(i, "Anisotropy", 1.0)?,
                    self.float(i, "Orientation 2D", std::f32::consts::FRAC_PI_4)?,
                    self.vec(i, "Orientation 3D", Vec3::new(std::f32::consts::SQRT_2, std::f32::consts::SQRT_2, 0.0))?,
                ];
                let outputs = [
                    self.out(i, "Value", Ty::Float),
                    self.out(i, "Phase", Ty::Float),
                    self.out(i, "Intensity", Ty::Float),
                ];
                self.ops.push(Op::Texture(Box::new(TexOp::Gabor { kind, inputs, outputs })));
            }
            "ShaderNodeRadialTiling" => {
                let normalize = match self.desc(i).props.get("normalize") {
                    None => false,
                    Some(Value::Bool(b)) => *b,
                    Some(other) => {
                        return Err(self.err(i, format!("property 'normalize' must be true or false, not {other}")));
                    }
                };
                // Cycles' Vector has no implicit coordinate: unlinked, it is the socket's
                // value (the origin by default), and the node folds to constants.
                let inputs =
                    [self.vec_xy(i, "Vector")?, self.float(i, "Sides", 5.0)?, self.float(i, "Roundness", 0.0)?];
                let outputs = [
                    self.out(i, "Segment Coordinates", Ty::Vector),
                    self.out(i, "Segment ID", Ty::Float),
                    self.out(i, "Segment Width", Ty::Float),
                    self.out(i, "Segment Rotation", Ty::Float),
                ];
                // Coordinates, Width and Rotation come from one computation, the ID from another.
                let used = RadialTilingUse {
                    segment: ["Segment Coordinates", "Segment Width", "Segment Rotation"]
                        .iter()
                        .any(|id| self.is_used(i, id)),
                    segment_id: self.is_used(i, "Segment ID"),
                };
                self.ops.push(Op::Texture(Box::new(TexOp::RadialTiling { normalize, used, inputs, outputs })));
            }
            "ShaderNodeTexGradient" => {
                let g = self.prop_str(i, "gradient_type", "LINEAR");
                let kind = gradient_kind(g).ok_or_else(|| self.err(i, format!("unknown gradient type '{g}'")))?;
                let vector = self.vec_implicit(i, "Vector", InputKind::Generated)?;
                let fac = self.out(i, "Fac", Ty::Float);
                let color = self.out(i, "Color", Ty::Color);
                self.ops.push(Op::Texture(Box::new(TexOp::Gradient { kind, vector, fac, color })));
            }
            "ShaderNodeTexMagic" => {
                let depth = self.desc(i).props.get("turbulence_depth").and_then(Value::as_i64).unwrap_or(2) as i32;
                let inputs = [
                    self.vec_implicit(i, "Vector", InputKind::Generated)?,
                    self.float(i, "Scale", 5.0)?,
                    self.float(i, "Distortion", 1.0)?,
                ];
                let color = self.out(i, "Color", Ty::Color);
                let fac = self.out(i, "Fac", Ty::Float);
                self.ops.push(Op::Texture(Box::new(TexOp::Magic { depth, inputs, color, fac })));
            }
            "ShaderNodeTexBrick" => {
                let num_prop = |c: &Self, k: &str, d: f64| c.desc(i).props.get(k).and_then(Value::as_f64).unwrap_or(d);
                let (offset, offset_frequency) =
                    (num_prop(self, "offset", 0.5) as f32, num_prop(self, "offset_frequency", 2.0) as i32);
                let (squash, squash_frequency) =
                    (num_prop(self, "squash", 1.0) as f32, num_prop(self, "squash_frequency", 2.0) as i32);
                let inputs = [
                    self.vec_implicit(i, "Vector", InputKind::Generated)?,
                    self.vec(i, "Color1", Vec3::splat(0.8))?,
                    self.vec(i, "Color2", Vec3::splat(0.2))?,
                    self.vec(i, "Mortar", Vec3::ZERO)?,
                    self.float(i, "Scale", 5.0)?,
                    self.float(i, "Mortar Size", 0.02)?,
                    self.float(i, "Mortar Smooth", 0.1)?,
                    self.float(i, "Bias", 0.0)?,
                    self.float(i, "Brick Width", 0.5)?,
                    self.float(i, "Row Height", 0.25)?,
                ];
                let color = self.out(i, "Color", Ty::Color);
                let fac = self.out(i, "Fac", Ty::Float);
                let op = TexOp::Brick { offset, offset_frequency, squash, squash_frequency, inputs, color, fac };
                self.ops.push(Op::Texture(Box::new(op)));
            }
            "ShaderNodeTexSky" => {
                let model = match self.prop_str(i, "sky_type", "MULTIPLE_SCATTERING") {
                    "SINGLE_SCATTERING" => SkyModel::Single,
                    "MULTIPLE_SCATTERING" => SkyModel::Multiple,
                    "PREETHAM" => SkyModel::Preetham,
                    "HOSEK_WILKIE" => SkyModel::HosekWilkie,
                    other => return Err(self.err(i, format!("unknown sky type '{other}'"))),
                };
                let vector = self.vec_implicit(i, "Vector", InputKind::Generated)?;
                let color = self.out(i, "Color", Ty::Color);
                let num =
                    |c: &Self, k: &str, d: f64| c.desc(i).props.get(k).and_then(Value::as_f64).unwrap_or(d) as f32;
                let sun_direction = match self.desc(i).props.get("sun_direction") {
                    None => Vec3::Z,
                    Some(v) => {
                        let parts = v
                            .as_array()
                            .filter(|a| a.len() == 3)
                            .and_then(|a| a.iter().map(|x| x.as_f64().map(|x| x as f32)).collect::<Option<Vec<f32>>>());
                        let Some(p) = parts else {
                            return Err(self.err(i, "the sky's sun_direction must be 3 numbers"));
                        };
                        Vec3::new(p[0], p[1], p[2])
                    }
                };
                let params = SkyParams {
                    model,
                    sun_disc: self.prop_bool(i, "sun_disc", true),
                    sun_size: num(self, "sun_size", 0.009_512),
                    sun_intensity: num(self, "sun_intensity", 1.0),
                    sun_elevation: num(self, "sun_elevation", 15f64.to_radians()),
                    sun_rotation: num(self, "sun_rotation", 0.0),
                    altitude: num(self, "altitude", 100.0),
                    air: num(self, "air_density", 1.0),
                    aerosol: num(self, "aerosol_density", 1.0),
                    ozone: num(self, "ozone_density", 1.0),
                    sun_direction,
                    turbidity: num(self, "turbidity", 2.2),
                    ground_albedo: num(self, "ground_albedo", 0.3),
                };
                let finite = [params.sun_size, params.sun_intensity, params.sun_elevation, params.sun_rotation]
                    .into_iter()
                    .chain([params.altitude, params.air, params.aerosol, params.ozone])
                    .chain([params.turbidity, params.ground_albedo])
                    .all(f32::is_finite)
                    && params.sun_direction.is_finite();
                if !finite {
                    return Err(self.err(i, "the sky's settings must be finite numbers"));
                }
                if matches!(model, SkyModel::Preetham | SkyModel::HosekWilkie) {
                    // Blender's ranges: outside them Cycles' fits are undefined (Hosek's
                    // table has no row below turbidity 1).
                    if !(1.0..=10.0).contains(&params.turbidity) || !(0.0..=1.0).contains(&params.ground_albedo) {
                        return Err(
                            self.err(i, "the sky's turbidity must be in [1, 10] and its ground albedo in [0, 1]")
                        );
                    }
                    if params.sun_direction.length_squared() == 0.0 {
                        return Err(self.err(i, "the sky's sun direction must not be zero"));
                    }
                }
                let sky = std::sync::Arc::new(Sky::new_in(&params, self.prog.space));
                self.ops.push(Op::Texture(Box::new(TexOp::Sky { sky, vector, color })));
            }
            "ShaderNodeTexEnvironment" => {
                let (texture, interp) = self.image_and_interpolation(i)?;
                let projection = match self.prop_str(i, "projection", "EQUIRECTANGULAR") {
                    "EQUIRECTANGULAR" => Projection::Equirectangular,
                    "MIRROR_BALL" => Projection::MirrorBall,
                    other => return Err(self.err(i, format!("unknown projection '{other}'"))),
                };
                // On a surface an unlinked vector is the position, as Cycles.
                let vector = self.vec_implicit(i, "Vector", InputKind::Position)?;
                let color = self.out(i, "Color", Ty::Color);
                let alpha = self.out(i, "Alpha", Ty::Float);
                self.all_const = false;
                let op = ImageOp {
                    texture,
                    tiles: Vec::new(),
                    interp,
                    extension: Extension::Repeat,
                    projection,
                    blend: 0.0,
                    vector,
                    normal: vector,
                    color,
                    alpha,
                    alpha_read: self.is_used(i, "Alpha"),
                };
                self.ops.push(Op::Image(Box::new(op)));
            }
            "ShaderNodeTexImage" => {
                let (texture, interp) = self.image_and_interpolation(i)?;
                let extension = match self.prop_str(i, "extension", "REPEAT") {
                    "REPEAT" => Extension::Repeat,
                    "EXTEND" => Extension::Extend,
                    "CLIP" => Extension::Clip,
                    "MIRROR" => Extension::Mirror,
                    other => return Err(self.err(i, format!("unknown extension '{other}'"))),
                };
                let projection = match self.prop_str(i, "projection", "FLAT") {
                    "FLAT" => Projection::Flat,
                    "BOX" => Projection::Box,
                    "SPHERE" => Projection::Sphere,
                    "TUBE" => Projection::Tube,
                    other => return Err(self.err(i, format!("unknown projection '{other}'"))),
                };
                let blend = self.desc(i).props.get("projection_blend").and_then(Value::as_f64).unwrap_or(0.0) as f32;
                let vector = self.vec_implicit(i, "Vector", InputKind::Uv(self.tex_coord(i)))?;
                let normal = if projection == Projection::Box {
                    let n = self.alloc(3);
                    self.ops.push(Op::Input { what: InputKind::ObjectNormal, out: n });
                    n
                } else {
                    vector
                };
                let color = self.out(i, "Color", Ty::Color);
                let alpha = self.out(i, "Alpha", Ty::Float);
                self.all_const = false;
                let tiles = self.udim_tiles(i)?;
                if !tiles.is_empty() && projection != Projection::Flat {
                    self.warn(i, "a UDIM image with a projection other than Flat reads its first tile only");
                }
                let alpha_read = self.is_used(i, "Alpha");
                let op = ImageOp {
                    texture,
                    tiles,
                    interp,
                    extension,
                    projection,
                    blend,
                    vector,
                    normal,
                    color,
                    alpha,
                    alpha_read,
                };
                self.ops.push(Op::Image(Box::new(op)));
            }
            _ => return Ok(false),
        }
        Ok(true)
    }

    pub(super) fn noise_dims(&self, i: usize) -> Result<u8, String> {
        let s = self.prop_str(i, "noise_dimensions", "3D");
        noise_dims(s).ok_or_else(|| self.err(i, format!("unknown dimensions '{s}'")))
    }

    /// The operation ranges of node `i` and every node upstream of it, in program order
    /// (what a Bump re-runs at its offset positions).
    pub(super) fn upstream_ranges(&self, i: usize) -> Vec<(u32, u32)> {
        let mut seen = vec![false; self.ext.nodes.len()];
        let mut stack = vec![i];
        let mut nodes = Vec::new();
        while let Some(n) = stack.pop() {
            if std::mem::replace(&mut seen[n], true) {
                continue;
            }
            nodes.push(n);
            for d in self.ext.nodes[n].inputs.values() {
                if let Some(l) = &d.link {
                    stack.push(l.0);
                }
            }
        }
        let mut ranges: Vec<(u32, u32)> = nodes.into_iter().map(|n| self.ranges[n]).filter(|(a, b)| b > a).collect();
        ranges.sort_unstable();
        // Ranges that meet are one loop for the Bump's re-runs (nodes compiled one after
        // the other are usually adjacent).
        let mut merged: Vec<(u32, u32)> = Vec::with_capacity(ranges.len());
        for (a, b) in ranges {
            match merged.last_mut() {
                Some(last) if last.1 == a => last.1 = b,
                _ => merged.push((a, b)),
            }
        }
        merged
    }
}
