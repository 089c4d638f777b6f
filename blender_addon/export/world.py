"""The world (contract: `CAUSTIC_world`), which the glTF exporter does not write: Blender's
Background node, optionally an equirectangular Environment Texture and a Mapping rotation about
Z, as colour/strength/image/rotation; any other World Output Surface (Sky Texture, procedural
textures, Mix/Add Shader of backgrounds, converters) as its whole node graph (`nodes`, in the
shape of `CAUSTIC_materials_nodes`), and so is a world with AOV Output nodes when the view layer
has shader AOVs (Cycles writes them where the camera sees the world)."""

import json
import os

import bpy

from .lights import cycles_max_bounces
from .media import TREE_NODES, tree_medium, varying_medium
from .node_graph import GraphContext, build_world_graph, has_aov_outputs
from .nodes import linked_node
from .settings import REC709, working_space_name
from .visibility import world_visibility

WORLD_EXTENSION = "CAUSTIC_world"

_IMAGE_EXTENSIONS = {"HDR": ".hdr", "OPEN_EXR": ".exr", "OPEN_EXR_MULTILAYER": ".exr", "PNG": ".png",
                     "JPEG": ".jpg"}


# The nodes of a world the plain form expresses (colour, strength, image, rotation).
_PLAIN_WORLD_NODES = {"BACKGROUND", "TEX_ENVIRONMENT", "MAPPING", "TEX_COORD"}


def world_extension(scene, folder, writer=None, depsgraph=None):
    """The `CAUSTIC_world` value for the scene's world, and warnings about what it drops.

    A Background node (colour × strength) on the active World Output, whose colour may come
    from an Environment Texture (equirectangular) optionally rotated about Z by a Mapping node,
    is written in the plain form (the image file, or the packed image's bytes, is copied next
    to the glTF, at full float precision); any other Surface graph is written as `nodes`, its
    images through `writer` (node_images.ImageWriter), as is one with AOV Output nodes when
    the view layer of `depsgraph` has shader AOVs. A volume shader on the Volume output is
    `medium`: fog filling the scene.
    """
    world = scene.world
    if world is None:
        return None, []
    warnings = []
    value, warnings = _world_surface(world, folder, warnings)
    context = GraphContext(depsgraph)
    tree = world.node_tree if getattr(world, "use_nodes", True) else None
    aovs = context.with_aovs and has_aov_outputs(tree)
    graph_value = None
    if writer is not None and (warnings or aovs or not _plain_world(world)):
        graph_value, graph_warnings = _world_graph(world, writer, context)
        if graph_value is not None:
            value, warnings = graph_value, graph_warnings
    if aovs and writer is not None and graph_value is None:
        warnings.append(f"world '{world.name}': its AOV Output nodes are not rendered (the World Output's "
                        "Surface is not linked)")
    medium = _world_volume(world, warnings, writer)
    if medium is not None:
        # A world without a surface is black; its fog still counts.
        value = value or {"color": [0.0, 0.0, 0.0], "strength": 0.0}
        value["medium"] = medium
    hidden = world_visibility(world)
    if value is not None and hidden is not None:
        value["visibility"] = hidden
    # Max Bounces limits the world's light sampling, which Cycles does only with the world's
    # Sampling on (its background light); with Sampling None the limit changes nothing.
    bounces = cycles_max_bounces(world)
    sampled = getattr(getattr(world, "cycles", None), "sampling_method", "AUTOMATIC") != "NONE"
    if value is not None and bounces is not None and sampled:
        value["max_bounces"] = bounces
    return value, warnings


# What makes a written glTF more than a camera: geometry and lights, on nodes or the root.
_SEEN_NODE_KEYS = ("mesh",)
_SEEN_NODE_EXTENSIONS = ("KHR_lights_punctual", "CAUSTIC_lights_area")
_SEEN_ROOT_EXTENSIONS = ("CAUSTIC_curves", "CAUSTIC_points")


def add_black_world_if_empty(gltf_path, scene):
    """Write Blender's missing world as a black `CAUSTIC_world` into a glTF that has nothing
    else to see (no mesh, curves, points or light); returns True when it did.

    Cycles renders a scene without a World black. The binary refuses a file with no geometry,
    no world and no lights (nothing to render, more likely a broken file than an intent), so a
    .blend with only a camera (every object hidden, or no world at all) says its black world
    explicitly; any other file keeps no world, which the binary reads as black too.
    """
    if scene.world is not None:
        return False
    with open(gltf_path, encoding="utf-8") as f:
        doc = json.load(f)
    if any(key in node for node in doc.get("nodes", []) for key in _SEEN_NODE_KEYS):
        return False
    if any(ext in node.get("extensions", {}) for node in doc.get("nodes", []) for ext in _SEEN_NODE_EXTENSIONS):
        return False
    if any(ext in doc.get("extensions", {}) for ext in _SEEN_ROOT_EXTENSIONS):
        return False
    target = doc.get("scenes", [{}])[doc.get("scene", 0)]
    target.setdefault("extensions", {})[WORLD_EXTENSION] = {"color": [0.0, 0.0, 0.0], "strength": 0.0}
    used = doc.setdefault("extensionsUsed", [])
    if WORLD_EXTENSION not in used:
        used.append(WORLD_EXTENSION)
    with open(gltf_path, "w", encoding="utf-8") as f:
        json.dump(doc, f)
    return True


def _world_volume(world, warnings, writer=None):
    """The medium of the World Output's Volume input, or None: constant, or with its node
    graph when its inputs vary over space (a texture on the Density), which Cycles evaluates
    per point in a world volume too. Emission added to an absorbing or scattering shader (Add
    Shader) is folded into that shader's medium (`_emitting_medium`); an Emission node alone
    is not exported (warning: Cycles renders it as infinite radiance)."""
    tree = world.node_tree if getattr(world, "use_nodes", True) else None
    if tree is None:
        return None
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_WORLD"]
    output = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    if output is None or not output.inputs["Volume"].is_linked:
        return None
    node = linked_node(output.inputs["Volume"])
    what = f"world '{world.name}'"
    if node.type in {"EMISSION", "ADD_SHADER"}:
        return _emitting_medium(world, node, what, warnings, writer)
    return varying_medium(world, node, what, warnings, writer)


# Measured with bpy 5.0.1 (CPU, 64x48): an Emission of strength 0.1 alone on the World Volume
# makes every pixel inf, whatever the camera's clip end (10, 100 or 1000) -- Cycles integrates
# the emission over rays that escape to FLT_MAX with nothing attenuating it
# (`volume_emission_integrate`: E * t).
_INFINITE = "Cycles renders it as infinite radiance (every pixel inf)"


def _emission_leaves(node, what, warnings):
    """(summed emitted radiance per unit length of the Emission nodes, the other shader nodes)
    under an Add Shader tree (or one node), or None when an Emission's input is linked (warned)."""
    if node is None or node.mute:
        return [0.0, 0.0, 0.0], []
    if node.type == "ADD_SHADER":
        total, others = [0.0, 0.0, 0.0], []
        for sock in node.inputs:
            part = _emission_leaves(linked_node(sock), what, warnings)
            if part is None:
                return None
            total = [a + b for a, b in zip(total, part[0])]
            others += part[1]
        return total, others
    if node.type == "EMISSION":
        if node.inputs["Color"].is_linked or node.inputs["Strength"].is_linked:
            warnings.append(f"{what}: the {node.name} node on the World Volume has a linked input, which "
                            "Caustic does not read there; the volume is left out")
            return None
        strength = max(float(node.inputs["Strength"].default_value), 0.0)
        return [max(float(c), 0.0) * strength for c in node.inputs["Color"].default_value[:3]], []
    return [0.0, 0.0, 0.0], [node]


def _emitting_medium(world, node, what, warnings, writer):
    """The medium of an Emission node added to one absorbing or scattering shader on the World
    Volume (its emission is summed into that shader's), or None with a warning: an Emission
    alone, or emission in a colour channel the medium does not attenuate, which Cycles
    integrates over unbounded rays to infinity. Several shaders added or mixed go to the renderer
    as one tree (`tree_medium`), which sums them, Emission included."""
    leaves = _emission_leaves(node, what, warnings)
    if leaves is None:
        return None
    emission, others = leaves
    if not others:
        if max(emission) > 0.0:
            warnings.append(f"{what}: an Emission on the World Volume with nothing absorbing or scattering "
                            f"glows along every ray that leaves the scene; {_INFINITE}; the volume is left out")
        return None
    if len(others) > 1 or any(n.type in TREE_NODES for n in others):
        # Several shaders added (or mixed): the renderer sums the whole tree, Emission included.
        return tree_medium(world, node, what, warnings, writer)
    value = varying_medium(world, others[0], what, warnings, writer)
    if value is None or max(emission) <= 0.0:
        return value
    if "graph" in value:
        return _graph_with_emission(value, others[0], emission, what, warnings)
    own = value.get("emission", [0.0, 0.0, 0.0])
    value["emission"] = [a + b for a, b in zip(own, emission)]
    density = value["density"]
    sigma_t = [density * (s + a) for s, a in zip(value["scatter_color"], value["absorption_color"])]
    if any(e > 0.0 and st <= 0.0 for e, st in zip(value["emission"], sigma_t)):
        warnings.append(f"{what}: the World Volume emits in a colour channel its {others[0].name} node does "
                        f"not attenuate, so the light along rays that leave the scene is unbounded; {_INFINITE} "
                        "in that channel; the volume is left out")
        return None
    return value


def _graph_with_emission(value, shader, emission, what, warnings):
    """`value` (a medium with a graph) whose Principled Volume also emits `emission`: its
    Emission Color and Strength, unlinked, become their product plus `emission`. Another
    shader in the graph has no emission input: the volume is left out (warning)."""
    entry = value["graph"]["nodes"][value["graph_shader"]]
    inputs = entry["inputs"]
    color, strength = inputs.get("Emission Color", {}), inputs.get("Emission Strength", {})
    if shader.type != "PRINCIPLED_VOLUME" or "link" in color or "link" in strength:
        warnings.append(f"{what}: an Emission added to the textured {shader.name} node on the World Volume "
                        "is only read with a Principled Volume whose own Emission inputs are not linked; "
                        "the volume is left out")
        return None
    own = [float(c) * float(strength.get("value", 0.0)) for c in color.get("value", [1.0, 1.0, 1.0])[:3]]
    total = [a + b for a, b in zip(own, emission)]
    inputs["Emission Color"] = dict(color, value=total + [1.0])
    inputs["Emission Strength"] = dict(strength, value=1.0)
    return value


def _world_surface(world, folder, warnings):
    """The Background part of `CAUSTIC_world` (None for a black world) and the warnings."""
    tree = world.node_tree if getattr(world, "use_nodes", True) else None
    if tree is None:
        c = world.color
        return {"color": [float(c[0]), float(c[1]), float(c[2])], "strength": 1.0}, warnings
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_WORLD"]
    output = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    if output is None or not output.inputs["Surface"].is_linked:
        return None, warnings
    node = linked_node(output.inputs["Surface"])
    if node.type != "BACKGROUND":
        warnings.append(f"world '{world.name}': the {node.bl_label} node is not supported; the world is black")
        return None, warnings
    if node.inputs["Strength"].is_linked:
        warnings.append(f"world '{world.name}': a linked Strength is not supported; using its value")
    strength = float(node.inputs["Strength"].default_value)
    value = {"color": [1.0, 1.0, 1.0], "strength": strength}
    color_in = node.inputs["Color"]
    source = linked_node(color_in)
    if source is None:
        value["color"] = [float(c) for c in color_in.default_value[:3]]
        return value, warnings
    if source.type != "TEX_ENVIRONMENT" or source.image is None:
        warnings.append(f"world '{world.name}': colour from a {source.bl_label} node is not supported; "
                        "using the Background colour")
        value["color"] = [float(c) for c in color_in.default_value[:3]]
        return value, warnings
    if source.projection != "EQUIRECTANGULAR":
        warnings.append(f"world '{world.name}': {source.projection} projection is not supported; "
                        "read as equirectangular")
    mapping = linked_node(source.inputs["Vector"])
    if mapping is not None:
        if mapping.type == "MAPPING":
            rotation = mapping.inputs["Rotation"].default_value
            value["rotation"] = float(rotation[2])
            if abs(rotation[0]) > 1e-6 or abs(rotation[1]) > 1e-6:
                warnings.append(f"world '{world.name}': Mapping rotation about X/Y is not supported")
        elif mapping.type != "TEX_COORD":
            warnings.append(f"world '{world.name}': the {mapping.bl_label} node before the "
                            "Environment Texture is not supported")
    image = source.image
    if not _file_space_is_blenders(image):
        # The renderer decodes the copied file itself (8-bit as sRGB, float as linear Rec.709):
        # another colour space set in Blender would be ignored (an OpenEXR Blender saved from
        # a float image is marked sRGB and held decoded: 1.84x too bright at 0.19 read as is).
        warnings.append(f"world '{world.name}': image '{image.name}' is in colour space "
                        f"'{image.colorspace_settings.name}', which the renderer does not read from its file; "
                        f"read as {'linear' if image.is_float else 'sRGB'}")
    suffix = _IMAGE_EXTENSIONS.get(image.file_format, os.path.splitext(image.filepath)[1].lower() or ".png")
    target = os.path.join(folder, "world" + suffix)
    if image.packed_file is not None:
        with open(target, "wb") as f:
            f.write(image.packed_file.data)
    else:
        src = bpy.path.abspath(image.filepath, library=image.library)
        if not os.path.isfile(src):
            warnings.append(f"world '{world.name}': image '{image.name}' has no file ({src}); "
                            "using the Background colour")
            value["color"] = [float(c) for c in color_in.default_value[:3]]
            return value, warnings
        with open(src, "rb") as fin, open(target, "wb") as fout:
            fout.write(fin.read())
    value["image"] = os.path.basename(target)
    return value, warnings


def _file_space_is_blenders(image):
    """Whether the renderer reads `image`'s file in the colour space Blender gives it: it reads
    an 8-bit file as sRGB, a float one (OpenEXR, Radiance HDR, 16-bit PNG) as linear Rec.709
    (converted to the working space)."""
    settings = image.colorspace_settings
    if not image.is_float:
        return settings.name == "sRGB" and not settings.is_data
    return settings.name == REC709 or (settings.is_data and working_space_name() == REC709)


def _surface_tree_nodes(world):
    """Every node feeding the active World Output's Surface (Blender's own links), or None
    when a group or muted node is on the way."""
    tree = world.node_tree if getattr(world, "use_nodes", True) else None
    if tree is None:
        return []
    output = tree.get_output_node("CYCLES")
    if output is None or not output.inputs["Surface"].is_linked:
        return []
    seen, nodes, todo = set(), [], [output.inputs["Surface"]]
    while todo:
        for link in todo.pop().links:
            node = link.from_node
            if node.as_pointer() in seen:
                continue
            seen.add(node.as_pointer())
            if node.type == "GROUP" or node.mute or node.type == "REROUTE":
                return None
            nodes.append(node)
            todo.extend(s for s in node.inputs if s.is_linked)
    return nodes


def _plain_world(world):
    """Whether the plain form says everything the Surface does: only Background, Environment
    Texture, Texture Coordinate and a point Mapping that only turns about Z."""
    nodes = _surface_tree_nodes(world)
    if nodes is None:
        return False
    for node in nodes:
        if node.type not in _PLAIN_WORLD_NODES:
            return False
        if node.type == "MAPPING":
            loc, scale = node.inputs["Location"], node.inputs["Scale"]
            if node.vector_type != "POINT" or loc.is_linked or scale.is_linked or node.inputs["Rotation"].is_linked:
                return False
            if any(abs(v) > 1e-6 for v in loc.default_value) or any(abs(v - 1.0) > 1e-6 for v in scale.default_value):
                return False
        if node.type == "TEX_COORD" and any(o.is_linked for o in node.outputs if o.name != "Generated"):
            return False
    return True


def _world_graph(world, writer, context):
    """The `nodes` form of `CAUSTIC_world` and its warnings, or (None, []) without a Cycles
    World Output or a linked Surface; the AOV Output nodes come along when `context` asks for them."""
    graph = build_world_graph(world, context)
    if graph is None or graph.output["surface"] is None:
        return None, []
    warnings = list(graph.warnings)
    value = writer.graph_value(graph, f"world '{world.name}'", warnings)
    value["output"] = {"surface": graph.output["surface"]}
    return {"nodes": value}, warnings
