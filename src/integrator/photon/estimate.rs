//! Density estimation on photon maps, and the direct-light step shared by the photon
//! integrators.
//!
//! Radiance estimate (Jensen): the k nearest photons within a maximum radius whose
//! surface normal agrees with the query's (cos > 0.5: photons on other surfaces, e.g.
//! across a corner or the back of a thin wall, are not counted), each weighted by the
//! BSDF for its arrival direction and a **cone filter** w = 1 - d/r, over the disc area
//! π r² ∫w = π r²/3:
//!
//! ```text
//! L(x, wo) ≈ Σ_p f(wo, wp) Φp (1 - dp/r) / (π r² / 3)
//! ```
//!
//! r is the distance to the k-th photon when k were found (that photon then has weight
//! 0, which makes the estimate unbiased for a uniform photon density: the other k-1 are
//! uniform in the disc), else the maximum radius (a fixed-radius estimate).
//! Caveat, measured: photons come from Owen-scrambled Sobol points, which are more even
//! than a Poisson process, so the k-th neighbour's disc holds slightly fewer photons
//! than the Poisson argument assumes and the k-NN estimate can be low by up to about
//! 1/k (0.02 at k = 50) where the density is uniform; the fixed-radius estimate is
//! unbiased there whatever the point set (each photon is marginally uniform), which is
//! what `tests/photon.rs` checks against the analytic irradiance.

use super::kdtree::KnnResult;
use super::{Photon, PhotonMap};
use crate::bsdf::Bsdf;
use crate::integrator::{SceneContext, power_heuristic};
use crate::math::{Frame, Rgb};
use crate::medium::MediumStack;
use crate::render::job::RayStats;
use crate::scene::shading::{ShadingPoint, SurfaceHit};
use glam::{Vec2, Vec3};

/// Photons whose normal is within 60° of the query's count (`Photon::normal_within_60`).
pub const NORMAL_COS: f32 = 0.5;

/// Cone-filtered density estimate of Σ weight(p) Φp per unit area at `q` on a surface
/// with normal `n`: returns (estimate, squared radius used).
#[inline]
pub fn estimate(
    map: &PhotonMap,
    q: Vec3,
    n: Vec3,
    k: usize,
    max_r2: f32,
    filter: impl Fn(&Photon) -> bool,
    weight: impl Fn(&Photon) -> Rgb,
) -> (Rgb, f32) {
    if map.is_empty() {
        return (Rgb::ZERO, max_r2);
    }
    let mut res = KnnResult::new(k);
    map.knn(q, max_r2, |p| p.normal_within_60(n) && filter(p), &mut res);
    let r2 = if res.full() { res.max_d2() } else { max_r2 };
    if !(r2 > 0.0) {
        return (Rgb::ZERO, max_r2);
    }
    let r = r2.sqrt();
    let mut sum = Rgb::ZERO;
    for &(d2, i) in res.items() {
        let p = &map.photons()[i as usize];
        let w = 1.0 - d2.sqrt() / r;
        if w > 0.0 {
            sum += weight(p) * p.power() * w;
        }
    }
    (sum * (3.0 / (std::f32::consts::PI * r2)), r2)
}

/// Reflected radiance toward `wo_local` from the photons of `map` at a shading point.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn radiance(
    map: &PhotonMap,
    q: Vec3,
    ng: Vec3,
    frame: &Frame,
    bsdf: &Bsdf,
    wo_local: Vec3,
    k: usize,
    max_r2: f32,
    filter: impl Fn(&Photon) -> bool,
) -> Rgb {
    let at = bsdf.at(wo_local);
    estimate(map, q, ng, k, max_r2, filter, |p| at.eval(frame.to_local(p.wi()))).0
}

/// Next-event estimation at a shading point: one light chosen by the light sampler
/// (with the geometric normal as receiver normal), weighted by
/// the power heuristic against `bsdf_rays` BSDF-sampled rays from the same point that
/// may find the same light (0: no MIS, weight 1). `media`: the media the point is in.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn direct_light(
    ctx: &SceneContext,
    s: &SurfaceHit,
    sp: &ShadingPoint,
    wo_local: Vec3,
    u_light: f32,
    u_pt: Vec2,
    bsdf_rays: f32,
    media: MediumStack,
    stats: &mut RayStats,
) -> Rgb {
    // Only light above the geometric normal counts here (below), so the tree may cull by it.
    let Some((index, pmf)) = ctx.lights.sample(s.p, s.ng, u_light) else {
        return Rgb::ZERO;
    };
    let Some(ls) = ctx.sample_light(index, s.p, u_pt) else {
        return Rgb::ZERO;
    };
    let wi_local = sp.frame.to_local(ls.wi);
    let f = sp.bsdf.eval(wo_local, wi_local) * wi_local.z.abs();
    if f == Rgb::ZERO || ls.li == Rgb::ZERO || ls.wi.dot(s.ng) <= 0.0 {
        return Rgb::ZERO;
    }
    stats.shadow += 1;
    // Through media and volume boundaries when the scene has any.
    let vis = if ctx.has_media {
        crate::integrator::media::light_transmittance(ctx, s.p, Some(s.ng), &ls, ctx.medium_after(s, ls.wi, media))
    } else {
        Rgb::splat(ctx.visibility(s.p, s.ng, &ls))
    };
    if vis == Rgb::ZERO {
        return Rgb::ZERO;
    }
    let w = if ls.delta || bsdf_rays == 0.0 {
        1.0
    } else {
        power_heuristic(ls.pdf * pmf, bsdf_rays * sp.bsdf.pdf(wo_local, wi_local))
    };
    f * ls.li * vis * (w / (ls.pdf * pmf))
}
