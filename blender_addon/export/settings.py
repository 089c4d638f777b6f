"""The render settings: the Caustic panel's values as `scenes[i].extras.caustic` (contract)."""

import bpy
import mathutils

# Blender's default working space: what Caustic computes in when the key is absent.
REC709 = "Linear Rec.709"


def working_space_name():
    """Color Management > Working Space (Blender 5.0; Linear Rec.709 before it)."""
    colorspace = getattr(bpy.data, "colorspace", None)
    if colorspace is None:
        return REC709
    return getattr(colorspace, "working_space", REC709) or REC709


def working_space():
    """`working_space` for a working space other than Linear Rec.709: its name and the linear
    Rec.709 -> working space matrix (rows), Blender's own OCIO transform (mathutils), which the
    binary applies to what it decodes or computes as RGB itself; None for Rec.709."""
    name = working_space_name()
    if name == REC709:
        return None
    cols = [mathutils.Color(v).from_rec709_linear_to_scene_linear() for v in ((1, 0, 0), (0, 1, 0), (0, 0, 1))]
    return {"name": name, "from_rec709": [[float(cols[j][i]) for j in range(3)] for i in range(3)]}


def render_settings(scene, resolution, camera_name, viewport=False):
    """The `extras.caustic` object for a scene: the Caustic panel's values in contract keys
    (`viewport`: for the Rendered viewport or a material preview, which take Simplify's
    viewport Texture Limit, as Cycles' interactive renders do)."""
    props = scene.caustic
    settings = {
        "resolution": [int(resolution[0]), int(resolution[1])],
        "spp": int(props.samples),
        **light_paths(scene),
        "seed": int(props.seed),
        "integrator": props.integrator,
        "light_sampler": props.light_sampler,
        # Film → Transparent off means an opaque background (alpha 1), as in Cycles.
        "transparent": bool(scene.render.film_transparent),
        **pixel_filter(scene),
    }
    limit = texture_limit(scene, viewport)
    if limit is not None:
        settings["texture_limit"] = limit
    gi = fast_gi(scene, viewport)
    if gi is not None:
        settings["fast_gi"] = gi
    cycles = getattr(scene, "cycles", None)
    if scene.render.film_transparent and cycles is not None and cycles.film_transparent_glass:
        # Film → Transparent Glass: the background stays transparent behind glass at most
        # this rough (the binary's path tracer; the other integrators warn).
        settings["transparent_glass"] = float(cycles.film_transparent_roughness)
    if props.integrator == "sppm":
        settings["sppm_iterations"] = int(props.samples)
    if props.integrator == "photon":
        if props.photons > 0:
            settings["photons"] = int(props.photons)
        if props.caustic_photons > 0:
            settings["caustic_photons"] = int(props.caustic_photons)
    if props.use_adaptive_sampling:
        threshold = float(props.adaptive_threshold)
        if threshold == 0.0:
            # Cycles' automatic threshold (scene/integrator.cpp): max(0.001, 1 / samples).
            threshold = max(0.001, 1.0 / int(props.samples))
        settings["noise_threshold"] = threshold
        settings["min_samples"] = int(props.adaptive_min_samples)
    if props.time_limit > 0.0:
        settings["time_limit"] = float(props.time_limit)
    if props.threads > 0:
        settings["threads"] = int(props.threads)
    if camera_name:
        settings["camera"] = camera_name
    space = working_space()
    if space is not None:
        settings["working_space"] = space
    world = scene.world
    if world is not None:
        # The Mist and AO passes' settings live on the world, as in Cycles.
        mist = world.mist_settings
        falloff = {"QUADRATIC": 2.0, "LINEAR": 1.0, "INVERSE_QUADRATIC": 0.5}[mist.falloff]
        settings["mist"] = [float(mist.start), float(mist.depth), falloff]
        settings["ao_distance"] = float(world.light_settings.distance)
    return settings


# Cycles' pixel filters (scene.cycles.pixel_filter_type) as the contract's names, and how much
# wider than Blender's Filter Width Cycles spreads each one's window (scene/film.cpp: Blackman-
# Harris twice, Gaussian three times; the Box is always one pixel, blender/sync.cpp).
_FILTERS = {"BLACKMAN_HARRIS": ("blackman-harris", 2.0), "GAUSSIAN": ("gaussian", 3.0), "BOX": ("box", None)}


def pixel_filter(scene):
    """The contract's `filter` and `filter_width` from the Film panel's Pixel Filter, which
    Blender keeps in the Cycles settings (Caustic's Film panel is Cycles'): the same .blend
    filters alike in both renderers."""
    cycles = getattr(scene, "cycles", None)
    if cycles is None:  # Cycles disabled: Blender's own filter size, Cycles' default type
        return {"filter": "blackman-harris", "filter_width": 2.0 * float(scene.render.filter_size)}
    name, spread = _FILTERS[cycles.pixel_filter_type]
    return {"filter": name, "filter_width": 1.0 if spread is None else spread * float(cycles.filter_width)}


# Cycles' Light Paths defaults (Blender 5.0), taken when Cycles' settings are absent (Cycles
# disabled): a .blend renders as Cycles would render it once Cycles is enabled.
_LIGHT_PATHS_DEFAULTS = {
    "max_bounces": 12,
    "diffuse_bounces": 4,
    "glossy_bounces": 4,
    "transmission_bounces": 12,
    "volume_bounces": 0,
    "transparent_max_bounces": 8,
    "sample_clamp_direct": 0.0,
    "sample_clamp_indirect": 10.0,
    "blur_glossy": 1.0,
    "caustics_reflective": True,
    "caustics_refractive": True,
}


def light_paths(scene):
    """The contract's Light Paths keys from Cycles' Light Paths panel (Caustic's panel draws
    Cycles' properties, as its Film panel does): one source of truth for both renderers."""
    cycles = getattr(scene, "cycles", None)

    def get(name):
        return _LIGHT_PATHS_DEFAULTS[name] if cycles is None else getattr(cycles, name)

    return {
        # Blender counts bounces, the renderer counts scattering events (contract).
        "max_depth": int(get("max_bounces")) + 1,
        "diffuse_max_bounces": int(get("diffuse_bounces")),
        "glossy_max_bounces": int(get("glossy_bounces")),
        "transmission_max_bounces": int(get("transmission_bounces")),
        "volume_max_bounces": int(get("volume_bounces")),
        "transparent_max_bounces": int(get("transparent_max_bounces")),
        "clamp_direct": float(get("sample_clamp_direct")),
        "clamp_indirect": float(get("sample_clamp_indirect")),
        "filter_glossy": float(get("blur_glossy")),
        "caustics_reflective": bool(get("caustics_reflective")),
        "caustics_refractive": bool(get("caustics_refractive")),
    }


def film_exposure(scene):
    """The Film panel's Exposure, a plain factor on the light passes (Cycles' film_exposure);
    1 without Cycles' settings."""
    cycles = getattr(scene, "cycles", None)
    return 1.0 if cycles is None else float(cycles.film_exposure)


def layer_render_settings(scene, view_layer, objects, resolution, camera_name):
    """(settings, warnings) of one view layer's frame: the scene's settings with the layer's
    light groups and shader AOVs. F12 and the farm operator both export through this, so a
    frame rendered on the farm carries the same passes as a local one."""
    from .light_groups import light_group_settings
    from .shader_aovs import shader_aov_settings

    settings = render_settings(scene, resolution, camera_name)
    groups = light_group_settings(view_layer, scene, objects)
    if groups is not None:
        settings["light_groups"] = groups
    aovs, warnings = shader_aov_settings(view_layer)
    if aovs is not None:
        settings["shader_aovs"] = aovs
    layer_samples(scene, view_layer, settings)
    warnings += fast_gi_warnings(settings, objects)
    return settings, warnings


def layer_samples(scene, view_layer, settings):
    """The view layer's own Samples (View Layer > Override > Samples, 0: the scene's), as Cycles'
    Layer Samples setting takes it: Use replaces the scene's count, Bounded caps it, Ignore
    leaves it (Cycles' `BlenderSync::get_layer_samples`)."""
    cycles = getattr(scene, "cycles", None)
    samples = int(getattr(view_layer, "samples", 0))
    mode = getattr(cycles, "use_layer_samples", "USE") if cycles is not None else "USE"
    if samples <= 0 or mode == "IGNORE":
        return
    spp = samples if mode == "USE" else min(samples, settings["spp"])
    settings["spp"] = spp
    if "sppm_iterations" in settings:
        settings["sppm_iterations"] = spp


def fast_gi(scene, viewport=False):
    """Light Paths > Fast GI Approximation as Cycles' sync reads it: the method, AO Bounces
    (Render, or Viewport for interactive renders) and World > Ambient Occlusion's Factor and
    Distance; None when it is off or the scene has no world (Cycles' factor is then 0)."""
    cycles = getattr(scene, "cycles", None)
    if cycles is None or not getattr(cycles, "use_fast_gi", False) or scene.world is None:
        return None
    light = scene.world.light_settings
    return {
        "method": "add" if cycles.fast_gi_method == "ADD" else "replace",
        "bounces": int(cycles.ao_bounces if viewport else cycles.ao_bounces_render),
        "factor": float(light.ao_factor),
        "distance": float(light.distance),
    }


def fast_gi_warnings(settings, objects):
    """What of Fast GI the binary does not follow, named: an object's own AO Distance
    (Object > Visibility), which Cycles takes for rays leaving that object (Replace)."""
    gi = settings.get("fast_gi")
    if gi is None or gi["method"] != "replace":
        return []
    names = sorted(o.name for o in objects if getattr(getattr(o, "cycles", None), "ao_distance", 0.0) > 0.0)
    if not names:
        return []
    return [f"Fast GI: the AO Distance of object(s) {', '.join(names)} is not applied (the world's "
            f"{gi['distance']:g} is used for rays leaving them)"]


def texture_limit(scene, viewport=False):
    """Simplify's Texture Limit in pixels, or None: Cycles shrinks every image whose longer side
    passes it on load (`texture_limit_render` for F12, `texture_limit` for interactive renders),
    and only while Simplify is on; the binary shrinks them the same way."""
    cycles = getattr(scene, "cycles", None)
    if cycles is None or not scene.render.use_simplify:
        return None
    limit = getattr(cycles, "texture_limit" if viewport else "texture_limit_render", "OFF")
    return None if limit == "OFF" else int(limit)
