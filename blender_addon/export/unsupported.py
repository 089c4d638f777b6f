"""What Caustic cannot render yet, named: scene features that would otherwise be dropped without
a word (point clouds; shape keys on a mesh without modifiers, which Blender's glTF exporter
writes undeformed). Each warning names the object and says what the render does instead."""

import numpy as np


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
        if _shape_keys_dropped(original, depsgraph):
            warnings.append(f"object '{original.name}': its shape keys are not rendered: Blender's glTF exporter "
                            "writes a mesh without modifiers from its undeformed data (add any modifier to "
                            "export the deformed mesh)")
    return warnings


def _shape_keys_dropped(obj, depsgraph):
    """True for a mesh whose shape keys deform it but which has no modifier: the exporter then
    writes the original (basis) vertices, where Cycles renders the keys' mix."""
    if obj.type != "MESH" or obj.data.shape_keys is None or len(obj.modifiers) > 0:
        return False
    evaluated = obj.evaluated_get(depsgraph).data
    basis = obj.data
    if len(evaluated.vertices) != len(basis.vertices):
        return True
    a, b = (np.empty(3 * len(m.vertices), dtype=np.float32) for m in (evaluated, basis))
    evaluated.vertices.foreach_get("co", a)
    basis.vertices.foreach_get("co", b)
    return not np.array_equal(a, b)


def object_warnings(obj):
    """Warnings for one object's features that Caustic does not render."""
    what = f"object '{obj.name}'"
    warnings = []
    if obj.type == "POINTCLOUD":
        warnings.append(f"{what}: point clouds are not rendered")
    return warnings

