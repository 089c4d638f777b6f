"""Render on Farm with real bpy: the add-on exports, runs caustic_farm on a local Dask
cluster, and loads the merged frame, which equals a single render of the exported scene."""

import os
import subprocess
import sys

import bpy
import pytest

import scenes

pytestmark = pytest.mark.needs_binary

W, H = 32, 24
FARM = os.path.join(os.path.dirname(__file__), "..", "..", "farm")


@pytest.fixture
def scene(empty_scene, tmp_path, monkeypatch, addon):
    s = empty_scene
    scenes.small_render_settings(s, W, H, samples=6)
    scenes.plane_and_cube_scene(s)
    scenes.light(s, "Key", "AREA", location=(0.5, -0.5, 3.0), shape="RECTANGLE", size=1.5,
                 size_y=1.0, energy=200.0)
    s.render.filepath = str(tmp_path / "frames" / "out")
    # The farm runs in this test's Python (the project's .venv has distributed) with farm/ on its path.
    monkeypatch.setenv("CAUSTIC_FARM_PYTHON", sys.executable)
    monkeypatch.setenv("PYTHONPATH", os.path.abspath(FARM))
    return s


def farm_module(addon):
    return sys.modules[f"{addon.__name__}.farm"]


def test_render_on_farm_equals_single_render(scene, addon, tmp_path):
    assert bpy.ops.caustic.render_farm(animation=False) == {"FINISHED"}
    run = farm_module(addon).last_run
    assert run["code"] == 0
    out = run["outputs"][0]
    # The merged frame is loaded as an image (Blender reads the multi-pass EXR as a multilayer
    # image, whose passes show in the image editor).
    image = bpy.data.images["Caustic Farm"]
    assert os.path.samefile(bpy.path.abspath(image.filepath_raw), out), (image.filepath_raw, out)
    assert sys.modules[f"{addon.__name__}.result"].exr_size(out) == (W, H)
    assert sum(1 for m in run["lines"] if m["type"] == "chunk") == 4  # the preference's default
    single = str(tmp_path / "single.exr")
    # The view layer's passes are asked for as F12 asks for them (this layer has none beyond
    # Combined, so the default data passes are not written either).
    assert run["chunk_flags"] == ["--passes", "none"], run["chunk_flags"]
    subprocess.run([os.environ["CAUSTIC_BINARY"], "render", run["scenes"][0], "-o", single, *run["chunk_flags"]],
                   check=True, capture_output=True)
    with open(out, "rb") as a, open(single, "rb") as b:
        assert a.read() == b.read()


def test_animation_on_farm_writes_every_frame(scene, addon):
    scene.frame_start, scene.frame_end = 1, 3
    cam = bpy.data.objects["Camera"]
    cam.location.x = 0.0
    cam.keyframe_insert("location", frame=1)
    cam.location.x = 0.4
    cam.keyframe_insert("location", frame=3)
    assert bpy.ops.caustic.render_farm(animation=True) == {"FINISHED"}
    run = farm_module(addon).last_run
    assert [os.path.basename(p) for p in run["outputs"]] == [f"caustic_farm_{f:05d}.exr" for f in (1, 2, 3)]
    data = [open(p, "rb").read() for p in run["outputs"]]
    assert len(set(data)) == 3  # the camera moved: three different frames


def test_missing_farm_python_is_a_clear_error(scene, addon, monkeypatch):
    monkeypatch.delenv("CAUSTIC_FARM_PYTHON")
    with pytest.raises(RuntimeError, match="Farm's Python|farm's Python"):
        bpy.ops.caustic.render_farm(animation=False)


def test_a_shadow_catcher_on_the_farm_equals_the_local_render(scene, addon, tmp_path):
    """Chunks carry the shadow catcher's sums, so a frame with a catcher renders on the farm as
    locally, to the bit."""
    bpy.data.objects["Floor"].is_shadow_catcher = True
    local = scenes.render_rgb(scene, "CAUSTIC", 3, str(tmp_path / "local.exr"))
    scene.caustic.use_farm = True
    on_farm = scenes.render_rgb(scene, "CAUSTIC", 3, str(tmp_path / "farm.exr"))
    assert (on_farm == local).all(), abs(on_farm - local).max()


def test_f12_on_the_farm_equals_the_local_render(scene, addon, tmp_path, capfd):
    # "Render on Farm" on: F12 runs the frame as sample chunks on the farm and loads the merged
    # frame into the Render Result, which then equals the local F12 render to the bit (the
    # chunks merge exactly). The time limit has no meaning on the farm: a warning says so.
    local = scenes.render_rgb(scene, "CAUSTIC", 3, str(tmp_path / "local.exr"))
    scene.caustic.use_farm = True
    scene.caustic.time_limit = 100.0
    capfd.readouterr()
    on_farm = scenes.render_rgb(scene, "CAUSTIC", 3, str(tmp_path / "farm.exr"))
    out, err = capfd.readouterr()
    assert "time limit is not used" in out + err, (out + err)[-2000:]
    assert on_farm.shape == local.shape == (H, W, 3)
    assert (on_farm == local).all(), abs(on_farm - local).max()


def test_f12_on_the_farm_without_its_python_is_an_error(scene, addon, monkeypatch):
    monkeypatch.delenv("CAUSTIC_FARM_PYTHON")
    scene.caustic.use_farm = True
    with pytest.raises(RuntimeError, match="farm's Python"):
        bpy.ops.render.render()


def test_f12_on_the_farm_cancels_with_a_partial_image(scene, addon, tmp_path, monkeypatch):
    # Esc during a farm F12 (the engine's break check turns true after 4 s): the farm stops
    # every renderer, merges what they had into the Render Result, and leaves no process.
    import time

    import psutil

    scene.caustic.use_farm = True
    scene.caustic.samples = 1_000_000
    engine_cls = sys.modules[f"{addon.__name__}.engine"].CausticRenderEngine
    t0 = time.monotonic()
    monkeypatch.setattr(engine_cls, "should_stop", lambda self: time.monotonic() - t0 > 4.0)
    pixels = scenes.render_rgb(scene, "CAUSTIC", 0, str(tmp_path / "cancelled.exr"))
    assert time.monotonic() - t0 < 90.0
    assert pixels.mean() > 0.0  # the samples rendered before the cancel
    leftovers = [p for p in psutil.Process().children(recursive=True) if p.is_running()]
    assert not leftovers, leftovers


def test_farm_job_cancels_with_partial_frames(scene, addon):
    # The operators' job, polled as the modal operator polls it: cancel after the farm has
    # started; the frame holds the samples rendered so far, the run reports code 5 and no
    # process is left.
    import time

    import psutil

    scene.caustic.samples = 1_000_000
    farm = farm_module(addon)
    reports = []
    job = farm.FarmJob(bpy.context, False, lambda kind, text: reports.append(text))
    t0 = time.monotonic()
    written = None
    while written is None and time.monotonic() - t0 < 120.0:
        if time.monotonic() - t0 > 4.0:
            job.cancel()
        written = job.poll()
        time.sleep(0.1)
    assert written and os.path.isfile(written[0]), reports
    assert farm.last_run["code"] == 5
    assert any("cancelled" in r for r in reports), reports
    assert not [p for p in psutil.Process().children(recursive=True) if p.is_running()]


def test_the_farm_operator_writes_the_view_layers_passes(scene, addon, tmp_path):
    """The operator's frames carry what F12 would ask for: a light pass, a light group and a
    shader AOV, merged from chunks exactly as a single render of the same scene with them."""
    layer = bpy.context.view_layer
    layer.use_pass_diffuse_direct = True
    layer.lightgroups.add(name="keygroup")
    bpy.data.objects["Key"].lightgroup = "keygroup"
    layer.aovs.add().name = "tint"
    assert bpy.ops.caustic.render_farm(animation=False) == {"FINISHED"}
    run = farm_module(addon).last_run
    assert run["code"] == 0
    with open(run["outputs"][0], "rb") as f:
        farm_bytes = f.read()
    header = farm_bytes[:4096]
    for channel in (b"Diffuse Direct.R", b"Combined_keygroup.R", b"tint.R"):
        assert channel in header, (channel, header[:600])
    single = str(tmp_path / "single.exr")
    assert run["chunk_flags"][:2] == ["--passes", "diffuse_direct,light_groups,shader_aovs"], run["chunk_flags"]
    subprocess.run([os.environ["CAUSTIC_BINARY"], "render", run["scenes"][0], "-o", single, *run["chunk_flags"]],
                   check=True, capture_output=True)
    with open(single, "rb") as b:
        assert farm_bytes == b.read()
