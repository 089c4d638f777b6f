"""Render on farm: export the frame (or every frame of the range), hand the scenes to the
`caustic_farm` command (Dask; README "Rendering on many machines") and load the merged
result into Blender as an image.

The farm runs in a Python that has `caustic_farm` and Dask's `distributed` installed (the
project's `.venv`, or a render-farm machine's), named in the add-on preferences with the
scheduler address (empty: a local cluster on 127.0.0.1). Blender's own Python is not used:
it has no Dask. The operator blocks while the farm runs and shows progress on the window
manager's progress indicator; frame images are written beside the blend file's output path.
"""

import json
import os
import subprocess
import tempfile
import threading

import bpy
from bpy.props import BoolProperty

from . import export, runner
from .errors import CausticError
from .final import FrameWindow

# What the last run did, for tests and scripts: scenes exported, frame images, farm lines.
last_run = {}


def _prefs(context):
    return context.preferences.addons[__package__].preferences


def farm_command(python, scenes, pattern, chunks, scheduler, binary):
    """The farm's argv: one scene per frame, chunks per frame, the scheduler if any."""
    argv = [python, "-m", "caustic_farm", *scenes, "-o", pattern, "--chunks", str(chunks), "--binary", binary]
    if scheduler:
        argv += ["--scheduler", scheduler]
    return argv


def _export_frames(context, frames, folder):
    """Exports each frame to its own folder; returns the glTF paths (frame order)."""
    scene = context.scene
    window = FrameWindow(scene.render)
    camera = scene.camera
    paths = []
    current = scene.frame_current
    try:
        for f in frames:
            scene.frame_set(f)
            settings = export.render_settings(scene, (window.width, window.height), camera.name if camera else None)
            if settings.pop("noise_threshold", None) is not None:
                # The binary refuses adaptive chunks: a pixel's stop depends on all its samples.
                settings.pop("min_samples", None)
                print(f"Caustic farm: frame {f}: adaptive sampling is off on the farm (frames are rendered in "
                      "sample chunks, and a pixel's stopping point needs all of its samples); every pixel takes "
                      "every sample")
            if scene.caustic.use_denoising:
                print(f"Caustic farm: frame {f}: not denoised (the farm merges sample chunks; denoising on the "
                      "farm is not implemented)")
            sub = os.path.join(folder, f"frame_{f:05d}")
            os.makedirs(sub)
            gltf, state = export.export_scene(context.evaluated_depsgraph_get(), sub, settings)
            for warning in state.warnings:
                print(f"Caustic farm: frame {f}: {warning}")
            paths.append(gltf)
    finally:
        scene.frame_set(current)
    return paths


def run_farm(argv, on_line):
    """Runs the farm command, calling `on_line(dict)` for each JSON line; returns (code, error)."""
    try:
        proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    except OSError as err:
        raise CausticError(f"could not start the farm ({argv[0]}): {err.strerror}") from None
    log = []
    reader = threading.Thread(target=lambda: log.extend(proc.stderr.read().decode(errors="replace").splitlines()),
                              daemon=True)
    reader.start()
    error = None
    try:
        for raw in proc.stdout:
            try:
                message = json.loads(raw)
            except ValueError:
                continue
            if isinstance(message, dict):
                if message.get("type") == "error":
                    error = message.get("message")
                on_line(message)
        code = proc.wait()
    except BaseException:
        proc.terminate()  # the farm cancels its chunks and stops its workers
        proc.wait()
        raise
    reader.join(timeout=1.0)
    if code not in (0, 5) and not error:
        tail = " / ".join(log[-3:])
        error = f"the farm exited with code {code}" + (f": {tail}" if tail else "")
    return code, error


def render_on_farm(context, animation, report):
    """Exports, runs the farm, loads the result; returns the frame image paths."""
    scene = context.scene
    prefs = _prefs(context)
    python = prefs.farm_python or os.environ.get("CAUSTIC_FARM_PYTHON", "")
    if not python:
        raise CausticError("set the farm's Python (with caustic_farm installed) in Preferences > Add-ons > Caustic")
    binary = runner.find_binary()
    frames = list(range(scene.frame_start, scene.frame_end + 1, scene.frame_step)) if animation \
        else [scene.frame_current]
    work = tempfile.mkdtemp(prefix="caustic-farm-")
    out_dir = os.path.dirname(bpy.path.abspath(scene.render.filepath)) or work
    os.makedirs(out_dir, exist_ok=True)
    scenes = _export_frames(context, frames, work)
    outputs = [os.path.join(out_dir, f"caustic_farm_{f:05d}.exr") for f in frames]
    # The farm numbers frames 0..n-1: write through a pattern on that index, then rename.
    tmp_pattern = os.path.join(work, "frame_{frame:05d}.exr")
    argv = farm_command(python, scenes, tmp_pattern, prefs.farm_chunks, prefs.farm_scheduler, binary)
    lines = []
    wm = context.window_manager
    wm.progress_begin(0, 1)

    def on_line(message):
        lines.append(message)
        if message.get("type") == "chunk" and message.get("total"):
            wm.progress_update(message["done"] / message["total"])
        elif message.get("type") == "retry":
            report({"WARNING"}, f"Caustic farm: retrying frame {message.get('frame')}: {message.get('reason')}")

    try:
        code, error = run_farm(argv, on_line)
    finally:
        wm.progress_end()
    last_run.update(scenes=scenes, outputs=outputs, lines=lines, code=code)
    if error:
        raise CausticError(f"Caustic farm: {error}")
    written = []
    for i, out in enumerate(outputs):
        src = tmp_pattern.format(frame=i)
        if os.path.exists(src):
            os.replace(src, out)
            written.append(out)
    if not written:
        raise CausticError("Caustic farm: no frame was rendered")
    image = bpy.data.images.load(written[-1], check_existing=False)
    image.name = "Caustic Farm"
    if code == 5:
        report({"WARNING"}, "Caustic farm: cancelled; the frames hold the samples rendered so far")
    return written


class CAUSTIC_OT_render_farm(bpy.types.Operator):
    """Render the frame (or the animation) on a Dask render farm, merged exactly from sample chunks"""

    bl_idname = "caustic.render_farm"
    bl_label = "Render on Farm"

    animation: BoolProperty(name="Animation", description="Render every frame of the range", default=False)

    @classmethod
    def poll(cls, context):
        return context.scene.render.engine == "CAUSTIC"

    def execute(self, context):
        try:
            written = render_on_farm(context, self.animation, self.report)
        except CausticError as err:
            self.report({"ERROR"}, str(err))
            return {"CANCELLED"}
        self.report({"INFO"}, f"Caustic farm: {len(written)} frame(s) in {os.path.dirname(written[0])}")
        return {"FINISHED"}


def register():
    bpy.utils.register_class(CAUSTIC_OT_render_farm)


def unregister():
    bpy.utils.unregister_class(CAUSTIC_OT_render_farm)
