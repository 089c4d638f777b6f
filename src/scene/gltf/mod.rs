//! The glTF 2.0 loader: the only module that touches the `gltf` crate.
//!
//! Reads .gltf (external or data-URI buffers and images) and .glb, flattens the node
//! hierarchy into world-space triangles, and converts materials, cameras, lights and
//! the `CAUSTIC_*` extensions into the renderer's own types. Every defect of the input
//! becomes an [`Error::Scene`] naming the file and the offending object; every guess
//! or dropped feature becomes a warning in [`Scene::warnings`].
//!
//! One file per loading step, all methods of one [`Loader`]: this file reads the
//! container and orchestrates; `validate.rs` checks indices, views and accessor types
//! before the `gltf` crate sees them; `textures.rs` decodes images; `materials.rs`
//! converts materials; `nodes.rs` flattens the node trees; `mesh.rs` reads primitives
//! and generates tangents; `cameras.rs`, `lights.rs` and `world.rs` the rest;
//! `extensions.rs` holds the serde shapes of the `CAUSTIC_*` extensions.

mod attributes;
mod buffers;
mod cameras;
mod curves;
mod deformation;
mod displace;
mod draco;
mod emission;
mod extensions;
mod gpu_instancing;
mod iridescence;
mod light_groups;
mod light_linking;
mod light_nodes;
mod lights;
mod material_ext;
mod materials;
mod mesh;
mod meshopt;
mod motion;
mod nodes;
mod pass_ids;
mod points;
mod pose;
mod procedural_volume;
mod quantized;
mod shader_graph;
pub(crate) use lights::{punctual_power, triangle_light_power};
pub(crate) use shader_graph::{colorspace_converts, colorspace_is_srgb, graph_material, mean_node_emission};
mod spec_gloss;
mod textures;
mod validate;
mod volume;
mod world;

use super::texture::Texture;
use super::{CameraReport, LightReport, LoadProfile, LoadReport, Material, Mesh, Projection, Scene, SceneSettings};
use crate::error::{Error, Result};
use crate::light::Light;
use crate::memory::MemoryBudget;
use crate::scene::linking::{LightLinking, ReceiverRule};
use cameras::frame_bounds;
use extensions::ObjectVisibilityExt;
use glam::Vec2;
use gltf::json;
use std::collections::HashMap;
use std::path::Path;
use std::time::Instant;
use validate::check_references;

/// Extensions that Caustic renders, and so accepts in `extensionsRequired`: every one the
/// loader reads.
pub const SUPPORTED_REQUIRED: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_texture_transform",
    "KHR_materials_transmission",
    "KHR_materials_diffuse_transmission",
    "KHR_materials_ior",
    "KHR_materials_volume",
    "KHR_materials_clearcoat",
    "KHR_materials_specular",
    "KHR_materials_sheen",
    "KHR_materials_dispersion",
    "KHR_materials_unlit",
    "KHR_materials_anisotropy",
    "KHR_materials_iridescence",
    "KHR_materials_pbrSpecularGlossiness",
    "KHR_mesh_quantization",
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "EXT_texture_webp",
    "EXT_mesh_gpu_instancing",
    "KHR_node_visibility",
    "CAUSTIC_lights_area",
    "CAUSTIC_lights_punctual",
    "CAUSTIC_materials_nodes",
    "CAUSTIC_camera",
    "CAUSTIC_world",
    "CAUSTIC_materials_medium",
    "CAUSTIC_materials_subsurface",
    "CAUSTIC_materials_coat",
    "CAUSTIC_materials_anisotropy",
    "CAUSTIC_materials_sheen",
    "CAUSTIC_materials_iridescence",
    "CAUSTIC_materials_shadow",
    "CAUSTIC_default_material",
    "CAUSTIC_volume",
    "CAUSTIC_motion",
];

/// Extensions accepted in `extensionsRequired` though Caustic cannot render them, because
/// what they carry can be left out with a warning naming it: `KHR_texture_basisu` (a KTX2
/// texture without a fallback is dropped from its material, `textures::basisu_only_textures`)
/// and `KHR_materials_variants` (each primitive's own material, the file's default, is
/// rendered, as when the extension is only used: Blender's exporter lists it as required).
pub const DEGRADED_REQUIRED: &[&str] = &["KHR_texture_basisu", "KHR_materials_variants"];

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

/// A decoded image: width, height, RGBA8 texels (shared by the textures that use it).
type DecodedImage = (u32, u32, std::sync::Arc<Vec<[u8; 4]>>);

/// Key of a decoded texture: (image, sRGB, sampler).
type TexKey = (usize, bool, Option<usize>);

/// The loader's state while one file is read: its name and folder, the memory budget,
/// the warnings so far, and the textures decoded so far (each image decoded once).
struct Loader<'a> {
    file: &'a str,
    base_dir: &'a Path,
    budget: &'a MemoryBudget,
    warnings: Vec<String>,
    textures: Vec<Texture>,
    texture_cache: HashMap<TexKey, u32>,
    images: HashMap<usize, DecodedImage>,
    /// Textures whose only image is KTX2 (`KHR_texture_basisu` without a fallback).
    basisu_only: std::collections::HashSet<usize>,
    profile: LoadProfile,
    /// External files read so far (URI, content hash), for `Scene::source_hash`; a cell
    /// because files are read through `&self`.
    files_read: std::cell::RefCell<Vec<(String, u64)>>,
    /// Whether the file declares KHR_mesh_quantization (integer vertex attributes).
    quantization: quantized::Quantization,
    /// The world graph, when it has AOV Output nodes (for `ShaderAovs::resolve`).
    world_aovs: Option<crate::light::world_graph::WorldGraph>,
    /// The attributes the materials' graphs read by name (only those are kept on the mesh).
    attribute_keys: std::collections::HashSet<crate::scene::mesh::AttributeKey>,
    /// (material, attribute) → the meshes of that material's primitives without it, for the
    /// warnings after the mesh is built (`attributes::warn_missing`).
    attribute_gaps: HashMap<(u32, crate::scene::mesh::AttributeKey), Vec<String>>,
    /// The scene's working colour space (`extras.caustic.working_space`) and its name.
    space: crate::scene::working_space::WorkingSpace,
    space_name: Option<String>,
    /// Simplify's Texture Limit (`extras.caustic.texture_limit`), applied to every image.
    texture_limit: Option<u32>,
}

/// An emitter's light linking rules: receivers, blockers (`CAUSTIC_light_linking`).
type Links = (Option<ReceiverRule>, Option<ReceiverRule>);

/// What the crate's JSON types require and glTF leaves optional, supplied for the crate: a
/// scene's `nodes` (an empty scene) and an animation channel's `target.node` (absent when an
/// extension such as `KHR_animation_pointer` names the target). Neither changes the render:
/// such channels are dropped from the crate's copy (animations are not played, and named in a
/// warning, `Loader::load`).
fn relax_for_crate(root: &mut serde_json::Map<String, serde_json::Value>) {
    for scene in root.get_mut("scenes").and_then(|s| s.as_array_mut()).into_iter().flatten() {
        if let Some(scene) = scene.as_object_mut() {
            scene.entry("nodes").or_insert_with(|| serde_json::Value::Array(Vec::new()));
        }
    }
    for animation in root.get_mut("animations").and_then(|a| a.as_array_mut()).into_iter().flatten() {
        if let Some(channels) = animation.get_mut("channels").and_then(|c| c.as_array_mut()) {
            channels.retain(|c| c.pointer("/target/node").is_some());
        }
    }
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
            basisu_only: Default::default(),
            profile: LoadProfile::default(),
            files_read: Default::default(),
            quantization: quantized::Quantization::Core,
            world_aovs: None,
            attribute_keys: Default::default(),
            attribute_gaps: HashMap::new(),
            space: Default::default(),
            space_name: None,
            texture_limit: None,
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

    /// The typed document of `value`, with the crate's index validation. The crate refuses
    /// every required extension outside its own few features, including those Caustic
    /// reads from the raw JSON: they were checked before, so it does not see the list.
    fn typed_document(&self, value: &serde_json::Value) -> Result<gltf::Document> {
        let mut for_crate = value.clone();
        if let Some(root) = for_crate.as_object_mut() {
            root.remove("extensionsRequired");
            relax_for_crate(root);
        }
        let root: json::Root = serde_json::from_value(for_crate).map_err(|e| self.err(format!("invalid glTF: {e}")))?;
        gltf::Document::from_json(root).map_err(|e| self.err(format!("invalid glTF: {}", describe_validation(&e))))
    }

    fn load(mut self, bytes: &[u8]) -> Result<Scene> {
        let start = Instant::now();
        // 1. Container: GLB or JSON.
        let (json_bytes, mut bin): (Vec<u8>, Option<Vec<u8>>) = if bytes.starts_with(b"glTF") {
            let glb = gltf::binary::Glb::from_slice(bytes)
                .map_err(|e| self.err(format!("malformed GLB container: {e} (truncated or corrupt file?)")))?;
            (glb.json.into_owned(), glb.bin.map(|b| b.into_owned()))
        } else if bytes.len() >= 4 && &bytes[..4] != b"glTF" && bytes.iter().take(16).any(|&b| b == 0) {
            return Err(self.err("not a glTF file: binary data without the 'glTF' magic"));
        } else {
            (bytes.to_vec(), None)
        };

        // 2. JSON, with its position on error.
        let mut value: serde_json::Value =
            serde_json::from_slice(&json_bytes).map_err(|e| self.err(format!("invalid JSON: {e}")))?;
        if !value.is_object() {
            return Err(self.err("invalid glTF: the JSON root is not an object"));
        }
        textures::prefer_webp_sources(&mut value);
        self.basisu_only = textures::basisu_only_textures(&mut value);
        let version = value.pointer("/asset/version").and_then(|v| v.as_str()).unwrap_or("");
        if !version.starts_with("2.") {
            return Err(self.err(format!(
                "unsupported glTF version '{version}' (asset.version must be 2.x; is this a glTF 2.0 file?)"
            )));
        }
        // 3. Required extensions we cannot honour are refused by name.
        if let Some(req) = value.get("extensionsRequired").and_then(|v| v.as_array()) {
            let unsupported: Vec<&str> = req
                .iter()
                .filter_map(|v| v.as_str())
                .filter(|name| !SUPPORTED_REQUIRED.contains(name) && !DEGRADED_REQUIRED.contains(name))
                .collect();
            if !unsupported.is_empty() {
                return Err(self.err(format!(
                    "the file requires unsupported extension(s): {} (Caustic supports {})",
                    unsupported.join(", "),
                    SUPPORTED_REQUIRED.join(", ")
                )));
            }
        }
        let settings = self.parse_settings(&value)?;
        self.space = crate::scene::working_space::WorkingSpace::of(settings.working_space.as_ref())
            .map_err(|e| self.err(format!("scene extras 'caustic': {e}")))?;
        self.space_name = settings.working_space.as_ref().map(|w| w.name.clone());
        if settings.texture_limit == Some(0) {
            return Err(self.err("scene extras 'caustic': texture_limit 0 is not a size (leave it out for no limit)"));
        }
        self.texture_limit = settings.texture_limit;
        // The crate's own validation indexes arrays with the file's indices unchecked
        // (a dangling accessor index panics inside it): check every reference first.
        check_references(&value).map_err(|e| self.err(e))?;

        // 4. Compressed geometry decoded into buffers of the loader's own: meshopt's views
        // pointed at theirs (the fallback buffers never read), then Draco's primitives read by
        // rewritten accessors. The crate refuses Draco's accessors without a bufferView, so
        // this reads the buffers through a document of the buffers alone.
        let mut draco_buffers = None;
        let meshopt = meshopt::present(&value);
        if meshopt || draco::present(&value) {
            if meshopt {
                meshopt::empty_fallbacks(&mut value);
            }
            let only_buffers = serde_json::json!({
                "asset": value["asset"],
                "buffers": value.get("buffers").cloned().unwrap_or_else(|| serde_json::json!([])),
            });
            let mut buffers = self.load_buffers(&self.typed_document(&only_buffers)?, bin.take())?;
            if meshopt {
                self.decode_meshopt(&mut value, &mut buffers)?;
            }
            self.decode_draco(&mut value, &mut buffers)?;
            draco_buffers = Some(buffers);
        }

        // 5. Typed document with the crate's index validation, and buffers.
        let doc = self.typed_document(&value)?;
        let buffers = match draco_buffers {
            Some(buffers) => buffers,
            None => self.load_buffers(&doc, bin)?,
        };
        self.check_views_and_accessors(&doc, &buffers)?;
        if doc.extensions_used().any(|e| e == "KHR_mesh_quantization") {
            self.quantization = quantized::Quantization::Allowed;
        }
        self.check_accessor_types(&doc)?;

        self.profile.parse = start.elapsed().as_secs_f64();

        // 6. Materials (textures decoded on first use).
        let phase = Instant::now();
        let mut materials = Vec::new();
        let mut material_reports = Vec::new();
        for m in doc.materials() {
            let (mat, rep) = self.material(&doc, &m, &buffers)?;
            materials.push(mat);
            material_reports.push(rep);
        }
        let default_material = self.default_material(&value, &mut materials)?;
        self.profile.materials = phase.elapsed().as_secs_f64() - self.profile.decode_textures;
        self.attribute_keys = attributes::keys_read(&materials);

        // 7. Node graph to instances.
        let phase = Instant::now();
        let instances = self.instances(&doc, &value)?;
        self.charge_mesh(&doc, &instances)?;

        let mut mesh = Mesh::default();
        // Volume objects first: their boxes are plain triangles with a volume-only material.
        let mut grids = self.volumes(&value, &mut mesh, &mut materials)?;
        let mut cameras = Vec::new();
        let mut lights = Vec::new();
        // The node name of each light from a node, for its light group.
        let mut light_nodes: Vec<Option<String>> = Vec::new();
        // Lights whose node tree varies over them, by light index (`light::light_graph`).
        let mut light_graphs: Vec<(usize, crate::light::light_graph::LightGraph)> = Vec::new();
        // Lights whose Cast Shadow is off, by index in `lights`.
        let mut shadowless = Vec::new();
        let mut no_catcher = Vec::new();
        let mut hidden_lights = Vec::new();
        // Lights with a Max Bounces of their own: (index in `lights`, limit).
        let mut bounded_lights = Vec::new();
        let mut light_reports = Vec::new();
        let mut used_meshes = std::collections::HashSet::new();
        let mut instance_count = 0;
        let mut degenerate = 0;
        let mut area_lights = Vec::new();
        // Shader graphs read the instance (Object coordinates, Object Info, Generated):
        // per-triangle instance indices are kept only when a graph is present.
        let graphs = materials.iter().any(|m| m.nodes.is_some() || m.volume_program.is_some());
        let mut objects: Vec<crate::shader::geom::ObjectData> = Vec::new();
        let mut ray_visibility = crate::scene::visibility::RayVisibility::default();
        // Light linking: every triangle's object is kept only when some emitter has a rule.
        let linked = doc.nodes().any(|n| n.extension_value("CAUSTIC_light_linking").is_some());
        let mut linking = LightLinking::default();
        // An emitter's rules: (receivers, blockers).
        let mut light_rules: Vec<(usize, Links)> = Vec::new();
        let mut node_rules: HashMap<u32, Links> = HashMap::new();
        let mut instances_out = Vec::new();
        let mut undisplaced = displace::Undisplaced::default();
        // (node, name, end of its triangles) of each mesh instance, for the pass ids.
        let mut id_spans = Vec::new();
        // Joints' world matrices, for skinned meshes only (joints may lie outside the scene).
        let worlds = if doc.nodes().any(|n| n.skin().is_some() && n.mesh().is_some()) {
            pose::node_worlds(&doc)
        } else {
            Vec::new()
        };
        let animations: Vec<String> = doc
            .animations()
            .map(|a| a.name().map(|n| format!("'{n}'")).unwrap_or_else(|| format!("animation {}", a.index())))
            .collect();
        if !animations.is_empty() {
            self.warn(format!(
                "the file's animations ({}) are not played: the scene is rendered in its rest pose (the nodes' \
                 own transforms and the meshes' default morph weights)",
                animations.join(", ")
            ));
        }
        // The node of each instance span and of each camera, for `CAUSTIC_motion`.
        let (mut span_nodes, mut camera_nodes) = (Vec::new(), Vec::new());
        // Nodes whose meshes or lights `KHR_node_visibility` hides, named in one note.
        let mut hidden_nodes = Vec::new();
        for (node_index, world, visible) in &instances {
            let node = doc.nodes().nth(*node_index).expect("validated index");
            let node_name = node.name().map(str::to_string).unwrap_or_else(|| format!("node {node_index}"));
            let visible = *visible;
            if !visible
                && (node.mesh().is_some()
                    || node.light().is_some()
                    || node.extension_value("CAUSTIC_lights_area").is_some())
            {
                hidden_nodes.push(format!("'{node_name}'"));
            }
            if !world.is_finite() {
                return Err(self.err(format!("node {node_index} ('{node_name}'): transform is not finite")));
            }
            let rule = match node.extension_value("CAUSTIC_light_linking") {
                Some(ext) => {
                    linking.emitters.push(node_name.clone());
                    Some(self.receiver_rule(&value, &doc, *node_index, &node_name, ext)?)
                }
                None => None,
            };
            if let Some(m) = node.mesh().filter(|_| visible) {
                used_meshes.insert(m.index());
                // EXT_mesh_gpu_instancing draws the mesh once per row of its attributes.
                let copies = self.mesh_copies(&doc, &node, &node_name, world, &buffers)?;
                for world in &copies {
                    instance_count += 1;
                    let (v0, t0) = (mesh.positions.len() as u32, mesh.triangles.len() as u32);
                    let first = t0 as usize;
                    let pose = self.node_pose(&node, &m, &worlds, &buffers)?;
                    let per_object = self.object_attributes(&value, *node_index, &node_name)?;
                    degenerate += self.append_mesh(
                        &m,
                        world,
                        &pose,
                        &buffers,
                        &materials,
                        default_material,
                        &per_object,
                        &mut mesh,
                    )?;
                    if let Some(ext) = node.extension_value("CAUSTIC_object_visibility") {
                        let vis: ObjectVisibilityExt = serde_json::from_value(ext.clone()).map_err(|e| {
                            self.err(format!("node {node_index} ('{node_name}'): bad CAUSTIC_object_visibility: {e}"))
                        })?;
                        let total = mesh.triangles.len();
                        ray_visibility.mark(&node_name, first..total, total, vis.mask());
                        if vis.holdout {
                            ray_visibility.mark_holdout(&node_name, first..total, total);
                        }
                        if vis.shadow_catcher {
                            ray_visibility.mark_catcher(&node_name, first..total, total);
                        }
                    }
                    if let Some(ext) = node.extension_value("CAUSTIC_object_shading") {
                        let shading: extensions::ObjectShadingExt =
                            serde_json::from_value(ext.clone()).map_err(|e| {
                                self.err(format!("node {node_index} ('{node_name}'): bad CAUSTIC_object_shading: {e}"))
                            })?;
                        let offset = shading.shadow_terminator_offset;
                        if !(offset.is_finite() && offset >= 0.0) {
                            return Err(self.err(format!(
                                "node {node_index} ('{node_name}'): CAUSTIC_object_shading's shadow_terminator_offset \
                                 {offset} is not a finite number ≥ 0"
                            )));
                        }
                        let shading_offset = shading.shading_offset;
                        if !(shading_offset.is_finite() && (0.0..2.0).contains(&shading_offset)) {
                            return Err(self.err(format!(
                                "node {node_index} ('{node_name}'): CAUSTIC_object_shading's shading_offset \
                                 {shading_offset} is not a number in [0, 2)"
                            )));
                        }
                        let total = mesh.triangles.len();
                        ray_visibility.mark_terminator(first..total, total, offset);
                        ray_visibility.mark_shading_offset(first..total, total, shading_offset);
                    }
                    if linked {
                        linking.tri_object.resize(mesh.triangles.len(), *node_index as u32);
                    }
                    if let Some(r) = &rule {
                        node_rules.insert(*node_index as u32, r.clone());
                    }
                    let mut object = None;
                    if graphs {
                        let texspace = value.pointer(&format!("/meshes/{}/extras/CAUSTIC_texspace", m.index()));
                        let color = value.pointer(&format!("/nodes/{node_index}/extras/CAUSTIC_object_color"));
                        let random_id = value.pointer(&format!("/nodes/{node_index}/extras/CAUSTIC_random_id"));
                        let pass =
                            value.pointer(&format!("/nodes/{node_index}/extensions/CAUSTIC_object_pass/pass_index"));
                        objects.push(shader_graph::object_data(world, &node_name, texspace, color, random_id, pass));
                        let o = objects.len() as u32 - 1;
                        mesh.tri_object.resize(mesh.triangles.len(), o);
                        object = Some(o);
                        let domain = displace::NormalsDomain::parse(
                            value.pointer(&format!("/meshes/{}/extras/CAUSTIC_normals_domain", m.index())),
                        )
                        .map_err(|e| self.err(format!("mesh {}: {e}", m.index())))?;
                        let (verts, tris) = (v0 as usize..mesh.positions.len(), first..mesh.triangles.len());
                        self.displace_instance(
                            &mut mesh,
                            verts,
                            tris,
                            &objects,
                            world,
                            &materials,
                            domain,
                            &mut undisplaced,
                            &node_name,
                        )?;
                    }
                    id_spans.push((*node_index, node_name.clone(), mesh.triangles.len() as u32));
                    span_nodes.push(*node_index);
                    instances_out.push(crate::scene::InstanceSpan {
                        name: node_name.clone(),
                        world: *world,
                        vertices: v0..mesh.positions.len() as u32,
                        triangles: t0..mesh.triangles.len() as u32,
                        object,
                    });
                }
            }
            if let Some(c) = node.camera() {
                let blender = node.extension_value("CAUSTIC_camera").cloned();
                cameras.push(self.camera(&c, &node_name, world, blender)?);
                camera_nodes.push(*node_index);
            } else if let Some(v) = node.extension_value("CAUSTIC_camera").filter(|v| v.get("panorama").is_some()) {
                // A panoramic camera: the exporter wrote no glTF camera for it.
                cameras.push(self.panoramic_camera(&node_name, world, v.clone())?);
                camera_nodes.push(*node_index);
            }
            if let Some(l) = node.light().filter(|_| visible) {
                let blender = node.extension_value("CAUSTIC_lights_punctual").cloned();
                let (light, rep, graph) = self.punctual_light(&l, &node_name, world, blender)?;
                if let Some(g) = graph {
                    light_graphs.push((lights.len(), g));
                }
                if !rep.cast_shadow {
                    shadowless.push(lights.len());
                }
                if !rep.lights_catcher {
                    no_catcher.push(lights.len());
                }
                if rep.rays != crate::scene::visibility::RayMask::ALL {
                    hidden_lights.push((lights.len(), rep.rays));
                }
                if rep.max_bounces != crate::scene::light_bounces::NO_LIMIT {
                    bounded_lights.push((lights.len(), rep.max_bounces));
                }
                if let Some(r) = &rule {
                    light_rules.push((lights.len(), r.clone()));
                }
                light_nodes.resize(lights.len(), None);
                light_nodes.push(Some(node_name.clone()));
                lights.push(light);
                light_reports.push(rep);
            }
            if let Some(ext) = node.extension_value("CAUSTIC_lights_area").filter(|_| visible) {
                area_lights.push((ext.clone(), node_name.clone(), *world, rule));
            }
        }
        // An unlit surface is seen by camera rays alone, as Blender's glTF importer builds it
        // (its Light Path trick: Emission for camera rays, Transparent for every other ray):
        // it shows its colour, casts no shadow and lights nothing (`materials.rs`).
        ray_visibility.camera_only(mesh.triangles.len(), |t| materials[mesh.tri_material[t] as usize].unlit);
        if !hidden_nodes.is_empty() {
            self.warn(format!(
                "KHR_node_visibility hides node(s) {}: their meshes and lights are not rendered (cameras stay usable)",
                hidden_nodes.join(", ")
            ));
        }
        ray_visibility.finish(mesh.triangles.len());
        undisplaced.finish(&mut mesh);
        self.finish_attributes(&mut mesh, &materials);
        let curves = self.curves(&value, &doc, &buffers, &mut materials, default_material)?;
        let points =
            self.points(&value, &doc, &buffers, &mut materials, default_material, graphs.then_some(&mut objects))?;
        if linked {
            linking.curve_object = curves::object_ids(&value, &doc).into_iter().map(|(_, id)| id).collect();
            linking.point_object =
                points::object_ids(&value, &doc, curves.objects.len()).into_iter().map(|(_, id)| id).collect();
        }
        let mut portals = Vec::new();
        for (ext, name, world, rule) in area_lights {
            let (light, rep) = match self.area_light(&ext, &name, &world)? {
                Some(lights::AreaResult::Light(light, rep, graph)) => {
                    if let Some(g) = graph {
                        light_graphs.push((lights.len(), g));
                    }
                    (light, rep)
                }
                Some(lights::AreaResult::Portal(p)) => {
                    portals.push(p);
                    continue;
                }
                None => continue,
            };
            {
                if !rep.cast_shadow {
                    shadowless.push(lights.len());
                }
                if !rep.lights_catcher {
                    no_catcher.push(lights.len());
                }
                if rep.rays != crate::scene::visibility::RayMask::ALL {
                    hidden_lights.push((lights.len(), rep.rays));
                }
                if rep.max_bounces != crate::scene::light_bounces::NO_LIMIT {
                    bounded_lights.push((lights.len(), rep.max_bounces));
                }
                if let Some(r) = rule {
                    light_rules.push((lights.len(), r));
                }
                light_nodes.resize(lights.len(), None);
                light_nodes.push(Some(name.clone()));
                lights.push(light);
                light_reports.push(rep);
            }
        }
        self.procedural_media(&mut grids, &mesh, &objects, &mut materials);
        // Strands or points alone are a scene (their BVHs stand beside an empty triangle BVH),
        // and so is no geometry at all: Cycles renders the world's background (and a world
        // fog lit by the lights) there. Its box is then the cameras' and the placed lights'
        // (`scene::bounds`); the default camera, if the file has none, is made from it below.
        let (mut lo, mut hi) = crate::scene::bounds::of_scene(&mesh, &curves, &points, &cameras, &lights);
        let scene_radius = ((hi - lo).length() * 0.5).max(1e-3);

        self.profile.mesh = phase.elapsed().as_secs_f64() - self.profile.tangents;
        let (mut world, world_volume) = self.world(&value, &doc, &buffers)?;
        // A file with no geometry, no world and no lights holds nothing that could be seen:
        // glTF's default would be a black image by construction, which is far likelier a
        // broken export than an intent (the add-on writes Blender's missing world as a black
        // one, so a camera-only .blend renders black as in Cycles). A world, a world fog or a
        // light, even black or invisible to the camera, is a scene Cycles renders.
        let geometryless = mesh.triangles.is_empty() && curves.is_empty() && points.is_empty();
        if geometryless && world.is_none() && matches!(world_volume, world::WorldMedium::None) && lights.is_empty() {
            return Err(self.err(
                "nothing to render: the scene has no geometry (no triangles, curves or point clouds; glTF points \
                 and lines are not rendered), no world (CAUSTIC_world) and no lights",
            ));
        }
        match &mut world {
            Some(w) => w.portals = portals,
            None if !portals.is_empty() => self.warn("the scene has portals but no world: they do nothing"),
            None => {}
        }
        let world_power = world.as_ref().map(|w| {
            // Power through the scene's bounding disk: irradiance π L over π R².
            std::f32::consts::PI * w.mean_luminance() * std::f32::consts::PI * scene_radius * scene_radius
        });
        let mut light_power: Vec<f32> = lights.iter().map(|l| punctual_power(l, scene_radius)).collect();
        let mut light_graphs_by_index = Vec::new();
        for (i, g) in light_graphs {
            // Selection by the graph's value at a typical receiver (`LightGraph::selection_factor`).
            light_power[i] *= g.selection_factor(&lights[i], scene_radius);
            light_graphs_by_index.resize(i + 1, None);
            light_graphs_by_index[i] = Some(g);
        }
        if let Some(power) = world_power {
            if power > 0.0 {
                // The world's Ray Visibility goes with the lights' (`scene::light_visibility`).
                let rays = self.world_rays(&value)?;
                if rays != crate::scene::visibility::RayMask::ALL {
                    hidden_lights.push((lights.len(), rays));
                }
                // Cycles samples the world as a light only where it varies over directions (an
                // image, a graph) or has portals (`test_enabled_lights`): a constant colour is
                // found by BSDF-sampled rays alone, which the limit never stops.
                let sampled =
                    world.as_ref().is_some_and(|w| w.image.is_some() || w.graph.is_some() || !w.portals.is_empty());
                let max_bounces =
                    if sampled { self.world_max_bounces(&value)? } else { crate::scene::light_bounces::NO_LIMIT };
                if max_bounces != crate::scene::light_bounces::NO_LIMIT {
                    bounded_lights.push((lights.len(), max_bounces));
                }
                lights.push(Light::World);
                light_power.push(power);
                light_reports.push(LightReport {
                    kind: "world".into(),
                    name: "world".into(),
                    power,
                    triangles: 0,
                    cast_shadow: true,
                    lights_catcher: true,
                    rays,
                    max_bounces,
                });
            } else {
                self.warn("the world is black: it lights nothing");
            }
        }
        for ((rep, p), l) in light_reports.iter_mut().zip(&light_power).zip(&lights) {
            // Signed: a negative light (selected by its size) reports its negative power.
            rep.power = p.copysign(lights::signed_power(l, scene_radius));
        }

        // Emissive triangles are lights, one each, grouped by material in the report.
        let phase = Instant::now();
        self.node_emitters(&mesh, &objects, &mut materials);
        self.emissive_lights(&mesh, &materials, &mut lights, &mut light_power, &mut light_reports)?;
        if linked {
            linking.rules = vec![None; lights.len()];
            linking.blockers = vec![None; lights.len()];
            for (i, (r, b)) in light_rules {
                (linking.rules[i], linking.blockers[i]) = (r, b);
            }
            // An emissive object's rule goes to each of its triangles' lights.
            for (i, l) in lights.iter().enumerate() {
                if let Light::Triangle { tri } = l
                    && let Some(r) = node_rules.get(&linking.tri_object[*tri as usize])
                {
                    (linking.rules[i], linking.blockers[i]) = r.clone();
                }
            }
        }
        self.profile.emitter_power = phase.elapsed().as_secs_f64();

        let file_cameras = cameras.len();
        if cameras.is_empty() {
            self.warn("no camera in the file: framing the scene's bounds from +Z with a 40° camera");
            cameras.push(frame_bounds(lo, hi));
        }
        let (world_medium, world_grid) = match world_volume {
            world::WorldMedium::None => (None, None),
            world::WorldMedium::Homogeneous(m) => (Some(m), None),
            world::WorldMedium::Graph(volume) => {
                // The fog's box holds the surfaces, every camera (paths start there) and
                // every light with a place (light paths start there, shadow rays end there):
                // outside it the fog is held at the boundary's coefficients.
                let (flo, fhi) = crate::scene::bounds::world_fog(lo, hi, geometryless, &cameras, &lights);
                if geometryless {
                    // Cycles follows the graph to infinity; with nothing but cameras and
                    // lights to bound it, most of what the camera sees is held fog.
                    self.warn(
                        "the world fog's node graph is followed within the box of the cameras and lights (at least 2 \
                         units a side: the scene has no geometry to bound it) and a little beyond; farther, the fog \
                         keeps the coefficients it reached",
                    );
                }
                let source = crate::medium::procedural_source::ProceduralSource {
                    volume: *volume,
                    object: crate::shader::geom::NO_OBJECT,
                    grids: None,
                };
                grids.push(crate::medium::procedural::world_fog_medium(flo, fhi, source));
                (None, Some(grids.len() as u32 - 1))
            }
        };
        let glowing_media = world_medium.as_ref().is_some_and(|m| m.emission != glam::Vec3::ZERO)
            || materials.iter().any(|m| m.medium.as_ref().is_some_and(|m| m.emission != glam::Vec3::ZERO))
            || grids.iter().any(|g| g.may_emit());
        // Unlit surfaces show their colour without light (and are no lights themselves).
        let unlit_seen =
            mesh.tri_material.iter().any(|&m| materials[m as usize].unlit && materials[m as usize].is_emissive());
        if lights.is_empty() && !glowing_media && !unlit_seen {
            self.warn("the scene has no lights, no emissive materials and no emitting media: the image will be black");
        }
        if degenerate > 0 {
            self.warn(format!("{degenerate} degenerate (zero-area) triangle(s) were dropped"));
        }
        let motion =
            self.motion(&value, &doc, &buffers, &mesh, &instances_out, &span_nodes, &mut cameras, &camera_nodes)?;
        if let Some(m) = motion.as_ref().filter(|m| m.blurs()) {
            // The scene's bounds hold every moving triangle at every step.
            for p in m.corners.iter().flatten() {
                (lo, hi) = (lo.min(*p), hi.max(*p));
            }
            self.motion_warnings(m, &lights);
        }

        self.profile.total = start.elapsed().as_secs_f64();
        let source_hash = self.source_hash(bytes);
        let pass_ids = self.pass_ids(&doc, &id_spans, &materials)?;
        let light_groups = self.light_groups(
            settings.light_groups.as_ref(),
            &lights,
            &light_nodes,
            &id_spans,
            mesh.triangles.len(),
            glowing_media,
        )?;
        let mut aov_warnings = Vec::new();
        // Cycles evaluates no background shader for a ray the world is hidden from.
        let world_aovs = match self.world_rays(&value)?.meets(crate::scene::visibility::RayMask::CAMERA) {
            true => self.world_aovs.take(),
            false => None,
        };
        let shader_aovs = crate::scene::shader_aovs::ShaderAovs::resolve(
            settings.shader_aovs.as_ref(),
            &materials,
            world_aovs.as_ref(),
            |w| aov_warnings.push(w),
        )
        .map_err(|e| self.err(format!("render settings 'shader_aovs': {e}")))?;
        for w in aov_warnings {
            self.warn(w);
        }
        let report = LoadReport {
            file: self.file.to_string(),
            triangles: mesh.triangles.len(),
            meshes: used_meshes.len(),
            instances: instance_count,
            degenerate_triangles: degenerate,
            strands: curves.strands.len(),
            curve_segments: curves.segments(),
            curve_bytes: curves.bytes(),
            points: points.spheres.len(),
            point_bytes: points.bytes(),
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
                        Projection::Panoramic(p) => format!("panoramic {p:?}"),
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
            profile: self.profile,
        };
        let mut light_casts_shadow = vec![true; lights.len()];
        for i in shadowless {
            light_casts_shadow[i] = false;
        }
        // Only with a light hidden from some kind of ray (empty: every ray sees every light).
        let mut light_rays = Vec::new();
        if !hidden_lights.is_empty() {
            light_rays = vec![crate::scene::visibility::RayMask::ALL; lights.len()];
            for (i, mask) in hidden_lights {
                light_rays[i] = mask;
            }
        }
        let light_max_bounces = crate::scene::light_bounces::table(&bounded_lights, lights.len());
        let mut light_lights_catcher = Vec::new();
        if !no_catcher.is_empty() {
            light_lights_catcher = vec![true; lights.len()];
            for i in no_catcher {
                light_lights_catcher[i] = false;
            }
        }
        Ok(Scene {
            pass_ids,
            mesh,
            curves,
            points,
            materials,
            textures: self.textures,
            lights,
            light_power,
            light_graphs: light_graphs_by_index,
            cameras,
            world,
            world_medium,
            world_grid,
            grids,
            light_casts_shadow,
            light_lights_catcher,
            light_rays,
            light_max_bounces,
            ray_visibility,
            light_linking: linking,
            settings,
            warnings: self.warnings,
            report,
            bounds: (lo, hi),
            objects,
            view: Default::default(),
            source_hash,
            instances: instances_out,
            motion,
            light_groups,
            shader_aovs,
        })
    }

    /// The material of primitives that name none: `CAUSTIC_default_material`'s (the add-on
    /// names Blender's default surface there), else glTF's default, appended.
    fn default_material(&self, value: &serde_json::Value, materials: &mut Vec<Material>) -> Result<u32> {
        let Some(ext) = value.pointer("/extensions/CAUSTIC_default_material") else {
            materials.push(Material::default());
            return Ok(materials.len() as u32 - 1);
        };
        let e: extensions::DefaultMaterialExt = serde_json::from_value(ext.clone())
            .map_err(|e| self.err(format!("CAUSTIC_default_material is malformed: {e}")))?;
        if e.material as usize >= materials.len() {
            return Err(self.err(format!(
                "CAUSTIC_default_material: material {} does not exist (the file has {})",
                e.material,
                materials.len()
            )));
        }
        Ok(e.material)
    }

    fn parse_settings(&self, value: &serde_json::Value) -> Result<SceneSettings> {
        let scene_index = value.get("scene").and_then(|s| s.as_u64()).unwrap_or(0) as usize;
        let Some(extras) = value.pointer(&format!("/scenes/{scene_index}/extras/caustic")) else {
            return Ok(SceneSettings::default());
        };
        serde_json::from_value(extras.clone())
            .map_err(|e| self.err(format!("scene extras 'caustic' (render settings) are malformed: {e}")))
    }
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

#[cfg(test)]
mod tests;
