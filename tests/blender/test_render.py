"""Headless renders with the real binary: result filled, cancel, errors, border, animation."""

import subprocess
import sys

import bpy
import numpy as np
import pytest

import scenes

pytestmark = pytest.mark.needs_binary

W, H = 32, 24


@pytest.fixture
def scene(empty_scene, tmp_path):
    s = empty_scene
    scenes.small_render_settings(s, W, H, samples=4)
    scenes.plane_and_cube_scene(s)
    scenes.light(s, "Key", "AREA", location=(0.5, -0.5, 3.0), shape="RECTANGLE", size=1.5,
                 size_y=1.0, energy=200.0)
    s.render.filepath = str(tmp_path / "out.exr")
    return s


def module(addon, name):
    return sys.modules[f"{addon.__name__}.{name}"]


def test_headless_render_fills_result_and_writes_file(scene):
    bpy.ops.render.render(write_still=True)
    img = scenes.load_pixels(scene.render.filepath)
    assert img.shape == (H, W, 4)
    assert np.isfinite(img).all()
    rgb = img[..., :3]
    assert rgb.mean() > 1e-3, "the render is black"
    assert (img[..., 3] > 0.99).mean() > 0.9  # the floor covers (almost) the whole frame


def test_render_result_has_the_passes(scene):
    from exr_io import read_exr
    layer = scene.view_layers[0]
    layer.use_pass_z = layer.use_pass_normal = layer.cycles.denoising_store_passes = True
    scene.render.image_settings.media_type = "MULTI_LAYER_IMAGE"
    scene.render.image_settings.exr_codec = "ZIP"
    bpy.ops.render.render(write_still=True)
    ch = read_exr(scene.render.filepath)
    depth = ch["ViewLayer.Depth.Z"]
    camera = bpy.data.objects["Camera"]
    # Planar depth of the floor (z = 0) at the image centre: camera height / cos(tilt).
    centre = depth[H // 2 - 1:H // 2 + 1, W // 2 - 1:W // 2 + 1].mean()
    assert 0.5 * camera.location.z < centre < 3 * camera.location.z
    nz = ch["ViewLayer.Normal.Z"]
    assert np.median(nz) == pytest.approx(1.0, abs=1e-3)  # the floor faces Blender's +Z
    assert np.median(ch["ViewLayer.Denoising Albedo.R"]) == pytest.approx(0.5, abs=0.05)


def test_cancel_after_first_progress_line(scene, addon, monkeypatch):
    engine = module(addon, "engine")
    runner = module(addon, "runner")
    scene.caustic.samples = 100000  # long enough to need a cancel
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
    assert process.returncode in (5, 6), process.returncode
    if process.returncode == 5:  # a partial image came back
        img = scenes.load_pixels(scene.render.filepath)
        assert img.shape == (H, W, 4)
        assert img[..., :3].mean() > 0

    monkeypatch.undo()  # Blender continues: the next render works
    scene.caustic.samples = 2
    scene.render.filepath = scene.render.filepath.replace("out.exr", "after.exr")
    bpy.ops.render.render(write_still=True)
    assert scenes.load_pixels(scene.render.filepath)[..., :3].mean() > 0


def test_missing_binary_reports_an_error(scene, monkeypatch, capfd):
    monkeypatch.setenv("CAUSTIC_BINARY", "/nonexistent/caustic")
    with pytest.raises(RuntimeError, match="Caustic binary not found"):
        bpy.ops.render.render(write_still=True)
    assert "Traceback" not in capfd.readouterr().err


def test_broken_scene_reports_the_binarys_message(empty_scene, tmp_path, capfd):
    """A scene the renderer refuses (here: absurd settings, two billion photons, whose maps the
    memory budget refuses before allocating; a camera and a light alone no longer serve, since
    they render as Cycles renders them): the binary's JSON error message, not a generic exit
    code, reaches the operator's report."""
    scenes.small_render_settings(empty_scene, W, H, samples=1)
    scenes.camera(empty_scene, (0, -3, 5), (30, 0, 0))
    scenes.light(empty_scene, "Sun", "SUN", energy=1.0)
    scenes.plane(empty_scene, "Floor", 4.0)
    empty_scene.caustic.integrator = "photon"
    empty_scene.caustic.photons = 2_000_000_000
    empty_scene.render.filepath = str(tmp_path / "out.exr")
    with pytest.raises(RuntimeError) as err:
        bpy.ops.render.render(write_still=True)
    message = str(err.value)
    assert message.startswith("Error: Caustic: ")
    assert "not enough memory: photon maps" in message, message
    assert "exit code" not in message  # the binary's own words, not the add-on's fallback
    assert "Traceback" not in capfd.readouterr().err


@pytest.mark.parametrize("crop", [True, False])
def test_border_render(scene, tmp_path, crop):
    full_path = str(tmp_path / "full.exr")
    scene.render.filepath = full_path
    bpy.ops.render.render(write_still=True)
    full = scenes.load_pixels(full_path)

    r = scene.render
    r.use_border, r.use_crop_to_border = True, crop
    r.border_min_x, r.border_max_x = 0.25, 0.75
    r.border_min_y, r.border_max_y = 0.5, 1.0
    r.filepath = str(tmp_path / "border.exr")
    bpy.ops.render.render(write_still=True)
    img = scenes.load_pixels(r.filepath)
    xmin, xmax, ymin, ymax = W // 4, 3 * W // 4, H // 2, H
    window = img if crop else img[ymin:ymax, xmin:xmax]
    assert img.shape[:2] == ((ymax - ymin, xmax - xmin) if crop else (H, W))
    if not crop:
        outside = img.copy()
        outside[ymin:ymax, xmin:xmax] = 0
        assert np.all(outside == 0)
    # Same region of the same scene: the means agree within the 4-spp noise.
    expected = full[ymin:ymax, xmin:xmax, :3].mean()
    assert window[..., :3].mean() == pytest.approx(expected, rel=0.25)
    assert window[..., :3].mean() > 0


def test_two_frame_animation(scene, tmp_path):
    box = bpy.data.objects["Box"]
    for frame, x in ((1, -1.0), (2, 1.0)):
        box.location.x = x
        box.keyframe_insert("location", frame=frame)
    scene.frame_start, scene.frame_end = 1, 2
    scene.render.filepath = str(tmp_path / "frame_")
    bpy.ops.render.render(animation=True)
    first = scenes.load_pixels(str(tmp_path / "frame_0001.exr"))
    second = scenes.load_pixels(str(tmp_path / "frame_0002.exr"))
    assert first.shape == second.shape == (H, W, 4)
    assert first[..., :3].mean() > 0 and second[..., :3].mean() > 0
    # The box moved from the left half to the right half: the images differ where it is.
    left = np.s_[:, : W // 2, :3]
    right = np.s_[:, W // 2:, :3]
    assert abs(first[left].mean() - second[left].mean()) + abs(first[right].mean() - second[right].mean()) > 0.01
