"""Lights' node trees against Cycles (issue 19): a tree beyond an Emission node's two unlinked
numbers goes to the renderer as its graph (`CAUSTIC_lights_*.nodes`), folded into the light at
load when it is constant, else evaluated per emission as Cycles shades a light.

Scene and tolerance: test_cycles_agreement's (grey floor, lighter cube, camera looking down,
64x48, two seeds per renderer), each channel checked on its own (`per_channel`: a Blackbody
colour wrong in hue but right in brightness would pass the mean over channels) within 5 sigma
from 8x8 blocks + the 1 % model allowance, both derived there.

Cases:
* point_blackbody: Blackbody (3200 K) into the Emission Color of a point light (the pre-4.5 way
  to set a colour temperature): constant, folded into the light's colour.
* spot_math_strength: Value × Math (Multiply by 2.5) into a spot's Strength: constant, folded.
* point_light_falloff: Light Falloff's Linear output (strength 40) into a point light's
  Strength: Cycles multiplies by the distance to the receiver, so the light falls off as 1/d,
  evaluated per emission (a varying graph).
* area_linked_strength: an area light whose Strength is Light Falloff's Quadratic output with
  Smooth 2: strength × d² / (d² + 2) per emission.

Measured on bpy 5.0.1 (Caustic/Cycles, R G B; before = main's add-on and binary, which read
only an Emission node's unlinked values and named a linked socket in a warning):
* point_blackbody: before 0.595 1.155 3.068 (white light), now 0.9999 0.9999 0.9999;
* spot_math_strength: before 0.333 (the Strength's unlinked 1 instead of 3), now 0.9999;
* point_light_falloff: before 0.0001 (the exporter's intensity from the Falloff's Strength),
  now 0.9999;
* area_linked_strength: before 0.870, now 1.0000.
(`CAUSTIC_BINARY=... python -m pytest -q tests/blender/test_light_nodes.py -s`; the before
figures from a copy of main's blender_addon/ and tests/blender/ with this file added.)
"""

import pytest

import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, assert_mean_matches_cycles, build

pytestmark = pytest.mark.needs_binary


def _tree(light):
    """The light's node tree (switched on), its Emission and Light Output nodes."""
    light.use_nodes = True
    tree = light.node_tree
    emission = next(n for n in tree.nodes if n.type == "EMISSION")
    return tree, emission


def point_blackbody(scene):
    obj = scenes.light(scene, "Warm", "POINT", location=(0.6, -0.4, 3.0), energy=600.0)
    tree, emission = _tree(obj.data)
    bb = tree.nodes.new("ShaderNodeBlackbody")
    bb.inputs["Temperature"].default_value = 3200.0
    tree.links.new(bb.outputs["Color"], emission.inputs["Color"])


def spot_math_strength(scene):
    obj = scenes.light(scene, "Scaled", "SPOT", location=(0.5, -0.3, 3.0), rotation_deg=(6.0, 10.0, 0.0),
                       energy=300.0, spot_size=1.0, spot_blend=0.3)
    tree, emission = _tree(obj.data)
    value = tree.nodes.new("ShaderNodeValue")
    value.outputs[0].default_value = 1.2
    math_node = tree.nodes.new("ShaderNodeMath")
    math_node.operation = "MULTIPLY"
    math_node.inputs[1].default_value = 2.5
    tree.links.new(value.outputs[0], math_node.inputs[0])
    tree.links.new(math_node.outputs[0], emission.inputs["Strength"])


def point_light_falloff(scene):
    obj = scenes.light(scene, "Falloff", "POINT", location=(-0.4, 0.5, 2.5), energy=300.0)
    tree, emission = _tree(obj.data)
    falloff = tree.nodes.new("ShaderNodeLightFalloff")
    falloff.inputs["Strength"].default_value = 40.0
    tree.links.new(falloff.outputs["Linear"], emission.inputs["Strength"])


def area_linked_strength(scene):
    obj = scenes.light(scene, "Panel", "AREA", location=(0.2, 0.3, 3.0), energy=400.0, shape="RECTANGLE",
                       size=1.0, size_y=0.6)
    tree, emission = _tree(obj.data)
    falloff = tree.nodes.new("ShaderNodeLightFalloff")
    falloff.inputs["Strength"].default_value = 1.5
    falloff.inputs["Smooth"].default_value = 2.0
    tree.links.new(falloff.outputs["Quadratic"], emission.inputs["Strength"])


CASES = {
    "point_blackbody": point_blackbody,
    "spot_math_strength": spot_math_strength,
    "point_light_falloff": point_light_falloff,
    "area_linked_strength": area_linked_strength,
}


@pytest.mark.parametrize("case", list(CASES))
def test_light_node_tree_matches_cycles(empty_scene, tmp_path, case):
    scene = empty_scene
    build(scene, CASES[case])
    assert_mean_matches_cycles(scene, tmp_path, case, MODEL_ALLOWANCE, per_channel=True)
