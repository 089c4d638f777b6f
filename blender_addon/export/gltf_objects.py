"""Pieces of the exporter's own glTF object tree (io_scene_gltf2's internal classes).

Imported lazily: the exporter add-on may be loaded after Caustic.
"""

import struct


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
