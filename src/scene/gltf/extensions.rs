//! The serde shapes of the `CAUSTIC_*` extensions (docs/contract.md) and their defaults.

use serde::Deserialize;

/// `CAUSTIC_lights_area` on a node.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct AreaLightExt {
    pub(super) shape: String,
    pub(super) size: Vec<f32>,
    pub(super) power: f32,
    #[serde(default = "white")]
    pub(super) color: [f32; 3],
    #[serde(default = "yes")]
    pub(super) camera_visible: bool,
    /// Blender's Spread: full angle in radians, π = no narrowing.
    #[serde(default = "half_turn")]
    pub(super) spread: f32,
    /// Blender's Cast Shadow: false lights every point as if nothing stood in the way.
    #[serde(default = "yes")]
    pub(super) cast_shadow: bool,
    /// The light object's Shadow Catcher flag: false leaves it out of the catcher pass.
    #[serde(default = "yes")]
    pub(super) shadow_catcher: bool,
    /// The light's Ray Visibility beyond Camera (`scene::light_visibility`): each kind of
    /// bounce finds the light unless its flag is false.
    #[serde(default = "yes")]
    pub(super) diffuse_visible: bool,
    #[serde(default = "yes")]
    pub(super) glossy_visible: bool,
    #[serde(default = "yes")]
    pub(super) transmission_visible: bool,
    #[serde(default = "yes")]
    pub(super) volume_scatter_visible: bool,
    /// Cycles' Max Bounces of the light (`scene::light_bounces`); absent: no limit.
    pub(super) max_bounces: Option<u32>,
    /// Cycles' Portal: the light emits nothing and steers the world's light sampling.
    #[serde(default)]
    pub(super) portal: bool,
    /// The light's node tree (`light::light_graph`); its Emission's factors are not in
    /// `power` and `color` then.
    #[serde(default)]
    pub(super) nodes: Option<crate::shader::graph::NodesExt>,
}

/// The kinds of ray that see a light whose Ray Visibility flags beyond Camera are these
/// (camera and shadow rays always: the camera flag is `camera_visible`, and Cycles gives
/// lights no shadow visibility).
pub(super) fn light_rays(
    diffuse: bool,
    glossy: bool,
    transmission: bool,
    volume: bool,
) -> crate::scene::visibility::RayMask {
    use crate::scene::visibility::RayMask;
    let flags = [
        (diffuse, RayMask::DIFFUSE),
        (glossy, RayMask::GLOSSY),
        (transmission, RayMask::TRANSMISSION),
        (volume, RayMask::VOLUME),
    ];
    RayMask(flags.iter().filter(|(on, _)| *on).fold(RayMask::CAMERA.0 | RayMask::SHADOW.0, |m, (_, k)| m | k.0))
}

fn half_turn() -> f32 {
    std::f32::consts::PI
}

/// `CAUSTIC_materials_medium` on a material (docs/contract.md).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct MediumExt {
    #[serde(default = "one_f32")]
    pub(super) density: f32,
    #[serde(default = "white")]
    pub(super) scatter_color: [f32; 3],
    #[serde(default = "black")]
    pub(super) absorption_color: [f32; 3],
    #[serde(default)]
    pub(super) anisotropy: f32,
    #[serde(default = "black")]
    pub(super) emission: [f32; 3],
    /// The Principled Volume's Blackbody Intensity (0: no blackbody emission).
    #[serde(default)]
    pub(super) blackbody_intensity: f32,
    /// Blackbody Tint.
    #[serde(default = "white")]
    pub(super) blackbody_tint: [f32; 3],
    /// Temperature (kelvin).
    #[serde(default = "kelvin_1000")]
    pub(super) temperature: f32,
    #[serde(default = "yes")]
    pub(super) surface: bool,
    /// Blender's Volume Scatter Phase by its enum name (docs/contract.md), and the inputs the
    /// non-Henyey-Greenstein ones read.
    #[serde(default = "hg_phase")]
    pub(super) phase: String,
    #[serde(default = "phase_alpha")]
    pub(super) phase_alpha: f32,
    #[serde(default = "phase_ior")]
    pub(super) phase_ior: f32,
    #[serde(default = "phase_backscatter")]
    pub(super) phase_backscatter: f32,
    #[serde(default = "phase_diameter")]
    pub(super) phase_diameter: f32,
    /// The Volume output's node graph when the shader's inputs vary over the medium (a
    /// texture on the Density): its coefficients are then the graph's (docs/contract.md).
    #[serde(default)]
    pub(super) graph: Option<crate::shader::graph::NodesExt>,
    /// The volume shader node's index in `graph`.
    #[serde(default)]
    pub(super) graph_shader: Option<usize>,
}

/// Blender's default Volume Scatter Phase.
pub(super) fn hg_phase() -> String {
    "HENYEY_GREENSTEIN".into()
}

/// The Volume Scatter node's default Alpha (Draine).
pub(super) fn phase_alpha() -> f32 {
    0.5
}

/// The Volume Scatter node's default IOR (Fournier-Forand).
pub(super) fn phase_ior() -> f32 {
    1.33
}

/// The Volume Scatter node's default Backscatter (Fournier-Forand).
pub(super) fn phase_backscatter() -> f32 {
    0.1
}

/// The Volume Scatter node's default Diameter in µm (Mie).
pub(super) fn phase_diameter() -> f32 {
    20.0
}

/// The Principled Volume's default Temperature.
fn kelvin_1000() -> f32 {
    1000.0
}

/// `CAUSTIC_materials_subsurface` on a material (docs/contract.md).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SubsurfaceExt {
    #[serde(default = "one_f32")]
    pub(super) weight: f32,
    pub(super) radius: [f32; 3],
    #[serde(default)]
    pub(super) anisotropy: f32,
    #[serde(default = "skin_ior")]
    pub(super) ior: f32,
    #[serde(default = "random_walk")]
    pub(super) method: String,
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

/// `CAUSTIC_world` on the scene (docs/contract.md).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct WorldExt {
    #[serde(default = "white")]
    pub(super) color: [f32; 3],
    #[serde(default = "one_f32")]
    pub(super) strength: f32,
    pub(super) image: Option<String>,
    #[serde(default)]
    pub(super) rotation: f32,
    /// Blender's World Volume: a homogeneous medium filling the scene (the camera is in it).
    pub(super) medium: Option<MediumExt>,
    /// The World Output's Surface graph (`CAUSTIC_materials_nodes`' shape); replaces
    /// colour, strength, image and rotation.
    pub(super) nodes: Option<crate::shader::graph::NodesExt>,
    /// The world's Ray Visibility (Cycles' World > Ray Visibility); absent: every ray.
    pub(super) visibility: Option<WorldVisibilityExt>,
    /// Cycles' Max Bounces of the world (`scene::light_bounces`); absent: no limit.
    pub(super) max_bounces: Option<u32>,
}

/// `visibility` in `CAUSTIC_world`: which rays see the world (each true when absent).
#[derive(Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
pub(super) struct WorldVisibilityExt {
    #[serde(default = "yes")]
    pub(super) camera: bool,
    #[serde(default = "yes")]
    pub(super) diffuse: bool,
    #[serde(default = "yes")]
    pub(super) glossy: bool,
    #[serde(default = "yes")]
    pub(super) transmission: bool,
    #[serde(default = "yes")]
    pub(super) scatter: bool,
}

impl WorldVisibilityExt {
    /// The ray kinds that see the world (a light's mask, with the camera's bit too).
    pub(super) fn mask(self) -> crate::scene::visibility::RayMask {
        use crate::scene::visibility::RayMask;
        let m = light_rays(self.diffuse, self.glossy, self.transmission, self.scatter);
        if self.camera { m } else { RayMask(m.0 & !RayMask::CAMERA.0) }
    }
}

/// `CAUSTIC_camera` on a camera's node: Blender's lens shift and depth of field.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CameraExt {
    #[serde(default)]
    pub(super) shift: [f32; 2],
    pub(super) aperture_radius: Option<f32>,
    pub(super) focus_distance: Option<f32>,
    #[serde(default)]
    pub(super) blades: u32,
    #[serde(default)]
    pub(super) blade_rotation: f32,
    pub(super) aperture_ratio: Option<f32>,
    /// A panoramic camera, which glTF cannot say (the node then has no glTF camera).
    pub(super) panorama: Option<PanoramaExt>,
    /// A panoramic camera's clip start and end (Blender's), along each ray.
    pub(super) clip: Option<[f32; 2]>,
}

/// `CAUSTIC_camera.panorama`: Blender's panoramic camera type and the settings it reads.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PanoramaExt {
    #[serde(rename = "type")]
    pub(super) kind: String,
    /// Fisheyes' field of view (radians).
    pub(super) fov: Option<f32>,
    /// The equisolid fisheye's focal length (mm).
    pub(super) lens: Option<f32>,
    /// The sensor's width and height (mm) as fitted to the frame (equisolid, polynomial).
    pub(super) sensor: Option<[f32; 2]>,
    /// Equirectangular: minimum and maximum latitude and longitude (radians).
    pub(super) latitude: Option<[f32; 2]>,
    pub(super) longitude: Option<[f32; 2]>,
    /// The lens polynomial's k0..k4.
    pub(super) polynomial: Option<[f32; 5]>,
    /// Central cylindrical: the angle's range (radians) and the height's over the radius.
    pub(super) u_range: Option<[f32; 2]>,
    pub(super) v_range: Option<[f32; 2]>,
}

/// `CAUSTIC_lights_punctual` on a light's node: Blender's light shape parameters.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct BlenderLight {
    #[serde(default)]
    pub(super) radius: f32,
    #[serde(default)]
    pub(super) angle: f32,
    pub(super) spot_blend: Option<f32>,
    #[serde(default)]
    pub(super) soft_falloff: bool,
    #[serde(default = "yes")]
    pub(super) camera_visible: bool,
    #[serde(default = "yes")]
    pub(super) cast_shadow: bool,
    /// The light object's Shadow Catcher flag: false leaves it out of the catcher pass.
    #[serde(default = "yes")]
    pub(super) shadow_catcher: bool,
    /// The light's Ray Visibility beyond Camera (`scene::light_visibility`): each kind of
    /// bounce finds the light unless its flag is false.
    #[serde(default = "yes")]
    pub(super) diffuse_visible: bool,
    #[serde(default = "yes")]
    pub(super) glossy_visible: bool,
    #[serde(default = "yes")]
    pub(super) transmission_visible: bool,
    #[serde(default = "yes")]
    pub(super) volume_scatter_visible: bool,
    /// The light's node tree (`light::light_graph`); the glTF light's colour and intensity
    /// are then the light's own, without its Emission's factors.
    #[serde(default)]
    pub(super) nodes: Option<crate::shader::graph::NodesExt>,
    /// Cycles' Max Bounces of the light (`scene::light_bounces`); absent: no limit.
    pub(super) max_bounces: Option<u32>,
    /// Blender's power is negative (the light subtracts light, as in Cycles): the glTF
    /// intensity, which `KHR_lights_punctual` keeps non-negative, is its size.
    #[serde(default)]
    pub(super) negative: bool,
}

impl Default for BlenderLight {
    fn default() -> Self {
        BlenderLight {
            radius: 0.0,
            angle: 0.0,
            spot_blend: None,
            soft_falloff: false,
            camera_visible: true,
            cast_shadow: true,
            shadow_catcher: true,
            diffuse_visible: true,
            glossy_visible: true,
            transmission_visible: true,
            volume_scatter_visible: true,
            nodes: None,
            max_bounces: None,
            negative: false,
        }
    }
}

/// `CAUSTIC_object_visibility` on a mesh's node: Blender's Ray Visibility of the object
/// (docs/contract.md); each kind of ray sees the object unless its flag is false.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ObjectVisibilityExt {
    #[serde(default = "yes")]
    pub(super) camera: bool,
    #[serde(default = "yes")]
    pub(super) diffuse: bool,
    #[serde(default = "yes")]
    pub(super) glossy: bool,
    #[serde(default = "yes")]
    pub(super) transmission: bool,
    #[serde(default = "yes")]
    pub(super) volume_scatter: bool,
    #[serde(default = "yes")]
    pub(super) shadow: bool,
    /// Blender's Holdout (the object's, or its collection's in the view layer).
    #[serde(default)]
    pub(super) holdout: bool,
    /// Blender's Shadow Catcher.
    #[serde(default)]
    pub(super) shadow_catcher: bool,
}

impl ObjectVisibilityExt {
    /// The kinds of ray that see the object.
    pub(super) fn mask(&self) -> crate::scene::visibility::RayMask {
        use crate::scene::visibility::RayMask;
        let flags = [
            (self.camera, RayMask::CAMERA),
            (self.diffuse, RayMask::DIFFUSE),
            (self.glossy, RayMask::GLOSSY),
            (self.transmission, RayMask::TRANSMISSION),
            (self.volume_scatter, RayMask::VOLUME),
            (self.shadow, RayMask::SHADOW),
        ];
        RayMask(flags.iter().filter(|(on, _)| *on).fold(0, |m, (_, k)| m | k.0))
    }
}

/// `CAUSTIC_object_shading` on a mesh's node: Blender's Object > Shading settings that
/// Cycles renders (docs/contract.md).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ObjectShadingExt {
    /// Shadow Terminator > Geometry Offset (≥ 0; Blender's default 0.1).
    #[serde(default)]
    pub(super) shadow_terminator_offset: f32,
    /// Shadow Terminator > Shading Offset (in [0, 2); Blender's default 0).
    #[serde(default)]
    pub(super) shading_offset: f32,
}

/// `CAUSTIC_light_linking` on an emitter's node (a light or an emissive mesh): the objects it
/// lights, by node name (docs/contract.md).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct LightLinkingExt {
    /// Receivers' node names (none: the emitter lights every object).
    pub(super) receivers: Option<Vec<String>>,
    /// True: only the receivers are lit; false: every object but them.
    #[serde(default)]
    pub(super) include: bool,
    /// Blockers' node names (shadow linking; none: every object casts its shadows).
    pub(super) blockers: Option<Vec<String>>,
    /// True: only the blockers cast its shadows; false: every object but them.
    #[serde(default)]
    pub(super) blockers_include: bool,
}

/// `CAUSTIC_default_material` on the document's root: the material of primitives that
/// name none (docs/contract.md).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct DefaultMaterialExt {
    pub(super) material: u32,
}
