"""Caustic's panels, and Blender's standard panels opened to the CAUSTIC engine where they apply.

Only controls that change Caustic's render are shown. Left out on purpose: the world (the
exporter drops it and Caustic has no world yet), depth of field and motion blur (dropped by the
exporter), light radius / sun angle (glTF punctual lights are points and directions), material
volume and displacement.
"""

import bpy

ENGINE = "CAUSTIC"

# Standard panels whose settings the export or Blender's own pipeline honour for Caustic.
_COMPAT_PANELS = (
    # Output properties (dimensions, frame range, file output, stamp, post-processing).
    "RENDER_PT_format",
    "RENDER_PT_frame_range",
    "RENDER_PT_time_stretching",
    "RENDER_PT_output",
    "RENDER_PT_output_views",
    "RENDER_PT_output_color_management",
    "RENDER_PT_output_pixel_density",
    "RENDER_PT_encoding",
    "RENDER_PT_encoding_video",
    "RENDER_PT_encoding_audio",
    "RENDER_PT_post_processing",
    "RENDER_PT_stamp",
    "RENDER_PT_stamp_note",
    "RENDER_PT_stamp_burn",
    # Color management applies to any engine's result.
    "RENDER_PT_color_management",
    "RENDER_PT_color_management_working_space",
    "RENDER_PT_color_management_advanced",
    "RENDER_PT_color_management_curves",
    "RENDER_PT_color_management_white_balance",
    # Camera (lens, sensor; the rest is viewport display).
    "DATA_PT_context_camera",
    "DATA_PT_lens",
    "DATA_PT_camera",
    "DATA_PT_camera_display",
    "DATA_PT_camera_display_composition_guides",
    "DATA_PT_camera_safe_areas",
    "DATA_PT_camera_safe_areas_center_cut",
    "DATA_PT_camera_background_image",
    # Light (Caustic's own light panel is below).
    "DATA_PT_context_light",
    # Material: the node tree's surface, converted to glTF PBR by the exporter.
    "EEVEE_MATERIAL_PT_context_material",
    "EEVEE_MATERIAL_PT_surface",
)


class CausticButtonsPanel:
    """Shared poll: only when Caustic is the scene's engine."""

    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    COMPAT_ENGINES = {ENGINE}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


class CAUSTIC_PT_render(CausticButtonsPanel, bpy.types.Panel):
    """Render settings: integrator, samples, time limit, light sampling, seed, threads (bounces: Light Paths)."""

    bl_label = "Caustic"
    bl_context = "render"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        settings = context.scene.caustic

        layout.prop(settings, "integrator")
        if settings.integrator == "photon":
            layout.prop(settings, "photons")
            layout.prop(settings, "caustic_photons")
        row = layout.row(heading="Noise Threshold")
        # SPPM and VCM iterate over every pixel together: no pixel can stop on its own.
        row.active = settings.integrator not in {"sppm", "vcm"}
        row.prop(settings, "use_adaptive_sampling", text="")
        sub = row.row()
        sub.active = settings.use_adaptive_sampling
        sub.prop(settings, "adaptive_threshold", text="")
        col = layout.column(align=True)
        col.prop(settings, "samples", text="Max Samples" if settings.use_adaptive_sampling else "Samples")
        sub = col.column(align=True)
        sub.active = settings.use_adaptive_sampling
        sub.prop(settings, "adaptive_min_samples", text="Min Samples")
        col.prop(settings, "time_limit")
        layout.prop(settings, "use_denoising")
        layout.prop(settings, "light_sampler")
        layout.prop(settings, "seed")
        layout.prop(settings, "threads")
        layout.prop(settings, "use_farm")
        row = layout.row(align=True)
        row.operator("caustic.render_farm", text="Render on Farm", icon="RENDER_STILL").animation = False
        row.operator("caustic.render_farm", text="Animation on Farm", icon="RENDER_ANIMATION").animation = True


class CAUSTIC_PT_light(CausticButtonsPanel, bpy.types.Panel):
    """The light settings Caustic renders: type, colour, power, shape."""

    bl_label = "Light"
    bl_context = "data"

    @classmethod
    def poll(cls, context):
        return context.light is not None and super().poll(context)

    def draw(self, context):
        layout = self.layout
        light = context.light
        layout.row().prop(light, "type", expand=True)
        layout.use_property_split = True

        col = layout.column()
        row = col.row(heading="Temperature")
        row.prop(light, "use_temperature", text="")
        sub = row.row()
        sub.active = light.use_temperature
        sub.prop(light, "temperature", text="")
        col.prop(light, "color", text="Tint" if light.use_temperature else "Color")

        col = layout.column()
        col.prop(light, "energy")
        col.prop(light, "exposure")
        if light.type == "AREA":
            col.prop(light, "normalize")
            col = layout.column()
            col.prop(light, "shape")
            sub = col.column(align=True)
            if light.shape in {"SQUARE", "DISK"}:
                sub.prop(light, "size")
            else:
                sub.prop(light, "size", text="Size X")
                sub.prop(light, "size_y", text="Y")


class CAUSTIC_PT_light_spot(CausticButtonsPanel, bpy.types.Panel):
    """The spot cone (exported as KHR_lights_punctual inner/outer cone angles)."""

    bl_label = "Beam Shape"
    bl_context = "data"
    bl_parent_id = "CAUSTIC_PT_light"

    @classmethod
    def poll(cls, context):
        return context.light is not None and context.light.type == "SPOT" and super().poll(context)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        light = context.light
        col = layout.column()
        col.prop(light, "spot_size", text="Angle")
        col.prop(light, "spot_blend", text="Blend", slider=True)
        col.prop(light, "show_cone")


class CAUSTIC_PT_film(CausticButtonsPanel, bpy.types.Panel):
    """Film: exposure, pixel filter, transparency and transparent glass, kept where Cycles keeps them (its scene
    settings), so a .blend made for Cycles renders alike (export/settings.py)."""

    bl_label = "Film"
    bl_context = "render"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        scene = context.scene
        cycles = getattr(scene, "cycles", None)
        if cycles is not None:
            layout.prop(cycles, "film_exposure")
            layout.prop(cycles, "pixel_filter_type", text="Pixel Filter")
            sub = layout.column()
            sub.active = cycles.pixel_filter_type != "BOX"  # Cycles' Box is always one pixel
            sub.prop(cycles, "filter_width", text="Width")
        layout.prop(scene.render, "film_transparent", text="Transparent")
        if cycles is not None:
            sub = layout.column()
            sub.active = scene.render.film_transparent
            sub.prop(cycles, "film_transparent_glass", text="Transparent Glass")
            sub = sub.column()
            sub.active = scene.render.film_transparent and cycles.film_transparent_glass
            sub.prop(cycles, "film_transparent_roughness", text="Roughness Threshold")


class CAUSTIC_PT_light_paths(CausticButtonsPanel, bpy.types.Panel):
    """Light Paths: Cycles' own settings (bounce limits, clamping, caustics), drawn here so that
    one value serves both renderers and a .blend made for Cycles renders alike
    (export/settings.py `light_paths`)."""

    bl_label = "Light Paths"
    bl_context = "render"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        return getattr(context.scene, "cycles", None) is not None and super().poll(context)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        cycles = context.scene.cycles
        col = layout.column(align=True)
        col.prop(cycles, "max_bounces", text="Total")
        col.prop(cycles, "diffuse_bounces", text="Diffuse")
        col.prop(cycles, "glossy_bounces", text="Glossy")
        col.prop(cycles, "transmission_bounces", text="Transmission")
        col.prop(cycles, "volume_bounces", text="Volume")
        col.prop(cycles, "transparent_max_bounces", text="Transparent")
        col = layout.column(align=True)
        col.prop(cycles, "sample_clamp_direct", text="Clamp Direct")
        col.prop(cycles, "sample_clamp_indirect", text="Clamp Indirect")
        layout.prop(cycles, "blur_glossy", text="Filter Glossy")
        col = layout.column(heading="Caustics", align=True)
        col.prop(cycles, "caustics_reflective", text="Reflective")
        col.prop(cycles, "caustics_refractive", text="Refractive")


classes = (CAUSTIC_PT_render, CAUSTIC_PT_light_paths, CAUSTIC_PT_film, CAUSTIC_PT_light, CAUSTIC_PT_light_spot)


def _compat_panels():
    for name in _COMPAT_PANELS:
        panel = getattr(bpy.types, name, None)
        if panel is not None and hasattr(panel, "COMPAT_ENGINES"):
            yield panel


def register():
    """Register Caustic's panels and open the standard ones to the engine."""
    for cls in classes:
        bpy.utils.register_class(cls)
    for panel in _compat_panels():
        panel.COMPAT_ENGINES.add(ENGINE)


def unregister():
    """Undo register()."""
    for panel in _compat_panels():
        panel.COMPAT_ENGINES.discard(ENGINE)
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
