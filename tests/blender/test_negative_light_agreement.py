"""Lights of negative power against Cycles. Blender lets a light's Power (or its Emission node's
Strength) be negative; Cycles renders such a light subtracting its light (measured with Cycles in
Blender 5.0.1: a negative point, spot, sun or area light alone renders exactly the negated image
of the positive one, light tree on or off), and its light tree picks it by |energy|
(`LightTreeEmitter`: "use absolute value of energy so lights with negative strength are properly
supported"). Caustic used to refuse the whole scene ("intensity and color must be finite and
non-negative"); now the add-on carries the sign (an area light's `power`, a punctual light's
`negative` in `CAUSTIC_lights_punctual`, since KHR_lights_punctual's intensity must not be
negative) and every integrator renders it as the path tracer does (`tests/negative_lights.rs`).

The scene: a grey floor and back wall lit by a positive 300 W disk light and a weaker negative
light of each kind (a -40 W point of radius 0.25, a -60 W spot, a -0.4 W/m² sun, a -60 W area light) that
darkens part of it. Bounds: test_nodes_agreement.py's `compare` (image mean per channel within
5 sigma + 1 %, 4x4 blocks within 5 sigma + 2 %, sigma from two seeds per engine; derived there).
The path tracer renders every kind; BDPT, VCM and Jensen's photon mapping the point light.
`point_graph`: a positive light made negative by its node tree's Strength (Light Falloff, kept as
a per-point graph), which Caustic clamped at 0 before (rendered as no light).
"""

import importlib
import json

import bpy
import pytest

import scenes
from test_nodes_agreement import BOUNCES, SAMPLES, W, H, compare

NEGATIVE = {
    "point": dict(kind="POINT", location=(0.7, 0.3, 1.2), energy=-40.0),
    "spot": dict(kind="SPOT", location=(0.6, 0.0, 1.5), energy=-60.0, spot_size=0.9),
    "sun": dict(kind="SUN", rotation_deg=(25.0, 10.0, 0.0), energy=-0.4, angle=0.1),
    "area": dict(kind="AREA", location=(0.7, 0.2, 1.0), energy=-60.0, size=0.4),
}


def floor_scene(scene, negative):
    """The grey floor and a back wall (which the floor's light reaches by a bounce, so photons
    matter) seen from above, the positive disk light, and the negative light `negative`."""
    grey = scenes.diffuse_material("Grey", 0.5)
    scenes.plane(scene, "Floor", 10.0, material=grey)
    scenes.mesh_object(scene, "Wall", [(-5, 1.5, 0), (5, 1.5, 0), (5, 1.5, 4), (-5, 1.5, 4)], [(0, 1, 2, 3)], grey)
    scenes.light(scene, "Key", "AREA", location=(-0.8, 0.0, 3.0), shape="DISK", size=1.0, energy=300.0)
    if negative == "point_graph":
        # A positive point light whose node tree makes it negative where Caustic evaluates the
        # tree per shading point (Light Falloff reads the ray length, so nothing folds it into
        # the power): Quadratic of Strength -1 is -1 at every distance (Smooth 0), so it
        # renders as the -40 W point light. Cycles keeps the emission's sign (emission_setup).
        obj = scenes.light(scene, "Minus", "POINT", location=(0.7, 0.3, 1.2), energy=40.0)
        obj.data.use_nodes = True
        tree = obj.data.node_tree
        emission = next(n for n in tree.nodes if n.type == "EMISSION")
        falloff = tree.nodes.new("ShaderNodeLightFalloff")
        falloff.inputs["Strength"].default_value = -1.0
        falloff.inputs["Smooth"].default_value = 0.0
        tree.links.new(falloff.outputs["Quadratic"], emission.inputs["Strength"])
    else:
        props = dict(NEGATIVE[negative])
        kind = props.pop("kind")
        scenes.light(scene, "Minus", kind, **props)
    scenes.camera(scene, (0.0, -2.5, 4.0), (32.0, 0.0, 0.0), lens=35.0)


@pytest.mark.needs_binary
@pytest.mark.parametrize("negative,integrator", [(k, "path") for k in NEGATIVE]
                         + [("point", i) for i in ("bdpt", "vcm", "photon")]
                         + [("point_graph", i) for i in ("path", "bdpt")])
def test_negative_light_matches_cycles(empty_scene, tmp_path, negative, integrator):
    floor_scene(empty_scene, negative)
    scenes.small_render_settings(empty_scene, W, H, samples=SAMPLES)
    empty_scene.caustic.threads = 0
    empty_scene.caustic.integrator = integrator
    scenes.match_cycles(empty_scene, SAMPLES, BOUNCES)
    compare(empty_scene, tmp_path, f"negative {negative} ({integrator})")


def test_export_carries_the_sign_in_valid_gltf(empty_scene, addon, tmp_path):
    """KHR_lights_punctual's intensity is the size of a negative power (glTF forbids a negative
    one) with `negative` beside it; a light data shared by two objects is negated once and both
    nodes say `negative`; an area light's power keeps its sign; a positive light says nothing."""
    scene = empty_scene
    scenes.small_render_settings(scene, 8, 6, samples=1)
    scenes.camera(scene, (0, -4, 3), (60, 0, 0))
    point = scenes.light(scene, "Minus", "POINT", energy=-50.0)
    twin = bpy.data.objects.new("Twin", point.data)
    scene.collection.objects.link(twin)
    scenes.light(scene, "Dusk", "SUN", energy=-2.0)
    scenes.light(scene, "Plus", "POINT", energy=50.0)
    scenes.light(scene, "Shade", "AREA", energy=-30.0)
    export = importlib.import_module(addon.__name__ + ".export")
    settings = export.render_settings(scene, (8, 6), "Camera")
    path, _ = export.export_scene(bpy.context.evaluated_depsgraph_get(), str(tmp_path), settings)
    with open(path) as f:
        gltf = json.load(f)
    lights = gltf["extensions"]["KHR_lights_punctual"]["lights"]
    nodes = {n["name"]: n.get("extensions", {}) for n in gltf["nodes"]}
    assert all(light["intensity"] > 0.0 for light in lights), lights
    for name in ("Minus", "Twin", "Dusk"):
        assert nodes[name]["CAUSTIC_lights_punctual"]["negative"] is True, nodes[name]
    assert "negative" not in nodes["Plus"].get("CAUSTIC_lights_punctual", {}), nodes["Plus"]
    minus = lights[nodes["Minus"]["KHR_lights_punctual"]["light"]]["intensity"]
    plus = lights[nodes["Plus"]["KHR_lights_punctual"]["light"]]["intensity"]
    assert minus == pytest.approx(plus), (minus, plus)
    assert nodes["Shade"]["CAUSTIC_lights_area"]["power"] == pytest.approx(-30.0)
