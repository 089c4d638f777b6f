//! SPPM's shadow catcher (`integrator::catcher`, issues 20 and 21). The camera pass splits
//! where its camera segment ends on a catcher, as Jensen's camera chain does; the catcher
//! pass is the path tracer's walk from there in the scene of catchers only (no photon map
//! holds that scene's light). The camera sample's own sums (catcher pass, the matte's
//! emission and direct light, split, count, background) are means over iterations as
//! Combined's direct light is. The matte also holds the photon flux gathered by visible
//! points of paths that did not split: SPPM reduces τ per pixel, so a second τ keeps that
//! share, reduced with the same radius ratio as τ (as `sppm_passes` keeps τ's classes).
//! Allocated only when the film keeps the catcher's sums (`passes::CATCHER_SLOTS`).

use crate::film::{CATCHER_SUMS, Film, FilmImage};
use crate::integrator::SceneContext;
use crate::integrator::catcher::{self, Split};
use crate::integrator::path::PathIntegrator;
use crate::math::Rgb;
use crate::passes::{Aov, CATCHER_SLOTS, Pass, PassSet, slot};
use crate::render::job::RayStats;
use crate::sampling::PixelSampler;
use glam::DVec3;

/// True when a render with `passes` keeps the catcher's sums (as the film does).
pub fn wanted(passes: PassSet) -> bool {
    passes.slots() & CATCHER_SLOTS != 0
}

/// One iteration's camera sample of the catcher's sums, applied when the iteration counts.
#[derive(Clone, Copy, Debug, Default)]
pub struct CatcherSample {
    /// The sums in slot order (`slot::CATCHER_PASS` onward).
    sums: [f32; CATCHER_SUMS],
    /// The camera path split at a catcher: what its visible point gathers is not the matte's.
    split: bool,
    /// The sample's radiance was not finite (dropped, as from Combined).
    bad: bool,
}

/// One pixel's catcher sums over the completed iterations.
#[derive(Clone, Copy, Debug, Default)]
pub struct CatcherSums {
    /// Σ of the camera samples' sums, slot order.
    sums: [f64; CATCHER_SUMS],
    /// The matte's share of τ (visible points of paths that did not split), radius-scaled as τ.
    tau_matte: DVec3,
}

/// The catcher sums of a camera sample whose path noted `split` and collected `ld`
/// (emission and direct light): when it split, the catcher pass is `continuation`'s walk
/// from the split in `ctx`'s catcher scene; `bad` marks a non-finite sample.
pub fn sample(
    ctx: &SceneContext,
    split: &Split,
    ld: Rgb,
    bad: bool,
    continuation: &PathIntegrator,
    sampler: &mut PixelSampler,
    stats: &mut RayStats,
) -> CatcherSample {
    let mut aov = Aov::default();
    match (ctx.catcher.as_deref(), split.at) {
        (Some(pass_ctx), Some((pre, _))) => {
            let pass = continuation.continue_path(pass_ctx, pre, sampler, stats);
            // The world behind the catcher, for an opaque film's approximate catcher.
            let behind = match continuation.transparent_background {
                true => Rgb::ZERO,
                false => pre.escaped_radiance(ctx).map_or(Rgb::ZERO, |le| pre.beta * le),
            };
            catcher::record(&mut aov, split, ld, pass, behind);
        }
        _ => catcher::record(&mut aov, split, ld, Rgb::ZERO, Rgb::ZERO),
    }
    let mut sums = [0.0; CATCHER_SUMS];
    sums.copy_from_slice(&aov.0[slot::CATCHER_PASS..slot::CATCHER_PASS + CATCHER_SUMS]);
    let bad = bad || !sums.iter().all(|v| v.is_finite());
    CatcherSample { sums, split: split.at.is_some(), bad }
}

impl CatcherSums {
    /// Adds an iteration's camera sample (a non-finite one is dropped whole).
    pub fn add_sample(&mut self, s: &CatcherSample) {
        if s.bad {
            return;
        }
        for (a, v) in self.sums.iter_mut().zip(&s.sums) {
            *a += *v as f64;
        }
    }

    /// τ's update for the matte's share: (τ_m + β Σ f Φ) · ratio when the sample's path did
    /// not split, τ_m · ratio when it did (τ's reduction applies to every share of τ).
    pub fn add_gather(&mut self, s: &CatcherSample, contrib: Rgb, ratio: f64) {
        let add = if s.split { DVec3::ZERO } else { contrib.as_dvec3() };
        self.tau_matte = (self.tau_matte + add) * ratio;
    }

    /// The pixel's means (`inv` = 1 / iterations; `area` its π r², None when no photons
    /// were gathered), the matte with its share of τ.
    fn means(&self, inv: f64, area: Option<f64>) -> [f32; CATCHER_SUMS] {
        const MATTE: usize = slot::CATCHER_MATTE - slot::CATCHER_PASS;
        let mut m = self.sums.map(|v| v * inv);
        if let Some(a) = area {
            let t = self.tau_matte * inv / a;
            m[MATTE] += t.x;
            m[MATTE + 1] += t.y;
            m[MATTE + 2] += t.z;
        }
        m.map(|v| v as f32)
    }
}

/// Fills `img.catcher` from `sums` after `iters` iterations (`area(i)`: pixel i's π r²), and
/// gives it the Shadow Catcher pass's plane when `passes` asks for it and it has none yet
/// (`shadow_catcher::resolve` fills it).
pub fn write(
    img: &mut FilmImage,
    passes: PassSet,
    sums: &[CatcherSums],
    iters: u32,
    area: impl Fn(usize) -> Option<f64>,
) {
    let inv = 1.0 / iters.max(1) as f64;
    img.catcher = sums.iter().enumerate().map(|(i, s)| s.means(inv, area(i))).collect();
    if passes.contains(Pass::ShadowCatcher) && !img.extra.iter().any(|(p, _)| *p == Pass::ShadowCatcher) {
        img.extra.push((Pass::ShadowCatcher, vec![0.0; sums.len() * 3]));
    }
}

/// Sets the catcher slots of `film` (a chunk's: the window's size) to the means [`write`]
/// gives times `iters`, so that `Film::image` reads them back and `caustic merge` weighs
/// them by iterations as it weighs Combined.
pub fn into_film(film: &mut Film, sums: &[CatcherSums], iters: u32, area: impl Fn(usize) -> Option<f64>) {
    let inv = 1.0 / iters.max(1) as f64;
    let slots = film.passes.slots();
    let w = film.width;
    for (i, s) in sums.iter().enumerate() {
        let (x, y) = (i as u32 % w, i as u32 / w);
        let m = s.means(inv, area(i));
        let (acc, _) = film.pixel_extra_mut(x, y);
        for (k, v) in m.iter().enumerate() {
            let at = slot::CATCHER_PASS + k;
            if slots & (1u64 << at) != 0 {
                acc[(slots & ((1u64 << at) - 1)).count_ones() as usize] = crate::chunk::mean_times(*v, iters);
            }
        }
    }
}
