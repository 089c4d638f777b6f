"""Lights: what Blender's glTF exporter leaves out of them (contract: `CAUSTIC_lights_area`,
`CAUSTIC_lights_punctual`).

* Area lights: the exporter drops them ("Unsupported light source AREA"); Caustic puts
  `CAUSTIC_lights_area` on the light's node. The node gets the exporter's -90° X light
  correction and the Y-up axis swap, and the two cancel (checked on io_scene_gltf2 5.0.21): the
  node's local frame *is* the Blender light's local frame (light in local XY, emitting towards
  local -Z, object scale in the node's scale), so no compensation is needed.
* Point, spot and sun: KHR_lights_punctual cannot say a radius, a sun's angle or Cycles' spot
  blend; they go in `CAUSTIC_lights_punctual`.
* A spot with blend 0 gets innerConeAngle == outerConeAngle from the exporter, which the glTF
  validator calls an error (glTF wants inner < outer): the inner angle is moved down to the
  next double (Caustic uses `spot_blend` instead anyway).
"""

import math

AREA_LIGHT_EXTENSION = "CAUSTIC_lights_area"
PUNCTUAL_EXTENSION = "CAUSTIC_lights_punctual"

# Blender's area light shapes -> the contract's names.
_AREA_SHAPES = {"SQUARE": "square", "RECTANGLE": "rectangle", "DISK": "disk", "ELLIPSE": "ellipse"}


def area_light_extension(blender_object):
    """The `CAUSTIC_lights_area` value for an area light object, and warnings about what it drops."""
    light = blender_object.data
    warnings = []
    shape = _AREA_SHAPES[light.shape]
    if light.shape in {"SQUARE", "DISK"}:
        size = [light.size, light.size]
    else:
        size = [light.size, light.size_y]

    color = list(light.color)
    if light.use_temperature:
        color = [c * t for c, t in zip(color, light.temperature_color)]

    # Same power as Cycles: exposure is a power of two; without "normalize" the power is per
    # unit area, the area taken in world space (object scale included).
    power = light.energy * 2.0 ** light.exposure
    if not light.normalize:
        power *= light.area(matrix_world=blender_object.matrix_world)

    if light.use_nodes:
        warnings.append(f"light '{blender_object.name}': light node trees are ignored")
    value = {"shape": shape, "size": [float(s) for s in size], "power": float(power),
             "color": [float(c) for c in color],
             # Ray Visibility > Camera (Blender hides lights from the camera by default).
             "camera_visible": bool(blender_object.visible_camera)}
    # Spread (full angle, radians); 180° is Blender's default and no narrowing.
    if light.spread < math.pi - 1e-4:
        value["spread"] = float(light.spread)
    return value, warnings


def punctual_light_extension(blender_object):
    """Blender's light shape parameters that KHR_lights_punctual cannot say, or None.

    radius: a point light's `shadow_soft_size` (a sphere light in Cycles, or with soft falloff a
    disk facing the shading point); angle: a sun's
    angular diameter; spot_blend: applied with Cycles' smoothstep instead of glTF's ramp.
    """
    light = blender_object.data
    value = {}
    if light.type == "POINT" and light.shadow_soft_size > 0.0:
        value["radius"] = float(light.shadow_soft_size)
        value["camera_visible"] = bool(blender_object.visible_camera)
        value["soft_falloff"] = bool(getattr(light, "use_soft_falloff", False))
    elif light.type == "SPOT":
        value["spot_blend"] = float(light.spot_blend)
        if light.shadow_soft_size > 0.0:
            value["radius"] = float(light.shadow_soft_size)
    elif light.type == "SUN" and light.angle > 0.0:
        value["angle"] = float(light.angle)
    return value or None


def separate_spot_angles(gltf2_node):
    """Make a spot's innerConeAngle strictly smaller than its outerConeAngle (glTF's rule)."""
    ext = (gltf2_node.extensions or {}).get("KHR_lights_punctual")
    child = ext.extension.get("light") if ext is not None and isinstance(ext.extension, dict) else None
    light = getattr(child, "extension", None)
    spot = light.get("spot") if isinstance(light, dict) else None
    if isinstance(spot, dict):
        inner, outer = spot.get("innerConeAngle"), spot.get("outerConeAngle")
        if isinstance(inner, float) and isinstance(outer, float) and inner >= outer > 0.0:
            spot["innerConeAngle"] = math.nextafter(outer, 0.0)
