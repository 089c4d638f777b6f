"""Caustic and Cycles frame Blender's panoramic cameras alike (the glTF exporter writes no
camera for them: the add-on sends them in `CAUSTIC_camera.panorama`, docs/contract.md).

Before this test the exporter left the camera out and the render failed ("unknown camera").
Scene: three emissive cubes around the camera, one pure red (ahead and to the left, low),
one pure green (to the right, high), one pure blue (behind and to the left), and a dim grey
world, so that each colour channel is the image of one cube plus the world, and a wrong axis,
handedness, range or shift moves a cube's centroid. Where a fisheye or a mirror ball sees
nothing (outside its circle) Cycles gives black: with a visible world, drawing the world
there would raise the mean.

What is compared, per channel: the mean and the centroid (x, y) in pixels, of the mean of two
seeds per renderer. The tolerance is derived as in test_camera_agreement.py: the two seeds give
each statistic's standard error (|a - b| / 2 is one draw of the mean's deviation; the centroid's
two components pooled), the bound is 5 sigma of the difference plus a model allowance of 1 % of
the mean (sample patterns and filter tables, as in test_cycles_agreement.py) and 0.1 px on a
centroid (a tenth of the one-pixel misplacement that a wrong mapping gives at least).
"""

import math

import bpy
import numpy as np
import pytest

import scenes

pytestmark = pytest.mark.needs_binary

SAMPLES = 32
SEEDS = (1, 2)
SIGMAS = 5.0
W, H = 64, 48


def build(scene):
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    for name, center, size, color in [
        ("Red", (-1.5, 3.0, -0.6), 1.0, (1.0, 0.0, 0.0)),
        ("Green", (2.5, -0.5, 1.2), 0.8, (0.0, 1.0, 0.0)),
        ("Blue", (-1.0, -2.5, 0.3), 1.2, (0.0, 0.0, 1.0)),
    ]:
        scenes.cube(scene, name, size, center, material=scenes.emission_material(name, color, 3.0))
    world = bpy.data.worlds.new("World")
    if world.node_tree is None:  # Blender < 5.0 creates worlds without nodes
        world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.05, 0.05, 0.05, 1.0)
    scene.world = world
    # Looking along +Y (rotation 90° about X), slightly turned so that left and right differ.
    cam = scenes.camera(scene, (0.0, 0.0, 0.0), (90.0, 5.0, 0.0))
    cam.data.type = "PANO"
    scenes.match_cycles(scene, SAMPLES, 1)
    return cam.data


def equirectangular(cam):
    cam.panorama_type = "EQUIRECTANGULAR"


def equirectangular_ranges_shift(cam):
    cam.panorama_type = "EQUIRECTANGULAR"
    cam.longitude_min, cam.longitude_max = math.radians(-150.0), math.radians(100.0)
    cam.latitude_min, cam.latitude_max = math.radians(-60.0), math.radians(75.0)
    cam.shift_x, cam.shift_y = 0.05, -0.04


def fisheye_equidistant(cam):
    cam.panorama_type = "FISHEYE_EQUIDISTANT"
    cam.fisheye_fov = math.radians(200.0)


def fisheye_equisolid(cam):
    cam.panorama_type = "FISHEYE_EQUISOLID"
    cam.fisheye_lens = 8.0
    cam.fisheye_fov = math.radians(180.0)


def fisheye_equisolid_vertical_fit(cam):
    fisheye_equisolid(cam)
    cam.sensor_fit = "VERTICAL"
    cam.sensor_height = 20.0


def fisheye_polynomial(cam):
    cam.panorama_type = "FISHEYE_LENS_POLYNOMIAL"
    cam.fisheye_fov = math.radians(190.0)


def mirrorball(cam):
    cam.panorama_type = "MIRRORBALL"


def central_cylindrical(cam):
    cam.panorama_type = "CENTRAL_CYLINDRICAL"
    cam.central_cylindrical_range_v_min, cam.central_cylindrical_range_v_max = -0.8, 1.2
    cam.central_cylindrical_radius = 1.5


def cubemap_face(cam):
    cam.panorama_type = "EQUIANGULAR_CUBEMAP_FACE"


def fisheye_depth_of_field(cam):
    fisheye_equidistant(cam)
    cam.dof.use_dof = True
    cam.dof.focus_distance = 3.0
    cam.dof.aperture_fstop = 0.05
    cam.dof.aperture_blades = 5


CASES = {f.__name__: f for f in (equirectangular, equirectangular_ranges_shift, fisheye_equidistant,
                                 fisheye_equisolid, fisheye_equisolid_vertical_fit, fisheye_polynomial,
                                 mirrorball, central_cylindrical, cubemap_face, fisheye_depth_of_field)}


def statistics(img):
    """Mean and centroid (x, y) in pixels of one channel."""
    h, w = img.shape
    y, x = np.mgrid[0:h, 0:w] + 0.5
    total = img.sum()
    return {"mean": img.mean(), "cx": (img * x).sum() / total, "cy": (img * y).sum() / total}


@pytest.mark.parametrize("case", list(CASES))
def test_panoramic_camera_matches_cycles(empty_scene, tmp_path, case):
    scene = empty_scene
    CASES[case](build(scene))
    images = {engine: [scenes.render_rgb(scene, engine, s, str(tmp_path / f"{engine}_{s}.exr")) for s in SEEDS]
              for engine in ("CYCLES", "CAUSTIC")}
    failures = []
    for channel, cube in enumerate(("red", "green", "blue")):
        stats = {}
        for engine, (a, b) in images.items():
            a, b = a[..., channel], b[..., channel]
            sa, sb, sm = statistics(a), statistics(b), statistics(0.5 * (a + b))
            stats[engine] = {k: (sm[k], abs(sa[k] - sb[k]) / 2.0) for k in sm}
        m_cycles = stats["CYCLES"]["mean"][0]
        assert m_cycles > 1e-3, f"{case}: Cycles' {cube} channel is black: the scene is broken"
        allowance = {"mean": 0.01 * m_cycles, "cx": 0.1, "cy": 0.1}
        groups = {"mean": ["mean"], "cx": ["cx", "cy"], "cy": ["cx", "cy"]}
        for k in allowance:
            ours, theirs = stats["CAUSTIC"][k][0], stats["CYCLES"][k][0]
            var = sum(stats[e][g][1] ** 2 for e in stats for g in groups[k]) / len(groups[k])
            bound = SIGMAS * math.sqrt(var) + allowance[k]
            print(f"\n[caustic/cycles] {case:30s} {cube:5s} {k:4s} caustic {ours:9.4f} cycles {theirs:9.4f} "
                  f"diff {ours - theirs:+.4f} bound {bound:.4f}")
            if abs(ours - theirs) > bound:
                failures.append(f"{cube} {k}: Caustic {ours:.4f} vs Cycles {theirs:.4f} (bound {bound:.4f})")
    assert not failures, f"{case}: " + "; ".join(failures)
