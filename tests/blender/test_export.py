"""What the add-on writes for the renderer: the glTF of a render, read back and checked value by value.

The glTF is captured from a real F12-style render (`bpy.ops.render.render`) with the contract's
stand-in binary (fake_caustic.py), so the export runs exactly as in production: from inside
RenderEngine.render(), with the render depsgraph. The exporter swallows hook exceptions, so only
the written file proves that the hooks ran.
"""

import importlib
import json
import math

import bpy
import numpy as np
import pytest
from mathutils import Matrix, Quaternion

import scenes

WATTS_TO_LUMENS = 683.0


@pytest.fixture
def captured(fake_binary, tmp_path, monkeypatch):
    """A function rendering the current scene and returning the glTF the binary received."""
    folder = tmp_path / "scenes"
    monkeypatch.setenv("FAKE_CAUSTIC_SCENE_DIR", str(folder))

    def render(animation=False):
        bpy.ops.render.render(animation=animation)
        files = sorted(folder.glob("*.gltf"))
        return [json.loads(f.read_text()) for f in files]

    return render


def node_by_name(gltf, name):
    return next(n for n in gltf["nodes"] if n.get("name") == name)


def node_matrix(node):
    x, y, z, w = node.get("rotation", [0, 0, 0, 1])
    t = Matrix.Translation(node.get("translation", [0, 0, 0]))
    r = Quaternion((w, x, y, z)).to_matrix().to_4x4()
    s = Matrix.Diagonal([*node.get("scale", [1, 1, 1]), 1.0])
    return t @ r @ s


# Blender (Z up) to glTF (Y up) world axes: (x, y, z) -> (x, z, -y).
BLENDER_TO_GLTF = Matrix(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, 0), (0, 0, 0, 1)))

AREA_LIGHTS = [
    # name, shape, size, size_y, energy, color, expected size
    ("AreaRect", "RECTANGLE", 2.0, 0.5, 100.0, (1.0, 0.5, 0.25), [2.0, 0.5]),
    ("AreaSquare", "SQUARE", 1.5, 9.0, 40.0, (0.2, 1.0, 0.2), [1.5, 1.5]),
    ("AreaDisk", "DISK", 0.75, 9.0, 25.0, (1.0, 1.0, 1.0), [0.75, 0.75]),
    ("AreaEllipse", "ELLIPSE", 1.25, 0.4, 60.0, (0.3, 0.6, 0.9), [1.25, 0.4]),
]


@pytest.fixture
def light_scene(empty_scene):
    scene = empty_scene
    scenes.small_render_settings(scene, 16, 12, samples=2)
    scenes.plane(scene, "Floor", 4.0, material=scenes.diffuse_material("Grey", 0.5))
    scenes.camera(scene, (0, -4, 3), (60, 0, 0))
    for i, (name, shape, size, size_y, energy, color, _) in enumerate(AREA_LIGHTS):
        scenes.light(scene, name, "AREA", location=(i, 1.0, 2.0 + i), rotation_deg=(20 * i, 10, 5 * i),
                     shape=shape, size=size, size_y=size_y, energy=energy, color=color)
    scenes.light(scene, "Point", "POINT", location=(1, 2, 3), energy=150.0, color=(1, 0.9, 0.8),
                 shadow_soft_size=0.0)
    scenes.light(scene, "Spot", "SPOT", location=(0, 0, 4), energy=300.0, spot_size=math.radians(50),
                 spot_blend=0.2, shadow_soft_size=0.0)
    scenes.light(scene, "Sun", "SUN", rotation_deg=(30, 0, 0), energy=3.0, angle=0.0)
    scene.caustic.samples = 7
    scene.cycles.max_bounces = 5
    scene.caustic.seed = 42
    scene.caustic.threads = 2
    scene.caustic.time_limit = 12.5
    return scene


def test_area_lights_get_caustic_extension(light_scene, captured):
    (gltf,) = captured()
    assert "CAUSTIC_lights_area" in gltf["extensionsUsed"]
    assert "CAUSTIC_lights_area" not in gltf.get("extensionsRequired", [])
    for name, shape, _, _, energy, color, size in AREA_LIGHTS:
        ext = node_by_name(gltf, name)["extensions"]["CAUSTIC_lights_area"]
        assert ext["shape"] == shape.lower()
        assert ext["size"] == pytest.approx(size)
        assert ext["power"] == pytest.approx(energy)
        assert ext["color"] == pytest.approx(list(color))


def test_area_light_node_frame_is_the_blender_light_frame(light_scene, captured):
    """Contract: light in the node's local XY plane, emitting towards local -Z, scale applies.

    The exporter gives light nodes a -90° X correction and converts to Y up; for the contract
    to hold without compensation, node world matrix == axis change @ Blender world matrix.
    """
    obj = bpy.data.objects["AreaEllipse"]
    obj.scale = (1.0, 2.0, 3.0)
    (gltf,) = captured()
    node = node_by_name(gltf, "AreaEllipse")
    expected = BLENDER_TO_GLTF @ obj.matrix_world
    got = node_matrix(node)
    for i in range(4):
        assert list(got[i]) == pytest.approx(list(expected[i]), abs=1e-5)
    assert node["scale"] == pytest.approx([1.0, 2.0, 3.0], abs=1e-5)


def test_area_light_power_includes_exposure_temperature_and_unnormalized_area(light_scene, captured):
    data = bpy.data.lights["AreaRect"]
    data.exposure = 1.0
    data.normalize = False
    data.use_temperature = True
    data.temperature = 3000.0
    obj = bpy.data.objects["AreaRect"]
    obj.scale = (2.0, 1.0, 1.0)
    (gltf,) = captured()
    ext = node_by_name(gltf, "AreaRect")["extensions"]["CAUSTIC_lights_area"]
    world_area = (2.0 * 2.0) * 0.5
    assert ext["power"] == pytest.approx(100.0 * 2.0 * world_area, rel=1e-5)
    tint = [c * t for c, t in zip((1.0, 0.5, 0.25), data.temperature_color)]
    assert ext["color"] == pytest.approx(tint, rel=1e-5)


def test_punctual_light_units(light_scene, captured):
    """The exporter's 'SPEC' lighting mode: point/spot W/(4π)·683 cd, sun W/m²·683 lux."""
    (gltf,) = captured()
    lights = gltf["extensions"]["KHR_lights_punctual"]["lights"]

    def light_of(node_name):
        return lights[node_by_name(gltf, node_name)["extensions"]["KHR_lights_punctual"]["light"]]

    assert light_of("Point")["intensity"] == pytest.approx(150.0 / (4 * math.pi) * WATTS_TO_LUMENS)
    spot = light_of("Spot")
    assert spot["intensity"] == pytest.approx(300.0 / (4 * math.pi) * WATTS_TO_LUMENS)
    assert spot["spot"]["outerConeAngle"] == pytest.approx(math.radians(25))
    assert spot["spot"]["innerConeAngle"] == pytest.approx(math.radians(25) * (1 - 0.2), rel=1e-5)
    assert light_of("Sun")["intensity"] == pytest.approx(3.0 * WATTS_TO_LUMENS)
    assert light_of("Sun")["type"] == "directional"


def test_scene_extras_carry_render_settings(light_scene, captured):
    light_scene.render.resolution_percentage = 50
    (gltf,) = captured()
    settings = gltf["scenes"][gltf.get("scene", 0)]["extras"]["caustic"]
    assert settings == {
        "resolution": [8, 6],
        "spp": 7,
        "max_depth": 6,
        # Cycles' Light Paths defaults but Max Bounces (Caustic's panel draws Cycles' own).
        "diffuse_max_bounces": 4,
        "glossy_max_bounces": 4,
        "transmission_max_bounces": 12,
        "volume_max_bounces": 0,
        "transparent_max_bounces": 8,
        "clamp_direct": 0.0,
        "clamp_indirect": 10.0,
        "filter_glossy": 1.0,
        "caustics_reflective": True,
        "caustics_refractive": True,
        "seed": 42,
        "integrator": "path",
        "light_sampler": "tree",
        "time_limit": 12.5,
        "threads": 2,
        "camera": "Camera",
        "transparent": bool(light_scene.render.film_transparent),
        "filter": "blackman-harris",
        "filter_width": 2.0 * light_scene.cycles.filter_width,
    }


def test_film_transparent_and_filter_reach_the_renderer(light_scene, captured):
    """The Film panel's pixel filter is Cycles' (scene.cycles), spread as Cycles spreads it:
    Blackman-Harris twice the Width, Gaussian three times, Box always one pixel. Before,
    the add-on read Blender's render.filter_size, which Cycles ignores, and always wrote
    Blackman-Harris."""
    light_scene.render.film_transparent = True
    light_scene.cycles.filter_width = 2.25
    light_scene.render.filter_size = 0.5  # Eevee's, not Cycles': no effect
    gltf = captured()[-1]
    settings = gltf["scenes"][gltf.get("scene", 0)]["extras"]["caustic"]
    assert settings["transparent"] is True
    assert (settings["filter"], settings["filter_width"]) == ("blackman-harris", 4.5)
    light_scene.cycles.pixel_filter_type = "GAUSSIAN"
    gltf = captured()[-1]
    settings = gltf["scenes"][gltf.get("scene", 0)]["extras"]["caustic"]
    assert (settings["filter"], settings["filter_width"]) == ("gaussian", 6.75)
    light_scene.cycles.pixel_filter_type = "BOX"
    gltf = captured()[-1]
    settings = gltf["scenes"][gltf.get("scene", 0)]["extras"]["caustic"]
    assert (settings["filter"], settings["filter_width"]) == ("box", 1.0)


def test_view_layer_samples_override_as_cycles(light_scene, captured):
    """View Layer > Override > Samples, as Cycles' Layer Samples takes it: Use replaces the
    scene's count, Bounded caps it, Ignore leaves it (before, every layer rendered the scene's
    count: a layer meant for 16 spp took the scene's 7 here, or 512 in a production file)."""
    light_scene.view_layers[0].samples = 3

    def spp():
        gltf = captured()[-1]
        return gltf["scenes"][gltf.get("scene", 0)]["extras"]["caustic"]["spp"]

    light_scene.cycles.use_layer_samples = "USE"
    assert spp() == 3
    light_scene.cycles.use_layer_samples = "IGNORE"
    assert spp() == 7
    light_scene.cycles.use_layer_samples = "BOUNDED"
    assert spp() == 3
    light_scene.view_layers[0].samples = 50
    assert spp() == 7


def test_transparent_glass_reaches_the_renderer(light_scene, captured):
    """Film > Transparent Glass goes as its Roughness Threshold, only with a transparent film
    (Cycles ignores it otherwise)."""
    light_scene.cycles.film_transparent_glass = True
    light_scene.cycles.film_transparent_roughness = 0.25
    light_scene.render.film_transparent = False
    gltf = captured()[-1]
    assert "transparent_glass" not in gltf["scenes"][gltf.get("scene", 0)]["extras"]["caustic"]
    light_scene.render.film_transparent = True
    gltf = captured()[-1]
    assert gltf["scenes"][gltf.get("scene", 0)]["extras"]["caustic"]["transparent_glass"] == 0.25


def test_command_line_repeats_settings(light_scene, captured, fake_binary):
    captured()
    argv = json.loads(fake_binary.read_text())
    assert argv[0] == "render" and argv[2] == "-o"
    pairs = dict(zip(argv[4::2], argv[5::2]))
    assert pairs["--progress"] == "json"
    assert pairs["--resolution"] == "16x12"
    assert pairs["--spp"] == "7"
    assert pairs["--max-depth"] == "6"
    assert pairs["--seed"] == "42"
    assert pairs["--threads"] == "2"
    assert float(pairs["--time-limit"]) == 12.5
    assert pairs["--camera"] == "Camera"
    assert "--crop" not in pairs


def test_render_visibility_and_render_level_modifiers(empty_scene, captured):
    scene = empty_scene
    scenes.small_render_settings(scene, 8, 6, samples=1)
    scenes.camera(scene, (0, -4, 3), (60, 0, 0))
    scenes.light(scene, "Sun", "SUN", energy=1.0)
    smooth = scenes.cube(scene, "Smooth", 1.0, (0, 0, 0))
    sub = smooth.modifiers.new("Subdivision", "SUBSURF")
    sub.levels, sub.render_levels = 0, 2
    only_render = scenes.cube(scene, "OnlyRender", 1.0, (2, 0, 0))
    only_render.modifiers.new("Tri", "TRIANGULATE").show_viewport = False
    bevel = only_render.modifiers.new("Bevel", "BEVEL")
    bevel.show_viewport, bevel.show_render = False, True
    hidden = scenes.cube(scene, "NotRendered", 1.0, (-2, 0, 0))
    hidden.hide_render = True
    viewport_off = scenes.cube(scene, "ViewportDisabled", 1.0, (0, 2, 0))
    viewport_off.hide_viewport = True

    (gltf,) = captured()
    names = {n.get("name") for n in gltf["nodes"]}
    assert "NotRendered" not in names
    assert "ViewportDisabled" in names

    def triangles(node_name):
        mesh = gltf["meshes"][node_by_name(gltf, node_name)["mesh"]]
        return sum(gltf["accessors"][p["indices"]]["count"] // 3 for p in mesh["primitives"])

    assert triangles("Smooth") == 6 * 16 * 2  # render level 2: each quad -> 16 quads
    assert triangles("OnlyRender") > 12  # bevel applied although hidden in the viewport
    assert triangles("ViewportDisabled") == 12


def test_excluded_collections_are_left_out_but_their_instances_render(empty_scene, captured):
    """A collection excluded from the view layer is not rendered (Cycles), but an instance of
    it is: the usual way to keep instanced assets out of view."""
    scene = empty_scene
    scenes.small_render_settings(scene, 8, 6, samples=1)
    scenes.camera(scene, (0, -4, 3), (60, 0, 0))
    scenes.light(scene, "Sun", "SUN", energy=1.0)
    scenes.cube(scene, "Kept", 1.0, (0, 0, 0))
    assets = bpy.data.collections.new("Assets")
    scene.collection.children.link(assets)
    asset = scenes.cube(scene, "Asset", 1.0, (5, 0, 0))
    scene.collection.objects.unlink(asset)
    assets.objects.link(asset)
    lamp = scenes.light(scene, "AssetLamp", "POINT", location=(5, 0, 3), energy=10.0)
    scene.collection.objects.unlink(lamp)
    assets.objects.link(lamp)
    scene.view_layers[0].layer_collection.children["Assets"].exclude = True
    instancer = bpy.data.objects.new("Instancer", None)
    instancer.instance_type = "COLLECTION"
    instancer.instance_collection = assets
    instancer.location = (-3, 0, 0)
    scene.collection.objects.link(instancer)

    (gltf,) = captured()
    names = [n.get("name") for n in gltf["nodes"]]
    meshes = [n.get("name") for n in gltf["nodes"] if "mesh" in n]
    # The excluded collection's cube and light appear once each: through the instancer (an
    # instanced light lights the scene in Cycles too), not at their own place.
    assert sorted(meshes) == ["Asset", "Kept"], names
    assert names.count("AssetLamp") == 1, names


def test_nested_collection_instances_render_once(empty_scene, captured):
    """An excluded collection "Outer" of two instancers of the excluded "Inner" (a cube),
    itself instanced twice: Cycles renders the cube 4 times (2 x 2). The exporter also walks
    Outer's instancers from the tree's root; the view layer filter dropped those but kept what
    they instance, which the exporter then put at the root: 6 cubes (sweep 4's
    nested_collection_instances: B 1.0175 of Cycles, 2 of 48 blocks off)."""
    scene = empty_scene
    scenes.small_render_settings(scene, 8, 6, samples=1)
    scenes.camera(scene, (0, -4, 3), (60, 0, 0))
    scenes.light(scene, "Sun", "SUN", energy=1.0)
    layers = scene.view_layers[0].layer_collection.children
    inner = bpy.data.collections.new("Inner")
    scene.collection.children.link(inner)
    cube = scenes.cube(scene, "Box", 0.3, (0, 0, 0))
    scene.collection.objects.unlink(cube)
    inner.objects.link(cube)
    outer = bpy.data.collections.new("Outer")
    scene.collection.children.link(outer)
    for name, parent, collection, x in (("In0", outer, inner, -0.5), ("In1", outer, inner, 0.5),
                                        ("Out0", scene.collection, outer, -2.0),
                                        ("Out1", scene.collection, outer, 2.0)):
        empty = bpy.data.objects.new(name, None)
        empty.instance_type = "COLLECTION"
        empty.instance_collection = collection
        empty.location = (x, 0, 0)
        parent.objects.link(empty)
    layers["Inner"].exclude = True
    layers["Outer"].exclude = True

    (gltf,) = captured()
    meshes = [n.get("name") for n in gltf["nodes"] if "mesh" in n]
    assert meshes == ["Box"] * 4, [n.get("name") for n in gltf["nodes"]]
    roots = [gltf["nodes"][i].get("name") for i in gltf["scenes"][0]["nodes"]]
    assert "Box" not in roots and "In0" not in roots, roots


def _world_matrices(gltf):
    """Each mesh node's name and world matrix (glTF axes), walking the scene's tree."""
    found = []

    def walk(index, parent):
        node = gltf["nodes"][index]
        world = parent @ node_matrix(node)
        if "mesh" in node:
            found.append((node.get("name"), world))
        for child in node.get("children", []):
            walk(child, world)

    for root in gltf["scenes"][0]["nodes"]:
        walk(root, Matrix.Identity(4))
    return found


def test_children_of_collection_instancers_stay_where_blender_has_them(empty_scene, captured):
    """A sphere, turned and scaled, parented (with its parent inverse) to an Empty that instances a
    collection and is itself moved and turned: Blender's exporter wrote the sphere's transform
    relative to the world under the Empty's node, so it rendered offset by the Empty's own
    transform (glTF-Blender-IO's 39_parenting_full_hierarchy.blend: three objects off, 102 of
    3,072 blocks against Cycles). A child of a plain Empty is checked alongside."""
    scene = empty_scene
    scenes.small_render_settings(scene, 8, 6, samples=1)
    scenes.camera(scene, (0, -8, 5), (60, 0, 0))
    scenes.light(scene, "Sun", "SUN", energy=1.0)
    inner = bpy.data.collections.new("Inner")
    scene.collection.children.link(inner)
    cube = scenes.cube(scene, "Box", 0.3, (0, 0, 0))
    scene.collection.objects.unlink(cube)
    inner.objects.link(cube)
    scene.view_layers[0].layer_collection.children["Inner"].exclude = True
    expected = {}
    for name, instancing in (("Instancer", True), ("Plain", False)):
        holder = bpy.data.objects.new(name, None)
        if instancing:
            holder.instance_type = "COLLECTION"
            holder.instance_collection = inner
        holder.location = (0.5, 3.0, 0.2) if instancing else (-2.0, 1.0, 0.0)
        holder.rotation_euler = (0.0, 0.0, 0.6)
        scene.collection.objects.link(holder)
        ball = scenes.cube(scene, f"Child of {name}", 0.4, (1.0, -1.0, 2.0))
        ball.rotation_euler = (0.3, 0.0, 0.2)
        ball.scale = (1.0, 2.0, 1.0)
        bpy.context.view_layer.update()
        ball.parent = holder
        ball.matrix_parent_inverse = holder.matrix_world.inverted()
        bpy.context.view_layer.update()
        expected[ball.name] = BLENDER_TO_GLTF @ ball.matrix_world @ BLENDER_TO_GLTF.inverted()

    (gltf,) = captured()
    worlds = dict(_world_matrices(gltf))
    for name, want in expected.items():
        got = worlds[name]
        error = max(abs(got[i][j] - want[i][j]) for i in range(4) for j in range(4))
        assert error < 1e-4, f"{name}: exported world matrix {got} differs from Blender's {want}"


def test_object_ray_visibility_is_exported(empty_scene, captured):
    """An object's Ray Visibility flags that are off, its Holdout (its own or its
    collection's in the view layer), an Indirect Only collection's (camera off) and its Shadow
    Catcher go out as CAUSTIC_object_visibility
    on its node; an ordinary object carries no extension. A light whose Shadow Catcher flag is
    off says so in its light extension."""
    scene = empty_scene
    scenes.small_render_settings(scene, 8, 6, samples=1)
    scenes.camera(scene, (0, -4, 3), (60, 0, 0))
    scenes.light(scene, "Sun", "SUN", energy=1.0)
    scenes.cube(scene, "Plain", 1.0, (0, 0, 0))
    ghost = scenes.cube(scene, "Ghost", 1.0, (2, 0, 0))
    ghost.visible_camera = False
    ghost.visible_shadow = False
    ghost.visible_volume_scatter = False
    scenes.cube(scene, "Held", 1.0, (4, 0, 0)).is_holdout = True
    held_coll = bpy.data.collections.new("HeldCollection")
    scene.collection.children.link(held_coll)
    in_held = scenes.cube(scene, "InHeld", 1.0, (6, 0, 0))
    scene.collection.objects.unlink(in_held)
    held_coll.objects.link(in_held)
    bpy.context.view_layer.layer_collection.children["HeldCollection"].holdout = True
    scenes.cube(scene, "Catcher", 1.0, (8, 0, 0)).is_shadow_catcher = True
    indirect_coll = bpy.data.collections.new("IndirectCollection")
    scene.collection.children.link(indirect_coll)
    indirect = scenes.cube(scene, "Indirect", 1.0, (10, 0, 0))
    scene.collection.objects.unlink(indirect)
    indirect_coll.objects.link(indirect)
    bpy.context.view_layer.layer_collection.children["IndirectCollection"].indirect_only = True
    scenes.light(scene, "Apart", "POINT", energy=1.0).is_shadow_catcher = False
    (gltf,) = captured()
    assert node_by_name(gltf, "Catcher")["extensions"]["CAUSTIC_object_visibility"] == {"shadow_catcher": True}
    # Indirect Only: Cycles clears the object's camera visibility.
    assert node_by_name(gltf, "Indirect")["extensions"]["CAUSTIC_object_visibility"] == {"camera": False}
    assert node_by_name(gltf, "Apart")["extensions"]["CAUSTIC_lights_punctual"] == {"shadow_catcher": False}
    assert "shadow_catcher" not in node_by_name(gltf, "Sun")["extensions"]["CAUSTIC_lights_punctual"]
    assert node_by_name(gltf, "Ghost")["extensions"]["CAUSTIC_object_visibility"] == {
        "camera": False, "volume_scatter": False, "shadow": False}
    for name in ("Held", "InHeld"):
        assert node_by_name(gltf, name)["extensions"]["CAUSTIC_object_visibility"] == {"holdout": True}
    assert "CAUSTIC_object_visibility" not in node_by_name(gltf, "Plain").get("extensions", {})
    assert "CAUSTIC_object_visibility" in gltf["extensionsUsed"]


def _nan_tent(scene, name, x, origin_vertex=False):
    """A pyramid whose apex is NaN (a Geometry Nodes division by zero would make one), with its
    square base as two more triangles; optionally one base corner exactly at the origin."""
    base = [(-1, -1, 0.5), (1, -1, 0.5), (1, 1, 0.5), (-1, 1, 0.5)]
    if origin_vertex:
        base[0] = (0.0, 0.0, 0.0)
    obj = scenes.mesh_object(scene, name, base + [(0, 0, 1.5)],
                             [(0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4), (0, 1, 2), (0, 2, 3)])
    obj.location.x = x
    obj.data.vertices[4].co = (float("nan"),) * 3
    return obj


def test_nonfinite_vertices_drop_their_triangles(empty_scene, addon, tmp_path):
    """Cycles leaves out a triangle with a non-finite corner; Blender's exporter writes such a
    vertex at the origin (nonfinite.py). The four sides of the NaN-apexed pyramid are exported
    degenerate, its base intact, with a warning naming the object; where a finite vertex is at
    the origin too, nothing is dropped and the warning says so."""
    scene = empty_scene
    scenes.small_render_settings(scene, 8, 6, samples=1)
    scenes.camera(scene, (0, -6, 4), (55, 0, 0))
    _nan_tent(scene, "Tent", 0.0)
    _nan_tent(scene, "Corner", 3.0, origin_vertex=True)
    export = importlib.import_module(addon.__name__ + ".export")
    settings = export.render_settings(scene, (8, 6), "Camera")
    path, state = export.export_scene(bpy.context.evaluated_depsgraph_get(), str(tmp_path), settings)
    with open(path) as f:
        gltf = json.load(f)

    def triangles(name):
        prim = gltf["meshes"][node_by_name(gltf, name)["mesh"]]["primitives"][0]
        acc = gltf["accessors"][prim["indices"]]
        view = gltf["bufferViews"][acc["bufferView"]]
        data = (tmp_path / gltf["buffers"][view["buffer"]]["uri"]).read_bytes()
        start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        dtype = {5121: np.uint8, 5123: np.uint16, 5125: np.uint32}[acc["componentType"]]
        return np.frombuffer(data[start:start + acc["count"] * np.dtype(dtype).itemsize], dtype).reshape(-1, 3)

    tent = triangles("Tent")
    degenerate = [len(set(t.tolist())) == 1 for t in tent]
    assert sum(degenerate) == 4 and len(tent) == 6, tent
    assert not any(len(set(t.tolist())) == 1 for t in triangles("Corner"))
    assert any("'Tent'" in w and "non-finite" in w and "4 triangles" in w for w in state.warnings), state.warnings
    assert any("'Corner'" in w and "non-finite" in w and "cannot be told apart" in w for w in state.warnings), \
        state.warnings


def test_shadow_terminator_offset_is_exported(empty_scene, addon, tmp_path):
    """Object > Shading > Shadow Terminator: the Geometry Offset goes out as
    CAUSTIC_object_shading (Blender's default 0.1 on every object; none at 0), a Shading
    Offset below 2 beside it (at 2 or more Cycles' frequency multiplier is not above 1: nothing)."""
    scene = empty_scene
    scenes.small_render_settings(scene, 8, 6, samples=1)
    scenes.camera(scene, (0, -4, 3), (60, 0, 0))
    scenes.light(scene, "Sun", "SUN", energy=1.0)
    scenes.cube(scene, "Default", 1.0, (0, 0, 0))
    scenes.cube(scene, "Off", 1.0, (2, 0, 0)).shadow_terminator_geometry_offset = 0.0
    shaded = scenes.cube(scene, "Shaded", 1.0, (4, 0, 0))
    shaded.shadow_terminator_geometry_offset = 0.5
    shaded.shadow_terminator_shading_offset = 0.6
    scenes.cube(scene, "Beyond", 1.0, (6, 0, 0)).shadow_terminator_shading_offset = 2.0
    export = importlib.import_module(addon.__name__ + ".export")
    settings = export.render_settings(scene, (8, 6), "Camera")
    path, state = export.export_scene(bpy.context.evaluated_depsgraph_get(), str(tmp_path), settings)
    with open(path) as f:
        gltf = json.load(f)
    offset = node_by_name(gltf, "Default")["extensions"]["CAUSTIC_object_shading"]["shadow_terminator_offset"]
    assert offset == pytest.approx(0.1)
    assert "CAUSTIC_object_shading" not in node_by_name(gltf, "Off").get("extensions", {})
    assert node_by_name(gltf, "Shaded")["extensions"]["CAUSTIC_object_shading"] == pytest.approx(
        {"shadow_terminator_offset": 0.5, "shading_offset": 0.6})
    assert "shading_offset" not in node_by_name(gltf, "Beyond")["extensions"]["CAUSTIC_object_shading"]
    assert not any("Shading Offset" in w for w in state.warnings), state.warnings


def test_animation_exports_each_frame(empty_scene, captured, tmp_path):
    scene = empty_scene
    scenes.small_render_settings(scene, 8, 6, samples=1)
    scenes.camera(scene, (0, -4, 3), (60, 0, 0))
    scenes.light(scene, "Sun", "SUN", energy=1.0)
    box = scenes.cube(scene, "Box", 1.0, (0, 0, 0))
    for frame, x in ((1, 0.0), (2, 1.5)):
        box.location.x = x
        box.keyframe_insert("location", frame=frame)
    scene.frame_start, scene.frame_end = 1, 2
    scene.render.filepath = str(tmp_path / "frame_")
    first, second = captured(animation=True)
    assert node_by_name(first, "Box").get("translation", [0, 0, 0])[0] == pytest.approx(0.0)
    assert node_by_name(second, "Box")["translation"][0] == pytest.approx(1.5)


def test_plain_gltf_export_is_left_alone(light_scene, tmp_path):
    """With Caustic enabled, a user's own glTF export gets no Caustic data."""
    path = tmp_path / "plain.gltf"
    bpy.ops.export_scene.gltf(filepath=str(path), export_format="GLTF_SEPARATE", export_lights=True)
    gltf = json.loads(path.read_text())
    assert "CAUSTIC_lights_area" not in gltf.get("extensionsUsed", [])
    assert "caustic" not in gltf["scenes"][0].get("extras", {})


def test_hooks_work_when_the_addon_is_registered_but_not_in_preferences(light_scene, captured, addon):
    """Scripts may call register() without enabling the add-on in Preferences; the exporter only
    looks at `preferences.addons`, so the add-on lists itself during its own export."""
    addons = bpy.context.preferences.addons
    addons.remove(addons[addon.__name__])
    try:
        (gltf,) = captured()
        assert addon.__name__ not in addons  # listed only for the duration of the export
    finally:
        addons.new().module = addon.__name__
    assert "CAUSTIC_lights_area" in node_by_name(gltf, "AreaDisk")["extensions"]
    assert "caustic" in gltf["scenes"][0]["extras"]


def _principled(name):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:  # Blender < 5.0 creates materials without nodes
        mat.use_nodes = True
    return mat, mat.node_tree.nodes["Principled BSDF"], mat.node_tree.nodes["Material Output"]


def _volume_only(name, node_type):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:  # Blender < 5.0 creates materials without nodes
        mat.use_nodes = True
    tree = mat.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    node = tree.nodes.new(node_type)
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Volume"])
    return mat, node


def test_subsurface_and_volume_materials(empty_scene, captured, addon):
    scene = empty_scene
    scenes.small_render_settings(scene, 16, 12, samples=2)
    scenes.camera(scene, (0, -6, 3), (60, 0, 0))
    skin, bsdf, _ = _principled("Skin")
    bsdf.inputs["Base Color"].default_value = (0.8, 0.5, 0.4, 1.0)
    bsdf.inputs["Subsurface Weight"].default_value = 0.7
    bsdf.inputs["Subsurface Radius"].default_value = (1.0, 0.5, 0.25)
    bsdf.inputs["Subsurface Scale"].default_value = 0.1
    bsdf.inputs["Subsurface Anisotropy"].default_value = 0.2
    bsdf.subsurface_method = "RANDOM_WALK_SKIN"
    next(i for i in bsdf.inputs if i.name == "Subsurface IOR").default_value = 1.35
    scenes.cube(scene, "SkinCube", 1.0, (-3, 0, 0), material=skin)

    smoke, pv = _volume_only("Smoke", "ShaderNodeVolumePrincipled")
    pv.inputs["Color"].default_value = (0.8, 0.4, 0.2, 1.0)
    pv.inputs["Density"].default_value = 3.0
    pv.inputs["Absorption Color"].default_value = (0.25, 0.25, 0.25, 1.0)
    pv.inputs["Anisotropy"].default_value = 0.3
    pv.inputs["Emission Strength"].default_value = 2.0
    pv.inputs["Emission Color"].default_value = (1.0, 0.5, 0.0, 1.0)
    scenes.cube(scene, "SmokeCube", 1.0, (-1, 0, 0), material=smoke)

    fog, scatter = _volume_only("Fog", "ShaderNodeVolumeScatter")
    scatter.inputs["Color"].default_value = (0.9, 0.9, 1.0, 1.0)
    scatter.inputs["Density"].default_value = 0.5
    scatter.inputs["Anisotropy"].default_value = -0.2
    # Fog behind glass: a surface and a volume.
    glass = fog.node_tree.nodes.new("ShaderNodeBsdfGlass")
    fog.node_tree.links.new(glass.outputs[0], fog.node_tree.nodes["Material Output"].inputs["Surface"])
    scenes.cube(scene, "FogCube", 1.0, (1, 0, 0), material=fog)

    ink, absorb = _volume_only("Ink", "ShaderNodeVolumeAbsorption")
    absorb.inputs["Color"].default_value = (0.2, 0.6, 1.0, 1.0)
    absorb.inputs["Density"].default_value = 4.0
    scenes.cube(scene, "InkCube", 1.0, (3, 0, 0), material=ink)

    (gltf,) = captured()
    mats = {m["name"]: m.get("extensions", {}) for m in gltf["materials"]}
    s = mats["Skin"]["CAUSTIC_materials_subsurface"]
    assert s["weight"] == pytest.approx(0.7)
    assert s["radius"] == pytest.approx([0.1, 0.05, 0.025])
    assert s["anisotropy"] == pytest.approx(0.2)
    assert s["ior"] == pytest.approx(1.35)
    assert s["method"] == "random_walk_skin"
    m = mats["Smoke"]["CAUSTIC_materials_medium"]
    assert m["surface"] is False
    assert m["density"] == pytest.approx(3.0)
    assert m["scatter_color"] == pytest.approx([0.8, 0.4, 0.2])
    # Cycles: σa = density × max(1 - colour, 0) × max(1 - √absorption colour, 0).
    assert m["absorption_color"] == pytest.approx([0.2 * 0.5, 0.6 * 0.5, 0.8 * 0.5])
    assert m["anisotropy"] == pytest.approx(0.3)
    assert m["emission"] == pytest.approx([2.0, 1.0, 0.0])
    f = mats["Fog"]["CAUSTIC_materials_medium"]
    assert f["surface"] is True and f["density"] == pytest.approx(0.5)
    assert f["scatter_color"] == pytest.approx([0.9, 0.9, 1.0]) and f["absorption_color"] == [0.0, 0.0, 0.0]
    assert f["anisotropy"] == pytest.approx(-0.2)
    i = mats["Ink"]["CAUSTIC_materials_medium"]
    assert i["scatter_color"] == [0.0, 0.0, 0.0]
    assert i["absorption_color"] == pytest.approx([0.8, 0.4, 0.0])
    assert "CAUSTIC_materials_medium" in gltf["extensionsUsed"]
    assert "CAUSTIC_materials_subsurface" in gltf["extensionsUsed"]


def test_unsupported_volume_node_is_named(empty_scene, addon, tmp_path):
    import importlib
    export = importlib.import_module(addon.__name__ + ".export")
    node_images = importlib.import_module(addon.__name__ + ".export.node_images")
    mat, node = _volume_only("Diffuse", "ShaderNodeBsdfDiffuse")
    value, warnings = export.medium_extension(mat)
    assert value is None
    assert any("Diffuse" in w and node.name in w for w in warnings), warnings
    # A texture on the Density: the graph is exported (test_textured_volume.py renders it).
    smoke, pv = _volume_only("Textured", "ShaderNodeVolumePrincipled")
    noise = smoke.node_tree.nodes.new("ShaderNodeTexNoise")
    smoke.node_tree.links.new(noise.outputs[0], pv.inputs["Density"])
    value, warnings = export.medium_extension(smoke)
    assert value is not None and "graph" in value and warnings == [], warnings
    # An image: written by the export's image writer into the graph's images (the renderer
    # reads it per point, test_textured_volume.py); without a writer (the viewport's
    # comparison of a material's extras) named, and the constant medium is written.
    imaged, pv = _volume_only("Imaged", "ShaderNodeVolumePrincipled")
    image = imaged.node_tree.nodes.new("ShaderNodeTexImage")
    image.image = bpy.data.images.new("Puff", 4, 4)
    imaged.node_tree.links.new(image.outputs["Alpha"], pv.inputs["Density"])
    value, warnings = export.medium_extension(imaged, node_images.ImageWriter(str(tmp_path)))
    assert warnings == [], warnings
    assert len(value["graph"]["images"]) == 1
    (tex,) = [n for n in value["graph"]["nodes"] if n["type"] == "ShaderNodeTexImage"]
    assert tex["props"]["image"] == 0
    assert (tmp_path / value["graph"]["images"][0]["uri"]).is_file()
    value, warnings = export.medium_extension(imaged)
    assert value is not None and "graph" not in value
    assert any("Imaged" in w and "Image Texture" in w for w in warnings), warnings
    # A chain of Value and Math nodes folds to its constant, as Cycles folds it: no warning.
    folded, pv = _volume_only("Folded", "ShaderNodeVolumePrincipled")
    tree = folded.node_tree
    number = tree.nodes.new("ShaderNodeValue")
    number.outputs[0].default_value = 3.0
    times = tree.nodes.new("ShaderNodeMath")
    times.operation = "MULTIPLY"
    times.inputs[1].default_value = 0.25
    tree.links.new(number.outputs[0], times.inputs[0])
    power = tree.nodes.new("ShaderNodeMath")
    power.operation = "POWER"
    power.inputs[1].default_value = 2.0
    tree.links.new(times.outputs[0], power.inputs[0])
    tree.links.new(power.outputs[0], pv.inputs["Density"])
    value, warnings = export.medium_extension(folded)
    assert value["density"] == pytest.approx(0.5625)
    assert not warnings, warnings
    # A divide by zero folds to Cycles' safe 0; a clamped result stays in [0, 1].
    times.operation = "DIVIDE"
    times.inputs[1].default_value = 0.0
    assert export.medium_extension(folded)[0]["density"] == 0.0
    times.operation = "ADD"
    power.use_clamp = True
    assert export.medium_extension(folded)[0]["density"] == 1.0


def test_shader_nodes_become_gltf_materials(empty_scene, captured, addon):
    """Blender's exporter writes no pbrMetallicRoughness for Diffuse/Glossy/Glass/Mix surfaces (glTF
    then reads a white rough metal); the add-on writes what Cycles renders, or warns and writes
    a grey diffuse."""
    import importlib
    export = importlib.import_module(addon.__name__ + ".export")
    scene = empty_scene
    scenes.small_render_settings(scene, 16, 12, samples=2)
    scenes.camera(scene, (0, -6, 3), (60, 0, 0))
    made = {}
    for i, (name, kind, inputs) in enumerate([
        ("Dif", "ShaderNodeBsdfDiffuse", {"Color": (0.7, 0.3, 0.2, 1)}),
        ("Glo", "ShaderNodeBsdfAnisotropic", {"Color": (0.9, 0.6, 0.3, 1), "Roughness": 0.25}),
        ("Gla", "ShaderNodeBsdfGlass", {"IOR": 1.33, "Roughness": 0.1}),
        ("Mix", "ShaderNodeMixShader", {}),
    ]):
        mat = scenes.shader_node_material(name, kind, **inputs)
        made[name] = mat
        scenes.cube(scene, name + "Cube", 0.5, (i - 1.5, 0, 0), material=mat)
    # A Mix Shader of a Diffuse and a Glossy BSDF renders as its Diffuse, with a warning.
    mixed = scenes.shader_node_material("DifGlo", "ShaderNodeMixShader")
    tree = mixed.node_tree
    mix = next(n for n in tree.nodes if n.type == "MIX_SHADER")
    dif, glo = tree.nodes.new("ShaderNodeBsdfDiffuse"), tree.nodes.new("ShaderNodeBsdfAnisotropic")
    dif.inputs["Color"].default_value = (0.1, 0.6, 0.2, 1)
    tree.links.new(dif.outputs[0], mix.inputs[1])
    tree.links.new(glo.outputs[0], mix.inputs[2])
    scenes.cube(scene, "DifGloCube", 0.5, (3, 0, 0), material=mixed)
    gltf = captured()[0]
    mats = {m["name"]: m for m in gltf["materials"]}
    pbr = {k: m["pbrMetallicRoughness"] for k, m in mats.items()}
    assert pbr["Dif"]["metallicFactor"] == 0 and mats["Dif"]["extensions"]["KHR_materials_specular"] == {
        "specularFactor": 0.0}
    assert pbr["Dif"]["baseColorFactor"][:3] == pytest.approx([0.7, 0.3, 0.2])
    assert pbr["Glo"]["metallicFactor"] == 1 and pbr["Glo"]["roughnessFactor"] == pytest.approx(0.25)
    assert mats["Gla"]["extensions"]["KHR_materials_transmission"]["transmissionFactor"] == 1.0
    assert mats["Gla"]["extensions"]["KHR_materials_ior"]["ior"] == pytest.approx(1.33)
    assert "KHR_materials_volume" in mats["Gla"]["extensions"]  # a solid, as Cycles refracts
    assert pbr["Mix"]["baseColorFactor"][:3] == pytest.approx([0.8, 0.8, 0.8])
    _, _, warnings = export.shader_node_material(made["Mix"])
    assert any("Mix" in w and "Mix Shader" in w for w in warnings), warnings
    assert mats["DifGlo"]["pbrMetallicRoughness"]["baseColorFactor"][:3] == pytest.approx([0.1, 0.6, 0.2])
    _, _, warnings = export.shader_node_material(mixed)
    assert any("DifGlo" in w and "Diffuse BSDF at full weight" in w for w in warnings), warnings


def test_procedural_texture_on_a_principled_input_is_named(empty_scene, addon):
    """The exporter drops procedural textures silently; the add-on names the input and node."""
    import importlib
    export = importlib.import_module(addon.__name__ + ".export")
    mat, bsdf, _ = _principled("Marble")
    tree = mat.node_tree
    noise = tree.nodes.new("ShaderNodeTexNoise")
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    tree.links.new(noise.outputs[0], ramp.inputs[0])
    tree.links.new(ramp.outputs[0], bsdf.inputs["Base Color"])
    _, warnings = export.principled_extras(mat)
    assert any("Marble" in w and "Base Color" in w and "Noise Texture" in w for w in warnings), warnings
    image_mat, image_bsdf, _ = _principled("Photo")
    tex = image_mat.node_tree.nodes.new("ShaderNodeTexImage")
    image_mat.node_tree.links.new(tex.outputs[0], image_bsdf.inputs["Base Color"])
    _, warnings = export.principled_extras(image_mat)
    assert not any("cannot carry" in w for w in warnings), warnings


def test_principled_inside_a_node_group_is_left_to_the_exporter(empty_scene, captured):
    """The exporter finds a Principled BSDF inside a node group; the add-on must not replace it."""
    scene = empty_scene
    scenes.small_render_settings(scene, 16, 12, samples=2)
    scenes.camera(scene, (0, -6, 3), (60, 0, 0))
    mat = scenes.shader_node_material("Grouped", "ShaderNodeMixShader")
    tree = mat.node_tree
    tree.nodes.remove(next(n for n in tree.nodes if n.type == "MIX_SHADER"))
    group = bpy.data.node_groups.new("WrappedPrincipled", "ShaderNodeTree")
    group.interface.new_socket("BSDF", in_out="OUTPUT", socket_type="NodeSocketShader")
    inner = group.nodes.new("ShaderNodeBsdfPrincipled")
    inner.inputs["Base Color"].default_value = (0.1, 0.7, 0.2, 1)
    group.links.new(inner.outputs[0], group.nodes.new("NodeGroupOutput").inputs[0])
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    scenes.cube(scene, "GroupedCube", 0.5, (0, 0, 0), material=mat)
    gltf = captured()[0]
    pbr = next(m for m in gltf["materials"] if m["name"] == "Grouped")["pbrMetallicRoughness"]
    assert pbr["baseColorFactor"][:3] == pytest.approx([0.1, 0.7, 0.2])


def test_unrendered_features_are_named(addon, empty_scene, tmp_path):
    """Scene features Caustic does not render yet are each named in a warning (issue 20):
    a volume object without a .vdb file; an ordinary object gets none, nor does a point cloud
    (rendered since CAUSTIC_points, test_points.py), nor do
    a light's ray visibility beyond Camera (exported: light_ray_visibility, rendered since
    test_light_visibility.py), an object's ray visibility, Holdout, Indirect Only
    collection and Shadow Catcher (exported, test_object_ray_visibility_is_exported), nor hair
    (rendered since CAUSTIC_curves, test_hair.py), nor motion blur (exported, test_motion_blur.py)."""
    unsupported = importlib.import_module(addon.__name__ + ".export.unsupported")
    scene = empty_scene
    scene.render.use_motion_blur = True
    plain = scenes.cube(scene, "Plain", 1.0, (0, 0, 0))
    held = scenes.cube(scene, "Held", 1.0, (2, 0, 0))
    held.is_holdout = True
    catcher = scenes.cube(scene, "Catcher", 1.0, (4, 0, 0))
    catcher.is_shadow_catcher = True
    shy = scenes.cube(scene, "Shy", 1.0, (6, 0, 0))
    shy.visible_shadow = False
    shy_light = scenes.light(scene, "ShyLight", "POINT", energy=1.0)
    shy_light.visible_diffuse = False
    linked = scenes.cube(scene, "Linked", 1.0, (8, 0, 0))
    linked.light_linking.receiver_collection = bpy.data.collections.new("Receivers")
    linked.light_linking.blocker_collection = bpy.data.collections.new("Blockers")
    furry = scenes.cube(scene, "Furry", 1.0, (10, 0, 0))
    furry.modifiers.new("Hair", "PARTICLE_SYSTEM").particle_system.settings.type = "HAIR"
    fog = bpy.data.objects.new("Smoke", bpy.data.volumes.new("SmokeData"))
    scene.collection.objects.link(fog)
    held_coll = bpy.data.collections.new("HeldCollection")
    scene.collection.children.link(held_coll)
    bpy.context.view_layer.layer_collection.children["HeldCollection"].holdout = True
    indirect_coll = bpy.data.collections.new("IndirectCollection")
    scene.collection.children.link(indirect_coll)
    bpy.context.view_layer.layer_collection.children["IndirectCollection"].indirect_only = True

    warnings = unsupported.scene_warnings(bpy.context.evaluated_depsgraph_get())
    text = "\n".join(warnings)
    assert not any("Working Space" in line for line in warnings), text
    # Blender 5.0's working space other than Rec.709 is exported and followed, a Principled
    # Volume's blackbody included (rendered in the working space since the seventh session:
    # test_working_space_agreement.py volume_blackbody), so nothing is named.
    bpy.ops.wm.set_working_color_space(working_space="ACEScg", convert_colors=False)
    try:
        spaced = unsupported.scene_warnings(bpy.context.evaluated_depsgraph_get())
        assert not any("Working Space" in line for line in spaced), spaced
        fire = bpy.data.materials.new("Fire")
        fire.use_nodes = True
        volume = fire.node_tree.nodes.new("ShaderNodeVolumePrincipled")
        volume.inputs["Blackbody Intensity"].default_value = 1.0
        scenes.cube(scene, "Flame", 1.0, (14, 0, 0), material=fire)
        spaced = unsupported.scene_warnings(bpy.context.evaluated_depsgraph_get())
        assert not any("Working Space" in line for line in spaced), spaced
    finally:
        bpy.ops.wm.set_working_color_space(working_space="Linear Rec.709", convert_colors=False)
    assert not any("motion blur" in line for line in warnings), text
    assert not any("ShyLight" in line for line in warnings), text
    lights = importlib.import_module(addon.__name__ + ".export.lights")
    assert lights.light_ray_visibility(shy_light) == {"diffuse_visible": False}
    # Shape keys on a mesh without modifiers are exported deformed (export/shape_keys.py,
    # tests/blender/test_shape_keys.py): no longer named.
    squashed = scenes.cube(scene, "Squashed", 1.0, (12, 0, 0))
    squashed.shape_key_add(name="Basis")
    squashed.shape_key_add(name="Squash").data[0].co.z -= 0.5
    squashed.data.shape_keys.key_blocks["Squash"].value = 1.0
    warnings = unsupported.scene_warnings(bpy.context.evaluated_depsgraph_get())
    assert not any("shape keys" in line for line in warnings), warnings
    # A light's and the world's Cycles Max Bounces are exported (`max_bounces`, rendered since
    # test_max_bounces.py), not named; the default, 1024, limits nothing and is not written.
    bounded = scenes.light(scene, "Bounded", "POINT", location=(0, 0, 5), energy=10.0)
    assert "max_bounces" not in (lights.punctual_light_extension(bounded) or {})
    bounded.data.cycles.max_bounces = 2
    assert lights.punctual_light_extension(bounded)["max_bounces"] == 2
    assert unsupported.object_warnings(bounded) == []
    scene.world = bpy.data.worlds.new("Bounded sky")
    scene.world.cycles.max_bounces = 3
    world_warnings = unsupported.scene_warnings(bpy.context.evaluated_depsgraph_get())
    assert not any("Max Bounces" in line for line in world_warnings), world_warnings
    world = importlib.import_module(addon.__name__ + ".export.world")
    assert world.world_extension(scene, str(tmp_path))[0]["max_bounces"] == 3
    # Point clouds render (export/points.py, tests/blender/test_points.py): no longer named here;
    # what of them is not rendered is named by points.py.
    dots = bpy.data.objects.new("Dots", bpy.data.pointclouds.new("DotsData"))
    assert unsupported.object_warnings(dots) == []
    # Volume objects render (export/volumes.py); one without a .vdb file is named there.
    volumes = importlib.import_module(addon.__name__ + ".export.volumes")
    value, volume_warnings = volumes.volume_extension(bpy.context.evaluated_depsgraph_get(), str(tmp_path))
    assert value is None
    assert any("'Smoke'" in line and ".vdb" in line for line in volume_warnings), volume_warnings
    assert not any("'Plain'" in line for line in warnings), text
    assert not any("'Furry'" in line for line in warnings), text
    assert unsupported.object_warnings(plain) == []
    assert unsupported.object_warnings(shy) == []
    assert unsupported.object_warnings(held) == []
    assert unsupported.object_warnings(catcher) == []
    assert unsupported.object_warnings(linked) == []
    assert not any("HeldCollection" in line or "IndirectCollection" in line for line in warnings), text
    # A light's Shadow Catcher flag (on by default in Blender 5.0) is exported, not warned about.
    assert shy_light.is_shadow_catcher
    assert not any("ShyLight" in line and "Catcher" in line for line in warnings), text


def test_opaque_principled_ior_is_written(empty_scene, captured):
    """An opaque Principled BSDF's IOR (not glTF's 1.5) reaches the file as KHR_materials_ior:
    Blender 5.0's exporter deletes the extension from a material without transmission, volume
    or specular after the add-on's material hook (`__check_ior`), and Caustic rendered such a
    material at 1.5 (`test_principled_ior_matches_cycles` in test_principled_ior_below_one.py); the add-on writes it
    back (materials.restore_opaque_iors). IOR 1.5 writes nothing, as glTF's default."""
    scene = empty_scene
    scenes.small_render_settings(scene, 16, 12, samples=2)
    scenes.camera(scene, (0, -6, 3), (60, 0, 0))
    for i, ior in enumerate((3.0, 1.33, 1.5)):
        mat = scenes.shader_node_material(f"Ior{ior}", "ShaderNodeBsdfPrincipled", IOR=ior)
        scenes.cube(scene, f"Cube{i}", 0.5, (i - 1.0, 0, 0), material=mat)
    gltf = captured()[0]
    mats = {m["name"]: m for m in gltf["materials"]}
    assert mats["Ior3.0"]["extensions"]["KHR_materials_ior"]["ior"] == pytest.approx(3.0)
    assert mats["Ior1.33"]["extensions"]["KHR_materials_ior"]["ior"] == pytest.approx(1.33)
    assert "KHR_materials_ior" not in mats["Ior1.5"].get("extensions", {})
    assert "KHR_materials_ior" in gltf["extensionsUsed"]
