//! The data passes of a camera sample (Mist, Position, UV, Ambient Occlusion, Object and
//! Material Index, Cryptomatte's ids), from the
//! camera ray's first opaque hit, the same for every integrator that renders camera
//! samples (`crate::passes` says what each pass holds, after Cycles' `data_passes.h` and
//! its AO pass). Costs one more closest-hit ray per sample (and one AO ray), only when a
//! data pass is asked for. Transparent surfaces (BLEND alpha) are not looked through:
//! the first surface hit gives the values.

use super::SceneContext;
use crate::film::CameraSample;
use crate::math::{Frame, offset_ray_origin};
use crate::passes::{DataSettings, Pass, PassSet, slot};
use crate::render::job::RayStats;
use crate::sampling::warp::cosine_hemisphere;
use crate::scene::camera::{CameraRay, CameraRays};
use glam::Vec2;

/// Two uniform numbers for the AO ray of pixel sample (seed, x, y, i), apart from the
/// sampler's stream so that asking for AO changes no other pass (SplitMix64 of the tuple).
fn ao_numbers(pixel_sample: (u32, u32, u32, u32)) -> Vec2 {
    let (seed, x, y, i) = pixel_sample;
    let mut z = (seed as u64) << 32 ^ (x as u64) << 48 ^ (y as u64) << 16 ^ i as u64 ^ 0xA0_A0A0_A0A0;
    let mut next = || {
        z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut v = z;
        v = (v ^ (v >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        v = (v ^ (v >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((v ^ (v >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    };
    Vec2::new(next(), next())
}

/// Fills the asked data passes of camera sample `out` along camera ray `ray`.
#[allow(clippy::too_many_arguments)]
pub fn fill(
    ctx: &SceneContext,
    camera: &CameraRays,
    ray: &CameraRay,
    out: &mut CameraSample,
    passes: PassSet,
    settings: &DataSettings,
    pixel_sample: (u32, u32, u32, u32),
    stats: &mut RayStats,
) {
    if ray.is_blind() {
        return; // outside a panoramic camera's lens: nothing seen
    }
    let org = if ray.near > 0.0 { ray.org + ray.dir * ray.near } else { ray.org };
    let Some(hit) = ctx.intersect(org, ray.dir, ray.far - ray.near) else {
        return; // the defaults: mist 1, everything else 0
    };
    stats.camera += 1;
    let s = ctx.scene.surface(&hit, org, ray.dir);
    if passes.any_crypto() {
        // Weight 1 per sample: an opaque first hit (Cycles' throughput × (1 − transparency)).
        out.crypto = ctx.scene.pass_ids.crypto(s.tri, s.material);
    }
    let a = &mut out.aov.0;
    if passes.contains(Pass::Mist) {
        // Distance from the camera, not Z (Cycles' camera_distance).
        a[slot::MIST] = settings.mist((s.p - ray.org).length());
    }
    if passes.contains(Pass::Position) {
        a[slot::POS..slot::POS + 3].copy_from_slice(&s.p.to_array());
    }
    if passes.contains(Pass::Uv) {
        // glTF's v runs down the image, Blender's up.
        let uv = s.uv[0];
        a[slot::UV..slot::UV + 3].copy_from_slice(&[uv.x, 1.0 - uv.y, 1.0]);
    }
    if passes.contains(Pass::ObjectIndex) || passes.contains(Pass::MaterialIndex) {
        let [ob, ma] = ctx.scene.pass_ids.indices(s.tri, s.material);
        (a[slot::OB], a[slot::MA]) = (ob, ma);
    }
    if passes.contains(Pass::Vector) {
        let v = crate::motion::vector::motion_vector(ctx.scene.motion.as_ref(), camera, &hit, s.p);
        a[slot::VECTOR..slot::VECTOR + 4].copy_from_slice(&v);
    }
    if passes.contains(Pass::AmbientOcclusion) {
        // Cycles: one cosine-distributed ray about the shading normal, as long as the AO
        // distance; the pass is the unoccluded fraction. The normal faces the camera.
        let n = if s.ns.dot(ray.dir) > 0.0 { -s.ns } else { s.ns };
        let ng = if s.ng.dot(n) < 0.0 { -s.ng } else { s.ng };
        let wi = Frame::from_normal(n).to_world(cosine_hemisphere(ao_numbers(pixel_sample)));
        if wi.dot(ng) > 0.0 {
            stats.shadow += 1;
            let from = offset_ray_origin(s.p, ng);
            a[slot::AO] =
                ctx.transmittance(from, wi, settings.ao_distance, crate::scene::light_path::LightPath::SHADOW_RAY);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mist_follows_blender() {
        let d = DataSettings::default();
        assert_eq!(d.mist(4.0), 0.0);
        assert_eq!(d.mist(30.0), 1.0);
        assert!((d.mist(17.5) - 0.25).abs() < 1e-6); // ((17.5 - 5) / 25)^2
    }

    #[test]
    fn ao_numbers_are_uniform_and_distinct() {
        let a = ao_numbers((0, 1, 2, 3));
        assert!((0.0..1.0).contains(&a.x) && (0.0..1.0).contains(&a.y) && a.x != a.y);
        assert_ne!(a, ao_numbers((0, 1, 2, 4)));
    }
}
