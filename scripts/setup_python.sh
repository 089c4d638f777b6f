#!/usr/bin/env bash
# Create the project's Python environment for the Blender add-on tests: .venv/ at the repository
# root with bpy 5.0.1 (Blender as a Python module, needs CPython 3.11), pytest and numpy from PyPI,
# matplotlib for the benchmark's plots (bench/run.py), and the render farm package (farm/:
# caustic_farm, editable) with Dask's distributed.
# Idempotent: an existing .venv that already has these versions is left as it is.
#
# Usage: scripts/setup_python.sh        (PYTHON=python3.11 to choose the interpreter)
set -euo pipefail

cd "$(dirname "$0")/.."
VENV=.venv
BPY_VERSION=5.0.1
PYTHON=${PYTHON:-}

if [[ -z "$PYTHON" ]]; then
    for candidate in python3.11 python3; do
        if command -v "$candidate" >/dev/null 2>&1; then
            PYTHON=$candidate
            break
        fi
    done
fi
if [[ -z "$PYTHON" ]]; then
    echo "setup_python.sh: no python3.11 found (bpy $BPY_VERSION needs CPython 3.11)" >&2
    exit 1
fi
version=$("$PYTHON" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
if [[ "$version" != "3.11" ]]; then
    echo "setup_python.sh: $PYTHON is Python $version; bpy $BPY_VERSION needs 3.11 (set PYTHON=...)" >&2
    exit 1
fi

if [[ ! -x "$VENV/bin/python" ]]; then
    "$PYTHON" -m venv "$VENV"
fi

# Already complete? (bpy's import is slow, so ask the package metadata instead.)
if "$VENV/bin/python" - "$BPY_VERSION" <<'EOF'
import sys
from importlib.metadata import PackageNotFoundError, version
try:
    ok = (version("bpy") == sys.argv[1] and version("pytest") and version("numpy")
          and version("matplotlib") and version("distributed") == "2026.8.0"
          and version("caustic-farm"))
except PackageNotFoundError:
    ok = False
sys.exit(0 if ok else 1)
EOF
then
    echo "setup_python.sh: $VENV already has bpy $BPY_VERSION, pytest, numpy, matplotlib, distributed and caustic-farm"
    exit 0
fi

"$VENV/bin/python" -m pip install --upgrade pip
"$VENV/bin/python" -m pip install "bpy==$BPY_VERSION" pytest numpy matplotlib "distributed==2026.8.0"
"$VENV/bin/python" -m pip install -e farm
echo "setup_python.sh: ready: $VENV/bin/python -m pytest tests/blender"
