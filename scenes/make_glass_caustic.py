"""Writes scenes/glass_caustic.gltf (+ glass_caustic.bin): the caustic test scene.

A clear glass sphere and a smaller sphere of red absorbing glass on a white diffuse floor,
lit by a small emissive quad above them, with a mirror behind that shows the caustics
from the other side. Caustics (light -> glass -> floor -> camera) are what path tracing
finds slowly and photon mapping quickly; the mirror adds L S+ D S E paths.

Standard library only; deterministic output. Run: python3 scenes/make_glass_caustic.py
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
            "asset": {"version": "2.0", "generator": "caustic scenes/make_glass_caustic.py"},
            "extensionsUsed": [
                "KHR_materials_emissive_strength",
                "KHR_materials_transmission",
                "KHR_materials_volume",
            ],
            "scene": 0,
            "scenes": [{"name": "glass_caustic", "nodes": [],
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
    """Two triangles over four corners given counter-clockwise seen from `normal`'s side."""
    return list(corners), [normal] * 4, [0, 1, 2, 0, 2, 3]


def sphere(radius, segments=48, rings=24):
    """A UV sphere with smooth normals, counter-clockwise from outside."""
    positions, normals, indices = [], [], []
    for r in range(rings + 1):
        theta = math.pi * r / rings
        for s in range(segments + 1):
            phi = 2 * math.pi * s / segments
            n = (math.sin(theta) * math.cos(phi), math.cos(theta), -math.sin(theta) * math.sin(phi))
            normals.append(n)
            positions.append(tuple(radius * c for c in n))
    for r in range(rings):
        for s in range(segments):
            a = r * (segments + 1) + s
            b = a + segments + 1
            if r != 0:
                indices += [a, b, a + 1]
            if r != rings - 1:
                indices += [a + 1, b, b + 1]
    return positions, normals, indices


def main():
    g = Builder()
    white = g.material({"name": "floor", "pbrMetallicRoughness": {
        "baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "doubleSided": True})
    mirror = g.material({"name": "mirror", "pbrMetallicRoughness": {
        "baseColorFactor": [0.95, 0.95, 0.95, 1], "metallicFactor": 1.0, "roughnessFactor": 0.0},
        "doubleSided": True})
    glass = g.material({"name": "clear_glass", "pbrMetallicRoughness": {
        "baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                       "KHR_materials_volume": {"thicknessFactor": 0.7}}})
    red_glass = g.material({"name": "red_glass", "pbrMetallicRoughness": {
        "baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                       "KHR_materials_volume": {"thicknessFactor": 0.5,
                                                "attenuationColor": [0.9, 0.25, 0.15],
                                                "attenuationDistance": 0.3}}})
    light = g.material({"name": "light", "pbrMetallicRoughness": {
        "baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0},
        "emissiveFactor": [1.0, 0.9, 0.8],
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 300.0}}})

    g.mesh("floor", *quad([(-2, 0, 2), (2, 0, 2), (2, 0, -2), (-2, 0, -2)], (0, 1, 0)), white)
    g.mesh("mirror", *quad([(-1.4, 0, -1.2), (1.4, 0, -1.2), (1.4, 1.4, -1.2), (-1.4, 1.4, -1.2)],
                           (0, 0, 1)), mirror)
    g.mesh("glass_sphere", *sphere(0.35), glass, translation=(-0.35, 0.35, 0.0))
    g.mesh("red_glass_sphere", *sphere(0.25), red_glass, translation=(0.5, 0.25, 0.25))
    # A 0.2 m square light 2 m up, facing down (`doubleSided` false; its back face emits upwards
    # too, as Cycles renders Blender's import).
    h, y = 0.1, 2.0
    g.mesh("light", *quad([(-h, y, -h), (h, y, -h), (h, y, h), (-h, y, h)], (0, -1, 0)), light,
           translation=(0.05, 0.0, 0.35))

    g.doc["cameras"].append({"name": "camera", "type": "perspective", "perspective": {
        "yfov": math.radians(38.0), "aspectRatio": 320 / 240, "znear": 0.01}})
    # Look from (0, 1.1, 2.7) toward (0, 0.3, -0.2): a rotation about X by the pitch.
    eye, target = (0.0, 1.1, 2.7), (0.0, 0.3, -0.2)
    d = [t - e for t, e in zip(target, eye)]
    pitch = math.atan2(d[1], -d[2])  # negative: looking down
    q = [math.sin(pitch / 2), 0.0, 0.0, math.cos(pitch / 2)]
    g.node({"name": "camera", "camera": 0, "translation": list(eye), "rotation": q})
    g.write("glass_caustic")


if __name__ == "__main__":
    main()
