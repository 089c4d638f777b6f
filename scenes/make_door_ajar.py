"""Writes scenes/door_ajar.gltf (+ door_ajar.bin): two rooms joined by a door left ajar.

The camera's room is lit only through the narrow wedge between the door's edge and its frame:
the lamp (a small emissive panel facing the door) is in the other room. Nearly all light that
reaches the camera has passed the gap, which path tracing finds only by chance (light
sampling from the camera's room is almost always blocked) and bidirectional path tracing finds
by tracing light through the gap and connecting it to the camera's paths: Veach's classic
"light through a door" scene, the benchmark scene of the BDPT issue.

Standard library only; deterministic output. Run: python3 scenes/make_door_ajar.py
"""

import json
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))


class Builder:
    """Accumulates meshes into one binary buffer and a glTF document."""

    def __init__(self):
        self.bin = bytearray()
        self.doc = {
            "asset": {"version": "2.0", "generator": "caustic scenes/make_door_ajar.py"},
            "extensionsUsed": ["KHR_materials_emissive_strength"],
            "scene": 0,
            "scenes": [{"name": "door_ajar", "nodes": [],
                        "extras": {"caustic": {"resolution": [320, 240], "spp": 64}}}],
            "nodes": [], "meshes": [], "materials": [], "accessors": [], "bufferViews": [],
            "cameras": [],
        }

    def view(self, data, target):
        while len(self.bin) % 4:
            self.bin.append(0)
        offset = len(self.bin)
        self.bin += data
        self.doc["bufferViews"].append(
            {"buffer": 0, "byteOffset": offset, "byteLength": len(data), "target": target})
        return len(self.doc["bufferViews"]) - 1

    def accessor(self, view, ctype, count, kind, lo=None, hi=None):
        acc = {"bufferView": view, "componentType": ctype, "count": count, "type": kind}
        if lo is not None:
            acc["min"], acc["max"] = lo, hi
        self.doc["accessors"].append(acc)
        return len(self.doc["accessors"]) - 1

    def material(self, mat):
        self.doc["materials"].append(mat)
        return len(self.doc["materials"]) - 1

    def mesh(self, name, positions, normals, indices, material, translation=(0, 0, 0)):
        pos = b"".join(struct.pack("<3f", *p) for p in positions)
        nrm = b"".join(struct.pack("<3f", *n) for n in normals)
        idx = b"".join(struct.pack("<I", i) for i in indices)
        lo = [min(p[k] for p in positions) for k in range(3)]
        hi = [max(p[k] for p in positions) for k in range(3)]
        pa = self.accessor(self.view(pos, 34962), 5126, len(positions), "VEC3", lo, hi)
        na = self.accessor(self.view(nrm, 34962), 5126, len(normals), "VEC3")
        ia = self.accessor(self.view(idx, 34963), 5125, len(indices), "SCALAR")
        self.doc["meshes"].append({"name": name, "primitives": [
            {"attributes": {"POSITION": pa, "NORMAL": na}, "indices": ia, "material": material}]})
        self.node({"name": name, "mesh": len(self.doc["meshes"]) - 1,
                   "translation": list(translation)})

    def node(self, node):
        self.doc["nodes"].append(node)
        self.doc["scenes"][0]["nodes"].append(len(self.doc["nodes"]) - 1)

    def write(self, name):
        self.doc["buffers"] = [{"byteLength": len(self.bin), "uri": name + ".bin"}]
        with open(os.path.join(HERE, name + ".bin"), "wb") as f:
            f.write(self.bin)
        with open(os.path.join(HERE, name + ".gltf"), "w") as f:
            json.dump(self.doc, f, indent=1, sort_keys=True)
            f.write("\n")


def quad(corners, normal):
    """Two triangles over four corners, wound counter-clockwise seen from `normal`'s side
    (the corners are reversed when they go round the other way)."""
    a, b, c = corners[0], corners[1], corners[2]
    e1 = [b[k] - a[k] for k in range(3)]
    e2 = [c[k] - a[k] for k in range(3)]
    cross = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0])
    if sum(cross[k] * normal[k] for k in range(3)) < 0:
        corners = list(reversed(corners))
    return list(corners), [normal] * 4, [0, 1, 2, 0, 2, 3]


def box_inside(lo, hi):
    """The six faces of a room from `lo` to `hi`, each counter-clockwise seen from inside."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    return [
        ([(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)], (0, 1, 0)),  # floor
        ([(x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)], (0, -1, 0)),  # ceiling
        ([(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)], (1, 0, 0)),  # left wall
        ([(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)], (-1, 0, 0)),  # right wall
    ]


def main():
    g = Builder()
    wall = g.material({"name": "wall", "pbrMetallicRoughness": {
        "baseColorFactor": [0.8, 0.78, 0.74, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "doubleSided": True})
    floor = g.material({"name": "floor", "pbrMetallicRoughness": {
        "baseColorFactor": [0.45, 0.3, 0.2, 1], "metallicFactor": 0.0, "roughnessFactor": 0.5},
        "doubleSided": True})
    door = g.material({"name": "door", "pbrMetallicRoughness": {
        "baseColorFactor": [0.6, 0.65, 0.7, 1], "metallicFactor": 0.0, "roughnessFactor": 0.7},
        "doubleSided": True})
    brass = g.material({"name": "brass", "pbrMetallicRoughness": {
        "baseColorFactor": [0.9, 0.75, 0.4, 1], "metallicFactor": 1.0, "roughnessFactor": 0.25},
        "doubleSided": True})
    lamp = g.material({"name": "lamp", "pbrMetallicRoughness": {
        "baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0},
        "emissiveFactor": [1.0, 0.85, 0.65],
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 400.0}}})

    height = 2.5
    # Both rooms share the floor, ceiling and side walls: x in [-2, 2], z in [-4, 4].
    faces = box_inside((-2, 0, -4), (2, height, 4))
    for i, (corners, normal) in enumerate(faces):
        g.mesh(f"room_{i}", *quad(corners, normal), floor if i == 0 else wall)
    g.mesh("back_wall_lamp_room", *quad([(-2, 0, -4), (-2, height, -4), (2, height, -4), (2, 0, -4)],
                                        (0, 0, 1)), wall)
    g.mesh("back_wall_camera_room", *quad([(-2, 0, 4), (2, 0, 4), (2, height, 4), (-2, height, 4)],
                                          (0, 0, -1)), wall)
    # The wall between the rooms at z = 0 with a door opening x in [0.2, 1.0], y in [0, 2].
    d0, d1, dh = 0.2, 1.0, 2.0
    g.mesh("wall_left", *quad([(-2, 0, 0), (d0, 0, 0), (d0, height, 0), (-2, height, 0)], (0, 0, 1)), wall)
    g.mesh("wall_right", *quad([(d1, 0, 0), (2, 0, 0), (2, height, 0), (d1, height, 0)], (0, 0, 1)), wall)
    g.mesh("wall_lintel", *quad([(d0, dh, 0), (d1, dh, 0), (d1, height, 0), (d0, height, 0)], (0, 0, 1)), wall)
    # The door, hinged at x = d1 and opened 6 degrees into the lamp's room: a wedge-shaped
    # gap of about 8 cm at the latch side.
    angle = math.radians(6.0)
    width = d1 - d0
    ex, ez = d1 - width * math.cos(angle), -width * math.sin(angle)
    g.mesh("door", *quad([(ex, 0, ez), (d1, 0, 0), (d1, dh, 0), (ex, dh, ez)], (0, 0, 1)), door)
    # A brass box in the camera's room to catch glossy light from the gap.
    lo, hi = (-0.9, 0.0, 1.2), (-0.3, 0.6, 1.8)
    box = [
        ([(lo[0], hi[1], lo[2]), (lo[0], hi[1], hi[2]), (hi[0], hi[1], hi[2]), (hi[0], hi[1], lo[2])], (0, 1, 0)),
        ([(lo[0], lo[1], hi[2]), (hi[0], lo[1], hi[2]), (hi[0], hi[1], hi[2]), (lo[0], hi[1], hi[2])], (0, 0, 1)),
        ([(lo[0], lo[1], lo[2]), (lo[0], hi[1], lo[2]), (hi[0], hi[1], lo[2]), (hi[0], lo[1], lo[2])], (0, 0, -1)),
        ([(lo[0], lo[1], lo[2]), (lo[0], lo[1], hi[2]), (lo[0], hi[1], hi[2]), (lo[0], hi[1], lo[2])], (-1, 0, 0)),
        ([(hi[0], lo[1], lo[2]), (hi[0], hi[1], lo[2]), (hi[0], hi[1], hi[2]), (hi[0], lo[1], hi[2])], (1, 0, 0)),
    ]
    for i, (corners, normal) in enumerate(box):
        g.mesh(f"brass_{i}", *quad(corners, normal), brass)
    # The lamp: a 0.4 m square panel in the lamp room facing the door, so that part of its
    # light falls straight through the gap (Veach's arrangement) and the rest lights the
    # camera's room after bouncing in the lamp room (its back face emits too, into the lamp
    # room, as Cycles renders Blender's import of a single-sided emitter).
    h, z = 0.2, -1.5
    g.mesh("lamp", *quad([(-h, 1.0 - h, z), (h, 1.0 - h, z), (h, 1.0 + h, z), (-h, 1.0 + h, z)], (0, 0, 1)),
           lamp, translation=(0.4, 0.0, 0.0))

    g.doc["cameras"].append({"name": "camera", "type": "perspective", "perspective": {
        "yfov": math.radians(50.0), "aspectRatio": 320 / 240, "znear": 0.01}})
    # From the camera room's far corner toward the door.
    eye, target = (-1.5, 1.5, 3.8), (0.5, 0.9, 0.0)
    d = [t - e for t, e in zip(target, eye)]
    yaw = math.atan2(-d[0], -d[2])
    pitch = math.atan2(d[1], math.hypot(d[0], d[2]))
    cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    # q = yaw about Y, then pitch about the yawed X.
    q = [cy * sp, sy * cp, -sy * sp, cy * cp]
    g.node({"name": "camera", "camera": 0, "translation": list(eye), "rotation": q})
    g.write("door_ajar")


if __name__ == "__main__":
    main()
