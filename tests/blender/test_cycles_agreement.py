"""Caustic and Cycles agree on the brightness of the same .blend, light type by light type.

Scene: a grey Lambertian floor (albedo 0.5) and a lighter cube (0.8), camera below the lights
looking straight down (so no light is in view), no world. Lit in turn by a point light
(radius 0), a spot (blend 0, radius 0), a sun (angle 0), a rectangular and a disk area light and
an emissive quad. Both renderers: 64x48, 3 bounces (Caustic max_depth 4), no clamping, no
denoising, no adaptive sampling, Blackman-Harris 1.5 px filter.

How the tolerance is derived (nothing is tuned by hand except the model allowance):
* Each renderer renders the scene with two seeds, a and b. For any pixel, var(a_p - b_p) =
  2 var_p, so the variance of one image's mean is sum_p var_p / P^2. Pixel filters make
  neighbouring pixels' errors correlated, so the sum is taken over 8x8-pixel blocks (sums of
  a - b per block), which are nearly independent: var(mean) ~= sum_blocks D_k^2 / (2 P^2), with
  48 blocks, i.e. 48 degrees of freedom.
* The estimate compared is the mean of the two seeds, of variance var(mean) / 2. The difference
  of Caustic's and Cycles' estimates has sigma = sqrt(var_caustic / 2 + var_cycles / 2).
* Bound: |mean_caustic - mean_cycles| <= 5 sigma + 1 % of mean_cycles. 5 sigma (with a 48-dof
  variance estimate) keeps false alarms below ~1e-4 per light type; the 1 % model allowance
  covers differences that are not noise and not light units: sample-pattern and filter
  differences at the image border, float32 accumulation, and Cycles' spot light smoothstep
  evaluated on a hard cone edge. A wrong light unit (a missing pi, 4 pi or 683) is off by
  far more than that.
The Caustic/Cycles ratios are printed (run pytest with -s) for the issue's closing note.

Measured on bpy 5.0.1: with the first renderer build 1.010-1.013 for all six lights (the
renderer ignored KHR_materials_specular, and the test material has Specular IOR Level 0, i.e.
specularFactor 0); since the renderer reads specularFactor: point 1.0023, spot 0.9998, sun
0.9995, rectangle 1.0021, disk 1.0019, emissive mesh 1.0022, sigma ~1e-4 of the mean. The
remaining ~0.2 % is systematic (it does not shrink with samples) and is well inside the 1 %
allowance.
"""

import math

import bpy
import numpy as np
import pytest

import scenes

pytestmark = pytest.mark.needs_binary

W, H = 64, 48
SAMPLES = 128
BOUNCES = 3
SEEDS = (1, 2)
BLOCK = 8
SIGMAS = 5.0
MODEL_ALLOWANCE = 0.01

LIGHT_HEIGHT = 3.5


def add_point(scene):
    scenes.light(scene, "Point", "POINT", location=(0.4, -0.3, LIGHT_HEIGHT), energy=400.0,
                 shadow_soft_size=0.0)


def add_spot(scene):
    scenes.light(scene, "Spot", "SPOT", location=(0.2, 0.1, LIGHT_HEIGHT), energy=800.0,
                 spot_size=math.radians(50.0), spot_blend=0.0, shadow_soft_size=0.0)


def add_sun(scene):
    scenes.light(scene, "Sun", "SUN", rotation_deg=(25.0, 10.0, 0.0), energy=2.0, angle=0.0)


def add_rectangle(scene):
    scenes.light(scene, "Rect", "AREA", location=(0.3, -0.2, LIGHT_HEIGHT), rotation_deg=(10, 0, 0),
                 shape="RECTANGLE", size=1.5, size_y=0.75, energy=300.0)


def add_disk(scene):
    scenes.light(scene, "Disk", "AREA", location=(-0.2, 0.3, LIGHT_HEIGHT), shape="DISK",
                 size=1.2, energy=300.0)


def add_emitter(scene):
    # Faces down (-Z): vertices ordered clockwise seen from above.
    h = 0.5
    z = LIGHT_HEIGHT
    scenes.mesh_object(scene, "Emitter", [(-h, -h, z), (-h, h, z), (h, h, z), (h, -h, z)],
                       [(0, 1, 2, 3)], scenes.emission_material("Glow", (1.0, 0.9, 0.8), 60.0))


def add_point_radius(scene):
    scenes.light(scene, "PointR", "POINT", location=(0.4, -0.3, LIGHT_HEIGHT), energy=400.0,
                 shadow_soft_size=0.4)


def add_point_radius_hard(scene):
    scenes.light(scene, "PointS", "POINT", location=(0.4, -0.3, LIGHT_HEIGHT), energy=400.0,
                 shadow_soft_size=0.4, use_soft_falloff=False)


def add_spot_blend(scene):
    scenes.light(scene, "SpotB", "SPOT", location=(0.2, 0.1, LIGHT_HEIGHT), energy=800.0,
                 spot_size=math.radians(60.0), spot_blend=0.4, shadow_soft_size=0.0)


def add_rectangle_spread(scene):
    # Tilted so that the spread's falloff and its cut-off both cross the floor in view.
    scenes.light(scene, "RectS", "AREA", location=(0.3, -0.2, LIGHT_HEIGHT), rotation_deg=(20, 0, 0),
                 shape="RECTANGLE", size=1.5, size_y=0.75, energy=300.0, spread=math.radians(60.0))


def add_disk_spread(scene):
    scenes.light(scene, "DiskS", "AREA", location=(-0.2, 0.3, LIGHT_HEIGHT), rotation_deg=(0, -15, 0),
                 shape="DISK", size=1.2, energy=300.0, spread=math.radians(30.0))


def add_sun_angle(scene):
    scenes.light(scene, "SunA", "SUN", rotation_deg=(25.0, 10.0, 0.0), energy=2.0, angle=math.radians(12.0))


def add_point_no_shadow(scene):
    """A point light with Cast Shadow off: the cube's shadow on the floor disappears."""
    add_point(scene)
    scene.objects["Point"].data.use_shadow = False


def add_spot_stretched(scene):
    """A narrow spot whose object is scaled (2, 1, 1.2): Cycles stretches the cone by the
    scale (wider along X, narrower for the longer Z), an ellipse on the floor. Before: the
    renderer drew the round cone, 0.9240 of Cycles' mean here (0.62 with scale (2, 1, 1) in a
    sweep scene, 2.59 with (1, 1, 2)). After: 0.9998."""
    light = scenes.light(scene, "SpotS", "SPOT", location=(0.2, 0.1, LIGHT_HEIGHT), rotation_deg=(0, 0, 25),
                         energy=800.0, spot_size=math.radians(30.0), spot_blend=0.2, shadow_soft_size=0.0)
    light.scale = (2.0, 1.0, 1.2)


def add_rectangle_no_shadow(scene):
    add_rectangle(scene)
    scene.objects["Rect"].data.use_shadow = False


LIGHTS = {
    "point_no_shadow": add_point_no_shadow,
    "area_rectangle_no_shadow": add_rectangle_no_shadow,
    "point": add_point,
    "point_radius": add_point_radius,
    "point_radius_hard": add_point_radius_hard,
    "spot_blend": add_spot_blend,
    "spot_stretched": add_spot_stretched,
    "sun_angle": add_sun_angle,
    "spot": add_spot,
    "sun": add_sun,
    "area_rectangle": add_rectangle,
    "area_disk": add_disk,
    "area_rectangle_spread": add_rectangle_spread,
    "area_disk_spread": add_disk_spread,
    "emissive_mesh": add_emitter,
}


def build(scene, add_light):
    scenes.small_render_settings(scene, W, H, samples=SAMPLES)
    scenes.plane(scene, "Floor", 10.0, material=scenes.diffuse_material("Grey", 0.5))
    scenes.cube(scene, "Box", 1.0, (0.3, -0.2, 0.5), material=scenes.diffuse_material("Light", 0.8))
    scenes.camera(scene, (0.0, 0.0, 2.8), (0.0, 0.0, 0.0), lens=24.0)
    add_light(scene)
    scene.caustic.threads = 0
    scenes.match_cycles(scene, SAMPLES, BOUNCES)


def render(scene, engine, seed, path):
    """The rendered image's channel mean (height, width)."""
    return scenes.render_rgb(scene, engine, seed, path).mean(axis=2)


def mean_and_variance(a, b):
    """The two-seed estimate of the image mean and its variance (block method, see above)."""
    diff = a - b
    h, w = diff.shape
    blocks = diff[: h - h % BLOCK, : w - w % BLOCK].reshape(h // BLOCK, BLOCK, w // BLOCK, BLOCK)
    block_sums = blocks.sum(axis=(1, 3))
    var_single = (block_sums ** 2).sum() / (2.0 * (h * w) ** 2)
    return 0.5 * (a.mean() + b.mean()), var_single / 2.0


def assert_mean_matches_cycles(scene, tmp_path, label, allowance, per_channel=False):
    """Renders `scene` with both engines and both seeds; asserts the image means agree within
    SIGMAS sigma + `allowance` (a fraction of Cycles' mean), as derived in the module doc.
    With `per_channel` the red, green and blue means are checked one by one (same bound, per
    channel), else the mean over the channels. Returns {plane: Caustic/Cycles ratio}."""
    images = {engine: [scenes.render_rgb(scene, engine, s, str(tmp_path / f"{engine}_{s}.exr")) for s in SEEDS]
              for engine in ("CYCLES", "CAUSTIC")}
    planes = {"R": 0, "G": 1, "B": 2} if per_channel else {"": None}
    ratios, failures = {}, []
    for plane, channel in planes.items():
        results = {}
        for engine, (a, b) in images.items():
            a, b = (a.mean(axis=2), b.mean(axis=2)) if channel is None else (a[..., channel], b[..., channel])
            results[engine] = mean_and_variance(a, b)
        (m_caustic, v_caustic), (m_cycles, v_cycles) = results["CAUSTIC"], results["CYCLES"]
        sigma = math.sqrt(v_caustic + v_cycles)
        bound = SIGMAS * sigma + allowance * m_cycles
        ratio = ratios[plane] = m_caustic / m_cycles
        name = f"{label} {plane}".strip()
        print(f"\n[caustic/cycles] {name:15s} ratio {ratio:.4f}  caustic {m_caustic:.5f}  "
              f"cycles {m_cycles:.5f}  sigma {sigma:.2e}  bound {bound:.2e}")
        assert m_cycles > 1e-3, f"{name}: the Cycles reference is black: the scene is broken"
        if abs(m_caustic - m_cycles) > bound:
            failures.append(f"{name}: Caustic/Cycles = {ratio:.4f}, difference {m_caustic - m_cycles:.3e} "
                            f"exceeds {SIGMAS} sigma ({sigma:.2e}) + {allowance:.1%} model allowance")
    assert not failures, "; ".join(failures)
    return ratios


@pytest.mark.parametrize("light", list(LIGHTS))
def test_mean_radiance_matches_cycles(empty_scene, tmp_path, light):
    scene = empty_scene
    build(scene, LIGHTS[light])
    assert_mean_matches_cycles(scene, tmp_path, light, MODEL_ALLOWANCE)
