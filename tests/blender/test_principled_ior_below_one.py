"""Caustic and Cycles agree on a Principled BSDF whose IOR is below 1 (corpus
collection_to_link.blend has IOR 0). Cycles keeps that η (down to 1e-5): its specular layer
takes the exact Fresnel of η < 1, total internal reflection included (IOR 0 is a near
mirror), Specular IOR Level inverts the adjusted η back below 1, and the diffuse base is
layered under the albedo estimate Cycles reads from its table at z = √|(η − 1)/(η + 1)|,
the entry of 1/η. Caustic clamped η to 1 (no specular layer) with a warning.

The materials are constants, as a user sets them (the glTF path, KHR_materials_ior), and
one is driven by a Value node (the node-graph path). A coloured base on a lone sphere under a
key light and a grey world, so that both the layer and the base under it show.

Tolerance as test_cycles_agreement.py: two seeds per renderer, per channel, 5 sigma of the
image-mean difference + the 1 % model allowance (MODEL_ALLOWANCE). Measured ratios are
printed (pytest -s) and stated in each case's comment, before -> after.
"""

import bpy
import pytest

import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, assert_mean_matches_cycles
from test_principled_agreement import driven, lone_sphere

pytestmark = pytest.mark.needs_binary

BASE = {"Base Color": (0.7, 0.3, 0.2, 1)}

# Caustic/Cycles R/G/B before (η clamped to 1) -> after, in each comment.
CASES = {
    # IOR 0: a near mirror.
    "ior0": {**BASE, "Roughness": 0.4, "IOR": 0.0},
    # Rough and smooth η = 0.5 (critical angle 30°).
    "ior05": {**BASE, "Roughness": 0.5, "IOR": 0.5},
    "ior05_smooth": {**BASE, "Roughness": 0.0, "IOR": 0.5},
    # η = 0.9 (critical angle 64°): little but grazing total internal reflection.
    "ior09": {**BASE, "Roughness": 0.2, "IOR": 0.9},
    # Specular IOR Level 0.25 halves F0(0.7); Cycles inverts the adjusted η back below 1.
    "level": {**BASE, "Roughness": 0.3, "IOR": 0.7, "Specular IOR Level": 0.25},
    # The glass part with η < 1 (light bends away from the normal on entering).
    "glass": {**BASE, "Roughness": 0.2, "IOR": 0.7, "Transmission Weight": 1.0},
}


def grey_world(scene):
    """A grey world: the layer's reflection of it shows where the key light's does not."""
    world = bpy.data.worlds.new("Grey")
    next(n for n in world.node_tree.nodes if n.type == "BACKGROUND").inputs["Color"].default_value = (0.3, 0.3, 0.3, 1)
    scene.world = world


@pytest.mark.parametrize("case", list(CASES))
def test_principled_ior_below_one_matches_cycles(empty_scene, tmp_path, case):
    """See CASES; constants, so the glTF path (KHR_materials_ior) renders them."""
    mat = scenes.shader_node_material("IorBelowOne", "ShaderNodeBsdfPrincipled", **CASES[case])
    lone_sphere(empty_scene, mat)
    grey_world(empty_scene)
    assert_mean_matches_cycles(empty_scene, tmp_path, case, MODEL_ALLOWANCE, per_channel=True)


def test_principled_ior_below_one_graph_matches_cycles(empty_scene, tmp_path):
    """IOR 0.5 driven by a Value node: the node-graph path (src/shader/closure.rs)."""
    mat = driven("ShaderNodeBsdfPrincipled", {"IOR": 0.5}, **BASE, Roughness=0.5)
    lone_sphere(empty_scene, mat)
    grey_world(empty_scene)
    assert_mean_matches_cycles(empty_scene, tmp_path, "graph", MODEL_ALLOWANCE, per_channel=True)


def test_glass_bsdf_ior_zero_matches_cycles(empty_scene, tmp_path):
    """A Glass BSDF of IOR 0: Cycles clamps it to 1e-5 (a mirror from outside); Caustic took an
    IOR of 0 or less as 1.5."""
    mat = driven("ShaderNodeBsdfGlass", {"Roughness": 0.2}, Color=(0.9, 0.7, 0.5, 1), IOR=0.0)
    lone_sphere(empty_scene, mat)
    grey_world(empty_scene)
    assert_mean_matches_cycles(empty_scene, tmp_path, "glass bsdf", MODEL_ALLOWANCE, per_channel=True)
