"""Object Index, Material Index and Cryptomatte as the compositor uses them, Caustic against
Cycles on one small scene: a floor, a cube "Left" (Pass Index 3, material "Red" of Pass Index
5) and a cube "Right" (Pass Index 4, material "Blue") parented to an empty "Rig" (its
Cryptomatte asset), the Right cube partly behind the Left one so that objects share edges.

Both engines render 40x30 at 32 samples with Blackman-Harris 1.5 px and write a multilayer EXR
(every pass, the render result's metadata) with the compositor's output in it: a Cryptomatte
node (Blender 5.0: `scene.compositing_node_group`, a Group Output) set to the view layer's
CryptoObject layer with Matte ID "Left", whose Matte is the output.

What must agree, and why the bounds hold:
* a pixel whose samples all see one object (or all the world) in both engines is "pure":
  there the Cryptomatte ids and coverages and the index passes (one sample per pixel:
  Cycles' sample 0, Caustic's first) are equal exactly;
* the matte is the coverage of Left per pixel: 0 or 1 wherever a pixel sees one object only
  (equal exactly on pure pixels), and on the E other pixels a fraction of 32 samples of the same filter, each of
  variance at most 1/4 per sample; the image mean differs by at most 5 sigma of the two
  engines' sums over the E edge pixels: 5 * sqrt(2 * E / (4 * 32)) / pixels;
* the names: the render result's metadata (cryptomatte/<hash>/name and manifest) names the
  layer and holds Left's, Right's and Rig's hashes as Cycles' does.
"""

import json

import bpy
import numpy as np
import pytest

import scenes
from exr_io import read_exr

pytestmark = pytest.mark.needs_binary

W, H = 40, 30
SAMPLES = 32
LEVELS = 4


def build(scene):
    scenes.plane(scene, "Floor", 8.0, material=scenes.diffuse_material("Grey", 0.5))
    red = scenes.diffuse_material("Red", 0.6)
    red.pass_index = 5
    left = scenes.cube(scene, "Left", 0.8, (-0.3, 0.0, 0.4), material=red)
    left.pass_index = 3
    rig = bpy.data.objects.new("Rig", None)
    scene.collection.objects.link(rig)
    rig.location = (0.5, 1.0, 0.0)
    right = scenes.cube(scene, "Right", 0.8, (0.0, 0.0, 0.5), material=scenes.diffuse_material("Blue", 0.4))
    right.parent = rig
    right.pass_index = 4
    scenes.light(scene, "Key", "AREA", location=(0.5, -1.0, 3.0), shape="SQUARE", size=1.0, energy=100.0)
    scenes.camera(scene, (0.0, -4.0, 1.5), (75.0, 0.0, 0.0), lens=35.0)
    scenes.small_render_settings(scene, W, H, SAMPLES)
    scenes.match_cycles(scene, SAMPLES, 2)
    scene.render.image_settings.media_type = "MULTI_LAYER_IMAGE"
    scene.render.image_settings.exr_codec = "ZIP"
    layer = scene.view_layers[0]
    layer.use_pass_object_index = layer.use_pass_material_index = True
    layer.use_pass_cryptomatte_object = layer.use_pass_cryptomatte_material = True
    layer.use_pass_cryptomatte_asset = True
    layer.pass_cryptomatte_depth = LEVELS
    matte_output(scene, f"{layer.name}.CryptoObject", "Left")


def matte_output(scene, layer_name, matte_id):
    """The compositor's output is the Cryptomatte node's Matte for `matte_id`."""
    tree = bpy.data.node_groups.new("Matte", "CompositorNodeTree")
    tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
    scene.compositing_node_group = tree
    scene.render.use_compositing = True
    node = tree.nodes.new("CompositorNodeCryptomatteV2")
    node.source = "RENDER"
    node.scene = scene
    node.layer_name = layer_name
    node.matte_id = matte_id
    out = tree.nodes.new("NodeGroupOutput")
    tree.links.new(node.outputs["Matte"], out.inputs[0])


def exr_metadata(path):
    """The string attributes of an EXR's header."""
    import importlib
    result = importlib.import_module("bl_ext.caustic_dev.caustic.result")
    return result.exr_text_attributes(path)


def render(scene, engine, path):
    scene.render.engine = engine
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    ch = read_exr(path)
    return {key: value.astype(np.float64) for key, value in ch.items()}, exr_metadata(path)


@pytest.fixture(scope="module")
def renders(addon, tmp_path_factory):
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    scene = bpy.context.scene
    scene.render.engine = "CAUSTIC"
    build(scene)
    tmp = tmp_path_factory.mktemp("crypto")
    return {engine: render(scene, engine, str(tmp / f"{engine}.exr")) for engine in ("CYCLES", "CAUSTIC")}


def crypto_ranks(ch, layer):
    """(ids as uint32 bits, coverages) of a Cryptomatte layer: arrays (H, W, ranks)."""
    ids, cov = [], []
    for i in range(LEVELS // 2):
        for id_c, cov_c in (("r", "g"), ("b", "a")):
            ids.append(ch[f"ViewLayer.{layer}{i:02d}.{id_c}"].astype(np.float32).view(np.uint32))
            cov.append(ch[f"ViewLayer.{layer}{i:02d}.{cov_c}"])
    return np.stack(ids, -1), np.stack(cov, -1)


def pure(ch, layer):
    """Pixels whose samples all saw one entity (its coverage 1 within float rounding) or all saw
    the world (no entity): where two renders of the same scene must agree exactly."""
    _, cov = crypto_ranks(ch, layer)
    return (cov[..., 0] > 1.0 - 1e-6) | (cov.sum(-1) == 0.0)


def test_cryptomatte_ids_and_coverage_match_cycles(renders):
    """Where a pixel sees one entity or none in both engines, both name the same one; coverages
    are ranked highest first and add up to the pixel's share of samples on geometry."""
    (cy, _), (ca, _) = renders["CYCLES"], renders["CAUSTIC"]
    for layer in ("CryptoObject", "CryptoMaterial", "CryptoAsset"):
        ids_cy, cov_cy = crypto_ranks(cy, layer)
        ids_ca, cov_ca = crypto_ranks(ca, layer)
        both = pure(cy, layer) & pure(ca, layer)
        # The 3-pixel filter window spreads every edge over about three columns: a third to
        # a half of this small frame is near an edge.
        assert both.mean() > 0.4, f"{layer}: enough pixels see one entity"
        assert np.array_equal(ids_cy[..., 0][both], ids_ca[..., 0][both]), layer
        assert np.array_equal(cov_cy[..., 0][both], cov_ca[..., 0][both]), layer
        assert (cov_ca[..., 0][both] == 0.0).any() and (cov_ca[..., 0][both] == 1.0).any(), "world and objects"
        # Ranked: coverage never increases from one rank to the next.
        assert np.all(np.diff(cov_ca, axis=-1) <= 0.0), layer
        # Each coverage is a count over 32 samples rounded once to f32: the sum is at most 1.
        assert np.all(cov_ca.sum(-1) <= 1.0 + 1e-6), layer


def test_index_passes_match_cycles(renders):
    """Object and Material Index equal Cycles' wherever the pixel holds one object (elsewhere
    each engine takes its one sample's object)."""
    (cy, _), (ca, _) = renders["CYCLES"], renders["CAUSTIC"]
    alone = pure(cy, "CryptoObject") & pure(ca, "CryptoObject")
    for name, values in (("Object Index", {0.0, 3.0, 4.0}), ("Material Index", {0.0, 5.0})):
        a, b = cy[f"ViewLayer.{name}.X"], ca[f"ViewLayer.{name}.X"]
        assert set(np.unique(b)) == values, f"{name}: {np.unique(b)}"
        assert np.array_equal(a[alone], b[alone]), name


def test_compositor_matte_isolates_left_as_cycles(renders):
    """The Cryptomatte node picks "Left": the matte is Left's coverage, as in Cycles (bound in
    the module's doc)."""
    (cy, _), (ca, _) = renders["CYCLES"], renders["CAUSTIC"]
    matte_cy, matte_ca = cy["Composite.Combined.R"], ca["Composite.Combined.R"]
    alone = pure(cy, "CryptoObject") & pure(ca, "CryptoObject")
    assert np.array_equal(matte_cy[alone], matte_ca[alone])
    assert 0.05 < matte_ca.mean() < 0.5, "Left fills part of the frame"
    edges = (~alone).sum()
    bound = 5.0 * np.sqrt(2.0 * edges / (4.0 * SAMPLES)) / matte_ca.size
    print(f"matte mean cycles {matte_cy.mean():.5f} caustic {matte_ca.mean():.5f} bound {bound:.5f}")
    assert abs(matte_ca.mean() - matte_cy.mean()) <= bound
    # The matte is exactly Left's coverage from the passes.
    ids, cov = crypto_ranks(ca, "CryptoObject")
    left = ids[..., 0][matte_ca > 0.999][0]
    np.testing.assert_allclose(matte_ca, (cov * (ids == left)).sum(-1), atol=1e-6)


def test_manifest_names_the_entities_as_cycles(renders):
    """The render result's metadata (written to the multilayer EXR) has the layer names and the
    manifests Cycles writes, keyed by the hash of `ViewLayer.CryptoObject` etc."""
    (_, meta_cy), (_, meta_ca) = renders["CYCLES"], renders["CAUSTIC"]
    for layer, names in (("CryptoObject", ("Left", "Right")), ("CryptoMaterial", ("Red", "Blue")),
                         ("CryptoAsset", ("Left", "Rig"))):
        keys = [k for k, v in meta_cy.items() if k.endswith("/name") and v == f"ViewLayer.{layer}"]
        assert len(keys) == 1, (layer, sorted(meta_cy))
        prefix = keys[0][:-len("name")]
        assert meta_ca.get(prefix + "name") == f"ViewLayer.{layer}", (layer, sorted(meta_ca))
        for field in ("hash", "conversion"):
            assert meta_ca[prefix + field] == meta_cy[prefix + field]
        cy, ca = json.loads(meta_cy[prefix + "manifest"]), json.loads(meta_ca[prefix + "manifest"])
        for n in names:
            assert ca[n] == cy[n], (layer, n)


def test_request_levels_and_warnings(addon):
    """The binary is asked for the enabled layers with the view layer's levels (odd levels:
    Cycles' passes of two ranks, rounded up), for the light groups and for the shader AOVs; chunks
    on the farm carry all of them; BDPT renders light groups too, Jensen's photon mapping none,
    SPPM no shader AOVs."""
    import importlib
    result = importlib.import_module("bl_ext.caustic_dev.caustic.result")
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    layer = bpy.context.scene.view_layers[0]
    layer.use_pass_cryptomatte_asset = layer.use_pass_object_index = True
    layer.pass_cryptomatte_depth = 3
    layer.lightgroups.add(name="Key")
    layer.aovs.add().name = "Mask"
    passes, warnings = result.pass_request(layer, "path")
    assert passes == "object_index,cryptomatte_asset,light_groups,shader_aovs"
    assert result.cryptomatte_arguments(layer, passes) == ["--cryptomatte-levels", "3"]
    assert result.enabled_cryptomatte(layer) == [("cryptomatte_asset", ["CryptoAsset00", "CryptoAsset01"])]
    assert not any("Combined_Key" in w for w in warnings)
    assert not any("'Mask'" in w for w in warnings)
    passes, warnings = result.pass_request(layer, "bdpt")
    assert "light_groups" in passes and not any("Combined_Key" in w for w in warnings)
    passes, warnings = result.pass_request(layer, "photon")
    assert "light_groups" in passes and not any("Combined_Key" in w for w in warnings)
    passes, warnings = result.pass_request(layer, "sppm")
    assert "shader_aovs" in passes and "cryptomatte_asset" in passes and not any("SPPM" in w for w in warnings)
    assert "light_groups" in passes and not any("Combined_Key" in w for w in warnings)
    # The farm asks the same: SPPM's chunks keep every pass's sums too (docs/contract.md).
