"""Meshes: a textured material on a mesh without a UV map.

The exporter keeps the material's texture bindings but writes no TEXCOORD attribute, which the
glTF validator calls an error. The missing TEXCOORD_n are added with every vertex at Blender's
UV (0, 0) (glTF (0, 1)), which is what Cycles looks up for a mesh without UVs, with a warning.
"""

from .gltf_objects import constant_uv_accessor


def add_missing_texcoords(gltf2_mesh, blender_mesh, state):
    """Give the mesh's primitives the TEXCOORD_n their materials' textures read."""
    for prim in gltf2_mesh.primitives or []:
        needed = _texcoords_used(prim.material)
        attributes = prim.attributes or {}
        position = attributes.get("POSITION")
        missing = [n for n in needed if f"TEXCOORD_{n}" not in attributes]
        if not missing or position is None:
            continue
        for n in range(max(missing) + 1):
            if f"TEXCOORD_{n}" not in attributes:
                attributes[f"TEXCOORD_{n}"] = constant_uv_accessor(position.count)
        prim.attributes = attributes
        state.warnings.append(
            f"mesh '{getattr(blender_mesh, 'name', '?')}' has no UV map for its material's textures: "
            "they are read at UV (0, 0), as Blender does")


def _texcoords_used(material):
    """The texCoord sets (0, 1, ...) that a glTF material object's texture bindings read."""
    used, seen, todo = set(), set(), [material]
    while todo:
        obj = todo.pop()
        if obj is None or isinstance(obj, (str, bytes, int, float, bool)) or id(obj) in seen:
            continue
        seen.add(id(obj))
        if isinstance(obj, dict):
            todo.extend(obj.values())
            continue
        if isinstance(obj, (list, tuple)):
            todo.extend(obj)
            continue
        if hasattr(obj, "tex_coord") and hasattr(obj, "index"):  # TextureInfo and its kin
            used.add(obj.tex_coord or 0)
        todo.extend(vars(obj).values() if hasattr(obj, "__dict__") else ())
    return sorted(used)
