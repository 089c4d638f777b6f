"""The images of exported node graphs, written beside the glTF in `caustic_nodes/` (contract:
`CAUSTIC_materials_nodes`, `images`).

Every image (packed, generated or from a file) is written from the pixels Blender holds, so the
renderer reads the same numbers Cycles does: 8-bit images as PNG, float images as OpenEXR, the
values as stored (no view transform) and the colour space recorded by name. Blender holds a
float image (OpenEXR, Radiance HDR, 16-bit PNG) already converted to the scene's linear space
when its colour space is not data: an sRGB one is encoded back (Cycles filters it encoded)
under a Linear Rec.709 working space, any other (and every one under another working space) is
recorded as in the working space, which the renderer leaves as it is; an 8-bit image in a space
the contract does not name (ACEScg, AgX Log, ...) is converted to linear by Blender's colour
management and written as float. A 16-bit PNG with alpha (Straight or Premultiplied) is
written as Cycles holds it, its stored values times alpha, marked Premultiplied
(`_png16_associated`). An image is written once per export however many materials use it.
"""

import copy
import os
import re

import bpy
import numpy as np

from .image_frames import FileStandIn
from .settings import REC709, working_space_name

FOLDER = "caustic_nodes"
# The colour spaces the renderer decodes itself (docs/contract.md, `images`).
CONTRACT_SPACES = {"sRGB", "Non-Color", "Linear Rec.709"}


class ImageWriter:
    """Writes each Blender image once into `<gltf folder>/caustic_nodes/`; remembers the entries."""

    def __init__(self, gltf_folder):
        self.gltf_folder = gltf_folder
        self.written = {}  # image pointer -> the contract's entry, or None when it has no pixels
        self.names = set()

    def entry(self, image, what, warnings):
        """The contract's `images` entry for `image` (writing it on first use), or None when the
        image has no pixels (a missing file), which is named in a warning."""
        key = image.as_pointer()
        if key not in self.written:
            self.written[key] = self._write(image, what, warnings)
        return self.written[key]

    def graph_value(self, graph, what, warnings):
        """The graph as the contract's value: its images written (an image without pixels is
        dropped from the nodes that read it, with a warning) and renumbered, its nodes."""
        entries, renumber = [], {}
        for i, image in enumerate(graph.images):
            entry = self.entry(image, what, warnings)
            if entry is not None:
                renumber[i] = len(entries)
                entries.append(entry)
        nodes = copy.deepcopy(graph.nodes)
        for node in nodes:
            image = node["props"].get("image")
            if image is not None:
                if image in renumber:
                    node["props"]["image"] = renumber[image]
                else:
                    del node["props"]["image"]
            if "tiles" in node["props"]:  # a tile without pixels reads as missing, as Cycles' absent tile
                node["props"]["tiles"] = [[n, renumber[k]] for n, k in node["props"]["tiles"] if k in renumber]
        value = graph.value(entries)
        value["nodes"] = nodes
        return value

    def _write(self, image, what, warnings):
        if isinstance(image, FileStandIn):
            temp = image.load()
            if temp is None:
                warnings.append(f"{what}: image '{image.name}' has no file for {image.label} "
                                f"({image.path}); Caustic renders the renderer's missing-image colour")
                return None
            try:
                return self._write(temp, what, warnings)
            finally:
                bpy.data.images.remove(temp)
        if image.source in {"SEQUENCE", "MOVIE"}:
            warnings.append(f"{what}: image '{image.name}' is a {image.source.lower()}; its current frame is used")
        if image.source == "TILED":
            warnings.append(f"{what}: image '{image.name}' has UDIM tiles; only its first tile is exported")
        width, height = image.size
        if width == 0 or height == 0 or not image.has_data and not _load(image):
            warnings.append(f"{what}: image '{image.name}' has no pixels (missing file?); Caustic renders the "
                            "renderer's missing-image colour")
            return None
        width, height = image.size
        channels = image.channels
        pixels = np.empty(width * height * channels, dtype=np.float32)
        image.pixels.foreach_get(pixels)
        pixels = pixels.reshape(height, width, channels)
        if channels == 4:
            rgba = pixels  # the usual case: no second copy of a large image
        else:
            rgba = np.ones((height, width, 4), dtype=np.float32)
            rgba[..., :3] = pixels[..., :3] if channels >= 3 else pixels[..., :1]  # 1-2 channels: grey
            if channels == 2:
                rgba[..., 3] = pixels[..., 1]
        is_float = bool(image.is_float)
        if image.alpha_mode == "NONE":
            # Cycles ignores the stored alpha of an image whose Alpha mode is None: it reads 1.
            rgba[..., 3] = 1.0  # `rgba` is this function's own array
        elif image.alpha_mode == "PREMUL" and not is_float:
            # Blender gives a premultiplied 8-bit image's pixels divided by alpha; Cycles reads
            # its stored bytes (and associates them again, as every 8-bit colour image): write
            # those (exact for a premultiplied file, whose colour never exceeds its alpha).
            rgba[..., :3] *= rgba[..., 3:4]
        colorspace = image.colorspace_settings.name
        # Blender's scene linear space: the working space (Blender 5.0), which the renderer
        # leaves as it is.
        scene_linear = working_space_name()
        alpha_mode = image.alpha_mode
        if is_float and channels == 4 and png_with_alpha(image):
            rgba, colorspace = _png16_associated(rgba, alpha_mode, colorspace, scene_linear)
            alpha_mode = "PREMUL"  # written associated (module doc)
        elif image.colorspace_settings.is_data:
            colorspace = "Non-Color"
        elif is_float and colorspace == "sRGB" and scene_linear == REC709:
            # Blender decoded it on loading (module doc); Cycles filters an sRGB image encoded
            # and decodes after, so the encoded values go back into the file.
            rgba[..., :3] = _srgb_encode(rgba[..., :3])
        elif is_float:
            colorspace = scene_linear  # Blender converted it on loading (module doc)
        elif colorspace not in CONTRACT_SPACES:
            linear = _to_scene_linear(rgba, colorspace, self.gltf_folder)
            if linear is None:
                warnings.append(f"{what}: image '{image.name}' is in colour space '{colorspace}', which Blender "
                                "could not convert to linear; the renderer reads it as linear")
            else:
                rgba, is_float, colorspace = linear, True, scene_linear
        suffix = ".exr" if is_float else ".png"
        filename = self._unique(image.name, suffix)
        os.makedirs(os.path.join(self.gltf_folder, FOLDER), exist_ok=True)
        path = os.path.join(self.gltf_folder, FOLDER, filename)
        _save(rgba, is_float, path)
        return {"uri": f"{FOLDER}/{filename}", "colorspace": colorspace, "alpha": alpha_mode}

    def _unique(self, name, suffix):
        stem = re.sub(r"[^A-Za-z0-9._-]+", "_", os.path.splitext(name)[0]) or "image"
        candidate, n = stem + suffix, 1
        while candidate in self.names:
            candidate, n = f"{stem}_{n}{suffix}", n + 1
        self.names.add(candidate)
        return candidate


def _load(image):
    """Try to load an image's pixels from its file; whether it has them now."""
    try:
        image.reload()
    except RuntimeError:
        return False
    return image.has_data and image.size[0] > 0


def png_with_alpha(image):
    """Whether `image` is a 16-bit PNG colour image with alpha in Straight or Premultiplied mode,
    which Cycles associates in the file's own encoding (module doc)."""
    return (image.is_float and image.file_format == "PNG" and image.alpha_mode in {"STRAIGHT", "PREMUL"}
            and not image.colorspace_settings.is_data)


def _png16_associated(rgba, alpha_mode, colorspace, scene_linear):
    """A 16-bit PNG's pixels as Cycles holds them: the stored values times alpha, and the colour
    space they are in. Cycles reads the file itself (a PNG is straight by definition, so it
    associates in either alpha mode: measured on bpy 5.0.1, Straight and Premultiplied render
    alike) and decodes sRGB after filtering. Blender's pixels are the decoded straight colour times
    alpha, the straight colour being the stored one (Straight) or the stored one over alpha
    (Premultiplied); undone here. A texel of alpha 0 keeps colour 0, as it does in Cycles. Under another working space, or in another colour space, the
    association is done on Blender's linear values (exact for a linear file)."""
    alpha = rgba[..., 3:4]
    safe = np.where(alpha > 0.0, alpha, 1.0)
    straight = np.where(alpha > 0.0, rgba[..., :3] / safe, 0.0)
    out = rgba.copy()
    if colorspace == "sRGB" and scene_linear == REC709:
        stored = _srgb_encode(straight)
    else:
        stored, colorspace = straight, scene_linear
    if alpha_mode == "PREMUL":
        stored = stored * alpha
    out[..., :3] = stored * alpha
    return out, colorspace


def _srgb_encode(linear):
    """Linear values to sRGB's encoding (the inverse of the piecewise decode Blender and the
    renderer use; the linear segment continued below 0, the power curve past 1)."""
    return np.where(linear <= 0.0031308, linear * 12.92,
                    1.055 * np.power(np.maximum(linear, 0.0031308), 1.0 / 2.4) - 0.055).astype(np.float32)


def _to_scene_linear(rgba, colorspace, folder):
    """8-bit RGBA pixels stored in `colorspace`, converted to Blender's scene linear space (float
    RGBA), or None when Blender cannot convert them. Blender's colour management does the
    conversion, as it does for Cycles: a temporary image tagged with the space is saved as
    OpenEXR (a linear format: no view transform) through a temporary scene's output settings
    and read back as stored. Alpha is left out of the conversion (saved as 1, put back after),
    since Blender premultiplies on the way."""
    height, width, _ = rgba.shape
    opaque = rgba.copy()
    opaque[..., 3] = 1.0
    path = os.path.join(folder, "caustic-colorspace.exr")
    temp = bpy.data.images.new("caustic-colorspace", width, height, alpha=True)
    scene = bpy.data.scenes.new("caustic-colorspace")
    try:
        temp.colorspace_settings.name = colorspace
        temp.pixels.foreach_set(opaque.ravel())
        out = scene.render.image_settings
        out.file_format, out.color_depth, out.color_mode = "OPEN_EXR", "32", "RGBA"
        temp.save_render(path, scene=scene)
        back = bpy.data.images.load(path, check_existing=False)
        try:
            back.colorspace_settings.name = "Linear Rec.709"  # as written: read without conversion
            linear = np.empty(width * height * 4, dtype=np.float32)
            back.pixels.foreach_get(linear)
        finally:
            bpy.data.images.remove(back)
    except (RuntimeError, TypeError, ValueError):
        return None
    finally:
        bpy.data.images.remove(temp)
        bpy.data.scenes.remove(scene)
        if os.path.exists(path):
            os.remove(path)
    linear = linear.reshape(height, width, 4)
    linear[..., 3] = rgba[..., 3]
    return linear


def _save(rgba, is_float, path):
    """Write RGBA pixels (rows bottom to top, Blender's order) as PNG (8-bit) or OpenEXR (float),
    through a temporary Blender image so that nothing is converted on the way: a byte image's
    stored values go back to the same bytes, a float image's are written as 32-bit floats."""
    height, width, _ = rgba.shape
    temp = bpy.data.images.new("caustic-node-image", width, height, alpha=True, float_buffer=is_float)
    try:
        # The temporary image's own colour space must not convert on save: Non-Color stores
        # the numbers as they are in both formats.
        temp.colorspace_settings.name = "Non-Color"
        temp.pixels.foreach_set(rgba.ravel())
        temp.filepath_raw = path
        temp.file_format = "OPEN_EXR" if is_float else "PNG"
        temp.save()
    finally:
        bpy.data.images.remove(temp)
