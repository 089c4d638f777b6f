//! A compiled shader graph: a flat list of operations over a register file of f32.
//! Vectors and colours take three consecutive registers; constants (unlinked inputs and
//! the results of nodes whose inputs are all constant) sit in the initial register file,
//! copied in at each evaluation. Evaluation allocates nothing: the register file is a
//! per-thread scratch grown once (`with_registers`).
//!
//! Coordinates inside the program are Blender's (Z up: b = (x, −z, y) of glTF).

// The operations themselves are in `instructions.rs`; the shading point in `geom.rs`.

use super::closure::Closures;
use super::geom::{Geom, Reg, from_blender, geom_at_ng, set3, to_blender, v3};
use super::instructions::{
    AttributeOutput, BumpOp, ColorSpace, CurveKind, CurveOutput, InputKind, MappingKind, Op, Program,
};
use super::ops;
use glam::{EulerRot, Mat3, Mat4, Vec3, Vec4};
use std::cell::RefCell;

thread_local! {
    static REGISTERS: RefCell<Vec<f32>> = const { RefCell::new(Vec::new()) };
    /// A copy of the register file that a Bump's offset evaluations run in.
    static SAVED: RefCell<Vec<f32>> = const { RefCell::new(Vec::new()) };
}

/// Runs `f` with this thread's register file (grown once to the largest program).
pub fn with_registers<R>(f: impl FnOnce(&mut Vec<f32>) -> R) -> R {
    REGISTERS.with(|r| match r.try_borrow_mut() {
        Ok(mut regs) => f(&mut regs),
        // Re-entered (cannot happen in the renderer: evaluation does not recurse): a
        // private file keeps it correct.
        Err(_) => f(&mut Vec::new()),
    })
}

/// Fresnel reflectance of a dielectric for |cos| and relative η (Cycles' fresnel_dielectric_cos).
pub fn fresnel_dielectric_cos(cosi: f32, eta: f32) -> f32 {
    let c = cosi.abs();
    let g = eta * eta - 1.0 + c * c;
    if g > 0.0 {
        let g = g.sqrt();
        let a = (g - c) / (g + c);
        let b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
        0.5 * a * a * (1.0 + b * b)
    } else {
        1.0
    }
}

/// The Mapping node's rotation matrix for Euler angles `rv` (XYZ order, as Blender's).
#[inline]
pub fn mapping_rotation(rv: Vec3) -> Mat3 {
    Mat3::from_euler(EulerRot::ZYX, rv.z, rv.y, rv.x)
}

impl Program {
    /// Evaluates the surface's operations at `g`, leaving closures in `out` (what only AOV
    /// Output nodes read is left to `run_aovs`).
    pub fn run(&self, g: &Geom, regs: &mut Vec<f32>, out: &mut Closures) {
        regs.clear();
        regs.extend_from_slice(&self.init);
        let end = self.surface_end.min(self.ops.len());
        match &self.lane_bump {
            Some(l) => self.run_lanes(l, g, regs, out, end),
            None => self.steps(&self.ops[..end], g, regs, out),
        }
    }

    /// One operation.
    #[inline]
    pub fn step(&self, op: &Op, g: &Geom, r: &mut [f32], out: &mut Closures) {
        self.steps(std::slice::from_ref(op), g, r, out);
    }

    /// Operations in order. The loop stays small: the Math node (the most frequent
    /// operation, cheap but for its function) inline, every other operation in one call
    /// to `dispatch`. Callgrind on `bench/node_graph.py`: a call for every operation cost
    /// ~19 instructions an operation in entry and exit (its big match keeps most registers
    /// saved), and the whole match inlined into this loop spilled the loop's values around
    /// every operation instead (539.0 M instructions; 511.9 M as here).
    pub fn steps(&self, ops: &[Op], g: &Geom, r: &mut [f32], out: &mut Closures) {
        for op in ops {
            match *op {
                Op::Math { op, a, b, c, out, clamp } => {
                    let v = ops::math(op, r[a as usize], r[b as usize], r[c as usize]);
                    r[out as usize] = if clamp { v.clamp(0.0, 1.0) } else { v };
                }
                _ => self.dispatch(op, g, r, out),
            }
        }
    }

    /// The work of one operation (out of line: see `steps`).
    #[inline(never)]
    pub(super) fn dispatch(&self, op: &Op, g: &Geom, r: &mut [f32], out: &mut Closures) {
        match *op {
            Op::Math { op, a, b, c, out, clamp } => {
                let v = ops::math(op, r[a as usize], r[b as usize], r[c as usize]);
                r[out as usize] = if clamp { v.clamp(0.0, 1.0) } else { v };
            }
            Op::VecMath { op, a, b, c, s, vout, fout } => {
                let (v, f) = ops::vector_math(op, v3(r, a), v3(r, b), v3(r, c), r[s as usize]);
                set3(r, vout, v);
                r[fout as usize] = f;
            }
            Op::MixFloat { fac, a, b, out, clamp } => {
                let t = if clamp { r[fac as usize].clamp(0.0, 1.0) } else { r[fac as usize] };
                r[out as usize] = r[a as usize] * (1.0 - t) + r[b as usize] * t;
            }
            Op::MixVec { fac, fac_vec, a, b, out, clamp } => {
                let mut t = if fac_vec { v3(r, fac) } else { Vec3::splat(r[fac as usize]) };
                if clamp {
                    t = t.clamp(Vec3::ZERO, Vec3::ONE);
                }
                set3(r, out, v3(r, a) * (Vec3::ONE - t) + v3(r, b) * t);
            }
            Op::MixColor { blend, fac, a, b, out, clamp_fac, clamp_res } => {
                let t = if clamp_fac { r[fac as usize].clamp(0.0, 1.0) } else { r[fac as usize] };
                let mut c = ops::blend(blend, t, v3(r, a), v3(r, b));
                if clamp_res {
                    c = c.clamp(Vec3::ZERO, Vec3::ONE);
                }
                set3(r, out, c);
            }
            Op::MapRange { interp, vector, v, fmin, fmax, tmin, tmax, steps, out, clamp } => {
                let n = if vector { 3 } else { 1 };
                for k in 0..n {
                    let at = |x: Reg| r[x as usize + k];
                    r[out as usize + k] =
                        ops::map_range(interp, at(v), at(fmin), at(fmax), at(tmin), at(tmax), at(steps), clamp);
                }
            }
            Op::Clamp { range, v, min, max, out } => {
                let (x, lo, hi) = (r[v as usize], r[min as usize], r[max as usize]);
                r[out as usize] = if range && lo > hi { x.max(hi).min(lo) } else { x.max(lo).min(hi) };
            }
            Op::Ramp { table, interpolate, fac, color, alpha } => {
                let t = &self.ramps[table as usize];
                let n = t.len();
                let f = r[fac as usize];
                let f = if f.is_nan() { 0.0 } else { f.clamp(0.0, 1.0) * (n - 1) as f32 };
                let i = (f as usize).min(n - 1);
                let frac = f - i as f32;
                let mut c = Vec4::from(t[i]);
                if interpolate && frac > 0.0 && i + 1 < n {
                    c = c * (1.0 - frac) + Vec4::from(t[i + 1]) * frac;
                }
                set3(r, color, c.truncate());
                r[alpha as usize] = c.w;
            }
            Op::Curve { table, kind, fac, v, out } => {
                let c = &self.curves[table as usize];
                let t = r[fac as usize];
                match kind {
                    CurveKind::Float => {
                        let x = r[v as usize];
                        r[out as usize] = x * (1.0 - t) + c.eval(0, x) * t;
                    }
                    CurveKind::Vector => {
                        let x = v3(r, v);
                        let y = Vec3::new(c.eval(0, x.x), c.eval(1, x.y), c.eval(2, x.z));
                        set3(r, out, x * (1.0 - t) + y * t);
                    }
                    CurveKind::Rgb => {
                        let x = v3(r, v);
                        // The combined curve C first, then each channel's (Blender's order).
                        let y =
                            Vec3::new(c.eval(1, c.eval(0, x.x)), c.eval(2, c.eval(0, x.y)), c.eval(3, c.eval(0, x.z)));
                        set3(r, out, x * (1.0 - t) + y * t);
                    }
                }
            }
            Op::Invert { fac, c, out } => {
                let x = v3(r, c);
                let t = r[fac as usize];
                set3(r, out, x * (1.0 - t) + (Vec3::ONE - x) * t);
            }
            Op::Gamma { c, g, out } => set3(r, out, ops::gamma(v3(r, c), r[g as usize])),
            Op::Blackbody { t, out } => {
                // Cycles clamps after `rec709_to_rgb`, in the working space.
                let rgb = self.space.from_rec709(crate::medium::blackbody::blackbody_rgb(r[t as usize]));
                set3(r, out, rgb.max(glam::Vec3::ZERO))
            }
            Op::Ies { ref profile, vector, strength, out } => {
                let f = profile.as_ref().map_or(100.0, |p| p.eval_direction(v3(r, vector)));
                r[out as usize] = r[strength as usize] * f;
            }
            Op::Wavelength { lambda, out } => set3(r, out, ops::wavelength_to_rgb(r[lambda as usize], &self.space)),
            Op::Wireframe { size, out, pixel_size } => {
                let size = r[size as usize];
                r[out as usize] = wireframe(g, if pixel_size { size * pixel_width(g) } else { size });
            }
            Op::BrightContrast { c, bright, contrast, out } => {
                set3(r, out, ops::bright_contrast(v3(r, c), r[bright as usize], r[contrast as usize]))
            }
            Op::HueSat { hue, sat, val, fac, c, out } => set3(
                r,
                out,
                ops::hue_sat_val(v3(r, c), r[hue as usize], r[sat as usize], r[val as usize], r[fac as usize]),
            ),
            Op::Lum { c, out } => r[out as usize] = self.space.luminance(v3(r, c)),
            Op::Avg { v, out } => {
                let x = v3(r, v);
                r[out as usize] = (x.x + x.y + x.z) / 3.0;
            }
            Op::Splat { f, out } => set3(r, out, Vec3::splat(r[f as usize])),
            Op::Pack { x, y, z, out } => set3(r, out, Vec3::new(r[x as usize], r[y as usize], r[z as usize])),
            Op::Copy3 { src, out } => set3(r, out, v3(r, src)),
            Op::ColorSpace { space, to_rgb, c, out } => {
                let x = v3(r, c);
                let y = match (space, to_rgb) {
                    (ColorSpace::Hsv, true) => ops::hsv_to_rgb(x),
                    (ColorSpace::Hsv, false) => ops::rgb_to_hsv(x),
                    (ColorSpace::Hsl, true) => ops::hsl_to_rgb(x),
                    (ColorSpace::Hsl, false) => ops::rgb_to_hsl(x),
                };
                set3(r, out, y);
            }
            Op::Input { what, out } => self.input(what, g, r, out),
            Op::Fresnel { ior, n, out } => {
                let n = n.map_or(to_blender(g.n), |n| ops::safe_normalize(v3(r, n)));
                let eta = r[ior as usize].max(1e-5);
                let eta = if g.backfacing { 1.0 / eta } else { eta };
                r[out as usize] = fresnel_dielectric_cos(to_blender(g.wo).dot(n), eta);
            }
            Op::LayerWeight { blend, n, fresnel, facing } => {
                let n = n.map_or(to_blender(g.n), |n| ops::safe_normalize(v3(r, n)));
                let b = r[blend as usize];
                let cos = to_blender(g.wo).dot(n);
                let eta = (1.0 - b).max(1e-5);
                let eta = if g.backfacing { eta } else { 1.0 / eta };
                r[fresnel as usize] = fresnel_dielectric_cos(cos, eta);
                let mut f = cos.abs();
                if b != 0.5 {
                    let b = b.clamp(0.0, 1.0 - 1e-5);
                    let b = if b < 0.5 { 2.0 * b } else { 0.5 / (1.0 - b) };
                    f = f.powf(b);
                }
                r[facing as usize] = 1.0 - f;
            }
            Op::VectorTransform { kind, from, to, v, out } => {
                // Through world space in glTF axes: Blender's world and object spaces are
                // its axes, Cycles' camera space is the same in both.
                let apply = |m: Mat4, x: Vec3| if kind == 0 { m.transform_point3(x) } else { m.transform_vector3(x) };
                let x = v3(r, v);
                let world = match from {
                    0 => from_blender(x),
                    1 => apply(g.object.world_to_object.inverse(), from_blender(x)),
                    _ => apply(g.view.world_to_camera.inverse(), x),
                };
                let y = match to {
                    0 => to_blender(world),
                    1 => to_blender(apply(g.object.world_to_object, world)),
                    _ => apply(g.view.world_to_camera, world),
                };
                set3(r, out, if kind == 2 { ops::safe_normalize(y) } else { y });
            }
            Op::VectorRotate { kind, invert, v, center, axis, angle, rot, out } => {
                let (x, c) = (v3(r, v), v3(r, center));
                let y = if kind == 4 {
                    let m = mapping_rotation(v3(r, rot));
                    (if invert { m.transpose() } else { m }) * (x - c) + c
                } else {
                    let a = match kind {
                        1 => Vec3::X,
                        2 => Vec3::Y,
                        3 => Vec3::Z,
                        _ => v3(r, axis),
                    };
                    let len = a.length();
                    let angle = if invert { -r[angle as usize] } else { r[angle as usize] };
                    if len != 0.0 { ops::rotate_around_axis(x - c, a / len, angle) + c } else { x }
                };
                set3(r, out, y);
            }
            Op::Mapping { kind, v, loc, rot, rotation, scale, out } => {
                let x = v3(r, v);
                let m = match rotation {
                    Some(k) => self.rotations[k as usize],
                    None => mapping_rotation(v3(r, rot)),
                };
                let s = v3(r, scale);
                let sdiv = |a: Vec3, b: Vec3| {
                    Vec3::new(ops::safe_divide(a.x, b.x), ops::safe_divide(a.y, b.y), ops::safe_divide(a.z, b.z))
                };
                let y = match kind {
                    MappingKind::Point => m * (x * s) + v3(r, loc),
                    MappingKind::Texture => sdiv(m.transpose() * (x - v3(r, loc)), s),
                    MappingKind::Vector => m * (x * s),
                    MappingKind::Normal => ops::safe_normalize(m * sdiv(x, s)),
                };
                set3(r, out, y);
            }
            Op::NormalMap { space, strength, color, out } => {
                let c = v3(r, color) * 2.0 - Vec3::ONE;
                let n = to_blender(g.n);
                let s = r[strength as usize];
                // Cycles (since 4.1) applies a tangent-space map's Strength in tangent space:
                // x and y scaled by it, z from 1 towards the map's by it clamped to [0, 1];
                // other spaces (and a tangent map without tangents) blend with the normal.
                let mut blend = true;
                let mapped = match space {
                    0 => {
                        let t = g.tangent.truncate();
                        if t.length_squared() > 0.0 {
                            // The tangent frame belongs to the front face.
                            let side = if g.backfacing { -1.0 } else { 1.0 };
                            let nf = g.n * side;
                            let tf = (t - nf * nf.dot(t)).normalize_or_zero();
                            let bf = nf.cross(tf) * if g.tangent.w < 0.0 { -1.0 } else { 1.0 };
                            let z = 1.0 + (c.z - 1.0) * s.clamp(0.0, 1.0);
                            blend = false;
                            to_blender((tf * (c.x * s) + bf * (c.y * s) + nf * z) * side)
                        } else {
                            n
                        }
                    }
                    1 => {
                        // Object-space normals reach the world by the transposed world→object matrix.
                        let m = g.object.world_to_object.transpose();
                        to_blender(m.transform_vector3(from_blender(c)))
                    }
                    _ => c,
                };
                // Cycles negates an object- or world-space normal on a back face (the tangent
                // case is built on the front face and turned above).
                let mapped = if space != 0 && g.backfacing { -mapped } else { mapped };
                let mapped = ops::safe_normalize(mapped);
                let y = if blend { ops::safe_normalize(n + (mapped - n) * s.max(0.0)) } else { mapped };
                set3(r, out, if y == Vec3::ZERO { n } else { y });
            }
            Op::MixWeight { w, fac, out1, out2 } => {
                let wv = w.map_or(1.0, |w| r[w as usize]);
                let t = r[fac as usize].clamp(0.0, 1.0);
                r[out1 as usize] = wv * (1.0 - t);
                r[out2 as usize] = wv * t;
            }
            Op::Closure(ref c) => c.apply(r, g, out),
            Op::Texture(ref t) => t.run(r),
            Op::Image(ref t) => t.run(r, g.textures),
            Op::Bump(ref b) => self.bump(b, g, r, out),
            Op::Ao(ref a) => a.run(g, r),
            Op::Bevel(ref b) => b.run(g, r),
        }
    }

    /// The Bump node: Cycles' surface-gradient formula (`svm_node_set_bump`) with the
    /// heights at P + dx and P + dy, dx and dy an orthogonal pair in the triangle's plane
    /// as long as the ray's footprint times the Filter Width (`bump_offsets`): N' =
    /// normalize(N − Distance ∇h) blended with N by Strength, ∇h the finite difference
    /// over that step, which smooths away height detail finer than the footprint as
    /// Cycles' does.
    fn bump(&self, b: &BumpOp, g: &Geom, r: &mut [f32], out: &mut Closures) {
        let Some(off) = bump_offsets(g, b.filter_width) else {
            return self.bump_finish(b, g, r, None);
        };
        let run_sub = |g2: &Geom, r: &mut [f32], out: &mut Closures| {
            for &(a, z) in &b.sub {
                self.steps(&self.ops[a as usize..z as usize], g2, r, out);
            }
        };
        let mut h = [0.0f32; 2];
        // The offset runs go to a copy of the register file, so the height's registers
        // keep their centre values without a restore (one copy of the file instead of
        // two; the second offset overwrites what the first wrote, as it did in place).
        // A nested bump, whose copy is in use, runs in place and re-runs the centre.
        let copied = SAVED.with(|s| {
            let Ok(mut s) = s.try_borrow_mut() else { return false };
            s.clear();
            s.extend_from_slice(r);
            for (k, g2) in off.geom.iter().enumerate() {
                run_sub(g2, &mut s, out);
                h[k] = s[b.height as usize];
            }
            true
        });
        if !copied {
            for (k, g2) in off.geom.iter().enumerate() {
                run_sub(g2, r, out);
                h[k] = r[b.height as usize];
            }
            run_sub(g, r, out);
        }
        self.bump_finish(b, g, r, Some((off.d, h)));
    }

    /// The Bump node's normal from the heights `h` at the offsets `d` (None: a degenerate
    /// triangle, where the input normal passes through).
    pub(super) fn bump_finish(&self, b: &BumpOp, g: &Geom, r: &mut [f32], offsets: Option<([Vec3; 2], [f32; 2])>) {
        let n_in = b.normal.map_or(g.n, |n| from_blender(v3(r, n)).normalize_or(g.n));
        let hc = r[b.height as usize];
        let mut result = n_in;
        if let Some(([dx, dy], h)) = offsets {
            let rx = dy.cross(n_in);
            let ry = n_in.cross(dx);
            let det = dx.dot(rx);
            let surfgrad = (h[0] - hc) * rx + (h[1] - hc) * ry;
            let dist = r[b.distance as usize] * if b.invert { -1.0 } else { 1.0 };
            let bumped = (det.abs() * n_in - dist * det.signum() * surfgrad).normalize_or(n_in);
            let s = r[b.strength as usize].clamp(0.0, 1.0);
            result = (s * bumped + (1.0 - s) * n_in).normalize_or(n_in);
        }
        set3(r, b.out, to_blender(result));
    }

    fn input(&self, what: InputKind, g: &Geom, r: &mut [f32], out: Reg) {
        let obj = g.object;
        let v = match what {
            InputKind::Position => to_blender(g.p),
            InputKind::Normal => to_blender(g.n),
            InputKind::TrueNormal => to_blender(g.ng),
            InputKind::Incoming => to_blender(g.wo),
            InputKind::Backfacing => {
                r[out as usize] = g.backfacing as u8 as f32;
                return;
            }
            InputKind::Tangent => {
                let t = g.tangent.truncate();
                if t == Vec3::ZERO { Vec3::ZERO } else { to_blender(perpendicular(t, g.n)) }
            }
            InputKind::Radial(axis) => to_blender(g.radial_tangent(axis)),
            InputKind::Uv(set) => {
                let uv = g.uv[set.min(1) as usize];
                Vec3::new(uv.x, 1.0 - uv.y, 0.0)
            }
            InputKind::Object => to_blender(obj.world_to_object.transform_point3(g.p)),
            InputKind::ObjectMatrix(i) => to_blender(self.matrices[i as usize].transform_point3(g.p)),
            InputKind::Generated => g.generated(),
            InputKind::ObjectNormal => {
                // Normals go to object space by the inverse transpose of world→object.
                let m = obj.world_to_object.inverse().transpose();
                to_blender(m.transform_vector3(g.n).normalize_or_zero())
            }
            InputKind::ObjectIncoming => {
                let m = obj.world_to_object.inverse().transpose();
                to_blender(m.transform_vector3(g.wo).normalize_or_zero())
            }
            InputKind::Reflection => {
                let n = g.n;
                to_blender(2.0 * n.dot(g.wo) * n - g.wo)
            }
            // Camera space and the frame are the same in both axis conventions.
            InputKind::Camera => g.view.camera(g.p),
            InputKind::Window => g.view.window(g.p),
            InputKind::VertexColor => g.color.truncate(),
            InputKind::VertexAlpha => {
                r[out as usize] = g.color.w;
                return;
            }
            InputKind::ObjectLocation => to_blender(obj.location),
            InputKind::ObjectRandom => {
                r[out as usize] = obj.random;
                return;
            }
            InputKind::ObjectColor => obj.color.truncate(),
            InputKind::ObjectAlpha => {
                r[out as usize] = obj.color.w;
                return;
            }
            InputKind::Parametric => parametric(g),
            InputKind::ObjectIndex => {
                r[out as usize] = obj.pass_index;
                return;
            }
            InputKind::MaterialIndex => {
                r[out as usize] = self.material_index;
                return;
            }
            InputKind::LightPath(o) => {
                r[out as usize] = g.path.output(o);
                return;
            }
            InputKind::PointPosition => g.point.map_or(Vec3::ZERO, |p| to_blender(p.centre)),
            InputKind::PointRadius => {
                r[out as usize] = g.point.map_or(0.0, |p| p.radius);
                return;
            }
            InputKind::PointRandom => {
                r[out as usize] = g.point.map_or(0.0, |p| p.random);
                return;
            }
            InputKind::Curve(o) => {
                let c = g.curve;
                if o == CurveOutput::TangentNormal {
                    c.map_or(Vec3::ZERO, |c| to_blender(c.tangent_normal))
                } else {
                    r[out as usize] = c.map_or(0.0, |c| match o {
                        CurveOutput::IsStrand => 1.0,
                        CurveOutput::Intercept => c.intercept,
                        CurveOutput::Length => c.length,
                        CurveOutput::Thickness => c.thickness,
                        _ => c.random,
                    });
                    return;
                }
            }
            InputKind::Attribute { slot, out: which } => {
                let found = match g.grid_values {
                    Some(values) => values.get(slot as usize).copied().flatten(),
                    None => self.attributes.get(slot as usize).and_then(|(key, _)| g.attribute(key)),
                };
                let a = found.unwrap_or(crate::scene::mesh::NOT_FOUND);
                match which {
                    AttributeOutput::Vector => a.vector,
                    AttributeOutput::Fac => {
                        r[out as usize] = a.fac;
                        return;
                    }
                    AttributeOutput::Alpha => {
                        r[out as usize] = a.alpha;
                        return;
                    }
                    AttributeOutput::ColorAlpha => {
                        r[out as usize] = found.map_or(0.0, |a| a.alpha);
                        return;
                    }
                }
            }
        };
        set3(r, out, v);
    }
}

/// Cycles' `cross(N, normalize(cross(t, N)))`: `t` made perpendicular to the normal `n`, unit
/// (0 where `t` is along `n`).
fn perpendicular(t: Vec3, n: Vec3) -> Vec3 {
    n.cross(t.cross(n).normalize_or_zero())
}

/// One pixel's width at `g` for the Wireframe node's Pixel Size, as Cycles measures it: the
/// compact differential `sd->dP` (the ray's footprint; for a path from a light, the camera's
/// footprint at the point) spread along `make_orthonormals(Ng)`'s two axes, each projected on
/// the plane facing the viewer, their lengths averaged (`svm_wireframe.h`).
fn pixel_width(g: &Geom) -> f32 {
    let footprint = g.path.footprint_radius().unwrap_or_else(|| g.view.footprint_at(g.p));
    let Some(&[i0, i1, i2]) = g.mesh.triangles.get(g.tri as usize) else {
        return footprint;
    };
    let m = g.mesh;
    let p0 = m.positions[i0 as usize];
    let ng = (m.positions[i1 as usize] - p0).cross(m.positions[i2 as usize] - p0).normalize_or(Vec3::Z);
    let (ex, ey) = cycles_orthonormals(to_blender(if ng.dot(g.ng) < 0.0 { -ng } else { ng }));
    let wi = to_blender(g.wo);
    let across = |e: Vec3| (1.0 - e.dot(wi).powi(2)).max(0.0).sqrt();
    footprint * 0.5 * (across(ex) + across(ey))
}

/// The Wireframe node's Fac at `g` for a width `size` in scene units (Cycles' `wireframe`): 1 where the
/// point lies within `size` / 2 of one of its triangle's three edges (the triangulated mesh's,
/// as Cycles), each neighbour drawing its own half; 0 off a triangle (a strand).
fn wireframe(g: &Geom, size: f32) -> f32 {
    let Some(&[i0, i1, i2]) = g.mesh.triangles.get(g.tri as usize) else {
        return 0.0;
    };
    let co = [i0, i1, i2].map(|i| g.mesh.positions[i as usize]);
    let half = 0.5 * size;
    let width2 = half * half;
    for i in 0..3 {
        let i2 = if i > 0 { i - 1 } else { 2 };
        let (dir, edge) = (g.p - co[i], co[i] - co[i2]);
        let crs = edge.cross(dir);
        // |crs|² / |edge|² is the squared distance to the edge's line.
        if crs.dot(crs) < edge.dot(edge) * width2 {
            return 1.0;
        }
    }
    0.0
}

/// Geometry Parametric at `g`: Cycles' `(1 − u − v, u, 0)` for its hit barycentrics (u, v) on
/// the triangle's corners a, b, c (P = a + u (b − a) + v (c − a)), i.e. the weights of the
/// first and second corners, which keep Blender's corner order through the glTF file. They
/// are solved from the point (the least-squares solution in the triangle's plane); 0 off a
/// triangle (a strand).
fn parametric(g: &Geom) -> Vec3 {
    let Some(&[i0, i1, i2]) = g.mesh.triangles.get(g.tri as usize) else {
        return Vec3::ZERO;
    };
    let m = g.mesh;
    let p0 = m.positions[i0 as usize];
    let (e1, e2, d) = (m.positions[i1 as usize] - p0, m.positions[i2 as usize] - p0, g.p - p0);
    let (a, b, c) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d1, d2) = (d.dot(e1), d.dot(e2));
    let det = a * c - b * b;
    if !(det > 0.0) {
        return Vec3::ZERO;
    }
    let u = (c * d1 - b * d2) / det;
    let v = (a * d2 - b * d1) / det;
    Vec3::new(1.0 - u - v, u, 0.0)
}

/// The Bump node's two offset points: the offsets `d` in the triangle's plane and the
/// shading point there.
pub(super) struct BumpOffsets<'a> {
    pub d: [Vec3; 2],
    pub geom: [Geom<'a>; 2],
}

/// The length of a Bump's offsets at `g`: the ray's footprint there (Cycles' compact
/// differential `sd->dP`; for a path from a light, the camera's footprint at the point)
/// times the Filter Width `fw`, as Cycles offsets by `dP.dx × fw`. The fixed 10⁻⁴ of
/// max(1, |P|) (above f32's resolution of P, below any texture detail) is the floor where
/// the footprint is zero or not finite (no camera: shading without a ray, tests). None
/// for a Filter Width ≤ 0, where Cycles' normal is the input normal (its gradient is 0).
pub fn bump_step(g: &Geom, fw: f32) -> Option<f32> {
    if !(fw > 0.0) {
        return None;
    }
    let floor = 1e-4 * g.p.abs().max_element().max(1.0);
    let footprint = g.path.footprint_radius().unwrap_or_else(|| g.view.footprint_at(g.p));
    let step = footprint * fw;
    Some(if step.is_finite() { step.max(floor) } else { floor })
}

/// The points at which a Bump of Filter Width `fw` evaluates its height besides `g`
/// (`Program::bump`'s pair, `bump_step` long); None for a degenerate triangle, a point
/// without one, or a Filter Width ≤ 0.
pub(super) fn bump_offsets<'a>(g: &Geom<'a>, fw: f32) -> Option<BumpOffsets<'a>> {
    let eps = bump_step(g, fw)?;
    let &[i0, i1, i2] = g.mesh.triangles.get(g.tri as usize)?;
    let m = g.mesh;
    let (p0, p1, p2) = (m.positions[i0 as usize], m.positions[i1 as usize], m.positions[i2 as usize]);
    let (e1, e2) = (p1 - p0, p2 - p0);
    // geom_at's normal for this triangle (the same expression), computed once for the frame
    // and both offset points.
    let ng = e1.cross(e2).normalize_or(Vec3::Z);
    // Cycles' pair: `differential_from_compact(sd->Ng, sd->dP)`, the frame of
    // `make_orthonormals` around the geometric normal on the viewer's side (Blender axes).
    let (ex, ey) = cycles_orthonormals(to_blender(if ng.dot(g.ng) < 0.0 { -ng } else { ng }));
    let (ex, ey) = (from_blender(ex), from_blender(ey));
    // Barycentrics of a point of the plane: solve p − p0 = b1 e1 + b2 e2.
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let den = d11 * d22 - d12 * d12;
    if den <= 0.0 || den.is_nan() {
        return None;
    }
    let bary = |q: Vec3| {
        let v = q - p0;
        let (v1, v2) = (v.dot(e1), v.dot(e2));
        ((d22 * v1 - d12 * v2) / den, (d11 * v2 - d12 * v1) / den)
    };
    let offset_geom = |d: Vec3| {
        let (b1, b2) = bary(g.p + d);
        let mut g2 = geom_at_ng(m, std::slice::from_ref(g.object), g.textures, g.tri, b1, b2, ng);
        g2.object = g.object;
        g2.wo = g.wo;
        g2.backfacing = g.backfacing;
        g2.path = g.path;
        g2.view = g.view;
        g2.rays = g.rays;
        g2.p = g.p + d;
        if g2.n.dot(g.n) < 0.0 {
            g2.n = -g2.n;
            g2.ng = -g2.ng;
        }
        g2
    };
    let d = [ex * eps, ey * eps];
    Some(BumpOffsets { d, geom: [offset_geom(d[0]), offset_geom(d[1])] })
}

/// Cycles' `make_orthonormals(n)`: a unit tangent from (1, 1, 1) × n (from (−1, 1, 1) × n
/// where n lies along (1, 1, 1)) and n × it, for unit `n`.
fn cycles_orthonormals(n: Vec3) -> (Vec3, Vec3) {
    let a = if n.x != n.y || n.x != n.z {
        Vec3::new(n.z - n.y, n.x - n.z, n.y - n.x)
    } else {
        Vec3::new(n.z - n.y, n.x + n.z, -n.y - n.x)
    }
    .normalize();
    (a, n.cross(a))
}
