"""Caustic's settings: per scene (render settings) and per installation (add-on preferences).

Only settings the renderer implements today live here; each maps to one command-line flag or
one key of `scenes[i].extras.caustic` (docs/contract.md).
"""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty

# (identifier, UI name, description); the identifier is the renderer's integrator name.
INTEGRATORS = [
    ("path", "Path Tracing", "Unidirectional path tracing with next-event estimation and MIS"),
    ("bdpt", "Bidirectional Path Tracing", "Camera and light subpaths joined by every strategy with MIS "
     "(unbiased; finds caustics and light through small openings that path tracing misses)"),
    ("photon", "Photon Mapping", "Jensen's photon mapping: caustic and global photon maps, final gather "
     "(fast, smooth caustics; slightly biased)"),
    ("sppm", "Progressive Photon Mapping", "Stochastic progressive photon mapping: consistent, converges "
     "to the path-traced image; Samples sets the number of iterations"),
    ("vcm", "Vertex Connection and Merging", "Bidirectional path tracing and photon merging combined by MIS "
     "(consistent; diffuse light like BDPT, caustics like photon mapping): the integrator to pick when "
     "unsure. Samples sets the number of iterations"),
]


# (identifier, UI name, description); the identifier is the renderer's light sampler name.
LIGHT_SAMPLERS = [
    ("tree", "Light Tree", "Prefer the lights near and facing each shading point (as Cycles' light "
     "tree); best with many lights"),
    ("power", "Power", "Choose lights in proportion to their power, wherever the shading point is"),
]


class CausticRenderSettings(bpy.types.PropertyGroup):
    """Render settings stored on the scene (`scene.caustic`)."""

    integrator: EnumProperty(
        name="Integrator",
        description="Light transport algorithm",
        items=INTEGRATORS,
        default="path",
    )
    light_sampler: EnumProperty(
        name="Light Sampling",
        description="How next-event estimation chooses the light to sample",
        items=LIGHT_SAMPLERS,
        default="tree",
    )
    photons: IntProperty(
        name="Photons",
        description="Photons in the global map (Photon Mapping; 0 = the renderer's default)",
        default=0,
        min=0,
        soft_max=10_000_000,
    )
    caustic_photons: IntProperty(
        name="Caustic Photons",
        description="Photons in the caustic map (Photon Mapping; 0 = the renderer's default)",
        default=0,
        min=0,
        soft_max=10_000_000,
    )
    samples: IntProperty(
        name="Samples",
        description="Samples per pixel",
        default=64,
        min=1,
        soft_max=4096,
    )
    # Cycles' names and meanings (scene.cycles.*); off by default, unlike Cycles, so that a
    # scene made before these existed renders as it did.
    use_adaptive_sampling: BoolProperty(
        name="Noise Threshold",
        description="Automatically reduce the number of samples per pixel based on estimated noise level "
        "(path tracing, bidirectional and photon mapping; progressive photon mapping ignores it)",
        default=False,
    )
    adaptive_threshold: FloatProperty(
        name="Noise Threshold",
        description="Noise level step to stop sampling at, lower values reduce noise at the cost of render "
        "time. Zero for automatic setting based on number of AA samples",
        default=0.01,
        min=0.0,
        max=1.0,
        soft_min=0.001,
        step=0.1,
        precision=4,
    )
    adaptive_min_samples: IntProperty(
        name="Min Samples",
        description="Minimum AA samples for adaptive sampling, to discover noisy features before stopping "
        "sampling. Zero for automatic setting based on noise threshold",
        default=0,
        min=0,
        max=4096,
    )
    use_denoising: BoolProperty(
        name="Denoise",
        description="Denoise the rendered image with Intel Open Image Denoise (the copy Blender ships); "
        "the noisy image is kept as the Noisy Image pass",
        default=False,
    )
    time_limit: FloatProperty(
        name="Time Limit",
        description="Stop rendering after this many seconds, even if not all samples are done "
        "(0 = no limit)",
        default=0.0,
        min=0.0,
        subtype="TIME_ABSOLUTE",
        unit="TIME_ABSOLUTE",
    )
    seed: IntProperty(
        name="Seed",
        description="Seed of the sample pattern",
        default=0,
        min=0,
    )
    threads: IntProperty(
        name="Threads",
        description="Number of render threads (0 = all cores)",
        default=0,
        min=0,
        max=1024,
    )
    use_farm: BoolProperty(
        name="Render on Farm",
        description="Render (F12) and Render Animation send each frame to the Dask render farm "
        "set in the add-on preferences, split into sample chunks that merge into exactly the "
        "local image; progress, cancel and the result as for a local render",
        default=False,
    )


class CausticPreferences(bpy.types.AddonPreferences):
    """Per-installation settings: where the renderer binary lives."""

    bl_idname = __package__

    binary_path: StringProperty(
        name="Caustic Binary",
        description="Path to the caustic executable. Leave empty to use the binary shipped "
        "with the extension, or `caustic` on PATH",
        subtype="FILE_PATH",
        default="",
    )
    farm_python: StringProperty(
        name="Farm Python",
        description="Python with caustic_farm and Dask installed, which runs Render on Farm "
        "(empty: $CAUSTIC_FARM_PYTHON)",
        subtype="FILE_PATH",
        default="",
    )
    farm_scheduler: StringProperty(
        name="Farm Scheduler",
        description="Dask scheduler address (tcp://host:8786, tls://...). Empty: a local cluster "
        "on 127.0.0.1",
        default="",
    )
    farm_chunks: IntProperty(
        name="Chunks per Frame",
        description="Sample chunks each frame is split into on the farm",
        default=4,
        min=1,
        max=4096,
    )

    def draw(self, context):
        """Show the binary path and which binary will actually be used, and the farm settings."""
        from . import runner

        layout = self.layout
        layout.prop(self, "binary_path")
        layout.prop(self, "farm_python")
        layout.prop(self, "farm_scheduler")
        layout.prop(self, "farm_chunks")
        try:
            found = runner.find_binary()
            layout.label(text=f"Using: {found}", icon="CHECKMARK")
        except runner.CausticError as err:
            layout.label(text=str(err), icon="ERROR")


classes = (CausticRenderSettings, CausticPreferences)


def register():
    """Register the property groups and attach the scene settings."""
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.caustic = PointerProperty(type=CausticRenderSettings)


def unregister():
    """Detach the scene settings and unregister the property groups."""
    del bpy.types.Scene.caustic
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
