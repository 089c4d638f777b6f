//! The Charlie sheen lobe of `KHR_materials_sheen` and the precomputed table of its
//! directional albedo, which scales the layers below the sheen (built once, lazily).

use super::albedo::{SpecularAlbedo, TABLE_N, build_entries};
use super::microfacet::reflect;
use glam::Vec3;

/// The Charlie sheen BRDF of Estevez & Kulla 2017 ("Production Friendly Microfacet Sheen
/// BRDF"), one of the two visibilities the glTF sheen extension allows: the normalised
/// distribution D(h) = (2 + 1/α) sin^(1/α)θh / 2π, α = roughness² (kept above 10⁻³ so the
/// exponent stays finite), with the paper's fitted Smith Λ, f = D / ((1 + Λo + Λi) 4 μo μi).
/// A single-scattering microfacet model with a proper masking term reflects at most what
/// it receives, which Ashikhmin's simpler visibility does not (its albedo passes 1 at
/// grazing angles; the energy test caught it).
#[inline]
pub fn charlie_brdf(cos_h: f32, mu_o: f32, mu_i: f32, roughness: f32) -> f32 {
    let alpha = (roughness * roughness).max(1e-3);
    let inv = 1.0 / alpha;
    let sin2 = (1.0 - cos_h * cos_h).max(0.0);
    let d = (2.0 + inv) * sin2.powf(0.5 * inv) / (2.0 * std::f32::consts::PI);
    let denom = (1.0 + charlie_lambda(mu_o, alpha) + charlie_lambda(mu_i, alpha)) * 4.0 * mu_o * mu_i;
    if denom > 0.0 { d / denom } else { 0.0 }
}

/// Estevez & Kulla's fit of the Charlie distribution's Smith Λ: exp(L(μ)) below μ = 1/2 and
/// its mirror exp(2 L(1/2) - L(1 - μ)) above, with L(x) = a / (1 + b x^c) + d x + e and
/// (a..e) interpolated between the paper's two fitted rows by (1 - α)².
#[inline]
fn charlie_lambda(mu: f32, alpha: f32) -> f32 {
    let t = (1.0 - alpha) * (1.0 - alpha);
    let lerp = |x: f32, y: f32| x + (y - x) * t;
    let (a, b, c, d, e) = (
        lerp(21.5473, 25.3245),
        lerp(3.82987, 3.32435),
        lerp(0.19823, 0.16801),
        lerp(-1.97760, -1.27393),
        lerp(-4.32054, -4.85967),
    );
    let l = |x: f32| a / (1.0 + b * x.max(0.0).powf(c)) + d * x + e;
    let mu = mu.abs();
    if mu < 0.5 { l(mu).exp() } else { (2.0 * l(0.5) - l(1.0 - mu)).exp() }
}

/// Stratified samples per axis for the sheen table.
const SHEEN_STRATA: usize = 48;

/// Directional albedo E(μ, roughness) of the Charlie sheen (white), tabulated once by
/// stratified cosine-weighted quadrature.
pub struct SheenAlbedo {
    e: Vec<f32>,
}

impl SheenAlbedo {
    fn compute() -> Self {
        let e = build_entries(TABLE_N * TABLE_N, |i| {
            let (ri, mi) = (i / TABLE_N, i % TABLE_N);
            sheen_directional_albedo(SpecularAlbedo::mu(mi), ri as f32 / (TABLE_N - 1) as f32, SHEEN_STRATA)
        });
        SheenAlbedo { e }
    }

    /// E(μ, roughness), bilinear.
    #[inline]
    pub fn e(&self, mu: f32, roughness: f32) -> f32 {
        let x = mu.clamp(0.0, 1.0).sqrt() * (TABLE_N - 1) as f32;
        let y = roughness.clamp(0.0, 1.0) * (TABLE_N - 1) as f32;
        let (x0, y0) = ((x as usize).min(TABLE_N - 2), (y as usize).min(TABLE_N - 2));
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let (i00, i01) = (y0 * TABLE_N + x0, (y0 + 1) * TABLE_N + x0);
        let t = &self.e;
        (1.0 - fx) * (1.0 - fy) * t[i00]
            + fx * (1.0 - fy) * t[i00 + 1]
            + (1.0 - fx) * fy * t[i01]
            + fx * fy * t[i01 + 1]
    }
}

/// ∫ f_sheen cos dωi at μ = cos θo for white sheen, by `n`×`n` stratified samples of the
/// half vector from D(h) cos θh (sin θh = ξ^(α / (2α + 1)) inverts its CDF), for which the
/// estimator f μi / p = |wo·h| / ((1 + Λo + Λi) μo cos θh) is smooth: cosine-weighted
/// strata miss the lobe at grazing angles and low roughness.
pub fn sheen_directional_albedo(mu: f32, roughness: f32, n: usize) -> f32 {
    let alpha = (roughness * roughness).max(1e-3);
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let lo = charlie_lambda(mu, alpha);
    let mut sum = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            let (x1, x2) = ((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let sin_h = x1.powf(alpha / (2.0 * alpha + 1.0));
            let cos_h = (1.0 - sin_h * sin_h).max(0.0).sqrt();
            let phi = std::f32::consts::TAU * x2;
            let h = Vec3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h);
            let wi = reflect(wo, h);
            if wi.z <= 0.0 || cos_h <= 0.0 {
                continue;
            }
            let li = charlie_lambda(wi.z, alpha);
            sum += (wo.dot(h).abs() / ((1.0 + lo + li) * mu * cos_h)) as f64;
        }
    }
    (sum / (n * n) as f64).min(1.0) as f32
}

/// The shared sheen table.
pub fn sheen_albedo_table() -> &'static SheenAlbedo {
    static TABLE: std::sync::OnceLock<SheenAlbedo> = std::sync::OnceLock::new();
    TABLE.get_or_init(SheenAlbedo::compute)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::albedo::TABLE_ERROR;

    /// The sheen table agrees with a 4× finer quadrature (the albedo test allows its error).
    #[test]
    fn sheen_table_accuracy() {
        let t = sheen_albedo_table();
        for &(mu, r) in &[(0.05f32, 0.2f32), (0.3, 0.5), (0.77, 0.9), (1.0, 1.0), (0.5, 0.05)] {
            let fine = sheen_directional_albedo(mu, r, 4 * SHEEN_STRATA) as f64;
            let err = (t.e(mu, r) as f64 - fine).abs();
            assert!(err < TABLE_ERROR, "E_sheen({mu}, {r}): table {} vs {fine}", t.e(mu, r));
        }
    }
}
