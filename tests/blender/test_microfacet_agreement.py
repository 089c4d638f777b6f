"""Caustic and Cycles agree on the microfacet options of Blender's BSDF nodes (issue 19): the
Beckmann distribution of the Glossy, Refraction and Glass BSDFs, the Glass BSDF's single-
scattering "GGX", the Glossy BSDF's Anisotropy along Cycles' default tangent, and the
Principled metal's Specular Tint (Cycles' F82 tint of the metal); and the Toon BSDF.

Glossy, Glass and Refraction BSDFs are always exported as node graphs (the glTF exporter does
not read them); a Principled metal with a Specular Tint is too (the add-on's `needs_graph`).

Tolerance as test_cycles_agreement.py: two seeds per renderer, per channel, 5 sigma of the
image-mean difference + the 1 % model allowance (MODEL_ALLOWANCE: the same model in both
renderers). Each scene is set up so that the feature moves the mean by far more than that: the
ratios of main's binary (before this change, the option rendered as GGX or left out with a
warning) are in each case's comment, measured with
CAUSTIC_BINARY=/work/main/target/release/caustic; the ratios now are printed (pytest -s).
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


def node_material(kind, distribution=None, **inputs):
    """One shader node of type `kind` with its `distribution` and inputs set."""
    mat = scenes.shader_node_material(kind + (distribution or ""), kind, **inputs)
    node = next(n for n in mat.node_tree.nodes if n.bl_idname == kind)
    if distribution is not None:
        node.distribution = distribution
    return mat


def highlight_scene(scene, material):
    """A plane under a small disk light, framed closely around the light's mirror image by a
    long lens, so that the highlight's shape (its tails, its stretch) decides the mean. At the
    mirror image (1, 0, 0) Cycles' default radial tangent points along +Y, the view's direction
    on the plane."""
    scenes.plane(scene, "Sheet", 6.0, material=material)
    scenes.light(scene, "Key", "AREA", location=(1.0, 1.5, 1.0), shape="DISK", size=0.2, energy=60.0)
    scenes.camera(scene, (1.0, -3.0, 2.0), (56.31, 0.0, 0.0), lens=85.0)


def refraction_scene(scene, material):
    """A sphere of `material` in front of a bright emitting wall: what it shows is the wall
    refracted through it."""
    uv_sphere(scene, "Ball", 0.8, (0.0, 0.0, 0.8), material)
    wall = scenes.plane(scene, "Wall", 8.0, material=scenes.emission_material("Glow", (1.0, 1.0, 1.0), 2.0))
    wall.location = (0.0, 2.0, 0.8)
    wall.rotation_euler = (1.5708, 0.0, 0.0)
    scenes.camera(scene, (0.0, -3.2, 0.8), (90.0, 0.0, 0.0), lens=60.0)


def refraction_scene_without_nee(scene, material):
    """The refraction scene with the wall found only by BSDF sampling in Cycles (its Emission
    Sampling off): Cycles' evaluation of a rough refraction (`bsdf_microfacet_eval`, whose TODO
    says it does not check the configuration) gives light to pairs of directions no microfacet
    refracts into each other, which its sampler never draws, so its next-event estimate is
    brighter than its BSDF samples (measured with rough GGX glass 0.8: 2.4 % here, NEE on; with
    it off Caustic/Cycles is 1.0000). Caustic has no such pairs; see the report of issue 19."""
    refraction_scene(scene, material)
    next(m for m in bpy.data.materials if m.name.startswith("Glow")).cycles.emission_sampling = "NONE"


def grazing_scene(scene, material):
    """A plane seen at 80° from its normal reflecting a disk light: near 82°, where the F82
    tint acts."""
    scenes.plane(scene, "Sheet", 6.0, material=material)
    scenes.light(scene, "Key", "AREA", location=(0.0, 4.0, 0.7), rotation_deg=(-80.07, 0, 0), shape="DISK",
                 size=0.6, energy=200.0)
    scenes.camera(scene, (0.0, -4.0, 0.7), (80.07, 0.0, 0.0), lens=50.0)


def lit_sphere_scene(scene, material):
    """A sphere of `material` on a grey floor under a disk light beside the camera."""
    scenes.plane(scene, "Floor", 10.0, material=scenes.diffuse_material("Grey", 0.5))
    uv_sphere(scene, "Ball", 0.6, (0.0, 0.0, 0.6), material)
    scenes.light(scene, "Disk", "AREA", location=(0.8, -0.5, 3.0), shape="DISK", size=0.8, energy=400.0)
    scenes.camera(scene, (0.0, -2.2, 3.2), (35.0, 0.0, 0.0), lens=30.0)


def toon(component, size, smooth):
    """A Toon BSDF of `component` (DIFFUSE or GLOSSY)."""
    mat = scenes.shader_node_material("Toon" + component, "ShaderNodeBsdfToon", Color=(0.9, 0.6, 0.3, 1), Size=size,
                                      Smooth=smooth)
    next(n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfToon").component = component
    return mat


def tinted_metal():
    """A plain Principled metal (no links) with a coloured Specular Tint."""
    mat = bpy.data.materials.new("TintedMetal")
    if mat.node_tree is None:  # Blender < 5.0 creates materials without nodes
        mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    for key, value in {"Base Color": (0.9, 0.6, 0.3, 1), "Metallic": 1.0, "Roughness": 0.3,
                       "Specular Tint": (0.3, 0.6, 1.0, 1)}.items():
        bsdf.inputs[key].default_value = value
    return mat


CASES = {
    # Before: GGX single scattering with a warning: 0.8923 of Cycles in R, G and B; now 1.0000.
    "beckmann_glossy": (highlight_scene, lambda: node_material(
        "ShaderNodeBsdfAnisotropic", "BECKMANN", Color=(0.9, 0.6, 0.3, 1), Roughness=0.4)),
    # Before: isotropic with a warning: R 0.7886, G 0.7938, B 0.7990; now R 1.0006, G 1.0072,
    # B 1.0138.
    "anisotropic_glossy": (highlight_scene, lambda: node_material(
        "ShaderNodeBsdfAnisotropic", "MULTI_GGX", Color=(0.9, 0.6, 0.3, 1), Roughness=0.3, Anisotropy=0.8)),
    # The Refraction BSDF at its default, Beckmann. Before: GGX with a warning: R 0.9302,
    # G 0.9429, B 0.9603; now R 0.9979, G 0.9983, B 0.9989.
    "beckmann_refraction": (refraction_scene, lambda: node_material(
        "ShaderNodeBsdfRefraction", None, Color=(0.9, 0.7, 0.5, 1), Roughness=0.4, IOR=1.45)),
    # Before: multiscatter GGX, without a warning: R 1.0155, G 1.0088, B 1.0030; now R 0.9933,
    # G 0.9948, B 0.9966.
    "beckmann_glass": (refraction_scene, lambda: node_material(
        "ShaderNodeBsdfGlass", "BECKMANN", Color=(0.9, 0.7, 0.5, 1), Roughness=0.6, IOR=1.45)),
    # Single-scattering GGX glass. Before: multiscatter GGX, without a warning: R 1.3766,
    # G 1.2761, B 1.1678; now 1.0000 in each.
    "single_scatter_glass": (refraction_scene_without_nee, lambda: node_material(
        "ShaderNodeBsdfGlass", "GGX", Color=(0.9, 0.7, 0.5, 1), Roughness=0.8, IOR=1.45)),
    # Before: Schlick's Fresnel of the base colour (a warning where the add-on wrote a graph, else
    # silently through glTF): R 2.9199, G 1.6576, B 1.0032; now R 1.0005, G 1.0021, B 1.0032.
    "principled_metal_specular_tint": (grazing_scene, tinted_metal),
    # The Toon BSDF (Cycles' bsdf_toon.h). Before: an unsupported node, black with a warning.
    "toon_diffuse": (lit_sphere_scene, lambda: toon("DIFFUSE", 0.5, 0.2)),
    "toon_glossy": (lit_sphere_scene, lambda: toon("GLOSSY", 0.3, 0.1)),
}


@pytest.mark.parametrize("case", list(CASES))
def test_microfacet_option_matches_cycles(empty_scene, tmp_path, case):
    scene = empty_scene
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    build, material = CASES[case]
    build(scene, material())
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)
    assert_mean_matches_cycles(scene, tmp_path, case, MODEL_ALLOWANCE, per_channel=True)
