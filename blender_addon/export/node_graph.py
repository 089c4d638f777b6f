"""A material's shader node graph as Cycles sees it: `CAUSTIC_materials_nodes` (contract).

`build_graph` walks backwards from the active Material Output (Cycles target) and returns the
contract's node list: node groups inlined (inner nodes named `Group/Inner`, Group Input and
Group Output resolved to what feeds them), reroutes removed, muted nodes replaced by their
internal pass-through links (an output without one feeds nothing, as in Cycles), invalid and
muted links and links from unavailable sockets treated as absent.
The walk reads Blender data only; images are collected (the caller writes them, node_images.py)
and the few settings that need the scene (UV map numbers, object matrices) come from a
`GraphContext`.

AOV Output nodes (Blender's shader AOVs) are added, with what feeds them, when the view layer
being rendered has AOVs (`GraphContext.with_aovs`): Cycles writes every unmuted one of the tree,
inside node groups too, whatever the Material Output reads.

`needs_graph` says whether the glTF exporter could express the material itself (contract: only
Principled BSDF, Image Texture, Normal Map, UV Map and Material Output, with the links the
exporter reads); a material it can express keeps today's export unchanged.
"""

import bpy
import numpy as np

from .attributes import view_layer_rgba
from .image_frames import sequence_frame, udim_tiles
from .node_images import png_with_alpha

GRAPH_EXTENSION = "CAUSTIC_materials_nodes"
GRAPH_VERSION = 1

# What the glTF exporter reads (contract): any other node type needs the graph.
_EXPRESSIBLE = {"ShaderNodeBsdfPrincipled", "ShaderNodeTexImage", "ShaderNodeNormalMap", "ShaderNodeUVMap"}
# The Principled BSDF inputs whose links the exporter turns into glTF textures (io_scene_gltf2
# 5.0: base colour and alpha, metallic/roughness, normal, emission, clearcoat, transmission,
# specular, sheen); a link into any other input is dropped by it.
_EXPORTER_LINKED_INPUTS = {"Base Color", "Alpha", "Metallic", "Roughness", "Normal", "Emission Color",
                           "Coat Weight", "Coat Roughness", "Coat Normal", "Transmission Weight",
                           "Specular IOR Level", "Specular Tint", "Sheen Color", "Sheen Roughness"}
# Pointer properties that are not settings of the node (legacy texture mapping, image user):
_SKIPPED_POINTERS = {"texture_mapping", "color_mapping", "image_user", "node_tree"}
# Cycles' colour-to-float conversion: luminance of linear Rec.709 (util/color.h, the scene's
# default colour space).
_LUMINANCE = (0.2126729, 0.7151522, 0.0721750)
# Blender Z-up to glTF Y-up: (x, y, z) -> (x, z, -y).
_Y_UP = ((1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0), (0.0, -1.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
# Samples of ColorRamp and curve tables: as Cycles 5.0 bakes them (RAMP_TABLE_SIZE + 1 entries
# at i/256, looked up with floor; checked with a render: a CONSTANT ramp's step at 0.65 falls at
# 167/256), so that the renderer's lookup gives Cycles' values, step positions included.
TABLE_SIZE = 257
# Nodes that name a UV map (`uv_map`, empty: the active render map) and nodes that read the
# active render map when their input is unlinked (Image Texture) or on an output (UV).
_NAMED_UV_NODES = {"ShaderNodeUVMap", "ShaderNodeNormalMap", "ShaderNodeTangent"}
_ACTIVE_UV_NODES = {"ShaderNodeTexImage", "ShaderNodeTexCoord"}
# Procedural textures whose unlinked Vector input is Generated in Cycles
# (SocketType::LINK_TEXTURE_GENERATED); Image Texture's is UV, Environment's the direction.
_GENERATED_DEFAULT = {"TEX_NOISE", "TEX_VORONOI", "TEX_WAVE", "TEX_CHECKER", "TEX_GRADIENT", "TEX_MAGIC",
                      "TEX_BRICK", "TEX_WHITE_NOISE", "TEX_GABOR"}


def _identity_mapping(mapping):
    """Whether a node's Texture Mapping leaves the vector as it is (Cycles' TextureMapping::skip:
    no translation, rotation or scaling, axes in place, no min/max; the vector type alone
    changes nothing then)."""
    return (tuple(mapping.translation) == (0.0, 0.0, 0.0) and tuple(mapping.rotation) == (0.0, 0.0, 0.0)
            and tuple(mapping.scale) == (1.0, 1.0, 1.0) and not mapping.use_min and not mapping.use_max
            and (mapping.mapping_x, mapping.mapping_y, mapping.mapping_z) == ("X", "Y", "Z"))


def colour_attributes_read(tree, seen=None):
    """The attribute names the tree's Attribute (geometry) and Color Attribute nodes read, its
    groups' included; '' for a Color Attribute node reading the active one."""
    seen = set() if seen is None else seen
    if tree is None or tree.as_pointer() in seen:
        return set()
    seen.add(tree.as_pointer())
    names = set()
    for node in tree.nodes:
        if node.bl_idname == "ShaderNodeAttribute" and node.attribute_type == "GEOMETRY":
            names.add(node.attribute_name)
        elif node.bl_idname == "ShaderNodeVertexColor":
            names.add(node.layer_name)
        elif node.bl_idname == "ShaderNodeGroup":
            names |= colour_attributes_read(node.node_tree, seen)
    return names


def single_colour_attribute(depsgraph):
    """The one colour attribute name the node trees of the depsgraph's materials read (Attribute
    and Color Attribute nodes), else None (none, several, or a Color Attribute node reading the
    active one): the export then asks the glTF exporter for it by name as COLOR_0."""
    names, seen = set(), set()
    for obj in depsgraph.objects:
        for slot in getattr(obj, "material_slots", ()):
            mat = slot.material
            if mat is not None and mat.node_tree is not None:
                names |= colour_attributes_read(mat.node_tree, seen)
    override = depsgraph.view_layer.material_override
    if override is not None and override.node_tree is not None:
        names |= colour_attributes_read(override.node_tree, seen)
    return next(iter(names)) if len(names) == 1 and "" not in names else None


class GraphContext:
    """What the walk needs from the scene: the depsgraph (object matrices), the meshes that
    use the material (UV map numbers) and the colour attribute exported as COLOR_0 by name."""

    def __init__(self, depsgraph=None, meshes=(), colour_attribute=None):
        self.depsgraph = depsgraph
        self.meshes = list(meshes)
        self.colour_attribute = colour_attribute

    @property
    def with_aovs(self):
        """Whether the view layer rendered has shader AOVs (then AOV Output nodes are exported)."""
        view_layer = getattr(self.depsgraph, "view_layer", None)
        return bool(view_layer is not None and len(getattr(view_layer, "aovs", ())) > 0)


class Graph:
    """A built graph: the contract's value without `images`, the Blender images it uses (in
    index order), whether it reads Generated coordinates, and warnings."""

    def __init__(self, nodes, output, images, uses_generated, warnings, displacement_method="BUMP"):
        self.nodes = nodes
        self.output = output
        self.images = images
        self.uses_generated = uses_generated
        self.warnings = warnings
        self.displacement_method = displacement_method

    @property
    def true_displacement(self):
        """Whether the Displacement output moves the mesh (method DISPLACEMENT or BOTH)."""
        return self.output.get("displacement") is not None and self.displacement_method != "BUMP"

    def value(self, image_entries):
        """The extension's value, with the `images` entries the caller wrote."""
        value = {"version": GRAPH_VERSION, "nodes": self.nodes, "output": self.output, "images": image_entries}
        if self.true_displacement:
            value["displacement_method"] = self.displacement_method
        return value


def _valid_link(sock):
    """The link into an input socket Cycles follows, or None (unlinked, invalid, muted, or from
    a socket the node's settings made unavailable, such as the Mix node's float result in
    colour mode)."""
    if not sock.is_linked:
        return None
    for link in sock.links:
        if link.is_valid and not link.is_muted and _available(link.from_socket):
            return link
    return None


def _available(sock):
    """Cycles sees only enabled, available sockets."""
    return sock.enabled and not sock.is_unavailable


def plain(value):
    """A socket or property value as JSON: numbers, strings, lists of numbers."""
    if isinstance(value, (bool, int, float, str)):
        return value
    try:
        return [plain(v) for v in value]
    except TypeError:
        return float(value)


def convert(value, from_type, to_type):
    """A constant carried from a socket of `from_type` into one of `to_type`, as Cycles'
    implicit conversion nodes do (float -> grey colour, colour -> luminance, vector -> average)."""
    value = plain(value)
    if from_type == to_type or isinstance(value, str):
        return value
    scalar = not isinstance(value, list)
    if to_type in {"VALUE", "INT", "BOOLEAN"}:
        if scalar:
            out = float(value)
        elif from_type == "RGBA":
            out = sum(c * w for c, w in zip(value[:3], _LUMINANCE))
        else:
            out = sum(value[:3]) / 3.0
        return int(out) if to_type == "INT" else (out != 0.0 if to_type == "BOOLEAN" else out)
    if to_type == "RGBA":
        return [float(value)] * 3 + [1.0] if scalar else [*value[:3], value[3] if len(value) > 3 else 1.0]
    if to_type in {"VECTOR", "ROTATION"}:
        return [float(value)] * 3 if scalar else list(value[:3])
    return value


def _matrix_list(m):
    """A 4x4 matrix as 16 numbers, column-major (glTF's order)."""
    return [float(m[row][col]) for col in range(4) for row in range(4)]


def object_matrix(obj, depsgraph):
    """The inverse of `obj`'s world matrix in glTF's Y-up world: C M^-1 C^-1 with C the axis swap,
    so that applied to a glTF world point it gives the object-space point in glTF axes."""
    from mathutils import Matrix
    if depsgraph is not None:
        obj = obj.evaluated_get(depsgraph)
    c = Matrix(_Y_UP)
    return _matrix_list(c @ obj.matrix_world.inverted_safe() @ c.inverted())


def ramp_table(ramp):
    """A ColorRamp evaluated by Blender at i/256, i = 0..256 (contract)."""
    return [[float(c) for c in ramp.evaluate(i / (TABLE_SIZE - 1))] for i in range(TABLE_SIZE)]


def curve_tables(node):
    """A curve node's mapping as the contract's range, extrapolation and tables.

    The range is Cycles' (curvemapping_minmax: the first and last points' x over all curves);
    RGB Curves lists C, R, G, B (Blender stores C as curves[3])."""
    mapping = node.mapping
    mapping.initialize()  # evaluate() needs the curve tables Blender builds here
    curves = list(mapping.curves)
    if node.bl_idname == "ShaderNodeRGBCurve":
        curves = [curves[3], curves[0], curves[1], curves[2]]
    elif node.bl_idname == "ShaderNodeVectorCurve":
        curves = curves[:3]
    else:
        curves = curves[:1]
    lo = min(c.points[0].location[0] for c in curves)
    hi = max(c.points[len(c.points) - 1].location[0] for c in curves)
    xs = [lo + (hi - lo) * i / (TABLE_SIZE - 1) for i in range(TABLE_SIZE)]
    return {"range": [float(lo), float(hi)], "extrapolate": mapping.extend == "EXTRAPOLATED",
            "tables": [[float(mapping.evaluate(c, x)) for x in xs] for c in curves]}


def _uv_index(name, meshes):
    """The TEXCOORD_n Blender's glTF exporter writes for UV map `name`: it writes every UV map of
    the mesh in order (primitive_extract.py, tex_coord_max = len(uv_layers)), so n is the map's
    index. Returns (n or None, meshes that disagree or lack the map)."""
    found, missing = set(), []
    for mesh in meshes:
        i = mesh.uv_layers.find(name)
        if i < 0:
            missing.append(mesh.name)
        else:
            found.add(i)
    return (min(found) if found else None), missing, len(found) > 1


def _active_uv_index(meshes):
    """The TEXCOORD_n of the meshes' active render UV maps (Cycles' default UV map), and whether
    the meshes disagree; (None, False) when none has a UV map."""
    found = set()
    for mesh in meshes:
        layers = list(mesh.uv_layers)
        if layers:
            found.add(next((i for i, layer in enumerate(layers) if layer.active_render), 0))
    return (min(found) if found else None), len(found) > 1


class _Builder:
    """One walk over one material's tree (see the module doc)."""

    def __init__(self, material, context):
        self.material = material
        self.context = context
        self.nodes = []
        self.index = {}
        self.todo = []
        self.images = []
        self.image_index = {}
        self.uses_generated = False
        self.warnings = []
        self.base_props = {p.identifier for p in bpy.types.ShaderNode.bl_rna.properties}
        self.what = f"material '{material.name}'"  # how warnings name the tree's owner

    def warn(self, node_name, text):
        self.warnings.append(f"{self.what}, node '{node_name}': {text}")

    def warn_once(self, node_name, text):
        """`warn`, unless this very warning was given already (a node read by several inputs)."""
        if f"{self.what}, node '{node_name}': {text}" not in self.warnings:
            self.warn(node_name, text)

    # --- resolving sockets to sources: ("link", index, identifier) | ("value", v, type) | None ---

    def input_source(self, scope, sock, depth=0):
        """What feeds an input socket in `scope` (a tuple of group nodes), or None when unlinked."""
        link = _valid_link(sock)
        if link is None:
            return None
        return self.output_source(scope, link.from_node, link.from_socket, depth + 1)

    def output_source(self, scope, node, out, depth):
        """What an output socket stands for: a node of the graph (added on first sight), or,
        through reroutes, muted nodes and group boundaries, what feeds those."""
        if depth > 256:  # Blender refuses cycles; this only guards against a corrupt file
            self.warn(node.name, "the graph is too deep (a cycle?); the input is left unlinked")
            return None
        if node.type == "REROUTE":
            return self.input_source(scope, node.inputs[0], depth)
        if node.mute:
            return self._muted(scope, node, out, depth)
        if node.type == "GROUP":
            return self._group_output(scope, node, out, depth)
        if node.type == "GROUP_INPUT":
            return self._group_input(scope, node, out, depth)
        if node.type == "FRAME":
            return None
        if node.type == "SHADERTORGB":
            # EEVEE-only: Cycles' sync makes no node of it, so the input it feeds keeps its own value.
            self.warn_once(node.name, "Shader to RGB is EEVEE-only: as in Cycles, the input it feeds keeps its "
                                      "own value")
            return None
        if node.type == "TEX_COORD" and out.identifier == "Generated":
            self.uses_generated = True
        # Radial tangents (the Tangent node's, Geometry's Tangent) turn about the Generated
        # coordinates' centre, as Cycles.
        if (node.type == "NEW_GEOMETRY" and out.identifier == "Tangent") or \
                (node.type == "TANGENT" and node.direction_type == "RADIAL"):
            self.uses_generated = True
        return ("link", self.add(scope, node), out.identifier)

    def _value_or_link(self, scope, sock, depth):
        """The source of an input that stands in for an output (pass-through, group sockets)."""
        source = self.input_source(scope, sock, depth)
        if source is not None:
            return source
        if sock.type == "SHADER" or not hasattr(sock, "default_value"):
            return None
        return ("value", plain(sock.default_value), sock.type)

    def _muted(self, scope, node, out, depth):
        """A muted node's output: what feeds the input its internal link passes through (that
        input's own value when unlinked). An output without a pass-through is no source: as in
        Cycles (its sync maps muted nodes' internal links only), the input it fed keeps its own
        value."""
        for link in node.internal_links:
            if link.to_socket.identifier == out.identifier and link.from_socket is not None:
                return self._value_or_link(scope, link.from_socket, depth)
        return None

    def _group_output(self, scope, node, out, depth):
        tree = node.node_tree
        if tree is None:
            self.warn(node.name, "the group node has no node tree; its outputs are left unlinked")
            return None
        outputs = [n for n in tree.nodes if n.type == "GROUP_OUTPUT"]
        group_out = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
        if group_out is None:
            return None
        sock = next((s for s in group_out.inputs if s.identifier == out.identifier), None)
        return None if sock is None else self._value_or_link(scope + (node,), sock, depth)

    def _group_input(self, scope, node, out, depth):
        if not scope:
            return None
        group = scope[-1]
        sock = next((s for s in group.inputs if s.identifier == out.identifier), None)
        return None if sock is None else self._value_or_link(scope[:-1], sock, depth)

    # --- nodes ---

    def add(self, scope, node):
        """The index of `node` (in `scope`) in the node list, adding it on first sight."""
        key = (tuple(g.as_pointer() for g in scope), node.as_pointer())
        if key not in self.index:
            self.index[key] = len(self.nodes)
            name = "/".join([g.name for g in scope] + [node.name])
            self.nodes.append({"name": name, "type": node.bl_idname, "props": {}, "inputs": {}})
            self.todo.append((scope, node))
        return self.index[key]

    def fill(self, scope, node):
        """The node's props and inputs (after `add`; iterative, so deep graphs need no recursion)."""
        entry = self.nodes[self.index[(tuple(g.as_pointer() for g in scope), node.as_pointer())]]
        entry["props"] = self.props(node, entry["name"])
        for sock in node.inputs:
            if not _available(sock):
                continue
            item = {}
            if sock.type != "SHADER" and hasattr(sock, "default_value"):
                item["value"] = plain(sock.default_value)
            source = self.input_source(scope, sock)
            if source is not None and source[0] == "link":
                item["link"] = [source[1], source[2]]
            elif source is not None and "value" in item:
                item["value"] = convert(source[1], source[2], sock.type)
            entry["inputs"][sock.identifier] = item
        mapping = getattr(node, "texture_mapping", None)
        if mapping is not None and not _identity_mapping(mapping):
            self._texture_mapping(node, entry, mapping)
        if node.type in _GENERATED_DEFAULT:
            vector = node.inputs.get("Vector")
            if vector is not None and _available(vector) and "link" not in entry["inputs"].get("Vector", {}):
                self.uses_generated = True
        anisotropy_input = {"BSDF_PRINCIPLED": "Anisotropic", "BSDF_ANISOTROPIC": "Anisotropy",
                            "BSDF_GLOSSY": "Anisotropy", "BSDF_METALLIC": "Anisotropy"}.get(node.type)
        if anisotropy_input is not None and "link" not in entry["inputs"].get("Tangent", {}):
            # Cycles' default Tangent (the Geometry node's, radial around the object's Z axis)
            # reads Generated coordinates where the BSDF is anisotropic.
            anisotropic = entry["inputs"].get(anisotropy_input, {})
            if "link" in anisotropic or anisotropic.get("value", 0.0) != 0.0:
                self.uses_generated = True

    def _synthetic(self, name, kind, props=None, inputs=None):
        """Appends a node the add-on makes (not in Blender's tree); its index."""
        self.nodes.append({"name": name, "type": kind, "props": props or {}, "inputs": inputs or {}})
        return len(self.nodes) - 1

    def _texture_mapping(self, node, entry, mapping):
        """A texture node's own (legacy, sidebar) Texture Mapping, which Cycles applies to the
        vector before the lookup (`TextureMapping::compile`): the axes picked first (X/Y/Z or
        none), then Location, Rotation and Scale as the Mapping node of the same vector type
        (Cycles' Point, Texture, Vector and Normal transforms are that node's), then the
        Minimum and Maximum clamps. Written as nodes in front of the texture's Vector."""
        vector = entry["inputs"].get("Vector")
        name = entry["name"]
        if vector is None:
            return
        if "link" in vector:
            source = vector["link"]
        elif node.type in _GENERATED_DEFAULT:
            source = [self._synthetic(f"{name}/Texture Coordinate", "ShaderNodeTexCoord"), "Generated"]
            self.uses_generated = True
        elif node.bl_idname == "ShaderNodeTexImage":
            source = [self._synthetic(f"{name}/Texture Coordinate", "ShaderNodeTexCoord"), "UV"]
        elif node.bl_idname == "ShaderNodeTexEnvironment":
            source = [self._synthetic(f"{name}/Geometry", "ShaderNodeNewGeometry"), "Position"]
        else:
            self.warn(name, "its own Texture Mapping (node sidebar) is not applied to its default vector; "
                            "a Mapping node in front of it is")
            return
        axes = (mapping.mapping_x, mapping.mapping_y, mapping.mapping_z)
        if axes != ("X", "Y", "Z"):
            split = self._synthetic(f"{name}/Texture Mapping axes", "ShaderNodeSeparateXYZ",
                                    inputs={"Vector": {"value": [0.0, 0.0, 0.0], "link": source}})
            picks = {}
            for target, axis in zip("XYZ", axes):
                picks[target] = {"value": 0.0} if axis == "NONE" else {"value": 0.0, "link": [split, axis]}
            source = [self._synthetic(f"{name}/Texture Mapping axes'", "ShaderNodeCombineXYZ", inputs=picks), "Vector"]
        source = [self._synthetic(
            f"{name}/Texture Mapping", "ShaderNodeMapping", props={"vector_type": mapping.vector_type},
            inputs={"Vector": {"value": [0.0, 0.0, 0.0], "link": source},
                    "Location": {"value": plain(mapping.translation)},
                    "Rotation": {"value": plain(mapping.rotation)},
                    "Scale": {"value": plain(mapping.scale)}}), "Vector"]
        for use, bound, operation in ((mapping.use_min, mapping.min, "MAXIMUM"),
                                      (mapping.use_max, mapping.max, "MINIMUM")):
            if use:
                source = [self._synthetic(
                    f"{name}/Texture Mapping {operation.lower()}", "ShaderNodeVectorMath",
                    props={"operation": operation},
                    inputs={"Vector": {"value": [0.0, 0.0, 0.0], "link": source},
                            "Vector_001": {"value": plain(bound)}}), "Vector"]
        entry["inputs"]["Vector"] = dict(vector, link=source)

    def props(self, node, name):
        """The node's own settings (everything not inherited from ShaderNode), contract's shapes."""
        props = {}
        for prop in node.bl_rna.properties:
            key = prop.identifier
            if key in self.base_props or key in _SKIPPED_POINTERS or prop.type == "COLLECTION":
                continue
            value = getattr(node, key)
            if prop.type == "POINTER":
                self._pointer_prop(node, name, key, value, props)
            elif prop.type == "ENUM":
                props[key] = sorted(value) if prop.is_enum_flag else value
            else:
                props[key] = plain(value)
        # Value and RGB nodes keep their number in the output socket, not in a setting.
        if node.bl_idname == "ShaderNodeValue":
            props["value"] = float(node.outputs[0].default_value)
        elif node.bl_idname == "ShaderNodeRGB":
            props["color"] = plain(node.outputs[0].default_value)
        elif node.bl_idname == "ShaderNodeNormal":
            props["direction"] = plain(node.outputs["Normal"].default_value)
        self._tex_coord(node, name, props)
        self._colour_0(node, props)
        if node.bl_idname == "ShaderNodeAttribute" and node.attribute_type == "VIEW_LAYER":
            props["view_layer_value"] = view_layer_rgba(self.context.depsgraph, node.attribute_name)
        return props

    def _colour_0(self, node, props):
        """Mark (`color_0`) a node that reads the colour attribute exported as COLOR_0: when the
        scene's graphs read one named colour attribute alone, the export asks the glTF exporter
        for it by name (`single_colour_attribute`), which makes it COLOR_0 of every mesh that has
        it (its own choice, Export Vertex Color "Material", sees only what its Principled BSDF
        reads: checked on io_scene_gltf2 5.0.21, an Attribute node into a Diffuse BSDF got a fake
        white COLOR_0). Every other attribute read by name is exported under its own name
        (attributes.py)."""
        if node.bl_idname == "ShaderNodeVertexColor":
            attribute = node.layer_name
        elif node.bl_idname == "ShaderNodeAttribute" and "tex_coord" not in props and \
                node.attribute_type == "GEOMETRY":
            attribute = node.attribute_name
        else:
            return
        meshes = self.context.meshes
        if attribute and attribute == self.context.colour_attribute and meshes and \
                all(mesh.color_attributes.get(attribute) is not None for mesh in meshes) and \
                not _byte_colours_converted(meshes, attribute) and \
                not _colours_outside_unit_range(meshes, attribute):
            props["color_0"] = True

    def _pointer_prop(self, node, name, key, value, props):
        if key == "color_ramp":
            props[key] = {"interpolation": value.interpolation, "table": ramp_table(value)}
        elif key == "mapping":
            props[key] = curve_tables(node)
        elif key == "image":
            if value is None:
                self.warn(name, "the image texture has no image; Cycles renders it magenta, Caustic as "
                          "the renderer's missing-image colour")
                return
            if value.source == "SEQUENCE":
                depsgraph = self.context.depsgraph
                scene = depsgraph.scene if depsgraph is not None else bpy.context.scene
                value = sequence_frame(value, node.image_user, scene.frame_current)
            if value.source == "TILED" and node.type == "TEX_IMAGE":
                tiles = [[tile.part, self._image(tile)] for tile in udim_tiles(value)]
                props["tiles"] = tiles
                props[key] = tiles[0][1]
                return
            props[key] = self._image(value)
        elif key == "object":
            if value is not None:
                props["object_matrix"] = object_matrix(value, self.context.depsgraph)
        elif key == "ies":
            pass  # an IES Texture's text: written beside the glTF by light_nodes.py
        elif value is not None:
            self.warn(name, f"its setting '{key}' ({type(value).__name__}) is not exported")

    def _image(self, image):
        """The index of `image` (a Blender image or a file stand-in) in the graph's images."""
        pointer = image.as_pointer()
        if pointer not in self.image_index:
            self.image_index[pointer] = len(self.images)
            self.images.append(image)
        return self.image_index[pointer]

    def _tex_coord(self, node, name, props):
        """`tex_coord`: the TEXCOORD_n of the UV map the node reads — a named map (UV Map, Normal
        Map, Tangent, an Attribute naming a UV map), or the active render map that Cycles uses
        for an unnamed one, an Image Texture's default and Texture Coordinate's UV."""
        meshes = self.context.meshes
        if not meshes:
            return
        uv_map = getattr(node, "uv_map", None) if node.bl_idname in _NAMED_UV_NODES else None
        if node.bl_idname == "ShaderNodeAttribute" and node.attribute_type == "GEOMETRY":
            if any(mesh.uv_layers.find(node.attribute_name) >= 0 for mesh in meshes):
                uv_map = node.attribute_name
            else:
                return  # a colour or other attribute, not a UV map
        if uv_map:
            n, missing, ambiguous = _uv_index(uv_map, meshes)
            if missing:
                self.warn(name, f"UV map '{uv_map}' is missing on mesh(es) {', '.join(sorted(missing))}; "
                          "they use their active map")
        elif uv_map is not None or node.bl_idname in _ACTIVE_UV_NODES:
            uv_map = "(active render map)"
            n, ambiguous = _active_uv_index(meshes)
        else:
            return
        if ambiguous:
            self.warn(name, f"UV map '{uv_map}' has different numbers on the material's meshes; "
                      f"TEXCOORD_{n} is used for all")
        if n is not None:
            props["tex_coord"] = n

    def run(self, output, with_aovs=False):
        surface = self._output_link(output, "Surface")
        displacement = self._output_link(output, "Displacement")
        if with_aovs:
            for scope, node in _aov_outputs(output.id_data, ()):
                self.add(scope, node)
        while self.todo:
            self.fill(*self.todo.pop())
        # A world has no displacement method; a material's moves the mesh at load when it is
        # DISPLACEMENT or BOTH (the renderer's `scene::gltf::displace`, contract).
        method = getattr(self.material, "displacement_method", "BUMP")
        return Graph(self.nodes, {"surface": surface, "displacement": displacement}, self.images,
                     self.uses_generated, self.warnings, method)

    def _output_link(self, output, socket_name):
        sock = output.inputs.get(socket_name)
        source = self.input_source((), sock) if sock is not None else None
        return [source[1], source[2]] if source is not None and source[0] == "link" else None


def has_aov_outputs(tree):
    """Whether `tree` (or a group it uses) has an unmuted AOV Output node."""
    return tree is not None and bool(_aov_outputs(tree, ()))


def _aov_outputs(tree, scope, depth=0):
    """(scope, node) of each unmuted AOV Output node of `tree` and of the groups it uses."""
    found = []
    if depth > 32:  # Blender refuses recursive groups; this only guards against a corrupt file
        return found
    for node in tree.nodes:
        if node.mute:
            continue
        if node.bl_idname == "ShaderNodeOutputAOV":
            found.append((scope, node))
        elif node.type == "GROUP" and node.node_tree is not None:
            found += _aov_outputs(node.node_tree, scope + (node,), depth + 1)
    return found


def cycles_output(material):
    """The Material Output node Cycles renders, or None."""
    tree = getattr(material, "node_tree", None)
    if tree is None:
        return None
    return tree.get_output_node("CYCLES")


def _volume_linked(material):
    """Whether the Material Output Cycles renders has something on its Volume socket."""
    output = cycles_output(material)
    volume = output.inputs.get("Volume") if output is not None else None
    return volume is not None and volume.is_linked


def build_graph(material, context):
    """The material's graph (a `Graph`), or None when it has no Cycles Material Output."""
    output = cycles_output(material)
    if output is None:
        return None
    return _Builder(material, context).run(output, with_aovs=context.with_aovs)


def build_world_graph(world, context):
    """The World Output's Surface graph (a `Graph`, contract: `CAUSTIC_world.nodes`), or None
    when the world has no Cycles World Output."""
    output = cycles_output(world)
    if output is None:
        return None
    builder = _Builder(world, context)
    builder.what = f"world '{world.name}'"
    # Cycles' background shader writes the world's AOVs where the camera sees the world.
    return builder.run(output, with_aovs=context.with_aovs)


def build_light_graph(light, what, context):
    """The Light Output's Surface graph of a light datablock (a `Graph`, contract: `nodes` of
    the light extensions), warnings naming `what`; None without a Cycles Light Output."""
    output = cycles_output(light)
    if output is None:
        return None
    builder = _Builder(light, context)
    builder.what = what
    return builder.run(output)


def build_volume_graph(material, shader_node, context):
    """The graph of a Volume output's shader node and what feeds it (a `Graph` whose output is
    empty; contract: `CAUSTIC_materials_medium.graph`), and the shader node's index in it."""
    builder = _Builder(material, context)
    index = builder.add((), shader_node)
    while builder.todo:
        builder.fill(*builder.todo.pop())
    return Graph(builder.nodes, {}, builder.images, builder.uses_generated, builder.warnings), index


def needs_graph(material, graph):
    """Whether the glTF exporter cannot express `material`, whose graph is `graph` (contract):
    a node type it does not read, a group or muted node on the way (the graph is then not what
    the exporter walks), a Displacement output, a projected image, or a link it drops."""
    if graph is None:
        return False
    if graph.output["displacement"] is not None:
        return True
    if graph.output["surface"] is None and not _volume_linked(material):
        # Cycles renders no surface (black); the exporter writes a node it finds unlinked. With
        # a Volume linked the unlinked Surface is no surface at all (the volume's boundary),
        # which the volume export already writes.
        return True
    if any(n["type"] == "ShaderNodeOutputAOV" for n in graph.nodes):
        return True  # the exporter has no shader AOVs
    if any(n["type"] not in _EXPRESSIBLE for n in graph.nodes):
        return True
    if any(n["type"] == "ShaderNodeTexImage" and n["props"].get("projection", "FLAT") != "FLAT" for n in graph.nodes):
        return True  # the exporter reads every image as UV-mapped
    if any("tiles" in n["props"] for n in graph.nodes):
        return True  # the exporter writes a UDIM image's first tile only
    if _shows_sequence(material, graph):
        return True  # the exporter copies the image's own file, not the frame the node shows
    if _raw_walk_has_group_or_mute(cycles_output(material)):
        return True
    if _ignored_link_into(material, graph):
        return True  # the exporter follows it (and drops the socket's value); Cycles does not
    if any(_foreign_colour_space(graph, n) for n in graph.nodes):
        return True  # the exporter copies the file; the graph's image is converted (node_images.py)
    if any(_associated_alpha(graph, n) for n in graph.nodes):
        return True  # glTF filters straight colour; Cycles the colour times alpha (contract, `images`)
    if any(_tinted_metal(n) or _beyond_gltf_principled(n) for n in graph.nodes):
        return True
    for entry in graph.nodes:
        for identifier, item in entry["inputs"].items():
            if "link" not in item:
                continue
            source = graph.nodes[item["link"][0]]
            if not _exporter_reads_link(entry, identifier, source, item["link"][1]):
                return True
            if _image_space_differs(graph, source, entry, identifier):
                return True
            if item["link"][1] == "Alpha" and _alpha_ignored(graph, source):
                return True  # the exporter reads the stored alpha; the graph's image writes 1
    return False


def _shows_sequence(material, graph):
    """Whether an Image Texture node of `graph` shows an image sequence or a movie: Cycles reads
    the frame its Image User picks at the scene's frame (the graph writes that frame's file,
    image_frames.py, or warns), where the glTF exporter copies the file the image names."""
    tree = getattr(material, "node_tree", None)
    if tree is None:
        return False
    for entry in graph.nodes:
        node = tree.nodes.get(entry["name"]) if entry["type"] == "ShaderNodeTexImage" else None
        image = getattr(node, "image", None)
        if image is not None and image.source in {"SEQUENCE", "MOVIE"}:
            return True
    return False


def _ignored_link_into(material, graph):
    """Whether a link that Cycles ignores (invalid, muted, or from or to a socket the nodes'
    settings made unavailable, as a Voronoi's Distance in N-Sphere Radius mode) ends on a node
    of `graph`: the glTF exporter follows such a link to a Base Color and, finding no image,
    drops the socket's own value (white instead of Cycles' 0.8)."""
    tree = getattr(material, "node_tree", None)
    if tree is None:
        return False
    names = {entry["name"] for entry in graph.nodes}
    return any(link.to_node.name in names
               and not (link.is_valid and not link.is_muted and _available(link.from_socket)
                        and _available(link.to_socket))
               for link in tree.links)


def _foreign_colour_space(graph, entry):
    """Whether `entry` is an Image Texture whose image is in a colour space glTF cannot say
    (neither sRGB nor data: ACEScg, AgX Log, ...)."""
    index = entry["props"].get("image") if entry["type"] == "ShaderNodeTexImage" else None
    if index is None:
        return False
    settings = graph.images[index].colorspace_settings
    return not settings.is_data and settings.name not in {"sRGB", "Non-Color", "Linear Rec.709"}


# Principled inputs the glTF exporter writes as sRGB-encoded colour textures.
_COLOUR_SLOTS = {"Base Color", "Emission Color", "Specular Tint", "Sheen Color"}


def _image_space_differs(graph, source, entry, identifier):
    """Whether the image `source` feeds `entry`'s input `identifier` in a colour space the glTF
    texture it becomes does not have. A colour slot (base, emission, specular and sheen colour)
    is read as sRGB: a Non-Color or linear image there is decoded once too often (a Non-Color
    base colour: 0.944 of Cycles, blocks 0.39x). A data slot (metallic, roughness, coat,
    transmission, specular level, sheen roughness, a Normal Map's colour) is filtered as
    stored, where Cycles keeps an 8-bit sRGB image encoded, filters the encoded values and
    decodes after (`compress_as_srgb`): a magnified sRGB Metallic image of black and white texels
    blends otherwise (blocks 3 % off)."""
    index = source["props"].get("image") if source["type"] == "ShaderNodeTexImage" else None
    if index is None:
        return False
    settings = graph.images[index].colorspace_settings
    srgb = not settings.is_data and settings.name == "sRGB"
    if entry["type"] == "ShaderNodeNormalMap":
        return identifier == "Color" and srgb
    if entry["type"] != "ShaderNodeBsdfPrincipled" or identifier not in _EXPORTER_LINKED_INPUTS:
        return False
    if identifier in _COLOUR_SLOTS:
        return not srgb
    return srgb and identifier not in {"Normal", "Coat Normal", "Alpha"}


def _alpha_ignored(graph, entry):
    """Whether `entry` is an Image Texture whose image's Alpha mode is None (Cycles reads 1)."""
    index = entry["props"].get("image") if entry["type"] == "ShaderNodeTexImage" else None
    return index is not None and graph.images[index].alpha_mode == "NONE"


def _associated_alpha(graph, entry):
    """Whether `entry` is an Image Texture whose image the renderer holds with associated alpha,
    as Cycles (contract, `images`): a colour image with an alpha channel, 8-bit in Straight or
    Premultiplied mode or float in Premultiplied mode. Cycles filters its colour times alpha and
    divides back only when the node's Alpha is linked, so a transparent texel's colour never
    bleeds into its neighbours and an unlinked Alpha darkens the colour; glTF's texture is
    straight."""
    index = entry["props"].get("image") if entry["type"] == "ShaderNodeTexImage" else None
    if index is None:
        return False
    image = graph.images[index]
    if getattr(image, "depth", 0) not in {32, 64, 128} or image.colorspace_settings.is_data:
        return False  # no alpha channel (RGBA is 32, 64 or 128 bits a pixel), or data
    if png_with_alpha(image):
        return True  # Cycles associates a 16-bit PNG too (node_images.py)
    return image.alpha_mode == "PREMUL" or image.alpha_mode == "STRAIGHT" and not image.is_float


def _tinted_metal(entry):
    """Whether a Principled BSDF's metal has a Specular Tint, which Cycles renders as the metal's
    F82 tint and glTF cannot express (KHR_materials_specular tints the dielectric only)."""
    if entry["type"] != "ShaderNodeBsdfPrincipled":
        return False
    metallic, tint = entry["inputs"].get("Metallic", {}), entry["inputs"].get("Specular Tint", {})
    metal = "link" in metallic or metallic.get("value", 0.0) != 0.0
    tinted = "link" in tint or any(c != 1.0 for c in tint.get("value", [1.0, 1.0, 1.0])[:3])
    return metal and tinted


def _beyond_gltf_principled(entry):
    """Whether a Principled BSDF has a constant Diffuse Roughness or Anisotropic, which the
    graph renders as Cycles (Oren-Nayar; widths along Cycles' default radial tangent) and glTF
    cannot say (a Lambertian base; the anisotropy along the UV tangents), the "GGX"
    distribution (single scattering; glTF's materials are compensated as Multiscatter GGX), or
    a constant IOR below 1 (Cycles' inverted layer, which the graph renders; Blender's exporter
    drops an opaque material's KHR_materials_ior after the material hook, so glTF would render
    it at 1.5)."""
    if entry["type"] != "ShaderNodeBsdfPrincipled":
        return False
    if entry["props"].get("distribution") == "GGX":
        return True
    if entry["inputs"].get("IOR", {}).get("value", 1.5) < 1.0:
        return True
    return any(entry["inputs"].get(name, {}).get("value", 0.0) != 0.0 for name in ("Diffuse Roughness", "Anisotropic"))


def _exporter_reads_link(entry, identifier, source, output_identifier):
    """Whether Blender's glTF exporter turns this link (between expressible nodes) into glTF."""
    kind = entry["type"]
    if kind == "ShaderNodeBsdfPrincipled":
        name = identifier  # Principled BSDF's identifiers are its socket names
        return name in _EXPORTER_LINKED_INPUTS and (
            source["type"] != "ShaderNodeTexImage" or output_identifier == "Color" or name == "Alpha")
    if kind == "ShaderNodeNormalMap":
        return identifier == "Color" and entry["props"].get("space") == "TANGENT"
    if kind == "ShaderNodeTexImage":
        return identifier == "Vector" and source["type"] == "ShaderNodeUVMap" and entry["props"].get(
            "projection") == "FLAT"
    return False


def _raw_walk_has_group_or_mute(output):
    """Whether a group node or a muted node feeds the output's Surface or Displacement (walking
    Blender's own links; the Volume output is exported apart, media.py)."""
    seen, todo = set(), [s for s in output.inputs if s.is_linked and s.name in {"Surface", "Displacement"}]
    while todo:
        for link in todo.pop().links:
            node = link.from_node
            if node.as_pointer() in seen:
                continue
            seen.add(node.as_pointer())
            if node.type == "GROUP" or node.mute:
                return True
            todo.extend(s for s in node.inputs if s.is_linked)
    return False


def _colours_outside_unit_range(meshes, attribute):
    """True when a float colour attribute holds a value below 0 or above 1, which the glTF
    exporter's COLOR_0 clamps to [0, 1] (glTF's range for vertex colours) and Cycles reads as
    it is: such an attribute goes under its own name (a Geometry Nodes colour from positions,
    realized: R/G 0.975/0.991 of Cycles as COLOR_0)."""
    for mesh in meshes:
        layer = mesh.color_attributes.get(attribute)
        if layer is None or layer.data_type != "FLOAT_COLOR" or len(layer.data) == 0:
            continue
        values = np.empty(len(layer.data) * 4, np.float32)
        layer.data.foreach_get("color", values)
        if values.min() < 0.0 or values.max() > 1.0:
            return True
    return False


def _byte_colours_converted(meshes, attribute):
    """True when a byte colour attribute must go under its own name rather than as the glTF
    exporter's COLOR_0: under a working space other than Linear Rec.709 the exporter writes
    every byte colour converted to the working space, which Cycles does in the corner domain
    only (attributes.corner_values applies its rule)."""
    from .settings import REC709, working_space_name
    if working_space_name() == REC709:
        return False
    return any(mesh.color_attributes.get(attribute).data_type == "BYTE_COLOR" for mesh in meshes)
