"""Volume objects (OpenVDB grids: smoke, fire, clouds): the grids their shader reads are copied
from the .vdb into a Caustic grid file (`caustic_volumes/*.cvol`, little-endian, layout in
docs/contract.md) beside the glTF, and the object is named in the root `CAUSTIC_volume` with
its placement and its volume shader: the parameters of one Principled Volume (Volume Scatter,
Volume Absorption and Emission are written as the Principled Volume that renders the same), or,
for a shader tree or inputs linked through nodes, the Volume output's node graph, whose
Attribute nodes read the grids by name (the Principled Volume's attribute fields written as
Attribute and Math nodes).

The .vdb is read with the `openvdb` module that bpy bundles. Grids that exist only in memory
(made or changed by modifiers or geometry nodes) are first saved to a .vdb by Blender
(`VolumeGrids.save`). Non-linear (frustum) grid transforms cannot be placed; such grids are
ignored with a warning naming them."""

import math
import os
import re
import struct
import sys

import bpy

from .media import is_varying, scatter_phase, tree_medium
from .nodes import linked_node, material_output, socket, value as _value

VOLUME_EXTENSION = "CAUSTIC_volume"
FOLDER = "caustic_volumes"
MAGIC = b"CAUSTICV"
VERSION = 1
MAX_GRIDS = 16  # grids per file (src/medium/grid_file.rs)

# Blender (Z up) to glTF (Y up): (x, y, z) -> (x, z, -y), as the glTF exporter converts.
_TO_GLTF = ((1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0), (0.0, -1.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))


def _openvdb():
    """bpy's bundled openvdb module (its folder, in Blender's own Python tree, is not on sys.path
    in every Blender build)."""
    folder = os.path.join(bpy.utils.resource_path("LOCAL"), "python", "lib",
                          f"python{sys.version_info[0]}.{sys.version_info[1]}", "site-packages")
    if os.path.isdir(folder) and folder not in sys.path:
        sys.path.append(folder)
    import openvdb
    return openvdb


def _principled_defaults():
    """The Principled Volume's parameters as Blender's defaults set them."""
    return {"density": 1.0, "color": [0.5, 0.5, 0.5], "absorption_color": [0.0, 0.0, 0.0], "anisotropy": 0.0,
            "emission": [0.0, 0.0, 0.0], "blackbody_intensity": 0.0, "blackbody_tint": [1.0, 1.0, 1.0],
            "temperature": 1000.0}


def volume_shader(blender_material, what, warnings):
    """(shader parameters, {kind: attribute name}) of a volume object's material, or (None, None)
    when its Volume output carries nothing Caustic renders (warned)."""
    if blender_material is None:
        # Cycles gives a volume object without a material its default volume shader: a
        # Principled Volume reading the "density" grid.
        return _principled_defaults(), {"density": "density", "temperature": "temperature", "color": ""}
    tree = getattr(blender_material, "node_tree", None)
    output = material_output(tree) if tree is not None else None
    if output is None or not output.inputs["Volume"].is_linked:
        warnings.append(f"{what}: its material '{blender_material.name}' has nothing on the Volume output; "
                        "the volume is left out")
        return None, None
    node = linked_node(output.inputs["Volume"])
    mat_what = f"{what}, material '{blender_material.name}'"

    def rgb(name, default):
        return [float(c) for c in _value(node, name, mat_what, warnings, default)[:3]]

    def num(name, default):
        return float(_value(node, name, mat_what, warnings, default))

    shader = _principled_defaults()
    attributes = {"density": "", "temperature": "", "color": ""}
    if node.type == "PRINCIPLED_VOLUME":
        shader.update(density=num("Density", 1.0), color=rgb("Color", (0.5,) * 3),
                      absorption_color=rgb("Absorption Color", (0.0,) * 3), anisotropy=num("Anisotropy", 0.0),
                      blackbody_intensity=num("Blackbody Intensity", 0.0),
                      blackbody_tint=rgb("Blackbody Tint", (1.0,) * 3), temperature=num("Temperature", 1000.0))
        strength = num("Emission Strength", 0.0)
        shader["emission"] = [strength * c for c in rgb("Emission Color", (1.0,) * 3)]
        for kind, name in (("density", "Density Attribute"), ("temperature", "Temperature Attribute"),
                           ("color", "Color Attribute")):
            sock = socket(node, name)
            attributes[kind] = str(sock.default_value) if sock is not None else ""
    elif node.type == "VOLUME_SCATTER":
        # sigma_s = colour x density, no absorption: a Principled Volume whose absorption factor
        # (1 - sqrt(absorption colour)) is 0.
        shader.update(density=num("Density", 1.0), color=rgb("Color", (0.8,) * 3),
                      absorption_color=[1.0, 1.0, 1.0], anisotropy=num("Anisotropy", 0.0))
        shader.update(scatter_phase(node, mat_what, warnings))
    elif node.type == "VOLUME_ABSORPTION":
        # sigma_a = (1 - colour) x density: colour 0 and absorption colour c^2 give it.
        c = rgb("Color", (0.8,) * 3)
        shader.update(density=num("Density", 1.0), color=[0.0, 0.0, 0.0],
                      absorption_color=[max(x, 0.0) ** 2 for x in c])
    elif node.type == "EMISSION":
        shader.update(density=0.0, emission=[num("Strength", 1.0) * x for x in rgb("Color", (1.0,) * 3)])
    else:
        warnings.append(f"{mat_what}: the {node.name} node ({node.bl_label}) on the Volume output cannot be "
                        "rendered in a volume object; the volume is left out")
        return None, None
    shader["anisotropy"] = min(max(shader["anisotropy"], -1.0), 1.0)
    for key in ("color", "absorption_color", "emission", "blackbody_tint"):
        shader[key] = [max(x, 0.0) for x in shader[key]]
    shader["density"] = max(shader["density"], 0.0)
    return shader, attributes


def volume_graph(blender_material, what, warnings, writer):
    """(graph value, root index) of a volume object's material whose Volume output needs its
    node graph (a shader tree, or inputs linked through nodes: contract, `CAUSTIC_volume.graph`);
    None when `volume_shader` describes it; False when it is left out (warned)."""
    tree = getattr(blender_material, "node_tree", None) if blender_material is not None else None
    output = material_output(tree) if tree is not None else None
    if output is None or not output.inputs["Volume"].is_linked:
        return None
    node = linked_node(output.inputs["Volume"])
    if not is_varying(node):
        return None
    value = tree_medium(blender_material, node, f"{what}, material '{blender_material.name}'", warnings, writer)
    if value is None:
        return False
    return value["graph"], value["graph_shader"]


def graph_grid_names(graph):
    """The grid names a volume graph reads: its Attribute nodes' (Geometry type) and its
    Principled Volumes' Density, Color and Temperature Attribute fields."""
    names = []
    for entry in graph["nodes"]:
        if entry["type"] == "ShaderNodeAttribute" and entry["props"].get("attribute_type", "GEOMETRY") == "GEOMETRY":
            names.append(entry["props"].get("attribute_name", ""))
        if entry["type"] == "ShaderNodeVolumePrincipled":
            names.extend(entry["inputs"].get(f, {}).get("value", "") for f, _ in _ATTRIBUTE_FIELDS)
    return [n for n in dict.fromkeys(names) if isinstance(n, str) and n]


# The Principled Volume's attribute fields and the input each multiplies.
_ATTRIBUTE_FIELDS = (("Density Attribute", "Density"), ("Color Attribute", "Color"),
                     ("Temperature Attribute", "Temperature"))


def apply_attribute_fields(graph, present):
    """Cycles' Principled Volume multiplies its Density, Color and Temperature (the last by the
    grid's value clamped at 0) by the grids its attribute fields name, where the object has them
    (`svm_node_principled_volume`); a name the object lacks changes nothing. Written into
    `graph` as Attribute and Math nodes in front of those inputs; `present` holds the names of
    the object's grids."""
    nodes = graph["nodes"]

    def add(entry):
        nodes.append(entry)
        return len(nodes) - 1

    for entry in list(nodes):
        if entry["type"] != "ShaderNodeVolumePrincipled":
            continue
        for field, target in _ATTRIBUTE_FIELDS:
            name = entry["inputs"].pop(field, {}).get("value", "")
            if not isinstance(name, str) or name not in present:
                continue
            base = f"{entry['name']}/{field}"
            attr = add({"name": base, "type": "ShaderNodeAttribute", "inputs": {},
                        "props": {"attribute_name": name, "attribute_type": "GEOMETRY"}})
            item = dict(entry["inputs"].get(target, {}))
            if target == "Color":
                item["value"] = list(item.get("value", [0.5, 0.5, 0.5]))[:3]
                mul = add({"name": base + " x", "type": "ShaderNodeVectorMath", "props": {"operation": "MULTIPLY"},
                           "inputs": {"Vector": item, "Vector_001": {"value": [0.0] * 3, "link": [attr, "Color"]}}})
                entry["inputs"][target] = {"value": entry["inputs"].get(target, {}).get("value"), "link": [mul, "Vector"]}
                continue
            source = [attr, "Fac"]
            if target == "Temperature":
                source = [add({"name": base + " max 0", "type": "ShaderNodeMath", "props": {"operation": "MAXIMUM"},
                               "inputs": {"Value": {"value": 0.0, "link": source}, "Value_001": {"value": 0.0}}}),
                          "Value"]
            mul = add({"name": base + " x", "type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
                       "inputs": {"Value": item, "Value_001": {"value": 0.0, "link": source}}})
            entry["inputs"][target] = {"value": item.get("value", 0.0), "link": [mul, "Value"]}


def _matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def _same_transform(a, b):
    pts = ((0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1))
    return all(math.isclose(x, y, rel_tol=1e-6, abs_tol=1e-9)
               for p in pts for x, y in zip(a.indexToWorld(p), b.indexToWorld(p)))


def write_grid_file(path, grids):
    """Writes `grids` (openvdb grids sharing one linear transform) to a Caustic grid file over
    the union of their active voxels; returns nothing. Layout: docs/contract.md."""
    import numpy as np
    lo = [min(g.evalActiveVoxelBoundingBox()[0][a] for g in grids) for a in range(3)]
    hi = [max(g.evalActiveVoxelBoundingBox()[1][a] for g in grids) for a in range(3)]
    dims = [max(hi[a] - lo[a] + 1, 1) for a in range(3)]
    t = grids[0].transform
    origin = t.indexToWorld(tuple(lo))
    axes = [[t.indexToWorld(tuple(lo[b] + (1 if b == a else 0) for b in range(3)))[r] - origin[r]
             for a in range(3)] for r in range(3)]
    matrix = [axes[0][0], axes[0][1], axes[0][2], origin[0],
              axes[1][0], axes[1][1], axes[1][2], origin[1],
              axes[2][0], axes[2][1], axes[2][2], origin[2]]
    blocks = []
    with open(path, "wb") as f:
        f.write(MAGIC)
        f.write(struct.pack("<I3I", VERSION, *dims))
        f.write(struct.pack("<12f", *matrix))
        f.write(struct.pack("<I", len(grids)))
        for g in grids:
            vector = g.valueTypeName.startswith("vec3")
            name = g.name.encode("utf-8")
            f.write(struct.pack("<I", len(name)) + name + struct.pack("<I", 3 if vector else 1))
            shape = tuple(dims) + ((3,) if vector else ())
            arr = np.zeros(shape, dtype=np.float32 if not g.valueTypeName.endswith("d") else np.float64)
            g.copyToArray(arr, ijk=tuple(lo))
            # Caustic's order: x fastest, then y, then z (components interleaved).
            order = (2, 1, 0, 3) if vector else (2, 1, 0)
            blocks.append(np.ascontiguousarray(arr.transpose(order), dtype="<f4"))
        for b in blocks:
            f.write(b.tobytes())


def _safe_name(name, used):
    base = re.sub(r"[^A-Za-z0-9_.-]", "_", name) or "volume"
    candidate, i = base, 1
    while candidate in used:
        i += 1
        candidate = f"{base}_{i}"
    used.add(candidate)
    return candidate


def _grid_file(obj, volume, what, folder, warnings):
    """(path of a .vdb holding the object's evaluated grids, whether it is a copy to delete):
    the volume's own file where nothing changed its grids; else the grids Blender holds in
    memory (made or changed by modifiers or geometry nodes) saved by `VolumeGrids.save`. None
    (warned) when neither can be read."""
    filepath = volume.grids.frame_filepath if volume.filepath else ""
    filepath = bpy.path.abspath(filepath, library=volume.original.library) if filepath else ""
    modified = any(m.show_render for m in obj.original.modifiers) or obj.original.type != "VOLUME"
    if filepath and os.path.isfile(filepath) and not modified:
        return filepath, False
    grids = volume.grids
    try:
        loaded = grids.is_loaded or grids.load()
    except RuntimeError:
        loaded = False
    if not loaded or len(grids) == 0:
        warnings.append(f"{what}: it has no grids to read (no .vdb file, and Blender holds none in memory"
                        f"{': ' + grids.error_message if grids.error_message else ''}); the volume is left out")
        return None, False
    os.makedirs(os.path.join(folder, FOLDER), exist_ok=True)
    # Read and deleted before the next object's: one name serves them all.
    path = os.path.join(folder, FOLDER, "_saved_grids.vdb")
    try:
        saved = grids.save(filepath=path)
    except RuntimeError as err:
        saved, message = False, str(err)
    else:
        message = grids.error_message
    if not saved or not os.path.isfile(path):
        warnings.append(f"{what}: its grids could not be saved for Caustic ({message}); the volume is left out")
        return None, False
    return path, True


def _usable(grid, kind, chosen, what, warnings):
    """Whether `grid` can join `chosen` as `kind` (a scalar, or a colour for "color" and "any"),
    warning why not."""
    if grid.valueTypeName not in ("float", "double", "vec3s", "vec3d") or \
            (kind not in ("color", "any") and grid.valueTypeName.startswith("vec3")):
        warnings.append(f"{what}: grid '{grid.name}' ({grid.valueTypeName}) cannot be the {kind}; it is ignored")
        return False
    if not grid.transform.isLinear or (chosen and not _same_transform(grid.transform, chosen[0].transform)):
        warnings.append(f"{what}: grid '{grid.name}' has a transform Caustic cannot place with the others; "
                        "it is ignored")
        return False
    return True


def volume_extension(depsgraph, folder, writer=None):
    """The root `CAUSTIC_volume` value for the depsgraph's volume objects (None without any),
    writing their grid files into `folder`/caustic_volumes; and warnings. `writer` is the
    export's image writer: one writer names every image file, so that two images whose names
    clean to the same file name do not overwrite each other (a surface would read the other)."""
    from .node_images import ImageWriter
    warnings, volumes, used = [], [], set()
    writer = writer if writer is not None else ImageWriter(folder)
    for instance in depsgraph.object_instances:
        obj = instance.object
        if obj.type != "VOLUME":
            continue
        what = f"object '{obj.original.name}'"
        volume = obj.data
        material = next((m for m in volume.materials if m is not None), None)
        graph = volume_graph(material, what, warnings, writer)
        if graph is False:
            continue
        shader, attributes = (_principled_defaults(), {}) if graph else volume_shader(material, what, warnings)
        if shader is None:
            continue
        filepath, temporary = _grid_file(obj, volume, what, folder, warnings)
        if filepath is None:
            continue
        vdb = _openvdb()
        try:
            file_grids, _ = vdb.readAll(filepath)
        except Exception as err:  # the module raises its own types for unreadable files
            warnings.append(f"{what}: cannot read '{filepath}' ({err}); the volume is left out")
            continue
        finally:
            if temporary:
                os.remove(filepath)
        by_name = {g.name: g for g in file_grids}
        chosen, names, present = [], {}, set()
        wanted = [("any", n) for n in graph_grid_names(graph[0])] if graph else \
            [(kind, attributes.get(kind) or "") for kind in ("density", "temperature", "color")]
        for kind, name in wanted:
            grid = by_name.get(name) if name else None
            if grid is None or not _usable(grid, kind, chosen, what, warnings):
                continue
            names[kind] = name
            present.add(name)
            if grid.activeVoxelCount() > 0 and grid not in chosen:
                chosen.append(grid)
        if len(chosen) > MAX_GRIDS:
            # The grid file holds MAX_GRIDS grids (the most a graph reads, src/medium/grid_file.rs).
            dropped = ", ".join(f"'{g.name}'" for g in chosen[MAX_GRIDS:])
            warnings.append(f"{what}: its shader reads {len(chosen)} grids; Caustic holds {MAX_GRIDS}, so {dropped} "
                            "read 0")
            chosen = chosen[:MAX_GRIDS]
        if graph and not chosen:
            # A graph that reads no grid with voxels (constant shaders) fills the box of the
            # object's grids, as Cycles fills their active voxels.
            chosen = [g for g in file_grids if g.activeVoxelCount() > 0 and g.transform.isLinear
                      and g.valueTypeName in ("float", "double")][:1]
        if not chosen:
            read = ", ".join(n for _, n in wanted if n) or "none"
            warnings.append(f"{what}: none of the grids its shader reads ({read}) has active voxels in "
                            f"'{filepath}'; the volume is left out")
            continue
        os.makedirs(os.path.join(folder, FOLDER), exist_ok=True)
        uri = f"{FOLDER}/{_safe_name(obj.original.name, used)}.cvol"
        write_grid_file(os.path.join(folder, uri), chosen)
        world = _matmul([list(r) for r in _TO_GLTF], [list(r) for r in instance.matrix_world])
        entry = {
            "name": obj.original.name,
            "uri": uri,
            "matrix": [world[r][c] for c in range(4) for r in range(4)],
            "density_grid": None if graph else names.get("density"),
            "temperature_grid": None if graph else names.get("temperature"),
            "color_grid": None if graph else names.get("color"),
            "shader": shader,
        }
        if graph:
            # Grids named but without voxels still count as the object's (they read 0).
            apply_attribute_fields(graph[0], present)
            entry["graph"], entry["graph_shader"] = graph
        volumes.append(entry)
    return ({"volumes": volumes} if volumes else None), warnings


def attach_volumes(depsgraph, folder, gltf_path, writer=None):
    """Writes the volume objects' grid files and adds `CAUSTIC_volume` to the exported glTF at
    `gltf_path` (the exporter has no hook for a root extension of our own); returns warnings.
    `writer`: the export's image writer (`volume_extension`)."""
    import json
    value, warnings = volume_extension(depsgraph, folder, writer)
    if value is None:
        return warnings
    with open(gltf_path, encoding="utf-8") as f:
        gltf = json.load(f)
    gltf.setdefault("extensions", {})[VOLUME_EXTENSION] = value
    used = gltf.setdefault("extensionsUsed", [])
    if VOLUME_EXTENSION not in used:
        used.append(VOLUME_EXTENSION)
    with open(gltf_path, "w", encoding="utf-8") as f:
        json.dump(gltf, f)
    return warnings
