"""Shared set-up for the Blender add-on tests (real bpy from the project's .venv).

* Blender's user folders go to a temporary directory (BLENDER_USER_RESOURCES, set before bpy is
  imported), so the tests never touch the developer's ~/.config/blender.
* The add-on is enabled the way Blender enables an installed extension: the source folder is
  linked into a local extension repository and enabled with
  `addon_utils.enable("bl_ext.caustic_dev.caustic", default_set=True)`, which also puts it in
  `preferences.addons`, where the glTF exporter looks for the hooks.
* CAUSTIC_BINARY defaults to target/release/caustic of this repository (an existing value wins,
  so CI can point elsewhere). Tests marked `needs_binary` *fail* when it is missing: CI builds it
  first, and a silent skip would hide a broken pipeline.
* Between tests the scene is reset with `read_homefile(use_empty=True, use_factory_startup=True)`,
  which keeps the preferences (and so the enabled add-on), unlike `read_factory_settings`.
"""

import os
import sys
import tempfile

import pytest

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
ADDON_SOURCE = os.path.join(REPO, "blender_addon")
BINARY = os.path.join(REPO, "target", "release", "caustic")
DEV_REPO_MODULE = "caustic_dev"
ADDON_MODULE = f"bl_ext.{DEV_REPO_MODULE}.caustic"
HERE = os.path.dirname(os.path.abspath(__file__))

_USER_RESOURCES = tempfile.mkdtemp(prefix="caustic-blender-user-")
os.environ["BLENDER_USER_RESOURCES"] = _USER_RESOURCES
os.environ.setdefault("CAUSTIC_BINARY", BINARY)
sys.path.insert(0, HERE)

import bpy  # noqa: E402  (after the environment above)
import addon_utils  # noqa: E402  (importable once bpy has set up its script paths)


def pytest_configure(config):
    config.addinivalue_line("markers", "needs_binary: needs target/release/caustic (fails without it)")


def pytest_runtest_setup(item):
    if item.get_closest_marker("needs_binary"):
        binary = os.environ["CAUSTIC_BINARY"]
        if not (os.path.isfile(binary) and os.access(binary, os.X_OK)):
            pytest.fail(f"the caustic binary is missing: {binary} "
                        "(build it with `cargo build --release` first)", pytrace=False)


def enable_dev_addon():
    """Link blender_addon/ into a local extension repository and enable it as Blender would."""
    prefs = bpy.context.preferences
    if ADDON_MODULE in prefs.addons:
        return sys.modules[ADDON_MODULE]
    repo_dir = os.path.join(_USER_RESOURCES, "dev_extensions")
    os.makedirs(repo_dir, exist_ok=True)
    link = os.path.join(repo_dir, "caustic")
    if not os.path.exists(link):
        os.symlink(ADDON_SOURCE, link)
    if not any(r.module == DEV_REPO_MODULE for r in prefs.extensions.repos):
        prefs.extensions.repos.new(name="Caustic Dev", module=DEV_REPO_MODULE,
                                   custom_directory=repo_dir, source="USER")
    errors = []
    module = addon_utils.enable(ADDON_MODULE, default_set=True, handle_error=errors.append)
    if module is None:
        raise RuntimeError(f"could not enable {ADDON_MODULE}: {errors}")
    return module


@pytest.fixture(scope="session")
def addon():
    """The enabled add-on package (bl_ext.caustic_dev.caustic)."""
    return enable_dev_addon()


@pytest.fixture
def empty_scene(addon):
    """A fresh empty scene with Caustic as its engine."""
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    scene = bpy.context.scene
    scene.render.engine = "CAUSTIC"
    return scene


@pytest.fixture
def fake_binary(tmp_path, monkeypatch):
    """Point CAUSTIC_BINARY at fake_caustic.py (the contract's stand-in); returns a log path."""
    wrapper = tmp_path / "caustic"
    wrapper.write_text(f'#!/bin/sh\nexec "{sys.executable}" "{os.path.join(HERE, "fake_caustic.py")}" "$@"\n')
    wrapper.chmod(0o755)
    argv_log = tmp_path / "argv.json"
    monkeypatch.setenv("CAUSTIC_BINARY", str(wrapper))
    monkeypatch.setenv("FAKE_CAUSTIC_ARGV_LOG", str(argv_log))
    return argv_log
