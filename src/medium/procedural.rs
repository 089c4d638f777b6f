//! A medium whose coefficients come from a node graph (a Principled Volume whose Density,
//! colour or emission is fed by textures, ColorRamps, Math...): the material's
//! [`VolumeProgram`] is run at each point the tracking looks up, as Cycles runs a volume
//! shader per point. It is carried by a [`GridMedium`] (`GridMedium::procedural`) whose
//! box covers the triangles of the material, so that the cell walk, the trackers and the
//! integrators treat it as any grid.
//!
//! The majorant cannot be proven for an arbitrary graph (a Noise texture has no closed-form
//! bound), so the trackers are the variants that stay unbiased when σt exceeds it
//! (`tracking.rs`: signed null-collision weights in spectral tracking, Kutz et al. 2017,
//! and ratio tracking without clamping, Novák et al. 2014). The majorant is only a guess
//! that keeps the weights near [0, 1]: per cell, the largest σt at a lattice of points
//! times [`MAJORANT_MARGIN`], and never below one expected collision per cell crossing, so
//! that no cell, however empty it looked, is skipped (a cell with μ = 0 would be).
//! A path's throughput can then turn negative: the path tracer's roulette reads its
//! magnitude; BDPT's and the photon tracer's read its largest channel and end such a path
//! (a bias confined to where σt exceeded the sampled majorant).

use super::coefficients::VolumeShader;
use super::grid::{CELL, GridMedium};
use super::procedural_source::ProceduralSource;
use crate::math::Rgb;
use glam::{Affine3A, Vec3};
use rayon::prelude::*;

/// Voxel-index extent of the box along each axis: 16 majorant cells of [`CELL`] (the
/// program is evaluated at any point; the "voxels" only size the cells).
const DIMS: u32 = 16 * CELL - 1;

/// Factor on the largest σt found at a cell's lattice points: texture detail between the
/// points can exceed it (the trackers stay unbiased then, with some negative weights).
pub const MAJORANT_MARGIN: f32 = 1.5;

/// Lattice points per axis sampled in each majorant cell (corners included).
const LATTICE: u32 = 5;

/// The grid medium of material `name` over the world box [lo, hi] (padded by a small
/// fraction so that boundary triangles lie inside), evaluated by `source`; builds the
/// sampled majorant.
pub fn procedural_medium(name: String, lo: Vec3, hi: Vec3, source: ProceduralSource) -> GridMedium {
    let pad = (hi - lo).max(Vec3::splat(1e-4)) * 1e-3;
    let (lo, hi) = (lo - pad, hi + pad);
    // Index −1 ↦ lo, index DIMS ↦ hi (the grid's domain, `GridMedium::domain`).
    let world_from_index = Affine3A::from_translation(lo)
        * Affine3A::from_scale((hi - lo) / (DIMS + 1) as f32)
        * Affine3A::from_translation(Vec3::ONE);
    let anisotropy = source.volume.anisotropy;
    let shader = VolumeShader {
        density: 1.0,
        color: Rgb::ONE,
        absorption_color: Rgb::ZERO,
        anisotropy,
        emission: Rgb::ZERO,
        blackbody_intensity: 0.0,
        blackbody_tint: Rgb::ONE,
        temperature: 0.0,
    };
    let mut g = GridMedium::new(name, [DIMS; 3], world_from_index, [None, None, None], shader);
    g.phase = source.volume.phase;
    g.procedural = Some(Box::new(source));
    let (majorant, emits) = sampled_majorant(&g);
    g.majorant = majorant;
    if emits {
        // `may_emit` reads the shader: mark the medium as emitting somewhere.
        g.shader.emission = Rgb::ONE;
    }
    g
}

/// The world's textured volume (Blender's World Volume with a node graph): a procedural
/// grid medium over the box [lo, hi] of the scene's surfaces and cameras, grown on each side
/// by half its extent so that paths leaving the scene still cross varying fog for a
/// while, marked `unbounded`: outside the box a free flight follows the graph for a while,
/// then holds the coefficients it reached (`tracking.rs`). Object and Generated coordinates are the
/// position, as Cycles gives them in a world volume (measured with Blender 5.0: a Gradient
/// on either matches one on the position).
pub fn world_fog_medium(lo: Vec3, hi: Vec3, source: ProceduralSource) -> GridMedium {
    let grow = (hi - lo).max(Vec3::splat(1e-3)) * 0.5;
    let mut g = procedural_medium("world".into(), lo - grow, hi + grow, source);
    g.unbounded = true;
    g.outer_majorant = g.majorant.iter().copied().fold(0.0, f32::max);
    g
}

/// Per cell: [`MAJORANT_MARGIN`] × the largest max-channel σt at the cell's lattice points,
/// at least one expected collision per cell crossing; and whether any point emits.
pub(super) fn sampled_majorant(g: &GridMedium) -> (Vec<f32>, bool) {
    let src = g.procedural.as_deref().expect("a procedural medium");
    let [nx, ny, nz] = g.cells;
    let cell_len =
        (0..3).map(|a| g.world_from_index.matrix3.col(a).length()).fold(f32::INFINITY, f32::min) * CELL as f32;
    let floor = 1.0 / cell_len.max(1e-30);
    // Cells in parallel (x fastest, the order `cell_majorant` reads): 125 program runs each.
    let cells: Vec<(f32, bool)> = (0..nx * ny * nz)
        .into_par_iter()
        .map(|i| {
            let (cx, cy, cz) = (i % nx, i / nx % ny, i / (nx * ny));
            let lo = Vec3::new(cx as f32, cy as f32, cz as f32) * CELL as f32 - 1.0;
            let (mut m, mut emits) = (0.0f32, false);
            for k in 0..LATTICE * LATTICE * LATTICE {
                let t =
                    Vec3::new((k % LATTICE) as f32, (k / LATTICE % LATTICE) as f32, (k / (LATTICE * LATTICE)) as f32)
                        / (LATTICE - 1) as f32;
                let c = src.coefficients(g.world_from_index.transform_point3(lo + t * CELL as f32), true);
                m = m.max((c.sigma_a + c.sigma_s).max_element());
                emits |= c.emission.abs().max_element() > 0.0;
            }
            ((m * MAJORANT_MARGIN).max(floor), emits)
        })
        .collect();
    (cells.iter().map(|c| c.0).collect(), cells.iter().any(|c| c.1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::tracking::{delta_tracking, ratio_tracking};
    use crate::medium::{FreeFlight, WalkRng};
    use crate::shader::compile::volume::compile_volume;
    use crate::shader::geom::ObjectData;
    use crate::shader::graph::NodesExt;
    use serde_json::json;

    /// A Principled Volume whose Density is 6 × a 3D Noise Texture (Scale 3, Detail 2) in
    /// object space, over the box [−1, 1]³.
    fn noise_medium() -> GridMedium {
        let ext: NodesExt = serde_json::from_value(json!({"version": 1, "nodes": [
            {"name": "Noise", "type": "ShaderNodeTexNoise", "props": {"noise_dimensions": "3D"},
             "inputs": {"Scale": {"value": 3.0}, "Detail": {"value": 2.0}}},
            {"name": "Math", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
             "inputs": {"Value": {"value": 0.5, "link": [0, "Fac"]}, "Value_001": {"value": 6.0}}},
            {"name": "PV", "type": "ShaderNodeVolumePrincipled",
             "inputs": {"Density": {"value": 1.0, "link": [1, "Value"]},
                        "Color": {"value": [0.8, 0.5, 0.3, 1.0]}}}],
            "output": {}}))
        .unwrap();
        let volume = compile_volume("noise", &ext, 2, &[], Default::default()).unwrap();
        let source = ProceduralSource { volume, object: ObjectData::default(), grids: None };
        procedural_medium("noise".into(), Vec3::splat(-1.0), Vec3::ONE, source)
    }

    /// ∫₀ᵗ f(s) ds by composite Simpson over `n` (even) intervals, in f64.
    fn simpson(t: f32, n: usize, f: impl Fn(f32) -> glam::DVec3) -> glam::DVec3 {
        let h = t as f64 / n as f64;
        let mut sum = f(0.0) + f(t);
        for i in 1..n {
            sum += f((i as f64 * h) as f32) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        sum * h / 3.0
    }

    /// Mean and standard error of `n` draws.
    fn mean_and_error(n: usize, mut draw: impl FnMut() -> Rgb) -> (glam::DVec3, glam::DVec3) {
        let (mut sum, mut sq) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
        for _ in 0..n {
            let x = draw().as_dvec3();
            sum += x;
            sq += x * x;
        }
        let mean = sum / n as f64;
        (mean, ((sq / n as f64 - mean * mean).max(glam::DVec3::ZERO) / n as f64).map(f64::sqrt))
    }

    /// Five standard errors: a true mean falls outside with probability under 6e-7 per channel.
    fn agrees(what: &str, (mean, err): (glam::DVec3, glam::DVec3), want: glam::DVec3) {
        for c in 0..3 {
            let bound = 5.0 * err[c] + 1e-6;
            assert!(
                (mean[c] - want[c]).abs() <= bound,
                "{what}, channel {c}: {} vs {} (bound {bound})",
                mean[c],
                want[c]
            );
        }
    }

    /// Transmittance through the noise medium along a ray: ratio tracking and delta
    /// tracking's pass weight average to exp(−∫σt) by quadrature, and its scatter weight to
    /// ∫σs·Tr; with the sampled majorant and with one cut to a fifth of it (σt then exceeds
    /// the majorant over most of the ray: the signed weights keep the means exact).
    #[test]
    fn tracking_is_unbiased_against_quadrature() {
        let mut g = noise_medium();
        let org = Vec3::new(-0.95, -0.3, 0.2);
        let dir = Vec3::new(1.0, 0.35, -0.1).normalize();
        let t_max = 1.7;
        let base = g.clone();
        let sigma = |s: f32| base.coefficients(base.index_from_world.transform_point3(org + dir * s), false);
        // 4000 Simpson intervals of 4e-4: the noise's finest octave (scale 6) varies over
        // ~0.1, so the quadrature error (h⁴ f⁗) is far below the Monte Carlo bound.
        let n = 4000;
        let tau = simpson(t_max, n, |s| {
            let c = sigma(s);
            (c.sigma_a + c.sigma_s).as_dvec3()
        });
        assert!(tau.min_element() > 0.5, "the ray must cross real density: τ = {tau}");
        let tr_at = |s: f32| {
            let tau_s = simpson(s, 200, |x| {
                let c = sigma(x);
                (c.sigma_a + c.sigma_s).as_dvec3()
            });
            (-tau_s).exp()
        };
        let scatter = simpson(t_max, 400, |s| sigma(s).sigma_s.as_dvec3() * tr_at(s));
        let tr = (-tau).exp();
        let sampled = g.majorant.clone();
        for (label, scale) in [("sampled majorant", 1.0f32), ("majorant / 5", 0.2)] {
            g.majorant = sampled.iter().map(|m| m * scale).collect();
            let mut rng = WalkRng::new(0.5, 17);
            agrees(label, mean_and_error(100_000, || ratio_tracking(&g, org, dir, t_max, &mut rng)), tr);
            let mut rng = WalkRng::new(0.25, 5);
            let (mut pass, mut scat) = (Vec::new(), Vec::new());
            for _ in 0..100_000 {
                let mut e = Rgb::ZERO;
                match delta_tracking(&g, org, dir, t_max, Rgb::ONE, &mut rng, &mut e).0 {
                    FreeFlight::Pass { weight } => {
                        pass.push(weight);
                        scat.push(Rgb::ZERO)
                    }
                    FreeFlight::Scatter { weight, .. } => {
                        pass.push(Rgb::ZERO);
                        scat.push(weight)
                    }
                }
            }
            let mut it = pass.iter();
            agrees(label, mean_and_error(pass.len(), || *it.next().unwrap()), tr);
            let mut it = scat.iter();
            agrees(label, mean_and_error(scat.len(), || *it.next().unwrap()), scatter);
        }
        // The sampled majorant bounds σt almost everywhere along the ray (margin 1.5).
        g.majorant = sampled;
        let over = (0..1000).filter(|&i| {
            let s = t_max * i as f32 / 1000.0;
            let p = g.index_from_world.transform_point3(org + dir * s);
            let cell = (p + 1.0) / CELL as f32;
            let m = g.cell_majorant([cell.x as u32, cell.y as u32, cell.z as u32]);
            (sigma(s).sigma_a + sigma(s).sigma_s).max_element() > m
        });
        assert!(over.count() < 10, "the sampled majorant is a poor guess");
    }

    /// The world's fog of `world_fog_medium`: a Principled Volume whose Density is
    /// 0.4 × Gradient (linear, on the position's x) over the scene box [−1, 1]³ (the fog's box
    /// grows to [−2, 2]³), with a constant emission 0.5. Its density is 0 for x ≤ 0 and 0.4 for
    /// x ≥ 1, so it is constant outside the box on every face it can be left through along
    /// the rays below, and the held stretches there are exact.
    fn gradient_fog() -> GridMedium {
        let ext: NodesExt = serde_json::from_value(json!({"version": 1, "nodes": [
            {"name": "Gradient", "type": "ShaderNodeTexGradient", "props": {"gradient_type": "LINEAR"}, "inputs": {}},
            {"name": "Math", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
             "inputs": {"Value": {"value": 0.5, "link": [0, "Fac"]}, "Value_001": {"value": 0.4}}},
            {"name": "PV", "type": "ShaderNodeVolumePrincipled",
             "inputs": {"Density": {"value": 1.0, "link": [1, "Value"]},
                        "Color": {"value": [0.8, 0.5, 0.3, 1.0]},
                        "Emission Strength": {"value": 0.5}}}],
            "output": {}}))
        .unwrap();
        let volume = compile_volume("fog", &ext, 2, &[], Default::default()).unwrap();
        let source = ProceduralSource { volume, object: crate::shader::geom::NO_OBJECT, grids: None };
        world_fog_medium(Vec3::splat(-1.0), Vec3::ONE, source)
    }

    /// Rays through the world's fog that start outside its box, leave it, or never meet it
    /// (beyond the box the graph is followed, then held where it is constant along them):
    /// ratio tracking, delta tracking's pass and scatter weights and its emission average to
    /// the closed-form field's quadrature (σt = 0.4 clamp(x, 0, 1) in every channel, σs = colour
    /// × that, E = 0.5); unbounded rays are exactly dark where the fog is dense at infinity and
    /// exactly clear where it is empty.
    #[test]
    fn world_fog_beyond_its_box() {
        let g = gradient_fog();
        assert!(g.unbounded);
        let col = glam::DVec3::new(0.8, 0.5, 0.3);
        let emission = 0.5f64;
        let rays = [
            ("leaves the box", Vec3::ZERO, Vec3::X, 6.0f32),
            ("enters then leaves", Vec3::new(5.0, 0.3, -0.2), Vec3::NEG_X, 7.5),
            ("misses the box", Vec3::new(3.0, 0.0, 0.0), Vec3::Y, 4.0),
            ("oblique, out through +x", Vec3::new(-0.5, 0.2, 0.1), Vec3::new(1.0, 0.4, -0.3).normalize(), 5.0),
            // Out through +y at x = 0.8, into fog that thickens beyond the box (to x = 1):
            // the graph followed there, which the boundary's held σt 0.32 missed.
            ("out through +y, thickening", Vec3::new(0.2, 0.0, 0.0), Vec3::new(0.3, 1.0, 0.0).normalize(), 6.0),
        ];
        for (label, org, dir, t_max) in rays {
            let density = |s: f32| 0.4 * (org.x + dir.x * s).clamp(0.0, 1.0) as f64;
            // 6000 Simpson intervals of ≤ 1.3e-3: the field has two kinks (x = 0 and 1),
            // where Simpson's error is O(h²) ≈ 2e-6, far below the Monte Carlo bounds.
            let n = 6000;
            let tau = |t: f32| simpson(t, n, |s| glam::DVec3::splat(density(s))).x;
            let tr = (-tau(t_max)).exp();
            let tr_at = |s: f32| (-simpson(s, 400, |x| glam::DVec3::splat(density(x))).x).exp();
            let scatter = simpson(t_max, 600, |s| col * density(s) * tr_at(s));
            let emitted = simpson(t_max, 600, |s| glam::DVec3::splat(emission * tr_at(s)));
            assert!(tr > 1e-3 && tr < 0.9, "{label}: the ray must cross some fog, and not too much: {tr}");
            let mut rng = WalkRng::new(0.5, 3);
            let want = glam::DVec3::splat(tr);
            agrees(label, mean_and_error(100_000, || ratio_tracking(&g, org, dir, t_max, &mut rng)), want);
            let mut rng = WalkRng::new(0.75, 9);
            let (mut pass, mut scat, mut glow) = (Vec::new(), Vec::new(), Vec::new());
            for _ in 0..100_000 {
                let mut e = Rgb::ZERO;
                match delta_tracking(&g, org, dir, t_max, Rgb::ONE, &mut rng, &mut e).0 {
                    FreeFlight::Pass { weight } => {
                        pass.push(weight);
                        scat.push(Rgb::ZERO)
                    }
                    FreeFlight::Scatter { weight, .. } => {
                        pass.push(Rgb::ZERO);
                        scat.push(weight)
                    }
                }
                glow.push(e);
            }
            let mut it = pass.iter();
            agrees(label, mean_and_error(pass.len(), || *it.next().unwrap()), want);
            let mut it = scat.iter();
            agrees(label, mean_and_error(scat.len(), || *it.next().unwrap()), scatter);
            let mut it = glow.iter();
            agrees(label, mean_and_error(glow.len(), || *it.next().unwrap()), emitted);
        }
        // Unbounded: into the dense side nothing passes, into the empty side everything.
        let mut rng = WalkRng::new(0.1, 1);
        assert_eq!(ratio_tracking(&g, Vec3::ZERO, Vec3::X, f32::INFINITY, &mut rng), Rgb::ZERO);
        assert_eq!(ratio_tracking(&g, Vec3::new(-0.5, 0.0, 0.0), Vec3::NEG_X, f32::INFINITY, &mut rng), Rgb::ONE);
        for _ in 0..100 {
            let mut e = Rgb::ZERO;
            let out =
                delta_tracking(&g, Vec3::new(-0.5, 0.0, 0.0), Vec3::NEG_X, f32::INFINITY, Rgb::ONE, &mut rng, &mut e);
            assert!(matches!(out.0, FreeFlight::Pass { weight } if weight == Rgb::ONE), "{:?}", out.0);
            // No attenuation, so the unbounded emission diverges and is left out.
            assert!(e.is_finite());
        }
    }

    /// An Image Texture on Generated coordinates feeds a Principled Volume's Density: the
    /// medium reads the program's own image (a 2 × 1 float image, 0.25 and 1.0, Closest,
    /// Extend) where Cycles maps Generated (here, with no texture space, the position in
    /// Blender's axes: u = x): σt = Density × (Color 0.5 + 0.5 × absorption factor 1).
    #[test]
    fn image_textured_density() {
        let ext: NodesExt = serde_json::from_value(json!({"version": 1, "nodes": [
            {"name": "Coords", "type": "ShaderNodeTexCoord", "inputs": {}},
            {"name": "Img", "type": "ShaderNodeTexImage",
             "props": {"image": 0, "interpolation": "Closest", "extension": "EXTEND"},
             "inputs": {"Vector": {"value": [0.0, 0.0, 0.0], "link": [0, "Generated"]}}},
            {"name": "PV", "type": "ShaderNodeVolumePrincipled",
             "inputs": {"Density": {"value": 1.0, "link": [1, "Color"]}}}],
            "output": {}}))
        .unwrap();
        let mut volume = compile_volume("img", &ext, 2, &[0], Default::default()).unwrap();
        volume.textures = vec![crate::scene::Texture {
            name: "density".into(),
            width: 2,
            height: 1,
            texels: Vec::new(),
            hdr: vec![glam::Vec4::new(0.25, 0.25, 0.25, 1.0), glam::Vec4::ONE],
            srgb: false,
            wrap_s: crate::scene::texture::Wrap::Repeat,
            wrap_t: crate::scene::texture::Wrap::Repeat,
            nearest: false,
            to_working: None,
            associated: false,
            mean: Vec3::ZERO,
        }];
        let source = ProceduralSource { volume, object: crate::shader::geom::NO_OBJECT, grids: None };
        let g = procedural_medium("img".into(), Vec3::ZERO, Vec3::ONE, source);
        for (x, want) in [(0.2f32, 0.25f32), (0.45, 0.25), (0.55, 1.0), (0.9, 1.0)] {
            let p = g.index_from_world.transform_point3(Vec3::new(x, 0.5, -0.3));
            let c = g.coefficients(p, false);
            let sigma_t = c.sigma_a + c.sigma_s;
            assert!((sigma_t - Rgb::splat(want)).abs().max_element() < 1e-6, "x = {x}: σt {sigma_t}, want {want}");
        }
    }

    /// A linked Anisotropy that varies (0.8 × Gradient on x over the box [0, 1]³): the phase
    /// function at a scattering point is the graph's there, clamped to the box outside it;
    /// the medium's own phase keeps the shader's value (0.1).
    #[test]
    fn anisotropy_varies_per_point() {
        let ext: NodesExt = serde_json::from_value(json!({"version": 1, "nodes": [
            {"name": "Gradient", "type": "ShaderNodeTexGradient", "props": {"gradient_type": "LINEAR"}, "inputs": {}},
            {"name": "Math", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
             "inputs": {"Value": {"value": 0.5, "link": [0, "Fac"]}, "Value_001": {"value": 0.8}}},
            {"name": "PV", "type": "ShaderNodeVolumePrincipled",
             "inputs": {"Density": {"value": 2.0}, "Anisotropy": {"value": 0.1, "link": [1, "Value"]}}}],
            "output": {}}))
        .unwrap();
        let volume = compile_volume("aniso", &ext, 2, &[], Default::default()).unwrap();
        assert!(volume.anisotropy_reg.is_some() && volume.warnings.is_empty(), "{:?}", volume.warnings);
        let source = ProceduralSource { volume, object: crate::shader::geom::NO_OBJECT, grids: None };
        let g = procedural_medium("aniso".into(), Vec3::ZERO, Vec3::ONE, source);
        let hg_g = |p: crate::medium::Phase| match p {
            crate::medium::Phase::HenyeyGreenstein(h) => h.g,
            other => panic!("not Henyey-Greenstein: {other:?}"),
        };
        assert!((hg_g(g.phase) - 0.1).abs() < 1e-6);
        for (x, want) in [(0.25f32, 0.2f32), (0.75, 0.6), (3.0, 0.8 * g.world_corners()[7].x.min(1.0))] {
            let got = hg_g(g.phase_at(Vec3::new(x, 0.5, -0.5)));
            assert!((got - want).abs() < 1e-5, "x = {x}: g = {got}, want {want}");
        }
    }
}
