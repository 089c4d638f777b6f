"""The world (contract: `CAUSTIC_world`), which the glTF exporter does not write: Blender's
Background node, optionally an equirectangular Environment Texture and a Mapping rotation about
Z, as colour/strength/image/rotation; any other World Output Surface (Sky Texture, procedural
textures, Mix/Add Shader of backgrounds, converters) as its whole node graph (`nodes`, in the
shape of `CAUSTIC_materials_nodes`), and so is a world with AOV Output nodes when the view layer
has shader AOVs (Cycles writes them where the camera sees the world)."""

import os

import bpy

from .media import varying_medium, volume_medium
from .node_graph import GraphContext, build_world_graph, has_aov_outputs
from .nodes import linked_node
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
    return value, warnings


def _world_volume(world, warnings, writer=None):
    """The medium of the World Output's Volume input, or None: constant, or with its node
    graph when its inputs vary over space (a texture on the Density), which Cycles evaluates
    per point in a world volume too. An Emission node alone would glow along every unbounded
    ray: it is not exported (warning)."""
    tree = world.node_tree if getattr(world, "use_nodes", True) else None
    if tree is None:
        return None
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_WORLD"]
    output = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    if output is None or not output.inputs["Volume"].is_linked:
        return None
    node = linked_node(output.inputs["Volume"])
    what = f"world '{world.name}'"
    if node.type == "EMISSION":
        return volume_medium(node, what, warnings)
    return varying_medium(world, node, what, warnings, writer)


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
