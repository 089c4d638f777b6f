//! Scattering functions. A [`Bsdf`] lives in a local shading frame (+Z = shading
//! normal) and offers `eval`, `pdf` and `sample` on local directions; both directions
//! point away from the surface. Closed set of lobes: an enum, no dynamic dispatch.

pub mod albedo;
mod albedo_table;
pub mod aniso_albedo;
pub mod ashikhmin_shirley;
mod beckmann;
pub mod dielectric;
mod exclude;
pub mod fresnel_layer;
pub mod glass_albedo;
pub mod hair;
pub mod hair_lobes;
mod layer_table;
pub mod microfacet;
pub mod microfiber;
mod microfiber_table;
pub mod mix;
pub mod oren_nayar;
pub mod pbr;
pub mod sheen;
pub mod thin_film;
pub mod velvet;

use crate::math::Rgb;
use glam::{Vec2, Vec3};
pub use hair::HairBsdf;
pub use hair_lobes::HairLobes;
pub use mix::MixBsdf;
pub use pbr::{PbrAt, PbrBsdf, PbrView};

/// A sampled direction with the BSDF value and the density that chose it.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Incident direction, local frame.
    pub wi: Vec3,
    /// BSDF value f(wo, wi) (not multiplied by the cosine).
    pub f: Rgb,
    /// Solid-angle density of `wi` (for a delta lobe: the probability of choosing it).
    pub pdf: f32,
    /// Chosen from a delta lobe (perfect mirror or refraction): no MIS, no NEE.
    pub delta: bool,
    /// The kind of lobe that chose `wi` (Cycles' closure labels; with `delta` = singular).
    pub kind: LobeKind,
}

/// Which kind of lobe sampled a direction, as Cycles labels its closures.
///
/// Ray visibility, the Light Path node and the light passes classify a bounce by it:
/// diffuse (Lambert, Oren-Nayar, translucent, sheen) or glossy (microfacet and smooth
/// reflection or refraction; singular when the sample is `delta`). Whether the bounce
/// transmitted is geometric: `wi` on the other side of the surface from `wo`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LobeKind {
    /// A diffuse closure (reflecting or translucent).
    Diffuse,
    /// A glossy closure: metal, specular, coat, glass reflection or refraction.
    Glossy,
}

/// The scattering function at a surface point.
///
/// The mixture makes the enum 1472 bytes (436 for `Pbr` alone; 764 while a mixture held one
/// Principled BSDF and shared one frame); boxing it would allocate per shading point.
/// Measured (callgrind, Cornell box 96×72, 8 spp, 1 thread): `render::render` executed 0.13 %
/// fewer instructions than before the variant existed, and 0.04 % fewer again after the
/// mixture grew to two Principled BSDFs and a frame a closure (1,087,234,848 →
/// 1,086,826,579), so materials without a graph do not pay for it; SPPM's visible points and
/// BDPT's vertices grow by the difference.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
pub enum Bsdf {
    /// glTF 2.0 metallic-roughness (Appendix B of the spec).
    Pbr(PbrBsdf),
    /// A weighted mixture of closures (a shader graph's Surface output, `mix.rs`).
    Mix(MixBsdf),
    /// The Principled Hair BSDF (Chiang) of a strand (`hair.rs`).
    Hair(HairBsdf),
    /// The (non-principled) Hair BSDF's lobes of a strand (`hair_lobes.rs`).
    HairLobes(HairLobes),
}

impl Bsdf {
    /// Probability that a path at this material takes its subsurface part, seen from
    /// `wo` (what the layers above leave to the diffuse base, times the subsurface
    /// weight; 0 without subsurface). The BSDF holds the rest.
    #[inline]
    pub fn subsurface_weight(&self, wo: Vec3) -> f32 {
        match self {
            Bsdf::Pbr(b) => b.subsurface_weight(wo),
            Bsdf::Mix(m) => m.subsurface_weight(wo),
            Bsdf::Hair(_) | Bsdf::HairLobes(_) => 0.0,
        }
    }

    /// Colour and roughness of the diffuse base, which a subsurface walk takes as its
    /// albedo and entry roughness, and the IOR of its entry: the specular layer's, the
    /// material's IOR adjusted by the specular factor (Cycles' `bssrdf->ior = eta`).
    #[inline]
    pub fn subsurface_base(&self) -> (Rgb, f32, f32) {
        match self {
            Bsdf::Pbr(b) => (b.base, b.roughness, b.layer_eta()),
            Bsdf::Mix(m) => {
                let p = m.subsurface_part();
                (p.base, p.roughness, p.layer_eta())
            }
            Bsdf::Hair(h) => (h.albedo(), 1.0, 1.0),
            Bsdf::HairLobes(h) => (h.albedo(), 1.0, 1.0),
        }
    }

    /// f(wo, wi).
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        match self {
            Bsdf::Pbr(b) => b.eval(wo, wi),
            Bsdf::Mix(m) => m.eval(wo, wi),
            Bsdf::Hair(h) => h.eval(wo, wi),
            Bsdf::HairLobes(h) => h.eval(wo, wi),
        }
    }

    /// The BSDF seen from `wo`, for evaluating many `wi` (photon gathers).
    #[inline]
    pub fn at(&self, wo: Vec3) -> BsdfAt<'_> {
        match self {
            Bsdf::Pbr(b) => BsdfAt::Pbr(b.at(wo)),
            Bsdf::Mix(m) => BsdfAt::Mix(m, wo),
            Bsdf::Hair(h) => BsdfAt::Hair(h, wo),
            Bsdf::HairLobes(h) => BsdfAt::HairLobes(h, wo),
        }
    }

    /// The BSDF seen from `wo` for its value alone: [`at`](Self::at) without the lobe
    /// choice, which only densities and sampling read ([`BsdfValue::lobed`] makes it). A
    /// connection's value is zero before any density is asked for 40 % of the Cornell box's.
    #[inline]
    pub fn at_value(&self, wo: Vec3) -> BsdfValue<'_> {
        BsdfValue(match self {
            Bsdf::Pbr(b) => BsdfAt::Pbr(b.at_value(wo)),
            _ => self.at(wo),
        })
    }

    /// [`at`](Self::at) again from the terms [`BsdfAt::view`] kept of it (for this BSDF).
    #[inline]
    pub fn bind(&self, v: &BsdfView) -> BsdfAt<'_> {
        match (self, v) {
            (Bsdf::Pbr(b), BsdfView::Pbr(v)) => BsdfAt::Pbr(b.bind(v)),
            (Bsdf::Mix(m), BsdfView::Wo(wo)) => BsdfAt::Mix(m, *wo),
            (Bsdf::Hair(h), BsdfView::Wo(wo)) => BsdfAt::Hair(h, *wo),
            (Bsdf::HairLobes(h), BsdfView::Wo(wo)) => BsdfAt::HairLobes(h, *wo),
            // Another kind of BSDF's view (a caller's mistake): its direction seen afresh.
            (_, v) => {
                debug_assert!(false, "a BSDF view bound to another kind of BSDF");
                self.at(v.wo())
            }
        }
    }

    /// Density with which `sample` returns `wi` given `wo`.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Bsdf::Pbr(b) => b.pdf(wo, wi),
            Bsdf::Mix(m) => m.pdf(wo, wi),
            Bsdf::Hair(h) => h.pdf(wo, wi),
            Bsdf::HairLobes(h) => h.pdf(wo, wi),
        }
    }

    /// Samples an incident direction; `uc` picks the lobe, `u` the direction.
    #[inline]
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        match self {
            Bsdf::Pbr(b) => b.sample(wo, uc, u),
            Bsdf::Mix(m) => m.sample(wo, uc, u),
            Bsdf::Hair(h) => hair_sample(h, wo, uc, u),
            Bsdf::HairLobes(h) => lobes_sample(h, wo, uc, u),
        }
    }

    /// Cycles' Filter Glossy at a vertex reached by a path whose least likely bounce had
    /// density `min_pdf`: with `blur_pdf = min_pdf / filter_glossy` below 1, every microfacet
    /// lobe is widened to α ≥ ½ √(1 − blur_pdf) (`surface_shader_prepare_closures`,
    /// `bsdf_microfacet_blur`). Hair is not blurred here (Cycles blurs it too).
    pub fn blur(&mut self, filter_glossy: f32, min_pdf: f32) {
        if !(filter_glossy > 0.0) {
            return;
        }
        let blur_pdf = min_pdf / filter_glossy;
        if blur_pdf < 1.0 {
            let alpha = (1.0 - blur_pdf).sqrt() * 0.5;
            match self {
                Bsdf::Pbr(b) => b.blur(alpha),
                Bsdf::Mix(m) => m.blur(alpha),
                Bsdf::Hair(_) | Bsdf::HairLobes(_) => {}
            }
        }
    }

    /// Drops the reflective (`reflective`) and refractive (`refractive`) closures, as Cycles
    /// does at a point reached by a diffuse bounce with a caustics switch off
    /// (`LightPaths::drops_caustics`). Hair keeps its lobes (Cycles tests no switch there).
    pub fn drop_caustics(&mut self, reflective: bool, refractive: bool) {
        if !(reflective || refractive) {
            return;
        }
        match self {
            Bsdf::Pbr(b) => b.drop_caustics(reflective, refractive),
            Bsdf::Mix(m) => m.drop_caustics(reflective, refractive),
            Bsdf::Hair(_) | Bsdf::HairLobes(_) => {}
        }
    }

    /// True when every lobe is a delta lobe (light sampling cannot help).
    #[inline]
    pub fn is_delta(&self) -> bool {
        match self {
            Bsdf::Pbr(b) => b.is_delta(),
            Bsdf::Mix(m) => m.is_delta(),
            Bsdf::Hair(_) | Bsdf::HairLobes(_) => false,
        }
    }

    /// The adjoint BSDF f*(wo, wi) = f(wi, wo) that carries importance along light paths:
    /// the same as `eval` with the arguments swapped for reflection; for refraction across
    /// a solid's interface `eval` is Cycles' BTDF, η² times a reciprocal one (the camera's
    /// throughput keeps 1 - F whatever η, `bsdf::dielectric`), so its adjoint is `eval(wo,
    /// wi)` over η² (times the change of rough glass's multiple-scattering compensation,
    /// which depends on the viewer's side).
    #[inline]
    pub fn eval_adjoint(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z * wi.z >= 0.0 {
            self.eval(wi, wo)
        } else if let Bsdf::Pbr(b) = self
            && let Some(back) = b.across_pair(wo, wi)
        {
            // A reflection by the coat's own normal across the frame's horizon.
            if back { self.eval(wi, wo) } else { self.eval(wo, wi) * b.across_adjoint_ratio(wo, wi) }
        } else if let Bsdf::Pbr(b) = self
            && b.transmits_diffusely()
        {
            // Lambertian transmission crosses no interface of another η: its adjoint is f(wi, wo).
            b.crossing_adjoint(wo, wi, self.refraction_adjoint_scale())
        } else {
            self.eval(wo, wi) * self.refraction_adjoint_scale() * self.refraction_adjoint_ratio(wo, wi)
        }
    }

    /// [`eval_adjoint`](Self::eval_adjoint) from this BSDF seen from both directions,
    /// `own` = `at(wo)` and `back` = `at_value(wi)`, which a bidirectional vertex has at hand for
    /// its densities as well (the same value bit for bit).
    #[inline]
    pub fn eval_adjoint_at(&self, own: &BsdfAt, back: &BsdfValue, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z * wi.z >= 0.0 {
            back.eval(wo)
        } else if let Bsdf::Pbr(b) = self
            && let Some(from_back) = b.across_pair(wo, wi)
        {
            if from_back { back.eval(wo) } else { own.eval(wi) * b.across_adjoint_ratio(wo, wi) }
        } else if let Bsdf::Pbr(b) = self
            && b.transmits_diffusely()
        {
            b.crossing_adjoint(wo, wi, self.refraction_adjoint_scale())
        } else {
            own.eval(wi) * self.refraction_adjoint_scale() * self.refraction_adjoint_ratio(wo, wi)
        }
    }

    /// For a refracted pair (wo, wi), η² f(wi, wo) over f(wo, wi): not 1 when
    /// rough glass compensates multiple scattering, which depends on the viewer's side.
    #[inline]
    pub fn refraction_adjoint_ratio(&self, wo: Vec3, wi: Vec3) -> Rgb {
        match self {
            Bsdf::Pbr(b) => b.refraction_adjoint_ratio(wo, wi),
            Bsdf::Mix(m) => m.refraction_adjoint_ratio(wo, wi),
            Bsdf::Hair(_) | Bsdf::HairLobes(_) => Rgb::ONE,
        }
    }

    /// 1/η² of the refracting part (1 for thin sheets): the ratio between a transmitted
    /// sample's adjoint value (light paths) and its value (camera paths).
    #[inline]
    pub fn refraction_adjoint_scale(&self) -> f32 {
        match self {
            Bsdf::Pbr(b) => {
                if b.glass.thin {
                    1.0
                } else {
                    1.0 / (b.glass.eta * b.glass.eta)
                }
            }
            Bsdf::Mix(m) => m.refraction_adjoint_scale(),
            // Light leaves the fibre into the medium it came from: no change of η.
            Bsdf::Hair(_) | Bsdf::HairLobes(_) => 1.0,
        }
    }

    /// How rough the glossy transmission is, as Cycles' Film → Transparent Glass compares
    /// it with its threshold (its specular roughness squared): αx·αy of the refracting lobe,
    /// 0 when smooth; the roughest of several refracting lobes; infinite for hair.
    #[inline]
    pub fn glass_alpha2(&self) -> f32 {
        match self {
            Bsdf::Pbr(b) => b.glass.alpha2(),
            Bsdf::Mix(m) => m.glass_alpha2(),
            Bsdf::Hair(_) | Bsdf::HairLobes(_) => f32::INFINITY,
        }
    }

    /// True when light from `wi` reaches `wo` (the shading frame) by a reflection: on wo's side
    /// of the frame's horizon, or across it by a coat on its own normal
    /// (`PbrBsdf::reflects_across`, Cycles' per-closure reflection). The integrators check it
    /// against the sides the geometric normal gives.
    #[inline]
    pub fn reflects(&self, wo: Vec3, wi: Vec3) -> bool {
        wi.z * wo.z > 0.0 || matches!(self, Bsdf::Pbr(b) if b.reflects_across(wo, wi))
    }

    /// True when some light may pass through to the other side.
    #[inline]
    pub fn transmits(&self) -> bool {
        match self {
            Bsdf::Pbr(b) => b.transmits(),
            Bsdf::Mix(m) => m.transmits(),
            Bsdf::Hair(_) | Bsdf::HairLobes(_) => true,
        }
    }

    /// Colour for the "Denoising Albedo" pass.
    pub fn albedo(&self) -> Rgb {
        match self {
            Bsdf::Pbr(b) => b.albedo(),
            Bsdf::Mix(m) => m.albedo(),
            Bsdf::Hair(h) => h.albedo(),
            Bsdf::HairLobes(h) => h.albedo(),
        }
    }
}

/// A [`Bsdf`] seen from one outgoing direction ([`Bsdf::at`]): what depends on wo alone
/// (layer albedos, the lobe weights) is computed once for the NEE evaluation, its MIS
/// density and the sampled bounce of one vertex.
#[derive(Clone, Copy, Debug)]
pub enum BsdfAt<'a> {
    /// glTF metallic-roughness.
    Pbr(PbrAt<'a>),
    /// A mixture and wo (its lobes' wo-only terms are cheap; evaluated per call).
    Mix(&'a MixBsdf, Vec3),
    /// A hair fibre and wo.
    Hair(&'a HairBsdf, Vec3),
    /// The Hair BSDF's lobes and wo.
    HairLobes(&'a HairLobes, Vec3),
}

/// A [`BsdfAt`]'s wo-only terms apart from the BSDF ([`BsdfAt::view`], [`Bsdf::bind`]): a
/// bidirectional vertex keeps its own, as it is joined to many vertices of the other
/// subpath from one outgoing direction (BDPT and VCM computed some 30 views a sample on
/// the Cornell box, against 2.4 in the path tracer).
#[derive(Clone, Copy, Debug)]
pub enum BsdfView {
    /// A Principled BSDF's terms.
    Pbr(PbrView),
    /// Any other BSDF's: wo alone (their views compute nothing ahead).
    Wo(Vec3),
}

/// A [`BsdfAt`] for its value alone ([`Bsdf::at_value`]).
#[derive(Clone, Copy, Debug)]
pub struct BsdfValue<'a>(BsdfAt<'a>);

impl<'a> BsdfValue<'a> {
    /// f(wo, wi), as [`BsdfAt::eval`].
    #[inline]
    pub fn eval(&self, wi: Vec3) -> Rgb {
        self.0.eval(wi)
    }

    /// The whole view, with the lobe choice made: `Bsdf::at(wo)` bit for bit.
    #[inline]
    pub fn lobed(self) -> BsdfAt<'a> {
        match self.0 {
            BsdfAt::Pbr(b) => BsdfAt::Pbr(b.lobed()),
            other => other,
        }
    }
}

impl BsdfView {
    /// The outgoing direction it was made for.
    #[inline]
    pub fn wo(&self) -> Vec3 {
        match self {
            BsdfView::Pbr(v) => v.outgoing(),
            BsdfView::Wo(wo) => *wo,
        }
    }
}

impl BsdfAt<'_> {
    /// Its wo-only terms, to be bound again to the same BSDF by [`Bsdf::bind`].
    #[inline]
    pub fn view(&self) -> BsdfView {
        match self {
            BsdfAt::Pbr(b) => BsdfView::Pbr(b.view()),
            BsdfAt::Mix(_, wo) | BsdfAt::Hair(_, wo) | BsdfAt::HairLobes(_, wo) => BsdfView::Wo(*wo),
        }
    }

    /// f(wo, wi), as [`Bsdf::eval`].
    #[inline]
    pub fn eval(&self, wi: Vec3) -> Rgb {
        match self {
            BsdfAt::Pbr(b) => b.eval(wi),
            BsdfAt::Mix(m, wo) => m.eval(*wo, wi),
            BsdfAt::Hair(h, wo) => h.eval(*wo, wi),
            BsdfAt::HairLobes(h, wo) => h.eval(*wo, wi),
        }
    }

    /// Density of [`sample`](Self::sample) for wi, as [`Bsdf::pdf`].
    #[inline]
    pub fn pdf(&self, wi: Vec3) -> f32 {
        match self {
            BsdfAt::Pbr(b) => b.pdf(wi),
            BsdfAt::Mix(m, wo) => m.pdf(*wo, wi),
            BsdfAt::Hair(h, wo) => h.pdf(*wo, wi),
            BsdfAt::HairLobes(h, wo) => h.pdf(*wo, wi),
        }
    }

    /// Samples an incident direction, as [`Bsdf::sample`].
    #[inline]
    pub fn sample(&self, uc: f32, u: Vec2) -> Option<BsdfSample> {
        match self {
            BsdfAt::Pbr(b) => b.sample(uc, u),
            BsdfAt::Mix(m, wo) => m.sample(*wo, uc, u),
            BsdfAt::Hair(h, wo) => hair_sample(h, *wo, uc, u),
            BsdfAt::HairLobes(h, wo) => lobes_sample(h, *wo, uc, u),
        }
    }

    /// True when light from `wi` (the shading frame), below its horizon, is reflected by a lobe
    /// on its own normal: a Principled BSDF's coat (`PbrAt::reflects_across`).
    #[inline]
    pub fn reflects_across(&self, wi: Vec3) -> bool {
        match self {
            BsdfAt::Pbr(b) => b.reflects_across(wi),
            _ => false,
        }
    }

    /// The side of the surface the BSDF puts `wi` (the shading frame) on: above the frame's
    /// horizon, or below it where a coat on its own normal reflects it (`reflects_across`).
    /// The integrators check it against the side the geometric normal gives.
    #[inline]
    pub fn above(&self, wi: Vec3) -> bool {
        wi.z > 0.0 || self.reflects_across(wi)
    }

    /// The part of [`eval`](Self::eval) from diffuse-class closures (Cycles' classes, for
    /// the light passes: diffuse, translucent, sheen).
    #[inline]
    pub fn eval_diffuse(&self, wi: Vec3) -> Rgb {
        match self {
            BsdfAt::Pbr(b) => b.eval_diffuse(wi),
            BsdfAt::Mix(m, wo) => m.eval_diffuse(*wo, wi),
            // Cycles labels every hair lobe glossy.
            BsdfAt::Hair(..) | BsdfAt::HairLobes(..) => Rgb::ZERO,
        }
    }

    /// Albedo per closure class (diffuse, glossy, transmission) seen from wo: the
    /// Colour passes.
    pub fn class_albedo(&self) -> [Rgb; 3] {
        match self {
            BsdfAt::Pbr(b) => b.class_albedo(),
            BsdfAt::Mix(m, wo) => m.class_albedo(*wo),
            BsdfAt::Hair(h, _) => [Rgb::ZERO, h.albedo(), Rgb::ZERO],
            // Cycles labels the Hair BSDF's lobes glossy (reflection and transmission alike).
            BsdfAt::HairLobes(h, _) => [Rgb::ZERO, h.albedo(), Rgb::ZERO],
        }
    }
}

/// A hair sample as a `BsdfSample`: every lobe is glossy (Cycles' labels), none is a delta.
#[inline]
fn hair_sample(h: &HairBsdf, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
    h.sample(wo, uc, u).map(|(wi, f, pdf, _)| BsdfSample { wi, f, pdf, delta: false, kind: LobeKind::Glossy })
}

/// A Hair BSDF sample as a `BsdfSample`: both lobes are glossy (Cycles' labels), none a delta.
#[inline]
fn lobes_sample(h: &HairLobes, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
    h.sample(wo, uc, u).map(|(wi, f, pdf, _)| BsdfSample { wi, f, pdf, delta: false, kind: LobeKind::Glossy })
}
