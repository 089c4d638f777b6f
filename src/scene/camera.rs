//! Cameras: glTF perspective and orthographic projections, placed by their node.

use glam::{Mat4, Vec2, Vec3};

/// Projection of a camera.
#[derive(Clone, Copy, Debug)]
pub enum Projection {
    /// Pinhole camera.
    Perspective {
        /// Vertical field of view in radians.
        yfov: f32,
        /// Aspect ratio stored in the file, if any.
        aspect: Option<f32>,
    },
    /// Parallel projection.
    Orthographic {
        /// Half width of the view.
        xmag: f32,
        /// Half height of the view.
        ymag: f32,
    },
}

/// A camera; it looks down its local -Z with +Y up, as glTF cameras do.
#[derive(Clone, Debug)]
pub struct Camera {
    /// Node name (Blender's object name), else "node N".
    pub name: String,
    /// The glTF camera's own name (Blender's camera data name), if any.
    pub data_name: Option<String>,
    /// Position.
    pub position: Vec3,
    /// Unit right, up, and backward (local +X, +Y, +Z) axes in world space.
    pub right: Vec3,
    /// Local +Y.
    pub up: Vec3,
    /// Local +Z (the camera looks down -back).
    pub back: Vec3,
    /// Projection.
    pub projection: Projection,
}

impl Camera {
    /// A camera from a node's world matrix (scale is removed).
    pub fn from_matrix(name: String, m: &Mat4, projection: Projection) -> Self {
        let right = m.transform_vector3(Vec3::X).normalize_or(Vec3::X);
        let up0 = m.transform_vector3(Vec3::Y);
        let back = right.cross(up0).normalize_or(Vec3::Z);
        let up = back.cross(right);
        Camera { name, data_name: None, position: m.transform_point3(Vec3::ZERO), right, up, back, projection }
    }

    /// Aspect ratio that the camera wants, if it says.
    pub fn aspect(&self) -> Option<f32> {
        match self.projection {
            Projection::Perspective { aspect, .. } => aspect,
            Projection::Orthographic { xmag, ymag } => Some(xmag / ymag),
        }
    }
}

/// A camera prepared for an image size: maps film positions to rays.
#[derive(Clone, Debug)]
pub struct CameraRays {
    cam: Camera,
    /// Half extents of the image plane at distance 1 (perspective) or in world units.
    half: Vec2,
    width: f32,
    height: f32,
    ortho: bool,
}

impl CameraRays {
    /// Prepares `cam` for a full frame of `width` × `height` pixels. The vertical field
    /// of view (or ymag) is kept; the horizontal extent follows the camera's aspect ratio
    /// when the file gives one (glTF's definition; Blender's exporter folds the pixel
    /// aspect into it), else the image's.
    pub fn new(cam: &Camera, width: u32, height: u32) -> Self {
        let image_aspect = width as f32 / height as f32;
        let (half, ortho) = match cam.projection {
            Projection::Perspective { yfov, aspect } => {
                let h = (0.5 * yfov).tan();
                (Vec2::new(h * aspect.unwrap_or(image_aspect), h), false)
            }
            Projection::Orthographic { xmag, ymag } => (Vec2::new(xmag, ymag), true),
        };
        CameraRays { cam: cam.clone(), half, width: width as f32, height: height as f32, ortho }
    }

    /// Ray through film position (x, y) in pixels from the top-left corner of the full
    /// frame: (origin, unit direction).
    #[inline]
    pub fn ray(&self, x: f32, y: f32) -> (Vec3, Vec3) {
        let sx = (2.0 * x / self.width - 1.0) * self.half.x;
        let sy = (1.0 - 2.0 * y / self.height) * self.half.y;
        let c = &self.cam;
        if self.ortho {
            (c.position + c.right * sx + c.up * sy, -c.back)
        } else {
            (c.position, (c.right * sx + c.up * sy - c.back).normalize())
        }
    }

    /// Camera-space depth (distance along the viewing axis) of a world point.
    #[inline]
    pub fn depth(&self, p: Vec3) -> f32 {
        (self.cam.position - p).dot(self.cam.back)
    }

    /// True for an orthographic camera (a delta in direction: light tracing cannot reach it).
    pub fn is_orthographic(&self) -> bool {
        self.ortho
    }

    /// Where a world point appears on a perspective camera's film: (film position in
    /// pixels from the top-left corner of the full frame, cos θ to the viewing axis,
    /// distance), or None behind the camera, more than `margin` pixels outside the frame
    /// (a pixel filter reaches that far), or for an orthographic camera.
    #[inline]
    pub fn project(&self, p: Vec3, margin: f32) -> Option<(Vec2, f32, f32)> {
        if self.ortho {
            return None;
        }
        let c = &self.cam;
        let d = p - c.position;
        let dist = d.length();
        let w = d / dist;
        let z = -w.dot(c.back);
        if !(z > 0.0) || !(dist > 0.0) {
            return None;
        }
        let (sx, sy) = (w.dot(c.right) / z, w.dot(c.up) / z);
        let x = (sx / self.half.x + 1.0) * 0.5 * self.width;
        let y = (1.0 - sy / self.half.y) * 0.5 * self.height;
        let inside = (-margin..self.width + margin).contains(&x) && (-margin..self.height + margin).contains(&y);
        inside.then_some((Vec2::new(x, y), z, dist))
    }

    /// Area of one pixel on the image plane at distance 1 (perspective).
    #[inline]
    pub fn pixel_area(&self) -> f32 {
        4.0 * self.half.x * self.half.y / (self.width * self.height)
    }

    /// Solid-angle density of a camera ray's direction at cos θ from the axis when film
    /// positions are uniform over the whole frame (the density bidirectional MIS uses).
    #[inline]
    pub fn pdf_dir(&self, cos_theta: f32) -> f32 {
        if self.ortho || !(cos_theta > 0.0) {
            return 0.0;
        }
        1.0 / (4.0 * self.half.x * self.half.y * cos_theta * cos_theta * cos_theta)
    }

    /// The camera.
    pub fn camera(&self) -> &Camera {
        &self.cam
    }
}
