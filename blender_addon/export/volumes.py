"""Volume objects (OpenVDB grids: smoke, fire, clouds): the grids their shader reads are copied
from the .vdb into a Caustic grid file (`caustic_volumes/*.cvol`, little-endian, layout in
docs/contract.md) beside the glTF, and the object is named in the root `CAUSTIC_volume` with
its placement and its volume shader's parameters (Principled Volume; Volume Scatter, Volume
Absorption and Emission are written as the Principled Volume that renders the same).

The .vdb is read with the `openvdb` module that bpy bundles. Grids that exist only in memory
(made by modifiers or geometry nodes, with no file) and non-linear (frustum) grid transforms
cannot be read that way; such objects are left out with a warning naming them.
"""

import math
import os
import re
import struct
import sys

import bpy

from .media import scatter_phase
from .nodes import linked_node, material_output, socket, value as _value

VOLUME_EXTENSION = "CAUSTIC_volume"
FOLDER = "caustic_volumes"
MAGIC = b"CAUSTICV"
VERSION = 1

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


def volume_extension(depsgraph, folder):
    """The root `CAUSTIC_volume` value for the depsgraph's volume objects (None without any),
    writing their grid files into `folder`/caustic_volumes; and warnings."""
    warnings, volumes, used = [], [], set()
    for instance in depsgraph.object_instances:
        obj = instance.object
        if obj.type != "VOLUME":
            continue
        what = f"object '{obj.original.name}'"
        volume = obj.data
        material = next((m for m in volume.materials if m is not None), None)
        shader, attributes = volume_shader(material, what, warnings)
        if shader is None:
            continue
        filepath = volume.grids.frame_filepath if volume.filepath else ""
        filepath = bpy.path.abspath(filepath, library=volume.original.library) if filepath else ""
        if not filepath or not os.path.isfile(filepath):
            warnings.append(f"{what}: its grids have no .vdb file Caustic can read (made by modifiers or geometry "
                            "nodes, or the file is missing); the volume is left out")
            continue
        vdb = _openvdb()
        try:
            file_grids, _ = vdb.readAll(filepath)
        except Exception as err:  # the module raises its own types for unreadable files
            warnings.append(f"{what}: cannot read '{filepath}' ({err}); the volume is left out")
            continue
        by_name = {g.name: g for g in file_grids}
        chosen, names = [], {}
        for kind in ("density", "temperature", "color"):
            name = attributes.get(kind) or ""
            grid = by_name.get(name) if name else None
            if grid is None:
                continue
            if grid.valueTypeName not in ("float", "double", "vec3s", "vec3d") or \
                    (kind != "color" and grid.valueTypeName.startswith("vec3")):
                warnings.append(f"{what}: grid '{name}' ({grid.valueTypeName}) cannot be the {kind}; it is ignored")
                continue
            if not grid.transform.isLinear or (chosen and not _same_transform(grid.transform, chosen[0].transform)):
                warnings.append(f"{what}: grid '{name}' has a transform Caustic cannot place with the others; "
                                "it is ignored")
                continue
            if grid.activeVoxelCount() == 0:
                continue
            if grid not in chosen:
                chosen.append(grid)
            names[kind] = name
        if not chosen:
            warnings.append(f"{what}: none of the grids its shader reads ({', '.join(n for n in attributes.values() if n) or 'none'}) "
                            f"has active voxels in '{filepath}'; the volume is left out")
            continue
        os.makedirs(os.path.join(folder, FOLDER), exist_ok=True)
        uri = f"{FOLDER}/{_safe_name(obj.original.name, used)}.cvol"
        write_grid_file(os.path.join(folder, uri), chosen)
        world = _matmul([list(r) for r in _TO_GLTF], [list(r) for r in instance.matrix_world])
        volumes.append({
            "name": obj.original.name,
            "uri": uri,
            "matrix": [world[r][c] for c in range(4) for r in range(4)],
            "density_grid": names.get("density"),
            "temperature_grid": names.get("temperature"),
            "color_grid": names.get("color"),
            "shader": shader,
        })
        if any(m.show_render for m in obj.original.modifiers):
            warnings.append(f"{what}: its modifiers are not applied to the grids read from the .vdb file")
    return ({"volumes": volumes} if volumes else None), warnings


def attach_volumes(depsgraph, folder, gltf_path):
    """Writes the volume objects' grid files and adds `CAUSTIC_volume` to the exported glTF at
    `gltf_path` (the exporter has no hook for a root extension of our own); returns warnings."""
    import json
    value, warnings = volume_extension(depsgraph, folder)
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
