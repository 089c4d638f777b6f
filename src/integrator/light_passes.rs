//! The path tracer's light passes: each contribution filed by the class of the path's
//! first scattering event, as Cycles does (`kernel/film/light_passes.h`, see
//! `crate::passes`). At a surface the class weights are the BSDF's diffuse and glossy
//! shares of f at the direction taken (transmission: the rest; the sampled bounce's
//! for what the path finds later, the light direction's for the first next-event
//! estimate); in a medium everything is volume. Direct: the first event's next-event
//! estimate and emission found at the next vertex; indirect: the rest. Only when a
//! light pass is asked for does the path tracer keep a tally.

use crate::bsdf::BsdfAt;
use crate::film::CameraSample;
use crate::math::Rgb;
use crate::passes::slot;
use glam::Vec3;

/// Where the path scattered first.
#[derive(Clone, Copy, Debug, PartialEq)]
enum First {
    /// Not yet: contributions are seen directly.
    None,
    /// At a surface, with the diffuse and glossy shares of the bounce taken.
    Surface(Rgb, Rgb),
    /// In a medium.
    Volume,
}

/// The light-pass bookkeeping of one camera path.
#[derive(Clone, Copy, Debug)]
pub struct Tally {
    first: First,
}

/// Diffuse and glossy shares of a BSDF value `f` whose diffuse-class part is `fd`, for a
/// reflected (`reflect`) or transmitted direction (Cycles' `bsdf_eval_pass_*_weight`).
#[inline]
pub fn shares(f: Rgb, fd: Rgb, reflect: bool) -> (Rgb, Rgb) {
    let div = |a: f32, b: f32| if b != 0.0 { a / b } else { 0.0 };
    let d = Rgb::new(div(fd.x, f.x), div(fd.y, f.y), div(fd.z, f.z));
    (d, if reflect { Rgb::ONE - d } else { Rgb::ZERO })
}

/// The shares of the BSDF at local direction `wi`.
#[inline]
pub fn shares_at(at: &BsdfAt, wi: Vec3) -> (Rgb, Rgb) {
    shares(at.eval(wi), at.eval_diffuse(wi), wi.z > 0.0)
}

impl Default for Tally {
    fn default() -> Self {
        Tally { first: First::None }
    }
}

impl Tally {
    /// The tally of a camera path handed over after its first event, whose class is
    /// `first` (a surface's diffuse and glossy shares; None: in a medium) (BDPT's
    /// continuations).
    pub fn continued(first: Option<(Rgb, Rgb)>) -> Self {
        let first = first.map_or(First::Volume, |(d, g)| First::Surface(d, g));
        Tally { first }
    }

    /// The first event was a surface bounce with these shares.
    pub fn surface_bounce(&mut self, diffuse: Rgb, glossy: Rgb) {
        if self.first == First::None {
            self.first = First::Surface(diffuse, glossy);
        }
    }

    /// The first event was the surface bounce `bs` sampled from `at` (a delta lobe's
    /// light is glossy when reflected, transmission when refracted, as the path tracer's).
    pub fn surface_bounce_sampled(&mut self, at: &BsdfAt, bs: &crate::bsdf::BsdfSample) {
        if self.first == First::None {
            let (d, g) =
                if bs.delta { (Rgb::ZERO, Rgb::splat(at.above(bs.wi) as u8 as f32)) } else { shares_at(at, bs.wi) };
            self.first = First::Surface(d, g);
        }
    }

    /// The diffuse and glossy shares of the first event when it was a surface bounce
    /// (SPPM files the photon flux gathered after it by them).
    pub fn first_shares(&self) -> Option<(Rgb, Rgb)> {
        match self.first {
            First::Surface(d, g) => Some((d, g)),
            _ => None,
        }
    }

    /// The first event was a subsurface walk: diffuse (the walk adds no depth, so its
    /// exit's estimate is the direct one, as Cycles').
    pub fn subsurface(&mut self) {
        if self.first == First::None {
            self.first = First::Surface(Rgb::ONE, Rgb::ZERO);
        }
    }

    /// The first event was scattering in a medium.
    pub fn volume(&mut self) {
        if self.first == First::None {
            self.first = First::Volume;
        }
    }

    /// Emission `c` found by the path after `depth` events (`world`: the world's).
    pub fn found(&self, out: &mut CameraSample, depth: u32, c: Rgb, world: bool) {
        if depth == 0 {
            out.aov.add3(if world { slot::ENV } else { slot::EMIT }, c);
        } else {
            self.file(out, depth == 1, self.first, c);
        }
    }

    /// Next-event estimate `c` at a vertex after `depth` events; `shares`: the BSDF's at
    /// the light direction (None in a medium or at a subsurface exit).
    pub fn estimated(&self, out: &mut CameraSample, depth: u32, c: Rgb, shares: Option<(Rgb, Rgb)>) {
        let direct = depth == 0;
        let class = match (direct && depth == 0, shares) {
            (true, Some((d, g))) => First::Surface(d, g),
            (true, None) => First::Volume,
            _ => self.first,
        };
        self.file(out, direct, class, c);
    }

    /// Indirect light `c` (e.g. a photon-map read after the first event), filed by the
    /// first event's class.
    pub fn indirect(&self, out: &mut CameraSample, c: Rgb) {
        self.file(out, false, self.first, c);
    }

    fn file(&self, out: &mut CameraSample, direct: bool, class: First, c: Rgb) {
        match class {
            First::Surface(d, g) => {
                let (sd, sg, st) = match direct {
                    true => (slot::DIFF_DIR, slot::GLOSS_DIR, slot::TRANS_DIR),
                    false => (slot::DIFF_IND, slot::GLOSS_IND, slot::TRANS_IND),
                };
                out.aov.add3(sd, d * c);
                out.aov.add3(sg, g * c);
                out.aov.add3(st, (Rgb::ONE - d - g) * c);
            }
            First::Volume => out.aov.add3(if direct { slot::VOL_DIR } else { slot::VOL_IND }, c),
            // Unreachable for depth > 0; kept in Combined's accounting as emission.
            First::None => out.aov.add3(slot::EMIT, c),
        }
    }

    /// The Colour passes at the first surface hit: the class albedos times the throughput.
    pub fn colours(out: &mut CameraSample, at: &BsdfAt, beta: Rgb) {
        let [d, g, t] = at.class_albedo();
        out.aov.set3(slot::DIFF_COL, d * beta);
        out.aov.set3(slot::GLOSS_COL, g * beta);
        out.aov.set3(slot::TRANS_COL, t * beta);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shares_split_reflection_and_transmission() {
        let (d, g) = shares(Rgb::new(2.0, 1.0, 0.0), Rgb::new(1.0, 1.0, 0.0), true);
        assert_eq!((d, g), (Rgb::new(0.5, 1.0, 0.0), Rgb::new(0.5, 0.0, 1.0)));
        let (d, g) = shares(Rgb::splat(1.0), Rgb::splat(0.25), false);
        assert_eq!((d, g), (Rgb::splat(0.25), Rgb::ZERO));
    }
}
