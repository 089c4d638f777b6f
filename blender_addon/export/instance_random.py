"""Object Info's Random of instances (`CAUSTIC_random_id`, docs/contract.md), and their
Instancer attributes (`CAUSTIC_object_attributes.instancer`, attributes.py).

Cycles gives an instance the random number Blender's depsgraph made for it
(`DepsgraphObjectInstance.random_id`, from the instancer and the instance's persistent id) and
a real object the hash of its name. Blender's glTF exporter names every Geometry Nodes instance
"GN Instance" and every particle or vertex/face instance after the instanced object, so the
renderer's name hash gave all instances of one instancer the same number: a scatter coloured
by Random rendered in one colour. After the exporter has run, `add_instance_randoms` writes
each instance node's `random_id` into its extras.

The exporter makes an instancer's instance nodes children of its node, from
`depsgraph.object_instances` (`io_scene_gltf2/blender/exp/tree.py`: Duplis and Geometry Nodes
instances). Each child is matched to the instance at its world position (glTF's Y-up of
Blender's), so the exporter's order need not be relied on; children at one position take the
instances there in order.

An instance's Object attributes are its instanced object's, its Instancer attributes its
instancer's where that has them (the particle settings, the attribute Geometry Nodes stored on
the instance, the instancing object, as Cycles' `BKE_object_dupli_find_rgba_attribute`), else
the object's: they replace what the node hook wrote (which is not given the instanced object
of a Geometry Nodes instance). Geometry Nodes instances nested in instances are read at their
instancer only, named in a warning.
"""

import json

import numpy as np

from .attributes import OBJECT_EXTRA, InstanceAttributes, instance_values

RANDOM_EXTRA = "CAUSTIC_random_id"
# Positions of one instance in Blender and in the glTF file agree to float32 rounding of the
# exporter's decomposed TRS; farther apart is another instance.
_MATCH_TOLERANCE = 1e-4


def _node_matrix(node):
    """A glTF node's local matrix (column-major `matrix` or TRS), as a 4x4 array."""
    if "matrix" in node:
        return np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T
    x, y, z, w = node.get("rotation", [0.0, 0.0, 0.0, 1.0])
    rotation = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])
    m = np.eye(4)
    m[:3, :3] = rotation * np.array(node.get("scale", [1.0, 1.0, 1.0]))
    m[:3, 3] = node.get("translation", [0.0, 0.0, 0.0])
    return m


def _world_positions(doc):
    """Each glTF node's world position (Y-up), by node index."""
    nodes = doc.get("nodes", [])
    parent = {}
    for i, node in enumerate(nodes):
        for child in node.get("children", []):
            parent[child] = i
    positions = {}
    for i in range(len(nodes)):
        m, j = np.eye(4), i
        while j is not None:
            m = _node_matrix(nodes[j]) @ m
            j = parent.get(j)
        positions[i] = m[:3, 3]
    return positions


def _instances_by_instancer(depsgraph, object_names=(), instancer_names=(), warnings=None):
    """{instancer object name: [(Y-up world position, random_id, object attributes or None)]}
    over the depsgraph's instances: the Object attributes `object_names` and Instancer
    attributes `instancer_names` of each (`attributes.instance_values`)."""
    found = {}
    stored = InstanceAttributes()
    for inst in depsgraph.object_instances:
        if not inst.is_instance or inst.parent is None:
            continue
        t = inst.matrix_world.translation
        values = instance_values(inst, object_names, instancer_names, stored)
        found.setdefault(inst.parent.original.name, []).append(
            (np.array([t.x, t.z, -t.y], dtype=np.float64), int(inst.random_id) & 0xFFFFFFFF, values))
    if warnings is not None:
        warnings.extend(f"object '{name}': its nested Geometry Nodes instances read the Instancer attributes "
                        f"{', '.join(sorted(instancer_names))} from the instancer object, not from the attributes "
                        "stored on them" for name in sorted(stored.nested))
    return found


def _grid_key(p, cell):
    return tuple(int(np.floor(c / cell)) for c in p)


def add_instance_randoms(gltf_path, depsgraph, object_names=(), instancer_names=(), warnings=None):
    """Write `CAUSTIC_random_id` on every instance node of the written glTF file, and its Object
    and Instancer attributes `object_names`, `instancer_names` (module doc), naming in
    `warnings` what is not read as Cycles reads it; returns how many nodes got a random number."""
    instances = _instances_by_instancer(depsgraph, object_names, instancer_names, warnings)
    if not instances:
        return 0
    with open(gltf_path, encoding="utf-8") as f:
        doc = json.load(f)
    nodes = doc.get("nodes", [])
    positions = None
    written = 0
    for node in nodes:
        candidates = instances.get(node.get("name"))
        if not candidates or not node.get("children"):
            continue
        if positions is None:
            positions = _world_positions(doc)
        # Candidates in cells a few tolerances wide: a child looks in its cell's neighbours.
        cell = 4.0 * _MATCH_TOLERANCE * max(1.0, max(np.abs(q).max() for q, _, _ in candidates))
        grid = {}
        for k, (q, _, _) in enumerate(candidates):
            grid.setdefault(_grid_key(q, cell), []).append(k)
        taken = [False] * len(candidates)
        offsets = [(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1)]
        for child in node["children"]:
            p = positions[child]
            key = _grid_key(p, cell)
            near = sorted(k for o in offsets for k in grid.get(tuple(x + d for x, d in zip(key, o)), ())
                          if np.abs(p - candidates[k][0]).max() <= cell / 4.0)
            if near:
                # The exporter writes a vertex- or face-instanced object twice (as a dupli and
                # as a Geometry Nodes instance, on top of each other): the second copy takes
                # the number of the first.
                k = next((k for k in near if not taken[k]), near[0])
                taken[k] = True
                extras = nodes[child].setdefault("extras", {})
                extras[RANDOM_EXTRA] = candidates[k][1]
                if candidates[k][2]:
                    extras[OBJECT_EXTRA] = candidates[k][2]
                written += 1
    if written:
        with open(gltf_path, "w", encoding="utf-8") as f:
            json.dump(doc, f)
    return written
