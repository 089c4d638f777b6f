"""Cancelling and broken binaries: Blender must come out of every one of them working.

* Twenty renders with the real binary, each cancelled at a random moment (the break is
  injected: in background mode `test_break()` is always False), with the binary's loading
  and BVH phases stretched by its hidden `--debug-delay` hook so that the moments fall in
  every phase. After each: no process of ours left running or unreaped, no temporary folder
  left, no error report; after all of them a plain render still works.
* The contract's stand-in binary crashing, being killed, printing garbage, lying about its
  image or ignoring SIGTERM: each gives a one-line report in Blender (or, for garbage around a
  good render, a good render), never a traceback.
"""

import os
import random
import subprocess
import sys
import tempfile
import time

import bpy
import pytest

import scenes

W, H = 24, 16


def module(addon, name):
    return sys.modules[f"{addon.__name__}.{name}"]


def child_processes():
    """(pid, state) of every process whose parent is this one (zombies included)."""
    me = os.getpid()
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                stat = f.read()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()
        if int(fields[1]) == me:
            found.append((int(entry), fields[0]))
    return found


@pytest.fixture
def recorded_processes(addon, monkeypatch):
    """Every Popen the runner makes, in order."""
    runner = module(addon, "runner")
    processes = []

    class RecordingPopen(subprocess.Popen):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            processes.append(self)

    monkeypatch.setattr(runner.subprocess, "Popen", RecordingPopen)
    return processes


@pytest.fixture
def temp_root(tmp_path, monkeypatch):
    """A private folder for the add-on's temporary folders, to see what it leaves behind."""
    root = tmp_path / "tmp"
    root.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(root))
    return root


def small_scene(scene, tmp_path):
    scenes.small_render_settings(scene, W, H, samples=4)
    scenes.plane_and_cube_scene(scene)
    scenes.light(scene, "Key", "AREA", location=(0.5, -0.5, 3.0), shape="RECTANGLE", size=1.5,
                 size_y=1.0, energy=200.0)
    scene.render.filepath = str(tmp_path / "out.exr")


@pytest.mark.needs_binary
def test_twenty_cancels_at_random_moments(empty_scene, addon, tmp_path, monkeypatch, recorded_processes,
                                          temp_root):
    scene = empty_scene
    small_scene(scene, tmp_path)
    scene.caustic.samples = 1000000  # never finishes by itself
    engine = module(addon, "engine")
    final = module(addon, "final")
    real_command_line = final.command_line

    def stretched(*args, **kwargs):
        # Loading and BVH take milliseconds on this scene: 0.3 s each puts random moments there too.
        return real_command_line(*args, **kwargs) + ["--debug-delay", "loading=0.3", "--debug-delay", "bvh=0.3"]

    monkeypatch.setattr(final, "command_line", stretched)
    rng = random.Random(11)  # reproducible "random" moments
    phases_hit = {}
    for i in range(20):
        delay = rng.uniform(0.0, 1.6)
        clock = {}
        phase_at_break = {}

        def should_stop(self, delay=delay, clock=clock, phase_at_break=phase_at_break):
            now = time.monotonic()
            start = clock.setdefault("start", now)  # the first poll comes right after the export
            if now - start < delay:
                return False
            session = getattr(self, "_caustic_session", None)
            phase_at_break.setdefault("phase", getattr(session, "last_phase", None) if session else "export")
            return True

        monkeypatch.setattr(engine.CausticRenderEngine, "should_stop", should_stop)
        before = len(recorded_processes)
        scene.render.filepath = str(tmp_path / f"cancel_{i}.exr")
        bpy.ops.render.render(write_still=True)  # a cancel is not an error: this must not raise
        started = recorded_processes[before:]
        for process in started:
            assert process.returncode in (5, 6), f"cancel {i} at {delay:.2f} s: exit {process.returncode}"
        assert child_processes() == [], f"cancel {i}: processes left: {child_processes()}"
        assert os.listdir(temp_root) == [], f"cancel {i}: left {os.listdir(temp_root)}"
        phase = phase_at_break.get("phase") or "before the first phase line"
        phases_hit[phase] = phases_hit.get(phase, 0) + 1
    print(f"cancel moments by phase: {phases_hit}")
    # The moments must really be spread: at least the loading/BVH phases and rendering.
    assert len(phases_hit) >= 3, phases_hit

    monkeypatch.setattr(final, "command_line", real_command_line)
    monkeypatch.setattr(engine.CausticRenderEngine, "should_stop", lambda self: self.test_break())
    scene.caustic.samples = 2
    scene.render.filepath = str(tmp_path / "after.exr")
    bpy.ops.render.render(write_still=True)
    assert scenes.load_pixels(scene.render.filepath)[..., :3].mean() > 0
    assert child_processes() == [] and os.listdir(temp_root) == []


@pytest.fixture
def fake_scene(empty_scene, fake_binary, tmp_path, temp_root):
    s = empty_scene
    scenes.small_render_settings(s, W, H, samples=4)
    scenes.camera(s, (0, -4, 3), (60, 0, 0))
    scenes.plane(s, "Floor", 4.0)
    scenes.light(s, "Sun", "SUN", energy=1.0)
    s.render.filepath = str(tmp_path / "out.exr")
    return s


@pytest.mark.parametrize("mode, message", [
    ("segfault", r"^Error: Caustic: the renderer was killed by signal 11 \(exit code -11\)"),
    ("no-image", r"^Error: Caustic: cannot read the rendered image .*out\.exr"),
    ("wrong-size", r"^Error: Caustic: the rendered image is 27x17, Blender expects 384 pixels"),
    ("crash", r"^Error: Caustic: the renderer stopped unexpectedly \(exit code 101\).*fake panic"),
])
def test_a_broken_binary_gives_a_one_line_report(fake_scene, monkeypatch, capfd, temp_root, mode, message):
    monkeypatch.setenv("FAKE_CAUSTIC_MODE", mode)
    with pytest.raises(RuntimeError, match=message) as err:
        bpy.ops.render.render(write_still=True)
    assert "\n" not in str(err.value).strip()
    captured = capfd.readouterr()
    assert "Traceback" not in captured.err + captured.out
    assert child_processes() == [] and os.listdir(temp_root) == []


def test_garbage_around_a_good_render_is_ignored(fake_scene, monkeypatch, capfd, temp_root, recorded_processes):
    """Raw bytes, cut JSON and JSON of the wrong types on both streams: the render goes on."""
    monkeypatch.setenv("FAKE_CAUSTIC_MODE", "garbage")
    bpy.ops.render.render(write_still=True)
    (process,) = recorded_processes
    assert process.returncode == 0
    img = scenes.load_pixels(fake_scene.render.filepath)
    assert img.shape[:2] == (H, W) and img[..., 0].max() > 0
    captured = capfd.readouterr()
    assert "Traceback" not in captured.err + captured.out
    assert os.listdir(temp_root) == []


def test_a_binary_that_ignores_sigterm_is_killed(fake_scene, addon, monkeypatch, capfd, temp_root,
                                                 recorded_processes):
    runner = module(addon, "runner")
    engine = module(addon, "engine")
    monkeypatch.setenv("FAKE_CAUSTIC_MODE", "ignore-term")
    monkeypatch.setattr(runner, "TERMINATE_GRACE_SECONDS", 1.0)

    def should_stop(self):
        session = getattr(self, "_caustic_session", None)
        return bool(session and session.progress_seen)

    monkeypatch.setattr(engine.CausticRenderEngine, "should_stop", should_stop)
    bpy.ops.render.render(write_still=True)  # the user cancelled: no error report
    (process,) = recorded_processes
    assert process.returncode == -9
    assert "Traceback" not in capfd.readouterr().err
    assert child_processes() == [] and os.listdir(temp_root) == []
