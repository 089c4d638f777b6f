//! Render passes as Blender names them: which exist, which a render was asked for
//! (`--passes`, or `passes` in the scene's render settings), where a camera sample keeps
//! each one's value ([`Aov`] slots) and how the film turns the sums into the pass.
//!
//! Names, channels and meanings follow Cycles 5.0 (checked with bpy 5.0.1: every pass of
//! the view layer enabled under Cycles, `render_result` saved as multilayer EXR):
//! * light passes (`intern/cycles/kernel/film/light_passes.h`): a contribution is filed by
//!   the class of the first scattering event (diffuse, glossy, transmission at a surface,
//!   by the BSDF's split at the sampled or light direction; volume in a medium); "direct"
//!   is next-event estimation at the first event and emission found at the second vertex,
//!   "indirect" the rest. Emission and Environment are emitters and the world seen
//!   directly (the world also when Film → Transparent hides it from Combined, as Cycles).
//!   Colour passes hold the first hit's albedo per class; Cycles divides Direct and
//!   Indirect by the Colour pass when it reads the film (`safe_divide_even_color`), so
//!   that (Direct + Indirect) × Colour is the class's light.
//! * data passes (`kernel/film/data_passes.h`): Mist = 1 − mean((1 − mist) × coverage),
//!   with mist = clamp((distance − start) / depth)^falloff; Position, Object Index and
//!   Material Index are single values, not means: the pixel's first sample's (Cycles
//!   writes sample 0's, wherever the pixel filter put it; 0 when it hit nothing); UV is
//!   (u, v, 1) averaged, so its A channel is the coverage; AO is the fraction of cosine
//!   rays from the first hit that travel the world's AO distance unoccluded.
//! * Cryptomatte (`crate::cryptomatte`): per layer the ranked (id, coverage) pairs of the
//!   camera ray's first hit, `CryptoObject00.R/G/B/A`, ... as Blender names them.

use crate::cryptomatte::{Kind, Layout};
use crate::error::{Error, Result};

/// A render pass that Caustic can write, with Blender's name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Pass {
    /// Camera-space Z of the first hit (always accumulated).
    Depth,
    /// First hit's shading normal (always accumulated).
    Normal,
    /// Albedo for denoisers (always accumulated).
    DenoisingAlbedo,
    /// Normal for denoisers (the Normal sums).
    DenoisingNormal,
    /// Samples taken per pixel.
    SampleCount,
    /// Diffuse light, direct.
    DiffuseDirect,
    /// Diffuse light, indirect.
    DiffuseIndirect,
    /// Diffuse albedo of the first hit.
    DiffuseColor,
    /// Glossy light, direct.
    GlossyDirect,
    /// Glossy light, indirect.
    GlossyIndirect,
    /// Glossy albedo of the first hit.
    GlossyColor,
    /// Transmitted light, direct.
    TransmissionDirect,
    /// Transmitted light, indirect.
    TransmissionIndirect,
    /// Transmission albedo of the first hit.
    TransmissionColor,
    /// Light scattered first in a volume, direct.
    VolumeDirect,
    /// Light scattered first in a volume, indirect.
    VolumeIndirect,
    /// Emitters seen directly.
    Emission,
    /// The world seen directly.
    Environment,
    /// Ambient occlusion of the first hit.
    AmbientOcclusion,
    /// Blender's mist.
    Mist,
    /// World position of the first hit (Blender's axes).
    Position,
    /// UV of the first hit (active render map).
    Uv,
    /// Object pass index.
    ObjectIndex,
    /// Material pass index.
    MaterialIndex,
    /// Cryptomatte of objects (`crate::cryptomatte`).
    CryptoObject,
    /// Cryptomatte of materials.
    CryptoMaterial,
    /// Cryptomatte of assets (topmost parents).
    CryptoAsset,
    /// Cycles' Shadow Catcher: the factor by which catchers change what is behind them
    /// (Combined over the catcher pass, `crate::shadow_catcher`).
    ShadowCatcher,
    /// Screen-space motion of the first hit in pixels: to the previous frame (X, Y) and to
    /// the next (Z, W), as Cycles' Vector pass (`crate::motion::vector`).
    Vector,
}

/// Every pass, in the order of the table below.
pub const ALL: [Pass; 29] = [
    Pass::Depth,
    Pass::Normal,
    Pass::DenoisingAlbedo,
    Pass::DenoisingNormal,
    Pass::SampleCount,
    Pass::DiffuseDirect,
    Pass::DiffuseIndirect,
    Pass::DiffuseColor,
    Pass::GlossyDirect,
    Pass::GlossyIndirect,
    Pass::GlossyColor,
    Pass::TransmissionDirect,
    Pass::TransmissionIndirect,
    Pass::TransmissionColor,
    Pass::VolumeDirect,
    Pass::VolumeIndirect,
    Pass::Emission,
    Pass::Environment,
    Pass::AmbientOcclusion,
    Pass::Mist,
    Pass::Position,
    Pass::Uv,
    Pass::ObjectIndex,
    Pass::MaterialIndex,
    Pass::CryptoObject,
    Pass::CryptoMaterial,
    Pass::CryptoAsset,
    Pass::ShadowCatcher,
    Pass::Vector,
];

/// Slots of [`Aov`]: where a camera sample keeps each extra pass's value.
pub mod slot {
    /// Diffuse Direct (RGB).
    pub const DIFF_DIR: usize = 0;
    /// Diffuse Indirect.
    pub const DIFF_IND: usize = 3;
    /// Diffuse Color.
    pub const DIFF_COL: usize = 6;
    /// Glossy Direct.
    pub const GLOSS_DIR: usize = 9;
    /// Glossy Indirect.
    pub const GLOSS_IND: usize = 12;
    /// Glossy Color.
    pub const GLOSS_COL: usize = 15;
    /// Transmission Direct.
    pub const TRANS_DIR: usize = 18;
    /// Transmission Indirect.
    pub const TRANS_IND: usize = 21;
    /// Transmission Color.
    pub const TRANS_COL: usize = 24;
    /// Volume Direct.
    pub const VOL_DIR: usize = 27;
    /// Volume Indirect.
    pub const VOL_IND: usize = 30;
    /// Emission.
    pub const EMIT: usize = 33;
    /// Environment.
    pub const ENV: usize = 36;
    /// Ambient Occlusion (one value, written grey).
    pub const AO: usize = 39;
    /// Mist's per-sample value (1 − (1 − mist) × coverage).
    pub const MIST: usize = 40;
    /// Position (nearest hit).
    pub const POS: usize = 41;
    /// UV and coverage.
    pub const UV: usize = 44;
    /// Object index (nearest hit).
    pub const OB: usize = 47;
    /// Material index (nearest hit).
    pub const MA: usize = 48;
    /// Vector (four values).
    pub const VECTOR: usize = 49;
    /// Shadow catcher (`integrator::catcher`): the catcher pass's radiance (RGB).
    pub const CATCHER_PASS: usize = 53;
    /// The matte: radiance of paths that did not split at a catcher (RGB).
    pub const CATCHER_MATTE: usize = 56;
    /// The matte's transparency from splits (mean throughput at the split).
    pub const CATCHER_SPLIT: usize = 59;
    /// Samples that split at a catcher.
    pub const CATCHER_COUNT: usize = 60;
    /// The world along camera rays that escaped or split (Cycles' background pass, which
    /// an opaque film's approximate shadow catcher composites over).
    pub const CATCHER_BACKGROUND: usize = 61;
    /// Number of slots (the catcher's sums stay last: `CATCHER_SLOTS` runs to the end).
    pub const COUNT: usize = 64;
}

// The film keeps its slots in a u64 bit mask.
const _: () = assert!(slot::COUNT <= 64);

/// The light-pass slots that light-tracing splats add to: every light pass but the Colour
/// passes (a splat has no camera sample whose first hit's albedo it could give), and the
/// shadow catcher's matte (a splat of a path that did not split at a catcher).
pub const SPLAT_SLOTS: u64 = {
    let starts = [
        slot::DIFF_DIR,
        slot::DIFF_IND,
        slot::GLOSS_DIR,
        slot::GLOSS_IND,
        slot::TRANS_DIR,
        slot::TRANS_IND,
        slot::VOL_DIR,
        slot::VOL_IND,
        slot::EMIT,
        slot::ENV,
        slot::CATCHER_MATTE,
    ];
    let mut mask = 0u64;
    let mut i = 0;
    while i < starts.len() {
        mask |= 0b111 << starts[i];
        i += 1;
    }
    mask
};

/// Bit mask of the slots kept as "the pixel's first sample's value" instead of a sum.
pub const FIRST_SAMPLE_SLOTS: u64 = (0b111 << slot::POS) | (1 << slot::OB) | (1 << slot::MA);

/// The extra pass values of one camera sample, by [`slot`].
#[derive(Clone, Copy, Debug)]
pub struct Aov(pub [f32; slot::COUNT]);

impl Default for Aov {
    fn default() -> Self {
        // Mist of a sample that hits nothing is 1 (Cycles' 1 − 0).
        let mut a = [0.0; slot::COUNT];
        a[slot::MIST] = 1.0;
        Aov(a)
    }
}

impl Aov {
    /// Adds an RGB value to the three slots from `at`.
    #[inline]
    pub fn add3(&mut self, at: usize, v: glam::Vec3) {
        self.0[at] += v.x;
        self.0[at + 1] += v.y;
        self.0[at + 2] += v.z;
    }

    /// Sets three slots from `at`.
    #[inline]
    pub fn set3(&mut self, at: usize, v: glam::Vec3) {
        self.0[at..at + 3].copy_from_slice(&v.to_array());
    }
}

impl Pass {
    /// Blender's pass name (the EXR channel prefix `RenderLayer.load_from_file` reads).
    pub fn name(self) -> &'static str {
        match self {
            Pass::Depth => "Depth",
            Pass::Normal => "Normal",
            Pass::DenoisingAlbedo => "Denoising Albedo",
            Pass::DenoisingNormal => "Denoising Normal",
            Pass::SampleCount => "Debug Sample Count",
            Pass::DiffuseDirect => "Diffuse Direct",
            Pass::DiffuseIndirect => "Diffuse Indirect",
            Pass::DiffuseColor => "Diffuse Color",
            Pass::GlossyDirect => "Glossy Direct",
            Pass::GlossyIndirect => "Glossy Indirect",
            Pass::GlossyColor => "Glossy Color",
            Pass::TransmissionDirect => "Transmission Direct",
            Pass::TransmissionIndirect => "Transmission Indirect",
            Pass::TransmissionColor => "Transmission Color",
            Pass::VolumeDirect => "Volume Direct",
            Pass::VolumeIndirect => "Volume Indirect",
            Pass::Emission => "Emission",
            Pass::Environment => "Environment",
            Pass::AmbientOcclusion => "Ambient Occlusion",
            Pass::Mist => "Mist",
            Pass::Position => "Position",
            Pass::Uv => "UV",
            Pass::ObjectIndex => "Object Index",
            Pass::MaterialIndex => "Material Index",
            Pass::CryptoObject => "CryptoObject",
            Pass::CryptoMaterial => "CryptoMaterial",
            Pass::CryptoAsset => "CryptoAsset",
            Pass::ShadowCatcher => "Shadow Catcher",
            Pass::Vector => "Vector",
        }
    }

    /// The short name used by `--passes`: Blender's view-layer property without
    /// `use_pass_` (`diffuse_direct`, `emit`, `z`, ...), or Cycles' for its own passes.
    pub fn token(self) -> &'static str {
        match self {
            Pass::Depth => "z",
            Pass::Normal => "normal",
            Pass::DenoisingAlbedo => "denoising_albedo",
            Pass::DenoisingNormal => "denoising_normal",
            Pass::SampleCount => "sample_count",
            Pass::DiffuseDirect => "diffuse_direct",
            Pass::DiffuseIndirect => "diffuse_indirect",
            Pass::DiffuseColor => "diffuse_color",
            Pass::GlossyDirect => "glossy_direct",
            Pass::GlossyIndirect => "glossy_indirect",
            Pass::GlossyColor => "glossy_color",
            Pass::TransmissionDirect => "transmission_direct",
            Pass::TransmissionIndirect => "transmission_indirect",
            Pass::TransmissionColor => "transmission_color",
            Pass::VolumeDirect => "volume_direct",
            Pass::VolumeIndirect => "volume_indirect",
            Pass::Emission => "emit",
            Pass::Environment => "environment",
            Pass::AmbientOcclusion => "ambient_occlusion",
            Pass::Mist => "mist",
            Pass::Position => "position",
            Pass::Uv => "uv",
            Pass::ObjectIndex => "object_index",
            Pass::MaterialIndex => "material_index",
            Pass::CryptoObject => "cryptomatte_object",
            Pass::CryptoMaterial => "cryptomatte_material",
            Pass::CryptoAsset => "cryptomatte_asset",
            Pass::ShadowCatcher => "shadow_catcher",
            Pass::Vector => "vector",
        }
    }

    /// Channel names, as Blender's render result has them.
    pub fn channels(self) -> &'static [&'static str] {
        match self {
            Pass::Depth | Pass::Mist => &["Z"],
            Pass::SampleCount | Pass::ObjectIndex | Pass::MaterialIndex => &["X"],
            Pass::Normal | Pass::DenoisingNormal | Pass::Position => &["X", "Y", "Z"],
            Pass::Uv => &["U", "V", "A"],
            // Lower case as Cycles names them (OpenEXR's DWA compression keeps r g b a lossless).
            Pass::CryptoObject | Pass::CryptoMaterial | Pass::CryptoAsset => &["r", "g", "b", "a"],
            Pass::Vector => &["X", "Y", "Z", "W"],
            _ => &["R", "G", "B"],
        }
    }

    /// First [`slot`] of an extra pass (None: the pass lives in the film's base sums).
    pub fn slot(self) -> Option<usize> {
        Some(match self {
            Pass::Depth
            | Pass::Normal
            | Pass::DenoisingAlbedo
            | Pass::DenoisingNormal
            | Pass::SampleCount
            | Pass::CryptoObject
            | Pass::CryptoMaterial
            | Pass::CryptoAsset => {
                return None;
            }
            Pass::DiffuseDirect => slot::DIFF_DIR,
            Pass::DiffuseIndirect => slot::DIFF_IND,
            Pass::DiffuseColor => slot::DIFF_COL,
            Pass::GlossyDirect => slot::GLOSS_DIR,
            Pass::GlossyIndirect => slot::GLOSS_IND,
            Pass::GlossyColor => slot::GLOSS_COL,
            Pass::TransmissionDirect => slot::TRANS_DIR,
            Pass::TransmissionIndirect => slot::TRANS_IND,
            Pass::TransmissionColor => slot::TRANS_COL,
            Pass::VolumeDirect => slot::VOL_DIR,
            Pass::VolumeIndirect => slot::VOL_IND,
            Pass::Emission => slot::EMIT,
            Pass::Environment => slot::ENV,
            Pass::AmbientOcclusion => slot::AO,
            Pass::Mist => slot::MIST,
            Pass::Position => slot::POS,
            Pass::Uv => slot::UV,
            Pass::ObjectIndex => slot::OB,
            Pass::MaterialIndex => slot::MA,
            Pass::ShadowCatcher => slot::CATCHER_PASS,
            Pass::Vector => slot::VECTOR,
        })
    }

    /// Slots the pass occupies (its channels; AO keeps one value for three channels).
    fn slot_count(self) -> usize {
        match self {
            Pass::AmbientOcclusion => 1,
            p => p.channels().len(),
        }
    }

    /// The Colour pass a Direct or Indirect pass is divided by when it is read.
    pub fn divided_by(self) -> Option<Pass> {
        match self {
            Pass::DiffuseDirect | Pass::DiffuseIndirect => Some(Pass::DiffuseColor),
            Pass::GlossyDirect | Pass::GlossyIndirect => Some(Pass::GlossyColor),
            Pass::TransmissionDirect | Pass::TransmissionIndirect => Some(Pass::TransmissionColor),
            _ => None,
        }
    }

    /// A light pass: the path tracer must classify its contributions.
    pub fn is_light(self) -> bool {
        matches!(
            self,
            Pass::DiffuseDirect
                | Pass::DiffuseIndirect
                | Pass::DiffuseColor
                | Pass::GlossyDirect
                | Pass::GlossyIndirect
                | Pass::GlossyColor
                | Pass::TransmissionDirect
                | Pass::TransmissionIndirect
                | Pass::TransmissionColor
                | Pass::VolumeDirect
                | Pass::VolumeIndirect
                | Pass::Emission
                | Pass::Environment
        )
    }

    /// The Cryptomatte layer of a Cryptomatte pass.
    pub fn crypto_kind(self) -> Option<Kind> {
        match self {
            Pass::CryptoObject => Some(Kind::Object),
            Pass::CryptoMaterial => Some(Kind::Material),
            Pass::CryptoAsset => Some(Kind::Asset),
            _ => None,
        }
    }

    /// Reads a pass from its token or its Blender name (case and `_`/space insensitive).
    pub fn parse(s: &str) -> Option<Pass> {
        let norm = |x: &str| x.trim().to_ascii_lowercase().replace(' ', "_");
        let want = norm(s);
        ALL.into_iter().find(|p| norm(p.token()) == want || norm(p.name()) == want)
    }
}

/// A set of passes (bit i = `ALL[i]`; the top bit: keep the shadow catcher's sums; the
/// next: the light groups), Cryptomatte's levels and the number of light groups.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct PassSet {
    bits: u32,
    /// Blender's Cryptomatte levels (0: Blender's default).
    crypto_levels: u32,
    /// Light groups of the scene written as `Combined_<name>` (when asked).
    light_groups: u8,
    /// Channels of the view layer's shader AOVs (`crate::scene::shader_aovs`; when asked).
    #[serde(default)]
    shader_aovs: u8,
    /// Keep Cryptomatte's slots for an exact merge of chunks (`Layout::with_exact`).
    #[serde(default)]
    crypto_exact: bool,
}

/// The [`PassSet`] bit that keeps the shadow catcher's sums (no pass of its own).
const CATCHER_SUMS: u32 = 1 << 31;
/// The [`PassSet`] bit that asks for the scene's light groups (`--passes light_groups`).
const LIGHT_GROUPS: u32 = 1 << 30;
/// The [`PassSet`] bit that asks for the view layer's shader AOVs (`--passes shader_aovs`).
const SHADER_AOVS: u32 = 1 << 29;
// Bits 0..ALL.len() are the passes; 29, 30 and 31 the flags above.
const _: () = assert!(ALL.len() <= 29);

/// The `--passes` token that asks for the view layer's shader AOVs (AOV Output nodes), one
/// pass each as the scene's render settings list them (`crate::scene::shader_aovs`).
pub const SHADER_AOVS_TOKEN: &str = "shader_aovs";

/// The `--passes` token that asks for one `Combined_<group>` pass per light group of the
/// scene (`crate::scene::light_groups`).
pub const LIGHT_GROUPS_TOKEN: &str = "light_groups";

/// The slots of the shadow catcher's sums.
pub const CATCHER_SLOTS: u64 = ((1u64 << (slot::COUNT - slot::CATCHER_PASS)) - 1) << slot::CATCHER_PASS;

impl PassSet {
    /// This set, keeping the shadow catcher's sums too (a scene with catchers, rendered by
    /// an integrator that splits at them): the film then gives Combined as Cycles does.
    pub fn with_catcher_sums(self) -> Self {
        PassSet { bits: self.bits | CATCHER_SUMS, ..self }
    }

    /// True when the shadow catcher's sums are kept.
    pub fn catcher_sums(self) -> bool {
        self.bits & CATCHER_SUMS != 0
    }

    /// True when the light groups were asked for (`--passes light_groups`).
    pub fn asks_light_groups(self) -> bool {
        self.bits & LIGHT_GROUPS != 0
    }

    /// Sets how many light groups the scene has (written only when asked).
    pub fn set_light_groups(&mut self, count: usize) {
        self.light_groups = count.min(crate::scene::light_groups::MAX) as u8;
    }

    /// The light groups to write: the scene's count when asked, else 0.
    #[inline]
    pub fn light_groups(self) -> usize {
        if self.asks_light_groups() { self.light_groups as usize } else { 0 }
    }

    /// True when the shader AOVs were asked for (`--passes shader_aovs`).
    pub fn asks_shader_aovs(self) -> bool {
        self.bits & SHADER_AOVS != 0
    }

    /// Sets how many channels the scene's shader AOVs take (written only when asked).
    pub fn set_shader_aov_channels(&mut self, channels: usize) {
        self.shader_aovs = channels.min(crate::scene::shader_aovs::MAX_CHANNELS) as u8;
    }

    /// The shader AOV channels to keep: the scene's count when asked, else 0.
    #[inline]
    pub fn shader_aov_channels(self) -> usize {
        if self.asks_shader_aovs() { self.shader_aovs as usize } else { 0 }
    }

    /// What a render writes without `--passes`: the passes of Caustic before pass
    /// selection (Combined, Depth, Normal, the two denoising passes and the sample count).
    pub fn legacy() -> Self {
        [Pass::Depth, Pass::Normal, Pass::DenoisingAlbedo, Pass::DenoisingNormal, Pass::SampleCount]
            .into_iter()
            .collect()
    }

    /// True when `p` is in the set.
    #[inline]
    pub fn contains(self, p: Pass) -> bool {
        self.bits & (1 << index(p)) != 0
    }

    /// Adds a pass.
    pub fn insert(&mut self, p: Pass) {
        self.bits |= 1 << index(p);
    }

    /// The passes, in [`ALL`]'s order.
    pub fn iter(self) -> impl Iterator<Item = Pass> {
        ALL.into_iter().filter(move |p| self.contains(*p))
    }

    /// Any light pass asked (the path tracer classifies contributions only then).
    pub fn any_light(self) -> bool {
        self.iter().any(Pass::is_light)
    }

    /// Any data pass the camera ray's first hit gives (AO, Mist, Position, UV, indices,
    /// Cryptomatte).
    pub fn any_data(self) -> bool {
        self.iter()
            .any(|p| (p.slot().is_some() && !p.is_light() && p != Pass::ShadowCatcher) || p.crypto_kind().is_some())
    }

    /// Any Cryptomatte layer asked.
    #[inline]
    pub fn any_crypto(self) -> bool {
        [Pass::CryptoObject, Pass::CryptoMaterial, Pass::CryptoAsset].into_iter().any(|p| self.contains(p))
    }

    /// Sets Blender's Cryptomatte levels (2..=16; checked by [`PassSet::cryptomatte`]).
    pub fn set_cryptomatte_levels(&mut self, levels: u32) {
        self.crypto_levels = levels;
    }

    /// Keeps Cryptomatte's slots as chunks need them (`render --chunk`).
    pub fn set_cryptomatte_exact(&mut self) {
        self.crypto_exact = true;
    }

    /// The Cryptomatte layers asked for and their slots per pixel.
    pub fn cryptomatte(self) -> Result<Layout> {
        let kinds: Vec<Kind> = self.iter().filter_map(Pass::crypto_kind).collect();
        let levels = if self.crypto_levels == 0 { crate::cryptomatte::DEFAULT_LEVELS } else { self.crypto_levels };
        let layout = Layout::new(&kinds, levels)?;
        Ok(if self.crypto_exact { layout.with_exact() } else { layout })
    }

    /// The slots a film must keep for these passes: each pass's own, and the Colour
    /// pass's for a Direct or Indirect pass, which is divided by it.
    pub fn slots(self) -> u64 {
        // The Shadow Catcher pass is computed from the catcher's sums.
        let mut mask = if self.catcher_sums() || self.contains(Pass::ShadowCatcher) { CATCHER_SLOTS } else { 0 };
        for p in self.iter() {
            for q in [Some(p), p.divided_by()].into_iter().flatten() {
                if let Some(s) = q.slot() {
                    mask |= ((1u64 << q.slot_count()) - 1) << s;
                }
            }
        }
        mask
    }

    /// RGB triples a light-tracing splat carries per pixel besides Combined: the asked
    /// light passes' ([`SPLAT_SLOTS`], in slot order), then one per light group.
    pub fn splat_triples(self) -> usize {
        (self.slots() & SPLAT_SLOTS).count_ones() as usize / 3 + self.light_groups()
    }

    /// Reads a comma-separated list of tokens or Blender names; "combined" is accepted
    /// (always written) and "none" or an empty list asks for Combined alone.
    pub fn parse_list(list: &str) -> Result<PassSet> {
        let mut set = PassSet::default();
        for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            if item.eq_ignore_ascii_case("combined") || item.eq_ignore_ascii_case("none") {
                continue;
            }
            if item.eq_ignore_ascii_case(LIGHT_GROUPS_TOKEN) {
                set.bits |= LIGHT_GROUPS;
                continue;
            }
            if item.eq_ignore_ascii_case(SHADER_AOVS_TOKEN) {
                set.bits |= SHADER_AOVS;
                continue;
            }
            set.insert(Pass::parse(item).ok_or_else(|| {
                Error::Usage(format!(
                    "unknown pass '{item}' (known: combined, {}, {LIGHT_GROUPS_TOKEN}, {SHADER_AOVS_TOKEN})",
                    ALL.iter().map(|p| p.token()).collect::<Vec<_>>().join(", ")
                ))
            })?);
        }
        Ok(set)
    }
}

impl FromIterator<Pass> for PassSet {
    fn from_iter<I: IntoIterator<Item = Pass>>(it: I) -> Self {
        let mut s = PassSet::default();
        for p in it {
            s.insert(p);
        }
        s
    }
}

/// Bit of pass `p` in a [`PassSet`]: its place in [`ALL`], which lists the variants in
/// declaration order (a unit test checks it).
#[inline]
fn index(p: Pass) -> usize {
    p as usize
}

/// a / b per channel; where b is zero in a channel the ratio of the other channels is
/// taken, so a colour pass with a zero channel still gives a grey quotient (Cycles'
/// `safe_divide_even_color`, which its film applies to Direct and Indirect passes).
pub fn divide_even_color(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    let q = |i: usize| if b[i] != 0.0 { a[i] / b[i] } else { 0.0 };
    let (mut x, mut y, mut z) = (q(0), q(1), q(2));
    let zero = [b[0] == 0.0, b[1] == 0.0, b[2] == 0.0];
    match zero {
        [true, true, _] => (x, y) = (z, z),
        [true, false, true] => (x, z) = (y, y),
        [true, false, false] => x = 0.5 * (y + z),
        [false, true, true] => (y, z) = (x, x),
        [false, true, false] => y = 0.5 * (x + z),
        [false, false, true] => z = 0.5 * (x + y),
        [false, false, false] => {}
    }
    [x, y, z]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_is_in_declaration_order() {
        for (i, p) in ALL.into_iter().enumerate() {
            assert_eq!(index(p), i, "{p:?}");
        }
    }

    #[test]
    fn names_and_tokens_parse_back() {
        for p in ALL {
            assert_eq!(Pass::parse(p.token()), Some(p));
            assert_eq!(Pass::parse(p.name()), Some(p));
        }
        let set = PassSet::parse_list("Combined, diffuse_direct,Emission").unwrap();
        assert_eq!(set.iter().collect::<Vec<_>>(), vec![Pass::DiffuseDirect, Pass::Emission]);
        assert!(PassSet::parse_list("diffuse_directt").unwrap_err().to_string().contains("unknown pass"));
        let mut set = PassSet::parse_list("light_groups").unwrap();
        assert_eq!((set.iter().count(), set.light_groups()), (0, 0));
        set.set_light_groups(3);
        assert_eq!(set.light_groups(), 3);
        let mut unasked = PassSet::default();
        unasked.set_light_groups(3);
        unasked.set_shader_aov_channels(5);
        assert_eq!((unasked.light_groups(), unasked.shader_aov_channels()), (0, 0));
        let mut aovs = PassSet::parse_list("shader_aovs").unwrap();
        aovs.set_shader_aov_channels(5);
        assert_eq!((aovs.iter().count(), aovs.shader_aov_channels()), (0, 5));
    }

    #[test]
    fn direct_passes_keep_their_colour() {
        let set = PassSet::parse_list("glossy_direct").unwrap();
        assert_eq!(set.slots(), (0b111 << slot::GLOSS_DIR) | (0b111 << slot::GLOSS_COL));
        assert_eq!(PassSet::parse_list("ambient_occlusion").unwrap().slots(), 1 << slot::AO);
    }

    #[test]
    fn even_colour_division() {
        assert_eq!(divide_even_color([2.0, 4.0, 6.0], [1.0, 2.0, 3.0]), [2.0, 2.0, 2.0]);
        assert_eq!(divide_even_color([2.0, 4.0, 0.0], [1.0, 1.0, 0.0]), [2.0, 4.0, 3.0]);
        assert_eq!(divide_even_color([0.0, 0.0, 5.0], [0.0, 0.0, 2.0]), [2.5, 2.5, 2.5]);
        assert_eq!(divide_even_color([1.0, 1.0, 1.0], [0.0, 0.0, 0.0]), [0.0, 0.0, 0.0]);
    }
}

/// Blender's mist and AO settings (World panel), with Blender's defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DataSettings {
    /// Mist start (scene units).
    pub mist_start: f32,
    /// Mist depth: distance over which mist goes from 0 to 1.
    pub mist_depth: f32,
    /// Mist falloff exponent (Blender's Quadratic 2, Linear 1, Inverse Quadratic 0.5).
    pub mist_falloff: f32,
    /// AO ray length.
    pub ao_distance: f32,
}

impl Default for DataSettings {
    /// Blender 5.0's defaults: mist start 5, depth 25, quadratic; AO distance 10.
    fn default() -> Self {
        DataSettings { mist_start: 5.0, mist_depth: 25.0, mist_falloff: 2.0, ao_distance: 10.0 }
    }
}

impl DataSettings {
    /// The scene's settings over the defaults, checked.
    pub fn resolve(mist: Option<[f32; 3]>, ao_distance: Option<f32>) -> Result<Self> {
        let mut d = DataSettings::default();
        if let Some([start, depth, falloff]) = mist {
            if !(start.is_finite() && depth.is_finite() && depth >= 0.0 && falloff.is_finite() && falloff > 0.0) {
                return Err(Error::Usage(format!(
                    "the scene's mist [{start}, {depth}, {falloff}] needs a finite start, depth ≥ 0 and falloff > 0"
                )));
            }
            (d.mist_start, d.mist_depth, d.mist_falloff) = (start, depth, falloff);
        }
        if let Some(a) = ao_distance {
            if !(a.is_finite() && a >= 0.0) {
                return Err(Error::Usage(format!("the scene's ao_distance {a} must be a distance ≥ 0")));
            }
            d.ao_distance = a;
        }
        Ok(d)
    }

    /// Mist at camera distance `dist`: clamp((dist − start) / depth, 0, 1) ^ falloff.
    pub fn mist(&self, dist: f32) -> f32 {
        let m = if self.mist_depth > 0.0 {
            ((dist - self.mist_start) / self.mist_depth).clamp(0.0, 1.0)
        } else if dist >= self.mist_start {
            1.0
        } else {
            0.0
        };
        m.powf(self.mist_falloff)
    }
}
