//! The scene's answers to a shader graph's rays (`shader::geom::SceneRays`): the Ambient
//! Occlusion node's occlusion test and the Bevel node's and Only Local AO's hits on one
//! object (`shader::trace`), against this context's BVHs.

use super::SceneContext;
use crate::accel::Hit;
use crate::scene::visibility::RayMask;
use crate::shader::geom::SceneRays;
use glam::Vec3;

impl SceneRays for SceneContext<'_> {
    /// Cycles' `scene_intersect` of an opaque shadow ray: any surface that shadow rays see
    /// (alpha masks applied, Transparent surfaces opaque), moving triangles and strands too.
    fn occluded(&self, org: Vec3, dir: Vec3, tmax: f32, skip: u32) -> bool {
        let accept = self.accepts(RayMask::SHADOW);
        if self.accel.intersect_except(org, dir, tmax, skip, &self.masked, &accept).is_some() {
            return true;
        }
        if let Some(m) = self.motion
            && m.intersect(org, dir, tmax, crate::motion::ray_time(), &self.masked, &accept).is_some()
        {
            return true;
        }
        self.scene.curves.bvh.as_ref().is_some_and(|c| c.occluded(&self.scene.curves.points, org, dir, tmax))
    }

    /// Cycles' `scene_intersect_local`: every triangle of the instance, whatever its ray
    /// visibility; the still triangles only.
    fn local_hits(&self, org: Vec3, dir: Vec3, tmax: f32, object: u32, skip: u32, f: &mut dyn FnMut(Hit) -> bool) {
        let of = &self.scene.mesh.tri_object;
        self.accel.visit_hits(org, dir, tmax, &mut |hit| {
            if hit.tri == skip || of.get(hit.tri as usize) != Some(&object) {
                return true;
            }
            f(hit)
        });
    }

    fn ao_distance(&self) -> f32 {
        self.scene.settings.ao_distance.unwrap_or(crate::passes::DataSettings::default().ao_distance)
    }
}
