//! The shadow catcher's film: Cycles' reading of its sums (`kernel/film/read.h`,
//! `film_calculate_shadow_catcher` and `film_calculate_shadow_catcher_matte_with_shadow`;
//! `session/buffers.cpp`, `get_actual_display_pass`: with catchers in the scene Blender's
//! Combined is the matte). The sums come from `integrator::catcher`, as means per pixel
//! (`FilmImage::catcher`):
//! * Shadow Catcher = (Combined − matte) / catcher pass per channel (1 where the catcher
//!   pass is 0, and 1 in pixels where no sample split), alpha-overed on white with
//!   Combined's alpha.
//! * Combined, when the Shadow Catcher pass is not asked (Cycles' "approximate" shadow
//!   catcher): the matte's colour with alpha (1 − a)(1 − mean(Shadow Catcher)) + a, a the
//!   matte's own alpha; under an opaque film that is composited over the world behind it
//!   (alpha 1). When the pass is asked: the matte with its own alpha, for the compositor
//!   to multiply the footage by the pass.

use crate::film::{CATCHER_SUMS, FilmImage};
use crate::passes::Pass;

/// Index of each sum in a pixel's `FilmImage::catcher` entry (slot order).
const PASS: usize = 0;
const MATTE: usize = 3;
const SPLIT: usize = 6;
const COUNT: usize = 7;
const BACKGROUND: usize = 8;
const _: () = assert!(BACKGROUND + 3 == CATCHER_SUMS);

/// Replaces Combined and fills the Shadow Catcher pass from the catcher's sums, after the
/// film was made opaque or not (`transparent`: Blender's Film → Transparent). Does nothing
/// when the film kept no catcher sums.
pub fn resolve(img: &mut FilmImage, transparent: bool) {
    if img.catcher.is_empty() {
        return;
    }
    let approximate = !img.passes.contains(Pass::ShadowCatcher);
    let has_catchers = img.passes.catcher_sums();
    let pass_index = img.extra.iter().position(|(p, _)| *p == Pass::ShadowCatcher);
    for i in 0..img.catcher.len() {
        if img.samples[i] == 0 {
            continue;
        }
        let c = img.catcher[i];
        let combined = img.combined[i];
        // Combined's alpha: under an opaque film nothing is transparent.
        let alpha = if transparent { combined[3].clamp(0.0, 1.0) } else { 1.0 };
        let factor = shadow_factor(&c, &combined, alpha);
        if let Some(k) = pass_index {
            img.extra[k].1[i * 3..i * 3 + 3].copy_from_slice(&factor);
        }
        if !has_catchers {
            continue;
        }
        // The matte's alpha: Combined's, less the samples that split at a catcher.
        let matte_alpha = (alpha - c[SPLIT]).clamp(0.0, 1.0);
        let matte = [c[MATTE], c[MATTE + 1], c[MATTE + 2]];
        img.combined[i] = if !approximate {
            [matte[0], matte[1], matte[2], matte_alpha]
        } else {
            let mean = (factor[0] + factor[1] + factor[2]) / 3.0;
            let a = (1.0 - matte_alpha) * (1.0 - mean.clamp(0.0, 1.0)) + matte_alpha;
            if transparent {
                [matte[0], matte[1], matte[2], a]
            } else {
                let bg = |k: usize| matte[k] + c[BACKGROUND + k] * (1.0 - a);
                [bg(0), bg(1), bg(2), 1.0]
            }
        };
    }
}

/// Cycles' Shadow Catcher value of a pixel: its sums `c`, Combined and Combined's alpha.
fn shadow_factor(c: &[f32; CATCHER_SUMS], combined: &[f32; 4], alpha: f32) -> [f32; 3] {
    if c[COUNT] == 0.0 {
        return [1.0; 3];
    }
    [0, 1, 2].map(|k| {
        let without_matte = combined[k] - c[MATTE + k];
        let ratio = if c[PASS + k] != 0.0 { without_matte / c[PASS + k] } else { 1.0 };
        (1.0 - alpha) + alpha * ratio
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::passes::PassSet;

    fn one_pixel(passes: PassSet, combined: [f32; 4], sums: [f32; CATCHER_SUMS]) -> FilmImage {
        FilmImage {
            width: 1,
            height: 1,
            combined: vec![combined],
            samples: vec![1],
            passes,
            extra: passes.iter().filter(|p| *p == Pass::ShadowCatcher).map(|p| (p, vec![0.0; 3])).collect(),
            catcher: vec![sums],
            ..Default::default()
        }
    }

    /// A pixel wholly on a catcher, half in shadow: Combined holds the shadowed light, the
    /// catcher pass the unshadowed; the matte is empty and every sample split.
    const HALF_SHADOW: [f32; CATCHER_SUMS] = [0.8, 0.8, 0.8, 0.0, 0.0, 0.0, 1.0, 1.0, 0.5, 0.5, 0.5];

    #[test]
    fn approximate_combined_holds_the_shadow_in_alpha() {
        let passes = PassSet::default().with_catcher_sums();
        let mut img = one_pixel(passes, [0.4, 0.4, 0.4, 1.0], HALF_SHADOW);
        resolve(&mut img, true);
        // Factor 0.5: alpha 1 − 0.5 over a transparent matte, colour the (empty) matte.
        assert_eq!(img.combined[0], [0.0, 0.0, 0.0, 0.5]);
        // Opaque film: the world behind, darkened by the alpha.
        let mut img = one_pixel(passes, [0.4, 0.4, 0.4, 1.0], HALF_SHADOW);
        resolve(&mut img, false);
        assert_eq!(img.combined[0], [0.25, 0.25, 0.25, 1.0]);
    }

    #[test]
    fn asked_pass_holds_the_factor_and_combined_the_matte() {
        let passes = PassSet::parse_list("shadow_catcher").unwrap().with_catcher_sums();
        let mut img = one_pixel(passes, [0.4, 0.4, 0.4, 1.0], HALF_SHADOW);
        resolve(&mut img, true);
        assert_eq!(img.extra[0].1, vec![0.5, 0.5, 0.5]);
        assert_eq!(img.combined[0], [0.0, 0.0, 0.0, 0.0]);
        // A pixel no sample split in: factor 1, Combined is the matte (all of Combined).
        let mut sums = [0.0; CATCHER_SUMS];
        sums[MATTE..MATTE + 3].copy_from_slice(&[0.3, 0.2, 0.1]);
        let mut img = one_pixel(passes, [0.3, 0.2, 0.1, 1.0], sums);
        resolve(&mut img, true);
        assert_eq!(img.extra[0].1, vec![1.0, 1.0, 1.0]);
        assert_eq!(img.combined[0], [0.3, 0.2, 0.1, 1.0]);
    }

    #[test]
    fn without_catchers_the_pass_is_one_and_combined_unchanged() {
        let passes = PassSet::parse_list("shadow_catcher").unwrap();
        let mut img = one_pixel(passes, [0.3, 0.2, 0.1, 0.7], [0.0; CATCHER_SUMS]);
        resolve(&mut img, true);
        assert_eq!(img.extra[0].1, vec![1.0, 1.0, 1.0]);
        assert_eq!(img.combined[0], [0.3, 0.2, 0.1, 0.7]);
    }
}
