"""Volume objects (OpenVDB grids) against Cycles: a smoke-like sphere of density lit by a point
light over test_cycles_agreement's floor and cube, and a fire-like one that glows by blackbody
emission from a temperature grid. The .vdb files are made here with the openvdb module bpy
bundles. Same scene, renders and tolerance derivation as test_cycles_agreement.py: the image
means (per colour channel) agree within 5 sigma of the two renderers' noise plus its 1 % model
allowance.

Measured on bpy 5.0.1 (Caustic/Cycles per channel, printed with pytest -s): smoke R 1.0001,
G 1.0002, B 1.0002 (bound about 1.2 %); fire R 1.0017, G 1.0027, B 1.0050. Sensitivity: without
the smoke the scene's mean is 0.4701 in every channel, against the smoke's R 0.4794, G 0.4603,
B 0.4444, so a smoke that is not rendered fails all three channels (2 %, 2 %, 5.5 % > bound).
The fire was 2.3-3.5 % dark before its blackbody term was blended from the voxels' emission
(Cycles' stochastic lookup), which the bound catches.
"""

import importlib

import bpy
import numpy as np
import pytest

import scenes
from test_cycles_agreement import MODEL_ALLOWANCE, add_point, assert_mean_matches_cycles, build

pytestmark = pytest.mark.needs_binary

N = 24  # voxels per side: small files, still a smooth sphere under trilinear lookup
VOXEL = 0.05  # metres: the sphere's radius is 0.55 m


def sphere_field():
    """A (N, N, N) field falling linearly from 1 at the centre to 0 at radius N/2 - 1 voxels."""
    idx = np.indices((N, N, N)).astype(np.float32)
    r = np.sqrt(((idx - (N - 1) / 2.0) ** 2).sum(axis=0))
    return np.clip(1.0 - r / (N / 2.0 - 1.0), 0.0, 1.0).astype(np.float32)


def write_vdb(addon, path, grids):
    """Writes float grids {name: (N, N, N) array} to a .vdb with voxel size VOXEL, centred on
    the object's origin."""
    vdb = importlib.import_module(addon.__name__ + ".export.volumes")._openvdb()
    out = []
    for name, values in grids.items():
        g = vdb.FloatGrid()
        g.name = name
        g.copyFromArray(values, ijk=(-N // 2, -N // 2, -N // 2))
        g.transform = vdb.createLinearTransform(voxelSize=VOXEL)
        out.append(g)
    vdb.write(str(path), grids=out)


def volume_object(scene, name, path, material, location):
    """A Volume object reading `path`, with `material`, at `location`."""
    volume = bpy.data.volumes.new(name + "Data")
    volume.filepath = str(path)
    volume.materials.append(material)
    obj = bpy.data.objects.new(name, volume)
    obj.location = location
    scene.collection.objects.link(obj)
    return obj


def principled_volume(name, **inputs):
    """A material whose Volume output is a Principled Volume with `inputs`, no surface."""
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    for node in list(tree.nodes):
        if node.type != "OUTPUT_MATERIAL":
            tree.nodes.remove(node)
    node = tree.nodes.new("ShaderNodeVolumePrincipled")
    for key, value in inputs.items():
        node.inputs[key].default_value = value
    tree.links.new(node.outputs["Volume"], tree.nodes["Material Output"].inputs["Volume"])
    return mat


def test_smoke_volume_matches_cycles(addon, empty_scene, tmp_path):
    """Scattering smoke between the light and the floor: its shadow, its in-scattered glow and
    the light it takes from the cube, per colour channel (the smoke is tinted)."""
    path = tmp_path / "smoke.vdb"
    write_vdb(addon, path, {"density": sphere_field()})

    def add_smoke(scene):
        add_point(scene)
        mat = principled_volume("Smoke", Density=6.0, Color=(0.9, 0.75, 0.6, 1.0), Anisotropy=0.3)
        volume_object(scene, "Smoke", path, mat, (-0.4, 0.3, 1.4))

    scene = empty_scene
    build(scene, add_smoke)
    ratios = assert_mean_matches_cycles(scene, tmp_path, "smoke volume", MODEL_ALLOWANCE, per_channel=True)
    print(f"\n[caustic/cycles] smoke volume {ratios}")


def test_fire_volume_matches_cycles(addon, empty_scene, tmp_path):
    """A fire-like volume without lights: blackbody emission from the temperature grid (up to
    5000 K at the centre) through thin absorbing smoke lights the floor and is seen directly."""
    path = tmp_path / "fire.vdb"
    field = sphere_field()
    write_vdb(addon, path, {"density": 0.5 * field, "temperature": field})

    def add_fire(scene):
        mat = principled_volume("Fire", Density=2.0, Color=(0.2, 0.2, 0.2, 1.0), **{
            "Blackbody Intensity": 1.0, "Temperature": 5000.0, "Blackbody Tint": (1.0, 0.9, 0.8, 1.0)})
        volume_object(scene, "Fire", path, mat, (0.0, 0.2, 1.0))

    scene = empty_scene
    build(scene, add_fire)
    ratios = assert_mean_matches_cycles(scene, tmp_path, "fire volume", MODEL_ALLOWANCE, per_channel=True)
    print(f"\n[caustic/cycles] fire volume {ratios}")


def test_volume_export_writes_the_grid_file(addon, empty_scene, tmp_path):
    """The export: the grid file holds the density over the active voxels, in x-fastest order,
    and `CAUSTIC_volume` names it with the object's placement (glTF axes) and its shader."""
    import json
    import struct
    path = tmp_path / "smoke.vdb"
    field = sphere_field()
    write_vdb(addon, path, {"density": field})
    scene = empty_scene
    mat = principled_volume("Smoke", Density=3.0, Anisotropy=0.2)
    volume_object(scene, "Smoke", path, mat, (1.0, 2.0, 3.0))
    volumes = importlib.import_module(addon.__name__ + ".export.volumes")
    folder = tmp_path / "out"
    folder.mkdir()
    value, warnings = volumes.volume_extension(bpy.context.evaluated_depsgraph_get(), str(folder))
    assert warnings == []
    (v,) = value["volumes"]
    assert v["density_grid"] == "density" and v["temperature_grid"] is None
    assert v["shader"]["density"] == pytest.approx(3.0) and v["shader"]["anisotropy"] == pytest.approx(0.2)
    # Blender (1, 2, 3) is glTF (1, 3, -2): the matrix's translation column.
    assert v["matrix"][12:15] == pytest.approx([1.0, 3.0, -2.0])
    data = (folder / v["uri"]).read_bytes()
    assert data[:8] == b"CAUSTICV"
    version, nx, ny, nz = struct.unpack_from("<4I", data, 8)
    m = struct.unpack_from("<12f", data, 24)
    # The active voxels: the sphere's, inside the N^3 block (its corners are zero, inactive).
    active = np.argwhere(field != 0.0)
    lo, hi = active.min(axis=0), active.max(axis=0)
    assert (version, nx, ny, nz) == (1, *(hi - lo + 1))
    assert m[0] == pytest.approx(VOXEL) and m[3] == pytest.approx((lo[0] - N // 2) * VOXEL)
    (count,) = struct.unpack_from("<I", data, 72)
    (length,) = struct.unpack_from("<I", data, 76)
    assert count == 1 and data[80:80 + length] == b"density"
    voxels = np.frombuffer(data, "<f4", offset=80 + length + 4).reshape(nz, ny, nx)
    expected = field[lo[0]:hi[0] + 1, lo[1]:hi[1] + 1, lo[2]:hi[2] + 1].transpose(2, 1, 0)
    np.testing.assert_array_equal(voxels, expected)
    assert json.dumps(value)  # plain JSON


def test_blackbody_in_a_mesh_volume_matches_cycles(empty_scene, tmp_path):
    """A Principled Volume with blackbody emission inside a mesh (no temperature grid: the
    Temperature alone, 2500 K) glowing through its own absorption onto the floor, no light;
    exported as `CAUSTIC_materials_medium`'s blackbody keys."""
    def add_glow(scene):
        mat = principled_volume("Glow", Density=1.5, Color=(0.1, 0.1, 0.1, 1.0), **{
            "Blackbody Intensity": 1.0, "Temperature": 2500.0, "Blackbody Tint": (0.9, 1.0, 1.0, 1.0)})
        scenes.cube(scene, "GlowBox", 0.8, (-0.3, 0.2, 1.2), material=mat)

    scene = empty_scene
    build(scene, add_glow)
    ratios = assert_mean_matches_cycles(scene, tmp_path, "mesh blackbody", MODEL_ALLOWANCE, per_channel=True)
    print(f"\n[caustic/cycles] mesh blackbody {ratios}")
