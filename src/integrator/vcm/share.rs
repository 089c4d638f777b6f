//! How many light subpaths VCM traces per camera sample: the share f of the camera samples
//! that get one (Georgiev et al. 2012 count each strategy's samples in its MIS density;
//! `bdpt::mis::PathDensities::light_share`). Where the light subpath's strategies (s ≥ 2,
//! t = 1, merges) add little, as under a sky, tracing and connecting one for every pixel
//! costs more than it buys: VCM had 1.9× the path tracer's equal-time error on the bench's
//! HDRI scene at f = 1 (docs/bench-2026-11-25-quiet.txt).
//!
//! The rule, decided once per render from a pilot at f = 1 (one camera sample on every other
//! pixel of every other row, at a sample index no image sample takes, then thrown away):
//! of the pilot's image, a share φ came from the light subpath's strategies (connections
//! s ≥ 2, merges, and light tracing's splats) and 1 − φ from the camera side (s = 0, 1);
//! R_l and R_c rays were cast for each. Taking the light subpath with probability f (its
//! strategies weighted 1 / f) gives the variance V(f) = A + B / f at the cost
//! C(f) = R_c + f R_l, and V·C is least at f = √(B R_c / (A R_l)). With each side's
//! variance proportional to what it contributes (a sum of many small independent
//! contributions, Poisson-like), B / A = φ / (1 − φ). The model leaves out that the MIS
//! weights move toward the camera strategies as f drops, which makes V grow slower than
//! B / f, so its f errs high: on the bench scenes it keeps f = 1 on the Cornell box, the
//! glass caustic and many lights, and picks about 0.3 under the HDRI sky.
//! The same f serves every pixel and every iteration and depends on the seed and the
//! window alone, so the estimator is as consistent as at f = 1 and chunks merge exactly.

/// The smallest share: below it the light subpath's strategies (caustics seen directly,
/// light tracing) get too few samples to converge visibly in a preview, and the light
/// pass's cost is already small beside the camera pass's.
pub const SHARE_MIN: f32 = 1.0 / 16.0;

/// The pilot's sums over its camera samples (luminance).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PilotSums {
    /// Σ X_c: what the camera side (s = 0, s = 1) gave.
    pub camera: f64,
    /// Σ X_l: what the connections to the light subpath (s ≥ 2, t ≥ 2) and merges gave.
    pub light: f64,
    /// Σ of the light tracing splats (t = 1), in splat units (a pixel gets Σ / light paths).
    pub splat: f64,
    /// Rays cast by the camera side (camera subpath and s = 1's shadow rays).
    pub camera_rays: u64,
    /// Rays cast by the light side (light subpaths, their connections and splats).
    pub light_rays: u64,
    /// Camera samples taken, each with a light subpath.
    pub samples: u64,
}

impl PilotSums {
    /// Adds another part's sums.
    pub(crate) fn add(&mut self, o: &PilotSums) {
        self.camera += o.camera;
        self.light += o.light;
        self.splat += o.splat;
        self.camera_rays += o.camera_rays;
        self.light_rays += o.light_rays;
        self.samples += o.samples;
    }

    /// The share f (see the module's doc); `npix`: the window's pixels, over which the
    /// splats spread.
    pub(crate) fn light_share(&self, npix: u64) -> f32 {
        if self.samples == 0 || self.light_rays == 0 || npix == 0 {
            return 1.0;
        }
        // Mean per pixel: the camera side's over the samples; the splats' sum over the
        // light paths (as many as the samples) and the pixels.
        let n = self.samples as f64;
        let camera = self.camera / n;
        let light = self.light / n + self.splat / (n * npix as f64);
        if camera <= 0.0 {
            return 1.0; // the light subpath makes the whole image
        }
        let ratio = light / camera * self.camera_rays as f64 / self.light_rays as f64;
        let f = ratio.max(0.0).sqrt() as f32;
        if f.is_finite() { f.clamp(SHARE_MIN, 1.0) } else { 1.0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rule follows the model: V·C at the chosen f is no larger than at nearby shares,
    /// and the limits hold (nothing from the light side: the least share; from the light
    /// side alone: 1).
    #[test]
    fn share_minimises_variance_times_cost() {
        let p =
            PilotSums { camera: 900.0, light: 60.0, splat: 4.0e6, camera_rays: 3000, light_rays: 2000, samples: 1000 };
        let npix = 100_000;
        let f = p.light_share(npix) as f64;
        let (a, b) = (0.9, 0.06 + 4.0e6 / (1000.0 * npix as f64));
        let vc = |f: f64| (a + b / f) * (3000.0 + f * 2000.0);
        assert!(f > SHARE_MIN as f64 && f < 1.0, "{f}");
        assert!(vc(f) <= vc(f * 1.05) && vc(f) <= vc(f / 1.05), "{f}");
        let none = PilotSums { light: 0.0, splat: 0.0, ..p };
        assert_eq!(none.light_share(npix), SHARE_MIN);
        let all = PilotSums { camera: 0.0, ..p };
        assert_eq!(all.light_share(npix), 1.0);
    }
}
