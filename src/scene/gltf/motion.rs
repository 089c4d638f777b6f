//! `CAUSTIC_motion` (docs/contract.md): the shutter and step times on the scene, each
//! moving node's world matrices at the steps. Moving meshes' triangles are baked at the
//! steps (and at sub-steps where a step turns more than `MAX_STEP_ANGLE`, so that the
//! linear blend of corners between steps follows Cycles' decomposed interpolation to
//! within a small chord error), their vertices deformed first when the node carries
//! deformation (`deformation.rs`); a moving camera keeps its decomposed frames.

use super::Loader;
use super::deformation::{Deformation, normal_turn};
use crate::error::Result;
use crate::motion::transform::Decomposed;
use crate::motion::{CameraMotion, SceneMotion, Shutter, segment};
use crate::scene::{Camera, InstanceSpan, Mesh};
use glam::{Mat3, Mat4, Vec3};
use serde::Deserialize;

/// Largest rotation between two baked steps. A corner at radius r then departs from the
/// arc by at most r (1 − cos(θ/2)) = 1e-3 r for θ = 5°: well under a pixel for an object
/// a few hundred pixels across.
const MAX_STEP_ANGLE: f32 = 5.0 * std::f32::consts::PI / 180.0;

/// Most baked steps (memory: 36 bytes × 2 per moving triangle and step).
const MAX_STEPS: usize = 129;

/// The scene's `CAUSTIC_motion`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneMotionExt {
    /// Step times in frames relative to the frame, ascending.
    times: Vec<f32>,
    /// The shutter when the render blurs motion (absent: the steps serve the Vector pass).
    #[serde(default)]
    shutter: Option<ShutterExt>,
}

/// The shutter in `CAUSTIC_motion`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ShutterExt {
    /// Opening and closing times in frames.
    open: f32,
    close: f32,
    /// Blender's Rolling Shutter Duration when the rolling shutter is on.
    #[serde(default)]
    rolling_duration: Option<f32>,
}

/// A node's `CAUSTIC_motion`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct NodeMotionExt {
    /// The world matrix at the frame, in the axes of `matrices` (column-major).
    matrix: [f32; 16],
    /// The world matrix at each step time.
    matrices: Vec<[f32; 16]>,
    /// Deformation: the accessor of the object's vertex positions at the frame
    /// (`deformation.rs`).
    #[serde(default)]
    reference: Option<usize>,
    /// Deformation: one accessor of vertex positions per step time.
    #[serde(default)]
    positions: Option<Vec<usize>>,
}

impl Loader<'_> {
    /// Reads `CAUSTIC_motion`: returns the scene's motion (None when nothing moves) and
    /// gives moving cameras their motion. `nodes[i]` is the node of `spans[i]`'s instance;
    /// `camera_nodes[j]` the node of `cameras[j]`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn motion(
        &mut self,
        value: &serde_json::Value,
        doc: &gltf::Document,
        buffers: &[Vec<u8>],
        mesh: &Mesh,
        spans: &[InstanceSpan],
        span_nodes: &[usize],
        cameras: &mut [Camera],
        camera_nodes: &[usize],
    ) -> Result<Option<SceneMotion>> {
        let scene_index = value.get("scene").and_then(|s| s.as_u64()).unwrap_or(0);
        let ext = value.pointer(&format!("/scenes/{scene_index}/extensions/CAUSTIC_motion"));
        let node_ext = |n: usize| value.pointer(&format!("/nodes/{n}/extensions/CAUSTIC_motion"));
        let Some(ext) = ext else {
            if let Some(n) = (0..doc.nodes().count()).find(|&n| node_ext(n).is_some()) {
                return Err(self.err(format!(
                    "node {n} has CAUSTIC_motion but the scene gives no step times (scenes[{scene_index}].extensions.CAUSTIC_motion)"
                )));
            }
            return Ok(None);
        };
        let ext: SceneMotionExt = serde_json::from_value(ext.clone())
            .map_err(|e| self.err(format!("the scene's CAUSTIC_motion is malformed: {e}")))?;
        let times = ext.times;
        if times.len() < 2 || times.len() > MAX_STEPS {
            return Err(self.err(format!("CAUSTIC_motion: {} step times; give 2 to {MAX_STEPS}", times.len())));
        }
        if !times.iter().all(|t| t.is_finite() && t.abs() <= 1e6) || !times.windows(2).all(|w| w[0] < w[1]) {
            return Err(self.err(format!("CAUSTIC_motion: step times {times:?} must be finite and ascending")));
        }
        let shutter = match ext.shutter {
            None => None,
            Some(s) => {
                let rolling_ok = s.rolling_duration.is_none_or(|d| (0.0..=1.0).contains(&d));
                if !(s.open.is_finite() && s.close.is_finite() && s.open <= s.close && rolling_ok) {
                    return Err(self.err(format!(
                        "CAUSTIC_motion: shutter open {} close {} (rolling duration {:?}) needs open <= close, a duration in 0..1",
                        s.open, s.close, s.rolling_duration
                    )));
                }
                Some(Shutter { open: s.open, close: s.close, rolling: s.rolling_duration })
            }
        };
        // Every node's matrices, checked.
        let mut node_steps = std::collections::HashMap::new();
        let mut node_deform: std::collections::HashMap<usize, Deformation> = Default::default();
        for n in 0..doc.nodes().count() {
            let Some(v) = node_ext(n) else { continue };
            let e: NodeMotionExt = serde_json::from_value(v.clone())
                .map_err(|e| self.err(format!("node {n}: CAUSTIC_motion is malformed: {e}")))?;
            if e.matrices.len() != times.len() {
                return Err(self.err(format!(
                    "node {n}: CAUSTIC_motion has {} matrices for {} step times",
                    e.matrices.len(),
                    times.len()
                )));
            }
            let reference = Mat4::from_cols_array(&e.matrix);
            let steps: Vec<Mat4> = e.matrices.iter().map(Mat4::from_cols_array).collect();
            let invertible = |m: &Mat4| m.is_finite() && Mat3::from_mat4(*m).determinant().abs() > 1e-30;
            if !invertible(&reference) || !steps.iter().all(invertible) {
                return Err(self.err(format!("node {n}: CAUSTIC_motion matrices must be finite and invertible")));
            }
            match (e.reference, &e.positions) {
                (Some(r), Some(p)) => {
                    let d = self.deformation(n, doc, buffers, r, p, times.len())?;
                    node_deform.insert(n, d);
                }
                (None, None) => {}
                _ => {
                    return Err(
                        self.err(format!("node {n}: CAUSTIC_motion needs both reference and positions, or neither"))
                    );
                }
            }
            if steps.iter().any(|m| *m != reference) {
                node_steps.insert(n, (reference, steps));
            }
        }
        // A node without its own motion moves with its nearest ancestor that has one (the
        // exporter's camera-correction child, a collection instance's objects under the
        // instancer): its world matrix is the ancestor's times a fixed local part.
        let mut parent = vec![None; doc.nodes().count()];
        for nd in doc.nodes() {
            for c in nd.children() {
                parent[c.index()] = Some(nd.index());
            }
        }
        let moving_ancestor = |mut n: usize| loop {
            if node_steps.contains_key(&n) {
                return Some(n);
            }
            n = parent[n]?;
        };
        for (cam, &n) in cameras.iter_mut().zip(camera_nodes) {
            if let Some((reference, steps)) = moving_ancestor(n).and_then(|a| node_steps.get(&a)) {
                cam.motion = Some(CameraMotion::new(times.clone(), steps, reference));
            }
        }
        // Moving meshes: their decomposed steps (none: the transform stays), their
        // deformation (its source vertex per mesh vertex), and the baking grid.
        type Moving<'s> = (&'s InstanceSpan, Mat4, Vec<Decomposed>, Option<(&'s Deformation, Vec<u32>)>);
        let mut moving: Vec<Moving> = Vec::new();
        for (s, &n) in spans.iter().zip(span_nodes) {
            let transform = moving_ancestor(n).and_then(|a| node_steps.get(&a));
            let deform = match node_deform.get(&n) {
                Some(d) => {
                    let v = s.vertices.start as usize..s.vertices.end as usize;
                    // Found by their positions before true displacement (`displace.rs`).
                    let frame: Vec<Vec3> = v.map(|k| super::displace::undisplaced_at(mesh, k)).collect();
                    match d.vertex_map(&s.world, &frame) {
                        Some(map) => Some((d, map)),
                        None => {
                            self.warn(format!(
                                "object '{}': its deformation positions do not match its mesh at the frame; deformation \
                                 motion blur is not rendered (it blurs by its transform only)",
                                s.name
                            ));
                            None
                        }
                    }
                }
                None => None,
            };
            if transform.is_none() && deform.is_none() {
                continue;
            }
            let (inv, decomposed) = match transform {
                Some((r, st)) => (r.inverse(), st.iter().map(Decomposed::new).collect()),
                None => (Mat4::IDENTITY, Vec::new()),
            };
            moving.push((s, inv, decomposed, deform));
        }
        let mut per_segment = vec![1usize; times.len() - 1];
        for (_, _, d, _) in moving.iter().filter(|m| !m.2.is_empty()) {
            for (i, sub) in per_segment.iter_mut().enumerate() {
                let need = (d[i].angle_to(&d[i + 1]) / MAX_STEP_ANGLE).ceil() as usize;
                *sub = (*sub).max(need);
            }
        }
        let mut grid = vec![times[0]];
        for (i, &sub) in per_segment.iter().enumerate() {
            for j in 1..=sub {
                grid.push(times[i] + (times[i + 1] - times[i]) * j as f32 / sub as f32);
            }
        }
        if grid.len() > MAX_STEPS {
            self.warn(format!(
                "CAUSTIC_motion: rotations need {} steps; {MAX_STEPS} are baked, so fast spins cut their arcs short",
                grid.len()
            ));
            grid = (0..MAX_STEPS)
                .map(|j| times[0] + (times[times.len() - 1] - times[0]) * j as f32 / (MAX_STEPS - 1) as f32)
                .collect();
        }
        let mut motion = SceneMotion {
            times: grid.clone(),
            shutter,
            slot: vec![crate::motion::STATIC; mesh.triangles.len()],
            ..Default::default()
        };
        for (span, reference_inv, decomposed, deform) in &moving {
            motion.objects.push(span.name.clone());
            // The motion from the frame to each baked time: D(t) = M(t) M(0)⁻¹ (identity for
            // a node that only deforms), and the step segment of each time.
            let deltas: Vec<(Mat4, Mat3, (usize, f32))> = grid
                .iter()
                .map(|&t| {
                    let seg = segment(&times, t);
                    let d = match decomposed.is_empty() {
                        true => Mat4::IDENTITY,
                        false => decomposed[seg.0].lerp(&decomposed[seg.0 + 1], seg.1).matrix() * *reference_inv,
                    };
                    (d, Mat3::from_mat4(d).inverse().transpose(), seg)
                })
                .collect();
            let v0 = span.vertices.start as usize;
            for tri in span.triangles.clone() {
                motion.slot[tri as usize] = motion.triangles.len() as u32;
                motion.triangles.push(tri);
                let v = mesh.triangles[tri as usize].map(|i| i as usize);
                let frame = v.map(|i| mesh.positions[i]);
                for (d, n, (i, f)) in &deltas {
                    // The deformed corners at the frame's transform, then the transform's motion.
                    let (at_frame, turn) = match deform {
                        Some((def, map)) => {
                            // Each step moves by the vertex's displacement too, as Cycles
                            // displaces every motion step by the frame's offset.
                            let c = v.map(|k| {
                                span.world.transform_point3(def.at(map[k - v0], *i, *f)) + mesh.positions[k]
                                    - super::displace::undisplaced_at(mesh, k)
                            });
                            (c, normal_turn(frame, c))
                        }
                        None => (frame, glam::Quat::IDENTITY),
                    };
                    motion.corners.push(at_frame.map(|p| d.transform_point3(p)));
                    // A zero normal (the geometric one) stays zero.
                    motion.normals.push(v.map(|k| (*n * (turn * mesh.normals[k])).normalize_or_zero()));
                }
            }
        }
        if motion.triangles.is_empty() && cameras.iter().all(|c| c.motion.is_none()) {
            return Ok(None);
        }
        Ok(Some(motion))
    }
}

impl Loader<'_> {
    /// Names what motion blur leaves sharp: moving emissive triangles, which next-event
    /// estimation samples where they are at the frame. (Moving punctual and area lights are
    /// placed where they are at the frame, which is what Cycles does: its lights have no
    /// motion, a moving light renders the same with motion blur on or off,
    /// tests/blender/test_moving_lights.py; so they are not named.)
    pub(super) fn motion_warnings(&mut self, motion: &SceneMotion, lights: &[crate::light::Light]) {
        let moving_emitters =
            lights.iter().any(|l| matches!(l, crate::light::Light::Triangle { tri } if motion.moving(*tri).is_some()));
        if moving_emitters {
            self.warn(format!(
                "emissive moving object(s) {}: seen blurred, but next-event estimation samples their light where it is at the frame",
                motion.objects.join(", ")
            ));
        }
    }
}
