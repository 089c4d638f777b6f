"""Material fidelity: the add-on's part of the issue's "done when", Caustic against Cycles.

Each case renders one subject on the grey floor of test_material_agreement.py (disk area light
above, camera looking down; 64x48, 256 samples, 8 bounces of every kind, no clamping, no
denoising, caustics on) with both engines and two seeds each, and compares the image means
with test_cycles_agreement.assert_mean_matches_cycles: |difference| <= 5 sigma (sigma from the
two renders' seed differences, 8x8-block method) + a model allowance. The allowances are not
tuned on these renders:
* 1 % wherever Cycles and Caustic model the same thing: the residual the light tests measure
  with identical materials (sample pattern, filter at the border, float32; 0.2 %), with room;
* 0.5 % for the default Principled BSDF and for an object without a material (which Cycles
  renders as the default Principled BSDF): the issue's own bound;
* the Glass BSDF colour is checked channel by channel (the issue is red and blue off on a green
  glass while the grey mean hides it).

Measured with the renderer of the branch's base (Caustic/Cycles of the image mean): no material
1.0023, default Principled 1.0023, Glass BSDF colour (0.3, 0.9, 0.3) R 1.209 G 1.054 B 1.209,
normal map 0.715 (tilts along U only 1.046), rough metal 0.3/0.6/1.0: 0.992/0.903/0.646, rough
glass 0.3/0.6/1.0: 0.954/0.649/0.393, rough glass of IOR 1: 0.216, glass of base colour 0.8:
sphere 1.002, Suzanne 0.985 (0.890 and 0.917 before the add-on wrote sqrt(base), below), glass
sheet 1.060 (1.116 thin-walled), sheen 1.150 with glTF's Charlie sheen, 0.9949 with Cycles' microfiber sheen
(CAUSTIC_materials_sheen). Anisotropic metal (Anisotropic 0.6, roughness 0.4): 1.006 with the add-on's
CAUSTIC_materials_anisotropy (Cycles' width mapping), 0.906 with glTF's mapping of the same strength.
The Glass BSDF node is rendered from its shader graph (CAUSTIC_materials_nodes), whose Glass
closure tints reflection and transmission as Cycles does: R 1.0001 G 1.0137 B 1.0001.
Refraction in Cycles' convention (a refracted ray keeps 1 - F of its throughput, not (1 - F)/η²;
the same over closed objects, not over one surface) with the sheet kept a refracting volume:
glass sheet 0.9976, Suzanne 0.9934 (was 0.985), closed sphere 1.004, the rest unchanged.

After the dielectric layer took Cycles' Fresnel (bsdf/fresnel_layer.rs): the normal-mapped sphere
1.0002 and with tilts along U only 1.0007 (were 1.020 and 1.014: the Schlick layer on a tilted
normal was the difference, not the tangents or the filtering); no material 1.0003,
default Principled 1.0003, anisotropic metal 1.0061, sheen 0.9992, Sheen BSDF node 0.9993; thin
film on IOR 1.5 (400 nm, film IOR 1.33) R 1.0013 G 1.0010 B 1.0010.

Rough glass at roughness 1.0 (0.941 of Cycles under the area light, a strict xfail until then) is
Cycles' light sampling, not the material: see CYCLES_GLASS_FURNACE_LOSS; against Cycles' BSDF-sampled
estimate it is 1.020.

Cases that cannot pass with today's renderer are marked strict xfails (`pytest.mark.xfail(strict=True,
reason=...)` in their marks) naming the renderer fix they wait for, so that the fix's merge turns them
into failures (XPASS) until the mark is removed; none is left.
Ratios are printed with pytest -s.
"""

import json
import math

import bpy
import pytest

import scenes
from test_cycles_agreement import assert_mean_matches_cycles
from test_material_agreement import BOUNCES, H, SAMPLES, W, principled, uv_sphere

pytestmark = pytest.mark.needs_binary

MATCHED = 0.01  # same model in both renderers (module doc)
ISSUE_DEFAULT = 0.005  # the issue's bound for the default Principled BSDF
# Thin film: the same model (bsdf/thin_film.rs), but Caustic's colour-matching functions are
# Wyman et al.'s fit of CIE 1931 (within 1 % of the tables' peak) where Cycles tabulates the
# tables themselves: 1 % for that on top of MATCHED.
FILM = MATCHED + 0.01

# What each remaining xfail waits for (measured Caustic/Cycles after multiscatter GGX, tangent
# handedness and IOR 1 glass landed; the marks of the cases those fixed are gone).
# Rough glass at roughness 1.0 against the area light of the other cases is 0.94 of Cycles, and
# that is Cycles disagreeing with itself: with an emissive disk found by BSDF sampling alone
# (emission sampling None) Cycles renders the same sphere 0.939 of what it renders when it
# samples that disk (1.179 vs 1.257, 1024 spp), while Caustic gives the same either way. Cycles'
# rough refraction eval, which only light sampling calls, does not reject half vectors that no
# microfacet produces (bsdf_microfacet_eval: "TODO: check if the refraction configuration is
# valid"): integrated over all directions, such pairs add 12-106 % to the refracted light at
# alpha = 1 and 4-54 % at alpha = 0.36 (a Monte Carlo of its formula against its own sampling). So the roughness-1 case is compared with
# Cycles' unbiased estimator, test_rough_glass_1_matches_cycles_bsdf_sampled_lamp below.
# Cycles' glass also loses light that Caustic keeps: a white furnace (sphere filling the frame,
# 32 bounces) is 0.985 in Cycles at roughness 1 (0.984 at 0.6, 0.996 at 0.3), 1.000 in Caustic
# (its multiscatter albedo tables under-compensate): that loss is the allowance's second part.
CYCLES_GLASS_FURNACE_LOSS = 0.015

# The subject fills the frame (a 90 mm lens frames 1.56 x 1.17 units at the sphere), so that the
# image mean measures the material, not the floor around it; the sheet needs the floor under it.
CLOSE_UP = 90.0
WIDE = 30.0


def floor_light_camera(scene, lens=CLOSE_UP):
    """The common set-up of test_material_agreement.py without its subject."""
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    scenes.plane(scene, "Floor", 10.0, material=scenes.diffuse_material("Grey", 0.5))
    scenes.light(scene, "Disk", "AREA", location=(0.8, -0.5, 3.0), shape="DISK", size=0.8, energy=400.0)
    scenes.camera(scene, (0.0, -2.2, 3.2), (35.0, 0.0, 0.0), lens=lens)
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)


def sphere_of(make):
    """A subject builder: the agreement sphere with the material `make()`."""
    def add(scene):
        uv_sphere(scene, "Ball", 0.6, (0.0, 0.0, 0.6), make())
    return add


def glass(name, roughness, ior=1.5, base=1.0):
    """A Principled BSDF glass (transmission 1) of a grey base colour."""
    return principled(name, **{"Base Color": (base, base, base, 1), "Roughness": roughness,
                               "Transmission Weight": 1.0, "IOR": ior})


def rough_metal(roughness):
    return principled(f"Metal{roughness}", **{"Base Color": (0.9, 0.6, 0.3, 1), "Roughness": roughness,
                                             "Metallic": 1.0})


def add_no_material(scene):
    """The sphere with no material slot at all."""
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=0.6, location=(0.0, 0.0, 0.6))
    bpy.context.active_object.name = "Bare"
    bpy.ops.object.shade_smooth()


def add_suzanne_glass(scene):
    """Subdivided Suzanne, an open mesh (its eye sockets are holes), in glass of base colour 0.8."""
    bpy.ops.mesh.primitive_monkey_add(size=1.0, location=(0.0, 0.0, 0.6), rotation=(math.radians(-20), 0, 0))
    obj = bpy.context.active_object
    mod = obj.modifiers.new("Subdivision", "SUBSURF")
    mod.levels = mod.render_levels = 1
    bpy.ops.object.shade_smooth()
    obj.data.materials.append(glass("OpenGlass", 0.0, base=0.8))


def add_thin_sheet(scene):
    """A single-faced glass quad between the light and the floor (a window modelled as a plane)."""
    scenes.plane(scene, "Sheet", 1.4, z=0.9, material=glass("SheetGlass", 0.0))


def normal_map_material(name, tilt_v=True):
    """A Principled BSDF whose Normal comes from a Normal Map node reading a tangent-space image:
    stripes tilted 35 degrees along +U and along +V (a wrong bitangent sign flips the second);
    without `tilt_v` only along +U (the tangent alone)."""
    mat = principled(name, **{"Base Color": (0.8, 0.8, 0.8, 1), "Roughness": 0.4})
    size = 16
    image = bpy.data.images.new(name + "Map", size, size, float_buffer=False)
    image.colorspace_settings.name = "Non-Color"
    s, c = math.sin(math.radians(35.0)), math.cos(math.radians(35.0))
    pixels = []
    for y in range(size):
        for x in range(size):
            n = (s, 0.0, c) if (x // 4) % 2 or not tilt_v else (0.0, s, c)
            pixels += [0.5 * n[0] + 0.5, 0.5 * n[1] + 0.5, 0.5 * n[2] + 0.5, 1.0]
    image.pixels.foreach_set(pixels)
    image.pack()
    tree = mat.node_tree
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    tex.interpolation = "Closest"
    normal_map = tree.nodes.new("ShaderNodeNormalMap")
    tree.links.new(tex.outputs["Color"], normal_map.inputs["Color"])
    tree.links.new(normal_map.outputs["Normal"], tree.nodes["Principled BSDF"].inputs["Normal"])
    return mat


# name -> (subject builder, model allowance, per channel, marks)
CASES = {
    "no_material": (add_no_material, ISSUE_DEFAULT, False, []),
    "default_principled": (sphere_of(lambda: principled("Default")), ISSUE_DEFAULT, False, []),
    "glass_node_color": (sphere_of(lambda: scenes.shader_node_material(
        "GreenGlass", "ShaderNodeBsdfGlass", Color=(0.3, 0.9, 0.3, 1), Roughness=0.0, IOR=1.45)),
        MATCHED, True, []),
    "normal_map": (sphere_of(lambda: normal_map_material("NormalMapped")), MATCHED, False, []),
    "normal_map_tangent_only": (sphere_of(lambda: normal_map_material("NormalMappedU", tilt_v=False)),
                                MATCHED, False, []),
    "rough_metal_0.3": (sphere_of(lambda: rough_metal(0.3)), MATCHED, False, []),
    "rough_metal_0.6": (sphere_of(lambda: rough_metal(0.6)), MATCHED, False, []),
    "rough_metal_1.0": (sphere_of(lambda: rough_metal(1.0)), MATCHED, False, []),
    "rough_glass_0.3": (sphere_of(lambda: glass("RoughGlass0.3", 0.3)), MATCHED, False, []),
    "rough_glass_0.6": (sphere_of(lambda: glass("RoughGlass0.6", 0.6)), MATCHED, False, []),
    "rough_glass_ior_1": (sphere_of(lambda: glass("GlassIor1", 0.5, ior=1.0)), MATCHED, False, []),
    "glass_0.8_closed_sphere": (sphere_of(lambda: glass("ClosedGlass", 0.0, base=0.8)), MATCHED, False, []),
    "glass_0.8_open_suzanne": (add_suzanne_glass, MATCHED, False, []),
    "thin_sheet": (add_thin_sheet, MATCHED, False, []),
    "anisotropic_metal": (sphere_of(lambda: principled("Brushed", **{
        "Base Color": (0.9, 0.6, 0.3, 1), "Roughness": 0.4, "Metallic": 1.0, "Anisotropic": 0.6})),
        MATCHED, False, []),
    "sheen": (sphere_of(lambda: principled("Sheen", **{"Base Color": (0.05, 0.05, 0.05, 1), "Roughness": 0.8,
                                                        "Sheen Weight": 1.0, "Sheen Roughness": 0.5})),
              MATCHED, False, []),
    "sheen_node": (sphere_of(lambda: scenes.shader_node_material(
        "SheenNode", "ShaderNodeBsdfSheen", Color=(0.9, 0.7, 0.5, 1), Roughness=0.3)), MATCHED, False, []),
    # Thin film (KHR_materials_iridescence from the add-on): a coated dark plastic and a soap-bubble
    # film (IOR 1 under the film: the free film's reflection), channel by channel. The soap film was
    # R 0.976 G 0.831 B 1.053 of Cycles (a strict xfail) while Blender's exporter dropped the opaque
    # material's IOR 1 and the film sat on IOR 1.5; with the IOR written back
    # (materials.restore_opaque_iors) it is 1.0097/1.0094/1.0017.
    "thin_film_coating": (sphere_of(lambda: principled("Iridescent", **{
        "Base Color": (0.02, 0.02, 0.02, 1), "Roughness": 0.2, "Thin Film Thickness": 400.0,
        "Thin Film IOR": 1.33})), FILM, True, []),
    "thin_film_soap": (sphere_of(lambda: principled("Soap", **{
        "Base Color": (0.0, 0.0, 0.0, 1), "Roughness": 0.05, "IOR": 1.0, "Thin Film Thickness": 500.0,
        "Thin Film IOR": 1.33})), FILM, True, []),
}


@pytest.mark.parametrize("case", [pytest.param(name, marks=marks) for name, (*_, marks) in CASES.items()])
def test_material_fidelity_matches_cycles(empty_scene, tmp_path, case):
    scene = empty_scene
    add_subject, allowance, per_channel, _ = CASES[case]
    floor_light_camera(scene, WIDE if case == "thin_sheet" else CLOSE_UP)
    add_subject(scene)
    assert_mean_matches_cycles(scene, tmp_path, case, allowance, per_channel=per_channel)


# BSDF sampling alone finds the lamp, so the renders are noisier than with light sampling: at
# 256 spp the image mean's sigma was 1.2 %; a lamp of 9x the area (the same power) and 4x the
# samples bring it to 0.3 %, so that 5 sigma + the allowance (3.9 %) stays well below the 6.5 %
# of Cycles' light-sampling bias that this case must not hide.
LAMP_SAMPLES = 1024


def test_rough_glass_1_matches_cycles_bsdf_sampled_lamp(empty_scene, tmp_path):
    """Rough glass of roughness 1.0 under an emissive disk that Cycles finds by BSDF sampling
    only (its material's emission sampling None), where Cycles' estimate is unbiased (see
    CYCLES_GLASS_FURNACE_LOSS). Measured: Caustic/Cycles 1.020 (0.3: 1.0002, 0.6: 1.013, the
    order of Cycles' furnace losses)."""
    scene = empty_scene
    floor_light_camera(scene)
    bpy.data.objects.remove(bpy.data.objects["Disk"])
    lamp = scenes.emission_material("Lamp", (1.0, 1.0, 1.0), 200.0 / 9.0)
    lamp.cycles.emission_sampling = "NONE"
    # A 32-gon of radius 1.2 at the disk light's place, wound to face down.
    ring = [(0.8 + 1.2 * math.cos(-2 * math.pi * i / 32), -0.5 + 1.2 * math.sin(-2 * math.pi * i / 32), 3.0)
            for i in range(32)]
    scenes.mesh_object(scene, "Lamp", ring, [tuple(range(32))], lamp)
    sphere_of(lambda: glass("RoughGlass1.0", 1.0))(scene)
    scene.cycles.samples = scene.caustic.samples = LAMP_SAMPLES
    assert_mean_matches_cycles(scene, tmp_path, "rough_glass_1.0", MATCHED + CYCLES_GLASS_FURNACE_LOSS)


def test_principled_glass_base_colour_is_written_as_its_square_root(addon, empty_scene, tmp_path):
    """Cycles tints light through a Principled glass by sqrt(base colour) per crossing, glTF by the
    base colour: a full-transmission glass of base 0.64 is written as 0.8; a partly transmissive
    one cannot be (its diffuse part needs 0.64) and is named in a warning."""
    scene = empty_scene
    floor_light_camera(scene)
    uv_sphere(scene, "Full", 0.3, (-0.5, 0, 0.3), glass("FullGlass", 0.0, base=0.64))
    partial = principled("HalfGlass", **{"Base Color": (0.64, 0.64, 0.64, 1), "Transmission Weight": 0.5})
    uv_sphere(scene, "Half", 0.3, (0.5, 0, 0.3), partial)
    settings = addon.export.render_settings(scene, (W, H), "Camera")
    path, state = addon.export.export_scene(bpy.context.evaluated_depsgraph_get(), str(tmp_path), settings)
    with open(path) as f:
        gltf = json.load(f)
    materials = {m["name"]: m for m in gltf["materials"]}
    assert materials["FullGlass"]["pbrMetallicRoughness"]["baseColorFactor"][:3] == pytest.approx([0.8] * 3, abs=1e-6)
    assert materials["HalfGlass"]["pbrMetallicRoughness"]["baseColorFactor"][:3] == pytest.approx([0.64] * 3, abs=1e-6)
    assert any("HalfGlass" in w and "square root" in w for w in state.warnings), state.warnings
    assert not any("FullGlass" in w for w in state.warnings), state.warnings
    # The exporter's empty extensions ({}: no transmission, no anisotropy) are not the real
    # thing: the floor, an opaque material, gets neither the warning nor Cycles' anisotropy
    # mapping.
    opaque = [name for name in materials if "Glass" not in name]
    assert opaque and not any(name in w for name in opaque for w in state.warnings), state.warnings
    assert not any("CAUSTIC_materials_anisotropy" in materials[n].get("extensions", {}) for n in opaque)


def test_principled_sheen_is_written_as_microfiber_with_its_weight(addon, empty_scene, tmp_path):
    """Blender's sheen is Cycles' microfiber sheen (CAUSTIC_materials_sheen), and Sheen Weight,
    which the exporter drops (it writes Sheen Tint as sheenColorFactor), scales the colour."""
    scene = empty_scene
    floor_light_camera(scene)
    mat = principled("HalfSheen", **{"Sheen Weight": 0.5, "Sheen Tint": (1.0, 0.8, 0.6, 1), "Sheen Roughness": 0.3})
    uv_sphere(scene, "Ball", 0.6, (0.0, 0.0, 0.6), mat)
    settings = addon.export.render_settings(scene, (W, H), "Camera")
    path, _ = addon.export.export_scene(bpy.context.evaluated_depsgraph_get(), str(tmp_path), settings)
    with open(path) as f:
        gltf = json.load(f)
    ext = next(m for m in gltf["materials"] if m["name"] == "HalfSheen")["extensions"]
    assert ext["CAUSTIC_materials_sheen"] == {"model": "microfiber"}
    assert ext["KHR_materials_sheen"]["sheenColorFactor"] == pytest.approx([0.5, 0.4, 0.3], abs=1e-6)
    assert ext["KHR_materials_sheen"]["sheenRoughnessFactor"] == pytest.approx(0.3, abs=1e-6)
    floor = next(m for m in gltf["materials"] if m["name"] == "Grey")
    assert "CAUSTIC_materials_sheen" not in floor.get("extensions", {})


def test_object_without_material_gets_blenders_default_surface(empty_scene, tmp_path, monkeypatch, fake_binary):
    """An object with no material (and one with an empty slot) is written with Cycles' default
    surface, a Principled BSDF of base colour 0.8, metallic 0, roughness 0.5 and IOR 1.5, not
    without a material (glTF's white metal)."""
    scene = empty_scene
    floor_light_camera(scene)
    add_no_material(scene)
    empty_slot = scenes.cube(scene, "EmptySlot", 0.5, (1.0, 0.5, 0.25))
    empty_slot.data.materials.append(None)
    folder = tmp_path / "scenes"
    monkeypatch.setenv("FAKE_CAUSTIC_SCENE_DIR", str(folder))
    scene.render.engine = "CAUSTIC"
    bpy.ops.render.render()
    (gltf,) = [json.loads(f.read_text()) for f in sorted(folder.glob("*.gltf"))]
    for mesh_name in ("Sphere", "EmptySlot"):
        mesh = next(m for m in gltf["meshes"] if m["name"] == mesh_name)
        for prim in mesh["primitives"]:
            assert "material" in prim, f"{mesh_name}: a primitive without a material (glTF's white metal)"
            mat = gltf["materials"][prim["material"]]
            pbr = mat["pbrMetallicRoughness"]
            assert pbr["baseColorFactor"] == pytest.approx([0.8, 0.8, 0.8, 1.0])
            assert pbr["metallicFactor"] == 0.0
            assert pbr["roughnessFactor"] == pytest.approx(0.5)
            # IOR 1.5 and Specular IOR Level 0.5 are glTF's defaults: no extension needed.
            assert "KHR_materials_ior" not in mat.get("extensions", {})
            assert "KHR_materials_specular" not in mat.get("extensions", {})
    defaults = [m for m in gltf["materials"] if m.get("name") == "Blender default surface"]
    assert len(defaults) == 1, "one shared default material"
    floor = next(m for m in gltf["meshes"] if m["name"] == "Floor")
    assert gltf["materials"][floor["primitives"][0]["material"]]["name"] == "Grey"
