//! The shader AOVs of a camera sample (`crate::scene::shader_aovs`), the same for every
//! integrator that renders camera samples, as `data_passes` are.
//!
//! Cycles' rule (`svm_node_aov_check`): a surface's AOV Output nodes write while the path
//! is a camera ray that has passed only transparent surfaces and no surface has yet
//! ended the "single pass" (`PATH_RAY_SINGLE_PASS_DONE`, set at the first surface whose
//! alpha reaches the view layer's Alpha Threshold). So the camera ray is walked here: at
//! each hit the material's AOVs are added; a surface at least as opaque as the threshold
//! is the last; a more transparent one is passed with probability 1 − alpha (Cycles picks
//! its transparent closure by weight, which is 1 − alpha of the closures' total), else
//! the path turned there and writes nothing more. A ray that leaves the scene on the way
//! reaches the world, whose AOV Output nodes then write (Cycles' background shader, with
//! the camera ray's path flags and ray length `FLT_MAX`). Costs one closest-hit ray per
//! surface walked, only when the render asks for shader AOVs.

use super::SceneContext;
use super::walk::MAX_TRANSPARENT_HITS;
use crate::film::CameraSample;
use crate::math::offset_ray_origin;
use crate::render::job::RayStats;
use crate::scene::camera::CameraRay;
use crate::scene::light_path::LightPath;
use crate::scene::material::AlphaMode;
use crate::scene::visibility::RayMask;

/// A uniform number in [0, 1) for the `k`-th pass-through decision of pixel sample
/// (seed, x, y, i), apart from the sampler's stream so that asking for AOVs changes no
/// other pass (SplitMix64 of the tuple).
pub(super) fn pass_number(pixel_sample: (u32, u32, u32, u32), k: u32) -> f32 {
    let (seed, x, y, i) = pixel_sample;
    let mut v = ((seed as u64) << 32 ^ (x as u64) << 48 ^ (y as u64) << 16 ^ i as u64 ^ (k as u64) << 56)
        .wrapping_add(0x5AE_A0F5_u64.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    v = (v ^ (v >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    v = (v ^ (v >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((v ^ (v >> 31)) >> 40) as f32 / (1u64 << 24) as f32
}

/// Adds the shader AOVs along camera ray `ray` to sample `out` (see the module doc).
pub fn fill(
    ctx: &SceneContext,
    ray: &CameraRay,
    out: &mut CameraSample,
    pixel_sample: (u32, u32, u32, u32),
    stats: &mut RayStats,
) {
    if ray.is_blind() {
        return; // outside a panoramic camera's lens: nothing seen
    }
    let aovs = &ctx.scene.shader_aovs;
    let mut org = if ray.near > 0.0 { ray.org + ray.dir * ray.near } else { ray.org };
    let mut tmax = ray.far - ray.near;
    let mut path = LightPath::camera(ray.footprint.moved(ray.near.max(0.0)));
    for k in 0..=MAX_TRANSPARENT_HITS {
        let Some(hit) = ctx.intersect_as(org, ray.dir, tmax, RayMask::CAMERA) else {
            if let Some(world) = &aovs.world_graph {
                let sums = &mut out.shader_aovs;
                world.with_aov_registers(ray.dir, path.at(f32::MAX), |prog, regs| {
                    crate::shader::aov::add_targets(prog, &aovs.world, regs, sums)
                });
            }
            return;
        };
        stats.camera += 1;
        let s = ctx.scene.surface(&hit, org, ray.dir);
        let mat = &ctx.scene.materials[s.material as usize];
        let s = crate::scene::hit::SurfaceHit { light_path: path.at(hit.t), ..s };
        // A volume boundary without a surface is passed as Cycles passes it: transparently.
        let alpha = if mat.null_surface {
            0.0
        } else {
            if let Some(prog) = &mat.nodes {
                let targets = aovs.of_material(s.material);
                if !targets.is_empty() {
                    crate::shader::aov::write(ctx.scene, prog, targets, &s, -ray.dir, &mut out.shader_aovs, Some(ctx));
                }
            }
            match mat.alpha_mode {
                AlphaMode::Blend => ctx.scene.pass_through(hit.tri, hit.b1, hit.b2, s.light_path, ray.dir).0,
                _ => 1.0,
            }
        };
        // The last surface: opaque enough, or the path turned here (probability alpha).
        if !mat.null_surface && (alpha >= aovs.alpha_threshold || pass_number(pixel_sample, k) < alpha) {
            return;
        }
        path = path.moved(hit.t).passed_transparent();
        org = offset_ray_origin(s.p, -s.ng);
        tmax -= hit.t;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pass_numbers_are_uniform_and_distinct() {
        let n = 4096;
        let mean = (0..n).map(|k| pass_number((1, 2, 3, k), 0)).sum::<f32>() / n as f32;
        // The mean of n uniforms has standard deviation 1/sqrt(12 n) ≈ 0.0045: 5σ.
        assert!((mean - 0.5).abs() < 5.0 / (12.0 * n as f32).sqrt(), "{mean}");
        assert_ne!(pass_number((1, 2, 3, 4), 0), pass_number((1, 2, 3, 4), 1));
    }
}
