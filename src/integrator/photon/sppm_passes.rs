//! SPPM's light passes and light groups (issue 21). The camera pass files its emission and
//! direct light (and what it path traces: the glossy part after the visible point, media,
//! subsurface) as the path tracer does (`light_passes::Tally`, `filing::Filing`); its
//! per-pixel sums are kept here. The gathered photon flux τ is indirect light: at a visible
//! point that is the camera path's first hit it is split by the class of each photon's
//! arrival direction (`shares_at`, the split `map_read.rs` makes for Jensen), later by the
//! class of the camera path's first bounce; by light group with each photon's group. The
//! split τ's take the same radius-reduction ratio as τ, so passes and groups keep summing to
//! Combined. Allocated only when a light pass or light group is asked for.
//!
//! A chunk (`--chunk`) keeps them as SPPM keeps Combined (`chunk::set_means`): each pixel's
//! value (Direct and Indirect before their division by Colour) times the iterations, so
//! that `caustic merge` weighs the chunks' passes by their iterations as it weighs their
//! Combined, and the merged passes still sum to the merged Combined.

use crate::film::{CameraSample, Film, FilmImage};
use crate::math::Rgb;
use crate::passes::{PassSet, divide_even_color, slot};
use crate::scene::light_groups::{GroupSums, MAX};
use glam::DVec3;

/// Slots of the light passes (Diffuse Direct … Environment): all those before AO.
const LIGHT_SLOTS: usize = slot::AO;

/// The indirect slots τ is filed in (diffuse, glossy, transmission).
const TAU_SLOTS: [usize; 3] = [slot::DIFF_IND, slot::GLOSS_IND, slot::TRANS_IND];

/// One pixel's light-pass and light-group sums over the completed iterations.
#[derive(Clone, Copy, Debug)]
pub struct SplitSums {
    /// Σ of the camera samples' light-pass values, by slot.
    ld: [f64; LIGHT_SLOTS],
    /// Σ of the camera samples' light-group values.
    ld_groups: [DVec3; MAX],
    /// τ by class (diffuse, glossy, transmission; all indirect), radius-scaled as τ.
    tau: [DVec3; 3],
    /// τ by light group, radius-scaled as τ.
    tau_groups: [DVec3; MAX],
}

impl Default for SplitSums {
    fn default() -> Self {
        SplitSums {
            ld: [0.0; LIGHT_SLOTS],
            ld_groups: [DVec3::ZERO; MAX],
            tau: [DVec3::ZERO; 3],
            tau_groups: [DVec3::ZERO; MAX],
        }
    }
}

/// One iteration's gathered flux Σ f Φ split by class and by group (before the throughput).
#[derive(Clone, Copy, Debug, Default)]
pub struct GatherSplit {
    /// By class: diffuse, glossy, transmission.
    pub classes: [Rgb; 3],
    /// By the photons' light groups.
    pub groups: GroupSums,
}

impl GatherSplit {
    /// Adds a photon's `c` = f Φ with the BSDF's diffuse and glossy shares `(d, g)` at its
    /// direction (transmission the rest) and its light group `group`.
    #[inline]
    pub fn add(&mut self, c: Rgb, (d, g): (Rgb, Rgb), group: u8) {
        self.classes[0] += d * c;
        self.classes[1] += g * c;
        self.classes[2] += (Rgb::ONE - d - g) * c;
        self.groups.add(group, c);
    }
}

impl SplitSums {
    /// Adds a camera sample's light passes and groups (a sample whose radiance was not
    /// finite is dropped by the caller, as from Combined).
    pub fn add_sample(&mut self, s: &CameraSample) {
        for (a, v) in self.ld.iter_mut().zip(&s.aov.0[..LIGHT_SLOTS]) {
            *a += *v as f64;
        }
        for (a, v) in self.ld_groups.iter_mut().zip(&s.groups.0) {
            *a += Rgb::from_array(*v).as_dvec3();
        }
    }

    /// τ's update for the split: (τ_c + β Σ_c) · ratio, as `sppm::render` does for τ.
    pub fn add_gather(&mut self, beta: Rgb, g: &GatherSplit, ratio: f64) {
        for (t, c) in self.tau.iter_mut().zip(&g.classes) {
            *t = (*t + (beta * *c).as_dvec3()) * ratio;
        }
        for (t, c) in self.tau_groups.iter_mut().zip(&g.groups.0) {
            *t = (*t + (beta * Rgb::from_array(*c)).as_dvec3()) * ratio;
        }
    }
}

/// A pixel's value of a light slot triple `at`: the camera pass's mean plus τ's share of it
/// (`inv` = 1 / iterations, `area` the pixel's π r², None when no photons were gathered).
fn slot_value(s: &SplitSums, at: usize, inv: f64, area: Option<f64>) -> [f32; 3] {
    let mut v = DVec3::new(s.ld[at], s.ld[at + 1], s.ld[at + 2]) * inv;
    if let (Some(k), Some(a)) = (TAU_SLOTS.iter().position(|&t| t == at), area) {
        v += s.tau[k] * inv / a;
    }
    v.as_vec3().to_array()
}

/// A pixel's value of light group `g` (as [`slot_value`]).
fn group_value(s: &SplitSums, g: usize, inv: f64, area: Option<f64>) -> [f32; 3] {
    let mut v = s.ld_groups[g] * inv;
    if let Some(a) = area {
        v += s.tau_groups[g] * inv / a;
    }
    v.as_vec3().to_array()
}

/// Writes the light passes and light groups `passes` asks for into `img`, from `sums` after
/// `iters` iterations; `area(i)` is pixel i's π r² (None: no photons were gathered).
pub fn write(
    img: &mut FilmImage,
    passes: PassSet,
    sums: &[SplitSums],
    iters: u32,
    area: impl Fn(usize) -> Option<f64>,
) {
    let n = sums.len();
    let inv = 1.0 / iters.max(1) as f64;
    for pass in passes.iter().filter(|p| p.is_light()) {
        let Some(at) = pass.slot() else { continue };
        // Direct and Indirect are written divided by their Colour pass, as the film does.
        let col = pass.divided_by().and_then(|c| c.slot());
        let mut data = vec![0.0f32; n * 3];
        for (i, px) in data.chunks_exact_mut(3).enumerate() {
            let value = |at: usize| slot_value(&sums[i], at, inv, area(i));
            let v = value(at);
            px.copy_from_slice(&col.map_or(v, |c| divide_even_color(v, value(c))));
        }
        img.extra.push((pass, data));
    }
    let groups = passes.light_groups();
    img.light_groups = (0..groups)
        .map(|g| {
            let mut data = vec![0.0f32; n * 3];
            for (i, px) in data.chunks_exact_mut(3).enumerate() {
                px.copy_from_slice(&group_value(&sums[i], g, inv, area(i)));
            }
            data
        })
        .collect();
}

/// Sets the light slots and light-group sums of `film` (a chunk's: the window's size, with
/// `passes`) to the values [`write`] gives, undivided, times `iters`, so that `Film::image`
/// reads them back (Direct and Indirect then divided by their Colour from these sums).
pub fn into_film(
    film: &mut Film,
    passes: PassSet,
    sums: &[SplitSums],
    iters: u32,
    area: impl Fn(usize) -> Option<f64>,
) {
    let inv = 1.0 / iters.max(1) as f64;
    let slots = passes.slots();
    let groups = passes.light_groups();
    let w = film.width;
    for (i, s) in sums.iter().enumerate() {
        let (x, y) = (i as u32 % w, i as u32 / w);
        let a = area(i);
        let (acc, group_sums) = film.pixel_extra_mut(x, y);
        // The light passes come in RGB triples from their first slot: fill the kept ones.
        let mut m = slots;
        for v in acc.iter_mut() {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            if k < LIGHT_SLOTS {
                let at = k - k % 3;
                *v = crate::chunk::mean_times(slot_value(s, at, inv, a)[k % 3], iters);
            }
        }
        for (g, acc) in group_sums[..3 * groups].chunks_exact_mut(3).enumerate() {
            for (v, c) in acc.iter_mut().zip(group_value(s, g, inv, a)) {
                *v = crate::chunk::mean_times(c, iters);
            }
        }
    }
}
