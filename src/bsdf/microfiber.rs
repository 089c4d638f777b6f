//! Blender's sheen: the microfiber sheen of Zeltner, Burley and Chiang 2022 ("Practical
//! Multiple-Scattering Sheen Using Linearly Transformed Cosines"), which Cycles' Principled
//! BSDF and Sheen BSDF (Microfiber) render. glTF's `KHR_materials_sheen` keeps the Charlie
//! lobe of its spec (`sheen.rs`); Blender's materials get this one (contract,
//! `CAUSTIC_materials_sheen`).
//!
//! The lobe seen from wo is a linearly transformed cosine: in the frame whose X axis is wo's
//! direction in the tangent plane, a direction w has density
//! D(w) = w.z a² / (π |M⁻¹w|⁴), M⁻¹ = [[a, 0, b], [0, a, 0], [0, 0, 1]],
//! the cosine distribution carried through M. D integrates to 1 over the sphere; the part
//! below the horizon is lost (Cycles loses it too). The lobe's cos-weighted value is
//! colour × E(μo) × D(wi), with E the fibre layer's directional albedo: a, b and E come from
//! the paper's fit tabulated over (μo, roughness) (`microfiber_table.rs`), read bilinearly as
//! Cycles reads it, roughness clamped to [10⁻³, 1]. Sampling is exact: a cosine sample mapped
//! through M, whose density is D itself.
//!
//! The layers below are scaled by 1 − max(colour) E(μo), by the view alone, as Cycles layers
//! its sheen: not reciprocal (light paths use the adjoint, `Bsdf::eval_adjoint`).

use super::microfiber_table::{LTC_A, LTC_ALBEDO, LTC_B};
use crate::sampling::warp::concentric_disk;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Rows and columns of the fitted tables.
const N: usize = 32;

/// The microfiber sheen seen from one outgoing direction (local frame, +Z the normal).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfiber {
    /// The LTC's diagonal a (0 where the fit has no lobe: the albedo is 0 there too).
    a: f32,
    /// The LTC's shear b.
    b: f32,
    /// The fibre layer's directional albedo E(μo) (white).
    albedo: f32,
    /// wo's direction in the tangent plane: the LTC frame's X axis is (tx, ty, 0).
    tx: f32,
    ty: f32,
}

/// Bilinear read of a 32 × 32 table at (cos θ, roughness) in [0, 1]², as Cycles'
/// `lookup_table_read_2D`.
#[inline]
fn lookup(table: &[f32; N * N], mu: f32, roughness: f32) -> f32 {
    let x = mu.clamp(0.0, 1.0) * (N - 1) as f32;
    let y = roughness.clamp(0.0, 1.0) * (N - 1) as f32;
    let (x0, y0) = ((x as usize).min(N - 2), (y as usize).min(N - 2));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let i = y0 * N + x0;
    let row = |i: usize| table[i] + (table[i + 1] - table[i]) * fx;
    row(i) + (row(i + N) - row(i)) * fy
}

impl Microfiber {
    /// The lobe of sheen roughness `roughness` seen from `wo` (upper hemisphere).
    #[inline]
    pub fn at(wo: Vec3, roughness: f32) -> Self {
        let mu = wo.z.clamp(0.0, 1.0);
        let r = roughness.clamp(1e-3, 1.0);
        let (a, b, albedo) = (lookup(&LTC_A, mu, r), lookup(&LTC_B, mu, r), lookup(&LTC_ALBEDO, mu, r));
        // Seen along the normal the lobe is symmetric about it (b = 0): any X axis will do.
        let len = (wo.x * wo.x + wo.y * wo.y).sqrt();
        let (tx, ty) = if len > 1e-7 { (wo.x / len, wo.y / len) } else { (1.0, 0.0) };
        // Where the fit has no lobe (grazing views at the lowest roughnesses) a is 0: none.
        let present = a > 0.0 && albedo > 0.0;
        Microfiber { a: if present { a } else { 0.0 }, b, albedo: if present { albedo } else { 0.0 }, tx, ty }
    }

    /// The white layer's directional albedo E(μo): what it reflects of a white world, before
    /// the loss below the horizon.
    #[inline]
    pub fn albedo(&self) -> f32 {
        self.albedo
    }

    /// The LTC's density at `wi` (0 below the horizon): the sampling density, and the
    /// cos-weighted value over the albedo.
    #[inline]
    pub fn density(&self, wi: Vec3) -> f32 {
        if wi.z <= 0.0 || self.a <= 0.0 {
            return 0.0;
        }
        let x = wi.x * self.tx + wi.y * self.ty;
        let y = wi.y * self.tx - wi.x * self.ty;
        let (a, b) = (self.a, self.b);
        let len2 = (a * x + b * wi.z) * (a * x + b * wi.z) + (a * y) * (a * y) + wi.z * wi.z;
        FRAC_1_PI * wi.z * (a / len2) * (a / len2)
    }

    /// The white lobe's f(wo, wi) (not times the cosine): E(μo) D(wi) / cos θi.
    #[inline]
    pub fn f(&self, wi: Vec3) -> f32 {
        if wi.z <= 0.0 { 0.0 } else { self.albedo * self.density(wi) / wi.z }
    }

    /// A direction from the LTC (density [`density`](Self::density); it may fall below the
    /// horizon, where the density is 0 and the caller discards it). None without a lobe.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<Vec3> {
        if self.a <= 0.0 {
            return None;
        }
        let d = concentric_disk(u);
        let z = (1.0 - d.dot(d)).max(0.0).sqrt();
        // M applied to a cosine-distributed direction: M = M⁻¹'s inverse.
        let x = (d.x - z * self.b) / self.a;
        let y = d.y / self.a;
        let w = Vec3::new(x * self.tx - y * self.ty, x * self.ty + y * self.tx, z).try_normalize()?;
        Some(w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{ChiSquareTest, Pcg32, assert_chi2};

    /// The sampler follows the density, at several roughnesses and view angles (the view
    /// turned off the X axis, so that the frame's rotation is tested too).
    #[test]
    fn chi2_microfiber() {
        for roughness in [0.05f32, 0.3, 0.5, 1.0] {
            for theta in [0.0f32, 0.7, 1.3, 1.55] {
                let wo = Vec3::new(theta.sin() * 0.6, theta.sin() * 0.8, theta.cos());
                let m = Microfiber::at(wo, roughness);
                if m.albedo() == 0.0 {
                    continue;
                }
                let t = ChiSquareTest::new(&format!("microfiber sheen r={roughness} θ={theta}"));
                assert_chi2(t.run_with_pdf(
                    |u| m.sample(u).filter(|w| w.z > 0.0).map(|w| (w, m.density(w))),
                    |wi| m.density(wi),
                ));
            }
        }
    }

    /// The LTC is a density: over the sphere it integrates to 1 (the part above the horizon,
    /// by quadrature of `density`, plus the fraction of samples below it, which `density`
    /// does not see). The quadrature's error: a 512² midpoint grid in (cos θ, φ) of a smooth
    /// integrand, ~1e-4; the sampled fraction's standard error at 2·10⁵ samples is below
    /// 1.2·10⁻³, so 5 of them plus the quadrature's give 0.007.
    #[test]
    fn ltc_integrates_to_one() {
        let mut rng = Pcg32::new(5);
        for roughness in [0.2f32, 0.5, 0.8, 1.0] {
            for theta in [0.2f32, 0.9, 1.4] {
                let m = Microfiber::at(Vec3::new(theta.sin(), 0.0, theta.cos()), roughness);
                let g = 512;
                let mut above = 0.0f64;
                for i in 0..g {
                    for j in 0..g {
                        let mu = (i as f32 + 0.5) / g as f32;
                        let phi = std::f32::consts::TAU * (j as f32 + 0.5) / g as f32;
                        let s = (1.0 - mu * mu).sqrt();
                        above += m.density(Vec3::new(s * phi.cos(), s * phi.sin(), mu)) as f64;
                    }
                }
                above *= std::f64::consts::TAU / (g * g) as f64;
                let n = 200_000;
                let below = (0..n)
                    .filter(|_| m.sample(Vec2::new(rng.next_f32(), rng.next_f32())).is_some_and(|w| w.z <= 0.0))
                    .count() as f64
                    / n as f64;
                let total = above + below;
                assert!((total - 1.0).abs() < 0.007, "r={roughness} θ={theta}: {above} above + {below} below");
            }
        }
    }

    /// The table reads back its own entries at the grid points, and the lobe vanishes where
    /// the fit has none.
    #[test]
    fn table_lookup_at_grid_points() {
        for (r, c) in [(0usize, 0usize), (8, 16), (31, 31), (16, 0), (31, 5)] {
            let (mu, rough) = (c as f32 / 31.0, r as f32 / 31.0);
            assert!((lookup(&LTC_ALBEDO, mu, rough) - LTC_ALBEDO[r * N + c]).abs() < 1e-6);
            assert!((lookup(&LTC_A, mu, rough) - LTC_A[r * N + c]).abs() < 1e-6);
        }
        let m = Microfiber::at(Vec3::Z, 0.0);
        assert_eq!((m.albedo(), m.density(Vec3::Z), m.sample(Vec2::splat(0.5))), (0.0, 0.0, None));
    }
}
