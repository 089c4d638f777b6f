//! Curves Info on strands, as Cycles computes it (`blender/curves.cpp`'s curve attributes,
//! `svm_node_hair_info`): Intercept, the fraction of the strand's length from the root along
//! Cycles' keys, interpolated linearly between two keys; Length, the strand's length along its
//! keys in object space; Thickness, twice the radius; Tangent Normal, the view direction made
//! perpendicular to the strand; Random, Cycles' hash of the strand's index in its geometry.
//!
//! Nothing is stored per point or per strand: Intercept and Length walk the strand's keys at
//! each shading point that reads them (a few to a few dozen points), and a curves object
//! carries three numbers (`ObjectInfo`).

use super::{CURVE_BIT, Curves};
use crate::scene::hit::SurfaceHit;
use glam::{Vec3, Vec4Swizzles};

/// What a curves object adds for Curves Info (`CAUSTIC_curves`' `randomBase`, `lengthScale`,
/// `keyStep`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectInfo {
    /// Cycles' index of the object's first strand in its hair geometry (a hair system after
    /// others on the same emitter starts past theirs): Random hashes this plus the strand's.
    pub random_base: u32,
    /// Object-space length per world-space length (Cycles measures Length in object space).
    pub length_scale: f32,
    /// Points per interval between two of Cycles' keys: 1, or the add-on's subdivisions of a
    /// Curves object's Catmull-Rom segments (the keys are every `key_step`-th point).
    pub key_step: u32,
}

impl Default for ObjectInfo {
    fn default() -> Self {
        ObjectInfo { random_base: 0, length_scale: 1.0, key_step: 1 }
    }
}

/// Curves Info's outputs at a strand's shading point (world axes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurveInfo {
    /// 0 at the root, 1 at the tip.
    pub intercept: f32,
    /// The strand's length (object space).
    pub length: f32,
    /// Twice the radius at the point (world).
    pub thickness: f32,
    /// The view direction perpendicular to the strand, unit (world, glTF axes).
    pub tangent_normal: Vec3,
    /// Cycles' per-strand random number in [0, 1].
    pub random: f32,
}

impl Curves {
    /// Curves Info at strand hit `s` (a `Curves::surface`, whose `bary.x` is the axial
    /// parameter on its segment) seen from `wo`.
    pub fn info(&self, s: &SurfaceHit, wo: Vec3) -> CurveInfo {
        let Some(bvh) = self.bvh.as_ref() else {
            return CurveInfo { intercept: 0.0, length: 0.0, thickness: 0.0, tangent_normal: Vec3::ZERO, random: 0.0 };
        };
        let k = bvh.first_point(s.tri & !CURVE_BIT);
        let index = self.strands.partition_point(|st| st.first <= k) - 1;
        let strand = &self.strands[index];
        let object = self.info.get(strand.object as usize).copied().unwrap_or_default();
        let segments = strand.count - 1;
        // A step that does not divide the strand's segments (never written so) counts every point.
        let step = if object.key_step > 0 && segments.is_multiple_of(object.key_step) { object.key_step } else { 1 };
        let (first, j) = (strand.first as usize, k - strand.first);
        let b1 = s.bary.x.clamp(0.0, 1.0);
        let key = |i: u32| self.points[first + (i * step) as usize].xyz();
        let mut total = 0.0;
        let mut before = 0.0;
        let mut this = 0.0;
        let here = j / step;
        for i in 0..segments / step {
            let d = key(i).distance(key(i + 1));
            if i < here {
                before += d;
            } else if i == here {
                this = d;
            }
            total += d;
        }
        // Cycles interpolates the keys' intercepts by the Catmull-Rom parameter between them,
        // which the add-on's pieces divide evenly.
        let u = ((j % step) as f32 + b1) / step as f32;
        let intercept = if total > 0.0 { ((before + u * this) / total).clamp(0.0, 1.0) } else { 0.0 };
        let (a, b) = (self.points[k as usize], self.points[k as usize + 1]);
        let t = s.tangent.truncate();
        let local = index as u32 - self.strands.partition_point(|st| st.object < strand.object) as u32;
        use crate::shader::texture::hash::{hash_uint2, uint_to_float_incl};
        CurveInfo {
            intercept,
            length: total * object.length_scale,
            thickness: 2.0 * (a.w + (b.w - a.w) * b1),
            tangent_normal: (wo - t * t.dot(wo)).normalize_or_zero(),
            random: uint_to_float_incl(hash_uint2(object.random_base.wrapping_add(local), 0)),
        }
    }
}
