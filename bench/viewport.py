"""Viewport benchmark: the time from each edit kind to the first updated frame of `caustic serve`.

Usage:
    cargo build --release
    python3 bench/viewport.py [SCENE] [--resolution 960x540] [--repeats 5] [--threads N]
                              [--integrator path]

Drives the server through the add-on's own client (blender_addon/server_client.py, no Blender
needed): loads the scene (default: the bundled Cornell box), starts rendering at the given
resolution and, for each edit kind (camera move, material edit, object transform, world),
sends the edit and waits for the first frame of the new generation, which is the reduced
(1/4 per side) frame. Prints the median and the worst of the repeats per kind, in ms, and the
time to the first full-resolution frame. The times include the pipe round trip and the
decoding of the frame by the client, as the viewport sees them.
"""
import argparse
import math
import os
import statistics
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "blender_addon"))

from server_client import ServerClient  # noqa: E402  (the add-on folder is not a package here)


def camera(angle, resolution):
    """A camera on a circle around the Cornell box's centre (glTF axes, looking at it)."""
    x, z = 3.9 * math.sin(angle), 3.9 * math.cos(angle)
    c, s = math.cos(angle), math.sin(angle)
    # Rotation about +Y by `angle`: the camera's -Z looks at the origin's height 1.
    m = [c, 0, -s, 0, 0, 1, 0, 0, s, 0, c, 0, x, 1, z, 1]
    return {"type": "camera", "matrix": m, "projection": "perspective", "yfov": 0.69,
            "resolution": list(resolution)}


def edits(resolution):
    """One request per edit kind, varying with the repeat index."""
    return {
        "camera": lambda i: camera(0.05 * (i + 1), resolution),
        "material": lambda i: {"type": "material", "name": "white",
                               "base_color": [0.5 + 0.05 * i, 0.5, 0.5, 1.0]},
        "transform": lambda i: {"type": "transform", "name": "tall_block",
                                "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0.02 * i, 0, 0, 1]},
        "world": lambda i: {"type": "world", "color": [0.01 * i, 0.01 * i, 0.01 * i]},
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", nargs="?", default=os.path.join(ROOT, "scenes", "cornell_box.gltf"))
    ap.add_argument("--resolution", default="960x540")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--threads", type=int)
    ap.add_argument("--integrator", default="path")
    ap.add_argument("--binary", default=os.environ.get("CAUSTIC_BINARY",
                                                       os.path.join(ROOT, "target", "release", "caustic")))
    a = ap.parse_args()
    resolution = tuple(int(v) for v in a.resolution.split("x"))
    client = ServerClient(a.binary, threads=a.threads)
    try:
        client.request({"type": "settings", "integrator": a.integrator, "frame_format": "f16"})
        t = time.perf_counter()
        loaded = client.request({"type": "load", "path": os.path.abspath(a.scene)})
        print(f"load: {1000 * (time.perf_counter() - t):.0f} ms ({loaded['triangles']} triangles, "
              f"BVH {1000 * loaded['bvh_seconds']:.1f} ms)")
        client.request(camera(0.0, resolution))
        gen = client.request({"type": "render_start"})["generation"]
        t = time.perf_counter()
        client.wait_frame(gen)
        print(f"render_start → first frame: {1000 * (time.perf_counter() - t):.1f} ms")
        full = []
        for kind, make in edits(resolution).items():
            times = []
            for i in range(a.repeats):
                t = time.perf_counter()
                gen = client.request(make(i))["generation"]
                header, _ = client.wait_frame(gen)
                times.append(1000 * (time.perf_counter() - t))
                # The first full-resolution pass after the reduced frame.
                while True:
                    header, _ = client.wait_frame(gen)
                    if not header["reduced"]:
                        break
                    time.sleep(0.001)
                full.append(1000 * (time.perf_counter() - t))
            print(f"{kind:9s} → first frame: median {statistics.median(times):6.1f} ms, "
                  f"worst {max(times):6.1f} ms  ({a.repeats} repeats, {resolution[0]}x{resolution[1]})")
        print(f"edit → first full-resolution frame: median {statistics.median(full):.1f} ms")
    finally:
        client.stop()


if __name__ == "__main__":
    main()
