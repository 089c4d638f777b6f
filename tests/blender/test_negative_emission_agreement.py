"""Negative emission in the integrators that also trace light from the lights: BDPT, VCM and
Jensen's photon mapping against Cycles, with test_nodes_agreement.py's scenes and bounds (image
mean per channel within 5 sigma + 1 %, 4x4 blocks within 5 sigma + 2 %, two seeds per engine).

Cycles keeps an Emission of negative colour or strength (`emission_setup`): it subtracts light,
and its light tree picks the emitter by |emission| (`Shader::estimate_emission` takes fabs).
Caustic picks such emitters by |power| and carries the sign in each light subpath's and photon's
weight (`src/light/origin.rs`, `src/light/emit.rs`), so every strategy sees the same signed
emission as the path tracer. The cases:
* negative_emission: test_nodes_agreement.py's plane whose blue emission runs from -0.3 to 1,
  seen directly (light tracing from the plane reaches the camera too);
* negative_glow_ball: a grey diffuse ball that also emits (0.3, 0.6, 1.0) x -2 on a grey floor
  under a disk light: it darkens the floor around it and its own lit side, through next-event
  estimation, light subpaths and photons alike.
"""

import pytest

import scenes
from test_node_graph_export import new_material
from test_nodes_agreement import CASES, SAMPLES, BOUNCES, W, H, compare, sphere_scene

pytestmark = pytest.mark.needs_binary


def negative_glow(name):
    """A maker: Add Shader of a grey Diffuse and an Emission of (0.3, 0.6, 1.0) x -2."""
    mat = new_material(name)
    tree = mat.node_tree
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (0.5, 0.5, 0.5, 1.0)
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (0.3, 0.6, 1.0, 1.0)
    emission.inputs["Strength"].default_value = -2.0
    add = tree.nodes.new("ShaderNodeAddShader")
    tree.links.new(diffuse.outputs["BSDF"], add.inputs[0])
    tree.links.new(emission.outputs["Emission"], add.inputs[1])
    tree.links.new(add.outputs["Shader"], tree.nodes["Material Output"].inputs["Surface"])
    return mat


NEGATIVE_CASES = {
    "negative_emission": CASES["negative_emission"],
    "negative_glow_ball": (sphere_scene, negative_glow, None),
}


@pytest.mark.parametrize("integrator", ["bdpt", "vcm", "photon"])
@pytest.mark.parametrize("case", list(NEGATIVE_CASES))
def test_negative_emission_matches_cycles(empty_scene, tmp_path, case, integrator):
    build, make, _ = NEGATIVE_CASES[case]
    build(empty_scene, make(case))
    scenes.small_render_settings(empty_scene, W, H, samples=SAMPLES)
    empty_scene.caustic.threads = 0
    empty_scene.caustic.integrator = integrator
    scenes.match_cycles(empty_scene, SAMPLES, BOUNCES)
    compare(empty_scene, tmp_path, f"{case} ({integrator})")
