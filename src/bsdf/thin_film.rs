//! Thin-film iridescence: the reflectance of a dielectric film (index n2, thickness d) between
//! air and a dielectric substrate (n3), in RGB, as Cycles evaluates Blender's Principled BSDF
//! Thin Film (after Belcour & Barla 2017, "A Practical Extension to Microfacet Theory for the
//! Modeling of Varying Iridescence"); glTF's `KHR_materials_iridescence` is the same model.
//!
//! Per wavelength the film's reflectance is the Airy sum of its internal reflections. Written
//! as a series in the round trips m (Belcour & Barla, eq. 10), per polarisation,
//!
//! ```text
//! R(λ) = C0 + 2 Σ_{m≥1} Cm cos(m (2π OPD/λ + φ)),   OPD = 2 n2 d cos θ2,
//! C0 = R12 + Rs,  Rs = T121² R23 / (1 − R12 R23),  Cm = (Rs − T121) (R12 R23)^(m/2),
//! ```
//! with R12, R23 the interfaces' reflectances, T121 = 1 − R12 and φ the reflections' phase
//! shifts (0 or π at dielectric interfaces). A colour channel is R weighted by that channel's
//! colour-matching function: the cosine terms become the real part of the CMF's Fourier
//! transform at m·OPD, S_c(x) = ∫ cmf_c(λ) e^{2πi x/λ} dλ / ∫ cmf_c, tabulated once
//! ([`sensitivity`]). The series stops at m = 3 as Cycles' does (the rest is bounded by
//! 2 |Rs − T121| r⁴/(1 − r), r = √(R12 R23): 3e-7 for a soap film, 3e-4 for a film of index 2 in air).
//!
//! The CMFs are CIE 1931 2° by the multi-lobe fit of Wyman, Sloan & Shirley 2013 (JCGT 2(2)),
//! taken to linear Rec.709 (Blender's default scene-linear space) by the XYZ → sRGB matrix of
//! IEC 61966-2-1; each channel is normalised so that a flat spectrum of reflectance 1 is white.
//! Not handled: a film on a metal (Cycles' conductor case), wavelength dependence of the
//! indices.

use crate::math::Rgb;
use glam::Vec3;

/// Largest optical path difference tabulated, nm (Cycles' range); beyond it S is read at
/// the last entry, where the transform has decayed to a few percent.
const OPD_MAX: f64 = 60000.0;
/// Table entries over [0, OPD_MAX]: a step of 7.3 nm keeps the linear interpolation of the
/// fastest oscillation (period λ_min = 380 nm) within (2π h/λ_min)²/8 ≈ 1.5e-2 of |S| ≤ 1,
/// which the coefficients Cm (≤ 0.1 for n < 2.5) scale to a few 1e-4.
const TABLE_N: usize = 8192;
/// Frequency samples (1/λ over [1/830, 1/360] nm⁻¹) of the transform: step 1.5e-6 nm⁻¹, so
/// that the largest OPD's phase advances 0.6 rad per step.
const NU_N: usize = 1024;

/// CIE 1931 2° colour-matching functions x̄, ȳ, z̄ at λ (nm): Wyman, Sloan & Shirley's
/// multi-lobe fit (piecewise Gaussians, within about 1 % of the tabulated functions' peak).
pub fn cmf_xyz(lambda: f64) -> [f64; 3] {
    let g = |mu: f64, s1: f64, s2: f64| {
        let t = (lambda - mu) / if lambda < mu { s1 } else { s2 };
        (-0.5 * t * t).exp()
    };
    [
        1.056 * g(599.8, 37.9, 31.0) + 0.362 * g(442.0, 16.0, 26.7) - 0.065 * g(501.1, 20.4, 26.2),
        0.821 * g(568.8, 46.9, 40.5) + 0.286 * g(530.9, 16.3, 31.1),
        1.217 * g(437.0, 11.8, 36.0) + 0.681 * g(459.0, 26.0, 13.8),
    ]
}

/// The colour-matching functions of linear Rec.709 at λ: XYZ → RGB by IEC 61966-2-1's matrix.
pub fn cmf_rgb(lambda: f64) -> [f64; 3] {
    let [x, y, z] = cmf_xyz(lambda);
    [
        3.2404542 * x - 1.5371385 * y - 0.4985314 * z,
        -0.9692660 * x + 1.8760108 * y + 0.0415560 * z,
        0.0556434 * x - 0.2040259 * y + 1.0572252 * z,
    ]
}

/// The normalised Fourier transforms S_c(x) of the RGB CMFs, (Re, Im) per channel.
pub struct Sensitivity {
    table: Box<[[f32; 6]]>,
}

impl Sensitivity {
    fn compute() -> Self {
        // Over ν = 1/λ: ∫ cmf(λ) e^{2πi x/λ} dλ = ∫ cmf(1/ν) e^{2πi x ν} dν / ν², midpoint rule;
        // each entry's phasor advances by one rotation per step in x.
        let (nu0, nu1) = (1.0 / 830.0, 1.0 / 360.0);
        let dnu = (nu1 - nu0) / NU_N as f64;
        let dx = OPD_MAX / (TABLE_N - 1) as f64;
        let mut acc = vec![[0.0f64; 6]; TABLE_N];
        for k in 0..NU_N {
            let nu = nu0 + (k as f64 + 0.5) * dnu;
            let c = cmf_rgb(1.0 / nu);
            let w = dnu / (nu * nu);
            let (step_im, step_re) = (2.0 * std::f64::consts::PI * dx * nu).sin_cos();
            let (mut pr, mut pi) = (1.0f64, 0.0f64);
            for e in acc.iter_mut() {
                for ch in 0..3 {
                    e[ch] += c[ch] * w * pr;
                    e[3 + ch] += c[ch] * w * pi;
                }
                let r = pr * step_re - pi * step_im;
                pi = pr * step_im + pi * step_re;
                pr = r;
            }
        }
        let norm = [acc[0][0], acc[0][1], acc[0][2]];
        let table = acc
            .iter()
            .map(|e| {
                let mut out = [0.0f32; 6];
                for ch in 0..3 {
                    out[ch] = (e[ch] / norm[ch]) as f32;
                    out[3 + ch] = (e[3 + ch] / norm[ch]) as f32;
                }
                out
            })
            .collect();
        Sensitivity { table }
    }

    /// Re S_c(x) per channel at optical path difference `x` nm (linear between entries).
    #[inline]
    pub fn re(&self, x: f32) -> Rgb {
        let t = (x.max(0.0) / OPD_MAX as f32 * (TABLE_N - 1) as f32).min((TABLE_N - 1) as f32);
        let i = (t as usize).min(TABLE_N - 2);
        let f = t - i as f32;
        let (a, b) = (&self.table[i], &self.table[i + 1]);
        Vec3::new(a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f, a[2] + (b[2] - a[2]) * f)
    }
}

/// The shared sensitivity table, built on first use.
pub fn sensitivity() -> &'static Sensitivity {
    static TABLE: std::sync::OnceLock<Sensitivity> = std::sync::OnceLock::new();
    TABLE.get_or_init(Sensitivity::compute)
}

/// Reflectances (s, p) of a dielectric interface of relative index `eta` (transmitted over
/// incident) at incidence cosine `cos_i`, the transmitted cosine, and the signs of the
/// amplitudes (the phase shift, 0 or π); None under total internal reflection.
#[inline]
fn interface(cos_i: f32, eta: f32) -> Option<([f32; 2], f32, [f32; 2])> {
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    Some(([r_s * r_s, r_p * r_p], cos_t, [r_s.signum(), r_p.signum()]))
}

/// The Airy series of one polarisation in RGB, truncated after m = 3.
#[inline]
fn airy(s: &Sensitivity, r12: f32, r23: f32, opd: f32, phase: f32) -> Rgb {
    let t121 = 1.0 - r12;
    let r123 = r12 * r23;
    let rs = t121 * t121 * r23 / (1.0 - r123).max(1e-6);
    let r = r123.sqrt();
    let mut out = Rgb::splat(r12 + rs);
    let (mut cm, mut sign) = (rs - t121, 1.0f32);
    for m in 1..=3 {
        cm *= r;
        sign *= phase;
        out += s.re(m as f32 * opd) * (2.0 * cm * sign);
    }
    out
}

/// RGB reflectance at incidence cosine `cos` (from air) of a film of index `film_ior` and
/// thickness `thickness` nm on a dielectric of index `substrate_ior`. Below 1 nm the film's
/// index blends towards air's (smoothstep), as Cycles does, where the wave picture no longer
/// holds; total internal reflection in the film reflects everything.
pub fn film_reflectance(cos: f32, film_ior: f32, thickness: f32, substrate_ior: f32) -> Rgb {
    let n2 = if thickness < 1.0 {
        let t = thickness.clamp(0.0, 1.0);
        1.0 + (film_ior - 1.0) * t * t * (3.0 - 2.0 * t)
    } else {
        film_ior
    };
    let cos1 = cos.clamp(0.0, 1.0);
    let Some((r12, cos2, sign12)) = interface(cos1, n2) else { return Rgb::ONE };
    let Some((r23, _, sign23)) = interface(cos2, substrate_ior / n2) else { return Rgb::ONE };
    let opd = 2.0 * n2 * thickness.max(0.0) * cos2;
    let s = sensitivity();
    // Phase of the two reflections a round trip adds: at 2→3 and at 2→1 (the opposite sign
    // of 1→2's amplitude).
    let rs = airy(s, r12[0], r23[0], opd, -sign12[0] * sign23[0]);
    let rp = airy(s, r12[1], r23[1], opd, -sign12[1] * sign23[1]);
    ((rs + rp) * 0.5).clamp(Vec3::ZERO, Vec3::ONE)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exact reflectance at normal incidence of a film between indices n1 = 1 and n3, per
    /// wavelength: |(r12 + r23 e^{iδ}) / (1 + r12 r23 e^{iδ})|², δ = 4π n2 d/λ.
    fn exact(lambda: f64, n2: f64, d: f64, n3: f64) -> f64 {
        let r12 = (1.0 - n2) / (1.0 + n2);
        let r23 = (n2 - n3) / (n2 + n3);
        let delta = 4.0 * std::f64::consts::PI * n2 * d / lambda;
        let (s, c) = delta.sin_cos();
        let (nr, ni) = (r12 + r23 * c, r23 * s);
        let (dr, di) = (1.0 + r12 * r23 * c, r12 * r23 * s);
        (nr * nr + ni * ni) / (dr * dr + di * di)
    }

    /// At normal incidence the RGB reflectance equals the exact per-wavelength reflectance
    /// weighted by each channel's CMF (integrated over λ in 0.05 nm steps), for a soap film
    /// and a coating on glass at several thicknesses. Bound: the truncated series' tail
    /// 2 |Rs − T121| r⁴/(1 − r), plus the table's interpolation (1.5e-2 of S, times Σ 2|Cm|),
    /// plus 1e-4 for the two quadratures of the CMFs.
    #[test]
    fn normal_incidence_matches_the_closed_form() {
        for (n2, n3) in [(1.33f64, 1.0f64), (1.33, 1.5), (2.0, 1.5), (1.45, 1.0)] {
            for d in [50.0f64, 150.0, 300.0, 450.0, 800.0] {
                let fast = film_reflectance(1.0, n2 as f32, d as f32, n3 as f32);
                let (mut num, mut den) = ([0.0f64; 3], [0.0f64; 3]);
                let mut lambda = 360.0;
                while lambda < 830.0 {
                    let c = cmf_rgb(lambda);
                    let r = exact(lambda, n2, d, n3);
                    for ch in 0..3 {
                        num[ch] += c[ch] * r;
                        den[ch] += c[ch];
                    }
                    lambda += 0.05;
                }
                let r12 = ((1.0 - n2) / (1.0 + n2)).powi(2);
                let r23 = ((n2 - n3) / (n2 + n3)).powi(2);
                let t121 = 1.0 - r12;
                let rs = t121 * t121 * r23 / (1.0 - r12 * r23);
                let r = (r12 * r23).sqrt();
                let c1 = (rs - t121).abs();
                let tail = 2.0 * c1 * r.powi(4) / (1.0 - r);
                let table = 1.5e-2 * 2.0 * c1 * (r + r * r + r * r * r);
                let bound = tail + table + 1e-4;
                for ch in 0..3 {
                    // Rec.709's red CMF is negative over the blue-greens: a film reflecting mostly
                    // there is out of gamut, clamped at 0 as the renderer (and Cycles) clamp it.
                    let want = (num[ch] / den[ch]).clamp(0.0, 1.0);
                    assert!(
                        (fast[ch] as f64 - want).abs() <= bound,
                        "n2={n2} n3={n3} d={d} channel {ch}: {} vs {want} (bound {bound:.1e})",
                        fast[ch]
                    );
                }
            }
        }
    }

    /// A vanishing film leaves the bare interface: a film of thickness 0 on glass reflects
    /// glass's F0 at normal incidence, and a soap film of thickness 0 reflects nothing (the
    /// two reflections cancel).
    #[test]
    fn vanishing_film() {
        let glass = film_reflectance(1.0, 1.33, 0.0, 1.5);
        assert!((glass - Vec3::splat(0.04)).abs().max_element() < 1e-4, "{glass}");
        let soap = film_reflectance(1.0, 1.33, 0.5, 1.0);
        assert!(soap.max_element() < 1e-3, "{soap}");
    }

    /// A flat spectrum is white: S_c(0) = 1 in every channel, and the transform decays far out.
    #[test]
    fn sensitivity_is_normalised() {
        let s = sensitivity();
        assert!((s.re(0.0) - Vec3::ONE).abs().max_element() < 1e-6);
        assert!(s.re(59000.0).abs().max_element() < 0.1);
    }
}
