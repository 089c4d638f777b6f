//! The world as a shader graph (`CAUSTIC_world.nodes`): Blender's World Output Surface
//! compiled by the material compiler (`shader::compile`) and evaluated per escaped ray
//! direction, as Cycles shades the background: Generated, Object and Position coordinates
//! are the direction, the normal and the incoming direction its opposite. Background and
//! Emission closures add their colour × strength; mixtures weigh them as on a surface.
//!
//! Sampling: the graph's radiance is baked at load into an equirectangular table (texel
//! centres, plus each visible Sky Texture sun's centre so that a disc smaller than a texel
//! is still found), and the world is sampled from that table's distribution exactly as an
//! HDRI (`EnvImage`), while the radiance of a direction always comes from the graph itself.
//! This is Cycles' arrangement (its background map serves sampling only), and MIS stays
//! unbiased since the density is the table's wherever the graph is evaluated.

use crate::math::Rgb;
use crate::scene::light_path::LightPath;
use crate::scene::texture::Texture;
use crate::shader::closure::Closures;
use crate::shader::geom::{Geom, NO_OBJECT, NO_VIEW, ViewData, from_blender};
use crate::shader::instructions::{InputKind, Op, Program};
use crate::shader::program::with_registers;
use crate::shader::texture_nodes::TexOp;
use glam::{Vec2, Vec3, Vec4};
use std::f32::consts::PI;
use std::sync::Arc;

/// Side of the baked table: 1024 × 512 (Cycles' default background map resolution,
/// 0.35° per texel); a graph reading an image bakes at the image's width (up to 4096) so
/// that the table resolves what the image holds.
pub const DEFAULT_BAKE_WIDTH: usize = 1024;
/// The largest table width.
pub const MAX_BAKE_WIDTH: usize = 4096;

/// A compiled world graph and the images it reads (shared: the shader AOVs keep a copy).
#[derive(Clone, Debug)]
pub struct WorldGraph {
    program: Arc<Program>,
    /// The graph reads the Light Path node: a ray then sees the world with its own state.
    reads_light_path: bool,
    /// The graph's images (its Image/Environment Texture nodes index these).
    textures: Arc<Vec<Texture>>,
    /// The render camera as Texture Coordinate Camera and Window see a direction
    /// ([`with_view`](Self::with_view); none until the camera is known: both give 0).
    view: ViewData,
}

impl WorldGraph {
    /// The graph and its own images.
    pub fn new(program: Program, textures: Vec<Texture>) -> WorldGraph {
        let reads_light_path =
            program.ops.iter().any(|op| matches!(op, Op::Input { what: InputKind::LightPath(_), .. }));
        WorldGraph { program: Arc::new(program), textures: Arc::new(textures), reads_light_path, view: NO_VIEW }
    }

    /// True when the graph reads the Light Path node (what a ray sees then depends on it).
    pub fn reads_light_path(&self) -> bool {
        self.reads_light_path
    }

    /// Whether the graph reads the render camera (Texture Coordinate Camera or Window).
    pub fn reads_view(&self) -> bool {
        self.program.ops.iter().any(|op| matches!(op, Op::Input { what: InputKind::Camera | InputKind::Window, .. }))
    }

    /// The graph seen from the render camera `view` (`CameraRays::shader_view`). Cycles
    /// shades the background at P = the ray's direction and adds the camera's position for
    /// Camera (every ray) and for a perspective camera's Window: so Camera is the direction
    /// in camera space and Window the frame position it projects to, for every ray alike
    /// (a bounce's direction too, not only the camera's): `ViewData::background`. Under an
    /// orthographic camera Window reads the direction as a world point, as Cycles for
    /// every ray but camera rays (whose origin it reads; warned at load).
    pub fn with_view(&self, view: ViewData) -> WorldGraph {
        WorldGraph { view: ViewData { background: true, ..view }, ..self.clone() }
    }

    /// The compiled program.
    pub fn program(&self) -> &Program {
        &self.program
    }

    /// The shading point of glTF direction `d` (unit, pointing away from the scene) for a ray
    /// of path state `path`.
    fn geom(&self, d: Vec3, path: LightPath) -> Geom<'_> {
        Geom {
            p: d,
            n: -d,
            ng: -d,
            wo: -d,
            uv: [Vec2::ZERO; 2],
            color: Vec4::ONE,
            tangent: Vec4::ZERO,
            backfacing: false,
            object: &NO_OBJECT,
            textures: &self.textures,
            // No surface: a Bump in a world graph finds none and keeps the normal.
            mesh: &crate::scene::mesh::EMPTY_MESH,
            tri: u32::MAX,
            bary: Vec2::ZERO,
            path,
            view: &self.view,
            rays: crate::shader::geom::Rays::default(),
            point: None,
            curve: None,
            grid_values: None,
        }
    }

    /// Radiance arriving from glTF direction `d` (unit, pointing away from the scene), as
    /// light sampling sees it (the baked table's and next-event estimation's reading).
    pub fn radiance(&self, d: Vec3) -> Rgb {
        self.radiance_for(d, LightPath::LIGHT_EMISSION)
    }

    /// Radiance arriving from `d` along a ray of path state `path` (Cycles shades the
    /// background with the escaping ray's flags: a camera ray reads Is Camera Ray 1).
    pub fn radiance_for(&self, d: Vec3, path: LightPath) -> Rgb {
        let g = self.geom(d, path);
        let mut out = Closures::default();
        with_registers(|regs| self.program.run(&g, regs, &mut out));
        let e = out.emission;
        if e.is_finite() { e.max(Vec3::ZERO) } else { Vec3::ZERO }
    }

    /// Runs the graph and its AOV Output nodes for a camera ray of path state `path` leaving
    /// the scene along `d`, and hands the program and its registers to `read` (the caller
    /// files the AOV values, `crate::shader::aov`), as Cycles' background shader writes them
    /// where the camera sees the world.
    pub fn with_aov_registers(&self, d: Vec3, path: LightPath, read: impl FnOnce(&Program, &[f32])) {
        let g = self.geom(d, path);
        with_registers(|regs| {
            let mut closures = Closures::default();
            self.program.run(&g, regs, &mut closures);
            self.program.run_aovs(&g, regs);
            read(&self.program, regs);
        });
    }

    /// Directions (glTF) of the visible sun discs of Sky Textures reading the direction
    /// itself (an unlinked Vector, or Generated/Object/Position straight from the input
    /// node); a Sky behind a Mapping is found by the table's texel centres only.
    pub fn sun_directions(&self) -> Vec<Vec3> {
        let ops = &self.program.ops;
        let direct = |reg| {
            ops.iter().any(|op| {
                matches!(op, Op::Input { what: InputKind::Generated | InputKind::Object | InputKind::Position, out }
                    if *out == reg)
            })
        };
        ops.iter()
            .filter_map(|op| match op {
                Op::Texture(t) => match t.as_ref() {
                    TexOp::Sky { sky, vector, .. } if direct(*vector) => sky.sun_direction().map(from_blender),
                    _ => None,
                },
                _ => None,
            })
            .collect()
    }

    /// The table's width: the widest image the graph reads, else 1024; at most 4096.
    pub fn bake_width(&self) -> usize {
        let widest = self.textures.iter().map(|t| t.width as usize).max().unwrap_or(0);
        widest.clamp(DEFAULT_BAKE_WIDTH, MAX_BAKE_WIDTH)
    }

    /// The radiance at the centres of a `width` × `width / 2` equirectangular table (rows
    /// top first, Blender's mapping as `EnvImage`), each texel holding a sun centre raised
    /// to the radiance there. Rows run in parallel.
    pub fn bake(&self, width: usize, dir_of: impl Fn(Vec2) -> Vec3 + Sync) -> Vec<Rgb> {
        use rayon::prelude::*;
        let height = width / 2;
        let mut texels = vec![Rgb::ZERO; width * height];
        texels.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
            for (x, t) in row.iter_mut().enumerate() {
                let uv = Vec2::new((x as f32 + 0.5) / width as f32, 1.0 - (y as f32 + 0.5) / height as f32);
                *t = self.radiance(dir_of(uv));
            }
        });
        for d in self.sun_directions() {
            let b = crate::shader::geom::to_blender(d);
            let u = (0.5 - b.y.atan2(b.x) / (2.0 * PI)).rem_euclid(1.0);
            let v = 0.5 + b.z.clamp(-1.0, 1.0).asin() / PI;
            let x = ((u * width as f32) as usize).min(width - 1);
            let y = (((1.0 - v) * height as f32) as usize).min(height - 1);
            let t = &mut texels[y * width + x];
            *t = t.max(self.radiance(d));
        }
        texels
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::Environment;
    use crate::sampling::warp::cosine_hemisphere;
    use crate::shader::compile::compile;
    use crate::shader::graph::NodesExt;
    use serde_json::json;

    fn world(nodes: serde_json::Value, surface: serde_json::Value) -> Environment {
        let ext: NodesExt =
            serde_json::from_value(json!({"version": 1, "nodes": nodes, "output": {"surface": surface}})).unwrap();
        let c = compile("world", &ext, &[]).unwrap();
        assert!(c.warnings.is_empty(), "{:?}", c.warnings);
        Environment::from_graph(WorldGraph::new(c.program, Vec::new())).unwrap()
    }

    /// Blender 5.0's sky with a 5° sun at 30°, times 0.1, as a Background.
    fn sky_world() -> Environment {
        world(
            json!([
                {"name": "Sky", "type": "ShaderNodeTexSky",
                 "props": {"sky_type": "MULTIPLE_SCATTERING", "sun_size": 5f64.to_radians(),
                           "sun_elevation": 30f64.to_radians(), "sun_rotation": 0.4},
                 "inputs": {"Vector": {"value": [0.0, 0.0, 0.0]}}},
                {"name": "Background", "type": "ShaderNodeBackground",
                 "inputs": {"Color": {"link": [0, "Color"]}, "Strength": {"value": 0.1}}}
            ]),
            json!([1, "Background"]),
        )
    }

    /// A Noise Texture's colour mixed by a Gradient between two Backgrounds.
    fn noise_mix_world() -> Environment {
        world(
            json!([
                {"name": "Noise", "type": "ShaderNodeTexNoise",
                 "props": {"noise_dimensions": "3D", "noise_type": "FBM", "normalize": true},
                 "inputs": {"Vector": {"value": [0.0, 0.0, 0.0]}, "Scale": {"value": 3.0},
                            "Detail": {"value": 2.0}, "Roughness": {"value": 0.5},
                            "Lacunarity": {"value": 2.0}, "Distortion": {"value": 0.0}}},
                {"name": "Gradient", "type": "ShaderNodeTexGradient", "props": {"gradient_type": "LINEAR"},
                 "inputs": {"Vector": {"value": [0.0, 0.0, 0.0]}}},
                {"name": "A", "type": "ShaderNodeBackground",
                 "inputs": {"Color": {"link": [0, "Color"]}, "Strength": {"value": 2.0}}},
                {"name": "B", "type": "ShaderNodeBackground",
                 "inputs": {"Color": {"value": [0.2, 0.3, 0.9, 1.0]}, "Strength": {"value": 1.0}}},
                {"name": "Mix", "type": "ShaderNodeMixShader",
                 "inputs": {"Fac": {"link": [1, "Fac"]}, "Shader": {"link": [2, "Background"]},
                            "Shader_001": {"link": [3, "Background"]}}}
            ]),
            json!([4, "Shader"]),
        )
    }

    /// A small deterministic generator (SplitMix64) for the estimators.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f32 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
        }
        fn u2(&mut self) -> Vec2 {
            Vec2::new(self.next(), self.next())
        }
    }

    /// Mean and standard error of the luminance of `n` samples of `f`.
    fn estimate(n: usize, mut f: impl FnMut() -> f32) -> (f64, f64) {
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let v = f() as f64;
            s += v;
            s2 += v * v;
        }
        let m = s / n as f64;
        (m, ((s2 / n as f64 - m * m).max(0.0) / n as f64).sqrt())
    }

    /// The irradiance of an upward diffuse plane (glTF +Y) three ways: BSDF (cosine) sampling
    /// alone, the world's own sampling (NEE) alone, and both weighted by the power heuristic.
    /// They estimate one integral, so each pair agrees within 5 standard errors of their
    /// difference (a false alarm about 6e-7 per pair); a density that is not the one the
    /// sampler draws from, or a sample whose radiance is not the graph's, breaks NEE's
    /// agreement with cosine sampling, which never looks at the table.
    #[test]
    fn nee_and_bsdf_sampling_agree_under_mis() {
        for (name, env, n) in [("sky", sky_world(), 400_000), ("noise mix", noise_mix_world(), 100_000)] {
            let lum = |c: Rgb| crate::math::luminance(c);
            let up = Vec3::Y;
            let frame = crate::math::Frame::from_normal(up);
            let mut rng = Rng(17);
            let bsdf = estimate(n, || {
                let d = frame.to_world(cosine_hemisphere(rng.u2()));
                // cos / pdf = π for cosine sampling.
                PI * lum(env.radiance(d))
            });
            let mut rng = Rng(29);
            let nee = estimate(n, || match env.sample(rng.u2()) {
                Some((d, l, pdf)) if d.dot(up) > 0.0 => {
                    assert!((pdf - env.pdf(d)).abs() <= 1e-3 * pdf, "{name}: sample pdf {pdf} vs pdf {}", env.pdf(d));
                    lum(l) * d.dot(up) / pdf
                }
                _ => 0.0,
            });
            let mut rng = Rng(41);
            let mis = estimate(n, || {
                let mut v = 0.0;
                if let Some((d, l, pdf)) = env.sample(rng.u2()) {
                    let cos = d.dot(up);
                    if cos > 0.0 {
                        let pb = cos / PI;
                        v += lum(l) * cos / pdf * pdf * pdf / (pdf * pdf + pb * pb);
                    }
                }
                let d = frame.to_world(cosine_hemisphere(rng.u2()));
                let (pb, pl) = (d.dot(up) / PI, env.pdf(d));
                if pb > 0.0 {
                    v += PI * lum(env.radiance(d)) * pb * pb / (pb * pb + pl * pl);
                }
                v
            });
            eprintln!("{name}: bsdf {bsdf:?}, nee {nee:?}, mis {mis:?}");
            for ((a, sa), (b, sb), what) in
                [(bsdf, nee, "BSDF vs NEE"), (bsdf, mis, "BSDF vs MIS"), (nee, mis, "NEE vs MIS")]
            {
                let sigma = (sa * sa + sb * sb).sqrt();
                assert!((a - b).abs() <= 5.0 * sigma, "{name}: {what}: {a} vs {b} (σ {sigma})");
            }
            assert!(bsdf.0 > 0.0);
        }
    }

    /// The sun of a Sky Texture is in the table even when it is smaller than a texel: its
    /// texel's weight is the disc's radiance, so NEE draws it.
    #[test]
    fn a_small_sun_is_found_by_the_table() {
        let env = world(
            json!([
                {"name": "Sky", "type": "ShaderNodeTexSky", "props": {"sky_type": "MULTIPLE_SCATTERING"},
                 "inputs": {"Vector": {"value": [0.0, 0.0, 0.0]}}},
                {"name": "Background", "type": "ShaderNodeBackground",
                 "inputs": {"Color": {"link": [0, "Color"]}, "Strength": {"value": 1.0}}}
            ]),
            json!([1, "Background"]),
        );
        let graph = env.graph.as_ref().unwrap();
        let suns = graph.sun_directions();
        assert_eq!(suns.len(), 1);
        let sun = suns[0];
        // Blender's default: 15° up, toward Blender's +Y (glTF −Z).
        let e = 15f32.to_radians();
        assert!((sun - Vec3::new(0.0, e.sin(), -e.cos())).length() < 1e-4, "{sun}");
        let sky_pdf = env.pdf(Vec3::new(0.3, 0.8, 0.5).normalize());
        assert!(env.pdf(sun) > 1e3 * sky_pdf, "sun pdf {} vs sky {sky_pdf}", env.pdf(sun));
    }

    /// The legacy skies' settings outside Blender's ranges (where Cycles' fits are undefined)
    /// are refused naming the node; valid ones compile without a warning.
    #[test]
    fn legacy_sky_settings_are_checked() {
        let compile_sky = |props: serde_json::Value| {
            let ext: NodesExt = serde_json::from_value(json!({"version": 1, "nodes": [
                {"name": "Sky", "type": "ShaderNodeTexSky", "props": props,
                 "inputs": {"Vector": {"value": [0.0, 0.0, 0.0]}}},
                {"name": "Background", "type": "ShaderNodeBackground",
                 "inputs": {"Color": {"link": [0, "Color"]}, "Strength": {"value": 1.0}}}
            ], "output": {"surface": [1, "Background"]}}))
            .unwrap();
            compile("world", &ext, &[]).map(|c| c.warnings).map_err(|e| e.to_string())
        };
        let ok = compile_sky(json!({"sky_type": "HOSEK_WILKIE", "sun_direction": [0.2, 0.3, 0.9], "turbidity": 4.0}));
        assert_eq!(ok, Ok(Vec::new()));
        for (props, says) in [
            (json!({"sky_type": "PREETHAM", "sun_direction": [0.0, 0.0, 0.0]}), "must not be zero"),
            (json!({"sky_type": "HOSEK_WILKIE", "turbidity": 0.5}), "turbidity must be in [1, 10]"),
            (json!({"sky_type": "HOSEK_WILKIE", "ground_albedo": 1.5}), "ground albedo in [0, 1]"),
            (json!({"sky_type": "PREETHAM", "sun_direction": [0.0, 1.0]}), "must be 3 numbers"),
        ] {
            let e = compile_sky(props.clone()).expect_err(&props.to_string());
            assert!(e.contains("Sky") && e.contains(says), "{props}: {e}");
        }
    }
}
