//! The `caustic` commands: argument types, settings resolution (flag > scene >
//! default, every default in one place), and the render and info pipelines.

use crate::accel::Accel;
use crate::error::{Error, Result};
use crate::film::Filter;
use crate::integrator::bdpt::BdptIntegrator;
use crate::integrator::path::PathIntegrator;
use crate::integrator::photon;
use crate::integrator::photon::io::PhotonMaps;
use crate::integrator::photon::jensen::JensenIntegrator;
use crate::integrator::photon::sppm::SppmIntegrator;
use crate::integrator::photon::{MAX_K, PhotonSettings, default_max_radius};
use crate::integrator::{Integrator, SceneContext};
use crate::light::LightSamplerKind;
use crate::memory::{self, MemoryBudget, human};
use crate::output;
use crate::progress::{ProgressMode, Reporter};
use crate::render::{self, RenderJob};
use crate::scene::camera::CameraRays;
use crate::scene::{self, Scene};
use clap::{Args, Parser, Subcommand, ValueEnum};
use serde_json::json;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Prints a line to stdout, ignoring a closed pipe (`caustic info --json | head`).
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write;
        let _ = writeln!(std::io::stdout().lock(), $($arg)*);
    }};
}

/// Default output width when neither the flag nor the scene gives a resolution.
pub const DEFAULT_WIDTH: u32 = 640;
/// Default output height when the camera gives no aspect ratio either.
pub const DEFAULT_HEIGHT: u32 = 480;
/// Default samples per pixel.
pub const DEFAULT_SPP: u32 = 64;
/// Largest accepted image side.
pub const MAX_SIDE: u32 = 32_768;
/// Largest accepted pixel count (the film holds ~60 bytes per pixel).
pub const MAX_PIXELS: u64 = 1 << 28;
/// Largest accepted samples per pixel.
pub const MAX_SPP: u32 = 1 << 24;
/// Largest accepted path depth.
pub const MAX_DEPTH: u32 = 1024;

/// Caustic: a physically based renderer for glTF scenes.
#[derive(Parser, Debug)]
#[command(name = "caustic", version, about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a glTF scene to an OpenEXR image.
    Render(RenderArgs),
    /// Describe what Caustic loads from a scene, with every warning.
    Info(InfoArgs),
    /// Measure rendering speed on a scene (default: the bundled Cornell box).
    Bench(BenchArgs),
    /// Trace a scene's photon maps and write them for `render --photon-map`.
    Photons(PhotonsArgs),
}

/// `caustic photons`.
#[derive(Args, Debug)]
pub struct PhotonsArgs {
    /// Scene file (.gltf or .glb).
    pub scene: PathBuf,
    /// Output photon-map file.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Maximum scattering events per path the map will serve [default: 13].
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Random seed [default: 0].
    #[arg(long)]
    pub seed: Option<u32>,
    /// Worker threads [default: all cores].
    #[arg(long)]
    pub threads: Option<usize>,
    /// Progress display [default: bar on a terminal, else none].
    #[arg(long, value_enum)]
    pub progress: Option<ProgressMode>,
    /// Photon-mapping settings.
    #[command(flatten)]
    pub photon: PhotonArgs,
    /// Memory budget: a size (8G, 512M), a share of the available memory (50%), or none [default: 90% of the available memory].
    #[arg(long, value_name = "SIZE")]
    pub memory_limit: Option<String>,
    /// Test hook: sleep SECONDS, uninterruptibly, when PHASE starts (docs/contract.md).
    #[arg(long, value_name = "PHASE=SECONDS", hide = true)]
    pub debug_delay: Vec<String>,
}

/// Photon-mapping flags (shared by `render` and `photons`); defaults in
/// `integrator::photon::PhotonSettings` and [`resolve_photon`].
#[derive(Args, Debug, Default, Clone)]
pub struct PhotonArgs {
    /// Photons emitted for the global map (photon integrator) [default: 200000].
    #[arg(long)]
    pub photons: Option<u64>,
    /// Photons emitted for the caustic map (photon integrator) [default: 100000].
    #[arg(long)]
    pub caustic_photons: Option<u64>,
    /// Neighbours per global-map radiance estimate (1..=256) [default: 20].
    #[arg(long)]
    pub k: Option<usize>,
    /// Neighbours per caustic-map radiance estimate (1..=256) [default: 10].
    #[arg(long)]
    pub caustic_k: Option<usize>,
    /// Maximum photon search radius in scene units [default: 0.1 × the scene's bounding radius].
    #[arg(long)]
    pub max_radius: Option<f32>,
    /// Final-gather rays per camera sample [default: 1].
    #[arg(long)]
    pub gather_rays: Option<u32>,
    /// Non-specular bounces before the global map is read; 0 = no final gather [default: 1].
    #[arg(long)]
    pub diffuse_bounces: Option<u32>,
    /// SPPM iterations (one camera sample per pixel each) [default: 64].
    #[arg(long)]
    pub sppm_iterations: Option<u32>,
    /// SPPM photons per iteration [default: 2 × the rendered window's pixel count].
    #[arg(long)]
    pub sppm_photons: Option<u64>,
    /// SPPM initial radius in scene units [default: per pixel, 3 pixel footprints at the visible point, clamped to 1e-4..0.05 × the scene radius].
    #[arg(long)]
    pub sppm_radius: Option<f32>,
}

/// `caustic bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Scene file [default: scenes/cornell_box.gltf].
    #[arg(default_value = "scenes/cornell_box.gltf")]
    pub scene: PathBuf,
    /// Samples per pixel.
    #[arg(long, default_value_t = 64)]
    pub spp: u32,
    /// Image size WxH.
    #[arg(long, value_parser = parse_resolution, default_value = "512x512")]
    pub resolution: (u32, u32),
    /// Worker threads [default: all cores].
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print the figures as JSON.
    #[arg(long)]
    pub json: bool,
    /// Light-transport algorithm to measure.
    #[arg(long, value_enum, default_value = "path")]
    pub integrator: IntegratorKind,
    /// Light selection [default: the scene's, else tree].
    #[arg(long, value_enum)]
    pub light_sampler: Option<LightSamplerArg>,
    /// Photon-mapping settings.
    #[command(flatten)]
    pub photon: PhotonArgs,
}

/// Light-transport algorithm.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum IntegratorKind {
    /// Path tracing with next-event estimation and MIS.
    Path,
    /// Jensen's photon mapping: caustic map, final gather on the global map.
    Photon,
    /// Stochastic progressive photon mapping (consistent).
    Sppm,
    /// Bidirectional path tracing with MIS over all strategies.
    Bdpt,
}

impl IntegratorKind {
    /// The name used on the command line and in the scene settings.
    pub fn name(self) -> &'static str {
        match self {
            IntegratorKind::Path => "path",
            IntegratorKind::Photon => "photon",
            IntegratorKind::Sppm => "sppm",
            IntegratorKind::Bdpt => "bdpt",
        }
    }
}

/// Light selection for next-event estimation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum LightSamplerArg {
    /// Light tree: prefers lights near and facing the shading point (Conty & Kulla 2018).
    Tree,
    /// In proportion to each light's power.
    Power,
}

impl From<LightSamplerArg> for LightSamplerKind {
    fn from(a: LightSamplerArg) -> Self {
        match a {
            LightSamplerArg::Tree => LightSamplerKind::Tree,
            LightSamplerArg::Power => LightSamplerKind::Power,
        }
    }
}

/// Pixel filter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FilterKind {
    /// Blackman-Harris (Blender's default).
    BlackmanHarris,
    /// Box.
    Box,
}

/// `caustic render`.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (.gltf or .glb).
    pub scene: PathBuf,
    /// Output OpenEXR file.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Samples per pixel [default: the scene's, else 64; unlimited with --time-limit alone].
    #[arg(long)]
    pub spp: Option<u32>,
    /// Image size WxH [default: the scene's, else 640 wide in the camera's aspect ratio, else 640x480].
    #[arg(long, value_parser = parse_resolution)]
    pub resolution: Option<(u32, u32)>,
    /// Maximum scattering events per path (1 = direct light only) [default: 13 = Blender's 12 bounces].
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Random seed [default: 0].
    #[arg(long)]
    pub seed: Option<u32>,
    /// Worker threads [default: all cores].
    #[arg(long)]
    pub threads: Option<usize>,
    /// Stop rendering after this many seconds and write the image.
    #[arg(long)]
    pub time_limit: Option<f64>,
    /// Camera by name or index [default: the scene's, else the first].
    #[arg(long)]
    pub camera: Option<String>,
    /// Render only the pixel window X0,Y0,X1,Y1 of the full frame (top-left origin, end exclusive).
    #[arg(long, value_parser = parse_crop)]
    pub crop: Option<[u32; 4]>,
    /// Write half floats instead of 32-bit floats (Depth stays 32-bit).
    #[arg(long)]
    pub half: bool,
    /// Progress display [default: bar on a terminal, else none].
    #[arg(long, value_enum)]
    pub progress: Option<ProgressMode>,
    /// Light-transport algorithm [default: the scene's, else path].
    #[arg(long, value_enum)]
    pub integrator: Option<IntegratorKind>,
    /// Photon maps written by `caustic photons` for this scene (photon integrator).
    #[arg(long)]
    pub photon_map: Option<PathBuf>,
    /// Photon-mapping settings.
    #[command(flatten)]
    pub photon: PhotonArgs,
    /// Debugging (bdpt): render only strategy S,T (S light vertices, T camera vertices,
    /// the camera included), MIS-weighted, or unweighted with S,T,unweighted.
    #[arg(long, value_name = "S,T[,unweighted]", value_parser = parse_strategy)]
    pub bdpt_strategy: Option<crate::integrator::bdpt::Strategy>,
    /// Rewrite the output every SECONDS while rendering.
    #[arg(long, value_name = "SECONDS")]
    pub interim: Option<f64>,
    /// Pixel filter [default: the scene's, else blackman-harris].
    #[arg(long, value_enum)]
    pub filter: Option<FilterKind>,
    /// Filter window in pixels [default: the scene's, else 3 for Blackman-Harris (Blender's 1.5 px filter size, which Cycles spans twice as wide), 1 for box].
    #[arg(long)]
    pub filter_width: Option<f32>,
    /// Memory budget: a size (8G, 512M), a share of the available memory (50%), or none [default: 90% of the available memory].
    #[arg(long, value_name = "SIZE")]
    pub memory_limit: Option<String>,
    /// Test hook: sleep SECONDS, uninterruptibly, when PHASE starts (docs/contract.md).
    #[arg(long, value_name = "PHASE=SECONDS", hide = true)]
    pub debug_delay: Vec<String>,
    /// Light selection for next-event estimation [default: the scene's, else tree].
    #[arg(long, value_enum)]
    pub light_sampler: Option<LightSamplerArg>,
}

/// `caustic info`.
#[derive(Args, Debug)]
pub struct InfoArgs {
    /// Scene file (.gltf or .glb).
    pub scene: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Memory budget: a size (8G, 512M), a share of the available memory (50%), or none [default: 90% of the available memory].
    #[arg(long, value_name = "SIZE")]
    pub memory_limit: Option<String>,
}

fn parse_resolution(s: &str) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("'{s}' is not WxH"))?;
    let w: u32 = w.trim().parse().map_err(|_| format!("bad width in '{s}'"))?;
    let h: u32 = h.trim().parse().map_err(|_| format!("bad height in '{s}'"))?;
    Ok((w, h))
}

fn parse_crop(s: &str) -> std::result::Result<[u32; 4], String> {
    let v: Vec<u32> = s
        .split(',')
        .map(|p| p.trim().parse::<u32>().map_err(|_| format!("'{s}' is not X0,Y0,X1,Y1")))
        .collect::<std::result::Result<_, _>>()?;
    <[u32; 4]>::try_from(v).map_err(|_| format!("'{s}' is not X0,Y0,X1,Y1"))
}

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
    /// Filter.
    pub filter: Filter,
    /// Transparent background.
    pub transparent: bool,
    /// Algorithm.
    pub integrator: IntegratorKind,
    /// Photon-mapping settings.
    pub photon: PhotonSettings,
    /// Light selection.
    pub light_sampler: LightSamplerKind,
}

/// Parses `S,T` or `S,T,unweighted` for `--bdpt-strategy`.
fn parse_strategy(v: &str) -> std::result::Result<crate::integrator::bdpt::Strategy, String> {
    let parts: Vec<&str> = v.split(',').map(str::trim).collect();
    let num = |x: &str, what: &str| -> std::result::Result<u32, String> {
        x.parse::<u32>().map_err(|_| format!("{what} '{x}' is not a whole number (expected S,T or S,T,unweighted)"))
    };
    let (s, t, weighted) = match parts.as_slice() {
        [s, t] => (num(s, "S")?, num(t, "T")?, true),
        [s, t, "unweighted"] => (num(s, "S")?, num(t, "T")?, false),
        [s, t, "weighted"] => (num(s, "S")?, num(t, "T")?, true),
        _ => return Err(format!("'{v}' is not S,T or S,T,unweighted")),
    };
    if t == 0 {
        return Err("T must be at least 1 (the camera is a vertex of every path)".into());
    }
    if s + t < 2 {
        return Err("a path needs at least two vertices (S + T >= 2)".into());
    }
    Ok(crate::integrator::bdpt::Strategy { s, t, weighted })
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
    if p.diffuse_bounces > MAX_DEPTH {
        return Err(Error::Usage(format!("--diffuse-bounces {} is absurd", p.diffuse_bounces)));
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

/// Resolves every setting; each default lives here.
pub fn resolve(args: &RenderArgs, scene: &Scene) -> Result<Resolved> {
    let st = &scene.settings;
    let camera = pick_camera(scene, args.camera.as_deref().or(st.camera.as_deref()))?;
    let resolution = match args.resolution.or(st.resolution.map(|r| (r[0], r[1]))) {
        Some(r) => r,
        None => match scene.cameras[camera].aspect() {
            Some(a) => (DEFAULT_WIDTH, ((DEFAULT_WIDTH as f32 / a).round() as u32).max(1)),
            None => (DEFAULT_WIDTH, DEFAULT_HEIGHT),
        },
    };
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
        (None, Some(other)) => {
            return Err(Error::Usage(format!("unknown filter '{other}' in the scene settings")));
        }
    };
    let filter_width = args.filter_width.or(st.filter_width).unwrap_or(match filter_kind {
        // Blender's default filter size is 1.5 px, over which Cycles spreads its
        // Blackman-Harris window twice as wide (film.cpp: width *= 2): a 3 px window.
        FilterKind::BlackmanHarris => 3.0,
        FilterKind::Box => 1.0,
    });
    if !(filter_width > 0.0 && filter_width <= 16.0) {
        return Err(Error::Usage(format!("filter width {filter_width} must be in (0, 16] pixels")));
    }
    let filter = match filter_kind {
        FilterKind::BlackmanHarris => Filter::blackman_harris(filter_width),
        FilterKind::Box => Filter::box_filter(filter_width),
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
                "the scene asks for integrator '{name}', which this build does not have (path, bdpt, photon, sppm)"
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
    // SPPM with a time limit and no iteration count iterates until the time is up, as the
    // path tracer samples until then without --spp.
    if integrator == IntegratorKind::Sppm
        && time_limit.is_some()
        && args.photon.sppm_iterations.or(st.sppm_iterations).is_none()
    {
        photon.sppm_iterations = MAX_SPP;
    }
    if integrator != IntegratorKind::Path && max_depth > photon::MAX_PHOTON_DEPTH {
        return Err(Error::Usage(format!(
            "--max-depth {max_depth} is too deep for photon mapping (at most {})",
            photon::MAX_PHOTON_DEPTH
        )));
    }
    if integrator == IntegratorKind::Bdpt && max_depth > crate::integrator::bdpt::MAX_BDPT_DEPTH {
        return Err(Error::Usage(format!(
            "--max-depth {max_depth} is too deep for bidirectional path tracing (at most {})",
            crate::integrator::bdpt::MAX_BDPT_DEPTH
        )));
    }
    if args.bdpt_strategy.is_some() && integrator != IntegratorKind::Bdpt {
        return Err(Error::Usage("--bdpt-strategy needs --integrator bdpt".into()));
    }
    if args.photon_map.is_some() && integrator != IntegratorKind::Photon {
        return Err(Error::Usage("--photon-map needs --integrator photon".into()));
    }
    Ok(Resolved {
        resolution,
        window,
        spp,
        time_limit,
        camera,
        threads,
        job_seed: args.seed.or(st.seed).unwrap_or(0),
        max_depth,
        filter,
        transparent: st.transparent.unwrap_or(true),
        integrator,
        photon,
        light_sampler,
    })
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
    let scene = scene::gltf::load_within(&args.scene, &budget)?;
    for w in &scene.warnings {
        reporter.warning(w);
    }
    let res = resolve(args, &scene)?;
    charge_render(&budget, args, &res, &scene)?;
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
    let accel = pool.install(|| {
        // The BSDF's albedo table is built here, in parallel, rather than by the first
        // shading point inside the timed rendering phase.
        crate::bsdf::pbr::specular_albedo();
        Accel::build(&tris)
    });
    drop(tris);
    if stop.load(Ordering::Relaxed) {
        return Err(Error::InterruptedEmpty);
    }
    let ctx = SceneContext::with_light_sampler(&scene, &accel, res.light_sampler);
    let camera = CameraRays::new(&scene.cameras[res.camera], res.resolution.0, res.resolution.1);
    let mut photon_stats = serde_json::Value::Null;
    let integrator = match res.integrator {
        IntegratorKind::Path => Integrator::Path(PathIntegrator::new(res.max_depth, res.transparent)),
        IntegratorKind::Sppm => {
            Integrator::Sppm(SppmIntegrator::new(res.max_depth, res.photon.clone(), res.transparent))
        }
        IntegratorKind::Bdpt => {
            Integrator::Bdpt(BdptIntegrator::new(&scene, res.max_depth, res.transparent, args.bdpt_strategy))
        }
        IntegratorKind::Photon => {
            reporter.phase("photons", t0.elapsed().as_secs_f64());
            let maps = match &args.photon_map {
                Some(path) => {
                    let maps = PhotonMaps::load(path, photon::io::scene_hash(&args.scene)?)?;
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
                    let hash = photon::io::scene_hash(&args.scene)?;
                    let (maps, st) = pool
                        .install(|| trace_maps(&ctx, &res.photon, res.job_seed, res.max_depth, hash, reporter, stop));
                    photon_stats = map_stats_json(&maps, &st);
                    maps
                }
            };
            if stop.load(Ordering::Relaxed) {
                return Err(Error::InterruptedEmpty);
            }
            let (_, scene_r) = scene.bounding_sphere();
            Integrator::Photon(JensenIntegrator::new(maps, &res.photon, scene_r, res.max_depth, res.transparent))
        }
    };
    let job = RenderJob {
        width: res.resolution.0,
        height: res.resolution.1,
        window: res.window,
        spp: res.spp,
        time_limit: res.time_limit,
        seed: res.job_seed,
        filter: res.filter.clone(),
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
                if !res.transparent {
                    img.make_opaque();
                }
                match output::write_exr(&args.output, &img, args.half) {
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
    if !res.transparent {
        result.image.make_opaque();
    }

    reporter.phase("writing", t0.elapsed().as_secs_f64());
    output::write_exr(&args.output, &result.image, args.half)?;
    reporter.image(&out_str, result.spp_min, true);

    let mut warnings = scene.warnings.clone();
    if result.nan_samples > 0 {
        let w = format!("{} sample(s) were NaN or infinite and were dropped", result.nan_samples);
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
        "integrator": integrator.describe(),
        "stats": {
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
            "photons": photon_stats,
        }
    });
    reporter.summary(summary.clone());
    Ok(Outcome { interrupted: result.interrupted, summary })
}

/// Traces the global and caustic maps, reporting the "photons" phase's progress at
/// most about twice a second.
fn trace_maps(
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
fn map_stats_json(maps: &PhotonMaps, st: &photon::io::MapStats) -> serde_json::Value {
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

/// `caustic photons`: traces the maps of a scene and writes them.
pub fn run_photons(args: &PhotonsArgs, reporter: &Reporter, stop: &AtomicBool) -> Result<()> {
    let t0 = Instant::now();
    reporter.phase("loading", 0.0);
    let budget = MemoryBudget::from_flag(args.memory_limit.as_deref())?;
    let scene = scene::gltf::load_within(&args.scene, &budget)?;
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
    let hash = photon::io::scene_hash(&args.scene)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::Internal(format!("cannot start worker threads: {e}")))?;
    reporter.phase("bvh", t0.elapsed().as_secs_f64());
    let tris: Vec<[glam::Vec3; 3]> =
        scene.mesh.triangles.iter().map(|t| t.map(|i| scene.mesh.positions[i as usize])).collect();
    let accel = pool.install(|| {
        // The BSDF's albedo table is built here, in parallel, rather than by the first
        // shading point inside the timed rendering phase.
        crate::bsdf::pbr::specular_albedo();
        Accel::build(&tris)
    });
    let ctx = SceneContext::new(&scene, &accel);
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

/// `caustic info`.
pub fn run_info(args: &InfoArgs) -> Result<()> {
    let budget = MemoryBudget::from_flag(args.memory_limit.as_deref())?;
    let scene = scene::gltf::load_within(&args.scene, &budget)?;
    let r = &scene.report;
    if args.json {
        let v = json!({
            "file": r.file,
            "triangles": r.triangles,
            "meshes": r.meshes,
            "instances": r.instances,
            "degenerate_triangles": r.degenerate_triangles,
            "emissive_triangles": scene.lights.iter().filter(|l| matches!(l, crate::light::Light::Triangle { .. })).count(),
            "punctual_lights": scene.lights.iter().filter(|l| !matches!(l, crate::light::Light::Triangle { .. } | crate::light::Light::Area(_))).count(),
            "area_lights": scene.lights.iter().filter(|l| matches!(l, crate::light::Light::Area(_))).count(),
            "materials": r.materials,
            "lights": r.lights,
            "cameras": r.cameras,
            "bounds": r.bounds,
            "extensions_used": r.extensions_used,
            "settings": scene.settings,
            "warnings": scene.warnings,
        });
        outln!("{}", serde_json::to_string_pretty(&v).unwrap_or_default());
        return Ok(());
    }
    outln!("{}", r.file);
    outln!(
        "  triangles: {} ({} meshes, {} instances, {} degenerate dropped)",
        r.triangles,
        r.meshes,
        r.instances,
        r.degenerate_triangles
    );
    outln!("  bounds: {:?} .. {:?}", r.bounds[0], r.bounds[1]);
    if !r.extensions_used.is_empty() {
        outln!("  extensions used: {}", r.extensions_used.join(", "));
    }
    outln!("  materials:");
    for m in &r.materials {
        outln!("    {}: {}", m.name, if m.features.is_empty() { "factors only".into() } else { m.features.join(", ") });
    }
    outln!("  lights:");
    for l in &r.lights {
        let tri = if l.kind == "emissive" { format!(" ({} triangles)", l.triangles) } else { String::new() };
        outln!("    {} '{}': {:.4} W{}", l.kind, l.name, l.power, tri);
    }
    outln!("  cameras:");
    for c in &r.cameras {
        let mut extra = String::new();
        if let Some([x, y]) = c.shift {
            extra += &format!(", shift {x} x {y} frames");
        }
        if let Some(d) = &c.depth_of_field {
            extra += &format!(", depth of field: {d}");
        }
        outln!("    {} ({}{extra})", c.name, c.kind);
    }
    if !scene.warnings.is_empty() {
        outln!("  warnings:");
        for w in &scene.warnings {
            outln!("    {w}");
        }
    }
    Ok(())
}

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
        seed: None,
        threads: args.threads,
        time_limit: None,
        camera: None,
        crop: None,
        half: false,
        progress: Some(ProgressMode::None),
        integrator: Some(args.integrator),
        photon_map: None,
        photon: args.photon.clone(),
        bdpt_strategy: None,
        interim: None,
        filter: None,
        filter_width: None,
        memory_limit: None,
        debug_delay: Vec::new(),
        light_sampler: args.light_sampler,
    };
    let reporter = Reporter::silent();
    let outcome = run_render(&render_args, &reporter, stop);
    let _ = std::fs::remove_dir_all(&dir);
    let s = outcome?.summary;
    let photon_figures = if matches!(args.integrator, IntegratorKind::Path | IntegratorKind::Bdpt) {
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
        // The BSDF's albedo table is built here, in parallel, rather than by the first
        // shading point inside the timed rendering phase.
        crate::bsdf::pbr::specular_albedo();
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

// ---- Memory budget of the commands (issue 11): estimates charged before allocating. ----

/// Charges the BVH build of the scene's triangles.
fn charge_bvh(budget: &MemoryBudget, scene: &Scene) -> Result<()> {
    let n = scene.mesh.triangles.len() as u64;
    budget.charge(format!("the BVH over {n} triangles"), n.saturating_mul(memory::BVH_BYTES_PER_TRIANGLE))
}

/// Charges the photon maps traced with settings `p` (global and caustic).
fn charge_photon_maps(budget: &MemoryBudget, p: &PhotonSettings, max_depth: u32) -> Result<()> {
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
                pixels.saturating_mul(photon::sppm::bytes_per_pixel()),
            )?;
            let per_iter = res.photon.sppm_photons.unwrap_or_else(|| photon::default_sppm_photons(pixels));
            budget.charge(
                format!("SPPM's photon map of {per_iter} photons per iteration"),
                memory::photon_map_bytes(per_iter, res.max_depth),
            )
        }
        // Light-tracing splats: the film's sum plus one buffer per worker (f64 RGB each;
        // the pool holds one per concurrently running tile, at most one per thread).
        IntegratorKind::Bdpt => budget.charge(
            format!("bidirectional splat buffers ({} threads + 1) for {pixels} pixels", res.threads),
            pixels.saturating_mul(24).saturating_mul(res.threads as u64 + 1),
        ),
        // The path tracer keeps nothing per pixel beyond the film.
        IntegratorKind::Path => Ok(()),
    }
}
