//! `KHR_materials_diffuse_transmission`: the diffuse base of the opaque dielectric splits by
//! the factor t into the Lambertian BRDF of the base colour (1 − t) and a Lambertian BTDF of
//! the transmission colour (t) into the other hemisphere, under the same specular layer, as
//! the extension's spec mixes them:
//!
//! ```text
//! dielectric = fresnel_mix(layer = specular_brdf(α),
//!                          base = mix(diffuse_brdf(baseColor), diffuse_btdf(diffuseTransmissionColor), t))
//! ```
//!
//! The layer weights the whole base by 1 − max(E_layer(μo)) (Cycles' layering, as the diffuse
//! base alone had), so a white base and colour keep all the layer leaves, split t : 1 − t
//! between the two sides. The BTDF is a non-specular lobe sampled cosine-weighted around −Z,
//! so next-event estimation, BDPT's connections and photons see it. With
//! `KHR_materials_volume` the transmitted direction enters the volume as any crossing does
//! (the walk decides the medium by the ray's side); thin-walled otherwise.

use super::{PbrAt, PbrBsdf};
use crate::math::Rgb;
use glam::Vec3;
use std::f32::consts::FRAC_1_PI;

impl PbrAt<'_> {
    /// The Lambertian transmission's part of [`eval`](Self::eval) for `wi` as given (zero
    /// unless `wi` lies on the other side of the surface from wo).
    #[inline]
    pub fn eval_diffuse_transmission(&self, wi: Vec3) -> Rgb {
        // Where the coat alone reflects (`reflects_across`) Cycles cuts the Translucent closure.
        if self.reflects_across(wi) {
            return Rgb::ZERO;
        }
        let wi = if self.flip { Vec3::new(wi.x, wi.y, -wi.z) } else { wi };
        self.diffuse_transmission_up(wi)
    }

    /// [`eval_diffuse_transmission`](Self::eval_diffuse_transmission) for `wi` in the frame
    /// where wo is above the surface.
    #[inline]
    pub(super) fn diffuse_transmission_up(&self, wi: Vec3) -> Rgb {
        let b = self.b;
        if b.diffuse_transmission <= 0.0 || self.wo.z <= 0.0 || wi.z >= 0.0 {
            return Rgb::ZERO;
        }
        let opaque = (1.0 - b.metallic) * (1.0 - b.transmission);
        let weight = PbrBsdf::base_weight(self.eo) * (1.0 - b.subsurface) * b.diffuse_transmission * opaque;
        let scaling = b.sheen_scaling_from(self.sheen_o, -wi.z);
        b.diffuse_transmission_color * (weight * FRAC_1_PI * scaling) * self.under
    }
}

#[cfg(test)]
mod tests {
    //! The BTDF samples by its density (chi-square, in `tests.rs`' material list too), conserves
    //! energy in a white furnace, and a white sheet of factor 1 transmits what the specular
    //! layer leaves, by quadrature and by sampling.

    use super::super::{PbrBsdf, PbrParams};
    use crate::bsdf::albedo::TABLE_ERROR;
    use crate::bsdf::fresnel_layer::LAYER_TABLE_ERROR;
    use crate::math::Rgb;
    use crate::sampling::chi2::{ChiSquareTest, Pcg32, assert_chi2};
    use glam::{DVec3, Vec2, Vec3};

    fn sheet(base: Rgb, factor: f32, color: Rgb, roughness: f32, specular: f32) -> PbrBsdf {
        PbrBsdf::from_params(&PbrParams {
            diffuse_transmission: factor,
            diffuse_transmission_color: color,
            specular,
            ..PbrParams::opaque(base, 0.0, roughness)
        })
    }

    /// Mean and standard error per channel of the sampled weight f cos / pdf seen from `wo`,
    /// split into the reflected and the transmitted part.
    fn sampled_albedo(b: &PbrBsdf, wo: Vec3, n: usize, seed: u64) -> [(DVec3, DVec3); 2] {
        let mut rng = Pcg32::new(seed);
        let mut acc = [(DVec3::ZERO, DVec3::ZERO); 2];
        for _ in 0..n {
            let u = Vec2::new(rng.next_f32(), rng.next_f32());
            let Some(s) = b.sample(wo, rng.next_f32(), u) else { continue };
            let v = (s.f * (s.wi.z.abs() / s.pdf)).as_dvec3();
            let k = usize::from(s.wi.z * wo.z < 0.0);
            acc[k].0 += v;
            acc[k].1 += v * v;
        }
        acc.map(|(sum, sum2)| {
            let mean = sum / n as f64;
            (mean, ((sum2 / n as f64 - mean * mean).max(DVec3::ZERO) / n as f64).powf(0.5))
        })
    }

    #[test]
    fn chi2_diffuse_transmission() {
        for (factor, roughness, specular) in [(0.5f32, 0.5f32, 1.0f32), (1.0, 0.3, 1.0), (0.6, 0.8, 0.0)] {
            let b = sheet(Vec3::new(0.8, 0.4, 0.1), factor, Vec3::new(0.2, 0.9, 0.3), roughness, specular);
            for theta in [0.1f32, 0.9, 1.45, 2.5] {
                // θ > π/2: seen from below, the BSDF is two-sided.
                let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                let mut rng = Pcg32::new(5);
                let t = ChiSquareTest::new(&format!("diffuse transmission t={factor} r={roughness} θ={theta}"));
                assert_chi2(
                    t.run_with_pdf(|u| b.sample(wo, rng.next_f32(), u).map(|s| (s.wi, s.pdf)), |wi| b.pdf(wo, wi)),
                );
            }
        }
    }

    /// White furnace: base colour and transmission colour white, factor 0.5 and 1: reflected
    /// plus transmitted is 1 at every view angle (the layer reflects E(μo), the base gets
    /// 1 − E(μo), all of it leaves again), within 5 standard errors plus the layer table's
    /// error (scaled by its compensation, as the dielectric layer's furnace allows); and the
    /// transmitted share is the factor times what the layer leaves, 1 − max E(μo), read from
    /// the BSDF's own layer albedo (`at`), to the same bound.
    #[test]
    fn white_furnace_diffuse_transmission() {
        let n = 400_000;
        for factor in [0.5f32, 1.0] {
            for roughness in [0.3f32, 0.7, 1.0] {
                let b = sheet(Vec3::ONE, factor, Vec3::ONE, roughness, 1.0);
                for theta in [0.0f32, 0.7, 1.2, 1.45] {
                    let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                    let [(r, r_se), (t, t_se)] = sampled_albedo(&b, wo, n, 11);
                    let total = r.x + t.x;
                    let bound = 5.0 * (r_se.x + t_se.x) + 1.25 * LAYER_TABLE_ERROR + TABLE_ERROR;
                    eprintln!(
                        "t={factor} r={roughness} θ={theta}: R {:.4} + T {:.4} = {total:.4} (bound {bound:.4})",
                        r.x, t.x
                    );
                    assert!((total - 1.0).abs() <= bound, "t={factor} r={roughness} θ={theta}: albedo {total}");
                    let expected_t = f64::from(factor * PbrBsdf::base_weight(b.at(wo).eo));
                    assert!(
                        (t.x - expected_t).abs() <= 5.0 * t_se.x + 1e-6,
                        "t={factor} r={roughness} θ={theta}: transmitted {} vs {expected_t}",
                        t.x
                    );
                }
            }
        }
    }

    /// The analytic check of a backlit sheet (factor 1, colour white): a sun of irradiance E
    /// from straight behind gives, seen from the front at μo, radiance
    /// L = f_t(wo, −Z)·E = (1 − max E_layer(μo))·E/π, the layer's share seen from the viewer.
    /// At roughness 1 and IOR 1.5 that share is read from the layer table; here it is
    /// checked against an independent quadrature of the layer lobe alone (the BSDF with a black
    /// base and no transmission reflects exactly E_layer(μo)), within the quadrature's error,
    /// and the sheet's value itself against (1 − E)/π exactly.
    #[test]
    fn backlit_sheet_transmits_what_the_layer_leaves() {
        let n = 400_000;
        for theta in [0.0f32, 0.6, 1.2] {
            let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
            let b = sheet(Vec3::ONE, 1.0, Vec3::ONE, 1.0, 1.0);
            let f = b.eval(wo, -Vec3::Z);
            let layer = sheet(Vec3::ZERO, 0.0, Vec3::ONE, 1.0, 1.0);
            let [(e, e_se), _] = sampled_albedo(&layer, wo, n, 3);
            let expected = (1.0 - e.x) / std::f64::consts::PI;
            let bound = (5.0 * e_se.x + 1.25 * LAYER_TABLE_ERROR + TABLE_ERROR) / std::f64::consts::PI;
            eprintln!(
                "θ={theta}: f_t·π {:.4}, 1 − E_layer {:.4} ± {:.4}",
                f.x as f64 * std::f64::consts::PI,
                1.0 - e.x,
                e_se.x
            );
            assert!((f.x as f64 - expected).abs() <= bound, "θ={theta}: f_t {} vs {expected}", f.x);
            // Without a specular layer (specularFactor 0) the sheet is a pure Lambertian BTDF.
            let bare = sheet(Vec3::ONE, 1.0, Vec3::ONE, 1.0, 0.0);
            assert!((bare.eval(wo, -Vec3::Z).x - std::f32::consts::FRAC_1_PI).abs() < 1e-6);
            assert_eq!(bare.eval(wo, Vec3::Z), Rgb::ZERO, "factor 1 reflects nothing diffusely");
        }
    }

    /// The adjoint of a transmitted pair is the BSDF seen from the other side, f(wi, wo), with
    /// no 1/η² even when the material has a volume (thick): a sheet scattering, not a refraction.
    #[test]
    fn crossing_adjoint_is_f_seen_from_wi() {
        let p = PbrParams {
            diffuse_transmission: 0.7,
            diffuse_transmission_color: Vec3::new(0.3, 0.8, 0.2),
            thin: false,
            eta: 1.5,
            ..PbrParams::opaque(Vec3::splat(0.5), 0.0, 0.5)
        };
        let b = crate::bsdf::Bsdf::Pbr(PbrBsdf::from_params(&p));
        let wo = Vec3::new(0.3, 0.1, 0.9).normalize();
        let wi = Vec3::new(-0.5, 0.2, -0.7).normalize();
        let adj = b.eval_adjoint(wo, wi);
        let swapped = b.eval(wi, wo);
        assert!((adj - swapped).abs().max_element() < 1e-6, "{adj} vs {swapped}");
        assert!(adj.max_element() > 0.0);
    }
}
