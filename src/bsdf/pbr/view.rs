//! A [`PbrBsdf`] seen from one outgoing direction: the view-side terms (layer, coat and
//! sheen albedo at wo, the metal's multiscatter factor) computed once per vertex, then the
//! value, density and sampled bounce that next-event estimation and the path share.

use super::{Cuts, LobeChoice, PbrBsdf};
use crate::bsdf::microfacet::reflect;
use crate::bsdf::microfiber::Microfiber;
use crate::bsdf::{BsdfSample, LobeKind};
use crate::math::{Frame, Rgb};
use crate::sampling::warp::cosine_hemisphere;
use glam::{Vec2, Vec3};

/// A [`PbrBsdf`] seen from one outgoing direction ([`PbrBsdf::at`]): evaluates f(wo, wi)
/// for many wi with the wo-only terms (coat transmittance, layer and sheen albedos at wo)
/// computed once. `PbrBsdf::eval` goes through it, so there is one copy of the formula.
#[derive(Clone, Copy, Debug)]
pub struct PbrAt<'a> {
    pub(super) b: &'a PbrBsdf,
    pub(super) v: PbrView,
}

/// The wo-only terms of a [`PbrAt`] without the BSDF they belong to: a bidirectional
/// vertex keeps its own (`PbrBsdf::bind`), as it is joined to many vertices of the other
/// subpath from the same outgoing direction.
#[derive(Clone, Copy, Debug)]
pub struct PbrView {
    /// wo, flipped into the upper hemisphere.
    pub(super) wo: Vec3,
    /// wo was below the surface: wi is flipped with it.
    pub(super) flip: bool,
    /// What the coat leaves to the layers below, seen from wo.
    pub(super) under: Rgb,
    /// The opaque dielectric layer's albedo at wo.
    pub(super) eo: Rgb,
    /// The dielectric layer's multiple-scattering factor at wo.
    pub(super) layer_ms: Rgb,
    /// 1 - the sheen's albedo at wo (1 without sheen).
    pub(super) sheen_o: f32,
    /// The metal's multiple-scattering factor at wo.
    pub(super) metal_ms: Rgb,
    /// The coat's albedo at wo.
    pub(super) ec: f32,
    /// What a tinted coat transmits, seen from wo.
    pub(super) coat_t: Rgb,
    /// The sheen's albedo at wo (0 without sheen).
    pub(super) es: f32,
    /// The microfiber sheen seen from wo, when the sheen is one.
    pub(super) fiber: Option<Microfiber>,
    /// How `sample` chooses among the lobes at wo (`PbrBsdf::lobes`), computed once.
    pub(super) c: LobeChoice,
}

impl PbrView {
    /// The outgoing direction it was made for (unflipped).
    #[inline]
    pub fn outgoing(&self) -> Vec3 {
        if self.flip { Vec3::new(self.wo.x, self.wo.y, -self.wo.z) } else { self.wo }
    }
}

impl std::ops::Deref for PbrAt<'_> {
    type Target = PbrView;
    #[inline]
    fn deref(&self) -> &PbrView {
        &self.v
    }
}

impl<'a> PbrAt<'a> {
    /// With the lobe choice at wo made (which the density and sampling read).
    #[inline]
    pub fn lobed(mut self) -> Self {
        if self.v.wo.z > 0.0 {
            self.v.c = self.b.lobes(&self);
        }
        self
    }

    /// Its wo-only terms, to be bound again to the same BSDF by [`PbrBsdf::bind`].
    #[inline]
    pub fn view(&self) -> PbrView {
        self.v
    }
}

impl PbrAt<'_> {
    /// Density of [`PbrBsdf::sample`] for wi, as [`PbrBsdf::pdf`].
    #[inline]
    pub fn pdf(&self, wi: Vec3) -> f32 {
        let cuts = self.b.cuts(wi);
        let across = self.across(wi, cuts);
        let wi = if self.flip { Vec3::new(wi.x, wi.y, -wi.z) } else { wi };
        if self.wo.z <= 0.0 || wi.z == 0.0 {
            return 0.0;
        }
        self.b.pdf_with(&self.c, self.wo, wi, cuts, across)
    }

    /// True when light from `wi` (local, as given), below the shading frame's horizon, is
    /// reflected by the coat's own normal (`PbrBsdf::coat_across`): the integrators take it as
    /// a reflection. Never for a view from below the frame (the flipped BSDF).
    #[inline]
    pub fn reflects_across(&self, wi: Vec3) -> bool {
        wi.z < 0.0 && self.b.coat_frame.is_some() && self.across(wi, self.b.cuts(wi))
    }

    /// [`reflects_across`](Self::reflects_across) with the cuts toward wi at hand.
    #[inline]
    fn across(&self, wi: Vec3, cuts: Cuts) -> bool {
        !self.flip && self.b.coat_across(self.wo, wi, cuts)
    }

    /// [`PbrBsdf::sample`] from the view-side terms computed once.
    #[inline]
    pub fn sample(&self, uc: f32, u: Vec2) -> Option<BsdfSample> {
        let flip = self.flip;
        let mirror = |w: Vec3| if flip { Vec3::new(w.x, w.y, -w.z) } else { w };
        let wo_up = self.wo;
        if wo_up.z <= 0.0 {
            return None;
        }
        let this = self.b;
        let c = &self.c;
        let diffuse =
            uc >= c.glass + c.metal + c.spec && uc < c.glass + c.metal + c.spec + c.diffuse + c.dtrans + c.sheen;
        // The diffuse base's Lambertian transmission chose wi (below the surface).
        let dtrans =
            uc >= c.glass + c.metal + c.spec + c.diffuse && uc < c.glass + c.metal + c.spec + c.diffuse + c.dtrans;
        // Which lobe group samples: Cycles does not cut a closure's own sample, only what the
        // other closures evaluate toward it (`PbrBsdf::cuts`).
        let (from_spec, from_coat) =
            (uc < c.glass + c.metal + c.spec, uc >= c.glass + c.metal + c.spec + c.diffuse + c.dtrans + c.sheen);
        let wi_up = if uc < c.glass {
            let s = this.glass.sample(wo_up, uc / c.glass, u)?;
            if s.delta {
                let weight = self.coat_t
                    * (1.0 - this.metallic)
                    * this.transmission
                    * (1.0 - self.ec)
                    * this.sheen_scaling_from(self.sheen_o, s.wi.z.abs());
                return Some(BsdfSample {
                    wi: mirror(s.wi),
                    f: s.f * weight,
                    pdf: s.pdf * c.glass,
                    delta: true,
                    kind: s.kind,
                });
            }
            s.wi
        } else if uc < c.glass + c.metal + c.spec {
            if this.smooth {
                // Perfect mirror: the metal's and the dielectric layer's reflectance.
                let mu = wo_up.z;
                let under = self.under * this.sheen_scaling_from(self.sheen_o, mu);
                let opaque = (1.0 - this.metallic) * (1.0 - this.transmission);
                let metal = this.metal_fresnel(mu) * this.metallic;
                // The layer's albedo at roughness 0 is its Fresnel at μ, which the table holds for
                // η > 1; below 1 the table holds 1/η's (Cycles' estimate, which weights the base
                // only), and the mirror reflects the Fresnel of η, total internal reflection included.
                let layer = if this.layer && this.layer_eta < 1.0 { this.layer_fresnel(mu) } else { self.eo };
                let refl = (metal + layer * opaque) * under;
                let wi = Vec3::new(-wo_up.x, -wo_up.y, wo_up.z);
                return Some(BsdfSample {
                    wi: mirror(wi),
                    f: refl / mu,
                    pdf: c.metal + c.spec,
                    delta: true,
                    kind: LobeKind::Glossy,
                });
            }
            reflect(wo_up, this.ggx.sample_visible_normal(wo_up, u))
        } else if uc < c.glass + c.metal + c.spec + c.diffuse {
            match &this.diffuse_frame {
                Some(f) => f.to_world(cosine_hemisphere(u)),
                None => cosine_hemisphere(u),
            }
        } else if dtrans {
            let w = cosine_hemisphere(u);
            Vec3::new(w.x, w.y, -w.z)
        } else if uc < c.glass + c.metal + c.spec + c.diffuse + c.dtrans + c.sheen {
            match &c.fiber {
                Some(m) => m.sample(u)?,
                None => cosine_hemisphere(u),
            }
        } else {
            let cf = this.coat_frame.unwrap_or(Frame { s: Vec3::X, t: Vec3::Y, n: Vec3::Z });
            let wo_c = cf.to_local(wo_up);
            if wo_c.z <= 0.0 {
                return None;
            }
            if this.smooth_coat {
                let wi = cf.to_world(Vec3::new(-wo_c.x, -wo_c.y, wo_c.z));
                if wi.z == 0.0 || (wi.z < 0.0 && !self.across(mirror(wi), this.cuts(mirror(wi)))) {
                    return None;
                }
                return Some(BsdfSample {
                    wi: mirror(wi),
                    f: Rgb::splat(self.ec / wi.z.abs()),
                    pdf: c.coat,
                    delta: true,
                    kind: LobeKind::Glossy,
                });
            }
            // Below the coat's horizon the lobe has no value and `coat_pdf` no density: a sample
            // there (above the shading frame's horizon, so not caught below) would be counted at
            // the other lobes' density alone.
            let wi_c = reflect(wo_c, this.coat_ggx.sample_visible_normal(wo_c, u));
            if wi_c.z <= 0.0 {
                return None;
            }
            cf.to_world(wi_c)
        };
        if wi_up.z == 0.0 {
            return None;
        }
        // The density and value from the lobe choice and wo-terms of this call (the same
        // numbers `pdf` and `eval` would recompute: the profile had the albedo-table
        // lookups at wo three times per sampled bounce).
        let wi = mirror(wi_up);
        let mut cuts = this.cuts(wi);
        // Below the frame's horizon only the coat reflects where its normal puts wi above
        // (`coat_across`), and only the transmission lobes sample elsewhere: a glass or
        // diffuse transmission sample there is one Cycles labels a transmission above the
        // surface (and drops), a coat sample cut there one whose density `pdf` does not count.
        if wi_up.z < 0.0 {
            let across = self.across(wi, cuts);
            if across != from_coat || (!from_coat && uc >= c.glass && !dtrans) {
                return None;
            }
        }
        let across = wi_up.z < 0.0 && from_coat;
        cuts.spec &= !from_spec;
        cuts.coat &= !from_coat;
        let pdf = this.pdf_with(c, wo_up, wi_up, cuts, across);
        if !(pdf > 0.0) {
            return None;
        }
        let kind = if diffuse { LobeKind::Diffuse } else { LobeKind::Glossy };
        Some(BsdfSample { wi, f: self.eval_with(wi, cuts, across), pdf, delta: false, kind })
    }
}

impl PbrAt<'_> {
    /// f(wo, wi), as [`PbrBsdf::eval`].
    #[inline]
    pub fn eval(&self, wi: Vec3) -> Rgb {
        let cuts = self.b.cuts(wi);
        self.eval_with(wi, cuts, wi.z < 0.0 && self.across(wi, cuts))
    }

    /// [`eval`](Self::eval) with the lobes `cuts` leaves out (Cycles' `bump_shadowing_term`);
    /// `across`: wi is one only the coat reflects (`PbrBsdf::coat_across`).
    #[inline]
    fn eval_with(&self, wi: Vec3, cuts: Cuts, across: bool) -> Rgb {
        let b = self.b;
        let wo = self.wo;
        let wi = if self.flip { Vec3::new(wi.x, wi.y, -wi.z) } else { wi };
        if wo.z <= 0.0 || wi.z == 0.0 {
            return Vec3::ZERO;
        }
        if across {
            return if b.smooth_coat { Rgb::ZERO } else { Rgb::splat(b.coat_eval(wo, wi)) };
        }
        let dielectric = 1.0 - b.metallic;
        let under = self.under;
        let scaling = b.sheen_scaling_from(self.sheen_o, wi.z.abs());
        let mut f = Rgb::ZERO;
        if b.transmission > 0.0 && !cuts.spec {
            f += b.glass.eval(wo, wi) * (dielectric * b.transmission);
        }
        if wi.z < 0.0 {
            return f * (under * scaling) + self.diffuse_transmission_up(wi);
        }
        let h = (wo + wi).normalize();
        let cos_h = wo.dot(h).max(0.0);
        // Smooth reflection is a delta lobe: sampled only, never evaluated. Without a
        // specular layer or metal nothing reads the microfacet term (a floor of Specular 0:
        // GGX's D and G2 were 1 % of the glass bench scene's instructions).
        let spec = if b.smooth || !(b.layer || b.metallic > 0.0) || cuts.spec {
            0.0
        } else {
            b.ggx.d(h) * b.ggx.g2(wo, wi) / (4.0 * wo.z * wi.z)
        };
        let opaque = dielectric * (1.0 - b.transmission);
        if opaque > 0.0 {
            // Cycles' layer: its Fresnel and compensation, the base under 1 − max(albedo at wo).
            let f_layer = if b.layer && spec > 0.0 { b.layer_fresnel(cos_h) * self.layer_ms } else { Rgb::ZERO };
            // What diffuse transmission leaves to the reflecting base (a factor of 1 without it).
            let diffuse_weight = PbrBsdf::base_weight(self.eo) * (1.0 - b.subsurface) * (1.0 - b.diffuse_transmission);
            f += (b.diffuse_f(wo, wi, diffuse_weight) + f_layer * spec) * opaque;
        }
        if b.metallic > 0.0 {
            f += b.metal_fresnel(cos_h) * self.metal_ms * (spec * b.metallic);
        }
        f = (f * scaling + b.sheen_eval(&self.fiber, wo, wi)) * under;
        if b.coat > 0.0 && !b.smooth_coat && !b.coat_dropped && !cuts.coat {
            f += Rgb::splat(b.coat_eval(wo, wi));
        }
        f
    }
}
