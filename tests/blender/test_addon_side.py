"""The add-on's half of the contract, driven by the contract's stand-in binary (fake_caustic.py).

The stand-in writes pixels that encode their full-frame position, so crop placement, pass
loading and normal axes are checked exactly, independent of the renderer's state. The same
behaviours are then checked against the real binary in test_render.py.
"""

import subprocess

import bpy
import numpy as np
import pytest

import scenes
from exr_io import read_exr

W, H = 20, 16


@pytest.fixture
def scene(empty_scene, fake_binary, tmp_path):
    s = empty_scene
    scenes.small_render_settings(s, W, H, samples=4)
    scenes.camera(s, (0, -4, 3), (60, 0, 0))
    scenes.plane(s, "Floor", 4.0)
    scenes.light(s, "Sun", "SUN", energy=1.0)
    s.render.filepath = str(tmp_path / "out.exr")
    return s


def engine_module(addon):
    import sys
    return sys.modules[addon.__name__ + ".engine"]


def test_passes_are_loaded_by_name_and_normals_are_blender_axes(scene, tmp_path):
    layer = scene.view_layers[0]
    layer.use_pass_z = layer.use_pass_normal = layer.cycles.denoising_store_passes = True
    scene.render.image_settings.media_type = "MULTI_LAYER_IMAGE"
    scene.render.image_settings.exr_codec = "ZIP"
    bpy.ops.render.render(write_still=True)
    ch = read_exr(scene.render.filepath)
    ys, xs = np.mgrid[0:H, 0:W]
    assert np.allclose(ch["ViewLayer.Combined.R"], (xs + 0.5) / W, atol=1e-6)
    assert np.allclose(ch["ViewLayer.Combined.G"], (ys + 0.5) / H, atol=1e-6)  # rows top-down
    assert np.allclose(ch["ViewLayer.Depth.Z"], 3.0)
    assert np.allclose(ch["ViewLayer.Denoising Albedo.G"], 0.5)
    # glTF +Y (up) is Blender's +Z.
    assert np.allclose(ch["ViewLayer.Normal.X"], 0.0)
    assert np.allclose(ch["ViewLayer.Normal.Y"], 0.0)
    assert np.allclose(ch["ViewLayer.Normal.Z"], 1.0)
    # The Denoising Normal in Cycles' camera space (x right, y up, z forward): the camera is
    # tilted 60 degrees from looking down, so the world's up is (0, sin 60, -cos 60) there.
    assert np.allclose(ch["ViewLayer.Denoising Normal.X"], 0.0, atol=1e-6)
    assert np.allclose(ch["ViewLayer.Denoising Normal.Y"], np.sin(np.radians(60)), atol=1e-6)
    assert np.allclose(ch["ViewLayer.Denoising Normal.Z"], -0.5, atol=1e-6)


@pytest.mark.parametrize("crop", [True, False])
def test_border_render_places_the_window(scene, fake_binary, crop):
    import json
    r = scene.render
    r.resolution_percentage = 50
    r.resolution_x, r.resolution_y = 2 * W + 1, 2 * H  # 50 % of an odd width truncates
    r.use_border, r.use_crop_to_border = True, crop
    r.border_min_x, r.border_max_x = 0.13, 0.71
    r.border_min_y, r.border_max_y = 0.2, 0.93
    bpy.ops.render.render(write_still=True)
    xmin, xmax, ymin, ymax = int(0.13 * W), int(0.71 * W), int(0.2 * H), int(0.93 * H)
    argv = json.loads(fake_binary.read_text())
    assert argv[argv.index("--crop") + 1] == f"{xmin},{H - ymax},{xmax},{H - ymin}"
    assert argv[argv.index("--resolution") + 1] == f"{W}x{H}"

    img = scenes.load_pixels(r.filepath)  # rows bottom-up
    if crop:
        assert img.shape[:2] == (ymax - ymin, xmax - xmin)
        window = img
    else:
        assert img.shape[:2] == (H, W)
        window = img[ymin:ymax, xmin:xmax]
        outside = img.copy()
        outside[ymin:ymax, xmin:xmax] = 0
        assert np.all(outside == 0)
    ys, xs = np.mgrid[ymin:ymax, xmin:xmax]
    assert np.allclose(window[..., 0], (xs + 0.5) / W, atol=1e-6)
    assert np.allclose(window[..., 1], (H - ys - 0.5) / H, atol=1e-6)  # top-down y in the EXR


def test_interim_images_are_loaded(scene, addon, monkeypatch):
    import sys
    result_module = sys.modules[addon.__name__ + ".result"]
    loads = []
    real_load = result_module.load
    monkeypatch.setattr(result_module, "load",
                        lambda res, path, exposure=1.0, to_camera=None: (loads.append(path),
                                                                         real_load(res, path, exposure, to_camera)))
    scene.caustic.samples = 40  # the stand-in takes 0.05 s per sample: two interim images
    bpy.ops.render.render(write_still=True)
    assert len(loads) >= 2  # interim(s) + final


def test_cancel_terminates_the_binary_and_keeps_the_partial_image(scene, addon, monkeypatch):
    engine = engine_module(addon)
    runner = __import__(addon.__name__ + ".runner", fromlist=["runner"])
    monkeypatch.setenv("FAKE_CAUSTIC_MODE", "slow")  # renders until SIGTERM
    processes = []

    class RecordingPopen(subprocess.Popen):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            processes.append(self)

    monkeypatch.setattr(runner.subprocess, "Popen", RecordingPopen)

    def should_stop(self):
        session = getattr(self, "_caustic_session", None)
        return bool(session and session.progress_seen)

    monkeypatch.setattr(engine.CausticRenderEngine, "should_stop", should_stop)
    bpy.ops.render.render(write_still=True)
    (process,) = processes
    assert process.returncode == 5  # interrupted, image written
    img = scenes.load_pixels(scene.render.filepath)
    assert img.shape[:2] == (H, W) and img[..., 0].max() > 0

    monkeypatch.undo()  # Blender goes on: a normal render still works
    scene.render.filepath = scene.render.filepath.replace("out.exr", "again.exr")
    bpy.ops.render.render(write_still=True)
    assert scenes.load_pixels(scene.render.filepath).shape[:2] == (H, W)


def test_missing_binary_is_a_readable_report(scene, monkeypatch, capfd):
    monkeypatch.setenv("CAUSTIC_BINARY", "/nonexistent/caustic")
    with pytest.raises(RuntimeError, match=r"Caustic binary not found.*/nonexistent/caustic"):
        bpy.ops.render.render(write_still=True)
    assert "Traceback" not in capfd.readouterr().err


def test_nothing_found_anywhere_is_a_readable_report(scene, monkeypatch, capfd):
    monkeypatch.delenv("CAUSTIC_BINARY")
    monkeypatch.setenv("PATH", "/nonexistent")
    with pytest.raises(RuntimeError, match=r"Caustic binary not found: set its path in Preferences"):
        bpy.ops.render.render(write_still=True)
    assert "Traceback" not in capfd.readouterr().err


@pytest.mark.parametrize("mode, message", [
    ("error", r"Caustic: scene has a mesh with NaN vertices \(fake\)"),
    ("crash", r"Caustic: the renderer stopped unexpectedly \(exit code 101\).*fake panic"),
])
def test_binary_errors_become_reports(scene, monkeypatch, capfd, mode, message):
    monkeypatch.setenv("FAKE_CAUSTIC_MODE", mode)
    with pytest.raises(RuntimeError, match=message):
        bpy.ops.render.render(write_still=True)
    assert "Traceback" not in capfd.readouterr().err


def test_binary_search_order(addon, tmp_path, monkeypatch):
    import os
    import sys
    runner = sys.modules[addon.__name__ + ".runner"]
    prefs = bpy.context.preferences.addons[addon.__name__].preferences
    exe = tmp_path / "caustic"
    exe.write_text("#!/bin/sh\n")
    exe.chmod(0o644)  # as after a zip extraction: find_binary restores the exec bit
    monkeypatch.setenv("CAUSTIC_BINARY", str(exe))
    assert runner.find_binary() == str(exe)
    assert os.access(exe, os.X_OK)

    other = tmp_path / "pref" / "caustic"
    other.parent.mkdir()
    other.write_text("#!/bin/sh\n")
    other.chmod(0o755)
    monkeypatch.delenv("CAUSTIC_BINARY")
    prefs.binary_path = str(other)
    try:
        assert runner.find_binary() == str(other)
        prefs.binary_path = ""
        monkeypatch.setenv("PATH", str(tmp_path))
        assert runner.find_binary() == str(exe)
    finally:
        prefs.binary_path = ""


def test_exporter_failure_is_one_readable_line(scene, monkeypatch):
    """An exception inside Blender's glTF exporter fails the render with one line that names
    its cause, without the exporter's traceback. bpy 5.0.1 ends the operator's message with a
    "Location: .../ops.py:109" line, which the report showed instead of the cause (the
    exporter's failure on a light with Normalize off read "glTF export failed: Location: ...")."""
    from io_scene_gltf2.blender.exp import export as gltf_export

    def broken(context, export_settings):
        raise TypeError("the exporter's own reason")

    monkeypatch.setattr(gltf_export, "save", broken)
    with pytest.raises(RuntimeError) as err:
        bpy.ops.render.render(write_still=True)
    message = str(err.value)
    assert message.startswith("Error: Caustic: glTF export failed: ")
    assert "Traceback" not in message and "\n" not in message.strip()
    assert message.strip().endswith("TypeError: the exporter's own reason"), message
