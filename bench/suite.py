"""The benchmark's scene suite, built with bpy (nothing is loaded from disk).

Every builder takes an empty scene (`read_homefile(use_empty=True)`) and fills it with geometry,
materials, lights and a camera; render settings are set by run.py, the same for both renderers.
The small helpers (Lambertian and emissive Principled BSDFs, quads, cubes, camera, lights) are the
add-on test suite's own (tests/blender/scenes.py), so the benchmark and the agreement test build
materials the same way.

Scenes and what they stress:
* cornell       - diffuse walls and boxes, one square area light in the ceiling (the path tracer's
                  home ground; target: Caustic PT relMSE / Cycles <= 1).
* glass_caustic - a smooth glass sphere (Principled transmission 1, IOR 1.5) and a mirror on a
                  diffuse floor, lit by a small disk light: refractive and reflective caustics.
* subsurface    - a subdivided Suzanne with Principled subsurface weight 1, back-lit.
* many_lights   - 256 small emissive quads of 8 colours over a floor with boxes.
* hdri          - a glossy-diffuse object lit only by the world: an equirectangular sky image
                  computed here with numpy (sky gradient, horizon, ground, a sun disc).
"""

import math

import bpy
import numpy as np

import scenes  # tests/blender/scenes.py (run.py puts it on sys.path)


def _principled(name):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:  # Blender < 5.0
        mat.use_nodes = True
    return mat, mat.node_tree.nodes["Principled BSDF"]


def _coloured_diffuse(name, rgb):
    mat = scenes.diffuse_material(name, 1.0)
    mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (*rgb, 1.0)
    return mat


def _smooth(obj):
    for poly in obj.data.polygons:
        poly.use_smooth = True


def _uv_sphere(scene, name, radius, location, material, segments=48, rings=24):
    """A smooth UV sphere built from vertex lists (no operator, so no context is needed)."""
    verts = [(0.0, 0.0, radius)]
    for i in range(1, rings):
        theta = math.pi * i / rings
        for j in range(segments):
            phi = 2 * math.pi * j / segments
            verts.append((radius * math.sin(theta) * math.cos(phi),
                          radius * math.sin(theta) * math.sin(phi), radius * math.cos(theta)))
    verts.append((0.0, 0.0, -radius))
    faces = []
    for j in range(segments):  # top cap
        faces.append((0, 1 + j, 1 + (j + 1) % segments))
    for i in range(rings - 2):
        a, b = 1 + i * segments, 1 + (i + 1) * segments
        for j in range(segments):
            k = (j + 1) % segments
            faces.append((a + j, b + j, b + k, a + k))
    last = len(verts) - 1
    base = 1 + (rings - 2) * segments
    for j in range(segments):  # bottom cap
        faces.append((base + (j + 1) % segments, base + j, last))
    obj = scenes.mesh_object(scene, name, verts, faces, material)
    obj.location = location
    _smooth(obj)
    return obj


def _box(scene, name, size, location, rotation_z_deg, material):
    """A box of size (sx, sy, sz) standing on z = location.z, rotated about Z."""
    sx, sy, sz = size
    v = [(x * sx / 2, y * sy / 2, z * sz) for x in (-1, 1) for y in (-1, 1) for z in (0, 1)]
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    obj = scenes.mesh_object(scene, name, v, faces, material)
    obj.location = location
    obj.rotation_euler = (0.0, 0.0, math.radians(rotation_z_deg))
    return obj


def _suzanne(scene, name, levels, material, location=(0, 0, 0), scale=1.0):
    """Blender's monkey, subdivided `levels` times (Catmull-Clark, applied at render time)."""
    mesh = bpy.data.meshes.new(name)
    import bmesh

    bm = bmesh.new()
    bmesh.ops.create_monkey(bm)
    bm.to_mesh(mesh)
    bm.free()
    if material is not None:
        mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    obj.location = location
    obj.scale = (scale, scale, scale)
    _smooth(obj)
    if levels:
        mod = obj.modifiers.new("Subdivision", "SUBSURF")
        mod.levels = mod.render_levels = levels
    return obj


def cornell(scene):
    white = _coloured_diffuse("White", (0.73, 0.73, 0.73))
    red = _coloured_diffuse("Red", (0.63, 0.065, 0.05))
    green = _coloured_diffuse("Green", (0.14, 0.45, 0.09))
    m = scenes.mesh_object
    m(scene, "Floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [(0, 1, 2, 3)], white)
    m(scene, "Ceiling", [(-1, -1, 2), (-1, 1, 2), (1, 1, 2), (1, -1, 2)], [(0, 1, 2, 3)], white)
    m(scene, "Back", [(-1, 1, 0), (1, 1, 0), (1, 1, 2), (-1, 1, 2)], [(0, 1, 2, 3)], white)
    m(scene, "Left", [(-1, -1, 0), (-1, 1, 0), (-1, 1, 2), (-1, -1, 2)], [(0, 1, 2, 3)], red)
    m(scene, "Right", [(1, -1, 0), (1, -1, 2), (1, 1, 2), (1, 1, 0)], [(0, 1, 2, 3)], green)
    _box(scene, "Tall", (0.6, 0.6, 1.2), (-0.35, 0.35, 0.0), 17.0, white)
    _box(scene, "Short", (0.6, 0.6, 0.6), (0.35, -0.3, 0.0), -17.0, white)
    scenes.light(scene, "Ceiling Light", "AREA", location=(0.0, 0.0, 1.98), shape="SQUARE",
                 size=0.5, energy=40.0)
    scenes.camera(scene, (0.0, -3.9, 1.0), (90.0, 0.0, 0.0), lens=38.0)


def glass_caustic(scene):
    floor = _coloured_diffuse("Floor", (0.8, 0.8, 0.8))
    scenes.plane(scene, "Floor", 8.0, material=floor)
    glass, bsdf = _principled("Glass")
    bsdf.inputs["Base Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bsdf.inputs["Transmission Weight"].default_value = 1.0
    bsdf.inputs["IOR"].default_value = 1.5
    bsdf.inputs["Roughness"].default_value = 0.0
    bsdf.inputs["Metallic"].default_value = 0.0
    _uv_sphere(scene, "Glass Sphere", 0.5, (0.0, 0.0, 0.5), glass)
    mirror, bsdf = _principled("Mirror")
    bsdf.inputs["Base Color"].default_value = (0.95, 0.95, 0.95, 1.0)
    bsdf.inputs["Metallic"].default_value = 1.0
    bsdf.inputs["Roughness"].default_value = 0.0
    # A vertical mirror behind the sphere, turned 30 degrees towards the camera side.
    obj = scenes.mesh_object(scene, "Mirror", [(-0.9, 0, 0), (0.9, 0, 0), (0.9, 0, 1.4), (-0.9, 0, 1.4)],
                             [(0, 1, 2, 3)], mirror)
    obj.location = (1.0, 1.3, 0.0)
    obj.rotation_euler = (0.0, 0.0, math.radians(-30.0))
    scenes.light(scene, "Small Light", "AREA", location=(-0.8, -0.4, 3.0), rotation_deg=(-8, -14, 0),
                 shape="DISK", size=0.15, energy=150.0)
    scenes.camera(scene, (0.0, -3.6, 2.6), (55.0, 0.0, 0.0), lens=35.0)


def subsurface(scene):
    floor = _coloured_diffuse("Floor", (0.5, 0.5, 0.5))
    scenes.plane(scene, "Floor", 8.0, material=floor)
    skin, bsdf = _principled("Skin")
    bsdf.inputs["Base Color"].default_value = (0.8, 0.55, 0.45, 1.0)
    bsdf.inputs["Subsurface Weight"].default_value = 1.0
    bsdf.inputs["Subsurface Radius"].default_value = (1.0, 0.35, 0.2)
    bsdf.inputs["Subsurface Scale"].default_value = 0.15
    bsdf.inputs["Roughness"].default_value = 0.5
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    _suzanne(scene, "Suzanne", 2, skin, location=(0.0, 0.0, 0.75), scale=0.8)
    # Back light (behind and above) and a weak fill from the camera side.
    scenes.light(scene, "Back", "AREA", location=(0.0, 1.6, 3.0), rotation_deg=(-35, 0, 0),
                 shape="SQUARE", size=1.0, energy=250.0)
    scenes.light(scene, "Fill", "AREA", location=(-1.5, -2.0, 1.5), rotation_deg=(60, 0, -35),
                 shape="SQUARE", size=1.0, energy=40.0)
    scenes.camera(scene, (0.0, -3.2, 1.3), (82.0, 0.0, 0.0), lens=45.0)


def many_lights(scene, count=256, colours=8):
    floor = _coloured_diffuse("Floor", (0.6, 0.6, 0.6))
    scenes.plane(scene, "Floor", 8.0, material=floor)
    for i, (x, y) in enumerate([(-1.0, 0.4), (0.8, 0.9), (0.2, -0.6)]):
        _box(scene, f"Box{i}", (0.5, 0.5, 0.4 + 0.3 * i), (x, y, 0.0), 20.0 * i, floor)
    rng = np.random.default_rng(7)
    h = 0.04
    for c in range(colours):
        hue = c / colours
        rgb = [0.5 + 0.5 * math.cos(2 * math.pi * (hue + k / 3)) for k in range(3)]
        mat = scenes.emission_material(f"Lamp{c}", rgb, 60.0)
        verts, faces = [], []
        for _ in range(count // colours):
            x, y = rng.uniform(-2.2, 2.2, 2)
            z = rng.uniform(0.8, 2.0)
            n = len(verts)
            # Faces down (-Z): clockwise seen from above.
            verts += [(x - h, y - h, z), (x - h, y + h, z), (x + h, y + h, z), (x + h, y - h, z)]
            faces.append((n, n + 1, n + 2, n + 3))
        scenes.mesh_object(scene, f"Lamps{c}", verts, faces, mat)
    scenes.camera(scene, (0.0, -4.2, 3.2), (50.0, 0.0, 0.0), lens=30.0)


def sky_pixels(width=256, height=128):
    """An equirectangular sky (RGBA float, rows bottom to top as Blender stores them)."""
    v = (np.arange(height) + 0.5) / height  # 0 = bottom (nadir), 1 = top (zenith)
    u = (np.arange(width) + 0.5) / width
    elevation = (v - 0.5) * math.pi  # -pi/2 .. pi/2
    azimuth = (u - 0.5) * 2 * math.pi
    el, az = np.meshgrid(elevation, azimuth, indexing="ij")
    up = np.clip(np.sin(el), 0.0, 1.0)[..., None]
    zenith = np.array([0.15, 0.3, 0.8])
    horizon = np.array([0.7, 0.8, 1.0])
    ground = np.array([0.25, 0.2, 0.15])
    sky = horizon + (zenith - horizon) * up ** 0.5
    rgb = np.where((el > 0)[..., None], sky, ground * (0.6 + 0.4 * np.cos(el))[..., None])
    # A sun disc of ~4 degrees at elevation 35, azimuth 40 degrees.
    sun_el, sun_az = math.radians(35.0), math.radians(40.0)
    cos_angle = (np.sin(el) * math.sin(sun_el) + np.cos(el) * math.cos(sun_el) * np.cos(az - sun_az))
    rgb = rgb + np.where(cos_angle > math.cos(math.radians(2.0)), 400.0, 0.0)[..., None]
    rgba = np.concatenate([rgb, np.ones((height, width, 1))], axis=2).astype(np.float32)
    return rgba


def hdri(scene):
    floor = _coloured_diffuse("Floor", (0.5, 0.5, 0.5))
    scenes.plane(scene, "Floor", 6.0, material=floor)
    mat, bsdf = _principled("Glossy Blue")
    bsdf.inputs["Base Color"].default_value = (0.2, 0.35, 0.8, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.3
    _suzanne(scene, "Suzanne", 1, mat, location=(0.0, 0.0, 0.7), scale=0.7)
    rgba = sky_pixels()
    image = bpy.data.images.new("Procedural Sky", rgba.shape[1], rgba.shape[0], alpha=True,
                                float_buffer=True)
    image.pixels.foreach_set(rgba.ravel())
    image.pack()
    world = bpy.data.worlds.new("Sky")
    if world.node_tree is None:
        world.use_nodes = True
    nodes = world.node_tree.nodes
    env = nodes.new("ShaderNodeTexEnvironment")
    env.image = image
    background = nodes["Background"]
    world.node_tree.links.new(env.outputs["Color"], background.inputs["Color"])
    scene.world = world
    scenes.camera(scene, (0.0, -3.0, 1.6), (72.0, 0.0, 0.0), lens=40.0)


def subdivided(scene, levels):
    """Triangle-count scaling: Suzanne subdivided `levels` times under one area light."""
    floor = _coloured_diffuse("Floor", (0.5, 0.5, 0.5))
    scenes.plane(scene, "Floor", 6.0, material=floor)
    _suzanne(scene, "Suzanne", levels, _coloured_diffuse("Grey", (0.7, 0.7, 0.7)),
             location=(0.0, 0.0, 0.7), scale=0.7)
    scenes.light(scene, "Key", "AREA", location=(1.0, -1.0, 3.0), rotation_deg=(20, 20, 0),
                 shape="SQUARE", size=1.0, energy=300.0)
    scenes.camera(scene, (0.0, -3.0, 1.6), (72.0, 0.0, 0.0), lens=40.0)


# name -> (builder, note shown in the table when Caustic is known not to render a feature)
SUITE = {
    "cornell": (cornell, ""),
    "glass_caustic": (glass_caustic, ""),
    "subsurface": (subsurface, "Blender's glTF exporter writes no subsurface, so Caustic renders "
                   "this material without it (and without a warning)"),
    "many_lights": (many_lights, ""),
    "hdri": (hdri, ""),
}
