//! Hair and curves: strands as chains of round-cone segments (`round_cone.rs`), or of
//! ray-facing ribbons where Blender's Curves Shape is Ribbons (`ribbon.rs`), with a radius
//! per control point, in their own BVH beside the triangles' (`bvh.rs`), and the surface a
//! ray finds on them (`Curves::surface`).
//!
//! A curve hit travels through the integrators as an `accel::Hit` whose `tri` has
//! [`CURVE_BIT`] set (the rest is the segment's index in BVH order) and whose `b1` is the
//! axial parameter on the segment; `Scene::surface` turns it into a `SurfaceHit`. Nothing
//! per triangle is ever indexed with such an id: the few per-triangle tables the
//! integrators read for a hit (lights, light linking, holdout, ray visibility) are read
//! with `get`, which gives "none" for it.
//!
//! Memory: 16 bytes per control point (xyz, radius), 4 per segment (its first point, in
//! BVH order), 24 per strand and the BVH's nodes (`Curves::bytes`, measured in
//! docs/benchmarks.md).

pub mod bvh;
pub mod info;
pub mod ribbon;
pub mod round_cone;
pub mod shade;

use crate::accel::Hit;
use crate::scene::hit::SurfaceHit;
use glam::{Vec2, Vec3, Vec4, Vec4Swizzles};

/// Set in `Hit::tri` for a curve segment's hit.
pub const CURVE_BIT: u32 = 1 << 31;

/// True when a hit's primitive id is a curve segment's (not a point's, whose id has this bit
/// and the next: `points::POINT_BITS`).
#[inline(always)]
pub fn is_curve(prim: u32) -> bool {
    prim & crate::points::POINT_BITS == CURVE_BIT
}

/// One strand: a run of consecutive control points, root first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Strand {
    /// Index of its root in `Curves::points`.
    pub first: u32,
    /// Number of control points (at least 2).
    pub count: u32,
    /// Material index.
    pub material: u32,
    /// Texture coordinates of the root (glTF convention), given to every point of the strand.
    pub uv: Vec2,
    /// Index of the curves object (`Curves::objects`) it belongs to.
    pub object: u32,
}

/// All strands of a scene, in world space, and their BVH.
#[derive(Clone, Debug, Default)]
pub struct Curves {
    /// Control points: centre (xyz) and radius (w).
    pub points: Vec<Vec4>,
    /// Strands, in order of their first point.
    pub strands: Vec<Strand>,
    /// Names of the curves objects (hair systems, Curves objects), for messages.
    pub objects: Vec<String>,
    /// Per curves object, the name of the Blender object it belongs to (light linking).
    pub object_names: Vec<String>,
    /// Per curves object, true when it is drawn as ray-facing ribbons (`ribbon.rs`).
    pub ribbons: Vec<bool>,
    /// Per curves object, what Curves Info needs beyond the points (`info.rs`).
    pub info: Vec<info::ObjectInfo>,
    /// The segments' BVH; None until `build` (and when there are no strands).
    pub bvh: Option<bvh::CurveBvh>,
}

impl Curves {
    /// True when there is nothing to intersect.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.bvh.is_none()
    }

    /// Number of segments.
    pub fn segments(&self) -> usize {
        self.strands.iter().map(|s| s.count as usize - 1).sum()
    }

    /// Builds the BVH over every segment (after all strands are added).
    pub fn build(&mut self) {
        self.bvh = if self.strands.is_empty() {
            None
        } else {
            Some(bvh::CurveBvh::build(&self.points, &self.strands, &self.ribbons))
        };
    }

    /// Bytes held: points, strands and the BVH (for the memory figures).
    pub fn bytes(&self) -> usize {
        self.points.len() * size_of::<Vec4>()
            + self.strands.len() * size_of::<Strand>()
            + self.bvh.as_ref().map_or(0, |b| b.bytes())
    }

    /// The strand holding control point `first` of a segment.
    #[inline]
    pub(crate) fn strand_of(&self, point: u32) -> &Strand {
        let i = self.strands.partition_point(|s| s.first <= point) - 1;
        &self.strands[i]
    }

    /// The centre of the sphere a curve hit touches: a point on the strand's axis (on a
    /// ribbon, on its Catmull-Rom curve).
    pub fn axis_point(&self, hit: &Hit) -> Vec3 {
        if let Some(p) = self.ribbon_points(hit) {
            return ribbon::catmull_rom(&p, hit.b1).xyz();
        }
        let k = self.first_point(hit) as usize;
        self.points[k].xyz().lerp(self.points[k + 1].xyz(), hit.b1)
    }

    /// The Catmull-Rom control points of a ribbon hit's segment (None on a round strand).
    fn ribbon_points(&self, hit: &Hit) -> Option<[Vec4; 4]> {
        let bvh = self.bvh.as_ref()?;
        let id = hit.tri & !CURVE_BIT;
        bvh.is_ribbon(id).then(|| bvh.ribbon_points(&self.points, id))
    }

    /// Position along the strand of a curve hit: 0 at the root, 1 at the tip.
    pub fn v(&self, hit: &Hit) -> f32 {
        let k = self.first_point(hit);
        let strand = self.strand_of(k);
        ((k - strand.first) as f32 + hit.b1) / (strand.count - 1) as f32
    }

    /// The curves object (index into `objects`) of a curve hit's primitive (`Hit::tri`).
    #[inline]
    pub fn object_of_prim(&self, prim: u32) -> u32 {
        match &self.bvh {
            Some(bvh) => self.strand_of(bvh.first_point(prim & !CURVE_BIT)).object,
            None => 0,
        }
    }

    /// The strand a curve hit is on.
    pub fn strand_of_hit(&self, hit: &Hit) -> &Strand {
        self.strand_of(self.first_point(hit))
    }

    #[inline]
    fn first_point(&self, hit: &Hit) -> u32 {
        let bvh = self.bvh.as_ref().expect("a curve hit comes from the curves' BVH");
        bvh.first_point(hit.tri & !CURVE_BIT)
    }

    /// The surface of a curve hit seen along `dir`: the point on the touching sphere, its
    /// outward normal (always facing the ray: only entries are hits), the strand's direction
    /// root to tip as the tangent, the root's UV in both sets (as Cycles gives curves). On a
    /// ribbon: the point on the strip and Cycles' rounded normal there.
    pub fn surface(&self, hit: &Hit, org: Vec3, dir: Vec3) -> SurfaceHit {
        let k = self.first_point(hit);
        let strand = self.strand_of(k);
        let (a, b) = (self.points[k as usize], self.points[k as usize + 1]);
        let s = hit.b1;
        let (p, n, along) = match self.ribbon_points(hit) {
            Some(cr) => {
                // The Catmull-Rom curve's tangent: the rounded normal and the fibre follow it.
                let tangent = ribbon::catmull_rom_tangent(&cr, s);
                (org + dir * hit.t, ribbon::normal_along(dir, tangent, hit.b2), tangent)
            }
            None => {
                let n = round_cone::normal(org + dir * hit.t, a, b, s);
                (a.xyz().lerp(b.xyz(), s) + n * (a.w + (b.w - a.w) * s), n, b.xyz() - a.xyz())
            }
        };
        let along = along.normalize_or(n.any_orthonormal_vector());
        SurfaceHit {
            p,
            ng: n,
            ns: n,
            tangent: along.extend(1.0),
            uv: [strand.uv; 2],
            color: Vec4::ONE,
            material: strand.material,
            tri: hit.tri,
            // The axial parameter on the segment, which Curves Info reads (`info.rs`).
            bary: glam::Vec2::new(s, 0.0),
            front: true,
            t: hit.t,
            // The walker sets the ray's state (`advance_with`), as for triangles.
            light_path: crate::scene::light_path::LightPath::CAMERA_RAY.at(hit.t),
        }
    }
}
