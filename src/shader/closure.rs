//! Closure nodes: what each shader node adds to the point's closures (weighted lobes of
//! a [`MixBsdf`], emission, transparency), and the mixture they make.
//!
//! Mapping onto the renderer's lobes (Cycles' `kernel/svm/closure.h` for reference):
//! * Principled BSDF → [`PbrParams`] (Base Color, Metallic, Roughness, IOR, Transmission
//!   Weight; Specular IOR Level L as the dielectric layer's F0 scale 2L with the tint, which
//!   is Cycles' F0 = 2L F0(IOR) × tint with the shape of that F0's IOR; Coat Weight, Roughness,
//!   IOR, Tint; Sheen Weight × Sheen Tint; Subsurface Weight; Emission Color × Strength; Thin
//!   Film Thickness and IOR on the dielectric layer and the metal (`bsdf/thin_film.rs`);
//!   Alpha as a Transparent part of weight 1 − Alpha; Diffuse Roughness as Cycles' Oren-Nayar
//!   diffuse base; Anisotropic as Cycles' widths r²/aspect, r² × aspect, aspect = √(1 − 0.9 a),
//!   along the Tangent (unlinked: Cycles' radial tangent around the object's Z axis,
//!   `Geom::radial_tangent`) turned by Anisotropic Rotation × 2π around the normal, which
//!   becomes the shading frame's X axis; Base Color above 1 on the diffuse base; the glass
//!   tinted by √Base Color at each crossing: `PbrParams::cycles_principled`). Two
//!   Principled BSDFs in one mixture are each rendered in full, each with its own normal
//!   and tangent; a third and those after it share the second slot, which holds one of them
//!   whole, chosen by weight at each point, with the weight of them all (a pixel averages
//!   their mixture as Cycles evaluates it). Every closure records its own Normal input (and an
//!   anisotropic one its tangent), from which `shader::shade` builds its frame.
//! * Diffuse → Lambert, or Cycles' Oren-Nayar for a roughness; Glossy → GGX with
//!   a constant Fresnel, the colour, and Cycles' multiscatter compensation ("GGX": none;
//!   "Beckmann": Beckmann's distribution, uncompensated, as Glass and Refraction take it too;
//!   "Ashikhmin-Shirley": Cycles' lobe of that name, `bsdf::ashikhmin_shirley`;
//!   Glass "GGX" is single scattering), anisotropic along its Tangent by Cycles' Glossy widths
//!   ([`AnisoMapping`]; Metallic by the Principled BSDF's); Metallic →
//!   GGX with Cycles' F82-tint Fresnel of F0 = Base Color and its Edge Tint (the
//!   physical-conductor mode with Cycles' exact conductor Fresnel), either under its Thin Film
//!   (`GlossyFresnel::with_film`); Glass → a dielectric interface whose
//!   reflection and transmission the colour tints; Refraction → the interface's refraction
//!   alone, without Fresnel weighting (Cycles' Refraction BSDF); Translucent → Lambertian transmission; Toon → Cycles' toon lobe (`Lobe::Toon`); Sheen →
//!   Cycles' microfiber sheen (its Ashikhmin distribution: Cycles' velvet, `bsdf::velvet`), as is
//!   the Principled BSDF's sheen; Emission → emitted radiance Color × Strength; Transparent → pass-through
//!   by coverage (`Scene::pass_through`: probability its colour's mean, weight colour / mean;
//!   shadow rays `Scene::transmission`).

use super::geom::{Geom, Reg, from_blender, v3};
use crate::bsdf::ashikhmin_shirley::AshikhminShirley;
use crate::bsdf::dielectric::DielectricBsdf;
use crate::bsdf::hair::{HairParams, sigma_from_color, sigma_from_melanin};
use crate::bsdf::hair_lobes::{HairLobe, HairLobes};
use crate::bsdf::mix::{GlossyFresnel, Lobe, Lobes, MAX_LOBES, MAX_PBR, MixBsdf, Toon};
use crate::bsdf::pbr::PbrParams;
use crate::bsdf::velvet::Velvet;
use crate::math::Rgb;
use glam::Vec3;

/// Registers of a Principled BSDF's inputs.
#[derive(Clone, Debug)]
#[allow(missing_docs)]
pub struct PrincipledRegs {
    pub base: Reg,
    pub metallic: Reg,
    pub roughness: Reg,
    pub ior: Reg,
    pub alpha: Reg,
    pub subsurface: Reg,
    pub spec_level: Reg,
    pub spec_tint: Reg,
    pub transmission: Reg,
    pub coat: Reg,
    pub coat_roughness: Reg,
    pub coat_ior: Reg,
    pub coat_tint: Reg,
    pub coat_normal: Option<Reg>,
    pub sheen: Reg,
    pub sheen_roughness: Reg,
    pub sheen_tint: Reg,
    pub emission: Reg,
    pub emission_strength: Reg,
    pub thin_film_thickness: Reg,
    pub thin_film_ior: Reg,
    pub diffuse_roughness: Reg,
    pub anisotropic: Reg,
    pub anisotropic_rotation: Reg,
    /// The Tangent input when linked (Blender axes); unlinked, Cycles' radial tangent.
    pub tangent: Option<Reg>,
    /// Distribution "GGX": single scattering (`PbrParams::single_scatter`).
    pub single_scatter: bool,
}

/// How a Principled Hair BSDF gets its absorption (its Parametrization).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HairColouring {
    /// Absorption Coefficient.
    Absorption,
    /// Melanin concentration, redness and tint.
    Melanin,
    /// Direct colouring.
    Color,
}

/// Registers of a Principled Hair BSDF's inputs.
#[derive(Clone, Debug)]
#[allow(missing_docs)]
pub struct HairRegs {
    pub colouring: HairColouring,
    pub color: Reg,
    pub melanin: Reg,
    pub redness: Reg,
    pub tint: Reg,
    pub absorption: Reg,
    pub roughness: Reg,
    pub radial: Reg,
    pub coat: Reg,
    pub ior: Reg,
    pub offset: Reg,
    pub random_color: Reg,
    pub random_roughness: Reg,
    pub random: Reg,
    /// The Random input is linked (else a strand's own random number, the input's value
    /// elsewhere).
    pub random_linked: bool,
}

/// Which closure.
#[derive(Clone, Debug)]
pub enum ClosureKind {
    /// Diffuse BSDF: Lambertian, or Oren-Nayar for a roughness above 0.
    Diffuse,
    /// Glossy (constant Fresnel) or Metallic (Schlick), with multiscatter compensation or not.
    Glossy {
        /// Metallic BSDF: the colour is F0.
        metallic: bool,
        /// Multiscatter GGX.
        multiscatter: bool,
        /// The Metallic BSDF's Edge Tint (F82-tint), when not a constant white.
        edge_tint: Option<Reg>,
        /// The physical-conductor Metallic BSDF's Extinction k (the colour register holds its
        /// IOR n): Cycles' exact conductor Fresnel.
        extinction: Option<Reg>,
        /// Beckmann's distribution instead of GGX.
        beckmann: bool,
        /// The Glossy BSDF's Ashikhmin-Shirley distribution instead of GGX.
        ashikhmin: bool,
        /// The Anisotropy, Rotation and Tangent inputs, when the lobe may be anisotropic.
        aniso: Option<AnisoRegs>,
        /// The Metallic BSDF's Thin Film Thickness and IOR, when it may have a film.
        film: Option<(Reg, Reg)>,
    },
    /// Glass BSDF.
    Glass {
        /// Beckmann's distribution instead of GGX.
        beckmann: bool,
        /// Multiscatter GGX (Cycles' default); plain "GGX" is single scattering.
        multiscatter: bool,
    },
    /// Refraction BSDF: the glass's refraction alone.
    Refraction {
        /// Beckmann's distribution (Blender's default for this node) instead of GGX.
        beckmann: bool,
    },
    /// Translucent BSDF.
    Translucent,
    /// Toon BSDF (Size in `roughness`, Smooth in `strength`).
    Toon {
        /// The Glossy component (else Diffuse).
        glossy: bool,
    },
    /// Sheen BSDF: Microfiber, or its Ashikhmin distribution (Cycles' velvet).
    Sheen {
        /// The Ashikhmin (velvet) distribution.
        velvet: bool,
    },
    /// Emission.
    Emission,
    /// Transparent BSDF.
    Transparent,
    /// Holdout: its weight cuts the surface out of the film's alpha for camera rays.
    Holdout,
    /// Principled BSDF.
    Principled(Box<PrincipledRegs>),
    /// Principled Hair BSDF (Chiang): strands only.
    PrincipledHair(Box<HairRegs>),
    /// Hair BSDF, one component (Offset in `ior`, RoughnessU in `roughness`, RoughnessV in
    /// `strength`): strands only.
    HairLobe {
        /// The Transmission component (else Reflection).
        transmission: bool,
    },
}

/// How a node maps its Anisotropy to widths (Cycles' `svm_node_closure_bsdf`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AnisoMapping {
    /// The Glossy BSDF: a in [−0.99, 0.99], αx = α(1 − a), αy = α/(1 − a) (a < 0: α/(1 + a),
    /// α(1 + a)); isotropic for |a| ≤ 10⁻⁴.
    Glossy,
    /// The Metallic and Principled BSDFs: a in [0, 1], aspect √(1 − 0.9a), αx = α/aspect,
    /// αy = α × aspect.
    Aspect,
}

/// Registers of an anisotropic lobe's inputs.
#[derive(Clone, Copy, Debug)]
pub struct AnisoRegs {
    /// Anisotropy.
    pub anisotropy: Reg,
    /// Rotation (turns around the normal).
    pub rotation: Reg,
    /// The Tangent input when linked (Blender axes); unlinked, Cycles' radial tangent.
    pub tangent: Option<Reg>,
    /// The node's mapping to widths.
    pub mapping: AnisoMapping,
}

impl AnisoMapping {
    /// The widths (αx along the tangent, αy) for isotropic width `alpha` and anisotropy `a`;
    /// None where the node is isotropic.
    pub fn widths(self, alpha: f32, a: f32) -> Option<(f32, f32)> {
        match self {
            AnisoMapping::Glossy => {
                let a = a.clamp(-0.99, 0.99);
                if !(a.abs() > 1e-4) {
                    None
                } else if a < 0.0 {
                    Some((alpha / (1.0 + a), alpha * (1.0 + a)))
                } else {
                    Some((alpha * (1.0 - a), alpha / (1.0 - a)))
                }
            }
            AnisoMapping::Aspect => {
                let a = a.clamp(0.0, 1.0);
                if !(a > 0.0) {
                    return None;
                }
                let aspect = (1.0 - 0.9 * a).sqrt();
                Some((alpha / aspect, alpha * aspect))
            }
        }
    }
}

/// A closure node compiled: its kind, weight and inputs.
#[derive(Clone, Debug)]
pub struct ClosureOp {
    /// Kind.
    pub kind: ClosureKind,
    /// Weight register (None: 1).
    pub w: Option<Reg>,
    /// Colour.
    pub color: Reg,
    /// Roughness (or IOR-less kinds: unused).
    pub roughness: Reg,
    /// IOR.
    pub ior: Reg,
    /// Emission strength.
    pub strength: Reg,
    /// Normal input when linked (Blender axes).
    pub normal: Option<Reg>,
}

/// Closures gathered at a shading point.
#[derive(Clone, Copy, Debug)]
pub struct Closures {
    /// Small lobes with weights.
    pub mix: Lobes,
    /// Per Principled slot, Σ w × parameters (the Principled BSDFs past the last slot are
    /// merged into it).
    pub pbr: [PbrParams; MAX_PBR],
    /// Per Principled slot, Σ w.
    pub pbr_w: [f32; MAX_PBR],
    /// Per Principled slot, the Σ w its parameters were summed with: `pbr_w` but for the last
    /// slot when more BSDFs than slots are mixed, which holds the parameters of one of them
    /// (chosen by weight at each point) with the weight of them all.
    pub pbr_param_w: [f32; MAX_PBR],
    /// Principled BSDFs met with a weight.
    pub principled: u8,
    /// Emitted radiance.
    pub emission: Rgb,
    /// Transparent weight.
    pub transparent: Rgb,
    /// Holdout weight (Cycles' `surface_shader_apply_holdout`: the Holdout closures' sum).
    pub holdout: f32,
    /// The first linked closure normal (Blender axes): the mixture's shading frame.
    pub normal: Option<Vec3>,
    /// The normal of closures without a linked one when not the interpolated normal: the
    /// Material Output's bump displacement (Blender axes).
    pub default_normal: Option<Vec3>,
    /// Each small lobe's linked normal (Blender axes).
    pub lobe_normals: [Option<Vec3>; MAX_LOBES],
    /// Each small lobe's tangent when anisotropic (world glTF axes).
    pub lobe_tangents: [Option<Vec3>; MAX_LOBES],
    /// Each Principled slot's linked normal (its first BSDF's, Blender axes).
    pub pbr_normals: [Option<Vec3>; MAX_PBR],
    /// Each Principled slot's linked coat normal (Blender axes).
    pub coat_normals: [Option<Vec3>; MAX_PBR],
    /// Per Principled slot, Σ w × Anisotropic.
    pub anisotropic: [f32; MAX_PBR],
    /// Each Principled slot's tangent, rotated (world glTF axes), when anisotropic.
    pub tangents: [Option<Vec3>; MAX_PBR],
    /// Σ of the grey weights of the small lobes offered to the mixture's last slot: past the
    /// capacity they share it, which holds one of them (chosen by weight at each point) with
    /// the weight of them all (a weighted reservoir, as the last Principled slot).
    pub lobe_res_total: f32,
    /// The last slot's lobe's own weight, before the reservoir's scaling.
    pub lobe_res_weight: Rgb,
    /// Small lobes offered with a weight (the reservoir's hash index).
    pub lobes_offered: u8,
    /// Σ w of the Principled Hair BSDFs.
    pub hair_w: f32,
    /// Σ w × their parameters (absorption, roughnesses, coat, offset, IOR).
    pub hair: HairParams,
    /// The Hair BSDF's lobes.
    pub hair_lobes: HairLobes,
}

/// An empty mixture, built once: `MixBsdf::new` builds its placeholder Principled BSDFs
/// (albedo table lookups, ~760 instructions each; callgrind, `bench/node_graph.py`), which
/// every mixture would pay before its closures replaced them. A copy is far less.
pub fn empty_mix() -> MixBsdf {
    static EMPTY: std::sync::LazyLock<MixBsdf> = std::sync::LazyLock::new(MixBsdf::new);
    *EMPTY
}

impl Default for Closures {
    fn default() -> Self {
        Closures {
            mix: Lobes::EMPTY,
            pbr: [zero_params(); MAX_PBR],
            pbr_w: [0.0; MAX_PBR],
            pbr_param_w: [0.0; MAX_PBR],
            principled: 0,
            emission: Rgb::ZERO,
            transparent: Rgb::ZERO,
            holdout: 0.0,
            normal: None,
            default_normal: None,
            lobe_normals: [None; MAX_LOBES],
            lobe_tangents: [None; MAX_LOBES],
            pbr_normals: [None; MAX_PBR],
            coat_normals: [None; MAX_PBR],
            anisotropic: [0.0; MAX_PBR],
            tangents: [None; MAX_PBR],
            lobe_res_total: 0.0,
            lobe_res_weight: Rgb::ZERO,
            lobes_offered: 0,
            hair_w: 0.0,
            hair: HairParams {
                sigma: [0.0; 3],
                roughness: 0.0,
                radial_roughness: 0.0,
                coat: 0.0,
                offset: 0.0,
                ior: 0.0,
            },
            hair_lobes: HairLobes::EMPTY,
        }
    }
}

fn zero_params() -> PbrParams {
    PbrParams {
        base: Rgb::ZERO,
        metallic: 0.0,
        roughness: 0.0,
        specular: 0.0,
        ior: 0.0,
        transmission: 0.0,
        thin: false,
        eta: 1.0,
        coat: 0.0,
        coat_roughness: 0.0,
        coat_normal: None,
        diffuse_normal: None,
        smooth_normal: None,
        cut_normal: None,
        coat_ior: 0.0,
        coat_tint: Rgb::ZERO,
        coat_dielectric_fresnel: true,
        specular_color: Rgb::ZERO,
        sheen_color: Rgb::ZERO,
        sheen_roughness: 0.0,
        microfiber_sheen: true,
        dispersion: 0.0,
        subsurface: 0.0,
        anisotropy: None,
        diffuse_roughness: 0.0,
        cycles_principled: true,
        thin_film: None,
        thin_film_metal: true,
        single_scatter: false,
        diffuse_transmission: 0.0,
        diffuse_transmission_color: Rgb::ZERO,
    }
}

impl ClosureOp {
    /// Adds this closure, weighted, to `out`.
    pub fn apply(&self, r: &[f32], g: &Geom, out: &mut Closures) {
        let w = self.w.map_or(1.0, |w| r[w as usize]);
        if !(w > 0.0) {
            return;
        }
        if out.normal.is_none()
            && let Some(n) = self.normal
        {
            out.normal = Some(v3(r, n));
        }
        let color = || v3(r, self.color).max(Vec3::ZERO);
        let rough = || r[self.roughness as usize].clamp(0.0, 1.0);
        let normal = self.normal.map(|n| v3(r, n));
        let mut push = |weight: Rgb, lobe: Lobe, tangent: Option<Vec3>| {
            out.offer_lobe(weight, lobe, normal, tangent, |index| reservoir_u(g, LOBE_RESERVOIR + index))
        };
        match &self.kind {
            ClosureKind::Diffuse => {
                // Cycles takes a roughness below 1e-5 as Lambertian.
                let sigma = rough();
                let lobe = if sigma < 1e-5 { Lobe::Diffuse } else { Lobe::oren_nayar(sigma, color().min(Vec3::ONE)) };
                push(color() * w, lobe, None)
            }
            ClosureKind::Translucent => push(color() * w, Lobe::Translucent, None),
            ClosureKind::Toon { glossy } => {
                let lobe = Lobe::Toon(Toon::new(r[self.roughness as usize], r[self.strength as usize], *glossy));
                push(color() * w, lobe, None)
            }
            ClosureKind::Sheen { velvet: false } => push(color() * w, Lobe::Sheen { roughness: rough() }, None),
            ClosureKind::Sheen { velvet: true } => push(color() * w, Lobe::Velvet(Velvet::new(rough())), None),
            ClosureKind::Glossy { metallic, multiscatter, edge_tint, extinction, beckmann, ashikhmin, aniso, film } => {
                let (weight, fresnel) = if *metallic {
                    let f0 = color().min(Vec3::ONE);
                    let fresnel = match (extinction, edge_tint) {
                        (Some(k), _) => {
                            GlossyFresnel::Conductor { n: color().max(Vec3::ZERO), k: v3(r, *k).max(Vec3::ZERO) }
                        }
                        (None, Some(t)) => GlossyFresnel::f82_tint(f0, v3(r, *t).clamp(Vec3::ZERO, Vec3::ONE)),
                        (None, None) => GlossyFresnel::Schlick(f0),
                    };
                    let fresnel = match film {
                        Some((d, ior)) => fresnel.with_film(r[*d as usize], r[*ior as usize]),
                        None => fresnel,
                    };
                    (Rgb::splat(w), fresnel)
                } else {
                    (color() * w, GlossyFresnel::Constant)
                };
                let alpha = rough() * rough();
                // Anisotropic widths lie along the closure's tangent: its frame's X axis.
                let mut tangent = None;
                let widths = aniso.and_then(|a| {
                    let widths = a.mapping.widths(alpha, r[a.anisotropy as usize])?;
                    tangent = closure_tangent(a.tangent, r[a.rotation as usize], self.normal, r, g);
                    Some(widths)
                });
                let mut lobe = match widths {
                    _ if *ashikhmin => {
                        let (ax, ay) = widths.unwrap_or((alpha, alpha));
                        Lobe::AshikhminShirley(AshikhminShirley::new(ax, ay))
                    }
                    Some((ax, ay)) => Lobe::glossy_widths(ax, ay, *beckmann, fresnel),
                    None if *beckmann => Lobe::glossy_widths(alpha, alpha, true, fresnel),
                    None => Lobe::glossy(rough(), fresnel),
                };
                if !*multiscatter && let Lobe::Glossy { fms, .. } = &mut lobe {
                    *fms = Rgb::ZERO;
                }
                push(weight, lobe, tangent);
            }
            ClosureKind::Glass { .. } | ClosureKind::Refraction { .. } => {
                let ior = r[self.ior as usize];
                // Cycles' `fmaxf(ior, 1e-5f)`: IOR 0 is a mirror from outside, not glass of 1.5.
                let ior = if ior.is_finite() { ior.max(crate::bsdf::pbr::MIN_IOR) } else { 1.5 };
                let eta = if g.backfacing { 1.0 / ior } else { ior };
                let d = DielectricBsdf::new(eta, rough(), false, Rgb::ONE);
                // Cycles' Refraction BSDF has no Fresnel and no multiple-scattering compensation;
                // its Glass compensates only as "Multiscatter GGX" (no Beckmann table).
                let d = match self.kind {
                    ClosureKind::Refraction { beckmann: true } => d.with_beckmann().refraction_only(),
                    ClosureKind::Refraction { beckmann: false } => d.refraction_only(),
                    ClosureKind::Glass { beckmann: true, .. } => d.with_beckmann(),
                    ClosureKind::Glass { multiscatter: true, .. } => d.with_multiscatter(),
                    _ => d,
                };
                push(color() * w, Lobe::Dielectric(d), None);
            }
            // Cycles' `emission_setup` keeps a negative colour (it subtracts light), unlike
            // `bsdf_alloc`, which clamps every BSDF weight at 0 as `color()` does.
            ClosureKind::Emission => out.emission += v3(r, self.color) * (r[self.strength as usize] * w),
            ClosureKind::Transparent => out.transparent += color() * w,
            ClosureKind::Holdout => out.holdout += w,
            ClosureKind::Principled(p) => principled(p, r, g, self.normal, w, out),
            ClosureKind::PrincipledHair(p) => principled_hair(p, r, g, w, out),
            ClosureKind::HairLobe { transmission } => out.hair_lobes.push(HairLobe::new(
                color() * w,
                *transmission,
                r[self.ior as usize],
                r[self.roughness as usize],
                r[self.strength as usize],
            )),
        }
    }
}

/// Rotates `v` by `angle` radians around the unit `axis` (right-handed, Rodrigues; Cycles'
/// `rotate_around_axis`).
fn rotate_around_axis(v: Vec3, axis: Vec3, angle: f32) -> Vec3 {
    let (sin, cos) = angle.sin_cos();
    v * cos + axis.cross(v) * sin + axis * (axis.dot(v) * (1.0 - cos))
}

/// An anisotropic closure's tangent (world glTF axes): the Tangent input (linked) or Cycles'
/// radial tangent around the object's Z axis, turned by `rotation` × 2π around the closure
/// normal.
fn closure_tangent(tangent: Option<Reg>, rotation: f32, normal: Option<Reg>, r: &[f32], g: &Geom) -> Option<Vec3> {
    let t = match tangent {
        Some(t) => from_blender(v3(r, t)),
        None => g.radial_tangent(2),
    };
    let n = normal.and_then(|n| from_blender(v3(r, n)).try_normalize()).unwrap_or(g.n);
    let t = if rotation != 0.0 { rotate_around_axis(t, n, rotation * std::f32::consts::TAU) } else { t };
    t.try_normalize()
}

/// Adds a Principled Hair BSDF of weight `w`, its inputs as Cycles' `svm_node_principled_hair`
/// reads them: Random (linked, else the strand's) spreads the roughnesses by Random Roughness
/// and, for melanin, the concentration by Random Color, each by ±half the amount.
fn principled_hair(p: &HairRegs, r: &[f32], g: &Geom, w: f32, out: &mut Closures) {
    let f = |i: Reg| r[i as usize];
    let random = if p.random_linked { f(p.random) } else { g.curve.map_or(f(p.random), |c| c.random) };
    let spread = |amount: f32| 1.0 + 2.0 * (random - 0.5) * amount;
    let by_random = spread(f(p.random_roughness));
    let roughness = f(p.roughness) * by_random;
    let radial = f(p.radial) * by_random;
    let sigma = match p.colouring {
        HairColouring::Absorption => v3(r, p.absorption),
        HairColouring::Melanin => {
            let melanin = f(p.melanin) * spread(f(p.random_color).clamp(0.0, 1.0));
            sigma_from_melanin(melanin, f(p.redness), v3(r, p.tint), radial)
        }
        HairColouring::Color => sigma_from_color(v3(r, p.color), radial),
    }
    .max(Vec3::ZERO);
    let h = &mut out.hair;
    for (k, s) in h.sigma.iter_mut().enumerate() {
        *s += sigma[k] * w;
    }
    h.roughness += roughness.clamp(0.0, 1.0) * w;
    h.radial_roughness += radial.clamp(0.0, 1.0) * w;
    h.coat += f(p.coat).clamp(0.0, 1.0) * w;
    h.offset += f(p.offset) * w;
    h.ior += f(p.ior) * w;
    out.hair_w += w;
}

fn principled(p: &PrincipledRegs, r: &[f32], g: &Geom, normal: Option<Reg>, w: f32, out: &mut Closures) {
    let f = |i: Reg| r[i as usize];
    let alpha = f(p.alpha).clamp(0.0, 1.0);
    if alpha < 1.0 {
        out.transparent += Rgb::splat(w * (1.0 - alpha));
    }
    let w = w * alpha;
    // Unclamped, as Cycles' `emission_setup` (a BSDF's weight is clamped at 0, emission's not).
    out.emission += v3(r, p.emission) * (f(p.emission_strength) * w);
    if w <= 0.0 {
        return;
    }
    // Each Principled BSDF has a slot of its own, in full. Past the last slot, the BSDFs that
    // share it are chosen among by weight at each point (a weighted reservoir): the slot keeps
    // one of them whole with the weight of them all, so the mixture Cycles evaluates is what
    // the point renders on average over a pixel's points, where averaging their parameters
    // (a red metal and a blue plastic made one purple semi-metal) was another material.
    let index = out.principled as usize;
    let slot = index.min(MAX_PBR - 1);
    out.principled = out.principled.saturating_add(1);
    if index >= MAX_PBR {
        let total = out.pbr_w[slot] + w;
        out.pbr_w[slot] = total;
        if reservoir_u(g, index) * total >= w {
            return;
        }
        clear_slot(out, slot);
    } else {
        out.pbr_w[slot] += w;
    }
    let first = out.pbr_param_w[slot] <= 0.0;
    if first {
        out.pbr_normals[slot] = normal.map(|n| v3(r, n));
        out.coat_normals[slot] = p.coat_normal.map(|n| v3(r, n));
    }
    let level = f(p.spec_level).max(0.0);
    let acc = &mut out.pbr[slot];
    if first {
        // The slot's first Principled BSDF's distribution (a flag does not average).
        acc.single_scatter = p.single_scatter;
    }
    // Above 1 too: the diffuse base takes it as given (the BSDF clamps it elsewhere).
    acc.base += v3(r, p.base).max(Vec3::ZERO) * w;
    acc.diffuse_roughness += f(p.diffuse_roughness).clamp(0.0, 1.0) * w;
    acc.metallic += f(p.metallic).clamp(0.0, 1.0) * w;
    acc.roughness += f(p.roughness).clamp(0.0, 1.0) * w;
    // Cycles' `fmaxf(ior, 1e-5f)`: an IOR below 1 keeps its (inverted) layer.
    acc.ior += f(p.ior).max(crate::bsdf::pbr::MIN_IOR) * w;
    acc.transmission += f(p.transmission).clamp(0.0, 1.0) * w;
    acc.specular += 2.0 * level * w;
    acc.specular_color += v3(r, p.spec_tint).max(Vec3::ZERO) * w;
    acc.coat += f(p.coat).clamp(0.0, 1.0) * w;
    acc.coat_roughness += f(p.coat_roughness).clamp(0.0, 1.0) * w;
    acc.coat_ior += f(p.coat_ior).max(1.0) * w;
    acc.coat_tint += v3(r, p.coat_tint).clamp(Vec3::ZERO, Vec3::ONE) * w;
    acc.sheen_color += v3(r, p.sheen_tint).clamp(Vec3::ZERO, Vec3::ONE) * (f(p.sheen).clamp(0.0, 1.0) * w);
    acc.sheen_roughness += f(p.sheen_roughness).clamp(0.0, 1.0) * w;
    acc.subsurface += f(p.subsurface).clamp(0.0, 1.0) * w;
    // The slot's first Principled BSDF's film, whole (films do not average).
    let thickness = f(p.thin_film_thickness);
    if acc.thin_film.is_none() && thickness > 0.1 {
        acc.thin_film = Some((thickness, f(p.thin_film_ior).max(1e-5), 1.0));
    }
    // Cycles' anisotropy: the tangent (linked, else radial around the object's Z axis) turned
    // around the closure normal by Anisotropic Rotation × 2π; the slot's first one's.
    let anisotropic = f(p.anisotropic).clamp(0.0, 1.0);
    if anisotropic > 0.0 {
        out.anisotropic[slot] += anisotropic * w;
        if out.tangents[slot].is_none() {
            out.tangents[slot] = closure_tangent(p.tangent, f(p.anisotropic_rotation), normal, r, g);
        }
    }
    out.pbr_param_w[slot] += w;
}

/// The reservoir hash's indices of small lobes start here, past any Principled BSDF's, so the
/// two choices at one point are independent.
const LOBE_RESERVOIR: usize = 1 << 16;

impl Closures {
    /// Adds small lobe `lobe` of weight `weight` (with its Normal input and tangent). Past
    /// [`MAX_LOBES`] the lobes share the last slot, which holds one of them whole, lobe k kept
    /// with probability gₖ / Σg (g the mean of a weight's channels) and weighted by Σg / gₖ, so
    /// its expectation over a pixel's points is the sum Cycles evaluates; dropping them lost
    /// their light. `u(k)`: a uniform number for the k-th lobe offered, the same at every
    /// evaluation of one point.
    pub fn offer_lobe(
        &mut self,
        weight: Rgb,
        lobe: Lobe,
        normal: Option<Vec3>,
        tangent: Option<Vec3>,
        u: impl FnOnce(usize) -> f32,
    ) {
        let grey = (weight.x + weight.y + weight.z) / 3.0;
        if !(grey > 0.0) || !weight.is_finite() || weight.max_element() <= 0.0 {
            return;
        }
        let index = self.lobes_offered as usize;
        self.lobes_offered = self.lobes_offered.saturating_add(1);
        let last = MAX_LOBES - 1;
        let k = self.mix.n as usize;
        if k < MAX_LOBES {
            self.mix.push(weight, lobe);
            self.lobe_normals[k] = normal;
            self.lobe_tangents[k] = tangent;
            if k == last {
                (self.lobe_res_total, self.lobe_res_weight) = (grey, weight);
            }
            return;
        }
        self.lobe_res_total += grey;
        if u(index) * self.lobe_res_total < grey {
            self.mix.lobes[last] = lobe;
            self.lobe_normals[last] = normal;
            self.lobe_tangents[last] = tangent;
            self.lobe_res_weight = weight;
        }
        let kept = self.lobe_res_weight;
        self.mix.weights[last] = kept * (self.lobe_res_total / ((kept.x + kept.y + kept.z) / 3.0));
    }
}

/// A uniform number in [0, 1) for the weighted choice among Principled BSDF `index` and those
/// before it in the last slot: a hash of the shading point's position and triangle, so every
/// evaluation of one point (its light samples, BSDF samples and connections) sees the same
/// closure, and the points of a pixel see each with its probability.
fn reservoir_u(g: &Geom, index: usize) -> f32 {
    use crate::shader::texture::hash::hash_uint4;
    let h = hash_uint4(g.p.x.to_bits(), g.p.y.to_bits(), g.p.z.to_bits() ^ g.tri, index as u32);
    (h >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// Empties Principled slot `slot`'s parameters (its weight stays): another BSDF takes it.
fn clear_slot(out: &mut Closures, slot: usize) {
    out.pbr[slot] = zero_params();
    out.pbr_param_w[slot] = 0.0;
    out.pbr_normals[slot] = None;
    out.coat_normals[slot] = None;
    out.anisotropic[slot] = 0.0;
    out.tangents[slot] = None;
}

impl Closures {
    /// The Principled Hair BSDFs' parameters (weights divided out); None without one.
    pub fn hair_params(&self) -> Option<HairParams> {
        if !(self.hair_w > 0.0) {
            return None;
        }
        let s = 1.0 / self.hair_w;
        let h = &self.hair;
        Some(HairParams {
            sigma: h.sigma.map(|x| x * s),
            roughness: h.roughness * s,
            radial_roughness: h.radial_roughness * s,
            coat: h.coat * s,
            offset: h.offset * s,
            ior: (h.ior * s).max(1.0 + 1e-4),
        })
    }

    /// True when hair closures have a weight here (a strand is then shaded with them alone).
    pub fn has_hair(&self) -> bool {
        self.hair_w > 0.0 || self.hair_lobes.n > 0
    }

    /// Principled slot `j`'s parameters (weights divided out), for a point on the side
    /// given by `backfacing`.
    pub fn principled_params(&self, j: usize, backfacing: bool) -> PbrParams {
        let s = 1.0 / self.pbr_param_w[j];
        let p = &self.pbr[j];
        let ior = p.ior * s;
        PbrParams {
            base: p.base * s,
            metallic: p.metallic * s,
            roughness: p.roughness * s,
            specular: p.specular * s,
            ior,
            transmission: p.transmission * s,
            thin: false,
            eta: if backfacing { 1.0 / ior } else { ior },
            coat: p.coat * s,
            coat_roughness: p.coat_roughness * s,
            coat_normal: None,
            diffuse_normal: None,
            smooth_normal: None,
            cut_normal: None,
            coat_ior: p.coat_ior * s,
            coat_tint: p.coat_tint * s,
            // Cycles' coat closure: the exact dielectric Fresnel of the Coat IOR.
            coat_dielectric_fresnel: true,
            specular_color: p.specular_color * s,
            sheen_color: p.sheen_color * s,
            sheen_roughness: p.sheen_roughness * s,
            // Blender's graphs: Cycles' sheen.
            microfiber_sheen: true,
            dispersion: 0.0,
            subsurface: p.subsurface * s,
            anisotropy: anisotropy(self.tangents[j].is_some(), p.roughness * s, self.anisotropic[j] * s),
            diffuse_roughness: p.diffuse_roughness * s,
            // Cycles' Principled glass: √base at each crossing.
            cycles_principled: true,
            thin_film: p.thin_film,
            // Cycles' Principled puts the film on its F82-tint metal too.
            thin_film_metal: true,
            single_scatter: p.single_scatter,
            // Blender's Principled BSDF has no diffuse transmission.
            diffuse_transmission: 0.0,
            diffuse_transmission_color: Rgb::ONE,
        }
    }

    /// The closure normal in world (glTF) axes, if a closure had one linked.
    pub fn normal_world(&self) -> Option<Vec3> {
        world(self.normal)
    }

    /// The normal of closures without a linked one (world axes), when not the interpolated one.
    pub fn default_normal_world(&self) -> Option<Vec3> {
        world(self.default_normal)
    }

    /// Small lobe `k`'s linked normal in world axes.
    pub fn lobe_normal_world(&self, k: usize) -> Option<Vec3> {
        world(self.lobe_normals[k])
    }

    /// Principled slot `j`'s linked normal in world axes.
    pub fn pbr_normal_world(&self, j: usize) -> Option<Vec3> {
        world(self.pbr_normals[j])
    }

    /// Principled slot `j`'s coat normal in world axes.
    pub fn coat_normal_world(&self, j: usize) -> Option<Vec3> {
        world(self.coat_normals[j])
    }
}

/// A normal in Blender axes to world (glTF) axes, unit.
fn world(n: Option<Vec3>) -> Option<Vec3> {
    n.map(from_blender).and_then(|n| n.try_normalize())
}

/// Cycles' anisotropic GGX widths for `roughness` and Anisotropic `a`: with
/// aspect = √(1 − 0.9 a), αx = roughness² / aspect along the tangent, αy = roughness² ×
/// aspect across (widths above 1 are clamped to 1 by the BSDF). None without a tangent.
fn anisotropy(tangent: bool, roughness: f32, a: f32) -> Option<(f32, f32)> {
    if !(a > 0.0) || !tangent {
        return None;
    }
    let alpha = roughness * roughness;
    let aspect = (1.0 - 0.9 * a.min(1.0)).sqrt();
    Some((alpha / aspect, alpha * aspect))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Past the mixture's four small lobes, the last slot holds one of those offered to it
    /// with the weight of them all, so over many points each lobe's mean weight is its own
    /// (it dropped the fifth and sixth lobe's light before). Six lobes of distinct kinds, so the
    /// slot's kind says which it holds. Bound: the mean of N draws of lobe k's estimate
    /// (w_k/p_k with probability p_k = g_k/Σg) has relative standard error √((1 − p_k)/(p_k N));
    /// 5 of them.
    #[test]
    fn lobes_past_the_capacity_share_the_last_slot() {
        let lobes = [
            Lobe::Diffuse,
            Lobe::Translucent,
            Lobe::Sheen { roughness: 0.5 },
            Lobe::Velvet(Velvet::new(0.3)),
            Lobe::Toon(Toon::new(0.5, 0.1, false)),
            Lobe::oren_nayar(0.5, Rgb::splat(0.5)),
        ];
        let weights: [Rgb; 6] = core::array::from_fn(|k| Rgb::new(0.1 + 0.05 * k as f32, 0.3, 0.05 * (6 - k) as f32));
        let kind = |l: &Lobe| std::mem::discriminant(l);
        let mut state = 0x9e37_79b9u32;
        let mut next = || {
            state = state.wrapping_mul(1664525).wrapping_add(1013904223);
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        const N: usize = 20_000;
        let mut sums = [glam::DVec3::ZERO; 6];
        for _ in 0..N {
            let mut c = Closures::default();
            for (l, w) in lobes.iter().zip(weights) {
                let u = next();
                c.offer_lobe(w, *l, None, None, |_| u);
            }
            assert_eq!(c.mix.n as usize, MAX_LOBES);
            for j in 0..MAX_LOBES {
                let k = lobes.iter().position(|l| kind(l) == kind(&c.mix.lobes[j])).unwrap();
                assert!(j == MAX_LOBES - 1 || k == j, "slot {j} holds lobe {k}");
                sums[k] += c.mix.weights[j].as_dvec3();
            }
        }
        let grey = |w: Rgb| (w.x + w.y + w.z) / 3.0;
        let shared: f32 = weights[MAX_LOBES - 1..].iter().map(|&w| grey(w)).sum();
        for k in 0..6 {
            let mean = sums[k] / N as f64;
            let p = if k < MAX_LOBES - 1 { 1.0 } else { grey(weights[k]) / shared };
            // Plus f32 rounding of the weights themselves.
            let bound = 5.0 * ((1.0 - p) / (p * N as f32)).sqrt() as f64 + 1e-6;
            let rel = ((mean - weights[k].as_dvec3()) / weights[k].as_dvec3()).abs().max_element();
            assert!(rel <= bound, "lobe {k}: mean {mean:?} of {:?} (relative {rel}, bound {bound})", weights[k]);
        }
    }

    /// Anisotropic Rotation turns the tangent right-handedly around the normal, as Cycles'
    /// `rotate_around_axis`: a quarter turn about Z takes X to Y; the normal's part stays.
    #[test]
    fn rotation_is_right_handed() {
        let r = rotate_around_axis(Vec3::X, Vec3::Z, std::f32::consts::FRAC_PI_2);
        assert!((r - Vec3::Y).abs().max_element() < 1e-6, "{r:?}");
        let v = Vec3::new(0.3, -0.5, 0.8);
        let r = rotate_around_axis(v, Vec3::Z, 1.1);
        assert!((r.z - v.z).abs() < 1e-6 && (r.length() - v.length()).abs() < 1e-6);
    }

    /// Cycles' widths: aspect √(1 − 0.9 a), αx = r²/aspect, αy = r² aspect; none without a tangent.
    #[test]
    fn anisotropic_widths_are_cycles() {
        let (ax, ay) = anisotropy(true, 0.3, 0.8).unwrap();
        let aspect = (1.0f32 - 0.72).sqrt();
        assert!((ax - 0.09 / aspect).abs() < 1e-6 && (ay - 0.09 * aspect).abs() < 1e-6);
        assert!(anisotropy(false, 0.3, 0.8).is_none());
    }
}
