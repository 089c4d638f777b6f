"""A single-sided emissive quad lights the floor from its back face in the `caustic` binary as
Cycles renders Blender's import of the file (in the style of test_gltf_import_agreement.py).

glTF's `doubleSided: false` allows back-face culling; Blender's importer turns it into the
material's Backface Culling, a viewport setting that Cycles ignores: the back face is rendered,
and the Principled BSDF's emission leaves both faces. The file: a square emissive quad (0.8 m,
emissive (1, 0.8, 0.5) x strength 4, black base) 1.2 m over a grey floor, its front facing up,
away from the floor and from the camera below its plane, which sees the floor it lights and the
quad's back face. `single_sided` is the case; `double_sided` the same file with
`doubleSided: true`, the control (both faces emitted before too).

Measured (bpy 5.0.1, 48x36, 64 spp, two seeds), Caustic/Cycles R/G/B, before -> after:
single_sided 0/0/0 (the image black: the back face emitted nothing) -> 1.0035/1.0035/1.0035
(sigma 0.05 %); double_sided 1.0035 before and after. The 0.35 % both cases share is not the
back face's: the control has it too.

Through the add-on (`culled_*`): the same quad made in Blender, a Principled BSDF emitting with
Backface Culling on, which the exporter writes as `doubleSided: false`; with Emission Sampling
Auto and Front, which in Cycles steers light sampling only (Front: the floor under the back face
is found by BSDF sampling alone, so Cycles' image is noisier, never darker). Caustic/Cycles
R/G/B before -> after (48x36, 64 spp): culled_auto 0/0/0 (black) -> 1.0007 each (sigma 0.2 %),
culled_front 0/0/0 -> 1.0029 each (sigma 0.45 %: Cycles' noisier image).

A node graph's emission read from the side and angle light leaves by (`graph_*`): light sampling
read an emitter's graph as seen along its front normal, so a graph emitting by Backfacing or by
the angle it is seen at gave next-event estimation another value than the rays that hit it (and
light subpaths and photons the front's). `graph_front_only`: Blender users' one-sided emitter, a
Mix Shader of Emission and Transparent BSDF by Geometry > Backfacing, facing up, away from the
floor, under a grey world: the floor is lit by the world alone in Cycles, and was also lit by the
quad's front read from below. `graph_facing`: an Emission whose strength is 8 x Layer Weight's
Facing (blend 0.5), facing down at the floor: the floor was lit by the light samples' share at
Facing 0 (the view along the normal). Caustic/Cycles R/G/B before -> after (48x36, 64 spp):
graph_front_only 1.107/1.085/1.053 -> 1.0002 each; graph_facing 0.877 each -> 1.0012 each.

Tolerance: test_gltf_import_agreement's, the block-variance bound (5 sigma over two seeds each)
plus its 1 % model allowance: the quad and the floor are Principled BSDFs both renderers model
with the same closures.
"""

import math

import numpy as np
import pytest

import scenes
from test_cycles_agreement import assert_mean_matches_cycles
from test_gltf_import_agreement import (ALLOWANCE, BOUNCES, SAMPLES, H, W, _Gltf, assert_channels_match,
                                        caustic_images, cycles_images)

pytestmark = pytest.mark.needs_binary

HALF = 0.4  # the quad's half side (m)
HEIGHT = 1.2  # the quad's height over the floor (m)


def build(path, double_sided):
    """Floor, quad facing up (+Y, glTF's up), camera below the quad's plane; no other light."""
    g = _Gltf()
    glow = {"name": "Glow", "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0],
                                                     "metallicFactor": 0.0, "roughnessFactor": 0.5},
            "emissiveFactor": [1.0, 0.8, 0.5],
            "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}}
    if double_sided:
        glow["doubleSided"] = True
    g.doc["materials"] = [{"name": "Floor", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1],
                                                                      "metallicFactor": 0.0, "roughnessFactor": 0.8}},
                          glow]
    up = np.tile(np.array([[0, 1, 0]], np.float32), (4, 1))
    for name, y, s, material in (("Floor", 0.0, 5.0, 0), ("Quad", HEIGHT, HALF, 1)):
        # Counter-clockwise seen from +Y: both face up.
        pos = np.array([[-s, y, -s], [-s, y, s], [s, y, s], [s, y, -s]], np.float32)
        prim = {"attributes": {"POSITION": g.accessor(pos, "VEC3", minmax=True), "NORMAL": g.accessor(up, "VEC3")},
                "indices": g.accessor(np.array([0, 1, 2, 0, 2, 3], np.uint32), "SCALAR", 5125),
                "material": material}
        g.doc["meshes"].append({"name": name, "primitives": [prim]})
    roots = [g.node(name="Floor", mesh=0), g.node(name="Quad", mesh=1)]
    # Camera at (0, 0.7, 3) looking at (0, 0.4, 0): the quad's underside near the frame's top.
    tilt = -math.atan2(0.7 - 0.4, 3.0)
    g.doc["cameras"] = [{"type": "perspective", "perspective": {"yfov": 0.6, "aspectRatio": W / H,
                                                                  "znear": 0.1, "zfar": 100.0}}]
    roots.append(g.node(name="Camera", camera=0, translation=[0.0, 0.7, 3.0],
                        rotation=[math.sin(tilt / 2), 0.0, 0.0, math.cos(tilt / 2)]))
    g.doc["scenes"][0]["nodes"] = roots
    g.write(path, {"KHR_materials_emissive_strength"})


@pytest.mark.parametrize("case", ["single_sided", "double_sided"])
def test_back_face_of_an_emitter_matches_cycles_on_its_import(addon, tmp_path, case):
    gltf_path = tmp_path / f"{case}.gltf"
    build(gltf_path, case == "double_sided")
    cycles = cycles_images(gltf_path, tmp_path)
    caustic, log = caustic_images(gltf_path, tmp_path)
    assert_channels_match(case, caustic, cycles)


@pytest.mark.parametrize("sampling", ["AUTO", "FRONT"])
def test_addon_export_of_a_culled_emitter_matches_cycles(empty_scene, tmp_path, sampling):
    scene = empty_scene
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    scenes.plane(scene, "Floor", 10.0, material=scenes.diffuse_material("Grey", 0.5))
    glow = scenes.emission_material("Glow", (1.0, 0.8, 0.5), 4.0)
    glow.use_backface_culling = True
    glow.cycles.emission_sampling = sampling
    # Facing +Z, away from the floor and from the camera below its plane (Blender's Z up).
    scenes.plane(scene, "Quad", 2 * HALF, z=HEIGHT, material=glow)
    # At (0, -3, 0.7) looking along +Y, tilted down to (0, 0, 0.4) as the file's camera.
    scenes.camera(scene, (0.0, -3.0, 0.7), (90.0 - math.degrees(math.atan2(0.3, 3.0)), 0.0, 0.0))
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)
    assert_mean_matches_cycles(scene, tmp_path, f"culled_{sampling.lower()}", ALLOWANCE, per_channel=True)


def _graph_glow(kind):
    """The quad's node material: `front_only` emits by its front face alone (Mix Shader of
    Emission and Transparent by Backfacing), `facing` emits 8 x Layer Weight's Facing."""
    import bpy
    mat = bpy.data.materials.new(f"Glow_{kind}")
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    emit = nodes.new("ShaderNodeEmission")
    emit.inputs["Color"].default_value = (1.0, 0.8, 0.5, 1.0)
    if kind == "front_only":
        emit.inputs["Strength"].default_value = 4.0
        geo = nodes.new("ShaderNodeNewGeometry")
        clear = nodes.new("ShaderNodeBsdfTransparent")
        mix = nodes.new("ShaderNodeMixShader")
        links.new(geo.outputs["Backfacing"], mix.inputs["Fac"])
        links.new(emit.outputs["Emission"], mix.inputs[1])
        links.new(clear.outputs["BSDF"], mix.inputs[2])
        links.new(mix.outputs["Shader"], out.inputs["Surface"])
    else:
        weight = nodes.new("ShaderNodeLayerWeight")
        weight.inputs["Blend"].default_value = 0.5
        scale = nodes.new("ShaderNodeMath")
        scale.operation = "MULTIPLY"
        scale.inputs[1].default_value = 8.0
        links.new(weight.outputs["Facing"], scale.inputs[0])
        links.new(scale.outputs["Value"], emit.inputs["Strength"])
        links.new(emit.outputs["Emission"], out.inputs["Surface"])
    return mat


@pytest.mark.parametrize("kind", ["front_only", "facing"])
def test_graph_emission_is_read_from_the_side_light_leaves(empty_scene, tmp_path, kind):
    import bpy
    scene = empty_scene
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    scenes.plane(scene, "Floor", 10.0, material=scenes.diffuse_material("Grey", 0.5))
    quad = scenes.plane(scene, "Quad", 2 * HALF, material=_graph_glow(kind))
    quad.location.z = HEIGHT
    if kind == "facing":
        # Upside down: its front faces the floor.
        quad.rotation_euler = (math.pi, 0.0, 0.0)
    else:
        world = bpy.data.worlds.new("Grey")
        world.use_nodes = True
        world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.3, 0.3, 0.3, 1.0)
        scene.world = world
    scenes.camera(scene, (0.0, -3.0, 0.7), (90.0 - math.degrees(math.atan2(0.3, 3.0)), 0.0, 0.0))
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)
    assert_mean_matches_cycles(scene, tmp_path, f"graph_{kind}", ALLOWANCE, per_channel=True)
