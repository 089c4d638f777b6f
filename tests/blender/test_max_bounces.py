"""Caustic and Cycles agree on a light's and the world's Max Bounces (issue 20): past it Cycles'
next-event estimation leaves the light out (`light_select_reached_max_bounces`: the path's
bounce count above the limit), while rays that find the light keep their MIS weight.

Scene and bound as test_cycles_agreement.py (5 sigma of the two-seed estimate, block variance,
plus the 1 % model allowance derived there): its grey floor and light cube, closed above by a
grey ceiling (albedo 0.8) over the lights, so that light bounces between floor and ceiling and
the limit removes a large share of it: a point light (radius 0, light sampling alone) with Max
Bounces 0 (direct light only) and 1, and a world (no lamp) with Max Bounces 1, whose light
comes in between floor and ceiling. The world is a Gradient Texture: Cycles samples a world as
a light only where it varies (or has portals), so a constant world's Max Bounces changes
nothing in Cycles (measured: 0.19504 with 0, 1 and 1024), nor in Caustic, whose loader then
leaves the limit out. Each case also checks that the limit matters: Caustic's image
with the limit lifted (Cycles' default 1024, which is what the renderer rendered before it read
the limit) differs from its image with the limit by more than the bound; that before figure is
printed as a Caustic/Cycles ratio beside the after one.
"""

import math

import bpy

import pytest

import scenes
from test_cycles_agreement import (MODEL_ALLOWANCE, SEEDS, SIGMAS, assert_mean_matches_cycles, build,
                                   mean_and_variance)

pytestmark = pytest.mark.needs_binary

UNLIMITED = 1024


def ceiling(scene):
    """A grey ceiling above the lights (the agreement scene's lights sit at z = 3.5)."""
    scenes.plane(scene, "Ceiling", 10.0, z=4.5, material=scenes.diffuse_material("Ceiling", 0.8))


def point(scene):
    ceiling(scene)
    scenes.light(scene, "Point", "POINT", location=(0.4, -0.3, 3.5), energy=400.0, shadow_soft_size=0.0)
    return scene.objects["Point"].data


def world(scene):
    ceiling(scene)
    sky = bpy.data.worlds.new("Sky")
    sky.use_nodes = True
    background = sky.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (0.5, 0.5, 0.5, 1.0)
    background.inputs["Strength"].default_value = 1.0
    # Cycles samples a world as a light only where it varies over directions (a constant colour
    # is found by BSDF-sampled rays alone, which the limit never stops): a Gradient Texture
    # (over the direction, the world's default coordinates) makes it vary.
    gradient = sky.node_tree.nodes.new("ShaderNodeTexGradient")
    sky.node_tree.links.new(gradient.outputs["Color"], background.inputs["Color"])
    scene.world = sky
    return sky


CASES = {"point_0": (point, 0), "point_1": (point, 1), "world_1": (world, 1)}


def caustic_mean(scene, tmp_path, label):
    """Caustic's two-seed image mean and its variance (test_cycles_agreement's estimate)."""
    a, b = (scenes.render_rgb(scene, "CAUSTIC", s, str(tmp_path / f"{label}_{s}.exr")).mean(axis=2) for s in SEEDS)
    return mean_and_variance(a, b)


@pytest.mark.parametrize("case", list(CASES))
def test_max_bounces_matches_cycles(empty_scene, tmp_path, case):
    add, bounces = CASES[case]
    limited = []

    def light_and_limit(scene):
        datablock = add(scene)
        datablock.cycles.max_bounces = bounces
        limited.append(datablock)

    scene = empty_scene
    build(scene, light_and_limit)
    ratios = assert_mean_matches_cycles(scene, tmp_path, f"max bounces {case}", MODEL_ALLOWANCE, per_channel=True)
    m_limited, v_limited = caustic_mean(scene, tmp_path, "limited")
    limited[0].cycles.max_bounces = UNLIMITED
    m_whole, v_whole = caustic_mean(scene, tmp_path, "whole")
    bound = SIGMAS * math.sqrt(v_limited + v_whole) + MODEL_ALLOWANCE * m_limited
    after = sum(ratios.values()) / len(ratios)
    print(f"\n[caustic/cycles] max bounces {case}: before (limit not read) {after * m_whole / m_limited:.4f} "
          f"-> after {ratios}")
    assert abs(m_whole - m_limited) > bound, f"{case}: the limit changes the image by less than the bound"
