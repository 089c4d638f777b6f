"""A Principled BSDF's coat over a normal-mapped base, rendered by Cycles and by Caustic through
both export paths (glTF, and the node graph when an input is driven).

Cycles evaluates each closure against its own normal: the coat's (an unlinked Coat Normal is
the geometry's Normal, sd->N, not the Normal input's map) reflects light arriving above that
normal even where the base's mapped normal puts it below the horizon, and only the base's
closures are cut there (`bump_shadowing_term`). Caustic's BSDF lives in the mapped normal's
frame; it used to give the coat nothing below that frame's horizon, and its integrators dropped
such directions as a transmission that the geometry calls a reflection.

Scene: test_normal_map_strength_agreement's floor of steep sine ridges (Strength 0.4, tilts up
to ~70 degrees) under a low sun across them, the floor's Principled BSDF with Coat Weight 1 and
Coat Roughness 0.2: on the ridges' far slopes the sun is below the mapped normal's horizon but
above the coat's. Measured (bpy 5.0.1, 64x48, 128 spp, both seeds), Caustic/Cycles, every
channel alike: glTF path 0.9853 before (sigma 0.08 %), 0.9997 after; graph path 0.9967 before
(within the bound: there the coat also lay on the mapped normal, which hid part of the loss),
0.9993 after; the Principled BSDF in a Mix Shader with a Diffuse BSDF 0.9978 before, 0.9989
after.

Tolerance: test_cycles_agreement's (5 sigma of the two-seed block-variance estimate plus its 1 %
model allowance, derived there), per channel.
"""

import bpy
import pytest

from test_cycles_agreement import MODEL_ALLOWANCE, assert_mean_matches_cycles, build
from test_normal_map_strength_agreement import normal_mapped_floor

pytestmark = pytest.mark.needs_binary


def coated_ridges(graph, mix=False):
    """normal_mapped_floor with a coat on the floor; `graph` drives the Coat Weight from a Value
    node, which sends the material through its node graph; `mix` mixes the Principled BSDF (3/4)
    with a Diffuse BSDF on the unmapped normal (1/4)."""
    def add(scene):
        normal_mapped_floor(scene)
        tree = bpy.data.objects["Floor"].active_material.node_tree
        bsdf = tree.nodes["Principled BSDF"]
        bsdf.inputs["Coat Roughness"].default_value = 0.2
        if mix:
            diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
            diffuse.inputs["Color"].default_value = bsdf.inputs["Base Color"].default_value
            shader = tree.nodes.new("ShaderNodeMixShader")
            shader.inputs["Fac"].default_value = 0.75
            output = next(n for n in tree.nodes if n.type == "OUTPUT_MATERIAL")
            tree.links.new(diffuse.outputs[0], shader.inputs[1])
            tree.links.new(bsdf.outputs[0], shader.inputs[2])
            tree.links.new(shader.outputs[0], output.inputs["Surface"])
        if graph:
            value = tree.nodes.new("ShaderNodeValue")
            value.outputs[0].default_value = 1.0
            tree.links.new(value.outputs[0], bsdf.inputs["Coat Weight"])
        else:
            bsdf.inputs["Coat Weight"].default_value = 1.0
    return add


@pytest.mark.parametrize("graph,mix", [(False, False), (True, False), (True, True)], ids=["gltf", "graph", "mix"])
def test_coat_reflects_by_its_own_normal(empty_scene, tmp_path, graph, mix):
    """Coat over steep normal-mapped ridges, lit across them by a low sun: glTF 0.9853 -> 0.9997,
    graph 0.9967 -> 0.9993, mix 0.9978 -> 0.9989 of Cycles (module doc)."""
    scene = empty_scene
    build(scene, coated_ridges(graph, mix))
    assert_mean_matches_cycles(scene, tmp_path, "coat_own_normal", MODEL_ALLOWANCE, per_channel=True)
