//! Blender's Ambient Occlusion and Bevel nodes as Cycles traces them (`svm/ao.h`,
//! `svm/bevel.h`): the only nodes that cast rays from inside a shader, through the
//! shading point's `Rays` (the scene's BVH, `geom::SceneRays`, and a seed).
//!
//! Ambient Occlusion: `samples` cosine-distributed rays about the normal (flipped for
//! Inside) from the point, as long as Distance (the world's AO distance when Distance is an
//! unlinked 0); AO is the fraction that meet nothing (Only Local: nothing of the point's own
//! object), Color the Color input times AO.
//!
//! Bevel: `samples` probe rays within Radius, Cycles' BSSRDF-style disk probe: an axis of
//! the geometric normal's frame (the normal with probability ½, each tangent ¼), a point on
//! the disk about the point perpendicular to it at a radius drawn from the cubic falloff
//! 10 (R − r)³ / (π R⁵), a ray along the axis through the disk's sphere cap (length 2 h,
//! h² + r² = R²) meeting the object's own triangles; each hit's smooth normal is weighted
//! by the multiple-importance weight of the three axes and falloff(|hit − P|) /
//! falloff(r), at most four hits a ray (a uniform choice among more, weighted up). The sum's
//! direction is the bevelled normal.
//!
//! Where Cycles does not trace (lights' and the world's graphs, volumes, shadow and alpha
//! evaluation: its kernels there lack the ray-tracing node feature) `Rays::query` is None
//! and the nodes give AO 1 and the unbevelled normal, as Cycles does. Cycles also skips the
//! bevel for "blurry" rays (the path's smallest BSDF density below 8): here after a diffuse
//! bounce, whose density is at most 1/π; a rough glossy bounce, which Cycles' rule also
//! catches, keeps the bevel. Only Local and Bevel see the static triangles (not the moving
//! ones of a motion-blurred object, nor strands): a strand gives AO 1 with Only Local and its
//! own normal.
//!
//! Random numbers: a SplitMix64 stream from the point's seed and the node's output
//! register, the same at the Bump node's offset points (their heights then differ by the
//! geometry alone, as Cycles' re-evaluations draw the same numbers). Cycles' numbers are its
//! sampler's; the expected values are the same.

use super::geom::{Geom, Reg, from_blender, set3, to_blender, v3};
use crate::accel::Hit;
use crate::math::{Frame, offset_ray_origin};
use crate::sampling::warp::concentric_disk;
use glam::{Vec2, Vec3};

/// An Ambient Occlusion node.
#[derive(Clone, Debug, PartialEq)]
pub struct AoOp {
    /// Rays per evaluation (Samples).
    pub samples: u32,
    /// Inside: rays about the flipped normal.
    pub inside: bool,
    /// Only Local: only the point's own object occludes.
    pub only_local: bool,
    /// Distance was an unlinked 0: the world's AO distance is taken.
    pub global_distance: bool,
    /// Distance register.
    pub distance: Reg,
    /// The Normal input when linked (Blender axes).
    pub normal: Option<Reg>,
    /// Color input register.
    pub color: Reg,
    /// Color output register (Color × AO).
    pub color_out: Reg,
    /// AO output register.
    pub ao_out: Reg,
}

/// A Bevel node.
#[derive(Clone, Debug, PartialEq)]
pub struct BevelOp {
    /// Probe rays per evaluation (Samples).
    pub samples: u32,
    /// Radius register.
    pub radius: Reg,
    /// The Normal input when linked (Blender axes).
    pub normal: Option<Reg>,
    /// Output normal register (Blender axes).
    pub out: Reg,
}

/// Hits of one Bevel probe that are weighed (Cycles' `LOCAL_MAX_HITS`).
const MAX_HITS: usize = 4;

/// A SplitMix64 stream of uniform numbers in [0, 1).
struct Stream(u64);

impl Stream {
    /// The stream of the point's `seed` for the node writing register `reg`.
    fn new(seed: u32, reg: Reg) -> Self {
        Stream((seed as u64) << 32 ^ reg as u64 ^ 0x5EED_0000_0000_A0B3)
    }

    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut v = self.0;
        v = (v ^ (v >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        v = (v ^ (v >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((v ^ (v >> 31)) >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }
}

/// The random seed of a shading point at `p` seen from `wo` by a path `depth` bounces long:
/// a hash of their bits, so that every thread count draws the same numbers for a sample.
pub fn seed_of(p: Vec3, wo: Vec3, depth: u16) -> u32 {
    let mut h = 0x811C_9DC5u32;
    for v in [p.x, p.y, p.z, wo.x, wo.y, wo.z] {
        h = (h ^ v.to_bits()).wrapping_mul(0x0100_0193).rotate_left(13);
    }
    h ^= depth as u32;
    // A final avalanche (murmur3's) so that nearby points give unrelated streams.
    h ^= h >> 16;
    h = h.wrapping_mul(0x85EB_CA6B);
    h ^= h >> 13;
    h = h.wrapping_mul(0xC2B2_AE35);
    h ^ (h >> 16)
}

impl AoOp {
    /// Writes AO and Color × AO at `g`.
    pub fn run(&self, g: &Geom, r: &mut [f32]) {
        let ao = self.unoccluded(g, r);
        r[self.ao_out as usize] = ao;
        set3(r, self.color_out, v3(r, self.color) * ao);
    }

    /// The fraction of the node's rays that meet nothing within its distance.
    fn unoccluded(&self, g: &Geom, r: &[f32]) -> f32 {
        let Some(q) = g.rays.query else { return 1.0 };
        let dist = if self.global_distance { q.ao_distance() } else { r[self.distance as usize] };
        if !(dist > 0.0) || self.samples == 0 {
            return 1.0;
        }
        let object = match (self.only_local, g.mesh.tri_object.get(g.tri as usize)) {
            (false, _) => u32::MAX,
            (true, Some(&o)) => o,
            // A point of no object of triangles (a strand): nothing local to meet.
            (true, None) => return 1.0,
        };
        let mut n = self.normal.map_or(g.n, |n| from_blender(v3(r, n)).normalize_or(g.n));
        if self.inside {
            n = -n;
        }
        let frame = Frame::from_normal(n);
        let mut rng = Stream::new(g.rays.seed, self.ao_out);
        let mut open = 0u32;
        for _ in 0..self.samples {
            let d = concentric_disk(Vec2::new(rng.next(), rng.next()));
            let z = (1.0 - d.dot(d)).max(0.0).sqrt();
            let dir = frame.to_world(Vec3::new(d.x, d.y, z)).normalize_or(n);
            // Cycles leaves from P passing its own triangle; the origin also steps off the
            // surface to the ray's side for the queries that cannot pass it (moving
            // triangles, strands).
            let org = offset_ray_origin(g.p, if dir.dot(g.ng) < 0.0 { -g.ng } else { g.ng });
            let hit = if self.only_local {
                let mut any = false;
                q.local_hits(org, dir, dist, object, g.tri, &mut |_| {
                    any = true;
                    false
                });
                any
            } else {
                q.occluded(org, dir, dist, g.tri)
            };
            open += !hit as u32;
        }
        open as f32 / self.samples as f32
    }
}

impl BevelOp {
    /// Writes the bevelled normal at `g`.
    pub fn run(&self, g: &Geom, r: &mut [f32]) {
        let bevelled = self.bevelled(g, r[self.radius as usize]);
        // Cycles keeps a linked Normal's own bend: the input plus the bevel's change.
        let n = match self.normal {
            Some(reg) => (from_blender(v3(r, reg)) + (bevelled - g.n)).normalize_or(bevelled),
            None => bevelled,
        };
        set3(r, self.out, to_blender(n));
    }

    /// The bevelled normal (world glTF axes, on the viewer's side), `g.n` where nothing is
    /// traced.
    fn bevelled(&self, g: &Geom, radius: f32) -> Vec3 {
        let Some(q) = g.rays.query else { return g.n };
        if !(radius > 0.0) || self.samples == 0 || g.path.diffuse > 0 {
            return g.n;
        }
        let Some(&object) = g.mesh.tri_object.get(g.tri as usize) else { return g.n };
        let m = g.mesh;
        let f = Frame::from_normal(g.ng);
        let axes = [f.n, f.s, f.t];
        const PICK: [f32; 3] = [0.5, 0.25, 0.25];
        let mut rng = Stream::new(g.rays.seed, self.out);
        let mut sum = Vec3::ZERO;
        for _ in 0..self.samples {
            let (u0, u1) = (rng.next(), rng.next());
            // The axis and the rest of u0, stretched back to [0, 1).
            let (c, u0) = if u0 < 0.5 {
                (0, u0 * 2.0)
            } else if u0 < 0.75 {
                (1, (u0 - 0.5) * 4.0)
            } else {
                (2, (u0 - 0.75) * 4.0)
            };
            let (axis, t, b) = (axes[c], axes[(c + 1) % 3], axes[(c + 2) % 3]);
            let (disk_r, h) = cubic_sample(radius, u1);
            let disk_pdf = cubic_pdf(radius, disk_r);
            if !(disk_pdf > 0.0) {
                continue;
            }
            let phi = std::f32::consts::TAU * u0;
            let org = g.p + axis * h + (t * phi.cos() + b * phi.sin()) * disk_r;
            // A uniform choice of MAX_HITS among all hits (reservoir sampling).
            let mut hits = [Hit { tri: 0, t: 0.0, b1: 0.0, b2: 0.0 }; MAX_HITS];
            let mut count = 0usize;
            q.local_hits(org, -axis, 2.0 * h, object, u32::MAX, &mut |hit| {
                count += 1;
                if count <= MAX_HITS {
                    hits[count - 1] = hit;
                } else {
                    let j = (rng.next() * count as f32) as usize;
                    if j < MAX_HITS {
                        hits[j] = hit;
                    }
                }
                true
            });
            let more = if count > MAX_HITS { count as f32 / MAX_HITS as f32 } else { 1.0 };
            for hit in &hits[..count.min(MAX_HITS)] {
                let Some(&[i0, i1, i2]) = m.triangles.get(hit.tri as usize) else { continue };
                let [p0, p1, p2] = [i0, i1, i2].map(|i| m.positions[i as usize]);
                let b0 = 1.0 - hit.b1 - hit.b2;
                let hit_p = p0 * b0 + p1 * hit.b1 + p2 * hit.b2;
                let hit_ng = (p1 - p0).cross(p2 - p0).normalize_or_zero();
                let smooth = match (m.normals.get(i0 as usize), m.normals.get(i1 as usize), m.normals.get(i2 as usize))
                {
                    (Some(&n0), Some(&n1), Some(&n2)) => (n0 * b0 + n1 * hit.b1 + n2 * hit.b2).normalize_or(hit_ng),
                    _ => hit_ng,
                };
                // Multiple importance over the three axes (power heuristic; the chosen
                // axis' density cancels against the estimator's).
                let pdf = |k: usize| PICK[k] * axes[k].dot(hit_ng).abs();
                let (pa, pb, pc) = (pdf(0), pdf(1), pdf(2));
                let denom = pa * pa + pb * pb + pc * pc;
                if !(denom > 0.0) {
                    continue;
                }
                let w = pdf(c) / denom * more * cubic_pdf(radius, (hit_p - g.p).length()) / disk_pdf;
                sum += w * smooth;
            }
        }
        // The hits' normals are their mesh's (outward); the result faces the viewer as `g.n`.
        match sum.try_normalize() {
            Some(n) if g.backfacing => -n,
            Some(n) => n,
            None => g.n,
        }
    }
}

/// Cycles' cubic falloff of the bevel's probe radius: 10 (R − r)³ / (π R⁵) within R, the
/// planar density of the probe's disk radius.
fn cubic_pdf(radius: f32, r: f32) -> f32 {
    if r >= radius {
        return 0.0;
    }
    let f = radius - r;
    10.0 * f * f * f / (radius * radius * radius * radius * radius * std::f32::consts::PI)
}

/// A disk radius r with density `cubic_pdf` from uniform `xi`, and the height h of the
/// sphere of radius R above it (h² + r² = R²). The radial CDF in x = r / R is
/// 10x² − 20x³ + 15x⁴ − 4x⁵, inverted by Newton's method from x = ¼ (Cycles' root finder:
/// tolerance 10⁻⁶, at most ten steps, clamped to [0, 1]).
fn cubic_sample(radius: f32, xi: f32) -> (f32, f32) {
    let mut x = 0.25f32;
    for _ in 0..10 {
        let (x2, nx) = (x * x, 1.0 - x);
        let f = 10.0 * x2 - 20.0 * x2 * x + 15.0 * x2 * x2 - 4.0 * x2 * x2 * x - xi;
        let df = 20.0 * x * nx * nx * nx;
        if f.abs() < 1e-6 || df == 0.0 {
            break;
        }
        x = (x - f / df).clamp(0.0, 1.0);
    }
    let r = x * radius;
    (r, (radius * radius - r * r).max(0.0).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sampled radii follow the cubic falloff: the fraction within R/2 is the CDF at ½,
    /// 10/4 − 20/8 + 15/16 − 4/32 = 0.8125.
    #[test]
    fn cubic_sample_follows_its_density() {
        let n = 20_000;
        let inside = (0..n).filter(|&i| cubic_sample(2.0, (i as f32 + 0.5) / n as f32).0 < 1.0).count();
        assert!((inside as f32 / n as f32 - 0.8125).abs() < 1e-3, "{inside}");
        // And the density integrates to 1 over the disk: ∫ 2π r pdf(r) dr.
        let steps = 10_000;
        let integral: f32 = (0..steps)
            .map(|i| {
                let r = 2.0 * (i as f32 + 0.5) / steps as f32;
                std::f32::consts::TAU * r * cubic_pdf(2.0, r) * 2.0 / steps as f32
            })
            .sum();
        assert!((integral - 1.0).abs() < 1e-3, "{integral}");
    }

    #[test]
    fn streams_are_uniform_and_seeds_differ() {
        let mut s = Stream::new(7, 3);
        let mean = (0..10_000).map(|_| s.next()).sum::<f32>() / 10_000.0;
        assert!((mean - 0.5).abs() < 0.01, "{mean}");
        assert_ne!(seed_of(Vec3::X, Vec3::Y, 0), seed_of(Vec3::X, Vec3::Y, 1));
        assert_ne!(seed_of(Vec3::X, Vec3::Y, 0), seed_of(Vec3::new(1.0, 1e-7, 0.0), Vec3::Y, 0));
    }
}
