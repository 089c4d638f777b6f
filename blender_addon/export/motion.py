"""Motion blur and the Vector pass's motion: `CAUSTIC_motion` (docs/contract.md).

With Render → Motion Blur on, the scene is evaluated at the motion steps over the shutter, as
Cycles samples it (`intern/cycles/blender/sync.cpp`): an object with Motion Steps s has 2^s + 1
steps spread evenly over the shutter (the most any object asks for is used for all), the
shutter lasting Shutter frames and centred on, starting at or ending at the frame (Position).
With motion blur off and the Vector pass enabled, the steps are the previous frame, the frame
and the next (Cycles' motion pass). Objects whose Motion Blur is off stay still.

Each moving object's node gets its world matrices at the steps and at the frame, in glTF axes;
the scene gets the step times and the shutter. Deformation motion (vertices moving within the
object: shape keys, armatures, lattices, any modifier; Cycles' Deformation Motion) goes out as
the evaluated mesh's vertex positions at the frame (`reference`) and at each step
(`positions`), object space in glTF axes, in a binary buffer beside the glTF
(`add_deformation`); the binary finds each exported vertex's Blender vertex by its position at
the frame, which the exporter wrote from the same evaluated mesh. An object whose vertex count
changes between steps blurs by its transform only (a warning names it). The shutter curve is
taken as flat (a warning says when it is not).
"""

import json
import math
import os

import numpy as np

MOTION_EXTENSION = "CAUSTIC_motion"

# Blender's axes (Z up) to glTF's (Y up), as the exporter converts with export_yup:
# (x, y, z) -> (x, z, -y).
_TO_GLTF = ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, -1.0, 0.0))


class Motion:
    """The step times, the shutter and each moving object's matrices (by object name)."""

    def __init__(self, times, shutter):
        self.times = times
        self.shutter = shutter
        self.matrices = {}  # object name -> (matrix at the frame, [matrix per step]), glTF axes
        # object name -> (matrix at the frame, vertex positions at the frame, [positions per step]):
        # (n, 3) float32 arrays, object space in glTF axes.
        self.deformation = {}
        self.warnings = []

    def scene_extension(self):
        """The scene's `CAUSTIC_motion`."""
        value = {"times": list(self.times)}
        if self.shutter is not None:
            value["shutter"] = self.shutter
        return value

    def node_extension(self, name):
        """The node's `CAUSTIC_motion`, or None when the object does not move."""
        if name in self.matrices:
            frame, steps = self.matrices[name]
            return {"matrix": frame, "matrices": steps}
        if name in self.deformation:
            # Deformation alone: the transform stays; `add_deformation` adds the positions.
            frame = self.deformation[name][0]
            return {"matrix": frame, "matrices": [frame] * len(self.times)}
        return None


def gltf_matrix(m):
    """Blender's 4x4 world matrix in glTF axes (C M C^-1), column-major as glTF stores it."""
    c = _TO_GLTF
    rows = [[sum(c[i][k] * m[k][j] for k in range(3)) for j in range(4)] for i in range(3)]
    # Right-multiply by C^-1 = C^T on the 3x3 part; the translation column is only rotated.
    out = [[sum(rows[i][k] * c[j][k] for k in range(3)) for j in range(3)] + [rows[i][3]] for i in range(3)]
    out.append([0.0, 0.0, 0.0, 1.0])
    return [float(out[r][col]) for col in range(4) for r in range(4)]


def _motion_steps(obj):
    """Cycles' step count of an object: 2^(s - 1) * 2 + 1 for its Motion Steps s."""
    steps = max(1, int(getattr(obj.cycles, "motion_steps", 1)))
    return (2 << (steps - 1)) + 1


def _blurs(obj):
    return bool(getattr(obj.cycles, "use_motion_blur", True))


def step_times(scene, view_layer, objects):
    """(times in frames relative to the frame, shutter dict or None), or None without motion."""
    render = scene.render
    if render.use_motion_blur:
        length = float(render.motion_blur_shutter)
        if length <= 0.0:
            return None
        n = max([_motion_steps(o) for o in objects if _blurs(o)] or [3])
        start = {"CENTER": -0.5 * length, "START": 0.0, "END": -length}[render.motion_blur_position]
        times = [start + length * i / (n - 1) for i in range(n)]
        shutter = {"open": start, "close": start + length}
        cycles = getattr(scene, "cycles", None)
        if cycles is not None and cycles.rolling_shutter_type == "TOP":
            shutter["rolling_duration"] = float(cycles.rolling_shutter_duration)
        return times, shutter
    if getattr(view_layer, "use_pass_vector", False):
        return [-1.0, 0.0, 1.0], None
    return None


def _vertex_positions(obj, depsgraph):
    """An evaluated mesh's vertex positions, object space, in glTF axes ((n, 3) float32): the
    exporter's (x, y, z) -> (x, z, -y), exact in float32, so they equal what it writes."""
    mesh = obj.evaluated_get(depsgraph).data
    co = np.empty(3 * len(mesh.vertices), dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    return np.stack([co[:, 0], co[:, 2], -co[:, 1]], axis=1)


def sample_motion(scene, view_layer):
    """Evaluate the scene at the motion steps and return a Motion, or None when nothing asks.

    The frame is set to each step time and back to the frame (and subframe) it was at.
    """
    import bpy
    objects = [o for o in scene.objects if o.type in ("MESH", "CAMERA", "LIGHT", "EMPTY", "CURVE", "FONT",
                                                       "SURFACE", "META")]
    timing = step_times(scene, view_layer, objects)
    if timing is None:
        return None
    times, shutter = timing
    motion = Motion(times, shutter)
    curve = scene.render.motion_blur_shutter_curve
    if shutter is not None and any(abs(p.location[1] - 1.0) > 1e-6 for p in curve.curves[0].points):
        motion.warnings.append("motion blur: the shutter curve is not flat; Caustic opens the shutter fully "
                               "for its whole length")
    frame, subframe = scene.frame_current, scene.frame_subframe
    moving = [o for o in objects if _blurs(o)]
    deforming = [o for o in moving if o.type == "MESH" and getattr(o.cycles, "use_deform_motion", True)
                 and (len(o.modifiers) > 0 or o.data.shape_keys is not None)]
    per_step = {o.name: [] for o in moving}
    positions = {o.name: [] for o in deforming}
    try:
        for t in times:
            whole = math.floor(frame + subframe + t)
            scene.frame_set(int(whole), subframe=float(frame + subframe + t - whole))
            depsgraph = bpy.context.evaluated_depsgraph_get()
            for o in moving:
                per_step[o.name].append(gltf_matrix(o.matrix_world))
            for o in deforming:
                positions[o.name].append(_vertex_positions(o, depsgraph))
    finally:
        scene.frame_set(frame, subframe=subframe)
    for o in moving:
        steps = per_step[o.name]
        reference = gltf_matrix(o.matrix_world)
        if any(any(abs(a - b) > 1e-7 * max(1.0, abs(b)) for a, b in zip(m, reference)) for m in steps):
            motion.matrices[o.name] = (reference, steps)
    if deforming:
        depsgraph = bpy.context.evaluated_depsgraph_get()
        for o in deforming:
            steps = positions[o.name]
            reference = _vertex_positions(o, depsgraph)
            if any(p.shape != reference.shape for p in steps):
                motion.warnings.append(f"object '{o.name}': its vertex count changes within the shutter; "
                                       "deformation motion blur is not rendered, it blurs by its transform only")
            elif any(not np.array_equal(p, reference) for p in steps):
                motion.deformation[o.name] = (gltf_matrix(o.matrix_world), reference, steps)
    return motion


def add_deformation(gltf_path, motion):
    """Append each deforming object's vertex positions to the written glTF file: a binary
    buffer (`scene_motion.bin`) and, on the object's node's `CAUSTIC_motion`, the accessors
    `reference` (at the frame) and `positions` (one per step). Returns the objects written."""
    if motion is None or not motion.deformation:
        return 0
    with open(gltf_path, encoding="utf-8") as f:
        doc = json.load(f)
    blob = bytearray()
    buffer_index = len(doc.setdefault("buffers", []))
    views = doc.setdefault("bufferViews", [])
    accessors = doc.setdefault("accessors", [])

    def accessor(array):
        data = np.ascontiguousarray(array, dtype=np.float32).tobytes()
        views.append({"buffer": buffer_index, "byteOffset": len(blob), "byteLength": len(data)})
        blob.extend(data)
        accessors.append({"bufferView": len(views) - 1, "componentType": 5126, "count": len(array), "type": "VEC3"})
        return len(accessors) - 1

    written = 0
    for node in doc.get("nodes", []):
        entry = motion.deformation.get(node.get("name"))
        ext = node.get("extensions", {}).get(MOTION_EXTENSION)
        if entry is None or ext is None or "mesh" not in node:
            continue
        _, reference, steps = entry
        ext["reference"] = accessor(reference)
        ext["positions"] = [accessor(p) for p in steps]
        written += 1
    if written:
        name = "scene_motion.bin"
        with open(os.path.join(os.path.dirname(gltf_path), name), "wb") as f:
            f.write(blob)
        doc["buffers"].append({"uri": name, "byteLength": len(blob)})
        with open(gltf_path, "w", encoding="utf-8") as f:
            json.dump(doc, f)
    return written
