"""The Rendered viewport's add-on side (viewport.py, server_client.py) with real bpy.

* The depsgraph-to-edit conversion: a scene is built in bpy, an object moved, a material's
  colour changed, an object added, and the requests `edits_from_updates` makes from the
  depsgraph's real updates (collected in `depsgraph_update_post`) are checked.
* The region's view to a camera edit: a scene camera's own view and projection matrices
  (`calc_matrix_camera`) must give the camera the exporter writes for it.
* A server killed mid-frame is restarted by the client class the viewport uses, which brings
  it back to its scene, view and rendering state.
* Drawing: headless bpy has no GPU context (`gpu` cannot create a texture or bind a shader
  without a window), so `view_draw` itself cannot run here. What it draws is tested instead:
  the frame → pixel-buffer conversion (half floats decoded, rows flipped to Blender's
  bottom-first order) and where a frame of a window or a reduced frame goes in the region.
"""

import math
import os
import signal
import struct
import sys
import types

import bpy
import mathutils
import numpy as np
import pytest

import scenes

W, H = 48, 32


@pytest.fixture
def vp(addon):
    """The add-on's viewport and client modules."""
    pkg = addon.__name__
    return sys.modules[f"{pkg}.viewport"], sys.modules[f"{pkg}.server_client"]


@pytest.fixture
def updates():
    """The depsgraph's updates after each evaluation, copied while the handler runs (the
    update structs die with it), with their ids as the original datablocks."""
    got = []

    def collect(scene, depsgraph):
        got.extend(types.SimpleNamespace(id=u.id.original, is_updated_transform=u.is_updated_transform,
                                         is_updated_geometry=u.is_updated_geometry,
                                         is_updated_shading=u.is_updated_shading)
                   for u in depsgraph.updates)

    bpy.app.handlers.depsgraph_update_post.append(collect)
    yield got
    bpy.app.handlers.depsgraph_update_post.remove(collect)


def _settle():
    bpy.context.evaluated_depsgraph_get().update()


def test_moving_an_object_is_a_transform_edit_in_gltf_axes(vp, empty_scene, updates):
    viewport, _ = vp
    cube = scenes.cube(empty_scene, "Box", 1.0, (0, 0, 0))
    _settle()
    before = viewport.rendered_objects(bpy.context.evaluated_depsgraph_get())
    updates.clear()
    cube.location = (1.0, 2.0, 3.0)
    _settle()
    edits = viewport.edits_from_updates(updates, before, before)
    assert edits and all(e["type"] == "transform" for e in edits), edits
    m = edits[-1]["matrix"]
    # Column-major: the translation is the last column; Blender (x, y, z) is glTF (x, z, -y).
    assert m[12:15] == pytest.approx([1.0, 3.0, -2.0])
    assert edits[-1]["name"] == "Box"


def test_a_principled_colour_change_is_a_material_edit(vp, empty_scene, updates):
    viewport, _ = vp
    mat = scenes.diffuse_material("Paint", 0.5)
    scenes.cube(empty_scene, "Box", 1.0, (0, 0, 0), material=mat)
    _settle()
    names = viewport.rendered_objects(bpy.context.evaluated_depsgraph_get())
    known = {mat.name: viewport.material_snapshot(mat)}
    updates.clear()
    bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    bsdf.inputs["Base Color"].default_value = (0.9, 0.1, 0.2, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.25
    _settle()
    edits = viewport.edits_from_updates(updates, names, names, known)
    mats = [e for e in edits if e["type"] == "material"]
    assert mats and mats[-1]["name"] == "Paint", edits
    assert mats[-1]["base_color"] == pytest.approx([0.9, 0.1, 0.2, 1.0])
    assert mats[-1]["roughness"] == pytest.approx(0.25)
    assert not any(e["type"] == "transform" for e in edits), "a colour change is not a move"
    # Emission is not in a material edit: turning it up needs the exporter.
    bsdf.inputs["Emission Strength"].default_value = 3.0
    assert viewport.material_request(mat, known) == viewport.RELOAD
    bsdf.inputs["Emission Strength"].default_value = 0.0
    assert viewport.material_request(mat, known)["type"] == "material"
    # A texture linked into Base Color makes the material a graph: the scene is reloaded.
    tex = mat.node_tree.nodes.new("ShaderNodeTexChecker")
    mat.node_tree.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    assert viewport.material_request(mat) == viewport.RELOAD


def test_added_objects_and_mesh_edits_reload(vp, empty_scene, updates):
    viewport, _ = vp
    scenes.cube(empty_scene, "Box", 1.0, (0, 0, 0))
    _settle()
    dg = bpy.context.evaluated_depsgraph_get()
    before = viewport.rendered_objects(dg)
    scenes.cube(empty_scene, "Other", 1.0, (3, 0, 0))
    _settle()
    after = viewport.rendered_objects(bpy.context.evaluated_depsgraph_get())
    assert viewport.edits_from_updates(updates, before, after) == [viewport.RELOAD]
    updates.clear()
    mesh = bpy.data.objects["Box"].data
    mesh.vertices[0].co.x += 0.5
    mesh.update()
    _settle()
    assert viewport.edits_from_updates(updates, after, after) == [viewport.RELOAD]


def test_a_cameras_view_gives_the_camera_the_exporter_writes(vp, empty_scene):
    viewport, _ = vp
    cam = scenes.camera(empty_scene, (1, -5, 2), (75, 0, 10), lens=40.0)
    cam.data.shift_x, cam.data.shift_y = 0.1, -0.05
    _settle()
    dg = bpy.context.evaluated_depsgraph_get()
    proj = cam.calc_matrix_camera(dg, x=W, y=H)
    req = viewport.camera_request(cam.matrix_world.inverted(), proj, True, (W, H), (0.1, 100.0))
    # Blender's vertical field of view for a horizontal sensor fit: 2 atan(h/w · 18 / lens).
    yfov = 2.0 * math.atan(H / W * cam.data.sensor_width / 2.0 / cam.data.lens)
    assert req["yfov"] == pytest.approx(yfov, rel=1e-5)
    assert req["aspect"] == pytest.approx(W / H, rel=1e-5)
    # Shift is in units of the larger side: x is a fraction of the width already, y of the
    # height after multiplying by the aspect ratio.
    assert req["shift"] == pytest.approx([0.1, -0.05 * W / H], rel=1e-4)
    m = mathutils.Matrix([req["matrix"][c::4] for c in range(4)])
    assert list(m.translation) == pytest.approx([1.0, 2.0, 5.0])  # glTF (x, z, -y)
    forward = m.to_3x3() @ mathutils.Vector((0, 0, -1))
    blender_forward = cam.matrix_world.to_3x3() @ mathutils.Vector((0, 0, -1))
    assert list(forward) == pytest.approx([blender_forward.x, blender_forward.z, -blender_forward.y], abs=1e-6)


def test_frames_become_bottom_first_float_pixels(vp):
    viewport, client = vp
    w, h = 3, 2
    # Top row red, bottom row green, as half floats.
    rows = [[(1.0, 0.0, 0.0, 1.0)] * w, [(0.0, 1.0, 0.0, 0.5)] * w]
    payload = b"".join(struct.pack("<4e", *p) for row in rows for p in row)
    header = {"type": "frame", "format": "f16", "width": w, "height": h,
              "resolution": [w * 4, h * 4], "window": [4, 0, 7, 2]}
    px = client.frame_pixels(header, payload)
    assert px.shape == (h, w, 4) and px.dtype == np.float32
    assert px[0, 0].tolist() == [0.0, 1.0, 0.0, 0.5]  # Blender's first row is the bottom one
    assert px[1, 2].tolist() == [1.0, 0.0, 0.0, 1.0]
    with pytest.raises(client.ServerError):
        client.frame_pixels(header, payload[:-2])
    # The window's top rows of the full frame are drawn at the region's top.
    x, y, dw, dh = viewport.draw_rect(header, 120, 80)
    assert (x, y, dw, dh) == pytest.approx((40.0, 60.0, 30.0, 20.0))


@pytest.mark.needs_binary
def test_a_server_killed_mid_frame_is_restarted_with_its_state(vp):
    _, client_mod = vp
    scene = os.path.join(os.path.dirname(__file__), "..", "..", "scenes", "cornell_box.gltf")
    c = client_mod.ServerClient(os.environ["CAUSTIC_BINARY"], threads=2)
    try:
        c.request({"type": "settings", "spp": 64, "frame_format": "f32"})
        c.request({"type": "load", "path": os.path.abspath(scene)})
        gen = c.request({"type": "render_start"})["generation"]
        c.wait_frame(gen)
        first = c.process
        os.kill(first.pid, signal.SIGKILL)
        first.wait()
        assert not c.alive()
        note = c.ensure_running()
        assert note and "restarted" in note and str(-signal.SIGKILL) in note
        assert c.alive() and c.process is not first and c.restarts == 1
        # Brought back to rendering the same scene: frames of the replayed generation arrive,
        # at 64 spp as the replayed settings say.
        header, payload = c.wait_frame(c.generation)
        assert header["target"] == 64 and header["format"] == "f32"
        assert len(payload) == header["width"] * header["height"] * 16
    finally:
        c.stop()
    assert c.process is None


class _Engine:
    """What viewport.Viewport uses of the RenderEngine: reports (recorded) and redraws."""

    def __init__(self):
        self.reports = []

    def report(self, kind, message):
        self.reports.append((kind, message))

    def tag_redraw(self):
        pass


@pytest.mark.needs_binary
def test_view_update_exports_once_then_sends_edits(vp, empty_scene):
    """The first view_update exports and loads the scene and starts rendering; a move made
    afterwards (seen by a depsgraph handler, as view_update sees it) is a transform edit that
    the server accepts, with no second export."""
    viewport, _ = vp
    scenes.small_render_settings(empty_scene, W, H, samples=2)
    scenes.camera(empty_scene, (0, -4, 3), (60, 0, 0))
    box = scenes.cube(empty_scene, "Box", 1.0, (0, 0, 0.5), material=scenes.diffuse_material("Paint", 0.5))
    scenes.plane(empty_scene, "Floor", 4.0)
    scenes.light(empty_scene, "Sun", "SUN", energy=1.0)
    engine = _Engine()
    v = viewport.Viewport(engine)
    try:
        v.update(bpy.context, bpy.context.evaluated_depsgraph_get())
        assert not [r for r in engine.reports if r[0] == {"ERROR"}], engine.reports
        first_folder = v.folder
        assert first_folder and v.client.alive()
        v.client.wait_frame(v.client.generation)
        sent = []
        request = v.client.request

        def spy(header, payload=b"", replay=True):
            sent.append(header["type"])
            return request(header, payload, replay)

        v.client.request = spy

        def handler(scene, depsgraph):
            v.update(bpy.context, depsgraph)

        bpy.app.handlers.depsgraph_update_post.append(handler)
        try:
            box.location.x += 0.5
            _settle()
        finally:
            bpy.app.handlers.depsgraph_update_post.remove(handler)
        assert "transform" in sent and "load" not in sent, sent
        assert v.folder == first_folder, "a move exported the scene again"
        v.client.wait_frame(v.client.generation)
        assert not [r for r in engine.reports if r[0] == {"ERROR"}], engine.reports
    finally:
        v.free()
    assert v.client is None and v.folder is None
