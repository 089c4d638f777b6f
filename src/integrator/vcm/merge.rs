//! Vertex merging: the light subpaths' vertices stored for range search, and the merge
//! at each camera vertex with every stored vertex within the radius.

use super::grid::HashGrid;
use super::mis::{Recursion, Side, merge_weight};
use crate::film::CameraSample;
use crate::integrator::SceneContext;
use crate::integrator::bdpt::Ledger;
use crate::integrator::bdpt::bounces::Verdict;
use crate::integrator::bdpt::mis::MIN_MERGE_VERTEX;
use crate::integrator::bdpt::passes::First;
use crate::integrator::bdpt::vertex::Vertex;
use crate::light::origin as lights;
use crate::math::Rgb;
use crate::scene::Scene;
use glam::Vec3;

/// A light subpath vertex as merging needs it (a non-delta surface vertex z_m,
/// m ≥ `MIN_MERGE_VERTEX`).
#[derive(Clone, Copy, Debug)]
pub struct MergeRecord {
    /// Position.
    pub p: Vec3,
    /// Unit direction toward the previous vertex of its light subpath.
    pub wo: Vec3,
    /// Geometric normal (either side).
    pub ng: Vec3,
    /// Light throughput arriving here divided by the densities (BDPT's `beta`).
    pub beta: Rgb,
    /// The light subpath's share of the merge weight.
    pub side: Side,
    /// |cos| at the previous vertex toward this one / distance²: turns the camera
    /// vertex's solid-angle density toward the previous vertex into an area density.
    pub g: f32,
    /// Vertex index m on its light subpath (m - 1 scattering events before it).
    pub m: u32,
    /// The light its subpath started at (light groups).
    pub light: u32,
    /// The bounces its light subpath counts before it (`bdpt::bounces`).
    pub(crate) classes: crate::integrator::bdpt::bounces::Classes,
}

/// What one iteration's merging needs: the stored vertices, their grid, and the constants.
#[derive(Debug, Default)]
pub struct MergeMap {
    /// Every light subpath's merge records (in the grid's bucket order after `build`).
    pub records: Vec<MergeRecord>,
    /// The records in the order they were added (scratch of `build`).
    unsorted: Vec<MergeRecord>,
    /// The records' positions, in the same order: the query's distance tests read 12
    /// bytes a record from here, not a 72-byte record (its loads were the query's cost).
    positions: Vec<Vec3>,
    /// The records' grid.
    pub grid: HashGrid,
    /// The merging radius r_i.
    pub radius: f32,
    /// η = f N π r² (f N: light subpaths of the iteration, expected).
    pub eta: f32,
    /// f: light subpaths per camera sample (`PathDensities::light_share`).
    pub light_share: f32,
    /// 1 / (f N π r²): the kernel's normalisation.
    pub norm: f32,
}

impl MergeMap {
    /// Sets the radius of this iteration for `n` camera samples each with a light subpath
    /// of probability `light_share`, rebuilds the grid and puts the records in its bucket
    /// order.
    pub fn build(&mut self, radius: f32, n: u64, light_share: f32) {
        self.radius = radius;
        self.light_share = light_share;
        let area = std::f32::consts::PI * radius * radius;
        self.eta = light_share * n as f32 * area;
        self.norm = 1.0 / self.eta;
        self.grid.build(self.records.iter().map(|r| r.p), radius);
        std::mem::swap(&mut self.records, &mut self.unsorted);
        self.records.clear();
        self.records.extend(self.grid.order().iter().map(|&i| self.unsorted[i as usize]));
        self.positions.clear();
        self.positions.extend(self.records.iter().map(|r| r.p));
    }
}

/// Appends to `out` the merge records of one light subpath (`light`, BDPT's vertices from
/// the light point on), with η and f (`MergeMap`) of this iteration for the recursive weights.
pub(crate) fn push_records(scene: &Scene, light: &[Vertex], (eta, share): (f32, f32), out: &mut Vec<MergeRecord>) {
    let Some(lp) = light.first().and_then(|v| v.light) else {
        return;
    };
    // A camera ray from z₁ at a contact cannot find the light (`bdpt::contact`): no s = 0.
    let hittable = !lights::is_delta(scene, lp.light as usize) && !light.get(1).is_some_and(|v| v.contact);
    let mut rec = Recursion::start(eta, share, light[0].pdf_fwd, !light[0].delta, Some(hittable));
    for i in 1..light.len() {
        let v = &light[i];
        if i >= MIN_MERGE_VERTEX && v.bsdf.is_some() && !v.specular {
            out.push(MergeRecord {
                p: v.p,
                wo: v.wo,
                ng: v.ng,
                beta: v.beta,
                side: rec.side(v.pdf_fwd),
                g: light[i - 1].area_density(1.0, v.p),
                m: i as u32,
                classes: v.classes,
                light: lp.light,
            });
        }
        if i + 1 < light.len() {
            rec.push(v.pdf_fwd, !v.delta, light[i - 1].pdf_rev, i >= MIN_MERGE_VERTEX);
        }
    }
}

/// Merges every camera vertex of `cam` (BDPT's camera subpath: the camera, then surface
/// vertices) with the stored light vertices within the radius; returns the weighted sum.
/// `camera_connectible`: light subpaths can reach the camera (not orthographic);
/// `max_depth` bounds the merged paths' scattering events.
/// With `passes`, each merge is also filed into the camera sample's light passes and light
/// groups (`bdpt::passes`; the class of the first bounce of `cam` when it is not the merge's).
pub(crate) fn merge_camera_path(
    cam: &[Vertex],
    map: &MergeMap,
    camera_connectible: bool,
    max_depth: u32,
    limits: &crate::integrator::light_paths::LightPaths,
    mut passes: Option<(&SceneContext, Ledger, First, &mut CameraSample)>,
) -> Rgb {
    let mut total = Rgb::ZERO;
    let mut rec = Recursion::start(map.eta, map.light_share, 0.0, camera_connectible, None);
    for c in 1..cam.len() {
        if c >= 2 {
            let prev = &cam[c - 1];
            // Beyond any merge's light vertex (m ≥ 2): merging is a strategy there.
            rec.push(prev.pdf_fwd, !prev.delta, cam[c - 2].pdf_rev, true);
        }
        // Scattering events of a merged path: m - 1 on the light side, this vertex, c - 1.
        if c as u32 > max_depth {
            break;
        }
        let x = &cam[c];
        // A restricted camera prefix: its paths are the camera side's (`bdpt::visibility`,
        // `bdpt::bounces`); past the bounce limits, none goes on.
        if x.restricted || x.spent {
            continue;
        }
        // By reference: a BSDF is 672 bytes, and most camera vertices merge nothing.
        let (Some(bsdf), Some(hit)) = (&x.bsdf, &x.hit) else { continue };
        // Nothing merges at a contact: light arrives there only straight from its light
        // (`bdpt::contact`), which merging never carries.
        if x.specular || x.contact {
            continue;
        }
        let cam_side = rec.side(x.pdf_fwd);
        // Area density factor of the camera-side predecessor seen from this vertex.
        let g_prev = cam[c - 1].area_density(1.0, x.p);
        let wo_l = x.frame.to_local(x.wo);
        // The view-side terms (layer albedos, lobe weights) the vertex keeps: f and the
        // camera side's own density share them.
        let at = bsdf.bind(&x.view);
        let m_max = max_depth + 1 - c as u32;
        let vertex = c;
        let mut sum = Rgb::ZERO;
        map.grid.for_each_within(
            x.p,
            |i| map.positions[i as usize],
            |i| {
                let y = &map.records[i as usize];
                // Another surface within r (an edge, a corner, a face seen at a grazing
                // angle) is not this one: its light is not merged here (SPPM's 60° rule, on
                // either side so that light a thin surface transmits still merges). As
                // r → 0 only points of the same surface remain, so the weights, which
                // assume merging can make every path through a non-delta vertex, stay right.
                if y.m > m_max {
                    return;
                }
                let c = y.ng.dot(hit.ng);
                if c * c < 0.25 {
                    return;
                }
                // Light Paths' bounce limits (`bdpt::bounces`): the merged vertex (m ≥ 2) counts.
                if !x.classes_toward(y.wo).plus(y.classes).verdict(limits).eq(&Verdict::Kept) {
                    return;
                }
                let wi_l = x.frame.to_local(y.wo);
                let cos_g = y.wo.dot(hit.ng);
                // The light arrived on the side the BSDF says it did.
                if at.above(wi_l) != (cos_g > 0.0) {
                    return;
                }
                let f = at.eval(wi_l);
                if f == Rgb::ZERO {
                    return;
                }
                // Photon flux is per unit area across the geometric normal; the BSDF's
                // cosine is the shading normal's: |wi·ns| / |wi·ng| (bounded as BDPT's
                // shading-normal correction is).
                let shading = (wi_l.z.abs() / cos_g.abs()).min(10.0);
                let b_prev = at.pdf(wi_l) * y.g;
                let a_next = bsdf.pdf(wi_l, wo_l) * g_prev;
                let w = merge_weight(map.eta, y.side, b_prev, cam_side, a_next);
                sum += f * y.beta * (shading * w);
                if let Some((ctx, ledger, first, out)) = passes.as_mut() {
                    // Scattering events: this vertex and the c - 1 before it, m - 1 on the light side.
                    let first = match (vertex, ledger.light_passes) {
                        (1, true) => {
                            let (d, g) = crate::integrator::light_passes::shares_at(&at, wi_l);
                            First::Surface(d, g)
                        }
                        _ => *first,
                    };
                    let contribution = x.beta * f * y.beta * (shading * w * map.norm);
                    let group = ledger.group_of_light(ctx, y.light as usize);
                    ledger.file(out, vertex + y.m as usize - 1, first, false, group, contribution);
                }
            },
        );
        total += x.beta * sum * map.norm;
    }
    total
}
