"""Render-farm benchmark (issue 23): wall time of one frame on 1 and 2 local Dask workers,
and the overhead per chunk (scheduling, scene transfer, merge), measured, not modelled.

Each worker renders with `--threads 1`, so on this 2-core machine 2 workers stand for 2
machines of one core each. Every figure is the median of `--repeats` runs on one running
LocalCluster (its start-up is timed separately).

Usage: CAUSTIC_BINARY=target/release/caustic .venv/bin/python bench/farm.py [--spp 64]
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.join(REPO, "farm"))

from caustic_farm import render_frames  # noqa: E402


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--spp", type=int, default=64)
    p.add_argument("--resolution", default="128x96")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--scene", default=os.path.join(REPO, "scenes", "cornell_box.gltf"))
    a = p.parse_args()
    binary = os.environ.get("CAUSTIC_BINARY", os.path.join(REPO, "target", "release", "caustic"))
    os.environ["CAUSTIC_BINARY"] = binary
    from distributed import Client, LocalCluster

    render = ["--resolution", a.resolution, "--threads", "1"]
    tmp = tempfile.mkdtemp(prefix="caustic-farm-bench-")
    out = os.path.join(tmp, "o.exr")

    def median(f):
        times = []
        for _ in range(a.repeats):
            t0 = time.monotonic()
            f()
            times.append(time.monotonic() - t0)
        return statistics.median(times)

    single = median(lambda: subprocess.run([binary, "render", a.scene, "-o", out, "--spp", str(a.spp), *render],
                                           check=True, capture_output=True))
    res = {"spp": a.spp, "resolution": a.resolution, "single_render_s": single}
    for workers in (1, 2):
        t0 = time.monotonic()
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                          dashboard_address=None) as cluster, Client(cluster) as client:
            res[f"cluster_start_{workers}w_s"] = time.monotonic() - t0
            for chunks in (1, 2, 8):
                res[f"farm_{workers}w_{chunks}c_s"] = median(lambda: render_frames(
                    [a.scene], [out], spp=a.spp, chunks=chunks, extra_args=render, client=client,
                    report=lambda _: None))
    # Per-chunk overhead on one worker: the extra time of 8 chunks over 1, per extra chunk.
    res["overhead_per_chunk_s"] = (res["farm_1w_8c_s"] - res["farm_1w_1c_s"]) / 7
    # Fixed overhead of a farm frame: one chunk on one worker against the plain render.
    res["fixed_overhead_s"] = res["farm_1w_1c_s"] - single
    res["speedup_2w_2c"] = res["farm_1w_2c_s"] / res["farm_2w_2c_s"]
    res["speedup_2w_8c"] = res["farm_1w_8c_s"] / res["farm_2w_8c_s"]
    print(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
