//! The glTF 2.0 loader: the only module that touches the `gltf` crate.
//!
//! Reads .gltf (external or data-URI buffers and images) and .glb, flattens the node
//! hierarchy into world-space triangles, and converts materials, cameras, lights and
//! the `CAUSTIC_*` extensions into the renderer's own types. Every defect of the input
//! becomes an [`Error::Scene`] naming the file and the offending object; every guess
//! or dropped feature becomes a warning in [`Scene::warnings`].

use super::material::{Subsurface, SubsurfaceMethod};
use super::texture::{Texture, Wrap, texture_transform};
use super::{
    AlphaMode, Camera, CameraReport, Lens, LightReport, LoadReport, Material, MaterialReport, Mesh, Projection, Scene,
    SceneSettings, TexRef,
};
use crate::error::{Error, Result};
use crate::light::{AreaLight, AreaShape, Light};
use crate::math::luminance;
use crate::medium::{HenyeyGreenstein, HomogeneousMedium};
use crate::memory::{self, MemoryBudget};
use base64::Engine;
use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
use gltf::json;
use serde::Deserialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Extensions that Caustic renders, and so accepts in `extensionsRequired`.
pub const SUPPORTED_REQUIRED: &[&str] =
    &["KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_texture_transform"];

/// Material extensions that Caustic reads.
const HANDLED_MATERIAL_EXTENSIONS: &[&str] = &[
    "KHR_materials_emissive_strength",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_ior",
    "KHR_materials_volume",
    "KHR_materials_clearcoat",
    "CAUSTIC_materials_medium",
    "CAUSTIC_materials_subsurface",
    "KHR_materials_sheen",
    "KHR_materials_dispersion",
    "CAUSTIC_materials_coat",
    // Warned about by name where they are read:
    "KHR_materials_iridescence",
    "KHR_materials_anisotropy",
];

/// glTF's photometric units to Blender's radiometric ones: Blender's exporter writes
/// W × 683 lm/W (its PBR_WATTS_TO_LUMENS), so dividing gives Blender's watts back.
pub const LUMENS_PER_WATT: f32 = 683.0;

/// Largest texture accepted (per side), to refuse absurd image headers before decoding.
const MAX_TEXTURE_SIDE: u32 = 16_384;

/// Largest accepted world coordinate: the BVH's box arithmetic needs headroom in f32.
const MAX_COORDINATE: f32 = 1e15;

/// Instances beyond this are refused: a DAG of shared nodes can explode exponentially.
const MAX_INSTANCES: usize = 1_000_000;

/// Loads a scene from a .gltf or .glb file with no memory limit (tests and tools; the
/// commands use [`load_within`]).
pub fn load(path: &Path) -> Result<Scene> {
    load_within(path, &MemoryBudget::unlimited())
}

/// Loads a scene, charging the decoded textures and the flattened mesh to `budget`
/// before allocating them.
pub fn load_within(path: &Path, budget: &MemoryBudget) -> Result<Scene> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    load_bytes(&bytes, &base, &path.display().to_string(), budget)
}

/// Loads a scene from bytes; external files are resolved relative to `base_dir`.
/// Panics inside the parser are turned into errors: a malformed file must never
/// take the process down.
pub fn load_bytes(bytes: &[u8], base_dir: &Path, file: &str, budget: &MemoryBudget) -> Result<Scene> {
    // The parser's panics are reported as errors below; keep their default message
    // (and backtrace) off stderr, where a host reads JSON lines.
    let previous_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let result =
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| Loader::new(file, base_dir, budget).load(bytes)));
    std::panic::set_hook(previous_hook);
    match result {
        Ok(r) => r,
        Err(panic) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown".into());
            Err(Error::Scene { file: file.into(), message: format!("malformed glTF (parser failed: {what})") })
        }
    }
}

/// `CAUSTIC_lights_area` on a node.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AreaLightExt {
    shape: String,
    size: Vec<f32>,
    power: f32,
    #[serde(default = "white")]
    color: [f32; 3],
    #[serde(default = "yes")]
    camera_visible: bool,
    /// Blender's Spread: full angle in radians, π = no narrowing.
    #[serde(default = "half_turn")]
    spread: f32,
}

fn half_turn() -> f32 {
    std::f32::consts::PI
}

/// `CAUSTIC_materials_medium` on a material (docs/contract.md).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MediumExt {
    #[serde(default = "one_f32")]
    density: f32,
    #[serde(default = "white")]
    scatter_color: [f32; 3],
    #[serde(default = "black")]
    absorption_color: [f32; 3],
    #[serde(default)]
    anisotropy: f32,
    #[serde(default = "black")]
    emission: [f32; 3],
    #[serde(default = "yes")]
    surface: bool,
}

/// `CAUSTIC_materials_subsurface` on a material (docs/contract.md).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SubsurfaceExt {
    #[serde(default = "one_f32")]
    weight: f32,
    radius: [f32; 3],
    #[serde(default)]
    anisotropy: f32,
    #[serde(default = "skin_ior")]
    ior: f32,
    #[serde(default = "random_walk")]
    method: String,
}

fn one_f32() -> f32 {
    1.0
}

fn black() -> [f32; 3] {
    [0.0; 3]
}

fn skin_ior() -> f32 {
    1.4
}

fn random_walk() -> String {
    "random_walk".into()
}

fn yes() -> bool {
    true
}

fn white() -> [f32; 3] {
    [1.0; 3]
}

/// A decoded image: width, height, RGBA8 texels (shared by the textures that use it).
type DecodedImage = (u32, u32, std::sync::Arc<Vec<[u8; 4]>>);

/// Key of a decoded texture: (image, sRGB, sampler).
type TexKey = (usize, bool, Option<usize>);

struct Loader<'a> {
    file: &'a str,
    base_dir: &'a Path,
    budget: &'a MemoryBudget,
    warnings: Vec<String>,
    textures: Vec<Texture>,
    texture_cache: HashMap<TexKey, u32>,
    images: HashMap<usize, DecodedImage>,
}

impl<'a> Loader<'a> {
    fn new(file: &'a str, base_dir: &'a Path, budget: &'a MemoryBudget) -> Self {
        Loader {
            file,
            base_dir,
            budget,
            warnings: Vec::new(),
            textures: Vec::new(),
            texture_cache: HashMap::new(),
            images: HashMap::new(),
        }
    }

    fn err(&self, message: impl Into<String>) -> Error {
        Error::Scene { file: self.file.to_string(), message: message.into() }
    }

    fn warn(&mut self, message: impl Into<String>) {
        let m = message.into();
        if !self.warnings.contains(&m) {
            self.warnings.push(m);
        }
    }

    fn load(mut self, bytes: &[u8]) -> Result<Scene> {
        // 1. Container: GLB or JSON.
        let (json_bytes, bin): (Vec<u8>, Option<Vec<u8>>) = if bytes.starts_with(b"glTF") {
            let glb = gltf::binary::Glb::from_slice(bytes)
                .map_err(|e| self.err(format!("malformed GLB container: {e} (truncated or corrupt file?)")))?;
            (glb.json.into_owned(), glb.bin.map(|b| b.into_owned()))
        } else if bytes.len() >= 4 && &bytes[..4] != b"glTF" && bytes.iter().take(16).any(|&b| b == 0) {
            return Err(self.err("not a glTF file: binary data without the 'glTF' magic"));
        } else {
            (bytes.to_vec(), None)
        };

        // 2. JSON, with its position on error.
        let value: serde_json::Value =
            serde_json::from_slice(&json_bytes).map_err(|e| self.err(format!("invalid JSON: {e}")))?;
        if !value.is_object() {
            return Err(self.err("invalid glTF: the JSON root is not an object"));
        }
        let version = value.pointer("/asset/version").and_then(|v| v.as_str()).unwrap_or("");
        if !version.starts_with("2.") {
            return Err(self.err(format!(
                "unsupported glTF version '{version}' (asset.version must be 2.x; is this a glTF 2.0 file?)"
            )));
        }
        // 3. Required extensions we cannot honour are refused by name.
        if let Some(req) = value.get("extensionsRequired").and_then(|v| v.as_array()) {
            let unsupported: Vec<&str> =
                req.iter().filter_map(|v| v.as_str()).filter(|name| !SUPPORTED_REQUIRED.contains(name)).collect();
            if !unsupported.is_empty() {
                return Err(self.err(format!(
                    "the file requires unsupported extension(s): {} (Caustic supports {})",
                    unsupported.join(", "),
                    SUPPORTED_REQUIRED.join(", ")
                )));
            }
        }
        let settings = self.parse_settings(&value)?;
        // The crate's own validation indexes arrays with the file's indices unchecked
        // (a dangling accessor index panics inside it): check every reference first.
        check_references(&value).map_err(|e| self.err(e))?;

        // 4. Typed document with the crate's index validation.
        let root: json::Root =
            serde_json::from_value(value.clone()).map_err(|e| self.err(format!("invalid glTF: {e}")))?;
        let doc = gltf::Document::from_json(root)
            .map_err(|e| self.err(format!("invalid glTF: {}", describe_validation(&e))))?;

        // 5. Buffers.
        let buffers = self.load_buffers(&doc, bin)?;
        self.check_views_and_accessors(&doc, &buffers)?;
        self.check_accessor_types(&doc)?;

        // 6. Materials (textures decoded on first use).
        let mut materials = Vec::new();
        let mut material_reports = Vec::new();
        for m in doc.materials() {
            let (mat, rep) = self.material(&doc, &m, &buffers)?;
            materials.push(mat);
            material_reports.push(rep);
        }
        let default_material = materials.len() as u32;
        materials.push(Material::default());

        // 7. Node graph to instances.
        let instances = self.instances(&doc, &value)?;
        self.charge_mesh(&doc, &instances)?;

        let mut mesh = Mesh::default();
        let mut cameras = Vec::new();
        let mut lights = Vec::new();
        let mut light_reports = Vec::new();
        let mut used_meshes = std::collections::HashSet::new();
        let mut instance_count = 0;
        let mut degenerate = 0;
        let mut area_lights = Vec::new();
        for (node_index, world) in &instances {
            let node = doc.nodes().nth(*node_index).expect("validated index");
            let node_name = node.name().map(str::to_string).unwrap_or_else(|| format!("node {node_index}"));
            if !world.is_finite() {
                return Err(self.err(format!("node {node_index} ('{node_name}'): transform is not finite")));
            }
            if let Some(m) = node.mesh() {
                used_meshes.insert(m.index());
                instance_count += 1;
                degenerate += self.append_mesh(&m, world, &buffers, &materials, default_material, &mut mesh)?;
            }
            if let Some(c) = node.camera() {
                let blender = node.extension_value("CAUSTIC_camera").cloned();
                cameras.push(self.camera(&c, &node_name, world, blender)?);
            }
            if let Some(l) = node.light() {
                let blender = node.extension_value("CAUSTIC_lights_punctual").cloned();
                let (light, rep) = self.punctual_light(&l, &node_name, world, blender)?;
                lights.push(light);
                light_reports.push(rep);
            }
            if let Some(ext) = node.extension_value("CAUSTIC_lights_area") {
                area_lights.push((ext.clone(), node_name.clone(), *world));
            }
        }
        if mesh.triangles.is_empty() {
            return Err(self.err("nothing to render: the scene has no triangles (no mesh, or only points/lines)"));
        }

        // Bounds.
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for t in &mesh.triangles {
            for &i in t {
                lo = lo.min(mesh.positions[i as usize]);
                hi = hi.max(mesh.positions[i as usize]);
            }
        }
        let scene_radius = ((hi - lo).length() * 0.5).max(1e-3);

        for (ext, name, world) in area_lights {
            if let Some((light, rep)) = self.area_light(&ext, &name, &world)? {
                lights.push(light);
                light_reports.push(rep);
            }
        }
        let world = self.world(&value, &doc, &buffers)?;
        let world_power = world.as_ref().map(|w| {
            // Power through the scene's bounding disk: irradiance π L over π R².
            std::f32::consts::PI * w.mean_luminance() * std::f32::consts::PI * scene_radius * scene_radius
        });
        let mut light_power: Vec<f32> = lights.iter().map(|l| punctual_power(l, scene_radius)).collect();
        if let Some(power) = world_power {
            if power > 0.0 {
                lights.push(Light::World);
                light_power.push(power);
                light_reports.push(LightReport { kind: "world".into(), name: "world".into(), power, triangles: 0 });
            } else {
                self.warn("the world is black: it lights nothing");
            }
        }
        for (rep, p) in light_reports.iter_mut().zip(&light_power) {
            rep.power = *p;
        }

        // Emissive triangles are lights, one each, grouped by material in the report.
        let mut emissive_by_material: HashMap<u32, (usize, f32)> = HashMap::new();
        for (ti, tri) in mesh.triangles.iter().enumerate() {
            let mi = mesh.tri_material[ti];
            let mat = &materials[mi as usize];
            if !mat.is_emissive() {
                continue;
            }
            let mean_tex = mat.emissive_tex.map(|t| self.textures[t.texture as usize].mean_rgb()).unwrap_or(Vec3::ONE);
            let p = tri.map(|i| mesh.positions[i as usize]);
            let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
            let sides = if mat.double_sided { 2.0 } else { 1.0 };
            let power = luminance(mat.emissive * mean_tex) * area * std::f32::consts::PI * sides;
            if power <= 0.0 {
                continue;
            }
            lights.push(Light::Triangle { tri: ti as u32 });
            light_power.push(power);
            let e = emissive_by_material.entry(mi).or_default();
            e.0 += 1;
            e.1 += power;
        }
        let mut emissive: Vec<_> = emissive_by_material.into_iter().collect();
        emissive.sort_by_key(|(mi, _)| *mi);
        for (mi, (count, power)) in emissive {
            light_reports.push(LightReport {
                kind: "emissive".into(),
                name: materials[mi as usize].name.clone(),
                power,
                triangles: count,
            });
        }

        let file_cameras = cameras.len();
        if cameras.is_empty() {
            self.warn("no camera in the file: framing the scene's bounds from +Z with a 40° camera");
            cameras.push(frame_bounds(lo, hi));
        }
        if lights.is_empty() {
            self.warn("the scene has no lights and no emissive materials: the image will be black");
        }
        if degenerate > 0 {
            self.warn(format!("{degenerate} degenerate (zero-area) triangle(s) were dropped"));
        }

        let report = LoadReport {
            file: self.file.to_string(),
            triangles: mesh.triangles.len(),
            meshes: used_meshes.len(),
            instances: instance_count,
            degenerate_triangles: degenerate,
            extensions_used: doc.extensions_used().map(str::to_string).collect(),
            materials: material_reports,
            lights: light_reports,
            cameras: cameras
                .iter()
                .enumerate()
                .map(|(i, c)| CameraReport {
                    generated: i >= file_cameras,
                    name: c.name.clone(),
                    kind: match c.projection {
                        Projection::Perspective { .. } => "perspective".into(),
                        Projection::Orthographic { .. } => "orthographic".into(),
                    },
                    shift: (c.shift != Vec2::ZERO).then(|| c.shift.to_array()),
                    depth_of_field: c.lens.map(|l| {
                        let shape = if l.blades >= 3 { format!(", {} blades", l.blades) } else { String::new() };
                        let ratio = if l.ratio != 1.0 { format!(", ratio {}", l.ratio) } else { String::new() };
                        format!("aperture radius {}, focus {}{shape}{ratio}", l.radius, l.focus_distance)
                    }),
                })
                .collect(),
            bounds: [lo.to_array(), hi.to_array()],
        };
        Ok(Scene {
            mesh,
            materials,
            textures: self.textures,
            lights,
            light_power,
            cameras,
            world,
            settings,
            warnings: self.warnings,
            report,
            bounds: (lo, hi),
        })
    }

    /// `scenes[i].extensions.CAUSTIC_world`: a colour × strength, or an equirectangular
    /// image (.hdr, .exr, .png, .jpg) × colour × strength, rotated about the up axis.
    fn world(
        &mut self,
        value: &serde_json::Value,
        doc: &gltf::Document,
        buffers: &[Vec<u8>],
    ) -> Result<Option<crate::light::Environment>> {
        let scene_index = value.get("scene").and_then(|s| s.as_u64()).unwrap_or(0) as usize;
        let Some(ext) = value.pointer(&format!("/scenes/{scene_index}/extensions/CAUSTIC_world")) else {
            return Ok(None);
        };
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct WorldExt {
            #[serde(default = "white")]
            color: [f32; 3],
            #[serde(default = "one")]
            strength: f32,
            image: Option<String>,
            #[serde(default)]
            rotation: f32,
        }
        fn one() -> f32 {
            1.0
        }
        let w: WorldExt =
            serde_json::from_value(ext.clone()).map_err(|e| self.err(format!("CAUSTIC_world is malformed: {e}")))?;
        let color = Vec3::from(w.color) * w.strength;
        if !color.is_finite() || color.min_element() < 0.0 || !w.rotation.is_finite() {
            return Err(self.err("CAUSTIC_world: color, strength and rotation must be finite and non-negative"));
        }
        let _ = (doc, buffers);
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
                // texel; transient: the decoder's image and its f32 RGB copy (16 + 12 B).
                let texels = width as u64 * height as u64;
                self.budget.charge(format!("{label} ({width}×{height})"), texels * 20)?;
                self.budget.check_peak(format!("decoding {label}"), texels * 28)?;
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
                let decode = |c: f32| {
                    if srgb { if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) } } else { c }
                };
                let texels: Vec<Vec3> = rgb
                    .pixels()
                    .map(|p| Vec3::new(decode(p.0[0]), decode(p.0[1]), decode(p.0[2])).max(Vec3::ZERO))
                    .collect();
                Some(
                    crate::light::environment::EnvImage::new(width as usize, height as usize, texels)
                        .ok_or_else(|| self.err(format!("{label}: the image has non-finite pixels")))?,
                )
            }
        };
        Ok(Some(crate::light::Environment { color, image, rotation: w.rotation }))
    }

    fn parse_settings(&self, value: &serde_json::Value) -> Result<SceneSettings> {
        let scene_index = value.get("scene").and_then(|s| s.as_u64()).unwrap_or(0) as usize;
        let Some(extras) = value.pointer(&format!("/scenes/{scene_index}/extras/caustic")) else {
            return Ok(SceneSettings::default());
        };
        serde_json::from_value(extras.clone())
            .map_err(|e| self.err(format!("scene extras 'caustic' (render settings) are malformed: {e}")))
    }

    fn resolve_uri(&self, uri: &str, what: &str) -> Result<Vec<u8>> {
        if let Some(rest) = uri.strip_prefix("data:") {
            let Some((_, payload)) = rest.split_once(";base64,") else {
                return Err(self.err(format!("{what}: data URI is not base64-encoded")));
            };
            return base64::engine::general_purpose::STANDARD
                .decode(payload.trim())
                .map_err(|e| self.err(format!("{what}: data URI has invalid base64: {e}")));
        }
        if uri.contains("://") {
            return Err(
                self.err(format!("{what}: remote URI '{uri}' is not supported (only relative files and data URIs)"))
            );
        }
        let decoded = percent_encoding::percent_decode_str(uri).decode_utf8_lossy().to_string();
        let path: PathBuf = self.base_dir.join(&decoded);
        std::fs::read(&path).map_err(|e| self.err(format!("{what}: cannot read '{}': {e}", path.display())))
    }

    fn load_buffers(&self, doc: &gltf::Document, mut bin: Option<Vec<u8>>) -> Result<Vec<Vec<u8>>> {
        let mut out = Vec::new();
        for b in doc.buffers() {
            let what = format!("buffer {}", b.index());
            let data = match b.source() {
                gltf::buffer::Source::Bin => bin
                    .take()
                    .ok_or_else(|| self.err(format!("{what} refers to the GLB binary chunk, which is missing")))?,
                gltf::buffer::Source::Uri(uri) => self.resolve_uri(uri, &what)?,
            };
            if data.len() < b.length() {
                return Err(self.err(format!(
                    "{what} is shorter than its byteLength ({} < {} bytes): truncated file?",
                    data.len(),
                    b.length()
                )));
            }
            out.push(data);
        }
        Ok(out)
    }

    /// Bounds checks the crate leaves to us: views inside buffers, accessors inside views.
    /// Checks every primitive's attribute and index accessors and image sources against
    /// the types glTF allows: the crate's readers and `Image::source`
    /// reach `unreachable!()` or unwrap `None` on anything else (found by the fuzzer).
    fn check_accessor_types(&self, doc: &gltf::Document) -> Result<()> {
        use gltf::Semantic;
        use gltf::accessor::{DataType as T, Dimensions as D};
        for m in doc.meshes() {
            for prim in m.primitives() {
                let what = format!("mesh {} primitive {}", m.index(), prim.index());
                if let Some(idx) = prim.indices()
                    && !(idx.dimensions() == D::Scalar && matches!(idx.data_type(), T::U8 | T::U16 | T::U32))
                {
                    return Err(self.err(format!(
                        "{what}: indices accessor {} is {:?} {:?}; indices must be unsigned-integer SCALAR",
                        idx.index(),
                        idx.data_type(),
                        idx.dimensions()
                    )));
                }
                for (semantic, acc) in prim.attributes() {
                    let (t, d) = (acc.data_type(), acc.dimensions());
                    let ok = match &semantic {
                        Semantic::Positions | Semantic::Normals => (t, d) == (T::F32, D::Vec3),
                        Semantic::Tangents => (t, d) == (T::F32, D::Vec4),
                        Semantic::TexCoords(_) => d == D::Vec2 && matches!(t, T::F32 | T::U8 | T::U16),
                        Semantic::Colors(_) => matches!(d, D::Vec3 | D::Vec4) && matches!(t, T::F32 | T::U8 | T::U16),
                        Semantic::Joints(_) => d == D::Vec4 && matches!(t, T::U8 | T::U16),
                        Semantic::Weights(_) => d == D::Vec4 && matches!(t, T::F32 | T::U8 | T::U16),
                        #[allow(unreachable_patterns)]
                        _ => true,
                    };
                    if !ok {
                        return Err(self.err(format!(
                            "{what}: attribute {} uses accessor {} of type {t:?} {d:?}, which glTF does not allow for it",
                            semantic.to_string(),
                            acc.index()
                        )));
                    }
                }
            }
        }
        for image in doc.images() {
            let json = image.index();
            let raw = &doc.as_json().images[json];
            match (&raw.buffer_view, &raw.uri, &raw.mime_type) {
                (Some(_), _, None) => {
                    return Err(self.err(format!("image {json}: a bufferView image needs a mimeType")));
                }
                (None, None, _) => return Err(self.err(format!("image {json}: has neither a uri nor a bufferView"))),
                _ => {}
            }
        }
        Ok(())
    }

    fn check_views_and_accessors(&self, doc: &gltf::Document, buffers: &[Vec<u8>]) -> Result<()> {
        for v in doc.views() {
            let end = v.offset().checked_add(v.length());
            let buf_len = v.buffer().length();
            if end.is_none_or(|e| e > buf_len) {
                return Err(self.err(format!(
                    "bufferView {} (offset {} + length {}) lies outside buffer {} ({} bytes)",
                    v.index(),
                    v.offset(),
                    v.length(),
                    v.buffer().index(),
                    buf_len
                )));
            }
            debug_assert!(buffers[v.buffer().index()].len() >= buf_len);
        }
        for a in doc.accessors() {
            let elem = a.size();
            if let Some(v) = a.view() {
                let stride = v.stride().unwrap_or(elem);
                if stride < elem {
                    return Err(self.err(format!(
                        "accessor {}: byteStride {} is smaller than its element size {}",
                        a.index(),
                        stride,
                        elem
                    )));
                }
                let need = if a.count() == 0 {
                    Some(0)
                } else {
                    stride
                        .checked_mul(a.count() - 1)
                        .and_then(|x| x.checked_add(elem))
                        .and_then(|x| x.checked_add(a.offset()))
                };
                if need.is_none_or(|n| n > v.length()) {
                    return Err(self.err(format!(
                        "accessor {} ({} elements of {} bytes at offset {}) runs past the end of bufferView {} ({} bytes)",
                        a.index(),
                        a.count(),
                        elem,
                        a.offset(),
                        v.index(),
                        v.length()
                    )));
                }
            }
            if let Some(sparse) = a.sparse() {
                let idx_view = sparse.indices().view();
                let val_view = sparse.values().view();
                let idx_need = sparse.indices().offset() + sparse.count() * sparse.indices().index_type().size();
                let val_need = sparse.values().offset() + sparse.count() * elem;
                if idx_need > idx_view.length() || val_need > val_view.length() {
                    return Err(self.err(format!("accessor {}: sparse data runs past its bufferView", a.index())));
                }
            }
        }
        Ok(())
    }

    fn image(&mut self, doc: &gltf::Document, index: usize, buffers: &[Vec<u8>]) -> Result<DecodedImage> {
        if let Some(img) = self.images.get(&index) {
            return Ok(img.clone());
        }
        let image = doc.images().nth(index).expect("validated index");
        let name = image.name().map(|n| format!("image {index} ('{n}')")).unwrap_or_else(|| format!("image {index}"));
        let (bytes, label) = match image.source() {
            gltf::image::Source::View { view, .. } => {
                let b = &buffers[view.buffer().index()];
                (b[view.offset()..view.offset() + view.length()].to_vec(), name.clone())
            }
            gltf::image::Source::Uri { uri, .. } => {
                let label = if uri.starts_with("data:") { name.clone() } else { format!("{name} '{uri}'") };
                (self.resolve_uri(uri, &format!("texture {label}"))?, label)
            }
        };
        let reader = image::ImageReader::new(std::io::Cursor::new(&bytes))
            .with_guessed_format()
            .map_err(|e| self.err(format!("texture {label}: {e}")))?;
        if reader.format().is_none() {
            return Err(self.err(format!("texture {label}: unknown image format (Caustic reads PNG and JPEG)")));
        }
        let (w, h) = reader
            .into_dimensions()
            .map_err(|e| self.err(format!("texture {label}: cannot read the image header: {e}")))?;
        if w == 0 || h == 0 || w > MAX_TEXTURE_SIDE || h > MAX_TEXTURE_SIDE {
            return Err(
                self.err(format!("texture {label}: image size {w}×{h} is outside 1..={MAX_TEXTURE_SIDE} per side"))
            );
        }
        // Kept: RGBA8 texels; transient: the decoded image (at most 16-bit RGBA) and
        // its 8-bit conversion.
        let texels = w as u64 * h as u64;
        self.budget.charge(format!("texture {label} ({w}×{h})"), texels * 4)?;
        self.budget.check_peak(format!("decoding texture {label}"), texels * 12)?;
        let decoded = image::ImageReader::new(std::io::Cursor::new(&bytes))
            .with_guessed_format()
            .map_err(|e| self.err(format!("texture {label}: {e}")))?
            .decode()
            .map_err(|e| self.err(format!("texture {label}: cannot decode: {e}")))?
            .to_rgba8();
        let texels: Vec<[u8; 4]> = decoded.pixels().map(|p| p.0).collect();
        let entry = (w, h, std::sync::Arc::new(texels));
        self.images.insert(index, entry.clone());
        Ok(entry)
    }

    fn texture(
        &mut self,
        doc: &gltf::Document,
        texture: gltf::Texture,
        tex_coord: u32,
        transform: Mat3,
        srgb: bool,
        buffers: &[Vec<u8>],
    ) -> Result<TexRef> {
        let image_index = texture.source().index();
        let sampler = texture.sampler();
        let key = (image_index, srgb, sampler.index());
        let index = if let Some(&i) = self.texture_cache.get(&key) {
            i
        } else {
            let (w, h, texels) = self.image(doc, image_index, buffers)?;
            let wrap = |m: gltf::texture::WrappingMode| match m {
                gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
                gltf::texture::WrappingMode::MirroredRepeat => Wrap::Mirror,
                gltf::texture::WrappingMode::ClampToEdge => Wrap::Clamp,
            };
            let nearest = matches!(sampler.mag_filter(), Some(gltf::texture::MagFilter::Nearest));
            self.textures.push(Texture {
                name: texture.source().name().unwrap_or("").to_string(),
                width: w,
                height: h,
                texels: (*texels).clone(),
                srgb,
                wrap_s: wrap(sampler.wrap_s()),
                wrap_t: wrap(sampler.wrap_t()),
                nearest,
            });
            let i = (self.textures.len() - 1) as u32;
            self.texture_cache.insert(key, i);
            i
        };
        if tex_coord > 1 {
            self.warn(format!("a texture uses TEXCOORD_{tex_coord}; Caustic reads TEXCOORD_0 and _1 only (using 0)"));
        }
        Ok(TexRef { texture: index, tex_coord: tex_coord.min(1), transform })
    }

    fn info_texture(
        &mut self,
        doc: &gltf::Document,
        info: Option<gltf::texture::Info>,
        srgb: bool,
        buffers: &[Vec<u8>],
        features: &mut Vec<String>,
        label: &str,
    ) -> Result<Option<TexRef>> {
        let Some(info) = info else { return Ok(None) };
        let mut tex_coord = info.tex_coord();
        let mut transform = Mat3::IDENTITY;
        if let Some(t) = info.texture_transform() {
            transform = texture_transform(t.offset(), t.rotation(), t.scale());
            if let Some(tc) = t.tex_coord() {
                tex_coord = tc;
            }
            push_unique(features, "KHR_texture_transform");
        }
        push_unique(features, label);
        self.texture(doc, info.texture(), tex_coord, transform, srgb, buffers).map(Some)
    }

    /// A textureInfo given as raw extension JSON (`{"index": i, "texCoord": n, "extensions": ...}`).
    fn raw_texture(
        &mut self,
        doc: &gltf::Document,
        info: &serde_json::Value,
        srgb: bool,
        buffers: &[Vec<u8>],
        material: &str,
    ) -> Result<Option<TexRef>> {
        let index = info
            .get("index")
            .and_then(|v| v.as_u64())
            .ok_or_else(|| self.err(format!("material '{material}': a texture reference has no index")))?;
        let texture = doc
            .textures()
            .nth(index as usize)
            .ok_or_else(|| self.err(format!("material '{material}': texture {index} does not exist")))?;
        let mut tex_coord = info.get("texCoord").and_then(|v| v.as_u64()).unwrap_or(0) as u32;
        let mut transform = Mat3::IDENTITY;
        if let Some(t) = info.pointer("/extensions/KHR_texture_transform") {
            let f = |k: &str, d: f32, i: usize| {
                t.get(k).and_then(|v| v.get(i).or(Some(v))).and_then(|v| v.as_f64()).map(|v| v as f32).unwrap_or(d)
            };
            transform = texture_transform(
                [f("offset", 0.0, 0), f("offset", 0.0, 1)],
                f("rotation", 0.0, 0),
                [f("scale", 1.0, 0), f("scale", 1.0, 1)],
            );
            if let Some(tc) = t.get("texCoord").and_then(|v| v.as_u64()) {
                tex_coord = tc as u32;
            }
        }
        self.texture(doc, texture, tex_coord, transform, srgb, buffers).map(Some)
    }

    fn material(
        &mut self,
        doc: &gltf::Document,
        m: &gltf::Material,
        buffers: &[Vec<u8>],
    ) -> Result<(Material, MaterialReport)> {
        let index = m.index().unwrap_or(0);
        let name = m.name().map(str::to_string).unwrap_or_else(|| format!("material {index}"));
        let mut features = Vec::new();
        let pbr = m.pbr_metallic_roughness();
        let check = |v: f32, what: &str| -> Result<f32> {
            if v.is_finite() {
                Ok(v)
            } else {
                Err(self.err(format!("material '{name}': {what} is not a finite number")))
            }
        };
        let bc = pbr.base_color_factor();
        let base_color = Vec4::new(
            check(bc[0], "baseColorFactor")?,
            check(bc[1], "baseColorFactor")?,
            check(bc[2], "baseColorFactor")?,
            check(bc[3], "baseColorFactor")?,
        );
        let metallic = check(pbr.metallic_factor(), "metallicFactor")?;
        let roughness = check(pbr.roughness_factor(), "roughnessFactor")?;
        let em = m.emissive_factor();
        let strength = m.emissive_strength().unwrap_or(1.0);
        let emissive = Vec3::new(
            check(em[0], "emissiveFactor")?,
            check(em[1], "emissiveFactor")?,
            check(em[2], "emissiveFactor")?,
        ) * check(strength, "emissive strength")?;
        let clamped = |v: Vec4| v.clamp(Vec4::ZERO, Vec4::ONE);
        if clamped(base_color) != base_color || !(0.0..=1.0).contains(&metallic) || !(0.0..=1.0).contains(&roughness) {
            self.warn(format!("material '{name}': factors outside [0, 1] were clamped"));
        }
        if emissive.min_element() < 0.0 {
            self.warn(format!("material '{name}': negative emission was clamped to 0"));
        }
        if m.emissive_strength().is_some() {
            features.push("KHR_materials_emissive_strength".into());
        }
        let base_color_tex =
            self.info_texture(doc, pbr.base_color_texture(), true, buffers, &mut features, "baseColorTexture")?;
        let metallic_roughness_tex = self.info_texture(
            doc,
            pbr.metallic_roughness_texture(),
            false,
            buffers,
            &mut features,
            "metallicRoughnessTexture",
        )?;
        let emissive_tex =
            self.info_texture(doc, m.emissive_texture(), true, buffers, &mut features, "emissiveTexture")?;
        let (normal_tex, normal_scale) = match m.normal_texture() {
            Some(n) => {
                let mut transform = Mat3::IDENTITY;
                let mut tex_coord = n.tex_coord();
                if let Some(t) = n.extension_value("KHR_texture_transform") {
                    let f = |k: &str, d: f32, i: usize| {
                        t.get(k)
                            .and_then(|v| v.get(i).or(Some(v)))
                            .and_then(|v| v.as_f64())
                            .map(|v| v as f32)
                            .unwrap_or(d)
                    };
                    transform = texture_transform(
                        [f("offset", 0.0, 0), f("offset", 0.0, 1)],
                        f("rotation", 0.0, 0),
                        [f("scale", 1.0, 0), f("scale", 1.0, 1)],
                    );
                    if let Some(tc) = t.get("texCoord").and_then(|v| v.as_u64()) {
                        tex_coord = tc as u32;
                    }
                    push_unique(&mut features, "KHR_texture_transform");
                }
                features.push("normalTexture".into());
                (Some(self.texture(doc, n.texture(), tex_coord, transform, false, buffers)?), n.scale())
            }
            None => (None, 1.0),
        };
        if m.occlusion_texture().is_some() {
            features.push("occlusionTexture (ignored: path tracing computes occlusion)".into());
        }
        let alpha_mode = match m.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => {
                features.push("alphaMode MASK".into());
                AlphaMode::Mask(m.alpha_cutoff().unwrap_or(0.5))
            }
            gltf::material::AlphaMode::Blend => {
                features.push("alphaMode BLEND (stochastic transparency)".into());
                AlphaMode::Blend
            }
        };
        if m.double_sided() {
            features.push("doubleSided".into());
        }
        let file = self.file.to_string();
        let num = |v: &serde_json::Value, key: &str, default: f32| -> Result<f32> {
            match v.get(key) {
                None => Ok(default),
                Some(x) => x.as_f64().map(|f| f as f32).filter(|f| f.is_finite()).ok_or_else(|| Error::Scene {
                    file: file.clone(),
                    message: format!("material '{name}': {key} is not a finite number"),
                }),
            }
        };
        let mut transmission = 0.0;
        let mut transmission_tex = None;
        if let Some(t) = m.extension_value("KHR_materials_transmission").cloned() {
            features.push("KHR_materials_transmission".into());
            let factor = num(&t, "transmissionFactor", 0.0)?;
            transmission = factor.clamp(0.0, 1.0);
            if transmission != factor {
                self.warn(format!("material '{name}': transmissionFactor {factor} was clamped to [0, 1]"));
            }
            if let Some(tex) = t.get("transmissionTexture") {
                transmission_tex = self.raw_texture(doc, tex, false, buffers, &name)?;
            }
        }
        let mut ior = 1.5;
        if let Some(i) = m.extension_value("KHR_materials_ior").cloned() {
            features.push("KHR_materials_ior".into());
            let v = num(&i, "ior", 1.5)?;
            // glTF allows 0 to mean "no Fresnel"; Caustic needs a physical index.
            if v < 1.0 {
                self.warn(format!("material '{name}': ior {v} is below 1 and was set to 1"));
            }
            ior = v.clamp(1.0, 10.0);
        }
        let mut medium = None;
        if let Some(v) = m.extension_value("KHR_materials_volume").cloned() {
            features.push("KHR_materials_volume".into());
            let thickness = num(&v, "thicknessFactor", 0.0)?;
            let distance = num(&v, "attenuationDistance", f32::INFINITY)?;
            let color = v
                .get("attenuationColor")
                .and_then(|c| c.as_array())
                .map(|c| c.iter().map(|x| x.as_f64().unwrap_or(1.0) as f32).collect::<Vec<f32>>())
                .unwrap_or_else(|| vec![1.0; 3]);
            if color.len() != 3 || color.iter().any(|c| !c.is_finite()) || !(distance > 0.0) {
                return Err(self.err(format!(
                    "material '{name}': KHR_materials_volume needs 3 finite attenuationColor values and attenuationDistance > 0"
                )));
            }
            // Beer-Lambert: after attenuationDistance, light keeps attenuationColor.
            let sigma = Vec3::new(color[0], color[1], color[2]).clamp(Vec3::splat(1e-6), Vec3::ONE);
            let sigma_a = if distance.is_finite() {
                -Vec3::new(sigma.x.ln(), sigma.y.ln(), sigma.z.ln()) / distance
            } else {
                Vec3::ZERO
            };
            if thickness > 0.0 {
                medium = Some(HomogeneousMedium::absorbing(sigma_a));
            }
            if v.get("thicknessTexture").is_some() {
                features.push("thicknessTexture (ignored: Caustic traces the real geometry)".into());
            }
        }
        let mut null_surface = false;
        if let Some(v) = m.extension_value("CAUSTIC_materials_medium").cloned() {
            features.push("CAUSTIC_materials_medium".into());
            let ext: MediumExt = serde_json::from_value(v)
                .map_err(|e| self.err(format!("material '{name}': CAUSTIC_materials_medium is malformed: {e}")))?;
            let colours = [ext.scatter_color, ext.absorption_color, ext.emission];
            let finite = ext.density.is_finite()
                && ext.anisotropy.is_finite()
                && colours.iter().all(|c| c.iter().all(|x| x.is_finite()));
            if !finite || ext.density < 0.0 || colours.iter().any(|c| c.iter().any(|&x| x < 0.0)) {
                return Err(self.err(format!(
                    "material '{name}': CAUSTIC_materials_medium needs finite, non-negative density and colours"
                )));
            }
            if !(-1.0..=1.0).contains(&ext.anisotropy) {
                return Err(self.err(format!(
                    "material '{name}': CAUSTIC_materials_medium anisotropy {} is outside [-1, 1]",
                    ext.anisotropy
                )));
            }
            if medium.is_some() {
                self.warn(format!(
                    "material '{name}': CAUSTIC_materials_medium replaces the KHR_materials_volume attenuation"
                ));
            }
            medium = Some(HomogeneousMedium {
                sigma_a: Vec3::from(ext.absorption_color) * ext.density,
                sigma_s: Vec3::from(ext.scatter_color) * ext.density,
                phase: HenyeyGreenstein::new(ext.anisotropy),
                emission: Vec3::from(ext.emission),
            });
            null_surface = !ext.surface;
        }
        let mut subsurface = None;
        if let Some(v) = m.extension_value("CAUSTIC_materials_subsurface").cloned() {
            features.push("CAUSTIC_materials_subsurface".into());
            let ext: SubsurfaceExt = serde_json::from_value(v)
                .map_err(|e| self.err(format!("material '{name}': CAUSTIC_materials_subsurface is malformed: {e}")))?;
            let finite = [ext.weight, ext.anisotropy, ext.ior].iter().chain(ext.radius.iter()).all(|x| x.is_finite());
            if !finite || ext.weight < 0.0 || ext.radius.iter().any(|&r| r < 0.0) || ext.ior < 1.0 {
                return Err(self.err(format!(
                    "material '{name}': CAUSTIC_materials_subsurface needs finite values, weight and radius >= 0, ior >= 1"
                )));
            }
            let method = match ext.method.as_str() {
                "random_walk" => SubsurfaceMethod::RandomWalk,
                "random_walk_skin" => SubsurfaceMethod::RandomWalkSkin,
                other => {
                    return Err(self.err(format!(
                        "material '{name}': CAUSTIC_materials_subsurface method '{other}' is unknown (random_walk, random_walk_skin)"
                    )));
                }
            };
            if ext.weight > 1.0 || !(0.0..=0.9).contains(&ext.anisotropy) {
                self.warn(format!(
                    "material '{name}': subsurface weight was clamped to [0, 1] and anisotropy to [0, 0.9] (as Cycles)"
                ));
            }
            if ext.weight > 0.0 && ext.radius.iter().any(|&r| r > 0.0) {
                subsurface = Some(Subsurface {
                    weight: ext.weight.min(1.0),
                    radius: Vec3::from(ext.radius),
                    anisotropy: ext.anisotropy.clamp(0.0, 0.9),
                    ior: ext.ior.clamp(1.01, 3.8),
                    method,
                });
            }
        }
        let (mut coat, mut coat_tex, mut coat_roughness, mut coat_roughness_tex) = (0.0, None, 0.0, None);
        let (mut coat_normal_tex, mut coat_normal_scale) = (None, 1.0);
        if let Some(c) = m.extension_value("KHR_materials_clearcoat").cloned() {
            features.push("KHR_materials_clearcoat".into());
            coat = num(&c, "clearcoatFactor", 0.0)?.clamp(0.0, 1.0);
            coat_roughness = num(&c, "clearcoatRoughnessFactor", 0.0)?.clamp(0.0, 1.0);
            if let Some(t) = c.get("clearcoatTexture") {
                coat_tex = self.raw_texture(doc, t, false, buffers, &name)?;
            }
            if let Some(t) = c.get("clearcoatRoughnessTexture") {
                coat_roughness_tex = self.raw_texture(doc, t, false, buffers, &name)?;
            }
            if let Some(t) = c.get("clearcoatNormalTexture") {
                coat_normal_tex = self.raw_texture(doc, t, false, buffers, &name)?;
                coat_normal_scale = num(t, "scale", 1.0)?;
            }
        }
        // A colour factor: 3 finite numbers, clamped to be non-negative.
        let color3 = |v: &serde_json::Value, key: &str, default: Vec3| -> Result<Vec3> {
            match v.get(key) {
                None => Ok(default),
                Some(c) => c
                    .as_array()
                    .filter(|a| a.len() == 3)
                    .and_then(|a| {
                        let f: Vec<f32> = a.iter().filter_map(|x| x.as_f64().map(|f| f as f32)).collect();
                        (f.len() == 3 && f.iter().all(|x| x.is_finite())).then(|| Vec3::new(f[0], f[1], f[2]))
                    })
                    .map(|c| c.max(Vec3::ZERO))
                    .ok_or_else(|| Error::Scene {
                        file: self.file.to_string(),
                        message: format!("material '{name}': {key} must be 3 finite numbers"),
                    }),
            }
        };
        let (mut coat_ior, mut coat_tint) = (1.5, Vec3::ONE);
        if let Some(c) = m.extension_value("CAUSTIC_materials_coat").cloned() {
            features.push("CAUSTIC_materials_coat".into());
            let v = num(&c, "ior", 1.5)?;
            if !(1.0..=10.0).contains(&v) {
                self.warn(format!("material '{name}': coat ior {v} was clamped to [1, 10]"));
            }
            coat_ior = v.clamp(1.0, 10.0);
            coat_tint = color3(&c, "tint", Vec3::ONE)?;
            if coat_tint.max_element() > 1.0 {
                self.warn(format!("material '{name}': coat tint {coat_tint} was clamped to [0, 1]"));
                coat_tint = coat_tint.min(Vec3::ONE);
            }
            if coat == 0.0 {
                self.warn(format!(
                    "material '{name}': CAUSTIC_materials_coat without a coat (KHR_materials_clearcoat) does nothing"
                ));
            }
        }
        let (mut sheen_color, mut sheen_color_tex, mut sheen_roughness, mut sheen_roughness_tex) =
            (Vec3::ZERO, None, 0.0, None);
        if let Some(sh) = m.extension_value("KHR_materials_sheen").cloned() {
            features.push("KHR_materials_sheen".into());
            sheen_color = color3(&sh, "sheenColorFactor", Vec3::ZERO)?;
            if sheen_color.max_element() > 1.0 {
                self.warn(format!("material '{name}': sheenColorFactor {sheen_color} was clamped to [0, 1]"));
                sheen_color = sheen_color.min(Vec3::ONE);
            }
            sheen_roughness = num(&sh, "sheenRoughnessFactor", 0.0)?.clamp(0.0, 1.0);
            if let Some(t) = sh.get("sheenColorTexture") {
                sheen_color_tex = self.raw_texture(doc, t, true, buffers, &name)?;
            }
            if let Some(t) = sh.get("sheenRoughnessTexture") {
                sheen_roughness_tex = self.raw_texture(doc, t, false, buffers, &name)?;
            }
        }
        let mut dispersion = 0.0;
        if let Some(d) = m.extension_value("KHR_materials_dispersion").cloned() {
            features.push("KHR_materials_dispersion".into());
            let v = num(&d, "dispersion", 0.0)?;
            if v < 0.0 {
                self.warn(format!("material '{name}': dispersion {v} is negative and was set to 0"));
            }
            dispersion = v.clamp(0.0, 20.0);
            if dispersion > 0.0 && roughness >= crate::bsdf::dielectric::SMOOTH_ROUGHNESS {
                self.warn(format!(
                    "material '{name}': dispersion is rendered on smooth glass only; this rough glass uses its mean index"
                ));
            }
        }
        for ext in ["KHR_materials_iridescence", "KHR_materials_anisotropy"] {
            if m.extension_value(ext).is_some() {
                features.push(format!("{ext} (ignored)"));
                self.warn(format!("material '{name}': {ext} is not rendered yet and was ignored"));
            }
        }
        let mut specular = 1.0;
        let (mut specular_color, mut specular_tex, mut specular_color_tex) = (Vec3::ONE, None, None);
        if let Some(spec) = m.extension_value("KHR_materials_specular").cloned() {
            features.push("KHR_materials_specular".into());
            let factor = spec.get("specularFactor").and_then(|v| v.as_f64()).unwrap_or(1.0) as f32;
            if !factor.is_finite() {
                return Err(self.err(format!("material '{name}': specularFactor is not a finite number")));
            }
            specular = factor.clamp(0.0, 1.0);
            if specular != factor {
                self.warn(format!("material '{name}': specularFactor {factor} was clamped to [0, 1]"));
            }
            specular_color = color3(&spec, "specularColorFactor", Vec3::ONE)?;
            if let Some(t) = spec.get("specularTexture") {
                specular_tex = self.raw_texture(doc, t, false, buffers, &name)?;
            }
            if let Some(t) = spec.get("specularColorTexture") {
                specular_color_tex = self.raw_texture(doc, t, true, buffers, &name)?;
            }
        }
        if let Some(exts) = m.extensions() {
            for key in exts.keys() {
                if HANDLED_MATERIAL_EXTENSIONS.contains(&key.as_str()) {
                    continue;
                }
                features.push(format!("{key} (ignored)"));
                self.warn(format!("material '{name}': {key} is not rendered yet and was ignored"));
            }
        }
        let mat = Material {
            name: name.clone(),
            base_color: clamped(base_color),
            base_color_tex,
            metallic: metallic.clamp(0.0, 1.0),
            roughness: roughness.clamp(0.0, 1.0),
            metallic_roughness_tex,
            normal_tex,
            normal_scale,
            emissive: emissive.max(Vec3::ZERO),
            emissive_tex,
            specular,
            specular_tex,
            specular_color,
            specular_color_tex,
            ior,
            transmission,
            transmission_tex,
            medium,
            null_surface,
            subsurface,
            coat,
            coat_tex,
            coat_roughness,
            coat_roughness_tex,
            coat_ior,
            coat_tint,
            coat_normal_tex,
            coat_normal_scale,
            sheen_color,
            sheen_color_tex,
            sheen_roughness,
            sheen_roughness_tex,
            dispersion,
            alpha_mode,
            double_sided: m.double_sided(),
        };
        Ok((mat, MaterialReport { name, features }))
    }

    /// Walks the scene's node trees; returns (node, world matrix) for every node
    /// reached, refusing cycles.
    fn instances(&mut self, doc: &gltf::Document, value: &serde_json::Value) -> Result<Vec<(usize, Mat4)>> {
        let n = doc.nodes().count();
        // Cycle check over the children graph (iterative three-colour DFS).
        let children: Vec<Vec<usize>> = doc.nodes().map(|nd| nd.children().map(|c| c.index()).collect()).collect();
        let mut colour = vec![0u8; n];
        for start in 0..n {
            if colour[start] != 0 {
                continue;
            }
            let mut stack = vec![(start, 0usize)];
            colour[start] = 1;
            while let Some(&mut (node, ref mut next)) = stack.last_mut() {
                if *next < children[node].len() {
                    let c = children[node][*next];
                    *next += 1;
                    match colour[c] {
                        0 => {
                            colour[c] = 1;
                            stack.push((c, 0));
                        }
                        1 => {
                            return Err(self.err(format!("the node hierarchy has a cycle through node {c}")));
                        }
                        _ => {}
                    }
                } else {
                    colour[node] = 2;
                    stack.pop();
                }
            }
        }
        // glTF's nodes form strict trees: one parent at most, and a root is no one's
        // child and listed once. Shared subtrees could multiply instances exponentially.
        let mut parent = vec![None; n];
        for (p, cs) in children.iter().enumerate() {
            for &c in cs {
                if let Some(q) = parent[c] {
                    return Err(
                        self.err(format!("node {c} has two parents (nodes {q} and {p}); glTF nodes form trees"))
                    );
                }
                parent[c] = Some(p);
            }
        }
        let roots: Vec<usize> = if let Some(scene) = doc.default_scene().or_else(|| doc.scenes().next()) {
            if value.get("scene").is_none() && doc.scenes().count() > 1 {
                self.warn("the file has several scenes and no default: rendering scene 0");
            }
            scene.nodes().map(|n| n.index()).collect()
        } else {
            let mut is_child = vec![false; n];
            for c in children.iter().flatten() {
                is_child[*c] = true;
            }
            if n > 0 {
                self.warn("the file has no scene: rendering every root node");
            }
            (0..n).filter(|&i| !is_child[i]).collect()
        };
        let mut seen_root = vec![false; n];
        for &r in &roots {
            if seen_root[r] {
                return Err(self.err(format!("node {r} is listed twice as a root of the scene")));
            }
            seen_root[r] = true;
            if let Some(p) = parent[r] {
                return Err(self.err(format!("node {r} is a root of the scene and also a child of node {p}")));
            }
        }
        let mut out = Vec::new();
        let mut stack: Vec<(usize, Mat4)> = roots.into_iter().rev().map(|r| (r, Mat4::IDENTITY)).collect();
        while let Some((node, parent)) = stack.pop() {
            let nd = doc.nodes().nth(node).expect("validated index");
            let local = Mat4::from_cols_array_2d(&nd.transform().matrix());
            let world = parent * local;
            out.push((node, world));
            if out.len() > MAX_INSTANCES {
                return Err(self.err(format!("more than {MAX_INSTANCES} node instances: shared subtrees explode")));
            }
            for c in children[node].iter().rev() {
                stack.push((*c, world));
            }
        }
        Ok(out)
    }

    /// Appends every triangle primitive of `m` under `world`; returns the number of
    /// degenerate triangles dropped.
    #[allow(clippy::too_many_arguments)]
    /// Charges the world-space mesh that flattening `instances` will build (each
    /// instance copies its mesh's vertices and triangles), before any of it is read:
    /// accessor counts are known from the JSON alone, and a sparse accessor or a shared
    /// subtree can declare far more than the file holds.
    fn charge_mesh(&self, doc: &gltf::Document, instances: &[(usize, Mat4)]) -> Result<()> {
        use gltf::mesh::Mode;
        let mut per_mesh: HashMap<usize, (u64, u64)> = HashMap::new();
        let (mut vertices, mut triangles) = (0u64, 0u64);
        for (node_index, _) in instances {
            let Some(m) = doc.nodes().nth(*node_index).and_then(|n| n.mesh()) else { continue };
            let (v, t) = *per_mesh.entry(m.index()).or_insert_with(|| {
                let (mut v, mut t) = (0u64, 0u64);
                for prim in m.primitives() {
                    let n = prim.get(&gltf::Semantic::Positions).map_or(0, |a| a.count() as u64);
                    let idx = prim.indices().map_or(n, |a| a.count() as u64);
                    v += n;
                    t += match prim.mode() {
                        Mode::Triangles => idx / 3,
                        Mode::TriangleStrip | Mode::TriangleFan => idx.saturating_sub(2),
                        _ => 0,
                    };
                }
                (v, t)
            });
            vertices = vertices.saturating_add(v);
            triangles = triangles.saturating_add(t);
        }
        let bytes = vertices
            .saturating_mul(memory::MESH_BYTES_PER_VERTEX)
            .saturating_add(triangles.saturating_mul(memory::MESH_BYTES_PER_TRIANGLE));
        self.budget.charge(format!("the mesh ({triangles} triangles and {vertices} vertices after instancing)"), bytes)
    }

    fn append_mesh(
        &mut self,
        m: &gltf::Mesh,
        world: &Mat4,
        buffers: &[Vec<u8>],
        materials: &[Material],
        default_material: u32,
        out: &mut Mesh,
    ) -> Result<usize> {
        let mesh_name =
            m.name().map(|n| format!("mesh {} ('{n}')", m.index())).unwrap_or_else(|| format!("mesh {}", m.index()));
        let normal_matrix = Mat3::from_mat4(*world).inverse().transpose();
        let det = Mat3::from_mat4(*world).determinant();
        if !det.is_finite() {
            return Err(self.err(format!("{mesh_name}: an instance's transform is not finite (scale too large?)")));
        }
        if det == 0.0 {
            self.warn(format!("{mesh_name}: an instance has a singular transform (zero scale) and was skipped"));
            return Ok(0);
        }
        let flip = det < 0.0;
        let mut degenerate = 0;
        for prim in m.primitives() {
            let what = format!("{mesh_name} primitive {}", prim.index());
            use gltf::mesh::Mode;
            let mode = prim.mode();
            if matches!(mode, Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip) {
                self.warn(format!("{what}: {mode:?} primitives (points/lines) are not rendered and were skipped"));
                continue;
            }
            let reader = prim.reader(|b| buffers.get(b.index()).map(|v| v.as_slice()));
            let pos_acc = prim
                .get(&gltf::Semantic::Positions)
                .ok_or_else(|| self.err(format!("{what}: no POSITION attribute")))?;
            if pos_acc.data_type() != gltf::accessor::DataType::F32
                || pos_acc.dimensions() != gltf::accessor::Dimensions::Vec3
            {
                return Err(self.err(format!(
                    "{what}: POSITION must be float VEC3 (quantized positions, KHR_mesh_quantization, are not supported)"
                )));
            }
            let positions: Vec<Vec3> = reader
                .read_positions()
                .ok_or_else(|| self.err(format!("{what}: cannot read POSITION")))?
                .map(Vec3::from)
                .collect();
            if positions.len() != pos_acc.count() {
                return Err(self.err(format!("{what}: POSITION data is shorter than its accessor count")));
            }
            if let Some(bad) = positions.iter().position(|p| !p.is_finite()) {
                return Err(self.err(format!("{what}: vertex {bad} has a NaN or infinite position")));
            }
            let nv = positions.len();
            let read_exact = |v: Option<Vec<Vec3>>, name: &str| -> Result<Option<Vec<Vec3>>> {
                match v {
                    Some(v) if v.len() != nv => {
                        Err(self.err(format!("{what}: {name} has {} entries for {nv} vertices", v.len())))
                    }
                    other => Ok(other),
                }
            };
            let normals = read_exact(reader.read_normals().map(|it| it.map(Vec3::from).collect()), "NORMAL")?;
            let tangents: Option<Vec<Vec4>> = reader.read_tangents().map(|it| it.map(Vec4::from).collect());
            let uv0: Option<Vec<Vec2>> = reader.read_tex_coords(0).map(|t| t.into_f32().map(Vec2::from).collect());
            let uv1: Option<Vec<Vec2>> = reader.read_tex_coords(1).map(|t| t.into_f32().map(Vec2::from).collect());
            let colors: Option<Vec<Vec4>> = reader.read_colors(0).map(|c| c.into_rgba_f32().map(Vec4::from).collect());
            for (len, name) in [
                (tangents.as_ref().map(Vec::len), "TANGENT"),
                (uv0.as_ref().map(Vec::len), "TEXCOORD_0"),
                (uv1.as_ref().map(Vec::len), "TEXCOORD_1"),
                (colors.as_ref().map(Vec::len), "COLOR_0"),
            ] {
                if let Some(l) = len
                    && l != nv
                {
                    return Err(self.err(format!("{what}: {name} has {l} entries for {nv} vertices")));
                }
            }
            let raw_indices: Vec<u32> = match reader.read_indices() {
                Some(ix) => ix.into_u32().collect(),
                None => (0..nv as u32).collect(),
            };
            if let Some(&bad) = raw_indices.iter().find(|&&i| i as usize >= nv) {
                return Err(self.err(format!("{what}: index {bad} is out of range (the primitive has {nv} vertices)")));
            }
            let tris: Vec<[u32; 3]> = match mode {
                Mode::Triangles => raw_indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
                Mode::TriangleStrip => (0..raw_indices.len().saturating_sub(2))
                    .map(|i| {
                        let (a, b, c) = (raw_indices[i], raw_indices[i + 1], raw_indices[i + 2]);
                        if i % 2 == 0 { [a, b, c] } else { [b, a, c] }
                    })
                    .collect(),
                Mode::TriangleFan => (1..raw_indices.len().saturating_sub(1))
                    .map(|i| [raw_indices[0], raw_indices[i], raw_indices[i + 1]])
                    .collect(),
                _ => unreachable!("points and lines skipped above"),
            };
            let material_index = prim.material().index().map(|i| i as u32).unwrap_or(default_material);
            let material = &materials[material_index as usize];

            // Tangents for normal maps: given, or generated with MikkTSpace.
            let mut tangents = tangents;
            if let Some(nt) = material.normal_tex
                && tangents.is_none()
            {
                let uv = if nt.tex_coord == 0 { &uv0 } else { &uv1 };
                match (uv, &normals) {
                    (Some(uv), Some(n)) => tangents = Some(mikktspace_tangents(&positions, n, uv, &tris)),
                    _ => self.warn(format!("{what}: a normal map without UVs or normals cannot be applied; ignored")),
                }
            }

            // Append transformed vertices.
            let base = out.positions.len() as u32;
            for i in 0..nv {
                let p = world.transform_point3(positions[i]);
                if !p.is_finite() {
                    return Err(self.err(format!(
                        "{what}: vertex {i} is not finite after its node transform (position or scale too large)"
                    )));
                }
                // Beyond this, bounding-box arithmetic in the BVH build overflows f32.
                if p.abs().max_element() > MAX_COORDINATE {
                    return Err(self.err(format!(
                        "{what}: vertex {i} lies at {p}, beyond ±{MAX_COORDINATE:e} scene units (not supported)"
                    )));
                }
                out.positions.push(p);
                // A zero normal marks "use the geometric normal" (glTF: flat shading
                // when normals are absent).
                let n = normals.as_ref().map(|n| (normal_matrix * n[i]).normalize_or_zero()).unwrap_or(Vec3::ZERO);
                out.normals.push(n);
                let t = tangents
                    .as_ref()
                    .map(|t| {
                        let v = world.transform_vector3(t[i].truncate()).normalize_or_zero();
                        v.extend(if flip { -t[i].w } else { t[i].w })
                    })
                    .unwrap_or(Vec4::ZERO);
                out.tangents.push(t);
                out.uv0.push(uv0.as_ref().map(|u| u[i]).unwrap_or(Vec2::ZERO));
                out.uv1.push(uv1.as_ref().map(|u| u[i]).unwrap_or(Vec2::ZERO));
                out.colors.push(colors.as_ref().map(|c| c[i]).unwrap_or(Vec4::ONE));
            }
            let first_tri = out.triangles.len();
            for t in tris {
                let p = t.map(|i| out.positions[(base + i) as usize]);
                let area2 = (p[1] - p[0]).cross(p[2] - p[0]).length();
                if !(area2 > 0.0) || !area2.is_finite() {
                    degenerate += 1;
                    continue;
                }
                let t = if flip { [t[0], t[2], t[1]] } else { t };
                out.triangles.push(t.map(|i| base + i));
                out.tri_material.push(material_index);
            }
            let material = &materials[material_index as usize];
            if material.medium.is_some() || material.subsurface.is_some() {
                let open = open_edges(&out.positions, &out.triangles[first_tri..]);
                if open > 0 {
                    self.warn(format!(
                        "{what}: material '{}' has a volume or subsurface scattering but the primitive is not closed \
                         ({open} open edges): paths that leave through a hole lose the light the medium would have \
                         scattered (a path escaping to the sky from inside is black)",
                        material.name
                    ));
                }
            }
        }
        Ok(degenerate)
    }

    fn camera(
        &mut self,
        c: &gltf::Camera,
        node_name: &str,
        world: &Mat4,
        blender: Option<serde_json::Value>,
    ) -> Result<Camera> {
        // The node's name is the Blender object's name, which is what users pick by.
        let name = node_name.to_string();
        let projection = match c.projection() {
            gltf::camera::Projection::Perspective(p) => {
                let yfov = p.yfov();
                if !(yfov > 0.0 && yfov < std::f32::consts::PI) {
                    return Err(self.err(format!("camera '{name}': yfov {yfov} must be in (0, π) radians")));
                }
                let aspect = match p.aspect_ratio() {
                    Some(a) if a > 0.0 && a.is_finite() => Some(a),
                    Some(a) => {
                        return Err(self.err(format!("camera '{name}': aspectRatio {a} must be a positive number")));
                    }
                    None => None,
                };
                Projection::Perspective { yfov, aspect }
            }
            gltf::camera::Projection::Orthographic(o) => {
                let (xmag, ymag) = (o.xmag().abs(), o.ymag().abs());
                if !(xmag > 0.0 && ymag > 0.0 && xmag.is_finite() && ymag.is_finite()) {
                    return Err(self.err(format!("camera '{name}': xmag/ymag must be non-zero and finite")));
                }
                Projection::Orthographic { xmag, ymag }
            }
        };
        let mut cam = Camera::from_matrix(name, world, projection);
        cam.data_name = c.name().map(str::to_string);
        if let Some(v) = blender {
            self.camera_extension(&mut cam, v)?;
        }
        Ok(cam)
    }

    /// `CAUSTIC_camera` on a camera's node: Blender's lens shift and depth of field, which
    /// glTF cannot say (docs/contract.md).
    fn camera_extension(&mut self, cam: &mut Camera, v: serde_json::Value) -> Result<()> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct CameraExt {
            #[serde(default)]
            shift: [f32; 2],
            aperture_radius: Option<f32>,
            focus_distance: Option<f32>,
            #[serde(default)]
            blades: u32,
            #[serde(default)]
            blade_rotation: f32,
            aperture_ratio: Option<f32>,
        }
        let name = cam.name.clone();
        let e: CameraExt = serde_json::from_value(v)
            .map_err(|e| self.err(format!("camera '{name}': CAUSTIC_camera is malformed: {e}")))?;
        if !(e.shift[0].is_finite() && e.shift[1].is_finite() && e.shift[0].abs() <= 100.0 && e.shift[1].abs() <= 100.0)
        {
            return Err(self.err(format!("camera '{name}': shift {:?} must be finite (at most 100 frames)", e.shift)));
        }
        cam.shift = Vec2::from(e.shift);
        let Some(radius) = e.aperture_radius else {
            if e.focus_distance.is_some() || e.aperture_ratio.is_some() || e.blades != 0 {
                return Err(self
                    .err(format!("camera '{name}': CAUSTIC_camera gives aperture settings without aperture_radius")));
            }
            return Ok(());
        };
        if !(radius.is_finite() && radius >= 0.0) {
            return Err(self.err(format!("camera '{name}': aperture_radius {radius} must be finite and >= 0")));
        }
        let focus_distance = e.focus_distance.unwrap_or(10.0);
        if !(focus_distance.is_finite() && focus_distance > 0.0) {
            return Err(self.err(format!("camera '{name}': focus_distance {focus_distance} must be positive")));
        }
        let ratio = e.aperture_ratio.unwrap_or(1.0);
        if !(ratio.is_finite() && ratio > 0.0) {
            return Err(self.err(format!("camera '{name}': aperture_ratio {ratio} must be positive")));
        }
        if !e.blade_rotation.is_finite() {
            return Err(self.err(format!("camera '{name}': blade_rotation must be finite")));
        }
        if e.blades == 1 || e.blades == 2 || e.blades > 1000 {
            return Err(self.err(format!("camera '{name}': {} blades: use 0 (round) or 3..=1000", e.blades)));
        }
        // Radius 0 is Blender's depth of field at an infinite f-stop: a pinhole.
        if radius > 0.0 {
            cam.lens = Some(Lens { radius, focus_distance, blades: e.blades, rotation: e.blade_rotation, ratio });
        }
        Ok(())
    }

    fn punctual_light(
        &mut self,
        l: &gltf::khr_lights_punctual::Light,
        node_name: &str,
        world: &Mat4,
        blender: Option<serde_json::Value>,
    ) -> Result<(Light, LightReport)> {
        let name = l.name().map(str::to_string).unwrap_or_else(|| node_name.to_string());
        let intensity = l.intensity();
        let color = Vec3::from(l.color());
        if !(intensity >= 0.0 && intensity.is_finite() && color.is_finite()) || color.min_element() < 0.0 {
            return Err(self.err(format!("light '{name}': intensity and color must be finite and non-negative")));
        }
        if l.range().is_some() {
            self.warn(format!("light '{name}': 'range' is ignored (Caustic's lights fall off physically, as Cycles')"));
        }
        let position = world.transform_point3(Vec3::ZERO);
        let forward = world.transform_vector3(-Vec3::Z).normalize_or(-Vec3::Z);
        let radiometric = color * (intensity / LUMENS_PER_WATT);
        // Blender's light shape parameters (`CAUSTIC_lights_punctual`, written by the add-on).
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct BlenderLight {
            #[serde(default)]
            radius: f32,
            #[serde(default)]
            angle: f32,
            spot_blend: Option<f32>,
            #[serde(default)]
            soft_falloff: bool,
            #[serde(default = "yes")]
            camera_visible: bool,
        }
        impl Default for BlenderLight {
            fn default() -> Self {
                BlenderLight { radius: 0.0, angle: 0.0, spot_blend: None, soft_falloff: false, camera_visible: true }
            }
        }
        let bl: BlenderLight = match blender {
            None => BlenderLight::default(),
            Some(v) => serde_json::from_value(v)
                .map_err(|e| self.err(format!("light '{name}': CAUSTIC_lights_punctual is malformed: {e}")))?,
        };
        if !(bl.radius.is_finite() && bl.radius >= 0.0 && bl.angle.is_finite() && bl.angle >= 0.0)
            || bl.spot_blend.is_some_and(|b| !(b.is_finite() && b >= 0.0))
        {
            return Err(self.err(format!("light '{name}': CAUSTIC_lights_punctual values must be finite and ≥ 0")));
        }
        use gltf::khr_lights_punctual::Kind;
        if bl.radius > 0.0 && matches!(l.kind(), Kind::Spot { .. }) {
            self.warn(format!("light '{name}': a spot's radius is not supported; rendered as a point spot"));
        }
        let (light, kind) = match l.kind() {
            Kind::Point if bl.radius > 0.0 => {
                // The sphere radiates the point's power: L = P / (4π² r²), P = 4π I.
                let r = bl.radius;
                let radiance = radiometric / (std::f32::consts::PI * r * r);
                (
                    Light::Sphere {
                        center: position,
                        radius: r,
                        radiance,
                        soft: bl.soft_falloff,
                        camera_visible: bl.camera_visible,
                    },
                    "point",
                )
            }
            Kind::Point => (Light::Point { position, intensity: radiometric }, "point"),
            Kind::Directional => {
                let half = (0.5 * bl.angle).min(std::f32::consts::FRAC_PI_2);
                (
                    Light::Directional { direction: forward, irradiance: radiometric, cos_half: half.cos() },
                    "directional",
                )
            }
            Kind::Spot { inner_cone_angle, outer_cone_angle } => {
                let outer = outer_cone_angle.clamp(1e-4, std::f32::consts::FRAC_PI_2);
                let inner = inner_cone_angle.clamp(0.0, outer);
                if outer != outer_cone_angle || inner != inner_cone_angle {
                    self.warn(format!("light '{name}': spot cone angles were clamped to 0 ≤ inner ≤ outer ≤ π/2"));
                }
                (
                    Light::Spot {
                        position,
                        direction: forward,
                        intensity: radiometric,
                        cos_inner: inner.cos(),
                        cos_outer: outer.cos(),
                        smooth: bl.spot_blend.map(|b| 1.0 / ((1.0 - outer.cos()) * b).max(1e-12)),
                    },
                    "spot",
                )
            }
        };
        Ok((light, LightReport { kind: kind.into(), name, power: 0.0, triangles: 0 }))
    }

    fn area_light(
        &mut self,
        ext: &serde_json::Value,
        name: &str,
        world: &Mat4,
    ) -> Result<Option<(Light, LightReport)>> {
        let a: AreaLightExt = serde_json::from_value(ext.clone())
            .map_err(|e| self.err(format!("node '{name}': CAUSTIC_lights_area is malformed: {e}")))?;
        let shape = match a.shape.as_str() {
            "rectangle" | "square" => AreaShape::Rectangle,
            "disk" | "ellipse" => AreaShape::Ellipse,
            other => {
                return Err(self.err(format!(
                    "node '{name}': CAUSTIC_lights_area shape '{other}' is unknown (rectangle, square, disk, ellipse)"
                )));
            }
        };
        let sx = *a.size.first().ok_or_else(|| self.err(format!("node '{name}': CAUSTIC_lights_area has no size")))?;
        let sy = if matches!(a.shape.as_str(), "square" | "disk") { sx } else { a.size.get(1).copied().unwrap_or(sx) };
        let color = Vec3::from(a.color);
        if !(a.power >= 0.0 && a.power.is_finite() && color.is_finite() && sx.is_finite() && sy.is_finite())
            || color.min_element() < 0.0
        {
            return Err(self.err(format!(
                "node '{name}': CAUSTIC_lights_area power, color and size must be finite and non-negative"
            )));
        }
        if !(a.spread > 0.0 && a.spread <= std::f32::consts::PI + 1e-4) {
            return Err(
                self.err(format!("node '{name}': CAUSTIC_lights_area spread {} must be in (0, π] radians", a.spread))
            );
        }
        if a.spread < crate::light::MIN_SPREAD {
            self.warn(format!(
                "area light '{name}': spread {:.2e} rad is rendered as {:.0e} rad (a collimated beam is not supported)",
                a.spread,
                crate::light::MIN_SPREAD
            ));
        }
        let center = world.transform_point3(Vec3::ZERO);
        let ax = world.transform_vector3(Vec3::X * (0.5 * sx));
        let ay = world.transform_vector3(Vec3::Y * (0.5 * sy));
        let emit = world.transform_vector3(-Vec3::Z);
        match AreaLight::new(shape, center, ax, ay, emit, color * a.power)
            .map(|l| AreaLight { camera_visible: a.camera_visible, ..l }.with_spread(a.spread))
        {
            Some(l) => Ok(Some((
                Light::Area(l),
                LightReport { kind: "area".into(), name: name.into(), power: 0.0, triangles: 0 },
            ))),
            None => {
                self.warn(format!("area light '{name}' has zero area and was skipped"));
                Ok(None)
            }
        }
    }
}

/// Power used for light selection and reported by `info` (luminance, W).
fn punctual_power(l: &Light, scene_radius: f32) -> f32 {
    use std::f32::consts::PI;
    match l {
        Light::Point { intensity, .. } => 4.0 * PI * luminance(*intensity),
        // A spot's power is bounded by its cone; Blender's spots have a point's
        // intensity, so use the cone's solid angle.
        Light::Spot { intensity, cos_outer, .. } => 2.0 * PI * (1.0 - cos_outer) * luminance(*intensity),
        Light::Sphere { radius, radiance, .. } => 4.0 * PI * PI * radius * radius * luminance(*radiance),
        Light::Directional { irradiance, .. } => PI * scene_radius * scene_radius * luminance(*irradiance),
        Light::Area(a) => luminance(a.radiance) * a.area * PI,
        Light::Triangle { .. } | Light::World => 0.0,
    }
}

/// Edges used by an odd number of the triangles: 0 for a closed surface. Vertices are
/// joined by position rounded to 10⁻⁶ of the primitive's size, so that vertices split
/// for UV seams or hard edges, or computed twice with rounding (a sphere's seam and
/// poles), still join.
fn open_edges(positions: &[Vec3], tris: &[[u32; 3]]) -> usize {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for t in tris {
        for &i in t {
            lo = lo.min(positions[i as usize]);
            hi = hi.max(positions[i as usize]);
        }
    }
    let scale = 1e6 / (hi - lo).max_element().max(1e-30);
    let key = |i: u32| (positions[i as usize] * scale).round().to_array().map(|c| c as i64);
    let mut count: HashMap<([i64; 3], [i64; 3]), u32> = HashMap::new();
    for t in tris {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            let (ka, kb) = (key(a), key(b));
            if ka != kb {
                *count.entry(if ka < kb { (ka, kb) } else { (kb, ka) }).or_default() += 1;
            }
        }
    }
    count.values().filter(|&&c| c % 2 == 1).count()
}

fn push_unique(v: &mut Vec<String>, s: &str) {
    if !v.iter().any(|x| x == s) {
        v.push(s.to_string());
    }
}

fn describe_validation(e: &gltf::Error) -> String {
    match e {
        gltf::Error::Validation(errs) => {
            errs.iter().take(5).map(|(path, err)| format!("{}: {err}", path.as_str())).collect::<Vec<_>>().join("; ")
        }
        other => other.to_string(),
    }
}

/// A camera looking at the bounds from +Z, far enough to see them all.
fn frame_bounds(lo: Vec3, hi: Vec3) -> Camera {
    let c = (lo + hi) * 0.5;
    let r = ((hi - lo).length() * 0.5).max(1e-3);
    let yfov = 40f32.to_radians();
    let dist = r / (0.5 * yfov).sin();
    let m = Mat4::from_translation(c + Vec3::Z * dist);
    Camera::from_matrix("auto".into(), &m, Projection::Perspective { yfov, aspect: None })
}

/// MikkTSpace tangents for an indexed triangle list, per vertex.
fn mikktspace_tangents(positions: &[Vec3], normals: &[Vec3], uvs: &[Vec2], tris: &[[u32; 3]]) -> Vec<Vec4> {
    struct Geo<'a> {
        p: &'a [Vec3],
        n: &'a [Vec3],
        uv: &'a [Vec2],
        tris: &'a [[u32; 3]],
        out: Vec<Vec4>,
    }
    impl mikktspace::Geometry for Geo<'_> {
        fn num_faces(&self) -> usize {
            self.tris.len()
        }
        fn num_vertices_of_face(&self, _face: usize) -> usize {
            3
        }
        fn position(&self, face: usize, vert: usize) -> [f32; 3] {
            self.p[self.tris[face][vert] as usize].to_array()
        }
        fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
            self.n[self.tris[face][vert] as usize].to_array()
        }
        fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
            self.uv[self.tris[face][vert] as usize].to_array()
        }
        fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
            self.out[self.tris[face][vert] as usize] = Vec4::from(tangent);
        }
    }
    let mut g = Geo { p: positions, n: normals, uv: uvs, tris, out: vec![Vec4::ZERO; positions.len()] };
    mikktspace::generate_tangents(&mut g);
    g.out
}

/// Checks that every index in the document points into its array, with a message naming
/// the JSON path of the first one that does not.
fn check_references(v: &serde_json::Value) -> std::result::Result<(), String> {
    use serde_json::Value;
    let len = |key: &str| v.get(key).and_then(Value::as_array).map_or(0, Vec::len);
    let check = |value: Option<&Value>, target: &str, path: &str| -> std::result::Result<(), String> {
        let Some(value) = value else { return Ok(()) };
        let n = len(target);
        match value.as_u64() {
            Some(i) if (i as usize) < n => Ok(()),
            _ => Err(format!("{path} = {value} is not a valid index into {target} (the file has {n})")),
        }
    };
    let items = |key: &str| v.get(key).and_then(Value::as_array).cloned().unwrap_or_default();
    check(v.get("scene"), "scenes", "scene")?;
    for (i, sc) in items("scenes").iter().enumerate() {
        for (j, n) in sc.get("nodes").and_then(Value::as_array).into_iter().flatten().enumerate() {
            check(Some(n), "nodes", &format!("scenes[{i}].nodes[{j}]"))?;
        }
    }
    let light_count = v.pointer("/extensions/KHR_lights_punctual/lights").and_then(Value::as_array).map_or(0, Vec::len);
    for (i, node) in items("nodes").iter().enumerate() {
        for (j, c) in node.get("children").and_then(Value::as_array).into_iter().flatten().enumerate() {
            check(Some(c), "nodes", &format!("nodes[{i}].children[{j}]"))?;
        }
        check(node.get("mesh"), "meshes", &format!("nodes[{i}].mesh"))?;
        check(node.get("camera"), "cameras", &format!("nodes[{i}].camera"))?;
        check(node.get("skin"), "skins", &format!("nodes[{i}].skin"))?;
        if let Some(l) = node.pointer("/extensions/KHR_lights_punctual/light")
            && l.as_u64().is_none_or(|l| l as usize >= light_count)
        {
            return Err(format!("nodes[{i}] refers to light {l}, but the file has {light_count} lights"));
        }
    }
    for (i, mesh) in items("meshes").iter().enumerate() {
        for (j, prim) in mesh.get("primitives").and_then(Value::as_array).into_iter().flatten().enumerate() {
            let path = format!("meshes[{i}].primitives[{j}]");
            for (name, a) in prim.get("attributes").and_then(Value::as_object).into_iter().flatten() {
                check(Some(a), "accessors", &format!("{path}.attributes.{name}"))?;
            }
            check(prim.get("indices"), "accessors", &format!("{path}.indices"))?;
            check(prim.get("material"), "materials", &format!("{path}.material"))?;
            for (k, t) in prim.get("targets").and_then(Value::as_array).into_iter().flatten().enumerate() {
                for (name, a) in t.as_object().into_iter().flatten() {
                    check(Some(a), "accessors", &format!("{path}.targets[{k}].{name}"))?;
                }
            }
        }
    }
    for (i, a) in items("accessors").iter().enumerate() {
        check(a.get("bufferView"), "bufferViews", &format!("accessors[{i}].bufferView"))?;
        check(a.pointer("/sparse/indices/bufferView"), "bufferViews", &format!("accessors[{i}].sparse.indices"))?;
        check(a.pointer("/sparse/values/bufferView"), "bufferViews", &format!("accessors[{i}].sparse.values"))?;
    }
    for (i, bv) in items("bufferViews").iter().enumerate() {
        check(bv.get("buffer").or(Some(&Value::Null)), "buffers", &format!("bufferViews[{i}].buffer"))?;
    }
    for (i, t) in items("textures").iter().enumerate() {
        check(t.get("source"), "images", &format!("textures[{i}].source"))?;
        check(t.get("sampler"), "samplers", &format!("textures[{i}].sampler"))?;
    }
    for (i, im) in items("images").iter().enumerate() {
        check(im.get("bufferView"), "bufferViews", &format!("images[{i}].bufferView"))?;
    }
    // Texture references anywhere in a material (core slots and extensions): "index" keys.
    fn texture_indices(v: &Value, path: String, out: &mut Vec<(String, Value)>) {
        match v {
            Value::Object(m) => {
                for (k, x) in m {
                    if k == "index" {
                        out.push((format!("{path}.index"), x.clone()));
                    } else {
                        texture_indices(x, format!("{path}.{k}"), out);
                    }
                }
            }
            Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    texture_indices(x, format!("{path}[{i}]"), out);
                }
            }
            _ => {}
        }
    }
    for (i, m) in items("materials").iter().enumerate() {
        let mut refs = Vec::new();
        texture_indices(m, format!("materials[{i}]"), &mut refs);
        for (path, r) in refs {
            check(Some(&r), "textures", &path)?;
        }
    }
    for (i, skin) in items("skins").iter().enumerate() {
        check(skin.get("inverseBindMatrices"), "accessors", &format!("skins[{i}].inverseBindMatrices"))?;
        check(skin.get("skeleton"), "nodes", &format!("skins[{i}].skeleton"))?;
        for (j, n) in skin.get("joints").and_then(Value::as_array).into_iter().flatten().enumerate() {
            check(Some(n), "nodes", &format!("skins[{i}].joints[{j}]"))?;
        }
    }
    for (i, anim) in items("animations").iter().enumerate() {
        let samplers = anim.get("samplers").and_then(Value::as_array).cloned().unwrap_or_default();
        for (j, s) in samplers.iter().enumerate() {
            check(s.get("input"), "accessors", &format!("animations[{i}].samplers[{j}].input"))?;
            check(s.get("output"), "accessors", &format!("animations[{i}].samplers[{j}].output"))?;
        }
        for (j, c) in anim.get("channels").and_then(Value::as_array).into_iter().flatten().enumerate() {
            check(c.pointer("/target/node"), "nodes", &format!("animations[{i}].channels[{j}].target.node"))?;
            match c.get("sampler").and_then(Value::as_u64) {
                Some(s) if (s as usize) < samplers.len() => {}
                other => {
                    return Err(format!(
                        "animations[{i}].channels[{j}].sampler = {other:?} is not a valid sampler index"
                    ));
                }
            }
        }
    }
    Ok(())
}
