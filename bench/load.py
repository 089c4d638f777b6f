"""Loader benchmark: a DamagedHelmet-sized asset (15k triangles, 2048² base colour, normal and
emissive textures, no TANGENT attribute), generated here so that nothing large is committed.

Usage:
    cargo build --release --example load_profile && cargo build --release
    python3 bench/load.py [--out DIR] [--triangles N] [--texture SIDE] [--repeats R]

Prints the loader's time per phase (parse, image decoding, materials, mesh, MikkTSpace
tangents, emitter power; from `examples/load_profile.rs`) and the BVH build, the texels read
for emitter power,
and the wall time of `caustic info --json` (which also includes process start-up).
Quote the phases' ratios, not the seconds, across machines.
"""
import argparse
import json
import math
import os
import struct
import subprocess
import sys
import tempfile
import time
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def png(side, row):
    """An RGB PNG of side², row(y) giving each row's bytes (3·side of them)."""
    raw = b"".join(b"\x00" + row(y) for y in range(side))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", side, side, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw, 1)) + chunk(b"IEND", b""))


def textures(side):
    """Base colour, normal map (gentle bumps) and emissive (lit panels on black), all varying."""
    xs = range(side)
    def base(y):
        return bytes(v for x in xs for v in ((x * 255 // side), (y * 255 // side), ((x ^ y) & 255)))
    def normal(y):
        return bytes(v for x in xs for v in (128 + ((x >> 4) % 7) * 8 - 24, 128 + ((y >> 4) % 5) * 8 - 16, 230))
    def emissive(y):
        lit = (y // 64) % 4 == 0
        return bytes(v for x in xs for v in ((255, 200, 80) if lit and (x // 64) % 3 == 0 else (0, 0, 0)))
    return {"base": png(side, base), "normal": png(side, normal), "emissive": png(side, emissive)}


def sphere(triangles):
    """A UV sphere with about `triangles` triangles: positions, normals, UVs, indices."""
    n = max(2, int(math.sqrt(triangles / 2)))
    pos, nrm, uv, idx = [], [], [], []
    for j in range(n + 1):
        theta = math.pi * j / n
        for i in range(n + 1):
            phi = 2 * math.pi * i / n
            p = (math.sin(theta) * math.cos(phi), math.cos(theta), math.sin(theta) * math.sin(phi))
            pos += p
            nrm += p
            uv += (i / n, j / n)
    for j in range(n):
        for i in range(n):
            a, b = j * (n + 1) + i, j * (n + 1) + i + 1
            c, d = a + n + 1, b + n + 1
            idx += (a, c, b, b, c, d)
    return pos, nrm, uv, idx


def write_asset(out, triangles, side):
    os.makedirs(out, exist_ok=True)
    pos, nrm, uv, idx = sphere(triangles)
    blobs = [struct.pack(f"<{len(pos)}f", *pos), struct.pack(f"<{len(nrm)}f", *nrm),
             struct.pack(f"<{len(uv)}f", *uv), struct.pack(f"<{len(idx)}I", *idx)]
    views, offset = [], 0
    for b in blobs:
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(b)})
        offset += len(b)
    with open(os.path.join(out, "helmet.bin"), "wb") as f:
        f.write(b"".join(blobs))
    for name, data in textures(side).items():
        with open(os.path.join(out, f"{name}.png"), "wb") as f:
            f.write(data)
    count = len(pos) // 3
    doc = {
        "asset": {"version": "2.0", "generator": "bench/load.py"},
        "buffers": [{"uri": "helmet.bin", "byteLength": offset}],
        "bufferViews": views,
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": count, "type": "VEC3",
             "min": [-1, -1, -1], "max": [1, 1, 1]},
            {"bufferView": 1, "componentType": 5126, "count": count, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": count, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5125, "count": len(idx), "type": "SCALAR"},
        ],
        "images": [{"uri": f"{n}.png"} for n in ("base", "normal", "emissive")],
        "textures": [{"source": i} for i in range(3)],
        "materials": [{"name": "helmet", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}},
                       "normalTexture": {"index": 1}, "emissiveTexture": {"index": 2},
                       "emissiveFactor": [1, 1, 1]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                                    "indices": 3, "material": 0}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    }
    path = os.path.join(out, "helmet.gltf")
    with open(path, "w") as f:
        json.dump(doc, f)
    return path, len(idx) // 3


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None)
    ap.add_argument("--triangles", type=int, default=15000)
    ap.add_argument("--texture", type=int, default=2048)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    binary = os.environ.get("CAUSTIC_BINARY", os.path.join(target, "release", "caustic"))
    profiler = os.path.join(target, "release", "examples", "load_profile")
    out = args.out or tempfile.mkdtemp(prefix="caustic-load-")
    t0 = time.time()
    path, tris = write_asset(out, args.triangles, args.texture)
    print(f"asset: {path} ({tris} triangles, 3 textures {args.texture}², generated in {time.time() - t0:.1f} s)")
    for r in range(args.repeats):
        p = json.loads(subprocess.run([profiler, path], check=True, capture_output=True, text=True).stdout)
        t = time.time()
        subprocess.run([binary, "info", path, "--json"], check=True, capture_output=True)
        wall = time.time() - t
        phases = ", ".join(f"{k} {v:.3f}" for k, v in p["profile"].items() if isinstance(v, float))
        print(f"run {r + 1}: {phases}, bvh {p['bvh']:.3f} s; emitter texel reads {p['profile']['emitter_texel_reads']:,} "
              f"for {p['emissive_triangles']} emissive triangles; `caustic info` wall {wall:.2f} s")


if __name__ == "__main__":
    sys.exit(main())
