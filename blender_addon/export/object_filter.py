"""The viewport's export of a few objects alone (an added object, an edited mesh): the
exporter's tree keeps only the named objects, so that their change costs their own export, not
the scene's, and the server merges them into the scene it holds (`objects`, docs/protocol.md).
"""

import json


def keep_only(vtree, names):
    """Untags the exporter's nodes whose object is not one of `names`; an instance node without
    an object of its own (a geometry-nodes instance) stays with its nearest object ancestor.
    Returns the names kept."""
    kept = []
    for node in vtree.nodes.values():
        if not node.keep_tag:
            continue
        owner, parent = node.blender_object, node.parent_uuid
        while owner is None and parent is not None:
            owner, parent = vtree.nodes[parent].blender_object, vtree.nodes[parent].parent_uuid
        if owner is None or owner.name not in names:
            node.keep_tag = False
        elif node.blender_object is not None:
            kept.append(owner.name)
    return kept


def mergeable(obj):
    """Whether the server can merge `obj` exported alone: a mesh object without hair or points
    (strands, point clouds and volumes, lights and curves objects come with a whole export,
    `load`)."""
    from .points import makes_points
    if obj is None or obj.type != "MESH":
        return False
    return not any(p.settings.type == "HAIR" for p in obj.particle_systems) and not makes_points(obj)


def foreign_meshes(path, names, loaded):
    """Mesh nodes of the export at `path` (a .gltf) that are not the objects `names` yet bear the
    name of an object the server holds (`loaded`): instances an object makes (particles,
    geometry nodes) named after their source object. Merged, they would replace that object."""
    with open(path, encoding="utf-8") as f:
        doc = json.load(f)
    return sorted({n.get("name") for n in doc.get("nodes", [])
                   if "mesh" in n and n.get("name") not in names and n.get("name") in loaded})
