//! The Ray Visibility cases shared by `tests/photon_visibility.rs` and
//! `tests/bidirectional_visibility.rs`: a grey floor, a back wall and a grey quad hanging
//! over the floor ("Blocker"), seen from the front, lit by a point light above the blocker
//! (a delta light: the path tracer takes it by next-event estimation alone, weight 1, so
//! its image is the reference without MIS shares in the way). Each case sets one rule.

use super::GltfBuilder;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// One case of the scene: the light's punctual extension, the blocker's visibility and the
/// world's.
pub struct Case {
    /// What the case is called in messages.
    pub name: &'static str,
    /// The point light's `CAUSTIC_lights_punctual` (empty: none).
    pub light: Value,
    /// The blocker's `CAUSTIC_object_visibility` (empty: none).
    pub blocker: Value,
    /// The world's `visibility`: `Some` adds a grey world (and makes the floor and wall a
    /// rough metal, so that glossy rays carry most of its light); `None`: no world.
    pub world: Option<Value>,
    /// A square area light (0.6 wide, facing down) in the point light's place.
    pub area: bool,
}

impl Case {
    /// The same scene without the case's rule (the world kept, seen by every ray).
    pub fn without_rule(&self) -> Case {
        Case {
            name: self.name,
            light: json!({}),
            blocker: json!({}),
            world: self.world.as_ref().map(|_| json!({})),
            area: self.area,
        }
    }
}

/// The cases of the light's Cast Shadow and the objects' and light's Ray Visibility.
pub fn cases() -> Vec<Case> {
    vec![
        Case {
            name: "cast shadow off",
            light: json!({"cast_shadow": false}),
            blocker: json!({}),
            world: None,
            area: false,
        },
        Case {
            name: "blocker hidden from diffuse rays",
            light: json!({}),
            blocker: json!({"diffuse": false}),
            world: None,
            area: false,
        },
        Case {
            name: "blocker seen by shadow rays only",
            light: json!({}),
            blocker: json!({"camera": false, "diffuse": false, "glossy": false, "transmission": false}),
            world: None,
            area: false,
        },
        Case {
            name: "light hidden from diffuse rays",
            light: json!({"diffuse_visible": false}),
            blocker: json!({}),
            world: None,
            area: false,
        },
    ]
}

/// A case of the world's Ray Visibility: hidden from glossy rays over rough metal.
pub fn world_hidden_from_glossy() -> Case {
    Case {
        name: "world hidden from glossy rays",
        light: json!({}),
        blocker: json!({}),
        world: Some(json!({"glossy": false})),
        area: false,
    }
}

/// The blocker hidden from transmission rays under an area light: no material here
/// transmits, so the rule changes nothing in expectation, but every path that meets the
/// blocker is a restricted one (`bdpt::visibility`), weighed by s = 0 against s = 1 alone.
pub fn blocker_hidden_from_transmission_under_an_area_light() -> Case {
    Case {
        name: "blocker hidden from transmission rays, area light",
        light: json!({}),
        blocker: json!({"transmission": false}),
        world: None,
        area: true,
    }
}

/// An area light (in the point light's place) hidden from diffuse rays: it lights the
/// glossy layer alone, found by BSDF sampling and light sampling both.
pub fn area_light_hidden_from_diffuse() -> Case {
    Case {
        name: "area light hidden from diffuse rays",
        light: json!({"diffuse_visible": false}),
        blocker: json!({}),
        world: None,
        area: true,
    }
}

/// The scene (module doc) of `case`, written to `dir/file`.
pub fn scene(dir: &Path, file: &str, case: &Case) -> PathBuf {
    let mut g = GltfBuilder::new();
    let grey = g
        .material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1], "metallicFactor": 0.0},
            "doubleSided": true}));
    let room = match case.world {
        Some(_) => g.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1],
            "metallicFactor": 1.0, "roughnessFactor": 0.3}, "doubleSided": true})),
        None => grey,
    };
    let quad = |g: &mut GltfBuilder, p: [[f32; 3]; 4], m: usize| g.mesh(&p, &[0, 1, 2, 0, 2, 3], m);
    let floor = quad(&mut g, [[-2.0, -1.0, -2.0], [2.0, -1.0, -2.0], [2.0, -1.0, -6.0], [-2.0, -1.0, -6.0]], room);
    let wall = quad(&mut g, [[-2.0, -1.0, -6.0], [2.0, -1.0, -6.0], [2.0, 2.0, -6.0], [-2.0, 2.0, -6.0]], room);
    let blocker = quad(&mut g, [[-1.2, 0.3, -3.5], [0.2, 0.3, -3.5], [0.2, 0.3, -4.5], [-1.2, 0.3, -4.5]], grey);
    g.node_name(floor, "Floor");
    g.node_name(wall, "Wall");
    g.node_name(blocker, "Blocker");
    if case.blocker.as_object().is_some_and(|o| !o.is_empty()) {
        g.node_ext(blocker, "CAUSTIC_object_visibility", case.blocker.clone());
    }
    let point = json!({"type": "point", "intensity": 4000.0});
    let at = ([-0.5, 1.5, -4.0], [0.0, 0.0, 0.0, 1.0]);
    if case.area {
        g.use_ext("CAUSTIC_lights_area");
        // Facing down: -Z turned by -90° about X.
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let mut area = json!({"shape": "square", "size": [0.6, 0.6], "power": 300.0});
        for (k, v) in case.light.as_object().into_iter().flatten() {
            area[k] = v.clone();
        }
        g.node(json!({"translation": at.0, "rotation": [-h, 0.0, 0.0, h],
            "extensions": {"CAUSTIC_lights_area": area}}));
    } else if case.light.as_object().is_some_and(|o| !o.is_empty()) {
        g.use_ext("CAUSTIC_lights_punctual");
        g.punctual_with(point, at.0, at.1, json!({"CAUSTIC_lights_punctual": case.light}));
    } else {
        g.punctual(point, at.0, at.1);
    }
    if let Some(v) = &case.world {
        let mut w = json!({"color": [0.4, 0.4, 0.4], "strength": 1.0});
        if v.as_object().is_some_and(|o| !o.is_empty()) {
            w["visibility"] = v.clone();
        }
        g.world(w);
    }
    g.camera([0.0, 0.3, 0.0], [0.0, 0.0, 0.0, 1.0], 0.9);
    g.write(dir, file)
}
