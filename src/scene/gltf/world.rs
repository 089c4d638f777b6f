//! The world: `CAUSTIC_world`'s colour or equirectangular image, and its volume.

use super::extensions::WorldExt;
use super::{Loader, MAX_TEXTURE_SIDE};
use crate::error::Result;
use crate::medium::HomogeneousMedium;
use glam::Vec3;

/// Blender's World Volume as `CAUSTIC_world.medium` gives it.
pub(super) enum WorldMedium {
    /// No world volume.
    None,
    /// Constant coefficients.
    Homogeneous(HomogeneousMedium),
    /// A node graph evaluated per point (`medium::procedural::world_fog_medium`).
    Graph(Box<crate::shader::compile::volume::VolumeProgram>),
}

impl Loader<'_> {
    /// The world's Ray Visibility (`visibility` in `CAUSTIC_world`): the ray kinds that see
    /// it, camera included; every kind without the extension or the field.
    pub(super) fn world_rays(&self, value: &serde_json::Value) -> Result<crate::scene::visibility::RayMask> {
        let scene_index = value.get("scene").and_then(|s| s.as_u64()).unwrap_or(0) as usize;
        let Some(ext) = value.pointer(&format!("/scenes/{scene_index}/extensions/CAUSTIC_world")) else {
            return Ok(crate::scene::visibility::RayMask::ALL);
        };
        let w: WorldExt =
            serde_json::from_value(ext.clone()).map_err(|e| self.err(format!("CAUSTIC_world is malformed: {e}")))?;
        Ok(w.visibility.map_or(crate::scene::visibility::RayMask::ALL, |v| v.mask()))
    }

    /// The world's Max Bounces (`max_bounces` in `CAUSTIC_world`, `scene::light_bounces`);
    /// no limit without the extension or the field.
    pub(super) fn world_max_bounces(&self, value: &serde_json::Value) -> Result<u32> {
        let scene_index = value.get("scene").and_then(|s| s.as_u64()).unwrap_or(0) as usize;
        let Some(ext) = value.pointer(&format!("/scenes/{scene_index}/extensions/CAUSTIC_world")) else {
            return Ok(crate::scene::light_bounces::NO_LIMIT);
        };
        let w: WorldExt =
            serde_json::from_value(ext.clone()).map_err(|e| self.err(format!("CAUSTIC_world is malformed: {e}")))?;
        Ok(crate::scene::light_bounces::from_file(w.max_bounces))
    }

    /// `scenes[i].extensions.CAUSTIC_world`: a colour × strength, or an equirectangular
    /// image (.hdr, .exr, .png, .jpg) × colour × strength, rotated about the up axis; and
    /// the homogeneous medium that fills the scene (Blender's World Volume).
    pub(super) fn world(
        &mut self,
        value: &serde_json::Value,
        doc: &gltf::Document,
        buffers: &[Vec<u8>],
    ) -> Result<(Option<crate::light::Environment>, WorldMedium)> {
        let scene_index = value.get("scene").and_then(|s| s.as_u64()).unwrap_or(0) as usize;
        let Some(ext) = value.pointer(&format!("/scenes/{scene_index}/extensions/CAUSTIC_world")) else {
            return Ok((None, WorldMedium::None));
        };
        let w: WorldExt =
            serde_json::from_value(ext.clone()).map_err(|e| self.err(format!("CAUSTIC_world is malformed: {e}")))?;
        let color = Vec3::from(w.color) * w.strength;
        if !color.is_finite() || color.min_element() < 0.0 || !w.rotation.is_finite() {
            return Err(self.err("CAUSTIC_world: color, strength and rotation must be finite and non-negative"));
        }
        let _ = (doc, buffers);
        let medium = match &w.medium {
            None => WorldMedium::None,
            Some(m) => {
                if !m.surface {
                    return Err(
                        self.err("CAUSTIC_world: a world medium has no surface to leave out (\"surface\": false)")
                    );
                }
                let mut medium = self.homogeneous_medium("CAUSTIC_world medium", m)?;
                let mut program = None;
                if let Some(graph) = &m.graph {
                    // Textured fog: the graph gives the coefficients at each point (the
                    // constant fields are not read), built into a grid once the scene's
                    // bounds are known (`world_fog_medium`).
                    let what = "CAUSTIC_world medium.graph";
                    let Some(shader) = m.graph_shader else {
                        return Err(self.err(format!("{what} needs graph_shader (the volume shader node)")));
                    };
                    let v = self.volume_program("world", graph, shader, what)?;
                    for w in &v.warnings {
                        self.warn(format!("{what}: {w}"));
                    }
                    // A tree of constant shaders is one homogeneous fog.
                    match crate::medium::procedural_source::constant_medium(Box::new(v)) {
                        Ok(h) => medium = h,
                        Err(v) => program = Some(v),
                    }
                }
                if let Some(v) = program {
                    WorldMedium::Graph(v)
                } else {
                    // Radiance gathered along an unbounded ray is E/σt: infinite where σt = 0
                    // (Cycles 5.0 integrates E·t to FLT_MAX there: every pixel is inf).
                    let st = medium.sigma_t();
                    if (0..3).any(|c| medium.emission[c] > 0.0 && st[c] <= 0.0) {
                        return Err(self.err(
                            "CAUSTIC_world medium: emission in a colour channel the medium does not attenuate is infinite along every ray that leaves the scene (Cycles renders it as inf)",
                        ));
                    }
                    WorldMedium::Homogeneous(medium)
                }
            }
        };
        if let Some(nodes) = &w.nodes {
            let ortho = doc.cameras().any(|c| matches!(c.projection(), gltf::camera::Projection::Orthographic(_)));
            return Ok((Some(self.world_graph(nodes, ortho)?), medium));
        }
        let image = match &w.image {
            None => None,
            Some(uri) => {
                let label =
                    if uri.starts_with("data:") { "world image".to_string() } else { format!("world image '{uri}'") };
                let bytes = self.resolve_uri(uri, &label)?;
                let reader = image::ImageReader::new(std::io::Cursor::new(&bytes))
                    .with_guessed_format()
                    .map_err(|e| self.err(format!("{label}: {e}")))?;
                let (width, height) = reader
                    .into_dimensions()
                    .map_err(|e| self.err(format!("{label}: cannot read the image header: {e}")))?;
                if width == 0 || height == 0 || width > MAX_TEXTURE_SIDE || height > MAX_TEXTURE_SIDE {
                    return Err(self.err(format!(
                        "{label}: image size {width}×{height} is outside 1..={MAX_TEXTURE_SIDE} per side"
                    )));
                }
                // Kept: linear RGB (12 B) and the importance distribution (≈ 8 B) per
                // texel; transient: the decoder's image, its f32 RGB copy and the RGBA values the
                // Texture Limit reads (16 + 12 + 16 B).
                let texels = width as u64 * height as u64;
                self.budget.charge(format!("{label} ({width}×{height})"), texels * 20)?;
                self.budget.check_peak(format!("decoding {label}"), texels * 44)?;
                let decode_start = std::time::Instant::now();
                let decoded = image::ImageReader::new(std::io::Cursor::new(&bytes))
                    .with_guessed_format()
                    .map_err(|e| self.err(format!("{label}: {e}")))?
                    .decode()
                    .map_err(|e| self.err(format!("{label}: cannot decode: {e}")))?;
                // 8-bit images are sRGB-encoded (as Blender reads them); float images linear.
                let srgb = matches!(
                    decoded.color(),
                    image::ColorType::Rgb8 | image::ColorType::Rgba8 | image::ColorType::L8 | image::ColorType::La8
                );
                let rgb = decoded.to_rgb32f();
                let (mut width, mut height) = (width, height);
                let mut stored: Vec<glam::Vec4> =
                    rgb.pixels().map(|p| glam::Vec4::new(p.0[0], p.0[1], p.0[2], 1.0)).collect();
                // Simplify's Texture Limit shrinks the stored values, as Cycles does.
                if let Some((sw, sh, small)) =
                    self.texture_limit.and_then(|l| crate::scene::texture_limit::shrink_f32(&stored, width, height, l))
                {
                    (width, height, stored) = (sw, sh, small);
                }
                self.profile.decode_textures += decode_start.elapsed().as_secs_f64();
                let decode = |c: f32| {
                    if srgb { if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) } } else { c }
                };
                // A colour image, in the working space as Cycles converts it on load.
                let space = self.space;
                let texels: Vec<Vec3> = stored
                    .iter()
                    .map(|p| {
                        let linear = Vec3::new(decode(p.x), decode(p.y), decode(p.z)).max(Vec3::ZERO);
                        space.from_rec709(linear).max(Vec3::ZERO)
                    })
                    .collect();
                Some(
                    crate::light::environment::EnvImage::new(width as usize, height as usize, texels)
                        .ok_or_else(|| self.err(format!("{label}: the image has non-finite pixels")))?,
                )
            }
        };
        Ok((
            Some(crate::light::Environment { color, image, rotation: w.rotation, graph: None, portals: Vec::new() }),
            medium,
        ))
    }
}

impl Loader<'_> {
    /// The world's node graph compiled, its images decoded into its own textures, and its
    /// radiance baked into the sampling table (`light::world_graph`).
    /// `ortho`: the document has an orthographic camera (the Window output then differs from
    /// Cycles' for camera rays, warned).
    fn world_graph(
        &mut self,
        nodes: &crate::shader::graph::NodesExt,
        ortho: bool,
    ) -> Result<crate::light::Environment> {
        const NAME: &str = "world";
        let first = self.textures.len();
        let mut images = Vec::with_capacity(nodes.images.len());
        for (k, img) in nodes.images.iter().enumerate() {
            images.push(self.node_image(NAME, k, img)? - first as u32);
        }
        // The graph's images belong to the world alone: they leave the scene's list.
        let textures = self.textures.split_off(first);
        let compiled = crate::shader::compile::compile_in(NAME, nodes, &images, self.space)
            .map_err(|e| self.err(format!("CAUSTIC_world nodes: {e}")))?;
        for w in &compiled.warnings {
            self.warn(format!("world: {w}"));
        }
        let prog = compiled.program;
        let lobes = prog.ops.iter().any(|op| {
            matches!(op, crate::shader::instructions::Op::Closure(c)
                if !matches!(c.kind, crate::shader::closure::ClosureKind::Emission))
        });
        // A graph reading the Light Path node is evaluated per escaping ray with the ray's
        // state (`WorldGraph::radiance_for`); the table holds light sampling's reading.
        let camera = prog.ops.iter().any(|op| {
            use crate::shader::instructions::{InputKind, Op};
            matches!(op, Op::Input { what: InputKind::Camera | InputKind::Window, .. })
        });
        if camera && ortho {
            // Camera and Window are the render camera's view of the direction (`Scene::set_view`
            // bakes the world again for it); Cycles reads a camera ray's origin for Window
            // under an orthographic camera, which the world's direction alone cannot give.
            self.warn("world: Texture Coordinate Window under an orthographic camera reads the direction as a point for camera rays too (Cycles reads the ray's origin there)");
        }
        if lobes || prog.transparent {
            self.warn("world: a BSDF or Transparent shader on the World Output renders nothing (black, as in Cycles)");
        }
        let graph = crate::light::world_graph::WorldGraph::new(prog, textures);
        if !graph.program().aovs.is_empty() {
            // Its AOV Output nodes write where the camera sees the world (`scene::shader_aovs`).
            self.world_aovs = Some(graph.clone());
        }
        let width = graph.bake_width();
        // The table: radiance (12 B) and its distribution (≈ 8 B) per texel.
        self.budget.charge(format!("world table ({width}×{})", width / 2), (width * width / 2) as u64 * 20)?;
        let start = std::time::Instant::now();
        let env = crate::light::Environment::from_graph(graph)
            .ok_or_else(|| self.err("CAUSTIC_world nodes: the world's radiance is not finite"))?;
        self.profile.decode_textures += start.elapsed().as_secs_f64();
        Ok(env)
    }
}
