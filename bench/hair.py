"""A sphere with a million hair strands (issue 20: "renders within memory and its time per sample
is stated against Cycles' on the same scene").

The scene: a unit sphere (a 64 × 32 UV sphere) with N strands rooted at uniform random points,
each 9 control points (8 segments, Blender's default render steps) growing along the normal
with a random bend, 0.15 long, radius 0.002 at the root tapering to 0 at the tip (Blender's
closed tip); grey diffuse sphere and strands, a sun and a grey world, camera framing the sphere.

Caustic reads it as glTF with `CAUSTIC_curves` (accessors in a .bin); Cycles gets the same
strands as a Curves object of Poly type (straight segments, Cycles' "thick linear" curves, so
both renderers intersect the same round cones) built with bpy from the same arrays.

Time per sample: each renderer renders at S1 and S2 samples; (t2 - t1) / (S2 - S1) removes
loading, BVH building and scene sync. Memory: the peak resident set of the process (Caustic's
whole process; for Cycles, Blender's process, which also holds the Curves data), and Caustic's
own count of the bytes its strands and their BVH hold (`caustic info --json`: curve_bytes).

Usage:
    cargo build --release
    .venv/bin/python bench/hair.py [--binary target/release/caustic] [--strands 1000000] [--cycles] [--shape ribbon]
(numpy, and for --cycles the project's bpy: run it with the .venv's Python.)
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
POINTS = 9
LENGTH = 0.15
ROOT_RADIUS = 0.002
RES = (320, 240)
SAMPLES = (4, 12)


def strands(n, seed=1):
    """Points (n * POINTS, 3) Blender axes (Z up), radii, counts."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(-1.0, 1.0, n)
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    r = np.sqrt(1.0 - z * z)
    normal = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    bend = rng.normal(0.0, 0.6, (n, 3))
    bend -= normal * np.sum(bend * normal, axis=1, keepdims=True)
    s = np.linspace(0.0, 1.0, POINTS)
    pts = normal[:, None, :] * (1.0 + LENGTH * s[None, :, None]) + bend[:, None, :] * (LENGTH * s[None, :, None] ** 2)
    radii = np.tile(ROOT_RADIUS * (1.0 - s), n)
    return pts.reshape(-1, 3).astype(np.float32), radii.astype(np.float32), np.full(n, POINTS, np.uint32)


def uv_sphere(seg=64, rings=32):
    verts, faces = [], []
    for i in range(rings + 1):
        th = np.pi * i / rings
        for j in range(seg):
            ph = 2 * np.pi * j / seg
            verts.append((np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)))
    for i in range(rings):
        for j in range(seg):
            a, b = i * seg + j, i * seg + (j + 1) % seg
            c, d = a + seg, b + seg
            faces += [(a, c, d), (a, d, b)]
    return np.array(verts, np.float32), np.array(faces, np.uint32)


def gltf_axes(p):
    return np.stack([p[:, 0], p[:, 2], -p[:, 1]], axis=1)


def write_gltf(folder, n, shape="round"):
    pts, radii, counts = strands(n)
    verts, faces = uv_sphere()
    blob = bytearray()
    views, accessors = [], []

    def add(arr, comp, kind, extra=None):
        while len(blob) % 4:
            blob.append(0)
        data = np.ascontiguousarray(arr).tobytes()
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)})
        blob.extend(data)
        acc = {"bufferView": len(views) - 1, "componentType": comp, "count": len(arr), "type": kind}
        acc.update(extra or {})
        accessors.append(acc)
        return len(accessors) - 1

    v = gltf_axes(verts)
    pos = add(v, 5126, "VEC3", {"min": v.min(0).tolist(), "max": v.max(0).tolist()})
    nrm = add(v, 5126, "VEC3")
    idx = add(faces.reshape(-1), 5125, "SCALAR")
    cp = add(gltf_axes(pts), 5126, "VEC3")
    cr = add(radii, 5126, "SCALAR")
    cc = add(counts, 5125, "SCALAR")
    with open(os.path.join(folder, "hair.bin"), "wb") as f:
        f.write(blob)
    grey = {"name": "Grey", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.4, 0.3, 1], "metallicFactor": 0.0,
                                                     "roughnessFactor": 1.0},
            "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}}
    cam_rot = [-0.2588, 0.0, 0.0, 0.9659]  # 30° down about x
    doc = {
        "asset": {"version": "2.0"}, "scene": 0,
        "extensionsUsed": ["CAUSTIC_curves", "KHR_lights_punctual", "KHR_materials_specular", "CAUSTIC_world"],
        "buffers": [{"uri": "hair.bin", "byteLength": len(blob)}], "bufferViews": views, "accessors": accessors,
        "materials": [grey],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos, "NORMAL": nrm}, "indices": idx, "material": 0}]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.6, "znear": 0.1, "aspectRatio": RES[0] / RES[1]}}],
        "extensions": {
            "KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 3.0 * 683.0}]},
            "CAUSTIC_curves": {"objects": [dict({"name": "Fur", "material": 0, "points": cp, "radii": cr, "counts": cc},
                                                **({"shape": "ribbon"} if shape == "ribbon" else {}))]},
        },
        "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0.0, 2.3, 4.0], "rotation": cam_rot},
                  {"rotation": [-0.7071068, 0.0, 0.0, 0.7071068], "extensions": {"KHR_lights_punctual": {"light": 0}}}],
        "scenes": [{"nodes": [0, 1, 2], "extensions": {"CAUSTIC_world": {"color": [0.2, 0.2, 0.2], "strength": 1.0}}}],
    }
    path = os.path.join(folder, "hair.gltf")
    with open(path, "w") as f:
        json.dump(doc, f)
    return path


def run_caustic(binary, scene, spp):
    out = os.path.join(os.path.dirname(scene), f"caustic_{spp}.exr")
    cmd = ["/usr/bin/time", "-f", "%e %M", binary, "render", scene, "-o", out, "--spp", str(spp),
           "--resolution", f"{RES[0]}x{RES[1]}", "--max-depth", "4", "--progress", "none"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"caustic failed: {r.stderr}")
    wall, rss_kb = r.stderr.strip().splitlines()[-1].split()
    return float(wall), int(rss_kb) * 1024


CYCLES_SCRIPT = r'''
import sys, time, resource, json
import numpy as np
import bpy
sys.path.insert(0, {bench!r})
import hair
n, spp = {n}, {spp}
pts, radii, counts = hair.strands(n)
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.engine = "CYCLES"
c = scene.cycles
c.device = "CPU"; c.samples = spp; c.use_adaptive_sampling = False; c.use_denoising = False
c.max_bounces = c.diffuse_bounces = c.glossy_bounces = 3
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = {res}[0], {res}[1], 100
scene.render.threads_mode = "AUTO"
mat = bpy.data.materials.new("Grey")
b = mat.node_tree.nodes["Principled BSDF"]
b.inputs["Base Color"].default_value = (0.5, 0.4, 0.3, 1); b.inputs["Roughness"].default_value = 1.0
b.inputs["Specular IOR Level"].default_value = 0.0
verts, faces = hair.uv_sphere()
me = bpy.data.meshes.new("Sphere"); me.from_pydata(verts.tolist(), [], faces.tolist()); me.materials.append(mat)
scene.collection.objects.link(bpy.data.objects.new("Sphere", me))
hc = bpy.data.hair_curves.new("Fur")
hc.add_curves(counts.tolist())
hc.points.foreach_set("position", pts.reshape(-1))
r = hc.attributes.new("radius", "FLOAT", "POINT"); r.data.foreach_set("value", radii)
hc.set_types(type={curve_type!r})
scene.cycles_curves.shape = {cycles_shape!r}
hc.materials.append(mat)
scene.collection.objects.link(bpy.data.objects.new("Fur", hc))
cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
cam.location = (0.0, -4.0, 2.3); cam.rotation_euler = (1.0472 + 0.0, 0.0, 0.0)
scene.collection.objects.link(cam); scene.camera = cam
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN")); sun.data.energy = 3.0
scene.collection.objects.link(sun)
world = bpy.data.worlds.new("W"); world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.2, 0.2, 0.2, 1); scene.world = world
scene.render.filepath = {out!r}
t = time.time(); bpy.ops.render.render(write_still=True); t = time.time() - t
print("RESULT", json.dumps({{"seconds": t, "rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024}}))
'''


def run_cycles(n, spp, folder, shape="round"):
    script = os.path.join(folder, f"cycles_{spp}.py")
    with open(script, "w") as f:
        # Ribbons: Cycles draws only non-Poly curves as ribbons (through the same points).
        curve_type, cycles_shape = ("CATMULL_ROM", "RIBBONS") if shape == "ribbon" else ("POLY", "THICK")
        f.write(CYCLES_SCRIPT.format(bench=os.path.join(ROOT, "bench"), n=n, spp=spp, res=RES,
                                     curve_type=curve_type, cycles_shape=cycles_shape,
                                     out=os.path.join(folder, f"cycles_{spp}.exr")))
    r = subprocess.run([os.path.join(ROOT, ".venv", "bin", "python"), script], capture_output=True, text=True)
    line = next((ln for ln in r.stdout.splitlines() if ln.startswith("RESULT")), None)
    if line is None:
        sys.exit(f"cycles failed: {r.stdout[-2000:]} {r.stderr[-2000:]}")
    res = json.loads(line[len("RESULT "):])
    return res["seconds"], res["rss"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--binary", default=os.path.join(ROOT, "target", "release", "caustic"))
    ap.add_argument("--strands", type=int, default=1_000_000)
    ap.add_argument("--cycles", action="store_true", help="also render the scene with Cycles (bpy)")
    ap.add_argument("--shape", choices=("round", "ribbon"), default="round",
                    help="strands as round cones (Cycles: Poly curves, Thick Linear) or ribbons (Cycles: Catmull-Rom "
                         "curves under the Ribbons Curves Shape, Blender 5.0's default)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="caustic-hair-") as folder:
        t = time.time()
        scene = write_gltf(folder, args.strands, args.shape)
        print(f"scene: {args.strands} strands, {args.strands * (POINTS - 1)} segments, written in {time.time() - t:.1f} s")
        info = json.loads(subprocess.run([args.binary, "info", scene, "--json"], capture_output=True, text=True,
                                         check=True).stdout)
        print(f"caustic: {info['strands']} strands, {info['curve_segments']} segments, strands + BVH "
              f"{info['curve_bytes'] / 2**20:.1f} MiB = {info['curve_bytes'] / info['curve_segments']:.1f} bytes per segment, "
              f"load {info['load_profile']['total']:.2f} s")
        (t1, m1), (t2, m2) = (run_caustic(args.binary, scene, s) for s in SAMPLES)
        per = (t2 - t1) / (SAMPLES[1] - SAMPLES[0])
        print(f"caustic: {SAMPLES[0]} spp {t1:.2f} s, {SAMPLES[1]} spp {t2:.2f} s -> {per:.3f} s per sample "
              f"({RES[0]}x{RES[1]}); peak RSS {max(m1, m2) / 2**20:.0f} MiB")
        if args.cycles:
            (c1, n1), (c2, n2) = (run_cycles(args.strands, s, folder, args.shape) for s in SAMPLES)
            cper = (c2 - c1) / (SAMPLES[1] - SAMPLES[0])
            print(f"cycles:  {SAMPLES[0]} spp {c1:.2f} s, {SAMPLES[1]} spp {c2:.2f} s -> {cper:.3f} s per sample; "
                  f"peak RSS {max(n1, n2) / 2**20:.0f} MiB (Blender's process, the Curves data included)")
            print(f"caustic / cycles time per sample: {per / cper:.2f}")


if __name__ == "__main__":
    main()
