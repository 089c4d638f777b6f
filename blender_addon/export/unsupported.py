"""What Caustic cannot render yet, named: scene features that would otherwise be dropped without
a word. Each warning names the object and says what the render does instead. Of the
scene-wide kind one is left: Blender 5.0's Color Management > Working Space other than Linear
Rec.709 (`working_space_warnings`). A light's and the world's Max Bounces are exported
(lights.py, world.py); shape keys on a mesh without modifiers are exported deformed by
shape_keys.py; point clouds are rendered, and what of them is not is named by points.py."""

import bpy

# The working space Caustic renders in: every colour it computes or decodes itself is given in
# Rec.709 primaries.
RENDER_SPACE = "Linear Rec.709"


def working_space_warnings():
    """Blender 5.0 lets a .blend choose its scene-linear working space (Rec.709, Rec.2020,
    ACEScg). Colours the .blend holds (material inputs, light colours) are already in it and
    render alike, and the EXR is read back as that space; but what Caustic turns into RGB itself
    (decoded image textures and world images, Blackbody, Wavelength, light temperatures, the
    Sky Texture) comes out in Rec.709 primaries where Cycles converts it to the working space
    (measured: an sRGB image texture under ACEScg 0.42-0.94 of Cycles per channel, a 2500 K
    Blackbody light 1.35 / 0.90 / 0.56)."""
    colorspace = getattr(bpy.data, "colorspace", None)
    space = getattr(colorspace, "working_space", RENDER_SPACE) if colorspace is not None else RENDER_SPACE
    if not space or space == RENDER_SPACE:
        return []
    return [f"Color Management > Working Space is '{space}': Caustic decodes image textures and computes "
            f"Blackbody, Wavelength, light temperature and Sky Texture colours in {RENDER_SPACE} primaries, "
            f"not in '{space}' as Cycles does, so those colours differ from Cycles' (other colours are "
            f"rendered as they are); set the Working Space to {RENDER_SPACE} to match Cycles"]


def scene_warnings(depsgraph):
    """Warnings for everything in the render depsgraph's scene that Caustic does not render."""
    warnings = working_space_warnings()
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
