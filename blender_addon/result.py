"""The renderer's EXR into Blender's render result, pass by pass.

Facts (bpy 5.0.1): `RenderLayer.load_from_file(path)` reads channels named `<Pass>.<Ch>` (the
contract's `Combined.R`, `Depth.Z`, ...) or `<ViewLayer>.<Pass>.<Ch>`, flipping rows to Blender's
bottom-up order; a channel it does not find leaves the pass black with only a console warning,
and `RenderResult.load_from_file` accepts the `<ViewLayer>.` form only. A pass only exists in the
result when it was registered (`update_render_passes`).
"""

import struct

import numpy as np

from .errors import CausticError

# (name, channels, channel ids, type) as RenderEngine.register_pass wants them.
PASSES = (
    ("Combined", 4, "RGBA", "COLOR"),
    ("Depth", 1, "Z", "VALUE"),
    ("Normal", 3, "XYZ", "VECTOR"),
    ("Denoising Albedo", 3, "RGB", "COLOR"),
    ("Denoising Normal", 3, "XYZ", "VECTOR"),
)

# The binary writes normals in glTF axes (Y up); Blender's passes are in Blender's world axes
# (Z up), as Cycles writes them: blender = (x, -z, y).
_NORMAL_PASSES = ("Normal", "Denoising Normal")


def register_passes(engine, scene, view_layer):
    """Declare Caustic's passes so they appear in the compositor's Render Layers node."""
    for name, channels, chan_id, kind in PASSES:
        engine.register_pass(scene, view_layer, name, channels, chan_id, kind)


def exr_size(path):
    """Width and height of an OpenEXR file's data window (raises CausticError if unreadable)."""
    try:
        with open(path, "rb") as f:
            head = f.read(65536)
    except OSError as err:
        raise CausticError(f"cannot read the rendered image {path}: {err.strerror}") from None
    if len(head) < 8 or struct.unpack_from("<i", head, 0)[0] != 20000630:
        raise CausticError(f"the rendered image is not an OpenEXR file: {path}")
    key = b"dataWindow\0box2i\0"
    at = head.find(key)
    if at < 0:
        raise CausticError(f"the rendered image has no data window: {path}")
    x0, y0, x1, y1 = struct.unpack_from("<4i", head, at + len(key) + 4)
    return x1 - x0 + 1, y1 - y0 + 1


def load(result, path):
    """Load the EXR at `path` into the first layer of `result` (sizes must match)."""
    layer = result.layers[0]
    combined = layer.passes.find_by_name("Combined", "")
    width, height = exr_size(path)
    expected = len(combined.rect) if combined else None
    if expected is not None and expected != width * height:
        raise CausticError(f"the rendered image is {width}x{height}, Blender expects "
                           f"{expected} pixels")
    try:
        layer.load_from_file(path)
    except RuntimeError as err:
        raise CausticError(f"cannot load the rendered image: {err}") from None
    for name in _NORMAL_PASSES:
        render_pass = layer.passes.find_by_name(name, "")
        if render_pass is not None and render_pass.channels == 3:
            _gltf_to_blender_axes(render_pass)


def _gltf_to_blender_axes(render_pass):
    pixels = np.empty(len(render_pass.rect) * 3, dtype=np.float32)
    render_pass.rect.foreach_get(pixels)
    xyz = pixels.reshape(-1, 3)
    converted = np.empty_like(xyz)
    converted[:, 0] = xyz[:, 0]
    converted[:, 1] = -xyz[:, 2]
    converted[:, 2] = xyz[:, 1]
    render_pass.rect.foreach_set(converted.ravel())
