//! The random walk of subsurface scattering (Chiang et al. 2016, as Cycles' "Random
//! Walk"): free flights inside a mesh until the walk crosses its surface, steered by
//! Dwivedi's guide as Cycles' walk is. The scene is seen only through the `intersect`
//! closure it is given.

use super::{HenyeyGreenstein, WalkMedium, WalkRng};
use crate::accel::Hit;
use crate::math::Frame;
use crate::math::Rgb;
use glam::{Vec2, Vec3, Vec3A};

/// A walk whose throughput falls below this ends (Cycles' VOLUME_THROUGHPUT_EPSILON).
const WALK_THROUGHPUT_EPSILON: f32 = 1e-6;

/// After this many steps the walk uses the similarity relation (isotropic phase,
/// reduced scattering σs(1 - g)), as Cycles does: far from the entry the anisotropy
/// no longer matters and isotropic steps are longer.
const SIMILARITY_STEP: u32 = 9;

/// Steps of a subsurface random walk before it is abandoned (Cycles' BSSRDF_MAX_BOUNCES):
/// such a path ends and its energy is lost; with albedo α < 1 per step the lost part
/// is below α^256 of the walk's weight.
pub const MAX_WALK_STEPS: u32 = 256;

/// Where a random walk left the medium: the hit, the ray that found it, and the
/// walk's throughput factor.
pub struct WalkExit {
    /// The surface hit.
    pub hit: Hit,
    /// Origin of the last step.
    pub org: Vec3,
    /// Direction of the last step.
    pub dir: Vec3,
    /// Throughput of the walk (entry scale included).
    pub weight: Rgb,
}

/// A subsurface random walk (Chiang et al. 2016, as Cycles' "Random Walk") from
/// `org` inside a mesh along `dir`, in the homogeneous medium `m`, until it crosses a
/// surface. Free flights pick a channel in proportion to throughput × albedo and
/// weight by the channels' average density, as `HomogeneousMedium::sample_free_flight`.
/// After the first step, directions and distances are drawn as Cycles draws them: from
/// the phase function or from Dwivedi's guide toward the entry surface (or, where the
/// first step found the far side near, toward that side), every strategy and channel
/// weighed by the balance heuristic ([`Guide`]). `entry` is the surface point the walk
/// entered at, `n` its outward shading normal. `beta` is the path throughput before the
/// walk (for the channel choice). Returns None when the walk is abandoned (too many
/// steps, negligible throughput).
///
/// `clearance(p, cap)` is a radius (at most `cap`) around p that no surface `intersect`
/// could return comes within (0 when unknown): a step that starts and ends inside such a
/// ball crosses no surface, so its query is skipped — the same answer, so the walk is
/// the same bit for bit.
#[allow(clippy::too_many_arguments)]
pub fn random_walk(
    intersect: impl Fn(Vec3, Vec3, f32) -> Option<Hit>,
    mut clearance: impl FnMut(Vec3, f32) -> f32,
    entry: Vec3,
    n: Vec3,
    mut org: Vec3,
    mut dir: Vec3,
    m: &WalkMedium,
    beta: Rgb,
    rng: &mut WalkRng,
) -> Option<WalkExit> {
    // The colour sums in SSE lanes (Vec3A): the same IEEE operations lane by lane as
    // the scalar `Rgb` (products, quotients, `element_sum` as (x + y) + z, `max_element`
    // as `a > b ? a : b`), so the same bits; callgrind: scalar colour arithmetic was
    // about a fifth of a walk step's own instructions.
    let (alpha, sigma_t0) = (Vec3A::from(m.alpha), Vec3A::from(m.sigma_t));
    let beta = Vec3A::from(beta);
    let mut throughput = Vec3A::from(m.scale);
    let sigma_s0 = sigma_t0 * alpha;
    let g = m.phase.g;
    let similar_s = sigma_s0 * (1.0 - g);
    let similar_t = sigma_t0 - sigma_s0 + similar_s;
    let isotropic = HenyeyGreenstein::new(0.0);
    let guide = Guide::new(m.alpha.max_element(), entry, n)?;
    // Cycles' share of guided steps: half in an isotropic medium, less the more
    // anisotropic it is (its guide ignores the phase function's lobe).
    let guided_share = 1.0 - g.abs().powf(0.125).max(0.5);
    // The far side of the object along the entry direction, as a distance below the
    // entry's tangent plane, when the first step's longer query found one.
    let mut opposite: Option<f32> = None;
    // The ball free of surfaces (centre, radius) the walk last asked for; none at first.
    // A ball is sought only where it can reach `need`, the longest mean free path times
    // BALL_FREE_PATHS (a smaller one holds too few steps to pay for its search). The
    // distance to the nearest surface changes by at most the distance moved, so a point x
    // is about r + |x - c| from one at most (r is the centre's distance less a margin, or
    // the cap): below `need`, no search there. This only decides where to search.
    let need = BALL_FREE_PATHS / sigma_t_floor(m.sigma_t.min(Rgb::from(similar_t)));
    let mut ball = (org, 0.0f32);
    let inside = |ball: (Vec3, f32), p: Vec3| (p - ball.0).length_squared() <= ball.1 * ball.1;
    for step in 0..MAX_WALK_STEPS {
        let (sigma_t, sigma_s, phase, share) = if step <= SIMILARITY_STEP {
            (sigma_t0, sigma_s0, m.phase, guided_share)
        } else {
            // Cycles' share for the isotropic phase of the similarity relation.
            (similar_t, similar_s, isotropic, 0.75)
        };
        let (c, pmf) = sample_channel3(beta * throughput * alpha, rng.next_f32());
        let u_t = rng.next_f32();
        // The first step keeps the entry direction and classic distances; after it the
        // direction and the distance's stretch come from the strategy drawn.
        let mut step_pdf = None;
        let mut sample_sigma = sigma_t[c];
        if step > 0 {
            let u = [rng.next_f32(), rng.next_f32(), rng.next_f32(), rng.next_f32()];
            let s = guide.step(dir, org, opposite, phase, share, u);
            dir = s.dir;
            sample_sigma *= s.stretch;
            step_pdf = Some(s);
        }
        let t = -(1.0 - u_t).ln() / sample_sigma;
        let end = org + dir * t;
        let clear = ball.1 > 0.0 && inside(ball, org) && inside(ball, end);
        // The first query looks ten mean free paths ahead (at least) for the far side,
        // as Cycles does; a hit beyond t only tells where that side is.
        let reach = if step == 0 { t.max(10.0 / sigma_t.min_element()) } else { t };
        let found = if clear { None } else { intersect(org, dir, reach) };
        if step == 0
            && let Some(h) = &found
        {
            opposite = Some((org + dir * h.t - entry).dot(-n));
        }
        let exit = found.filter(|h| step > 0 || h.t < t);
        let t = exit.as_ref().map_or(t, |h| h.t);
        let tr = transmittance3(sigma_t, t);
        let leaves = exit.is_some();
        let mut pdf = if leaves { tr } else { sigma_t * tr };
        if let Some(s) = &step_pdf {
            pdf = s.mixed_pdf(pdf, sigma_t, t, leaves);
        }
        let p = (pmf * pdf).element_sum();
        if !(p > 0.0) {
            return None;
        }
        if let Some(hit) = exit {
            throughput *= tr / p;
            return Some(WalkExit { hit, org, dir, weight: throughput.into() });
        }
        throughput *= sigma_s * tr / p;
        if !(throughput.max_element() >= WALK_THROUGHPUT_EPSILON) {
            return None;
        }
        org = end;
        if !clear && ball.1 + (org - ball.0).length() >= need {
            ball = (org, clearance(org, BALL_CAP * need));
        }
    }
    None
}

/// Dwivedi's guided sampling of a walk's steps (Křivánek & d'Eon 2014, with Meng et al.
/// 2016's phase function and d'Eon & Křivánek 2020's diffusion length and two-sided
/// choice), as Cycles combines it with the classic walk: a guided direction's cosine μ
/// to the entry normal has density 1 / ((v - μ) ln((v+1)/(v-1))), and its distance is
/// drawn with σt stretched by (1 - μ/v), so walks head back to the surface they
/// entered. Light leaves a subsurface object only across its surface, so the walk's
/// variance and length fall (2-4× fewer steps in `bench/walk_steps.py`'s half-space).
/// Every step's density is the balance-heuristic mixture of the classic, forward and
/// backward strategies over the three channels: the estimate stays unbiased.
struct Guide {
    /// Diffusion length v (> 1, in mean free paths).
    v: f32,
    /// ln((v + 1) / (v - 1)), the guide's normalisation.
    log: f32,
    /// Where the walk entered.
    entry: Vec3,
    /// The frame about the entry's outward normal.
    frame: Frame,
}

/// A step's direction and what its density needs once the step's end is known.
struct GuidedStep {
    /// The new direction.
    dir: Vec3,
    /// The factor on σt of the drawn strategy's distance sampling.
    stretch: f32,
    /// The share of guided steps.
    share: f32,
    /// The share of guided steps that head for the far side.
    backward: f32,
    /// Stretch of the forward and backward guides' distances.
    stretches: (f32, f32),
    /// Forward and backward guides' direction densities over the phase function's.
    ratios: (f32, f32),
}

impl Guide {
    /// The guide for a walk whose largest single-scattering albedo is `alpha_max`; None
    /// where its diffusion length is 1 (α near 0, never reached above
    /// [`MIN_WALK_ALBEDO`](super::MIN_WALK_ALBEDO)), where Cycles ends the walk too.
    fn new(alpha_max: f32, entry: Vec3, n: Vec3) -> Option<Self> {
        // d'Eon & Křivánek 2020, eq. 67: the asymptotic diffusion length's fit.
        let a = alpha_max.clamp(1e-6, 0.999_999);
        let v = 1.0 / (1.0 - a.powf(2.44294 - 0.0215813 * a + 0.578637 / a)).sqrt();
        let log = ((v + 1.0) / (v - 1.0)).ln();
        (v > 1.0 && v.is_finite() && log.is_finite()).then(|| Guide { v, log, entry, frame: Frame::from_normal(n) })
    }

    /// Density of the forward guide over the cosine μ to the normal (on [-1, 1]).
    #[inline]
    fn pdf_cos(&self, mu: f32) -> f32 {
        1.0 / ((self.v - mu) * self.log)
    }

    /// The forward guide's cosine for a uniform `u` (its inverse CDF).
    #[inline]
    fn sample_cos(&self, u: f32) -> f32 {
        self.v - (self.v + 1.0) * (-u * self.log).exp()
    }

    /// Draws the direction of a step from `org` for a ray travelling along `dir`: with
    /// probability `share` from the guide (toward the far side, at `opposite` below the
    /// entry plane, with Cycles' logistic share by depth), else from `phase`. `u[0]` and
    /// `u[1]` pick the strategies, `u[2]` and `u[3]` the direction.
    #[inline]
    fn step(
        &self,
        dir: Vec3,
        org: Vec3,
        opposite: Option<f32>,
        phase: HenyeyGreenstein,
        share: f32,
        u: [f32; 4],
    ) -> GuidedStep {
        let backward = opposite.map_or(0.0, |d| {
            // Cycles' clamp (min of max): a far side found above the entry plane (d < 0)
            // gives d, not a panic.
            let depth = (org - self.entry).dot(-self.frame.n).max(0.0).min(d);
            1.0 / (1.0 + ((d - 2.0 * depth) / self.v).exp())
        });
        let guided = u[0] < share;
        let to_far_side = guided && u[1] < backward;
        let uv = Vec2::new(u[2], u[3]);
        let (new_dir, mu, phase_pdf) = if guided {
            let mu = self.sample_cos(uv.x);
            let mu = if to_far_side { -mu } else { mu };
            let sin = (1.0 - mu * mu).max(0.0).sqrt();
            let phi = std::f32::consts::TAU * uv.y;
            let d = self.frame.to_world(Vec3::new(sin * phi.cos(), sin * phi.sin(), mu));
            (d, mu, phase.eval(dir, d))
        } else {
            let (d, pdf) = phase.sample(dir, uv);
            (d, d.dot(self.frame.n), pdf)
        };
        let per_azimuth = std::f32::consts::FRAC_1_PI * 0.5 / phase_pdf;
        let stretches = (1.0 - mu / self.v, 1.0 + mu / self.v);
        let stretch = match (guided, to_far_side) {
            (false, _) => 1.0,
            (true, false) => stretches.0,
            (true, true) => stretches.1,
        };
        GuidedStep {
            dir: new_dir,
            stretch,
            share,
            backward,
            stretches,
            ratios: (self.pdf_cos(mu) * per_azimuth, self.pdf_cos(-mu) * per_azimuth),
        }
    }
}

impl GuidedStep {
    /// The step's density per channel, mixed over the three strategies, relative to
    /// the phase function's (which cancels against its value): `classic` is the
    /// classic distance density (σt T, or T for a step that leaves, `leaves`).
    #[inline]
    fn mixed_pdf(&self, classic: Vec3A, sigma_t: Vec3A, t: f32, leaves: bool) -> Vec3A {
        let distance = |stretch: f32| {
            let s = sigma_t * stretch;
            let tr = transmittance3(s, t);
            if leaves { tr } else { s * tr }
        };
        let forward = distance(self.stretches.0) * self.ratios.0;
        let guided = if self.backward > 0.0 {
            let back = distance(self.stretches.1) * self.ratios.1;
            forward + (back - forward) * self.backward
        } else {
            forward
        };
        classic + (guided - classic) * self.share
    }
}

/// [`sample_channel`](super::sample_channel) in SSE lanes, the same choice and
/// probabilities bit for bit (the sum taken x + y + z as there).
#[inline]
fn sample_channel3(weights: Vec3A, u: f32) -> (usize, Vec3A) {
    let w = weights.abs();
    let sum = w.x + w.y + w.z;
    let pmf = if sum > 0.0 && sum.is_finite() { w / sum } else { Vec3A::splat(1.0 / 3.0) };
    let c = if u < pmf.x {
        0
    } else if u < pmf.x + pmf.y || pmf.z == 0.0 {
        1
    } else {
        2
    };
    (c, pmf)
}

/// A ball free of surfaces is sought only where it can be at least this many of the
/// medium's longest mean free paths ℓ wide. A walk from its centre takes about
/// (r / ℓ)² / 2 steps inside (a 3-D walk of exponential steps moves 2ℓ² in squared
/// distance per step) against one search costing about four closest-hit queries
/// (callgrind). Measured on the subsurface bench scene (instructions of a 4 spp render,
/// 0.5 to 3 tried): flat from 1 to 2, lowest at 1.
const BALL_FREE_PATHS: f32 = 1.0;

/// The largest ball sought, in units of the smallest useful one (`BALL_FREE_PATHS`): a
/// walk takes ~8 steps to leave a ball of 4ℓ, about a quarter of its average length on
/// the subsurface bench scene, and the search's cost grows with the radius (2 to 8
/// tried: flat from 2.5 to 4).
const BALL_CAP: f32 = 4.0;

/// The smallest extinction coefficient, or 0 (an infinite `need`: no ball is ever
/// sought) when a channel has none: that channel's free flights are unbounded.
#[inline]
fn sigma_t_floor(sigma_t: Rgb) -> f32 {
    let s = sigma_t.min_element();
    if s > 0.0 { s } else { 0.0 }
}

/// Below this exponent e^x is under f32's smallest normal (2^-126 = e^-87.34): the
/// lanes there are flushed to 0, where libm would return a denormal. A walk's
/// sampled channel has σt = -ln(1 - u) ≤ 16.7 (u < 1 in f32), so a flushed lane is
/// one whose share of the sums it enters is below 2^-126 / 2^-24, lost in rounding.
const EXP_MIN_X: f32 = -87.33;

/// e^(-σt t) per channel (1 where σt ≤ 0), as `super::transmittance`, but the three
/// exponentials in one vector pass instead of three libm calls per walk step.
#[inline]
fn transmittance3(sigma_t: Vec3A, t: f32) -> Vec3A {
    let e = exp3(-sigma_t * t);
    Vec3A::select(sigma_t.cmpgt(Vec3A::ZERO), e, Vec3A::ONE)
}

/// e^x per lane for x ≤ 0 (the walk's exponents; larger x is clamped to 0): x =
/// n ln 2 + r with |r| ≤ ln 2 / 2, e^r by its Taylor series to r^7 (the dropped
/// term is below r^8 / 8! = 5.3e-9, under half an f32 ulp of 1), scaled by 2^n
/// through the exponent bits. ln 2 is split in a part exact in 9 bits and the rest,
/// so n ln 2 is subtracted without rounding for |n| ≤ 126. Within 2 ulp of libm's
/// expf (the Horner steps' rounding; tested below).
#[inline]
fn exp3(x: Vec3A) -> Vec3A {
    const LN2_HI: f32 = 355.0 / 512.0; // exact in 9 bits
    const LN2_LO: f32 = -2.121_944_4e-4; // ln 2 - LN2_HI
    let xc = x.clamp(Vec3A::splat(EXP_MIN_X), Vec3A::ZERO);
    let n = (xc * std::f32::consts::LOG2_E + 0.5).floor();
    let r = xc - n * LN2_HI - n * LN2_LO;
    let mut p = Vec3A::splat(1.0 / 5040.0);
    for c in [1.0 / 720.0, 1.0 / 120.0, 1.0 / 24.0, 1.0 / 6.0, 0.5, 1.0, 1.0] {
        p = p * r + Vec3A::splat(c);
    }
    Vec3A::select(x.cmplt(Vec3A::splat(EXP_MIN_X)), Vec3A::ZERO, p * pow2(n))
}

/// 2^n per lane for integral n in [-126, 0], from its exponent bits. On x86-64 the
/// three lanes in one SSE2 conversion: Rust's saturating `as i32` took ~22
/// instructions a lane (callgrind: 2.2 % of the walk's own work). The same bits.
#[inline]
fn pow2(n: Vec3A) -> Vec3A {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{
            __m128, _mm_add_epi32, _mm_castsi128_ps, _mm_cvttps_epi32, _mm_set1_epi32, _mm_slli_epi32,
        };
        let v: __m128 = n.into();
        // SAFETY: SSE2 is part of x86-64; the lanes are integers in [-126, 0], so the
        // truncating conversion is exact and the biased exponent lies in [1, 127].
        let bits = unsafe { _mm_slli_epi32::<23>(_mm_add_epi32(_mm_cvttps_epi32(v), _mm_set1_epi32(127))) };
        Vec3A::from(unsafe { _mm_castsi128_ps(bits) })
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let lane = |n: f32| f32::from_bits(((n as i32 + 127) as u32) << 23);
        Vec3A::new(lane(n.x), lane(n.y), lane(n.z))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{ChiSquareTest, assert_chi2};

    /// The step's directions are drawn from the density its weights assume: the phase
    /// function and the forward and backward guides mixed by their shares (chi-square
    /// over the sphere, and the sampler's density against that mixture written out
    /// anew), isotropic and anisotropic, with and without a far side, for a ray
    /// travelling across the entry normal.
    #[test]
    fn guided_directions_chi2() {
        let n = Vec3::new(0.2, -0.3, 0.93).normalize();
        let dir = Vec3::new(0.6, 0.5, -0.2).normalize();
        let org = -n * 0.7 + Vec3::new(0.1, 0.2, 0.0);
        for (alpha, g, opposite) in [(0.95f32, 0.0f32, None), (0.6, 0.5, Some(1.5f32)), (0.99, 0.0, Some(0.4))] {
            let guide = Guide::new(alpha, Vec3::ZERO, n).unwrap();
            let phase = HenyeyGreenstein::new(g);
            let share = 1.0 - g.abs().powf(0.125).max(0.5);
            let backward = opposite.map_or(0.0, |d: f32| {
                let depth = org.dot(-n).max(0.0).min(d);
                1.0 / (1.0 + ((d - 2.0 * depth) / guide.v).exp())
            });
            let density = |w: Vec3| {
                let mu = w.dot(n);
                let dw = |m: f32| 1.0 / ((guide.v - m) * ((guide.v + 1.0) / (guide.v - 1.0)).ln());
                (1.0 - share) * phase.eval(dir, w)
                    + share * ((1.0 - backward) * dw(mu) + backward * dw(-mu)) / std::f32::consts::TAU
            };
            let mut rng = WalkRng::new(0.25, 7);
            let r = ChiSquareTest::new(&format!("guided walk α={alpha} g={g} far side {opposite:?}")).run_with_pdf(
                |u| {
                    let s = guide.step(dir, org, opposite, phase, share, [rng.next_f32(), rng.next_f32(), u.x, u.y]);
                    let ratio = (1.0 - s.share) + s.share * ((1.0 - s.backward) * s.ratios.0 + s.backward * s.ratios.1);
                    Some((s.dir, phase.eval(dir, s.dir) * ratio))
                },
                density,
            );
            assert_chi2(r);
        }
    }

    /// Reflectance and transmittance of a slab two mean free paths thick, entered
    /// normally at its top: the guided walk (which finds the bottom on its first step
    /// and guides toward it too) against an analog walk of the same medium written out
    /// here (weight α per scattering). Both are unbiased, so their means differ by
    /// noise alone: at most 5 standard errors of the difference.
    #[test]
    fn guided_walk_matches_analog_walk_in_a_slab() {
        let depth = 2.0f32;
        let m = WalkMedium::new(Rgb::splat(0.8), Rgb::ONE, 0.0);
        let (sigma_t, alpha) = (m.sigma_t.x, m.alpha.x);
        // The slab's planes z = 0 (triangle 0) and z = -depth (triangle 1).
        let slab = |o: Vec3, d: Vec3, t_max: f32| {
            let (tri, t) = if d.z > 0.0 {
                (0, -o.z / d.z)
            } else if d.z < 0.0 {
                (1, (-depth - o.z) / d.z)
            } else {
                return None;
            };
            (t >= 0.0 && t <= t_max).then_some(Hit { tri, t, b1: 0.0, b2: 0.0 })
        };
        let n_walks = 200_000;
        let org = Vec3::new(0.0, 0.0, -1e-5);
        let mut sums = [[0.0f64; 2]; 2]; // [guided, analog] × [sum, sum of squares], reflected
        let mut trans = [[0.0f64; 2]; 2];
        let mut rng = WalkRng::new(0.5, 3);
        let phase = HenyeyGreenstein::new(0.0);
        for _ in 0..n_walks {
            let guided = random_walk(slab, |_, _| 0.0, Vec3::ZERO, Vec3::Z, org, -Vec3::Z, &m, Rgb::ONE, &mut rng);
            let (mut r, mut t) = (0.0, 0.0);
            if let Some(e) = guided {
                let w = e.weight.x as f64;
                if e.hit.tri == 0 { r = w } else { t = w }
            }
            let (mut o, mut d, mut w) = (org, -Vec3::Z, 1.0f64);
            let (mut ra, mut ta) = (0.0, 0.0);
            for _ in 0..MAX_WALK_STEPS {
                let s = -(1.0 - rng.next_f32()).ln() / sigma_t;
                if let Some(h) = slab(o, d, s) {
                    if h.tri == 0 {
                        ra = w
                    } else {
                        ta = w
                    }
                    break;
                }
                o += d * s;
                w *= alpha as f64;
                d = phase.sample(d, Vec2::new(rng.next_f32(), rng.next_f32())).0;
            }
            for (acc, v) in sums.iter_mut().chain(trans.iter_mut()).zip([r, ra, t, ta]) {
                acc[0] += v;
                acc[1] += v * v;
            }
        }
        let stat = |a: [f64; 2]| {
            let mean = a[0] / n_walks as f64;
            (mean, ((a[1] / n_walks as f64 - mean * mean) / n_walks as f64).sqrt())
        };
        for (what, pair) in [("reflected", sums), ("transmitted", trans)] {
            let ((g, sg), (a, sa)) = (stat(pair[0]), stat(pair[1]));
            eprintln!("slab {what}: guided {g:.5} ± {sg:.5}, analog {a:.5} ± {sa:.5}");
            assert!((g - a).abs() <= 5.0 * (sg * sg + sa * sa).sqrt(), "{what}: guided {g} vs analog {a}");
        }
    }

    /// The vector exponential stays within 2 ulp of libm's over the walk's range
    /// (every 1/4096 from -87.3 to 0), and is exact at 0; the flushed lanes are 0.
    #[test]
    fn exp3_matches_libm() {
        let mut worst = 0u32;
        let mut i = 0;
        while (i as f32) / 4096.0 < 87.3 {
            let x = -(i as f32) / 4096.0;
            let got = exp3(Vec3A::new(x, x * 0.5, x * 0.25));
            for (g, want) in [(got.x, x.exp()), (got.y, (x * 0.5).exp()), (got.z, (x * 0.25).exp())] {
                worst = worst.max(g.to_bits().abs_diff(want.to_bits()));
            }
            i += 1;
        }
        assert!(worst <= 2, "exp3 is {worst} ulp from expf");
        assert_eq!(exp3(Vec3A::ZERO), Vec3A::ONE);
        assert_eq!(exp3(Vec3A::splat(-90.0)), Vec3A::ZERO);
        let tr = transmittance3(Vec3A::new(0.0, 2.0, -1.0), 0.5);
        assert_eq!((tr.x, tr.z), (1.0, 1.0));
    }
}
