"""Blender 5.0's Color Management > Working Space (ACEScg, Linear Rec.2020) rendered as Cycles
renders it (issues 19 and 20): what Caustic decodes or computes as RGB itself (colour image
textures, Blackbody, Wavelength, the Sky Texture, luminance, a Principled Volume's blackbody)
is given in the working space by the add-on's matrix (`extras.caustic.working_space`), data
images are not converted; byte colour attributes as Cycles 5.0.1 reads them (decoded in the
point domain, decoded and converted in the corner domain).

Each case is the agreement scene of test_cycles_agreement.py with one feature added, checked
per channel by `assert_mean_matches_cycles` (two seeds per renderer, 5 sigma from 8x8-pixel
blocks plus the 1 % model allowance, derived there). Before (main's binary, the add-on only
warning), Caustic/Cycles per channel R / G / B under ACEScg: in each case's docstring.
"""

import bpy
import numpy as np
import pytest

import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, assert_mean_matches_cycles, build

pytestmark = pytest.mark.needs_binary

REC709 = "Linear Rec.709"


def image(name, pixels, float_buffer=False, colorspace="sRGB"):
    """An 8x8 image of `pixels(odd)` RGBA texels in a checker, packed."""
    img = bpy.data.images.new(name, 8, 8, float_buffer=float_buffer)
    y, x = np.mgrid[0:8, 0:8]
    odd = ((x + y) % 2 == 1)[..., None]
    img.pixels.foreach_set(np.where(odd, pixels[0], pixels[1]).astype(np.float32).ravel())
    if float_buffer:
        img.file_format = "OPEN_EXR"
    img.pack()
    img.colorspace_settings.name = colorspace
    return img


def textured(material, img, socket="Base Color", through_gamma=False):
    """Links `img` (by the mesh's UVs) into `socket` of `material`'s Principled BSDF;
    `through_gamma` routes it through a Gamma 1 node (the graph then goes as a node graph)."""
    tree = bpy.data.materials[material].node_tree
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = img
    out = tex.outputs["Color"]
    if through_gamma:
        gamma = tree.nodes.new("ShaderNodeGamma")
        gamma.inputs["Gamma"].default_value = 1.0
        tree.links.new(out, gamma.inputs["Color"])
        out = gamma.outputs["Color"]
    tree.links.new(out, tree.nodes["Principled BSDF"].inputs[socket])


def with_uvs():
    for name in ("Floor", "Box"):
        bpy.data.objects[name].data.uv_layers.new(name="UVMap")


def sun(scene):
    scenes.light(scene, "Sun", "SUN", rotation_deg=(25.0, 10.0, 0.0), energy=2.0, angle=0.0)


def srgb_texture(scene):
    """An 8-bit sRGB checker as the base colour of floor and box (glTF base colour textures).
    Before: 0.82 / 0.63 / 0.65 (Rec.2020 0.81 / 0.64 / 0.64)."""
    with_uvs()
    checker = image("Checker", ((0.9, 0.2, 0.1, 1.0), (0.1, 0.3, 0.9, 1.0)))
    textured("Grey", checker)
    textured("Light", checker)
    sun(scene)


def exr_texture(scene):
    """A float OpenEXR checker tagged Linear Rec.709, through a node graph. Blender holds its
    pixels in the working space already: the add-on names them so and the binary leaves them
    (1.0000 before and after; a guard against converting them twice)."""
    with_uvs()
    checker = image("Linear", ((0.8, 0.1, 0.05, 1.0), (0.05, 0.2, 0.7, 1.0)), float_buffer=True,
                    colorspace=REC709)
    textured("Grey", checker, through_gamma=True)
    textured("Light", checker, through_gamma=True)
    sun(scene)


def noncolor_roughness(scene):
    """A Non-Color image driving a glossy floor's Roughness (a colour read as a float: the
    working space's luminance), not converted (1.0027 before, 1.0014 after: a guard)."""
    with_uvs()
    rough = image("Rough", ((0.05, 0.6, 0.1, 1.0), (0.6, 0.05, 0.9, 1.0)), colorspace="Non-Color")
    textured("Grey", rough, "Roughness", through_gamma=True)
    bsdf = bpy.data.materials["Grey"].node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Metallic"].default_value = 1.0
    bsdf.inputs["Base Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    scenes.light(scene, "Lamp", "POINT", location=(0.5, -0.4, 2.0), energy=300.0, shadow_soft_size=0.5)
    sun(scene)


def blackbody_light(scene):
    """A point light whose Emission colour is a Blackbody 2500 K node. Before: 1.35 / 0.90 / 0.56
    (Rec.2020 1.33 / 0.90 / 0.62)."""
    lamp = scenes.light(scene, "Warm", "POINT", location=(0.6, -0.4, 3.0), energy=300.0, shadow_soft_size=0.2)
    lamp.data.use_nodes = True
    tree = lamp.data.node_tree
    bb = tree.nodes.new("ShaderNodeBlackbody")
    bb.inputs["Temperature"].default_value = 2500.0
    tree.links.new(bb.outputs["Color"], tree.nodes["Emission"].inputs["Color"])


def wavelength_emission(scene):
    """The box emits a Wavelength 520 nm colour (a saturated green). Before: 1.00 / 1.07 / 0.95."""
    tree = bpy.data.materials["Light"].node_tree
    wl = tree.nodes.new("ShaderNodeWavelength")
    wl.inputs["Wavelength"].default_value = 520.0
    bsdf = tree.nodes["Principled BSDF"]
    tree.links.new(wl.outputs["Color"], bsdf.inputs["Emission Color"])
    bsdf.inputs["Emission Strength"].default_value = 3.0
    sun(scene)


def sky_world(scene):
    """A Sky Texture world (Multiple Scattering, no sun disc) lights the scene. Before: 0.75 /
    1.02 / 1.06."""
    world = bpy.data.worlds.new("Sky")
    world.use_nodes = True
    tree = world.node_tree
    sky = tree.nodes.new("ShaderNodeTexSky")
    sky.sky_type = "MULTIPLE_SCATTERING"
    sky.sun_disc = False
    sky.sun_elevation = 0.5
    tree.links.new(sky.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    tree.nodes["Background"].inputs["Strength"].default_value = 0.3
    scene.world = world


def luminance_links(scene):
    """RGB to BW of a saturated red as the floor's base colour, and a saturated cyan colour
    linked into the box's Emission Strength (an implicit colour → float). Before: 0.95."""
    tree = bpy.data.materials["Grey"].node_tree
    rgb = tree.nodes.new("ShaderNodeRGB")
    rgb.outputs["Color"].default_value = (0.9, 0.1, 0.05, 1.0)
    bw = tree.nodes.new("ShaderNodeRGBToBW")
    tree.links.new(rgb.outputs["Color"], bw.inputs["Color"])
    tree.links.new(bw.outputs["Val"], tree.nodes["Principled BSDF"].inputs["Base Color"])
    tree = bpy.data.materials["Light"].node_tree
    rgb = tree.nodes.new("ShaderNodeRGB")
    rgb.outputs["Color"].default_value = (0.05, 0.6, 0.9, 1.0)
    bsdf = tree.nodes["Principled BSDF"]
    bsdf.inputs["Emission Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    tree.links.new(rgb.outputs["Color"], bsdf.inputs["Emission Strength"])
    sun(scene)


def volume_blackbody(scene):
    """The box is a fire: a Principled Volume with Blackbody Intensity 1 at 1500 K (no surface).
    The medium's blackbody colour is the working space's, as Cycles' `rec709_to_rgb`. Before
    (the add-on warning that it stays in Rec.709) under ACEScg 1.053 / 0.991 / 0.994 (Rec.2020
    1.050 / 0.991 / 0.995); after 1.0002.
    The box floats 5 cm above the floor: with its bottom face in the floor's plane the two
    renderers light the floor under it differently (Cycles 5.0.1 not at all through an
    orthographic view from above, Caustic a little: the floor's rays look back for the face
    they start on), a contact of a volume-only boundary that neither renders as a medium
    standing on a floor would light it."""
    bpy.data.objects["Box"].location.z += 0.05
    tree = bpy.data.materials["Light"].node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    volume = tree.nodes.new("ShaderNodeVolumePrincipled")
    volume.inputs["Density"].default_value = 0.5
    volume.inputs["Blackbody Intensity"].default_value = 1.0
    volume.inputs["Temperature"].default_value = 1500.0
    tree.links.new(volume.outputs["Volume"], tree.nodes["Material Output"].inputs["Volume"])
    sun(scene)


def volume_blackbody_graph(scene):
    """The same fire with its Density from a Noise texture and an extra Emission Color from a
    Blackbody node at 3000 K (a volume graph: Blackbody computed in the working space there
    too). Before under ACEScg 1.111 / 0.979 / 0.970 (Rec.2020 1.106 / 0.979 / 0.976); after
    0.999-0.9998."""
    volume_blackbody(scene)
    tree = bpy.data.materials["Light"].node_tree
    volume = tree.nodes["Principled Volume"]
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 2.0
    tree.links.new(noise.outputs["Fac"], volume.inputs["Density"])
    bb = tree.nodes.new("ShaderNodeBlackbody")
    bb.inputs["Temperature"].default_value = 3000.0
    tree.links.new(bb.outputs["Color"], volume.inputs["Emission Color"])
    volume.inputs["Emission Strength"].default_value = 0.5


def byte_colors(domain):
    """The floor's base colour from a byte colour attribute of `domain` (sRGB bytes) read by
    a Color Attribute node. Cycles 5.0.1 converts the point domain's decoded bytes to the
    working space and takes the corner domain's as they decode (attributes.py
    `_corner_bytes_converted`). Before (the glTF exporter's COLOR_0, converted in both domains)
    under ACEScg: point 1.308 / 0.959 / 1.112, corner 0.9999-1.0001; after 0.9999-1.0001."""
    def case(scene):
        mesh = bpy.data.objects["Floor"].data
        attr = mesh.color_attributes.new("Paint", "BYTE_COLOR", domain)
        for i, d in enumerate(attr.data):
            d.color = (0.9, 0.3, 0.1, 1.0) if i % 2 else (0.2, 0.8, 0.3, 1.0)
        tree = bpy.data.materials["Grey"].node_tree
        node = tree.nodes.new("ShaderNodeVertexColor")
        node.layer_name = "Paint"
        tree.links.new(node.outputs["Color"], tree.nodes["Principled BSDF"].inputs["Base Color"])
        sun(scene)
    return case


def byte_colors_beside_float(scene):
    """Byte colours of both domains beside a float colour attribute, mixed (each goes under its
    own name, not as COLOR_0). Before under ACEScg (both decoded, neither converted): 1.141 /
    0.982 / 0.950; after 0.9999-1.0000."""
    mesh = bpy.data.objects["Floor"].data
    tree = bpy.data.materials["Grey"].node_tree
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.inputs["Factor"].default_value = 0.5
    for k, (name, kind, domain) in enumerate((("Point", "BYTE_COLOR", "POINT"), ("Corner", "BYTE_COLOR", "CORNER"))):
        attr = mesh.color_attributes.new(name, kind, domain)
        for i, d in enumerate(attr.data):
            d.color = (0.9, 0.3, 0.1, 1.0) if (i + k) % 2 else (0.2, 0.8, 0.3, 1.0)
        node = tree.nodes.new("ShaderNodeVertexColor")
        node.layer_name = name
        tree.links.new(node.outputs["Color"], mix.inputs[6 + k])
    mesh.color_attributes.new("Float", "FLOAT_COLOR", "POINT")
    tree.links.new(mix.outputs[2], tree.nodes["Principled BSDF"].inputs["Base Color"])
    box = bpy.data.materials["Light"].node_tree
    node = box.nodes.new("ShaderNodeVertexColor")
    node.layer_name = "Float"
    sun(scene)


CASES = {
    "srgb_texture": srgb_texture,
    "exr_texture": exr_texture,
    "noncolor_roughness": noncolor_roughness,
    "blackbody_light": blackbody_light,
    "wavelength_emission": wavelength_emission,
    "sky_world": sky_world,
    "luminance_links": luminance_links,
    "volume_blackbody": volume_blackbody,
    "volume_blackbody_graph": volume_blackbody_graph,
    "byte_color_point": byte_colors("POINT"),
    "byte_color_corner": byte_colors("CORNER"),
    "byte_colors_beside_float": byte_colors_beside_float,
}


@pytest.fixture
def working_space(request):
    """Sets the working space for the test (colours converted, as a user switching does) and
    puts Linear Rec.709 back."""
    bpy.ops.wm.set_working_color_space(working_space=request.param, convert_colors=True)
    try:
        yield request.param
    finally:
        bpy.ops.wm.set_working_color_space(working_space=REC709, convert_colors=True)


@pytest.mark.parametrize("working_space", ["ACEScg", "Linear Rec.2020"], indirect=True)
@pytest.mark.parametrize("case", list(CASES))
def test_working_space_matches_cycles(empty_scene, tmp_path, working_space, case):
    scene = empty_scene
    assert bpy.data.colorspace.working_space == working_space
    build(scene, CASES[case])
    assert_mean_matches_cycles(scene, tmp_path, f"{case} {working_space}", MODEL_ALLOWANCE, per_channel=True)
