"""Point, spot and sun lights with Normalize off, which Blender's glTF exporter cannot write.

io_scene_gltf2 5.0.21 multiplies such a light's intensity by its area with
`blender_lamp.area(world_matrix=...)`, a keyword the API calls `matrix_world`, and fails with
"PointLight.area(): was called with invalid keyword argument(s)", so the whole F12 render
failed. Cycles renders such a light with its power times `light.area()` (a point's or spot's
4πr², a sun's solid angle; the object's scale does not enter, so one value per light
datablock). While the exporter runs, `normalize_baked` gives each such light that product as
its power with Normalize on, and restores both afterwards (area lights are left alone: the
exporter skips them and `lights.area_light_extension` applies Normalize itself).
"""

from contextlib import contextmanager

import bpy
from mathutils import Matrix


@contextmanager
def normalize_baked(warnings):
    """While active, every point, spot and sun light with Normalize off has power × area and
    Normalize on; a light that cannot be edited (linked from a library) is named in
    `warnings`, and the exporter's failure on it is left to report."""
    changed = []
    try:
        for light in bpy.data.lights:
            if light.type == "AREA" or getattr(light, "normalize", True):
                continue
            if light.library is not None:
                warnings.append(f"light '{light.name}': linked from a library, its Normalize off cannot be "
                                "written for Blender's glTF exporter, which fails on it")
                continue
            energy = light.energy
            light.energy = energy * light.area(matrix_world=Matrix.Identity(4))
            light.normalize = True
            changed.append((light, energy))
        yield
    finally:
        for light, energy in changed:
            light.normalize = False
            light.energy = energy
