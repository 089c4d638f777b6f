"""The driver: submits a run's chunks and merges to a Dask cluster, retries what a retry can
cure, fails at once on what it cannot, reports JSON lines, and cancels cleanly.

One run: every frame's scene files are hashed and scattered once (content-addressed: a file
shared by frames is one key); each chunk is a `tasks.render_chunk` task; when a frame's
chunks are in, a `tasks.merge_chunks` task adds them and the driver writes the frame
atomically. A chunk whose worker died is rescheduled by Dask itself; one whose process
failed with an internal error or crashed is resubmitted here, up to `max_attempts` times.
A bad scene or bad settings (exit 2, 3, 7) stops the whole run at once with that code.
Cancel (`cancel` set, e.g. by SIGINT): the run's Dask event tells every running chunk to
stop its renderer, which writes its samples so far; frames with any samples are merged into
valid partial images, and the result's code is 5 (6 if nothing was rendered).
"""

import hashlib
import json
import os
import sys
import threading
import time
import uuid
from dataclasses import dataclass, field

from . import tasks
from .plan import Chunk, plan_chunks
from .scene_files import SceneError, scene_files, scene_setting, scene_spp, sha256_file


class FarmError(Exception):
    """The run failed; `code` is the exit code (docs/contract.md's codes)."""

    def __init__(self, code, message):
        super().__init__(message)
        self.code = code


@dataclass
class FarmResult:
    """What a run produced: exit code (0, or 5/6 when cancelled), frames written, retries."""

    code: int
    written: list = field(default_factory=list)
    retries: int = 0
    elapsed: float = 0.0


def json_lines(stream=None):
    """A reporter printing one JSON object per line (stdout by default)."""
    def report(obj):
        print(json.dumps(obj), file=stream or sys.stdout, flush=True)
    return report


def _atomic_write(path, data):
    tmp = os.path.join(os.path.dirname(os.path.abspath(path)), f".{os.path.basename(path)}.farm-tmp-{os.getpid()}")
    with open(tmp, "wb") as f:
        f.write(data)
    os.replace(tmp, path)


def _start_client(scheduler, workers):
    """A client of the given scheduler, or of a LocalCluster on loopback only (the embedded default)."""
    from distributed import Client, LocalCluster

    if scheduler:
        return Client(scheduler), None
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address=None)
    return Client(cluster), cluster


class _SceneFiles:
    """A run's scene files by hash: what each frame needs, and for each blob either the
    future of the bytes sent to the cluster or None where every worker already held it."""

    def __init__(self, client, scenes):
        self.client = client
        self.paths = {}  # sha -> a local path with those bytes
        self.frames = []  # per frame: (scene key, scene file name, [(rel, sha)])
        for path in scenes:
            entries = [(rel, full, sha256_file(full)) for rel, full in scene_files(path)]
            for _, full, sha in entries:
                self.paths.setdefault(sha, full)
            manifest = json.dumps(sorted((rel, sha) for rel, _, sha in entries)).encode()
            key = hashlib.sha256(manifest).hexdigest()[:32]
            self.frames.append((key, entries[0][0], [(rel, sha) for rel, _, sha in entries]))
        shas = sorted(self.paths)
        held = client.run(tasks.cached_blobs, shas)
        everywhere = set(shas)
        for blobs in held.values():
            everywhere &= set(blobs)
        if not held:
            everywhere = set()
        self.futures = {sha: None for sha in everywhere}
        self.send([sha for sha in shas if sha not in everywhere])
        self.cached = len(everywhere)

    def send(self, shas):
        """Scatters the files with these hashes (each once); returns how many were sent."""
        sent = 0
        for sha in shas:
            if self.futures.get(sha) is None:
                with open(self.paths[sha], "rb") as f:
                    self.futures[sha] = self.client.scatter(f.read(), hash=False)
                sent += 1
        return sent

    def frame(self, f):
        """(scene key, scene file name, [(rel, sha, future or None)]) of frame f, for a task."""
        key, scene_rel, entries = self.frames[f]
        return key, scene_rel, [(rel, sha, self.futures[sha]) for rel, sha in entries]


# `caustic photons` takes these of the render flags; the map they make is the one a render
# with the same flags traces itself.
PHOTON_FLAGS = ("--photons", "--caustic-photons", "--max-depth", "--seed", "--memory-limit")


def flag_value(args, name):
    """The value of `name` in a flag list (`--name v` or `--name=v`; the last wins), or None."""
    value = None
    for i, a in enumerate(args):
        if a == name and i + 1 < len(args):
            value = args[i + 1]
        elif a.startswith(name + "="):
            value = a[len(name) + 1:]
    return value


def photon_args(args):
    """The render flags that `caustic photons` needs to trace the same map."""
    out = []
    for name in PHOTON_FLAGS:
        v = flag_value(args, name)
        if v is not None:
            out += [name, v]
    return out


def render_frames(scenes, outputs, *, spp=None, chunks=4, binary=None, extra_args=(), scheduler=None,
                  workers=2, client=None, max_attempts=3, report=None, cancel=None, photon_maps="frame"):
    """Renders frame i from `scenes[i]` to `outputs[i]`; returns a FarmResult or raises FarmError.

    `photon_maps` (Jensen photon mapping): "frame" traces each frame's map once and every
    chunk reads it (exact: the single render's image); "chunk" lets chunk k trace its own map
    from photon seed seed + 1 + k (independent estimates, less variance, not bit-equal)."""
    report = report or json_lines()
    cancel = cancel or threading.Event()
    t0 = time.monotonic()
    if len(scenes) != len(outputs) or not scenes:
        raise FarmError(2, "give one output per scene, and at least one scene")
    if chunks < 1:
        raise FarmError(2, f"--chunks {chunks} must be at least 1")
    if photon_maps not in ("frame", "chunk"):
        raise FarmError(2, f"photon maps per {photon_maps!r}: choose frame or chunk")
    try:
        spps = [spp or scene_spp(s, "sppm_iterations" if _integrator(extra_args, s) == "sppm" else "spp")
                or 64 for s in scenes]  # 64: the binary's default for both
    except SceneError as err:
        raise FarmError(err.code, str(err)) from None
    if any(n < 1 or n > 1 << 24 for n in spps):
        raise FarmError(2, f"--spp must be in 1..={1 << 24}")
    for out in outputs:
        folder = os.path.dirname(os.path.abspath(out))
        if not os.path.isdir(folder):
            raise FarmError(4, f"{out}: the output folder does not exist")

    own_client = client is None
    cluster = None
    if own_client:
        client, cluster = _start_client(scheduler, workers)
    cancel_name = f"caustic-farm-cancel-{uuid.uuid4().hex}"
    try:
        return _run(client, scenes, outputs, spps, chunks, binary, list(extra_args), max_attempts, report,
                    cancel, cancel_name, t0, photon_maps)
    finally:
        if own_client:
            client.close()
            if cluster is not None:
                cluster.close()


def _integrator(extra_args, scene):
    """The integrator a render of `scene` with these flags uses (flag > scene > path)."""
    return flag_value(list(extra_args), "--integrator") or scene_setting(scene, "integrator") or "path"


def _run(client, scenes, outputs, spps, chunks, binary, extra_args, max_attempts, report, cancel, cancel_name, t0,
         photon_maps):
    from distributed import Event

    try:
        files = _SceneFiles(client, scenes)
    except SceneError as err:
        raise FarmError(err.code, str(err)) from None
    plan = [Chunk(f, c.offset, c.spp) for f, n in enumerate(spps) for c in plan_chunks(1, n, chunks)]
    report({"type": "start", "frames": len(scenes), "chunks": len(plan), "files": len(files.paths),
            "files_cached": files.cached, "scheduler": client.scheduler.address})
    Event(cancel_name)  # created before any task polls it
    kinds = [_integrator(extra_args, s) for s in scenes]
    # Jensen photon mapping: each frame's map is traced once, by a task, and travels to the
    # chunks (the map a chunk would trace from the seed is the same map, so chunks stay exact).
    maps = {}

    def submit_map(f):
        key, scene_rel, frame_files = files.frame(f)
        maps[f] = client.submit(tasks.trace_photons, binary, key, scene_rel, frame_files,
                                photon_args(extra_args), cancel_name, pure=False, retries=max_attempts - 1)

    for f, kind in enumerate(kinds):
        if kind == "photon" and photon_maps == "frame" and flag_value(extra_args, "--photon-map") is None:
            submit_map(f)

    seed = int(flag_value(extra_args, "--seed") or 0)
    index_in_frame = {c: sum(1 for d in plan if d.frame == c.frame and d.offset < c.offset) for c in plan}

    def submit(chunk, attempt):
        key, scene_rel, frame_files = files.frame(chunk.frame)
        count_flag = "--sppm-iterations" if kinds[chunk.frame] == "sppm" else "--spp"
        args = extra_args
        if kinds[chunk.frame] == "photon" and photon_maps == "chunk":
            args = [*extra_args, "--photon-seed", str((seed + 1 + index_in_frame[chunk]) % (1 << 32))]
        return client.submit(tasks.render_chunk, binary, key, scene_rel, frame_files, chunk.offset, chunk.spp,
                             args, cancel_name, count_flag, maps.get(chunk.frame), pure=False,
                             key=f"render-f{chunk.frame}-s{chunk.offset}-a{attempt}-{uuid.uuid4().hex[:8]}")

    active = {submit(c, 1): (c, 1) for c in plan}
    done_chunks = {f: [] for f in range(len(scenes))}
    remaining = {f: sum(1 for c in plan if c.frame == f) for f in range(len(scenes))}
    merges = {}
    result = {"retries": 0, "written": []}
    done_count = 0
    cancelled = False

    def finish_frame(f):
        merges[client.submit(tasks.merge_chunks, binary, done_chunks[f], pure=False)] = f

    while active or merges:
        if cancel.is_set() and not cancelled:
            cancelled = True
            Event(cancel_name).set()
            report({"type": "cancelling", "elapsed": time.monotonic() - t0})
        time.sleep(0.05)
        for fut in [f for f in active if f.done()]:
            chunk, attempt = active.pop(fut)
            err = fut.exception() if fut.status == "error" else None
            if err is None and fut.status == "finished":
                res = fut.result()
                done_chunks[chunk.frame].append(fut)
                remaining[chunk.frame] -= 1
                done_count += 1
                report({"type": "chunk", "frame": chunk.frame, "samples": chunk.samples, "partial": res["partial"],
                        "worker": res["worker"], "seconds": round(res["elapsed"], 3), "done": done_count,
                        "total": len(plan), "elapsed": time.monotonic() - t0})
            elif isinstance(err, tasks.MissingFiles) and not cancelled:
                # A worker lost (or never had) files every worker held at the start: send
                # them and run the chunk again; this is not a failed attempt.
                report({"type": "resend", "frame": chunk.frame, "files": files.send(err.shas)})
                if chunk.frame in maps and maps[chunk.frame].status == "error":
                    submit_map(chunk.frame)  # the map's task met the same missing files
                active[submit(chunk, attempt)] = (chunk, attempt)
                continue
            elif isinstance(err, tasks.RenderFailed) and err.fatal:
                Event(cancel_name).set()
                raise FarmError(err.code, f"frame {chunk.frame} ({scenes[chunk.frame]}): {err}")
            elif cancelled:
                remaining[chunk.frame] -= 1
            elif attempt < max_attempts:
                result["retries"] += 1
                report({"type": "retry", "frame": chunk.frame, "samples": chunk.samples, "attempt": attempt + 1,
                        "reason": str(err) or type(err).__name__})
                active[submit(chunk, attempt + 1)] = (chunk, attempt + 1)
                continue
            else:
                Event(cancel_name).set()
                code = err.code if isinstance(err, tasks.RenderFailed) and err.code > 0 else 1
                raise FarmError(code, f"frame {chunk.frame}: samples {chunk.samples[0]}..{chunk.samples[1]} failed "
                                      f"{attempt} times: {err}")
            if remaining[chunk.frame] == 0 and done_chunks[chunk.frame]:
                finish_frame(chunk.frame)
        for fut in [f for f in merges if f.done()]:
            f = merges.pop(fut)
            if fut.status != "finished":
                Event(cancel_name).set()
                err = fut.exception()
                code = err.code if isinstance(err, tasks.RenderFailed) and err.code > 0 else 1
                raise FarmError(code, f"frame {f}: {err}")
            data = fut.result()
            if data is None:
                continue
            _atomic_write(outputs[f], data)
            result["written"].append(outputs[f])
            report({"type": "frame", "frame": f, "path": outputs[f], "partial": cancelled,
                    "elapsed": time.monotonic() - t0})
    code = 0 if not cancelled else (5 if result["written"] else 6)
    out = FarmResult(code, result["written"], result["retries"], time.monotonic() - t0)
    report({"type": "summary", "code": code, "frames": len(scenes), "written": out.written, "retries": out.retries,
            "cancelled": cancelled, "elapsed": out.elapsed})
    return out
