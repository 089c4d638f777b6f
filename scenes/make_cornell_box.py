#!/usr/bin/env python3
"""Write scenes/cornell_box.gltf + scenes/cornell_box.bin: the classic Cornell box.

Geometry: the measured data of the Cornell Program of Computer Graphics
(https://www.graphics.cornell.edu/online/box/data.html), given there in millimetres, Y up, and
converted here to metres (x 0.001). glTF is Y up too, so no axis change is needed.

* Every face is a quad of the data split into two triangles; each triangle has its own three
  vertices and its flat geometric normal (some quads of the data are not exactly planar).
* Walls face the inside of the box, block faces face outwards; the winding of every triangle
  agrees with its normal (counter-clockwise seen from the side the normal points to).
* The ceiling is whole (no hole); the light quad sits 0.1 mm below it (y = 548.7 mm), single
  sided (`doubleSided` false), facing down (-Y), as in the pbrt / Mitsuba versions of the scene.
  Caustic, as Cycles on Blender's import, emits from its back face too: that half of its light
  stays in the gap (it counts in the light's power for light selection and photons).
* Materials: glTF metallic-roughness, metallic 0, roughness 1 (Lambertian), with the usual RGB
  approximations of the measured spectra (as in the Mitsuba / pbrt scenes). The light's
  radiance is (17, 12, 4): emissiveFactor (1, 12/17, 4/17) x KHR_materials_emissive_strength 17.
* Camera: the data's camera (position (278, 273, -800) mm, looking along +Z, 35 mm focal length
  on a 25 mm x 25 mm film, i.e. yfov = 2 atan(12.5 / 35) = 39.3077 deg). A glTF camera looks
  down its local -Z, so its node is rotated 180 deg about Y (quaternion [0, 1, 0, 0]); world +X
  then points to the image's left, so the red wall (x ~ 0.55 m) is on the left as in the photos.
* Render settings in scenes[0].extras.caustic: 256 x 256, 64 spp.

Plain Python 3 standard library only; the output is byte-for-byte the same on every run.
Usage: python3 scenes/make_cornell_box.py  (writes next to this script)
"""

import json
import math
import os
import struct

MM = 0.001  # millimetres -> metres

# ---------------------------------------------------------------------------------------------
# The measured data (millimetres), quads in the order given on the Cornell page.
# ---------------------------------------------------------------------------------------------
FLOOR = [[(552.8, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 559.2), (549.6, 0.0, 559.2)]]
CEILING = [[(556.0, 548.8, 0.0), (556.0, 548.8, 559.2), (0.0, 548.8, 559.2), (0.0, 548.8, 0.0)]]
BACK_WALL = [[(549.6, 0.0, 559.2), (0.0, 0.0, 559.2), (0.0, 548.8, 559.2), (556.0, 548.8, 559.2)]]
RIGHT_WALL_GREEN = [[(0.0, 0.0, 559.2), (0.0, 0.0, 0.0), (0.0, 548.8, 0.0), (0.0, 548.8, 559.2)]]
LEFT_WALL_RED = [[(552.8, 0.0, 0.0), (549.6, 0.0, 559.2), (556.0, 548.8, 559.2), (556.0, 548.8, 0.0)]]
SHORT_BLOCK = [
    [(130.0, 165.0, 65.0), (82.0, 165.0, 225.0), (240.0, 165.0, 272.0), (290.0, 165.0, 114.0)],
    [(290.0, 0.0, 114.0), (290.0, 165.0, 114.0), (240.0, 165.0, 272.0), (240.0, 0.0, 272.0)],
    [(130.0, 0.0, 65.0), (130.0, 165.0, 65.0), (290.0, 165.0, 114.0), (290.0, 0.0, 114.0)],
    [(82.0, 0.0, 225.0), (82.0, 165.0, 225.0), (130.0, 165.0, 65.0), (130.0, 0.0, 65.0)],
    [(240.0, 0.0, 272.0), (240.0, 165.0, 272.0), (82.0, 165.0, 225.0), (82.0, 0.0, 225.0)],
]
TALL_BLOCK = [
    [(423.0, 330.0, 247.0), (265.0, 330.0, 296.0), (314.0, 330.0, 456.0), (472.0, 330.0, 406.0)],
    [(423.0, 0.0, 247.0), (423.0, 330.0, 247.0), (472.0, 330.0, 406.0), (472.0, 0.0, 406.0)],
    [(472.0, 0.0, 406.0), (472.0, 330.0, 406.0), (314.0, 330.0, 456.0), (314.0, 0.0, 456.0)],
    [(314.0, 0.0, 456.0), (314.0, 330.0, 456.0), (265.0, 330.0, 296.0), (265.0, 0.0, 296.0)],
    [(265.0, 0.0, 296.0), (265.0, 330.0, 296.0), (423.0, 330.0, 247.0), (423.0, 0.0, 247.0)],
]
LIGHT_Y = 548.7  # the data says 548.8 (flush with the ceiling); 0.1 mm lower avoids coplanarity
LIGHT = [[(343.0, LIGHT_Y, 227.0), (343.0, LIGHT_Y, 332.0), (213.0, LIGHT_Y, 332.0),
          (213.0, LIGHT_Y, 227.0)]]

BOX_CENTRE = (278.0, 274.4, 279.6)  # inside the box: walls face it
SHORT_CENTRE = (186.0, 82.5, 168.5)  # inside the short block: its faces face away from it
TALL_CENTRE = (368.5, 165.0, 351.5)

# ---------------------------------------------------------------------------------------------
# Materials
# ---------------------------------------------------------------------------------------------
WHITE = (0.725, 0.71, 0.68)
RED = (0.63, 0.065, 0.05)
GREEN = (0.14, 0.45, 0.091)
LIGHT_RADIANCE = (17.0, 12.0, 4.0)


def diffuse_material(name, rgb):
    return {
        "name": name,
        "pbrMetallicRoughness": {
            "baseColorFactor": [rgb[0], rgb[1], rgb[2], 1.0],
            "metallicFactor": 0.0,
            "roughnessFactor": 1.0,
        },
        "doubleSided": True,
    }


def light_material(name, radiance):
    strength = max(radiance)
    return {
        "name": name,
        "pbrMetallicRoughness": {
            "baseColorFactor": [0.0, 0.0, 0.0, 1.0],
            "metallicFactor": 0.0,
            "roughnessFactor": 1.0,
        },
        "emissiveFactor": [c / strength for c in radiance],
        "doubleSided": False,
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": strength}},
    }


# ---------------------------------------------------------------------------------------------
# Small vector helpers
# ---------------------------------------------------------------------------------------------
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
    """x rounded to the nearest float32 (what the buffer stores)."""
    return struct.unpack("<f", struct.pack("<f", x))[0]


def short_float(x):
    """The shortest decimal that reads back as the same float32 (for accessor min/max)."""
    target = f32(x)
    for digits in range(1, 18):
        v = float("%.*g" % (digits, target))
        if f32(v) == target:
            return v
    return target


def triangles_of(quads, reference, facing):
    """Split each quad (0,1,2)+(0,2,3) and orient each triangle: facing='towards' makes the
    normal point at the reference point, 'away' away from it, a vector makes it agree with it."""
    tris = []
    for q in quads:
        for tri in ((q[0], q[1], q[2]), (q[0], q[2], q[3])):
            n = cross(sub(tri[1], tri[0]), sub(tri[2], tri[0]))
            if isinstance(facing, tuple):
                want = facing
            else:
                centre = tuple(sum(v[i] for v in tri) / 3.0 for i in range(3))
                to_ref = sub(reference, centre)
                want = to_ref if facing == "towards" else (-to_ref[0], -to_ref[1], -to_ref[2])
            if dot(n, want) < 0.0:
                tri = (tri[0], tri[2], tri[1])
                n = (-n[0], -n[1], -n[2])
            tris.append((tri, normalize(n)))
    return tris


# ---------------------------------------------------------------------------------------------
# glTF writing
# ---------------------------------------------------------------------------------------------
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

    def indices(self, values):
        data = struct.pack("<%dH" % len(values), *values)
        self.accessors.append({"bufferView": self._view(data, 34963), "componentType": 5123,
                               "count": len(values), "type": "SCALAR"})
        return len(self.accessors) - 1

    def mesh(self, name, tris, material):
        positions, normals = [], []
        for tri, n in tris:
            for v in tri:
                positions.append(tuple(c * MM for c in v))
                normals.append(n)
        prim = {
            "attributes": {"POSITION": self.vec3(positions, True),
                           "NORMAL": self.vec3(normals, False)},
            "indices": self.indices(list(range(len(positions)))),
            "material": material,
            "mode": 4,
        }
        return {"name": name, "primitives": [prim]}


def build():
    materials = [
        diffuse_material("white", WHITE),
        diffuse_material("red", RED),
        diffuse_material("green", GREEN),
        light_material("light", LIGHT_RADIANCE),
    ]
    white, red, green, light = 0, 1, 2, 3
    objects = [
        ("floor", triangles_of(FLOOR, BOX_CENTRE, "towards"), white),
        ("ceiling", triangles_of(CEILING, BOX_CENTRE, "towards"), white),
        ("back_wall", triangles_of(BACK_WALL, BOX_CENTRE, "towards"), white),
        ("red_wall", triangles_of(LEFT_WALL_RED, BOX_CENTRE, "towards"), red),
        ("green_wall", triangles_of(RIGHT_WALL_GREEN, BOX_CENTRE, "towards"), green),
        ("short_block", triangles_of(SHORT_BLOCK, SHORT_CENTRE, "away"), white),
        ("tall_block", triangles_of(TALL_BLOCK, TALL_CENTRE, "away"), white),
        ("light", triangles_of(LIGHT, None, (0.0, -1.0, 0.0)), light),
    ]
    for tri, n in objects[-1][1]:
        assert n == (0.0, -1.0, 0.0), "the light must face -Y"

    w = Writer()
    meshes = [w.mesh(name, tris, mat) for name, tris, mat in objects]
    nodes = [{"name": name, "mesh": i} for i, (name, _, _) in enumerate(objects)]
    nodes.append({
        "name": "camera",
        "camera": 0,
        "translation": [278.0 * MM, 273.0 * MM, -800.0 * MM],
        "rotation": [0.0, 1.0, 0.0, 0.0],
    })
    while len(w.bin) % 4:
        w.bin.append(0)

    gltf = {
        "asset": {"version": "2.0", "generator": "caustic scenes/make_cornell_box.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{
            "name": "cornell_box",
            "nodes": list(range(len(nodes))),
            "extras": {"caustic": {"resolution": [256, 256], "spp": 64}},
        }],
        "nodes": nodes,
        "cameras": [{
            "name": "camera",
            "type": "perspective",
            "perspective": {
                "yfov": 2.0 * math.atan(12.5 / 35.0),
                "aspectRatio": 1.0,
                "znear": 0.01,
            },
        }],
        "meshes": meshes,
        "materials": materials,
        "accessors": w.accessors,
        "bufferViews": w.views,
        "buffers": [{"uri": "cornell_box.bin", "byteLength": len(w.bin)}],
    }
    return gltf, bytes(w.bin)


def to_json(value, indent=0):
    """JSON with two-space indentation, but lists of numbers or strings on one line."""
    pad = "  " * indent
    if isinstance(value, dict):
        if not value:
            return "{}"
        items = ['%s  %s: %s' % (pad, json.dumps(k), to_json(v, indent + 1))
                 for k, v in value.items()]
        return "{\n" + ",\n".join(items) + "\n" + pad + "}"
    if isinstance(value, list):
        if all(not isinstance(v, (dict, list)) for v in value):
            return "[" + ", ".join(json.dumps(v) for v in value) + "]"
        items = [pad + "  " + to_json(v, indent + 1) for v in value]
        return "[\n" + ",\n".join(items) + "\n" + pad + "]"
    return json.dumps(value)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    gltf, data = build()
    with open(os.path.join(here, "cornell_box.bin"), "wb") as f:
        f.write(data)
    with open(os.path.join(here, "cornell_box.gltf"), "w", encoding="utf-8", newline="\n") as f:
        f.write(to_json(gltf) + "\n")
    tris = sum(gltf["accessors"][m["primitives"][0]["indices"]]["count"] // 3
               for m in gltf["meshes"])
    print("wrote cornell_box.gltf + cornell_box.bin (%d bytes, %d triangles)" % (len(data), tris))


if __name__ == "__main__":
    main()
