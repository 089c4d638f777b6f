"""Objects parented to a collection instancer, placed where Blender has them.

Blender's glTF exporter (io_scene_gltf2 5.0.21) writes the node of an object whose parent
instances a collection (an Empty with Instancing: Collection) with its transform relative to the
world, not to that parent, although it nests the node under the parent's: the object lands offset
by the parent's own transform (an Empty at (0, 3, 0) instancing a collection, a sphere parented to
it at (0, 0, 3): exported at (0, 3, 3); glTF-Blender-IO's 39_parenting_full_hierarchy.blend:
three objects off, 102 of 3,072 blocks against Cycles). A plain Empty parent is exported right.

The hooks note which Blender object each node was made for; once the scene's tree is built, every
such node that sits under its parent object's node is given the transform Blender has between them,
`parent.matrix_world⁻¹ · matrix_world` in glTF's axes, whatever the exporter wrote.
"""


def note_node(state, gltf2_node, blender_object):
    """Remember the Blender object of `gltf2_node` (called from the node hook)."""
    state.node_objects[id(gltf2_node)] = blender_object.name


def place_instancer_children(gltf2_scene, state):
    """Give each node of an object parented to a collection instancer, nested under its parent's
    node, Blender's transform relative to that parent (module doc). Returns the names fixed."""
    import bpy
    fixed = []

    def walk(node, parent_name):
        name = state.node_objects.get(id(node))
        obj = bpy.data.objects.get(name) if name is not None else None
        if obj is not None and obj.type not in {"CAMERA", "LIGHT"}:
            parent = obj.parent
            if (parent is not None and parent.name == parent_name and parent.instance_type == "COLLECTION"
                    and parent.instance_collection is not None):
                _set_local(node, parent.matrix_world.inverted_safe() @ obj.matrix_world)
                fixed.append(obj.name)
        for child in node.children or []:
            walk(child, name)

    for root in gltf2_scene.nodes or []:
        walk(root, None)
    return fixed


def _set_local(node, matrix):
    """Set `node`'s TRS to Blender's local `matrix`, converted to glTF's Y-up axes as the
    exporter converts (location (x, z, -y), rotation (x, z, -y, w), scale (x, z, y))."""
    t, q, s = matrix.decompose()
    node.matrix = None
    node.translation = [t.x, t.z, -t.y]
    node.rotation = [q.x, q.z, -q.y, q.w]
    node.scale = [s.x, s.z, s.y]
