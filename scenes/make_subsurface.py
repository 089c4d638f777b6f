"""Writes scenes/subsurface.gltf (+ subsurface.bin): the media test scene.

A smooth blob of marble-like random-walk subsurface material (CAUSTIC_materials_subsurface)
beside a glass sphere filled with coloured smoke (a nested medium without a surface,
CAUSTIC_materials_medium), on a white floor, lit by a rectangular area light
(CAUSTIC_lights_area) and a dim world. Exercises free-flight sampling in a chromatic medium,
NEE from inside media through a volume boundary, nested media (smoke inside glass) and the
subsurface random walk.

Standard library only; deterministic output. Run: python3 scenes/make_subsurface.py
"""

import math

from make_glass_caustic import Builder, quad, sphere


def blob(radius, segments=64, rings=32):
    """A closed smooth blob: a sphere displaced by low-frequency lobes, with normals from
    the analytic gradient of its radius function (counter-clockwise from outside)."""
    def r_of(theta, phi):
        return radius * (1.0 + 0.12 * math.sin(3 * theta) * math.cos(2 * phi) + 0.08 * math.cos(2 * theta))

    def point(theta, phi):
        r = r_of(theta, phi)
        return (r * math.sin(theta) * math.cos(phi), r * math.cos(theta), -r * math.sin(theta) * math.sin(phi))

    positions, normals, indices = [], [], []
    eps = 1e-4
    for i in range(rings + 1):
        theta = math.pi * i / rings
        for j in range(segments + 1):
            phi = 2 * math.pi * j / segments
            p = point(theta, phi)
            positions.append(p)
            # Normal from the cross product of the surface's partial derivatives; at the
            # poles (where ∂/∂φ vanishes) it is the axis.
            t0 = min(max(theta, eps), math.pi - eps)
            a = [u - v for u, v in zip(point(t0 + eps, phi), point(t0 - eps, phi))]
            b = [u - v for u, v in zip(point(t0, phi + eps), point(t0, phi - eps))]
            n = (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
            length = math.sqrt(sum(c * c for c in n))
            n = tuple(c / length for c in n)
            # Point outward.
            if sum(c * d for c, d in zip(n, p)) < 0:
                n = tuple(-c for c in n)
            normals.append(n)
    for i in range(rings):
        for j in range(segments):
            a = i * (segments + 1) + j
            b = a + segments + 1
            if i != 0:
                indices += [a, b, a + 1]
            if i != rings - 1:
                indices += [a + 1, b, b + 1]
    return positions, normals, indices


def main():
    g = Builder()
    g.doc["asset"]["generator"] = "caustic scenes/make_subsurface.py"
    g.doc["extensionsUsed"] = [
        "KHR_materials_transmission",
        "KHR_materials_volume",
        "CAUSTIC_materials_medium",
        "CAUSTIC_materials_subsurface",
        "CAUSTIC_lights_area",
        "CAUSTIC_world",
    ]
    g.doc["scenes"][0]["name"] = "subsurface"
    g.doc["scenes"][0]["extras"] = {"caustic": {"resolution": [320, 240], "spp": 64, "transparent": False}}
    g.doc["scenes"][0]["extensions"] = {"CAUSTIC_world": {"color": [0.15, 0.17, 0.2]}}

    white = g.material({"name": "floor", "pbrMetallicRoughness": {
        "baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "doubleSided": True})
    # Marble: a nearly white multiple-scattering albedo, mean free paths of a few
    # centimetres (radius / 4π), slightly longer in red.
    marble = g.material({"name": "marble", "pbrMetallicRoughness": {
        "baseColorFactor": [0.9, 0.88, 0.82, 1], "metallicFactor": 0.0, "roughnessFactor": 0.3},
        "extensions": {"CAUSTIC_materials_subsurface": {
            "weight": 1.0, "radius": [0.5, 0.35, 0.25], "anisotropy": 0.0, "ior": 1.4, "method": "random_walk"}}})
    glass = g.material({"name": "glass", "pbrMetallicRoughness": {
        "baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                       "KHR_materials_volume": {"thicknessFactor": 1.0}}})
    # Orange smoke: scatters red and green more than blue, absorbs blue; forward scattering.
    smoke = g.material({"name": "smoke", "pbrMetallicRoughness": {
        "baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
        "extensions": {"CAUSTIC_materials_medium": {
            "density": 8.0, "scatter_color": [0.9, 0.5, 0.15], "absorption_color": [0.05, 0.2, 0.6],
            "anisotropy": 0.3, "surface": False}}})

    g.mesh("floor", *quad([(-3, 0, 3), (3, 0, 3), (3, 0, -3), (-3, 0, -3)], (0, 1, 0)), white)
    g.mesh("marble_blob", *blob(0.32), marble, translation=(-0.45, 0.36, 0.0))
    g.mesh("glass_sphere", *sphere(0.33), glass, translation=(0.45, 0.33, 0.0))
    # The smoke fills the glass but for a thin wall (its own closed mesh inside).
    g.mesh("smoke", *sphere(0.31), smoke, translation=(0.45, 0.33, 0.0))

    # A 0.8 x 0.5 m area light 1.8 m up, facing down (its local -Z), Blender's 60 W.
    s = math.sqrt(0.5)
    g.node({"name": "area_light", "translation": [0.0, 1.8, 0.6], "rotation": [-s, 0.0, 0.0, s],
            "extensions": {"CAUSTIC_lights_area": {
                "shape": "rectangle", "size": [0.8, 0.5], "power": 60.0, "color": [1.0, 0.95, 0.9]}}})

    g.doc["cameras"].append({"name": "camera", "type": "perspective", "perspective": {
        "yfov": math.radians(36.0), "aspectRatio": 320 / 240, "znear": 0.01}})
    eye, target = (0.0, 0.9, 2.6), (0.0, 0.3, 0.0)
    d = [t - e for t, e in zip(target, eye)]
    pitch = math.atan2(d[1], -d[2])
    q = [math.sin(pitch / 2), 0.0, 0.0, math.cos(pitch / 2)]
    g.node({"name": "camera", "camera": 0, "translation": list(eye), "rotation": q})
    g.write("subsurface")


if __name__ == "__main__":
    main()
