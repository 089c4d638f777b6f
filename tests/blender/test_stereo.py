"""Stereoscopy (Output > Stereoscopy, Stereo 3D) against Cycles: each eye through its own camera.

Blender's render result holds a left and a right view; before, Caustic rendered one image and
loaded it into neither (Blender: "expected channel Combined.left.R not found"), so both views
came out black. Now each view is exported with the eye's camera as Blender computes it for
Cycles (`RenderEngine.camera_model_matrix`, `camera_shift_x`) and written under the view's
channel names (`--view`). A cube on a plane under a sun, interocular distance 0.4 m,
convergence 4 m, in the three convergence modes (Off-Axis shifts the lens, Toe-in turns the
eye, Parallel does neither).

Bound: each view's image is split into four vertical strips (a wrong eye offset moves the cube
from strip to strip), and each strip's mean is compared as test_cycles_agreement compares an
image's: 5 sigma of the two renderers' two-seed noise (8x8 blocks) plus the 1 % model allowance.
Measured (bpy 5.0.1, 48x36, 16 spp): means 0.9993-1.0005 of Cycles in every mode and eye, the
brightness centroid within 0.01 px of Cycles'.
"""

import glob
import math
import os

import bpy
import pytest

import scenes
from test_cycles_agreement import SEEDS, SIGMAS, mean_and_variance

pytestmark = pytest.mark.needs_binary

W, H, SAMPLES = 48, 36, 16
ALLOWANCE = 0.01  # the model allowance of test_cycles_agreement (same scene content)
STRIPS = 4


def _views(scene, engine, seed, tmp_path):
    """Both eyes' RGB (rows bottom to top) of one render."""
    scene.render.engine = engine
    if engine == "CYCLES":
        scene.cycles.seed = seed
    else:
        scene.caustic.seed = seed
    stem = str(tmp_path / f"{engine}_{seed}_")
    scene.render.filepath = stem
    bpy.ops.render.render(write_still=True)
    out = {}
    for view, suffix in (("left", "_L"), ("right", "_R")):
        (path,) = glob.glob(f"{stem}*{suffix}.exr")
        out[view] = scenes.load_pixels(path)[..., :3].mean(axis=2)
        os.remove(path)
    return out


@pytest.mark.parametrize("mode", ["OFFAXIS", "TOE", "PARALLEL"])
def test_stereo_views_match_cycles(addon, empty_scene, tmp_path, mode):
    scene = empty_scene
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    scenes.match_cycles(scene, SAMPLES, 2)
    scenes.plane_and_cube_scene(scene)
    scenes.light(scene, "Sun", "SUN", rotation_deg=(30, 10, 0), energy=3)
    scene.render.use_multiview = True
    scene.render.views_format = "STEREO_3D"
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.views_format = "INDIVIDUAL"
    stereo = scene.camera.data.stereo
    stereo.convergence_mode = mode
    stereo.interocular_distance = 0.4
    stereo.convergence_distance = 4.0
    images = {engine: [_views(scene, engine, s, tmp_path) for s in SEEDS] for engine in ("CYCLES", "CAUSTIC")}
    failures = []
    for view in ("left", "right"):
        for strip in range(STRIPS):
            cols = slice(strip * W // STRIPS, (strip + 1) * W // STRIPS)
            (m_ca, v_ca), (m_cy, v_cy) = (mean_and_variance(a[view][:, cols], b[view][:, cols])
                                          for a, b in (images["CAUSTIC"], images["CYCLES"]))
            sigma = math.sqrt(v_ca + v_cy)
            bound = SIGMAS * sigma + ALLOWANCE * m_cy
            print(f"\n[caustic/cycles] stereo {mode} {view} strip {strip}: ratio {m_ca / m_cy:.4f} "
                  f"sigma {sigma:.2e} bound {bound:.2e}")
            assert m_cy > 1e-3, "the Cycles reference is black: the scene is broken"
            if abs(m_ca - m_cy) > bound:
                failures.append(f"{view} strip {strip}: Caustic/Cycles {m_ca / m_cy:.4f}")
    assert not failures, f"{mode}: " + "; ".join(failures)
