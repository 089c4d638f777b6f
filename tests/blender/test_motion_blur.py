"""Motion blur and the Vector pass against Cycles, on a cube sliding across a floor.

Scene: test_cycles_agreement's grey floor and light cube, seen from straight above (64x48,
3 bounces), lit by a sun; the cube is keyed at (x, y) = (-0.6, -0.2) on frame 1 and (0.6, 0.2) on frame 3
(Blender's default Bezier easing, which both renderers sample at their motion steps), and
frame 2 is rendered. At 24 mm and depth 1.8 (the cube's top) a frame moves the
top face about 14 px, so the shutter's half frame blurs it over 7 px.

Motion blur: the image is cut into vertical strips (8 columns each, see STRIP_START): the blurred
cube's light spreads across them, a sharp render or a wrong shutter (length, position) moves
it between strips by far more than the bound. Each strip's mean is compared as
test_cycles_agreement derives its bound (two seeds, 8x8 block variance, 5 sigma + the 1 %
model allowance); each strip has 6 blocks.

Vector pass (motion blur off): pixels whose 3x3 neighbourhood has one Cycles vector (inside the
top face, or on the still floor) hold the same motion in both renderers; the projection is
deterministic, so the bound is float rounding of a 14 px motion (1e-3 px) plus 1e-3 of it for
Cycles' float32 camera matrices.
"""

import importlib
import math

import bpy
import numpy as np
import pytest

import scenes
from exr_io import read_exr
from mathutils import Matrix
from test_export import captured, node_by_name, node_matrix  # noqa: F401  (captured is a fixture)
from test_cycles_agreement import MODEL_ALLOWANCE, SEEDS, SIGMAS, mean_and_variance

pytestmark = pytest.mark.needs_binary

W, H = 64, 48
SAMPLES = 64
BOUNCES = 3
# Strips of 8 columns from column 4: boundaries fall on columns 20 and 44, where the sharp cube
# top's edges are (x = ±0.5 at depth 1.8: 32 ± 0.5 × 64 / (1.5 × 1.8) = 32 ∓ 11.9), so blur moves
# light across them, symmetric (Center) or not.
STRIP, STRIP_START, STRIPS = 8, 4, 7


def build(scene, blur=True, position="CENTER"):
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    scenes.plane(scene, "Floor", 10.0, material=scenes.diffuse_material("Grey", 0.5))
    box = scenes.cube(scene, "Box", 1.0, (0.0, 0.0, 0.5), material=scenes.diffuse_material("Light", 0.8))
    scenes.camera(scene, (0.0, 0.0, 2.8), (0.0, 0.0, 0.0), lens=24.0)
    scenes.light(scene, "Sun", "SUN", rotation_deg=(25.0, 10.0, 0.0), energy=2.0, angle=0.0)
    for frame, (x, y) in ((1, (-0.6, -0.2)), (3, (0.6, 0.2))):
        box.location = (x, y, 0.0)
        box.keyframe_insert("location", frame=frame)
    scene.frame_set(2)
    scene.render.use_motion_blur = blur
    scene.render.motion_blur_shutter = 0.5
    scene.render.motion_blur_position = position
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)


def strip_images(img):
    return [img[:, STRIP_START + k * STRIP:STRIP_START + (k + 1) * STRIP] for k in range(STRIPS)]


@pytest.mark.parametrize("position", ["CENTER", "START"])
def test_moving_cube_blurs_as_in_cycles(empty_scene, tmp_path, position):
    scene = empty_scene
    build(scene, blur=True, position=position)
    assert_blur_matches_cycles(scene, tmp_path, f"motion {position}")


def assert_blur_matches_cycles(scene, tmp_path, label):
    """Caustic's blurred render against Cycles', strip by strip (mean within the bound of each
    strip), and the sharp render outside the bound in some strip, so that the test sees blur."""
    images = {engine: [scenes.render_rgb(scene, engine, s, str(tmp_path / f"{engine}_{s}.exr")).mean(axis=2)
                       for s in SEEDS] for engine in ("CYCLES", "CAUSTIC")}
    sharp = scenes.render_rgb(scene_sharp(scene), "CAUSTIC", SEEDS[0], str(tmp_path / "sharp.exr")).mean(axis=2)
    failures, moved = [], 0.0
    for k in range(STRIPS):
        (mc, vc), (my, vy) = (mean_and_variance(*[strip_images(i)[k] for i in images[e]])
                              for e in ("CAUSTIC", "CYCLES"))
        sigma = math.sqrt(vc + vy)
        bound = SIGMAS * sigma + MODEL_ALLOWANCE * my
        print(f"\n[{label}] strip {k}: caustic {mc:.5f} cycles {my:.5f} ratio {mc / my:.4f} "
              f"bound {bound:.2e} sharp {strip_images(sharp)[k].mean():.5f}")
        if abs(mc - my) > bound:
            failures.append(f"strip {k}: Caustic {mc:.5f}, Cycles {my:.5f}, bound {bound:.2e}")
        moved = max(moved, abs(strip_images(sharp)[k].mean() - my) / bound)
    assert not failures, "; ".join(failures)
    assert moved > 1.0, "the sharp render is within the bound of the blurred one: the scene shows no blur"


def scene_sharp(scene):
    scene.render.use_motion_blur = False
    return scene


def test_vector_pass_matches_cycles(empty_scene, tmp_path):
    scene = empty_scene
    build(scene, blur=False)
    scene.view_layers[0].use_pass_vector = True
    scene.render.image_settings.media_type = "MULTI_LAYER_IMAGE"
    vectors = {}
    for engine in ("CYCLES", "CAUSTIC"):
        scene.render.engine = engine
        path = str(tmp_path / f"{engine}_vector.exr")
        scene.render.filepath = path
        bpy.ops.render.render(write_still=True)
        ch = read_exr(path)
        key = next(k for k in ch if k.endswith("Vector.X"))
        prefix = key[:-1]
        vectors[engine] = np.stack([ch[prefix + c].astype(np.float64) for c in "XYZW"], -1)
    cyc, cau = vectors["CYCLES"], vectors["CAUSTIC"]
    assert np.abs(cyc).max() > 5.0, "Cycles' Vector pass shows no motion: the scene is broken"
    # Pixels whose 3x3 neighbourhood has one Cycles vector: no edge, no filter mixing.
    h, w, _ = cyc.shape
    flat = np.zeros((h, w), dtype=bool)
    for y in range(1, h - 1):
        for x in range(1, w - 1):
            flat[y, x] = np.abs(cyc[y - 1:y + 2, x - 1:x + 2] - cyc[y, x]).max() < 1e-3
    moving = flat & (np.abs(cyc).max(axis=2) > 1.0)
    still = flat & (np.abs(cyc).max(axis=2) == 0.0)
    assert moving.sum() >= 20 and still.sum() >= 20, (moving.sum(), still.sum())
    err = np.abs(cau - cyc)
    bound = 1e-3 + 1e-3 * np.abs(cyc)
    print(f"\n[vector] {moving.sum()} moving pixels: Cycles {cyc[moving].mean(axis=0)}, "
          f"Caustic {cau[moving].mean(axis=0)}; largest difference {err[moving | still].max():.2e} px")
    assert (err[moving] <= bound[moving]).all(), f"largest difference {err[moving].max()} px"
    assert (err[still] <= bound[still]).all()


def test_motion_is_exported_at_cycles_steps(addon, empty_scene, captured):
    """CAUSTIC_motion in the glTF: Cycles' 3 steps (Motion Steps 1) over a centred half-frame
    shutter, the moving cube's matrices in glTF axes (its frame matrix is the node's own), none
    for a still object or one whose Motion Blur is off; a deforming object's vertex positions
    at the frame and the steps, in glTF axes, behind accessors on its node."""
    motion = importlib.import_module(addon.__name__ + ".export.motion")
    scene = empty_scene
    build(scene, blur=True)
    opted = scenes.cube(scene, "Opted", 0.5, (2.0, 0.0, 0.25))
    opted.keyframe_insert("location", frame=1)
    opted.location = (1.0, 0.0, 0.0)
    opted.keyframe_insert("location", frame=3)
    opted.cycles.use_motion_blur = False
    scenes.cube(scene, "Still", 0.5, (-2.0, 0.0, 0.25))
    wobbly = scenes.cube(scene, "Wobbly", 0.5, (0.0, 2.0, 0.25))
    wobbly.shape_key_add(name="Basis")
    key = wobbly.shape_key_add(name="Squash")
    for v in key.data:
        v.co.z *= 0.5
    key.value = 0.0
    key.keyframe_insert("value", frame=1)
    key.value = 1.0
    key.keyframe_insert("value", frame=3)
    scene.frame_set(2)

    sampled = motion.sample_motion(scene, scene.view_layers[0])
    assert sampled.times == pytest.approx([-0.25, 0.0, 0.25])
    assert set(sampled.matrices) == {"Box"}, sampled.matrices.keys()
    assert set(sampled.deformation) == {"Wobbly"}, sampled.deformation.keys()
    assert not sampled.warnings, sampled.warnings
    # The squash halves Blender z (glTF y) from 0.75 to 0.625 (ease) around the frame's value.
    _, reference, steps = sampled.deformation["Wobbly"]
    assert reference.shape == (8, 3) and len(steps) == 3
    assert steps[0][:, 1].max() > reference[:, 1].max() > steps[-1][:, 1].max()
    assert scene.frame_current == 2 and scene.frame_subframe == 0.0

    (gltf,) = captured()
    assert gltf["scenes"][0]["extensions"]["CAUSTIC_motion"] == {
        "times": pytest.approx([-0.25, 0.0, 0.25]), "shutter": {"open": -0.25, "close": 0.25}}
    box = node_by_name(gltf, "Box")
    ext = box["extensions"]["CAUSTIC_motion"]
    frame = Matrix([ext["matrix"][c::4] for c in range(4)])
    assert all(abs(a - b) < 1e-6 for ra, rb in zip(frame, node_matrix(box)) for a, b in zip(ra, rb))
    # The cube moves along Blender's +x (glTF +x) and +y (glTF −z) through the frame.
    first, last = ext["matrices"][0], ext["matrices"][-1]
    assert first[12] < frame[0][3] < last[12] and first[14] > frame[2][3] > last[14]
    for name in ("Opted", "Still"):
        assert "CAUSTIC_motion" not in node_by_name(gltf, name).get("extensions", {})
    wobbly_ext = node_by_name(gltf, "Wobbly")["extensions"]["CAUSTIC_motion"]
    assert wobbly_ext["matrices"] == [wobbly_ext["matrix"]] * 3
    accessors = gltf["accessors"]
    assert [accessors[i]["count"] for i in [wobbly_ext["reference"], *wobbly_ext["positions"]]] == [8] * 4


def build_squash(scene):
    """The floor and the light cube, which a Simple Deform modifier stretches along x (about
    the object's origin), the factor keyed from 0 on frame 1 to 1 on frame 3 (Blender's default
    Bezier keys, which both renderers sample at their motion steps): from frame 2 a half-frame
    shutter sweeps the factor by about a third, so the cube's sides at x = ±0.5 (1 + factor)
    sweep about 0.17, several pixels at 24 mm, while its height and depth shrink by
    1 / sqrt(1 + factor). A modifier, not a
    shape key: the exporter writes a mesh without modifiers from its undeformed data (so
    Caustic warns that it cannot match the deformation of a shape-key-only object)."""
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    scenes.plane(scene, "Floor", 10.0, material=scenes.diffuse_material("Grey", 0.5))
    box = scenes.cube(scene, "Box", 1.0, (0.0, 0.0, 0.5), material=scenes.diffuse_material("Light", 0.8))
    scenes.camera(scene, (0.0, 0.0, 2.8), (0.0, 0.0, 0.0), lens=24.0)
    scenes.light(scene, "Sun", "SUN", rotation_deg=(25.0, 10.0, 0.0), energy=2.0, angle=0.0)
    stretch = box.modifiers.new("Stretch", "SIMPLE_DEFORM")
    stretch.deform_method = "STRETCH"
    stretch.deform_axis = "X"
    for frame, factor in ((1, 0.0), (3, 1.0)):
        stretch.factor = factor
        box.keyframe_insert('modifiers["Stretch"].factor', frame=frame)
    scene.frame_set(2)
    scene.render.use_motion_blur = True
    scene.render.motion_blur_shutter = 0.5
    # The shutter opens at the frame: a centred one would blur each edge evenly about its
    # sharp place, leaving the strips' means where the sharp render has them.
    scene.render.motion_blur_position = "START"
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)


def test_deforming_cube_blurs_as_in_cycles(empty_scene, tmp_path):
    """Deformation motion blur (a modifier stretching the cube) against Cycles, strip by strip
    as the sliding cube above (same bound); the sharp render must fall outside the bound
    somewhere, so the test sees the blur."""
    scene = empty_scene
    build_squash(scene)
    assert_blur_matches_cycles(scene, tmp_path, "deformation")

