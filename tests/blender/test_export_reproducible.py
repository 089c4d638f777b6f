"""The export is a function of the scene's data: the same .blend exports the same scene.gltf and
scene.bin byte for byte, twice in one process and in two processes.

Two exports that differed (a UV sphere's triangle order and the last bits of some normals) came
from scenes built afresh in each process: Blender's `primitive_uv_sphere_add` gives its mesh a
face and edge order that changes from process to process (measured in bpy 5.0.1: four runs,
four different loop orders, vertex positions identical), and the exporter writes triangles in
the mesh's loop-triangle order and normals that Blender sums over a vertex's faces in their
order. A saved mesh keeps its order, and its exports agree (this test); the add-on adds no
order of its own (sets, dicts of ids, hash seeds: the bytes agree across processes, whose
string hashes are seeded differently).
"""

import hashlib
import importlib
import os
import subprocess
import sys

import bpy

import scenes

HERE = os.path.dirname(os.path.abspath(__file__))

# Run in a fresh bpy: open the .blend, export it with the add-on, print the files' hashes.
CHILD = """
import importlib, os, sys
sys.path.insert(0, {here!r})
import conftest
addon = conftest.enable_dev_addon()
import bpy
bpy.ops.wm.open_mainfile(filepath={blend!r})
export = importlib.import_module(addon.__name__ + ".export")
scene = bpy.context.scene
settings = export.render_settings(scene, (16, 12), "Camera")
export.export_scene(bpy.context.evaluated_depsgraph_get(), {folder!r}, settings)
"""


def _digests(folder):
    return {name: hashlib.sha256(open(os.path.join(folder, name), "rb").read()).hexdigest()
            for name in sorted(os.listdir(folder))}


def _export(addon, folder):
    export = importlib.import_module(addon.__name__ + ".export")
    settings = export.render_settings(bpy.context.scene, (16, 12), "Camera")
    os.makedirs(folder)
    export.export_scene(bpy.context.evaluated_depsgraph_get(), folder, settings)
    return _digests(folder)


def test_a_saved_scene_exports_the_same_bytes_every_time(addon, empty_scene, tmp_path):
    scene = empty_scene
    scenes.small_render_settings(scene, 16, 12, samples=1)
    scenes.camera(scene, (0.0, -6.0, 4.0), (55.0, 0.0, 0.0))
    scenes.light(scene, "Sun", "SUN", rotation_deg=(30.0, 20.0, 0.0), energy=2.0)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0)
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(scenes.diffuse_material("Grey", 0.5))
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=3, location=(2.5, 0.0, 0.0))
    bpy.context.object.modifiers.new("Smooth", "SUBSURF")
    blend = str(tmp_path / "scene.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    first, second = _export(addon, str(tmp_path / "a")), _export(addon, str(tmp_path / "b"))
    assert "scene.bin" in first and first == second, (first, second)
    for k in range(2):
        folder = str(tmp_path / f"child{k}")
        os.makedirs(folder)
        code = CHILD.format(here=HERE, blend=blend, folder=folder)
        env = dict(os.environ, PYTHONHASHSEED=str(k + 1))
        subprocess.run([sys.executable, "-c", code], check=True, env=env, capture_output=True, timeout=300)
        assert _digests(folder) == first, f"process {k}: {_digests(folder)} != {first}"
