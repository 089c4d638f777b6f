"""Material and light preview thumbnails (preview.py) with real bpy.

Headless bpy does not render thumbnails: `bpy.ops.ed.lib_id_generate_preview` finishes without
calling the engine in background mode (checked: the preview stays black with Cycles too). What
Blender would do is done here instead: the engine's preview path gets a depsgraph of a small
preview-like scene (a shaded sphere, a light, a camera) and a stand-in for the RenderEngine's
result calls, and the thumbnail is compared with a final render of the same scene at the same
samples. The engine class is checked to declare previews and to route `is_preview` renders
to the preview server.
"""

import sys

import bpy
import numpy as np
import pytest

import scenes

SIZE = 40


class _Pass:
    def __init__(self):
        self.rect = None


class _Result:
    def __init__(self, w, h):
        self.size = (w, h)
        self.layers = [type("Layer", (), {"passes": {"Combined": _Pass()}})()]


class _PreviewEngine:
    """What preview.py uses of a RenderEngine rendering a thumbnail."""

    camera_override = None
    is_preview = True

    def __init__(self, cancel_after=None):
        self.results, self.ended, self.reports, self.progress = [], [], [], []
        self.breaks = 0
        self.cancel_after = cancel_after

    def test_break(self):
        self.breaks += 1
        return self.cancel_after is not None and self.breaks > self.cancel_after

    def report(self, kind, message):
        self.reports.append((kind, message))

    def update_progress(self, value):
        self.progress.append(value)

    def begin_result(self, x, y, w, h):
        r = _Result(w, h)
        self.results.append(r)
        return r

    def end_result(self, result):
        self.ended.append(result)


def _preview_scene(scene, samples):
    scenes.small_render_settings(scene, SIZE, SIZE, samples=samples)
    mat = bpy.data.materials.new("Preview")
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.8, 0.3, 0.1, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.4
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, location=(0, 0, 1))
    bpy.context.active_object.data.materials.append(mat)
    scenes.plane(scene, "Floor", 8.0, material=scenes.diffuse_material("Grey", 0.5))
    scenes.light(scene, "Key", "AREA", location=(2, -2, 4), rotation_deg=(40, 0, 45), energy=400.0, size=1.0)
    scenes.camera(scene, (0, -5, 2.5), (75, 0, 0), lens=50)


def _preview_module(addon):
    return sys.modules[f"{addon.__name__}.preview"]


def test_the_engine_renders_previews_through_the_preview_server(addon):
    engine = sys.modules[f"{addon.__name__}.engine"].CausticRenderEngine
    assert engine.bl_use_preview is True
    assert isinstance(engine._caustic_previews, _preview_module(addon).PreviewServer)


@pytest.mark.needs_binary
def test_a_thumbnail_is_the_final_render_of_the_preview_scene(addon, empty_scene, tmp_path):
    """The thumbnail equals a final render of the same scene at the preview's samples (the
    served frame is `caustic render`'s image: tests/server.rs), to float rounding of the
    final path's EXR round trip; a second thumbnail reuses the running server."""
    preview = _preview_module(addon)
    _preview_scene(empty_scene, preview.PREVIEW_SAMPLES)
    server = preview.PreviewServer()
    try:
        engine = _PreviewEngine()
        samples = server.render(engine, bpy.context.evaluated_depsgraph_get())
        assert samples == preview.PREVIEW_SAMPLES
        assert len(engine.results) == 1 and engine.ended == engine.results
        thumb = np.asarray(engine.results[0].layers[0].passes["Combined"].rect).reshape(SIZE, SIZE, 4)
        process = server.client.process
        engine2 = _PreviewEngine()
        server.render(engine2, bpy.context.evaluated_depsgraph_get())
        assert server.client.process is process, "the second thumbnail started another server"
    finally:
        server.stop()
    final = scenes.render_rgb(empty_scene, "CAUSTIC", empty_scene.caustic.seed, str(tmp_path / "final.exr"))
    rgb = thumb[..., :3].astype(np.float64)
    assert float(rgb.mean()) > 0.01, "the thumbnail is black"
    assert float(rgb.mean()) == pytest.approx(float(final.mean()), rel=1e-5)
    assert np.abs(rgb - final).max() <= 1e-5 * max(float(final.max()), 1.0)


@pytest.mark.needs_binary
def test_a_cancelled_thumbnail_writes_no_result(addon, empty_scene):
    """Blender cancels a thumbnail the user scrolled past (test_break): no result is begun,
    and the server takes the next one."""
    preview = _preview_module(addon)
    _preview_scene(empty_scene, preview.PREVIEW_SAMPLES)
    server = preview.PreviewServer()
    try:
        engine = _PreviewEngine(cancel_after=1)
        assert server.render(engine, bpy.context.evaluated_depsgraph_get()) == 0
        assert engine.results == []
        assert server.render(_PreviewEngine(), bpy.context.evaluated_depsgraph_get()) == preview.PREVIEW_SAMPLES
    finally:
        server.stop()
