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


def test_added_objects_and_mesh_edits_reload_before_a_load(vp, empty_scene, updates):
    """Without an exported scene (nothing loaded yet) there is nothing to merge objects into
    (test_viewport_objects.py has the merges)."""
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


def test_the_render_border_in_camera_view_is_a_part_of_the_camera_frame(vp, empty_scene):
    """Looking through the camera, the scene's render border (fractions of the camera frame)
    becomes the protocol's border (fractions of the region): with the camera's own projection
    the frame fills the region; zoomed out by half, the frame is the region's middle half."""
    viewport, _ = vp
    scenes.small_render_settings(empty_scene, W, H)  # the camera frame's aspect is the render's
    cam = scenes.camera(empty_scene, (1, -5, 2), (75, 0, 10), lens=40.0)
    _settle()
    dg = bpy.context.evaluated_depsgraph_get()
    corners = [cam.matrix_world @ c for c in cam.data.view_frame(scene=empty_scene)]
    view = cam.matrix_world.inverted()
    proj = cam.calc_matrix_camera(dg, x=W, y=H)
    frame = viewport.camera_frame_in_region(corners, proj @ view, W, H)
    assert frame == pytest.approx((0.0, 0.0, W, H), abs=1e-3)
    border = (0.25, 0.5, 0.75, 1.0)  # Blender's: x0, y0, x1, y1 from the bottom left
    assert viewport.camera_view_border(frame, border, W, H) == pytest.approx((0.25, 0.0, 0.75, 0.5), abs=1e-5)
    zoom = mathutils.Matrix.Diagonal((0.5, 0.5, 1.0, 1.0))
    frame = viewport.camera_frame_in_region(corners, zoom @ proj @ view, W, H)
    assert frame == pytest.approx((W / 4, H / 4, 3 * W / 4, 3 * H / 4), abs=1e-3)
    assert viewport.camera_view_border(frame, border, W, H) == pytest.approx((0.375, 0.25, 0.625, 0.5), abs=1e-5)
    # A border wholly outside the region clips nothing.
    assert viewport.camera_view_border((W, H, 2 * W, 2 * H), (0.5, 0.5, 1.0, 1.0), W, H) is None


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
    # 8-bit frames: sRGB-encoded colour (188 is the encoding of 0.5 linear), linear alpha.
    bytes8 = bytes([0, 255, 188, 128] * w + [7, 0, 0, 255] * w)
    px8 = client.frame_pixels(dict(header, format="u8"), bytes8)
    mid = ((188 / 255 + 0.055) / 1.055) ** 2.4  # 0.5029: 0.5 encodes to 187.52, rounded up
    assert px8[1, 0].tolist() == pytest.approx([0.0, 1.0, mid, 128 / 255], rel=1e-6)
    assert px8[0, 0].tolist() == pytest.approx([7 / 255 / 12.92, 0.0, 0.0, 1.0], abs=1e-6)
    with pytest.raises(client.ServerError):
        client.frame_pixels(dict(header, format="rgb9"), payload)
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


@pytest.mark.needs_binary
def test_a_late_end_of_the_killed_server_is_not_its_successors_reply(vp, monkeypatch):
    """The killed server's reader may see the end of its pipe only after the successor has
    started (CI saw this once: 'the viewport server ended while handling hello'). Its end must
    stay with the dead process, not answer the successor's next request."""
    import threading

    _, client_mod = vp
    real_read = client_mod.read_message
    late = threading.Event()
    dead_streams = []

    def read_message(stream):
        msg = real_read(stream)
        if msg is None and stream in dead_streams:
            late.wait(timeout=30)
        return msg

    monkeypatch.setattr(client_mod, "read_message", read_message)
    c = client_mod.ServerClient(os.environ["CAUSTIC_BINARY"], threads=1)
    try:
        c.request({"type": "settings", "spp": 4, "frame_format": "f32"})
        first = c.process
        dead_streams.append(first.stdout)
        os.kill(first.pid, signal.SIGKILL)
        first.wait()
        assert c.ensure_running()
        # Now the dead reader reports its end, after the successor answered hello and the
        # replayed settings; the next request must get the successor's own reply.
        late.set()
        threading.Event().wait(0.5)  # the dead reader's put follows its read at once
        c.request({"type": "settings", "spp": 8})
        assert c.alive() and c.restarts == 1
    finally:
        late.set()
        c.stop()


class _Engine:
    """What viewport.Viewport uses of the RenderEngine: reports (recorded) and redraws."""

    def __init__(self):
        self.reports = []

    def report(self, kind, message):
        self.reports.append((kind, message))

    def tag_redraw(self):
        pass


def _apply_live(v, change):
    """Run `change()` with the viewport `v` hearing every depsgraph update (as view_update does);
    returns the types of the requests it sent."""
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
        change()
        _settle()
    finally:
        bpy.app.handlers.depsgraph_update_post.remove(handler)
    return sent


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

        def move():
            box.location.x += 0.5

        sent = _apply_live(v, move)
        assert "transform" in sent and "load" not in sent, sent
        assert v.folder == first_folder, "a move exported the scene again"
        v.client.wait_frame(v.client.generation)
        assert not [r for r in engine.reports if r[0] == {"ERROR"}], engine.reports
    finally:
        v.free()
    assert v.client is None and v.folder is None


def _light_scene(scene, kind):
    """A box on a floor under one light of `kind`, seen by the scene camera."""
    scenes.small_render_settings(scene, W, H, samples=4)
    scenes.camera(scene, (0, -4, 3), (55, 0, 0))
    scenes.cube(scene, "Box", 1.0, (0, 0, 0.5), material=scenes.diffuse_material("Paint", 0.6))
    scenes.plane(scene, "Floor", 6.0, material=scenes.diffuse_material("Grey", 0.5))
    energy = {"POINT": 300.0, "SPOT": 600.0, "SUN": 3.0, "AREA": 200.0}[kind]
    lamp = scenes.light(scene, "Lamp", kind, location=(0.5, -0.5, 3.0), rotation_deg=(10, 0, 0), energy=energy)
    if kind == "AREA":
        lamp.data.size = 0.5
    if kind == "SPOT":
        lamp.data.spot_size = math.radians(70)
    return lamp


def _converged(v):
    """The pixels of the viewport server's converged frame (the scene camera's view)."""
    server_client = sys.modules[type(v).__module__.rsplit(".", 1)[0] + ".server_client"]
    header, payload = v.client.wait_frame(v.client.generation, timeout=120, final=True)
    return server_client.frame_pixels(header, payload)


def _edited_and_fresh(viewport, change):
    """The converged frame after `change()` is sent as edits to a running viewport, against
    a second viewport that exports the changed scene from scratch; and the requests sent."""
    engine = _Engine()
    v = viewport.Viewport(engine)
    try:
        v.update(bpy.context, bpy.context.evaluated_depsgraph_get())
        _converged(v)
        sent = _apply_live(v, change)
        edited = _converged(v)
        assert not [r for r in engine.reports if r[0] == {"ERROR"}], engine.reports
    finally:
        v.free()
    fresh_view = viewport.Viewport(_Engine())
    try:
        fresh_view.update(bpy.context, bpy.context.evaluated_depsgraph_get())
        fresh = _converged(fresh_view)
    finally:
        fresh_view.free()
    return edited, fresh, sent


def _assert_same_render(edited, fresh):
    """The same samples of the same scene: the edit's emission differs from the loader's own
    conversion by float rounding only (a ratio of powers against the exporter's chain of
    products: a few ulps, ~1e-6 relative) and the light's matrix alike, so almost every pixel
    agrees to 1e-4 relative and the mean to 1e-4 — far below what any edit changes (tens of
    percent here). A shadow ray grazing the box's edge may part differently after such a
    rounding and change its pixel by a sample's share, so 1 % of the pixels are let off."""
    assert edited.shape == fresh.shape
    a, b = edited[..., :3], fresh[..., :3]
    assert float(a.mean()) == pytest.approx(float(b.mean()), rel=1e-4)
    close = np.abs(a - b) <= 1e-4 * np.maximum(np.abs(b), 1e-3 * float(b.mean()))
    assert close.mean() >= 0.99, f"{(~close).sum()} of {close.size} values differ"


@pytest.mark.needs_binary
@pytest.mark.parametrize("kind", ["POINT", "SPOT", "SUN", "AREA"])
def test_light_edits_render_as_a_fresh_export(vp, empty_scene, kind):
    """A light's power, colour and placement changed in the viewport are light edits (no
    export), and the frame they give is the frame of the changed scene exported anew."""
    viewport, _ = vp
    lamp = _light_scene(empty_scene, kind)

    def change():
        lamp.data.energy *= 2.5
        lamp.data.color = (1.0, 0.6, 0.3)
        lamp.location = (-0.4, -0.2, 2.6)
        lamp.rotation_euler = (math.radians(-15), math.radians(10), 0)

    edited, fresh, sent = _edited_and_fresh(viewport, change)
    assert "light" in sent and "load" not in sent, sent
    _assert_same_render(edited, fresh)


@pytest.mark.needs_binary
def test_world_edits_render_as_a_fresh_export(vp, empty_scene):
    """A Background's colour and strength changed in the viewport are a world edit (no export)
    giving the frame of the changed scene exported anew; a new node in the world reloads."""
    viewport, _ = vp
    _light_scene(empty_scene, "SUN")
    world = bpy.data.worlds.new("Sky")
    world.use_nodes = True
    empty_scene.world = world
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.2, 0.3, 0.5, 1.0)
    bg.inputs["Strength"].default_value = 1.0

    def change():
        bg.inputs["Color"].default_value = (0.6, 0.4, 0.1, 1.0)
        bg.inputs["Strength"].default_value = 1.7

    edited, fresh, sent = _edited_and_fresh(viewport, change)
    assert "world" in sent and "load" not in sent, sent
    _assert_same_render(edited, fresh)


def test_light_changes_beyond_emission_and_placement_reload(vp, empty_scene, updates):
    """A light's shape (here its radius and, for an area light, its size) is not in a light
    edit: the scene is reloaded; a shared light data, too."""
    viewport, _ = vp
    lamp = _light_scene(empty_scene, "POINT")
    _settle()
    names = viewport.rendered_objects(bpy.context.evaluated_depsgraph_get())
    lights_mod = sys.modules[viewport.__name__ + "_lights"]
    state = lights_mod.LightState(empty_scene, [{"name": "Lamp", "kind": "point", "emission": [1.0, 1.0, 1.0]}])
    updates.clear()
    lamp.data.energy = 50.0
    _settle()
    edits = viewport.edits_from_updates(updates, names, names, {}, state)
    assert [e["type"] for e in edits] == ["light"], edits
    assert edits[0]["emission"] == pytest.approx([50.0 / 300.0] * 3)
    # The light's matrix in glTF axes: Blender (x, y, z) is glTF (x, z, -y).
    assert edits[0]["matrix"][12:15] == pytest.approx([0.5, 3.0, 0.5])
    updates.clear()
    lamp.data.shadow_soft_size = 0.7
    _settle()
    assert viewport.edits_from_updates(updates, names, names, {}, state) == [viewport.RELOAD]
    # Without a light state (nothing loaded yet), any light change reloads.
    assert viewport.edits_from_updates(updates, names, names, {}, None) == [viewport.RELOAD]
    # Cycles' Max Bounces of the light, which the exporter writes, is not in an edit either.
    state = lights_mod.LightState(empty_scene, [{"name": "Lamp", "kind": "point", "emission": [1.0, 1.0, 1.0]}])
    updates.clear()
    lamp.data.cycles.max_bounces = 2
    # A Python-defined property set from a script tags nothing; the panel's edit does.
    lamp.data.update_tag()
    _settle()
    assert viewport.edits_from_updates(updates, names, names, {}, state) == [viewport.RELOAD]


def test_render_settings_changes_reload(vp, empty_scene):
    """The Light Paths, Film and Caustic panels' settings travel with the loaded scene, not in
    an edit: the view reloads when any of them changes (before, a running view kept its bounce
    limits and samples until some object change reloaded it); the resolution, which the view
    sets itself, does not count."""
    viewport, _ = vp
    key = viewport.scene_settings_key(empty_scene)
    empty_scene.render.resolution_x += 10
    assert viewport.scene_settings_key(empty_scene) == key
    for setting, value in [("diffuse_bounces", 1), ("sample_clamp_indirect", 2.5), ("blur_glossy", 0.0)]:
        before = getattr(empty_scene.cycles, setting)
        setattr(empty_scene.cycles, setting, value)
        assert viewport.scene_settings_key(empty_scene) != key, setting
        setattr(empty_scene.cycles, setting, before)
        assert viewport.scene_settings_key(empty_scene) == key, setting
    empty_scene.caustic.samples += 1
    assert viewport.scene_settings_key(empty_scene) != key


def test_world_settings_beyond_its_colour_reload(vp, empty_scene):
    """The world's Max Bounces and Ray Visibility, which the exporter writes, are not in a
    world edit: changing either reloads; its Background colour stays an edit."""
    viewport, _ = vp
    world = bpy.data.worlds.new("Sky")
    world.use_nodes = True
    empty_scene.world = world
    lights_mod = sys.modules[viewport.__name__ + "_lights"]
    state = lights_mod.LightState(empty_scene, [])
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 2.0
    assert lights_mod.world_request(world, state)["type"] == "world"
    world.cycles.max_bounces = 3
    assert lights_mod.world_request(world, state) == lights_mod.RELOAD
    world.cycles.max_bounces = 1024
    world.cycles_visibility.camera = False
    assert lights_mod.world_request(world, state) == lights_mod.RELOAD


def test_hiding_and_showing_are_visibility_edits(vp, empty_scene, updates):
    """A mesh object of the exported scene hidden and shown again: visibility edits (shown
    with its matrix now); a mesh edited while hidden is exported alone when shown; a new object
    is merged and a deleted one hidden (test_viewport_objects.py)."""
    viewport, _ = vp
    scenes.cube(empty_scene, "Box", 1.0, (0, 0, 0))
    scenes.cube(empty_scene, "Other", 1.0, (3, 0, 0))
    _settle()
    exported = viewport.rendered_objects(bpy.context.evaluated_depsgraph_get())
    updates.clear()
    box = bpy.data.objects["Box"]
    box.hide_viewport = True
    _settle()
    hidden = viewport.rendered_objects(bpy.context.evaluated_depsgraph_get())
    assert hidden == exported - {"Box"}
    prints = {}
    edits = viewport.edits_from_updates(updates, exported, hidden, {}, None, exported, prints)
    assert {"type": "visibility", "name": "Box", "visible": False} in edits, edits
    updates.clear()
    box.hide_viewport = False
    box.location.x = 0.5
    _settle()
    edits = viewport.edits_from_updates(updates, hidden, exported, {}, None, exported, prints)
    assert {"type": "visibility", "name": "Box", "visible": True} in edits, edits
    moves = [e for e in edits if e["type"] == "transform" and e["name"] == "Box"]
    assert len(moves) == 1 and moves[0]["matrix"][12] == pytest.approx(0.5)
    # A mesh edited while hidden is exported again when shown: alone (merged), or with the
    # scene when nothing can be merged.
    prints = {}
    assert viewport.visibility_edits(exported, hidden, exported, None, prints) != [viewport.RELOAD]
    box.data.vertices[0].co.z += 0.25
    saved = dict(prints)
    assert viewport.visibility_edits(hidden, exported, exported, None, prints) == [viewport.RELOAD]
    merge = set()
    assert viewport.visibility_edits(hidden, exported, exported, None, saved, merge) == []
    assert merge == {"Box"}
    # Without the exported set (nothing loaded): reload.
    assert viewport.edits_from_updates([], exported, hidden, {}, None, None) == [viewport.RELOAD]


@pytest.mark.needs_binary
def test_a_hidden_object_renders_as_a_fresh_export_without_it(vp, empty_scene):
    """Hiding an object in a running viewport sends a visibility edit (no export), and the
    frame is that of the scene exported anew without it."""
    viewport, _ = vp
    _light_scene(empty_scene, "SUN")
    box = bpy.data.objects["Box"]

    def change():
        box.hide_viewport = True

    edited, fresh, sent = _edited_and_fresh(viewport, change)
    assert "visibility" in sent and "load" not in sent, sent
    _assert_same_render(edited, fresh)
