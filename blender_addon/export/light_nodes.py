"""A light's node tree as its whole graph (contract: `nodes` of `CAUSTIC_lights_area` and
`CAUSTIC_lights_punctual`), in the shape of `CAUSTIC_materials_nodes`.

Cycles multiplies a light's emission by its Light Output's Surface shader evaluated at each
emission (a Blackbody colour, Light Falloff, a texture on the light's coordinates, an IES
profile). An Emission node whose Strength and Color are unlinked is two numbers, which
`lights.light_node_factors` folds into the light's power and colour; any other tree goes to
the renderer as its graph, and the light's power and colour are then its own (without the
tree), which the renderer multiplies by the graph's value (`light::light_graph`).
"""

import hashlib
import os

import bpy

from .node_graph import GraphContext, build_light_graph

# Where the IES Texture nodes' profiles go, beside the glTF (contract: `ies_file`).
IES_FOLDER = "caustic_ies"


def _surface_shader(light):
    """The unmuted node on the light's Cycles output Surface, through reroutes, or None."""
    from .lights import _emission_node
    return _emission_node(light)


def needs_graph(light):
    """Whether the light's node tree is more than an Emission node with unlinked inputs."""
    if not getattr(light, "use_nodes", False) or light.node_tree is None:
        return False
    node = _surface_shader(light)
    if node is None:
        return False  # nothing on the output: `light_node_factors` names it
    if node.type != "EMISSION" or node.mute:
        return True
    return any(node.inputs[name].is_linked for name in ("Strength", "Color"))


def light_graph(blender_object, writer, depsgraph=None):
    """(the `nodes` value, warnings) of the light object's node tree, or (None, []) when
    `needs_graph` is false or no writer is given (a preview without files)."""
    light = blender_object.data
    if writer is None or not needs_graph(light):
        return None, []
    what = f"light '{blender_object.name}'"
    graph = build_light_graph(light, what, GraphContext(depsgraph))
    if graph is None or graph.output["surface"] is None:
        return None, []
    warnings = list(graph.warnings)
    write_ies_profiles(light, graph.nodes, writer.gltf_folder, what, warnings)
    value = writer.graph_value(graph, what, warnings)
    value["output"] = {"surface": graph.output["surface"]}
    return value, warnings


def _ies_bytes(node, what, warnings):
    """The IES Texture node's profile: its internal text datablock or its external file, or
    None (named in a warning: Cycles then renders 100 × Strength)."""
    if node.mode == "INTERNAL":
        if node.ies is None:
            warnings.append(f"{what}, node '{node.name}': the IES Texture has no text datablock")
            return None
        return node.ies.as_string().encode("utf-8")
    path = bpy.path.abspath(node.filepath)
    try:
        with open(path, "rb") as f:
            return f.read()
    except OSError as err:
        warnings.append(f"{what}, node '{node.name}': the IES file '{node.filepath}' cannot be read ({err})")
        return None


def write_ies_profiles(owner, nodes, folder, what, warnings):
    """Write the profiles of the IES Texture entries among `nodes` (a graph's written node
    entries) of `owner`'s node tree (a light or a material) beside the glTF."""
    for entry in nodes:
        if entry["type"] == "ShaderNodeTexIES":
            _write_ies(owner, entry, folder, what, warnings)


def _write_ies(owner, entry, folder, what, warnings):
    """Write the profile of the graph's IES Texture `entry` into `<folder>/caustic_ies/` (named
    by its content's hash, so a profile used twice is written once) as its `ies_file`."""
    props = entry["props"]
    for key in ("mode", "filepath", "ies"):
        props.pop(key, None)
    node = owner.node_tree.nodes.get(entry["name"])
    if node is None or node.bl_idname != "ShaderNodeTexIES":
        warnings.append(f"{what}, node '{entry['name']}': an IES Texture inside a node group is not "
                        "exported (Caustic renders 100 × Strength, as Cycles for a missing profile)")
        return
    data = _ies_bytes(node, what, warnings)
    if data is None:
        return
    name = f"{hashlib.sha1(data).hexdigest()[:16]}.ies"
    os.makedirs(os.path.join(folder, IES_FOLDER), exist_ok=True)
    with open(os.path.join(folder, IES_FOLDER, name), "wb") as f:
        f.write(data)
    props["ies_file"] = f"{IES_FOLDER}/{name}"
