//! The renderer's own scene description. Everything downstream of the loader sees
//! these types only; `gltf/` is the one module that reads glTF.

pub mod bent_normal;
pub mod bounds;
pub mod camera;
pub mod gltf;
pub mod hit;
pub mod ids;
pub mod light_bounces;
pub mod light_groups;
pub mod light_path;
pub mod light_visibility;
pub mod linking;
pub mod material;
pub mod mesh;
pub mod panorama;
pub mod shader_aovs;
pub mod shading;
pub mod terminator;
pub mod texture;
pub mod texture_limit;
pub mod visibility;
pub mod working_space;

use crate::light::Light;
use glam::Vec3;
use serde::Serialize;

pub use camera::{Camera, Lens, Projection};
pub use material::{AlphaMode, Material};
pub use mesh::Mesh;
pub use panorama::Panorama;
pub use texture::{TexRef, Texture};

/// Render settings stored in the scene (`scenes[i].extras.caustic`), all optional;
/// command-line flags override them.
#[derive(Clone, Debug, Default, Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSettings {
    /// Output size in pixels.
    pub resolution: Option<[u32; 2]>,
    /// Samples per pixel.
    pub spp: Option<u32>,
    /// Seconds to render for.
    pub time_limit: Option<f64>,
    /// Maximum scattering events per path.
    pub max_depth: Option<u32>,
    /// Cycles' Transparent Max Bounces: alpha pass-throughs a path may make (it ends at
    /// the next surface after the last), and with them those its shadow rays may cross
    /// (default `integrator::DEFAULT_TRANSPARENT_MAX`, Blender's).
    pub transparent_max_bounces: Option<u32>,
    /// Cycles' Diffuse Bounces (default: unlimited, Max Bounces alone).
    pub diffuse_max_bounces: Option<u32>,
    /// Cycles' Glossy Bounces (default: unlimited).
    pub glossy_max_bounces: Option<u32>,
    /// Cycles' Transmission Bounces (default: unlimited).
    pub transmission_max_bounces: Option<u32>,
    /// Cycles' Volume Bounces (default: unlimited).
    pub volume_max_bounces: Option<u32>,
    /// Cycles' Clamp Direct (0 or absent: off).
    pub clamp_direct: Option<f32>,
    /// Cycles' Clamp Indirect (0 or absent: off).
    pub clamp_indirect: Option<f32>,
    /// Cycles' Filter Glossy (0 or absent: off).
    pub filter_glossy: Option<f32>,
    /// Cycles' Reflective Caustics (absent: on); off is not rendered yet, named in a warning.
    pub caustics_reflective: Option<bool>,
    /// Cycles' Refractive Caustics (absent: on); off is not rendered yet, named in a warning.
    pub caustics_refractive: Option<bool>,
    /// Random seed.
    pub seed: Option<u32>,
    /// Worker threads.
    pub threads: Option<usize>,
    /// Integrator name.
    pub integrator: Option<String>,
    /// Pixel filter: "blackman-harris", "gaussian" or "box".
    pub filter: Option<String>,
    /// Filter width in pixels.
    pub filter_width: Option<f32>,
    /// Camera name.
    pub camera: Option<String>,
    /// Transparent background (alpha = coverage); false gives alpha 1 everywhere, as
    /// Blender's Film → Transparent off. Default true.
    pub transparent: Option<bool>,
    /// Film → Transparent Glass's Roughness Threshold: with a transparent background, a
    /// camera path refracted only by glass at most this rough (Cycles' rule) leaves the
    /// background transparent. Absent: glass is opaque in the alpha.
    pub transparent_glass: Option<f32>,
    // Photon mapping ("photon" and "sppm" integrators); defaults in
    // `integrator::photon::PhotonSettings`, meanings as the CLI flags of the same name.
    /// Photons emitted for the global map.
    pub photons: Option<u64>,
    /// Photons emitted for the caustic map.
    pub caustic_photons: Option<u64>,
    /// Neighbours per global-map radiance estimate.
    pub k: Option<usize>,
    /// Neighbours per caustic-map radiance estimate.
    pub caustic_k: Option<usize>,
    /// Maximum photon search radius (scene units).
    pub max_radius: Option<f32>,
    /// Final-gather rays.
    pub gather_rays: Option<u32>,
    /// Non-specular bounces before the global map is read (0: no final gather).
    pub diffuse_bounces: Option<u32>,
    /// SPPM iterations.
    pub sppm_iterations: Option<u32>,
    /// SPPM photons per iteration.
    pub sppm_photons: Option<u64>,
    /// SPPM initial radius (scene units).
    pub sppm_radius: Option<f32>,
    /// Light selection for next-event estimation: "tree" or "power".
    pub light_sampler: Option<String>,
    /// Adaptive sampling's noise threshold (0 = off).
    pub noise_threshold: Option<f32>,
    /// Adaptive sampling's minimum samples (0 = derived from the threshold).
    pub min_samples: Option<u32>,
    /// Passes to write besides Combined (`crate::passes`: tokens or Blender names).
    pub passes: Option<Vec<String>>,
    /// Blender's Cryptomatte levels (View Layer → Cryptomatte → Levels, 2..=16).
    pub cryptomatte_levels: Option<u32>,
    /// Blender's mist (World → Mist Pass): start, depth, falloff exponent (quadratic 2,
    /// linear 1, inverse quadratic 0.5).
    pub mist: Option<[f32; 3]>,
    /// Blender's AO distance (World → Ambient Occlusion → Distance) for the AO pass.
    pub ao_distance: Option<f32>,
    /// The view layer's light groups and their emitters (`light_groups`).
    pub light_groups: Option<light_groups::LightGroupSpec>,
    /// The view layer's shader AOVs (`shader_aovs`).
    pub shader_aovs: Option<shader_aovs::ShaderAovSpec>,
    /// Light Paths > Fast GI Approximation with World > Ambient Occlusion
    /// (`integrator::fast_gi`).
    pub fast_gi: Option<crate::integrator::fast_gi::FastGiSettings>,
    /// Simplify > Texture Limit (render), in pixels: images whose longer side passes it are
    /// shrunk on load as Cycles shrinks them (`texture_limit`).
    pub texture_limit: Option<u32>,
    /// Color Management > Working Space when not linear Rec.709 (`working_space`).
    pub working_space: Option<working_space::WorkingSpaceSettings>,
}

/// Counts and per-material features for `caustic info`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct LoadReport {
    /// Source file.
    pub file: String,
    /// Triangles after instancing and after dropping degenerate ones.
    pub triangles: usize,
    /// Distinct glTF meshes used.
    pub meshes: usize,
    /// Mesh instances (nodes with a mesh).
    pub instances: usize,
    /// Degenerate (zero-area) triangles dropped.
    pub degenerate_triangles: usize,
    /// Hair and curve strands (`CAUSTIC_curves`).
    pub strands: usize,
    /// Their segments (round cones).
    pub curve_segments: usize,
    /// Bytes the strands and their BVH hold.
    pub curve_bytes: usize,
    /// Points of point clouds (`CAUSTIC_points`).
    pub points: usize,
    /// Bytes the points and their BVH hold.
    pub point_bytes: usize,
    /// `extensionsUsed` of the file.
    pub extensions_used: Vec<String>,
    /// One entry per material.
    pub materials: Vec<MaterialReport>,
    /// One entry per light.
    pub lights: Vec<LightReport>,
    /// Cameras by name.
    pub cameras: Vec<CameraReport>,
    /// Scene bounds (min, max).
    pub bounds: [[f32; 3]; 2],
    /// Time per loading phase and the emitter work.
    pub profile: LoadProfile,
}

/// Where loading spent its time (seconds, wall clock), for `info --json` and
/// `bench/load.py`. The BVH is built after loading and is not included.
#[derive(Clone, Debug, Default, Serialize)]
pub struct LoadProfile {
    /// Reading the container and the JSON, validating, reading buffers.
    pub parse: f64,
    /// Decoding images (textures and the world image).
    pub decode_textures: f64,
    /// Converting materials, without decoding their textures.
    pub materials: f64,
    /// Flattening nodes and meshes into world-space triangles, without tangents.
    pub mesh: f64,
    /// Generating MikkTSpace tangents for normal maps.
    pub tangents: f64,
    /// Emissive triangles' powers: texture pyramids and per-triangle means.
    pub emitter_power: f64,
    /// The whole load.
    pub total: f64,
    /// Texels read for the emitters' powers (pyramids and triangles): linear in the
    /// texture size plus the triangle count, not their product.
    pub emitter_texel_reads: u64,
}

/// A material in the report.
#[derive(Clone, Debug, Default, Serialize)]
pub struct MaterialReport {
    /// Name.
    pub name: String,
    /// glTF features and extensions it uses.
    pub features: Vec<String>,
}

/// A light in the report.
#[derive(Clone, Debug, Serialize)]
pub struct LightReport {
    /// "point", "spot", "directional", "area", "emissive".
    pub kind: String,
    /// Name (node or mesh).
    pub name: String,
    /// Emitted power in W (luminance-weighted; directional: through the scene's disk).
    pub power: f32,
    /// Number of emissive triangles (for "emissive" entries).
    pub triangles: usize,
    /// Blender's Cast Shadow (false: the light reaches every point it faces, unoccluded).
    pub cast_shadow: bool,
    /// The light's Shadow Catcher flag (false: it does not light the catcher pass).
    #[serde(skip)]
    pub lights_catcher: bool,
    /// The kinds of ray that see the light (its Ray Visibility, `light_visibility`).
    #[serde(skip)]
    pub rays: visibility::RayMask,
    /// Cycles' Max Bounces of the light (`light_bounces`; `NO_LIMIT`: none).
    #[serde(skip)]
    pub max_bounces: u32,
}

/// A camera in the report.
#[derive(Clone, Debug, Serialize)]
pub struct CameraReport {
    /// Name.
    pub name: String,
    /// "perspective" or "orthographic".
    pub kind: String,
    /// Made by the loader because the file has no camera.
    pub generated: bool,
    /// Lens shift (frame widths, heights), when not zero.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shift: Option<[f32; 2]>,
    /// Depth of field, e.g. "aperture radius 0.025, focus 6, 6 blades", when the camera has a lens.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub depth_of_field: Option<String>,
}

/// A loaded scene.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// Geometry.
    pub mesh: Mesh,
    /// Hair and curves (`CAUSTIC_curves`), with their own BVH; empty without them.
    pub curves: crate::curves::Curves,
    /// Point clouds (`CAUSTIC_points`): a sphere per point, with their own BVH; empty without them.
    pub points: crate::points::Points,
    /// Materials; triangles index into this.
    pub materials: Vec<Material>,
    /// Textures; materials index into this.
    pub textures: Vec<Texture>,
    /// Lights (emissive triangles are one light each).
    pub lights: Vec<Light>,
    /// Power (luminance, W) of each light, for light selection.
    pub light_power: Vec<f32>,
    /// Each light's node tree that varies over it, by light index (shorter than `lights`
    /// or None: the light has none; constant trees are folded into the light at load).
    pub light_graphs: Vec<Option<crate::light::light_graph::LightGraph>>,
    /// Cameras in node order.
    pub cameras: Vec<Camera>,
    /// The world light (`CAUSTIC_world`), if any.
    pub world: Option<crate::light::Environment>,
    /// The medium filling the scene outside every mesh medium (Blender's World Volume);
    /// camera rays and lights start in it.
    pub world_medium: Option<crate::medium::HomogeneousMedium>,
    /// The world's volume when a node graph gives it (`grids` index; `world_medium` is then
    /// None): textured fog filling the scene.
    pub world_grid: Option<u32>,
    /// Volume objects' grid media (`Material::grid` indexes this).
    pub grids: Vec<crate::medium::GridMedium>,
    /// Per light (indexed as `lights`): false for a light whose Cast Shadow is off, whose
    /// next-event estimation then skips the shadow ray (as Cycles does).
    pub light_casts_shadow: Vec<bool>,
    /// Per light: false for a light whose object is no shadow catcher, which Cycles leaves
    /// out of the catcher pass (`integrator::catcher`); empty when every light lights it.
    pub light_lights_catcher: Vec<bool>,
    /// Per light: the kinds of ray that see it (Blender's Ray Visibility of a light,
    /// `light_visibility`); empty when every ray sees every light.
    pub light_rays: Vec<visibility::RayMask>,
    /// Per light: Cycles' Max Bounces (`light_bounces`); empty when no light has one.
    pub light_max_bounces: Vec<u32>,
    /// Which rays see each triangle (Blender's per-object Ray Visibility).
    pub ray_visibility: visibility::RayVisibility,
    /// Which objects each light lights (Blender's light linking receivers).
    pub light_linking: linking::LightLinking,
    /// Render settings from the file.
    pub settings: SceneSettings,
    /// Everything the loader dropped, clamped or guessed.
    pub warnings: Vec<String>,
    /// Counts for `caustic info`.
    pub report: LoadReport,
    /// World bounds (min, max).
    pub bounds: (Vec3, Vec3),
    /// Per-instance data for shader graphs (`Mesh::tri_object` indexes it).
    pub objects: Vec<crate::shader::geom::ObjectData>,
    /// The render camera as shader graphs read it (Texture Coordinate Camera and Window):
    /// set by the command that renders (`Scene::set_view`), unknown after loading.
    pub view: crate::shader::geom::ViewData,
    /// FNV-1a 64 of the glTF file and of every external file it read (buffers, images, by
    /// URI): the identity of a photon map and of a chunk, which a changed texture or .bin
    /// must change too.
    pub source_hash: u64,
    /// Each mesh instance's name, world matrix and span of the flattened mesh, so that
    /// the render server can move one object without reloading (`server::edits`).
    pub instances: Vec<InstanceSpan>,
    /// Pass indices and Cryptomatte ids of each instance and material.
    pub pass_ids: ids::PassIds,
    /// Moving triangles and the shutter (`CAUSTIC_motion`); None when nothing moves.
    pub motion: Option<crate::motion::SceneMotion>,
    /// Each emitter's light group (`light_groups`); empty without groups.
    pub light_groups: light_groups::LightGroups,
    /// The view layer's shader AOVs and the AOV Output nodes that write them.
    pub shader_aovs: shader_aovs::ShaderAovs,
}

/// Where one mesh instance (a glTF node with a mesh) lies in the flattened [`Mesh`].
#[derive(Clone, Debug)]
pub struct InstanceSpan {
    /// Node name (Blender's object name), else "node N".
    pub name: String,
    /// The node's world matrix (glTF axes) the vertices were transformed by.
    pub world: glam::Mat4,
    /// Its vertices in `Mesh::positions` (and the other per-vertex arrays).
    pub vertices: std::ops::Range<u32>,
    /// Its triangles in `Mesh::triangles`.
    pub triangles: std::ops::Range<u32>,
    /// Its entry in `Scene::objects`, when shader graphs keep instance data.
    pub object: Option<u32>,
}

impl Scene {
    /// Makes shader graphs see camera `camera` with a `width` × `height` frame (Texture
    /// Coordinate Camera and Window).
    pub fn set_view(&mut self, camera: usize, width: u32, height: u32) {
        if let Some(c) = self.cameras.get(camera) {
            self.apply_view(camera::CameraRays::new(c, width, height).shader_view());
        }
    }

    /// Sets the render camera shader graphs read (`view`); a world graph reading it
    /// (Texture Coordinate Camera, Window) is baked again for it, so that its sampling
    /// table follows what it shows.
    pub fn apply_view(&mut self, view: crate::shader::geom::ViewData) {
        self.view = view;
        if let Some(graph) = self.world.as_ref().and_then(|w| w.graph.as_ref()).filter(|g| g.reads_view())
            && let Some(env) = crate::light::Environment::from_graph(graph.with_view(view))
        {
            self.world = Some(env);
        }
        if let Some(g) = self.shader_aovs.world_graph.as_mut().filter(|g| g.reads_view()) {
            *g = g.with_view(view);
        }
    }

    /// True when some material's graph has a Bump, the one reader of a camera ray's
    /// footprint (`CameraRays::with_footprints`).
    pub fn reads_footprint(&self) -> bool {
        self.materials.iter().any(|m| m.nodes.as_ref().is_some_and(|p| p.reads_footprint()))
    }

    /// Centre and radius of a sphere bounding the scene.
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        let c = (self.bounds.0 + self.bounds.1) * 0.5;
        (c, ((self.bounds.1 - self.bounds.0).length() * 0.5).max(1e-3))
    }
}
