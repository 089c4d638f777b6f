"""Caustic's benchmark against Cycles: equal-time error, same-spp time, throughput and scaling.

Usage (the project's venv has bpy 5.0.1, numpy and matplotlib; see scripts/setup_python.sh):

    CAUSTIC_BINARY=target/release/caustic .venv/bin/python bench/run.py --quick   # CI, < 1 min
    CAUSTIC_BINARY=target/release/caustic .venv/bin/python bench/run.py --full    # ~10 min

Options: --out DIR (default results/<mode>-<date>), --scenes a,b (subset of the suite),
--binary PATH (else $CAUSTIC_BINARY, else target/release/caustic), --threads N (default 2).

What it does, in one bpy process:
1. Builds each scene of bench/suite.py with bpy (Cornell box, glass caustic with a mirror,
   subsurface, 256 small emitters, an object lit by a procedural sky image) and exports it once
   with the add-on's own exporter (blender_addon/export.py: Blender's glTF exporter + Caustic's
   hooks), exactly as an F12 render would.
2. Renders every scene with Cycles (CPU, through bpy) and with every integrator the binary
   offers (parsed from `caustic render --help` at run time), with the same resolution, the same
   bounces (Cycles max/diffuse/glossy/transmission bounces B; Caustic --max-depth B+1), the same
   Blackman-Harris 1.5 px filter, no denoising, no adaptive sampling, no clamping, fixed seeds.
   * References: per scene and per renderer two independent renders (seeds 1001 and 1002) of
     `ref_seconds` each; the reference is their mean.
   * Equal time: one render per time budget (Cycles `scene.cycles.time_limit`, Caustic
     `--time-limit`; both count from the start of sampling, after scene sync / BVH build)
     with seed 1, compared with BOTH references.
   * Error metric (per image): relMSE = mean over pixels p and channels c in R,G,B of the linear
     Combined pass of (x_pc - ref_pc)^2 / (ref_pc^2 + 0.01).
     The reference's own noise adds to that; it is estimated from its two halves a, b as
     floor = mean((a - b)^2 / 4 / (ref^2 + 0.01)), and `relmse_debiased` = relMSE - floor.
     Ratios Caustic/Cycles are taken on the debiased values (the raw ones are in the CSV too).
   * Where the references disagree: relMSE of one reference against the other, compared with
     the sum of their floors (what pure noise would give), and the ratio of their means; the
     same after a 3x3 median of both (which removes fireflies, whose heavy tail the two-halves
     noise estimate underrates); and the 16x16 block where they differ most.
3. Same spp: wall time of one render of `same_spp` samples per pixel, Caustic's path tracer vs
   Cycles (the best of `repeats` runs each, interleaved).
4. Throughput: `caustic bench --json` on each exported scene (rays/s by kind, BVH build time) and
   the peak resident memory (VmHWM) of each Caustic process.
5. Scaling of Caustic's wall time (`caustic bench`) with pixel count (Cornell box), triangle
   count (Suzanne subdivided 0..n times) and thread count (1, 2). Photon-count scaling is a hook
   (`photon_scaling`) that runs when the binary has a photon integrator and a photon-count flag.

Output under the results folder: table.txt (also printed), equal_time.csv, references.csv,
same_spp.csv, throughput.csv, scaling.csv, results.json, error_vs_time.png, contact_sheet.png and
images/*.npy (the linear images). Exit code 1 when any render failed (the table still says which).
Quote ratios measured in one run; absolute seconds depend on the machine and its load.
"""

import argparse
import csv
import datetime
import json
import math
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
TESTS = os.path.join(REPO, "tests", "blender")

EPS = 1e-2  # relMSE denominator offset
CAUSTIC_MAX_SPP = 16777216  # the binary's --spp ceiling: "unlimited" next to --time-limit
CYCLES_MAX_SPP = 1 << 24

MODES = {
    "quick": dict(
        resolution=(24, 24), bounces=4, budgets=[0.2, 0.4], ref_seconds=0.3, same_spp=4,
        repeats=1, bench_spp=4, scale_resolutions=[16, 32], scale_levels=[0, 2],
        scale_spp=4, threads_list=[1, 2],
    ),
    "full": dict(
        resolution=(128, 128), bounces=8, budgets=[1.0, 2.0, 4.0, 8.0], ref_seconds=12.0,
        same_spp=16, repeats=2, bench_spp=16, scale_resolutions=[32, 64, 128, 256],
        scale_levels=[0, 1, 2, 3, 4], scale_spp=16, threads_list=[1, 2],
    ),
}

REF_SEEDS = (1001, 1002)
# Cycles builds its Blackman-Harris table over twice Blender's filter width (intern/cycles/scene/
# film.cpp: `width *= 2.0f` for FILTER_BLACKMAN_HARRIS); the renderer's --filter-width is the
# window's full width, so Blender's 1.5 px is 3 px for Caustic. The add-on passes 1.5 unchanged
# (a narrower filter than Cycles'; see docs/benchmarks.md), the benchmark passes the matching
# width so that both renderers really use the same filter.
FILTER_SIZE = 1.5
CAUSTIC_BH_WIDTH = 2.0 * FILTER_SIZE
TEST_SEED = 1


# ----------------------------------------------------------------------------- metrics

def rel_mse(x, ref):
    """mean over pixels and RGB of (x - ref)^2 / (ref^2 + EPS)."""
    import numpy as np

    return float(np.mean((x - ref) ** 2 / (ref ** 2 + EPS)))


def median3(img):
    """3x3 median of each channel (edges replicated): removes isolated fireflies."""
    import numpy as np

    h, w = img.shape[:2]
    p = np.pad(img, ((1, 1), (1, 1), (0, 0)), mode="edge")
    stack = np.stack([p[dy:dy + h, dx:dx + w] for dy in range(3) for dx in range(3)])
    return np.median(stack, axis=0)


def ref_floor(a, b):
    """Expected relMSE contribution of the noise of ref = (a + b) / 2 (a, b independent)."""
    import numpy as np

    ref = 0.5 * (a + b)
    return float(np.mean((a - b) ** 2 / 4.0 / (ref ** 2 + EPS)))


def finite(x):
    return x is not None and isinstance(x, (int, float)) and math.isfinite(x)


# ----------------------------------------------------------------------------- the binary

def caustic_integrators(binary):
    """Integrator names listed under --integrator in `caustic render --help` (at run time)."""
    text = subprocess.run([binary, "render", "--help"], capture_output=True, text=True,
                          check=True).stdout
    start = text.find("--integrator")
    if start < 0:
        return ["path"]
    section = text[start:]
    end = re.search(r"\n {2,6}-", section)
    section = section[:end.start()] if end else section
    names = re.findall(r"^\s+- ([A-Za-z0-9_-]+):", section, re.M)
    if not names:
        names = re.findall(r"possible values: ([^\]]+)\]", section)
        names = [n.strip() for n in names[0].split(",")] if names else ["path"]
    return names


def render_help_has(binary, flag):
    text = subprocess.run([binary, "render", "--help"], capture_output=True, text=True).stdout
    return flag in text


def _peak_rss_mib(pid, exe, state):
    """Poll /proc/PID/status for VmHWM (peak RSS) while PID runs `exe` (not the forked Python)."""
    while state["running"]:
        try:
            if os.path.realpath(f"/proc/{pid}/exe") == exe:
                with open(f"/proc/{pid}/status") as f:
                    for line in f:
                        if line.startswith("VmHWM:"):
                            state["peak"] = max(state["peak"], int(line.split()[1]) / 1024.0)
        except OSError:
            pass
        time.sleep(0.01)


def run_with_rusage(argv, stderr_path):
    """Run argv; return (exit code, wall seconds, peak RSS in MiB, stdout text).

    The peak RSS is the child's VmHWM polled every 10 ms (the rusage of wait4 would report the
    forked bpy process's size, which ru_maxrss keeps across exec); it can miss a peak reached in
    the last 10 ms of the run.
    """
    import threading

    exe = os.path.realpath(argv[0])
    with open(stderr_path, "wb") as err, tempfile.TemporaryFile() as out:
        t0 = time.perf_counter()
        proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=out, stderr=err)
        state = {"running": True, "peak": 0.0}
        poller = threading.Thread(target=_peak_rss_mib, args=(proc.pid, exe, state), daemon=True)
        poller.start()
        code = proc.wait()
        wall = time.perf_counter() - t0
        state["running"] = False
        poller.join()
        out.seek(0)
        text = out.read().decode("utf-8", "replace")
    return code, wall, (state["peak"] or float("nan")), text


def parse_progress(path):
    summary, error, warnings = None, None, []
    with open(path, encoding="utf-8", errors="replace") as f:
        for line in f:
            line = line.strip()
            if not line.startswith("{"):
                if line:
                    warnings.append(line)
                continue
            try:
                msg = json.loads(line)
            except ValueError:
                continue
            kind = msg.get("type")
            if kind == "summary":
                summary = msg
            elif kind == "error":
                error = msg
            elif kind == "warning":
                warnings.append(msg.get("message", ""))
    return summary, error, warnings


# ----------------------------------------------------------------------------- the benchmark

class Bench:
    def __init__(self, mode, cfg, binary, out_dir, threads, scene_names):
        self.mode, self.cfg, self.binary, self.out = mode, cfg, binary, out_dir
        self.threads = threads
        self.scene_names = scene_names
        self.work = tempfile.mkdtemp(prefix="caustic-bench-")
        self.failures = []
        self._stats = []
        self.scene_refs = {}  # scene -> (exported glTF, Cycles reference), for photon_scaling
        self.records = {"equal_time": [], "references": [], "same_spp": [], "throughput": [],
                        "scaling": [], "scenes": {}}
        self.images = {}  # (scene, label) -> linear RGB array (rows top to bottom)

    # -- bpy side ------------------------------------------------------------------------------

    def new_scene(self, builder, *args):
        bpy = self.bpy
        bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
        scene = bpy.context.scene
        builder(scene, *args)
        # Cycles hides lights from camera rays by default (Object > Visibility > Camera off for
        # new lights); Caustic always shows area lights (the add-on does not export the flag).
        # Shown in both, so that the comparison measures noise, not that difference.
        for obj in scene.objects:
            if obj.type == "LIGHT":
                obj.visible_camera = True
        self.configure(scene, self.cfg["resolution"])
        return scene

    def configure(self, scene, resolution):
        r = scene.render
        r.resolution_x, r.resolution_y = resolution
        r.resolution_percentage = 100
        r.image_settings.file_format = "OPEN_EXR"
        r.image_settings.color_depth = "32"
        r.image_settings.color_mode = "RGBA"
        r.filter_size = FILTER_SIZE
        r.film_transparent = False
        r.threads_mode = "FIXED"
        r.threads = self.threads
        b = self.cfg["bounces"]
        c = scene.cycles
        c.device = "CPU"
        c.use_adaptive_sampling = False
        c.use_denoising = False
        c.use_animated_seed = False
        c.max_bounces = c.diffuse_bounces = c.glossy_bounces = b
        c.transmission_bounces = c.volume_bounces = b
        c.transparent_max_bounces = max(b, 8)
        c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
        c.light_sampling_threshold = 0.0
        c.caustics_reflective = c.caustics_refractive = True
        c.blur_glossy = 0.0
        c.pixel_filter_type = "BLACKMAN_HARRIS"
        # Caustic renders Cycles' Light Paths (above): no bounce setting of its own.
        p = scene.caustic
        p.threads = self.threads
        p.seed = TEST_SEED

    def export(self, scene, name):
        """The scene as the add-on exports it for an F12 render; returns (gltf path, warnings)."""
        addon = self.addon
        folder = os.path.join(self.work, name)
        os.makedirs(folder, exist_ok=True)
        w, h = scene.render.resolution_x, scene.render.resolution_y
        settings = addon.export.render_settings(scene, (w, h), scene.camera.name)
        depsgraph = self.bpy.context.evaluated_depsgraph_get()
        path, state = addon.export.export_scene(depsgraph, folder, settings)
        return path, list(state.warnings)

    def cycles(self, scene, tag, seed, time_limit=None, spp=None):
        """One Cycles render; returns a record dict (image under 'image')."""
        import exr_io

        bpy = self.bpy
        scene.render.engine = "CYCLES"
        c = scene.cycles
        c.seed = seed
        c.samples = spp if spp else CYCLES_MAX_SPP
        c.time_limit = time_limit or 0.0
        path = os.path.join(self.work, f"{tag}.exr")
        scene.render.filepath = path
        self._stats = []
        rec = {"renderer": "cycles", "seed": seed, "time_limit": time_limit, "spp_target": spp}
        t0 = time.perf_counter()
        try:
            bpy.ops.render.render(write_still=True)
        except Exception as err:  # noqa: BLE001  (the table must say what failed)
            rec["error"] = f"{type(err).__name__}: {err}"
            return rec
        rec["wall"] = time.perf_counter() - t0
        if not os.path.isfile(path):
            rec["error"] = "Cycles wrote no image"
            return rec
        chans = exr_io.read_exr(path)
        meta = exr_header_strings(path)
        rec["render_seconds"] = parse_clock(meta.get("cycles.ViewLayer.render_time"))
        rec["sync_seconds"] = parse_clock(meta.get("cycles.ViewLayer.synchronization_time"))
        rec["spp"] = spp if spp else last_cycles_sample(self._stats)
        rec["image"] = np_stack(chans, ("R", "G", "B"))
        os.remove(path)
        return rec

    # -- binary side ---------------------------------------------------------------------------

    def caustic(self, gltf, tag, integrator, seed, time_limit=None, spp=None, resolution=None,
                threads=None, extra=()):
        import exr_tiled

        out = os.path.join(self.work, f"{tag}.exr")
        w, h = resolution or self.cfg["resolution"]
        argv = [self.binary, "render", gltf, "-o", out, "--progress", "json",
                "--resolution", f"{w}x{h}", "--max-depth", str(self.cfg["bounces"] + 1),
                "--seed", str(seed), "--threads", str(threads or self.threads),
                "--integrator", integrator,
                "--filter", "blackman-harris", "--filter-width", repr(CAUSTIC_BH_WIDTH),
                "--spp", str(spp if spp else CAUSTIC_MAX_SPP),
                # What an F12 sends for the suite's view layers (Combined alone, Blender's
                # default), which is all Cycles renders here; without it the binary writes
                # its legacy Depth, Normal, denoising and sample-count passes too.
                "--passes", "none"]
        if time_limit:
            argv += ["--time-limit", repr(float(time_limit))]
        argv += list(extra)
        code, wall, rss, _ = run_with_rusage(argv, out + ".log")
        summary, error, warnings = parse_progress(out + ".log")
        rec = {"renderer": f"caustic-{integrator}", "seed": seed, "time_limit": time_limit,
               "spp_target": spp, "wall": wall, "peak_rss_mib": rss, "exit_code": code,
               "warnings": warnings}
        if code != 0 or summary is None:
            rec["error"] = (error or {}).get("message") or f"exit code {code}"
            return rec
        stats = summary.get("stats", {})
        rec["render_seconds"] = stats.get("render_seconds")
        rec["bvh_build_seconds"] = stats.get("bvh_build_seconds")
        rec["spp"] = summary.get("spp")
        rec["spp_max"] = summary.get("spp_max")
        rec["rays_per_sec"] = stats.get("rays_per_sec")
        rec["black"] = summary.get("black")
        rec["nan_samples"] = summary.get("nan_samples")
        chans = exr_tiled.read_exr(out)
        rec["image"] = np_stack(chans, ("Combined.R", "Combined.G", "Combined.B"))
        os.remove(out)
        return rec

    def caustic_bench(self, gltf, spp, resolution, threads):
        # (`caustic bench` has no filter flag: it uses the scene's, i.e. the add-on's 1.5 px.)
        argv = [self.binary, "bench", gltf, "--json", "--spp", str(spp),
                "--resolution", f"{resolution[0]}x{resolution[1]}", "--threads", str(threads)]
        code, wall, rss, text = run_with_rusage(argv, os.path.join(self.work, "bench.log"))
        if code != 0:
            with open(os.path.join(self.work, "bench.log"), errors="replace") as f:
                raise RuntimeError(f"caustic bench failed ({code}): {f.read()[-500:]}")
        data = json.loads(text)
        data["peak_rss_mib"] = rss
        data["process_wall"] = wall
        return data

    def caustic_info(self, gltf):
        out = subprocess.run([self.binary, "info", gltf, "--json"], capture_output=True, text=True)
        try:
            return json.loads(out.stdout)
        except ValueError:
            return {}

    # -- record keeping ------------------------------------------------------------------------

    def keep(self, scene_name, label, rec):
        """Store a render's image aside; note failures."""
        image = rec.pop("image", None)
        if "error" in rec:
            self.failures.append(f"{scene_name} / {label}: {rec['error']}")
            print(f"  FAILED {scene_name} / {label}: {rec['error']}", flush=True)
        if image is not None:
            self.images[(scene_name, label)] = image
        return image

    # -- the parts -----------------------------------------------------------------------------

    def run(self):
        import numpy as np
        import suite

        cfg = self.cfg
        integrators = self.integrators
        for name in self.scene_names:
            builder, note = suite.SUITE[name]
            t_scene = time.perf_counter()
            print(f"== {name}", flush=True)
            scene = self.new_scene(builder)
            scene.render.engine = "CAUSTIC"
            gltf, export_warnings = self.export(scene, name)
            info = self.caustic_info(gltf)
            meta = {"note": note, "export_warnings": export_warnings,
                    "load_warnings": info.get("warnings", []), "triangles": info.get("triangles"),
                    "emissive_triangles": info.get("emissive_triangles"),
                    "extensions_used": info.get("extensions_used", []),
                    "render_warnings": []}
            self.records["scenes"][name] = meta

            # References: two halves per renderer, independent of the equal-time renders' seed.
            refs = {}
            renderers = ["cycles"] + [f"caustic-{i}" for i in integrators]
            for r in renderers:
                halves = []
                for seed in REF_SEEDS:
                    tag = f"{name}-ref-{r}-{seed}"
                    if r == "cycles":
                        rec = self.cycles(scene, tag, seed, time_limit=cfg["ref_seconds"])
                    else:
                        rec = self.caustic(gltf, tag, r[len("caustic-"):], seed,
                                           time_limit=cfg["ref_seconds"])
                        meta["render_warnings"] += [w for w in rec.get("warnings", [])
                                                    if w not in meta["render_warnings"]]
                    img = self.keep(name, f"ref-{r}-{seed}", rec)
                    rec.update(scene=name, kind="reference-half")
                    if img is not None:
                        halves.append((img, rec))
                if len(halves) == 2:
                    a, b = halves[0][0], halves[1][0]
                    refs[r] = {"image": 0.5 * (a + b), "floor": ref_floor(a, b), "halves": (a, b),
                               "spp": sum((h[1].get("spp") or 0) for h in halves),
                               "mean": float(np.mean(0.5 * (a + b)))}
                    self.images[(name, f"ref-{r}")] = refs[r]["image"]
                    if r != "cycles" and refs[r]["mean"] == 0.0:
                        meta["note"] = (meta["note"] + " " if meta["note"] else "") + (
                            f"Caustic ({r}) renders this scene black.")
            self.compare_references(name, refs)
            self.scene_refs[name] = (gltf, refs.get("cycles"))

            # Equal time, interleaved so that machine load hits every renderer alike.
            for budget in cfg["budgets"]:
                for r in renderers:
                    tag = f"{name}-{r}-{budget}"
                    if r == "cycles":
                        rec = self.cycles(scene, tag, TEST_SEED, time_limit=budget)
                    else:
                        rec = self.caustic(gltf, tag, r[len("caustic-"):], TEST_SEED,
                                           time_limit=budget)
                    img = self.keep(name, f"{r}-{budget}", rec)
                    row = {"scene": name, "renderer": r, "budget": budget,
                           "wall": rec.get("wall"), "render_seconds": rec.get("render_seconds"),
                           "spp": rec.get("spp"), "error": rec.get("error", "")}
                    for ref_name, ref in refs.items():
                        key = "cycles" if ref_name == "cycles" else ref_name
                        if img is None:
                            continue
                        raw = rel_mse(img, ref["image"])
                        row[f"relmse_vs_{key}"] = raw
                        row[f"relmse_debiased_vs_{key}"] = raw - ref["floor"]
                    if img is not None:
                        row["mean"] = float(np.mean(img))
                    self.records["equal_time"].append(row)
                    print("  " + format_equal_row(row), flush=True)

            # Same spp: Caustic's path tracer vs Cycles, best of `repeats`, interleaved.
            best = {}
            for _ in range(cfg["repeats"]):
                for r in ("cycles", "caustic-path"):
                    tag = f"{name}-spp-{r}"
                    if r == "cycles":
                        rec = self.cycles(scene, tag, TEST_SEED, spp=cfg["same_spp"])
                    else:
                        rec = self.caustic(gltf, tag, "path", TEST_SEED, spp=cfg["same_spp"])
                    self.keep(name, f"spp-{r}", rec)
                    if "error" not in rec and (r not in best or rec["wall"] < best[r]["wall"]):
                        best[r] = rec
            if len(best) == 2:
                cy, ca = best["cycles"], best["caustic-path"]
                row = {"scene": name, "spp": cfg["same_spp"], "cycles_wall": cy["wall"],
                       "caustic_wall": ca["wall"], "wall_ratio": ca["wall"] / cy["wall"],
                       "cycles_render_seconds": cy.get("render_seconds"),
                       "caustic_render_seconds": ca.get("render_seconds")}
                if finite(row["cycles_render_seconds"]) and row["cycles_render_seconds"] > 0 \
                        and finite(row["caustic_render_seconds"]):
                    row["render_ratio"] = row["caustic_render_seconds"] / row["cycles_render_seconds"]
                self.records["same_spp"].append(row)

            # Throughput (rays/s by kind, BVH build) on the exported scene.
            try:
                data = self.caustic_bench(gltf, cfg["bench_spp"], cfg["resolution"], self.threads)
                data.update(scene=name, triangles=info.get("triangles"))
                data.pop("scene_file", None)
                self.records["throughput"].append(data)
            except (RuntimeError, ValueError) as err:
                self.failures.append(f"{name} / caustic bench: {err}")
            print(f"  ({time.perf_counter() - t_scene:.0f} s)", flush=True)

        if "cornell" in self.scene_names and cfg.get("scaling", True):
            self.scaling()
        self.records["photon_scaling"] = self.photon_scaling()

    def compare_references(self, name, refs):
        import numpy as np

        names = list(refs)
        for r in names:
            self.records["references"].append({
                "scene": name, "reference": r, "a": r, "b": "", "mean": refs[r]["mean"],
                "spp": refs[r]["spp"], "floor": refs[r]["floor"]})
        for i, a in enumerate(names):
            for b in names[i + 1:]:
                cross = rel_mse(refs[a]["image"], refs[b]["image"])
                noise = refs[a]["floor"] + refs[b]["floor"]
                ratio = refs[a]["mean"] / refs[b]["mean"] if refs[b]["mean"] > 0 else float("inf")
                # Pure noise gives cross ~= noise; a mean ratio off by > 1 % is not noise here.
                plain = cross <= 3.0 * noise
                # Fireflies (caustics by path tracing) have a heavy tail that the two-halves noise
                # estimate underrates; a 3x3 median removes them, so the same test on
                # median-filtered images separates "different images" from "rare huge samples".
                med = {r: median3(refs[r]["image"]) for r in (a, b)}
                cross_med = rel_mse(med[a], med[b])
                noise_med = sum(ref_floor(*(median3(x) for x in refs[r]["halves"])) for r in (a, b))
                m_a, m_b = float(np.mean(med[a])), float(np.mean(med[b]))
                ratio_med = m_a / m_b if m_b > 0 else float("inf")
                robust = cross_med <= 3.0 * noise_med and abs(ratio_med - 1.0) <= 0.01
                agree = (plain and abs(ratio - 1.0) <= 0.01) or robust
                self.records["references"].append({
                    "scene": name, "reference": f"{a} vs {b}", "a": a, "b": b,
                    "relmse_a_vs_b": cross, "noise_expected": noise, "mean_ratio_a_over_b": ratio,
                    "relmse_median3": cross_med, "noise_median3": noise_med,
                    "mean_ratio_median3": ratio_med,
                    "agree_plain": plain, "agree_median3": robust, "agree": agree})
                # Where they disagree, and how: the 8x8-block relMSE map's worst block.
                diff = (refs[a]["image"] - refs[b]["image"]) ** 2 / (refs[b]["image"] ** 2 + EPS)
                h, w = diff.shape[:2]
                k = max(1, min(h, w) // 8)
                blocks = diff[: h - h % k, : w - w % k].mean(axis=2).reshape(h // k, k, w // k, k)
                blocks = blocks.mean(axis=(1, 3))
                by, bx = np.unravel_index(np.argmax(blocks), blocks.shape)
                self.records["references"][-1]["worst_block"] = (
                    f"rows {by * k}-{by * k + k - 1}, cols {bx * k}-{bx * k + k - 1} "
                    f"(top-left origin): block relMSE {blocks[by, bx]:.3g}")
                verdict = ("agree within noise" if agree and plain and abs(ratio - 1.0) <= 0.01 else
                           "agree after a 3x3 median (they differ by fireflies)" if agree else "DISAGREE")
                print(f"  references {a} vs {b}: relMSE {cross:.3g} (noise alone ~{noise:.3g}), "
                      f"mean ratio {ratio:.4f}: {verdict}", flush=True)

    def scaling(self):
        """Caustic wall time against pixel count, triangle count and thread count."""
        import suite

        cfg = self.cfg
        spp = cfg["scale_spp"]
        print("== scaling", flush=True)
        scene = self.new_scene(suite.cornell)
        gltf, _ = self.export(scene, "scale-cornell")
        for side in cfg["scale_resolutions"]:
            d = self.caustic_bench(gltf, spp, (side, side), self.threads)
            self.records["scaling"].append(scaling_row("pixels", side * side, d, scene="cornell"))
        for threads in cfg["threads_list"]:
            side = cfg["resolution"][0]
            d = self.caustic_bench(gltf, spp, (side, side), threads)
            self.records["scaling"].append(scaling_row("threads", threads, d, scene="cornell"))
        for level in cfg["scale_levels"]:
            scene = self.new_scene(suite.subdivided, level)
            gltf, _ = self.export(scene, f"scale-suzanne-{level}")
            tris = self.caustic_info(gltf).get("triangles")
            d = self.caustic_bench(gltf, spp, cfg["resolution"], self.threads)
            self.records["scaling"].append(scaling_row("triangles", tris, d, scene=f"suzanne{level}"))
        for row in self.records["scaling"]:
            print(f"  {row['axis']:9s} {row['value']:>8} wall {row['wall_seconds']:.3f} s  "
                  f"render {row['render_seconds']:.3f} s  bvh {row['bvh_build_seconds'] * 1e3:.2f} ms  "
                  f"rss {row['peak_rss_mib']:.0f} MiB", flush=True)

    def photon_scaling(self):
        """Photon-count scaling: the photon integrator on the glass caustic scene.

        Runs when `caustic render --help` lists the `photon` integrator and its `--photons` flag:
        renders glass_caustic at `same_spp` spp with 1/4, 1 and 4 times the default photon counts
        (`--photons` global map, `--caustic-photons` caustic map) and records wall time, render
        time, peak memory and relMSE against the Cycles reference. Otherwise records why not.
        """
        if "photon" not in self.integrators:
            return {"status": "skipped: the binary has no photon integrator yet"}
        if not render_help_has(self.binary, "--photons"):
            return {"status": "skipped: the photon integrator has no --photons flag"}
        if "glass_caustic" not in self.scene_refs or self.scene_refs["glass_caustic"][1] is None:
            return {"status": "skipped: glass_caustic was not run"}
        gltf, ref = self.scene_refs["glass_caustic"]
        rows = []
        for scale in (0.25, 1.0, 4.0):
            photons, caustic_photons = int(200000 * scale), int(100000 * scale)
            rec = self.caustic(gltf, f"photons-{scale}", "photon", TEST_SEED, spp=self.cfg["same_spp"],
                               extra=["--photons", str(photons), "--caustic-photons", str(caustic_photons)])
            img = self.keep("glass_caustic", f"photon-scaling-{scale}", rec)
            rows.append({"photons": photons, "caustic_photons": caustic_photons,
                         "wall": rec.get("wall"), "render_seconds": rec.get("render_seconds"),
                         "peak_rss_mib": rec.get("peak_rss_mib"),
                         "relmse_vs_cycles": rel_mse(img, ref["image"]) if img is not None else None,
                         "error": rec.get("error", "")})
        return {"status": "measured (glass_caustic, photon integrator, "
                          f"{self.cfg['same_spp']} spp)", "rows": rows}


def scaling_row(axis, value, d, scene):
    return {"axis": axis, "value": value, "scene": scene, "spp": d.get("spp"),
            "resolution": d.get("resolution"), "threads": d.get("threads"),
            "wall_seconds": d.get("wall_seconds"), "render_seconds": d.get("render_seconds"),
            "bvh_build_seconds": d.get("bvh_build_seconds"), "peak_rss_mib": d.get("peak_rss_mib"),
            "rays_per_sec": d.get("rays_per_sec")}


# ----------------------------------------------------------------------------- helpers

def np_stack(chans, names):
    import numpy as np

    return np.stack([chans[n] for n in names], axis=2).astype(np.float64)


def exr_header_strings(path):
    import exr_io

    with open(path, "rb") as f:
        buf = f.read(65536)
    headers, _, _ = exr_io._read_headers(buf)
    return {k: v.decode("utf-8", "replace") for k, (t, v) in headers[0].items() if t == "string"}


def parse_clock(text):
    """Blender's 'MM:SS.ss' or 'HH:MM:SS.ss' as seconds (None when absent)."""
    if not text:
        return None
    seconds = 0.0
    for part in text.split(":"):
        seconds = seconds * 60 + float(part)
    return seconds


def last_cycles_sample(stats):
    """The highest 'Sample N/M' Cycles reported during a render (about its final sample count;
    Cycles reports 'Sample 0/M' again as it finishes, so the last one is not it)."""
    best = None
    for s in stats:
        m = re.search(r"Sample (\d+)/", s)
        if m:
            best = max(best or 0, int(m.group(1)))
    return best


def fmt(x, spec=".3g"):
    return format(x, spec) if finite(x) else "-"


def format_equal_row(row):
    parts = [f"{row['renderer']:14s} budget {row['budget']:>5}s wall {fmt(row.get('wall'), '.2f'):>6}s "
             f"spp {str(row.get('spp') or '-'):>6}"]
    for key in sorted(k for k in row if k.startswith("relmse_vs_")):
        parts.append(f"{key[len('relmse_'):]} {fmt(row[key])}")
    if row.get("error"):
        parts.append("ERROR " + row["error"])
    return "  ".join(parts)


# ----------------------------------------------------------------------------- report

def ratio_summary(records, integrators):
    """Equal-time ratios Caustic/Cycles per scene and reference (geometric mean over budgets)."""
    out = []
    rows = records["equal_time"]
    scenes = sorted({r["scene"] for r in rows}, key=[r["scene"] for r in rows].index)
    refs = ["cycles"] + [f"caustic-{i}" for i in integrators]
    for scene in scenes:
        for integ in integrators:
            r = f"caustic-{integ}"
            for ref in refs:
                key = f"relmse_debiased_vs_{ref}"
                ratios = []
                per_budget = {}
                for c in rows:
                    if c["scene"] != scene or c["renderer"] != "cycles" or key not in c:
                        continue
                    match = [x for x in rows if x["scene"] == scene and x["renderer"] == r
                             and x["budget"] == c["budget"] and key in x]
                    if not match:
                        continue
                    num, den = match[0][key], c[key]
                    # A debiased value at or below 0 means "below the reference's noise".
                    ratio = num / den if den > 0 and num > 0 else float("nan")
                    per_budget[c["budget"]] = ratio
                    if finite(ratio):
                        ratios.append(ratio)
                gm = math.exp(sum(map(math.log, ratios)) / len(ratios)) if ratios else float("nan")
                out.append({"scene": scene, "integrator": integ, "reference": ref,
                            "ratio_geomean": gm, "per_budget": per_budget})
    return out


TARGETS = [
    # (scene, which integrators, bound, text)
    ("cornell", "path", 1.0, "equal-time relMSE Caustic PT / Cycles <= 1.0 on the Cornell box"),
    ("glass_caustic", "photon", 0.1,
     "equal-time relMSE best photon integrator / Cycles <= 0.1 on the glass caustic scene"),
    ("subsurface", "best", 1.0, "equal-time relMSE Caustic / Cycles <= 1.0 on subsurface"),
]


def target_report(records, ratios, integrators):
    lines = []
    photon = [i for i in integrators if i not in ("path", "bdpt")]
    for scene, which, bound, text in TARGETS:
        cands = [r for r in ratios if r["scene"] == scene]
        if which == "path":
            cands = [r for r in cands if r["integrator"] == "path"]
        elif which == "photon":
            cands = [r for r in cands if r["integrator"] in photon]
        if not cands:
            reason = ("no photon integrator in the binary yet" if which == "photon"
                      else "scene not run")
            lines.append(f"- {text}: NOT MEASURED ({reason})")
            continue
        best = {}
        for r in cands:  # per reference, the best integrator
            if finite(r["ratio_geomean"]) and (r["reference"] not in best or
                                              r["ratio_geomean"] < best[r["reference"]]["ratio_geomean"]):
                best[r["reference"]] = r
        if not best:
            lines.append(f"- {text}: no finite ratio")
            continue
        parts = []
        worst = 0.0
        for ref, r in best.items():
            parts.append(f"{r['ratio_geomean']:.3g} vs the {ref} reference ({r['integrator']})")
            worst = max(worst, r["ratio_geomean"])
        verdict = "MET" if worst <= bound else f"MISSED by x{worst / bound:.2f}"
        cross = [r for r in records["references"] if r["scene"] == scene and r["b"]
                 and r["a"] == "cycles" and r["b"] == f"caustic-{best_integ(best)}"]
        if cross and not cross[0]["agree"]:
            verdict += (f" (but the references disagree: Caustic/Cycles mean ratio "
                        f"{1.0 / cross[0]['mean_ratio_a_over_b']:.3f}, cross relMSE "
                        f"{cross[0]['relmse_a_vs_b']:.3g} vs {cross[0]['noise_expected']:.3g} from "
                        "noise: the two renderers do not converge to the same image, so the "
                        "ratio mixes noise with bias)")
        lines.append(f"- {text}: {'; '.join(parts)} -> {verdict}")
    spp_rows = records["same_spp"]
    if spp_rows:
        agree = {r["scene"] for r in records["references"]
                 if r["b"] == "caustic-path" and r["a"] == "cycles" and r["agree"]}
        same = [r for r in spp_rows if r["scene"] in agree]
        other = [r for r in spp_rows if r["scene"] not in agree]
        parts = [f"{r['scene']} {r['wall_ratio']:.2f}" for r in same]
        if same:
            worst = max(same, key=lambda r: r["wall_ratio"])
            verdict = ("MET" if worst["wall_ratio"] <= 1.0
                       else f"MISSED by x{worst['wall_ratio']:.2f} ({worst['scene']})")
        else:
            verdict = "NOT MEASURED (no scene where both renderers make the same image)"
        line = ("- same-spp wall time Caustic PT / Cycles <= 1.0, on the scenes where both render "
                "the same image (references agree): " + (", ".join(parts) or "none") + f" -> {verdict}")
        if other:
            line += ("; not comparable (Caustic renders a different, cheaper or empty image): "
                     + ", ".join(f"{r['scene']} {r['wall_ratio']:.2f}" for r in other))
        lines.append(line)
    return lines


def binary_identity(path):
    import hashlib

    with open(path, "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()[:12]
    mtime = datetime.datetime.fromtimestamp(os.path.getmtime(path))
    return f"sha256 {digest}, built {mtime:%Y-%m-%d %H:%M}"


def verdict_text(r):
    if not r["agree"]:
        return "DISAGREE"
    plain = r["agree_plain"] and abs(r["mean_ratio_a_over_b"] - 1.0) <= 0.01
    return "agree" if plain else "agree after the median (fireflies)"


def best_integ(best):
    return next(iter(best.values()))["integrator"]


def build_table(bench, ratios, targets):
    rec = bench.records
    cfg = bench.cfg
    L = []
    L.append(f"Caustic benchmark, {bench.mode} mode, {datetime.datetime.now():%Y-%m-%d %H:%M}, "
             f"{platform.node()} ({os.cpu_count()} cores), {bench.threads} threads per render")
    L.append(f"binary {bench.binary} ({binary_identity(bench.binary)}); integrators {', '.join(bench.integrators)}; "
             f"{cfg['resolution'][0]}x{cfg['resolution'][1]} px, {cfg['bounces']} bounces, "
             f"Blackman-Harris {FILTER_SIZE} px (Caustic --filter-width {CAUSTIC_BH_WIDTH}); "
             f"lights visible to the camera; references 2 x {cfg['ref_seconds']} s per renderer")
    L.append("relMSE = mean over pixels and R,G,B of (x - ref)^2 / (ref^2 + 0.01); "
             "'deb' = minus the reference's own noise")
    L.append("")
    L.append("Scenes and Caustic's warnings")
    for name, meta in rec["scenes"].items():
        warns = meta["export_warnings"] + meta["load_warnings"] + [
            w for w in meta["render_warnings"] if w not in meta["load_warnings"]]
        extra = f" NOTE: {meta['note']}." if meta["note"] else ""
        L.append(f"  {name:14s} {meta['triangles']} triangles ({meta['emissive_triangles']} emissive); "
                 f"glTF extensions: {', '.join(meta['extensions_used']) or '-'}.{extra}")
        for w in warns:
            L.append(f"  {'':14s} WARNING: {w}")
    L.append("")
    L.append("References (2 halves each): mean, spp, own noise floor; cross-check")
    for r in rec["references"]:
        if r["b"] == "":
            L.append(f"  {r['scene']:14s} {r['reference']:14s} mean {r['mean']:.4g}  spp {r['spp'] or '-'}  "
                     f"floor {r['floor']:.3g}")
        else:
            L.append(f"  {r['scene']:14s} {r['reference']}: relMSE {r['relmse_a_vs_b']:.3g} "
                     f"(noise alone {r['noise_expected']:.3g}), mean ratio {r['mean_ratio_a_over_b']:.4f}"
                     f"; after a 3x3 median {r['relmse_median3']:.3g} (noise {r['noise_median3']:.3g}, "
                     f"mean ratio {r['mean_ratio_median3']:.4f})"
                     f" -> {verdict_text(r)}; worst {r['worst_block']}")
    L.append("")
    refs = ["cycles"] + [f"caustic-{i}" for i in bench.integrators]
    head = f"  {'scene':14s} {'renderer':14s} {'budget':>6s} {'wall':>6s} {'spp':>7s}"
    for ref in refs:
        head += f" {'vs ' + ref:>13s} {'deb':>9s}"
    L.append("Equal time: relMSE against each reference")
    L.append(head)
    for row in rec["equal_time"]:
        line = (f"  {row['scene']:14s} {row['renderer']:14s} {row['budget']:>6g} "
                f"{fmt(row.get('wall'), '.2f'):>6s} {str(row.get('spp') or '-'):>7s}")
        for ref in refs:
            line += (f" {fmt(row.get('relmse_vs_' + ref), '.4g'):>13s}"
                     f" {fmt(row.get('relmse_debiased_vs_' + ref), '.3g'):>9s}")
        if row.get("error"):
            line += "  ERROR: " + row["error"]
        L.append(line)
    L.append("")
    L.append("Equal-time ratio Caustic/Cycles of debiased relMSE (geometric mean over budgets; per budget)")
    for r in ratios:
        per = ", ".join(f"{b:g}s {fmt(v)}" for b, v in r["per_budget"].items())
        L.append(f"  {r['scene']:14s} {r['integrator']:6s} vs {r['reference']:14s} "
                 f"{fmt(r['ratio_geomean']):>8s}   ({per})")
    L.append("")
    L.append(f"Same spp ({cfg['same_spp']} spp, best of {cfg['repeats']}): wall time "
             "(Cycles: bpy render call incl. sync; Caustic: process incl. load + BVH + EXR write)")
    L.append(f"  {'scene':14s} {'cycles s':>9s} {'caustic s':>9s} {'ratio':>6s} | render phase: "
             f"{'cycles':>7s} {'caustic':>7s} {'ratio':>6s}")
    for r in rec["same_spp"]:
        L.append(f"  {r['scene']:14s} {r['cycles_wall']:9.3f} {r['caustic_wall']:9.3f} "
                 f"{r['wall_ratio']:6.2f} | {'':14s}{fmt(r.get('cycles_render_seconds'), '.2f'):>7s} "
                 f"{fmt(r.get('caustic_render_seconds'), '.2f'):>7s} {fmt(r.get('render_ratio'), '.2f'):>6s}")
    L.append("")
    L.append(f"Throughput (caustic bench --json, {cfg['bench_spp']} spp): Mrays/s by kind")
    L.append(f"  {'scene':14s} {'tris':>7s} {'total':>7s} {'camera':>7s} {'bounce':>7s} {'shadow':>7s} "
             f"{'Msamp/s':>8s} {'bvh ms':>8s} {'rss MiB':>8s}")
    for d in rec["throughput"]:
        L.append(f"  {d['scene']:14s} {str(d.get('triangles')):>7s} {d['rays_per_sec'] / 1e6:7.2f} "
                 f"{d['camera_rays_per_sec'] / 1e6:7.2f} {d['bounce_rays_per_sec'] / 1e6:7.2f} "
                 f"{d['shadow_rays_per_sec'] / 1e6:7.2f} {d['samples_per_sec'] / 1e6:8.3f} "
                 f"{d['bvh_build_seconds'] * 1e3:8.2f} {d['peak_rss_mib']:8.0f}")
    L.append("")
    if rec["scaling"]:
        L.append(f"Scaling of Caustic (caustic bench, {cfg['scale_spp']} spp), relative to the first "
                 "row of each axis")
        L.append(f"  {'axis':9s} {'value':>8s} {'wall s':>8s} {'render s':>9s} {'rel':>6s} "
                 f"{'per unit':>9s} {'Mrays/s':>8s} {'bvh ms':>8s} {'rss MiB':>8s}")
        first = {}
        for r in rec["scaling"]:
            f0 = first.setdefault(r["axis"], r)
            rel = r["render_seconds"] / f0["render_seconds"]
            per = rel / (r["value"] / f0["value"]) if r["axis"] == "pixels" else float("nan")
            if r["axis"] == "threads":
                per = (1.0 / rel) / (r["value"] / f0["value"])  # speed-up / threads; 1 = perfect
            L.append(f"  {r['axis']:9s} {str(r['value']):>8s} {r['wall_seconds']:8.3f} "
                     f"{r['render_seconds']:9.3f} {rel:6.2f} {fmt(per, '.2f'):>9s} "
                     f"{fmt((r.get('rays_per_sec') or float('nan')) / 1e6, '.2f'):>8s} "
                     f"{r['bvh_build_seconds'] * 1e3:8.2f} {r['peak_rss_mib']:8.0f}")
        L.append("  (pixels: 'per unit' = render time per pixel relative to the first row; threads: "
                 "'per unit' = parallel efficiency, 1 = perfect; render s includes the one-time "
                 "set-up inside the render phase)")
    ps = rec.get("photon_scaling", {})
    L.append(f"Photon-count scaling: {ps.get('status', '-')}")
    for r in ps.get("rows", []):
        L.append(f"  global {r['photons']:>8d} caustic {r['caustic_photons']:>8d}  wall "
                 f"{fmt(r['wall'], '.2f')} s  render {fmt(r['render_seconds'], '.2f')} s  rss "
                 f"{fmt(r['peak_rss_mib'], '.0f')} MiB  relMSE vs cycles {fmt(r['relmse_vs_cycles'])}"
                 + (f"  ERROR {r['error']}" if r["error"] else ""))
    L.append("")
    L.append("Targets (issue 10), ratios measured in this run")
    L.extend("  " + t for t in targets)
    if bench.failures:
        L.append("")
        L.append("FAILED RENDERS")
        L.extend("  " + f for f in bench.failures)
    return "\n".join(L)


def write_csv(path, rows):
    if not rows:
        return
    keys = []
    for r in rows:
        for k in r:
            if k not in keys and not isinstance(r[k], (list, dict)):
                keys.append(k)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow(r)


def json_safe(x):
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {str(k): json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_safe(v) for v in x]
    return x


def tonemap(img, scale):
    import numpy as np

    x = np.clip(img * scale, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def plots(bench, out):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker
    import numpy as np

    rows = bench.records["equal_time"]
    scenes = list(bench.records["scenes"])
    renderers = ["cycles"] + [f"caustic-{i}" for i in bench.integrators]
    refs = renderers
    fig, axes = plt.subplots(len(refs), len(scenes), figsize=(3.2 * len(scenes), 3.0 * len(refs)),
                             squeeze=False)
    for i, ref in enumerate(refs):
        for j, scene in enumerate(scenes):
            ax = axes[i][j]
            for r in renderers:
                pts = [(x["wall"], x.get(f"relmse_vs_{ref}")) for x in rows
                       if x["scene"] == scene and x["renderer"] == r and finite(x.get("wall"))
                       and finite(x.get(f"relmse_vs_{ref}")) and x[f"relmse_vs_{ref}"] > 0]
                if pts:
                    pts.sort()
                    ax.loglog(*zip(*pts), "o-", label=r)
            floor = [x["floor"] for x in bench.records["references"]
                     if x["scene"] == scene and x["reference"] == ref]
            if floor and floor[0] > 0:
                ax.axhline(floor[0], color="grey", ls=":", lw=1, label="ref. noise")
            ax.set_title(f"{scene}\nvs {ref} reference", fontsize=9)
            ax.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
            ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
            ax.set_xticks(sorted(set(bench.cfg["budgets"])))
            ax.set_xlabel("wall time [s]", fontsize=8)
            if j == 0:
                ax.set_ylabel("relMSE", fontsize=8)
            ax.tick_params(labelsize=7)
            ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "error_vs_time.png"), dpi=90)
    plt.close(fig)

    # Contact sheet: per scene, the references and the longest equal-time render of each renderer.
    top = max(bench.cfg["budgets"])
    cols = [f"ref-{r}" for r in renderers] + [f"{r}-{top}" for r in renderers]
    fig, axes = plt.subplots(len(scenes), len(cols), figsize=(2.2 * len(cols), 2.3 * len(scenes)),
                             squeeze=False)
    for i, scene in enumerate(scenes):
        ref = bench.images.get((scene, "ref-cycles"))
        lum = ref.mean(axis=2) if ref is not None else None
        scale = 0.8 / max(float(np.percentile(lum, 95)), 1e-6) if lum is not None else 1.0
        for j, col in enumerate(cols):
            ax = axes[i][j]
            img = bench.images.get((scene, col))
            if img is not None:
                ax.imshow(tonemap(img, scale), interpolation="nearest")
            else:
                ax.text(0.5, 0.5, "missing", ha="center", va="center")
            ax.set_xticks([])
            ax.set_yticks([])
            if i == 0:
                ax.set_title(col, fontsize=8)
            if j == 0:
                ax.set_ylabel(scene, fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "contact_sheet.png"), dpi=90)
    plt.close(fig)


# ----------------------------------------------------------------------------- main

def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--quick", action="store_true", help="tiny images, short times (CI)")
    group.add_argument("--full", action="store_true", help="128x128, 1-8 s budgets (~10 min)")
    parser.add_argument("--out", help="results folder (default results/<mode>-<date>)")
    parser.add_argument("--scenes", help="comma-separated subset of the suite")
    parser.add_argument("--binary", help="caustic binary (default $CAUSTIC_BINARY, "
                        "else target/release/caustic)")
    parser.add_argument("--threads", type=int, default=2, help="threads per render (default 2)")
    parser.add_argument("--resolution", help="override the mode's image size, WxH")
    parser.add_argument("--budgets", help="override the mode's time budgets, e.g. 1,2,4")
    parser.add_argument("--ref-seconds", type=float, help="override the reference time per half")
    parser.add_argument("--no-scaling", action="store_true", help="skip the scaling runs")
    parser.add_argument("--keep-work", action="store_true",
                        help="keep the temporary folder with the exported glTF scenes and logs")
    args = parser.parse_args(argv)
    mode = "full" if args.full else "quick"
    cfg = dict(MODES[mode])
    if args.resolution:
        cfg["resolution"] = tuple(int(v) for v in args.resolution.lower().split("x"))
    if args.budgets:
        cfg["budgets"] = [float(v) for v in args.budgets.split(",")]
    if args.ref_seconds:
        cfg["ref_seconds"] = args.ref_seconds
    cfg["scaling"] = not args.no_scaling
    binary = os.path.abspath(args.binary or os.environ.get("CAUSTIC_BINARY")
                             or os.path.join(REPO, "target", "release", "caustic"))
    if not os.access(binary, os.X_OK):
        print(f"bench: the caustic binary is missing: {binary}", file=sys.stderr)
        return 2
    os.environ["CAUSTIC_BINARY"] = binary
    out = os.path.abspath(args.out or os.path.join(
        REPO, "results", f"{mode}-{datetime.datetime.now():%Y%m%d-%H%M%S}"))
    os.makedirs(out, exist_ok=True)
    t_start = time.perf_counter()

    # The add-on is enabled as the test suite enables it (tests/blender/conftest.py: Blender's
    # user folders in a temporary directory, the source folder linked as a local extension).
    sys.path[:0] = [HERE, TESTS]
    import conftest  # noqa: E402  (sets BLENDER_USER_RESOURCES before importing bpy)
    import bpy  # noqa: E402
    import numpy as np  # noqa: E402,F401
    import suite  # noqa: E402

    names = args.scenes.split(",") if args.scenes else list(suite.SUITE)
    unknown = [n for n in names if n not in suite.SUITE]
    if unknown:
        print(f"bench: unknown scenes {unknown}; the suite has {list(suite.SUITE)}", file=sys.stderr)
        return 2
    bench = Bench(mode, cfg, binary, out, args.threads, names)
    bench.bpy = bpy
    bench.addon = conftest.enable_dev_addon()
    bench.integrators = caustic_integrators(binary)
    # Persistent: read_homefile (a new scene per benchmark scene) drops ordinary handlers.
    @bpy.app.handlers.persistent
    def on_render_stats(stats):
        bench._stats.append(stats)

    bpy.app.handlers.render_stats.append(on_render_stats)
    print(f"bench ({mode}): binary {binary}, integrators {bench.integrators}, results in {out}",
          flush=True)
    bench.run()

    ratios = ratio_summary(bench.records, bench.integrators)
    targets = target_report(bench.records, ratios, bench.integrators)
    table = build_table(bench, ratios, targets)
    print()
    print(table)
    with open(os.path.join(out, "table.txt"), "w") as f:
        f.write(table + "\n")
    write_csv(os.path.join(out, "equal_time.csv"), bench.records["equal_time"])
    write_csv(os.path.join(out, "references.csv"), bench.records["references"])
    write_csv(os.path.join(out, "same_spp.csv"), bench.records["same_spp"])
    write_csv(os.path.join(out, "throughput.csv"), [
        {k: v for k, v in d.items() if k != "rays"} for d in bench.records["throughput"]])
    write_csv(os.path.join(out, "scaling.csv"), bench.records["scaling"])
    images = os.path.join(out, "images")
    os.makedirs(images, exist_ok=True)
    for (scene, label), img in bench.images.items():
        if label.startswith("ref-") and label.count("-") <= 2 or label.endswith(f"-{max(cfg['budgets'])}"):
            np.save(os.path.join(images, f"{scene}--{label}.npy"), img.astype(np.float32))
    try:
        plots(bench, out)
    except Exception as err:  # noqa: BLE001  (plots are a convenience; the numbers are written)
        bench.failures.append(f"plots: {err!r}")
        print(f"bench: plots failed: {err!r}", file=sys.stderr)
    result = {"mode": mode, "config": cfg, "binary": binary,
              "binary_identity": binary_identity(binary), "integrators": bench.integrators,
              "date": datetime.datetime.now().isoformat(timespec="seconds"),
              "host": platform.node(), "cpus": os.cpu_count(), "threads": bench.threads,
              "metric": "relMSE = mean over pixels and RGB of (x-ref)^2/(ref^2+0.01)",
              "records": bench.records, "ratios": ratios, "targets": targets,
              "failures": bench.failures,
              "seconds": time.perf_counter() - t_start}
    with open(os.path.join(out, "results.json"), "w") as f:
        json.dump(json_safe(result), f, indent=1)
    if args.keep_work:
        print(f"bench: kept the exported scenes and logs in {bench.work}")
    else:
        shutil.rmtree(bench.work, ignore_errors=True)
    print(f"\nbench: {time.perf_counter() - t_start:.0f} s; results in {out}", flush=True)
    return 1 if bench.failures else 0


if __name__ == "__main__":
    sys.exit(main())
