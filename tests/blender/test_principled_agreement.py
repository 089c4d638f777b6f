"""Caustic and Cycles agree on the Principled BSDF's inputs that only the node-graph path
renders (`CAUSTIC_materials_nodes`, src/shader/closure.rs: Anisotropic with Cycles' default
tangent, Diffuse Roughness, Base Color above 1, partial Transmission), on the Refraction BSDF
and on the Metallic BSDF's Edge Tint (issue 19). Anisotropic and Diffuse Roughness are also
checked as constants, which send the material to its graph by their values alone.

Each material drives the input under test from a Value node: Blender's glTF exporter drops
that link, so the add-on exports the material as a node graph (the path under test) and
Cycles folds the Value node into a constant (the same material in both).

Tolerance as test_cycles_agreement.py: two seeds per renderer, per channel, 5 sigma of the
image-mean difference + the 1 % model allowance (MODEL_ALLOWANCE: the same model in both
renderers). Each scene is set up so that the feature moves the mean by far more than that
(the ratio of the binary without the feature is in each test's docstring). Measured ratios
are printed (pytest -s).
"""

import bpy
import pytest

import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, assert_mean_matches_cycles
from test_material_agreement import uv_sphere

pytestmark = pytest.mark.needs_binary

W, H = 48, 36
SAMPLES = 128
BOUNCES = 4


def driven(kind, driven_inputs, **inputs):
    """A material of one shader node of type `kind` whose `driven_inputs` (name -> value) come
    from Value nodes (so that the add-on exports a node graph) and whose other inputs are set."""
    mat = scenes.shader_node_material(kind + "Driven", kind, **inputs)
    tree = mat.node_tree
    node = next(n for n in tree.nodes if n.bl_idname == kind)
    for name, value in driven_inputs.items():
        v = tree.nodes.new("ShaderNodeValue")
        v.outputs[0].default_value = value
        tree.links.new(v.outputs[0], node.inputs[name])
    return mat


def principled(linked, driven_inputs, **inputs):
    """A Principled BSDF material with `driven_inputs` from Value nodes (`linked`) or set as
    constants, as a user sets them (then only the values themselves can send the material to
    its node graph)."""
    if linked:
        return driven("ShaderNodeBsdfPrincipled", driven_inputs, **inputs)
    return scenes.shader_node_material("PrincipledConstant", "ShaderNodeBsdfPrincipled", **inputs, **driven_inputs)


@pytest.mark.parametrize("linked", [True, False], ids=["linked", "constant"])
def test_anisotropic_principled_matches_cycles(empty_scene, tmp_path, linked):
    """Brushed metal: a Principled BSDF with Metallic 1, Roughness 0.3, Anisotropic 0.8 on a
    plane, whose unlinked Tangent is Cycles' default (radial around the object's Z axis), under
    a small disk light. A long lens frames the highlight closely, so that its shape (stretched
    along the tangent, narrowed across it) decides how much of it the image holds. Before,
    Caustic rendered it isotropic with a warning: R 1.1383, G 1.1395, B 1.1418 of Cycles (with
    the anisotropic albedo table for the multiple-scattering compensation instead of Cycles'
    isotropic proxy: R 1.029, G 1.020, B 1.011); now R 0.9999, G 1.0002, B 1.0005.
    A constant Anisotropic (no Value node, as a user sets it) still went through glTF, which
    rendered this plane as the isotropic case above (R/G/B 1.1383/1.1395/1.1418 of Cycles, with a
    warning about UV tangents); now it sends the material to its node graph: R/G/B
    0.9999/1.0002/1.0005."""
    scene = empty_scene
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    mat = principled(linked, {"Anisotropic": 0.8},
                     **{"Base Color": (0.9, 0.6, 0.3, 1), "Metallic": 1.0, "Roughness": 0.3})
    scenes.plane(scene, "Brushed", 6.0, material=mat)
    # The mirror image of the light seen from the camera lies at (1, 0, 0), where the radial
    # tangent points along +Y, the camera's view direction on the plane.
    scenes.light(scene, "Key", "AREA", location=(1.0, 1.5, 1.0), shape="DISK", size=0.2, energy=60.0)
    scenes.camera(scene, (1.0, -3.0, 2.0), (56.31, 0.0, 0.0), lens=85.0)
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)
    assert_mean_matches_cycles(scene, tmp_path, "anisotropic", MODEL_ALLOWANCE, per_channel=True)


def lone_sphere(scene, material):
    """`material` on a lone smooth sphere lit from beside the camera (no floor, whose light
    would dilute the sphere's)."""
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    uv_sphere(scene, "Ball", 0.8, (0.0, 0.0, 0.8), material)
    scenes.light(scene, "Key", "AREA", location=(0.4, -3.0, 1.2), rotation_deg=(75, 0, 0), shape="DISK",
                 size=0.5, energy=300.0)
    scenes.camera(scene, (0.0, -3.2, 0.8), (90.0, 0.0, 0.0), lens=40.0)
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)


@pytest.mark.parametrize("linked", [True, False], ids=["linked", "constant"])
def test_principled_diffuse_roughness_matches_cycles(empty_scene, tmp_path, linked):
    """Diffuse Roughness 1: the Principled BSDF's diffuse base is Cycles' Oren-Nayar (the Diffuse
    BSDF's rough lobe) under the specular layer. Before, Caustic rendered it Lambertian with a
    warning: R 0.7631, G 0.8192, B 0.8296 of Cycles; now 1.0009 in each. A constant Diffuse
    Roughness (no Value node, as a user sets it) still went through glTF, Lambertian with that
    warning: R/G/B 0.7631/0.8192/0.8296; now it sends the material to its node graph: 1.0010 in each."""
    lone_sphere(empty_scene, principled(linked, {"Diffuse Roughness": 1.0},
                                        **{"Base Color": (0.7, 0.3, 0.2, 1), "Roughness": 0.5}))
    assert_mean_matches_cycles(empty_scene, tmp_path, "diffuse roughness", MODEL_ALLOWANCE, per_channel=True)


def test_principled_bright_base_color_matches_cycles(empty_scene, tmp_path):
    """Base Color (1.6, 0.8, 0.3): Cycles weights the diffuse base by the colour as given (only the
    metal, glass and subsurface clamp it). Before, Caustic clamped it to 1: R 0.6298 (G 1.0006, B 1.0007)
    of Cycles; now R 1.0006."""
    lone_sphere(empty_scene, driven("ShaderNodeBsdfPrincipled", {"Roughness": 0.5},
                                    **{"Base Color": (1.6, 0.8, 0.3, 1)}))
    assert_mean_matches_cycles(empty_scene, tmp_path, "bright base", MODEL_ALLOWANCE, per_channel=True)


def test_partial_transmission_matches_cycles(empty_scene, tmp_path):
    """Transmission Weight 0.5, smooth, Base Color (0.9, 0.5, 0.2): Cycles' glass closure
    transmits √(base colour) at each crossing, so a ray through the sphere keeps the base colour
    once. A bright emitting wall behind the sphere fills the frame; the camera sees it through
    the sphere. Before, Caustic tinted each crossing by the base colour with a warning: R 0.9646,
    G 0.8902, B 0.9188 of Cycles; now R 0.9985, G 0.9975, B 0.9967."""
    scene = empty_scene
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    mat = driven("ShaderNodeBsdfPrincipled", {"Transmission Weight": 0.5},
                 **{"Base Color": (0.9, 0.5, 0.2, 1), "Roughness": 0.0, "IOR": 1.45})
    uv_sphere(scene, "Ball", 0.8, (0.0, 0.0, 0.8), mat)
    wall = scenes.plane(scene, "Wall", 8.0, material=scenes.emission_material("Glow", (1.0, 1.0, 1.0), 2.0))
    wall.location = (0.0, 2.0, 0.8)
    wall.rotation_euler = (1.5708, 0.0, 0.0)
    scenes.camera(scene, (0.0, -3.2, 0.8), (90.0, 0.0, 0.0), lens=60.0)
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)
    assert_mean_matches_cycles(scene, tmp_path, "transmission", MODEL_ALLOWANCE, per_channel=True)


def test_refraction_bsdf_matches_cycles(empty_scene, tmp_path):
    """A Refraction BSDF sphere (Color (0.9, 0.7, 0.5), IOR 1.45, Roughness 0.3, GGX) in front of a
    bright emitting wall: Cycles' closure refracts only, with no Fresnel weighting (all of the
    light goes through, but where a facet reflects totally). Before, Caustic rendered it as a
    Glass BSDF with a warning: R 0.9458, G 0.9598, B 0.9779 of Cycles; now R 0.9966, G 0.9973,
    B 0.9982. (The node's default Beckmann distribution: test_microfacet_agreement.py.)"""
    scene = empty_scene
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    mat = driven("ShaderNodeBsdfRefraction", {"Roughness": 0.3}, Color=(0.9, 0.7, 0.5, 1), IOR=1.45)
    # GGX (the node's default is Beckmann, tested in test_microfacet_agreement.py).
    next(n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfRefraction").distribution = "GGX"
    uv_sphere(scene, "Ball", 0.8, (0.0, 0.0, 0.8), mat)
    wall = scenes.plane(scene, "Wall", 8.0, material=scenes.emission_material("Glow", (1.0, 1.0, 1.0), 2.0))
    wall.location = (0.0, 2.0, 0.8)
    wall.rotation_euler = (1.5708, 0.0, 0.0)
    scenes.camera(scene, (0.0, -3.2, 0.8), (90.0, 0.0, 0.0), lens=60.0)
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)
    assert_mean_matches_cycles(scene, tmp_path, "refraction", MODEL_ALLOWANCE, per_channel=True)


def test_metallic_edge_tint_matches_cycles(empty_scene, tmp_path):
    """A Metallic BSDF (F82 Tint mode) with Base Color (0.9, 0.6, 0.3) and Edge Tint (0.3, 0.6,
    1.0), Roughness 0.3, on a plane seen at 80° from its normal reflecting a disk light: near 82°
    Cycles' F82-tint Fresnel is Schlick's times the tint. Before, Caustic rendered Schlick's of
    the base colour with a warning: R 2.9199, G 1.6576, B 1.0032 of Cycles; now R 1.0005,
    G 1.0021, B 1.0032."""
    scene = empty_scene
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    mat = driven("ShaderNodeBsdfMetallic", {"Roughness": 0.3},
                 **{"Base Color": (0.9, 0.6, 0.3, 1), "Edge Tint": (0.3, 0.6, 1.0, 1)})
    scenes.plane(scene, "Sheet", 6.0, material=mat)
    scenes.light(scene, "Key", "AREA", location=(0.0, 4.0, 0.7), rotation_deg=(-80.07, 0, 0), shape="DISK",
                 size=0.6, energy=200.0)
    scenes.camera(scene, (0.0, -4.0, 0.7), (80.07, 0.0, 0.0), lens=50.0)
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)
    assert_mean_matches_cycles(scene, tmp_path, "edge tint", MODEL_ALLOWANCE, per_channel=True)


SINGLE_SCATTER_CASES = {
    "rough_metal": {"Base Color": (0.9, 0.7, 0.5, 1), "Metallic": 1.0, "Roughness": 1.0},
    "dielectric": {"Base Color": (0.8, 0.8, 0.8, 1), "Roughness": 0.7},
    "rough_glass": {"Base Color": (0.9, 0.8, 0.6, 1), "Transmission Weight": 1.0, "Roughness": 0.6, "IOR": 1.45},
}


@pytest.mark.parametrize("case", list(SINGLE_SCATTER_CASES))
def test_principled_single_scatter_ggx_matches_cycles(empty_scene, tmp_path, case):
    """Distribution "GGX" (Blender's single-scattering choice; "Multiscatter GGX" is the default
    and what glTF's materials get): Cycles compensates neither the metal, the dielectric layer
    nor the glass for multiple scattering, and weights the diffuse base under the layer by
    1 − its albedo estimate, the table's Fresnel average mix(F0, 1, s) without the lobe's
    albedo E (which only Multiscatter GGX's compensation puts in the closure weight).
    Caustic dropped the setting (glTF has none, the graph did not read it) and rendered
    Multiscatter GGX: Caustic/Cycles R/G/B rough_metal 1.850/1.493/1.262, dielectric 1.0132,
    rough_glass 1.278/1.235/1.155; now the distribution sends the material to its graph, which
    renders it as Cycles: 0.9999, 1.0007, 0.987/0.988/0.990 (glass within its noise, sigma
    0.6-0.8 %)."""
    mat = scenes.shader_node_material("SingleScatter", "ShaderNodeBsdfPrincipled", **SINGLE_SCATTER_CASES[case])
    mat.node_tree.nodes["Principled BSDF"].distribution = "GGX"
    lone_sphere(empty_scene, mat)
    # A grey world too: the glass and the metal's rough lobes show it, the dark sky would not.
    world = bpy.data.worlds.new("Grey")
    next(n for n in world.node_tree.nodes if n.type == "BACKGROUND").inputs["Color"].default_value = (0.3, 0.3, 0.3, 1)
    empty_scene.world = world
    assert_mean_matches_cycles(empty_scene, tmp_path, case, MODEL_ALLOWANCE, per_channel=True)
