"""Render on farm, two ways. With the render setting "Render on Farm" on, F12 and Render
Animation send each frame to the `caustic_farm` command (Dask; README "Rendering on many
machines") in sample chunks, with progress, cancel (Esc) and the merged frame in the Render
Result like a local render (`frame_command`, `on_frame_message`; final.py runs it). The
operators export every frame of the range at once (frames run in parallel on the farm) and
load the merged result into Blender as an image; from the panel they run as a modal
operator (Blender stays responsive, Esc cancels), from scripts to the end.

The farm runs in a Python that has `caustic_farm` and Dask's `distributed` installed (the
project's `.venv`, or a render-farm machine's), named in the add-on preferences with the
scheduler address (empty: a local cluster on 127.0.0.1). Blender's own Python is not used:
it has no Dask. Progress shows on the window manager's indicator and the status bar; frame
images are written beside the blend file's output path.
"""

import json
import os
import queue
import subprocess
import tempfile
import threading
import time

import bpy
from bpy.props import BoolProperty

from . import export, result, runner
from .errors import CausticError
from .frame import FrameWindow

# What the last run did, for tests and scripts: scenes exported, frame images, farm lines,
# the flags every chunk was rendered with.
last_run = {}


def _prefs(context):
    return context.preferences.addons[__package__].preferences


def preferences():
    """The add-on preferences that hold the farm's Python, scheduler and chunk count."""
    return _prefs(bpy.context)


def farm_command(python, scenes, pattern, chunks, scheduler, binary):
    """The farm's argv: one scene per frame, chunks per frame, the scheduler if any."""
    argv = [python, "-m", "caustic_farm", *scenes, "-o", pattern, "--chunks", str(chunks), "--binary", binary]
    if scheduler:
        argv += ["--scheduler", scheduler]
    return argv


# Flags of `caustic render` that the farm sets per chunk itself or that have no meaning
# there, with whether they take a value.
_FARM_OWN_FLAGS = {"--progress": True, "--interim": True, "--spp": True, "--time-limit": True,
                   "--denoise": False, "--oidn": True}


def strip_unfarmable(settings, scene):
    """Drops from the render settings what chunks cannot do; returns the warnings saying so.
    Shadow catchers, light groups, shader AOVs and the light and data passes travel in chunks
    (their sums merge exactly), Cryptomatte too (each pixel's first-seen ids with their counts)."""
    warnings = []
    if settings.pop("noise_threshold", None) is not None:
        # The binary refuses adaptive chunks: a pixel's stop depends on all its samples.
        settings.pop("min_samples", None)
        warnings.append("adaptive sampling is off on the farm (frames are rendered in sample chunks, and a "
                        "pixel's stopping point needs all of its samples); every pixel takes every sample")
    if scene.caustic.use_denoising:
        warnings.append("not denoised (the farm merges sample chunks; denoising on the farm is not implemented)")
    return warnings


def frame_command(prefs, binary, gltf_path, out_path, render_argv, spp):
    """The farm's argv for one frame, from the local render's argv (`final.command_line`):
    its flags go to every chunk after `--`, but the sample count, which the farm splits into
    chunks, and the flags the farm owns. Returns (argv, warnings)."""
    python = prefs.farm_python or os.environ.get("CAUSTIC_FARM_PYTHON", "")
    if not python:
        raise CausticError("Render on Farm is on: set the farm's Python (with caustic_farm installed) in "
                           "Preferences > Add-ons > Caustic")
    flags, warnings, i = [], [], 5  # after: binary render SCENE -o OUT
    while i < len(render_argv):
        flag = render_argv[i]
        if flag in _FARM_OWN_FLAGS:
            if flag == "--time-limit":
                warnings.append("Render on Farm renders every sample: the time limit is not used")
            i += 2 if _FARM_OWN_FLAGS[flag] else 1
            continue
        flags.append(flag)
        i += 1
    argv = farm_command(python, [gltf_path], out_path, prefs.farm_chunks, prefs.farm_scheduler, binary)
    return argv + ["--spp", str(spp), "--", *flags], warnings


def on_frame_message(engine, message):
    """Shows one JSON line of the farm on the engine: progress per merged chunk, retries."""
    kind = message.get("type")
    if kind == "start":
        engine.update_stats("", f"Caustic farm | {message.get('chunks', '?')} chunks on "
                                f"{message.get('scheduler', 'the farm')}")
    elif kind == "chunk":
        done, total = message.get("done"), message.get("total")
        if isinstance(done, int) and isinstance(total, int) and total > 0:
            engine.update_progress(min(max(done / total, 0.0), 1.0))
            engine.update_stats("", f"Caustic farm | chunk {done}/{total}")
    elif kind == "retry":
        engine.report({"WARNING"}, f"Caustic farm: retrying samples {message.get('samples')}: "
                                   f"{message.get('reason')}")
    elif kind == "cancelling":
        engine.update_stats("", "Caustic farm | cancelling: merging the samples rendered so far")


def _export_frames(context, frames, folder):
    """Exports each frame to its own folder; returns (the glTF paths in frame order, the flags
    for every chunk: the view layer's passes, as F12 asks for them)."""
    scene = context.scene
    view_layer = context.view_layer
    window = FrameWindow(scene.render)
    camera = scene.camera
    paths = []
    current = scene.frame_current
    try:
        for f in frames:
            scene.frame_set(f)
            depsgraph = context.evaluated_depsgraph_get()
            settings, warnings = export.layer_render_settings(scene, view_layer, depsgraph.objects,
                                                              (window.width, window.height),
                                                              camera.name if camera else None)
            if export.film_exposure(scene) != 1.0:
                # F12 applies it when loading the image (result.load); these files are the binary's.
                warnings.append(f"Film Exposure {export.film_exposure(scene):g} is not applied to the farm's "
                                "EXR files (F12 applies it)")
            for warning in warnings + strip_unfarmable(settings, scene):
                print(f"Caustic farm: frame {f}: {warning}")
            sub = os.path.join(folder, f"frame_{f:05d}")
            os.makedirs(sub)
            gltf, state = export.export_scene(depsgraph, sub, settings)
            for warning in state.warnings:
                print(f"Caustic farm: frame {f}: {warning}")
            paths.append(gltf)
    finally:
        scene.frame_set(current)
    passes, warnings = result.pass_request(view_layer, settings["integrator"],
                                           motion_blur=scene.render.use_motion_blur)
    for warning in warnings:
        print(f"Caustic farm: {warning}")
    return paths, ["--passes", passes, *result.cryptomatte_arguments(view_layer, passes)]


class FarmJob:
    """One run of the farm over exported frames, polled rather than waited on, so that the
    modal operator keeps Blender responsive and Esc cancels, while scripts (and headless
    tests) poll the same job in a loop."""

    def __init__(self, context, animation, report):
        scene = context.scene
        prefs = _prefs(context)
        python = prefs.farm_python or os.environ.get("CAUSTIC_FARM_PYTHON", "")
        if not python:
            raise CausticError("set the farm's Python (with caustic_farm installed) in Preferences > Add-ons > Caustic")
        binary = runner.find_binary()
        frames = list(range(scene.frame_start, scene.frame_end + 1, scene.frame_step)) if animation \
            else [scene.frame_current]
        self.report = report
        self.work = tempfile.mkdtemp(prefix="caustic-farm-")
        out_dir = os.path.dirname(bpy.path.abspath(scene.render.filepath)) or self.work
        os.makedirs(out_dir, exist_ok=True)
        self.scenes, self.chunk_flags = _export_frames(context, frames, self.work)
        self.outputs = [os.path.join(out_dir, f"caustic_farm_{f:05d}.exr") for f in frames]
        # The farm numbers frames 0..n-1: write through a pattern on that index, then rename.
        self.pattern = os.path.join(self.work, "frame_{frame:05d}.exr")
        argv = farm_command(python, self.scenes, self.pattern, prefs.farm_chunks, prefs.farm_scheduler, binary)
        argv += ["--", *self.chunk_flags]
        self.lines = []
        self.fraction = 0.0
        self.error = None
        self.cancelled = False
        self.log = []
        self.messages = queue.Queue()
        try:
            self.proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                         stderr=subprocess.PIPE)
        except OSError as err:
            raise CausticError(f"could not start the farm ({argv[0]}): {err.strerror}") from None
        self.readers = [threading.Thread(target=self._read_json, daemon=True),
                        threading.Thread(target=self._read_log, daemon=True)]
        for t in self.readers:
            t.start()

    def _read_json(self):
        for raw in self.proc.stdout:
            try:
                message = json.loads(raw)
            except ValueError:
                continue
            if isinstance(message, dict):
                self.messages.put(message)

    def _read_log(self):
        self.log.extend(self.proc.stderr.read().decode(errors="replace").splitlines())

    def _take_messages(self):
        while True:
            try:
                message = self.messages.get_nowait()
            except queue.Empty:
                return
            self.lines.append(message)
            kind = message.get("type")
            if kind == "error":
                self.error = message.get("message")
            elif kind == "chunk" and message.get("total"):
                self.fraction = message["done"] / message["total"]
            elif kind == "retry":
                self.report({"WARNING"}, f"Caustic farm: retrying frame {message.get('frame')}: "
                                         f"{message.get('reason')}")

    def cancel(self):
        """Asks the farm to stop: every renderer writes its samples, partial frames merge.
        Once: a second signal would make the farm leave without merging."""
        if self.proc.poll() is None and not self.cancelled:
            self.cancelled = True
            self.proc.terminate()

    def kill(self):
        """Leaves at once (Blender is closing the operator): no process stays behind."""
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()

    def poll(self):
        """None while the farm runs; then the frame images written (raises CausticError)."""
        self._take_messages()
        code = self.proc.poll()
        if code is None:
            return None
        for t in self.readers:
            t.join(timeout=1.0)
        self._take_messages()
        last_run.update(scenes=self.scenes, outputs=self.outputs, lines=self.lines, code=code,
                        chunk_flags=self.chunk_flags)
        if code not in (0, 5) and not self.error:
            tail = " / ".join(self.log[-3:])
            self.error = f"the farm exited with code {code}" + (f": {tail}" if tail else "")
        if self.error:
            raise CausticError(f"Caustic farm: {self.error}")
        written = []
        for i, out in enumerate(self.outputs):
            src = self.pattern.format(frame=i)
            if os.path.exists(src):
                os.replace(src, out)
                written.append(out)
        if not written:
            raise CausticError("Caustic farm: no frame was rendered")
        image = bpy.data.images.load(written[-1], check_existing=False)
        image.name = "Caustic Farm"
        if code == 5:
            self.report({"WARNING"}, "Caustic farm: cancelled; the frames hold the samples rendered so far")
        return written


class CAUSTIC_OT_render_farm(bpy.types.Operator):
    """Render the frame (or the animation) on a Dask render farm, merged exactly from sample chunks"""

    bl_idname = "caustic.render_farm"
    bl_label = "Render on Farm"

    animation: BoolProperty(name="Animation", description="Render every frame of the range", default=False)

    _job = None
    _timer = None

    @classmethod
    def poll(cls, context):
        return context.scene.render.engine == "CAUSTIC"

    def execute(self, context):
        """Scripts: run the farm to the end (Ctrl-C in the console cancels it)."""
        try:
            job = FarmJob(context, self.animation, self.report)
            try:
                while (written := job.poll()) is None:
                    time.sleep(0.1)
            except KeyboardInterrupt:
                job.cancel()
                while (written := job.poll()) is None:
                    time.sleep(0.1)
        except CausticError as err:
            self.report({"ERROR"}, str(err))
            return {"CANCELLED"}
        return self._finished(written)

    def invoke(self, context, event):
        """The panel's buttons: run in the background of Blender's event loop; Esc cancels."""
        try:
            self._job = FarmJob(context, self.animation, self.report)
        except CausticError as err:
            self.report({"ERROR"}, str(err))
            return {"CANCELLED"}
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.25, window=context.window)
        wm.modal_handler_add(self)
        wm.progress_begin(0, 1)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type == "ESC":
            self._job.cancel()
            context.workspace.status_text_set("Caustic farm: cancelling (merging the samples rendered so far)")
            return {"RUNNING_MODAL"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            written = self._job.poll()
        except CausticError as err:
            self._end(context)
            self.report({"ERROR"}, str(err))
            return {"CANCELLED"}
        if written is None:
            context.window_manager.progress_update(self._job.fraction)
            context.workspace.status_text_set(f"Caustic farm: {self._job.fraction:.0%} (Esc to cancel)")
            return {"RUNNING_MODAL"}
        self._end(context)
        return self._finished(written)

    def cancel(self, context):
        """Blender ends the operator (file closed, quit): stop the farm with it."""
        if self._job is not None:
            self._job.kill()
        self._end(context)

    def _end(self, context):
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()
        context.workspace.status_text_set(None)

    def _finished(self, written):
        self.report({"INFO"}, f"Caustic farm: {len(written)} frame(s) in {os.path.dirname(written[0])}")
        return {"FINISHED"}


def register():
    bpy.utils.register_class(CAUSTIC_OT_render_farm)


def unregister():
    bpy.utils.unregister_class(CAUSTIC_OT_render_farm)
