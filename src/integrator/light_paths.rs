//! Cycles' Light Paths panel beyond Max Bounces (which stays the integrators' `max_depth`):
//! the per-kind bounce limits and the sample clamp, as Cycles 5.0's kernel applies them.
//!
//! Bounce limits (`path_state_next`): a bounce of a kind raises that kind's counter; once a
//! counter exceeds its limit (the kernel's `max_*_bounce` is the setting + 1, compared with
//! `>=`), the path is flagged `PATH_RAY_TERMINATE_AFTER_TRANSPARENT`: it still passes
//! transparent surfaces and finds the emission where it lands (MIS-weighted as usual), but
//! it does no next-event estimation there and does not bounce again — the same end as Max
//! Bounces, which every walker already applies after the emission. Reflections count as
//! diffuse or glossy by the sampled lobe (singular ones glossy), every crossing of a surface
//! as transmission, scattering in a volume as volume.
//!
//! Clamping (`film_clamp_light`): each contribution written to the film is scaled down so
//! that |r| + |g| + |b| is at most 3 × the limit (the colour's ratios kept). A contribution
//! is direct when it belongs to bounce 0: next-event estimation at the first vertex, and
//! emission found by the camera ray or by the ray leaving the first vertex (Cycles writes
//! emission at `bounce - 1`); everything else is indirect. 0 turns a clamp off.
//!
//! Filter Glossy (`surface_shader_prepare_closures`): a path keeps the least density of its
//! non-singular bounces (BSDF or phase function; `min_ray_pdf`); at each vertex where that
//! over Filter Glossy is below 1, every microfacet lobe is widened (`Bsdf::blur`).
//!
//! Caustics (`svm_node_closure_bsdf` under `__CAUSTICS_TRICKS__`): with Reflective or
//! Refractive Caustics off, a shading point reached by a ray whose last bounce was diffuse
//! (`PATH_RAY_DIFFUSE`: cleared by every other bounce, kept by transparent pass-throughs)
//! drops its reflective or refractive closures (`Bsdf::drop_caustics`), for its next-event
//! estimate and its bounce alike.

use crate::math::Rgb;
use crate::scene::SceneSettings;
use crate::scene::light_path::LightPath;

/// The per-kind bounce limits and the clamps of one render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightPaths {
    /// Diffuse Bounces (`NO_LIMIT`: unlimited).
    pub diffuse: u32,
    /// Glossy Bounces.
    pub glossy: u32,
    /// Transmission Bounces.
    pub transmission: u32,
    /// Volume Bounces.
    pub volume: u32,
    /// Clamp Direct (0: off).
    pub clamp_direct: f32,
    /// Clamp Indirect (0: off).
    pub clamp_indirect: f32,
    /// Filter Glossy (0: off): `Bsdf::blur` at each vertex past the first, by the least
    /// density of the path's bounces so far (Cycles' `min_ray_pdf`).
    pub filter_glossy: f32,
    /// Reflective Caustics (false: glossy reflection dropped after a diffuse bounce).
    pub caustics_reflective: bool,
    /// Refractive Caustics (false: refraction dropped after a diffuse bounce).
    pub caustics_refractive: bool,
}

/// A limit that never ends a path.
pub const NO_LIMIT: u32 = u32::MAX;

impl LightPaths {
    /// No per-kind limit and no clamp: a plain glTF run (Max Bounces alone ends paths).
    pub const UNLIMITED: LightPaths = LightPaths {
        diffuse: NO_LIMIT,
        glossy: NO_LIMIT,
        transmission: NO_LIMIT,
        volume: NO_LIMIT,
        clamp_direct: 0.0,
        clamp_indirect: 0.0,
        filter_glossy: 0.0,
        caustics_reflective: true,
        caustics_refractive: true,
    };

    /// The file's values (`scenes[i].extras.caustic`), unchecked: absent keys limit and clamp
    /// nothing (the CLI checks them, flags first, in `cli::settings::resolve`).
    pub fn from_settings(st: &SceneSettings) -> LightPaths {
        let u = LightPaths::UNLIMITED;
        LightPaths {
            diffuse: st.diffuse_max_bounces.unwrap_or(u.diffuse),
            glossy: st.glossy_max_bounces.unwrap_or(u.glossy),
            transmission: st.transmission_max_bounces.unwrap_or(u.transmission),
            volume: st.volume_max_bounces.unwrap_or(u.volume),
            clamp_direct: st.clamp_direct.unwrap_or(0.0),
            clamp_indirect: st.clamp_indirect.unwrap_or(0.0),
            filter_glossy: st.filter_glossy.unwrap_or(0.0),
            caustics_reflective: st.caustics_reflective.unwrap_or(true),
            caustics_refractive: st.caustics_refractive.unwrap_or(true),
        }
    }

    /// The path of state `path` has spent a kind's bounces: it ends at the next surface,
    /// after that surface's emission (or, in a medium, at its next scattering event, which
    /// in expectation leaves it attenuated as Cycles' absorption-only segment does).
    #[inline]
    pub fn spent(&self, path: LightPath) -> bool {
        u32::from(path.diffuse) > self.diffuse
            || u32::from(path.glossy) > self.glossy
            || u32::from(path.transmission) > self.transmission
            || u32::from(path.volume) > self.volume
    }

    /// Some per-kind limit can end a path of at most `max_depth` events earlier than Max
    /// Bounces does (for the integrators that honour only Max Bounces, to warn).
    pub fn limits_below(&self, max_depth: u32) -> Vec<&'static str> {
        // A kind limited to `n` bounces ends a path after n + 1 of them: only a limit
        // below max_depth - 1 (= Max Bounces) can matter.
        let max_bounces = max_depth.saturating_sub(1);
        [
            ("Diffuse Bounces", self.diffuse),
            ("Glossy Bounces", self.glossy),
            ("Transmission Bounces", self.transmission),
            ("Volume Bounces", self.volume),
        ]
        .into_iter()
        .filter(|&(_, n)| n < max_bounces)
        .map(|(name, _)| name)
        .collect()
    }

    /// The clamps and Filter Glossy when on, by their panel names (what only the path
    /// tracer follows besides the per-kind limits).
    pub fn clamps_on(&self) -> Vec<&'static str> {
        let mut on = Vec::new();
        if self.filter_glossy > 0.0 {
            on.push("Filter Glossy");
        }
        if self.clamp_direct > 0.0 {
            on.push("Clamp Direct");
        }
        if self.clamp_indirect > 0.0 {
            on.push("Clamp Indirect");
        }
        on
    }

    /// Which closures a shading point reached along `path` drops: (reflective, refractive),
    /// each when its switch is off and the path's last bounce was diffuse (Cycles'
    /// `PATH_RAY_DIFFUSE` test in `svm_node_closure_bsdf`).
    #[inline]
    pub fn drops_caustics(&self, path: LightPath) -> (bool, bool) {
        let after_diffuse = path.flags & LightPath::DIFFUSE != 0;
        (after_diffuse && !self.caustics_reflective, after_diffuse && !self.caustics_refractive)
    }

    /// The caustics switches that are off, by their panel names (for the integrators that
    /// do not follow them, to warn).
    pub fn caustics_off(&self) -> Vec<&'static str> {
        let mut off = Vec::new();
        if !self.caustics_reflective {
            off.push("Reflective Caustics off");
        }
        if !self.caustics_refractive {
            off.push("Refractive Caustics off");
        }
        off
    }

    /// Emission found by a ray after `depth` scattering events, clamped (direct for depth ≤ 1).
    #[inline]
    pub fn found(&self, c: Rgb, depth: u32) -> Rgb {
        self.clamp(c, depth <= 1)
    }

    /// Next-event estimation at a vertex after `depth` events, clamped (direct for depth 0).
    #[inline]
    pub fn estimated(&self, c: Rgb, depth: u32) -> Rgb {
        self.clamp(c, depth == 0)
    }

    /// `c` scaled so that its absolute channel sum is at most 3 × the clamp.
    #[inline]
    fn clamp(&self, c: Rgb, direct: bool) -> Rgb {
        let limit = if direct { self.clamp_direct } else { self.clamp_indirect };
        if limit <= 0.0 {
            return c;
        }
        let sum = c.abs().element_sum();
        if sum > 3.0 * limit { c * (3.0 * limit / sum) } else { c }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::LobeKind;

    #[test]
    fn a_kind_is_spent_one_bounce_past_its_limit() {
        let lp = LightPaths { diffuse: 1, glossy: 0, ..LightPaths::UNLIMITED };
        let once = LightPath::CAMERA_RAY.bounced(LobeKind::Diffuse, false, false);
        assert!(!lp.spent(once));
        assert!(lp.spent(once.bounced(LobeKind::Diffuse, false, false)));
        // Glossy 0: the first glossy bounce already ends the path at the next surface.
        assert!(lp.spent(LightPath::CAMERA_RAY.bounced(LobeKind::Glossy, false, false)));
        // A transmission is not a glossy bounce, a volume scattering is neither.
        assert!(!lp.spent(LightPath::CAMERA_RAY.bounced(LobeKind::Glossy, true, false)));
        let vol = LightPaths { volume: 0, ..LightPaths::UNLIMITED };
        assert!(!vol.spent(once));
        assert!(vol.spent(LightPath::CAMERA_RAY.scattered_in_volume()));
    }

    #[test]
    fn clamping_keeps_the_colour_and_splits_direct_from_indirect() {
        let lp = LightPaths { clamp_direct: 0.0, clamp_indirect: 0.5, ..LightPaths::UNLIMITED };
        let c = Rgb::new(3.0, 2.0, 1.0);
        assert_eq!(lp.estimated(c, 0), c);
        assert_eq!(lp.found(c, 1), c);
        let k = lp.found(c, 2);
        assert!((k.element_sum() - 1.5).abs() < 1e-6);
        assert!((k.x / k.z - 3.0).abs() < 1e-5);
        assert_eq!(lp.estimated(Rgb::new(0.2, 0.2, 0.2), 1), Rgb::new(0.2, 0.2, 0.2));
    }

    /// Filter Glossy widens a mirror only after a bounce whose density over the filter is
    /// below 1 (a diffuse bounce's is at most 1/π): there it is no longer a delta lobe, and a
    /// rough lobe is never narrowed.
    #[test]
    fn filter_glossy_blurs_a_mirror_after_an_unlikely_bounce() {
        use crate::bsdf::{Bsdf, PbrBsdf};
        let mirror = Bsdf::Pbr(PbrBsdf::new(Rgb::ONE, 1.0, 0.0));
        assert!(mirror.is_delta());
        for (filter, min_pdf, delta) in [(1.0, f32::MAX, true), (0.0, 0.1, true), (1.0, 1.5, true), (1.0, 0.3, false)] {
            let mut b = mirror;
            b.blur(filter, min_pdf);
            assert_eq!(b.is_delta(), delta, "filter {filter}, min pdf {min_pdf}");
        }
        let rough = Bsdf::Pbr(PbrBsdf::new(Rgb::ONE, 1.0, 0.9));
        let mut b = rough;
        b.blur(1.0, 0.3);
        let (wo, wi) = (glam::Vec3::new(0.3, 0.0, 0.95).normalize(), glam::Vec3::new(-0.2, 0.1, 0.97).normalize());
        assert_eq!(b.eval(wo, wi), rough.eval(wo, wi), "α 0.81 is above the blur's 0.42");
    }

    /// Cycles' `PATH_RAY_DIFFUSE`: set by a diffuse bounce (reflected or translucent), kept
    /// by a pass-through, cleared by any other bounce; camera rays never drop closures.
    #[test]
    fn caustics_drop_only_after_a_diffuse_bounce() {
        let lp = LightPaths { caustics_reflective: false, ..LightPaths::UNLIMITED };
        let diffuse = LightPath::CAMERA_RAY.bounced(LobeKind::Diffuse, false, false);
        assert_eq!(lp.drops_caustics(LightPath::CAMERA_RAY), (false, false));
        assert_eq!(lp.drops_caustics(diffuse), (true, false));
        assert_eq!(lp.drops_caustics(diffuse.passed_transparent()), (true, false));
        assert_eq!(lp.drops_caustics(LightPath::CAMERA_RAY.bounced(LobeKind::Diffuse, true, false)), (true, false));
        assert_eq!(lp.drops_caustics(diffuse.bounced(LobeKind::Glossy, false, false)), (false, false));
        assert_eq!(lp.drops_caustics(diffuse.scattered_in_volume()), (false, false));
        assert_eq!(LightPaths::UNLIMITED.drops_caustics(diffuse), (false, false));
    }

    /// With Reflective Caustics dropped, a half-metallic Principled BSDF is its diffuse base
    /// alone, unattenuated by the specular layer it lost: f = (1 − metallic) × base / π
    /// (Cycles: the metal and specular closures are not allocated, the weight keeps
    /// 1 − metallic); a metal is black, and a smooth glass keeps its refraction alone.
    #[test]
    fn dropped_reflection_leaves_the_diffuse_base() {
        use crate::bsdf::{Bsdf, PbrBsdf};
        use glam::{Vec2, Vec3};
        let base = Rgb::new(0.8, 0.5, 0.2);
        let mut b = Bsdf::Pbr(PbrBsdf::new(base, 0.5, 0.4));
        b.drop_caustics(true, false);
        let (wo, wi) = (Vec3::new(0.3, 0.0, 0.95).normalize(), Vec3::new(-0.2, 0.1, 0.97).normalize());
        let expect = base * (0.5 / std::f32::consts::PI);
        assert!((b.eval(wo, wi) - expect).abs().max_element() < 1e-5, "{:?} vs {expect:?}", b.eval(wo, wi));
        let mut metal = Bsdf::Pbr(PbrBsdf::new(base, 1.0, 0.4));
        metal.drop_caustics(true, false);
        assert_eq!(metal.eval(wo, wi), Rgb::ZERO);
        let mut params = crate::bsdf::pbr::PbrParams::opaque(Rgb::ONE, 0.0, 0.0);
        params.transmission = 1.0;
        let mut glass = Bsdf::Pbr(PbrBsdf::from_params(&params));
        glass.drop_caustics(false, true);
        for uc in [0.01, 0.5, 0.99] {
            if let Some(s) = glass.sample(wo, uc, Vec2::splat(0.5)) {
                assert!(s.wi.z > 0.0 || s.f == Rgb::ZERO, "refraction dropped: {s:?}");
            }
        }
    }

    #[test]
    fn only_limits_below_max_bounces_are_named() {
        let lp = LightPaths { diffuse: 4, glossy: 4, transmission: 12, volume: 0, ..LightPaths::UNLIMITED };
        assert_eq!(lp.limits_below(13), vec!["Diffuse Bounces", "Glossy Bounces", "Volume Bounces"]);
        assert!(LightPaths::UNLIMITED.limits_below(13).is_empty());
    }
}
