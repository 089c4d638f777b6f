"""Meshes deformed by shape keys alone, exported deformed.

Blender's glTF exporter (`blender/exp/nodes.py`, `__gather_mesh`) writes a mesh object that has
no modifier from its original data, whose vertices are the basis shape: the shape keys' mix,
which Cycles renders, would be lost (the exporter's morph targets are off: Caustic takes the
evaluated mesh, and morph targets cannot carry vertex-group masks, keys relative to other keys
or driven values). With any modifier in the stack, even a disabled one, it writes the object's
evaluated mesh instead (from the render depsgraph, see depsgraph.py), which holds the keys' mix.

So for the export each such object gets a placeholder modifier, disabled for the viewport and
for renders (evaluation skips it, so the evaluated mesh is unchanged) and a no-op if it were
enabled (Smooth with no iterations and factor 0), removed again when the export ends, also on
failure. An object whose modifiers cannot be edited (linked library data) keeps the warning.

Final renders only: in the Rendered viewport, adding and removing a modifier tags the object's
geometry as changed, which the viewport answers with a reload (viewport.py), which would export
again: a loop. There such objects are named instead (shown undeformed until a final render).
"""

from contextlib import contextmanager

import numpy as np

PLACEHOLDER_NAME = "Caustic export (temporary)"


def shape_keyed_meshes(depsgraph):
    """The original mesh objects of the depsgraph (instanced ones included) that have shape keys
    and no modifier: those the exporter would write undeformed."""
    found = {}
    for instance in depsgraph.object_instances:
        obj = (instance.instance_object if instance.is_instance else instance.object).original
        if obj.type == "MESH" and obj.data.shape_keys is not None and len(obj.modifiers) == 0:
            found.setdefault(obj.name, obj)
    return list(found.values())


def _deformed(obj, depsgraph):
    """True when the keys move the mesh: its evaluated vertices differ from its basis."""
    evaluated = obj.evaluated_get(depsgraph).data
    if len(evaluated.vertices) != len(obj.data.vertices):
        return True
    a, b = (np.empty(3 * len(m.vertices), dtype=np.float32) for m in (evaluated, obj.data))
    evaluated.vertices.foreach_get("co", a)
    obj.data.vertices.foreach_get("co", b)
    return not np.array_equal(a, b)


@contextmanager
def shape_keys_exported(depsgraph, warnings, viewport=False):
    """While active, every mesh of `shape_keyed_meshes` carries the placeholder modifier (module
    doc); objects that cannot take one are named in `warnings`. In the `viewport` nothing is
    touched: meshes the keys deform are named in `warnings`."""
    added = []
    if viewport:
        warnings.extend(f"object '{obj.name}': its shape keys are not shown in the Rendered viewport (Blender's "
                        "glTF exporter writes a mesh without modifiers from its undeformed data); final renders "
                        "deform it" for obj in shape_keyed_meshes(depsgraph) if _deformed(obj, depsgraph))
        yield
        return
    try:
        for obj in shape_keyed_meshes(depsgraph):
            try:
                modifier = obj.modifiers.new(PLACEHOLDER_NAME, "SMOOTH")
            except (RuntimeError, TypeError, AttributeError):
                modifier = None
            if modifier is None:
                warnings.append(f"object '{obj.name}': its shape keys are not rendered: its modifier stack "
                                "cannot be edited (linked data?), and Blender's glTF exporter writes a mesh "
                                "without modifiers from its undeformed data")
                continue
            modifier.iterations = 0
            modifier.factor = 0.0
            modifier.show_viewport = False
            modifier.show_render = False
            added.append((obj, modifier.name))
        yield
    finally:
        for obj, name in added:
            modifier = obj.modifiers.get(name)
            if modifier is not None:
                obj.modifiers.remove(modifier)
