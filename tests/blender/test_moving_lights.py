"""Moving lights under motion blur, against Cycles.

Cycles gives lights no motion: a light is placed where it is at the frame (its kernel reads one
position and orientation per light, `klight->co`, with no time), so a moving light renders the
same with motion blur on and off, while the objects around it blur. Caustic does the same
without a warning. This test holds both facts against bpy 5.0.1, so that a Blender that starts
blurring lights fails here first.

Scene: test_motion_blur's floor and camera (straight down, 64x48, 3 bounces), the cube keyed
sliding as there (so the render blurs and the scene has motion), and one light keyed to travel
2 units along x between frames 1 and 3 (frame 2 rendered, shutter one frame: Cycles would
smear it over a unit if it moved): a point light 0.6 above the floor, a spot turning by 60
degrees about y, or an area light 0.8 above it. The pool of light on the floor moves by far
more than the strip bound between the sharp frame pose and any blurred one.

Bound: test_motion_blur's strip comparison (5 sigma of the two seeds' block variance + the 1 %
model allowance per 8-column strip). Cycles' own blur-on and blur-off renders of the light
(the cube left still) agree within the same bound: that is the "lights do not move" check.
"""

import math

import pytest

import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, SEEDS, SIGMAS, mean_and_variance
from test_motion_blur import BOUNCES, SAMPLES, STRIPS, H, W, strip_images

pytestmark = pytest.mark.needs_binary

LIGHTS = {
    "POINT": dict(kind="POINT", z=0.6, energy=60.0, props=dict(shadow_soft_size=0.0)),
    "SPOT": dict(kind="SPOT", z=1.2, energy=150.0, props=dict(shadow_soft_size=0.0, spot_size=math.radians(40.0),
                                                                  spot_blend=0.2)),
    "AREA": dict(kind="AREA", z=0.8, energy=80.0, props=dict(shape="SQUARE", size=0.4)),
}


def build(scene, light, cube_moves=True):
    """The scene of the module's comment with the given light; returns the light object."""
    spec = LIGHTS[light]
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    scenes.plane(scene, "Floor", 10.0, material=scenes.diffuse_material("Grey", 0.5))
    box = scenes.cube(scene, "Box", 0.5, (0.0, 0.6, 0.25), material=scenes.diffuse_material("Light", 0.8))
    scenes.camera(scene, (0.0, 0.0, 2.8), (0.0, 0.0, 0.0), lens=24.0)
    lamp = scenes.light(scene, "Lamp", spec["kind"], location=(0.0, 0.0, spec["z"]), energy=spec["energy"],
                        **spec["props"])
    for frame, x, turn in ((1, -1.0, -30.0), (3, 1.0, 30.0)):
        lamp.location = (x, 0.0, spec["z"])
        lamp.rotation_euler = (0.0, math.radians(turn) if light == "SPOT" else 0.0, 0.0)
        lamp.keyframe_insert("location", frame=frame)
        lamp.keyframe_insert("rotation_euler", frame=frame)
        if cube_moves:
            box.location = (x * 0.5, 0.0, 0.0)
            box.keyframe_insert("location", frame=frame)
    scene.frame_set(2)
    scene.render.use_motion_blur = True
    scene.render.motion_blur_shutter = 1.0
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)
    return lamp


def strip_means(scene, engine, tmp_path, tag):
    """Each seed's image (grey) of `scene` rendered by `engine`."""
    return [scenes.render_rgb(scene, engine, s, str(tmp_path / f"{engine}_{tag}_{s}.exr")).mean(axis=2)
            for s in SEEDS]


def disagreements(a, b, label):
    """Strips where the two-seed renders `a` and `b` differ beyond the bound (module doc)."""
    out, worst = [], 0.0
    for k in range(STRIPS):
        (ma, va), (mb, vb) = (mean_and_variance(*[strip_images(i)[k] for i in imgs]) for imgs in (a, b))
        bound = SIGMAS * math.sqrt(va + vb) + MODEL_ALLOWANCE * mb
        print(f"\n[{label}] strip {k}: {ma:.5f} vs {mb:.5f} ratio {ma / mb:.4f} bound {bound:.2e}")
        worst = max(worst, abs(ma - mb) / bound)
        if abs(ma - mb) > bound:
            out.append(f"strip {k}: {ma:.5f} against {mb:.5f} (bound {bound:.2e})")
    return out, worst


@pytest.mark.parametrize("light", list(LIGHTS))
def test_moving_light_renders_at_the_frame_as_in_cycles(empty_scene, tmp_path, light):
    scene = empty_scene
    lamp = build(scene, light)
    caustic = strip_means(scene, "CAUSTIC", tmp_path, "blur")
    cycles = strip_means(scene, "CYCLES", tmp_path, "blur")
    failures, _ = disagreements(caustic, cycles, f"{light} Caustic/Cycles")
    assert not failures, "; ".join(failures)
    # Cycles leaves the light at the frame: with the cube still, blur on and off agree.
    still = build_still(scene, lamp)
    blur_on = strip_means(still, "CYCLES", tmp_path, "still_on")
    still.render.use_motion_blur = False
    blur_off = strip_means(still, "CYCLES", tmp_path, "still_off")
    failures, _ = disagreements(blur_on, blur_off, f"{light} Cycles blur on/off")
    assert not failures, "Cycles now blurs moving lights; Caustic places them at the frame: " + "; ".join(failures)
    # The light's travel matters: the light where it is at the shutter's opening lights the
    # floor elsewhere, beyond the bound in some strip.
    scene.frame_set(1)
    moved = strip_means(still, "CAUSTIC", tmp_path, "opening")
    scene.frame_set(2)
    _, worst = disagreements(moved, blur_off, f"{light} opening/frame")
    assert worst > 1.0, "the light's pool does not move between the shutter's opening and the frame"


def build_still(scene, lamp):
    """The scene with the cube's keys removed (only the light moves)."""
    box = scene.objects["Box"]
    box.animation_data_clear()
    box.location = (0.0, 0.0, 0.0)
    return scene
