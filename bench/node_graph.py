"""Cost of a shader graph against a Principled-only material (issue 19: "a 30-node procedural
material costs at most 1.5x the shading time of a Principled-only material at equal spp").

One quad filling the view under a point light, rendered twice at equal spp on one thread: with
a plain glTF material, and with a 26-node graph (Texture Coordinate → Mapping → Noise (detail 4,
distortion) → ColorRamp; Voronoi → 12 Math → Clamp → Mix → Hue/Saturation → Invert → Gamma →
Principled Base Color; Map Range → Roughness; RGB to BW → Bump → Normal).

Usage:
    cargo build --release
    python3 bench/node_graph.py [--binary target/release/caustic] [--callgrind]
    .venv/bin/python bench/node_graph.py --cycles [--pairs 3]

Prints each render's user CPU time (or, with --callgrind, the instructions of
`render::render`, which a shared machine does not disturb) and the ratio graph / plain.
With --cycles the same two materials are rendered by Cycles instead (bpy: the plain scene
imported from the same glTF, the graph built as Blender nodes from the same list), one
thread, 320x240, 16 spp, in alternating pairs; each render's time is the user CPU of
`bpy.ops.render.render` alone, less the same render at 1 spp (scene sync, shader compile and
kernel start-up), so that the ratio compares 15 spp of sampling and shading. --sampling-only
measures Caustic the same way (16 spp less 1 spp, user CPU of the process).
"""
import argparse
import base64
import json
import os
import re
import resource
import struct
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

def scene(material, path):
    pos=[-2,-2,0, 2,-2,0, 2,2,0, -2,2,0]; nrm=[0,0,1]*4; uv=[0,1,1,1,1,0,0,0]; idx=[0,1,2,0,2,3]
    data=struct.pack('12f',*pos)+struct.pack('12f',*nrm)+struct.pack('8f',*uv)+struct.pack('6I',*idx)
    uri="data:application/octet-stream;base64,"+base64.b64encode(data).decode()
    doc={"asset":{"version":"2.0"},"extensionsUsed":["CAUSTIC_materials_nodes","KHR_lights_punctual"],
      "buffers":[{"uri":uri,"byteLength":len(data)}],
      "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":48},{"buffer":0,"byteOffset":96,"byteLength":32},{"buffer":0,"byteOffset":128,"byteLength":24}],
      "accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[-2,-2,0],"max":[2,2,0]},{"bufferView":1,"componentType":5126,"count":4,"type":"VEC3"},{"bufferView":2,"componentType":5126,"count":4,"type":"VEC2"},{"bufferView":3,"componentType":5125,"count":6,"type":"SCALAR"}],
      "materials":[material],
      "meshes":[{"primitives":[{"attributes":{"POSITION":0,"NORMAL":1,"TEXCOORD_0":2},"indices":3,"material":0}]}],
      "cameras":[{"type":"perspective","perspective":{"yfov":0.8,"znear":0.1,"aspectRatio":1.333}}],
      "extensions":{"KHR_lights_punctual":{"lights":[{"type":"point","intensity":20000,"color":[1,1,1]}]}},
      "nodes":[{"mesh":0},{"camera":0,"translation":[0,0,3]},{"translation":[0.5,0.5,2],"extensions":{"KHR_lights_punctual":{"light":0}}}],
      "scenes":[{"nodes":[0,1,2]}],"scene":0}
    json.dump(doc, open(path,'w'))
plain={"name":"plain","pbrMetallicRoughness":{"baseColorFactor":[0.8,0.5,0.3,1],"metallicFactor":0,"roughnessFactor":0.5}}
N=[]
def add(n):
    N.append(n); return len(N)-1
tc=add({"name":"tc","type":"ShaderNodeTexCoord"})
mp=add({"name":"map","type":"ShaderNodeMapping","props":{"vector_type":"POINT"},"inputs":{"Vector":{"link":[tc,"UV"]},"Location":{"value":[0,0,0]},"Rotation":{"value":[0,0,0.3]},"Scale":{"value":[2,2,2]}}})
nz=add({"name":"noise","type":"ShaderNodeTexNoise","props":{"noise_dimensions":"3D","noise_type":"FBM","normalize":True},"inputs":{"Vector":{"link":[mp,"Vector"]},"Scale":{"value":5.0},"Detail":{"value":4.0},"Roughness":{"value":0.5},"Lacunarity":{"value":2.0},"Distortion":{"value":0.2}}})
table=[[i/255,0.5*i/255,0.2,1] for i in range(256)]
rp=add({"name":"ramp","type":"ShaderNodeValToRGB","props":{"color_ramp":{"interpolation":"LINEAR","table":table}},"inputs":{"Fac":{"link":[nz,"Fac"]}}})
vo=add({"name":"vor","type":"ShaderNodeTexVoronoi","props":{"voronoi_dimensions":"3D","feature":"F1","distance":"EUCLIDEAN","normalize":False},"inputs":{"Vector":{"link":[mp,"Vector"]},"Scale":{"value":8.0},"Randomness":{"value":1.0}}})
last=(vo,"Distance")
for k in range(12):
    last=(add({"name":f"m{k}","type":"ShaderNodeMath","props":{"operation":["MULTIPLY_ADD","SINE","ABSOLUTE","POWER"][k%4]},"inputs":{"Value":{"link":list(last)},"Value_001":{"value":1.1},"Value_002":{"value":0.05}}}),"Value")
cl=add({"name":"clamp","type":"ShaderNodeClamp","inputs":{"Value":{"link":list(last)},"Min":{"value":0.0},"Max":{"value":1.0}}})
mx=add({"name":"mix","type":"ShaderNodeMix","props":{"data_type":"RGBA","blend_type":"MULTIPLY","clamp_factor":True},"inputs":{"Factor_Float":{"link":[cl,"Result"]},"A_Color":{"link":[rp,"Color"]},"B_Color":{"value":[0.9,0.8,0.7,1]}}})
hs=add({"name":"hsv","type":"ShaderNodeHueSaturation","inputs":{"Hue":{"value":0.5},"Saturation":{"value":1.1},"Value":{"value":1.0},"Fac":{"value":1.0},"Color":{"link":[mx,"Result_Color"]}}})
mr=add({"name":"mr","type":"ShaderNodeMapRange","props":{"data_type":"FLOAT","interpolation_type":"SMOOTHSTEP","clamp":True},"inputs":{"Value":{"link":[nz,"Fac"]},"From_Min":{"value":0.3},"From_Max":{"value":0.7},"To_Min":{"value":0.2},"To_Max":{"value":0.8}}})
bw=add({"name":"bw","type":"ShaderNodeRGBToBW","inputs":{"Color":{"link":[hs,"Color"]}}})
bp=add({"name":"bump","type":"ShaderNodeBump","props":{"invert":False},"inputs":{"Strength":{"value":0.5},"Distance":{"value":0.1},"Height":{"link":[bw,"Val"]}}})
inv=add({"name":"inv","type":"ShaderNodeInvert","inputs":{"Fac":{"value":0.2},"Color":{"link":[hs,"Color"]}}})
gm=add({"name":"gamma","type":"ShaderNodeGamma","inputs":{"Color":{"link":[inv,"Color"]},"Gamma":{"value":1.1}}})
pr=add({"name":"bsdf","type":"ShaderNodeBsdfPrincipled","inputs":{"Base Color":{"link":[gm,"Color"]},"Roughness":{"link":[mr,"Result"]},"Normal":{"link":[bp,"Normal"]}}})
graph={"name":"graph","extensions":{"CAUSTIC_materials_nodes":{"version":1,"nodes":N,"output":{"surface":[pr,"BSDF"]}}}}



def run(binary, path, callgrind, out_dir, spp=None):
    spp = spp or (4 if callgrind else 16)
    args = [binary, "render", path, "-o", os.path.join(out_dir, "o.exr"), "--resolution", "80x60" if callgrind else "320x240",
            "--spp", str(spp), "--threads", "1"]
    if callgrind:
        cg = os.path.join(out_dir, "cg.out")
        subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=" + cg] + args, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        # Run from the temporary directory: inside the source tree callgrind_annotate names
        # files relative to it and splits `render::render` by file (a 7 M share, not 460 M).
        text = subprocess.run(["callgrind_annotate", "--inclusive=yes", cg], capture_output=True, text=True,
                              cwd=out_dir).stdout
        line = next(l for l in text.splitlines() if re.search(r"caustic::render::render \[", l))
        return int(line.split()[0].replace(",", ""))
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
    subprocess.run(args, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime - before


def cycles_material(bpy, spec):
    """The graph's node list as a Blender material (the same nodes, inputs and links)."""
    mat = bpy.data.materials.new("graph")
    tree = mat.node_tree
    tree.nodes.clear()
    made = []
    for n in N:
        node = tree.nodes.new(n["type"])
        for key, val in n.get("props", {}).items():
            if key == "color_ramp":
                # The exported table samples a linear ramp between two stops at 0 and 1.
                els = node.color_ramp.elements
                els[0].position, els[0].color = 0.0, val["table"][0]
                els[1].position, els[1].color = 1.0, val["table"][-1]
                node.color_ramp.interpolation = val["interpolation"]
            else:
                setattr(node, key, val)
        made.append(node)
    def socket(sockets, ident):
        # The extension names a socket by its identifier where names repeat (Value_001), else
        # by name; an unknown one is an error in this list, not something to skip.
        found = ([s for s in sockets if s.identifier == ident] or [s for s in sockets if s.name == ident]
                 or [s for s in sockets if s.name == ident.replace("_", " ")])
        if not found:
            raise KeyError(f"no socket {ident!r} among {[s.identifier for s in sockets]}")
        return found[0]
    for node, n in zip(made, N):
        for ident, inp in n.get("inputs", {}).items():
            sock = socket(node.inputs, ident)
            if "link" in inp:
                src, out = inp["link"]
                tree.links.new(socket(made[src].outputs, out), sock)
            else:
                sock.default_value = inp["value"]
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    src, name = spec["output"]["surface"]
    tree.links.new(socket(made[src].outputs, name), out.inputs["Surface"])
    return mat


def cycles_times(gltf, pairs):
    """User CPU seconds of Cycles' sampling (16 spp less 1 spp) for the plain and graph materials."""
    import bpy
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    bpy.ops.import_scene.gltf(filepath=gltf)
    scene = bpy.context.scene
    scene.camera = next(o for o in scene.objects if o.type == "CAMERA")
    quad = next(o for o in scene.objects if o.type == "MESH")
    mats = {"plain": quad.material_slots[0].material,
            "graph": cycles_material(bpy, graph["extensions"]["CAUSTIC_materials_nodes"])}
    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x, r.resolution_y, r.resolution_percentage = 320, 240, 100
    r.threads_mode, r.threads = "FIXED", 1
    c = scene.cycles
    c.device = "CPU"
    c.use_adaptive_sampling = c.use_denoising = False
    def render(name, spp):
        quad.material_slots[0].material = mats[name]
        c.samples = spp
        # User CPU of this process (Cycles renders on one thread here): unlike the wall
        # clock it does not count the time other programs hold the core.
        t0 = resource.getrusage(resource.RUSAGE_SELF).ru_utime
        bpy.ops.render.render()
        return resource.getrusage(resource.RUSAGE_SELF).ru_utime - t0
    for name in mats:  # warm-up: kernels and shader compile once
        render(name, 1)
    times = {"plain": [], "graph": []}
    for _ in range(pairs):
        for name in ("plain", "graph"):
            times[name].append(render(name, 16) - render(name, 1))
    return times


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--binary", default=os.path.join(ROOT, "target", "release", "caustic"))
    ap.add_argument("--callgrind", action="store_true")
    ap.add_argument("--cycles", action="store_true", help="render with Cycles through bpy instead")
    ap.add_argument("--pairs", type=int, default=3, help="alternating render pairs (--cycles, --sampling-only)")
    ap.add_argument("--sampling-only", action="store_true", help="Caustic's user CPU at 16 spp less 1 spp, as --cycles")
    a = ap.parse_args()
    if a.cycles:
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "plain.gltf")
            scene(plain, path)
            t = cycles_times(path, a.pairs)
        for name in t:
            print(f"cycles {name}: " + " ".join(f"{x:.3f}" for x in t[name]) + " s")
        ratios = [g / p for g, p in zip(t["graph"], t["plain"])]
        print(f"{len(N)} nodes; Cycles graph / plain per pair: " + " ".join(f"{x:.2f}" for x in ratios)
              + f"; of the minima {min(t['graph']) / min(t['plain']):.2f}")
        return
    with tempfile.TemporaryDirectory() as d:
        paths = {}
        for name, m in (("plain", plain), ("graph", graph)):
            paths[name] = os.path.join(d, name + ".gltf")
            scene(m, paths[name])
        if a.sampling_only:
            # Alternating pairs, as for Cycles: the minimum of each is the least disturbed.
            runs = {name: [] for name in paths}
            for _ in range(a.pairs):
                for name, p in paths.items():
                    runs[name].append(run(a.binary, p, False, d) - run(a.binary, p, False, d, spp=1))
            for name in runs:
                print(f"caustic {name}: " + " ".join(f"{x:.3f}" for x in runs[name]) + " s")
            cost = {name: min(v) for name, v in runs.items()}
        else:
            cost = {name: run(a.binary, p, a.callgrind, d) for name, p in paths.items()}
    unit = "instructions" if a.callgrind else "s user"
    fmt = (lambda x: str(x)) if a.callgrind else (lambda x: f"{x:.3f}")
    print(f"{len(N)} nodes; plain {fmt(cost['plain'])} {unit}, graph {fmt(cost['graph'])} {unit}, "
          f"ratio {cost['graph'] / cost['plain']:.2f}")


if __name__ == "__main__":
    main()
