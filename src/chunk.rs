//! Chunk files: a render's raw fixed-point sums inside its EXR, so that renders of
//! disjoint sample ranges of one frame (`--sample-offset`, on any machine) merge into
//! exactly the image a single render of all the samples gives.
//!
//! A chunk is an ordinary output EXR (Blender reads it as usual) with two additions,
//! written only with `render --chunk` or `merge --chunk`:
//! * the attribute `causticChunk`: a JSON [`ChunkInfo`] (what must agree between the chunks
//!   of one frame, and the sample ranges and light paths this chunk holds);
//! * UINT channels `CausticSum.<Q>.<k>` holding each fixed-point sum Q (see
//!   `crate::fixed`) as four little-endian 32-bit words k = 0..3, `CausticSum.N` the
//!   samples per pixel and a FLOAT channel `CausticSum.Depth` with the nearest depth
//!   (infinite where nothing was hit), so that the merge never reads the rounded means;
//!   the extra passes' sums likewise, `CausticSum.S<slot>.<k>` for each [`slot`] the
//!   passes keep (the first-sample slots hold their f32 bits) and `CausticSum.L<g><c>.<k>`
//!   for channel c of light group g, `CausticSum.V<c>.<k>` for shader AOV channel c.
//!   Cryptomatte's kept slots (`crate::cryptomatte`: a chunk keeps each pixel's
//!   first-seen ids with their exact counts) as `CausticSum.C<layer><slot>.id` and `.n`
//!   (layer: Object, Material, Asset), so that merged chunks rank as one render does.
//!   Light-tracing splats' light passes and light groups (`Film::splat_extra`, bidirectional
//!   integrators only) as `CausticSum.X<j>.<k>` for its j-th value of a pixel.
//!
//! [`slot`]: crate::passes::slot

use crate::error::{Error, Result};
use crate::film::{Film, FilmImage, PixelAccum};
use crate::fixed;
use crate::passes::PassSet;
use exr::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Version of the chunk layout; a merge refuses any other. 3: shader AOV sums (`V`) and
/// Cryptomatte's per-pixel id lists (`C`) joined layout 2, so a chunk of a build before
/// them cannot merge exactly with one after.
pub const CHUNK_VERSION: u32 = 3;

/// Name of the EXR attribute holding the [`ChunkInfo`] JSON.
pub const ATTRIBUTE: &str = "causticChunk";

/// The fixed-point sums of a pixel in channel order: radiance, alpha, normal, albedo,
/// light-tracing splats.
const QUANTITIES: [&str; 13] = ["R", "G", "B", "A", "NX", "NY", "NZ", "AR", "AG", "AB", "SR", "SG", "SB"];

/// What a chunk says about itself.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ChunkInfo {
    /// Layout version ([`CHUNK_VERSION`]).
    pub version: u32,
    /// FNV-1a of the scene file's bytes.
    pub scene_hash: u64,
    /// FNV-1a of every setting that changes the samples (resolution, camera, seed,
    /// integrator and its parameters, filter, ...), but not the sample range or threads.
    pub settings_hash: u64,
    /// Integrator name (for messages, and because SPPM chunks are merged as estimates).
    pub integrator: String,
    /// Full frame size.
    pub resolution: [u32; 2],
    /// Pixel window of the full frame held (x0, y0, x1, y1).
    pub window: [u32; 4],
    /// Seed.
    pub seed: u32,
    /// Film → Transparent (false: alpha is made 1 where samples were taken).
    pub transparent: bool,
    /// Sample index ranges [start, end) held (one per chunk merged in; a pixel may hold a
    /// prefix of a range when its render was interrupted).
    pub samples: Vec<[u32; 2]>,
    /// Light paths traced (the splat sums' denominator).
    pub light_paths: u64,
    /// The passes whose sums the chunk holds (part of the settings hash too).
    pub passes: PassSet,
    /// The light groups' names, in the order of their sums.
    pub light_groups: Vec<String>,
    /// The shader AOVs, in the order of their sums.
    #[serde(default)]
    pub shader_aovs: Vec<crate::scene::shader_aovs::AovSpec>,
    /// Samples whose Cryptomatte id a full pixel list counted under another id: 0 when the
    /// chunk's Cryptomatte merges exactly.
    #[serde(default)]
    pub crypto_folded: u64,
}

impl ChunkInfo {
    /// Checks that `other` belongs to the same frame and holds other samples; the error
    /// names both files.
    pub fn check_compatible(&self, other: &ChunkInfo, a: &Path, b: &Path) -> Result<()> {
        let what = |name: &str, x: String, y: String| {
            Error::Usage(format!("cannot merge {} and {}: their {name} differ ({x} vs {y})", a.display(), b.display()))
        };
        if self.scene_hash != other.scene_hash {
            return Err(what("scenes", format!("{:016x}", self.scene_hash), format!("{:016x}", other.scene_hash)));
        }
        if self.resolution != other.resolution || self.window != other.window {
            return Err(what(
                "sizes",
                format!("{:?} window {:?}", self.resolution, self.window),
                format!("{:?} window {:?}", other.resolution, other.window),
            ));
        }
        if self.seed != other.seed {
            return Err(what("seeds", self.seed.to_string(), other.seed.to_string()));
        }
        if self.integrator != other.integrator
            || self.settings_hash != other.settings_hash
            || self.transparent != other.transparent
            || self.passes != other.passes
            || self.light_groups != other.light_groups
            || self.shader_aovs != other.shader_aovs
        {
            return Err(what(
                "render settings",
                format!("{} {:016x}", self.integrator, self.settings_hash),
                format!("{} {:016x}", other.integrator, other.settings_hash),
            ));
        }
        Ok(())
    }
}

/// Sorts ranges and fails when two overlap (a sample would count twice).
pub fn check_disjoint(ranges: &mut [([u32; 2], &Path)]) -> Result<()> {
    ranges.sort_by_key(|(r, _)| *r);
    for w in ranges.windows(2) {
        let ((a, pa), (b, pb)) = (&w[0], &w[1]);
        if b[0] < a[1] {
            return Err(Error::Usage(format!(
                "cannot merge: samples {}..{} of {} overlap samples {}..{} of {}",
                a[0],
                a[1],
                pa.display(),
                b[0],
                b[1],
                pb.display()
            )));
        }
    }
    Ok(())
}

/// The chunk channels of `film` (see the module doc).
pub fn channels(film: &Film) -> Vec<AnyChannel<FlatSamples>> {
    let (w, h) = (film.width, film.height);
    let n = (w * h) as usize;
    let mut words: Vec<Vec<u32>> = vec![vec![0; n]; QUANTITIES.len() * 4];
    let mut count = vec![0u32; n];
    let mut depth = vec![f32::INFINITY; n];
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let p = film.pixel(x, y);
            let s = film.splat[i];
            let q = [
                p.rgb[0],
                p.rgb[1],
                p.rgb[2],
                p.alpha,
                p.normal[0],
                p.normal[1],
                p.normal[2],
                p.albedo[0],
                p.albedo[1],
                p.albedo[2],
                s[0],
                s[1],
                s[2],
            ];
            for (j, v) in q.iter().enumerate() {
                let u = *v as u128;
                for k in 0..4 {
                    words[j * 4 + k][i] = (u >> (32 * k)) as u32;
                }
            }
            count[i] = p.n;
            depth[i] = p.depth;
        }
    }
    let mut out = Vec::with_capacity(words.len() + 2);
    for (j, data) in words.into_iter().enumerate() {
        let name = format!("CausticSum.{}.{}", QUANTITIES[j / 4], j % 4);
        out.push(AnyChannel::new(name.as_str(), FlatSamples::U32(data)));
    }
    let names = extra_names(film.passes);
    let mut extra: Vec<Vec<u32>> = vec![vec![0; n]; names.len() * 4];
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let (slots, groups) = film.pixel_extra(x, y);
            for (j, v) in slots.iter().chain(groups).enumerate() {
                for (k, word) in extra[j * 4..j * 4 + 4].iter_mut().enumerate() {
                    word[i] = (*v as u128 >> (32 * k)) as u32;
                }
            }
        }
    }
    for (j, data) in extra.into_iter().enumerate() {
        let name = format!("CausticSum.{}.{}", names[j / 4], j % 4);
        out.push(AnyChannel::new(name.as_str(), FlatSamples::U32(data)));
    }
    // The splats' light passes and groups, when the render kept them.
    let per = film.splat_extra.len() / n.max(1) * 3;
    for j in 0..per {
        for k in 0..4 {
            let data = film.splat_extra.chunks_exact(per / 3).map(|px| (px[j / 3][j % 3] as u128 >> (32 * k)) as u32);
            let name = format!("CausticSum.X{j}.{k}");
            out.push(AnyChannel::new(name.as_str(), FlatSamples::U32(data.collect())));
        }
    }
    out.push(AnyChannel::new("CausticSum.N", FlatSamples::U32(count)));
    out.push(AnyChannel::new("CausticSum.Depth", FlatSamples::F32(depth)));
    let names = crypto_names(film);
    let mut crypto: Vec<Vec<u32>> = vec![vec![0; n]; names.len()];
    for t in &film.tiles {
        let stride = t.crypto_layout.stride();
        for ty in 0..t.h {
            for tx in 0..t.w {
                let (i, j) = (((t.y0 + ty) * w + t.x0 + tx) as usize, (ty * t.w + tx) as usize);
                for (k, slot) in t.crypto[j * stride..(j + 1) * stride].iter().enumerate() {
                    crypto[2 * k][i] = slot.id;
                    crypto[2 * k + 1][i] = slot.count;
                }
            }
        }
    }
    for (name, data) in names.iter().zip(crypto) {
        out.push(AnyChannel::new(name.as_str(), FlatSamples::U32(data)));
    }
    out
}

/// The Cryptomatte channels of `film` in the order of its kept slots: id and count of each.
fn crypto_names(film: &Film) -> Vec<String> {
    let layout = film.tiles.first().map(|t| t.crypto_layout).unwrap_or_default();
    let mut names = Vec::new();
    for kind in layout.iter() {
        for j in 0..layout.kept() {
            let layer = &kind.name()[6..]; // "CryptoObject" → "Object"
            names.push(format!("CausticSum.C{layer}{j}.id"));
            names.push(format!("CausticSum.C{layer}{j}.n"));
        }
    }
    names
}

/// The names of the extra sums of `passes` in the film's order: each kept slot, then each
/// light group's three channels, then each shader AOV channel.
fn extra_names(passes: PassSet) -> Vec<String> {
    let slots = passes.slots();
    let mut names: Vec<String> = (0..64).filter(|k| slots >> k & 1 == 1).map(|k| format!("S{k}")).collect();
    for g in 0..passes.light_groups() {
        names.extend(["R", "G", "B"].map(|c| format!("L{g}{c}")));
    }
    names.extend((0..passes.shader_aov_channels()).map(|c| format!("V{c}")));
    names
}

/// The info as the EXR attribute value.
pub fn attribute(info: &ChunkInfo) -> (Text, AttributeValue) {
    let json = serde_json::to_string(info).unwrap_or_default();
    (Text::from(ATTRIBUTE), AttributeValue::Text(Text::from_slice_unchecked(json.as_bytes())))
}

/// A chunk read back: its info and its sums as a film (one tile).
pub struct Chunk {
    /// What the chunk says about itself.
    pub info: ChunkInfo,
    /// The sums.
    pub film: Film,
    /// The header's Cryptomatte attributes (`cryptomatte/...`: the manifests), for the merge
    /// to write again.
    pub metadata: Vec<(String, String)>,
}

/// Reads a chunk's [`ChunkInfo`] from its header alone (the pixels are not read).
pub fn read_info(path: &Path) -> Result<ChunkInfo> {
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| Error::io(path, format!("not a readable OpenEXR file: {e}")))?;
    let not_chunk = |why: &str| {
        Error::Usage(format!("{} is not a Caustic chunk ({why}); render chunks with --chunk", path.display()))
    };
    let header = meta.headers.first().ok_or_else(|| not_chunk("no layer"))?;
    let text = header
        .own_attributes
        .other
        .get(&Text::from(ATTRIBUTE))
        .and_then(|v| if let AttributeValue::Text(t) = v { Some(t.bytes().to_vec()) } else { None })
        .ok_or_else(|| not_chunk("no causticChunk attribute"))?;
    serde_json::from_slice(&text).map_err(|e| not_chunk(&format!("unreadable causticChunk: {e}")))
}

/// Reads a chunk; a file that is not an EXR, is cut short or has no chunk data is an error
/// naming it (I/O for an unreadable file, usage for an EXR that is not a chunk).
pub fn read(path: &Path) -> Result<Chunk> {
    let image = read_all_flat_layers_from_file(path)
        .map_err(|e| Error::io(path, format!("not a readable OpenEXR file: {e}")))?;
    let not_chunk = |why: &str| {
        Error::Usage(format!("{} is not a Caustic chunk ({why}); render chunks with --chunk", path.display()))
    };
    let layer = image.layer_data.first().ok_or_else(|| not_chunk("no layer"))?;
    let info = layer
        .attributes
        .other
        .get(&Text::from(ATTRIBUTE))
        .and_then(|v| if let AttributeValue::Text(t) = v { Some(t.bytes().to_vec()) } else { None })
        .ok_or_else(|| not_chunk("no causticChunk attribute"))?;
    let info: ChunkInfo =
        serde_json::from_slice(&info).map_err(|e| not_chunk(&format!("unreadable causticChunk: {e}")))?;
    if info.version != CHUNK_VERSION {
        return Err(not_chunk(&format!("layout version {}, this build reads {CHUNK_VERSION}", info.version)));
    }
    let [x0, y0, x1, y1] = info.window;
    let (w, h) = (x1.saturating_sub(x0), y1.saturating_sub(y0));
    if (layer.size.width(), layer.size.height()) != (w as usize, h as usize) {
        return Err(not_chunk("the image size is not the window's"));
    }
    let find = |name: &str| layer.channel_data.list.iter().find(|c| c.name.to_string() == name);
    let u32s = |name: &str| -> Result<&Vec<u32>> {
        match find(name).map(|c| &c.sample_data) {
            Some(FlatSamples::U32(v)) => Ok(v),
            _ => Err(not_chunk(&format!("no UINT channel {name}"))),
        }
    };
    let mut words = Vec::with_capacity(QUANTITIES.len() * 4);
    for q in QUANTITIES {
        for k in 0..4 {
            words.push(u32s(&format!("CausticSum.{q}.{k}"))?);
        }
    }
    let count = u32s("CausticSum.N")?;
    let depth = match find("CausticSum.Depth").map(|c| &c.sample_data) {
        Some(FlatSamples::F32(v)) => v,
        _ => return Err(not_chunk("no FLOAT channel CausticSum.Depth")),
    };
    let aov_channels: usize = info.shader_aovs.iter().map(|a| a.kind.channels().len()).sum();
    if (info.passes.any_crypto() && !info.passes.cryptomatte().is_ok_and(|l| l.exact))
        || info.light_groups.len() != info.passes.light_groups()
        || aov_channels != info.passes.shader_aov_channels()
    {
        return Err(not_chunk("its passes are not ones chunks carry"));
    }
    let names = extra_names(info.passes);
    let mut extra = Vec::with_capacity(names.len() * 4);
    for q in &names {
        for k in 0..4 {
            extra.push(u32s(&format!("CausticSum.{q}.{k}"))?);
        }
    }
    let mut film = Film::with_passes(w, h, crate::render::job::TILE_SIZE, info.passes);
    film.light_paths = info.light_paths;
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let q: Vec<i128> = (0..QUANTITIES.len())
                .map(|j| (0..4).fold(0u128, |a, k| a | (words[j * 4 + k][i] as u128) << (32 * k)) as i128)
                .collect();
            *film.pixel_mut(x, y) = PixelAccum {
                rgb: [q[0], q[1], q[2]],
                alpha: q[3],
                depth: depth[i],
                normal: [q[4], q[5], q[6]],
                albedo: [q[7], q[8], q[9]],
                n: count[i],
            };
            film.splat[i] = [q[10], q[11], q[12]];
            let (slots, groups) = film.pixel_extra_mut(x, y);
            for (j, v) in slots.iter_mut().chain(groups).enumerate() {
                *v = (0..4).fold(0u128, |a, k| a | (extra[j * 4 + k][i] as u128) << (32 * k)) as i128;
            }
        }
    }
    if find("CausticSum.X0.0").is_some() {
        let per = 3 * info.passes.splat_triples();
        let mut words = Vec::with_capacity(per * 4);
        for j in 0..per {
            for k in 0..4 {
                words.push(u32s(&format!("CausticSum.X{j}.{k}"))?);
            }
        }
        film.splat_extra = (0..(w * h) as usize)
            .flat_map(|i| {
                let value = |j: usize| (0..4).fold(0u128, |a, k| a | (words[j * 4 + k][i] as u128) << (32 * k)) as i128;
                (0..per / 3).map(move |t| [value(3 * t), value(3 * t + 1), value(3 * t + 2)]).collect::<Vec<_>>()
            })
            .collect();
    }
    let names = crypto_names(&film);
    let crypto = names.iter().map(|n| u32s(n)).collect::<Result<Vec<_>>>()?;
    for t in &mut film.tiles {
        let stride = t.crypto_layout.stride();
        for ty in 0..t.h {
            for tx in 0..t.w {
                let (i, j) = (((t.y0 + ty) * w + t.x0 + tx) as usize, (ty * t.w + tx) as usize);
                for (k, slot) in t.crypto[j * stride..(j + 1) * stride].iter_mut().enumerate() {
                    *slot = crate::cryptomatte::Slot { id: crypto[2 * k][i], count: crypto[2 * k + 1][i] };
                }
            }
        }
    }
    let metadata = layer
        .attributes
        .other
        .iter()
        .filter(|(k, _)| k.to_string().starts_with("cryptomatte/"))
        .filter_map(|(k, v)| match v {
            AttributeValue::Text(t) => Some((k.to_string(), String::from_utf8_lossy(t.bytes()).into_owned())),
            _ => None,
        })
        .collect();
    Ok(Chunk { info, film, metadata })
}

/// A film holding `img`'s means times its sample counts, for integrators that keep no
/// sums (SPPM without extra passes: its chunks are independent estimates, merged weighted by
/// iterations).
pub fn film_from_image(img: &FilmImage) -> Film {
    let mut film = Film::new(img.width, img.height, crate::render::job::TILE_SIZE);
    set_means(&mut film, img);
    film
}

/// A mean over `n` samples as the fixed-point sum those samples would have given: exact,
/// since the f32 mean (24-bit mantissa) × n (≤ 2^24) fits f64's 53 bits and × 2^64 is a
/// power of two; an image's value read back from it (`Film::image`) is the mean again.
pub fn mean_times(v: f32, n: u32) -> i128 {
    ((v as f64) * (n as f64) * fixed::SCALE) as i128
}

/// Sets `film`'s base sums (Combined, alpha, normal, albedo, depth, sample count) to `img`'s
/// means times its sample counts; its extra sums are left as they are.
pub fn set_means(film: &mut Film, img: &FilmImage) {
    for y in 0..img.height {
        for x in 0..img.width {
            let i = (y * img.width + x) as usize;
            let n = img.samples[i];
            let c = img.combined[i];
            *film.pixel_mut(x, y) = PixelAccum {
                rgb: [mean_times(c[0], n), mean_times(c[1], n), mean_times(c[2], n)],
                alpha: mean_times(c[3], n),
                depth: img.depth[i],
                normal: img.normal[i].map(|v| mean_times(v, n)),
                albedo: img.albedo[i].map(|v| mean_times(v, n)),
                n,
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overlapping_ranges_are_refused() {
        let (a, b) = (Path::new("a.exr"), Path::new("b.exr"));
        assert!(check_disjoint(&mut [([3, 8], a), ([0, 3], b)]).is_ok());
        let err = check_disjoint(&mut [([0, 4], a), ([3, 8], b)]).unwrap_err().to_string();
        assert!(err.contains("overlap"), "{err}");
    }
}
