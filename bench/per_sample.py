"""Variance per sample of Caustic's integrators at equal sample count, without Blender.

Usage (numpy from the project's venv):

    .venv/bin/python bench/per_sample.py [--scenes cornell_box,hdri_sky] [--spp 64]
        [--resolution 64x64] [--ref-spp 4096] [--seeds 3] [--max-depth 8] [--out DIR]
        LABEL=BINARY:INTEGRATOR [LABEL=BINARY:INTEGRATOR ...]

Where `bench/integrators.py` compares integrators at equal time (cost and variance mixed, on a
shared machine at the mercy of its load), this separates the two: every column renders the same
`--spp` on one thread, seeds 1..N (the same seeds in every column, so columns share their
camera samples), against a path-traced reference of two halves (seeds 1001, 1002) of `--ref-spp`
each, kept in `--out` and reused. Prints each column's relMSE (as bench/run.py: mean over pixels
and R,G,B of (x - ref)^2 / (ref^2 + 0.01), minus the reference's noise floor estimated from its
halves), relMSE x spp (the variance of one sample, comparable across spp) and the mean wall
time (for cost, prefer user time of repeated runs on a quiet machine).
"""

import argparse
import os
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "bench"))
sys.path.insert(0, os.path.join(ROOT, "tests", "blender"))
import exr_tiled  # noqa: E402


def load(path):
    d = exr_tiled.read_exr(path)
    if isinstance(d, tuple):
        d = next(x for x in d if isinstance(x, dict))
    return np.stack([d["Combined.R"], d["Combined.G"], d["Combined.B"]], -1).astype(np.float64)


def render(binary, scene, out, integrator, seed, spp, a):
    argv = [binary, "render", scene, "-o", out, "--integrator", integrator, "--seed", str(seed),
            "--resolution", a.resolution, "--threads", "1", "--progress", "none", "--spp", str(spp),
            "--max-depth", str(a.max_depth)]
    t = time.time()
    r = subprocess.run(argv, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"render failed ({' '.join(argv)}):\n{r.stderr}")
    return load(out), time.time() - t


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("columns", nargs="+", help="LABEL=BINARY:INTEGRATOR")
    ap.add_argument("--scenes", default="cornell_box,hdri_sky,many_lights,subsurface")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--resolution", default="64x64")
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--max-depth", type=int, default=8)
    ap.add_argument("--ref-binary", default=os.path.join(ROOT, "target", "release", "caustic"))
    ap.add_argument("--out", default=os.path.join(ROOT, "results", "per_sample"))
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    columns = []
    for c in a.columns:
        label, rest = c.split("=", 1)
        binary, integrator = rest.rsplit(":", 1)
        columns.append((label, binary, integrator))
    print(f"{a.spp} spp, {a.resolution}, 1 thread, seeds 1-{a.seeds}, reference 2 x {a.ref_spp} spp of path")
    for name in a.scenes.split(","):
        scene = os.path.join(ROOT, "scenes", f"{name}.gltf")
        halves = []
        for seed in (1001, 1002):
            path = os.path.join(a.out, f"{name}_ref{seed}_{a.resolution}_{a.ref_spp}.exr")
            if not os.path.exists(path):
                render(a.ref_binary, scene, path, "path", seed, a.ref_spp, a)
            halves.append(load(path))
        ref = 0.5 * (halves[0] + halves[1])
        floor = float(np.mean((halves[0] - halves[1]) ** 2 / 4 / (ref ** 2 + 0.01)))
        for label, binary, integrator in columns:
            errs, times = [], []
            for seed in range(1, a.seeds + 1):
                x, t = render(binary, scene, os.path.join(a.out, f"{name}_{label}_{seed}.exr"), integrator, seed,
                              a.spp, a)
                errs.append(float(np.mean((x - ref) ** 2 / (ref ** 2 + 0.01))) - floor)
                times.append(t)
            e = float(np.mean(errs))
            print(f"{name:14s} {label:14s} relMSE {e:.4g} (seeds {' '.join(f'{v:.3g}' for v in errs)})  "
                  f"x spp {e * a.spp:.4g}  wall {np.mean(times):.2f} s", flush=True)


if __name__ == "__main__":
    main()
