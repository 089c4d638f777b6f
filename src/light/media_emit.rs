//! Emitting media as photon sources: the World Volume's emission, volume objects' grids
//! (Emission Strength, blackbody fire) and homogeneous media with emission inside meshes.
//!
//! A medium of emission E (radiance per unit length, Blender's and Cycles' unit, which
//! `advance` integrates along camera rays as ∫ Tr E ds) emits E dV dω isotropically, so
//! its power is Φ = 4π ∫ E dV. A photon starts at a point x drawn with volume density
//! p(x) in the medium's bounded region, flies in a uniform direction (density 1/4π), and
//! carries 4π E(x) / (p(x) p_m N), p_m the medium's selection probability and N the photons
//! emitted: the sum over photons estimates Φ without bias for any p that is positive where
//! E is. The transmittance on the way is the photon tracer's free flights.
//!
//! | medium | region | p(x) |
//! |---|---|---|
//! | homogeneous in a mesh | the box of the mesh's triangles; a point outside the mesh carries nothing (the tracer's inside test) | uniform in the box |
//! | world fog, homogeneous | the box of the textured world fog (`procedural::world_fog_medium`): surfaces, cameras and lights, grown by half on each side | uniform in the box |
//! | its light from beyond the box | the box's faces | uniform by area, cosine-weighted inward |
//! | grid (volume object, textured fog in a mesh or the world) | the grid's domain, clipped majorant cells | a cell by a bound of its emission × its volume, uniform in the cell |
//!
//! A voxel grid's cell bound is the largest emission at the voxels whose trilinear support
//! reaches the cell (the emission at a point is a convex blend of theirs), so it holds;
//! a procedural grid's is sampled at the cell's lattice points, doubled, with a floor of a
//! hundredth of the mean so that no emitting cell has density 0.
//!
//! The homogeneous world fog beyond its box meets no surface (the box holds them all), so
//! the radiance its emission sends into the box before any scattering is E/σt exactly:
//! photons enter through the box's faces, cosine-weighted inward, carrying π A E/σt in all
//! (A the box's area). Photons that leave the box fly on in the fog and may scatter back.
//!
//! Left out: the light a scattering world fog emits beyond its box and scatters there
//! before it enters (nothing for a fog that only absorbs), and a textured world fog's
//! light from beyond its box (its held stretches), which reaches surfaces straight (the
//! camera side's rays run to infinity) but not after a scattering or a bounce.

use crate::math::{Rgb, luminance};
use crate::medium::grid::CELL;
use crate::medium::{GridMedium, MediumStack};
use crate::sampling::Distribution1D;
use crate::sampling::warp::{cosine_hemisphere, uniform_sphere};
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::f32::consts::PI;

/// Where one emitting medium's photons start.
#[derive(Clone, Debug)]
enum Region {
    /// Constant emission `e` uniform in the box [lo, hi].
    Uniform { lo: Vec3, hi: Vec3, e: Rgb },
    /// Grid `grid`'s index-space cells, drawn by `dist`; `det` turns index volume into world volume.
    Grid { grid: u32, cells: Vec<(Vec3, Vec3)>, dist: Distribution1D, det: f32 },
    /// The faces of the box [lo, hi], radiance `l` entering through them (cosine-weighted
    /// inward): the unbounded fog's light from beyond the box before it scatters there.
    Inflow { lo: Vec3, hi: Vec3, l: Rgb },
}

/// One emitting medium: its region and the mesh material whose inside holds it (None: the world's).
#[derive(Clone, Debug)]
struct Source {
    region: Region,
    material: Option<u32>,
}

/// A photon leaving an emitting medium.
#[derive(Clone, Copy, Debug)]
pub struct MediumPhoton {
    /// Where it starts.
    pub org: Vec3,
    /// Unit direction of travel.
    pub dir: Vec3,
    /// Power (W).
    pub power: Rgb,
    /// The media it starts in.
    pub media: MediumStack,
    /// The mesh material it must be inside (the tracer's test: the first surface along
    /// `dir` is that material's, left from inside); None for the world's fog.
    pub inside: Option<u32>,
}

/// The scene's emitting media as photon sources, chosen by their power.
#[derive(Clone, Debug, Default)]
pub struct MediaEmitters {
    sources: Vec<Source>,
    /// Estimated power of each source (luminance, W).
    power: Vec<f32>,
    dist: Option<Distribution1D>,
    total: f32,
}

impl MediaEmitters {
    /// Every emitting medium of `scene` with its power.
    pub fn new(scene: &Scene) -> Self {
        let mut sources = Vec::new();
        let mut power = Vec::new();
        let mut add = |region: Region, material: Option<u32>, watts: f32| {
            if watts > 0.0 && watts.is_finite() {
                sources.push(Source { region, material });
                power.push(watts);
            }
        };
        if let Some(m) = scene.world_medium.as_ref().filter(|m| m.emission != Rgb::ZERO) {
            let (lo, hi) = world_fog_box(scene);
            let v = (hi - lo).element_product();
            add(Region::Uniform { lo, hi, e: m.emission }, None, 4.0 * PI * luminance(m.emission).abs() * v);
            // Beyond the box the fog meets no surface (the box holds them all), so the light
            // its emission there sends into the box before any scattering is exactly E/σt
            // (the loader refuses emission in a channel σt leaves at 0).
            let l = m.emission / m.sigma_t();
            if l.is_finite() {
                add(Region::Inflow { lo, hi, l }, None, PI * luminance(l).abs() * box_area(lo, hi));
            }
        }
        if let Some(g) = scene.world_grid.filter(|&g| scene.grids[g as usize].may_emit()) {
            let (region, watts) = grid_region(scene, g);
            add(region, None, watts);
        }
        for (i, mat) in scene.materials.iter().enumerate() {
            let i = i as u32;
            if let Some(g) = mat.grid {
                if scene.grids[g as usize].may_emit() {
                    let (region, watts) = grid_region(scene, g);
                    add(region, Some(i), watts);
                }
            } else if let Some(m) = mat.medium.as_ref().filter(|m| m.emission != Rgb::ZERO) {
                let Some((lo, hi, volume)) = mesh_box(scene, i) else { continue };
                add(
                    Region::Uniform { lo, hi, e: m.emission },
                    Some(i),
                    4.0 * PI * luminance(m.emission).abs() * volume,
                );
            }
        }
        let total = power.iter().map(|&p| p as f64).sum::<f64>() as f32;
        let dist = (!power.is_empty()).then(|| Distribution1D::new(&power));
        MediaEmitters { sources, power, dist, total }
    }

    /// Sum of the sources' estimated power (luminance, W); 0 when no medium emits.
    pub fn total_luminance(&self) -> f32 {
        self.total
    }

    /// Emits one photon: `u_source` picks the medium, `u_cell` a grid's cell, `u_pos` the
    /// point and `u_dir` the direction; `scale` is 1 / (the media's share of the photons × N).
    #[inline]
    pub fn emit(
        &self,
        scene: &Scene,
        u_source: f32,
        u_cell: f32,
        u_pos: Vec3,
        u_dir: Vec2,
        scale: f32,
    ) -> Option<MediumPhoton> {
        let (index, pmf, _) = self.dist.as_ref()?.sample(u_source);
        if !(pmf > 0.0) {
            return None;
        }
        let source = &self.sources[index];
        let (org, power) = match &source.region {
            Region::Uniform { lo, hi, e } => {
                let v = (*hi - *lo).element_product();
                (*lo + (*hi - *lo) * u_pos, *e * (4.0 * PI * v * scale / pmf))
            }
            Region::Grid { grid, cells, dist, det } => {
                let g = &scene.grids[*grid as usize];
                let (c, p_cell, _) = dist.sample(u_cell);
                if !(p_cell > 0.0) {
                    return None;
                }
                let (lo, hi) = cells[c];
                let q = lo + (hi - lo) * u_pos;
                let e = g.coefficients(q, true).emission;
                let v = (hi - lo).element_product() * det;
                (g.world_from_index.transform_point3(q), e * (4.0 * PI * v * scale / (pmf * p_cell)))
            }
            Region::Inflow { lo, hi, l } => {
                let (org, dir) = box_inflow(*lo, *hi, u_cell, u_pos, u_dir);
                let power = *l * (PI * box_area(*lo, *hi) * scale / pmf);
                return (power != Rgb::ZERO && power.is_finite()).then_some(MediumPhoton {
                    org,
                    dir,
                    power,
                    media: MediumStack::default(),
                    inside: None,
                });
            }
        };
        if power == Rgb::ZERO || !power.is_finite() {
            return None;
        }
        let mut media = MediumStack::default();
        if let Some(m) = source.material {
            media.enter(m);
        }
        Some(MediumPhoton { org, dir: uniform_sphere(u_dir), power, media, inside: source.material })
    }

    /// Estimated power of each source (luminance, W), for reports.
    pub fn powers(&self) -> &[f32] {
        &self.power
    }
}

/// True when some medium of `scene` emits (the media [`MediaEmitters::new`] looks at).
pub fn any(scene: &Scene) -> bool {
    let glows = |m: &crate::medium::HomogeneousMedium| m.emission != Rgb::ZERO;
    scene.world_medium.as_ref().is_some_and(glows)
        || scene.world_grid.is_some_and(|g| scene.grids[g as usize].may_emit())
        || scene.materials.iter().any(|m| match m.grid {
            Some(g) => scene.grids[g as usize].may_emit(),
            None => m.medium.as_ref().is_some_and(glows),
        })
}

/// The box the world's fog emits photons from: the one `procedural::world_fog_medium`
/// tracks the textured fog in (the surfaces, the cameras and every light with a place,
/// grown by half its extent on each side).
pub fn world_fog_box(scene: &Scene) -> (Vec3, Vec3) {
    let (lo, hi) = scene.bounds;
    let geometryless = scene.mesh.triangles.is_empty() && scene.curves.is_empty() && scene.points.is_empty();
    let (lo, hi) = crate::scene::bounds::world_fog(lo, hi, geometryless, &scene.cameras, &scene.lights);
    let grow = (hi - lo).max(Vec3::splat(1e-3)) * 0.5;
    (lo - grow, hi + grow)
}

/// Surface area of the box [lo, hi].
fn box_area(lo: Vec3, hi: Vec3) -> f32 {
    let d = hi - lo;
    2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
}

/// A point on the faces of the box [lo, hi] (a face by its area with `u_face`, uniform on it
/// with `u_pos`) and a cosine-weighted direction into the box (`u_dir`): density
/// cos θ / (π A) per unit area and solid angle.
#[inline]
fn box_inflow(lo: Vec3, hi: Vec3, u_face: f32, u_pos: Vec3, u_dir: Vec2) -> (Vec3, Vec3) {
    let d = hi - lo;
    let areas = [d.y * d.z, d.y * d.z, d.z * d.x, d.z * d.x, d.x * d.y, d.x * d.y];
    let total: f32 = areas.iter().sum();
    let mut u = u_face * total;
    let mut face = 5;
    for (i, a) in areas.iter().enumerate() {
        if u < *a {
            face = i;
            break;
        }
        u -= a;
    }
    let axis = face / 2;
    let mut p = lo + d * u_pos;
    // Face 2k is the low side of axis k (inward normal +axis), 2k + 1 the high side.
    let (at, sign) = if face % 2 == 0 { (lo[axis], 1.0) } else { (hi[axis], -1.0) };
    p[axis] = at;
    let mut n = Vec3::ZERO;
    n[axis] = sign;
    (p, crate::math::Frame::from_normal(n).to_world(cosine_hemisphere(u_dir)))
}

/// The box of the triangles of material `m` and the volume they enclose (the divergence
/// theorem's sum; the box's volume where that is not positive, as for an open mesh).
fn mesh_box(scene: &Scene, m: u32) -> Option<(Vec3, Vec3, f32)> {
    let mesh = &scene.mesh;
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    let mut signed = 0.0f64;
    for (t, tri) in mesh.triangles.iter().enumerate() {
        if mesh.tri_material[t] != m {
            continue;
        }
        let p = tri.map(|i| mesh.positions[i as usize]);
        for q in p {
            (lo, hi) = (lo.min(q), hi.max(q));
        }
        signed += p[0].as_dvec3().dot(p[1].as_dvec3().cross(p[2].as_dvec3())) / 6.0;
    }
    let v_box = (hi - lo).element_product();
    if !(v_box > 0.0) || !v_box.is_finite() {
        return None;
    }
    let v = signed.abs() as f32;
    Some((lo, hi, if v > 0.0 && v <= v_box { v } else { v_box }))
}

/// Grid `g`'s cells (index space, clipped to its domain) with the distribution that draws
/// them, and its estimated power.
fn grid_region(scene: &Scene, g: u32) -> (Region, f32) {
    let grid = &scene.grids[g as usize];
    let (dlo, dhi) = grid.domain();
    let n = ((dhi - dlo) / CELL as f32).ceil().max(Vec3::ONE);
    let [nx, ny, nz] = [n.x as u32, n.y as u32, n.z as u32];
    let cells: Vec<(Vec3, Vec3)> = (0..nx * ny * nz)
        .map(|i| {
            let c = Vec3::new((i % nx) as f32, (i / nx % ny) as f32, (i / (nx * ny)) as f32);
            let lo = dlo + c * CELL as f32;
            (lo, (lo + Vec3::splat(CELL as f32)).min(dhi))
        })
        .collect();
    // Per cell: a bound of |E| and the mean luminance over the points looked at.
    let stats: Vec<(f32, f32)> = cells.par_iter().map(|&(lo, hi)| cell_emission(grid, lo, hi)).collect();
    let det = grid.world_from_index.matrix3.determinant().abs();
    let volume = |c: &(Vec3, Vec3)| (c.1 - c.0).element_product();
    let mut weights: Vec<f32> = stats.iter().zip(&cells).map(|(s, c)| s.0 * volume(c)).collect();
    if grid.procedural.is_some() {
        // A sampled bound may miss a peak: doubled, and a floor so that every cell can be drawn.
        let mean = weights.iter().map(|&w| w as f64).sum::<f64>() as f32 / weights.len() as f32;
        for (w, c) in weights.iter_mut().zip(&cells) {
            *w = 2.0 * *w + 0.01 * mean * volume(c) / (CELL * CELL * CELL) as f32;
        }
    }
    let watts = 4.0 * PI * det * stats.iter().zip(&cells).map(|(s, c)| (s.1 * volume(c)) as f64).sum::<f64>() as f32;
    (Region::Grid { grid: g, cells, dist: Distribution1D::new(&weights), det }, watts)
}

/// Lattice points looked at per cell axis in a procedural grid (as its majorant's).
const LATTICE: u32 = 5;

/// (bound of the largest |E| channel, mean luminance of E) over the cell [lo, hi] of
/// `grid` (index space): a voxel grid's at the voxels whose trilinear support reaches
/// the cell (a bound), a procedural one's at a lattice of points (an estimate).
fn cell_emission(grid: &GridMedium, lo: Vec3, hi: Vec3) -> (f32, f32) {
    let (dlo, dhi) = grid.domain();
    let (mut bound, mut sum, mut count) = (0.0f32, 0.0f64, 0u32);
    let mut look = |q: Vec3| {
        let e = grid.coefficients(q, true).emission;
        bound = bound.max(e.abs().max_element());
        sum += luminance(e) as f64;
        count += 1;
    };
    if grid.procedural.is_some() {
        for k in 0..LATTICE * LATTICE * LATTICE {
            let t = Vec3::new((k % LATTICE) as f32, (k / LATTICE % LATTICE) as f32, (k / (LATTICE * LATTICE)) as f32)
                / (LATTICE - 1) as f32;
            look(lo + (hi - lo) * t);
        }
    } else {
        let (a, b) = (lo.floor().max(dlo), hi.ceil().min(dhi));
        for z in a.z as i64..=b.z as i64 {
            for y in a.y as i64..=b.y as i64 {
                for x in a.x as i64..=b.x as i64 {
                    look(Vec3::new(x as f32, y as f32, z as f32));
                }
            }
        }
    }
    (bound, if count > 0 { (sum / count as f64).max(0.0) as f32 } else { 0.0 })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::grid::{Field, VolumeShader};
    use crate::medium::{HomogeneousMedium, WalkRng};
    use crate::scene::material::Material;
    use glam::Affine3A;

    /// The photons' mean power over N draws and its standard error, per channel.
    fn photon_sum(scene: &Scene, n: u32) -> (glam::DVec3, glam::DVec3) {
        let media = MediaEmitters::new(scene);
        let mut rng = WalkRng::new(0.25, 7);
        let (mut sum, mut sq) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
        for i in 0..n {
            let u_cell = (i as f32 + rng.next_f32()) / n as f32;
            let u_pos = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let u_dir = Vec2::new(rng.next_f32(), rng.next_f32());
            // Power per photon as if it were the only one (scale 1): its mean is Φ.
            let p = media.emit(scene, rng.next_f32(), u_cell, u_pos, u_dir, 1.0).map_or(Rgb::ZERO, |m| m.power);
            let p = p.as_dvec3();
            sum += p;
            sq += p * p;
        }
        let mean = sum / n as f64;
        let var = ((sq / n as f64 - mean * mean) / (n as f64 - 1.0)).max(glam::DVec3::ZERO);
        (mean, glam::DVec3::new(var.x.sqrt(), var.y.sqrt(), var.z.sqrt()))
    }

    /// A volume object's fire: the photons' power averages 4π ∫ E dV, with ∫ E dV exact (E is
    /// trilinear in each unit cell of index space between voxel centres, so its integral there
    /// is the mean of the cell's corners), within 5 standard errors per channel.
    #[test]
    fn grid_photons_carry_the_emitted_power() {
        let dims = [4u32, 3, 5];
        let temps: Vec<f32> = (0..60).map(|i| 0.3 + ((i * 7) % 11) as f32 * 0.15).collect();
        let shader = VolumeShader {
            density: 0.5,
            color: Rgb::splat(0.8),
            absorption_color: Rgb::ZERO,
            anisotropy: 0.0,
            emission: Rgb::new(0.1, 0.2, 0.05),
            blackbody_intensity: 1.0,
            blackbody_tint: Rgb::ONE,
            temperature: 1000.0,
        };
        let place =
            Affine3A::from_translation(Vec3::new(1.0, -2.0, 0.5)) * Affine3A::from_scale(Vec3::new(0.3, 0.2, 0.25));
        let temperature = Field { values: temps, components: 1 };
        let grid = GridMedium::new("fire".into(), dims, place, [None, Some(temperature), None], shader);
        let det = grid.world_from_index.matrix3.determinant().abs() as f64;
        let mut exact = glam::DVec3::ZERO;
        for z in -1..dims[2] as i32 {
            for y in -1..dims[1] as i32 {
                for x in -1..dims[0] as i32 {
                    for c in 0..8 {
                        let q = Vec3::new((x + (c & 1)) as f32, (y + (c >> 1 & 1)) as f32, (z + (c >> 2 & 1)) as f32);
                        exact += grid.coefficients(q, true).emission.as_dvec3() / 8.0;
                    }
                }
            }
        }
        exact *= 4.0 * std::f64::consts::PI * det;
        let scene = Scene {
            grids: vec![grid],
            materials: vec![Material {
                medium: Some(HomogeneousMedium::absorbing(Rgb::ZERO)),
                grid: Some(0),
                ..Material::default()
            }],
            ..Scene::default()
        };
        let (mean, se) = photon_sum(&scene, 400_000);
        for c in 0..3 {
            assert!((mean[c] - exact[c]).abs() <= 5.0 * se[c], "channel {c}: {} ± {} vs {}", mean[c], se[c], exact[c]);
        }
    }

    /// The world's glowing fog (grey): its box emits 4π E V and its faces let in π A E/σt
    /// (the fog beyond them); by power both shares give every photon that sum exactly.
    #[test]
    fn world_fog_photons_carry_the_box_power() {
        let e = Rgb::new(0.3, 0.2, 0.1);
        let scene = Scene {
            world_medium: Some(HomogeneousMedium { emission: e, ..HomogeneousMedium::absorbing(Rgb::splat(0.5)) }),
            // At least 2 units a side, so that the floor a scene without geometry gets
            // (`scene::bounds::world_fog`) leaves it as it is.
            bounds: (Vec3::new(-1.0, 0.0, -2.0), Vec3::new(1.0, 2.0, 2.0)),
            ..Scene::default()
        };
        let (lo, hi) = world_fog_box(&scene);
        assert_eq!((lo, hi), (Vec3::new(-2.0, -1.0, -4.0), Vec3::new(2.0, 3.0, 4.0)));
        let (mean, se) = photon_sum(&scene, 1000);
        // The grown box is 4 × 4 × 8: volume 128, area 160.
        let want = e.as_dvec3() * (4.0 * std::f64::consts::PI * 128.0 + std::f64::consts::PI * 160.0 / 0.5);
        assert!((mean - want).abs().max_element() < 1e-4 * want.max_element(), "{mean} vs {want}");
        assert!(se.max_element() < 1e-4 * want.max_element(), "photons of unequal power: {se}");
    }
}
