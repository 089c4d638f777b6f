"""View layers: each layer Blender asks for is rendered from its own depsgraph, so a collection
excluded in one layer is absent from that layer's image only, as in Cycles.

Scene and tolerance as test_cycles_agreement.py (a grey floor, a lighter cube, an area light;
image means of two seeds per engine, 5 sigma from 8x8-block variances plus the 1 % model
allowance). Two layers: "Full" sees everything, "NoBox" excludes the cube's collection; each
is rendered on its own by both engines and compared, and the two layers
must differ by far more than the bound (the cube's shadow and its own brightness), so that a
renderer that ignored the exclusion fails.
"""

import math

import bpy
import pytest

import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, SEEDS, SIGMAS, add_rectangle, build, mean_and_variance

pytestmark = pytest.mark.needs_binary


def render_layer(scene, engine, seed, layer, path):
    """The channel-mean image of one view layer, rendered alone (the other layers' Use for
    Rendering off: `render(layer=...)` re-renders one layer but `write_still` may save
    another)."""
    for view_layer in scene.view_layers:
        view_layer.use = view_layer.name == layer
    scene.render.engine = engine
    if engine == "CYCLES":
        scene.cycles.seed = seed
    else:
        scene.caustic.seed = seed
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    return scenes.load_pixels(path)[..., :3].astype(float).mean(axis=2)


def test_view_layers_with_an_excluded_collection_match_cycles(empty_scene, tmp_path):
    scene = empty_scene
    build(scene, add_rectangle)
    box = scene.objects["Box"]
    collection = bpy.data.collections.new("BoxCol")
    scene.collection.children.link(collection)
    for c in list(box.users_collection):
        c.objects.unlink(box)
    collection.objects.link(box)
    full = scene.view_layers[0]
    full.name = "Full"
    no_box = scene.view_layers.new("NoBox")
    no_box.layer_collection.children["BoxCol"].exclude = True
    means = {}
    for layer in ("Full", "NoBox"):
        results = {}
        for engine in ("CYCLES", "CAUSTIC"):
            a, b = (render_layer(scene, engine, s, layer, str(tmp_path / f"{layer}_{engine}_{s}.exr")) for s in SEEDS)
            results[engine] = mean_and_variance(a, b)
        (m_caustic, v_caustic), (m_cycles, v_cycles) = results["CAUSTIC"], results["CYCLES"]
        sigma = math.sqrt(v_caustic + v_cycles)
        bound = SIGMAS * sigma + MODEL_ALLOWANCE * m_cycles
        print(f"\n[caustic/cycles] layer {layer}: ratio {m_caustic / m_cycles:.4f}  bound {bound:.2e}")
        assert abs(m_caustic - m_cycles) <= bound, (layer, m_caustic, m_cycles, bound)
        means[layer] = (m_caustic, m_cycles, bound)
    # The exclusion is visible in both renderers: far beyond the bound.
    for i, engine in enumerate(("CAUSTIC", "CYCLES")):
        assert abs(means["Full"][i] - means["NoBox"][i]) > 5 * means["Full"][2], (engine, means)


def test_material_override_matches_cycles(empty_scene, tmp_path):
    """A view layer's Material Override dresses every mesh in one material, in Cycles and in
    Caustic (per channel, same bound); without it the image is far from the overridden one."""
    from test_cycles_agreement import assert_mean_matches_cycles

    scene = empty_scene
    build(scene, add_rectangle)
    plain = scenes.render_rgb(scene, "CAUSTIC", 1, str(tmp_path / "plain.exr")).mean()
    red = bpy.data.materials.new("RedOverride")
    bsdf = red.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.9, 0.2, 0.1, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    scene.view_layers[0].material_override = red
    ratios = assert_mean_matches_cycles(scene, tmp_path, "material override", MODEL_ALLOWANCE, per_channel=True)
    overridden = scenes.render_rgb(scene, "CAUSTIC", 1, str(tmp_path / "over.exr")).mean()
    assert abs(overridden - plain) > 0.1 * plain, (plain, overridden, ratios)
