"""Caustic and Cycles agree on world lighting: a uniform colour and a rotated HDRI.

Same scene, tolerance derivation and model allowance as test_cycles_agreement.py (a grey floor
and a cube seen from above), lit only by the world: a Background colour × strength, and an
equirectangular float image (an OpenEXR made here: a sky gradient with a bright sun patch) rotated about Z
by a Mapping node. The HDRI case checks the image mapping, its rotation direction and the
importance sampling of the world; a wrong axis or rotation sign moves the sun patch and
changes the floor's shading by far more than the bound. The same file with its colour space
set in Blender to sRGB (as Blender marks an OpenEXR it saved itself) is decoded by Cycles:
the add-on must not hand the renderer the raw file then (Caustic/Cycles was 0.199 here);
nor an 8-bit PNG set to Non-Color (`png_noncolor`, 0.655).
"""

import math

import bpy
import numpy as np
import pytest

import exr_io
import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, SEEDS, SIGMAS, build, mean_and_variance, render

pytestmark = pytest.mark.needs_binary


def uniform_world(scene):
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.6, 0.7, 0.9, 1.0)
    bg.inputs["Strength"].default_value = 1.5
    scene.world = world


def hdri_world(tmp_path, rotation_z, colorspace=None):
    def setup(scene):
        w, h = 64, 32
        y = (np.arange(h) + 0.5) / h  # 0 at the image's top row
        sky = np.zeros((h, w, 3), dtype=np.float32)
        sky[..., 0] = 0.5 - 0.3 * y[:, None]
        sky[..., 1] = 0.7 - 0.4 * y[:, None]
        sky[..., 2] = 1.0 - 0.5 * y[:, None]
        # A bright sun patch, high in the sky and away from the image centre.
        sky[5:8, 10:13, :] = 400.0
        if colorspace == "sRGB":
            sky[5:8, 10:13, :] = 12.0  # decoded: about 390
        # Written with the tests' own EXR writer: Blender 5.0's Image.save() of a generated
        # float image stores values clipped at 12.75, which would test nothing.
        path = str(tmp_path / "sky.exr")
        exr_io.write_exr(path, {"R": sky[..., 0], "G": sky[..., 1], "B": sky[..., 2]})
        world = bpy.data.worlds.new("World")
        world.use_nodes = True
        nodes, links = world.node_tree.nodes, world.node_tree.links
        env = nodes.new("ShaderNodeTexEnvironment")
        env.image = bpy.data.images.load(path, check_existing=False)
        if colorspace is not None:
            env.image.colorspace_settings.name = colorspace
        mapping = nodes.new("ShaderNodeMapping")
        mapping.inputs["Rotation"].default_value = (0.0, 0.0, rotation_z)
        coords = nodes.new("ShaderNodeTexCoord")
        links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
        links.new(mapping.outputs["Vector"], env.inputs["Vector"])
        links.new(env.outputs["Color"], nodes["Background"].inputs["Color"])
        nodes["Background"].inputs["Strength"].default_value = 1.0
        scene.world = world
    return setup


def png_world(tmp_path, colorspace):
    """An 8-bit PNG panorama (a sky gradient, saved by Blender from a byte image: its bytes as
    set) read in `colorspace`: Non-Color, which Cycles reads undecoded and the renderer's own
    reading of an 8-bit file decodes as sRGB (0.6548 of Cycles here before)."""
    def setup(scene):
        w, h = 64, 32
        y = (np.arange(h) + 0.5) / h  # 0 at the bottom row (Blender's pixel order)
        px = np.ones((h, w, 4), dtype=np.float32)
        px[..., 0] = (0.3 + 0.5 * y)[:, None]
        px[..., 1] = (0.4 + 0.4 * y)[:, None]
        px[..., 2] = (0.9 - 0.2 * y)[:, None]
        made = bpy.data.images.new("Pano", w, h)
        made.pixels.foreach_set(px.ravel())
        path = str(tmp_path / "pano.png")
        made.filepath_raw, made.file_format = path, "PNG"
        made.save()
        world = bpy.data.worlds.new("World")
        world.use_nodes = True
        nodes, links = world.node_tree.nodes, world.node_tree.links
        env = nodes.new("ShaderNodeTexEnvironment")
        env.image = bpy.data.images.load(path, check_existing=False)
        env.image.colorspace_settings.name = colorspace
        links.new(env.outputs["Color"], nodes["Background"].inputs["Color"])
        scene.world = world
    return setup


@pytest.mark.parametrize("world", ["uniform", "hdri", "hdri_rotated", "hdri_srgb", "png_noncolor"])
def test_world_lighting_matches_cycles(empty_scene, tmp_path, world):
    scene = empty_scene
    setup = {"uniform": uniform_world, "hdri": hdri_world(tmp_path, 0.0),
             "hdri_rotated": hdri_world(tmp_path, math.radians(120.0)),
             "hdri_srgb": hdri_world(tmp_path, 0.0, "sRGB"), "png_noncolor": png_world(tmp_path, "Non-Color")}[world]
    build(scene, setup)
    images = {}
    for engine in ("CYCLES", "CAUSTIC"):
        images[engine] = [render(scene, engine, s, str(tmp_path / f"{engine}_{s}.exr")) for s in SEEDS]
    # The whole image, then each quadrant: the sun's shadow of the cube falls in one of
    # them, so a mirrored or wrongly rotated world fails a quadrant even if the mean agrees.
    h, w = images["CYCLES"][0].shape
    regions = {"all": (slice(0, h), slice(0, w))}
    for qy in range(2):
        for qx in range(2):
            regions[f"quadrant {qy}{qx}"] = (slice(qy * h // 2, (qy + 1) * h // 2), slice(qx * w // 2, (qx + 1) * w // 2))
    for region, (ys, xs) in regions.items():
        (m_caustic, v_caustic), (m_cycles, v_cycles) = (
            mean_and_variance(images[e][0][ys, xs], images[e][1][ys, xs]) for e in ("CAUSTIC", "CYCLES"))
        sigma = math.sqrt(v_caustic + v_cycles)
        bound = SIGMAS * sigma + MODEL_ALLOWANCE * m_cycles
        ratio = m_caustic / m_cycles
        print(f"\n[caustic/cycles] world {world:13s} {region:12s} ratio {ratio:.4f}  caustic {m_caustic:.5f}  "
              f"cycles {m_cycles:.5f}  sigma {sigma:.2e}  bound {bound:.2e}")
        assert m_cycles > 1e-3
        assert abs(m_caustic - m_cycles) <= bound, (
            f"world {world} {region}: Caustic/Cycles = {ratio:.4f}, difference {m_caustic - m_cycles:.3e} "
            f"exceeds {SIGMAS} sigma ({sigma:.2e}) + {MODEL_ALLOWANCE:.0%} model allowance")


def fog_world(scene):
    """World fog lit by a point light: the Background is black and the World Output's Volume
    is a Principled Volume (scattering with a little absorption, forward anisotropy), so the
    light reaches the floor attenuated and the air between glows with in-scattered light."""
    from test_cycles_agreement import add_point
    world = bpy.data.worlds.new("Fog")
    world.use_nodes = True
    nodes, links = world.node_tree.nodes, world.node_tree.links
    nodes["Background"].inputs["Strength"].default_value = 0.0
    volume = nodes.new("ShaderNodeVolumePrincipled")
    volume.inputs["Density"].default_value = 0.15
    volume.inputs["Color"].default_value = (0.9, 0.8, 0.7, 1.0)
    volume.inputs["Anisotropy"].default_value = 0.3
    links.new(volume.outputs["Volume"], nodes["World Output"].inputs["Volume"])
    scene.world = world
    add_point(scene)


def test_world_fog_matches_cycles(empty_scene, tmp_path):
    """Blender's World Volume through the add-on (`CAUSTIC_world.medium`) against Cycles, per
    colour channel (the fog is coloured), with test_cycles_agreement's derived bound."""
    from test_cycles_agreement import assert_mean_matches_cycles
    scene = empty_scene
    build(scene, fog_world)
    ratios = assert_mean_matches_cycles(scene, tmp_path, "world fog", MODEL_ALLOWANCE, per_channel=True)
    print(f"\n[caustic/cycles] world fog {ratios}")
