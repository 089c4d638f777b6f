"""Caustic and Cycles agree on materials: glass, rough glass, rough metal, coated plastic, a tinted
coat, a tinted specular layer and a sheen cloth; and on the shader nodes Blender's glTF exporter
does not read (Diffuse, textured Diffuse, Glossy, Metallic and Glass BSDF), which the add-on
translates.

Scene: a grey Lambertian floor, a sphere with the material under test, a disk area light
above, the camera looking down at the sphere. Both renderers: 64x48, 8 bounces, no clamping,
no denoising, Blackman-Harris 1.5 px; reflective and refractive caustics on in Cycles.

Tolerance, derived as in test_cycles_agreement.py: two seeds per renderer, the variance of
the image mean from 8x8-block sums of the seed differences, bound = 5 sigma + a model
allowance. The allowance is per material, with the measured reason:
* glass (smooth and rough): 2 % — both renderers use exact dielectric Fresnel and GGX
  (single scattering for Caustic; Cycles' Principled glass is multiscatter GGX, which keeps
  the energy single scattering loses at roughness > 0.3);
* coated plastic: 3 % — Caustic's coat uses Schlick's Fresnel (F0 0.04) with albedo scaling;
  Cycles' the exact dielectric Fresnel of the coat IOR (1.5) and its own layering;
* tinted coat (Coat IOR 1.8, Coat Tint, through CAUSTIC_materials_coat) and Specular Tint:
  3 %, as the coated plastic (measured 1.0006 and 1.0003 on bpy 5.0.1);
* sheen cloth: 1 % — both render the microfiber sheen (Zeltner et al. 2022; the add-on writes
  CAUSTIC_materials_sheen); measured Caustic/Cycles 0.9994 on this scene (1.017 with glTF's
  Charlie sheen);
* rough metal: 4 % — Cycles' Principled metal uses the F82-tint Fresnel and multiscatter GGX,
  Caustic glTF's Schlick Fresnel and single scattering: at roughness 0.5 the multiple
  scattering Caustic leaves out is a few per cent of the reflected light (Kulla & Conty
  2017, fig. 3).
* Diffuse BSDF node: 1 % (a Lambertian in both; measured 0.9998), textured: 2 % (8-bit PNG
  export of the image; measured 0.9998; a lost texture renders white, 1.27);
* Glossy and Metallic BSDF nodes: 4 %, as the rough metal (Caustic: Schlick metal with F0 = the
  colour, single scattering; Cycles: multiscatter GGX, Glossy without Fresnel, Metallic with
  F82); measured 1.0013 and 1.0034;
* Glass BSDF node: 2 %, as the glass (measured 0.9941).
Measured ratios are printed (pytest -s) for the issue's closing note.
"""

import bpy
import pytest

import scenes
from test_cycles_agreement import assert_mean_matches_cycles

pytestmark = pytest.mark.needs_binary

W, H = 64, 48
SAMPLES = 256
BOUNCES = 8


def principled(name, **inputs):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    for key, value in inputs.items():
        bsdf.inputs[key].default_value = value
    return mat


shader_node = scenes.shader_node_material


def textured_diffuse(name):
    """A Diffuse BSDF whose Color is an image texture (a generated 8x8 two-colour checker)."""
    mat = shader_node(name, "ShaderNodeBsdfDiffuse")
    image = bpy.data.images.new(name + "Checker", 8, 8)
    pixels = []
    for y in range(8):
        for x in range(8):
            pixels += [0.9, 0.5, 0.1, 1.0] if (x + y) % 2 else [0.1, 0.3, 0.8, 1.0]
    image.pixels.foreach_set(pixels)
    image.pack()
    tree = mat.node_tree
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    tex.interpolation = "Closest"
    diffuse = next(n for n in tree.nodes if n.type == "BSDF_DIFFUSE")
    tree.links.new(tex.outputs["Color"], diffuse.inputs["Color"])
    return mat


def uv_sphere(scene, name, radius, center, material):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=radius, location=center)
    obj = bpy.context.active_object
    obj.name = name
    bpy.ops.object.shade_smooth()
    obj.data.materials.append(material)
    return obj


MATERIALS = {
    "glass": (lambda: principled("Glass", **{"Base Color": (1, 1, 1, 1), "Roughness": 0.0,
                                             "Transmission Weight": 1.0, "IOR": 1.5}), 0.02),
    "rough_glass": (lambda: principled("RoughGlass", **{"Base Color": (1, 1, 1, 1), "Roughness": 0.3,
                                                        "Transmission Weight": 1.0, "IOR": 1.5}), 0.02),
    "rough_metal": (lambda: principled("Metal", **{"Base Color": (0.9, 0.6, 0.3, 1), "Roughness": 0.5,
                                                   "Metallic": 1.0}), 0.04),
    "coated_plastic": (lambda: principled("Coated", **{"Base Color": (0.8, 0.15, 0.1, 1), "Roughness": 0.6,
                                                       "Coat Weight": 1.0, "Coat Roughness": 0.1}), 0.03),
    "tinted_coat": (lambda: principled("TintedCoat", **{"Base Color": (0.7, 0.7, 0.7, 1), "Roughness": 0.6,
                                                        "Coat Weight": 1.0, "Coat Roughness": 0.1, "Coat IOR": 1.8,
                                                        "Coat Tint": (0.9, 0.5, 0.3, 1)}), 0.03),
    "specular_tint": (lambda: principled("SpecTint", **{"Base Color": (0.1, 0.1, 0.1, 1), "Roughness": 0.3,
                                                        "Specular IOR Level": 0.8,
                                                        "Specular Tint": (1.0, 0.6, 0.2, 1)}), 0.03),
    "sheen_cloth": (lambda: principled("Sheen", **{"Base Color": (0.1, 0.05, 0.3, 1), "Roughness": 0.8,
                                                   "Sheen Weight": 1.0, "Sheen Roughness": 0.5,
                                                   "Sheen Tint": (1, 1, 1, 1)}), 0.01),
    # Shader nodes other than the Principled BSDF, which Blender's glTF exporter does not read;
    # the add-on writes their glTF material (export.shader_node_material).
    "diffuse_node": (lambda: shader_node("DiffuseNode", "ShaderNodeBsdfDiffuse",
                                         Color=(0.7, 0.3, 0.2, 1), Roughness=0.0), 0.01),
    "textured_diffuse_node": (lambda: textured_diffuse("TexDiffuse"), 0.02),
    "glossy_node": (lambda: shader_node("GlossyNode", "ShaderNodeBsdfAnisotropic",
                                        Color=(0.9, 0.6, 0.3, 1), Roughness=0.3), 0.04),
    "metallic_node": (lambda: shader_node("MetallicNode", "ShaderNodeBsdfMetallic",
                                          **{"Base Color": (0.9, 0.6, 0.3, 1), "Roughness": 0.3}), 0.04),
    "glass_node": (lambda: shader_node("GlassNode", "ShaderNodeBsdfGlass",
                                       Color=(1, 1, 1, 1), Roughness=0.0, IOR=1.45), 0.02),
}


def build(scene, material):
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    scenes.plane(scene, "Floor", 10.0, material=scenes.diffuse_material("Grey", 0.5))
    uv_sphere(scene, "Ball", 0.6, (0.0, 0.0, 0.6), material)
    scenes.light(scene, "Disk", "AREA", location=(0.8, -0.5, 3.0), shape="DISK", size=0.8, energy=400.0)
    scenes.camera(scene, (0.0, -2.2, 3.2), (35.0, 0.0, 0.0), lens=30.0)
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)


@pytest.mark.parametrize("material", list(MATERIALS))
def test_material_mean_matches_cycles(empty_scene, tmp_path, material):
    scene = empty_scene
    make, allowance = MATERIALS[material]
    build(scene, make())
    assert_mean_matches_cycles(scene, tmp_path, material, allowance)


def test_transmissive_material_exported_as_solid(empty_scene, tmp_path, monkeypatch, fake_binary):
    """A Principled glass gets KHR_materials_volume (thickness 1), so it refracts as in Cycles."""
    import json

    scene = empty_scene
    build(scene, MATERIALS["glass"][0]())
    folder = tmp_path / "scenes"
    monkeypatch.setenv("FAKE_CAUSTIC_SCENE_DIR", str(folder))
    scene.render.engine = "CAUSTIC"
    bpy.ops.render.render()
    (gltf,) = [json.loads(f.read_text()) for f in sorted(folder.glob("*.gltf"))]
    glass = next(m for m in gltf["materials"] if m["name"] == "Glass")
    assert glass["extensions"]["KHR_materials_transmission"]["transmissionFactor"] == 1.0
    assert glass["extensions"]["KHR_materials_volume"]["thicknessFactor"] == 1.0
    assert "KHR_materials_volume" in gltf["extensionsUsed"]
    floor = next(m for m in gltf["materials"] if m["name"] == "Grey")
    assert "KHR_materials_volume" not in floor.get("extensions", {})


def test_rough_diffuse_node_matches_cycles(empty_scene, tmp_path):
    """A Diffuse BSDF with Roughness 1 is Cycles' Oren-Nayar (Fujii's improved model with
    OpenPBR's multiple-scattering term), which reflects more light back toward its source and
    less sideways than Lambert's. A lone sphere lit from beside the camera (no floor, whose
    Lambertian light would dilute it), per channel, 5 sigma + 1 % (the Diffuse BSDF node's
    allowance above). Before, Caustic rendered it Lambertian with a warning: R 0.7525, G 0.8032, B 0.8095 of Cycles;
    now 0.9998 in each."""
    scene = empty_scene
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    uv_sphere(scene, "Ball", 0.8, (0.0, 0.0, 0.8),
              shader_node("RoughDiffuse", "ShaderNodeBsdfDiffuse", Color=(0.7, 0.3, 0.2, 1), Roughness=1.0))
    scenes.light(scene, "Key", "AREA", location=(0.4, -3.0, 1.2), rotation_deg=(75, 0, 0), shape="DISK",
                 size=0.5, energy=300.0)
    scenes.camera(scene, (0.0, -3.2, 0.8), (90.0, 0.0, 0.0), lens=40.0)
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)
    assert_mean_matches_cycles(scene, tmp_path, "rough diffuse", 0.01, per_channel=True)
