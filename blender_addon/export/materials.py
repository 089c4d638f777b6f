"""Materials: what Blender's glTF exporter writes differently from what Cycles renders, and the
Principled BSDF parameters it drops (contract, "Materials the exporter writes differently").

* Shader nodes the exporter does not read (it reads the Principled BSDF and Emission): it
  writes no pbrMetallicRoughness for them, which glTF reads as a white, rough *metal*. Caustic
  writes the glTF material that renders like Cycles' node (`shader_node_material`).
* Transmissive materials: without KHR_materials_volume glTF calls a transmissive surface
  thin-walled (no refraction), but Cycles always refracts at a glass surface: a glass sphere
  from Blender must render as a solid sphere (`KHR_materials_volume`, thickness 1).
* A Principled glass's base colour: glTF tints by it at every crossing, Cycles by its square
  root; written as sqrt(base) where that is exact (`_principled_transmission_tint`).
* Coat IOR and tint (`CAUSTIC_materials_coat`); subsurface and volume media (media.py).
* Thin Film Thickness and IOR, which the exporter drops: `KHR_materials_iridescence` (`_thin_film`).
* Sheen: Cycles renders the microfiber sheen, not glTF's Charlie (`CAUSTIC_materials_sheen`),
  and the exporter drops Sheen Weight (`_sheen`).
* Anything else the exporter cannot express (procedural textures, converters, mixtures of
  shaders, groups, bump, ...): the whole Surface/Displacement graph in
  `CAUSTIC_materials_nodes` (node_graph.py); the exporter's glTF material stays beside it for
  other readers, and its fallback warnings are not given, since Caustic renders the graph.
* Principled inputs neither glTF nor Caustic render: warnings.
"""

import json
import math

from .gltf_objects import optional_extension
from .node_graph import GRAPH_EXTENSION, GraphContext, build_graph, needs_graph
from .light_nodes import write_ies_profiles
from .media import MEDIUM_EXTENSION, SUBSURFACE_EXTENSION, medium_extension, subsurface_extension
from .nodes import procedural_source, surface_node, value as _value

COAT_EXTENSION = "CAUSTIC_materials_coat"
ANISOTROPY_EXTENSION = "CAUSTIC_materials_anisotropy"
NORMAL_MAP_EXTENSION = "CAUSTIC_materials_normal_map"
SHEEN_EXTENSION = "CAUSTIC_materials_sheen"
IRIDESCENCE_EXTENSION = "CAUSTIC_materials_iridescence"
SHADOW_EXTENSION = "CAUSTIC_materials_shadow"

# Shaders the add-on translates; any other surface is a warning and a grey Lambertian.
_BSDF_NODES = {"BSDF_DIFFUSE", "BSDF_GLOSSY", "BSDF_METALLIC", "BSDF_GLASS", "BSDF_REFRACTION"}


def _principled(blender_material):
    """The material's Principled BSDF node, if its output uses one directly."""
    node = surface_node(blender_material)
    return node if node is not None and node.type == "BSDF_PRINCIPLED" else None


def principled_extras(blender_material, graph=False):
    """What Blender's glTF exporter drops from a Principled BSDF that Caustic renders
    (`CAUSTIC_materials_coat`: coat IOR and tint), and warnings naming what neither renders
    (the anisotropy's Cycles mapping is added in `complete_material`).

    With `graph` (the material is exported as a node graph) linked inputs are not named: the
    graph carries them."""
    node = _principled(blender_material)
    if node is None:
        return None, []
    name = blender_material.name
    warnings = []
    coat = None
    inputs = node.inputs

    def value(socket_name, default):
        socket = inputs.get(socket_name)
        if socket is None:
            return default
        if socket.is_linked and not graph:
            warnings.append(f"material '{name}': a linked {socket_name} is not supported; using its value")
        return socket.default_value

    for socket in inputs if not graph else ():
        source = procedural_source(socket) if socket.is_linked and socket.type != "SHADER" else None
        if source is not None:
            warnings.append(f"material '{name}': {socket.name} comes from a {source.bl_label} node, which glTF "
                            "cannot carry (only image textures and constants are exported); Caustic renders "
                            "the exporter's fallback, not the pattern")
    # A linked Coat Weight is the exporter's clearcoatTexture (an image, or the graph otherwise):
    # the coat's IOR and tint are still owed (a textured coat of IOR 1.2: blocks 23 % bright).
    weight = inputs.get("Coat Weight")
    if weight is not None and (weight.is_linked or weight.default_value > 0.0):
        ior = float(value("Coat IOR", 1.5))
        tint = [float(c) for c in value("Coat Tint", (1, 1, 1, 1))[:3]]
        if abs(ior - 1.5) > 1e-6 or any(abs(c - 1.0) > 1e-6 for c in tint):
            coat = {"ior": ior, "tint": tint}
    # Diffuse Roughness and Anisotropic, which glTF cannot say as Cycles renders them, send the
    # material to its node graph (node_graph.needs_graph), so they need no word here.
    return coat, warnings


def shader_node_material(blender_material):
    """The glTF parameters for a material whose surface is a single Diffuse, Glossy, Metallic,
    Glass or Refraction BSDF (None for any other surface), and warnings.

    Returns (params, color_socket, warnings): params has base (RGB), metallic, roughness and
    optionally specular (0: no dielectric layer), transmission and ior; color_socket is the
    colour input when it is linked (a texture for the hook to export), else None. Mappings:
    Diffuse -> Lambertian (specular 0); Glossy and Metallic -> metal with F0 = colour (Schlick);
    Glass -> transmission 1 with the node's IOR; Refraction -> the same (with a warning: glTF
    glass also reflects). A Mix or Add Shader is rendered as the first shader in it that is
    one of these or a Principled BSDF (which the exporter writes), with a warning naming the
    mix. Other shaders (Translucent, Transparent, Toon, ...) get a warning and a grey
    Lambertian, Blender's default surface, instead of the white metal.
    """
    node = surface_node(blender_material)
    name = blender_material.name
    warnings = []
    if node is not None and node.type in {"MIX_SHADER", "ADD_SHADER"}:
        inner = _first_translatable(node)
        if inner is not None:
            warnings.append(f"material '{name}': the {node.bl_label}'s weights are not rendered: Caustic "
                            f"renders its {inner.bl_label} at full weight (and the light of any Emission in it)")
            node = inner
    if node is None or node.type in {"BSDF_PRINCIPLED", "EMISSION"}:
        return None, None, warnings
    if node.type not in _BSDF_NODES:
        warnings.append(f"material '{name}': the {node.bl_label} node is not supported as a surface; "
                        "rendered as a grey diffuse surface (only Principled BSDF, Diffuse, Glossy, Metallic, "
                        "Glass, Refraction and Emission shaders are translated)")
        # "fallback": the hook keeps what the exporter wrote if it found a Principled BSDF
        # (inside a node group, say) and uses this only where it wrote nothing.
        return ({"base": [0.8, 0.8, 0.8], "metallic": 0.0, "roughness": 1.0, "specular": 0.0, "fallback": True},
                None, warnings)
    what = f"material '{name}'"
    if node.type == "BSDF_METALLIC" and getattr(node, "fresnel_type", "F82") == "PHYSICAL_CONDUCTOR":
        # Its Base Color is unavailable (Blender 5.0's `inputs[...]` does not find it).
        base, conductor_warnings = conductor_reflectance(node, what)
        warnings += conductor_warnings
        linked_color = None
    else:
        color_socket = node.inputs["Base Color" if node.type == "BSDF_METALLIC" else "Color"]
        linked_color = color_socket if color_socket.is_linked else None
        base = [float(c) for c in color_socket.default_value[:3]] if linked_color is None else [1.0, 1.0, 1.0]
    roughness = float(_value(node, "Roughness", what, warnings, 0.5)) if "Roughness" in node.inputs else 1.0
    for socket_name in ("Normal", "Anisotropy"):
        socket = node.inputs.get(socket_name)
        if socket is not None and (socket.is_linked or (socket_name == "Anisotropy" and socket.default_value != 0.0)):
            warnings.append(f"{what}: the {node.bl_label}'s {socket_name} is not rendered")
    if node.type == "BSDF_DIFFUSE":
        if roughness > 0.0:
            warnings.append(f"{what}: Diffuse BSDF roughness (Oren-Nayar) is not rendered; Lambertian instead")
        return {"base": base, "metallic": 0.0, "roughness": 1.0, "specular": 0.0}, linked_color, warnings
    if node.type in {"BSDF_GLOSSY", "BSDF_METALLIC"}:
        return {"base": base, "metallic": 1.0, "roughness": roughness}, linked_color, warnings
    ior = float(_value(node, "IOR", what, warnings, 1.5))
    if node.type == "BSDF_REFRACTION":
        warnings.append(f"{what}: Refraction BSDF is rendered as glass (it also reflects, by Fresnel)")
    return ({"base": base, "metallic": 0.0, "roughness": roughness, "transmission": 1.0, "ior": ior},
            linked_color, warnings)


def conductor_reflectance(node, what):
    """A physical-conductor Metallic BSDF's reflectance at normal incidence per channel,
    ((n - 1)^2 + k^2) / ((n + 1)^2 + k^2) from its IOR n and Extinction k, which Caustic's
    glTF approximation's Schlick Fresnel starts from; and warnings. The approximation is rendered
    only where the material's node graph is not (the graph renders Cycles' exact conductor
    Fresnel, and the approximation's warnings are dropped then)."""
    warnings = [f"{what}: Metallic BSDF's physical conductor is rendered from its glTF approximation, Schlick's "
                "Fresnel from its reflectance at normal incidence (Cycles' exact conductor Fresnel differs towards "
                "grazing angles)"]
    values = {}
    for socket_name in ("IOR", "Extinction"):
        socket = next(s for s in node.inputs if s.identifier == socket_name)
        if socket.is_linked:
            warnings.append(f"{what}: the Metallic BSDF's linked {socket_name} is not rendered; "
                            "its unlinked value is used")
        values[socket_name] = [float(c) for c in socket.default_value[:3]]
    base = [((n - 1.0) ** 2 + k * k) / ((n + 1.0) ** 2 + k * k)
            for n, k in zip(values["IOR"], values["Extinction"])]
    return base, warnings


def _shaders_in(node, depth=0):
    """Depth-first, the shader nodes mixed or added by a Mix/Add Shader (nested ones opened)."""
    found = []
    if depth > 16:
        return found
    for socket in node.inputs:
        if socket.type != "SHADER" or not socket.is_linked:
            continue
        inner = socket.links[0].from_node
        if inner.type in {"MIX_SHADER", "ADD_SHADER"}:
            found += _shaders_in(inner, depth + 1)
        else:
            found.append(inner)
    return found


def _first_translatable(node):
    """The first Principled or translatable BSDF in a Mix/Add Shader, else its first Emission.

    A BSDF comes first: the exporter writes an Emission's light whichever node is chosen, and a
    material with emission only would be read as a white metal that also emits."""
    shaders = _shaders_in(node)
    for inner in shaders:
        if inner.type in _BSDF_NODES or inner.type == "BSDF_PRINCIPLED":
            return inner
    return next((inner for inner in shaders if inner.type == "EMISSION"), None)


def _color_texture(socket, export_settings):
    """A glTF TextureInfo for an image linked to `socket`, made by Blender's exporter, or None.

    Uses the exporter's own texture gathering (its internal API; on a version where that
    fails the caller warns and keeps the constant colour)."""
    from io_scene_gltf2.blender.exp.material.search_node_tree import NodeSocket, has_image_node_from_socket
    from io_scene_gltf2.blender.exp.material.texture_info import gather_texture_info
    nav = NodeSocket(socket, [socket.id_data])  # the group path starts at the material's tree
    if not has_image_node_from_socket(nav, export_settings):
        return None
    tex, _uvmap_info, _udim_info, _factor = gather_texture_info(nav, (nav,), export_settings)
    return tex


def _principled_transmission_tint(gltf2_material, blender_material):
    """Write a Principled glass's base colour as the per-crossing tint glTF means; return warnings.

    glTF (KHR_materials_transmission) tints light by the base colour at every crossing of the
    surface; Cycles' Principled BSDF tints it by sqrt(base colour) (svm closure setup:
    transmission_tint = sqrt(base)), so that light entering and leaving a solid is tinted by
    the base colour once. With full transmission and no metal the base colour is used for
    nothing else, so sqrt(base) in the glTF is exact; otherwise the diffuse or metal part needs
    the colour itself, and the difference is named in a warning.
    """
    node = _principled(blender_material)
    pbr = gltf2_material.pbr_metallic_roughness
    if node is None or pbr is None or not _present(gltf2_material, "KHR_materials_transmission"):
        return []
    inputs = node.inputs
    base = inputs["Base Color"]
    transmission, metallic = inputs["Transmission Weight"], inputs["Metallic"]
    if base.is_linked or pbr.base_color_texture is not None:
        white = False
    else:
        white = all(abs(c - 1.0) < 1e-6 for c in base.default_value[:3])
    if white:
        return []
    exact = (not base.is_linked and not transmission.is_linked and not metallic.is_linked
             and transmission.default_value >= 1.0 and metallic.default_value <= 0.0)
    if exact:
        factor = list(pbr.base_color_factor or [1.0, 1.0, 1.0, 1.0])
        pbr.base_color_factor = [math.sqrt(max(float(c), 0.0)) for c in factor[:3]] + list(factor[3:])
        return []
    return [f"material '{blender_material.name}': transmitted light is tinted by the base colour at each "
            "surface crossing (glTF); Cycles tints by its square root, which the glTF can only say for full "
            "transmission, no metal and an untextured base colour"]


def _set_extension(gltf2_material, name, value):
    """Add (or replace) the optional extension `name` on a glTF material."""
    extensions = gltf2_material.extensions or {}
    extensions[name] = optional_extension(name, value)
    gltf2_material.extensions = extensions


def _present(gltf2_material, name):
    """Whether the exporter wrote extension `name` with any value: at the hook it also holds
    empty ones ({} = every factor 0: no transmission, no anisotropy), dropped only later."""
    ext = (gltf2_material.extensions or {}).get(name)
    value = getattr(ext, "extension", ext)
    return bool(value)


def _has_normal_map(gltf2_material):
    """Whether the exporter wrote a normal texture or a clear coat normal texture."""
    if getattr(gltf2_material, "normal_texture", None) is not None:
        return True
    coat = (gltf2_material.extensions or {}).get("KHR_materials_clearcoat")
    coat = getattr(coat, "extension", coat)
    return isinstance(coat, dict) and coat.get("clearcoatNormalTexture") is not None


def complete_material(gltf2_material, blender_material, export_settings, state, force_graph=False):
    """Everything Caustic adds to the exporter's glTF material (the material hook's work);
    `force_graph`: render it from its node graph even where glTF could say it (a material the
    exporter did not convert, such as a view layer's override). Returns whether the graph
    was written."""
    as_graph = _node_graph(gltf2_material, blender_material, export_settings, state, force_graph)
    # A material exported as a graph is rendered from the graph: the warnings about what its
    # glTF approximation drops do not apply to Caustic, so they are collected and discarded.
    approximation_warnings = [] if as_graph else state.warnings
    _translate_shader_node(gltf2_material, blender_material, export_settings, approximation_warnings)
    coat, warnings = principled_extras(blender_material, graph=as_graph)
    state.warnings.extend(warnings)
    if _present(gltf2_material, "KHR_materials_clearcoat"):
        # Cycles' coat reflects with the exact dielectric Fresnel, glTF's with Schlick's
        # (docs/contract.md).
        coat = {**(coat or {}), "fresnel": "dielectric"}
    if coat is not None:
        _set_extension(gltf2_material, COAT_EXTENSION, coat)
    if _present(gltf2_material, "KHR_materials_sheen"):
        state.warnings.extend(_sheen(gltf2_material, blender_material))
    state.warnings.extend(_thin_film(gltf2_material, blender_material, as_graph))
    ior = _opaque_ior(gltf2_material, blender_material)
    if ior is not None:
        state.opaque_iors[gltf2_material.name or blender_material.name] = ior
    if _present(gltf2_material, "KHR_materials_anisotropy"):
        # The exporter writes Blender's Anisotropic as glTF's strength; Cycles maps it to widths
        # differently (docs/contract.md).
        _set_extension(gltf2_material, ANISOTROPY_EXTENSION, {"mapping": "blender"})
    if _has_normal_map(gltf2_material):
        # The exporter writes a Normal Map node's Strength as the texture's scale; Cycles
        # applies a Strength below 1 differently from glTF's scale (docs/contract.md).
        _set_extension(gltf2_material, NORMAL_MAP_EXTENSION, {"mapping": "blender"})
    approximation_warnings.extend(_principled_transmission_tint(gltf2_material, blender_material))
    if _present(gltf2_material, "KHR_materials_transmission") and not _present(gltf2_material, "KHR_materials_volume"):
        _set_extension(gltf2_material, "KHR_materials_volume", {"thicknessFactor": 1.0})
        state.solid_materials.append(blender_material.name if blender_material else "?")
    # A volume graph's images are written as the surface graphs' are.
    writer = state.image_writer(export_settings["gltf_filedirectory"])
    for name, build in ((SUBSURFACE_EXTENSION, subsurface_extension),
                        (MEDIUM_EXTENSION, lambda m: medium_extension(m, writer))):
        value, warnings = build(blender_material)
        state.warnings.extend(warnings)
        if value is not None:
            _set_extension(gltf2_material, name, value)
    return as_graph


def _sheen(gltf2_material, blender_material):
    """Blender's sheen in the exporter's KHR_materials_sheen: Cycles' microfiber model
    (`CAUSTIC_materials_sheen`), and Sheen Weight, which the exporter drops (it writes Sheen
    Tint as sheenColorFactor), multiplied into the colour. Returns warnings."""
    _set_extension(gltf2_material, SHEEN_EXTENSION, {"model": "microfiber"})
    node = _principled(blender_material)
    socket = node.inputs.get("Sheen Weight") if node is not None else None
    if socket is None:
        return []
    if socket.is_linked:
        return [f"material '{blender_material.name}': a linked Sheen Weight is not carried by glTF; "
                "the sheen is rendered at full weight"]
    weight = min(max(float(socket.default_value), 0.0), 1.0)
    ext = gltf2_material.extensions["KHR_materials_sheen"]
    value = getattr(ext, "extension", ext)
    colour = value.get("sheenColorFactor", [0.0, 0.0, 0.0])
    value["sheenColorFactor"] = [float(c) * weight for c in colour]
    return []


def _opaque_ior(gltf2_material, blender_material):
    """The Principled BSDF's IOR, which the exporter writes only beside transmission, volume or
    specular extensions: an opaque material of another IOR than glTF's 1.5 would lose the shape
    of its dielectric layer's Fresnel (and a free thin film, IOR 1, its substrate). Returns the
    IOR when it is not 1.5: the exporter's final pass (`__check_ior`) deletes it again from a
    material without those extensions, after every hook, so `restore_opaque_iors` writes it
    back into the file."""
    node = _principled(blender_material)
    socket = node.inputs.get("IOR") if node is not None else None
    if socket is None or socket.is_linked:
        return None
    ior = float(socket.default_value)
    # Below 1 is outside glTF's range: such a material renders from its node graph
    # (`needs_graph`), which carries the IOR.
    if abs(ior - 1.5) <= 1e-6 or ior < 1.0:
        return None
    # The exporter writes it itself for an unlinked IOR, and deletes it at the end.
    if not _present(gltf2_material, "KHR_materials_ior"):
        _set_extension(gltf2_material, "KHR_materials_ior", {"ior": ior})
    return ior


def restore_opaque_iors(gltf_path, iors):
    """Write `iors` (glTF material name -> IOR, from `_opaque_ior`) back as KHR_materials_ior on
    the materials of the written file that lost it: Blender 5.0's exporter keeps the extension
    only beside transmission, volume or specular, so an opaque Principled of IOR 1.33 or 3 was
    rendered at glTF's default 1.5. Returns how many materials it restored."""
    if not iors:
        return 0
    with open(gltf_path, encoding="utf-8") as f:
        doc = json.load(f)
    restored = 0
    for mat in doc.get("materials", []):
        ior = iors.get(mat.get("name"))
        if ior is None or "KHR_materials_ior" in mat.get("extensions", {}):
            continue
        mat.setdefault("extensions", {})["KHR_materials_ior"] = {"ior": ior}
        restored += 1
    if restored:
        used = doc.setdefault("extensionsUsed", [])
        if "KHR_materials_ior" not in used:
            used.append("KHR_materials_ior")
        with open(gltf_path, "w", encoding="utf-8") as f:
            json.dump(doc, f)
    return restored


# Cycles' THINFILM_THICKNESS_CUTOFF: a thinner film is no film.
_THIN_FILM_CUTOFF_NM = 0.1


def _thin_film(gltf2_material, blender_material, graph):
    """The Principled BSDF's Thin Film as KHR_materials_iridescence (factor 1, the film's IOR,
    minimum = maximum = the thickness in nm), which the exporter drops, marked
    `CAUSTIC_materials_iridescence` {"metal": "conductor"}: the film covers the metal part too,
    on Cycles' F82-tint conductor. The renderer does not put it on the glass part: a
    transmissive part is named in a warning. With `graph` the node graph carries a linked
    thickness. Returns warnings."""
    node = _principled(blender_material)
    socket = node.inputs.get("Thin Film Thickness") if node is not None else None
    if socket is None or (float(socket.default_value) <= _THIN_FILM_CUTOFF_NM and not socket.is_linked):
        return []
    name = blender_material.name
    warnings = []
    if socket.is_linked and not graph:
        warnings.append(f"material '{name}': a linked Thin Film Thickness is not carried by glTF; using its value")
    thickness = float(socket.default_value)
    if thickness > _THIN_FILM_CUTOFF_NM:
        ior = float(node.inputs["Thin Film IOR"].default_value)
        _set_extension(gltf2_material, "KHR_materials_iridescence", {
            "iridescenceFactor": 1.0, "iridescenceIor": ior,
            "iridescenceThicknessMinimum": thickness, "iridescenceThicknessMaximum": thickness})
        _set_extension(gltf2_material, IRIDESCENCE_EXTENSION, {"metal": "conductor"})
    p = node.inputs.get("Transmission Weight")
    if p is not None and (p.is_linked or float(p.default_value) > 0.0):
        warnings.append(f"material '{name}': the thin film is rendered on the dielectric layer and the metal, "
                        "not on the glass part (Transmission Weight)")
    return warnings


def graph_of(blender_material, state):
    """The material's node graph (node_graph.Graph, or None), built once per export.

    The UV map numbers come from the evaluated meshes of the objects that use the material."""
    if blender_material is None:
        return None
    key = blender_material.as_pointer()
    if key not in state.graphs:
        meshes = list(_meshes_by_material(state).get(blender_material.original.as_pointer(), {}).values())
        state.graphs[key] = build_graph(blender_material, GraphContext(state.depsgraph, meshes, state.colour_attribute))
    return state.graphs[key]


def _meshes_by_material(state):
    """Original material pointer -> {mesh pointer: evaluated mesh} of the depsgraph's objects
    using it in a slot; built once per export (one pass over the objects, not one per material)."""
    if state.material_meshes is None:
        state.material_meshes = {}
        override = state.material_override
        for obj in state.depsgraph.objects if state.depsgraph is not None else ():
            if obj.type != "MESH":
                continue
            if override is not None:  # every mesh wears the view layer's override
                state.material_meshes.setdefault(override.original.as_pointer(), {})[obj.data.as_pointer()] = obj.data
                continue
            for slot in obj.material_slots:
                if slot.material is not None:
                    users = state.material_meshes.setdefault(slot.material.original.as_pointer(), {})
                    users[obj.data.as_pointer()] = obj.data
    return state.material_meshes


def uses_graph(blender_material, state):
    """Whether the material is exported as a node graph (contract's rule, node_graph.needs_graph)."""
    graph = graph_of(blender_material, state)
    return graph is not None and needs_graph(blender_material, graph)


def _node_graph(gltf2_material, blender_material, export_settings, state, force=False):
    """Attach `CAUSTIC_materials_nodes` when the exporter cannot express the material (or
    `force`), writing its images; whether it did."""
    graph = graph_of(blender_material, state)
    if graph is None or not (force or uses_graph(blender_material, state)):
        return False
    state.warnings.extend(graph.warnings)
    writer = state.image_writer(export_settings["gltf_filedirectory"])
    what = f"material '{blender_material.name}'"
    value = writer.graph_value(graph, what, state.warnings)
    write_ies_profiles(blender_material, value["nodes"], export_settings["gltf_filedirectory"], what, state.warnings)
    _set_extension(gltf2_material, GRAPH_EXTENSION, value)
    return True


def _translate_shader_node(gltf2_material, blender_material, export_settings, out_warnings):
    """Write the glTF material of a Diffuse/Glossy/Metallic/Glass/Refraction surface; its
    warnings go to `out_warnings`."""
    params, color_socket, warnings = shader_node_material(blender_material)
    pbr = gltf2_material.pbr_metallic_roughness
    wrote = pbr is not None and any(getattr(pbr, k, None) is not None for k in (
        "base_color_factor", "base_color_texture", "metallic_factor", "roughness_factor",
        "metallic_roughness_texture"))
    if params is not None and params.get("fallback") and wrote:
        return  # the exporter found a Principled BSDF in the surface (e.g. in a node group)
    out_warnings.extend(warnings)
    if params is None:
        return
    from io_scene_gltf2.io.com.gltf2_io import MaterialPBRMetallicRoughness
    texture = None
    if color_socket is not None:
        try:
            texture = _color_texture(color_socket, export_settings)
        except Exception as err:  # the exporter's internal API changed
            texture = None
            print(f"Caustic: texture of material '{blender_material.name}' not exported: {err!r}")
        if texture is None:
            out_warnings.append(f"material '{blender_material.name}': its colour comes from nodes other "
                                  "than an image texture; rendered white")
    pbr = gltf2_material.pbr_metallic_roughness or MaterialPBRMetallicRoughness(
        None, None, None, None, None, None, None)
    pbr.base_color_factor = [*params["base"], 1.0]
    pbr.base_color_texture = texture
    pbr.metallic_factor = params["metallic"]
    pbr.roughness_factor = params["roughness"]
    pbr.metallic_roughness_texture = None
    gltf2_material.pbr_metallic_roughness = pbr
    extensions = gltf2_material.extensions or {}
    if "specular" in params:
        extensions["KHR_materials_specular"] = optional_extension(
            "KHR_materials_specular", {"specularFactor": params["specular"]})
    if "transmission" in params:
        extensions["KHR_materials_transmission"] = optional_extension(
            "KHR_materials_transmission", {"transmissionFactor": params["transmission"]})
        extensions["KHR_materials_ior"] = optional_extension("KHR_materials_ior", {"ior": params["ior"]})
    gltf2_material.extensions = extensions or None


def add_shadow_extension(gltf2_material, blender_material):
    """`CAUSTIC_materials_shadow` with `"transparent": false` when the material's Transparent
    Shadows setting is off: Cycles then stops shadow rays at its surface whatever its alpha
    (`Shader::use_transparent_shadow`, from `Material.use_transparent_shadow`); files made
    before Blender 4.2 often have it off."""
    if not getattr(blender_material, "use_transparent_shadow", True):
        _set_extension(gltf2_material, SHADOW_EXTENSION, {"transparent": False})
