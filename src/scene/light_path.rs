//! What the Light Path node knows of the ray that reached a shading point: Cycles' path
//! flags (`PATH_RAY_CAMERA`, `_SHADOW`, `_DIFFUSE`, `_GLOSSY`, `_SINGULAR`, `_REFLECT`,
//! `_TRANSMIT`, `_VOLUME_SCATTER`) and bounce counters, updated as Cycles' `path_state_next`
//! updates them. A leaf: the path walkers carry one in their state and hand a copy to each
//! hit (`SurfaceHit::light_path`); the node evaluator reads it.

use crate::bsdf::LobeKind;

/// The ray state at a shading point (Cycles' `path_flag` and `path.*_bounce`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightPath {
    /// `LightPath::CAMERA` | `SHADOW` | ... bits.
    pub flags: u16,
    /// Scattering events so far (Cycles' `bounce`: surfaces and volumes, not transparency).
    pub depth: u16,
    /// Diffuse reflections so far.
    pub diffuse: u16,
    /// Glossy (and singular) reflections so far.
    pub glossy: u16,
    /// Transmissions through surfaces so far.
    pub transmission: u16,
    /// Transparent surfaces passed so far (on a shadow ray, also those the ray passed).
    pub transparent: u16,
    /// Scattering events in volumes so far (Cycles' `volume_bounce`: Volume Bounces).
    pub volume: u16,
    /// Distance from the ray's origin to the shading point.
    pub ray_length: f32,
    /// The ray's footprint (the Bump node's offsets).
    pub footprint: PathFootprint,
}

/// Where a shading point's footprint comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PathFootprint {
    /// The ray's own compact differential, carried from the camera along the path.
    Ray(RayFootprint),
    /// A path from a light: the footprint a camera ray would have at the point
    /// (`ViewData::footprint_at`).
    FromCamera,
}

/// Cycles' compact ray differential: the radius of one pixel's footprint at the ray's
/// origin (`dp`, world units) and its growth per unit of distance along the ray (`dd`),
/// so that the footprint `t` along the ray is `dp + t dd` (`differential_transfer_compact`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RayFootprint {
    /// Radius at the origin.
    pub dp: f32,
    /// Growth per unit distance (the pixel's angular spread).
    pub dd: f32,
}

impl RayFootprint {
    /// No footprint: the Bump node falls back to its fixed floor offset.
    pub const ZERO: RayFootprint = RayFootprint { dp: 0.0, dd: 0.0 };

    /// The footprint's radius `t` along the ray.
    #[inline]
    pub fn at(self, t: f32) -> f32 {
        self.dp + t * self.dd
    }

    /// The footprint of a ray leaving the point `t` along this one: Cycles' bounce keeps the
    /// spread and starts from the radius reached (`ray->dP = sd->dP`, `dD` untouched).
    #[inline]
    pub fn moved(self, t: f32) -> RayFootprint {
        RayFootprint { dp: self.at(t), dd: self.dd }
    }
}

impl LightPath {
    /// A camera ray, until its first scattering event (pass-throughs keep it).
    pub const CAMERA: u16 = 1;
    /// A shadow ray of next-event estimation.
    pub const SHADOW: u16 = 2;
    /// The last bounce was a diffuse closure's.
    pub const DIFFUSE: u16 = 4;
    /// The last bounce was a glossy closure's (singular ones too, as Cycles).
    pub const GLOSSY: u16 = 8;
    /// The last bounce was a delta lobe's (perfect mirror or refraction).
    pub const SINGULAR: u16 = 16;
    /// The last bounce reflected.
    pub const REFLECT: u16 = 32;
    /// The last bounce crossed the surface.
    pub const TRANSMIT: u16 = 64;
    /// The last event was a volume scattering.
    pub const VOLUME_SCATTER: u16 = 128;
    /// Emission evaluated for light sampling, not by a ray (Cycles' `PATH_RAY_EMISSION`).
    pub const EMISSION: u16 = 256;

    /// A camera ray before it hits anything.
    pub const CAMERA_RAY: LightPath = LightPath {
        flags: Self::CAMERA,
        depth: 0,
        diffuse: 0,
        glossy: 0,
        transmission: 0,
        transparent: 0,
        volume: 0,
        ray_length: 0.0,
        footprint: PathFootprint::Ray(RayFootprint::ZERO),
    };

    /// A path leaving a light (photons, BDPT's light subpaths): no Cycles ray kind.
    pub const FROM_LIGHT: LightPath = LightPath { flags: 0, footprint: PathFootprint::FromCamera, ..Self::CAMERA_RAY };

    /// Emission evaluated without a ray: light sampling of emissive triangles and their
    /// power at load (Cycles evaluates them with `PATH_RAY_EMISSION` only).
    pub const LIGHT_EMISSION: LightPath = LightPath { flags: Self::EMISSION, ..Self::CAMERA_RAY };

    /// A shadow ray with no known path behind it (AO, BDPT connections, media).
    pub const SHADOW_RAY: LightPath = LightPath { flags: Self::SHADOW, ..Self::CAMERA_RAY };

    /// The state after a surface bounce from a lobe of `kind` (`transmitted`: the new
    /// direction crossed the surface; `singular`: drawn from a delta lobe), as Cycles'
    /// `path_state_next`: the camera flag and the previous bounce's kinds are cleared.
    #[inline]
    pub fn bounced(self, kind: LobeKind, transmitted: bool, singular: bool) -> LightPath {
        let mut p = self;
        p.depth = p.depth.saturating_add(1);
        p.flags = if transmitted {
            p.transmission = p.transmission.saturating_add(1);
            Self::TRANSMIT
        } else {
            match kind {
                LobeKind::Diffuse => p.diffuse = p.diffuse.saturating_add(1),
                LobeKind::Glossy => p.glossy = p.glossy.saturating_add(1),
            }
            Self::REFLECT
        };
        p.flags |= match (kind, singular) {
            (_, true) => Self::GLOSSY | Self::SINGULAR,
            (LobeKind::Diffuse, false) => Self::DIFFUSE,
            (LobeKind::Glossy, false) => Self::GLOSSY,
        };
        p
    }

    /// The state after a scattering event in a volume.
    #[inline]
    pub fn scattered_in_volume(self) -> LightPath {
        LightPath {
            flags: Self::VOLUME_SCATTER,
            depth: self.depth.saturating_add(1),
            volume: self.volume.saturating_add(1),
            ..self
        }
    }

    /// The state after passing a transparent surface (flags kept, as Cycles).
    #[inline]
    pub fn passed_transparent(self) -> LightPath {
        LightPath { transparent: self.transparent.saturating_add(1), ..self }
    }

    /// The same path with the ray's length to the shading point.
    #[inline]
    pub fn at(self, ray_length: f32) -> LightPath {
        LightPath { ray_length, ..self }
    }

    /// A camera ray with footprint `f`.
    #[inline]
    pub fn camera(f: RayFootprint) -> LightPath {
        LightPath { footprint: PathFootprint::Ray(f), ..Self::CAMERA_RAY }
    }

    /// The same path with its ray's origin moved `t` along it (a bounce or a pass-through
    /// there): the footprint reached there becomes the next ray's, as Cycles' bounce sets
    /// `ray->dP = sd->dP` and keeps `ray->dD`.
    #[inline]
    pub fn moved(self, t: f32) -> LightPath {
        let footprint = match self.footprint {
            PathFootprint::Ray(f) => PathFootprint::Ray(f.moved(t)),
            PathFootprint::FromCamera => PathFootprint::FromCamera,
        };
        LightPath { footprint, ..self }
    }

    /// The footprint's radius at the shading point (`ray_length` along the ray), None for
    /// a path from a light.
    #[inline]
    pub fn footprint_radius(&self) -> Option<f32> {
        match self.footprint {
            PathFootprint::Ray(f) => Some(f.at(self.ray_length)),
            PathFootprint::FromCamera => None,
        }
    }

    /// The shadow ray of next-event estimation from a shading point reached by this path:
    /// Cycles shades what it crosses with `PATH_RAY_SHADOW` alone, the counters copied.
    #[inline]
    pub fn shadow(self) -> LightPath {
        LightPath { flags: Self::SHADOW, ray_length: 0.0, ..self }
    }

    /// A light-sampled emitter seen from a shading point reached by this path, `ray_length`
    /// away: Cycles shades it with `PATH_RAY_EMISSION` alone and the path's own counters
    /// (`light_sample_shader_eval`), so Ray Depth reads one more than the shading point's.
    #[inline]
    pub fn emission(self, ray_length: f32) -> LightPath {
        LightPath { flags: Self::EMISSION, ray_length, ..self }
    }

    /// One output of the Light Path node (Cycles' `svm_node_light_path`).
    #[inline]
    pub fn output(&self, o: PathOutput) -> f32 {
        let flag = |f: u16| (self.flags & f != 0) as u8 as f32;
        match o {
            PathOutput::IsCamera => flag(Self::CAMERA),
            PathOutput::IsShadow => flag(Self::SHADOW),
            PathOutput::IsDiffuse => flag(Self::DIFFUSE),
            PathOutput::IsGlossy => flag(Self::GLOSSY),
            PathOutput::IsSingular => flag(Self::SINGULAR),
            PathOutput::IsReflection => flag(Self::REFLECT),
            PathOutput::IsTransmission => flag(Self::TRANSMIT),
            PathOutput::IsVolumeScatter => flag(Self::VOLUME_SCATTER),
            PathOutput::RayLength => self.ray_length,
            // Shadow rays and emission evaluated for light sampling are one bounce further.
            PathOutput::RayDepth => self.depth as f32 + flag(Self::SHADOW | Self::EMISSION),
            PathOutput::DiffuseDepth => self.diffuse as f32,
            PathOutput::GlossyDepth => self.glossy as f32,
            PathOutput::TransparentDepth => self.transparent as f32,
            PathOutput::TransmissionDepth => self.transmission as f32,
        }
    }
}

impl Default for LightPath {
    fn default() -> Self {
        Self::CAMERA_RAY
    }
}

/// The Light Path node's outputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(missing_docs)]
pub enum PathOutput {
    IsCamera,
    IsShadow,
    IsDiffuse,
    IsGlossy,
    IsSingular,
    IsReflection,
    IsTransmission,
    IsVolumeScatter,
    RayLength,
    RayDepth,
    DiffuseDepth,
    GlossyDepth,
    TransparentDepth,
    TransmissionDepth,
}

impl PathOutput {
    /// Every output with its Blender socket name.
    pub const ALL: [(&'static str, PathOutput); 14] = [
        ("Is Camera Ray", PathOutput::IsCamera),
        ("Is Shadow Ray", PathOutput::IsShadow),
        ("Is Diffuse Ray", PathOutput::IsDiffuse),
        ("Is Glossy Ray", PathOutput::IsGlossy),
        ("Is Singular Ray", PathOutput::IsSingular),
        ("Is Reflection Ray", PathOutput::IsReflection),
        ("Is Transmission Ray", PathOutput::IsTransmission),
        ("Is Volume Scatter Ray", PathOutput::IsVolumeScatter),
        ("Ray Length", PathOutput::RayLength),
        ("Ray Depth", PathOutput::RayDepth),
        ("Diffuse Depth", PathOutput::DiffuseDepth),
        ("Glossy Depth", PathOutput::GlossyDepth),
        ("Transparent Depth", PathOutput::TransparentDepth),
        ("Transmission Depth", PathOutput::TransmissionDepth),
    ];
}

#[cfg(test)]
mod tests {
    use super::*;

    fn out(p: &LightPath, name: &str) -> f32 {
        p.output(PathOutput::ALL.iter().find(|(n, _)| *n == name).unwrap().1)
    }

    /// The footprint along a path as Cycles' compact differentials carry it: a camera ray
    /// of spread dd reaches r = dd t at its hit; a bounce (or a pass-through) there starts
    /// the next ray from r with the same spread (`ray->dP = sd->dP`, `dD` kept), so the
    /// footprint is the spread times the whole path's length; the Light Path flags do not
    /// touch it; a path from a light has none of its own (the camera's rule).
    #[test]
    fn footprint_grows_along_the_path_as_cycles() {
        let cam = LightPath::camera(RayFootprint { dp: 0.0, dd: 0.01 });
        let hit = cam.at(2.0);
        assert_eq!(hit.footprint_radius(), Some(0.02));
        let next = hit.moved(hit.ray_length).bounced(LobeKind::Diffuse, false, false);
        assert_eq!(next.at(3.0).footprint_radius(), Some(0.01 * 5.0));
        let passed = next.at(3.0).moved(3.0).passed_transparent();
        assert!((passed.at(1.0).footprint_radius().unwrap() - 0.06).abs() < 1e-7);
        assert_eq!(LightPath::FROM_LIGHT.at(4.0).moved(4.0).footprint_radius(), None);
        // No camera footprint: zero, the Bump node's floor then.
        assert_eq!(LightPath::CAMERA_RAY.at(7.0).footprint_radius(), Some(0.0));
    }

    /// The flags and counters along camera → transparent → diffuse → refraction → shadow,
    /// as Cycles' `path_state_next` and `svm_node_light_path` give them.
    #[test]
    fn flags_and_counters_follow_cycles() {
        let cam = LightPath::CAMERA_RAY.at(2.5);
        assert_eq!(out(&cam, "Is Camera Ray"), 1.0);
        assert_eq!(out(&cam, "Ray Length"), 2.5);
        assert_eq!(out(&cam, "Ray Depth"), 0.0);
        // A transparent pass keeps the camera flag and counts only as transparent.
        let t = cam.passed_transparent();
        assert_eq!((out(&t, "Is Camera Ray"), out(&t, "Transparent Depth"), out(&t, "Ray Depth")), (1.0, 1.0, 0.0));
        let d = t.bounced(LobeKind::Diffuse, false, false);
        assert_eq!(out(&d, "Is Camera Ray"), 0.0);
        assert_eq!(
            (out(&d, "Is Diffuse Ray"), out(&d, "Is Reflection Ray"), out(&d, "Is Glossy Ray")),
            (1.0, 1.0, 0.0)
        );
        assert_eq!((out(&d, "Ray Depth"), out(&d, "Diffuse Depth")), (1.0, 1.0));
        // A smooth refraction: transmission, glossy and singular (Is Glossy stays set on
        // transmission, unlike ray visibility).
        let r = d.bounced(LobeKind::Glossy, true, true);
        let flags: Vec<f32> =
            ["Is Transmission Ray", "Is Glossy Ray", "Is Singular Ray", "Is Reflection Ray", "Is Diffuse Ray"]
                .iter()
                .map(|n| out(&r, n))
                .collect();
        assert_eq!(flags, [1.0, 1.0, 1.0, 0.0, 0.0]);
        assert_eq!((out(&r, "Transmission Depth"), out(&r, "Glossy Depth"), out(&r, "Ray Depth")), (1.0, 0.0, 2.0));
        // Its shadow ray: only the shadow flag, one bounce further, counters kept.
        let s = r.shadow();
        assert_eq!(
            (out(&s, "Is Shadow Ray"), out(&s, "Is Transmission Ray"), out(&s, "Is Camera Ray")),
            (1.0, 0.0, 0.0)
        );
        assert_eq!((out(&s, "Ray Depth"), out(&s, "Transmission Depth"), out(&s, "Diffuse Depth")), (3.0, 1.0, 1.0));
        let v = r.scattered_in_volume();
        assert_eq!(
            (out(&v, "Is Volume Scatter Ray"), out(&v, "Is Transmission Ray"), out(&v, "Ray Depth")),
            (1.0, 0.0, 3.0)
        );
        assert_eq!(out(&LightPath::LIGHT_EMISSION, "Ray Depth"), 1.0);
        // An emitter sampled by next-event estimation from the refraction's shading point:
        // no flag, the path's counters, depth + 1, the distance to the sample.
        let e = r.emission(4.0);
        assert_eq!(
            (out(&e, "Is Transmission Ray"), out(&e, "Is Camera Ray"), out(&e, "Is Shadow Ray")),
            (0.0, 0.0, 0.0)
        );
        assert_eq!((out(&e, "Ray Depth"), out(&e, "Diffuse Depth"), out(&e, "Ray Length")), (3.0, 1.0, 4.0));
    }
}
