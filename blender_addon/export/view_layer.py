"""What one view layer renders: the exporter walks the scene's whole collection tree and knows
nothing of the view layer's excluded collections, which Cycles leaves out. An object is in
the layer when one of its collections is (Blender's rule: the layer's collection tree,
an excluded collection taking its children with it); the exporter's tree is filtered by
that (`drop_objects_outside`, from the exporter's filter hook); inside instances, whose source
collection is often excluded on purpose, by the outermost instancer's.
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


def _outermost_instancer(vtree, uuid):
    """The outermost instancer above the node (it is part of an instanced collection or an
    instancer's children), or None: the node's visibility is that instancer's (the instanced
    collection is often excluded on purpose). Not the nearest one: an instancer inside an
    excluded collection that an instance shows is also walked from the tree's root, and what
    it instances there goes with it (a nested collection instance's contents were rendered a
    second time at the scene's origin)."""
    found = None
    parent = vtree.nodes[uuid].parent_uuid
    while parent is not None:
        node = vtree.nodes[parent]
        if node.blender_type == node.INST_COLLECTION or node.is_instancer:
            found = node
        parent = node.parent_uuid
    return found


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
        if node.blender_bone is not None:
            continue
        instancer = _outermost_instancer(vtree, uuid)
        owner = obj if instancer is None else instancer.blender_object
        if owner is None:
            continue
        if not any(c.as_pointer() in included for c in owner.users_collection):
            node.keep_tag = False
            dropped.append(obj.name)
    return dropped
