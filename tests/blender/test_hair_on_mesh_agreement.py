"""Hair BSDFs on meshes, against Cycles: a sphere shaded by the Principled Hair BSDF (Melanin,
Direct Coloring), by the Hair BSDF (Reflection, Transmission, both added) and by a Principled
Hair BSDF mixed with a Diffuse one; and a hair particle system's emitter sharing its hair's
material (the particle settings' material slot 1, Blender's default).

Cycles shades a triangle with hair closures as a fibre along the triangle's dPdu (the Principled
Hair BSDF, h from the geometric normal) or dPdv (the Hair BSDF, no Offset, cut at the shading
normal): the UV sphere's quads and pole triangles each show the highlight of fibres along one of
their edges, as the exporter's loop triangles keep Cycles' corner order. Caustic rendered such
meshes black (warned).

The sphere cases are test_nodes_agreement.py's `sphere_scene` (a ball on a grey floor under a
disk light, 48x36 pixels, two seeds per engine) checked by its `compare`: the image mean per
channel within 5 sigma + 1 % of Cycles', and every 4x4 block of the luminance within 5 sigma + 2 %
of its Cycles value (the bounds and their derivation are in that file's docstring; nothing here
is tuned on the results). The furry emitter is test_hair.py's furry sphere with its material a
Principled Hair BSDF, checked as that file's cases (mean per channel within 5 sigma + 1 %;
thin strands make per-block noise too uneven for the block test).

Cycles' evaluation (light sampling), never its sampling, gives nothing toward a light on the
other side of the closure's normal than of the shading normal (`bump_shadowing_term`), and a hair
closure's normal is its own (the Principled Hair BSDF's Y = X x wi): without that cut the melanin
sphere was 1.0575/1.0367/1.0124 of Cycles (2 blocks over); Cycles also turns dPdu round on a back
face, which the cuticle tilt reads (a sphere seen through its own far wall was 8 % bright).

Before (main's binary: the hair meshes black) and after, Caustic/Cycles mean R/G/B and blocks
over their bound of 108 (pytest -s prints both):
* melanin 0.770/0.834/0.912, 19 blocks -> 1.0003/1.0021/1.0044, 0
* direct_colouring 0.697/0.722/0.762, 16 -> 1.0021/1.0022/1.0025, 0
* hair_reflection 0.446/0.564/0.684, 41 -> 0.9932/0.9958/0.9975, 0
* hair_transmission 0.960/0.904/0.795, 51 -> 0.9995/0.9995/0.9996, 0
* hair_both 0.427/0.507/0.540, 50 -> 0.9958/0.9957/0.9957, 0
* hair_and_diffuse 0.858/0.873/0.909, 24 -> 1.0068/1.0050/1.0036, 0
* the furry emitter sharing its hair's material 0.9650/0.9830/0.9939 (R over its bound) ->
  1.0024/1.0005/0.9999.
"""

import bpy
import pytest

import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, assert_mean_matches_cycles
from test_hair import furry_sphere
from test_node_graph_export import new_material
from test_nodes_agreement import BOUNCES, SAMPLES, W, H, compare, sphere_scene


def _output(mat, socket):
    mat.node_tree.links.new(socket, mat.node_tree.nodes["Material Output"].inputs["Surface"])


def principled_hair(parametrization, inputs):
    """A maker: a Principled Hair BSDF (Chiang) of `parametrization` with `inputs`."""
    def make(name):
        mat = new_material(name)
        node = mat.node_tree.nodes.new("ShaderNodeBsdfHairPrincipled")
        node.parametrization = parametrization
        for key, value in inputs.items():
            node.inputs[key].default_value = value
        _output(mat, node.outputs[0])
        return mat
    return make


def _hair_node(tree, component, colour):
    node = tree.nodes.new("ShaderNodeBsdfHair")
    node.component = component
    node.inputs["Color"].default_value = colour
    node.inputs["RoughnessU"].default_value = 0.3
    node.inputs["RoughnessV"].default_value = 0.5
    return node


def hair_bsdf(*components):
    """A maker: the Hair BSDF's `components` (added when two)."""
    colours = {"Reflection": (0.8, 0.5, 0.3, 1.0), "Transmission": (0.3, 0.5, 0.8, 1.0)}

    def make(name):
        mat = new_material(name)
        tree = mat.node_tree
        nodes = [_hair_node(tree, c, colours[c]) for c in components]
        if len(nodes) == 1:
            _output(mat, nodes[0].outputs[0])
        else:
            add = tree.nodes.new("ShaderNodeAddShader")
            tree.links.new(nodes[0].outputs[0], add.inputs[0])
            tree.links.new(nodes[1].outputs[0], add.inputs[1])
            _output(mat, add.outputs[0])
        return mat
    return make


def hair_and_diffuse(name):
    """A Principled Hair BSDF (Direct Coloring) and a blue Diffuse mixed at 0.4."""
    mat = principled_hair("COLOR", {"Color": (0.7, 0.3, 0.1, 1.0)})(name)
    tree = mat.node_tree
    hair = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfHairPrincipled")
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (0.2, 0.4, 0.8, 1.0)
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = 0.4
    tree.links.new(hair.outputs[0], mix.inputs[1])
    tree.links.new(diffuse.outputs[0], mix.inputs[2])
    _output(mat, mix.outputs[0])
    return mat


CASES = {
    "melanin": principled_hair("MELANIN", {"Melanin": 0.3, "Roughness": 0.35}),
    "direct_colouring": principled_hair("COLOR", {"Color": (0.6, 0.3, 0.15, 1.0), "Roughness": 0.25}),
    "hair_reflection": hair_bsdf("Reflection"),
    "hair_transmission": hair_bsdf("Transmission"),
    "hair_both": hair_bsdf("Reflection", "Transmission"),
    "hair_and_diffuse": hair_and_diffuse,
}

# main's figures (the hair meshes black), Caustic/Cycles mean R/G/B and blocks over of 108.
BEFORE = {
    "melanin": "0.7697 0.8339 0.9118, 19/108 blocks over",
    "direct_colouring": "0.6966 0.7218 0.7617, 16/108 blocks over",
    "hair_reflection": "0.4464 0.5643 0.6839, 41/108 blocks over",
    "hair_transmission": "0.9599 0.9044 0.7954, 51/108 blocks over",
    "hair_both": "0.4273 0.5073 0.5401, 50/108 blocks over",
    "hair_and_diffuse": "0.8575 0.8732 0.9085, 24/108 blocks over",
}


@pytest.mark.needs_binary
@pytest.mark.parametrize("case", list(CASES))
def test_hair_on_a_sphere_matches_cycles(empty_scene, tmp_path, case):
    scene = empty_scene
    sphere_scene(scene, CASES[case](case))
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)
    if case in BEFORE:
        print(f"\n[hair on mesh before] {case:20s} {BEFORE[case]}")
    compare(scene, tmp_path, case)


@pytest.mark.needs_binary
def test_hair_emitter_sharing_its_material_matches_cycles(empty_scene, tmp_path):
    """The furry sphere whose one material, a Principled Hair BSDF (Melanin), the hair shares
    (particle settings material slot 1): scalp and strands both shade as hair."""
    scene = empty_scene
    sphere = furry_sphere(scene)
    mat = principled_hair("MELANIN", {"Melanin": 0.4})("SharedFur")
    sphere.data.materials[0] = mat
    assert sphere.particle_systems[0].settings.material == 1
    ratios = assert_mean_matches_cycles(scene, tmp_path, "hair emitter", MODEL_ALLOWANCE, per_channel=True)
    print(f"\n[hair on mesh] emitter sharing its hair's material Caustic/Cycles {ratios}")
