"""Caustic and Cycles agree on the world's own Ray Visibility (World > Ray Visibility, issue 20):
a world hidden from camera rays is not seen behind the scene, hidden from diffuse or glossy
rays it is not found by bounces of that kind and does not light that class of closures by
next-event estimation (Cycles' SHADER_EXCLUDE_* flags on the background shader).

Scene and bound as test_cycles_agreement.py (5 sigma of the two-seed estimate, block variance,
plus the 1 % model allowance derived there): its grey Lambertian floor and cube, lit by the
uniform world of test_world_agreement.py and the rectangle area light (so that hiding the world
from a kind of ray leaves an image Cycles does not render black). Each flag removes one
renderer-independent part of the light: hidden from diffuse rays the world lights nothing
diffuse (the rectangle alone lights the floor), hidden from glossy rays the cube, made a rough
metal, reflects no sky, hidden from the camera the sky behind the scene is black (the camera is
tilted to see the horizon). Each case also checks that the flag matters: Caustic's image with
the world seen by every ray differs from its image with the flag by more than the bound, so a
renderer ignoring the flag would fail.
"""

import math

import pytest

import scenes
from test_cycles_agreement import (MODEL_ALLOWANCE, SEEDS, SIGMAS, add_rectangle, assert_mean_matches_cycles,
                                   build, mean_and_variance)
from test_light_visibility import metal
from test_world_agreement import uniform_world

pytestmark = pytest.mark.needs_binary

CASES = ("camera", "diffuse", "glossy")


def caustic_mean(scene, tmp_path, label):
    """Caustic's two-seed image mean and its variance (test_cycles_agreement's estimate)."""
    a, b = (scenes.render_rgb(scene, "CAUSTIC", s, str(tmp_path / f"{label}_{s}.exr")).mean(axis=2) for s in SEEDS)
    return mean_and_variance(a, b)


@pytest.mark.parametrize("case", CASES)
def test_world_ray_visibility_matches_cycles(empty_scene, tmp_path, case):
    def world_and_light(scene):
        uniform_world(scene)
        add_rectangle(scene)
        if case == "glossy":
            scene.objects["Box"].data.materials[0] = metal("Metal")
        if case == "camera":
            # Looking at the cube from the side, the horizon in the upper third of the frame.
            scene.camera.location = (0.0, -6.0, 1.2)
            scene.camera.rotation_euler = (math.radians(80.0), 0.0, 0.0)
        setattr(scene.world.cycles_visibility, case, False)

    scene = empty_scene
    build(scene, world_and_light)
    ratios = assert_mean_matches_cycles(scene, tmp_path, f"world hidden from {case}", MODEL_ALLOWANCE)
    m_hidden, v_hidden = caustic_mean(scene, tmp_path, "hidden")
    setattr(scene.world.cycles_visibility, case, True)
    m_seen, v_seen = caustic_mean(scene, tmp_path, "seen")
    bound = SIGMAS * math.sqrt(v_hidden + v_seen) + MODEL_ALLOWANCE * m_hidden
    print(f"\n[caustic/cycles] world hidden from {case}: {ratios}; seen by every ray the mean moves by "
          f"{m_seen / m_hidden - 1.0:+.4f} (bound {bound / m_hidden:.4f})")
    assert abs(m_seen - m_hidden) > bound, f"{case}: the flag changes the image by less than the bound"
