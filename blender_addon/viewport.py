"""The Rendered viewport through `caustic serve` (docs/protocol.md).

`view_update` turns the depsgraph's updates into requests (`edits_from_updates`): an object's
move is a transform edit, a Principled BSDF's factors a material edit, a node-graph material's
changed graph a `material_graph` edit (its graph alone exported again, viewport_graphs.py), a
light's power, colour or placement a light edit and a Background's colour or strength a world edit
(viewport_lights.py); a mesh object added or its mesh changed (edit mode, modifiers, an
armature's pose) is exported alone by the final render's exporter and merged into the running
scene (`objects`), a deleted one hidden; anything else (lights or other objects added or
deleted, a graph edit the server refuses (a new image, a new medium), a light's shape)
re-exports the scene and loads it. `view_draw` sends the region's view as a camera edit when it
changed, and draws the newest frame through the view's colour management. The
server is one process per viewport, started lazily, restarted (with a report) when it died,
and stopped when Blender frees the engine.
"""

import json
import shutil
import tempfile

import bpy
import mathutils

from . import export, runner, viewport_graphs, viewport_lights
from .errors import CausticError
from .export.object_filter import foreign_meshes, mergeable
from .export.points import point_owners
from .server_client import ServerClient, ServerError, frame_pixels

# Blender's world axes (Z up) to glTF's (Y up), as the glTF exporter converts them.
AXES = mathutils.Matrix(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, 0), (0, 0, 0, 1)))

RELOAD = "reload"
# The request `edits_from_updates` asks for objects to export alone and merge: {"type": OBJECTS,
# "names": [...]}; `Viewport.update` exports them and sends the server's `objects` request.
OBJECTS = "objects"
# Object types that render nothing themselves but deform meshes (whose own updates carry it).
DEFORMERS = ("ARMATURE", "LATTICE")


def _flat(m):
    """A 4×4 matrix as 16 floats, column-major (glTF's and the protocol's order)."""
    return [float(m[r][c]) for c in range(4) for r in range(4)]


def object_matrix(matrix_world):
    """A mesh object's world matrix in glTF axes: its vertices were converted too."""
    return _flat(AXES @ matrix_world @ AXES.inverted())


def camera_request(view_matrix, window_matrix, perspective, resolution, clip, border=None):
    """The camera edit for a view: the view matrix (world → view, Blender axes) and the
    projection matrix Blender draws the region with, so the frame shows what the region shows.

    A perspective projection has P[1][1] = 1 / tan(yfov / 2), P[0][0] / P[1][1] = 1 / aspect,
    and P[0][2], P[1][2] = the frame centre's offset in half-frames, so the lens shift in
    frames is half of it. An orthographic one has P[0][0] = 1 / xmag, P[1][1] = 1 / ymag and
    the offset, negated, in P[0][3], P[1][3].
    """
    p = window_matrix
    header = {
        "type": "camera",
        "matrix": _flat(AXES @ view_matrix.inverted()),
        "resolution": [int(resolution[0]), int(resolution[1])],
        "clip": [float(clip[0]), float(clip[1])],
    }
    if perspective:
        import math

        header.update(projection="perspective", yfov=2.0 * math.atan(1.0 / p[1][1]),
                      aspect=float(p[1][1] / p[0][0]), shift=[float(p[0][2]) / 2.0, float(p[1][2]) / 2.0])
    else:
        header.update(projection="orthographic", xmag=float(1.0 / p[0][0]), ymag=float(1.0 / p[1][1]),
                      shift=[-float(p[0][3]) / 2.0, -float(p[1][3]) / 2.0])
    if border is not None:
        header["border"] = [float(v) for v in border]
    return header


def _principled(material):
    """The material's Principled BSDF when it feeds the output directly with no input linked
    that a material edit carries; else None (the exporter may make a node graph of it)."""
    tree = material.node_tree
    if tree is None:
        return None
    out = next((n for n in tree.nodes if n.type == "OUTPUT_MATERIAL" and n.is_active_output), None)
    if out is None or not out.inputs["Surface"].is_linked:
        return None
    node = out.inputs["Surface"].links[0].from_node
    if node.type != "BSDF_PRINCIPLED":
        return None
    if any(node.inputs[n].is_linked for n in EDITABLE_INPUTS):
        return None
    return node


EDITABLE_INPUTS = ("Base Color", "Metallic", "Roughness", "IOR", "Transmission Weight", "Alpha")


def _value(socket):
    return viewport_lights.rounded(getattr(socket, "default_value", None))


def material_snapshot(material):
    """What a material edit does not carry: every other input of the material's nodes and its
    links. A change there (emission, coat, sheen, a new node) needs the exporter."""
    tree = material.node_tree
    if tree is None:
        return None
    nodes = tuple(sorted(
        (n.name, n.type, tuple((i.identifier, _value(i)) for i in n.inputs
                               if not (n.type == "BSDF_PRINCIPLED" and i.name in EDITABLE_INPUTS)))
        for n in tree.nodes))
    links = tuple(sorted((l.from_node.name, l.from_socket.identifier, l.to_node.name, l.to_socket.identifier)
                         for l in tree.links))
    return nodes, links


def material_request(material, known=None):
    """The material edit for a Blender material, or RELOAD when its factors are not plain or
    anything else in it changed since `known` (name → `material_snapshot` at the last export)."""
    node = _principled(material)
    if node is None:
        return RELOAD
    if known is not None and known.get(material.name) != material_snapshot(material):
        return RELOAD
    inp = node.inputs
    color = list(inp["Base Color"].default_value)
    color[3] = float(inp["Alpha"].default_value)
    clamp = lambda v: min(max(float(v), 0.0), 1.0)  # noqa: E731 (the exporter clamps alike)
    return {
        "type": "material",
        "name": material.name,
        "base_color": [clamp(c) for c in color],
        "metallic": clamp(inp["Metallic"].default_value),
        "roughness": clamp(inp["Roughness"].default_value),
        "ior": max(float(inp["IOR"].default_value), 0.0),
        "transmission": clamp(inp["Transmission Weight"].default_value),
    }


def mesh_fingerprint(obj):
    """The object's mesh data and modifier stack, compared when a hidden object is shown: an
    edit made while it was hidden (no rendered object, so no update reaches the viewport)
    needs the exporter."""
    import numpy as np

    mesh = obj.data
    co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    mods = tuple((m.name, m.type, m.show_render, m.show_viewport) for m in obj.modifiers)
    return len(mesh.vertices), len(mesh.polygons), hash(co.tobytes()), mods


def visibility_edits(objects_before, objects_now, exported, lights, fingerprints=None, merge=None):
    """Requests for objects hidden or shown since the last update, or [RELOAD]: a mesh object
    of the exported scene is hidden or shown in place (`visibility`, with its matrix now when
    shown), a light by its emission (0 while hidden; a light the camera sees is reloaded, as its
    shape would stay). With a `merge` set, a new mesh object (`mergeable`), or one whose mesh
    changed while hidden, is added to it (to be exported alone and merged), and a deleted one is
    hidden and leaves `exported` (its name, taken again, is a new object); without, or for any
    other kind, the exporter reloads. `fingerprints` (name → `mesh_fingerprint` when hidden) is
    updated."""
    added, removed = objects_now - objects_before, objects_before - objects_now
    if exported is None or (merge is None and not added <= exported):
        return [RELOAD]
    fingerprints = {} if fingerprints is None else fingerprints
    edits = []
    for name, visible in [(n, False) for n in sorted(removed)] + [(n, True) for n in sorted(added)]:
        obj = bpy.data.objects.get(name)
        if obj is None and merge is not None:
            # Deleted: hidden for good (the server refuses a name it holds no mesh of: reload).
            edits.append({"type": "visibility", "name": name, "visible": False})
            exported.discard(name)
            fingerprints.pop(name, None)
            continue
        if obj is None:
            return [RELOAD]  # deleted: a new object could take its name
        if visible and name not in exported:
            if not mergeable(obj):
                return [RELOAD]
            merge.add(name)
            continue
        if obj.type == "MESH":
            if not visible:
                fingerprints[name] = mesh_fingerprint(obj)
            elif fingerprints.pop(name, None) != mesh_fingerprint(obj):
                if merge is None or not mergeable(obj):
                    return [RELOAD]
                merge.add(name)
                continue
            edits.append({"type": "visibility", "name": name, "visible": visible})
            if visible:
                edits.append({"type": "transform", "name": name, "matrix": object_matrix(obj.matrix_world)})
        elif obj.type == "LIGHT" and lights is not None and not obj.visible_camera:
            req = viewport_lights.light_request(obj, lights)
            if req == RELOAD:
                return [RELOAD]
            if not visible:
                req["emission"] = [0.0, 0.0, 0.0]
            edits.append(req)
        else:
            return [RELOAD]
    return edits


def edits_from_updates(updates, objects_before, objects_now, known=None, lights=None, exported=None,
                       fingerprints=None, graphs=None):
    """Requests for one depsgraph update: a list of headers, or [RELOAD] when the scene must be
    exported again (objects other than meshes added, a material that is not a plain Principled
    BSDF or changed beyond its factors, a light or world changed beyond what their edits carry:
    viewport_lights.py). Mesh objects added or whose mesh changed come first as one OBJECTS
    request naming them (exported alone, they carry their matrix: no other edit of theirs is
    sent). `objects_*` are the sets of rendered object names, `known` the materials' snapshots
    at the last export, `lights` its `LightState` (None: every light and world change reloads),
    `exported` the objects it exported (None: nothing is merged, hiding reloads; deleted objects
    leave it), `fingerprints` the meshes of hidden objects (visibility_edits), `graphs` the
    materials the server loaded as node graphs (name -> viewport_graphs.graph_extras at the
    export): a change of theirs is a MATERIAL_GRAPH request naming them, which `Viewport.update`
    exports."""
    edits = []
    merge = set() if exported is not None else None
    new_materials = []
    toggled = objects_before ^ objects_now
    if toggled:
        edits = visibility_edits(objects_before, objects_now, exported, lights, fingerprints, merge)
        if edits == [RELOAD]:
            return edits

    def add(req):
        # One edit per light or object: the last state wins (a light's data and object both update).
        key = (req["type"], req.get("name"))
        edits[:] = [e for e in edits if (e["type"], e.get("name")) != key] + [req]

    for u in updates:
        data = getattr(u.id, "original", u.id)
        if isinstance(data, bpy.types.Object) and data.type == "LIGHT":
            if u.is_updated_transform or u.is_updated_geometry or u.is_updated_shading:
                req = viewport_lights.light_request(data, lights) if lights else RELOAD
                if req == RELOAD:
                    return [RELOAD]
                add(req)
        elif isinstance(data, bpy.types.Object) and data.name in toggled:
            continue  # hidden or shown: its visibility edit says it (shown: with its matrix)
        elif isinstance(data, bpy.types.Object):
            if u.is_updated_geometry and data.type in DEFORMERS and not u.is_updated_transform:
                continue  # a pose or a lattice edit: the objects it deforms update on their own
            if u.is_updated_geometry and data.type != "CAMERA":
                # Edit mode, a modifier, an armature's pose: the object's evaluated mesh changed.
                if merge is None or data.name not in objects_now or not mergeable(data):
                    return [RELOAD]
                merge.add(data.name)
            if u.is_updated_transform:
                if data.type == "MESH":
                    add({"type": "transform", "name": data.name, "matrix": object_matrix(data.matrix_world)})
                elif data.type != "CAMERA":  # cameras: the view is sent by view_draw
                    return [RELOAD]
        elif isinstance(data, bpy.types.Material):
            if graphs is not None and data.name in graphs:
                if graphs[data.name] != viewport_graphs.graph_extras(data):
                    return [RELOAD]  # the medium or subsurface beside the graph changed
                add({"type": viewport_graphs.MATERIAL_GRAPH, "name": data.name})
                continue
            if merge is not None and known is not None and data.name not in known:
                new_materials.append(data)  # not in the scene yet: exported with its objects
                continue
            req = material_request(data, known)
            if req == RELOAD:
                return [RELOAD]
            add(req)
        elif isinstance(data, bpy.types.Light):
            users = [o for o in (bpy.data.objects.get(n) for n in (lights.lights if lights else ()))
                     if o is not None and o.data == data]
            if not users:
                return [RELOAD]
            for obj in users:
                req = viewport_lights.light_request(obj, lights)
                if req == RELOAD:
                    return [RELOAD]
                add(req)
        elif isinstance(data, bpy.types.World):
            req = viewport_lights.world_request(data, lights) if lights else RELOAD
            if req == RELOAD:
                return [RELOAD]
            add(req)
        elif isinstance(data, (bpy.types.Mesh, bpy.types.Curve)):
            # A shown object's mesh is evaluated again: its fingerprint said whether it changed.
            shown = any(getattr(bpy.data.objects.get(n), "data", None) == data for n in toggled)
            if u.is_updated_geometry and not shown:
                users = [o for o in (bpy.data.objects.get(n) for n in objects_now) if o is not None and o.data == data]
                if merge is None or not all(mergeable(o) for o in users):
                    return [RELOAD]
                merge.update(o.name for o in users)
    for mat in new_materials:
        users = {o.name for o in (bpy.data.objects.get(n) for n in objects_now) if o is not None
                 and any(slot.material == mat for slot in getattr(o, "material_slots", ()))}
        if not users <= merge:
            return [RELOAD]  # a new material on an object that is not exported again
    if merge:
        # Exported alone, the objects carry their matrix and visibility: their other edits go.
        edits = [{"type": OBJECTS, "names": sorted(merge)}] + [e for e in edits if e.get("name") not in merge]
    return edits


def touches_points(updates, objects_before, objects_now, owners):
    """Whether an update moves, changes, hides or shows an object whose point clouds the running
    scene holds (`owners`): their points come only with a whole export."""
    if owners and objects_before is not None and (objects_before ^ objects_now) & owners:
        return True
    for u in updates if owners else ():
        data = getattr(u.id, "original", u.id)
        if isinstance(data, bpy.types.Object) and data.name in owners \
                and (u.is_updated_transform or u.is_updated_geometry):
            return True
    return False


def rendered_objects(depsgraph):
    """Names of the objects the depsgraph renders."""
    return {inst.object.name for inst in depsgraph.object_instances}


def scene_settings_key(scene):
    """The render settings a running view was loaded with, as one string: the Caustic panel's
    and Cycles' Light Paths and Film settings the export writes (not the resolution, which is
    the view's own). A change of any reloads, as Cycles restarts its viewport render: the
    loaded scene carries them, and no edit does."""
    return json.dumps(export.render_settings(scene, (1, 1), None, viewport=True), sort_keys=True)


def view_settings(scene):
    """The settings request of the viewport: the scene's, with SPPM (no progressive frames)
    shown by Jensen's photon mapping, which the panel's photon counts also drive."""
    props = scene.caustic
    integrator = "photon" if props.integrator == "sppm" else props.integrator
    return {"type": "settings", "integrator": integrator, "spp": int(props.samples), "frame_format": "f16"}


def camera_frame_in_region(corners, perspective_matrix, region_width, region_height):
    """The camera frame's rectangle in region pixels (x0, y0, x1, y1, bottom-left origin) from
    its corners in world space and the region's perspective matrix (window · view), as
    `view3d_utils.location_3d_to_region_2d` projects points."""
    xs, ys = [], []
    for c in corners:
        p = perspective_matrix @ mathutils.Vector((c[0], c[1], c[2], 1.0))
        w = p[3] if abs(p[3]) > 1e-12 else 1e-12
        xs.append((p[0] / w + 1.0) * 0.5 * region_width)
        ys.append((p[1] / w + 1.0) * 0.5 * region_height)
    return min(xs), min(ys), max(xs), max(ys)


def camera_view_border(frame, border, region_width, region_height):
    """The protocol's border (fractions of the region, top-left origin) for the scene's render
    border (fractions of the camera frame, bottom-left origin) when the region shows the camera
    frame at `frame` (camera_frame_in_region); None when it falls outside the region (nothing to
    clip: the whole region renders)."""
    fx0, fy0, fx1, fy1 = frame
    bx0, by0, bx1, by1 = border
    x0, x1 = fx0 + bx0 * (fx1 - fx0), fx0 + bx1 * (fx1 - fx0)
    y0, y1 = fy0 + by0 * (fy1 - fy0), fy0 + by1 * (fy1 - fy0)
    clamp = lambda v: min(max(v, 0.0), 1.0)  # noqa: E731
    rx0, rx1 = clamp(x0 / region_width), clamp(x1 / region_width)
    ry0, ry1 = clamp(1.0 - y1 / region_height), clamp(1.0 - y0 / region_height)
    if not (rx0 < rx1 and ry0 < ry1):
        return None
    return rx0, ry0, rx1, ry1


def draw_rect(header, region_width, region_height):
    """Where a frame goes in the region: x, y (bottom-left) and size in region pixels. The frame
    covers its window of the full frame, which spans the region (a reduced frame too)."""
    w, h = header["resolution"]
    x0, y0, x1, y1 = header["window"]
    sx, sy = region_width / w, region_height / h
    return x0 * sx, (h - y1) * sy, (x1 - x0) * sx, (y1 - y0) * sy


class Viewport:
    """The render server of one viewport engine instance."""

    def __init__(self, engine):
        self.engine = engine
        self.client = None
        self.folder = None
        self.objects = None
        self.settings_key = None  # scene_settings_key at the last export
        self.last_camera = None
        self.texture = None
        self.texture_generation = None
        self.texture_key = None
        self.known = None
        self.lights = None
        self.exported = None
        self.point_owners = set()  # objects whose point clouds the loaded scene holds
        self.fingerprints = {}
        self.graphs = None  # node-graph materials of the loaded scene: name -> graph_extras
        self.images = {}  # the last export's node-graph images: pointer -> entry
        self.graph_warnings = set()  # warnings of graph edits reported so far

    def _client(self):
        if self.client is None:
            self.client = ServerClient(runner.find_binary())
        note = self.client.ensure_running()
        if note:
            self.engine.report({"WARNING"}, note)
        return self.client

    def _reload(self, depsgraph):
        """Export the scene as F12 does and load it."""
        scene = depsgraph.scene
        settings = export.render_settings(scene, (scene.render.resolution_x, scene.render.resolution_y), None, viewport=True)
        old, self.folder = self.folder, tempfile.mkdtemp(prefix="caustic-view-")
        path, state = export.export_scene(depsgraph, self.folder, settings, motion=False, viewport=True)
        self.settings_key = scene_settings_key(scene)
        self.known = {m.name: material_snapshot(m) for m in bpy.data.materials}
        for warning in state.warnings:
            self.engine.report({"WARNING"}, f"Caustic: {warning}")
        client = self._client()
        client.request(view_settings(scene))
        loaded = client.request({"type": "load", "path": path})
        self.lights = viewport_lights.LightState(scene, loaded.get("lights", []))
        self.images = state.image_entries()
        self.graphs = {m["name"]: viewport_graphs.graph_extras(bpy.data.materials[m["name"]])
                       for m in loaded.get("materials", [])
                       if m.get("nodes") and m["name"] in bpy.data.materials}
        self.exported = rendered_objects(depsgraph)
        self.point_owners = point_owners(depsgraph)
        self.fingerprints = {}
        if old:
            shutil.rmtree(old, ignore_errors=True)

    def _merge(self, depsgraph, names):
        """Export the objects `names` alone, as F12 exports them, and merge them into the
        running scene (`objects`): added ones join it, changed ones replace their old selves."""
        scene = depsgraph.scene
        settings = export.render_settings(scene, (scene.render.resolution_x, scene.render.resolution_y), None, viewport=True)
        folder = tempfile.mkdtemp(prefix="objects-", dir=self.folder)
        try:
            path, state = export.export_scene(depsgraph, folder, settings, motion=False, viewport=True,
                                              only=set(names))
            clash = foreign_meshes(path, names, self.exported)
            if clash:
                raise CausticError(f"the export of {sorted(names)} holds instances named as other objects "
                                   f"({', '.join(clash)}): exporting the scene")
            for warning in state.warnings:
                self.engine.report({"WARNING"}, f"Caustic: {warning}")
            reply = self._client().request({"type": "objects", "path": path})
        finally:
            # The server has read every file of the export by its reply.
            shutil.rmtree(folder, ignore_errors=True)
        self.exported |= set(names)
        for obj in (bpy.data.objects.get(n) for n in names):
            for slot in getattr(obj, "material_slots", ()):
                if slot.material is not None:
                    self.known[slot.material.name] = material_snapshot(slot.material)
        if 2 * reply.get("retired_triangles", 0) > reply.get("triangles", 0):
            # The meshes replaced so far (kept, collapsed, by the server) outweigh the live scene:
            # a reload gives their memory back, so a session of mesh edits stays within twice the
            # scene's size at the cost of one export per scene's worth of edited triangles.
            self._reload(depsgraph)

    def _graph_edit(self, depsgraph, name):
        """Export material `name`'s graph alone and have the server compile it in place."""
        material = bpy.data.materials.get(name)
        if material is None:
            raise viewport_graphs.GraphRefused(f"material '{name}' is gone")
        header, warnings = viewport_graphs.graph_request(material, depsgraph, self.images)
        reply = self._client().request(header)
        # Once each: a drag sends the same graph's warnings on every step.
        for warning in warnings + reply.get("warnings", []):
            if warning not in self.graph_warnings:
                self.graph_warnings.add(warning)
                self.engine.report({"WARNING"}, f"Caustic: {warning}")

    def update(self, context, depsgraph):
        """view_update: the depsgraph's changes as edits, or a reload."""
        try:
            objects = rendered_objects(depsgraph)
            first = self.objects is None or self.client is None or not self.client.alive()
            first = first or touches_points(depsgraph.updates, self.objects, objects, self.point_owners)
            first = first or scene_settings_key(depsgraph.scene) != self.settings_key
            edits = [RELOAD] if first else edits_from_updates(depsgraph.updates, self.objects, objects, self.known,
                                                                      self.lights, self.exported, self.fingerprints,
                                                                      self.graphs)
            self.objects = objects
            if edits == [RELOAD]:
                self._reload(depsgraph)
                self._client().request({"type": "render_start"})
                return
            for req in edits:
                try:
                    if req["type"] == OBJECTS:
                        self._merge(depsgraph, req["names"])
                        continue
                    if req["type"] == viewport_graphs.MATERIAL_GRAPH:
                        self._graph_edit(depsgraph, req["name"])
                        continue
                    self._client().request(req)
                    if req["type"] == "material":
                        mat = bpy.data.materials.get(req["name"])
                        if mat is not None:
                            self.known[req["name"]] = material_snapshot(mat)
                except (ServerError, CausticError):
                    # The server refused it (a graph needing a new image, a mirrored object,
                    # objects it cannot merge) or their export failed: reload.
                    self._reload(depsgraph)
                    break
        except (CausticError, ServerError) as err:
            self.engine.report({"ERROR"}, f"Caustic viewport: {err}")

    def draw(self, context, depsgraph):
        """view_draw: send the view if it moved, draw the newest frame, redraw while rendering."""
        region, rv3d = context.region, context.region_data
        if self.client is None:
            return
        try:
            border = None
            v3d = context.space_data
            scene = depsgraph.scene
            if rv3d.view_perspective == "CAMERA":
                # Looking through the camera, the scene's render border (a part of the camera's
                # frame) is the part rendered, as Cycles does.
                camera = scene.camera
                if scene.render.use_border and camera is not None:
                    corners = [camera.matrix_world @ c for c in camera.data.view_frame(scene=scene)]
                    frame = camera_frame_in_region(corners, rv3d.perspective_matrix, region.width, region.height)
                    border = camera_view_border(frame, (scene.render.border_min_x, scene.render.border_min_y,
                                                        scene.render.border_max_x, scene.render.border_max_y),
                                                region.width, region.height)
            elif getattr(v3d, "use_render_border", False):
                # Blender's border has its origin bottom-left; the protocol's top-left.
                border = (v3d.render_border_min_x, 1.0 - v3d.render_border_max_y,
                          v3d.render_border_max_x, 1.0 - v3d.render_border_min_y)
            cam = camera_request(rv3d.view_matrix, rv3d.window_matrix, rv3d.is_perspective,
                                 (region.width, region.height), (v3d.clip_start, v3d.clip_end), border)
            client = self._client()
            if cam != self.last_camera:
                client.request(cam)
                self.last_camera = cam
            frame = client.latest_frame
            if client.render_error:
                self.engine.report({"ERROR"}, f"Caustic viewport: {client.render_error}")
                client.render_error = None
        except (CausticError, ServerError) as err:
            self.engine.report({"ERROR"}, f"Caustic viewport: {err}")
            return
        if frame is not None:
            self._draw_frame(depsgraph.scene, frame, region.width, region.height)
        if client.done is None or client.done["generation"] < client.generation:
            self.engine.tag_redraw()

    def _draw_frame(self, scene, frame, region_width, region_height):
        import gpu
        from gpu_extras.presets import draw_texture_2d

        header, payload = frame
        exposure = export.film_exposure(scene)
        key = (header["generation"], header["samples"], header["width"], header["height"], exposure)
        if key != self.texture_key:
            px = frame_pixels(header, payload)
            px[..., :3] *= exposure  # the Film panel's Exposure, as F12 applies it (result.load)
            buf = gpu.types.Buffer("FLOAT", px.size, px.ravel())
            self.texture = gpu.types.GPUTexture((header["width"], header["height"]), format="RGBA16F", data=buf)
            self.texture_key = key
        x, y, w, h = draw_rect(header, region_width, region_height)
        gpu.state.blend_set("ALPHA_PREMULT")
        # As Blender's own example engine: the display space shader applies the view's colour
        # management (view transform, look, exposure) to the texture drawn while it is bound.
        self.engine.bind_display_space_shader(scene)
        draw_texture_2d(self.texture, (x, y), w, h)
        self.engine.unbind_display_space_shader()
        gpu.state.blend_set("NONE")

    def free(self):
        """Stop the server and remove the exported scene."""
        if self.client is not None:
            self.client.stop()
            self.client = None
        if self.folder:
            shutil.rmtree(self.folder, ignore_errors=True)
            self.folder = None

