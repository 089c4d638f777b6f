"""Material, light and world preview thumbnails, rendered by a `caustic serve` process.

Blender renders a thumbnail by calling the engine's `render` with `is_preview` on a small
preview scene (the material on a sphere, cube or other shape, its lights and world). Starting
the binary for each would pay its start-up (the process, the BSDF tables) every time; a
preview server started on the first thumbnail keeps them, and each thumbnail is an export of
the preview scene, a `load`, a render to `PREVIEW_SAMPLES` samples and the converged frame
copied into the render result. A cancelled thumbnail (Blender's test_break: the user moved on)
stops the render. Blender may render previews from a job thread: one lock serialises them.
The server is stopped when the add-on is unregistered, and ends by itself when Blender exits
(its stdin closes).
"""

import shutil
import tempfile
import threading
import time

from . import export, runner
from .errors import CausticError
from .frame import FrameWindow
from .server_client import ServerClient, ServerError, frame_pixels

# Samples per pixel of a thumbnail: Cycles' previews converge in a fraction of a second too.
PREVIEW_SAMPLES = 16
# How often a waiting preview checks for cancellation.
POLL_SECONDS = 0.02
# A thumbnail that has not converged in this long is reported and dropped.
TIMEOUT_SECONDS = 120.0


class PreviewServer:
    """One `caustic serve` process for every preview thumbnail."""

    def __init__(self, binary=None):
        self.binary = binary
        self.client = None
        self.lock = threading.Lock()

    def _client(self, engine):
        if self.client is None:
            self.client = ServerClient(self.binary or runner.find_binary())
        note = self.client.ensure_running()
        if note:
            engine.report({"WARNING"}, note)
        return self.client

    def render(self, engine, depsgraph):
        """Render the preview scene of `depsgraph` into a new render result of `engine`.
        Returns the number of samples rendered (0 when cancelled)."""
        with self.lock:
            scene = depsgraph.scene
            window = FrameWindow(scene.render)
            camera = engine.camera_override or scene.camera
            if camera is None:
                raise CausticError("the preview scene has no camera")
            settings = export.render_settings(scene, (window.width, window.height), camera.name, viewport=True)
            folder = tempfile.mkdtemp(prefix="caustic-preview-")
            try:
                path, _ = export.export_scene(depsgraph, folder, settings, motion=False)
                if engine.test_break():
                    return 0
                client = self._client(engine)
                integrator = "photon" if settings["integrator"] == "sppm" else settings["integrator"]
                client.request({"type": "settings", "integrator": integrator, "spp": PREVIEW_SAMPLES,
                                "max_depth": int(settings["max_depth"]), "frame_format": "f32", "reduce": 1})
                client.request({"type": "load", "path": path})
                generation = client.request({"type": "render_start"})["generation"]
                frame = self._wait(engine, client, generation)
                if frame is None:
                    return 0
                header, payload = frame
                pixels = frame_pixels(header, payload)
                result = engine.begin_result(0, 0, header["width"], header["height"])
                result.layers[0].passes["Combined"].rect = pixels.reshape(-1, 4)
                engine.end_result(result)
                return header["samples"]
            except ServerError as err:
                raise CausticError(f"Caustic preview: {err}") from err
            finally:
                shutil.rmtree(folder, ignore_errors=True)

    @staticmethod
    def _wait(engine, client, generation):
        """The converged frame of `generation`, or None when Blender cancelled the preview."""
        end = time.monotonic() + TIMEOUT_SECONDS
        while time.monotonic() < end:
            if engine.test_break():
                client.request({"type": "render_stop"})
                return None
            frame, done, error = client.take_state()
            if error:
                raise ServerError(error)
            if done and done["generation"] >= generation and frame and frame[0]["generation"] >= generation \
                    and frame[0]["samples"] >= done["samples"]:
                return frame
            if frame and frame[0]["generation"] >= generation and frame[0]["target"]:
                engine.update_progress(min(frame[0]["samples"] / frame[0]["target"], 1.0))
            if not client.alive():
                raise ServerError("the preview server ended")
            time.sleep(POLL_SECONDS)
        raise ServerError(f"the preview did not converge in {TIMEOUT_SECONDS:.0f} s")

    def stop(self):
        """End the server process."""
        with self.lock:
            if self.client is not None:
                self.client.stop()
                self.client = None
