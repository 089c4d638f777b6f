//! Closure nodes: what each shader node adds to the point's closures (weighted lobes of
//! a [`MixBsdf`], emission, transparency), and the mixture they make.
//!
//! Mapping onto the renderer's lobes (Cycles' `kernel/svm/closure.h` for reference):
//! * Principled BSDF → [`PbrParams`] (Base Color, Metallic, Roughness, IOR, Transmission
//!   Weight; Specular IOR Level L as the dielectric layer's F0 scale 2L with the tint, which
//!   is Cycles' F0 = 2L F0(IOR) × tint with the shape of that F0's IOR; Coat Weight, Roughness,
//!   IOR, Tint; Sheen Weight × Sheen Tint; Subsurface Weight; Emission Color × Strength; Thin
//!   Film Thickness and IOR on the dielectric layer (`bsdf/thin_film.rs`);
//!   Alpha as a Transparent part of weight 1 − Alpha). Several Principled BSDFs in one
//!   mixture are merged into one by their weights (an approximation: warned at load).
//! * Diffuse → Lambert (Oren-Nayar roughness is warned about at load); Glossy → GGX with
//!   a constant Fresnel, the colour, and Cycles' multiscatter compensation; Metallic →
//!   GGX with Schlick's Fresnel of F0 = Base Color (edge tint and the physical-conductor
//!   mode are approximated, warned at load); Glass → a dielectric interface whose
//!   reflection and transmission the colour tints; Refraction → the same interface
//!   (Cycles' has no reflection: warned); Translucent → Lambertian transmission; Sheen →
//!   Cycles' microfiber sheen (its Ashikhmin distribution is warned about at load), as is
//!   the Principled BSDF's sheen; Emission → emitted radiance Color × Strength; Transparent → pass-through
//!   by coverage (`Scene::pass_through`: probability its colour's mean, weight colour / mean;
//!   shadow rays `Scene::transmission`).

use super::geom::{Geom, Reg, from_blender, v3};
use crate::bsdf::dielectric::DielectricBsdf;
use crate::bsdf::mix::{GlossyFresnel, Lobe, MAX_LOBES, MixBsdf};
use crate::bsdf::pbr::PbrParams;
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
    },
    /// Glass or Refraction BSDF.
    Glass,
    /// Translucent BSDF.
    Translucent,
    /// Sheen BSDF.
    Sheen,
    /// Emission.
    Emission,
    /// Transparent BSDF.
    Transparent,
    /// Holdout: its weight cuts the surface out of the film's alpha for camera rays.
    Holdout,
    /// Principled BSDF.
    Principled(Box<PrincipledRegs>),
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
    pub mix: MixBsdf,
    /// Σ w × Principled parameters.
    pub pbr: PbrParams,
    /// Σ w of the Principled BSDFs.
    pub pbr_w: f32,
    /// Emitted radiance.
    pub emission: Rgb,
    /// Transparent weight.
    pub transparent: Rgb,
    /// Holdout weight (Cycles' `surface_shader_apply_holdout`: the Holdout closures' sum).
    pub holdout: f32,
    /// The first linked closure normal (Blender axes).
    pub normal: Option<Vec3>,
    /// The first linked coat normal (Blender axes).
    pub coat_normal: Option<Vec3>,
    /// Lobes past the mixture's capacity were dropped.
    pub dropped: bool,
}

/// An empty mixture, built once: `MixBsdf::new` builds its placeholder Principled BSDF
/// (albedo table lookups, ~760 instructions; callgrind, `bench/node_graph.py`), which every
/// shading point paid before its closures replaced it. A copy is ~90.
fn empty_mix() -> MixBsdf {
    static EMPTY: std::sync::LazyLock<MixBsdf> = std::sync::LazyLock::new(MixBsdf::new);
    *EMPTY
}

impl Default for Closures {
    fn default() -> Self {
        Closures {
            mix: empty_mix(),
            pbr: zero_params(),
            pbr_w: 0.0,
            emission: Rgb::ZERO,
            transparent: Rgb::ZERO,
            holdout: 0.0,
            normal: None,
            coat_normal: None,
            dropped: false,
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
        coat_ior: 0.0,
        coat_tint: Rgb::ZERO,
        specular_color: Rgb::ZERO,
        sheen_color: Rgb::ZERO,
        sheen_roughness: 0.0,
        microfiber_sheen: true,
        dispersion: 0.0,
        subsurface: 0.0,
        anisotropy: None,
        thin_film: None,
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
        let mut push = |weight: Rgb, lobe: Lobe| {
            if !out.mix.push(weight, lobe) {
                out.dropped = true;
            }
        };
        match &self.kind {
            ClosureKind::Diffuse => {
                // Cycles takes a roughness below 1e-5 as Lambertian.
                let sigma = rough();
                let lobe = if sigma < 1e-5 { Lobe::Diffuse } else { Lobe::oren_nayar(sigma, color().min(Vec3::ONE)) };
                push(color() * w, lobe)
            }
            ClosureKind::Translucent => push(color() * w, Lobe::Translucent),
            ClosureKind::Sheen => push(color() * w, Lobe::Sheen { roughness: rough() }),
            ClosureKind::Glossy { metallic, multiscatter } => {
                let (weight, fresnel) = if *metallic {
                    (Rgb::splat(w), GlossyFresnel::Schlick(color().min(Vec3::ONE)))
                } else {
                    (color() * w, GlossyFresnel::Constant)
                };
                let mut lobe = Lobe::glossy(rough(), fresnel);
                if !*multiscatter && let Lobe::Glossy { fms, .. } = &mut lobe {
                    *fms = Rgb::ZERO;
                }
                push(weight, lobe);
            }
            ClosureKind::Glass => {
                let ior = r[self.ior as usize];
                let ior = if ior.is_finite() && ior > 0.0 { ior } else { 1.5 };
                let eta = if g.backfacing { 1.0 / ior } else { ior };
                let d = DielectricBsdf::new(eta, rough(), false, Rgb::ONE).with_multiscatter();
                push(color() * w, Lobe::Dielectric(d));
            }
            ClosureKind::Emission => out.emission += color() * (r[self.strength as usize] * w),
            ClosureKind::Transparent => out.transparent += color() * w,
            ClosureKind::Holdout => out.holdout += w,
            ClosureKind::Principled(p) => principled(p, r, w, out),
        }
    }
}

fn principled(p: &PrincipledRegs, r: &[f32], w: f32, out: &mut Closures) {
    let f = |i: Reg| r[i as usize];
    let alpha = f(p.alpha).clamp(0.0, 1.0);
    if alpha < 1.0 {
        out.transparent += Rgb::splat(w * (1.0 - alpha));
    }
    let w = w * alpha;
    out.emission += v3(r, p.emission).max(Vec3::ZERO) * (f(p.emission_strength) * w);
    if w <= 0.0 {
        return;
    }
    if out.coat_normal.is_none()
        && let Some(n) = p.coat_normal
    {
        out.coat_normal = Some(v3(r, n));
    }
    let level = f(p.spec_level).max(0.0);
    let acc = &mut out.pbr;
    acc.base += v3(r, p.base).clamp(Vec3::ZERO, Vec3::ONE) * w;
    acc.metallic += f(p.metallic).clamp(0.0, 1.0) * w;
    acc.roughness += f(p.roughness).clamp(0.0, 1.0) * w;
    acc.ior += f(p.ior).max(1.0) * w;
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
    // The first Principled BSDF's film, whole (films do not average).
    let thickness = f(p.thin_film_thickness);
    if acc.thin_film.is_none() && thickness > 0.1 {
        acc.thin_film = Some((thickness, f(p.thin_film_ior).max(1e-5), 1.0));
    }
    out.pbr_w += w;
}

impl Closures {
    /// The merged Principled parameters (weights divided out), for a point on the side
    /// given by `backfacing`.
    pub fn principled_params(&self, backfacing: bool) -> PbrParams {
        let s = 1.0 / self.pbr_w;
        let p = &self.pbr;
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
            coat_ior: p.coat_ior * s,
            coat_tint: p.coat_tint * s,
            specular_color: p.specular_color * s,
            sheen_color: p.sheen_color * s,
            sheen_roughness: p.sheen_roughness * s,
            // Blender's graphs: Cycles' sheen.
            microfiber_sheen: true,
            dispersion: 0.0,
            subsurface: p.subsurface * s,
            anisotropy: None,
            thin_film: p.thin_film,
        }
    }

    /// The closure normal in world (glTF) axes, if a closure had one linked.
    pub fn normal_world(&self) -> Option<Vec3> {
        self.normal.map(from_blender).and_then(|n| n.try_normalize())
    }

    /// The coat normal in world axes.
    pub fn coat_normal_world(&self) -> Option<Vec3> {
        self.coat_normal.map(from_blender).and_then(|n| n.try_normalize())
    }
}

/// Capacity of the mixture, for the loader's warning.
pub const CAPACITY: usize = MAX_LOBES;
