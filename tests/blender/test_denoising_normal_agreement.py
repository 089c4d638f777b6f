"""The Denoising Normal pass (View Layer > Passes > Denoising Data) is in the camera's space, as
Cycles writes it (film_write_denoising_features_surface: the closures' mean normal turned by
kernel_data.cam.worldtocamera; x right, y up, z forward), which the compositor's Denoise node
reads. The binary writes the world-space normal; the add-on turns it when loading the result.
Before: means X/Y/Z 0.0183/-0.0418/0.7561 against Cycles' -0.1929/0.6104/-0.4049 (the world's axes);
now -0.1929/0.6104/-0.4050.

Scene: a grey floor whose far edge meets the world, a diffuse ball and a turned cube (every
surface diffuse, so Cycles writes the first hit's normal, its feature weight 1), seen by a
camera turned about all three axes (rolled too) so that no camera axis is a world axis or level.
Bound per channel, derived as in test_cycles_agreement.py: two seeds per renderer give the
block-wise variance of each image mean; |Caustic - Cycles| <= 5 sigma + 0.5 % of the channel's
mean magnitude over the pixels (|n| summed per pixel, so a channel whose signed mean is near
zero is not held to a relative bound it cannot meet): the normals are the same geometry's, and
the allowance covers the pixel filter's sample patterns at silhouettes (1 % in
test_cycles_agreement.py for a whole image, half of it for a quantity bounded by 1).
"""

import math

import bpy
import numpy as np
import pytest

import scenes
from exr_io import read_exr
from test_cycles_agreement import SEEDS, mean_and_variance

pytestmark = pytest.mark.needs_binary

W, H = 64, 48
SAMPLES = 32
SIGMAS = 5.0
ALLOWANCE = 0.005


def build(scene):
    scenes.plane(scene, "Floor", 10.0, material=scenes.diffuse_material("Grey", 0.5))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=(0.3, 0.2, 0.5), segments=24, ring_count=12)
    ball = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    ball.data.materials.append(scenes.diffuse_material("Ball", 0.7))
    cube = scenes.cube(scene, "Box", 0.6, (-1.0, 0.4, 0.3), material=scenes.diffuse_material("Light", 0.8))
    cube.rotation_euler = (0.0, 0.0, 0.6)
    scenes.light(scene, "Area", "AREA", location=(1.0, -1.0, 3.0), rotation_deg=(20, 10, 0), size=1.0, energy=300.0)
    world = bpy.data.worlds.new("Grey")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.1, 0.1, 0.1, 1.0)
    scene.world = world
    scenes.camera(scene, (1.5, -4.0, 2.6), (60.0, 15.0, 20.0), lens=35.0)
    scenes.small_render_settings(scene, W, H, SAMPLES)
    scenes.match_cycles(scene, SAMPLES, 3)
    scene.render.image_settings.media_type = "MULTI_LAYER_IMAGE"
    scene.render.image_settings.exr_codec = "ZIP"
    scene.view_layers[0].cycles.denoising_store_passes = True


def render_normal(scene, engine, seed, path):
    scenes.render_seeded(scene, engine, seed, path)
    channels = read_exr(path)
    return np.stack([channels[f"ViewLayer.Denoising Normal.{c}"].astype(np.float64) for c in "XYZ"], -1)


@pytest.fixture(scope="module")
def both_renders(addon, tmp_path_factory):
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    scene = bpy.context.scene
    build(scene)
    tmp = tmp_path_factory.mktemp("denoising_normal")
    return {engine: [render_normal(scene, engine, s, str(tmp / f"{engine}{s}.exr")) for s in SEEDS]
            for engine in ("CYCLES", "CAUSTIC")}


@pytest.mark.parametrize("channel", [0, 1, 2], ids=list("XYZ"))
def test_denoising_normal_is_in_camera_space_as_cycles(both_renders, channel):
    (m_cy, v_cy), (m_ca, v_ca) = (mean_and_variance(*(r[..., channel] for r in both_renders[e]))
                                  for e in ("CYCLES", "CAUSTIC"))
    magnitude = np.mean([np.abs(r[..., channel]).mean() for r in both_renders["CYCLES"]])
    bound = SIGMAS * math.sqrt(v_cy + v_ca) + ALLOWANCE * magnitude
    print(f"Denoising Normal.{'XYZ'[channel]}: caustic {m_ca:.5f} cycles {m_cy:.5f} bound {bound:.5f}")
    assert magnitude > 0.05, "Cycles' channel is nearly empty: the scene does not exercise it"
    assert abs(m_ca - m_cy) <= bound, f"caustic {m_ca:.5f}, cycles {m_cy:.5f}, bound {bound:.5f}"


def test_denoising_depth_is_named_as_missing(addon):
    """Denoising Data is three passes in Cycles; the third, Denoising Depth, is not rendered, and
    the request's warnings say so (it was missing from the result without a word)."""
    import importlib
    result = importlib.import_module(addon.__name__ + ".result")
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    layer = bpy.context.scene.view_layers[0]
    layer.cycles.denoising_store_passes = True
    passes, warnings = result.pass_request(layer, "path")
    assert passes.split(",") == ["denoising_albedo", "denoising_normal"], passes
    assert any("Denoising Depth" in w for w in warnings), warnings
    layer.cycles.denoising_store_passes = False
    assert not any("Denoising" in w for w in result.pass_request(layer, "path")[1])
