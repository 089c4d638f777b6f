//! Point clouds: one sphere per point (centre, radius), as Cycles renders Blender's point
//! clouds (`PointCloud`, its `PRIMITIVE_POINT`), in their own BVH beside the triangles' and
//! the strands' (`bvh.rs`), met by the ray/sphere test of `sphere.rs` (entries only, the
//! sphere a ray leaves never met again), and the surface a ray finds on them
//! (`Points::surface`).
//!
//! A point hit travels through the integrators as an `accel::Hit` whose `tri` has
//! [`POINT_BITS`] set (the rest is the sphere's slot in BVH order). Like a strand's, such an id
//! indexes no per-triangle table: those the integrators read for a hit (lights, light linking)
//! are read with `get`, which gives "none" for it; the object's Ray Visibility and Holdout are
//! looked up by the slot's object (`rays_of`, `holdout_of`), as `SceneContext::sees` and
//! `is_holdout` do for a point's id.
//!
//! Memory: 16 bytes per point (centre, radius), 4 for its index in load order (its object
//! and Point Info's Random), and the BVH's nodes (`Points::bytes`; about 10 bytes a point,
//! measured in `bvh.rs`'s test), 40 bytes per point cloud object.

pub mod bvh;
pub mod sphere;

use crate::accel::Hit;
use crate::curves::CURVE_BIT;
use crate::scene::hit::SurfaceHit;
use glam::{Vec2, Vec3, Vec4, Vec4Swizzles};

/// Set in `Hit::tri` for a point's hit: the curves' bit and the next one (a strand's id never
/// has it, its segments staying below 2^29).
pub const POINT_BITS: u32 = CURVE_BIT | (1 << 30);

/// Points a scene may hold: the slot shares its word with [`POINT_BITS`].
pub const MAX_POINTS: usize = 1 << 30;

/// True when a hit's primitive id is a point's.
#[inline(always)]
pub fn is_point(prim: u32) -> bool {
    prim & POINT_BITS == POINT_BITS
}

/// A warning for the integrators that trace light from the lights (`integrator`: its name),
/// naming the materials of points that transmit (glass, refraction, translucency,
/// transmission); None when no point's material does. Cycles refracts a ray where it enters a
/// point and lets it leave unrefracted (`sphere.rs`): light followed from the lights does not
/// retrace that path backwards, so what those integrators carry through such points differs
/// from the path tracer's (and Cycles') image.
pub fn transmission_warning(scene: &crate::scene::Scene, integrator: &str) -> Option<String> {
    use crate::shader::closure::ClosureKind;
    use crate::shader::instructions::Op;
    let mut named: Vec<String> = Vec::new();
    for o in &scene.points.objects {
        let m = &scene.materials[o.material as usize];
        let graph = m.nodes.as_ref().is_some_and(|p| {
            p.transmits
                || p.ops.iter().any(|op| {
                    matches!(op, Op::Closure(c)
                        if matches!(c.kind, ClosureKind::Glass { .. } | ClosureKind::Refraction { .. } | ClosureKind::Translucent))
                })
        });
        let name = format!("'{}'", m.name);
        if (graph || (m.nodes.is_none() && m.transmission > 0.0)) && !named.contains(&name) {
            named.push(name);
        }
    }
    (!named.is_empty()).then(|| {
        format!(
            "point clouds of material(s) {} transmit: as in Cycles a ray refracts where it enters a point and \
             leaves it unrefracted, which light traced from the lights does not retrace backwards, so {integrator} \
             renders the light passing through them differently from the path tracer (and Cycles)",
            named.join(", ")
        )
    })
}

/// One point cloud object: a run of consecutive points in load order.
#[derive(Clone, Debug, PartialEq)]
pub struct PointObject {
    /// Name, for messages.
    pub name: String,
    /// Load-order index of its first point.
    pub first: u32,
    /// Number of points.
    pub count: u32,
    /// Material index.
    pub material: u32,
    /// Its instance data for shader graphs (`Scene::objects`), when the scene has graphs.
    pub object: Option<u32>,
    /// Each point's index in its Blender point cloud, when the file gives them (points were
    /// left out); the index among the object's points without.
    pub indices: Option<Vec<u32>>,
    /// The kinds of ray that see the object (its Ray Visibility, as a mesh's).
    pub rays: crate::scene::visibility::RayMask,
    /// The object is a holdout: camera rays that reach it see nothing, alpha 0.
    pub holdout: bool,
}

impl PointObject {
    /// An object of `count` points from load-order index `first`, with material `material`.
    pub fn new(name: &str, first: u32, count: u32, material: u32) -> Self {
        PointObject {
            name: name.to_string(),
            first,
            count,
            material,
            object: None,
            indices: None,
            rays: crate::scene::visibility::RayMask::ALL,
            holdout: false,
        }
    }
}

/// What the Point Info node reads at a point hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointInfo {
    /// The sphere's centre (world, glTF axes).
    pub centre: Vec3,
    /// Its radius (world).
    pub radius: f32,
    /// Cycles' per-point random number: `hash_uint2_to_float(index in its point cloud, 0)`.
    pub random: f32,
}

/// All points of a scene, in world space, and their BVH.
#[derive(Clone, Debug, Default)]
pub struct Points {
    /// Spheres: centre (xyz) and radius (w); in load order until `build`, in BVH order after.
    pub spheres: Vec<Vec4>,
    /// Per sphere in BVH order, its index in load order (empty until `build`).
    pub index: Vec<u32>,
    /// Point cloud objects, in order of their first point.
    pub objects: Vec<PointObject>,
    /// The spheres' BVH; None until `build` (and when there are no points).
    pub bvh: Option<bvh::PointBvh>,
}

impl Points {
    /// True when there is nothing to intersect.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.bvh.is_none()
    }

    /// Builds the BVH over every sphere (after all objects are added) and puts the spheres
    /// in its order.
    pub fn build(&mut self) {
        if self.spheres.is_empty() {
            self.bvh = None;
            return;
        }
        let (bvh, order) = bvh::PointBvh::build(&self.spheres);
        self.spheres = order.iter().map(|&k| self.spheres[k as usize]).collect();
        self.index = order;
        self.bvh = Some(bvh);
    }

    /// Bytes held: spheres, their indices, objects and the BVH (for the memory figures).
    pub fn bytes(&self) -> usize {
        self.spheres.len() * size_of::<Vec4>()
            + self.index.len() * size_of::<u32>()
            + self
                .objects
                .iter()
                .map(|o| size_of::<PointObject>() + o.indices.as_ref().map_or(0, |v| v.len() * 4))
                .sum::<usize>()
            + self.bvh.as_ref().map_or(0, |b| b.bytes())
    }

    /// The BVH slot of a point hit's primitive id.
    #[inline(always)]
    fn slot(prim: u32) -> usize {
        (prim & !POINT_BITS) as usize
    }

    /// The object (index into `objects`) of a point hit's primitive id, and the point's index
    /// in it.
    #[inline]
    pub fn object_of_prim(&self, prim: u32) -> (usize, u32) {
        let k = self.index[Self::slot(prim)];
        let o = self.objects.partition_point(|obj| obj.first <= k) - 1;
        (o, k - self.objects[o].first)
    }

    /// True when some object is hidden from some kind of ray or is a holdout (the per-hit
    /// lookups below are needed only then).
    pub fn restricted(&self) -> bool {
        self.objects.iter().any(|o| o.rays != crate::scene::visibility::RayMask::ALL || o.holdout)
    }

    /// The kinds of ray that see the object of a point hit's primitive id.
    #[inline]
    pub fn rays_of(&self, prim: u32) -> crate::scene::visibility::RayMask {
        self.objects[self.object_of_prim(prim).0].rays
    }

    /// True when the object of a point hit's primitive id is a holdout.
    #[inline]
    pub fn holdout_of(&self, prim: u32) -> bool {
        self.objects[self.object_of_prim(prim).0].holdout
    }

    /// Point Info at a point hit's primitive id.
    #[inline]
    pub fn info(&self, prim: u32) -> PointInfo {
        let s = self.spheres[Self::slot(prim)];
        let (o, i) = self.object_of_prim(prim);
        let i = self.objects[o].indices.as_ref().map_or(i, |v| v[i as usize]);
        let random = crate::shader::texture::hash::uint_to_float_incl(crate::shader::texture::hash::hash_uint2(i, 0));
        PointInfo { centre: s.xyz(), radius: s.w, random }
    }

    /// The surface of a point hit seen along `dir` (from `org`): the entry point on the sphere,
    /// its outward normal as both the geometric and the shading normal (Cycles' `Ng = N`), no
    /// tangent and no UV (Cycles gives points none: the glTF (0, 1) here, Blender's (0, 0)),
    /// always the front (only entries are hits).
    pub fn surface(&self, hit: &Hit, org: Vec3, dir: Vec3) -> SurfaceHit {
        let (p, n) = sphere::entry_point(org, dir, self.spheres[Self::slot(hit.tri)]);
        let (o, _) = self.object_of_prim(hit.tri);
        SurfaceHit {
            p,
            ng: n,
            ns: n,
            tangent: Vec4::ZERO,
            uv: [Vec2::new(0.0, 1.0); 2],
            color: Vec4::ONE,
            material: self.objects[o].material,
            tri: hit.tri,
            bary: Vec2::ZERO,
            front: true,
            t: hit.t,
            // The walker sets the ray's state (`advance_with`), as for triangles.
            light_path: crate::scene::light_path::LightPath::CAMERA_RAY.at(hit.t),
        }
    }
}
