"""What Caustic cannot render yet, named: scene features that would otherwise be dropped without
a word (a light's or the world's Cycles Max Bounces). Each warning names the object and says what
the render does instead. (Shape keys on a mesh without modifiers are exported deformed by
shape_keys.py; point clouds are rendered, and what of them is not is named by points.py.)"""


def scene_warnings(depsgraph):
    """Warnings for everything in the render depsgraph's scene that Caustic does not render."""
    warnings = []
    seen = set()
    for instance in depsgraph.object_instances:
        obj = instance.instance_object if instance.is_instance else instance.object
        original = obj.original
        if original.name in seen:
            continue
        seen.add(original.name)
        warnings += object_warnings(original)
    world = depsgraph.scene.world
    bounces = _cycles_max_bounces(world)
    if bounces is not None:
        warnings.append(f"world '{world.name}': its Max Bounces ({bounces}) is not read: "
                        "the world lights paths of every length")
    return warnings


# Cycles' default Max Bounces of a light and of the world: no limit of their own.
_UNLIMITED_BOUNCES = 1024


def _cycles_max_bounces(datablock):
    """A light's or world's Cycles Max Bounces when it limits anything, else None."""
    settings = getattr(datablock, "cycles", None)
    bounces = getattr(settings, "max_bounces", _UNLIMITED_BOUNCES)
    return int(bounces) if bounces < _UNLIMITED_BOUNCES else None


def object_warnings(obj):
    """Warnings for one object's features that Caustic does not render."""
    what = f"object '{obj.name}'"
    warnings = []
    if obj.type == "LIGHT":
        bounces = _cycles_max_bounces(obj.data)
        if bounces is not None:
            warnings.append(f"{what}: the light's Max Bounces ({bounces}) is not read: "
                            "it lights paths of every length")
    return warnings

