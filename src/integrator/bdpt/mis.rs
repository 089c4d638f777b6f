//! Multiple importance sampling weights over all strategies of a path, power heuristic,
//! in the ratio form of Veach's thesis §10.2 (as pbrt and SmallVCM compute it): linear in
//! the path length.
//!
//! A path z₀ … z_k runs from the light (z₀) to the camera (z_k). Strategy j takes
//! z₀ … z_{j-1} from a light subpath and z_j … z_k from a camera subpath, so its density is
//! p_j = Π_{i<j} a_i · Π_{i≥j} b_i, with a_i the area density of z_i generated from the light
//! side and b_i from the camera side. Then p_j / p_{j+1} = b_j / a_j, and the weight of
//! strategy s is p_s² / Σ_j p_j², summed over the strategies that can make the path.
//!
//! Vertices reached through a delta lobe store densities of 0, counted as 1 in the
//! ratios (their delta factor is common to every strategy that can sample them), or with
//! `BdptIntegrator::delta_geometry` (VCM) their geometric factor alone; no strategy may
//! connect at them. Any choice of densities gives weights that sum to 1
//! over the strategies as long as every strategy evaluates the same function of the
//! path, which is what makes the estimator unbiased; the densities only decide how well
//! the strategies are combined.
//!
//! Vertex merging (VCM, `integrator::vcm`) adds one strategy per interior vertex z_m
//! (1 ≤ m ≤ k-1, connectible): the light subpath generates z₀ … z_m, the camera subpath
//! z_m … z_k, and they are joined when within the merging radius r, which happens with
//! probability a_m π r², for each of the N light subpaths of an iteration. So its density
//! is P_m = p_m · a_m · η with η = N π r² (`eta_vm`; 0 for BDPT, which has no merging).
//! Merging is not a strategy at z₁ (`MIN_MERGE_VERTEX`): direct light is left to the
//! connections, as photon mapping leaves it to shadow rays.
//!
//! VCM may trace a light subpath for a fraction f of the pixels only (`light_share`, 1 in
//! BDPT): the strategies that take the pixel's light subpath (s ≥ 2, and t = 1) then have
//! f samples per camera sample, so their densities count f times (Georgiev et al.'s sample
//! counts n_s p_s in the power heuristic), and `weight` returns the weight over f, which is
//! what a sample taken with probability f must carry to stay unbiased.

/// Most vertices a path may have (subpath lengths are bounded accordingly).
pub const MAX_PATH_VERTICES: usize = 130;

/// The first light-subpath vertex merging may take: 2, so merges carry light that has
/// scattered at least once. Direct light at z₁ is always made by light sampling (s = 1, any
/// light but a hittable-only one is sampled) and by s = 0 / t = 1; a merge there competed
/// with light sampling by density (a₁ η against 1) although its estimate, about one photon
/// within r, is far noisier than a shadow ray (issue 24: it added a fifth to the variance per
/// sample of the Cornell box). The set of strategies is a property of the vertex index,
/// the same for every strategy's weight, so the weights still sum to 1.
pub const MIN_MERGE_VERTEX: usize = 2;

/// The densities of one full path, light end first.
#[derive(Clone, Debug)]
pub struct PathDensities {
    /// Area density of each vertex generated from the light side.
    pub a: [f32; MAX_PATH_VERTICES],
    /// Area density of each vertex generated from the camera side.
    pub b: [f32; MAX_PATH_VERTICES],
    /// The vertex can be an end of a connection (not a delta scattering, and for the
    /// camera: a camera that light paths can reach).
    pub connectible: [bool; MAX_PATH_VERTICES],
    /// Vertices in the path.
    pub n: usize,
    /// A camera path can hit z₀ (false for point and spot lights).
    pub light_hittable: bool,
    /// Vertex merging's η = N π r² (light subpaths per iteration × the merging disk's
    /// area); 0 without merging (BDPT).
    pub eta_vm: f32,
    /// Vertices at a contact at the light end, z₁ … z_c (`bdpt::contact`): with c ≥ 1 no
    /// camera ray from z₁ finds the light (j = 0), with c ≥ 2 only light sampling at z₁
    /// (j = 1) makes the path.
    pub contacts: usize,
    /// Light subpaths per camera sample f (0 < f ≤ 1): the sample count of every strategy
    /// that takes the pixel's light subpath (s ≥ 2, or t = 1); 1 in BDPT.
    pub light_share: f32,
}

impl Default for PathDensities {
    fn default() -> Self {
        PathDensities {
            a: [0.0; MAX_PATH_VERTICES],
            b: [0.0; MAX_PATH_VERTICES],
            connectible: [false; MAX_PATH_VERTICES],
            n: 0,
            light_hittable: true,
            eta_vm: 0.0,
            contacts: 0,
            light_share: 1.0,
        }
    }
}

#[inline]
fn remap0(x: f32) -> f32 {
    if x != 0.0 { x } else { 1.0 }
}

impl PathDensities {
    /// Whether strategy `j` (j light vertices) can produce the path.
    #[inline]
    pub fn valid(&self, j: usize) -> bool {
        let k = self.n - 1;
        if j > k {
            return false; // t = 0: the camera cannot be hit
        }
        let light_end = if j == 0 { self.light_hittable } else { self.connectible[j - 1] };
        light_end && self.connectible[j] && self.contact_allows(j)
    }

    /// Whether the contacts at the light end (`contacts`) leave strategy `j` able to make
    /// the path (`bdpt::contact`).
    #[inline]
    pub fn contact_allows(&self, j: usize) -> bool {
        match self.contacts {
            0 => true,
            1 => j != 0,
            _ => j == 1,
        }
    }

    /// Whether vertex merging can produce the path at z_m (an interior, connectible vertex,
    /// m ≥ `MIN_MERGE_VERTEX`).
    #[inline]
    pub fn mergeable(&self, m: usize) -> bool {
        self.eta_vm > 0.0 && m >= MIN_MERGE_VERTEX && m + 1 < self.n && self.connectible[m] && self.contacts < 2
    }

    /// Samples per camera sample of connection strategy `j`: f when it takes the pixel's
    /// light subpath (j ≥ 2 light vertices, or j = k: t = 1), else 1 (s = 0, and s = 1's
    /// light point of its own).
    #[inline]
    fn count(&self, j: usize) -> f64 {
        if j >= 2 || j + 1 == self.n { self.light_share as f64 } else { 1.0 }
    }

    /// (P_m / p_m)²: vertex merging at z_m against connection strategy m.
    #[inline]
    fn merge_ratio2(&self, m: usize) -> f64 {
        let x = remap0(self.a[m]) as f64 * self.eta_vm as f64;
        x * x
    }

    /// `own` + Σ over every strategy that can make the path (connections, and merges
    /// when `eta_vm` > 0) of (density / (c p_s))², the connection strategy s itself left out
    /// (connections' densities times their `count`; BDPT's sums are added in the order they
    /// always were, and its counts are 1: weights stay bit for bit).
    #[inline]
    fn total(&self, s: usize, own: f64, c: f64) -> f64 {
        let k = self.n - 1;
        let inv_c2 = 1.0 / (c * c);
        let mut sum = own;
        if self.mergeable(s) {
            sum += self.merge_ratio2(s) * inv_c2;
        }
        let mut r = 1.0f64;
        for j in (0..s).rev() {
            r *= remap0(self.b[j]) as f64 / remap0(self.a[j]) as f64;
            if self.valid(j) {
                let n = self.count(j);
                sum += r * r * (n * n * inv_c2);
            }
            if self.mergeable(j) {
                sum += r * r * self.merge_ratio2(j) * inv_c2;
            }
        }
        r = 1.0;
        for j in s + 1..=k {
            r *= remap0(self.a[j - 1]) as f64 / remap0(self.b[j - 1]) as f64;
            if self.valid(j) {
                let n = self.count(j);
                sum += r * r * (n * n * inv_c2);
            }
            if self.mergeable(j) {
                sum += r * r * self.merge_ratio2(j) * inv_c2;
            }
        }
        sum
    }

    /// Power-heuristic weight of strategy `s`, over its sample count (see the module's doc).
    #[inline]
    pub fn weight(&self, s: usize) -> f32 {
        // A strategy the contacts rule out gives nothing (it makes no such path, except
        // where the walk's look back and the vertex's contact test disagree).
        if !self.contact_allows(s) {
            return 0.0;
        }
        let c = self.count(s);
        let w = (1.0 / (self.total(s, 1.0, c) * c)) as f32;
        if w.is_finite() { w } else { 0.0 }
    }

    /// Power-heuristic weight of merging at z_m (`mergeable(m)`), in the ratio form; the
    /// merging integrator computes it recursively (`vcm::mis`), this is its reference.
    pub fn merge_weight(&self, m: usize) -> f32 {
        let x2 = self.merge_ratio2(m);
        let c = self.count(m);
        let own = if self.valid(m) { c * c } else { 0.0 };
        let w = (x2 / self.total(m, own, 1.0)) as f32;
        if w.is_finite() { w } else { 0.0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// For random densities and delta flags, the weights of the valid strategies of one
    /// path sum to 1 (to rounding), for every path length.
    #[test]
    fn weights_sum_to_one() {
        let mut state = 0x1234_5678u64;
        let mut rnd = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32 + 0.5) / (1u64 << 24) as f32
        };
        for trial in 0..2000 {
            let n = 2 + trial % 20;
            // Every third path with fewer light subpaths than camera samples.
            let light_share = if trial % 3 == 0 { 0.02 + 0.98 * rnd() } else { 1.0 };
            let mut d = PathDensities { n, light_hittable: rnd() < 0.7, light_share, ..Default::default() };
            for i in 0..n {
                // Densities over many orders of magnitude, some delta (0).
                let delta = i > 0 && i < n - 1 && rnd() < 0.2;
                d.a[i] = if delta { 0.0 } else { (rnd() * 20.0 - 10.0).exp() };
                d.b[i] = if delta { 0.0 } else { (rnd() * 20.0 - 10.0).exp() };
                d.connectible[i] = !delta;
            }
            d.connectible[n - 1] = rnd() < 0.8;
            let valid: Vec<usize> = (0..n).filter(|&j| d.valid(j)).collect();
            if valid.is_empty() {
                continue;
            }
            // A weight is over its strategy's sample count: times the count, they sum to 1.
            let sum: f64 = valid.iter().map(|&j| d.weight(j) as f64 * d.count(j)).sum();
            assert!((sum - 1.0).abs() < 1e-4, "trial {trial}: n {n}, Σw = {sum}");
        }
    }

    /// With contacts at the light end (`bdpt::contact`) the strategies they leave share
    /// the path (weights and merges sum to 1) and the others get 0: s = 0 for one contact,
    /// all but s = 1 for more.
    #[test]
    fn contacts_leave_their_strategies() {
        let mut state = 0x0bad_cafeu64;
        let mut rnd = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32 + 0.5) / (1u64 << 24) as f32
        };
        for trial in 0..2000 {
            let n = 3 + trial % 12;
            let contacts = 1 + trial % 3;
            let eta_vm = if trial % 2 == 0 { 0.0 } else { (rnd() * 8.0 - 4.0).exp() };
            let mut d = PathDensities { n, contacts, eta_vm, ..Default::default() };
            for i in 0..n {
                d.a[i] = (rnd() * 20.0 - 10.0).exp();
                d.b[i] = (rnd() * 20.0 - 10.0).exp();
                d.connectible[i] = true;
            }
            let mut sum = 0.0f64;
            for j in 0..n {
                let w = d.weight(j) as f64;
                match (contacts, j) {
                    (_, 0) => assert_eq!(w, 0.0, "trial {trial}: s = 0 at a contact"),
                    (2.., 2..) => assert_eq!(w, 0.0, "trial {trial}: s = {j} beyond a contact's chain"),
                    _ => sum += w,
                }
                if d.mergeable(j) {
                    assert!(contacts == 1, "trial {trial}: a merge through a contact's chain");
                    sum += d.merge_weight(j) as f64;
                }
            }
            assert!((sum - 1.0).abs() < 1e-4, "trial {trial}: n {n}, contacts {contacts}, Σw = {sum}");
        }
    }

    /// Two strategies with equal densities share the path equally; a strategy whose
    /// density dominates gets nearly all of it.
    #[test]
    fn weights_follow_densities() {
        let mut d = PathDensities { n: 2, ..Default::default() };
        d.a = [1.0; MAX_PATH_VERTICES];
        d.b = [1.0; MAX_PATH_VERTICES];
        d.connectible[0] = true;
        d.connectible[1] = true;
        assert!((d.weight(0) - 0.5).abs() < 1e-6 && (d.weight(1) - 0.5).abs() < 1e-6);
        d.b[0] = 100.0; // the camera side finds z₀ 100× more often
        assert!((d.weight(0) - 1e4 / (1e4 + 1.0)).abs() < 1e-6);
    }
}
