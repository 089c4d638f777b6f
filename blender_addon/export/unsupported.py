"""What Caustic cannot render yet, named: scene features that would otherwise be dropped without
a word (point clouds). Each warning names the object and says what the render does instead.
(Shape keys on a mesh without modifiers are exported deformed by shape_keys.py.)"""


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
    """Warnings for one object's features that Caustic does not render."""
    what = f"object '{obj.name}'"
    warnings = []
    if obj.type == "POINTCLOUD":
        warnings.append(f"{what}: point clouds are not rendered")
    return warnings

