#!/usr/bin/env bash
# Sets up and runs every test: bpy in a project-local virtual environment first (its wheel
# carries the OIDN library the denoising tests load), then the Rust suite (release build),
# the Blender add-on suite with real bpy (and the Khronos glTF validator from npm in .tools/,
# for the export-validity tests), and the render farm's tests.
# Usage: bash scripts/test.sh
set -euo pipefail
cd "$(dirname "$0")/.."

# bpy first: its wheel carries the Open Image Denoise library that tests/denoise.rs uses.
echo "== Python: bpy 5.0.1 + pytest in .venv =="
bash scripts/setup_python.sh

echo "== Rust: build and test (release) =="
cargo build --release --locked
cargo test --release --locked

echo "== Khronos glTF validator (npm gltf-validator) in .tools =="
bash scripts/setup_validator.sh

echo "== Blender add-on tests (real bpy) =="
CAUSTIC_BINARY="${CARGO_TARGET_DIR:-$PWD/target}/release/caustic" .venv/bin/python -m pytest -q tests/blender

echo "== Render farm: caustic_farm on a Dask LocalCluster (loopback) =="
CAUSTIC_BINARY="${CARGO_TARGET_DIR:-$PWD/target}/release/caustic" .venv/bin/python -m pytest -q farm/tests -p no:cacheprovider
