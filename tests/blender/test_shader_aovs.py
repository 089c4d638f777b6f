"""Shader AOVs as the compositor sees them: AOV Output nodes write the view layer's AOVs, a colour
(RGBA) and a value (X), and Caustic's passes agree with Cycles' on a scene that exercises
Cycles' rule (written at each camera-ray hit up to the first surface at least as opaque as the
Alpha Threshold).

Scene: a grey floor (no AOV node), a cube whose material writes a Noise Texture colour (object
coordinates) to "tint" and its Geometry Position (a vector into a value socket: their average) to
"height"; in front of part of the cube a plane of Mix(white Diffuse 0.3, Transparent 0.7), alpha
0.3 below the 0.5 threshold, writing 0.25 to "height": behind it the camera ray writes the cube's
AOVs too whenever it passes the plane (probability 0.7 in both renderers: Cycles picks the
Transparent closure by its share of the closures' weights, 0.7 of a white Diffuse's 0.3). The
world (seen above the floor's far edge) writes its Generated coordinate, the ray's direction, to
"tint" and that direction's average to "height" (Cycles' background shader writes a world's AOVs
where the camera sees it). 48x36, 64 samples, test_passes.py's settings.

Bound per channel mean, derived as in test_passes.py: two seeds per renderer give each image
mean's variance from 8x8 blocks (the noise is the pixel filter's sampling across edges and the
plane's pass-through draws); |Caustic - Cycles| <= 5 sigma + 1e-4 of the mean (the AOV values
themselves are the same functions of the hit in both renderers, no material model between: only
float rounding of 64-sample sums, about 2^-24 x 64, is left).
"""

import bpy
import numpy as np
import pytest

import scenes
from test_passes import H, SAMPLES, SEEDS, SIGMAS, W, mean_and_variance, render_passes

pytestmark = pytest.mark.needs_binary


def aov_output(tree, name, socket, source):
    node = tree.nodes.new("ShaderNodeOutputAOV")
    node.aov_name = name
    tree.links.new(source, node.inputs[socket])
    return node


def cube_material():
    mat = bpy.data.materials.new("Painted")
    mat.use_nodes = True
    tree = mat.node_tree
    coords = tree.nodes.new("ShaderNodeTexCoord")
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 3.0
    tree.links.new(coords.outputs["Object"], noise.inputs["Vector"])
    geometry = tree.nodes.new("ShaderNodeNewGeometry")
    aov_output(tree, "tint", "Color", noise.outputs["Color"])
    aov_output(tree, "height", "Value", geometry.outputs["Position"])
    return mat


def veil_material():
    mat = bpy.data.materials.new("Veil")
    mat.use_nodes = True
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    transparent = tree.nodes.new("ShaderNodeBsdfTransparent")
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = 0.7
    tree.links.new(diffuse.outputs["BSDF"], mix.inputs[1])
    tree.links.new(transparent.outputs["BSDF"], mix.inputs[2])
    tree.links.new(mix.outputs["Shader"], out.inputs["Surface"])
    value = tree.nodes.new("ShaderNodeValue")
    value.outputs[0].default_value = 0.25
    aov_output(tree, "height", "Value", value.outputs[0])
    return mat


def world_with_aovs():
    """A dark grey world whose AOV Output nodes write the direction (Generated) to "tint" and
    its average to "height"."""
    world = bpy.data.worlds.new("Sky")
    if hasattr(world, "use_nodes"):
        world.use_nodes = True
    tree = world.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputWorld")
    background = tree.nodes.new("ShaderNodeBackground")
    background.inputs["Color"].default_value = (0.05, 0.05, 0.05, 1.0)
    tree.links.new(background.outputs["Background"], out.inputs["Surface"])
    coords = tree.nodes.new("ShaderNodeTexCoord")
    aov_output(tree, "tint", "Color", coords.outputs["Generated"])
    aov_output(tree, "height", "Value", coords.outputs["Generated"])
    return world


def build(scene, with_aovs=True):
    scene.world = world_with_aovs()
    scenes.plane(scene, "Floor", 8.0, material=scenes.diffuse_material("Grey", 0.5))
    scenes.cube(scene, "Box", 2.0, (0.0, 0.6, 1.0), material=cube_material())
    scenes.mesh_object(scene, "Veil", [(-1.6, -0.8, 0.1), (0.2, -0.8, 0.1), (0.2, -0.8, 2.4), (-1.6, -0.8, 2.4)],
                       [(0, 1, 2, 3)], veil_material())
    scenes.light(scene, "Key", "AREA", location=(0.5, -1.0, 3.0), rotation_deg=(20, 0, 0), shape="SQUARE",
                 size=1.0, energy=150.0)
    scenes.camera(scene, (0.0, -4.5, 1.6), (80.0, 0.0, 0.0), lens=24.0)
    scenes.small_render_settings(scene, W, H, SAMPLES)
    scenes.match_cycles(scene, SAMPLES, 3)
    scene.render.film_transparent = False
    scene.render.image_settings.media_type = "MULTI_LAYER_IMAGE"
    scene.render.image_settings.exr_codec = "ZIP"
    layer = scene.view_layers[0]
    if with_aovs:
        layer.aovs.add().name = "tint"
        height = layer.aovs.add()
        height.name, height.type = "height", "VALUE"
        assert layer.pass_alpha_threshold == 0.5


@pytest.fixture(scope="module")
def both_renders(addon, tmp_path_factory):
    """Each renderer's passes for both seeds (rendered once for the module)."""
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    scene = bpy.context.scene
    scene.render.engine = "CAUSTIC"
    build(scene)
    tmp = tmp_path_factory.mktemp("shader_aovs")
    return {engine: [render_passes(scene, engine, s, str(tmp / f"{engine}{s}.exr")) for s in SEEDS]
            for engine in ("CYCLES", "CAUSTIC")}


# (pass, channel index in render_passes' name-sorted order, channel name): tint is A B G R.
CHANNELS = [("tint", 3, "R"), ("tint", 2, "G"), ("tint", 1, "B"), ("tint", 0, "A"), ("height", 0, "X")]


@pytest.mark.parametrize("name,index,channel", CHANNELS, ids=[f"{n}.{c}" for n, _, c in CHANNELS])
def test_aov_matches_cycles(both_renders, name, index, channel):
    for engine, renders in both_renders.items():
        for r in renders:
            assert name in r, f"{engine} has no {name} pass"
            assert r[name].shape[-1] == (1 if name == "height" else 4), (engine, r[name].shape)
    m_cy, v_cy = mean_and_variance(*(r[name][..., index:index + 1] for r in both_renders["CYCLES"]))
    m_ca, v_ca = mean_and_variance(*(r[name][..., index:index + 1] for r in both_renders["CAUSTIC"]))
    bound = SIGMAS * np.sqrt(v_cy + v_ca) + 1e-4 * max(abs(m_cy), abs(m_ca))
    print(f"{name}.{channel:2s} cycles {m_cy:.5f} caustic {m_ca:.5f} bound {bound:.5f}")
    assert m_cy != 0.0, "Cycles wrote nothing: the scene does not exercise the pass"
    assert abs(m_ca - m_cy) <= bound, f"caustic {m_ca:.5f}, cycles {m_cy:.5f}, bound {bound:.5f}"


def test_no_aov_passes_without_aovs(empty_scene, tmp_path):
    """Without AOVs in the view layer no AOV pass is declared or written (the nodes stay)."""
    scene = empty_scene
    build(scene, with_aovs=False)
    scene.caustic.samples = 2
    p = render_passes(scene, "CAUSTIC", 1, str(tmp_path / "plain.exr"))
    assert "tint" not in p and "height" not in p



def test_world_aovs_export_with_the_graph(addon, empty_scene, tmp_path):
    """A plain world (a Background colour) with AOV Output nodes is exported as its graph with
    them when the view layer has AOVs, and as the plain colour without; a world whose Surface
    is not linked names its unrendered AOV nodes in a warning."""
    from test_node_graph_export import export

    scene = empty_scene
    scene.world = world_with_aovs()
    gltf, state, _ = export(addon, scene, tmp_path / "plain")
    assert "nodes" not in gltf["scenes"][0]["extensions"]["CAUSTIC_world"], "AOV nodes without AOVs"
    scene.view_layers[0].aovs.add().name = "tint"
    gltf, state, _ = export(addon, scene, tmp_path / "aovs")
    nodes = gltf["scenes"][0]["extensions"]["CAUSTIC_world"]["nodes"]["nodes"]
    assert sorted(n["props"]["aov_name"] for n in nodes if n["type"] == "ShaderNodeOutputAOV") == ["height", "tint"]
    assert not [w for w in state.warnings if "world" in w], state.warnings
    tree = scene.world.node_tree
    for link in list(tree.links):
        if link.to_node.type == "OUTPUT_WORLD":
            tree.links.remove(link)
    _, state, _ = export(addon, scene, tmp_path / "unlinked")
    assert any("AOV Output nodes are not rendered" in w for w in state.warnings), state.warnings
