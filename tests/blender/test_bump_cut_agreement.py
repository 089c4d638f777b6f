"""Cycles' bump shadowing term (`bump_shadowing_term`, closure/bsdf.h) on the closures it
reaches, against Cycles: a strongly bumped Principled BSDF (dielectric and metal, low
roughness) and a bumped Translucent BSDF, each a ball on test_nodes_agreement.py's grey floor
under a disk light (`sphere_scene`, 48x36, 32 spp, two seeds per engine).

Cycles evaluates every closure whose normal is not sd->N (the interpolated normal, or the
Material Output's bump) through the term: a light on the other side of the closure's normal
than sd->N puts it gives that closure nothing (its evaluation and density, not its own
sample), and diffuse-class closures (CLOSURE_IS_BSDF_DIFFUSE: Diffuse, Oren-Nayar, Sheen,
Toon Diffuse and Translucent) are also cut in their samples and softened by the GGX shadowing
of their normal's tilt. Caustic cut the small glossy lobes of a mixture but not a Principled
BSDF's specular lobes, and treated Translucent as outside the diffuse class (no cut, no
softening).

The check is test_nodes_agreement.py's `compare` (image mean per channel within 5 sigma + 1 %
of Cycles', each 4x4 block of luminance within 5 sigma + 2 %; bounds derived there, nothing
tuned here). The backlit plane (a plane lit from behind by a sun) shows the Translucent's
evaluation alone: Cycles also bends its normal for a valid reflection
(`maybe_ensure_valid_specular_reflection`), which Caustic did not.

Caustic/Cycles mean R/G/B, blocks over of 108, main -> now:
* principled_glossy 0.9938/0.9942/0.9952, 0 -> 0.9937/0.9942/0.9952, 0 (the cut reaches only
  light between sd->N's plane and the bent normal's, which the integrators' side test against
  the geometric normal mostly refused already)
* principled_metal 0.9888/0.9917/0.9955, 0 -> unchanged to four digits
* translucent (the ball) 1.1100/1.1062/1.0905, 21 -> 0.9861/0.9885/0.9932, 0
* translucent_backlit_plane 0.8977, 96 -> 1.0004, 0
"""

import bpy  # noqa: F401
import pytest

import scenes
from test_node_graph_export import new_material
from test_node_graph_export import uv_plane
from test_nodes_agreement import BOUNCES, SAMPLES, W, H, bump, compare, sphere_scene


def bumped(kind, **inputs):
    """A maker: a `kind` shader node with `inputs`, its Normal from test_nodes_agreement's
    strong noise Bump (strength 1, distance 1)."""
    def make(name):
        mat = new_material(name)
        tree = mat.node_tree
        node = tree.nodes.new(kind)
        for key, value in inputs.items():
            node.inputs[key].default_value = value
        tree.links.new(bump(tree), node.inputs["Normal"])
        tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
        return mat
    return make


def backlit_plane(scene, material):
    """test_nodes_agreement's 2x2 plane seen from 3 units above, lit from below by a sun 30
    degrees off the axis: what shows is the closure's evaluation toward the sun alone."""
    uv_plane(scene, "Plane", material)
    scenes.camera(scene, (0.0, 0.0, 3.0), (0.0, 0.0, 0.0), lens=54.0)
    scenes.light(scene, "Sun", "SUN", rotation_deg=(150.0, 10.0, 0.0), energy=3.0, angle=0.0)


CASES = {
    "principled_glossy": bumped("ShaderNodeBsdfPrincipled", **{"Base Color": (0.2, 0.3, 0.6, 1.0),
                                                                "Roughness": 0.1}),
    "principled_metal": bumped("ShaderNodeBsdfPrincipled", **{"Base Color": (0.9, 0.6, 0.3, 1.0),
                                                               "Metallic": 1.0, "Roughness": 0.1}),
    "translucent": bumped("ShaderNodeBsdfTranslucent", Color=(0.8, 0.7, 0.5, 1.0)),
    "translucent_backlit_plane": bumped("ShaderNodeBsdfTranslucent", Color=(0.8, 0.7, 0.5, 1.0)),
}
BUILD = {"translucent_backlit_plane": backlit_plane}


@pytest.mark.needs_binary
@pytest.mark.parametrize("case", list(CASES))
def test_bump_cut_matches_cycles(empty_scene, tmp_path, case):
    scene = empty_scene
    BUILD.get(case, sphere_scene)(scene, CASES[case](case))
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)
    compare(scene, tmp_path, case)
