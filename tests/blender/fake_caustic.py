"""A stand-in for the `caustic` binary that follows docs/contract.md, for the add-on's own tests.

It reads the glTF (so a broken export fails), writes an EXR whose pixels encode their full-frame
position (R = (x+0.5)/W, G = (y+0.5)/H with y from the top), and talks JSON on stderr. This pins
the add-on's half of the contract (crop placement, interim images, cancel, errors) exactly,
independent of the renderer's progress. Behaviour switches through FAKE_CAUSTIC_MODE:
"ok" (default), "slow" (renders until SIGTERM), "error" (a scene error, exit 3),
"crash" (dies with a message that is not JSON), "segfault" (killed by SIGSEGV mid-render),
"garbage" (binary junk and malformed or ill-typed JSON on stdout and stderr, then a normal
render), "no-image" (claims success but writes nothing), "wrong-size" (writes an image of
the wrong size), "ignore-term" (renders until SIGKILL, ignoring SIGTERM). With FAKE_CAUSTIC_SCENE_DIR set, each glTF it
is given is copied there as scene_000.gltf, scene_001.gltf, ... for the export tests.
"""

import argparse
import json
import os
import shutil
import signal
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from exr_io import write_exr  # noqa: E402


def emit(**obj):
    sys.stderr.write(json.dumps(obj) + "\n")
    sys.stderr.flush()


def junk():
    """What a broken or foreign binary might print: raw bytes, cut JSON, JSON of the wrong shape."""
    for stream in (sys.stdout.buffer, sys.stderr.buffer):
        stream.write(b"\x00\xff\xfe garbage \x1b[31m\x80\x81\n")
        stream.write(b'{"type": "progress", "fraction": 0.5\n')
        stream.write(b"[1, 2, 3]\n")
        stream.write(b"{\"no_type\": 1}\n")
        stream.write(b"\xff" * 5000 + b"\n")
        stream.flush()
    for obj in ({"type": "progress", "fraction": "half", "samples_done": "many", "samples_total": [],
                 "elapsed": "soon", "eta": {}, "rays_per_sec": "fast"},
                {"type": "progress", "fraction": float("nan"), "elapsed": float("inf")},
                {"type": "phase"}, {"type": 5}, {"type": "warning", "message": ["not", "text"]},
                {"type": "image", "path": 123, "final": "no"},
                {"type": "image", "path": "/etc/passwd", "final": False},
                {"type": "summary", "spp": "x", "elapsed": None, "nan_samples": "y"}):
        sys.stderr.write(json.dumps(obj) + "\n")
    sys.stderr.flush()


def image(width, height, crop, value_scale):
    x0, y0, x1, y1 = crop
    ys, xs = np.mgrid[y0:y1, x0:x1].astype(np.float32)
    shape = (y1 - y0, x1 - x0)
    ch = {
        "Combined.R": (xs + 0.5) / width * value_scale,
        "Combined.G": (ys + 0.5) / height * value_scale,
        "Combined.B": np.full(shape, 0.25, np.float32),
        "Combined.A": np.ones(shape, np.float32),
        "Depth.Z": np.full(shape, 3.0, np.float32),
        "Normal.X": np.zeros(shape, np.float32),
        "Normal.Y": np.ones(shape, np.float32),
        "Normal.Z": np.zeros(shape, np.float32),
        "Denoising Albedo.R": np.full(shape, 0.5, np.float32),
        "Denoising Albedo.G": np.full(shape, 0.5, np.float32),
        "Denoising Albedo.B": np.full(shape, 0.5, np.float32),
        "Denoising Normal.X": np.zeros(shape, np.float32),
        "Denoising Normal.Y": np.ones(shape, np.float32),
        "Denoising Normal.Z": np.zeros(shape, np.float32),
    }
    return ch


def write_atomic(path, channels):
    tmp = path + ".tmp.exr"
    write_exr(tmp, channels)
    os.replace(tmp, path)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("command")
    parser.add_argument("scene")
    parser.add_argument("-o", dest="out", required=True)
    parser.add_argument("--progress")
    parser.add_argument("--interim", type=float)
    parser.add_argument("--crop")
    parser.add_argument("--resolution")
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--time-limit", type=float)
    parser.add_argument("--max-depth", type=int)
    parser.add_argument("--seed", type=int)
    parser.add_argument("--threads", type=int)
    parser.add_argument("--camera")
    parser.add_argument("--integrator")
    parser.add_argument("--passes")
    parser.add_argument("--cryptomatte-levels", type=int)
    args = parser.parse_args()
    mode = os.environ.get("FAKE_CAUSTIC_MODE", "ok")
    if args.progress != "json":
        sys.exit(2)

    with open(os.environ.get("FAKE_CAUSTIC_ARGV_LOG", os.devnull), "w") as log:
        json.dump(sys.argv[1:], log)

    stop = {"flag": False}
    if mode == "ignore-term":
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
    else:
        signal.signal(signal.SIGTERM, lambda *_: stop.update(flag=True))
    if mode == "garbage":
        junk()

    emit(type="phase", phase="loading", elapsed=0.0)
    try:
        with open(args.scene) as f:
            gltf = json.load(f)
    except (OSError, ValueError) as err:
        emit(type="error", code=3, message=f"cannot read scene: {err}")
        sys.exit(3)
    copy_dir = os.environ.get("FAKE_CAUSTIC_SCENE_DIR")
    if copy_dir:
        os.makedirs(copy_dir, exist_ok=True)
        index = len([n for n in os.listdir(copy_dir) if n.endswith(".gltf")])
        shutil.copy(args.scene, os.path.join(copy_dir, f"scene_{index:03d}.gltf"))
    if mode == "error":
        emit(type="error", code=3, message="scene has a mesh with NaN vertices (fake)")
        sys.exit(3)
    if mode == "crash":
        sys.stderr.write("thread 'main' panicked at src/main.rs:1:1: fake panic\n")
        sys.exit(101)

    width, height = (int(v) for v in args.resolution.split("x"))
    if "resolution" in gltf["scenes"][0].get("extras", {}).get("caustic", {}):
        assert gltf["scenes"][0]["extras"]["caustic"]["resolution"] == [width, height]
    if mode == "wrong-size":
        width, height = width + 3, height + 1
    crop = tuple(int(v) for v in args.crop.split(",")) if args.crop else (0, 0, width, height)
    emit(type="phase", phase="rendering", elapsed=0.0)
    total = None if mode in ("slow", "ignore-term") else args.spp
    done = 0
    last_interim = time.monotonic()
    started = time.monotonic()
    while not stop["flag"] and (total is None or done < total):
        if time.monotonic() - started > 60:  # a cancel that never comes must fail, not hang
            emit(type="error", code=1, message="fake: no SIGTERM within 60 s")
            sys.exit(1)
        time.sleep(0.05)
        done += 1
        if mode == "segfault" and done == 3:
            os.kill(os.getpid(), signal.SIGSEGV)
        if mode == "garbage" and done == 2:
            junk()
        emit(type="progress", phase="rendering", fraction=(done / total) if total else 0.0,
             samples_done=done, samples_total=total, elapsed=done * 0.05, eta=None,
             rays_per_sec=1.0e6)
        if args.interim and time.monotonic() - last_interim >= args.interim:
            write_atomic(args.out, image(width, height, crop, 1.0))
            emit(type="image", path=args.out, samples=done, final=False)
            last_interim = time.monotonic()
    interrupted = stop["flag"]
    emit(type="phase", phase="writing", elapsed=done * 0.05)
    if mode != "no-image":
        write_atomic(args.out, image(width, height, crop, 1.0))
    emit(type="image", path=args.out, samples=done, final=True)
    emit(type="summary", output=args.out, width=crop[2] - crop[0], height=crop[3] - crop[1],
         spp=done, elapsed=done * 0.05, interrupted=interrupted, nan_samples=0, warnings=[],
         stats={})
    sys.exit(5 if interrupted else 0)


if __name__ == "__main__":
    main()
