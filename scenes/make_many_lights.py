#!/usr/bin/env python3
"""Write scenes/many_lights.gltf + scenes/many_lights.bin: a street at night under festoon lights.

The scene for light selection (issue 9): a 40 m street between two facades, lit only by
**288 small emitters** made of 2016 emissive triangles (each triangle is one light for Caustic):

* 10 strings of festoon bulbs across the street, 24 bulbs each (240 bulbs), hanging in a sag
  between 5.2 m at the facades and 4.4 m in the middle; each bulb is an octahedron of 5 cm
  radius (8 outward-facing triangles) in one of 8 colours (the hues of bench/suite.py's
  many_lights), radiance 250 x colour;
* 48 lit windows (0.8 m x 1.2 m quads on both facades, two floors), warm white, radiance 1.5,
  facing the street (`doubleSided` false; their back faces, inside the facades, emit too, as
  Cycles renders Blender's import: light selection and photons spend a share there).

Most of each shading point's light comes from a handful of nearby bulbs, so choosing lights by
power wastes most shadow rays, which is what the light tree is for. Four boxes stand in for
parked cars (occlusion and soft shadows). No world: the sky is black.

glTF is Y up; the street runs along X, the facades are at z = +-6 m. The camera stands at the
street's west end at eye height and looks east. Render settings in scenes[0].extras.caustic:
320 x 180, 16 spp.

Plain Python 3 standard library; the output is byte-for-byte the same on every run.
Usage: python3 scenes/make_many_lights.py  (writes next to this script)
"""

import json
import math
import os
import struct

STREET_X = (-20.0, 20.0)
HALF_WIDTH = 6.0
FACADE_HEIGHT = 9.0
STRINGS = 10
BULBS_PER_STRING = 24
BULB_RADIUS = 0.05
BULB_RADIANCE = 250.0
WINDOW_RADIANCE = 1.5
WINDOW_COLOUR = (1.0, 0.75, 0.45)
COLOURS = 8


def hue(c):
    """The 8 colours of bench/suite.py's many_lights (a cosine palette)."""
    h = c / COLOURS
    return tuple(0.5 + 0.5 * math.cos(2 * math.pi * (h + k / 3)) for k in range(3))


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def normalize(a):
    n = math.sqrt(dot(a, a))
    return (a[0] / n, a[1] / n, a[2] / n)


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def short_float(x):
    """The shortest decimal that reads back as the same float32 (for accessor min/max)."""
    target = f32(x)
    for digits in range(1, 18):
        v = float("%.*g" % (digits, target))
        if f32(v) == target:
            return v
    return target


def oriented(tri, want):
    """The triangle wound so that its normal agrees with `want`, and that normal."""
    n = cross(sub(tri[1], tri[0]), sub(tri[2], tri[0]))
    if dot(n, want) < 0.0:
        tri = (tri[0], tri[2], tri[1])
        n = (-n[0], -n[1], -n[2])
    return tri, normalize(n)


def quad(corners, want):
    q = corners
    return [oriented((q[0], q[1], q[2]), want), oriented((q[0], q[2], q[3]), want)]


def box(lo, hi):
    """An axis-aligned box with outward normals."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    c = ((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2)
    faces = [
        [(x0, y0, z0), (x0, y1, z0), (x0, y1, z1), (x0, y0, z1)],
        [(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)],
        [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)],
        [(x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1)],
        [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0)],
        [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],
    ]
    tris = []
    for f in faces:
        fc = tuple(sum(v[i] for v in f) / 4 for i in range(3))
        tris += quad(f, sub(fc, c))
    return tris


def octahedron(centre, r):
    """8 outward-facing triangles."""
    x, y, z = centre
    px, nx = (x + r, y, z), (x - r, y, z)
    py, ny = (x, y + r, z), (x, y - r, z)
    pz, nz = (x, y, z + r), (x, y, z - r)
    tris = []
    for a in (px, nx):
        for b in (py, ny):
            for c in (pz, nz):
                t = (a, b, c)
                fc = tuple(sum(v[i] for v in t) / 3 for i in range(3))
                tris.append(oriented(t, sub(fc, centre)))
    return tris


def diffuse(name, rgb, roughness=1.0):
    return {
        "name": name,
        "pbrMetallicRoughness": {"baseColorFactor": [*rgb, 1.0], "metallicFactor": 0.0,
                                 "roughnessFactor": roughness},
    }


def emitter(name, rgb, strength):
    return {
        "name": name,
        "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0,
                                 "roughnessFactor": 1.0},
        "emissiveFactor": list(rgb),
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": strength}},
    }


class Writer:
    def __init__(self):
        self.bin = bytearray()
        self.views = []
        self.accessors = []

    def _view(self, data, target):
        while len(self.bin) % 4:
            self.bin.append(0)
        self.views.append({"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data),
                           "target": target})
        self.bin += data
        return len(self.views) - 1

    def vec3(self, values, with_bounds):
        data = b"".join(struct.pack("<3f", *v) for v in values)
        acc = {"bufferView": self._view(data, 34962), "componentType": 5126,
               "count": len(values), "type": "VEC3"}
        if with_bounds:
            acc["min"] = [short_float(min(v[i] for v in values)) for i in range(3)]
            acc["max"] = [short_float(max(v[i] for v in values)) for i in range(3)]
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def indices(self, count):
        data = struct.pack("<%dI" % count, *range(count))
        self.accessors.append({"bufferView": self._view(data, 34963), "componentType": 5125,
                               "count": count, "type": "SCALAR"})
        return len(self.accessors) - 1

    def mesh(self, name, tris, material):
        positions = [v for tri, _ in tris for v in tri]
        normals = [n for _, n in tris for _ in range(3)]
        prim = {
            "attributes": {"POSITION": self.vec3(positions, True), "NORMAL": self.vec3(normals, False)},
            "indices": self.indices(len(positions)),
            "material": material,
            "mode": 4,
        }
        return {"name": name, "primitives": [prim]}


def build():
    x0, x1 = STREET_X
    w = HALF_WIDTH
    materials = [
        diffuse("asphalt", (0.25, 0.25, 0.27)),
        diffuse("facade", (0.6, 0.52, 0.42)),
        diffuse("car", (0.35, 0.4, 0.5), roughness=0.35),
        emitter("window", WINDOW_COLOUR, WINDOW_RADIANCE),
    ] + [emitter("bulb%d" % c, hue(c), BULB_RADIANCE) for c in range(COLOURS)]
    asphalt, facade, car, window = 0, 1, 2, 3

    objects = [
        ("street", quad([(x0, 0, -w), (x1, 0, -w), (x1, 0, w), (x0, 0, w)], (0, 1, 0)), asphalt),
        ("facade_south", quad([(x0, 0, -w), (x1, 0, -w), (x1, FACADE_HEIGHT, -w), (x0, FACADE_HEIGHT, -w)],
                              (0, 0, 1)), facade),
        ("facade_north", quad([(x0, 0, w), (x1, 0, w), (x1, FACADE_HEIGHT, w), (x0, FACADE_HEIGHT, w)],
                              (0, 0, -1)), facade),
        ("end_wall", quad([(x1, 0, -w), (x1, 0, w), (x1, FACADE_HEIGHT, w), (x1, FACADE_HEIGHT, -w)],
                          (-1, 0, 0)), facade),
    ]
    cars = []
    for cx, cz in ((-9.0, -4.2), (-2.5, 4.1), (4.0, -4.3), (11.0, 4.2)):
        cars += box((cx - 2.1, 0.0, cz - 0.9), (cx + 2.1, 1.4, cz + 0.9))
    objects.append(("cars", cars, car))

    windows = []
    for side in (-1.0, 1.0):
        z = side * (w - 0.01)
        for floor_y in (3.0, 6.0):
            for k in range(12):
                cx = x0 + 2.0 + k * 3.2
                windows += quad([(cx - 0.4, floor_y, z), (cx + 0.4, floor_y, z), (cx + 0.4, floor_y + 1.2, z),
                                 (cx - 0.4, floor_y + 1.2, z)], (0, 0, -side))
    objects.append(("windows", windows, window))

    bulbs = [[] for _ in range(COLOURS)]
    for s in range(STRINGS):
        x = x0 + 3.0 + s * (x1 - x0 - 6.0) / (STRINGS - 1)
        for b in range(BULBS_PER_STRING):
            z = -w + 0.25 + b * (2 * w - 0.5) / (BULBS_PER_STRING - 1)
            y = 5.2 - 0.8 * (1.0 - (z / w) ** 2)
            bulbs[(s * 3 + b) % COLOURS] += octahedron((x, y, z), BULB_RADIUS)
    for c in range(COLOURS):
        objects.append(("bulbs%d" % c, bulbs[c], 4 + c))

    wr = Writer()
    meshes = [wr.mesh(name, tris, mat) for name, tris, mat in objects]
    nodes = [{"name": name, "mesh": i} for i, (name, _, _) in enumerate(objects)]
    # Looking along +X (a glTF camera looks down its -Z): -90 deg about Y, then 4 deg up.
    yaw = (0.0, math.sin(-math.pi / 4), 0.0, math.cos(-math.pi / 4))
    pitch = (math.sin(math.radians(2.0)), 0.0, 0.0, math.cos(math.radians(2.0)))

    def qmul(a, b):
        ax, ay, az, aw = a
        bx, by, bz, bw = b
        return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)

    nodes.append({"name": "camera", "camera": 0, "translation": [x0 + 1.0, 1.7, 0.0],
                  "rotation": [round(c, 9) for c in qmul(yaw, pitch)]})
    while len(wr.bin) % 4:
        wr.bin.append(0)
    gltf = {
        "asset": {"version": "2.0", "generator": "caustic scenes/make_many_lights.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{
            "name": "many_lights",
            "nodes": list(range(len(nodes))),
            "extras": {"caustic": {"resolution": [320, 180], "spp": 16}},
        }],
        "nodes": nodes,
        "cameras": [{"name": "camera", "type": "perspective",
                     "perspective": {"yfov": math.radians(50.0), "aspectRatio": 16 / 9, "znear": 0.01}}],
        "meshes": meshes,
        "materials": materials,
        "accessors": wr.accessors,
        "bufferViews": wr.views,
        "buffers": [{"uri": "many_lights.bin", "byteLength": len(wr.bin)}],
    }
    emitters = len(windows) // 2 + STRINGS * BULBS_PER_STRING
    emissive_tris = len(windows) + sum(len(b) for b in bulbs)
    return gltf, bytes(wr.bin), emitters, emissive_tris


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    gltf, data, emitters, emissive_tris = build()
    with open(os.path.join(here, "many_lights.bin"), "wb") as f:
        f.write(data)
    with open(os.path.join(here, "many_lights.gltf"), "w", encoding="utf-8", newline="\n") as f:
        f.write(json.dumps(gltf, indent=1) + "\n")
    print("wrote many_lights.gltf + many_lights.bin (%d bytes, %d emitters, %d emissive triangles)"
          % (len(data), emitters, emissive_tris))


if __name__ == "__main__":
    main()
