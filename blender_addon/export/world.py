"""The world: Blender's Background node, optionally an equirectangular Environment Texture and
a Mapping rotation about Z (contract: `CAUSTIC_world`), which the glTF exporter does not write."""

import os

import bpy

from .media import volume_medium
from .nodes import linked_node

WORLD_EXTENSION = "CAUSTIC_world"

_IMAGE_EXTENSIONS = {"HDR": ".hdr", "OPEN_EXR": ".exr", "OPEN_EXR_MULTILAYER": ".exr", "PNG": ".png",
                     "JPEG": ".jpg"}


def world_extension(scene, folder):
    """The `CAUSTIC_world` value for the scene's world, and warnings about what it drops.

    Supported: a Background node (colour × strength) on the active World Output, whose colour
    may come from an Environment Texture (equirectangular) optionally rotated about Z by a
    Mapping node (the image file, or the packed image's bytes, is copied next to the glTF);
    and a volume shader on its Volume output (`medium`: fog filling the scene).
    """
    world = scene.world
    if world is None:
        return None, []
    warnings = []
    value, warnings = _world_surface(world, folder, warnings)
    medium = _world_volume(world, warnings)
    if medium is not None:
        # A world without a surface is black; its fog still counts.
        value = value or {"color": [0.0, 0.0, 0.0], "strength": 0.0}
        value["medium"] = medium
    return value, warnings


def _world_volume(world, warnings):
    """The medium of the World Output's Volume input, or None."""
    tree = world.node_tree if getattr(world, "use_nodes", True) else None
    if tree is None:
        return None
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_WORLD"]
    output = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    if output is None or not output.inputs["Volume"].is_linked:
        return None
    return volume_medium(linked_node(output.inputs["Volume"]), f"world '{world.name}'", warnings)


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
