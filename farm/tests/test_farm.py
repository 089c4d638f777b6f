"""caustic_farm on a LocalCluster: chunks merge to the single render bit for bit, a killed
worker or a crashed process is retried and the result stays exact, a bad scene fails at
once with its code, an animation gives its frames, cancel leaves no process behind."""

import json
import os
import signal
import subprocess
import sys
import threading
import time

import psutil
import pytest
from conftest import BINARY, CORNELL, REPO

from caustic_farm import FarmError, plan_chunks, render_frames

SMALL = ["--resolution", "24x18"]


def single(tmp_path, scene, name, extra):
    """The reference: one `caustic render` of all the samples."""
    out = str(tmp_path / name)
    subprocess.run([BINARY, "render", scene, "-o", out, *extra], check=True, capture_output=True)
    with open(out, "rb") as f:
        return f.read()


def read(path):
    with open(path, "rb") as f:
        return f.read()


def test_plan_covers_every_sample_once():
    chunks = plan_chunks(2, 10, 4)
    for frame in (0, 1):
        ranges = [c.samples for c in chunks if c.frame == frame]
        assert ranges == [[0, 3], [3, 6], [6, 8], [8, 10]]
    assert [c.samples for c in plan_chunks(1, 2, 5)] == [[0, 1], [1, 2]]  # no empty chunk


@pytest.mark.parametrize("integrator", ["path", "bdpt", "photon"])
def test_merged_chunks_equal_single_render(tmp_path, client, events, integrator):
    # Jensen: the frame's map is traced once by a task and read by every chunk; it is the
    # map a single render traces from the same seed.
    extra = [*SMALL, "--integrator", integrator, "--max-depth", "5"]
    if integrator == "photon":
        extra += ["--photons", "4000", "--caustic-photons", "1000"]
    out = str(tmp_path / "farm.exr")
    result = render_frames([CORNELL], [out], spp=8, chunks=3, extra_args=extra, client=client, report=events)
    assert result.code == 0 and result.written == [out]
    assert read(out) == single(tmp_path, CORNELL, "single.exr", [*extra, "--spp", "8"])
    kinds = [e["type"] for e in events.seen]
    assert kinds.count("chunk") == 3 and kinds[-1] == "summary"


def test_photon_maps_per_chunk_are_independent(tmp_path, client, events):
    # Each chunk traces its own map (--photon-seed): the merge is a mean of independent
    # estimates, so it differs from the shared-map render, whose image is the single render's.
    extra = [*SMALL, "--integrator", "photon", "--photons", "3000", "--caustic-photons", "1000"]
    shared, own = str(tmp_path / "shared.exr"), str(tmp_path / "own.exr")
    assert render_frames([CORNELL], [shared], spp=4, chunks=2, extra_args=extra, client=client,
                         report=events).code == 0
    assert render_frames([CORNELL], [own], spp=4, chunks=2, extra_args=extra, client=client, report=events,
                         photon_maps="chunk").code == 0
    assert read(shared) == single(tmp_path, CORNELL, "single.exr", [*extra, "--spp", "4"])
    assert read(own) != read(shared)


def test_sppm_chunks_split_iterations(tmp_path, client, events):
    # SPPM chunks are independent runs of their share of the iterations (docs/contract.md).
    out = str(tmp_path / "farm.exr")
    result = render_frames([CORNELL], [out], spp=4, chunks=2, client=client, report=events,
                           extra_args=[*SMALL, "--integrator", "sppm", "--sppm-photons", "1000"])
    assert result.code == 0 and os.path.getsize(out) > 0
    assert sorted(e["samples"] for e in events.seen if e["type"] == "chunk") == [[0, 2], [2, 4]]


def test_killed_worker_is_retried_and_exact(tmp_path, client, events):
    # Each chunk sleeps 1.5 s when rendering starts (the binary's test hook), so that a
    # worker can be killed while its renderer runs.
    extra = [*SMALL, "--debug-delay", "rendering=1.5"]
    out = str(tmp_path / "farm.exr")
    worker_pids = set(client.run(os.getpid).values())
    box = {}
    thread = threading.Thread(target=lambda: box.update(r=render_frames(
        [CORNELL], [out], spp=8, chunks=4, extra_args=extra, client=client, report=events)))
    thread.start()
    victim, orphan = None, None
    deadline = time.monotonic() + 30
    while victim is None and time.monotonic() < deadline:
        for pid in worker_pids:
            try:
                kids = [k for k in psutil.Process(pid).children() if "render" in k.cmdline()]
            except psutil.NoSuchProcess:
                continue
            if kids:
                victim, orphan = pid, kids[0]
                break
        time.sleep(0.05)
    assert victim is not None, "no chunk started on a worker"
    os.kill(victim, signal.SIGKILL)
    thread.join(120)
    assert box["r"].code == 0
    assert read(out) == single(tmp_path, CORNELL, "single.exr", [*SMALL, "--spp", "8"])
    # The killed worker's renderer died with it (PR_SET_PDEATHSIG), it did not run on.
    orphan_gone = not orphan.is_running() or orphan.status() == psutil.STATUS_ZOMBIE
    assert orphan_gone


def test_internal_error_is_retried(tmp_path, client, events):
    # A binary that crashes (exit 1, the binary's "internal error") on its first render only:
    # mkdir is atomic, so of two chunks starting together exactly one crashes.
    marker = tmp_path / "crashed-once"
    fake = tmp_path / "flaky-caustic"
    fake.write_text(f"#!/bin/sh\nif [ \"$1\" = render ] && mkdir {marker} 2>/dev/null; then "
                    f"echo '{{\"type\":\"error\",\"code\":1,\"message\":\"simulated bug\"}}' >&2; exit 1; fi\n"
                    f"exec {BINARY} \"$@\"\n")
    fake.chmod(0o755)
    out = str(tmp_path / "farm.exr")
    result = render_frames([CORNELL], [out], spp=6, chunks=2, binary=str(fake), extra_args=SMALL, client=client,
                           report=events)
    assert result.code == 0 and result.retries == 1
    retry = [e for e in events.seen if e["type"] == "retry"]
    assert len(retry) == 1 and "simulated bug" in retry[0]["reason"]
    assert read(out) == single(tmp_path, CORNELL, "single.exr", [*SMALL, "--spp", "6"])


def test_bad_scene_fails_fast(tmp_path, client, events):
    bad = tmp_path / "bad.gltf"
    bad.write_text(json.dumps({"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}],
                               "nodes": [{"mesh": 0}], "meshes": [{"primitives": [{"attributes": {"POSITION": 7}}]}]}))
    t0 = time.monotonic()
    with pytest.raises(FarmError) as err:
        render_frames([str(bad)], [str(tmp_path / "o.exr")], spp=4, chunks=2, extra_args=SMALL, client=client,
                      report=events)
    assert err.value.code == 3, err.value
    assert time.monotonic() - t0 < 15
    assert not any(e["type"] == "retry" for e in events.seen)
    assert not (tmp_path / "o.exr").exists()


def test_bad_settings_fail_with_code_2(tmp_path, client, events):
    with pytest.raises(FarmError) as err:
        render_frames([CORNELL], [str(tmp_path / "o.exr")], spp=4, extra_args=[*SMALL, "--max-depth", "999999"],
                      client=client, report=events)
    assert err.value.code == 2


def test_animation_of_three_frames(tmp_path, client, events):
    doc = json.loads(read(CORNELL))
    scenes = []
    for f in range(3):
        frame = json.loads(json.dumps(doc))
        # The same .bin for every frame; the camera steps sideways.
        for node in frame["nodes"]:
            if "camera" in node:
                t = node.get("translation", [0, 0, 0])
                node["translation"] = [t[0] + 0.1 * f, t[1], t[2]]
        for b in frame["buffers"]:
            b["uri"] = os.path.join(os.path.dirname(CORNELL), b["uri"])
        path = tmp_path / f"frame{f}.gltf"
        path.write_text(json.dumps(frame))
        scenes.append(str(path))
    # The buffer must travel with a path relative to the scene: copy it beside the frames.
    for s in scenes:
        frame = json.loads(read(s))
        for b in frame["buffers"]:
            name = os.path.basename(b["uri"])
            if not (tmp_path / name).exists():
                (tmp_path / name).write_bytes(read(b["uri"]))
            b["uri"] = name
        with open(s, "w") as f:
            json.dump(frame, f)
    outs = [str(tmp_path / f"out{f}.exr") for f in range(3)]
    result = render_frames(scenes, outs, spp=4, chunks=2, extra_args=SMALL, client=client, report=events)
    assert result.code == 0 and sorted(result.written) == sorted(outs)
    start = next(e for e in events.seen if e["type"] == "start")
    assert start["files"] == 4  # three scene files and one shared buffer, each sent once
    images = [read(o) for o in outs]
    for f, s in enumerate(scenes):
        assert images[f] == single(tmp_path, s, f"single{f}.exr", [*SMALL, "--spp", "4"])
    assert images[0] != images[1] != images[2]


def test_cancel_leaves_no_process_and_a_partial_frame(tmp_path):
    out = tmp_path / "farm.exr"
    env = dict(os.environ, PYTHONPATH=os.path.join(REPO, "farm"))
    cmd = [sys.executable, "-m", "caustic_farm", CORNELL, "-o", str(out), "--spp", "100000", "--chunks", "2",
           "--workers", "2", "--", "--resolution", "32x24"]
    farm = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env, text=True)
    lines = []
    renders = []
    deadline = time.monotonic() + 60
    # Wait until both chunks' renderers run.
    while len(renders) < 2 and time.monotonic() < deadline:
        renders = [p for p in psutil.Process(farm.pid).children(recursive=True) if "render" in p.cmdline()]
        time.sleep(0.1)
    assert len(renders) == 2, "the chunks did not start"
    time.sleep(1.0)  # some samples
    family = psutil.Process(farm.pid).children(recursive=True)
    farm.send_signal(signal.SIGINT)
    stdout, _ = farm.communicate(timeout=60)
    lines = [json.loads(line) for line in stdout.splitlines() if line.startswith("{")]
    assert farm.returncode == 5, lines
    assert any(e["type"] == "frame" and e["partial"] for e in lines)
    assert out.exists()
    _, alive = psutil.wait_procs(family, timeout=10)
    assert not alive, f"left running: {[p.cmdline() for p in alive]}"
    # The partial frame is a valid image with fewer samples than asked.
    info = subprocess.run([BINARY, "merge", str(out), "-o", str(tmp_path / "x.exr")], capture_output=True, text=True)
    assert info.returncode == 2 and "not a Caustic chunk" in info.stderr


def _own_scene(tmp_path, tag):
    """A copy of the Cornell box whose glTF bytes are this test's own (a new hash), so that
    no earlier test's run has cached it."""
    folder = tmp_path / "scene"
    folder.mkdir()
    with open(CORNELL) as f:
        doc = json.load(f)
    doc["asset"]["extras"] = {"test": f"{tag} {time.time_ns()}"}
    (folder / "cornell_box.gltf").write_text(json.dumps(doc))
    with open(os.path.join(os.path.dirname(CORNELL), "cornell_box.bin"), "rb") as f:
        (folder / "cornell_box.bin").write_bytes(f.read())
    return str(folder / "cornell_box.gltf")


def test_scene_files_travel_once(tmp_path, client, events):
    # The second run finds every file in the workers' caches and sends none; the frame is
    # the same bytes.
    scene = _own_scene(tmp_path, "once")
    outs = [str(tmp_path / "a.exr"), str(tmp_path / "b.exr")]
    starts = []
    for out in outs:
        events.seen.clear()
        assert render_frames([scene], [out], spp=4, chunks=2, extra_args=SMALL, client=client,
                             report=events).code == 0
        starts.append(next(e for e in events.seen if e["type"] == "start"))
    assert starts[0]["files"] == 2 and starts[0]["files_cached"] < 2, starts[0]
    assert starts[1]["files_cached"] == 2, starts[1]
    assert read(outs[0]) == read(outs[1])


def test_file_gone_from_a_cache_is_sent_again(tmp_path, client, events):
    # A blob that every worker held when the run asked, deleted before the chunks ran (a
    # cache cleaned meanwhile): the chunks ask for it, the driver sends it, the frame is exact.
    from caustic_farm import tasks
    from caustic_farm.scene_files import sha256_file

    scene = _own_scene(tmp_path, "gone")
    first = str(tmp_path / "first.exr")
    assert render_frames([scene], [first], spp=4, chunks=2, extra_args=SMALL, client=client,
                         report=events).code == 0
    blob = os.path.join(tasks.cache_dir(), "blobs", sha256_file(scene))
    seen = []

    def report(obj):
        seen.append(obj)
        if obj["type"] == "start":
            assert obj["files_cached"] == 2
            os.remove(blob)

    again = str(tmp_path / "again.exr")
    result = render_frames([scene], [again], spp=4, chunks=2, extra_args=SMALL, client=client, report=report)
    assert result.code == 0 and result.retries == 0
    assert any(e["type"] == "resend" and e["files"] == 1 for e in seen), seen
    assert read(again) == read(first)


def test_volume_grid_files_travel(tmp_path):
    # A volume object's grid file is named by `CAUSTIC_volume.volumes[].uri` (docs/contract.md):
    # it travels with the scene like buffers and images.
    from caustic_farm.scene_files import scene_files

    (tmp_path / "caustic_volumes").mkdir()
    (tmp_path / "caustic_volumes" / "Smoke.cvol").write_bytes(b"CAUSTICV")
    scene = tmp_path / "scene.gltf"
    scene.write_text(json.dumps({"asset": {"version": "2.0"}, "extensions": {"CAUSTIC_volume": {"volumes": [
        {"name": "Smoke", "uri": "caustic_volumes/Smoke.cvol"}]}}}))
    rels = [rel for rel, _ in scene_files(str(scene))]
    assert rels == ["scene.gltf", os.path.join("caustic_volumes", "Smoke.cvol")]
