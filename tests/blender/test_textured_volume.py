"""A mesh volume whose density comes from a texture, against Cycles: a cube of smoke whose
Principled Volume Density is a Noise Texture (on its default Generated coordinates) through a
ColorRamp and a Math node, tinted, lit by a point light over test_cycles_agreement's floor and
cube. Caustic evaluates the volume's node graph at each point of the medium
(`medium::procedural`) with trackers that stay unbiased whatever the sampled majorant.

Same scene, renders and tolerance derivation as test_cycles_agreement.py (the image means per
colour channel agree within 5 sigma of the two renderers' noise plus its 1 % model allowance),
and the same check over the image's four quadrants (the smoke's structure moves light between
them; each quadrant's bound is derived the same way from its own 12 blocks).

Measured on bpy 5.0.1 (Caustic/Cycles, printed with pytest -s): image R 1.0002, G 1.0000,
B 0.9998 (bound about 1.3 % of the mean); quadrants 0.9983-1.0005. Sensitivity: rendered as
before (the Density socket's own value 1, with a warning) the quadrant under the smoke is R 0.2911
instead of 0.3389 (-14 %, bound 2.3 %) and B 0.1680 instead of 0.1558 (+8 %), so a volume whose
texture is dropped fails. Caustic's render took 2.2 s against 0.57 s for the constant medium
(64 x 48, 128 samples: the graph runs at every tentative collision).

Two variants, same scene and bounds: the density read from an Image Texture (a float EXR of
4 x 4-texel blocks, Closest) on the cube's Generated coordinates, measured 0.9978-1.0002; and
the Noise smoke with its Anisotropy linked to a Gradient mapped to [-0.7, 0.8], whose phase
function is read at each scattering point, measured 0.9958-1.0013 (read as the socket's own
0.2, as before, its quadrant 2 is R 0.339 where Cycles gives 0.617).
"""

import bpy
import numpy as np
import pytest

import exr_io
import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, SEEDS, SIGMAS, add_point, build, mean_and_variance

pytestmark = pytest.mark.needs_binary


def noise_smoke(name):
    """A volume-only material: Density = 8 x ColorRamp(Noise Fac; 0.45 black to 0.65 white),
    Color tinted, Anisotropy 0.2."""
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    for node in list(tree.nodes):
        if node.type != "OUTPUT_MATERIAL":
            tree.nodes.remove(node)
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 3.0
    noise.inputs["Detail"].default_value = 2.0
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].position = 0.45
    ramp.color_ramp.elements[1].position = 0.65
    scale = tree.nodes.new("ShaderNodeMath")
    scale.operation = "MULTIPLY"
    scale.inputs[1].default_value = 8.0
    pv = tree.nodes.new("ShaderNodeVolumePrincipled")
    pv.inputs["Color"].default_value = (0.9, 0.7, 0.5, 1.0)
    pv.inputs["Anisotropy"].default_value = 0.2
    tree.links.new(noise.outputs["Fac"], ramp.inputs["Fac"])
    tree.links.new(ramp.outputs["Color"], scale.inputs[0])
    tree.links.new(scale.outputs["Value"], pv.inputs["Density"])
    tree.links.new(pv.outputs["Volume"], tree.nodes["Material Output"].inputs["Volume"])
    return mat


def add_textured_smoke(scene):
    add_point(scene)
    scenes.cube(scene, "Smoke", 1.0, (-0.4, 0.3, 1.3), material=noise_smoke("NoiseSmoke"))


def image_smoke(name, image_path):
    """A volume-only material: Density = 8 x an Image Texture (Closest, on Generated
    coordinates: the cube's texture space) of the float image at `image_path`, Color tinted."""
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    for node in list(tree.nodes):
        if node.type != "OUTPUT_MATERIAL":
            tree.nodes.remove(node)
    coords = tree.nodes.new("ShaderNodeTexCoord")
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = bpy.data.images.load(image_path, check_existing=False)
    tex.interpolation = "Closest"
    scale = tree.nodes.new("ShaderNodeMath")
    scale.operation = "MULTIPLY"
    scale.inputs[1].default_value = 8.0
    pv = tree.nodes.new("ShaderNodeVolumePrincipled")
    pv.inputs["Color"].default_value = (0.9, 0.7, 0.5, 1.0)
    tree.links.new(coords.outputs["Generated"], tex.inputs["Vector"])
    tree.links.new(tex.outputs["Color"], scale.inputs[0])
    tree.links.new(scale.outputs["Value"], pv.inputs["Density"])
    tree.links.new(pv.outputs["Volume"], tree.nodes["Material Output"].inputs["Volume"])
    return mat


def write_density_image(path):
    """A 16 x 16 float EXR: 4 x 4-texel blocks alternating 1 and 0.05, the top-left quarter
    empty (0), so the smoke's shape is the image's and not a cube's."""
    y, x = np.mgrid[0:16, 0:16]
    d = np.where((x // 4 + y // 4) % 2 == 0, 1.0, 0.05).astype(np.float32)
    d[:8, :8] = 0.0
    exr_io.write_exr(path, {"R": d, "G": d, "B": d})


def region_means(images, rows, cols):
    """{engine: [(mean, variance of the mean) per region]} over a rows x cols split, per channel
    (a list of three), from the two seeds' images (test_cycles_agreement's estimate)."""
    out = {}
    for engine, (a, b) in images.items():
        h, w = a.shape[:2]
        regions = []
        for r in range(rows):
            for c in range(cols):
                sl = (slice(r * h // rows, (r + 1) * h // rows), slice(c * w // cols, (c + 1) * w // cols))
                regions.append([mean_and_variance(a[sl][..., k], b[sl][..., k]) for k in range(3)])
        out[engine] = regions
    return out


def render_both(scene, tmp_path):
    """{engine: [image per seed]} for Cycles and Caustic."""
    return {engine: [scenes.render_rgb(scene, engine, s, str(tmp_path / f"{engine}_{s}.exr")) for s in SEEDS]
            for engine in ("CYCLES", "CAUSTIC")}


def assert_regions_match(images, label):
    """The whole image (1 x 1) and its quadrants (2 x 2) agree per channel within 5 sigma of
    the two renderers' noise plus the 1 % model allowance (module doc); ratios printed."""
    failures = []
    for region, (rows, cols) in (("image", (1, 1)), ("quadrant", (2, 2))):
        means = region_means(images, rows, cols)
        for i, (ours, theirs) in enumerate(zip(means["CAUSTIC"], means["CYCLES"])):
            for k, channel in enumerate("RGB"):
                (m_c, v_c), (m_y, v_y) = ours[k], theirs[k]
                bound = SIGMAS * (v_c + v_y) ** 0.5 + MODEL_ALLOWANCE * m_y
                name = f"{region} {i} {channel}" if rows > 1 else f"{region} {channel}"
                print(f"\n[caustic/cycles] {label} {name:12s} ratio {m_c / m_y:.4f}  caustic {m_c:.5f}  "
                      f"cycles {m_y:.5f}  bound {bound:.2e}")
                assert m_y > 1e-3, f"{name}: the Cycles reference is black: the scene is broken"
                if abs(m_c - m_y) > bound:
                    failures.append(f"{name}: Caustic/Cycles = {m_c / m_y:.4f} exceeds 5 sigma + 1 %")
    assert not failures, "; ".join(failures)


def test_noise_textured_smoke_matches_cycles(addon, empty_scene, tmp_path):
    scene = empty_scene
    build(scene, add_textured_smoke)
    assert_regions_match(render_both(scene, tmp_path), "textured smoke")


def test_image_textured_smoke_matches_cycles(addon, empty_scene, tmp_path):
    """The cube's smoke density read from an image on its Generated coordinates, against
    Cycles, with the same bounds as the Noise smoke's."""
    scene = empty_scene
    path = str(tmp_path / "density.exr")
    write_density_image(path)

    def add_image_smoke(scene):
        add_point(scene)
        scenes.cube(scene, "Smoke", 1.0, (-0.4, 0.3, 1.3), material=image_smoke("ImageSmoke", path))

    build(scene, add_image_smoke)
    assert_regions_match(render_both(scene, tmp_path), "image smoke")


def test_linked_anisotropy_matches_cycles(addon, empty_scene, tmp_path):
    """The Noise smoke with its Anisotropy linked to a Gradient on Generated x mapped to
    [-0.7, 0.8] (back-scattering on one side of the cube, forward on the other): the phase
    function of each scattering point is the graph's there, against Cycles, same bounds."""
    scene = empty_scene

    def add_smoke(scene):
        add_point(scene)
        mat = noise_smoke("AnisoSmoke")
        tree = mat.node_tree
        gradient = tree.nodes.new("ShaderNodeTexGradient")
        to_g = tree.nodes.new("ShaderNodeMapRange")
        to_g.inputs["To Min"].default_value = -0.7
        to_g.inputs["To Max"].default_value = 0.8
        tree.links.new(gradient.outputs["Fac"], to_g.inputs["Value"])
        pv = next(n for n in tree.nodes if n.type == "PRINCIPLED_VOLUME")
        tree.links.new(to_g.outputs["Result"], pv.inputs["Anisotropy"])
        scenes.cube(scene, "Smoke", 1.0, (-0.4, 0.3, 1.3), material=mat)

    build(scene, add_smoke)
    assert_regions_match(render_both(scene, tmp_path), "aniso smoke")


def test_textured_volume_exports_its_graph(addon, empty_scene):
    """The material's medium carries the Volume output's graph (Noise, ColorRamp, Math and the
    Principled Volume, which `graph_shader` names) and no 'input is linked' warning; the cube's
    texture space is exported for the Noise's Generated coordinates."""
    import importlib
    media = importlib.import_module(addon.__name__ + ".export.media")
    mat = noise_smoke("Exported")
    value, warnings = media.medium_extension(mat)
    assert warnings == []
    graph = value["graph"]
    kinds = sorted(n["type"] for n in graph["nodes"])
    assert kinds == ["ShaderNodeMath", "ShaderNodeTexNoise", "ShaderNodeValToRGB", "ShaderNodeVolumePrincipled"]
    assert graph["nodes"][value["graph_shader"]]["type"] == "ShaderNodeVolumePrincipled"
    assert media.volume_uses_generated(mat)
    assert value["surface"] is False
