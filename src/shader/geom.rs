//! What the graph's input nodes read: the register index, Blender's axes, the instance
//! data and the shading point (`Geom`), and the shading point at barycentrics without a
//! ray (`geom_at`, for alpha, emission and Bump's offset evaluations). A leaf of
//! `shader/`: it imports none of its siblings, so the node operations, the program and
//! the shading dispatch all build on it without a circle.

use crate::accel::Hit;
use crate::scene::light_path::LightPath;
use crate::scene::mesh::Mesh;
use crate::scene::texture::Texture;
use glam::{Mat4, Vec2, Vec3, Vec4};

/// A register index.
pub type Reg = u32;

/// glTF (Y up) to Blender (Z up) axes.
#[inline]
pub fn to_blender(v: Vec3) -> Vec3 {
    Vec3::new(v.x, -v.z, v.y)
}

/// Blender (Z up) to glTF (Y up) axes.
#[inline]
pub fn from_blender(v: Vec3) -> Vec3 {
    Vec3::new(v.x, v.z, -v.y)
}

/// What the instance of the shaded triangle gives the graph.
#[derive(Clone, Copy, Debug)]
pub struct ObjectData {
    /// World (glTF) to object (glTF axes of the object's local frame).
    pub world_to_object: Mat4,
    /// The object's origin in the world (glTF axes).
    pub location: Vec3,
    /// Object Info's Random in [0, 1).
    pub random: f32,
    /// Texture space of the mesh (Blender's `texspace_location`, `texspace_size`, Blender axes).
    pub texspace: Option<(Vec3, Vec3)>,
    /// Object Info Color (RGB) and Alpha: the object's viewport colour (`Object.color`).
    pub color: Vec4,
    /// Object Info's Object Index: the object's Pass Index (`CAUSTIC_object_pass`).
    pub pass_index: f32,
}

impl Default for ObjectData {
    fn default() -> Self {
        NO_OBJECT
    }
}

/// The shading point as the graph's input nodes see it (world glTF axes).
#[derive(Clone, Copy, Debug)]
pub struct Geom<'a> {
    /// Position.
    pub p: Vec3,
    /// Interpolated shading normal, on the viewer's side.
    pub n: Vec3,
    /// Geometric normal, on the viewer's side.
    pub ng: Vec3,
    /// Toward the viewer (Blender's Incoming).
    pub wo: Vec3,
    /// Texture coordinates (glTF's: v down).
    pub uv: [Vec2; 2],
    /// COLOR_0.
    pub color: Vec4,
    /// Tangent (xyz) and bitangent sign, zero when absent.
    pub tangent: Vec4,
    /// The ray hit the back face.
    pub backfacing: bool,
    /// The instance.
    pub object: &'a ObjectData,
    /// The scene's textures (Image Texture nodes).
    pub textures: &'a [Texture],
    /// The scene's triangles (Bump re-evaluates attributes at offset points).
    pub mesh: &'a Mesh,
    /// The shaded triangle.
    pub tri: u32,
    /// Barycentrics (b1, b2) of the point in the triangle (its second and third vertices'
    /// weights), for the attributes read by name.
    pub bary: Vec2,
    /// The ray that reached the point (the Light Path node).
    pub path: LightPath,
    /// The render camera (Texture Coordinate Camera and Window).
    pub view: &'a ViewData,
    /// The scene's rays for the Ambient Occlusion and Bevel nodes (`shader::trace`); none
    /// where Cycles does not trace them either (lights, the world, volumes, alpha).
    pub rays: Rays<'a>,
    /// A point cloud's point (Point Info), None elsewhere (Cycles' Point Info gives 0 there).
    pub point: Option<crate::points::PointInfo>,
    /// A strand's Curves Info (when the program reads it), None elsewhere (0, as Cycles).
    pub curve: Option<crate::curves::info::CurveInfo>,
    /// A volume object's grids at the voxel being read, one value per attribute slot of the
    /// program (None: the grid is not there); the Attribute node reads these instead of the
    /// mesh's (`medium::procedural_source`).
    pub grid_values: Option<&'a [Option<crate::scene::mesh::AttributeValue>]>,
}

/// The ray queries a shader graph's Ambient Occlusion and Bevel nodes make against the
/// scene (`integrator::SceneContext` answers them with its BVH).
pub trait SceneRays: Sync {
    /// True when a ray from `org` along unit `dir` meets, in (0, `tmax`), a surface that
    /// shadow rays see, passing triangle `skip` (the one it leaves).
    fn occluded(&self, org: Vec3, dir: Vec3, tmax: f32, skip: u32) -> bool;
    /// Calls `f` with each hit in (0, `tmax`) of the triangles of instance `object`
    /// (`Mesh::tri_object`) but `skip`, in no order, until it returns false.
    fn local_hits(&self, org: Vec3, dir: Vec3, tmax: f32, object: u32, skip: u32, f: &mut dyn FnMut(Hit) -> bool);
    /// The world's Ambient Occlusion Distance, which an AO node with an unlinked Distance
    /// of 0 takes (Cycles' `NODE_AO_GLOBAL_RADIUS`).
    fn ao_distance(&self) -> f32;
}

/// What a shading point may trace: the scene's queries and the point's random seed (a
/// hash of the hit, so that renders stay the same for any thread count; Bump's offset
/// points keep the centre's seed so that their heights differ by the geometry alone).
#[derive(Clone, Copy, Default)]
pub struct Rays<'a> {
    /// The queries; None: the nodes give their untraced values (AO 1, the normal).
    pub query: Option<&'a dyn SceneRays>,
    /// The random seed.
    pub seed: u32,
}

impl std::fmt::Debug for Rays<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Rays").field("traced", &self.query.is_some()).field("seed", &self.seed).finish()
    }
}

impl Geom<'_> {
    /// Attribute `key` at the point, None where its triangle does not have it (off a mesh
    /// too: the world, a strand).
    #[inline]
    pub fn attribute(&self, key: &crate::scene::mesh::AttributeKey) -> Option<crate::scene::mesh::AttributeValue> {
        self.mesh.attribute_at(key, self.tri, self.bary.x, self.bary.y)
    }

    /// The Texture Coordinate node's Generated output (Blender axes): the object-space point
    /// mapped by the mesh's texture space to [0, 1]³, the object-space point without one.
    #[inline]
    pub fn generated(&self) -> Vec3 {
        let p = to_blender(self.object.world_to_object.transform_point3(self.undisplaced_p()));
        match self.object.texspace {
            Some((loc, size)) => {
                let d = |a: f32, b: f32| if b != 0.0 { a / (2.0 * b) } else { 0.0 };
                let q = p - loc;
                Vec3::new(d(q.x, size.x), d(q.y, size.y), d(q.z, size.z)) + Vec3::splat(0.5)
            }
            None => p,
        }
    }

    /// The point where it was before true displacement moved its triangle (`Mesh::undisplaced`),
    /// at the same barycentrics; the point itself where nothing was moved.
    #[inline]
    fn undisplaced_p(&self) -> Vec3 {
        let m = self.mesh;
        if m.undisplaced.is_empty() {
            return self.p;
        }
        let Some(&[i0, i1, i2]) = m.triangles.get(self.tri as usize) else { return self.p };
        let [a, b, c] = [i0, i1, i2].map(|i| m.positions[i as usize]);
        let (e1, e2, d) = (b - a, c - a, self.p - a);
        let n = e1.cross(e2);
        let nn = n.length_squared();
        if !(nn > 0.0) {
            return self.p;
        }
        let (b1, b2) = (d.cross(e2).dot(n) / nn, e1.cross(d).dot(n) / nn);
        let u = [i0, i1, i2].map(|i| m.undisplaced[i as usize]);
        u[0] * (1.0 - b1 - b2) + u[1] * b1 + u[2] * b2
    }

    /// Cycles' radial tangent around the object's X, Y or Z axis (`axis` 0, 1, 2) through the
    /// texture space's centre: for Z, (−(g.y − ½), g.x − ½, 0) of the Generated point g,
    /// carried to the world as a normal is and made perpendicular to the shading normal. The
    /// Tangent node's Radial outputs, and around Z the default where a closure's Tangent input
    /// is unlinked (the Geometry node's Tangent that Cycles links there, `primitive_tangent`).
    /// World glTF axes; zero on the axis itself.
    #[inline]
    pub fn radial_tangent(&self, axis: u8) -> Vec3 {
        let q = self.generated() - Vec3::splat(0.5);
        let t = from_blender(match axis {
            0 => Vec3::new(0.0, -q.z, q.y),
            1 => Vec3::new(-q.z, 0.0, q.x),
            _ => Vec3::new(-q.y, q.x, 0.0),
        });
        // A normal's object-to-world map: the transpose of world-to-object.
        let t = glam::Mat3::from_mat4(self.object.world_to_object).transpose() * t;
        self.n.cross(t.cross(self.n).normalize_or_zero())
    }
}

/// The render camera as the Texture Coordinate node's Camera and Window outputs read it
/// (Cycles' `worldtocamera` and `worldtondc`), made from the camera and frame the render
/// uses (`CameraRays::shader_view`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewData {
    /// World (glTF axes) to Cycles' camera space: x right, y up, z forward (into the view).
    pub world_to_camera: Mat4,
    /// The frame's lower-left corner on the image plane (distance 1, or world units for an
    /// orthographic camera), lens shift included.
    pub plane_min: Vec2,
    /// 1 / the frame's size on that plane.
    pub plane_inv_size: Vec2,
    /// Parallel projection.
    pub ortho: bool,
    /// False where no render camera is known (a scene shaded without one): both outputs
    /// then give 0.
    pub known: bool,
    /// The shading point is a direction leaving the scene (the world, `WorldGraph::with_view`):
    /// Cycles adds the camera's position to it for Camera, and for Window under a
    /// perspective camera, so both see the direction from the camera.
    pub background: bool,
    /// One pixel's mean size on the image plane (distance 1, or world units for an
    /// orthographic camera): the footprint rule of light-side shading points.
    pub pixel: f32,
}

impl ViewData {
    /// The footprint a camera ray would have at world point `p`: the rule for shading points
    /// that no camera ray reached (light subpaths, photons), which Cycles does not have
    /// (it shades surfaces from camera paths only). The pinhole's pixel spread times the
    /// distance from the camera, one pixel for an orthographic camera; 0 without a camera.
    #[inline]
    pub fn footprint_at(&self, p: Vec3) -> f32 {
        match (self.known, self.ortho) {
            (false, _) => 0.0,
            (true, true) => self.pixel,
            (true, false) => self.pixel * self.world_to_camera.transform_point3(p).length(),
        }
    }

    /// Camera space of a world point (the Camera output).
    #[inline]
    pub fn camera(&self, p: Vec3) -> Vec3 {
        match (self.known, self.background) {
            (false, _) => Vec3::ZERO,
            (true, false) => self.world_to_camera.transform_point3(p),
            (true, true) => self.world_to_camera.transform_vector3(p),
        }
    }

    /// Normalised frame coordinates of a world point (the Window output): (0, 0) at the
    /// frame's lower-left corner, (1, 1) at its upper right, z = 0. A point behind a
    /// perspective camera is divided by its negative depth as Cycles' `transform_perspective`
    /// divides (mirrored), and one in the camera's plane gives 0 as there.
    #[inline]
    pub fn window(&self, p: Vec3) -> Vec3 {
        if !self.known {
            return Vec3::ZERO;
        }
        let c = if self.background && !self.ortho {
            self.world_to_camera.transform_vector3(p)
        } else {
            self.world_to_camera.transform_point3(p)
        };
        let s = if self.ortho {
            Vec2::new(c.x, c.y)
        } else if c.z != 0.0 {
            Vec2::new(c.x, c.y) / c.z
        } else {
            return Vec3::ZERO;
        };
        ((s - self.plane_min) * self.plane_inv_size).extend(0.0)
    }
}

impl Default for ViewData {
    fn default() -> Self {
        NO_VIEW
    }
}

/// No render camera: Camera and Window give 0.
pub static NO_VIEW: ViewData = ViewData {
    world_to_camera: Mat4::IDENTITY,
    plane_min: Vec2::ZERO,
    plane_inv_size: Vec2::ONE,
    ortho: false,
    known: false,
    background: false,
    pixel: 0.0,
};

/// The default instance data (identity transform) for triangles without one.
pub static NO_OBJECT: ObjectData = ObjectData {
    world_to_object: Mat4::IDENTITY,
    location: Vec3::ZERO,
    random: 0.0,
    texspace: None,
    color: Vec4::ONE,
    pass_index: 0.0,
};

/// The shading point at barycentrics of a triangle without a ray: the viewer is taken
/// along the normal (Fresnel-driven transparency or emission then uses normal incidence),
/// the Light Path node sees emission for light sampling (callers with a ray set `path`),
/// and no camera is known (callers with a scene set `view`).
pub fn geom_at<'a>(
    mesh: &'a Mesh,
    objects: &'a [ObjectData],
    textures: &'a [Texture],
    tri: u32,
    b1: f32,
    b2: f32,
) -> Geom<'a> {
    let [i0, i1, i2] = mesh.triangles[tri as usize].map(|i| i as usize);
    let ng =
        (mesh.positions[i1] - mesh.positions[i0]).cross(mesh.positions[i2] - mesh.positions[i0]).normalize_or(Vec3::Z);
    geom_at_ng(mesh, objects, textures, tri, b1, b2, ng)
}

/// [`geom_at`] with the triangle's unit geometric normal `ng` already known (the Bump
/// node's offset points: `program::bump_offsets` has it for the triangle's frame).
pub(super) fn geom_at_ng<'a>(
    mesh: &'a Mesh,
    objects: &'a [ObjectData],
    textures: &'a [Texture],
    tri: u32,
    b1: f32,
    b2: f32,
    ng: Vec3,
) -> Geom<'a> {
    let m = mesh;
    let [i0, i1, i2] = m.triangles[tri as usize].map(|i| i as usize);
    let b0 = 1.0 - b1 - b2;
    let p = m.positions[i0] * b0 + m.positions[i1] * b1 + m.positions[i2] * b2;
    let ns = (m.normals[i0] * b0 + m.normals[i1] * b1 + m.normals[i2] * b2).normalize_or(ng);
    let uv = [m.uv0[i0] * b0 + m.uv0[i1] * b1 + m.uv0[i2] * b2, m.uv1[i0] * b0 + m.uv1[i1] * b1 + m.uv1[i2] * b2];
    let color = m.colors[i0] * b0 + m.colors[i1] * b1 + m.colors[i2] * b2;
    let tangent = m.tangents[i0] * b0 + m.tangents[i1] * b1 + m.tangents[i2] * b2;
    let object = match m.tri_object.get(tri as usize) {
        Some(&o) => objects.get(o as usize).unwrap_or(&NO_OBJECT),
        None => &NO_OBJECT,
    };
    Geom {
        p,
        n: ns,
        ng,
        wo: ns,
        uv,
        color,
        tangent,
        backfacing: false,
        object,
        textures,
        mesh,
        tri,
        bary: Vec2::new(b1, b2),
        path: LightPath::LIGHT_EMISSION,
        view: &NO_VIEW,
        rays: Rays::default(),
        point: None,
        curve: None,
        grid_values: None,
    }
}

/// The vector in registers i..i+3.
#[inline]
pub(super) fn v3(r: &[f32], i: Reg) -> Vec3 {
    let i = i as usize;
    Vec3::new(r[i], r[i + 1], r[i + 2])
}

/// Writes a vector to registers i..i+3.
#[inline]
pub(super) fn set3(r: &mut [f32], i: Reg, v: Vec3) {
    let i = i as usize;
    r[i] = v.x;
    r[i + 1] = v.y;
    r[i + 2] = v.z;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A camera at (5, 1, 2) looking down -Z with a square frame of half-size 0.5 on the plane
    /// at distance 1: a world point is seen from the camera, a direction (the world) as if the
    /// camera stood at the origin, as Cycles adds the camera's position to the background's P.
    #[test]
    fn background_directions_are_seen_from_the_camera() {
        // Cycles' camera space: z forward, so glTF's -Z maps to +z (y up, x right).
        let rot =
            Mat4::from_cols_array(&[1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        let world_to_camera = rot * Mat4::from_translation(-Vec3::new(5.0, 1.0, 2.0));
        let point = ViewData {
            world_to_camera,
            plane_min: Vec2::splat(-0.5),
            plane_inv_size: Vec2::ONE,
            ortho: false,
            known: true,
            background: false,
            pixel: 0.0,
        };
        let world = ViewData { background: true, ..point };
        let d = Vec3::new(0.25, -0.25, -1.0);
        // The direction's own camera-space vector and its frame position, whatever the position.
        assert_eq!(world.camera(d), Vec3::new(0.25, -0.25, 1.0));
        assert_eq!(world.window(d), Vec3::new(0.75, 0.25, 0.0));
        // A point at the camera's position plus the direction reads the same as a point.
        let p = Vec3::new(5.0, 1.0, 2.0) + d;
        assert_eq!(point.camera(p), world.camera(d));
        assert_eq!(point.window(p), world.window(d));
        // Without a known camera both give 0.
        assert_eq!(ViewData { known: false, ..world }.window(d), Vec3::ZERO);
    }
}
