"""A partly transparent emitter lights its surroundings as in Cycles, in every integrator, with
test_nodes_agreement.py's bounds (image mean per channel within 5 sigma + 1 %, 4x4 blocks
within 5 sigma + 2 %, two seeds per engine, derived there).

The only light is a panel whose material mixes Transparent and Emission (3, cyan) at 0.5: Cycles
gives its emission closure weight 0.5, so it emits 0.5 x 3 both to rays that hit it and to
light sampling. Caustic's node program gives the same weighted emission, which a hit
renormalises by the coverage it passes through with (`shade_nodes`); light sampling, light
subpaths and photons multiplied it by the coverage again, so the floor the panel lights was
half as bright: the sweep-5 scene 0.978 of Cycles over the image (13 of 48 blocks off, the
floor outside the panel 0.50) before, 0.9995 after. The second case takes the Alpha of a
Principled BSDF from a Noise texture (a node graph): 0.9762 -> 0.9988.
"""

import math

import pytest

import scenes
from test_node_graph_export import new_material
from test_nodes_agreement import BOUNCES, H, SAMPLES, W, compare

pytestmark = pytest.mark.needs_binary


def glow_half(name):
    """Mix Shader 0.5 of Transparent and Emission (0.2, 0.8, 1.0) x 3."""
    mat = new_material(name)
    tree = mat.node_tree
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (0.2, 0.8, 1.0, 1.0)
    emission.inputs["Strength"].default_value = 3.0
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = 0.5
    tree.links.new(tree.nodes.new("ShaderNodeBsdfTransparent").outputs[0], mix.inputs[1])
    tree.links.new(emission.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return mat


def principled_noise_alpha(name):
    """A Principled BSDF emitting (0.2, 0.8, 1.0) x 3, its Alpha a Noise texture's Fac."""
    mat = new_material(name)
    tree = mat.node_tree
    bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Emission Color"].default_value = (0.2, 0.8, 1.0, 1.0)
    bsdf.inputs["Emission Strength"].default_value = 3.0
    tree.links.new(tree.nodes.new("ShaderNodeTexNoise").outputs["Fac"], bsdf.inputs["Alpha"])
    tree.links.new(bsdf.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return mat


def panel_scene(scene, material):
    """A grey floor lit only by a 2.5-unit panel of `material` standing at 80 degrees, seen
    from the front and above (the floor on both sides of it and behind it through it)."""
    scenes.plane(scene, "Floor", 14.0, material=scenes.diffuse_material("Grey", 0.5))
    panel = scenes.mesh_object(scene, "Panel", [(-1.25, 0, -1.25), (1.25, 0, -1.25), (1.25, 0, 1.25),
                                                (-1.25, 0, 1.25)], [(0, 1, 2, 3)], material)
    panel.location = (0.0, -1.4, 1.0)
    panel.rotation_euler = (math.radians(-10.0), 0.0, 0.0)
    scenes.camera(scene, (0.0, -5.0, 3.2), (63.0, 0.0, 0.0), lens=35.0)


CASES = {"mix_transparent_emission": glow_half, "principled_noise_alpha_emission": principled_noise_alpha}


@pytest.mark.parametrize("integrator", ["path", "bdpt", "vcm", "photon"])
@pytest.mark.parametrize("case", list(CASES))
def test_transparent_emitter_matches_cycles(empty_scene, tmp_path, case, integrator):
    panel_scene(empty_scene, CASES[case](case))
    scenes.small_render_settings(empty_scene, W, H, samples=SAMPLES)
    empty_scene.caustic.threads = 0
    empty_scene.caustic.integrator = integrator
    scenes.match_cycles(empty_scene, SAMPLES, BOUNCES)
    compare(empty_scene, tmp_path, f"{case} ({integrator})")
