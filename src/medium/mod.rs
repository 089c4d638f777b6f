//! Participating media: homogeneous RGB media with a Henyey-Greenstein phase function,
//! chromatic free-flight sampling, the medium stack that tracks nested media along a
//! path, and the albedo inversion of random-walk subsurface scattering. Pure maths:
//! the scene-aware parts (walks through geometry, shadow rays) live in
//! `integrator::media`. Grid media (volume objects) and their tracking are in
//! `grid.rs` and `tracking.rs`, their file format in `grid_file.rs`; media whose
//! coefficients come from a node graph ride on a grid (`procedural.rs`).
//!
//! Chromatic media are sampled as Cycles and pbrt-v4 do: pick one colour channel,
//! sample a distance from that channel's exponential, and weight by the *average* of
//! the three channels' densities (one-sample MIS with the balance heuristic), so a
//! medium whose extinction differs by channel has no fireflies.

pub mod blackbody;
pub mod coefficients;
pub mod grid;
pub mod grid_file;
pub mod phase;
pub mod procedural;
pub mod procedural_source;
pub mod tracking;
pub mod volume_grids;
pub mod walk;

use crate::math::Rgb;
pub use grid::GridMedium;
pub use phase::{FournierForand, HenyeyGreenstein, Mie, Phase};
pub use tracking::Medium;

/// A homogeneous medium: coefficients per scene unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomogeneousMedium {
    /// Absorption coefficient σa.
    pub sigma_a: Rgb,
    /// Scattering coefficient σs.
    pub sigma_s: Rgb,
    /// Phase function.
    pub phase: Phase,
    /// Emitted radiance per unit length (Blender's volume emission).
    pub emission: Rgb,
}

/// What free-flight sampling chose along a segment.
#[derive(Clone, Copy, Debug)]
pub enum FreeFlight {
    /// A real scattering event at distance `t`; multiply the throughput by `weight`
    /// (σs·Tr / pdf, averaged over channels).
    Scatter {
        /// Distance along the ray.
        t: f32,
        /// Throughput factor.
        weight: Rgb,
    },
    /// No event before the segment's end; multiply the throughput by `weight` (Tr / P).
    Pass {
        /// Throughput factor.
        weight: Rgb,
    },
}

/// e^(-σ t) per channel, with 0·∞ read as 0 (no extinction means no attenuation).
#[inline]
pub fn transmittance(sigma_t: Rgb, t: f32) -> Rgb {
    let tr = |s: f32| if s > 0.0 { (-s * t).exp() } else { 1.0 };
    Rgb::new(tr(sigma_t.x), tr(sigma_t.y), tr(sigma_t.z))
}

/// Picks a colour channel with probability proportional to `weights` (uniform when
/// they are all zero); returns it and the three probabilities.
#[inline]
pub fn sample_channel(weights: Rgb, u: f32) -> (usize, Rgb) {
    let w = weights.abs();
    let sum = w.x + w.y + w.z;
    let pmf = if sum > 0.0 && sum.is_finite() { w / sum } else { Rgb::splat(1.0 / 3.0) };
    let c = if u < pmf.x {
        0
    } else if u < pmf.x + pmf.y || pmf.z == 0.0 {
        1
    } else {
        2
    };
    (c, pmf)
}

impl HomogeneousMedium {
    /// A purely absorbing medium (glTF `KHR_materials_volume`, Beer-Lambert).
    pub fn absorbing(sigma_a: Rgb) -> Self {
        HomogeneousMedium { sigma_a, sigma_s: Rgb::ZERO, phase: Phase::hg(0.0), emission: Rgb::ZERO }
    }

    /// Extinction σt = σa + σs.
    #[inline]
    pub fn sigma_t(&self) -> Rgb {
        self.sigma_a + self.sigma_s
    }

    /// True when the medium scatters light (needs free-flight sampling).
    #[inline]
    pub fn scatters(&self) -> bool {
        self.sigma_s.max_element() > 0.0
    }

    /// True when the medium attenuates light at all.
    #[inline]
    pub fn attenuates(&self) -> bool {
        self.sigma_t().max_element() > 0.0
    }

    /// Transmittance over distance `t` (0 over an infinite distance where σt > 0).
    #[inline]
    pub fn transmittance(&self, t: f32) -> Rgb {
        transmittance(self.sigma_t(), t)
    }

    /// Emitted radiance collected along a segment of length `t`:
    /// ∫₀ᵗ Tr(s) E ds = E (1 - e^(-σt t)) / σt per channel (E t where σt = 0).
    #[inline]
    pub fn emitted(&self, t: f32) -> Rgb {
        if self.emission == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let st = self.sigma_t();
        let one = |s: f32, e: f32| {
            if e == 0.0 {
                0.0
            } else if s * t > 1e-4 {
                e * (1.0 - (-s * t).exp()) / s
            } else {
                // Series of (1 - e^-x)/x, exact to f32 for x ≤ 1e-4.
                e * t * (1.0 - 0.5 * s * t)
            }
        };
        Rgb::new(one(st.x, self.emission.x), one(st.y, self.emission.y), one(st.z, self.emission.z))
    }

    /// The throughput factor `sample_free_flight` gives a path that passes distance `t`
    /// without an event (Tr / P(pass), 1 for a grey medium), for emitters crossed on the way.
    #[inline]
    pub fn pass_weight(&self, t: f32, beta: Rgb) -> Rgb {
        let sigma_t = self.sigma_t();
        let tr = transmittance(sigma_t, t);
        if !self.scatters() {
            return tr;
        }
        let (_, pmf) = sample_channel(beta * self.albedo(), 0.0);
        let p = (pmf * tr).element_sum();
        if p > 0.0 { tr / p } else { Rgb::ZERO }
    }

    /// Single-scattering albedo σs / σt (0 where σt = 0).
    #[inline]
    pub fn albedo(&self) -> Rgb {
        let st = self.sigma_t();
        let a = |s: f32, t: f32| if t > 0.0 { s / t } else { 0.0 };
        Rgb::new(a(self.sigma_s.x, st.x), a(self.sigma_s.y, st.y), a(self.sigma_s.z, st.z))
    }

    /// Samples where the next interaction happens along a segment of length `t_max`
    /// (may be infinite) for a path of throughput `beta`. The channel is chosen in
    /// proportion to throughput × single-scattering albedo (as Cycles'
    /// `volume_sample_channel`); `u_channel` picks it, `u_dist` the distance.
    #[inline]
    pub fn sample_free_flight(&self, t_max: f32, beta: Rgb, u_channel: f32, u_dist: f32) -> FreeFlight {
        let sigma_t = self.sigma_t();
        if !self.scatters() {
            // Pure absorption: no event to sample, the transmittance is exact.
            return FreeFlight::Pass { weight: transmittance(sigma_t, t_max) };
        }
        let (c, pmf) = sample_channel(beta * self.albedo(), u_channel);
        let s = sigma_t[c];
        let t = if s > 0.0 { -(1.0 - u_dist).ln() / s } else { f32::INFINITY };
        if t < t_max {
            let tr = transmittance(sigma_t, t);
            let pdf = (pmf * sigma_t * tr).element_sum();
            let weight = if pdf > 0.0 { self.sigma_s * tr / pdf } else { Rgb::ZERO };
            FreeFlight::Scatter { t, weight }
        } else {
            let tr = transmittance(sigma_t, t_max);
            let p = (pmf * tr).element_sum();
            FreeFlight::Pass { weight: if p > 0.0 { tr / p } else { Rgb::ZERO } }
        }
    }
}

/// Media a path is inside, innermost (most recently entered) last. Fixed size, so a
/// path state never allocates. Rule for nested and overlapping media: the medium in
/// effect is the one entered last and not yet left; leaving removes the most recent
/// entry of that medium (leaving one never entered changes nothing); entering a fifth
/// drops the outermost. Paths start in vacuum (the camera is outside every medium).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MediumStack {
    ids: [u32; MediumStack::CAPACITY],
    len: u8,
}

impl MediumStack {
    /// Deepest nesting tracked.
    pub const CAPACITY: usize = 4;

    /// The medium in effect (a material index), if any.
    #[inline]
    pub fn current(&self) -> Option<u32> {
        (self.len > 0).then(|| self.ids[self.len as usize - 1])
    }

    /// Enters the medium of material `id`.
    #[inline]
    pub fn enter(&mut self, id: u32) {
        if self.len as usize == Self::CAPACITY {
            self.ids.copy_within(1.., 0);
            self.len -= 1;
        }
        self.ids[self.len as usize] = id;
        self.len += 1;
    }

    /// Leaves the medium of material `id`.
    #[inline]
    pub fn leave(&mut self, id: u32) {
        let n = self.len as usize;
        if let Some(i) = self.ids[..n].iter().rposition(|&m| m == id) {
            self.ids.copy_within(i + 1..n, i);
            self.len -= 1;
        }
    }
}

/// Random numbers for a walk of unbounded length (a subsurface random walk), seeded
/// from one sample dimension so that the pixel sampler's dimensions stay aligned
/// (splitmix64).
pub struct WalkRng(u64);

impl WalkRng {
    /// A generator seeded from a sample value and a salt.
    pub fn new(u: f32, salt: u32) -> Self {
        WalkRng(((u.to_bits() as u64) << 32 | salt as u64) ^ 0x9e37_79b9_7f4a_7c15)
    }

    /// Uniform in [0, 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 40) as f32 * (1.0 / 16_777_216.0)
    }
}

/// Single-scattering albedo α that gives a semi-infinite medium of anisotropy `g`,
/// entered and left diffusely, the multiple-scattering albedo `a` (the colour an
/// artist sets). Chiang, Kutz & Burley, "Practical and Controllable Subsurface
/// Scattering for Production Path Tracing" (SIGGRAPH 2016 talk), extended to
/// anisotropy by a degree-7 fit in g of each of its six coefficients; these are the
/// coefficients Cycles uses (`subsurface_random_walk_remap`), so the same colour gives
/// the same medium as in Blender.
pub fn single_scattering_albedo(a: f32, g: f32) -> f32 {
    AlbedoFit::new(g).alpha(a)
}

/// [`single_scattering_albedo`]'s six coefficients at one anisotropy g: a walk medium
/// fits its three channels with one set (callgrind on the subsurface bench scene: the
/// polynomials and their two exponentials, per channel, were a third of the fit's cost).
struct AlbedoFit {
    a: f32,
    b: f32,
    c: f32,
    d: f32,
    e: f32,
    f: f32,
}

impl AlbedoFit {
    // The fit's coefficients as published, all their digits.
    #[allow(clippy::excessive_precision, clippy::unreadable_literal)]
    fn new(g: f32) -> Self {
        // Polynomial in g, lowest degree first.
        let poly = |c: &[f32; 8]| c.iter().rev().fold(0.0f32, |acc, &k| acc * g + k);
        const A: [f32; 8] = [
            1.8260523782,
            -1.28451056436,
            -1.79904629312,
            9.19393289202,
            -22.8215585862,
            32.0234874259,
            -23.6264803333,
            7.21067002658,
        ];
        const B_EXP: [f32; 8] = [
            0.0,
            31.1491581433,
            -201.847017512,
            841.576016723,
            -2018.09288505,
            2731.71560286,
            -1935.41424244,
            559.009054474,
        ];
        const C: [f32; 8] = [
            1.09686102424,
            -0.394704063468,
            1.05258115941,
            -8.83963712726,
            28.8643230661,
            -46.8802913581,
            38.5402837518,
            -12.7181042538,
        ];
        const D: [f32; 8] = [
            0.496310210422,
            0.360146581622,
            -2.15139309747,
            17.8896899217,
            -55.2984010333,
            82.065982243,
            -58.5106008578,
            15.8478295021,
        ];
        const E_EXP: [f32; 8] = [
            0.0,
            76.7316253952,
            -594.356773233,
            2448.8834203,
            -5576.68528998,
            7116.60171912,
            -4763.54467887,
            1303.5318055,
        ];
        const F: [f32; 8] = [
            2.40602999408,
            -2.51814844609,
            9.18494908356,
            -79.2191708682,
            259.082868209,
            -403.613804597,
            302.85712436,
            -87.4370473567,
        ];
        let b = 4.98511194385 + 0.127355959438 * poly(&B_EXP).exp();
        let e = 4.23190299701 + 0.00310603949088 * poly(&E_EXP).exp();
        AlbedoFit { a: poly(&A), b, c: poly(&C), d: poly(&D), e, f: poly(&F) }
    }

    /// α for the multiple-scattering albedo `a`.
    fn alpha(&self, a: f32) -> f32 {
        let blend = a.max(0.0).powf(0.25);
        let alpha = (1.0 - blend) * self.a * (self.b * a).atan().powf(self.c)
            + blend * self.d * (self.e * a).atan().powf(self.f);
        alpha.clamp(0.0, 0.999_999)
    }
}

/// Lowest single-scattering albedo used by a walk: below it (colours darker than about
/// 0.025) Cycles raises α to this and lowers the throughput by α / 0.2 instead, which
/// keeps the walk short; the same rule here.
pub const MIN_WALK_ALBEDO: f32 = 0.2;

/// A random walk's medium: extinction, single-scattering albedo and the throughput
/// factor from [`MIN_WALK_ALBEDO`], for mean free paths `mfp` (per channel, scene
/// units) and multiple-scattering albedo `albedo`.
#[derive(Clone, Copy, Debug)]
pub struct WalkMedium {
    /// Extinction σt = 1 / (mfp (1 - g)).
    pub sigma_t: Rgb,
    /// Single-scattering albedo α.
    pub alpha: Rgb,
    /// Factor on the throughput at entry.
    pub scale: Rgb,
    /// Phase function.
    pub phase: HenyeyGreenstein,
}

impl WalkMedium {
    /// The walk medium for a subsurface material (anisotropy clamped to [0, 0.9] as Cycles does).
    pub fn new(albedo: Rgb, mfp: Rgb, anisotropy: f32) -> Self {
        let g = anisotropy.clamp(0.0, 0.9);
        let mut alpha = Rgb::ZERO;
        let mut sigma_t = Rgb::ZERO;
        let mut scale = Rgb::ONE;
        let fit = AlbedoFit::new(g);
        for c in 0..3 {
            let a = fit.alpha(albedo[c].clamp(0.0, 1.0));
            sigma_t[c] = 1.0 / (mfp[c].max(1e-16) * (1.0 - g));
            if a < MIN_WALK_ALBEDO {
                scale[c] = a / MIN_WALK_ALBEDO;
                alpha[c] = MIN_WALK_ALBEDO;
            } else {
                alpha[c] = a;
            }
        }
        WalkMedium { sigma_t, alpha, scale, phase: HenyeyGreenstein::new(g) }
    }
}

/// Jensen's dipole diffuse reflectance for reduced albedo α' and boundary term
/// A = (1 + F_dr)/(1 - F_dr) (times 4/3): Cycles' `bssrdf_dipole_compute_Rd`.
fn dipole_rd(alpha_prime: f32, four_thirds_a: f32) -> f32 {
    let s = (3.0 * (1.0 - alpha_prime)).sqrt();
    0.5 * alpha_prime * (1.0 + (-four_thirds_a * s).exp()) * (-s).exp()
}

/// Mean free path of Blender's "Random Walk (Skin)" method: the radius scaled by
/// √(3(1 - α')), α' the reduced albedo whose dipole reflectance is the colour
/// (bisection, as Cycles' `bssrdf_setup_radius`).
pub fn skin_mean_free_path(radius: f32, albedo: f32, ior: f32) -> f32 {
    let eta = ior.clamp(1.01, 3.8);
    let inv = 1.0 / eta;
    let f_dr = inv * (-1.440 * inv + 0.710) + 0.668 + 0.0636 * eta;
    let four_thirds_a = 4.0 / 3.0 * (1.0 + f_dr) / (1.0 - f_dr);
    let alpha_prime = if albedo < 1e-4 {
        0.0
    } else if albedo >= 0.995 {
        0.999_999
    } else {
        let (mut lo, mut hi) = (0.0f32, 1.0f32);
        for _ in 0..20 {
            let mid = 0.5 * (lo + hi);
            if dipole_rd(mid, four_thirds_a) < albedo {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    };
    radius * (3.0 * (1.0 - alpha_prime)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stack_rule() {
        let mut s = MediumStack::default();
        assert_eq!(s.current(), None);
        s.enter(3);
        s.enter(5);
        assert_eq!(s.current(), Some(5));
        // Leaving the outer medium while inside the inner one (overlap) keeps the inner.
        s.leave(3);
        assert_eq!(s.current(), Some(5));
        s.leave(5);
        assert_eq!(s.current(), None);
        s.leave(7);
        assert_eq!(s.current(), None);
        for i in 0..6 {
            s.enter(i);
        }
        assert_eq!(s.current(), Some(5));
        for i in (2..6).rev() {
            s.leave(i);
        }
        assert_eq!(s.current(), None, "the two outermost were dropped on overflow");
    }

    /// Free-flight weights are unbiased: E[w_pass·1{pass}] = Tr(t_max) and E[w_scatter·1{scatter}] = ∫₀^t_max σs Tr dt = σs/σt (1 - Tr), per
    /// channel, for a chromatic medium. 10⁶ stratified samples; the bound 1e-3 is
    /// many standard errors (weights are bounded by max σ ratio ≈ 10).
    #[test]
    fn free_flight_expectations() {
        let m = HomogeneousMedium {
            sigma_a: Rgb::new(0.1, 0.5, 2.0),
            sigma_s: Rgb::new(1.0, 0.3, 0.2),
            phase: Phase::hg(0.0),
            emission: Rgb::ZERO,
        };
        let t_max = 1.3;
        let beta = Rgb::new(1.0, 0.5, 0.25);
        let n = 1_000_000;
        let (mut pass, mut scatter) = (Rgb::ZERO.as_dvec3(), Rgb::ZERO.as_dvec3());
        let mut rng = WalkRng::new(0.5, 1);
        for i in 0..n {
            let u = (i as f32 + rng.next_f32()) / n as f32;
            match m.sample_free_flight(t_max, beta, rng.next_f32(), u) {
                FreeFlight::Pass { weight } => pass += weight.as_dvec3(),
                FreeFlight::Scatter { weight, .. } => scatter += weight.as_dvec3(),
            }
        }
        let st = m.sigma_t();
        for c in 0..3 {
            let tr = (-(st[c] as f64) * t_max as f64).exp();
            let p = pass[c] / n as f64;
            let s = scatter[c] / n as f64;
            let s_expect = m.sigma_s[c] as f64 / st[c] as f64 * (1.0 - tr);
            assert!((p - tr).abs() < 1e-3, "channel {c}: pass {p} vs {tr}");
            assert!((s - s_expect).abs() < 1e-3, "channel {c}: scatter {s} vs {s_expect}");
        }
    }

    /// The albedo fit is increasing and maps 0 → 0 and 1 → ~1 (its accuracy is tested
    /// end to end by the semi-infinite slab in `integrator::media`).
    #[test]
    fn albedo_inversion_shape() {
        assert!(single_scattering_albedo(0.0, 0.0) < 1e-3);
        assert!(single_scattering_albedo(1.0, 0.0) > 0.99);
        let mut prev = 0.0;
        for i in 1..=100 {
            let a = single_scattering_albedo(i as f32 / 100.0, 0.0);
            assert!(a >= prev, "not monotonic at {i}");
            prev = a;
        }
    }

    #[test]
    fn emission_integral() {
        let m = HomogeneousMedium {
            sigma_a: Rgb::new(0.0, 1.0, 1e-7),
            sigma_s: Rgb::ZERO,
            phase: Phase::hg(0.0),
            emission: Rgb::ONE,
        };
        let e = m.emitted(2.0);
        assert!((e.x - 2.0).abs() < 1e-6);
        assert!((e.y - (1.0 - (-2.0f32).exp())).abs() < 1e-6);
        assert!((e.z - 2.0).abs() < 1e-5);
    }
}
