//! Media along rays through the scene: one ray segment through the media a path is in
//! (emission, free flight, the weight of emitters crossed), and shadow-ray
//! transmittance across volume boundaries and through media. The maths (media, phase
//! function, free flights, albedo inversion, the subsurface random walk) is in
//! `crate::medium`.

use super::SceneContext;
use crate::light::LightSample;
use crate::math::{Rgb, offset_ray_origin};
use crate::medium::tracking::delta_tracking;
use crate::medium::{FreeFlight, GridMedium, Medium, MediumStack, Phase, WalkRng};
use crate::scene::AlphaMode;
use crate::scene::light_path::LightPath;
use crate::scene::visibility::RayMask;
use glam::Vec3;

/// Surfaces a shadow ray may cross (volume boundaries without a surface, transparent
/// BLEND surfaces) before it is considered blocked: bounds the loop.
const MAX_SHADOW_CROSSINGS: u32 = 64;

/// One ray segment `(origin, unit direction)` through the media `media`, up to
/// `t_surface`: adds the medium's emission along it to `l` (times `beta`) and samples a
/// free flight. Returns the scattering event (distance, phase function) if any, the
/// weight of emitters crossed before the event, and the segment's throughput factor.
#[inline]
pub fn medium_segment(
    ctx: &SceneContext,
    media: &MediumStack,
    ray: (Vec3, Vec3),
    t_surface: f32,
    beta: Rgb,
    u: [f32; 2],
    l: &mut Rgb,
) -> (Option<(f32, Phase)>, Rgb, Rgb) {
    if !ctx.media_act {
        // Vacuum everywhere: the weights below would be exactly 1 and nothing emitted.
        return (None, Rgb::ONE, Rgb::ONE);
    }
    let m = match ctx.medium(media) {
        None => return (None, Rgb::ONE, Rgb::ONE),
        Some(Medium::Grid(g)) => return grid_segment(g, ray, t_surface, beta, u, l),
        Some(Medium::Homogeneous(m)) => m,
    };
    // An unbounded segment (an open mesh's medium, the world's) gathers E/σt where the
    // medium attenuates; infinite emission (σt = 0) is refused when the scene loads.
    let emitted = m.emitted(t_surface);
    if emitted.is_finite() {
        *l += beta * emitted;
    }
    match m.sample_free_flight(t_surface, beta, u[0], u[1]) {
        FreeFlight::Scatter { t, weight } => (Some((t, m.phase)), m.pass_weight(t, beta), weight),
        FreeFlight::Pass { weight } => (None, m.pass_weight(t_surface.min(1e30), beta), weight),
    }
}

/// [`medium_segment`] in a grid medium: delta tracking, seeded from the segment's two
/// sample values (the walk needs as many numbers as it meets collisions). Emitters crossed
/// before the event take the weight the tracking reached at the event, which is exact
/// when none sits inside the grid's box (an area light inside smoke is approximate).
#[inline]
fn grid_segment(
    g: &GridMedium,
    (org, dir): (Vec3, Vec3),
    t_surface: f32,
    beta: Rgb,
    u: [f32; 2],
    l: &mut Rgb,
) -> (Option<(f32, Phase)>, Rgb, Rgb) {
    let mut rng = WalkRng::new(u[1], u[0].to_bits());
    let mut emitted = Rgb::ZERO;
    let (flight, pass) = delta_tracking(g, org, dir, t_surface, beta, &mut rng, &mut emitted);
    if emitted.is_finite() {
        *l += beta * emitted;
    }
    match flight {
        // A graph's Anisotropy may vary: the phase function of the scattering point.
        FreeFlight::Scatter { t, weight } => (Some((t, g.phase_at(org + dir * t))), pass, weight),
        FreeFlight::Pass { weight } => (None, pass, weight),
    }
}

/// Fraction of light from a light sample reaching point `p` (a surface point offset
/// along `ng`, or a point in a medium when `ng` is None) through the media of `stack`:
/// volume boundaries without a surface are crossed (changing the medium), BLEND
/// surfaces pass 1 - alpha (a tinted Transparent BSDF its colour), any other surface blocks.
/// `path`: the shadow ray as the Light Path node sees it.
pub fn light_transmittance(
    ctx: &SceneContext,
    p: Vec3,
    ng: Option<Vec3>,
    ls: &LightSample,
    stack: MediumStack,
    path: LightPath,
) -> Rgb {
    light_transmittance_of(ctx, p, ng, ls, stack, None, path)
}

/// [`light_transmittance`] toward a sample of light `light`: with shadow linking, surfaces
/// that do not block it are passed as if they were not there.
pub fn light_transmittance_of(
    ctx: &SceneContext,
    p: Vec3,
    ng: Option<Vec3>,
    ls: &LightSample,
    stack: MediumStack,
    light: Option<usize>,
    path: LightPath,
) -> Rgb {
    light_transmittance_as(ctx, p, ng, ls, stack, light, path, RayMask::SHADOW)
}

/// [`light_transmittance_of`] along a segment that rays of kind `ray` trace (objects hidden
/// from it are passed): BDPT's light-tracing segment to the camera is a camera ray.
#[allow(clippy::too_many_arguments)]
pub fn light_transmittance_as(
    ctx: &SceneContext,
    p: Vec3,
    ng: Option<Vec3>,
    ls: &LightSample,
    mut stack: MediumStack,
    light: Option<usize>,
    mut path: LightPath,
    ray: RayMask,
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
    // Cycles measures each hit's Ray Length along the one shadow ray.
    let mut travelled = 0.0;
    let crossings_left = ctx.transparent_crossings_left(path);
    let mut crossings = 0u32;
    for _ in 0..MAX_SHADOW_CROSSINGS {
        let hit = ctx.intersect_as(org, dir, remaining, ray);
        let seg = hit.map_or(remaining, |h| h.t);
        if let Some(m) = ctx.medium(&stack)
            && m.attenuates()
        {
            tr *= m.transmittance_along(org, dir, seg);
        }
        let Some(h) = hit else {
            return tr;
        };
        let s = ctx.scene.surface(&h, org, dir);
        let mat = &ctx.scene.materials[s.material as usize];
        if light.is_some_and(|l| !ctx.blocks(l, h.tri)) {
            // Not one of the light's blockers: passed, its medium ignored.
        } else if mat.null_surface {
            stack = ctx.medium_after(&s, dir, stack);
        } else if mat.alpha_mode == AlphaMode::Blend && mat.transparent_shadow {
            // Opaque past the crossings the path's transparent bounces leave (Cycles).
            if crossings == crossings_left {
                return Rgb::ZERO;
            }
            crossings += 1;
            tr *= ctx.scene.transmission(h.tri, h.b1, h.b2, path.at(travelled + h.t), dir);
            path = path.passed_transparent();
            // The shadow ray enters or leaves its medium too (Cycles' transparent shadows).
            stack = ctx.medium_after(&s, dir, stack);
        } else {
            return Rgb::ZERO;
        }
        if tr == Rgb::ZERO {
            return tr;
        }
        org = offset_ray_origin(s.p, -s.ng);
        remaining -= h.t;
        travelled += h.t;
        if !(remaining > 0.0) {
            return tr;
        }
    }
    Rgb::ZERO
}
