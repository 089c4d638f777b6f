//! Volume merging: light that reached a medium through delta bounces alone (a glass sphere
//! focusing a light into fog: L S+ V), merged at the camera subpath's first medium vertex
//! with a 3-D kernel, the point–point estimator of Křivánek et al. 2014 ("Unifying points,
//! beams and paths in volumetric light transport simulation"): the in-scattered radiance at
//! x toward the camera is estimated by Σ_j f_p(ω, ω_j) β_j / (N · 4/3 π r³) over the light
//! vertices x_j within r of x (N light subpaths per iteration).
//!
//! Which strategy makes which path. BDPT's strategies carry no medium vertex; from the
//! camera subpath's first medium vertex x the path tracer takes over (`bdpt::subpath`). The
//! paths x → S+ → emitter (one or more delta bounces, then a light that starts light
//! subpaths) are this module's alone: the path tracer continued from x leaves that emission
//! out (`PathIntegrator::merged_delta_light`, `integrator::linking::merged_in_media`), and volume merging makes them
//! with weight 1. Those paths are the ones the path tracer finds only by hitting the light
//! through the glass (noisy for small lights, impossible for point lights), and no other
//! strategy can make them, so the split is the whole of the MIS between the two: every
//! other path is made exactly as before. (A power heuristic between merging and the path
//! tracer's hits would need the merge's density in the path tracer's continuation; the
//! split gives merging every such path, which for small lights is what the heuristic
//! would do anyway.)
//! In a scene with restricted objects or lights (`bdpt::visibility`: Ray Visibility, BSDFs
//! switched by the Light Path node) volume merging is off and the path tracer keeps these
//! paths: light subpaths stop before a restricted segment and never start on a restricted
//! light, so merging could not make all of them.
//!
//! Light side. Every segment a light subpath crosses in a medium after delta bounces alone
//! (z₁ … z_k delta, k ≥ 1; the segment from the light itself is direct light, the path
//! tracer's light sampling at x) gets one collision point sampled along it with its own
//! random numbers; the subpath itself goes on unchanged (it still crosses the medium
//! attenuated), so BDPT's strategies and the surface merges see the same subpaths as
//! before. In a homogeneous medium the point is drawn by chromatic free-flight sampling
//! (a channel by β·σ_s, then a distance from that channel's exponential, the density the
//! average over channels) and stored with β · Tr(t) / p(t): an unbiased estimate of the
//! light arriving along the segment, per unit volume. In a grid medium (volume objects,
//! textured fog) it is a delta-tracking collision, stored with the tracker's scattering
//! weight divided by σ_s at the point (the camera side multiplies σ_s of its own point).
//! Collisions past the segment's end deposit nothing.
//!
//! Camera side. The camera subpath's first medium vertex x (throughput β_c, which holds
//! σ_s(x) · Tr / p) merges with every stored point within r: β_c f_p(ω_c, −ω_j) β_j times the
//! kernel's normalisation. Later medium vertices of the path tracer's continuation do not
//! merge (their L S+ V light is the path tracer's, as before). The radius is the surface
//! merges' r_i, so the bias (light of points within r of x, not at x) vanishes with it.

use super::grid::HashGrid;
use crate::film::CameraSample;
use crate::integrator::SceneContext;
use crate::integrator::bdpt::Ledger;
use crate::integrator::bdpt::volume_records::{LightSegment, MediumVertex};
use crate::math::Rgb;
use crate::medium::tracking::delta_tracking;
use crate::medium::{HomogeneousMedium, Medium, WalkRng, sample_channel, transmittance};
use glam::Vec3;

/// A light point stored for volume merging.
#[derive(Clone, Copy, Debug)]
pub struct VolumeRecord {
    /// Position (a collision in a medium).
    pub p: Vec3,
    /// Unit direction the light travelled along.
    pub dir: Vec3,
    /// Light arriving here per unit volume, divided by the densities (σ_s not included).
    pub beta: Rgb,
    /// Delta bounces on its light subpath before it.
    pub bounces: u32,
    /// The light its subpath started at (light groups).
    pub light: u32,
}

/// A seed for one light subpath's collisions: the render's seed, the pixel and the
/// iteration, mixed (murmur3's finaliser) so that neighbouring pixels differ in every bit.
pub(crate) fn salt(seed: u32, px: u32, py: u32, index: u32) -> u32 {
    let mut h = seed ^ px.wrapping_mul(0x9e37_79b1) ^ py.wrapping_mul(0x85eb_ca77) ^ index.wrapping_mul(0xc2b2_ae3d);
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^ (h >> 16)
}

/// Samples one collision along each segment of one light subpath and appends the stored
/// points to `out`; `salt` seeds the random numbers (the pixel and iteration), so that
/// renders are deterministic.
pub(crate) fn deposit(ctx: &SceneContext, segments: &[LightSegment], salt: u32, out: &mut Vec<VolumeRecord>) {
    for (n, seg) in segments.iter().enumerate() {
        let mut rng = WalkRng::new(f32::from_bits(salt), n as u32 ^ 0x5bd1_e995);
        let Some((t, beta)) = collision(ctx, seg, &mut rng) else { continue };
        // By size: a negative emitter's light vertices carry negative light.
        if !(beta.is_finite() && beta.abs().max_element() > 0.0) {
            continue;
        }
        out.push(VolumeRecord { p: seg.org + seg.dir * t, dir: seg.dir, beta, bounces: seg.bounces, light: seg.light });
    }
}

/// A collision along `seg` and the stored throughput there (see the module's doc), or None
/// when the flight passes the segment's end or the medium does not scatter.
fn collision(ctx: &SceneContext, seg: &LightSegment, rng: &mut WalkRng) -> Option<(f32, Rgb)> {
    match ctx.medium(&seg.media)? {
        Medium::Homogeneous(m) => homogeneous_collision(m, seg.beta, seg.t_end, rng),
        Medium::Grid(g) => {
            let mut emitted = Rgb::ZERO;
            let (flight, _) = delta_tracking(g, seg.org, seg.dir, seg.t_end, seg.beta, rng, &mut emitted);
            let crate::medium::FreeFlight::Scatter { t, weight } = flight else { return None };
            let p = g.index_from_world.transform_point3(seg.org + seg.dir * t);
            let sigma_s = g.coefficients(p, false).sigma_s;
            // The tracker's weight holds σ_s at the point; the camera side brings its own.
            let per = |w: f32, s: f32| if s > 0.0 { w / s } else { 0.0 };
            let w = Rgb::new(per(weight.x, sigma_s.x), per(weight.y, sigma_s.y), per(weight.z, sigma_s.z));
            Some((t, seg.beta * w))
        }
    }
}

/// A free-flight collision in homogeneous medium `m` before `t_end` for light of throughput
/// `beta`, and β · Tr(t) / p(t) (chromatic: a channel drawn by β·σ_s, the density averaged
/// over channels); None when the flight passes `t_end` or the medium does not scatter.
fn homogeneous_collision(m: &HomogeneousMedium, beta: Rgb, t_end: f32, rng: &mut WalkRng) -> Option<(f32, Rgb)> {
    if !m.scatters() {
        return None;
    }
    let sigma_t = m.sigma_t();
    // Channels that do not scatter cannot be merged: draw by β·σ_s.
    let (c, pmf) = sample_channel(beta * m.sigma_s, rng.next_f32());
    let s = sigma_t[c];
    if !(s > 0.0) {
        return None;
    }
    let t = -(1.0 - rng.next_f32()).ln() / s;
    if !(t < t_end) {
        return None;
    }
    let tr = transmittance(sigma_t, t);
    let pdf = (pmf * sigma_t * tr).element_sum();
    (pdf > 0.0).then(|| (t, beta * tr / pdf))
}

/// One iteration's stored volume points, their grid and the kernel's normalisation.
#[derive(Debug, Default)]
pub struct VolumeMap {
    /// The stored points (in the grid's bucket order after `build`).
    pub records: Vec<VolumeRecord>,
    /// The records in the order they were added (scratch of `build`).
    unsorted: Vec<VolumeRecord>,
    /// The records' positions in the same order (the query reads these).
    positions: Vec<Vec3>,
    /// The records' grid.
    grid: HashGrid,
    /// 1 / (N · 4/3 π r³).
    pub norm: f32,
}

impl VolumeMap {
    /// Rebuilds the grid over `records` for radius `radius` and `n` light subpaths expected
    /// (camera samples times VCM's light share: each sample traced one with that probability).
    pub fn build(&mut self, radius: f32, n: f32) {
        let volume = 4.0 / 3.0 * std::f32::consts::PI * radius * radius * radius;
        self.norm = 1.0 / (n * volume);
        self.grid.build(self.records.iter().map(|r| r.p), radius);
        std::mem::swap(&mut self.records, &mut self.unsorted);
        self.records.clear();
        self.records.extend(self.grid.order().iter().map(|&i| self.unsorted[i as usize]));
        self.positions.clear();
        self.positions.extend(self.records.iter().map(|r| r.p));
    }

    /// The merges at the camera subpath's first medium vertex `x` (paths of at most
    /// `max_depth` scattering events); with `passes`, each is filed into the camera
    /// sample's light passes and light groups.
    pub(crate) fn merge(
        &self,
        x: &MediumVertex,
        max_depth: u32,
        mut passes: Option<(&SceneContext, Ledger, &mut CameraSample)>,
    ) -> Rgb {
        // Scattering events of a merged path: the camera side's, x, then the light's bounces.
        let Some(max_bounces) = max_depth.checked_sub(x.events_before + 1) else { return Rgb::ZERO };
        let mut sum = Rgb::ZERO;
        self.grid.for_each_within(
            x.p,
            |i| self.positions[i as usize],
            |i| {
                let y = &self.records[i as usize];
                if y.bounces > max_bounces {
                    return;
                }
                // The path tracer's convention: the phase of the arriving direction and the
                // direction toward the light.
                let c = y.beta * (x.phase.eval(x.dir, -y.dir) * self.norm);
                sum += c;
                if let Some((ctx, ledger, out)) = passes.as_mut() {
                    let events = (x.events_before + 1 + y.bounces) as usize;
                    let group = ledger.group_of_light(ctx, y.light as usize);
                    ledger.file(out, events, x.first, false, group, x.beta * c);
                }
            },
        );
        x.beta * sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::Phase;

    /// The homogeneous collision's stored weight integrates the segment's light: over many
    /// draws, the mean of β·Tr/p restricted to t < t_end equals ∫₀^t_end Tr(t) dt per channel
    /// (the light per unit volume along the segment), within five standard errors.
    #[test]
    fn collision_weight_integrates_transmittance() {
        let m = HomogeneousMedium {
            sigma_a: Rgb::new(0.2, 0.5, 0.1),
            sigma_s: Rgb::new(1.0, 0.5, 2.0),
            phase: Phase::hg(0.3),
            emission: Rgb::ZERO,
        };
        let t_end = 0.8f32;
        let sigma_t = m.sigma_t();
        let n = 200_000;
        let (mut sum, mut sum2) = (Rgb::ZERO, Rgb::ZERO);
        let mut rng = WalkRng::new(0.25, 7);
        for _ in 0..n {
            if let Some((t, w)) = homogeneous_collision(&m, Rgb::ONE, t_end, &mut rng) {
                assert!(t < t_end);
                sum += w;
                sum2 += w * w;
            }
        }
        let mean = sum / n as f32;
        let var = sum2 / n as f32 - mean * mean;
        for c in 0..3 {
            let exact = (1.0 - (-sigma_t[c] * t_end).exp()) / sigma_t[c];
            let se = (var[c] / n as f32).sqrt();
            assert!((mean[c] - exact).abs() < 5.0 * se, "channel {c}: {} vs {exact} (se {se})", mean[c]);
        }
    }
}
