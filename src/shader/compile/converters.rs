//! Compiling the converter nodes, which read nothing of the shading point: Math, Vector
//! Math, Mix, Map Range, Clamp, ColorRamp and the curves (their tables), Invert, Gamma,
//! Bright/Contrast, Hue/Saturation/Value, RGB to BW, Separate and Combine (XYZ, colour),
//! Value and RGB. Other kinds go on to `sources.rs`.

use super::*;

impl Compiler<'_> {
    /// Emits a data node's operations; false for an unknown type.
    pub(super) fn data_node(&mut self, i: usize, kind: &str) -> Result<bool, String> {
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
            "ShaderNodeWavelength" => {
                let lambda = self.float(i, "Wavelength", 500.0)?;
                let out = self.out(i, "Color", Ty::Color);
                self.ops.push(Op::Wavelength { lambda, out });
            }
            "ShaderNodeBlackbody" => {
                let t = self.float(i, "Temperature", 1500.0)?;
                let out = self.out(i, "Color", Ty::Color);
                self.ops.push(Op::Blackbody { t, out });
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
