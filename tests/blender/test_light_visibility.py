"""Caustic and Cycles agree on a light's own Ray Visibility beyond Camera (issue 20): a light
hidden from diffuse or glossy rays is not found by bounces of that kind and does not light
that class of closures by next-event estimation (Cycles' SHADER_EXCLUDE_* flags).

Scene and bound as test_cycles_agreement.py (5 sigma of the two-seed estimate, block
variance, plus the 1 % model allowance derived there): its grey Lambertian floor and the
rectangle area light, with the cube made a rough metal (a pure glossy closure), so that each
flag removes one renderer-independent part of the light: hidden from diffuse rays the light
reaches the floor only through the metal cube (its reflection), hidden from glossy rays the
cube shows no highlight of it. Each case also checks that the flag matters: Caustic's image
with the light seen by every ray differs from its image with the flag by more than the bound,
so a renderer ignoring the flag would fail.
"""

import math

import bpy

import pytest

import scenes
from test_cycles_agreement import (MODEL_ALLOWANCE, SEEDS, SIGMAS, add_rectangle, assert_mean_matches_cycles,
                                   build, mean_and_variance)

pytestmark = pytest.mark.needs_binary

FLAGS = {"diffuse": "visible_diffuse", "glossy": "visible_glossy"}


def metal(name):
    """A rough metal: one glossy closure in Cycles, the glTF metal in Caustic."""
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:  # Blender < 5.0 creates materials without nodes
        mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.9, 0.9, 0.9, 1.0)
    bsdf.inputs["Metallic"].default_value = 1.0
    bsdf.inputs["Roughness"].default_value = 0.3
    return mat


def caustic_mean(scene, tmp_path, label):
    """Caustic's two-seed image mean and its variance (test_cycles_agreement's estimate)."""
    a, b = (scenes.render_rgb(scene, "CAUSTIC", s, str(tmp_path / f"{label}_{s}.exr")).mean(axis=2) for s in SEEDS)
    return mean_and_variance(a, b)


@pytest.mark.parametrize("case", list(FLAGS))
def test_light_ray_visibility_matches_cycles(empty_scene, tmp_path, case):
    def light_and_flag(scene):
        add_rectangle(scene)
        box = scene.objects["Box"]
        box.data.materials[0] = metal("Metal")
        setattr(scene.objects["Rect"], FLAGS[case], False)

    scene = empty_scene
    build(scene, light_and_flag)
    ratios = assert_mean_matches_cycles(scene, tmp_path, f"light hidden from {case}", MODEL_ALLOWANCE)
    m_hidden, v_hidden = caustic_mean(scene, tmp_path, "hidden")
    setattr(scene.objects["Rect"], FLAGS[case], True)
    m_seen, v_seen = caustic_mean(scene, tmp_path, "seen")
    # Against Caustic's image with the flag (equal to Cycles' within the bound just checked).
    bound = SIGMAS * math.sqrt(v_hidden + v_seen) + MODEL_ALLOWANCE * m_hidden
    print(f"\n[caustic/cycles] light hidden from {case}: {ratios}; seen by every ray the mean moves by "
          f"{m_seen / m_hidden - 1.0:+.4f} (bound {bound / m_hidden:.4f})")
    assert abs(m_seen - m_hidden) > bound, f"{case}: the flag changes the image by less than the bound"
