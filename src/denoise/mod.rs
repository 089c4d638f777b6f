//! Denoising the final image with Intel Open Image Denoise (`caustic render --denoise`),
//! as Cycles' OIDN denoiser with its default "Accurate" prefilter: the albedo and normal
//! passes are first denoised on their own (they are means of noisy first hits too), then
//! the Combined RGB is denoised as HDR colour with the cleaned passes as auxiliary images
//! (`cleanAux`). Alpha is kept. The noisy Combined stays in the image as `Noisy Image`,
//! Cycles' name for it.
//!
//! The library is found, in this order, at `--oidn PATH`, at `$CAUSTIC_OIDN` (a file, or
//! a directory holding it), else by the system loader's search; the add-on passes the copy
//! Blender ships. When none loads the render is refused before it starts (exit 2), never
//! written noisy under the denoised name. Interim images are not denoised.

pub mod oidn;

use crate::error::{Error, Result};
use crate::film::FilmImage;
use oidn::{FilterImages, Oidn};
use std::path::{Path, PathBuf};

/// The library's file name on this platform (OIDN 2.x).
#[cfg(target_os = "linux")]
pub const LIBRARY_NAME: &str = "libOpenImageDenoise.so.2";
/// The library's file name on this platform (OIDN 2.x).
#[cfg(target_os = "macos")]
pub const LIBRARY_NAME: &str = "libOpenImageDenoise.2.dylib";
/// The library's file name on this platform (OIDN 2.x).
#[cfg(not(any(target_os = "linux", target_os = "macos")))]
pub const LIBRARY_NAME: &str = "OpenImageDenoise.dll";

/// The environment variable naming the library (or its directory).
pub const ENV_VAR: &str = "CAUSTIC_OIDN";

/// A loaded OIDN.
pub struct Denoiser {
    oidn: Oidn,
    /// Where it was loaded from (for the summary).
    pub source: PathBuf,
}

/// Bytes per pixel that [`Denoiser::denoise`] allocates: the prefiltered albedo and normal,
/// the colour input and output (RGB f32 each) and the kept noisy RGBA. OIDN's own working
/// memory is not counted: it tiles the image to bound it.
pub const BYTES_PER_PIXEL: u64 = 4 * 12 + 16;

impl Denoiser {
    /// Loads OIDN from `flag`, else `$CAUSTIC_OIDN`, else the system search path, and
    /// checks that it can make a CPU device; a usage error (exit 2) says how to point at it.
    pub fn open(flag: Option<&Path>) -> Result<Denoiser> {
        let env = std::env::var_os(ENV_VAR).filter(|v| !v.is_empty()).map(PathBuf::from);
        let (given, origin) = match (flag, env) {
            (Some(p), _) => (Some(p.to_path_buf()), "--oidn"),
            (None, Some(p)) => (Some(p), ENV_VAR),
            (None, None) => (None, "the system library path"),
        };
        let path = match given {
            Some(p) if p.is_dir() => p.join(LIBRARY_NAME),
            Some(p) => p,
            None => PathBuf::from(LIBRARY_NAME),
        };
        let refuse = |why: String| {
            Error::Usage(format!(
                "--denoise needs Intel Open Image Denoise 2 ({LIBRARY_NAME}), from {origin}: {why}. Point --oidn or \
                 ${ENV_VAR} at the library or its folder (Blender ships it: bpy/lib/ in the bpy wheel, lib/ beside \
                 Blender's executable)"
            ))
        };
        let oidn = Oidn::load(&path).map_err(refuse)?;
        oidn.device().map_err(refuse)?;
        Ok(Denoiser { oidn, source: path })
    }

    /// Denoises `img`'s Combined RGB in place (alpha kept) and keeps the noisy Combined
    /// in `img.noisy`.
    pub fn denoise(&self, img: &mut FilmImage) -> Result<()> {
        let (w, h) = (img.width as usize, img.height as usize);
        let device = self.oidn.device().map_err(Error::Internal)?;
        let run = |images: FilterImages, out: &mut Vec<[f32; 3]>| {
            device.run(w, h, images, out).map_err(|e| Error::Internal(format!("denoising failed: {e}")))
        };
        let plain = |color| FilterImages { color, albedo: None, normal: None, hdr: false, clean_aux: false };
        // Cycles' "Accurate" prefilter: the auxiliary passes denoised on their own first.
        let mut albedo = vec![[0.0; 3]; w * h];
        run(plain(&img.albedo), &mut albedo)?;
        let mut normal = vec![[0.0; 3]; w * h];
        run(plain(&img.normal), &mut normal)?;
        let color: Vec<[f32; 3]> = img.combined.iter().map(|p| [p[0], p[1], p[2]]).collect();
        let mut out = vec![[0.0; 3]; w * h];
        let beauty =
            FilterImages { color: &color, albedo: Some(&albedo), normal: Some(&normal), hdr: true, clean_aux: true };
        run(beauty, &mut out)?;
        if let Some(bad) = out.iter().position(|d| d.iter().any(|v| !v.is_finite())) {
            return Err(Error::Internal(format!(
                "the denoiser returned a non-finite value at pixel {} of {}x{} ({})",
                bad,
                w,
                h,
                self.source.display()
            )));
        }
        img.noisy = img.combined.clone();
        for (p, d) in img.combined.iter_mut().zip(&out) {
            *p = [d[0], d[1], d[2], p[3]];
        }
        Ok(())
    }
}
