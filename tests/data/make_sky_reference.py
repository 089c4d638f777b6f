"""Reference values of Blender's Sky Texture, computed by Cycles itself.

Run with the project's real bpy (5.0.1):

    .venv/bin/python tests/data/make_sky_reference.py

Blender 5.0's Sky Texture reads the direction itself in the Single and Multiple Scattering
models (the Vector socket is unavailable); for Preetham and Hosek / Wilkie the unlinked Vector
is the same direction (Generated, on the world). So Cycles renders the world through an equirectangular panoramic camera,
W x H pixels, one sample per pixel with a 0.01 px pixel filter (the same sample position in
every render of a pixel): first a world whose Background colour is 0.5 Generated + 0.5
(Generated is the direction on the world), which gives each pixel's direction, then one world
per case with the Sky Texture as the Background colour (strength 1). Colour management is Standard
(scene linear out). The result, with each case's node settings as the add-on exports them,
is `sky_reference.json`, read by `src/shader/sky/mod.rs`'s tests.
"""

import json
import math
import pathlib
import tempfile

import bpy
import numpy as np

W, H = 64, 32
OUT = pathlib.Path(__file__).with_name("sky_reference.json")

CASES = [
    ("multiple_default", {"sky_type": "MULTIPLE_SCATTERING"}),
    ("multiple_settings", {"sky_type": "MULTIPLE_SCATTERING", "sun_size": math.radians(8.0),
                           "sun_elevation": math.radians(40.0), "sun_rotation": 1.0, "sun_intensity": 0.5,
                           "altitude": 2000.0, "air_density": 2.0, "aerosol_density": 0.5,
                           "ozone_density": 3.0}),
    ("multiple_low_sun", {"sky_type": "MULTIPLE_SCATTERING", "sun_size": math.radians(10.0),
                          "sun_elevation": math.radians(2.0), "sun_rotation": -2.0}),
    ("single_settings", {"sky_type": "SINGLE_SCATTERING", "sun_size": math.radians(8.0),
                         "sun_elevation": math.radians(10.0), "sun_rotation": 0.5, "altitude": 500.0,
                         "air_density": 1.5, "aerosol_density": 2.0, "ozone_density": 0.5}),
    # The legacy models (Blender 2.7x-2.9x scenes), read from sun_direction, turbidity and
    # ground_albedo: a mid sun and a low one, whole and fractional turbidities (Hosek blends
    # the two nearest rows), albedos between the dataset's 0 and 1.
    ("preetham_default", {"sky_type": "PREETHAM"}),
    ("preetham_low_sun", {"sky_type": "PREETHAM", "sun_direction": (0.6, -0.7, 0.12), "turbidity": 5.5}),
    ("hosek_default", {"sky_type": "HOSEK_WILKIE"}),
    ("hosek_settings", {"sky_type": "HOSEK_WILKIE", "sun_direction": (-0.4, 0.3, 0.5), "turbidity": 6.3,
                        "ground_albedo": 0.7}),
    ("hosek_low_sun", {"sky_type": "HOSEK_WILKIE", "sun_direction": (0.2, 0.9, 0.05), "turbidity": 2.0,
                       "ground_albedo": 0.1}),
]
# The legacy models' settings, in the props of their cases only (so that the physical
# cases' entries stay as they were).
LEGACY_KEYS = ("sun_direction", "turbidity", "ground_albedo")


def build_scene():
    scene = bpy.context.scene
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.device = "CPU"
    c.samples = 1
    c.seed = 0
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.max_bounces = 0
    c.pixel_filter_type = "BOX"
    scene.render.filter_size = 0.01
    scene.render.resolution_x, scene.render.resolution_y = W, H
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    cam_data = bpy.data.cameras.new("cam")
    cam_data.type = "PANO"
    cam_data.panorama_type = "EQUIRECTANGULAR"
    cam = bpy.data.objects.new("cam", cam_data)
    cam.rotation_euler = (math.pi / 2, 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam

    world = bpy.data.worlds.new("sky")
    scene.world = world
    nt = world.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputWorld")
    background = nt.nodes.new("ShaderNodeBackground")
    background.inputs["Strength"].default_value = 1.0
    sky = nt.nodes.new("ShaderNodeTexSky")
    nt.links.new(background.outputs[0], out.inputs["Surface"])
    # The direction pass: Generated (the direction, in the world) as 0.5 d + 0.5.
    coord = nt.nodes.new("ShaderNodeTexCoord")
    half = nt.nodes.new("ShaderNodeVectorMath")
    half.operation = "MULTIPLY_ADD"
    half.inputs[1].default_value = (0.5, 0.5, 0.5)
    half.inputs[2].default_value = (0.5, 0.5, 0.5)
    nt.links.new(coord.outputs["Generated"], half.inputs[0])

    def show(socket):
        nt.links.new(socket, background.inputs["Color"])

    return scene, sky, lambda: show(half.outputs[0]), lambda: show(sky.outputs["Color"])


def render(scene, path):
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(path, check_existing=False)
    pixels = np.empty(W * H * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    bpy.data.images.remove(image)
    return pixels.reshape(H, W, 4)[..., :3]


def main():
    scene, sky, show_direction, show_sky = build_scene()
    keys = ("sky_type", "sun_disc", "sun_size", "sun_intensity", "sun_elevation", "sun_rotation", "altitude",
            "air_density", "aerosol_density", "ozone_density")
    defaults = {k: getattr(sky, k) for k in keys}
    defaults.update({k: tuple(v) if k == "sun_direction" else v
                     for k, v in ((k, getattr(sky, k)) for k in LEGACY_KEYS)})
    cases = []
    with tempfile.TemporaryDirectory() as tmp:
        show_direction()
        d = render(scene, str(pathlib.Path(tmp) / "direction.exr")).astype(np.float64) * 2.0 - 1.0
        lengths = np.linalg.norm(d, axis=2)
        print("direction lengths", lengths.min(), lengths.max())
        show_sky()
        for name, settings in CASES:
            for k, v in defaults.items():
                setattr(sky, k, v)
            for k, v in settings.items():
                setattr(sky, k, v)
            case_keys = keys + (LEGACY_KEYS if settings["sky_type"] in ("PREETHAM", "HOSEK_WILKIE") else ())
            props = {k: getattr(sky, k) for k in case_keys}
            props = {k: (v if isinstance(v, (str, bool)) else [float(x) for x in v] if k == "sun_direction"
                         else float(v)) for k, v in props.items()}
            rgb = render(scene, str(pathlib.Path(tmp) / f"{name}.exr"))
            samples = [[round(float(v), 7) for v in d[j, i]] + [float(v) for v in rgb[j, i]]
                       for j in range(H) for i in range(W)]
            cases.append({"name": name, "props": props, "samples": samples})
            print(name, "mean", rgb.mean(axis=(0, 1)), "max", rgb.max())
    OUT.write_text(json.dumps({"width": W, "height": H, "cases": cases}, separators=(",", ":")))
    print("wrote", OUT, OUT.stat().st_size, "bytes")


if __name__ == "__main__":
    main()
