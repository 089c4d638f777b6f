"""Point, spot and sun lights with a blackbody temperature, which Blender's glTF exporter cannot
write.

io_scene_gltf2 5.0 multiplies each channel of the light's colour by `temperature_color` (a
colour, not a number) and fails with "color[item] = x: assigned value not a number", so
the whole F12 render failed. Cycles renders the light's colour times its temperature's colour
(`light.temperature_color`, Blender's blackbody in the scene's linear space). While the
exporter runs, `temperatures_baked` gives each such light that product as its colour with
the temperature switched off, and restores both afterwards (area lights are left alone: the
exporter skips them and `lights.area_light_extension` applies the temperature itself).
"""

from contextlib import contextmanager

import bpy


@contextmanager
def temperatures_baked(warnings):
    """While active, every point, spot and sun light that uses a temperature has colour ×
    temperature colour and no temperature; a light that cannot be edited (linked from a
    library) is named in `warnings`, and the exporter's failure on it is left to report."""
    changed = []
    try:
        for light in bpy.data.lights:
            if light.type == "AREA" or not getattr(light, "use_temperature", False):
                continue
            if light.library is not None:
                warnings.append(f"light '{light.name}': linked from a library, its temperature cannot be "
                                "written for Blender's glTF exporter, which fails on it")
                continue
            color = tuple(light.color)
            light.color = [c * float(t) for c, t in zip(color, light.temperature_color)]
            light.use_temperature = False
            changed.append((light, color))
        yield
    finally:
        for light, color in changed:
            light.use_temperature = True
            light.color = color
