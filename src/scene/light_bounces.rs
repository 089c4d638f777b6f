//! A light's and the world's Max Bounces (Cycles' `light.cycles.max_bounces`,
//! `world.cycles.max_bounces`), as Cycles 5.0 renders them:
//!
//! * next-event estimation toward the light is skipped at a shading point whose path has
//!   made more than `max` bounces (`light_select_reached_max_bounces`: `bounce > max`, with
//!   the path's `bounce` counter, which counts surface and volume scattering but not
//!   transparent pass-throughs; the camera ray's first hit is bounce 0). The light is still
//!   chosen with its usual probability, so the estimate of the other lights is unchanged;
//! * a BSDF- or phase-sampled ray that finds the light is not limited: the emission hit
//!   keeps its MIS weight (`integrate_light`, `integrate_distant_lights` and
//!   `integrate_background` never read the limit). Past the limit a light that rays can find
//!   (an area light, a point or spot with a radius, a sun with an angle, the world) thus
//!   gives only the BSDF strategy's MIS share of its light; a delta light gives nothing.
//!
//! Emissive objects have no Max Bounces in Cycles. Max Bounces 0 keeps a light's direct
//! light; `NO_LIMIT` (Cycles' default 1024 and above: no path gets that long) is no limit.

/// No limit of the light's own.
pub const NO_LIMIT: u32 = u32::MAX;

/// Cycles' default Max Bounces of a light and of the world, which limits nothing (a path
/// ends long before: Blender's Total bounces are at most 1024).
pub const CYCLES_DEFAULT: u32 = 1024;

/// True when next-event estimation from a shading point whose path has made `bounce`
/// bounces may take light `light` of the per-light table `table` (empty: no limits).
#[inline]
pub fn nee_allowed(table: &[u32], light: usize, bounce: u16) -> bool {
    table.get(light).is_none_or(|&max| u32::from(bounce) <= max)
}

/// The per-light table from `(light index, max bounces)` pairs of the lights that have a
/// limit, for `count` lights; empty when none has one.
pub fn table(limited: &[(usize, u32)], count: usize) -> Vec<u32> {
    if limited.is_empty() {
        return Vec::new();
    }
    let mut t = vec![NO_LIMIT; count];
    for &(i, max) in limited {
        t[i] = max;
    }
    t
}

/// A file's Max Bounces: `None` and Cycles' default or above are no limit.
#[inline]
pub fn from_file(max: Option<u32>) -> u32 {
    match max {
        Some(m) if m < CYCLES_DEFAULT => m,
        _ => NO_LIMIT,
    }
}

/// What the photon integrators (`integrator`: "photon mapping", "SPPM") do not render of
/// the lights' Max Bounces, or None. Their camera side follows the rule (next-event
/// estimation stops past it, found emitters keep their MIS weight); photons of a light with
/// Max Bounces 0 are left out (every photon read is light past the first bounce), exact
/// for a delta light, whose light only next-event estimation brings; photons do not know
/// the camera path's bounces they will be read at, so a larger limit is not applied to them.
pub fn photon_warning(scene: &crate::scene::Scene, integrator: &str) -> Option<String> {
    let name = |i: usize| scene.report.lights.get(i).map_or_else(|| format!("light {i}"), |r| format!("'{}'", r.name));
    let mut whole = Vec::new();
    let mut missing = Vec::new();
    for (i, &max) in scene.light_max_bounces.iter().enumerate() {
        if max == NO_LIMIT {
            continue;
        }
        if max > 0 {
            whole.push(format!("{} (Max Bounces {max})", name(i)));
        } else if !crate::light::origin::is_delta(scene, i) {
            missing.push(name(i));
        }
    }
    let mut parts = Vec::new();
    if !whole.is_empty() {
        parts.push(format!(
            "the photons of {} light paths of every length, so their indirect light past the limit is kept",
            whole.join(", ")
        ));
    }
    if !missing.is_empty() {
        parts.push(format!(
            "{} (Max Bounces 0) sends no photons, so the share of its light past the first bounce that Cycles keeps \
             through BSDF-sampled rays that find it is missing",
            missing.join(", ")
        ));
    }
    (!parts.is_empty()).then(|| {
        format!(
            "light Max Bounces with {integrator}: {} (the path tracer, BDPT and VCM follow Cycles)",
            parts.join("; ")
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn estimates_stop_past_the_limit_as_cycles() {
        let t = table(&[(1, 0), (2, 3)], 3);
        assert_eq!(t, vec![NO_LIMIT, 0, 3]);
        // Max Bounces 0: the camera ray's first hit (bounce 0) still takes the light.
        assert!(nee_allowed(&t, 1, 0) && !nee_allowed(&t, 1, 1));
        assert!(nee_allowed(&t, 2, 3) && !nee_allowed(&t, 2, 4));
        assert!(nee_allowed(&t, 0, u16::MAX));
        assert!(nee_allowed(&[], 5, u16::MAX));
        assert!(table(&[], 4).is_empty());
        assert_eq!(from_file(Some(1024)), NO_LIMIT);
        assert_eq!(from_file(None), NO_LIMIT);
        assert_eq!(from_file(Some(2)), 2);
    }
}
