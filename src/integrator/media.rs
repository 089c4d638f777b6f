//! Media along rays through the scene: shadow-ray transmittance across volume
//! boundaries and through media, and the random walk of subsurface scattering. The
//! maths (media, phase function, free flights, albedo inversion) is in `crate::medium`.

use super::SceneContext;
use crate::accel::Hit;
use crate::light::LightSample;
use crate::math::{Rgb, offset_ray_origin};
use crate::medium::{FreeFlight, HenyeyGreenstein, MediumStack, WalkMedium, WalkRng, sample_channel, transmittance};
use crate::scene::AlphaMode;
use glam::{Vec2, Vec3};

/// Surfaces a shadow ray may cross (volume boundaries without a surface, transparent
/// BLEND surfaces) before it is considered blocked: bounds the loop.
const MAX_SHADOW_CROSSINGS: u32 = 64;

/// Steps of a subsurface random walk before it is abandoned (Cycles' BSSRDF_MAX_BOUNCES):
/// such a path ends and its energy is lost; with albedo α < 1 per step the lost part
/// is below α^256 of the walk's weight.
pub const MAX_WALK_STEPS: u32 = 256;

/// After this many steps the walk uses the similarity relation (isotropic phase,
/// reduced scattering σs(1 - g)), as Cycles does: far from the entry the anisotropy
/// no longer matters and isotropic steps are longer.
const SIMILARITY_STEP: u32 = 9;

/// A walk whose throughput falls below this ends (Cycles' VOLUME_THROUGHPUT_EPSILON).
const WALK_THROUGHPUT_EPSILON: f32 = 1e-6;

/// One ray segment through the media `media`, up to `t_surface`: adds the medium's
/// emission along it to `l` (times `beta`) and samples a free flight. Returns the
/// scattering event (distance, phase function) if any, the weight of emitters crossed
/// before the event, and the segment's throughput factor.
#[inline]
pub fn medium_segment(
    ctx: &SceneContext,
    media: &MediumStack,
    t_surface: f32,
    beta: Rgb,
    u: [f32; 2],
    l: &mut Rgb,
) -> (Option<(f32, HenyeyGreenstein)>, Rgb, Rgb) {
    let Some(m) = ctx.medium(media) else {
        return (None, Rgb::ONE, Rgb::ONE);
    };
    if t_surface.is_finite() {
        *l += beta * m.emitted(t_surface);
    }
    match m.sample_free_flight(t_surface, beta, u[0], u[1]) {
        FreeFlight::Scatter { t, weight } => (Some((t, m.phase)), m.pass_weight(t, beta), weight),
        FreeFlight::Pass { weight } => (None, m.pass_weight(t_surface.min(1e30), beta), weight),
    }
}

/// Fraction of light from a light sample reaching point `p` (a surface point offset
/// along `ng`, or a point in a medium when `ng` is None) through the media of `stack`:
/// volume boundaries without a surface are crossed (changing the medium), BLEND
/// surfaces pass 1 - alpha, any other surface blocks.
pub fn light_transmittance(
    ctx: &SceneContext,
    p: Vec3,
    ng: Option<Vec3>,
    ls: &LightSample,
    mut stack: MediumStack,
) -> Rgb {
    let org = match ng {
        Some(n) => offset_ray_origin(p, if ls.wi.dot(n) >= 0.0 { n } else { -n }),
        None => p,
    };
    let (dir, mut remaining) = if ls.dist.is_infinite() {
        (ls.wi, f32::INFINITY)
    } else {
        let target = if ls.normal != Vec3::ZERO { offset_ray_origin(ls.point, ls.normal) } else { ls.point };
        let d = target - org;
        let dist = d.length();
        if !(dist > 0.0) {
            return Rgb::ZERO;
        }
        (d / dist, dist * (1.0 - 1e-4))
    };
    let mut org = org;
    let mut tr = Rgb::ONE;
    for _ in 0..MAX_SHADOW_CROSSINGS {
        let hit = ctx.intersect(org, dir, remaining);
        let seg = hit.map_or(remaining, |h| h.t);
        if let Some(m) = ctx.medium(&stack)
            && m.attenuates()
        {
            tr *= m.transmittance(seg);
        }
        let Some(h) = hit else {
            return tr;
        };
        let mat = &ctx.scene.materials[ctx.scene.mesh.tri_material[h.tri as usize] as usize];
        let s = ctx.scene.surface(&h, org, dir);
        if mat.null_surface {
            stack = ctx.medium_after(&s, dir, stack);
        } else if mat.alpha_mode == AlphaMode::Blend {
            tr *= (1.0 - ctx.scene.alpha(h.tri, h.b1, h.b2)).clamp(0.0, 1.0);
        } else {
            return Rgb::ZERO;
        }
        if tr == Rgb::ZERO {
            return tr;
        }
        org = offset_ray_origin(s.p, -s.ng);
        remaining -= h.t;
        if !(remaining > 0.0) {
            return tr;
        }
    }
    Rgb::ZERO
}

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
    ctx: &SceneContext,
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
    let isotropic = crate::medium::HenyeyGreenstein::new(0.0);
    for step in 0..MAX_WALK_STEPS {
        let (sigma_t, sigma_s, phase) =
            if step <= SIMILARITY_STEP { (m.sigma_t, sigma_s0, m.phase) } else { (similar_t, similar_s, isotropic) };
        let (c, pmf) = sample_channel(beta * throughput * m.alpha, rng.next_f32());
        let t = -(1.0 - rng.next_f32()).ln() / sigma_t[c];
        if let Some(hit) = ctx.intersect(org, dir, t) {
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
