"""Blender's Object > Visibility panel as the `CAUSTIC_object_visibility` node extension
(docs/contract.md): which kinds of ray see a mesh object (Ray Visibility; Cycles' flags, one
to one, honoured by the path tracer), whether it is a holdout (the object's Holdout, or a
Holdout collection of the view layer being rendered) and whether it is a Shadow Catcher. An
object in an Indirect Only collection of the view layer (and no holdout) is hidden from camera
rays, as Cycles clears its camera visibility."""

OBJECT_VISIBILITY_EXTENSION = "CAUSTIC_object_visibility"

# Blender's property and the extension's key, per kind of ray.
_FLAGS = (("visible_camera", "camera"), ("visible_diffuse", "diffuse"), ("visible_glossy", "glossy"),
          ("visible_transmission", "transmission"), ("visible_volume_scatter", "volume_scatter"),
          ("visible_shadow", "shadow"))


def object_visibility_extension(blender_object, view_layer=None):
    """The kinds of ray that do not see the object, as {key: False}, "holdout": True for a
    holdout in `view_layer` and "shadow_catcher": True for a catcher; None when every ray sees
    it and it is neither."""
    value = {key: False for prop, key in _FLAGS if not getattr(blender_object, prop, True)}
    if is_holdout(blender_object, view_layer):
        value["holdout"] = True
    elif is_indirect_only(blender_object, view_layer):
        value["camera"] = False
    if getattr(getattr(blender_object, "original", blender_object), "is_shadow_catcher", False):
        value["shadow_catcher"] = True
    return value or None


OBJECT_SHADING_EXTENSION = "CAUSTIC_object_shading"


def object_shading_extension(blender_object):
    """Object > Shading settings Cycles renders: the Shadow Terminator's Geometry Offset
    (Blender's default 0.1: shadow rays of smooth-shaded triangles leave from the smooth patch
    near the terminator) and Shading Offset (the cosine to the light remapped so the terminator
    moves towards the light); None when both are 0. A Shading Offset of 2 or more, for which
    Cycles' frequency multiplier 1 / (1 - offset / 2) is not above 1, does nothing in Cycles
    and is not written."""
    original = getattr(blender_object, "original", blender_object)
    value = {}
    offset = float(getattr(original, "shadow_terminator_geometry_offset", 0.0))
    if offset > 0.0:
        value["shadow_terminator_offset"] = offset
    shading = float(getattr(original, "shadow_terminator_shading_offset", 0.0))
    if 0.0 < shading < 2.0:
        value["shading_offset"] = shading
    return value or None


def object_shading_warnings(blender_object):
    """What of Object > Shading is not rendered (nothing at present: both offsets are)."""
    del blender_object
    return []


def is_indirect_only(blender_object, view_layer=None):
    """Whether an Indirect Only collection of `view_layer` holds the object there."""
    if view_layer is None:
        return False
    original = getattr(blender_object, "original", blender_object)
    try:
        return bool(original.indirect_only_get(view_layer=view_layer))
    except (RuntimeError, TypeError):  # not in that view layer (e.g. an instanced collection's object)
        return False


def is_holdout(blender_object, view_layer=None):
    """The object's own Holdout, or (with `view_layer`) a Holdout collection holding it there."""
    original = getattr(blender_object, "original", blender_object)
    if original.is_holdout:
        return True
    if view_layer is None:
        return False
    try:
        return bool(original.holdout_get(view_layer=view_layer))
    except (RuntimeError, TypeError):  # not in that view layer (e.g. an instanced collection's object)
        return False


# Cycles' World > Ray Visibility (`world.cycles_visibility`) and the key in `CAUSTIC_world`'s
# `visibility`, per kind of ray (its Shadow flag has no effect on a world and is not read).
WORLD_FLAGS = ("camera", "diffuse", "glossy", "transmission", "scatter")


def world_visibility(world):
    """The kinds of ray that do not see the world, as {key: False}; None when every ray sees it."""
    flags = getattr(world, "cycles_visibility", None)
    if flags is None:
        return None
    value = {key: False for key in WORLD_FLAGS if not getattr(flags, key, True)}
    return value or None
