//! Each emitter's light group (`light_groups` in the render settings, docs/contract.md;
//! `crate::scene::light_groups` says what the groups mean): lights by their node's name,
//! emissive triangles by their object's, the world by the world's group.

use super::Loader;
use crate::error::Result;
use crate::light::Light;
use crate::scene::light_groups::{LightGroupSpec, LightGroups, NONE};

impl Loader<'_> {
    /// The groups of `lights` (`light_nodes[i]`: the node name of light i when it came from
    /// a node; emissive triangles and the world have none) and of every triangle, from
    /// `instances` ((node, node name, end of its triangles) in triangle order). Emitting
    /// media are in no group: `glowing_media` warns so.
    pub(super) fn light_groups(
        &mut self,
        spec: Option<&LightGroupSpec>,
        lights: &[Light],
        light_nodes: &[Option<String>],
        instances: &[(usize, String, u32)],
        triangles: usize,
        glowing_media: bool,
    ) -> Result<LightGroups> {
        let Some(spec) = spec.filter(|s| !s.names.is_empty()) else {
            return Ok(LightGroups::default());
        };
        spec.check().map_err(|e| self.err(format!("render settings 'light_groups': {e}")))?;
        let mut of_tri = vec![NONE; triangles];
        let mut start = 0usize;
        for (_, name, end) in instances {
            let end = *end as usize;
            of_tri[start..end].fill(spec.group_of(name));
            start = end;
        }
        let world = spec.world_group();
        let of_light = lights
            .iter()
            .enumerate()
            .map(|(i, l)| match l {
                Light::World => world,
                Light::Triangle { tri } => of_tri[*tri as usize],
                _ => light_nodes.get(i).and_then(|n| n.as_deref()).map_or(NONE, |n| spec.group_of(n)),
            })
            .collect();
        if glowing_media {
            self.warn(
                "light groups: the emission of volumes and of the world's volume is in no light group (the groups \
                 then sum to less than Combined)",
            );
        }
        Ok(LightGroups { names: spec.names.clone(), of_light, of_tri, world })
    }
}
