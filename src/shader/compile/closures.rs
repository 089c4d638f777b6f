//! Compiling the Surface output: the closure tree flattened into weights and closure
//! operations, and the Displacement output as bump or as true displacement's height.

use super::*;
use crate::shader::closure::{HairColouring, HairRegs};
use crate::shader::instructions::GraphSubsurface;

impl Compiler<'_> {
    /// The Displacement output: through a Displacement node, (Height − Midlevel) × Scale. As
    /// bump (methods "BUMP" and "BOTH") it is the height of a bump of distance 1 on the shading
    /// normal, which closures without a linked normal take (as Cycles' bump); compiled for true
    /// displacement alone (`height_only`) it is the register the loader moves vertices by.
    pub(super) fn displacement(&mut self, i: usize, out: &str) -> Result<(), String> {
        if self.unknown[i] {
            return Ok(());
        }
        if self.desc(i).kind != "ShaderNodeDisplacement" {
            if !self.height_only {
                self.warn(
                    i,
                    format!("the Displacement output from '{out}' is rendered only through a Displacement node"),
                );
            }
            return Ok(());
        }
        let src = self.desc(i).inputs.get("Height").and_then(|d| d.link.clone());
        // An unlinked height bumps nothing, but still moves the surface by a constant.
        if src.is_none() && !self.height_only {
            return Ok(());
        }
        if !self.height_only && self.desc(i).inputs.get("Normal").is_some_and(|d| d.link.is_some()) {
            self.warn(i, "the Displacement node's Normal input is not read: it displaces along the shading normal");
        }
        let mark = self.ops.len();
        let h = self.float(i, "Height", 0.0)?;
        let mid = self.float(i, "Midlevel", 0.5)?;
        let scale = self.float(i, "Scale", 1.0)?;
        let centred = self.alloc(1);
        self.ops.push(Op::Math { op: MathOp::Subtract, a: h, b: mid, c: mid, out: centred, clamp: false });
        let height = self.alloc(1);
        self.ops.push(Op::Math { op: MathOp::Multiply, a: centred, b: scale, c: scale, out: height, clamp: false });
        let object_space = self.desc(i).props.get("space").and_then(Value::as_str).is_none_or(|s| s == "OBJECT");
        if self.height_only {
            self.displacement_height = Some((height, object_space));
            return Ok(());
        }
        let Some(src) = src else { return Ok(()) };
        if self.method == Method::Displacement {
            return Ok(());
        }
        if !object_space {
            self.warn(i, "world-space displacement is bumped as object-space bump");
        }
        // The bump re-runs the height's nodes and the two operations above.
        let mut sub = self.upstream_ranges(src.0);
        sub.push((mark as u32, self.ops.len() as u32));
        let (one, out_n) = (self.konst_f(1.0), self.alloc(3));
        self.ops.push(Op::Bump(Box::new(BumpOp {
            strength: one,
            distance: one,
            invert: false,
            // Cycles' bump for the Displacement output is a Bump node with its defaults.
            filter_width: super::BUMP_FILTER_WIDTH,
            height,
            normal: None,
            out: out_n,
            sub,
        })));
        self.prog.displacement_normal = Some(out_n);
        Ok(())
    }

    /// Flattens the closure tree under output `out` of node `i` with weight `w`.
    pub(super) fn closure(&mut self, i: usize, out: &str, w: Option<Reg>) -> Result<(), String> {
        if self.closure_ops >= MAX_CLOSURE_OPS {
            self.warn(i, format!("the shader tree has more than {MAX_CLOSURE_OPS} closures: the rest are dropped"));
            return Ok(());
        }
        let kind = self.desc(i).kind.as_str();
        if self.unknown[i] {
            return Ok(());
        }
        if !is_closure_node(kind) {
            // A colour linked to a shader socket: Cycles inserts an Emission of strength 1.
            let s = self.outs[i].iter().find(|(n, _)| n == out).map(|(_, s)| *s);
            let Some(s) = s else {
                return Err(
                    self.err(i, format!("the shader is linked to output '{out}', which the node does not have"))
                );
            };
            let color = self.convert_vec(i, out, s)?;
            let strength = self.konst_f(1.0);
            self.warn(i, "a colour linked to a shader socket emits it, as in Cycles");
            self.push_closure(ClosureKind::Emission, w, color, strength, strength, strength, None);
            return Ok(());
        }
        if out != closure_output(kind) {
            return Err(self.err(i, format!("the shader is linked to output '{out}', which the node does not have")));
        }
        let link = |c: &Self, id: &str| c.desc(i).inputs.get(id).and_then(|d| d.link.clone());
        match kind {
            "ShaderNodeMixShader" => {
                let fac = self.float(i, "Fac", 0.5)?;
                let (out1, out2) = (self.alloc(1), self.alloc(1));
                self.ops.push(Op::MixWeight { w, fac, out1, out2 });
                if let Some(l) = link(self, "Shader") {
                    self.closure(l.0, &l.1, Some(out1))?;
                }
                if let Some(l) = link(self, "Shader_001") {
                    self.closure(l.0, &l.1, Some(out2))?;
                }
            }
            "ShaderNodeAddShader" => {
                for id in ["Shader", "Shader_001"] {
                    if let Some(l) = link(self, id) {
                        self.closure(l.0, &l.1, w)?;
                    }
                }
            }
            "ShaderNodeHoldout" => {
                // No colour; camera rays' alpha loses its weight (`Program::holdout`).
                self.prog.holdout = true;
                let zero = self.konst_f(0.0);
                self.push_closure(ClosureKind::Holdout, w, zero, zero, zero, zero, None);
            }
            "ShaderNodeBsdfPrincipled" => {
                self.principled += 1;
                let p = PrincipledRegs {
                    base: self.vec(i, "Base Color", Vec3::splat(0.8))?,
                    metallic: self.float(i, "Metallic", 0.0)?,
                    roughness: self.float(i, "Roughness", 0.5)?,
                    ior: self.float(i, "IOR", 1.5)?,
                    alpha: self.float(i, "Alpha", 1.0)?,
                    subsurface: self.float(i, "Subsurface Weight", 0.0)?,
                    spec_level: self.float(i, "Specular IOR Level", 0.5)?,
                    spec_tint: self.vec(i, "Specular Tint", Vec3::ONE)?,
                    transmission: self.float(i, "Transmission Weight", 0.0)?,
                    coat: self.float(i, "Coat Weight", 0.0)?,
                    coat_roughness: self.float(i, "Coat Roughness", 0.03)?,
                    coat_ior: self.float(i, "Coat IOR", 1.5)?,
                    coat_tint: self.vec(i, "Coat Tint", Vec3::ONE)?,
                    coat_normal: self.normal(i, "Coat Normal")?,
                    sheen: self.float(i, "Sheen Weight", 0.0)?,
                    sheen_roughness: self.float(i, "Sheen Roughness", 0.5)?,
                    sheen_tint: self.vec(i, "Sheen Tint", Vec3::ONE)?,
                    emission: self.vec(i, "Emission Color", Vec3::ONE)?,
                    emission_strength: self.float(i, "Emission Strength", 0.0)?,
                    thin_film_thickness: self.float(i, "Thin Film Thickness", 0.0)?,
                    thin_film_ior: self.float(i, "Thin Film IOR", 1.33)?,
                    diffuse_roughness: self.float(i, "Diffuse Roughness", 0.0)?,
                    anisotropic: self.float(i, "Anisotropic", 0.0)?,
                    anisotropic_rotation: self.float(i, "Anisotropic Rotation", 0.0)?,
                    tangent: match self.source(i, "Tangent")? {
                        Some(_) => Some(self.vec(i, "Tangent", Vec3::ZERO)?),
                        None => None,
                    },
                    // Blender's "GGX"; "MULTI_GGX" (the default) is compensated.
                    single_scatter: self.prop_str(i, "distribution", "MULTI_GGX") == "GGX",
                };
                let anisotropic = !self.is_const(p.anisotropic, 1) || self.init[p.anisotropic as usize] != 0.0;
                if anisotropic && p.tangent.is_none() {
                    // Cycles' default tangent: radial in the Generated coordinates.
                    self.uses_generated = true;
                }
                if !self.is_const(p.alpha, 1) || self.init[p.alpha as usize] < 1.0 {
                    self.prog.transparent = true;
                }
                if !self.is_const(p.transmission, 1) || self.init[p.transmission as usize] != 0.0 {
                    self.prog.transmits = true;
                }
                if !self.is_const(p.emission_strength, 1) || self.init[p.emission_strength as usize] != 0.0 {
                    self.prog.emits = true;
                }
                if !self.is_const(p.subsurface, 1) || self.init[p.subsurface as usize] > 0.0 {
                    let method = self.prop_str(i, "subsurface_method", "RANDOM_WALK");
                    let ids = ["Subsurface Radius", "Subsurface Scale", "Subsurface Anisotropy", "Subsurface IOR"];
                    self.subsurface(i, ids, method, false)?;
                }
                self.principled_closure(i, p, w)?;
            }
            "ShaderNodeSubsurfaceScattering" => {
                // Cycles' BSSRDF closure of weight and albedo Color: Caustic's Principled with
                // the whole diffuse base below the surface and no specular layer, entering at the
                // node's IOR with its Roughness (Random Walk; Skin's entry is fully rough).
                self.principled += 1;
                let zero = self.konst_f(0.0);
                let one = self.konst_f(1.0);
                let white = self.konst_v(Vec3::ONE);
                let method = self.prop_str(i, "falloff", "RANDOM_WALK");
                let p = PrincipledRegs {
                    base: self.vec(i, "Color", Vec3::splat(0.8))?,
                    metallic: zero,
                    roughness: self.float(i, "Roughness", 1.0)?,
                    ior: self.float(i, "IOR", 1.4)?,
                    alpha: one,
                    subsurface: one,
                    spec_level: zero,
                    spec_tint: white,
                    transmission: zero,
                    coat: zero,
                    coat_roughness: zero,
                    coat_ior: self.konst_f(1.5),
                    coat_tint: white,
                    coat_normal: None,
                    sheen: zero,
                    sheen_roughness: zero,
                    sheen_tint: white,
                    emission: white,
                    emission_strength: zero,
                    thin_film_thickness: zero,
                    thin_film_ior: self.konst_f(1.33),
                    diffuse_roughness: zero,
                    anisotropic: zero,
                    anisotropic_rotation: zero,
                    tangent: None,
                    single_scatter: false,
                };
                self.subsurface(i, ["Radius", "Scale", "Anisotropy", "IOR"], method, true)?;
                self.principled_closure(i, p, w)?;
            }
            "ShaderNodeBsdfHairPrincipled" => self.principled_hair(i, w)?,
            "ShaderNodeBsdfHair" => {
                // Cycles' Hair BSDF: Color, Offset, RoughnessU and RoughnessV in the op's colour,
                // IOR, roughness and strength registers.
                self.prog.hair = true;
                self.hair_lobes += 1;
                let transmission = match self.prop_str(i, "component", "Reflection") {
                    "Reflection" => false,
                    "Transmission" => true,
                    other => return Err(self.err(i, format!("unknown hair component '{other}'"))),
                };
                if self.source(i, "Tangent")?.is_some() {
                    self.warn(i, "the Hair BSDF's Tangent input is not read: strands take their own direction, meshes their dPdv");
                }
                let color = self.vec(i, "Color", Vec3::splat(0.8))?;
                let offset = self.float(i, "Offset", 0.0)?;
                let (u, v) = (self.float(i, "RoughnessU", 0.1)?, self.float(i, "RoughnessV", 1.0)?);
                self.push_closure(ClosureKind::HairLobe { transmission }, w, color, u, offset, v, None);
            }
            _ => self.simple_closure(i, kind, w)?,
        }
        Ok(())
    }

    /// The Principled Hair BSDF (Chiang; the Huang model warned and rendered as Chiang), its
    /// inputs read at each strand point as Cycles' `svm_node_principled_hair` reads them.
    fn principled_hair(&mut self, i: usize, w: Option<Reg>) -> Result<(), String> {
        self.prog.hair = true;
        self.hair_principled += 1;
        if self.prop_str(i, "model", "CHIANG") == "HUANG" {
            self.warn(
                i,
                "the Principled Hair BSDF's Huang model is rendered as the Chiang model (the same colour, roughness, \
                 IOR and offset; no aspect ratio or lobe weights)",
            );
        }
        let colouring = match self.prop_str(i, "parametrization", "COLOR") {
            "ABSORPTION" => HairColouring::Absorption,
            "MELANIN" => HairColouring::Melanin,
            "COLOR" => HairColouring::Color,
            other => return Err(self.err(i, format!("unknown hair parametrization '{other}'"))),
        };
        // Blender's defaults, for the inputs a parametrization hides (they are not written).
        let regs = HairRegs {
            colouring,
            color: self.vec(i, "Color", Vec3::new(0.017513, 0.005763, 0.002059))?,
            melanin: self.float(i, "Melanin", 0.8)?,
            redness: self.float(i, "Melanin Redness", 1.0)?,
            tint: self.vec(i, "Tint", Vec3::ONE)?,
            absorption: self.vec(i, "Absorption Coefficient", Vec3::new(0.245531, 0.52, 1.365))?,
            roughness: self.float(i, "Roughness", 0.3)?,
            radial: self.float(i, "Radial Roughness", 0.3)?,
            coat: self.float(i, "Coat", 0.0)?,
            ior: self.float(i, "IOR", 1.55)?,
            offset: self.float(i, "Offset", 2f32.to_radians())?,
            random_color: self.float(i, "Random Color", 0.0)?,
            random_roughness: self.float(i, "Random Roughness", 0.0)?,
            random: self.float(i, "Random", 0.0)?,
            random_linked: self.source(i, "Random")?.is_some(),
        };
        // Unlinked, Random is the strand's own number (Cycles' ATTR_STD_CURVE_RANDOM).
        if !regs.random_linked {
            self.prog.reads_curves_info = true;
        }
        let zero = self.konst_f(0.0);
        let op = ClosureOp {
            kind: ClosureKind::PrincipledHair(Box::new(regs)),
            w,
            color: zero,
            roughness: zero,
            ior: zero,
            strength: zero,
            normal: None,
        };
        self.ops.push(Op::Closure(Box::new(op)));
        self.closure_ops += 1;
        Ok(())
    }

    /// Records the subsurface walk of node `i` from its inputs `ids` (radius, scale,
    /// anisotropy, IOR) and its `method`: the first closure's is the material's (one walk
    /// medium a material); one that differs, or parameters that vary over the surface, are
    /// named in a warning.
    fn subsurface(&mut self, i: usize, ids: [&str; 4], method: &str, enter_at_ior: bool) -> Result<(), String> {
        let radius = self.vec(i, ids[0], Vec3::new(1.0, 0.2, 0.1))?;
        let scale = self.float(i, ids[1], 0.05)?;
        let anisotropy = self.float(i, ids[2], 0.0)?;
        let ior = self.float(i, ids[3], 1.4)?;
        if !(self.is_const(radius, 3)
            && self.is_const(scale, 1)
            && self.is_const(anisotropy, 1)
            && self.is_const(ior, 1))
        {
            self.warn(
                i,
                "a linked subsurface radius, scale, anisotropy or IOR is rendered at its value where it is \
                 constant, else at Blender's default (a material has one walk medium)",
            );
        }
        let at = |c: &Self, r: Reg, default: f32| if c.is_const(r, 1) { c.init[r as usize] } else { default };
        let default_radius = [1.0, 0.2, 0.1];
        let radius =
            if self.is_const(radius, 3) { [0, 1, 2].map(|k| self.init[radius as usize + k]) } else { default_radius };
        let scale = at(self, scale, 0.05).max(0.0);
        if method == "BURLEY" {
            self.warn(i, "subsurface method Christensen-Burley is rendered as Random Walk");
        }
        let spec = GraphSubsurface {
            radius: radius.map(|r| r.max(0.0) * scale),
            anisotropy: at(self, anisotropy, 0.0),
            ior: at(self, ior, 1.4),
            skin: method == "RANDOM_WALK_SKIN",
            enter_at_ior,
        };
        match self.prog.subsurface {
            None => self.prog.subsurface = Some(spec),
            Some(first) if first != spec => self.warn(
                i,
                "its subsurface parameters differ from another subsurface closure's: the material's walk uses \
                 the first one's (one walk medium a material)",
            ),
            Some(_) => {}
        }
        Ok(())
    }

    /// Pushes the Principled closure `p` of node `i` with weight `w`.
    fn principled_closure(&mut self, i: usize, p: PrincipledRegs, w: Option<Reg>) -> Result<(), String> {
        let normal = self.normal(i, "Normal")?;
        let zero = self.konst_f(0.0);
        let op = ClosureOp {
            kind: ClosureKind::Principled(Box::new(p)),
            w,
            color: zero,
            roughness: zero,
            ior: zero,
            strength: zero,
            normal,
        };
        self.ops.push(Op::Closure(Box::new(op)));
        self.closure_ops += 1;
        Ok(())
    }

    fn simple_closure(&mut self, i: usize, kind: &str, w: Option<Reg>) -> Result<(), String> {
        let zero = self.konst_f(0.0);
        let (ck, color) = match kind {
            "ShaderNodeBsdfDiffuse" => (ClosureKind::Diffuse, self.vec(i, "Color", Vec3::splat(0.8))?),
            "ShaderNodeBsdfGlossy" | "ShaderNodeBsdfAnisotropic" => {
                let dist = self.prop_str(i, "distribution", "MULTI_GGX");
                let aniso = self.aniso(i, AnisoMapping::Glossy)?;
                let (beckmann, multiscatter) = (dist == "BECKMANN", dist == "MULTI_GGX");
                let ashikhmin = dist == "ASHIKHMIN_SHIRLEY";
                (
                    ClosureKind::Glossy {
                        metallic: false,
                        multiscatter,
                        edge_tint: None,
                        extinction: None,
                        beckmann,
                        ashikhmin,
                        aniso,
                        film: None,
                    },
                    self.vec(i, "Color", Vec3::splat(0.8))?,
                )
            }
            "ShaderNodeBsdfMetallic" => {
                let (mut edge_tint, mut extinction) = (None, None);
                let colour = if self.prop_str(i, "fresnel_type", "F82") == "PHYSICAL_CONDUCTOR" {
                    // Blender's defaults; the colour register holds the IOR n, as the lobe's
                    // exact conductor Fresnel takes n and k.
                    extinction = Some(self.vec(i, "Extinction", Vec3::new(3.867, 3.404, 3.009))?);
                    self.vec(i, "IOR", Vec3::new(2.757, 2.513, 2.231))?
                } else {
                    let tint = self.vec(i, "Edge Tint", Vec3::ONE)?;
                    if !self.is_const(tint, 3) || (0..3).any(|k| self.init[tint as usize + k] != 1.0) {
                        edge_tint = Some(tint);
                    }
                    self.vec(i, "Base Color", Vec3::splat(0.8))?
                };
                // Cycles' Metallic BSDF puts its film on either conductor.
                let linked = self.desc(i).inputs.get("Thin Film Thickness").is_some_and(|d| d.link.is_some());
                let thick = self.value(i, "Thin Film Thickness").and_then(Value::as_f64).is_some_and(|v| v > 0.1);
                let film = if linked || thick {
                    Some((self.float(i, "Thin Film Thickness", 0.0)?, self.float(i, "Thin Film IOR", 1.33)?))
                } else {
                    None
                };
                let dist = self.prop_str(i, "distribution", "MULTI_GGX");
                let aniso = self.aniso(i, AnisoMapping::Aspect)?;
                let (beckmann, multiscatter) = (dist == "BECKMANN", dist == "MULTI_GGX");
                (
                    ClosureKind::Glossy {
                        metallic: true,
                        multiscatter,
                        edge_tint,
                        extinction,
                        beckmann,
                        ashikhmin: false,
                        aniso,
                        film,
                    },
                    colour,
                )
            }
            "ShaderNodeBsdfGlass" => {
                let dist = self.prop_str(i, "distribution", "MULTI_GGX");
                self.warn_thin_film(i);
                let kind = ClosureKind::Glass { beckmann: dist == "BECKMANN", multiscatter: dist == "MULTI_GGX" };
                (kind, self.vec(i, "Color", Vec3::ONE)?)
            }
            "ShaderNodeBsdfRefraction" => {
                // Blender's default for this node is Beckmann.
                let beckmann = self.prop_str(i, "distribution", "BECKMANN") == "BECKMANN";
                (ClosureKind::Refraction { beckmann }, self.vec(i, "Color", Vec3::ONE)?)
            }
            "ShaderNodeBsdfTranslucent" => (ClosureKind::Translucent, self.vec(i, "Color", Vec3::splat(0.8))?),
            "ShaderNodeBsdfToon" => {
                let glossy = self.prop_str(i, "component", "DIFFUSE") == "GLOSSY";
                let color = self.vec(i, "Color", Vec3::splat(0.8))?;
                let (size, smooth) = (self.float(i, "Size", 0.5)?, self.float(i, "Smooth", 0.0)?);
                let normal = self.normal(i, "Normal")?;
                self.small_lobes += 1;
                self.push_closure(ClosureKind::Toon { glossy }, w, color, size, zero, smooth, normal);
                return Ok(());
            }
            "ShaderNodeBsdfSheen" => {
                let dist = self.prop_str(i, "distribution", "MICROFIBER");
                let velvet = dist == "ASHIKHMIN";
                if !velvet && dist != "MICROFIBER" {
                    self.warn(i, format!("distribution {dist} is rendered as Microfiber"));
                }
                (ClosureKind::Sheen { velvet }, self.vec(i, "Color", Vec3::splat(0.8))?)
            }
            // Cycles' Ray Portal with its Position and Direction unlinked (the hit point, the
            // ray's own direction: `bsdf_ray_portal_setup`) continues the ray straight on,
            // tinted by its colour, and adds its weight to the transparency shadow rays see:
            // a Transparent BSDF. A linked one would teleport the ray, which is not followed.
            "ShaderNodeBsdfTransparent" | "ShaderNodeBsdfRayPortal" => {
                let linked = |id: &str| self.desc(i).inputs.get(id).is_some_and(|d| d.link.is_some());
                if kind == "ShaderNodeBsdfRayPortal" && (linked("Position") || linked("Direction")) {
                    self.warn(
                        i,
                        "a linked Position or Direction is not followed (rays are not moved): rendered as a \
                         Transparent BSDF, rays continuing straight through",
                    );
                }
                let c = self.vec(i, "Color", Vec3::ONE)?;
                if !self.is_const(c, 3) || {
                    let v = &self.init[c as usize..c as usize + 3];
                    v[0] != v[1] || v[1] != v[2]
                } {
                    self.prog.tinted_transparency = true;
                }
                self.prog.transparent = true;
                (ClosureKind::Transparent, c)
            }
            // A world's Background is its emission (Cycles' background closure: colour × strength).
            "ShaderNodeEmission" | "ShaderNodeBackground" => {
                let c = self.vec(i, "Color", Vec3::ONE)?;
                let s = self.float(i, "Strength", 1.0)?;
                self.prog.emits = true;
                self.push_closure(ClosureKind::Emission, w, c, zero, zero, s, None);
                return Ok(());
            }
            _ => unreachable!("closure kinds are listed in is_closure_node"),
        };
        let roughness = match ck {
            ClosureKind::Glossy { .. } | ClosureKind::Glass { .. } | ClosureKind::Refraction { .. } => {
                self.float(i, "Roughness", 0.5)?
            }
            ClosureKind::Sheen { .. } => self.float(i, "Roughness", 0.5)?,
            // Oren-Nayar's σ (0: Lambertian).
            ClosureKind::Diffuse => self.float(i, "Roughness", 0.0)?,
            _ => zero,
        };
        let ior = if matches!(ck, ClosureKind::Glass { .. } | ClosureKind::Refraction { .. }) {
            self.float(i, "IOR", 1.5)?
        } else {
            zero
        };
        let normal = if matches!(ck, ClosureKind::Transparent) { None } else { self.normal(i, "Normal")? };
        if !matches!(ck, ClosureKind::Transparent) {
            self.small_lobes += 1;
        }
        self.push_closure(ck, w, color, roughness, ior, zero, normal);
        Ok(())
    }

    /// The Anisotropy, Rotation and Tangent inputs of node `i`, or None when its Anisotropy is
    /// a constant that leaves it isotropic; an unlinked Tangent reads Generated coordinates
    /// (Cycles' radial tangent).
    fn aniso(&mut self, i: usize, mapping: AnisoMapping) -> Result<Option<AnisoRegs>, String> {
        let anisotropy = self.float(i, "Anisotropy", 0.0)?;
        if self.is_const(anisotropy, 1) && mapping.widths(1.0, self.init[anisotropy as usize]).is_none() {
            return Ok(None);
        }
        let rotation = self.float(i, "Rotation", 0.0)?;
        let tangent = match self.source(i, "Tangent")? {
            Some(_) => Some(self.vec(i, "Tangent", Vec3::ZERO)?),
            None => {
                self.uses_generated = true;
                None
            }
        };
        Ok(Some(AnisoRegs { anisotropy, rotation, tangent, mapping }))
    }

    /// Names a thin film on a node whose film Caustic does not render.
    fn warn_thin_film(&mut self, i: usize) {
        let linked = self.desc(i).inputs.get("Thin Film Thickness").is_some_and(|d| d.link.is_some());
        let thick = self.value(i, "Thin Film Thickness").and_then(Value::as_f64).is_some_and(|v| v > 0.1);
        if linked || thick {
            self.warn(i, "its thin film is not rendered");
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn push_closure(
        &mut self,
        kind: ClosureKind,
        w: Option<Reg>,
        color: Reg,
        roughness: Reg,
        ior: Reg,
        strength: Reg,
        normal: Option<Reg>,
    ) {
        self.closure_ops += 1;
        self.ops.push(Op::Closure(Box::new(ClosureOp { kind, w, color, roughness, ior, strength, normal })));
    }
}
