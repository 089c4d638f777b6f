"""World node graphs (`CAUSTIC_world.nodes`): Caustic through the add-on against Cycles.

A grey diffuse floor seen from a camera that also sees the sky above the horizon, lit by the
world alone, 48x36 pixels, `test_nodes_agreement`'s render settings and its two derived checks
(mean per channel within 5 sigma + 1 %, 4x4-downsampled luminance blocks within 5 sigma + 2 %;
the derivation is in that module's doc). The camera sees the world directly (its value per
direction: the graph evaluated at the escaped ray) and the floor sees it through next-event
estimation from the baked table and BSDF sampling, weighted by MIS, so a wrong direction
convention, a wrong pattern or a biased sampler all move blocks far beyond the bound.

Worlds: Blender 5.0's default Sky Texture (Multiple Scattering; the sun behind the camera, so
that the floor is lit by the disc through the sampler and the sky is seen), a Mix Shader of
two Backgrounds whose factor is a Gradient Texture on the world's Generated coordinates (the
direction), a Noise Texture's colour as the Background, Texture Coordinate Camera and Window
(the render camera's view of the direction) through Gradients and Separate XYZ, and the legacy
Preetham and Hosek / Wilkie skies (older scenes' worlds; main before issue 19 rendered them
black: Caustic/Cycles 0).
"""

import math

import bpy
import pytest

import scenes
from test_nodes_agreement import BOUNCES, SAMPLES, H, W, compare

pytestmark = pytest.mark.needs_binary


def world_with(build_surface):
    """A new world whose Background gets its colour (or whose Output gets its shader) from
    `build_surface(tree, output)`."""
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    tree = world.node_tree
    tree.nodes.clear()
    output = tree.nodes.new("ShaderNodeOutputWorld")
    build_surface(tree, output)
    return world


def background(tree, color=None, strength=1.0):
    node = tree.nodes.new("ShaderNodeBackground")
    if color is not None:
        node.inputs["Color"].default_value = color
    node.inputs["Strength"].default_value = strength
    return node


def sky_world(tree, output):
    sky = tree.nodes.new("ShaderNodeTexSky")  # Blender 5.0's default: Multiple Scattering
    sky.sun_elevation = math.radians(35.0)
    sky.sun_rotation = math.pi  # toward -Y: behind the camera
    bg = background(tree, strength=0.1)
    tree.links.new(sky.outputs["Color"], bg.inputs["Color"])
    tree.links.new(bg.outputs[0], output.inputs["Surface"])


def legacy_sky_world(sky_type, **settings):
    """A Preetham or Hosek / Wilkie sky as the Background: the sun low and to the right of the
    view (+X, ahead along +Y), so that the camera sees its glow and the floor is lit by it."""
    def surface(tree, output):
        sky = tree.nodes.new("ShaderNodeTexSky")
        sky.sky_type = sky_type
        sky.sun_direction = (0.6, 0.5, 0.35)
        for key, value in settings.items():
            setattr(sky, key, value)
        bg = background(tree, strength=1.0)
        tree.links.new(sky.outputs["Color"], bg.inputs["Color"])
        tree.links.new(bg.outputs[0], output.inputs["Surface"])
    return surface


def gradient_mix_world(tree, output):
    gradient = tree.nodes.new("ShaderNodeTexGradient")  # linear in Generated x: the direction's
    mix = tree.nodes.new("ShaderNodeMixShader")
    warm = background(tree, (1.0, 0.55, 0.2, 1.0), 1.5)
    cool = background(tree, (0.2, 0.4, 1.0, 1.0), 0.8)
    tree.links.new(gradient.outputs["Fac"], mix.inputs["Fac"])
    tree.links.new(warm.outputs[0], mix.inputs[1])
    tree.links.new(cool.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], output.inputs["Surface"])


def noise_world(tree, output):
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 2.5
    noise.inputs["Detail"].default_value = 3.0
    bg = background(tree, strength=1.2)
    tree.links.new(noise.outputs["Color"], bg.inputs["Color"])
    tree.links.new(bg.outputs[0], output.inputs["Surface"])


def camera_window_world(tree, output):
    """Texture Coordinate Camera and Window: Cycles shades the background at the ray's direction
    plus the camera's position, so Camera is the direction in camera space and Window (a
    perspective camera) the frame position it projects to, for every ray: the camera sees a
    left-to-right ramp (Window x), a bottom-to-top one (Window y) and Camera x's right half,
    and the floor is lit by what those give the directions above it."""
    coords = tree.nodes.new("ShaderNodeTexCoord")
    window_x = tree.nodes.new("ShaderNodeTexGradient")  # linear: clamp(x, 0, 1)
    camera_x = tree.nodes.new("ShaderNodeTexGradient")
    split = tree.nodes.new("ShaderNodeSeparateXYZ")
    window_y = tree.nodes.new("ShaderNodeMath")
    window_y.operation = "MULTIPLY"
    window_y.use_clamp = True
    window_y.inputs[1].default_value = 1.0
    combine = tree.nodes.new("ShaderNodeCombineColor")
    tree.links.new(coords.outputs["Window"], window_x.inputs["Vector"])
    tree.links.new(coords.outputs["Camera"], camera_x.inputs["Vector"])
    tree.links.new(coords.outputs["Window"], split.inputs[0])
    tree.links.new(split.outputs["Y"], window_y.inputs[0])
    tree.links.new(window_x.outputs["Fac"], combine.inputs[0])
    tree.links.new(window_y.outputs[0], combine.inputs[1])
    tree.links.new(camera_x.outputs["Fac"], combine.inputs[2])
    bg = background(tree, strength=1.0)
    tree.links.new(combine.outputs[0], bg.inputs["Color"])
    tree.links.new(bg.outputs[0], output.inputs["Surface"])


WORLDS = {"sky": sky_world, "gradient_mix": gradient_mix_world, "noise": noise_world,
          "camera_window": camera_window_world,
          "sky_preetham": legacy_sky_world("PREETHAM", turbidity=3.0),
          "sky_hosek": legacy_sky_world("HOSEK_WILKIE", turbidity=4.5, ground_albedo=0.5)}


def build(scene, surface):
    scenes.plane(scene, "Floor", 40.0, material=scenes.diffuse_material("Grey", 0.5))
    # Looking along +Y, 15 degrees down: the floor in the lower part, the sky above it.
    scenes.camera(scene, (0.0, -3.0, 1.0), (75.0, 0.0, 0.0), lens=20.0)
    scene.world = world_with(surface)
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)


@pytest.mark.parametrize("world", sorted(WORLDS))
def test_world_graph_matches_cycles(empty_scene, tmp_path, world):
    scene = empty_scene
    build(scene, WORLDS[world])
    compare(scene, tmp_path, f"world {world}")


@pytest.mark.parametrize("world", sorted(WORLDS))
def test_world_graph_is_exported_as_nodes(addon, empty_scene, tmp_path, world):
    """The add-on writes these worlds as `nodes` (not the plain colour) and warns of nothing."""
    from test_node_graph_export import export

    scene = empty_scene
    build(scene, WORLDS[world])
    gltf, state, _ = export(addon, scene, tmp_path)
    ext = gltf["scenes"][0]["extensions"]["CAUSTIC_world"]
    assert "nodes" in ext and "color" not in ext, ext
    types = {n["type"] for n in ext["nodes"]["nodes"]}
    assert "ShaderNodeBackground" in types, types
    assert not [w for w in state.warnings if "world" in w], state.warnings
