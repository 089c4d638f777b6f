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
//! One deliberate departure from Appendix B: the spec weights the diffuse base by
//! (1 - F(v·h)) per direction pair, which reflects more than it receives near 60° for
//! smooth surfaces (albedo ≈ 1.016 at roughness 0.15). Caustic layers by albedo
//! scaling instead, as Cycles' Principled BSDF and the glTF layering extensions do, in
//! Kulla & Conty's reciprocal form: diffuse × (1 - E(μo))(1 - E(μi)) / (1 - E_avg), with
//! E the directional albedo of the specular layer, tabulated once. It conserves energy
//! exactly and stays reciprocal.
//!
//! Not handled here: transmission, clearcoat, sheen, specular tint (the materials
//! issue), and the energy lost by single-scattering GGX at high roughness (Cycles
//! compensates with multiscatter GGX: rough metals are slightly darker in Caustic).

use super::BsdfSample;
use super::microfacet::{Ggx, reflect, schlick_weight};
use crate::math::{Rgb, luminance};
use crate::sampling::warp::{cosine_hemisphere, cosine_hemisphere_pdf};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Normal-incidence reflectance of the dielectric layer (IOR 1.5).
const F0_DIELECTRIC: f32 = 0.04;

/// glTF metallic-roughness BRDF, reflection only, two-sided.
#[derive(Clone, Copy, Debug)]
pub struct PbrBsdf {
    /// Base colour (linear).
    pub base: Rgb,
    /// Metalness in [0, 1].
    pub metallic: f32,
    /// Perceptual roughness in [0, 1] (for the albedo table).
    pub roughness: f32,
    /// Weight of the dielectric specular layer (`KHR_materials_specular` specularFactor).
    pub specular: f32,
    /// Microfacet distribution.
    pub ggx: Ggx,
}

impl PbrBsdf {
    /// A BRDF from glTF factors (already multiplied by their textures), specular weight 1.
    pub fn new(base: Rgb, metallic: f32, roughness: f32) -> Self {
        Self::with_specular(base, metallic, roughness, 1.0)
    }

    /// A BRDF with a specular layer weight (`KHR_materials_specular` specularFactor).
    pub fn with_specular(base: Rgb, metallic: f32, roughness: f32, specular: f32) -> Self {
        PbrBsdf {
            base: base.clamp(Vec3::ZERO, Vec3::ONE),
            metallic: metallic.clamp(0.0, 1.0),
            roughness: roughness.clamp(0.0, 1.0),
            specular: specular.clamp(0.0, 1.0),
            ggx: Ggx::from_roughness(roughness.clamp(0.0, 1.0)),
        }
    }

    /// Probability of sampling the specular lobe for `wo` (local, wo.z > 0).
    #[inline]
    fn specular_probability(&self, wo: Vec3) -> f32 {
        let e = self.specular * specular_albedo().e(wo.z, self.roughness);
        let f_metal = luminance(self.base + (Vec3::ONE - self.base) * schlick_weight(wo.z));
        let spec = (1.0 - self.metallic) * e + self.metallic * f_metal;
        let diff = (1.0 - self.metallic) * (1.0 - e) * luminance(self.base);
        if spec + diff > 0.0 {
            spec / (spec + diff)
        } else {
            1.0
        }
    }

    /// f(wo, wi); directions in the local frame, either side (two-sided).
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        let (wo, wi) = flip_to_upper(wo, wi);
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let h = (wo + wi).normalize();
        let voh = wo.dot(h).max(0.0);
        let fw = schlick_weight(voh);
        let spec = self.ggx.d(h) * self.ggx.g2(wo, wi) / (4.0 * wo.z * wi.z);
        // The specular weight scales the whole layer (F0 and F90), so its albedo is
        // weight × E and the albedo scaling stays exact.
        let f_dielectric = self.specular * (F0_DIELECTRIC + (1.0 - F0_DIELECTRIC) * fw);
        let table = specular_albedo();
        let sw = self.specular;
        let (eo, ei) = (
            sw * table.e(wo.z, self.roughness),
            sw * table.e(wi.z, self.roughness),
        );
        let diffuse_weight = (1.0 - eo) * (1.0 - ei) / (1.0 - sw * table.e_avg(self.roughness));
        let dielectric =
            self.base * (FRAC_1_PI * diffuse_weight) + Vec3::splat(f_dielectric * spec);
        let f_metal = self.base + (Vec3::ONE - self.base) * fw;
        let metal = f_metal * spec;
        dielectric * (1.0 - self.metallic) + metal * self.metallic
    }

    /// Density of [`sample`](Self::sample).
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo, wi) = flip_to_upper(wo, wi);
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let ps = self.specular_probability(wo);
        let h = (wo + wi).normalize();
        let pdf_spec = self.ggx.pdf_visible_normal(wo, h) / (4.0 * wo.dot(h).max(1e-8));
        ps * pdf_spec + (1.0 - ps) * cosine_hemisphere_pdf(wi.z)
    }

    /// Samples wi for wo.
    #[inline]
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        let flip = wo.z < 0.0;
        let wo_up = if flip {
            Vec3::new(wo.x, wo.y, -wo.z)
        } else {
            wo
        };
        if wo_up.z <= 0.0 {
            return None;
        }
        let ps = self.specular_probability(wo_up);
        let wi_up = if uc < ps {
            let m = self.ggx.sample_visible_normal(wo_up, u);
            reflect(wo_up, m)
        } else {
            cosine_hemisphere(u)
        };
        if wi_up.z <= 0.0 {
            return None;
        }
        let wi = if flip {
            Vec3::new(wi_up.x, wi_up.y, -wi_up.z)
        } else {
            wi_up
        };
        let pdf = self.pdf(wo, wi);
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample {
            wi,
            f: self.eval(wo, wi),
            pdf,
        })
    }

    /// Albedo for the denoiser: the colour a white light would reflect, roughly.
    pub fn albedo(&self) -> Rgb {
        let f0 = F0_DIELECTRIC * self.specular;
        let dielectric = self.base * (1.0 - f0) + Vec3::splat(f0);
        dielectric * (1.0 - self.metallic) + self.base * self.metallic
    }
}

/// Resolution of the albedo table along cos θ and roughness.
const TABLE_N: usize = 32;

/// Directional albedo E(μ, roughness) of the dielectric GGX layer (F0 = 0.04) and its
/// cosine-weighted average, computed once by stratified quadrature of the VNDF
/// estimator F · G2 / G1 (deterministic: no random numbers).
pub struct SpecularAlbedo {
    e: Vec<f32>,
    avg: Vec<f32>,
}

/// Stratified samples per table entry (per axis).
const TABLE_STRATA: usize = 48;

impl SpecularAlbedo {
    fn compute() -> Self {
        let mut e = vec![0.0f32; TABLE_N * TABLE_N];
        for ri in 0..TABLE_N {
            let roughness = ri as f32 / (TABLE_N - 1) as f32;
            for mi in 0..TABLE_N {
                e[ri * TABLE_N + mi] = directional_albedo(Self::mu(mi), roughness, TABLE_STRATA);
            }
        }
        // E_avg = 2 ∫ E(μ) μ dμ by the trapezoid rule on the table's nodes.
        let avg = (0..TABLE_N)
            .map(|ri| {
                let mut sum = 0.0f32;
                for mi in 0..TABLE_N - 1 {
                    let (m0, m1) = (Self::mu(mi), Self::mu(mi + 1));
                    sum += 0.5
                        * (e[ri * TABLE_N + mi] * m0 + e[ri * TABLE_N + mi + 1] * m1)
                        * (m1 - m0);
                }
                2.0 * sum
            })
            .collect();
        SpecularAlbedo { e, avg }
    }

    /// Node i of the μ axis; nodes are spaced in √μ because E changes fastest at grazing angles.
    fn mu(i: usize) -> f32 {
        let x = i as f32 / (TABLE_N - 1) as f32;
        (x * x).max(1e-3)
    }

    /// E(μ, roughness), bilinear in the table.
    #[inline]
    pub fn e(&self, mu: f32, roughness: f32) -> f32 {
        let x = mu.clamp(0.0, 1.0).sqrt() * (TABLE_N - 1) as f32;
        let y = roughness.clamp(0.0, 1.0) * (TABLE_N - 1) as f32;
        let (x0, y0) = ((x as usize).min(TABLE_N - 2), (y as usize).min(TABLE_N - 2));
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let at = |i: usize, j: usize| self.e[j * TABLE_N + i];
        let a = at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx;
        let b = at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx;
        a * (1.0 - fy) + b * fy
    }

    /// Cosine-weighted average of E over the hemisphere.
    #[inline]
    pub fn e_avg(&self, roughness: f32) -> f32 {
        let y = roughness.clamp(0.0, 1.0) * (TABLE_N - 1) as f32;
        let y0 = (y as usize).min(TABLE_N - 2);
        let fy = y - y0 as f32;
        self.avg[y0] * (1.0 - fy) + self.avg[y0 + 1] * fy
    }
}

/// ∫ f_spec cos dωi for the dielectric GGX layer at μ = cos θo, by `n`×`n` stratified VNDF samples.
pub fn directional_albedo(mu: f32, roughness: f32, n: usize) -> f32 {
    let ggx = Ggx::from_roughness(roughness);
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let mut sum = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let m = ggx.sample_visible_normal(wo, u);
            let wi = reflect(wo, m);
            if wi.z <= 0.0 {
                continue;
            }
            let f = F0_DIELECTRIC + (1.0 - F0_DIELECTRIC) * schlick_weight(wo.dot(m));
            sum += (f * ggx.g2(wo, wi) / ggx.g1(wo)) as f64;
        }
    }
    (sum / (n * n) as f64) as f32
}

/// The shared table.
pub fn specular_albedo() -> &'static SpecularAlbedo {
    static TABLE: std::sync::OnceLock<SpecularAlbedo> = std::sync::OnceLock::new();
    TABLE.get_or_init(SpecularAlbedo::compute)
}

/// Mirrors both directions to the upper hemisphere when `wo` is below it, which makes
/// the BRDF two-sided; `wi` on the other side of the surface than `wo` stays rejected.
#[inline]
fn flip_to_upper(wo: Vec3, wi: Vec3) -> (Vec3, Vec3) {
    if wo.z < 0.0 {
        (Vec3::new(wo.x, wo.y, -wo.z), Vec3::new(wi.x, wi.y, -wi.z))
    } else {
        (wo, wi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{ChiSquareTest, Pcg32, assert_chi2};

    fn materials() -> Vec<(String, PbrBsdf)> {
        let mut v = Vec::new();
        for roughness in [0.15f32, 0.5, 1.0] {
            for metallic in [0.0f32, 0.5, 1.0] {
                v.push((
                    format!("r={roughness} m={metallic}"),
                    PbrBsdf::new(Vec3::new(0.8, 0.4, 0.1), metallic, roughness),
                ));
            }
            for specular in [0.0f32, 0.5] {
                v.push((
                    format!("r={roughness} specular={specular}"),
                    PbrBsdf::with_specular(Vec3::new(0.8, 0.4, 0.1), 0.0, roughness, specular),
                ));
            }
        }
        v
    }

    #[test]
    fn chi2_pbr_lobes() {
        for (name, b) in materials() {
            for theta in [0.1f32, 0.9, 1.45] {
                let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                let mut rng = Pcg32::new(3);
                let t = ChiSquareTest::new(&format!("glTF PBR {name} θ={theta}"));
                assert_chi2(t.run_with_pdf(
                    |u| b.sample(wo, rng.next_f32(), u).map(|s| (s.wi, s.pdf)),
                    |wi| b.pdf(wo, wi),
                ));
            }
        }
    }

    /// Reciprocity: f(wo, wi) = f(wi, wo) for the whole BRDF (the Fresnel term uses the
    /// half vector, which is symmetric; the diffuse/specular split is too).
    #[test]
    fn reciprocity() {
        let mut rng = Pcg32::new(9);
        for (_, b) in materials() {
            for _ in 0..200 {
                let a = cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let c = cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let f1 = b.eval(a, c);
                let f2 = b.eval(c, a);
                assert!((f1 - f2).abs().max_element() <= 1e-4 * f1.max_element().max(1.0));
            }
        }
    }

    /// The albedo table agrees with a 4× finer quadrature within TABLE_ERROR, which the
    /// energy test below then allows for.
    const TABLE_ERROR: f64 = 2e-3;

    #[test]
    fn albedo_table_accuracy() {
        let t = specular_albedo();
        for &(mu, r) in &[
            (0.05f32, 0.1f32),
            (0.3, 0.5),
            (0.77, 0.23),
            (1.0, 1.0),
            (0.5, 0.05),
        ] {
            let fine = directional_albedo(mu, r, 4 * TABLE_STRATA) as f64;
            let err = (t.e(mu, r) as f64 - fine).abs();
            assert!(
                err < TABLE_ERROR,
                "E({mu}, {r}): table {} vs {fine}",
                t.e(mu, r)
            );
        }
    }

    /// Energy: the directional albedo ∫ f cos dwi ≤ 1 at every angle, estimated by
    /// importance sampling with N samples; the bound allows 5 standard errors of the
    /// estimate (its sample standard deviation / √N) plus the albedo table's error.
    #[test]
    fn albedo_at_most_one() {
        let n = 200_000;
        for (name, b) in materials() {
            let b = PbrBsdf {
                base: Vec3::ONE,
                ..b
            };
            for theta in [0.0f32, 0.5, 1.0, 1.5] {
                let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                let mut rng = Pcg32::new(1);
                let (mut sum, mut sum2) = (0f64, 0f64);
                for _ in 0..n {
                    let u = Vec2::new(rng.next_f32(), rng.next_f32());
                    let v = b
                        .sample(wo, rng.next_f32(), u)
                        .map(|s| (s.f.max_element() * s.wi.z / s.pdf) as f64)
                        .unwrap_or(0.0);
                    sum += v;
                    sum2 += v * v;
                }
                let mean = sum / n as f64;
                let se = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
                assert!(
                    mean <= 1.0 + 5.0 * se + TABLE_ERROR,
                    "{name} θ={theta}: albedo {mean} ± {se}"
                );
            }
        }
    }

    /// A white Lambertian (metallic 0, rough) reflects 1 - F: its albedo is close to,
    /// and below, 1 at normal incidence; a black dielectric reflects only the specular.
    #[test]
    fn diffuse_limit() {
        let b = PbrBsdf::new(Vec3::ZERO, 0.0, 1.0);
        let wo = Vec3::Z;
        let wi = Vec3::new(0.6, 0.0, 0.8);
        let f = b.eval(wo, wi);
        assert!(f.x == f.y && f.y == f.z && f.x > 0.0 && f.x < 0.1);
    }
}
