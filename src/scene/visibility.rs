//! Per-object ray visibility (Blender's Object > Visibility > Ray Visibility, Cycles'
//! `PATH_RAY_*` flags): which kinds of ray see an object. A ray carries the one kind it
//! is (its [`RayMask`]); a triangle is hit when its object's mask shares a bit with it,
//! else the ray passes on as if the object were not there.

use crate::bsdf::LobeKind;

/// A set of ray kinds, as bits (Cycles' `PATH_RAY_CAMERA`, `_DIFFUSE`, `_GLOSSY`,
/// `_TRANSMIT`, `_VOLUME_SCATTER`, `_SHADOW`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RayMask(pub u8);

impl RayMask {
    /// Rays from the camera (up to the first scattering event; pass-throughs keep it).
    pub const CAMERA: RayMask = RayMask(1);
    /// Rays reflected by a diffuse lobe.
    pub const DIFFUSE: RayMask = RayMask(2);
    /// Rays reflected by a glossy or mirror lobe.
    pub const GLOSSY: RayMask = RayMask(4);
    /// Rays that crossed the surface (any lobe: Cycles' visibility tests only TRANSMIT).
    pub const TRANSMISSION: RayMask = RayMask(8);
    /// Rays scattered in a volume.
    pub const VOLUME: RayMask = RayMask(16);
    /// Shadow rays of next-event estimation.
    pub const SHADOW: RayMask = RayMask(32);
    /// Every kind: an object seen by every ray, or a ray that sees every object.
    pub const ALL: RayMask = RayMask(63);

    /// True when the two sets share a kind (a ray of kind `self` sees an object of mask `other`).
    #[inline]
    pub fn meets(self, other: RayMask) -> bool {
        self.0 & other.0 != 0
    }

    /// The kind of the ray leaving a surface bounce drawn from a lobe of `kind`:
    /// transmission when `wi` crossed the surface, whatever the lobe (Cycles'
    /// `path_state_ray_visibility`: "diffuse/glossy are for reflection only").
    #[inline]
    pub fn after_bounce(kind: LobeKind, transmitted: bool) -> RayMask {
        match (transmitted, kind) {
            (true, _) => RayMask::TRANSMISSION,
            (false, LobeKind::Diffuse) => RayMask::DIFFUSE,
            (false, LobeKind::Glossy) => RayMask::GLOSSY,
        }
    }

    /// The kind of the ray leaving a scattering event in a volume: volume scatter alone, as
    /// Cycles' `path_state_next` gives it, so an object hidden from volume rays is passed
    /// after a volume bounce. (Adding the diffuse kind, as this did, let such rays find an
    /// emissive box hidden from volume rays in fog: 1.0196 of Cycles in red, 0.9989 without.)
    pub const AFTER_VOLUME: RayMask = RayMask(RayMask::VOLUME.0);
}

/// Which rays see each triangle, and the objects that hide from some.
#[derive(Clone, Debug, Default)]
pub struct RayVisibility {
    /// Per triangle (indexed as `Mesh::triangles`); empty when every object is seen by every ray.
    pub per_triangle: Vec<RayMask>,
    /// The objects hidden from some kind of ray, for warnings.
    pub hidden_objects: Vec<HiddenObject>,
    /// Per triangle: its object is a holdout (Blender's Object > Visibility > Holdout, or a
    /// Holdout collection): camera rays that reach it see nothing, alpha 0. Empty when no
    /// object is.
    pub holdout: Vec<bool>,
    /// Names of the holdout objects, for warnings.
    pub holdout_objects: Vec<String>,
    /// Per triangle: its object is a shadow catcher (Blender's Object > Visibility > Shadow
    /// Catcher; `integrator::catcher`). Empty when no object is.
    pub catcher: Vec<bool>,
    /// Names of the shadow catcher objects, for warnings.
    pub catcher_objects: Vec<String>,
    /// Per triangle: its object's Shadow Terminator Geometry Offset (`scene::terminator`).
    /// Empty when no object has one.
    pub terminator: Vec<f32>,
    /// Per triangle: the frequency multiplier of its object's Shadow Terminator Shading Offset
    /// (`scene::terminator::shift_cos_in`; 1: none). Empty when no object has one.
    pub shading_frequency: Vec<f32>,
}

/// An object that some kind of ray does not see.
#[derive(Clone, Debug)]
pub struct HiddenObject {
    /// Its node's name.
    pub name: String,
    /// Its triangles (indices into `Mesh::triangles`).
    pub triangles: std::ops::Range<usize>,
    /// The kinds of ray that see it.
    pub mask: RayMask,
}

impl RayVisibility {
    /// Marks triangles `range` (one object's, just appended) with `mask`; `total` is the
    /// triangle count so far. A mask of every kind stores nothing.
    pub fn mark(&mut self, name: &str, range: std::ops::Range<usize>, total: usize, mask: RayMask) {
        if mask == RayMask::ALL {
            return;
        }
        self.per_triangle.resize(total, RayMask::ALL);
        self.per_triangle[range.clone()].fill(mask);
        self.hidden_objects.push(HiddenObject { name: name.to_string(), triangles: range, mask });
    }

    /// Marks triangles `range` (one object's, just appended; `total` so far) as a holdout.
    pub fn mark_holdout(&mut self, name: &str, range: std::ops::Range<usize>, total: usize) {
        self.holdout.resize(total, false);
        self.holdout[range].fill(true);
        self.holdout_objects.push(name.to_string());
    }

    /// True when triangle `tri` belongs to a holdout object.
    #[inline]
    pub fn is_holdout(&self, tri: u32) -> bool {
        self.holdout.get(tri as usize).copied().unwrap_or(false)
    }

    /// Gives triangles `range` (one object's, just appended; `total` so far) the object's
    /// Shadow Terminator Geometry Offset.
    pub fn mark_terminator(&mut self, range: std::ops::Range<usize>, total: usize, offset: f32) {
        if offset > 0.0 {
            self.terminator.resize(total, 0.0);
            self.terminator[range].fill(offset);
        }
    }

    /// Gives triangles `range` (one object's, just appended; `total` so far) the object's
    /// Shadow Terminator Shading Offset (in [0, 2): Cycles' frequency multiplier
    /// 1 / (1 − offset / 2), `object.cpp`).
    pub fn mark_shading_offset(&mut self, range: std::ops::Range<usize>, total: usize, offset: f32) {
        if offset > 0.0 {
            self.shading_frequency.resize(total, 1.0);
            self.shading_frequency[range].fill(1.0 / (1.0 - 0.5 * offset));
        }
    }

    /// The factor triangle `tri`'s Shading Offset puts on a BSDF value for light at cosine
    /// `cos_in` to the shading normal on the viewer's side (`scene::terminator::shift_cos_in`):
    /// 1 without an offset.
    #[inline]
    pub fn shading_offset_factor(&self, tri: u32, cos_in: f32) -> f32 {
        match self.shading_frequency.get(tri as usize) {
            Some(&k) if k > 1.0 => crate::scene::terminator::shift_cos_in(cos_in, k),
            _ => 1.0,
        }
    }

    /// Triangle `tri`'s Shadow Terminator Geometry Offset (0: none).
    #[inline]
    pub fn terminator_offset(&self, tri: u32) -> f32 {
        self.terminator.get(tri as usize).copied().unwrap_or(0.0)
    }

    /// Marks triangles `range` (one object's, just appended; `total` so far) as a shadow catcher.
    pub fn mark_catcher(&mut self, name: &str, range: std::ops::Range<usize>, total: usize) {
        self.catcher.resize(total, false);
        self.catcher[range].fill(true);
        self.catcher_objects.push(name.to_string());
    }

    /// True when triangle `tri` belongs to a shadow catcher object.
    #[inline]
    pub fn is_catcher(&self, tri: u32) -> bool {
        self.catcher.get(tri as usize).copied().unwrap_or(false)
    }

    /// Hides the triangles for which `camera_only` is true from every ray but camera rays (a
    /// `KHR_materials_unlit` surface: `scene::gltf::materials`), on top of their object's mask.
    pub fn camera_only(&mut self, total: usize, camera_only: impl Fn(usize) -> bool) {
        for tri in (0..total).filter(|&t| camera_only(t)) {
            if self.per_triangle.is_empty() {
                self.per_triangle.resize(total, RayMask::ALL);
            }
            self.per_triangle[tri] = RayMask(self.per_triangle[tri].0 & RayMask::CAMERA.0);
        }
    }

    /// Pads the tables to `total` triangles once every object is loaded (objects appended
    /// after the last marked one are seen by every ray and are no holdouts).
    pub fn finish(&mut self, total: usize) {
        if !self.per_triangle.is_empty() {
            self.per_triangle.resize(total, RayMask::ALL);
        }
        if !self.holdout.is_empty() {
            self.holdout.resize(total, false);
        }
        if !self.catcher.is_empty() {
            self.catcher.resize(total, false);
        }
        if !self.terminator.is_empty() {
            self.terminator.resize(total, 0.0);
        }
        if !self.shading_frequency.is_empty() {
            self.shading_frequency.resize(total, 1.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transmission_hides_the_lobe_kind_as_cycles() {
        assert_eq!(RayMask::after_bounce(LobeKind::Diffuse, false), RayMask::DIFFUSE);
        assert_eq!(RayMask::after_bounce(LobeKind::Glossy, false), RayMask::GLOSSY);
        assert_eq!(RayMask::after_bounce(LobeKind::Diffuse, true), RayMask::TRANSMISSION);
        assert_eq!(RayMask::after_bounce(LobeKind::Glossy, true), RayMask::TRANSMISSION);
        // An object hidden from diffuse rays only is still seen by transmitted ones.
        let no_diffuse = RayMask(RayMask::ALL.0 & !RayMask::DIFFUSE.0);
        assert!(RayMask::TRANSMISSION.meets(no_diffuse));
        assert!(!RayMask::DIFFUSE.meets(no_diffuse));
        // A volume bounce does not see an object hidden from volume rays, diffuse or not.
        let no_volume = RayMask(RayMask::ALL.0 & !RayMask::VOLUME.0);
        assert!(!RayMask::AFTER_VOLUME.meets(no_volume));
        assert!(RayMask::AFTER_VOLUME.meets(RayMask(RayMask::ALL.0 & !RayMask::DIFFUSE.0)));
    }

    #[test]
    fn marking_pads_with_visible_triangles() {
        let mut v = RayVisibility::default();
        v.mark("seen", 0..2, 2, RayMask::ALL);
        assert!(v.per_triangle.is_empty());
        v.mark("ghost", 2..3, 3, RayMask::SHADOW);
        v.finish(5);
        assert_eq!(v.per_triangle, vec![RayMask::ALL, RayMask::ALL, RayMask::SHADOW, RayMask::ALL, RayMask::ALL]);
        assert_eq!(v.hidden_objects.len(), 1);
        assert_eq!((v.hidden_objects[0].name.as_str(), v.hidden_objects[0].triangles.clone()), ("ghost", 2..3));
        v.mark("no glossy", 3..4, 4, RayMask(RayMask::ALL.0 & !RayMask::GLOSSY.0));
        v.mark("no volume", 4..5, 5, RayMask(RayMask::ALL.0 & !RayMask::VOLUME.0));
        assert_eq!(v.hidden_objects.len(), 3);
        assert!(!v.is_holdout(1));
        v.mark_holdout("held", 1..2, 5);
        v.finish(6);
        assert_eq!(v.holdout, vec![false, true, false, false, false, false]);
        assert!(v.is_holdout(1) && !v.is_holdout(0) && !v.is_holdout(9));
        v.mark_catcher("floor", 2..4, 6);
        v.finish(7);
        assert_eq!(v.catcher, vec![false, false, true, true, false, false, false]);
        assert!(v.is_catcher(3) && !v.is_catcher(4) && !v.is_catcher(99));
    }
}
