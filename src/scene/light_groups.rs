//! Light groups (Blender's View Layer → Light Groups, Cycles' `lightgroup` passes): each
//! emitter (a light, an emissive object, the world) may belong to one of the view layer's
//! groups, and each group gets a pass `Combined_<name>` holding the light its emitters
//! bring to the camera, so that the groups of a scene whose every emitter has one sum to
//! Combined.
//!
//! Cycles files a contribution by the emitter that gave it, whatever the path did before
//! (`kernel/film/light_passes.h`: next-event estimates by the sampled light's group,
//! emission found by the path by the emitter's, the world seen or found by the world's
//! group); contributions of paths split at a shadow catcher go to no group. An object or
//! a light whose group is not in the view layer's list, or that has none, goes to no group
//! (Cycles resolves the names against the view layer the same way). Emission of media
//! (volume objects, the world's volume) goes to no group in Caustic (a warning says so).

use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// Most light groups a render can write: each takes three sums per pixel and per sample.
pub const MAX: usize = 16;

/// Group index of an emitter in no group.
pub const NONE: u8 = u8::MAX;

/// `light_groups` in the scene's render settings (docs/contract.md): the view layer's groups
/// in order, the world's group and each emitting object's group by node name.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightGroupSpec {
    /// The view layer's light groups, in its order (the passes' order).
    pub names: Vec<String>,
    /// The world's light group (World → Settings → Light Group), if any.
    #[serde(default)]
    pub world: Option<String>,
    /// Object (glTF node) name to its light group, for lights and emissive meshes.
    #[serde(default)]
    pub objects: HashMap<String, String>,
}

/// Which group each emitter of a loaded scene belongs to; empty when the scene has none.
#[derive(Clone, Debug, Default)]
pub struct LightGroups {
    /// Group names, in pass order.
    pub names: Vec<String>,
    /// Per light (indexed as `Scene::lights`), its group or [`NONE`].
    pub of_light: Vec<u8>,
    /// Per triangle, its object's group or [`NONE`] (emission found on a surface).
    pub of_tri: Vec<u8>,
    /// The world's group or [`NONE`].
    pub world: u8,
}

impl LightGroupSpec {
    /// Checks the spec: at most [`MAX`] groups, distinct non-empty names, and every group
    /// an emitter names among them (a name not in the list is an exporter error, since the
    /// add-on resolves names against the view layer as Cycles does); the message says what is wrong.
    pub fn check(&self) -> Result<(), String> {
        if self.names.len() > MAX {
            return Err(format!("the scene has {} light groups; Caustic renders at most {MAX}", self.names.len()));
        }
        for (i, n) in self.names.iter().enumerate() {
            if n.is_empty() || self.names[..i].contains(n) {
                return Err(format!("light group name '{n}' is empty or given twice"));
            }
        }
        let known = |g: &String| self.names.contains(g);
        if let Some(w) = self.world.as_ref().filter(|w| !known(w)) {
            return Err(format!("the world's light group '{w}' is not among the scene's light groups"));
        }
        if let Some((o, g)) = self.objects.iter().find(|(_, g)| !known(g)) {
            return Err(format!("object '{o}': light group '{g}' is not among the scene's light groups"));
        }
        Ok(())
    }

    /// The group index of a named object, or [`NONE`].
    pub fn group_of(&self, object: &str) -> u8 {
        self.objects.get(object).map_or(NONE, |g| self.index(g))
    }

    fn index(&self, group: &str) -> u8 {
        self.names.iter().position(|n| n == group).map_or(NONE, |i| i as u8)
    }

    /// The world's group index, or [`NONE`].
    pub fn world_group(&self) -> u8 {
        self.world.as_deref().map_or(NONE, |w| self.index(w))
    }
}

impl LightGroups {
    /// Number of groups.
    #[inline]
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// True when the scene has no light groups.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }

    /// The group of light `light` (index into `Scene::lights`).
    #[inline]
    pub fn of_light(&self, light: usize) -> u8 {
        self.of_light.get(light).copied().unwrap_or(NONE)
    }

    /// The group of the object of triangle `tri`.
    #[inline]
    pub fn of_tri(&self, tri: u32) -> u8 {
        self.of_tri.get(tri as usize).copied().unwrap_or(NONE)
    }
}

/// One camera sample's light, by group (`MAX` RGB sums; only the first `len` are used).
#[derive(Clone, Copy, Debug)]
pub struct GroupSums(pub [[f32; 3]; MAX]);

impl Default for GroupSums {
    fn default() -> Self {
        GroupSums([[0.0; 3]; MAX])
    }
}

impl GroupSums {
    /// Adds light `c` to group `g` ([`NONE`]: nowhere).
    #[inline]
    pub fn add(&mut self, g: u8, c: glam::Vec3) {
        if let Some(s) = self.0.get_mut(g as usize) {
            s[0] += c.x;
            s[1] += c.y;
            s[2] += c.z;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> LightGroupSpec {
        LightGroupSpec {
            names: vec!["key".into(), "fill".into()],
            world: Some("fill".into()),
            objects: [("Lamp".to_string(), "key".to_string())].into_iter().collect(),
        }
    }

    #[test]
    fn groups_resolve_by_name() {
        let s = spec();
        s.check().unwrap();
        assert_eq!((s.group_of("Lamp"), s.group_of("Other"), s.world_group()), (0, NONE, 1));
    }

    #[test]
    fn bad_specs_are_refused() {
        let mut s = spec();
        s.objects.insert("X".into(), "rim".into());
        assert!(s.check().unwrap_err().contains("'rim'"));
        let mut s = spec();
        s.names.push("key".into());
        assert!(s.check().is_err());
        let s = LightGroupSpec { names: (0..=MAX).map(|i| format!("g{i}")).collect(), ..Default::default() };
        assert!(s.check().unwrap_err().contains("at most"));
    }

    #[test]
    fn sums_ignore_none() {
        let mut g = GroupSums::default();
        g.add(1, glam::Vec3::new(1.0, 2.0, 3.0));
        g.add(NONE, glam::Vec3::ONE);
        assert_eq!(g.0[1], [1.0, 2.0, 3.0]);
        assert_eq!(g.0.iter().flatten().sum::<f32>(), 6.0);
    }
}
