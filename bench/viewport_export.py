"""The add-on's share of a viewport edit that adds or changes one object (issue 22: "moving one
object in a 1 M-triangle scene does not re-export the scene"): the time to export the whole scene
as a reload did, against the time to export the one changed object alone as the viewport now does
(`export_scene(..., only=...)`, merged by the server's `objects` request).

The scene: a UV sphere of about N triangles, a cube beside it, a sun and a camera. Each export
runs `--repeats` times into a fresh folder; the medians are printed with the files' sizes.

Usage:
    .venv/bin/python bench/viewport_export.py [--triangles 1000000] [--repeats 3]
(run with the .venv's Python: it needs the project's bpy.)
"""
import argparse
import os
import shutil
import statistics
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests", "blender"))

import conftest  # noqa: E402  (sets Blender's user folders aside, then imports bpy)
import bpy  # noqa: E402


def build(triangles):
    """The scene; returns the depsgraph."""
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    scene = bpy.context.scene
    scene.render.engine = "CAUSTIC"
    rings = max(4, int((triangles / 4) ** 0.5))
    bpy.ops.mesh.primitive_uv_sphere_add(segments=2 * rings, ring_count=rings, radius=1.0, location=(0, 0, 1))
    bpy.context.object.name = "Dense"
    bpy.ops.mesh.primitive_cube_add(size=0.5, location=(2, 0, 0.25))
    bpy.context.object.name = "Cube"
    bpy.ops.object.light_add(type="SUN", location=(0, 0, 5))
    bpy.ops.object.camera_add(location=(0, -6, 2), rotation=(1.3, 0, 0))
    scene.camera = bpy.context.object
    return bpy.context.evaluated_depsgraph_get()


def timed(export, depsgraph, settings, only, repeats):
    """Median seconds of `repeats` exports and the size of the last one's files."""
    times, size = [], 0
    for _ in range(repeats):
        folder = tempfile.mkdtemp(prefix="caustic-bench-export-")
        try:
            t = time.perf_counter()
            export.export_scene(depsgraph, folder, settings, motion=False, viewport=True, only=only)
            times.append(time.perf_counter() - t)
            size = sum(os.path.getsize(os.path.join(d, f)) for d, _, fs in os.walk(folder) for f in fs)
        finally:
            shutil.rmtree(folder, ignore_errors=True)
    return statistics.median(times), size


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--triangles", type=int, default=1_000_000)
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    addon = conftest.enable_dev_addon()
    export = sys.modules[f"{addon.__name__}.export"]
    depsgraph = build(a.triangles)
    scene = depsgraph.scene
    settings = export.render_settings(scene, (scene.render.resolution_x, scene.render.resolution_y), None)
    tris = sum(len(o.evaluated_get(depsgraph).data.loop_triangles) for o in scene.objects if o.type == "MESH")
    whole, whole_bytes = timed(export, depsgraph, settings, None, a.repeats)
    alone, alone_bytes = timed(export, depsgraph, settings, {"Cube"}, a.repeats)
    print(f"scene: {tris} triangles; medians of {a.repeats}")
    print(f"whole scene exported (a reload): {1000 * whole:8.1f} ms, {whole_bytes / 1e6:8.2f} MB")
    print(f"the cube alone (objects):        {1000 * alone:8.1f} ms, {alone_bytes / 1e6:8.3f} MB")


if __name__ == "__main__":
    main()
