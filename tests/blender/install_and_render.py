"""Run in a fresh Python (by test_extension_zip.py): install the built zip into bpy, render, report.

argv: ZIP OUTPUT_IMAGE. Prints one JSON line with what it found. BLENDER_USER_RESOURCES must
point to an empty temporary folder, CAUSTIC_BINARY must be unset (the bundled binary is used).
"""

import json
import sys

import bpy

sys.path.insert(0, __file__.rsplit("/", 1)[0])
import scenes  # noqa: E402


def main():
    zip_path, out_path = sys.argv[1], sys.argv[2]
    bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default",
                                             enable_on_install=True)
    module_name = "bl_ext.user_default.caustic"
    enabled = module_name in bpy.context.preferences.addons
    runner = sys.modules.get(module_name + ".runner")
    binary = runner.find_binary() if runner else None

    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    scene = bpy.context.scene
    scene.render.engine = "CAUSTIC"
    scenes.small_render_settings(scene, 24, 18, samples=2)
    scenes.plane_and_cube_scene(scene)
    scenes.light(scene, "Sun", "SUN", rotation_deg=(20, 0, 0), energy=3.0)
    scene.render.filepath = out_path
    bpy.ops.render.render(write_still=True)
    pixels = scenes.load_pixels(out_path)
    print("RESULT " + json.dumps({"enabled": enabled, "binary": binary,
                                  "shape": list(pixels.shape), "mean": float(pixels[..., :3].mean())}))


main()
