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
//!
//! On a conductor (Cycles' `fresnel_iridescence_channel<true>`) the film-to-metal reflection
//! shifts the phase by any angle, not 0 or π: the series takes the complex phasor e^{iφ} and
//! the transform's imaginary part, Re(e^{imφ} S_c(m OPD)) per term ([`conductor_film_reflectance`]).
//! Cycles' F82-tint metal (the Principled BSDF's and the Metallic BSDF's default) gets its
//! complex index from F0 and its value at 82° by Gulbrandsen's artist-friendly mapping
//! ([`f82_conductor_index`]), its reflectances under the film from the F82 model at the index
//! relative to the film's, its phases from that index.
//! Not handled: wavelength dependence of the indices.

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
        self.at(x).0
    }

    /// (Re, Im) of S_c(x) per channel at optical path difference `x` nm (linear between
    /// entries); Im is ∫ cmf sin(2π x/λ), the opposite sign of Cycles' table (numpy's FFT).
    #[inline]
    pub fn at(&self, x: f32) -> (Rgb, Rgb) {
        let t = (x.max(0.0) / OPD_MAX as f32 * (TABLE_N - 1) as f32).min((TABLE_N - 1) as f32);
        let i = (t as usize).min(TABLE_N - 2);
        let f = t - i as f32;
        let (a, b) = (&self.table[i], &self.table[i + 1]);
        let l = |c: usize| a[c] + (b[c] - a[c]) * f;
        (Vec3::new(l(0), l(1), l(2)), Vec3::new(l(3), l(4), l(5)))
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
    let n2 = film_index(film_ior, thickness);
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

/// The film's index, blended towards air's below 1 nm (smoothstep), as Cycles does where the
/// wave picture no longer holds.
#[inline]
fn film_index(film_ior: f32, thickness: f32) -> f32 {
    if thickness < 1.0 {
        let t = thickness.clamp(0.0, 1.0);
        1.0 + (film_ior - 1.0) * t * t * (3.0 - 2.0 * t)
    } else {
        film_ior
    }
}

/// The complex index n + ik of Cycles' F82-tint conductor of normal reflectance `f0` and
/// F82-tint factor `b` (`microfacet::f82_tint_b`), by Gulbrandsen's mapping of (r, g) =
/// (F0, the reflectance at cos θ = 1/7), with that g: (n, k, g) per channel, as Cycles'
/// `microfacet_fresnel` derives them for a film.
pub fn f82_conductor_index(f0: Rgb, b: Rgb) -> (Rgb, Rgb, Rgb) {
    let g = super::microfacet::f82_tint(f0, b, 1.0 / 7.0);
    let (mut n, mut k) = (Rgb::ZERO, Rgb::ZERO);
    for c in 0..3 {
        let r = f0[c].min(0.999);
        let sr = r.max(0.0).sqrt();
        let nc = (1.0 + sr) / (1.0 - sr) + ((1.0 - r) / (1.0 + r) - (1.0 + sr) / (1.0 - sr)) * g[c];
        n[c] = nc;
        k[c] = ((r * (nc + 1.0) * (nc + 1.0) - (nc - 1.0) * (nc - 1.0)) / (1.0 - r)).max(0.0).sqrt();
    }
    (n, k, g)
}

/// Reflectances (s, p) and phasors e^{iφ} (re, im) of the interface from a dielectric of
/// index `eta1` into a conductor n + ik at incidence cosine `cos`: Cycles'
/// `fresnel_conductor_polarized` (Born & Wolf 14.4.1 with n + ik). With `f82` (the F82-tint
/// value at 82° in air) the reflectances are instead the F82 model's, its F0 taken at the
/// index relative to `eta1`, as Cycles' F82 conductor under a film.
#[inline]
fn conductor_interface(cos: f32, eta1: f32, n: f32, k: f32, f82: Option<f32>) -> ([f32; 2], [(f32, f32); 2]) {
    let (e1s, n2s, k2s) = (eta1 * eta1, n * n, k * k);
    let two_nk = 2.0 * n * k;
    let t1 = n2s - k2s - e1s * (1.0 - cos * cos);
    let t2 = (t1 * t1 + two_nk * two_nk).sqrt();
    let (u2, v2) = ((0.5 * (t2 + t1)).max(0.0), (0.5 * (t2 - t1)).max(0.0));
    let (u, v) = (u2.sqrt(), v2.sqrt());
    let div = |a: f32, b: f32| if b != 0.0 { a / b } else { 0.0 };
    let r = match f82 {
        Some(f82) => {
            let (nr, kr2) = (n / eta1, (k / eta1) * (k / eta1));
            let f0 = ((nr - 1.0) * (nr - 1.0) + kr2) / ((nr + 1.0) * (nr + 1.0) + kr2);
            let b = super::microfacet::f82_b_through(Vec3::splat(f0), Vec3::splat(f82)).x;
            let r = super::microfacet::f82_tint(Vec3::splat(f0), Vec3::splat(b), cos).x;
            [r, r]
        }
        None => {
            let rs = div((eta1 * cos - u).powi(2) + v2, (eta1 * cos + u).powi(2) + v2);
            let (t3, t4) = ((n2s - k2s) * cos, two_nk * cos);
            let rp = div(
                (t3 - eta1 * u).powi(2) + (t4 - eta1 * v).powi(2),
                (t3 + eta1 * u).powi(2) + (t4 + eta1 * v).powi(2),
            );
            [rs, rp]
        }
    };
    let unit = |re: f32, im: f32| {
        let m = (re * re + im * im).sqrt();
        if m == 0.0 { (1.0, 0.0) } else { (re / m, im / m) }
    };
    let s = unit(-u2 - v2 + e1s * cos * cos, -2.0 * eta1 * cos * v);
    let p = unit(((n2s + k2s) * cos).powi(2) - e1s * (u2 + v2), 2.0 * eta1 * cos * (two_nk * u - (n2s - k2s) * v));
    (r, [s, p])
}

/// The Airy series of one polarisation and channel with a complex round-trip phasor: C0 plus
/// 2 Σ Cm Re(e^{imφ} S(m OPD)), m ≤ 3, from the transforms `s` at m OPD.
#[inline]
fn airy_complex(s: &[(f32, f32); 3], r12: f32, r23: f32, phasor: (f32, f32)) -> f32 {
    let t121 = 1.0 - r12;
    let r123 = r12 * r23;
    let rs = t121 * t121 * r23 / (1.0 - r123).max(1e-6);
    let r = r123.sqrt();
    let mut out = r12 + rs;
    let mut cm = rs - t121;
    let mut acc = phasor;
    for &(re, im) in s {
        cm *= r;
        out += 2.0 * cm * (acc.0 * re - acc.1 * im);
        acc = (acc.0 * phasor.0 - acc.1 * phasor.1, acc.0 * phasor.1 + acc.1 * phasor.0);
    }
    out
}

/// RGB reflectance at incidence cosine `cos` (from air) of a film of index `film_ior` and
/// thickness `thickness` nm on a conductor of complex index `n` + i`k` per channel: exact
/// interface reflectances (Cycles' physical conductor), or with `f82` (per channel, the
/// F82-tint value at 82°: [`f82_conductor_index`]) the F82 model's (Cycles' F82 conductor).
pub fn conductor_film_reflectance(cos: f32, film_ior: f32, thickness: f32, n: Rgb, k: Rgb, f82: Option<Rgb>) -> Rgb {
    let n2 = film_index(film_ior, thickness);
    let cos1 = cos.clamp(0.0, 1.0);
    let Some((r12, cos2, sign12)) = interface(cos1, n2) else { return Rgb::ONE };
    let opd = 2.0 * n2 * thickness.max(0.0) * cos2;
    let table = sensitivity();
    let terms = [table.at(opd), table.at(2.0 * opd), table.at(3.0 * opd)];
    let mut out = Rgb::ZERO;
    for c in 0..3 {
        let s = terms.map(|(re, im)| (re[c], im[c]));
        let (r23, [ps, pp]) = conductor_interface(cos2, n2, n[c], k[c], f82.map(|f| f[c]));
        // The round trip's phase: the film-to-metal reflection's and the film-to-air one's
        // (the opposite sign of air-to-film's amplitude).
        let rs = airy_complex(&s, r12[0], r23[0], (-sign12[0] * ps.0, -sign12[0] * ps.1));
        let rp = airy_complex(&s, r12[1], r23[1], (-sign12[1] * pp.0, -sign12[1] * pp.1));
        out[c] = (0.5 * (rs + rp)).clamp(0.0, 1.0);
    }
    out
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
                let bound = airy_bound(c1, r) + 1e-4;
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

    /// The fast sum's error against the exact Airy sum: the terms past the third (a geometric
    /// tail of ratio r, amplitude 2 c1) and the sensitivity table's 1.5 % on the first three.
    fn airy_bound(c1: f64, r: f64) -> f64 {
        2.0 * c1 * r.powi(4) / (1.0 - r) + 1.5e-2 * 2.0 * c1 * (r + r * r + r * r * r)
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

    /// Complex numbers for the exact conductor reference.
    #[derive(Clone, Copy)]
    struct C(f64, f64);
    impl C {
        fn add(self, o: C) -> C {
            C(self.0 + o.0, self.1 + o.1)
        }
        fn sub(self, o: C) -> C {
            C(self.0 - o.0, self.1 - o.1)
        }
        fn mul(self, o: C) -> C {
            C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
        }
        fn div(self, o: C) -> C {
            let d = o.0 * o.0 + o.1 * o.1;
            C((self.0 * o.0 + self.1 * o.1) / d, (self.1 * o.0 - self.0 * o.1) / d)
        }
        fn sqrt(self) -> C {
            let m = (self.0 * self.0 + self.1 * self.1).sqrt();
            C(((m + self.0) / 2.0).sqrt(), ((m - self.0) / 2.0).sqrt().copysign(self.1))
        }
        fn norm2(self) -> f64 {
            self.0 * self.0 + self.1 * self.1
        }
    }

    /// The exact reflectance (s and p averaged) of a film n2, d nm, between air and a conductor
    /// n + ik at wavelength λ and incidence cosine `cos1`: the Airy sum
    /// (r12 + r23 e^{iδ}) / (1 + r12 r23 e^{iδ}) of the complex amplitudes, δ = 4π n2 d cos θ2 / λ
    /// (time convention e^{-iωt}, absorbing index n + ik).
    fn exact_conductor(lambda: f64, cos1: f64, n2: f64, d: f64, n: f64, k: f64) -> f64 {
        let sin1_2 = 1.0 - cos1 * cos1;
        let cos2 = (1.0 - sin1_2 / (n2 * n2)).sqrt();
        let big_n = C(n, k);
        let n2c = C(n2, 0.0);
        // N cos θ3 = sqrt(N² − n2² sin² θ2), the root with a positive imaginary part.
        let n_cos3 = big_n.mul(big_n).sub(C(n2 * n2 * (1.0 - cos2 * cos2), 0.0)).sqrt();
        let delta = 4.0 * std::f64::consts::PI * n2 * d * cos2 / lambda;
        let e = C(delta.cos(), delta.sin());
        let airy = |r12: f64, r23: C| {
            let r12 = C(r12, 0.0);
            r12.add(r23.mul(e)).div(C(1.0, 0.0).add(r12.mul(r23).mul(e))).norm2()
        };
        let r12s = (cos1 - n2 * cos2) / (cos1 + n2 * cos2);
        let r12p = (n2 * cos1 - cos2) / (n2 * cos1 + cos2);
        let c2 = C(cos2, 0.0);
        let r23s = n2c.mul(c2).sub(n_cos3).div(n2c.mul(c2).add(n_cos3));
        // p: (N² cos θ2 − n2 N cos θ3) / (N² cos θ2 + n2 N cos θ3), the dielectric code's sign.
        let nn = big_n.mul(big_n).mul(c2);
        let r23p = nn.sub(n2c.mul(n_cos3)).div(nn.add(n2c.mul(n_cos3)));
        0.5 * (airy(r12s, r23s) + airy(r12p, r23p))
    }

    /// On a physical conductor (gold-like and aluminium-like indices) at normal and oblique
    /// incidence, the RGB reflectance equals the exact per-wavelength Airy reflectance with the
    /// complex Fresnel amplitudes, weighted by each channel's CMF. This fixes the phasors' and
    /// the transform's signs (a conjugate phase moves the colours by several 0.01). Bound: the
    /// truncated series' tail 2 |Rs − T121| r⁴/(1 − r) of the largest R23 over the channels,
    /// plus the table's interpolation and the quadratures, as for the dielectric.
    #[test]
    fn conductor_film_matches_the_complex_airy_sum() {
        for (n, k) in [(0.2f64, 3.0f64), (1.2, 7.0), (2.5, 3.5)] {
            for (n2, d) in [(1.8f64, 300.0f64), (1.33, 450.0), (1.5, 120.0)] {
                for cos1 in [1.0f64, 0.6] {
                    let fast = conductor_film_reflectance(
                        cos1 as f32,
                        n2 as f32,
                        d as f32,
                        Rgb::splat(n as f32),
                        Rgb::splat(k as f32),
                        None,
                    );
                    let (mut num, mut den) = ([0.0f64; 3], [0.0f64; 3]);
                    let mut lambda = 360.0;
                    while lambda < 830.0 {
                        let c = cmf_rgb(lambda);
                        let r = exact_conductor(lambda, cos1, n2, d, n, k);
                        for ch in 0..3 {
                            num[ch] += c[ch] * r;
                            den[ch] += c[ch];
                        }
                        lambda += 0.05;
                    }
                    // The series' coefficients at the worst polarisation (R12 up to that of s).
                    let cos2 = (1.0 - (1.0 - cos1 * cos1) / (n2 * n2)).sqrt();
                    let r12 = ((cos1 - n2 * cos2) / (cos1 + n2 * cos2))
                        .powi(2)
                        .max(((n2 * cos1 - cos2) / (n2 * cos1 + cos2)).powi(2));
                    // The largest over the metal's reflectance R23 (unknown here: swept).
                    let bound = (1..100)
                        .map(|i| {
                            let r23 = i as f64 / 100.0;
                            let t121 = 1.0 - r12;
                            let rs = t121 * t121 * r23 / (1.0 - r12 * r23);
                            let r = (r12 * r23).sqrt();
                            let c1 = (rs - t121).abs();
                            airy_bound(c1, r)
                        })
                        .fold(0.0f64, f64::max)
                        + 1e-4;
                    for ch in 0..3 {
                        let want = (num[ch] / den[ch]).clamp(0.0, 1.0);
                        assert!(
                            (fast[ch] as f64 - want).abs() <= bound,
                            "n={n} k={k} n2={n2} d={d} cos={cos1} channel {ch}: {} vs {want} (bound {bound:.1e})",
                            fast[ch]
                        );
                    }
                }
            }
        }
    }

    /// Gulbrandsen's index reproduces F0, and a vanishing film on Cycles' F82 conductor leaves
    /// the bare F82-tint metal (the film's index blends to air's, so the interface below it is
    /// the metal's own in air).
    #[test]
    fn f82_conductor_without_a_film_is_the_bare_metal() {
        use crate::bsdf::microfacet::{f82_tint, f82_tint_b};
        let f0 = Rgb::new(0.9, 0.6, 0.3);
        for tint in [Rgb::ONE, Rgb::new(0.5, 0.8, 1.0)] {
            let b = f82_tint_b(f0, tint);
            let (n, k, g) = f82_conductor_index(f0, b);
            let back = ((n - Rgb::ONE) * (n - Rgb::ONE) + k * k) / ((n + Rgb::ONE) * (n + Rgb::ONE) + k * k);
            assert!((back - f0).abs().max_element() < 1e-4, "{back} vs {f0}");
            for cos in [1.0f32, 0.7, 0.3, 0.1] {
                let film = conductor_film_reflectance(cos, 1.8, 0.0, n, k, Some(g));
                let bare = f82_tint(f0, b, cos);
                assert!((film - bare).abs().max_element() < 2e-4, "cos {cos}: {film} vs {bare}");
            }
        }
    }
}
