//! Merging weights in recursive form (Georgiev et al. 2012; the quantities SmallVCM calls
//! dVCM, dVC and dVM), so that weighing one merge costs O(1) however long the paths.
//!
//! The densities are those of `bdpt::mis` (a path z₀ … z_k, light end first; a_i the
//! density of z_i from the light side, b_i from the camera side; 0 after a delta lobe,
//! counted as 1). Merging at z_m has density P_m = p_{m+1} · b_m · η (η = N π r²). Its
//! weight is 1 / (1 + S_L + S_C): S_L sums (density / P_m)² over the strategies that take
//! fewer camera vertices (connections j ≤ m, merges below m), S_C over the others. Both
//! are short recursions along one subpath, except for the one density that depends on
//! the merge itself (b_{m-1}: the camera vertex's BSDF sampling toward z_{m-1}; a_{m+1}
//! likewise toward the camera side), which is kept as a factor:
//!
//! - light side: C₀ = v₀ / a₀², C_i = (v_i + b_{i-1}² C_{i-1}) / a_i² + η² μ_i, and
//!   S_L η² = v_m / a_m² + b_{m-1}² C_{m-1} / a_m² (`Side::e` and `Side::f`);
//! - camera side, camera vertex c (c = 0 the camera): D⁰ = 0, D^c = (v^c + a_{c-1}² D^{c-1}) /
//!   b_c² + η² μ^c, and S_C η² = v / b_c² + a_{m+1}² D^{c-1} / b_c²,
//!
//! with v the flag "the connection strategy there can make the path" times its sample count
//! squared (f², `PathDensities::light_share`, for the strategies that take the pixel's light
//! subpath: every one on the camera side, light vertex counts j ≥ 2 on the light side) and μ "merging
//! there can" (never at z₁, `bdpt::mis::MIN_MERGE_VERTEX`; on the camera side every vertex
//! is beyond the merge, so μ^c depends on connectibility alone). `PathDensities::merge_weight` is the same weight in the ratio form; the
//! test checks one against the other.

/// 0 (a delta density) counts as 1, as in `bdpt::mis`.
#[inline]
pub(crate) fn remap0(x: f32) -> f64 {
    if x != 0.0 { x as f64 } else { 1.0 }
}

/// One subpath's share of a merge weight at its end vertex: S η² = e + d² f, where d is
/// the density (area measure) that the merge itself decides.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Side {
    /// The connection strategy at the merged vertex, over its density squared.
    pub e: f32,
    /// The rest of the subpath's strategies, over the merged vertex's density squared.
    pub f: f32,
}

/// Walks a subpath from its start, one vertex at a time, keeping the running sum C (light
/// side) or D (camera side).
#[derive(Clone, Copy, Debug)]
pub struct Recursion {
    /// η² (0: no merging).
    eta2: f64,
    /// The running sum at the last vertex added.
    sum: f64,
    /// The last vertex is connectible.
    conn: bool,
    /// f²: the squared sample count of the strategies that take the pixel's light subpath.
    share2: f64,
    /// Light side: the index of the last vertex (its strategies' counts depend on it);
    /// None on the camera side, whose strategies all take the light subpath.
    light_index: Option<usize>,
}

impl Recursion {
    /// Starts at a light point (`first_dens` a₀, `light_hittable` Some(a camera path can
    /// find it): the running sum is v₀ / a₀²) or at the camera (`light_hittable` None: the
    /// sum starts at 0); `first_conn`: the start is connectible (the camera: light
    /// subpaths can reach it, i.e. not orthographic); `light_share`: light subpaths per
    /// camera sample (`PathDensities::light_share`).
    pub fn start(eta: f32, light_share: f32, first_dens: f32, first_conn: bool, light_hittable: Option<bool>) -> Self {
        let d = remap0(first_dens);
        let sum = match light_hittable {
            Some(h) if h && first_conn => 1.0 / (d * d),
            _ => 0.0,
        };
        let f = light_share as f64;
        Recursion {
            eta2: (eta as f64) * (eta as f64),
            sum,
            conn: first_conn,
            share2: f * f,
            light_index: light_hittable.map(|_| 0),
        }
    }

    /// The squared sample count of the connection strategy that joins the last vertex to
    /// the next one: on the light side it has j = index + 1 light vertices (s = 1 has a
    /// light point of its own, `PathDensities::count`).
    #[inline]
    fn next_count2(&self) -> f64 {
        match self.light_index {
            Some(i) if i + 1 < 2 => 1.0,
            _ => self.share2,
        }
    }

    /// The merge share at the next vertex, whose density from this subpath's side is `dens`.
    #[inline]
    pub fn side(&self, dens: f32) -> Side {
        let d = remap0(dens);
        let inv2 = 1.0 / (d * d);
        Side { e: if self.conn { (self.next_count2() * inv2) as f32 } else { 0.0 }, f: (self.sum * inv2) as f32 }
    }

    /// Moves on to the next vertex: its density `dens` from this side, its own
    /// connectibility `conn` (its sampled lobe is not delta), `rev`, the density of the
    /// last vertex from the other side (sampled from the next one), and `merge`: merging
    /// is a strategy there by its index (`bdpt::mis::MIN_MERGE_VERTEX`).
    #[inline]
    pub fn push(&mut self, dens: f32, conn: bool, rev: f32, merge: bool) {
        let d = remap0(dens);
        let r = remap0(rev);
        let v = if self.conn && conn { self.next_count2() } else { 0.0 };
        let mu = if conn && merge { self.eta2 } else { 0.0 };
        self.sum = (v + r * r * self.sum) / (d * d) + mu;
        self.conn = conn;
        self.light_index = self.light_index.map(|i| i + 1);
    }
}

/// Power-heuristic weight of a merge from the light side `l` and camera side `c`, with
/// `b_prev` (camera vertex's BSDF toward the light vertex's predecessor, area measure) and
/// `a_next` (likewise toward the camera vertex's predecessor).
#[inline]
pub fn merge_weight(eta: f32, l: Side, b_prev: f32, c: Side, a_next: f32) -> f32 {
    let (bp, an) = (remap0(b_prev), remap0(a_next));
    let s = l.e as f64 + bp * bp * l.f as f64 + c.e as f64 + an * an * c.f as f64;
    let eta2 = (eta as f64) * (eta as f64);
    let w = (1.0 / (1.0 + s / eta2)) as f32;
    if w.is_finite() { w } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrator::bdpt::mis::{MIN_MERGE_VERTEX, PathDensities};

    /// The recursive merge weight equals the ratio form's (`PathDensities::merge_weight`)
    /// for random densities, delta vertices and path lengths; and with merging, the
    /// weights of every strategy that can make a path sum to 1.
    #[test]
    fn recursion_matches_ratio_form() {
        let mut state = 0x9e37_79b9u64;
        let mut rnd = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32 + 0.5) / (1u64 << 24) as f32
        };
        let mut checked = 0;
        for trial in 0..3000 {
            let n = 3 + trial % 12;
            let eta = (rnd() * 8.0 - 4.0).exp();
            // Every third path with fewer light subpaths than camera samples.
            let f = if trial % 3 == 0 { 0.02 + 0.98 * rnd() } else { 1.0 };
            let mut d =
                PathDensities { n, light_hittable: rnd() < 0.7, eta_vm: eta, light_share: f, ..Default::default() };
            for i in 0..n {
                let delta = i > 0 && i < n - 1 && rnd() < 0.2;
                d.a[i] = if delta { 0.0 } else { (rnd() * 12.0 - 6.0).exp() };
                d.b[i] = if delta { 0.0 } else { (rnd() * 12.0 - 6.0).exp() };
                d.connectible[i] = !delta;
            }
            d.connectible[n - 1] = rnd() < 0.8;
            // A contact at z₁ (`bdpt::contact`) takes s = 0 away: the light side starts
            // without it.
            d.contacts = usize::from(rnd() < 0.3);
            // Σ weights = 1 over connections (each over its count: times it) and merges.
            let mut sum = 0.0f64;
            for j in 0..n {
                if d.valid(j) {
                    let count = if j >= 2 || j + 1 == n { f as f64 } else { 1.0 };
                    sum += d.weight(j) as f64 * count;
                }
                if d.mergeable(j) {
                    sum += d.merge_weight(j) as f64;
                }
            }
            if sum > 0.0 {
                assert!((sum - 1.0).abs() < 1e-4, "trial {trial}: Σw = {sum}");
            }
            let k = n - 1;
            for m in 1..k {
                if !d.mergeable(m) {
                    continue;
                }
                // Light side: z₀ … z_m.
                let mut lr =
                    Recursion::start(eta, f, d.a[0], d.connectible[0], Some(d.light_hittable && d.contacts == 0));
                for i in 1..m {
                    lr.push(d.a[i], d.connectible[i], d.b[i - 1], i >= MIN_MERGE_VERTEX);
                }
                let l = lr.side(d.a[m]);
                // Camera side: z_k (camera) … z_m, camera vertex c is z_{k-c}.
                let mut cr = Recursion::start(eta, f, 0.0, d.connectible[k], None);
                for c in 1..k - m {
                    let j = k - c;
                    // z_j is beyond the merge, so merging is a strategy there when connectible.
                    cr.push(d.b[j], d.connectible[j], if c >= 2 { d.a[j + 1] } else { 0.0 }, true);
                }
                let c = cr.side(d.b[m]);
                let b_prev = d.b[m - 1];
                let a_next = d.a[m + 1];
                let w = merge_weight(eta, l, b_prev, c, a_next);
                let reference = d.merge_weight(m);
                assert!(
                    (w - reference).abs() <= 1e-4 * reference.max(1e-3),
                    "trial {trial}: n {n}, m {m}: recursive {w} vs ratio form {reference}"
                );
                checked += 1;
            }
        }
        assert!(checked > 1000, "only {checked} merges checked");
    }
}
