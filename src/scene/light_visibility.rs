//! A light's own Ray Visibility (Blender's Object > Visibility > Ray Visibility on a light
//! object: Diffuse, Glossy, Transmission, Volume Scatter; Camera is `camera_visible` on the
//! light), as Cycles 5.0 renders it with the light shader's `SHADER_EXCLUDE_*` flags:
//!
//! * a path whose last bounce was of a hidden kind does not find the light
//!   (`is_light_shader_visible_to_path`: diffuse bounces, reflecting glossy bounces,
//!   transmitted bounces and volume scattering, by the path's flags);
//! * next-event estimation toward the light leaves out the closures of the hidden
//!   classes (`_surface_shader_exclude`): diffuse (diffuse, translucent, sheen), glossy
//!   (reflection), transmission (refraction); a glass closure, which both reflects and
//!   refracts, only when glossy and transmission are both hidden; a volume scattering
//!   event takes no estimate from a light hidden from volume rays.
//!
//! The estimate's MIS weight uses the whole BSDF's density, where Cycles sums only the
//! visible closures' densities: the two agree for materials of one class and differ a
//! little for a mixture under a large light.

use crate::scene::light_path::LightPath;
use crate::scene::visibility::RayMask;

/// The BSDF classes whose light from one light next-event estimation leaves out.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Excluded {
    /// Diffuse closures (diffuse, translucent, sheen).
    pub diffuse: bool,
    /// Glossy reflection.
    pub glossy: bool,
    /// Refraction.
    pub transmission: bool,
}

impl Excluded {
    /// The classes a light seen by ray kinds `mask` leaves out.
    #[inline]
    pub fn of(mask: RayMask) -> Excluded {
        Excluded {
            diffuse: !mask.meets(RayMask::DIFFUSE),
            glossy: !mask.meets(RayMask::GLOSSY),
            transmission: !mask.meets(RayMask::TRANSMISSION),
        }
    }

    /// True when nothing is left out.
    #[inline]
    pub fn none(self) -> bool {
        !(self.diffuse || self.glossy || self.transmission)
    }

    /// Glass closures (reflection and refraction in one) are left out only with both.
    #[inline]
    pub fn glass(self) -> bool {
        self.glossy && self.transmission
    }
}

/// True when a path whose last event set `path`'s flags finds a light seen by ray kinds
/// `mask` (Cycles' `is_light_shader_visible_to_path`; the camera is the light's
/// `camera_visible`, tested where camera rays are told apart).
#[inline]
pub fn path_sees(mask: RayMask, path: &LightPath) -> bool {
    let f = path.flags;
    let has = |bit: u16| f & bit != 0;
    let hidden = |kind: RayMask| !mask.meets(kind);
    !((hidden(RayMask::DIFFUSE) && has(LightPath::DIFFUSE))
        || (hidden(RayMask::GLOSSY) && has(LightPath::GLOSSY) && has(LightPath::REFLECT))
        || (hidden(RayMask::TRANSMISSION) && has(LightPath::TRANSMIT))
        || (hidden(RayMask::VOLUME) && has(LightPath::VOLUME_SCATTER)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::LobeKind;

    fn without(kind: RayMask) -> RayMask {
        RayMask(RayMask::ALL.0 & !kind.0)
    }

    #[test]
    fn paths_find_lights_by_their_last_bounce_as_cycles() {
        let cam = LightPath::CAMERA_RAY;
        let diffuse = cam.bounced(LobeKind::Diffuse, false, false);
        let glossy = cam.bounced(LobeKind::Glossy, false, false);
        let mirror = cam.bounced(LobeKind::Glossy, false, true);
        let refracted = cam.bounced(LobeKind::Glossy, true, false);
        let translucent = cam.bounced(LobeKind::Diffuse, true, false);
        let volume = cam.scattered_in_volume();
        let no_diffuse = without(RayMask::DIFFUSE);
        assert!(!path_sees(no_diffuse, &diffuse));
        // Translucency is a diffuse closure: hidden from diffuse, it is not found either.
        assert!(!path_sees(no_diffuse, &translucent));
        assert!(path_sees(no_diffuse, &glossy) && path_sees(no_diffuse, &refracted) && path_sees(no_diffuse, &volume));
        let no_glossy = without(RayMask::GLOSSY);
        assert!(!path_sees(no_glossy, &glossy) && !path_sees(no_glossy, &mirror));
        // Glossy refraction is transmission, not glossy, to the light's flags.
        assert!(path_sees(no_glossy, &refracted) && path_sees(no_glossy, &diffuse));
        let no_transmission = without(RayMask::TRANSMISSION);
        assert!(!path_sees(no_transmission, &refracted) && !path_sees(no_transmission, &translucent));
        assert!(path_sees(no_transmission, &glossy));
        let no_volume = without(RayMask::VOLUME);
        assert!(!path_sees(no_volume, &volume) && path_sees(no_volume, &diffuse));
        // Camera rays are the light's camera flag's business.
        assert!(path_sees(RayMask::CAMERA, &cam));
    }

    #[test]
    fn exclusions_follow_the_hidden_kinds() {
        assert!(Excluded::of(RayMask::ALL).none());
        let e = Excluded::of(without(RayMask::DIFFUSE));
        assert_eq!(e, Excluded { diffuse: true, glossy: false, transmission: false });
        assert!(!e.glass());
        let e = Excluded::of(RayMask(RayMask::CAMERA.0 | RayMask::DIFFUSE.0));
        assert!(e.glossy && e.transmission && e.glass() && !e.diffuse);
    }
}
