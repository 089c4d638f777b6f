//! Light linking (Blender's Object > Shading > Light Linking > Receiver Collection on an
//! emitter, Cycles' light sets): which objects a light or an emissive object lights. A rule
//! either includes only the listed objects or excludes them; an emitter without a rule
//! lights everything. Camera rays see every emitter whatever its rule, as in Cycles.
//! Shadow linking (Blocker Collection) has the same shape: the objects that cast the
//! emitter's shadows.

/// The receivers of one emitter.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ReceiverRule {
    /// True: only `objects` are lit; false: all but `objects` are.
    pub include: bool,
    /// Object ids (glTF node indices), sorted.
    pub objects: Vec<u32>,
}

impl ReceiverRule {
    /// True when the rule lets its emitter light object `object` (`NO_OBJECT`: a point in a
    /// medium, which no collection holds).
    #[inline]
    pub fn lights(&self, object: u32) -> bool {
        self.objects.binary_search(&object).is_ok() == self.include
    }
}

/// The object id of a point that belongs to no object (a scattering event in a medium).
pub const NO_OBJECT: u32 = u32::MAX;

/// Light linking of a scene; empty when no emitter has a rule.
#[derive(Clone, Debug, Default)]
pub struct LightLinking {
    /// Per triangle, its object's id (glTF node index); empty without rules.
    pub tri_object: Vec<u32>,
    /// Per light (indexed as `Scene::lights`), its rule; empty without rules.
    pub rules: Vec<Option<ReceiverRule>>,
    /// Per light, the objects that cast its shadows (shadow linking: a rule of the same
    /// shape, `lights` read as "blocks"); empty without rules.
    pub blockers: Vec<Option<ReceiverRule>>,
    /// Names of the emitters with a rule, for warnings.
    pub emitters: Vec<String>,
    /// Per curves object (`Curves::objects`), its object's id: the node of the same name
    /// (a hair system's emitter mesh), else one past the nodes by its index; empty without rules.
    pub curve_object: Vec<u32>,
    /// Per point cloud object (`Points::objects`), its object's id: the node of its Blender
    /// object's name (a mesh whose Geometry Nodes made the points), else one past the nodes
    /// and the curves objects by its index; empty without rules.
    pub point_object: Vec<u32>,
}

impl LightLinking {
    /// True when light `light` lights the surface of triangle `tri` (`NO_OBJECT`: no surface).
    #[inline]
    pub fn lights(&self, light: usize, tri: u32) -> bool {
        match self.rules.get(light) {
            Some(Some(rule)) => rule.lights(self.tri_object.get(tri as usize).copied().unwrap_or(NO_OBJECT)),
            _ => true,
        }
    }

    /// True when light `light` lights the strands of curves object `curves_object`.
    #[inline]
    pub fn lights_curves(&self, light: usize, curves_object: u32) -> bool {
        match self.rules.get(light) {
            Some(Some(rule)) => {
                rule.lights(self.curve_object.get(curves_object as usize).copied().unwrap_or(NO_OBJECT))
            }
            _ => true,
        }
    }

    /// True when light `light` lights the points of point cloud object `object`.
    #[inline]
    pub fn lights_points(&self, light: usize, object: usize) -> bool {
        match self.rules.get(light) {
            Some(Some(rule)) => rule.lights(self.point_object.get(object).copied().unwrap_or(NO_OBJECT)),
            _ => true,
        }
    }

    /// True when the points of point cloud object `object` cast light `light`'s shadows.
    #[inline]
    pub fn blocks_points(&self, light: usize, object: usize) -> bool {
        match self.blockers.get(light) {
            Some(Some(rule)) => rule.lights(self.point_object.get(object).copied().unwrap_or(NO_OBJECT)),
            _ => true,
        }
    }

    /// True when the object of triangle `tri` casts light `light`'s shadows.
    #[inline]
    pub fn blocks(&self, light: usize, tri: u32) -> bool {
        match self.blockers.get(light) {
            Some(Some(rule)) => rule.lights(self.tri_object.get(tri as usize).copied().unwrap_or(NO_OBJECT)),
            _ => true,
        }
    }

    /// True when the strands of curves object `curves_object` cast light `light`'s shadows.
    #[inline]
    pub fn blocks_curves(&self, light: usize, curves_object: u32) -> bool {
        match self.blockers.get(light) {
            Some(Some(rule)) => {
                rule.lights(self.curve_object.get(curves_object as usize).copied().unwrap_or(NO_OBJECT))
            }
            _ => true,
        }
    }

    /// True when light `light` has a blocker rule.
    #[inline]
    pub fn shadow_linked(&self, light: usize) -> bool {
        matches!(self.blockers.get(light), Some(Some(_)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn include_and_exclude_rules() {
        let include = ReceiverRule { include: true, objects: vec![2, 5] };
        assert!(include.lights(2) && include.lights(5) && !include.lights(3) && !include.lights(NO_OBJECT));
        let exclude = ReceiverRule { include: false, objects: vec![2] };
        assert!(!exclude.lights(2) && exclude.lights(3) && exclude.lights(NO_OBJECT));
        let l = LightLinking {
            tri_object: vec![2, 3],
            rules: vec![None, Some(include.clone())],
            blockers: vec![Some(include), None],
            emitters: vec![],
            curve_object: vec![5],
            point_object: vec![3, 2],
        };
        assert!(l.lights(0, 1) && l.lights(1, 0) && !l.lights(1, 1) && !l.lights(1, NO_OBJECT));
        // Light 0's shadows come from object 2 only; light 1 is blocked by everything.
        assert!(l.blocks(0, 0) && !l.blocks(0, 1) && l.blocks(1, 1));
        assert!(l.shadow_linked(0) && !l.shadow_linked(1) && !l.shadow_linked(7));
        // Strands of curves object 0 belong to object 5, which light 1 includes.
        assert!(l.lights_curves(1, 0) && !l.lights_curves(1, 1) && l.lights_curves(0, 3));
        // Points of point cloud object 1 belong to object 2, which light 1 includes and which
        // blocks light 0; those of object 0 (object 3) neither.
        assert!(l.lights_points(1, 1) && !l.lights_points(1, 0) && l.lights_points(0, 0));
        assert!(l.blocks_points(0, 1) && !l.blocks_points(0, 0) && l.blocks_points(1, 0));
        // Light 0's blockers are objects 2 and 5: the strands of curves object 0 (object 5)
        // block it, those of an object it does not list do not; light 1 has no blocker rule.
        assert!(l.blocks_curves(0, 0) && !l.blocks_curves(0, 1) && l.blocks_curves(1, 1));
    }
}
