"""Scene export: Blender's own glTF exporter, plus Caustic's data through its user-extension hooks.

`export_scene` is the entry point; one module per Blender concept holds what the exporter leaves
out of it or writes differently from what Cycles renders (docs/contract.md):

| module | job |
|---|---|
| `settings.py` | the render settings: `scenes[i].extras.caustic` |
| `camera.py` | lens shift and depth of field: `CAUSTIC_camera` |
| `lights.py` | area lights (`CAUSTIC_lights_area`), light shapes (`CAUSTIC_lights_punctual`), spot |
|  | angles, light node trees' strength and colour |
| `light_nodes.py` | a light node tree beyond an Emission's two numbers as its graph (`nodes`), IES files in `caustic_ies/` |
| `light_temperature.py` | punctual lights' temperature folded into their colour while the exporter runs (it fails on it) |
| `hollow_groups.py` | links from node groups without a Group Output taken out while the exporter runs (it fails on them) |
| `world.py` | the world's Background and environment image: `CAUSTIC_world` |
| `materials.py` | shader nodes the exporter cannot read, solid glass, coat, warnings |
| `node_graph.py` | a material's whole shader graph for the renderer: `CAUSTIC_materials_nodes` |
| `node_images.py` | the graphs' images, written beside the glTF in `caustic_nodes/` |
| `media.py` | subsurface and the Volume output: `CAUSTIC_materials_subsurface`, `CAUSTIC_materials_medium` |
| `meshes.py` | TEXCOORD_n for textured meshes without a UV map; `CAUSTIC_texspace` extras |
| `attributes.py` | attributes read by name as Cycles reads them: `_CAUSTIC_*` vertex attributes (named, |
|  | Pointiness, Random Per Island), `CAUSTIC_object_attributes` node extras, View Layer constants |
| `nodes.py` | reading shader node trees (shared) |
| `gltf_objects.py` | building the exporter's glTF objects (extensions, accessors) |
| `gltf_hooks.py` | the hook class the exporter calls, and making sure it finds it |
| `depsgraph.py` | pointing the exporter at the render depsgraph |
| `state.py` | the export in progress, shared with the hooks |
| `view_layer.py` | the view layer's excluded collections left out of the exporter's tree (instances kept); the Material Override is applied in `meshes.py` |
| `volumes.py` | volume objects: their grids from the .vdb into `caustic_volumes/*.cvol`, `CAUSTIC_volume` |
| `curves.py` | hair particle systems and Curves objects: `CAUSTIC_curves`, appended after the exporter ran |
| `points.py` | point clouds (Point Cloud objects, Geometry Nodes' points): `CAUSTIC_points`, appended after it |
| `motion.py` | motion blur and the Vector pass: the scene evaluated at the motion steps, `CAUSTIC_motion` |
| `object_filter.py` | the viewport's export of a few objects alone (added objects, edited meshes) |
| `unsupported.py` | warnings naming what Caustic cannot render yet (motion blur, hair, holdout, ...) |
"""

import os

import bpy

from ..errors import CausticError
from .curves import add_curves
from .points import add_points
from .instance_random import add_instance_randoms
from .camera import CAMERA_EXTENSION, camera_extension  # noqa: F401  (public names)
from .depsgraph import render_depsgraph
from .gltf_hooks import glTF2ExportUserExtension, hooks_enabled  # noqa: F401
from .lights import (AREA_LIGHT_EXTENSION, PUNCTUAL_EXTENSION, area_light_extension,  # noqa: F401
                     punctual_light_extension)
from .materials import COAT_EXTENSION, principled_extras, restore_opaque_iors, shader_node_material  # noqa: F401
from .media import MEDIUM_EXTENSION, SUBSURFACE_EXTENSION, medium_extension, subsurface_extension  # noqa: F401
from .settings import film_exposure, layer_render_settings, render_settings  # noqa: F401
from .light_groups import light_group_settings  # noqa: F401
from .shader_aovs import shader_aov_settings  # noqa: F401
from . import nonfinite
from .state import ExportState, exporting
from .motion import add_deformation, sample_motion
from .node_graph import single_colour_attribute
from .shape_keys import shape_keys_exported
from .light_normalize import normalize_baked
from .hollow_groups import hollow_group_links_removed
from .light_temperature import temperatures_baked
from .unsupported import scene_warnings
from .volumes import VOLUME_EXTENSION, attach_volumes  # noqa: F401
from .world import WORLD_EXTENSION, add_black_world_if_empty, world_extension  # noqa: F401


def _exporter_options(filepath, viewport=False, colour_attribute=None):
    """Exporter settings for a renderer: the current frame's state, everything renderable (in
    the viewport: everything visible there, as Cycles' viewport shows objects disabled in
    renders and hides those hidden in the viewport); `colour_attribute`: the one colour
    attribute the graphs read, written as COLOR_0 by name (else the exporter's choice)."""
    by_name = {} if colour_attribute is None else dict(export_vertex_color="NAME",
                                                       export_vertex_color_name=colour_attribute)
    return dict(
        **by_name,
        filepath=filepath,
        check_existing=False,
        export_format="GLTF_SEPARATE",
        export_image_format="AUTO",
        use_selection=False,
        use_visible=viewport,
        use_renderable=not viewport,
        use_active_scene=True,
        use_active_collection=False,
        export_cameras=True,
        export_lights=True,
        export_import_convert_lighting_mode="SPEC",
        export_apply=True,  # modifiers, from the render depsgraph (see depsgraph.py)
        export_yup=True,
        export_extras=False,
        export_animations=False,
        export_current_frame=True,  # else the exporter jumps to frame 0 and back
        export_skins=False,  # deformation comes baked in the evaluated mesh
        # Bones as posed: an object parented to a bone follows the bone's node, which otherwise
        # holds the rest pose (the pose then lives in the animation, which is not exported).
        export_rest_position_armature=False,
        export_morph=False,
        export_gn_mesh=True,
        export_gpu_instances=False,
        export_draco_mesh_compression_enable=False,
        export_materials="EXPORT",
        # Cycles' default surface of a mesh without a material reads no colour attribute (meshes.py).
        export_active_vertex_color_when_no_material=False,
        will_save_settings=False,
    )


def export_scene(depsgraph, folder, settings, motion=True, viewport=False, only=None):
    """Write the render depsgraph's scene to `folder`/scene.gltf; return (path, export state).

    `motion`: export motion blur's (or the Vector pass's) steps; the viewport renders without.
    `viewport`: the objects visible in the viewport, not those enabled for renders.
    `only`: a set of object names to export alone (the viewport's added objects and edited
    meshes, object_filter.py): no world, hair, point clouds, volumes or scene-wide warnings,
    which the running scene already has.

    Raises CausticError when the exporter fails or one of Caustic's hooks failed.
    """
    filepath = os.path.join(folder, "scene.gltf")
    scene = depsgraph.scene  # the original scene (scene_eval is the evaluated copy)
    view_layer = depsgraph.view_layer
    state = ExportState(settings)
    state.pixel_aspect = (scene.render.pixel_aspect_x, scene.render.pixel_aspect_y)
    state.depsgraph = depsgraph
    state.material_override = view_layer.material_override
    state.only = only
    state.colour_attribute = single_colour_attribute(depsgraph)
    # The exporter takes object transforms from the original objects, which only the viewport
    # depsgraph updates; during an animation render it still holds the previous frame.
    scene_eval = depsgraph.scene_eval
    scene.frame_set(scene_eval.frame_current, subframe=scene_eval.frame_subframe)
    if motion:
        with bpy.context.temp_override(scene=scene, view_layer=view_layer):
            state.motion = sample_motion(scene, view_layer)
        if state.motion is not None:
            state.warnings.extend(state.motion.warnings)
    state.nonfinite = nonfinite.scan(depsgraph)
    try:
        with exporting(state), bpy.context.temp_override(scene=scene, view_layer=view_layer), \
                hooks_enabled(), shape_keys_exported(depsgraph, state.warnings, viewport), \
                temperatures_baked(state.warnings), normalize_baked(state.warnings), \
                hollow_group_links_removed(state.warnings), render_depsgraph(depsgraph):
            bpy.ops.export_scene.gltf(**_exporter_options(filepath, viewport, state.colour_attribute))
    except RuntimeError as err:
        # The operator's error carries the exporter's whole traceback; its last line says why
        # (bpy 5.0 appends the operator's "Location: .../ops.py:109", which does not).
        lines = [line.strip() for line in str(err).splitlines()
                 if line.strip() and not line.strip().startswith("Location:")]
        raise CausticError(f"glTF export failed: {lines[-1] if lines else err}") from None
    if state.errors:
        raise CausticError("export failed: " + "; ".join(state.errors))
    if not os.path.isfile(filepath):
        raise CausticError("glTF export wrote no file")
    try:
        restore_opaque_iors(filepath, state.opaque_iors)
    except (OSError, ValueError) as err:
        raise CausticError(f"writing the opaque materials' IOR failed: {err!r}") from None
    if only is not None:
        return filepath, state
    state.warnings.extend(scene_warnings(depsgraph))
    state.warnings.extend(attach_volumes(depsgraph, folder, filepath, state.image_writer(folder)))
    try:
        add_curves(filepath, depsgraph, state)
    except (OSError, ValueError, KeyError, AttributeError) as err:
        raise CausticError(f"exporting hair and curves failed: {err!r}") from None
    try:
        add_points(filepath, depsgraph, state)
    except (OSError, ValueError, KeyError, AttributeError) as err:
        raise CausticError(f"exporting point clouds failed: {err!r}") from None
    try:
        add_instance_randoms(filepath, depsgraph, state.object_names, state.instancer_names, state.warnings)
    except (OSError, ValueError, KeyError) as err:
        raise CausticError(f"writing the instances' random numbers failed: {err!r}") from None
    try:
        add_deformation(filepath, state.motion)
    except (OSError, ValueError, KeyError) as err:
        raise CausticError(f"exporting deformation motion failed: {err!r}") from None
    try:
        add_black_world_if_empty(filepath, scene)
    except (OSError, ValueError, KeyError, IndexError) as err:
        raise CausticError(f"writing the missing world failed: {err!r}") from None
    return filepath, state
