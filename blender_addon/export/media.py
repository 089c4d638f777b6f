"""Light inside a material: Principled subsurface (`CAUSTIC_materials_subsurface`) and the
material's Volume output (`CAUSTIC_materials_medium`), which Blender's glTF exporter drops.
Coefficients as Cycles builds them (contract). A volume shader whose inputs vary over space (a
texture, a ColorRamp, an Attribute on its Density, colours or emission) also carries its node
graph (`graph`, `graph_shader`), which the renderer evaluates at each point of the medium."""

import math

from .constant_fold import folded_float
from .node_graph import GraphContext, build_volume_graph
from .nodes import linked_node, material_output, socket, value as _value

SUBSURFACE_EXTENSION = "CAUSTIC_materials_subsurface"
MEDIUM_EXTENSION = "CAUSTIC_materials_medium"

# Blender's subsurface methods -> the contract's; Christensen-Burley has no random walk of
# its own and is rendered as Random Walk (with a warning).
_SUBSURFACE_METHODS = {"RANDOM_WALK": "random_walk", "RANDOM_WALK_SKIN": "random_walk_skin",
                       "BURLEY": "random_walk"}


def subsurface_extension(blender_material):
    """The `CAUSTIC_materials_subsurface` value of a material (None without subsurface), and warnings."""
    warnings = []
    tree = getattr(blender_material, "node_tree", None)
    if tree is None:
        return None, warnings
    output = material_output(tree)
    if output is None or not output.inputs["Surface"].is_linked:
        return None, warnings
    node = linked_node(output.inputs["Surface"])
    if node.type != "BSDF_PRINCIPLED":
        return None, warnings
    what = f"material '{blender_material.name}'"
    weight = float(_value(node, "Subsurface Weight", what, warnings, 0.0))
    if weight <= 0.0:
        return None, []
    radius = _value(node, "Subsurface Radius", what, warnings, (1.0, 0.2, 0.1))
    scale = float(_value(node, "Subsurface Scale", what, warnings, 0.05))
    method = getattr(node, "subsurface_method", "RANDOM_WALK")
    if method == "BURLEY":
        warnings.append(f"{what}: subsurface method Christensen-Burley is rendered as Random Walk")
    value = {
        "weight": weight,
        "radius": [max(float(r), 0.0) * max(scale, 0.0) for r in radius[:3]],
        "anisotropy": float(_value(node, "Subsurface Anisotropy", what, warnings, 0.0)),
        "ior": float(_value(node, "Subsurface IOR", what, warnings, 1.4)),
        "method": _SUBSURFACE_METHODS.get(method, "random_walk"),
    }
    return value, warnings


def medium_extension(blender_material, writer=None):
    """The `CAUSTIC_materials_medium` value of a material's Volume output (None without one),
    and warnings naming what cannot be exported. Coefficients as Cycles builds them (contract).
    A varying volume's images are written by `writer` (node_images.ImageWriter); without one
    a graph with images is not exported (warning)."""
    warnings = []
    tree = getattr(blender_material, "node_tree", None)
    if tree is None:
        return None, warnings
    output = material_output(tree)
    if output is None or not output.inputs["Volume"].is_linked:
        return None, warnings
    node = linked_node(output.inputs["Volume"])
    value = varying_medium(blender_material, node, f"material '{blender_material.name}'", warnings, writer)
    if value is None:
        return None, warnings
    value["surface"] = bool(output.inputs["Surface"].is_linked)
    return value, warnings


def varying_medium(owner, node, what, warnings, writer=None):
    """The `CAUSTIC_materials_medium` value (without `surface`) of volume shader `node` in
    the node tree of `owner` (a material, or the world), with its node graph when its inputs
    vary over space (its images written by `writer`); None (with a warning) for a node that
    is not a volume shader."""
    if node.type in TREE_NODES:
        return tree_medium(owner, node, what, warnings, writer)
    graph = _volume_graph(owner, node, what, warnings, writer)
    if graph is None:
        value = volume_medium(node, what, warnings)
    elif node.type == "EMISSION":
        # Emission only: the graph gives it; the constant part is an empty medium.
        value = {"density": 0.0, "scatter_color": [0.0] * 3, "absorption_color": [0.0] * 3, "anisotropy": 0.0}
    else:
        # The graph carries the linked inputs: the constant part's "input is linked" warnings
        # do not apply.
        constant = []
        value = volume_medium(node, what, constant)
        warnings.extend(w for w in constant if "input is linked" not in w)
    if value is not None and graph is not None:
        value["graph"], value["graph_shader"] = graph
    return value


# Inputs of each volume shader that a link can make vary over the medium.
_VARYING_INPUTS = {
    "PRINCIPLED_VOLUME": ("Density", "Color", "Absorption Color", "Anisotropy", "Emission Strength",
                          "Emission Color", "Blackbody Intensity", "Blackbody Tint", "Temperature"),
    "VOLUME_SCATTER": ("Density", "Color", "Anisotropy"),
    "VOLUME_ABSORPTION": ("Density", "Color"),
    "EMISSION": ("Color", "Strength"),
}


# Volume output nodes whose shaders the renderer reads from the node graph whatever their
# inputs: Mix and Add Shader trees (their shaders' coefficients summed by weight, as Cycles
# sums volume closures) and Volume Coefficients. A tree whose inputs are all constant is
# folded into one homogeneous medium by the renderer.
TREE_NODES = {"MIX_SHADER", "ADD_SHADER", "VOLUME_COEFFICIENTS"}


def tree_medium(owner, node, what, warnings, writer=None):
    """The `CAUSTIC_materials_medium` value (without `surface`) of the shader tree under
    `node`: an empty constant part and the tree's graph, or None (warning) when its images
    cannot be written here."""
    graph = _graph_of(owner, node, what, warnings, writer, "the volume is left out")
    if graph is None:
        return None
    return {"density": 0.0, "scatter_color": [0.0] * 3, "absorption_color": [0.0] * 3, "anisotropy": 0.0,
            "graph": graph[0], "graph_shader": graph[1]}


def _graph_of(owner, node, what, warnings, writer, instead):
    """(graph value, root index) of the Volume output's graph under `node`, its images written
    by `writer`; without a writer (the viewport's comparison of a material's extras) a graph with
    images is not exported: None, with a warning ending in `instead` (what happens then)."""
    graph, index = build_volume_graph(owner, node, GraphContext())
    if graph.images and writer is None:
        warnings.append(f"{what}: an Image Texture feeds the {node.name} node on the Volume output; its "
                        f"images cannot be written here and {instead}")
        return None
    warnings.extend(graph.warnings)
    if writer is None:
        return {"version": 1, "nodes": graph.nodes, "output": {}}, index
    value = writer.graph_value(graph, what, warnings)
    value["output"] = {}
    return value, index


def _varies(node):
    """Whether an input of the volume shader is linked to something that does not fold to a
    constant (a float chain of Value and Math nodes folds, `constant_fold`)."""
    for name in _VARYING_INPUTS.get(node.type, ()):
        sock = socket(node, name)
        if sock is not None and sock.is_linked and (sock.type != "VALUE" or folded_float(sock) is None):
            return True
    return False


def is_varying(node):
    """Whether volume shader `node` needs its node graph: a shader tree, or an input linked to
    something that does not fold to a constant."""
    return node.type in TREE_NODES or _varies(node)


def _volume_graph(owner, node, what, warnings, writer):
    """(graph value, shader index) of a volume shader whose inputs vary (an Emission node on
    the Volume output always), or None. Its images are written by `writer`; without a writer
    (the viewport's comparison of a material's extras) a graph with images is not exported:
    the constant medium is used, with a warning."""
    if node.type not in _VARYING_INPUTS or not (node.type == "EMISSION" or _varies(node)):
        return None
    return _graph_of(owner, node, what, warnings, writer, "its inputs' own values are used")


def volume_uses_generated(blender_material):
    """Whether the material's Volume output graph reads Generated coordinates (the mesh's
    texture space is then exported, meshes.py)."""
    tree = getattr(blender_material, "node_tree", None)
    output = material_output(tree) if tree is not None else None
    if output is None or not output.inputs["Volume"].is_linked:
        return False
    node = linked_node(output.inputs["Volume"])
    if node.type not in TREE_NODES and (
            node.type not in _VARYING_INPUTS or not (node.type == "EMISSION" or _varies(node))):
        return False
    return build_volume_graph(blender_material, node, GraphContext())[0].uses_generated


def _density(node, what, warnings):
    """A volume shader's Density: its value, or the constant a linked chain of Value and Math
    nodes folds to (`constant_fold`); another link (a texture, an attribute) is named in a
    warning and the socket's own value is used."""
    sock = socket(node, "Density")
    if sock is not None and sock.is_linked:
        folded = folded_float(sock)
        if folded is not None:
            return folded
    return float(_value(node, "Density", what, warnings, 1.0))


# The Volume Scatter inputs each phase function reads beside Anisotropy -> the contract's keys.
_PHASE_INPUTS = {"DRAINE": (("Alpha", "phase_alpha", 0.5),),
                 "FOURNIER_FORAND": (("IOR", "phase_ior", 1.33), ("Backscatter", "phase_backscatter", 0.1)),
                 "MIE": (("Diameter", "phase_diameter", 20.0),)}


def scatter_phase(node, what, warnings):
    """A Volume Scatter node's Phase (Blender 5.0: Henyey-Greenstein, Fournier-Forand, Draine,
    Rayleigh, Mie) and the inputs it reads, as the contract's `phase*` keys; Henyey-Greenstein
    writes nothing (the default)."""
    phase = getattr(node, "phase", "HENYEY_GREENSTEIN")
    if phase == "HENYEY_GREENSTEIN":
        return {}
    value = {"phase": phase}
    for name, key, default in _PHASE_INPUTS.get(phase, ()):
        value[key] = float(_value(node, name, what, warnings, default))
    return value


def volume_medium(node, what, warnings):
    """The medium coefficients of a volume shader node (Principled Volume, Volume Scatter,
    Volume Absorption) as `CAUSTIC_materials_medium` has them, or None (with a warning) for
    another node. Shared by materials and the world's Volume output."""
    value = {}

    def rgb(name, default):
        return [float(c) for c in _value(node, name, what, warnings, default)[:3]]

    if node.type == "PRINCIPLED_VOLUME":
        color = rgb("Color", (0.5, 0.5, 0.5))
        absorption = rgb("Absorption Color", (0.0, 0.0, 0.0))
        value["density"] = max(_density(node, what, warnings), 0.0)
        value["scatter_color"] = [max(c, 0.0) for c in color]
        value["absorption_color"] = [max(1.0 - c, 0.0) * max(1.0 - math.sqrt(max(a, 0.0)), 0.0)
                                     for c, a in zip(color, absorption)]
        value["anisotropy"] = float(_value(node, "Anisotropy", what, warnings, 0.0))
        strength = float(_value(node, "Emission Strength", what, warnings, 0.0))
        value["emission"] = [max(c, 0.0) * max(strength, 0.0) for c in rgb("Emission Color", (1, 1, 1))]
        value["blackbody_intensity"] = max(float(_value(node, "Blackbody Intensity", what, warnings, 0.0)), 0.0)
        value["blackbody_tint"] = [max(c, 0.0) for c in rgb("Blackbody Tint", (1.0, 1.0, 1.0))]
        value["temperature"] = float(_value(node, "Temperature", what, warnings, 1000.0))
    elif node.type == "VOLUME_SCATTER":
        value["density"] = max(_density(node, what, warnings), 0.0)
        value["scatter_color"] = [max(c, 0.0) for c in rgb("Color", (0.8, 0.8, 0.8))]
        value["absorption_color"] = [0.0, 0.0, 0.0]
        value["anisotropy"] = float(_value(node, "Anisotropy", what, warnings, 0.0))
        value.update(scatter_phase(node, what, warnings))
    elif node.type == "VOLUME_ABSORPTION":
        value["density"] = max(_density(node, what, warnings), 0.0)
        value["scatter_color"] = [0.0, 0.0, 0.0]
        value["absorption_color"] = [max(1.0 - c, 0.0) for c in rgb("Color", (0.8, 0.8, 0.8))]
    else:
        warnings.append(f"{what}: the {node.name} node ({node.bl_label}) on the Volume output cannot be "
                        "exported; the volume is left out")
        return None
    value["anisotropy"] = min(max(value.get("anisotropy", 0.0), -1.0), 1.0)
    return value
