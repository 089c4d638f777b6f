//! `caustic merge`: adds chunks of one frame (renders of disjoint sample ranges written
//! with `--chunk`) into the image a single render of all their samples gives, exactly:
//! the chunks carry fixed-point sums, and integer addition does not depend on the order.
//! Depth takes the minimum; light-tracing splats and light-path counts add.

use super::args::MergeArgs;
use crate::chunk::{self, ChunkInfo};
use crate::error::{Error, Result};
use crate::output;
use crate::progress::Reporter;
use serde_json::json;
use std::time::Instant;

/// The first sample index of the chunk at `path` (its header only).
fn read_start(path: &std::path::Path) -> Result<u32> {
    Ok(chunk::read_info(path)?.samples.iter().map(|r| r[0]).min().unwrap_or(u32::MAX))
}

/// `caustic merge`.
pub fn run_merge(args: &MergeArgs, reporter: &Reporter) -> Result<()> {
    let t0 = Instant::now();
    reporter.phase("loading", 0.0);
    output::clean_stale_temps(&args.output);
    output::check_writable(&args.output)?;
    // Cryptomatte's lists are appended in sample order (`Film::merge_crypto`): the chunks are
    // merged by their first sample, whatever the order of the arguments.
    let mut order: Vec<(u32, &std::path::PathBuf)> =
        args.inputs.iter().map(|p| Ok((read_start(p)?, p))).collect::<Result<Vec<_>>>()?;
    order.sort_by_key(|(s, _)| *s);
    let mut inputs = order.into_iter().map(|(_, p)| p);
    let first = inputs.next().ok_or_else(|| Error::Usage("merge needs at least one chunk".into()))?;
    let chunk::Chunk { info, mut film, metadata } = chunk::read(first)?;
    let mut ranges: Vec<([u32; 2], &std::path::Path)> = info.samples.iter().map(|r| (*r, first.as_path())).collect();
    let mut merged = ChunkInfo { samples: Vec::new(), ..info.clone() };
    // Per pixel, the first sample index of the chunk whose first-sample values (Position,
    // the indices: a single render keeps its sample 0's) the merged film holds.
    let start = |c: &ChunkInfo| c.samples.iter().map(|r| r[0]).min().unwrap_or(u32::MAX);
    let mut first_from: Vec<u32> = (0..film.height)
        .flat_map(|y| (0..film.width).map(move |x| (x, y)))
        .map(|(x, y)| if film.pixel(x, y).n > 0 { start(&info) } else { u32::MAX })
        .collect();
    let mut folded = info.crypto_folded;
    for path in inputs {
        let c = chunk::read(path)?;
        folded += c.info.crypto_folded;
        info.check_compatible(&c.info, first, path)?;
        ranges.extend(c.info.samples.iter().map(|r| (*r, path.as_path())));
        let s = start(&c.info);
        for y in 0..film.height {
            for x in 0..film.width {
                let f = &mut first_from[(y * film.width + x) as usize];
                let other_first = c.film.pixel(x, y).n > 0 && s < *f;
                if other_first {
                    *f = s;
                }
                film.merge_pixel(x, y, &c.film, other_first);
            }
        }
        for (a, b) in film.splat.iter_mut().zip(&c.film.splat) {
            crate::fixed::sum3(a, b);
        }
        if film.splat_extra.is_empty() {
            film.splat_extra = vec![[0; 3]; c.film.splat_extra.len()];
        }
        for (a, b) in film.splat_extra.iter_mut().zip(&c.film.splat_extra) {
            crate::fixed::sum3(a, b);
        }
        film.light_paths += c.info.light_paths;
    }
    chunk::check_disjoint(&mut ranges)?;
    merged.samples = ranges.iter().map(|(r, _)| *r).collect();
    merged.light_paths = film.light_paths;
    merged.crypto_folded = folded + film.crypto_folded();
    let mut warnings = Vec::new();
    if merged.crypto_folded > 0 {
        let w = format!(
            "{} samples' Cryptomatte ids were counted under another id (a pixel of a chunk saw more than {} ids              in a layer): the merged Cryptomatte is not exactly the single render's there",
            merged.crypto_folded,
            crate::cryptomatte::EXACT_SLOTS
        );
        reporter.warning(&w);
        warnings.push(w);
    }

    reporter.phase("writing", t0.elapsed().as_secs_f64());
    let mut img = film.image();
    img.light_group_names.clone_from(&info.light_groups);
    img.aov_specs.clone_from(&info.shader_aovs);
    // The Cryptomatte manifests of the frame (every chunk has the same).
    img.metadata = metadata;
    crate::shadow_catcher::resolve(&mut img, info.transparent);
    match args.chunk {
        true => output::write_chunk(&args.output, &img, args.half, &film, &merged)?,
        false => output::write_exr(&args.output, &img, args.half)?,
    }
    let spp_min = img.samples.iter().copied().min().unwrap_or(0);
    let spp_max = img.samples.iter().copied().max().unwrap_or(0);
    let out = args.output.display().to_string();
    reporter.image(&out, spp_min, true);
    reporter.summary(json!({
        "output": out,
        "width": img.width,
        "height": img.height,
        "spp": spp_min,
        "spp_max": spp_max,
        "chunks": args.inputs.len(),
        "samples": merged.samples,
        "light_paths": merged.light_paths,
        "integrator": merged.integrator,
        "elapsed": t0.elapsed().as_secs_f64(),
        "interrupted": false,
        "warnings": warnings,
    }));
    Ok(())
}
