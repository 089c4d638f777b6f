//! Helpers shared by the integration tests: running the binary with a time bound,
//! and writing small glTF scenes with data-URI buffers.
#![allow(dead_code)]

pub mod agreement;
pub mod pass_checks;
pub mod serve;
pub mod visibility_cases;

use base64::Engine;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// What a run of the binary produced.
pub struct Run {
    /// Exit code (None if killed by a signal).
    pub code: Option<i32>,
    /// Standard output.
    pub stdout: String,
    /// Standard error.
    pub stderr: String,
    /// Wall time.
    pub elapsed: Duration,
}

impl Run {
    /// JSON objects from `--progress json` stderr lines.
    pub fn json_lines(&self) -> Vec<Value> {
        self.stderr.lines().filter_map(|l| serde_json::from_str(l).ok()).collect()
    }

    /// The messages of the warning objects, in order.
    pub fn warnings(&self) -> Vec<String> {
        self.json_lines()
            .into_iter()
            .filter(|v| v["type"] == "warning")
            .filter_map(|v| v["message"].as_str().map(str::to_string))
            .collect()
    }

    /// The error object's message, if any.
    pub fn error_message(&self) -> Option<String> {
        self.json_lines()
            .into_iter()
            .find(|v| v["type"] == "error")
            .and_then(|v| v["message"].as_str().map(str::to_string))
    }

    /// The summary object, if any.
    pub fn summary(&self) -> Option<Value> {
        self.json_lines().into_iter().find(|v| v["type"] == "summary")
    }
}

/// The binary under test.
pub fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_caustic")
}

/// Runs the binary; fails the test if it does not end within `limit`.
pub fn run(args: &[&str], limit: Duration) -> Run {
    let start = Instant::now();
    let mut child = Command::new(bin())
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start caustic");
    // Drain the pipes in threads so a chatty child cannot block on a full pipe.
    let mut out = child.stdout.take().unwrap();
    let mut err = child.stderr.take().unwrap();
    let t_out = std::thread::spawn(move || {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut out, &mut s).ok();
        s
    });
    let t_err = std::thread::spawn(move || {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut err, &mut s).ok();
        s
    });
    let status = loop {
        if let Some(st) = child.try_wait().expect("wait") {
            break st;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            panic!("caustic {:?} did not finish within {:?} (hang)", args, limit);
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    Run { code: status.code(), stdout: t_out.join().unwrap(), stderr: t_err.join().unwrap(), elapsed: start.elapsed() }
}

/// A fresh temporary directory for one test.
pub fn temp_dir() -> tempfile::TempDir {
    tempfile::tempdir().expect("temp dir")
}

/// Repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Builds a glTF document: meshes are (positions, indices, material index, node
/// matrix or None); everything goes in one data-URI buffer.
pub struct GltfBuilder {
    buffer: Vec<u8>,
    doc: Value,
}

impl Default for GltfBuilder {
    fn default() -> Self {
        Self::new()
    }
}

impl GltfBuilder {
    /// An empty document with one scene.
    pub fn new() -> Self {
        GltfBuilder {
            buffer: Vec::new(),
            doc: json!({
                "asset": {"version": "2.0", "generator": "caustic tests"},
                "scene": 0,
                "scenes": [{"nodes": []}],
                "nodes": [], "meshes": [], "materials": [], "accessors": [], "bufferViews": [],
                "extensionsUsed": []
            }),
        }
    }

    fn push_view(&mut self, bytes: &[u8], target: u32) -> usize {
        while !self.buffer.len().is_multiple_of(4) {
            self.buffer.push(0);
        }
        let offset = self.buffer.len();
        self.buffer.extend_from_slice(bytes);
        let views = self.doc["bufferViews"].as_array_mut().unwrap();
        views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len(), "target": target}));
        views.len() - 1
    }

    fn add_node(&mut self, node: Value) -> usize {
        let nodes = self.doc["nodes"].as_array_mut().unwrap();
        nodes.push(node);
        let i = nodes.len() - 1;
        self.doc["scenes"][0]["nodes"].as_array_mut().unwrap().push(json!(i));
        i
    }

    /// Adds a material (glTF JSON) and returns its index.
    pub fn material(&mut self, m: Value) -> usize {
        let mats = self.doc["materials"].as_array_mut().unwrap();
        mats.push(m);
        mats.len() - 1
    }

    /// Names material `m`.
    pub fn doc_material_name(&mut self, m: usize, name: &str) {
        self.doc["materials"][m]["name"] = json!(name);
    }

    /// Adds a triangle mesh with flat shading (no normals) on a node.
    pub fn mesh(&mut self, positions: &[[f32; 3]], indices: &[u32], material: usize) -> usize {
        let pos_bytes: Vec<u8> = positions.iter().flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes())).collect();
        let idx_bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let pv = self.push_view(&pos_bytes, 34962);
        let iv = self.push_view(&idx_bytes, 34963);
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let acc = self.doc["accessors"].as_array_mut().unwrap();
        acc.push(json!({"bufferView": pv, "componentType": 5126, "count": positions.len(), "type": "VEC3", "min": lo, "max": hi}));
        acc.push(json!({"bufferView": iv, "componentType": 5125, "count": indices.len(), "type": "SCALAR"}));
        let (pa, ia) = (acc.len() - 2, acc.len() - 1);
        let meshes = self.doc["meshes"].as_array_mut().unwrap();
        meshes.push(json!({"primitives": [{"attributes": {"POSITION": pa}, "indices": ia, "material": material}]}));
        let m = meshes.len() - 1;
        self.add_node(json!({"mesh": m}))
    }

    /// Adds an axis-aligned box (12 triangles) from `lo` to `hi`.
    pub fn cube(&mut self, lo: [f32; 3], hi: [f32; 3], material: usize) -> usize {
        let c = |i: usize| {
            [
                if i & 1 == 0 { lo[0] } else { hi[0] },
                if i & 2 == 0 { lo[1] } else { hi[1] },
                if i & 4 == 0 { lo[2] } else { hi[2] },
            ]
        };
        let positions: Vec<[f32; 3]> = (0..8).map(c).collect();
        let faces: [[u32; 4]; 6] = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let indices: Vec<u32> = faces.iter().flat_map(|f| [f[0], f[1], f[2], f[0], f[2], f[3]]).collect();
        self.mesh(&positions, &indices, material)
    }

    /// Adds a camera node at `pos` looking along `dir` (perspective, vertical fov in radians).
    pub fn camera(&mut self, pos: [f32; 3], rotation: [f32; 4], yfov: f32) -> usize {
        let cams = self.doc.as_object_mut().unwrap().entry("cameras").or_insert(json!([]));
        cams.as_array_mut()
            .unwrap()
            .push(json!({"type": "perspective", "perspective": {"yfov": yfov, "znear": 0.01, "aspectRatio": 1.0}}));
        let ci = cams.as_array().unwrap().len() - 1;
        self.add_node(json!({"camera": ci, "translation": pos, "rotation": rotation}))
    }

    /// Adds an orthographic camera node at `pos` with `rotation` (half-extents xmag, ymag).
    pub fn orthographic(&mut self, pos: [f32; 3], rotation: [f32; 4], xmag: f32, ymag: f32) -> usize {
        let cams = self.doc.as_object_mut().unwrap().entry("cameras").or_insert(json!([]));
        cams.as_array_mut().unwrap().push(
            json!({"type": "orthographic", "orthographic": {"xmag": xmag, "ymag": ymag, "znear": 0.01, "zfar": 100.0}}),
        );
        let ci = cams.as_array().unwrap().len() - 1;
        self.add_node(json!({"camera": ci, "translation": pos, "rotation": rotation}))
    }

    /// Adds a `CAUSTIC_curves` object: strands of `counts[i]` consecutive `points` (world
    /// space) with a radius each, in accessors of the document's buffer.
    pub fn curves(&mut self, name: &str, material: usize, points: &[[f32; 3]], radii: &[f32], counts: &[u32]) {
        let bytes = |v: &[f32]| v.iter().flat_map(|c| c.to_le_bytes()).collect::<Vec<u8>>();
        let flat: Vec<f32> = points.iter().flatten().copied().collect();
        let pv = self.push_view(&bytes(&flat), 34962);
        let rv = self.push_view(&bytes(radii), 34962);
        let cv = self.push_view(&counts.iter().flat_map(|c| c.to_le_bytes()).collect::<Vec<u8>>(), 34962);
        let acc = self.doc["accessors"].as_array_mut().unwrap();
        let first = acc.len();
        acc.push(json!({"bufferView": pv, "componentType": 5126, "count": points.len(), "type": "VEC3"}));
        acc.push(json!({"bufferView": rv, "componentType": 5126, "count": radii.len(), "type": "SCALAR"}));
        acc.push(json!({"bufferView": cv, "componentType": 5125, "count": counts.len(), "type": "SCALAR"}));
        self.use_ext("CAUSTIC_curves");
        let root = self.doc.as_object_mut().unwrap();
        let exts = root.entry("extensions").or_insert(json!({}));
        let curves = exts.as_object_mut().unwrap().entry("CAUSTIC_curves").or_insert(json!({"objects": []}));
        curves["objects"].as_array_mut().unwrap().push(json!({
            "name": name, "material": material, "points": first, "radii": first + 1, "counts": first + 2
        }));
    }

    /// Adds a `CAUSTIC_points` point cloud: a sphere per centre (world, glTF axes) and radius.
    pub fn points(&mut self, name: &str, material: usize, centres: &[[f32; 3]], radii: &[f32]) {
        let bytes = |v: &[f32]| v.iter().flat_map(|c| c.to_le_bytes()).collect::<Vec<u8>>();
        let flat: Vec<f32> = centres.iter().flatten().copied().collect();
        let pv = self.push_view(&bytes(&flat), 34962);
        let rv = self.push_view(&bytes(radii), 34962);
        let acc = self.doc["accessors"].as_array_mut().unwrap();
        let first = acc.len();
        acc.push(json!({"bufferView": pv, "componentType": 5126, "count": centres.len(), "type": "VEC3"}));
        acc.push(json!({"bufferView": rv, "componentType": 5126, "count": radii.len(), "type": "SCALAR"}));
        self.use_ext("CAUSTIC_points");
        let root = self.doc.as_object_mut().unwrap();
        let exts = root.entry("extensions").or_insert(json!({}));
        let points = exts.as_object_mut().unwrap().entry("CAUSTIC_points").or_insert(json!({"objects": []}));
        points["objects"].as_array_mut().unwrap().push(json!({
            "name": name, "material": material, "positions": first, "radii": first + 1
        }));
    }

    /// Adds a KHR_lights_punctual light on a node.
    pub fn punctual(&mut self, light: Value, translation: [f32; 3], rotation: [f32; 4]) -> usize {
        self.punctual_with(light, translation, rotation, json!({}))
    }

    /// Adds a KHR_lights_punctual light on a node that has further node extensions.
    pub fn punctual_with(
        &mut self,
        light: Value,
        translation: [f32; 3],
        rotation: [f32; 4],
        node_exts: Value,
    ) -> usize {
        self.use_ext("KHR_lights_punctual");
        let root = self.doc.as_object_mut().unwrap();
        let exts = root.entry("extensions").or_insert(json!({}));
        let lights = exts.as_object_mut().unwrap().entry("KHR_lights_punctual").or_insert(json!({"lights": []}));
        let arr = lights["lights"].as_array_mut().unwrap();
        arr.push(light);
        let li = arr.len() - 1;
        let mut exts = node_exts;
        exts["KHR_lights_punctual"] = json!({ "light": li });
        self.add_node(json!({"translation": translation, "rotation": rotation, "extensions": exts}))
    }

    /// Adds a node with arbitrary JSON (e.g. a CAUSTIC_lights_area extension).
    pub fn node(&mut self, node: Value) -> usize {
        self.add_node(node)
    }

    /// Puts a `CAUSTIC_camera` extension (shift, depth of field) on camera node `node`.
    pub fn camera_ext(&mut self, node: usize, ext: Value) {
        self.use_ext("CAUSTIC_camera");
        self.doc["nodes"][node]["extensions"] = json!({ "CAUSTIC_camera": ext });
    }

    /// Names node `node`.
    pub fn node_name(&mut self, node: usize, name: &str) {
        self.doc["nodes"][node]["name"] = json!(name);
    }

    /// Puts extension `name` with value `ext` on node `node` (beside any it has) and declares it.
    pub fn node_ext(&mut self, node: usize, name: &str, ext: Value) {
        self.use_ext(name);
        let n = &mut self.doc["nodes"][node];
        if n.get("extensions").is_none() {
            n["extensions"] = json!({});
        }
        n["extensions"][name] = ext;
    }

    /// Declares an extension as used.
    pub fn use_ext(&mut self, name: &str) {
        let used = self.doc["extensionsUsed"].as_array_mut().unwrap();
        if !used.iter().any(|v| v == name) {
            used.push(json!(name));
        }
    }

    /// Sets the world (`CAUSTIC_world` on the scene).
    pub fn world(&mut self, w: Value) {
        self.use_ext("CAUSTIC_world");
        self.doc["scenes"][0]["extensions"] = json!({ "CAUSTIC_world": w });
    }

    /// Puts extension `name` with value `ext` on the scene (beside any it has) and declares it.
    pub fn scene_ext(&mut self, name: &str, ext: Value) {
        self.use_ext(name);
        let scene = &mut self.doc["scenes"][0];
        if scene.get("extensions").is_none() {
            scene["extensions"] = json!({});
        }
        scene["extensions"][name] = ext;
    }

    /// Sets scene render settings (extras.caustic).
    pub fn settings(&mut self, s: Value) {
        self.doc["scenes"][0]["extras"] = json!({ "caustic": s });
    }

    /// Writes the document to `dir/name` and returns its path.
    pub fn write(mut self, dir: &Path, name: &str) -> PathBuf {
        let b64 = base64::engine::general_purpose::STANDARD.encode(&self.buffer);
        self.doc["buffers"] =
            json!([{"byteLength": self.buffer.len(), "uri": format!("data:application/octet-stream;base64,{b64}")}]);
        let path = dir.join(name);
        std::fs::write(&path, serde_json::to_vec_pretty(&self.doc).unwrap()).unwrap();
        path
    }
}

/// Quaternion rotating -Z (a glTF camera's view) onto unit `dir` (dir not parallel to +Z).
pub fn look_rotation(dir: [f32; 3]) -> [f32; 4] {
    let from = glam::Vec3::NEG_Z;
    let to = glam::Vec3::from(dir).normalize();
    let q = glam::Quat::from_rotation_arc(from, to);
    [q.x, q.y, q.z, q.w]
}

/// Every channel of an EXR (all layers), decoded to f32 bits, by name (sorted): equality of
/// two of these is bit-for-bit equality of the images.
pub fn exr_channel_bits(path: &Path) -> Vec<(String, Vec<u32>)> {
    let image = exr::prelude::read_all_flat_layers_from_file(path).expect("read EXR");
    let mut out: Vec<(String, Vec<u32>)> = image
        .layer_data
        .iter()
        .flat_map(|l| l.channel_data.list.iter())
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().map(f32::to_bits).collect()))
        .collect();
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

/// Renders `scene` to `out` with `extra` flags, asserts success, and returns the Combined pixels.
pub fn render_image(scene: &Path, out: &Path, extra: &[&str], limit: Duration) -> Vec<[f32; 4]> {
    let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"];
    args.extend_from_slice(extra);
    let r = run(&args, limit);
    assert_eq!(r.code, Some(0), "render failed: {}", r.stderr);
    caustic::output::read_combined(out).unwrap().2
}

/// The warnings of a 4×4, one-sample render of `scene` to `out` with `extra` flags (an
/// integrator's), asserting that it succeeds: enough to see what an integrator refuses to honour.
pub fn quick_render_warnings(scene: &Path, out: &Path, extra: &[&str], limit: Duration) -> Vec<String> {
    let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress", "json"];
    args.extend_from_slice(&["--resolution", "4x4", "--spp", "1"]);
    args.extend_from_slice(extra);
    let r = run(&args, limit);
    assert_eq!(r.code, Some(0), "{extra:?}: {}", r.stderr);
    r.warnings()
}

/// Mean and standard error of a set of independent estimates.
pub fn mean_se(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// The emissive furnace: a closed cube [-1, 1]³ of white, double-sided walls of the given
/// roughness that each emit `le`, seen from inside; written to `dir/name`. With albedo 1 and
/// at most D scattering events, every pixel sees exactly (D + 1) Le.
pub fn emissive_furnace(dir: &Path, name: &str, le: f64, roughness: f32) -> PathBuf {
    let mut g = GltfBuilder::new();
    g.use_ext("KHR_materials_emissive_strength");
    let m = g.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": roughness},
        "emissiveFactor": [1, 1, 1], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": le}},
        "doubleSided": true
    }));
    g.cube([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], m);
    g.camera([0.1, 0.2, 0.3], look_rotation([0.3, -0.2, -1.0]), 1.2);
    g.write(dir, name)
}

/// A fog layer over a white floor lit by a point light above it (no camera): a chromatic,
/// forward-scattering medium bounded by a box without a surface, y in [1, 1.6], the floor at
/// y = 0, the light at y = 3.
pub fn fog_layer(g: &mut GltfBuilder) {
    let white = g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
    g.mesh(
        &[[-20.0, 0.0, -20.0], [20.0, 0.0, -20.0], [20.0, 0.0, 20.0], [-20.0, 0.0, 20.0]],
        &[0, 2, 1, 0, 3, 2],
        white,
    );
    g.use_ext("CAUSTIC_materials_medium");
    let fog = g.material(json!({"extensions": {"CAUSTIC_materials_medium": {
        "density": 1.5, "scatter_color": [1.0, 0.7, 0.4], "absorption_color": [0.2, 0.2, 0.2],
        "anisotropy": 0.3, "surface": false}}}));
    g.cube([-10.0, 1.0, -10.0], [10.0, 1.6, 10.0], fog);
    g.punctual(json!({"type": "point", "intensity": 2732.0}), [0.3, 3.0, -0.2], [0.0, 0.0, 0.0, 1.0]);
}
