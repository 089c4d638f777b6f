//! The command line: clap argument types, their parsers and the accepted ranges.

use crate::light::LightSamplerKind;
use crate::progress::ProgressMode;
use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

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
/// Largest accepted `--sample-offset`: offset + spp stays below 2^32 (the sample index is a u32).
pub const MAX_SAMPLE_OFFSET: u32 = 1 << 31;
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
// Parsed once per process: the size of the largest variant does not matter.
#[allow(clippy::large_enum_variant)]
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
    /// Merge chunks of one frame (renders with --chunk of disjoint sample ranges) exactly.
    Merge(MergeArgs),
    /// Serve Blender's Rendered viewport: framed requests on stdin, frames on stdout (docs/protocol.md).
    Serve(ServeArgs),
}

/// `caustic serve`.
#[derive(Args, Debug)]
pub struct ServeArgs {
    /// Worker threads [default: all cores].
    #[arg(long)]
    pub threads: Option<usize>,
    /// Memory budget for loaded scenes, e.g. 8G [default: none].
    #[arg(long)]
    pub memory_limit: Option<String>,
}

/// `caustic merge`.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// Chunk files written by `caustic render --chunk` (any order).
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Output OpenEXR file.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Write the merged sums too, so that the output can be merged again.
    #[arg(long)]
    pub chunk: bool,
    /// Write half floats instead of 32-bit floats (Depth stays 32-bit).
    #[arg(long)]
    pub half: bool,
    /// Progress display [default: none].
    #[arg(long, value_enum)]
    pub progress: Option<ProgressMode>,
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

/// Cycles' Light Paths settings beyond Max Bounces (`--max-depth`); defaults in
/// `integrator::light_paths` and `cli::settings::resolve`.
#[derive(Args, Debug, Default, Clone)]
pub struct LightPathArgs {
    /// Cycles' Diffuse Bounces: a path ends after one more diffuse reflection [default: the scene's, else unlimited].
    #[arg(long)]
    pub diffuse_max_bounces: Option<u32>,
    /// Cycles' Glossy Bounces [default: the scene's, else unlimited].
    #[arg(long)]
    pub glossy_max_bounces: Option<u32>,
    /// Cycles' Transmission Bounces [default: the scene's, else unlimited].
    #[arg(long)]
    pub transmission_max_bounces: Option<u32>,
    /// Cycles' Volume Bounces (0 = single scattering) [default: the scene's, else unlimited].
    #[arg(long)]
    pub volume_max_bounces: Option<u32>,
    /// Cycles' Transparent Max Bounces [default: the scene's, else 8].
    #[arg(long)]
    pub transparent_max_bounces: Option<u32>,
    /// Cycles' Clamp Direct: largest direct-light sample value, 0 = off [default: the scene's, else 0].
    #[arg(long)]
    pub clamp_direct: Option<f32>,
    /// Cycles' Clamp Indirect: largest indirect-light sample value, 0 = off [default: the scene's, else 0].
    #[arg(long)]
    pub clamp_indirect: Option<f32>,
    /// Cycles' Filter Glossy: glossy lobes met after unlikely bounces are blurred, 0 = off [default: the scene's, else 0].
    #[arg(long)]
    pub filter_glossy: Option<f32>,
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
    /// Vertex connection and merging: BDPT and photon merging combined by MIS
    /// (consistent; the integrator to pick when unsure).
    Vcm,
}

impl IntegratorKind {
    /// The name used on the command line and in the scene settings.
    pub fn name(self) -> &'static str {
        match self {
            IntegratorKind::Path => "path",
            IntegratorKind::Photon => "photon",
            IntegratorKind::Sppm => "sppm",
            IntegratorKind::Bdpt => "bdpt",
            IntegratorKind::Vcm => "vcm",
        }
    }
}

/// VCM's strategies (`--vcm-mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum VcmModeArg {
    /// Connections and merging.
    Full,
    /// Connections only (BDPT).
    Connect,
}

impl From<VcmModeArg> for crate::integrator::vcm::VcmMode {
    fn from(a: VcmModeArg) -> Self {
        match a {
            VcmModeArg::Full => crate::integrator::vcm::VcmMode::Full,
            VcmModeArg::Connect => crate::integrator::vcm::VcmMode::Connect,
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
    /// Gaussian (Cycles' table: standard deviation a twelfth of the window).
    Gaussian,
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
    /// Cycles' Light Paths limits and clamps (flags over the scene's).
    #[command(flatten)]
    pub light_paths: LightPathArgs,
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
    /// Name the channels for Blender's view NAME of a multi-view render (`Combined.NAME.R`, ...).
    #[arg(long, value_name = "NAME", value_parser = parse_view, conflicts_with = "chunk")]
    pub view: Option<String>,
    /// Progress display [default: bar on a terminal, else none].
    #[arg(long, value_enum)]
    pub progress: Option<ProgressMode>,
    /// Light-transport algorithm [default: the scene's, else path].
    #[arg(long, value_enum)]
    pub integrator: Option<IntegratorKind>,
    /// Photon maps written by `caustic photons` for this scene (photon integrator).
    #[arg(long)]
    pub photon_map: Option<PathBuf>,
    /// Seed of the photon maps the render traces (photon integrator): chunks with their own maps [default: --seed].
    #[arg(long, value_name = "N")]
    pub photon_seed: Option<u32>,
    /// Photon-mapping settings.
    #[command(flatten)]
    pub photon: PhotonArgs,
    /// First sample index: render samples N..N+spp of the seed's sequence (a chunk of a frame) [default: 0].
    #[arg(long, value_name = "N")]
    pub sample_offset: Option<u32>,
    /// Write the raw sums into the EXR as well, for `caustic merge` (docs/contract.md, chunks).
    #[arg(long)]
    pub chunk: bool,
    /// Debugging (bdpt): render only strategy S,T (S light vertices, T camera vertices,
    /// the camera included), MIS-weighted, or unweighted with S,T,unweighted.
    #[arg(long, value_name = "S,T[,unweighted]", value_parser = parse_strategy)]
    pub bdpt_strategy: Option<crate::integrator::bdpt::Strategy>,
    /// VCM's initial merging radius in scene units [default: 1 pixel footprint at the first hits, bounded by the scene's size].
    #[arg(long, value_name = "R")]
    pub vcm_radius: Option<f32>,
    /// Debugging (vcm): `connect` renders the connections alone (BDPT, bit for bit) [default: full].
    #[arg(long, value_enum, value_name = "MODE")]
    pub vcm_mode: Option<VcmModeArg>,
    /// Rewrite the output every SECONDS while rendering.
    #[arg(long, value_name = "SECONDS")]
    pub interim: Option<f64>,
    /// Pixel filter [default: the scene's, else blackman-harris].
    #[arg(long, value_enum)]
    pub filter: Option<FilterKind>,
    /// Filter window in pixels [default: the scene's, else 3 for Blackman-Harris (Blender's 1.5 px filter width, which Cycles spans twice as wide), 4.5 for Gaussian (three times as wide), 1 for box].
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
    /// Adaptive sampling's noise threshold, as Cycles' (0 = off; path, bdpt, photon) [default: the scene's, else 0].
    #[arg(long, value_name = "T")]
    pub noise_threshold: Option<f32>,
    /// Samples before adaptive sampling may stop a pixel (0 = Cycles' derivation from the threshold) [default: the scene's, else 0].
    #[arg(long, value_name = "N")]
    pub min_samples: Option<u32>,
    /// Denoise the final Combined with Intel Open Image Denoise (the noisy one is kept as `Noisy Image`).
    #[arg(long)]
    pub denoise: bool,
    /// The Open Image Denoise library (or its folder) for --denoise [default: $CAUSTIC_OIDN, else the system's].
    #[arg(long, value_name = "PATH")]
    pub oidn: Option<std::path::PathBuf>,
    /// Passes to write besides Combined, comma-separated Blender names or view-layer
    /// tokens (diffuse_direct, emit, z, mist, ...; "none": Combined alone) [default: the
    /// scene's, else z,normal,denoising_albedo,denoising_normal,sample_count].
    #[arg(long, value_name = "LIST")]
    pub passes: Option<String>,
    /// Cryptomatte levels: (id, coverage) pairs kept per pixel and layer, as Blender's
    /// (2 to 16) [default: the scene's, else 6].
    #[arg(long, value_name = "N")]
    pub cryptomatte_levels: Option<u32>,
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

/// A view name for `--view`: letters, digits, `_` and `-` (it goes between dots in a channel name).
fn parse_view(s: &str) -> Result<String, String> {
    if !s.is_empty() && s.len() <= 64 && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-') {
        Ok(s.to_string())
    } else {
        Err(format!("'{s}' is not a view name (1 to 64 letters, digits, '_' or '-')"))
    }
}

fn parse_crop(s: &str) -> std::result::Result<[u32; 4], String> {
    let v: Vec<u32> = s
        .split(',')
        .map(|p| p.trim().parse::<u32>().map_err(|_| format!("'{s}' is not X0,Y0,X1,Y1")))
        .collect::<std::result::Result<_, _>>()?;
    <[u32; 4]>::try_from(v).map_err(|_| format!("'{s}' is not X0,Y0,X1,Y1"))
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
