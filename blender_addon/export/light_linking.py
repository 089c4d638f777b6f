"""Blender's light linking receivers (Object > Shading > Light Linking > Receiver Collection,
on a light or an emissive object) as the `CAUSTIC_light_linking` node extension
(docs/contract.md): the objects the emitter lights, by name, and whether the list includes or
excludes them. Blender's rule: a collection with any Include entry lights only what it includes;
with Exclude entries only, everything but them. A child collection's state holds for all its
objects. Blocker collections (shadow linking) are not exported: unsupported.py warns."""

LIGHT_LINKING_EXTENSION = "CAUSTIC_light_linking"


def light_linking_extension(blender_object):
    """{"receivers": [names], "include": bool} for an emitter with a receiver collection, else None."""
    linking = getattr(getattr(blender_object, "original", blender_object), "light_linking", None)
    collection = linking.receiver_collection if linking is not None else None
    if collection is None:
        return None
    states = {}
    _collect(collection, states)
    included = sorted(name for name, state in states.items() if state == "INCLUDE")
    if included:
        return {"receivers": included, "include": True}
    return {"receivers": sorted(states), "include": False}


def _collect(collection, states):
    """Each object's link state in `collection` (its own entry, or its child collection's)."""
    for obj, entry in zip(collection.objects, collection.collection_objects):
        states[obj.name] = entry.light_linking.link_state
    for child, entry in zip(collection.children, collection.collection_children):
        for obj in child.all_objects:
            states.setdefault(obj.name, entry.light_linking.link_state)
