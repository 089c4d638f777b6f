"""The renderer's EXR into Blender's render result, pass by pass.

Facts (bpy 5.0.1): `RenderLayer.load_from_file(path)` reads channels named `<Pass>.<Ch>` (the
contract's `Combined.R`, `Depth.Z`, ...) or `<ViewLayer>.<Pass>.<Ch>`, flipping rows to Blender's
bottom-up order; a channel it does not find leaves the pass black with only a console warning,
and `RenderResult.load_from_file` accepts the `<ViewLayer>.` form only. A pass only exists in the
result when it was registered (`update_render_passes`).
"""

import struct

import numpy as np

from .errors import CausticError
from .export.shader_aovs import valid_aovs

# The view layer's passes Caustic renders: (where the flag lives: "" the view layer, "cycles"
# its Cycles settings; the flag; the binary's `--passes` token; then the name, channels,
# channel ids and type as RenderEngine.register_pass wants them). Names and channels are
# Cycles' (checked on bpy 5.0.1 with every pass enabled under Cycles).
VIEW_LAYER_PASSES = (
    ("", "use_pass_z", "z", "Depth", 1, "Z", "VALUE"),
    ("", "use_pass_mist", "mist", "Mist", 1, "Z", "VALUE"),
    ("", "use_pass_normal", "normal", "Normal", 3, "XYZ", "VECTOR"),
    ("", "use_pass_position", "position", "Position", 3, "XYZ", "VECTOR"),
    ("", "use_pass_uv", "uv", "UV", 3, "UVA", "VECTOR"),
    ("", "use_pass_object_index", "object_index", "Object Index", 1, "X", "VALUE"),
    ("", "use_pass_material_index", "material_index", "Material Index", 1, "X", "VALUE"),
    ("", "use_pass_diffuse_direct", "diffuse_direct", "Diffuse Direct", 3, "RGB", "COLOR"),
    ("", "use_pass_diffuse_indirect", "diffuse_indirect", "Diffuse Indirect", 3, "RGB", "COLOR"),
    ("", "use_pass_diffuse_color", "diffuse_color", "Diffuse Color", 3, "RGB", "COLOR"),
    ("", "use_pass_glossy_direct", "glossy_direct", "Glossy Direct", 3, "RGB", "COLOR"),
    ("", "use_pass_glossy_indirect", "glossy_indirect", "Glossy Indirect", 3, "RGB", "COLOR"),
    ("", "use_pass_glossy_color", "glossy_color", "Glossy Color", 3, "RGB", "COLOR"),
    ("", "use_pass_transmission_direct", "transmission_direct", "Transmission Direct", 3, "RGB", "COLOR"),
    ("", "use_pass_transmission_indirect", "transmission_indirect", "Transmission Indirect", 3, "RGB",
     "COLOR"),
    ("", "use_pass_transmission_color", "transmission_color", "Transmission Color", 3, "RGB", "COLOR"),
    ("cycles", "use_pass_volume_direct", "volume_direct", "Volume Direct", 3, "RGB", "COLOR"),
    ("cycles", "use_pass_volume_indirect", "volume_indirect", "Volume Indirect", 3, "RGB", "COLOR"),
    ("", "use_pass_emit", "emit", "Emission", 3, "RGB", "COLOR"),
    ("", "use_pass_environment", "environment", "Environment", 3, "RGB", "COLOR"),
    ("", "use_pass_ambient_occlusion", "ambient_occlusion", "Ambient Occlusion", 3, "RGB", "COLOR"),
    ("cycles", "use_pass_shadow_catcher", "shadow_catcher", "Shadow Catcher", 3, "RGB", "COLOR"),
    ("cycles", "denoising_store_passes", "denoising_albedo", "Denoising Albedo", 3, "RGB", "COLOR"),
    ("cycles", "denoising_store_passes", "denoising_normal", "Denoising Normal", 3, "XYZ", "VECTOR"),
    # Screen-space motion to the previous and next frames, in pixels (export/motion.py).
    ("", "use_pass_vector", "vector", "Vector", 4, "XYZW", "VECTOR"),
)

# Light passes and light groups: the integrators that file light by the first bounce (contract);
# all of them, in farm chunks too (SPPM's chunks keep them as its Combined: means times iterations).
LIGHT_INTEGRATORS = ("path", "bdpt", "vcm", "photon", "sppm")
LIGHT_TOKENS = frozenset(t for _, _, t, *_ in VIEW_LAYER_PASSES
                         if t.endswith(("_direct", "_indirect", "_color")) or t in ("emit", "environment"))
# Cryptomatte layers: the view layer's flag, the binary's token and Blender's pass prefix; each
# layer is ceil(levels / 2) passes of 4 channels (two ranks of id and coverage), as Cycles'.
CRYPTOMATTE_LAYERS = (
    ("use_pass_cryptomatte_object", "cryptomatte_object", "CryptoObject"),
    ("use_pass_cryptomatte_material", "cryptomatte_material", "CryptoMaterial"),
    ("use_pass_cryptomatte_asset", "cryptomatte_asset", "CryptoAsset"),
)
# The Shadow Catcher pass: every integrator splits camera paths at catchers (the set stays for
# an integrator that may not).
CATCHER_TOKENS = frozenset({"shadow_catcher"})
CATCHER_INTEGRATORS = frozenset({"path", "bdpt", "vcm", "photon", "sppm"})

# The binary's `--passes` token for one `Combined_<group>` pass per light group of the scene (whose
# groups the exporter writes, export/light_groups.py).
LIGHT_GROUPS_TOKEN = "light_groups"
# The binary's `--passes` token for the view layer's shader AOVs, one pass each as the exporter
# lists them (export/shader_aovs.py), with Cycles' channels: a colour RGBA, a value X.
SHADER_AOVS_TOKEN = "shader_aovs"

# Passes of the view layer that Caustic does not render yet (named in a warning when on).
UNSUPPORTED = (
    ("", "use_pass_shadow", "Shadow"),
    # Cycles' Denoising Data has a third pass, the distance along the denoising features' path
    # (film/denoising_passes.h); the binary writes the normal and albedo only.
    ("cycles", "denoising_store_passes", "Denoising Depth"),
)

# The passes the Film panel's Exposure scales, as Cycles' (scene/pass.cpp: `use_exposure`): the
# light passes, Combined's colour (not its alpha) before denoising too, and each light group's
# Combined_<group>.
EXPOSED_PASSES = frozenset({
    "Combined", "Noisy Image", "Emission", "Environment", "Shadow Catcher",
    *(f"{kind} {part}" for kind in ("Diffuse", "Glossy", "Transmission", "Volume")
      for part in ("Direct", "Indirect")),
})

# The binary writes normals and positions in glTF axes (Y up); Blender's passes are in Blender's
# world axes (Z up), as Cycles writes them: blender = (x, -z, y).
_AXIS_PASSES = ("Normal", "Denoising Normal", "Position")


def _flag(view_layer, owner, attr):
    holder = getattr(view_layer, owner, None) if owner else view_layer
    return bool(getattr(holder, attr, False)) if holder is not None else False


def enabled_passes(view_layer):
    """The rows of VIEW_LAYER_PASSES whose flag is on in `view_layer`."""
    return [row for row in VIEW_LAYER_PASSES if _flag(view_layer, row[0], row[1])]


def light_group_passes(view_layer):
    """The pass names of the view layer's light groups, as Cycles names them: `Combined_<group>`."""
    return [f"Combined_{group.name}" for group in getattr(view_layer, "lightgroups", ())]


def enabled_cryptomatte(view_layer):
    """(token, pass names) of each Cryptomatte layer enabled in `view_layer`."""
    count = (min(16, view_layer.pass_cryptomatte_depth) + 1) // 2
    return [(token, [f"{prefix}{i:02}" for i in range(count)])
            for attr, token, prefix in CRYPTOMATTE_LAYERS if _flag(view_layer, "", attr)]


def pass_request(view_layer, integrator, motion_blur=False):
    """(`--passes` list, warnings): the enabled passes that `integrator` renders (farm chunks
    carry them all), and a warning naming each enabled pass that will be missing from the result. With `motion_blur` on, Vector stays black, as in Cycles (whose
    panel greys it out then): its motion is to the neighbouring frames, not over the shutter."""
    tokens, warnings = [], []
    rows = [(token, name) for _, _, token, name, *_ in enabled_passes(view_layer)]
    rows += [(token, f"Cryptomatte {token.rpartition('_')[2].capitalize()}")
             for token, _ in enabled_cryptomatte(view_layer)]
    for token, name in rows:
        if token == "vector" and motion_blur:
            warnings.append("the Vector pass needs motion blur off (as in Cycles); it stays black")
        elif token in CATCHER_TOKENS and integrator not in CATCHER_INTEGRATORS:
            warnings.append(f"the {name} pass is rendered by the path, BDPT, VCM, photon and SPPM integrators only; "
                            f"it stays black with '{integrator}'")
        elif token in LIGHT_TOKENS and integrator not in LIGHT_INTEGRATORS:
            warnings.append(f"the {name} pass is rendered by the path, BDPT, VCM and photon integrators only; "
                            f"it stays black with '{integrator}'")
        else:
            tokens.append(token)
    for owner, attr, name in UNSUPPORTED:
        if _flag(view_layer, owner, attr):
            warnings.append(f"the {name} pass is not rendered by Caustic yet; it stays black")
    groups = light_group_passes(view_layer)
    if groups and integrator not in LIGHT_INTEGRATORS:
        warnings.append(f"the light group passes ({', '.join(groups)}) are rendered by the path, BDPT, VCM and "
                        f"photon integrators only; they stay black with '{integrator}'")
    elif groups:
        tokens.append(LIGHT_GROUPS_TOKEN)
    aovs = valid_aovs(view_layer)
    if aovs:
        tokens.append(SHADER_AOVS_TOKEN)
    return ",".join(tokens) or "none", warnings


def cryptomatte_arguments(view_layer, passes):
    """The binary's `--cryptomatte-levels` for the view layer's levels when `passes` (the
    `--passes` list) asks for a Cryptomatte layer."""
    if any(token in passes.split(",") for _, token, _ in CRYPTOMATTE_LAYERS):
        return ["--cryptomatte-levels", str(view_layer.pass_cryptomatte_depth)]
    return []


def register_passes(engine, scene, view_layer):
    """Declare exactly the view layer's enabled passes that Caustic writes, so that they appear
    in the compositor's Render Layers node (Combined always)."""
    engine.register_pass(scene, view_layer, "Combined", 4, "RGBA", "COLOR")
    for _, _, _, name, channels, chan_id, kind in enabled_passes(view_layer):
        engine.register_pass(scene, view_layer, name, channels, chan_id, kind)
    for _, names in enabled_cryptomatte(view_layer):
        for name in names:
            engine.register_pass(scene, view_layer, name, 4, "rgba", "COLOR")
    for name in light_group_passes(view_layer):
        engine.register_pass(scene, view_layer, name, 3, "RGB", "COLOR")
    for aov in valid_aovs(view_layer):
        # Cycles' declaration (its engine.py): a value AOV is X, a colour RGBA.
        if aov.type == "VALUE":
            engine.register_pass(scene, view_layer, aov.name, 1, "X", "VALUE")
        else:
            engine.register_pass(scene, view_layer, aov.name, 4, "RGBA", "COLOR")
    settings = getattr(scene, "caustic", None)
    if settings is not None and settings.use_denoising and not settings.use_farm:
        # The Combined before denoising, which the binary writes beside it (Cycles' name).
        engine.register_pass(scene, view_layer, "Noisy Image", 4, "RGBA", "COLOR")


def exr_size(path):
    """Width and height of an OpenEXR file's data window (raises CausticError if unreadable)."""
    try:
        with open(path, "rb") as f:
            head = f.read(65536)
    except OSError as err:
        raise CausticError(f"cannot read the rendered image {path}: {err.strerror}") from None
    if len(head) < 8 or struct.unpack_from("<i", head, 0)[0] != 20000630:
        raise CausticError(f"the rendered image is not an OpenEXR file: {path}")
    key = b"dataWindow\0box2i\0"
    at = head.find(key)
    if at < 0:
        raise CausticError(f"the rendered image has no data window: {path}")
    x0, y0, x1, y1 = struct.unpack_from("<4i", head, at + len(key) + 4)
    return x1 - x0 + 1, y1 - y0 + 1


def camera_rotation(camera):
    """Cycles' world-to-camera rotation of `camera` (x right, y up, z forward; its scale
    cleared, as Cycles' sync clears it), as a 3x3 array, or None without a camera."""
    if camera is None:
        return None
    columns = np.array(camera.matrix_world.to_3x3().normalized(), dtype=np.float32)
    rotation = columns.T.copy()  # rows: the camera's right, up and back axes in the world
    rotation[2] *= -1.0  # Cycles' camera looks down +z (blender/camera.cpp scales z by -1)
    return rotation


def load(result, path, exposure=1.0, to_camera=None):
    """Load the EXR at `path` into the first layer of `result` (sizes must match), its light
    passes times the Film panel's `exposure` (export.film_exposure), its Denoising Normal
    turned into the camera space of `to_camera` (camera_rotation), as Cycles writes it
    (film_write_denoising_features_surface: worldtocamera); the binary writes it in the world's."""
    layer = result.layers[0]
    combined = layer.passes.find_by_name("Combined", "")
    width, height = exr_size(path)
    expected = len(combined.rect) if combined else None
    if expected is not None and expected != width * height:
        raise CausticError(f"the rendered image is {width}x{height}, Blender expects "
                           f"{expected} pixels")
    try:
        layer.load_from_file(path)
    except RuntimeError as err:
        raise CausticError(f"cannot load the rendered image: {err}") from None
    for name in _AXIS_PASSES:
        render_pass = layer.passes.find_by_name(name, "")
        if render_pass is not None and render_pass.channels == 3:
            _gltf_to_blender_axes(render_pass)
            if name == "Denoising Normal" and to_camera is not None:
                _rotate(render_pass, to_camera)
    if exposure != 1.0:
        for render_pass in layer.passes:
            if render_pass.name in EXPOSED_PASSES or render_pass.name.startswith("Combined_"):
                _scale_colour(render_pass, exposure)


def store_metadata(engine, path, view_layer_name):
    """Put the EXR's Cryptomatte names into the render's metadata, as Cycles does: saved with
    the image, they let compositors name what they isolate. Cycles stamps the engine's whole
    result (`RenderEngine.get_result`); the tile result of `begin_result` keeps no stamp."""
    fields = cryptomatte_metadata(path, view_layer_name)
    if fields:
        whole = engine.get_result()
        for key, value in fields.items():
            whole.stamp_data_add_field(key, value)


def cryptomatte_metadata(path, view_layer_name):
    """The Cryptomatte header attributes of the binary's EXR, keyed as Cycles keys them in the
    render result: the binary names a layer `CryptoObject` (its channels' prefix), Blender
    `<view layer>.CryptoObject`, and the key holds the first 7 hex digits of the name's hash."""
    attributes = exr_text_attributes(path)
    out = {}
    for key, name in attributes.items():
        parts = key.split("/")
        if len(parts) != 3 or parts[0] != "cryptomatte" or parts[2] != "name":
            continue
        full = f"{view_layer_name}.{name}"
        prefix = f"cryptomatte/{murmur3_32(full.encode()):08x}"[:len("cryptomatte/") + 7]
        out[f"{prefix}/name"] = full
        for field in ("hash", "conversion", "manifest"):
            value = attributes.get(f"cryptomatte/{parts[1]}/{field}")
            if value is not None:
                out[f"{prefix}/{field}"] = value
    return out


def exr_text_attributes(path):
    """The header attributes of type `string` of an OpenEXR file, by name."""
    try:
        with open(path, "rb") as f:
            data = f.read(1 << 16)
            while True:
                attributes, complete = _parse_header(data)
                if complete:
                    return attributes
                more = f.read(len(data))
                if not more:
                    raise CausticError(f"the rendered image's header is cut short: {path}")
                data += more
    except OSError as err:
        raise CausticError(f"cannot read the rendered image {path}: {err.strerror}") from None


def _parse_header(data):
    """(string attributes, whether the header's end was reached) of the EXR bytes `data`."""
    attributes, pos = {}, 8
    while pos < len(data):
        if data[pos] == 0:
            return attributes, True
        name_end = data.find(b"\0", pos)
        type_end = data.find(b"\0", name_end + 1) if name_end >= 0 else -1
        if type_end < 0 or type_end + 5 > len(data):
            return attributes, False
        (size,) = struct.unpack_from("<i", data, type_end + 1)
        start = type_end + 5
        if start + size > len(data):
            return attributes, False
        if data[name_end + 1:type_end] == b"string":
            attributes[data[pos:name_end].decode("utf-8", "replace")] = \
                data[start:start + size].decode("utf-8", "replace")
        pos = start + size
    return attributes, False


def murmur3_32(data, seed=0):
    """MurmurHash3 (x86, 32 bits), the hash Cryptomatte names its layers and entities by."""
    c1, c2, mask = 0xcc9e2d51, 0x1b873593, 0xffffffff
    h = seed
    whole = len(data) // 4 * 4
    for i in range(0, whole, 4):
        k = int.from_bytes(data[i:i + 4], "little")
        k = (k * c1) & mask
        k = ((k << 15) | (k >> 17)) & mask
        h ^= (k * c2) & mask
        h = ((h << 13) | (h >> 19)) & mask
        h = (h * 5 + 0xe6546b64) & mask
    tail = data[whole:]
    if tail:
        k = int.from_bytes(tail, "little")
        k = (k * c1) & mask
        k = ((k << 15) | (k >> 17)) & mask
        h ^= (k * c2) & mask
    h ^= len(data)
    h ^= h >> 16
    h = (h * 0x85ebca6b) & mask
    h ^= h >> 13
    h = (h * 0xc2b2ae35) & mask
    return h ^ (h >> 16)


def _gltf_to_blender_axes(render_pass):
    pixels = np.empty(len(render_pass.rect) * 3, dtype=np.float32)
    render_pass.rect.foreach_get(pixels)
    xyz = pixels.reshape(-1, 3)
    converted = np.empty_like(xyz)
    converted[:, 0] = xyz[:, 0]
    converted[:, 1] = -xyz[:, 2]
    converted[:, 2] = xyz[:, 1]
    render_pass.rect.foreach_set(converted.ravel())


def _rotate(render_pass, rotation):
    pixels = np.empty(len(render_pass.rect) * 3, dtype=np.float32)
    render_pass.rect.foreach_get(pixels)
    render_pass.rect.foreach_set((pixels.reshape(-1, 3) @ rotation.T).astype(np.float32).ravel())


def _scale_colour(render_pass, factor):
    """Multiply a pass's colour channels by `factor` (a fourth channel, alpha, is kept)."""
    channels = render_pass.channels
    pixels = np.empty(len(render_pass.rect) * channels, dtype=np.float32)
    render_pass.rect.foreach_get(pixels)
    values = pixels.reshape(-1, channels)
    values[:, :3] *= np.float32(factor)
    render_pass.rect.foreach_set(pixels)
