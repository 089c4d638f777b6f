"""Blender's light and shadow linking (Object > Shading > Light Linking > Receiver Collection and
Blocker Collection, on a light or an emissive object) as the `CAUSTIC_light_linking` node
extension (docs/contract.md): the objects the emitter lights and the objects that cast its
shadows, by name, and whether each list includes or excludes them. Blender's rule: a collection
with any Include entry holds only what it includes; with Exclude entries only, everything but
them. A child collection's state holds for all its objects."""

LIGHT_LINKING_EXTENSION = "CAUSTIC_light_linking"


def light_linking_extension(blender_object):
    """{"receivers": [names], "include": bool} for an emitter with a receiver collection, and
    {"blockers": [names], "blockers_include": bool} with a blocker collection; None without."""
    linking = getattr(getattr(blender_object, "original", blender_object), "light_linking", None)
    if linking is None:
        return None
    value = {}
    for prop, names_key, include_key in (("receiver_collection", "receivers", "include"),
                                         ("blocker_collection", "blockers", "blockers_include")):
        collection = getattr(linking, prop, None)
        if collection is None:
            continue
        states = {}
        _collect(collection, states)
        included = sorted(name for name, state in states.items() if state == "INCLUDE")
        value[names_key], value[include_key] = (included, True) if included else (sorted(states), False)
    return value or None


def _collect(collection, states):
    """Each object's link state in `collection` (its own entry, or its child collection's)."""
    for obj, entry in zip(collection.objects, collection.collection_objects):
        states[obj.name] = entry.light_linking.link_state
    for child, entry in zip(collection.children, collection.collection_children):
        for obj in child.all_objects:
            states.setdefault(obj.name, entry.light_linking.link_state)
