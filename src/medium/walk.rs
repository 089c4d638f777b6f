//! The random walk of subsurface scattering (Chiang et al. 2016, as Cycles' "Random
//! Walk"): free flights inside a mesh until the walk crosses its surface. The scene is
//! seen only through the `intersect` closure it is given.

use super::{HenyeyGreenstein, WalkMedium, WalkRng};
use crate::accel::Hit;
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
/// `beta` is the path throughput before the walk (for the channel choice). Returns
/// None when the walk is abandoned (too many steps, negligible throughput).
///
/// `clearance(p, cap)` is a radius (at most `cap`) around p that no surface `intersect`
/// could return comes within (0 when unknown): a step that starts and ends inside such a
/// ball crosses no surface, so its query is skipped — the same answer, so the walk is
/// the same bit for bit.
pub fn random_walk(
    intersect: impl Fn(Vec3, Vec3, f32) -> Option<Hit>,
    mut clearance: impl FnMut(Vec3, f32) -> f32,
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
        let (sigma_t, sigma_s, phase) =
            if step <= SIMILARITY_STEP { (sigma_t0, sigma_s0, m.phase) } else { (similar_t, similar_s, isotropic) };
        let (c, pmf) = sample_channel3(beta * throughput * alpha, rng.next_f32());
        let t = -(1.0 - rng.next_f32()).ln() / sigma_t[c];
        let end = org + dir * t;
        let clear = ball.1 > 0.0 && inside(ball, org) && inside(ball, end);
        if let Some(hit) = if clear { None } else { intersect(org, dir, t) } {
            let tr = transmittance3(sigma_t, hit.t);
            let p = (pmf * tr).element_sum();
            if !(p > 0.0) {
                return None;
            }
            throughput *= tr / p;
            return Some(WalkExit { hit, org, dir, weight: throughput.into() });
        }
        let tr = transmittance3(sigma_t, t);
        let pdf = (pmf * sigma_t * tr).element_sum();
        if !(pdf > 0.0) {
            return None;
        }
        throughput *= sigma_s * tr / pdf;
        if !(throughput.max_element() >= WALK_THROUGHPUT_EPSILON) {
            return None;
        }
        org = end;
        if !clear && ball.1 + (org - ball.0).length() >= need {
            ball = (org, clearance(org, BALL_CAP * need));
        }
        dir = phase.sample(dir, Vec2::new(rng.next_f32(), rng.next_f32())).0;
    }
    None
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
