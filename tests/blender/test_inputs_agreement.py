"""Shader-graph inputs and the Holdout shader, Caustic against Cycles (issue 19).

Scenes and settings are test_nodes_agreement.py's (`sphere_scene`, `flat_scene`, 48x36 pixels,
32 samples, 2 bounces, `scenes.match_cycles`), compared as test_visibility.py's holdout test:
the image mean of every channel, R, G, B and alpha, one by one, two seeds per engine, bound
5 sigma of the two engines' noise (8x8-block variance of the seeds' difference) + 1 % of
Cycles' mean (`MODEL_ALLOWANCE`, derived in test_cycles_agreement.py). Nothing is tuned here.

* Holdout (Cycles' `integrate_surface_holdout`): a camera ray, through transparent surfaces
  only, that reaches a Holdout closure of weight h takes h x its throughput from the film's
  alpha (written whether or not the film is transparent), and ends there when h = 1; the other
  closures shade on at their weights. The sphere is a Holdout, or a Mix Shader of Holdout and a
  Diffuse BSDF at 0.5 (half cut out, half the diffuse's colour), over a floor filling the view.
  Measured Caustic/Cycles alpha: before (a warned no-op: the sphere black but opaque) 1.5258
  (holdout) and 1.2082 (mix), after 1.0000 and 1.0000 (R, G, B 0.9994-0.9995 both times).
  With Film > Transparent off Cycles cuts alpha the same (0.8277 for the mix; the world counts
  as seen, the holdout's share does not): Caustic's film made every sampled pixel opaque there
  (alpha 1.2082 x Cycles'); now each integrator's camera sample keeps its held-out share
  (`CameraSample::held`) and an opaque film's alpha is 1 less it. A holdout object under an
  opaque film likewise.
* Object Info's Object Index and Material Index (the objects' and materials' Pass Index): a
  flat plane coloured (0.1 x Object Index, 0.1 x Material Index, 0.3). Before (both gave 0 with
  a warning), red and green were 0 x Cycles'; after, 0.9999 and 0.9999.
"""

import math

import bpy
import pytest

import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, SIGMAS, mean_and_variance
from test_node_graph_export import diffuse_from, new_material
from test_nodes_agreement import BOUNCES, H, SAMPLES, W, flat_scene, sphere_scene
from test_visibility import render_rgba

pytestmark = pytest.mark.needs_binary

SEEDS = (1, 2)


def compare_rgba(scene, tmp_path, label):
    """Asserts each of R, G, B and A agrees with Cycles (module doc); returns the ratios."""
    images = {e: [render_rgba(scene, e, s, str(tmp_path / f"{e}_{s}.exr")) for s in SEEDS]
              for e in ("CYCLES", "CAUSTIC")}
    failures, ratios = [], {}
    for channel, name in enumerate("RGBA"):
        (m_caustic, v_caustic), (m_cycles, v_cycles) = (
            mean_and_variance(images[e][0][..., channel], images[e][1][..., channel]) for e in ("CAUSTIC", "CYCLES"))
        bound = SIGMAS * math.sqrt(v_caustic + v_cycles) + MODEL_ALLOWANCE * m_cycles
        ratios[name] = m_caustic / m_cycles if m_cycles > 0 else float("nan")
        print(f"\n[caustic/cycles] {label} {name} ratio {ratios[name]:.4f}  caustic {m_caustic:.5f}  "
              f"cycles {m_cycles:.5f}  bound {bound:.2e}")
        assert m_cycles > 1e-3, f"{label}: Cycles' {name} is black: the scene is broken"
        if abs(m_caustic - m_cycles) > bound:
            failures.append(f"{name}: {m_caustic:.5f} against Cycles' {m_cycles:.5f} (bound {bound:.2e})")
    assert not failures, f"{label}: " + "; ".join(failures)
    return ratios


def settings(scene):
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)


def holdout(name):
    mat = new_material(name)
    tree = mat.node_tree
    node = tree.nodes.new("ShaderNodeHoldout")
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return mat


def holdout_and_diffuse(name):
    """A Mix Shader at 0.5 of a Holdout and an orange Diffuse BSDF."""
    mat = new_material(name)
    tree = mat.node_tree
    held = tree.nodes.new("ShaderNodeHoldout")
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (0.8, 0.4, 0.1, 1.0)
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = 0.5
    tree.links.new(held.outputs[0], mix.inputs[1])
    tree.links.new(diffuse.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return mat


def diffuse_held_object(name):
    """An orange Diffuse BSDF on a sphere whose object is a Holdout (`Object.is_holdout`)."""
    return holdout_and_diffuse(name)


# case: (material, film transparent, the sphere object a holdout)
HOLDOUTS = {"holdout": (holdout, True, False), "holdout_mix": (holdout_and_diffuse, True, False),
            "holdout_opaque_film": (holdout_and_diffuse, False, False),
            "holdout_object_opaque_film": (diffuse_held_object, False, True)}


@pytest.mark.parametrize("case", HOLDOUTS)
def test_holdout_shader_matches_cycles(empty_scene, tmp_path, case):
    make, transparent, held_object = HOLDOUTS[case]
    scene = empty_scene
    sphere_scene(scene, make(case))
    scene.objects["Ball"].is_holdout = held_object
    settings(scene)
    scene.render.film_transparent = transparent
    compare_rgba(scene, tmp_path, case)


def pass_indices(name):
    """Diffuse colour (0.1 Object Index, 0.1 Material Index, 0.3) from Object Info."""
    mat = new_material(name)
    mat.pass_index = 6
    tree = mat.node_tree
    info = tree.nodes.new("ShaderNodeObjectInfo")
    combine = tree.nodes.new("ShaderNodeCombineColor")
    for output, channel in (("Object Index", "Red"), ("Material Index", "Green")):
        scale = tree.nodes.new("ShaderNodeMath")
        scale.operation = "MULTIPLY"
        scale.inputs[1].default_value = 0.1
        tree.links.new(info.outputs[output], scale.inputs[0])
        tree.links.new(scale.outputs[0], combine.inputs[channel])
    combine.inputs["Blue"].default_value = 0.3
    diffuse_from(mat, combine.outputs["Color"])
    return mat


def test_object_and_material_index_match_cycles(empty_scene, tmp_path):
    scene = empty_scene
    flat_scene(scene, pass_indices("Indices"))
    bpy.data.objects["Plane"].pass_index = 4
    settings(scene)
    compare_rgba(scene, tmp_path, "pass indices")


def geometry_output(output):
    """Diffuse colour from one output of the Geometry node, plus (0, 0, 0.3) (so that no
    channel is black: Parametric's third is 0)."""
    def make(name):
        mat = new_material(name)
        tree = mat.node_tree
        node = tree.nodes.new("ShaderNodeNewGeometry")
        add = tree.nodes.new("ShaderNodeVectorMath")
        add.operation = "ADD"
        add.inputs[1].default_value = (0.0, 0.0, 0.3)
        tree.links.new(node.outputs[output], add.inputs[0])
        diffuse_from(mat, add.outputs[0])
        return mat
    return make


GEOMETRY = {"parametric_plane": (flat_scene, "Parametric"), "parametric_sphere": (sphere_scene, "Parametric")}


@pytest.mark.parametrize("case", list(GEOMETRY))
def test_geometry_output_matches_cycles(empty_scene, tmp_path, case):
    build, output = GEOMETRY[case]
    scene = empty_scene
    build(scene, geometry_output(output)(case))
    settings(scene)
    compare_rgba(scene, tmp_path, case)


def test_named_colour_attribute_matches_cycles(empty_scene, tmp_path):
    """An Attribute node into a Diffuse BSDF naming one of two colour attributes (not the
    active one): the glTF exporter's own choice wrote a fake white COLOR_0 (it sees only what a
    Principled BSDF reads), which Caustic read, with a warning: R, G, B 2.0608, 2.5125,
    2.3470 x Cycles'. The export now asks for the one attribute the graphs read by name
    (`node_graph.single_colour_attribute`): 0.9999 each, no warning."""
    mat = new_material("Named")
    attr = mat.node_tree.nodes.new("ShaderNodeAttribute")
    attr.attribute_name = "Second"
    diffuse_from(mat, attr.outputs["Color"])
    scene = empty_scene
    flat_scene(scene, mat)
    mesh = bpy.data.objects["Plane"].data
    first = mesh.color_attributes.new("First", "FLOAT_COLOR", "POINT")
    second = mesh.color_attributes.new("Second", "FLOAT_COLOR", "POINT")
    corners = [(0.9, 0.2, 0.1, 1.0), (0.2, 0.8, 0.3, 1.0), (0.1, 0.3, 0.9, 1.0), (0.7, 0.7, 0.2, 1.0)]
    for i in range(len(mesh.vertices)):
        first.data[i].color = (1.0, 0.0, 1.0, 1.0)
        second.data[i].color = corners[i % 4]
    mesh.color_attributes.active_color_name = "First"
    settings(scene)
    compare_rgba(scene, tmp_path, "named colour attribute")


def wavelength_gradient(name):
    """Diffuse colour from a Wavelength node swept from 370 to 790 nm across the plane
    (Generated X through Map Range: both ends black, the whole table between)."""
    mat = new_material(name)
    tree = mat.node_tree
    coords = tree.nodes.new("ShaderNodeTexCoord")
    split = tree.nodes.new("ShaderNodeSeparateXYZ")
    sweep = tree.nodes.new("ShaderNodeMapRange")
    sweep.inputs["To Min"].default_value = 370.0
    sweep.inputs["To Max"].default_value = 790.0
    wavelength = tree.nodes.new("ShaderNodeWavelength")
    tree.links.new(coords.outputs["Generated"], split.inputs[0])
    tree.links.new(split.outputs["X"], sweep.inputs["Value"])
    tree.links.new(sweep.outputs["Result"], wavelength.inputs["Wavelength"])
    diffuse_from(mat, wavelength.outputs["Color"])
    return mat


def normal_dot(name):
    """Diffuse grey from the Normal node's Dot of its direction with the shading normal,
    plus 0.2 (where it is negative the grey is 0 in both renderers)."""
    mat = new_material(name)
    tree = mat.node_tree
    geometry = tree.nodes.new("ShaderNodeNewGeometry")
    normal = tree.nodes.new("ShaderNodeNormal")
    normal.outputs["Normal"].default_value = (0.3, -0.5, 0.8)
    lift = tree.nodes.new("ShaderNodeMath")
    lift.inputs[1].default_value = 0.2
    tree.links.new(geometry.outputs["Normal"], normal.inputs["Normal"])
    tree.links.new(normal.outputs["Dot"], lift.inputs[0])
    diffuse_from(mat, lift.outputs[0])
    return mat


def wireframe(name):
    """Diffuse colour mixed from blue to orange by Wireframe (Size 0.05, no Pixel Size)."""
    mat = new_material(name)
    tree = mat.node_tree
    wire = tree.nodes.new("ShaderNodeWireframe")
    wire.inputs["Size"].default_value = 0.05
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.inputs["A"].default_value = (0.1, 0.2, 0.6, 1.0)
    mix.inputs["B"].default_value = (0.9, 0.5, 0.1, 1.0)
    tree.links.new(wire.outputs["Fac"], mix.inputs["Factor"])
    diffuse_from(mat, mix.outputs["Result"])
    return mat


def wireframe_pixel_size(name):
    """`wireframe` with Pixel Size on and Size 0.5 (pixels): Cycles scales the width by the
    ray's footprint (`svm_wireframe.h`). Caustic/Cycles R/G/B before (0.5 read as scene units,
    with a warning) 1.1736/1.0824/0.8302, after 1.0024/1.0009/0.9970."""
    mat = wireframe(name)
    wire = mat.node_tree.nodes["Wireframe"]
    wire.use_pixel_size = True
    wire.inputs["Size"].default_value = 0.5
    return mat


CONVERTERS = {"wavelength": (flat_scene, wavelength_gradient), "normal_dot": (sphere_scene, normal_dot),
              "wireframe": (sphere_scene, wireframe), "wireframe_pixel_size": (sphere_scene, wireframe_pixel_size)}


@pytest.mark.parametrize("case", list(CONVERTERS))
def test_converter_node_matches_cycles(empty_scene, tmp_path, case):
    build, make = CONVERTERS[case]
    scene = empty_scene
    build(scene, make(case))
    settings(scene)
    compare_rgba(scene, tmp_path, case)


def tangent_colour(direction_type="RADIAL", axis="Z", geometry=False):
    """Diffuse colour |tangent| x 0.8 + 0.1 (Vector Math Absolute, then Multiply Add), from a
    Tangent node (`direction_type`, `axis`) or Geometry's Tangent."""
    def make(name):
        mat = new_material(name)
        tree = mat.node_tree
        if geometry:
            source = tree.nodes.new("ShaderNodeNewGeometry").outputs["Tangent"]
        else:
            node = tree.nodes.new("ShaderNodeTangent")
            node.direction_type, node.axis = direction_type, axis
            if direction_type == "UV_MAP":
                node.uv_map = "UVMap"
            source = node.outputs["Tangent"]
        absolute = tree.nodes.new("ShaderNodeVectorMath")
        absolute.operation = "ABSOLUTE"
        scale = tree.nodes.new("ShaderNodeVectorMath")
        scale.operation = "MULTIPLY_ADD"
        scale.inputs[1].default_value = (0.8, 0.8, 0.8)
        scale.inputs[2].default_value = (0.1, 0.1, 0.1)
        tree.links.new(source, absolute.inputs[0])
        tree.links.new(absolute.outputs[0], scale.inputs[0])
        diffuse_from(mat, scale.outputs[0])
        return mat
    return make


def uv_sphere_scene(scene, material):
    """`sphere_scene` with the ball unwrapped (a UV map named UVMap, Blender's sphere unwrap)."""
    sphere_scene(scene, material)
    ball = bpy.data.objects["Ball"]
    if ball.data.uv_layers.get("UVMap") is None:
        ball.data.uv_layers.new(name="UVMap")
    ball.rotation_euler = (0.4, 0.3, 0.0)


TANGENTS = {"tangent_radial_z": tangent_colour(), "tangent_radial_x": tangent_colour(axis="X"),
            "tangent_uv_map": tangent_colour("UV_MAP"), "geometry_tangent": tangent_colour(geometry=True)}


# Geometry's Tangent on the unwrapped plane: radial about Z (Cycles), not the UV tangent (+X).
TANGENTS["geometry_tangent_plane"] = tangent_colour(geometry=True)


@pytest.mark.parametrize("case", list(TANGENTS))
def test_tangent_matches_cycles(empty_scene, tmp_path, case):
    scene = empty_scene
    (flat_scene if case.endswith("_plane") else uv_sphere_scene)(scene, TANGENTS[case](case))
    settings(scene)
    compare_rgba(scene, tmp_path, case)


def principled_glass(roughness):
    """A maker: the Principled BSDF as clear glass (Transmission 1) of the given Roughness."""
    def make(name):
        mat = new_material(name)
        bsdf = mat.node_tree.nodes.new("ShaderNodeBsdfPrincipled")
        bsdf.inputs["Transmission Weight"].default_value = 1.0
        bsdf.inputs["Roughness"].default_value = roughness
        mat.node_tree.links.new(bsdf.outputs[0], mat.node_tree.nodes["Material Output"].inputs["Surface"])
        return mat
    return make


# Film > Transparent Glass (Cycles' LABEL_TRANSMIT_TRANSPARENT): a camera path that only
# refracted through glass at most the Roughness Threshold rough (αx·αy at most its fourth
# power), then meets the world, leaves the pixel that transparent (its throughput's mean) and
# adds no world to Combined. A glass sphere over a small matte cube, no floor, under a disk
# light and a grey world, threshold 0.3. Before (the setting was not exported): Caustic/Cycles
# alpha 4.90 for the smooth Glass BSDF and 2.38 for the Principled glass of Roughness 0.25, RGB
# 1.21 and 1.41 (the world seen through the glass was added); after: alpha 0.9969 and 1.0036.
# The rougher glass (0.4) stays opaque in both. RGB's bound is wide here (glass caustics at
# 32 samples); alpha is what the case measures. The other integrators follow the rule too
# (BDPT and VCM with the glass restricted to the camera side, `bdpt::with_transparent_glass`;
# the photon integrators' camera paths as the path tracer's); before, they kept glass opaque:
# alpha 2.375 (BDPT, rough 0.25), 4.905 (VCM, smooth), 4.905 (photon mapping, smooth) and 2.375
# (SPPM, rough 0.25); now 1.0024, 0.9864, 0.9969 and 1.0036.
TRANSPARENT_GLASS = {
    "transparent_glass_smooth": (lambda name: scenes.shader_node_material(name, "ShaderNodeBsdfGlass",
                                                                          Roughness=0.0), "path"),
    "transparent_glass_rough_under_threshold": (principled_glass(0.25), "path"),
    "transparent_glass_rough_over_threshold": (principled_glass(0.4), "path"),
    "transparent_glass_rough_under_threshold_bdpt": (principled_glass(0.25), "bdpt"),
    "transparent_glass_smooth_vcm": (lambda name: scenes.shader_node_material(name, "ShaderNodeBsdfGlass",
                                                                              Roughness=0.0), "vcm"),
    "transparent_glass_smooth_photon": (lambda name: scenes.shader_node_material(name, "ShaderNodeBsdfGlass",
                                                                                 Roughness=0.0), "photon"),
    "transparent_glass_rough_under_threshold_sppm": (principled_glass(0.25), "sppm"),
}


@pytest.mark.parametrize("case", TRANSPARENT_GLASS)
def test_transparent_glass_matches_cycles(empty_scene, tmp_path, case):
    scene = empty_scene
    maker, integrator = TRANSPARENT_GLASS[case]
    sphere_scene(scene, maker(case))
    bpy.data.objects.remove(scene.objects["Floor"])
    scenes.cube(scene, "Block", 0.5, (0.25, 0.2, -0.3), material=scenes.diffuse_material("Matte", 0.8))
    world = bpy.data.worlds.new("Grey")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.3, 0.3, 0.3, 1.0)
    scene.world = world
    settings(scene)
    scene.render.film_transparent = True
    scene.cycles.film_transparent_glass = True
    scene.cycles.film_transparent_roughness = 0.3
    scene.caustic.integrator = integrator
    compare_rgba(scene, tmp_path, case)
