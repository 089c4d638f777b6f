"""Hair particle systems and Curves objects: `CAUSTIC_curves` (docs/contract.md).

The glTF exporter writes neither, so after it has run, `add_curves` reads them from the render
depsgraph the way Cycles does (intern/cycles/blender/curves.cpp) and appends them to the file:
strands of world-space control points with a radius each, one count per strand and one root UV
per strand, in a second binary buffer (`scene_curves.bin`) behind accessors, so that a million
strands load without a JSON array.

* Hair particle systems (render type Path, render-enabled modifier): the render-evaluated
  strands from `ParticleSystem.co_hair`, children included (with children, only the children,
  as Cycles), at 2^render_step + 1 points; Cycles' radius: radius scale / 2 times the root and
  tip diameters, shaped by Shape along the strand's length, 0 at a closed tip.
* Curves objects: their evaluated points and `radius` attribute (0.005 without one, as Cycles),
  the first 2D curve attribute as the root UV (as Cycles' "weak" rule), transformed by the
  object's matrix (radius scaled by its mean scale).

Cycles intersects non-Poly strands as Catmull-Rom curves through these points, drawn as the
scene's Curves Shape (`scene.cycles_curves.shape`): Ribbons (Blender 5.0's default) or Thick;
Poly curves always as Thick Linear. Strands Cycles draws as ribbons are written with `"shape":
"ribbon"` (the renderer's ray-facing strips with Cycles' self-intersection guard, which is what
makes dense ribbon fur brighter than round fur); the rest are round. Caustic's segments are
straight. A Curves object's segments (a few control points per strand,
as sculpted) are subdivided here into `SUBDIVISIONS` pieces on the Catmull-Rom curve (radius
interpolated the same way), which brings the straight chain within (segment length)² ×
curvature / 8 / SUBDIVISIONS² of the curve. Particle hair is not: its points are already
Blender's path sampled at the render steps (8 segments per strand by default), so the chain is
within L² κ / 8 of Cycles' curve, and subdividing would multiply the memory of a million strands.
"""

import json
import math
import os

import numpy as np

CURVES_EXTENSION = "CAUSTIC_curves"
HAIR_EXTENSION = "CAUSTIC_materials_hair"
BUFFER_NAME = "scene_curves.bin"
# Straight pieces per Catmull-Rom segment (see the module's comment).
SUBDIVISIONS = 4
# Cycles' radius of a Curves point without a `radius` attribute.
DEFAULT_CURVES_RADIUS = 0.005


class Strands:
    """One object's strands: points (N, 3) glTF axes, radii (N,), counts (M,), root UVs (M, 2) or None."""

    def __init__(self, name, material, points, radii, counts, uvs, object_name=None):
        self.name = name
        # The Blender object the strands belong to (light linking names it).
        self.object_name = object_name or name
        self.material = material
        self.points = np.asarray(points, dtype=np.float32).reshape(-1, 3)
        self.radii = np.asarray(radii, dtype=np.float32)
        self.counts = np.asarray(counts, dtype=np.uint32)
        self.uvs = None if uvs is None else np.asarray(uvs, dtype=np.float32).reshape(-1, 2)
        # Poly curves: Cycles draws them as straight round segments whatever the Curves Shape.
        self.poly = False
        # Drawn as ray-facing ribbons (set by `scene_strands` from the scene's Curves Shape).
        self.ribbon = False
        # Curves Info: Cycles' index of the first strand in its hair geometry (Random hashes
        # it), object-space length per world length (Length), points per key interval
        # (Intercept and Length run along Cycles' keys, not the subdivided points).
        self.random_base = 0
        self.length_scale = 1.0
        self.key_step = 1


def _length_scale(matrix):
    """Object-space length per world length of a (uniformly scaled) object matrix."""
    m = np.array(matrix, dtype=np.float64)
    scale = abs(np.linalg.det(m[:3, :3])) ** (1.0 / 3.0)
    return 1.0 / scale if scale > 0 else 1.0


def _to_gltf_axes(p):
    """Blender's Z-up (x, y, z) to glTF's Y-up (x, z, -y), for an (N, 3) array."""
    return np.stack([p[:, 0], p[:, 2], -p[:, 1]], axis=1)


def catmull_rom(points, radii, counts, pieces):
    """Each strand's segments cut into `pieces` straight pieces on the uniform Catmull-Rom curve
    through its points (end points repeated, as Cycles' curve keys); radii alike."""
    if pieces <= 1 or len(counts) == 0:
        return points, radii, counts
    out_p, out_r, out_c = [], [], []
    s = np.arange(pieces, dtype=np.float64) / pieces
    # Catmull-Rom basis at each s, for the four keys around a segment.
    basis = np.stack([(-s ** 3 + 2 * s ** 2 - s) / 2, (3 * s ** 3 - 5 * s ** 2 + 2) / 2,
                      (-3 * s ** 3 + 4 * s ** 2 + s) / 2, (s ** 3 - s ** 2) / 2], axis=1)
    first = 0
    for n in counts:
        n = int(n)
        keys = np.concatenate([points[first:first + n], radii[first:first + n, None]], axis=1).astype(np.float64)
        padded = np.concatenate([keys[:1], keys, keys[-1:]])
        # Segment k uses padded[k .. k+3]; every segment's pieces, then the last point.
        windows = np.stack([padded[k:k + n - 1] for k in range(4)], axis=1)  # (n-1, 4, 4)
        curve = np.einsum("sk,nkd->nsd", basis, windows).reshape(-1, 4)
        curve = np.concatenate([curve, keys[-1:]])
        out_p.append(curve[:, :3])
        out_r.append(np.maximum(curve[:, 3], 0.0))
        out_c.append(len(curve))
        first += n
    return np.concatenate(out_p), np.concatenate(out_r), np.array(out_c, dtype=np.uint32)


def _shape_radius(shape, root, tip, time):
    """Cycles' `shaperadius`: the radius at fraction `time` of the strand's length."""
    r = 1.0 - time
    if shape < 0.0:
        r = np.power(r, 1.0 + shape)
    elif shape > 0.0:
        r = np.power(r, 1.0 / (1.0 - shape))
    return r * (root - tip) + tip


def particle_strands(obj, modifier, warnings):
    """A hair particle system's render strands (Cycles' ObtainCacheParticleData), or None."""
    psys = obj.particle_systems.get(modifier.particle_system.name)
    if psys is None:
        return None
    part = psys.settings
    totpart, totchild = len(psys.particles), len(psys.child_particles)
    start = totpart if (part.child_type != "NONE" and totchild) else 0
    steps = (1 << part.render_step) + 1
    if part.kink == "SPIRAL":
        steps += part.kink_extra_steps
    total = totpart + totchild - start
    if total <= 0:
        return None
    pts = np.empty((total, steps, 3), dtype=np.float64)
    for i, p in enumerate(range(start, totpart + totchild)):
        for k in range(steps):
            pts[i, k] = psys.co_hair(object=obj, particle_no=p, step=k)
    # Radius along the length (Cycles measures it in object space; the same for a rigid
    # transform, and the fraction of the length is what matters).
    seg = np.linalg.norm(np.diff(pts, axis=1), axis=2)
    length = np.concatenate([np.zeros((total, 1)), np.cumsum(seg, axis=1)], axis=1)
    full = length[:, -1:]
    time = np.divide(length, full, out=np.zeros_like(length), where=full > 0)
    half = part.radius_scale * 0.5
    radii = _shape_radius(part.shape, half * part.root_radius, half * part.tip_radius, time)
    if part.use_close_tip:
        radii[:, -1] = 0.0
    uvs = None
    mesh = obj.data
    if getattr(mesh, "uv_layers", None) and len(mesh.uv_layers):
        uv_no = next((i for i, layer in enumerate(mesh.uv_layers) if layer.active_render), 0)
        uvs = np.empty((total, 2))
        for i, p in enumerate(range(start, totpart + totchild)):
            # Cycles hands the parent for parents and the first particle for children.
            particle = psys.particles[p if p < totpart else 0]
            uvs[i] = psys.uv_on_emitter(modifier=modifier, particle=particle, particle_no=p, uv_no=uv_no)
        uvs[:, 1] = 1.0 - uvs[:, 1]  # glTF's v runs down
    slots = obj.material_slots
    material = slots[min(max(part.material - 1, 0), len(slots) - 1)].material if len(slots) else None
    points = _to_gltf_axes(pts.reshape(-1, 3))
    counts = np.full(total, steps, dtype=np.uint32)
    strands = Strands(f"{obj.name}/{psys.name}", material, points, radii.reshape(-1), counts, uvs, obj.name)
    # Cycles measures Length in the emitter's object space.
    strands.length_scale = _length_scale(obj.matrix_world)
    return strands


def curves_object_strands(obj, warnings):
    """A Curves object's evaluated strands (Cycles' export_hair_curves), or None."""
    data = obj.data
    n_points, n_curves = len(data.points), len(data.curves)
    if n_points == 0 or n_curves == 0:
        return None
    pos = np.empty(n_points * 3, dtype=np.float32)
    data.attributes["position"].data.foreach_get("vector", pos)
    pos = pos.reshape(-1, 3).astype(np.float64)
    radius = data.attributes.get("radius")
    if radius is not None and radius.domain == "POINT" and radius.data_type == "FLOAT":
        radii = np.empty(n_points, dtype=np.float32)
        radius.data.foreach_get("value", radii)
        radii = radii.astype(np.float64)
    else:
        radii = np.full(n_points, DEFAULT_CURVES_RADIUS)
    offsets = np.empty(n_curves + 1, dtype=np.int32)
    data.curve_offset_data.foreach_get("value", offsets)
    counts = np.diff(offsets)
    if np.any(counts < 2):
        warnings.append(f"object '{obj.name}': {int(np.sum(counts < 2))} curve(s) with fewer than 2 points "
                        "are not rendered")
        keep = np.repeat(counts >= 2, counts)
        pos, radii, counts = pos[keep], radii[keep], counts[counts >= 2]
        if len(counts) == 0:
            return None
    m = np.array(obj.matrix_world, dtype=np.float64)
    pos = pos @ m[:3, :3].T + m[:3, 3]
    scale = abs(np.linalg.det(m[:3, :3])) ** (1.0 / 3.0)
    radii = radii * scale
    uvs = None
    for attr in data.attributes:
        if attr.domain == "CURVE" and attr.data_type == "FLOAT2":
            uvs = np.empty(n_curves * 2, dtype=np.float32)
            attr.data.foreach_get("vector", uvs)
            uvs = uvs.reshape(-1, 2)[np.diff(offsets) >= 2].astype(np.float64)
            uvs[:, 1] = 1.0 - uvs[:, 1]
            break
    types = data.attributes.get("curve_type")
    poly = False
    if types is not None:
        first = np.empty(n_curves, dtype=np.int8)
        types.data.foreach_get("value", first)
        poly = int(first[0]) == 1  # CURVE_TYPE_POLY: Cycles then uses straight segments
    points = _to_gltf_axes(pos)
    if not poly:
        points, radii, counts = catmull_rom(points, radii, counts, SUBDIVISIONS)
    material = obj.material_slots[0].material if len(obj.material_slots) else None
    strands = Strands(obj.name, material, points, radii, counts, uvs)
    strands.poly = poly
    strands.length_scale = 1.0 / scale if scale > 0 else 1.0
    strands.key_step = 1 if poly else SUBDIVISIONS
    return strands


def ribbons_in(scene):
    """True when Cycles draws this scene's (non-Poly) curves as ribbons: the Curves Shape of the
    Render properties (`cycles_curves.shape`, 'RIBBONS' by default in Blender 5.0)."""
    settings = getattr(scene, "cycles_curves", None)
    return settings is not None and settings.shape == "RIBBONS"


def scene_strands(depsgraph, warnings):
    """Every hair particle system and Curves object the render depsgraph renders, each marked
    ribbon or round as Cycles draws it."""
    ribbons = ribbons_in(depsgraph.scene)
    out = []
    for obj in depsgraph.objects:
        if obj.type == "CURVES":
            s = curves_object_strands(obj, warnings)
            if s is not None:
                out.append(s)
            continue
        # Cycles puts an emitter's hair systems in one geometry, numbering their strands on.
        first = 0
        for modifier in getattr(obj, "modifiers", ()):
            if modifier.type != "PARTICLE_SYSTEM" or not modifier.show_render:
                continue
            settings = modifier.particle_system.settings
            if settings.type == "HAIR" and settings.render_type == "PATH":
                s = particle_strands(obj, modifier, warnings)
                if s is not None:
                    s.random_base = first
                    first += len(s.counts)
                    out.append(s)
    for s in out:
        s.ribbon = ribbons and not s.poly
    return out


def _gltf_material(doc, material, warnings, what):
    """The glTF index of `material`: the exporter's (same name), else a material appended from
    its Principled BSDF's or Diffuse BSDF's constant inputs; None for Blender's default surface."""
    from .nodes import socket, surface_node
    if material is None:
        return None
    materials = doc.setdefault("materials", [])
    for i, m in enumerate(materials):
        if m.get("name") == material.name:
            return i
    node = surface_node(material)
    entry = {"name": material.name}
    if node is not None and node.type in ("BSDF_PRINCIPLED", "BSDF_DIFFUSE"):
        colour = socket(node, "Base Color") or socket(node, "Color")
        rgb = [float(c) for c in colour.default_value[:3]]
        pbr = {"baseColorFactor": rgb + [1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}
        if node.type == "BSDF_PRINCIPLED":
            pbr["metallicFactor"] = float(socket(node, "Metallic").default_value)
            pbr["roughnessFactor"] = float(socket(node, "Roughness").default_value)
        else:
            # Diffuse BSDF: no specular layer.
            entry["extensions"] = {"KHR_materials_specular": {"specularFactor": 0.0}}
            used = doc.setdefault("extensionsUsed", [])
            if "KHR_materials_specular" not in used:
                used.append("KHR_materials_specular")
        linked = [s.name for s in node.inputs if s.is_linked]
        if linked:
            warnings.append(f"{what}: material '{material.name}': linked inputs ({', '.join(linked)}) are not "
                            "exported for strands; their values are used")
        entry["pbrMetallicRoughness"] = pbr
    elif node is not None and node.type == "BSDF_HAIR_PRINCIPLED":
        # Shaded by CAUSTIC_materials_hair on strands; the glTF values serve a mesh using it.
        entry["pbrMetallicRoughness"] = {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0}
    else:
        kind = node.bl_label if node is not None else "no surface"
        warnings.append(f"{what}: material '{material.name}' ({kind}) is not rendered on strands; they are "
                        "shaded grey diffuse")
        entry["pbrMetallicRoughness"] = {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0}
    materials.append(entry)
    return len(materials) - 1


def needs_graph(material):
    """True when strands must render `material` as its node graph: a surface other than a
    Principled, Diffuse or Principled Hair BSDF with constant inputs (Curves Info, a texture, a
    mixture), or a Principled Hair BSDF with Random Color or Random Roughness."""
    from .nodes import socket, surface_node
    node = surface_node(material)
    if node is None:
        return False
    if any(s.is_linked for s in node.inputs if s.enabled):
        return True
    if node.type == "BSDF_HAIR_PRINCIPLED":
        randomised = any(socket(node, name).enabled and socket(node, name).default_value > 0.0
                         for name in ("Random Color", "Random Roughness"))
        return randomised
    return node.type not in ("BSDF_PRINCIPLED", "BSDF_DIFFUSE")


def strand_material(doc, material, state, folder, what):
    """The glTF index of the strands' `material` (Blender's default surface for None): the
    exporter's material of that name, else its node graph where `needs_graph`, else one
    appended from its BSDF's constant inputs (with `CAUSTIC_materials_hair` for a Principled
    Hair BSDF: the compact form, no graph evaluated per hit)."""
    from .meshes import default_surface_index
    from .nodes import surface_node
    from .points import _gltf_material as graph_material
    if material is None:
        return default_surface_index(doc)
    graph = needs_graph(material)
    index = graph_material(doc, material, state, folder, state.warnings, what, strands=True) if graph else \
        _gltf_material(doc, material, state.warnings, what)
    node = surface_node(material)
    if not graph and node is not None and node.type == "BSDF_HAIR_PRINCIPLED":
        gltf_material = doc["materials"][index]
        gltf_material.setdefault("extensions", {})[HAIR_EXTENSION] = hair_parameters(
            node, f"{what}: material '{material.name}'", state.warnings)
        if HAIR_EXTENSION not in used_extensions(doc):
            used_extensions(doc).append(HAIR_EXTENSION)
    return index


def _sigma_from_reflectance(color, radial):
    """Cycles' `sigma_from_reflectance`: the absorption giving the fibre colour `color`."""
    x = radial
    fac = (((((0.245 * x) + 5.574) * x - 10.73) * x + 2.532) * x - 0.215) * x + 5.969
    return [(math.log(max(c, 1e-6)) / fac) ** 2 for c in color[:3]]


def hair_parameters(node, what, warnings):
    """`CAUSTIC_materials_hair` of a Principled Hair BSDF node: the absorption from its
    parametrisation (Cycles' formulas, node_principled_hair_bsdf.osl), roughnesses, coat, offset, IOR."""
    from .nodes import socket
    linked = [s.name for s in node.inputs if s.is_linked]
    if linked:
        warnings.append(f"{what}: the Principled Hair BSDF's linked inputs ({', '.join(linked)}) are not "
                        "exported; their values are used")
    if node.model == "HUANG":
        warnings.append(f"{what}: the Principled Hair BSDF's Huang model is rendered as the Chiang model "
                        "(the same colour, roughness, IOR and offset; no aspect ratio or lobe weights)")
    if socket(node, "Random Color").default_value or socket(node, "Random Roughness").default_value:
        warnings.append(f"{what}: the Principled Hair BSDF's Random Color and Random Roughness are ignored "
                        "(every strand takes the node's values)")
    value = lambda name: socket(node, name).default_value  # noqa: E731
    radial = float(value("Radial Roughness"))
    if node.parametrization == "ABSORPTION":
        sigma = [float(c) for c in value("Absorption Coefficient")[:3]]
    elif node.parametrization == "MELANIN":
        melanin = -math.log(max(1.0 - float(value("Melanin")), 1e-4))
        redness = float(value("Melanin Redness"))
        eu, pheo = melanin * (1.0 - redness), melanin * redness
        tint = _sigma_from_reflectance(value("Tint"), radial)
        sigma = [eu * a + pheo * b + t for a, b, t in zip((0.506, 0.841, 1.653), (0.343, 0.733, 1.924), tint)]
    else:
        sigma = _sigma_from_reflectance(value("Color"), radial)
    return {"sigma": sigma, "roughness": min(max(float(value("Roughness")), 0.0), 1.0),
            "radialRoughness": min(max(radial, 0.0), 1.0), "coat": min(max(float(value("Coat")), 0.0), 1.0),
            "offset": float(value("Offset")), "ior": max(float(value("IOR")), 1.0001)}


def used_extensions(doc):
    """The document's extensionsUsed list (made when missing)."""
    return doc.setdefault("extensionsUsed", [])


def add_curves(gltf_path, depsgraph, state):
    """Append the scene's strands to the written glTF file; returns the number of strands."""
    warnings = state.warnings
    strands = scene_strands(depsgraph, warnings)
    if not strands:
        return 0
    with open(gltf_path, encoding="utf-8") as f:
        doc = json.load(f)
    blob = bytearray()
    buffer_index = len(doc.setdefault("buffers", []))
    views = doc.setdefault("bufferViews", [])
    accessors = doc.setdefault("accessors", [])

    def accessor(array, component, kind):
        while len(blob) % 4:
            blob.append(0)
        data = np.ascontiguousarray(array).tobytes()
        views.append({"buffer": buffer_index, "byteOffset": len(blob), "byteLength": len(data)})
        blob.extend(data)
        count = len(array)
        accessors.append({"bufferView": len(views) - 1, "componentType": component, "count": count, "type": kind})
        return len(accessors) - 1

    objects = []
    total = 0
    folder = os.path.dirname(gltf_path)
    for s in strands:
        what = f"hair '{s.name}'"
        entry = {
            "name": s.name,
            "object": s.object_name,
            "points": accessor(s.points.astype(np.float32), 5126, "VEC3"),
            "radii": accessor(s.radii.astype(np.float32), 5126, "SCALAR"),
            "counts": accessor(s.counts.astype(np.uint32), 5125, "SCALAR"),
        }
        if s.uvs is not None:
            entry["rootUvs"] = accessor(s.uvs.astype(np.float32), 5126, "VEC2")
        if s.ribbon:
            entry["shape"] = "ribbon"
        if s.random_base:
            entry["randomBase"] = int(s.random_base)
        if s.length_scale != 1.0:
            entry["lengthScale"] = float(s.length_scale)
        if s.key_step != 1:
            entry["keyStep"] = int(s.key_step)
        material = strand_material(doc, s.material, state, folder, what)
        if material is not None:
            entry["material"] = material
        objects.append(entry)
        total += len(s.counts)
    with open(os.path.join(folder, BUFFER_NAME), "wb") as f:
        f.write(blob)
    doc["buffers"].append({"uri": BUFFER_NAME, "byteLength": len(blob)})
    doc.setdefault("extensions", {})[CURVES_EXTENSION] = {"objects": objects}
    used = doc.setdefault("extensionsUsed", [])
    if CURVES_EXTENSION not in used:
        used.append(CURVES_EXTENSION)
    with open(gltf_path, "w", encoding="utf-8") as f:
        json.dump(doc, f)
    return total

