"""What runs on the workers: rebuild a scene's folder from content-addressed files, render
one chunk with the `caustic` binary, merge a frame's chunks.

Each function runs the binary as a child process that dies with its worker (Linux
`PR_SET_PDEATHSIG`), so a killed worker leaves no render behind, and polls the run's
cancel event so that a cancelled farm stops its renders (SIGTERM: the binary writes the
samples it has as a valid partial chunk, exit 5).
"""

import ctypes
import json
import os
import shutil
import signal
import subprocess
import tempfile
import threading
import time
import uuid

# Exit codes of the binary (docs/contract.md) that no retry can cure: bad settings, bad
# scene, over the memory budget.
FATAL_CODES = (2, 3, 7)
INTERRUPTED_PARTIAL = 5
INTERRUPTED_EMPTY = 6


class RenderFailed(Exception):
    """A chunk's or merge's process failed: `fatal` for the codes above (fail the run at
    once), else retryable (internal error, crash, I/O on the worker)."""

    def __init__(self, code, message, fatal):
        super().__init__(message)
        self.code = code
        self.fatal = fatal

    def __reduce__(self):
        return (RenderFailed, (self.code, str(self), self.fatal))


class MissingFiles(Exception):
    """This worker's cache lacks files the driver did not send because every worker held
    them when it asked (evicted since, or a worker that joined later): the driver sends
    them and submits the task again."""

    def __init__(self, shas):
        super().__init__(f"{len(shas)} scene file(s) missing from this worker's cache")
        self.shas = list(shas)

    def __reduce__(self):
        return (MissingFiles, (self.shas,))


def cache_dir():
    """This machine's cache of scene files (CAUSTIC_FARM_CACHE, else under the temp folder)."""
    return os.environ.get("CAUSTIC_FARM_CACHE") or os.path.join(tempfile.gettempdir(), "caustic-farm-cache")


def _write_atomically(path, data):
    tmp = f"{path}.tmp-{os.getpid()}-{threading.get_ident()}"
    with open(tmp, "wb") as f:
        f.write(data)
    os.replace(tmp, path)


def cached_blobs(shas):
    """The hashes among `shas` whose files this machine's cache holds (asked by the driver
    before it sends a run's files, so that a scene is sent once, not once per run)."""
    blobs = os.path.join(cache_dir(), "blobs")
    return sorted(s for s in shas if os.path.isfile(os.path.join(blobs, s)))


def materialize(scene_key, files):
    """The folder holding a scene's files on this worker: `files` is [(relative path, sha256,
    bytes or None)]; each blob is stored once per machine under its hash and linked into the
    folder. None: the driver found the blob in every worker's cache and did not send it;
    if it has gone since, MissingFiles asks the driver for it."""
    root = cache_dir()
    blobs = os.path.join(root, "blobs")
    folder = os.path.join(root, "scenes", scene_key)
    os.makedirs(blobs, exist_ok=True)
    missing = [sha for _, sha, data in files if data is None and not os.path.isfile(os.path.join(blobs, sha))]
    if missing:
        raise MissingFiles(missing)
    for rel, sha, data in files:
        blob = os.path.join(blobs, sha)
        if not os.path.exists(blob):
            _write_atomically(blob, data)
        dest = os.path.join(folder, rel)
        if not os.path.exists(dest):
            os.makedirs(os.path.dirname(dest), exist_ok=True)
            tmp = f"{dest}.tmp-{os.getpid()}-{threading.get_ident()}"
            try:
                os.link(blob, tmp)
            except OSError:
                shutil.copyfile(blob, tmp)
            os.replace(tmp, dest)
    return folder


def _die_with_parent():
    """In the child: receive SIGKILL when the worker process that started it dies."""
    libc = ctypes.CDLL("libc.so.6", use_errno=True)
    libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG


def _cancelled(cancel_name):
    """True when the run's cancel event is set (a scheduler round trip)."""
    if not cancel_name:
        return False
    from distributed import Event

    return Event(cancel_name).is_set()


def resolve_binary(binary):
    """The binary on this worker: the given path, else CAUSTIC_BINARY, else `caustic` on PATH."""
    found = binary or os.environ.get("CAUSTIC_BINARY") or shutil.which("caustic")
    if not found or not os.path.isfile(found):
        raise RenderFailed(1, f"no caustic binary on this worker ({found or 'set CAUSTIC_BINARY'})", fatal=True)
    return found


def run_binary(args, cancel_name):
    """Runs the binary with `--progress json`; returns (exit code, error message or None,
    whether cancel stopped it). Polls the cancel event twice a second."""
    proc = subprocess.Popen(args + ["--progress", "json"], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, preexec_fn=_die_with_parent)
    lines = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stderr.read().decode(errors="replace").splitlines()))
    reader.start()
    stopped = False
    last_check = 0.0
    while proc.poll() is None:
        time.sleep(0.05)
        if not stopped and time.monotonic() - last_check > 0.5:
            last_check = time.monotonic()
            if _cancelled(cancel_name):
                proc.send_signal(signal.SIGTERM)
                stopped = True
    reader.join()
    message = None
    for line in lines:
        try:
            obj = json.loads(line)
        except ValueError:
            continue
        if obj.get("type") == "error":
            message = obj.get("message")
    return proc.returncode, message, stopped


def trace_photons(binary, scene_key, scene_rel, files, photon_args, cancel_name):
    """Traces a frame's photon maps once (`caustic photons`); returns the map file's bytes,
    which then travel to the workers that render the frame's chunks."""
    binary = resolve_binary(binary)
    folder = materialize(scene_key, files)
    work = os.path.join(cache_dir(), "work")
    os.makedirs(work, exist_ok=True)
    out = os.path.join(work, f"map-{uuid.uuid4().hex}.photons")
    try:
        code, message, stopped = run_binary([binary, "photons", os.path.join(folder, scene_rel), "-o", out,
                                             *photon_args], cancel_name)
        if code == 0:
            with open(out, "rb") as f:
                return f.read()
        if stopped:
            return None
        what = message or (f"killed by signal {-code}" if code < 0 else f"exit code {code}")
        raise RenderFailed(code, f"photon maps: {what}", fatal=code in FATAL_CODES)
    finally:
        if os.path.exists(out):
            os.remove(out)


def render_chunk(binary, scene_key, scene_rel, files, offset, spp, extra_args, cancel_name, count_flag="--spp",
                 photon_map=None):
    """Renders samples [offset, offset + spp) of a scene as a chunk (`count_flag`: `--spp`, or
    `--sppm-iterations` for SPPM); with `photon_map` (the bytes of the frame's map) the
    chunk reads it instead of tracing its own. Returns {"data": EXR bytes or None,
    "partial": bool, "elapsed": s, "worker": address}."""
    t0 = time.monotonic()
    worker = _worker_address()
    if _cancelled(cancel_name):
        return {"data": None, "partial": True, "elapsed": 0.0, "worker": worker}
    binary = resolve_binary(binary)
    folder = materialize(scene_key, files)
    work = os.path.join(cache_dir(), "work")
    os.makedirs(work, exist_ok=True)
    out = os.path.join(work, f"chunk-{uuid.uuid4().hex}.exr")
    args = [binary, "render", os.path.join(folder, scene_rel), "-o", out, "--sample-offset", str(offset),
            count_flag, str(spp), "--chunk", *extra_args]
    map_path = None
    if photon_map is not None:
        map_path = f"{out}.photons"
        with open(map_path, "wb") as f:
            f.write(photon_map)
        args += ["--photon-map", map_path]
    try:
        code, message, stopped = run_binary(args, cancel_name)
        if code in (0, INTERRUPTED_PARTIAL):
            with open(out, "rb") as f:
                data = f.read()
            return {"data": data, "partial": code != 0, "elapsed": time.monotonic() - t0, "worker": worker}
        if code == INTERRUPTED_EMPTY and stopped:
            return {"data": None, "partial": True, "elapsed": time.monotonic() - t0, "worker": worker}
        what = message or (f"killed by signal {-code}" if code < 0 else f"exit code {code}")
        raise RenderFailed(code, f"samples {offset}..{offset + spp}: {what}", fatal=code in FATAL_CODES)
    finally:
        for p in (out, map_path):
            if p and os.path.exists(p):
                os.remove(p)


def merge_chunks(binary, chunks):
    """Merges chunk results (from `render_chunk`; empty ones skipped) into the output EXR's bytes."""
    binary = resolve_binary(binary)
    work = os.path.join(cache_dir(), "work", f"merge-{uuid.uuid4().hex}")
    os.makedirs(work)
    try:
        paths = []
        for i, c in enumerate(chunks):
            if c and c.get("data"):
                p = os.path.join(work, f"{i}.exr")
                with open(p, "wb") as f:
                    f.write(c["data"])
                paths.append(p)
        if not paths:
            return None
        out = os.path.join(work, "merged.exr")
        code, message, _ = run_binary([binary, "merge", *paths, "-o", out], None)
        if code != 0:
            raise RenderFailed(code, f"merge: {message or f'exit code {code}'}", fatal=code in FATAL_CODES)
        with open(out, "rb") as f:
            return f.read()
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _worker_address():
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return None
