"""Light groups as the compositor sees them: a view layer with three light groups (an area light,
an emissive object, the world) gives one `Combined_<group>` pass each, as Cycles' passes, and
Caustic's groups sum to its Combined, with the path tracer and with Jensen's photon mapping.

Scene: a grey floor, a rough gold cube, an emissive quad in view, an area light and a grey world
in view; 48x36, 64 samples, 3 bounces, Film → Transparent off (test_passes.py's settings).

Bounds, derived as in test_passes.py: two seeds per renderer give each image mean's variance from
8x8 blocks; |Caustic - Cycles| <= 5 sigma + 5 % of the mean, 5 % being the material model's
allowance (Blender's Principled BSDF through glTF's metallic-roughness model, measured by
test_material_agreement.py). The sum is checked per pixel against float rounding: each group and
Combined add the same f32 contributions in other orders (2^-24 relative per addition, a few dozen
per path and 64 paths), the EXR rounds to f32: 1e-4 of the pixel's magnitude bounds it.
"""

import bpy
import numpy as np
import pytest

import scenes
from test_passes import BOUNCES, H, SAMPLES, SEEDS, SIGMAS, W, mean_and_variance, principled, render_passes

pytestmark = pytest.mark.needs_binary

GROUPS = ("key", "glow", "sky")


def build(scene, groups=GROUPS):
    scenes.plane(scene, "Floor", 8.0, material=scenes.diffuse_material("Grey", 0.5))
    scenes.cube(scene, "Metal", 0.8, (-0.7, 0.3, 0.4),
                material=principled("Metal", **{"Base Color": (0.9, 0.7, 0.4, 1.0), "Metallic": 1.0,
                                                "Roughness": 0.35}))
    h = 0.3
    glow = scenes.mesh_object(scene, "Emitter", [(-h, 1.5, 0.2), (h, 1.5, 0.2), (h, 1.5, 0.8), (-h, 1.5, 0.8)],
                              [(0, 3, 2, 1)], scenes.emission_material("Glow", (1.0, 0.8, 0.6), 5.0))
    key = scenes.light(scene, "Key", "AREA", location=(0.5, -1.0, 3.0), rotation_deg=(20, 0, 0), shape="SQUARE",
                       size=1.0, energy=150.0)
    world = bpy.data.worlds.new("Grey")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.2, 0.25, 0.3, 1.0)
    scene.world = world
    layer = scene.view_layers[0]
    for name in groups:
        layer.lightgroups.add(name=name)
    # The objects name their groups either way: without the view layer's groups they are in none.
    key.lightgroup, glow.lightgroup, world.lightgroup = GROUPS
    scenes.camera(scene, (0.0, -4.5, 1.6), (80.0, 0.0, 0.0), lens=24.0)
    scenes.small_render_settings(scene, W, H, SAMPLES)
    scenes.match_cycles(scene, SAMPLES, BOUNCES)
    scene.render.film_transparent = False
    scene.render.image_settings.media_type = "MULTI_LAYER_IMAGE"
    scene.render.image_settings.exr_codec = "ZIP"


def rgb(p, name):
    """R, G, B of a pass of `render_passes`, which orders channels by name (A B G R, or B G R)."""
    return p[name][..., -3:][..., ::-1]


@pytest.fixture(scope="module")
def both_renders(addon, tmp_path_factory):
    """Each renderer's passes for both seeds (rendered once for the module)."""
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    scene = bpy.context.scene
    scene.render.engine = "CAUSTIC"
    build(scene)
    tmp = tmp_path_factory.mktemp("light_groups")
    return {engine: [render_passes(scene, engine, s, str(tmp / f"{engine}{s}.exr")) for s in SEEDS]
            for engine in ("CYCLES", "CAUSTIC", "CAUSTIC_PHOTON")}


@pytest.mark.parametrize("engine", ("CAUSTIC", "CAUSTIC_PHOTON"))
@pytest.mark.parametrize("group", GROUPS)
def test_light_group_matches_cycles(both_renders, group, engine):
    """Each group of the path tracer and of Jensen's photon mapping against Cycles'."""
    name = f"Combined_{group}"
    assert all(name in r for rs in both_renders.values() for r in rs), "the pass is missing"
    m_cy, v_cy = mean_and_variance(*(rgb(r, name) for r in both_renders["CYCLES"]))
    m_ca, v_ca = mean_and_variance(*(rgb(r, name) for r in both_renders[engine]))
    bound = SIGMAS * np.sqrt(v_cy + v_ca) + 0.05 * max(abs(m_cy), abs(m_ca))
    print(f"{engine:15s} {name:16s} cycles {m_cy:.5f} caustic {m_ca:.5f} bound {bound:.5f}")
    assert m_ca > 0.0 and m_cy > 0.0
    assert abs(m_ca - m_cy) <= bound, f"caustic {m_ca:.5f}, cycles {m_cy:.5f}, bound {bound:.5f}"


def test_light_groups_sum_to_combined(both_renders):
    for p in both_renders["CAUSTIC"] + both_renders["CAUSTIC_PHOTON"]:
        total = sum(rgb(p, f"Combined_{g}") for g in GROUPS)
        combined = rgb(p, "Combined")
        worst = np.max(np.abs(total - combined) / (1e-4 * np.maximum(np.abs(combined), np.abs(total)) + 1e-9))
        assert worst <= 1.0, f"light groups differ from Combined by {worst} x the rounding bound"


def test_light_groups_stay_off_without_groups(empty_scene, tmp_path):
    """Without light groups in the view layer no `Combined_` pass is declared or written."""
    scene = empty_scene
    build(scene, groups=())
    scene.caustic.samples = 2
    p = render_passes(scene, "CAUSTIC", 1, str(tmp_path / "plain.exr"))
    assert not any(name.startswith("Combined_") for name in p)
