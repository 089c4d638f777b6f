"""Caustic and Cycles agree on per-object Ray Visibility (issue 20).

Scene and bound as test_cycles_agreement.py (a grey floor and a lighter cube under a point
light, seen from above; 5 sigma of the two-seed estimate, block variance, plus the 1 % model
allowance derived there). The cube is hidden in turn from the camera (the floor shows through
it, its shadow stays), from shadow rays (it shows, its shadow goes), from diffuse rays (the
light it bounces onto the floor goes; the light then sits low beside the cube, so that this
bounce is 19 % of the image) and from both camera and shadow rays. Each case also
checks that the flag matters: Caustic's image with the cube seen by every ray differs from
Cycles' by more than the bound, so a renderer ignoring the flag would fail.

The cube is lifted 2 cm off the floor: its bottom face would otherwise lie in the floor's
plane, where which of two coincident faces a ray finds is up to each renderer's
self-intersection rule (with it on the floor and hidden from camera and shadow rays, the
floor inside it sees its lit inner faces: Caustic/Cycles was 1.0100).
"""

import math

import pytest

import scenes
from test_cycles_agreement import (MODEL_ALLOWANCE, SEEDS, SIGMAS, add_point, assert_mean_matches_cycles, build,
                                   mean_and_variance)

pytestmark = pytest.mark.needs_binary

FLAGS = {
    "camera": ("visible_camera",),
    "shadow": ("visible_shadow",),
    "diffuse": ("visible_diffuse",),
    "camera_and_shadow": ("visible_camera", "visible_shadow"),
}


def caustic_mean(scene, tmp_path, label):
    """Caustic's two-seed image mean and its variance (test_cycles_agreement's estimate)."""
    a, b = (scenes.render_rgb(scene, "CAUSTIC", s, str(tmp_path / f"{label}_{s}.exr")).mean(axis=2) for s in SEEDS)
    return mean_and_variance(a, b)


@pytest.mark.parametrize("case", list(FLAGS))
def test_ray_visibility_matches_cycles(empty_scene, tmp_path, case):
    def light_and_flags(scene):
        add_point(scene)
        if case == "diffuse":
            # Low beside the cube: its lit side bounces enough light onto the floor to matter.
            scene.objects["Point"].location = (1.2, -0.2, 0.6)
        scene.objects["Box"].location.z += 0.02
        for flag in FLAGS[case]:
            setattr(scene.objects["Box"], flag, False)

    scene = empty_scene
    build(scene, light_and_flags)
    ratios = assert_mean_matches_cycles(scene, tmp_path, f"hidden from {case}", MODEL_ALLOWANCE)
    m_hidden, v_hidden = caustic_mean(scene, tmp_path, "hidden")
    for flag in FLAGS[case]:
        setattr(scene.objects["Box"], flag, True)
    m_seen, v_seen = caustic_mean(scene, tmp_path, "seen")
    # Against Caustic's hidden image (equal to Cycles' within the bound just checked).
    bound = SIGMAS * math.sqrt(v_hidden + v_seen) + MODEL_ALLOWANCE * m_hidden
    print(f"\n[caustic/cycles] box hidden from {case}: {ratios}; seen by every ray the mean moves by "
          f"{m_seen / m_hidden - 1.0:+.4f} (bound {bound / m_hidden:.4f})")
    assert abs(m_seen - m_hidden) > bound, f"{case}: the flag changes the image by less than the bound"
