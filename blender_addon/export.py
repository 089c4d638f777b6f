"""Scene export: Blender's own glTF exporter, plus Caustic's data through its user-extension hooks.

What the exporter leaves out and Caustic needs (docs/contract.md):
* area lights ("Unsupported light source AREA"): `CAUSTIC_lights_area` on the light's node;
* the render settings: `scenes[i].extras.caustic`;
* Principled BSDF subsurface: `CAUSTIC_materials_subsurface` on the material;
* the material's Volume output: `CAUSTIC_materials_medium` on the material.

And what it writes that the glTF validator calls an error (tests/blender/test_gltf_validity.py):
* a spot with blend 0 gets innerConeAngle == outerConeAngle (glTF wants inner < outer): the
  inner angle is moved down to the next double (Caustic uses `spot_blend` instead anyway);
* a textured material on a mesh without a UV map keeps its texture bindings with no TEXCOORD
  attribute: the hook adds the missing TEXCOORD_n, every vertex at Blender's UV (0, 0) (glTF
  (0, 1)), which is what Cycles looks up for a mesh without UVs, and warns.

Facts this module relies on (io_scene_gltf2 5.0.21, shipped with Blender/bpy 5.0.1):
* the exporter instantiates `glTF2ExportUserExtension` from `sys.modules[name]` for every
  `name` in `bpy.context.preferences.addons`; the package's `__init__` re-exports the class and
  `_hooks_enabled` makes sure the package is listed while Caustic exports;
* hook exceptions are logged and swallowed by the exporter, so the hooks record their own
  failures in `_ExportState.errors` and `export_scene` raises them afterwards;
* an area light's node gets the exporter's -90° X light correction and the Y-up axis swap, and
  the two cancel: the node's local frame *is* the Blender light's local frame (light in local
  XY, emitting towards local -Z, object scale in the node's scale). No compensation is needed;
* the exporter evaluates meshes with `bpy.context.evaluated_depsgraph_get()`, the viewport
  depsgraph. `_render_depsgraph` points it at the render depsgraph for the duration of the export
  so that render-level modifiers and render visibility are used.
"""

import math
import os
import sys
from contextlib import contextmanager

import bpy

from .errors import CausticError

AREA_LIGHT_EXTENSION = "CAUSTIC_lights_area"

# Blender's area light shapes -> the contract's names.
_AREA_SHAPES = {"SQUARE": "square", "RECTANGLE": "rectangle", "DISK": "disk", "ELLIPSE": "ellipse"}

# The one export in progress; the hooks are no-ops outside a Caustic export, so that a user's
# ordinary glTF export is not changed by having Caustic enabled.
_current = None


class _ExportState:
    """What one Caustic export hands to the hooks and what the hooks hand back."""

    def __init__(self, settings):
        self.settings = settings
        self.pixel_aspect = (1.0, 1.0)  # the scene's, for the camera's sensor fit
        self.area_lights = []  # names of the nodes that got CAUSTIC_lights_area
        self.scenes = 0  # scenes that got extras.caustic
        self.solid_materials = []  # transmissive materials marked as solids
        self.warnings = []
        self.errors = []


def render_settings(scene, resolution, camera_name):
    """The `extras.caustic` object for a scene: the Caustic panel's values in contract keys."""
    props = scene.caustic
    settings = {
        "resolution": [int(resolution[0]), int(resolution[1])],
        "spp": int(props.samples),
        # Blender counts bounces, the renderer counts scattering events (contract).
        "max_depth": int(props.max_bounces) + 1,
        "seed": int(props.seed),
        "integrator": props.integrator,
        "light_sampler": props.light_sampler,
        # Film → Transparent off means an opaque background (alpha 1), as in Cycles.
        "transparent": bool(scene.render.film_transparent),
        # Blender's pixel filter (Blackman-Harris, as Cycles' default). Cycles spreads the
        # window over twice the filter size (film.cpp: width *= 2 for Blackman-Harris).
        "filter": "blackman-harris",
        "filter_width": 2.0 * float(scene.render.filter_size),
    }
    if props.integrator == "sppm":
        settings["sppm_iterations"] = int(props.samples)
    if props.integrator == "photon":
        if props.photons > 0:
            settings["photons"] = int(props.photons)
        if props.caustic_photons > 0:
            settings["caustic_photons"] = int(props.caustic_photons)
    if props.time_limit > 0.0:
        settings["time_limit"] = float(props.time_limit)
    if props.threads > 0:
        settings["threads"] = int(props.threads)
    if camera_name:
        settings["camera"] = camera_name
    return settings


def area_light_extension(blender_object):
    """The `CAUSTIC_lights_area` value for an area light object, and warnings about what it drops."""
    light = blender_object.data
    warnings = []
    shape = _AREA_SHAPES[light.shape]
    if light.shape in {"SQUARE", "DISK"}:
        size = [light.size, light.size]
    else:
        size = [light.size, light.size_y]

    color = list(light.color)
    if light.use_temperature:
        color = [c * t for c, t in zip(color, light.temperature_color)]

    # Same power as Cycles: exposure is a power of two; without "normalize" the power is per
    # unit area, the area taken in world space (object scale included).
    power = light.energy * 2.0 ** light.exposure
    if not light.normalize:
        power *= light.area(matrix_world=blender_object.matrix_world)

    if light.use_nodes:
        warnings.append(f"light '{blender_object.name}': light node trees are ignored")
    value = {"shape": shape, "size": [float(s) for s in size], "power": float(power),
             "color": [float(c) for c in color],
             # Ray Visibility > Camera (Blender hides lights from the camera by default).
             "camera_visible": bool(blender_object.visible_camera)}
    # Spread (full angle, radians); 180° is Blender's default and no narrowing.
    if light.spread < math.pi - 1e-4:
        value["spread"] = float(light.spread)
    return value, warnings


WORLD_EXTENSION = "CAUSTIC_world"
CAMERA_EXTENSION = "CAUSTIC_camera"


def camera_extension(blender_object, resolution, pixel_aspect=(1.0, 1.0)):
    """Blender's lens shift and depth of field for a camera object (`CAUSTIC_camera`), and warnings.

    The glTF exporter drops both. Shift goes out as fractions of the frame's width and height:
    Blender measures it in units of the sensor-fitted dimension (Cycles' viewplane: dx = 2 *
    aspect * shift_x with the fitted side spanning 2 * aspect). Depth of field as Cycles reads it:
    aperture radius = focal length / (2 f-stop) (focal length in mm, scene units in metres;
    1 / (2 f-stop) for an orthographic camera), focus distance along the viewing axis (to the
    focus object's origin when there is one).
    Returns (value or None, warnings).
    """
    cam = blender_object.data
    warnings = []
    xr = float(resolution[0]) * float(pixel_aspect[0])
    yr = float(resolution[1]) * float(pixel_aspect[1])
    fit = cam.sensor_fit
    horizontal = xr > yr if fit == "AUTO" else fit == "HORIZONTAL"
    if horizontal:
        shift = [cam.shift_x, cam.shift_y * xr / yr]
    else:
        shift = [cam.shift_x * yr / xr, cam.shift_y]
    value = {}
    if cam.shift_x != 0.0 or cam.shift_y != 0.0:
        value["shift"] = [float(s) for s in shift]
    if cam.type == "PANO":
        warnings.append(f"camera '{blender_object.name}': panoramic cameras are not supported; "
                        "rendered as the exporter's perspective camera")
    dof = cam.dof
    if dof.use_dof:
        fstop = max(float(dof.aperture_fstop), 1e-5)
        radius = 1.0 / (2.0 * fstop) if cam.type == "ORTHO" else cam.lens * 1e-3 / (2.0 * fstop)
        if dof.focus_object is not None:
            m = blender_object.matrix_world
            view_dir = m.col[2].xyz.normalized()
            dof_dir = m.translation - dof.focus_object.matrix_world.translation
            focus = abs(view_dir.dot(dof_dir))
            if getattr(dof, "focus_subtarget", ""):
                warnings.append(f"camera '{blender_object.name}': the focus bone is ignored; "
                                "focusing on the object's origin")
        else:
            focus = float(dof.focus_distance)
        value["aperture_radius"] = float(radius)
        value["focus_distance"] = float(max(focus, 1e-6))
        if dof.aperture_blades >= 3:
            value["blades"] = int(dof.aperture_blades)
            value["blade_rotation"] = float(dof.aperture_rotation)
        if dof.aperture_ratio != 1.0:
            value["aperture_ratio"] = float(dof.aperture_ratio)
    return (value or None), warnings
PUNCTUAL_EXTENSION = "CAUSTIC_lights_punctual"


def punctual_light_extension(blender_object):
    """Blender's light shape parameters that KHR_lights_punctual cannot say, or None.

    radius: a point light's `shadow_soft_size` (a sphere light in Cycles, or with soft falloff a
    disk facing the shading point); angle: a sun's
    angular diameter; spot_blend: applied with Cycles' smoothstep instead of glTF's ramp.
    """
    light = blender_object.data
    value = {}
    if light.type == "POINT" and light.shadow_soft_size > 0.0:
        value["radius"] = float(light.shadow_soft_size)
        value["camera_visible"] = bool(blender_object.visible_camera)
        value["soft_falloff"] = bool(getattr(light, "use_soft_falloff", False))
    elif light.type == "SPOT":
        value["spot_blend"] = float(light.spot_blend)
        if light.shadow_soft_size > 0.0:
            value["radius"] = float(light.shadow_soft_size)
    elif light.type == "SUN" and light.angle > 0.0:
        value["angle"] = float(light.angle)
    return value or None

_IMAGE_EXTENSIONS = {"HDR": ".hdr", "OPEN_EXR": ".exr", "OPEN_EXR_MULTILAYER": ".exr", "PNG": ".png",
                     "JPEG": ".jpg"}


COAT_EXTENSION = "CAUSTIC_materials_coat"


def _principled(blender_material):
    """The material's Principled BSDF node, if its output uses one directly."""
    node = _surface_node(blender_material)
    return node if node is not None and node.type == "BSDF_PRINCIPLED" else None


def principled_extras(blender_material):
    """What Blender's glTF exporter drops from a Principled BSDF that Caustic renders
    (`CAUSTIC_materials_coat`: coat IOR and tint), and warnings naming what neither renders."""
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
        if socket.is_linked:
            warnings.append(f"material '{name}': a linked {socket_name} is not supported; using its value")
        return socket.default_value

    for socket in inputs:
        source = _procedural_source(socket) if socket.is_linked and socket.type != "SHADER" else None
        if source is not None:
            warnings.append(f"material '{name}': {socket.name} comes from a {source.bl_label} node, which glTF "
                            "cannot carry (only image textures and constants are exported); Caustic renders "
                            "the exporter's fallback, not the pattern")
    if value("Coat Weight", 0.0) > 0.0:
        ior = float(value("Coat IOR", 1.5))
        tint = [float(c) for c in value("Coat Tint", (1, 1, 1, 1))[:3]]
        if abs(ior - 1.5) > 1e-6 or any(abs(c - 1.0) > 1e-6 for c in tint):
            coat = {"ior": ior, "tint": tint}
    if value("Thin Film Thickness", 0.0) > 0.0:
        warnings.append(f"material '{name}': thin film (iridescence) is not rendered by Caustic")
    if value("Diffuse Roughness", 0.0) > 0.0:
        warnings.append(f"material '{name}': Diffuse Roughness is not rendered (Caustic's diffuse is Lambertian)")
    if value("Anisotropic", 0.0) > 0.0:
        warnings.append(f"material '{name}': anisotropic reflection is rendered isotropic")
    return coat, warnings


def _surface_node(blender_material):
    """The node linked to the active Material Output's Surface, or None."""
    tree = getattr(blender_material, "node_tree", None)
    if tree is None:
        return None
    for node in tree.nodes:
        if node.type == "OUTPUT_MATERIAL" and node.is_active_output:
            surface = node.inputs.get("Surface")
            if surface is not None and surface.is_linked:
                return surface.links[0].from_node
    return None


# Shaders Blender's glTF exporter does not read (it reads the Principled BSDF and Emission): it
# writes no pbrMetallicRoughness for them, which glTF reads as a white, rough *metal*. Caustic
# writes the glTF material that renders like Cycles' node (docs/contract.md, "Materials").
_BSDF_NODES = {"BSDF_DIFFUSE", "BSDF_GLOSSY", "BSDF_METALLIC", "BSDF_GLASS", "BSDF_REFRACTION"}


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
    node = _surface_node(blender_material)
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
    color_name = "Base Color" if node.type == "BSDF_METALLIC" else "Color"
    color_socket = node.inputs[color_name]
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
        if node.type == "BSDF_METALLIC" and getattr(node, "fresnel_type", "F82") != "F82":
            warnings.append(f"{what}: Metallic BSDF's physical conductor (IOR, extinction) is rendered "
                            "with its Base Color as the reflectance at normal incidence")
        return {"base": base, "metallic": 1.0, "roughness": roughness}, linked_color, warnings
    ior = float(_value(node, "IOR", what, warnings, 1.5))
    if node.type == "BSDF_REFRACTION":
        warnings.append(f"{what}: Refraction BSDF is rendered as glass (it also reflects, by Fresnel)")
    return ({"base": base, "metallic": 0.0, "roughness": roughness, "transmission": 1.0, "ior": ior},
            linked_color, warnings)


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


def _procedural_source(socket, depth=0, seen=None):
    """The first procedural texture node (Noise, Voronoi, Wave, ...) upstream of `socket`, or None.

    Blender's glTF exporter carries image textures and constants; a procedural texture on
    a Principled input is dropped without a word, and the input takes glTF's default."""
    seen = set() if seen is None else seen
    if depth > 32 or not socket.is_linked:
        return None
    node = socket.links[0].from_node
    if node.as_pointer() in seen:
        return None
    seen.add(node.as_pointer())
    if node.type.startswith("TEX_") and node.type not in {"TEX_IMAGE", "TEX_ENVIRONMENT", "TEX_COORD"}:
        return node
    for upstream in node.inputs:
        found = _procedural_source(upstream, depth + 1, seen)
        if found is not None:
            return found
    return None


def _linked_node(socket):
    return socket.links[0].from_node if socket.is_linked else None


def world_extension(scene, folder):
    """The `CAUSTIC_world` value for the scene's world, and warnings about what it drops.

    Supported: a Background node (colour × strength) on the active World Output, whose colour
    may come from an Environment Texture (equirectangular) optionally rotated about Z by a
    Mapping node. The image file (or the packed image's bytes) is copied next to the glTF.
    """
    world = scene.world
    if world is None:
        return None, []
    warnings = []
    tree = world.node_tree if getattr(world, "use_nodes", True) else None
    if tree is None:
        c = world.color
        return {"color": [float(c[0]), float(c[1]), float(c[2])], "strength": 1.0}, warnings
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_WORLD"]
    output = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    if output is None or not output.inputs["Surface"].is_linked:
        return None, warnings
    node = _linked_node(output.inputs["Surface"])
    if node.type != "BACKGROUND":
        warnings.append(f"world '{world.name}': the {node.bl_label} node is not supported; the world is black")
        return None, warnings
    if node.inputs["Strength"].is_linked:
        warnings.append(f"world '{world.name}': a linked Strength is not supported; using its value")
    strength = float(node.inputs["Strength"].default_value)
    value = {"color": [1.0, 1.0, 1.0], "strength": strength}
    color_in = node.inputs["Color"]
    source = _linked_node(color_in)
    if source is None:
        value["color"] = [float(c) for c in color_in.default_value[:3]]
        return value, warnings
    if source.type != "TEX_ENVIRONMENT" or source.image is None:
        warnings.append(f"world '{world.name}': colour from a {source.bl_label} node is not supported; "
                        "using the Background colour")
        value["color"] = [float(c) for c in color_in.default_value[:3]]
        return value, warnings
    if source.projection != "EQUIRECTANGULAR":
        warnings.append(f"world '{world.name}': {source.projection} projection is not supported; "
                        "read as equirectangular")
    mapping = _linked_node(source.inputs["Vector"])
    if mapping is not None:
        if mapping.type == "MAPPING":
            rotation = mapping.inputs["Rotation"].default_value
            value["rotation"] = float(rotation[2])
            if abs(rotation[0]) > 1e-6 or abs(rotation[1]) > 1e-6:
                warnings.append(f"world '{world.name}': Mapping rotation about X/Y is not supported")
        elif mapping.type != "TEX_COORD":
            warnings.append(f"world '{world.name}': the {mapping.bl_label} node before the "
                            "Environment Texture is not supported")
    image = source.image
    suffix = _IMAGE_EXTENSIONS.get(image.file_format, os.path.splitext(image.filepath)[1].lower() or ".png")
    target = os.path.join(folder, "world" + suffix)
    if image.packed_file is not None:
        with open(target, "wb") as f:
            f.write(image.packed_file.data)
    else:
        src = bpy.path.abspath(image.filepath, library=image.library)
        if not os.path.isfile(src):
            warnings.append(f"world '{world.name}': image '{image.name}' has no file ({src}); "
                            "using the Background colour")
            value["color"] = [float(c) for c in color_in.default_value[:3]]
            return value, warnings
        with open(src, "rb") as fin, open(target, "wb") as fout:
            fout.write(fin.read())
    value["image"] = os.path.basename(target)
    return value, warnings


SUBSURFACE_EXTENSION = "CAUSTIC_materials_subsurface"
MEDIUM_EXTENSION = "CAUSTIC_materials_medium"

# Blender's subsurface methods -> the contract's; Christensen-Burley has no random walk of
# its own and is rendered as Random Walk (with a warning).
_SUBSURFACE_METHODS = {"RANDOM_WALK": "random_walk", "RANDOM_WALK_SKIN": "random_walk_skin",
                       "BURLEY": "random_walk"}


def _material_output(tree):
    """The Material Output node Cycles uses (the active one, else the first)."""
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_MATERIAL"]
    for n in outputs:
        if n.is_active_output and n.target in ("ALL", "CYCLES"):
            return n
    return outputs[0] if outputs else None


def _socket(node, name):
    """A node input by name, also when Blender hides it (disabled sockets are not reachable by key)."""
    return next((i for i in node.inputs if i.name == name), None)


def _value(node, name, what, warnings, default=None):
    """An input's unlinked value; a linked input is named in a warning and its value used."""
    sock = _socket(node, name)
    if sock is None:
        return default
    if sock.is_linked:
        warnings.append(f"{what}: the {node.name} node's {name} input is linked; Caustic uses its value "
                        f"{_fmt(sock.default_value)} (textures and node inputs are not exported)")
    return sock.default_value


def _fmt(v):
    try:
        return "(" + ", ".join(f"{float(x):.3g}" for x in v) + ")"
    except TypeError:
        return f"{float(v):.3g}"


def subsurface_extension(blender_material):
    """The `CAUSTIC_materials_subsurface` value of a material (None without subsurface), and warnings."""
    warnings = []
    tree = getattr(blender_material, "node_tree", None)
    if tree is None:
        return None, warnings
    output = _material_output(tree)
    if output is None or not output.inputs["Surface"].is_linked:
        return None, warnings
    node = _linked_node(output.inputs["Surface"])
    if node.type != "BSDF_PRINCIPLED":
        return None, warnings
    what = f"material '{blender_material.name}'"
    weight = float(_value(node, "Subsurface Weight", what, warnings, 0.0))
    if weight <= 0.0:
        return None, []
    radius = _value(node, "Subsurface Radius", what, warnings, (1.0, 0.2, 0.1))
    scale = float(_value(node, "Subsurface Scale", what, warnings, 0.05))
    method = getattr(node, "subsurface_method", "RANDOM_WALK")
    if method == "BURLEY":
        warnings.append(f"{what}: subsurface method Christensen-Burley is rendered as Random Walk")
    value = {
        "weight": weight,
        "radius": [max(float(r), 0.0) * max(scale, 0.0) for r in radius[:3]],
        "anisotropy": float(_value(node, "Subsurface Anisotropy", what, warnings, 0.0)),
        "ior": float(_value(node, "Subsurface IOR", what, warnings, 1.4)),
        "method": _SUBSURFACE_METHODS.get(method, "random_walk"),
    }
    return value, warnings


def medium_extension(blender_material):
    """The `CAUSTIC_materials_medium` value of a material's Volume output (None without one),
    and warnings naming what cannot be exported. Coefficients as Cycles builds them (contract)."""
    warnings = []
    tree = getattr(blender_material, "node_tree", None)
    if tree is None:
        return None, warnings
    output = _material_output(tree)
    if output is None or not output.inputs["Volume"].is_linked:
        return None, warnings
    node = _linked_node(output.inputs["Volume"])
    what = f"material '{blender_material.name}'"
    value = {"surface": bool(output.inputs["Surface"].is_linked)}

    def rgb(name, default):
        return [float(c) for c in _value(node, name, what, warnings, default)[:3]]

    if node.type == "PRINCIPLED_VOLUME":
        color = rgb("Color", (0.5, 0.5, 0.5))
        absorption = rgb("Absorption Color", (0.0, 0.0, 0.0))
        value["density"] = max(float(_value(node, "Density", what, warnings, 1.0)), 0.0)
        value["scatter_color"] = [max(c, 0.0) for c in color]
        value["absorption_color"] = [max(1.0 - c, 0.0) * max(1.0 - math.sqrt(max(a, 0.0)), 0.0)
                                     for c, a in zip(color, absorption)]
        value["anisotropy"] = float(_value(node, "Anisotropy", what, warnings, 0.0))
        strength = float(_value(node, "Emission Strength", what, warnings, 0.0))
        value["emission"] = [max(c, 0.0) * max(strength, 0.0) for c in rgb("Emission Color", (1, 1, 1))]
        if float(_value(node, "Blackbody Intensity", what, warnings, 0.0)) > 0.0:
            warnings.append(f"{what}: the {node.name} node's blackbody emission is not exported")
    elif node.type == "VOLUME_SCATTER":
        value["density"] = max(float(_value(node, "Density", what, warnings, 1.0)), 0.0)
        value["scatter_color"] = [max(c, 0.0) for c in rgb("Color", (0.8, 0.8, 0.8))]
        value["absorption_color"] = [0.0, 0.0, 0.0]
        value["anisotropy"] = float(_value(node, "Anisotropy", what, warnings, 0.0))
        phase = getattr(node, "phase", "HENYEY_GREENSTEIN")
        if phase != "HENYEY_GREENSTEIN":
            warnings.append(f"{what}: the {node.name} node's {phase} phase function is rendered as "
                            "Henyey-Greenstein")
    elif node.type == "VOLUME_ABSORPTION":
        value["density"] = max(float(_value(node, "Density", what, warnings, 1.0)), 0.0)
        value["scatter_color"] = [0.0, 0.0, 0.0]
        value["absorption_color"] = [max(1.0 - c, 0.0) for c in rgb("Color", (0.8, 0.8, 0.8))]
    else:
        warnings.append(f"{what}: the {node.name} node ({node.bl_label}) on the Volume output cannot be "
                        "exported; the volume is left out")
        return None, warnings
    value["anisotropy"] = min(max(value.get("anisotropy", 0.0), -1.0), 1.0)
    return value, warnings


class glTF2ExportUserExtension:
    """Hooks the glTF exporter calls; they add Caustic's data while a Caustic render exports."""

    def __init__(self):
        # Imported here: the exporter add-on may be loaded after Caustic.
        from io_scene_gltf2.io.com.gltf2_io_extensions import Extension
        self._extension = Extension

    def _attach(self, gltf2_object, name, value):
        """Put extension `name` with `value` (not required by readers) on a glTF object."""
        if gltf2_object.extensions is None:
            gltf2_object.extensions = {}
        gltf2_object.extensions[name] = self._extension(name=name, extension=value, required=False)

    def gather_node_hook(self, gltf2_node, blender_object, export_settings):
        """Attach CAUSTIC_lights_area to an area light's node, CAUSTIC_lights_punctual to the others."""
        state = _current
        if state is None or blender_object is None:
            return
        try:
            if blender_object.type == "CAMERA":
                value, warnings = camera_extension(blender_object, state.settings["resolution"],
                                                   state.pixel_aspect)
                state.warnings.extend(warnings)
                if value:
                    self._attach(gltf2_node, CAMERA_EXTENSION, value)
                return
            if blender_object.type != "LIGHT":
                return
            if blender_object.data.type != "AREA":
                _separate_spot_angles(gltf2_node)
                value = punctual_light_extension(blender_object)
                if value:
                    self._attach(gltf2_node, PUNCTUAL_EXTENSION, value)
                return
            value, warnings = area_light_extension(blender_object)
            self._attach(gltf2_node, AREA_LIGHT_EXTENSION, value)
            state.area_lights.append(gltf2_node.name)
            state.warnings.extend(warnings)
        except Exception as err:  # the exporter would swallow it: keep it for export_scene
            state.errors.append(f"area light '{blender_object.name}': {err!r}")

    def gather_mesh_hook(self, gltf2_mesh, blender_mesh, blender_object, vertex_groups, modifiers, materials,
                         export_settings):
        """Give primitives the TEXCOORD_n their material's textures read (see the module doc)."""
        state = _current
        if state is None or gltf2_mesh is None:
            return
        try:
            for prim in gltf2_mesh.primitives or []:
                needed = _texcoords_used(prim.material)
                attributes = prim.attributes or {}
                position = attributes.get("POSITION")
                missing = [n for n in needed if f"TEXCOORD_{n}" not in attributes]
                if not missing or position is None:
                    continue
                for n in range(max(missing) + 1):
                    if f"TEXCOORD_{n}" not in attributes:
                        attributes[f"TEXCOORD_{n}"] = _constant_uv_accessor(position.count)
                prim.attributes = attributes
                state.warnings.append(
                    f"mesh '{getattr(blender_mesh, 'name', '?')}' has no UV map for its material's textures: "
                    "they are read at UV (0, 0), as Blender does")
        except Exception as err:
            state.errors.append(f"mesh '{getattr(blender_mesh, 'name', '?')}': {err!r}")

    def gather_material_hook(self, gltf2_material, blender_material, export_settings):
        """Mark transmissive materials as solids (KHR_materials_volume, thickness 1), and add
        the subsurface and volume extensions.

        Without KHR_materials_volume glTF calls a transmissive surface thin-walled (no
        refraction), but Cycles always refracts at a glass surface: a glass sphere from
        Blender must render as a solid sphere.
        """
        state = _current
        if state is None or gltf2_material is None:
            return
        try:
            extensions = gltf2_material.extensions or {}
            self._translate_shader_node(gltf2_material, blender_material, export_settings, state)
            extensions = gltf2_material.extensions or {}
            coat, warnings = principled_extras(blender_material)
            state.warnings.extend(warnings)
            if coat is not None:
                extensions[COAT_EXTENSION] = self._extension(name=COAT_EXTENSION, extension=coat, required=False)
                gltf2_material.extensions = extensions
            if "KHR_materials_transmission" in extensions and "KHR_materials_volume" not in extensions:
                extensions["KHR_materials_volume"] = self._extension(
                    name="KHR_materials_volume", extension={"thicknessFactor": 1.0}, required=False)
                gltf2_material.extensions = extensions
                state.solid_materials.append(blender_material.name if blender_material else "?")
            for name, build in ((SUBSURFACE_EXTENSION, subsurface_extension), (MEDIUM_EXTENSION, medium_extension)):
                value, warnings = build(blender_material)
                state.warnings.extend(warnings)
                if value is not None:
                    extensions[name] = self._extension(name=name, extension=value, required=False)
                    gltf2_material.extensions = extensions
        except Exception as err:
            state.errors.append(f"material '{getattr(blender_material, 'name', '?')}': {err!r}")

    def _translate_shader_node(self, gltf2_material, blender_material, export_settings, state):
        """Write the glTF material of a Diffuse/Glossy/Metallic/Glass/Refraction surface."""
        params, color_socket, warnings = shader_node_material(blender_material)
        pbr = gltf2_material.pbr_metallic_roughness
        wrote = pbr is not None and any(getattr(pbr, k, None) is not None for k in (
            "base_color_factor", "base_color_texture", "metallic_factor", "roughness_factor",
            "metallic_roughness_texture"))
        if params is not None and params.get("fallback") and wrote:
            return  # the exporter found a Principled BSDF in the surface (e.g. in a node group)
        state.warnings.extend(warnings)
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
                state.warnings.append(f"material '{blender_material.name}': its colour comes from nodes other "
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
            extensions["KHR_materials_specular"] = self._extension(
                name="KHR_materials_specular", extension={"specularFactor": params["specular"]}, required=False)
        if "transmission" in params:
            extensions["KHR_materials_transmission"] = self._extension(
                name="KHR_materials_transmission", extension={"transmissionFactor": params["transmission"]},
                required=False)
            extensions["KHR_materials_ior"] = self._extension(
                name="KHR_materials_ior", extension={"ior": params["ior"]}, required=False)
        gltf2_material.extensions = extensions or None

    def gather_scene_hook(self, gltf2_scene, blender_scene, export_settings):
        """Store the render settings in the scene's extras.caustic."""
        state = _current
        if state is None:
            return
        try:
            extras = gltf2_scene.extras if isinstance(gltf2_scene.extras, dict) else {}
            extras["caustic"] = dict(state.settings)
            gltf2_scene.extras = extras
            state.scenes += 1
        except Exception as err:
            state.errors.append(f"scene settings: {err!r}")
        try:
            value, warnings = world_extension(blender_scene, export_settings["gltf_filedirectory"])
            state.warnings.extend(warnings)
            if value is not None:
                if gltf2_scene.extensions is None:
                    gltf2_scene.extensions = {}
                gltf2_scene.extensions[WORLD_EXTENSION] = self._extension(
                    name=WORLD_EXTENSION, extension=value, required=False)
        except Exception as err:
            state.errors.append(f"world: {err!r}")


def _separate_spot_angles(gltf2_node):
    """Make a spot's innerConeAngle strictly smaller than its outerConeAngle (glTF's rule)."""
    ext = (gltf2_node.extensions or {}).get("KHR_lights_punctual")
    child = ext.extension.get("light") if ext is not None and isinstance(ext.extension, dict) else None
    light = getattr(child, "extension", None)
    spot = light.get("spot") if isinstance(light, dict) else None
    if isinstance(spot, dict):
        inner, outer = spot.get("innerConeAngle"), spot.get("outerConeAngle")
        if isinstance(inner, float) and isinstance(outer, float) and inner >= outer > 0.0:
            spot["innerConeAngle"] = math.nextafter(outer, 0.0)


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


def _constant_uv_accessor(count):
    """A VEC2 float accessor of `count` vertices, all at glTF UV (0, 1) = Blender's (0, 0)."""
    from io_scene_gltf2.io.com import gltf2_io
    from io_scene_gltf2.io.com.constants import BufferViewTarget, ComponentType, DataType
    from io_scene_gltf2.io.exp.binary_data import BinaryData
    import struct
    data = struct.pack("<2f", 0.0, 1.0) * count
    return gltf2_io.Accessor(
        buffer_view=BinaryData(data, bufferViewTarget=BufferViewTarget.ARRAY_BUFFER), byte_offset=None,
        component_type=ComponentType.Float, count=count, extensions=None, extras=None, max=None, min=None,
        name=None, normalized=None, sparse=None, type=DataType.Vec2)


@contextmanager
def _hooks_enabled():
    """Make sure the exporter finds this package's hooks, however the add-on was enabled.

    Installed and enabled from Preferences, the package is already in `preferences.addons`.
    When only `register()` was called (scripts, tests) it is not, and the exporter would skip the
    hooks silently: list the package for the duration of the export, then remove it again.
    """
    addons = bpy.context.preferences.addons
    added = None
    if __package__ not in addons:
        added = addons.new()
        added.module = __package__
    try:
        yield
    finally:
        if added is not None:
            addons.remove(added)


class _ContextProxy:
    """bpy.context, except that evaluated_depsgraph_get() returns the render depsgraph."""

    def __init__(self, depsgraph):
        object.__setattr__(self, "_depsgraph", depsgraph)

    def evaluated_depsgraph_get(self):
        return self._depsgraph

    def __getattr__(self, name):
        return getattr(bpy.context, name)

    def __setattr__(self, name, value):
        setattr(bpy.context, name, value)


class _BpyProxy:
    """The bpy module as seen by the exporter during a Caustic export."""

    def __init__(self, depsgraph):
        self.context = _ContextProxy(depsgraph)

    def __getattr__(self, name):
        return getattr(bpy, name)


@contextmanager
def _render_depsgraph(depsgraph):
    """Let the exporter's modules see `depsgraph` as the context's evaluated depsgraph."""
    proxy = _BpyProxy(depsgraph)
    patched = []
    for name, module in list(sys.modules.items()):
        if name.startswith("io_scene_gltf2.blender.exp") and getattr(module, "bpy", None) is bpy:
            module.bpy = proxy
            patched.append(module)
    try:
        yield
    finally:
        for module in patched:
            module.bpy = bpy


def _exporter_options(filepath):
    """Exporter settings for a renderer: the current frame's state, everything renderable."""
    return dict(
        filepath=filepath,
        check_existing=False,
        export_format="GLTF_SEPARATE",
        export_image_format="AUTO",
        use_selection=False,
        use_visible=False,
        use_renderable=True,
        use_active_scene=True,
        use_active_collection=False,
        export_cameras=True,
        export_lights=True,
        export_import_convert_lighting_mode="SPEC",
        export_apply=True,  # modifiers, from the render depsgraph (see _render_depsgraph)
        export_yup=True,
        export_extras=False,
        export_animations=False,
        export_current_frame=True,  # else the exporter jumps to frame 0 and back
        export_skins=False,  # deformation comes baked in the evaluated mesh
        export_morph=False,
        export_gn_mesh=True,
        export_gpu_instances=False,
        export_draco_mesh_compression_enable=False,
        export_materials="EXPORT",
        will_save_settings=False,
    )


def export_scene(depsgraph, folder, settings):
    """Write the render depsgraph's scene to `folder`/scene.gltf; return (path, export state).

    Raises CausticError when the exporter fails or one of Caustic's hooks failed.
    """
    global _current
    filepath = os.path.join(folder, "scene.gltf")
    scene = depsgraph.scene  # the original scene (scene_eval is the evaluated copy)
    view_layer = depsgraph.view_layer
    state = _ExportState(settings)
    state.pixel_aspect = (scene.render.pixel_aspect_x, scene.render.pixel_aspect_y)
    # The exporter takes object transforms from the original objects, which only the viewport
    # depsgraph updates; during an animation render it still holds the previous frame.
    scene_eval = depsgraph.scene_eval
    scene.frame_set(scene_eval.frame_current, subframe=scene_eval.frame_subframe)
    _current = state
    try:
        with bpy.context.temp_override(scene=scene, view_layer=view_layer), \
                _hooks_enabled(), _render_depsgraph(depsgraph):
            bpy.ops.export_scene.gltf(**_exporter_options(filepath))
    except RuntimeError as err:
        # The operator's error carries the exporter's whole traceback; its last line says why.
        lines = [line.strip() for line in str(err).splitlines() if line.strip()]
        raise CausticError(f"glTF export failed: {lines[-1] if lines else err}") from None
    finally:
        _current = None
    if state.errors:
        raise CausticError("export failed: " + "; ".join(state.errors))
    if not os.path.isfile(filepath):
        raise CausticError("glTF export wrote no file")
    return filepath, state
