//! Hair BSDFs on a triangle, as Cycles shades a mesh whose material has them (a hair particle
//! system's emitter wears its hair's material by default): the Principled Hair BSDF (Chiang)
//! about the triangle's `dPdu`, the Hair BSDF about its `dPdv`, the point on the surface.
//!
//! Cycles' fibre (`bsdf_hair_chiang_setup`): X = dPdu, Y = X × wi, Z = X × Y and
//! h = (Ng × X)·Z, Ng the geometric normal on the viewer's side; on a triangle dPdu = p1 − p0
//! and dPdv = p2 − p0 in its corner order (`triangle_dPdudv`; both turned round on a back face,
//! which the cuticle tilt reads), which is the exporter's (the
//! mesh's loop triangles) but on a mirrored instance, where the loader turns corners 1 and 2
//! (`gltf/mesh.rs`) and the two tangents trade places. The Hair BSDF (`svm_node_closure_bsdf`)
//! takes T = dPdv on a triangle, no Offset, and cuts its lobes at the shading normal.
//!
//! The shading frame is the triangle's: z its geometric normal on the viewer's side, x the
//! fibre (both tangents lie in the triangle's plane). Both BSDFs measure azimuths from the
//! viewer's direction across the fibre, so a frame turned about the fibre gives them the same
//! values (`hair_lobes`' test `any_frame_about_the_fibre`; Chiang's reads only differences of
//! azimuths). With z the geometric normal, the integrators' side tests (a direction below z
//! crosses the triangle) and ray offsets (across the triangle, to the side the ray leaves by)
//! hold as for any surface: a ray leaving into the mesh starts behind the triangle it leaves
//! and never meets it, as Cycles skips the primitive a ray leaves.

use crate::bsdf::Bsdf;
use crate::bsdf::hair::BumpCut;
use crate::curves::shade::hair_frame;
use crate::math::{Frame, Rgb};
use crate::scene::Scene;
use crate::scene::bent_normal::valid_reflection_normal;
use crate::scene::hit::{ShadingPoint, SurfaceHit};
use crate::shader::closure::Closures;
use glam::Vec3;

/// The shading point of triangle hit `s` seen from `wo` with a graph's hair closures `c`,
/// their weights times `keep`: the Principled Hair BSDFs (parameters averaged by weight, as on
/// strands), else the Hair BSDF's lobes.
pub fn hair_on_triangle(
    scene: &Scene,
    c: &Closures,
    s: &SurfaceHit,
    wo: Vec3,
    keep: f32,
    emitted: Rgb,
    holdout: f32,
) -> ShadingPoint {
    let ([p0, p1, p2], _) = scene.corners(s.tri);
    // Cycles turns dPdu and dPdv round with the normals on a back face: the fibre's root-to-tip
    // sense, which the Principled Hair BSDF's cuticle tilt (Offset) reads, follows the viewer's side.
    let sense = if s.front { 1.0 } else { -1.0 };
    let (bsdf, frame) = match c.hair_params() {
        Some(params) => {
            let frame = Frame::from_normal_tangent(s.ng, (p1 - p0) * sense);
            // Cycles' Z is the hair frame's −z (`hair_frame`): away from the viewer.
            let h = s.ng.cross(frame.s).dot(-hair_frame(frame.s, wo).n);
            let mut bsdf = params.at(h).weighted(Rgb::splat(c.hair_w * keep));
            // Cycles' closure normal is its Y = X × wi (`BumpCut`).
            let y = frame.s.cross(wo).normalize_or(frame.t);
            bsdf.cut = Some(BumpCut { ns: frame.to_local(shading_normal(c, s)), n: frame.to_local(y) });
            (Bsdf::Hair(bsdf), frame)
        }
        None => {
            let frame = Frame::from_normal_tangent(s.ng, (p2 - p0) * sense);
            let mut lobes = c.hair_lobes;
            for l in &mut lobes.lobes {
                l.weight *= keep;
                l.offset = 0.0;
            }
            // Cycles' `bsdf->N`: the shading normal, bent for a valid reflection; where it is
            // bent, Cycles cuts the evaluation by it (`BumpCut`).
            let n = shading_normal(c, s);
            let bent = valid_reflection_normal(s.ng, wo, n);
            lobes.normal = frame.to_local(bent);
            lobes.smooth = (bent != n).then(|| frame.to_local(n));
            (Bsdf::HairLobes(lobes), frame)
        }
    };
    ShadingPoint { bsdf, frame, emitted, holdout }
}

/// Cycles' `sd->N` at triangle hit `s`: the interpolated normal, or the Material Output's
/// bump, on the viewer's side.
fn shading_normal(c: &Closures, s: &SurfaceHit) -> Vec3 {
    let facing = |m: Vec3| if m.dot(s.ng) < 0.0 { -m } else { m };
    c.default_normal_world().map_or(s.ns, facing)
}

/// The share of a point's samples the hair closures take where a mesh mixes them with other
/// closures (Cycles evaluates them all; one BSDF a point holds either, chosen by weight at each
/// point with the weight of both, so a pixel averages the mixture): their weight over all the
/// closures' (mean over channels), 1 with hair closures alone.
pub fn hair_share(c: &Closures) -> f32 {
    let grey = |w: Rgb| ((w.x + w.y + w.z) / 3.0).max(0.0);
    let hair =
        if c.hair_params().is_some() { c.hair_w } else { c.hair_lobes.used().iter().map(|l| grey(l.weight)).sum() };
    let rest: f32 = c.pbr_w.iter().map(|w| w.max(0.0)).sum::<f32>()
        + c.mix.weights[..c.mix.n as usize].iter().map(|&w| grey(w)).sum::<f32>();
    if rest > 0.0 { hair / (hair + rest) } else { 1.0 }
}

/// A uniform number in [0, 1) for the choice between the hair closures and the others at the
/// point of `s`: a hash of its position and triangle, so every evaluation of one point (its
/// light samples, BSDF samples and connections) sees the same choice.
pub fn choice_u(s: &SurfaceHit) -> f32 {
    use crate::shader::texture::hash::hash_uint4;
    let h = hash_uint4(s.p.x.to_bits(), s.p.y.to_bits(), s.p.z.to_bits() ^ s.tri, 0x6861_6972);
    (h >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}
