"""Object > Shading > Shadow Terminator > Geometry Offset (Blender's default 0.1 on every
object) rendered as Cycles renders it: next-event estimation's shadow rays from a smooth-shaded
triangle near its terminator leave from the smooth patch through its corners and normals
(`scene/terminator.rs`, Cycles' `shadow_ray_offset`), and a light below the flat triangle but
above the shading normal's horizon is traced from there instead of being taken as behind the
surface. Without it a coarse smooth sphere's terminator is a band of dark facets in Caustic that
Cycles does not show.

A UV sphere of 8 or 16 segments, smooth-shaded, under a low sun, compared with
test_nodes_agreement's `compare` (per-channel means within 5 sigma + 1 %, and every 4x4 block of
the downsampled luminance within 5 sigma + 2 %, derived there). Before (main's binary, the
offset not exported): 8 segments 0.9951 of Cycles' mean with 4 of 432 blocks off, the worst
8.6x its bound (Caustic 0.0146, Cycles 0.0593 at the terminator); 16 segments 0.9960, 4 blocks,
9.6x. After: 0.9998 and 0.9997, no block off (the worst 0.54x and 0.36x). With the offset at 0
both renderers agreed before and after (1.0000, 0.9996).

The Shading Offset (0.5 and 1 on the 16-segment sphere): not rendered before, 1.3655 and 1.7286 of
Cycles' mean with 159 and 194 of 432 blocks off; after (`shift_cos_in`), 0.9997 and 0.9996, none.
"""

import bpy
import pytest

import scenes
from test_nodes_agreement import compare

pytestmark = pytest.mark.needs_binary


@pytest.mark.parametrize("segments,offset,shading", [(8, 0.1, 0.0), (16, 0.1, 0.0), (8, 0.0, 0.0),
                                                     (16, 0.1, 0.5), (16, 0.1, 1.0)])
def test_shadow_terminator_matches_cycles(empty_scene, tmp_path, segments, offset, shading):
    scene = empty_scene
    scenes.small_render_settings(scene, 96, 72, samples=64)
    scenes.plane(scene, "Floor", 10.0, material=scenes.diffuse_material("Grey", 0.5))
    bpy.ops.mesh.primitive_uv_sphere_add(segments=segments, ring_count=segments // 2, radius=0.8,
                                         location=(0.0, 0.0, 0.8))
    sphere = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    sphere.data.materials.append(scenes.diffuse_material("Sphere", 0.8))
    sphere.shadow_terminator_geometry_offset = offset
    sphere.shadow_terminator_shading_offset = shading
    scenes.camera(scene, (0.0, -3.5, 1.2), (80.0, 0.0, 0.0), lens=35.0)
    scenes.light(scene, "Sun", "SUN", rotation_deg=(0.0, 75.0, 0.0), energy=3.0, angle=0.0)
    scene.caustic.threads = 0
    scenes.match_cycles(scene, 64, 3)
    compare(scene, tmp_path, f"shadow terminator {segments} segments, offset {offset}, shading {shading}")
