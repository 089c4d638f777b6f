//! Rays through grid media: the walk over the majorant cells a ray crosses, free flights
//! by delta tracking and transmittance by ratio tracking against those majorants, and
//! [`Medium`], the one handle integrators hold for the medium a ray is in (homogeneous
//! or grid).
//!
//! Free flights are Kutz et al.'s spectral tracking ("Spectral and Decomposition
//! Tracking", 2017) with absorption folded into the null weight: at each tentative
//! collision of the scalar majorant μ (the largest channel's bound), emission adds w·E/μ,
//! then a real scattering is chosen with probability P_s = Σ β w σs / Σ β w (σs + σn),
//! σn = μ − σt, weighting the path by σs/(μ P_s), else a null collision by σn/(μ (1 − P_s)).
//! Both estimators are unbiased for any majorant μ > 0, also one that σt exceeds (a
//! procedural medium's, `procedural.rs`): the null coefficient σn = μ − σt is then
//! negative, the null event is chosen with |σn| and its weight σn/(μ (1 − P_s)) is
//! negative, and ratio tracking's factor 1 − σt/μ too; a bounding majorant never sees
//! that, and a tighter one is only faster. Transmittance is ratio tracking: Π (1 − σt/μ)
//! over the tentative collisions. Both end paths whose weight (largest magnitude) has
//! fallen under [`ROULETTE_BELOW`] by Russian roulette.
//!
//! An unbounded grid (the world's textured fog) is tracked so inside its box; outside it a
//! ray tracks the graph on for [`FOLLOWED_DEPTH`] optical depths and then crosses a
//! homogeneous stretch, sampled exactly (`held_stretches`, `Beyond`).
//!
//! The random numbers are a [`WalkRng`]: from the path's sample for free flights, from
//! a hash of the ray for shadow rays (which have no sample dimensions to spare), so a
//! render stays deterministic.

use super::grid::GridMedium;
use super::{FreeFlight, HomogeneousMedium, Phase, WalkRng};
use crate::math::Rgb;
use glam::Vec3;

/// Weight (largest channel) under which a tracked path plays Russian roulette, surviving
/// with probability 1/2.
pub const ROULETTE_BELOW: f32 = 0.1;

/// The medium a ray is in.
#[derive(Clone, Copy, Debug)]
pub enum Medium<'a> {
    /// Constant coefficients (materials' and the world's volumes).
    Homogeneous(&'a HomogeneousMedium),
    /// A volume object's voxel grid.
    Grid(&'a GridMedium),
}

impl Medium<'_> {
    /// True when the medium attenuates light at all (a grid always may).
    #[inline]
    pub fn attenuates(&self) -> bool {
        match self {
            Medium::Homogeneous(m) => m.attenuates(),
            Medium::Grid(_) => true,
        }
    }

    /// The phase function.
    #[inline]
    pub fn phase(&self) -> Phase {
        match self {
            Medium::Homogeneous(m) => m.phase,
            Medium::Grid(g) => g.phase,
        }
    }

    /// Transmittance from `org` along unit `dir` over distance `t`: exact for a
    /// homogeneous medium, an unbiased ratio-tracking estimate for a grid.
    #[inline]
    pub fn transmittance_along(&self, org: Vec3, dir: Vec3, t: f32) -> Rgb {
        match self {
            Medium::Homogeneous(m) => m.transmittance(t),
            Medium::Grid(g) => ratio_tracking(g, org, dir, t, &mut ray_rng(org, dir)),
        }
    }
}

/// A generator seeded from a ray's bits: shadow rays' ratio tracking.
#[inline]
pub fn ray_rng(org: Vec3, dir: Vec3) -> WalkRng {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for v in [org.x, org.y, org.z, dir.x, dir.y, dir.z] {
        h = (h ^ v.to_bits() as u64).wrapping_mul(0x0000_0100_0000_01b3);
    }
    WalkRng(h)
}

/// Where a ray (index-space origin `o`, direction `d`; t is the world distance) is inside
/// the grid's domain: (t_in, t_out), unclipped (t_in < 0 when it starts inside), empty
/// (t_in ≥ t_out) when it misses.
#[inline]
fn box_span(g: &GridMedium, o: Vec3, d: Vec3) -> (f32, f32) {
    let (lo, hi) = g.domain();
    let (mut t0, mut t1) = (f32::NEG_INFINITY, f32::INFINITY);
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] < lo[a] || o[a] > hi[a] {
                return (f32::INFINITY, f32::NEG_INFINITY);
            }
            continue;
        }
        let (ta, tb) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
        t0 = t0.max(ta.min(tb));
        t1 = t1.min(ta.max(tb));
    }
    (t0, t1)
}

/// A stretch [t0, t1) of a ray outside an unbounded grid's box, with the homogeneous
/// medium it sees there: the coefficients at the box point where the ray enters or leaves
/// the box (or, for a ray that never meets it, at the box point nearest its origin).
#[derive(Clone, Copy)]
struct Held {
    t0: f32,
    t1: f32,
    medium: HomogeneousMedium,
}

/// The stretches of a ray outside the box of an unbounded grid (the world's textured
/// volume), before and after the box; none for a bounded grid, whose medium is empty there.
/// The box holds the scene's surfaces and cameras, so these stretches are where paths
/// leave the scene: Cycles evaluates the graph along them to infinity, which no finite
/// majorant bounds; holding the boundary's coefficients keeps their transmittance,
/// emission and scattering exact for a medium that is constant outside the box (contract).
/// Rays follow the graph into them first ([`Beyond`]).
#[inline]
fn held_stretches(g: &GridMedium, org: Vec3, dir: Vec3, t_max: f32, with_emission: bool) -> [Option<Held>; 2] {
    if !g.unbounded || !(t_max > 0.0) {
        return [None, None];
    }
    let o = g.index_from_world.transform_point3(org);
    let d = g.index_from_world.transform_vector3(dir);
    let (lo, hi) = g.domain();
    let held = |t0: f32, t1: f32, anchor: Vec3| {
        let c = g.coefficients(anchor.clamp(lo, hi), with_emission);
        let phase = g.phase_at(g.world_from_index.transform_point3(anchor.clamp(lo, hi)));
        let medium = HomogeneousMedium { sigma_a: c.sigma_a, sigma_s: c.sigma_s, phase, emission: c.emission };
        (t1 > t0).then_some(Held { t0, t1, medium })
    };
    let (t_in, t_out) = box_span(g, o, d);
    if !(t_in < t_out) || t_out <= 0.0 {
        return [held(0.0, t_max, o), None];
    }
    let before = if t_in > 0.0 { held(0.0, t_in.min(t_max), o + d * t_in) } else { None };
    let after = if t_out < t_max { held(t_out, t_max, o + d * t_out) } else { None };
    [before, after]
}

/// The majorant cells a ray crosses, as (t_enter, t_exit, majorant), in order.
pub struct MajorantWalk<'a> {
    g: &'a GridMedium,
    cell: [i64; 3],
    step: [i64; 3],
    next: [f32; 3],
    delta: [f32; 3],
    t: f32,
    t_end: f32,
}

impl<'a> MajorantWalk<'a> {
    /// The walk from `org` along `dir` (world space) over [0, t_max].
    pub fn new(g: &'a GridMedium, org: Vec3, dir: Vec3, t_max: f32) -> Self {
        let o = g.index_from_world.transform_point3(org);
        let d = g.index_from_world.transform_vector3(dir);
        let (lo, _) = g.domain();
        let (t_in, t_out) = box_span(g, o, d);
        let (t0, t1) = (t_in.max(0.0), t_out.min(t_max));
        let mut walk =
            MajorantWalk { g, cell: [0; 3], step: [0; 3], next: [f32::INFINITY; 3], delta: [0.0; 3], t: t0, t_end: t1 };
        if !(t0 < t1) {
            walk.t_end = walk.t;
            return walk;
        }
        let cell_size = super::grid::CELL as f32;
        // The entry cell (clamped: the entry point lies on the domain's face).
        let p = o + d * t0;
        for a in 0..3 {
            let c = ((p[a] - lo[a]) / cell_size).floor() as i64;
            walk.cell[a] = c.clamp(0, g.cells[a] as i64 - 1);
            if d[a] > 0.0 {
                walk.step[a] = 1;
                walk.next[a] = (lo[a] + (walk.cell[a] + 1) as f32 * cell_size - o[a]) / d[a];
                walk.delta[a] = cell_size / d[a];
            } else if d[a] < 0.0 {
                walk.step[a] = -1;
                walk.next[a] = (lo[a] + walk.cell[a] as f32 * cell_size - o[a]) / d[a];
                walk.delta[a] = -cell_size / d[a];
            }
        }
        walk
    }
}

impl Iterator for MajorantWalk<'_> {
    type Item = (f32, f32, f32);

    #[inline]
    fn next(&mut self) -> Option<(f32, f32, f32)> {
        if !(self.t < self.t_end) || (0..3).any(|a| self.cell[a] < 0 || self.cell[a] >= self.g.cells[a] as i64) {
            return None;
        }
        let a = if self.next[0] <= self.next[1] && self.next[0] <= self.next[2] {
            0
        } else if self.next[1] <= self.next[2] {
            1
        } else {
            2
        };
        let t1 = self.next[a].min(self.t_end);
        let m = self.g.cell_majorant([self.cell[0] as u32, self.cell[1] as u32, self.cell[2] as u32]);
        let item = (self.t, t1, m);
        self.t = t1;
        self.cell[a] += self.step[a];
        self.next[a] += self.delta[a];
        Some(item)
    }
}

/// Russian roulette on a tracked weight: false when the path ends (the weight is then
/// meaningless); survivors are doubled.
#[inline]
fn roulette(w: &mut Rgb, rng: &mut WalkRng) -> bool {
    if w.abs().max_element() >= ROULETTE_BELOW {
        return true;
    }
    if rng.next_f32() < 0.5 {
        return false;
    }
    *w *= 2.0;
    true
}

/// Free flight through grid `g` from `org` along unit `dir` up to `t_max`, for a path of
/// throughput `beta`: delta (spectral) tracking against the majorant cells. Emission met
/// on the way is added to `emitted` (to be multiplied by `beta`). A path absorbed or
/// ended by roulette passes with weight zero. Also returns the null-collision weight
/// reached at the event (the pass weight, without the scattering factor).
pub fn delta_tracking(
    g: &GridMedium,
    org: Vec3,
    dir: Vec3,
    t_max: f32,
    beta: Rgb,
    rng: &mut WalkRng,
    emitted: &mut Rgb,
) -> (FreeFlight, Rgb) {
    let mut w = Rgb::ONE;
    let ray = Ray { g, org, dir };
    let [before, after] = held_stretches(g, org, dir, t_max, true);
    if let Some(h) = &before
        && let Some(event) = beyond_flight(&ray, h, beta, &mut w, rng, emitted)
    {
        return event;
    }
    for (t0, t1, mu) in MajorantWalk::new(g, org, dir, t_max) {
        if let Some(event) = track(&ray, t0, t1, mu, beta, &mut w, rng, emitted) {
            return event;
        }
    }
    if let Some(h) = &after
        && let Some(event) = beyond_flight(&ray, h, beta, &mut w, rng, emitted)
    {
        return event;
    }
    (FreeFlight::Pass { weight: w }, w)
}

/// A ray through grid `g` (world space).
struct Ray<'a> {
    g: &'a GridMedium,
    org: Vec3,
    dir: Vec3,
}

impl Ray<'_> {
    /// The index-space point at distance `t`.
    #[inline]
    fn index(&self, t: f32) -> Vec3 {
        self.g.index_from_world.transform_point3(self.org + self.dir * t)
    }
}

/// Spectral tracking over [t0, t1) against majorant `mu` for a path of throughput `beta`
/// that reached t0 with tracking weight `w`: the event that ends the flight (a scattering,
/// or weight zero once absorbed or ended by roulette), None when it passes t1 (`w` updated).
#[allow(clippy::too_many_arguments)]
#[inline]
fn track(
    ray: &Ray,
    t0: f32,
    t1: f32,
    mu: f32,
    beta: Rgb,
    w: &mut Rgb,
    rng: &mut WalkRng,
    emitted: &mut Rgb,
) -> Option<(FreeFlight, Rgb)> {
    if !(mu > 0.0) {
        return None;
    }
    let mut t = t0;
    loop {
        t -= (1.0 - rng.next_f32()).ln() / mu;
        if t >= t1 {
            return None;
        }
        let c = ray.g.coefficients(ray.index(t), true);
        *emitted += *w * c.emission / mu;
        // Negative where σt exceeds a sampled majorant (module doc).
        let sigma_n = Rgb::splat(mu) - c.sigma_a - c.sigma_s;
        let bw = (beta * *w).abs();
        let (ps, pn) = ((c.sigma_s * bw).element_sum(), (sigma_n.abs() * bw).element_sum());
        if !(ps + pn > 0.0) {
            // Only absorption at the majorant: the path ends here.
            return Some((FreeFlight::Pass { weight: Rgb::ZERO }, Rgb::ZERO));
        }
        let p_scatter = ps / (ps + pn);
        if rng.next_f32() < p_scatter {
            return Some((FreeFlight::Scatter { t, weight: *w * c.sigma_s / (mu * p_scatter) }, *w));
        }
        *w *= sigma_n / (mu * (1.0 - p_scatter));
        if !roulette(w, rng) {
            return Some((FreeFlight::Pass { weight: Rgb::ZERO }, Rgb::ZERO));
        }
    }
}

/// Optical depth, at the box boundary's least σt, over which a free flight beyond an
/// unbounded grid's box follows the graph before holding the coefficients it reached:
/// e^−13.8 = 10⁻⁶ of the light there is left to the held rest, for a fog as dense beyond
/// as at its boundary.
const FOLLOWED_DEPTH: f32 = 13.8;

/// How a stretch `h` beyond an unbounded grid's box is crossed: the graph tracked point by
/// point over [h.t0, t_far) against majorant `mu` (the cells' largest, or the boundary's σt:
/// unbiased for any), as Cycles follows it to infinity, for the first [`FOLLOWED_DEPTH`];
/// then `rest`, held at the coefficients of the point reached. A stretch whose boundary does
/// not attenuate some channel is held whole (its unbounded emission diverges, as Cycles').
struct Beyond {
    t_far: f32,
    mu: f32,
    rest: Option<Held>,
}

fn beyond(ray: &Ray, h: &Held, with_emission: bool) -> Beyond {
    let sigma_t = h.medium.sigma_a + h.medium.sigma_s;
    let least = sigma_t.min_element();
    if !(least > 0.0) {
        return Beyond { t_far: h.t0, mu: 0.0, rest: Some(*h) };
    }
    let t_far = (h.t0 + FOLLOWED_DEPTH / least).min(h.t1);
    let mu = sigma_t.max_element().max(ray.g.outer_majorant);
    let rest = (t_far < h.t1).then(|| {
        let far = ray.index(t_far);
        let c = ray.g.coefficients(far, with_emission);
        let phase = ray.g.phase_at(ray.g.world_from_index.transform_point3(far));
        let medium = HomogeneousMedium { sigma_a: c.sigma_a, sigma_s: c.sigma_s, phase, emission: c.emission };
        Held { t0: t_far, t1: h.t1, medium }
    });
    Beyond { t_far, mu, rest }
}

/// The free flight across the stretch `h` beyond an unbounded grid's box ([`Beyond`]).
fn beyond_flight(
    ray: &Ray,
    h: &Held,
    beta: Rgb,
    w: &mut Rgb,
    rng: &mut WalkRng,
    emitted: &mut Rgb,
) -> Option<(FreeFlight, Rgb)> {
    let b = beyond(ray, h, true);
    if let Some(event) = track(ray, h.t0, b.t_far, b.mu, beta, w, rng, emitted) {
        return Some(event);
    }
    b.rest.and_then(|rest| held_flight(&rest, beta, w, rng, emitted))
}

/// The free flight across a held stretch (homogeneous: exact sampling) for a path that
/// reached it with tracking weight `w`: its emission's expectation is added, and a scatter
/// inside it is returned as [`delta_tracking`] returns one; a pass multiplies `w`. Emission
/// over an unbounded stretch in a channel the stretch does not attenuate is infinite and
/// left out (Cycles' integral diverges there too).
#[inline]
fn held_flight(h: &Held, beta: Rgb, w: &mut Rgb, rng: &mut WalkRng, emitted: &mut Rgb) -> Option<(FreeFlight, Rgb)> {
    let len = h.t1 - h.t0;
    let e = h.medium.emitted(len);
    if e.is_finite() {
        *emitted += *w * e;
    }
    let bw = beta * *w;
    match h.medium.sample_free_flight(len, bw, rng.next_f32(), rng.next_f32()) {
        FreeFlight::Scatter { t, weight } => {
            let pass = *w * h.medium.pass_weight(t, bw);
            Some((FreeFlight::Scatter { t: h.t0 + t, weight: *w * weight }, pass))
        }
        FreeFlight::Pass { weight } => {
            *w *= weight;
            None
        }
    }
}

/// Transmittance through grid `g` from `org` along unit `dir` over `t_max`: ratio tracking.
pub fn ratio_tracking(g: &GridMedium, org: Vec3, dir: Vec3, t_max: f32, rng: &mut WalkRng) -> Rgb {
    let mut tr = Rgb::ONE;
    let ray = Ray { g, org, dir };
    let [before, after] = held_stretches(g, org, dir, t_max, false);
    let followed = [&before, &after].map(|h| h.as_ref().map(|h| (h.t0, beyond(&ray, h, false))));
    // The held rests first: one that is opaque (an unbounded stretch to the world through fog)
    // ends the ray without tracking.
    for (_, b) in followed.iter().flatten() {
        if let Some(rest) = &b.rest {
            tr *= rest.medium.transmittance(rest.t1 - rest.t0);
        }
    }
    if tr == Rgb::ZERO {
        return tr;
    }
    let cells = MajorantWalk::new(g, org, dir, t_max);
    let spans = followed.iter().flatten().map(|(t0, b)| (*t0, b.t_far, b.mu)).chain(cells);
    for (t0, t1, mu) in spans {
        if !ratio_track(&ray, t0, t1, mu, &mut tr, rng) {
            return Rgb::ZERO;
        }
    }
    tr
}

/// Ratio tracking over [t0, t1) against majorant `mu`, multiplying `tr`; false once roulette
/// ends it.
#[inline]
fn ratio_track(ray: &Ray, t0: f32, t1: f32, mu: f32, tr: &mut Rgb, rng: &mut WalkRng) -> bool {
    if !(mu > 0.0) {
        return true;
    }
    let mut t = t0;
    loop {
        t -= (1.0 - rng.next_f32()).ln() / mu;
        if t >= t1 {
            return true;
        }
        let c = ray.g.coefficients(ray.index(t), false);
        // Negative where σt exceeds a sampled majorant: kept, so the mean stays exact.
        *tr *= Rgb::ONE - (c.sigma_a + c.sigma_s) / mu;
        if !roulette(tr, rng) {
            return false;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::grid::{Field, VolumeShader};
    use glam::Affine3A;

    fn shader(density: f32, emission: Rgb) -> VolumeShader {
        VolumeShader {
            density,
            color: Rgb::new(0.8, 0.5, 0.1),
            absorption_color: Rgb::new(0.0, 0.25, 0.0),
            anisotropy: 0.0,
            emission,
            blackbody_intensity: 0.0,
            blackbody_tint: Rgb::ONE,
            temperature: 0.0,
        }
    }

    /// Mean and standard error of `n` draws of a vector estimator.
    fn mean_and_error(n: usize, mut draw: impl FnMut(usize) -> Rgb) -> (Rgb, Rgb) {
        let (mut sum, mut sq) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
        for i in 0..n {
            let x = draw(i).as_dvec3();
            sum += x;
            sq += x * x;
        }
        let mean = sum / n as f64;
        let var = (sq / n as f64 - mean * mean).max(glam::DVec3::ZERO);
        (mean.as_vec3(), (var / n as f64).map(f64::sqrt).as_vec3())
    }

    /// Five standard errors (plus f32 rounding of the sums): a true mean falls outside with
    /// probability under 1e-6 per channel.
    fn agrees(what: &str, got: (Rgb, Rgb), want: Rgb) {
        let (mean, err) = got;
        for c in 0..3 {
            let bound = 5.0 * err[c] + 1e-5;
            assert!(
                (mean[c] - want[c]).abs() <= bound,
                "{what}, channel {c}: {} vs {} (bound {bound})",
                mean[c],
                want[c]
            );
        }
    }

    /// A grid of constant density is the homogeneous medium: delta tracking's pass and
    /// scatter weights and its emission have the homogeneous medium's expectations
    /// (Tr, σs/σt·(1 − Tr), E·(1 − Tr)/σt per channel), through a scaled, rotated grid.
    #[test]
    fn constant_grid_is_the_homogeneous_medium() {
        let emission = Rgb::new(0.3, 0.2, 0.1);
        let world = Affine3A::from_rotation_y(0.4) * Affine3A::from_scale(Vec3::splat(0.25));
        let g = GridMedium::new("const".into(), [8, 8, 8], world, [None, None, None], shader(1.5, emission));
        let c = g.coefficients(Vec3::splat(3.0), true);
        let sigma_t = c.sigma_a + c.sigma_s;
        let org = world.transform_point3(Vec3::new(-0.5, 3.0, 3.5));
        let dir = world.transform_vector3(Vec3::new(1.0, 0.2, 0.1)).normalize();
        let t_max = 1.6; // stays inside the domain: 6.4 index units along a ray of slope ≤ 0.2
        assert!(g.index_from_world.transform_point3(org + dir * t_max).max_element() < 8.0);
        let tr = (-sigma_t * t_max).exp();
        let beta = Rgb::new(1.0, 0.7, 0.4);
        let n = 200_000;
        let mut pass = Vec::with_capacity(n);
        let mut scatter = Vec::with_capacity(n);
        let mut glow = Vec::with_capacity(n);
        let mut rng = WalkRng::new(0.25, 3);
        for _ in 0..n {
            let mut e = Rgb::ZERO;
            let (flight, _) = delta_tracking(&g, org, dir, t_max, beta, &mut rng, &mut e);
            let (p, s) = match flight {
                FreeFlight::Pass { weight } => (weight, Rgb::ZERO),
                FreeFlight::Scatter { weight, .. } => (Rgb::ZERO, weight),
            };
            pass.push(p);
            scatter.push(s);
            glow.push(e);
        }
        agrees("pass", mean_and_error(n, |i| pass[i]), tr);
        agrees("scatter", mean_and_error(n, |i| scatter[i]), c.sigma_s / sigma_t * (Rgb::ONE - tr));
        agrees("emission", mean_and_error(n, |i| glow[i]), emission * (Rgb::ONE - tr) / sigma_t);
        let mut rng = WalkRng::new(0.75, 9);
        agrees("ratio tracking", mean_and_error(n, |_| ratio_tracking(&g, org, dir, t_max, &mut rng)), tr);
    }

    /// Ratio tracking through a density ramp d(x) = x (voxel centres on the ray) against
    /// the closed form exp(−k (b² − a²)/2), k the extinction per unit density.
    #[test]
    fn transmittance_of_a_linear_ramp() {
        let n_vox = 16;
        let density = Field { values: (0..n_vox).map(|i| i as f32).collect(), components: 1 };
        let voxel = 0.1;
        let world = Affine3A::from_scale(Vec3::splat(voxel));
        let g =
            GridMedium::new("ramp".into(), [n_vox, 1, 1], world, [Some(density), None, None], shader(0.8, Rgb::ZERO));
        // Extinction per unit density, read where the density is 1.
        let c = g.coefficients(Vec3::new(1.0, 0.0, 0.0), false);
        let k = c.sigma_a + c.sigma_s;
        let (a, b) = (2.0f32, 13.5f32); // index units, inside [0, n − 1] where d is linear
        let org = Vec3::new(a * voxel, 0.0, 0.0);
        let t_max = (b - a) * voxel;
        // ∫ σt dt over world distance = k ∫ x d(x·voxel) = k·voxel·(b² − a²)/2.
        let exact = (-k * voxel * (b * b - a * a) / 2.0).exp();
        let mut rng = WalkRng::new(0.5, 11);
        agrees("ramp", mean_and_error(200_000, |_| ratio_tracking(&g, org, Vec3::X, t_max, &mut rng)), exact);
        // Both directions agree (the cell walk runs backwards too).
        let mut rng = WalkRng::new(0.5, 12);
        let back = Vec3::new(b * voxel, 0.0, 0.0);
        agrees(
            "ramp backwards",
            mean_and_error(200_000, |_| ratio_tracking(&g, back, -Vec3::X, t_max, &mut rng)),
            exact,
        );
    }

    /// The cell walk covers [entry, exit] of the domain without gaps or overlaps.
    #[test]
    fn majorant_walk_is_contiguous() {
        let g = GridMedium::new(
            "walk".into(),
            [20, 13, 7],
            Affine3A::from_rotation_z(0.3) * Affine3A::from_scale(Vec3::new(0.1, 0.2, 0.05)),
            [None, None, None],
            shader(1.0, Rgb::ZERO),
        );
        let mut rng = WalkRng::new(0.1, 1);
        for _ in 0..1000 {
            let org = Vec3::new(rng.next_f32() * 4.0 - 2.0, rng.next_f32() * 4.0 - 2.0, rng.next_f32() * 2.0 - 1.0);
            let dir = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize();
            let mut prev: Option<f32> = None;
            let mut total = 0.0;
            for (t0, t1, _) in MajorantWalk::new(&g, org, dir, 10.0) {
                if let Some(p) = prev {
                    assert!((t0 - p).abs() < 1e-5, "gap or overlap: {p} then {t0}");
                }
                assert!(t1 >= t0);
                total += t1 - t0;
                prev = Some(t1);
            }
            assert!(total <= 10.0 + 1e-4);
        }
    }
}
