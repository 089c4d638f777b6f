"""Caustic and Cycles agree on a Principled BSDF whose IOR is below 1 (corpus
collection_to_link.blend has IOR 0). Cycles keeps that η (down to 1e-5): its specular layer
takes the exact Fresnel of η < 1, total internal reflection included (IOR 0 is a near
mirror), Specular IOR Level inverts the adjusted η back below 1, and the diffuse base is
layered under the albedo estimate Cycles reads from its table at z = √|(η − 1)/(η + 1)|,
the entry of 1/η. Caustic clamped η to 1 (no specular layer) with a warning.

The materials are constants, as a user sets them (a constant IOR below 1 sends the material
to its node graph: Blender's exporter drops an opaque material's KHR_materials_ior), and one
is driven by a Value node. A coloured base on a lone sphere under a
key light and a grey world, so that both the layer and the base under it show.

Tolerance as test_cycles_agreement.py: two seeds per renderer, per channel, 5 sigma of the
image-mean difference + the 1 % model allowance (MODEL_ALLOWANCE). Measured ratios are
printed (pytest -s) and stated in each case's comment, before -> after.
"""

import bpy
import pytest

import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, assert_mean_matches_cycles
from test_integrators import ALLOWANCE as INTEGRATOR_ALLOWANCE
from test_principled_agreement import driven, lone_sphere

pytestmark = pytest.mark.needs_binary

BASE = {"Base Color": (0.7, 0.3, 0.2, 1)}

# Caustic/Cycles R/G/B before (η clamped to 1) -> after, in each comment.
CASES = {
    # IOR 0: a near mirror. 1.281/0.710/0.567 -> 1.010/1.005/1.003.
    "ior0": {**BASE, "Roughness": 0.4, "IOR": 0.0},
    # Rough and smooth η = 0.5 (critical angle 30°): 0.957/0.874/0.833 -> 1.0007/1.0008/1.0008,
    # 0.953/0.869/0.828 -> 0.999/0.998/0.997.
    "ior05": {**BASE, "Roughness": 0.5, "IOR": 0.5},
    "ior05_smooth": {**BASE, "Roughness": 0.0, "IOR": 0.5},
    # η = 0.9 (critical angle 64°): little but grazing total internal reflection.
    # 0.963/0.976/0.983 -> 0.9999.
    "ior09": {**BASE, "Roughness": 0.2, "IOR": 0.9},
    # Specular IOR Level 0.25 halves F0(0.7); Cycles inverts the adjusted η back below 1.
    # 0.978/0.935/0.911 -> 1.0000/1.0001/1.0002.
    "level": {**BASE, "Roughness": 0.3, "IOR": 0.7, "Specular IOR Level": 0.25},
    # Subsurface under the layer of η < 1: weighted by what Cycles' estimate leaves it, entering
    # at Cycles' clamp of η, 1.01. 0.971/0.853/0.796 -> 0.993/1.003/1.003.
    "subsurface": {**BASE, "Roughness": 0.5, "IOR": 0.5, "Subsurface Weight": 1.0, "Subsurface Scale": 0.2},
    # The glass part with η < 1 (light bends away from the normal on entering).
    # 0.891/0.806/0.783 -> 1.005/1.004/1.003.
    "glass": {**BASE, "Roughness": 0.2, "IOR": 0.7, "Transmission Weight": 1.0},
}


# An opaque Principled BSDF's IOR above glTF's 1.5: Blender 5.0's exporter deletes
# KHR_materials_ior from a material without transmission, volume or specular extensions after
# every hook, so the add-on writes it back into the file (materials.restore_opaque_iors).
# Caustic/Cycles R/G/B before (rendered at 1.5) -> after, in each comment.
OPAQUE = {
    # F0 0.25 instead of 0.04: 1.050/0.924/0.866 -> 0.9988/0.9999/1.0004.
    "ior3": {**BASE, "Roughness": 0.3, "IOR": 3.0},
    # Water's 1.33 (F0 0.020; before within its bound, the roughness-0.1 highlight is noisy):
    # 0.9945/1.0102/1.0192 -> 1.0009/1.0017/1.0021.
    "ior133": {**BASE, "Roughness": 0.1, "IOR": 1.33},
}


def grey_world(scene):
    """A grey world: the layer's reflection of it shows where the key light's does not."""
    world = bpy.data.worlds.new("Grey")
    next(n for n in world.node_tree.nodes if n.type == "BACKGROUND").inputs["Color"].default_value = (0.3, 0.3, 0.3, 1)
    scene.world = world


@pytest.mark.parametrize("case", list(CASES) + list(OPAQUE))
def test_principled_ior_matches_cycles(empty_scene, tmp_path, case):
    """See CASES and OPAQUE (Caustic/Cycles R/G/B before -> after)."""
    mat = scenes.shader_node_material("PrincipledIor", "ShaderNodeBsdfPrincipled", **{**CASES, **OPAQUE}[case])
    lone_sphere(empty_scene, mat)
    grey_world(empty_scene)
    assert_mean_matches_cycles(empty_scene, tmp_path, case, MODEL_ALLOWANCE, per_channel=True)


def test_principled_ior_below_one_graph_matches_cycles(empty_scene, tmp_path):
    """IOR 0.5 driven by a Value node: the node-graph path (src/shader/closure.rs), which
    clamped η to 1: 0.972/0.861/0.807 -> 1.0007/1.0008/1.0008."""
    mat = driven("ShaderNodeBsdfPrincipled", {"IOR": 0.5}, **BASE, Roughness=0.5)
    lone_sphere(empty_scene, mat)
    grey_world(empty_scene)
    assert_mean_matches_cycles(empty_scene, tmp_path, "graph", MODEL_ALLOWANCE, per_channel=True)


def test_glass_bsdf_ior_zero_matches_cycles(empty_scene, tmp_path):
    """A Glass BSDF of IOR 0: Cycles clamps it to 1e-5 (a mirror from outside); Caustic took an
    IOR of 0 or less as 1.5: 0.463/0.464/0.499 -> 1.011/1.011/1.010."""
    mat = driven("ShaderNodeBsdfGlass", {"Roughness": 0.2}, Color=(0.9, 0.7, 0.5, 1), IOR=0.0)
    lone_sphere(empty_scene, mat)
    grey_world(empty_scene)
    assert_mean_matches_cycles(empty_scene, tmp_path, "glass bsdf", MODEL_ALLOWANCE, per_channel=True)


@pytest.mark.parametrize("integrator", list(INTEGRATOR_ALLOWANCE))
@pytest.mark.parametrize("case", ["ior05", "ior05_smooth"])
def test_every_integrator_renders_ior_below_one(empty_scene, tmp_path, integrator, case):
    """IOR 0.5, rough and smooth, by each other integrator against Cycles: light subpaths and
    photons see the layer through the BSDF's adjoint. Bound: the 1 % model allowance plus the
    integrator's bias allowance (test_integrators.py). Measured: photon and SPPM as the path
    tracer (no caustic paths here), BDPT and VCM 1.0005 (rough), 1.0008-1.0016 (smooth)."""
    mat = scenes.shader_node_material("IorBelowOne", "ShaderNodeBsdfPrincipled", **CASES[case])
    lone_sphere(empty_scene, mat)
    grey_world(empty_scene)
    empty_scene.caustic.integrator = integrator
    assert_mean_matches_cycles(empty_scene, tmp_path, f"{case} {integrator}",
                               MODEL_ALLOWANCE + INTEGRATOR_ALLOWANCE[integrator], per_channel=True)
