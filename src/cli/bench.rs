//! `caustic bench`: renders a scene once and prints speed figures (and, for the photon
//! integrators, photon-map figures).

use super::args::*;
use super::render::{build_bsdf_tables, map_stats_json, run_render, trace_maps};
use super::settings::resolve_photon;
use crate::accel::Accel;
use crate::error::{Error, Result};
use crate::integrator::SceneContext;
use crate::integrator::path::PathIntegrator;
use crate::integrator::photon;
use crate::integrator::photon::default_max_radius;
use crate::progress::{ProgressMode, Reporter};
use crate::scene;
use serde_json::json;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

/// `caustic bench`: renders the scene once to a temporary file and prints the figures.
pub fn run_bench(args: &BenchArgs, stop: &AtomicBool) -> Result<()> {
    let dir = std::env::temp_dir().join(format!("caustic-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let render_args = RenderArgs {
        scene: args.scene.clone(),
        output: dir.join("bench.exr"),
        spp: Some(args.spp),
        resolution: Some(args.resolution),
        max_depth: None,
        light_paths: Default::default(),
        seed: None,
        threads: args.threads,
        time_limit: None,
        camera: None,
        crop: None,
        half: false,
        view: None,
        progress: Some(ProgressMode::None),
        integrator: Some(args.integrator),
        photon_map: None,
        photon_seed: None,
        photon: args.photon.clone(),
        bdpt_strategy: None,
        vcm_radius: None,
        vcm_mode: None,
        sample_offset: None,
        chunk: false,
        interim: None,
        filter: None,
        filter_width: None,
        memory_limit: None,
        debug_delay: Vec::new(),
        light_sampler: args.light_sampler,
        noise_threshold: None,
        min_samples: None,
        denoise: false,
        oidn: None,
        passes: None,
        cryptomatte_levels: None,
    };
    let reporter = Reporter::silent();
    let outcome = run_render(&render_args, &reporter, stop);
    let _ = std::fs::remove_dir_all(&dir);
    let s = outcome?.summary;
    let photon_figures = if matches!(args.integrator, IntegratorKind::Path | IntegratorKind::Bdpt | IntegratorKind::Vcm)
    {
        serde_json::Value::Null
    } else {
        bench_photon_maps(args, stop)?
    };
    let st = &s["stats"];
    let f = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let figures = json!({
        "scene": args.scene.display().to_string(),
        "resolution": format!("{}x{}", args.resolution.0, args.resolution.1),
        "spp": args.spp,
        "threads": st["threads"],
        "wall_seconds": f(&s["elapsed"]),
        "render_seconds": f(&st["render_seconds"]),
        "bvh_build_seconds": f(&st["bvh_build_seconds"]),
        "samples_per_sec": f(&st["samples_per_sec"]),
        "rays_per_sec": f(&st["rays_per_sec"]),
        "camera_rays_per_sec": f(&st["camera_rays_per_sec"]),
        "bounce_rays_per_sec": f(&st["bounce_rays_per_sec"]),
        "shadow_rays_per_sec": f(&st["shadow_rays_per_sec"]),
        "rays": st["rays"],
        "integrator": s["integrator"],
        "photons": photon_figures,
    });
    if args.json {
        outln!("{}", serde_json::to_string_pretty(&figures).unwrap_or_default());
        return Ok(());
    }
    outln!("scene             {}", figures["scene"].as_str().unwrap_or(""));
    outln!(
        "image             {} at {} spp, {} threads",
        figures["resolution"].as_str().unwrap_or(""),
        args.spp,
        st["threads"]
    );
    outln!("wall time         {:.3} s (render {:.3} s)", f(&figures["wall_seconds"]), f(&figures["render_seconds"]));
    outln!("BVH build         {:.4} s", f(&figures["bvh_build_seconds"]));
    outln!("samples/s         {:.3} M", f(&figures["samples_per_sec"]) / 1e6);
    outln!("rays/s            {:.3} M", f(&figures["rays_per_sec"]) / 1e6);
    outln!("  camera rays/s   {:.3} M", f(&figures["camera_rays_per_sec"]) / 1e6);
    outln!("  bounce rays/s   {:.3} M", f(&figures["bounce_rays_per_sec"]) / 1e6);
    outln!("  shadow rays/s   {:.3} M", f(&figures["shadow_rays_per_sec"]) / 1e6);
    let p = &figures["photons"];
    if !p.is_null() {
        outln!("integrator        {}", s["integrator"].as_str().unwrap_or(""));
        outln!(
            "photons traced/s  {:.3} M ({} emitted, {} rays)",
            f(&p["photons_traced_per_sec"]) / 1e6,
            p["global_emitted"].as_u64().unwrap_or(0) + p["caustic_emitted"].as_u64().unwrap_or(0),
            p["photon_rays"]
        );
        outln!(
            "photons stored/s  {:.3} M ({} global, {} caustic)",
            f(&p["photons_stored_per_sec"]) / 1e6,
            p["global_stored"],
            p["caustic_stored"]
        );
        outln!("kd-tree build     {:.4} s", f(&p["kdtree_build_seconds"]));
        outln!(
            "k-NN queries/s    {:.3} M (k = {}, {} queries)",
            f(&p["knn_queries_per_sec"]) / 1e6,
            p["k"],
            p["knn_queries"]
        );
        outln!("bytes per photon  {}", p["bytes_per_photon"]);
    }
    Ok(())
}

/// Photon-map figures for `bench`: traces the maps of the bench scene (same settings
/// as the render), then times k-NN radiance-estimate queries at stored photon
/// positions (single thread, so the figure is per core).
fn bench_photon_maps(args: &BenchArgs, stop: &AtomicBool) -> Result<serde_json::Value> {
    let scene = scene::gltf::load(&args.scene)?;
    let p = resolve_photon(&args.photon, &scene.settings)?;
    let max_depth = scene.settings.max_depth.unwrap_or(PathIntegrator::default().max_depth);
    let tris: Vec<[glam::Vec3; 3]> =
        scene.mesh.triangles.iter().map(|t| t.map(|i| scene.mesh.positions[i as usize])).collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .map_err(|e| Error::Internal(format!("cannot start worker threads: {e}")))?;
    let accel = pool.install(|| {
        build_bsdf_tables(&scene);
        Accel::build(&tris)
    });
    let ctx = SceneContext::new(&scene, &accel);
    let reporter = Reporter::silent();
    let (maps, ms) = pool.install(|| trace_maps(&ctx, &p, 0, max_depth, 0, &reporter, stop));
    let mut v = map_stats_json(&maps, &ms);
    let (_, scene_r) = scene.bounding_sphere();
    let r = p.max_radius.unwrap_or_else(|| default_max_radius(scene_r));
    let ph = maps.global.photons();
    let queries = if ph.is_empty() { 0 } else { 200_000usize };
    let t = Instant::now();
    let mut sink = glam::Vec3::ZERO;
    for i in 0..queries {
        let q = &ph[(crate::math::hash_u32(i as u32) as usize) % ph.len()];
        let (e, _) =
            photon::estimate::estimate(&maps.global, q.pos(), q.normal(), p.k, r * r, |_| true, |_| glam::Vec3::ONE);
        sink += e;
    }
    let secs = t.elapsed().as_secs_f64();
    v["knn_queries"] = json!(queries);
    v["k"] = json!(p.k);
    v["knn_queries_per_sec"] = json!(queries as f64 / secs.max(1e-9));
    v["knn_checksum"] = json!(sink.x);
    Ok(v)
}
