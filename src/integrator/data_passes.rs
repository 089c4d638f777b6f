//! The data passes of a camera sample (Mist, Position, UV, Ambient Occlusion, Object and
//! Material Index, Cryptomatte's ids), the same for every integrator that renders camera
//! samples (`crate::passes` says what each pass holds, after Cycles' `data_passes.h` and
//! its AO pass). The camera ray is walked through BLEND surfaces as Cycles' path passes
//! them (`shader_aovs` walks it alike): it ends at a surface with probability alpha, Mist
//! sums (1 − mist) × alpha over the surfaces reached, Cryptomatte takes the surface where it
//! ended, and the single-pass values come from the first surface whose alpha reaches the
//! view layer's Alpha Threshold (Position and the indices from the last surface reached when
//! none does and the ray ends on a surface, nothing when it leaves the scene). An alpha-cut leaf's see-through texels thus give the surface behind them.
//! Objects hidden from camera rays are passed. Costs a closest-hit ray per surface walked
//! (and one AO ray), only when a data pass is asked for.

use super::SceneContext;
use super::shader_aovs::pass_number;
use super::walk::MAX_TRANSPARENT_HITS;
use crate::accel::Hit;
use crate::film::CameraSample;
use crate::math::{Frame, offset_ray_origin};
use crate::passes::{DataSettings, Pass, PassSet, slot};
use crate::render::job::RayStats;
use crate::sampling::warp::cosine_hemisphere;
use crate::scene::camera::{CameraRay, CameraRays};
use crate::scene::hit::SurfaceHit;
use crate::scene::light_path::LightPath;
use crate::scene::material::AlphaMode;
use crate::scene::visibility::RayMask;
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
    let threshold = ctx.scene.shader_aovs.alpha_threshold;
    let mut org = if ray.near > 0.0 { ray.org + ray.dir * ray.near } else { ray.org };
    let mut tmax = ray.far - ray.near;
    let mut path = LightPath::camera(ray.footprint.moved(ray.near.max(0.0)));
    // Σ (1 − mist) × alpha over the surfaces the walk reaches (Cycles' mist_output).
    let mut unmisted = 0.0;
    // The surface that gives the single-pass values, and whether it reached the threshold.
    let mut chosen: Option<(Hit, SurfaceHit, bool)> = None;
    for k in 0..=MAX_TRANSPARENT_HITS {
        let Some(hit) = ctx.intersect_as(org, ray.dir, tmax, RayMask::CAMERA) else {
            // The background overwrites what the surfaces passed wrote (Cycles'
            // film_write_data_passes_background), unless one reached the threshold.
            if !matches!(chosen, Some((_, _, true))) {
                chosen = None;
            }
            break;
        };
        stats.camera += 1;
        let s = ctx.scene.surface(&hit, org, ray.dir);
        let mat = &ctx.scene.materials[s.material as usize];
        let alpha = if mat.null_surface {
            0.0
        } else {
            match mat.alpha_mode {
                AlphaMode::Blend => ctx.scene.pass_through(hit.tri, hit.b1, hit.b2, path.at(hit.t), ray.dir).0,
                _ => 1.0,
            }
        };
        if !mat.null_surface {
            // Distance from the camera, not Z (Cycles' camera_distance).
            unmisted += (1.0 - settings.mist((s.p - ray.org).length())) * alpha;
            if !matches!(chosen, Some((_, _, true))) {
                chosen = Some((hit, s, alpha >= threshold));
            }
            // The path ends here with probability alpha (it takes another closure).
            if alpha >= 1.0 || pass_number(pixel_sample, k) < alpha {
                if passes.any_crypto() {
                    // Weight 1 per sample where the path stops: expected alpha × what
                    // reaches the surface, Cycles' throughput × (1 − transparency).
                    out.crypto = ctx.scene.pass_ids.crypto(s.tri, s.material);
                }
                break;
            }
        }
        path = path.moved(hit.t).passed_transparent();
        org = offset_ray_origin(s.p, -s.ng);
        tmax -= hit.t;
    }
    let a = &mut out.aov.0;
    if passes.contains(Pass::Mist) {
        a[slot::MIST] = 1.0 - unmisted;
    }
    // Cycles writes Depth, Position and the indices at every surface of sample 0's camera ray
    // (and zeros at the background) until one reaches the view layer's Alpha Threshold
    // (`PATH_RAY_SINGLE_PASS_DONE`), so the last one written stands; UV, Vector and AO only at
    // that one.
    let Some((hit, s, opaque)) = chosen else {
        return; // the defaults: mist 1, everything else 0
    };
    if passes.contains(Pass::Position) {
        a[slot::POS..slot::POS + 3].copy_from_slice(&s.p.to_array());
    }
    if passes.contains(Pass::ObjectIndex) || passes.contains(Pass::MaterialIndex) {
        let [ob, ma] = ctx.scene.pass_ids.indices(s.tri, s.material);
        (a[slot::OB], a[slot::MA]) = (ob, ma);
    }
    if !opaque {
        return;
    }
    if passes.contains(Pass::Uv) {
        // glTF's v runs down the image, Blender's up.
        let uv = s.uv[0];
        a[slot::UV..slot::UV + 3].copy_from_slice(&[uv.x, 1.0 - uv.y, 1.0]);
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
