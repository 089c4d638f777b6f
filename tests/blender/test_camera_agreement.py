"""Caustic and Cycles frame and blur the same .blend alike: lens shift, depth of field, and the
Film panel's Exposure and Pixel Filter.

Blender's glTF exporter drops both; the add-on sends them in `CAUSTIC_camera` (docs/contract.md).
Scene: three emissive cubes at three depths (in front of, at and behind the plane in focus),
one pure red, one pure green, one pure blue, on black: no lights, no world, so each colour
channel is the image of one cube and has no noise besides the lens's and the pixel filter's.

What is compared, per channel (per cube), on the two renderers' images (each the mean of two
seeds): the mean, the centroid (x, y) and the second central moments (xx, yy) in pixels. A
shift of the frame moves the centroids; the blur of the depth of field adds to the second
moments (the blurred image is the sharp one convolved with the aperture's image), by an
amount that depends on the cube's depth, so a wrong aperture size, shape or focus distance
changes them.
How the tolerance is derived: for each statistic, the two seeds of a renderer give its
standard error (|a - b| / 2 is one draw of the mean's deviation, pooled over the statistic's
components); the bound is 5 sigma of the difference plus a model allowance: 1 % of the mean
(sample patterns and filter tables, as in test_cycles_agreement.py), 0.05 px on a centroid
(a third of the smallest shift error that matters: a frame misplaced by one pixel in 64) and
2 % on a second moment (Blackman-Harris is tabulated by Cycles, evaluated by Caustic).
The figures are printed with -s for the closing note.
"""

import math

import bpy
import numpy as np
import pytest

import scenes

pytestmark = pytest.mark.needs_binary

SAMPLES = 64
SEEDS = (1, 2)
SIGMAS = 5.0


def build(scene, width, height):
    scenes.small_render_settings(scene, width, height, samples=SAMPLES)
    for name, center, size, color in [
        ("Near", (-0.3, 0.12, 2.0), 0.2, (1.0, 0.0, 0.0)),
        ("Mid", (0.15, -0.1, 0.0), 0.3, (0.0, 1.0, 0.0)),
        ("Far", (0.4, 0.35, -3.0), 0.5, (0.0, 0.0, 1.0)),
    ]:
        scenes.cube(scene, name, size, center, material=scenes.emission_material(name, color, 4.0))
    cam = scenes.camera(scene, (0.0, 0.0, 6.0), (0.0, 0.0, 0.0), lens=100.0)
    scenes.match_cycles(scene, SAMPLES, 1)
    return cam


def shift(cam, scene):
    cam.data.shift_x, cam.data.shift_y = -0.1, 0.08


def shift_vertical_fit(cam, scene):
    shift(cam, scene)
    cam.data.sensor_fit = "VERTICAL"
    cam.data.sensor_height = 20.0


def dof_round(cam, scene):
    d = cam.data.dof
    d.use_dof = True
    d.focus_distance = 6.0  # the middle cube; the blur of the others is several pixels
    d.aperture_fstop = 0.1


def dof_blades_focus_object(cam, scene):
    d = cam.data.dof
    d.use_dof = True
    target = bpy.data.objects.new("FocusTarget", None)
    target.location = (0.5, -0.4, 2.0)  # the near cube's depth, off axis: the axial distance counts
    scene.collection.objects.link(target)
    d.focus_object = target
    d.aperture_fstop = 0.12
    d.aperture_blades = 5
    d.aperture_rotation = math.radians(20.0)
    d.aperture_ratio = 1.6
    shift(cam, scene)


def ortho_shift_dof(cam, scene):
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 1.6
    shift(cam, scene)
    d = cam.data.dof
    d.use_dof = True
    d.focus_distance = 6.0
    d.aperture_fstop = 2.0  # an orthographic aperture's radius is 1 / (2 f-stop) (Cycles)


def ortho_vertical_fit(cam, scene):
    """Sensor Fit Vertical: Cycles fits the Orthographic Scale to the frame's height, where
    Blender's glTF exporter fits it to the longer side. Before: the view was narrower by 4/3
    (the mid cube's mean 0.1874 against Cycles' 0.1054, centroids off by up to 4 px); after:
    0.1055, every statistic within its bound."""
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 1.6
    cam.data.sensor_fit = "VERTICAL"
    shift(cam, scene)


def ortho_horizontal_fit_portrait(cam, scene):
    """Sensor Fit Horizontal on a portrait frame: the scale along the (shorter) width. Before:
    mid cube 0.1875 against 0.1054; after 0.1054."""
    ortho_vertical_fit(cam, scene)
    cam.data.sensor_fit = "HORIZONTAL"


def film_exposure(cam, scene):
    """The Film panel's Exposure, a factor on the image (Cycles' film_exposure). Before: not
    applied, Caustic/Cycles mean 0.589 (1 / 1.7) on every cube; after: 1.000-1.002."""
    scene.cycles.film_exposure = 1.7


def small_cubes(cam, scene):
    """A 16 mm lens: the cubes span about a pixel, so the filter decides their second moments;
    more samples, as so few lit pixels make the moments noisy (still under a second a render)."""
    cam.data.lens = 16.0
    scene.caustic.samples = scene.cycles.samples = 8 * SAMPLES


def filter_box(cam, scene):
    """Cycles' Box pixel filter (always one pixel wide). Before: the add-on always sent
    Blackman-Harris over twice render.filter_size (a setting Cycles ignores): the far cube's
    xx was 0.4076 against Cycles' 0.3279; after: 0.3269."""
    small_cubes(cam, scene)
    scene.cycles.pixel_filter_type = "BOX"


def filter_gaussian_wide(cam, scene):
    """Cycles' Gaussian over 3 x Filter Width 2.5 (standard deviation 0.625 px). Before: the
    add-on sent Blackman-Harris over 3 px (far cube xx 0.4076 vs Cycles' 0.6286; after 0.6233)."""
    small_cubes(cam, scene)
    scene.cycles.pixel_filter_type = "GAUSSIAN"
    scene.cycles.filter_width = 2.5


def filter_blackman_harris_wide(cam, scene):
    """Blackman-Harris with Filter Width 3 (a 6 px window). Before: the add-on read
    render.filter_size (1.5): far cube xx 0.4076 vs Cycles' 0.9213 (after: 0.9191)."""
    small_cubes(cam, scene)
    scene.cycles.filter_width = 3.0


CASES = {
    "shift_landscape": (64, 48, shift),
    "shift_portrait": (48, 64, shift),
    "shift_vertical_fit": (64, 48, shift_vertical_fit),
    "dof_round": (64, 48, dof_round),
    "dof_blades_focus_object": (64, 48, dof_blades_focus_object),
    "ortho_shift_dof": (64, 48, ortho_shift_dof),
    "ortho_vertical_fit": (64, 48, ortho_vertical_fit),
    "ortho_horizontal_fit_portrait": (48, 64, ortho_horizontal_fit_portrait),
    "film_exposure": (64, 48, film_exposure),
    "filter_box": (64, 48, filter_box),
    "filter_gaussian_wide": (64, 48, filter_gaussian_wide),
    "filter_blackman_harris_wide": (64, 48, filter_blackman_harris_wide),
}


def statistics(img):
    """Mean, centroid (x, y) and second central moments (xx, yy), in pixels, of one channel."""
    h, w = img.shape
    y, x = np.mgrid[0:h, 0:w] + 0.5
    total = img.sum()
    cx, cy = (img * x).sum() / total, (img * y).sum() / total
    xx = (img * (x - cx) ** 2).sum() / total
    yy = (img * (y - cy) ** 2).sum() / total
    return {"mean": img.mean(), "cx": cx, "cy": cy, "xx": xx, "yy": yy}


@pytest.mark.parametrize("case", list(CASES))
def test_camera_matches_cycles(empty_scene, tmp_path, case):
    scene = empty_scene
    width, height, setup = CASES[case]
    cam = build(scene, width, height)
    setup(cam, scene)
    images = {}
    for engine in ("CYCLES", "CAUSTIC"):
        images[engine] = [scenes.render_rgb(scene, engine, s, str(tmp_path / f"{engine}_{s}.exr")) for s in SEEDS]
    failures = []
    for channel, cube in enumerate(("near", "mid", "far")):
        stats = {}
        for engine, (a, b) in images.items():
            a, b = a[..., channel], b[..., channel]
            sa, sb, sm = statistics(a), statistics(b), statistics(0.5 * (a + b))
            stats[engine] = {k: (sm[k], abs(sa[k] - sb[k]) / 2.0) for k in sm}
        assert stats["CYCLES"]["mean"][0] > 1e-3, f"the {cube} cube is not in Cycles' frame: the scene is broken"
        allowance = {"mean": 0.01 * stats["CYCLES"]["mean"][0], "cx": 0.05, "cy": 0.05,
                     "xx": 0.02 * stats["CYCLES"]["xx"][0], "yy": 0.02 * stats["CYCLES"]["yy"][0]}
        # Pool the seeds' deviations over the centroid's and over the moments' components
        # (one draw alone is a poor variance estimate).
        groups = {"mean": ["mean"], "cx": ["cx", "cy"], "cy": ["cx", "cy"], "xx": ["xx", "yy"],
                  "yy": ["xx", "yy"]}
        for k, (m_cycles, _) in stats["CYCLES"].items():
            m_caustic = stats["CAUSTIC"][k][0]
            var = sum(stats[e][g][1] ** 2 for e in stats for g in groups[k]) / len(groups[k])
            bound = SIGMAS * math.sqrt(var) + allowance[k]
            print(f"\n[caustic/cycles] {case:24s} {cube:4s} {k:4s} caustic {m_caustic:9.4f} "
                  f"cycles {m_cycles:9.4f} diff {m_caustic - m_cycles:+.4f} bound {bound:.4f}")
            if abs(m_caustic - m_cycles) > bound:
                failures.append(f"{cube} {k}: Caustic {m_caustic:.4f} vs Cycles {m_cycles:.4f} (bound {bound:.4f})")
    assert not failures, f"{case}: " + "; ".join(failures)
