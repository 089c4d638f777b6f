"""The add-on's `CAUSTIC_materials_nodes` (docs/contract.md): the exported JSON of shader graphs.

Each test builds a material in bpy, exports the scene as a render does (`export_scene` on the
evaluated depsgraph) and reads the glTF: node groups inlined (nested), reroutes removed, muted
nodes passed through, ColorRamp and curve tables against Blender's own `evaluate`, images
written and referenced, UV map numbers, texture space extras, object matrices, light node
trees, a plain Principled material unchanged, and the Khronos validator on a graph scene.
"""

import json
import math
import os
import struct
import subprocess

import bpy
import numpy as np
import pytest
from mathutils import Matrix, Vector

import scenes
from test_gltf_validity import VALIDATE, VALIDATOR

EXT = "CAUSTIC_materials_nodes"


def new_material(name):
    """A material with only its Material Output (and the default Principled BSDF removed)."""
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    for node in list(mat.node_tree.nodes):
        if node.type != "OUTPUT_MATERIAL":
            mat.node_tree.nodes.remove(node)
    return mat


def diffuse_from(mat, socket):
    """A Diffuse BSDF on the output whose Color is fed by `socket`; returns the BSDF."""
    tree = mat.node_tree
    bsdf = tree.nodes.new("ShaderNodeBsdfDiffuse")
    tree.links.new(socket, bsdf.inputs["Color"])
    tree.links.new(bsdf.outputs["BSDF"], tree.nodes["Material Output"].inputs["Surface"])
    return bsdf


def by_id(sockets, identifier):
    """A socket by identifier (`sockets[key]` looks names up, and the Mix node's repeat them)."""
    return next(s for s in sockets if s.identifier == identifier)


def uv_plane(scene, name, material, uv_maps=("UVMap",), location=(0, 0, 0)):
    """A unit plane with the given UV maps (all the same unwrap)."""
    obj = scenes.plane(scene, name, 2.0, material=material)
    obj.location = location
    for uv in uv_maps:
        layer = obj.data.uv_layers.new(name=uv)
        for i, loop in enumerate(obj.data.loops):
            layer.data[i].uv = [(0, 0), (1, 0), (1, 1), (0, 1)][loop.vertex_index]
    return obj


def export(addon, scene, tmp_path):
    """Export the scene as a render does; (glTF dict, export state, folder)."""
    scenes.small_render_settings(scene, 16, 12, samples=1)
    if scene.camera is None:
        scenes.camera(scene, (0, -4, 3), (60, 0, 0))
    settings = addon.export.render_settings(scene, (16, 12), scene.camera.name)
    path, state = addon.export.export_scene(bpy.context.evaluated_depsgraph_get(), str(tmp_path), settings)
    with open(path) as f:
        return json.load(f), state, os.path.dirname(path)


def graph_of(gltf, name):
    mat = next(m for m in gltf["materials"] if m["name"] == name)
    return mat.get("extensions", {}).get(EXT)


def by_name(graph):
    return {n["name"]: (i, n) for i, n in enumerate(graph["nodes"])}


def test_nested_groups_are_inlined_with_their_inputs_resolved(addon, empty_scene, tmp_path):
    """Noise -> Outer group (-> Inner group: Math multiply by the group input) -> Diffuse colour:
    the inner Math is `Outer/Inner/Math`, its first input links to the Noise, its second is the
    Outer group node's unlinked socket value passed down through both Group Inputs."""
    inner = bpy.data.node_groups.new("InnerTree", "ShaderNodeTree")
    inner.interface.new_socket("In", in_out="INPUT", socket_type="NodeSocketFloat")
    inner.interface.new_socket("Gain", in_out="INPUT", socket_type="NodeSocketFloat")
    inner.interface.new_socket("Out", in_out="OUTPUT", socket_type="NodeSocketFloat")
    gi, go = inner.nodes.new("NodeGroupInput"), inner.nodes.new("NodeGroupOutput")
    math_node = inner.nodes.new("ShaderNodeMath")
    math_node.name = "Math"
    math_node.operation = "MULTIPLY"
    inner.links.new(gi.outputs["In"], math_node.inputs[0])
    inner.links.new(gi.outputs["Gain"], math_node.inputs[1])
    inner.links.new(math_node.outputs[0], go.inputs["Out"])

    outer = bpy.data.node_groups.new("OuterTree", "ShaderNodeTree")
    outer.interface.new_socket("In", in_out="INPUT", socket_type="NodeSocketFloat")
    outer.interface.new_socket("Gain", in_out="INPUT", socket_type="NodeSocketFloat")
    outer.interface.new_socket("Out", in_out="OUTPUT", socket_type="NodeSocketFloat")
    ogi, ogo = outer.nodes.new("NodeGroupInput"), outer.nodes.new("NodeGroupOutput")
    inner_node = outer.nodes.new("ShaderNodeGroup")
    inner_node.node_tree = inner
    inner_node.name = "Inner"
    outer.links.new(ogi.outputs["In"], inner_node.inputs["In"])
    outer.links.new(ogi.outputs["Gain"], inner_node.inputs["Gain"])
    outer.links.new(inner_node.outputs["Out"], ogo.inputs["Out"])

    mat = new_material("Grouped")
    tree = mat.node_tree
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.name = "Noise"
    outer_node = tree.nodes.new("ShaderNodeGroup")
    outer_node.node_tree = outer
    outer_node.name = "Outer"
    outer_node.inputs["Gain"].default_value = 0.25
    tree.links.new(noise.outputs["Fac"], outer_node.inputs["In"])
    diffuse_from(mat, outer_node.outputs["Out"])
    uv_plane(empty_scene, "P", mat)

    gltf, _, _ = export(addon, empty_scene, tmp_path)
    graph = graph_of(gltf, "Grouped")
    assert graph is not None and graph["version"] == 1
    nodes = by_name(graph)
    assert set(nodes) == {"Noise", "Outer/Inner/Math", "Diffuse BSDF"}, list(nodes)
    _, m = nodes["Outer/Inner/Math"]
    assert m["type"] == "ShaderNodeMath" and m["props"]["operation"] == "MULTIPLY"
    assert m["inputs"]["Value"]["link"] == [nodes["Noise"][0], "Fac"]
    assert m["inputs"]["Value_001"] == {"value": pytest.approx(0.25)}
    assert "Value_002" not in m["inputs"], "the Math node's third input is unavailable for MULTIPLY"
    _, d = nodes["Diffuse BSDF"]
    # A float into a colour socket: the link is kept (the renderer converts), with the default value.
    assert d["inputs"]["Color"]["link"] == [nodes["Outer/Inner/Math"][0], "Value"]
    assert graph["output"]["surface"] == [nodes["Diffuse BSDF"][0], "BSDF"]
    assert graph["output"].get("displacement") is None  # the exporter drops null members


def test_reroutes_are_removed_and_muted_nodes_pass_through(addon, empty_scene, tmp_path):
    """Noise -> Reroute -> Reroute -> muted Invert -> muted Math -> Diffuse colour: the Diffuse's
    colour links straight to the Noise; a muted node without a pass-through for its output (a
    muted Value node) leaves the input it feeds with its own value, as Cycles does; a muted
    link is absent."""
    mat = new_material("Muted")
    tree = mat.node_tree
    noise = tree.nodes.new("ShaderNodeTexNoise")
    r1, r2 = tree.nodes.new("NodeReroute"), tree.nodes.new("NodeReroute")
    invert = tree.nodes.new("ShaderNodeInvert")
    invert.mute = True
    tree.links.new(noise.outputs["Color"], r1.inputs[0])
    tree.links.new(r1.outputs[0], r2.inputs[0])
    tree.links.new(r2.outputs[0], invert.inputs["Color"])
    bsdf = diffuse_from(mat, invert.outputs["Color"])
    value = tree.nodes.new("ShaderNodeValue")
    value.outputs[0].default_value = 0.7  # not passed on: a muted Value node has no pass-through
    value.mute = True
    bsdf.inputs["Roughness"].default_value = 0.35
    tree.links.new(value.outputs[0], bsdf.inputs["Roughness"])
    normal_src = tree.nodes.new("ShaderNodeTexCoord")
    muted_link = tree.links.new(normal_src.outputs["Normal"], bsdf.inputs["Normal"])
    muted_link.is_muted = True
    uv_plane(empty_scene, "P", mat)

    gltf, _, _ = export(addon, empty_scene, tmp_path)
    graph = graph_of(gltf, "Muted")
    nodes = by_name(graph)
    assert {n["type"] for n in graph["nodes"]} == {"ShaderNodeTexNoise", "ShaderNodeBsdfDiffuse"}
    _, d = nodes["Diffuse BSDF"]
    assert d["inputs"]["Color"]["link"] == [nodes["Noise Texture"][0], "Color"]
    assert d["inputs"]["Roughness"] == {"value": pytest.approx(bsdf.inputs["Roughness"].default_value)}
    assert "link" not in d["inputs"]["Normal"]


def test_color_ramp_and_curve_tables_are_blenders_own_evaluation(addon, empty_scene, tmp_path):
    """The ColorRamp table is `ColorRamp.evaluate(i/256)`; RGB Curves' tables are C, R, G, B from
    `CurveMapping.evaluate` over the curves' x range; Float Curve has one table."""
    mat = new_material("Tables")
    tree = mat.node_tree
    noise = tree.nodes.new("ShaderNodeTexNoise")
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.interpolation = "EASE"
    ramp.color_ramp.elements[0].color = (0.1, 0.2, 0.9, 1.0)
    mid = ramp.color_ramp.elements.new(0.4)
    mid.color = (1.0, 0.5, 0.0, 0.5)
    curves = tree.nodes.new("ShaderNodeRGBCurve")
    red = curves.mapping.curves[0]
    red.points.new(0.3, 0.8)
    curves.mapping.curves[3].points[1].location = (1.0, 0.6)
    curves.mapping.update()
    fcurve = tree.nodes.new("ShaderNodeFloatCurve")
    fcurve.mapping.curves[0].points.new(0.5, 0.1)
    fcurve.mapping.update()
    tree.links.new(noise.outputs["Fac"], ramp.inputs["Fac"])
    tree.links.new(ramp.outputs["Color"], curves.inputs["Color"])
    tree.links.new(noise.outputs["Fac"], fcurve.inputs["Value"])
    bsdf = diffuse_from(mat, curves.outputs["Color"])
    tree.links.new(fcurve.outputs["Value"], bsdf.inputs["Roughness"])
    uv_plane(empty_scene, "P", mat)

    gltf, _, _ = export(addon, empty_scene, tmp_path)
    nodes = by_name(graph_of(gltf, "Tables"))
    table = nodes["Color Ramp"][1]["props"]["color_ramp"]
    assert table["interpolation"] == "EASE" and len(table["table"]) == 257
    for i in (0, 64, 102, 200, 256):
        assert table["table"][i] == pytest.approx(list(ramp.color_ramp.evaluate(i / 256)), abs=1e-6), i
    mapping = nodes["RGB Curves"][1]["props"]["mapping"]
    assert mapping["range"] == [0.0, 1.0] and len(mapping["tables"]) == 4
    assert all(len(t) == 257 for t in mapping["tables"])
    curves.mapping.initialize()
    for i in (0, 77, 128, 256):
        x = i / 256
        expected = [curves.mapping.evaluate(curves.mapping.curves[c], x) for c in (3, 0, 1, 2)]
        assert [t[i] for t in mapping["tables"]] == pytest.approx(expected, abs=1e-6), i
    assert mapping["tables"][1][int(0.3 * 256 + 0.5)] == pytest.approx(0.8, abs=0.02), "the red curve's point"
    assert mapping["tables"][0][256] == pytest.approx(0.6, abs=1e-6), "the combined curve's end point"
    fmap = nodes["Float Curve"][1]["props"]["mapping"]
    assert len(fmap["tables"]) == 1 and fmap["tables"][0][128] == pytest.approx(0.1, abs=0.02)


def test_images_are_written_beside_the_gltf_and_referenced(addon, empty_scene, tmp_path):
    """A packed 8-bit image becomes a PNG with the same bytes, a float image an EXR with the same
    floats, both in caustic_nodes/ with their colour space and alpha mode; an image used by two
    nodes is written once."""
    rng = np.random.default_rng(3)
    byte_pixels = np.round(rng.random((8, 8, 4)) * 255) / 255
    byte_pixels[..., 3] = 1.0
    byte_image = bpy.data.images.new("Bytes", 8, 8)
    byte_image.pixels.foreach_set(byte_pixels.astype(np.float32).ravel())
    byte_image.pack()
    float_pixels = (rng.random((4, 4, 4)) * 5.0).astype(np.float32)
    float_pixels[..., 3] = 1.0
    float_image = bpy.data.images.new("Floats", 4, 4, float_buffer=True)
    float_image.colorspace_settings.name = "Non-Color"
    float_image.pixels.foreach_set(float_pixels.ravel())

    mat = new_material("Imaged")
    tree = mat.node_tree
    t1, t2, t3 = (tree.nodes.new("ShaderNodeTexImage") for _ in range(3))
    t1.image, t2.image, t3.image = byte_image, float_image, byte_image
    t3.interpolation = "Closest"
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    tree.links.new(t1.outputs["Color"], by_id(mix.inputs, "A_Color"))
    tree.links.new(t2.outputs["Color"], by_id(mix.inputs, "B_Color"))
    tree.links.new(t3.outputs["Alpha"], by_id(mix.inputs, "Factor_Float"))
    diffuse_from(mat, by_id(mix.outputs, "Result_Color"))
    uv_plane(empty_scene, "P", mat)

    gltf, _, folder = export(addon, empty_scene, tmp_path)
    graph = graph_of(gltf, "Imaged")
    images = graph["images"]
    assert len(images) == 2, images
    nodes = by_name(graph)
    entries = {name: images[nodes[name][1]["props"]["image"]] for name in ("Image Texture", "Image Texture.001",
                                                                           "Image Texture.002")}
    assert entries["Image Texture"] == entries["Image Texture.002"]
    png = entries["Image Texture"]
    assert png["uri"].startswith("caustic_nodes/") and png["uri"].endswith(".png")
    assert png["colorspace"] == "sRGB" and png["alpha"] == "STRAIGHT"
    assert entries["Image Texture.001"]["uri"].endswith(".exr")
    assert entries["Image Texture.001"]["colorspace"] == "Non-Color"
    assert nodes["Image Texture.002"][1]["props"]["interpolation"] == "Closest"
    for name, expected in (("Image Texture", byte_pixels), ("Image Texture.001", float_pixels)):
        written = scenes.load_pixels(os.path.join(folder, entries[name]["uri"]))
        tolerance = 0.5 / 255 if name == "Image Texture" else 1e-6  # a byte round trip; floats exact
        np.testing.assert_allclose(written, expected, atol=tolerance)


def test_uv_map_numbers_object_matrix_and_texspace(addon, empty_scene, tmp_path):
    """A UV Map node naming the second UV map gets tex_coord 1 (the exporter writes every map in
    order), as does a node reading the active render map when that is the second; a Texture
    Coordinate node's object gives its inverse world matrix in glTF's Y-up world; a mesh whose
    material reads Generated coordinates carries its texture space."""
    target = bpy.data.objects.new("Target", None)
    empty_scene.collection.objects.link(target)
    target.location = (1.0, 2.0, 3.0)
    target.rotation_euler = (0.3, 0.0, 0.7)
    target.scale = (2.0, 1.0, 1.0)

    mat = new_material("Coords")
    tree = mat.node_tree
    uvmap = tree.nodes.new("ShaderNodeUVMap")
    uvmap.uv_map = "Second"
    coords = tree.nodes.new("ShaderNodeTexCoord")
    coords.object = target
    noise = tree.nodes.new("ShaderNodeTexNoise")
    checker = tree.nodes.new("ShaderNodeTexChecker")
    tree.links.new(uvmap.outputs["UV"], noise.inputs["Vector"])
    tree.links.new(coords.outputs["Object"], checker.inputs["Vector"])
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    tree.links.new(noise.outputs["Color"], by_id(mix.inputs, "A_Color"))
    tree.links.new(checker.outputs["Color"], by_id(mix.inputs, "B_Color"))
    diffuse_from(mat, by_id(mix.outputs, "Result_Color"))
    two_maps = uv_plane(empty_scene, "TwoMaps", mat, uv_maps=("First", "Second"))
    two_maps.data.uv_layers["Second"].active_render = True  # Cycles' default UV map

    generated = new_material("Generated")
    diffuse_from(generated, generated.node_tree.nodes.new("ShaderNodeTexWave").outputs["Color"])
    cube = scenes.cube(empty_scene, "Box", 1.0, (3.0, 0.5, 0.2), material=generated)
    cube.modifiers.new("Bevel", "BEVEL")  # the texture space comes from the evaluated mesh

    gltf, state, _ = export(addon, empty_scene, tmp_path)
    assert any("'Box'" in w and "Bevel" in w and "undeformed" in w for w in state.warnings), state.warnings
    nodes = by_name(graph_of(gltf, "Coords"))
    assert nodes["UV Map"][1]["props"]["uv_map"] == "Second"
    assert nodes["UV Map"][1]["props"]["tex_coord"] == 1
    # The Texture Coordinate node's UV output is the active render map, the exporter's TEXCOORD_1.
    assert nodes["Texture Coordinate"][1]["props"]["tex_coord"] == 1
    matrix = nodes["Texture Coordinate"][1]["props"]["object_matrix"]
    # glTF point of Blender's world origin offset: p_b -> p_g = (x, z, -y); the object-space
    # point in glTF axes is C M^-1 p_b.
    c = Matrix(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, 0), (0, 0, 0, 1)))
    m = Matrix([matrix[col::4] for col in range(4)])  # column-major -> rows
    p_b = Vector((0.4, -1.2, 2.5, 1.0))
    expected = c @ (target.matrix_world.inverted() @ p_b)
    assert list(m @ (c @ p_b)) == pytest.approx(list(expected), abs=1e-5)

    meshes = {me["name"]: me for me in gltf["meshes"]}
    evaluated = cube.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    texspace = meshes["Box"]["extras"]["CAUSTIC_texspace"]
    assert texspace["location"] == pytest.approx(list(evaluated.texspace_location), abs=1e-6)
    assert texspace["size"] == pytest.approx(list(evaluated.texspace_size), abs=1e-6)
    assert "CAUSTIC_texspace" not in (meshes["TwoMaps"].get("extras") or {}), "UV and Object only: no Generated"


def test_plain_principled_writes_no_graph_and_procedural_warnings_are_replaced(addon, empty_scene, tmp_path):
    """A Principled BSDF with an image texture and constants is the exporter's business: no graph,
    no caustic_nodes folder. A Noise texture on a Principled input used to be dropped with a
    warning; it is now in the graph and the warning is gone."""
    image = bpy.data.images.new("Plain", 4, 4)
    image.pack()
    plain = scenes.diffuse_material("Plain", 0.5)
    tex = plain.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    plain.node_tree.links.new(tex.outputs["Color"], plain.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    uv_plane(empty_scene, "PlainPlane", plain)
    marble = scenes.diffuse_material("Marble", 0.5)
    noise = marble.node_tree.nodes.new("ShaderNodeTexNoise")
    marble.node_tree.links.new(noise.outputs["Color"], marble.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    uv_plane(empty_scene, "MarblePlane", marble, location=(3, 0, 0))

    gltf, state, folder = export(addon, empty_scene, tmp_path)
    assert graph_of(gltf, "Plain") is None
    assert EXT not in json.dumps(next(m for m in gltf["materials"] if m["name"] == "Plain"))
    graph = graph_of(gltf, "Marble")
    assert {n["type"] for n in graph["nodes"]} == {"ShaderNodeTexNoise", "ShaderNodeBsdfPrincipled"}
    assert not any("Marble" in w and "cannot carry" in w for w in state.warnings), state.warnings
    assert not os.path.exists(os.path.join(folder, "caustic_nodes")), "no graph image to write"


def test_light_node_tree_strength_and_colour_multiply_the_light(addon, empty_scene, tmp_path):
    """Cycles multiplies a light's power by its node tree's Emission Strength and its colour by the
    Emission Color: the exported point light's intensity and colour, and the area light's power
    and colour, carry both; a linked Strength sends the whole tree as the light's graph
    (`CAUSTIC_lights_punctual.nodes`, evaluated by the renderer), the light keeping its own
    power and colour, with no warning."""
    uv_plane(empty_scene, "Floor", scenes.diffuse_material("Grey", 0.5))
    plain = scenes.light(empty_scene, "Plain", "POINT", location=(0, 0, 3), energy=300.0, color=(1.0, 0.5, 0.25))
    noded = scenes.light(empty_scene, "Noded", "POINT", location=(1, 0, 3), energy=300.0, color=(1.0, 0.5, 0.25))
    area = scenes.light(empty_scene, "AreaNoded", "AREA", location=(0, 1, 3), energy=200.0, size=1.0)
    linked = scenes.light(empty_scene, "Linked", "POINT", location=(2, 0, 3), energy=100.0)
    for obj, strength, color in ((noded, 1.0 / 3.0, (0.5, 1.0, 1.0)), (area, 2.0, (1.0, 0.8, 0.6)),
                                 (linked, 0.5, (1.0, 1.0, 1.0))):
        obj.data.use_nodes = True
        emission = next(n for n in obj.data.node_tree.nodes if n.type == "EMISSION")
        emission.inputs["Strength"].default_value = strength
        emission.inputs["Color"].default_value = (*color, 1.0)
    tree = linked.data.node_tree
    value = tree.nodes.new("ShaderNodeValue")
    tree.links.new(value.outputs[0], next(n for n in tree.nodes if n.type == "EMISSION").inputs["Strength"])

    gltf, state, _ = export(addon, empty_scene, tmp_path)
    lights, graphs = {}, {}
    for node in gltf["nodes"]:
        ext = node.get("extensions", {})
        graphs[node["name"]] = ext.get("CAUSTIC_lights_punctual", {}).get("nodes")
        if "KHR_lights_punctual" in ext:
            index = ext["KHR_lights_punctual"]["light"]
            lights[node["name"]] = gltf["extensions"]["KHR_lights_punctual"]["lights"][index]
        if "CAUSTIC_lights_area" in ext:
            lights[node["name"]] = ext["CAUSTIC_lights_area"]
    assert lights["Noded"]["intensity"] == pytest.approx(lights["Plain"]["intensity"] / 3.0, rel=1e-6)
    assert lights["Noded"]["color"] == pytest.approx([0.5, 0.5, 0.25], abs=1e-6)
    assert lights["Plain"]["color"] == pytest.approx([1.0, 0.5, 0.25], abs=1e-6)
    assert lights["AreaNoded"]["power"] == pytest.approx(400.0, rel=1e-6)
    assert lights["AreaNoded"]["color"] == pytest.approx([1.0, 0.8, 0.6], abs=1e-6)
    assert not any("Linked" in w for w in state.warnings), state.warnings
    assert graphs["Linked"] is not None and graphs["Noded"] is None and graphs["Plain"] is None
    assert {"ShaderNodeValue", "ShaderNodeEmission"} <= {n["type"] for n in graphs["Linked"]["nodes"]}
    # The light's own power (100 W of the Plain light's 300 W) and colour; the graph scales it.
    assert lights["Linked"]["intensity"] == pytest.approx(lights["Plain"]["intensity"] / 3.0, rel=1e-6)


def test_graph_scene_passes_the_khronos_validator(addon, empty_scene, tmp_path):
    """A scene with a graph material (procedural texture, image, groups) still validates."""
    if not os.path.isfile(VALIDATOR):
        pytest.fail("the glTF validator is not installed: run scripts/setup_validator.sh", pytrace=False)
    image = bpy.data.images.new("Tex", 4, 4)
    image.pack()
    mat = new_material("Procedural")
    tree = mat.node_tree
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    wave = tree.nodes.new("ShaderNodeTexWave")
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    tree.links.new(tex.outputs["Color"], by_id(mix.inputs, "A_Color"))
    tree.links.new(wave.outputs["Color"], by_id(mix.inputs, "B_Color"))
    diffuse_from(mat, by_id(mix.outputs, "Result_Color"))
    uv_plane(empty_scene, "P", mat)
    scenes.cube(empty_scene, "Box", 0.5, (0, 0, 0.5), material=mat)
    scenes.light(empty_scene, "Key", "POINT", location=(0, 0, 3), energy=100.0)
    gltf, _, folder = export(addon, empty_scene, tmp_path)
    assert graph_of(gltf, "Procedural") is not None
    run = subprocess.run(["node", VALIDATE, os.path.join(folder, "scene.gltf")], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0, run.stderr
    issues = json.loads(run.stdout)["issues"]
    errors = [f"{m['code']} at {m.get('pointer', '?')}: {m['message']}" for m in issues["messages"]
              if m["severity"] == 0]
    assert issues["numErrors"] == 0, "\n".join(errors)


def test_displacement_output_is_exported_and_unknown_settings_named(addon, empty_scene, tmp_path):
    """A Principled material with only a Displacement (through a Bump-less Displacement node) gets
    a graph whose output names both sockets and the displacement method when not bump (the
    renderer moves the mesh), and the mesh its normals domain; adaptive subdivision is named."""
    mat = scenes.diffuse_material("Displaced", 0.5)
    tree = mat.node_tree
    noise = tree.nodes.new("ShaderNodeTexNoise")
    disp = tree.nodes.new("ShaderNodeDisplacement")
    tree.links.new(noise.outputs["Fac"], disp.inputs["Height"])
    tree.links.new(disp.outputs["Displacement"], tree.nodes["Material Output"].inputs["Displacement"])
    mat.displacement_method = "BOTH"
    plane = uv_plane(empty_scene, "P", mat)
    subsurf = plane.modifiers.new("Subdivision", "SUBSURF")
    subsurf.use_adaptive_subdivision = True
    gltf, state, _ = export(addon, empty_scene, tmp_path)
    graph = graph_of(gltf, "Displaced")
    nodes = by_name(graph)
    assert graph["output"]["displacement"] == [nodes["Displacement"][0], "Displacement"]
    assert graph["output"]["surface"] == [nodes["Principled BSDF"][0], "BSDF"]
    assert graph["displacement_method"] == "BOTH"
    assert not any("bump only" in w for w in state.warnings), state.warnings
    assert [m["extras"]["CAUSTIC_normals_domain"] for m in gltf["meshes"]] == ["FACE"]
    assert any("'P'" in w and "adaptive subdivision" in w for w in state.warnings), state.warnings
    mat.displacement_method = "BUMP"
    gltf, state, _ = export(addon, empty_scene, tmp_path)
    assert "displacement_method" not in graph_of(gltf, "Displaced")
    assert all("CAUSTIC_normals_domain" not in (m.get("extras") or {}) for m in gltf["meshes"])
    assert math.isclose(nodes["Displacement"][1]["inputs"]["Scale"]["value"], disp.inputs["Scale"].default_value,
                        rel_tol=1e-6)


def test_file_images_are_rewritten_and_missing_ones_named(addon, empty_scene, tmp_path):
    """An image loaded from a PNG file is written from its pixels like a packed one; an image
    whose file is missing is named in a warning and its node has no image (the renderer warns)."""
    source = tmp_path / "source"
    source.mkdir()
    pixels = np.zeros((4, 4, 4), dtype=np.float32)
    pixels[..., 0] = np.arange(16).reshape(4, 4) / 15.0
    pixels[..., 3] = 1.0
    saved = bpy.data.images.new("OnDisk", 4, 4)
    saved.pixels.foreach_set(pixels.ravel())
    saved.filepath_raw = str(source / "on disk.png")
    saved.file_format = "PNG"
    saved.save()
    bpy.data.images.remove(saved)
    loaded = bpy.data.images.load(str(source / "on disk.png"))
    missing = bpy.data.images.new("Missing", 4, 4)
    missing.source = "FILE"
    missing.filepath = str(source / "nowhere.png")

    mat = new_material("Files")
    tree = mat.node_tree
    t1, t2 = tree.nodes.new("ShaderNodeTexImage"), tree.nodes.new("ShaderNodeTexImage")
    t1.image, t2.image = loaded, missing
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    tree.links.new(t1.outputs["Color"], by_id(mix.inputs, "A_Color"))
    tree.links.new(t2.outputs["Color"], by_id(mix.inputs, "B_Color"))
    diffuse_from(mat, by_id(mix.outputs, "Result_Color"))
    uv_plane(empty_scene, "P", mat)

    gltf, state, folder = export(addon, empty_scene, tmp_path / "out")
    graph = graph_of(gltf, "Files")
    nodes = by_name(graph)
    assert len(graph["images"]) == 1
    entry = graph["images"][nodes["Image Texture"][1]["props"]["image"]]
    assert entry["uri"] == "caustic_nodes/on_disk.png"
    written = scenes.load_pixels(os.path.join(folder, entry["uri"]))
    np.testing.assert_allclose(written, pixels, atol=0.5 / 255)
    assert "image" not in nodes["Image Texture.001"][1]["props"]
    assert any("Files" in w and "'Missing'" in w and "no pixels" in w for w in state.warnings), state.warnings


def test_colour_attributes_are_exported_by_name(addon, empty_scene, tmp_path):
    """glTF's COLOR_n sets carry no names: where the graphs read several colour attributes
    (a Color Attribute node's and an Attribute node's), each is a vertex attribute of its own
    name (`_CAUSTIC_ATTR_` and the name in hex, attributes.py), one value per vertex, and
    nothing is warned (each used to be named in a warning, read as COLOR_0)."""
    mat = new_material("Painted")
    tree = mat.node_tree
    paint = tree.nodes.new("ShaderNodeVertexColor")
    paint.layer_name = "Paint"
    bsdf = diffuse_from(mat, paint.outputs["Color"])
    wet = tree.nodes.new("ShaderNodeAttribute")
    wet.attribute_name = "Wet"
    tree.links.new(wet.outputs["Fac"], bsdf.inputs["Roughness"])
    obj = uv_plane(empty_scene, "P", mat)
    obj.data.color_attributes.new("Paint", "BYTE_COLOR", "CORNER")
    obj.data.color_attributes.new("Wet", "BYTE_COLOR", "CORNER")
    gltf, state, _ = export(addon, empty_scene, tmp_path)
    nodes = by_name(graph_of(gltf, "Painted"))
    assert nodes["Color Attribute"][1]["props"]["layer_name"] == "Paint"
    assert "color_0" not in nodes["Attribute"][1]["props"]
    assert not any("'Painted'" in w and "attribute" in w for w in state.warnings), state.warnings
    prim = gltf["meshes"][0]["primitives"][0]
    for name in ("Paint", "Wet"):
        semantic = "_CAUSTIC_ATTR_" + name.encode().hex().upper()
        accessor = gltf["accessors"][prim["attributes"][semantic]]
        assert (accessor["type"], accessor["componentType"]) == ("VEC4", 5126), accessor
        assert accessor["count"] == gltf["accessors"][prim["attributes"]["POSITION"]]["count"]


def test_the_one_colour_attribute_the_graphs_read_is_colour_0(addon, empty_scene, tmp_path):
    """Where the scene's graphs read one colour attribute alone, the export asks the glTF
    exporter for it by name, which writes it as COLOR_0 (its own choice, Export Vertex Color
    "Material", sees only what a Principled BSDF reads: a fake white COLOR_0 here, with
    First and Second as COLOR_1 and COLOR_2). No warning then: there was one for any name
    (e.g. 'Col'), and the renderer read the fake white."""
    mat = new_material("Named")
    attr = mat.node_tree.nodes.new("ShaderNodeAttribute")
    attr.attribute_name = "Second"
    diffuse_from(mat, attr.outputs["Color"])
    obj = uv_plane(empty_scene, "P", mat)
    for attribute, colour in (("First", (1.0, 0.0, 0.0, 1.0)), ("Second", (0.0, 1.0, 0.0, 1.0))):
        layer = obj.data.color_attributes.new(attribute, "FLOAT_COLOR", "POINT")
        for item in layer.data:
            item.color = colour
    obj.data.color_attributes.active_color_name = "First"
    gltf, state, folder = export(addon, empty_scene, tmp_path)
    assert not any("'Named'" in w and "COLOR_n" in w for w in state.warnings), state.warnings
    # ... nor in the renderer: the node is marked as COLOR_0's.
    assert by_name(graph_of(gltf, "Named"))["Attribute"][1]["props"]["color_0"] is True
    prim = gltf["meshes"][0]["primitives"][0]
    accessor = gltf["accessors"][prim["attributes"]["COLOR_0"]]
    view = gltf["bufferViews"][accessor["bufferView"]]
    with open(os.path.join(folder, gltf["buffers"][view["buffer"]]["uri"]), "rb") as f:
        f.seek(view.get("byteOffset", 0) + accessor.get("byteOffset", 0))
        raw = f.read(6)
    assert accessor["componentType"] == 5123 and accessor["normalized"], accessor  # unsigned short
    assert struct.unpack("<3H", raw) == (0, 65535, 0), "COLOR_0 is not Second"


def shader_node_types():
    """Every shader node type that can be added to a material's tree (bpy 5.0.1: about 100)."""
    probe = new_material("Probe")
    kinds = []
    for name in dir(bpy.types):
        cls = getattr(bpy.types, name)
        if not (isinstance(cls, type) and issubclass(cls, bpy.types.ShaderNode)) or cls is bpy.types.ShaderNode:
            continue
        try:
            node = probe.node_tree.nodes.new(name)
        except RuntimeError:  # abstract or not allowed in a material
            continue
        if node.outputs and node.type not in {"OUTPUT_MATERIAL", "OUTPUT_LIGHT", "OUTPUT_WORLD", "OUTPUT_AOV",
                                              "GROUP"}:
            kinds.append(name)
    bpy.data.materials.remove(probe)
    return kinds


def test_every_shader_node_type_exports(addon, empty_scene, tmp_path):
    """Each shader node type, on the output (closures) or into a Diffuse colour (values), is
    written as itself with props and inputs that are plain, finite JSON; nothing raises (a
    Principled BSDF alone stays the exporter's)."""
    kinds = shader_node_types()
    assert len(kinds) > 80, kinds
    for i, kind in enumerate(kinds):
        mat = new_material(f"Kind{i}")
        tree = mat.node_tree
        node = tree.nodes.new(kind)
        out = node.outputs[0]
        if out.type == "SHADER":
            tree.links.new(out, tree.nodes["Material Output"].inputs["Surface"])
        else:
            diffuse_from(mat, out)
        uv_plane(empty_scene, f"P{i}", mat, location=(3 * (i % 10), 3 * (i // 10), 0))
    gltf, state, _ = export(addon, empty_scene, tmp_path)
    text = json.dumps(gltf, allow_nan=False)  # raises on NaN or infinity
    assert "CAUSTIC_materials_nodes" in text
    for i, kind in enumerate(kinds):
        graph = graph_of(gltf, f"Kind{i}")
        if kind == "ShaderNodeBsdfPrincipled":  # alone on the output: the exporter's own material
            assert graph is None
            continue
        if kind == "ShaderNodeShaderToRGB":  # EEVEE-only: left out as Cycles, its input keeps its value
            assert graph is None or kind not in {n["type"] for n in graph["nodes"]}, graph
            continue
        assert graph is not None, kind
        assert kind in {n["type"] for n in graph["nodes"]}, (kind, graph["nodes"])


def test_value_and_rgb_nodes_carry_their_numbers(addon, empty_scene, tmp_path):
    """Value and RGB nodes keep their number in the output socket: the add-on writes it as
    props.value / props.color (contract), else the renderer would read 0."""
    mat = new_material("Constants")
    tree = mat.node_tree
    rgb = tree.nodes.new("ShaderNodeRGB")
    rgb.outputs[0].default_value = (0.2, 0.4, 0.6, 1.0)
    bsdf = diffuse_from(mat, rgb.outputs[0])
    value = tree.nodes.new("ShaderNodeValue")
    value.outputs[0].default_value = 0.3
    tree.links.new(value.outputs[0], bsdf.inputs["Roughness"])
    uv_plane(empty_scene, "P", mat)

    gltf, _, _ = export(addon, empty_scene, tmp_path)
    nodes = by_name(graph_of(gltf, "Constants"))
    assert nodes["Value"][1]["props"]["value"] == pytest.approx(0.3)
    assert nodes["Color"][1]["props"]["color"][:3] == pytest.approx([0.2, 0.4, 0.6])


def test_principled_ior_below_one_exports_without_warning(addon, empty_scene, tmp_path):
    """A Principled BSDF with IOR below 1 (corpus collection_to_link.blend has 0): Caustic renders
    the specular layer of that η as Cycles does (test_principled_ior_below_one.py), so the export
    warns no more (it named the node while Caustic clamped η to 1). The constant sends the
    material to its node graph, which carries the IOR (Blender's exporter drops an opaque
    material's KHR_materials_ior)."""
    mat = bpy.data.materials.new("Odd")
    if mat.node_tree is None:
        mat.use_nodes = True
    mat.node_tree.nodes["Principled BSDF"].inputs["IOR"].default_value = 0.0
    uv_plane(empty_scene, "Plane", mat)
    gltf, state, _ = export(addon, empty_scene, tmp_path)
    assert not any("IOR" in w for w in state.warnings), state.warnings
    nodes = by_name(graph_of(gltf, "Odd"))
    assert nodes["Principled BSDF"][1]["inputs"]["IOR"]["value"] == 0.0


def test_triangles_the_udim_split_leaves_out_are_named(addon, empty_scene, tmp_path):
    """Blender's glTF exporter splits a mesh with UDIM textures by tile and leaves out a triangle
    whose first corner's UV is in no tile (corpus 33_udim_merged.blend: 6 of 12 exported, the
    faces whose UVs start at -0.02); Cycles renders them. The export names the mesh."""
    import test_images_agreement as images
    mat = images.principled_image(images.udim)(str(tmp_path), "Tiles")
    images.udim_split_scene(empty_scene, mat)
    mesh = empty_scene.objects["Plane"].data
    for loop in mesh.polygons[0].loop_indices:  # the first face's UVs start just below tile 1001
        mesh.uv_layers["UVMap"].data[loop].uv -= Vector((0.15, 0.0))
    _, state, _ = export(addon, empty_scene, tmp_path)
    assert any("'Plane'" in w and "left out" in w and "of its 4 triangles" in w for w in state.warnings), \
        state.warnings
