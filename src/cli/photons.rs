//! `caustic photons`: traces a scene's photon maps and writes them to a file.

use super::args::*;
use super::render::{build_bsdf_tables, charge_bvh, charge_photon_maps, map_stats_json, trace_maps};
use super::settings::resolve_photon;
use crate::accel::Accel;
use crate::error::{Error, Result};
use crate::integrator::SceneContext;
use crate::integrator::path::PathIntegrator;
use crate::integrator::photon;
use crate::memory::MemoryBudget;
use crate::progress::{ProgressMode, Reporter};
use crate::scene;
use serde_json::json;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// `caustic photons`: traces the maps of a scene and writes them.
pub fn run_photons(args: &PhotonsArgs, reporter: &Reporter, stop: &AtomicBool) -> Result<()> {
    let t0 = Instant::now();
    reporter.phase("loading", 0.0);
    let budget = MemoryBudget::from_flag(args.memory_limit.as_deref())?;
    let mut scene = scene::gltf::load_within(&args.scene, &budget)?;
    super::settings::scene_view(&mut scene)?;
    for w in &scene.warnings {
        reporter.warning(w);
    }
    let st = &scene.settings;
    let p = resolve_photon(&args.photon, st)?;
    let max_depth = args.max_depth.or(st.max_depth).unwrap_or(PathIntegrator::default().max_depth);
    if max_depth == 0 || max_depth > photon::MAX_PHOTON_DEPTH {
        return Err(Error::Usage(format!(
            "--max-depth {max_depth} must be in 1..={} for a photon map",
            photon::MAX_PHOTON_DEPTH
        )));
    }
    charge_bvh(&budget, &scene)?;
    charge_photon_maps(&budget, &p, max_depth)?;
    let seed = args.seed.or(st.seed).unwrap_or(0);
    let threads = match args.threads.or(st.threads) {
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
        Some(0) => return Err(Error::Usage("--threads must be at least 1".into())),
        Some(t) => t.min(4096),
    };
    let hash = scene.source_hash;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::Internal(format!("cannot start worker threads: {e}")))?;
    reporter.phase("bvh", t0.elapsed().as_secs_f64());
    let tris: Vec<[glam::Vec3; 3]> =
        scene.mesh.triangles.iter().map(|t| t.map(|i| scene.mesh.positions[i as usize])).collect();
    let accel = pool.install(|| {
        build_bsdf_tables(&scene);
        Accel::build(&tris)
    });
    // Photons honour light and shadow linking, as `caustic render`'s maps.
    // Photons carry the kinds of camera ray that may read them, as in `caustic render`.
    let ctx = SceneContext::new(&scene, &accel).with_ray_visibility().with_light_linking();
    reporter.phase("photons", t0.elapsed().as_secs_f64());
    let (maps, ms) = pool.install(|| trace_maps(&ctx, &p, seed, max_depth, hash, reporter, stop));
    if stop.load(Ordering::Relaxed) {
        return Err(Error::InterruptedEmpty);
    }
    reporter.phase("writing", t0.elapsed().as_secs_f64());
    maps.save(&args.output)?;
    let mut summary = map_stats_json(&maps, &ms);
    summary["output"] = json!(args.output.display().to_string());
    summary["elapsed"] = json!(t0.elapsed().as_secs_f64());
    summary["max_depth"] = json!(max_depth);
    summary["seed"] = json!(seed);
    if reporter.mode() == ProgressMode::Json {
        reporter.summary(summary);
    } else {
        eprintln!(
            "wrote {} ({} global + {} caustic photons stored, {:.2} M photons/s) in {:.2} s",
            args.output.display(),
            ms.global.stored,
            ms.caustic.stored,
            summary["photons_traced_per_sec"].as_f64().unwrap_or(0.0) / 1e6,
            t0.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
