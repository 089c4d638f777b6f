"""Pointing Blender's glTF exporter at the render depsgraph.

The exporter evaluates meshes with `bpy.context.evaluated_depsgraph_get()`, the viewport
depsgraph. `render_depsgraph` makes its modules see the render depsgraph instead for the
duration of the export, so that render-level modifiers and render visibility are used.
"""

import sys
from contextlib import contextmanager

import bpy


class _ContextProxy:
    """bpy.context, except that evaluated_depsgraph_get() returns the render depsgraph."""

    def __init__(self, depsgraph):
        object.__setattr__(self, "_depsgraph", depsgraph)

    def evaluated_depsgraph_get(self):
        return self._depsgraph

    def __getattr__(self, name):
        return getattr(bpy.context, name)

    def __setattr__(self, name, value):
        setattr(bpy.context, name, value)


class _BpyProxy:
    """The bpy module as seen by the exporter during a Caustic export."""

    def __init__(self, depsgraph):
        self.context = _ContextProxy(depsgraph)

    def __getattr__(self, name):
        return getattr(bpy, name)


def _import_exporter_modules():
    """Imports every module of the exporter's `blender.exp` package: the exporter imports
    some only inside its operator, and a module first imported after the patch below would
    see the viewport depsgraph (the first F12 of a session exported viewport subdivision
    levels)."""
    import importlib
    import pkgutil

    try:
        package = importlib.import_module("io_scene_gltf2.blender.exp")
    except ImportError:
        return
    for info in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
        try:
            importlib.import_module(info.name)
        except Exception:  # an optional part (e.g. a compression library) may not load
            continue


@contextmanager
def render_depsgraph(depsgraph):
    """Let the exporter's modules see `depsgraph` as the context's evaluated depsgraph."""
    _import_exporter_modules()
    proxy = _BpyProxy(depsgraph)
    patched = []
    for name, module in list(sys.modules.items()):
        if name.startswith("io_scene_gltf2.blender.exp") and getattr(module, "bpy", None) is bpy:
            module.bpy = proxy
            patched.append(module)
    try:
        yield
    finally:
        for module in patched:
            module.bpy = bpy
