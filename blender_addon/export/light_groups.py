"""The view layer's light groups as the render settings' `light_groups` (docs/contract.md): the
groups in the view layer's order, the world's group and each object's, by object name (the glTF
node's name). Cycles resolves an object's or the world's group name against the view layer's
list and leaves a name not in it in no group; the same is done here, so the binary sees only
groups that exist."""


def light_group_settings(view_layer, scene, objects):
    """The `light_groups` settings for `view_layer` and the `objects` rendered (None without
    light groups)."""
    names = [group.name for group in getattr(view_layer, "lightgroups", ())]
    if not names:
        return None
    known = set(names)
    members = {obj.name: obj.lightgroup for obj in objects if getattr(obj, "lightgroup", "") in known}
    world = scene.world.lightgroup if scene.world is not None else ""
    spec = {"names": names, "objects": members}
    if world in known:
        spec["world"] = world
    return spec
