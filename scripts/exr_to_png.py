"""Converts a Caustic EXR (Combined pass) to an sRGB PNG for viewing: python exr_to_png.py IN.exr OUT.png [exposure]."""
import sys

import bpy


def main():
    src, dst = sys.argv[1], sys.argv[2]
    exposure = float(sys.argv[3]) if len(sys.argv) > 3 else 0.0
    img = bpy.data.images.load(src)
    scene = bpy.context.scene
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.exposure = exposure
    scene.render.image_settings.file_format = "PNG"
    img.save_render(dst, scene=scene)
    print(f"{src}: {img.size[0]}x{img.size[1]} -> {dst}")


main()
