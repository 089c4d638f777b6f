"""KHR_materials_clearcoat with normal maps: the binary on a glTF file against Cycles on
Blender's import of it (sweep 6, after the Khronos CompareClearcoat / ClearcoatWicker models).

glTF's clear coat takes its own normal map (`clearcoatNormalTexture`) and, without one, the
interpolated normal even where the base has a `normalTexture` (the extension's spec: "no normal
mapping is applied to the clear coat layer"); Blender's importer links the first to the
Principled BSDF's Coat Normal and leaves that socket unlinked otherwise, which Cycles reads as
the interpolated normal. Two defects were found here:
* `coat_over_base_normal`: the coat followed the base's normal map;
* `coat_normal_only`: a coat normal map on a material without a base normal map generated no
  tangents, so the coat kept the interpolated normal.

The file is test_gltf_import_agreement's (floor, sphere, camera, point light), the sphere with a
generated bump normal map; the coat's roughness (0.3) keeps the point light's reflections off
the coat from making fireflies on the floor. Measured (bpy 5.0.1, 48x36, 64 spp), Caustic/Cycles
R/G/B before -> after: see CASES.

Tolerance: test_gltf_import_agreement's (5 sigma of the two-seed block-variance estimate plus its
1 % model allowance), per channel.
"""

import json
import math

import numpy as np
import pytest

import test_gltf_import_agreement as agreement

pytestmark = pytest.mark.needs_binary


def _normal_map_png(n=32):
    """Sine bumps as a tangent-space normal map (8-bit PNG data URI)."""
    import base64
    from io import BytesIO
    from PIL import Image
    x = (np.arange(n) + 0.5) / n
    nx = 0.6 * np.sin(2.0 * math.pi * 3.0 * x)[None, :].repeat(n, 0)
    ny = 0.6 * np.cos(2.0 * math.pi * 2.0 * x)[:, None].repeat(n, 1)
    length = np.sqrt(nx * nx + ny * ny + 1.0)
    rgb = np.stack([0.5 + 0.5 * nx / length, 0.5 + 0.5 * ny / length, 0.5 + 0.5 / length], axis=-1)
    buf = BytesIO()
    Image.fromarray(np.round(255.0 * rgb).astype(np.uint8), "RGB").save(buf, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


BASE = {"pbrMetallicRoughness": {"baseColorFactor": [0.1, 0.4, 0.1, 1], "metallicFactor": 0.0,
                                 "roughnessFactor": 0.6}}
COAT = {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.3}

CASES = {
    # Before: R/G/B 0.9629/0.9707/0.9629 (sigma 0.2 %); after 0.9993/1.0012/0.9993.
    "coat_over_base_normal": dict(BASE, normalTexture={"index": 0},
                                  extensions={"KHR_materials_clearcoat": COAT}),
    # Before: 1.0378/1.0332/1.0378 (sigma 0.3 %); after 0.9984/1.0002/0.9984.
    "coat_normal_only": dict(BASE, extensions={"KHR_materials_clearcoat": dict(
        COAT, clearcoatNormalTexture={"index": 0})}),
}


def build(path, material):
    """test_gltf_import_agreement's file with the sphere's UVs and the normal map as texture 0."""
    agreement.build(path, material, texture=True)
    with open(path) as f:
        doc = json.load(f)
    doc["images"] = [{"uri": _normal_map_png()}]
    doc["samplers"] = [{"magFilter": 9729, "minFilter": 9729}]
    with open(path, "w") as f:
        json.dump(doc, f)


@pytest.mark.parametrize("case", list(CASES))
def test_clearcoat_normal_maps_match_cycles(addon, tmp_path, case):
    gltf_path = tmp_path / f"{case}.gltf"
    build(gltf_path, CASES[case])
    cycles = agreement.cycles_images(gltf_path, tmp_path)
    caustic, log = agreement.caustic_images(gltf_path, tmp_path)
    assert "ignored" not in log, log
    agreement.assert_channels_match(case, caustic, cycles)
