"""Caustic for Blender: a render engine that runs the `caustic` binary as a separate process.

This file only registers. The glTF exporter looks for `glTF2ExportUserExtension` in this module,
so the hook class is re-exported here.
"""

from . import engine, farm, properties, ui
from .export import glTF2ExportUserExtension  # noqa: F401  (found by the glTF exporter here)

_modules = (properties, engine, farm, ui)


def register():
    """Register settings, the engine and the panels."""
    for module in _modules:
        module.register()


def unregister():
    """Unregister in reverse order."""
    for module in reversed(_modules):
        module.unregister()
