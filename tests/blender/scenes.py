"""Scene builders shared by the add-on tests (everything made with bpy, nothing loaded)."""

import math

import bpy
import numpy as np


def diffuse_material(name, grey):
    """A Principled BSDF that is a pure Lambertian reflector of albedo `grey` in both renderers.

    Roughness 1, metallic 0 and specular IOR level 0 remove the dielectric layer (the exporter
    writes KHR_materials_specular with specularFactor 0), so Cycles and the glTF model agree.
    """
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:  # Blender < 5.0 creates materials without nodes
        mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (grey, grey, grey, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Metallic"].default_value = 0.0
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    return mat


def emission_material(name, color, strength):
    """A material that only emits (Principled BSDF with black base and emission)."""
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:  # Blender < 5.0 creates materials without nodes
        mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Emission Color"].default_value = (*color, 1.0)
    bsdf.inputs["Emission Strength"].default_value = strength
    return mat


def mesh_object(scene, name, verts, faces, material=None):
    """Link a new mesh object built from vertex and face lists."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    mesh.update()
    if material is not None:
        mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    return obj


def plane(scene, name, size, z=0.0, material=None):
    """A square in the XY plane facing +Z."""
    h = size / 2
    return mesh_object(scene, name, [(-h, -h, z), (h, -h, z), (h, h, z), (-h, h, z)],
                       [(0, 1, 2, 3)], material)


def cube(scene, name, size, center, material=None):
    """An axis-aligned cube with outward faces."""
    h = size / 2
    cx, cy, cz = center
    v = [(cx + x * h, cy + y * h, cz + z * h) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return mesh_object(scene, name, v, faces, material)


def camera(scene, location, rotation_deg, lens=35.0, name="Camera"):
    """Add a perspective camera and make it the scene camera."""
    data = bpy.data.cameras.new(name)
    data.lens = lens
    obj = bpy.data.objects.new(name, data)
    obj.location = location
    obj.rotation_euler = [math.radians(a) for a in rotation_deg]
    scene.collection.objects.link(obj)
    scene.camera = obj
    return obj


def light(scene, name, kind, location=(0, 0, 3), rotation_deg=(0, 0, 0), **props):
    """Add a light object; `props` are set on the light data (energy, color, shape, ...)."""
    data = bpy.data.lights.new(name, kind)
    for key, value in props.items():
        setattr(data, key, value)
    obj = bpy.data.objects.new(name, data)
    obj.location = location
    obj.rotation_euler = [math.radians(a) for a in rotation_deg]
    scene.collection.objects.link(obj)
    return obj


def small_render_settings(scene, width=32, height=24, samples=4):
    """Tiny image, few samples, float EXR output (linear, no view transform)."""
    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = width, height, 100
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "32"
    r.image_settings.color_mode = "RGBA"
    scene.caustic.samples = samples
    # Cycles' Max Bounces, which Caustic renders too (its other Light Paths settings keep
    # Cycles' defaults in both renderers).
    scene.cycles.max_bounces = 4
    scene.caustic.threads = 2


def plane_and_cube_scene(scene):
    """The agreement scene: a grey plane, a lighter cube on it, the camera above looking down."""
    plane(scene, "Floor", 8.0, material=diffuse_material("Grey", 0.5))
    cube(scene, "Box", 1.0, (0.3, -0.2, 0.5), material=diffuse_material("Light", 0.8))
    camera(scene, (0.0, -3.0, 5.0), (30.0, 0.0, 0.0), lens=30.0)


def match_cycles(scene, samples, bounces):
    """Render settings under which Cycles and Caustic compute the same image: `bounces` for
    every kind of bounce (Cycles' Light Paths, which Caustic renders too), no denoising, adaptive sampling,
    clamping or light threshold, caustics on, Filter Glossy 0, Blackman-Harris 1.5 px, CPU."""
    c = scene.cycles
    c.device = "CPU"
    c.samples = samples
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = bounces
    c.transmission_bounces = c.volume_bounces = c.transparent_max_bounces = bounces
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    c.light_sampling_threshold = 0.0
    c.caustics_reflective = c.caustics_refractive = True
    c.blur_glossy = 0.0
    c.pixel_filter_type = "BLACKMAN_HARRIS"
    c.filter_width = 1.5


def render_seeded(scene, engine, seed, path):
    """Render `scene` with `engine` ("CYCLES" or "CAUSTIC") and seed `seed`, written to `path`."""
    scene.render.engine = engine
    if engine == "CYCLES":
        scene.cycles.seed = seed
    else:
        scene.caustic.seed = seed
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)


def render_rgb(scene, engine, seed, path):
    """Render `scene` with `engine` ("CYCLES" or "CAUSTIC") and seed `seed` to `path`; the
    linear RGB image as a (height, width, 3) float64 array."""
    render_seeded(scene, engine, seed, path)
    return load_pixels(path)[..., :3].astype(np.float64)


def shader_node_material(name, kind, **inputs):
    """A material whose surface is one shader node of type `kind` (not a Principled BSDF)."""
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:  # Blender < 5.0 creates materials without nodes
        mat.use_nodes = True
    tree = mat.node_tree
    for node in list(tree.nodes):
        if node.type != "OUTPUT_MATERIAL":
            tree.nodes.remove(node)
    node = tree.nodes.new(kind)
    for key, value in inputs.items():
        node.inputs[key].default_value = value
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return mat


def load_pixels(path):
    """An image file as a (height, width, 4) float array, rows bottom to top (Blender's order)."""
    image = bpy.data.images.load(path, check_existing=False)
    try:
        w, h = image.size
        pixels = np.empty(w * h * 4, dtype=np.float32)
        image.pixels.foreach_get(pixels)
        return pixels.reshape(h, w, 4)
    finally:
        bpy.data.images.remove(image)
