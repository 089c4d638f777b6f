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
* point_ies_internal: an IES Texture (a small asymmetric type C profile in a text datablock)
  into a point light's Strength, the light turned 30° about Z (the profile's horizontal angle is
  read in the light's frame);
* spot_ies_external: the same profile from a file, Strength 1.3, on a tilted spot.
* sphere_ies: the profile on a point light of radius 0.3 with Soft Falloff off (a sphere light,
  whose surface normal differs from the direction to the lit point that the IES node reads).

Measured on bpy 5.0.1 (Caustic/Cycles, R G B; before = main's add-on and binary, which read
only an Emission node's unlinked values and named a linked socket in a warning):
* point_blackbody: before 0.595 1.155 3.068 (white light), now 0.9999 0.9999 0.9999;
* spot_math_strength: before 0.333 (the Strength's unlinked 1 instead of 3), now 0.9999;
* point_light_falloff: before 0.0001 (the exporter's intensity from the Falloff's Strength),
  now 0.9999;
* area_linked_strength: before 0.870, now 1.0000;
* point_ies_internal: before 0.0277 (the Strength's unlinked 1 instead of the profile's ~70:
  main named the link in a warning), then 1.0214 (the lookup past the grid's ends as Cycles'
  source reads, not as Blender 5.0 renders: `shader::ies` tests), now 0.9999;
* spot_ies_external: before 0.0180, then 1.0340, now 1.0000;
* sphere_ies: before 0.6764 (the sphere's normal as the IES vector; Cycles reads the incoming
  direction in the light's frame), now 0.9997.
(`CAUSTIC_BINARY=... python -m pytest -q tests/blender/test_light_nodes.py -s`; the before
figures from a copy of main's blender_addon/ and tests/blender/ with this file added.)

Trees with nothing on their output (found on the glTF-Blender-IO test scenes, whose lights'
node group is linked from a library file that is not there), each beside a plain Fill light:
* point_unlinked_surface, area_unlinked_surface: a light whose Emission is not linked to the
  Light Output: Cycles renders no light from it; before 3.151 and 8.993 (Caustic lit it with
  its own power, warned), now 1.0000;
* spot_hollow_group: the Light Output's Surface from a node group without a Group Output:
  before, Blender's glTF exporter failed (IndexError) and nothing rendered; now 1.0000;
* material_unlinked_surface: the box's Material Output with nothing on Surface (Cycles: black):
  before 1.932 (the exporter wrote the unlinked Principled BSDF it found), now 1.0000;
* material_hollow_group: the box's Surface from such a group: before the exporter failed,
  now 1.0000.
"""

import os
import tempfile

import bpy
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


# A small type C profile (LM-63-2002), asymmetric in the horizontal angle so that its
# orientation in the light's frame matters: vertical angles 0-90 (nothing upwards), horizontal
# 0, 90, 180, 270 and 360 (= 0), in candela.
IES_PROFILE = """IESNA:LM-63-2002
[TEST] Caustic light-node test profile
TILT=NONE
1 1000 1 5 5 1 2 0 0 0
1 1 100
0 22.5 45 67.5 90
0 90 180 270 360
1000 900 600 250 0
600 500 300 100 0
300 280 200 80 0
600 500 300 100 0
1000 900 600 250 0
"""


def _ies_tree(obj):
    """IES Texture's Fac into the Emission Strength of `obj`'s light; returns the IES node."""
    tree, emission = _tree(obj.data)
    ies = tree.nodes.new("ShaderNodeTexIES")
    tree.links.new(ies.outputs["Fac"], emission.inputs["Strength"])
    return ies


def point_ies_internal(scene):
    obj = scenes.light(scene, "Downlight", "POINT", location=(0.2, -0.3, 2.6), rotation_deg=(0.0, 0.0, 30.0),
                       energy=8.0)
    ies = _ies_tree(obj)
    text = bpy.data.texts.new("profile.ies")
    text.write(IES_PROFILE)
    ies.mode = "INTERNAL"
    ies.ies = text


def sphere_ies(scene):
    obj = scenes.light(scene, "Globe", "POINT", location=(0.3, -0.2, 2.8), rotation_deg=(0.0, 0.0, 30.0),
                       energy=8.0, shadow_soft_size=0.3, use_soft_falloff=False)
    ies = _ies_tree(obj)
    text = bpy.data.texts.new("globe.ies")
    text.write(IES_PROFILE)
    ies.mode = "INTERNAL"
    ies.ies = text


def spot_ies_external(scene):
    obj = scenes.light(scene, "Wallwasher", "SPOT", location=(-0.3, 0.2, 2.8), rotation_deg=(12.0, 0.0, -20.0),
                       energy=10.0, spot_size=1.8, spot_blend=0.2)
    ies = _ies_tree(obj)
    path = os.path.join(tempfile.mkdtemp(prefix="caustic-ies-"), "wallwasher.ies")
    with open(path, "w") as f:
        f.write(IES_PROFILE)
    ies.mode = "EXTERNAL"
    ies.filepath = path
    ies.inputs["Strength"].default_value = 1.3


def _fill(scene):
    """A plain point light, so that a scene whose other light is dark is lit."""
    scenes.light(scene, "Fill", "POINT", location=(-0.5, 0.4, 3.0), energy=300.0)


def point_unlinked_surface(scene):
    _fill(scene)
    obj = scenes.light(scene, "Unlinked", "POINT", location=(0.6, -0.4, 3.0), energy=600.0)
    tree, emission = _tree(obj.data)
    for link in list(emission.outputs["Emission"].links):
        tree.links.remove(link)


def area_unlinked_surface(scene):
    _fill(scene)
    obj = scenes.light(scene, "Unlinked", "AREA", location=(0.2, 0.3, 3.0), energy=600.0, size=0.8)
    tree, emission = _tree(obj.data)
    for link in list(emission.outputs["Emission"].links):
        tree.links.remove(link)


def _hollow_group():
    """A shader node group with an Emission output and no Group Output node (what a group linked
    from a missing library file reads as)."""
    group = bpy.data.node_groups.new("Hollow", "ShaderNodeTree")
    group.interface.new_socket("Emission", in_out="OUTPUT", socket_type="NodeSocketShader")
    return group


def spot_hollow_group(scene):
    _fill(scene)
    obj = scenes.light(scene, "Hollow", "SPOT", location=(0.5, -0.3, 3.0), rotation_deg=(6.0, 10.0, 0.0),
                       energy=600.0, spot_size=1.0)
    tree, emission = _tree(obj.data)
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = _hollow_group()
    output = next(n for n in tree.nodes if n.type == "OUTPUT_LIGHT")
    tree.links.new(node.outputs["Emission"], output.inputs["Surface"])


def material_hollow_group(scene):
    _fill(scene)
    tree = bpy.data.materials["Light"].node_tree
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = _hollow_group()
    output = next(n for n in tree.nodes if n.type == "OUTPUT_MATERIAL")
    tree.links.new(node.outputs["Emission"], output.inputs["Surface"])


def material_unlinked_surface(scene):
    _fill(scene)
    tree = bpy.data.materials["Light"].node_tree
    output = next(n for n in tree.nodes if n.type == "OUTPUT_MATERIAL")
    for link in list(output.inputs["Surface"].links):
        tree.links.remove(link)


CASES = {
    "point_blackbody": point_blackbody,
    "spot_math_strength": spot_math_strength,
    "point_light_falloff": point_light_falloff,
    "area_linked_strength": area_linked_strength,
    "point_ies_internal": point_ies_internal,
    "spot_ies_external": spot_ies_external,
    "sphere_ies": sphere_ies,
    "point_unlinked_surface": point_unlinked_surface,
    "area_unlinked_surface": area_unlinked_surface,
    "spot_hollow_group": spot_hollow_group,
    "material_hollow_group": material_hollow_group,
    "material_unlinked_surface": material_unlinked_surface,
}
PARAMS = [pytest.param(name, add, id=name) for name, add in CASES.items()]


@pytest.mark.parametrize("case,add", PARAMS)
def test_light_node_tree_matches_cycles(empty_scene, tmp_path, case, add):
    scene = empty_scene
    build(scene, add)
    assert_mean_matches_cycles(scene, tmp_path, case, MODEL_ALLOWANCE, per_channel=True)


def test_ies_texture_in_a_material_matches_cycles(empty_scene, tmp_path):
    """An IES Texture in a material (its Fac into an Emission's Strength on the box, turned so
    the profile's asymmetry shows): the profile goes beside the glTF as a light's does, and
    the node reads the incoming direction in the box's frame. Before: the profile was not
    exported and the box glowed 100 x Strength (warned): 2.547x Cycles' mean; now 0.9999."""
    def add(scene):
        scenes.light(scene, "Sun", "SUN", rotation_deg=(20.0, 10.0, 0.0), energy=2.0)
        box = bpy.data.objects["Box"]
        box.rotation_euler = (0.3, 0.2, 0.7)
        mat = scenes.shader_node_material("Beacon", "ShaderNodeEmission")
        tree = mat.node_tree
        emission = next(n for n in tree.nodes if n.type == "EMISSION")
        ies = tree.nodes.new("ShaderNodeTexIES")
        text = bpy.data.texts.new("beacon.ies")
        text.write(IES_PROFILE)
        ies.mode = "INTERNAL"
        ies.ies = text
        ies.inputs["Strength"].default_value = 0.02
        tree.links.new(ies.outputs["Fac"], emission.inputs["Strength"])
        box.data.materials.clear()
        box.data.materials.append(mat)

    build(empty_scene, add)
    assert_mean_matches_cycles(empty_scene, tmp_path, "material_ies", MODEL_ALLOWANCE, per_channel=True)
