//! Light transport. [`SceneContext`] is the narrow view of the scene that every
//! integrator uses: closest hit, transmittance of a shadow segment, the material at a
//! hit, light sampling and the light pdf for MIS. Integrators compute one camera
//! sample at a time; the tile loop, film and progress are shared (`render.rs`).

pub mod bdpt;
pub mod catcher;
pub mod data_passes;
mod emission;
pub mod fast_gi;
pub mod filing;
pub mod light_passes;
pub mod light_paths;
pub mod linking;
pub mod media;
pub mod nee;
pub mod path;
pub mod photon;
pub mod shader_aovs;
mod shader_rays;
pub mod vcm;
pub mod walk;

use crate::accel::{Accel, Hit};
use crate::film::{CameraSample, Filter, SplatBuffer, SplatPool};
use crate::light::{AreaLight, DELTA_SUN_COS, Light, LightSample, LightSampler, LightSamplerKind, sun_radiance};
use crate::math::{Rgb, offset_ray_origin};
use crate::medium::{Medium, MediumStack};
use crate::render::job::RayStats;
use crate::sampling::PixelSampler;
use crate::scene::camera::CameraRay;
use crate::scene::camera::CameraRays;
use crate::scene::light_path::LightPath;
use crate::scene::light_visibility::{self, Excluded};
use crate::scene::shading::{ConstantBsdf, ShadingPoint, SurfaceHit};
use crate::scene::visibility::RayMask;
use crate::scene::{AlphaMode, Scene};
use glam::{Vec2, Vec3};

/// Per light, the kinds of ray whose next-event estimate takes it (`SceneContext::light_nee`):
/// its own Ray Visibility, and an emissive triangle's object's; empty when no emissive
/// triangle's object is hidden from some kind (then the lights' own visibility says it).
fn nee_rays(scene: &Scene) -> Vec<RayMask> {
    let objects = &scene.ray_visibility.per_triangle;
    let object = |l: &Light| match l {
        Light::Triangle { tri } => objects.get(*tri as usize).copied().unwrap_or(RayMask::ALL),
        _ => RayMask::ALL,
    };
    if !scene.lights.iter().any(|l| object(l) != RayMask::ALL) {
        return Vec::new();
    }
    let own = |i: usize| scene.light_rays.get(i).copied().unwrap_or(RayMask::ALL);
    scene.lights.iter().enumerate().map(|(i, l)| RayMask(own(i).0 & object(l).0)).collect()
}

/// Everything an integrator may ask of the scene.
pub struct SceneContext<'a> {
    /// The scene description.
    pub scene: &'a Scene,
    /// Triangle BVH.
    pub accel: &'a Accel,
    /// Light selection.
    pub lights: LightSampler,
    /// Triangles whose material has an alpha mask (tested during traversal).
    masked: Vec<bool>,
    /// Triangles that shadow rays may pass through (MASK or BLEND, or hidden from shadow rays).
    transparent: Vec<bool>,
    /// Which rays see each triangle (empty: every ray sees every triangle, or the
    /// integrator does not honour ray visibility; see `with_ray_visibility`).
    visibility: std::borrow::Cow<'a, [RayMask]>,
    /// Some point cloud object is hidden from some kind of ray and the context honours ray
    /// visibility (`with_object_visibility`): point hits look their object's mask up.
    point_rays: bool,
    /// Light linking is honoured (`with_light_linking`).
    linking: bool,
    /// Per light, the kinds of ray that see it (`Scene::light_rays`; empty: every ray sees
    /// every light, or the integrator does not honour it; see `with_ray_visibility`).
    light_rays: &'a [RayMask],
    /// Per light, the kinds of ray whose next-event estimate takes it: its own Ray Visibility
    /// and, for an emissive triangle, its object's (Cycles gives a mesh light its object's
    /// `SHADER_EXCLUDE_*`: closures of a hidden kind and volume scattering take no estimate
    /// from it, while rays that find it check only the object's visibility). Empty: as
    /// `light_rays`.
    light_nee: Vec<RayMask>,
    /// This context is a shadow catcher's pass (`catcher::pass_context`): rays see only
    /// catcher objects and only the lights that light catchers give light.
    catcher_only: bool,
    /// Per light, whether it lights the catcher pass (filled for `catcher_only`).
    lights_catcher: Vec<bool>,
    /// The shadow catcher's pass context when the scene has catchers and the integrator
    /// splits paths at them (`with_shadow_catcher`).
    pub catcher: Option<Box<SceneContext<'a>>>,
    /// Area lights with their light index (intersected by camera and BSDF rays).
    area_lights: Vec<(AreaLight, usize)>,
    /// Light index of the world, if it is a light.
    world_light: Option<usize>,
    /// The world is not light-sampled: next-event estimation skips it and what rays find
    /// of it is not MIS-weighted (`fast_gi::cycles_skips_world_sampling`).
    world_unsampled: bool,
    /// Sphere lights: (centre, radius, radiance, soft, camera-visible, spot cone, light index).
    spheres: Vec<SphereEntry>,
    /// Suns with a size: (unit direction toward the sun, cos half angle, radiance, light index).
    suns: Vec<(Vec3, f32, Rgb, usize)>,
    /// Some material has a medium or subsurface scattering (paths then track media and
    /// shadow rays step through volume boundaries).
    pub has_media: bool,
    /// Some medium changes light along a ray (absorbs, scatters or emits; a grid or a
    /// volume graph), or a material has subsurface scattering or a volume boundary
    /// without a surface. False when every medium is vacuum (a glTF glass's
    /// `KHR_materials_volume` without attenuation, as Blender's exporter writes for every
    /// transmissive material): the media stack then changes nothing, so ray segments and
    /// shadow rays skip it with the same numbers (vacuum's weights are exactly 1), and
    /// walkers skip drawing the media dimensions they keep in their layout (`has_media`).
    pub media_act: bool,
    /// Shadow rays must cross media and volume boundaries (`media::light_transmittance`):
    /// `media_act` but for subsurface scattering, whose surfaces block shadow rays as any
    /// opaque surface does. A scene whose only "medium" is a subsurface material (the
    /// subsurface bench scene) then traces its shadow rays as any-hit visibility instead of
    /// closest hits surface by surface: the same 0 or 1 for the same segment.
    pub shadow_media: bool,
    /// Some medium emits: photons start in media too (`light::media_emit`).
    pub media_emit: bool,
    /// The mesh media around the camera, which camera paths start in (`with_camera_at`).
    pub camera_media: MediumStack,
    /// Cycles' Transparent Max Bounces (`SceneSettings::transparent_max_bounces`): a path
    /// that has passed this many alpha surfaces ends at the next surface after its
    /// emission, and a shadow ray from a point reached through `n` of them is opaque when
    /// it crosses more than `max - n` (`integrate_shadow_max_transparent_hits`).
    pub transparent_max: u32,
    /// Cycles' per-kind bounce limits and sample clamps (`light_paths`); the CLI sets the
    /// resolved ones (flags over the file's).
    pub light_paths: light_paths::LightPaths,
    /// Some material's Transparent BSDF is coloured: shadow rays then take the per-channel
    /// route (`media::light_transmittance`), as with media.
    pub tinted_shadows: bool,
    /// Per material, its BSDF built once when it reads no texture (`Scene::constant_bsdf`).
    constant_bsdfs: Vec<Option<ConstantBsdf>>,
    /// The moving triangles' BVH when the render blurs motion (`with_motion`).
    motion: Option<&'a crate::motion::accel::MotionAccel>,
    /// Camera samples draw a time over the scene's shutter (`with_motion`); false for
    /// renders whose BVH holds every triangle where it is at the frame (server, bench).
    pub blurs_motion: bool,
}

/// A sphere light as crossed by rays: (centre, radius, radiance, soft, camera-visible, spot
/// cone, light index).
type SphereEntry = (Vec3, f32, Rgb, bool, bool, Option<crate::light::SpotCone>, usize);

/// Cycles' default Transparent Max Bounces, taken when the file does not say.
pub const DEFAULT_TRANSPARENT_MAX: u32 = 8;

/// Power heuristic (β = 2) of Veach; 0 when the weights are not finite.
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    let w = a / (a + b);
    if w.is_finite() {
        w
    } else if pdf_a > 0.0 && pdf_b == 0.0 {
        1.0
    } else {
        0.0
    }
}

impl<'a> SceneContext<'a> {
    /// Prepares the per-triangle flags and the default light sampler.
    pub fn new(scene: &'a Scene, accel: &'a Accel) -> Self {
        Self::with_light_sampler(scene, accel, LightSamplerKind::default())
    }

    /// Prepares the per-triangle flags and the light sampler of the given kind.
    pub fn with_light_sampler(scene: &'a Scene, accel: &'a Accel, kind: LightSamplerKind) -> Self {
        let mut tri_to_light = vec![u32::MAX; scene.mesh.triangles.len()];
        let mut area_lights = Vec::new();
        let mut world_light = None;
        let (mut spheres, mut suns) = (Vec::new(), Vec::new());
        for (i, l) in scene.lights.iter().enumerate() {
            match l {
                Light::Triangle { tri } => tri_to_light[*tri as usize] = i as u32,
                Light::Area(a) => area_lights.push((*a, i)),
                Light::World => world_light = Some(i),
                Light::Sphere { center, radius, radiance, soft, camera_visible, spot } => {
                    spheres.push((*center, *radius, *radiance, *soft, *camera_visible, *spot, i))
                }
                Light::Directional { direction, irradiance, cos_half } if *cos_half < DELTA_SUN_COS => {
                    suns.push((-*direction, *cos_half, sun_radiance(*irradiance, *cos_half), i))
                }
                _ => {}
            }
        }
        let mode = |t: usize| scene.materials[scene.mesh.tri_material[t] as usize].alpha_mode;
        let n = scene.mesh.triangles.len();
        let shadow_media = scene.world_medium.is_some()
            || scene.world_grid.is_some()
            || scene.materials.iter().any(|m| {
                m.medium.is_some_and(|h| h.attenuates() || h.emission != Rgb::ZERO)
                    || m.grid.is_some()
                    || m.volume_program.is_some()
                    || m.null_surface
            });
        SceneContext {
            scene,
            accel,
            lights: match kind {
                LightSamplerKind::Power => LightSampler::new(&scene.light_power, tri_to_light),
                LightSamplerKind::Tree => LightSampler::with_tree(
                    &scene.light_power,
                    &crate::light::tree::scene_light_bounds(scene),
                    tri_to_light,
                ),
            },
            masked: (0..n).map(|t| matches!(mode(t), AlphaMode::Mask(_))).collect(),
            transparent: (0..n).map(|t| mode(t) != AlphaMode::Opaque).collect(),
            visibility: std::borrow::Cow::Borrowed(&[]),
            point_rays: false,
            linking: false,
            light_rays: &[],
            light_nee: Vec::new(),
            catcher_only: false,
            lights_catcher: Vec::new(),
            catcher: None,
            area_lights,
            world_light,
            world_unsampled: false,
            spheres,
            suns,
            has_media: scene.world_medium.is_some()
                || scene.world_grid.is_some()
                || scene.materials.iter().any(|m| m.medium.is_some() || m.subsurface.is_some()),
            media_emit: crate::light::media_emit::any(scene),
            media_act: shadow_media || scene.materials.iter().any(|m| m.subsurface.is_some()),
            shadow_media,
            constant_bsdfs: (0..scene.materials.len() as u32).map(|m| scene.constant_bsdf(m)).collect(),
            camera_media: MediumStack::default(),
            transparent_max: scene.settings.transparent_max_bounces.unwrap_or(DEFAULT_TRANSPARENT_MAX),
            light_paths: light_paths::LightPaths::from_settings(&scene.settings),
            tinted_shadows: scene.materials.iter().any(|m| m.nodes.as_ref().is_some_and(|p| p.tinted_transparency)),
            motion: None,
            blurs_motion: false,
        }
    }

    /// Rays also meet the moving triangles, where they are at the camera sample's time
    /// (`crate::motion`); the static BVH must then hold only the others
    /// (`SceneMotion::static_triangles`).
    pub fn with_motion(mut self, motion: Option<&'a crate::motion::accel::MotionAccel>) -> Self {
        self.motion = motion;
        self.blurs_motion = self.scene.motion.as_ref().is_some_and(|m| m.blurs());
        self
    }

    /// This context with the resolved Light Paths limits and clamps and Transparent Max
    /// Bounces (the command line's over the file's, which `new` took).
    pub fn with_light_paths(mut self, lp: light_paths::LightPaths, transparent_max: u32) -> Self {
        self.light_paths = lp;
        self.transparent_max = transparent_max;
        self
    }

    /// This context for a camera at `p`: camera paths start in the mesh media that enclose
    /// it (a camera under water sees through the water), as Cycles starts them.
    pub fn with_camera_at(mut self, p: Vec3) -> Self {
        self.camera_media = self.media_at(p);
        self
    }

    /// The media enclosing `p`, outermost first: a ray from `p` is followed through every
    /// surface, and a medium whose boundary it first crosses from the back (leaving) holds
    /// `p`. The ray's direction is generic so that it does not run along a mesh's edges.
    pub fn media_at(&self, p: Vec3) -> MediumStack {
        // Surfaces followed at most: enough for any real nesting, bounded for a broken mesh.
        const MAX_SURFACES: usize = 4096;
        let mut stack = MediumStack::default();
        if !self.scene.materials.iter().any(|m| m.medium.is_some()) {
            return stack;
        }
        let dir = Vec3::new(0.3178, 0.8059, 0.4993).normalize();
        let (mut org, mut seen, mut inside) = (p, Vec::new(), Vec::new());
        for _ in 0..MAX_SURFACES {
            let Some(hit) = self.intersect(org, dir, f32::INFINITY) else {
                break;
            };
            let s = self.scene.surface(&hit, org, dir);
            if self.scene.materials[s.material as usize].medium.is_some() && !seen.contains(&s.material) {
                seen.push(s.material);
                if !s.front {
                    inside.push(s.material);
                }
            }
            org = offset_ray_origin(s.p, -s.ng);
        }
        // Met innermost first.
        for &m in inside.iter().rev() {
            stack.enter(m);
        }
        stack
    }

    /// Honours the objects' ray visibility (`Scene::ray_visibility`): rays pass objects
    /// hidden from their kind. Every integrator asks for it (BDPT and VCM through
    /// `bdpt::visibility`).
    pub fn with_ray_visibility(mut self) -> Self {
        // Lights' own ray visibility (`scene::light_visibility`) goes with the objects'.
        self.light_rays = &self.scene.light_rays;
        self.light_nee = nee_rays(self.scene);
        self.with_object_visibility()
    }

    /// Honours the objects' ray visibility alone (not the lights'; `with_ray_visibility`
    /// adds them).
    pub fn with_object_visibility(mut self) -> Self {
        let scene = self.scene;
        self.point_rays = scene.points.objects.iter().any(|o| o.rays != RayMask::ALL);
        let vis = &scene.ray_visibility.per_triangle;
        if vis.is_empty() {
            return self;
        }
        for (t, m) in vis.iter().enumerate() {
            // Hidden from some kind: tested during traversal, like an alpha mask.
            self.masked[t] |= *m != RayMask::ALL;
            self.transparent[t] |= !m.meets(RayMask::SHADOW);
        }
        self.visibility = std::borrow::Cow::Borrowed(vis);
        self
    }

    /// Honours light linking (`Scene::light_linking`): emitters light only their receivers,
    /// by NEE and when BSDF-sampled rays find them; shadow linking's blockers alone stop
    /// their shadow rays. Every integrator asks for it: walkers track the object a ray left
    /// (`PathState::prev_tri`), BDPT, VCM and photon tracing read it in path space
    /// (`linking`).
    pub fn with_light_linking(mut self) -> Self {
        let linking = &self.scene.light_linking;
        self.linking = !linking.rules.is_empty();
        // Shadow linking: a triangle that some light's shadow passes is tested during
        // shadow traversal, like a transparent one.
        let linked: Vec<usize> = (0..linking.blockers.len()).filter(|&l| linking.shadow_linked(l)).collect();
        if !linked.is_empty() {
            for (t, flag) in self.transparent.iter_mut().enumerate() {
                *flag |= linked.iter().any(|&l| !linking.blocks(l, t as u32));
            }
        }
        self
    }

    /// True when light `light` has a blocker rule (shadow linking): its next-event estimate
    /// counts only blockers' shadows and takes all of its light (BSDF-sampled rays that
    /// find it give nothing, as they cannot tell its blockers from other objects); always
    /// false without light linking.
    #[inline]
    pub fn shadow_linked(&self, light: usize) -> bool {
        self.linking && self.scene.light_linking.shadow_linked(light)
    }

    /// True when light `light` lights the surface of triangle `receiver` (`NO_OBJECT`: a
    /// point in a medium); always without light linking.
    #[inline]
    pub fn links(&self, light: usize, receiver: u32) -> bool {
        // The catcher pass is lit only by the lights that light catchers (Cycles'
        // SHADER_EXCLUDE_SHADOW_CATCHER, and emissive objects that are no catchers).
        if self.catcher_only && !self.lights_catcher.get(light).copied().unwrap_or(true) {
            return false;
        }
        if !self.linking {
            return true;
        }
        // A strand's receiver is its curves object's object, a point's its point cloud's.
        if receiver != crate::scene::linking::NO_OBJECT && crate::curves::is_curve(receiver) {
            let object = self.scene.curves.object_of_prim(receiver);
            return self.scene.light_linking.lights_curves(light, object);
        }
        if receiver != crate::scene::linking::NO_OBJECT && crate::points::is_point(receiver) {
            let (object, _) = self.scene.points.object_of_prim(receiver);
            return self.scene.light_linking.lights_points(light, object);
        }
        self.scene.light_linking.lights(light, receiver)
    }

    /// The BSDF classes next-event estimation toward light `light` leaves out (its Ray
    /// Visibility, `scene::light_visibility`); none unless the context honours it.
    #[inline]
    pub fn light_excludes(&self, light: usize) -> Excluded {
        self.nee_rays(light).map_or(Excluded::default(), Excluded::of)
    }

    /// The kinds of ray whose next-event estimate takes light `light` (`light_nee`), None
    /// for every kind.
    #[inline]
    fn nee_rays(&self, light: usize) -> Option<RayMask> {
        if self.light_nee.is_empty() { self.light_rays.get(light).copied() } else { self.light_nee.get(light).copied() }
    }

    /// True when a path whose last event set `path`'s flags finds light `light` (its Ray
    /// Visibility beyond Camera); always unless the context honours it.
    #[inline]
    pub fn light_seen_by(&self, light: usize, path: &LightPath) -> bool {
        self.light_rays.get(light).is_none_or(|m| light_visibility::path_sees(*m, path))
    }

    /// True when a bounce that left `receiver` with `path`'s flags finds light `light`
    /// (light linking and the light's ray visibility).
    #[inline]
    fn bounce_finds(&self, light: usize, receiver: u32, path: &LightPath) -> bool {
        self.links(light, receiver) && self.light_seen_by(light, path)
    }

    /// True when a ray of a path in state `path` sees the world (its Ray Visibility, held
    /// with the lights'; `camera`: the camera ray, through pass-throughs only); always
    /// unless the context honours it.
    #[inline]
    pub fn world_seen_by(&self, camera: bool, path: &LightPath) -> bool {
        match self.world_light.and_then(|w| self.light_rays.get(w)) {
            None => true,
            Some(m) if camera => m.meets(RayMask::CAMERA),
            Some(m) => light_visibility::path_sees(*m, path),
        }
    }

    /// True when next-event estimation from a point whose path has made `bounce` bounces
    /// (`LightPath::depth`) takes light `light`: its Max Bounces (`scene::light_bounces`).
    #[inline]
    pub fn nee_within_bounces(&self, light: usize, bounce: u16) -> bool {
        if self.world_unsampled && self.world_light == Some(light) {
            return false;
        }
        crate::scene::light_bounces::nee_allowed(&self.scene.light_max_bounces, light, bounce)
    }

    /// The context with the world left out of light sampling: found by rays alone, at full
    /// weight (as Cycles treats a world without spatial variation, `fast_gi`).
    pub fn without_world_sampling(mut self) -> Self {
        self.world_unsampled = true;
        self
    }

    /// True when light `light` lights volume scattering events (Ray Visibility > Volume
    /// Scatter); always unless the context honours it.
    #[inline]
    pub fn light_seen_in_volume(&self, light: usize) -> bool {
        self.nee_rays(light).is_none_or(|m| m.meets(RayMask::VOLUME))
    }

    /// True when triangle `tri` belongs to a shadow catcher at which camera paths split
    /// (only with a catcher pass context, `with_shadow_catcher`).
    #[inline]
    pub fn is_catcher(&self, tri: u32) -> bool {
        self.catcher.is_some() && self.scene.ray_visibility.is_catcher(tri)
    }

    /// True when triangle `tri` belongs to a holdout object: camera rays reaching it end
    /// with nothing seen (colour and alpha 0), as Cycles' holdout.
    #[inline]
    pub fn is_holdout(&self, tri: u32) -> bool {
        if crate::points::is_point(tri) {
            return self.scene.points.holdout_of(tri);
        }
        self.scene.ray_visibility.is_holdout(tri)
    }

    /// A node graph's Holdout seen by a camera ray (through pass-throughs only) with
    /// throughput `beta`: the film alpha this sample leaves there, 1 − h × mean(beta) for the
    /// holdout weight h, and whether the path ends (h = 1, the surface wholly held out: no
    /// colour, no data passes). Cycles' `integrate_surface_holdout`, which writes the same
    /// transparency whether or not the film is transparent; the rest of the closures
    /// (weights 1 − h in a Mix Shader) shade on.
    #[inline]
    pub fn holdout_alpha(sp: &ShadingPoint, beta: Rgb) -> (f32, bool) {
        let h = sp.holdout;
        (1.0 - h * (beta.x + beta.y + beta.z) / 3.0, (h - 1.0).abs() <= 1e-6)
    }

    /// The kinds of ray that see triangle `tri`'s object (every kind unless the context
    /// honours ray visibility): photons read it (`photon::visibility`).
    #[inline]
    pub fn object_rays(&self, tri: u32) -> RayMask {
        if self.point_rays && crate::points::is_point(tri) {
            return self.scene.points.rays_of(tri);
        }
        self.visibility.get(tri as usize).copied().unwrap_or(RayMask::ALL)
    }

    /// True when rays of kind `ray` see triangle `tri` (or the point of a point hit's id).
    #[inline]
    pub(crate) fn sees(&self, ray: RayMask, tri: u32) -> bool {
        if self.point_rays && crate::points::is_point(tri) {
            return ray.meets(self.scene.points.rays_of(tri));
        }
        self.visibility.get(tri as usize).is_none_or(|m| ray.meets(*m))
    }

    /// The material at a hit (`Scene::shade`), with texture-free materials' BSDFs built once
    /// and a node graph's Ambient Occlusion and Bevel nodes traced in this context's scene.
    #[inline]
    pub fn shade(&self, s: &SurfaceHit, wo: Vec3) -> ShadingPoint {
        let constant = self.constant_bsdfs.get(s.material as usize).and_then(Option::as_ref);
        self.scene.shade_with(s, wo, constant, Some(self))
    }

    /// The media a path is in after leaving surface `s` in direction `wi`: crossing the
    /// boundary of a solid with a medium enters or leaves it (the nesting rule is
    /// `MediumStack`'s); reflection and thin surfaces keep the current media, and so do
    /// points, whose back a ray never meets (a glass point refracts, no more).
    #[inline]
    pub fn medium_after(&self, s: &SurfaceHit, wi: Vec3, mut stack: MediumStack) -> MediumStack {
        if wi.dot(s.ng) < 0.0
            && self.scene.materials[s.material as usize].medium.is_some()
            && !crate::points::is_point(s.tri)
        {
            if s.front {
                stack.enter(s.material);
            } else {
                stack.leave(s.material);
            }
        }
        stack
    }

    /// False for a light whose Cast Shadow is off: next-event estimation skips its shadow
    /// ray, as Cycles does (neither occluders nor media dim it).
    #[inline]
    pub fn casts_shadow(&self, light: usize) -> bool {
        self.scene.light_casts_shadow.get(light).copied().unwrap_or(true)
    }

    /// The medium in effect for a stack of media.
    #[inline]
    pub fn medium(&self, stack: &MediumStack) -> Option<Medium<'_>> {
        match stack.current() {
            Some(m) => {
                let mat = &self.scene.materials[m as usize];
                match mat.grid {
                    Some(g) => Some(Medium::Grid(&self.scene.grids[g as usize])),
                    None => mat.medium.as_ref().map(Medium::Homogeneous),
                }
            }
            // Outside every mesh medium: the world's volume, if any.
            None => match self.scene.world_grid {
                Some(g) => Some(Medium::Grid(&self.scene.grids[g as usize])),
                None => self.scene.world_medium.as_ref().map(Medium::Homogeneous),
            },
        }
    }

    /// Radiance of the world seen along direction `d` (zero without a world).
    #[inline]
    pub fn world_radiance(&self, d: Vec3) -> Rgb {
        self.scene.world.as_ref().map_or(Rgb::ZERO, |w| w.radiance(d))
    }

    /// [`world_radiance`](Self::world_radiance) seen by a ray of path state `path` escaping
    /// along `d` (differs where the world's graph reads the Light Path node).
    #[inline]
    pub fn world_radiance_for(&self, d: Vec3, path: &crate::scene::light_path::LightPath) -> Rgb {
        self.scene.world.as_ref().map_or(Rgb::ZERO, |w| w.radiance_for(d, path))
    }

    /// [`world_pdf`](Self::world_pdf) of the world's map alone, without its portals (BDPT's
    /// and VCM's world connections, `sample_light_unguided`).
    #[inline]
    pub fn world_map_pdf(&self, d: Vec3) -> f32 {
        match (self.world_light, &self.scene.world) {
            (Some(i), Some(w)) => self.lights.infinite_pmf(i) * w.pdf(d),
            _ => 0.0,
        }
    }

    /// Density with which light sampling at `p` (world choice included) picks direction `d`.
    #[inline]
    pub fn world_pdf(&self, p: Vec3, d: Vec3) -> f32 {
        if self.world_unsampled {
            return 0.0;
        }
        match (self.world_light, &self.scene.world) {
            (Some(i), Some(w)) => self.lights.infinite_pmf(i) * w.pdf_from(p, d),
            _ => 0.0,
        }
    }

    /// Closest surface hit (alpha masks applied) of a ray that sees every object.
    #[inline]
    pub fn intersect(&self, org: Vec3, dir: Vec3, tmax: f32) -> Option<Hit> {
        self.intersect_as(org, dir, tmax, RayMask::ALL)
    }

    /// Closest surface hit (alpha masks applied) of a ray of kind `ray`: objects hidden
    /// from it are passed.
    #[inline]
    pub fn intersect_as(&self, org: Vec3, dir: Vec3, tmax: f32, ray: RayMask) -> Option<Hit> {
        let hit = self.accel.intersect(org, dir, tmax, &self.masked, self.accepts(ray));
        let hit = match self.motion {
            None => hit,
            Some(m) => {
                let t = crate::motion::ray_time();
                m.intersect(org, dir, hit.map_or(tmax, |h| h.t), t, &self.masked, self.accepts(ray)).or(hit)
            }
        };
        // Strands and points, in their own BVHs, up to the nearest hit so far: the nearer wins.
        let hit = match &self.scene.curves.bvh {
            Some(curves) => curves.intersect(&self.scene.curves.points, org, dir, hit.map_or(tmax, |h| h.t)).or(hit),
            None => hit,
        };
        match &self.scene.points.bvh {
            Some(points) => {
                // Points hidden from the ray's kind are passed (their object's Ray Visibility).
                let seen = |slot: u32| self.sees(ray, crate::points::POINT_BITS | slot);
                points.intersect(&self.scene.points.spheres, org, dir, hit.map_or(tmax, |h| h.t), seen).or(hit)
            }
            None => hit,
        }
    }

    /// [`intersect_as`](Self::intersect_as) among the still triangles only, passing
    /// triangle `skip`: the short look back across a surface that a ray has just left
    /// (`walk::PathState::coincident_hit`).
    #[inline]
    pub fn intersect_still_except(&self, org: Vec3, dir: Vec3, tmax: f32, ray: RayMask, skip: u32) -> Option<Hit> {
        self.accel.intersect_except(org, dir, tmax, skip, &self.masked, self.accepts(ray))
    }

    /// A radius (at most `cap`) around `p` that no surface a closest-hit query can return
    /// comes within (`Accel::clearance`); 0 with moving triangles, strands or points, which it
    /// does not see.
    /// The subsurface walk skips the query for steps inside it.
    #[inline]
    /// `near` is the last search's nearest triangle (`Accel::clearance_near`).
    pub fn clearance(&self, p: Vec3, cap: f32, near: &mut u32) -> f32 {
        match (self.motion, &self.scene.curves.bvh, &self.scene.points.bvh) {
            (None, None, None) => self.accel.clearance_near(p, cap, near),
            _ => 0.0,
        }
    }

    /// The hit filter of a ray of kind `ray`: visibility and alpha masks.
    #[inline]
    fn accepts(&self, ray: RayMask) -> impl Fn(u32, f32, f32) -> bool + '_ {
        move |tri: u32, b1: f32, b2: f32| {
            if !self.sees(ray, tri) {
                return false;
            }
            match self.scene.materials[self.scene.mesh.tri_material[tri as usize] as usize].alpha_mode {
                AlphaMode::Mask(cutoff) => self.scene.alpha(tri, b1, b2) >= cutoff,
                _ => true,
            }
        }
    }

    /// Fraction of light passing from `org` along `dir` for distance `tmax` (a shadow
    /// ray of state `path`: objects hidden from shadow rays let it through).
    #[inline]
    pub fn transmittance(&self, org: Vec3, dir: Vec3, tmax: f32, path: LightPath) -> f32 {
        self.transmittance_of(org, dir, tmax, None, path)
    }

    /// [`transmittance`](Self::transmittance) of a shadow ray toward light `light`: with
    /// shadow linking only its blockers stop it.
    #[inline]
    pub fn transmittance_of(&self, org: Vec3, dir: Vec3, tmax: f32, light: Option<usize>, path: LightPath) -> f32 {
        // Cycles makes the ray opaque when it crosses more alpha surfaces than the path's
        // transparent bounces leave (each one counts, whatever its alpha there).
        let crossings_left = self.transparent_crossings_left(path);
        let crossings = std::cell::Cell::new(0u32);
        let transparency = |tri: u32, b1: f32, b2: f32| {
            if !self.sees(RayMask::SHADOW, tri) || light.is_some_and(|l| !self.blocks(l, tri)) {
                return 1.0;
            }
            let material = &self.scene.materials[self.scene.mesh.tri_material[tri as usize] as usize];
            // Transparent Shadows off: Cycles' shadow rays stop at the surface whatever its alpha.
            let mode = if material.transparent_shadow { material.alpha_mode } else { AlphaMode::Opaque };
            if mode != AlphaMode::Opaque {
                crossings.set(crossings.get() + 1);
                if crossings.get() > crossings_left {
                    return 0.0;
                }
            }
            match mode {
                AlphaMode::Mask(cutoff) => {
                    if self.scene.shadow_alpha(tri, b1, b2, path, org, dir) >= cutoff {
                        0.0
                    } else {
                        1.0
                    }
                }
                AlphaMode::Blend => (1.0 - self.scene.shadow_alpha(tri, b1, b2, path, org, dir)).clamp(0.0, 1.0),
                AlphaMode::Opaque => 0.0,
            }
        };
        let tr = self.accel.transmittance(org, dir, tmax, &self.transparent, transparency);
        let tr = match self.motion {
            Some(m) if tr > 0.0 => {
                let t = crate::motion::ray_time();
                tr * m.transmittance(org, dir, tmax, t, &self.transparent, transparency)
            }
            _ => tr,
        };
        // Strands and points are opaque; with shadow linking only the light's blockers among
        // them count.
        let linked = light.filter(|&l| self.shadow_linked(l));
        let points = &self.scene.curves.points;
        let tr = match (&self.scene.curves.bvh, linked) {
            (Some(curves), None) if tr > 0.0 && curves.occluded(points, org, dir, tmax) => 0.0,
            (Some(curves), Some(l)) if tr > 0.0 => {
                let blocker = |segment: u32| self.blocks(l, crate::curves::CURVE_BIT | segment);
                if curves.occluded_by(points, org, dir, tmax, blocker) { 0.0 } else { tr }
            }
            _ => tr,
        };
        let spheres = &self.scene.points.spheres;
        // Points hidden from shadow rays let them through.
        let shadows = |slot: u32| self.sees(RayMask::SHADOW, crate::points::POINT_BITS | slot);
        match (&self.scene.points.bvh, linked) {
            (Some(points), None) if tr > 0.0 && points.occluded_by(spheres, org, dir, tmax, shadows) => 0.0,
            (Some(points), Some(l)) if tr > 0.0 => {
                let blocker = |slot: u32| shadows(slot) && self.blocks(l, crate::points::POINT_BITS | slot);
                if points.occluded_by(spheres, org, dir, tmax, blocker) { 0.0 } else { tr }
            }
            _ => tr,
        }
    }

    /// How many alpha surfaces a shadow ray of state `path` may cross before Cycles makes
    /// it opaque: Transparent Max Bounces less the path's transparent bounces (Blender 5.0;
    /// older Cycles sources subtract one more, which renders two layers' shadows darker
    /// than bpy 5.0.1 does: `test_alpha_layers_agreement.py`).
    #[inline]
    pub fn transparent_crossings_left(&self, path: LightPath) -> u32 {
        self.transparent_max.saturating_sub(u32::from(path.transparent))
    }

    /// A path of state `path` ends at the surface it has reached, after its emission:
    /// it has passed Transparent Max Bounces alpha surfaces (Cycles'
    /// `PATH_RAY_TERMINATE_ON_NEXT_SURFACE`, set by a transparent bounce only: with a
    /// maximum of 0 a path that crossed no alpha surface shades on, as Cycles renders
    /// opaque surfaces lit then).
    #[inline]
    pub fn ends_at_surface(&self, path: LightPath) -> bool {
        path.transparent > 0 && u32::from(path.transparent) >= self.transparent_max
    }

    /// Samples light `index` from point `p` (the light's own `sample_li`).
    #[inline]
    pub fn sample_light(&self, index: usize, p: Vec3, u: Vec2) -> Option<LightSample> {
        let s = self.scene.lights[index].sample_li(self.scene, p, u);
        self.with_light_graph(index, p, s, LightPath::LIGHT_EMISSION)
    }

    /// Sample `s` of light `index` from `p` with its varying node tree's factor
    /// (`light::light_graph`), evaluated for a ray of state `path`.
    #[inline]
    fn with_light_graph(&self, index: usize, p: Vec3, s: Option<LightSample>, path: LightPath) -> Option<LightSample> {
        match (s, self.scene.light_graphs.get(index)) {
            (Some(mut s), Some(Some(_))) => {
                let f = crate::light::light_graph::graph_factor(self.scene, index, s.point, s.normal, p, path);
                s.li *= f;
                Some(s)
            }
            (s, _) => s,
        }
    }

    /// [`sample_light_from`](Self::sample_light_from) with the world sampled by its map
    /// alone (BDPT's and VCM's connections: `Light::sample_li_unguided`).
    #[inline]
    pub fn sample_light_unguided(&self, index: usize, p: Vec3, u: Vec2, path: LightPath) -> Option<LightSample> {
        let s = self.scene.lights[index].sample_li_unguided(self.scene, p, u, path);
        self.with_light_graph(index, p, s, path.emission(0.0))
    }

    /// [`sample_light`](Self::sample_light) from a shading point reached by `path` (an
    /// emissive node graph's Light Path node reads it, as Cycles' light sampling does).
    #[inline]
    pub fn sample_light_from(&self, index: usize, p: Vec3, u: Vec2, path: LightPath) -> Option<LightSample> {
        let s = self.scene.lights[index].sample_li_from(self.scene, p, u, path);
        self.with_light_graph(index, p, s, path.emission(0.0))
    }

    /// [`sample_light_from`](Self::sample_light_from) at a receiver of normal `n`, the one
    /// light selection was given (`Light::sample_li_at`).
    #[inline]
    pub fn sample_light_at(&self, index: usize, p: Vec3, n: Vec3, u: Vec2, path: LightPath) -> Option<LightSample> {
        let s = self.scene.lights[index].sample_li_at(self.scene, p, n, u, path);
        self.with_light_graph(index, p, s, path.emission(0.0))
    }

    /// Solid-angle density with which `sample_light` (including the light choice, made
    /// with the receiver normal `n`) would pick the point `q` with normal `n_light` of
    /// light `index`, from `p`.
    #[inline]
    pub fn light_pdf(&self, index: usize, p: Vec3, n: Vec3, q: Vec3, n_light: Vec3) -> f32 {
        self.scene.lights[index].pdf_li(self.scene, p, q, n_light).map_or(0.0, |pdf| self.lights.pmf(p, n, index) * pdf)
    }

    /// Unoccluded fraction between a surface point (offset along `ng`) and a light sample,
    /// for a shadow ray of state `path`.
    #[inline]
    pub fn visibility(&self, p: Vec3, ng: Vec3, ls: &LightSample, path: LightPath) -> f32 {
        self.visibility_of(p, ng, ls, None, path)
    }

    /// True when triangle `tri` casts light `light`'s shadows (shadow linking).
    #[inline]
    pub fn blocks(&self, light: usize, tri: u32) -> bool {
        if !self.linking {
            return true;
        }
        // A strand blocks as its curves object's object, a point as its point cloud's.
        if tri != crate::scene::linking::NO_OBJECT && crate::curves::is_curve(tri) {
            let object = self.scene.curves.object_of_prim(tri);
            return self.scene.light_linking.blocks_curves(light, object);
        }
        if tri != crate::scene::linking::NO_OBJECT && crate::points::is_point(tri) {
            let (object, _) = self.scene.points.object_of_prim(tri);
            return self.scene.light_linking.blocks_points(light, object);
        }
        self.scene.light_linking.blocks(light, tri)
    }

    /// [`visibility`](Self::visibility) of a sample of light `light` (shadow linking).
    #[inline]
    pub fn visibility_of(&self, p: Vec3, ng: Vec3, ls: &LightSample, light: Option<usize>, path: LightPath) -> f32 {
        let side = if ls.wi.dot(ng) >= 0.0 { ng } else { -ng };
        let org = offset_ray_origin(p, side);
        if ls.dist.is_infinite() {
            return self.transmittance_of(org, ls.wi, f32::INFINITY, light, path);
        }
        let target = if ls.normal != Vec3::ZERO { offset_ray_origin(ls.point, ls.normal) } else { ls.point };
        let d = target - org;
        let dist = d.length();
        if !(dist > 0.0) {
            return 0.0;
        }
        self.transmittance_of(org, d / dist, dist * (1.0 - 1e-4), light, path)
    }
}

/// The light-transport algorithms; one per file.
#[derive(Clone, Debug)]
pub enum Integrator {
    /// Unidirectional path tracing with NEE and MIS.
    Path(path::PathIntegrator),
    /// Jensen's photon mapping (rendering pass; the maps are built before).
    Photon(photon::jensen::JensenIntegrator),
    /// Bidirectional path tracing with MIS over all strategies.
    Bdpt(bdpt::BdptIntegrator),
    /// Stochastic progressive photon mapping (drives its own iterations).
    Sppm(photon::sppm::SppmIntegrator),
    /// Vertex connection and merging (drives its own iterations).
    Vcm(vcm::VcmIntegrator),
}

/// Per-tile working memory of an integrator, taken before a tile and released after it.
pub enum TileScratch {
    /// Nothing to keep.
    None,
    /// Bidirectional: this tile's light-tracing splats and subpath vertices (boxed: the
    /// scratch is over 200 bytes, one allocation per tile).
    Bdpt(SplatBuffer, Box<bdpt::BdptScratch>),
}

impl TileScratch {
    /// Hands the splat buffer back to the pool it came from.
    pub fn release(self, pool: &SplatPool) {
        if let TileScratch::Bdpt(buf, _) = self {
            pool.give(buf);
        }
    }
}

impl Integrator {
    /// Human-readable description with parameters, for logs and `info`.
    pub fn describe(&self) -> String {
        match self {
            Integrator::Path(p) => p.describe(),
            Integrator::Photon(p) => p.describe(),
            Integrator::Bdpt(b) => b.describe(),
            Integrator::Sppm(s) => s.describe(),
            Integrator::Vcm(v) => v.describe(),
        }
    }

    /// Working memory for one tile of the progressive loop.
    pub fn tile_scratch(&self, splats: &SplatPool) -> TileScratch {
        match self {
            Integrator::Bdpt(b) => TileScratch::Bdpt(splats.take(), Box::new(bdpt::BdptScratch::new(b.max_depth))),
            _ => TileScratch::None,
        }
    }

    /// Light subpaths traced per camera sample (bidirectional: one), for the summary.
    pub fn light_paths_per_sample(&self) -> u64 {
        matches!(self, Integrator::Bdpt(_)) as u64
    }

    /// One camera sample along `ray` of pixel sample `(seed, px, py, index)`, written over
    /// `out` (the path tracer fills it in place: no per-sample copy of the record).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn sample(
        &self,
        ctx: &SceneContext,
        camera: &CameraRays,
        filter: &Filter,
        scratch: &mut TileScratch,
        ray: &CameraRay,
        sampler: &mut PixelSampler,
        pixel_sample: (u32, u32, u32, u32),
        stats: &mut RayStats,
        out: &mut CameraSample,
    ) {
        if ray.is_blind() {
            // BDPT still splats the sample's light subpath (`BdptIntegrator::li_blind`).
            *out = match (self, scratch) {
                (Integrator::Bdpt(b), TileScratch::Bdpt(buf, vertices)) => {
                    let mut target = bdpt::FilmTarget { camera, filter, splats: buf };
                    b.li_blind(ctx, ray, pixel_sample, &mut target, vertices, stats)
                }
                _ => CameraSample::blind(),
            };
            return;
        }
        match (self, scratch) {
            (Integrator::Path(p), _) => p.li(ctx, ray, sampler, |q| camera.depth(q), stats, out),
            (Integrator::Photon(p), _) => *out = p.li(ctx, ray, sampler, |q| camera.depth(q), stats),
            (Integrator::Bdpt(b), TileScratch::Bdpt(buf, vertices)) => {
                let mut target = bdpt::FilmTarget { camera, filter, splats: buf };
                *out = b.li(ctx, ray, sampler, pixel_sample, &mut target, vertices, stats)
            }
            // SPPM and VCM render whole iterations (`render::render` never asks them for
            // samples); BDPT always has its scratch (`tile_scratch`).
            (Integrator::Sppm(_) | Integrator::Vcm(_) | Integrator::Bdpt(_), _) => *out = CameraSample::default(),
        }
    }
}
