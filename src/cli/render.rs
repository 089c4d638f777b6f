//! `caustic render`: load, build, trace photon maps where the integrator needs them,
//! render, write; and the memory budget charged before each allocation.

use super::args::*;
use super::settings::{Resolved, resolve};
use crate::accel::Accel;
use crate::chunk::{self, ChunkInfo};
use crate::error::{Error, Result};
use crate::integrator::bdpt::BdptIntegrator;
use crate::integrator::path::PathIntegrator;
use crate::integrator::photon;
use crate::integrator::photon::PhotonSettings;
use crate::integrator::photon::io::PhotonMaps;
use crate::integrator::photon::jensen::JensenIntegrator;
use crate::integrator::photon::sppm::SppmIntegrator;
use crate::integrator::{Integrator, SceneContext};
use crate::memory::{self, MemoryBudget, human};
use crate::output;
use crate::progress::Reporter;
use crate::render::{self, RenderJob};
use crate::scene::camera::CameraRays;
use crate::scene::{self, Scene};
use serde_json::json;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Builds the BSDF's albedo tables the scene's materials use, in parallel on the
/// caller's pool, rather than by the first shading point inside the timed rendering phase
/// (and, inside a render worker, on one thread).
pub(crate) fn build_bsdf_tables(scene: &Scene) {
    crate::bsdf::albedo::specular_albedo();
    crate::bsdf::fresnel_layer::layer_albedo();
    let m = &scene.materials;
    if m.iter().any(may_show_rough_glass) {
        crate::bsdf::glass_albedo::glass_albedo();
    }
    if m.iter().any(|m| m.sheen_color != crate::math::Rgb::ZERO || m.sheen_color_tex.is_some()) {
        crate::bsdf::sheen::sheen_albedo_table();
    }
}

/// Whether a material may show rough glass, the only user of the glass albedo table
/// (multiscatter compensation; a smooth interface, roughness below
/// `SMOOTH_ROUGHNESS`, never reads it). Building that table costs ~0.25 s on two cores,
/// a third of a small render's wall time on the benchmark's glass scene, whose sphere is
/// smooth. Only a hint: a material that needs the table after all builds it at first use.
fn may_show_rough_glass(m: &crate::scene::material::Material) -> bool {
    use crate::shader::closure::ClosureKind;
    use crate::shader::instructions::Op;
    let pbr_glass = (m.transmission > 0.0 || m.transmission_tex.is_some())
        && (m.roughness >= crate::bsdf::dielectric::SMOOTH_ROUGHNESS || m.metallic_roughness_tex.is_some());
    // A node graph's Glass and Principled closures read their roughness per shading point; a
    // Principled BSDF whose Transmission Weight is a constant 0 never refracts (the table
    // costs 1.68 G instructions, 2.7 times the render of bench/node_graph.py).
    let graph_glass = m.nodes.as_ref().is_some_and(|p| {
        p.ops.iter().any(|op| {
            matches!(op, Op::Closure(c) if match c.kind {
                // Only Multiscatter GGX glass reads the table.
                ClosureKind::Glass { multiscatter, beckmann } => multiscatter && !beckmann,
                ClosureKind::Principled(_) => p.transmits,
                _ => false,
            })
        })
    });
    pbr_glass || graph_glass
}

/// Outcome of a finished render command.
pub struct Outcome {
    /// Stopped by a signal (the partial image was written).
    pub interrupted: bool,
    /// The summary object that was reported.
    pub summary: serde_json::Value,
}

/// `caustic render`.
pub fn run_render(args: &RenderArgs, reporter: &Reporter, stop: &AtomicBool) -> Result<Outcome> {
    let t0 = Instant::now();
    reporter.phase("loading", 0.0);
    output::clean_stale_temps(&args.output);
    output::check_writable(&args.output)?;
    let budget = MemoryBudget::from_flag(args.memory_limit.as_deref())?;
    let mut scene = scene::gltf::load_within(&args.scene, &budget)?;
    for w in &scene.warnings {
        reporter.warning(w);
    }
    let res = resolve(args, &scene)?;
    scene.set_view(res.camera, res.resolution.0, res.resolution.1);
    let mut run_warnings = Vec::new();
    // Cast Shadow off is rendered by every integrator: next-event estimation skips the
    // shadow ray; BDPT/VCM take such a light by light sampling alone and photons pass every
    // surface on its first segment (`integrator::linking`).
    // Ray Visibility of objects, lights and the world is rendered by every integrator: the
    // path tracer's rays carry their kind, photons the kinds that may read them
    // (`integrator::photon::visibility`), BDPT and VCM leave the paths that meet a hidden
    // kind to their camera side (`integrator::bdpt::visibility`).
    let world_reads_path = scene.world.as_ref().and_then(|w| w.graph.as_ref()).is_some_and(|g| g.reads_light_path());
    if world_reads_path && res.integrator != IntegratorKind::Path {
        // Camera rays read their own state in every integrator; light subpaths and photons
        // leave the world before any camera ray exists, so they read light sampling's.
        let w = "the world's Light Path node: with this integrator, rays that bounced read it as light sampling \
                 does (Is Camera Ray 0, Ray Depth 1), where Cycles' bounced rays read their own state (camera \
                 rays read theirs; the path tracer reads every ray's)"
            .to_string();
        reporter.warning(&w);
        run_warnings.push(w);
    }
    // Media and subsurface scattering: the parts BDPT and VCM continue with the path tracer.
    let path_traced_parts = scene.world_medium.is_some()
        || scene.world_grid.is_some()
        || scene.materials.iter().any(|m| m.medium.is_some() || m.subsurface.is_some());
    // Fast GI is the path tracer's (Cycles has no other integrator to approximate).
    if res.fast_gi.is_some() && res.integrator != IntegratorKind::Path {
        let w = format!(
            "Light Paths > Fast GI Approximation is rendered by the path tracer only: {} traces full global illumination",
            res.integrator.name()
        );
        reporter.warning(&w);
        run_warnings.push(w);
    }
    for w in foreign_flag_warnings(&args.photon, args.spp, res.integrator) {
        reporter.warning(&w);
        run_warnings.push(w);
    }
    for w in light_paths_warnings(&res, path_traced_parts) {
        reporter.warning(&w);
        run_warnings.push(w);
    }
    // BDPT's and VCM's connections and light sampling shadow from the flat triangle.
    if matches!(res.integrator, IntegratorKind::Bdpt | IntegratorKind::Vcm)
        && !scene.ray_visibility.terminator.is_empty()
    {
        let w = format!(
            "Object > Shading > Shadow Terminator > Geometry Offset: {} shadows smooth-shaded triangles from the flat \
             triangle (coarse smooth meshes darker at their terminator than in Cycles); the path tracer and the photon \
             integrators follow it",
            res.integrator.name()
        );
        reporter.warning(&w);
        run_warnings.push(w);
    }
    // The Shading Offset remaps the cosine of light sampled and traced from the camera side
    // (`scene::terminator::shift_cos_in`); BDPT's and VCM's other strategies and the photon
    // maps' estimates do not carry it.
    if !scene.ray_visibility.shading_frequency.is_empty() && res.integrator != IntegratorKind::Path {
        let w = format!(
            "Object > Shading > Shadow Terminator > Shading Offset: {} applies it to {}; the path tracer renders \
             it as Cycles does",
            res.integrator.name(),
            match res.integrator {
                IntegratorKind::Bdpt | IntegratorKind::Vcm => "no strategy",
                _ => "light sampling and traced bounces only, not to the photon estimates",
            }
        );
        reporter.warning(&w);
        run_warnings.push(w);
    }
    // Photons leave emitters whose graph reads the Light Path node without a camera path
    // (`light::path_emitters`); BDPT and VCM take those emitters from the camera side.
    let photon_name = match res.integrator {
        IntegratorKind::Photon => Some("photon mapping"),
        IntegratorKind::Sppm => Some("SPPM"),
        _ => None,
    };
    if let Some(w) = photon_name.and_then(|name| crate::light::path_emitters::photon_warning(&scene, name)) {
        reporter.warning(&w);
        run_warnings.push(w);
    }
    // Photons start in emitting media too (`light::media_emit`), but in the world's fog only
    // within the box that holds the scene, and a homogeneous fog's light from beyond it
    // enters through the box's faces before it scatters: exact where the fog does not
    // scatter, short of the light it scatters beyond the box where it does; a textured
    // fog's light from beyond reaches surfaces only straight (camera-side rays).
    let beyond = match (&scene.world_medium, scene.world_grid) {
        (Some(m), _) if m.emission != crate::math::Rgb::ZERO && m.scatters() => {
            Some("the light the fog beyond that box scatters before it enters is missing")
        }
        (_, Some(g)) if scene.grids[g as usize].may_emit() => Some(
            "the fog's light from beyond that box reaches surfaces straight but not after a scattering or a bounce",
        ),
        _ => None,
    };
    if let Some((name, beyond)) = photon_name.zip(beyond) {
        let w = format!(
            "the World Volume emits: {name}'s photons start in it within the box of the scene's surfaces, cameras \
             and lights grown by half on each side, so {beyond} (nothing is missing where surfaces close the scene \
             in); the path tracer, BDPT and VCM render it all"
        );
        reporter.warning(&w);
        run_warnings.push(w);
    }
    // Nor do they know it where they scatter on a material whose BSDF reads the node.
    let light_side = match res.integrator {
        IntegratorKind::Bdpt => Some(("BDPT", crate::light::path_emitters::LightSide::Subpaths)),
        IntegratorKind::Vcm => Some(("VCM", crate::light::path_emitters::LightSide::Subpaths)),
        _ => photon_name.map(|n| (n, crate::light::path_emitters::LightSide::Photons)),
    };
    if let Some(w) =
        light_side.and_then(|(name, side)| crate::light::path_emitters::scattering_warning(&scene, name, side))
    {
        reporter.warning(&w);
        run_warnings.push(w);
    }
    // Lights' Max Bounces: photons do not know the camera bounces they will be read at.
    if let Some(w) = photon_name.and_then(|name| crate::scene::light_bounces::photon_warning(&scene, name)) {
        reporter.warning(&w);
        run_warnings.push(w);
    }
    // Light traced from the lights crosses glass points by another path than Cycles' camera rays.
    let light_tracing = match res.integrator {
        IntegratorKind::Bdpt => Some("BDPT"),
        IntegratorKind::Vcm => Some("VCM"),
        _ => photon_name,
    };
    if let Some(w) = light_tracing.and_then(|name| crate::points::transmission_warning(&scene, name)) {
        reporter.warning(&w);
        run_warnings.push(w);
    }
    // They emit from sphere lights outward only; Cycles lights the surfaces inside them too.
    if let Some(w) = light_tracing.and_then(|name| crate::light::inside::warning(&scene, name)) {
        reporter.warning(&w);
        run_warnings.push(w);
    }
    // Every integrator splits camera paths at shadow catchers (`integrator::catcher`).
    if res.passes.asks_shader_aovs() && scene.shader_aovs.channels == 0 {
        let w = "the shader AOVs were asked for, but the scene declares none: none is written".to_string();
        reporter.warning(&w);
        run_warnings.push(w);
    }
    if !scene.shader_aovs.world.is_empty()
        && res.transparent
        && !res.passes.contains(crate::passes::Pass::Environment)
        && res.passes.shader_aov_channels() > 0
    {
        // Cycles shades no background for a transparent film's camera rays unless the
        // Environment pass is on (`integrate_background`): the world's AOVs stay empty.
        scene.shader_aovs.world.clear();
        scene.shader_aovs.world_graph = None;
        let w = "the world's AOV Output nodes write nothing with Film → Transparent unless the Environment pass is on \
                 (as in Cycles)"
            .to_string();
        reporter.warning(&w);
        run_warnings.push(w);
    }
    if res.passes.asks_light_groups() && scene.light_groups.is_empty() {
        let w = "the light group passes were asked for, but the scene declares no light groups: none is written"
            .to_string();
        reporter.warning(&w);
        run_warnings.push(w);
    }
    if res.adaptive.is_some() && res.integrator == IntegratorKind::Vcm {
        let w = "adaptive sampling (noise threshold) is ignored by VCM: every iteration merges every pixel \
                 with one shared set of light subpaths, so every pixel takes every iteration"
            .to_string();
        reporter.warning(&w);
        run_warnings.push(w);
    }
    if res.adaptive.is_some() && res.integrator == IntegratorKind::Sppm {
        // Ignored rather than refused, so that a scene saved with adaptive sampling on still
        // renders with SPPM: the warning names what was not applied.
        let w = "adaptive sampling (noise threshold) is ignored by SPPM: its iterations shrink every pixel's \
                 photon radius together, so no pixel can stop on its own; every pixel takes every iteration"
            .to_string();
        reporter.warning(&w);
        run_warnings.push(w);
    }
    if let Some(m) = scene.motion.as_ref().filter(|m| m.blurs()) {
        if res.passes.contains(crate::passes::Pass::Vector) {
            // Blender offers the Vector pass only without motion blur (its steps are then
            // the neighbouring frames, not the shutter's).
            return Err(Error::Usage(
                "the Vector pass needs motion blur off (as in Blender): the scene's CAUSTIC_motion has a shutter"
                    .into(),
            ));
        }
        let w = match res.integrator {
            // Photons fly at times over the shutter (`photon::trace`): exact where only the
            // camera moves, since the light on still surfaces does not depend on the time.
            IntegratorKind::Sppm | IntegratorKind::Photon if !m.objects.is_empty() => Some(format!(
                "motion blur with photon mapping: the photons fly at times spread over the shutter, so the \
                 surfaces of {} gather the photons that reached the places they pass at any time of the \
                 exposure (still surfaces, and the shadows and caustics cast on them, blur exactly)",
                m.objects.iter().map(|o| format!("'{o}'")).collect::<Vec<_>>().join(", ")
            )),
            IntegratorKind::Vcm => Some(
                "motion blur with VCM: merging joins light and camera subpaths traced at different shutter \
                 times (each pixel's at its own)"
                    .to_string(),
            ),
            _ => None,
        };
        if let Some(w) = w {
            reporter.warning(&w);
            run_warnings.push(w);
        }
        // BDPT and VCM test which paths meet a restricted object on its triangles at the
        // frame (`integrator::bdpt::visibility`).
        let moving = crate::integrator::bdpt::visibility::moving_restricted(&scene, m);
        let bidirectional = matches!(res.integrator, IntegratorKind::Bdpt | IntegratorKind::Vcm);
        if bidirectional && !moving.is_empty() {
            let w = format!(
                "motion blur with BDPT/VCM: the ray visibility of moving object(s) {} is judged where they are at \
                 the frame, so paths that pass near them as they move may be weighed for the wrong strategies",
                moving.iter().map(|o| format!("'{o}'")).collect::<Vec<_>>().join(", ")
            );
            reporter.warning(&w);
            run_warnings.push(w);
        }
        // The same test finds the triangles of materials whose BSDF reads the Light Path node.
        let moving = crate::integrator::bdpt::visibility::moving_switched(&scene, m);
        if bidirectional && !moving.is_empty() {
            let w = format!(
                "motion blur with BDPT/VCM: the moving triangles of material(s) {}, whose BSDF or transparency reads \
                 the Light Path node, are judged where they are at the frame, so paths that pass near them as they \
                 move may be weighed for the wrong strategies",
                moving.iter().map(|o| format!("'{o}'")).collect::<Vec<_>>().join(", ")
            );
            reporter.warning(&w);
            run_warnings.push(w);
        }
    }
    charge_render(&budget, args, &res, &scene)?;
    // Loaded before rendering, so that a missing library costs no render time.
    let denoiser = match args.denoise {
        false => None,
        true if args.chunk => {
            return Err(Error::Usage(
                "--denoise cannot write a chunk (--chunk): chunks carry sums to merge; denoise the merged frame".into(),
            ));
        }
        true => {
            let pixels = ((res.window[2] - res.window[0]) as u64) * ((res.window[3] - res.window[1]) as u64);
            budget.charge(
                format!("the denoiser's images for {pixels} pixels"),
                pixels.saturating_mul(crate::denoise::BYTES_PER_PIXEL),
            )?;
            Some(crate::denoise::Denoiser::open(args.oidn.as_deref())?)
        }
    };
    // The film sums the first hit's normal and albedo only for a pass or the denoiser.
    let guides = crate::film::needs_guides(res.passes) || denoiser.is_some();
    if stop.load(Ordering::Relaxed) {
        return Err(Error::InterruptedEmpty);
    }

    reporter.phase("bvh", t0.elapsed().as_secs_f64());
    let tris: Vec<[glam::Vec3; 3]> =
        scene.mesh.triangles.iter().map(|t| t.map(|i| scene.mesh.positions[i as usize])).collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(res.threads)
        .build()
        .map_err(|e| Error::Internal(format!("cannot start worker threads: {e}")))?;
    // With motion blur the moving triangles get their own BVH (`motion::accel`).
    let (accel, motion_accel) = pool.install(|| {
        build_bsdf_tables(&scene);
        match scene.motion.as_ref().filter(|m| m.blurs()) {
            Some(m) => {
                let (fixed, ids) = m.static_triangles(&tris);
                (Accel::build_with_ids(&fixed, &ids), crate::motion::accel::MotionAccel::build(m))
            }
            None => (Accel::build(&tris), None),
        }
    });
    drop(tris);
    if stop.load(Ordering::Relaxed) {
        return Err(Error::InterruptedEmpty);
    }
    // Only the path tracer follows the per-kind limits, clamps and Filter Glossy (the others
    // are warned above).
    let light_paths = res.followed_light_paths();
    let ctx = SceneContext::with_light_sampler(&scene, &accel, res.light_sampler)
        .with_light_paths(light_paths, res.transparent_max)
        .with_motion(motion_accel.as_ref())
        .with_camera_at(scene.cameras[res.camera].position);
    // Every integrator honours Ray Visibility (above) and light and shadow linking
    // (`integrator::linking`).
    let ctx = ctx.with_ray_visibility().with_light_linking();
    // Fast GI's Replace with a uniform world: the world is found by rays alone, as Cycles.
    let unsampled_world = res.integrator == IntegratorKind::Path
        && crate::integrator::fast_gi::cycles_skips_world_sampling(res.fast_gi, &scene);
    let ctx = if unsampled_world { ctx.without_world_sampling() } else { ctx };
    // The shadow catcher's pass sees the scene apart (settings keep its sums for the
    // integrators that split, `settings::splits_at_catchers`).
    let ctx = if res.passes.catcher_sums() {
        let pass = SceneContext::with_light_sampler(&scene, &accel, res.light_sampler)
            .with_light_paths(light_paths, res.transparent_max)
            .with_camera_at(scene.cameras[res.camera].position)
            .with_light_linking();
        let pass = if unsampled_world { pass.without_world_sampling() } else { pass };
        ctx.with_shadow_catcher(crate::integrator::catcher::pass_context(pass, true))
    } else {
        ctx
    };
    let camera = CameraRays::new(&scene.cameras[res.camera], res.resolution.0, res.resolution.1)
        .with_footprints(scene.reads_footprint());
    let mut photon_stats = serde_json::Value::Null;
    // What BDPT and VCM file their contributions into besides Combined.
    let ledger = crate::integrator::bdpt::Ledger {
        light_passes: res.passes.any_light(),
        light_groups: res.passes.light_groups() > 0,
    };
    let integrator = match res.integrator {
        IntegratorKind::Path => Integrator::Path(PathIntegrator {
            light_passes: res.passes.any_light(),
            light_groups: res.passes.light_groups() > 0,
            glass_threshold: res.transparent_glass,
            fast_gi: res.fast_gi,
            guides,
            ..PathIntegrator::new(res.max_depth, res.transparent)
        }),
        IntegratorKind::Sppm => {
            // A chunk keeps SPPM's sums of Combined and of every pass (`sppm_passes::into_film`).
            Integrator::Sppm(SppmIntegrator {
                keep_sums: args.chunk,
                glass_threshold: res.transparent_glass,
                ..SppmIntegrator::new(res.max_depth, res.photon.clone(), res.transparent)
            })
        }
        IntegratorKind::Bdpt => Integrator::Bdpt(BdptIntegrator {
            ledger,
            ..BdptIntegrator::new(&scene, res.max_depth, res.transparent, args.bdpt_strategy)
                .with_transparent_glass(&scene, res.transparent_glass)
                .with_bounce_limits(res.bounce_limits())
        }),
        IntegratorKind::Vcm => {
            let mut vcm = crate::integrator::vcm::VcmIntegrator::new(
                &scene,
                res.max_depth,
                res.transparent,
                args.vcm_mode.map_or(crate::integrator::vcm::VcmMode::Full, Into::into),
                args.vcm_radius,
            );
            vcm.bdpt = BdptIntegrator {
                ledger,
                ..vcm.bdpt.with_transparent_glass(&scene, res.transparent_glass).with_bounce_limits(res.bounce_limits())
            };
            Integrator::Vcm(vcm)
        }
        IntegratorKind::Photon => {
            reporter.phase("photons", t0.elapsed().as_secs_f64());
            let maps = match &args.photon_map {
                Some(path) => {
                    if res.passes.light_groups() > 0 {
                        // The file keeps no photon's light: its map reads could not be split.
                        return Err(Error::Usage(format!(
                            "the light group passes need photon maps traced in the render: the photon map file '{}' \
                             does not record each photon's light group (render without --photon-map)",
                            path.display()
                        )));
                    }
                    let maps = PhotonMaps::load(path, scene.source_hash)?;
                    if maps.max_depth < res.max_depth {
                        return Err(Error::Usage(format!(
                            "the photon map '{}' serves paths of at most {} scattering events; render with --max-depth {} or less, or make the map with --max-depth {}",
                            path.display(),
                            maps.max_depth,
                            maps.max_depth,
                            res.max_depth
                        )));
                    }
                    photon_stats = json!({
                        "loaded": path.display().to_string(),
                        "global_stored": maps.global.len(),
                        "caustic_stored": maps.caustic.len(),
                    });
                    maps
                }
                None => {
                    let hash = scene.source_hash;
                    // A chunk may trace its own, independent map (`--photon-seed`); by default
                    // every chunk of a frame traces the frame's map from the seed.
                    let map_seed = args.photon_seed.unwrap_or(res.job_seed);
                    let (maps, st) =
                        pool.install(|| trace_maps(&ctx, &res.photon, map_seed, res.max_depth, hash, reporter, stop));
                    photon_stats = map_stats_json(&maps, &st);
                    maps
                }
            };
            if stop.load(Ordering::Relaxed) {
                return Err(Error::InterruptedEmpty);
            }
            let (_, scene_r) = scene.bounding_sphere();
            Integrator::Photon(JensenIntegrator {
                light_passes: res.passes.any_light(),
                light_groups: res.passes.light_groups() > 0,
                glass_threshold: res.transparent_glass,
                ..JensenIntegrator::new(maps, &res.photon, scene_r, res.max_depth, res.transparent)
            })
        }
    };
    let job = RenderJob {
        width: res.resolution.0,
        height: res.resolution.1,
        window: res.window,
        spp: res.spp,
        time_limit: res.time_limit,
        seed: res.job_seed,
        sample_offset: res.sample_offset,
        filter: res.filter.clone(),
        adaptive: res.adaptive,
        passes: res.passes,
        data: res.data,
        guides,
    };
    // What every chunk of this frame must agree on (`--chunk`); the ranges are filled in per write.
    let chunk_info = match args.chunk {
        true => Some(chunk_info(args, &res, &scene)),
        false => None,
    };
    let write = |img: &crate::film::FilmImage, film: Option<&crate::film::Film>, spp: u32, light_paths: u64| {
        match &chunk_info {
            None => match &args.view {
                Some(view) => output::write_exr_in_view(&args.output, img, args.half, view),
                None => output::write_exr(&args.output, img, args.half),
            },
            Some(info) => {
                let info = ChunkInfo {
                    samples: vec![[res.sample_offset, res.sample_offset + spp]],
                    light_paths,
                    crypto_folded: film.map_or(0, |f| f.crypto_folded()),
                    ..info.clone()
                };
                match film {
                    Some(f) => output::write_chunk(&args.output, img, args.half, f, &info),
                    None => output::write_chunk(&args.output, img, args.half, &chunk::film_from_image(img), &info),
                }
            }
        }
    };

    // The Cryptomatte manifests go into every image's header (interim ones too).
    let crypto_header: Vec<(String, String)> =
        res.passes.cryptomatte()?.iter().flat_map(|k| crate::cryptomatte::header(k, scene.pass_ids.names(k))).collect();
    // The light groups' pass names, by the film's group order.
    let group_names: Vec<String> = scene.light_groups.names[..res.passes.light_groups()].to_vec();
    // The shader AOVs' passes, when asked.
    let aov_specs = match res.passes.shader_aov_channels() {
        0 => Vec::new(),
        _ => scene.shader_aovs.specs.clone(),
    };
    reporter.phase("rendering", t0.elapsed().as_secs_f64());
    let out_str = args.output.display().to_string();
    let mut last_interim = Instant::now();
    let interim = args.interim.map(Duration::from_secs_f64);
    let mut interim_error = None;
    let on_progress = |p: &render::Progress| {
        reporter.progress(p.fraction, p.samples_done, p.samples_total, p.elapsed, p.eta, p.rays_per_sec)
    };
    let result = pool.install(|| {
        render::render(&ctx, &camera, &integrator, &job, stop, &on_progress, &mut |film, spp| {
            if let Some(every) = interim
                && last_interim.elapsed() >= every
                && Some(spp) != job.spp
            {
                let mut img = film.image();
                img.metadata.clone_from(&crypto_header);
                img.light_group_names.clone_from(&group_names);
                img.aov_specs.clone_from(&aov_specs);
                crate::shadow_catcher::resolve(&mut img, res.transparent);
                match write(&img, Some(film), spp, film.light_paths) {
                    Ok(()) => reporter.image(&out_str, spp, false),
                    Err(e) => interim_error = Some(e),
                }
                last_interim = Instant::now();
            }
        })
    });
    if let Some(st) = &result.integrator_stats {
        photon_stats = st.clone();
    }
    if let Some(e) = interim_error {
        return Err(e);
    }
    if result.spp_max == 0 {
        return Err(Error::InterruptedEmpty);
    }
    let mut result = result;
    result.image.metadata = crypto_header;
    result.image.light_group_names = group_names;
    result.image.aov_specs = aov_specs;
    crate::shadow_catcher::resolve(&mut result.image, res.transparent);

    if let Some(d) = &denoiser {
        reporter.phase("denoising", t0.elapsed().as_secs_f64());
        pool.install(|| d.denoise(&mut result.image))?;
    }

    reporter.phase("writing", t0.elapsed().as_secs_f64());
    write(&result.image, result.film.as_ref(), result.spp_max, result.light_paths)?;
    reporter.image(&out_str, result.spp_min, true);

    let mut warnings = scene.warnings.clone();
    warnings.extend(run_warnings);
    if result.nan_samples > 0 {
        let w = format!("{} sample(s) were NaN, infinite or beyond ±2^31 and were dropped", result.nan_samples);
        reporter.warning(&w);
        warnings.push(w);
    }
    let black = result.image.combined.iter().all(|p| p[0] == 0.0 && p[1] == 0.0 && p[2] == 0.0);
    if black {
        let w = "the image is black: no light reached the camera".to_string();
        reporter.warning(&w);
        warnings.push(w);
    }
    let secs = result.elapsed.as_secs_f64().max(1e-9);
    let pixels = ((res.window[2] - res.window[0]) * (res.window[3] - res.window[1])) as f64;
    let total_samples: f64 = result.image.samples.iter().map(|&s| s as f64).sum();
    let summary = json!({
        "output": out_str,
        "width": res.window[2] - res.window[0],
        "height": res.window[3] - res.window[1],
        "spp": result.spp_min,
        "spp_max": result.spp_max,
        "elapsed": t0.elapsed().as_secs_f64(),
        "interrupted": result.interrupted,
        "nan_samples": result.nan_samples,
        "black": black,
        "warnings": warnings,
        "light_sampler": res.light_sampler.name(),
        "denoised": denoiser.as_ref().map(|d| d.source.display().to_string()),
        "integrator": integrator.describe(),
        "stats": {
            "load_profile": scene.report.profile,
            "bvh_build_seconds": accel.build_time.as_secs_f64(),
            "render_seconds": secs,
            "samples_per_sec": total_samples / secs,
            "pixels": pixels,
            "light_paths": result.light_paths,
            "splats": result.splats,
            "rays": result.rays,
            "rays_per_sec": result.rays.total() as f64 / secs,
            "camera_rays_per_sec": result.rays.camera as f64 / secs,
            "bounce_rays_per_sec": result.rays.bounce as f64 / secs,
            "shadow_rays_per_sec": result.rays.shadow as f64 / secs,
            "threads": res.threads,
            "adaptive": res.adaptive.filter(|_| result.adaptive_active.is_some()).map(|a| json!({
                "noise_threshold": a.noise_threshold,
                "min_samples": a.min_samples,
                "step": a.step,
                "active_pixels": result.adaptive_active,
            })),
            "photons": photon_stats,
        }
    });
    reporter.summary(summary.clone());
    Ok(Outcome { interrupted: result.interrupted, summary })
}

/// The chunk identity of this render: the scene's source hash (the glTF and every file it
/// read) and a hash of every setting that changes what a sample computes (not the sample
/// range, threads or output).
/// Warnings naming the Light Paths settings this render does not follow: for the integrators
/// other than the path tracer, the per-kind bounce limits that could end a path before Max
/// Bounces (BDPT and VCM follow them, `bdpt::bounces`, but for the paths they continue with
/// the path tracer, without them, in media and through subsurface scattering:
/// `path_traced_parts`), the clamps, Filter Glossy and a caustics switch off (BDPT and
/// VCM weigh whole paths made of a camera and a light subpath, photons do not know the camera
/// path they will be read at; Cycles has neither).
/// The photon-mapping flags given for an integrator that does not read them (the photon
/// integrator's map flags, SPPM's own; `--k` both read), and an `--spp` that SPPM's
/// `--sppm-iterations` overrides: named rather than ignored silently.
fn foreign_flag_warnings(
    p: &crate::cli::args::PhotonArgs,
    spp: Option<u32>,
    integrator: IntegratorKind,
) -> Vec<String> {
    use IntegratorKind::{Photon, Sppm};
    let mut out = Vec::new();
    if let (Sppm, Some(s), Some(i)) = (integrator, spp, p.sppm_iterations)
        && s != i
    {
        out.push(format!("--spp {s} is ignored: SPPM renders --sppm-iterations {i} (one sample per pixel each)"));
    }
    let given = [
        ("--photons", p.photons.is_some(), &[Photon][..]),
        ("--caustic-photons", p.caustic_photons.is_some(), &[Photon]),
        ("--k", p.k.is_some(), &[Photon, Sppm]),
        ("--caustic-k", p.caustic_k.is_some(), &[Photon]),
        ("--max-radius", p.max_radius.is_some(), &[Photon]),
        ("--gather-rays", p.gather_rays.is_some(), &[Photon]),
        ("--diffuse-bounces", p.diffuse_bounces.is_some(), &[Photon]),
        ("--sppm-iterations", p.sppm_iterations.is_some(), &[Sppm]),
        ("--sppm-photons", p.sppm_photons.is_some(), &[Sppm]),
        ("--sppm-radius", p.sppm_radius.is_some(), &[Sppm]),
    ];
    given
        .iter()
        .filter(|(_, set, readers)| *set && !readers.contains(&integrator))
        .map(|(flag, _, readers)| {
            let names: Vec<&str> = readers.iter().map(|k| k.name()).collect();
            format!("{flag} is read by {} only; the {} integrator ignores it", names.join(" and "), integrator.name())
        })
        .for_each(|w| out.push(w));
    out
}

fn light_paths_warnings(res: &Resolved, path_traced_parts: bool) -> Vec<String> {
    let mut out = Vec::new();
    if res.integrator != IntegratorKind::Path {
        let name = res.integrator.name();
        let limits = res.light_paths.limits_below(res.max_depth);
        let bidirectional = matches!(res.integrator, IntegratorKind::Bdpt | IntegratorKind::Vcm);
        if !limits.is_empty() && bidirectional && path_traced_parts {
            out.push(format!(
                "Light Paths > {}: {name} follows them except past a vertex in a medium or a subsurface walk, \
                 where it continues the path with the path tracer without them; the path tracer follows them",
                limits.join(", ")
            ));
        } else if !limits.is_empty() && !bidirectional {
            out.push(format!(
                "Light Paths > {}: {name} does not follow per-kind bounce limits (only Max Bounces); the path tracer does",
                limits.join(", ")
            ));
        }
        let clamps = res.light_paths.clamps_on();
        if !clamps.is_empty() {
            out.push(format!("Light Paths > {}: {name} does not follow it; the path tracer does", clamps.join(", ")));
        }
        let caustics = res.light_paths.caustics_off();
        if !caustics.is_empty() {
            out.push(format!(
                "Light Paths > {}: {name} renders caustics regardless; the path tracer follows it",
                caustics.join(", ")
            ));
        }
    }
    out
}

fn chunk_info(args: &RenderArgs, res: &Resolved, scene: &Scene) -> ChunkInfo {
    // SPPM's iteration count is its chunk's sample count, not an identity.
    let photon = PhotonSettings { sppm_iterations: 0, ..res.photon.clone() };
    let settings = format!(
        "{:?}|{:?}|{}|{:?}|{}|{:?}|{:?}|{}|{:?}|{:?}|{:?}",
        res.resolution,
        res.camera,
        res.max_depth,
        res.filter,
        res.transparent,
        res.integrator,
        photon,
        res.light_sampler.name(),
        args.bdpt_strategy,
        res.passes,
        res.data,
    );
    ChunkInfo {
        version: chunk::CHUNK_VERSION,
        scene_hash: scene.source_hash,
        settings_hash: crate::math::fnv1a64(settings.as_bytes()),
        integrator: res.integrator.name().to_string(),
        resolution: [res.resolution.0, res.resolution.1],
        window: res.window,
        seed: res.job_seed,
        transparent: res.transparent,
        samples: Vec::new(),
        light_paths: 0,
        passes: res.passes,
        light_groups: scene.light_groups.names[..res.passes.light_groups()].to_vec(),
        shader_aovs: match res.passes.shader_aov_channels() {
            0 => Vec::new(),
            _ => scene.shader_aovs.specs.clone(),
        },
        crypto_folded: 0,
    }
}

/// Traces the global and caustic maps, reporting the "photons" phase's progress at
/// most about twice a second.
pub(super) fn trace_maps(
    ctx: &SceneContext,
    p: &PhotonSettings,
    seed: u32,
    max_depth: u32,
    hash: u64,
    reporter: &Reporter,
    stop: &AtomicBool,
) -> (PhotonMaps, photon::io::MapStats) {
    let last = std::sync::atomic::AtomicU64::new(0);
    PhotonMaps::trace(ctx, p.photons, p.caustic_photons, seed, max_depth, hash, stop, &|done, total, elapsed| {
        let ms = (elapsed * 1000.0) as u64;
        let prev = last.load(Ordering::Relaxed);
        if (ms >= prev + 500 || done == total)
            && last.compare_exchange(prev, ms.max(prev + 1), Ordering::Relaxed, Ordering::Relaxed).is_ok()
        {
            reporter.photon_progress(
                done as f64 / total.max(1) as f64,
                done,
                total,
                elapsed,
                done as f64 / elapsed.max(1e-9),
            );
        }
    })
}

/// Figures of a map build, for the summary and `bench`.
pub(super) fn map_stats_json(maps: &PhotonMaps, st: &photon::io::MapStats) -> serde_json::Value {
    let emitted = st.global.emitted + st.caustic.emitted;
    let stored = st.global.stored + st.caustic.stored;
    json!({
        "global_emitted": st.global.emitted,
        "global_stored": st.global.stored,
        "caustic_emitted": st.caustic.emitted,
        "caustic_stored": st.caustic.stored,
        "photon_rays": st.global.rays + st.caustic.rays,
        "trace_seconds": st.trace_seconds,
        "photons_traced_per_sec": emitted as f64 / st.trace_seconds.max(1e-9),
        "photons_stored_per_sec": stored as f64 / st.trace_seconds.max(1e-9),
        "kdtree_build_seconds": st.build_seconds,
        "bytes_per_photon": std::mem::size_of::<photon::Photon>(),
        "map_bytes": maps.global.bytes() + maps.caustic.bytes(),
    })
}

// ---- Memory budget of the commands (issue 11): estimates charged before allocating. ----

/// Charges the BVH build of the scene's triangles.
pub(super) fn charge_bvh(budget: &MemoryBudget, scene: &Scene) -> Result<()> {
    let n = scene.mesh.triangles.len() as u64;
    budget.charge(format!("the BVH over {n} triangles"), n.saturating_mul(memory::BVH_BYTES_PER_TRIANGLE))
}

/// Charges the photon maps traced with settings `p` (global and caustic).
pub(super) fn charge_photon_maps(budget: &MemoryBudget, p: &PhotonSettings, max_depth: u32) -> Result<()> {
    let emitted = p.photons.saturating_add(p.caustic_photons);
    budget.charge(
        format!("photon maps for {} + {} photons", p.photons, p.caustic_photons),
        memory::photon_map_bytes(emitted, max_depth),
    )
}

/// Charges everything `run_render` allocates after loading: the BVH, the film and
/// output buffers of the rendered window, and the integrator's own state (photon maps,
/// SPPM's per-pixel state and per-iteration maps).
fn charge_render(budget: &MemoryBudget, args: &RenderArgs, res: &Resolved, scene: &Scene) -> Result<()> {
    charge_bvh(budget, scene)?;
    let [x0, y0, x1, y1] = res.window;
    let pixels = (x1 - x0) as u64 * (y1 - y0) as u64;
    budget.charge(
        format!("the film for {}x{} pixels", x1 - x0, y1 - y0),
        pixels.saturating_mul(memory::film_bytes_per_pixel()),
    )?;
    let slots = res.passes.slots().count_ones() as u64;
    if slots > 0 {
        // Each extra slot: an i128 sum, the image's f32 and the EXR writer's copy.
        budget.charge(
            format!("the {} extra pass channels for {}x{} pixels", slots, x1 - x0, y1 - y0),
            pixels.saturating_mul(slots * (16 + 4 + 4)),
        )?;
    }
    let groups = res.passes.light_groups() as u64;
    if groups > 0 {
        // Each group: three i128 sums in the tiles, the image's three f32 and the writer's copy.
        budget.charge(
            format!("the {groups} light group passes for {}x{} pixels", x1 - x0, y1 - y0),
            pixels.saturating_mul(groups * 3 * (16 + 4 + 4)),
        )?;
    }
    let aov_channels = res.passes.shader_aov_channels() as u64;
    if aov_channels > 0 {
        // Each channel: an i128 sum in the tiles, the image's f32 and the writer's copy.
        budget.charge(
            format!("the {aov_channels} shader AOV channels for {}x{} pixels", x1 - x0, y1 - y0),
            pixels.saturating_mul(aov_channels * (16 + 4 + 4)),
        )?;
    }
    let crypto = res.passes.cryptomatte()?;
    if !crypto.is_empty() {
        // Each slot: 8 bytes in the tiles, the image's two f32 and the EXR writer's copy.
        budget.charge(
            format!("the Cryptomatte slots for {}x{} pixels", x1 - x0, y1 - y0),
            pixels.saturating_mul(crypto.stride() as u64 * (8 + 8 + 8)),
        )?;
    }
    if args.chunk {
        // The chunk channels, built beside the image: 54 words of 4 bytes per pixel, and four
        // words for each extra sum (the kept slots, three per light group, the AOV channels).
        let words = 54 + 4 * (slots + 3 * groups + aov_channels);
        budget
            .charge(format!("the chunk sums for {}x{} pixels", x1 - x0, y1 - y0), pixels.saturating_mul(words * 4))?;
    }
    // A splat's Combined, then its light passes and light groups (bidirectional integrators).
    let splat_bytes = std::mem::size_of::<[i128; 3]>() as u64 * (1 + res.passes.splat_triples() as u64);
    match res.integrator {
        IntegratorKind::Photon => match &args.photon_map {
            // A map file holds 32 bytes per photon, as the loaded map does.
            Some(path) => {
                let len = std::fs::metadata(path).map_err(|e| Error::io(path, e))?.len();
                budget.charge(format!("the photon map file {} ({})", path.display(), human(len)), len)
            }
            None => charge_photon_maps(budget, &res.photon, res.max_depth),
        },
        IntegratorKind::Sppm => {
            budget.charge(
                format!("SPPM's per-pixel state for {pixels} pixels"),
                pixels.saturating_mul(photon::sppm::bytes_per_pixel(
                    res.passes.any_light() || res.passes.light_groups() > 0,
                    photon::sppm_catcher::wanted(res.passes),
                )),
            )?;
            let per_iter = res.photon.sppm_photons.unwrap_or_else(|| photon::default_sppm_photons(pixels));
            budget.charge(
                format!("SPPM's photon map of {per_iter} photons per iteration"),
                memory::photon_map_bytes(per_iter, res.max_depth),
            )
        }
        // Light-tracing splats: the film's sum plus one buffer per worker (fixed-point RGB
        // each, and one more per light pass and light group asked; the pool holds one per
        // concurrently running tile, at most one per thread).
        IntegratorKind::Bdpt => budget.charge(
            format!("bidirectional splat buffers ({} threads + 1) for {pixels} pixels", res.threads),
            pixels.saturating_mul(splat_bytes).saturating_mul(res.threads as u64 + 1),
        ),
        // VCM: BDPT's splat buffers, plus one iteration's merge records (a light subpath
        // stores about one per bounce from its second vertex on: 1.5 per pixel on the Cornell
        // box, 3.2 on door_ajar at 13 bounces; charged for four per pixel) in three copies
        // (the rows', gathered, in bucket order), their positions (12 bytes) and their grid
        // (about 16 bytes a record), and the light subpaths kept for the connections (the
        // records' vertices, the light point and delta vertices: charged for five per pixel).
        IntegratorKind::Vcm => budget.charge(
            format!(
                "VCM's splat buffers ({} threads + 1), merge records and light subpaths for {pixels} pixels",
                res.threads
            ),
            pixels.saturating_mul(
                splat_bytes * (res.threads as u64 + 1)
                    + 4 * (3 * std::mem::size_of::<crate::integrator::vcm::merge::MergeRecord>() as u64 + 12 + 16)
                    + 5 * crate::integrator::vcm::light_store::VERTEX_BYTES,
            ),
        ),
        // The path tracer keeps nothing per pixel beyond the film.
        IntegratorKind::Path => Ok(()),
    }
}
