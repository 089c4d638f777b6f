"""Hair: particle hair on a sphere against Cycles, and the export of hair and Curves objects.

The furry sphere: a grey sphere (radius 0.6) with 400 hair particles of length 0.3, each
replaced by 5 rendered interpolated children (2000 strands), root diameter 1 × radius scale 0.03 (radius
0.015 at the root, closed tip), the same Lambertian material on the sphere and the hair
(Principled BSDF, roughness 1, specular IOR level 0, which both renderers shade as a diffuse
surface with the curve's normal), on the agreement test's floor, lit by a sun, 3 bounces.

The bound is test_cycles_agreement's (5 sigma of the two renderers' two-seed means, block
variance) plus a model allowance: Cycles intersects each strand as a Catmull-Rom swept circle
through the render-step points, Caustic as straight round cones between them
(export/curves.py), which leaves the chain within L² κ / 8 of the curve for a segment of
length L and curvature κ; for these strands (L = 0.3 / 8, κ below 1 / 0.3) that is under 6e-4,
under 4 % of the root radius, and the same on both sides of each strand, so the covered area
moves by far less than the 1 % allowance of the light-type tests (which covers filter and
sample-pattern differences).
"""

import importlib
import json
import os

import bpy
import numpy as np
import pytest

import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, SEEDS, assert_mean_matches_cycles

W, H = 64, 48
SAMPLES = 64
BOUNCES = 3


def furry_sphere(scene, hair=True):
    """The furry sphere scene (see the module's comment); returns the sphere object."""
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    fur = scenes.diffuse_material("Fur", 0.5)
    scenes.plane(scene, "Floor", 10.0, material=scenes.diffuse_material("Grey", 0.5))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.6, location=(0.0, 0.0, 0.7), segments=32, ring_count=16)
    sphere = bpy.context.object
    sphere.data.materials.append(fur)
    if hair:
        modifier = sphere.modifiers.new("Hair", "PARTICLE_SYSTEM")
        settings = modifier.particle_system.settings
        settings.type = "HAIR"
        settings.count = 400
        settings.hair_length = 0.3
        settings.child_type = "INTERPOLATED"
        settings.child_percent = 1
        settings.rendered_child_count = 5
        settings.radius_scale = 0.03
        settings.material = 1
    scenes.camera(scene, (0.0, -3.2, 1.6), (70.0, 0.0, 0.0), lens=35.0)
    scenes.light(scene, "Sun", "SUN", rotation_deg=(35.0, 15.0, 0.0), energy=3.0, angle=0.0)
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)
    return sphere


@pytest.mark.needs_binary
def test_furry_sphere_matches_cycles(empty_scene, tmp_path):
    scene = empty_scene
    sphere = furry_sphere(scene)
    ratios = assert_mean_matches_cycles(scene, tmp_path, "furry sphere", MODEL_ALLOWANCE)
    # Per pixel: the two-seed means' mean absolute difference against Cycles, beside the same
    # measure between Cycles' two seeds (its noise); printed for the issue's note.
    load = {e: [scenes.load_pixels(str(tmp_path / f"{e}_{s}.exr"))[..., :3] for s in SEEDS] for e in ("CYCLES", "CAUSTIC")}
    per_pixel = np.abs((load["CAUSTIC"][0] + load["CAUSTIC"][1]) - (load["CYCLES"][0] + load["CYCLES"][1])).mean() / 2
    noise = np.abs(load["CYCLES"][0] - load["CYCLES"][1]).mean() / np.sqrt(2)
    # The hair must matter: without it Caustic's mean moves by far more than the bound.
    with_hair = np.mean(load["CAUSTIC"])
    sphere.modifiers.remove(sphere.modifiers["Hair"])
    bare = np.mean(scenes.render_rgb(scene, "CAUSTIC", SEEDS[0], str(tmp_path / "bare.exr")))
    print(f"\n[hair] furry sphere Caustic/Cycles {ratios['']:.4f}; per-pixel mean |difference| {per_pixel:.4f} "
          f"(Cycles' own seed-to-seed {noise:.4f}); without hair the mean moves {bare / with_hair - 1:+.1%}")
    # 5 %: several times the agreement bound (1 % allowance + 5 sigma, 1.3 % of the mean here).
    assert abs(bare / with_hair - 1) > 0.05


def test_particle_hair_is_exported_render_evaluated(addon, empty_scene, tmp_path):
    """The render-evaluated children are exported (not the viewport's share), Cycles' radii,
    world-space points in glTF axes, a root UV per strand, the material, no hair warning."""
    export = importlib.import_module(addon.__name__ + ".export")
    curves = importlib.import_module(addon.__name__ + ".export.curves")
    scene = empty_scene
    sphere = furry_sphere(scene)
    sphere.location.x = 2.0
    bpy.ops.mesh.uv_texture_add()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    warnings = []
    strands = curves.scene_strands(depsgraph, warnings)
    assert len(strands) == 1 and not warnings, warnings
    s = strands[0]
    settings = sphere.particle_systems[0].settings
    steps = 2 ** settings.render_step + 1
    # Children only (interpolated children replace their parents, as in Cycles); the
    # viewport depsgraph evaluates display children (child_percent per parent).
    assert len(s.counts) == settings.count * settings.child_percent
    per_strand = steps
    assert np.all(s.counts == per_strand)
    assert len(s.points) == len(s.radii) == per_strand * len(s.counts)
    root = s.radii[:: per_strand]
    assert root == pytest.approx(0.5 * settings.radius_scale * settings.root_radius, rel=1e-6)
    assert np.all(s.radii[per_strand - 1:: per_strand] == 0.0), "closed tips"
    # Roots on the sphere (world space, glTF axes: Blender (x, y, z) -> (x, z, -y)).
    centre = np.array([2.0, 0.7, 0.0])
    dist = np.linalg.norm(s.points[:: per_strand] - centre, axis=1)
    assert dist == pytest.approx(0.6, abs=0.01)
    assert s.uvs is not None and s.uvs.shape == (len(s.counts), 2)
    assert s.material.name == "Fur"

    # The whole export: the extension, its buffer and the shared material.
    settings = export.render_settings(scene, (W, H), "Camera")
    path, state = export.export_scene(bpy.context.evaluated_depsgraph_get(), str(tmp_path), settings)
    with open(path) as f:
        doc = json.load(f)
    assert "CAUSTIC_curves" in doc["extensionsUsed"]
    (obj,) = doc["extensions"]["CAUSTIC_curves"]["objects"]
    assert doc["materials"][obj["material"]]["name"] == "Fur"
    # The strands belong to their emitter, whose node light linking finds by that name.
    assert obj["object"] == s.object_name != obj["name"]
    assert any(n.get("name") == obj["object"] for n in doc["nodes"])
    assert doc["accessors"][obj["counts"]]["count"] == len(s.counts)
    buffer = doc["buffers"][doc["bufferViews"][doc["accessors"][obj["points"]]["bufferView"]]["buffer"]]
    assert os.path.getsize(os.path.join(tmp_path, buffer["uri"])) == buffer["byteLength"]
    assert not any("hair" in w.lower() for w in state.warnings), state.warnings
    # Drawn as Cycles draws them: ribbons under Blender 5.0's default Curves Shape, else round.
    assert scene.cycles_curves.shape == "RIBBONS" and obj["shape"] == "ribbon"
    scene.cycles_curves.shape = "THICK"
    assert all(not s.ribbon for s in curves.scene_strands(bpy.context.evaluated_depsgraph_get(), []))


def test_curves_object_is_exported(addon, empty_scene):
    """A Curves object: its points through the object's transform, its radius attribute
    (scaled with the object), straight segments for Poly curves, a material from its slot."""
    curves = importlib.import_module(addon.__name__ + ".export.curves")
    scene = empty_scene
    data = bpy.data.hair_curves.new("Strands")
    data.add_curves([3, 2])
    data.points.foreach_set("position", [0, 0, 0, 0, 0, 1, 0, 0, 2, 1, 0, 0, 1, 1, 0])
    radius = data.attributes.new("radius", "FLOAT", "POINT")
    radius.data.foreach_set("value", [0.1, 0.05, 0.0, 0.02, 0.02])
    data.set_types(type="POLY")
    data.materials.append(scenes.diffuse_material("Strand", 0.3))
    obj = bpy.data.objects.new("Strands", data)
    scene.collection.objects.link(obj)
    obj.location = (0.0, 0.0, 1.0)
    obj.scale = (2.0, 2.0, 2.0)
    warnings = []
    (s,) = curves.scene_strands(bpy.context.evaluated_depsgraph_get(), warnings)
    assert not warnings
    assert list(s.counts) == [3, 2], "Poly curves are not subdivided"
    assert not s.ribbon, "Cycles draws Poly curves round (Thick Linear) whatever the Curves Shape"
    # (0, 0, 2) in the object -> (0, 0, 5) in the world -> (0, 5, 0) in glTF axes.
    assert s.points[2] == pytest.approx([0.0, 5.0, 0.0])
    assert s.radii == pytest.approx([0.2, 0.1, 0.0, 0.04, 0.04])
    assert s.material.name == "Strand"
    # Without a radius attribute: Cycles' 0.005 (times the scale); Catmull-Rom curves are
    # cut into SUBDIVISIONS pieces per segment through the same end points.
    data.attributes.remove(data.attributes["radius"])
    data.set_types(type="CATMULL_ROM")
    (s,) = curves.scene_strands(bpy.context.evaluated_depsgraph_get(), [])
    assert list(s.counts) == [2 * curves.SUBDIVISIONS + 1, curves.SUBDIVISIONS + 1]
    assert s.radii == pytest.approx(2.0 * curves.DEFAULT_CURVES_RADIUS)
    assert s.points[0] == pytest.approx([0.0, 1.0, 0.0]) and s.points[2 * curves.SUBDIVISIONS] == pytest.approx([0.0, 5.0, 0.0])
    assert s.ribbon, "Catmull-Rom curves take the scene's Curves Shape (Ribbons by default)"


@pytest.mark.needs_binary
@pytest.mark.parametrize("parametrization", ["COLOR", "MELANIN"])
@pytest.mark.parametrize("shape", ["RIBBONS", "THICK"])
def test_principled_hair_bsdf_matches_cycles(empty_scene, tmp_path, parametrization, shape):
    """The furry sphere with a Principled Hair BSDF (Chiang, Blender 5.0's default model) on the
    strands: brown direct colouring, and melanin with a tint; the strands drawn as ribbons
    (Blender 5.0's default Curves Shape) and as round tubes. Same bound as the diffuse case.
    Ribbons matter: Cycles ignores a ribbon hit nearer than two radii along any ray, so in this
    fur (strands about as far apart as that) shadow rays and bounces pass neighbours that round
    strands stop; drawn round, Caustic was 3-4 % darker than Cycles' ribbons (COLOR R 0.960),
    while round against round agreed (1.003). Ribbons follow the Catmull-Rom curve through
    the points, as Cycles' (measured on bpy 5.0.1 over three runs: COLOR 0.9968-0.9998,
    MELANIN 1.0001-1.0015, furry sphere 0.9998-1.0003; along straight segments one run gave
    COLOR 0.9968-0.9981, MELANIN 1.0013-1.0015, furry 1.0009: the same within the runs' spread).
    Beyond its allowance: Cycles samples the R lobe's longitudinal angle with the uncoated
    variance (its pdf then differs from its sampling when Coat > 0; the test keeps Coat 0) and
    takes h from the curve's true normal, Caustic from the segment's axis (exact on cylinders;
    these strands taper by 0.015 over 0.3, a slope of 3 degrees)."""
    scene = empty_scene
    sphere = furry_sphere(scene)
    hair = scenes.shader_node_material("Hairy", "ShaderNodeBsdfHairPrincipled")
    node = hair.node_tree.nodes["Principled Hair BSDF"]
    node.parametrization = parametrization
    # Inputs of the other parametrisations are hidden (not reachable by key).
    values = {"Color": (0.5, 0.3, 0.15, 1.0), "Roughness": 0.35, "Radial Roughness": 0.4, "Melanin": 0.4,
              "Melanin Redness": 0.6, "Tint": (0.9, 0.8, 0.7, 1.0)}
    for socket in node.inputs:
        if socket.name in values:
            socket.default_value = values[socket.name]
    sphere.data.materials.append(hair)
    sphere.particle_systems[0].settings.material = 2
    scene.cycles_curves.shape = shape
    ratios = assert_mean_matches_cycles(scene, tmp_path, f"hair BSDF {parametrization} {shape}", MODEL_ALLOWANCE,
                                        per_channel=True)
    print(f"\n[hair] Principled Hair BSDF ({parametrization}, {shape}) Caustic/Cycles {ratios}")


def test_principled_hair_bsdf_is_exported(addon, empty_scene, tmp_path):
    """Strands whose material is a Principled Hair BSDF carry CAUSTIC_materials_hair on that
    material: the absorption of its colour (Cycles' inverse of the fibre's albedo), roughness,
    radial roughness, coat, offset and IOR; the Huang model is named in a warning."""
    curves = importlib.import_module(addon.__name__ + ".export.curves")
    scene = empty_scene
    sphere = furry_sphere(scene)
    hair = scenes.shader_node_material("Hairy", "ShaderNodeBsdfHairPrincipled",
                                       **{"Color": (0.5, 0.3, 0.15, 1.0), "Coat": 0.25})
    node = hair.node_tree.nodes["Principled Hair BSDF"]
    assert node.model == "CHIANG"
    sphere.data.materials.append(hair)
    sphere.particle_systems[0].settings.material = 2
    export = importlib.import_module(addon.__name__ + ".export")
    settings = export.render_settings(scene, (W, H), "Camera")
    path, state = export.export_scene(bpy.context.evaluated_depsgraph_get(), str(tmp_path), settings)
    with open(path) as f:
        doc = json.load(f)
    (obj,) = doc["extensions"][curves.CURVES_EXTENSION]["objects"]
    material = doc["materials"][obj["material"]]
    assert material["name"] == "Hairy"
    params = material["extensions"][curves.HAIR_EXTENSION]
    fac = 5.969 - 0.215 * 0.3 + 2.532 * 0.3 ** 2 - 10.73 * 0.3 ** 3 + 5.574 * 0.3 ** 4 + 0.245 * 0.3 ** 5
    assert params["sigma"] == pytest.approx([(np.log(c) / fac) ** 2 for c in (0.5, 0.3, 0.15)], rel=1e-5)
    assert params["coat"] == pytest.approx(0.25) and params["ior"] == pytest.approx(1.55)
    assert params["offset"] == pytest.approx(np.radians(2.0), rel=1e-5)
    assert curves.HAIR_EXTENSION in doc["extensionsUsed"]
    assert not any("Hairy" in w for w in state.warnings), state.warnings
    node.model = "HUANG"
    _, state = export.export_scene(bpy.context.evaluated_depsgraph_get(), str(tmp_path), settings)
    assert any("Huang" in w and "Hairy" in w for w in state.warnings), state.warnings
