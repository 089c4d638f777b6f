//! The Bump node's three heights (at the point and at its two offsets) as lanes of one pass.
//!
//! `Program::bump` re-runs the height's operations at the two offset points after the
//! centre run: three passes of the same operations, 10⁻⁴ apart. Here the program's first
//! Bump (when its height holds no other Bump) is run in lane form instead: from the first
//! operation of its height on, each height operation runs for the centre in the register
//! file and for the two offsets in two copies of it, one operation after the other, so an
//! operation with a lane form (`lane_step`: the 3-D fBm Noise texture) does the three
//! points' work together; every other operation runs once per lane, the same call as in
//! `Program::bump`. Each lane computes what the scalar passes compute (bit for bit: the
//! lane forms are tested against the scalar code), so images do not change.
//!
//! What an offset lane starts from: the height's operations read only constants and each
//! other's results (a node's operations, conversions included, lie in its own range, and
//! `upstream_ranges` takes every node above the height), so a copy of the file at the first
//! height operation is what `Program::bump`'s copy at the Bump holds for them.

use super::closure::Closures;
use super::geom::{Geom, v3};
use super::instructions::{Op, Program};
use super::ops;
use super::program::bump_offsets;
use super::texture::noise::{NoiseKind, NoiseParams};
use super::texture::noise_lanes::noise_fbm_3d_lanes;
use super::texture_nodes::TexOp;
use std::cell::RefCell;

thread_local! {
    /// The two offset lanes' register files, one after the other.
    static LANES: RefCell<Vec<f32>> = const { RefCell::new(Vec::new()) };
}

/// Where a program's lane-form Bump sits: `ops[start..at]` in runs of height operations
/// (run in lanes) and others (run at the centre only); the Bump itself is `ops[at]`.
#[derive(Clone, Debug, Default)]
pub struct LaneBump {
    start: usize,
    at: usize,
    /// Consecutive operations `(from, to, height)`, covering `start..at` in order.
    runs: Vec<(usize, usize, bool)>,
}

impl LaneBump {
    /// The first Bump among the surface's operations `ops[..end]`, when its height's
    /// operations hold no Bump (a nested one keeps `Program::bump`'s passes).
    pub fn find(ops: &[Op], end: usize) -> Option<LaneBump> {
        let at = ops[..end].iter().position(|op| matches!(op, Op::Bump(_)))?;
        let Op::Bump(b) = &ops[at] else { return None };
        let start = b.sub.first()?.0 as usize;
        let mut in_height = vec![false; at.saturating_sub(start)];
        for &(a, z) in &b.sub {
            let (a, z) = (a as usize, z as usize);
            if z > at || a < start {
                return None;
            }
            if ops[a..z].iter().any(|op| matches!(op, Op::Bump(_))) {
                return None;
            }
            in_height[a - start..z - start].fill(true);
        }
        let mut runs: Vec<(usize, usize, bool)> = Vec::new();
        for (k, &h) in in_height.iter().enumerate() {
            match runs.last_mut() {
                Some(last) if last.2 == h => last.1 = start + k + 1,
                _ => runs.push((start + k, start + k + 1, h)),
            }
        }
        Some(LaneBump { start, at, runs })
    }
}

impl Program {
    /// The surface's operations `ops[..end]` with the lane-form Bump `l`.
    pub(super) fn run_lanes(&self, l: &LaneBump, g: &Geom, r: &mut [f32], out: &mut Closures, end: usize) {
        let Op::Bump(b) = &self.ops[l.at] else {
            return self.steps(&self.ops[..end], g, r, out);
        };
        self.steps(&self.ops[..l.start], g, r, out);
        let Some(off) = bump_offsets(g) else {
            // A degenerate triangle: the height at the centre only, as `Program::bump`.
            return self.steps(&self.ops[l.start..end], g, r, out);
        };
        let h = LANES.with(|lanes| {
            let Ok(mut lanes) = lanes.try_borrow_mut() else { return None };
            let n = r.len();
            lanes.clear();
            lanes.extend_from_slice(r);
            lanes.extend_from_slice(r);
            let (la, lb) = lanes.split_at_mut(n);
            let gs = [g, &off.geom[0], &off.geom[1]];
            for &(a, z, height) in &l.runs {
                if height {
                    for op in &self.ops[a..z] {
                        self.lane_step(op, gs, [&mut *r, &mut *la, &mut *lb], out);
                    }
                } else {
                    self.steps(&self.ops[a..z], g, r, out);
                }
            }
            Some([la[b.height as usize], lb[b.height as usize]])
        });
        match h {
            Some(h) => self.bump_finish(b, g, r, Some((off.d, h))),
            // The lanes' files are in use (cannot happen: evaluation does not recurse).
            None => {
                self.steps(&self.ops[l.start..l.at], g, r, out);
                self.step(&self.ops[l.at], g, r, out);
            }
        }
        self.steps(&self.ops[l.at + 1..end], g, r, out);
    }

    /// One height operation at the three points `g` in the files `r`: the Math node inline
    /// (as `steps` has it), the lane forms, and one `dispatch` per lane for the rest.
    #[inline]
    fn lane_step(&self, op: &Op, g: [&Geom; 3], r: [&mut [f32]; 3], out: &mut Closures) {
        if let Op::Math { op, a, b, c, out, clamp } = *op {
            for file in r {
                let v = ops::math(op, file[a as usize], file[b as usize], file[c as usize]);
                file[out as usize] = if clamp { v.clamp(0.0, 1.0) } else { v };
            }
            return;
        }
        if let Op::Texture(t) = op
            && let TexOp::Noise { dims: 3, kind: NoiseKind::Fbm, normalize, inputs: i, fac, color: None } = **t
        {
            // The lane form needs the same settings in every lane (they are constants or
            // position-independent links nearly always; otherwise each lane runs alone).
            let same = i[2..].iter().all(|&k| {
                let k = k as usize;
                r[0][k].to_bits() == r[1][k].to_bits() && r[0][k].to_bits() == r[2][k].to_bits()
            });
            if same {
                let f = |k: usize| r[0][i[k] as usize];
                let prm = NoiseParams {
                    dims: 3,
                    kind: NoiseKind::Fbm,
                    normalize,
                    scale: f(2),
                    detail: f(3),
                    roughness: f(4),
                    lacunarity: f(5),
                    offset: f(6),
                    gain: f(7),
                    distortion: f(8),
                };
                let p = [v3(r[0], i[0]), v3(r[1], i[0]), v3(r[2], i[0])];
                let v = noise_fbm_3d_lanes(p, &prm);
                for (file, v) in r.into_iter().zip(v) {
                    file[fac as usize] = v;
                }
                return;
            }
        }
        for (file, g) in r.into_iter().zip(g) {
            self.dispatch(op, g, file, out);
        }
    }
}
