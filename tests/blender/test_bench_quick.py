"""The benchmark keeps working: `bench/run.py --quick` runs end to end (CI, ~40 s on 2 cores).

It runs in its own process (as a user would run it), with the binary the suite uses
($CAUSTIC_BINARY), and must produce the printed table, the CSV and JSON files and the plots, with
a finite wall time and finite relMSE against every reference for every scene and every renderer
(Cycles and each integrator the binary lists). Any failed render fails the test. The numbers
themselves are not judged here: they are figures for docs/benchmarks.md, not timed tests.
"""

import csv
import json
import math
import os
import subprocess
import sys
import time

import pytest

pytestmark = pytest.mark.needs_binary

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
RUN = os.path.join(REPO, "bench", "run.py")
SCENES = ("cornell", "glass_caustic", "subsurface", "many_lights", "hdri")


def finite(value):
    try:
        return math.isfinite(float(value))
    except (TypeError, ValueError):
        return False


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, RUN, "--quick", "--out", str(out)],
                          capture_output=True, text=True, timeout=600,
                          env=dict(os.environ))
    seconds = time.perf_counter() - t0
    print(f"\n[bench --quick] {seconds:.0f} s")
    return out, proc, seconds


def test_quick_mode_succeeds(quick_run):
    out, proc, _ = quick_run
    tail = (proc.stdout[-3000:] + "\n" + proc.stderr[-3000:])
    assert proc.returncode == 0, f"bench/run.py --quick failed ({proc.returncode}):\n{tail}"
    assert "Equal time: relMSE against each reference" in proc.stdout
    assert "FAILED RENDERS" not in proc.stdout
    for name in ("table.txt", "equal_time.csv", "references.csv", "same_spp.csv",
                 "throughput.csv", "scaling.csv", "results.json", "error_vs_time.png",
                 "contact_sheet.png"):
        path = out / name
        assert path.is_file() and path.stat().st_size > 0, f"{name} was not written"


def test_every_scene_and_renderer_has_finite_numbers(quick_run):
    out, proc, _ = quick_run
    assert proc.returncode == 0, proc.stderr[-2000:]
    result = json.loads((out / "results.json").read_text())
    assert result["failures"] == []
    renderers = ["cycles"] + [f"caustic-{i}" for i in result["integrators"]]
    assert "caustic-path" in renderers
    with open(out / "equal_time.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    for scene in SCENES:
        for renderer in renderers:
            mine = [r for r in rows if r["scene"] == scene and r["renderer"] == renderer]
            assert len(mine) == len(result["config"]["budgets"]), (scene, renderer)
            for r in mine:
                assert r["error"] == "", (scene, renderer, r["error"])
                assert finite(r["wall"]) and float(r["wall"]) > 0, (scene, renderer, r)
                for ref in renderers:
                    assert finite(r[f"relmse_vs_{ref}"]), (scene, renderer, ref, r)
    same_spp = {r["scene"]: r for r in result["records"]["same_spp"]}
    throughput = {r["scene"]: r for r in result["records"]["throughput"]}
    for scene in SCENES:
        assert finite(same_spp[scene]["wall_ratio"]), scene
        assert finite(throughput[scene]["rays_per_sec"]), scene
    axes = {r["axis"] for r in result["records"]["scaling"]}
    assert axes == {"pixels", "threads", "triangles"}
    assert all(finite(r["render_seconds"]) for r in result["records"]["scaling"])
