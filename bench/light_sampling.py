"""Light selection benchmark: equal-time relative MSE of the light tree against power sampling.

Usage (needs numpy; the project's venv has it):

    CAUSTIC_BINARY=target/release/caustic .venv/bin/python bench/light_sampling.py
    ... bench/light_sampling.py --scene scenes/many_lights.gltf --spp 16 --runs 4 --ref-spp 1024

What it does, with the binary only (no Blender):
1. Reference: two renders with the light tree (seeds 1001, 1002) of `--ref-spp` each; the
   reference is their mean, and its own noise is estimated from the two halves a, b as
   floor = mean((a - b)^2 / 4 / (ref^2 + 0.01)).
2. Measured renders: `--runs` renders per sampler of `--spp` samples, seeds 1.., the two
   samplers interleaved so that a busy machine slows both alike.
3. Error per image: relMSE = mean over pixels and R, G, B of (x - ref)^2 / (ref^2 + 0.01), as
   bench/run.py; `debiased` subtracts the reference's floor. Over the full frame and over the
   lit surfaces (pixels where no emitter is seen directly, found with a 4096 spp --max-depth 0 render, widened by a pixel:
   the anti-aliasing noise of emitters seen directly is the same whatever picks the lights, and
   on a street of bulbs it dominates the full-frame figure).
4. Equal time: all renders have the same spp (render time grows in whole passes, so time
   limits would compare 16 spp with 32); relMSE at equal time = relMSE x render seconds, as
   relMSE falls as 1 / time. Printed: the tree / power ratios at equal spp, of time per sample
   and at equal time, the last being the figure to quote (issue 9's target is <= 0.3).
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path[:0] = [os.path.join(ROOT, "bench"), os.path.join(ROOT, "tests", "blender")]
from exr_tiled import read_exr  # noqa: E402


def render(binary, scene, out, sampler, seed, spp, resolution, threads, max_depth, crop):
    args = [binary, "render", scene, "-o", out, "--progress", "json", "--light-sampler", sampler,
            "--seed", str(seed), "--spp", str(spp), "--resolution", resolution,
            "--threads", str(threads), "--max-depth", str(max_depth)]
    if crop:
        args += ["--crop", crop]
    r = subprocess.run(args, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"render failed ({r.returncode}): {r.stderr}")
    # The JSON progress lines go to stderr; the last one is the summary.
    summary = json.loads(r.stderr.strip().splitlines()[-1])
    seconds = summary["stats"]["render_seconds"]
    d = read_exr(out)
    img = np.stack([d["Combined." + c] for c in "RGB"], -1).astype(np.float64)
    return img, seconds


def rel_mse(x, ref, mask=None):
    e = ((x - ref) ** 2 / (ref ** 2 + 0.01)).mean(-1)
    return float(e.mean() if mask is None else e[mask].mean())





def dilate(m):
    """3x3 dilation of a boolean image."""
    p = np.pad(m, 1)
    return np.any([p[1 + dy:1 + dy + m.shape[0], 1 + dx:1 + dx + m.shape[1]]
                   for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=0)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--binary", default=os.environ.get("CAUSTIC_BINARY",
                                                      os.path.join(ROOT, "target/release/caustic")))
    ap.add_argument("--scene", default=os.path.join(ROOT, "scenes/many_lights.gltf"))
    ap.add_argument("--resolution", default="160x90")
    ap.add_argument("--spp", type=int, default=16, help="samples per pixel of a measured render")
    ap.add_argument("--runs", type=int, default=4, help="measured renders per sampler")
    ap.add_argument("--ref-spp", type=int, default=1024, help="samples per pixel of a reference half")
    ap.add_argument("--crop", default="", help="X0,Y0,X1,Y1: measure only this window")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--max-depth", type=int, default=5)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "x.exr")
        common = (a.resolution, a.threads, a.max_depth, a.crop)
        halves = [render(a.binary, a.scene, out, "tree", 1001 + k, a.ref_spp, *common) for k in range(2)]
        ref = (halves[0][0] + halves[1][0]) / 2
        # Lit surfaces: the pixels where no emitter is seen directly (a render with
        # --max-depth 0 is that emission alone, spread by the pixel filter); the
        # anti-aliasing noise of emitters is the same whatever picks the lights.
        # Far bulbs cover a fraction of a pixel: many samples, and one pixel more around.
        seen, _ = render(a.binary, a.scene, out, "power", 7, 4096, a.resolution, a.threads, 0, a.crop)
        surfaces = ~dilate(seen.max(-1) > 0.0)
        diff2 = ((halves[0][0] - halves[1][0]) ** 2 / 4 / (ref ** 2 + 0.01)).mean(-1)
        floor = {"full": float(diff2.mean()), "surfaces": float(diff2[surfaces].mean())}
        results = {"tree": [], "power": []}
        for run in range(a.runs):
            for sampler in results:
                img, secs = render(a.binary, a.scene, out, sampler, 1 + run, a.spp, *common)
                results[sampler].append(({"full": rel_mse(img, ref), "surfaces": rel_mse(img, ref, surfaces)},
                                         secs, float(img.mean())))
    print(f"scene {os.path.relpath(a.scene, ROOT)}  {a.resolution}  crop {a.crop or 'none'}  max depth "
          f"{a.max_depth}  {a.threads} threads  {a.spp} spp x {a.runs} runs  reference 2 x {a.ref_spp} spp "
          f"(mean {ref.mean():.5g}; lit surfaces {surfaces.mean():.1%} of the pixels)")
    for region in ("full", "surfaces"):
        print(f"  {region} (reference floor {floor[region]:.3g})")
        eff = {}
        for sampler, rows in results.items():
            raw = np.mean([r[0][region] for r in rows])
            secs = np.mean([r[1] for r in rows])
            eff[sampler] = (raw - floor[region], secs)
            print(f"    {sampler:6s} render {secs:7.3f} s  relMSE {raw:.4g}  debiased {raw - floor[region]:.4g}  "
                  f"image mean {np.mean([r[2] for r in rows]):.5g}")
        (et, tt), (ep, tp) = eff["tree"], eff["power"]
        print(f"    tree / power: relMSE at equal spp {et / ep:.3f}, time per sample {tt / tp:.3f}, "
              f"relMSE at equal time {et * tt / (ep * tp):.3f}")


if __name__ == "__main__":
    main()
