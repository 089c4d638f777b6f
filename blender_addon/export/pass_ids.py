"""An object's and a material's Pass Index and an object's Cryptomatte asset, as the
`CAUSTIC_object_pass` node and `CAUSTIC_material_pass` material extensions (docs/contract.md).

Cycles' names (intern/cycles/blender/object.cpp): the object's own name, and for the asset the
name of its topmost parent (its own without a parent); the binary reads the node's and the
material's names from the glTF, which are Blender's."""

OBJECT_PASS_EXTENSION = "CAUSTIC_object_pass"
MATERIAL_PASS_EXTENSION = "CAUSTIC_material_pass"


def object_pass_extension(blender_object):
    """{"pass_index", "asset"} where they differ from the binary's defaults (0; the node's root in
    the file, which is the object itself when it has no parent), else None."""
    original = getattr(blender_object, "original", blender_object)
    value = {}
    if original.pass_index:
        value["pass_index"] = int(original.pass_index)
    top = original
    while top.parent is not None:
        top = top.parent
    if top is not original:
        value["asset"] = top.name
    return value or None


def material_pass_extension(blender_material):
    """{"pass_index"} for a material with a Pass Index, else None."""
    index = getattr(blender_material, "pass_index", 0)
    return {"pass_index": int(index)} if index else None
