"""Views and shadows through two alpha layers, Cycles against Caustic through the add-on
(issue 20: "shadows through two alpha layers are 1.017x Cycles' brightness").

Scene: the agreement scene of test_cycles_agreement.py (grey floor, lighter cube, camera
looking down) under a sun, with two parallel overlapping quads above the floor, each either a
Principled BSDF with Alpha 0.5 (`blend_layers`) or one whose Alpha is an image's alpha, a
4x4 checker of holes sampled Closest (`leaf_layers`, a cut-out leaf). `shadow_layers` puts the
quads above the camera: only their shadow is seen. `match_cycles` sets every bounce limit to
3, Transparent Max Bounces too (Caustic's as Cycles').

The cause: Cycles counts alpha pass-throughs against Transparent Max Bounces. A camera ray
that has passed two layers has transparent bounce 2; its shadow ray may then cross only
3 - 2 = 1 alpha surface and is opaque behind two (`integrate_shadow_max_transparent_hits`;
bpy 5.0.1 renders T - n, not the T - n - 1 of older sources: with T - n - 1 Caustic was 0.981-
0.989 of Cycles here), and a path that has passed T of them ends at the next surface after
its emission. Caustic ignored the setting (it passed up to 128 surfaces). Measured on bpy
5.0.1, Caustic/Cycles per channel (R, G, B):
  before: blend 1.0186 1.0217 1.0284, leaf 1.0261 (grey: each channel; both fail the bound below),
          shadow only 1.0000 (a shadow ray from a point reached directly may cross 3);
  after:  blend 1.0003 1.0002 1.0002, leaf 1.0002 1.0001 1.0001, shadow only 1.0000.
With Cycles' Transparent Max Bounces at 128 the old Caustic agreed as well (1.0001-1.0003):
the difference is the limit alone.

`opaque_shadow_layers` / `opaque_shadow_blend_layers`: the same layers with the materials'
Transparent Shadows off, which Cycles honours (`Shader::use_transparent_shadow`): its shadow
rays stop at them whatever their alpha, while camera and bounce rays still pass. Caustic passed
shadow rays through by alpha: shadow only 1.0498/1.0488/1.0482 and in view 1.1159/1.1049/1.0901
(corpus 24_vertex_colors.blend B 1.235, 14 of 48 blocks off); now the add-on writes
`CAUSTIC_materials_shadow` and Caustic's shadow rays stop there: 1.0000 and 1.0002/1.0002/1.0003.

Bound: `assert_mean_matches_cycles`'s, per channel: 5 sigma from 8x8-pixel block differences
of two seeds per renderer plus the 1 % model allowance (derived in test_cycles_agreement.py).
"""

import bpy
import numpy as np
import pytest

import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, assert_mean_matches_cycles, build

pytestmark = pytest.mark.needs_binary

HEIGHTS_IN_VIEW = (1.2, 1.6)
HEIGHTS_ABOVE_CAMERA = (3.0, 3.4)  # the camera is at 2.8, looking down


def half_alpha_material(name):
    """A Lambertian orange (Principled, no specular layer) with Alpha 0.5."""
    mat = scenes.diffuse_material(name, 0.8)
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.9, 0.6, 0.3, 1.0)
    bsdf.inputs["Alpha"].default_value = 0.5
    return mat


def leaf_material(name):
    """A green Lambertian whose Alpha is a packed 4x4 checker's alpha (0 or 1), Closest."""
    mat = scenes.diffuse_material(name, 0.8)
    tree = mat.node_tree
    image = bpy.data.images.new(name + "Alpha", 4, 4, alpha=True)
    y, x = np.mgrid[0:4, 0:4]
    alpha = ((x + y) % 2 == 0).astype(np.float32)
    pixels = np.stack([0.2 + 0 * alpha, 0.7 + 0 * alpha, 0.2 + 0 * alpha, alpha], -1)
    image.pixels.foreach_set(pixels.astype(np.float32).ravel())
    image.pack()
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image, tex.interpolation = image, "Closest"
    tree.links.new(tex.outputs["Alpha"], tree.nodes["Principled BSDF"].inputs["Alpha"])
    return mat


def two_layers(scene, heights, make_material):
    """Two 1.6 m quads, 0.2 m apart sideways, at `heights`, and a sun at an angle."""
    for i, z in enumerate(heights):
        obj = scenes.plane(scene, f"Layer{i}", 1.6, z=z, material=make_material(f"Layer{i}"))
        obj.location.x = 0.2 * i - 0.3
        obj.data.uv_layers.new()
    scenes.light(scene, "Sun", "SUN", rotation_deg=(25.0, 10.0, 0.0), energy=2.0, angle=0.0)


def opaque_shadow_material(name):
    """`half_alpha_material` with Transparent Shadows off (material settings; often off in
    files made before Blender 4.2): Cycles stops shadow rays at it whatever its alpha."""
    mat = half_alpha_material(name)
    mat.use_transparent_shadow = False
    return mat


CASES = {
    "blend_layers": lambda scene: two_layers(scene, HEIGHTS_IN_VIEW, half_alpha_material),
    "leaf_layers": lambda scene: two_layers(scene, HEIGHTS_IN_VIEW, leaf_material),
    "shadow_layers": lambda scene: two_layers(scene, HEIGHTS_ABOVE_CAMERA, half_alpha_material),
    "opaque_shadow_layers": lambda scene: two_layers(scene, HEIGHTS_ABOVE_CAMERA, opaque_shadow_material),
    "opaque_shadow_blend_layers": lambda scene: two_layers(scene, HEIGHTS_IN_VIEW, opaque_shadow_material),
}


@pytest.mark.parametrize("case", list(CASES))
def test_two_alpha_layers_match_cycles(empty_scene, tmp_path, case):
    scene = empty_scene
    build(scene, CASES[case])
    assert_mean_matches_cycles(scene, tmp_path, case, MODEL_ALLOWANCE, per_channel=True)
