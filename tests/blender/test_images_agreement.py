"""Image textures from files, in the colour spaces, alpha modes, sequences and extensions
everyday scenes use: Caustic (through the add-on's node graphs) against Cycles.

Each case is test_nodes_agreement.py's flat scene (a 2x2 plane filling the frame under a sun)
whose Diffuse BSDF (or Principled BSDF, where the glTF exporter would take it) is coloured by a
16x16 image file written for the test: a gradient in red and green and a 2-texel checker in
blue, so that both the mean and the filtering between dark and light texels are seen. The two
checks and their tolerances are test_nodes_agreement.compare's (image mean per channel within
5 sigma + 1 %, every 4x4 block within 5 sigma + 2 %), derived there from the renders' noise.

What each case catches (Caustic/Cycles mean R/G/B with main's binary and add-on, printed with
pytest -s; after: 0.9984-1.0022, no block over its bound):
* png16_srgb: a 16-bit PNG is a float image to Blender, which decodes it to linear on loading;
  the add-on wrote those linear values tagged sRGB, decoded twice: 0.5527 0.3839 0.9866 (every
  block over), silently. Cycles keeps an sRGB image encoded and decodes after filtering, now
  so does the renderer for float images too.
* exr_tagged_srgb: the same for an OpenEXR whose colour space is set to sRGB: 0.5537 0.3852
  0.9821, silently.
* acescg_png / agx_log_png: 8-bit images in a colour space the contract does not name were
  read as linear (with a warning): ACEScg 0.9372 1.0002 0.9996 (53 of 108 blocks over), AgX
  Log 0.0008 0.0091 0.0007; now Blender's colour management converts them to linear floats.
* acescg_principled: the same ACEScg image as a Principled Base Color, which the glTF
  exporter copied as an sRGB texture: 0.6124 0.5947 0.6458, silently; now such a material goes
  as its node graph.
* alpha_none: an image with Alpha mode None into Principled Alpha over a floor: Cycles ignores
  the stored alpha, Caustic used it: 1.2564 1.1112 1.0512, silently.
* sequence_offset: a two-frame image sequence shown with an Image User offset of 1: the add-on
  found no pixels and rendered the missing-image colour (7.5254 0.0000 3.3442, with
  warnings); now the frame Blender picks (Start, Offset, Frames, Cyclic) is written.
* sequence_principled: the same sequence into a Principled BSDF's Base Color: the glTF exporter
  did not carry the frame (Caustic rendered the missing-image colour): 5.2316 3.1519 2.8893 (108
  of 108 blocks over; sweep 4's image_sequence_frame at frame 4: 1.4907 1.6010 1.5698, 16 of 48),
  silently; now such a material goes as its node graph, which writes the frame Blender picks.
* clip_edge: Extension Clip, the image shown at half size in the middle of the plane: Cycles'
  linear filter fades out over half a texel past the edge, where Caustic cut at the edge:
  0.9886 0.9884 0.9913 (13 of 108 blocks over), silently.
* udim_tiles: a UDIM image of two tiles on UVs that span both: only the first tile was
  exported (with a warning) and repeated: 1.7459 1.7430 0.0258 (52 of 108 blocks over); now
  each tile is its own image, picked as Cycles' `kernel_image_udim_map`.
* udim_tiles_principled: the same image into a Principled BSDF's Base Color, each face within
  one tile: Blender's glTF exporter splits such a mesh into a primitive per tile with its UVs
  moved into 0-1, and the node graph (which holds every tile) read tile 1001 everywhere:
  R/G/B 1.5056/1.5105/0.1741 (51 of 108 blocks over; corpus 33_udim.blend 15 of 48), silently;
  now the UVs are moved back to their tiles.
* alpha_*: images with an alpha channel, which Cycles holds with associated alpha (colour
  times alpha, filtered so, divided back only where the node's Alpha is linked). Straight and
  Premultiplied 8-bit PNGs on Base Color alone: glTF's straight texture, 1.2387 1.8392 1.8608
  (97 of 108 blocks over) and 1.1116 1.1873 1.1924 (85), silently; a leaf cutout (an opaque
  disc in white transparent texels) into Base Color and Alpha over a floor: the white bled
  into the edge, 1.0821 1.0327 1.0785 (36), silently; an OpenEXR on Base Color alone (held
  associated by Blender, read straight): 0.6482 0.5946 0.6482 (108). Channel Packed (never
  associated) and a 16-bit PNG leaf (its Alpha linked) agreed before and still do.
* texture_limit_*: Simplify's render Texture Limit (128 px) on a 300x130 image whose green is
  a 1-texel checker: Cycles scales it by 1/4 on load, averaging 4x4 texels in their stored
  (sRGB) encoding, so the checker turns a flat 0.5 encoded (0.21 linear), where the full-size
  image, filtered between its dark and light texels before decoding, renders brighter. Caustic
  rendered the full size (warned): Diffuse (node graph) 1.0007 1.1147 1.0346 (12 of 108 blocks
  over), Principled Base Color (glTF texture) 1.0007 1.0862 1.0272 (7); now the binary shrinks
  every image as Cycles does (`scene/texture_limit.rs`). texture_limit_float: the same checker as an
  OpenEXR (held as floats): its first version asked the empty byte storage to shrink and panicked
  on any float image over the limit; 0.9999.
* alpha_png16_*: a 16-bit PNG with alpha on Base Color alone. Cycles reads the file itself and
  associates it in its sRGB encoding in either alpha mode; the add-on wrote Blender's pixels
  (linear, associated) re-encoded: Straight 1.2257 1.8271 1.8505 (97 of 108 blocks over),
  Premultiplied 1.5869 10.5287 11.6448 (99); now the stored values times alpha are written (node_images.py).
"""

import os

import bpy
import numpy as np
import pytest

import scenes
import test_nodes_agreement as nodes
from test_node_graph_export import diffuse_from, new_material, uv_plane

pytestmark = pytest.mark.needs_binary

SIZE = 16


def pattern(alpha=False):
    """RGBA rows bottom to top: red rises across, green up, blue a 2-texel checker of 0.1/0.9;
    alpha (when asked) rises across from 0 to 1."""
    px = np.ones((SIZE, SIZE, 4), dtype=np.float32)
    ramp = (np.arange(SIZE) + 0.5) / SIZE
    px[..., 0] = ramp[None, :]
    px[..., 1] = ramp[:, None]
    px[..., 2] = ((np.arange(SIZE)[None, :] // 2 + np.arange(SIZE)[:, None] // 2) % 2) * 0.8 + 0.1
    if alpha:
        px[..., 3] = np.clip(ramp[None, :] * 1.2, 0.0, 1.0) * np.ones((SIZE, 1))
    return px


def image_file(path, fmt="PNG", depth="8", colorspace=None, alpha=False, float_buffer=False):
    """`pattern()` saved at `path` (format and bit depth as the scene's output would write it,
    no view transform) and loaded back as Blender loads a texture; its colour space set."""
    img = bpy.data.images.new(os.path.basename(path), SIZE, SIZE, alpha=True, float_buffer=float_buffer)
    img.pixels.foreach_set(pattern(alpha).ravel())
    scene = bpy.context.scene
    out, view = scene.render.image_settings, scene.view_settings
    saved = (out.file_format, out.color_depth, out.color_mode, view.view_transform)
    out.file_format, out.color_mode, out.color_depth = fmt, "RGBA", depth
    view.view_transform = "Standard"
    img.save_render(path, scene=scene)
    out.file_format = saved[0]
    out.color_depth, out.color_mode, view.view_transform = saved[1:]
    bpy.data.images.remove(img)
    loaded = bpy.data.images.load(path)
    if colorspace is not None:
        loaded.colorspace_settings.name = colorspace
    return loaded


def fine_checker_exr(folder, name, width=300, height=130):
    """`fine_checker` as an OpenEXR (a float image, held as floats by both renderers)."""
    px = np.ones((height, width, 4), dtype=np.float32)
    px[..., 1] = ((np.arange(width)[None, :] + np.arange(height)[:, None]) % 2) * 0.9 + 0.05
    path = os.path.join(folder, f"{name}.exr")
    img = bpy.data.images.new(os.path.basename(path), width, height, alpha=True, float_buffer=True)
    img.pixels.foreach_set(px.ravel())
    img.filepath_raw = path
    img.file_format = "OPEN_EXR"
    img.save()
    bpy.data.images.remove(img)
    return bpy.data.images.load(path)


def fine_checker(folder, name, width=300, height=130):
    """A `width` x `height` image (sRGB PNG): red rising across, green a 1-texel checker of
    0.05/0.95, blue rising up; large enough for Simplify's smallest Texture Limit (128)."""
    px = np.ones((height, width, 4), dtype=np.float32)
    px[..., 0] = ((np.arange(width) + 0.5) / width)[None, :]
    px[..., 1] = ((np.arange(width)[None, :] + np.arange(height)[:, None]) % 2) * 0.9 + 0.05
    px[..., 2] = ((np.arange(height) + 0.5) / height)[:, None]
    path = os.path.join(folder, f"{name}.png")
    _save_png(px, path)
    return bpy.data.images.load(path)


def simplified(build, limit="128"):
    """`build` with Simplify on and its render Texture Limit at `limit`."""
    def make(scene, material):
        build(scene, material)
        scene.render.use_simplify = True
        scene.cycles.texture_limit_render = limit
    return make


def _save_png(px, path):
    """RGBA pixels `px` (rows bottom to top) written as an 8-bit PNG file at `path`, as Blender
    saves an image datablock (the frames of a sequence, the tiles of a UDIM set)."""
    img = bpy.data.images.new(os.path.basename(path), px.shape[1], px.shape[0], alpha=True)
    img.pixels.foreach_set(px.ravel())
    img.filepath_raw = path
    img.file_format = "PNG"
    img.save()
    bpy.data.images.remove(img)


def diffuse_image(make_image):
    """A maker: a Diffuse BSDF coloured by an Image Texture of `make_image(folder, name)`."""
    def make(folder, name):
        mat = new_material(name)
        node = mat.node_tree.nodes.new("ShaderNodeTexImage")
        node.image = make_image(folder, name)
        diffuse_from(mat, node.outputs["Color"])
        return mat
    return make


def principled_image(make_image, alpha=False):
    """A maker: the default Principled BSDF with Base Color (and Alpha) from an Image Texture."""
    def make(folder, name):
        mat = bpy.data.materials.new(name)
        if mat.node_tree is None:
            mat.use_nodes = True
        tree = mat.node_tree
        bsdf = tree.nodes["Principled BSDF"]
        node = tree.nodes.new("ShaderNodeTexImage")
        node.image = make_image(folder, name)
        tree.links.new(node.outputs["Color"], bsdf.inputs["Base Color"])
        if alpha:
            tree.links.new(node.outputs["Alpha"], bsdf.inputs["Alpha"])
        return mat
    return make


def sequence(folder, name):
    """Two frames (red 0.2 and 0.4) of a sequence; the node shows the second one at frame 1."""
    for frame in (1, 2):
        px = pattern()
        px[..., 0] = 0.2 * frame
        _save_png(px, os.path.join(folder, f"{name}_{frame:04d}.png"))
    img = bpy.data.images.load(os.path.join(folder, f"{name}_0001.png"))
    img.source = "SEQUENCE"
    return img


def sequence_material(folder, name):
    mat = diffuse_image(sequence)(folder, name)
    user = next(n for n in mat.node_tree.nodes if n.type == "TEX_IMAGE").image_user
    user.frame_duration, user.frame_offset = 2, 1
    return mat


def sequence_principled(folder, name):
    """The sequence into a Principled BSDF's Base Color, the node showing its second frame."""
    mat = principled_image(sequence)(folder, name)
    user = next(n for n in mat.node_tree.nodes if n.type == "TEX_IMAGE").image_user
    user.frame_duration, user.frame_offset = 2, 1
    return mat


def clipped(folder, name):
    """A Diffuse BSDF coloured by the image with Extension Clip, UVs scaled 2x about the centre
    (the image covers the middle half of the plane; black around it)."""
    mat = diffuse_image(lambda f, n: image_file(os.path.join(f, f"{n}.png")))(folder, name)
    tree = mat.node_tree
    node = next(n for n in tree.nodes if n.type == "TEX_IMAGE")
    node.extension = "CLIP"
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.inputs["Location"].default_value = (-0.5, -0.5, 0.0)
    mapping.inputs["Scale"].default_value = (2.0, 2.0, 1.0)
    tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["UV"], mapping.inputs["Vector"])
    tree.links.new(mapping.outputs["Vector"], node.inputs["Vector"])
    return mat


def udim(folder, name):
    """A UDIM image of two tiles, 1001 (the pattern, blue 0.1) and 1002 (darker, blue 0.9),
    from files `<name>.1001.png` and `<name>.1002.png`."""
    for tile, scale, blue in ((1001, 1.0, 0.1), (1002, 0.4, 0.9)):
        px = pattern()
        px[..., :2] *= scale
        px[..., 2] = blue
        _save_png(px, os.path.join(folder, f"{name}.{tile}.png"))
    img = bpy.data.images.load(os.path.join(folder, f"{name}.1001.png"))
    img.source = "TILED"
    img.filepath = os.path.join(folder, f"{name}.<UDIM>.png")
    if 1002 not in [t.number for t in img.tiles]:
        img.tiles.new(tile_number=1002)
    img.reload()
    return img


def udim_scene(scene, material):
    """The flat scene with the plane's U running 0 to 2: tiles 1001 and 1002."""
    nodes.flat_scene(scene, material)
    mesh = scene.objects["Plane"].data
    for i, loop in enumerate(mesh.loops):
        mesh.uv_layers["UVMap"].data[i].uv = [(0, 0), (2, 0), (2, 1), (0, 1)][loop.vertex_index]


def udim_split_scene(scene, material):
    """Two quads side by side filling the flat scene's view, the left one's UVs in tile 1001,
    the right one's in tile 1002 (each face within one tile, as an unwrap packed per tile)."""
    verts = [(-1.0, -0.75, 0.0), (0.0, -0.75, 0.0), (0.0, 0.75, 0.0), (-1.0, 0.75, 0.0),
             (0.0, -0.75, 0.0), (1.0, -0.75, 0.0), (1.0, 0.75, 0.0), (0.0, 0.75, 0.0)]
    obj = scenes.mesh_object(scene, "Plane", verts, [(0, 1, 2, 3), (4, 5, 6, 7)], material=material)
    layer = obj.data.uv_layers.new(name="UVMap")
    corners = [(0.1, 0.1), (0.9, 0.1), (0.9, 0.9), (0.1, 0.9)]
    for poly in obj.data.polygons:
        for corner, loop in zip(corners, poly.loop_indices):
            layer.data[loop].uv = (corner[0] + poly.index, corner[1])
    scenes.camera(scene, (0.0, 0.0, 3.0), (0.0, 0.0, 0.0), lens=54.0)
    scenes.light(scene, "Sun", "SUN", rotation_deg=(20.0, 10.0, 0.0), energy=3.0, angle=0.0)


def with_alpha_mode(mode):
    def make(folder, name):
        img = image_file(os.path.join(folder, f"{name}.png"), alpha=True)
        img.alpha_mode = mode
        return img
    return make


def png16_alpha(mode):
    """The alpha pattern as a 16-bit PNG in Alpha mode `mode`."""
    def make(folder, name):
        img = image_file(os.path.join(folder, f"{name}.png"), depth="16", alpha=True)
        img.alpha_mode = mode
        return img
    return make


def premultiplied(folder, name):
    """The alpha pattern saved premultiplied (colour times alpha, as a premultiplied file holds
    it), Alpha mode Premultiplied."""
    px = pattern(alpha=True)
    px[..., :3] *= px[..., 3:4]
    path = os.path.join(folder, f"{name}.png")
    _save_png(px, path)
    img = bpy.data.images.load(path)
    img.alpha_mode = "PREMUL"
    return img


def cutout(folder, name):
    """A leaf card as painted: an opaque green disc in a transparent surround whose colour is
    white (8-bit PNG, Alpha mode Straight), so a straight filter bleeds white into the edge."""
    y, x = np.mgrid[0:SIZE, 0:SIZE]
    inside = ((x - 7.5) ** 2 + (y - 7.5) ** 2 < 36)[..., None]
    px = np.where(inside, (0.2, 0.7, 0.1, 1.0), (1.0, 1.0, 1.0, 0.0)).astype(np.float32)
    path = os.path.join(folder, f"{name}.png")
    _save_png(px, path)
    return bpy.data.images.load(path)


def floor_scene(scene, material):
    """The flat scene's plane 0.3 above a grey floor, which shows through its alpha."""
    nodes.flat_scene(scene, material)
    scene.objects["Plane"].location.z = 0.3
    scenes.plane(scene, "Floor", 6.0, material=scenes.diffuse_material("Floor", 0.6))


CASES = {
    "png16_srgb": (nodes.flat_scene, diffuse_image(
        lambda folder, name: image_file(os.path.join(folder, f"{name}.png"), depth="16"))),
    "exr_tagged_srgb": (nodes.flat_scene, diffuse_image(
        lambda folder, name: image_file(os.path.join(folder, f"{name}.exr"), "OPEN_EXR", "32", "sRGB",
                                        float_buffer=True))),
    "acescg_png": (nodes.flat_scene, diffuse_image(
        lambda folder, name: image_file(os.path.join(folder, f"{name}.png"), colorspace="ACEScg"))),
    "agx_log_png": (nodes.flat_scene, diffuse_image(
        lambda folder, name: image_file(os.path.join(folder, f"{name}.png"), colorspace="AgX Log"))),
    "acescg_principled": (nodes.flat_scene, principled_image(
        lambda folder, name: image_file(os.path.join(folder, f"{name}.png"), colorspace="ACEScg"))),
    "alpha_none": (floor_scene, principled_image(with_alpha_mode("NONE"), alpha=True)),
    "alpha_straight_colour_only": (nodes.flat_scene, principled_image(with_alpha_mode("STRAIGHT"))),
    "alpha_premultiplied_colour_only": (nodes.flat_scene, principled_image(premultiplied)),
    "alpha_channel_packed_colour_only": (nodes.flat_scene, principled_image(with_alpha_mode("CHANNEL_PACKED"))),
    "alpha_cutout_leaf": (floor_scene, principled_image(cutout, alpha=True)),
    "alpha_png16_leaf": (floor_scene, principled_image(
        lambda folder, name: image_file(os.path.join(folder, f"{name}.png"), depth="16", alpha=True), alpha=True)),
    "alpha_png16_colour_only": (nodes.flat_scene, principled_image(png16_alpha("STRAIGHT"))),
    "alpha_png16_premultiplied_colour_only": (nodes.flat_scene, principled_image(png16_alpha("PREMUL"))),
    "alpha_exr_colour_only": (nodes.flat_scene, principled_image(
        lambda folder, name: image_file(os.path.join(folder, f"{name}.exr"), "OPEN_EXR", "32", alpha=True,
                                        float_buffer=True))),
    "sequence_offset": (nodes.flat_scene, sequence_material),
    "sequence_principled": (nodes.flat_scene, sequence_principled),
    "clip_edge": (nodes.flat_scene, clipped),
    "udim_tiles": (udim_scene, diffuse_image(udim)),
    "texture_limit_graph": (simplified(nodes.flat_scene), diffuse_image(fine_checker)),
    "texture_limit_gltf": (simplified(nodes.flat_scene), principled_image(fine_checker)),
    "texture_limit_float": (simplified(nodes.flat_scene), diffuse_image(fine_checker_exr)),
    "udim_tiles_principled": (udim_split_scene, principled_image(udim)),
}


@pytest.mark.parametrize("case", list(CASES))
def test_image_matches_cycles(empty_scene, tmp_path, case):
    build, make = CASES[case]
    build(empty_scene, make(str(tmp_path), case))
    scenes.small_render_settings(empty_scene, nodes.W, nodes.H, samples=nodes.SAMPLES)
    empty_scene.caustic.threads = 0
    scenes.match_cycles(empty_scene, nodes.SAMPLES, nodes.BOUNCES)
    nodes.compare(empty_scene, tmp_path, case)
