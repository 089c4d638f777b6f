"""Hair as artists shade it, against Cycles: strand materials that read Curves Info (Intercept
through a ColorRamp root to tip, Random for per-strand variation) on a Principled BSDF and on the
Principled Hair BSDF (its inputs linked, Random Color and Random Roughness), the non-principled
Hair BSDF's two components, and Curves Info's other outputs seen through an Emission.

The scene is test_hair.py's furry sphere (2000 strands, 64 x 48 pixels, 64 samples, 3 bounces);
the sphere keeps its grey diffuse material, the strands take the material under test. The bound
is test_cycles_agreement's (5 sigma of the two renderers' two-seed means, block variance) plus
its 1 % model allowance, per channel, as test_hair.py's Principled Hair cases, which this scene's
geometry (ribbons along the Catmull-Rom curve) already brings within it.
"""

import importlib
import json

import bpy
import pytest

from test_cycles_agreement import MODEL_ALLOWANCE, assert_mean_matches_cycles
from test_hair import furry_sphere


def _strand_material(sphere, name, kind):
    """A material with one shader node `kind` on the strands (material slot 2); returns
    (material, node tree, shader node)."""
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    for node in list(tree.nodes):
        if node.type != "OUTPUT_MATERIAL":
            tree.nodes.remove(node)
    node = tree.nodes.new(kind)
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    sphere.data.materials.append(mat)
    sphere.particle_systems[0].settings.material = 2
    return mat, tree, node


def _ramp(tree, factor, colours):
    """A ColorRamp fed by `factor`, with stops at 0 and 1 of the two `colours`."""
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = colours[0]
    ramp.color_ramp.elements[1].color = colours[1]
    tree.links.new(factor, ramp.inputs["Fac"])
    return ramp


def _principled_intercept(sphere):
    """(a) Principled BSDF whose Base Color is a ColorRamp of Intercept: dark red at the root to
    pale yellow at the tip (rough, no specular: a diffuse fibre)."""
    _, tree, node = _strand_material(sphere, "InterceptPrincipled", "ShaderNodeBsdfPrincipled")
    node.inputs["Roughness"].default_value = 1.0
    node.inputs["Specular IOR Level"].default_value = 0.0
    info = tree.nodes.new("ShaderNodeHairInfo")
    ramp = _ramp(tree, info.outputs["Intercept"], ((0.3, 0.02, 0.01, 1.0), (0.9, 0.8, 0.3, 1.0)))
    tree.links.new(ramp.outputs["Color"], node.inputs["Base Color"])


def _melanin_random(sphere):
    """(b) Principled Hair (Melanin): Melanin from Curves Info Random through a Map Range (0.2 to
    0.9), Random Color 0.5 and Random Roughness 0.5 on the strands' own random number."""
    _, tree, node = _strand_material(sphere, "MelaninRandom", "ShaderNodeBsdfHairPrincipled")
    node.parametrization = "MELANIN"
    node.inputs["Roughness"].default_value = 0.3
    node.inputs["Random Color"].default_value = 0.5
    node.inputs["Random Roughness"].default_value = 0.5
    info = tree.nodes.new("ShaderNodeHairInfo")
    remap = tree.nodes.new("ShaderNodeMapRange")
    remap.inputs["To Min"].default_value = 0.2
    remap.inputs["To Max"].default_value = 0.9
    tree.links.new(info.outputs["Random"], remap.inputs["Value"])
    tree.links.new(remap.outputs["Result"], node.inputs["Melanin"])


def _colour_intercept(sphere):
    """(c) Principled Hair (Direct Coloring) whose Color is a ColorRamp of Intercept: dark brown
    at the root to blond at the tip."""
    _, tree, node = _strand_material(sphere, "ColourIntercept", "ShaderNodeBsdfHairPrincipled")
    node.parametrization = "COLOR"
    info = tree.nodes.new("ShaderNodeHairInfo")
    ramp = _ramp(tree, info.outputs["Intercept"], ((0.08, 0.04, 0.02, 1.0), (0.8, 0.6, 0.35, 1.0)))
    tree.links.new(ramp.outputs["Color"], node.inputs["Color"])


def _hair_bsdf(component):
    """(d) The (non-principled) Hair BSDF, one component, a warm colour, Offset 0 by default."""
    def build(sphere):
        _, _, node = _strand_material(sphere, f"Hair{component}", "ShaderNodeBsdfHair")
        node.component = component
        node.inputs["Color"].default_value = (0.8, 0.5, 0.3, 1.0)
        node.inputs["RoughnessU"].default_value = 0.3
        node.inputs["RoughnessV"].default_value = 0.6
    return build


def _info_emission(sphere):
    """(e) An Emission whose colour is (Length × 2, Thickness × 20, Is Strand × 0.5): each
    output's own value on the strands (Length 0.3, Thickness up to 0.03)."""
    _, tree, node = _strand_material(sphere, "InfoEmission", "ShaderNodeEmission")
    info = tree.nodes.new("ShaderNodeHairInfo")
    combine = tree.nodes.new("ShaderNodeCombineXYZ")
    for output, socket, scale in (("Length", "X", 2.0), ("Thickness", "Y", 20.0), ("Is Strand", "Z", 0.5)):
        math = tree.nodes.new("ShaderNodeMath")
        math.operation = "MULTIPLY"
        math.inputs[1].default_value = scale
        tree.links.new(info.outputs[output], math.inputs[0])
        tree.links.new(math.outputs[0], combine.inputs[socket])
    tree.links.new(combine.outputs[0], node.inputs["Color"])


def _tangent_normal_emission(sphere):
    """(e) An Emission whose colour is |Tangent Normal| (the view direction across the strand,
    world axes; its absolute value so that every component shows)."""
    _, tree, node = _strand_material(sphere, "TangentNormal", "ShaderNodeEmission")
    info = tree.nodes.new("ShaderNodeHairInfo")
    absolute = tree.nodes.new("ShaderNodeVectorMath")
    absolute.operation = "ABSOLUTE"
    tree.links.new(info.outputs["Tangent Normal"], absolute.inputs[0])
    tree.links.new(absolute.outputs[0], node.inputs["Color"])


CASES = {
    "principled_intercept": _principled_intercept,
    "melanin_random": _melanin_random,
    "colour_intercept": _colour_intercept,
    "hair_reflection": _hair_bsdf("Reflection"),
    "hair_transmission": _hair_bsdf("Transmission"),
    "info_emission": _info_emission,
    "tangent_normal": _tangent_normal_emission,
}


@pytest.mark.needs_binary
@pytest.mark.parametrize("case", list(CASES))
def test_hair_shading_matches_cycles(empty_scene, tmp_path, case):
    scene = empty_scene
    sphere = furry_sphere(scene)
    CASES[case](sphere)
    ratios = assert_mean_matches_cycles(scene, tmp_path, case, MODEL_ALLOWANCE, per_channel=True)
    print(f"\n[hair shading] {case} Caustic/Cycles {ratios}")


def test_strand_graphs_are_exported(addon, empty_scene, tmp_path):
    """A strand-only material that reads Curves Info goes as its node graph (no warning names
    Curves Info or replaced inputs); a Principled Hair BSDF with Random Color too, one without
    as the compact CAUSTIC_materials_hair; a second hair system on the emitter numbers its
    strands on from the first's (Cycles' Random), and a scaled emitter's Length is in object
    space (lengthScale)."""
    export = importlib.import_module(addon.__name__ + ".export")
    curves = importlib.import_module(addon.__name__ + ".export.curves")
    scene = empty_scene
    sphere = furry_sphere(scene)
    _principled_intercept(sphere)
    sphere.scale = (2.0, 2.0, 2.0)
    second = sphere.modifiers.new("Hair2", "PARTICLE_SYSTEM").particle_system.settings
    second.type = "HAIR"
    second.count = 10
    second.material = 3
    melanin, _, node = _strand_material(sphere, "Melanin", "ShaderNodeBsdfHairPrincipled")
    sphere.particle_systems[0].settings.material = 2
    node.parametrization = "MELANIN"
    settings = export.render_settings(scene, (64, 48), "Camera")
    path, state = export.export_scene(bpy.context.evaluated_depsgraph_get(), str(tmp_path), settings)
    with open(path) as f:
        doc = json.load(f)
    first, other = doc["extensions"][curves.CURVES_EXTENSION]["objects"]
    material = doc["materials"][first["material"]]
    assert material["name"] == "InterceptPrincipled" and "CAUSTIC_materials_nodes" in material["extensions"]
    assert not any("Curves Info" in w or "linked inputs" in w for w in state.warnings), state.warnings
    assert "randomBase" not in first and other["randomBase"] == doc["accessors"][first["counts"]]["count"]
    assert first["lengthScale"] == pytest.approx(0.5) and first.get("keyStep", 1) == 1
    hair = doc["materials"][other["material"]]
    assert curves.HAIR_EXTENSION in hair["extensions"] and "CAUSTIC_materials_nodes" not in hair["extensions"]
    node.inputs["Random Color"].default_value = 0.3
    path, state = export.export_scene(bpy.context.evaluated_depsgraph_get(), str(tmp_path / "again"), settings)
    with open(path) as f:
        doc = json.load(f)
    hair = doc["materials"][doc["extensions"][curves.CURVES_EXTENSION]["objects"][1]["material"]]
    assert "CAUSTIC_materials_nodes" in hair["extensions"] and curves.HAIR_EXTENSION not in hair["extensions"]
    assert melanin.name == hair["name"]
