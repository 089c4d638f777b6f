"""The glTF exporter's user-extension plumbing: the hook class and making the exporter find it.

Facts relied on (io_scene_gltf2 5.0.21, shipped with Blender/bpy 5.0.1):
* the exporter instantiates `glTF2ExportUserExtension` from `sys.modules[name]` for every
  `name` in `bpy.context.preferences.addons`; the add-on's `__init__` re-exports the class and
  `hooks_enabled` makes sure the add-on is listed while Caustic exports;
* hook exceptions are logged and swallowed by the exporter, so the hooks record their own
  failures in the export state's `errors` and `export_scene` raises them afterwards.

Each hook is a no-op outside a Caustic export and delegates to the module of its Blender concept.
"""

from contextlib import contextmanager

import bpy

from . import attributes, instancer_children, materials, meshes, nonfinite, object_filter, view_layer
from .camera import CAMERA_EXTENSION, camera_extension, fit_orthographic
from .gltf_objects import attach_extension
from .lights import (AREA_LIGHT_EXTENSION, PUNCTUAL_EXTENSION, area_light_extension, carry_negative_intensity,
                     punctual_light_extension, scale_punctual_light, separate_spot_angles)
from .state import current
from .udim_split import dropped_triangles_warning, restore_tile_uvs
from .light_linking import LIGHT_LINKING_EXTENSION, light_linking_extension
from .pass_ids import (MATERIAL_PASS_EXTENSION, OBJECT_PASS_EXTENSION, material_pass_extension,
                       object_pass_extension)
from .motion import MOTION_EXTENSION
from .visibility import (OBJECT_SHADING_EXTENSION, OBJECT_VISIBILITY_EXTENSION, object_shading_extension,
                         object_shading_warnings, object_visibility_extension)
from .world import WORLD_EXTENSION, world_extension

# The add-on's package (this module lives in its `export` subpackage).
ADDON_PACKAGE = __package__.rpartition(".")[0]


class glTF2ExportUserExtension:
    """Hooks the glTF exporter calls; they add Caustic's data while a Caustic render exports."""

    def gather_node_hook(self, gltf2_node, blender_object, export_settings):
        """Attach CAUSTIC_camera to a camera's node, CAUSTIC_lights_area to an area light's node,
        CAUSTIC_lights_punctual to the other lights', CAUSTIC_texspace to a mesh whose
        node graphs read Generated coordinates, CAUSTIC_normals_domain to a mesh that a material
        displaces, and CAUSTIC_object_visibility to a mesh node
        whose object some kind of ray does not see or that is a holdout, CAUSTIC_object_pass to a mesh
        node with a Pass Index or a parent, CAUSTIC_light_linking to an emitter with a receiver
        collection, CAUSTIC_motion to a moving object's node, and the Object and Instancer
        attributes its materials read to a mesh node's extras (attributes.py)."""
        state = current()
        if state is None or blender_object is None:
            return
        try:
            instancer_children.note_node(state, gltf2_node, blender_object)
            moves = state.motion.node_extension(blender_object.name) if state.motion is not None else None
            if moves is not None:
                attach_extension(gltf2_node, MOTION_EXTENSION, moves)
            receivers = light_linking_extension(blender_object)
            if receivers is not None:
                attach_extension(gltf2_node, LIGHT_LINKING_EXTENSION, receivers)
            if gltf2_node.mesh is not None:
                view_layer = state.depsgraph.view_layer if state.depsgraph is not None else None
                hidden = object_visibility_extension(blender_object, view_layer)
                if hidden:
                    attach_extension(gltf2_node, OBJECT_VISIBILITY_EXTENSION, hidden)
                shading = object_shading_extension(blender_object)
                if shading:
                    attach_extension(gltf2_node, OBJECT_SHADING_EXTENSION, shading)
                for warning in object_shading_warnings(blender_object):
                    if warning not in state.warnings:
                        state.warnings.append(warning)
                ids = object_pass_extension(blender_object)
                if ids:
                    attach_extension(gltf2_node, OBJECT_PASS_EXTENSION, ids)
            if blender_object.type == "CAMERA":
                fit_orthographic(gltf2_node.camera, blender_object.data, state.settings["resolution"],
                                 state.pixel_aspect)
                value, warnings = camera_extension(blender_object, state.settings["resolution"],
                                                   state.pixel_aspect)
                state.warnings.extend(warnings)
                if value:
                    attach_extension(gltf2_node, CAMERA_EXTENSION, value)
                return
            if gltf2_node.mesh is not None:
                values = attributes.object_attributes(blender_object, state)
                if values:
                    extras = gltf2_node.extras if isinstance(gltf2_node.extras, dict) else {}
                    extras[attributes.OBJECT_EXTRA] = values
                    gltf2_node.extras = extras
            if blender_object.type == "MESH":
                meshes.add_texspace(gltf2_node.mesh, blender_object, state)
                meshes.add_normals_domain(gltf2_node.mesh, blender_object, state)
                meshes.add_object_color(gltf2_node, blender_object, state)
                nonfinite.drop_nonfinite_triangles(gltf2_node.mesh, blender_object, state)
                return
            if blender_object.type != "LIGHT":
                return
            writer = state.image_writer(export_settings["gltf_filedirectory"])
            if blender_object.data.type != "AREA":
                separate_spot_angles(gltf2_node)
                value = punctual_light_extension(blender_object, writer, state.depsgraph, state.warnings)
                scale_punctual_light(gltf2_node, blender_object, state, graph=bool(value and "nodes" in value))
                value = carry_negative_intensity(gltf2_node, value, state)
                if value:
                    attach_extension(gltf2_node, PUNCTUAL_EXTENSION, value)
                return
            value, warnings = area_light_extension(blender_object, writer, state.depsgraph)
            attach_extension(gltf2_node, AREA_LIGHT_EXTENSION, value)
            state.area_lights.append(gltf2_node.name)
            state.warnings.extend(warnings)
        except Exception as err:  # the exporter would swallow it: keep it for export_scene
            state.errors.append(f"object '{blender_object.name}': {err!r}")

    def gather_mesh_hook(self, gltf2_mesh, blender_mesh, blender_object, vertex_groups, modifiers, materials,
                         export_settings):
        """Give primitives without a material Blender's default surface and the TEXCOORD_n their
        material's textures read, and drop the COLOR_0 their material does not read (meshes.py);
        move UDIM tile primitives' UVs back to their tiles (udim_split.py)."""
        state = current()
        if state is None or gltf2_mesh is None:
            return
        try:
            meshes.apply_material_override(gltf2_mesh, state, export_settings)
            meshes.give_default_material(gltf2_mesh, state)
            meshes.add_missing_texcoords(gltf2_mesh, blender_mesh, state)
            meshes.drop_unread_colour(gltf2_mesh)
            restore_tile_uvs(gltf2_mesh, state)
            dropped_triangles_warning(gltf2_mesh, blender_mesh, state)
        except Exception as err:
            state.errors.append(f"mesh '{getattr(blender_mesh, 'name', '?')}': {err!r}")

    def gather_attributes_change(self, blender_attributes, export_settings):
        """Add the mesh attributes the mesh's materials read by name (attributes.py) to the
        attributes the exporter is about to write."""
        state = current()
        if state is None:
            return
        try:
            attributes.add_mesh_attributes(blender_attributes, state)
        except Exception as err:
            state.errors.append(f"mesh attributes: {err!r}")

    def gather_material_hook(self, gltf2_material, blender_material, export_settings):
        """Translate what the exporter cannot read and add Caustic's material extensions (materials.py)."""
        state = current()
        if state is None or gltf2_material is None:
            return
        try:
            materials.complete_material(gltf2_material, blender_material, export_settings, state)
            materials.add_shadow_extension(gltf2_material, blender_material)
            if materials.uses_graph(blender_material, state):
                attributes.note_requests(blender_material, state)
            ids = material_pass_extension(blender_material)
            if ids:
                attach_extension(gltf2_material, MATERIAL_PASS_EXTENSION, ids)
        except Exception as err:
            state.errors.append(f"material '{getattr(blender_material, 'name', '?')}': {err!r}")

    def gather_tree_filter_tag_hook(self, vtree, export_settings):
        """Leave out the objects of collections the view layer excludes (see view_layer.py), and in
        an export of a few objects every other one (object_filter.py)."""
        state = current()
        if state is None or state.depsgraph is None:
            return
        try:
            view_layer.drop_objects_outside(vtree, state.depsgraph)
        except Exception as err:
            state.errors.append(f"view layer '{state.depsgraph.view_layer.name}': {err!r}")
        if state.only is not None:
            try:
                object_filter.keep_only(vtree, state.only)
            except Exception as err:
                state.errors.append(f"exporting only {sorted(state.only)}: {err!r}")

    def gather_scene_hook(self, gltf2_scene, blender_scene, export_settings):
        """Store the render settings in the scene's extras.caustic and the world in CAUSTIC_world."""
        state = current()
        if state is None:
            return
        try:
            instancer_children.place_instancer_children(gltf2_scene, state)
        except Exception as err:
            state.errors.append(f"objects parented to collection instancers: {err!r}")
        try:
            extras = gltf2_scene.extras if isinstance(gltf2_scene.extras, dict) else {}
            extras["caustic"] = dict(state.settings)
            gltf2_scene.extras = extras
            state.scenes += 1
        except Exception as err:
            state.errors.append(f"scene settings: {err!r}")
        if state.only is not None:
            return  # a few objects for the running scene, which keeps its own world
        try:
            folder = export_settings["gltf_filedirectory"]
            value, warnings = world_extension(blender_scene, folder, state.image_writer(folder), state.depsgraph)
            state.warnings.extend(warnings)
            if value is not None:
                attach_extension(gltf2_scene, WORLD_EXTENSION, value)
        except Exception as err:
            state.errors.append(f"world: {err!r}")
        if state.motion is not None:
            attach_extension(gltf2_scene, MOTION_EXTENSION, state.motion.scene_extension())


@contextmanager
def hooks_enabled():
    """Make sure the exporter finds the add-on's hooks, however the add-on was enabled.

    Installed and enabled from Preferences, the add-on is already in `preferences.addons`.
    When only `register()` was called (scripts, tests) it is not, and the exporter would skip the
    hooks silently: list the add-on for the duration of the export, then remove it again.
    """
    addons = bpy.context.preferences.addons
    added = None
    if ADDON_PACKAGE not in addons:
        added = addons.new()
        added.module = ADDON_PACKAGE
    try:
        yield
    finally:
        if added is not None:
            addons.remove(added)
