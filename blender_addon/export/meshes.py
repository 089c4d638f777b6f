"""Meshes: primitives without a material, and a textured material on a mesh without a UV map.

A mesh whose material slots are empty (or that has none) is exported without a material,
which glTF reads as a white metal of roughness 1; Cycles renders its default surface instead
(`ShaderManager::add_default`: a Principled BSDF with the node's defaults, base colour 0.8,
metallic 0, roughness 0.5, IOR 1.5, Specular IOR Level 0.5; checked on bpy 5.0.1, where a
material-less sphere and one with a new material's default Principled BSDF render identically).
Such primitives get one explicit glTF material of those values.

The exporter keeps the material's texture bindings but writes no TEXCOORD attribute, which the
glTF validator calls an error. The missing TEXCOORD_n are added with every vertex at Blender's
UV (0, 0) (glTF (0, 1)), which is what Cycles looks up for a mesh without UVs, with a warning.

A mesh whose materials' node graphs read Generated coordinates gets its texture space in
`extras.CAUSTIC_texspace` (contract): the evaluated mesh's `texspace_location`/`texspace_size`,
which Cycles reads from the same evaluated mesh (modifiers included).
"""

from .gltf_objects import constant_uv_accessor
from .materials import graph_of, uses_graph

TEXSPACE_EXTRA = "CAUSTIC_texspace"

DEFAULT_SURFACE_NAME = "Blender default surface"


def give_default_material(gltf2_mesh, state):
    """Give the mesh's primitives without a material Blender's default surface (module doc)."""
    for prim in gltf2_mesh.primitives or []:
        if prim.material is None:
            if state.default_material is None:
                state.default_material = _default_surface()
            prim.material = state.default_material


def _default_surface():
    """A glTF material equal to Cycles' default surface: glTF's defaults for everything else
    (IOR 1.5, specularFactor 1 = Specular IOR Level 0.5) are Blender's."""
    from io_scene_gltf2.io.com import gltf2_io
    pbr = gltf2_io.MaterialPBRMetallicRoughness(
        base_color_factor=[0.8, 0.8, 0.8, 1.0], base_color_texture=None, extensions=None, extras=None,
        metallic_factor=0.0, metallic_roughness_texture=None, roughness_factor=0.5)
    # Double-sided as the exporter writes a Blender material without backface culling.
    return gltf2_io.Material(
        alpha_cutoff=None, alpha_mode=None, double_sided=True, emissive_factor=None, emissive_texture=None,
        extensions=None, extras=None, name=DEFAULT_SURFACE_NAME, normal_texture=None, occlusion_texture=None,
        pbr_metallic_roughness=pbr)


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


def add_texspace(gltf2_mesh, blender_mesh, blender_object, materials, state):
    """Put the mesh's texture space in its extras when a material's graph reads Generated
    coordinates (module doc)."""
    if not any(m is not None and uses_graph(m, state) and graph_of(m, state).uses_generated
               for m in materials or ()):
        return
    mesh = blender_mesh
    if blender_object is not None and state.depsgraph is not None:
        evaluated = blender_object.evaluated_get(state.depsgraph)
        if evaluated.type == "MESH":
            mesh = evaluated.data
    extras = gltf2_mesh.extras if isinstance(gltf2_mesh.extras, dict) else {}
    extras[TEXSPACE_EXTRA] = {"location": [float(v) for v in mesh.texspace_location],
                              "size": [float(v) for v in mesh.texspace_size]}
    gltf2_mesh.extras = extras
