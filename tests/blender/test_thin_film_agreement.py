"""Caustic and Cycles agree on a thin film on a metal: Cycles puts the Principled BSDF's film on
its F82-tint conductor (a complex index from the base colour and the 82 degree reflectance,
`fresnel_iridescence_channel<true>`), and the Metallic BSDF's on either of its conductors
(bsdf/thin_film.rs `conductor_film_reflectance`). The Principled one through both export paths:
glTF (`KHR_materials_iridescence` marked `CAUSTIC_materials_iridescence` {"metal": "conductor"})
and the node graph (the thickness from a Value node); the Metallic BSDF through its graph.

Scene and tolerance as test_material_fidelity.py (a sphere filling the frame on the grey floor
under the disk light, 64x48, 256 samples, two seeds per renderer, per channel): 5 sigma of the
image-mean difference + its FILM allowance (1 % same model, 1 % for Caustic's fitted
colour-matching functions against Cycles' tabulated ones). A film this thick moves the channels
by far more (the ratios without the film on the metal are in each docstring; pytest -s prints
the ratios).
"""

import pytest

from test_cycles_agreement import assert_mean_matches_cycles
from test_material_fidelity import FILM, floor_light_camera, sphere_of
from test_principled_agreement import driven, principled

pytestmark = pytest.mark.needs_binary

METAL = {"Base Color": (0.9, 0.6, 0.3, 1), "Roughness": 0.25, "Metallic": 1.0, "Thin Film IOR": 1.8}


@pytest.mark.parametrize("linked", [False, True], ids=["gltf", "graph"])
def test_principled_film_on_metal_matches_cycles(empty_scene, tmp_path, linked):
    """Principled BSDF, Metallic 1, base (0.9, 0.6, 0.3), roughness 0.25, film 300 nm of IOR 1.8.
    Film left off the metal (before): R/G/B 1.0648/0.9841/1.6247; on Cycles' F82 conductor:
    0.9974/0.9979/0.9987 (both paths the same to four digits: with a white Specular Tint the
    two build the same metal)."""
    scene = empty_scene
    floor_light_camera(scene)
    sphere_of(lambda: principled(linked, {"Thin Film Thickness": 300.0}, **METAL))(scene)
    assert_mean_matches_cycles(scene, tmp_path, "principled_film_metal", FILM, per_channel=True)


@pytest.mark.parametrize("fresnel", ["F82", "PHYSICAL_CONDUCTOR"])
def test_metallic_bsdf_film_matches_cycles(empty_scene, tmp_path, fresnel):
    """Metallic BSDF of roughness 0.25 under a 250 nm film of IOR 1.5: F82 with base colour
    (0.9, 0.6, 0.3) and Edge Tint (0.5, 0.8, 1.0); Physical Conductor with Blender's default
    index (n 2.757/2.513/2.231, k 3.867/3.404/3.009). Film not rendered (before, warned): F82
    R/G/B 1.0390/0.9412/1.3357, physical 0.9856/1.0553/1.1208; with it: F82 0.9967/0.9995/0.9997,
    physical 0.9974/1.0003/0.9988."""
    scene = empty_scene
    floor_light_camera(scene)

    def material():
        mat = driven("ShaderNodeBsdfMetallic", {"Thin Film Thickness": 250.0},
                     **{"Base Color": (0.9, 0.6, 0.3, 1), "Edge Tint": (0.5, 0.8, 1.0, 1), "Roughness": 0.25,
                        "Thin Film IOR": 1.5})
        node = next(n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfMetallic")
        node.fresnel_type = fresnel
        return mat

    sphere_of(material)(scene)
    assert_mean_matches_cycles(scene, tmp_path, f"metallic_film_{fresnel.lower()}", FILM, per_channel=True)
