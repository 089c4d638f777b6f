"""Viewport benchmark: the time from each edit kind to the first updated frame of `caustic serve`.

Usage:
    cargo build --release
    python3 bench/viewport.py [SCENE] [--resolution 960x540] [--repeats 5] [--threads N]
                              [--integrator path] [--dense TRIANGLES]

`--dense N` adds a tessellated sphere of about N triangles and a point light to the Cornell box
(written to a temporary folder beside a copy of its buffer), for the issue's 100k- and
1M-triangle figures: the edits are the same (and a light edit), so each shows whether anything
scales with the mesh. The transform edit moves the box's tall block, not the sphere: the cost of
moving one object in a large scene, not of rebuilding a large object.

Drives the server through the add-on's own client (blender_addon/server_client.py, no Blender
needed): loads the scene (default: the bundled Cornell box), starts rendering at the given
resolution and, for each edit kind (camera move, material edit, object transform, world,
hide/show, light, an object added, a mesh edited, a node material's graph changed, and the
reload these needed before), sends the edit and waits for the first frame of the new
generation, which is the reduced (1/4 per side) frame. "add object" merges a new 12-triangle
cube (a glTF of that cube alone, as the add-on exports an added object) and "edit mesh" the tall
block with its vertices moved (the box's block alone, replacing the loaded one); "node material"
sends the `material_graph` of the red wall, which the bench makes a node graph (a Noise Texture,
3D fBM of Detail 3, into a Diffuse BSDF's colour) in its copy of the scene, with the noise's
Scale changed per repeat, as dragging that field in Blender sends it; "reload" loads the whole
scene again, the server's share of what they cost before (the add-on's export of the whole
scene came on top). Prints the median and the worst of the repeats per kind, in ms, and the
time to the first full-resolution frame. The times include the pipe round trip and the
decoding of the frame by the client, as the viewport sees them.
"""
import argparse
import json
import math
import os
import shutil
import statistics
import struct
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "blender_addon"))

from server_client import ServerClient  # noqa: E402  (the add-on folder is not a package here)


def camera(angle, resolution):
    """A camera on a circle around the Cornell box's centre (glTF axes, looking at it)."""
    x, z = 3.9 * math.sin(angle), 3.9 * math.cos(angle)
    c, s = math.cos(angle), math.sin(angle)
    # Rotation about +Y by `angle`: the camera's -Z looks at the origin's height 1.
    m = [c, 0, -s, 0, 0, 1, 0, 0, s, 0, c, 0, x, 1, z, 1]
    return {"type": "camera", "matrix": m, "projection": "perspective", "yfov": 0.69,
            "resolution": list(resolution)}


def object_files(folder):
    """Writers of the glTF files of "add object" (a cube named by the repeat, in a data-URI
    buffer) and "edit mesh" (the Cornell box's tall block alone, moved by the repeat, on the
    box's buffer, which `folder` holds): each returns the file's path."""
    import base64

    def add(i):
        # The 8 corners of a 0.1 cube on the floor and its 12 triangles.
        corners = [(0.1 * (k & 1) - 0.35, 0.1 * (k >> 1 & 1), 0.1 * (k >> 2 & 1) + 0.1 * (i % 5)) for k in range(8)]
        faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
        idx = [v for f in faces for v in (f[0], f[1], f[2], f[0], f[2], f[3])]
        data = b"".join(struct.pack("<3f", *c) for c in corners) + struct.pack(f"<{len(idx)}I", *idx)
        doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
               "nodes": [{"name": f"added_{i}", "mesh": 0}],
               "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
               "materials": [{"name": "added", "pbrMetallicRoughness": {"metallicFactor": 0.0}}],
               "buffers": [{"byteLength": len(data), "uri": "data:application/octet-stream;base64,"
                            + base64.b64encode(data).decode()}],
               "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 96},
                               {"buffer": 0, "byteOffset": 96, "byteLength": 4 * len(idx)}],
               "accessors": [{"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
                              "min": [min(c[k] for c in corners) for k in range(3)],
                              "max": [max(c[k] for c in corners) for k in range(3)]},
                             {"bufferView": 1, "componentType": 5125, "count": len(idx), "type": "SCALAR"}]}
        path = os.path.join(folder, f"added_{i}.gltf")
        json.dump(doc, open(path, "w"))
        return path

    def edit(i):
        doc = json.load(open(os.path.join(ROOT, "scenes", "cornell_box.gltf")))
        block = next(k for k, n in enumerate(doc["nodes"]) if n.get("name") == "tall_block")
        doc["scenes"][0]["nodes"] = [block]
        doc["nodes"][block]["translation"] = [0.01 * (i % 5), 0.0, 0.0]
        path = os.path.join(folder, f"edited_{i}.gltf")
        json.dump(doc, open(path, "w"))
        return path

    return add, edit


def noise_graph(scale):
    """The red wall's node graph (`CAUSTIC_materials_nodes`): a Noise Texture of `scale`
    colouring a Diffuse BSDF."""
    return {"version": 1, "output": {"surface": [2, "BSDF"]}, "images": [], "nodes": [
        {"name": "Geometry", "type": "ShaderNodeNewGeometry"},
        {"name": "Noise", "type": "ShaderNodeTexNoise",
         "props": {"noise_dimensions": "3D", "noise_type": "FBM", "normalize": True},
         "inputs": {"Vector": {"link": [0, "Position"]}, "Scale": {"value": scale}, "Detail": {"value": 3.0},
                    "Roughness": {"value": 0.5}, "Lacunarity": {"value": 2.0}, "Distortion": {"value": 0.0}}},
        {"name": "Diffuse", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"link": [1, "Color"]}}}]}


def with_node_material(scene, folder):
    """A copy of `scene` in `folder` (beside which its buffers are) whose material "red", when
    it has one, is the node graph of `noise_graph`; returns its path."""
    doc = json.load(open(scene))
    for m in doc.get("materials", []):
        if m.get("name") == "red":
            m.setdefault("extensions", {})["CAUSTIC_materials_nodes"] = noise_graph(4.0)
            doc.setdefault("extensionsUsed", []).append("CAUSTIC_materials_nodes")
    path = os.path.join(folder, "with_nodes.gltf")
    json.dump(doc, open(path, "w"))
    return path


def edits(resolution, folder, scene):
    """One request per edit kind, varying with the repeat index. The node material's edit comes
    before the merges: their files copy the original box, whose red wall is no graph."""
    add, edit = object_files(folder)
    return {
        "camera": lambda i: camera(0.05 * (i + 1), resolution),
        "material": lambda i: {"type": "material", "name": "white",
                               "base_color": [0.5 + 0.05 * i, 0.5, 0.5, 1.0]},
        "node material": lambda i: {"type": "material_graph", "name": "red", "nodes": noise_graph(4.0 + 0.5 * (i + 1))},
        "transform": lambda i: {"type": "transform", "name": "tall_block",
                                "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0.02 * i, 0, 0, 1]},
        "world": lambda i: {"type": "world", "color": [0.01 * i, 0.01 * i, 0.01 * i]},
        "hide/show": lambda i: {"type": "visibility", "name": "short_block", "visible": i % 2 == 1},
        "light": lambda i: {"type": "light", "name": "bench_lamp", "emission": [0.5 + 0.1 * i, 0.5, 0.5],
                            "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0.2 + 0.01 * i, 0.45, 0.2, 1]},
        "add object": lambda i: {"type": "objects", "path": add(i)},
        "edit mesh": lambda i: {"type": "objects", "path": edit(i)},
        "reload": lambda i: {"type": "load", "path": os.path.abspath(scene)},
    }


def dense_scene(triangles, folder):
    """The Cornell box with a UV sphere of about `triangles` triangles on its floor, as a .gltf
    in `folder`; returns its path. The sphere uses the box's white material."""
    src = os.path.join(ROOT, "scenes", "cornell_box.gltf")
    doc = json.load(open(src))
    shutil.copy(os.path.join(ROOT, "scenes", doc["buffers"][0]["uri"]), folder)
    rings = max(4, int(math.sqrt(triangles / 4)))
    segments = 2 * rings
    centre, radius = (0.40, 0.11, 0.15), 0.1
    pos, nrm = bytearray(), bytearray()
    for i in range(rings + 1):
        th = math.pi * i / rings
        for j in range(segments + 1):
            ph = 2 * math.pi * j / segments
            n = (math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph))
            pos += struct.pack("<3f", *(c + radius * v for c, v in zip(centre, n)))
            nrm += struct.pack("<3f", *n)
    idx = bytearray()
    row = segments + 1
    for i in range(rings):
        for j in range(segments):
            a, b = i * row + j, (i + 1) * row + j
            idx += struct.pack("<6I", a, b, a + 1, a + 1, b, b + 1)
    nverts, nidx = (rings + 1) * row, 6 * rings * segments
    with open(os.path.join(folder, "dense.bin"), "wb") as f:
        f.write(pos + nrm + idx)
    b = len(doc["buffers"])
    doc["buffers"].append({"uri": "dense.bin", "byteLength": len(pos) + len(nrm) + len(idx)})
    v = len(doc["bufferViews"])
    doc["bufferViews"] += [{"buffer": b, "byteOffset": 0, "byteLength": len(pos)},
                           {"buffer": b, "byteOffset": len(pos), "byteLength": len(nrm)},
                           {"buffer": b, "byteOffset": len(pos) + len(nrm), "byteLength": len(idx)}]
    a = len(doc["accessors"])
    lo = [c - radius for c in centre]
    hi = [c + radius for c in centre]
    doc["accessors"] += [{"bufferView": v, "componentType": 5126, "count": nverts, "type": "VEC3", "min": lo, "max": hi},
                         {"bufferView": v + 1, "componentType": 5126, "count": nverts, "type": "VEC3"},
                         {"bufferView": v + 2, "componentType": 5125, "count": nidx, "type": "SCALAR"}]
    white = next(i for i, m in enumerate(doc["materials"]) if m["name"] == "white")
    doc["meshes"].append({"name": "dense", "primitives": [
        {"attributes": {"POSITION": a, "NORMAL": a + 1}, "indices": a + 2, "material": white}]})
    doc["nodes"].append({"name": "dense_sphere", "mesh": len(doc["meshes"]) - 1})
    doc["scenes"][0]["nodes"].append(len(doc["nodes"]) - 1)
    # A point light, so that the bench times light edits too (the box's own light is a mesh).
    doc.setdefault("extensionsUsed", []).append("KHR_lights_punctual")
    doc.setdefault("extensions", {})["KHR_lights_punctual"] = {
        "lights": [{"name": "bench_lamp", "type": "point", "intensity": 2.0, "color": [1.0, 0.9, 0.8]}]}
    doc["nodes"].append({"name": "bench_lamp", "translation": [0.2, 0.45, 0.2],
                         "extensions": {"KHR_lights_punctual": {"light": 0}}})
    doc["scenes"][0]["nodes"].append(len(doc["nodes"]) - 1)
    path = os.path.join(folder, "dense.gltf")
    json.dump(doc, open(path, "w"))
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", nargs="?", default=os.path.join(ROOT, "scenes", "cornell_box.gltf"))
    ap.add_argument("--resolution", default="960x540")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--threads", type=int)
    ap.add_argument("--integrator", default="path")
    ap.add_argument("--dense", type=int, help="add a sphere of about this many triangles")
    ap.add_argument("--binary", default=os.environ.get("CAUSTIC_BINARY",
                                                       os.path.join(ROOT, "target", "release", "caustic")))
    a = ap.parse_args()
    resolution = tuple(int(v) for v in a.resolution.split("x"))
    folder = tempfile.mkdtemp(prefix="caustic-bench-view-")
    scene = dense_scene(a.dense, folder) if a.dense else a.scene
    if not a.dense:
        shutil.copy(os.path.join(ROOT, "scenes", "cornell_box.bin"), folder)
    scene = with_node_material(scene, folder)
    client = ServerClient(a.binary, threads=a.threads)
    try:
        client.request({"type": "settings", "integrator": a.integrator, "frame_format": "f16"})
        t = time.perf_counter()
        loaded = client.request({"type": "load", "path": os.path.abspath(scene)})
        print(f"load: {1000 * (time.perf_counter() - t):.0f} ms ({loaded['triangles']} triangles, "
              f"BVH {1000 * loaded['bvh_seconds']:.1f} ms)")
        client.request(camera(0.0, resolution))
        gen = client.request({"type": "render_start"})["generation"]
        t = time.perf_counter()
        client.wait_frame(gen)
        print(f"render_start → first frame: {1000 * (time.perf_counter() - t):.1f} ms")
        full = []
        has_graph = any(m["name"] == "red" and m["nodes"] for m in loaded.get("materials", []))
        has_lamp = any(entry["name"] == "bench_lamp" for entry in loaded.get("lights", []))
        for kind, make in edits(resolution, folder, scene).items():
            if kind == "light" and not has_lamp or kind == "node material" and not has_graph:
                continue
            times = []
            for i in range(a.repeats):
                request = make(i)  # the file of an objects request is written before the clock starts
                t = time.perf_counter()
                gen = client.request(request)["generation"]
                header, _ = client.wait_frame(gen)
                times.append(1000 * (time.perf_counter() - t))
                # The first full-resolution pass after the reduced frame.
                while True:
                    header, _ = client.wait_frame(gen)
                    if not header["reduced"]:
                        break
                    time.sleep(0.001)
                full.append(1000 * (time.perf_counter() - t))
            print(f"{kind:13s} → first frame: median {statistics.median(times):6.1f} ms, "
                  f"worst {max(times):6.1f} ms  ({a.repeats} repeats, {resolution[0]}x{resolution[1]})")
        print(f"edit → first full-resolution frame: median {statistics.median(full):.1f} ms")
    finally:
        client.stop()
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
