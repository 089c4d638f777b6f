"""Point clouds: `CAUSTIC_points` (docs/contract.md).

The glTF exporter writes no point cloud, so after it has run, `add_points` reads them from the
render depsgraph the way Cycles does (intern/cycles/blender/pointcloud.cpp) and appends them to
the file: world-space centres and a radius per point, in a binary buffer of their own
(`scene_points.bin`) behind accessors. Cycles renders each point as a sphere.

* Every instance of the depsgraph whose object is a point cloud: a Point Cloud object, and the
  point clouds Geometry Nodes make on any object (Mesh to Points, Distribute Points on Faces,
  Points): in Blender 5.0 these are instances whose `object` is a temporary POINTCLOUD object
  and whose `instance_object` is the object that made them.
* Radius: the `radius` point attribute, Cycles' 0.01 without one, scaled by the instance's mean
  scale (the cube root of its matrix's determinant); a non-uniform scale is named (Cycles then
  draws ellipsoids where it does not apply the transform). Points of radius <= 0 (which Cycles
  shows as nothing) are left out with a warning, and the remaining points' indices are written
  so that Point Info's Random keeps Cycles' numbers.
* Material: Cycles gives every point the object's first shader (the first material slot, the
  view layer's Material Override over it); the exporter's glTF material of that name when it
  wrote one, else one appended here as a shader node graph (`CAUSTIC_materials_nodes`, the
  path that renders any graph, Point Info included).
* Instance data for the graphs: the object's matrix (Texture Coordinate Object and Generated,
  which for a point cloud is the object-space point, Cycles having no texture space for it) and
  the instance's depsgraph random id (Object Info Random).

* The object's Ray Visibility and Holdout (an Indirect Only collection hides it from the camera)
  as `visibility`, `CAUSTIC_object_visibility`'s keys (export/visibility.py).

Not rendered, each named in a warning: an object's Shadow Catcher (the loader names it),
per-point attributes read by an Attribute node (only Point Info's outputs reach the shader), and
motion blur (the points are where they are at the frame).
"""

import json
import os

import numpy as np

POINTS_EXTENSION = "CAUSTIC_points"
BUFFER_NAME = "scene_points.bin"
# Cycles' radius of a point without a `radius` attribute (blender/pointcloud.cpp).
DEFAULT_POINT_RADIUS = 0.01
# Blender's Z-up axes to glTF's Y-up: (x, y, z) -> (x, z, -y).
_AXES = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


class Cloud:
    """One point cloud instance: centres (N, 3) world glTF axes, radii (N,), indices (N,) or None."""

    def __init__(self, name, object_name, material, centres, radii, indices, matrix, random_id, visibility=None):
        self.name = name
        self.object_name = object_name  # the Blender object, for light linking and messages
        self.material = material
        self.centres = np.asarray(centres, dtype=np.float32).reshape(-1, 3)
        self.radii = np.asarray(radii, dtype=np.float32)
        self.indices = None if indices is None else np.asarray(indices, dtype=np.uint32)
        self.matrix = matrix  # object to world, glTF axes, column-major (16 floats)
        self.random_id = random_id  # the depsgraph's random id of an instance, else None
        self.visibility = visibility  # CAUSTIC_object_visibility's keys (Ray Visibility, Holdout), or None


def owner_of(instance):
    """The object a point cloud instance belongs to: the object whose Geometry Nodes made it (an
    instance whose `instance_object` is not itself a point cloud), else its own object."""
    if instance.is_instance and instance.instance_object is not None \
            and instance.instance_object.type != "POINTCLOUD":
        return instance.instance_object
    return instance.object


def point_owners(depsgraph):
    """Names of the objects whose point clouds the depsgraph renders (owner_of each instance)."""
    return {getattr(owner_of(i), "original", owner_of(i)).name for i in depsgraph.object_instances
            if i.object.type == "POINTCLOUD"}


def makes_points(obj, depsgraph=None):
    """Whether the object's evaluated geometry holds points (a Point Cloud object, or Geometry
    Nodes' points on a mesh)."""
    if obj is None:
        return False
    if obj.type == "POINTCLOUD":
        return True
    try:
        import bpy
        geometry = obj.evaluated_get(depsgraph or bpy.context.evaluated_depsgraph_get()).evaluated_geometry()
        cloud = geometry.pointcloud
    except (AttributeError, RuntimeError, ReferenceError, TypeError):
        return False
    return cloud is not None and len(cloud.points) > 0


def _radii(data, n, what, warnings):
    """The `radius` point attribute as float64, or Cycles' default."""
    radius = data.attributes.get("radius")
    if radius is None or radius.domain != "POINT":
        return np.full(n, DEFAULT_POINT_RADIUS)
    if radius.data_type in ("FLOAT", "INT"):
        values = np.empty(n, dtype=np.float32 if radius.data_type == "FLOAT" else np.int32)
        radius.data.foreach_get("value", values)
        return values.astype(np.float64)
    warnings.append(f"{what}: its 'radius' attribute is {radius.data_type}, not FLOAT: the points take "
                    f"Cycles' default radius {DEFAULT_POINT_RADIUS}")
    return np.full(n, DEFAULT_POINT_RADIUS)


def _material(obj, override):
    """Cycles' shader of a point cloud: the view layer's override, else the first slot's material."""
    if override is not None:
        return override
    slots = obj.material_slots
    return slots[0].material if len(slots) else None


def _object_visibility_in(owner, view_layer):
    """The object's Ray Visibility, Holdout (an Indirect Only collection hides it from the camera)
    and Shadow Catcher flag as `CAUSTIC_object_visibility`'s keys, or None (the loader names a
    catcher, which points do not render)."""
    from .visibility import object_visibility_extension
    return object_visibility_extension(getattr(owner, "original", owner), view_layer)


def scene_clouds(depsgraph, warnings):
    """Every point cloud instance of the render depsgraph, as Clouds (empty ones left out)."""
    view_layer = depsgraph.view_layer
    override = view_layer.material_override
    clouds, names, warned = [], {}, set()
    for instance in depsgraph.object_instances:
        obj = instance.object
        if obj.type != "POINTCLOUD":
            continue
        data = obj.data
        n = len(data.points)
        if n == 0:
            continue
        owner = owner_of(instance)
        owner_name = getattr(owner, "original", owner).name
        count = names.get(owner_name, 0)
        names[owner_name] = count + 1
        name = owner_name if count == 0 else f"{owner_name} {count}"
        what = f"point cloud of object '{owner_name}'"
        visibility = _object_visibility_in(owner, view_layer)
        positions = np.empty(n * 3, dtype=np.float32)
        data.attributes["position"].data.foreach_get("vector", positions)
        positions = positions.reshape(-1, 3).astype(np.float64)
        radii = _radii(data, n, what, warnings)
        m = np.array(instance.matrix_world, dtype=np.float64)
        linear = m[:3, :3]
        scale = abs(np.linalg.det(linear)) ** (1.0 / 3.0)
        stretch = np.linalg.svd(linear, compute_uv=False)
        if scale > 0 and (stretch.max() - stretch.min()) > 1e-4 * stretch.max() and owner_name + "/scale" not in warned:
            warned.add(owner_name + "/scale")
            warnings.append(f"{what}: its non-uniform scale is rendered as spheres of the mean scale "
                            f"({scale:.4g}), not stretched")
        centres = positions @ linear.T + m[:3, 3]
        radii = radii * scale
        keep = np.isfinite(radii) & (radii > 0) & np.all(np.isfinite(centres), axis=1)
        indices = None
        if not np.all(keep):
            warnings.append(f"{what}: {int(np.sum(~keep))} of its {n} points have a radius of 0 or less or no "
                            "finite position, which Cycles shows as nothing; they are left out")
            indices = np.nonzero(keep)[0]
            centres, radii = centres[keep], radii[keep]
            if len(radii) == 0:
                continue
        matrix = (_AXES @ m @ _AXES.T).T.reshape(-1)
        random_id = int(instance.random_id) & 0xFFFFFFFF if instance.is_instance else None
        centres = np.stack([centres[:, 0], centres[:, 2], -centres[:, 1]], axis=1)
        clouds.append(Cloud(name, owner_name, _material(obj, override), centres, radii, indices,
                            [float(x) for x in matrix], random_id, visibility))
    if clouds and depsgraph.scene.render.use_motion_blur:
        warnings.append("point clouds are rendered without motion blur: their points are where they are "
                        "at the frame")
    return clouds


def _attribute_warnings(graph, what, strands=False):
    """Warnings for the graph's Attribute and Color Attribute nodes, which points (or strands:
    `strands`) do not feed."""
    out = []
    for node in graph.nodes:
        if node["type"] not in ("ShaderNodeAttribute", "ShaderNodeVertexColor"):
            continue
        props = node.get("props", {})
        if "tex_coord" in props:
            continue  # a UV map: 0 on points, as Cycles (points have none)
        name = props.get("attribute_name") or props.get("layer_name") or ""
        if strands:
            out.append(f"{what}: the attribute '{name}' is not exported for strands: it reads 0")
        else:
            out.append(f"{what}: the attribute '{name}' is not exported for points: it reads white (1)")
    return out


def _gltf_material(doc, material, state, folder, warnings, what, strands=False):
    """The glTF index of `material` for points (or strands): the exporter's material of that name
    when it wrote one, else one appended as its node graph; Blender's default surface for None."""
    from .curves import _gltf_material as constant_material
    from .materials import graph_of
    from .meshes import default_surface_index
    from .node_graph import GRAPH_EXTENSION
    from .pass_ids import MATERIAL_PASS_EXTENSION, material_pass_extension
    if material is None:
        return default_surface_index(doc)
    materials = doc.setdefault("materials", [])
    index = next((i for i, m in enumerate(materials) if m.get("name") == material.name), None)
    graph = graph_of(material, state)
    if graph is not None:
        warnings.extend(_attribute_warnings(graph, what, strands))
    if index is not None:
        return index
    if graph is None:
        return constant_material(doc, material, warnings, what)
    warnings.extend(graph.warnings)
    value = state.image_writer(folder).graph_value(graph, f"material '{material.name}'", warnings)
    entry = {"name": material.name, "extensions": {GRAPH_EXTENSION: value},
             "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0}}
    used = doc.setdefault("extensionsUsed", [])
    ids = material_pass_extension(material)
    if ids:
        entry["extensions"][MATERIAL_PASS_EXTENSION] = ids
        if MATERIAL_PASS_EXTENSION not in used:
            used.append(MATERIAL_PASS_EXTENSION)
    if GRAPH_EXTENSION not in used:
        used.append(GRAPH_EXTENSION)
    materials.append(entry)
    return len(materials) - 1


def add_points(gltf_path, depsgraph, state):
    """Append the scene's point clouds to the written glTF file; returns the number of points."""
    clouds = scene_clouds(depsgraph, state.warnings)
    if not clouds:
        return 0
    with open(gltf_path, encoding="utf-8") as f:
        doc = json.load(f)
    folder = os.path.dirname(gltf_path)
    blob = bytearray()
    buffer_index = len(doc.setdefault("buffers", []))
    views = doc.setdefault("bufferViews", [])
    accessors = doc.setdefault("accessors", [])

    def accessor(array, component, kind):
        while len(blob) % 4:
            blob.append(0)
        data = np.ascontiguousarray(array).tobytes()
        views.append({"buffer": buffer_index, "byteOffset": len(blob), "byteLength": len(data)})
        blob.extend(data)
        accessors.append({"bufferView": len(views) - 1, "componentType": component, "count": len(array),
                          "type": kind})
        return len(accessors) - 1

    objects = []
    total = 0
    for c in clouds:
        what = f"point cloud of object '{c.object_name}'"
        entry = {
            "name": c.name,
            "object": c.object_name,
            "positions": accessor(c.centres, 5126, "VEC3"),
            "radii": accessor(c.radii.astype(np.float32), 5126, "SCALAR"),
            "matrix": c.matrix,
        }
        if c.indices is not None:
            entry["indices"] = accessor(c.indices.astype(np.uint32), 5125, "SCALAR")
        if c.random_id is not None:
            entry["randomId"] = c.random_id
        if c.visibility:
            entry["visibility"] = c.visibility
        material = _gltf_material(doc, c.material, state, folder, state.warnings, what)
        if material is not None:
            entry["material"] = material
        objects.append(entry)
        total += len(c.radii)
    with open(os.path.join(folder, BUFFER_NAME), "wb") as f:
        f.write(blob)
    doc["buffers"].append({"uri": BUFFER_NAME, "byteLength": len(blob)})
    doc.setdefault("extensions", {})[POINTS_EXTENSION] = {"objects": objects}
    used = doc.setdefault("extensionsUsed", [])
    if POINTS_EXTENSION not in used:
        used.append(POINTS_EXTENSION)
    with open(gltf_path, "w", encoding="utf-8") as f:
        json.dump(doc, f)
    return total
