"""Shape keys: a mesh deformed by its shape keys alone (no modifier) renders deformed, as Cycles.

Blender's glTF exporter writes such a mesh from its undeformed data; export/shape_keys.py gives
it a disabled placeholder modifier for the export, so that the exporter writes the evaluated
mesh (the keys' mix), and takes it away afterwards.

The scene: the agreement test's grey floor and light cube (test_cycles_agreement.py), the cube
with a key "Tall" that lifts its top face by 1.0 (value 0.8, so 0.8 up) and a key "Wide" that
moves its +x face out by 0.6 at value 0.5 through a vertex group holding only two of its four
vertices (a half-weight, masked key, which morph targets could not carry), lit by a point light.

The bound is test_cycles_agreement's (5 sigma of the two renderers' two-seed means + the 1 %
model allowance; the cube is the same cube there). The keys must matter: the same scene with
the undeformed cube differs from the deformed render by more than that bound.
"""

import importlib
import json
import os

import bpy
import numpy as np
import pytest

import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, SEEDS, SIGMAS, assert_mean_matches_cycles

W, H = 64, 48
SAMPLES = 64
BOUNCES = 3


def keyed_cube_scene(scene):
    """The scene of the module's comment; returns the keyed cube."""
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    scenes.plane_and_cube_scene(scene)
    cube = bpy.data.objects["Box"]
    cube.shape_key_add(name="Basis")
    tall = cube.shape_key_add(name="Tall", from_mix=False)
    for v in tall.data:
        if v.co.z > 0.5:  # the top face (the mesh is in world coordinates, centre z 0.5)
            v.co.z += 1.0
    tall.value = 0.8
    wide = cube.shape_key_add(name="Wide", from_mix=False)
    right = [i for i, v in enumerate(cube.data.vertices) if v.co.x > 0.3]  # centre x 0.3
    for i in right:
        wide.data[i].co.x += 0.6
    group = cube.vertex_groups.new(name="Half")
    group.add(right[:2], 1.0, "REPLACE")
    wide.vertex_group = "Half"
    wide.value = 0.5
    scenes.light(scene, "Point", "POINT", location=(0.4, -0.3, 3.5), energy=400.0, shadow_soft_size=0.0)
    scenes.match_cycles(scene, SAMPLES, BOUNCES)
    return cube


def test_shape_keys_are_exported_deformed(addon, empty_scene, tmp_path):
    """The written cube has the evaluated (keyed) vertices, no warning names its shape keys, and
    the placeholder modifier is gone after the export."""
    export = importlib.import_module(addon.__name__ + ".export")
    scene = empty_scene
    cube = keyed_cube_scene(scene)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = cube.evaluated_get(depsgraph).data
    expected = np.array([cube.matrix_world @ v.co for v in evaluated.vertices])
    # The keys move the cube: its top from 1 to 1.8, and two of its +x corners (x 0.8) out by 0.3.
    assert expected[:, 2].max() == pytest.approx(1.8, abs=1e-5)
    assert expected[:, 0].max() == pytest.approx(0.8 + 0.3, abs=1e-5)
    settings = export.render_settings(scene, (W, H), "Camera")
    path, state = export.export_scene(depsgraph, str(tmp_path), settings)
    assert not any("shape keys" in w and "Box" in w for w in state.warnings), state.warnings
    assert len(cube.modifiers) == 0, "the placeholder modifier is removed after the export"
    with open(path) as f:
        doc = json.load(f)
    node = next(n for n in doc["nodes"] if n.get("name") == "Box")
    accessor = doc["accessors"][doc["meshes"][node["mesh"]]["primitives"][0]["attributes"]["POSITION"]]
    # glTF axes (x, z, -y) of Blender's; the node's translation is the cube's location.
    offset = np.array(node.get("translation", [0.0, 0.0, 0.0]))
    lo, hi = np.array(accessor["min"]) + offset, np.array(accessor["max"]) + offset
    blender = lambda p: np.array([p[0], -p[2], p[1]])  # noqa: E731
    assert blender(hi)[2] == pytest.approx(expected[:, 2].max(), abs=1e-5)
    assert blender(hi)[0] == pytest.approx(expected[:, 0].max(), abs=1e-5)
    assert blender(lo)[2] == pytest.approx(expected[:, 2].min(), abs=1e-5)
    assert os.path.isfile(path)
    # The Rendered viewport's export touches no modifier (a change would make the viewport
    # reload and export again, export/shape_keys.py) and names the keyed mesh instead.
    path, state = export.export_scene(depsgraph, str(tmp_path / "view"), settings, motion=False, viewport=True)
    assert any("'Box'" in w and "shape keys" in w and "viewport" in w for w in state.warnings), state.warnings
    assert len(cube.modifiers) == 0


@pytest.mark.needs_binary
def test_shape_keyed_cube_matches_cycles(empty_scene, tmp_path):
    scene = empty_scene
    cube = keyed_cube_scene(scene)
    ratios = assert_mean_matches_cycles(scene, tmp_path, "shape keys", MODEL_ALLOWANCE)
    keyed = np.mean([scenes.load_pixels(str(tmp_path / f"CAUSTIC_{s}.exr"))[..., :3] for s in SEEDS])
    # The keys must matter: the undeformed cube's image is farther from the keyed one than
    # the agreement bound (5 sigma is below 1e-3 of the mean here; the allowance is 1 %).
    for key in cube.data.shape_keys.key_blocks[1:]:
        key.value = 0.0
    plain = np.mean(scenes.render_rgb(scene, "CAUSTIC", SEEDS[0], str(tmp_path / "plain.exr")))
    print(f"\n[shape keys] Caustic/Cycles {ratios['']:.4f}; without the keys the mean moves {plain / keyed - 1:+.1%}")
    assert abs(plain / keyed - 1) > 3 * (MODEL_ALLOWANCE + SIGMAS * 1e-3)
