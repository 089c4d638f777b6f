//! A light's node tree (`nodes` of `CAUSTIC_lights_area` / `CAUSTIC_lights_punctual`):
//! Blender's Light Output Surface compiled by the material compiler (`shader::compile`) and
//! evaluated as Cycles shades a light (`shader_setup_from_sample`): its emission closures'
//! colour × strength multiply the light's own emission.
//!
//! A graph that reads nothing of the shading point (Blackbody of a constant temperature,
//! Math, RGB, Mix of constants) is evaluated once at load and folded into the light
//! (`constant`), so the light's power for selection is the one Cycles renders. A graph that
//! reads the point (Light Falloff's ray length, a texture on the light's coordinates) is
//! kept and evaluated per emission evaluation (`LightGraphs::factor`).

use crate::light::Light;
use crate::math::Rgb;
use crate::scene::Scene;
use crate::scene::light_path::LightPath;
use crate::scene::texture::Texture;
use crate::shader::closure::Closures;
use crate::shader::geom::{Geom, NO_OBJECT, NO_VIEW, ObjectData};
use crate::shader::instructions::{Op, Program};
use crate::shader::program::with_registers;
use glam::{Mat4, Vec2, Vec3, Vec4};
use std::sync::Arc;

/// Where Cycles shades a light: the point on it, its normal and the direction toward the
/// receiver (all world glTF axes), the distance to the receiver (Light Falloff's ray length)
/// and the light's parametric coordinates.
#[derive(Clone, Copy, Debug)]
pub struct LightPoint {
    /// The point on the light (a point or spot light's position; for a sun, the direction
    /// toward it, as Cycles' `ls->P`).
    pub p: Vec3,
    /// The light's normal there (Cycles' `ls->Ng`: for a point, spot or sun, toward the
    /// receiver).
    pub n: Vec3,
    /// Unit direction from the light toward the receiver (Cycles' Incoming = −D).
    pub to_receiver: Vec3,
    /// Distance from the receiver to the light point (infinite for a sun).
    pub dist: f32,
    /// The light's parametric coordinates (Cycles' `ls->u`, `ls->v`).
    pub uv: Vec2,
}

/// A compiled light graph that varies over the light, with its light object's frame.
#[derive(Clone, Debug)]
pub struct LightGraph {
    /// The light's name (warnings).
    name: Arc<str>,
    program: Arc<Program>,
    /// The graph's images.
    textures: Arc<Vec<Texture>>,
    /// The light object as Object coordinates and Object Info see it (shared: the graph is
    /// kept small, as lights are loaded by value).
    object: Arc<ObjectData>,
}

impl LightGraph {
    /// Light `name`'s graph, its images and the light object's world matrix (glTF axes).
    pub fn new(name: &str, program: Program, textures: Vec<Texture>, world: Mat4) -> LightGraph {
        // The light node's local frame is the Blender light's own (the exporter's light
        // correction and its Y-up swap cancel), while the graph turns object-space vectors
        // from glTF to Blender axes: the frame is given in glTF axes so that Object and
        // Normal coordinates come out in the light's Blender frame (−Z its direction).
        let blender_to_gltf = Mat4::from_cols(Vec4::X, -Vec4::Z, Vec4::Y, Vec4::W);
        let object = Arc::new(ObjectData {
            world_to_object: blender_to_gltf * world.inverse(),
            location: world.transform_point3(Vec3::ZERO),
            ..NO_OBJECT
        });
        LightGraph { name: name.into(), program: Arc::new(program), textures: Arc::new(textures), object }
    }

    /// The light's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// True when the graph reads the ray's length (Light Falloff, Light Path's Ray Length),
    /// which a photon leaving the light does not know.
    pub fn reads_ray_length(&self) -> bool {
        use crate::scene::light_path::PathOutput;
        use crate::shader::instructions::InputKind;
        self.program
            .ops
            .iter()
            .any(|op| matches!(op, Op::Input { what: InputKind::LightPath(PathOutput::RayLength), .. }))
    }

    /// The compiled program.
    pub fn program(&self) -> &Program {
        &self.program
    }

    /// True when the program reads nothing of the shading point: its value is the same for
    /// every evaluation ([`constant`](Self::constant)).
    pub fn is_constant(&self) -> bool {
        !self.program.ops.iter().any(|op| matches!(op, Op::Input { .. }))
    }

    /// The graph's emission at `at` for a ray of path state `path` (Light Path's outputs;
    /// its ray length is the distance to the receiver). A negative value subtracts light, as
    /// Cycles' `emission_setup` keeps the sign (and as a light of negative power does);
    /// non-finite values give 0.
    pub fn emission(&self, at: &LightPoint, path: LightPath) -> Rgb {
        let g = Geom {
            p: at.p,
            n: at.n,
            ng: at.n,
            wo: at.to_receiver,
            uv: [at.uv; 2],
            color: Vec4::ONE,
            tangent: Vec4::ZERO,
            backfacing: false,
            object: &self.object,
            textures: &self.textures,
            mesh: &crate::scene::mesh::EMPTY_MESH,
            tri: u32::MAX,
            bary: at.uv,
            path: path.at(at.dist),
            view: &NO_VIEW,
            rays: crate::shader::geom::Rays::default(),
            point: None,
            curve: None,
            grid_values: None,
        };
        let mut out = Closures::default();
        with_registers(|regs| self.program.run(&g, regs, &mut out));
        let e = out.emission;
        if e.is_finite() { e } else { Vec3::ZERO }
    }

    /// The factor that scales the light's power for light selection: the graph's luminance
    /// toward a receiver at a quarter of the scene's radius along the light's axis (its
    /// emitting normal, a spot's or sun's direction, else down), by size (a light is picked
    /// by |power|, as Cycles' light tree), at least 1e-3 so that no light that emits
    /// elsewhere is never chosen.
    pub fn selection_factor(&self, light: &Light, scene_radius: f32) -> f32 {
        let (q, axis) = match light {
            Light::Point { position, .. } => (*position, -Vec3::Y),
            Light::Spot { position, direction, .. } => (*position, *direction),
            Light::Sphere { center, spot, .. } => (*center, spot.map_or(-Vec3::Y, |s| s.direction)),
            Light::Area(a) => (a.center, a.normal),
            Light::Directional { direction, .. } => (Vec3::ZERO, *direction),
            Light::Triangle { .. } | Light::World => return 1.0,
        };
        let receiver = q + axis * (0.25 * scene_radius);
        let n = if let Light::Area(a) = light { a.normal } else { Vec3::ZERO };
        let at = light_point(light, q, n, receiver);
        crate::math::luminance(self.emission(&at, LightPath::LIGHT_EMISSION)).abs().max(1e-3)
    }

    /// The graph's value when it is constant, None when it varies.
    pub fn constant(&self) -> Option<Rgb> {
        self.is_constant().then(|| {
            let at = LightPoint { p: Vec3::ZERO, n: Vec3::Y, to_receiver: Vec3::Y, dist: 1.0, uv: Vec2::ZERO };
            self.emission(&at, LightPath::LIGHT_EMISSION)
        })
    }
}

/// Cycles' shading point of `light` at its point `q` seen from `receiver`
/// (`shader_setup_from_sample`): for a point or spot light (and a soft-falloff disk) the
/// normal is the direction toward the receiver (Cycles sets it so for texturing), for a
/// sphere the sphere's normal, for an area light its emitting normal; a sun's point and
/// normal are the direction toward it, its distance infinite (`FLT_MAX` in Cycles).
/// `n_light`: the light's normal at `q` where it has one, else zero.
pub fn light_point(light: &Light, q: Vec3, n_light: Vec3, receiver: Vec3) -> LightPoint {
    let (to_receiver, dist) = match light {
        Light::Directional { direction, .. } => (*direction, f32::MAX),
        _ => {
            let d = receiver - q;
            let len = d.length();
            (if len > 0.0 { d / len } else { n_light }, len)
        }
    };
    let (p, n) = match light {
        Light::Directional { .. } => (-to_receiver, -to_receiver),
        Light::Sphere { center, radius, soft: false, .. } => (q, ((q - *center) / *radius).normalize_or(to_receiver)),
        Light::Area(a) => (q, a.normal),
        _ => (q, to_receiver),
    };
    LightPoint { p, n, to_receiver, dist, uv: Vec2::ZERO }
}

/// The factor by which light `index`'s varying node tree multiplies its emission at its
/// point `q` (normal `n_light`, zero where it has none) toward `receiver`, for a ray of
/// path state `path`; 1 for a light without one.
#[inline]
pub fn graph_factor(scene: &Scene, index: usize, q: Vec3, n_light: Vec3, receiver: Vec3, path: LightPath) -> Rgb {
    match scene.light_graphs.get(index) {
        Some(Some(g)) => g.emission(&light_point(&scene.lights[index], q, n_light, receiver), path),
        _ => Rgb::ONE,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader::compile::compile;
    use crate::shader::graph::NodesExt;
    use serde_json::json;

    fn graph(nodes: serde_json::Value, surface: serde_json::Value) -> LightGraph {
        let ext: NodesExt =
            serde_json::from_value(json!({"version": 1, "nodes": nodes, "output": {"surface": surface}})).unwrap();
        let c = compile("light", &ext, &[]).unwrap();
        assert!(c.warnings.is_empty(), "{:?}", c.warnings);
        LightGraph::new("test", c.program, Vec::new(), Mat4::IDENTITY)
    }

    /// Blackbody of a constant temperature into the Emission's Color, strength scaled by a
    /// Math node: constant, and equal to the Blackbody's colour × the product.
    #[test]
    fn constant_blackbody_folds_to_the_nodes_colour() {
        let g = graph(
            json!([
                {"name": "Blackbody", "type": "ShaderNodeBlackbody", "inputs": {"Temperature": {"value": 3000.0}}},
                {"name": "Math", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
                 "inputs": {"Value": {"value": 2.0}, "Value_001": {"value": 1.5}}},
                {"name": "Emission", "type": "ShaderNodeEmission",
                 "inputs": {"Color": {"link": [0, "Color"]}, "Strength": {"link": [1, "Value"]}}}
            ]),
            json!([2, "Emission"]),
        );
        let c = g.constant().expect("a constant graph");
        // The Blackbody node's colour (its own tests hold it to Cycles' fit).
        let bb = crate::medium::blackbody::blackbody_rgb(3000.0);
        assert!((c - bb * 3.0).abs().max_element() < 1e-5, "{c} vs {}", bb * 3.0);
        assert!(bb.x > bb.y && bb.y > bb.z, "3000 K is reddish: {bb}");
    }

    /// A negative strength keeps its sign, constant or varying (Cycles' `emission_setup`
    /// does not clamp), and light selection weighs it by size.
    #[test]
    fn a_negative_strength_subtracts_light() {
        let constant = graph(
            json!([
                {"name": "Math", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
                 "inputs": {"Value": {"value": -2.0}, "Value_001": {"value": 1.5}}},
                {"name": "Emission", "type": "ShaderNodeEmission",
                 "inputs": {"Color": {"value": [1.0, 0.5, 0.25, 1.0]}, "Strength": {"link": [0, "Value"]}}}
            ]),
            json!([1, "Emission"]),
        );
        let c = constant.constant().expect("a constant graph");
        assert!((c - Vec3::new(-3.0, -1.5, -0.75)).abs().max_element() < 1e-6, "{c}");
        let varying = graph(
            json!([
                {"name": "Falloff", "type": "ShaderNodeLightFalloff",
                 "inputs": {"Strength": {"value": -4.0}, "Smooth": {"value": 0.0}}},
                {"name": "Emission", "type": "ShaderNodeEmission",
                 "inputs": {"Color": {"value": [1.0, 1.0, 1.0, 1.0]}, "Strength": {"link": [0, "Quadratic"]}}}
            ]),
            json!([1, "Emission"]),
        );
        let at = LightPoint { p: Vec3::ZERO, n: Vec3::X, to_receiver: Vec3::X, dist: 2.0, uv: Vec2::ZERO };
        assert_eq!(varying.emission(&at, LightPath::LIGHT_EMISSION), Vec3::splat(-4.0));
        let light = Light::Point { position: Vec3::ZERO, intensity: Vec3::ONE };
        assert!((varying.selection_factor(&light, 1.0) - 4.0).abs() < 1e-5);
    }

    /// Light Falloff reads the ray length: the graph varies, and its Linear output is the
    /// strength times the distance, its Constant output times the distance squared.
    #[test]
    fn light_falloff_varies_with_the_distance() {
        for (output, power) in [("Linear", 1), ("Constant", 2), ("Quadratic", 0)] {
            let g = graph(
                json!([
                    {"name": "Falloff", "type": "ShaderNodeLightFalloff",
                     "inputs": {"Strength": {"value": 5.0}, "Smooth": {"value": 0.0}}},
                    {"name": "Emission", "type": "ShaderNodeEmission",
                     "inputs": {"Color": {"value": [1.0, 1.0, 1.0, 1.0]}, "Strength": {"link": [0, output]}}}
                ]),
                json!([1, "Emission"]),
            );
            assert!(g.constant().is_none(), "{output}");
            for d in [0.5f32, 2.0, 3.0] {
                let at = LightPoint { p: Vec3::ZERO, n: Vec3::X, to_receiver: Vec3::X, dist: d, uv: Vec2::ZERO };
                let e = g.emission(&at, LightPath::LIGHT_EMISSION);
                let want = 5.0 * d.powi(power);
                assert!((e.x - want).abs() <= 1e-5 * want, "{output} at {d}: {e} vs {want}");
            }
        }
    }
}
