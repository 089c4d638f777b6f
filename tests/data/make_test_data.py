#!/usr/bin/env python3
"""Write the small hand-made glTF files of tests/data/ and tests/data/manifest.json.

Every file exercises one loader feature (or, under bad/, one defect). The files are valid
glTF 2.0 apart from the intended defect. Each `make_*` function below writes one file and
returns its manifest entry; the expected numbers of a good file (triangles, lights, cameras,
bounds) are then recomputed by an independent reading of the written file (`analyse`, a tiny
reference loader in this script) and the two must agree, so the manifest cannot silently
drift from the files. See README.md in this folder for the manifest's fields.

Plain Python 3 standard library only (struct, json, base64, zlib); deterministic: the same
bytes on every run. Usage: python3 tests/data/make_test_data.py  (writes next to this script)
"""

import base64
import json
import math
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
GENERATOR = "caustic tests/data/make_test_data.py"

# glTF enums
BYTE, UNSIGNED_BYTE, SHORT, UNSIGNED_SHORT, UNSIGNED_INT, FLOAT = 5120, 5121, 5122, 5123, 5125, 5126
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
POINTS, LINES, LINE_LOOP, LINE_STRIP, TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN = range(7)
NEAREST, LINEAR = 9728, 9729
NEAREST_MIPMAP_NEAREST, LINEAR_MIPMAP_LINEAR = 9984, 9987
CLAMP_TO_EDGE, MIRRORED_REPEAT, REPEAT = 33071, 33648, 10497

COMPONENT = {BYTE: ("b", 1), UNSIGNED_BYTE: ("B", 1), SHORT: ("h", 2), UNSIGNED_SHORT: ("H", 2),
             UNSIGNED_INT: ("I", 4), FLOAT: ("f", 4)}
NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


# =============================================================================================
# Small helpers: float32 rounding, JSON formatting, PNG writing, quaternions
# =============================================================================================
def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def short_float(x):
    """The shortest decimal that reads back as the same float32 (for accessor min/max)."""
    if math.isnan(x) or math.isinf(x):
        raise ValueError("min/max must be finite")
    target = f32(x)
    for digits in range(1, 18):
        v = float("%.*g" % (digits, target))
        if f32(v) == target:
            return v
    return target


def to_json(value, indent=0):
    """JSON with two-space indentation, but lists of numbers or strings on one line."""
    pad = "  " * indent
    if isinstance(value, dict):
        if not value:
            return "{}"
        items = ["%s  %s: %s" % (pad, json.dumps(k), to_json(v, indent + 1))
                 for k, v in value.items()]
        return "{\n" + ",\n".join(items) + "\n" + pad + "}"
    if isinstance(value, list):
        if all(not isinstance(v, (dict, list)) for v in value):
            return "[" + ", ".join(json.dumps(v) for v in value) + "]"
        items = [pad + "  " + to_json(v, indent + 1) for v in value]
        return "[\n" + ",\n".join(items) + "\n" + pad + "]"
    return json.dumps(value)


def png(width, height, rows, channels):
    """A PNG (8-bit, RGB or RGBA) from rows of pixel tuples. Stored (level 0) zlib blocks keep
    the bytes identical whatever zlib build runs this."""
    color_type = {3: 2, 4: 6}[channels]
    raw = b"".join(b"\x00" + bytes(c for px in row for c in px) for row in rows)

    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data +
                struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    return (b"\x89PNG\r\n\x1a\n" +
            chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, color_type, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw, 0)) +
            chunk(b"IEND", b""))


def checker_png():
    """4x4 RGBA checker: opaque orange / half-transparent blue / fully transparent texels."""
    a, b, c = (255, 128, 0, 255), (0, 64, 255, 128), (255, 255, 255, 0)
    rows = [[a, b, a, c], [b, a, c, a], [a, c, a, b], [c, a, b, a]]
    return png(4, 4, rows, 4)


def normal_map_png():
    """4x4 RGB tangent-space normal map: bumps tilted in +-X / +-Y around the flat (128,128,255)."""
    flat, px, nx, py, ny = (128, 128, 255), (218, 128, 218), (38, 128, 218), (128, 218, 218), (128, 38, 218)
    rows = [[flat, px, flat, nx], [py, flat, ny, flat], [flat, nx, flat, px], [ny, flat, py, flat]]
    return png(4, 4, rows, 3)


def metallic_roughness_png():
    """4x4 RGB: G = roughness, B = metallic (R unused), four quadrants of combinations."""
    rows = [[(0, 32, 0), (0, 32, 0), (0, 230, 0), (0, 230, 0)],
            [(0, 32, 0), (0, 32, 0), (0, 230, 0), (0, 230, 0)],
            [(0, 32, 255), (0, 32, 255), (0, 230, 255), (0, 230, 255)],
            [(0, 32, 255), (0, 32, 255), (0, 230, 255), (0, 230, 255)]]
    return png(4, 4, rows, 3)


def emissive_png():
    rows = [[(255, 255, 255) if (x + y) % 2 == 0 else (0, 0, 0) for x in range(4)] for y in range(4)]
    return png(4, 4, rows, 3)


def quat_axis_angle(axis, angle):
    n = math.sqrt(sum(c * c for c in axis))
    s = math.sin(angle / 2.0) / n
    return [axis[0] * s, axis[1] * s, axis[2] * s, math.cos(angle / 2.0)]


def quat_mul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return [aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz]


# =============================================================================================
# A small glTF builder
# =============================================================================================
class Builder:
    """Collects glTF objects and one binary buffer; writes .gltf (external or data-URI buffer)
    or .glb."""

    ROOT_ORDER = ["asset", "extensionsUsed", "extensionsRequired", "extensions", "scene", "scenes",
                  "nodes", "cameras", "meshes", "materials", "textures", "images", "samplers",
                  "accessors", "bufferViews", "buffers"]

    def __init__(self):
        self.root = {"asset": {"version": "2.0", "generator": GENERATOR}}
        self.bin = bytearray()

    # -- generic --------------------------------------------------------------------------
    def add(self, key, item):
        self.root.setdefault(key, []).append(item)
        return len(self.root[key]) - 1

    def use_extension(self, name, required=False):
        used = self.root.setdefault("extensionsUsed", [])
        if name not in used:
            used.append(name)
        if required:
            req = self.root.setdefault("extensionsRequired", [])
            if name not in req:
                req.append(name)

    # -- binary data ----------------------------------------------------------------------
    def view(self, data, target=None, stride=None):
        while len(self.bin) % 4:
            self.bin.append(0)
        v = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if stride is not None:
            v["byteStride"] = stride
        if target is not None:
            v["target"] = target
        self.bin += data
        return self.add("bufferViews", v)

    def accessor(self, view, ctype, count, kind, byte_offset=0, normalized=False, bounds=None):
        a = {"bufferView": view}
        if byte_offset:
            a["byteOffset"] = byte_offset
        a["componentType"] = ctype
        if normalized:
            a["normalized"] = True
        a["count"] = count
        a["type"] = kind
        if bounds is not None:
            a["min"], a["max"] = bounds
        return self.add("accessors", a)

    def attribute(self, values, kind="VEC3", ctype=FLOAT, normalized=False, bounds=False,
                  stride=None):
        """A vertex attribute accessor in its own bufferView. values: list of tuples."""
        fmt, size = COMPONENT[ctype]
        n = NCOMP[kind]
        elem = n * size
        stride_used = stride or elem
        data = bytearray()
        for v in values:
            assert len(v) == n
            packed = struct.pack("<%d%s" % (n, fmt), *v)
            data += packed + b"\x00" * (stride_used - elem)
        view = self.view(bytes(data), ARRAY_BUFFER, stride)
        b = None
        if bounds:
            b = ([short_float(min(v[i] for v in values)) for i in range(n)],
                 [short_float(max(v[i] for v in values)) for i in range(n)])
        return self.accessor(view, ctype, len(values), kind, normalized=normalized, bounds=b)

    def positions(self, values):
        return self.attribute(values, "VEC3", FLOAT, bounds=True)

    def indices(self, values, ctype=UNSIGNED_SHORT):
        fmt, _ = COMPONENT[ctype]
        view = self.view(struct.pack("<%d%s" % (len(values), fmt), *values), ELEMENT_ARRAY_BUFFER)
        return self.accessor(view, ctype, len(values), "SCALAR")

    # -- scene objects ----------------------------------------------------------------------
    def material(self, name, base=(0.8, 0.8, 0.8, 1.0), metallic=0.0, roughness=1.0,
                 double_sided=True, **extra):
        m = {"name": name,
             "pbrMetallicRoughness": {"baseColorFactor": list(base), "metallicFactor": metallic,
                                      "roughnessFactor": roughness}}
        m.update(extra)
        if double_sided:
            m["doubleSided"] = True
        return self.add("materials", m)

    def mesh(self, name, primitives):
        return self.add("meshes", {"name": name, "primitives": primitives})

    def node(self, name, **props):
        n = {"name": name}
        n.update(props)
        return self.add("nodes", n)

    def scene(self, nodes, name="scene", extras=None, default=True):
        s = {"name": name, "nodes": list(nodes)}
        if extras is not None:
            s["extras"] = extras
        index = self.add("scenes", s)
        if default:
            self.root["scene"] = index
        return index

    def perspective(self, name, yfov=0.8, aspect=1.0, znear=0.05, zfar=None):
        p = {"yfov": yfov}
        if aspect is not None:
            p["aspectRatio"] = aspect
        if zfar is not None:
            p["zfar"] = zfar
        p["znear"] = znear
        return self.add("cameras", {"name": name, "type": "perspective", "perspective": p})

    def orthographic(self, name, xmag, ymag, znear=0.01, zfar=100.0):
        return self.add("cameras", {"name": name, "type": "orthographic",
                                    "orthographic": {"xmag": xmag, "ymag": ymag,
                                                     "zfar": zfar, "znear": znear}})

    def punctual(self, light):
        self.use_extension("KHR_lights_punctual")
        ext = self.root.setdefault("extensions", {}).setdefault("KHR_lights_punctual",
                                                                {"lights": []})
        ext["lights"].append(light)
        return len(ext["lights"]) - 1

    def light_node(self, name, light, **props):
        return self.node(name, extensions={"KHR_lights_punctual": {"light": self.punctual(light)}},
                         **props)

    def png_image(self, name, data, how="datauri"):
        """how: 'datauri', 'bufferView' or a relative uri (the file is written by the caller)."""
        if how == "datauri":
            return self.add("images", {"name": name,
                                       "uri": "data:image/png;base64," + base64.b64encode(data).decode()})
        if how == "bufferView":
            return self.add("images", {"name": name, "bufferView": self.view(data),
                                       "mimeType": "image/png"})
        return self.add("images", {"name": name, "uri": how})

    def sampler(self, wrap_s=REPEAT, wrap_t=REPEAT, mag=LINEAR, min_=LINEAR_MIPMAP_LINEAR, name=None):
        s = {}
        if name:
            s["name"] = name
        s.update({"magFilter": mag, "minFilter": min_, "wrapS": wrap_s, "wrapT": wrap_t})
        return self.add("samplers", s)

    def texture(self, image, sampler=None):
        t = {"source": image}
        if sampler is not None:
            t["sampler"] = sampler
        return self.add("textures", t)

    # -- output -----------------------------------------------------------------------------
    def _root(self, buffer):
        while len(self.bin) % 4:
            self.bin.append(0)
        root = dict(self.root)
        if self.bin or "bufferViews" in root:
            root["buffers"] = [dict(buffer, byteLength=len(self.bin))]
        return {k: root[k] for k in self.ROOT_ORDER if k in root}

    def write_gltf(self, rel_path, buffer="external", bin_name=None):
        """buffer: 'external' (a .bin next to the file, or bin_name) or 'datauri'."""
        path = os.path.join(HERE, rel_path)
        while len(self.bin) % 4:
            self.bin.append(0)
        if buffer == "external":
            if bin_name is None:
                bin_name = os.path.splitext(os.path.basename(rel_path))[0] + ".bin"
            file_name = bin_name.replace("%20", " ")
            root = self._root({"uri": bin_name})
            bin_path = os.path.join(os.path.dirname(path), file_name)
            os.makedirs(os.path.dirname(bin_path), exist_ok=True)
            write_bytes(bin_path, bytes(self.bin))
        else:
            uri = "data:application/octet-stream;base64," + base64.b64encode(bytes(self.bin)).decode()
            root = self._root({"uri": uri})
        write_bytes(path, (to_json(root) + "\n").encode())
        return root

    def glb_bytes(self):
        root = self._root({})
        text = json.dumps(root, separators=(",", ":")).encode()
        text += b" " * (-len(text) % 4)
        data = bytes(self.bin)
        out = struct.pack("<II", len(text), 0x4E4F534A) + text
        if data:
            out += struct.pack("<II", len(data), 0x004E4942) + data
        return struct.pack("<III", 0x46546C67, 2, 12 + len(out)) + out

    def write_glb(self, rel_path):
        write_bytes(os.path.join(HERE, rel_path), self.glb_bytes())


def write_bytes(path, data):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb") as f:
        f.write(data)


def write_text(rel_path, text):
    write_bytes(os.path.join(HERE, rel_path), text.encode())


# =============================================================================================
# Building blocks shared by the files
# =============================================================================================
def quad_xy(x0, y0, x1, y1, z=0.0):
    """A quad in the plane z, counter-clockwise seen from +Z (normal +Z); UVs: v down."""
    pos = [(x0, y0, z), (x1, y0, z), (x1, y1, z), (x0, y1, z)]
    nrm = [(0.0, 0.0, 1.0)] * 4
    uv = [(0.0, 1.0), (1.0, 1.0), (1.0, 0.0), (0.0, 0.0)]
    return pos, nrm, uv, [0, 1, 2, 0, 2, 3]


def add_quad_primitive(b, x0, y0, x1, y1, z=0.0, material=None, normals=True, uv_scale=None,
                       index_type=UNSIGNED_SHORT):
    pos, nrm, uv, idx = quad_xy(x0, y0, x1, y1, z)
    attrs = {"POSITION": b.positions(pos)}
    if normals:
        attrs["NORMAL"] = b.attribute(nrm)
    if uv_scale is not None:
        attrs["TEXCOORD_0"] = b.attribute([(u * uv_scale, v * uv_scale) for u, v in uv], "VEC2")
    prim = {"attributes": attrs, "indices": b.indices(idx, index_type)}
    if material is not None:
        prim["material"] = material
    return prim


def add_camera(b, position=(0.0, 0.0, 4.0), rotation=None, name="camera", yfov=0.8):
    props = {"camera": b.perspective(name, yfov=yfov), "translation": list(position)}
    if rotation is not None:
        props["rotation"] = rotation
    return b.node(name, **props)


def add_sun(b, rotation=None, intensity=3.0, name="sun"):
    """A directional light; without rotation it shines along -Z (onto +Z-facing quads)."""
    props = {"translation": [0.0, 0.0, 5.0]}
    if rotation is not None:
        props["rotation"] = rotation
    return b.light_node(name, {"name": name, "type": "directional", "color": [1.0, 1.0, 1.0],
                               "intensity": intensity}, **props)


def grey(b):
    return b.material("grey", (0.8, 0.8, 0.8, 1.0))


def simple_quad_scene(b, material=None, camera=True, light=True):
    """A 2x2 quad at the origin facing +Z, a camera on +Z looking at it, a sun behind the camera."""
    if material is None:
        material = grey(b)
    mesh = b.mesh("quad", [add_quad_primitive(b, -1, -1, 1, 1, material=material)])
    nodes = [b.node("quad", mesh=mesh)]
    if camera:
        nodes.append(add_camera(b))
    if light:
        nodes.append(add_sun(b))
    b.scene(nodes)


def triangle_builder():
    """One triangle (no material: glTF's default material), a camera, a sun."""
    b = Builder()
    pos = [(-1.0, -1.0, 0.0), (1.0, -1.0, 0.0), (0.0, 1.0, 0.0)]
    prim = {"attributes": {"POSITION": b.positions(pos), "NORMAL": b.attribute([(0.0, 0.0, 1.0)] * 3)},
            "indices": b.indices([0, 1, 2])}
    mesh = b.mesh("triangle", [prim])
    b.scene([b.node("triangle", mesh=mesh), add_camera(b), add_sun(b)])
    return b


def ok(file, description, triangles, punctual=0, emissive=0, cameras=1, warnings=(), **extra):
    e = {"file": file, "expect": "ok", "description": description, "triangles": triangles,
         "lights": {"punctual": punctual, "emissive_triangles": emissive}, "cameras": cameras,
         "warnings_contain": list(warnings)}
    e.update(extra)
    return e


def bad(file, description, exit_code=3, contains=(), any_of=None, **extra):
    e = {"file": file, "expect": "error", "description": description, "exit_code": exit_code,
         "message_contains": list(contains)}
    if any_of:
        e["message_contains_any"] = list(any_of)
    e.update(extra)
    return e


# =============================================================================================
# Good files: one loader feature each
# =============================================================================================
def make_triangle_gltf_external():
    triangle_builder().write_gltf("triangle_gltf_external.gltf", "external")
    return ok("triangle_gltf_external.gltf", "one triangle, external .bin buffer, default material",
              1, punctual=1, features=["external buffer", "default material"])


def make_triangle_datauri():
    triangle_builder().write_gltf("triangle_datauri.gltf", "datauri")
    return ok("triangle_datauri.gltf", "one triangle, base64 data: URI buffer", 1, punctual=1,
              features=["data uri buffer"])


def make_triangle_glb():
    triangle_builder().write_glb("triangle.glb")
    return ok("triangle.glb", "one triangle in a binary .glb with a BIN chunk", 1, punctual=1,
              features=["glb"])


def make_no_indices():
    b = Builder()
    pos, nrm, _, idx = quad_xy(-1, -1, 1, 1)
    prim = {"attributes": {"POSITION": b.positions([pos[i] for i in idx]),
                           "NORMAL": b.attribute([nrm[i] for i in idx])},
            "material": grey(b)}
    mesh = b.mesh("quad_no_indices", [prim])
    b.scene([b.node("quad", mesh=mesh), add_camera(b), add_sun(b)])
    b.write_gltf("no_indices.gltf")
    return ok("no_indices.gltf", "a quad as 6 non-indexed vertices (no indices accessor)", 2,
              punctual=1, features=["non-indexed"])


def make_no_normals():
    b = Builder()
    mesh = b.mesh("quad_no_normals", [add_quad_primitive(b, -1, -1, 1, 1, material=grey(b),
                                                         normals=False)])
    b.scene([b.node("quad", mesh=mesh), add_camera(b), add_sun(b)])
    b.write_gltf("no_normals.gltf")
    return ok("no_normals.gltf", "quad without NORMAL: normals must be computed (flat, +Z)", 2,
              punctual=1, features=["computed normals"],
              details={"expected_normal": [0.0, 0.0, 1.0]})


def make_strip_fan():
    b = Builder()
    mat = grey(b)
    # TRIANGLE_STRIP, indexed, 4 vertices: triangles (0,1,2) and (1,3,2) -> both face +Z.
    strip = [(-2.0, -1.0, 0.0), (-1.0, -1.0, 0.0), (-2.0, 0.5, 0.0), (-1.0, 0.5, 0.0)]
    strip_prim = {"attributes": {"POSITION": b.positions(strip)},
                  "indices": b.indices([0, 1, 2, 3]), "material": mat, "mode": TRIANGLE_STRIP}
    # TRIANGLE_FAN, non-indexed, 5 vertices: centre then a half circle, counter-clockwise.
    fan = [(1.0, -1.0, 0.0)] + [(1.0 + math.cos(a * math.pi / 3), -1.0 + math.sin(a * math.pi / 3), 0.0)
                                for a in range(4)]
    fan_prim = {"attributes": {"POSITION": b.positions(fan)}, "material": mat,
                "mode": TRIANGLE_FAN}
    mesh = b.mesh("strip_and_fan", [strip_prim, fan_prim])
    b.scene([b.node("strip_and_fan", mesh=mesh), add_camera(b), add_sun(b)])
    b.write_gltf("strip_fan.gltf")
    return ok("strip_fan.gltf",
              "one TRIANGLE_STRIP (4 vertices, indexed = 2 triangles) and one TRIANGLE_FAN "
              "(5 vertices, not indexed = 3 triangles), all facing +Z, no normals", 5,
              punctual=1, features=["triangle strip", "triangle fan", "computed normals"],
              details={"expected_normal": [0.0, 0.0, 1.0]})


def make_points_lines():
    b = Builder()
    mat = grey(b)
    tri = b.positions([(-1.0, -1.0, 0.0), (1.0, -1.0, 0.0), (0.0, 1.0, 0.0)])
    # the points and lines lie inside the triangle's bounds, so the bounds are the triangle's
    pts = b.positions([(-0.5, -0.5, 0.0), (0.0, 0.0, 0.0), (0.5, -0.5, 0.0)])
    prims = [
        {"attributes": {"POSITION": pts}, "mode": POINTS},
        {"attributes": {"POSITION": pts}, "indices": b.indices([0, 1, 1, 2]), "mode": LINES},
        {"attributes": {"POSITION": pts}, "mode": LINE_STRIP},
        {"attributes": {"POSITION": pts}, "mode": LINE_LOOP},
        {"attributes": {"POSITION": tri}, "indices": b.indices([0, 1, 2]), "material": mat},
    ]
    mesh = b.mesh("mixed_modes", prims)
    b.scene([b.node("mixed", mesh=mesh), add_camera(b), add_sun(b)])
    b.write_gltf("points_lines.gltf")
    return ok("points_lines.gltf",
              "POINTS, LINES, LINE_STRIP and LINE_LOOP primitives (skipped with a warning) and "
              "one triangle", 1, punctual=1, warnings=["point", "line"],
              features=["points/lines skipped"])


def make_hierarchy_trs():
    b = Builder()
    mesh = b.mesh("quad", [add_quad_primitive(b, -0.5, -0.5, 0.5, 0.5, material=grey(b))])
    # child: a column-major matrix = translate (0.5, 0, 0) * scale (1, 0.5, 1)
    child = b.node("child_matrix", mesh=mesh,
                   matrix=[1.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0,
                           0.5, 0.0, 0.0, 1.0])
    # parent: T (1,2,3) * R (90 deg about +Y) * S (2,2,2)
    parent = b.node("parent_trs", children=[child], translation=[1.0, 2.0, 3.0],
                    rotation=quat_axis_angle((0, 1, 0), math.pi / 2), scale=[2.0, 2.0, 2.0])
    # the quad ends up in the plane x = 1 facing +X: look at it from +X
    look_minus_x = quat_axis_angle((0, 1, 0), math.pi / 2)
    cam = add_camera(b, position=(5.0, 2.0, 2.0), rotation=look_minus_x)
    sun = add_sun(b, rotation=look_minus_x)
    b.scene([parent, cam, sun])
    b.write_gltf("hierarchy_trs.gltf")
    # by hand: local (x, y, 0) -> child (x + 0.5, y / 2, 0) -> scale 2 (2x + 1, y, 0)
    # -> rotate 90 about Y (0, y, -(2x + 1)) -> translate (1, y + 2, 2 - 2x); x, y in [-0.5, 0.5]
    return ok("hierarchy_trs.gltf",
              "parent node with translation/rotation/scale, child with a matrix (translate + "
              "non-uniform scale), mesh on the child: world bounds prove the composition", 2,
              punctual=1, features=["node hierarchy", "TRS", "matrix"],
              bounds={"min": [1.0, 1.5, 1.0], "max": [1.0, 2.5, 3.0]},
              details={"expected_normal": [1.0, 0.0, 0.0]})


def make_negative_scale():
    b = Builder()
    mat = b.material("emit_one_sided", (0.0, 0.0, 0.0, 1.0), double_sided=False,
                     emissiveFactor=[1.0, 1.0, 1.0])
    # no NORMAL: the winding is the only source of the facing direction
    mesh = b.mesh("emissive_quad", [add_quad_primitive(b, 0.1, -0.9, 0.9, 0.9, material=mat,
                                                       normals=False)])
    right = b.node("right", mesh=mesh)
    left = b.node("left_mirrored", mesh=mesh, scale=[-1.0, 1.0, 1.0])
    cam = b.node("camera", camera=b.orthographic("ortho", 1.0, 1.0), translation=[0.0, 0.0, 5.0])
    b.scene([right, left, cam])
    b.write_gltf("negative_scale.gltf")
    return ok("negative_scale.gltf",
              "a one-sided emissive quad (no normals) on x>0 and the same mesh mirrored by scale "
              "(-1,1,1) onto x<0: the mirror flips the winding, so the loader must flip it back "
              "(checked by the loader's unit test: emission leaves both faces, as in Cycles); "
              "both halves of the image must be bright", 4, emissive=4,
              features=["negative scale", "one-sided emission"],
              bounds={"min": [-0.9, -0.9, 0.0], "max": [0.9, 0.9, 0.0]},
              render_checks=[
                  {"region": [0, 0, 4, 8], "rgb_min": [0.2, 0.2, 0.2], "what": "left (mirrored) half lit"},
                  {"region": [4, 0, 8, 8], "rgb_min": [0.2, 0.2, 0.2], "what": "right half lit"}])


def make_instances():
    b = Builder()
    mesh = b.mesh("shared_quad", [add_quad_primitive(b, -0.4, -0.4, 0.4, 0.4, material=grey(b))])
    nodes = [b.node("instance_%d" % i, mesh=mesh, translation=[x, 0.0, 0.0])
             for i, x in enumerate((-1.2, 0.0, 1.2))]
    b.scene(nodes + [add_camera(b), add_sun(b)])
    b.write_gltf("instances.gltf")
    return ok("instances.gltf", "one mesh (2 triangles) used by 3 nodes: 3 instances", 6,
              punctual=1, features=["instancing"], details={"meshes": 1, "instances": 3},
              bounds={"min": [-1.6, -0.4, 0.0], "max": [1.6, 0.4, 0.0]})


def make_textured():
    b = Builder()
    b.use_extension("KHR_texture_transform")
    image = b.png_image("checker", checker_png())
    variants = [
        ("repeat", REPEAT, REPEAT, NEAREST, NEAREST_MIPMAP_NEAREST,
         {"offset": [0.25, 0.0], "scale": [2.0, 2.0]}),
        ("mirrored_repeat", MIRRORED_REPEAT, MIRRORED_REPEAT, LINEAR, LINEAR_MIPMAP_LINEAR,
         {"rotation": 0.5}),
        ("clamp_to_edge", CLAMP_TO_EDGE, REPEAT, LINEAR, LINEAR,
         {"offset": [-0.5, -0.5], "rotation": 0.25, "scale": [1.5, 0.75]}),
    ]
    prims = []
    for i, (name, ws, wt, mag, mn, transform) in enumerate(variants):
        tex = b.texture(image, b.sampler(ws, wt, mag, mn, name=name))
        mat = b.material("checker_" + name, (1.0, 1.0, 1.0, 1.0), pbrMetallicRoughness={
            "baseColorFactor": [1.0, 1.0, 1.0, 1.0],
            "baseColorTexture": {"index": tex, "texCoord": 0,
                                 "extensions": {"KHR_texture_transform": transform}},
            "metallicFactor": 0.0, "roughnessFactor": 1.0})
        x0 = -1.6 + i * 1.1
        # UVs run 0..2 so that the wrap modes show
        prims.append(add_quad_primitive(b, x0, -0.5, x0 + 1.0, 0.5, material=mat, uv_scale=2.0))
    mesh = b.mesh("three_samplers", prims)
    b.scene([b.node("textured", mesh=mesh), add_camera(b), add_sun(b)])
    b.write_gltf("textured.gltf")
    return ok("textured.gltf",
              "three quads with the same embedded (data: URI) 4x4 RGBA PNG as baseColorTexture, "
              "samplers REPEAT / MIRRORED_REPEAT / CLAMP_TO_EDGE (+ NEAREST / LINEAR filters), "
              "each with KHR_texture_transform, TEXCOORD_0 spanning 0..2", 6, punctual=1,
              features=["base colour texture", "data uri image", "sampler wrap modes",
                        "KHR_texture_transform", "TEXCOORD_0"])


def make_textured_external_png():
    b = Builder()
    write_bytes(os.path.join(HERE, "checker_4x4.png"), checker_png())
    image = b.png_image("checker", None, how="checker_4x4.png")
    tex = b.texture(image, b.sampler())
    mat = b.material("checker", pbrMetallicRoughness={
        "baseColorTexture": {"index": tex}, "metallicFactor": 0.0, "roughnessFactor": 1.0})
    mesh = b.mesh("quad", [add_quad_primitive(b, -1, -1, 1, 1, material=mat, uv_scale=1.0)])
    b.scene([b.node("quad", mesh=mesh), add_camera(b), add_sun(b)])
    b.write_gltf("textured_external_png.gltf")
    return ok("textured_external_png.gltf", "base colour texture from an external .png file", 2,
              punctual=1, features=["external image"])


def make_textured_bufferview_glb():
    b = Builder()
    image = b.png_image("checker", checker_png(), how="bufferView")
    tex = b.texture(image, b.sampler(CLAMP_TO_EDGE, CLAMP_TO_EDGE))
    mat = b.material("checker", pbrMetallicRoughness={
        "baseColorTexture": {"index": tex}, "metallicFactor": 0.0, "roughnessFactor": 1.0})
    mesh = b.mesh("quad", [add_quad_primitive(b, -1, -1, 1, 1, material=mat, uv_scale=1.0)])
    b.scene([b.node("quad", mesh=mesh), add_camera(b), add_sun(b)])
    b.write_glb("textured_bufferview.glb")
    return ok("textured_bufferview.glb", "a .glb whose PNG image is stored in a bufferView", 2,
              punctual=1, features=["glb", "bufferView image"])


def make_uri_percent_encoded():
    b = Builder()
    write_bytes(os.path.join(HERE, "assets", "checker 4x4.png"), checker_png())
    image = b.png_image("checker", None, how="assets/checker%204x4.png")
    tex = b.texture(image)
    mat = b.material("checker", pbrMetallicRoughness={
        "baseColorTexture": {"index": tex}, "metallicFactor": 0.0, "roughnessFactor": 1.0})
    mesh = b.mesh("quad", [add_quad_primitive(b, -1, -1, 1, 1, material=mat, uv_scale=1.0)])
    b.scene([b.node("quad", mesh=mesh), add_camera(b), add_sun(b)])
    b.write_gltf("uri_percent_encoded.gltf", bin_name="assets/quad%20data.bin")
    return ok("uri_percent_encoded.gltf",
              "buffer and image uris relative to a subfolder with a space, percent-encoded "
              "('assets/quad%20data.bin', 'assets/checker%204x4.png')", 2, punctual=1,
              features=["uri percent-decoding", "texture without sampler"])


def make_pbr_textures():
    b = Builder()
    images = {name: b.png_image(name, data) for name, data in [
        ("base_color", checker_png()), ("metallic_roughness", metallic_roughness_png()),
        ("normal", normal_map_png()), ("emissive", emissive_png())]}
    tex = {name: b.texture(i) for name, i in images.items()}  # no sampler: default sampler
    mat = b.add("materials", {
        "name": "all_textures",
        "pbrMetallicRoughness": {
            "baseColorFactor": [1.0, 1.0, 1.0, 1.0],
            "baseColorTexture": {"index": tex["base_color"]},
            "metallicFactor": 1.0, "roughnessFactor": 1.0,
            "metallicRoughnessTexture": {"index": tex["metallic_roughness"], "texCoord": 1},
        },
        "normalTexture": {"index": tex["normal"], "scale": 0.5},
        "occlusionTexture": {"index": tex["metallic_roughness"], "strength": 1.0},
        "emissiveTexture": {"index": tex["emissive"]},
        "emissiveFactor": [0.5, 0.5, 0.5],
    })
    pos, nrm, uv, idx = quad_xy(-1, -1, 1, 1)
    attrs = {
        "POSITION": b.positions(pos),
        "NORMAL": b.attribute(nrm),
        "TANGENT": b.attribute([(1.0, 0.0, 0.0, 1.0)] * 4, "VEC4"),
        "TEXCOORD_0": b.attribute(uv, "VEC2"),
        # TEXCOORD_1 as normalized unsigned short (allowed by core glTF 2.0)
        "TEXCOORD_1": b.attribute([(int(u * 65535), int(v * 65535)) for u, v in uv], "VEC2",
                                  UNSIGNED_SHORT, normalized=True),
    }
    mesh = b.mesh("quad", [{"attributes": attrs, "indices": b.indices(idx), "material": mat}])
    b.scene([b.node("quad", mesh=mesh), add_camera(b), add_sun(b)])
    b.write_gltf("pbr_textures.gltf")
    return ok("pbr_textures.gltf",
              "base colour, metallic-roughness (on TEXCOORD_1, normalized uint16), normal (scale "
              "0.5, TANGENT given), occlusion and emissive textures; default samplers", 2,
              punctual=1, emissive=2,
              features=["metallic-roughness texture", "normal texture", "emissive texture",
                        "TEXCOORD_1", "TANGENT", "default sampler"])


def make_normal_map_no_tangents():
    b = Builder()
    tex = b.texture(b.png_image("normal", normal_map_png()), b.sampler())
    mat = b.material("bumpy", normalTexture={"index": tex})
    mesh = b.mesh("quad", [add_quad_primitive(b, -1, -1, 1, 1, material=mat, uv_scale=1.0)])
    b.scene([b.node("quad", mesh=mesh), add_camera(b), add_sun(b)])
    b.write_gltf("normal_map_no_tangents.gltf")
    return ok("normal_map_no_tangents.gltf",
              "a normal texture and no TANGENT attribute: tangents must be generated (MikkTSpace)",
              2, punctual=1, features=["generated tangents"])


def make_vertex_colors():
    b = Builder()
    mat = b.material("white", (1.0, 1.0, 1.0, 1.0))
    prims = []
    # float VEC4
    p = add_quad_primitive(b, -1.6, -0.5, -0.6, 0.5, material=mat)
    p["attributes"]["COLOR_0"] = b.attribute(
        [(1.0, 0.0, 0.0, 1.0), (0.0, 1.0, 0.0, 1.0), (0.0, 0.0, 1.0, 1.0), (1.0, 1.0, 0.0, 1.0)],
        "VEC4")
    prims.append(p)
    # normalized unsigned byte VEC3 (byteStride 4: vertex attributes are 4-byte aligned)
    p = add_quad_primitive(b, -0.5, -0.5, 0.5, 0.5, material=mat)
    p["attributes"]["COLOR_0"] = b.attribute(
        [(255, 0, 0), (0, 255, 0), (0, 0, 255), (255, 255, 255)], "VEC3", UNSIGNED_BYTE,
        normalized=True, stride=4)
    prims.append(p)
    # normalized unsigned short VEC4
    p = add_quad_primitive(b, 0.6, -0.5, 1.6, 0.5, material=mat)
    p["attributes"]["COLOR_0"] = b.attribute(
        [(65535, 32768, 0, 65535), (0, 65535, 32768, 65535), (32768, 0, 65535, 65535),
         (65535, 65535, 65535, 65535)], "VEC4", UNSIGNED_SHORT, normalized=True)
    prims.append(p)
    mesh = b.mesh("coloured_quads", prims)
    b.scene([b.node("coloured", mesh=mesh), add_camera(b), add_sun(b)])
    b.write_gltf("vertex_colors.gltf")
    return ok("vertex_colors.gltf",
              "COLOR_0 as float VEC4, as normalized uint8 VEC3 (byteStride 4) and as normalized "
              "uint16 VEC4, on three quads", 6, punctual=1, features=["COLOR_0"])


def make_alpha_modes():
    b = Builder()
    tex = b.texture(b.png_image("checker", checker_png()), b.sampler(mag=NEAREST, min_=NEAREST))
    backdrop = b.material("backdrop", (0.9, 0.9, 0.9, 1.0))
    opaque = b.material("opaque", (0.2, 0.8, 0.2, 0.5), alphaMode="OPAQUE")  # alpha ignored
    mask = b.material("mask", pbrMetallicRoughness={
        "baseColorFactor": [1.0, 1.0, 1.0, 1.0], "baseColorTexture": {"index": tex},
        "metallicFactor": 0.0, "roughnessFactor": 1.0}, alphaMode="MASK", alphaCutoff=0.5)
    blend = b.material("blend", (0.2, 0.2, 1.0, 0.3), alphaMode="BLEND")
    prims = [
        add_quad_primitive(b, -2.0, -1.0, 2.0, 1.0, z=-0.5, material=backdrop),
        add_quad_primitive(b, -1.6, -0.5, -0.6, 0.5, material=opaque),
        add_quad_primitive(b, -0.5, -0.5, 0.5, 0.5, material=mask, uv_scale=1.0),
        add_quad_primitive(b, 0.6, -0.5, 1.6, 0.5, material=blend),
    ]
    mesh = b.mesh("alpha_quads", prims)
    b.scene([b.node("alpha", mesh=mesh), add_camera(b), add_sun(b)])
    b.write_gltf("alpha_modes.gltf")
    return ok("alpha_modes.gltf",
              "three quads over a backdrop: OPAQUE (alpha 0.5 ignored), MASK (alphaCutoff 0.5, "
              "texture alpha 1 / 0.5 / 0), BLEND (alpha 0.3, stochastic transparency)", 8,
              punctual=1, features=["alphaMode OPAQUE", "alphaMode MASK", "alphaMode BLEND"])


def make_lights_punctual():
    b = Builder()
    mesh = b.mesh("floor", [{
        "attributes": {"POSITION": b.positions([(-3.0, 0.0, 3.0), (3.0, 0.0, 3.0), (3.0, 0.0, -3.0),
                                                (-3.0, 0.0, -3.0)]),
                       "NORMAL": b.attribute([(0.0, 1.0, 0.0)] * 4)},
        "indices": b.indices([0, 1, 2, 0, 2, 3]), "material": grey(b)}])
    floor = b.node("floor", mesh=mesh)
    point = b.light_node("point", {"name": "point", "type": "point", "color": [1.0, 0.9, 0.8],
                                   "intensity": 100.0, "range": 50.0},
                         translation=[0.0, 2.0, 0.0])
    # spot: under a translated and scaled parent (scale must not change the light's intensity);
    # rotated -90 deg about X so that its -Z points down
    spot = b.light_node("spot", {"name": "spot", "type": "spot", "color": [1.0, 1.0, 1.0],
                                 "intensity": 200.0,
                                 "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.6}},
                        translation=[0.75, 0.5, 0.0],
                        rotation=quat_axis_angle((1, 0, 0), -math.pi / 2))
    rig = b.node("spot_rig", children=[spot], translation=[0.0, 1.0, 0.0], scale=[2.0, 2.0, 2.0])
    # directional: rotated -45 deg about X: shines along (0, -sin 45, -cos 45)
    sun = b.light_node("sun", {"name": "sun", "type": "directional", "color": [1.0, 1.0, 1.0],
                               "intensity": 3.0},
                       translation=[0.0, 10.0, 10.0],
                       rotation=quat_axis_angle((1, 0, 0), -math.pi / 4))
    cam = add_camera(b, position=(0.0, 3.0, 5.0),
                     rotation=quat_axis_angle((1, 0, 0), -math.atan2(3.0, 5.0)))
    b.scene([floor, point, rig, sun, cam])
    b.write_gltf("lights_punctual.gltf")
    s = math.sqrt(0.5)
    return ok("lights_punctual.gltf",
              "KHR_lights_punctual over a floor: point 100 cd at (0,2,0), spot 200 cd (inner 0.3, "
              "outer 0.6 rad) under a scaled parent at (1.5,2,0) pointing down, directional 3 lx "
              "along (0,-0.707,-0.707). Intensities in the file's units (cd, lx)", 2, punctual=3,
              features=["KHR_lights_punctual point", "spot", "directional", "light node transform"],
              details={"lights": [
                  {"type": "point", "name": "point", "position": [0.0, 2.0, 0.0],
                   "intensity": 100.0, "color": [1.0, 0.9, 0.8], "range": 50.0},
                  {"type": "spot", "name": "spot", "position": [1.5, 2.0, 0.0],
                   "direction": [0.0, -1.0, 0.0], "intensity": 200.0,
                   "inner_cone_angle": 0.3, "outer_cone_angle": 0.6},
                  {"type": "directional", "name": "sun", "direction": [0.0, -s, -s],
                   "intensity": 3.0}]},
              # Caustic reads cd as W/sr x 683 (Blender's exporter convention), so the
              # 100 cd point light is 0.146 W/sr: the floor below it has radiance ~0.009
              # and the image mean is ~0.005. The check only asks for a lit floor.
              render_checks=[{"region": [0, 0, 8, 8], "rgb_min": [0.002, 0.002, 0.002],
                              "what": "the floor is lit"}])


def make_emissive_strength():
    b = Builder()
    b.use_extension("KHR_materials_emissive_strength")
    mat = b.material("emitter", (0.0, 0.0, 0.0, 1.0), double_sided=False,
                     emissiveFactor=[1.0, 0.5, 0.25],
                     extensions={"KHR_materials_emissive_strength": {"emissiveStrength": 5.0}})
    mesh = b.mesh("emissive_wall", [add_quad_primitive(b, -10, -10, 10, 10, material=mat)])
    b.scene([b.node("wall", mesh=mesh), add_camera(b, position=(0.0, 0.0, 2.0), yfov=0.5)])
    b.write_gltf("emissive_strength.gltf")
    return ok("emissive_strength.gltf",
              "a black emissive quad, emissiveFactor (1,0.5,0.25) x KHR_materials_emissive_strength "
              "5, filling the view: every pixel's radiance is (5, 2.5, 1.25)", 2, emissive=2,
              features=["emissive triangles", "KHR_materials_emissive_strength"],
              details={"radiance": [5.0, 2.5, 1.25]},
              render_checks=[{"region": [0, 0, 8, 8], "rgb_min": [4.95, 2.475, 1.2375],
                              "rgb_max": [5.05, 2.525, 1.2625], "alpha_min": 0.999,
                              "what": "radiance seen directly = emission"}])


def make_camera_ortho():
    b = Builder()
    mesh = b.mesh("quad", [add_quad_primitive(b, -1, -1, 1, 1, material=grey(b))])
    cam = b.node("camera", camera=b.orthographic("ortho", 1.5, 1.0), translation=[0.0, 0.0, 4.0])
    b.scene([b.node("quad", mesh=mesh), cam, add_sun(b)])
    b.write_gltf("camera_ortho.gltf")
    return ok("camera_ortho.gltf", "orthographic camera, xmag 1.5, ymag 1.0 (3:2), znear 0.01, "
              "zfar 100", 2, punctual=1, features=["orthographic camera"],
              details={"camera": {"type": "orthographic", "xmag": 1.5, "ymag": 1.0}})


def make_camera_no_aspect():
    b = Builder()
    mesh = b.mesh("quad", [add_quad_primitive(b, -1, -1, 1, 1, material=grey(b))])
    cam = b.node("camera", camera=b.perspective("no_aspect", yfov=0.8, aspect=None),
                 translation=[0.0, 0.0, 4.0])
    b.scene([b.node("quad", mesh=mesh), cam, add_sun(b)])
    b.write_gltf("camera_no_aspect.gltf")
    return ok("camera_no_aspect.gltf", "perspective camera without aspectRatio (and no zfar): "
              "the aspect comes from the output resolution", 2, punctual=1,
              features=["perspective camera without aspectRatio", "infinite zfar"])


def make_two_cameras():
    b = Builder()
    # a unit cube: 6 faces x 2 triangles, outward normals
    faces = []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = [0.0, 0.0, 0.0]
            n[axis] = sign
            u = [0.0, 0.0, 0.0]
            v = [0.0, 0.0, 0.0]
            u[(axis + 1) % 3] = 1.0
            v[(axis + 2) % 3] = 1.0
            if sign < 0:
                u, v = v, u
            c = [0.5 * x for x in n]
            corners = [tuple(c[k] + su * 0.5 * u[k] + sv * 0.5 * v[k] for k in range(3))
                       for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
            faces.append((corners, tuple(n)))
    pos, nrm, idx = [], [], []
    for corners, n in faces:
        base = len(pos)
        pos += corners
        nrm += [n] * 4
        idx += [base, base + 1, base + 2, base, base + 2, base + 3]
    mesh = b.mesh("cube", [{"attributes": {"POSITION": b.positions(pos), "NORMAL": b.attribute(nrm)},
                            "indices": b.indices(idx), "material": grey(b)}])
    front = b.node("Front", camera=b.perspective("Front", zfar=100.0), translation=[0.0, 0.0, 4.0])
    top = b.node("Top", camera=b.perspective("Top"), translation=[0.0, 4.0, 0.0],
                 rotation=quat_axis_angle((1, 0, 0), -math.pi / 2))
    sun_rot = quat_mul(quat_axis_angle((0, 1, 0), math.pi / 6), quat_axis_angle((1, 0, 0), -math.pi / 3))
    b.scene([b.node("cube", mesh=mesh), front, top, add_sun(b, rotation=sun_rot)])
    b.write_gltf("two_cameras.gltf")
    return ok("two_cameras.gltf", "a cube seen by two cameras named 'Front' (index 0, on +Z) and "
              "'Top' (index 1, on +Y looking down); --camera Top / --camera 1 select the second",
              12, punctual=1, cameras=2, features=["several cameras", "camera by name"],
              details={"camera_names": ["Front", "Top"],
                       "camera_positions": [[0.0, 0.0, 4.0], [0.0, 4.0, 0.0]]},
              bounds={"min": [-0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5]})


def make_no_camera():
    b = Builder()
    simple_quad_scene(b, camera=False)
    b.write_gltf("no_camera.gltf")
    return ok("no_camera.gltf", "a lit quad and no camera: the loader frames the bounds and warns",
              2, punctual=1, cameras=0, warnings=["camera"], features=["no camera: framing"],
              render_checks=[{"region": [0, 0, 8, 8], "alpha_min": 0.05,
                              "what": "the framing camera sees the quad"}])


def make_degenerate():
    b = Builder()
    pos = [(-1.0, -1.0, 0.0), (1.0, -1.0, 0.0), (1.0, 1.0, 0.0), (-1.0, 1.0, 0.0),
           (0.0, -1.0, 0.0)]  # vertex 4 lies on the edge 0-1
    idx = [0, 1, 2, 0, 2, 3,  # two good triangles
           0, 0, 1,           # repeated index: zero area
           0, 4, 1]           # three distinct collinear vertices: zero area
    mesh = b.mesh("quad_and_slivers", [{"attributes": {"POSITION": b.positions(pos)},
                                        "indices": b.indices(idx), "material": grey(b)}])
    b.scene([b.node("quad", mesh=mesh), add_camera(b), add_sun(b)])
    b.write_gltf("degenerate.gltf")
    return ok("degenerate.gltf", "two good triangles and two zero-area ones (a repeated index, "
              "three collinear vertices): dropped with a warning", 2, punctual=1,
              warnings=["degenerate"], features=["degenerate triangles dropped"],
              details={"degenerate_triangles": 2})


def make_unlit():
    b = Builder()
    simple_quad_scene(b, light=False)
    b.write_gltf("unlit.gltf")
    return ok("unlit.gltf", "geometry and a camera but no light and no emission: renders black "
              "with a warning (never a plain success)", 2, warnings=["light"],
              features=["no light warning"],
              render_checks=[{"region": [0, 0, 8, 8], "rgb_max": [0.0, 0.0, 0.0],
                              "what": "black"}])


def make_required_ext_supported():
    b = Builder()
    b.use_extension("KHR_materials_emissive_strength", required=True)
    mat = b.material("emitter", (0.0, 0.0, 0.0, 1.0), emissiveFactor=[1.0, 1.0, 1.0],
                     extensions={"KHR_materials_emissive_strength": {"emissiveStrength": 2.0}})
    simple_quad_scene(b, material=mat, light=False)
    b.write_gltf("required_ext_supported.gltf")
    return ok("required_ext_supported.gltf", "extensionsRequired "
              "['KHR_materials_emissive_strength'], which is supported: loads", 2, emissive=2,
              features=["extensionsRequired (supported)"])


def make_optional_ext_unknown():
    b = Builder()
    b.use_extension("VENDOR_made_up_extension")
    mat = b.material("grey", extensions={"VENDOR_made_up_extension": {"anything": 1}})
    simple_quad_scene(b, material=mat)
    b.write_gltf("optional_ext_unknown.gltf")
    return ok("optional_ext_unknown.gltf", "an unknown extension in extensionsUsed only (not "
              "required) on a material: ignored, loads (a warning is allowed, not required)", 2,
              punctual=1, features=["unknown optional extension ignored"])


def make_multiple_scenes():
    b = Builder()
    mat = grey(b)
    tri = b.mesh("triangle", [{"attributes": {"POSITION": b.positions(
        [(-5.0, -5.0, 0.0), (-4.0, -5.0, 0.0), (-4.5, -4.0, 0.0)])}, "indices": b.indices([0, 1, 2]),
        "material": mat}])
    quad = b.mesh("quad", [add_quad_primitive(b, -1, -1, 1, 1, material=mat)])
    b.scene([b.node("scene0_triangle", mesh=tri)], name="not_this_one", default=False)
    b.scene([b.node("scene1_quad", mesh=quad), add_camera(b), add_sun(b)], name="this_one")
    b.write_gltf("multiple_scenes.gltf")
    return ok("multiple_scenes.gltf", "two scenes, \"scene\": 1 selects the second (a quad); the "
              "first (a triangle far away) must not be loaded", 2, punctual=1,
              features=["default scene index"],
              bounds={"min": [-1.0, -1.0, 0.0], "max": [1.0, 1.0, 0.0]})


def make_no_default_scene():
    b = Builder()
    simple_quad_scene(b)
    del b.root["scene"]
    b.write_gltf("no_default_scene.gltf")
    return ok("no_default_scene.gltf", "no \"scene\" property: use scenes[0]", 2, punctual=1,
              features=["scene property absent"])


def make_interleaved():
    b = Builder()
    pos, nrm, uv, idx = quad_xy(-1, -1, 1, 1)
    data = b"".join(struct.pack("<3f3f2f", *(p + n + t)) for p, n, t in zip(pos, nrm, uv))
    view = b.view(data, ARRAY_BUFFER, stride=32)
    attrs = {
        "POSITION": b.accessor(view, FLOAT, 4, "VEC3", 0, bounds=([-1.0, -1.0, 0.0], [1.0, 1.0, 0.0])),
        "NORMAL": b.accessor(view, FLOAT, 4, "VEC3", 12),
        "TEXCOORD_0": b.accessor(view, FLOAT, 4, "VEC2", 24),
    }
    mesh = b.mesh("interleaved_quad", [{"attributes": attrs, "indices": b.indices(idx),
                                        "material": grey(b)}])
    b.scene([b.node("quad", mesh=mesh), add_camera(b), add_sun(b)])
    b.write_gltf("interleaved.gltf")
    return ok("interleaved.gltf", "POSITION, NORMAL, TEXCOORD_0 interleaved in one bufferView "
              "(byteStride 32, accessor byteOffsets 0/12/24)", 2, punctual=1,
              features=["interleaved attributes", "byteStride"])


def make_index_types():
    b = Builder()
    mat = grey(b)
    prims = [add_quad_primitive(b, x0, -0.5, x0 + 1.0, 0.5, material=mat, index_type=t)
             for x0, t in ((-1.6, UNSIGNED_BYTE), (-0.5, UNSIGNED_SHORT), (0.6, UNSIGNED_INT))]
    mesh = b.mesh("three_index_types", prims)
    b.scene([b.node("quads", mesh=mesh), add_camera(b), add_sun(b)])
    b.write_gltf("index_types.gltf")
    return ok("index_types.gltf", "three quads indexed with uint8, uint16 and uint32 indices", 6,
              punctual=1, features=["uint8 indices", "uint16 indices", "uint32 indices"])


def make_sparse_accessor():
    b = Builder()
    pos, nrm, _, idx = quad_xy(-1, -1, 1, 1)
    base = b.view(b"".join(struct.pack("<3f", *p) for p in pos), ARRAY_BUFFER)
    # sparse: vertex 2 moves from (1, 1, 0) to (1, 1.5, 0.5)
    sp_idx = b.view(struct.pack("<H", 2))
    sp_val = b.view(struct.pack("<3f", 1.0, 1.5, 0.5))
    acc = b.accessor(base, FLOAT, 4, "VEC3", bounds=([-1.0, -1.0, 0.0], [1.0, 1.5, 0.5]))
    b.root["accessors"][acc]["sparse"] = {
        "count": 1,
        "indices": {"bufferView": sp_idx, "componentType": UNSIGNED_SHORT},
        "values": {"bufferView": sp_val}}
    mesh = b.mesh("sparse_quad", [{"attributes": {"POSITION": acc}, "indices": b.indices(idx),
                                   "material": grey(b)}])
    b.scene([b.node("quad", mesh=mesh), add_camera(b), add_sun(b)])
    b.write_gltf("sparse_accessor.gltf")
    return ok("sparse_accessor.gltf", "POSITION is a sparse accessor: vertex 2 is replaced by "
              "(1, 1.5, 0.5); the bounds show whether the sparse values were applied", 2,
              punctual=1, features=["sparse accessor"],
              bounds={"min": [-1.0, -1.0, 0.0], "max": [1.0, 1.5, 0.5]})


# =============================================================================================
# Bad files: each must be refused with a clear one-line error, no output file, no panic
# =============================================================================================
def make_bad_invalid_json():
    write_text("bad/invalid_json.gltf",
               '{\n  "asset": {"version": "2.0"},\n  "scenes": [{"nodes": [0]}],\n  "nodes": [\n')
    return bad("bad/invalid_json.gltf", "JSON cut off in the middle", contains=["json"])


def make_bad_truncated_glb():
    data = triangle_builder().glb_bytes()
    write_bytes(os.path.join(HERE, "bad/truncated.glb"), data[:len(data) // 2])
    return bad("bad/truncated.glb", "a valid .glb (triangle.glb) cut in half",
               any_of=["truncat", "length", "short", "end of", "eof", "glb"])


def make_bad_wrong_magic():
    data = bytearray(triangle_builder().glb_bytes())
    data[0:4] = b"gLTf"
    write_bytes(os.path.join(HERE, "bad/wrong_magic.glb"), bytes(data))
    return bad("bad/wrong_magic.glb", "a .glb whose magic is 'gLTf' instead of 'glTF'",
               any_of=["magic", "glb", "json", "header"])


def make_bad_glb_version():
    data = bytearray(triangle_builder().glb_bytes())
    data[4:8] = struct.pack("<I", 1)
    write_bytes(os.path.join(HERE, "bad/glb_version_1.glb"), bytes(data))
    return bad("bad/glb_version_1.glb", "a .glb header with version 1", contains=["version"])


def make_bad_glb_chunk_length():
    data = bytearray(triangle_builder().glb_bytes())
    json_len = struct.unpack("<I", data[12:16])[0]
    data[12:16] = struct.pack("<I", json_len + 4096)  # JSON chunk claims more than the file has
    write_bytes(os.path.join(HERE, "bad/glb_chunk_length.glb"), bytes(data))
    return bad("bad/glb_chunk_length.glb", "a .glb whose JSON chunk length runs past the file",
               any_of=["length", "chunk", "truncat", "glb", "json"])


def make_bad_empty_file():
    write_bytes(os.path.join(HERE, "bad/empty_file.glb"), b"")
    return bad("bad/empty_file.glb", "a 0-byte file", any_of=["empty", "glb", "json", "eof",
                                                              "truncat", "end of"])


def make_bad_missing_buffer():
    b = triangle_builder()
    b.write_gltf("bad/missing_buffer.gltf", "external", bin_name="no_such_file.bin")
    os.remove(os.path.join(HERE, "bad", "no_such_file.bin"))
    return bad("bad/missing_buffer.gltf", "buffer uri 'no_such_file.bin' does not exist "
               "(a bad scene: exit 3, not 4, which is for the scene file itself)",
               contains=["no_such_file.bin"])


def make_bad_short_buffer():
    b = triangle_builder()
    root = b.write_gltf("bad/short_buffer.gltf", "external")
    root["buffers"][0]["byteLength"] = 1000  # the .bin written has far fewer bytes
    write_text("bad/short_buffer.gltf", to_json(root) + "\n")
    return bad("bad/short_buffer.gltf", "buffer byteLength 1000 but short_buffer.bin is shorter",
               contains=["buffer"])


def make_bad_view_past_buffer():
    b = triangle_builder()
    b.root["bufferViews"][0]["byteLength"] += 64  # POSITION's view now runs past the buffer end
    b.write_gltf("bad/view_past_buffer.gltf", "datauri")
    return bad("bad/view_past_buffer.gltf", "a bufferView whose byteOffset+byteLength is past the "
               "end of its buffer", contains=["buffer"])


def make_bad_accessor_out_of_range():
    b = triangle_builder()
    b.root["accessors"][0]["count"] = 30  # 30 x 12 bytes from a 36-byte bufferView
    b.write_gltf("bad/accessor_out_of_range.gltf", "datauri")
    return bad("bad/accessor_out_of_range.gltf", "POSITION accessor count 30 (x 12 bytes) past its "
               "36-byte bufferView", contains=["accessor"])


def make_bad_index_out_of_range():
    b = Builder()
    pos = [(-1.0, -1.0, 0.0), (1.0, -1.0, 0.0), (0.0, 1.0, 0.0)]
    mesh = b.mesh("triangle", [{"attributes": {"POSITION": b.positions(pos)},
                                "indices": b.indices([0, 1, 99])}])
    b.scene([b.node("triangle", mesh=mesh), add_camera(b), add_sun(b)])
    b.write_gltf("bad/index_out_of_range.gltf", "datauri")
    return bad("bad/index_out_of_range.gltf", "index 99 with 3 vertices",
               any_of=["index", "indices"])


def bad_position_file(rel_path, value):
    b = Builder()
    pos = [(-1.0, -1.0, 0.0), (1.0, -1.0, 0.0), (0.0, 1.0, 0.0)]
    acc = b.positions(pos)  # min/max from the finite values (JSON cannot hold NaN or Inf)
    mesh = b.mesh("triangle", [{"attributes": {"POSITION": acc}, "indices": b.indices([0, 1, 2])}])
    b.scene([b.node("triangle", mesh=mesh), add_camera(b), add_sun(b)])
    view = b.root["bufferViews"][b.root["accessors"][acc]["bufferView"]]
    off = view["byteOffset"] + 1 * 12 + 4  # vertex 1, y
    b.bin[off:off + 4] = struct.pack("<f", value)
    b.write_gltf(rel_path, "datauri")


def make_bad_nan_position():
    bad_position_file("bad/nan_position.gltf", float("nan"))
    return bad("bad/nan_position.gltf", "vertex 1 has y = NaN", any_of=["nan", "finite"])


def make_bad_inf_position():
    bad_position_file("bad/inf_position.gltf", float("inf"))
    return bad("bad/inf_position.gltf", "vertex 1 has y = +Inf", any_of=["inf", "finite"])


def make_bad_unsupported_required_ext():
    b = triangle_builder()
    b.use_extension("EXT_texture_avif", required=True)
    b.write_gltf("bad/unsupported_required_ext.gltf", "datauri")
    return bad("bad/unsupported_required_ext.gltf", "extensionsRequired "
               "['EXT_texture_avif']: refused, naming it",
               contains=["ext_texture_avif"])


def make_bad_unknown_required_ext():
    b = triangle_builder()
    b.use_extension("VENDOR_made_up_extension", required=True)
    b.write_gltf("bad/unknown_required_ext.gltf", "datauri")
    return bad("bad/unknown_required_ext.gltf", "extensionsRequired ['VENDOR_made_up_extension']",
               contains=["vendor_made_up_extension"])


def textured_quad_builder(image_uri=None, image_data=None):
    b = Builder()
    if image_data is not None:
        image = b.png_image("image", image_data)
    else:
        image = b.png_image("image", None, how=image_uri)
    tex = b.texture(image, b.sampler())
    mat = b.material("textured", pbrMetallicRoughness={
        "baseColorTexture": {"index": tex}, "metallicFactor": 0.0, "roughnessFactor": 1.0})
    mesh = b.mesh("quad", [add_quad_primitive(b, -1, -1, 1, 1, material=mat, uv_scale=1.0)])
    b.scene([b.node("quad", mesh=mesh), add_camera(b), add_sun(b)])
    return b


def make_bad_missing_texture():
    textured_quad_builder("no_such_texture.png").write_gltf("bad/missing_texture.gltf", "datauri")
    return bad("bad/missing_texture.gltf", "image uri 'no_such_texture.png' does not exist",
               contains=["no_such_texture.png"])


def make_bad_corrupt_png():
    data = checker_png()
    data = data[:8] + b"\xde\xad\xbe\xef" * 8 + data[40:]  # valid signature, garbage IHDR
    textured_quad_builder(image_data=data).write_gltf("bad/corrupt_png.gltf", "datauri")
    return bad("bad/corrupt_png.gltf", "an image data URI whose PNG bytes are corrupt",
               any_of=["image", "png", "texture", "decod"])


def make_bad_base64():
    b = triangle_builder()
    root = b.write_gltf("bad/bad_base64.gltf", "datauri")
    root["buffers"][0]["uri"] = "data:application/octet-stream;base64,!!not*base64~~"
    write_text("bad/bad_base64.gltf", to_json(root) + "\n")
    return bad("bad/bad_base64.gltf", "buffer data URI with invalid base64",
               any_of=["base64", "data uri", "data:"])


def make_bad_cyclic_nodes():
    b = Builder()
    mesh = b.mesh("quad", [add_quad_primitive(b, -1, -1, 1, 1, material=grey(b))])
    b.node("a", mesh=mesh, children=[1])
    b.node("b", children=[0])
    b.scene([0, add_camera(b), add_sun(b)])
    b.write_gltf("bad/cyclic_nodes.gltf", "datauri")
    return bad("bad/cyclic_nodes.gltf", "node 0 is a child of node 1 and node 1 of node 0 (must "
               "not hang or overflow the stack)", any_of=["cycle", "cyclic", "loop", "recurs",
                                                          "parent"])


def make_bad_empty_scene():
    b = Builder()
    b.scene([add_camera(b)])
    b.write_gltf("bad/empty_scene.gltf", "datauri")
    # A light or a world makes a scene without geometry renderable (Cycles renders the world's
    # background): only a file with none of them is refused.
    return bad("bad/empty_scene.gltf", "a camera alone: no mesh, no world, no light: nothing to render",
               contains=["nothing to render", "no world", "no lights"])


def make_bad_dangling_accessor():
    b = triangle_builder()
    b.root["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 7  # only 3 accessors
    b.write_gltf("bad/dangling_accessor.gltf", "datauri")
    return bad("bad/dangling_accessor.gltf", "POSITION refers to accessor 7, which does not exist",
               any_of=["accessor", "index", "range"])


def make_bad_missing_position():
    b = triangle_builder()
    del b.root["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
    b.write_gltf("bad/missing_position.gltf", "datauri")
    return bad("bad/missing_position.gltf", "the only primitive has no POSITION attribute (the "
               "spec says such a primitive is skipped: then nothing is left to render)",
               any_of=["position", "mesh", "triangle", "geometry", "nothing", "empty"])


def make_bad_accessor_past_view():
    b = Builder()
    pos = [(-1.0, -1.0, 0.0), (1.0, -1.0, 0.0), (0.0, 1.0, 0.0)]
    acc = b.positions(pos)
    b.view(struct.pack("<12f", *([0.5] * 12)))  # more data after the view, inside the buffer
    b.root["accessors"][acc]["count"] = 4       # 4 x 12 bytes from the 36-byte view
    b.root["accessors"][acc]["max"] = [1.0, 1.0, 0.5]
    mesh = b.mesh("triangle", [{"attributes": {"POSITION": acc}, "indices": b.indices([0, 1, 2])}])
    b.scene([b.node("triangle", mesh=mesh), add_camera(b), add_sun(b)])
    b.write_gltf("bad/accessor_past_view.gltf", "datauri")
    return bad("bad/accessor_past_view.gltf", "POSITION accessor (count 4 x 12 bytes) runs past "
               "its 36-byte bufferView but stays inside the buffer (gltf 1.4.1's reader only "
               "checks against the whole buffer)", contains=["accessor"])


def make_bad_percent_encoding():
    b = triangle_builder()
    b.write_gltf("bad/bad_percent_encoding.gltf", "external", bin_name="bad_%FF_name.bin")
    os.remove(os.path.join(HERE, "bad", "bad_%FF_name.bin"))
    return bad("bad/bad_percent_encoding.gltf", "buffer uri 'bad_%FF_name.bin': the percent-decoded "
               "name is not UTF-8 (gltf 1.4.1's import unwraps this decoding: must not panic)",
               any_of=["uri", "buffer", "%ff", "utf", "bad_"])


def make_bad_not_gltf():
    write_text("bad/not_gltf.txt",
               "This is not a glTF file.\nIt is plain text: no JSON object, no GLB header.\n")
    return bad("bad/not_gltf.txt", "a plain text file",
               any_of=["json", "gltf", "glb", "format", "extension"])


def make_bad_does_not_exist():
    return bad("bad/does_not_exist.gltf", "the scene file itself does not exist (never written): "
               "an I/O error", exit_code=4, contains=["does_not_exist.gltf"], absent=True)


def cornell_box_entry():
    return ok("../../scenes/cornell_box.gltf", "the bundled Cornell box (scenes/), 5 quads of "
              "walls, 2 blocks of 5 quads, a 2-triangle ceiling light of radiance (17,12,4)", 32,
              emissive=2, features=["KHR_materials_emissive_strength", "scene extras"],
              details={"resolution": [256, 256], "spp": 64},
              bounds={"min": [0.0, 0.0, 0.0], "max": [0.556, 0.5488, 0.5592]},
              render_checks=[{"region": [0, 0, 8, 8], "rgb_min": [0.01, 0.01, 0.01],
                              "what": "lit (a thin band along the top edge sees past the box)"},
                             {"region": [2, 2, 6, 6], "alpha_min": 0.999,
                              "what": "the middle is covered"}])



# =============================================================================================
# Hostile files (the reliability issue): JSON that parses but lies, absurd values, bad vendor
# extensions. Each is the one-triangle scene with one defect.
# =============================================================================================
def mutant(rel_path, mutate):
    """The one-triangle scene (camera, sun) written as a data-URI .gltf, then `mutate(root)`."""
    b = triangle_builder()
    root = b.write_gltf(rel_path, "datauri")
    mutate(root)
    write_text(rel_path, to_json(root) + "\n")


def tri_ok(rel_path, description, warnings, mutate, punctual=1, cameras=1):
    mutant(rel_path, mutate)
    return ok(rel_path, description, 1, punctual=punctual, cameras=cameras, warnings=warnings)


def tri_bad(rel_path, description, mutate, any_of, exit_code=3):
    mutant(rel_path, mutate)
    return bad(rel_path, description, exit_code=exit_code, any_of=any_of)


def setter(path, value):
    """A mutation that sets root[path...] = value (path: list of keys / indices)."""
    def mutate(root):
        obj = root
        for k in path[:-1]:
            obj = obj[k]
        obj[path[-1]] = value
    return mutate


def first_material(root):
    root.setdefault("materials", []).append({"name": "m", "pbrMetallicRoughness": {}})
    root["meshes"][0]["primitives"][0]["material"] = len(root["materials"]) - 1
    return root["materials"][-1]


def with_material(fields):
    def mutate(root):
        first_material(root).update(fields)
    return mutate


def with_ext(kind, name, value):
    """Adds a vendor/KHR extension on the triangle's node ('node'), material or scene."""
    def mutate(root):
        root.setdefault("extensionsUsed", []).append(name)
        if kind == "node":
            target = root["nodes"][0]
        elif kind == "material":
            target = first_material(root)
        else:
            target = root["scenes"][root.get("scene", 0)]
        target.setdefault("extensions", {})[name] = value
    return mutate


def hostile_makers():
    makers = []

    def add(fn):
        makers.append(fn)
        return fn

    def extreme_coordinate():
        # Found by the fuzzer: a finite 3e38 coordinate overflowed the BVH build.
        bad_position_file("bad/extreme_coordinate.gltf", 3.0e38)
        return bad("bad/extreme_coordinate.gltf", "a vertex at y = 3e38 (finite, but no room for box arithmetic)",
                   any_of=["beyond", "finite"])
    add(extreme_coordinate)
    add(lambda: tri_bad("bad/stride_smaller_than_element.gltf", "POSITION view byteStride 8 < 12",
                        setter(["bufferViews", 0, "byteStride"], 8), ["stride"]))
    add(lambda: tri_bad("bad/node_twice_as_root.gltf", "the scene lists node 0 twice",
                        lambda r: r["scenes"][0]["nodes"].append(0), ["node 0", "twice", "parent"]))

    def two_parents(root):
        root["nodes"].append({"name": "a", "children": [0]})
        root["nodes"].append({"name": "b", "children": [0]})
        root["scenes"][0]["nodes"] = [len(root["nodes"]) - 2, len(root["nodes"]) - 1] + root["scenes"][0]["nodes"][1:]
    add(lambda: tri_bad("bad/node_two_parents.gltf", "node 0 is the child of two nodes", two_parents,
                        ["parent", "node 0"]))

    def dag_explosion(root):
        # 40 levels, each node listing the next twice: 2^40 instances if walked naively.
        n0 = len(root["nodes"])
        for i in range(40):
            root["nodes"].append({"name": "level%d" % i, "children": [n0 + i + 1, n0 + i + 1] if i < 39 else [0]})
        root["scenes"][0]["nodes"] = [n0] + root["scenes"][0]["nodes"][1:]
    add(lambda: tri_bad("bad/node_dag_explosion.gltf", "a 40-level DAG of shared children (2^40 paths)",
                        dag_explosion, ["parent", "twice", "instances"]))
    add(lambda: tri_bad("bad/huge_scale.gltf", "node scale 1e38 makes world positions infinite",
                        setter(["nodes", 0, "scale"], [1e38, 1e38, 1e38]), ["finite", "infinite"]))
    add(lambda: tri_bad("bad/camera_zero_fov.gltf", "yfov 0",
                        setter(["cameras", 0, "perspective", "yfov"], 0.0), ["yfov", "fov"]))
    add(lambda: tri_bad("bad/camera_negative_fov.gltf", "yfov -1",
                        setter(["cameras", 0, "perspective", "yfov"], -1.0), ["yfov", "fov"]))
    add(lambda: tri_bad("bad/camera_fov_too_wide.gltf", "yfov 4 rad (> pi)",
                        setter(["cameras", 0, "perspective", "yfov"], 4.0), ["yfov", "fov"]))
    add(lambda: tri_bad("bad/camera_zero_aspect.gltf", "aspectRatio 0",
                        setter(["cameras", 0, "perspective", "aspectRatio"], 0.0), ["aspect"]))
    add(lambda: tri_bad("bad/light_negative_intensity.gltf", "a sun of intensity -3",
                        setter(["extensions", "KHR_lights_punctual", "lights", 0, "intensity"], -3.0),
                        ["intensity"]))
    add(lambda: tri_bad("bad/light_negative_color.gltf", "a sun of colour (1, -1, 1)",
                        setter(["extensions", "KHR_lights_punctual", "lights", 0, "color"], [1.0, -1.0, 1.0]),
                        ["color", "colour"]))
    add(lambda: tri_bad("bad/light_index_out_of_range.gltf", "a node refers to light 7",
                        setter(["nodes", 2, "extensions", "KHR_lights_punctual", "light"], 7),
                        ["light", "index", "range"]))
    add(lambda: tri_bad("bad/mesh_index_out_of_range.gltf", "node 0 refers to mesh 9",
                        setter(["nodes", 0, "mesh"], 9), ["mesh", "index", "range"]))
    add(lambda: tri_bad("bad/scene_node_out_of_range.gltf", "the scene lists node 42",
                        lambda r: r["scenes"][0]["nodes"].append(42), ["node", "index", "range"]))
    add(lambda: tri_bad("bad/material_index_out_of_range.gltf", "the primitive uses material 5",
                        setter(["meshes", 0, "primitives", 0, "material"], 5), ["material", "index", "range"]))
    add(lambda: tri_bad("bad/json_empty_object.gltf", "the JSON root is an empty object",
                        lambda r: (r.clear()), ["version", "object", "asset"]))

    def array_root():
        write_text("bad/json_array_root.gltf", "[1, 2, 3]\n")
        return bad("bad/json_array_root.gltf", "the JSON root is an array", any_of=["object", "json"])
    add(array_root)
    add(lambda: tri_bad("bad/asset_version_1.gltf", "asset.version 1.0",
                        setter(["asset", "version"], "1.0"), ["version"]))
    add(lambda: tri_bad("bad/no_asset.gltf", "no asset object",
                        lambda r: r.pop("asset"), ["version", "asset"]))
    add(lambda: tri_bad("bad/remote_buffer_uri.gltf", "buffer uri https://...",
                        setter(["buffers", 0, "uri"], "https://example.com/triangle.bin"), ["remote", "https"]))
    add(lambda: tri_bad("bad/data_uri_not_base64.gltf", "a data URI without ;base64",
                        setter(["buffers", 0, "uri"], "data:application/octet-stream,abcd"), ["base64", "data uri"]))

    def position_vec2(root):
        root["accessors"][0]["type"] = "VEC2"
        root["accessors"][0]["min"] = [-1.0, -1.0]
        root["accessors"][0]["max"] = [1.0, 1.0]
    add(lambda: tri_bad("bad/position_vec2.gltf", "POSITION declared as VEC2", position_vec2,
                        ["position", "vec3", "invalid"]))

    def position_quantized(root):
        root["accessors"][0]["componentType"] = 5122  # SHORT
        root["accessors"][0]["normalized"] = True
        root["accessors"][0]["count"] = 3
    add(lambda: tri_bad("bad/position_quantized.gltf", "POSITION as normalized SHORT without KHR_mesh_quantization declared",
                        position_quantized, ["position", "quantiz", "invalid"]))
    add(lambda: tri_bad("bad/settings_unknown_key.gltf", "extras.caustic with a misspelt key 'spps'",
                        setter(["scenes", 0, "extras"], {"caustic": {"spps": 4}}), ["spps", "settings"]))
    add(lambda: tri_bad("bad/settings_wrong_type.gltf", "extras.caustic spp is a string",
                        setter(["scenes", 0, "extras"], {"caustic": {"spp": "many"}}), ["spp", "settings"]))
    add(lambda: tri_bad("bad/area_light_unknown_shape.gltf", "CAUSTIC_lights_area shape 'triangle'",
                        with_ext("node", "CAUSTIC_lights_area", {"shape": "triangle", "size": [1, 1], "power": 10}),
                        ["shape", "triangle"]))
    # 1e39 is past f32: the loader reads it as infinite (JSON has no NaN or infinity).
    add(lambda: tri_bad("bad/area_light_infinite_power.gltf", "CAUSTIC_lights_area power 1e39 (infinite in f32)",
                        with_ext("node", "CAUSTIC_lights_area", {"shape": "square", "size": [1], "power": -1e39}),
                        ["power"]))

    def punctual_intensity(value, negative=False):
        def mutate(root):
            root["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"] = value
            if negative:
                root.setdefault("extensionsUsed", []).append("CAUSTIC_lights_punctual")
                root["nodes"][2].setdefault("extensions", {})["CAUSTIC_lights_punctual"] = {"negative": True}
        return mutate

    def negative_intensity():
        # KHR_lights_punctual's intensity is never negative (a negative light says so with
        # CAUSTIC_lights_punctual's `negative`): the error names the light.
        mutant("bad/punctual_negative_intensity.gltf", punctual_intensity(-3.0))
        return bad("bad/punctual_negative_intensity.gltf", "KHR_lights_punctual intensity -3 on the sun",
                   contains=["'sun'", "intensity", "negative"])
    add(negative_intensity)

    def infinite_negative_intensity():
        mutant("bad/punctual_infinite_negative.gltf", punctual_intensity(1e39, negative=True))
        return bad("bad/punctual_infinite_negative.gltf",
                   "intensity 1e39 (infinite in f32) on a sun with CAUSTIC_lights_punctual negative",
                   contains=["'sun'", "finite"])
    add(infinite_negative_intensity)
    add(lambda: tri_ok("negative_sun.gltf", "a sun with CAUSTIC_lights_punctual negative: it subtracts light",
                       [], punctual_intensity(3.0, negative=True)))
    add(lambda: tri_ok("negative_area_light.gltf", "CAUSTIC_lights_area power -10: it subtracts light", [],
                       with_ext("node", "CAUSTIC_lights_area", {"shape": "square", "size": [1], "power": -10})))
    add(lambda: tri_bad("bad/area_light_no_size.gltf", "CAUSTIC_lights_area with an empty size",
                        with_ext("node", "CAUSTIC_lights_area", {"shape": "square", "size": [], "power": 10}),
                        ["size"]))
    add(lambda: tri_bad("bad/world_missing_image.gltf", "CAUSTIC_world image 'no_such_sky.hdr'",
                        with_ext("scene", "CAUSTIC_world", {"image": "no_such_sky.hdr"}), ["no_such_sky.hdr"]))
    add(lambda: tri_bad("bad/world_negative_strength.gltf", "CAUSTIC_world strength -2",
                        with_ext("scene", "CAUSTIC_world", {"strength": -2.0}), ["world", "strength"]))
    add(lambda: tri_bad("bad/punctual_ext_negative_radius.gltf", "CAUSTIC_lights_punctual radius -1 on the sun",
                        lambda r: r["nodes"][2].setdefault("extensions", {}).update(
                            {"CAUSTIC_lights_punctual": {"radius": -1.0}}), ["radius", "lights_punctual"]))
    add(lambda: tri_bad("bad/volume_bad_attenuation.gltf", "KHR_materials_volume attenuationDistance 0",
                        with_ext("material", "KHR_materials_volume", {"thicknessFactor": 1, "attenuationDistance": 0}),
                        ["volume", "attenuation"]))
    add(lambda: tri_bad("bad/texture_index_out_of_range.gltf", "baseColorTexture index 5 (no textures)",
                        with_material({"pbrMetallicRoughness": {"baseColorTexture": {"index": 5}}}),
                        ["texture", "index", "range"]))

    def absurd_png(root):
        # A PNG whose IHDR declares 100000 x 100000 pixels.
        data = bytearray(checker_png())
        data[16:24] = struct.pack(">II", 100000, 100000)
        crc = zlib.crc32(bytes(data[12:29])) & 0xFFFFFFFF
        data[29:33] = struct.pack(">I", crc)
        root["images"] = [{"uri": "data:image/png;base64," + base64.b64encode(bytes(data)).decode()}]
        root["textures"] = [{"source": 0}]
        first_material(root)["pbrMetallicRoughness"] = {"baseColorTexture": {"index": 0}}
    add(lambda: tri_bad("bad/absurd_png_size.gltf", "a PNG header declaring 100000 x 100000 pixels",
                        absurd_png, ["size", "100000", "image"]))

    def unknown_image(root):
        root["images"] = [{"uri": "data:image/x-made-up;base64," + base64.b64encode(b"MADEUPIMG" * 10).decode()}]
        root["textures"] = [{"source": 0}]
        first_material(root)["pbrMetallicRoughness"] = {"baseColorTexture": {"index": 0}}
    add(lambda: tri_bad("bad/unknown_image_format.gltf", "an image of an unknown format (MIME image/x-made-up)",
                        unknown_image, ["format", "image", "texture"]))

    # Out-of-range factors: clamped with a warning naming the material, and rendered.
    add(lambda: tri_ok("bad/negative_roughness.gltf", "roughnessFactor -0.5: clamped with a warning", ["clamped"],
                       with_material({"pbrMetallicRoughness": {"roughnessFactor": -0.5, "metallicFactor": 0.0}})))
    add(lambda: tri_ok("bad/ior_zero.gltf", "KHR_materials_ior 0: rendered as Cycles renders its import (1e-5), named in a warning", ["ior"],
                       with_ext("material", "KHR_materials_ior", {"ior": 0.0})))
    add(lambda: tri_ok("bad/transmission_above_one.gltf", "transmissionFactor 3: clamped with a warning",
                       ["clamped"], with_ext("material", "KHR_materials_transmission", {"transmissionFactor": 3.0})))
    add(lambda: tri_ok("bad/spot_cone_too_wide.gltf", "a spot with outerConeAngle 3 rad: clamped with a warning",
                       ["clamped"], lambda r: r["extensions"]["KHR_lights_punctual"]["lights"].__setitem__(
                           0, {"type": "spot", "intensity": 100.0, "spot": {"innerConeAngle": 0.1, "outerConeAngle": 3.0}})))
    add(lambda: tri_ok("bad/area_light_zero_size.gltf", "a CAUSTIC_lights_area of size 0: skipped with a warning",
                       ["zero area"], with_ext("node", "CAUSTIC_lights_area", {"shape": "square", "size": [0.0], "power": 10})))

    def deep_chain(root):
        n0 = len(root["nodes"])
        for i in range(600):
            root["nodes"].append({"name": "link%d" % i, "children": [n0 + i + 1] if i < 599 else [0]})
        root["scenes"][0]["nodes"] = [n0] + root["scenes"][0]["nodes"][1:]
    add(lambda: tri_ok("bad/deep_hierarchy.gltf", "a chain of 600 nested nodes above the mesh (no recursion limit)",
                       [], deep_chain))

    # Found by the fuzzer (src/fuzz.rs, seeds 11-12): the glTF crate's readers reach
    # unreachable!() or unwrap None on these; the loader must refuse them by name first.
    add(lambda: tri_bad("bad/indices_float_accessor.gltf", "indices point at the float VEC3 POSITION accessor (fuzzer)",
                        setter(["meshes", 0, "primitives", 0, "indices"], 0), ["indices"]))
    add(lambda: tri_bad("bad/indices_signed_short.gltf", "an indices accessor of signed SHORTs (fuzzer)",
                        setter(["accessors", 2, "componentType"], 5122), ["indices"]))
    add(lambda: tri_bad("bad/texcoord_scalar.gltf", "TEXCOORD_0 is a SCALAR accessor",
                        setter(["meshes", 0, "primitives", 0, "attributes", "TEXCOORD_0"], 2), ["texcoord_0"]))

    def image_without_source(root):
        root["images"] = [{"name": "nothing"}]
        root["textures"] = [{"source": 0}]
        first_material(root)["pbrMetallicRoughness"] = {"baseColorTexture": {"index": 0}}
    add(lambda: tri_bad("bad/image_without_source.gltf", "an image with neither uri nor bufferView (fuzzer)",
                        image_without_source, ["uri", "bufferview"]))

    def image_view_without_mime(root):
        root["images"] = [{"bufferView": 2}]
        root["textures"] = [{"source": 0}]
        first_material(root)["pbrMetallicRoughness"] = {"baseColorTexture": {"index": 0}}
    add(lambda: tri_bad("bad/image_view_without_mime.gltf", "a bufferView image without mimeType",
                        image_view_without_mime, ["mimetype"]))

    def sparse_float_indices(root):
        root["accessors"][0]["sparse"] = {"count": 1, "indices": {"bufferView": 2, "componentType": 5126},
                                          "values": {"bufferView": 0}}
    add(lambda: tri_bad("bad/sparse_float_indices.gltf", "sparse indices of componentType FLOAT",
                        sparse_float_indices, ["sparse"]))

    def draco(data, view=None):
        """The triangle's primitive as KHR_draco_mesh_compression over `data` (a buffer of its
        own) or over bufferView `view`."""
        def mutate(root):
            root["buffers"].append({"byteLength": len(data), "uri": "data:application/octet-stream;base64,"
                                    + base64.b64encode(data).decode("ascii")})
            root["bufferViews"].append({"buffer": len(root["buffers"]) - 1, "byteLength": len(data)})
            name = "KHR_draco_mesh_compression"
            root.setdefault("extensionsUsed", []).append(name)
            root.setdefault("extensionsRequired", []).append(name)
            prim = root["meshes"][0]["primitives"][0]
            prim["extensions"] = {name: {"bufferView": len(root["bufferViews"]) - 1 if view is None else view,
                                         "attributes": {"POSITION": 0, "NORMAL": 1}}}
        return mutate
    # A Draco header (version 2.2, triangular mesh, edgebreaker) followed by noise.
    corrupt = b"DRACO" + bytes([2, 2, 1, 1, 0, 0]) + bytes((i * 97 + 13) % 256 for i in range(64))

    def draco_bad(rel_path, description, mutate, extension="KHR_draco_mesh_compression"):
        mutant(rel_path, mutate)
        return bad(rel_path, description, contains=["mesh 0", extension])
    add(lambda: draco_bad("bad/draco_corrupt.gltf", "KHR_draco_mesh_compression over a corrupt bitstream",
                          draco(corrupt)))
    add(lambda: draco_bad("bad/draco_view_out_of_range.gltf", "KHR_draco_mesh_compression naming bufferView 99",
                          draco(corrupt, view=99)))
    add(lambda: draco_bad("bad/draco_not_draco.gltf", "KHR_draco_mesh_compression over bytes without the DRACO magic",
                          draco(bytes(range(40)))))

    def meshopt_empty_fallback(root):
        # gltfpack's layout: the compressed bytes in buffer 0 (here the triangle's own
        # floats, not a meshopt stream), the views' fallback in a buffer without data.
        name = "EXT_meshopt_compression"
        root.setdefault("extensionsUsed", []).append(name)
        root["buffers"].append({"byteLength": 36, "extensions": {name: {"fallback": True}}})
        view = root["bufferViews"][root["accessors"][0]["bufferView"]]
        view["extensions"] = {name: {"buffer": 0, "byteOffset": 0, "byteLength": 16, "byteStride": 12,
                                     "mode": "ATTRIBUTES", "count": 3}}
        view["buffer"] = len(root["buffers"]) - 1
        view["byteOffset"] = 0
    add(lambda: draco_bad("bad/meshopt_corrupt.gltf", "EXT_meshopt_compression over bytes that are not meshopt data "
                          "(the fallback buffer holds none)", meshopt_empty_fallback, "EXT_meshopt_compression"))

    def billion_vertices(root):
        # A sparse accessor needs no base data: a few bytes declare 2e9 vertices (144 GB once
        # flattened), which the memory budget refuses before anything is read (exit 7).
        root["accessors"][0].update({"count": 2000000000, "sparse": {
            "count": 1, "indices": {"bufferView": 2, "componentType": 5123}, "values": {"bufferView": 0}}})
        root["accessors"][0].pop("bufferView")
    add(lambda: tri_bad("bad/sparse_billion_vertices.gltf", "a sparse POSITION accessor of 2e9 vertices: over the "
                        "memory budget", billion_vertices, ["memory limit"], exit_code=7))
    return makers


HOSTILE_MAKERS = hostile_makers()

MAKERS = [
    make_triangle_gltf_external, make_triangle_datauri, make_triangle_glb, make_no_indices,
    make_no_normals, make_strip_fan, make_points_lines, make_hierarchy_trs, make_negative_scale,
    make_instances, make_textured, make_textured_external_png, make_textured_bufferview_glb,
    make_uri_percent_encoded, make_pbr_textures, make_normal_map_no_tangents, make_vertex_colors,
    make_alpha_modes, make_lights_punctual, make_emissive_strength, make_camera_ortho,
    make_camera_no_aspect, make_two_cameras, make_no_camera, make_degenerate, make_unlit,
    make_required_ext_supported, make_optional_ext_unknown, make_multiple_scenes,
    make_no_default_scene, make_interleaved, make_index_types, make_sparse_accessor,
    cornell_box_entry,
    make_bad_invalid_json, make_bad_truncated_glb, make_bad_wrong_magic, make_bad_glb_version,
    make_bad_glb_chunk_length, make_bad_empty_file, make_bad_missing_buffer, make_bad_short_buffer,
    make_bad_view_past_buffer, make_bad_accessor_out_of_range, make_bad_index_out_of_range,
    make_bad_nan_position, make_bad_inf_position, make_bad_unsupported_required_ext,
    make_bad_unknown_required_ext, make_bad_missing_texture, make_bad_corrupt_png,
    make_bad_base64, make_bad_cyclic_nodes, make_bad_empty_scene, make_bad_dangling_accessor,
    make_bad_missing_position, make_bad_accessor_past_view, make_bad_percent_encoding,
    make_bad_not_gltf, make_bad_does_not_exist,
] + HOSTILE_MAKERS


# =============================================================================================
# An independent reading of the written files (a tiny reference loader) to check the manifest
# =============================================================================================
def load(path):
    data = open(path, "rb").read()
    bin_chunk = None
    if data[:4] == b"glTF":
        json_len = struct.unpack("<I", data[12:16])[0]
        root = json.loads(data[20:20 + json_len])
        rest = data[20 + json_len:]
        if rest:
            n = struct.unpack("<I", rest[:4])[0]
            bin_chunk = rest[8:8 + n]
    else:
        root = json.loads(data)
    buffers = []
    for buf in root.get("buffers", []):
        uri = buf.get("uri")
        if uri is None:
            buffers.append(bin_chunk)
        elif uri.startswith("data:"):
            buffers.append(base64.b64decode(uri.split(",", 1)[1]))
        else:
            rel = uri.replace("%20", " ")
            buffers.append(open(os.path.join(os.path.dirname(path), rel), "rb").read())
        assert len(buffers[-1]) >= buf["byteLength"], (path, len(buffers[-1]), buf["byteLength"])
    return root, buffers


def read_accessor(root, buffers, index):
    a = root["accessors"][index]
    fmt, size = COMPONENT[a["componentType"]]
    n = NCOMP[a["type"]]
    count = a["count"]

    def convert(x):
        if not a.get("normalized"):
            return x
        return {UNSIGNED_BYTE: x / 255.0, UNSIGNED_SHORT: x / 65535.0,
                BYTE: max(x / 127.0, -1.0), SHORT: max(x / 32767.0, -1.0)}[a["componentType"]]

    if "bufferView" in a:
        v = root["bufferViews"][a["bufferView"]]
        buf = buffers[v["buffer"]]
        stride = v.get("byteStride", n * size)
        start = v.get("byteOffset", 0) + a.get("byteOffset", 0)
        assert start + stride * (count - 1) + n * size <= v.get("byteOffset", 0) + v["byteLength"]
        out = [tuple(convert(x) for x in struct.unpack_from("<%d%s" % (n, fmt), buf, start + i * stride))
               for i in range(count)]
    else:
        out = [tuple([0] * n) for _ in range(count)]
    if "sparse" in a:
        sp = a["sparse"]
        iv = root["bufferViews"][sp["indices"]["bufferView"]]
        ifmt, isize = COMPONENT[sp["indices"]["componentType"]]
        ioff = iv.get("byteOffset", 0) + sp["indices"].get("byteOffset", 0)
        idx = struct.unpack_from("<%d%s" % (sp["count"], ifmt), buffers[iv["buffer"]], ioff)
        vv = root["bufferViews"][sp["values"]["bufferView"]]
        voff = vv.get("byteOffset", 0) + sp["values"].get("byteOffset", 0)
        for k, i in enumerate(idx):
            out[i] = tuple(convert(x) for x in struct.unpack_from(
                "<%d%s" % (n, fmt), buffers[vv["buffer"]], voff + k * n * size))
    return out


def mat_mul(a, b):
    return [[sum(a[r][k] * b[k][c] for k in range(4)) for c in range(4)] for r in range(4)]


def node_matrix(node):
    if "matrix" in node:
        m = node["matrix"]
        return [[m[c * 4 + r] for c in range(4)] for r in range(4)]
    t = node.get("translation", [0, 0, 0])
    x, y, z, w = node.get("rotation", [0, 0, 0, 1])
    s = node.get("scale", [1, 1, 1])
    r = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    return [[r[i][0] * s[0], r[i][1] * s[1], r[i][2] * s[2], t[i]] for i in range(3)] + [[0, 0, 0, 1]]


def apply(m, p, w=1.0):
    return tuple(m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3] * w for i in range(3))


def triangle_list(mode, idx):
    if mode == TRIANGLES:
        return [tuple(idx[i:i + 3]) for i in range(0, len(idx) - 2, 3)]
    if mode == TRIANGLE_STRIP:
        return [(idx[i], idx[i + 1 + i % 2], idx[i + 2 - i % 2]) for i in range(len(idx) - 2)]
    if mode == TRIANGLE_FAN:
        return [(idx[i + 1], idx[i + 2], idx[0]) for i in range(len(idx) - 2)]
    return []


def analyse(path):
    """Triangles (after instancing, strips/fans, dropping zero-area ones), emissive triangles,
    punctual light instances, camera nodes and world bounds of the triangles of the default
    scene. Checks on the way that triangles face their NORMAL (or +winding) consistently."""
    root, buffers = load(path)
    scene = root["scenes"][root.get("scene", 0)]
    res = {"triangles": 0, "punctual": 0, "emissive": 0, "cameras": 0, "lights": [],
           "lo": [math.inf] * 3, "hi": [-math.inf] * 3}
    identity = [[1 if r == c else 0 for c in range(4)] for r in range(4)]

    def visit(ni, parent, depth):
        assert depth < 900
        node = root["nodes"][ni]
        m = mat_mul(parent, node_matrix(node))
        if "camera" in node:
            res["cameras"] += 1
        if "KHR_lights_punctual" in node.get("extensions", {}):
            res["punctual"] += 1
            light = root["extensions"]["KHR_lights_punctual"]["lights"][
                node["extensions"]["KHR_lights_punctual"]["light"]]
            d = apply(m, (0.0, 0.0, -1.0), 0.0)
            dl = math.sqrt(sum(c * c for c in d))
            res["lights"].append({"type": light["type"], "position": apply(m, (0, 0, 0)),
                                  "direction": tuple(c / dl for c in d)})
        if "mesh" in node:
            for prim in root["meshes"][node["mesh"]]["primitives"]:
                mode = prim.get("mode", TRIANGLES)
                pos = read_accessor(root, buffers, prim["attributes"]["POSITION"])
                idx = ([i[0] for i in read_accessor(root, buffers, prim["indices"])]
                       if "indices" in prim else list(range(len(pos))))
                mat = root["materials"][prim["material"]] if "material" in prim else {}
                strength = mat.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get(
                    "emissiveStrength", 1.0)
                emissive = any(c * strength > 0 for c in mat.get("emissiveFactor", [0, 0, 0]))
                for tri in triangle_list(mode, idx):
                    p = [pos[i] for i in tri]
                    e1 = [p[1][k] - p[0][k] for k in range(3)]
                    e2 = [p[2][k] - p[0][k] for k in range(3)]
                    cr = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                          e1[0] * e2[1] - e1[1] * e2[0])
                    if max(abs(c) for c in cr) == 0.0:
                        continue
                    res["triangles"] += 1
                    res["emissive"] += emissive
                    for q in p:
                        wq = apply(m, q)
                        for k in range(3):
                            res["lo"][k] = min(res["lo"][k], wq[k])
                            res["hi"][k] = max(res["hi"][k], wq[k])
        for c in node.get("children", []):
            visit(c, m, depth + 1)

    for ni in scene["nodes"]:
        visit(ni, identity, 0)
    return res


def check_entry(entry):
    path = os.path.normpath(os.path.join(HERE, entry["file"]))
    r = analyse(path)
    got = (r["triangles"], r["punctual"], r["emissive"], r["cameras"])
    want = (entry["triangles"], entry["lights"]["punctual"], entry["lights"]["emissive_triangles"],
            entry["cameras"])
    assert got == want, "%s: analysed %r, manifest says %r" % (entry["file"], got, want)
    bounds = {"min": [round(x, 6) + 0.0 for x in r["lo"]], "max": [round(x, 6) + 0.0 for x in r["hi"]]}
    if "bounds" in entry:
        for k in ("min", "max"):
            for a, b in zip(entry["bounds"][k], bounds[k]):
                assert abs(a - b) < 1e-6, "%s: bounds %r vs analysed %r" % (entry["file"], entry["bounds"], bounds)
    entry["bounds"] = bounds
    for want_light in entry.get("details", {}).get("lights", []):
        match = [l for l in r["lights"] if l["type"] == want_light["type"]]
        assert len(match) == 1
        for key in ("position", "direction"):
            if key in want_light and not (want_light["type"] == "directional" and key == "position"):
                assert all(abs(a - b) < 1e-6 for a, b in zip(match[0][key], want_light[key])), \
                    (entry["file"], key, match[0][key], want_light[key])


ENTRY_ORDER = ["file", "expect", "description", "exit_code", "message_contains",
               "message_contains_any", "absent", "triangles", "lights", "cameras", "bounds",
               "warnings_contain", "features", "details", "render_checks"]


def main():
    entries = []
    for make in MAKERS:
        entry = make()
        if entry["expect"] == "ok":
            check_entry(entry)
        entries.append({k: entry[k] for k in ENTRY_ORDER if k in entry})
    files = [e["file"] for e in entries]
    assert len(files) == len(set(files))
    for e in entries:
        exists = os.path.exists(os.path.normpath(os.path.join(HERE, e["file"])))
        assert exists != bool(e.get("absent")), e["file"]
    write_text("manifest.json", to_json(entries) + "\n")
    print("wrote %d files (%d good, %d bad) and manifest.json" % (
        len(entries), sum(e["expect"] == "ok" for e in entries),
        sum(e["expect"] == "error" for e in entries)))


if __name__ == "__main__":
    main()
