"""The Environment Texture node in a material (issue 19): Caustic through the add-on against
Cycles.

Cycles' svm_node_tex_environment on a surface: the Vector (unlinked: the hit position, its
LINK_POSITION default; here also Texture Coordinate Reflection, the mirrored view direction)
is normalised and looked up as Equirectangular or Mirror Ball, with the node's interpolation
and Repeat extension. Scene: `test_nodes_agreement`'s sphere scene (a ball on a grey floor
under a disk light), the ball's material an Emission shader coloured by the Environment
Texture, so that the camera sees the whole sphere of directions (Reflection) or the ball's
positions (Position) mapped through the image, and the floor is lit by it. The image is a
small float image with colour varying along both of its axes and a seam-free pattern in U,
so a wrong direction convention (axis, sign, projection) or interpolation moves blocks far
beyond the bound. Checks and their derivation: `test_nodes_agreement.compare` (mean per
channel within 5 sigma + 1 %, 4x4 blocks within 5 sigma + 2 %).
"""

import math

import bpy
import pytest

import scenes
from test_node_graph_export import by_id, new_material
from test_nodes_agreement import BOUNCES, SAMPLES, H, W, compare, sphere_scene

pytestmark = pytest.mark.needs_binary

SIZE_U, SIZE_V = 32, 16


def environment_image():
    """A 32x16 float image (Linear Rec.709), seam-free in U and symmetric about neither axis
    (a mirrored U or V shows): red cosines of one and three periods around U, green rising
    along V, blue a sine around U; all within [0.1, 1.6]."""
    image = bpy.data.images.new("Environment", SIZE_U, SIZE_V, float_buffer=True)
    image.colorspace_settings.name = "Linear Rec.709"
    pixels = []
    for y in range(SIZE_V):
        for x in range(SIZE_U):
            u, v = (x + 0.5) / SIZE_U, (y + 0.5) / SIZE_V
            pixels += [0.85 + 0.5 * math.cos(2.0 * math.pi * u) + 0.25 * math.cos(6.0 * math.pi * u),
                       0.1 + 1.5 * v, 0.6 + 0.4 * math.sin(2.0 * math.pi * u), 1.0]
    image.pixels.foreach_set(pixels)
    image.pack()
    return image


def environment_emitter(projection, interpolation, coordinate=None):
    """A maker: an Emission shader (strength 1) whose colour is an Environment Texture of
    `projection` and `interpolation`, its Vector from Texture Coordinate `coordinate` (None:
    unlinked)."""
    def make(name):
        mat = new_material(name)
        tree = mat.node_tree
        tex = tree.nodes.new("ShaderNodeTexEnvironment")
        tex.image = environment_image()
        tex.projection = projection
        tex.interpolation = interpolation
        if coordinate is not None:
            coords = tree.nodes.new("ShaderNodeTexCoord")
            tree.links.new(coords.outputs[coordinate], tex.inputs["Vector"])
        emission = tree.nodes.new("ShaderNodeEmission")
        by_id(emission.inputs, "Strength").default_value = 1.0
        tree.links.new(tex.outputs["Color"], emission.inputs["Color"])
        tree.links.new(emission.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
        return mat
    return make


def with_texture_mapping(make, **settings):
    """`make` with the Environment Texture's own (sidebar) Texture Mapping set, which Cycles
    applies to the vector before the lookup (`TextureMapping`): the add-on writes it as
    axis, Mapping and clamp nodes in front of the texture."""
    def made(name):
        mat = make(name)
        tex = next(n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeTexEnvironment")
        for key, value in settings.items():
            setattr(tex.texture_mapping, key, value)
        return mat
    return made


CASES = {
    "equirectangular_reflection_linear": environment_emitter("EQUIRECTANGULAR", "Linear", "Reflection"),
    "mirror_ball_reflection_closest": environment_emitter("MIRROR_BALL", "Closest", "Reflection"),
    # Unlinked: the position (the ball's centre is at z 0.6, so the directions span the sphere's
    # upper part and all azimuths).
    "equirectangular_position_cubic": environment_emitter("EQUIRECTANGULAR", "Cubic"),
    # A texture node's own (sidebar) Texture Mapping. Before (dropped, warned): R/G/B of
    # Cycles 1.0246/1.0261/0.9810 with 43/108 blocks over their bound (sidebar_rotation),
    # 0.8988/1.0478/0.9012 with 26/108 (sidebar_axes); after 0.9978-1.0006 and 0.9993-1.0001,
    # no block over.
    "sidebar_rotation": with_texture_mapping(
        environment_emitter("EQUIRECTANGULAR", "Linear", "Reflection"),
        vector_type="POINT", rotation=(0.3, 0.0, 1.2), scale=(1.0, 1.0, -1.0)),
    "sidebar_axes": with_texture_mapping(
        environment_emitter("EQUIRECTANGULAR", "Linear"),
        vector_type="TEXTURE", mapping_x="Y", mapping_y="X", mapping_z="Z", translation=(0.0, 0.0, 0.4),
        use_min=True, min=(-1.0, -1.0, -0.2)),
}


def build(scene, case):
    sphere_scene(scene, CASES[case](case))
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)


@pytest.mark.parametrize("case", sorted(CASES))
def test_environment_texture_on_a_surface_matches_cycles(empty_scene, tmp_path, case):
    build(empty_scene, case)
    compare(empty_scene, tmp_path, case)


def test_environment_texture_on_a_surface_is_exported_without_warning(addon, empty_scene, tmp_path):
    """The add-on writes the node into the material's graph and warns of nothing."""
    from test_node_graph_export import export

    build(empty_scene, "equirectangular_reflection_linear")
    gltf, state, _ = export(addon, empty_scene, tmp_path)
    graphs = [m["extensions"]["CAUSTIC_materials_nodes"] for m in gltf["materials"]
              if "CAUSTIC_materials_nodes" in m.get("extensions", {})]
    types = {n["type"] for g in graphs for n in g["nodes"]}
    assert "ShaderNodeTexEnvironment" in types, types
    assert not state.warnings, state.warnings
