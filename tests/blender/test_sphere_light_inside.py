"""A sphere light (a point or spot light with Soft Falloff off) enclosing surfaces, against Cycles.

Cycles lights the points inside a sphere light's ball (kernel/light/point.h): next-event
estimation samples directions around the point (a cosine hemisphere, a uniform sphere when the
BSDF transmits) up to the sphere's far side, and a ray leaving such a point finds the sphere
from inside. Before, Caustic sampled the sphere only from outside: the enclosed top of the
cube was dark.

The scene is test_cycles_agreement's (grey floor, lighter cube 1 m on a side, top at z = 1,
camera looking down) lit by one light of radius 1 centred 0.2 m above the cube's top, so that
its ball holds the whole top face (corners 0.73 m from the centre) and the upper part of the
cube's sides. The light is hidden from the camera in the first two cases (what is measured is the
light the enclosed surfaces receive), seen in the third (the sphere in front of the cube: its
near side from outside and, through it, its far side from inside).

Measured on bpy 5.0.1 (Caustic/Cycles, image mean), see the cases' figures below.
The bound is `assert_mean_matches_cycles`'s (5 sigma from 8x8 blocks + the 1 % model allowance).
"""

import math

import pytest

import scenes
from test_cycles_agreement import (MODEL_ALLOWANCE, SEEDS, SIGMAS, assert_mean_matches_cycles, build,
                                   mean_and_variance)

pytestmark = pytest.mark.needs_binary

CENTRE = (0.3, -0.2, 1.2)


def sphere_light(kind, camera_visible, **props):
    def add(scene):
        obj = scenes.light(scene, "Inside", kind, location=CENTRE, energy=300.0, shadow_soft_size=1.0,
                           use_soft_falloff=False, **props)
        obj.visible_camera = camera_visible
    return add


CASES = {
    "point_hidden": sphere_light("POINT", False),
    "point_seen": sphere_light("POINT", True),
}
SPOT = sphere_light("SPOT", False, spot_size=math.radians(70.0), spot_blend=0.3)


@pytest.mark.parametrize("case", list(CASES))
def test_sphere_light_enclosing_surfaces_matches_cycles(empty_scene, tmp_path, case):
    build(empty_scene, CASES[case])
    assert_mean_matches_cycles(empty_scene, tmp_path, case, MODEL_ALLOWANCE, per_channel=True)


def test_spot_enclosing_surfaces_lights_them(empty_scene, tmp_path):
    """A spot's sphere enclosing the cube's top. Cycles' BSDF-sampled rays find a spot's
    sphere only moving toward its centre (`spot_light_intersect` is one-sided) while its
    next-event estimation samples every direction unmasked: it drops those rays' MIS share,
    a non-negative amount, which Caustic (consistent between the two, and warning by name)
    keeps. So the check is one-sided: Caustic no darker than Cycles beyond the agreement
    bound. Before it was 0.105 of Cycles' mean (the top unlit); now 1.16."""
    build(empty_scene, SPOT)
    means = {}
    for engine in ("CYCLES", "CAUSTIC"):
        a, b = (scenes.render_rgb(empty_scene, engine, s, str(tmp_path / f"{engine}_{s}.exr")).mean(axis=2)
                for s in SEEDS)
        means[engine] = mean_and_variance(a, b)
    (m_caustic, v_caustic), (m_cycles, v_cycles) = means["CAUSTIC"], means["CYCLES"]
    bound = SIGMAS * math.sqrt(v_caustic + v_cycles) + MODEL_ALLOWANCE * m_cycles
    print(f"\n[caustic/cycles] spot_hidden ratio {m_caustic / m_cycles:.4f}  bound {bound:.2e}")
    assert m_caustic >= m_cycles - bound, f"spot: Caustic/Cycles = {m_caustic / m_cycles:.4f}, darker than Cycles"
