"""Node groups without a Group Output (a group linked from a library file that is missing, a
group emptied by hand): Cycles reads nothing from their outputs (a light fed by one emits no
light, a shader from one is no closure), but Blender's glTF exporter fails on a link from one
(an IndexError in its node-tree search, which stopped the whole render). While the exporter
runs, such links are taken out of the local shader node trees and put back afterwards; each is
named in a warning. Caustic then reads the trees as Cycles does: what the link fed takes the
socket's own value.
"""

from contextlib import contextmanager

import bpy


def _output_missing(link):
    """Whether `link` comes from a group node whose tree has no Group Output with its socket."""
    node = link.from_node
    if node.type != "GROUP":
        return False
    tree = node.node_tree
    if tree is None:
        return True
    output = next((n for n in tree.nodes if n.type == "GROUP_OUTPUT"), None)  # the exporter's pick
    return output is None or not any(s.name == link.from_socket.name for s in output.inputs)


def _local_shader_trees():
    """(what, tree) of the local materials', lights' and shader node groups' trees."""
    for kind, datablocks in (("material", bpy.data.materials), ("light", bpy.data.lights)):
        for datablock in datablocks:
            if datablock.library is None and datablock.node_tree is not None:
                yield f"{kind} '{datablock.name}'", datablock.node_tree
    for group in bpy.data.node_groups:
        if group.library is None and group.bl_idname == "ShaderNodeTree":
            yield f"node group '{group.name}'", group


@contextmanager
def hollow_group_links_removed(warnings):
    """While active, no local shader node tree has a link from a group without a Group Output
    (module doc); each removed link is named in `warnings`."""
    removed = []
    try:
        for what, tree in _local_shader_trees():
            for link in [k for k in tree.links if _output_missing(k)]:
                node = link.from_node
                group = f"node group '{node.node_tree.name}'" if node.node_tree is not None else "no node group"
                warnings.append(f"{what}: node '{node.name}' has {group} without a Group Output (a missing "
                                f"library file?); its '{link.from_socket.name}' gives nothing, as in Cycles")
                removed.append((tree, link.from_socket, link.to_socket, link.is_muted))
                tree.links.remove(link)
        yield
    finally:
        for tree, from_socket, to_socket, muted in removed:
            tree.links.new(from_socket, to_socket).is_muted = muted
