"""The one Caustic export in progress, shared between `export_scene` and the exporter's hooks.

The hooks are no-ops outside a Caustic export (`current()` is None), so that a user's ordinary
glTF export is not changed by having Caustic enabled.
"""

from contextlib import contextmanager

_current = None


class ExportState:
    """What one Caustic export hands to the hooks and what the hooks hand back."""

    def __init__(self, settings):
        self.settings = settings
        self.pixel_aspect = (1.0, 1.0)  # the scene's, for the camera's sensor fit
        self.area_lights = []  # names of the nodes that got CAUSTIC_lights_area
        self.scenes = 0  # scenes that got extras.caustic
        self.solid_materials = []  # transmissive materials marked as solids
        # The one glTF material given to primitives without a material (meshes.py), shared so
        # that the exporter writes it once.
        self.default_material = None
        self.warnings = []
        self.depsgraph = None  # the render depsgraph (evaluated meshes and objects for node graphs)
        self.graphs = {}  # material pointer -> node_graph.Graph or None, built once per export
        self.material_meshes = None  # original material pointer -> {pointer: evaluated mesh} using it
        self.material_override = None  # the view layer's Material Override (a Blender material)
        self.override_material = None  # its glTF material, built once, given to every primitive
        self.scaled_lights = set()  # ids of KHR light dicts already scaled by a light node tree
        self.negative_lights = {}  # id of a KHR light dict -> its power was negative (lights.py)
        self._image_writer = None
        self.motion = None  # motion.Motion: the steps of moving objects, or None
        self.only = None  # names of the only objects to export (object_filter.py), or None: all
        self.colour_attribute = None  # the colour attribute exported as COLOR_0 by name, or None
        self.object_names = set()  # Object attributes the graphs read (attributes.py)
        self.instancer_names = set()  # Instancer attributes the graphs read (attributes.py)
        self.nonfinite = {}  # object name -> (NaN vertices, ambiguous), found before the export (nonfinite.py)
        self.nonfinite_meshes = set()  # ids of glTF meshes whose NaN-vertex triangles were dropped (nonfinite.py)
        self.node_objects = {}  # id of an exporter node -> its Blender object's name (instancer_children.py)
        self.tile_uv_accessors = set()  # ids of UV accessors moved back to their UDIM tile (udim_split.py)
        self.opaque_iors = {}  # glTF material name -> the IOR the exporter strips (materials.restore_opaque_iors)
        # The exporter logs and swallows hook exceptions: the hooks record them here and
        # export_scene raises them afterwards.
        self.errors = []


    def image_writer(self, gltf_folder):
        """The export's one node_images.ImageWriter (an image used twice is written once)."""
        if self._image_writer is None:
            from .node_images import ImageWriter
            self._image_writer = ImageWriter(gltf_folder)
        return self._image_writer

    def image_entries(self):
        """The node-graph images this export wrote: image pointer -> the contract's entry (None
        for an image without pixels); the viewport's graph edits name them (viewport_graphs.py)."""
        return dict(self._image_writer.written) if self._image_writer is not None else {}


def current():
    """The state of the Caustic export in progress, or None."""
    return _current


@contextmanager
def exporting(state):
    """Make `state` the current export's for the duration of the block."""
    global _current
    _current = state
    try:
        yield state
    finally:
        _current = None
