"""The zip from scripts/build_extension.py installs into a fresh bpy and renders with its own binary.

The install runs in a separate Python process with empty Blender user folders, so it neither sees
the development copy of the add-on enabled by conftest.py nor leaves anything behind.
"""

import json
import os
import subprocess
import sys
import zipfile

import pytest

from conftest import HERE, REPO

pytestmark = pytest.mark.needs_binary


def test_built_zip_installs_and_renders(tmp_path):
    build = subprocess.run([sys.executable, os.path.join(REPO, "scripts", "build_extension.py"),
                            os.environ["CAUSTIC_BINARY"], "--out-dir", str(tmp_path / "dist")],
                           capture_output=True, text=True, check=True)
    zip_path = build.stdout.strip().splitlines()[-1]
    with zipfile.ZipFile(zip_path) as zf:
        names = set(zf.namelist())
        manifest = zf.read("blender_manifest.toml").decode()
    assert {"blender_manifest.toml", "__init__.py", "engine.py", "bin/caustic"} <= names
    # Subpackages ship too (the exporter's hooks live in export/).
    assert {"export/__init__.py", "export/gltf_hooks.py", "export/materials.py"} <= names
    assert not any("__pycache__" in n for n in names)
    assert "platforms = [" in manifest

    env = dict(os.environ)
    env.pop("CAUSTIC_BINARY", None)
    env["BLENDER_USER_RESOURCES"] = str(tmp_path / "blender_user")
    env["PATH"] = "/usr/bin:/bin"  # no caustic on PATH: the bundled one must be found
    out = tmp_path / "render.exr"
    proc = subprocess.run([sys.executable, os.path.join(HERE, "install_and_render.py"), zip_path, str(out)],
                          capture_output=True, text=True, env=env, timeout=300)
    lines = [l for l in proc.stdout.splitlines() if l.startswith("RESULT ")]
    assert proc.returncode == 0 and lines, proc.stdout[-3000:] + proc.stderr[-3000:]
    result = json.loads(lines[-1][len("RESULT "):])
    assert result["enabled"]
    assert result["binary"].endswith(os.path.join("user_default", "caustic", "bin", "caustic"))
    assert result["shape"] == [18, 24, 4]
    assert result["mean"] > 1e-3
