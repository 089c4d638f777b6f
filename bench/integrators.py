"""Equal-time error of Caustic's integrators against each other, without Blender.

Usage (numpy from the project's venv; the binary from `cargo build --release`):

    .venv/bin/python bench/integrators.py [--scenes cornell_box,glass_caustic,door_ajar]
        [--integrators path,bdpt,vcm] [--resolution 160x120] [--seconds 20] [--ref-seconds 300]
        [--threads 2] [--binary target/release/caustic] [--out results/integrators]
        [--variant 'LABEL=INTEGRATOR FLAGS...'] [--reuse-ref] [--repeats N]

`--variant` adds a column rendered with extra flags (e.g. `--variant 'pm_k10=photon --k 10'`), or
with another build of the renderer (`--variant 'old=/tmp/caustic-old::sppm'`, before/after),
`--reuse-ref` takes the reference halves already in `--out`, so several runs share one reference.
`--repeats N` renders every column N times (seeds 1..N, interleaved so that a change in the
machine's load hits every column alike) and reports the mean relMSE; on this 2-core VM one
15-second render's relMSE varies by about 30 % from seed to seed (path tracing on the Cornell
box: 3.0e-4 and 3.9e-4 in two runs), so a single-seed ratio is good to roughly ±40 %.

For each scene of scenes/: a reference made of two independent renders (seeds 1001, 1002) of
`--ref-seconds` each with the reference integrator (bdpt: unbiased and the fastest to converge
on these scenes; pass --ref-integrator to change it), then one render per integrator with
`--time-limit SECONDS` (seeds 1..N). Error metric, as in bench/run.py: relMSE = mean over pixels
and R,G,B of (x - ref)^2 / (ref^2 + 0.01), minus the reference's own noise estimated from its
halves (floor = mean((a - b)^2 / 4 / (ref^2 + 0.01))). Prints a table of mean relMSE and of each
integrator's mean relMSE over the path tracer's with its standard error (from the spread over
seeds, first order in both means), and writes results.json (every seed's figure). Quote the ratios measured
in one run; absolute seconds depend on the machine and its load.
"""

import argparse
import json
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "tests", "blender"))
import exr_tiled  # noqa: E402


def load(path):
    d = exr_tiled.read_exr(path)
    if isinstance(d, tuple):
        d = next(x for x in d if isinstance(x, dict))
    return np.stack([d["Combined.R"], d["Combined.G"], d["Combined.B"]], -1).astype(np.float64)


# The binary's --spp ceiling: "unlimited" next to --time-limit. Without it a scene's own
# spp (64 in scenes/*.gltf) ends the render before the time is up, and the comparison is at
# equal spp instead (SPPM alone, which iterates until the time limit, got the full time).
UNLIMITED_SPP = 16777216


def render(binary, scene, out, integrator, seed, seconds, resolution, threads, extra=()):
    argv = [binary, "render", scene, "-o", out, "--integrator", integrator, "--seed", str(seed),
            "--time-limit", str(seconds), "--resolution", resolution, "--threads", str(threads),
            "--progress", "none", "--spp", str(UNLIMITED_SPP), *extra]
    r = subprocess.run(argv, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"render failed ({' '.join(argv)}):\n{r.stderr}")
    return load(out)


def rel_mse(x, ref):
    return float(np.mean((x - ref) ** 2 / (ref ** 2 + 0.01)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", default="cornell_box,glass_caustic,door_ajar")
    ap.add_argument("--integrators", default="path,bdpt,vcm")
    ap.add_argument("--ref-integrator", default="bdpt")
    ap.add_argument("--resolution", default="160x120")
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--ref-seconds", type=float, default=300.0)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--binary", default=os.environ.get("CAUSTIC_BINARY", os.path.join(ROOT, "target/release/caustic")))
    ap.add_argument("--out", default=os.path.join(ROOT, "results", "integrators"))
    ap.add_argument("--variant", action="append", default=[], metavar="LABEL=INTEGRATOR ARGS",
                    help="an extra column: INTEGRATOR with extra render flags, e.g. 'pm_k10=photon --k 10'")
    ap.add_argument("--repeats", type=int, default=1, help="renders per column (seeds 1..N); the table shows means")
    ap.add_argument("--reuse-ref", action="store_true",
                    help="use the reference halves already in --out (same scene, resolution, integrator)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    integrators = a.integrators.split(",")
    # label -> (binary, integrator, extra flags)
    runs = {i: (a.binary, i, []) for i in integrators}
    for v in a.variant:
        label, spec = v.split("=", 1)
        integ, *extra = spec.split()
        binary, _, integ = integ.rpartition("::")
        runs[label] = (binary or a.binary, integ, extra)
        integrators.append(label)
    results = {}
    print(f"equal time {a.seconds:g} s, reference 2 x {a.ref_seconds:g} s of {a.ref_integrator}, "
          f"{a.resolution}, {a.threads} threads")
    print(f"{'scene':<15}" + "".join(f"{i + ' relMSE':>16}" for i in integrators)
          + "".join(f"{i + '/path':>12}" for i in integrators if i != "path"))
    for name in a.scenes.split(","):
        scene = os.path.join(ROOT, "scenes", name + ".gltf")
        halves = []
        for s in (1001, 1002):
            path = os.path.join(a.out, f"{name}_ref{s}.exr")
            if a.reuse_ref and os.path.exists(path):
                halves.append(load(path))
            else:
                halves.append(render(a.binary, scene, path, a.ref_integrator, s, a.ref_seconds, a.resolution,
                                     a.threads))
        ref = 0.5 * (halves[0] + halves[1])
        floor = float(np.mean((halves[0] - halves[1]) ** 2 / 4 / (ref ** 2 + 0.01)))
        row = {"floor": floor}
        per_seed = {i: [] for i in integrators}
        means = {i: [] for i in integrators}
        for seed in range(1, a.repeats + 1):
            for integ in integrators:
                binary, kind, extra = runs[integ]
                img = render(binary, scene, os.path.join(a.out, f"{name}_{integ}_s{seed}.exr"), kind, seed,
                             a.seconds, a.resolution, a.threads, extra)
                per_seed[integ].append(rel_mse(img, ref) - floor)
                means[integ].append(float(img.mean() / ref.mean()))
        for integ in integrators:
            v = np.array(per_seed[integ])
            row[integ] = {"relmse_debiased": float(v.mean()), "per_seed": v.tolist(),
                          "stderr": float(v.std(ddof=1) / np.sqrt(len(v))) if len(v) > 1 else None,
                          "mean_ratio": float(np.mean(means[integ]))}
        results[name] = row
        line = f"{name:<15}" + "".join(f"{row[i]['relmse_debiased']:>16.4g}" for i in integrators)
        if "path" in row:
            p = row["path"]
            for i in integrators:
                if i == "path":
                    continue
                ratio = row[i]["relmse_debiased"] / p["relmse_debiased"]
                row[i]["ratio_to_path"] = ratio
                if a.repeats > 1:
                    rel = np.hypot(row[i]["stderr"] / row[i]["relmse_debiased"], p["stderr"] / p["relmse_debiased"])
                    row[i]["ratio_stderr"] = float(ratio * rel)
                    line += f"{ratio:>7.3f}±{ratio * rel:<5.2f}"
                else:
                    line += f"{ratio:>12.3f}"
        print(line + f"   (reference noise {floor:.2g}, {a.repeats} seed(s))", flush=True)
    with open(os.path.join(a.out, "results.json"), "w") as f:
        json.dump({"args": vars(a), "results": results}, f, indent=1)


if __name__ == "__main__":
    main()
