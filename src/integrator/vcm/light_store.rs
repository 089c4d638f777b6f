//! The light pass's subpaths kept for the camera pass's connections, so that each light
//! subpath is traced once per iteration (for the grid and for its pixel's connections).
//!
//! A BDPT vertex is most of a kilobyte, nearly all of it the BSDF (`size_of::<Bsdf>()`);
//! stored for every pixel that would be gigabytes at full HD. A stored vertex keeps
//! everything but the BSDF and the shading frame, which the camera pass rebuilds by
//! shading the stored hit again from the stored direction: shading is a pure function of
//! the hit, the direction and the sample's time (which the light and camera passes share),
//! so the rebuilt vertex is the traced one bit for bit, at the cost of a shading call
//! instead of a ray and a shading call.

use crate::integrator::SceneContext;
use crate::integrator::bdpt::vertex::{Kind, Vertex};
use crate::light::origin::LightPoint;
use crate::math::Rgb;
use crate::medium::MediumStack;
use crate::scene::shading::SurfaceHit;
use glam::Vec3;

/// A light subpath vertex without its BSDF and shading frame (see the module's doc).
#[derive(Clone, Copy, Debug)]
pub(crate) struct StoredVertex {
    kind: Kind,
    p: Vec3,
    ng: Vec3,
    hit: Option<SurfaceHit>,
    wo: Vec3,
    beta: Rgb,
    pdf_fwd: f32,
    pdf_rev: f32,
    delta: bool,
    /// At a contact (`bdpt::contact`): the connections' trap weight and the MIS read it.
    contact: bool,
    medium: MediumStack,
    light: Option<LightPoint>,
    /// The bounces its light subpath counted before it (`bdpt::bounces`).
    classes: crate::integrator::bdpt::bounces::Classes,
}

/// One light subpath per pixel of a row, in one flat array reused across iterations.
#[derive(Debug, Default)]
pub(crate) struct RowSubpaths {
    /// Every subpath's vertices, pixel after pixel.
    verts: Vec<StoredVertex>,
    /// Pixel i's subpath is `verts[starts[i]..starts[i + 1]]`.
    starts: Vec<u32>,
    /// The light vertex cache's entries of this row (`VertexCache`): each connectible vertex
    /// z_{s-1}, s ≥ 2, as the range of its subpath's prefix z₀ … z_{s-1} in `verts`.
    cached: Vec<(u32, u32)>,
}

impl RowSubpaths {
    /// Forgets the previous iteration's subpaths (keeping the memory).
    pub(crate) fn clear(&mut self) {
        self.verts.clear();
        self.starts.clear();
        self.starts.push(0);
        self.cached.clear();
    }

    /// Appends the next pixel's subpath.
    pub(crate) fn push(&mut self, light: &[Vertex]) {
        let start = self.verts.len() as u32;
        // The cache holds what a connection s, t ≥ 2 can join: a light vertex past the light
        // point whose BSDF is not all delta, not at a contact after a scattering
        // (`BdptIntegrator::connect_vertices`' own tests).
        for (i, v) in light.iter().enumerate().skip(1) {
            if v.bsdf.is_some_and(|b| !b.is_delta()) && !(v.contact && i > 1) {
                self.cached.push((start, start + i as u32 + 1));
            }
        }
        self.verts.extend(light.iter().map(|v| {
            // Only surfaces have a BSDF, and every surface vertex has one: the rebuilt
            // vertex takes it from shading `hit`.
            debug_assert_eq!(v.bsdf.is_some(), v.hit.is_some());
            StoredVertex {
                kind: v.kind,
                p: v.p,
                ng: v.ng,
                hit: v.hit,
                wo: v.wo,
                beta: v.beta,
                pdf_fwd: v.pdf_fwd,
                pdf_rev: v.pdf_rev,
                delta: v.delta,
                contact: v.contact,
                medium: v.medium,
                light: v.light,
                classes: v.classes,
            }
        }));
        self.starts.push(self.verts.len() as u32);
    }

    /// Rebuilds pixel `i`'s subpath (i counted from the row's first pixel) into `out`,
    /// as `BdptIntegrator::light_subpath` left it.
    pub(crate) fn restore(&self, ctx: &SceneContext, i: usize, out: &mut Vec<Vertex>) {
        out.clear();
        let (a, b) = (self.starts[i] as usize, self.starts[i + 1] as usize);
        out.extend(self.verts[a..b].iter().map(|s| s.rebuild(ctx, true)));
    }

    /// Rebuilds the prefix `verts[a..b]` of a cached entry into `out`: only its last vertex
    /// is shaded, as a connection reads the BSDF of the vertex it joins alone (the others
    /// give their densities, positions and flags).
    fn restore_prefix(&self, ctx: &SceneContext, (a, b): (u32, u32), out: &mut Vec<Vertex>) {
        out.clear();
        let prefix = &self.verts[a as usize..b as usize];
        let last = prefix.len() - 1;
        out.extend(prefix.iter().enumerate().map(|(j, s)| s.rebuild(ctx, j == last)));
    }
}

impl StoredVertex {
    /// The vertex as traced; with `shaded` false a surface vertex gets no BSDF, frame or hit.
    fn rebuild(&self, ctx: &SceneContext, shaded: bool) -> Vertex {
        let mut v = match self.hit {
            Some(hit) if shaded => Vertex::surface(&hit, &ctx.shade(&hit, self.wo), self.wo, self.beta, self.medium),
            _ => Vertex::new(self.kind, self.p),
        };
        v.kind = self.kind;
        v.p = self.p;
        v.ng = self.ng;
        v.wo = self.wo;
        v.beta = self.beta;
        v.pdf_fwd = self.pdf_fwd;
        v.pdf_rev = self.pdf_rev;
        v.delta = self.delta;
        v.contact = self.contact;
        v.medium = self.medium;
        v.light = self.light;
        v.classes = self.classes;
        v
    }
}

/// The light vertex cache of one iteration (after Davidovič et al. 2014, "Progressive light
/// transport simulation on the GPU: survey and improvements", §4.1): every connectible
/// vertex z_{s-1} (s ≥ 2) of the iteration's light subpaths. A camera vertex joins one of
/// them picked uniformly, with probability k = min(1, L̄) (L̄ the cache's vertices per light
/// subpath, measured by VCM's pilot), instead of every vertex of its own pixel's light
/// subpath: a camera vertex costs at most one connection however long the light subpaths
/// are, and no more than BDPT's L̄ where they are short. The MIS counts these connections
/// as c = k / L̄ samples per camera sample (`bdpt::mis::PathDensities::connect_share`), and
/// a pick is weighted by M c / (k f N) (M cached vertices from f N light subpaths expected):
/// over the pick its expectation is the weighted sum of the connections to every cached
/// vertex over f N, an unbiased estimate of the weighted connections to one light subpath.
pub(crate) struct VertexCache<'a> {
    rows: &'a [RowSubpaths],
    /// Entries before each row's end (a running sum over `rows`).
    ends: Vec<u32>,
    /// The probability k that a camera vertex picks a vertex.
    pick: f32,
    /// What a connection to a picked vertex is multiplied by.
    scale: f32,
}

impl<'a> VertexCache<'a> {
    /// The cache over `rows` for `light_paths` light subpaths expected (f N), picked with
    /// probability `pick`, whose connections count `connect_share` samples in the weights.
    pub(crate) fn new(rows: &'a [RowSubpaths], light_paths: f32, (connect_share, pick): (f32, f32)) -> Self {
        let mut total = 0u32;
        let ends = rows
            .iter()
            .map(|r| {
                total += r.cached.len() as u32;
                total
            })
            .collect();
        let scale = total as f32 * connect_share / (pick * light_paths);
        VertexCache { rows, ends, pick, scale: if scale.is_finite() { scale } else { 0.0 } }
    }

    /// Cached vertices (M).
    pub(crate) fn len(&self) -> u32 {
        self.ends.last().copied().unwrap_or(0)
    }

    /// The entry `u` in [0, 1) picks (none with probability 1 - k, else uniformly over the
    /// M entries): its row and range.
    fn locate(&self, u: f32) -> Option<(usize, (u32, u32))> {
        let m = self.len();
        if m == 0 || u >= self.pick {
            return None;
        }
        let g = ((u / self.pick * m as f32) as u32).min(m - 1);
        let row = self.ends.partition_point(|&e| e <= g);
        let before = if row > 0 { self.ends[row - 1] } else { 0 };
        Some((row, self.rows[row].cached[(g - before) as usize]))
    }
}

impl crate::integrator::bdpt::LightVertexCache for VertexCache<'_> {
    fn pick(&self, ctx: &SceneContext, u: f32, max_s: usize, out: &mut Vec<Vertex>) -> usize {
        let Some((row, entry)) = self.locate(u) else { return 0 };
        let s = (entry.1 - entry.0) as usize;
        if s > max_s {
            return 0;
        }
        self.rows[row].restore_prefix(ctx, entry, out);
        s
    }

    fn scale(&self) -> f32 {
        self.scale
    }
}

/// Bytes one stored vertex takes (for the memory budget).
pub const VERTEX_BYTES: u64 = std::mem::size_of::<StoredVertex>() as u64;

/// Bytes one light vertex cache entry takes (for the memory budget).
pub const CACHE_ENTRY_BYTES: u64 = std::mem::size_of::<(u32, u32)>() as u64;

#[cfg(test)]
mod tests {
    use super::*;

    /// Each cached vertex is picked with probability k / M whatever the rows' sizes (empty
    /// rows too), and a pick weighs M c / (k f N), so that over the pick each vertex's
    /// connection counts c / (f N): what makes the cache's estimate unbiased.
    #[test]
    fn picks_are_uniform_and_weighted_by_the_cache_size() {
        let sizes = [3u32, 0, 1, 7, 0, 2];
        let rows: Vec<RowSubpaths> = sizes
            .iter()
            .enumerate()
            .map(|(r, &n)| RowSubpaths {
                cached: (0..n).map(|i| (100 * r as u32, 100 * r as u32 + i + 2)).collect(),
                ..Default::default()
            })
            .collect();
        let (light_paths, c) = (5.0f32, 0.4f32);
        let m: u32 = sizes.iter().sum();
        for k in [1.0f32, 0.25] {
            let cache = VertexCache::new(&rows, light_paths, (c, k));
            assert_eq!(cache.len(), m);
            assert!((cache.scale - m as f32 * c / (k * light_paths)).abs() < 1e-6);
            // Stratified u: every entry exactly as often, none for a share 1 - k.
            let per = 1000u32;
            let draws = (per as f32 * m as f32 / k) as u32;
            let mut counts = std::collections::HashMap::new();
            let mut misses = 0;
            for i in 0..draws {
                match cache.locate((i as f32 + 0.5) / draws as f32) {
                    Some(e) => *counts.entry(e).or_insert(0u32) += 1,
                    None => misses += 1,
                }
            }
            assert_eq!(misses, draws - per * m, "k {k}");
            assert_eq!(counts.len(), m as usize);
            for ((row, entry), n) in counts {
                assert_eq!(n, per, "k {k}: row {row} entry {entry:?}");
                assert!(rows[row].cached.contains(&entry));
            }
            assert!(cache.locate(0.0).is_some());
        }
        let empty = [RowSubpaths::default(), RowSubpaths::default()];
        let none = VertexCache::new(&empty, light_paths, (c, 1.0));
        assert!(none.locate(0.5).is_none() && none.scale == 0.0);
    }
}
