"""Vertices at NaN or infinite positions (a Geometry Nodes division by zero, a broken import).

Cycles skips every triangle that has such a corner when it builds its BVH (a triangle is valid
only when its three vertices are finite), so the rest of the mesh renders. Blender's glTF
exporter validates each mesh it exports in place (`Mesh.validate`), which moves those vertices to
the object's origin in the mesh itself (checked on bpy 5.0.1), so the triangles would render
stretched to the origin without a word; the warning says the mesh was changed too. The exported vertex carries no trace of where it came from, so the triangles
are found by position: a corner at the origin belongs to a non-finite vertex when no finite
vertex of the mesh sits exactly there. Those triangles are collapsed onto one corner
(zero area, which the renderer drops as it drops every degenerate triangle), with a warning
naming the object. If a finite vertex does sit at the origin the two cannot be told apart and
the warning says the triangles are kept.
"""

import numpy as np

from .gltf_objects import accessor_array

_INDEX_FORMATS = {5121: np.uint8, 5123: np.uint16, 5125: np.uint32}


def scan(depsgraph):
    """Object name -> (vertices at non-finite positions, whether a finite vertex sits exactly at
    the origin) for the evaluated meshes that have any. Run before the export: the exporter
    validates the meshes it reads, which moves such vertices to the origin in place."""
    found = {}
    for obj in depsgraph.objects:
        if obj.type != "MESH":
            continue
        bad, ambiguous = nonfinite_vertices(obj.data)
        if bad:
            found[obj.original.name] = (bad, ambiguous)
    return found


def nonfinite_vertices(mesh):
    """Count of the mesh's vertices whose position is not finite, and whether a finite one sits
    exactly at the origin (where the exporter puts the others)."""
    count = len(getattr(mesh, "vertices", ()))
    if count == 0:
        return 0, False
    co = np.empty(count * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    finite = np.isfinite(co).all(axis=1)
    at_origin = bool(((co == 0.0).all(axis=1) & finite).any())
    return int((~finite).sum()), at_origin


def drop_nonfinite_triangles(gltf2_mesh, blender_object, state):
    """Collapse the triangles whose corners were non-finite in the object's evaluated mesh
    (module doc), as `scan` found them before the export."""
    found = state.nonfinite.get(blender_object.name)
    if gltf2_mesh is None or found is None:
        return
    bad, ambiguous = found
    name = blender_object.name
    if ambiguous:
        state.warnings.append(
            f"object '{name}': {bad} vertices have non-finite (NaN or infinite) positions, which Blender's glTF "
            "exporter writes at the origin; a finite vertex is there too, so their triangles cannot be told "
            "apart and render stretched to the origin (Cycles leaves them out); the exporter has moved them to the "
            "origin in the mesh itself")
        return
    if id(gltf2_mesh) in state.nonfinite_meshes:  # a mesh shared by several objects: collapsed once
        return
    state.nonfinite_meshes.add(id(gltf2_mesh))
    dropped = sum(_collapse_at_origin(prim) for prim in gltf2_mesh.primitives or [])
    state.warnings.append(
        f"object '{name}': {bad} vertices have non-finite (NaN or infinite) positions; the {dropped} triangles "
        "using them are left out, as Cycles leaves them out (Blender's glTF exporter has moved those vertices "
        "to the origin in the mesh itself)")


def _collapse_at_origin(prim):
    """Make every triangle of `prim` with a corner at the origin degenerate; returns how many."""
    position, indices = (prim.attributes or {}).get("POSITION"), prim.indices
    if position is None or indices is None or getattr(prim, "mode", None) not in (None, 4):
        return 0
    pos = accessor_array(position, np.float32, 3)
    idx_type = _INDEX_FORMATS.get(int(indices.component_type))
    if pos is None or idx_type is None:
        return 0
    idx = accessor_array(indices, idx_type, 1)
    if idx is None:
        return 0
    tris = idx.reshape(-1, 3).copy()
    at_origin = (pos == 0.0).all(axis=1)
    hit = at_origin[tris].any(axis=1)
    if not hit.any():
        return 0
    tris[hit] = tris[hit][:, :1]
    from io_scene_gltf2.io.exp.binary_data import BinaryData
    view = indices.buffer_view
    indices.buffer_view = BinaryData(tris.astype(idx_type).tobytes(), bufferViewTarget=view.bufferViewTarget)
    indices.byte_offset = None
    return int(hit.sum())
