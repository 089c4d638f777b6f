//! Blender's (non-principled) Hair BSDF, as Cycles' `bsdf_hair.h`: a Reflection lobe and a
//! Transmission lobe, each a longitudinal Cauchy-like lobe of width RoughnessU around the
//! mirror angle shifted by the Offset, times an azimuthal one of width RoughnessV (Reflection:
//! a cosine lobe on the viewer's side; Transmission: a Cauchy lobe around the far side). Each
//! lobe's value (f·cos, Cycles' convention) is its weight times its sampling density, so
//! that a sampled direction carries exactly the weight.
//!
//! Frame: x along the fibre (Cycles' `T`); the azimuths are measured from the viewer's
//! direction across the fibre (Cycles' `locy`, wo without its x part), so that a strand's
//! frame (z across the fibre toward the viewer, `hair_frame`) and a triangle's (z its normal,
//! x its Cycles tangent `dPdv`: `shader::mesh_hair`) both serve. Reflection is zero where the
//! direction is behind the fibre (cos φ < 0) or below the surface normal at the hit (Cycles'
//! `bsdf->N`: a strand's round normal, (0, h, √(1−h²)) for the offset h across the fibre; a
//! triangle's shading normal), Transmission where it is above that normal. Cycles' reflection samples azimuths up to π × RoughnessV but evaluates only
//! those within π/2: above RoughnessV 0.5 its samples reach directions its evaluation (and so
//! next-event estimation) gives zero; Caustic does the same (`sample` returns them with their
//! sampled value), so both renderers compute the same estimate.

use crate::math::Rgb;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, PI};

/// One lobe of the Hair BSDF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairLobe {
    /// The closure's weight (Color × mix weights).
    pub weight: Rgb,
    /// Transmission (else Reflection).
    pub transmission: bool,
    /// Cycles' offset: minus the node's Offset (radians).
    pub offset: f32,
    /// Longitudinal roughness (RoughnessU), in [0.001, 1].
    pub r1: f32,
    /// Azimuthal roughness (RoughnessV), in [0.001, 1].
    pub r2: f32,
}

impl HairLobe {
    /// Cycles' setup: the node's Offset (radians) and roughnesses, clamped as Cycles does.
    pub fn new(weight: Rgb, transmission: bool, node_offset: f32, roughness_u: f32, roughness_v: f32) -> Self {
        let clamp = |r: f32| if r.is_finite() { r.clamp(0.001, 1.0) } else { 1.0 };
        HairLobe {
            weight: weight.max(Rgb::ZERO),
            transmission,
            offset: if node_offset.is_finite() { -node_offset } else { 0.0 },
            r1: clamp(roughness_u),
            r2: clamp(roughness_v),
        }
    }

    /// The longitudinal angle's limits of the Cauchy lobe for a viewer at θr (Cycles' a, b).
    fn limits(&self, theta_r: f32) -> (f32, f32) {
        let a = (((FRAC_PI_2 + theta_r) * 0.5 - self.offset) / self.r1).atan();
        let b = (((-FRAC_PI_2 + theta_r) * 0.5 - self.offset) / self.r1).atan();
        (a, b)
    }

    /// The longitudinal density of θi (of cosine `cos_i`) per solid angle (Cycles' theta_pdf).
    fn theta_pdf(&self, theta_r: f32, theta_i: f32, cos_i: f32) -> f32 {
        let (a, b) = self.limits(theta_r);
        let t = (theta_i + theta_r) * 0.5 - self.offset;
        self.r1 / (2.0 * (t * t + self.r1 * self.r1) * (a - b) * cos_i)
    }

    /// Cycles' transmission azimuth normalisation c_TT.
    fn c_tt(&self) -> f32 {
        2.0 * (FRAC_PI_2 / self.r2).atan()
    }

    /// Cycles' evaluation: the density (and value over the weight) at wi, for the surface
    /// normal `n`; 0 outside the lobe.
    pub fn pdf(&self, wo: Vec3, wi: Vec3, n: Vec3) -> f32 {
        if (wi.dot(n) < 0.0) != self.transmission {
            return 0.0;
        }
        let theta_r = wo.x.clamp(-1.0, 1.0).asin();
        // The angle and its cosine from the components across the fibre: asin and cos lose
        // their precision near the fibre's direction, where the density is steepest.
        let across = (wi.y * wi.y + wi.z * wi.z).sqrt();
        let theta_i = wi.x.atan2(across);
        if FRAC_PI_2 - theta_i.abs() < 0.001 || !(across > 0.0) {
            return 0.0;
        }
        let (ly, lz) = view_azimuth(wo);
        let cos_phi = ((wi.y * ly + wi.z * lz) / across).clamp(-1.0, 1.0);
        let phi_pdf = if self.transmission {
            let p = PI - cos_phi.acos();
            self.r2 / (self.c_tt() * (p * p + self.r2 * self.r2))
        } else {
            if cos_phi < 0.0 {
                return 0.0;
            }
            let phi = (cos_phi.acos() / self.r2).min(PI);
            (phi * 0.5).cos() * 0.25 / self.r2
        };
        (phi_pdf * self.theta_pdf(theta_r, theta_i, across)).max(0.0)
    }

    /// Cycles' sampling: (wi, density). The value is the weight times the density.
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<(Vec3, f32)> {
        let theta_r = wo.x.clamp(-1.0, 1.0).asin();
        let (a, b) = self.limits(theta_r);
        let t = self.r1 * (u.x * (a - b) + b).tan();
        let theta_i = 2.0 * (t + self.offset) - theta_r;
        let (sin_t, cos_t) = theta_i.sin_cos();
        let (phi, phi_pdf) = if self.transmission {
            let c = self.c_tt();
            let p = self.r2 * (c * (u.y - 0.5)).tan();
            (p + PI, self.r2 / (c * (p * p + self.r2 * self.r2)))
        } else {
            let phi = 2.0 * (1.0 - 2.0 * u.y).clamp(-1.0, 1.0).asin() * self.r2;
            (phi, (phi * 0.5 / self.r2).cos() * 0.25 / self.r2)
        };
        if FRAC_PI_2 - theta_i.abs() < 0.001 {
            return None;
        }
        // Cycles' cos φ cos θ locy − sin φ cos θ locx + sin θ T, with locx = locy × T.
        let (sin_p, cos_p) = phi.sin_cos();
        let (ly, lz) = view_azimuth(wo);
        let wi = Vec3::new(sin_t, cos_t * (cos_p * ly - sin_p * lz), cos_t * (cos_p * lz + sin_p * ly));
        let pdf = (phi_pdf * self.theta_pdf(theta_r, theta_i, cos_t)).abs();
        (pdf > 0.0 && pdf.is_finite()).then_some((wi, pdf))
    }
}

/// Cycles' `locy` in the frame (its y and z; x is 0): the unit direction across the fibre
/// toward the viewer; z when the viewer looks along the fibre.
#[inline]
fn view_azimuth(wo: Vec3) -> (f32, f32) {
    let l = (wo.y * wo.y + wo.z * wo.z).sqrt();
    if l > 0.0 { (wo.y / l, wo.z / l) } else { (0.0, 1.0) }
}

/// The Hair BSDF's lobes at a strand point: up to a Reflection and a Transmission (several
/// closures of one component add their weights; their other inputs are the first one's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairLobes {
    /// The lobes; `n` of them are used.
    pub lobes: [HairLobe; 2],
    /// Lobes in use.
    pub n: u8,
    /// The strand's surface normal at the hit, in the fibre's frame (Cycles' `bsdf->N`).
    pub normal: Vec3,
    /// On a triangle, the shading point's normal (Cycles' `sd->N`) where the lobes' normal is
    /// bent away from it: the evaluation is cut as `hair::BumpCut` says; None on a strand.
    pub smooth: Option<Vec3>,
}

impl HairLobes {
    /// No lobe.
    pub const EMPTY: HairLobes = HairLobes {
        lobes: [HairLobe { weight: Rgb::ZERO, transmission: false, offset: 0.0, r1: 1.0, r2: 1.0 }; 2],
        n: 0,
        normal: Vec3::Z,
        smooth: None,
    };

    /// The lobes at offset `h` across the fibre: the surface normal there.
    pub fn at(mut self, h: f32) -> Self {
        let h = h.clamp(-1.0, 1.0);
        self.normal = Vec3::new(0.0, h, (1.0 - h * h).max(0.0).sqrt());
        self
    }

    /// Adds a lobe: a second one of the same component adds its weight to the first's.
    pub fn push(&mut self, lobe: HairLobe) {
        let n = self.n as usize;
        if let Some(same) = self.lobes[..n].iter_mut().find(|l| l.transmission == lobe.transmission) {
            same.weight += lobe.weight;
        } else if n < 2 {
            self.lobes[n] = lobe;
            self.n += 1;
        }
    }

    /// The lobes in use.
    #[inline]
    pub fn used(&self) -> &[HairLobe] {
        &self.lobes[..self.n as usize]
    }

    /// True when Cycles' evaluation gives nothing toward `wi` (`hair::BumpCut`).
    #[inline]
    fn cuts(&self, wi: Vec3) -> bool {
        self.smooth.is_some_and(|ns| crate::bsdf::hair::BumpCut { ns, n: self.normal }.cuts(wi))
    }

    /// Each lobe's share of the samples: its weight's mean, normalised.
    fn selection(&self) -> [f32; 2] {
        let grey = |l: &HairLobe| ((l.weight.x + l.weight.y + l.weight.z) / 3.0).max(0.0);
        let mut s = [0.0; 2];
        let mut total = 0.0;
        for (k, l) in self.used().iter().enumerate() {
            s[k] = grey(l);
            total += s[k];
        }
        if total > 0.0 { s.map(|x| x / total) } else { [0.0; 2] }
    }

    /// f(wo, wi): Cycles' value over |cos θ| to the frame's z.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        let c = wi.z.abs();
        if c < 1e-7 || self.cuts(wi) {
            return Rgb::ZERO;
        }
        self.used().iter().fold(Rgb::ZERO, |f, l| f + l.weight * l.pdf(wo, wi, self.normal)) / c
    }

    /// Density with which `sample` picks wi.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.cuts(wi) {
            return 0.0;
        }
        let s = self.selection();
        self.used().iter().zip(s).map(|(l, s)| if s > 0.0 { s * l.pdf(wo, wi, self.normal) } else { 0.0 }).sum()
    }

    /// Samples wi: `uc` picks the lobe, `u` its direction. Returns (wi, f, pdf, transmitted).
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<(Vec3, Rgb, f32, bool)> {
        let s = self.selection();
        let k = if self.n > 1 && uc >= s[0] { 1 } else { 0 };
        if !(s[k] > 0.0) {
            return None;
        }
        let lobe = &self.lobes[k];
        let (wi, own) = lobe.sample(wo, u)?;
        let c = wi.z.abs();
        if c < 1e-7 {
            return None;
        }
        // The other lobe's share at wi (Cycles' evaluation, 0 on the sampled lobe's side).
        let other = if self.n > 1 { &self.lobes[1 - k] } else { lobe };
        let other_pdf = if self.n > 1 { other.pdf(wo, wi, self.normal) } else { 0.0 };
        let pdf = s[k] * own + s[1 - k] * other_pdf;
        let value = lobe.weight * own + if self.n > 1 { other.weight * other_pdf } else { Rgb::ZERO };
        Some((wi, value / c, pdf, lobe.transmission))
    }

    /// The lobes' summed weights (their albedo: each lobe returns its weight).
    pub fn albedo(&self) -> Rgb {
        self.used().iter().fold(Rgb::ZERO, |a, l| a + l.weight)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{ChiSquareTest, Pcg32, assert_chi2};

    fn wo_at(theta: f32) -> Vec3 {
        Vec3::new(theta.sin(), 0.0, theta.cos())
    }

    /// Chi-square of each lobe's sampler against its evaluation (src/sampling/chi2.rs), and of
    /// the two together; RoughnessV up to 0.5 for Reflection, where Cycles' sampled azimuths
    /// stay within the π/2 its evaluation keeps (above, see the module's comment).
    #[test]
    fn chi2_sampling() {
        for &(r1, r2) in &[(0.1f32, 0.3f32), (0.4, 0.5), (0.8, 0.2)] {
            for &theta in &[-0.9f32, 0.2, 1.1] {
                for &offset in &[0.0f32, 0.05] {
                    for transmission in [false, true] {
                        let mut lobes = HairLobes::EMPTY;
                        lobes.push(HairLobe::new(Rgb::new(0.8, 0.5, 0.3), transmission, offset, r1, r2));
                        if transmission {
                            lobes.push(HairLobe::new(Rgb::splat(0.4), false, offset, r1, r2));
                        }
                        let wo = wo_at(theta);
                        let mut rng = Pcg32::new(5);
                        let name = format!("hair bsdf T={transmission} u={r1} v={r2} θ={theta} offset={offset}");
                        assert_chi2(ChiSquareTest::new(&name).run_with_pdf(
                            |u| lobes.sample(wo, rng.next_f32(), u).map(|(wi, _, pdf, _)| (wi, pdf)),
                            |wi| lobes.pdf(wo, wi),
                        ));
                    }
                }
            }
        }
    }

    /// Cycles' value is the weight times the density: a sampled direction of one lobe carries
    /// its weight exactly (f |cos| / pdf), and the lobes keep their sides of the fibre.
    #[test]
    fn samples_carry_the_weight() {
        let mut rng = Pcg32::new(9);
        let weight = Rgb::new(0.8, 0.5, 0.3);
        for transmission in [false, true] {
            let mut lobes = HairLobes::EMPTY;
            lobes.push(HairLobe::new(weight, transmission, 0.03, 0.3, 0.4));
            for _ in 0..1000 {
                let u = Vec2::new(rng.next_f32(), rng.next_f32());
                if let Some((wi, f, pdf, t)) = lobes.sample(wo_at(0.4), rng.next_f32(), u) {
                    assert_eq!(t, transmission);
                    assert_eq!(wi.z < 0.0, transmission, "{wi:?}");
                    let w = f * (wi.z.abs() / pdf);
                    assert!((w - weight).abs().max_element() < 1e-4, "{w:?}");
                }
            }
        }
    }

    /// A frame turned about the fibre (a triangle's, whose z is its normal, not the viewer's
    /// direction across the fibre) gives the same lobes: densities, and samples that are the
    /// turned frame's samples turned, since Cycles measures azimuths from the viewer's.
    #[test]
    fn any_frame_about_the_fibre() {
        let mut rng = Pcg32::new(3);
        for beta in [0.7f32, -2.1, 3.0] {
            let turn = |v: Vec3| {
                let (s, c) = beta.sin_cos();
                Vec3::new(v.x, c * v.y - s * v.z, s * v.y + c * v.z)
            };
            let mut lobes = HairLobes::EMPTY;
            lobes.push(HairLobe::new(Rgb::new(0.8, 0.5, 0.3), false, 0.0, 0.3, 0.4));
            lobes.push(HairLobe::new(Rgb::splat(0.4), true, 0.0, 0.3, 0.4));
            let lobes = lobes.at(0.3);
            let turned = HairLobes { normal: turn(lobes.normal), ..lobes };
            let wo = wo_at(0.4);
            for _ in 0..500 {
                let wi = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize();
                let (a, b) = (lobes.pdf(wo, wi), turned.pdf(turn(wo), turn(wi)));
                assert!((a - b).abs() <= 1e-4 * a.max(1.0), "{a} vs {b}");
                let u = Vec2::new(rng.next_f32(), rng.next_f32());
                let uc = rng.next_f32();
                match (lobes.sample(wo, uc, u), turned.sample(turn(wo), uc, u)) {
                    (Some((wa, _, pa, _)), Some((wb, _, pb, _))) => {
                        assert!((turn(wa) - wb).length() < 1e-4, "{wa:?} {wb:?}");
                        assert!((pa - pb).abs() <= 1e-3 * pa.max(1.0), "{pa} vs {pb}");
                    }
                    (None, None) => {}
                    other => panic!("{other:?}"),
                }
            }
        }
    }
}
