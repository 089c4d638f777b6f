"""The RenderEngine Blender sees; it only delegates (final.py renders, result.py declares passes)."""

import traceback

import bpy

from . import final, preview, result, viewport
from .errors import CausticError


class CausticRenderEngine(bpy.types.RenderEngine):
    """Caustic in Blender's Render Engine menu: final renders through the external binary."""

    bl_idname = "CAUSTIC"
    bl_label = "Caustic"
    # Material, light and world thumbnails render through one preview server (preview.py).
    bl_use_preview = True
    # Rendered shading is Caustic's, through `caustic serve` (viewport.py). With this off
    # Blender sends Material Preview to view_draw too (ED_view3d_engine_type), so both show
    # Caustic's image; Material Preview's studio lighting is not used.
    bl_use_eevee_viewport = False
    # Materials are Blender's own shader nodes, converted by the glTF exporter.
    bl_use_shading_nodes_custom = False
    # Compositing and sequencer work on Caustic's passes like on any engine's.
    bl_use_postprocess = True

    # The thumbnails' server, shared by every engine instance Blender makes for a preview
    # (each thumbnail gets a new one); stopped by unregister().
    _caustic_previews = preview.PreviewServer()

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._caustic_session = None
        self._caustic_viewport = None

    def __del__(self):
        # Blender frees the engine when the viewport leaves Rendered mode: stop its server.
        # (RenderEngine has no other hook for this; Cycles frees its session here too.)
        # The RNA side may already be gone (after a final render): attribute access on the
        # engine then raises ReferenceError, which a finaliser must not (it ran inside pytest's
        # source parsing and broke it). The Python side's own dict still holds the viewport.
        try:
            vp = object.__getattribute__(self, "__dict__").get("_caustic_viewport")
        except (AttributeError, ReferenceError):
            return
        if vp is not None:
            vp.free()

    def view_update(self, context, depsgraph):
        """The viewport's scene changed: send the edits (viewport.py), never raise."""
        if self._caustic_viewport is None:
            self._caustic_viewport = viewport.Viewport(self)
        try:
            self._caustic_viewport.update(context, depsgraph)
        except Exception as err:  # a bug in the add-on: keep Blender's viewport alive
            traceback.print_exc()
            self.report({"ERROR"}, f"Caustic viewport internal error: {err!r} (details in the console)")

    def view_draw(self, context, depsgraph):
        """Draw the newest frame of the viewport's server (viewport.py), never raise."""
        if self._caustic_viewport is None:
            return
        try:
            self._caustic_viewport.draw(context, depsgraph)
        except Exception as err:
            traceback.print_exc()
            self.report({"ERROR"}, f"Caustic viewport internal error: {err!r} (details in the console)")

    def render(self, depsgraph):
        """Render one frame of one view layer; failures become reports, never tracebacks."""
        try:
            if self.is_preview:
                self._caustic_previews.render(self, depsgraph)
            else:
                final.render_frame(self, depsgraph)
        except CausticError as err:
            self.report({"ERROR"}, str(err) if str(err).startswith("Caustic") else f"Caustic: {err}")
        except Exception as err:  # a bug in the add-on: say so, keep the details in the console
            traceback.print_exc()
            self.report({"ERROR"}, f"Caustic add-on internal error: {err!r} (details in the console)")

    def should_stop(self):
        """Whether the user cancelled; the one break check the render loop polls."""
        return self.test_break()

    def update_render_passes(self, scene=None, renderlayer=None):
        """Declare the passes Caustic writes (Blender calls this to build the pass list)."""
        result.register_passes(self, scene, renderlayer)


def register():
    """Register the render engine."""
    bpy.utils.register_class(CausticRenderEngine)


def unregister():
    """Unregister the render engine and stop its preview server."""
    CausticRenderEngine._caustic_previews.stop()
    bpy.utils.unregister_class(CausticRenderEngine)
