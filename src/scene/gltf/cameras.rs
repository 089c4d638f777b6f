//! Cameras: glTF perspective and orthographic projections, `CAUSTIC_camera`'s lens shift,
//! depth of field and panoramic cameras (on a node without a glTF camera), and the camera
//! made up when the file has none.

use super::Loader;
use super::extensions::{CameraExt, PanoramaExt};
use crate::error::Result;
use crate::scene::{Camera, Lens, Panorama, Projection};
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
            let e = self.parse_camera_extension(&cam.name, v)?;
            if e.panorama.is_some() || e.clip.is_some() {
                return Err(self.err(format!(
                    "camera '{}': CAUSTIC_camera gives a panorama or clip on a node that has a glTF camera",
                    cam.name
                )));
            }
            self.camera_extension(&mut cam, e)?;
        }
        Ok(cam)
    }

    /// A panoramic camera: a node without a glTF camera whose `CAUSTIC_camera` has a
    /// `panorama` (docs/contract.md), with its clip distances, shift and depth of field.
    pub(super) fn panoramic_camera(&mut self, node_name: &str, world: &Mat4, v: serde_json::Value) -> Result<Camera> {
        let name = node_name.to_string();
        let mut e = self.parse_camera_extension(&name, v)?;
        let Some(p) = e.panorama.take() else {
            return Err(self.err(format!("camera '{name}': CAUSTIC_camera has no panorama")));
        };
        let panorama = panorama(&p).map_err(|m| self.err(format!("camera '{name}': panorama: {m}")))?;
        let [near, far] = e.clip.unwrap_or([0.0, f32::INFINITY]);
        if !(near >= 0.0 && near.is_finite() && far > near) {
            return Err(self.err(format!("camera '{name}': clip {near}, {far} must satisfy 0 <= start < end")));
        }
        let mut cam = Camera::from_matrix(name, world, Projection::Panoramic(panorama));
        cam.clip = (near, far);
        self.camera_extension(&mut cam, e)?;
        Ok(cam)
    }

    fn parse_camera_extension(&self, name: &str, v: serde_json::Value) -> Result<CameraExt> {
        serde_json::from_value(v).map_err(|e| self.err(format!("camera '{name}': CAUSTIC_camera is malformed: {e}")))
    }

    /// `CAUSTIC_camera` on a camera's node: Blender's lens shift and depth of field, which
    /// glTF cannot say (docs/contract.md).
    fn camera_extension(&mut self, cam: &mut Camera, e: CameraExt) -> Result<()> {
        let name = cam.name.clone();
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

/// Cycles' kernel values of a `CAUSTIC_camera.panorama` (`scene/camera.cpp`), checked.
fn panorama(p: &PanoramaExt) -> std::result::Result<Panorama, String> {
    fn need<T: Copy>(v: Option<T>, what: &str) -> std::result::Result<T, String> {
        v.ok_or_else(|| format!("'{what}' is missing"))
    }
    let finite = |v: &[f32], what: &str| {
        if v.iter().all(|x| x.is_finite()) { Ok(()) } else { Err(format!("'{what}' must be finite")) }
    };
    let fov = |p: &PanoramaExt| -> std::result::Result<f32, String> {
        let f = need(p.fov, "fov")?;
        if f > 0.0 && f <= 2.0 * std::f32::consts::PI { Ok(f) } else { Err(format!("fov {f} must be in (0, 2π]")) }
    };
    let sensor = |p: &PanoramaExt| -> std::result::Result<Vec2, String> {
        let s = need(p.sensor, "sensor")?;
        if s.iter().all(|x| x.is_finite() && *x > 0.0) {
            Ok(Vec2::from(s))
        } else {
            Err("sensor must be positive".into())
        }
    };
    Ok(match p.kind.as_str() {
        "equirectangular" => {
            let [lat0, lat1] = need(p.latitude, "latitude")?;
            let [lon0, lon1] = need(p.longitude, "longitude")?;
            finite(&[lat0, lat1, lon0, lon1], "latitude/longitude")?;
            // φ runs from −lon_min at u = 0 to −lon_max; θ from the pole at v = 0.
            Panorama::Equirectangular { range: [lon0 - lon1, -lon0, lat0 - lat1, -lat0 + std::f32::consts::FRAC_PI_2] }
        }
        "equiangular_cubemap_face" => Panorama::EquiangularCubemapFace,
        "mirrorball" => Panorama::Mirrorball,
        "fisheye_equidistant" => Panorama::FisheyeEquidistant { fov: fov(p)? },
        "fisheye_equisolid" => {
            let lens = need(p.lens, "lens")?;
            if !(lens.is_finite() && lens > 0.0) {
                return Err(format!("lens {lens} must be positive"));
            }
            Panorama::FisheyeEquisolid { lens, fov: fov(p)?, sensor: sensor(p)? }
        }
        "fisheye_lens_polynomial" => {
            let k = need(p.polynomial, "polynomial")?;
            finite(&k, "polynomial")?;
            Panorama::FisheyeLensPolynomial { k, fov: fov(p)?, sensor: sensor(p)? }
        }
        "central_cylindrical" => {
            let [u0, u1] = need(p.u_range, "u_range")?;
            let [v0, v1] = need(p.v_range, "v_range")?;
            finite(&[u0, u1, v0, v1], "u_range/v_range")?;
            Panorama::CentralCylindrical { range: [-u0, -u1, v0, v1] }
        }
        other => return Err(format!("unknown type '{other}'")),
    })
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

#[cfg(test)]
mod tests {
    use super::*;

    fn ext(v: serde_json::Value) -> PanoramaExt {
        serde_json::from_value(v).unwrap()
    }

    #[test]
    fn panoramas_take_cycles_kernel_values_and_refuse_bad_keys() {
        use std::f32::consts::{FRAC_PI_2, PI};
        let full = ext(serde_json::json!({"type": "equirectangular", "latitude": [-FRAC_PI_2, FRAC_PI_2],
                                          "longitude": [-PI, PI]}));
        assert_eq!(panorama(&full).unwrap(), Panorama::Equirectangular { range: [-2.0 * PI, PI, -PI, PI] });
        for (bad, why) in [
            (serde_json::json!({"type": "fisheye_equidistant"}), "'fov' is missing"),
            (serde_json::json!({"type": "fisheye_equidistant", "fov": 7.0}), "must be in (0, 2π]"),
            (
                serde_json::json!({"type": "fisheye_equisolid", "fov": 3.0, "lens": 0.0, "sensor": [36.0, 24.0]}),
                "must be positive",
            ),
            (
                serde_json::json!({"type": "fisheye_lens_polynomial", "fov": 3.0, "sensor": [36.0, -1.0],
                                "polynomial": [0.0, -0.02, 0.0, 0.0, 0.0]}),
                "sensor must be positive",
            ),
            (serde_json::json!({"type": "stereographic"}), "unknown type"),
        ] {
            let e = panorama(&ext(bad)).unwrap_err();
            assert!(e.contains(why), "{e}");
        }
    }
}
