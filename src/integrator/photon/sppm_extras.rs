//! SPPM's data passes (Mist, Position, UV, AO, the indices, Vector), Cryptomatte and
//! shader AOVs. Each depends only on the camera ray (`data_passes::fill`,
//! `shader_aovs::fill`, which draw their own numbers from the pixel sample's hash), so after
//! SPPM's iterations a side film takes, for every pixel and completed iteration, the camera
//! ray of that iteration (drawn from the same sampler dimensions as `sppm::render`'s) and
//! the image takes the film's passes: the means over the iterations' camera samples, as
//! the progressive driver's over its samples.

use crate::film::{CameraSample, Film, FilmImage};
use crate::integrator::{SceneContext, data_passes, shader_aovs};
use crate::passes::PassSet;
use crate::render::job::TILE_SIZE;
use crate::render::job::{RayStats, RenderJob};
use crate::sampling::PixelSampler;
use crate::scene::camera::CameraRays;
use glam::Vec2;
use rayon::prelude::*;

/// True when `passes` asks for something the side film gives.
pub fn wanted(passes: PassSet) -> bool {
    passes.any_data() || passes.any_crypto() || passes.shader_aov_channels() > 0
}

/// Fills `img`'s data passes, Cryptomatte and shader AOVs for `iterations` completed
/// iterations of `job`, counting the rays in `rays`, and returns the side film whose sums
/// they are (a chunk's sums of them: they depend only on the sample indices, so SPPM's
/// chunks merge them exactly). Nothing when none is asked.
pub fn fill(
    ctx: &SceneContext,
    camera: &CameraRays,
    job: &RenderJob,
    iterations: u32,
    img: &mut FilmImage,
    rays: &mut RayStats,
) -> Option<Film> {
    if !wanted(job.passes) || iterations == 0 {
        return None;
    }
    let [x0, y0, x1, y1] = job.window;
    let mut film = Film::with_passes(x1 - x0, y1 - y0, TILE_SIZE, job.passes);
    let want_data = job.passes.any_data() || job.passes.any_crypto();
    let want_aovs = job.passes.shader_aov_channels() > 0;
    let tile_rays: Vec<RayStats> = film
        .tiles
        .par_iter_mut()
        .map(|tile| {
            let mut rs = RayStats::default();
            for ty in 0..tile.h {
                for tx in 0..tile.w {
                    let k = (ty * tile.w + tx) as usize;
                    let (px, py) = (x0 + tile.x0 + tx, y0 + tile.y0 + ty);
                    for it in 0..iterations {
                        let i = job.sample_offset + it;
                        let mut sampler = PixelSampler::new(job.seed, px, py, i);
                        let off = job.filter.camera_offset(i, sampler.next_2d());
                        let u_lens = if camera.has_lens() { sampler.next_2d() } else { Vec2::ZERO };
                        let ray = camera.sample_clipped(px as f32 + 0.5 + off.x, py as f32 + 0.5 + off.y, u_lens);
                        let mut s = CameraSample { depth: f32::INFINITY, ..Default::default() };
                        let pixel_sample = (job.seed, px, py, i);
                        if want_data {
                            data_passes::fill(ctx, camera, &ray, &mut s, job.passes, &job.data, pixel_sample, &mut rs);
                        }
                        if want_aovs {
                            shader_aovs::fill(ctx, &ray, &mut s, pixel_sample, &mut rs);
                        }
                        // A non-finite value drops the sample, as in the progressive driver.
                        tile.add(k, &s);
                    }
                }
            }
            rs
        })
        .collect();
    for r in &tile_rays {
        rays.add(r);
    }
    let side = film.image();
    // The light passes are SPPM's own (`sppm_passes`); the side film's are empty.
    img.extra.extend(side.extra.into_iter().filter(|(p, _)| !p.is_light()));
    img.crypto = side.crypto;
    img.shader_aovs = side.shader_aovs;
    Some(film)
}
