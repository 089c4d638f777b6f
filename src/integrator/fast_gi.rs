//! Cycles' Fast GI Approximation (Render > Light Paths > Fast GI), in the path tracer, as
//! Cycles 5.0's kernel does it. Blender's sync makes of the panel and World > Ambient
//! Occlusion (Factor, Distance) one of two methods:
//!
//! - **Replace** (`ao_bounces`, `ao_factor`): once a path has made more than Bounces
//!   bounces — counted as `bounce − transmission − (any glossy) + 1`, so crossings and the
//!   first glossy reflection are free (`path_state_ao_bounce`) — its next ray is an
//!   occlusion test: it sees at most Distance (`intersect_closest`), the world it escapes to
//!   shines Factor times as bright (`shade_background`; suns and next-event estimation
//!   unchanged), and at a surface it takes the emission and ends (`intersect_terminate`).
//!   Factor 0 turns the method off (the kernel's `ao_bounces` is then 0).
//! - **Add** (`ao_additive_factor`): at every surface a path shades, one cosine-distributed
//!   ray about the shading normal, as long as Distance, drawn with the BSDF's numbers; when it
//!   is not blocked the path gains Factor × the diffuse closures' weight × its throughput
//!   (`integrate_surface_ao`), in Combined only.

use crate::scene::light_path::LightPath;

/// The two methods, with their factor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Method {
    /// Rays past the AO bounces end within the distance; the world they reach × factor.
    Replace(f32),
    /// Ambient occlusion × factor added at every surface.
    Add(f32),
}

/// Fast GI of one render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FastGi {
    /// Method and factor.
    pub method: Method,
    /// AO Bounces (Replace): bounces before rays become occlusion tests.
    pub bounces: u32,
    /// World > Ambient Occlusion > Distance: the occlusion rays' length.
    pub distance: f32,
}

/// `fast_gi` as the scene settings carry it (`docs/contract.md`).
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct FastGiSettings {
    /// "replace" or "add".
    pub method: String,
    /// AO Bounces (Render, or Viewport for interactive renders).
    pub bounces: u32,
    /// World > Ambient Occlusion > Factor.
    pub factor: f32,
    /// World > Ambient Occlusion > Distance.
    pub distance: f32,
}

impl FastGi {
    /// The render's Fast GI from its settings; None when it does nothing (Replace with
    /// factor 0 or no bounces, Add with factor 0, as Cycles' `Integrator::device_update`).
    pub fn from_settings(s: &FastGiSettings) -> Result<Option<FastGi>, String> {
        if !(s.factor.is_finite() && s.factor >= 0.0) {
            return Err(format!("fast_gi factor {} must be a finite number at least 0", s.factor));
        }
        if !(s.distance.is_finite() && s.distance > 0.0) {
            return Err(format!("fast_gi distance {} must be a positive number of scene units", s.distance));
        }
        if s.bounces > 1024 {
            return Err(format!("fast_gi bounces {} is absurd (at most 1024)", s.bounces));
        }
        let method = match s.method.as_str() {
            "replace" => Method::Replace(s.factor),
            "add" => Method::Add(s.factor),
            other => return Err(format!("fast_gi method '{other}' is neither 'replace' nor 'add'")),
        };
        let active = match method {
            Method::Replace(f) => f != 0.0 && s.bounces > 0,
            Method::Add(f) => f != 0.0,
        };
        Ok(active.then_some(FastGi { method, bounces: s.bounces, distance: s.distance }))
    }

    /// Whether the ray leaving a vertex with `path`'s counts is an occlusion test (Replace).
    #[inline]
    pub fn occlusion_ray(&self, path: &LightPath) -> bool {
        let Method::Replace(_) = self.method else {
            return false;
        };
        let bounce = path.depth as i64 - path.transmission as i64 - (path.glossy > 0) as i64 + 1;
        bounce > self.bounces as i64
    }

    /// The world's factor for an occlusion ray that escapes (Replace).
    #[inline]
    pub fn world_factor(&self) -> f32 {
        match self.method {
            Method::Replace(f) => f,
            Method::Add(_) => 1.0,
        }
    }

    /// The factor of ambient occlusion added at a surface (Add), or None.
    #[inline]
    pub fn additive(&self) -> Option<f32> {
        match self.method {
            Method::Add(f) => Some(f),
            Method::Replace(_) => None,
        }
    }
}

/// Whether Cycles would leave the scene's world out of light sampling while Fast GI's Replace
/// weighs what the two strategies see differently: Cycles light-samples a world only when its
/// shader varies over directions or it has portals (`LightManager`: background MIS disabled
/// otherwise), so a uniform world is found by rays alone, and Replace's occlusion tests (short,
/// the world times the factor) then stand for all of its light. Caustic samples every world,
/// which gives the same image without Fast GI; with Replace it follows Cycles.
pub fn cycles_skips_world_sampling(gi: Option<FastGi>, scene: &crate::scene::Scene) -> bool {
    let replace = gi.is_some_and(|g| matches!(g.method, Method::Replace(_)));
    replace && scene.world.as_ref().is_some_and(|w| w.image.is_none() && w.graph.is_none() && w.portals.is_empty())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(method: &str, bounces: u32, factor: f32) -> FastGiSettings {
        FastGiSettings { method: method.into(), bounces, factor, distance: 0.5 }
    }

    /// Cycles' count: crossings and the first glossy reflection are free.
    #[test]
    fn occlusion_rays_follow_cycles_count() {
        let gi = FastGi::from_settings(&settings("replace", 1, 1.0)).unwrap().unwrap();
        let lp = |depth, glossy, transmission| LightPath { depth, glossy, transmission, ..LightPath::CAMERA_RAY };
        assert!(!gi.occlusion_ray(&lp(0, 0, 0)), "the camera ray");
        assert!(gi.occlusion_ray(&lp(1, 0, 0)), "after a diffuse bounce");
        assert!(!gi.occlusion_ray(&lp(1, 1, 0)), "after one glossy bounce");
        assert!(gi.occlusion_ray(&lp(2, 2, 0)), "after two glossy bounces");
        assert!(!gi.occlusion_ray(&lp(2, 0, 2)), "after two crossings");
        assert!(gi.occlusion_ray(&lp(3, 0, 2)), "after two crossings and a diffuse bounce");
        let two = FastGi::from_settings(&settings("replace", 2, 1.0)).unwrap().unwrap();
        assert!(!two.occlusion_ray(&lp(1, 0, 0)) && two.occlusion_ray(&lp(2, 0, 0)));
    }

    #[test]
    fn inactive_and_bad_settings() {
        assert_eq!(FastGi::from_settings(&settings("replace", 1, 0.0)), Ok(None));
        assert_eq!(FastGi::from_settings(&settings("replace", 0, 1.0)), Ok(None));
        assert_eq!(FastGi::from_settings(&settings("add", 0, 0.0)), Ok(None));
        assert!(FastGi::from_settings(&settings("add", 0, 0.5)).unwrap().is_some());
        assert!(FastGi::from_settings(&settings("both", 1, 1.0)).is_err());
        assert!(FastGi::from_settings(&settings("add", 1, f32::NAN)).is_err());
        assert!(FastGi::from_settings(&FastGiSettings { distance: 0.0, ..settings("add", 1, 1.0) }).is_err());
    }
}
