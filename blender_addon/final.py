"""A final (F12 / `bpy.ops.render.render`) render of one frame and one view layer.

Export the render depsgraph to a temporary folder, run the binary on it, show its progress and
interim images, load the image it wrote, and remove the folder. Animation renders call this once
per frame (Blender drives the frame loop).
"""

import os
import shutil
import tempfile

from . import export, farm, result, runner, views
from .frame import FrameWindow
from .errors import CausticError

INTERIM_SECONDS = 1
# Set to keep each render's temporary folder (scene.gltf, out.exr, log) for debugging.
KEEP_TEMP_ENV = "CAUSTIC_KEEP_TEMP"


def command_line(binary, gltf_path, out_path, settings, window, passes="none", denoise=False):
    """The binary's argv for one frame (flags repeat extras.caustic so that flags win);
    `passes` is the `--passes` list of the view layer (result.pass_request)."""
    argv = [binary, "render", gltf_path, "-o", out_path, "--progress", "json",
            "--interim", str(INTERIM_SECONDS),
            "--resolution", f"{window.width}x{window.height}",
            "--spp", str(settings["spp"]),
            "--max-depth", str(settings["max_depth"]),
            "--seed", str(settings["seed"]),
            "--integrator", settings["integrator"]]
    if "time_limit" in settings:
        argv += ["--time-limit", repr(settings["time_limit"])]
    if "threads" in settings:
        argv += ["--threads", str(settings["threads"])]
    if "camera" in settings:
        argv += ["--camera", settings["camera"]]
    if window.is_border:
        argv += ["--crop", window.crop_argument()]
    argv += ["--passes", passes]
    if denoise:
        argv += ["--denoise"]
        library = runner.find_oidn()
        if library:
            argv += ["--oidn", library]
    return argv


def _number(message, key):
    """The finite number at `key`, or None: a line from a broken binary must not raise here."""
    value = message.get(key)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value != value:
        return None
    return value if abs(value) != float("inf") else None


def _stats_text(message):
    done, total = _number(message, "samples_done"), _number(message, "samples_total")
    done = int(done) if done is not None else "?"
    parts = [f"Sample {done}/{int(total)}" if total else f"Sample {done}"]
    elapsed, eta, rays = _number(message, "elapsed"), _number(message, "eta"), _number(message, "rays_per_sec")
    if elapsed is not None:
        parts.append(f"{elapsed:.1f} s")
    if eta is not None:
        parts.append(f"{eta:.1f} s left")
    if rays:
        parts.append(f"{rays / 1e6:.1f} Mrays/s")
    return "Caustic | " + " | ".join(parts)


class _Session:
    """One frame's render: the engine, its render result and what the binary reported."""

    def __init__(self, engine, render_result, out_path, exposure=1.0, to_camera=None):
        self.engine = engine
        self.render_result = render_result
        self.out_path = out_path
        self.exposure = exposure  # the Film panel's, applied to every image loaded
        self.to_camera = to_camera  # the camera's rotation, for the Denoising Normal (result.load)
        self.progress_seen = False
        self.last_phase = None  # the binary's phase, for the stats line and tests

    def on_message(self, message):
        kind = message.get("type")
        engine = self.engine
        if kind == "phase":
            self.last_phase = str(message.get("phase", ""))
            engine.update_stats("", f"Caustic | {self.last_phase}")
        elif kind == "progress":
            self.progress_seen = True
            fraction = _number(message, "fraction")
            if fraction is not None:
                engine.update_progress(min(max(float(fraction), 0.0), 1.0))
            engine.update_stats("", _stats_text(message))
        elif kind == "warning":
            engine.report({"WARNING"}, f"Caustic: {message.get('message', '')}")
        elif kind == "image" and message.get("final") is False:
            # The contract's image path is the output path; only that file is ever read.
            self._show_interim(self.out_path)

    def _show_interim(self, path):
        # The binary replaces the file atomically; a failed interim load only delays the picture.
        try:
            result.load(self.render_result, path, self.exposure, self.to_camera)
        except CausticError as err:
            print(f"Caustic: interim image not shown: {err}")
            return
        self.engine.update_result(self.render_result)


def render_frame(engine, depsgraph):
    """Render the depsgraph's frame and view layer into a new render result of `engine`."""
    scene = depsgraph.scene
    window = FrameWindow(scene.render)
    binary = runner.find_binary()

    camera = engine.camera_override or scene.camera
    settings, layer_warnings = export.layer_render_settings(scene, depsgraph.view_layer, depsgraph.objects,
                                                         (window.width, window.height),
                                                         camera.name if camera else None)
    for warning in layer_warnings:
        engine.report({"WARNING"}, f"Caustic: {warning}")
    on_farm = scene.caustic.use_farm
    if on_farm:
        for warning in farm.strip_unfarmable(settings, scene):
            engine.report({"WARNING"}, f"Caustic farm: {warning}")
    folder = tempfile.mkdtemp(prefix="caustic-")
    try:
        engine.update_stats("", "Caustic | exporting scene")
        gltf_path, state = export.export_scene(depsgraph, folder, settings)
        for warning in state.warnings:
            engine.report({"WARNING"}, f"Caustic: {warning}")
        if engine.should_stop():
            return
        passes, pass_warnings = result.pass_request(depsgraph.view_layer, settings["integrator"],
                                                    motion_blur=depsgraph.scene.render.use_motion_blur)
        for warning in pass_warnings:
            engine.report({"WARNING"}, f"Caustic: {warning}")
        view_names = views.active_views(scene) if camera is not None else [""]
        if on_farm and view_names != [""]:
            raise CausticError("Stereoscopy renders on this machine only: turn off Render on Farm for a "
                               "multi-view render")
        for view in view_names:
            if engine.should_stop():
                return
            view_path = gltf_path
            if view:
                view_path = os.path.join(folder, f"scene_{view}.gltf")
                offset, shift_x, warnings = views.view_camera(engine, camera, view)
                for warning in warnings:
                    engine.report({"WARNING"}, f"Caustic: {warning}")
                try:
                    views.gltf_for_view(gltf_path, view_path, camera, offset, shift_x, (window.width, window.height),
                                        (scene.render.pixel_aspect_x, scene.render.pixel_aspect_y))
                except (OSError, ValueError, KeyError) as err:
                    raise CausticError(f"view '{view}': {err}") from None
            _render_view(engine, depsgraph, settings, window, binary, view_path, view, passes,
                         os.path.join(folder, f"out{'_' + view if view else ''}.exr"), on_farm)
    finally:
        if os.environ.get(KEEP_TEMP_ENV):
            print(f"Caustic: kept {folder}")
        else:
            shutil.rmtree(folder, ignore_errors=True)


def _render_view(engine, depsgraph, settings, window, binary, gltf_path, view, passes, out_path, on_farm):
    """Run the binary on one view's glTF and load its image into the result's `view` ("" for a
    single-view render)."""
    scene = depsgraph.scene
    # Denoising is a command-line option, not a scene setting: farm chunks cannot be denoised.
    argv = command_line(binary, gltf_path, out_path, settings, window, passes,
                        denoise=scene.caustic.use_denoising and not on_farm)
    argv += result.cryptomatte_arguments(depsgraph.view_layer, passes)
    if view:
        argv += ["--view", view]  # the channels Blender's multi-view result reads
    if on_farm:
        argv, warnings = farm.frame_command(farm.preferences(), binary, gltf_path, out_path, argv,
                                            settings["spp"])
        for warning in warnings:
            engine.report({"WARNING"}, f"Caustic: {warning}")
    width, height = window.size
    render_result = engine.begin_result(0, 0, width, height, layer=depsgraph.view_layer.name, view=view)
    failed = True
    try:
        session = _Session(engine, render_result, out_path, export.film_exposure(scene),
                           result.camera_rotation(engine.camera_override or scene.camera))
        engine._caustic_session = session  # lets tests see the progress state
        on_message = (lambda m: farm.on_frame_message(engine, m)) if on_farm else session.on_message
        folder = os.path.dirname(out_path)
        outcome = runner.run(argv, on_message, engine.should_stop,
                             log_path=os.path.join(folder, f"stdout{'_' + view if view else ''}.log"),
                             json_on_stdout=on_farm)
        message = outcome.error_message()
        if message:
            raise CausticError(message)
        if outcome.has_image:
            result.load(render_result, out_path, session.exposure, session.to_camera)
            result.store_metadata(engine, out_path, depsgraph.view_layer.name)
        if outcome.summary:
            _report_summary(engine, outcome.summary)
        failed = False
    finally:
        engine.end_result(render_result, cancel=failed)


def _report_summary(engine, summary):
    nan = _number(summary, "nan_samples") or 0
    if nan:
        engine.report({"WARNING"}, f"Caustic: {int(nan)} samples were NaN or infinite and dropped")
    spp = _number(summary, "spp")
    elapsed = _number(summary, "elapsed")
    if spp is not None and elapsed is not None:
        state = "interrupted" if summary.get("interrupted") else "done"
        engine.update_stats("", f"Caustic | {state}: {spp} samples in {elapsed:.1f} s")
