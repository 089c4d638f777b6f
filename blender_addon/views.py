"""Stereoscopy and multi-view: one image per view, each through the view's own camera.

With Output > Stereoscopy on, Blender expects the render result to hold every view (Stereo 3D:
left and right; Multi-View: one per camera suffix). Blender computes each view's camera as
Cycles reads it: `RenderEngine.camera_model_matrix` (the eye's offset along the camera's X by
half the interocular distance, turned inwards for Toe-in convergence) and
`RenderEngine.camera_shift_x` (Off-Axis convergence shifts the lens instead), once the view is
made active with `active_view_set`. The scene is exported once; each view's glTF is a copy whose
camera node carries the view's offset and shift, rendered into the result's view.

A panoramic camera's spherical stereo (Cycles offsets each ray by the eye's position around the
viewer) is not rendered: those views take the flat offset, with a warning.
"""

import copy
import json

from mathutils import Matrix, Quaternion, Vector

from .export.camera import lens_shift


def active_views(scene):
    """Names of the views to render: every enabled view under Stereoscopy, else one nameless
    view (Blender's single-view result)."""
    render = scene.render
    if not render.use_multiview:
        return [""]
    views = [v.name for v in render.views if v.use]
    if render.views_format == "STEREO_3D":
        views = [v for v in views if v in ("left", "right")]
    return views or [""]


def view_camera(engine, camera, view):
    """(the view's camera offset in the camera's own frame, its Shift X, warnings) for the
    active view `view`."""
    engine.active_view_set(view)
    spherical = bool(engine.use_spherical_stereo(camera))
    warnings = []
    if spherical:
        warnings.append(f"camera '{camera.name}': spherical stereo of a panoramic camera is not rendered; "
                        f"view '{view}' is the camera moved by the eye's offset")
    model = Matrix(engine.camera_model_matrix(camera, use_spherical_stereo=False))
    offset = camera.matrix_world.inverted_safe() @ model
    return offset, float(engine.camera_shift_x(camera, use_spherical_stereo=False)), warnings


def gltf_for_view(gltf_path, out_path, camera, offset, shift_x, resolution, pixel_aspect):
    """Write the glTF at `gltf_path` to `out_path` with `camera`'s node moved by `offset` (a
    matrix in the camera's frame, which is the glTF camera node's frame too: both look down
    their -Z with +Y up) and its CAUSTIC_camera shift given the view's Shift X."""
    with open(gltf_path) as f:
        doc = json.load(f)
    node = _camera_node(doc, camera.name)
    if node is None:
        raise ValueError(f"camera '{camera.name}' is not in the exported scene")
    local = _node_matrix(node) @ offset
    for key in ("translation", "rotation", "scale"):
        node.pop(key, None)
    node["matrix"] = [float(local[r][c]) for c in range(4) for r in range(4)]
    shift = lens_shift(camera.data, shift_x, resolution, pixel_aspect)
    ext = node.setdefault("extensions", {})
    value = copy.deepcopy(ext.get("CAUSTIC_camera", {}))
    if shift is not None:
        value["shift"] = shift
    else:
        value.pop("shift", None)
    if value:
        ext["CAUSTIC_camera"] = value
        used = doc.setdefault("extensionsUsed", [])
        if "CAUSTIC_camera" not in used:
            used.append("CAUSTIC_camera")
    else:
        ext.pop("CAUSTIC_camera", None)
        if not ext:
            node.pop("extensions")
    with open(out_path, "w") as f:
        json.dump(doc, f)


def _camera_node(doc, name):
    """The glTF node of camera object `name` (a node with a camera, by name)."""
    nodes = [n for n in doc.get("nodes", []) if "camera" in n or "CAUSTIC_camera" in n.get("extensions", {})]
    return next((n for n in nodes if n.get("name") == name), nodes[0] if len(nodes) == 1 else None)


def _node_matrix(node):
    """A glTF node's local matrix (its `matrix`, column-major, or its TRS)."""
    if "matrix" in node:
        m = node["matrix"]
        return Matrix([[m[c * 4 + r] for c in range(4)] for r in range(4)])
    t = Vector(node.get("translation", [0.0, 0.0, 0.0]))
    x, y, z, w = node.get("rotation", [0.0, 0.0, 0.0, 1.0])
    s = node.get("scale", [1.0, 1.0, 1.0])
    return Matrix.Translation(t) @ Quaternion((w, x, y, z)).to_matrix().to_4x4() @ Matrix.Diagonal((*s, 1.0))

