"""A scene with nothing render-visible but a world renders as Cycles renders it.

Cycles draws the world's background where a camera ray meets no object (lights alone are not
seen here: they sit behind the camera), and a world fog lit by a light where there is one.
Caustic refused such scenes ("nothing to render", exit 3) until the loader took the bounds of
a scene without geometry from its cameras and lights. Cases, each against Cycles in real bpy
(test_cycles_agreement's settings: no denoising, clamping or adaptive sampling, equal bounce
limits, Blackman-Harris 1.5 px):

1. a camera and a constant-colour world;
2. a camera and a world graph (a Gradient Texture over the view direction, blue to orange);
3. a cube hidden from renders, a plane in an excluded collection and a point light behind the
   camera, in a constant world;
4. world fog (World Volume, Principled Volume) around a point light, no objects;
5. a sun in world fog, no objects: Cycles gives black (the sun's light crosses an unbounded
   fog), and so must Caustic;
6. a camera and no world at all: Cycles renders black; the add-on writes the missing world as
   a black one, which the binary renders (it refuses a file with no geometry, world or light).

Tolerances (derived, not tuned):
* A constant world (1, 3) is every pixel's value in both renderers: each pixel is a weighted
  mean of equal samples, exact up to float accumulation, about N·2⁻²⁴ relative for N samples
  (N = 16: 1e-6); the bound per pixel is 1e-5 relative, ten times that.
* The graph world (2) and the fog (4) vary within pixels and with the sampler: their channel
  means per image and per quadrant are compared with test_cycles_agreement's two-seed bound
  (5 sigma from 8x8 blocks + 1 % model allowance, derived in that module's doc).
* Black (5, 6): both renderers' images are 0 up to Cycles' float noise floor (it writes a few
  1e-6 values where the world is black); the bound is 1e-5 per pixel.
"""

import bpy
import numpy as np
import pytest

import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, SEEDS, assert_mean_matches_cycles

pytestmark = pytest.mark.needs_binary

W, H = 32, 24
SAMPLES = 16
BOUNCES = 4
WORLD_RGB = (0.25, 0.45, 0.85)
WORLD_STRENGTH = 1.5


def setup(scene, samples=SAMPLES):
    scenes.small_render_settings(scene, W, H, samples=samples)
    scenes.camera(scene, (0.0, -4.0, 1.0), (80.0, 0.0, 10.0), lens=24.0)
    scene.caustic.threads = 0
    scenes.match_cycles(scene, samples, BOUNCES)


def constant_world(scene):
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (*WORLD_RGB, 1.0)
    bg.inputs["Strength"].default_value = WORLD_STRENGTH
    scene.world = world


def gradient_world(scene):
    """Background colour from a Gradient Texture (linear, over the Generated direction's x)
    through a Color Ramp, blue to orange: the image varies across the frame."""
    world = bpy.data.worlds.new("Gradient")
    world.use_nodes = True
    nodes, links = world.node_tree.nodes, world.node_tree.links
    coords = nodes.new("ShaderNodeTexCoord")
    gradient = nodes.new("ShaderNodeTexGradient")
    ramp = nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.1, 0.2, 0.9, 1.0)
    ramp.color_ramp.elements[1].color = (1.0, 0.5, 0.1, 1.0)
    links.new(coords.outputs["Generated"], gradient.inputs["Vector"])
    links.new(gradient.outputs["Fac"], ramp.inputs["Fac"])
    links.new(ramp.outputs["Color"], nodes["Background"].inputs["Color"])
    scene.world = world


def fog_world(scene, sun):
    """Principled Volume on the World Output's Volume, black background; a point light in
    front of the camera (Cycles renders its glow in the fog) or a sun."""
    world = bpy.data.worlds.new("Fog")
    world.use_nodes = True
    nodes, links = world.node_tree.nodes, world.node_tree.links
    nodes["Background"].inputs["Strength"].default_value = 0.0
    volume = nodes.new("ShaderNodeVolumePrincipled")
    volume.inputs["Density"].default_value = 0.15
    volume.inputs["Color"].default_value = (0.9, 0.8, 0.7, 1.0)
    links.new(volume.outputs["Volume"], nodes["World Output"].inputs["Volume"])
    scene.world = world
    if sun:
        scenes.light(scene, "Sun", "SUN", rotation_deg=(40.0, 0.0, 30.0), energy=3.0, angle=0.0)
    else:
        scenes.light(scene, "Point", "POINT", location=(0.3, 0.0, 1.2), energy=200.0, shadow_soft_size=0.0)


def hidden_objects(scene):
    """A cube hidden from renders, a plane in an excluded collection, a light behind the camera."""
    constant_world(scene)
    cube = scenes.cube(scene, "Hidden", 1.0, (0.0, 0.0, 1.0), material=scenes.diffuse_material("Grey", 0.5))
    cube.hide_render = True
    excluded = bpy.data.collections.new("Excluded")
    scene.collection.children.link(excluded)
    floor = scenes.plane(scene, "Floor", 8.0, material=scenes.diffuse_material("Floor", 0.5))
    for c in list(floor.users_collection):
        c.objects.unlink(floor)
    excluded.objects.link(floor)
    bpy.context.view_layer.layer_collection.children["Excluded"].exclude = True
    scenes.light(scene, "Behind", "POINT", location=(0.0, -6.0, 1.0), energy=100.0, shadow_soft_size=0.0)


def render_both(scene, tmp_path, seed=1):
    return {engine: scenes.render_rgb(scene, engine, seed, str(tmp_path / f"{engine}.exr"))
            for engine in ("CYCLES", "CAUSTIC")}


def assert_pixels(images, want, rel, label):
    """Both engines' pixels equal `want` (per channel) within `rel` relative (or absolute
    when `want` is 0)."""
    want = np.asarray(want, dtype=np.float64)
    for engine, img in images.items():
        scale = np.where(want > 0.0, want, 1.0)
        err = np.abs(img - want) / scale
        worst = float(err.max())
        print(f"\n[{label}] {engine}: mean {img.mean(axis=(0, 1))}, worst relative error {worst:.2e}")
        assert worst <= rel, f"{label}: {engine} differs from {want} by {worst:.2e} (bound {rel:.0e})"
    ratio = images["CAUSTIC"].mean() / images["CYCLES"].mean() if images["CYCLES"].mean() > 0 else float("nan")
    print(f"[caustic/cycles] {label} ratio {ratio:.6f}")


@pytest.mark.parametrize("case", ["constant_world", "hidden_objects"])
def test_constant_world_is_every_pixel(empty_scene, tmp_path, case):
    scene = empty_scene
    setup(scene)
    {"constant_world": constant_world, "hidden_objects": hidden_objects}[case](scene)
    want = [c * WORLD_STRENGTH for c in WORLD_RGB]
    assert_pixels(render_both(scene, tmp_path), want, 1e-5, case)


def test_gradient_world_matches_cycles(empty_scene, tmp_path):
    scene = empty_scene
    setup(scene)
    gradient_world(scene)
    ratios = assert_mean_matches_cycles(scene, tmp_path, "gradient world", MODEL_ALLOWANCE, per_channel=True)
    print(f"\n[caustic/cycles] gradient world {ratios}")
    # Orientation: the left and right halves differ (a mirrored gradient fails here).
    images = {e: scenes.render_rgb(scene, e, SEEDS[0], str(tmp_path / f"{e}_halves.exr"))
              for e in ("CYCLES", "CAUSTIC")}
    halves = {e: (img[:, : W // 2].mean(axis=(0, 1)), img[:, W // 2:].mean(axis=(0, 1))) for e, img in images.items()}
    for side in (0, 1):
        c, y = halves["CAUSTIC"][side], halves["CYCLES"][side]
        assert np.all(np.abs(c - y) <= MODEL_ALLOWANCE * y + 1e-4), f"half {side}: Caustic {c} vs Cycles {y}"


def test_world_fog_around_a_light_matches_cycles(empty_scene, tmp_path):
    scene = empty_scene
    setup(scene, samples=64)
    fog_world(scene, sun=False)
    ratios = assert_mean_matches_cycles(scene, tmp_path, "world fog, point", MODEL_ALLOWANCE, per_channel=True)
    print(f"\n[caustic/cycles] world fog around a point light {ratios}")


def test_sun_in_world_fog_is_black_as_in_cycles(empty_scene, tmp_path):
    scene = empty_scene
    setup(scene)
    fog_world(scene, sun=True)
    assert_pixels(render_both(scene, tmp_path), [0.0, 0.0, 0.0], 1e-5, "sun in world fog")


def test_camera_without_world_is_black_as_in_cycles(empty_scene, tmp_path):
    scene = empty_scene
    setup(scene)
    assert scene.world is None
    assert_pixels(render_both(scene, tmp_path), [0.0, 0.0, 0.0], 1e-5, "no world")


def test_the_rendered_viewport_shows_the_world_then_an_added_object(addon, empty_scene):
    """The Rendered viewport of a world-only scene (the server loads a scene without
    geometry): its converged frame is the world's colour, within half-float rounding (the
    viewport's frames are half floats: 2⁻¹¹ relative at most, which dwarfs the film's own
    1e-6); an object added afterwards is merged into it (`objects`) and darkens the frame."""
    import sys
    from test_viewport import _apply_live, _converged, _Engine
    viewport = sys.modules[f"{addon.__name__}.viewport"]
    scene = empty_scene
    setup(scene, samples=4)
    constant_world(scene)
    v = viewport.Viewport(_Engine())
    try:
        v.update(bpy.context, bpy.context.evaluated_depsgraph_get())
        frame = _converged(v)[..., :3]
        want = np.array([c * WORLD_STRENGTH for c in WORLD_RGB])
        worst = float((np.abs(frame - want) / want).max())
        print(f"\n[viewport] world only: worst relative error {worst:.2e}")
        assert worst <= 2.0 ** -11

        def add():
            scenes.cube(scene, "Added", 1.5, (0.0, 0.0, 1.0), material=scenes.diffuse_material("Dark", 0.05))

        sent = _apply_live(v, add)
        assert "objects" in sent or "load" in sent, sent
        after = _converged(v)[..., :3]
        assert not [r for r in v.engine.reports if r[0] == {"ERROR"}], v.engine.reports
        assert after.mean() < 0.95 * frame.mean(), f"the added cube is not seen: {after.mean()} vs {frame.mean()}"
    finally:
        v.free()
