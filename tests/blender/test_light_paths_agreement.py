"""Caustic renders Cycles' Light Paths panel (issue 20): the per-kind bounce limits and the
sample clamps, read from `scene.cycles` by the add-on, agree with Cycles.

Each case sets one Light Paths setting in the .blend (Cycles' own properties: Caustic's panel
draws them) and checks the image means as test_cycles_agreement.py derives its bound (5 sigma
of the two-seed estimate, block variance, plus the 1 % model allowance derived there). Each
case also renders Caustic with the setting at its neutral value — what main's add-on and binary
rendered, since they ignored it — prints that "before" figure as a Caustic/Cycles ratio beside
the "after" one, and checks that the setting matters: the two Caustic images differ by more
than the bound.

Cases:
* room_defaults: a closed grey room (albedo 0.8) lit by a point light, with Cycles' default
  Light Paths (Max 12, Diffuse 4, Glossy 4, Transmission 12, Volume 0, Transparent 8, Clamp
  Indirect 10, Filter Glossy 1 — no glossy closure here, so the filter changes nothing):
  Diffuse 4 ends paths that bounce on; before, Caustic bounced 12 times.
* glossy_1: a rough metal floor and a rough metal ceiling above the light, Glossy Bounces 1.
* transmission_2: an emissive floor seen through two stacked glass cubes (four crossings),
  Transmission Bounces 2.
* volume_0, volume_2: a scattering cube (Volume Scatter, albedo 0.95) on the floor, Volume
  Bounces 0 (single scattering) and 2.
* filter_glossy: the agreement scene under a smooth metal ceiling, Filter Glossy 1 (Cycles'
  default): after the floor's diffuse bounce the mirror is blurred, so next-event estimation
  there finds the point light, which no path finds off a delta mirror.
* clamp_direct, clamp_indirect: the agreement scene (diffuse floor and cube under a point light)
  under a grey ceiling, at Max Bounces 1, with Clamp Direct 0.3 or Clamp Indirect 0.5.

Why the clamp cases are meaningful: a clamp is a non-linear function of each sample's
contribution, so two renderers' clamped means agree only if their per-sample contributions have
the same distribution, not merely the same mean. Here they do: with one point light (chosen with
probability 1, a delta light: next-event estimation alone, no MIS) and Lambertian surfaces
sampled by the cosine (throughput after a bounce = the albedo exactly, in both), a direct
contribution is a fixed function of the first hit, and an indirect one (Max Bounces 1: no
Russian roulette in either renderer, which would divide the throughput by a survival
probability that differs between them) a fixed function of the first two hits, whose
distributions are the pixel filter's and the cosine's in both. Both pixel filters are
importance sampled (weight 1 per sample). A scene with an area light or glossy surfaces would
clamp MIS-weighted contributions whose split between light and BSDF sampling differs between
the renderers (e.g. the light tree's selection probabilities): there the clamped means may
differ while the unclamped ones agree.

* transparent_0: the agreement scene (Max Bounces 2) under a half-transparent quad, Transparent
  Max Bounces 0: a path that passes the quad ends at the next surface after its emission (none
  here), one that passes no alpha surface shades on, as Cycles sets its "terminate on the next
  surface" flag only at a transparent bounce. Before, Caustic ended every path at its first
  surface and rendered the image black (ratio 0), which the "before" figure here (the setting
  at 8) does not show.
* caustics_refractive, caustics_reflective, caustics_both: a glass sphere (Principled,
  Transmission 1) and a metal sphere (Principled, Metallic 1, Roughness 0.2) in a closed diffuse
  room lit by an area light, with Refractive, Reflective or both Caustics off: Cycles drops the
  glass's refraction, the glass's reflection and the metal, at points reached by a diffuse bounce.

Measured (bpy 5.0.1, Caustic/Cycles per channel, before -> after): room_defaults 1.3647 ->
0.9993, glossy_1 1.1152 -> 0.9950, transmission_2 1.8596 -> 0.9995, volume_0 1.1109 -> 0.9999,
volume_2 1.0402 -> 0.9998, filter_glossy 0.7553 -> 1.0002, clamp_direct 1.3452 -> 1.0000,
clamp_indirect 1.2367 -> 0.9998, caustics_refractive 1.4482 -> 1.0000, caustics_reflective
1.0619 -> 0.9942, caustics_both 1.5597 -> 0.9998; transparent_0 0.0000 (main's binary) ->
1.0000.
"""

import math

import bpy
import pytest

import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, SEEDS, SIGMAS, assert_mean_matches_cycles, mean_and_variance

pytestmark = pytest.mark.needs_binary

W, H = 64, 48
SAMPLES = 64
LIGHT = (0.4, -0.3, 3.5)

# Cycles' default Light Paths (Blender 5.0).
CYCLES_DEFAULTS = {
    "max_bounces": 12, "diffuse_bounces": 4, "glossy_bounces": 4, "transmission_bounces": 12,
    "volume_bounces": 0, "transparent_max_bounces": 8, "sample_clamp_direct": 0.0,
    "sample_clamp_indirect": 10.0, "blur_glossy": 1.0,
}


def point_light(scene, energy=400.0):
    scenes.light(scene, "Point", "POINT", location=LIGHT, energy=energy, shadow_soft_size=0.0)


def floor_and_box(scene, floor=None):
    scenes.plane(scene, "Floor", 10.0, material=floor or scenes.diffuse_material("Grey", 0.5))
    scenes.cube(scene, "Box", 1.0, (0.3, -0.2, 0.5), material=scenes.diffuse_material("Light", 0.8))


def metal(name, roughness=0.3):
    return scenes.shader_node_material(name, "ShaderNodeBsdfPrincipled", **{
        "Base Color": (0.9, 0.9, 0.9, 1.0), "Metallic": 1.0, "Roughness": roughness})


def room(scene):
    # A closed room: the camera, the light and a box inside a 6 m cube (faces seen from inside).
    scenes.cube(scene, "Room", 6.0, (0.0, 0.0, 2.9), material=scenes.diffuse_material("Walls", 0.8))
    scenes.cube(scene, "Box", 1.0, (0.3, -0.2, 0.5), material=scenes.diffuse_material("Light", 0.8))
    point_light(scene, 200.0)


def glossy(scene):
    floor_and_box(scene, floor=metal("Metal floor"))
    scenes.plane(scene, "Ceiling", 10.0, z=4.5, material=metal("Metal ceiling"))
    point_light(scene)


def mirror_ceiling(scene):
    # A smooth metal ceiling above the point light: unblurred, no path can reach the light off
    # it (a delta mirror and a delta light); blurred after the floor's diffuse bounce, next-
    # event estimation at the ceiling finds it.
    floor_and_box(scene)
    scenes.plane(scene, "Ceiling", 10.0, z=4.5, material=metal("Mirror", roughness=0.0))
    point_light(scene)


def glass_stack(scene):
    scenes.plane(scene, "Floor", 10.0, material=scenes.emission_material("Glow", (1.0, 1.0, 1.0), 1.0))
    glass = scenes.shader_node_material("Glass", "ShaderNodeBsdfGlass", Roughness=0.0, IOR=1.5)
    scenes.cube(scene, "Upper", 0.8, (0.0, 0.0, 1.6), material=glass)
    scenes.cube(scene, "Lower", 0.8, (0.0, 0.0, 0.6), material=glass)


def fog_cube(scene):
    floor_and_box(scene)
    fog = bpy.data.materials.new("Fog")
    if fog.node_tree is None:
        fog.use_nodes = True
    tree = fog.node_tree
    for node in list(tree.nodes):
        if node.type != "OUTPUT_MATERIAL":
            tree.nodes.remove(node)
    scatter = tree.nodes.new("ShaderNodeVolumeScatter")
    scatter.inputs["Color"].default_value = (0.95, 0.95, 0.95, 1.0)
    scatter.inputs["Density"].default_value = 3.0
    tree.links.new(scatter.outputs[0], tree.nodes["Material Output"].inputs["Volume"])
    scenes.cube(scene, "Fog", 1.2, (-1.0, 0.8, 0.65), material=fog)
    point_light(scene)


def uv_sphere(scene, name, radius, center, material):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=radius, location=center)
    obj = bpy.context.active_object
    obj.name = name
    bpy.ops.object.shade_smooth()
    obj.data.materials.append(material)


def caustics_room(scene):
    # The camera sees the spheres too (a camera ray keeps every closure) and the floor around
    # them, lit through the glass and off the metal: only those paths change.
    scenes.cube(scene, "Room", 6.0, (0.0, 0.0, 2.9), material=scenes.diffuse_material("Walls", 0.8))
    glass = scenes.shader_node_material("Glass", "ShaderNodeBsdfPrincipled", **{
        "Base Color": (1.0, 1.0, 1.0, 1.0), "Roughness": 0.0, "Transmission Weight": 1.0, "IOR": 1.5})
    uv_sphere(scene, "Glass ball", 0.6, (-0.7, 0.0, 0.5), glass)
    uv_sphere(scene, "Metal ball", 0.6, (0.7, 0.0, 0.5), metal("Metal", roughness=0.2))
    scenes.light(scene, "Area", "AREA", location=(0.0, 0.0, 5.0), energy=600.0, size=1.0)


def agreement(scene):
    floor_and_box(scene)
    # A grey ceiling just above the light (test_max_bounces.py's): the floor's indirect light
    # comes from it, bright where the light is near, so the indirect clamp cuts a large share.
    scenes.plane(scene, "Ceiling", 10.0, z=4.5, material=scenes.diffuse_material("Ceiling", 0.8))
    point_light(scene)


def veiled(scene):
    """The agreement scene under a half-transparent orange quad (Principled Alpha 0.5) that
    covers part of the view."""
    agreement(scene)
    mat = scenes.diffuse_material("Veil", 0.8)
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.9, 0.6, 0.3, 1.0)
    bsdf.inputs["Alpha"].default_value = 0.5
    veil = scenes.plane(scene, "Veil", 1.2, z=1.4, material=mat)
    veil.location.x = -0.6


# case: (scene, max bounces, {Cycles property: value under test}, {property: neutral value}).
CASES = {
    "room_defaults": (room, None, dict(CYCLES_DEFAULTS),
                      {"diffuse_bounces": 12, "glossy_bounces": 12, "volume_bounces": 12, "sample_clamp_indirect": 0.0}),
    "glossy_1": (glossy, 4, {"glossy_bounces": 1}, {"glossy_bounces": 4}),
    "transmission_2": (glass_stack, 8, {"transmission_bounces": 2}, {"transmission_bounces": 8}),
    "volume_0": (fog_cube, 8, {"volume_bounces": 0}, {"volume_bounces": 8}),
    "volume_2": (fog_cube, 8, {"volume_bounces": 2}, {"volume_bounces": 8}),
    "filter_glossy": (mirror_ceiling, 2, {"blur_glossy": 1.0}, {"blur_glossy": 0.0}),
    "clamp_direct": (agreement, 1, {"sample_clamp_direct": 0.3}, {"sample_clamp_direct": 0.0}),
    "clamp_indirect": (agreement, 1, {"sample_clamp_indirect": 0.5}, {"sample_clamp_indirect": 0.0}),
    "transparent_0": (veiled, 2, {"transparent_max_bounces": 0}, {"transparent_max_bounces": 8}),
    "caustics_refractive": (caustics_room, 8, {"caustics_refractive": False}, {"caustics_refractive": True}),
    "caustics_reflective": (caustics_room, 8, {"caustics_reflective": False}, {"caustics_reflective": True}),
    "caustics_both": (caustics_room, 8, {"caustics_reflective": False, "caustics_refractive": False},
                      {"caustics_reflective": True, "caustics_refractive": True}),
}


def build(scene, case):
    add, bounces, setting, _ = CASES[case]
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    add(scene)
    if scene.camera is None:
        scenes.camera(scene, (0.0, 0.0, 2.8), (0.0, 0.0, 0.0), lens=24.0)
    scene.caustic.threads = 0
    # Every other setting equal and neutral in both renderers (no clamp, no Filter Glossy,
    # every bounce kind at Max Bounces), then the case's settings.
    scenes.match_cycles(scene, SAMPLES, bounces if bounces is not None else 12)
    for name, value in setting.items():
        setattr(scene.cycles, name, value)


def caustic_mean(scene, tmp_path, label):
    """Caustic's two-seed image mean and its variance (test_cycles_agreement's estimate)."""
    a, b = (scenes.render_rgb(scene, "CAUSTIC", s, str(tmp_path / f"{label}_{s}.exr")).mean(axis=2) for s in SEEDS)
    return mean_and_variance(a, b)


@pytest.mark.parametrize("case", list(CASES))
def test_light_paths_match_cycles(empty_scene, tmp_path, case):
    scene = empty_scene
    build(scene, case)
    ratios = assert_mean_matches_cycles(scene, tmp_path, case, MODEL_ALLOWANCE, per_channel=True)
    m_after, v_after = caustic_mean(scene, tmp_path, "after")
    for name, value in CASES[case][3].items():
        setattr(scene.cycles, name, value)
    m_before, v_before = caustic_mean(scene, tmp_path, "before")
    bound = SIGMAS * math.sqrt(v_after + v_before) + MODEL_ALLOWANCE * m_after
    after = sum(ratios.values()) / len(ratios)
    print(f"\n[caustic/cycles] light paths {case}: before (setting ignored) {after * m_before / m_after:.4f} "
          f"-> after {after:.4f} {ratios}")
    assert abs(m_before - m_after) > bound, f"{case}: the setting changes the image by less than the bound"


# BDPT and VCM follow the per-kind bounce limits themselves (`src/integrator/bdpt/bounces.rs`):
# the cases whose paths have no medium vertex (those past one are path traced without the
# limits, warned). Caustic/Cycles before (main's binary, limits ignored) -> after, BDPT / VCM:
# room_defaults 1.3655 / 1.3657 -> 0.9994 / 0.9996, glossy_1 1.1237 / 1.1195 -> 1.0054 / 1.0007,
# transmission_2 1.8598 / 1.8596 -> 0.9995 / 0.9994.
BIDIRECTIONAL_CASES = ["room_defaults", "glossy_1", "transmission_2"]


@pytest.mark.parametrize("integrator", ["bdpt", "vcm"])
@pytest.mark.parametrize("case", BIDIRECTIONAL_CASES)
def test_bounce_limits_match_cycles_bidirectionally(empty_scene, tmp_path, case, integrator):
    build(empty_scene, case)
    empty_scene.caustic.integrator = integrator
    ratios = assert_mean_matches_cycles(empty_scene, tmp_path, f"{case} ({integrator})", MODEL_ALLOWANCE,
                                        per_channel=True)
    print(f"\n[caustic/cycles] light paths {case} ({integrator}): {ratios}")
