"""The panel's adaptive sampling and denoising: what the export writes, what the binary is
asked, and a real render with both on."""

import sys

import bpy
import numpy as np
import pytest

import scenes

W, H = 32, 24


def module(addon, name):
    return sys.modules[f"{addon.__name__}.{name}"]


@pytest.fixture
def scene(empty_scene, tmp_path):
    s = empty_scene
    scenes.small_render_settings(s, W, H, samples=64)
    scenes.plane_and_cube_scene(s)
    scenes.light(s, "Key", "AREA", location=(0.5, -0.5, 3.0), shape="RECTANGLE", size=1.5,
                 size_y=1.0, energy=200.0)
    s.render.filepath = str(tmp_path / "out.exr")
    return s


def test_adaptive_settings_follow_cycles_automatic_threshold(scene, addon):
    export = module(addon, "export")
    props = scene.caustic
    assert "noise_threshold" not in export.render_settings(scene, (W, H), None)
    props.use_adaptive_sampling = True
    props.adaptive_threshold = 0.0  # Cycles' "automatic": max(0.001, 1 / samples)
    props.adaptive_min_samples = 24
    s = export.render_settings(scene, (W, H), None)
    assert s["noise_threshold"] == pytest.approx(1.0 / 64)
    assert s["min_samples"] == 24
    props.adaptive_threshold = 0.05
    assert export.render_settings(scene, (W, H), None)["noise_threshold"] == pytest.approx(0.05)


def test_denoise_passes_the_library_blender_ships(scene, addon, monkeypatch):
    final, runner = module(addon, "final"), module(addon, "runner")
    monkeypatch.delenv("CAUSTIC_OIDN", raising=False)
    window = final.FrameWindow(scene.render)
    settings = module(addon, "export").render_settings(scene, (W, H), None)
    argv = final.command_line("caustic", "scene.gltf", "out.exr", settings, window, denoise=True)
    assert "--denoise" in argv
    library = runner.find_oidn()
    assert library is not None, "the bpy wheel ships libOpenImageDenoise"
    assert argv[argv.index("--oidn") + 1] == library


@pytest.mark.needs_binary
def test_render_with_adaptive_sampling_and_denoising(scene, monkeypatch):
    monkeypatch.delenv("CAUSTIC_OIDN", raising=False)
    scene.caustic.use_adaptive_sampling = True
    scene.caustic.adaptive_threshold = 0.1
    scene.caustic.adaptive_min_samples = 8
    scene.caustic.use_denoising = True
    bpy.ops.render.render(write_still=True)
    img = scenes.load_pixels(scene.render.filepath)
    assert img.shape == (H, W, 4)
    assert np.isfinite(img).all()
    assert img[..., :3].mean() > 1e-3, "the render is black"


def test_noisy_image_is_declared_with_denoising(scene, addon):
    """With denoising on, the Combined before denoising (which the binary writes as Noisy
    Image) is a pass of the result, as in Cycles; without it, or on the farm (not denoised),
    it is not."""
    result = module(addon, "result")

    class Engine:
        def __init__(self):
            self.names = []

        def register_pass(self, scene, layer, name, channels, chan_id, kind):
            self.names.append(name)

    def declared():
        engine = Engine()
        result.register_passes(engine, scene, scene.view_layers[0])
        return engine.names

    assert "Noisy Image" not in declared()
    scene.caustic.use_denoising = True
    assert "Noisy Image" in declared()
    scene.caustic.use_farm = True
    assert "Noisy Image" not in declared()


def test_simplify_texture_limit_goes_to_the_binary(scene, addon):
    """Simplify's Texture Limit reaches the binary as `texture_limit` (the render one for F12,
    the viewport one for interactive renders, as Cycles takes them), only while Simplify is
    on, and no longer as a warning (the binary shrinks images as Cycles: test_images_agreement)."""
    export = module(addon, "export")
    view_layer = scene.view_layers[0]
    scene.cycles.texture_limit_render = "128"
    scene.cycles.texture_limit = "512"
    settings, warnings = export.layer_render_settings(scene, view_layer, [], (W, H), None)
    assert "texture_limit" not in settings
    scene.render.use_simplify = True
    settings, warnings = export.layer_render_settings(scene, view_layer, [], (W, H), None)
    assert settings["texture_limit"] == 128
    assert not any("Texture Limit" in w for w in warnings), warnings
    assert export.render_settings(scene, (W, H), None, viewport=True)["texture_limit"] == 512
    scene.cycles.texture_limit_render = "OFF"
    assert "texture_limit" not in export.layer_render_settings(scene, view_layer, [], (W, H), None)[0]
