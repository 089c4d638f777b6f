"""An Emission node on the World Volume, against Cycles (issue 20).

What Cycles 5.0 renders (measured with bpy 5.0.1, CPU, 64x48, a cube and a camera, world
surface black):
* an Emission of strength 0.1 alone: every pixel inf, at camera clip ends 10, 100 and 1000
  alike. Rays that leave the scene run to FLT_MAX (the clip end bounds no world volume) and
  `volume_emission_integrate` gives E * t where nothing attenuates. Caustic leaves such a
  volume out with a warning that says so (`test_emission_alone_is_left_out_with_cycles_inf`).
* an Emission added to a Volume Absorption (Add Shader): finite, E / sigma_t along escaping
  rays (E 0.1, sigma_a 0.01: 8.96 at the top of the image, whatever the clip end);
* an Emission added to a Principled Volume whose Density is a Noise Texture: finite.

Both renderers render test_cycles_agreement's floor and box (no lamp: the world volume is the
only light) with the bound derived there and in test_textured_volume.py: the image means per
colour channel and per quadrant agree within 5 sigma of the two renderers' noise (two seeds,
8x8 blocks) plus the 1 % model allowance.

Measured on bpy 5.0.1 (Caustic/Cycles):
* Emission + Absorption: path image R 1.0000, G 0.9999, B 0.9999, quadrants 0.9997-1.0003
  (bound about 1 % of the mean); BDPT and VCM 0.9997-0.9998. Before (the exporter left an
  Add Shader on the World Volume out, with a warning) the image was black: ratio 0.0000.
* The photon integrators, whose photons start in the emitting fog within the box of the
  scene's surfaces, cameras and lights grown by half on each side, and enter through its
  faces with the E/sigma_t the fog beyond sends in before it scatters (`src/light/media_emit.rs`;
  before, they started at lights only):
  - Emission + Absorption: photon mapping and SPPM 0.9973-0.9999 per channel, quadrants
    0.9966-1.0011 (before 0.975-0.980).
  - Emission + a constant scattering Principled Volume inside the closed 12 m room (every
    bit of fog within that box): photon mapping 0.994-0.995 per channel (before 0.967-0.976,
    failing), SPPM 0.980-0.991 (bound about 4 %; before 0.77-0.88, failing).
  - The same fog in the open scene: photon mapping 0.9975-0.9979 (before 0.989-0.991), SPPM
    0.882/0.902/0.929 (before 0.73-0.81; a strict expected failure, measured again after the
    scatter_in_medium and beyond-the-box tracking changes: unchanged): the fog beyond the box
    glows, scatters there (about 9 m of diffusion length in red) and then enters, which no
    photon carries. Jensen's gather rays path-trace the fog they scatter in and miss it only at
    their gather points; SPPM's visible points read photons for all of it.
    Why it stays: the photons account for all light emitted inside the box (started there),
    for light emitted beyond it that enters before any scattering (the E/sigma_t inflow
    through the faces), and for light that leaves the box and comes back (photons fly on
    beyond it). What remains is light emitted beyond the box whose first scattering is beyond
    it too. Carrying it exactly takes photons that start at those first-scattering points:
    an unbounded region (a start density decaying away from the box, with no finite support),
    each photon weighted by sigma_s times the unscattered radiance there, which depends per
    direction on how much fog lies between the point and the box (or a surface in it), so a
    ray cast per photon; or, equivalently, inflow photons whose power is the full radiance
    entering the faces, estimated by a path traced outward from the face (which must then
    not be counted again by the photons that leave the box). Either is a new photon source
    with its own variance to bound; not done here (issue 20, item C).
* Emission + Noise-textured Principled Volume: 0.9998-1.0027 per channel and quadrant at the
  test's 32 samples (bound about 2 %). Before, 1.035-1.057 (a strict expected failure): beyond
  the fog's box a ray held the boundary point's coefficients, and the emission E/sigma_t held
  there was brighter than Cycles' graph followed to infinity. Now a free flight beyond the box
  tracks the graph point by point (spectral tracking against the cells' largest majorant,
  unbiased for any) over 13.8 optical depths at the boundary's least sigma_t, and holds only
  the rest, 1e-6 of the light for a fog as dense beyond as at its boundary (`src/medium/
  tracking.rs`). (The same fog without the texture: 0.9991-0.9998; the textured fog inside a
  closed room, where no ray leaves the box: 1.0022-1.0031.)
"""

import importlib

import bpy
import pytest

import scenes

from test_cycles_agreement import build
from test_textured_volume import assert_regions_match, render_both

pytestmark = pytest.mark.needs_binary

EMISSION = (1.0, 0.9, 0.8, 1.0)
NOISE_SAMPLES = 32


def emission_world(name, other=None):
    """A world with a black surface whose Volume is Emission (strength 0.1, tinted), alone or
    added (Add Shader) to the volume shader node `other(tree)` makes."""
    world = bpy.data.worlds.new(name)
    world.use_nodes = True
    tree = world.node_tree
    tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = EMISSION
    emission.inputs["Strength"].default_value = 0.1
    out = emission.outputs[0]
    if other is not None:
        add = tree.nodes.new("ShaderNodeAddShader")
        tree.links.new(out, add.inputs[0])
        tree.links.new(other(tree).outputs[0], add.inputs[1])
        out = add.outputs[0]
    tree.links.new(out, tree.nodes["World Output"].inputs["Volume"])
    return world


def absorption(tree):
    """Volume Absorption: sigma_a = 0.2 x (1 - colour) = (0.1, 0.08, 0.06)."""
    node = tree.nodes.new("ShaderNodeVolumeAbsorption")
    node.inputs["Density"].default_value = 0.2
    node.inputs["Color"].default_value = (0.5, 0.6, 0.7, 1.0)
    return node


def noise_principled(tree):
    """A scattering Principled Volume whose Density is 0.3 x ColorRamp(Noise on Object
    coordinates) from 0.3 to 1 (never 0, so the held stretches beyond the fog's box emit a
    finite E / sigma_t)."""
    coords = tree.nodes.new("ShaderNodeTexCoord")
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 0.8
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].position = 0.4
    ramp.color_ramp.elements[0].color = (0.3, 0.3, 0.3, 1.0)
    ramp.color_ramp.elements[1].position = 0.6
    scale = tree.nodes.new("ShaderNodeMath")
    scale.operation = "MULTIPLY"
    scale.inputs[1].default_value = 0.3
    node = tree.nodes.new("ShaderNodeVolumePrincipled")
    node.inputs["Color"].default_value = (0.9, 0.7, 0.5, 1.0)
    tree.links.new(coords.outputs["Object"], noise.inputs["Vector"])
    tree.links.new(noise.outputs["Fac"], ramp.inputs["Fac"])
    tree.links.new(ramp.outputs["Color"], scale.inputs[0])
    tree.links.new(scale.outputs["Value"], node.inputs["Density"])
    return node


def principled(tree):
    """A constant scattering Principled Volume: density 0.2, colour (0.9, 0.7, 0.5)."""
    node = tree.nodes.new("ShaderNodeVolumePrincipled")
    node.inputs["Density"].default_value = 0.2
    node.inputs["Color"].default_value = (0.9, 0.7, 0.5, 1.0)
    return node


@pytest.mark.parametrize("integrator", ["path", "bdpt", "vcm", "photon", "sppm"])
def test_emission_plus_absorption_matches_cycles(addon, empty_scene, tmp_path, integrator):
    """Emission + Volume Absorption on the World Volume: E / sigma_t along escaping rays.
    Measured: see the module doc."""
    scene = empty_scene
    build(scene, lambda s: setattr(s, "world", emission_world("EmitAbsorb", absorption)))
    scene.caustic.integrator = integrator
    assert_regions_match(render_both(scene, tmp_path), "emission + absorption")


@pytest.mark.parametrize("integrator", ["photon", "sppm"])
def test_emission_plus_scattering_fog_in_a_closed_room_photons_match_cycles(addon, empty_scene, tmp_path,
                                                                           integrator):
    """Emission + a constant scattering Principled Volume inside the closed grey room,
    rendered by the photon integrators: the fog's glow after a scattering or a bounce reaches
    surfaces through photons that start in the fog (`src/light/media_emit.rs`), all of it
    here, where the room holds the fog inside the box its photons start in. Measured: see
    the module doc."""
    scene = empty_scene

    def add(s):
        s.world = emission_world("EmitScatterRoom", principled)
        scenes.cube(s, "Room", 12.0, (0.0, 0.0, 0.0), material=scenes.diffuse_material("Wall", 0.3))

    build(scene, add)
    scene.caustic.integrator = integrator
    scene.caustic.samples = NOISE_SAMPLES
    scene.cycles.samples = NOISE_SAMPLES
    assert_regions_match(render_both(scene, tmp_path), f"emission + scattering fog, closed room, {integrator}")


@pytest.mark.parametrize("integrator", [
    "photon",
    pytest.param("sppm", marks=pytest.mark.xfail(
        strict=True, reason="light emitted and first scattered beyond the photons' box: 0.88-0.93x (module doc)")),
])
def test_emission_plus_scattering_fog_photons_match_cycles(addon, empty_scene, tmp_path, integrator):
    """Emission + a constant scattering Principled Volume in the open scene, rendered by the
    photon integrators: photons start in the fog only within the box of the scene, so the
    fog's glow from beyond it that scatters back (a diffusion length of about 9 m in red)
    reaches SPPM's visible points from no photon; Jensen's gather rays path-trace what
    scatters in the fog and miss it only at the gather points. Measured: see the module doc."""
    scene = empty_scene
    build(scene, lambda s: setattr(s, "world", emission_world("EmitScatter", principled)))
    scene.caustic.integrator = integrator
    assert_regions_match(render_both(scene, tmp_path), f"emission + scattering fog, {integrator}")


def test_emission_plus_noise_fog_in_a_closed_room_matches_cycles(addon, empty_scene, tmp_path):
    """Emission + the Noise-textured Principled Volume inside a closed grey room (a 12 m cube
    around the floor and box): no ray leaves the fog's box, so the graph is tracked point by
    point everywhere and the emission folded into the Principled Volume's graph is checked
    alone. Measured: see the module doc."""
    scene = empty_scene

    def add(s):
        s.world = emission_world("EmitNoiseRoom", noise_principled)
        scenes.cube(s, "Room", 12.0, (0.0, 0.0, 0.0), material=scenes.diffuse_material("Wall", 0.3))

    build(scene, add)
    scene.caustic.samples = NOISE_SAMPLES
    scene.cycles.samples = NOISE_SAMPLES
    assert_regions_match(render_both(scene, tmp_path), "emission + noise fog, closed room")


def test_emission_plus_noise_fog_matches_cycles(addon, empty_scene, tmp_path):
    """Emission + a Principled Volume with a Noise density (textured fog): the emission is
    folded into the Principled Volume's graph. Measured: see the module doc."""
    scene = empty_scene
    build(scene, lambda s: setattr(s, "world", emission_world("EmitNoise", noise_principled)))
    # 32 samples (Cycles tracks this fog slowly): the bound, derived from the noise, widens.
    scene.caustic.samples = NOISE_SAMPLES
    scene.cycles.samples = NOISE_SAMPLES
    assert_regions_match(render_both(scene, tmp_path), "emission + noise fog")


def test_emission_alone_is_left_out_with_cycles_inf(addon, empty_scene, tmp_path):
    """An Emission alone on the World Volume is not exported; the warning names the world and
    says what Cycles renders (inf). Emission + Absorption exports one medium with both."""
    world_mod = importlib.import_module(addon.__name__ + ".export.world")
    empty_scene.world = emission_world("Alone")
    value, warnings = world_mod.world_extension(empty_scene, str(tmp_path))
    assert value is None or "medium" not in value
    assert len(warnings) == 1 and "world 'Alone'" in warnings[0] and "inf" in warnings[0], warnings
    empty_scene.world = emission_world("Both", absorption)
    value, warnings = world_mod.world_extension(empty_scene, str(tmp_path))
    assert warnings == []
    medium = value["medium"]
    assert medium["emission"] == pytest.approx([0.1, 0.09, 0.08])
    assert medium["density"] * medium["absorption_color"][0] == pytest.approx(0.1)
