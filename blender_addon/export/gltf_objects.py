"""Pieces of the exporter's own glTF object tree (io_scene_gltf2's internal classes).

Imported lazily: the exporter add-on may be loaded after Caustic.
"""

import struct

import numpy as np


def optional_extension(name, value):
    """An exporter Extension object `name` with `value`, not required by readers."""
    from io_scene_gltf2.io.com.gltf2_io_extensions import Extension
    return Extension(name=name, extension=value, required=False)


def attach_extension(gltf2_object, name, value):
    """Put the optional extension `name` with `value` on a glTF object (node, material, scene)."""
    if gltf2_object.extensions is None:
        gltf2_object.extensions = {}
    gltf2_object.extensions[name] = optional_extension(name, value)


def constant_uv_accessor(count):
    """A VEC2 float accessor of `count` vertices, all at glTF UV (0, 1) = Blender's (0, 0)."""
    from io_scene_gltf2.io.com import gltf2_io
    from io_scene_gltf2.io.com.constants import BufferViewTarget, ComponentType, DataType
    from io_scene_gltf2.io.exp.binary_data import BinaryData
    data = struct.pack("<2f", 0.0, 1.0) * count
    return gltf2_io.Accessor(
        buffer_view=BinaryData(data, bufferViewTarget=BufferViewTarget.ARRAY_BUFFER), byte_offset=None,
        component_type=ComponentType.Float, count=count, extensions=None, extras=None, max=None, min=None,
        name=None, normalized=None, sparse=None, type=DataType.Vec2)


def accessor_array(accessor, dtype, width):
    """An exporter accessor's data as a (count, width) array, or None when it is not plain
    tightly packed data in memory (the exporter's own accessors always are)."""
    data = getattr(accessor.buffer_view, "data", None)
    if not isinstance(data, (bytes, bytearray)) or accessor.sparse is not None:
        return None
    offset = accessor.byte_offset or 0
    size = np.dtype(dtype).itemsize * width * accessor.count
    if offset + size > len(data):
        return None
    arr = np.frombuffer(bytes(data[offset:offset + size]), dtype=dtype)
    return arr.reshape(accessor.count, width) if width > 1 else arr
