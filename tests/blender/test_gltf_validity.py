"""The add-on's exports pass the Khronos glTF validator with no errors.

Each test scene of the add-on suite (every light type, the materials of the agreement tests,
a textured material, the uniform and image worlds, the render-test scene, point clouds, meshes
with attributes read by name) is exported exactly
as a render does (an F12 render with the contract's stand-in binary, the temporary folder kept
with CAUSTIC_KEEP_TEMP), and `scene.gltf` with its .bin and images goes through the validator
(npm `gltf-validator`, installed into .tools/ by scripts/setup_validator.sh; a missing install
fails the test). Errors fail; warnings and infos are printed (pytest -s), e.g. the validator's
UNSUPPORTED_EXTENSION for the CAUSTIC_* vendor extensions, which it cannot know.
"""

import json
import os
import subprocess

import bpy
import numpy as np
import pytest

import scenes
import test_cycles_agreement as lights
from test_export import AREA_LIGHTS
from test_material_agreement import MATERIALS
from test_material_agreement import build as build_material_scene
from test_world_agreement import hdri_world, uniform_world

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
VALIDATE = os.path.join(REPO, "scripts", "validate_gltf.js")
VALIDATOR = os.path.join(REPO, ".tools", "node_modules", "gltf-validator", "package.json")


def all_lights(scene, tmp_path):
    """test_export's light scene: four area-light shapes, point, spot and sun; and a point light
    of negative power (the exporter writes a negative intensity, which glTF forbids: the add-on
    makes it the size, with CAUSTIC_lights_punctual's `negative`)."""
    scenes.small_render_settings(scene, 16, 12, samples=2)
    scenes.plane(scene, "Floor", 4.0, material=scenes.diffuse_material("Grey", 0.5))
    scenes.camera(scene, (0, -4, 3), (60, 0, 0))
    for i, (name, shape, size, size_y, energy, color, _) in enumerate(AREA_LIGHTS):
        scenes.light(scene, name, "AREA", location=(i, 1.0, 2.0 + i), rotation_deg=(20 * i, 10, 5 * i),
                     shape=shape, size=size, size_y=size_y, energy=energy, color=color)
    for add in lights.LIGHTS.values():
        add(scene)
    scenes.light(scene, "Minus", "POINT", location=(-1.0, 0.5, 1.5), energy=-20.0)


def render_scene(scene, tmp_path):
    """test_render's scene: a plane, a cube and a rectangle light."""
    scenes.small_render_settings(scene, 16, 12, samples=2)
    scenes.plane_and_cube_scene(scene)
    scenes.light(scene, "Key", "AREA", location=(0.5, -0.5, 3.0), shape="RECTANGLE", size=1.5,
                 size_y=1.0, energy=200.0)


def textured(scene, tmp_path):
    """A base-colour image texture (a PNG beside the glTF) on the floor."""
    lights.build(scene, lights.add_point)
    img = bpy.data.images.new("Checker", 8, 8)
    pixels = np.zeros((8, 8, 4), dtype=np.float32)
    pixels[..., 3] = 1.0
    pixels[::2, ::2, :3] = 0.8
    img.pixels.foreach_set(pixels.ravel())
    img.filepath_raw = str(tmp_path / "checker.png")
    img.file_format = "PNG"
    img.save()
    mat = bpy.data.materials["Grey"]
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    tex = nodes.new("ShaderNodeTexImage")
    tex.image = img
    links.new(tex.outputs["Color"], nodes["Principled BSDF"].inputs["Base Color"])


def point_clouds(scene, tmp_path):
    """test_points' scenes at once: Geometry Nodes' points in a Point Info material (appended as
    a node graph) and a Point Cloud object (CAUSTIC_points and its buffer)."""
    import test_points
    test_points.lit_floor(scene)
    test_points.gn_points(scene, test_points.point_info_material())
    test_points.point_cloud_object(scene, scenes.diffuse_material("Light", 0.8), count=8)


def attribute_case(name, scene):
    """A scene of test_attributes_agreement.py (imported here: it imports this module)."""
    from test_attributes_agreement import CASES
    CASES[name](scene)


SCENES = {
    "all_lights": all_lights,
    "point_clouds": point_clouds,
    "render_scene": render_scene,
    "textured": textured,
    "world_uniform": lambda scene, tmp_path: lights.build(scene, uniform_world),
    "world_hdri": lambda scene, tmp_path: lights.build(scene, hdri_world(tmp_path, 0.7)),
    **{f"material_{name}": (lambda make: lambda scene, tmp_path: build_material_scene(scene, make()))(make)
       for name, (make, _) in MATERIALS.items()},
    # Attributes read by name: `_CAUSTIC_*` vertex attributes (application-specific semantics).
    **{f"attributes_{name}": (lambda name: lambda scene, tmp_path: attribute_case(name, scene))(name)
       for name in ("face_float", "corner_colours", "pointiness", "random_per_island", "object_properties")},
}


@pytest.fixture(scope="module")
def validator():
    if not os.path.isfile(VALIDATOR):
        pytest.fail("the glTF validator is not installed: run scripts/setup_validator.sh", pytrace=False)
    return VALIDATE


def export_folder(scene, tmp_path, monkeypatch):
    """Render with the stand-in binary keeping the add-on's temporary folder; return it."""
    import tempfile
    root = tmp_path / "kept"
    root.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(root))
    monkeypatch.setenv("CAUSTIC_KEEP_TEMP", "1")
    scene.render.filepath = str(tmp_path / "out.exr")
    bpy.ops.render.render(write_still=True)
    (folder,) = list(root.iterdir())
    return folder


@pytest.mark.parametrize("name", list(SCENES))
def test_export_passes_the_khronos_validator(empty_scene, fake_binary, tmp_path, monkeypatch, validator, name):
    SCENES[name](empty_scene, tmp_path)
    folder = export_folder(empty_scene, tmp_path, monkeypatch)
    gltf = folder / "scene.gltf"
    run = subprocess.run(["node", validator, str(gltf)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    report = json.loads(run.stdout)
    issues = report["issues"]
    by_severity = {0: [], 1: [], 2: [], 3: []}
    for m in issues["messages"]:
        by_severity[m["severity"]].append(f"{m['code']} at {m.get('pointer', '?')}: {m['message']}")
    for label, severity in (("warning", 1), ("info", 2), ("hint", 3)):
        for line in by_severity[severity]:
            print(f"{name}: {label}: {line}")
    assert issues["numErrors"] == 0, "\n".join(by_severity[0])
    # The scene really went through: meshes and the render's own extensions are in it.
    doc = json.loads(gltf.read_text())
    assert doc.get("meshes"), "nothing exported"
    for ext in doc.get("extensionsUsed", []):
        assert ext.startswith(("KHR_", "CAUSTIC_")), ext
    if name == "textured":
        # The floor has no UV map: the add-on supplied TEXCOORD_0 at Blender's UV (0, 0).
        floor = next(m for m in doc["meshes"] if m.get("name") == "Floor")
        assert "TEXCOORD_0" in floor["primitives"][0]["attributes"]
