//! Writing images: OpenEXR with Blender's pass names, replaced atomically.
//!
//! Channels are named `<Pass>.<Channel>` (`Combined.R`, `Depth.Z`, `Normal.X`,
//! `Diffuse Direct.R`, `UV.U`, ...; `crate::passes` names them all) because Blender's
//! `RenderLayer.load_from_file` finds passes by these names; a plain R/G/B/A file
//! would load as silent black.

use crate::chunk::ChunkInfo;
use crate::error::{Error, Result};
use crate::film::{Film, FilmImage};
use crate::passes::Pass;
use exr::prelude::*;
use std::path::{Path, PathBuf};

/// The temporary file an output is written to before it is renamed into place.
pub fn temp_path(out: &Path) -> PathBuf {
    let name = out.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_else(|| "out.exr".into());
    out.with_file_name(format!(".{name}.caustic-tmp-{}", std::process::id()))
}

/// Removes temporary files that a killed earlier run left beside `out`. A temp file
/// whose process is still running (another render to the same output, on Linux, where
/// `/proc/PID` tells) is left alone.
pub fn clean_stale_temps(out: &Path) {
    let Some(name) = out.file_name().map(|n| n.to_string_lossy().to_string()) else {
        return;
    };
    let dir = match out.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let prefix = format!(".{name}.caustic-tmp-");
    if let Ok(entries) = std::fs::read_dir(&dir) {
        for e in entries.flatten() {
            let file_name = e.file_name().to_string_lossy().to_string();
            let Some(pid) = file_name.strip_prefix(&prefix) else { continue };
            let alive = pid
                .parse::<u32>()
                .is_ok_and(|p| p != std::process::id() && Path::new("/proc").join(p.to_string()).is_dir());
            if !alive {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
}

/// Fails early, before rendering, when the output cannot be written.
pub fn check_writable(out: &Path) -> Result<()> {
    if out.is_dir() {
        return Err(Error::io(out, "is a directory"));
    }
    let tmp = temp_path(out);
    std::fs::write(&tmp, b"").map_err(|e| Error::io(out, format!("cannot write here: {e}")))?;
    let _ = std::fs::remove_file(&tmp);
    Ok(())
}

/// Writes the image as a single-part EXR, float or half, through a temp file + rename.
pub fn write_exr(out: &Path, img: &FilmImage, half: bool) -> Result<()> {
    write_exr_with(out, img, half, None, None)
}

/// Writes the image as [`write_exr`] does with every channel named for Blender's view `view`
/// of a multi-view render (`Combined.left.R`): Blender's render result reads a view's passes
/// under those names.
pub fn write_exr_in_view(out: &Path, img: &FilmImage, half: bool, view: &str) -> Result<()> {
    write_exr_with(out, img, half, None, Some(view))
}

/// Writes the image as [`write_exr`] does, plus a chunk's sums and info (`crate::chunk`)
/// in the same file, so that the chunk is replaced atomically as a whole.
pub fn write_chunk(out: &Path, img: &FilmImage, half: bool, film: &Film, info: &ChunkInfo) -> Result<()> {
    write_exr_with(out, img, half, Some((film, info)), None)
}

fn write_exr_with(
    out: &Path,
    img: &FilmImage,
    half: bool,
    chunk: Option<(&Film, &ChunkInfo)>,
    view: Option<&str>,
) -> Result<()> {
    let (w, h) = (img.width as usize, img.height as usize);
    let make = |data: Vec<f32>| -> FlatSamples {
        if half { FlatSamples::F16(data.into_iter().map(f16::from_f32).collect()) } else { FlatSamples::F32(data) }
    };
    let col4 = |c: usize| img.combined.iter().map(|p| p[c]).collect::<Vec<f32>>();
    let col3 = |v: &Vec<[f32; 3]>, c: usize| v.iter().map(|p| p[c]).collect::<Vec<f32>>();
    let mut list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (i, ch) in ["R", "G", "B", "A"].iter().enumerate() {
        list.push(AnyChannel::new(format!("Combined.{ch}").as_str(), make(col4(i))));
    }
    // The Combined before denoising, under Cycles' name for it (`--denoise` only).
    if !img.noisy.is_empty() {
        for (i, ch) in ["R", "G", "B", "A"].iter().enumerate() {
            list.push(AnyChannel::new(
                format!("Noisy Image.{ch}").as_str(),
                make(img.noisy.iter().map(|p| p[i]).collect()),
            ));
        }
    }
    let passes = img.passes;
    if passes.contains(Pass::Depth) {
        // Depth stays float even in half mode: 1e10 does not fit in a half.
        list.push(AnyChannel::new("Depth.Z", FlatSamples::F32(img.depth.clone())));
    }
    for (i, ch) in ["X", "Y", "Z"].iter().enumerate() {
        for pass in [Pass::Normal, Pass::DenoisingNormal] {
            if passes.contains(pass) {
                list.push(AnyChannel::new(format!("{}.{ch}", pass.name()).as_str(), make(col3(&img.normal, i))));
            }
        }
    }
    if passes.contains(Pass::DenoisingAlbedo) {
        for (i, ch) in ["R", "G", "B"].iter().enumerate() {
            list.push(AnyChannel::new(format!("Denoising Albedo.{ch}").as_str(), make(col3(&img.albedo, i))));
        }
    }
    if passes.contains(Pass::SampleCount) {
        // Samples per pixel, as Cycles' Debug Sample Count pass; float (exact up to 2^24)
        // and float even in half mode, which is exact only up to 2048.
        list.push(AnyChannel::new(
            "Debug Sample Count.X",
            FlatSamples::F32(img.samples.iter().map(|&n| n as f32).collect()),
        ));
    }
    for (pass, data) in &img.extra {
        let names = pass.channels();
        for (c, ch) in names.iter().enumerate() {
            let values: Vec<f32> = data.iter().skip(c).step_by(names.len()).copied().collect();
            // Indices and positions keep full precision in half mode (an index above 2048
            // or a far position would round), as Depth does.
            let exact = matches!(pass, Pass::ObjectIndex | Pass::MaterialIndex | Pass::Position);
            let samples = if exact { FlatSamples::F32(values) } else { make(values) };
            list.push(AnyChannel::new(format!("{}.{ch}", pass.name()).as_str(), samples));
        }
    }
    if img.light_groups.len() != img.light_group_names.len() {
        return Err(Error::Internal(format!(
            "{} light group passes but {} names to write them under",
            img.light_groups.len(),
            img.light_group_names.len()
        )));
    }
    for (name, data) in img.light_group_names.iter().zip(&img.light_groups) {
        // Blender's and Cycles' name for a light group's pass.
        for (c, ch) in ["R", "G", "B"].iter().enumerate() {
            let values: Vec<f32> = data.iter().skip(c).step_by(3).copied().collect();
            list.push(AnyChannel::new(format!("Combined_{name}.{ch}").as_str(), make(values)));
        }
    }
    let aov_channels: usize = img.aov_specs.iter().map(|a| a.kind.channels().len()).sum();
    if aov_channels * (img.width * img.height) as usize != img.shader_aovs.len() {
        return Err(Error::Internal(format!(
            "{} shader AOV values per image but {aov_channels} channels to write them under",
            img.shader_aovs.len()
        )));
    }
    let mut at = 0;
    for aov in &img.aov_specs {
        // The AOV's own name, with Blender's channels for its kind (Cycles' passes).
        for ch in aov.kind.channels() {
            let values: Vec<f32> = img.shader_aovs.iter().skip(at).step_by(aov_channels).copied().collect();
            list.push(AnyChannel::new(format!("{}.{ch}", aov.name).as_str(), make(values)));
            at += 1;
        }
    }
    for (name, data) in &img.crypto {
        // Ids are float-encoded hashes: float even in half mode, where they would round.
        for (c, ch) in Pass::CryptoObject.channels().iter().enumerate() {
            let values: Vec<f32> = data.iter().skip(c).step_by(4).copied().collect();
            list.push(AnyChannel::new(format!("{name}.{ch}").as_str(), FlatSamples::F32(values)));
        }
    }
    let mut attributes = LayerAttributes::default();
    for (key, value) in &img.metadata {
        attributes
            .other
            .insert(Text::from(key.as_str()), AttributeValue::Text(Text::from_slice_unchecked(value.as_bytes())));
    }
    if let Some(view) = view {
        for channel in list.iter_mut() {
            channel.name = Text::from(in_view(&channel.name.to_string(), view).as_str());
        }
    }
    if let Some((film, info)) = chunk {
        list.extend(crate::chunk::channels(film));
        let (name, value) = crate::chunk::attribute(info);
        attributes.other.insert(name, value);
    }
    // Tiles in increasing order: the exr crate compresses tiles in parallel and, with the
    // default "unspecified" order, writes each as it is done, so the same image made files
    // with different bytes from run to run. Increasing order makes it write them in place.
    let encoding = Encoding { line_order: exr::meta::attribute::LineOrder::Increasing, ..Encoding::FAST_LOSSLESS };
    let layer = Layer::new((w, h), attributes, encoding, AnyChannels::sort(list));
    let image = Image::from_layer(layer);
    let mut bytes = Vec::new();
    image
        .write()
        .to_buffered(std::io::Cursor::new(&mut bytes))
        .map_err(|e| Error::io(out, format!("cannot encode EXR: {e}")))?;
    // Custom attributes come out in a per-process hash order (see `crate::exr_header`).
    crate::exr_header::sort_attributes(&mut bytes).map_err(Error::Internal)?;
    let tmp = temp_path(out);
    let result = std::fs::write(&tmp, &bytes);
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::io(out, format!("cannot write EXR: {e}")));
    }
    std::fs::rename(&tmp, out).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(out, format!("cannot move the finished file into place: {e}"))
    })
}

/// `<Pass>.<Channel>` as Blender names it in view `view`: `<Pass>.<view>.<Channel>`.
fn in_view(name: &str, view: &str) -> String {
    match name.rsplit_once('.') {
        Some((pass, channel)) => format!("{pass}.{view}.{channel}"),
        None => format!("{view}.{name}"),
    }
}

/// Reads back the Combined RGBA of an EXR written by [`write_exr`] (for tests and tools).
pub fn read_combined(path: &Path) -> Result<(usize, usize, Vec<[f32; 4]>)> {
    let image = read_all_flat_layers_from_file(path).map_err(|e| Error::io(path, e))?;
    let layer = image.layer_data.first().ok_or_else(|| Error::io(path, "no layer"))?;
    let (w, h) = (layer.size.width(), layer.size.height());
    let find = |name: &str| -> Result<Vec<f32>> {
        let ch = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
            .ok_or_else(|| Error::io(path, format!("no channel {name}")))?;
        Ok(ch.sample_data.values_as_f32().collect())
    };
    let (r, g, b, a) = (find("Combined.R")?, find("Combined.G")?, find("Combined.B")?, find("Combined.A")?);
    Ok((w, h, (0..w * h).map(|i| [r[i], g[i], b[i], a[i]]).collect()))
}
