"""The Light Path node: Caustic (through the add-on's `CAUSTIC_materials_nodes`) against Cycles.

Scenes and checks are test_nodes_agreement.py's "sphere" scenes and its two bounds (image mean
per channel within 5 sigma + 1 %, 4x4 blocks within 5 sigma + 2 %, the noise measured from two
seeds per engine): a sphere on a grey floor under a disk light, its material switched by a Light
Path output, so that an engine that ignored the ray's kind renders a visibly different image:
* Is Camera Ray: the sphere shows a bright emission to the camera, a plain red diffuse to
  everything else (it neither lights the floor nor glows in its reflection);
* Is Shadow Ray: the sphere is red diffuse but Transparent to shadow rays (no shadow on the floor);
* Is Diffuse Ray: the floor is grey to the camera but a saturated green to diffuse rays, so the
  sphere's underside takes a green bounce light that the camera never sees on the floor;
* Is Glossy Ray / Is Reflection Ray: a mirror-like sphere (Glossy 0.05) over a floor that turns
  blue only to glossy reflections — seen blue in the sphere, grey directly.
* Ray Depth on an emitter: a small sphere that emits only where Ray Depth is 2 or more lights a
  orange ball on the floor (no other light). Cycles shades an emitter found by next-event
  estimation with the shading point's path (`light_sample_shader_eval`: the path's bounce + 1),
  so it is black to the camera and to what the camera sees, and lights what one bounce
  reaches; an emitter evaluated without the path (Ray Depth 1 always) gives next-event
  estimation nothing, leaving only the rare BSDF-sampled hits (measured before the fix: mean
  R/G/B 0.046 of Cycles).
* The same emitter in world fog: light scattered in the air reaches the emitter by next-event
  estimation from medium points, which Cycles also shades with the path's counters (a point
  scattered once already sees Ray Depth 2); evaluated without the path (Ray Depth 1 at every
  medium point, before the fix) the fog's glow beyond the first bounce is lost.

BDPT and VCM render the emitter cases too: their light subpaths cannot know the camera path, so
they take such an emitter by the camera-side strategies alone, weighed as the path tracer weighs
them (`src/integrator/bdpt/path_emitters.rs`); and Is Camera Ray's and Is Diffuse Ray's switched
BSDFs, whose paths they leave to the camera side likewise (`src/integrator/bdpt/visibility.rs`).
"""

import bpy

import pytest

import scenes
from test_node_graph_export import new_material
from test_material_agreement import uv_sphere
from test_nodes_agreement import SAMPLES, BOUNCES, W, H, compare, sphere_scene

pytestmark = pytest.mark.needs_binary


def light_path_switch(output, false_shader, true_shader):
    """A maker: Mix Shader (factor: Light Path `output`) of the two shaders, each given as
    (bl_idname, {input: value})."""
    def make(name):
        mat = new_material(name)
        tree = mat.node_tree
        path = tree.nodes.new("ShaderNodeLightPath")
        mix = tree.nodes.new("ShaderNodeMixShader")
        tree.links.new(path.outputs[output], mix.inputs["Fac"])
        for slot, (kind, inputs) in zip((1, 2), (false_shader, true_shader)):
            node = tree.nodes.new(kind)
            for key, value in inputs.items():
                node.inputs[key].default_value = value
            tree.links.new(node.outputs[0], mix.inputs[slot])
        tree.links.new(mix.outputs["Shader"], tree.nodes["Material Output"].inputs["Surface"])
        return mat
    return make


RED = ("ShaderNodeBsdfDiffuse", {"Color": (0.7, 0.1, 0.05, 1.0)})
GREY = ("ShaderNodeBsdfDiffuse", {"Color": (0.5, 0.5, 0.5, 1.0)})


def floor_switched(make_floor, ball=RED):
    """A sphere scene whose floor material comes from `make_floor` (the sphere: `ball`)."""
    def build(scene, _material):
        sphere_scene(scene, scenes.shader_node_material("Ball", ball[0], **ball[1]))
        scene.objects["Floor"].data.materials[0] = make_floor("Floor switched")
    return build


STRENGTH = 200.0


def depth_lit_scene(scene, _material):
    """An orange ball on a grey floor lit only by a small sphere emitting STRENGTH where Ray Depth
    is 2 or more, nothing at depths 0 and 1."""
    sphere_scene(scene, scenes.shader_node_material("Ball", "ShaderNodeBsdfDiffuse", Color=(0.7, 0.5, 0.3, 1.0)))
    bpy.data.objects.remove(bpy.data.objects["Disk"])
    mat = new_material("Depth emitter")
    tree = mat.node_tree
    path = tree.nodes.new("ShaderNodeLightPath")
    deep = tree.nodes.new("ShaderNodeMath")
    deep.operation = "GREATER_THAN"
    deep.inputs[1].default_value = 1.5
    times = tree.nodes.new("ShaderNodeMath")
    times.operation = "MULTIPLY"
    times.inputs[1].default_value = STRENGTH
    emission = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(path.outputs["Ray Depth"], deep.inputs[0])
    tree.links.new(deep.outputs["Value"], times.inputs[0])
    tree.links.new(times.outputs["Value"], emission.inputs["Strength"])
    tree.links.new(emission.outputs["Emission"], tree.nodes["Material Output"].inputs["Surface"])
    uv_sphere(scene, "Emitter", 0.25, (0.8, -0.5, 2.2), mat)


def depth_lit_fog_scene(scene, material):
    """depth_lit_scene in a world of thin scattering fog (black background)."""
    depth_lit_scene(scene, material)
    world = bpy.data.worlds.new("Fog")
    world.use_nodes = True
    nodes = world.node_tree.nodes
    nodes["Background"].inputs["Strength"].default_value = 0.0
    fog = nodes.new("ShaderNodeVolumeScatter")
    fog.inputs["Density"].default_value = 0.3
    world.node_tree.links.new(fog.outputs["Volume"], nodes["World Output"].inputs["Volume"])
    scene.world = world


CASES = {
    "ray_depth_emitter": (depth_lit_scene, None),
    "ray_depth_emitter_in_fog": (depth_lit_fog_scene, None),
    "is_camera_ray": (sphere_scene, light_path_switch(
        "Is Camera Ray", RED, ("ShaderNodeEmission", {"Color": (1.0, 0.8, 0.3, 1.0), "Strength": 4.0}))),
    "is_shadow_ray": (sphere_scene, light_path_switch(
        "Is Shadow Ray", RED, ("ShaderNodeBsdfTransparent", {"Color": (1.0, 1.0, 1.0, 1.0)}))),
    "is_diffuse_ray": (floor_switched(light_path_switch(
        "Is Diffuse Ray", GREY, ("ShaderNodeBsdfDiffuse", {"Color": (0.05, 0.8, 0.1, 1.0)}))), None),
    "is_glossy_ray": (floor_switched(light_path_switch(
        "Is Glossy Ray", GREY, ("ShaderNodeBsdfDiffuse", {"Color": (0.1, 0.2, 0.9, 1.0)})),
        ball=("ShaderNodeBsdfGlossy", {"Roughness": 0.05})), None),
    "is_reflection_ray": (floor_switched(light_path_switch(
        "Is Reflection Ray", GREY, ("ShaderNodeBsdfDiffuse", {"Color": (0.1, 0.2, 0.9, 1.0)})),
        ball=("ShaderNodeBsdfGlossy", {"Roughness": 0.05})), None),
}


@pytest.mark.parametrize("case", list(CASES))
def test_light_path_matches_cycles(empty_scene, tmp_path, case):
    build, make = CASES[case]
    build(empty_scene, make(case) if make else None)
    scenes.small_render_settings(empty_scene, W, H, samples=SAMPLES)
    empty_scene.caustic.threads = 0
    scenes.match_cycles(empty_scene, SAMPLES, BOUNCES)
    compare(empty_scene, tmp_path, case)


def camera_only_glow(name):
    """A red diffuse sphere that also emits 4 × Is Camera Ray (Add Shader): its BSDF reads no
    Light Path output, its emission does."""
    mat = new_material(name)
    tree = mat.node_tree
    path = tree.nodes.new("ShaderNodeLightPath")
    times = tree.nodes.new("ShaderNodeMath")
    times.operation = "MULTIPLY"
    times.inputs[1].default_value = 4.0
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (1.0, 0.8, 0.3, 1.0)
    diffuse = tree.nodes.new(RED[0])
    for key, value in RED[1].items():
        diffuse.inputs[key].default_value = value
    add = tree.nodes.new("ShaderNodeAddShader")
    tree.links.new(path.outputs["Is Camera Ray"], times.inputs[0])
    tree.links.new(times.outputs["Value"], emission.inputs["Strength"])
    tree.links.new(emission.outputs["Emission"], add.inputs[0])
    tree.links.new(diffuse.outputs["BSDF"], add.inputs[1])
    tree.links.new(add.outputs["Shader"], tree.nodes["Material Output"].inputs["Surface"])
    return mat


# Scenes whose emitter or BSDF reads the Light Path node. A BSDF switched by the node makes
# its triangles restricted in BDPT and VCM (`src/integrator/bdpt/visibility.rs`): the paths
# that meet them are made by the camera side alone, as the path tracer makes them. Before
# that rule "is_camera_ray" rendered R 1.013x Cycles' in both (light tracing showed the
# sphere's red diffuse side to the camera) and the material was named in a warning.
EMITTER_CASES = {
    "ray_depth_emitter": CASES["ray_depth_emitter"],
    "ray_depth_emitter_in_fog": CASES["ray_depth_emitter_in_fog"],
    "camera_only_glow": (sphere_scene, lambda _case: camera_only_glow("Glow")),
    "is_camera_ray": CASES["is_camera_ray"],
    "is_diffuse_ray": CASES["is_diffuse_ray"],
}


@pytest.mark.parametrize("integrator", ["bdpt", "vcm"])
@pytest.mark.parametrize("case", list(EMITTER_CASES))
def test_light_path_emitters_match_cycles_bidirectionally(empty_scene, tmp_path, case, integrator):
    build, make = EMITTER_CASES[case]
    build(empty_scene, make(case) if make else None)
    scenes.small_render_settings(empty_scene, W, H, samples=SAMPLES)
    empty_scene.caustic.threads = 0
    empty_scene.caustic.integrator = integrator
    scenes.match_cycles(empty_scene, SAMPLES, BOUNCES)
    compare(empty_scene, tmp_path, f"{case} ({integrator})")
