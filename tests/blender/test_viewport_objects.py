"""Added objects and changed meshes in the Rendered viewport, with real bpy: the depsgraph's
updates become one `objects` request naming the mesh objects to export alone (not a reload of
the scene), a deleted object is hidden, and in a running viewport the exported objects merged
into the server's scene render as the changed scene exported anew (test_viewport.py's
`_edited_and_fresh`)."""

import bpy
import pytest

import scenes
from test_viewport import _apply_live, _assert_same_render, _Engine, _edited_and_fresh, _light_scene, _settle


@pytest.fixture
def vp(addon):
    """The add-on's viewport module."""
    import sys
    return sys.modules[f"{addon.__name__}.viewport"]


@pytest.fixture
def updates():
    """The depsgraph's updates after each evaluation (as test_viewport.py collects them)."""
    import types
    got = []

    def collect(scene, depsgraph):
        got.extend(types.SimpleNamespace(id=u.id.original, is_updated_transform=u.is_updated_transform,
                                         is_updated_geometry=u.is_updated_geometry,
                                         is_updated_shading=u.is_updated_shading)
                   for u in depsgraph.updates)

    bpy.app.handlers.depsgraph_update_post.append(collect)
    yield got
    bpy.app.handlers.depsgraph_update_post.remove(collect)


def _rendered(vp):
    return vp.rendered_objects(bpy.context.evaluated_depsgraph_get())


def test_an_added_cube_is_an_objects_request(vp, empty_scene, updates):
    """A new mesh object (moved after it was added, as the add operator's redo panel does) is
    one `objects` request naming it, with no transform edit of a name the server lacks."""
    scenes.cube(empty_scene, "Box", 1.0, (0, 0, 0))
    _settle()
    exported = _rendered(vp)
    before = set(exported)
    updates.clear()
    new = scenes.cube(empty_scene, "New", 1.0, (3, 0, 0))
    _settle()
    new.location.x = 4.0
    _settle()
    edits = vp.edits_from_updates(updates, before, _rendered(vp), {}, None, exported)
    assert edits == [{"type": vp.OBJECTS, "names": ["New"]}], edits
    # A light added is not merged: the scene is exported again.
    scenes.light(empty_scene, "Lamp", "POINT")
    _settle()
    assert vp.edits_from_updates([], before, _rendered(vp), {}, None, exported) == [vp.RELOAD]


def test_mesh_edits_and_modifiers_are_objects_requests(vp, empty_scene, updates):
    """A mesh's vertices changed (as edit mode leaves them) or a modifier added: an `objects`
    request for the object (its transform edit dropped: the export carries its matrix)."""
    box = scenes.cube(empty_scene, "Box", 1.0, (0, 0, 0))
    scenes.cube(empty_scene, "Other", 1.0, (3, 0, 0))
    _settle()
    names = _rendered(vp)
    updates.clear()
    box.data.vertices[0].co.z += 0.25
    box.data.update()
    box.location.y = 1.0
    _settle()
    edits = vp.edits_from_updates(updates, names, names, {}, None, set(names))
    assert edits == [{"type": vp.OBJECTS, "names": ["Box"]}], edits
    updates.clear()
    box.modifiers.new("Bevel", "BEVEL")
    _settle()
    edits = vp.edits_from_updates(updates, names, names, {}, None, set(names))
    assert edits == [{"type": vp.OBJECTS, "names": ["Box"]}], edits


def test_an_armature_pose_is_an_objects_request_for_the_deformed_mesh(vp, empty_scene, updates):
    """A bone turned in pose mode: the armature renders nothing, and the mesh it deforms is
    exported alone and merged."""
    box = scenes.cube(empty_scene, "Box", 1.0, (0, 0, 0))
    rig = bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig"))
    empty_scene.collection.objects.link(rig)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    bone = rig.data.edit_bones.new("Bone")
    bone.head, bone.tail = (0, 0, -1), (0, 0, 1)
    bpy.ops.object.mode_set(mode="OBJECT")
    box.modifiers.new("Armature", "ARMATURE").object = rig
    box.vertex_groups.new(name="Bone").add(list(range(len(box.data.vertices))), 1.0, "REPLACE")
    _settle()
    names = _rendered(vp)
    updates.clear()
    rig.pose.bones["Bone"].rotation_mode = "XYZ"
    rig.pose.bones["Bone"].rotation_euler = (0.5, 0.0, 0.0)
    _settle()
    edits = vp.edits_from_updates(updates, names, names, {}, None, set(names))
    assert edits == [{"type": vp.OBJECTS, "names": ["Box"]}], edits


def test_a_deleted_object_is_hidden_and_its_name_is_new_again(vp, empty_scene, updates):
    """Deleting a mesh object is the visibility edit that hides it; the name, taken again by a
    new object, is an added object (merged, replacing the hidden one on the server)."""
    scenes.cube(empty_scene, "Box", 1.0, (0, 0, 0))
    scenes.cube(empty_scene, "Other", 1.0, (3, 0, 0))
    _settle()
    exported = _rendered(vp)
    before = set(exported)
    bpy.data.objects.remove(bpy.data.objects["Other"])
    _settle()
    after = _rendered(vp)
    edits = vp.edits_from_updates([], before, after, {}, None, exported)
    assert edits == [{"type": "visibility", "name": "Other", "visible": False}], edits
    assert "Other" not in exported
    scenes.cube(empty_scene, "Other", 0.5, (-3, 0, 0))
    _settle()
    edits = vp.edits_from_updates([], after, _rendered(vp), {}, None, exported)
    assert edits == [{"type": vp.OBJECTS, "names": ["Other"]}], edits


@pytest.mark.needs_binary
def test_a_cube_added_live_renders_as_a_fresh_export(vp, empty_scene):
    """A cube added to a running viewport is exported alone and merged (`objects`, no `load`),
    and the converged frame is the frame of the scene exported anew with it."""
    _light_scene(empty_scene, "SUN")

    def change():
        scenes.cube(empty_scene, "Added", 0.6, (-1.2, 0.4, 0.3), material=scenes.diffuse_material("Clay", 0.3))

    edited, fresh, sent = _edited_and_fresh(vp, change)
    assert "objects" in sent and "load" not in sent, sent
    _assert_same_render(edited, fresh)


@pytest.mark.needs_binary
def test_an_edited_mesh_renders_as_a_fresh_export(vp, empty_scene):
    """A box whose top is raised in a running viewport replaces the loaded box (`objects`, no
    `load`), and the converged frame is the frame of the scene exported anew."""
    _light_scene(empty_scene, "SUN")
    box = bpy.data.objects["Box"]

    def change():
        for v in box.data.vertices:
            if v.co.z > 0:
                v.co.z += 0.4
        box.data.update()

    edited, fresh, sent = _edited_and_fresh(vp, change)
    assert "objects" in sent and "load" not in sent, sent
    _assert_same_render(edited, fresh)


@pytest.mark.needs_binary
def test_repeated_mesh_edits_reload_once_the_replaced_meshes_outweigh_the_scene(vp, empty_scene):
    """Each edit of the box's mesh leaves the replaced box's triangles with the server; the
    first edit merges (12 of 26 triangles replaced), the second makes the replaced ones the
    larger part (24 of 38) and the viewport reloads the scene to give them back."""
    _light_scene(empty_scene, "SUN")
    box = bpy.data.objects["Box"]

    def raise_top():
        for v in box.data.vertices:
            if v.co.z > 0:
                v.co.z += 0.1
        box.data.update()

    v = vp.Viewport(_Engine())
    try:
        v.update(bpy.context, bpy.context.evaluated_depsgraph_get())
        assert _apply_live(v, raise_top) == ["objects"]
        assert _apply_live(v, raise_top)[:3] == ["objects", "settings", "load"]
    finally:
        v.free()


@pytest.mark.needs_binary
def test_an_edited_child_of_a_turned_parent_renders_as_a_fresh_export(vp, empty_scene):
    """The child of a turned and moved parent, its mesh changed, is exported alone (its parent
    left out of the export): it carries its world matrix, so the merged child sits where the
    fresh export of the whole scene puts it."""
    _light_scene(empty_scene, "SUN")
    parent = scenes.cube(empty_scene, "Parent", 0.4, (0.8, 0.6, 0.2))
    parent.rotation_euler = (0.0, 0.0, 0.5)
    child = scenes.cube(empty_scene, "Child", 0.3, (0.0, 0.0, 0.0), material=scenes.diffuse_material("Clay", 0.3))
    child.parent = parent
    child.location = (0.0, -0.9, 0.4)
    _settle()

    def change():
        for v in child.data.vertices:
            v.co.x *= 1.5
        child.data.update()

    edited, fresh, sent = _edited_and_fresh(vp, change)
    assert "objects" in sent and "load" not in sent, sent
    _assert_same_render(edited, fresh)


def test_instances_named_as_loaded_objects_are_not_merged(vp, tmp_path):
    """An export whose extra mesh nodes (an object's instances) bear the name of an object the
    server holds is caught before it is merged, so that the viewport exports the scene instead."""
    import json
    import sys
    object_filter = sys.modules[vp.__name__.rsplit(".", 1)[0] + ".export.object_filter"]
    path = tmp_path / "objects.gltf"
    path.write_text(json.dumps({"nodes": [{"name": "Scatter", "mesh": 0}, {"name": "Rock", "mesh": 1},
                                          {"name": "Pebble", "mesh": 1}, {"name": "Empty"}]}))
    assert object_filter.foreign_meshes(str(path), {"Scatter"}, {"Rock", "Ground", "Empty"}) == ["Rock"]
    assert object_filter.foreign_meshes(str(path), {"Scatter", "Rock"}, {"Rock"}) == []


@pytest.mark.needs_binary
def test_a_merge_the_server_refuses_reloads(vp, empty_scene):
    """Objects the server cannot merge (a scene with light linking, whose collections the server
    holds by node number) make the viewport export the scene anew instead, with no error shown."""
    _light_scene(empty_scene, "SUN")
    receivers = bpy.data.collections.new("Lit")
    receivers.objects.link(bpy.data.objects["Box"])
    bpy.data.objects["Lamp"].light_linking.receiver_collection = receivers
    engine = _Engine()
    v = vp.Viewport(engine)
    try:
        v.update(bpy.context, bpy.context.evaluated_depsgraph_get())
        v.client.wait_frame(v.client.generation)
        sent = _apply_live(v, lambda: scenes.cube(empty_scene, "Late", 0.5, (1.5, 0, 0.25)))
        assert sent.index("objects") < sent.index("load"), sent
        v.client.wait_frame(v.client.generation)
        assert not [r for r in engine.reports if r[0] == {"ERROR"}], engine.reports
    finally:
        v.free()
