"""Reference values of Blender's procedural texture nodes, computed by Blender itself.

Run with the project's real bpy (5.0.1):

    .venv/bin/python tests/data/make_texture_reference.py

Geometry nodes evaluate the same texture nodes as Cycles, on the CPU, with the same
algorithms (BLI_noise is a port of Cycles' svm/noise.h, voronoi.h, ...). The script builds a
point cloud of POINTS deterministic positions (negative and positive, a few near +-1e3, a few
on lattice points), a geometry-node tree that evaluates every texture node in several
settings with Vector = Position and W = the point attribute "w", stores each output as a named
attribute, evaluates the depsgraph and writes inputs and outputs to texture_reference.json.

Floats are stored as base64 little-endian f32 arrays, exactly the bits Blender computed, which
keeps the file small (< 1 MB). `tests/texture_reference.rs` reads it; it does not need bpy.
Each case names the node's Blender settings (properties and input socket values) as the
add-on exports them, so that the test also checks the mapping of Blender's enums.
"""

import base64
import json
import pathlib
import random

import bpy
import numpy as np

POINTS = 256
OUT = pathlib.Path(__file__).with_name("texture_reference.json")


def positions_and_w():
    """Deterministic sample points: most in [-3, 3], some far out, some on lattice points."""
    rng = random.Random(19)
    pts, ws = [], []
    for i in range(POINTS):
        if i < 200:
            p = [rng.uniform(-3.0, 3.0) for _ in range(3)]
            w = rng.uniform(-3.0, 3.0)
        elif i < 236:
            # Large coordinates: noise must stay well defined (Cycles' fmod precision fix).
            p = [rng.choice((-1.0, 1.0)) * rng.uniform(500.0, 1500.0) for _ in range(3)]
            w = rng.choice((-1.0, 1.0)) * rng.uniform(500.0, 1500.0)
        else:
            # Lattice points and halves, negative included: floor() of exact integers.
            p = [rng.randint(-6, 6) * 0.5 for _ in range(3)]
            w = rng.randint(-6, 6) * 0.5
        pts.append(p)
        ws.append(w)
    return pts, ws


def cases():
    """Every texture in several settings: (texture, node type, properties, socket values,
    outputs with their data type)."""
    out = []
    dims = ["1D", "2D", "3D", "4D"]
    vec = "FLOAT_VECTOR"

    for d in dims:
        out.append(("white_noise", "ShaderNodeTexWhiteNoise", {"noise_dimensions": d}, {},
                    [("Value", "FLOAT"), ("Color", vec)]))

    noise_variants = [
        # A fractional detail exercises the last partial octave; normalize on.
        dict(Scale=1.7, Detail=2.5, Roughness=0.6, Lacunarity=2.1, Offset=0.8, Gain=1.3,
             Distortion=0.0),
        # An integer detail, distortion on, normalize off.
        dict(Scale=3.3, Detail=5.0, Roughness=0.45, Lacunarity=1.9, Offset=1.1, Gain=0.9,
             Distortion=0.7),
    ]
    for d in dims:
        for kind in ["MULTIFRACTAL", "RIDGED_MULTIFRACTAL", "HYBRID_MULTIFRACTAL", "FBM",
                     "HETERO_TERRAIN"]:
            for v, sockets in enumerate(noise_variants):
                props = {"noise_dimensions": d, "noise_type": kind, "normalize": v == 0}
                out.append(("noise", "ShaderNodeTexNoise", props, sockets,
                            [("Fac", "FLOAT"), ("Color", vec)]))

    # Details cycle so that every metric meets a plain (0), a fractional and an integer
    # fractal voronoi; normalize alternates.
    details = [0.0, 1.5, 2.0, 0.7]
    for d in dims:
        metrics = ["EUCLIDEAN"] if d == "1D" else ["EUCLIDEAN", "MANHATTAN", "CHEBYCHEV",
                                                    "MINKOWSKI"]
        for feature in ["F1", "F2", "SMOOTH_F1"]:
            for m, metric in enumerate(metrics):
                props = {"voronoi_dimensions": d, "feature": feature, "distance": metric,
                         "normalize": m % 2 == 1}
                sockets = dict(Scale=2.3, Detail=details[m], Roughness=0.55, Lacunarity=2.2,
                               Smoothness=0.8, Exponent=1.3, Randomness=0.85)
                out.append(("voronoi", "ShaderNodeTexVoronoi", props, sockets,
                            [("Distance", "FLOAT"), ("Color", vec), ("Position", vec),
                             ("W", "FLOAT")]))
        props = {"voronoi_dimensions": d, "feature": "DISTANCE_TO_EDGE", "distance": "EUCLIDEAN",
                 "normalize": True}
        sockets = dict(Scale=2.3, Detail=1.5, Roughness=0.55, Lacunarity=2.2, Randomness=0.85)
        out.append(("voronoi", "ShaderNodeTexVoronoi", props, sockets, [("Distance", "FLOAT")]))
        props = {"voronoi_dimensions": d, "feature": "N_SPHERE_RADIUS", "distance": "EUCLIDEAN",
                 "normalize": False}
        sockets = dict(Scale=2.3, Randomness=0.85)
        out.append(("voronoi", "ShaderNodeTexVoronoi", props, sockets, [("Radius", "FLOAT")]))

    for scale in (1.0, 3.7):
        sockets = {"Color1": (0.9, 0.2, 0.1, 1.0), "Color2": (0.05, 0.3, 0.8, 1.0),
                   "Scale": scale}
        out.append(("checker", "ShaderNodeTexChecker", {}, sockets,
                    [("Color", vec), ("Fac", "FLOAT")]))

    for kind in ["LINEAR", "QUADRATIC", "EASING", "DIAGONAL", "SPHERICAL", "QUADRATIC_SPHERE",
                 "RADIAL"]:
        out.append(("gradient", "ShaderNodeTexGradient", {"gradient_type": kind}, {},
                    [("Fac", "FLOAT")]))

    # Magic is not here: geometry nodes compute a different function (see cycles_cases).

    for kind, directions in [("BANDS", ["X", "Y", "Z", "DIAGONAL"]),
                             ("RINGS", ["X", "Y", "Z", "SPHERICAL"])]:
        for i, direction in enumerate(directions):
            for j, profile in enumerate(["SIN", "SAW", "TRI"]):
                props = {"wave_type": kind, "wave_profile": profile}
                props["bands_direction" if kind == "BANDS" else "rings_direction"] = direction
                distorted = (i + j) % 2 == 0
                sockets = {"Scale": 1.3, "Distortion": 2.0 if distorted else 0.0,
                           "Detail": 2.5, "Detail Scale": 1.3, "Detail Roughness": 0.6,
                           "Phase Offset": 0.4}
                out.append(("wave", "ShaderNodeTexWave", props, sockets, [("Fac", "FLOAT")]))

    bricks = [
        ({"offset": 0.5, "offset_frequency": 2, "squash": 1.0, "squash_frequency": 2},
         {"Scale": 5.0, "Mortar Size": 0.02, "Mortar Smooth": 0.1, "Bias": 0.0,
          "Brick Width": 0.5, "Row Height": 0.25}),
        ({"offset": 0.3, "offset_frequency": 3, "squash": 0.6, "squash_frequency": 2},
         {"Scale": 2.2, "Mortar Size": 0.05, "Mortar Smooth": 0.0, "Bias": 0.2,
          "Brick Width": 0.7, "Row Height": 0.3}),
        ({"offset": 0.7, "offset_frequency": 1, "squash": 1.5, "squash_frequency": 3},
         {"Scale": 1.1, "Mortar Size": 0.08, "Mortar Smooth": 0.6, "Bias": -0.3,
          "Brick Width": 0.4, "Row Height": 0.2}),
    ]
    for props, sockets in bricks:
        sockets = dict(sockets, Color1=(0.8, 0.8, 0.8, 1.0), Color2=(0.2, 0.2, 0.2, 1.0),
                       Mortar=(0.0, 0.1, 0.3, 1.0))
        out.append(("brick", "ShaderNodeTexBrick", props, sockets,
                    [("Color", vec), ("Fac", "FLOAT")]))

    # Gabor: both kinds, anisotropic (the given orientation), partly and fully isotropic
    # (random orientations), a frequency below 1 and a clamped anisotropy above 1.
    gabors = [
        ("2D", {"Scale": 1.3, "Frequency": 2.2, "Anisotropy": 1.0, "Orientation 2D": 0.6}),
        ("2D", {"Scale": 2.1, "Frequency": 0.7, "Anisotropy": 0.3, "Orientation 2D": -1.1}),
        ("3D", {"Scale": 1.1, "Frequency": 1.9, "Anisotropy": 1.4, "Orientation 3D": (0.3, 0.5, 0.8)}),
        ("3D", {"Scale": 0.9, "Frequency": 3.1, "Anisotropy": 0.45, "Orientation 3D": (-0.6, 0.2, 0.4)}),
        ("3D", {"Scale": 1.7, "Frequency": 1.2, "Anisotropy": 0.0, "Orientation 3D": (1.0, 0.0, 0.0)}),
    ]
    for kind, sockets in gabors:
        out.append(("gabor", "ShaderNodeTexGabor", {"gabor_type": kind}, sockets,
                    [("Value", "FLOAT"), ("Phase", "FLOAT"), ("Intensity", "FLOAT")]))

    # Radial Tiling (2-D: the position's x and y): whole sides (2, whose straight "polygon"
    # is not normalised, 3, 5) and fractional ones (an irregular last segment: 6.5, 2.3);
    # roundness 0 (sharp), between (bevels; on fractional sides the irregular corner's
    # circle) and 1 (circles); normalize on and off; sides and roundness outside their
    # ranges (clamped to 2 and [0, 1]).
    radial = [
        (5.0, 0.0, False), (5.0, 0.0, True), (3.0, 0.3, False), (3.0, 0.3, True),
        (5.0, 1.0, True), (6.0, 0.7, False), (2.0, 0.0, True), (2.0, 0.5, False),
        (6.5, 0.0, False), (6.5, 0.0, True), (6.5, 0.3, False), (6.5, 0.3, True),
        (6.5, 1.0, False), (2.3, 0.6, True), (3.7, 1.0, True), (1.0, 1.4, False),
        (4.0, -0.5, True),
    ]
    for sides, roundness, normalize in radial:
        out.append(("radial_tiling", "ShaderNodeRadialTiling", {"normalize": normalize},
                    {"Sides": sides, "Roundness": roundness},
                    [("Segment Coordinates", vec), ("Segment ID", "FLOAT"),
                     ("Segment Width", "FLOAT"), ("Segment Rotation", "FLOAT")]))
    return out


def cycles_cases():
    """Nodes evaluated by rendering with Cycles (see render_with_cycles).

    Magic, because its geometry-node implementation differs from Cycles': Cycles takes the
    unscaled vector modulo 2 pi before scaling (svm/magic.h), geometry nodes do not
    (node_shader_tex_magic.cc).
    """
    vec = "FLOAT_VECTOR"
    out = []
    for depth, distortion in [(0, 1.7), (1, 1.7), (2, 1.7), (5, 1.7), (10, 1.7), (3, 0.0)]:
        out.append(("magic", "ShaderNodeTexMagic", {"turbulence_depth": depth},
                    {"Scale": 4.1, "Distortion": distortion}, [("Color", vec), ("Fac", "FLOAT")]))

    # A cross-check of the geometry-node reference: one or two settings of every other node,
    # rendered by Cycles too.
    out.append(("white_noise", "ShaderNodeTexWhiteNoise", {"noise_dimensions": "4D"}, {},
                [("Value", "FLOAT"), ("Color", vec)]))
    noise = dict(Scale=1.7, Detail=2.5, Roughness=0.6, Lacunarity=2.1, Offset=0.8, Gain=1.3,
                 Distortion=0.7)
    for dims, kind in [("4D", "FBM"), ("3D", "RIDGED_MULTIFRACTAL"), ("1D", "MULTIFRACTAL")]:
        out.append(("noise", "ShaderNodeTexNoise",
                    {"noise_dimensions": dims, "noise_type": kind, "normalize": True}, noise,
                    [("Fac", "FLOAT"), ("Color", vec)]))
    voronoi = dict(Scale=2.3, Detail=1.5, Roughness=0.55, Lacunarity=2.2, Smoothness=0.8,
                   Exponent=1.3, Randomness=0.85)
    for dims, feature, metric, outputs in [
        ("3D", "F1", "EUCLIDEAN", [("Distance", "FLOAT"), ("Color", vec), ("Position", vec)]),
        ("4D", "SMOOTH_F1", "MINKOWSKI", [("Distance", "FLOAT"), ("Color", vec), ("W", "FLOAT")]),
        ("2D", "F2", "MANHATTAN", [("Distance", "FLOAT"), ("Color", vec)]),
        ("3D", "DISTANCE_TO_EDGE", "EUCLIDEAN", [("Distance", "FLOAT")]),
        ("4D", "N_SPHERE_RADIUS", "EUCLIDEAN", [("Radius", "FLOAT")]),
    ]:
        out.append(("voronoi", "ShaderNodeTexVoronoi",
                    {"voronoi_dimensions": dims, "feature": feature, "distance": metric,
                     "normalize": True}, voronoi, outputs))
    out.append(("checker", "ShaderNodeTexChecker", {},
                {"Color1": (0.9, 0.2, 0.1, 1.0), "Color2": (0.05, 0.3, 0.8, 1.0), "Scale": 3.7},
                [("Color", vec), ("Fac", "FLOAT")]))
    for kind in ["RADIAL", "EASING", "QUADRATIC_SPHERE"]:
        out.append(("gradient", "ShaderNodeTexGradient", {"gradient_type": kind}, {},
                    [("Fac", "FLOAT")]))
    wave = {"Scale": 1.3, "Distortion": 2.0, "Detail": 2.5, "Detail Scale": 1.3,
            "Detail Roughness": 0.6, "Phase Offset": 0.4}
    out.append(("wave", "ShaderNodeTexWave",
                {"wave_type": "RINGS", "rings_direction": "SPHERICAL", "wave_profile": "SAW"}, wave,
                [("Fac", "FLOAT")]))
    out.append(("wave", "ShaderNodeTexWave",
                {"wave_type": "BANDS", "bands_direction": "DIAGONAL", "wave_profile": "SIN"},
                wave, [("Fac", "FLOAT")]))
    out.append(("brick", "ShaderNodeTexBrick",
                {"offset": 0.3, "offset_frequency": 3, "squash": 0.6, "squash_frequency": 2},
                {"Scale": 2.2, "Mortar Size": 0.05, "Mortar Smooth": 0.3, "Bias": 0.2,
                 "Brick Width": 0.7, "Row Height": 0.3, "Color1": (0.8, 0.8, 0.8, 1.0),
                 "Color2": (0.2, 0.2, 0.2, 1.0), "Mortar": (0.0, 0.1, 0.3, 1.0)},
                [("Color", vec), ("Fac", "FLOAT")]))
    out.append(("gabor", "ShaderNodeTexGabor", {"gabor_type": "3D"},
                {"Scale": 0.9, "Frequency": 3.1, "Anisotropy": 0.45, "Orientation 3D": (-0.6, 0.2, 0.4)},
                [("Value", "FLOAT"), ("Phase", "FLOAT"), ("Intensity", "FLOAT")]))
    out.append(("gabor", "ShaderNodeTexGabor", {"gabor_type": "2D"},
                {"Scale": 2.1, "Frequency": 0.7, "Anisotropy": 0.3, "Orientation 2D": -1.1},
                [("Value", "FLOAT")]))
    out.append(("radial_tiling", "ShaderNodeRadialTiling", {"normalize": True},
                {"Sides": 6.5, "Roundness": 0.3},
                [("Segment Coordinates", vec), ("Segment ID", "FLOAT"), ("Segment Width", "FLOAT"),
                 ("Segment Rotation", "FLOAT")]))
    out.append(("radial_tiling", "ShaderNodeRadialTiling", {"normalize": False},
                {"Sides": 5.0, "Roundness": 0.0},
                [("Segment Coordinates", vec), ("Segment ID", "FLOAT")]))
    return out


def socket_by_name(sockets, name):
    """A socket by its UI name (the identifiers of some outputs differ, e.g. Fac)."""
    for s in sockets:
        if s.name == name or s.identifier == name:
            return s
    raise KeyError(name)


def b64(array):
    return base64.b64encode(np.asarray(array, dtype="<f4").tobytes()).decode("ascii")


def render_with_cycles(pts, ws, all_cases):
    """Evaluates shader nodes with Cycles itself: one quad per sample point, seen by one pixel
    of an orthographic camera, carrying the point and w as exact FACE attributes; the node's
    output drives an Emission shader (strength 1), rendered with 1 sample and a 0.01 box
    filter (the pixel centre), Standard view transform, no denoising, into a float EXR."""
    side = 16
    assert side * side == POINTS
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 1
    scene.cycles.use_denoising = False
    scene.cycles.pixel_filter_type = "BOX"
    scene.cycles.filter_width = 0.01
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.render.dither_intensity = 0.0
    scene.render.resolution_x = side
    scene.render.resolution_y = side
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"

    verts, faces = [], []
    for i in range(POINTS):
        x, y = i % side, i // side
        base = len(verts)
        verts += [(x, y, 0.0), (x + 1, y, 0.0), (x + 1, y + 1, 0.0), (x, y + 1, 0.0)]
        faces.append((base, base + 1, base + 2, base + 3))
    mesh = bpy.data.meshes.new("pixels")
    mesh.from_pydata(verts, [], faces)
    p_attr = mesh.attributes.new("p", "FLOAT_VECTOR", "FACE")
    p_attr.data.foreach_set("vector", np.asarray(pts, dtype=np.float32).ravel())
    w_attr = mesh.attributes.new("w", "FLOAT", "FACE")
    w_attr.data.foreach_set("value", np.asarray(ws, dtype=np.float32))
    obj = bpy.data.objects.new("pixels", mesh)
    scene.collection.objects.link(obj)
    cam_data = bpy.data.cameras.new("camera")
    cam_data.type = "ORTHO"
    cam_data.ortho_scale = side
    camera = bpy.data.objects.new("camera", cam_data)
    camera.location = (side / 2, side / 2, 10.0)
    scene.collection.objects.link(camera)
    scene.camera = camera

    material = bpy.data.materials.new("texture")
    obj.data.materials.append(material)
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    p_node = nodes.new("ShaderNodeAttribute")
    p_node.attribute_name = "p"
    w_node = nodes.new("ShaderNodeAttribute")
    w_node.attribute_name = "w"
    emission = nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 1.0
    output = nodes.new("ShaderNodeOutputMaterial")
    links.new(emission.outputs[0], output.inputs["Surface"])

    import tempfile
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        for texture, node_type, props, sockets, outputs in all_cases:
            node = nodes.new(node_type)
            for key, value in props.items():
                setattr(node, key, value)
            for key, value in sockets.items():
                socket_by_name(node.inputs, key).default_value = value
            if "Vector" in node.inputs:
                links.new(p_node.outputs["Vector"], node.inputs["Vector"])
            if "W" in node.inputs:
                links.new(w_node.outputs["Fac"], node.inputs["W"])
            got = {}
            for name, data_type in outputs:
                links.new(socket_by_name(node.outputs, name), emission.inputs["Color"])
                scene.render.filepath = f"{tmp}/render.exr"
                bpy.ops.render.render(write_still=True)
                image = bpy.data.images.load(scene.render.filepath)
                pixels = np.asarray(image.pixels[:], dtype=np.float32).reshape(-1, 4)
                bpy.data.images.remove(image)
                width = 3 if data_type == "FLOAT_VECTOR" else 1
                got[name] = b64(pixels[:, :width].ravel())
            nodes.remove(node)
            results.append(got)
    return results


def main():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    pts, ws = positions_and_w()
    mesh = bpy.data.meshes.new("points")
    mesh.from_pydata(pts, [], [])
    w_attr = mesh.attributes.new("w", "FLOAT", "POINT")
    w_attr.data.foreach_set("value", np.asarray(ws, dtype=np.float32))
    obj = bpy.data.objects.new("points", mesh)
    bpy.context.scene.collection.objects.link(obj)

    tree = bpy.data.node_groups.new("textures", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = tree.nodes, tree.links
    group_in = nodes.new("NodeGroupInput")
    group_out = nodes.new("NodeGroupOutput")
    position = nodes.new("GeometryNodeInputPosition")
    w_in = nodes.new("GeometryNodeInputNamedAttribute")
    w_in.data_type = "FLOAT"
    w_in.inputs["Name"].default_value = "w"

    geometry = group_in.outputs[0]
    stored = []
    all_cases = cases()
    for index, (texture, node_type, props, sockets, outputs) in enumerate(all_cases):
        node = nodes.new(node_type)
        for key, value in props.items():
            setattr(node, key, value)
        for key, value in sockets.items():
            socket_by_name(node.inputs, key).default_value = value
        # Blender 5 lists only the sockets the settings use (no Vector in 1-D, no W in 3-D).
        if "Vector" in node.inputs:
            links.new(position.outputs["Position"], node.inputs["Vector"])
        if "W" in node.inputs:
            links.new(w_in.outputs["Attribute"], node.inputs["W"])
        for name, data_type in outputs:
            store = nodes.new("GeometryNodeStoreNamedAttribute")
            store.data_type = data_type
            store.domain = "POINT"
            attr = f"c{index}_{name}"
            store.inputs["Name"].default_value = attr
            links.new(geometry, store.inputs["Geometry"])
            links.new(socket_by_name(node.outputs, name), store.inputs["Value"])
            geometry = store.outputs["Geometry"]
            stored.append((index, name, attr, data_type))
    links.new(geometry, group_out.inputs[0])

    modifier = obj.modifiers.new("textures", "NODES")
    modifier.node_group = tree
    depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph).data

    count = len(evaluated.vertices)
    assert count == POINTS, count
    pos = np.empty(count * 3, dtype=np.float32)
    evaluated.attributes["position"].data.foreach_get("vector", pos)
    w = np.empty(count, dtype=np.float32)
    evaluated.attributes["w"].data.foreach_get("value", w)

    results = [{} for _ in all_cases]
    for index, name, attr, data_type in stored:
        width, field = (3, "vector") if data_type == "FLOAT_VECTOR" else (1, "value")
        values = np.empty(count * width, dtype=np.float32)
        evaluated.attributes[attr].data.foreach_get(field, values)
        results[index][name] = b64(values)

    doc = {
        "generator": "tests/data/make_texture_reference.py",
        "blender": bpy.app.version_string,
        "points": count,
        "position": b64(pos),
        "w": b64(w),
        "cases": [
            {
                "texture": texture,
                "properties": props,
                "inputs": {k: list(v) if isinstance(v, tuple) else v for k, v in sockets.items()},
                "outputs": results[index],
            }
            for index, (texture, _, props, sockets, _) in enumerate(all_cases)
        ],
    }
    # Nodes whose geometry-node version differs from Cycles: rendered with Cycles instead, at
    # the same points (as f32, exactly as the point cloud stored them).
    rendered_cases = cycles_cases()
    rendered = render_with_cycles(pos.reshape(-1, 3).tolist(), w.tolist(), rendered_cases)
    doc["cycles_cases"] = [
        {
            "texture": texture,
            "properties": props,
            "inputs": {k: list(v) if isinstance(v, tuple) else v for k, v in sockets.items()},
            "outputs": rendered[index],
        }
        for index, (texture, _, props, sockets, _) in enumerate(rendered_cases)
    ]
    OUT.write_text(json.dumps(doc, indent=0, sort_keys=True) + "\n")
    print(f"{OUT}: {len(all_cases)} cases, {count} points, {OUT.stat().st_size} bytes")


if __name__ == "__main__":
    main()
