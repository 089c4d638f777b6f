//! Tests of the glTF material BSDF: sampling against its density, reciprocity, energy.

use super::*;
use crate::bsdf::LobeKind;
use crate::bsdf::albedo::TABLE_ERROR;
use crate::bsdf::dielectric::refract;
use crate::bsdf::microfacet::reflect;
use crate::sampling::chi2::{ChiSquareTest, Pcg32, assert_chi2};
use crate::sampling::warp::cosine_hemisphere;

fn materials_with(base: Vec3) -> Vec<(String, PbrBsdf)> {
    let mut v = Vec::new();
    for roughness in [0.15f32, 0.5, 1.0] {
        for metallic in [0.0f32, 0.5, 1.0] {
            v.push((format!("r={roughness} m={metallic}"), PbrBsdf::new(base, metallic, roughness)));
        }
        for specular in [0.0f32, 0.5] {
            v.push((
                format!("r={roughness} specular={specular}"),
                PbrBsdf::with_specular(base, 0.0, roughness, specular),
            ));
        }
    }
    // Transmissive (rough: the chi-square needs densities), entering and leaving,
    // solid and thin, partly metallic, another IOR.
    for (transmission, eta, thin, metallic, ior) in [
        (1.0f32, 1.5f32, false, 0.0f32, 1.5f32),
        (1.0, 1.0 / 1.5, false, 0.0, 1.5),
        (0.5, 1.5, false, 0.0, 1.5),
        (1.0, 1.5, true, 0.0, 1.5),
        (0.7, 2.4, false, 0.3, 2.4),
    ] {
        for roughness in [0.3f32, 0.8] {
            let p = PbrParams {
                specular: 1.0,
                ior,
                transmission,
                thin,
                eta,
                ..PbrParams::opaque(base, metallic, roughness)
            };
            v.push((
                format!("r={roughness} transmission={transmission} η={eta} thin={thin} m={metallic}"),
                PbrBsdf::from_params(&p),
            ));
        }
    }
    // Sheen over a diffuse base, a metal and glass; a tinted specular layer.
    for (sheen, sr, metallic, transmission) in
        [(1.0f32, 0.3f32, 0.0f32, 0.0f32), (0.6, 0.8, 1.0, 0.0), (0.8, 0.5, 0.0, 1.0)]
    {
        let p = PbrParams {
            sheen_color: Vec3::new(sheen, sheen * 0.7, sheen * 0.4),
            sheen_roughness: sr,
            transmission,
            ..PbrParams::opaque(base, metallic, 0.5)
        };
        v.push((format!("sheen={sheen} sr={sr} m={metallic} t={transmission}"), PbrBsdf::from_params(&p)));
    }
    // Blender's microfiber sheen over a diffuse base, a metal and glass.
    for (sheen, sr, metallic, transmission) in
        [(1.0f32, 0.3f32, 0.0f32, 0.0f32), (0.7, 0.9, 1.0, 0.0), (0.8, 0.5, 0.0, 1.0)]
    {
        let p = PbrParams {
            sheen_color: Vec3::new(sheen, sheen * 0.7, sheen * 0.4),
            sheen_roughness: sr,
            microfiber_sheen: true,
            transmission,
            ..PbrParams::opaque(base, metallic, 0.5)
        };
        v.push((format!("microfiber sheen={sheen} sr={sr} m={metallic} t={transmission}"), PbrBsdf::from_params(&p)));
    }
    for roughness in [0.2f32, 0.6] {
        let p =
            PbrParams { specular_color: Vec3::new(3.0, 1.0, 0.2), ior: 1.8, ..PbrParams::opaque(base, 0.0, roughness) };
        v.push((format!("specular colour r={roughness}"), PbrBsdf::from_params(&p)));
    }
    // Coated: over a diffuse base, a metal and glass; the coat breaks reciprocity
    // (albedo scaling by wo), so the reciprocity test skips these.
    for (coat, coat_roughness, metallic, transmission) in
        [(1.0f32, 0.1f32, 0.0f32, 0.0f32), (0.5, 0.4, 1.0, 0.0), (1.0, 0.3, 0.0, 1.0)]
    {
        let p = PbrParams { coat, coat_roughness, transmission, ..PbrParams::opaque(base, metallic, 0.6) };
        v.push((format!("coat={coat} cr={coat_roughness} m={metallic} t={transmission}"), PbrBsdf::from_params(&p)));
    }
    // Blender's coat IOR and tint (CAUSTIC_materials_coat).
    let p = PbrParams {
        coat: 1.0,
        coat_roughness: 0.3,
        coat_ior: 1.8,
        coat_tint: Vec3::new(0.8, 0.5, 0.3),
        ..PbrParams::opaque(base, 0.0, 0.5)
    };
    v.push(("coat ior 1.8 tinted".into(), PbrBsdf::from_params(&p)));
    // Cycles' coat Fresnel (Blender's materials): the exact dielectric one, flat and with its
    // own normal.
    for coat_normal in [Some(Vec3::new(0.3, -0.2, 0.93)), None] {
        let p = PbrParams {
            coat: 1.0,
            coat_roughness: 0.3,
            coat_ior: 1.8,
            coat_normal,
            coat_dielectric_fresnel: true,
            ..PbrParams::opaque(base, 0.0, 0.5)
        };
        // Schlick's too: at IOR 1.8 its coat with its own normal, seen at 83°, sampled below the
        // coat's horizon, which its density does not count (chi-square p = 2e-9 before).
        let q = PbrParams { coat_dielectric_fresnel: false, ..p };
        v.push((format!("coat schlick ior 1.8 n={coat_normal:?}"), PbrBsdf::from_params(&q)));
        v.push((format!("coat dielectric fresnel n={coat_normal:?}"), PbrBsdf::from_params(&p)));
    }
    // A coat with its own normal (clearcoatNormalTexture), rough and smooth.
    for coat_roughness in [0.3f32, 0.1] {
        let p = PbrParams {
            coat: 1.0,
            coat_roughness,
            coat_normal: Some(Vec3::new(0.3, -0.2, 0.93)),
            ..PbrParams::opaque(base, 0.0, 0.5)
        };
        v.push((format!("coat normal cr={coat_roughness}"), PbrBsdf::from_params(&p)));
    }
    // A coat on sd->N over a normal-mapped base (the frame is the mapped normal, sd->N tilted
    // 30° from it): below the frame's horizon but above the coat's, only the coat reflects
    // (`PbrBsdf::coat_across`), sampled and counted there; glass and diffuse transmission
    // samples landing there are refused, and their density is not counted. No specular layer:
    // its own samples are not cut where its density is (Cycles' rule), which this test would
    // read as a mismatch.
    let ns = Vec3::new(-0.5, 0.0, 0.866);
    for (transmission, diffuse_transmission, coat_roughness) in [(0.0, 0.0, 0.3), (0.0, 0.6, 0.5)] {
        let p = PbrParams {
            specular: 0.0,
            coat: 1.0,
            coat_roughness,
            coat_normal: Some(ns),
            cut_normal: Some(ns),
            smooth_normal: Some(ns),
            coat_dielectric_fresnel: true,
            transmission,
            thin: false,
            diffuse_transmission,
            diffuse_transmission_color: Vec3::new(0.9, 0.8, 0.7),
            ..PbrParams::opaque(base, 0.0, 0.4)
        };
        v.push((
            format!("coat across the frame t={transmission} dt={diffuse_transmission} cr={coat_roughness}"),
            PbrBsdf::from_params(&p),
        ));
    }
    // Anisotropic metal and plastic (glTF's mapping αx = mix(α, 1, s²), αy = α).
    for (metallic, roughness, strength) in [(1.0f32, 0.3f32, 0.8f32), (0.0, 0.5, 1.0), (0.5, 0.2, 0.5)] {
        let a = roughness * roughness;
        let p = PbrParams {
            anisotropy: Some((a + (1.0 - a) * strength * strength, a)),
            ..PbrParams::opaque(base, metallic, roughness)
        };
        v.push((format!("anisotropic m={metallic} r={roughness} s={strength}"), PbrBsdf::from_params(&p)));
    }
    // Blender's Principled BSDF as Cycles builds it: a rough diffuse base (Oren-Nayar), on its
    // own normal too; anisotropic lobes with Cycles' albedo proxy; glass tinted by √base.
    for (sigma, metallic, transmission, aniso, normal) in
        [(1.0f32, 0.0f32, 0.0f32, false, false), (0.5, 0.3, 0.0, true, false), (0.8, 0.0, 0.5, false, true)]
    {
        let a = 0.4f32 * 0.4;
        let aspect = (1.0f32 - 0.9 * 0.8).sqrt();
        let p = PbrParams {
            diffuse_roughness: sigma,
            cycles_principled: true,
            transmission,
            eta: 1.5,
            thin: false,
            anisotropy: aniso.then_some((a / aspect, a * aspect)),
            diffuse_normal: normal.then_some(Vec3::new(0.5, 0.1, 0.86)),
            ..PbrParams::opaque(base, metallic, 0.4)
        };
        v.push((format!("principled σ={sigma} m={metallic} t={transmission} aniso={aniso}"), PbrBsdf::from_params(&p)));
    }
    // A diffuse base on its own (unbent) normal below a bent frame, tilted and turned away.
    for (nx, nz, metallic) in [(0.6f32, 0.8f32, 0.0f32), (0.95, -0.3, 0.3)] {
        let p = PbrParams {
            diffuse_normal: Some(Vec3::new(nx, 0.1, nz)),
            smooth_normal: Some(Vec3::new(0.2, -0.1, 0.97)),
            ..PbrParams::opaque(base, metallic, 0.4)
        };
        v.push((format!("diffuse normal ({nx}, 0.1, {nz}) m={metallic}"), PbrBsdf::from_params(&p)));
    }
    // KHR_materials_diffuse_transmission: alone, half, under sheen and coat, beside glass,
    // with a metal, without a specular layer.
    for (t, metallic, transmission, sheen, coat, specular) in [
        (1.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32, 1.0f32),
        (0.5, 0.0, 0.0, 0.0, 0.0, 1.0),
        (0.6, 0.3, 0.0, 0.5, 0.0, 1.0),
        (0.8, 0.0, 0.4, 0.0, 0.0, 1.0),
        (0.7, 0.0, 0.0, 0.0, 0.8, 1.0),
        (0.6, 0.0, 0.0, 0.0, 0.0, 0.0),
    ] {
        let p = PbrParams {
            diffuse_transmission: t,
            diffuse_transmission_color: Vec3::new(0.3, 0.9, 0.2),
            transmission,
            sheen_color: Vec3::splat(sheen),
            sheen_roughness: 0.4,
            coat,
            coat_roughness: 0.3,
            specular,
            ..PbrParams::opaque(base, metallic, 0.5)
        };
        v.push((
            format!("diffuse transmission={t} m={metallic} t={transmission} sheen={sheen} coat={coat} s={specular}"),
            PbrBsdf::from_params(&p),
        ));
    }
    v
}

fn materials() -> Vec<(String, PbrBsdf)> {
    materials_with(Vec3::new(0.8, 0.4, 0.1))
}

#[test]
fn chi2_pbr_lobes() {
    for (name, b) in materials() {
        for theta in [0.1f32, 0.9, 1.45] {
            let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
            let mut rng = Pcg32::new(3);
            let t = ChiSquareTest::new(&format!("glTF PBR {name} θ={theta}"));
            assert_chi2(t.run_with_pdf(|u| b.sample(wo, rng.next_f32(), u).map(|s| (s.wi, s.pdf)), |wi| b.pdf(wo, wi)));
        }
    }
}

/// Reciprocity: f(wo, wi) = f(wi, wo) for the whole BRDF (the Fresnel term uses the
/// half vector, which is symmetric), except where the coat, the dielectric layer or the
/// multiple-scattering compensation scale by what is seen from wo (as Cycles).
#[test]
fn reciprocity() {
    let mut rng = Pcg32::new(9);
    let layered = |b: &PbrBsdf| b.layer && b.metallic < 1.0 && b.transmission < 1.0;
    let compensated =
        |b: &PbrBsdf| (b.metallic > 0.0 && !b.smooth) || (b.transmission > 0.0 && !b.glass.smooth) || layered(b);
    // A diffuse normal apart from the frame's takes its cosine to another normal, as the coat.
    // So does the microfiber sheen, which scales the layers below by its albedo at wo.
    let own_normals = |b: &PbrBsdf| b.coat > 0.0 || b.diffuse_frame.is_some() || b.microfiber;
    for (_, b) in materials().into_iter().filter(|(_, b)| !own_normals(b) && !compensated(b)) {
        for _ in 0..200 {
            let a = cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let c = cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let f1 = b.eval(a, c);
            let f2 = b.eval(c, a);
            assert!((f1 - f2).abs().max_element() <= 1e-4 * f1.max_element().max(1.0));
        }
    }
}

/// The metal's multiple-scattering factor, seen from wo, is its only departure from
/// reciprocity: f(a, c) / ms(a) = f(c, a) / ms(c), coloured and rough.
#[test]
fn metal_multiscatter_is_a_factor_of_wo() {
    let mut rng = Pcg32::new(4);
    for roughness in [0.3f32, 0.7, 1.0] {
        let b = PbrBsdf::new(Vec3::new(0.9, 0.5, 0.2), 1.0, roughness);
        for _ in 0..200 {
            let a = cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let c = cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let f1 = b.eval(a, c) / b.at(a).metal_ms;
            let f2 = b.eval(c, a) / b.at(c).metal_ms;
            assert!((f1 - f2).abs().max_element() <= 1e-4 * f1.max_element().max(1.0), "{f1} vs {f2}");
        }
    }
}

/// The dielectric layer departs from reciprocity only by factors of wo, as Cycles': over a
/// black base its lobe divided by its compensation at wo is symmetric, and over a white base
/// the diffuse part divided by the base's weight 1 − max(E(wo)) is the symmetric Lambertian.
#[test]
fn dielectric_layer_is_reciprocal_but_for_factors_of_wo() {
    let mut rng = Pcg32::new(5);
    for (roughness, ior, tint) in
        [(0.3f32, 1.5f32, Vec3::ONE), (0.8, 1.5, Vec3::ONE), (0.5, 2.4, Vec3::new(1.0, 0.5, 0.2))]
    {
        let params = |base| PbrParams { ior, specular_color: tint, ..PbrParams::opaque(base, 0.0, roughness) };
        let black = PbrBsdf::from_params(&params(Vec3::ZERO));
        let white = PbrBsdf::from_params(&params(Vec3::ONE));
        for _ in 0..200 {
            let a = cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let c = cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let f1 = black.eval(a, c) / black.at(a).layer_ms;
            let f2 = black.eval(c, a) / black.at(c).layer_ms;
            assert!((f1 - f2).abs().max_element() <= 1e-4 * f1.max_element().max(1.0), "{f1} vs {f2}");
            let (wa, wc) = (white.at(a), white.at(c));
            let d1 = wa.eval_diffuse(c) / PbrBsdf::base_weight(wa.eo);
            let d2 = wc.eval_diffuse(a) / PbrBsdf::base_weight(wc.eo);
            assert!((d1 - d2).abs().max_element() <= 1e-5, "{d1} vs {d2}");
            assert!((d1 - Vec3::splat(std::f32::consts::FRAC_1_PI)).abs().max_element() <= 1e-5);
        }
    }
}

/// The adjoint of rough refraction: `Bsdf::eval_adjoint(wo, wi)` = f(wi, wo), evaluated by
/// the same glass seen from wi's side (relative IOR 1/η, frame turned over), for tinted
/// solid and thin glass whose compensation differs between the two sides.
#[test]
fn refraction_adjoint_is_the_other_sides_bsdf() {
    let mut rng = Pcg32::new(6);
    for (eta, thin) in [(1.5f32, false), (1.0 / 1.5, false), (1.33, true)] {
        for roughness in [0.3f32, 0.8] {
            let params = |eta| PbrParams {
                transmission: 1.0,
                thin,
                eta,
                ..PbrParams::opaque(Vec3::new(0.9, 0.6, 0.3), 0.0, roughness)
            };
            let here = super::super::Bsdf::Pbr(PbrBsdf::from_params(&params(eta)));
            let there = PbrBsdf::from_params(&params(if thin { eta } else { 1.0 / eta }));
            let turn = |w: Vec3| Vec3::new(w.x, w.y, -w.z);
            let mut checked = 0;
            for _ in 0..400 {
                let wo = cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let wi = turn(cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32())));
                let adjoint = here.eval_adjoint(wo, wi);
                let other = there.eval(turn(wi), turn(wo));
                if other.max_element() > 1e-3 {
                    checked += 1;
                }
                assert!(
                    (adjoint - other).abs().max_element() <= 2e-4 * other.max_element().max(1.0),
                    "η={eta} thin={thin} r={roughness}: {adjoint} vs {other}"
                );
            }
            assert!(checked > 20, "too few pairs inside the lobe");
        }
    }
}

/// A perfectly smooth metal is a delta mirror whose sampled weight is Schlick's
/// Fresnel; a smooth dielectric over black is one too, weighted by its layer albedo.
#[test]
fn smooth_reflection_is_a_delta_mirror() {
    let metal = PbrBsdf::new(Vec3::new(0.9, 0.6, 0.3), 1.0, 0.0);
    assert!(metal.is_delta());
    let wo = Vec3::new(0.6, 0.0, 0.8);
    let s = metal.sample(wo, 0.5, Vec2::new(0.3, 0.7)).unwrap();
    assert!(s.delta && (s.wi - Vec3::new(-0.6, 0.0, 0.8)).length() < 1e-6);
    let weight = s.f * s.wi.z / s.pdf;
    let expect = metal.base + (Vec3::ONE - metal.base) * schlick_weight(0.8);
    assert!((weight - expect).abs().max_element() < 1e-5, "{weight} vs {expect}");
    assert_eq!(metal.eval(wo, s.wi), Vec3::ZERO);
    // A smooth dielectric with a diffuse base is not a pure delta BSDF.
    assert!(!PbrBsdf::new(Vec3::splat(0.5), 0.0, 0.0).is_delta());
    assert!(PbrBsdf::new(Vec3::ZERO, 0.0, 0.0).is_delta());
}

/// Energy: the directional albedo ∫ f cos dwi ≤ 1 at every angle, estimated by
/// importance sampling with N samples; the bound allows 5 standard errors of the
/// estimate (its sample standard deviation / √N) plus the albedo table's error.
#[test]
fn albedo_at_most_one() {
    let n = 200_000;
    for (name, b) in materials_with(Vec3::ONE) {
        for theta in [0.0f32, 0.5, 1.0, 1.5] {
            let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
            let mut rng = Pcg32::new(1);
            // Per channel: a tinted layer has coloured weights, and the mean of the
            // largest channel would overstate every channel's albedo.
            let (mut sum, mut sum2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
            for _ in 0..n {
                let u = Vec2::new(rng.next_f32(), rng.next_f32());
                let v = b
                    .sample(wo, rng.next_f32(), u)
                    // Cycles' convention: a refracted sample's weight has no η².
                    .map(|s| (s.f * (s.wi.z.abs() / s.pdf)).as_dvec3())
                    .unwrap_or(glam::DVec3::ZERO);
                sum += v;
                sum2 += v * v;
            }
            let mean = sum / n as f64;
            let se = ((sum2 / n as f64 - mean * mean).max(glam::DVec3::ZERO) / n as f64).powf(0.5);
            for c in 0..3 {
                // The compensated lobes are exact to within 1 % (the white furnace test).
                let allowed = if b.metal_fms != Rgb::ZERO || b.glass.multiscatter(wo) != Rgb::ONE { 1e-2 } else { 0.0 };
                // The dielectric layer's table error, scaled by its compensation (as in the
                // dielectric layer's furnace).
                let allowed = allowed + 1.25 * crate::bsdf::fresnel_layer::LAYER_TABLE_ERROR;
                assert!(
                    mean[c] <= 1.0 + 5.0 * se[c] + TABLE_ERROR + allowed,
                    "{name} θ={theta} channel {c}: albedo {} ± {}",
                    mean[c],
                    se[c]
                );
            }
        }
    }
}

/// A tinted specular layer reflects its tint: at normal incidence over a black base the
/// sampled weight per channel follows F0 = min(F0(ior) × colour, 1).
#[test]
fn specular_colour_tints_f0() {
    let p = PbrParams { specular_color: Vec3::new(2.0, 1.0, 0.0), ..PbrParams::opaque(Vec3::ZERO, 0.0, 0.0) };
    let b = PbrBsdf::from_params(&p);
    let s = b.sample(Vec3::Z, 0.0, Vec2::splat(0.5)).unwrap();
    let w = s.f * s.wi.z / s.pdf;
    let f0 = f0_from_ior(1.5);
    // The delta mirror's weight is the layer albedo, which at μ = 1 is about F0.
    assert!((w.x / w.y - 2.0).abs() < 0.05 && w.z < 0.2 * w.y, "{w} for F0 {f0}");
}

/// A white Lambertian on its own normal, tilted θ from the frame's (a bent shading normal),
/// reflects the light of the frame's upper hemisphere only: its albedo is the view factor
/// of a plane tilted by θ to the sky, (1 + cos θ)/2.
#[test]
fn diffuse_normal_sees_the_frames_hemisphere() {
    for theta in [0.0f32, 0.5, 1.2, 2.0] {
        let p = PbrParams {
            specular: 0.0,
            diffuse_normal: Some(Vec3::new(theta.sin(), 0.0, theta.cos())),
            ..PbrParams::opaque(Vec3::ONE, 0.0, 0.5)
        };
        let b = PbrBsdf::from_params(&p);
        let wo = Vec3::new(-0.3, 0.2, 0.93).normalize();
        let mut rng = Pcg32::new(5);
        let n = 100_000;
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let u = Vec2::new(rng.next_f32(), rng.next_f32());
            let v = b.sample(wo, rng.next_f32(), u).map_or(0.0, |s| (s.f.x * s.wi.z / s.pdf) as f64);
            sum += v;
            sum2 += v * v;
        }
        let mean = sum / n as f64;
        let se = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
        let want = 0.5 * (1.0 + theta.cos() as f64);
        // Five standard errors of the estimate (its only error: the estimator is the exact
        // integrand over its exact density).
        assert!((mean - want).abs() <= 5.0 * se + 1e-6, "θ={theta}: albedo {mean} ± {se}, view factor {want}");
    }
}

/// The bump terminator's shadowing: none for light along the interpolated normal, falling
/// monotonically towards grazing light, zero for light that the interpolated normal and the
/// mapped one put on different sides; and G1 = 2 / (1 + √(1 + α² tan²θ)) at one point
/// worked by hand (α² = tan²30° / 8 = 1/24, θi = 60°: tan² = 3, G1 = 2 / (1 + √1.125)).
#[test]
fn bump_shadowing_of_the_diffuse_base() {
    let ns = Vec3::Z;
    let t = 30f32.to_radians();
    let n = Vec3::new(t.sin(), 0.0, t.cos());
    let alpha2 = t.tan().powi(2) / 8.0;
    assert!((bump_shadowing(ns, n, Vec3::Z, alpha2) - 1.0).abs() < 1e-6);
    let mut last = 1.0;
    for deg in [20.0f32, 40.0, 60.0, 80.0, 89.0] {
        let wi = Vec3::new(deg.to_radians().sin(), 0.0, deg.to_radians().cos());
        let g = bump_shadowing(ns, n, wi, alpha2);
        assert!(g < last && g > 0.0, "{deg}°: {g}");
        last = g;
    }
    let w60 = Vec3::new(60f32.to_radians().sin(), 0.0, 0.5);
    assert!((bump_shadowing(ns, n, w60, alpha2) - 2.0 / (1.0 + 1.125f32.sqrt())).abs() < 1e-5);
    // Above the mapped normal's horizon, below the interpolated one's.
    let under = Vec3::new(0.99, 0.0, -0.1).normalize();
    assert!(n.dot(under) > 0.0 && bump_shadowing(ns, n, under, alpha2) == 0.0);
}

/// The terminator's roughness as Cycles' `bump_shadowing_term` reads the deviation: none
/// where the normals agree, tan²θd / 8 up to 1, and 1 where they are perpendicular (Cycles'
/// saturated infinite tangent; this returned None there, so a normal map's normal at right
/// angles to the surface was neither shadowed nor smoothed).
#[test]
fn bump_alpha2_as_cycles() {
    assert_eq!(bump_alpha2(Vec3::Z, Vec3::Z), None);
    let t = 30f32.to_radians();
    let a = bump_alpha2(Vec3::Z, Vec3::new(t.sin(), 0.0, t.cos())).unwrap();
    assert!((a - t.tan().powi(2) / 8.0).abs() < 1e-6, "{a}");
    assert_eq!(bump_alpha2(Vec3::Z, Vec3::X), Some(1.0));
    assert_eq!(bump_alpha2(Vec3::Z, Vec3::new(0.0, 0.99, -0.141).normalize()), Some(1.0));
}

/// White furnace of the dielectric layer: a white base under the layer reflects exactly what
/// the layer leaves it, so the albedo is 1 at every roughness, IOR and angle, within 5
/// standard errors of the sampled estimate plus the layer table's error scaled by the
/// compensation (at most 1.25 where E ≥ 0.3 and F_ms ≤ 0.1, the layer's bounds here).
#[test]
fn white_furnace_dielectric_layer() {
    use crate::bsdf::fresnel_layer::LAYER_TABLE_ERROR;
    let n = 200_000;
    for roughness in [0.2f32, 0.5, 0.8, 1.0] {
        for ior in [1.5f32, 2.4, 1000.0] {
            let b = PbrBsdf::from_params(&PbrParams { ior, ..PbrParams::opaque(Vec3::ONE, 0.0, roughness) });
            for theta in [0.0f32, 0.8, 1.3] {
                let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                let mut rng = Pcg32::new(2);
                let (mut sum, mut sum2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
                for _ in 0..n {
                    let u = Vec2::new(rng.next_f32(), rng.next_f32());
                    let v = b
                        .sample(wo, rng.next_f32(), u)
                        .map(|s| (s.f * (s.wi.z.abs() / s.pdf)).as_dvec3())
                        .unwrap_or(glam::DVec3::ZERO);
                    sum += v;
                    sum2 += v * v;
                }
                let mean = sum / n as f64;
                let se = ((sum2 / n as f64 - mean * mean).max(glam::DVec3::ZERO) / n as f64).powf(0.5);
                let bound = 5.0 * se.x + 1.25 * LAYER_TABLE_ERROR;
                assert!(
                    (mean.x - 1.0).abs() <= bound,
                    "r={roughness} ior={ior} θ={theta}: albedo {} ± {}",
                    mean.x,
                    se.x
                );
            }
        }
    }
}

/// The red channel's albedo seen from `wo` by `n` BSDF samples of seed `seed`: its mean and
/// standard error.
fn sampled_albedo(b: &PbrBsdf, wo: Vec3, n: usize, seed: u64) -> (f64, f64) {
    let mut rng = Pcg32::new(seed);
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        let v = b.sample(wo, rng.next_f32(), u).map_or(0.0, |s| (s.f.x * s.wi.z.abs() / s.pdf) as f64);
        sum += v;
        sum2 += v * v;
    }
    let mean = sum / n as f64;
    (mean, ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt())
}

/// White furnace of Cycles' coat (exact dielectric Fresnel of the Coat IOR) over a white
/// Lambertian base: the coat reflects its albedo E_c(μo) = F0 A + B (the layer table's split at
/// the coat's η) and leaves 1 − E_c to the base, so the sum is 1 only if that albedo is what
/// the coat's lobe reflects. Bound: 5 standard errors plus the layer table's error.
#[test]
fn white_furnace_coat_dielectric_fresnel() {
    use crate::bsdf::fresnel_layer::LAYER_TABLE_ERROR;
    let n = 100_000;
    for coat_roughness in [0.1f32, 0.3, 0.7] {
        for coat_ior in [1.5f32, 2.5] {
            let b = PbrBsdf::from_params(&PbrParams {
                specular: 0.0,
                coat: 1.0,
                coat_roughness,
                coat_ior,
                coat_dielectric_fresnel: true,
                ..PbrParams::opaque(Vec3::ONE, 0.0, 0.5)
            });
            for theta in [0.0f32, 0.8, 1.3] {
                let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                let (mean, se) = sampled_albedo(&b, wo, n, 3);
                assert!(
                    (mean - 1.0).abs() <= 5.0 * se + LAYER_TABLE_ERROR,
                    "cr={coat_roughness} ior={coat_ior} θ={theta}: albedo {mean} ± {se}"
                );
            }
        }
    }
}

/// White furnace of a coat whose normal (Cycles' sd->N, `cut_normal`) leans 35° from the
/// shading frame's (a normal-mapped base) over a white Lambertian base on the frame, seen from
/// the side away from the lean, where much of the coat's lobe lies below the frame's horizon:
/// the coat reflects its albedo E_c(μo) about its own normal there too (`coat_across`), the base
/// takes 1 − E_c, so the sum is 1 (0.837 ± 0.001 at roughness 0.1, θ 0.6 while the coat stopped at
/// the frame's horizon). A
/// lobe beyond its albedo would make more than 1. Bound: 5 standard errors plus the table's error.
#[test]
fn white_furnace_coat_across_the_frame() {
    use crate::bsdf::fresnel_layer::LAYER_TABLE_ERROR;
    let n = 100_000;
    let ns = Vec3::new(35f32.to_radians().sin(), 0.0, 35f32.to_radians().cos());
    for coat_roughness in [0.1f32, 0.3, 0.6] {
        let b = PbrBsdf::from_params(&PbrParams {
            specular: 0.0,
            coat: 1.0,
            coat_roughness,
            coat_normal: Some(ns),
            cut_normal: Some(ns),
            coat_dielectric_fresnel: true,
            ..PbrParams::opaque(Vec3::ONE, 0.0, 0.5)
        });
        for theta in [0.3f32, 0.6, 0.8] {
            let wo = Vec3::new(-theta.sin(), 0.0, theta.cos());
            let (mean, se) = sampled_albedo(&b, wo, n, 5);
            assert!(
                (mean - 1.0).abs() <= 5.0 * se + LAYER_TABLE_ERROR,
                "cr={coat_roughness} θ={theta}: albedo {mean} ± {se}"
            );
        }
    }
}

/// White furnace of a layer of IOR 0.5 (Blender's Principled keeps an IOR below 1, as Cycles):
/// the layer reflects its own albedo, E_η = ms (F0 A_η + B_η) with the Fresnel of η < 1 (total
/// internal reflection included), ms Cycles' compensation 1 + F_ms (1/E − 1) with F_ss from
/// s_avg(η); the white base under it reflects 1 − ms (F0 A_{1/η} + B_{1/η}), Cycles' estimate,
/// which reads its η > 1 table at the same z, the entry of 1/η. So the albedo is not 1 (Cycles
/// gains energy there), but their sum, each (A, B) by a 4× finer quadrature than the table's.
/// Smooth, the layer is a mirror: F_η(μ) + 1 − F_{1/η}(μ). Bound: 5 standard errors of the
/// sampled estimate, plus the layer table's error (the base weight) and the quadrature's (the
/// expectation; the table test bounds both by LAYER_TABLE_ERROR), scaled by the compensation
/// (at most 1.25, as in the η > 1 furnace), plus the Schlick table's error (its E).
#[test]
fn white_furnace_ior_below_one() {
    use crate::bsdf::fresnel_layer::{LAYER_TABLE_ERROR, fresnel_s_avg, layer_split};
    use crate::bsdf::microfacet::fresnel_dielectric;
    let n = 200_000;
    let eta = 0.5f32;
    let f0 = f0_from_ior(eta);
    for roughness in [0.0f32, 0.3, 0.7] {
        let b = PbrBsdf::from_params(&PbrParams {
            ior: eta,
            cycles_principled: true,
            ..PbrParams::opaque(Vec3::ONE, 0.0, roughness)
        });
        for theta in [0.0f32, 0.8, 1.3] {
            let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
            let expect = if roughness < SMOOTH_ROUGHNESS {
                (fresnel_dielectric(wo.z, eta) + 1.0 - fresnel_dielectric(wo.z, 1.0 / eta)) as f64
            } else {
                let e = specular_albedo().e_white(wo.z, roughness);
                let (a_avg, b_avg) = specular_albedo().ab_avg(roughness);
                let e_avg = a_avg + b_avg;
                let f_ss = f0 + (1.0 - f0) * fresnel_s_avg(eta);
                let f_ms = f_ss * e_avg / (1.0 - f_ss * (1.0 - e_avg));
                let ms = 1.0 + f_ms * (1.0 / e - 1.0);
                let (a, bb) = layer_split(wo.z, roughness, eta, 96);
                let (ai, bi) = layer_split(wo.z, roughness, 1.0 / eta, 96);
                (ms * (f0 * a + bb) + 1.0 - ms * (f0 * ai + bi)) as f64
            };
            let (mean, se) = sampled_albedo(&b, wo, n, 5);
            let bound = 5.0 * se + 1.25 * 2.0 * LAYER_TABLE_ERROR + TABLE_ERROR;
            assert!(
                (mean - expect).abs() <= bound,
                "r={roughness} θ={theta}: albedo {mean} ± {se} vs {expect} (bound {bound})"
            );
            // Off normal incidence the layer of η < 1 reflects more than 1/η's estimate says.
            assert!(theta == 0.0 || expect > 1.0, "r={roughness} θ={theta}: {expect}");
        }
    }
}

/// The rough layer of IOR below 1 samples by its density (chi-square), over a coloured base,
/// with Specular IOR Level 0.25 too.
#[test]
fn chi2_ior_below_one() {
    for (ior, specular) in [(0.5f32, 1.0f32), (0.7, 0.5), (1e-5, 1.0)] {
        for roughness in [0.3f32, 0.8] {
            let p = PbrParams { ior, specular, ..PbrParams::opaque(Vec3::new(0.8, 0.4, 0.1), 0.0, roughness) };
            let b = PbrBsdf::from_params(&p);
            assert!(b.layer_eta() < 1.0);
            for theta in [0.1f32, 0.9, 1.45] {
                let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                let mut rng = Pcg32::new(9);
                let t = ChiSquareTest::new(&format!("IOR {ior} level {specular} r={roughness} θ={theta}"));
                assert_chi2(
                    t.run_with_pdf(|u| b.sample(wo, rng.next_f32(), u).map(|s| (s.wi, s.pdf)), |wi| b.pdf(wo, wi)),
                );
            }
        }
    }
}

/// A thin film on the dielectric layer: a smooth black dielectric's mirror at normal
/// incidence reflects the film's RGB reflectance on glass (no F0 rescaling at Specular IOR
/// Level 0.5: F0 = F0_η), within the table's error of E(μ = 1) = 1; and the rough layer with a
/// film samples by its density (chi-square), over a coloured base.
#[test]
fn thin_film_on_the_layer() {
    use crate::bsdf::thin_film::film_reflectance;
    let film = Some((400.0f32, 1.33f32, 1.0f32));
    let b = PbrBsdf::from_params(&PbrParams { thin_film: film, ..PbrParams::opaque(Vec3::ZERO, 0.0, 0.0) });
    let s = b.sample(Vec3::Z, 0.0, Vec2::splat(0.5)).unwrap();
    let w = s.f * s.wi.z / s.pdf;
    let want = film_reflectance(1.0, 1.33, 400.0, 1.5);
    assert!((w - want).abs().max_element() < TABLE_ERROR as f32, "{w} vs {want}");
    // A free film (IOR 1: no layer without it) still reflects.
    let soap =
        PbrBsdf::from_params(&PbrParams { ior: 1.0, thin_film: film, ..PbrParams::opaque(Vec3::ZERO, 0.0, 0.0) });
    let s = soap.sample(Vec3::Z, 0.0, Vec2::splat(0.5)).unwrap();
    assert!((s.f * s.wi.z / s.pdf).max_element() > 0.01);
    for roughness in [0.3f32, 0.7] {
        let p = PbrParams { thin_film: film, ..PbrParams::opaque(Vec3::new(0.2, 0.5, 0.3), 0.0, roughness) };
        let b = PbrBsdf::from_params(&p);
        for theta in [0.1f32, 0.9, 1.45] {
            let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
            let mut rng = Pcg32::new(8);
            let t = ChiSquareTest::new(&format!("thin film r={roughness} θ={theta}"));
            assert_chi2(t.run_with_pdf(|u| b.sample(wo, rng.next_f32(), u).map(|s| (s.wi, s.pdf)), |wi| b.pdf(wo, wi)));
        }
    }
}

/// A film on the metal (`thin_film_metal`, Blender's Principled): the smooth metal's mirror
/// reflects the film's reflectance on Cycles' F82 conductor of the base colour, at normal and
/// grazing incidence; without the flag the metal stays bare (glTF's files); the rough metal
/// with a film samples by its density (chi-square).
#[test]
fn thin_film_on_the_metal() {
    use crate::bsdf::thin_film::{conductor_film_reflectance, f82_conductor_index};
    let base = Vec3::new(0.9, 0.6, 0.3);
    let film = Some((300.0f32, 1.8f32, 1.0f32));
    let (n, k, g) = f82_conductor_index(base, Vec3::ZERO);
    for cos in [1.0f32, 0.5, 0.15] {
        let wo = Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos);
        let on = PbrBsdf::from_params(&PbrParams {
            thin_film: film,
            thin_film_metal: true,
            ..PbrParams::opaque(base, 1.0, 0.0)
        });
        let s = on.sample(wo, 0.0, Vec2::splat(0.5)).unwrap();
        let want = conductor_film_reflectance(cos, 1.8, 300.0, n, k, Some(g));
        assert!(
            (s.f * s.wi.z / s.pdf - want).abs().max_element() < 1e-4,
            "cos {cos}: {} vs {want}",
            s.f * s.wi.z / s.pdf
        );
        let off = PbrBsdf::from_params(&PbrParams { thin_film: film, ..PbrParams::opaque(base, 1.0, 0.0) });
        let s = off.sample(wo, 0.0, Vec2::splat(0.5)).unwrap();
        let bare = base + (Vec3::ONE - base) * (1.0 - cos).powi(5);
        assert!((s.f * s.wi.z / s.pdf - bare).abs().max_element() < 1e-4, "cos {cos}");
    }
    let p = PbrParams { thin_film: film, thin_film_metal: true, ..PbrParams::opaque(base, 1.0, 0.4) };
    let b = PbrBsdf::from_params(&p);
    for theta in [0.1f32, 1.2] {
        let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
        let mut rng = Pcg32::new(9);
        let t = ChiSquareTest::new(&format!("metal film θ={theta}"));
        assert_chi2(t.run_with_pdf(|u| b.sample(wo, rng.next_f32(), u).map(|s| (s.wi, s.pdf)), |wi| b.pdf(wo, wi)));
    }
}

/// A white Lambertian (metallic 0, rough) reflects 1 - F: its albedo is close to,
/// and below, 1 at normal incidence; a black dielectric reflects only the specular.
#[test]
fn diffuse_limit() {
    let b = PbrBsdf::new(Vec3::ZERO, 0.0, 1.0);
    let wo = Vec3::Z;
    let wi = Vec3::new(0.6, 0.0, 0.8);
    let f = b.eval(wo, wi);
    assert!(f.x == f.y && f.y == f.z && f.x > 0.0 && f.x < 0.1);
}

/// The directional albedo ∫ f |cos θi| dωi over the sphere of `b` seen from `wo` (Cycles'
/// convention: refraction without η²), as (mean, standard error) over `k`
/// independent replicas of a jittered `g`×`g` quadrature: each point picks a visible normal
/// m, which maps one-to-one onto a reflected direction and a refracted one (or its mirror
/// image through a thin sheet); `eval` there over the density of that map is a smooth
/// estimator of each half of the integral. This checks eval alone; the chi-square tests
/// check that sample() follows pdf().
fn albedo_quadrature(b: &PbrBsdf, wo: Vec3, g: usize, k: usize, seed: u64) -> (f64, f64) {
    let mut rng = Pcg32::new(seed);
    let ggx = b.glass.ggx;
    let means: Vec<f64> = (0..k)
        .map(|_| {
            let mut sum = 0.0f64;
            for c in 0..g * g {
                let u = Vec2::new(
                    ((c / g) as f32 + rng.next_f32()) / g as f32,
                    ((c % g) as f32 + rng.next_f32()) / g as f32,
                );
                let m = ggx.sample_visible_normal(wo, u);
                let (dm, om) = (ggx.pdf_visible_normal(wo, m), wo.dot(m));
                if !(dm > 0.0) || om <= 0.0 {
                    continue;
                }
                let wr = reflect(wo, m);
                if wr.z > 0.0 {
                    // Reflection: p(wr) = D_wo(m) / (4 wo·m).
                    let jac = 4.0 * om / dm;
                    sum += (b.eval(wo, wr).x * wr.z * jac) as f64;
                    if b.transmission > 0.0 && b.glass.thin {
                        sum += (b.eval(wo, Vec3::new(wr.x, wr.y, -wr.z)).x * wr.z * jac) as f64;
                    }
                }
                if b.transmission > 0.0
                    && !b.glass.thin
                    && let Some(wt) = refract(wo, m, b.glass.eta)
                    && wt.z < 0.0
                {
                    // Refraction: p(wt) = D_wo(m) |wt·m| / (wt·m + wo·m / η)².
                    let (eta, im) = (b.glass.eta, wt.dot(m));
                    let p = dm * im.abs() / ((im + om / eta) * (im + om / eta));
                    sum += (b.eval(wo, wt).x * -wt.z / p) as f64;
                }
            }
            sum / (g * g) as f64
        })
        .collect();
    let mean = means.iter().sum::<f64>() / k as f64;
    let var = means.iter().map(|m| (m - mean) * (m - mean)).sum::<f64>() / (k - 1) as f64;
    (mean, (var / k as f64).sqrt())
}

/// White furnace: a white rough metal (F0 = 1) and clear rough glass of IOR 1.5, entered
/// and left (R + T), reflect and transmit all they receive, as Cycles' multiscatter GGX
/// does, within 1 % at every roughness and view angle. The quadrature's own error is
/// allowed 5 standard errors (from 8 replicas: 5 is the two-sided 0.2 % quantile of
/// Student's t with 7 degrees of freedom), asserted small enough (≤ 0.3 %) to resolve 1 %.
#[test]
fn white_furnace_metal_and_glass() {
    use rayon::prelude::*;
    let materials = [
        ("metal", 0.0f32, 1.0f32, 1.5f32, true),
        ("glass entering", 1.0, 0.0, 1.5, false),
        ("glass leaving", 1.0, 0.0, 1.0 / 1.5, false),
        ("thin glass", 1.0, 0.0, 1.5, true),
    ];
    let thetas = [0.0f32, 0.6, 1.0, 1.35];
    let cases: Vec<(usize, usize, usize)> =
        (0..materials.len()).flat_map(|m| (1..=10).flat_map(move |r| (0..4).map(move |t| (m, r, t)))).collect();
    let results: Vec<(f64, f64)> = cases
        .par_iter()
        .map(|&(m, r, t)| {
            let (_, transmission, metallic, eta, thin) = materials[m];
            let p = PbrParams { transmission, thin, eta, ..PbrParams::opaque(Vec3::ONE, metallic, r as f32 / 10.0) };
            let wo = Vec3::new(thetas[t].sin(), 0.0, thetas[t].cos());
            albedo_quadrature(&PbrBsdf::from_params(&p), wo, 64, 8, 17)
        })
        .collect();
    let mut failures = Vec::new();
    for (&(m, r, t), &(mean, se)) in cases.iter().zip(&results) {
        let what = format!("{} r={} θ={}", materials[m].0, r as f32 / 10.0, thetas[t]);
        assert!(5.0 * se <= 3e-3, "{what}: standard error {se} too large to resolve 1 %");
        if (mean - 1.0).abs() > 0.01 + 5.0 * se {
            failures.push(format!("{what}: {mean:.4} ± {se:.4}"));
        }
    }
    // The table for the report: albedo at normal incidence and at θ = 1.35 per roughness.
    for (m, material) in materials.iter().enumerate() {
        let row: Vec<String> = (1..=10)
            .map(|r| {
                let at = |t: usize| results[cases.iter().position(|&c| c == (m, r, t)).unwrap()].0;
                format!("{:.3}/{:.3}", at(0), at(3))
            })
            .collect();
        eprintln!("{:>15}: {}", material.0, row.join(" "));
    }
    assert!(failures.is_empty(), "albedo not within 1 % of 1:\n{}", failures.join("\n"));
}

/// Rough glass of IOR 1 is an invisible interface, as in Cycles: light passes straight
/// through with all its energy (it rendered black: the half vector of a refraction with
/// η = 1 is the zero vector). Every sample is finite, its weight is 1 up to the ~10⁻⁷
/// reflected, and eval and pdf are finite everywhere.
#[test]
fn rough_glass_of_ior_one_passes_light_through() {
    let mut rng = Pcg32::new(8);
    for thin in [false, true] {
        for eta in [1.0f32, 1.0 + 5e-4, 1.0 / (1.0 + 5e-4)] {
            for r in 1..=10 {
                let roughness = r as f32 / 10.0;
                let p = PbrParams {
                    transmission: 1.0,
                    thin,
                    ior: 1.0,
                    eta,
                    ..PbrParams::opaque(Vec3::ONE, 0.0, roughness)
                };
                let b = PbrBsdf::from_params(&p);
                for theta in [0.0f32, 0.7, 1.2, 1.5] {
                    let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                    let n = 2000;
                    let mut sum = 0.0f64;
                    for _ in 0..n {
                        let s = b.sample(wo, rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32()));
                        // Cycles' convention: a refraction's weight has no η².
                        let w = s.map_or(Vec3::ZERO, |s| s.f * (s.wi.z.abs() / s.pdf));
                        assert!(w.is_finite(), "η={eta} thin={thin} r={roughness} θ={theta}: weight {w}");
                        sum += w.x as f64;
                    }
                    let albedo = sum / n as f64;
                    assert!(
                        (albedo - 1.0).abs() < 1e-3,
                        "η={eta} thin={thin} r={roughness} θ={theta}: albedo {albedo}"
                    );
                    let wi = cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                    for wi in [wi, -wi, -wo] {
                        assert!(b.eval(wo, wi).is_finite() && b.pdf(wo, wi).is_finite());
                    }
                }
            }
        }
    }
}

/// White furnace of an anisotropic white metal (F0 = 1): the compensation divides by the
/// anisotropic table's albedo at wo, so the lobe keeps all the light within the 1 %
/// (the table's own error is at most 0.5 %). Measured by the BSDF's own sampling estimator
/// f cos / pdf (the chi-square tests tie sample() to pdf()), allowed 5 standard errors on
/// top. Views along the wide axis, the narrow one and between, steep to grazing.
#[test]
fn white_furnace_anisotropic_metal() {
    let n = 200_000;
    for roughness in [0.2f32, 0.5, 0.8] {
        for strength in [0.5f32, 1.0] {
            let a = roughness * roughness;
            let ax = a + (1.0 - a) * strength * strength;
            let p = PbrParams { anisotropy: Some((ax, a)), ..PbrParams::opaque(Vec3::ONE, 1.0, roughness) };
            let b = PbrBsdf::from_params(&p);
            for (theta, phi) in [(0.0f32, 0.0f32), (0.7, 0.0), (0.7, 1.57), (1.3, 0.8), (1.3, 1.57)] {
                let wo = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
                let mut rng = Pcg32::new(17);
                let (mut sum, mut sum2) = (0.0f64, 0.0f64);
                for _ in 0..n {
                    let u = Vec2::new(rng.next_f32(), rng.next_f32());
                    let v = b.sample(wo, rng.next_f32(), u).map_or(0.0, |s| (s.f.x * s.wi.z / s.pdf) as f64);
                    sum += v;
                    sum2 += v * v;
                }
                let mean = sum / n as f64;
                let se = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
                assert!(
                    (mean - 1.0).abs() <= 0.01 + 5.0 * se,
                    "r={roughness} s={strength} θ={theta} φ={phi}: albedo {mean} ± {se}"
                );
            }
        }
    }
}

#[test]
fn sampled_lobe_kinds_follow_the_lobe_that_chose() {
    // The label must name the lobe that drew wi, not the mixture: directions labelled
    // diffuse are cosine distributed (E[cos θ] = 2/3, σ² = 1/2 - 4/9 = 1/18), and a metal
    // or a glass never labels a sample diffuse.
    let mut rng = Pcg32::new(7);
    let wo = Vec3::new(0.5, 0.1, 0.86).normalize();
    let plastic = PbrBsdf::new(Vec3::splat(0.8), 0.0, 0.5);
    let (mut n, mut sum, mut glossy) = (0usize, 0.0f64, 0usize);
    for _ in 0..40_000 {
        let Some(s) = plastic.sample(wo, rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32())) else {
            continue;
        };
        match s.kind {
            LobeKind::Diffuse => {
                n += 1;
                sum += s.wi.z as f64;
            }
            LobeKind::Glossy => glossy += 1,
        }
    }
    assert!(n > 10_000 && glossy > 1_000, "both lobes sampled: {n} diffuse, {glossy} glossy");
    let mean = sum / n as f64;
    let bound = 5.0 * (1.0f64 / 18.0 / n as f64).sqrt();
    assert!((mean - 2.0 / 3.0).abs() < bound, "diffuse-labelled mean cos {mean}, bound {bound}");

    let metal = PbrBsdf::new(Vec3::splat(0.8), 1.0, 0.5);
    let glass =
        PbrBsdf::from_params(&PbrParams { transmission: 1.0, eta: 1.5, ..PbrParams::opaque(Vec3::ONE, 0.0, 0.3) });
    let smooth_glass =
        PbrBsdf::from_params(&PbrParams { transmission: 1.0, eta: 1.5, ..PbrParams::opaque(Vec3::ONE, 0.0, 0.0) });
    for (name, b) in [("metal", metal), ("glass", glass), ("smooth glass", smooth_glass)] {
        for _ in 0..2_000 {
            if let Some(s) = b.sample(wo, rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32())) {
                assert_eq!(s.kind, LobeKind::Glossy, "{name}");
            }
        }
    }
}

/// The light passes' split: the diffuse-class part of f is never more than f, is all of f
/// for a pure Lambertian (specular 0, metallic 0), none of it for a metal without sheen; the class
/// albedos of every material sum to at most 1 (plus the tables' error).
#[test]
fn class_split_of_f_and_albedo() {
    let mut rng = Pcg32::new(7);
    let wo = Vec3::new(0.3, -0.2, 0.93).normalize();
    for (name, b) in materials() {
        let at = b.at(wo);
        for _ in 0..64 {
            let wi = cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let (f, fd) = (at.eval(wi), at.eval_diffuse(wi));
            assert!((fd - f).max_element() <= 1e-5 * f.max_element().max(1e-3), "{name}: {fd} above {f}");
            // Through the surface the diffuse class is the Lambertian transmission alone.
            let below = -wi;
            let (f_t, fd_t) = (at.eval(below), at.eval_diffuse(below));
            assert!((fd_t - f_t).max_element() <= 1e-5 * f_t.max_element().max(1e-3), "{name}: {fd_t} above {f_t}");
            assert_eq!(fd_t, at.eval_diffuse_transmission(below), "{name}");
            // Sheen is diffuse-class (as Cycles'), even over a metal.
            if b.metallic == 1.0 && b.sheen_max == 0.0 {
                assert_eq!(fd, Rgb::ZERO, "{name}");
            }
        }
        let [d, g, t] = at.class_albedo();
        assert!((d + g + t).max_element() <= 1.0 + TABLE_ERROR as f32, "{name}: {d} + {g} + {t}");
    }
    let lambert = PbrBsdf::with_specular(Vec3::splat(0.5), 0.0, 1.0, 0.0);
    let at = lambert.at(wo);
    let wi = Vec3::new(-0.4, 0.1, 0.9).normalize();
    assert_eq!(at.eval_diffuse(wi), at.eval(wi));
    assert_eq!(at.class_albedo()[1], Rgb::ZERO);
    // glTF's diffuse transmission is diffuse-class on both sides (a Translucent closure to
    // Cycles), so its light and albedo go to the Diffuse passes, none to Transmission.
    let leaf = PbrBsdf::from_params(&PbrParams {
        specular: 0.0,
        diffuse_transmission: 0.6,
        diffuse_transmission_color: Vec3::new(0.3, 0.9, 0.2),
        ..PbrParams::opaque(Vec3::splat(0.5), 0.0, 1.0)
    });
    let at = leaf.at(wo);
    let through = Vec3::new(0.2, -0.1, -0.97).normalize();
    assert!(at.eval(through).min_element() > 0.0);
    assert_eq!(at.eval_diffuse(through), at.eval(through));
    let [d, g, t] = at.class_albedo();
    assert_eq!((g, t), (Rgb::ZERO, Rgb::ZERO));
    assert!((d - (Vec3::splat(0.5) * 0.4 + Vec3::new(0.3, 0.9, 0.2) * 0.6)).abs().max_element() < 1e-5, "{d}");
}

/// White furnace of Blender's sheen: white fibres over a white Lambertian base (no specular
/// layer) reflect 1 − E(μo)(1 − C(μo)): the base gets 1 − E of the light, the fibres E, of
/// which they lose what their LTC puts below the horizon, 1 − C (Cycles loses it too). C comes
/// from a 256² quadrature of the LTC's density over the hemisphere (error ~1e-4); the BSDF's
/// own estimate, by sampling it, has 5 standard errors at 2·10⁵ samples (≤ 2e-3) allowed.
#[test]
fn white_furnace_microfiber_sheen() {
    use crate::bsdf::microfiber::Microfiber;
    for roughness in [0.1f32, 0.4, 0.7, 1.0] {
        for theta in [0.0f32, 0.6, 1.1, 1.45] {
            let p = PbrParams {
                sheen_color: Vec3::ONE,
                sheen_roughness: roughness,
                microfiber_sheen: true,
                specular: 0.0,
                ..PbrParams::opaque(Vec3::ONE, 0.0, 0.5)
            };
            let b = PbrBsdf::from_params(&p);
            let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
            let m = Microfiber::at(wo, roughness);
            let g = 256;
            let mut c = 0.0f64;
            for i in 0..g {
                for j in 0..g {
                    let mu = (i as f32 + 0.5) / g as f32;
                    let phi = std::f32::consts::TAU * (j as f32 + 0.5) / g as f32;
                    let s = (1.0 - mu * mu).sqrt();
                    c += m.density(Vec3::new(s * phi.cos(), s * phi.sin(), mu)) as f64;
                }
            }
            c *= std::f64::consts::TAU / (g * g) as f64;
            let expected = 1.0 - m.albedo() as f64 * (1.0 - c);
            let n = 200_000;
            let mut rng = Pcg32::new(23);
            let (mut sum, mut sum2) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let u = Vec2::new(rng.next_f32(), rng.next_f32());
                let v = b.sample(wo, rng.next_f32(), u).map_or(0.0, |s| (s.f.x * s.wi.z / s.pdf) as f64);
                sum += v;
                sum2 += v * v;
            }
            let mean = sum / n as f64;
            let se = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
            assert!(
                (mean - expected).abs() <= 5.0 * se + 1e-3,
                "r={roughness} θ={theta}: albedo {mean} ± {se}, expected {expected} (E {}, C {c})",
                m.albedo()
            );
        }
    }
}

/// Blender's Principled BSDF (`cycles_principled`): without a specular layer the diffuse base
/// is the base colour (above 1 too) times the Oren-Nayar lobe of the clamped colour, as
/// Cycles weights its closure; the glass transmits √base; the metal takes the base clamped.
#[test]
fn principled_diffuse_base_is_cycles_oren_nayar() {
    let base = Vec3::new(1.6, 0.8, 0.3);
    let p = PbrParams {
        specular: 0.0,
        diffuse_roughness: 0.7,
        cycles_principled: true,
        ..PbrParams::opaque(base, 0.0, 0.5)
    };
    let b = PbrBsdf::from_params(&p);
    let on = OrenNayar::new(0.7, base.min(Vec3::ONE));
    let wo = Vec3::new(0.3, 0.2, 0.93).normalize();
    let wi = Vec3::new(-0.6, 0.1, 0.79).normalize();
    let f = b.eval(wo, wi);
    let expect = base * on.eval(wo, wi);
    assert!((f - expect).abs().max_element() < 1e-5, "{f:?} vs {expect:?}");
    let glass = PbrBsdf::from_params(&PbrParams { transmission: 1.0, eta: 1.5, thin: false, ..p });
    assert!((glass.glass.tint - Vec3::new(1.0, 0.8f32.sqrt(), 0.3f32.sqrt())).abs().max_element() < 1e-6);
    assert_eq!(glass.base, Vec3::new(1.0, 0.8, 0.3));
}

/// Cycles' `bump_shadowing_term` on the specular lobes (`PbrParams::cut_normal`): with sd->N
/// tilted from the frame's normal (the bent, mapped normal), a rough metal gives nothing
/// toward light above the frame's plane but below sd->N's (value and density 0 there, where
/// the same metal without the cut reflects), and as without the cut elsewhere; its own samples
/// are never cut, so every sample's value and density are the uncut metal's. A dielectric's
/// diffuse base is not cut by it.
#[test]
fn specular_lobes_are_cut_where_cycles_cuts_them() {
    let ns = Vec3::new(0.6, 0.0, 0.8);
    for (metallic, specular) in [(1.0f32, 0.5f32), (0.0, 0.5)] {
        let p = PbrParams { specular, ..PbrParams::opaque(Vec3::new(0.8, 0.5, 0.3), metallic, 0.3) };
        let plain = PbrBsdf::from_params(&p);
        let cut = PbrBsdf::from_params(&PbrParams { cut_normal: Some(ns), ..p });
        let wo = Vec3::new(0.9, 0.05, 0.35).normalize();
        let (mut in_cut, mut kept) = (0, 0);
        for i in 0..48 {
            for j in 0..48 {
                let (c, phi) = ((i as f32 + 0.5) / 48.0, std::f32::consts::TAU * j as f32 / 48.0);
                let s = (1.0 - c * c).sqrt();
                let wi = Vec3::new(s * phi.cos(), s * phi.sin(), c);
                if ns.dot(wi) < 0.0 {
                    in_cut += (plain.eval(wo, wi) != Vec3::ZERO) as usize;
                    if metallic == 1.0 {
                        assert_eq!((cut.eval(wo, wi), cut.pdf(wo, wi)), (Vec3::ZERO, 0.0), "{wi}");
                    } else {
                        // The diffuse base stays, the specular layer goes.
                        assert!(
                            cut.eval(wo, wi).max_element() > 0.0 && cut.eval(wo, wi).cmple(plain.eval(wo, wi)).all()
                        );
                    }
                } else {
                    assert_eq!((cut.eval(wo, wi), cut.pdf(wo, wi)), (plain.eval(wo, wi), plain.pdf(wo, wi)));
                    kept += 1;
                }
            }
        }
        assert!(in_cut > 50 && kept > 50, "{in_cut} lit directions in the cut, {kept} kept");
        if metallic == 1.0 {
            let mut rng = Pcg32::new(3);
            let mut cut_samples = 0;
            for _ in 0..20_000 {
                let u = Vec2::new(rng.next_f32(), rng.next_f32());
                let (Some(a), Some(b)) = (cut.sample(wo, 0.5, u), plain.sample(wo, 0.5, u)) else { continue };
                assert_eq!((a.wi, a.f, a.pdf), (b.wi, b.f, b.pdf));
                cut_samples += (ns.dot(a.wi) < 0.0) as usize;
            }
            assert!(cut_samples > 100, "{cut_samples} samples in the cut");
        }
    }
}
