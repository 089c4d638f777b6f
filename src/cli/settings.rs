//! Settings resolution: flag > scene setting > default, every default and every
//! range check in one place.

use super::args::*;
use crate::error::{Error, Result};
use crate::film::Filter;
use crate::integrator::path::PathIntegrator;
use crate::integrator::photon::{self, MAX_K, PhotonSettings};
use crate::light::LightSamplerKind;
use crate::render::adaptive::Adaptive;
use crate::scene::{self, Scene};
use clap::ValueEnum;
use std::time::Duration;

/// Settings after resolving flags, scene settings and defaults.
#[derive(Debug)]
pub struct Resolved {
    /// Full frame width and height.
    pub resolution: (u32, u32),
    /// Window rendered.
    pub window: [u32; 4],
    /// Samples per pixel (None = until the time limit).
    pub spp: Option<u32>,
    /// Time limit.
    pub time_limit: Option<Duration>,
    /// Camera index.
    pub camera: usize,
    /// Worker threads.
    pub threads: usize,
    /// The render job.
    pub job_seed: u32,
    /// Max depth.
    pub max_depth: u32,
    /// Cycles' per-kind bounce limits and clamps (flag > scene > none).
    pub light_paths: crate::integrator::light_paths::LightPaths,
    /// Cycles' Transparent Max Bounces (flag > scene > 8).
    pub transparent_max: u32,
    /// Filter.
    pub filter: Filter,
    /// Transparent background.
    pub transparent: bool,
    /// Transparent Glass's roughness threshold (with a transparent background only).
    pub transparent_glass: Option<f32>,
    /// Algorithm.
    pub integrator: IntegratorKind,
    /// Photon-mapping settings.
    pub photon: PhotonSettings,
    /// Light selection.
    pub light_sampler: LightSamplerKind,
    /// Index of the first sample (`--sample-offset`).
    pub sample_offset: u32,
    /// Adaptive sampling (None: off).
    pub adaptive: Option<Adaptive>,
    /// Passes to write besides Combined.
    pub passes: crate::passes::PassSet,
    /// Data-pass settings (mist, AO distance).
    pub data: crate::passes::DataSettings,
    /// Light Paths > Fast GI Approximation (the path tracer renders it).
    pub fast_gi: Option<crate::integrator::fast_gi::FastGi>,
}

impl Resolved {
    /// The Light Paths settings the render follows: the resolved ones for the path tracer,
    /// none for the other integrators (warned by name; their path-traced parts, media and the
    /// catcher pass, follow none either).
    pub fn followed_light_paths(&self) -> crate::integrator::light_paths::LightPaths {
        match self.integrator {
            IntegratorKind::Path => self.light_paths,
            _ => crate::integrator::light_paths::LightPaths::UNLIMITED,
        }
    }

    /// The per-kind bounce limits BDPT and VCM follow themselves (`bdpt::bounces`; none for
    /// the other integrators, whose context holds `followed_light_paths`).
    pub fn bounce_limits(&self) -> crate::integrator::light_paths::LightPaths {
        use crate::integrator::light_paths::LightPaths;
        match self.integrator {
            IntegratorKind::Bdpt | IntegratorKind::Vcm => LightPaths {
                diffuse: self.light_paths.diffuse,
                glossy: self.light_paths.glossy,
                transmission: self.light_paths.transmission,
                volume: self.light_paths.volume,
                ..LightPaths::UNLIMITED
            },
            _ => LightPaths::UNLIMITED,
        }
    }
}

/// Resolves the photon-mapping settings (flag > scene > default) and checks them.
pub fn resolve_photon(a: &PhotonArgs, st: &scene::SceneSettings) -> Result<PhotonSettings> {
    let d = PhotonSettings::default();
    let p = PhotonSettings {
        photons: a.photons.or(st.photons).unwrap_or(d.photons),
        caustic_photons: a.caustic_photons.or(st.caustic_photons).unwrap_or(d.caustic_photons),
        k: a.k.or(st.k).unwrap_or(d.k),
        caustic_k: a.caustic_k.or(st.caustic_k).unwrap_or(d.caustic_k),
        max_radius: a.max_radius.or(st.max_radius).or(d.max_radius),
        gather_rays: a.gather_rays.or(st.gather_rays).unwrap_or(d.gather_rays),
        diffuse_bounces: a.diffuse_bounces.or(st.diffuse_bounces).unwrap_or(d.diffuse_bounces),
        sppm_iterations: a.sppm_iterations.or(st.sppm_iterations).unwrap_or(d.sppm_iterations),
        sppm_photons: a.sppm_photons.or(st.sppm_photons).or(d.sppm_photons),
        sppm_radius: a.sppm_radius.or(st.sppm_radius).or(d.sppm_radius),
        sppm_alpha: d.sppm_alpha,
    };
    const MAX_PHOTONS: u64 = 1 << 32;
    if p.photons > MAX_PHOTONS || p.caustic_photons > MAX_PHOTONS {
        return Err(Error::Usage(format!("photon counts must be at most {MAX_PHOTONS}")));
    }
    if p.photons == 0 && p.caustic_photons == 0 {
        return Err(Error::Usage("--photons and --caustic-photons cannot both be 0".into()));
    }
    for (name, k) in [("--k", p.k), ("--caustic-k", p.caustic_k)] {
        if !(1..=MAX_K).contains(&k) {
            return Err(Error::Usage(format!("{name} {k} must be in 1..={MAX_K}")));
        }
    }
    for (name, v) in [("--max-radius", p.max_radius), ("--sppm-radius", p.sppm_radius)] {
        if let Some(r) = v
            && !(r > 0.0 && r.is_finite())
        {
            return Err(Error::Usage(format!("{name} {r} must be a positive radius")));
        }
    }
    if p.gather_rays == 0 || p.gather_rays > 65_536 {
        return Err(Error::Usage(format!("--gather-rays {} must be in 1..=65536", p.gather_rays)));
    }
    if p.diffuse_bounces > crate::integrator::photon::MAX_DIFFUSE_BOUNCES {
        return Err(Error::Usage(format!(
            "--diffuse-bounces {} must be in 0..={}",
            p.diffuse_bounces,
            crate::integrator::photon::MAX_DIFFUSE_BOUNCES
        )));
    }
    if p.sppm_iterations == 0 || p.sppm_iterations > MAX_SPP {
        return Err(Error::Usage(format!("--sppm-iterations {} must be in 1..={MAX_SPP}", p.sppm_iterations)));
    }
    if matches!(p.sppm_photons, Some(0)) || p.sppm_photons.is_some_and(|n| n > MAX_PHOTONS) {
        return Err(Error::Usage(format!("--sppm-photons must be in 1..={MAX_PHOTONS}")));
    }
    Ok(p)
}

/// Chooses the camera by flag or scene setting.
fn pick_camera(scene: &Scene, wanted: Option<&str>) -> Result<usize> {
    let Some(w) = wanted else { return Ok(0) };
    if let Some(i) = scene.cameras.iter().position(|c| c.name == w) {
        return Ok(i);
    }
    if let Some(i) = scene.cameras.iter().position(|c| c.data_name.as_deref() == Some(w)) {
        return Ok(i);
    }
    if let Ok(i) = w.parse::<usize>()
        && i < scene.cameras.len()
    {
        return Ok(i);
    }
    let names: Vec<String> = scene.cameras.iter().enumerate().map(|(i, c)| format!("{i}: '{}'", c.name)).collect();
    Err(Error::Usage(format!("unknown camera '{w}' (the scene has {})", names.join(", "))))
}

/// The frame size: the flag's, else the scene's, else the default width at the camera's aspect.
fn frame_size(scene: &Scene, camera: usize, flag: Option<(u32, u32)>) -> (u32, u32) {
    match flag.or(scene.settings.resolution.map(|r| (r[0], r[1]))) {
        Some(r) => r,
        None => match scene.cameras[camera].aspect() {
            Some(a) => (DEFAULT_WIDTH, ((DEFAULT_WIDTH as f32 / a).round() as u32).max(1)),
            None => (DEFAULT_WIDTH, DEFAULT_HEIGHT),
        },
    }
}

/// The camera and frame the scene's own settings render with (`caustic photons`, whose
/// maps are traced before any render: shader graphs reading Camera or Window see it).
pub fn scene_view(scene: &mut Scene) -> Result<()> {
    if scene.cameras.is_empty() {
        return Ok(());
    }
    let camera = pick_camera(scene, scene.settings.camera.as_deref())?;
    let (w, h) = frame_size(scene, camera, None);
    scene.set_view(camera, w.max(1), h.max(1));
    Ok(())
}

/// Resolves every setting; each default lives here.
pub fn resolve(args: &RenderArgs, scene: &Scene) -> Result<Resolved> {
    let st = &scene.settings;
    let camera = pick_camera(scene, args.camera.as_deref().or(st.camera.as_deref()))?;
    let resolution = frame_size(scene, camera, args.resolution);
    let (w, h) = resolution;
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE || (w as u64) * (h as u64) > MAX_PIXELS {
        return Err(Error::Usage(format!(
            "resolution {w}x{h} is out of range (each side 1..={MAX_SIDE}, at most {MAX_PIXELS} pixels)"
        )));
    }
    let window = match args.crop {
        None => [0, 0, w, h],
        Some([x0, y0, x1, y1]) => {
            if !(x0 < x1 && y0 < y1 && x1 <= w && y1 <= h) {
                return Err(Error::Usage(format!(
                    "crop {x0},{y0},{x1},{y1} is not a non-empty window inside the {w}x{h} frame"
                )));
            }
            [x0, y0, x1, y1]
        }
    };
    let time_limit = match args.time_limit.or(st.time_limit) {
        None => None,
        Some(t) if t > 0.0 && t.is_finite() && t < 1e7 => Some(Duration::from_secs_f64(t)),
        Some(t) => {
            return Err(Error::Usage(format!("time limit {t} s must be a positive number of seconds")));
        }
    };
    let spp = match args.spp.or(st.spp) {
        Some(0) => return Err(Error::Usage("--spp must be at least 1".into())),
        Some(s) if s > MAX_SPP => {
            return Err(Error::Usage(format!("--spp {s} is absurd (at most {MAX_SPP})")));
        }
        Some(s) => Some(s),
        None if time_limit.is_some() => None,
        None => Some(DEFAULT_SPP),
    };
    let max_depth = args.max_depth.or(st.max_depth).unwrap_or(PathIntegrator::default().max_depth);
    if max_depth > MAX_DEPTH {
        return Err(Error::Usage(format!("--max-depth {max_depth} is absurd (at most {MAX_DEPTH})")));
    }
    let (light_paths, transparent_max) = resolve_light_paths(args, st)?;
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    let threads = match args.threads.or(st.threads) {
        None => cores,
        Some(0) => return Err(Error::Usage("--threads must be at least 1".into())),
        Some(t) if t > 4096 => return Err(Error::Usage(format!("--threads {t} is absurd"))),
        Some(t) => t,
    };
    let filter_kind = match (args.filter, st.filter.as_deref()) {
        (Some(f), _) => f,
        (None, None) | (None, Some("blackman-harris")) => FilterKind::BlackmanHarris,
        (None, Some("box")) => FilterKind::Box,
        (None, Some("gaussian")) => FilterKind::Gaussian,
        (None, Some(other)) => {
            return Err(Error::Usage(format!("unknown filter '{other}' in the scene settings")));
        }
    };
    let filter_width = args.filter_width.or(st.filter_width).unwrap_or(match filter_kind {
        // Blender's default filter size is 1.5 px, over which Cycles spreads its
        // Blackman-Harris window twice as wide (film.cpp: width *= 2): a 3 px window.
        FilterKind::BlackmanHarris => 3.0,
        // Cycles spreads its Gaussian over three times the filter width (film.cpp).
        FilterKind::Gaussian => 4.5,
        FilterKind::Box => 1.0,
    });
    // 32 px holds Cycles' widest window: the Gaussian over three times Filter Width's maximum, 10.
    if !(filter_width > 0.0 && filter_width <= 32.0) {
        return Err(Error::Usage(format!("filter width {filter_width} must be in (0, 32] pixels")));
    }
    let filter = match filter_kind {
        FilterKind::BlackmanHarris => Filter::blackman_harris(filter_width),
        FilterKind::Gaussian => Filter::gaussian(filter_width),
        FilterKind::Box => Filter::box_filter(filter_width),
    };
    // Cycles' Roughness Threshold is a fraction in [0, 1]; only a transparent film uses it.
    let transparent_glass = match st.transparent_glass {
        Some(t) if !(0.0..=1.0).contains(&t) => {
            return Err(Error::Usage(format!("transparent_glass {t} must be a roughness threshold in [0, 1]")));
        }
        t => t.filter(|_| st.transparent.unwrap_or(true)),
    };
    if let Some(i) = args.interim
        && !(i > 0.0 && i.is_finite())
    {
        return Err(Error::Usage(format!("--interim {i} must be a positive number of seconds")));
    }
    let integrator = match (args.integrator, st.integrator.as_deref()) {
        (Some(i), _) => i,
        (None, None) => IntegratorKind::Path,
        (None, Some(name)) => IntegratorKind::from_str(name, true).map_err(|_| {
            Error::Usage(format!(
                "the scene asks for integrator '{name}', which this build does not have (path, bdpt, photon, sppm, vcm)"
            ))
        })?,
    };
    // The tree is the default: on the many-lights scene it reaches the same mean with a
    // fraction of the error at equal time (docs/benchmarks.md, "Light selection").
    let light_sampler = match (args.light_sampler, st.light_sampler.as_deref()) {
        (Some(k), _) => k.into(),
        (None, None) => LightSamplerKind::default(),
        (None, Some(name)) => LightSamplerKind::from_name(name).ok_or_else(|| {
            Error::Usage(format!("the scene asks for light sampler '{name}', which does not exist (tree, power)"))
        })?,
    };
    let mut photon = resolve_photon(&args.photon, st)?;
    if integrator == IntegratorKind::Sppm {
        // An SPPM iteration takes one camera sample per pixel, so a sample count is an
        // iteration count: `--spp` counts iterations unless `--sppm-iterations` says otherwise
        // (a flag before the scene's settings, as everywhere; both given, the iterations win,
        // warned by the render); before, `--spp` was ignored.
        match (args.photon.sppm_iterations, args.spp) {
            (None, Some(s)) => photon.sppm_iterations = s,
            (None, None) if st.sppm_iterations.is_none() => match spp {
                Some(s) => photon.sppm_iterations = s,
                // With a time limit and no count SPPM iterates until the time is up, as the
                // path tracer samples until then without --spp.
                None => photon.sppm_iterations = MAX_SPP,
            },
            _ => {}
        }
    }
    if integrator != IntegratorKind::Path && max_depth > photon::MAX_PHOTON_DEPTH {
        return Err(Error::Usage(format!(
            "--max-depth {max_depth} is too deep for photon mapping (at most {})",
            photon::MAX_PHOTON_DEPTH
        )));
    }
    if matches!(integrator, IntegratorKind::Bdpt | IntegratorKind::Vcm)
        && max_depth > crate::integrator::bdpt::MAX_BDPT_DEPTH
    {
        return Err(Error::Usage(format!(
            "--max-depth {max_depth} is too deep for bidirectional path tracing (at most {})",
            crate::integrator::bdpt::MAX_BDPT_DEPTH
        )));
    }
    if args.bdpt_strategy.is_some() && integrator != IntegratorKind::Bdpt {
        return Err(Error::Usage("--bdpt-strategy needs --integrator bdpt".into()));
    }
    if (args.vcm_radius.is_some() || args.vcm_mode.is_some()) && integrator != IntegratorKind::Vcm {
        return Err(Error::Usage("--vcm-radius and --vcm-mode need --integrator vcm".into()));
    }
    if let Some(r) = args.vcm_radius
        && !(r > 0.0 && r.is_finite())
    {
        return Err(Error::Usage(format!("--vcm-radius {r} must be a positive number of scene units")));
    }
    let sample_offset = args.sample_offset.unwrap_or(0);
    if sample_offset > MAX_SAMPLE_OFFSET {
        return Err(Error::Usage(format!("--sample-offset {sample_offset} is absurd (at most {MAX_SAMPLE_OFFSET})")));
    }
    if args.photon_seed.is_some() && (integrator != IntegratorKind::Photon || args.photon_map.is_some()) {
        return Err(Error::Usage("--photon-seed needs --integrator photon and no --photon-map".into()));
    }
    if args.photon_map.is_some() && integrator != IntegratorKind::Photon {
        return Err(Error::Usage("--photon-map needs --integrator photon".into()));
    }
    let adaptive = resolve_adaptive(args, st)?;
    if adaptive.is_some() && (args.chunk || sample_offset != 0) {
        // Each chunk would stop its pixels on its own samples: the merged counts would not
        // be what one render decides, and the merge could not add them exactly.
        return Err(Error::Usage(
            "adaptive sampling (--noise-threshold) cannot be split into chunks (--chunk, --sample-offset): \
             a pixel's stopping point depends on all its earlier samples; render the frame whole or set the threshold to 0"
                .into(),
        ));
    }
    let mut passes = match (&args.passes, &st.passes) {
        (Some(list), _) => crate::passes::PassSet::parse_list(list)?,
        (None, Some(list)) => crate::passes::PassSet::parse_list(&list.join(","))
            .map_err(|e| Error::Usage(format!("the scene's render settings: {e}")))?,
        (None, None) => crate::passes::PassSet::legacy(),
    };
    // Every integrator files them as the path tracer: BDPT and VCM every strategy's
    // contribution (`integrator::bdpt::passes`), Jensen its map reads (`photon/map_read.rs`),
    // SPPM its camera pass and gathered flux (`photon/sppm_passes.rs`).
    if passes.asks_light_groups() {
        passes.set_light_groups(scene.light_groups.len());
    }
    if passes.asks_shader_aovs() {
        passes.set_shader_aov_channels(scene.shader_aovs.channels);
    }
    if let Some(levels) = args.cryptomatte_levels.or(st.cryptomatte_levels) {
        passes.set_cryptomatte_levels(levels);
    }
    passes.cryptomatte()?;
    if passes.any_crypto() && args.chunk {
        // Cryptomatte's slots are filled in sample order (a full pixel counts a new id in
        // its last slot): a chunk keeps each pixel's whole first-seen list for the merge.
        passes.set_cryptomatte_exact();
    }
    if !scene.ray_visibility.catcher_objects.is_empty() && splits_at_catchers(integrator) {
        passes = passes.with_catcher_sums();
    }
    if passes.contains(crate::passes::Pass::ShadowCatcher) && !splits_at_catchers(integrator) {
        return Err(Error::Usage(format!(
            "the Shadow Catcher pass is rendered by the path, BDPT, VCM, photon and SPPM integrators only, not by '{}'",
            integrator.name()
        )));
    }
    let data = crate::passes::DataSettings::resolve(st.mist, st.ao_distance)?;
    let fast_gi = match &st.fast_gi {
        None => None,
        Some(f) => crate::integrator::fast_gi::FastGi::from_settings(f)
            .map_err(|e| Error::Usage(format!("scene settings: {e}")))?,
    };
    if adaptive.is_some() {
        // Where adaptive sampling stopped each pixel is part of its result (Cycles writes it too).
        passes.insert(crate::passes::Pass::SampleCount);
    }
    Ok(Resolved {
        passes,
        data,
        resolution,
        window,
        spp,
        time_limit,
        camera,
        threads,
        job_seed: args.seed.or(st.seed).unwrap_or(0),
        max_depth,
        light_paths,
        transparent_max,
        filter,
        transparent: st.transparent.unwrap_or(true),
        transparent_glass,
        integrator,
        photon,
        light_sampler,
        sample_offset,
        adaptive,
        fast_gi,
    })
}

/// Resolves Cycles' Light Paths settings (flag > scene > a plain glTF run's: no per-kind
/// limit, no clamp or Filter Glossy, caustics on, 8 transparent bounces) and checks the clamps.
fn resolve_light_paths(
    args: &RenderArgs,
    st: &scene::SceneSettings,
) -> Result<(crate::integrator::light_paths::LightPaths, u32)> {
    use crate::integrator::light_paths::LightPaths;
    let a = &args.light_paths;
    let u = LightPaths::UNLIMITED;
    let clamp = |flag: Option<f32>, file: Option<f32>, name: &str| match flag.or(file) {
        Some(c) if !(c >= 0.0 && c.is_finite()) => {
            Err(Error::Usage(format!("--{name} {c} must be a finite number ≥ 0 (0 = off)")))
        }
        c => Ok(c.unwrap_or(0.0)),
    };
    let lp = LightPaths {
        diffuse: a.diffuse_max_bounces.or(st.diffuse_max_bounces).unwrap_or(u.diffuse),
        glossy: a.glossy_max_bounces.or(st.glossy_max_bounces).unwrap_or(u.glossy),
        transmission: a.transmission_max_bounces.or(st.transmission_max_bounces).unwrap_or(u.transmission),
        volume: a.volume_max_bounces.or(st.volume_max_bounces).unwrap_or(u.volume),
        clamp_direct: clamp(a.clamp_direct, st.clamp_direct, "clamp-direct")?,
        clamp_indirect: clamp(a.clamp_indirect, st.clamp_indirect, "clamp-indirect")?,
        filter_glossy: clamp(a.filter_glossy, st.filter_glossy, "filter-glossy")?,
        caustics_reflective: st.caustics_reflective.unwrap_or(true),
        caustics_refractive: st.caustics_refractive.unwrap_or(true),
    };
    let transparent_max =
        a.transparent_max_bounces.or(st.transparent_max_bounces).unwrap_or(crate::integrator::DEFAULT_TRANSPARENT_MAX);
    Ok((lp, transparent_max))
}

/// Resolves adaptive sampling (flag > scene > off) and checks its range (Cycles' panel:
/// threshold in [0, 1], min samples up to 4096; here up to the largest spp).
fn resolve_adaptive(args: &RenderArgs, st: &scene::SceneSettings) -> Result<Option<Adaptive>> {
    let threshold = args.noise_threshold.or(st.noise_threshold).unwrap_or(0.0);
    let min_samples = args.min_samples.or(st.min_samples).unwrap_or(0);
    if !(0.0..=1.0).contains(&threshold) {
        return Err(Error::Usage(format!("--noise-threshold {threshold} must be in [0, 1] (0 = off)")));
    }
    if min_samples > MAX_SPP {
        return Err(Error::Usage(format!("--min-samples {min_samples} is absurd (at most {MAX_SPP})")));
    }
    Ok((threshold > 0.0).then(|| Adaptive::new(threshold, min_samples)))
}

/// True when `integrator` splits camera paths at shadow catchers (`integrator::catcher`:
/// the path tracer; BDPT's, VCM's, Jensen's and SPPM's camera paths, whose catcher pass is path
/// traced). Every integrator does; the function names the rule the settings and warnings share.
pub fn splits_at_catchers(integrator: IntegratorKind) -> bool {
    matches!(
        integrator,
        IntegratorKind::Path
            | IntegratorKind::Bdpt
            | IntegratorKind::Vcm
            | IntegratorKind::Photon
            | IntegratorKind::Sppm
    )
}
