"""Lights: what Blender's glTF exporter leaves out of them (contract: `CAUSTIC_lights_area`,
`CAUSTIC_lights_punctual`).

* Area lights: the exporter drops them ("Unsupported light source AREA"); Caustic puts
  `CAUSTIC_lights_area` on the light's node. The node gets the exporter's -90° X light
  correction and the Y-up axis swap, and the two cancel (checked on io_scene_gltf2 5.0.21): the
  node's local frame *is* the Blender light's local frame (light in local XY, emitting towards
  local -Z, object scale in the node's scale), so no compensation is needed.
* Point, spot and sun: KHR_lights_punctual cannot say a radius, a sun's angle or Cycles' spot
  blend; they go in `CAUSTIC_lights_punctual`.
* A negative power (Cycles subtracts the light; its light tree picks it by |energy|): the area
  light's `power` keeps the sign; KHR_lights_punctual's intensity must not be negative (the
  exporter writes it signed), so it becomes the size and `CAUSTIC_lights_punctual` says
  `negative` (`carry_negative_intensity`).
* A spot with blend 0 gets innerConeAngle == outerConeAngle from the exporter, which the glTF
  validator calls an error (glTF wants inner < outer): the inner angle is moved down to the
  next double (Caustic uses `spot_blend` instead anyway).
* Ray Visibility: Camera goes out as `camera_visible`; Diffuse, Glossy, Transmission and
  Volume Scatter as `*_visible` keys, only when off (`light_ray_visibility`).
* Cycles' Max Bounces of a light goes out as `max_bounces`, only when it limits anything
  (below Cycles' default 1024, `cycles_max_bounces`).
* Light node trees: Cycles multiplies the light's power by the Strength and its colour by the
  Color of the Emission node on the light's output (`light_node_factors`); with nothing on the
  output's Surface the light emits nothing. The exporter instead
  replaces the colour by the node's and ignores the Strength (it uses it *instead of* the power
  for a sun); `scale_punctual_light` corrects what it wrote, `area_light_extension` applies the
  factors. Any other tree (a linked Strength or Color, another shader) goes as its graph
  (`light_nodes`, the extensions' `nodes`), and the light keeps its own power and colour.
"""

import math

from .light_nodes import light_graph

AREA_LIGHT_EXTENSION = "CAUSTIC_lights_area"
PUNCTUAL_EXTENSION = "CAUSTIC_lights_punctual"

# Blender's area light shapes -> the contract's names.
_AREA_SHAPES = {"SQUARE": "square", "RECTANGLE": "rectangle", "DISK": "disk", "ELLIPSE": "ellipse"}


def area_light_extension(blender_object, writer=None, depsgraph=None):
    """The `CAUSTIC_lights_area` value for an area light object, and warnings about what it drops;
    with `writer` (node_images.ImageWriter) a node tree beyond an Emission's two numbers goes as
    its graph (`light_nodes`)."""
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

    graph, graph_warnings = light_graph(blender_object, writer, depsgraph)
    if graph is None:
        strength, node_color, node_warnings = light_node_factors(blender_object)
        warnings += node_warnings
        power *= strength
        color = [c * n for c, n in zip(color, node_color)]
    else:
        warnings += graph_warnings
    value = {"shape": shape, "size": [float(s) for s in size], "power": float(power),
             "color": [float(c) for c in color],
             # Ray Visibility > Camera (Blender hides lights from the camera by default).
             "camera_visible": bool(blender_object.visible_camera)}
    if graph is not None:
        value["nodes"] = graph
    # Spread (full angle, radians); 180° is Blender's default and no narrowing.
    if light.spread < math.pi - 1e-4:
        value["spread"] = float(light.spread)
    if not light.use_shadow:
        value["cast_shadow"] = False
    if not _lights_catcher(blender_object):
        value["shadow_catcher"] = False
    value.update(light_ray_visibility(blender_object))
    bounces = cycles_max_bounces(light)
    if bounces is not None:
        value["max_bounces"] = bounces
    if getattr(getattr(light, "cycles", None), "is_portal", False):
        # Cycles' Portal: a window that steers the world's light sampling; it emits nothing.
        value["portal"] = True
    return value, warnings


def punctual_light_extension(blender_object, writer=None, depsgraph=None, warnings=None):
    """Blender's light shape parameters that KHR_lights_punctual cannot say, or None; with
    `writer`, a node tree beyond an Emission's two numbers as its graph (`nodes`, its warnings
    appended to `warnings`).

    radius: a point or spot light's `shadow_soft_size` (a sphere light in Cycles, or with soft
    falloff a disk facing the shading point; a spot's masked by its cone), with its Soft Falloff
    and Ray Visibility > Camera; angle: a sun's angular diameter; spot_blend: applied with
    Cycles' smoothstep instead of glTF's ramp.
    """
    light = blender_object.data
    value = {}
    if light.type in ("POINT", "SPOT") and light.shadow_soft_size > 0.0:
        value["radius"] = float(light.shadow_soft_size)
        value["camera_visible"] = bool(blender_object.visible_camera)
        value["soft_falloff"] = bool(getattr(light, "use_soft_falloff", False))
    if light.type == "SPOT":
        value["spot_blend"] = float(light.spot_blend)
    elif light.type == "SUN" and light.angle > 0.0:
        value["angle"] = float(light.angle)
    if not light.use_shadow:
        value["cast_shadow"] = False  # Cast Shadow off: nothing occludes the light
    if not _lights_catcher(blender_object):
        value["shadow_catcher"] = False
    value.update(light_ray_visibility(blender_object))
    graph, graph_warnings = light_graph(blender_object, writer, depsgraph)
    if graph is not None:
        value["nodes"] = graph
        if warnings is not None:
            warnings.extend(graph_warnings)
    bounces = cycles_max_bounces(light)
    if bounces is not None:
        value["max_bounces"] = bounces
    return value or None


# Cycles' default Max Bounces of a light and of the world: no limit of their own.
_UNLIMITED_BOUNCES = 1024


def cycles_max_bounces(datablock):
    """A light's or world's Cycles Max Bounces when it limits anything, else None: past it
    Cycles' next-event estimation leaves the light out (`light_select_reached_max_bounces`)."""
    settings = getattr(datablock, "cycles", None)
    bounces = int(getattr(settings, "max_bounces", _UNLIMITED_BOUNCES))
    return bounces if bounces < _UNLIMITED_BOUNCES else None


# Blender's Ray Visibility of a light object beyond Camera -> the extensions' keys.
_RAY_VISIBILITY = (("visible_diffuse", "diffuse_visible"), ("visible_glossy", "glossy_visible"),
                   ("visible_transmission", "transmission_visible"),
                   ("visible_volume_scatter", "volume_scatter_visible"))


def light_ray_visibility(blender_object):
    """The light's Ray Visibility flags that are off, as {key: False}: Cycles leaves the
    light out of bounces of those kinds and their closures out of its direct light."""
    original = getattr(blender_object, "original", blender_object)
    return {key: False for prop, key in _RAY_VISIBILITY if not getattr(original, prop, True)}


def _lights_catcher(blender_object):
    """The light object's Shadow Catcher flag: Cycles lights the shadow catcher pass only with
    lights whose flag is on (Blender 5.0 sets it on new lights)."""
    return bool(getattr(getattr(blender_object, "original", blender_object), "is_shadow_catcher", True))


def _khr_light(gltf2_node):
    """The KHR_lights_punctual light dict the exporter wrote for the node (shared by the objects
    of one light datablock), or None."""
    ext = (gltf2_node.extensions or {}).get("KHR_lights_punctual")
    child = ext.extension.get("light") if ext is not None and isinstance(ext.extension, dict) else None
    light = getattr(child, "extension", None)
    return light if isinstance(light, dict) else None


def carry_negative_intensity(gltf2_node, value, state):
    """The node's `CAUSTIC_lights_punctual` value (`value`, or a new dict) with `negative` when the
    light's power is negative (Cycles subtracts such a light). The exporter writes Blender's signed
    intensity, which KHR_lights_punctual forbids and Caustic refuses: the intensity becomes its
    size, once per light dict (`state.negative_lights`), and every node of it says `negative`."""
    light = _khr_light(gltf2_node)
    if light is None:
        return value
    key = id(light)
    if key not in state.negative_lights:
        intensity = light.get("intensity")
        negative = isinstance(intensity, (int, float)) and intensity < 0.0
        state.negative_lights[key] = negative
        if negative:
            light["intensity"] = -float(intensity)
    if not state.negative_lights[key]:
        return value
    value = dict(value or {})
    value["negative"] = True
    return value


def separate_spot_angles(gltf2_node):
    """Make a spot's innerConeAngle strictly smaller than its outerConeAngle (glTF's rule)."""
    light = _khr_light(gltf2_node)
    spot = light.get("spot") if light is not None else None
    if isinstance(spot, dict):
        inner, outer = spot.get("innerConeAngle"), spot.get("outerConeAngle")
        if isinstance(inner, float) and isinstance(outer, float) and inner >= outer > 0.0:
            spot["innerConeAngle"] = math.nextafter(outer, 0.0)


def _light_color(light):
    """The light's own colour, with its blackbody temperature when used (as Cycles)."""
    color = [float(c) for c in light.color]
    if getattr(light, "use_temperature", False):
        color = [c * float(t) for c, t in zip(color, light.temperature_color)]
    return color


def _emission_node(light):
    """The node on the light's (Cycles) output Surface, through reroutes, or None."""
    tree = light.node_tree
    output = tree.get_output_node("CYCLES") if tree is not None else None
    if output is None:
        return None
    sock = output.inputs.get("Surface")
    while sock is not None and sock.is_linked:
        link = next((k for k in sock.links if k.is_valid and not k.is_muted), None)
        if link is None:
            return None
        if link.from_node.type != "REROUTE":
            return link.from_node
        sock = link.from_node.inputs[0]
    return None


def light_node_factors(blender_object):
    """(strength, [r, g, b], warnings): what the light's node tree multiplies its power and colour
    by in Cycles. Only an Emission node with unlinked Strength and Color is read; anything else
    is named in a warning (and its unlinked values, or 1, are used)."""
    light = blender_object.data
    if not getattr(light, "use_nodes", False) or light.node_tree is None:
        return 1.0, [1.0, 1.0, 1.0], []
    name = blender_object.name
    node = _emission_node(light)
    if node is None:
        # Cycles renders such a light black (no emission closure), whatever its power.
        return 0.0, [1.0, 1.0, 1.0], [f"light '{name}': its node tree has no shader on the Light Output's "
                                       "Surface; it emits no light, as in Cycles"]
    if node.type != "EMISSION" or node.mute:
        return 1.0, [1.0, 1.0, 1.0], [f"light '{name}': the {node.bl_label} node '{node.name}' of its node tree "
                                       "is not read (only an Emission node is); Caustic uses the light's own "
                                       "power and colour"]
    warnings = []
    for socket_name in ("Strength", "Color"):
        if node.inputs[socket_name].is_linked:
            warnings.append(f"light '{name}': the {socket_name} of its node tree's Emission node '{node.name}' is "
                            "linked; Caustic uses the socket's own value (light textures are not exported)")
    strength = float(node.inputs["Strength"].default_value)
    color = [float(c) for c in node.inputs["Color"].default_value[:3]]
    return strength, color, warnings


def scale_punctual_light(gltf2_node, blender_object, state, graph=False):
    """Make the exporter's KHR_lights_punctual light what Cycles renders for a light with a node
    tree (module doc); warnings go to the state. `graph`: the tree goes as its graph, so the
    light gets its own colour and intensity, without the tree's."""
    value = _khr_light(gltf2_node)
    light = blender_object.data
    if value is None or not getattr(light, "use_nodes", False) or light.node_tree is None:
        return
    if graph:
        if id(value) not in state.scaled_lights:
            state.scaled_lights.add(id(value))
            value["color"] = _light_color(light)
            value["intensity"] = _own_intensity(light)
        return
    strength, node_color, warnings = light_node_factors(blender_object)
    if id(value) in state.scaled_lights:  # a light dict the exporter shares between objects
        return
    state.scaled_lights.add(id(value))
    state.warnings.extend(warnings)
    node = _emission_node(light)
    if node is None:
        # The exporter wrote the light's own values; Cycles renders no light (`light_node_factors`).
        value["intensity"] = 0.0
        return
    if node.type != "EMISSION" or node.mute:
        return  # the exporter found no Emission on the output either: it wrote the light's own values
    # The exporter wrote colour = the node's Color (the light's colour dropped) and intensity
    # from the light's power (a sun: from the node's Strength instead of the power).
    value["color"] = [c * n for c, n in zip(_light_color(light), node_color)]
    if light.type != "SUN" and _has_falloff_upstream(node.inputs["Strength"]):
        # The exporter took its intensity from the Light Falloff node's Strength instead of the
        # power; that is kept (the linked Strength is named in a warning above).
        return
    if "intensity" in value:
        value["intensity"] = float(value["intensity"]) * (float(light.energy) if light.type == "SUN" else strength)


# The exporter's SPEC lighting mode: lm per W (`io_scene_gltf2`'s PBR_WATTS_TO_LUMENS).
_LUMENS_PER_WATT = 683.0


def _own_intensity(light):
    """The KHR_lights_punctual intensity the exporter writes for the light without a node tree
    (SPEC mode): a sun's W/m² as lux, a point's or spot's W as candela (W / 4π), × 2^exposure."""
    power = float(light.energy) * 2.0 ** float(getattr(light, "exposure", 0.0)) * _LUMENS_PER_WATT
    return power if light.type == "SUN" else power / (4.0 * math.pi)


def _has_falloff_upstream(sock):
    """Whether a Light Falloff node feeds `sock` (the exporter reads its Strength then)."""
    todo, seen = [sock], set()
    while todo:
        for link in todo.pop().links:
            node = link.from_node
            if node.as_pointer() in seen:
                continue
            seen.add(node.as_pointer())
            if node.type == "LIGHT_FALLOFF":
                return True
            todo.extend(s for s in node.inputs if s.is_linked)
    return False
