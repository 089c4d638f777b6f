//! A heterogeneous medium on a voxel grid: Blender's volume object with its Principled
//! Volume. Density (and optionally temperature and colour) are trilinear in the voxels,
//! whose centres sit at integer index coordinates (OpenVDB's convention, which Cycles'
//! default Linear interpolation reads), zero beyond the grid. The coefficients at a point
//! are Cycles' (`svm_node_principled_volume`):
//!
//! * d = Density × max(density grid, 0) (zero under Cycles' closure cutoff),
//! * σs = colour × d, colour = Color × colour grid,
//! * σa = max(1 − colour, 0) × max(1 − √Absorption Color, 0) × d (a negative colour read as 0),
//! * E = Emission Strength × Emission Color + blackbody(T) × tint × σ/π·lerp(1, T⁴,
//!   Blackbody Intensity), T = Temperature × max(temperature grid, 0) — not scaled by
//!   the density, as in Cycles. Cycles reads grids by stochastic one-tap lookups (one
//!   voxel picked with its trilinear weight); for everything linear in the grid that is
//!   trilinear interpolation in the mean, and the blackbody term, non-linear in T, is
//!   blended from the voxels' emission to have the same mean.
//!
//! A coarse majorant grid (cells of [`CELL`] voxels) bounds the extinction for the
//! tracking in `tracking.rs`. What it does not do: Cycles bounds a volume object by the
//! hull of its active voxels; here the domain is the grid's whole box, which differs only
//! where uniform Emission Strength glows in inactive space.

use super::Phase;
use super::blackbody::{CLOSURE_WEIGHT_CUTOFF, blackbody_emission, blackbody_scale};
pub use super::coefficients::{PointCoefficients, VolumeShader};
use crate::math::Rgb;
use glam::{Affine3A, Vec3};

/// Voxels per majorant cell along each axis: small enough that a cell's bound is close
/// to the density it covers, large enough that the cell walk costs little.
pub const CELL: u32 = 8;

/// A scalar or RGB field on the voxel grid.
#[derive(Clone, Debug)]
pub struct Field {
    /// Values, x fastest, `components` per voxel.
    pub values: Vec<f32>,
    /// 1 or 3.
    pub components: u32,
}

/// A grid medium in the scene: fields, transform, shader and majorant grid.
#[derive(Clone, Debug)]
pub struct GridMedium {
    /// The volume object's name, for messages.
    pub name: String,
    /// Voxels per axis.
    pub dims: [u32; 3],
    /// World → index space (voxel centres at integers).
    pub index_from_world: Affine3A,
    /// Index → world.
    pub world_from_index: Affine3A,
    /// Density (None: 1 everywhere in the domain, a volume shader that reads no grid).
    pub density: Option<Field>,
    /// Temperature, if the shader reads one.
    pub temperature: Option<Field>,
    /// Colour, if the shader reads one.
    pub color: Option<Field>,
    /// The shader.
    pub shader: VolumeShader,
    /// The working space its blackbody colour is given in (Rec.709 until the loader sets it).
    pub space: crate::scene::working_space::WorkingSpace,
    /// Phase function.
    pub phase: Phase,
    /// Majorant cells per axis.
    pub cells: [u32; 3],
    /// Per cell, a bound of max-channel σt (or the emission floor) over the cell; for a
    /// procedural medium, a sampled estimate (`procedural.rs`).
    pub majorant: Vec<f32>,
    /// The node-graph program that gives the coefficients instead of the fields and shader.
    pub procedural: Option<Box<super::procedural_source::ProceduralSource>>,
    /// The world's textured volume: the medium fills all space, the box being where it is
    /// tracked point by point; outside it a ray sees the coefficients of the box point where
    /// it enters or leaves (`tracking.rs`, `Piece`).
    pub unbounded: bool,
    /// An unbounded grid's majorant beyond its box, where rays follow the graph for a while
    /// (`tracking.rs`): the largest cell's, a sampled estimate of the graph's range.
    pub outer_majorant: f32,
}

impl Field {
    /// The value at voxel (x, y, z), component `c`; zero outside the grid.
    #[inline]
    pub(crate) fn at(&self, dims: [u32; 3], x: i64, y: i64, z: i64, c: usize) -> f32 {
        if x < 0 || y < 0 || z < 0 || x >= dims[0] as i64 || y >= dims[1] as i64 || z >= dims[2] as i64 {
            return 0.0;
        }
        let i =
            (x as usize + dims[0] as usize * (y as usize + dims[1] as usize * z as usize)) * self.components as usize;
        self.values[i + c]
    }

    /// Trilinear value at index-space point `p` (up to three components; a scalar field
    /// repeats its value).
    #[inline]
    pub fn trilinear(&self, dims: [u32; 3], p: Vec3) -> Vec3 {
        let f = p.floor();
        let (fx, fy, fz) = (p.x - f.x, p.y - f.y, p.z - f.z);
        let (x0, y0, z0) = (f.x as i64, f.y as i64, f.z as i64);
        let n = self.components as usize;
        let mut out = [0.0f32; 3];
        for (c, o) in out.iter_mut().enumerate().take(n) {
            let v = |dx: i64, dy: i64, dz: i64| self.at(dims, x0 + dx, y0 + dy, z0 + dz, c);
            let x00 = v(0, 0, 0) + (v(1, 0, 0) - v(0, 0, 0)) * fx;
            let x10 = v(0, 1, 0) + (v(1, 1, 0) - v(0, 1, 0)) * fx;
            let x01 = v(0, 0, 1) + (v(1, 0, 1) - v(0, 0, 1)) * fx;
            let x11 = v(0, 1, 1) + (v(1, 1, 1) - v(0, 1, 1)) * fx;
            let y0 = x00 + (x10 - x00) * fy;
            let y1 = x01 + (x11 - x01) * fy;
            *o = y0 + (y1 - y0) * fz;
        }
        if n == 1 { Vec3::splat(out[0]) } else { Vec3::from(out) }
    }

    /// Σ wᵢ f(vᵢ) over the eight voxels around index-space point `p` with their trilinear
    /// weights (first component): the expectation of Cycles' stochastic one-tap lookup
    /// (Pharr et al., "Stochastic Texture Filtering"), which a non-linear `f` of the value
    /// (the blackbody's T⁴) needs to match.
    #[inline]
    pub fn trilinear_of(&self, dims: [u32; 3], p: Vec3, f: impl Fn(f32) -> Rgb) -> Rgb {
        let fl = p.floor();
        let t = p - fl;
        let (x0, y0, z0) = (fl.x as i64, fl.y as i64, fl.z as i64);
        let mut sum = Rgb::ZERO;
        for corner in 0..8 {
            let (dx, dy, dz) = ((corner & 1) as i64, (corner >> 1 & 1) as i64, (corner >> 2 & 1) as i64);
            let w = if dx == 1 { t.x } else { 1.0 - t.x }
                * if dy == 1 { t.y } else { 1.0 - t.y }
                * if dz == 1 { t.z } else { 1.0 - t.z };
            if w > 0.0 {
                sum += w * f(self.at(dims, x0 + dx, y0 + dy, z0 + dz, 0));
            }
        }
        sum
    }

    /// Largest value of component-maximum over voxels [lo, hi] (inclusive, clamped to the grid).
    fn max_over(&self, dims: [u32; 3], lo: [i64; 3], hi: [i64; 3]) -> f32 {
        let mut m = f32::NEG_INFINITY;
        for z in lo[2].max(0)..=hi[2].min(dims[2] as i64 - 1) {
            for y in lo[1].max(0)..=hi[1].min(dims[1] as i64 - 1) {
                for x in lo[0].max(0)..=hi[0].min(dims[0] as i64 - 1) {
                    for c in 0..self.components as usize {
                        m = m.max(self.at(dims, x, y, z, c));
                    }
                }
            }
        }
        // Beyond the grid the field is zero, and a cell reaching there sees that zero.
        let outside = (0..3).any(|a| lo[a] < 0 || hi[a] >= dims[a] as i64);
        if outside { m.max(0.0) } else { m }
    }
}

impl GridMedium {
    /// A grid medium over `dims` voxels placed by `world_from_index`, with its fields
    /// and shader; builds the majorant grid.
    pub fn new(
        name: String,
        dims: [u32; 3],
        world_from_index: Affine3A,
        fields: [Option<Field>; 3],
        shader: VolumeShader,
    ) -> GridMedium {
        let [density, temperature, color] = fields;
        let cells = dims.map(|d| (d + 1).div_ceil(CELL) + 1);
        let mut g = GridMedium {
            name,
            dims,
            index_from_world: world_from_index.inverse(),
            world_from_index,
            density,
            temperature,
            color,
            shader,
            space: Default::default(),
            phase: Phase::hg(shader.anisotropy),
            cells,
            majorant: Vec::new(),
            procedural: None,
            unbounded: false,
            outer_majorant: 0.0,
        };
        g.majorant = g.build_majorant();
        g
    }

    /// The domain in index space: one voxel beyond the outer voxel centres on each side,
    /// where trilinear interpolation has faded to the zero background.
    #[inline]
    pub fn domain(&self) -> (Vec3, Vec3) {
        (Vec3::splat(-1.0), Vec3::new(self.dims[0] as f32, self.dims[1] as f32, self.dims[2] as f32))
    }

    /// The domain's eight corners in world space (the box the loader bounds the medium with).
    pub fn world_corners(&self) -> [Vec3; 8] {
        let (lo, hi) = self.domain();
        std::array::from_fn(|i| {
            let c = Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            self.world_from_index.transform_point3(c)
        })
    }

    /// σt's per-channel factor on the density for colour `col`: col + max(1 − col, 0)·a.
    #[inline]
    fn extinction_factor(&self, col: Rgb) -> Rgb {
        col + (Rgb::ONE - col).max(Rgb::ZERO) * self.absorption_factor()
    }

    /// max(1 − √Absorption Color, 0).
    #[inline]
    fn absorption_factor(&self) -> Rgb {
        (Rgb::ONE - self.shader.absorption_color.max(Rgb::ZERO).map(f32::sqrt)).max(Rgb::ZERO)
    }

    /// The coefficients at index-space point `p` (emission left zero unless `with_emission`:
    /// shadow rays need only the extinction).
    #[inline]
    pub fn coefficients(&self, p: Vec3, with_emission: bool) -> PointCoefficients {
        if let Some(src) = &self.procedural {
            return src.coefficients(self.world_from_index.transform_point3(p), with_emission);
        }
        let sh = &self.shader;
        let mut d = sh.density.max(0.0);
        if d > CLOSURE_WEIGHT_CUTOFF
            && let Some(f) = &self.density
        {
            d = (d * f.trilinear(self.dims, p).x).max(0.0);
        }
        let (mut sigma_a, mut sigma_s) = (Rgb::ZERO, Rgb::ZERO);
        if d > CLOSURE_WEIGHT_CUTOFF {
            let col = match &self.color {
                Some(f) => sh.color * f.trilinear(self.dims, p),
                None => sh.color,
            }
            // A negative colour would scatter negatively; Cycles' grids are colours ≥ 0.
            .max(Rgb::ZERO);
            sigma_s = col * d;
            sigma_a = (Rgb::ONE - col).max(Rgb::ZERO) * self.absorption_factor() * d;
        }
        if !with_emission {
            return PointCoefficients { sigma_a, sigma_s, emission: Rgb::ZERO };
        }
        let mut emission = if sh.emission.max_element() > CLOSURE_WEIGHT_CUTOFF { sh.emission } else { Rgb::ZERO };
        if sh.blackbody_intensity > CLOSURE_WEIGHT_CUTOFF {
            // Not clamped: Cycles keeps the fit's negative channels (colours outside Rec.709,
            // below about 980 K in green) in a volume's emission.
            let glow = |t: f32| {
                blackbody_emission(sh.temperature * t.max(0.0), sh.blackbody_intensity, sh.blackbody_tint, &self.space)
            };
            emission += match &self.temperature {
                // Cycles looks the temperature up stochastically (one voxel, picked with its
                // trilinear weight), so its mean emission is the blend of the voxels' emission,
                // not the emission of the blended temperature.
                Some(f) => f.trilinear_of(self.dims, p, glow),
                None => glow(1.0),
            };
        }
        PointCoefficients { sigma_a, sigma_s, emission }
    }

    /// Index-space bounds of majorant cell (cx, cy, cz).
    #[inline]
    fn cell_bounds(&self, cx: u32, cy: u32, cz: u32) -> (Vec3, Vec3) {
        let lo = Vec3::new(cx as f32, cy as f32, cz as f32) * CELL as f32 - 1.0;
        (lo, lo + CELL as f32)
    }

    /// Per cell: the largest max-channel σt any point of the cell can have (density and
    /// colour bounded separately over the voxels whose trilinear support reaches the
    /// cell), raised to an emission floor where the cell can emit, so that the tracking
    /// visits emitting space that does not attenuate.
    fn build_majorant(&self) -> Vec<f32> {
        let sh = &self.shader;
        let [nx, ny, nz] = self.cells;
        // One collision per cell crossing, on average, where only emission needs visiting.
        let voxel = (0..3).map(|a| self.world_from_index.matrix3.col(a).length()).fold(f32::INFINITY, f32::min);
        let emission_floor = 1.0 / (CELL as f32 * voxel.max(1e-30));
        let mut out = Vec::with_capacity((nx * ny * nz) as usize);
        for cz in 0..nz {
            for cy in 0..ny {
                for cx in 0..nx {
                    let (lo, hi) = self.cell_bounds(cx, cy, cz);
                    let vlo = [lo.x.floor() as i64, lo.y.floor() as i64, lo.z.floor() as i64];
                    let vhi = [hi.x.ceil() as i64, hi.y.ceil() as i64, hi.z.ceil() as i64];
                    let d = sh.density.max(0.0)
                        * self.density.as_ref().map_or(1.0, |f| f.max_over(self.dims, vlo, vhi).max(0.0));
                    let col_max = match &self.color {
                        Some(f) => sh.color * f.max_over(self.dims, vlo, vhi).max(0.0),
                        None => sh.color,
                    };
                    // σt's factor col + max(1 − col, 0)·a increases with the colour (a ≤ 1),
                    // so the colour's bound bounds it.
                    let k = self.extinction_factor(col_max.max(Rgb::ZERO)).max_element();
                    let mut m = d * k;
                    let hot = match &self.temperature {
                        Some(f) => sh.temperature * f.max_over(self.dims, vlo, vhi).max(0.0),
                        None => sh.temperature,
                    };
                    let emits = sh.emission.max_element() > CLOSURE_WEIGHT_CUTOFF
                        || (sh.blackbody_intensity > CLOSURE_WEIGHT_CUTOFF
                            && blackbody_scale(hot.max(0.0), sh.blackbody_intensity) > CLOSURE_WEIGHT_CUTOFF);
                    if emits {
                        m = m.max(emission_floor);
                    }
                    // Rounding in the trilinear blend can exceed the corner maximum by an
                    // ulp or so; a relative margin keeps σt ≤ majorant.
                    out.push(m * (1.0 + 1e-5));
                }
            }
        }
        out
    }

    /// The phase function at world point `p`, a scattering point: a procedural medium's
    /// graph can vary its Anisotropy (read there; outside an unbounded medium's box, at the
    /// nearest box point), other media have one phase function.
    #[inline]
    pub fn phase_at(&self, p: Vec3) -> Phase {
        match &self.procedural {
            Some(src) if src.volume.phase_pair.is_some() => {
                let (lo, hi) = self.domain();
                let q = self.index_from_world.transform_point3(p).clamp(lo, hi);
                src.phase_at(self.world_from_index.transform_point3(q))
            }
            Some(src) if src.volume.anisotropy_reg.is_some() => {
                let (lo, hi) = self.domain();
                let q = self.index_from_world.transform_point3(p).clamp(lo, hi);
                self.phase.with_anisotropy(src.anisotropy_at(self.world_from_index.transform_point3(q)))
            }
            _ => self.phase,
        }
    }

    /// True when the shader emits anywhere (Emission Strength or blackbody).
    pub fn may_emit(&self) -> bool {
        self.shader.emission.max_element() > CLOSURE_WEIGHT_CUTOFF
            || self.shader.blackbody_intensity > CLOSURE_WEIGHT_CUTOFF
    }

    /// The majorant of cell (cx, cy, cz).
    #[inline]
    pub fn cell_majorant(&self, c: [u32; 3]) -> f32 {
        self.majorant[(c[0] + self.cells[0] * (c[1] + self.cells[1] * c[2])) as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(crate) fn shader(density: f32) -> VolumeShader {
        VolumeShader {
            density,
            color: Rgb::new(0.8, 0.5, 0.2),
            absorption_color: Rgb::new(0.25, 0.0, 1.0),
            anisotropy: 0.3,
            emission: Rgb::ZERO,
            blackbody_intensity: 0.0,
            blackbody_tint: Rgb::ONE,
            temperature: 1000.0,
        }
    }

    /// Trilinear lookup reproduces a linear field exactly inside the voxel centres and
    /// fades to zero one voxel beyond them.
    #[test]
    fn trilinear_is_exact_on_linear_fields() {
        let dims = [4, 3, 5];
        let values = (0..60).map(|i| (i % 4) as f32 + 2.0 * ((i / 4) % 3) as f32 + 3.0 * (i / 12) as f32).collect();
        let f = Field { values, components: 1 };
        let p = Vec3::new(1.25, 0.5, 3.75);
        assert!((f.trilinear(dims, p).x - (1.25 + 1.0 + 11.25)).abs() < 1e-5);
        assert_eq!(f.trilinear(dims, Vec3::new(-1.0, 1.0, 1.0)).x, 0.0);
        let half_out = f.trilinear(dims, Vec3::new(-0.5, 0.0, 0.0)).x;
        assert!((half_out - 0.0).abs() < 1e-6, "the corner voxel is 0 here");
    }

    /// The coefficients are Cycles' Principled Volume, and the majorant bounds σt at
    /// random points of a random field.
    #[test]
    fn coefficients_and_majorant_bound() {
        let dims = [9, 7, 12];
        let n = 9 * 7 * 12;
        let mut rng = super::super::WalkRng::new(0.3, 7);
        let density = Field { values: (0..n).map(|_| rng.next_f32() * 3.0).collect(), components: 1 };
        let color = Field { values: (0..3 * n).map(|_| rng.next_f32() * 1.5).collect(), components: 3 };
        let g = GridMedium::new(
            "test".into(),
            dims,
            Affine3A::from_scale(Vec3::splat(0.1)),
            [Some(density), None, Some(color)],
            shader(2.0),
        );
        for _ in 0..20_000 {
            let p = Vec3::new(rng.next_f32() * 11.0 - 1.0, rng.next_f32() * 9.0 - 1.0, rng.next_f32() * 14.0 - 1.0);
            let c = g.coefficients(p, true);
            let cell = (p + 1.0) / CELL as f32;
            let m = g.cell_majorant([cell.x as u32, cell.y as u32, cell.z as u32]);
            assert!(
                (c.sigma_a + c.sigma_s).max_element() <= m,
                "σt {} over majorant {m} at {p}",
                c.sigma_a + c.sigma_s
            );
        }
        // A voxel centre: σs = colour·d, σa = (1 − colour)(1 − √a)·d.
        let plain = GridMedium::new(
            "plain".into(),
            [1, 1, 1],
            Affine3A::IDENTITY,
            [Some(Field { values: vec![0.5], components: 1 }), None, None],
            shader(2.0),
        );
        let c = plain.coefficients(Vec3::ZERO, true);
        assert!((c.sigma_s - Rgb::new(0.8, 0.5, 0.2)).abs().max_element() < 1e-6);
        assert!((c.sigma_a - Rgb::new(0.2 * 0.5, 0.5, 0.0)).abs().max_element() < 1e-6);
    }
}
