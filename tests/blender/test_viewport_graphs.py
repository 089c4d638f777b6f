"""Node-graph material edits in the Rendered viewport (viewport_graphs.py) with real bpy: a
Noise Texture's Scale changed in a material the exporter writes as a node graph is a
`material_graph` request carrying the graph as the final render's exporter writes it (no
reload), the frame it gives is the frame of the changed scene exported anew, and a graph that
needs a new image reloads the scene.
"""

import bpy
import numpy as np
import pytest

import scenes
from test_viewport import H, W, _apply_live, _converged, _edited_and_fresh, _Engine, _settle, updates, vp  # noqa: F401


def _noise_material(name):
    """A Principled BSDF whose Base Color is a Noise Texture: the exporter writes its graph."""
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:  # Blender < 5.0 creates materials without nodes
        mat.use_nodes = True
    tree = mat.node_tree
    bsdf = next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED")
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 3.0
    tree.links.new(noise.outputs["Color"], bsdf.inputs["Base Color"])
    return mat, noise


def _graph_scene(scene):
    scenes.small_render_settings(scene, W, H, samples=4)
    scenes.camera(scene, (0, -4, 3), (55, 0, 0))
    mat, noise = _noise_material("Marble")
    scenes.cube(scene, "Box", 1.0, (0, 0, 0.5), material=mat)
    scenes.plane(scene, "Floor", 6.0, material=scenes.diffuse_material("Grey", 0.5))
    scenes.light(scene, "Lamp", "POINT", location=(0.5, -0.5, 3.0), energy=300.0)
    return mat, noise


def test_a_noise_scale_change_is_a_graph_request(vp, empty_scene, updates):
    """With the material known as a graph, a Scale change asks for MATERIAL_GRAPH (exported by
    `Viewport.update`); without it, for a reload; a new image node's graph is refused."""
    viewport, _ = vp
    graphs_mod = __import__(viewport.__name__.rsplit(".", 1)[0] + ".viewport_graphs", fromlist=["x"])
    mat, noise = _graph_scene(empty_scene)
    _settle()
    names = viewport.rendered_objects(bpy.context.evaluated_depsgraph_get())
    graphs = {mat.name: graphs_mod.graph_extras(mat)}
    updates.clear()
    noise.inputs["Scale"].default_value = 7.5
    _settle()
    edits = viewport.edits_from_updates(updates, names, names, {}, graphs=graphs)
    assert edits == [{"type": graphs_mod.MATERIAL_GRAPH, "name": "Marble"}], edits
    assert viewport.edits_from_updates(updates, names, names, {}) == [viewport.RELOAD]
    header, _ = graphs_mod.graph_request(mat, bpy.context.evaluated_depsgraph_get(), {})
    scale = [n for n in header["nodes"]["nodes"] if n["type"] == "ShaderNodeTexNoise"][0]["inputs"]["Scale"]
    assert scale["value"] == 7.5, header
    image = mat.node_tree.nodes.new("ShaderNodeTexImage")
    image.image = bpy.data.images.new("Paint", 4, 4)
    bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    mat.node_tree.links.new(image.outputs["Color"], bsdf.inputs["Roughness"])
    try:
        graphs_mod.graph_request(mat, bpy.context.evaluated_depsgraph_get(), {})
        raise AssertionError("a graph with an image the running scene lacks was not refused")
    except graphs_mod.GraphRefused as err:
        assert "'Paint' is not in the running scene" in str(err)


@pytest.mark.needs_binary
def test_a_graph_edit_renders_as_a_fresh_export(vp, empty_scene):
    """A Noise Texture's Scale changed in a live viewport is a material_graph request (no
    export, no load), and its converged frame is the fresh export's bit for bit: the server
    compiles the same graph with the loader's own steps into the same scene."""
    viewport, _ = vp
    _, noise = _graph_scene(empty_scene)

    def change():
        noise.inputs["Scale"].default_value = 7.5

    edited, fresh, sent = _edited_and_fresh(viewport, change)
    assert "material_graph" in sent and "load" not in sent, sent
    assert np.array_equal(edited, fresh), f"{np.abs(edited - fresh).max()} at most"


@pytest.mark.needs_binary
def test_a_graph_needing_a_new_image_reloads(vp, empty_scene):
    """An Image Texture added to the graph: its image is not in the running scene, so the
    viewport exports the scene again and loads it, with no error."""
    viewport, _ = vp
    mat, _ = _graph_scene(empty_scene)
    engine = _Engine()
    v = viewport.Viewport(engine)
    try:
        v.update(bpy.context, bpy.context.evaluated_depsgraph_get())
        _converged(v)

        def change():
            image = mat.node_tree.nodes.new("ShaderNodeTexImage")
            image.image = bpy.data.images.new("Paint", 4, 4)
            bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
            mat.node_tree.links.new(image.outputs["Color"], bsdf.inputs["Roughness"])

        sent = _apply_live(v, change)
        assert "load" in sent and "material_graph" not in sent, sent
        _converged(v)
        assert not [r for r in engine.reports if r[0] == {"ERROR"}], engine.reports
    finally:
        v.free()
