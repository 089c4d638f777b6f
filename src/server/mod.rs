//! `caustic serve`: a persistent render server for Blender's Rendered viewport. It
//! reads requests from stdin and writes replies and frames to stdout in the framed,
//! versioned protocol of `docs/protocol.md` (`protocol.rs`), keeps the loaded scene and
//! its BVH, applies edits in place (`edits.rs`: the view and materials keep the BVH, a
//! transform moves the object into a side BVH of moved objects; `graph_edit.rs`: a node-graph
//! material's new graph compiled in place) and renders on a worker thread (`worker.rs`) that every edit
//! stops and restarts. A bad request gets an error reply and the server goes on; only a
//! length prefix beyond the limits (the stream cannot be resynchronised) or the end of
//! the input ends it.

pub mod edits;
pub mod graph_edit;
pub mod merge;
pub mod protocol;
pub mod worker;

use crate::accel::Accel;
use crate::cli::{Cli, Command, IntegratorKind};
use crate::error::Error;
use crate::integrator::Integrator;
use crate::memory::MemoryBudget;
use crate::scene::{self, Scene};
use clap::Parser;
use edits::{Invalidates, View};
use protocol::{ReadError, Request, SettingsEdit};
use serde_json::json;
use std::io::Read;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;
use worker::{Job, Output, RenderSettings, Worker};

/// Default divisor of the first frame after an edit: 1/4 of each side is 1/16 of the
/// pixels, so the first frame costs about a sixteenth of a full 1-spp pass.
const DEFAULT_REDUCE: u32 = 4;

/// A loaded scene, its BVH and what the viewport renders it with.
struct Loaded {
    scene: Arc<Scene>,
    accel: Arc<Accel>,
    settings: RenderSettings,
    /// The scene's own camera and resolution, used until the client sends a view.
    default_view: View,
    /// Instances (indices into `Scene::instances`) moved or hidden since the load: their
    /// triangles left the scene's BVH; the visible ones live in its side BVH
    /// (`Accel::relocate`).
    detached: Vec<usize>,
    /// Instances hidden now.
    hidden: Vec<usize>,
    /// The hidden objects' emissive triangles by light index (their slot holds a black
    /// light meanwhile: `edits::visibility`), with their selection power.
    hidden_power: std::collections::HashMap<usize, (u32, f32)>,
}

/// The server's state between requests.
struct Server {
    out: Arc<Output>,
    pool: Arc<rayon::ThreadPool>,
    budget: MemoryBudget,
    loaded: Option<Loaded>,
    /// The client's view (kept across loads: a reload after a mesh edit keeps the view).
    view: Option<View>,
    /// Settings the client set (kept across loads).
    settings: SettingsEdit,
    /// Counts edits; frames carry the generation they show.
    generation: u64,
    rendering: bool,
    worker: Option<Worker>,
    /// The integrator of the current scene state (photon maps survive camera moves).
    integrator: Option<Arc<Integrator>>,
}

/// Runs the server on stdin/stdout until `quit` or the end of the input.
pub fn run(threads: Option<usize>, memory_limit: Option<&str>) -> crate::error::Result<()> {
    let budget = MemoryBudget::from_flag(memory_limit)?;
    let n = threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .map_err(|e| Error::Internal(format!("cannot start worker threads: {e}")))?;
    let out = Arc::new(Output::new(Box::new(std::io::stdout())));
    let mut server = Server {
        out,
        pool: Arc::new(pool),
        budget,
        loaded: None,
        view: None,
        settings: SettingsEdit::default(),
        generation: 0,
        rendering: false,
        worker: None,
        integrator: None,
    };
    server.serve(&mut std::io::stdin().lock());
    Ok(())
}

impl Server {
    fn error(&self, request: Option<&str>, message: &str) {
        self.out.send(json!({"type": "error", "request": request, "message": message}), &[]);
    }

    fn serve(&mut self, input: &mut impl Read) {
        loop {
            let msg = match protocol::read_message(input) {
                Ok(m) => m,
                Err(ReadError::Eof) => break,
                Err(ReadError::Truncated(why)) => {
                    self.error(None, &format!("truncated message: {why}"));
                    break;
                }
                Err(ReadError::Framing(why)) => {
                    self.error(None, &format!("malformed length prefix, closing: {why}"));
                    break;
                }
            };
            // The type, if the header says one, names the request in an error reply.
            let value: serde_json::Value = match serde_json::from_slice(&msg.header) {
                Ok(v) => v,
                Err(e) => {
                    self.error(None, &format!("malformed header: not JSON ({e})"));
                    continue;
                }
            };
            let kind = value.get("type").and_then(|t| t.as_str()).map(str::to_string);
            let request: Request = match serde_json::from_value(value) {
                Ok(r) => r,
                Err(e) => {
                    self.error(kind.as_deref(), &format!("bad request: {e}"));
                    continue;
                }
            };
            let kind = kind.unwrap_or_default();
            if matches!(request, Request::Quit) && msg.payload.is_empty() {
                self.out.send(json!({"type": "ok", "request": "quit", "generation": self.generation}), &[]);
                break;
            }
            if let Err(message) = self.handle(request, msg.payload) {
                self.error(Some(&kind), &message);
            }
        }
        if let Some(w) = self.worker.take() {
            w.finish();
        }
    }

    /// Stops the render in flight, keeping its integrator if it completed one.
    fn stop_worker(&mut self) {
        if let Some(w) = self.worker.take()
            && let Some(i) = w.finish()
        {
            self.integrator = Some(i);
        }
    }

    fn ok(&self, request: &str, extra: serde_json::Value) {
        let mut v = json!({"type": "ok", "request": request, "generation": self.generation});
        if let (Some(o), serde_json::Value::Object(e)) = (v.as_object_mut(), extra) {
            o.extend(e);
        }
        self.out.send(v, &[]);
    }

    fn handle(&mut self, request: Request, payload: Vec<u8>) -> Result<(), String> {
        let takes_payload =
            matches!(request, Request::Load { bytes: Some(_), .. } | Request::Objects { bytes: Some(_), .. });
        if !takes_payload && !payload.is_empty() {
            return Err(format!("unexpected payload of {} bytes", payload.len()));
        }
        match request {
            Request::Hello { version } => {
                if version != protocol::VERSION {
                    return Err(format!(
                        "protocol version {version} is not spoken here (the server speaks {})",
                        protocol::VERSION
                    ));
                }
                self.out.send(
                    json!({"type": "hello", "version": protocol::VERSION, "server": format!("caustic {}", env!("CARGO_PKG_VERSION")),
                           "formats": ["f16", "f32", "u8"]}),
                    &[],
                );
            }
            Request::Load { path, bytes, base_dir } => self.load(path, bytes, base_dir, payload)?,
            Request::Objects { path, bytes, base_dir } => self.objects(path, bytes, base_dir, payload)?,
            Request::Camera(e) => {
                let view = edits::view_from_edit(&e)?;
                self.stop_worker();
                self.view = Some(view);
                self.edited(Invalidates::View, "camera");
            }
            Request::Material(e) => self.edit_scene("material", |s| edits::material(s, &e))?,
            Request::MaterialGraph { name, nodes } => self.material_graph(&name, &nodes)?,
            Request::Transform { name, matrix } => {
                if let Some(l) = self.loaded.as_mut()
                    && let Some(i) = l.scene.instances.iter().rposition(|s| s.name == name)
                    && !l.detached.contains(&i)
                {
                    l.detached.push(i);
                }
                self.edit_scene("transform", |s| edits::transform(s, &name, &matrix))?
            }
            Request::Visibility { name, visible } => {
                let Some(l) = self.loaded.as_mut() else {
                    return Err("no scene loaded: send load first".into());
                };
                // The newest instance of the name: an `objects` request retires the older ones.
                let i = l
                    .scene
                    .instances
                    .iter()
                    .rposition(|s| s.name == name)
                    .ok_or_else(|| format!("no mesh object named '{name}'"))?;
                if !l.detached.contains(&i) {
                    l.detached.push(i);
                }
                l.hidden.retain(|&h| h != i);
                if !visible {
                    l.hidden.push(i);
                }
                let mut saved = std::mem::take(&mut l.hidden_power);
                let r = self.edit_scene("visibility", |s| edits::visibility(s, i, visible, &mut saved));
                if let Some(l) = self.loaded.as_mut() {
                    l.hidden_power = saved;
                }
                r?
            }
            Request::Light(e) => self.edit_scene("light", |s| edits::light(s, &e))?,
            Request::World { color } => self.edit_scene("world", |s| edits::world(s, color))?,
            Request::Settings(e) => {
                let mut merged = self.settings.clone();
                merge_settings(&mut merged, e);
                match &self.loaded {
                    Some(l) => {
                        let settings = resolve_settings(&l.scene, &merged)?;
                        self.stop_worker();
                        self.loaded.as_mut().expect("checked").settings = settings;
                    }
                    // Checked now as for a scene without settings of its own, so that a
                    // bad value is refused when sent, not at the next load.
                    None => drop(resolve_settings(&settings_probe(), &merged)?),
                }
                self.settings = merged;
                self.edited(Invalidates::Shading, "settings");
            }
            Request::RenderStart => {
                if self.loaded.is_none() {
                    return Err("no scene loaded: send load first".into());
                }
                self.stop_worker();
                self.rendering = true;
                self.edited(Invalidates::View, "render_start");
            }
            Request::RenderStop => {
                self.stop_worker();
                self.rendering = false;
                self.ok("render_stop", json!({}));
            }
            Request::Quit => unreachable!("a quit without payload ends the loop; with one it is refused above"),
        }
        Ok(())
    }

    /// After an edit: drops what it made stale, replies, and restarts the render.
    fn edited(&mut self, what: Invalidates, request: &str) {
        if what != Invalidates::View {
            self.integrator = None;
        }
        self.generation += 1;
        self.ok(request, json!({}));
        self.restart();
    }

    fn restart(&mut self) {
        let (Some(l), true) = (&mut self.loaded, self.rendering) else { return };
        let view = self.view.clone().unwrap_or_else(|| l.default_view.clone());
        // Shader graphs' Camera and Window read the view (the worker has ended, so the
        // scene is not shared and this does not copy it).
        let shader_view =
            crate::scene::camera::CameraRays::new(&view.camera, view.resolution.0, view.resolution.1).shader_view();
        if l.scene.view != shader_view {
            Arc::make_mut(&mut l.scene).apply_view(shader_view);
        }
        let job = Job {
            scene: l.scene.clone(),
            accel: l.accel.clone(),
            view,
            settings: l.settings.clone(),
            integrator: self.integrator.clone(),
            generation: self.generation,
        };
        self.worker = Some(Worker::spawn(job, self.out.clone(), self.pool.clone()));
    }

    /// Applies an edit to the loaded scene with the render stopped; a geometry edit
    /// relocates the moved objects' triangles in the BVH.
    fn edit_scene(
        &mut self,
        request: &str,
        edit: impl FnOnce(&mut Scene) -> Result<Invalidates, String>,
    ) -> Result<(), String> {
        if self.loaded.is_none() {
            return Err("no scene loaded: send load first".into());
        }
        self.stop_worker();
        let l = self.loaded.as_mut().expect("checked");
        // The worker has ended, so the scene is not shared and this does not copy it.
        let what = edit(Arc::make_mut(&mut l.scene))?;
        if what == Invalidates::Geometry {
            relocate(&self.pool, l);
        }
        self.edited(what, request);
        Ok(())
    }

    fn load(
        &mut self,
        path: Option<String>,
        bytes: Option<u64>,
        base_dir: Option<String>,
        payload: Vec<u8>,
    ) -> Result<(), String> {
        let t0 = Instant::now();
        let scene = read_scene("load", path, bytes, base_dir, payload, &self.budget)?;
        let settings = resolve_settings(&scene, &self.settings)?;
        let default_view = default_view(&scene, &self.settings)?;
        let load_seconds = t0.elapsed().as_secs_f64();
        self.stop_worker();
        let t1 = Instant::now();
        let accel = build_accel(&self.pool, &scene);
        let bvh_seconds = t1.elapsed().as_secs_f64();
        let names = |v: Vec<String>| serde_json::Value::from(v);
        let reply = json!({
            "triangles": scene.mesh.triangles.len(),
            "materials": scene.materials.iter().map(|m| json!({"name": m.name, "nodes": m.nodes.is_some()})).collect::<Vec<_>>(),
            "objects": names(scene.instances.iter().map(|i| i.name.clone()).collect()),
            "lights": scene.report.lights.iter().zip(&scene.lights).filter(|(l, _)| l.kind != "emissive" && l.kind != "world")
                .map(|(l, light)| json!({"name": l.name, "kind": l.kind, "emission": edits::emission(light)})).collect::<Vec<_>>(),
            "cameras": names(scene.cameras.iter().map(|c| c.name.clone()).collect()),
            "warnings": scene.warnings,
            "load_seconds": load_seconds,
            "bvh_seconds": bvh_seconds,
        });
        self.loaded = Some(Loaded {
            scene: Arc::new(scene),
            accel: Arc::new(accel),
            settings,
            default_view,
            detached: Vec::new(),
            hidden: Vec::new(),
            hidden_power: Default::default(),
        });
        self.integrator = None;
        self.generation += 1;
        self.ok("load", reply);
        self.restart();
        Ok(())
    }
    /// Replaces a node-graph material's program (`graph_edit`): compiled and checked while the
    /// render goes on, applied with it stopped; the BVH stays.
    fn material_graph(&mut self, name: &str, nodes: &serde_json::Value) -> Result<(), String> {
        let Some(l) = self.loaded.as_ref() else {
            return Err("no scene loaded: send load first".into());
        };
        let t0 = Instant::now();
        let edit = graph_edit::prepare(&l.scene, name, nodes)?;
        self.stop_worker();
        let l = self.loaded.as_mut().expect("checked");
        // The worker has ended, so the scene is not shared and this does not copy it.
        let (what, warnings) = edit.apply(Arc::make_mut(&mut l.scene));
        if what != Invalidates::View {
            self.integrator = None;
        }
        self.generation += 1;
        self.ok("material_graph", json!({"warnings": warnings, "compile_seconds": t0.elapsed().as_secs_f64()}));
        self.restart();
        Ok(())
    }

    /// Merges the objects of a second scene into the loaded one (`merge`): added objects are
    /// appended, an object named as a loaded one replaces it (the old one hidden for good),
    /// and the new triangles go to the side BVH; the scene's BVH is not rebuilt.
    fn objects(
        &mut self,
        path: Option<String>,
        bytes: Option<u64>,
        base_dir: Option<String>,
        payload: Vec<u8>,
    ) -> Result<(), String> {
        if self.loaded.is_none() {
            return Err("no scene loaded: send load first".into());
        }
        let t0 = Instant::now();
        let add = read_scene("objects", path, bytes, base_dir, payload, &self.budget)?;
        // Refused before the render stops, so that a refusal leaves the viewport rendering.
        merge::check(&self.loaded.as_ref().expect("checked").scene, &add)?;
        let warnings = add.warnings.clone();
        let load_seconds = t0.elapsed().as_secs_f64();
        self.stop_worker();
        let t1 = Instant::now();
        let l = self.loaded.as_mut().expect("checked");
        // The worker has ended, so the scene is not shared and this does not copy it.
        let scene = Arc::make_mut(&mut l.scene);
        let merged = merge::merge(scene, add)?;
        for &i in &merged.retired {
            if !l.detached.contains(&i) {
                l.detached.push(i);
            }
            if !l.hidden.contains(&i) {
                l.hidden.push(i);
            }
            edits::visibility(scene, i, false, &mut l.hidden_power)?;
        }
        l.detached.extend(&merged.added);
        edits::recompute_bounds(scene);
        self.pool.install(|| crate::cli::build_bsdf_tables(scene));
        relocate(&self.pool, l);
        // Each name once (an object replaced again retires its older copies with it).
        let names = |v: &[usize]| {
            let mut out: Vec<&str> = Vec::new();
            for &i in v {
                let n = l.scene.instances[i].name.as_str();
                if !out.contains(&n) {
                    out.push(n);
                }
            }
            out
        };
        let reply = json!({
            "added": names(&merged.added),
            "replaced": names(&merged.retired),
            "triangles": l.scene.mesh.triangles.len(),
            "retired_triangles": retired_triangles(&l.scene),
            "warnings": warnings,
            "load_seconds": load_seconds,
            "merge_seconds": t1.elapsed().as_secs_f64(),
        });
        self.integrator = None;
        self.generation += 1;
        self.ok("objects", reply);
        self.restart();
        Ok(())
    }
}

/// Triangles of the instances a newer one of the same name replaced (`merge`): memory they
/// still hold, which a client can reclaim by a `load` once it outweighs the live scene.
fn retired_triangles(scene: &Scene) -> usize {
    let mut newer = std::collections::HashSet::new();
    scene.instances.iter().rev().filter(|s| !newer.insert(s.name.as_str())).map(|s| s.triangles.len()).sum()
}

/// The scene a `load` or `objects` request names: a file, or the payload.
fn read_scene(
    request: &str,
    path: Option<String>,
    bytes: Option<u64>,
    base_dir: Option<String>,
    payload: Vec<u8>,
    budget: &MemoryBudget,
) -> Result<Scene, String> {
    match (path, bytes) {
        (Some(p), None) => scene::gltf::load_within(Path::new(&p), budget),
        (None, Some(n)) => {
            if n != payload.len() as u64 {
                return Err(format!(
                    "truncated payload: the header declares {n} bytes, the message carries {}",
                    payload.len()
                ));
            }
            let base = base_dir.unwrap_or_else(|| ".".into());
            scene::gltf::load_bytes(&payload, Path::new(&base), "payload", budget)
        }
        _ => return Err(format!("{request} needs either path or bytes (with the scene as payload)")),
    }
    .map_err(|e| e.to_string())
}

fn build_accel(pool: &rayon::ThreadPool, scene: &Scene) -> Accel {
    let tris: Vec<[glam::Vec3; 3]> =
        scene.mesh.triangles.iter().map(|t| t.map(|i| scene.mesh.positions[i as usize])).collect();
    pool.install(|| {
        crate::cli::build_bsdf_tables(scene);
        Accel::build(&tris)
    })
}

/// Carries the moved and hidden instances out of the scene's BVH, the visible ones into its
/// side BVH: the scene-sized BVH is not rebuilt (a 1 M-triangle scene's build takes about a
/// second on 2 cores; this costs a scan of its ids and a build over the moved objects alone).
fn relocate(pool: &rayon::ThreadPool, l: &mut Loaded) {
    let scene = &l.scene;
    let tris = |i: &usize| scene.instances[*i].triangles.clone();
    let detached: Vec<u32> = l.detached.iter().flat_map(tris).collect();
    let placed: Vec<(u32, [glam::Vec3; 3])> = l
        .detached
        .iter()
        .filter(|i| !l.hidden.contains(i))
        .flat_map(tris)
        .map(|t| (t, scene.mesh.triangles[t as usize].map(|v| scene.mesh.positions[v as usize])))
        .collect();
    match Arc::get_mut(&mut l.accel) {
        Some(accel) => pool.install(|| accel.relocate(&detached, &placed)),
        // Only the stopped worker shared it; should anything still hold it, a fresh build
        // of the visible triangles gives the same answers.
        None => {
            let mut fresh = build_accel(pool, scene);
            pool.install(|| fresh.relocate(&detached, &placed));
            l.accel = Arc::new(fresh);
        }
    }
}

fn merge_settings(into: &mut SettingsEdit, e: SettingsEdit) {
    into.integrator = e.integrator.or(into.integrator.take());
    into.spp = e.spp.or(into.spp);
    into.max_depth = e.max_depth.or(into.max_depth);
    into.seed = e.seed.or(into.seed);
    into.light_sampler = e.light_sampler.or(into.light_sampler.take());
    into.frame_format = e.frame_format.or(into.frame_format);
    into.reduce = e.reduce.or(into.reduce);
}

/// `caustic render`'s arguments for the client's settings, parsed by the same command
/// line parser so that names, ranges and defaults are the render command's.
fn render_args(s: &SettingsEdit) -> Result<crate::cli::RenderArgs, String> {
    let mut argv: Vec<String> = ["caustic", "render", "viewport.glb", "-o", "viewport.exr"].map(String::from).to_vec();
    let mut flag = |name: &str, v: Option<String>| {
        if let Some(v) = v {
            argv.push(format!("--{name}"));
            argv.push(v);
        }
    };
    flag("integrator", s.integrator.clone());
    flag("spp", s.spp.map(|v| v.to_string()));
    flag("max-depth", s.max_depth.map(|v| v.to_string()));
    flag("seed", s.seed.map(|v| v.to_string()));
    flag("light-sampler", s.light_sampler.clone());
    match Cli::try_parse_from(&argv) {
        Ok(Cli { command: Command::Render(a), .. }) => Ok(a),
        Ok(_) => unreachable!("the argument list names the render command"),
        Err(e) => Err(format!(
            "bad settings: {}",
            e.to_string().lines().next().unwrap_or("invalid").trim_start_matches("error: ")
        )),
    }
}

/// The viewport's render settings: the client's, then the scene's, then the defaults.
fn resolve_settings(scene: &Scene, s: &SettingsEdit) -> Result<RenderSettings, String> {
    let args = render_args(s)?;
    let res = crate::cli::resolve(&args, scene).map_err(|e| e.to_string())?;
    if res.integrator == IntegratorKind::Sppm {
        return Err("SPPM renders whole iterations with no progressive passes to show; use photon, path or bdpt in the viewport".into());
    }
    let reduce = s.reduce.unwrap_or(DEFAULT_REDUCE);
    if !(1..=64).contains(&reduce) {
        return Err(format!("reduce {reduce} must be in 1..=64"));
    }
    Ok(RenderSettings {
        integrator: res.integrator,
        spp: res.spp,
        max_depth: res.max_depth,
        // As `caustic render`: only the path tracer follows them.
        light_paths: res.followed_light_paths(),
        bounce_limits: res.bounce_limits(),
        transparent_max: res.transparent_max,
        seed: res.job_seed,
        filter: res.filter,
        transparent: res.transparent,
        transparent_glass: res.transparent_glass,
        fast_gi: res.fast_gi,
        photon: res.photon,
        light_sampler: res.light_sampler,
        format: s.frame_format.unwrap_or_default(),
        reduce,
    })
}

/// A scene with one camera and nothing else: enough for `resolve` to check settings.
fn settings_probe() -> Scene {
    let projection = crate::scene::Projection::Perspective { yfov: 0.8, aspect: None };
    Scene {
        cameras: vec![crate::scene::Camera::from_matrix("probe".into(), &glam::Mat4::IDENTITY, projection)],
        ..Scene::default()
    }
}

/// The scene's camera at its resolution (what `caustic render` would frame).
fn default_view(scene: &Scene, s: &SettingsEdit) -> Result<View, String> {
    let res = crate::cli::resolve(&render_args(s)?, scene).map_err(|e| e.to_string())?;
    let (w, h) = res.resolution;
    Ok(View { camera: scene.cameras[res.camera].clone(), resolution: (w, h), window: [0, 0, w, h] })
}
