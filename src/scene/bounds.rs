//! The scene's bounding box, which directional and world lights' powers, the photon radii and
//! the light-tracing integrators' emission from the world and the sun read. Geometry gives it
//! when there is some; a scene without geometry (a camera and a world, or lights only, which
//! Cycles renders as the world's background) takes the box of its cameras and placed lights,
//! so that the bounding sphere is finite and never NaN.

use crate::curves::Curves;
use crate::light::Light;
use crate::points::Points;
use crate::scene::{Camera, Mesh};
use glam::Vec3;

/// The box of every triangle, strand and point (radii included), or None without geometry.
pub fn geometry(mesh: &Mesh, curves: &Curves, points: &Points) -> Option<(Vec3, Vec3)> {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for t in &mesh.triangles {
        for &i in t {
            lo = lo.min(mesh.positions[i as usize]);
            hi = hi.max(mesh.positions[i as usize]);
        }
    }
    for p in curves.points.iter().chain(&points.spheres) {
        lo = lo.min(p.truncate() - p.w);
        hi = hi.max(p.truncate() + p.w);
    }
    (lo.cmple(hi).all()).then_some((lo, hi))
}

/// The box of a scene without geometry: its cameras' positions and the lights with a place
/// (points, spots, spheres, area lights); the origin when it has neither (a world seen from
/// a camera the loader makes). A single point is a valid box: `Scene::bounding_sphere` gives
/// it its least radius.
pub fn without_geometry(cameras: &[Camera], lights: &[Light]) -> (Vec3, Vec3) {
    let places = cameras.iter().map(|c| (c.position, c.position)).chain(lights.iter().filter_map(Light::extent));
    places.reduce(|(a, b), (l, h)| (a.min(l), b.max(h))).unwrap_or((Vec3::ZERO, Vec3::ZERO))
}

/// The scene's box: its geometry's, else [`without_geometry`]'s.
pub fn of_scene(mesh: &Mesh, curves: &Curves, points: &Points, cameras: &[Camera], lights: &[Light]) -> (Vec3, Vec3) {
    geometry(mesh, curves, points).unwrap_or_else(|| without_geometry(cameras, lights))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Projection;
    use glam::Mat4;

    fn camera_at(p: Vec3) -> Camera {
        Camera::from_matrix("c".into(), &Mat4::from_translation(p), Projection::Perspective { yfov: 0.7, aspect: None })
    }

    #[test]
    fn a_scene_without_geometry_is_bounded_by_its_cameras_and_placed_lights() {
        let (mesh, curves, points) = (Mesh::default(), Curves::default(), Points::default());
        assert_eq!(geometry(&mesh, &curves, &points), None);
        // Nothing at all: the origin, a point.
        assert_eq!(of_scene(&mesh, &curves, &points, &[], &[]), (Vec3::ZERO, Vec3::ZERO));
        // A camera alone: its position; a world light and a sun add nothing (no place).
        let cam = camera_at(Vec3::new(1.0, 2.0, 3.0));
        let sun = Light::Directional { direction: Vec3::NEG_Z, irradiance: Vec3::ONE, cos_half: 1.0 };
        let b = of_scene(&mesh, &curves, &points, std::slice::from_ref(&cam), &[Light::World, sun]);
        assert_eq!(b, (cam.position, cam.position));
        // A point light widens it.
        let point = Light::Point { position: Vec3::new(-1.0, 5.0, 0.0), intensity: Vec3::ONE };
        let (lo, hi) = of_scene(&mesh, &curves, &points, &[cam], &[point]);
        assert_eq!((lo, hi), (Vec3::new(-1.0, 2.0, 0.0), Vec3::new(1.0, 5.0, 3.0)));
    }
}
