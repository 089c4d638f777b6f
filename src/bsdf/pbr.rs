//! The glTF 2.0 metallic-roughness BRDF, as written in Appendix B of the glTF spec:
//!
//! ```text
//! dielectric = fresnel_mix(ior 1.5, base = lambert(base_color), layer = ggx(α))
//! metal      = conductor_fresnel(f0 = base_color, ggx(α))
//! f          = mix(dielectric, metal, metallic)
//! ```
//! with Schlick's Fresnel on the half vector, height-correlated Smith masking, and
//! α = roughness². Sampling picks the GGX lobe (visible normals) or the cosine-weighted
//! diffuse lobe with a probability estimated from the layer albedos at `wo`; `pdf` is
//! the mixture of both, so it matches `sample` exactly.
//!
//! The dielectric specular layer is Cycles' Principled one rather than Appendix B's
//! (`fresnel_layer.rs`): the exact dielectric Fresnel's shape for the layer's IOR rescaled
//! to start at its F0, with Cycles' multiple-scattering compensation; the diffuse base under
//! it is weighted by 1 − max over channels of the layer's albedo seen from wo, Cycles'
//! layering (tabulated over roughness, μ and η). Appendix B's (1 − F(v·h)) per direction pair
//! reflected more than it received near 60° for smooth surfaces; the albedo scaling conserves
//! energy exactly (a white base reflects what the layer leaves), but like Cycles' it is not
//! reciprocal: light paths use the adjoint (`Bsdf::eval_adjoint` swaps the directions).
//!
//! The glTF extensions layer on top by albedo scaling, as the glTF spec's layering rules
//! say: `KHR_materials_specular` colour tints the dielectric layer's F0 per channel and its
//! factor scales F0 as Blender imports it (half the Specular IOR Level; F90 stays 1),
//! `KHR_materials_sheen` is a Charlie-distribution sheen
//! (Estevez & Kulla 2017, Ashikhmin visibility) over everything below it with the
//! reciprocal scaling min(1 - s·E(μo), 1 - s·E(μi)), s = max(sheen colour), and
//! `KHR_materials_clearcoat` is a GGX layer of IOR 1.5 on top, with its own normal (Schlick's
//! Fresnel; Blender's coat takes Cycles' exact dielectric Fresnel of its Coat IOR,
//! `PbrParams::coat_dielectric_fresnel`). Blender's
//! sheen is Cycles' microfiber sheen instead (`microfiber.rs`, `CAUSTIC_materials_sheen`),
//! which scales the layers below by the view's side alone, 1 - s·E(μo), as Cycles does (the
//! sheen stays under the coat; Cycles puts it above).
//!
//! Multiple scattering between microfacets, as Cycles' default Multiscatter GGX: the
//! metal's GGX lobe keeps only E(μo) of the light (E of the white lobe, tabulated), so it
//! is scaled by 1 + F_ms (1/E(μo) - 1), with Kulla & Conty's Fresnel-averaged colour
//! F_ms = F_avg E_avg / (1 - F_avg (1 - E_avg)), F_avg = F0 + (1 - F0)/21 the cosine-weighted
//! average of Schlick's Fresnel: a white metal keeps all of the light, a coloured one
//! saturates as its interreflections do. The glass does the same with its own tables
//! (`DielectricBsdf::with_multiscatter`). The factor depends on wo alone, which keeps the
//! sampling exact and, as in Cycles, makes those lobes non-reciprocal (light paths use
//! the adjoint, `Bsdf::eval_adjoint`). The opaque dielectric's specular layer is compensated
//! the same way with its own F_ms (`fresnel_layer.rs`); the coat stays single-scattering.
//! Blender's Principled "GGX" (`PbrParams::single_scatter`) has none of these factors, and
//! the diffuse base under its layer takes Cycles' estimate mix(F0, 1, s), the layer's albedo
//! over the white lobe's E (Cycles' closure weight carries E only when compensated).
//!
//! `KHR_materials_anisotropy` (and Blender's Anisotropic): the metal's and the specular
//! layer's GGX take widths (αx, αy) along the shading frame's X axis (the anisotropy
//! direction) and Y; their albedos, for the layering and the multiple-scattering
//! compensation, come from the anisotropic table (`aniso_albedo.rs`), which depends on the
//! view's azimuth too. The glass stays isotropic, as in Cycles' Principled BSDF.
//!
//! Blender's Principled BSDF adds three things Cycles does its own way: a Diffuse Roughness
//! makes the diffuse base Cycles' Oren-Nayar (Fujii's, with its multiple-scattering term,
//! `oren_nayar.rs`) under the same layer weight; the diffuse base takes a base colour above 1
//! as given (the metal, glass and subsurface take it clamped); and the glass transmits
//! √(base colour) at each crossing and an anisotropic lobe's albedo is read at Cycles' isotropic
//! proxy (`PbrParams::cycles_principled`; glTF's glass tints by the colour).
//!
//! The shading frame's normal is the one the specular lobes see, which the caller may have
//! bent towards the geometric normal to keep mirror reflections above the surface (as
//! Cycles does, `scene::bent_normal`). Cycles leaves its diffuse closure on the unbent
//! normal; so does this BSDF: the diffuse base then has its own normal (`diffuse_normal`),
//! its cosine taken to it as the coat's is to the coat normal.
//!
//! Under a normal map the diffuse base is shadowed as Cycles shadows its diffuse closures
//! (the bump terminator: Estevez et al. 2019, "A Microfacet-Based Shadowing Function to Solve
//! the Bump Terminator Problem"): the mapped normal's deviation θd from the interpolated
//! normal Ns is read as the roughness of a GGX surface, α² = min(tan²θd / 8, 1), whose
//! masking G1 at the light's angle to Ns scales the diffuse value; light on the other side
//! of Ns than the mapped normal puts it is not reflected at all.

use super::BsdfSample;
pub use super::albedo::F0_DIELECTRIC;
use super::aniso_albedo::aniso_albedo;
use super::dielectric::{DielectricBsdf, SMOOTH_ROUGHNESS};
use super::fresnel_layer::{eta_z, f0_of, fresnel_s, layer_albedo, layer_eta};
use super::hair::BumpCut;
use super::microfacet::{Ggx, f82_tint, f82_tint_b, fresnel_dielectric, schlick_weight};
use super::microfiber::Microfiber;
use super::oren_nayar::OrenNayar;
use super::sheen::{charlie_brdf, sheen_albedo_table};
use super::thin_film::{conductor_film_reflectance, f82_conductor_index, film_reflectance};
use crate::math::{Frame, Rgb, luminance};
use crate::sampling::warp::cosine_hemisphere_pdf;
use glam::{Vec2, Vec3};

// The renderer warms the table up through this path before rendering.
pub use super::albedo::specular_albedo;

/// The smallest IOR a Principled BSDF keeps (Cycles' `fmaxf(ior, 1e-5f)`).
pub const MIN_IOR: f32 = 1e-5;

/// Normal-incidence reflectance of a dielectric of index `ior` in air.
#[inline]
pub fn f0_from_ior(ior: f32) -> f32 {
    let r = (ior - 1.0) / (ior + 1.0);
    r * r
}

/// The glTF material BSDF: a metal, an opaque dielectric (specular over diffuse) and a
/// transmissive dielectric (glass), mixed by metallic and transmission as the glTF
/// spec and Blender's Principled BSDF mix them.
#[derive(Clone, Copy, Debug)]
pub struct PbrBsdf {
    /// Base colour (linear), clamped to [0, 1]: the metal's F0 and the glass tint.
    pub base: Rgb,
    /// The diffuse base's colour: the base colour unclamped above (Cycles weights its
    /// Principled diffuse closure by the base colour as given).
    pub diffuse: Rgb,
    /// Blender's Diffuse Roughness σ (0: Lambertian).
    diffuse_roughness: f32,
    /// The diffuse base's rough lobe for this base colour, when σ is above Cycles' cutoff.
    oren: Option<OrenNayar>,
    /// The glass transmits √base (Blender's Principled BSDF as Cycles) instead of the base colour.
    cycles_principled: bool,
    /// Metalness in [0, 1].
    pub metallic: f32,
    /// Perceptual roughness in [0, 1] (for the albedo table).
    pub roughness: f32,
    /// Scale of the dielectric layer's F0 (`KHR_materials_specular` specularFactor, Blender's
    /// 2 × Specular IOR Level); 0: no layer.
    pub specular: f32,
    /// Normal-incidence reflectance of the opaque dielectric's layer (from the IOR).
    pub f0: f32,
    /// Per-channel F0 of that layer: min(f0 × specular × specular colour, 1).
    pub f0_rgb: Rgb,
    /// The layer's η, whose exact Fresnel gives its shape (the IOR of F0 × specular).
    layer_eta: f32,
    /// F0 of `layer_eta` (where the shape starts).
    layer_f0_eta: f32,
    /// `layer_eta` on the albedo table's axis.
    layer_z: f32,
    /// A thin film on the dielectric layer: (thickness nm, film IOR, weight).
    film: Option<(f32, f32, f32)>,
    /// The film on the metal too (`PbrParams::thin_film_metal`).
    metal_film: bool,
    /// The opaque dielectric has a specular layer (η > 1 or a film).
    layer: bool,
    /// Weight of the glass part within the dielectric part.
    pub transmission: f32,
    /// The glass part.
    pub glass: DielectricBsdf,
    /// Microfacet distribution of the reflection lobes.
    pub ggx: Ggx,
    /// Weight of the clear coat (a GGX dielectric layer of IOR 1.5 over everything).
    pub coat: f32,
    /// Roughness of the coat (for its albedo table).
    pub coat_roughness: f32,
    /// Microfacets of the coat.
    pub coat_ggx: Ggx,
    /// The reflection lobes are perfect mirrors (roughness below `SMOOTH_ROUGHNESS`).
    pub smooth: bool,
    /// F_ms per channel of the dielectric layer's multiple-scattering compensation (zero: off).
    layer_fms: Rgb,
    /// F_ms per channel of the metal's multiple-scattering compensation (zero: off).
    metal_fms: Rgb,
    /// The metal's F82 tint (Cycles' Principled: Specular Tint; white: Schlick's Fresnel).
    metal_tint: Rgb,
    /// The F82-tint factor b of the metal for this base colour (zero: Schlick's).
    metal_b: Rgb,
    /// Mean albedo E_avg = A_avg + B_avg of the reflection lobes (the metal's F_ms needs it).
    e_avg: f32,
    /// The glass part restores multiple scattering (its F_ms depends on the base colour).
    glass_ms: bool,
    /// No multiple-scattering compensation (`PbrParams::single_scatter`).
    single_scatter: bool,

    /// The coat is a perfect mirror.
    pub smooth_coat: bool,
    /// The coat's frame within the shading frame, when its normal differs.
    pub coat_frame: Option<Frame>,
    /// The diffuse base's frame within the shading frame, when its normal differs.
    pub diffuse_frame: Option<Frame>,
    /// Perceptual roughnesses (√αx, √αy) of anisotropic reflection lobes (their albedo table).
    aniso: Option<(f32, f32)>,
    /// The interpolated normal before normal mapping and the GGX α² of the bump shadowing
    /// (the diffuse base's), when a normal map moved the normal.
    bump: Option<(Vec3, f32)>,
    /// Cycles' `sd->N` in the shading frame where the specular lobes' normal (the frame's) is
    /// not it (`PbrParams::cut_normal`): Cycles' `bump_shadowing_term` gives a microfacet
    /// closure nothing toward light on the other side of its normal than sd->N puts that light,
    /// in its evaluation and density, never in its own sample (`Cuts`); the coat by its own
    /// normal likewise.
    cut_ref: Option<Vec3>,
    /// Normal-incidence reflectance of the coat (from its IOR).
    pub coat_f0: f32,
    /// Coat IOR (for the refracted path length through a tinted coat).
    pub coat_ior: f32,
    /// Coat tint (white: none).
    pub coat_tint: Rgb,
    /// The coat's Fresnel is the exact dielectric one of `coat_ior` (Cycles' coat closure),
    /// its albedo the layer table's at `coat_z`; else Schlick's from `coat_f0` (glTF's).
    coat_dielectric: bool,
    /// `coat_ior` on the layer albedo table's axis.
    coat_z: f32,
    /// Sheen colour (zero: no sheen).
    pub sheen_color: Rgb,
    /// Sheen roughness.
    pub sheen_roughness: f32,
    /// max(sheen colour): the sheen's albedo is this times the table's E.
    sheen_max: f32,
    /// The sheen is Blender's microfiber sheen (else glTF's Charlie).
    microfiber: bool,
    /// Fraction of the diffuse base left to subsurface scattering (not in this BSDF).
    pub subsurface: f32,
    /// `KHR_materials_diffuse_transmission` diffuseTransmissionFactor: the share of the
    /// diffuse base that is a Lambertian BTDF into the other hemisphere instead of a BRDF.
    pub diffuse_transmission: f32,
    /// diffuseTransmissionColorFactor: the colour of that BTDF (clamped to [0, 1]).
    pub diffuse_transmission_color: Rgb,
    /// The metal lobe was dropped (Reflective Caustics off); the rest keeps 1 − metallic.
    metal_dropped: bool,
    /// The coat's reflection was dropped (Reflective Caustics off); its tint still filters.
    coat_dropped: bool,
}

/// Probabilities of the lobes for one `wo`: metal, dielectric specular, diffuse, diffuse
/// transmission, glass, coat, sheen.
#[derive(Clone, Copy, Debug)]
pub(super) struct LobeChoice {
    metal: f32,
    spec: f32,
    diffuse: f32,
    /// The diffuse base's Lambertian transmission (`KHR_materials_diffuse_transmission`).
    dtrans: f32,
    glass: f32,
    coat: f32,
    sheen: f32,
    /// The microfiber sheen seen from wo (its sampling density), when the sheen is one.
    fiber: Option<Microfiber>,
}

impl LobeChoice {
    /// No energy towards wo: the specular lobe alone, as a fallback that is never sampled.
    const NONE: LobeChoice =
        LobeChoice { metal: 0.0, spec: 1.0, diffuse: 0.0, dtrans: 0.0, glass: 0.0, coat: 0.0, sheen: 0.0, fiber: None };
}

impl PbrBsdf {
    /// An opaque BRDF from glTF factors, specular weight 1, IOR 1.5.
    pub fn new(base: Rgb, metallic: f32, roughness: f32) -> Self {
        Self::from_params(&PbrParams::opaque(base, metallic, roughness))
    }

    /// An opaque BRDF with a specular layer weight (`KHR_materials_specular` specularFactor).
    pub fn with_specular(base: Rgb, metallic: f32, roughness: f32, specular: f32) -> Self {
        Self::from_params(&PbrParams { specular, ..PbrParams::opaque(base, metallic, roughness) })
    }

    /// The full material from its parameters (clamped to their valid ranges).
    #[inline]
    pub fn from_params(p: &PbrParams) -> Self {
        Self::without_base(p).with_base(p.base)
    }

    /// The dielectric layer's η: the IOR whose F0 is the IOR's F0 × specularFactor
    /// (Blender's IOR adjusted by Specular IOR Level), 1 without a layer.
    #[inline]
    pub fn layer_eta(&self) -> f32 {
        self.layer_eta
    }

    /// The material from every parameter but `p.base`, which `with_base` then supplies:
    /// a material whose other factors are the same at every hit builds this once, and
    /// the base colour (times the vertex colour) is all that varies.
    pub fn without_base(p: &PbrParams) -> Self {
        let roughness = p.roughness.clamp(0.0, 1.0);
        // Cycles keeps an IOR below 1 down to 1e-5 (IOR 0 is a near mirror): the layer's
        // Fresnel is then the one inside the denser medium, total internal reflection included.
        let ior = if p.ior.is_finite() { p.ior.max(MIN_IOR) } else { 1.5 };
        let f0 = f0_from_ior(ior).min(1.0);
        let specular = if p.specular.is_finite() { p.specular.max(0.0) } else { 1.0 };
        let layer_eta = if specular > 0.0 { layer_eta(ior, specular) } else { 1.0 };
        // Cycles' films of 0.1 nm or less are no film.
        let film = p.thin_film.filter(|&(d, n, w)| d > 0.1 && d.is_finite() && n > 0.0 && n.is_finite() && w > 0.0);
        // Cycles' condition for a specular layer: η ≠ 1 or a film (a free film of IOR 1).
        let layer = layer_eta != 1.0 || film.is_some();
        let spec_color = if p.specular_color.is_finite() { p.specular_color.max(Vec3::ZERO) } else { Vec3::ONE };
        let sheen_color =
            if p.sheen_color.is_finite() { p.sheen_color.clamp(Vec3::ZERO, Vec3::ONE) } else { Vec3::ZERO };
        let coat_frame = p.coat_normal.filter(|n| n.is_finite() && n.z > 1e-3).and_then(|n| {
            let n = n.normalize();
            (n.z < 1.0 - 1e-6).then(|| Frame::from_normal(n))
        });
        // A diffuse normal below the frame's horizon (a normal facing away from the
        // viewer) still reflects light arriving above both: kept, whatever its height.
        let diffuse_frame = p.diffuse_normal.filter(|n| n.is_finite()).and_then(|n| {
            let n = n.try_normalize()?;
            (n.z < 1.0 - 1e-6).then(|| Frame::from_normal(n))
        });
        let diffuse_n = diffuse_frame.map_or(Vec3::Z, |f| f.n);
        let bump =
            p.smooth_normal.and_then(|ns| ns.try_normalize()).and_then(|ns| Some((ns, bump_alpha2(ns, diffuse_n)?)));
        let (ggx, aniso, smooth) = match p.anisotropy.filter(|(x, y)| x.is_finite() && y.is_finite()) {
            Some((ax, ay)) => {
                // The table covers widths up to 1 (glTF's mapping stays within it).
                let ggx = Ggx::anisotropic(ax.clamp(0.0, 1.0), ay.clamp(0.0, 1.0));
                let (ax, ay) = ggx.alphas();
                // Cycles reads its isotropic table at the roughness (αx αy)^¼ (`roughness` below).
                let aniso = (!p.cycles_principled).then(|| (ax.sqrt(), ay.sqrt()));
                (ggx, aniso, ax.max(ay).sqrt() < SMOOTH_ROUGHNESS)
            }
            None => (Ggx::from_roughness(roughness), None, roughness < SMOOTH_ROUGHNESS),
        };
        let mut glass = DielectricBsdf::new(p.eta, roughness, p.thin, Rgb::ZERO);
        if p.dispersion > 0.0 && p.dispersion.is_finite() && !p.thin {
            glass = glass.with_dispersion(ior, p.dispersion);
        }
        let roughness = match p.anisotropy {
            Some(_) if p.cycles_principled && aniso.is_none() => {
                let (ax, ay) = ggx.alphas();
                (ax * ay).sqrt().sqrt()
            }
            _ => roughness,
        };
        PbrBsdf {
            base: Rgb::ZERO,
            diffuse: Rgb::ZERO,
            diffuse_roughness: if p.diffuse_roughness.is_finite() { p.diffuse_roughness.clamp(0.0, 1.0) } else { 0.0 },
            oren: None,
            cycles_principled: p.cycles_principled,
            metallic: p.metallic.clamp(0.0, 1.0),
            roughness,
            specular,
            f0,
            f0_rgb: (spec_color * (f0 * specular)).min(Vec3::ONE),
            layer_eta,
            layer_f0_eta: f0_of(layer_eta),
            layer_z: eta_z(layer_eta),
            film,
            metal_film: film.is_some() && p.thin_film_metal,
            layer,
            transmission: p.transmission.clamp(0.0, 1.0),
            glass,
            ggx,
            coat: p.coat.clamp(0.0, 1.0),
            coat_roughness: p.coat_roughness.clamp(0.0, 1.0),
            coat_ggx: Ggx::from_roughness(p.coat_roughness.clamp(0.0, 1.0)),
            smooth,
            smooth_coat: p.coat_roughness < SMOOTH_ROUGHNESS,
            layer_fms: Rgb::ZERO,
            metal_fms: Rgb::ZERO,
            // Cycles' Principled metal: F82 tint of min(Specular Tint, 1); glTF's is Schlick's.
            metal_tint: if p.cycles_principled { spec_color.min(Vec3::ONE) } else { Vec3::ONE },
            metal_b: Rgb::ZERO,
            e_avg: 0.0,
            // Only materials that show the glass pay for its table.
            glass_ms: p.transmission > 0.0 && p.metallic < 1.0 && !p.single_scatter,
            single_scatter: p.single_scatter,
            coat_frame,
            diffuse_frame,
            aniso,
            bump,
            cut_ref: p.cut_normal.filter(|n| n.is_finite()).and_then(|n| n.try_normalize()),
            coat_f0: f0_from_ior(if p.coat_ior.is_finite() && p.coat_ior >= 1.0 { p.coat_ior } else { 1.5 }).min(1.0),
            coat_ior: if p.coat_ior.is_finite() && p.coat_ior >= 1.0 { p.coat_ior } else { 1.5 },
            coat_tint: if p.coat_tint.is_finite() { p.coat_tint.clamp(Vec3::ZERO, Vec3::ONE) } else { Vec3::ONE },
            coat_dielectric: p.coat_dielectric_fresnel,
            coat_z: eta_z(if p.coat_ior.is_finite() && p.coat_ior >= 1.0 { p.coat_ior } else { 1.5 }),
            sheen_color,
            sheen_roughness: p.sheen_roughness.clamp(0.0, 1.0),
            sheen_max: sheen_color.max_element(),
            microfiber: p.microfiber_sheen,
            subsurface: p.subsurface.clamp(0.0, 1.0),
            diffuse_transmission: if p.diffuse_transmission.is_finite() {
                p.diffuse_transmission.clamp(0.0, 1.0)
            } else {
                0.0
            },
            diffuse_transmission_color: if p.diffuse_transmission_color.is_finite() {
                p.diffuse_transmission_color.clamp(Vec3::ZERO, Vec3::ONE)
            } else {
                Vec3::ONE
            },
            metal_dropped: false,
            coat_dropped: false,
        }
        .with_layer_avg()
    }

    fn with_layer_avg(mut self) -> Self {
        let (a, b) = match self.aniso {
            Some((rx, ry)) => aniso_albedo().ab_avg(rx, ry),
            None => specular_albedo().ab_avg(self.roughness),
        };
        self.e_avg = a + b;
        if self.layer && !self.smooth {
            // Cycles' F_ss = mix(F0, 1, s_avg) and Kulla & Conty's F_ms from it.
            let s_avg = layer_albedo().s_avg(self.layer_eta);
            let f_ss = self.f0_rgb + (Vec3::ONE - self.f0_rgb) * s_avg;
            self.layer_fms = f_ss * self.e_avg / (Vec3::ONE - f_ss * (1.0 - self.e_avg)).max(Vec3::splat(1e-6));
        }
        self
    }

    /// This material with base colour `base`: the diffuse base takes it as given (above 1
    /// too, as Cycles), the metal, the glass part's tint and the multiple-scattering terms
    /// clamped to [0, 1]. Built as one struct update from `self`, so that the caller's copy
    /// of this large BSDF lands where it is returned (separate copies showed in the profile).
    #[inline(always)]
    pub fn with_base(&self, base: Rgb) -> Self {
        let diffuse = if base.is_finite() { base.max(Vec3::ZERO) } else { Vec3::ZERO };
        let base = diffuse.min(Vec3::ONE);
        let mut glass = self.glass;
        glass.tint = if self.cycles_principled { Vec3::new(base.x.sqrt(), base.y.sqrt(), base.z.sqrt()) } else { base };
        // Cycles' Principled diffuse: Lambert below a roughness of 1e-5 (CLOSURE_WEIGHT_CUTOFF),
        // Oren-Nayar whose energy term takes the colour clamped.
        let oren = (self.diffuse_roughness >= 1e-5).then(|| OrenNayar::new(self.diffuse_roughness, base));
        if self.glass_ms {
            glass = glass.with_multiscatter();
        }
        let metal_b = if self.metal_tint == Vec3::ONE { Vec3::ZERO } else { f82_tint_b(base, self.metal_tint) };
        let metal_fms = if self.metallic > 0.0 && !self.smooth && !self.single_scatter {
            let e_avg = self.e_avg;
            // Cycles' fresnel_f82_Fss: the cosine-weighted average of the F82-tint curve.
            let f_avg = (base + (Vec3::ONE - base) / 21.0 - metal_b / 126.0).clamp(Vec3::ZERO, Vec3::ONE);
            f_avg * e_avg / (Vec3::ONE - f_avg * (1.0 - e_avg)).max(Vec3::splat(1e-6))
        } else {
            self.metal_fms
        };
        PbrBsdf { base, diffuse, oren, glass, metal_fms, metal_b, ..*self }
    }

    /// The metal's Fresnel at cos θ to the microfacet normal: Schlick's of the base colour, or
    /// Cycles' F82 tint when it has one; under a film on the metal, the film's reflectance on
    /// that F82 conductor (Cycles' `microfacet_fresnel` F82_TINT case), mixed in by its weight.
    #[inline]
    pub(super) fn metal_fresnel(&self, cos: f32) -> Rgb {
        let plain = if self.metal_dropped {
            return Rgb::ZERO;
        } else if self.metal_b == Vec3::ZERO {
            self.base + (Vec3::ONE - self.base) * schlick_weight(cos)
        } else {
            f82_tint(self.base, self.metal_b, cos)
        };
        match self.film {
            Some((d, n, w)) if self.metal_film => {
                let (eta, k, g) = f82_conductor_index(self.base, self.metal_b);
                let f = conductor_film_reflectance(cos, n, d, eta, k, Some(g));
                plain + (f - plain) * w.min(1.0)
            }
            _ => plain,
        }
    }

    /// (A, B) of the reflection lobes' albedo E = F0·A + B seen from local direction `w`.
    #[inline]
    fn lobe_ab(&self, w: Vec3) -> (f32, f32) {
        match self.aniso {
            Some((rx, ry)) => aniso_albedo().ab(w, rx, ry),
            None => specular_albedo().ab(w.z, self.roughness),
        }
    }

    /// (A, B) of the dielectric layer's albedo ms (F0·A + B) seen from `w`, with `white` = A + B
    /// of the reflection lobes (the Schlick table's, or the anisotropic table's): an anisotropic
    /// layer splits its own white albedo by the isotropic split at roughness (αx αy)^¼, the
    /// proxy Cycles' albedo estimate reads its table at. A layer of η < 1 reads the entry of
    /// 1/η (the same z), as Cycles' estimate does (`fresnel_layer.rs`).
    #[inline]
    fn layer_ab(&self, w: Vec3, white: f32) -> (f32, f32) {
        match self.aniso {
            Some((rx, ry)) => {
                let (a, b) = layer_albedo().ab(w.z, (rx * ry).sqrt(), self.layer_z);
                let fb = b / (a + b).max(1e-6);
                (white * (1.0 - fb), white * fb)
            }
            None => layer_albedo().ab(w.z, self.roughness, self.layer_z),
        }
    }

    /// The dielectric layer's multiple-scattering factor 1 + F_ms (1/E − 1) for the white lobe's
    /// albedo E seen from the viewer (E above 0.3 everywhere; the floor only guards the division).
    #[inline]
    fn layer_ms(&self, white: f32) -> Rgb {
        if self.layer_fms == Rgb::ZERO { Rgb::ONE } else { Rgb::ONE + self.layer_fms * (1.0 / white.max(0.05) - 1.0) }
    }

    /// The dielectric layer's Fresnel at cos θ to the half vector: F0 + (1 − F0) s(cos, η);
    /// with a thin film, the film's reflectance on a substrate of η, rescaled towards F0 as
    /// Cycles rescales it (each channel by mix(1, F0/F0_η, (1 − F)/(1 − F0_η))), mixed in by
    /// the film's weight.
    #[inline]
    pub(super) fn layer_fresnel(&self, cos: f32) -> Rgb {
        let s = fresnel_s(cos, self.layer_eta, self.layer_f0_eta);
        let plain = self.f0_rgb + (Vec3::ONE - self.f0_rgb) * s;
        let Some((d, n, w)) = self.film else { return plain };
        let mut f = film_reflectance(cos, n, d, self.layer_eta);
        let f0_eta = self.layer_f0_eta;
        if f0_eta > 1e-5 && f != Rgb::ONE {
            let t = ((Vec3::ONE - f) / (1.0 - f0_eta)).clamp(Vec3::ZERO, Vec3::ONE);
            let factor = self.f0_rgb / f0_eta;
            f *= Vec3::ONE + (factor - Vec3::ONE) * t;
        }
        plain + (f - plain) * w.min(1.0)
    }

    /// For a refracted pair (wo, wi), η² f(wi, wo) over f(wo, wi): not 1 when
    /// the glass compensates multiple scattering, which depends on the viewer's side.
    #[inline]
    pub fn refraction_adjoint_ratio(&self, wo: Vec3, wi: Vec3) -> Rgb {
        self.glass.adjoint_ratio(wo, wi)
    }

    /// cos θ of `w` to the coat's normal.
    #[inline]
    fn coat_mu(&self, w: Vec3) -> f32 {
        match &self.coat_frame {
            Some(f) => w.dot(f.n),
            None => w.z,
        }
    }

    /// Directional albedo of the coat seen from `wo` (weight included).
    #[inline]
    fn coat_albedo(&self, wo: Vec3) -> f32 {
        if self.coat > 0.0 && !self.coat_dropped {
            let mu = self.coat_mu(wo);
            if mu <= 0.0 {
                return 0.0;
            }
            if self.coat_dielectric {
                // The exact Fresnel is F0 + (1 − F0) s of the coat's own η: the layer table's split.
                let (a, b) = layer_albedo().ab(mu, self.coat_roughness, self.coat_z);
                self.coat * (self.coat_f0 * a + b)
            } else {
                self.coat * specular_albedo().e(mu, self.coat_roughness, self.coat_f0)
            }
        } else {
            0.0
        }
    }

    /// What a tinted coat lets through to the layers below, seen from `wo`: Cycles' model,
    /// tint^(1/cos θt) with θt the refracted angle in the coat (Beer's law over a unit-thickness
    /// coat whose tint is its normal-incidence transmittance), mixed in by the coat weight.
    #[inline]
    fn coat_transmittance(&self, wo: Vec3) -> Rgb {
        if self.coat <= 0.0 || self.coat_tint == Rgb::ONE {
            return Rgb::ONE;
        }
        let mu = self.coat_mu(wo).clamp(0.0, 1.0);
        let cos_t = (1.0 - (1.0 - mu * mu) / (self.coat_ior * self.coat_ior)).max(1e-4).sqrt();
        let t = self.coat_tint.powf(1.0 / cos_t);
        Rgb::ONE + (t - Rgb::ONE) * self.coat
    }

    /// Directional albedo of the opaque dielectric's specular layer seen from local
    /// direction `w` (upper hemisphere), per channel.
    #[inline]
    fn layer_albedo(&self, w: Vec3) -> Rgb {
        // Blender's Specular IOR Level 0 (a pure Lambertian) needs no table lookup.
        if !self.layer {
            return Rgb::ZERO;
        }
        let (a, b) = self.lobe_ab(w);
        if self.single_scatter {
            return self.layer_e(w, a + b) / (a + b).max(1e-4);
        }
        self.layer_e(w, a + b) * self.layer_ms(a + b)
    }

    /// The dielectric layer's single-scattering albedo seen from `w`, with `white` the lobe's
    /// albedo at Fresnel 1: from the table; with a thin film, Cycles' estimate, the white
    /// albedo times the Fresnel at the view angle (no table covers the film).
    #[inline]
    fn layer_e(&self, w: Vec3, white: f32) -> Rgb {
        if self.film.is_some() {
            return self.layer_fresnel(w.z) * white;
        }
        let (la, lb) = self.layer_ab(w, white);
        self.f0_rgb * la + Vec3::splat(lb)
    }

    /// The diffuse base's weight under the dielectric layer whose albedo seen from wo is `eo`:
    /// 1 − its largest channel (Cycles' `closure_layering_weight`).
    #[inline]
    pub(super) fn base_weight(eo: Rgb) -> f32 {
        (1.0 - eo.max_element()).clamp(0.0, 1.0)
    }

    /// The Charlie sheen's directional albedo at μ: max(sheen colour) × E_sheen.
    #[inline]
    fn sheen_albedo(&self, mu: f32) -> f32 {
        if self.sheen_max > 0.0 { self.sheen_max * sheen_albedo_table().e(mu, self.sheen_roughness) } else { 0.0 }
    }

    /// The microfiber sheen seen from `wo` (upper hemisphere), when the sheen is one.
    #[inline]
    fn fiber(&self, wo: Vec3) -> Option<Microfiber> {
        (self.microfiber && self.sheen_max > 0.0).then(|| Microfiber::at(wo, self.sheen_roughness))
    }

    /// The sheen's albedo scaling of everything below it, with `sheen_o` = 1 - its albedo at
    /// wo: Charlie's reciprocal min(1 - s·E(μo), 1 - s·E(μi)), the microfiber's 1 - s·E(μo).
    #[inline]
    fn sheen_scaling_from(&self, sheen_o: f32, mu_i: f32) -> f32 {
        if self.sheen_max > 0.0 && !self.microfiber { sheen_o.min(1.0 - self.sheen_albedo(mu_i)) } else { sheen_o }
    }

    /// The sheen's albedo scaling of everything below it, from wo and wi's cosines.
    #[inline]
    fn sheen_scaling(&self, wo: Vec3, mu_i: f32) -> f32 {
        if self.sheen_max <= 0.0 {
            return 1.0;
        }
        let e_o = match self.fiber(wo) {
            Some(m) => self.sheen_max * m.albedo(),
            None => self.sheen_albedo(wo.z),
        };
        self.sheen_scaling_from(1.0 - e_o, mu_i)
    }

    /// How `sample` chooses among the lobes at `at.wo` (upper hemisphere): by the energy each
    /// reflects towards wo, from the view-side terms [`at`](Self::at) computed.
    #[inline]
    fn lobes(&self, at: &PbrAt) -> LobeChoice {
        let wo = at.wo;
        // `at` leaves the layer albedo at 0 when nothing is opaque: every term that reads it
        // is multiplied by `opaque` = 0 then.
        // A smooth layer of η < 1 reflects its Fresnel (total internal reflection beyond the
        // critical angle), not the table's estimate at 1/η: sampled by what it reflects.
        let e = if self.smooth && self.layer && self.layer_eta < 1.0 && at.eo != Rgb::ZERO {
            luminance(self.layer_fresnel(wo.z))
        } else {
            luminance(at.eo)
        };
        let (ec, es) = (at.ec, at.es);
        let under = (1.0 - ec) * luminance(at.coat_t);
        let below = under * (1.0 - es);
        let dielectric = 1.0 - self.metallic;
        let opaque = dielectric * (1.0 - self.transmission);
        let metal = below * self.metallic * luminance(self.metal_fresnel(wo.z) * at.metal_ms);
        let spec = below * opaque * e;
        let dt = self.diffuse_transmission;
        let diffuse = below * opaque * Self::base_weight(at.eo) * luminance(self.diffuse) * (1.0 - self.subsurface);
        // Multiplied by 1 − 0 = 1 without the extension: every other material samples as before.
        let diffuse = diffuse * (1.0 - dt);
        let dtrans = if dt > 0.0 {
            below
                * opaque
                * Self::base_weight(at.eo)
                * luminance(self.diffuse_transmission_color)
                * (1.0 - self.subsurface)
                * dt
        } else {
            0.0
        };
        let glass = if self.transmission > 0.0 {
            let r = self.glass.reflect_probability(wo);
            let ms = luminance(self.glass.multiscatter(wo));
            below * dielectric * self.transmission * ((r + (1.0 - r) * luminance(self.base)) * ms).max(1e-3)
        } else {
            0.0
        };
        let coat = ec;
        let sheen = under * es;
        let total = metal + spec + diffuse + glass + coat + sheen + dtrans;
        if total > 0.0 {
            LobeChoice {
                metal: metal / total,
                spec: spec / total,
                diffuse: diffuse / total,
                dtrans: dtrans / total,
                glass: glass / total,
                coat: coat / total,
                sheen: sheen / total,
                fiber: at.fiber,
            }
        } else {
            LobeChoice::NONE
        }
    }

    /// The coat's GGX reflection f(wo, wi) (weight and Fresnel included), in its own frame.
    /// With its own normal, the value is rescaled by cos θi(coat) / cos θi(shading), so that
    /// the integrator's cosine to the shading normal gives the coat's own cosine, as Cycles
    /// takes each closure's cosine to its own normal: the coat then reflects exactly its
    /// albedo E_c(μo) around the coat normal.
    /// Below the shading frame's horizon (`coat_across`) the cosine it is rescaled by is
    /// |cos θi(shading)|, the one the integrators multiply by there.
    #[inline]
    fn coat_eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        let cos_base = wi.z.abs();
        let (wo, wi) = match &self.coat_frame {
            Some(f) => (f.to_local(wo), f.to_local(wi)),
            None => (wo, wi),
        };
        if wo.z <= 0.0 || wi.z <= 0.0 || cos_base <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        let cos_h = wo.dot(h).max(0.0);
        let f_coat = if self.coat_dielectric {
            fresnel_dielectric(cos_h, self.coat_ior)
        } else {
            self.coat_f0 + (1.0 - self.coat_f0) * schlick_weight(cos_h)
        };
        let f = self.coat * f_coat * self.coat_ggx.d(h) * self.coat_ggx.g2(wo, wi) / (4.0 * wo.z * wi.z);
        if self.coat_frame.is_some() { f * wi.z / cos_base } else { f }
    }

    /// Density of the coat lobe's samples (visible normals, in its frame).
    #[inline]
    fn coat_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo, wi) = match &self.coat_frame {
            Some(f) => (f.to_local(wo), f.to_local(wi)),
            None => (wo, wi),
        };
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        self.coat_ggx.pdf_visible_normal(wo, h) / (4.0 * wo.dot(h).max(1e-8))
    }

    /// Density of the diffuse lobe's cosine-weighted samples around its normal (wi in the
    /// upper hemisphere of the shading frame).
    #[inline]
    fn diffuse_pdf(&self, wi: Vec3) -> f32 {
        match &self.diffuse_frame {
            Some(f) => cosine_hemisphere_pdf(wi.dot(f.n).max(0.0)),
            None => cosine_hemisphere_pdf(wi.z),
        }
    }

    /// The diffuse base's f(wo, wi) times `weight`: the colour over π (Lambert) or the
    /// Oren-Nayar lobe in the diffuse base's own frame, times [`diffuse_cos_ratio`]. Lambert's
    /// product keeps the order it always had (the golden images are bit-exact).
    #[inline]
    pub(super) fn diffuse_f(&self, wo: Vec3, wi: Vec3, weight: f32) -> Rgb {
        match &self.oren {
            None => self.diffuse * (weight * std::f32::consts::FRAC_1_PI * self.diffuse_cos_ratio(wi)),
            Some(o) => {
                let shape = match &self.diffuse_frame {
                    Some(f) => o.eval(f.to_local(wo), f.to_local(wi)),
                    None => o.eval(wo, wi),
                };
                self.diffuse * shape * (weight * self.diffuse_cos_ratio(wi))
            }
        }
    }

    /// The diffuse base's cosine over the shading frame's (the integrators multiply by the
    /// latter, and the base reflects by its own normal's, 0 below its own horizon), times
    /// its bump shadowing.
    #[inline]
    fn diffuse_cos_ratio(&self, wi: Vec3) -> f32 {
        let (n, ratio) = match &self.diffuse_frame {
            Some(f) => (f.n, wi.dot(f.n).max(0.0) / wi.z),
            None => (Vec3::Z, 1.0),
        };
        match self.bump {
            Some((ns, alpha2)) => ratio * bump_shadowing(ns, n, wi, alpha2),
            None => ratio,
        }
    }

    /// The sheen lobe's f(wo, wi) (colour included): the microfiber `fiber` seen from wo,
    /// or the Charlie sheen.
    #[inline]
    fn sheen_eval(&self, fiber: &Option<Microfiber>, wo: Vec3, wi: Vec3) -> Rgb {
        if self.sheen_max <= 0.0 || wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        if let Some(m) = fiber {
            return self.sheen_color * m.f(wi);
        }
        let h = (wo + wi).normalize();
        self.sheen_color * charlie_brdf(h.z, wo.z, wi.z, self.sheen_roughness)
    }

    /// Drops the caustic closures as Cycles' Principled BSDF does after a diffuse bounce with
    /// a caustics switch off (`svm_node_closure_bsdf`): `reflective` drops the coat's
    /// reflection (its tint still filters), the metal (the rest keeps 1 − metallic), the
    /// specular layer with its film (the base then unattenuated by it) and the glass's
    /// reflection; `refractive` the glass's refraction. Sheen, diffuse and subsurface stay.
    pub fn drop_caustics(&mut self, reflective: bool, refractive: bool) {
        if reflective {
            self.coat_dropped = true;
            self.metal_dropped = true;
            self.layer = false;
        }
        self.glass.drop_caustics(reflective, refractive);
    }

    /// True when some light may pass through to the other side (a transmission lobe: the
    /// glass, or the diffuse base's Lambertian transmission).
    pub fn transmits(&self) -> bool {
        (self.transmission > 0.0 && self.metallic < 1.0) || self.transmits_diffusely()
    }

    /// True when the diffuse base transmits some light (`KHR_materials_diffuse_transmission`).
    #[inline]
    pub fn transmits_diffusely(&self) -> bool {
        self.diffuse_transmission > 0.0
            && self.metallic < 1.0
            && self.transmission < 1.0
            && self.subsurface < 1.0
            && self.diffuse_transmission_color.max_element() > 0.0
    }

    /// The adjoint of a transmitted pair (wo, wi on opposite sides): the glass's part as
    /// `Bsdf::eval_adjoint` takes it (1/η² of the camera-side value, `scale`, times rough
    /// glass's compensation ratio) and the Lambertian transmission's seen from wi, f(wi, wo):
    /// it changes no η (a sheet scattering, not a refraction), and like the diffuse base its
    /// only non-reciprocal terms are the layer weights seen from the viewer's side.
    pub fn crossing_adjoint(&self, wo: Vec3, wi: Vec3, scale: f32) -> Rgb {
        let at = self.view(wo);
        let dt = at.eval_diffuse_transmission(wi);
        let glass = (at.eval(wi) - dt).max(Rgb::ZERO) * scale * self.refraction_adjoint_ratio(wo, wi);
        glass + self.view(wi).eval_diffuse_transmission(wo)
    }

    /// Filter Glossy's blur (`Bsdf::blur`): every microfacet lobe (metal and specular layer,
    /// glass, coat) at least `alpha` wide, smooth ones rough past the smooth threshold; the
    /// albedo tables and compensations stay the original roughness's (Cycles recomputes none).
    pub fn blur(&mut self, alpha: f32) {
        let rough = |g: Ggx| {
            let (x, y) = g.alphas();
            x.max(y).sqrt() >= SMOOTH_ROUGHNESS
        };
        self.ggx = self.ggx.blurred(alpha);
        self.smooth &= !rough(self.ggx);
        self.coat_ggx = self.coat_ggx.blurred(alpha);
        self.smooth_coat &= !rough(self.coat_ggx);
        self.glass.blur(alpha);
    }

    /// True when every lobe is a delta lobe (smooth clear glass): no light sampling helps.
    pub fn is_delta(&self) -> bool {
        let dielectric = 1.0 - self.metallic;
        let opaque = dielectric * (1.0 - self.transmission);
        let dt_color = luminance(self.diffuse_transmission_color) * self.diffuse_transmission;
        let rough = (opaque > 0.0 && (luminance(self.diffuse) > 0.0 || dt_color > 0.0) && self.subsurface < 1.0)
            || (!self.smooth && (self.metallic > 0.0 || (opaque > 0.0 && self.layer)))
            || (self.transmission > 0.0 && dielectric > 0.0 && !self.glass.smooth)
            || (self.coat > 0.0 && !self.smooth_coat)
            || self.sheen_max > 0.0;
        !rough
    }

    /// f(wo, wi) of the non-delta lobes; directions in the local frame. Reflection is
    /// two-sided; transmission goes to the other side of wo.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        self.view(wo).eval(wi)
    }

    /// The BSDF seen from `wo`, with everything that depends on `wo` alone computed once:
    /// a photon gather evaluates f(wo, ·) for every photon found (the profile of a photon
    /// render had `eval` and its albedo-table lookups at ~20 % of the time).
    #[inline]
    pub fn at(&self, wo: Vec3) -> PbrAt<'_> {
        // The lobe choice depends on wo alone: the path tracer's vertex reads it twice (next-event
        // estimation's density, then the sampled bounce), the profile of the glass bench
        // scene had it at 3.2 % of the render's instructions when computed per call.
        self.view(wo).lobed()
    }

    /// [`at`](Self::at) without the lobe choice yet, for a value that may end a connection
    /// before any density is asked (`PbrAt::lobed` adds it).
    #[inline]
    pub fn at_value(&self, wo: Vec3) -> PbrAt<'_> {
        self.view(wo)
    }

    /// [`at`](Self::at) from its terms kept by [`PbrAt::view`] (for the same BSDF).
    #[inline]
    pub fn bind(&self, v: &PbrView) -> PbrAt<'_> {
        PbrAt { b: self, v: *v }
    }

    /// The view-side terms of [`at`](Self::at) without the lobe choice (which only the
    /// density and sampling read): what `eval` needs.
    #[inline]
    fn view(&self, wo: Vec3) -> PbrAt<'_> {
        let flip = wo.z < 0.0;
        let wo = if flip { Vec3::new(wo.x, wo.y, -wo.z) } else { wo };
        if wo.z <= 0.0 {
            return PbrAt {
                b: self,
                v: PbrView {
                    wo,
                    flip,
                    under: Rgb::ZERO,
                    eo: Rgb::ZERO,
                    layer_ms: Rgb::ONE,
                    sheen_o: 0.0,
                    metal_ms: Rgb::ONE,
                    ec: 0.0,
                    coat_t: Rgb::ONE,
                    es: 0.0,
                    fiber: None,
                    c: LobeChoice::NONE,
                },
            };
        }
        // The coat reflects E_c(μo) of the light and leaves the rest to the layers below
        // (albedo scaling by the outgoing direction, as Cycles layers its coat).
        let ec = self.coat_albedo(wo);
        let coat_t = self.coat_transmittance(wo);
        let under = coat_t * (1.0 - ec);
        let opaque = (1.0 - self.metallic) * (1.0 - self.transmission);
        // The dielectric layer and the metal read the same (μo, roughness) table entry.
        let need_layer = opaque > 0.0 && self.layer;
        let need_metal = self.metal_fms != Rgb::ZERO;
        let (a, b) = if need_layer || need_metal { self.lobe_ab(wo) } else { (0.0, 0.0) };
        // Single scattering ("GGX"): the lobe is not compensated, and the diffuse base below
        // takes Cycles' albedo estimate for it, the Fresnel average mix(F0, 1, s) of its table,
        // which is normalised by the lobe's white albedo E (Cycles' `bsdf_albedo` is the closure
        // weight, which only Multiscatter GGX's compensation scales by E (1 + F_ms (1/E − 1)),
        // times that estimate): the layer's albedo divided by E.
        let layer_ms = if need_layer && !self.single_scatter { self.layer_ms(a + b) } else { Rgb::ONE };
        let eo = match (need_layer, self.single_scatter) {
            (false, _) => Rgb::ZERO,
            (true, true) => self.layer_e(wo, a + b) / (a + b).max(1e-4),
            (true, false) => self.layer_e(wo, a + b) * layer_ms,
        };
        let fiber = self.fiber(wo);
        let es = match &fiber {
            Some(m) => self.sheen_max * m.albedo(),
            None => self.sheen_albedo(wo.z),
        };
        let sheen_o = if self.sheen_max > 0.0 { 1.0 - es } else { 1.0 };
        // The metal's multiple-scattering factor 1 + F_ms (1/E − 1) with E the white lobe's
        // albedo (above 0.3 everywhere; the floor only guards the division).
        let metal_ms = if need_metal { Rgb::ONE + self.metal_fms * (1.0 / (a + b).max(0.05) - 1.0) } else { Rgb::ONE };
        let v =
            PbrView { wo, flip, under, eo, layer_ms, sheen_o, metal_ms, ec, coat_t, es, fiber, c: LobeChoice::NONE };
        PbrAt { b: self, v }
    }

    /// Density of [`sample`](Self::sample) for the non-delta lobes.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let cuts = self.cuts(wi);
        let across = self.coat_across(wo, wi, cuts);
        let (wo, wi) = flip_to_upper(wo, wi);
        if wo.z <= 0.0 || wi.z == 0.0 {
            return 0.0;
        }
        self.pdf_with(&self.at(wo).c, wo, wi, cuts, across)
    }

    /// The lobes Cycles' `bump_shadowing_term` cuts toward `wi` (local, as given: not flipped
    /// with wo): the specular lobes (metal, specular layer, glass) by the frame's normal, the
    /// coat by its own, each against `cut_ref`, Cycles' sd->N. The diffuse base's cut is its
    /// bump shadowing (`bump`).
    /// Without `cut_ref` the frame's normal is sd->N: the specular lobes are never cut, the coat
    /// on its own normal is, toward light below the frame's horizon.
    #[inline]
    pub(super) fn cuts(&self, wi: Vec3) -> Cuts {
        let Some(ns) = self.cut_ref else {
            return match &self.coat_frame {
                Some(f) if self.coat > 0.0 => Cuts { spec: false, coat: BumpCut { ns: Vec3::Z, n: f.n }.cuts(wi) },
                _ => Cuts::default(),
            };
        };
        let coat_n = self.coat_frame.map_or(Vec3::Z, |f| f.n);
        Cuts { spec: BumpCut { ns, n: Vec3::Z }.cuts(wi), coat: self.coat > 0.0 && BumpCut { ns, n: coat_n }.cuts(wi) }
    }

    /// True when light from `wi`, below the shading frame's horizon, is reflected toward `wo`
    /// (above it; both local, not flipped) by the coat alone: Cycles' coat closure reflects by
    /// its own normal (`bsdf_microfacet_eval`: reflection where cos to its N is positive), so
    /// where the coat's normal puts wi above, the coat reflects it (unless `cuts` cuts it), and
    /// every other lobe gives nothing there (the specular lobes and the glass are cut by
    /// `bump_shadowing_term`, as is a diffuse transmission: wi is on sd->N's side of the coat
    /// normal). The integrators take such a direction as a reflection (`BsdfAt::above`).
    #[inline]
    pub(super) fn coat_across(&self, wo: Vec3, wi: Vec3, cuts: Cuts) -> bool {
        wi.z < 0.0
            && wo.z > 0.0
            && self.coat > 0.0
            && !self.coat_dropped
            && !cuts.coat
            && self.coat_frame.is_some_and(|f| wi.dot(f.n) > 0.0 && wo.dot(f.n) > 0.0)
    }

    /// [`coat_across`](Self::coat_across) with its cuts (wo, wi local; false when wo is below
    /// the frame: the flipped BSDF reflects by the frame's side alone).
    #[inline]
    pub fn reflects_across(&self, wo: Vec3, wi: Vec3) -> bool {
        wi.z < 0.0 && wo.z > 0.0 && self.coat_frame.is_some() && self.coat_across(wo, wi, self.cuts(wi))
    }

    /// For a pair (wo, wi) on the two sides of the frame's horizon that only the coat reflects
    /// (`coat_across`), which direction sees it: Some(true) when wi is above (its view
    /// evaluates f(wi, wo) as it is), Some(false) when wo is (f(wi, wo) is then f(wo, wi)
    /// times [`across_adjoint_ratio`](Self::across_adjoint_ratio)); None for any other pair.
    #[inline]
    pub fn across_pair(&self, wo: Vec3, wi: Vec3) -> Option<bool> {
        self.coat_frame?;
        if self.coat_across(wi, wo, self.cuts(wo)) {
            Some(true)
        } else if self.coat_across(wo, wi, self.cuts(wi)) {
            Some(false)
        } else {
            None
        }
    }

    /// f(wi, wo) / f(wo, wi) for a pair the coat reflects across the horizon: its GGX lobe is
    /// reciprocal in its own frame, only the cosine rescale (`coat_eval`) changes direction.
    #[inline]
    pub fn across_adjoint_ratio(&self, wo: Vec3, wi: Vec3) -> f32 {
        let n = self.coat_frame.map_or(Vec3::Z, |f| f.n);
        let den = wi.dot(n) * wo.z.abs();
        if den > 0.0 { wo.dot(n) * wi.z.abs() / den } else { 0.0 }
    }

    /// [`pdf`](Self::pdf) with the lobe choice at `wo` (upper hemisphere) already made:
    /// `sample` chooses a lobe and then needs the whole density, from the same choice.
    /// `across`: wi is one only the coat reflects (`coat_across`), where only its density counts.
    #[inline]
    fn pdf_with(&self, c: &LobeChoice, wo: Vec3, wi: Vec3, cuts: Cuts, across: bool) -> f32 {
        if wo.z <= 0.0 || wi.z == 0.0 {
            return 0.0;
        }
        if across {
            return if self.smooth_coat { 0.0 } else { c.coat * self.coat_pdf(wo, wi) };
        }
        let mut pdf = 0.0;
        if c.glass > 0.0 && !cuts.spec {
            pdf += c.glass * self.glass.pdf(wo, wi);
        }
        if wi.z > 0.0 {
            let h = (wo + wi).normalize();
            // Lobes of no weight add nothing: the floor of Specular 0 skips GGX's density.
            if !self.smooth && c.metal + c.spec > 0.0 && !cuts.spec {
                let pdf_spec = self.ggx.pdf_visible_normal(wo, h) / (4.0 * wo.dot(h).max(1e-8));
                pdf += (c.metal + c.spec) * pdf_spec;
            }
            let sheen_pdf = match &c.fiber {
                Some(m) => m.density(wi),
                None => cosine_hemisphere_pdf(wi.z),
            };
            pdf += c.diffuse * self.diffuse_pdf(wi) + c.sheen * sheen_pdf;
            if c.coat > 0.0 && !self.smooth_coat && !cuts.coat {
                pdf += c.coat * self.coat_pdf(wo, wi);
            }
        } else if c.dtrans > 0.0 {
            // The Lambertian transmission's cosine-weighted directions around −Z.
            pdf += c.dtrans * cosine_hemisphere_pdf(-wi.z);
        }
        pdf
    }

    /// Samples wi for wo; `uc` picks the lobe (and is reused within the glass lobe).
    #[inline]
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        self.at(wo).sample(uc, u)
    }
}

impl PbrBsdf {
    /// Weight of the subsurface part seen from `wo` (local, either side), relative to
    /// the base colour: what the layers above (coat, specular) and the metal and glass
    /// mixes leave to the diffuse base, times the subsurface weight. Cycles weights
    /// its subsurface closure the same way (albedo scaling by the outgoing direction).
    pub fn subsurface_weight(&self, wo: Vec3) -> f32 {
        if self.subsurface == 0.0 {
            return 0.0;
        }
        let up = Vec3::new(wo.x, wo.y, wo.z.abs());
        let mu = up.z;
        let opaque = (1.0 - self.metallic) * (1.0 - self.transmission);
        // Coloured layers (a tinted coat or specular layer) are reduced to their luminance:
        // the random walk carries one weight for the whole spectrum of its entry.
        let above = luminance(self.coat_transmittance(up)) * (1.0 - self.coat_albedo(up)) * self.sheen_scaling(up, mu);
        above * opaque * Self::base_weight(self.layer_albedo(up)) * self.subsurface
    }

    /// Albedo for the denoiser: the colour a white light would reflect, roughly.
    pub fn albedo(&self) -> Rgb {
        let f0 = (self.f0 * self.specular).min(1.0);
        // The diffuse base's colour, shared with its Lambertian transmission by the factor.
        let dt = self.diffuse_transmission;
        let base = self.diffuse * (1.0 - dt) + self.diffuse_transmission_color * dt;
        let dielectric = base * (1.0 - f0) + Vec3::splat(f0);
        let below = dielectric * (1.0 - self.metallic) + self.base * self.metallic;
        let below = below * (1.0 - self.sheen_max * 0.5) + self.sheen_color * 0.5;
        below * self.coat_transmittance(Vec3::Z) * (1.0 - self.coat * self.coat_f0)
            + Vec3::splat(self.coat * self.coat_f0)
    }
}

/// The lobes of a [`PbrBsdf`] that Cycles' `bump_shadowing_term` cuts toward one direction
/// (`PbrBsdf::cuts`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Cuts {
    /// The specular lobes: metal, specular layer and glass (reflection and refraction).
    pub spec: bool,
    /// The coat.
    pub coat: bool,
}

/// The bump terminator's shadowing of a diffuse lobe on normal `n` for light from `wi`, with
/// `ns` the interpolated normal and α² the GGX roughness its deviation stands for: 0 for
/// light on the other side of `ns` than `n` puts it, else Smith's G1 of that GGX surface at
/// the light's angle to `ns` (1 at normal incidence, falling towards grazing light).
#[inline]
pub(super) fn bump_shadowing(ns: Vec3, n: Vec3, wi: Vec3, alpha2: f32) -> f32 {
    let cos_i = ns.dot(wi);
    if cos_i * ns.dot(n) * n.dot(wi) < 0.0 {
        return 0.0;
    }
    let cos_i = cos_i.abs().min(1.0);
    if cos_i < 1e-6 {
        return 0.0;
    }
    let tan2 = 1.0 / (cos_i * cos_i) - 1.0;
    2.0 / (1.0 + (1.0 + alpha2 * tan2).sqrt())
}

/// The bump terminator's GGX α² for a diffuse lobe on unit normal `n` over the interpolated
/// unit normal `ns`: the deviation θd read as a roughness, min(tan²θd / 8, 1) (1 where they
/// are perpendicular, as Cycles' `saturatef` of the infinite tangent); None where they agree.
#[inline]
pub fn bump_alpha2(ns: Vec3, n: Vec3) -> Option<f32> {
    let cos_d = ns.dot(n).abs().min(1.0);
    (cos_d < 1.0).then(|| if cos_d > 0.0 { (0.125 * (1.0 / (cos_d * cos_d) - 1.0)).min(1.0) } else { 1.0 })
}

/// Mirrors both directions to the upper hemisphere when `wo` is below it, which makes
/// the BRDF two-sided; `wi` on the other side of the surface than `wo` stays rejected.
#[inline]
fn flip_to_upper(wo: Vec3, wi: Vec3) -> (Vec3, Vec3) {
    if wo.z < 0.0 { (Vec3::new(wo.x, wo.y, -wo.z), Vec3::new(wi.x, wi.y, -wi.z)) } else { (wo, wi) }
}

mod diffuse_transmission;
mod params;
mod passes;
mod view;
pub use params::PbrParams;
pub use view::{PbrAt, PbrView};

#[cfg(test)]
mod tests;
