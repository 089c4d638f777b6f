"""What Caustic cannot render yet, named: scene features that would otherwise be dropped without
a word. Each warning names the object and says what the render does instead. Blender 5.0's
Color Management > Working Space is exported (settings.py `working_space`) and followed by the
binary but for a Principled Volume's blackbody (`working_space_warnings`). A light's and the
world's Max Bounces are exported (lights.py, world.py); shape keys on a mesh without modifiers
are exported deformed by shape_keys.py; point clouds are rendered, and what of them is not is
named by points.py."""

import bpy

from .settings import REC709, working_space_name


def working_space_warnings(depsgraph):
    """Under a working space other than Linear Rec.709 the binary gives image textures,
    Blackbody, Wavelength, the Sky Texture and luminance in it, as Cycles; a Principled
    Volume's blackbody emission (Blackbody Intensity, Temperature) stays in Rec.709 primaries
    (medium/blackbody.rs is not given the space): each material that has one is named."""
    space = working_space_name()
    if space == REC709:
        return []
    names = set()
    for instance in depsgraph.object_instances:
        obj = instance.instance_object if instance.is_instance else instance.object
        for slot in getattr(obj, "material_slots", []):
            mat = slot.material
            if mat is None or not mat.use_nodes or mat.node_tree is None or mat.name in names:
                continue
            for node in mat.node_tree.nodes:
                if node.bl_idname != "ShaderNodeVolumePrincipled" or node.mute:
                    continue
                intensity = node.inputs["Blackbody Intensity"]
                if intensity.is_linked or intensity.default_value > 0.0:
                    names.add(mat.name)
    return [f"material '{name}': its Principled Volume's blackbody emission is computed in {REC709} "
            f"primaries, not in the Working Space '{space}' as Cycles does (its colour differs)"
            for name in sorted(names)]


def scene_warnings(depsgraph):
    """Warnings for everything in the render depsgraph's scene that Caustic does not render."""
    warnings = working_space_warnings(depsgraph)
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
