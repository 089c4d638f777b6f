"""What one view layer renders: the exporter walks the scene's whole collection tree and knows
nothing of the view layer's excluded collections, which Cycles leaves out. An object is in
the layer when one of its collections is (Blender's rule: the layer's collection tree,
an excluded collection taking its children with it); the exporter's tree is filtered by
that (`drop_objects_outside`, from the exporter's filter hook), except inside instances,
whose source collection is often excluded on purpose.
"""


def included_collections(view_layer):
    """Pointers of the collections the layer includes (the scene collection among them)."""
    included = set()

    def walk(layer_collection):
        if layer_collection.exclude:
            return
        included.add(layer_collection.collection.as_pointer())
        for child in layer_collection.children:
            walk(child)

    walk(view_layer.layer_collection)
    return included


def _inside_an_instance(vtree, uuid):
    """Whether the node is part of an instanced collection or an instancer's children: its
    visibility is its instancer's (the instanced collection is often excluded on purpose)."""
    parent = vtree.nodes[uuid].parent_uuid
    while parent is not None:
        node = vtree.nodes[parent]
        if node.blender_type == node.INST_COLLECTION or node.is_instancer:
            return True
        parent = node.parent_uuid
    return False


def drop_objects_outside(vtree, depsgraph):
    """Untags the exporter's nodes whose object the layer does not render (an excluded
    collection); cameras stay, the scene's camera renders from any collection. Returns the
    names dropped."""
    included = included_collections(depsgraph.view_layer)
    dropped = []
    for uuid, node in vtree.nodes.items():
        obj = node.blender_object
        if obj is None or not node.keep_tag or getattr(obj, "type", None) == "CAMERA":
            continue
        if node.blender_bone is not None or _inside_an_instance(vtree, uuid):
            continue
        if not any(c.as_pointer() in included for c in obj.users_collection):
            node.keep_tag = False
            dropped.append(obj.name)
    return dropped
