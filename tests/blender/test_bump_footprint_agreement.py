"""The Bump node's offsets from the ray's footprint: Caustic against Cycles.

Cycles evaluates a Bump's height at P and at P + Filter Width × dP.dx, dP.dy, where dP is the
compact ray differential (the camera ray's spread per pixel times the distance travelled; Blender
5.0's Filter Width defaults to 0.1). A height with detail finer than that step (a Noise of many
octaves) is smoothed by the finite difference: its high octaves barely tilt the normal. With a
fixed tiny step every octave counts, and the surface looks rougher and darker under the sun.

Scenes: test_nodes_agreement.py's flat plane seen straight down under a sun from 20/10 degrees,
a Principled BSDF (roughness 0.5, so both the diffuse and the specular lobe read the normal)
whose Normal is a Bump of a Noise (Scale 10, Roughness 0.5; Detail 15 or 0), Strength 1,
Distance 0.3; at 64x48 and 128x96 pixels, so the footprint halves between the two. The checks
and their derivation are test_nodes_agreement.py's `compare` (image mean per channel within
5 sigma + 1 %, every 4x4 block within 5 sigma + 2 %).

Measured (pytest -s, 32 samples, seeds 1 and 2; Caustic/Cycles image mean, blocks over bound):
* before (main: a fixed offset of 1e-4 max(1, |P|)): high detail 64x48 0.879 (190/192 blocks
  over, worst 2.06x), 128x96 0.907 (565/768, worst 1.97x); low detail 64x48 1.0012 (0/192),
  128x96 1.0014 (2/768, worst 1.18x at block (23, 23)); high detail with Filter Width 1 (64x48)
  0.7733 (192/192 blocks over, worst 4.48x).
* after (footprint x Filter Width in Cycles' frame): high detail 1.0000 (0/192, worst 0.40x)
  and 0.9993 (0/768, worst 0.42x); low detail 1.0014 (0/192, worst 0.22x) and 1.0015 (1/768,
  worst 1.22x at the same block (23, 23)); Filter Width 1: 1.0014 (0/192, worst 0.25x).
The low-detail 128x96 block was not the footprint's: it lies in a smooth dark valley at the
frame's bottom edge, where the bumped normal tilts so steeply that the viewer's mirror image about
it points below the surface. Cycles bends the Principled BSDF's specular normal towards the
geometric one there (`maybe_ensure_valid_specular_reflection`), the diffuse keeping the bumped
normal under the bump terminator term; Caustic's node path did neither (the two were not measured
separately: the terminator term only darkens, so the bend is what restores the specular
lobe lost below the surface). Before: the block 0.969 of Cycles (0.2821 against 0.2911). With both, as Cycles
(`shader/shade.rs`): 1.0003, 0/768 blocks over, worst 0.18x.
A Filter Width linked to a Value node of 1 (socket 0.1): Cycles folds the constant into the width;
main read the socket's 0.1: 0.8797 (190/192 blocks over, worst 3.57x); now 1.0003 (0/192).
"""

import math

import pytest

import scenes
from test_cycles_agreement import mean_and_variance
from test_node_graph_export import by_name, export, graph_of, new_material
from test_nodes_agreement import (BOUNCES, MEAN_ALLOWANCE, SAMPLES, SEEDS, SIGMAS, compare, flat_scene,
                                  luminance)

pytestmark = pytest.mark.needs_binary


def bumped_principled(detail, filter_width=None, linked_width=None):
    """A maker: a Principled BSDF (grey, roughness 0.5) bumped by a Noise of `detail` octaves,
    the Bump's Filter Width Blender's default or `filter_width`, or linked from a Value node of
    `linked_width` (the socket keeping its default)."""
    def make(name):
        mat = new_material(name)
        tree = mat.node_tree
        bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
        bsdf.inputs["Base Color"].default_value = (0.7, 0.7, 0.7, 1.0)
        bsdf.inputs["Roughness"].default_value = 0.5
        noise = tree.nodes.new("ShaderNodeTexNoise")
        noise.inputs["Scale"].default_value = 10.0
        noise.inputs["Detail"].default_value = detail
        noise.inputs["Roughness"].default_value = 0.5
        bump = tree.nodes.new("ShaderNodeBump")
        bump.inputs["Strength"].default_value = 1.0
        bump.inputs["Distance"].default_value = 0.3
        assert abs(bump.inputs["Filter Width"].default_value - 0.1) < 1e-6, "Blender's default changed"
        if filter_width is not None:
            bump.inputs["Filter Width"].default_value = filter_width
        if linked_width is not None:
            value = tree.nodes.new("ShaderNodeValue")
            value.outputs["Value"].default_value = linked_width
            tree.links.new(value.outputs["Value"], bump.inputs["Filter Width"])
        tree.links.new(noise.outputs["Fac"], bump.inputs["Height"])
        tree.links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
        tree.links.new(bsdf.outputs["BSDF"], tree.nodes["Material Output"].inputs["Surface"])
        return mat
    return make


CASES = {
    "high_detail_64": (15.0, 64, 48),
    # Ten times the default: the step is a whole footprint, so the Filter Width must scale it.
    "high_detail_64_filter_1": (15.0, 64, 48, 1.0),
    "high_detail_128": (15.0, 128, 96),
    "low_detail_64": (0.0, 64, 48),
    "low_detail_128": (0.0, 128, 96),
    # Filter Width 1 from a Value node, the socket left at 0.1: Cycles folds the constant link
    # into the width (measured in Blender 5.0: the same image as an unlinked width of 1).
    "high_detail_64_filter_linked": (15.0, 64, 48, None, 1.0),
}


# Known differences, kept failing on purpose (strict: a fix turns them into errors to remove).
KNOWN_DIFFERENCES = {}


@pytest.mark.parametrize("case", [pytest.param(c, marks=pytest.mark.xfail(strict=True, reason=KNOWN_DIFFERENCES[c]))
                                  if c in KNOWN_DIFFERENCES else c for c in CASES])
def test_bump_footprint_matches_cycles(empty_scene, tmp_path, case):
    detail, width, height, *filter_width = CASES[case]
    flat_scene(empty_scene, bumped_principled(detail, *filter_width)(case))
    scenes.small_render_settings(empty_scene, width, height, samples=SAMPLES)
    empty_scene.caustic.threads = 0
    scenes.match_cycles(empty_scene, SAMPLES, BOUNCES)
    compare(empty_scene, tmp_path, case)


# The other integrators' bias allowances (test_integrators.py) on top of the 1 % model allowance.
INTEGRATOR_ALLOWANCE = {"photon": 0.03, "sppm": 0.03, "bdpt": 0.0, "vcm": 0.03}


@pytest.mark.parametrize("integrator", list(INTEGRATOR_ALLOWANCE))
def test_every_integrator_bumps_by_the_footprint(empty_scene, tmp_path, integrator):
    """The high-detail 64x48 case by each other integrator against Cycles' image mean (the
    bound of test_nodes_agreement.py's mean check plus the integrator's bias allowance). The
    camera paths carry the footprint; light subpaths and photons take the camera's footprint
    at the point. Measured (Caustic/Cycles mean, main's fixed offset -> the footprint): photon
    0.8790 -> 1.0000, SPPM 0.8790 -> 1.0000, BDPT 0.8790 -> 1.0005, VCM 0.8791 -> 1.0004."""
    flat_scene(empty_scene, bumped_principled(15.0)(integrator))
    scenes.small_render_settings(empty_scene, 64, 48, samples=SAMPLES)
    empty_scene.caustic.threads = 0
    scenes.match_cycles(empty_scene, SAMPLES, BOUNCES)
    empty_scene.caustic.integrator = integrator
    images = {engine: [scenes.render_rgb(empty_scene, engine, s, str(tmp_path / f"{engine}_{s}.exr"))
                       for s in SEEDS]
              for engine in ("CYCLES", "CAUSTIC")}
    (m_caustic, v_caustic), (m_cycles, v_cycles) = (
        mean_and_variance(*(luminance(image) for image in images[e])) for e in ("CAUSTIC", "CYCLES"))
    bound = SIGMAS * math.sqrt(v_caustic + v_cycles) + (MEAN_ALLOWANCE + INTEGRATOR_ALLOWANCE[integrator]) * m_cycles
    print(f"\n[bump footprint {integrator}/cycles] mean ratio {m_caustic / m_cycles:.4f}, bound "
          f"{bound / m_cycles:.4f} relative")
    assert abs(m_caustic - m_cycles) <= bound, f"{integrator}: Caustic/Cycles = {m_caustic / m_cycles:.4f}"


def test_filter_width_is_exported_and_read(addon, empty_scene, tmp_path):
    """The Bump node's Filter Width reaches the graph (node_graph.py writes every unlinked input's
    value) with the value set in Blender, so the compiler reads it rather than its default."""
    mat = bumped_principled(15.0)("Wide")
    mat.node_tree.nodes["Bump"].inputs["Filter Width"].default_value = 0.7
    flat_scene(empty_scene, mat)
    gltf, _, _ = export(addon, empty_scene, tmp_path)
    _, bump = by_name(graph_of(gltf, "Wide"))["Bump"]
    assert abs(bump["inputs"]["Filter Width"]["value"] - 0.7) < 1e-6
