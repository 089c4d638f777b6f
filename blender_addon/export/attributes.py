"""Attributes read by name, as Cycles reads them (docs/contract.md, "Attributes").

Cycles gives a shader the attributes its nodes ask for: the Attribute node's (Geometry: a mesh
attribute by name; Object and Instancer: a property of the object, its data, or its instancer;
View Layer: a property of the view layer, scene or world), the Color Attribute node's, and the
Geometry node's Pointiness and Random Per Island, which its sync computes from the mesh
(`intern/cycles/blender/mesh.cpp`). The export gives the renderer the same values:

* Mesh attributes become glTF vertex attributes of the exporter's primitives, one value per
  corner, so that they follow its vertex split (a face or corner attribute splits vertices as
  the exporter's own UVs do): `_CAUSTIC_ATTR_<hex of the name>`, `_CAUSTIC_RENDER_COLOR`,
  `_CAUSTIC_POINTINESS`, `_CAUSTIC_RANDOM_PER_ISLAND`. They are added in the exporter's
  `gather_attributes_change` hook (`add_mesh_attributes`), which is handed the list of
  attributes its `PrimitiveCreator` is about to export: an entry with its own `get` fills the
  creator's per-corner table (its `dots`) as the exporter fills its own custom attributes'.
  The hook is not handed the creator, whose mesh and table the entry needs: it is the `self`
  of the frame that called the hook (io_scene_gltf2 5.0.21: `define_attributes`), found by the
  list it holds (`_creator`). Values are Cycles': integers and booleans as floats, byte
  colours decoded from sRGB by Cycles' formula, quaternions as (w, x, y, z); an edge attribute
  is averaged onto its vertices, as Blender's attribute API adapts it for Cycles.
* Pointiness (`pointiness`) and Random Per Island (`random_per_island`) are computed in numpy
  exactly as Cycles' `attr_create_pointiness` and `attr_create_random_per_island` do, from the
  mesh the exporter writes (the evaluated one: after modifiers and Geometry Nodes).
* Object and Instancer attributes are looked up as `BKE_object_dupli_find_rgba_attribute`
  does (`rna_rgba`: a custom property by name first, else an RNA path; a float, int or bool, or
  a float or int array of up to 4, as RGBA; else not found, 0): per mesh node
  (`object_attributes`, node extras `CAUSTIC_object_attributes`); an instance's (with its
  instancer's particle settings, Geometry Nodes instance attributes and object first) after the
  exporter ran, on the instance nodes matched to the depsgraph's instances
  (`instance_values`, `instance_random.add_instance_randoms`).
* View Layer attributes are constants (`view_layer_rgba`, on the node as `view_layer_value`).
"""

import sys

import numpy as np

OBJECT_EXTRA = "CAUSTIC_object_attributes"
NAMED_PREFIX = "_CAUSTIC_ATTR_"
# Kinds of request: a mesh attribute by name, the render colour attribute (a Color Attribute
# node without a name), Geometry's two computed outputs; object and instancer properties.
GEOMETRY, RENDER_COLOR, POINTINESS, RANDOM_PER_ISLAND = "GEOMETRY", "RENDER_COLOR", "POINTINESS", "RANDOM_PER_ISLAND"
OBJECT, INSTANCER = "OBJECT", "INSTANCER"
MESH_KINDS = {GEOMETRY, RENDER_COLOR, POINTINESS, RANDOM_PER_ISLAND}
# Blender attribute types Cycles reads (intern/cycles/blender/attribute_convert.h): the value
# property and the number of components; any other type is not read (0 in Cycles too).
_TYPES = {"FLOAT": ("value", 1), "INT": ("value", 1), "INT8": ("value", 1), "BOOLEAN": ("value", 1),
          "FLOAT2": ("vector", 2), "FLOAT_VECTOR": ("vector", 3), "FLOAT_COLOR": ("color", 4),
          "BYTE_COLOR": ("color_srgb", 4), "QUATERNION": ("value", 4)}
# The exporter's data types for 1-4 float components (its accessors: SCALAR, VEC2-4, FLOAT).
_GLTF_TYPES = {1: "FLOAT", 2: "FLOAT2", 3: "FLOAT_VECTOR", 4: "FLOAT_COLOR"}
_FLT_EPSILON = np.float32(1.1920929e-07)


def semantic(kind, name=""):
    """The glTF attribute semantic of a mesh attribute request."""
    if kind == GEOMETRY:
        return NAMED_PREFIX + name.encode("utf-8").hex().upper()
    return {RENDER_COLOR: "_CAUSTIC_RENDER_COLOR", POINTINESS: "_CAUSTIC_POINTINESS",
            RANDOM_PER_ISLAND: "_CAUSTIC_RANDOM_PER_ISLAND"}[kind]


def graph_requests(graph):
    """{(kind, name)} a built graph (node_graph.Graph) reads by name: Attribute nodes of the
    Geometry, Object and Instancer types and Color Attribute nodes (but those reading a UV map
    or the attribute exported as COLOR_0), the Geometry node's Pointiness and Random Per
    Island outputs where linked."""
    if graph is None:
        return set()
    linked = {(item["link"][0], item["link"][1]) for node in graph.nodes for item in node["inputs"].values()
              if "link" in item}
    found = set()
    for i, node in enumerate(graph.nodes):
        kind, props = node["type"], node["props"]
        if kind in {"ShaderNodeAttribute", "ShaderNodeVertexColor"}:
            if "tex_coord" in props or props.get("color_0"):
                continue
            if kind == "ShaderNodeVertexColor":
                name = props.get("layer_name", "")
                found.add((GEOMETRY, name) if name else (RENDER_COLOR, ""))
            elif props.get("attribute_type", "GEOMETRY") in {GEOMETRY, OBJECT, INSTANCER}:
                found.add((props.get("attribute_type", "GEOMETRY"), props.get("attribute_name", "")))
        elif kind == "ShaderNodeNewGeometry":
            if (i, "Pointiness") in linked:
                found.add((POINTINESS, ""))
            if (i, "Random Per Island") in linked:
                found.add((RANDOM_PER_ISLAND, ""))
    return found


def material_requests(materials, state):
    """The requests of the node graphs `materials` (Blender materials, None skipped) are
    rendered from: the view layer's override's when there is one."""
    from .materials import graph_of, uses_graph
    if state.material_override is not None:
        return graph_requests(graph_of(state.material_override, state))
    found = set()
    for material in materials:
        if material is not None and uses_graph(material, state):
            found |= graph_requests(graph_of(material, state))
    return found


# --- mesh attributes -------------------------------------------------------------------------

def _creator(blender_attributes):
    """The exporter's PrimitiveCreator that holds `blender_attributes` (module doc)."""
    frame = sys._getframe(1)
    while frame is not None:
        candidate = frame.f_locals.get("self")
        if getattr(candidate, "blender_attributes", None) is blender_attributes and \
                hasattr(candidate, "blender_mesh"):
            return candidate
        frame = frame.f_back
    return None


def add_mesh_attributes(blender_attributes, state):
    """The `gather_attributes_change` hook's work: entries for the mesh attributes the mesh's
    materials read (module doc). Returns the semantics added."""
    creator = _creator(blender_attributes)
    if creator is None:
        warning = ("the glTF exporter's primitive creator was not found (an exporter other than io_scene_gltf2 "
                   "5.0?): attributes read by name, Pointiness and Random Per Island are not exported and read 0")
        if warning not in state.warnings:
            state.warnings.append(warning)
        return []
    mesh = creator.blender_mesh
    requests = sorted(r for r in material_requests(getattr(creator, "materials", ()) or (), state)
                      if r[0] in MESH_KINDS)
    if not requests or len(mesh.loops) == 0:
        return []
    what = f"mesh '{getattr(mesh, 'name', '?')}'"
    corner_verts = np.empty(len(mesh.loops), dtype=np.int64)
    mesh.loops.foreach_get("vertex_index", corner_verts)
    added = []
    for kind, name in requests:
        values = corner_values(mesh, kind, name, corner_verts, state.warnings, what,
                               getattr(creator, "blender_vertex_groups", None))
        if values is None:
            continue
        gltf_name = semantic(kind, name)
        blender_attributes.append(_entry(creator, gltf_name, values))
        added.append(gltf_name)
    return added


def _entry(creator, gltf_name, values):
    """An attribute entry for the exporter's list whose `get` fills the creator's corner table."""
    width = values.shape[1]

    def get(attr):
        for i in range(width):
            creator.dots[gltf_name + str(i)] = values[:, i]

    return {"gltf_attribute_name": gltf_name, "blender_data_type": _GLTF_TYPES[width], "blender_domain": "CORNER",
            "len": width, "type": np.float32, "get": get}


def corner_values(mesh, kind, name, corner_verts, warnings, what, vertex_groups=None):
    """The request's values per corner of `mesh` as a float32 (corners, components) array, or
    None where Cycles does not find it either (then 0). A name that is no attribute but one of
    `vertex_groups` (the object's) reads that group's weights, as Cycles, which is handed the
    vertex groups among the mesh's attributes."""
    if kind == POINTINESS:
        return pointiness(mesh)[corner_verts][:, None]
    if kind == RANDOM_PER_ISLAND:
        return random_per_island(mesh)[corner_verts][:, None]
    if kind == RENDER_COLOR:
        name = mesh.attributes.default_color_name or ""
        if not name:
            return None
    attribute = mesh.attributes.get(name) if name else None
    if attribute is None:
        group = vertex_groups.get(name) if vertex_groups is not None and name else None
        if group is None:
            return None  # the renderer names the material and node reading it
        return vertex_group_weights(mesh, group.index)[corner_verts][:, None]
    if attribute.data_type not in _TYPES:
        warnings.append(f"{what}: attribute '{name}' is of type {attribute.data_type}, which Cycles does not "
                        "read either: it reads 0")
        return None
    prop, width = _TYPES[attribute.data_type]
    data = np.empty(len(attribute.data) * width, dtype=np.float32)
    if len(data):
        attribute.data.foreach_get(prop, data)
    data = data.reshape(-1, width)
    if attribute.data_type == "BYTE_COLOR":
        data[:, :3] = srgb_to_linear(data[:, :3])
        if attribute.domain == "CORNER":
            data[:, :3] = _corner_bytes_converted(data[:, :3])
    domain = attribute.domain
    if domain == "EDGE":
        data, domain = _edges_to_points(mesh, data, attribute.data_type == "BOOLEAN"), "POINT"
    if domain == "POINT":
        values = data[corner_verts]
    elif domain == "CORNER":
        values = data
    elif domain == "FACE":
        values = data[_corner_faces(mesh)]
    else:
        return None
    bad = ~np.isfinite(values)
    if bad.any():
        warnings.append(f"{what}: attribute '{name}' has {int(bad.any(axis=1).sum())} corner(s) with NaN or "
                        "infinite values, written as 0")
        values = np.where(bad, np.float32(0.0), values)
    return np.ascontiguousarray(values, dtype=np.float32)


def vertex_group_weights(mesh, group_index):
    """Each vertex's weight in vertex group `group_index`, 0 where it is not in the group (a
    point-domain float, as Blender's attribute API gives a vertex group to Cycles). Blender has
    no bulk accessor for the weights: one Python pass over the vertices' memberships."""
    weights = np.zeros(len(mesh.vertices), dtype=np.float32)
    for vertex in mesh.vertices:
        for element in vertex.groups:
            if element.group == group_index:
                weights[vertex.index] = element.weight
    return weights


def _corner_bytes_converted(linear):
    """Byte colours of the corner domain as Cycles 5.0.1 reads them under a working space other
    than Linear Rec.709: decoded from sRGB and converted from Rec.709 to the working space (what
    the attribute API's `color` gives), where the point domain's are taken as they decode
    (measured on an emitting plane under ACEScg: a byte colour set to (0.9, 0.3, 0.1) renders
    (0.91, 0.30, 0.10) in the point domain and (0.66, 0.34, 0.14) in the corner domain;
    `byte_color_*` cases of test_working_space_agreement.py)."""
    from .settings import working_space
    space = working_space()
    if space is None:
        return linear
    to_working = np.array(space["from_rec709"], dtype=np.float64)
    return (linear.astype(np.float64) @ to_working.T).astype(np.float32)


def srgb_to_linear(c):
    """Cycles' color_srgb_to_linear, per component (float32)."""
    c = np.asarray(c, dtype=np.float32)
    low = np.where(c < 0.0, np.float32(0.0), c * np.float32(1.0 / 12.92))
    high = np.power((c + np.float32(0.055)) * np.float32(1.0 / 1.055), np.float32(2.4)).astype(np.float32)
    return np.where(c < np.float32(0.04045), low, high).astype(np.float32)


def _corner_faces(mesh):
    """The face of each corner."""
    starts = np.empty(len(mesh.polygons), dtype=np.int64)
    totals = np.empty(len(mesh.polygons), dtype=np.int64)
    mesh.polygons.foreach_get("loop_start", starts)
    mesh.polygons.foreach_get("loop_total", totals)
    faces = np.zeros(len(mesh.loops), dtype=np.int64)
    faces[np.repeat(starts, totals) + (np.arange(totals.sum()) - np.repeat(np.cumsum(totals) - totals, totals))] = \
        np.repeat(np.arange(len(starts)), totals)
    return faces


def _edges(mesh):
    edges = np.empty(2 * len(mesh.edges), dtype=np.int64)
    mesh.edges.foreach_get("vertices", edges)
    return edges.reshape(-1, 2)


def _edges_to_points(mesh, data, boolean):
    """An edge attribute on the vertices, as Blender's attribute API adapts it: the mean of a
    vertex's edges (a boolean: whether any is set); 0 on a vertex without edges."""
    edges = _edges(mesh)
    n = len(mesh.vertices)
    total = np.zeros((n, data.shape[1]), dtype=np.float64)
    count = np.zeros(n, dtype=np.int64)
    for side in (0, 1):
        np.add.at(total, edges[:, side], data)
        np.add.at(count, edges[:, side], 1)
    if boolean:
        return (total > 0).astype(np.float32)
    return (total / np.maximum(count, 1)[:, None]).astype(np.float32)


# --- Pointiness and Random Per Island ---------------------------------------------------------

def _vectors(collection, prop, n):
    data = np.empty(3 * n, dtype=np.float32)
    if n:
        collection.foreach_get(prop, data)
    return data.reshape(-1, 3)


def pointiness(mesh):
    """Per-vertex Pointiness of `mesh` as Cycles' `attr_create_pointiness` computes it (float32)."""
    n = len(mesh.vertices)
    positions = _vectors(mesh.vertices, "co", n)
    normals = _vectors(mesh.vertex_normals, "vector", n)
    return pointiness_of(positions, normals, _edges(mesh))


def pointiness_of(positions, normals, edges):
    """Cycles' pointiness from object-space positions, Blender's vertex normals and the edges."""
    positions = np.asarray(positions, dtype=np.float32)
    n = len(positions)
    if n == 0:
        return np.zeros(0, dtype=np.float32)
    # Step 1: duplicates point to one vertex. Sorted by the sum of the coordinates (equal
    # positions by index, descending), each vertex looks forward, while the sums stay within
    # 3 FLT_EPSILON, for the first vertex nearer than sqrt(FLT_EPSILON).
    sums = (positions[:, 0] + positions[:, 1]) + positions[:, 2]
    order = np.lexsort((-np.arange(n), sums))
    sorted_sums = sums[order]
    window = np.float32(3.0) * _FLT_EPSILON
    orig = np.arange(n)
    active, k = np.arange(n), 1
    while len(active):
        active = active[active + k < n]
        # Sorted by sum, the difference only grows: a vertex past the window is done.
        active = active[(sorted_sums[active + k] - sorted_sums[active]) <= window]
        here, there = order[active], order[active + k]
        close = ((positions[there] - positions[here]) ** 2).sum(axis=1, dtype=np.float32) < _FLT_EPSILON
        orig[here[close]] = there[close]
        active = active[~close]
        k += 1
    # Every vertex to the end of its chain.
    while True:
        nxt = orig[orig]
        if np.array_equal(nxt, orig):
            break
        orig = nxt
    # Step 2: the welded vertices' normals.
    summed = np.zeros((n, 3), dtype=np.float32)
    np.add.at(summed, orig, np.asarray(normals, dtype=np.float32))
    length = np.sqrt((summed * summed).sum(axis=1, dtype=np.float32))
    with np.errstate(invalid="ignore", divide="ignore"):
        vert_normal = (summed / length[:, None]).astype(np.float32)
    # Step 3: the angle between the normal and the mean direction to the one-ring, once per
    # welded edge.
    welded = orig[np.asarray(edges, dtype=np.int64)] if len(edges) else np.zeros((0, 2), dtype=np.int64)
    if len(welded):
        keys = np.sort(welded, axis=1)
        _, first = np.unique(keys[:, 0] * np.int64(n) + keys[:, 1], return_index=True)
        welded = welded[np.sort(first)]
    v0, v1 = welded[:, 0], welded[:, 1]
    d = positions[v1] - positions[v0]
    length = np.sqrt((d * d).sum(axis=1, dtype=np.float32))
    with np.errstate(invalid="ignore", divide="ignore"):
        direction = np.where(length[:, None] > 0, d / length[:, None], np.float32(0.0)).astype(np.float32)
    accum = np.zeros((n, 3), dtype=np.float32)
    counter = np.zeros(n, dtype=np.int64)
    np.add.at(accum, v0, direction)
    np.add.at(accum, v1, -direction)
    np.add.at(counter, v0, 1)
    np.add.at(counter, v1, 1)
    raw = np.zeros(n, dtype=np.float32)
    rep = (orig == np.arange(n)) & (counter > 0)
    mean = accum[rep] / counter[rep][:, None].astype(np.float32)
    cosine = (vert_normal[rep] * mean).sum(axis=1, dtype=np.float32)
    raw[rep] = (np.arccos(np.clip(cosine, -1.0, 1.0)) * np.float32(1.0 / np.pi)).astype(np.float32)
    # Step 4: blurred over the one-ring, then copied to the duplicates.
    data = raw.copy()
    np.add.at(data, v0, raw[v1])
    np.add.at(data, v1, raw[v0])
    data = (data / (counter + 1).astype(np.float32)).astype(np.float32)
    return data[orig]


def random_per_island(mesh):
    """Per-vertex Random Per Island of `mesh` as Cycles' `attr_create_random_per_island`:
    the hash of the root of the vertex's island in Cycles' DisjointSet joined along the edges
    in order (equal for every vertex of a face, so the face's value)."""
    return random_per_island_of(len(mesh.vertices), _edges(mesh))


def random_per_island_of(n, edges):
    """Cycles' Random Per Island per vertex from the vertex count and the edges (float32)."""
    parent = list(range(n))
    rank = [0] * n

    def find(x):
        root = x
        while parent[root] != root:
            root = parent[root]
        while parent[x] != root:
            parent[x], x = root, parent[x]
        return root

    for a, b in np.asarray(edges, dtype=np.int64).tolist():
        ra, rb = find(a), find(b)
        if ra == rb:
            continue
        if rank[ra] < rank[rb]:
            ra, rb = rb, ra
        parent[rb] = ra
        if rank[ra] == rank[rb]:
            rank[ra] += 1
    roots = np.array([find(v) for v in range(n)], dtype=np.uint32)
    return hash_uint_to_float(roots)


def hash_uint_to_float(k):
    """Cycles' hash_uint_to_float (lookup3's final mix of one word, over 2^32), per element."""
    k = np.asarray(k, dtype=np.uint32)
    with np.errstate(over="ignore"):
        a = np.full(k.shape, 0xDEADBEEF + (1 << 2) + 13, dtype=np.uint32)
        b, c = a.copy(), a.copy()
        a = a + k

        def rot(x, s):
            return (x << np.uint32(s)) | (x >> np.uint32(32 - s))

        c ^= b
        c -= rot(b, 14)
        a ^= c
        a -= rot(c, 11)
        b ^= a
        b -= rot(a, 25)
        c ^= b
        c -= rot(b, 16)
        a ^= c
        a -= rot(c, 4)
        b ^= a
        b -= rot(a, 14)
        c ^= b
        c -= rot(b, 24)
    return (c.astype(np.float32) * np.float32(1.0 / 4294967296.0)).astype(np.float32)


# --- object, instancer and view layer attributes -----------------------------------------------

def rna_rgba(owner, name):
    """Cycles' `find_rna_property_rgba`: the custom property `name` of `owner` (an ID or a
    struct with custom properties), else the RNA path `name`, as RGBA: a float, int or bool
    scalar s gives (s, s, s, 1); a float or int array of up to 4 fills (0, 0, 0, 1) from the
    start; anything else, or nothing there, is None (not found)."""
    if owner is None or not name:
        return None
    try:
        keys = owner.keys()
    except (AttributeError, TypeError):
        keys = ()
    try:
        if name in keys:
            value = owner[name]
        else:
            value = owner.path_resolve(name)
    except (ValueError, KeyError, AttributeError, TypeError, IndexError):
        return None
    return _rgba(value)


def _rgba(value):
    if isinstance(value, bool):
        return [float(value)] * 3 + [1.0]
    if isinstance(value, (int, float)):
        return [float(value)] * 3 + [1.0]
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        return None
    typecode = getattr(value, "typecode", None)  # an IDPropertyArray: 'f'/'d', 'i' or 'b'
    try:
        items = list(value)
    except TypeError:
        return None
    if not 0 < len(items) <= 4 or typecode == "b":
        return None
    if any(isinstance(x, bool) or not isinstance(x, (int, float)) for x in items):
        return None  # a bool array, an array of arrays (a matrix), of structs
    out = [0.0, 0.0, 0.0, 1.0]
    out[:len(items)] = [float(x) for x in items]
    return out


def object_rgba(obj, name):
    """An object's attribute `name` as Cycles' object lookup: the object, else its data."""
    value = rna_rgba(obj, name)
    if value is None and obj is not None:
        value = rna_rgba(getattr(obj, "data", None), name)
    return value


# A Geometry Nodes instance's persistent id: the geometry's component, the instance's index,
# then INT_MAX (depsgraph instances of one level of Geometry Nodes instances, bpy 5.0.1).
_GN_UNUSED_ID = 2147483647


class InstanceAttributes:
    """The attributes Geometry Nodes stored on an instancer's instances (its evaluated
    geometry's instance domain), read once per instancer: {name: (instances, 4) RGBA} as
    Blender converts them to a colour (ColorGeometry4f): a float f (f, f, f, 1), a vector
    (x, y, z, 1), a float2 (x, y, 0, 1), an int or bool as a float."""

    def __init__(self):
        self.by_instancer = {}
        self.nested = set()  # instancers whose instances nest deeper than one level

    def _table(self, parent):
        key = parent.as_pointer()
        if key not in self.by_instancer:
            table = {}
            try:
                import bpy
                # The point cloud lives in the geometry set: keep it while reading.
                geometry = bpy.types.GeometrySet.from_evaluated_object(parent)
                cloud = geometry.instances_pointcloud()
            except (AttributeError, RuntimeError, TypeError, ReferenceError):
                geometry, cloud = None, None
            for attribute in getattr(cloud, "attributes", ()):
                if attribute.name.startswith(".") or attribute.data_type not in _TYPES:
                    continue
                prop, width = _TYPES[attribute.data_type]
                prop = "color" if attribute.data_type == "BYTE_COLOR" else prop
                data = np.empty(len(attribute.data) * width, dtype=np.float32)
                if len(data):
                    attribute.data.foreach_get(prop, data)
                data = data.reshape(-1, width)
                rgba = np.zeros((len(data), 4), dtype=np.float32)
                rgba[:, 3] = 1.0
                if width == 1:
                    rgba[:, :3] = data
                elif attribute.data_type == "QUATERNION":
                    continue  # no colour conversion in Blender
                else:
                    rgba[:, :width] = data
                table[attribute.name] = rgba
            del cloud, geometry
            self.by_instancer[key] = table
        return self.by_instancer[key]

    def value(self, instance, name):
        """The instance's attribute `name` from its Geometry Nodes instancer, or None."""
        parent = getattr(instance, "parent", None)
        if parent is None or getattr(instance, "particle_system", None) is not None:
            return None
        if not any(m.type == "NODES" for m in getattr(parent.original, "modifiers", ())):
            return None
        ids = list(instance.persistent_id)
        if len(ids) < 3 or ids[2] != _GN_UNUSED_ID:
            self.nested.add(parent.original.name)
            return None
        table = self._table(parent).get(name)
        if table is None or not 0 <= ids[1] < len(table):
            return None
        return [float(c) for c in table[ids[1]]]


def instancer_rgba(instance, name, instance_attributes=None):
    """An instance's Instancer attribute where its instancer has it, in Cycles' order: the
    particle settings, the attribute Geometry Nodes stored on the instance
    (`instance_attributes`, an InstanceAttributes), the instancing object (Cycles then tries
    the object and its data, which the node's Object lookup already wrote); None when none
    has it."""
    psys = getattr(instance, "particle_system", None)
    if psys is not None:
        value = rna_rgba(psys.settings, name)
        if value is not None:
            return value
    if instance_attributes is not None:
        value = instance_attributes.value(instance, name)
        if value is not None:
            return value
    return rna_rgba(getattr(instance, "parent", None), name)


def object_attributes(blender_object, state):
    """The node extras' value for a mesh object: {"object": {name: RGBA}, "instancer": {...}}
    for the Object and Instancer attributes its materials read (an instancer attribute here is
    the object's own, as for an object that is no instance; instances get their instancer's
    after the export), or None."""
    materials = [slot.material for slot in getattr(blender_object, "material_slots", ())]
    requests = [r for r in material_requests(materials, state) if r[0] in {OBJECT, INSTANCER}]
    if not requests:
        return None
    obj = blender_object
    if state.depsgraph is not None:
        try:
            obj = blender_object.evaluated_get(state.depsgraph)
        except (RuntimeError, ReferenceError):
            obj = blender_object
    value = {}
    for kind, name in sorted(requests):
        rgba = object_rgba(obj, name)
        value.setdefault(kind.lower(), {})[name] = rgba if rgba is not None else [0.0, 0.0, 0.0, 0.0]
    return value


def note_requests(blender_material, state):
    """Record the Object and Instancer attributes the material's graph reads (in
    `state.object_names` and `state.instancer_names`), for the instances' values written after
    the export (`instance_random.add_instance_randoms`)."""
    from .materials import graph_of
    for kind, name in graph_requests(graph_of(blender_material, state)):
        if kind == OBJECT:
            state.object_names.add(name)
        elif kind == INSTANCER:
            state.instancer_names.add(name)


def instance_values(instance, object_names, instancer_names, instance_attributes=None):
    """The node extras' value for a depsgraph instance (`object_attributes`' shape): the
    instanced object's Object attributes, and its Instancer attributes from its instancer
    where that has them, else the object's; None when no graph reads any."""
    obj = getattr(instance, "object", None)
    value = {}
    for name in sorted(object_names):
        rgba = object_rgba(obj, name)
        value.setdefault("object", {})[name] = rgba if rgba is not None else [0.0, 0.0, 0.0, 0.0]
    for name in sorted(instancer_names):
        rgba = instancer_rgba(instance, name, instance_attributes)
        if rgba is None:
            rgba = object_rgba(obj, name)
        value.setdefault("instancer", {})[name] = rgba if rgba is not None else [0.0, 0.0, 0.0, 0.0]
    return value or None


def view_layer_rgba(depsgraph, name):
    """Cycles' View Layer attribute (`BKE_view_layer_find_rgba_attribute`): the view layer's,
    else the scene's, else the world's; (0, 0, 0, 0) where none has it."""
    if depsgraph is None:
        return [0.0, 0.0, 0.0, 0.0]
    layer = getattr(depsgraph, "view_layer_eval", None) or getattr(depsgraph, "view_layer", None)
    scene = getattr(depsgraph, "scene_eval", None) or getattr(depsgraph, "scene", None)
    for owner in (layer, scene, getattr(scene, "world", None)):
        value = rna_rgba(owner, name)
        if value is not None:
            return value
    return [0.0, 0.0, 0.0, 0.0]
