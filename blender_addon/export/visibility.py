"""Blender's per-object Ray Visibility (Object > Visibility > Ray Visibility) as the
`CAUSTIC_object_visibility` node extension (docs/contract.md): which kinds of ray see a mesh
object. Cycles' flags, one to one; Caustic's path tracer honours them."""

OBJECT_VISIBILITY_EXTENSION = "CAUSTIC_object_visibility"

# Blender's property and the extension's key, per kind of ray.
_FLAGS = (("visible_camera", "camera"), ("visible_diffuse", "diffuse"), ("visible_glossy", "glossy"),
          ("visible_transmission", "transmission"), ("visible_volume_scatter", "volume_scatter"),
          ("visible_shadow", "shadow"))


def object_visibility_extension(blender_object):
    """The kinds of ray that do not see the object, as {key: False}, or None when every ray sees it."""
    hidden = {key: False for prop, key in _FLAGS if not getattr(blender_object, prop, True)}
    return hidden or None
