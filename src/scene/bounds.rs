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

/// The box the world's textured fog is tracked in (before `world_fog_medium` grows it by half
/// on each side): the scene's box `lo..hi` with every camera (paths start there) and every
/// light with a place (light paths start there, shadow rays end there). Without geometry
/// that box may be a point (a camera alone); its 16 majorant cells a side have a floor of
/// one collision per cell crossing, 16 / side per unit, so a 1 mm box made every ray take
/// ~16000 null collisions a unit (60 s for 8×8 pixels at 2 spp). There it is at least 2 units
/// a side (Blender's metres: a room), a floor of 8 a unit.
pub fn world_fog(lo: Vec3, hi: Vec3, geometryless: bool, cameras: &[Camera], lights: &[Light]) -> (Vec3, Vec3) {
    let (lo, hi) = cameras.iter().fold((lo, hi), |(a, b), c| (a.min(c.position), b.max(c.position)));
    let (lo, hi) = lights.iter().filter_map(Light::extent).fold((lo, hi), |(a, b), (l, h)| (a.min(l), b.max(h)));
    if !geometryless {
        return (lo, hi);
    }
    let (c, half) = ((lo + hi) * 0.5, ((hi - lo) * 0.5).max(Vec3::ONE));
    (c - half, c + half)
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
        // The fog's box of a camera alone is a 2-unit cube around it; with geometry it is
        // the box of everything, not floored.
        let cams = [camera_at(Vec3::new(1.0, 2.0, 3.0))];
        assert_eq!(
            world_fog(cams[0].position, cams[0].position, true, &cams, &[]),
            (Vec3::new(0.0, 1.0, 2.0), Vec3::new(2.0, 3.0, 4.0))
        );
        let flat = (Vec3::new(-5.0, 0.0, -5.0), Vec3::new(5.0, 0.0, 5.0));
        assert_eq!(
            world_fog(flat.0, flat.1, false, &cams, &[]),
            (Vec3::new(-5.0, 0.0, -5.0), Vec3::new(5.0, 2.0, 5.0))
        );
    }
}
