"""Caustic and Cycles agree on a Ray Portal BSDF whose Position and Direction are unlinked:
Cycles continues the ray from the hit point in its own direction, tinted by the colour, and
shadow rays see the portal's weight as transparency (`bsdf_ray_portal_setup`), which is a
Transparent BSDF. Before, the node was unknown (warned, its outputs 0).

Scene and tolerance: test_inputs_agreement.py's sphere scene, its ball a Ray Portal (tinted),
and `compare_rgba` (5 sigma of the two-seed mean difference + the 1 % model allowance per
channel, derived there).
"""

import bpy
import pytest

from test_inputs_agreement import compare_rgba, settings
from test_nodes_agreement import sphere_scene

pytestmark = pytest.mark.needs_binary


def _portal(name):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    tree = mat.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    portal = tree.nodes.new("ShaderNodeBsdfRayPortal")
    portal.inputs["Color"].default_value = (0.5, 0.8, 1.0, 1.0)
    tree.links.new(portal.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return mat


def test_unlinked_ray_portal_continues_the_ray_as_cycles(empty_scene, tmp_path):
    """Caustic/Cycles R/G/B before (unknown node: a grey ball) 0.9303/0.8397/0.7704, after
    0.9962/0.9918/0.9885 (about 1 sigma each: the tinted ball's caustic is noisy at 32 spp);
    sweep3's portal plane before a ball at 64 spp 0.893/0.843/0.806 -> 1.001/1.002/1.003."""
    sphere_scene(empty_scene, _portal("Portal"))
    settings(empty_scene)
    compare_rgba(empty_scene, tmp_path, "ray_portal")
