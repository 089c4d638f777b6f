"""A Principled BSDF's tangent-space Normal Map node with a Strength below 1, rendered by Cycles
and by Caustic through the add-on (sweep 6).

Blender's glTF exporter writes the Strength as the normal texture's `scale`. glTF applies a
scale s as (s·x, s·y, z); Cycles' Normal Map node applies Strength as (s·x, s·y, mix(1, z, s))
for s in [0, 1] (`svm_node_normal_map`), so a weak map is flatter in Cycles than the glTF
reading of the same number. The add-on now marks such materials `CAUSTIC_materials_normal_map`
{"mapping": "blender"} and the renderer applies Cycles' rule.

Scene: test_cycles_agreement's floor and cube, the Lambertian floor normal mapped with steep
sine ridges (tilts up to ~70 degrees, where the two rules differ most) at Strength 0.4, lit by
a low sun across the ridges; the camera looks down at it. Measured (bpy 5.0.1, 64x48, 128 spp)
with the add-on's marking left out (glTF's rule): R/G/B 0.9417 (sigma 2e-4 of the mean); with
Cycles' rule: 1.0002. The sweep's Khronos-style sphere (gentler map, Strength 0.5) was
0.9929 with 21 of 192 4x4 blocks beyond 5 sigma, now 1.0002 with 3.

Tolerance: test_cycles_agreement's (5 sigma of the two-seed block-variance estimate plus its 1 %
model allowance, derived there), per channel.
"""

import math

import bpy
import numpy as np
import pytest

import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, assert_mean_matches_cycles, build

pytestmark = pytest.mark.needs_binary

STRENGTH = 0.4


def steep_normal_map(name, n=32):
    """A tangent-space normal map of sine ridges along U whose tilt reaches ~70 degrees (8-bit,
    Non-Color, packed)."""
    image = bpy.data.images.new(name, n, n)
    x = (np.arange(n) + 0.5) / n
    nx = 2.7 * np.sin(2.0 * math.pi * 3.0 * x)  # slope of the ridges
    length = np.sqrt(nx * nx + 1.0)
    row = np.stack([0.5 + 0.5 * nx / length, np.full(n, 0.5), 0.5 + 0.5 / length, np.ones(n)], axis=1)
    pixels = np.broadcast_to(row, (n, n, 4)).astype(np.float32)
    image.pixels.foreach_set(pixels.ravel())
    image.colorspace_settings.name = "Non-Color"
    image.pack()
    return image


def normal_mapped_floor(scene):
    """The agreement scene's floor and cube, the floor normal mapped at STRENGTH, a low sun
    across the ridges."""
    floor = bpy.data.objects["Floor"]
    floor.data.uv_layers.new(name="UVMap")
    for loop, uv in zip(floor.data.loops, ((0, 0), (4, 0), (4, 4), (0, 4))):
        floor.data.uv_layers["UVMap"].data[loop.index].uv = uv
    mat = floor.active_material
    tree = mat.node_tree
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = steep_normal_map("Ridges")
    mapping = tree.nodes.new("ShaderNodeNormalMap")
    mapping.inputs["Strength"].default_value = STRENGTH
    tree.links.new(tex.outputs["Color"], mapping.inputs["Color"])
    tree.links.new(mapping.outputs["Normal"], tree.nodes["Principled BSDF"].inputs["Normal"])
    scenes.light(scene, "Sun", "SUN", rotation_deg=(0.0, 65.0, 0.0), energy=3.0, angle=0.0)


def test_normal_map_strength_below_one_matches_cycles(empty_scene, tmp_path):
    scene = empty_scene
    build(scene, normal_mapped_floor)
    assert_mean_matches_cycles(scene, tmp_path, "normal_map_strength", MODEL_ALLOWANCE, per_channel=True)
