//! Directional albedo of an anisotropic GGX reflection layer, for the albedo scaling and
//! the multiple-scattering compensation of anisotropic lobes (`KHR_materials_anisotropy`).
//!
//! An anisotropic lobe's albedo depends on the view's azimuth as well as its elevation: a
//! view along the wide axis loses far more light than one along the narrow axis (white GGX
//! at widths (1, 0.09): 0.53 along either axis seen from above, 0.75 vs 0.52 at 75°), so no
//! isotropic roughness stands in for it (Cycles' geometric-mean width leaves 4-40 % of the
//! energy out). The table holds E = F0·A + B (Schlick's Fresnel is linear in F0) over
//! (μ, φ, rx, ry), rx and ry the perceptual roughnesses √αx and √αy, φ folded into
//! [0, π/2] by the lobe's mirror symmetries; built once, lazily, only when a scene uses it.

use super::albedo::{albedo_split, build_entries};
use super::microfacet::Ggx;
use glam::Vec3;
use std::f32::consts::FRAC_PI_2;

/// Nodes along μ (spaced in √μ), φ (uniform in [0, π/2]) and each roughness (uniform).
const N_MU: usize = 16;
const N_PHI: usize = 9;
const N_R: usize = 16;
/// Stratified VNDF samples per entry (per axis).
const STRATA: usize = 24;

/// The table: (A, B) per node, and the cosine-weighted hemispherical averages per (rx, ry).
pub struct AnisoAlbedo {
    ab: Vec<(f32, f32)>,
    avg: Vec<(f32, f32)>,
}

fn node(i: usize, n: usize) -> f32 {
    i as f32 / (n - 1) as f32
}

fn mu_node(i: usize) -> f32 {
    let x = node(i, N_MU);
    (x * x).max(1e-3)
}

/// Linear position of `x` on `n` nodes over [0, 1]: (lower node, fraction).
#[inline]
fn cell(x: f32, n: usize) -> (usize, f32) {
    let t = x.clamp(0.0, 1.0) * (n - 1) as f32;
    let i = (t as usize).min(n - 2);
    (i, t - i as f32)
}

impl AnisoAlbedo {
    fn index(mi: usize, pi: usize, xi: usize, yi: usize) -> usize {
        ((yi * N_R + xi) * N_PHI + pi) * N_MU + mi
    }

    fn compute() -> Self {
        let n = N_MU * N_PHI * N_R * N_R;
        let ab = build_entries(n, |i| {
            let mi = i % N_MU;
            let pi = (i / N_MU) % N_PHI;
            let xi = (i / (N_MU * N_PHI)) % N_R;
            let yi = i / (N_MU * N_PHI * N_R);
            let (rx, ry) = (node(xi, N_R), node(yi, N_R));
            let phi = node(pi, N_PHI) * FRAC_PI_2;
            anisotropic_albedo_split(mu_node(mi), phi, rx * rx, ry * ry, STRATA)
        });
        // Average over the hemisphere, cosine-weighted: the mean over φ of 2 ∫ E(μ) μ dμ
        // (trapezoid rule on the nodes in both).
        let mut avg = Vec::with_capacity(N_R * N_R);
        for yi in 0..N_R {
            for xi in 0..N_R {
                let (mut sa, mut sb) = (0.0f32, 0.0f32);
                for pi in 0..N_PHI {
                    let w = if pi == 0 || pi == N_PHI - 1 { 0.5 } else { 1.0 } / (N_PHI - 1) as f32;
                    for mi in 0..N_MU - 1 {
                        let (m0, m1) = (mu_node(mi), mu_node(mi + 1));
                        let (a0, b0) = ab[Self::index(mi, pi, xi, yi)];
                        let (a1, b1) = ab[Self::index(mi + 1, pi, xi, yi)];
                        sa += w * (a0 * m0 + a1 * m1) * (m1 - m0);
                        sb += w * (b0 * m0 + b1 * m1) * (m1 - m0);
                    }
                }
                avg.push((sa, sb));
            }
        }
        AnisoAlbedo { ab, avg }
    }

    /// (A, B) with E = F0·A + B for the local direction `w` (unit, w.z > 0) and the
    /// perceptual roughnesses (rx, ry) along the frame's X and Y axes.
    #[inline]
    pub fn ab(&self, w: Vec3, rx: f32, ry: f32) -> (f32, f32) {
        let mu = w.z.clamp(0.0, 1.0);
        let phi = w.y.abs().atan2(w.x.abs()) / FRAC_PI_2;
        let (m0, fm) = cell(mu.sqrt(), N_MU);
        let (p0, fp) = cell(phi, N_PHI);
        let (x0, fx) = cell(rx, N_R);
        let (y0, fy) = cell(ry, N_R);
        let (mut a, mut b) = (0.0f32, 0.0f32);
        for corner in 0..16 {
            let (dm, dp, dx, dy) = (corner & 1, (corner >> 1) & 1, (corner >> 2) & 1, (corner >> 3) & 1);
            let w = (if dm == 1 { fm } else { 1.0 - fm })
                * (if dp == 1 { fp } else { 1.0 - fp })
                * (if dx == 1 { fx } else { 1.0 - fx })
                * (if dy == 1 { fy } else { 1.0 - fy });
            let (ea, eb) = self.ab[Self::index(m0 + dm, p0 + dp, x0 + dx, y0 + dy)];
            a += w * ea;
            b += w * eb;
        }
        (a, b)
    }

    /// (A, B) of the cosine-weighted hemispherical average.
    #[inline]
    pub fn ab_avg(&self, rx: f32, ry: f32) -> (f32, f32) {
        let (x0, fx) = cell(rx, N_R);
        let (y0, fy) = cell(ry, N_R);
        let at = |x: usize, y: usize| self.avg[y * N_R + x];
        let lerp = |p: (f32, f32), q: (f32, f32), t: f32| (p.0 + (q.0 - p.0) * t, p.1 + (q.1 - p.1) * t);
        lerp(lerp(at(x0, y0), at(x0 + 1, y0), fx), lerp(at(x0, y0 + 1), at(x0 + 1, y0 + 1), fx), fy)
    }
}

/// (A, B) of ∫ f_spec cos dωi = F0·A + B for the anisotropic GGX layer of widths (αx, αy)
/// seen from elevation cos θ = `mu` and azimuth `phi`, by `n`×`n` stratified VNDF samples.
pub fn anisotropic_albedo_split(mu: f32, phi: f32, alpha_x: f32, alpha_y: f32, n: usize) -> (f32, f32) {
    let ggx = Ggx::anisotropic(alpha_x, alpha_y);
    let s = (1.0 - mu * mu).max(0.0).sqrt();
    let wo = Vec3::new(s * phi.cos(), s * phi.sin(), mu);
    albedo_split(&ggx, wo, n)
}

/// The shared table.
pub fn aniso_albedo() -> &'static AnisoAlbedo {
    static TABLE: std::sync::OnceLock<AnisoAlbedo> = std::sync::OnceLock::new();
    TABLE.get_or_init(AnisoAlbedo::compute)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Between the nodes, the white lobe's albedo (A + B) agrees with a fine quadrature
    /// within 0.5 %: the furnace of an anisotropic white metal is exact up to this error
    /// and must hold within 1 %, so the table takes at most half of that.
    #[test]
    fn table_interpolates_the_albedo() {
        let t = aniso_albedo();
        let mut worst = 0.0f32;
        for &(mu, phi, rx, ry) in &[
            (0.9f32, 0.3f32, 0.35f32, 0.7f32),
            (0.5, 1.1, 0.62, 0.28),
            (0.2, 0.7, 0.45, 0.95),
            (0.75, 0.05, 0.9, 0.31),
            (0.33, 1.4, 0.2, 0.55),
            (0.6, 0.8, 0.5, 0.5),
        ] {
            let w = Vec3::new((1.0 - mu * mu).sqrt() * phi.cos(), (1.0 - mu * mu).sqrt() * phi.sin(), mu);
            let (a, b) = t.ab(w, rx, ry);
            let (fa, fb) = anisotropic_albedo_split(mu, phi, rx * rx, ry * ry, 96);
            let rel = ((a + b) - (fa + fb)).abs() / (fa + fb);
            worst = worst.max(rel);
            assert!(rel < 5e-3, "μ={mu} φ={phi} r=({rx}, {ry}): table {} vs {}", a + b, fa + fb);
        }
        eprintln!("worst relative table error {worst}");
    }
}
