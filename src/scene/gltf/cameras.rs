//! Cameras: glTF perspective and orthographic projections, `CAUSTIC_camera`'s lens shift
//! and depth of field, and the camera made up when the file has none.

use super::Loader;
use super::extensions::CameraExt;
use crate::error::Result;
use crate::scene::{Camera, Lens, Projection};
use glam::{Mat4, Vec2, Vec3};

impl Loader<'_> {
    pub(super) fn camera(
        &mut self,
        c: &gltf::Camera,
        node_name: &str,
        world: &Mat4,
        blender: Option<serde_json::Value>,
    ) -> Result<Camera> {
        // The node's name is the Blender object's name, which is what users pick by.
        let name = node_name.to_string();
        let (znear, zfar) = match c.projection() {
            gltf::camera::Projection::Perspective(p) => (p.znear(), p.zfar()),
            gltf::camera::Projection::Orthographic(o) => (o.znear(), Some(o.zfar())),
        };
        let far = zfar.unwrap_or(f32::INFINITY);
        if !(znear >= 0.0 && znear.is_finite() && far > znear) {
            return Err(self.err(format!(
                "camera '{name}': clipping planes znear {znear}, zfar {far} must satisfy 0 <= znear < zfar"
            )));
        }
        let projection = match c.projection() {
            gltf::camera::Projection::Perspective(p) => {
                let yfov = p.yfov();
                if !(yfov > 0.0 && yfov < std::f32::consts::PI) {
                    return Err(self.err(format!("camera '{name}': yfov {yfov} must be in (0, π) radians")));
                }
                let aspect = match p.aspect_ratio() {
                    Some(a) if a > 0.0 && a.is_finite() => Some(a),
                    Some(a) => {
                        return Err(self.err(format!("camera '{name}': aspectRatio {a} must be a positive number")));
                    }
                    None => None,
                };
                Projection::Perspective { yfov, aspect }
            }
            gltf::camera::Projection::Orthographic(o) => {
                let (xmag, ymag) = (o.xmag().abs(), o.ymag().abs());
                if !(xmag > 0.0 && ymag > 0.0 && xmag.is_finite() && ymag.is_finite()) {
                    return Err(self.err(format!("camera '{name}': xmag/ymag must be non-zero and finite")));
                }
                Projection::Orthographic { xmag, ymag }
            }
        };
        let mut cam = Camera::from_matrix(name, world, projection);
        cam.data_name = c.name().map(str::to_string);
        cam.clip = (znear, far);
        if let Some(v) = blender {
            self.camera_extension(&mut cam, v)?;
        }
        Ok(cam)
    }

    /// `CAUSTIC_camera` on a camera's node: Blender's lens shift and depth of field, which
    /// glTF cannot say (docs/contract.md).
    pub(super) fn camera_extension(&mut self, cam: &mut Camera, v: serde_json::Value) -> Result<()> {
        let name = cam.name.clone();
        let e: CameraExt = serde_json::from_value(v)
            .map_err(|e| self.err(format!("camera '{name}': CAUSTIC_camera is malformed: {e}")))?;
        if !(e.shift[0].is_finite() && e.shift[1].is_finite() && e.shift[0].abs() <= 100.0 && e.shift[1].abs() <= 100.0)
        {
            return Err(self.err(format!("camera '{name}': shift {:?} must be finite (at most 100 frames)", e.shift)));
        }
        cam.shift = Vec2::from(e.shift);
        let Some(radius) = e.aperture_radius else {
            if e.focus_distance.is_some() || e.aperture_ratio.is_some() || e.blades != 0 {
                return Err(self
                    .err(format!("camera '{name}': CAUSTIC_camera gives aperture settings without aperture_radius")));
            }
            return Ok(());
        };
        if !(radius.is_finite() && radius >= 0.0) {
            return Err(self.err(format!("camera '{name}': aperture_radius {radius} must be finite and >= 0")));
        }
        let focus_distance = e.focus_distance.unwrap_or(10.0);
        if !(focus_distance.is_finite() && focus_distance > 0.0) {
            return Err(self.err(format!("camera '{name}': focus_distance {focus_distance} must be positive")));
        }
        let ratio = e.aperture_ratio.unwrap_or(1.0);
        if !(ratio.is_finite() && ratio > 0.0) {
            return Err(self.err(format!("camera '{name}': aperture_ratio {ratio} must be positive")));
        }
        if !e.blade_rotation.is_finite() {
            return Err(self.err(format!("camera '{name}': blade_rotation must be finite")));
        }
        if e.blades == 1 || e.blades == 2 || e.blades > 1000 {
            return Err(self.err(format!("camera '{name}': {} blades: use 0 (round) or 3..=1000", e.blades)));
        }
        // Radius 0 is Blender's depth of field at an infinite f-stop: a pinhole.
        if radius > 0.0 {
            cam.lens = Some(Lens { radius, focus_distance, blades: e.blades, rotation: e.blade_rotation, ratio });
        }
        Ok(())
    }
}

/// A camera looking at the bounds from +Z, far enough to see them all.
pub(super) fn frame_bounds(lo: Vec3, hi: Vec3) -> Camera {
    let c = (lo + hi) * 0.5;
    let r = ((hi - lo).length() * 0.5).max(1e-3);
    let yfov = 40f32.to_radians();
    let dist = r / (0.5 * yfov).sin();
    let m = Mat4::from_translation(c + Vec3::Z * dist);
    Camera::from_matrix("auto".into(), &m, Projection::Perspective { yfov, aspect: None })
}
