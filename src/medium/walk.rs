//! The random walk of subsurface scattering (Chiang et al. 2016, as Cycles' "Random
//! Walk"): free flights inside a mesh until the walk crosses its surface. The scene is
//! seen only through the `intersect` closure it is given.

use super::{HenyeyGreenstein, WalkMedium, WalkRng, sample_channel, transmittance};
use crate::accel::Hit;
use crate::math::Rgb;
use glam::{Vec2, Vec3};

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
pub fn random_walk(
    intersect: impl Fn(Vec3, Vec3, f32) -> Option<Hit>,
    mut org: Vec3,
    mut dir: Vec3,
    m: &WalkMedium,
    beta: Rgb,
    rng: &mut WalkRng,
) -> Option<WalkExit> {
    let mut throughput = m.scale;
    let sigma_s0 = m.sigma_t * m.alpha;
    let g = m.phase.g;
    let similar_s = sigma_s0 * (1.0 - g);
    let similar_t = m.sigma_t - sigma_s0 + similar_s;
    let isotropic = HenyeyGreenstein::new(0.0);
    for step in 0..MAX_WALK_STEPS {
        let (sigma_t, sigma_s, phase) =
            if step <= SIMILARITY_STEP { (m.sigma_t, sigma_s0, m.phase) } else { (similar_t, similar_s, isotropic) };
        let (c, pmf) = sample_channel(beta * throughput * m.alpha, rng.next_f32());
        let t = -(1.0 - rng.next_f32()).ln() / sigma_t[c];
        if let Some(hit) = intersect(org, dir, t) {
            let tr = transmittance(sigma_t, hit.t);
            let p = (pmf * tr).element_sum();
            if !(p > 0.0) {
                return None;
            }
            throughput *= tr / p;
            return Some(WalkExit { hit, org, dir, weight: throughput });
        }
        let tr = transmittance(sigma_t, t);
        let pdf = (pmf * sigma_t * tr).element_sum();
        if !(pdf > 0.0) {
            return None;
        }
        throughput *= sigma_s * tr / pdf;
        if !(throughput.max_element() >= WALK_THROUGHPUT_EPSILON) {
            return None;
        }
        org += dir * t;
        dir = phase.sample(dir, Vec2::new(rng.next_f32(), rng.next_f32())).0;
    }
    None
}
