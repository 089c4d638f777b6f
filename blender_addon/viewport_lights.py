"""Light and world edits of the Rendered viewport, in place (docs/protocol.md `light`, `world`).

A light's colour, power, exposure, temperature or Emission-node factors and its placement are
sent as a `light` edit; anything else about it (type, size, shape, spot cone, radius, angle,
spread, shadows, visibility, Max Bounces, light group and linking, a scaled object, a light
data shared by several objects) changes
what the exporter writes beyond the emission and reloads the scene. The edit's emission is the
loaded one (the server reports it in its own unit at `load`) times the ratio of the light's
Blender powers now and at the export, per channel: the exporter's unit conversions are linear,
so this is exactly what exporting again would load, without repeating them here.

A world whose Surface is a Background node (a plain colour, or an Environment Texture as the
exporter writes it) gets `world` edits of colour × strength (an image world's multiplier: the
strength); any other change to the world (its nodes, links, image, volume, Ray Visibility, Max
Bounces, light group) reloads.
"""

import mathutils

from .export.light_nodes import needs_graph
from .export.lights import light_node_factors
from .export.visibility import WORLD_FLAGS

RELOAD = "reload"

# Blender's world axes (Z up) to glTF's (Y up). A light's local frame is not converted by the
# exporter (its -90° X light correction and the axis swap cancel: export/lights.py), so the
# light-to-world matrix in glTF axes is AXES · matrix_world.
AXES = mathutils.Matrix(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, 0), (0, 0, 0, 1)))

# Light properties an edit does not carry: a change to any reloads.
_SHAPE_PROPERTIES = ("type", "shape", "size", "size_y", "spot_size", "spot_blend", "shadow_soft_size", "angle",
                     "spread", "use_shadow", "normalize", "use_soft_falloff", "use_nodes")
_OBJECT_PROPERTIES = ("visible_camera", "visible_diffuse", "visible_glossy", "visible_transmission",
                      "visible_volume_scatter", "is_shadow_catcher", "lightgroup")
# Cycles' own settings of a light or world datablock that the exporter writes (Max Bounces),
# like the world's Ray Visibility: a change to any reloads.
_CYCLES_PROPERTIES = ("max_bounces",)


def _cycles_settings(datablock):
    """The datablock's Cycles settings the exporter reads (a tuple that compares)."""
    cycles = getattr(datablock, "cycles", None)
    return tuple((p, rounded(getattr(cycles, p, None))) for p in _CYCLES_PROPERTIES)


def _linking(obj):
    """The light's light and shadow linking collections (by name)."""
    linking = getattr(obj, "light_linking", None)
    return tuple(getattr(getattr(linking, p, None), "name", None)
                 for p in ("receiver_collection", "blocker_collection"))


def _flat(m):
    return [float(m[r][c]) for c in range(4) for r in range(4)]


def rounded(v):
    """A property or socket value, comparable and rounded to 7 digits (snapshots of lights,
    worlds and materials); strings, which iterate too, are kept as they are."""
    if v is None or isinstance(v, (bool, str, int)):
        return v
    try:
        return tuple(round(float(x), 7) for x in v)
    except TypeError:
        return round(float(v), 7)


def light_power(obj):
    """The light's Blender emission as an RGB power: colour (with its temperature) × energy ×
    2^exposure × the Emission node's Strength and Color, × the area when not normalized — every
    factor the exporter multiplies into what the binary loads."""
    light = obj.data
    color = [float(c) for c in light.color]
    if getattr(light, "use_temperature", False):
        color = [c * float(t) for c, t in zip(color, light.temperature_color)]
    power = float(light.energy) * 2.0 ** float(getattr(light, "exposure", 0.0))
    if light.type == "AREA" and not light.normalize:
        power *= light.area(matrix_world=obj.matrix_world)
    strength, node_color, _ = light_node_factors(obj)
    return [c * power * strength * n for c, n in zip(color, node_color)]


def light_snapshot(obj):
    """What a light edit does not carry (see the module doc); equal snapshots mean the light
    differs from the exported one only in its emission and placement."""
    light = obj.data
    shape = tuple((p, rounded(getattr(light, p, None))) for p in _SHAPE_PROPERTIES)
    flags = tuple((p, rounded(getattr(obj, p, None))) for p in _OBJECT_PROPERTIES)
    tree = light.node_tree if getattr(light, "use_nodes", False) else None
    # A tree sent as its graph (`export.light_nodes`) carries its Emission's values too.
    graph = needs_graph(light)
    nodes = None
    if tree is not None:
        nodes = (tuple(sorted((n.name, n.type, tuple((i.identifier, rounded(getattr(i, "default_value", None)))
                                                     for i in n.inputs if n.type != "EMISSION" or graph))
                              for n in tree.nodes)),
                 tuple(sorted((k.from_node.name, k.from_socket.identifier, k.to_node.name, k.to_socket.identifier)
                              for k in tree.links)))
    # To 5 digits: a turned light's scale, taken out of its matrix, drifts in the 7th.
    scale = tuple(round(float(x), 5) for x in obj.matrix_world.to_scale())
    # A light turned into a portal (or back) is no longer the loaded light: reload.
    portal = bool(getattr(getattr(light, "cycles", None), "is_portal", False))
    return shape, flags, nodes, scale, light.users, portal, _cycles_settings(light), _linking(obj)


def loaded_name(obj):
    """The name the binary reports for a light object: an area light is its node's (the
    object's) name, a punctual one its KHR light's, which the glTF exporter takes from the
    light data."""
    return obj.name if obj.data.type == "AREA" else obj.data.name


class LightState:
    """The lights and world as exported and loaded: what edits are computed against."""

    def __init__(self, scene, loaded_lights):
        """`loaded_lights`: the load reply's `lights` (name, kind, emission)."""
        emission = {entry["name"]: entry.get("emission") for entry in loaded_lights}
        self.lights = {}
        for obj in scene.objects:
            if obj.type == "LIGHT":
                name = loaded_name(obj)
                if emission.get(name) is not None:
                    self.lights[obj.name] = (name, emission[name], light_power(obj), light_snapshot(obj))
        self.world = world_snapshot(scene.world)


def light_request(obj, state):
    """The light edit for a light object that changed, or RELOAD."""
    known = state.lights.get(obj.name)
    if known is None:
        return RELOAD
    name, emission, power0, snapshot = known
    if light_snapshot(obj) != snapshot or obj.data.users > 1:
        return RELOAD
    power = light_power(obj)
    scaled = []
    for e, p, p0 in zip(emission, power, power0):
        if p0 == 0.0:
            if p != 0.0:  # a channel that was black has no loaded value to scale
                return RELOAD
            scaled.append(0.0)
        else:
            scaled.append(float(e) * p / p0)
    return {"type": "light", "name": name, "emission": scaled, "matrix": _flat(AXES @ obj.matrix_world)}


def _background(world):
    """The Background node on the active World Output's Surface (through reroutes), or None."""
    tree = world.node_tree if getattr(world, "use_nodes", True) else None
    if tree is None:
        return None
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_WORLD"]
    output = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    sock = output.inputs["Surface"] if output is not None else None
    while sock is not None and sock.is_linked:
        node = sock.links[0].from_node
        if node.type != "REROUTE":
            return node if node.type == "BACKGROUND" else None
        sock = node.inputs[0]
    return None


def world_snapshot(world):
    """Everything about the world but its Background colour and strength (module doc)."""
    if world is None:
        return None
    tree = world.node_tree if getattr(world, "use_nodes", True) else None
    if tree is None:
        return "no nodes", _cycles_settings(world)
    bg = _background(world)
    nodes = tuple(sorted(
        (n.name, n.type, getattr(getattr(n, "image", None), "name", None),
         tuple((i.identifier, rounded(getattr(i, "default_value", None))) for i in n.inputs
               if not (n == bg and (i.name == "Strength" or i.name == "Color" and not i.is_linked))))
        for n in tree.nodes))
    links = tuple(sorted((k.from_node.name, k.from_socket.identifier, k.to_node.name, k.to_socket.identifier)
                         for k in tree.links))
    flags = getattr(world, "cycles_visibility", None)
    visibility = tuple(bool(getattr(flags, key, True)) for key in WORLD_FLAGS)
    return nodes, links, _cycles_settings(world), visibility, getattr(world, "lightgroup", "")


def world_request(world, state):
    """The world edit for a world that changed, or RELOAD."""
    if world is None or world_snapshot(world) != state.world:
        return RELOAD
    tree = world.node_tree if getattr(world, "use_nodes", True) else None
    if tree is None:
        return {"type": "world", "color": [float(c) for c in world.color[:3]]}
    bg = _background(world)
    if bg is None or bg.inputs["Strength"].is_linked:
        return RELOAD
    strength = float(bg.inputs["Strength"].default_value)
    if bg.inputs["Color"].is_linked:
        # An image world (the snapshot holds its image and mapping): strength scales it.
        return {"type": "world", "color": [strength] * 3}
    return {"type": "world", "color": [float(c) * strength for c in bg.inputs["Color"].default_value[:3]]}
