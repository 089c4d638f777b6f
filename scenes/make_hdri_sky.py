#!/usr/bin/env python3
"""Write scenes/hdri_sky.gltf + .bin + scenes/hdri_sky.hdr: objects lit only by a procedural HDR sky.

The world scene of issue 9. The sky is computed here and written as a 512 x 256 equirectangular
Radiance .hdr (RGBE, run-length encoded scanlines) in Blender's Environment Texture mapping
(docs/contract.md, CAUSTIC_world): with Blender's axes (z up), u = 0.5 - atan2(y, x) / 2pi,
v = 0.5 + asin(z) / pi, the top row being the zenith.

* Sky: a gradient from a pale horizon (0.9, 0.95, 1.1) to a blue zenith (0.25, 0.45, 0.9) times
  0.8; below the horizon a brown ground (0.3, 0.24, 0.18) x 0.5.
* Sun: a disc of 1.5 deg radius at elevation 30 deg, azimuth 60 deg (Blender's frame), radiance
  (3000, 2850, 2600), with a glow 20 exp(-angle / 4 deg) around it; the disc gives about three
  times the sky's irradiance on a surface facing it, so shadows are sharp but not black.
* The world is rotated by 0.5 rad about Z (a Mapping node's rotation, `rotation` in
  CAUSTIC_world), so the sun stands at azimuth 60 + 28.6 deg.

Objects on a 20 m grey ground (glTF, Y up): three boxes, a pillar, a rough metal sphere and a
glossy blue sphere (UV spheres, 32 x 16). The camera sees the sky (extras.caustic.transparent
false). Render settings: 320 x 180, 32 spp.

Plain Python 3 standard library; byte-for-byte the same output on every run.
Usage: python3 scenes/make_hdri_sky.py  (writes next to this script)
"""

import json
import math
import os
import struct
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_many_lights import Writer, box, oriented, quad  # noqa: E402

WIDTH, HEIGHT = 512, 256
SUN_ELEVATION, SUN_AZIMUTH = math.radians(30.0), math.radians(60.0)
SUN_RADIUS = math.radians(1.5)
SUN_RADIANCE = (3000.0, 2850.0, 2600.0)
WORLD_ROTATION = 0.5


def sky(el, az):
    """Radiance of the sky at elevation `el`, azimuth `az` (radians, Blender's frame)."""
    if el > 0.0:
        t = math.sin(el) ** 0.5
        horizon, zenith = (0.9, 0.95, 1.1), (0.25, 0.45, 0.9)
        rgb = [0.8 * (h + (z - h) * t) for h, z in zip(horizon, zenith)]
    else:
        rgb = [0.5 * c for c in (0.3, 0.24, 0.18)]
    d = (math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el))
    s = (math.cos(SUN_ELEVATION) * math.cos(SUN_AZIMUTH), math.cos(SUN_ELEVATION) * math.sin(SUN_AZIMUTH),
         math.sin(SUN_ELEVATION))
    angle = math.acos(max(-1.0, min(1.0, sum(a * b for a, b in zip(d, s)))))
    glow = 20.0 * math.exp(-angle / math.radians(4.0))
    rgb = [c + glow * w for c, w in zip(rgb, (1.0, 0.9, 0.7))]
    if angle < SUN_RADIUS:
        rgb = [c + sun for c, sun in zip(rgb, SUN_RADIANCE)]
    return rgb


def rgbe(rgb):
    m = max(rgb)
    if m < 1e-32:
        return bytes(4)
    mant, e = math.frexp(m)
    scale = mant * 256.0 / m
    return bytes([min(255, int(c * scale)) for c in rgb] + [e + 128])


def write_hdr(path):
    rows = []
    for i in range(HEIGHT):
        v = 1.0 - (i + 0.5) / HEIGHT
        el = (v - 0.5) * math.pi
        pixels = []
        for j in range(WIDTH):
            u = (j + 0.5) / WIDTH
            az = (0.5 - u) * 2.0 * math.pi
            pixels.append(rgbe(sky(el, az)))
        # New-style RLE scanline: a header, then each channel as literal packets of <= 128.
        line = bytearray([2, 2, WIDTH >> 8, WIDTH & 255])
        for ch in range(4):
            data = bytes(p[ch] for p in pixels)
            for k in range(0, WIDTH, 128):
                chunk = data[k:k + 128]
                line.append(len(chunk))
                line += chunk
        rows.append(bytes(line))
    header = b"#?RADIANCE\n# caustic scenes/make_hdri_sky.py\nFORMAT=32-bit_rle_rgbe\n\n"
    header += b"-Y %d +X %d\n" % (HEIGHT, WIDTH)
    with open(path, "wb") as f:
        f.write(header + b"".join(rows))


def uv_sphere(centre, r, nu=32, nv=16):
    tris = []

    def pt(i, j):
        th, ph = math.pi * j / nv, 2 * math.pi * i / nu
        return (centre[0] + r * math.sin(th) * math.cos(ph), centre[1] + r * math.cos(th),
                centre[2] + r * math.sin(th) * math.sin(ph))

    for i in range(nu):
        for j in range(nv):
            a, b, c, d = pt(i, j), pt(i + 1, j), pt(i + 1, j + 1), pt(i, j + 1)
            for t in ((a, b, c), (a, c, d)):
                n = tuple(sum(v[k] for v in t) / 3 - centre[k] for k in range(3))
                if len({tuple(round(x, 9) for x in v) for v in t}) == 3:
                    tris.append(oriented(t, n))
    return tris


def material(name, rgb, metallic=0.0, roughness=1.0):
    return {"name": name, "pbrMetallicRoughness": {"baseColorFactor": [*rgb, 1.0], "metallicFactor": metallic,
                                                    "roughnessFactor": roughness}}


def build():
    materials = [material("ground", (0.5, 0.5, 0.5)), material("stone", (0.7, 0.65, 0.6)),
                 material("metal", (0.9, 0.75, 0.5), metallic=1.0, roughness=0.25),
                 material("glossy", (0.15, 0.3, 0.8), roughness=0.15)]
    g = 10.0
    objects = [
        ("ground", quad([(-g, 0, -g), (g, 0, -g), (g, 0, g), (-g, 0, g)], (0, 1, 0)), 0),
        ("boxes", box((-2.5, 0, -1.0), (-1.5, 1.0, 0.0)) + box((1.2, 0, -2.2), (2.0, 0.6, -1.4))
         + box((-0.6, 0, -3.5), (0.4, 0.5, -2.5)) + box((2.8, 0, -4.0), (3.3, 2.5, -3.5)), 1),
        ("metal_sphere", uv_sphere((0.0, 0.7, -0.8), 0.7), 2),
        ("glossy_sphere", uv_sphere((1.9, 0.45, 0.3), 0.45), 3),
    ]
    w = Writer()
    meshes = [w.mesh(name, tris, mat) for name, tris, mat in objects]
    nodes = [{"name": name, "mesh": i} for i, (name, _, _) in enumerate(objects)]
    # Camera at (0, 1.6, 6) looking along -Z, 8 degrees down.
    pitch = math.radians(-8.0)
    nodes.append({"name": "camera", "camera": 0, "translation": [0.0, 1.6, 6.0],
                  "rotation": [round(math.sin(pitch / 2), 9), 0.0, 0.0, round(math.cos(pitch / 2), 9)]})
    while len(w.bin) % 4:
        w.bin.append(0)
    gltf = {
        "asset": {"version": "2.0", "generator": "caustic scenes/make_hdri_sky.py"},
        "extensionsUsed": ["CAUSTIC_world"],
        "scene": 0,
        "scenes": [{
            "name": "hdri_sky",
            "nodes": list(range(len(nodes))),
            "extensions": {"CAUSTIC_world": {"image": "hdri_sky.hdr", "strength": 1.0, "rotation": WORLD_ROTATION}},
            "extras": {"caustic": {"resolution": [320, 180], "spp": 32, "transparent": False}},
        }],
        "nodes": nodes,
        "cameras": [{"name": "camera", "type": "perspective",
                     "perspective": {"yfov": math.radians(45.0), "aspectRatio": 16 / 9, "znear": 0.01}}],
        "meshes": meshes,
        "materials": materials,
        "accessors": w.accessors,
        "bufferViews": w.views,
        "buffers": [{"uri": "hdri_sky.bin", "byteLength": len(w.bin)}],
    }
    return gltf, bytes(w.bin)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    write_hdr(os.path.join(here, "hdri_sky.hdr"))
    gltf, data = build()
    with open(os.path.join(here, "hdri_sky.bin"), "wb") as f:
        f.write(data)
    with open(os.path.join(here, "hdri_sky.gltf"), "w", encoding="utf-8", newline="\n") as f:
        f.write(json.dumps(gltf, indent=1) + "\n")
    print("wrote hdri_sky.gltf + hdri_sky.bin (%d bytes) + hdri_sky.hdr (%d x %d)" % (len(data), WIDTH, HEIGHT))


if __name__ == "__main__":
    main()
