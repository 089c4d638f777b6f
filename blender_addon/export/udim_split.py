"""UDIM tiles: the exporter's per-tile split of a mesh, undone for a node graph material.

io_scene_gltf2 5.0.21 exports a material whose textures are UDIM images (all on one UV map) by
splitting the mesh into one primitive per tile, with a copy of the material named
"<material>.<tile>" and that UV map moved into the tile's 0–1 square (`primitive_extract.py`).
When the material goes as its node graph, the graph's Image Texture nodes hold every tile
(`tiles`) and pick one from the UV, as Cycles does: on the moved UVs every primitive read the
first tile (corpus 33_udim.blend). `restore_tile_uvs` moves the UV map back.

The split puts a triangle in the tile of its first corner and leaves out a triangle whose first
corner lies in no tile (a UV slightly below 0, as unwraps often have at the edges: corpus
33_udim_merged.blend exported 6 of its 12 triangles); Cycles renders them. They cannot be put
back at the hook, so `dropped_triangles_warning` names the mesh and how many are missing.
"""

import numpy as np

from .gltf_objects import accessor_array
from .node_graph import GRAPH_EXTENSION


def restore_tile_uvs(gltf2_mesh, state):
    """Move each tile primitive's UV map back to its tile (module doc); ambiguous cases are
    named in `state.warnings`."""
    for prim in gltf2_mesh.primitives or []:
        material = prim.material
        graph = _graph(material)
        if graph is None:
            continue
        tiled = _tiled(material)
        tile = _tile_suffix(getattr(material, "name", None) or "", tiled)
        if tile is None:
            continue
        maps = {n["props"].get("tex_coord", 0) for n in tiled}
        if len(maps) != 1:
            state.warnings.append(f"material '{material.name}': its UDIM images use several UV maps; the "
                                  "exporter's per-tile split is kept and the tiles may read the wrong UVs")
            continue
        accessor = (prim.attributes or {}).get(f"TEXCOORD_{maps.pop()}")
        if accessor is None or id(accessor) in state.tile_uv_accessors:
            continue
        uv = accessor_array(accessor, np.float32, 2)
        if uv is None:
            continue
        state.tile_uv_accessors.add(id(accessor))
        # Tile 1001 + u + 10 v spans Blender UV [u, u+1] x [v, v+1]; glTF's V is 1 - Blender's.
        u, v = (tile - 1001) % 10, (tile - 1001) // 10
        moved = uv + np.array([u, -v], dtype=np.float32)
        from io_scene_gltf2.io.exp.binary_data import BinaryData
        view = accessor.buffer_view
        accessor.buffer_view = BinaryData(moved.astype(np.float32).tobytes(), bufferViewTarget=view.bufferViewTarget)
        accessor.byte_offset = None
        if accessor.min is not None and accessor.max is not None:
            accessor.min = [float(x) for x in moved.min(axis=0)]
            accessor.max = [float(x) for x in moved.max(axis=0)]


def _graph(material):
    """The material's node graph value, or None."""
    ext = (getattr(material, "extensions", None) or {}).get(GRAPH_EXTENSION)
    value = getattr(ext, "extension", ext)
    return value if isinstance(value, dict) else None


def _tile_suffix(name, tiled):
    """The tile number the exporter appended to the material's name when the graph's UDIM
    images have that tile, else None."""
    head, _, tail = name.rpartition(".")
    if not head or not tail.isdigit():
        return None
    tile = int(tail)
    if not any(tile == t for n in tiled for t, _ in n["props"]["tiles"]):
        return None
    return tile


def dropped_triangles_warning(gltf2_mesh, blender_mesh, state):
    """Name the mesh in `state.warnings` when the exporter's per-tile split (module doc) wrote
    fewer triangles than the mesh has."""
    prims = gltf2_mesh.primitives or []
    if not any(_tile_suffix(getattr(p.material, "name", None) or "", _tiled(p.material)) for p in prims):
        return
    written = sum(p.indices.count // 3 for p in prims
                  if p.indices is not None and getattr(p, "mode", None) in (None, 4))
    blender_mesh.calc_loop_triangles()
    total = len(blender_mesh.loop_triangles)
    if written < total:
        state.warnings.append(f"mesh '{blender_mesh.name}': Blender's glTF exporter split it by UDIM tile and left out "
                              f"{total - written} of its {total} triangles, whose first corner's UV is in no tile "
                              "(Cycles renders them); Caustic renders without them")


def _tiled(material):
    """The material graph's Image Texture nodes that hold UDIM tiles."""
    graph = _graph(material)
    return [n for n in (graph or {}).get("nodes", []) if n.get("props", {}).get("tiles")]
