"""Meshes: primitives without a material, and a textured material on a mesh without a UV map.

A mesh whose material slots are empty (or that has none) is exported without a material,
which glTF reads as a white metal of roughness 1; Cycles renders its default surface instead
(`ShaderManager::add_default`: a Principled BSDF with the node's defaults, base colour 0.8,
metallic 0, roughness 0.5, IOR 1.5, Specular IOR Level 0.5; checked on bpy 5.0.1, where a
material-less sphere and one with a new material's default Principled BSDF render identically).
Such primitives get one explicit glTF material of those values. The default surface reads no
colour attribute: the exporter is asked not to write the active one as COLOR_0 for a mesh without
a material (`export_active_vertex_color_when_no_material`), which glTF multiplies into the base
colour. Neither does any material the exporter writes as glTF (not a node graph): their
primitives' COLOR_0, written when the graphs read one colour attribute by name, is removed.

The exporter keeps the material's texture bindings but writes no TEXCOORD attribute, which the
glTF validator calls an error. The missing TEXCOORD_n are added with every vertex at Blender's
UV (0, 0) (glTF (0, 1)), which is what Cycles looks up for a mesh without UVs, with a warning.

A mesh whose materials' node graphs read Generated coordinates gets its texture space in
`extras.CAUSTIC_texspace` (contract): the evaluated mesh's `texspace_location`/`texspace_size`,
which Cycles reads from the same evaluated mesh. Cycles applies it to the *undeformed* vertex
positions (orco), which glTF cannot carry; the renderer applies it to the exported ones. The two
agree without modifiers and with Subdivision Surface (which smooths both alike); any other
modifier or shape keys are named in a warning (checked on bpy 5.0.1: an Array modifier keeps the
original mesh's texture space, so its copies repeat the pattern in Cycles).
"""

from .attributes import note_requests
from .gltf_objects import constant_uv_accessor
from .materials import complete_material, graph_of, uses_graph
from .media import volume_uses_generated
from .node_graph import GRAPH_EXTENSION

TEXSPACE_EXTRA = "CAUSTIC_texspace"
NORMALS_DOMAIN_EXTRA = "CAUSTIC_normals_domain"
OBJECT_COLOR_EXTRA = "CAUSTIC_object_color"

DEFAULT_SURFACE_NAME = "Blender default surface"


def apply_material_override(gltf2_mesh, state, export_settings):
    """The view layer's Material Override on every primitive, as Cycles renders it: one glTF
    material built from the override's node graph (the exporter never converted it)."""
    override = state.material_override
    if override is None:
        return
    if state.override_material is None:
        material = _default_surface()
        material.name = override.name
        if not complete_material(material, override, export_settings, state, force_graph=True):
            state.warnings.append(f"material override '{override.name}' has no shader graph Caustic reads: "
                                  "rendered as Blender's default surface")
        note_requests(override, state)
        state.override_material = material
    for prim in gltf2_mesh.primitives or []:
        prim.material = state.override_material


def give_default_material(gltf2_mesh, state):
    """Give the mesh's primitives without a material Blender's default surface (module doc)."""
    for prim in gltf2_mesh.primitives or []:
        if prim.material is None:
            if state.default_material is None:
                state.default_material = _default_surface()
            prim.material = state.default_material


def drop_unread_colour(gltf2_mesh):
    """Remove COLOR_0 from the primitives whose material is not a node graph: glTF multiplies
    the base colour by it, but such a material has no node that reads a colour attribute in
    Cycles (a Color Attribute or Attribute node makes the material a graph, node_graph.needs_graph).
    The exporter writes it when the graphs read one colour attribute by name
    (`single_colour_attribute`): then for every mesh that has the attribute."""
    for prim in gltf2_mesh.primitives or []:
        if not prim.attributes or "COLOR_0" not in prim.attributes:
            continue
        extensions = getattr(prim.material, "extensions", None) or {}
        if GRAPH_EXTENSION not in extensions:
            del prim.attributes["COLOR_0"]


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


def default_surface_index(doc):
    """The index in the glTF document `doc` of Blender's default surface (module doc), appended
    when no mesh needed it: points and strands without a material take it too (a point cloud
    left to glTF's white metal of roughness 1: 1.031 of Cycles)."""
    materials = doc.setdefault("materials", [])
    for i, m in enumerate(materials):
        if m.get("name") == DEFAULT_SURFACE_NAME:
            return i
    materials.append({"name": DEFAULT_SURFACE_NAME, "doubleSided": True,
                      "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0,
                                               "roughnessFactor": 0.5}})
    return len(materials) - 1


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


def add_texspace(gltf2_mesh, blender_object, state):
    """Put the object's mesh's texture space in the glTF mesh's extras when a material's graph
    reads Generated coordinates (module doc). Called from the node hook: the exporter's mesh
    hook is not given the object of an unskinned mesh."""
    if gltf2_mesh is None or blender_object is None or blender_object.type != "MESH":
        return
    materials = [slot.material for slot in blender_object.material_slots]
    if not any(m is not None and ((uses_graph(m, state) and graph_of(m, state).uses_generated)
                                  or volume_uses_generated(m)) for m in materials):
        return
    mesh = blender_object.data
    if state.depsgraph is not None:
        mesh = blender_object.evaluated_get(state.depsgraph).data
    _warn_deformed(blender_object, state)
    extras = gltf2_mesh.extras if isinstance(gltf2_mesh.extras, dict) else {}
    extras[TEXSPACE_EXTRA] = {"location": [float(v) for v in mesh.texspace_location],
                              "size": [float(v) for v in mesh.texspace_size]}
    gltf2_mesh.extras = extras


def add_normals_domain(gltf2_mesh, blender_object, state):
    """Put the evaluated mesh's normals domain (`Mesh.normals_domain`: POINT, FACE or CORNER) in
    the glTF mesh's extras when a material of the object moves it (true displacement, contract):
    the renderer recomputes the displaced normals by it, as Cycles does by the mesh's smooth
    flags and corner normals, which the exported vertex normals do not tell apart on a plane.
    A Subdivision Surface modifier with adaptive subdivision is named: Caustic does not dice."""
    if gltf2_mesh is None or blender_object is None or blender_object.type != "MESH":
        return
    materials = [slot.material for slot in blender_object.material_slots]
    if not any(m is not None and uses_graph(m, state) and graph_of(m, state).true_displacement for m in materials):
        return
    mesh = blender_object.data
    if state.depsgraph is not None:
        mesh = blender_object.evaluated_get(state.depsgraph).data
    extras = gltf2_mesh.extras if isinstance(gltf2_mesh.extras, dict) else {}
    extras[NORMALS_DOMAIN_EXTRA] = str(mesh.normals_domain)
    gltf2_mesh.extras = extras
    for modifier in blender_object.modifiers:
        if modifier.type == "SUBSURF" and modifier.show_render and getattr(modifier, "use_adaptive_subdivision", False):
            state.warnings.append(
                f"object '{blender_object.name}': modifier '{modifier.name}' uses adaptive subdivision (dicing "
                "rate), which Caustic does not dice: the exported mesh is displaced at its vertices as it is")


def add_object_color(gltf2_node, blender_object, state):
    """Put the object's colour (Object Info Color and Alpha) in the glTF node's extras when a
    material's graph has an Object Info node and the colour is not Blender's default white."""
    if gltf2_node is None or blender_object is None or blender_object.type != "MESH":
        return
    color = [float(v) for v in blender_object.color]
    if color == [1.0, 1.0, 1.0, 1.0]:
        return
    materials = [slot.material for slot in blender_object.material_slots]
    if not any(m is not None and uses_graph(m, state)
               and any(n.get("type") == "ShaderNodeObjectInfo" for n in graph_of(m, state).nodes)
               for m in materials):
        return
    extras = gltf2_node.extras if isinstance(gltf2_node.extras, dict) else {}
    extras[OBJECT_COLOR_EXTRA] = color
    gltf2_node.extras = extras


# Modifiers after which Generated coordinates of the exported positions are still Cycles' (the
# undeformed positions go through them alike).
_ORCO_SAFE_MODIFIERS = {"SUBSURF"}


def _warn_deformed(blender_object, state):
    """Name an object whose modifiers or shape keys move its vertices away from the undeformed
    positions Cycles' Generated coordinates use (module doc)."""
    if blender_object is None:
        return
    moved = [m.name for m in blender_object.modifiers if m.show_render and m.type not in _ORCO_SAFE_MODIFIERS]
    if getattr(blender_object.data, "shape_keys", None) is not None:
        moved.append("shape keys")
    if moved:
        state.warnings.append(
            f"object '{blender_object.name}': Generated texture coordinates are computed from the modified mesh "
            f"({', '.join(moved)}); Cycles computes them from the undeformed one, so the pattern may differ")
