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
use crate::math::{Frame, Rgb};
use glam::Vec3;

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
    let mut sum = Rgb::ZERO;
    let (norm, r2) = estimate_each(map, q, n, k, max_r2, filter, |_, p, w| sum += weight(p) * p.power() * w);
    (sum * norm, r2)
}

/// The neighbour search of [`estimate`], handing each counted photon (its index in the
/// map, itself) and its cone weight to `visit` (callers that split the estimate, e.g. by light pass or light group, sum
/// `weight · Φp · w` themselves): returns (the factor the sums take, squared radius).
/// The factor is 0 when no photon counts.
#[inline]
pub fn estimate_each(
    map: &PhotonMap,
    q: Vec3,
    n: Vec3,
    k: usize,
    max_r2: f32,
    filter: impl Fn(&Photon) -> bool,
    mut visit: impl FnMut(u32, &Photon, f32),
) -> (f32, f32) {
    if map.is_empty() {
        return (0.0, max_r2);
    }
    let mut res = KnnResult::new(k);
    map.knn(q, max_r2, |p| p.normal_within_60(n) && filter(p), &mut res);
    let r2 = if res.full() { res.max_d2() } else { max_r2 };
    if !(r2 > 0.0) {
        return (0.0, max_r2);
    }
    let r = r2.sqrt();
    for &(d2, i) in res.items() {
        let p = &map.photons()[i as usize];
        let w = 1.0 - d2.sqrt() / r;
        if w > 0.0 {
            visit(i, p, w);
        }
    }
    (3.0 / (std::f32::consts::PI * r2), r2)
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
