"""What Caustic cannot render yet, named: scene features that would otherwise be dropped without
a word. Each warning names the object and says what the render does instead. Blender 5.0's
Color Management > Working Space is exported (settings.py `working_space`) and followed by the
binary. A light's and the world's Max Bounces are exported (lights.py, world.py); shape keys
on a mesh without modifiers are exported deformed by shape_keys.py; point clouds are rendered,
and what of them is not is named by points.py."""


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
    return warnings


def object_warnings(obj):
    """Warnings for one object's features that Caustic does not render (none at present)."""
    del obj
    return []
