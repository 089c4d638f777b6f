"""Reading Blender shader node trees: outputs, linked nodes and input values, shared by the
material, medium and world exports."""


def surface_node(blender_material):
    """The node linked to the active Material Output's Surface, or None."""
    tree = getattr(blender_material, "node_tree", None)
    if tree is None:
        return None
    for node in tree.nodes:
        if node.type == "OUTPUT_MATERIAL" and node.is_active_output:
            surface = node.inputs.get("Surface")
            if surface is not None and surface.is_linked:
                return surface.links[0].from_node
    return None


def material_output(tree):
    """The Material Output node Cycles uses (the active one, else the first)."""
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_MATERIAL"]
    for n in outputs:
        if n.is_active_output and n.target in ("ALL", "CYCLES"):
            return n
    return outputs[0] if outputs else None


def linked_node(socket):
    """The node feeding `socket`, or None when it is not linked."""
    return socket.links[0].from_node if socket.is_linked else None


def socket(node, name):
    """A node input by name, also when Blender hides it (disabled sockets are not reachable by key)."""
    return next((i for i in node.inputs if i.name == name), None)


def value(node, name, what, warnings, default=None):
    """An input's unlinked value; a linked input is named in a warning and its value used."""
    sock = socket(node, name)
    if sock is None:
        return default
    if sock.is_linked:
        warnings.append(f"{what}: the {node.name} node's {name} input is linked; Caustic uses its value "
                        f"{fmt(sock.default_value)} (textures and node inputs are not exported)")
    return sock.default_value


def fmt(v):
    """A number or vector, short, for a warning."""
    try:
        return "(" + ", ".join(f"{float(x):.3g}" for x in v) + ")"
    except TypeError:
        return f"{float(v):.3g}"


def procedural_source(sock, depth=0, seen=None):
    """The first procedural texture node (Noise, Voronoi, Wave, ...) upstream of `sock`, or None.

    Blender's glTF exporter carries image textures and constants; a procedural texture on
    a Principled input is dropped without a word, and the input takes glTF's default."""
    seen = set() if seen is None else seen
    if depth > 32 or not sock.is_linked:
        return None
    node = sock.links[0].from_node
    if node.as_pointer() in seen:
        return None
    seen.add(node.as_pointer())
    if node.type.startswith("TEX_") and node.type not in {"TEX_IMAGE", "TEX_ENVIRONMENT", "TEX_COORD"}:
        return node
    for upstream in node.inputs:
        found = procedural_source(upstream, depth + 1, seen)
        if found is not None:
            return found
    return None
