"""Vertex normals against the winding: a plane whose custom normals point down (its winding up),
under an area light and a grey world, above the agreement floor. Cycles shades with the normals
as given (`triangle_smooth_normal`): the shading hemisphere lies below the surface seen, so the
plane reflects and transmits nothing (black with every BSDF). Caustic turned such normals to the
winding's side, as pbrt does: the plane rendered lit, 1.22-1.58 of Cycles' image with Principled,
Diffuse and Glass; now it keeps them as given (`Scene::surface`): 1.0000.

Tolerance as test_cycles_agreement.py: two seeds per renderer, per channel, 5 sigma of the
image-mean difference + the 1 % model allowance (MODEL_ALLOWANCE)."""

import bpy
import pytest

import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, assert_mean_matches_cycles

pytestmark = pytest.mark.needs_binary

W, H = 48, 36
SAMPLES = 64
BOUNCES = 3

MATERIALS = {
    "principled": ("ShaderNodeBsdfPrincipled", {"Base Color": (0.8, 0.6, 0.3, 1.0), "Roughness": 0.4}),
    "diffuse": ("ShaderNodeBsdfDiffuse", {"Color": (0.8, 0.6, 0.3, 1.0)}),
    "glass": ("ShaderNodeBsdfGlass", {"Color": (0.8, 0.8, 0.8, 1.0), "Roughness": 0.1}),
}


@pytest.mark.parametrize("kind", sorted(MATERIALS))
def test_normals_against_the_winding_shade_as_cycles(empty_scene, tmp_path, kind):
    scene = empty_scene
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    scenes.plane(scene, "Floor", 10.0, material=scenes.diffuse_material("Grey", 0.5))
    scenes.camera(scene, (0.0, -4.0, 2.6), (60.0, 0.0, 0.0), lens=35.0)
    scenes.light(scene, "Area", "AREA", location=(1.0, -1.0, 3.0), rotation_deg=(20, 10, 0), size=1.0,
                 energy=300.0)
    world = bpy.data.worlds.new("Grey")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.1, 0.1, 0.1, 1.0)
    scene.world = world
    mesh = bpy.data.meshes.new("Down")
    mesh.from_pydata([(-1, -1, 0.3), (1, -1, 0.3), (1, 1, 0.3), (-1, 1, 0.3)], [], [(0, 1, 2, 3)])
    mesh.normals_split_custom_set([(0.0, 0.2, -1.0)] * 4)
    node, inputs = MATERIALS[kind]
    mesh.materials.append(scenes.shader_node_material(kind, node, **inputs))
    scene.collection.objects.link(bpy.data.objects.new("Down", mesh))
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)
    assert_mean_matches_cycles(scene, tmp_path, f"normals against the winding, {kind}", MODEL_ALLOWANCE,
                               per_channel=True)
